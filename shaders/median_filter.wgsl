// The final median filter on depth (paper Sec. 4.4: 5x5 at radius 2) over the samples inside
// the image; an even count takes the lower middle. `median` writes extra[0, n), `store` copies it
// back into the planes' depth.
#import rng
#import problem

@compute @workgroup_size(8, 8)
fn median(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = i32(id.x);
    let y = i32(id.y);
    let w = i32(params.width);
    let h = i32(params.height);
    if x >= w || y >= h {
        return;
    }
    let r = i32(params.median_radius);
    var v: array<f32, 49>;
    var n = 0u;
    for (var dy = -r; dy <= r; dy++) {
        for (var dx = -r; dx <= r; dx++) {
            let sx = x + dx;
            let sy = y + dy;
            if sx >= 0 && sy >= 0 && sx < w && sy < h {
                // Insertion sort as we go.
                let d = plane[u32(sy * w + sx)].w;
                var k = n;
                while k > 0u && v[k - 1u] > d {
                    v[k] = v[k - 1u];
                    k -= 1u;
                }
                v[k] = d;
                n += 1u;
            }
        }
    }
    extra[u32(y * w + x)] = v[(n - 1u) / 2u];
}

@compute @workgroup_size(8, 8)
fn store(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let i = id.y * params.width + id.x;
    plane[i].w = extra[i];
}
