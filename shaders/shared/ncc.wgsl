// Bilateral weighted NCC between a reference window and its plane-induced homography warp
// into a source, and the top-K mean of per-source costs (CPU reference: src/acmm/cpu/ncc.rs,
// `ref_patch`, `homography`, `ncc_cost`, `TopK`).

const MAX_SAMPLES: u32 = 64u;

// The window as pipeline constants: a pipeline made for one window (`AcmhPipelines::for_window`
// in src/gpu/acmh/pipelines.rs) has constant loop bounds, so a driver can unroll the window's loops
// and keep it in registers. WINDOW_RADIUS 0 (the default): read the window from `params`.
override WINDOW_RADIUS: u32 = 0u;
override WINDOW_STEP: u32 = 1u;

fn window_radius() -> i32 {
    return select(i32(problem.params.window_radius), i32(WINDOW_RADIUS), WINDOW_RADIUS > 0u);
}

fn window_step() -> i32 {
    return select(i32(max(problem.params.window_step, 1u)), i32(max(WINDOW_STEP, 1u)), WINDOW_RADIUS > 0u);
}

// Samples along each axis of the window (load_ref_patch stores as many columns and rows).
fn window_per_axis() -> u32 {
    if WINDOW_RADIUS > 0u {
        return 2u * WINDOW_RADIUS / max(WINDOW_STEP, 1u) + 1u;
    }
    return patch_per_axis;
}

// The reference window of the pixel being processed (one invocation, one pixel). Its
// columns and rows clamped to the image (sample i at column i % n, row i / n), the
// intensities minus the centre's, and the bilateral weights.
var<private> patch_xs: array<f32, 8>;
var<private> patch_ys: array<f32, 8>;
var<private> patch_values: array<f32, 64>;
var<private> patch_weights: array<f32, 64>;
var<private> patch_per_axis: u32;
var<private> patch_weight_sum: f32;
var<private> patch_mean: f32;
var<private> patch_variance: f32;
var<private> patch_centre: vec2<f32>;
// The sample the source side is shifted by: the first with the Laplacian weight, the
// heaviest (weight 1) with the Gaussian forms (`RefPatch::heaviest`).
var<private> patch_heaviest: u32;

// The Gaussian weight's spatial exponent; a sample's exponent adds |dI|^2 / c, c from
// `color_scale`, and a window's weights are exp(least - exponent), relative to its heaviest
// sample (`spatial_exponent` and `ref_patch_with` in src/acmm/cpu/ncc.rs).
fn spatial_exponent(dx: f32, dy: f32) -> f32 {
    let ss = 2.0 * problem.params.sigma_spatial * problem.params.sigma_spatial;
    return (dx * dx + dy * dy) / ss;
}

// 2 sigma_c^2 of a Gaussian window's colour term: sigma_color, or with the adaptive kernel
// (2) the robust standard deviation of the window's differences from its centre, 1.4826 x
// the lower median of |values[0..n]| found by counting, never below sigma_color
// (`color_scale` and `abs_median` in src/acmm/cpu/ncc.rs).
fn color_scale(values: ptr<function, array<f32, 64>>, n: u32) -> f32 {
    var sigma = problem.params.sigma_color;
    if problem.params.kernel == 2u {
        let k = (max(n, 1u) - 1u) / 2u;
        var median = 0.0;
        for (var i = 0u; i < n; i++) {
            let a = abs((*values)[i]);
            var less = 0u;
            var leq = 0u;
            for (var j = 0u; j < n; j++) {
                let b = abs((*values)[j]);
                less += select(0u, 1u, b < a);
                leq += select(0u, 1u, b <= a);
            }
            if less <= k && k < leq {
                median = a;
                break;
            }
        }
        sigma = max(sigma, 1.4826 * median);
    }
    return 2.0 * sigma * sigma;
}

// The unsquared (authors') weight; the Gaussian forms are weighed by the window.
fn bilateral_weight(dx: f32, dy: f32, dc: f32) -> f32 {
    let ss = 2.0 * problem.params.sigma_spatial * problem.params.sigma_spatial;
    let sc = 2.0 * problem.params.sigma_color * problem.params.sigma_color;
    return exp(-sqrt(dx * dx + dy * dy) / ss - abs(dc) / sc);
}

