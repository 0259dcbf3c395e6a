// The viewer's 3D view: points as instanced screen-space squares and camera frusta as lines,
// drawn into an offscreen colour + depth target, then copied 1:1 into egui's render pass.
// CPU references: `project_point` and `point_color` in src/viewer/cloud/mod.rs.

// Keep in sync with `CloudUniforms` in src/viewer/cloud/render.rs.
struct Uniforms {
    view_proj: mat4x4<f32>,
    // Offscreen target size in pixels.
    viewport: vec2<f32>,
    // Side of a point's square in pixels.
    point_size: f32,
    // 0: rgb, 1: normal, 2: cost.
    color_mode: u32,
    cost_range: vec2<f32>,
    // Top-left corner of the view in the window's framebuffer, in pixels (blit only).
    blit_origin: vec2<f32>,
}

@group(0) @binding(0) var<uniform> u: Uniforms;

// `cost_ramp` in cloud.rs: blue -> cyan -> yellow -> red over t in [0, 1].
fn cost_ramp(t: f32) -> vec3<f32> {
    if t < 1.0 / 3.0 {
        return mix(vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 1.0, 1.0), t * 3.0);
    }
    if t < 2.0 / 3.0 {
        return mix(vec3<f32>(0.0, 1.0, 1.0), vec3<f32>(1.0, 1.0, 0.0), t * 3.0 - 1.0);
    }
    return mix(vec3<f32>(1.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), t * 3.0 - 2.0);
}

fn point_color(color: vec3<f32>, normal: vec3<f32>, cost: f32) -> vec3<f32> {
    switch u.color_mode {
        case 1u: {
            return normal * 0.5 + 0.5;
        }
        case 2u: {
            let span = u.cost_range.y - u.cost_range.x;
            var t = 0.0;
            if span > 0.0 {
                t = clamp((cost - u.cost_range.x) / span, 0.0, 1.0);
            }
            return cost_ramp(t);
        }
        default: {
            return color;
        }
    }
}

struct PointIn {
    @location(0) position: vec3<f32>,
    @location(1) cost: f32,
    @location(2) color: vec3<f32>,
    @location(3) normal: vec3<f32>,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec3<f32>,
}

@vertex
fn vs_point(@builtin(vertex_index) vertex: u32, point: PointIn) -> VertexOut {
    // Two triangles of a unit square centred on the point.
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-0.5, -0.5),
        vec2<f32>(0.5, -0.5),
        vec2<f32>(0.5, 0.5),
        vec2<f32>(-0.5, -0.5),
        vec2<f32>(0.5, 0.5),
        vec2<f32>(-0.5, 0.5),
    );
    var out: VertexOut;
    out.color = point_color(point.color, point.normal, point.cost);
    let clip = u.view_proj * vec4<f32>(point.position, 1.0);
    if clip.w <= 0.0 {
        // Behind the eye: outside the clip volume, so the square is dropped.
        out.clip = vec4<f32>(2.0, 2.0, 2.0, 1.0);
        return out;
    }
    // The offset is in pixels; NDC spans 2 over the viewport, and clip = NDC * w.
    let offset = corners[vertex % 6u] * u.point_size * 2.0 / u.viewport;
    out.clip = vec4<f32>(clip.xy + offset * clip.w, clip.z, clip.w);
    return out;
}

@fragment
fn fs_color(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.color, 1.0);
}

struct LineIn {
    @location(0) position: vec3<f32>,
    @location(1) color: vec3<f32>,
}

@vertex
fn vs_line(line: LineIn) -> VertexOut {
    var out: VertexOut;
    out.clip = u.view_proj * vec4<f32>(line.position, 1.0);
    out.color = line.color;
    return out;
}

// Blit: one triangle covering the viewport egui set; each fragment reads its own texel.
@group(1) @binding(0) var offscreen: texture_2d<f32>;

@vertex
fn vs_blit(@builtin(vertex_index) vertex: u32) -> @builtin(position) vec4<f32> {
    let x = f32(vertex & 1u) * 4.0 - 1.0;
    let y = f32(vertex >> 1u) * 4.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

fn blit_texel(frag: vec4<f32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(offscreen));
    let texel = clamp(vec2<i32>(floor(frag.xy - u.blit_origin)), vec2<i32>(0), size - 1);
    return textureLoad(offscreen, texel, 0);
}

// The offscreen texture holds display (sRGB-encoded) values, as egui's preferred targets do.
@fragment
fn fs_blit(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    return blit_texel(frag);
}

// For an sRGB target the hardware encodes what we write, so decode first.
@fragment
fn fs_blit_srgb_target(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let c = blit_texel(frag);
    let lo = c.rgb / 12.92;
    let hi = pow((c.rgb + 0.055) / 1.055, vec3<f32>(2.4));
    return vec4<f32>(select(hi, lo, c.rgb <= vec3<f32>(0.04045)), c.a);
}
