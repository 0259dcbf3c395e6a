// The detail restorer (paper Sec. 5.2), its last step, in one of three modes
// (`problem.params.restorer`):
// - 2, `refine` (the default), and 1, `gated`: the basic model ran from the upsampled planes
//   (gated: a plane was replaced only where its cost beat C_init by xi), so the planes are
//   final; this records C_init - C_photo (C_photo the lowest cost the basic model found) in
//   extra[0, n), and in `refine` marks where it exceeds xi as replaced (aux bit 16).
// - 0, `random`: the basic model ran from random planes; C_init is the photometric cost of
//   the upsampled plane (`prior`), C_photo that of the basic model's plane (`plane`), both
//   aggregated with the view weights it ended with; where C_init - C_photo > xi the upsampled
//   plane is replaced. Writes the difference to extra[0, n) and the replaced flag to aux
//   bit 16.
// CPU reference: `detail_restorer_pixel` in src/acmm/multiscale.rs.
#import rng
#import problem
#import ncc

// The view weights the basic model ended with, a layer per source (read here; the
// checkerboard pass writes them).
@group(0) @binding(6) var weights_in: texture_2d_array<f32>;

fn weighted_cost(x: u32, y: u32, hyp: vec4<f32>) -> f32 {
    let nsrc = problem.params.num_sources;
    var den = 0.0;
    var num = 0.0;
    var top = topk_new();
    for (var j = 0u; j < nsrc; j++) {
        let w = textureLoad(weights_in, vec2<u32>(x, y), j, 0).x;
        let m = ncc_cost(j, hyp);
        den += w;
        num += w * m;
        topk_insert(&top, m, problem.params.top_k);
    }
    if den > 0.0 {
        return num / den;
    }
    return topk_mean(&top);
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
    if problem.params.restorer != 0u {
        // The pass from the upsampled planes already replaced what it replaced; record
        // C_init - C_photo, with C_photo the lowest cost the basic model found at the pixel.
        // Ungated (restorer = 2), the pixels where it exceeds xi are the errors in details.
        let difference = extra[i] - extra[n + i];
        extra[i] = difference;
        if problem.params.restorer == 2u {
            aux[i] = (aux[i] & 0xffffu) | select(0u, REPLACED_BIT, difference > problem.params.xi);
        }
        return;
    }
    load_ref_patch(x, y);
    let up = load_prior(i);
    let photo = load_plane(i);
    let c_photo = weighted_cost(x, y, photo);
    var c_init = MAX_COST;
    if up.w > 0.0 {
        c_init = weighted_cost(x, y, up);
    }
    let difference = c_init - c_photo;
    let replaced = difference > problem.params.xi;
    store_plane(i, select(up, photo, replaced));
    cost[i] = select(c_init, c_photo, replaced);
    extra[i] = difference;
    aux[i] = (aux[i] & 0xffffu) | select(0u, REPLACED_BIT, replaced);
}
