// The planar prior of ACMP / ACMMP (ACMP-REFERENCE.md §2-3), its three per-element passes:
// `support_points` picks each grid cell's credible support point (when `consistency` > 0 only
// among the pixels whose least reprojection error over the sources, extra[n, 2n), is below
// it), `rasterise` labels every pixel centre with the last triangle of the (host-side)
// Delaunay triangulation that covers it, `prior_plane` gives every pixel its triangle's plane
// (normal, depth along its ray; past the hull, with `extend`, its cell's plane; in a flat
// region, with `prior_regions`, the region's plane before any triangle). CPU reference: `support_points` (with `consistency_errors`),
// `rasterise`, `prior_planes` in src/acmm/planar.rs.

struct Planar {
    // Reference intrinsics fx, fy, cx, cy.
    k: vec4<f32>,
    width: u32,
    height: u32,
    cell: u32,
    cells_x: u32,
    cells_y: u32,
    num_triangles: u32,
    depth_min: f32,
    depth_max: f32,
    threshold: f32,
    // Largest least reprojection error of a support point, pixels (0: unchecked).
    consistency: f32,
    // The first pixel of the second window of the planes and prior planes (as `split` in
    // shared/problem.wgsl).
    split: u32,
    // 1: after the triangles, one plane per grid cell (row by row) for the pixels no
    // triangle covers (the prior past the hull, `prior_extend`).
    extend: u32,
    // Pixels whose least reprojection error (extra[n, 2n)) is below this get no prior
    // (`prior_lock`; 0: none).
    lock: f32,
    // 1: weak pixels look for anchors (`prior_anchors`; strong = least reprojection error
    // below `consistency`, depth in range), written as codes to extra[0, n).
    anchors: u32,
    anchor_inliers: u32,
    anchor_tolerance: f32,
    // > 0: a cell without a credible point takes its lowest-cost pixel whose window is flat
    // (extra[0, n) below FLAT_WINDOW_STD) when that cost is below this (`prior_flat_points`).
    flat_cost: f32,
    // 1: each record's normal.w counts the cell's pixels whose window is flat (extra[0, n)
    // below FLAT_WINDOW_STD), every pixel, with a point or not (`prior_regions`).
    count_flat: u32,
    // 1: the cell's point is its credible pixel of lowest confirmation key (extra[n, 2n),
    // `prior_confirmed_points`), then lowest cost, instead of its lowest-cost pixel.
    confirmed: u32,
    // With `confirmed`, > 0: rank by cost + key x this (one over the keys' scale, a power of
    // two), HPM-MVS++'s support score cost - confidence offset by the sources
    // (`prior_confidence_score`); 0: by key, then cost.
    score_weight: f32,
}

// Keep in sync with `FLAT_WINDOW_STD` in src/acmm/planar.rs.
const FLAT_WINDOW_STD: f32 = 3.0;

// Keep in sync with `SupportRecord` in src/acmm/planar.rs.
struct Support {
    // x, y, depth, cost; zeros where the cell has none
    point: vec4<f32>,
    // the point's own normal
    normal: vec4<f32>,
}

// Keep in sync with `GpuTriangle` in src/acmm/planar.rs.
struct Triangle {
    // x0, y0, x1, y1
    a: vec4<i32>,
    // x2, y2, kept (1; a cell's entry: 2, its flat region's plane, before any triangle) or
    // dropped (0), unused
    b: vec4<i32>,
    // n xyz, w: n . X + w = 0 in the reference camera frame
    plane: vec4<f32>,
}

const NO_TRIANGLE: f32 = 0.0;
const DROPPED_TRIANGLE: f32 = -1.0;
const OUT_OF_RANGE: f32 = -2.0;
const LOCKED: f32 = -3.0;
const NOT_HELD: f32 = -4.0;
// Keep in sync with `REGION_PLANE` in src/acmm/planar.rs.
const REGION_PLANE: i32 = 2;

