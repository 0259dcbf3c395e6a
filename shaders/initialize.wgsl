// Starts a pass (paper Sec. 4.1): a random plane per pixel (init_random = 1), or the pixel's
// current plane re-evaluated (the start of a geometric consistency pass); its cost is the
// mean of the K best per-source costs (m, plus lambda * reprojection error in geometric
// passes). Also writes each pixel's mean reprojection error in geometric passes;
// init_random = 2 only measures that error and leaves the state alone, 3 its least value over
// the sources (the planar prior's consistency check of support points), 6 the spread of the
// reference intensities over each window (the planar prior's flat-window support points). At the start of the
// detail restorer's pass (restorer != 0) the cost of the upsampled plane is kept as C_init.
// At the start of the planar prior's prior-assisted pass (prior = 1 or 2) a pixel with a prior
// plane whose cost is at least the threshold restarts from that plane, perturbed (as
// `prior_init` in src/acmm/planar.rs).
#import rng
#import problem
#import ncc
#import geometric
#import prior

// The view weights, a layer per source: reset where a pass starts afresh.
@group(0) @binding(6) var weights_out: texture_storage_2d_array<r32float, write>;

fn clear_weights(x: u32, y: u32) {
    for (var j = 0u; j < problem.params.num_sources; j++) {
        textureStore(weights_out, vec2<u32>(x, y), j, vec4<f32>(0.0));
    }
}

// The distinct-minimum test of the anchors' strong pixels (init_random = 4; CPU reference
// `distinct_minimum` in src/acmm/planar.rs, operation for operation): the pixel's plane
// moved along its ray in one-pixel steps of its most important source's epipolar line,
// +-DISTINCT_STEPS steps, matched against that source. Its depth is distinct when the lowest
// cost is within 2 steps of it, at most DISTINCT_MAX_COST, and no other local minimum more
// than 2 steps away comes within DISTINCT_GAP of it (APD-MVS's weak-texture test). A
// smooth-shading ramp matches itself at every shift: no distinct minimum.
const DISTINCT_STEPS: i32 = 30;
const DISTINCT_MAX_COST: f32 = 0.5;
const DISTINCT_GAP: f32 = 0.2;
const AMBIGUOUS_ERROR: f32 = 1e30;

fn source_pixel(j: u32, p: vec3<f32>) -> vec3<f32> {
    let src = problem.sources[j];
    let ps = vec3<f32>(dot(src.r0.xyz, p) + src.t.x, dot(src.r1.xyz, p) + src.t.y,
        dot(src.r2.xyz, p) + src.t.z);
    let ks = src.k;
    return vec3<f32>(ks.x * ps.x / ps.z + ks.z, ks.y * ps.y / ps.z + ks.w, ps.z);
}

