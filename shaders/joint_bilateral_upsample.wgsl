// Joint bilateral upsampling (paper Sec. 5.1, after Kopf et al. 2007): the coarse level's
// planes (in `prior`, coarse_width x coarse_height, intrinsics coarse_k) become this level's
// (`plane`), guided by this level's reference intensities; each coarse plane is evaluated
// along the fine pixel's ray. CPU reference: `joint_bilateral_upsample` in
// src/acmm/multiscale.rs.
#import rng
#import problem

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    if x >= problem.params.width || y >= problem.params.height {
        return;
    }
    let cw = problem.params.coarse_width;
    let ch = problem.params.coarse_height;
    let fw = problem.params.width;
    let fh = problem.params.height;
    let sx = f32(cw) / f32(fw);
    let sy = f32(ch) / f32(fh);
    let r = i32(problem.params.jbu_radius);
    let two_s2 = 2.0 * problem.params.jbu_sigma_spatial * problem.params.jbu_sigma_spatial;
    let two_r2 = 2.0 * problem.params.jbu_sigma_range * problem.params.jbu_sigma_range;
    let px = (f32(x) + 0.5) * sx - 0.5;
    let py = (f32(y) + 0.5) * sy - 0.5;
    let cx = i32(floor(px + 0.5));
    let cy = i32(floor(py + 0.5));
    let g0 = textureLoad(layers, vec2<u32>(x, y), problem.params.ref_layer, 0).x;
    let rf = ref_ray(f32(x), f32(y));
    let kc = problem.params.coarse_k;
    var wsum = 0.0;
    var d = 0.0;
    var n = vec3<f32>(0.0);
    for (var qy = cy - r; qy <= cy + r; qy++) {
        for (var qx = cx - r; qx <= cx + r; qx++) {
            if qx < 0 || qy < 0 || qx >= i32(cw) || qy >= i32(ch) {
                continue;
            }
            let q = load_prior(u32(qy) * cw + u32(qx));
            if q.w <= 0.0 {
                continue;
            }
            let fx = u32(clamp(i32(floor((f32(qx) + 0.5) / sx - 0.5 + 0.5)), 0, i32(fw) - 1));
            let fy = u32(clamp(i32(floor((f32(qy) + 0.5) / sy - 0.5 + 0.5)), 0, i32(fh) - 1));
            let gq = textureLoad(layers, vec2<u32>(fx, fy), problem.params.ref_layer, 0).x;
            let dx = f32(qx) - px;
            let dy = f32(qy) - py;
            let dg = g0 - gq;
            let w = exp(-(dx * dx + dy * dy) / two_s2) * exp(-(dg * dg) / two_r2);
            let rq = vec3<f32>((f32(qx) - kc.z) / kc.x, (f32(qy) - kc.w) / kc.y, 1.0);
            let num = q.w * (q.x * rq.x + q.y * rq.y + q.z * rq.z);
            let den = q.x * rf.x + q.y * rf.y + q.z * rf.z;
            var along = -1.0;
            if den < 0.0 {
                along = num / den;
            }
            var dq = q.w;
            if along > 0.5 * q.w && along < 1.5 * q.w {
                dq = along;
            }
            wsum += w;
            d += w * dq;
            n.x += w * q.x;
            n.y += w * q.y;
            n.z += w * q.z;
        }
    }
    let i = y * fw + x;
    if wsum <= 0.0 {
        store_plane(i, vec4<f32>(0.0, 0.0, -1.0, 0.0));
        return;
    }
    let len = sqrt(dot(n, n));
    var nn = vec3<f32>(0.0, 0.0, -1.0);
    if len > 0.0 {
        nn = n / len;
    }
    if nn.x * rf.x + nn.y * rf.y + nn.z * rf.z > 0.0 {
        nn = -nn;
    }
    store_plane(i, vec4<f32>(nn, d / wsum));
}