@group(0) @binding(0) var<storage, read> planar: Planar;
// The planes, in two windows (pixels [0, split) and [split, n)): no binding past 8 B a pixel.
@group(0) @binding(1) var<storage, read> plane_lo: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> plane_hi: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> cost: array<f32>;
// One per cell, row by row.
@group(0) @binding(3) var<storage, read_write> points: array<Support>;
@group(0) @binding(4) var<storage, read> triangles: array<Triangle>;
// Per pixel: 1 + the last covering triangle, 0 none.
@group(0) @binding(5) var<storage, read_write> labels: array<atomic<u32>>;
// Per pixel: the prior plane (normal, depth); depth <= 0 says why there is none.
@group(0) @binding(6) var<storage, read_write> prior_lo: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> prior_hi: array<vec4<f32>>;
// The solver's two extra maps; [n, 2n): each pixel's least reprojection error over its
// sources (the multi-view check, written just before `support_points`).
// With `anchors`, [0, n) receives every pixel's anchor code (0: none).
@group(0) @binding(7) var<storage, read_write> extra: array<f32>;

fn store_prior(i: u32, h: vec4<f32>) {
    if i < planar.split {
        prior_lo[i] = h;
    } else {
        prior_hi[i - planar.split] = h;
    }
}

// The lowest-cost pixel of the cell (first in row order on ties) among those multi-view
// consistent (least reprojection error below `consistency`; all pixels when it is 0), kept
// when its cost is below the threshold and its depth is in the view's range; failing that,
// with `flat_cost`, the lowest-cost such pixel whose window is flat (extra[0, n)), kept when
// its cost is below `flat_cost` and its depth in the range.
fn plane_at(i: u32) -> vec4<f32> {
    if i < planar.split {
        return plane_lo[i];
    }
    return plane_hi[i - planar.split];
}

fn credible_point(i: u32, c: f32, limit: f32) -> bool {
    let p = plane_at(i);
    return c < limit && p.w >= planar.depth_min && p.w <= planar.depth_max;
}

// With `confirmed`: whether pixel i ranks before the chosen b (none when !found): lower
// confirmation key, then lower cost (with `score_weight`, lower cost + key x score_weight);
// the earlier pixel keeps a tie.
fn ranks_before(i: u32, b: u32, found: bool) -> bool {
    let n = planar.width * planar.height;
    if found && planar.score_weight > 0.0 {
        return cost[i] + extra[n + i] * planar.score_weight
            < cost[b] + extra[n + b] * planar.score_weight;
    }
    return !found || extra[n + i] < extra[n + b]
        || (extra[n + i] == extra[n + b] && cost[i] < cost[b]);
}

// `support_points` with `confirmed` (`confirmed_points` in src/acmm/planar.rs): among the
// cell's consistent pixels whose depth is in range, the credible one (cost below the
// threshold) that ranks first; failing that, with `flat_cost`, the flat-window one of cost
// below it that ranks first.
fn confirmed_point(cell: u32) -> Support {
    let x0 = (cell % planar.cells_x) * planar.cell;
    let y0 = (cell / planar.cells_x) * planar.cell;
    let n = planar.width * planar.height;
    var best = 0u;
    var found = false;
    var flat = 0u;
    var flat_found = false;
    var flat_windows = 0u;
    for (var y = y0; y < min(y0 + planar.cell, planar.height); y++) {
        for (var x = x0; x < min(x0 + planar.cell, planar.width); x++) {
            let i = y * planar.width + x;
            let is_flat = extra[i] < FLAT_WINDOW_STD;
            if planar.count_flat != 0u && is_flat {
                flat_windows += 1u;
            }
            let d = plane_at(i).w;
            if !(extra[n + i] < planar.consistency) || d < planar.depth_min
                || d > planar.depth_max {
                continue;
            }
            if cost[i] < planar.threshold && ranks_before(i, best, found) {
                best = i;
                found = true;
            }
            if planar.flat_cost > 0.0 && is_flat && cost[i] < planar.flat_cost
                && ranks_before(i, flat, flat_found) {
                flat = i;
                flat_found = true;
            }
        }
    }
    var out = Support(vec4<f32>(0.0), vec4<f32>(0.0));
    if found || flat_found {
        let chosen = select(flat, best, found);
        let p = plane_at(chosen);
        out = Support(vec4<f32>(f32(chosen % planar.width), f32(chosen / planar.width), p.w,
            cost[chosen]), vec4<f32>(p.xyz, 0.0));
    }
    if planar.count_flat != 0u {
        out.normal.w = f32(flat_windows);
    }
    return out;
}

