// The detail restorer (paper Sec. 5.2): C_init is the photometric cost of the upsampled plane
// (`prior`), C_photo that of photometric ACMH's plane at this scale (`plane`), both aggregated
// with the view weights ACMH ended with; where C_init - C_photo > xi the upsampled plane is
// replaced. Writes the difference to extra[n, 2n) and the replaced flag to aux bit 16.
// CPU reference: `detail_restorer_pixel` in src/acmm/multiscale.rs.
#import rng
#import problem
#import ncc

fn weighted_cost(i: u32, hyp: vec4<f32>) -> f32 {
    let nsrc = params.num_sources;
    var den = 0.0;
    var num = 0.0;
    var top = topk_new();
    for (var j = 0u; j < nsrc; j++) {
        let w = weights[i * nsrc + j];
        let m = ncc_cost(j, hyp);
        den += w;
        num += w * m;
        topk_insert(&top, m, params.top_k);
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
    if x >= params.width || y >= params.height {
        return;
    }
    let i = y * params.width + x;
    let n = params.width * params.height;
    load_ref_patch(x, y);
    let up = prior[i];
    let photo = plane[i];
    let c_photo = weighted_cost(i, photo);
    var c_init = MAX_COST;
    if up.w > 0.0 {
        c_init = weighted_cost(i, up);
    }
    let difference = c_init - c_photo;
    let replaced = difference > params.xi;
    plane[i] = select(up, photo, replaced);
    cost[i] = select(c_init, c_photo, replaced);
    extra[n + i] = difference;
    aux[i] = (aux[i] & 0xffffu) | select(0u, REPLACED_BIT, replaced);
}
