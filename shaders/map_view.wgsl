// Map view: turns one view's ACMM maps into a displayable image (src/viewer/maps.rs).
//
// Pass 1 (`extract`) writes one vec4 per pixel into `values`: for scalar kinds x = value,
// y = 1 when valid (else 0), z = w = 0; Normal: xyz = normal, w = 1 when depth > 0; Image:
// xyz = rgb in [0, 1], w = 1. Pass 2 (`colorize`) maps `values` to an rgba8 texture.
// The CPU reference is `extract_value` / `colorize_value`; keep the two in step.

struct MapParams {
    width: u32,
    height: u32,
    kind: u32,
    source: u32,
    num_sources: u32,
    colormap: u32,
    lo: f32,
    hi: f32,
    // Whether the kind's per-pixel input (ground truth, confidence) is bound.
    has_input: u32,
    // The planar prior's factor (KIND_PRIOR_WEIGHT): gamma, 1 / (2 sd^2), 1 / (2 st^2).
    prior_gamma: f32,
    prior_inv_2sd2: f32,
    prior_inv_2sn2: f32,
    // The first pixel of the second window of the vec4 maps (`planes`, `priors`, `values`):
    // no binding past 8 bytes a pixel (src/acmm/memory.rs).
    split: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Kinds, in the order of `MapKind::ALL`.
const KIND_IMAGE: u32 = 0u;
const KIND_DEPTH: u32 = 1u;
const KIND_NORMAL: u32 = 2u;
const KIND_COST: u32 = 3u;
const KIND_SELECTED_COUNT: u32 = 4u;
const KIND_SELECTED_BIT: u32 = 5u;
const KIND_WEIGHT: u32 = 6u;
const KIND_WINNER: u32 = 7u;
const KIND_REPROJECTION_ERROR: u32 = 8u;
const KIND_RESTORER_DIFFERENCE: u32 = 9u;
const KIND_REPLACED: u32 = 10u;
const KIND_DEPTH_ERROR: u32 = 11u;
// The planar prior: `planes` is bound to the prior planes for depth and normal, `priors`
// to them for the weight, `words` to aux for the effect.
const KIND_PRIOR_DEPTH: u32 = 12u;
const KIND_PRIOR_NORMAL: u32 = 13u;
const KIND_PRIOR_WEIGHT: u32 = 14u;
const KIND_PRIOR_EFFECT: u32 = 15u;
// (16 and 17, the support points and the triangulation, draw the image: KIND_IMAGE.)
const KIND_CONFIDENCE: u32 = 18u;
// The anchors' codes (`prior_anchors`) are in the first extra map: 3 bits per direction.
const KIND_ANCHORS: u32 = 19u;
// The distance to texture at the shown scale (`scales_by_texture`), from `floats`.
const KIND_TEXTURE_REACH: u32 = 20u;

const COLORMAP_TURBO: u32 = 0u;
const COLORMAP_VIRIDIS: u32 = 1u;

// aux & 0xff of a pixel still holding its random initial plane; shown as value 16.
const WINNER_INITIAL: u32 = 254u;
const WINNER_INITIAL_VALUE: f32 = 16.0;
// Codes 0..=15 show as themselves (15: a prior plane no source sees, kept).
const WINNER_LAST_CODE: u32 = 15u;
// The f32 nearest to 1/255 (Rust: 1.0f32 / 255.0).
const INV_255: f32 = 0.003921569;
const INVALID_GREY: f32 = 0.12;
// The winner map's categorical colours in bytes, one per value 0..=16 (Rust:
// maps::WINNER_COLORS, which says why they are what they are).
const WINNER_COLORS = array<vec3<f32>, 17>(
    vec3<f32>(31.0, 119.0, 180.0),
    vec3<f32>(158.0, 202.0, 225.0),
    vec3<f32>(44.0, 160.0, 44.0),
    vec3<f32>(161.0, 217.0, 155.0),
    vec3<f32>(117.0, 107.0, 177.0),
    vec3<f32>(203.0, 160.0, 230.0),
    vec3<f32>(140.0, 86.0, 75.0),
    vec3<f32>(196.0, 156.0, 148.0),
    vec3<f32>(235.0, 235.0, 235.0),
    vec3<f32>(214.0, 39.0, 40.0),
    vec3<f32>(255.0, 127.0, 14.0),
    vec3<f32>(130.0, 16.0, 16.0),
    vec3<f32>(255.0, 152.0, 150.0),
    vec3<f32>(255.0, 187.0, 120.0),
    vec3<f32>(240.0, 220.0, 60.0),
    vec3<f32>(214.0, 0.0, 214.0),
    vec3<f32>(96.0, 96.0, 96.0),
);

@group(0) @binding(0) var<uniform> params: MapParams;
// Pass 1 inputs. `floats` and `words` are whichever f32 / u32 map the kind reads (cost,
// extra, ground truth / image, selected, aux); a 16-byte dummy when none. Each vec4 map is
// two windows, pixels [0, split) and [split, n) (`plane_at`, `prior_at`).
@group(0) @binding(1) var<storage, read> planes_lo: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> planes_hi: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> floats: array<f32>;
@group(0) @binding(3) var<storage, read> words: array<u32>;
// The prior planes (KIND_PRIOR_WEIGHT); the dummy for the other kinds.
@group(0) @binding(8) var<storage, read> priors_lo: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> priors_hi: array<vec4<f32>>;
// Output of pass 1, input of pass 2.
@group(0) @binding(4) var<storage, read_write> values_lo: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> values_hi: array<vec4<f32>>;
@group(0) @binding(5) var target_texture: texture_storage_2d<rgba8unorm, write>;
// The view weights, a layer per source (KIND_WEIGHT reads layer params.source); a 1x1
// texture for the other kinds.
@group(0) @binding(6) var weights: texture_2d_array<f32>;

fn plane_at(i: u32) -> vec4<f32> {
    if i < params.split {
        return planes_lo[i];
    }
    return planes_hi[i - params.split];
}

fn prior_at(i: u32) -> vec4<f32> {
    if i < params.split {
        return priors_lo[i];
    }
    return priors_hi[i - params.split];
}

fn value_at(i: u32) -> vec4<f32> {
    if i < params.split {
        return values_lo[i];
    }
    return values_hi[i - params.split];
}

fn flag(valid: bool) -> f32 {
    return select(0.0, 1.0, valid);
}

fn scalar(x: f32, valid: bool) -> vec4<f32> {
    return vec4<f32>(x, flag(valid), 0.0, 0.0);
}

// acos as `acos_approx` in src/acmm/planar.rs (shaders/shared/prior.wgsl).
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

fn extract_at(i: u32, n: u32) -> vec4<f32> {
    switch params.kind {
        case KIND_PRIOR_DEPTH: {
            let d = plane_at(i).w;
            return scalar(d, d > 0.0);
        }
        case KIND_PRIOR_NORMAL: {
            let p = plane_at(i);
            return vec4<f32>(p.xyz, flag(p.w > 0.0));
        }
        case KIND_PRIOR_WEIGHT: {
            let h = plane_at(i);
            let pp = prior_at(i);
            if pp.w <= 0.0 || h.w <= 0.0 {
                return scalar(0.0, false);
            }
            let dd = h.w - pp.w;
            let c = h.x * pp.x + h.y * pp.y + h.z * pp.z;
            let theta = acos_approx(c);
            return scalar(params.prior_gamma + exp(-(dd * dd * params.prior_inv_2sd2)
                - theta * theta * params.prior_inv_2sn2), true);
        }
        case KIND_PRIOR_EFFECT: {
            return scalar(f32((words[i] >> 17u) & 1u), true);
        }
        case KIND_IMAGE: {
            let c = words[i];
            return vec4<f32>(
                f32(c & 255u) * INV_255,
                f32((c >> 8u) & 255u) * INV_255,
                f32((c >> 16u) & 255u) * INV_255,
                1.0,
            );
        }
        case KIND_DEPTH: {
            let d = plane_at(i).w;
            return scalar(d, d > 0.0);
        }
        case KIND_NORMAL: {
            let p = plane_at(i);
            return vec4<f32>(p.xyz, flag(p.w > 0.0));
        }
        case KIND_COST: {
            return scalar(floats[i], plane_at(i).w > 0.0);
        }
        case KIND_SELECTED_COUNT: {
            return scalar(f32(countOneBits(words[i])), true);
        }
        case KIND_SELECTED_BIT: {
            if params.source >= min(params.num_sources, 32u) {
                return scalar(0.0, false);
            }
            return scalar(f32((words[i] >> params.source) & 1u), true);
        }
        case KIND_WEIGHT: {
            if params.source >= params.num_sources {
                return scalar(0.0, false);
            }
            let xy = vec2<u32>(i % params.width, i / params.width);
            return scalar(textureLoad(weights, xy, params.source, 0).x, true);
        }
        case KIND_WINNER: {
            let code = words[i] & 255u;
            if code <= WINNER_LAST_CODE {
                return scalar(f32(code), true);
            }
            if code == WINNER_INITIAL {
                return scalar(WINNER_INITIAL_VALUE, true);
            }
            return scalar(0.0, false);
        }
        case KIND_REPROJECTION_ERROR: {
            return scalar(floats[n + i], true);
        }
        case KIND_RESTORER_DIFFERENCE: {
            return scalar(floats[i], true);
        }
        case KIND_ANCHORS: {
            let code = u32(floats[i]);
            var count = 0u;
            for (var k = 0u; k < 8u; k++) {
                if ((code >> (3u * k)) & 7u) != 0u {
                    count += 1u;
                }
            }
            return scalar(f32(count), true);
        }
        case KIND_REPLACED: {
            return scalar(f32((words[i] >> 16u) & 1u), true);
        }
        case KIND_DEPTH_ERROR: {
            if params.has_input == 0u {
                return scalar(0.0, false);
            }
            let d = plane_at(i).w;
            let g = floats[i];
            if g > 0.0 && d > 0.0 {
                return scalar(abs(d - g) / g, true);
            }
            return scalar(0.0, false);
        }
        case KIND_CONFIDENCE: {
            if params.has_input != 0u && plane_at(i).w > 0.0 {
                return scalar(floats[i], true);
            }
            return scalar(0.0, false);
        }
        case KIND_TEXTURE_REACH: {
            if params.has_input != 0u {
                return scalar(floats[i], true);
            }
            return scalar(0.0, false);
        }
        default: {
            return vec4<f32>(0.0);
        }
    }
}

@compute @workgroup_size(8, 8)
fn extract(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let i = id.y * params.width + id.x;
    let v = extract_at(i, params.width * params.height);
    if i < params.split {
        values_lo[i] = v;
    } else {
        values_hi[i - params.split] = v;
    }
}

// 33 samples (t = k / 32) of each colour map, linearly interpolated.
const TABLE_STEPS: f32 = 32.0;
const TABLE_LAST_SEGMENT: u32 = 31u;
const TURBO = array<vec3<f32>, 33>(
    vec3<f32>(0.1900, 0.0718, 0.2322),
    vec3<f32>(0.2249, 0.1632, 0.4502),
    vec3<f32>(0.2509, 0.2517, 0.6324),
    vec3<f32>(0.2680, 0.3373, 0.7790),
    vec3<f32>(0.2762, 0.4199, 0.8897),
    vec3<f32>(0.2755, 0.4996, 0.9648),
    vec3<f32>(0.2594, 0.5777, 0.9986),
    vec3<f32>(0.2153, 0.6567, 0.9806),
    vec3<f32>(0.1602, 0.7332, 0.9252),
    vec3<f32>(0.1130, 0.8034, 0.8482),
    vec3<f32>(0.0927, 0.8634, 0.7655),
    vec3<f32>(0.1179, 0.9101, 0.6900),
    vec3<f32>(0.1922, 0.9474, 0.5993),
    vec3<f32>(0.2992, 0.9758, 0.4953),
    vec3<f32>(0.4210, 0.9935, 0.3912),
    vec3<f32>(0.5400, 0.9991, 0.3005),
    vec3<f32>(0.6384, 0.9910, 0.2365),
    vec3<f32>(0.7205, 0.9669, 0.2073),
    vec3<f32>(0.7994, 0.9277, 0.2042),
    vec3<f32>(0.8704, 0.8768, 0.2146),
    vec3<f32>(0.9290, 0.8173, 0.2261),
    vec3<f32>(0.9707, 0.7523, 0.2262),
    vec3<f32>(0.9921, 0.6810, 0.2059),
    vec3<f32>(0.9963, 0.5952, 0.1724),
    vec3<f32>(0.9853, 0.5018, 0.1324),
    vec3<f32>(0.9610, 0.4084, 0.0921),
    vec3<f32>(0.9253, 0.3229, 0.0577),
    vec3<f32>(0.8797, 0.2521, 0.0349),
    vec3<f32>(0.8230, 0.1909, 0.0195),
    vec3<f32>(0.7547, 0.1367, 0.0093),
    vec3<f32>(0.6747, 0.0895, 0.0045),
    vec3<f32>(0.5830, 0.0492, 0.0049),
    vec3<f32>(0.4796, 0.0158, 0.0106),);
const VIRIDIS = array<vec3<f32>, 33>(
    vec3<f32>(0.2670, 0.0049, 0.3294),
    vec3<f32>(0.2770, 0.0502, 0.3755),
    vec3<f32>(0.2823, 0.0946, 0.4170),
    vec3<f32>(0.2829, 0.1354, 0.4530),
    vec3<f32>(0.2789, 0.1749, 0.4830),
    vec3<f32>(0.2708, 0.2133, 0.5066),
    vec3<f32>(0.2593, 0.2507, 0.5244),
    vec3<f32>(0.2454, 0.2867, 0.5370),
    vec3<f32>(0.2302, 0.3213, 0.5455),
    vec3<f32>(0.2148, 0.3545, 0.5510),
    vec3<f32>(0.2000, 0.3864, 0.5545),
    vec3<f32>(0.1861, 0.4173, 0.5567),
    vec3<f32>(0.1733, 0.4474, 0.5579),
    vec3<f32>(0.1613, 0.4770, 0.5581),
    vec3<f32>(0.1497, 0.5064, 0.5573),
    vec3<f32>(0.1384, 0.5358, 0.5551),
    vec3<f32>(0.1281, 0.5651, 0.5509),
    vec3<f32>(0.1209, 0.5945, 0.5442),
    vec3<f32>(0.1203, 0.6238, 0.5343),
    vec3<f32>(0.1310, 0.6529, 0.5208),
    vec3<f32>(0.1554, 0.6815, 0.5032),
    vec3<f32>(0.1930, 0.7096, 0.4812),
    vec3<f32>(0.2415, 0.7366, 0.4545),
    vec3<f32>(0.2986, 0.7624, 0.4230),
    vec3<f32>(0.3629, 0.7867, 0.3866),
    vec3<f32>(0.4330, 0.8091, 0.3453),
    vec3<f32>(0.5081, 0.8292, 0.2992),
    vec3<f32>(0.5873, 0.8470, 0.2489),
    vec3<f32>(0.6694, 0.8622, 0.1954),
    vec3<f32>(0.7529, 0.8751, 0.1427),
    vec3<f32>(0.8359, 0.8861, 0.1025),
    vec3<f32>(0.9166, 0.8961, 0.1008),
    vec3<f32>(0.9932, 0.9062, 0.1439),);

fn colormap(which: u32, t: f32) -> vec3<f32> {
    if which != COLORMAP_TURBO && which != COLORMAP_VIRIDIS {
        return vec3<f32>(t);
    }
    let s = t * TABLE_STEPS;
    let k = min(u32(floor(s)), TABLE_LAST_SEGMENT);
    let f = s - f32(k);
    var table = TURBO;
    if which == COLORMAP_VIRIDIS {
        table = VIRIDIS;
    }
    let a = table[k];
    let b = table[k + 1u];
    return a + (b - a) * f;
}

fn color_of(v: vec4<f32>) -> vec3<f32> {
    let invalid = vec3<f32>(INVALID_GREY);
    if params.kind == KIND_IMAGE {
        if v.w > 0.5 {
            return clamp(v.xyz, vec3<f32>(0.0), vec3<f32>(1.0));
        }
        return invalid;
    }
    if params.kind == KIND_NORMAL || params.kind == KIND_PRIOR_NORMAL {
        if v.w > 0.5 {
            let rgb = vec3<f32>(v.x * 0.5 + 0.5, (-v.y) * 0.5 + 0.5, (-v.z) * 0.5 + 0.5);
            return clamp(rgb, vec3<f32>(0.0), vec3<f32>(1.0));
        }
        return invalid;
    }
    if v.y <= 0.5 {
        return invalid;
    }
    if params.kind == KIND_WINNER {
        var table = WINNER_COLORS;
        return table[min(u32(max(v.x, 0.0)), 16u)] * INV_255;
    }
    var t = 0.0;
    let span = params.hi - params.lo;
    if span > 0.0 {
        t = clamp((v.x - params.lo) / span, 0.0, 1.0);
    }
    return colormap(params.colormap, t);
}

@compute @workgroup_size(8, 8)
fn colorize(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let v = value_at(id.y * params.width + id.x);
    textureStore(target_texture, vec2<i32>(i32(id.x), i32(id.y)), vec4<f32>(color_of(v), 1.0));
}