fn load_ref_patch(x: u32, y: u32) {
    let w = i32(problem.params.width);
    let h = i32(problem.params.height);
    let centre = textureLoad(layers, vec2<u32>(x, y), problem.params.ref_layer, 0).x;
    let r = window_radius();
    let step = window_step();
    var a = 0u;
    for (var d = -r; d <= r; d += step) {
        patch_xs[a] = f32(clamp(i32(x) + d, 0, w - 1));
        patch_ys[a] = f32(clamp(i32(y) + d, 0, h - 1));
        a += 1u;
    }
    patch_per_axis = a;
    var n = 0u;
    var wsum = 0.0;
    var s = 0.0;
    var ss = 0.0;
    let gaussian = problem.params.kernel != 0u;
    patch_heaviest = 0u;
    for (var dy = -r; dy <= r; dy += step) {
        for (var dx = -r; dx <= r; dx += step) {
            let sx = clamp(i32(x) + dx, 0, w - 1);
            let sy = clamp(i32(y) + dy, 0, h - 1);
            let v = textureLoad(layers, vec2<i32>(sx, sy), problem.params.ref_layer, 0).x - centre;
            patch_values[n] = v;
            if gaussian {
                // The spatial exponent for now; the colour term and the weights follow.
                patch_weights[n] = spatial_exponent(f32(dx), f32(dy));
                n += 1u;
                continue;
            }
            let wk = bilateral_weight(f32(dx), f32(dy), v);
            patch_weights[n] = wk;
            wsum += wk;
            s += wk * v;
            ss += wk * v * v;
            n += 1u;
        }
    }
    if gaussian {
        var values = patch_values;
        let sc = color_scale(&values, n);
        var least = 3.4e38;
        for (var k = 0u; k < n; k++) {
            let v = patch_values[k];
            let e = patch_weights[k] + v * v / sc;
            patch_weights[k] = e;
            if e < least {
                least = e;
                patch_heaviest = k;
            }
        }
        for (var k = 0u; k < n; k++) {
            let wk = exp(least - patch_weights[k]);
            let v = patch_values[k];
            patch_weights[k] = wk;
            wsum += wk;
            s += wk * v;
            ss += wk * v * v;
        }
    }
    patch_weight_sum = wsum;
    patch_mean = s / wsum;
    patch_variance = ss / wsum - patch_mean * patch_mean;
    patch_centre = vec2<f32>(f32(x), f32(y));
}

// Bilinear sample of source `src` at continuous pixel coordinates (centres on integers),
// clamped to its border; as `bilinear` in src/acmm/cpu.rs, bit for bit. The four taps are one
// textureGather around the corner shared by texels (cx, cy) and (cx + 1, cy + 1): that point
// is half a texel from every texel boundary, so any GPU's fixed-point texel addressing picks
// exactly those four. Along an axis where the sample lies outside the view's inner cells
// both taps are the border texel: its weight on the second tap is 0 (a + (b - a) * 0 = a),
// so whatever the second tap reads (the next texel, or the layer's padding past a smaller
// view) cannot matter.
fn bilinear(src: Source, u: f32, v: f32) -> f32 {
    let w = i32(src.size.x);
    let h = i32(src.size.y);
    let x0 = floor(u);
    let y0 = floor(v);
    let ix = i32(x0);
    let iy = i32(y0);
    let fx = select(u - x0, 0.0, ix < 0 || ix >= w - 1);
    let fy = select(v - y0, 0.0, iy < 0 || iy >= h - 1);
    let cx = clamp(ix, 0, w - 1);
    let cy = clamp(iy, 0, h - 1);
    let corner = vec2<f32>(f32(cx) + 1.0, f32(cy) + 1.0) / vec2<f32>(textureDimensions(layers));
    // Gather order: (cx, cy+1), (cx+1, cy+1), (cx+1, cy), (cx, cy).
    let g = textureGather(0, layers, layer_sampler, corner, src.size.w);
    let a = g.w;
    let b = g.z;
    let c = g.x;
    let d = g.y;
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}

// The homography of plane `hyp` (its depth at pixel `centre`) into source j, as columns
// (c0 u + c1 v + c2), and g with g . (u, v, 1) < 0 where the plane is in front of the
// reference camera; `ok` false when the plane faces away, the warped centre lands behind
// the source or off it.
struct Warp {
    c0: vec3<f32>,
    c1: vec3<f32>,
    c2: vec3<f32>,
    g: vec3<f32>,
    ok: bool,
}

