// Copies one view's depths (the w of its planes) into its layer of a depth snapshot: what the
// next stage's geometric passes and the planar prior's support-point check read (the snapshot
// rule, src/session/mod.rs). CPU reference: `gather_depth` in src/gpu/acmh/buffers.rs.

struct Gather {
    width: u32,
    height: u32,
    // The view's layer in `depths`.
    layer: u32,
    // The planes' second window starts at this pixel (see `load_plane` in shared/problem.wgsl).
    split: u32,
}

@group(0) @binding(0) var<uniform> g: Gather;
@group(0) @binding(1) var<storage, read> plane_lo: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> plane_hi: array<vec4<f32>>;
@group(0) @binding(2) var depths: texture_storage_2d_array<r32float, write>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= g.width || id.y >= g.height {
        return;
    }
    let i = id.y * g.width + id.x;
    var d = 0.0;
    if i < g.split {
        d = plane_lo[i].w;
    } else {
        d = plane_hi[i - g.split].w;
    }
    textureStore(depths, vec2<u32>(id.x, id.y), g.layer, vec4<f32>(d));
}