fn distinct_minimum(i: u32, x: u32, y: u32, hyp: vec4<f32>) -> bool {
    let nsrc = problem.params.num_sources;
    if nsrc == 0u || !(hyp.w > 0.0) {
        return false;
    }
    var j = (aux[i] >> 8u) & 0xffu;
    if j >= nsrc {
        j = 0u;
    }
    let r = ref_ray(f32(x), f32(y));
    let d = hyp.w;
    let a = source_pixel(j, r * d);
    let b = source_pixel(j, r * (d * 1.001));
    if a.z <= 0.0 || b.z <= 0.0 {
        return false;
    }
    let du = length(b.xy - a.xy) / (d * 0.001);
    if !(du > 0.0) {
        return false;
    }
    load_ref_patch(x, y);
    var costs: array<f32, 61>;
    var best = 0u;
    for (var k = 0u; k < 61u; k++) {
        let dk = d + f32(i32(k) - DISTINCT_STEPS) / du;
        var c = MAX_COST;
        if dk >= problem.params.depth_min && dk <= problem.params.depth_max {
            c = ncc_cost(j, vec4<f32>(hyp.xyz, dk));
        }
        costs[k] = c;
        if c < costs[best] {
            best = k;
        }
    }
    let cb = costs[best];
    if abs(i32(best) - DISTINCT_STEPS) > 2 || cb > DISTINCT_MAX_COST {
        return false;
    }
    for (var k = 0u; k < 61u; k++) {
        if abs(i32(k) - i32(best)) <= 2 {
            continue;
        }
        let left = k == 0u || costs[k] <= costs[k - 1u];
        let right = k == 60u || costs[k] <= costs[k + 1u];
        if left && right && costs[k] < cb + DISTINCT_GAP {
            return false;
        }
    }
    return true;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if x >= problem.params.width || y >= problem.params.height {
        return;
    }
    let i = y * problem.params.width + x;
    let n = problem.params.width * problem.params.height;
    var hyp = load_plane(i);
    if problem.params.init_random == 2u {
        var err = 0.0;
        for (var j = 0u; j < problem.params.num_sources; j++) {
            err += reprojection_error(j, hyp, x, y);
        }
        extra[n + i] = err / f32(max(problem.params.num_sources, 1u));
        return;
    }
    if problem.params.init_random == 3u {
        // The smallest error over the sources (delta when there is none): the planar prior's
        // multi-view check of support points.
        var least = problem.params.delta;
        for (var j = 0u; j < problem.params.num_sources; j++) {
            least = min(least, reprojection_error(j, hyp, x, y));
        }
        extra[n + i] = least;
        return;
    }
    if problem.params.init_random == 4u {
        // Consistent pixels whose depth is not a distinct minimum are not strong.
        if !distinct_minimum(i, x, y, hyp) {
            extra[n + i] = AMBIGUOUS_ERROR;
        }
        return;
    }
    if problem.params.init_random == 5u {
        // Pixels fewer than anchor_views sources agree with are not strong.
        var agree = 0u;
        for (var j = 0u; j < problem.params.num_sources; j++) {
            if reprojection_error(j, hyp, x, y) < problem.params.anchor_limit {
                agree += 1u;
            }
        }
        if agree < problem.params.anchor_views {
            extra[n + i] = AMBIGUOUS_ERROR;
        }
        return;
    }
    if problem.params.init_random == 7u {
        // The support points' confirmation key (`rank_confirmed` in src/acmm/planar.rs):
        // a consistent pixel's least error becomes (sources - confirming) x scale, below
        // the limit and lower the more sources confirm it (reprojection and depth); the
        // scale is a power of two below the limit.
        if !(extra[n + i] < problem.params.anchor_limit) {
            return;
        }
        let sources = problem.params.num_sources;
        let scale = ldexp(problem.params.anchor_limit, -i32(32u - countLeadingZeros(sources)));
        if problem.params.confirm_score != 0u {
            // (sources - confidence) x scale: cost + key / scale ranks as HPM-MVS++'s
            // support score, cost - confidence (`prior_confidence_score`).
            var conf = 0.0;
            for (var j = 0u; j < sources; j++) {
                conf += source_confidence(j, hyp, x, y, problem.params.anchor_limit);
            }
            extra[n + i] = (f32(sources) - conf) * scale;
            return;
        }
        var agree = 0u;
        for (var j = 0u; j < problem.params.num_sources; j++) {
            if source_confirms(j, hyp, x, y, problem.params.anchor_limit) {
                agree += 1u;
            }
        }
        extra[n + i] = f32(sources - min(agree, sources)) * scale;
        return;
    }
    if problem.params.init_random == 6u && (problem.params.flat_ramp & 2u) != 0u {
        // The spread of the matching window's samples under their bilateral weights
        // (`weighted_window_spread` in src/acmm/planar.rs, operation for operation): the
        // window as the cost weighs it. Around the weighted least-squares ramp with bit 0.
        load_ref_patch(x, y);
        let n = patch_per_axis;
        // Two passes: the weighted means, then the moments about them (a window whose weight
        // sits on a few samples leaves no cancellation to the second).
        var wsum = 0.0;
        var sum = 0.0;
        var sx = 0.0;
        var sy = 0.0;
        for (var k = 0u; k < n * n; k++) {
            let wk = patch_weights[k];
            wsum += wk;
            sum += wk * patch_values[k];
            sx += wk * (patch_xs[k % n] - f32(x));
            sy += wk * (patch_ys[k / n] - f32(y));
        }
        let m = sum / wsum;
        let mx = sx / wsum;
        let my = sy / wsum;
        var vv = 0.0;
        var cxx = 0.0;
        var cyy = 0.0;
        var cxy = 0.0;
        var cvx = 0.0;
        var cvy = 0.0;
        for (var k = 0u; k < n * n; k++) {
            let wk = patch_weights[k];
            let v = patch_values[k] - m;
            let dx = patch_xs[k % n] - f32(x) - mx;
            let dy = patch_ys[k / n] - f32(y) - my;
            vv += wk * v * v;
            cxx += wk * dx * dx;
            cyy += wk * dy * dy;
            cxy += wk * dx * dy;
            cvx += wk * v * dx;
            cvy += wk * v * dy;
        }
        var var_v = vv / wsum;
        if (problem.params.flat_ramp & 1u) != 0u {
            let axx = cxx / wsum;
            let ayy = cyy / wsum;
            let axy = cxy / wsum;
            let avx = cvx / wsum;
            let avy = cvy / wsum;
            // A ramp is taken out only where the weighted offsets span both axes (the
            // determinant not lost to rounding against its terms).
            let det = axx * ayy - axy * axy;
            if det > 1e-4 * axx * ayy {
                var_v -= (ayy * avx * avx - 2.0 * axy * avx * avy + axx * avy * avy) / det;
            }
        }
        extra[i] = sqrt(max(var_v - problem.params.flat_noise_var, 0.0));
        return;
    }
    if problem.params.init_random == 6u {
        // The spread of the reference intensities over the whole window, clipped at the
        // border (`window_spread` in src/acmm/planar.rs, operation for operation), into the
        // first extra map: the planar prior's flat-window support points read it. With
        // flat_ramp, the spread around the window's least-squares plane in (dx, dy).
        let w = i32(problem.params.width);
        let h = i32(problem.params.height);
        let r = window_radius();
        let centre = textureLoad(layers, vec2<u32>(x, y), problem.params.ref_layer, 0).x;
        var count = 0.0;
        var sum = 0.0;
        var sum_sq = 0.0;
        var sx = 0.0;
        var sy = 0.0;
        var sxx = 0.0;
        var syy = 0.0;
        var sxy = 0.0;
        var svx = 0.0;
        var svy = 0.0;
        for (var yy = max(i32(y) - r, 0); yy < min(i32(y) + r + 1, h); yy++) {
            for (var xx = max(i32(x) - r, 0); xx < min(i32(x) + r + 1, w); xx++) {
                let v = textureLoad(layers, vec2<i32>(xx, yy), problem.params.ref_layer, 0).x - centre;
                let dx = f32(xx - i32(x));
                let dy = f32(yy - i32(y));
                count += 1.0;
                sum += v;
                sum_sq += v * v;
                sx += dx;
                sy += dy;
                sxx += dx * dx;
                syy += dy * dy;
                sxy += dx * dy;
                svx += v * dx;
                svy += v * dy;
            }
        }
        let m = sum / count;
        var var_v = sum_sq / count - m * m;
        if (problem.params.flat_ramp & 1u) != 0u {
            let mx = sx / count;
            let my = sy / count;
            let cxx = sxx / count - mx * mx;
            let cyy = syy / count - my * my;
            let cxy = sxy / count - mx * my;
            let cvx = svx / count - m * mx;
            let cvy = svy / count - m * my;
            let det = cxx * cyy - cxy * cxy;
            if det > 0.0 {
                var_v -= (cyy * cvx * cvx - 2.0 * cxy * cvx * cvy + cxx * cvy * cvy) / det;
            }
        }
        extra[i] = sqrt(max(var_v - problem.params.flat_noise_var, 0.0));
        return;
    }
    if problem.params.init_random == 1u {
        var s = pixel_stream(x, y);
        let d = random_depth(&s);
        let u1 = stream_next(&s);
        let u2 = stream_next(&s);
        hyp = vec4<f32>(random_normal(u1, u2, ref_ray(f32(x), f32(y))), d);
    }
    var restarted = false;
    // Only the prior-assisted pass restarts (prior 1 or 2; 3, a geometric pass the prior
    // holds in, starts from the planes it has).
    if problem.params.prior == 1u || problem.params.prior == 2u {
        let pp = load_prior(i);
        if pp.w > 0.0 && cost[i] >= problem.params.prior_threshold {
            restarted = true;
            var s = pixel_stream(x, y);
            let d = clamp(pp.w * (1.0 + (2.0 * stream_next(&s) - 1.0) * problem.params.prior_init_depth),
                problem.params.depth_min, problem.params.depth_max);
            let u1 = stream_next(&s);
            let u2 = stream_next(&s);
            hyp = vec4<f32>(perturb_normal(pp.xyz, u1, u2, problem.params.prior_init_normal_tan,
                ref_ray(f32(x), f32(y))), d);
        }
    }
    load_ref_patch(x, y);
    var top = topk_new();
    let top_k = problem.params.top_k;
    // The K lowest costs as a bitmask, lower index first on ties (as src/acmm/cpu.rs).
    var costs: array<f32, 32>;
    var err_sum = 0.0;
    for (var j = 0u; j < problem.params.num_sources; j++) {
        let m = ncc_cost(j, hyp);
        let c = combined_cost(m, j, hyp, x, y);
        if problem.params.geometric == 1u {
            err_sum += reprojection_error(j, hyp, x, y);
        }
        costs[j] = c;
        topk_insert(&top, c, top_k);
    }
    var mask = 0u;
    for (var m = 0u; m < min(problem.params.top_k, problem.params.num_sources); m++) {
        var best = 32u;
        for (var j = 0u; j < problem.params.num_sources; j++) {
            if (mask & (1u << j)) == 0u && (best == 32u || costs[j] < costs[best]) {
                best = j;
            }
        }
        mask |= 1u << best;
    }
    store_plane(i, hyp);
    cost[i] = topk_mean(&top);
    store_selected(i, mask);
    if problem.params.geometric == 1u {
        extra[n + i] = err_sum / f32(max(problem.params.num_sources, 1u));
    }
    if problem.params.restorer != 0u {
        // The detail restorer's C_init: the upsampled plane's cost at this scale; no
        // photometric cost found yet.
        extra[i] = cost[i];
        extra[n + i] = MAX_COST;
    }
    if problem.params.prior == 1u || problem.params.prior == 2u {
        // Weights and v_t start afresh; the restarted pixels are marked.
        aux[i] = select(WINNER_KEPT, WINNER_INITIAL | PRIOR_BIT, restarted) | (NO_VIEW << 8u);
        clear_weights(x, y);
    }
    if problem.params.init_random == 1u || problem.params.restorer != 0u {
        aux[i] = WINNER_INITIAL | (NO_VIEW << 8u);
        clear_weights(x, y);
    }
}