fn plane_warp(j: u32, hyp: vec4<f32>, centre: vec2<f32>) -> Warp {
    var out = Warp(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), false);
    let src = problem.sources[j];
    let k = problem.params.k;
    let n = hyp.xyz;
    let c = hyp.w * dot(n, ref_ray(centre.x, centre.y));
    if c >= 0.0 {
        return out;
    }
    // A = R + t n^T / c; H = K_s A K_r^-1.
    let a0 = src.r0.xyz + src.t.x * n / c;
    let a1 = src.r1.xyz + src.t.y * n / c;
    let a2 = src.r2.xyz + src.t.z * n / c;
    let ak0 = vec3<f32>(a0.x / k.x, a0.y / k.y, a0.z - a0.x * k.z / k.x - a0.y * k.w / k.y);
    let ak1 = vec3<f32>(a1.x / k.x, a1.y / k.y, a1.z - a1.x * k.z / k.x - a1.y * k.w / k.y);
    let ak2 = vec3<f32>(a2.x / k.x, a2.y / k.y, a2.z - a2.x * k.z / k.x - a2.y * k.w / k.y);
    let ks = src.k;
    let h0 = ks.x * ak0 + ks.z * ak2;
    let h1 = ks.y * ak1 + ks.w * ak2;
    let h2 = ak2;
    let g = vec3<f32>(n.x / k.x, n.y / k.y, n.z - n.x * k.z / k.x - n.y * k.w / k.y);

    let pc = vec3<f32>(centre, 1.0);
    let wc = vec3<f32>(dot(h0, pc), dot(h1, pc), dot(h2, pc));
    if wc.z <= 0.0 {
        return out;
    }
    let cu = wc.x / wc.z;
    let cv = wc.y / wc.z;
    let sw = f32(src.size.x);
    let sh = f32(src.size.y);
    if !(cu >= -0.5 && cv >= -0.5 && cu < sw - 0.5 && cv < sh - 0.5) {
        return out;
    }
    out.c0 = vec3<f32>(h0.x, h1.x, h2.x);
    out.c1 = vec3<f32>(h0.y, h1.y, h2.y);
    out.c2 = vec3<f32>(h0.z, h1.z, h2.z);
    out.g = g;
    out.ok = true;
    return out;
}

// 1 - NCC in [0, 2] of plane `hyp` (normal xyz, depth w) at the patch's pixel against
// source j; MAX_COST when the warp leaves the source, the plane is behind either camera,
// or either patch is flat.
fn ncc_cost(j: u32, hyp: vec4<f32>) -> f32 {
    let src = problem.sources[j];
    let warp = plane_warp(j, hyp, patch_centre);
    if !warp.ok {
        return MAX_COST;
    }
    let g = warp.g;
    var s = 0.0;
    var ss = 0.0;
    var rs = 0.0;
    var shift = 0.0;
    // The homography stepped along the window: a row's part (its v and the constant column)
    // once per row, then one multiply-add per coordinate and sample (8 operations, where
    // H q and g . q took 20), and the window's coordinates as 2 x 8 floats instead of 64
    // pairs. The same operations in the same order as `ncc_cost` in src/acmm/cpu.rs. One
    // loop over the samples: as two nested loops llvmpipe ran the matching 10% slower.
    let c0 = warp.c0;
    let c1 = warp.c1;
    let c2 = warp.c2;
    let n_axis = window_per_axis();
    let samples = n_axis * n_axis;
    if patch_heaviest > 0u {
        // Shifted by the heaviest sample's value (the Gaussian weight; `ncc_cost` in
        // src/acmm/cpu/ncc.rs): the sample computed as the loop below computes it.
        let qx = patch_xs[patch_heaviest % n_axis];
        let qy = patch_ys[patch_heaviest / n_axis];
        let p = c0 * qx + (c1 * qy + c2);
        if g.x * qx + (g.y * qy + g.z) >= 0.0 || p.z <= 0.0 {
            return MAX_COST;
        }
        shift = bilinear(src, p.x / p.z, p.y / p.z);
    }
    var ix = 0u;
    var iy = 0u;
    var row = c2;
    var g_row = g.z;
    for (var i = 0u; i < samples; i++) {
        if ix == 0u {
            let qy = patch_ys[iy];
            row = c1 * qy + c2;
            g_row = g.y * qy + g.z;
        }
        let qx = patch_xs[ix];
        let p = c0 * qx + row;
        if g.x * qx + g_row >= 0.0 || p.z <= 0.0 {
            return MAX_COST;
        }
        let value = bilinear(src, p.x / p.z, p.y / p.z);
        if i == 0u && patch_heaviest == 0u {
            shift = value;
        }
        let v = value - shift;
        let wk = patch_weights[i];
        s += wk * v;
        ss += wk * v * v;
        rs += wk * patch_values[i] * v;
        ix += 1u;
        if ix == n_axis {
            ix = 0u;
            iy += 1u;
        }
    }
    let mean = s / patch_weight_sum;
    let variance = ss / patch_weight_sum - mean * mean;
    if patch_variance < MIN_VARIANCE || variance < MIN_VARIANCE {
        return MAX_COST;
    }
    let covariance = rs / patch_weight_sum - patch_mean * mean;
    let ncc = covariance / sqrt(patch_variance * variance);
    return clamp(1.0 - ncc, 0.0, MAX_COST);
}

