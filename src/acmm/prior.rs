//! The prior-weighted hypothesis score of ACMP and ACMMP (ACMP-REFERENCE.md §4):
//! S = exp(−m²/β)·(γ + exp(−Δd²/2σd²)·exp(−Δθ²/2σθ²)), maximised instead of the lowest cost m
//! where a pixel has a prior plane. The CPU reference of shaders/shared/prior.wgsl, read by
//! the CPU's pixel update (`cpu`) and by the planar prior's passes (`planar`).

use super::params::Params;

/// Bit of `aux`: at the prior-assisted pass's start, the pixel restarted from its prior
/// plane; after one of its updates, the prior changed the choice (the hypothesis with the
/// best prior-weighted score is not the one of lowest matching cost).
pub const PRIOR_BIT: u32 = 1 << 17;

/// The constants of the prior-weighted score for one view (σd depends on its depth range).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PriorTerms {
    /// γ
    pub gamma: f32,
    /// β
    pub beta: f32,
    /// σd in depth units.
    pub sigma_depth: f32,
    /// 1 / (2σd²)
    pub inv_two_sigma_depth2: f32,
    /// 1 / (2σθ²), σθ in radians.
    pub inv_two_sigma_normal2: f32,
}

impl PriorTerms {
    pub fn new(params: &Params, depth_min: f32, depth_max: f32) -> PriorTerms {
        let sigma_depth = params.prior_sigma_depth * (depth_max - depth_min);
        let sigma_normal = params.prior_sigma_normal.to_radians();
        PriorTerms {
            gamma: params.prior_gamma,
            beta: params.prior_beta,
            sigma_depth,
            inv_two_sigma_depth2: 1.0 / (2.0 * sigma_depth * sigma_depth),
            inv_two_sigma_normal2: 1.0 / (2.0 * sigma_normal * sigma_normal),
        }
    }
}

/// acos by Abramowitz & Stegun 4.4.46 (|error| ≤ 2e-8 rad on [0, 1]), with the argument
/// clamped to [-1, 1] (the authors' unclamped acos gave NaN for a hypothesis equal to the
/// prior). Multiply, add and sqrt only, as in shaders/shared/prior.wgsl, so the GPU agrees.
#[allow(clippy::approx_constant)] // a0 of 4.4.46 is not π/2 in f32
pub fn acos_approx(x: f32) -> f32 {
    let c = x.clamp(-1.0, 1.0);
    let a = c.abs();
    let p = ((((((-0.001_262_491_1 * a + 0.006_670_09) * a - 0.017_088_126) * a + 0.030_891_88)
        * a
        - 0.050_174_303)
        * a
        + 0.088_978_99)
        * a
        - 0.214_598_8)
        * a
        + 1.570_796_3;
    let r = (1.0 - a).sqrt() * p;
    if c < 0.0 { std::f32::consts::PI - r } else { r }
}

/// The prior factor γ + exp(−Δd²/2σd² − Δθ²/2σθ²) of a hypothesis plane (normal, depth at
/// the pixel) against the pixel's prior plane: in [γ, 1 + γ].
pub fn prior_factor(plane: [f32; 4], prior: [f32; 4], t: &PriorTerms) -> f32 {
    let dd = plane[3] - prior[3];
    let c = plane[0] * prior[0] + plane[1] * prior[1] + plane[2] * prior[2];
    let theta = acos_approx(c);
    t.gamma + (-(dd * dd * t.inv_two_sigma_depth2) - theta * theta * t.inv_two_sigma_normal2).exp()
}

/// The photometric likelihood exp(−m²/β) of an aggregated matching cost m.
pub fn photometric_likelihood(m: f32, t: &PriorTerms) -> f32 {
    (-(m * m) / t.beta).exp()
}

/// The prior-weighted score S = exp(−m²/β)·(γ + ...) (maximised).
pub fn prior_score(m: f32, plane: [f32; 4], prior: [f32; 4], t: &PriorTerms) -> f32 {
    photometric_likelihood(m, t) * prior_factor(plane, prior, t)
}

/// The prior of one pass: every pixel's prior plane and the score's constants.
#[derive(Clone, Copy, Debug)]
pub struct Prior<'a> {
    pub planes: &'a [[f32; 4]],
    pub terms: PriorTerms,
    /// Each pixel's anchor code (`prior_anchors`; src/acmm/planar.rs `anchor_plane`): a
    /// pixel with one matches with its anchors' windows too.
    pub anchors: Option<&'a [u32]>,
}
