// Geometric consistency (paper Sec. 5.1): the forward-backward reprojection error of a plane
// through a source's current depth map, and what an aggregation sums per source, m or
// m + lambda * error (CPU references: `reprojection_error`, `combined_cost` in
// src/acmm/cpu/mod.rs).

// Where the point of pixel (x, y) at depth d lands in source j: (u, v, 1), or z = 0 where it
// lands behind the source or outside its image. CPU reference: `project_to_source`.
fn project_to_source(j: u32, d: f32, x: u32, y: u32) -> vec3<f32> {
    let src = problem.sources[j];
    let p = ref_ray(f32(x), f32(y)) * d;
    let ps = vec3<f32>(dot(src.r0.xyz, p) + src.t.x, dot(src.r1.xyz, p) + src.t.y,
        dot(src.r2.xyz, p) + src.t.z);
    if ps.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    let ks = src.k;
    let qu = ks.x * ps.x / ps.z + ks.z;
    let qv = ks.y * ps.y / ps.z + ks.w;
    let w = f32(src.size.x);
    let h = f32(src.size.y);
    if !(qu >= -0.5 && qv >= -0.5 && qu < w - 0.5 && qv < h - 0.5) {
        return vec3<f32>(0.0);
    }
    return vec3<f32>(qu, qv, 1.0);
}

// Whether some source's image holds the point of pixel (x, y) at depth d (Regions'
// `prior_keep_unseen`). CPU reference: `seen_by_a_source`.
fn seen_by_a_source(d: f32, x: u32, y: u32) -> bool {
    for (var j = 0u; j < problem.params.num_sources; j++) {
        if project_to_source(j, d, x, y).z != 0.0 {
            return true;
        }
    }
    return false;
}

// The round trip of pixel (x, y) at hyp's depth through source j's depth map: the point it
// comes back as in the reference frame (w = 1), or w = 0 where there is none (behind a
// camera, outside the source, no depth there). CPU reference: `round_trip`.
fn round_trip(j: u32, hyp: vec4<f32>, x: u32, y: u32) -> vec4<f32> {
    // The projection of `project_to_source`, written out: called from here, llvmpipe
    // compiles it to other bits, and ACMM's maps would change with it.
    let src = problem.sources[j];
    let p = ref_ray(f32(x), f32(y)) * hyp.w;
    let ps = vec3<f32>(dot(src.r0.xyz, p) + src.t.x, dot(src.r1.xyz, p) + src.t.y,
        dot(src.r2.xyz, p) + src.t.z);
    if ps.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let ks = src.k;
    let qu = ks.x * ps.x / ps.z + ks.z;
    let qv = ks.y * ps.y / ps.z + ks.w;
    let w = f32(src.size.x);
    let h = f32(src.size.y);
    if !(qu >= -0.5 && qv >= -0.5 && qu < w - 0.5 && qv < h - 0.5) {
        return vec4<f32>(0.0);
    }
    let qx = min(u32(floor(qu + 0.5)), src.size.x - 1u);
    let qy = min(u32(floor(qv + 0.5)), src.size.y - 1u);
    let d = textureLoad(depth_layers, vec2<u32>(qx, qy), src.size.w, 0).x;
    if d <= 0.0 {
        return vec4<f32>(0.0);
    }
    let xs = vec3<f32>((qu - ks.z) / ks.x * d, (qv - ks.w) / ks.y * d, d);
    let u = xs - src.t.xyz;
    let xr = vec3<f32>(src.r0.x * u.x + src.r1.x * u.y + src.r2.x * u.z,
        src.r0.y * u.x + src.r1.y * u.y + src.r2.y * u.z,
        src.r0.z * u.x + src.r1.z * u.y + src.r2.z * u.z);
    if xr.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(xr, 1.0);
}

// How far a round trip's point (w = 1) lands from pixel (x, y), truncated at delta (delta
// where there is none).
fn round_trip_error(xr: vec4<f32>, x: u32, y: u32) -> f32 {
    if xr.w == 0.0 {
        return problem.params.delta;
    }
    let k = problem.params.k;
    let du = k.x * xr.x / xr.z + k.z - f32(x);
    let dv = k.y * xr.y / xr.z + k.w - f32(y);
    return min(sqrt(du * du + dv * dv), problem.params.delta);
}

// The forward-backward reprojection error of source j in pixels (paper Sec. 5.1).
fn reprojection_error(j: u32, hyp: vec4<f32>, x: u32, y: u32) -> f32 {
    return round_trip_error(round_trip(j, hyp, x, y), x, y);
}

// Whether source j confirms the pixel's depth: the round trip comes back within limit px
// and within `confirm_depth` of the depth, relative (fusion's reprojection and depth
// checks). CPU reference: `cpu::Confirmation::confirms`.
fn source_confirms(j: u32, hyp: vec4<f32>, x: u32, y: u32, limit: f32) -> bool {
    let xr = round_trip(j, hyp, x, y);
    return xr.w != 0.0 && round_trip_error(xr, x, y) < limit
        && abs(xr.z - hyp.w) < problem.params.confirm_depth * hyp.w;
}

// How closely source j confirms the pixel's depth (HPM-MVS++'s confidence term without the
// normal's): exp(-(e + limit |dd| / (confirm_depth d))) where `source_confirms` holds, 0
// elsewhere. CPU reference: `cpu::Confirmation::confidence`.
fn source_confidence(j: u32, hyp: vec4<f32>, x: u32, y: u32, limit: f32) -> f32 {
    let xr = round_trip(j, hyp, x, y);
    if xr.w == 0.0 {
        return 0.0;
    }
    let e = round_trip_error(xr, x, y);
    let dd = abs(xr.z - hyp.w);
    let band = problem.params.confirm_depth * hyp.w;
    if e < limit && dd < band {
        return exp(-(e + limit * dd / band));
    }
    return 0.0;
}

// What an aggregation sums for source j: m, or m + lambda * reprojection error.
fn combined_cost(m: f32, j: u32, hyp: vec4<f32>, x: u32, y: u32) -> f32 {
    if problem.params.geometric == 1u {
        return m + problem.params.lambda * reprojection_error(j, hyp, x, y);
    }
    return m;
}
