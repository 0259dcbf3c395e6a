// Random initialisation (paper Sec. 4.1): a random plane per pixel, cost = mean of the K best
// per-source NCC costs.
#import rng
#import problem
#import ncc

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let i = y * params.width + x;
    var s = pixel_stream(x, y);
    let d = random_depth(&s);
    let u1 = stream_next(&s);
    let u2 = stream_next(&s);
    let n = random_normal(u1, u2, ref_ray(f32(x), f32(y)));
    let hyp = vec4<f32>(n, d);
    load_ref_patch(x, y);
    var top = topk_new();
    // The K lowest costs as a bitmask, lower index first on ties (as src/acmm/cpu.rs).
    var costs: array<f32, 32>;
    for (var j = 0u; j < params.num_sources; j++) {
        let c = ncc_cost(j, hyp);
        costs[j] = c;
        topk_insert(&top, c, params.top_k);
    }
    var mask = 0u;
    for (var m = 0u; m < min(params.top_k, params.num_sources); m++) {
        var best = 32u;
        for (var j = 0u; j < params.num_sources; j++) {
            if (mask & (1u << j)) == 0u && (best == 32u || costs[j] < costs[best]) {
                best = j;
            }
        }
        mask |= 1u << best;
    }
    plane[i] = hyp;
    cost[i] = topk_mean(&top);
    selected[i] = mask;
    aux[i] = WINNER_INITIAL | (NO_VIEW << 8u);
    for (var j = 0u; j < params.num_sources; j++) {
        weights[i * params.num_sources + j] = 0.0;
    }
}
