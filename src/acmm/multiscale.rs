//! Multi-scale pieces of ACMM (paper Sec. 5) on the CPU: the pyramid, joint bilateral
//! upsampling of planes and the detail restorer. The GPU passes
//! (shaders/joint_bilateral_upsample.wgsl, detail_restorer.wgsl) mirror these.

use rayon::prelude::*;

use super::cpu::{MAX_COST, TopK, ncc_cost, ray, ref_patch};
use super::params::{Method, Params};
use super::problem::{ViewProblem, ViewState};

/// Scale factors of the pyramid levels, coarsest first; the last is 1 (the input size).
/// The paper's rule: k levels, each η times the next. The original code's rule
/// (`params.original_pyramid`): halve until the long side is at most 1000 px. With
/// `params.coarsest_size`: levels η apart until the coarsest long side is at most that.
pub fn pyramid_scales(params: &Params, method: Method, long_side: u32) -> Vec<f64> {
    if !method.is_multiscale() {
        return vec![1.0];
    }
    let levels_until = |limit: f64, eta: f64| {
        let mut k = 1;
        let mut side = long_side as f64;
        while side > limit && k < 8 {
            side *= eta;
            k += 1;
        }
        k
    };
    let deep = method.deepens_pyramid(params);
    let k = if deep {
        // Resolved from the images into `scales` (`acmm::pyramid_depth::resolve`).
        params.scales.max(1)
    } else if params.original_pyramid {
        levels_until(1000.0, 0.5)
    } else if params.coarsest_size > 0 {
        levels_until(params.coarsest_size as f64, params.eta as f64)
    } else {
        params.scales.max(1)
    };
    let eta = if params.original_pyramid && !deep {
        0.5
    } else {
        params.eta as f64
    };
    (0..k).map(|l| eta.powi((k - 1 - l) as i32)).collect()
}

/// Joint bilateral upsampling (Kopf et al. 2007) of planes from a `cw x ch` level to the
/// `fw x fh` level whose intensities are `guide`: each fine pixel averages the coarse planes
/// of a (2r+1)² window around its position on the coarse grid, weighted by
/// exp(-|p↓ - q|² / 2σs²) (coarse pixels) times exp(-(I(p) - I(q↑))² / 2σr²) (fine
/// intensity at p and at q's position on the fine grid). Depth is averaged, normals are
/// averaged and renormalised (flipped to face the camera if they end up facing away).
/// Coarse pixels without depth (<= 0) do not vote; a pixel with no voter gets depth 0.
#[allow(clippy::too_many_arguments)]
pub fn joint_bilateral_upsample(
    coarse: &[[f32; 4]],
    cw: u32,
    ch: u32,
    guide: &[f32],
    fw: u32,
    fh: u32,
    k_coarse: [f32; 4],
    k_fine: [f32; 4],
    params: &Params,
) -> Vec<[f32; 4]> {
    let sx = cw as f32 / fw as f32;
    let sy = ch as f32 / fh as f32;
    let r = params.jbu_radius as i32;
    let two_s2 = 2.0 * params.jbu_sigma_spatial * params.jbu_sigma_spatial;
    let two_r2 = 2.0 * params.jbu_sigma_range * params.jbu_sigma_range;
    (0..fw * fh)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % fw, i / fw);
            jbu_pixel(
                coarse, cw, ch, guide, fw, fh, k_coarse, k_fine, x, y, sx, sy, r, two_s2, two_r2,
            )
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn jbu_pixel(
    coarse: &[[f32; 4]],
    cw: u32,
    ch: u32,
    guide: &[f32],
    fw: u32,
    fh: u32,
    k_coarse: [f32; 4],
    k_fine: [f32; 4],
    x: u32,
    y: u32,
    sx: f32,
    sy: f32,
    r: i32,
    two_s2: f32,
    two_r2: f32,
) -> [f32; 4] {
    // The fine pixel's position on the coarse grid (borders stay borders, camera.rs).
    let px = (x as f32 + 0.5) * sx - 0.5;
    let py = (y as f32 + 0.5) * sy - 0.5;
    let cx = (px + 0.5).floor() as i32;
    let cy = (py + 0.5).floor() as i32;
    let g0 = guide[(y * fw + x) as usize];
    let rf = ray(k_fine, x as f32, y as f32);
    let (mut wsum, mut d, mut n) = (0.0f32, 0.0f32, [0.0f32; 3]);
    for qy in cy - r..=cy + r {
        for qx in cx - r..=cx + r {
            if qx < 0 || qy < 0 || qx >= cw as i32 || qy >= ch as i32 {
                continue;
            }
            let q = coarse[(qy as u32 * cw + qx as u32) as usize];
            if q[3] <= 0.0 {
                continue;
            }
            // q's centre on the fine grid, nearest fine pixel.
            let fx = ((qx as f32 + 0.5) / sx - 0.5 + 0.5).floor() as i32;
            let fy = ((qy as f32 + 0.5) / sy - 0.5 + 0.5).floor() as i32;
            let fx = fx.clamp(0, fw as i32 - 1) as u32;
            let fy = fy.clamp(0, fh as i32 - 1) as u32;
            let gq = guide[(fy * fw + fx) as usize];
            let (dx, dy) = (qx as f32 - px, qy as f32 - py);
            let dg = g0 - gq;
            let w = (-(dx * dx + dy * dy) / two_s2).exp() * (-(dg * dg) / two_r2).exp();
            // The plane at q, evaluated along p's ray.
            let rq = ray(k_coarse, qx as f32, qy as f32);
            let nq = [q[0], q[1], q[2]];
            let num = q[3] * (nq[0] * rq[0] + nq[1] * rq[1] + nq[2] * rq[2]);
            let den = nq[0] * rf[0] + nq[1] * rf[1] + nq[2] * rf[2];
            let along = if den < 0.0 { num / den } else { -1.0 };
            let dq = if along > 0.5 * q[3] && along < 1.5 * q[3] {
                along
            } else {
                q[3]
            };
            wsum += w;
            d += w * dq;
            n[0] += w * q[0];
            n[1] += w * q[1];
            n[2] += w * q[2];
        }
    }
    if wsum <= 0.0 {
        return [0.0, 0.0, -1.0, 0.0];
    }
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let mut nn = if len > 0.0 {
        [n[0] / len, n[1] / len, n[2] / len]
    } else {
        [0.0, 0.0, -1.0]
    };
    if nn[0] * rf[0] + nn[1] * rf[1] + nn[2] * rf[2] > 0.0 {
        nn = [-nn[0], -nn[1], -nn[2]];
    }
    [nn[0], nn[1], nn[2], d / wsum]
}

