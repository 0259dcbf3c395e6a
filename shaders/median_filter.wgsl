// The final median filter on depth (paper Sec. 4.4: 5x5 at radius 2) over the samples inside
// the image; an even count takes the lower middle. `median` writes `scratch`, `store` copies it back
// into the planes' depth.

#import rng
#import problem

// The median of each pixel's window, before `store` writes it into the planes (bound by the
// median filter's own layout: `AcmhPipelines::median_layout`).
@group(0) @binding(12) var<storage, read_write> scratch: array<f32>;

@compute @workgroup_size(8, 8)
fn median(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = i32(id.x);
    let y = i32(id.y);
    let w = i32(problem.params.width);
    let h = i32(problem.params.height);
    if x >= w || y >= h {
        return;
    }
    let r = i32(problem.params.median_radius);
    var v: array<f32, 49>;
    var n = 0u;
    for (var dy = -r; dy <= r; dy++) {
        for (var dx = -r; dx <= r; dx++) {
            let sx = x + dx;
            let sy = y + dy;
            if sx >= 0 && sy >= 0 && sx < w && sy < h {
                v[n] = load_plane(u32(sy * w + sx)).w;
                n += 1u;
            }
        }
    }
    // The sample of rank (n - 1) / 2 in sorted order, equal samples by their order: the
    // value a sort puts there (`median_filter` in src/acmm/cpu). Ranks, not an insertion
    // sort: shifting in place (v[k] = v[k - 1] in a loop), llvmpipe (Mesa 22.3, LLVM 15)
    // lost shifted values once the shared bindings grew (tests/acmh.rs caught it).
    let middle = (n - 1u) / 2u;
    var median = 0.0;
    for (var a = 0u; a < n; a++) {
        var rank = 0u;
        for (var b = 0u; b < n; b++) {
            if v[b] < v[a] || (v[b] == v[a] && b < a) {
                rank += 1u;
            }
        }
        if rank == middle {
            median = v[a];
        }
    }
    scratch[u32(y * w + x)] = median;
}

@compute @workgroup_size(8, 8)
fn store(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= problem.params.width || id.y >= problem.params.height {
        return;
    }
    let i = id.y * problem.params.width + id.x;
    store_depth(i, scratch[i]);
}
