// The planar prior's hypothesis score (ACMP-REFERENCE.md §4), maximised in the prior-assisted
// pass: S = exp(-m^2 / beta) * (gamma + exp(-dd^2 / 2 sd^2) * exp(-dtheta^2 / 2 stheta^2)).
// CPU reference: `acos_approx`, `prior_factor`, `photometric_likelihood` and `prior_score` in
// src/acmm/prior.rs, operation for operation.

const PRIOR_BIT: u32 = 131072u;

// acos by Abramowitz & Stegun 4.4.46 on a clamped argument: multiply, add and sqrt only, so
// it agrees with the CPU where a driver's acos is loose.
fn acos_approx(x: f32) -> f32 {
    let c = clamp(x, -1.0, 1.0);
    let a = abs(c);
    let p = ((((((-0.0012624911 * a + 0.00667009) * a - 0.017088126) * a + 0.03089188) * a
        - 0.050174303) * a + 0.08897899) * a - 0.2145988) * a + 1.5707963;
    let r = sqrt(1.0 - a) * p;
    if c < 0.0 {
        return 3.1415927 - r;
    }
    return r;
}

fn prior_factor(h: vec4<f32>, pp: vec4<f32>) -> f32 {
    let dd = h.w - pp.w;
    let c = h.x * pp.x + h.y * pp.y + h.z * pp.z;
    let theta = acos_approx(c);
    return problem.params.prior_gamma + exp(-(dd * dd * problem.params.prior_inv_2sd2)
        - theta * theta * problem.params.prior_inv_2sn2);
}

fn photometric_likelihood(m: f32) -> f32 {
    return exp(-(m * m) / problem.params.prior_beta);
}

fn prior_score(m: f32, h: vec4<f32>, pp: vec4<f32>) -> f32 {
    return photometric_likelihood(m) * prior_factor(h, pp);
}
