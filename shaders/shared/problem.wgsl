// The bindings every ACMH/ACMM pass shares (one explicit layout, made in `AcmhPipelines::new`,
// src/gpu/acmh/pipelines.rs), the per-dispatch parameters and the plane helpers. Keep `Params`
// in sync with `GpuParams` (src/gpu/acmh/mod.rs) and `Source` with `GpuSource`
// (src/acmm/problem.rs).

struct Params {
    // Reference intrinsics fx, fy, cx, cy.
    k: vec4<f32>,
    // The coarse level's reference intrinsics (joint bilateral upsampling).
    coarse_k: vec4<f32>,
    width: u32,
    height: u32,
    num_sources: u32,
    view: u32,
    scale: u32,
    pass_id: u32,
    iteration: u32,
    color: u32,
    seed_lo: u32,
    seed_hi: u32,
    // 0 ACMH, 1 DWTA
    method: u32,
    top_k: u32,
    depth_min: f32,
    depth_max: f32,
    tau_t: f32,
    tau1: f32,
    beta: f32,
    n1: u32,
    n2: u32,
    sigma_spatial: f32,
    sigma_color: f32,
    // 0 Laplacian (unsquared distances), 1 Gaussian, 2 Gaussian with the window's own
    // colour spread (`BilateralKernel::Adaptive`)
    kernel: u32,
    window_radius: u32,
    window_step: u32,
    perturb_depth: f32,
    // tan of the largest normal tilt
    perturb_normal_tan: f32,
    median_radius: u32,
    // 1 in geometric consistency passes: aggregate m + lambda * reprojection error.
    geometric: u32,
    lambda: f32,
    delta: f32,
    // initialize: 1 draws random planes, 0 re-evaluates the current ones, 2 only measures
    // the reprojection error.
    init_random: u32,
    xi: f32,
    // Joint bilateral upsampling: the coarse level's size and the filter.
    coarse_width: u32,
    coarse_height: u32,
    jbu_radius: u32,
    jbu_sigma_spatial: f32,
    jbu_sigma_range: f32,
    // 1 in the detail restorer's gated pass (started from the upsampled planes): a pixel
    // leaves its current plane only for one whose cost is below C_init - xi.
    restorer: u32,
    // The first pixel of the planes' (and prior planes') second window: `plane_lo` holds
    // pixels [0, split), `plane_hi` the rest (see `load_plane`).
    split: u32,
    // The reference's layer in `layers`.
    ref_layer: u32,
    // Not 0 in the planar prior's prior-assisted pass: its start restarts low-confidence
    // pixels from the prior plane (initialize.wgsl), its updates maximise the prior-weighted
    // score where a pixel has a prior (adaptive_checkerboard.wgsl, shared/prior.wgsl); 1
    // updates every pixel, 2 only those with a prior. 3 in a geometric pass the prior holds
    // in (Regions' `prior_region_hold`): updates as 1, no restart at the start.
    prior: u32,
    prior_gamma: f32,
    prior_beta: f32,
    // sigma_d in depth units, 1 / (2 sigma_d^2), 1 / (2 sigma_theta^2) (radians).
    prior_sigma_depth: f32,
    prior_inv_2sd2: f32,
    prior_inv_2sn2: f32,
    prior_threshold: f32,
    prior_init_depth: f32,
    prior_init_normal_tan: f32,
    // In units of sigma_d.
    prior_refine_depth: f32,
    prior_refine_normal_tan: f32,
    // Where the selected-view masks start in `aux` (a multiple of 64: a binding offset).
    selected_base: u32,
    // 1 in the prior-assisted pass with `prior_anchors`: extra[0, n) holds each pixel's
    // anchor code, and its cost adds its anchors' windows (shared/ncc.wgsl `match_cost`).
    anchors: u32,
    anchor_weight: f32,
    // init_random = 5: the sources that must agree with a strong pixel, within anchor_limit px.
    anchor_views: u32,
    anchor_limit: f32,
    // init_random = 7: a source confirms a depth whose round trip comes back within this
    // share of it (`fusion_relative_depth`).
    confirm_depth: f32,
    // init_random = 7: 1 keys a pixel by the sources' summed confidence
    // (`prior_confidence_score`), 0 by the number that confirm it.
    confirm_score: u32,
    // init_random = 6: bit 0 measures the spread around the window's least-squares ramp
    // (`prior_flat_ramp`), else around its mean; bit 1 over the matching window's samples
    // under their bilateral weights (`prior_flat_weighted`), else over every pixel alike.
    flat_ramp: u32,
    // 1 with Regions' `prior_keep_unseen`: in a pass with a prior, a pixel whose prior plane
    // no source sees keeps it (adaptive_checkerboard.wgsl).
    prior_keep_unseen: u32,
    // init_random = 6: taken from each window's variance before its root, grey levels²
    // (`prior_flat_noise`: the reference image's noise; 0 for none).
    flat_noise_var: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Source {
    k: vec4<f32>,
    // Rows of src_from_ref.
    r0: vec4<f32>,
    r1: vec4<f32>,
    r2: vec4<f32>,
    t: vec4<f32>,
    // width, height, unused, layer in `layers` and `depth_layers`
    size: vec4<u32>,
}

const MAX_COST: f32 = 2.0;
const MIN_VARIANCE: f32 = 1e-5;
const NO_VIEW: u32 = 255u;
const WINNER_INITIAL: u32 = 254u;
const WINNER_KEPT: u32 = 8u;
// A pixel that kept its prior plane because no source sees it (`prior_keep_unseen`).
const WINNER_PRIOR_UNSEEN: u32 = 15u;
const METHOD_DWTA: u32 = 1u;
const PASS_RANDOM_INIT: u32 = 1u;
const PASS_GEOMETRIC: u32 = 3u;
const REPLACED_BIT: u32 = 65536u;

// The parameters and the sources, one read-only storage buffer (not a uniform: lavapipe
// leaks a shader variant per dispatch for uniforms, see acmh::STORAGE_BUFFERS; one buffer,
// not two, because a pass may bind eight storage buffers and the per-pixel maps need seven).
struct Problem {
    params: Params,
    sources: array<Source>,
}

// No storage binding grows past 8 bytes a pixel (128 MiB, llvmpipe's and WebGPU's default
// limit, holds a 16 Mpx view): a vec4 map is bound as two windows of its one buffer, pixels
// [0, split) and [split, n), and read through `load_plane` / `load_prior`.
@group(0) @binding(0) var<storage, read> problem: Problem;
// The views' intensities, view by view as layers (the reference's is params.ref_layer,
// source j's sources[j].size.w; a layer can be larger than its view, which fills its
// top-left corner): a texture, so the matching cost's four bilinear taps are one
// `textureGather`.
@group(0) @binding(1) var layers: texture_2d_array<f32>;
// Normal xyz (reference camera frame), depth w: pixels [0, split) and [split, n).
@group(0) @binding(3) var<storage, read_write> plane_lo: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> plane_hi: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> cost: array<f32>;
// Binding 6, the view weights w'(I_j) (a layer per source), is declared by the passes that
// use it: written by initialize.wgsl and adaptive_checkerboard.wgsl, read by
// detail_restorer.wgsl.
// [0, n): bits 0-7 winner, bits 8-15 the most important view v_t, the replaced and prior
// bits; [selected_base, selected_base + n): each pixel's selected-view mask (see
// `store_selected`).
@group(0) @binding(7) var<storage, read_write> aux: array<u32>;
// Two maps of width*height: [0, n) detail-restorer difference (C_init during the gated
// restorer pass), [n, 2n) mean geometric reprojection error (the lowest photometric cost
// found during the gated restorer pass).
@group(0) @binding(8) var<storage, read_write> extra: array<f32>;
// Planes kept aside: the coarse level's (input of the upsampling), then the upsampled ones
// the detail restorer compares against; in the planar prior's stage, each pixel's prior plane
// (normal xyz, depth w; w <= 0: none, shaders/planar_prior.wgsl). Two windows, as `plane`.
@group(0) @binding(9) var<storage, read_write> prior_lo: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> prior_hi: array<vec4<f32>>;
// The sources' depth maps (the previous stage's snapshot), in the same layers as the
// intensities (source j's is sources[j].size.w): what geometric passes read. A texture,
// so that no binding grows with the number of views (src/acmm/memory.rs).
@group(0) @binding(10) var depth_layers: texture_2d_array<f32>;
// Nearest, clamp to edge: textureGather's sampler.
@group(0) @binding(11) var layer_sampler: sampler;

fn load_plane(i: u32) -> vec4<f32> {
    let s = problem.params.split;
    if i < s {
        return plane_lo[i];
    }
    return plane_hi[i - s];
}

fn store_plane(i: u32, h: vec4<f32>) {
    let s = problem.params.split;
    if i < s {
        plane_lo[i] = h;
    } else {
        plane_hi[i - s] = h;
    }
}

fn store_depth(i: u32, d: f32) {
    let s = problem.params.split;
    if i < s {
        plane_lo[i].w = d;
    } else {
        plane_hi[i - s].w = d;
    }
}

fn load_prior(i: u32) -> vec4<f32> {
    let s = problem.params.split;
    if i < s {
        return prior_lo[i];
    }
    return prior_hi[i - s];
}

fn store_selected(i: u32, mask: u32) {
    aux[problem.params.selected_base + i] = mask;
}

fn pixel_stream(x: u32, y: u32) -> Stream {
    let key = hash7(problem.params.seed_lo, problem.params.seed_hi, problem.params.view, problem.params.scale, problem.params.pass_id,
        problem.params.iteration, y * problem.params.width + x);
    return Stream(key, 0u);
}

// Camera-frame ray of reference pixel (x, y), z = 1.
fn ref_ray(x: f32, y: f32) -> vec3<f32> {
    let k = problem.params.k;
    return vec3<f32>((x - k.z) / k.x, (y - k.w) / k.y, 1.0);
}

fn random_normal(u1: f32, u2: f32, view_ray: vec3<f32>) -> vec3<f32> {
    let nz = 2.0 * u1 - 1.0;
    let phi = 6.2831855 * u2;
    let r = sqrt(max(1.0 - nz * nz, 0.0));
    let n = vec3<f32>(r * cos(phi), r * sin(phi), nz);
    if dot(n, view_ray) > 0.0 {
        return -n;
    }
    return n;
}

// A neighbour's plane seen from pixel (x, y) (paper Sec. 4.2: a hypothesis is a 3-D plane):
// the plane through q = (qx, qy) at depth h.w with normal h.xyz, intersected with p's ray,
// d_p = d_q (n . K^-1 q~) / (n . K^-1 p~). Depth 0 when the ray meets it behind the camera
// or not at all. As `plane_at_pixel` in src/acmm/cpu.rs.
fn plane_at_pixel(h: vec4<f32>, qx: u32, qy: u32, x: u32, y: u32) -> vec4<f32> {
    let rq = ref_ray(f32(qx), f32(qy));
    let rp = ref_ray(f32(x), f32(y));
    let den = h.x * rp.x + h.y * rp.y + h.z * rp.z;
    let num = h.w * (h.x * rq.x + h.y * rq.y + h.z * rq.z);
    var d = 0.0;
    if den < 0.0 {
        d = num / den;
    }
    return vec4<f32>(h.xyz, d);
}

fn normalize3(v: vec3<f32>) -> vec3<f32> {
    return v / sqrt(dot(v, v));
}

// The normal tilted by up to +-tan_amount along two tangent directions (as
// `perturb_normal` in src/acmm/cpu.rs: sqrt and division only, no acos/atan2); unchanged
// if that would turn it away from the camera.
fn perturb_normal(n: vec3<f32>, u1: f32, u2: f32, tan_amount: f32, view_ray: vec3<f32>) -> vec3<f32> {
    let a = abs(n);
    var e = vec3<f32>(0.0, 0.0, 1.0);
    if a.x < a.y && a.x < a.z {
        e = vec3<f32>(1.0, 0.0, 0.0);
    } else if a.y < a.z {
        e = vec3<f32>(0.0, 1.0, 0.0);
    }
    let t1 = normalize3(cross(n, e));
    let t2 = cross(n, t1);
    let da = (2.0 * u1 - 1.0) * tan_amount;
    let db = (2.0 * u2 - 1.0) * tan_amount;
    let p = normalize3(n + da * t1 + db * t2);
    if dot(p, view_ray) < 0.0 {
        return p;
    }
    return n;
}

fn in_depth_range(d: f32) -> bool {
    return d >= problem.params.depth_min && d <= problem.params.depth_max;
}

fn random_depth(s: ptr<function, Stream>) -> f32 {
    return problem.params.depth_min + stream_next(s) * (problem.params.depth_max - problem.params.depth_min);
}
