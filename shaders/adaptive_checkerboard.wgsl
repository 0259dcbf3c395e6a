// One red or black half-iteration of ACMH (paper Sec. 4.2-4.4) or DWTA, photometric or with
// geometric consistency (Sec. 5.1: the vote sees m, aggregation sums m + lambda * error): adaptive checkerboard
// sampling proposes 8 planes, multi-hypothesis joint view selection votes on their 8 x (N-1)
// cost matrix and weighs the views, the best plane by aggregated cost is adopted, then
// refinement tries six random/perturbed combinations. In the planar prior's prior-assisted
// pass (problem.params.prior = 1) a pixel with a prior plane chooses by the largest prior-weighted
// score instead of the lowest cost, and refines around its prior (ACMP-REFERENCE.md §4); so
// does it in a geometric pass the prior holds in (prior = 3, Regions' `prior_region_hold`),
// its score then taking the cost with the geometric term.
// Reads only the other colour.
#import rng
#import problem
#import ncc
#import geometric
#import prior

// The view weights, a layer per source: written for display, the detail restorer and the
// next pass; the refinement below reads this update's from `view_weights`.
@group(0) @binding(6) var weights_out: texture_storage_2d_array<r32float, write>;

// This update's weight of each source (at most 32 sources: the selection mask's bits).
var<private> view_weights: array<f32, 32>;

// Sample s of area a around (x, y): even areas are V shapes of 7 samples, odd ones long strips
// of 11; a / 2 is the direction (up, down, left, right). Order as `checkerboard_areas` in
// src/acmm/cpu.rs.
fn area_sample(a: u32, s: u32, x: i32, y: i32) -> vec2<i32> {
    var dir = vec2<i32>(0, -1);
    switch a / 2u {
        case 1u: { dir = vec2<i32>(0, 1); }
        case 2u: { dir = vec2<i32>(-1, 0); }
        case 3u: { dir = vec2<i32>(1, 0); }
        default: {}
    }
    let p = vec2<i32>(x, y);
    if (a & 1u) == 1u {
        return p + dir * (3 + 2 * i32(s));
    }
    if s == 0u {
        return p + dir;
    }
    let i = i32((s - 1u) / 2u);
    let side = select(-1 - i, 1 + i, ((s - 1u) & 1u) == 1u);
    if dir.x == 0 {
        return vec2<i32>(x + side, y + dir.y * (2 + i));
    }
    return vec2<i32>(x + dir.x * (2 + i), y + side);
}

// The top-K lists of the 8 candidate rows, row a in [8a, 8a + 8). Module-scope and indexed by
// row rather than `&tops[a]`: naga 30's SPIR-V backend panics on a pointer to an element of a
// local array passed to a function ("Expression [..] is not cached").
var<private> cand_top: array<f32, 64>;
var<private> cand_top_n: array<u32, 8>;

fn cand_topk_insert(a: u32, c: f32, k: u32) {
    let base = a * 8u;
    var i = min(cand_top_n[a], k);
    if i == k && c >= cand_top[base + k - 1u] {
        return;
    }
    if i == k {
        i -= 1u;
    }
    while i > 0u && cand_top[base + i - 1u] > c {
        cand_top[base + i] = cand_top[base + i - 1u];
        i -= 1u;
    }
    cand_top[base + i] = c;
    cand_top_n[a] = min(cand_top_n[a] + 1u, k);
}

fn cand_topk_mean(a: u32) -> f32 {
    let n = cand_top_n[a];
    if n == 0u {
        return MAX_COST;
    }
    var sum = 0.0;
    for (var i = 0u; i < n; i++) {
        sum += cand_top[a * 8u + i];
    }
    return sum / f32(n);
}

fn area_size(a: u32) -> u32 {
    if problem.params.method == METHOD_DWTA {
        return 1u;
    }
    return select(7u, 11u, (a & 1u) == 1u);
}