/// What the detail restorer found at one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Restored {
    pub plane: [f32; 4],
    pub cost: f32,
    /// C_init − C_photo.
    pub difference: f32,
    pub replaced: bool,
}

/// Aggregated photometric cost of `plane` with the pixel's view weights `w` (top-K mean when
/// they are all zero), as ACMH aggregates.
fn weighted_cost(
    problem: &ViewProblem,
    patch: &super::cpu::RefPatch,
    plane: [f32; 4],
    weights: &[f32],
    top_k: usize,
) -> f32 {
    let den: f32 = weights.iter().sum();
    let mut num = 0.0f32;
    let mut top = TopK::new(top_k);
    for (j, &w) in weights.iter().enumerate() {
        let m = ncc_cost(problem, patch, j, plane);
        num += w * m;
        top.insert(m);
    }
    if den > 0.0 { num / den } else { top.mean() }
}

/// The detail restorer (Sec. 5.2) at one pixel: C_init is the photometric cost of the
/// upsampled plane, C_photo that of photometric ACMH's plane at this scale, both aggregated
/// with the view weights ACMH ended with at the pixel; where C_init − C_photo > ξ the
/// upsampled plane is an error in the details and ACMH's replaces it.
pub fn detail_restorer_pixel(
    problem: &ViewProblem,
    params: &Params,
    upsampled: [f32; 4],
    photometric: &ViewState,
    x: u32,
    y: u32,
) -> Restored {
    let i = (y * problem.width + x) as usize;
    let nsrc = problem.num_sources();
    let patch = ref_patch(problem, params, x, y);
    let weights = &photometric.weights[i * nsrc..(i + 1) * nsrc];
    let top_k = params.top_k as usize;
    let c_photo = weighted_cost(problem, &patch, photometric.plane[i], weights, top_k);
    let c_init = if upsampled[3] > 0.0 {
        weighted_cost(problem, &patch, upsampled, weights, top_k)
    } else {
        MAX_COST
    };
    let difference = c_init - c_photo;
    let replaced = difference > params.xi;
    Restored {
        plane: if replaced {
            photometric.plane[i]
        } else {
            upsampled
        },
        cost: if replaced { c_photo } else { c_init },
        difference,
        replaced,
    }
}

/// The last step of the detail restorer's pass from the upsampled planes: C_init − C_photo
/// per pixel (C_photo the lowest cost the basic model found there) and the pixels it
/// replaced: gated, those that passed the gate (`aux` bit 16); ungated, those where the
/// difference exceeds ξ (the errors in details). Marks them in `state.aux`.
pub fn restorer_result(
    gate: &super::cpu::RestorerGate,
    state: &mut ViewState,
    xi: f32,
) -> (Vec<f32>, Vec<bool>) {
    let difference: Vec<f32> = gate
        .c_init
        .iter()
        .zip(&gate.c_photo)
        .map(|(i, p)| i - p)
        .collect();
    let bit = super::cpu::REPLACED_BIT;
    if !gate.gated {
        for (a, d) in state.aux.iter_mut().zip(&difference) {
            *a = (*a & 0xffff) | if *d > xi { bit } else { 0 };
        }
    }
    let replaced = state.aux.iter().map(|a| a & bit != 0).collect();
    (difference, replaced)
}