// Anchors of the pixel being processed (`prior_anchors`, in the prior-assisted pass): their
// pixels, set per invocation by `load_anchors`; none elsewhere.
var<private> anchor_px: array<vec2<u32>, 8>;
var<private> anchor_n: u32;

// The 3 x 3 window of an anchor at q, samples `window_radius` apart (`anchor_offsets` and
// `ref_patch_with` in src/acmm/cpu/ncc.rs), matched under plane `hyp` (its depth at q) against
// source j: the same NCC as `ncc_cost`, its reference side computed here.
fn anchor_ncc(j: u32, hyp: vec4<f32>, q: vec2<u32>) -> f32 {
    let src = problem.sources[j];
    let w = i32(problem.params.width);
    let h = i32(problem.params.height);
    let r = i32(problem.params.window_radius);
    let centre = textureLoad(layers, q, problem.params.ref_layer, 0).x;
    var values: array<f32, 64>;
    var weights: array<f32, 9>;
    var wsum = 0.0;
    var rsum = 0.0;
    var rss = 0.0;
    var n = 0u;
    let gaussian = problem.params.kernel != 0u;
    var heaviest = 0u;
    for (var dy = -r; dy <= r; dy += r) {
        for (var dx = -r; dx <= r; dx += r) {
            let sx = clamp(i32(q.x) + dx, 0, w - 1);
            let sy = clamp(i32(q.y) + dy, 0, h - 1);
            let v = textureLoad(layers, vec2<i32>(sx, sy), problem.params.ref_layer, 0).x - centre;
            values[n] = v;
            if gaussian {
                weights[n] = spatial_exponent(f32(dx), f32(dy));
                n += 1u;
                continue;
            }
            let wk = bilateral_weight(f32(dx), f32(dy), v);
            weights[n] = wk;
            wsum += wk;
            rsum += wk * v;
            rss += wk * v * v;
            n += 1u;
        }
    }
    if gaussian {
        let sc = color_scale(&values, n);
        var least = 3.4e38;
        for (var k = 0u; k < n; k++) {
            let e = weights[k] + values[k] * values[k] / sc;
            weights[k] = e;
            if e < least {
                least = e;
                heaviest = k;
            }
        }
        for (var k = 0u; k < n; k++) {
            let wk = exp(least - weights[k]);
            weights[k] = wk;
            wsum += wk;
            rsum += wk * values[k];
            rss += wk * values[k] * values[k];
        }
    }
    let ref_mean = rsum / wsum;
    let ref_variance = rss / wsum - ref_mean * ref_mean;
    let warp = plane_warp(j, hyp, vec2<f32>(f32(q.x), f32(q.y)));
    if !warp.ok {
        return MAX_COST;
    }
    let g = warp.g;
    var s = 0.0;
    var ss = 0.0;
    var rs = 0.0;
    var shift = 0.0;
    if heaviest > 0u {
        // As `ncc_cost`: shifted by the heaviest sample's value.
        let qx = f32(clamp(i32(q.x) - r + r * i32(heaviest % 3u), 0, w - 1));
        let qy = f32(clamp(i32(q.y) - r + r * i32(heaviest / 3u), 0, h - 1));
        let p = warp.c0 * qx + (warp.c1 * qy + warp.c2);
        if g.x * qx + (g.y * qy + g.z) >= 0.0 || p.z <= 0.0 {
            return MAX_COST;
        }
        shift = bilinear(src, p.x / p.z, p.y / p.z);
    }
    var i = 0u;
    for (var dy = -r; dy <= r; dy += r) {
        let qy = f32(clamp(i32(q.y) + dy, 0, h - 1));
        let row = warp.c1 * qy + warp.c2;
        let g_row = g.y * qy + g.z;
        for (var dx = -r; dx <= r; dx += r) {
            let qx = f32(clamp(i32(q.x) + dx, 0, w - 1));
            let p = warp.c0 * qx + row;
            if g.x * qx + g_row >= 0.0 || p.z <= 0.0 {
                return MAX_COST;
            }
            let value = bilinear(src, p.x / p.z, p.y / p.z);
            if i == 0u && heaviest == 0u {
                shift = value;
            }
            let v = value - shift;
            let wk = weights[i];
            s += wk * v;
            ss += wk * v * v;
            rs += wk * values[i] * v;
            i += 1u;
        }
    }
    let mean = s / wsum;
    let variance = ss / wsum - mean * mean;
    if ref_variance < MIN_VARIANCE || variance < MIN_VARIANCE {
        return MAX_COST;
    }
    let covariance = rs / wsum - ref_mean * mean;
    let ncc = covariance / sqrt(ref_variance * variance);
    return clamp(1.0 - ncc, 0.0, MAX_COST);
}