// The anchors of pixel i (`prior_anchors`): direction k's digit of the code in extra[i]
// names the anchor ANCHOR_RADII[digit - 1] steps along ANCHOR_DIRECTIONS[k] (as
// `anchor_pixels` in src/acmm/planar.rs).
const ANCHOR_RADII = array<i32, 7>(2, 4, 8, 16, 32, 64, 128);
const ANCHOR_DIRECTIONS = array<vec2<i32>, 8>(vec2<i32>(1, 0), vec2<i32>(1, 1), vec2<i32>(0, 1),
    vec2<i32>(-1, 1), vec2<i32>(-1, 0), vec2<i32>(-1, -1), vec2<i32>(0, -1), vec2<i32>(1, -1));

fn load_anchors(i: u32, x: u32, y: u32) {
    anchor_n = 0u;
    if problem.params.anchors == 0u || problem.params.prior == 0u {
        return;
    }
    let code = u32(extra[i]);
    for (var k = 0u; k < 8u; k++) {
        let digit = (code >> (3u * k)) & 7u;
        if digit != 0u {
            let q = vec2<i32>(i32(x), i32(y)) + ANCHOR_DIRECTIONS[k] * ANCHOR_RADII[digit - 1u];
            anchor_px[anchor_n] = vec2<u32>(q);
            anchor_n += 1u;
        }
    }
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let y = id.y;
    let x = 2u * id.x + ((y + problem.params.color) & 1u);
    if x >= problem.params.width || y >= problem.params.height {
        return;
    }
    let w = i32(problem.params.width);
    let h = i32(problem.params.height);
    let i = y * problem.params.width + x;
    let nsrc = problem.params.num_sources;
    // The prior-assisted pass leaves pixels without a prior alone unless asked to update
    // every pixel (prior = 1, the authors' code).
    if problem.params.prior == 2u && load_prior(i).w <= 0.0 {
        return;
    }
    // Regions' `prior_keep_unseen`: a pixel whose prior plane puts its point in no source's
    // image keeps that plane. No source can score it, and the cost would only pull the pixel
    // to a depth some source sees (as `update_pixel` in src/acmm/cpu/mod.rs).
    if problem.params.prior_keep_unseen == 1u && problem.params.prior != 0u {
        let q = load_prior(i);
        if q.w > 0.0 && !seen_by_a_source(q.w, x, y) {
            store_plane(i, q);
            cost[i] = MAX_COST;
            store_selected(i, 0u);
            for (var j = 0u; j < nsrc; j++) {
                textureStore(weights_out, vec2<u32>(x, y), j, vec4<f32>(0.0));
            }
            aux[i] = WINNER_PRIOR_UNSEEN | (NO_VIEW << 8u) | PRIOR_BIT;
            return;
        }
    }
    let current = load_plane(i);
    let prev_best = (aux[i] >> 8u) & 0xffu;
    load_ref_patch(x, y);
    load_anchors(i, x, y);

    // Adaptive checkerboard sampling: the lowest-cost sample of each area.
    var cand: array<vec4<f32>, 8>;
    var valid: array<bool, 8>;
    for (var a = 0u; a < 8u; a++) {
        var best_cost = 0.0;
        var found = false;
        var best_index = 0u;
        for (var s = 0u; s < area_size(a); s++) {
            let q = area_sample(a, s, i32(x), i32(y));
            if q.x < 0 || q.y < 0 || q.x >= w || q.y >= h {
                continue;
            }
            let qi = u32(q.y) * problem.params.width + u32(q.x);
            if !found || cost[qi] < best_cost {
                found = true;
                best_index = qi;
                best_cost = cost[qi];
            }
        }
        valid[a] = found;
        cand[a] = current;
        if found {
            cand[a] = plane_at_pixel(load_plane(best_index), best_index % problem.params.width,
                best_index / problem.params.width, x, y);
        }
    }

    // Multi-hypothesis joint view selection, one source column at a time; the aggregation
    // sums accumulate in the same order as the CPU reference.
    var num: array<f32, 8>;
    for (var a = 0u; a < 8u; a++) {
        num[a] = 0.0;
        cand_top_n[a] = 0u;
    }
    var num_cur = 0.0;
    var top_cur = topk_new();
    var den = 0.0;
    var mask = 0u;
    var best_view = NO_VIEW;
    var best_weight = 0.0;
    let two_beta2 = 2.0 * problem.params.beta * problem.params.beta;
    for (var j = 0u; j < nsrc; j++) {
        var column: array<f32, 8>;
        var column_sum: array<f32, 8>;
        var good = 0u;
        var bad = 0u;
        var confidence = 0.0;
        for (var a = 0u; a < 8u; a++) {
            column[a] = MAX_COST;
            column_sum[a] = MAX_COST;
            if valid[a] {
                let m = match_cost(j, cand[a]);
                column[a] = m;
                column_sum[a] = combined_cost(m, j, cand[a], x, y);
                if m < problem.params.tau_t {
                    good += 1u;
                    confidence += exp(-(m * m) / two_beta2);
                }
                if m > problem.params.tau1 {
                    bad += 1u;
                }
            }
        }
        var wp = 0.0;
        if problem.params.method != METHOD_DWTA {
            let is_sel = good > problem.params.n1 && bad < problem.params.n2;
            let wj = select(0.0, confidence / f32(good), is_sel);
            let bonus = select(0.0, 1.0, prev_best == j);
            wp = select(0.2 * bonus, (bonus + 1.0) * wj, is_sel);
            if is_sel {
                mask |= 1u << j;
            }
        }
        view_weights[j] = wp;
        textureStore(weights_out, vec2<u32>(x, y), j, vec4<f32>(wp));
        if wp > best_weight {
            best_weight = wp;
            best_view = j;
        }
        den += wp;
        for (var a = 0u; a < 8u; a++) {
            num[a] += wp * column_sum[a];
            cand_topk_insert(a, column_sum[a], problem.params.top_k);
        }
        // A source of weight 0 adds 0 to the weighted sum: its cost is needed only for the
        // top-K mean (DWTA, or no source selected; then computed below).
        if wp > 0.0 || problem.params.method == METHOD_DWTA {
            let m_cur = combined_cost(match_cost(j, current), j, current, x, y);
            num_cur += wp * m_cur;
            topk_insert(&top_cur, m_cur, problem.params.top_k);
        }
    }
    let use_top = problem.params.method == METHOD_DWTA || den <= 0.0;
    if use_top && problem.params.method != METHOD_DWTA {
        for (var j = 0u; j < nsrc; j++) {
            topk_insert(&top_cur, combined_cost(match_cost(j, current), j, current, x, y),
                problem.params.top_k);
        }
    }

    var best_plane = current;
    let current_cost = select(num_cur / den, topk_mean(&top_cur), use_top);
    var best_cost = current_cost;
    var winner = WINNER_KEPT;
    // The planar prior: where the pixel has a prior plane, the largest S wins (as
    // `update_pixel` in src/acmm/cpu.rs); what the lowest cost alone would choose is tracked
    // for the "prior changed the choice" bit.
    let pp = load_prior(i);
    let use_prior = problem.params.prior != 0u && pp.w > 0.0;
    var best_score = 0.0;
    if use_prior {
        best_score = prior_score(current_cost, current, pp);
    }
    var photo_cost = current_cost;
    var photo_winner = WINNER_KEPT;
    for (var a = 0u; a < 8u; a++) {
        // Every candidate in the image votes; only one whose depth at p is in range is adopted.
        if valid[a] && in_depth_range(cand[a].w) {
            let c = select(num[a] / den, cand_topk_mean(a), use_top);
            var better = c < best_cost;
            var sc = 0.0;
            if use_prior {
                sc = prior_score(c, cand[a], pp);
                better = sc > best_score;
            }
            if better {
                best_plane = cand[a];
                best_cost = c;
                winner = a;
                best_score = sc;
            }
            if c < photo_cost {
                photo_cost = c;
                photo_winner = a;
            }
        }
    }

    // Refinement: random and perturbed depth/normal combined with the adopted plane; with a
    // prior the random ones are drawn around the prior plane.
    var s = pixel_stream(x, y);
    let view_ray = ref_ray(f32(x), f32(y));
    let u = stream_next(&s);
    let r1 = stream_next(&s);
    let r2 = stream_next(&s);
    var d_rand = problem.params.depth_min + u * (problem.params.depth_max - problem.params.depth_min);
    var n_rand = vec3<f32>(0.0);
    if use_prior {
        d_rand = clamp(pp.w + (2.0 * u - 1.0) * problem.params.prior_refine_depth
            * problem.params.prior_sigma_depth, problem.params.depth_min, problem.params.depth_max);
        n_rand = perturb_normal(pp.xyz, r1, r2, problem.params.prior_refine_normal_tan, view_ray);
    } else {
        n_rand = random_normal(r1, r2, view_ray);
    }
    let d = best_plane.w;
    let d_pert = clamp(d * (1.0 + (2.0 * stream_next(&s) - 1.0) * problem.params.perturb_depth),
        problem.params.depth_min, problem.params.depth_max);
    let p1 = stream_next(&s);
    let p2 = stream_next(&s);
    let n = best_plane.xyz;
    let n_pert = perturb_normal(n, p1, p2, problem.params.perturb_normal_tan, view_ray);
    var refine: array<vec4<f32>, 6>;
    refine[0] = vec4<f32>(n, d_rand);
    refine[1] = vec4<f32>(n_rand, d);
    refine[2] = vec4<f32>(n_rand, d_rand);
    refine[3] = vec4<f32>(n, d_pert);
    refine[4] = vec4<f32>(n_pert, d);
    refine[5] = vec4<f32>(n_pert, d_pert);
    for (var r = 0u; r < 6u; r++) {
        var acc = 0.0;
        var top = topk_new();
        for (var j = 0u; j < nsrc; j++) {
            // Zero-weight sources change nothing unless the top-K mean decides.
            let wj = view_weights[j];
            if wj > 0.0 || use_top {
                let m = combined_cost(match_cost(j, refine[r]), j, refine[r], x, y);
                acc += wj * m;
                topk_insert(&top, m, problem.params.top_k);
            }
        }
        let c = select(acc / den, topk_mean(&top), use_top);
        var better = c < best_cost;
        var sc = 0.0;
        if use_prior {
            // Starts from S of the plane adopted so far, never from 0.
            sc = prior_score(c, refine[r], pp);
            better = sc > best_score;
        }
        if better {
            best_plane = refine[r];
            best_cost = c;
            winner = 9u + r;
            best_score = sc;
        }
        if c < photo_cost {
            photo_cost = c;
            photo_winner = 9u + r;
        }
    }
    var flipped = 0u;
    if use_prior && photo_winner != winner {
        flipped = PRIOR_BIT;
    }

    // The detail restorer's pass (Sec. 5.2, started from the upsampled planes) keeps the
    // lowest cost C_photo found; gated (restorer = 1), the basic model's best plane replaces
    // the pixel's only where its cost beats C_init by xi.
    var replaced = 0u;
    if problem.params.restorer != 0u {
        let n = problem.params.width * problem.params.height;
        extra[n + i] = min(extra[n + i], best_cost);
    }
    if problem.params.restorer == 1u {
        let beats = best_cost < extra[i] - problem.params.xi;
        if !beats {
            best_plane = current;
            best_cost = current_cost;
            winner = WINNER_KEPT;
        }
        replaced = aux[i] & REPLACED_BIT;
        if beats && winner != WINNER_KEPT {
            replaced = REPLACED_BIT;
        }
    }

    store_plane(i, best_plane);
    cost[i] = best_cost;
    store_selected(i, mask);
    aux[i] = winner | (best_view << 8u) | replaced | flipped;
}