/// The ungated detail restorer over a whole view: replaces planes (and costs) in `state` and
/// returns the difference map and the replaced mask.
pub fn detail_restorer(
    problem: &ViewProblem,
    params: &Params,
    upsampled: &[[f32; 4]],
    state: &mut ViewState,
) -> (Vec<f32>, Vec<bool>) {
    let w = problem.width;
    let snapshot: &ViewState = state;
    let results: Vec<Restored> = (0..problem.pixels())
        .into_par_iter()
        .map(|i| {
            detail_restorer_pixel(
                problem,
                params,
                upsampled[i],
                snapshot,
                i as u32 % w,
                i as u32 / w,
            )
        })
        .collect();
    let mut diff = Vec::with_capacity(results.len());
    let mut replaced = Vec::with_capacity(results.len());
    for (i, r) in results.into_iter().enumerate() {
        state.plane[i] = r.plane;
        state.cost[i] = r.cost;
        state.aux[i] = (state.aux[i] & 0xffff) | (u32::from(r.replaced) << 16);
        diff.push(r.difference);
        replaced.push(r.replaced);
    }
    (diff, replaced)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pyramid_follows_the_paper_or_the_original() {
        let p = Params::default();
        assert_eq!(pyramid_scales(&p, Method::Acmm, 3072), vec![0.25, 0.5, 1.0]);
        assert_eq!(pyramid_scales(&p, Method::Acmh, 3072), vec![1.0]);
        let o = Params {
            original_pyramid: true,
            ..p
        };
        // 3072 -> 1536 -> 768: three levels.
        assert_eq!(pyramid_scales(&o, Method::Acmm, 3072), vec![0.25, 0.5, 1.0]);
        assert_eq!(pyramid_scales(&o, Method::Acmm, 900), vec![1.0]);
        // By the coarsest scale's size: 640 -> 80 in four levels, 320 -> 80 in three,
        // a 12 Mpx photo's 4000 -> 62.5 in seven; a view already small enough has one.
        let c = Params {
            coarsest_size: 100,
            ..p
        };
        assert_eq!(
            pyramid_scales(&c, Method::Acmm, 640),
            vec![0.125, 0.25, 0.5, 1.0]
        );
        assert_eq!(pyramid_scales(&c, Method::Acmm, 320).len(), 3);
        assert_eq!(pyramid_scales(&c, Method::Acmm, 4000).len(), 7);
        assert_eq!(pyramid_scales(&c, Method::Acmm, 90), vec![1.0]);
        assert!(
            Params {
                coarsest_size: 8,
                ..p
            }
            .validate()
            .is_err()
        );
    }

    #[test]
    fn jbu_reproduces_constant_planes_and_respects_edges() {
        let params = Params::default();
        let k = [20.0, 20.0, 7.5, 7.5];
        // A coarse 8x8 map: left half at depth 2, right half at depth 4.
        let coarse: Vec<[f32; 4]> = (0..64)
            .map(|i| [0.0, 0.0, -1.0, if i % 8 < 4 { 2.0 } else { 4.0 }])
            .collect();
        // Fine guide with an intensity edge exactly where the depth edge is.
        let guide: Vec<f32> = (0..256)
            .map(|i| if i % 16 < 8 { 50.0 } else { 200.0 })
            .collect();
        let kc = [10.0, 10.0, 3.5, 3.5];
        let up = joint_bilateral_upsample(&coarse, 8, 8, &guide, 16, 16, kc, k, &params);
        for y in 0..16 {
            for x in 0..16 {
                let d = up[y * 16 + x][3];
                let want = if x < 8 { 2.0 } else { 4.0 };
                // The range term keeps each side's depth even right at the edge.
                assert!((d - want).abs() < 0.02, "({x},{y}) {d}");
            }
        }
        // Without the guide edge the boundary blurs.
        let flat = vec![100.0; 256];
        let blurred = joint_bilateral_upsample(&coarse, 8, 8, &flat, 16, 16, kc, k, &params);
        let d = blurred[4 * 16 + 8][3];
        assert!(d > 2.1 && d < 3.9, "{d}");
        // Normals stay unit and face the camera.
        assert!(
            up.iter()
                .all(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2] - 1.0).abs() < 1e-5)
        );
    }
}