// The matching cost of `hyp` at the patch's pixel against source j: its own window's, or
// with anchors (1 - w) x that + w x the mean of the anchors' windows under the same plane
// (APD-MVS; `match_cost` in src/acmm/cpu/ncc.rs).
fn match_cost(j: u32, hyp: vec4<f32>) -> f32 {
    let own = ncc_cost(j, hyp);
    if anchor_n == 0u {
        return own;
    }
    let x = u32(patch_centre.x);
    let y = u32(patch_centre.y);
    var sum = 0.0;
    for (var a = 0u; a < anchor_n; a++) {
        let q = anchor_px[a];
        sum += anchor_ncc(j, plane_at_pixel(hyp, x, y, q.x, q.y), q);
    }
    let mean = sum / f32(anchor_n);
    let wa = problem.params.anchor_weight;
    return (1.0 - wa) * own + wa * mean;
}

// The K smallest costs, sorted (K <= 8); the mean of them is the top-K cost.
struct TopK {
    v: array<f32, 8>,
    n: u32,
}

fn topk_new() -> TopK {
    return TopK(array<f32, 8>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), 0u);
}

// The same insertion as `TopK::insert` in src/acmm/cpu/ncc.rs (after any equal costs), written
// as a copy from one array into another: shifting in place (v[i] = v[i - 1] in a loop),
// llvmpipe (Mesa 22.3, LLVM 15) lost the shifted value once the shader grew (the
// second-lowest cost read 0; tests/acmh.rs caught it when the bindings changed).
fn topk_insert(t: ptr<function, TopK>, c: f32, k: u32) {
    let v = (*t).v;
    let n = (*t).n;
    if n >= k && c >= v[k - 1u] {
        return;
    }
    // v is sorted: c goes after every cost not above it.
    var pos = 0u;
    for (var m = 0u; m < min(n, k); m++) {
        if v[m] <= c {
            pos = m + 1u;
        }
    }
    var out = v;
    for (var m = 1u; m < 8u; m++) {
        if m > pos && m < k {
            out[m] = v[m - 1u];
        }
    }
    out[pos] = c;
    (*t).v = out;
    (*t).n = min(n + 1u, k);
}

fn topk_mean(t: ptr<function, TopK>) -> f32 {
    if (*t).n == 0u {
        return MAX_COST;
    }
    var sum = 0.0;
    for (var i = 0u; i < (*t).n; i++) {
        sum += (*t).v[i];
    }
    return sum / f32((*t).n);
}