@compute @workgroup_size(64)
fn support_points(@builtin(global_invocation_id) id: vec3<u32>) {
    let cell = id.x;
    if cell >= planar.cells_x * planar.cells_y {
        return;
    }
    if planar.confirmed != 0u {
        points[cell] = confirmed_point(cell);
        return;
    }
    let x0 = (cell % planar.cells_x) * planar.cell;
    let y0 = (cell / planar.cells_x) * planar.cell;
    let errors = planar.width * planar.height;
    var best = 0u;
    var found = false;
    var best_cost = 0.0;
    var flat = 0u;
    var flat_found = false;
    var flat_cost = 0.0;
    var flat_windows = 0u;
    for (var y = y0; y < min(y0 + planar.cell, planar.height); y++) {
        for (var x = x0; x < min(x0 + planar.cell, planar.width); x++) {
            let i = y * planar.width + x;
            if planar.count_flat != 0u && extra[i] < FLAT_WINDOW_STD {
                flat_windows += 1u;
            }
            if planar.consistency > 0.0 && !(extra[errors + i] < planar.consistency) {
                continue;
            }
            if !found || cost[i] < best_cost {
                found = true;
                best_cost = cost[i];
                best = i;
            }
            if planar.flat_cost > 0.0 && extra[i] < FLAT_WINDOW_STD
                && (!flat_found || cost[i] < flat_cost) {
                flat_found = true;
                flat_cost = cost[i];
                flat = i;
            }
        }
    }
    var out = Support(vec4<f32>(0.0), vec4<f32>(0.0));
    var chosen = 0u;
    var chosen_cost = 0.0;
    var keep = false;
    if found && credible_point(best, best_cost, planar.threshold) {
        chosen = best;
        chosen_cost = best_cost;
        keep = true;
    } else if flat_found && credible_point(flat, flat_cost, planar.flat_cost) {
        chosen = flat;
        chosen_cost = flat_cost;
        keep = true;
    }
    if keep {
        let p = plane_at(chosen);
        out = Support(vec4<f32>(f32(chosen % planar.width), f32(chosen / planar.width), p.w,
            chosen_cost), vec4<f32>(p.xyz, 0.0));
    }
    if planar.count_flat != 0u {
        out.normal.w = f32(flat_windows);
    }
    points[cell] = out;
}

