// Copies one view's depths (the w of its planes) into a level's depth snapshot at the view's
// offset: what the next stage's geometric passes and the planar prior's support-point check
// read (the snapshot rule, src/session/mod.rs). CPU reference: `gather_depth` in
// src/gpu/acmh/buffers.rs.

struct Gather {
    // Pixels of the view.
    count: u32,
    // Where the view's depths start in `depths`.
    offset: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> g: Gather;
@group(0) @binding(1) var<storage, read> plane: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> depths: array<f32>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3<u32>,
        @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.y * groups.x * 256u + id.x;
    if i >= g.count {
        return;
    }
    depths[g.offset + i] = plane[i].w;
}