fn edge(a: vec2<i32>, b: vec2<i32>, p: vec2<i32>) -> i32 {
    return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

// One invocation per triangle: every pixel centre of its bounding box that it covers, edges
// included, takes the largest label (the later triangle wins a shared edge). Integer edge
// functions: the same pixels on every device.
@compute @workgroup_size(64)
fn rasterise(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = id.x;
    if t >= planar.num_triangles {
        return;
    }
    let tri = triangles[t];
    let v0 = tri.a.xy;
    let v1 = tri.a.zw;
    let v2 = tri.b.xy;
    let area = edge(v0, v1, v2);
    if area == 0 {
        return;
    }
    let x0 = max(min(min(v0.x, v1.x), v2.x), 0);
    let x1 = min(max(max(v0.x, v1.x), v2.x), i32(planar.width) - 1);
    let y0 = max(min(min(v0.y, v1.y), v2.y), 0);
    let y1 = min(max(max(v0.y, v1.y), v2.y), i32(planar.height) - 1);
    for (var y = y0; y <= y1; y++) {
        for (var x = x0; x <= x1; x++) {
            let p = vec2<i32>(x, y);
            let e0 = edge(v1, v2, p);
            let e1 = edge(v2, v0, p);
            let e2 = edge(v0, v1, p);
            var inside = e0 >= 0 && e1 >= 0 && e2 >= 0;
            if area < 0 {
                inside = e0 <= 0 && e1 <= 0 && e2 <= 0;
            }
            if inside {
                atomicMax(&labels[u32(y) * planar.width + u32(x)], t + 1u);
            }
        }
    }
}

// Anchors (`prior_anchors`; CPU reference `anchor_plane` in src/acmm/planar.rs, operation for
// operation): along 8 directions at 2, 4, ... 128 px the nearest strong pixel; every triple
// whose image triangle holds the pixel proposes the plane through the back-projected
// points; the plane most of them agree with (first triple on ties) wins with at least
// `anchor_inliers`. Code: direction k's digit (radius index + 1) in bits 3k..3k+3.
const ANCHOR_RADII = array<i32, 7>(2, 4, 8, 16, 32, 64, 128);
const ANCHOR_DIRECTIONS = array<vec2<i32>, 8>(vec2<i32>(1, 0), vec2<i32>(1, 1), vec2<i32>(0, 1),
    vec2<i32>(-1, 1), vec2<i32>(-1, 0), vec2<i32>(-1, -1), vec2<i32>(0, -1), vec2<i32>(1, -1));

struct AnchorFit {
    code: u32,
    plane: vec4<f32>,
}

fn load_plane_at(i: u32) -> vec4<f32> {
    if i < planar.split {
        return plane_lo[i];
    }
    return plane_hi[i - planar.split];
}

fn pixel_ray(x: f32, y: f32) -> vec3<f32> {
    let k = planar.k;
    return vec3<f32>((x - k.z) / k.x, (y - k.w) / k.y, 1.0);
}

fn is_strong(i: u32) -> bool {
    let d = load_plane_at(i).w;
    return extra[planar.width * planar.height + i] < planar.consistency
        && d >= planar.depth_min && d <= planar.depth_max;
}

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn anchor_fit(x: u32, y: u32) -> AnchorFit {
    var none = AnchorFit(0u, vec4<f32>(0.0));
    let w = i32(planar.width);
    let h = i32(planar.height);
    if is_strong(y * planar.width + x) {
        return none;
    }
    var digit: array<u32, 8>;
    var px: array<vec2<i32>, 8>;
    var pt: array<vec3<f32>, 8>;
    for (var k = 0u; k < 8u; k++) {
        digit[k] = 0u;
        px[k] = vec2<i32>(0);
        pt[k] = vec3<f32>(0.0);
        let d = ANCHOR_DIRECTIONS[k];
        for (var ri = 0u; ri < 7u; ri++) {
            let q = vec2<i32>(i32(x), i32(y)) + d * ANCHOR_RADII[ri];
            if q.x < 0 || q.y < 0 || q.x >= w || q.y >= h {
                break;
            }
            let qi = u32(q.y) * planar.width + u32(q.x);
            if is_strong(qi) {
                let rq = pixel_ray(f32(q.x), f32(q.y));
                let dq = load_plane_at(qi).w;
                digit[k] = ri + 1u;
                px[k] = q;
                pt[k] = vec3<f32>(dq * rq.x, dq * rq.y, dq * rq.z);
                break;
            }
        }
    }
    let rp = pixel_ray(f32(x), f32(y));
    let p = vec2<i32>(i32(x), i32(y));
    var found = false;
    var best_count = 0u;
    var best = none;
    for (var i = 0u; i < 8u; i++) {
        if digit[i] == 0u {
            continue;
        }
        for (var j = i + 1u; j < 8u; j++) {
            if digit[j] == 0u {
                continue;
            }
            for (var l = j + 1u; l < 8u; l++) {
                if digit[l] == 0u {
                    continue;
                }
                let area = edge(px[i], px[j], px[l]);
                if area == 0 {
                    continue;
                }
                let e0 = edge(px[j], px[l], p);
                let e1 = edge(px[l], px[i], p);
                let e2 = edge(px[i], px[j], p);
                var inside = e0 >= 0 && e1 >= 0 && e2 >= 0;
                if area < 0 {
                    inside = e0 <= 0 && e1 <= 0 && e2 <= 0;
                }
                if !inside {
                    continue;
                }
                let xi = pt[i];
                let a = pt[j] - xi;
                let b = pt[l] - xi;
                let c = vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
                let len = sqrt(dot3(c, c));
                if len <= 0.0 {
                    continue;
                }
                var n = vec3<f32>(c.x / len, c.y / len, c.z / len);
                if dot3(n, rp) > 0.0 {
                    n = -n;
                }
                let off = -dot3(n, xi);
                let den = dot3(n, rp);
                if den >= 0.0 {
                    continue;
                }
                let dp = -off / den;
                if !(dp >= planar.depth_min && dp <= planar.depth_max) {
                    continue;
                }
                var code = 0u;
                var count = 0u;
                for (var k = 0u; k < 8u; k++) {
                    if digit[k] == 0u {
                        continue;
                    }
                    let rk = pixel_ray(f32(px[k].x), f32(px[k].y));
                    let dk = dot3(n, rk);
                    if dk < 0.0 && abs(-off / dk - pt[k].z) <= planar.anchor_tolerance * pt[k].z {
                        code |= digit[k] << (3u * k);
                        count += 1u;
                    }
                }
                if !found || count > best_count {
                    found = true;
                    best_count = count;
                    best = AnchorFit(code, vec4<f32>(n, dp));
                }
            }
        }
    }
    if !found || best_count < planar.anchor_inliers {
        return none;
    }
    return best;
}

// The pixel's prior plane (none when it is locked): its triangle's normal and that plane's depth along the pixel's
// ray, d = -w / (n . K^-1 p~), where it lies in the depth range.
@compute @workgroup_size(8, 8)
fn prior_plane(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if x >= planar.width || y >= planar.height {
        return;
    }
    let i = y * planar.width + x;
    var fit = AnchorFit(0u, vec4<f32>(0.0));
    if planar.anchors != 0u {
        fit = anchor_fit(x, y);
        extra[i] = f32(fit.code);
    }
    if planar.lock > 0.0 && extra[planar.width * planar.height + i] < planar.lock {
        store_prior(i, vec4<f32>(0.0, 0.0, 0.0, LOCKED));
        return;
    }
    // A weak pixel with anchors takes the plane they agree on.
    if fit.code != 0u {
        store_prior(i, fit.plane);
        return;
    }
    let label = atomicLoad(&labels[i]);
    var t: Triangle;
    var region = false;
    if planar.extend != 0u {
        // A flat region's plane takes its cells before any triangle.
        t = triangles[planar.num_triangles + (y / planar.cell) * planar.cells_x + x / planar.cell];
        region = t.b.z == REGION_PLANE;
    }
    if region {
        // t is the region's plane.
    } else if label == 0u {
        // Past the hull: the cell's plane, when there are such planes and it has one.
        if planar.extend == 0u {
            store_prior(i, vec4<f32>(0.0, 0.0, 0.0, NO_TRIANGLE));
            return;
        }
        t = triangles[planar.num_triangles + (y / planar.cell) * planar.cells_x + x / planar.cell];
        if t.b.z == 0 {
            store_prior(i, vec4<f32>(0.0, 0.0, 0.0, NO_TRIANGLE));
            return;
        }
    } else {
        t = triangles[label - 1u];
        if t.b.z == 0 {
            store_prior(i, vec4<f32>(0.0, 0.0, 0.0, DROPPED_TRIANGLE));
            return;
        }
    }
    let k = planar.k;
    let r = vec3<f32>((f32(x) - k.z) / k.x, (f32(y) - k.w) / k.y, 1.0);
    let n = t.plane.xyz;
    let den = n.x * r.x + n.y * r.y + n.z * r.z;
    var d = 0.0;
    if den < 0.0 {
        d = -t.plane.w / den;
    }
    if d >= planar.depth_min && d <= planar.depth_max {
        store_prior(i, vec4<f32>(n, d));
    } else {
        store_prior(i, vec4<f32>(n, OUT_OF_RANGE));
    }
}

// After a view's prior-assisted pass, where its prior holds in the geometric passes
// (Regions' `prior_region_hold`): a pixel keeps its prior plane only where its grid cell's
// entry is its flat region's plane (the entries `prior_plane` read, still in `triangles`);
// the others get none. CPU reference: `held_prior` in src/acmm/planar.rs.
@compute @workgroup_size(8, 8)
fn keep_regions(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if x >= planar.width || y >= planar.height {
        return;
    }
    let t = triangles[planar.num_triangles + (y / planar.cell) * planar.cells_x + x / planar.cell];
    if planar.extend == 0u || t.b.z != REGION_PLANE {
        store_prior(y * planar.width + x, vec4<f32>(0.0, 0.0, 0.0, NOT_HELD));
    }
}
