//! The planar prior of ACMP and ACMMP (ACMP-REFERENCE.md §2-4) on the CPU: the reference of
//! shaders/planar_prior.wgsl (the multi-view check and choice of credible support points,
//! rasterising the triangles, the prior plane of every pixel) and of the prior-assisted
//! pass's start in shaders/initialize.wgsl (the restart from the prior; its score is in
//! `prior`, re-exported here), and the host's part that has no per-pixel GPU form: the
//! Delaunay triangulation of the support points in the image and a plane per triangle.
//!
//! A prior plane is stored per pixel as (normal xyz in the reference camera frame, depth);
//! a depth ≤ 0 means "no prior" and says why ([`NO_TRIANGLE`], [`DROPPED_TRIANGLE`],
//! [`OUT_OF_RANGE`], [`LOCKED`]).

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;

use super::cpu::{initialize, perturb_normal, pixel_stream, ray, reprojection_error};
use super::params::Params;
pub use super::prior::{
    PRIOR_BIT, Prior, PriorTerms, acos_approx, photometric_likelihood, prior_factor, prior_score,
};
use super::problem::{GpuSource, NO_VIEW, ViewProblem, ViewState, Winner};

/// Prior depth of a pixel that no triangle covers (outside the support points' hull).
pub const NO_TRIANGLE: f32 = 0.0;
/// Prior depth of a pixel whose triangle was dropped (degenerate, or inconsistent with its
/// vertices' normals: [`TriangleState`]).
pub const DROPPED_TRIANGLE: f32 = -1.0;
/// Prior depth of a pixel whose triangle's plane lies outside the view's depth range there.
pub const OUT_OF_RANGE: f32 = -2.0;

/// Prior depth of a pixel locked by `prior_lock`: its depth is multi-view consistent, so it
/// keeps its plane.
pub const LOCKED: f32 = -3.0;

/// Prior depth of a pixel in a geometric pass its prior holds in (Regions'
/// `prior_region_hold`) when no flat region's plane covers it ([`held_prior`]).
pub const NOT_HELD: f32 = -4.0;

/// Why a pixel has no prior, from its prior depth (`None`: it has one).
pub fn no_prior_reason(depth: f32) -> Option<&'static str> {
    if depth > 0.0 {
        None
    } else if depth == LOCKED {
        Some("its depth is already multi-view consistent: locked, it keeps its plane")
    } else if depth == DROPPED_TRIANGLE {
        Some("its triangle was dropped (degenerate, or inconsistent with its points' normals)")
    } else if depth == NOT_HELD {
        Some("no flat region's plane covers it: only those hold in the geometric passes")
    } else if depth == OUT_OF_RANGE {
        Some("its triangle's plane is outside the depth range here")
    } else {
        Some("no triangle covers it")
    }
}

/// Grid cells per row and column for a `width x height` view.
pub fn cell_grid(width: u32, height: u32, cell: u32) -> (u32, u32) {
    (width.div_ceil(cell), height.div_ceil(cell))
}

/// A grid cell's support point as the GPU writes it. Keep in sync with `struct Support` in
/// shaders/planar_prior.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SupportRecord {
    /// x, y, depth, cost; all zero when the cell has no credible point.
    pub point: [f32; 4],
    /// The point's own normal (camera frame); w: with `prior_regions`, how many of the
    /// cell's pixels have a flat matching window (whether or not it has a point).
    pub normal: [f32; 4],
}

/// Each pixel's least forward-backward reprojection error over its sources through `depths`
/// (the previous stage's snapshot, laid out as the geometric term reads it), truncated at δ
/// (δ when the pixel has no source): the multi-view check of support points. The reference
/// of `init_random = 3` in shaders/initialize.wgsl.
pub fn consistency_errors(
    problem: &ViewProblem,
    params: &Params,
    plane: &[[f32; 4]],
    depths: &[f32],
) -> Vec<f32> {
    let w = problem.width;
    plane
        .par_iter()
        .enumerate()
        .map(|(i, &p)| {
            let (x, y) = (i as u32 % w, i as u32 / w);
            (0..problem.num_sources()).fold(params.delta, |least, j| {
                least.min(reprojection_error(
                    problem,
                    depths,
                    j,
                    p,
                    x,
                    y,
                    params.delta,
                ))
            })
        })
        .collect()
}

/// Below this standard deviation of its intensities (grey levels) over the matching
/// window, every pixel counted, a window is flat: it holds no edge or texture whose match
/// could stand in for the pixel's own (the weak-window test of
/// [`crate::acmm::pyramid_depth::WEAK_WINDOW_STD`]).
pub const FLAT_WINDOW_STD: f32 = 3.0;

/// Each pixel's standard deviation of the reference intensities over its window of radius
/// `radius`, every pixel, clipped at the border (f32, rows then columns, values taken
/// relative to the centre: the operations of `init_random = 6` in shaders/initialize.wgsl).
/// With `ramp` (`prior_flat_ramp`) the deviation is from the window's least-squares plane
/// in the offsets (dx, dy) instead of from its mean: what is left once a ramp of shading,
/// to which NCC is blind, is taken out. `noise_var` (grey levels², 0 for none) is taken
/// from each window's variance before the root ([`flat_noise_variance`]).
/// A problem without its intensities (a session's header, whose images live on the
/// device) has no flat window: every spread is infinite; read the device's spread map
/// instead ([`support_points_with`]).
pub fn window_spread(problem: &ViewProblem, radius: u32, ramp: bool, noise_var: f32) -> Vec<f32> {
    let (w, h) = (problem.width as i32, problem.height as i32);
    let Some(gray) = problem.images.get(..problem.pixels()) else {
        return vec![f32::INFINITY; problem.pixels()];
    };
    let r = radius as i32;
    (0..problem.pixels())
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i as i32 % w, i as i32 / w);
            let centre = gray[i];
            let (mut n, mut s, mut ss) = (0.0f32, 0.0f32, 0.0f32);
            let (mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0.0f32, 0.0f32, 0.0, 0.0, 0.0);
            let (mut svx, mut svy) = (0.0f32, 0.0f32);
            for yy in (y - r).max(0)..(y + r + 1).min(h) {
                for xx in (x - r).max(0)..(x + r + 1).min(w) {
                    let v = gray[(yy * w + xx) as usize] - centre;
                    let (dx, dy) = ((xx - x) as f32, (yy - y) as f32);
                    n += 1.0;
                    s += v;
                    ss += v * v;
                    sx += dx;
                    sy += dy;
                    sxx += dx * dx;
                    syy += dy * dy;
                    sxy += dx * dy;
                    svx += v * dx;
                    svy += v * dy;
                }
            }
            let m = s / n;
            let mut var = ss / n - m * m;
            if ramp {
                let (mx, my) = (sx / n, sy / n);
                let (cxx, cyy, cxy) = (sxx / n - mx * mx, syy / n - my * my, sxy / n - mx * my);
                let (cvx, cvy) = (svx / n - m * mx, svy / n - m * my);
                let det = cxx * cyy - cxy * cxy;
                if det > 0.0 {
                    var -= (cyy * cvx * cvx - 2.0 * cxy * cvx * cvy + cxx * cvy * cvy) / det;
                }
            }
            (var - noise_var).max(0.0).sqrt()
        })
        .collect()
}

/// Each pixel's spread of its matching window's samples under their bilateral weights
/// (`prior_flat_weighted`): the weighted standard deviation of [`super::cpu::ref_patch`]'s
/// values (the kernel in force, the window's step and border clamping), around their
/// weighted least-squares plane in the samples' offsets with `prior_flat_ramp` (taken out
/// only where the weighted offsets' determinant exceeds 1e-4 of its diagonal's product),
/// else around their weighted mean (f32, two passes, samples row by row: the operations of
/// `init_random = 6` with `flat_ramp` bit 1 in shaders/initialize.wgsl), less `noise_var`
/// under the root as in [`window_spread`]. A problem without its intensities has no flat
/// window, as in [`window_spread`].
pub fn weighted_window_spread(problem: &ViewProblem, params: &Params, noise_var: f32) -> Vec<f32> {
    if problem.images.len() < problem.pixels() {
        return vec![f32::INFINITY; problem.pixels()];
    }
    let w = problem.width;
    (0..problem.pixels())
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let patch = super::cpu::ref_patch(problem, params, x, y);
            let n = patch.xs.len();
            let offset = |k: usize| (patch.xs[k % n] - x as f32, patch.ys[k / n] - y as f32);
            // Two passes: the weighted means, then the moments about them.
            let (mut ws, mut s, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
            for (k, (&wk, &v)) in patch.weights.iter().zip(&patch.values).enumerate() {
                let (dx, dy) = offset(k);
                ws += wk;
                s += wk * v;
                sx += wk * dx;
                sy += wk * dy;
            }
            let (m, mx, my) = (s / ws, sx / ws, sy / ws);
            let (mut vv, mut cxx, mut cyy, mut cxy) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
            let (mut cvx, mut cvy) = (0.0f32, 0.0f32);
            for (k, (&wk, &v)) in patch.weights.iter().zip(&patch.values).enumerate() {
                let (dx, dy) = offset(k);
                let (v, dx, dy) = (v - m, dx - mx, dy - my);
                vv += wk * v * v;
                cxx += wk * dx * dx;
                cyy += wk * dy * dy;
                cxy += wk * dx * dy;
                cvx += wk * v * dx;
                cvy += wk * v * dy;
            }
            let mut var = vv / ws;
            if params.prior_flat_ramp {
                let (axx, ayy, axy) = (cxx / ws, cyy / ws, cxy / ws);
                let (avx, avy) = (cvx / ws, cvy / ws);
                // A ramp is taken out only where the weighted offsets span both axes (the
                // determinant not lost to rounding against its terms).
                let det = axx * ayy - axy * axy;
                if det > 1e-4 * axx * ayy {
                    var -= (ayy * avx * avx - 2.0 * axy * avx * avy + axx * avy * avy) / det;
                }
            }
            (var - noise_var).max(0.0).sqrt()
        })
        .collect()
}

/// The spread the flat-window test reads, as `params` measure it: [`weighted_window_spread`]
/// with `prior_flat_weighted`, else [`window_spread`] over every pixel of the window; with
/// `prior_flat_noise`, beyond the reference image's noise ([`flat_noise_variance`]).
pub fn flat_spread(problem: &ViewProblem, params: &Params) -> Vec<f32> {
    let noise_var = problem.images.get(..problem.pixels()).map_or(0.0, |g| {
        flat_noise_variance(params, g, problem.width, problem.height)
    });
    if params.prior_flat_weighted {
        weighted_window_spread(problem, params, noise_var)
    } else {
        window_spread(
            problem,
            params.window_radius,
            params.prior_flat_ramp,
            noise_var,
        )
    }
}

/// The side of the blocks [`image_noise`] estimates the noise in, pixels.
pub const NOISE_BLOCK: u32 = 16;

/// The standard deviation of an image's sensor noise, grey levels: Immerkær's estimate
/// ("Fast noise variance estimation", CVIU 1996) taken over the image's most homogeneous
/// blocks. The difference of two Laplacians, the mask
/// [[1, -2, 1], [-2, 4, -2], [1, -2, 1]], cancels every intensity plane and quadric of x and
/// y alone, and on white noise of deviation σ its response has deviation 6σ, so
/// σ = √(π/2) / 6 · mean |response|. Texture and edges only add to the response, so the
/// estimate is taken in blocks of [`NOISE_BLOCK`] px (the responses whose 3x3 mask lies in
/// the block), skipping blocks with a clipped pixel (grey ≤ 0.5 or ≥ 254.5: saturation has
/// no noise), and the image's is the lower decile of its blocks' (the 10% most homogeneous
/// blocks: a little below σ on pure noise, about 0.9σ in 16-px blocks). 0 for an image with
/// no whole unclipped block.
pub fn image_noise(gray: &[f32], width: u32, height: u32) -> f32 {
    let (w, h, b) = (width as usize, height as usize, NOISE_BLOCK as usize);
    if gray.len() < w * h || w < b || h < b {
        return 0.0;
    }
    let (bw, bh) = (w / b, h / b);
    let mut blocks: Vec<f32> = (0..bw * bh)
        .into_par_iter()
        .filter_map(|k| {
            let (x0, y0) = ((k % bw) * b, (k / bw) * b);
            let at = |x: usize, y: usize| gray[y * w + x];
            let clipped =
                (y0..y0 + b).any(|y| (x0..x0 + b).any(|x| !(0.5..254.5).contains(&at(x, y))));
            if clipped {
                return None;
            }
            let mut sum = 0.0f64;
            for y in y0 + 1..y0 + b - 1 {
                for x in x0 + 1..x0 + b - 1 {
                    let r = at(x - 1, y - 1) - 2.0 * at(x, y - 1) + at(x + 1, y - 1)
                        - 2.0 * at(x - 1, y)
                        + 4.0 * at(x, y)
                        - 2.0 * at(x + 1, y)
                        + at(x - 1, y + 1)
                        - 2.0 * at(x, y + 1)
                        + at(x + 1, y + 1);
                    sum += f64::from(r.abs());
                }
            }
            let n = ((b - 2) * (b - 2)) as f64;
            Some(((std::f64::consts::FRAC_PI_2).sqrt() / 6.0 * sum / n) as f32)
        })
        .collect();
    if blocks.is_empty() {
        return 0.0;
    }
    blocks.sort_unstable_by(f32::total_cmp);
    blocks[(blocks.len() - 1) / 10]
}

/// The variance the flat test takes from each window's (`prior_flat_noise`): the square of
/// the reference image's noise ([`image_noise`] of `gray`, its intensities at the step's
/// level), or 0 with the option off.
pub fn flat_noise_variance(params: &Params, gray: &[f32], width: u32, height: u32) -> f32 {
    if params.prior_flat_noise && (params.prior_flat_points || params.prior_regions) {
        let s = image_noise(gray, width, height);
        s * s
    } else {
        0.0
    }
}

/// The credible support point of every grid cell (ACMP-REFERENCE.md §2), cells row by row:
/// the cell's lowest-cost pixel (first in row order on ties) when that cost is below
/// `prior_cost_threshold` and its depth is in the view's range, else zeros. With `errors`
/// ([`consistency_errors`]) and `prior_consistency` > 0 only the pixels whose least
/// reprojection error is below it compete (departure 3 in docs/method.md). The depth range
/// test is the guard against a failed pass's all-zero maps (ACMP#2). With
/// `prior_flat_points`, a cell that keeps no point this way takes its lowest-cost pixel
/// among those whose matching window is flat ([`window_spread`] below
/// [`FLAT_WINDOW_STD`]), when that cost is below `prior_flat_cost`: on a weak wall the
/// right depth matches only moderately well, and a flat window cannot borrow a low cost
/// from an edge beside it as the fattened points do (docs/method.md).
pub fn support_points(
    problem: &ViewProblem,
    params: &Params,
    plane: &[[f32; 4]],
    cost: &[f32],
    errors: Option<&[f32]>,
) -> Vec<SupportRecord> {
    let spread =
        (params.prior_flat_points || params.prior_regions).then(|| flat_spread(problem, params));
    support_points_with(problem, params, plane, cost, errors, spread.as_deref())
}

/// [`support_points`] with the windows' spread given (`None`: no window is flat), as the
/// device measured it (`init_random = 6`, the first extra map) where the problem holds no
/// intensities: what a session's host-side choices read (`--prior-oracle select`).
pub fn support_points_with(
    problem: &ViewProblem,
    params: &Params,
    plane: &[[f32; 4]],
    cost: &[f32],
    errors: Option<&[f32]>,
    spread: Option<&[f32]>,
) -> Vec<SupportRecord> {
    let (w, h) = (problem.width, problem.height);
    let c = params.prior_cell;
    let (cw, ch) = cell_grid(w, h, c);
    let checked = errors.filter(|_| params.prior_consistency > 0.0);
    let flat_cost = if params.prior_flat_points {
        params.prior_flat_cost
    } else {
        0.0
    };
    let record = |i: usize, cost: f32, limit: f32| {
        let p = plane[i];
        let d = p[3];
        (cost < limit && d >= problem.depth_min && d <= problem.depth_max).then(|| SupportRecord {
            point: [(i as u32 % w) as f32, (i as u32 / w) as f32, d, cost],
            normal: [p[0], p[1], p[2], 0.0],
        })
    };
    if params.prior_confirmed_points
        && let Some(keys) = checked
    {
        return confirmed_points(problem, params, plane, cost, keys, spread, flat_cost);
    }
    (0..cw * ch)
        .into_par_iter()
        .map(|cell| {
            let (x0, y0) = ((cell % cw) * c, (cell / cw) * c);
            let mut best: Option<(usize, f32)> = None;
            let mut flat: Option<(usize, f32)> = None;
            let mut flat_windows = 0u32;
            for y in y0..(y0 + c).min(h) {
                for x in x0..(x0 + c).min(w) {
                    let i = (y * w + x) as usize;
                    let is_flat =
                        spread.is_some_and(|s| s.get(i).is_some_and(|&v| v < FLAT_WINDOW_STD));
                    flat_windows += u32::from(is_flat);
                    if checked.is_some_and(|e| e[i].is_nan() || e[i] >= params.prior_consistency) {
                        continue;
                    }
                    if best.is_none_or(|(_, b)| cost[i] < b) {
                        best = Some((i, cost[i]));
                    }
                    if is_flat && flat.is_none_or(|(_, b)| cost[i] < b) {
                        flat = Some((i, cost[i]));
                    }
                }
            }
            let mut r = best
                .and_then(|(i, b)| record(i, b, params.prior_cost_threshold))
                .or_else(|| flat.and_then(|(i, b)| record(i, b, flat_cost)))
                .unwrap_or_default();
            if params.prior_regions {
                r.normal[3] = flat_windows as f32;
            }
            r
        })
        .collect()
}

/// [`support_points_with`] with `prior_confirmed_points`, `keys` the confirmation keys
/// ([`rank_confirmed`]): in each cell, among the multi-view consistent pixels whose depth is
/// in range and whose cost is below `prior_cost_threshold`, the one with the lowest key (the
/// most agreeing sources), the lowest cost among those, the first in row order on ties;
/// failing any, the same among the flat windows' pixels of cost below `flat_cost` (0: none).
/// A cell keeps a point exactly when the lowest-cost choice would keep one whose depth is
/// in range; only which of its pixels speaks for it changes.
fn confirmed_points(
    problem: &ViewProblem,
    params: &Params,
    plane: &[[f32; 4]],
    cost: &[f32],
    keys: &[f32],
    spread: Option<&[f32]>,
    flat_cost: f32,
) -> Vec<SupportRecord> {
    let (w, h) = (problem.width, problem.height);
    let c = params.prior_cell;
    let (cw, ch) = cell_grid(w, h, c);
    let in_range = |i: usize| {
        let d = plane[i][3];
        d >= problem.depth_min && d <= problem.depth_max
    };
    // Lower key first, then lower cost (with `prior_confidence_score`, lower cost +
    // key / scale, the score cost − confidence offset by the sources; the scale a power of
    // two, so its reciprocal is exact); the earlier pixel keeps a tie.
    let weight = confirmation_scale(params.prior_consistency, problem.num_sources() as u32).recip();
    let score = |i: usize| cost[i] + keys[i] * weight;
    let better = |i: usize, b: Option<usize>| {
        b.is_none_or(|b| {
            if params.prior_confidence_score {
                score(i) < score(b)
            } else {
                keys[i] < keys[b] || (keys[i] == keys[b] && cost[i] < cost[b])
            }
        })
    };
    (0..cw * ch)
        .into_par_iter()
        .map(|cell| {
            let (x0, y0) = ((cell % cw) * c, (cell / cw) * c);
            let mut best: Option<usize> = None;
            let mut flat: Option<usize> = None;
            let mut flat_windows = 0u32;
            for y in y0..(y0 + c).min(h) {
                for x in x0..(x0 + c).min(w) {
                    let i = (y * w + x) as usize;
                    let is_flat =
                        spread.is_some_and(|s| s.get(i).is_some_and(|&v| v < FLAT_WINDOW_STD));
                    flat_windows += u32::from(is_flat);
                    if !below(keys[i], params.prior_consistency) || !in_range(i) {
                        continue;
                    }
                    if cost[i] < params.prior_cost_threshold && better(i, best) {
                        best = Some(i);
                    }
                    if is_flat && cost[i] < flat_cost && better(i, flat) {
                        flat = Some(i);
                    }
                }
            }
            let mut r = best
                .or(flat)
                .map(|i| {
                    let p = plane[i];
                    SupportRecord {
                        point: [(i as u32 % w) as f32, (i as u32 / w) as f32, p[3], cost[i]],
                        normal: [p[0], p[1], p[2], 0.0],
                    }
                })
                .unwrap_or_default();
            if params.prior_regions {
                r.normal[3] = flat_windows as f32;
            }
            r
        })
        .collect()
}

/// Which of a cell's pixels the support-point choice may take, in its order of preference.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Eligibility {
    /// Consistent, depth in range, cost below `prior_cost_threshold`: chosen first.
    BelowCostLimit,
    /// Consistent with a flat window below `prior_flat_cost` (`prior_flat_points`): chosen
    /// when no pixel is below the cost limit.
    FlatWindow,
    /// Consistent but its cost too high.
    CostTooHigh,
    /// The multi-view check fails (or its depth is out of range).
    Inconsistent,
}

/// One pixel of a cell as the support-point choice saw it (the inspector's table).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SupportCandidate {
    pub x: u32,
    pub y: u32,
    pub depth: f32,
    pub cost: f32,
    /// Its matching window is flat (`prior_flat_points`).
    pub flat: bool,
    /// Multi-view consistent (a source's round trip within `prior_consistency`) with its
    /// depth in range, or no check asked for: it may be chosen.
    pub consistent: bool,
    pub eligibility: Eligibility,
    /// With `prior_confirmed_points`: how many sources confirm it, or with
    /// `prior_confidence_score` the summed confidence Σ exp(−(e + c·Δd/(r·d))) over them.
    pub confidence: Option<f32>,
    /// What the choice minimises among the consistent pixels below the cost limit: the cost
    /// (ACMMP), or cost − confidence (`prior_confidence_score`); with the count the choice
    /// is the most confirming sources first, then the cost.
    pub score: f32,
}

/// Why a cell has the support point it has: every pixel of the cell, best first by the
/// rule in force, and the one chosen (by [`support_points_with`] itself).
#[derive(Clone, Debug, PartialEq)]
pub struct SupportCell {
    /// The cell's top-left pixel and size.
    pub origin: (u32, u32),
    pub size: u32,
    pub chosen: Option<(u32, u32)>,
    /// Chosen among the flat windows (no consistent pixel below `prior_cost_threshold`).
    pub by_flat_window: bool,
    pub candidates: Vec<SupportCandidate>,
}

/// Explains the support point of the cell holding pixel (x, y): `plane`, `cost`, `keys`
/// (the multi-view check's errors, or with `prior_confirmed_points` the confirmation keys
/// of [`rank_confirmed`]) and `spread` as the support-point step read them.
#[allow(clippy::too_many_arguments)]
pub fn explain_cell(
    problem: &ViewProblem,
    params: &Params,
    plane: &[[f32; 4]],
    cost: &[f32],
    keys: Option<&[f32]>,
    spread: Option<&[f32]>,
    x: u32,
    y: u32,
) -> Option<SupportCell> {
    let (w, h) = (problem.width, problem.height);
    let c = params.prior_cell.max(1);
    if x >= w || y >= h || plane.len() != (w * h) as usize || cost.len() != plane.len() {
        return None;
    }
    let (cw, _) = cell_grid(w, h, c);
    let (x0, y0) = ((x / c) * c, (y / c) * c);
    let records = support_points_with(problem, params, plane, cost, keys, spread);
    let record = records.get(((y / c) * cw + x / c) as usize)?;
    let chosen = (record.point[2] > 0.0).then(|| (record.point[0] as u32, record.point[1] as u32));
    let checked = keys.filter(|_| params.prior_consistency > 0.0);
    let ranked = params.prior_confirmed_points && checked.is_some();
    let sources = problem.num_sources() as u32;
    let scale = confirmation_scale(params.prior_consistency, sources);
    let mut candidates = Vec::new();
    for py in y0..(y0 + c).min(h) {
        for px in x0..(x0 + c).min(w) {
            let i = (py * w + px) as usize;
            let d = plane[i][3];
            let in_range = d >= problem.depth_min && d <= problem.depth_max;
            let consistent =
                in_range && checked.is_none_or(|e| below(e[i], params.prior_consistency));
            // A key is (sources − confirmations) × scale.
            let confidence = checked
                .filter(|_| ranked && consistent)
                .map(|k| sources as f32 - k[i] / scale);
            let flat = spread.is_some_and(|s| s.get(i).is_some_and(|&v| v < FLAT_WINDOW_STD));
            let eligibility = if !consistent {
                Eligibility::Inconsistent
            } else if cost[i] < params.prior_cost_threshold {
                Eligibility::BelowCostLimit
            } else if params.prior_flat_points && flat && cost[i] < params.prior_flat_cost {
                Eligibility::FlatWindow
            } else {
                Eligibility::CostTooHigh
            };
            let score = match confidence {
                Some(conf) if params.prior_confidence_score => cost[i] - conf,
                _ => cost[i],
            };
            candidates.push(SupportCandidate {
                x: px,
                y: py,
                depth: d,
                cost: cost[i],
                flat,
                consistent,
                eligibility,
                confidence,
                score,
            });
        }
    }
    // Those the choice may take first; then most confirmations (the count) or the score.
    let count_rank = ranked && !params.prior_confidence_score;
    candidates.sort_by(|a, b| {
        a.eligibility
            .cmp(&b.eligibility)
            .then_with(|| {
                if count_rank {
                    b.confidence
                        .unwrap_or(0.0)
                        .total_cmp(&a.confidence.unwrap_or(0.0))
                } else {
                    std::cmp::Ordering::Equal
                }
            })
            .then_with(|| a.score.total_cmp(&b.score))
    });
    let by_flat_window =
        chosen.is_some_and(|(cx, cy)| cost[(cy * w + cx) as usize] >= params.prior_cost_threshold);
    Some(SupportCell {
        origin: (x0, y0),
        size: c,
        chosen,
        by_flat_window,
        candidates,
    })
}

/// A credible support point: a pixel, its depth, cost and normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SupportPoint {
    pub x: u32,
    pub y: u32,
    pub depth: f32,
    pub cost: f32,
    /// The normal its plane had (camera frame).
    pub normal: [f32; 3],
}

/// The support points among the cells' records (cells without one are skipped).
pub fn credible(records: &[SupportRecord]) -> Vec<SupportPoint> {
    records
        .iter()
        .filter(|r| r.point[2] > 0.0)
        .map(|r| SupportPoint {
            x: r.point[0] as u32,
            y: r.point[1] as u32,
            depth: r.point[2],
            cost: r.point[3],
            normal: [r.normal[0], r.normal[1], r.normal[2]],
        })
        .collect()
}

/// Whether a triangle gives its pixels a prior, and if not, why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriangleState {
    Kept,
    /// Collinear in the image, or its plane passes through the camera centre.
    Degenerate,
    /// Its plane is more than `prior_triangle_normal` from a vertex's own normal: it bridges
    /// a depth discontinuity or has a wrong vertex.
    Inconsistent,
}

/// A triangle of the prior: its support points and the plane through them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PriorTriangle {
    /// Indices into [`PriorMesh::points`].
    pub vertices: [usize; 3],
    /// (n, w) in the reference camera frame: n·X + w = 0, |n| = 1, n facing the camera.
    pub plane: [f32; 4],
    pub state: TriangleState,
}

impl PriorTriangle {
    /// Whether its pixels get a prior.
    pub fn kept(&self) -> bool {
        self.state == TriangleState::Kept
    }
}

/// The support points of a view and their triangulation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PriorMesh {
    pub width: u32,
    pub height: u32,
    pub points: Vec<SupportPoint>,
    pub triangles: Vec<PriorTriangle>,
    /// With `prior_regions`: the flat regions and their planes ([`fit_regions`]).
    pub regions: Option<RegionFit>,
}

/// `GpuTriangle::b[2]` of a cell's entry that is its flat region's plane: it takes the
/// cell's pixels before any triangle (1: a plane past the hull, only where no triangle is).
pub const REGION_PLANE: i32 = 2;

/// A triangle as the rasteriser reads it. Keep in sync with `struct Triangle` in
/// shaders/planar_prior.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    /// x0, y0, x1, y1 (pixel centres).
    pub a: [i32; 4],
    /// x2, y2, kept (1) or dropped (0), unused.
    pub b: [i32; 4],
    /// n xyz, w.
    pub plane: [f32; 4],
}

/// The plane through three support points, back-projected with their own depths
/// (X = d·K⁻¹(u, v, 1)): the triangle's 3-D plane, in f64, or `None` when degenerate. The
/// unit null vector of the 3x4 matrix of rows [Xᵀ 1] that the authors take by SVD is, for
/// three points, the normalised cross product of two edges.
pub fn triangle_plane(k: [f32; 4], p: [&SupportPoint; 3]) -> Option<[f32; 4]> {
    let area2 = (p[1].x as i64 - p[0].x as i64) * (p[2].y as i64 - p[0].y as i64)
        - (p[1].y as i64 - p[0].y as i64) * (p[2].x as i64 - p[0].x as i64);
    if area2 == 0 {
        return None;
    }
    let (fx, fy, cx, cy) = (k[0] as f64, k[1] as f64, k[2] as f64, k[3] as f64);
    let xs: Vec<[f64; 3]> = p
        .iter()
        .map(|s| {
            let d = s.depth as f64;
            [(s.x as f64 - cx) / fx * d, (s.y as f64 - cy) / fy * d, d]
        })
        .collect();
    let e1 = [
        xs[1][0] - xs[0][0],
        xs[1][1] - xs[0][1],
        xs[1][2] - xs[0][2],
    ];
    let e2 = [
        xs[2][0] - xs[0][0],
        xs[2][1] - xs[0][1],
        xs[2][2] - xs[0][2],
    ];
    let c = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let len = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    if !(len.is_finite() && len > 0.0) {
        return None;
    }
    let mut n = [c[0] / len, c[1] / len, c[2] / len];
    let dot0 = n[0] * xs[0][0] + n[1] * xs[0][1] + n[2] * xs[0][2];
    if dot0 > 0.0 {
        n = [-n[0], -n[1], -n[2]];
    }
    let w = -(n[0] * xs[0][0] + n[1] * xs[0][1] + n[2] * xs[0][2]);
    // A plane through the camera centre (w = 0) is seen edge-on: no depth along any ray.
    let scale = xs[0][2].abs().max(1e-30);
    if w <= 1e-9 * scale {
        return None;
    }
    Some([n[0] as f32, n[1] as f32, n[2] as f32, w as f32])
}

/// The plane through three support points and whether a triangle of them gives a prior: not
/// when degenerate ([`triangle_plane`]), nor when the plane is more than
/// `prior_triangle_normal` degrees from one of the points' own normals (zeros when none).
fn triangle_state(
    k: [f32; 4],
    params: &Params,
    p: [&SupportPoint; 3],
) -> ([f32; 4], TriangleState) {
    let Some(pl) = triangle_plane(k, p) else {
        return ([0.0; 4], TriangleState::Degenerate);
    };
    let cos_limit = params.prior_triangle_normal.to_radians().cos();
    let check = params.prior_triangle_normal < 180.0;
    let agrees = |s: &SupportPoint| {
        let n = s.normal;
        n[0] * pl[0] + n[1] * pl[1] + n[2] * pl[2] >= cos_limit
    };
    if !check || p.iter().all(|s| agrees(s)) {
        (pl, TriangleState::Kept)
    } else {
        (pl, TriangleState::Inconsistent)
    }
}

/// Delaunay triangulation of the support points in image space (the `delaunator` crate: it
/// has exact orientation tests, and needs no virtual outer vertices, so every triangle has
/// three real vertices and there is no prior outside their hull), and each triangle's plane.
/// A triangle whose plane is more than `prior_triangle_normal` degrees from one of its
/// vertices' own normals is dropped (a departure from the authors' code, docs/method.md).
pub fn triangulate(
    width: u32,
    height: u32,
    k: [f32; 4],
    params: &Params,
    points: Vec<SupportPoint>,
) -> PriorMesh {
    let input: Vec<delaunator::Point> = points
        .iter()
        .map(|p| delaunator::Point {
            x: p.x as f64,
            y: p.y as f64,
        })
        .collect();
    let t = delaunator::triangulate(&input);
    let triangles = t
        .triangles
        .chunks_exact(3)
        .map(|v| {
            let vertices = [v[0], v[1], v[2]];
            let (plane, state) = triangle_state(k, params, vertices.map(|i| &points[i]));
            PriorTriangle {
                vertices,
                plane,
                state,
            }
        })
        .collect();
    PriorMesh {
        width,
        height,
        points,
        triangles,
        regions: None,
    }
}

impl PriorMesh {
    /// The triangles as the rasteriser reads them.
    pub fn gpu_triangles(&self) -> Vec<GpuTriangle> {
        self.triangles
            .iter()
            .map(|t| {
                let p = t.vertices.map(|i| &self.points[i]);
                GpuTriangle {
                    a: [p[0].x as i32, p[0].y as i32, p[1].x as i32, p[1].y as i32],
                    b: [p[2].x as i32, p[2].y as i32, i32::from(t.kept()), 0],
                    plane: t.plane,
                }
            })
            .collect()
    }

    /// Triangles kept, degenerate and inconsistent.
    pub fn counts(&self) -> (usize, usize, usize) {
        let count = |s| self.triangles.iter().filter(|t| t.state == s).count();
        (
            count(TriangleState::Kept),
            count(TriangleState::Degenerate),
            count(TriangleState::Inconsistent),
        )
    }
}

/// Support points a plane past the hull is chosen among: the nearest this many to the cell's
/// centre (HPM-MVS's 6).
pub const HULL_NEIGHBOURS: usize = 6;

/// What the painting passes read (shaders/planar_prior.wgsl `rasterise`, `prior_plane`): the
/// triangles, then, with `prior_extend`, one plane per grid cell (row by row) for the pixels
/// of that cell that no triangle covers.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PaintList {
    /// The triangles, then the cells' planes (a cell without one: dropped, `b[2] = 0`).
    pub entries: Vec<GpuTriangle>,
    /// How many of `entries` are triangles.
    pub num_triangles: usize,
    /// The grid's cell side, pixels.
    pub cell: u32,
}

impl PaintList {
    /// The triangles alone (what is rasterised).
    pub fn triangles(&self) -> &[GpuTriangle] {
        &self.entries[..self.num_triangles.min(self.entries.len())]
    }

    /// Whether the cells' planes past the hull follow the triangles.
    pub fn extended(&self) -> bool {
        self.entries.len() > self.num_triangles
    }

    /// The plane past the hull for pixel (x, y) of a `width`-wide view, if the list has them.
    pub fn cell_plane(&self, width: u32, x: u32, y: u32) -> Option<&GpuTriangle> {
        if !self.extended() {
            return None;
        }
        let c = self.cell.max(1);
        let cell = (y / c) * width.div_ceil(c) + x / c;
        self.entries.get(self.num_triangles + cell as usize)
    }
}

impl PriorMesh {
    /// The painting passes' input: the triangles and, with `params.prior_extend`, the planes
    /// past the hull of every grid cell ([`cell_planes`]).
    pub fn paint_list(&self, k: [f32; 4], params: &Params) -> PaintList {
        let mut entries = self.gpu_triangles();
        let num_triangles = entries.len();
        if params.prior_extend {
            entries.extend(cell_planes(self, k, params));
        }
        if let Some(fit) = &self.regions {
            // A region's cell takes its plane before any triangle (`b[2] = 2`).
            if !params.prior_extend {
                entries.resize(num_triangles + fit.assigned.len(), GpuTriangle::default());
            }
            for (cell, &a) in fit.assigned.iter().enumerate() {
                if let (Some(pl), Some(e)) = (
                    a.checked_sub(1).and_then(|k| fit.planes.get(k as usize)),
                    entries.get_mut(num_triangles + cell),
                ) {
                    *e = GpuTriangle {
                        a: [0; 4],
                        b: [0, 0, REGION_PLANE, 0],
                        plane: pl.plane,
                    };
                }
            }
        }
        PaintList {
            entries,
            num_triangles,
            cell: params.prior_cell,
        }
    }
}

/// The planes past the hull (HPM-MVS's prior outside the triangulation), one per grid cell of
/// side `params.prior_cell`, row by row: among the [`HULL_NEIGHBOURS`] support points nearest
/// the cell's centre (ties by index), the first triple in lexicographic order whose triangle
/// would be kept ([`TriangleState::Kept`]: not collinear, its plane within
/// `prior_triangle_normal` of its points' normals), as a kept [`GpuTriangle`] with those three
/// points as corners; a dropped one (all zero) when no triple is. Departures from HPM-MVS: one
/// choice per cell, not per pixel (the same 6 points for every pixel of a 5-pixel cell, which
/// lets the host make it once), and the triangle's normal check, which HPM-MVS does not make.
/// The nearest points come from a 2-d tree ([`NearTree`]): exact, whatever the gaps between
/// the points.
pub fn cell_planes(mesh: &PriorMesh, k: [f32; 4], params: &Params) -> Vec<GpuTriangle> {
    let c = params.prior_cell.max(1);
    let (w, h) = (mesh.width, mesh.height);
    let (cw, ch) = cell_grid(w, h, c);
    let tree = NearTree::new(
        mesh.points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.x < w && p.y < h)
            .map(|(i, p)| (i, [p.x as f64, p.y as f64]))
            .collect(),
    );
    (0..cw * ch)
        .into_par_iter()
        .map(|cell| {
            let (gx, gy) = (cell % cw, cell / cw);
            let centre = |g: u32, n: u32| {
                let lo = g * c;
                let hi = (lo + c).min(n) - 1;
                (lo + hi) as f64 / 2.0
            };
            let mut near = Vec::with_capacity(HULL_NEIGHBOURS + 1);
            tree.nearest([centre(gx, w), centre(gy, h)], HULL_NEIGHBOURS, &mut near);
            near.truncate(HULL_NEIGHBOURS);
            let n = near.len();
            for a in 0..n {
                for b in a + 1..n {
                    for d in b + 1..n {
                        let idx = [near[a].1, near[b].1, near[d].1];
                        let pts = idx.map(|i| &mesh.points[i]);
                        let (plane, state) = triangle_state(k, params, pts);
                        if state == TriangleState::Kept {
                            return GpuTriangle {
                                a: [
                                    pts[0].x as i32,
                                    pts[0].y as i32,
                                    pts[1].x as i32,
                                    pts[1].y as i32,
                                ],
                                b: [pts[2].x as i32, pts[2].y as i32, 1, 0],
                                plane,
                            };
                        }
                    }
                }
            }
            GpuTriangle::default()
        })
        .collect()
}

/// The fewest support points a region's plane must hold (as many as the planes past the
/// hull choose among).
pub const REGION_MIN_POINTS: usize = HULL_NEIGHBOURS;

/// The least share of its region's support points a plane must hold.
pub const REGION_MIN_SHARE: f64 = 0.25;

/// At most this many planes per region (sequential RANSAC: each on the points the ones
/// before it left).
pub const REGION_MAX_PLANES: usize = 4;

/// The least share of the support points in the cells a plane paints that the plane must
/// hold: where it explains fewer, those cells are not on it (a curved object of one colour)
/// and keep their triangles.
pub const REGION_MIN_COVER: f64 = 0.5;

/// Random triples RANSAC tries per plane (every triple when a region has fewer).
pub const REGION_SAMPLES: usize = 256;

/// One plane of a flat region and the support points that agree with it.
#[derive(Clone, Debug, PartialEq)]
pub struct RegionPlane {
    /// The region it belongs to (index into [`RegionFit::sizes`]).
    pub region: u32,
    /// (n, w) in the reference camera frame, as a triangle's plane.
    pub plane: [f32; 4],
    /// Indices into [`PriorMesh::points`] within `prior_region_tolerance` of it.
    pub inliers: Vec<usize>,
    /// With `prior_region_axes`: the axis of the view's Manhattan frame
    /// ([`RegionFit::frame`]) that is its normal (0-2); [`FREE_PLANE`] for a plane through
    /// three of its points.
    pub axis: u8,
}

/// [`RegionPlane::axis`] of a plane RANSAC drew through three points.
pub const FREE_PLANE: u8 = 3;

/// The flat regions of a view's grid and their planes ([`fit_regions`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RegionFit {
    /// The grid's cell side, pixels (`prior_cell`).
    pub cell: u32,
    pub cells_x: u32,
    pub cells_y: u32,
    /// Per cell, row by row: 1 + its region, 0 when the cell is not flat.
    pub region: Vec<u32>,
    /// Per cell: 1 + the index of the plane it takes in [`RegionFit::planes`], 0 none.
    pub assigned: Vec<u32>,
    /// Each region's count of support points.
    pub sizes: Vec<usize>,
    pub planes: Vec<RegionPlane>,
    /// With `prior_region_edge`, each cell's shade ([`cell_shades`]) the edge rule compared;
    /// empty otherwise.
    pub shades: Vec<f32>,
    /// With `prior_region_axes`: the view's Manhattan frame, when its lines give one.
    pub frame: Option<super::lines::Frame>,
    /// With `prior_region_choice`, per region: whether its planes come from the later fit,
    /// to the support points of the scale's first geometric pass ([`choose_regions`]);
    /// empty otherwise. The inliers of such a region's planes index
    /// [`RegionFit::later_points`], not the mesh's points.
    pub later: Vec<bool>,
    /// The support points of the later fit, where some region took its planes from it.
    pub later_points: Vec<SupportPoint>,
}

impl RegionFit {
    /// Whether plane `plane`'s inliers index [`RegionFit::later_points`] (its region took
    /// the fit to the first geometric pass's points) rather than the mesh's points.
    pub fn is_later(&self, plane: &RegionPlane) -> bool {
        self.later
            .get(plane.region as usize)
            .copied()
            .unwrap_or(false)
    }

    /// The support point inlier `i` of `plane` names: in `points` (the mesh's), or in the
    /// later fit's points for a region that took that fit.
    pub fn inlier_point<'a>(
        &'a self,
        points: &'a [SupportPoint],
        plane: &RegionPlane,
        i: usize,
    ) -> Option<&'a SupportPoint> {
        if self.is_later(plane) {
            self.later_points.get(i)
        } else {
            points.get(i)
        }
    }

    /// Flat cells, cells given a plane, regions, planes.
    pub fn counts(&self) -> (usize, usize, usize, usize) {
        (
            self.region.iter().filter(|&&r| r > 0).count(),
            self.assigned.iter().filter(|&&a| a > 0).count(),
            self.sizes.len(),
            self.planes.len(),
        )
    }
}

/// 1/d = a·u + b·v + c, (u, v) = K⁻¹(x, y): a plane as an affine map of the normalised image
/// coordinates to inverse depth (n·(d·r) + w = 0 gives 1/d = −n·r / w).
fn inverse_depth_plane(p: &[[f64; 3]]) -> Option<[f64; 3]> {
    // Least squares over the points (exact for three): the normal equations of
    // [u v 1]·(a b c)ᵀ = 1/d. Unweighted: a stereo depth's error is about uniform in inverse
    // depth, and weighing the rows by depth (to minimise the relative error RANSAC scores)
    // measured worse on every scene (docs/accuracy.md, "RANSAC's plane").
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    for q in p {
        let row = [q[0], q[1], 1.0];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += row[i] * row[j];
            }
            r[i] += row[i] * q[2];
        }
    }
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    let scale = m[0][0].abs() * m[1][1].abs() * m[2][2].abs();
    if !(d.is_finite() && d.abs() > 1e-12 * scale.max(1e-300)) {
        return None;
    }
    // Cramer's rule.
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut mk = m;
        for i in 0..3 {
            mk[i][k] = r[i];
        }
        *o = det(&mk) / d;
    }
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// The (n, w) plane of an inverse-depth map: n = −(a, b, c)/|(a, b, c)|, w = 1/|(a, b, c)|.
fn plane_of(abc: [f64; 3]) -> Option<[f32; 4]> {
    let len = (abc[0] * abc[0] + abc[1] * abc[1] + abc[2] * abc[2]).sqrt();
    (len.is_finite() && len > 0.0).then(|| {
        [
            (-abc[0] / len) as f32,
            (-abc[1] / len) as f32,
            (-abc[2] / len) as f32,
            (1.0 / len) as f32,
        ]
    })
}

/// The flat regions of a view and the planes their support points agree on
/// (`prior_regions`; docs/method.md, "Region planes"). A cell is flat when at least
/// `prior_region_flat_share` of its pixels have a flat matching window (the count
/// `support_points` leaves in each record's `normal[3]`); flat cells form regions by
/// 4-connectivity, labelled in row order. In each
/// region with at least [`REGION_MIN_POINTS`] support points, sequential RANSAC: up to
/// [`REGION_SAMPLES`] triples (drawn from the seed, the view's key and scale and the
/// region's first cell in row order, so that a region's draw does not depend on how many
/// regions came before it; every triple when there are fewer), each making the plane through its
/// points, scored by how many of the remaining points lie within `prior_region_tolerance`
/// of it (relative depth along their rays; ties: the smaller sum of relative errors); the
/// best refitted by least squares to its inliers (kept when that holds at least as many),
/// and accepted when it holds at least [`REGION_MIN_POINTS`] and [`REGION_MIN_SHARE`] of
/// the region's points; its inliers leave, and the next plane is sought among the rest, up
/// to [`REGION_MAX_PLANES`]. Then every cell of the region takes the plane of the nearest
/// (4-connected steps within the region, ties to the earlier plane) cell whose point is one
/// of that plane's inliers, whether or not its own point agrees (a wrong point on a wall is
/// what the plane replaces). A plane that holds less than [`REGION_MIN_COVER`] of the
/// points in the cells it would paint is not their surface (a curved object of one colour):
/// it is dropped and those cells keep their triangles.
/// With `prior_region_edge` two neighbouring flat cells join only where no intensity edge
/// lies between them ([`edge_between`], on `gray`, the reference's intensities; `None`: no
/// cell stops at an edge). With `prior_region_axes` and a Manhattan frame from `gray`'s
/// straight lines ([`super::lines::view_frame`]), each step first tries the three planes
/// whose normal is one of the frame's axes, each at the offset inside the most of the
/// points' tolerance intervals and refitted by least squares in inverse depth with the
/// normal held; the one holding the most is taken when it holds the share above, and
/// RANSAC's free plane only otherwise ([`RegionPlane::axis`] says which).
pub fn fit_regions(
    problem: &ViewProblem,
    params: &Params,
    records: &[SupportRecord],
    points: &[SupportPoint],
    gray: Option<&[f32]>,
) -> RegionFit {
    let (w, h) = (problem.width, problem.height);
    // With `prior_region_axes`, the view's Manhattan frame from its own lines.
    let frame = gray
        .filter(|g| params.prior_region_axes && g.len() >= (w * h) as usize)
        .and_then(|g| {
            super::lines::view_frame(
                &g[..(w * h) as usize],
                w,
                h,
                problem.k,
                &[
                    params.seed as u32,
                    (params.seed >> 32) as u32,
                    problem.key,
                    problem.scale,
                    super::cpu::pass_id::REGIONS,
                    u32::MAX,
                ],
            )
        });
    fit_regions_framed(problem, params, records, points, gray, frame)
}

/// [`fit_regions`] with the view's Manhattan frame given (`None`: every plane RANSAC's).
fn fit_regions_framed(
    problem: &ViewProblem,
    params: &Params,
    records: &[SupportRecord],
    points: &[SupportPoint],
    gray: Option<&[f32]>,
    frame: Option<super::lines::Frame>,
) -> RegionFit {
    let c = params.prior_cell.max(1);
    let (w, h) = (problem.width, problem.height);
    let (cw, ch) = cell_grid(w, h, c);
    let n_cells = (cw * ch) as usize;
    let cell_pixels = |cell: usize| {
        let (gx, gy) = (cell as u32 % cw, cell as u32 / cw);
        ((gx * c + c).min(w) - gx * c) * ((gy * c + c).min(h) - gy * c)
    };
    let flat: Vec<bool> = (0..n_cells)
        .map(|cell| {
            records.get(cell).is_some_and(|r| {
                r.normal[3] >= (params.prior_region_flat_share * cell_pixels(cell) as f32).ceil()
            })
        })
        .collect();
    let cell_of = |p: &SupportPoint| ((p.y / c) * cw + p.x / c) as usize;
    let shades = gray
        .filter(|g| params.prior_region_edge && g.len() >= (w * h) as usize)
        .map(|g| cell_shades(g, w, h, c));
    let joined = |a: usize, b: usize| shades.as_ref().is_none_or(|s| !edge_between(s[a], s[b]));
    // Regions: 4-connected flat cells, labelled in row order.
    let mut region = vec![0u32; n_cells];
    let mut members: Vec<Vec<usize>> = Vec::new();
    let neighbours = |cell: usize| {
        let (gx, gy) = (cell as u32 % cw, cell as u32 / cw);
        let mut out = [usize::MAX; 4];
        if gx > 0 {
            out[0] = cell - 1;
        }
        if gx + 1 < cw {
            out[1] = cell + 1;
        }
        if gy > 0 {
            out[2] = cell - cw as usize;
        }
        if gy + 1 < ch {
            out[3] = cell + cw as usize;
        }
        out
    };
    for start in 0..n_cells {
        if !flat[start] || region[start] != 0 {
            continue;
        }
        let label = members.len() as u32 + 1;
        let mut queue = std::collections::VecDeque::from([start]);
        region[start] = label;
        let mut cells = Vec::new();
        while let Some(cell) = queue.pop_front() {
            cells.push(cell);
            for nb in neighbours(cell) {
                if nb != usize::MAX && flat[nb] && region[nb] == 0 && joined(cell, nb) {
                    region[nb] = label;
                    queue.push_back(nb);
                }
            }
        }
        members.push(cells);
    }
    // Each region's points: normalised coordinates and inverse depth.
    let mut by_region: Vec<Vec<usize>> = vec![Vec::new(); members.len()];
    for (i, p) in points.iter().enumerate() {
        if p.x >= w || p.y >= h || p.depth <= 0.0 {
            continue;
        }
        let cell = cell_of(p);
        if let Some(&r) = region.get(cell).filter(|&&r| r > 0) {
            by_region[r as usize - 1].push(i);
        }
    }
    let (fx, fy, cx, cy) = (
        problem.k[0] as f64,
        problem.k[1] as f64,
        problem.k[2] as f64,
        problem.k[3] as f64,
    );
    let uvd = |i: usize| {
        let p = &points[i];
        [
            (p.x as f64 - cx) / fx,
            (p.y as f64 - cy) / fy,
            1.0 / p.depth as f64,
        ]
    };
    let tol = params.prior_region_tolerance as f64;
    // Relative depth error of point q under the inverse-depth map abc (None: behind).
    let error = |abc: &[f64; 3], q: &[f64; 3]| {
        let inv = abc[0] * q[0] + abc[1] * q[1] + abc[2];
        (inv > 0.0).then(|| ((1.0 / inv) - 1.0 / q[2]).abs() * q[2])
    };
    let score = |abc: &[f64; 3], pts: &[[f64; 3]]| {
        let mut n = 0usize;
        let mut sum = 0.0;
        for q in pts {
            if let Some(e) = error(abc, q).filter(|&e| e <= tol) {
                n += 1;
                sum += e;
            }
        }
        (n, sum)
    };
    // The best plane whose normal is one of the frame's axes: per axis, the offset most of
    // the points agree with (every point's own offset gives the interval of offsets within
    // the tolerance of its depth; the offset inside the most intervals), refitted by least
    // squares in inverse depth; the axis whose plane holds the most points (ties: the
    // smaller summed error).
    let axis_plane = |pts: &[[f64; 3]]| -> Option<([f64; 3], (usize, f64), u8)> {
        let f = frame.as_ref()?;
        let mut best: Option<([f64; 3], (usize, f64), u8)> = None;
        for (ai, axis) in f.axes.iter().enumerate() {
            let s: Vec<f64> = pts
                .iter()
                .map(|q| axis[0] * q[0] + axis[1] * q[1] + axis[2])
                .collect();
            // Facing the camera: n·r < 0 on the points (most of them).
            let sign = if s.iter().filter(|&&v| v > 0.0).count() * 2 > s.len() {
                -1.0
            } else {
                1.0
            };
            // Offsets w = −d (n·r) = −(n·r)/inv; within tol of a point's depth when
            // w ∈ [w_i (1 − tol), w_i (1 + tol)].
            let mut events: Vec<(f64, i32)> = Vec::with_capacity(2 * pts.len());
            for (q, &si) in pts.iter().zip(&s) {
                let wi = -sign * si / q[2];
                if wi > 0.0 && wi.is_finite() {
                    events.push((wi * (1.0 - tol), 1));
                    events.push((wi * (1.0 + tol), -1));
                }
            }
            events.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
            let (mut now, mut top, mut at) = (0i32, 0i32, None);
            for (i, e) in events.iter().enumerate() {
                now += e.1;
                if now > top {
                    top = now;
                    at = events.get(i + 1).map(|n| (e.0 + n.0) / 2.0);
                }
            }
            let Some(w0) = at else {
                continue;
            };
            let n = [sign * axis[0], sign * axis[1], sign * axis[2]];
            let abc_of = |t: f64| [-t * n[0], -t * n[1], -t * n[2]];
            let mut abc = abc_of(1.0 / w0);
            let mut sc = score(&abc, pts);
            // Least squares in inverse depth with the normal held: inv = −t (n·r).
            let (mut num, mut den) = (0.0, 0.0);
            for q in pts {
                if error(&abc, q).is_some_and(|e| e <= tol) {
                    let sn = n[0] * q[0] + n[1] * q[1] + n[2];
                    num -= sn * q[2];
                    den += sn * sn;
                }
            }
            if den > 0.0 {
                let refit = abc_of(num / den);
                let s2 = score(&refit, pts);
                if s2.0 >= sc.0 {
                    (abc, sc) = (refit, s2);
                }
            }
            if best.is_none_or(|(_, b, _)| sc.0 > b.0 || (sc.0 == b.0 && sc.1 < b.1)) {
                best = Some((abc, sc, ai as u8));
            }
        }
        best
    };
    // RANSAC's plane through three of the points (the doc above), refitted to its inliers.
    let free_plane =
        |pts: &[[f64; 3]], stream: &mut crate::rng::Stream| -> Option<([f64; 3], (usize, f64))> {
            let n = pts.len();
            let all = n * (n - 1) * (n - 2) / 6;
            let triples: Vec<[usize; 3]> = if all <= REGION_SAMPLES {
                let mut t = Vec::with_capacity(all);
                for a in 0..n {
                    for b in a + 1..n {
                        for d in b + 1..n {
                            t.push([a, b, d]);
                        }
                    }
                }
                t
            } else {
                (0..REGION_SAMPLES)
                    .map(|_| {
                        let mut pick = || ((stream.next_f32() * n as f32) as usize).min(n - 1);
                        [pick(), pick(), pick()]
                    })
                    .collect()
            };
            let mut best: Option<([f64; 3], (usize, f64))> = None;
            for t in triples {
                if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                    continue;
                }
                let Some(abc) = inverse_depth_plane(&[pts[t[0]], pts[t[1]], pts[t[2]]]) else {
                    continue;
                };
                let s = score(&abc, pts);
                if best.is_none_or(|(_, b)| s.0 > b.0 || (s.0 == b.0 && s.1 < b.1)) {
                    best = Some((abc, s));
                }
            }
            let (mut abc, mut s) = best?;
            // Refit to the inliers; kept when it holds at least as many.
            let inl: Vec<[f64; 3]> = pts
                .iter()
                .filter(|q| error(&abc, q).is_some_and(|e| e <= tol))
                .copied()
                .collect();
            if let Some(refit) = inverse_depth_plane(&inl) {
                let s2 = score(&refit, pts);
                if s2.0 >= s.0 {
                    (abc, s) = (refit, s2);
                }
            }
            Some((abc, s))
        };
    let fits: Vec<Vec<(RegionPlane, bool)>> = by_region
        .par_iter()
        .enumerate()
        .map(|(r, idx)| {
            let mut planes = Vec::new();
            if idx.len() < REGION_MIN_POINTS {
                return Vec::new();
            }
            let need = REGION_MIN_POINTS.max((REGION_MIN_SHARE * idx.len() as f64).ceil() as usize);
            let mut left: Vec<usize> = idx.clone();
            let mut abcs: Vec<[f64; 3]> = Vec::new();
            let mut stream = crate::rng::Stream::new(&[
                params.seed as u32,
                (params.seed >> 32) as u32,
                problem.key,
                problem.scale,
                super::cpu::pass_id::REGIONS,
                // The region's own first cell (where its labelling started), not its label:
                // a region split or joined elsewhere renumbers every later region.
                members[r][0] as u32,
            ]);
            while planes.len() < REGION_MAX_PLANES && left.len() >= need {
                let pts: Vec<[f64; 3]> = left.iter().map(|&i| uvd(i)).collect();
                // With a frame, a plane on one of its axes that holds enough points is the
                // region's; RANSAC's free plane only where none does.
                let (abc, s, axis) = match axis_plane(&pts).filter(|(_, s, _)| s.0 >= need) {
                    Some(found) => found,
                    None => {
                        let Some((abc, s)) = free_plane(&pts, &mut stream) else {
                            break;
                        };
                        (abc, s, FREE_PLANE)
                    }
                };
                let Some(plane) = plane_of(abc).filter(|_| s.0 >= need) else {
                    break;
                };
                let agrees: Vec<bool> = pts
                    .iter()
                    .map(|q| error(&abc, q).is_some_and(|e| e <= tol))
                    .collect();
                let pick = |keep: bool| -> Vec<usize> {
                    left.iter()
                        .zip(&agrees)
                        .filter(|(_, a)| **a == keep)
                        .map(|(&i, _)| i)
                        .collect()
                };
                planes.push(RegionPlane {
                    region: r as u32,
                    plane,
                    inliers: pick(true),
                    axis,
                });
                abcs.push(abc);
                left = pick(false);
            }
            let quarter = planes.len();
            if params.prior_region_crease {
                crease_planes(
                    &mut planes,
                    &mut abcs,
                    &mut left,
                    r as u32,
                    &uvd,
                    &|i| cell_of(&points[i]),
                    cw as usize,
                    &|pts, st| free_plane(pts, st),
                    &mut stream,
                    tol,
                );
            }
            planes
                .into_iter()
                .enumerate()
                .map(|(k, pl)| (pl, k >= quarter))
                .collect()
        })
        .collect();
    let sizes: Vec<usize> = by_region.iter().map(Vec::len).collect();
    // Each plane, and whether the crease rule found it.
    let mut candidates: Vec<(RegionPlane, bool)> = fits.into_iter().flatten().collect();
    // Every cell of a region: the plane of the nearest inlier cell (multi-source BFS
    // through the region), its own point's agreement aside: a wrong point on a wall is what
    // the plane replaces.
    // A plane must hold most of the points of the cells it paints: where it holds fewer
    // the cells are not on it (a curved object of one colour), and keep their triangles.
    // With `prior_region_cover_seen` a point the plane does not hold counts against it only
    // where some source's image holds the plane's point: elsewhere the matching cost could
    // not have found the plane's depth (it scores what no source sees as the worst match),
    // so the point's disagreement says nothing about the plane.
    // Returns each cell's plane (index + 1, 0 none) and whether each plane passes.
    // With `prior_region_cover_band`, the points a plane does not hold but that lie within
    // this share of their depth from it count as held as far as they balance: as many
    // nearer as farther (a noisy wall's points scatter both ways; a curved surface, or a
    // foreground object, lies on one side of the plane).
    let band = (params.prior_region_cover_band.max(0.0) * params.prior_region_tolerance) as f64;
    let paint = |planes: &[(RegionPlane, bool)]| -> (Vec<u32>, Vec<bool>) {
        let mut assigned = vec![0u32; n_cells];
        let mut queue = std::collections::VecDeque::new();
        for (k, (pl, _)) in planes.iter().enumerate() {
            for &i in &pl.inliers {
                let cell = cell_of(&points[i]);
                if assigned[cell] == 0 {
                    assigned[cell] = k as u32 + 1;
                    queue.push_back(cell);
                }
            }
        }
        while let Some(cell) = queue.pop_front() {
            for nb in neighbours(cell) {
                if nb != usize::MAX && region[nb] == region[cell] && assigned[nb] == 0 {
                    assigned[nb] = assigned[cell];
                    queue.push_back(nb);
                }
            }
        }
        let mut held_by = vec![0u32; points.len()];
        for (k, (pl, _)) in planes.iter().enumerate() {
            for &i in &pl.inliers {
                held_by[i] = k as u32 + 1;
            }
        }
        let counts_against = |i: usize, k: usize| {
            held_by[i] == k as u32 + 1
                || !params.prior_region_cover_seen
                || plane_sees(problem, &planes[k].0.plane, &points[i])
        };
        let mut territory = vec![0usize; planes.len()];
        // With `prior_region_cover_band`: per plane, its territory's other points within
        // the band, nearer and farther than the plane, and each one's cell and side (−1
        // nearer, +1 farther).
        let mut sides = vec![(0usize, 0usize); planes.len()];
        let mut banded: Vec<Vec<(usize, i8)>> = vec![Vec::new(); planes.len()];
        for &i in by_region.iter().flatten() {
            let cell = cell_of(&points[i]);
            let a = assigned[cell] as usize;
            if a > 0 && counts_against(i, a - 1) {
                territory[a - 1] += 1;
                if band > 0.0 && held_by[i] != a as u32 {
                    match signed_residual(problem, &planes[a - 1].0.plane, &points[i]) {
                        Some(r) if r < 0.0 && -r <= band => {
                            sides[a - 1].0 += 1;
                            banded[a - 1].push((cell, -1));
                        }
                        Some(r) if r >= 0.0 && r <= band => {
                            sides[a - 1].1 += 1;
                            banded[a - 1].push((cell, 1));
                        }
                        _ => {}
                    }
                }
            }
        }
        // The sides count only where they are mixed as noise mixes them: a plane through a
        // curved surface, or across a fold, has its nearer and farther points in patches,
        // which meet along a line. Of the pairs of band points in neighbouring cells (8
        // neighbours), at least half as many must lie on opposite sides as would if the
        // same sides were dealt to the same points at random (a join count):
        // opposite ≥ ½ · pairs · 2·near·far / (n(n − 1)), n = near + far.
        let mut side_at = vec![0i8; n_cells];
        let mixed: Vec<bool> = banded
            .iter()
            .zip(&sides)
            .map(|(pts, &(near, far))| {
                for &(cell, side) in pts {
                    side_at[cell] = side;
                }
                let (mut pairs, mut opposite) = (0u64, 0u64);
                for &(cell, side) in pts {
                    let (gx, gy) = ((cell as u32 % cw) as i64, (cell as u32 / cw) as i64);
                    for (dx, dy) in [(1i64, 0i64), (-1, 1), (0, 1), (1, 1)] {
                        let (nx, ny) = (gx + dx, gy + dy);
                        if nx < 0 || ny < 0 || nx >= cw as i64 || ny >= ch as i64 {
                            continue;
                        }
                        let other = side_at[(ny * cw as i64 + nx) as usize];
                        if other != 0 {
                            pairs += 1;
                            opposite += u64::from(other != side);
                        }
                    }
                }
                for &(cell, _) in pts {
                    side_at[cell] = 0;
                }
                let n = (near + far) as u64;
                opposite * n * n.saturating_sub(1) >= pairs * near as u64 * far as u64
            })
            .collect();
        let passes = planes
            .iter()
            .zip(territory.iter().zip(sides.iter().zip(&mixed)))
            .map(|((pl, _), (&t, (&(near, far), &mixed)))| {
                let balance = if mixed { 2 * near.min(far) } else { 0 };
                (pl.inliers.len() + balance) as f64 >= REGION_MIN_COVER * t as f64
            })
            .collect();
        (assigned, passes)
    };
    // A crease plane that fails the test is dropped before the painting, not after: its
    // cells go back to the planes they had without it (the test keeps a plane from painting
    // cells it does not hold; a crease plane that holds too few of the cells nearest its
    // points says nothing about the earlier plane there).
    let (mut assigned, passes) = loop {
        let (assigned, passes) = paint(&candidates);
        if !candidates
            .iter()
            .zip(&passes)
            .any(|((_, crease), p)| *crease && !*p)
        {
            break (assigned, passes);
        }
        candidates = candidates
            .into_iter()
            .zip(passes)
            .filter(|((_, crease), p)| !*crease || *p)
            .map(|(c, _)| c)
            .collect();
    };
    let mut renumber = vec![0u32; candidates.len()];
    let mut kept = Vec::with_capacity(candidates.len());
    for (k, ((pl, _), pass)) in candidates.into_iter().zip(passes).enumerate() {
        if pass {
            kept.push(pl);
            renumber[k] = kept.len() as u32;
        }
    }
    for a in assigned.iter_mut().filter(|a| **a > 0) {
        *a = renumber[*a as usize - 1];
    }
    let planes = kept;
    if params.prior_region_near > 0 {
        assigned = near_cover(
            &assigned,
            &planes,
            points,
            cw,
            ch,
            params.prior_region_near,
            |p| cell_of(p),
            |p, plane| !params.prior_region_cover_seen || plane_sees(problem, plane, p),
        );
    }
    RegionFit {
        cell: c,
        cells_x: cw,
        cells_y: ch,
        region,
        assigned,
        sizes,
        planes,
        shades: shades.unwrap_or_default(),
        frame,
        later: Vec::new(),
        later_points: Vec::new(),
    }
}

/// `prior_region_choice`: per flat region, the planes of `mine` — fitted to the mesh's
/// points, those of a scale's restorer result (the authors' order's) — unless `later`'s,
/// fitted to `later_points` (those of its first geometric pass, `prior_after_geometric`'s),
/// hold strictly more of the region's points. Both fits share the regions, which the
/// reference's intensities alone decide; a region's planes and cells come whole from the
/// fit it takes, and a cell outside every region (`prior_region_near`) keeps the plane of
/// a region that took its fit. Each fit's points are judged only by its own planes: a
/// wall's points the views share wrong agree with one another as well as right ones do;
/// a geometric pass under good cameras scatters them, under poor cameras the right ones
/// (docs/method.md, "The per-region choice"). When the two fits' regions differ (they
/// cannot for one view at one scale) `mine` is returned as it is.
pub fn choose_regions(
    mine: RegionFit,
    later: RegionFit,
    later_points: Vec<SupportPoint>,
) -> RegionFit {
    if later.region != mine.region || later.cell != mine.cell {
        return mine;
    }
    let n = mine.sizes.len();
    let held = |fit: &RegionFit| {
        let mut held = vec![0usize; n];
        for p in &fit.planes {
            if let Some(h) = held.get_mut(p.region as usize) {
                *h += p.inliers.len();
            }
        }
        held
    };
    let (hm, hl) = (held(&mine), held(&later));
    let takes_later: Vec<bool> = (0..n).map(|r| hl[r] > hm[r]).collect();
    let takes = |plane: &RegionPlane, from_later: bool| {
        takes_later
            .get(plane.region as usize)
            .copied()
            .unwrap_or(false)
            == from_later
    };
    // The planes kept, mine then later's, and each fit's index map (1 + new index).
    let mut planes = Vec::new();
    let mut renumber = |fit: &RegionFit, from_later: bool| -> Vec<u32> {
        fit.planes
            .iter()
            .map(|p| {
                if takes(p, from_later) {
                    planes.push(p.clone());
                    planes.len() as u32
                } else {
                    0
                }
            })
            .collect()
    };
    let (map_m, map_l) = (renumber(&mine, false), renumber(&later, true));
    let mapped = |assigned: u32, map: &[u32]| {
        assigned
            .checked_sub(1)
            .and_then(|k| map.get(k as usize).copied())
            .unwrap_or(0)
    };
    let assigned = mine
        .region
        .iter()
        .enumerate()
        .map(|(cell, &r)| {
            let m = mapped(mine.assigned.get(cell).copied().unwrap_or(0), &map_m);
            let l = mapped(later.assigned.get(cell).copied().unwrap_or(0), &map_l);
            match r.checked_sub(1) {
                Some(r) if takes_later.get(r as usize).copied().unwrap_or(false) => l,
                Some(_) => m,
                None if m > 0 => m,
                None => l,
            }
        })
        .collect();
    let sizes = (0..n)
        .map(|r| {
            let fit = if takes_later[r] { &later } else { &mine };
            fit.sizes.get(r).copied().unwrap_or(0)
        })
        .collect();
    let any_later = takes_later.iter().any(|&l| l);
    RegionFit {
        assigned,
        sizes,
        planes,
        later: takes_later,
        later_points: if any_later { later_points } else { Vec::new() },
        ..mine
    }
}

/// RANSAC's free plane of points (normalised u, v, inverse depth): its inverse-depth map and
/// (inliers, their summed error).
type FreePlane<'a> =
    dyn Fn(&[[f64; 3]], &mut crate::rng::Stream) -> Option<([f64; 3], (usize, f64))> + 'a;

/// `prior_region_crease`: after sequential RANSAC's planes (each holding a quarter of the
/// region's points), the points left may hold planes of any size from
/// [`REGION_MIN_POINTS`] where each meets an earlier plane of the region between their
/// points. A flat region of one shade may fold (a room's corner, the crease of a wall and
/// the ceiling) but not step; a patch of wrong depths the views share (what more planes per
/// region gave planes to, docs/accuracy.md) sits off its wall, a step at its border. Two
/// planes meet between a pair of 8-neighbouring cells, one holding a point of each, when
/// their difference in inverse depth (affine in the image) changes sign between the two
/// points: their line of intersection passes between them. A plane is kept when it does so
/// at more than half of at least [`REGION_MIN_POINTS`] such pairs with the earlier
/// planes; RANSAC tries at most [`REGION_MAX_PLANES`] planes, each try's points leaving the
/// pool whether its plane is kept or not.
#[allow(clippy::too_many_arguments)]
fn crease_planes(
    planes: &mut Vec<RegionPlane>,
    abcs: &mut Vec<[f64; 3]>,
    left: &mut Vec<usize>,
    region: u32,
    uvd: &dyn Fn(usize) -> [f64; 3],
    cell_of: &dyn Fn(usize) -> usize,
    cw: usize,
    free_plane: &FreePlane<'_>,
    stream: &mut crate::rng::Stream,
    tol: f64,
) {
    let inv = |abc: &[f64; 3], q: &[f64; 3]| abc[0] * q[0] + abc[1] * q[1] + abc[2];
    for _ in 0..REGION_MAX_PLANES {
        if abcs.is_empty() || planes.len() >= REGION_MAX_PLANES || left.len() < REGION_MIN_POINTS {
            break;
        }
        let pts: Vec<[f64; 3]> = left.iter().map(|&i| uvd(i)).collect();
        let Some((abc, _)) = free_plane(&pts, stream).filter(|(_, s)| s.0 >= REGION_MIN_POINTS)
        else {
            break;
        };
        let agrees: Vec<bool> = pts
            .iter()
            .map(|q| {
                let v = inv(&abc, q);
                v > 0.0 && ((1.0 / v) - 1.0 / q[2]).abs() * q[2] <= tol
            })
            .collect();
        let mine: Vec<usize> = left
            .iter()
            .zip(&agrees)
            .filter(|(_, a)| **a)
            .map(|(&i, _)| i)
            .collect();
        let rest: Vec<usize> = left
            .iter()
            .zip(&agrees)
            .filter(|(_, a)| !**a)
            .map(|(&i, _)| i)
            .collect();
        // The cells the earlier planes hold a point in, the plane and the point.
        let mut held = std::collections::HashMap::new();
        for (k, pl) in planes.iter().enumerate() {
            for &i in &pl.inliers {
                held.insert(cell_of(i), (k, uvd(i)));
            }
        }
        let (mut pairs, mut crossing) = (0usize, 0usize);
        for &i in &mine {
            let (c, q) = (cell_of(i), uvd(i));
            let (cx, cy) = ((c % cw) as i64, (c / cw) as i64);
            for (dx, dy) in super::NEIGHBOURS_8 {
                let (nx, ny) = (cx + dx, cy + dy);
                if nx < 0 || ny < 0 || nx >= cw as i64 {
                    continue;
                }
                if let Some((k, o)) = held.get(&((ny * cw as i64 + nx) as usize)) {
                    let f = |p: &[f64; 3]| inv(&abc, p) - inv(&abcs[*k], p);
                    pairs += 1;
                    crossing += usize::from(f(&q) * f(o) <= 0.0);
                }
            }
        }
        if pairs >= REGION_MIN_POINTS
            && 2 * crossing > pairs
            && let Some(plane) = plane_of(abc)
        {
            planes.push(RegionPlane {
                region,
                plane,
                inliers: mine,
                axis: FREE_PLANE,
            });
            abcs.push(abc);
        }
        *left = rest;
    }
}

/// Each grid cell's shade (`prior_region_edge`): the median of its pixels' intensities
/// (the lower middle value of an even count), cells row by row. A median, so that an
/// object reaching a minority of a wall cell's pixels does not move it.
pub fn cell_shades(gray: &[f32], width: u32, height: u32, cell: u32) -> Vec<f32> {
    let c = cell.max(1);
    let (cw, ch) = cell_grid(width, height, c);
    (0..cw * ch)
        .into_par_iter()
        .map(|k| {
            let (x0, y0) = ((k % cw) * c, (k / cw) * c);
            let mut v: Vec<f32> = (y0..(y0 + c).min(height))
                .flat_map(|y| (x0..(x0 + c).min(width)).map(move |x| (y * width + x) as usize))
                .filter_map(|i| gray.get(i).copied())
                .collect();
            v.sort_unstable_by(f32::total_cmp);
            v.get(v.len().saturating_sub(1) / 2).copied().unwrap_or(0.0)
        })
        .collect()
}

/// Whether an intensity edge lies between two neighbouring cells of shades `a` and `b`
/// ([`cell_shades`]): they differ by at least 2 × [`FLAT_WINDOW_STD`]. A window half over
/// each (a step of Δ between its halves has a spread of Δ/2) would then fail the flat test
/// over every pixel, so this is the edge the every-pixel test stopped a region at, kept when
/// the flat test itself weighs the window (`prior_flat_weighted`) and no longer sees it; a
/// ramp of shading moves neighbouring cells' shades by its slope over one cell only.
pub fn edge_between(a: f32, b: f32) -> bool {
    (a - b).abs() >= 2.0 * FLAT_WINDOW_STD
}

/// Whether some source's image holds the point of `plane` (n, w in the reference camera
/// frame) on the ray of point `p`'s pixel: [`super::cpu::seen_by_a_source`] at the plane's
/// depth there. A plane behind the pixel, or parallel to its ray, has no point to be seen:
/// the point's disagreement counts.
fn plane_sees(problem: &ViewProblem, plane: &[f32; 4], p: &SupportPoint) -> bool {
    let d = plane_depth_at(problem, plane, p);
    !(d.is_finite() && d > 0.0) || super::cpu::seen_by_a_source(problem, d, p.x, p.y)
}

/// The depth of `plane` (n, w in the reference camera frame) on point `p`'s ray:
/// −w / (n·K⁻¹p̃); not finite where the plane is parallel to the ray, ≤ 0 behind it.
fn plane_depth_at(problem: &ViewProblem, plane: &[f32; 4], p: &SupportPoint) -> f32 {
    let ray = ray(problem.k, p.x as f32, p.y as f32);
    -plane[3] / (plane[0] * ray[0] + plane[1] * ray[1] + plane[2] * ray[2])
}

/// The relative depth of `plane` (n, w in the reference camera frame) on point `p`'s ray
/// against the point's own: (d_plane − d) / d, negative where the point lies behind the
/// plane. `None` where the plane is behind the pixel or parallel to its ray.
fn signed_residual(problem: &ViewProblem, plane: &[f32; 4], p: &SupportPoint) -> Option<f64> {
    let d = plane_depth_at(problem, plane, p) as f64;
    (d.is_finite() && d > 0.0 && p.depth > 0.0).then(|| (d - p.depth as f64) / p.depth as f64)
}

/// `prior_region_near`: each painted cell keeps its plane only where, among the cells within
/// `near` of it (Chebyshev) that the same plane paints and that hold a support point, the
/// plane holds at least [`REGION_MIN_COVER`] of those points; the others are unpainted
/// (0) and keep their triangles. Every cell is judged on the painting it was given, so the
/// order of the cells does not matter.
#[allow(clippy::too_many_arguments)]
fn near_cover(
    assigned: &[u32],
    planes: &[RegionPlane],
    points: &[SupportPoint],
    cw: u32,
    ch: u32,
    near: u32,
    cell_of: impl Fn(&SupportPoint) -> usize,
    seen: impl Fn(&SupportPoint, &[f32; 4]) -> bool,
) -> Vec<u32> {
    // Per cell: whether a point lies in it, and the plane (index + 1) that holds it.
    let mut pointed = vec![false; assigned.len()];
    let mut held = vec![0u32; assigned.len()];
    for (k, pl) in planes.iter().enumerate() {
        for &i in &pl.inliers {
            if let Some(h) = points.get(i).and_then(|p| held.get_mut(cell_of(p))) {
                *h = k as u32 + 1;
            }
        }
    }
    for p in points {
        let cell = cell_of(p);
        // A point its cell's plane does not hold counts only where a source sees the plane
        // (`prior_region_cover_seen`, as over the whole territory).
        let counts = match assigned.get(cell) {
            Some(&k) if k > 0 && held.get(cell) != Some(&k) => planes
                .get(k as usize - 1)
                .is_none_or(|pl| seen(p, &pl.plane)),
            _ => true,
        };
        if let Some(b) = pointed.get_mut(cell).filter(|_| counts) {
            *b = true;
        }
    }
    let r = near as i64;
    (0..assigned.len())
        .map(|cell| {
            let k = assigned[cell];
            if k == 0 {
                return 0;
            }
            let (gx, gy) = ((cell as u32 % cw) as i64, (cell as u32 / cw) as i64);
            let (mut total, mut holds) = (0usize, 0usize);
            for y in (gy - r).max(0)..(gy + r + 1).min(ch as i64) {
                for x in (gx - r).max(0)..(gx + r + 1).min(cw as i64) {
                    let nb = (y * cw as i64 + x) as usize;
                    if assigned[nb] == k && pointed[nb] {
                        total += 1;
                        holds += usize::from(held[nb] == k);
                    }
                }
            }
            if (holds as f64) < REGION_MIN_COVER * total as f64 {
                0
            } else {
                k
            }
        })
        .collect()
}

/// A 2-d tree over image points for the nearest-k queries of [`cell_planes`]: a balanced
/// tree stored in one array (each slice's median by the axis, x and y alternating), exact
/// under the order (squared distance, index), so the answer does not depend on the tree's
/// shape: O(log n) a query where a search over the grid's cells grows with the empty space
/// around a cell.
pub struct NearTree {
    nodes: Vec<(usize, [f64; 2])>,
}

impl NearTree {
    /// The tree over `points` (index, position).
    pub fn new(mut points: Vec<(usize, [f64; 2])>) -> NearTree {
        fn build(s: &mut [(usize, [f64; 2])], axis: usize) {
            if s.len() <= 1 {
                return;
            }
            let mid = s.len() / 2;
            s.select_nth_unstable_by(mid, |a, b| {
                a.1[axis].total_cmp(&b.1[axis]).then(a.0.cmp(&b.0))
            });
            let (lo, rest) = s.split_at_mut(mid);
            build(lo, 1 - axis);
            build(&mut rest[1..], 1 - axis);
        }
        build(&mut points, 0);
        NearTree { nodes: points }
    }

    /// The `k` points nearest `q` as (squared distance, index), nearest first, ties by index.
    pub fn nearest(&self, q: [f64; 2], k: usize, out: &mut Vec<(f64, usize)>) {
        fn search(
            s: &[(usize, [f64; 2])],
            axis: usize,
            q: [f64; 2],
            k: usize,
            best: &mut Vec<(f64, usize)>,
        ) {
            if s.is_empty() || k == 0 {
                return;
            }
            let mid = s.len() / 2;
            let (i, p) = s[mid];
            let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
            let at = best.partition_point(|e| e.0 < d2 || (e.0 == d2 && e.1 < i));
            if at < k {
                best.insert(at, (d2, i));
                best.truncate(k);
            }
            let diff = q[axis] - p[axis];
            // Left of the median: coordinates at most p's; right: at least p's.
            let (near, far) = if diff < 0.0 {
                (&s[..mid], &s[mid + 1..])
            } else {
                (&s[mid + 1..], &s[..mid])
            };
            search(near, 1 - axis, q, k, best);
            // The far side is no nearer than |diff|; equal distances may still win by index.
            if best.len() < k || best.last().is_some_and(|e| diff * diff <= e.0) {
                search(far, 1 - axis, q, k, best);
            }
        }
        out.clear();
        search(&self.nodes, 0, q, k, out);
    }
}

/// Twice the signed area of (a, b, p): which side of a→b the point p lies on.
fn edge(a: [i32; 2], b: [i32; 2], p: [i32; 2]) -> i32 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// The rasteriser of shaders/planar_prior.wgsl (`rasterise`): each pixel centre's label is
/// 1 + the index of the last triangle covering it (edges and vertices included, so a pixel on
/// an edge two triangles share belongs to the later one, as the authors' later triangles
/// overwrite), 0 where none does. Integer edge functions: exact on any device.
pub fn rasterise(triangles: &[GpuTriangle], width: u32, height: u32) -> Vec<u32> {
    let mut labels = vec![0u32; width as usize * height as usize];
    for (t, tri) in triangles.iter().enumerate() {
        let v = [
            [tri.a[0], tri.a[1]],
            [tri.a[2], tri.a[3]],
            [tri.b[0], tri.b[1]],
        ];
        let area = edge(v[0], v[1], v[2]);
        let x0 = v.iter().map(|p| p[0]).min().unwrap_or(0).max(0);
        let x1 = v
            .iter()
            .map(|p| p[0])
            .max()
            .unwrap_or(-1)
            .min(width as i32 - 1);
        let y0 = v.iter().map(|p| p[1]).min().unwrap_or(0).max(0);
        let y1 = v
            .iter()
            .map(|p| p[1])
            .max()
            .unwrap_or(-1)
            .min(height as i32 - 1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                if covers(v, area, [x, y]) {
                    let i = (y as u32 * width + x as u32) as usize;
                    labels[i] = labels[i].max(t as u32 + 1);
                }
            }
        }
    }
    labels
}

/// Whether the triangle `v` (of signed double area `area`) covers pixel centre `p`, its
/// edges included. A zero-area triangle covers nothing.
fn covers(v: [[i32; 2]; 3], area: i32, p: [i32; 2]) -> bool {
    if area == 0 {
        return false;
    }
    let e = [
        edge(v[1], v[2], p),
        edge(v[2], v[0], p),
        edge(v[0], v[1], p),
    ];
    if area > 0 {
        e.iter().all(|&x| x >= 0)
    } else {
        e.iter().all(|&x| x <= 0)
    }
}

/// The directions a weak pixel looks along for anchors (x, y steps), in the order of their
/// 3-bit digits in an anchor code (direction k in bits 3k..3k+3).
pub const ANCHOR_DIRECTIONS: [[i32; 2]; 8] = [
    [1, 0],
    [1, 1],
    [0, 1],
    [-1, 1],
    [-1, 0],
    [-1, -1],
    [0, -1],
    [1, -1],
];

/// The steps probed along each direction, nearest first; an anchor code's digit is the
/// index + 1 (0: no agreeing anchor that way).
pub const ANCHOR_RADII: [i32; 7] = [2, 4, 8, 16, 32, 64, 128];

/// What the anchor search reads (`prior_anchors`): the planes of the stage before, every
/// pixel's least reprojection error (the support points' multi-view check) and the limits.
#[derive(Clone, Copy)]
pub struct Anchoring<'a> {
    pub planes: &'a [[f32; 4]],
    pub errors: &'a [f32],
    /// A pixel is strong (an anchor may sit on it) when its least reprojection error is
    /// below this (`prior_consistency`) and its depth is in the range.
    pub limit: f32,
    pub tolerance: f32,
    pub inliers: u32,
}

impl<'a> Anchoring<'a> {
    /// The search `params` ask for (`prior_anchors`, with the multi-view check on).
    pub fn new(params: &Params, planes: &'a [[f32; 4]], errors: &'a [f32]) -> Option<Self> {
        params.anchors_on().then_some(Anchoring {
            planes,
            errors,
            limit: params.prior_consistency,
            tolerance: params.prior_anchor_tolerance,
            inliers: params.prior_anchor_inliers,
        })
    }
}

/// The pixel (x, y) of the anchor that digit `code` of direction `k` names.
pub fn anchor_pixel(x: u32, y: u32, k: usize, digit: u32) -> (i32, i32) {
    let r = ANCHOR_RADII[(digit - 1) as usize];
    let d = ANCHOR_DIRECTIONS[k];
    (x as i32 + d[0] * r, y as i32 + d[1] * r)
}

/// The anchors of a code, as pixels (at most 8).
pub fn anchor_pixels(x: u32, y: u32, code: u32) -> Vec<(i32, i32)> {
    (0..8)
        .filter_map(|k| {
            let digit = (code >> (3 * k)) & 7;
            (digit != 0).then(|| anchor_pixel(x, y, k, digit))
        })
        .collect()
}

fn cross3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The anchors of pixel (x, y) and the plane they agree on (shaders/planar_prior.wgsl
/// `anchor_plane`, operation for operation): `None` when the pixel is itself strong or no
/// plane has enough agreeing anchors. Along each direction the nearest probed strong pixel is
/// the candidate; every triple of candidates whose image triangle holds the pixel proposes
/// the plane through their back-projected points; the plane with the most candidates within
/// the tolerance of their depth (the first such triple on ties) wins if it has at least
/// `inliers`. Its depth at the pixel must lie in the range. Returns (code, normal xyz and
/// depth at the pixel), the code's digits naming the agreeing anchors.
pub fn anchor_plane(
    problem: &ViewProblem,
    a: &Anchoring,
    x: u32,
    y: u32,
) -> Option<(u32, [f32; 4])> {
    let (w, h) = (problem.width as i32, problem.height as i32);
    let in_range = |d: f32| d >= problem.depth_min && d <= problem.depth_max;
    let strong = |i: usize| a.errors[i] < a.limit && in_range(a.planes[i][3]);
    if strong((y * problem.width + x) as usize) {
        return None;
    }
    // Per direction: (digit, pixel, back-projected point).
    type Candidate = (u32, [i32; 2], [f32; 3]);
    let mut cand: [Option<Candidate>; 8] = [None; 8];
    for (k, d) in ANCHOR_DIRECTIONS.iter().enumerate() {
        for (ri, r) in ANCHOR_RADII.iter().enumerate() {
            let (qx, qy) = (x as i32 + d[0] * r, y as i32 + d[1] * r);
            if qx < 0 || qy < 0 || qx >= w || qy >= h {
                break;
            }
            let q = (qy * w + qx) as usize;
            if strong(q) {
                let rq = ray(problem.k, qx as f32, qy as f32);
                let dq = a.planes[q][3];
                cand[k] = Some((
                    ri as u32 + 1,
                    [qx, qy],
                    [dq * rq[0], dq * rq[1], dq * rq[2]],
                ));
                break;
            }
        }
    }
    let rp = ray(problem.k, x as f32, y as f32);
    let p = [x as i32, y as i32];
    let mut best: Option<(u32, u32, [f32; 4])> = None;
    for i in 0..8 {
        let Some((_, pi, xi)) = cand[i] else { continue };
        for j in i + 1..8 {
            let Some((_, pj, xj)) = cand[j] else { continue };
            for l in j + 1..8 {
                let Some((_, pl, xl)) = cand[l] else { continue };
                let v = [pi, pj, pl];
                if !covers(v, edge(pi, pj, pl), p) {
                    continue;
                }
                let e1 = [xj[0] - xi[0], xj[1] - xi[1], xj[2] - xi[2]];
                let e2 = [xl[0] - xi[0], xl[1] - xi[1], xl[2] - xi[2]];
                let c = cross3(e1, e2);
                let len = dot3(c, c).sqrt();
                if len <= 0.0 {
                    continue;
                }
                let mut n = [c[0] / len, c[1] / len, c[2] / len];
                if dot3(n, rp) > 0.0 {
                    n = [-n[0], -n[1], -n[2]];
                }
                let off = -dot3(n, xi);
                let den = dot3(n, rp);
                if den >= 0.0 {
                    continue;
                }
                let dp = -off / den;
                if !in_range(dp) {
                    continue;
                }
                let mut code = 0u32;
                let mut count = 0u32;
                for (k, c) in cand.iter().enumerate() {
                    let Some((digit, pk, xk)) = *c else { continue };
                    let rk = ray(problem.k, pk[0] as f32, pk[1] as f32);
                    let dk = dot3(n, rk);
                    if dk < 0.0 && (-off / dk - xk[2]).abs() <= a.tolerance * xk[2] {
                        code |= digit << (3 * k);
                        count += 1;
                    }
                }
                if best.is_none_or(|b| count > b.0) {
                    best = Some((count, code, [n[0], n[1], n[2], dp]));
                }
            }
        }
    }
    best.filter(|b| b.0 >= a.inliers).map(|b| (b.1, b.2))
}

/// The least reprojection error a pixel gets when its depth is no distinct minimum
/// ([`distinct_minimum`]): no anchor sits on it.
pub const AMBIGUOUS_ERROR: f32 = 1e30;

/// Steps of one pixel along the epipolar line each way, the most a distinct minimum may be
/// off, its highest cost and the gap to any other local minimum (APD-MVS's weak-texture test;
/// its numbers).
const DISTINCT_STEPS: i32 = 30;
const DISTINCT_MAX_COST: f32 = 0.5;
const DISTINCT_GAP: f32 = 0.2;

fn source_pixel(src: &GpuSource, p: [f32; 3]) -> [f32; 3] {
    let row = |r: [f32; 4], t: f32| r[0] * p[0] + r[1] * p[1] + r[2] * p[2] + t;
    let ps = [
        row(src.r0, src.t[0]),
        row(src.r1, src.t[1]),
        row(src.r2, src.t[2]),
    ];
    let k = src.k;
    [
        k[0] * ps[0] / ps[2] + k[2],
        k[1] * ps[1] / ps[2] + k[3],
        ps[2],
    ]
}

/// Whether the depth of `plane` at (x, y) is a distinct minimum of its matching cost
/// (shaders/initialize.wgsl `distinct_minimum`, operation for operation): the plane moved
/// along the pixel's ray in one-pixel steps of source `best_view`'s epipolar line, ±30 steps,
/// matched against that source; distinct when the lowest cost lies within 2 steps of the
/// depth, is at most 0.5, and no other local minimum more than 2 steps away comes within 0.2
/// of it. A window of smooth shading (a linear ramp) matches itself at every shift and fails.
pub fn distinct_minimum(
    problem: &ViewProblem,
    params: &Params,
    plane: [f32; 4],
    best_view: u32,
    x: u32,
    y: u32,
) -> bool {
    let nsrc = problem.num_sources();
    if nsrc == 0 || plane[3].is_nan() || plane[3] <= 0.0 {
        return false;
    }
    let j = if (best_view as usize) < nsrc {
        best_view as usize
    } else {
        0
    };
    let src = &problem.sources[j];
    let r = ray(problem.k, x as f32, y as f32);
    let d = plane[3];
    let a = source_pixel(src, [r[0] * d, r[1] * d, r[2] * d]);
    let d1 = d * 1.001;
    let b = source_pixel(src, [r[0] * d1, r[1] * d1, r[2] * d1]);
    if a[2] <= 0.0 || b[2] <= 0.0 {
        return false;
    }
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    let du = (ex * ex + ey * ey).sqrt() / (d * 0.001);
    if du.is_nan() || du <= 0.0 {
        return false;
    }
    let patch = super::cpu::ref_patch(problem, params, x, y);
    let mut costs = [0.0f32; 61];
    let mut best = 0usize;
    for (k, c) in costs.iter_mut().enumerate() {
        let dk = d + (k as i32 - DISTINCT_STEPS) as f32 / du;
        *c = if dk >= problem.depth_min && dk <= problem.depth_max {
            super::cpu::ncc_cost(problem, &patch, j, [plane[0], plane[1], plane[2], dk])
        } else {
            super::cpu::MAX_COST
        };
    }
    for k in 1..61 {
        if costs[k] < costs[best] {
            best = k;
        }
    }
    let cb = costs[best];
    if (best as i32 - DISTINCT_STEPS).abs() > 2 || cb > DISTINCT_MAX_COST {
        return false;
    }
    !(0..61).any(|k| {
        let left = k == 0 || costs[k] <= costs[k - 1];
        let right = k == 60 || costs[k] <= costs[k + 1];
        (k as i32 - best as i32).abs() > 2 && left && right && costs[k] < cb + DISTINCT_GAP
    })
}

/// [`AMBIGUOUS_ERROR`] for every pixel of `errors` (least reprojection errors) whose depth is
/// no distinct minimum (the device's `GpuViewSolver::mark_ambiguous`).
pub fn mark_ambiguous(
    problem: &ViewProblem,
    params: &Params,
    state: &ViewState,
    errors: &mut [f32],
) {
    let w = problem.width;
    errors.par_iter_mut().enumerate().for_each(|(i, e)| {
        let best = (state.aux[i] >> 8) & 0xff;
        if !distinct_minimum(
            problem,
            params,
            state.plane[i],
            best,
            i as u32 % w,
            i as u32 / w,
        ) {
            *e = AMBIGUOUS_ERROR;
        }
    });
}

/// [`AMBIGUOUS_ERROR`] for every pixel of `errors` fewer than `views` sources agree with
/// (reprojection error through `depths` below `prior_consistency`; the device's
/// `GpuViewSolver::mark_few_views`): `prior_support_views` before the support points,
/// `prior_anchor_views` before the anchors.
pub fn mark_few_views(
    problem: &ViewProblem,
    params: &Params,
    views: u32,
    plane: &[[f32; 4]],
    depths: &[f32],
    errors: &mut [f32],
) {
    let w = problem.width;
    errors.par_iter_mut().enumerate().for_each(|(i, e)| {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let agree = (0..problem.num_sources())
            .filter(|&j| {
                reprojection_error(problem, depths, j, plane[i], x, y, params.delta)
                    < params.prior_consistency
            })
            .count();
        if agree < views as usize {
            *e = AMBIGUOUS_ERROR;
        }
    });
}

/// Whether `v` is below `limit` (NaN is not): a pixel passes the multi-view check.
fn below(v: f32, limit: f32) -> bool {
    v < limit
}

/// The scale of the confirmation keys for `sources` sources: `prior_consistency` / 2^k with
/// 2^k the least power of two above `sources`, so that every key, (sources − agreeing) ×
/// scale with at least one agreeing, stays below `prior_consistency` and is exact in f32
/// on host and device alike (a power-of-two scale, `ldexp` in shaders/initialize.wgsl).
pub fn confirmation_scale(consistency: f32, sources: u32) -> f32 {
    let k = 32 - sources.leading_zeros();
    consistency * 2f32.powi(-(k as i32))
}

/// With `prior_confirmed_points`: every pixel of `errors` (least reprojection errors, below
/// `prior_consistency` where multi-view consistent) that is consistent takes its
/// confirmation key, (sources − confirming sources) × [`confirmation_scale`], where a
/// source confirms when the round trip through its depth in `depths` comes back within
/// `prior_consistency` px and `fusion_relative_depth` of the depth
/// ([`crate::acmm::cpu::Confirmation`]: fusion's checks but the normal's): still
/// below `prior_consistency`, so the check, the lock and the anchors decide as before, and
/// lower the more sources agree, so the support points rank by it. With
/// `prior_confidence_score` the key is (sources − confidence) × scale instead, the
/// confidence the sum of [`crate::acmm::cpu::Confirmation::confidence`] over the sources, so that
/// cost + key / scale ranks as HPM-MVS++'s support score, cost − confidence. The reference
/// of `init_random = 7` in shaders/initialize.wgsl (`GpuViewSolver::rank_confirmed`).
pub fn rank_confirmed(
    problem: &ViewProblem,
    params: &Params,
    plane: &[[f32; 4]],
    depths: &[f32],
    errors: &mut [f32],
) {
    let w = problem.width;
    let sources = problem.num_sources() as u32;
    let scale = confirmation_scale(params.prior_consistency, sources);
    errors.par_iter_mut().enumerate().for_each(|(i, e)| {
        if !below(*e, params.prior_consistency) {
            return;
        }
        let (x, y) = (i as u32 % w, i as u32 / w);
        let (p, check) = (
            plane[i],
            crate::acmm::cpu::Confirmation {
                delta: params.delta,
                limit: params.prior_consistency,
                relative: params.fusion_relative_depth,
            },
        );
        if params.prior_confidence_score {
            // Summed in source order, as the device does.
            let conf = (0..problem.num_sources()).fold(0.0f32, |c, j| {
                c + check.confidence(problem, depths, j, p, x, y)
            });
            *e = (sources as f32 - conf) * scale;
            return;
        }
        let agree = (0..problem.num_sources())
            .filter(|&j| check.confirms(problem, depths, j, p, x, y))
            .count() as u32;
        *e = (sources - agree.min(sources)) as f32 * scale;
    });
}

/// Every pixel's anchor code (0: none), as the prior-plane pass writes them to the first of
/// the solver's extra maps.
pub fn anchor_codes(problem: &ViewProblem, a: &Anchoring) -> Vec<u32> {
    (0..problem.pixels())
        .into_par_iter()
        .map(|i| {
            let w = problem.width;
            anchor_plane(problem, a, i as u32 % w, i as u32 / w).map_or(0, |(c, _)| c)
        })
        .collect()
}

/// The prior plane of every pixel from its label (shaders/planar_prior.wgsl `prior_plane`):
/// its triangle's normal and that plane's depth along the pixel's ray, d = −w / (n·K⁻¹p̃);
/// a depth ≤ 0 says why there is none.
pub fn prior_planes(
    problem: &ViewProblem,
    labels: &[u32],
    list: &PaintList,
    lock: Option<(&[f32], f32)>,
    anchors: Option<&Anchoring>,
) -> Vec<[f32; 4]> {
    let w = problem.width;
    let triangles = list.triangles();
    labels
        .par_iter()
        .enumerate()
        .map(|(i, &label)| {
            // Locked: the pixel's least reprojection error is below the limit.
            if lock.is_some_and(|(errors, limit)| errors.get(i).is_some_and(|&e| e < limit)) {
                return [0.0, 0.0, 0.0, LOCKED];
            }
            let (x, y) = (i as u32 % w, i as u32 / w);
            // A weak pixel with anchors takes the plane they agree on.
            if let Some((_, plane)) = anchors.and_then(|a| anchor_plane(problem, a, x, y)) {
                return plane;
            }
            let region = list.cell_plane(w, x, y).filter(|t| t.b[2] == REGION_PLANE);
            let t = if let Some(t) = region {
                t
            } else if label == 0 {
                // Past the hull: the cell's plane, when the list has them and it has one.
                match list.cell_plane(w, x, y) {
                    Some(t) if t.b[2] != 0 => t,
                    _ => return [0.0, 0.0, 0.0, NO_TRIANGLE],
                }
            } else {
                let Some(t) = triangles.get(label as usize - 1) else {
                    return [0.0, 0.0, 0.0, NO_TRIANGLE];
                };
                if t.b[2] == 0 {
                    return [0.0, 0.0, 0.0, DROPPED_TRIANGLE];
                }
                t
            };
            let n = [t.plane[0], t.plane[1], t.plane[2]];
            let r = ray(problem.k, x as f32, y as f32);
            let den = n[0] * r[0] + n[1] * r[1] + n[2] * r[2];
            let d = if den < 0.0 { -t.plane[3] / den } else { 0.0 };
            if d >= problem.depth_min && d <= problem.depth_max {
                [n[0], n[1], n[2], d]
            } else {
                [n[0], n[1], n[2], OUT_OF_RANGE]
            }
        })
        .collect()
}

/// The prior planes that hold in the geometric passes after the prior's stage (Regions'
/// `prior_region_hold`; shaders/planar_prior.wgsl `keep_regions`): a pixel's plane from
/// `prior` (painted from `list`) where its cell's entry in `list` is its flat region's
/// plane, [`NOT_HELD`] elsewhere. A triangle's plane rests on three support points, a
/// region's on every point of the region that agrees with it (a RANSAC fit): the
/// prior-assisted pass uses both, the geometric passes only the second.
pub fn held_prior(width: u32, prior: &[[f32; 4]], list: &PaintList) -> Vec<[f32; 4]> {
    let w = width.max(1);
    prior
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let (x, y) = (i as u32 % w, i as u32 / w);
            match list.cell_plane(w, x, y) {
                Some(t) if t.b[2] == REGION_PLANE => p,
                _ => [0.0, 0.0, 0.0, NOT_HELD],
            }
        })
        .collect()
}

/// Support points taken from the ground truth instead of the estimate: a diagnosis that
/// separates the prior's two sources of error (`bench --accuracy --prior-oracle`,
/// docs/accuracy.md). The same pixels are picked either way; only their depths differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PriorOracle {
    /// Every support point the truth knows takes the true depth: what the prior would do if
    /// the estimate were right at its credible pixels.
    Depth,
    /// Only the support points within 2% of the truth are kept, with their estimated depths:
    /// what a perfect test of the points (rejecting every wrong one) would give.
    Filter,
    /// Each cell's point is its lowest-cost pixel among those the estimate has within 2% of
    /// the truth (with the cost threshold as usual): the best the estimate itself offers,
    /// what a perfect choice of support points could give.
    Select,
}

/// The support points of a `width x height` view (intrinsics `k`) as `oracle` sees them with
/// `truth`, the true depth of each of its pixels (0 unknown). Points where the truth is
/// unknown are dropped in every reading (nothing vouches for them). `Depth` also gives each
/// point the truth's normal, from the back-projected true depths two pixels to each side (the
/// triangle check compares triangles with the points' normals), keeping the estimated one
/// where a neighbour's truth is unknown.
pub fn apply_oracle(
    points: Vec<SupportPoint>,
    width: u32,
    height: u32,
    k: [f32; 4],
    truth: &[f32],
    oracle: PriorOracle,
) -> Vec<SupportPoint> {
    let point = |x: i64, y: i64| -> Option<[f64; 3]> {
        if x < 0 || y < 0 || x >= width as i64 || y >= height as i64 {
            return None;
        }
        let d = truth[(y * width as i64 + x) as usize] as f64;
        (d > 0.0).then(|| {
            [
                (x as f64 - k[2] as f64) / k[0] as f64 * d,
                (y as f64 - k[3] as f64) / k[1] as f64 * d,
                d,
            ]
        })
    };
    let true_normal = |p: &SupportPoint| -> Option<[f32; 3]> {
        const STEP: i64 = 2;
        let (x, y) = (p.x as i64, p.y as i64);
        let (l, r) = (point(x - STEP, y)?, point(x + STEP, y)?);
        let (u, d) = (point(x, y - STEP)?, point(x, y + STEP)?);
        let a = [r[0] - l[0], r[1] - l[1], r[2] - l[2]];
        let b = [d[0] - u[0], d[1] - u[1], d[2] - u[2]];
        let mut n = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if !(len.is_finite() && len > 0.0) {
            return None;
        }
        let c = point(x, y)?;
        if n[0] * c[0] + n[1] * c[1] + n[2] * c[2] > 0.0 {
            n = [-n[0], -n[1], -n[2]];
        }
        Some([
            (n[0] / len) as f32,
            (n[1] / len) as f32,
            (n[2] / len) as f32,
        ])
    };
    points
        .into_iter()
        .filter_map(|p| {
            let d = truth[(p.y * width + p.x) as usize];
            match oracle {
                _ if d.is_nan() || d <= 0.0 => None,
                PriorOracle::Depth => Some(SupportPoint {
                    depth: d,
                    normal: true_normal(&p).unwrap_or(p.normal),
                    ..p
                }),
                PriorOracle::Filter | PriorOracle::Select => {
                    ((p.depth - d).abs() < 0.02 * d).then_some(p)
                }
            }
        })
        .collect()
}

/// For [`PriorOracle::Select`]: per pixel of an estimate, 0 where its depth is within 2% of
/// `truth` (the same pixels' true depths), infinity elsewhere (unknown truth included), in
/// the form of [`consistency_errors`] so that [`support_points`] lets only right pixels
/// compete.
pub fn oracle_errors(plane: &[[f32; 4]], truth: &[f32]) -> Vec<f32> {
    plane
        .iter()
        .zip(truth)
        .map(|(p, &d)| {
            if d > 0.0 && (p[3] - d).abs() < 0.02 * d {
                0.0
            } else {
                f32::INFINITY
            }
        })
        .collect()
}

/// [`oracle_errors`] with a test that also lets wrong pixels through: of the pixels the
/// estimate has wrong but the real test passes (`real`: the strong-pixel measure the anchors
/// read, below `tolerance`), `admit_percent` in 100 pass (chosen by a hash of the pixel and
/// `view`, the same in every run), as the false positives of a strong-pixel test would. 0 is
/// [`oracle_errors`]; 100 keeps every one of the real test's false positives and adds the
/// right pixels it missed. A diagnosis: how precise must a test of strong pixels be for the
/// anchors to help (`bench --accuracy --prior-oracle select --prior-oracle-admit P`).
pub fn oracle_errors_admitting(
    plane: &[[f32; 4]],
    truth: &[f32],
    real: &[f32],
    tolerance: f32,
    admit_percent: u32,
    view: usize,
) -> Vec<f32> {
    let mut errors = oracle_errors(plane, truth);
    for (i, e) in errors.iter_mut().enumerate() {
        let passes = real.get(i).is_some_and(|&r| r < tolerance);
        let known = truth.get(i).is_some_and(|&d| d > 0.0);
        if e.is_infinite()
            && passes
            && known
            && crate::rng::hash_coords(&[view as u32, i as u32, 0x0a11]) % 100 < admit_percent
        {
            *e = real[i];
        }
    }
    errors
}

/// The whole prior of a view from its state (the preceding pass's result) and, for the
/// multi-view check, the depth snapshot of that pass: support points, triangulation, and
/// every pixel's prior plane.
pub fn build_prior(
    problem: &ViewProblem,
    params: &Params,
    state: &ViewState,
    depths: Option<&[f32]>,
) -> (PriorMesh, Vec<[f32; 4]>) {
    let mut errors = depths.map(|d| consistency_errors(problem, params, &state.plane, d));
    if let (Some(e), Some(d)) = (errors.as_mut(), depths)
        && params.prior_consistency > 0.0
        && params.prior_support_views > 1
    {
        // Support points (and anchors) only where enough sources agree.
        mark_few_views(
            problem,
            params,
            params.prior_support_views,
            &state.plane,
            d,
            e,
        );
    }
    if let (Some(e), Some(d)) = (errors.as_mut(), depths)
        && params.prior_consistency > 0.0
        && params.prior_confirmed_points
    {
        // The support points rank the consistent pixels by how many sources agree.
        rank_confirmed(problem, params, &state.plane, d, e);
    }
    let records = support_points(
        problem,
        params,
        &state.plane,
        &state.cost,
        errors.as_deref(),
    );
    let mut mesh = triangulate(
        problem.width,
        problem.height,
        problem.k,
        params,
        credible(&records),
    );
    if params.prior_regions {
        let gray = problem.images.get(..problem.pixels());
        mesh.regions = Some(fit_regions(problem, params, &records, &mesh.points, gray));
    }
    let list = mesh.paint_list(problem.k, params);
    let labels = rasterise(list.triangles(), problem.width, problem.height);
    // With the anchors' distinct-minimum test, the painting reads the marked errors (the
    // lock too, as on the device).
    let mut strong = errors.clone();
    let anchors = params.anchors_on();
    if let (Some(e), Some(d)) = (strong.as_mut(), depths)
        && anchors
        && params.prior_anchor_views > 1
    {
        mark_few_views(
            problem,
            params,
            params.prior_anchor_views,
            &state.plane,
            d,
            e,
        );
    }
    if let Some(e) = strong
        .as_mut()
        .filter(|_| anchors && params.prior_anchor_distinct)
    {
        mark_ambiguous(problem, params, state, e);
    }
    let lock = strong
        .as_deref()
        .filter(|_| params.prior_lock && params.prior_consistency > 0.0)
        .map(|e| (e, params.prior_consistency));
    let anchoring = strong
        .as_deref()
        .and_then(|e| Anchoring::new(params, &state.plane, e));
    let planes = prior_planes(problem, &labels, &list, lock, anchoring.as_ref());
    (mesh, planes)
}

/// The restart plane of a pixel at the prior-assisted pass's start: the prior depth scaled by
/// U[1 ± prior_init_depth] (kept in the range), the prior normal tilted by up to
/// ± prior_init_normal along two tangents (kept if that would face away).
pub fn restart_plane(
    problem: &ViewProblem,
    params: &Params,
    prior: [f32; 4],
    x: u32,
    y: u32,
) -> [f32; 4] {
    let mut s = pixel_stream(params, problem, super::cpu::pass_id::PLANAR, 0, x, y);
    let d = (prior[3] * (1.0 + (2.0 * s.next_f32() - 1.0) * params.prior_init_depth))
        .clamp(problem.depth_min, problem.depth_max);
    let (u1, u2) = (s.next_f32(), s.next_f32());
    let n = perturb_normal(
        [prior[0], prior[1], prior[2]],
        u1,
        u2,
        params.prior_init_normal.to_radians().tan(),
        ray(problem.k, x as f32, y as f32),
    );
    [n[0], n[1], n[2], d]
}

/// The prior-assisted pass's start (ACMP-REFERENCE.md §4, "P2 init"): pixels with a prior
/// whose cost is at least `prior_cost_threshold` restart from it ([`restart_plane`]), the
/// others keep their plane; every pixel's cost becomes the photometric top-K mean, view
/// weights and v_t start afresh, and [`PRIOR_BIT`] marks the restarted pixels.
pub fn prior_init(
    problem: &ViewProblem,
    params: &Params,
    state: &mut ViewState,
    prior: &[[f32; 4]],
) {
    let w = problem.width;
    let restarted: Vec<bool> = (0..problem.pixels())
        .map(|i| prior[i][3] > 0.0 && state.cost[i] >= params.prior_cost_threshold)
        .collect();
    for (i, &r) in restarted.iter().enumerate() {
        if r {
            state.plane[i] = restart_plane(problem, params, prior[i], i as u32 % w, i as u32 / w);
        }
    }
    initialize(problem, params, state, None, false, None);
    let nsrc = problem.num_sources();
    for (i, &r) in restarted.iter().enumerate() {
        let bit = if r { PRIOR_BIT } else { 0 };
        let winner = if r { Winner::INITIAL } else { Winner::KEPT };
        state.aux[i] = winner | (NO_VIEW << 8) | bit;
        state.weights[i * nsrc..(i + 1) * nsrc].fill(0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-region choice: each region keeps the earlier fit (the mesh's points) unless
    /// the later fit's planes hold strictly more of its points (a tie keeps the earlier;
    /// none in either: nothing), its cells come whole from the fit it takes, a cell outside
    /// the regions keeps a plane of a region that took its fit, and a later plane's inliers
    /// name the later points.
    #[test]
    fn each_region_takes_the_later_fit_only_where_it_holds_more_points() {
        let point = |x: u32, depth: f32| SupportPoint {
            x,
            y: 0,
            depth,
            cost: 0.1,
            normal: [0.0, 0.0, -1.0],
        };
        let plane = |region: u32, w: f32, inliers: Vec<usize>| RegionPlane {
            region,
            plane: [0.0, 0.0, -1.0, w],
            inliers,
            axis: FREE_PLANE,
        };
        // Six cells in a row: regions 1 (cells 0-1), 2 (cells 2-3), 3 (cell 4), and cell 5
        // outside every region.
        let base = RegionFit {
            cell: 5,
            cells_x: 6,
            cells_y: 1,
            region: vec![1, 1, 2, 2, 3, 0],
            ..RegionFit::default()
        };
        // Mine (earlier): region 1 holds 2 points, region 2 holds 2; cell 5 takes region
        // 2's plane.
        let mine = RegionFit {
            assigned: vec![1, 1, 2, 2, 0, 2],
            sizes: vec![3, 4, 1],
            planes: vec![plane(0, 1.0, vec![0, 1]), plane(1, 2.0, vec![2, 3])],
            ..base.clone()
        };
        // Later: region 1 holds 3 in two planes (it wins), region 2 holds 2 (a tie: mine
        // stays), region 3 has no plane in either.
        let later = RegionFit {
            assigned: vec![1, 2, 3, 3, 0, 2],
            sizes: vec![5, 4, 1],
            planes: vec![
                plane(0, 5.0, vec![0]),
                plane(0, 6.0, vec![1, 2]),
                plane(1, 7.0, vec![3, 4]),
            ],
            ..base.clone()
        };
        let later_points: Vec<SupportPoint> = (0..5).map(|i| point(i * 5, 9.0)).collect();
        let chosen = choose_regions(mine.clone(), later.clone(), later_points.clone());
        assert_eq!(chosen.later, vec![true, false, false]);
        let ws: Vec<f32> = chosen.planes.iter().map(|p| p.plane[3]).collect();
        assert_eq!(
            ws,
            vec![2.0, 5.0, 6.0],
            "region 2's own plane, region 1's two later"
        );
        // Cells 0-1 take the later planes, 2-3 mine; cell 5 keeps mine's region-2 plane.
        assert_eq!(chosen.assigned, vec![2, 3, 1, 1, 0, 1]);
        assert_eq!(chosen.sizes, vec![5, 4, 1]);
        assert_eq!(chosen.region, mine.region);
        assert_eq!(chosen.later_points, later_points);
        let mesh_points: Vec<SupportPoint> = (0..4).map(|i| point(i, 1.0)).collect();
        let p = &chosen.planes[2];
        assert!(chosen.is_later(p) && !chosen.is_later(&chosen.planes[0]));
        assert_eq!(
            chosen.inlier_point(&mesh_points, p, p.inliers[1]),
            Some(&later_points[2])
        );
        assert_eq!(
            chosen.inlier_point(&mesh_points, &chosen.planes[0], 3),
            Some(&mesh_points[3])
        );
        // A cell outside every region whose earlier plane's region took the later fit
        // takes the later fit's plane there.
        let outside = choose_regions(
            RegionFit {
                assigned: vec![1, 1, 2, 2, 0, 1],
                ..mine.clone()
            },
            later.clone(),
            later_points.clone(),
        );
        assert_eq!(
            outside.assigned[5], 3,
            "later's plane 2 (region 1) after renumbering"
        );
        // The regions of the two fits differ (they cannot for one view): mine.
        let other = RegionFit {
            region: vec![1, 1, 2, 2, 0, 0],
            ..later.clone()
        };
        assert_eq!(choose_regions(mine.clone(), other, later_points), mine);
        // No region takes the later fit: no later points are kept, mine is unchanged.
        let weak = RegionFit {
            planes: vec![plane(0, 5.0, vec![0])],
            assigned: vec![1, 1, 0, 0, 0, 0],
            ..base
        };
        let chosen = choose_regions(mine.clone(), weak, vec![point(0, 9.0)]);
        assert_eq!(chosen.later, vec![false; 3]);
        assert!(chosen.later_points.is_empty());
        assert_eq!(
            (chosen.planes, chosen.assigned),
            (mine.planes, mine.assigned)
        );
    }

    /// `explain_cell` lists a cell's pixels best first by the rule in force and names the
    /// pixel `support_points_with` chose: by cost (ACMMP), by the count of confirming
    /// sources, by cost − confidence; a pixel the check fails or above the cost limit is
    /// never ahead of one that may be chosen.
    #[test]
    fn a_cells_support_point_is_explained_by_the_rule_in_force() {
        let s = crate::synthetic::generate(&crate::synthetic::SyntheticOptions {
            views: 3,
            width: 20,
            height: 20,
            seed: 1,
            noise_sigma: 0.0,
            room: false,
            sources: crate::scene::geometry::DEFAULT_SOURCES,
        })
        .unwrap();
        let problem = ViewProblem::new(&s.scene, 0, 0);
        let n = 400;
        let d = 0.5 * (problem.depth_min + problem.depth_max);
        let plane = vec![[0.0, 0.0, -1.0, d]; n];
        let base = Params {
            prior_cell: 5,
            ..Params::default()
        };
        let sources = problem.num_sources() as u32;
        let scale = confirmation_scale(base.prior_consistency, sources);
        // Cell (0, 0): pixel 0 cheapest, 1 most confirmed, 2 best cost − confidence, 3
        // cheapest of all but inconsistent, 4 confirmed and cheap but above the cost limit.
        let mut cost = vec![0.5f32; n];
        let mut keys = vec![f32::NAN; n];
        let key = |confidence: f32| (sources as f32 - confidence) * scale;
        for (i, c, k) in [
            (0, 0.005, key(0.4)),
            (1, 0.09, key(1.30)),
            (2, 0.01, key(1.28)),
            (3, 0.001, f32::NAN),
            (4, 0.40, key(2.0)),
        ] {
            cost[i] = c;
            keys[i] = k;
        }
        let explain =
            |p: &Params| explain_cell(&problem, p, &plane, &cost, Some(&keys), None, 2, 3).unwrap();
        let by_cost = explain(&base);
        assert_eq!(by_cost.origin, (0, 0));
        assert_eq!(by_cost.candidates.len(), 25);
        assert_eq!(by_cost.chosen, Some((0, 0)));
        let by_count = explain(&Params {
            prior_confirmed_points: true,
            ..base.clone()
        });
        assert_eq!(by_count.chosen, Some((1, 0)));
        let by_score = explain(&Params {
            prior_confirmed_points: true,
            prior_confidence_score: true,
            ..base.clone()
        });
        assert_eq!(by_score.chosen, Some((2, 0)));
        let first = &by_score.candidates[0];
        assert_eq!((first.x, first.y), (2, 0));
        assert!((first.confidence.unwrap() - 1.28).abs() < 1e-5);
        assert!((first.score - (0.01 - 1.28)).abs() < 1e-5);
        let order: Vec<(u32, u32)> = by_score.candidates[..3]
            .iter()
            .map(|c| (c.x, c.y))
            .collect();
        assert_eq!(order, vec![(2, 0), (1, 0), (0, 0)]);
        // Above the cost limit (and not a flat window) after every pixel that may be taken;
        // the inconsistent ones last.
        let four = by_score
            .candidates
            .iter()
            .position(|c| (c.x, c.y) == (4, 0))
            .unwrap();
        assert_eq!(
            by_score.candidates[four].eligibility,
            Eligibility::CostTooHigh
        );
        assert_eq!(four, 3);
        assert_eq!(
            by_score.candidates[24].eligibility,
            Eligibility::Inconsistent
        );
        assert!(!by_score.by_flat_window);
        // No consistent pixel: no point, and the explanation says so.
        let none = explain_cell(
            &problem,
            &base,
            &plane,
            &cost,
            Some(&vec![9.0; n]),
            None,
            7,
            7,
        )
        .unwrap();
        assert_eq!(none.chosen, None);
        assert_eq!(none.origin, (5, 5));
        assert!(explain_cell(&problem, &base, &plane, &cost, None, None, 20, 0).is_none());
    }

    /// White noise of deviation `sigma` (Box-Muller over a hash of the pixel), seeded.
    fn white_noise(i: usize, seed: u64, sigma: f32) -> f32 {
        let h = |k: u64| {
            let mut z = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed ^ (k << 59);
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let (u1, u2) = (h(1).max(1e-12), h(2));
        ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32 * sigma
    }

    #[test]
    fn image_noise_finds_the_sensor_noise_under_shading_and_texture() {
        let (w, h) = (160u32, 120u32);
        // Left half a ramp of shading, right half a fine texture of 20 grey levels, all at
        // mid grey: the texture's blocks answer the mask, the ramp's do not.
        let scene = |i: usize| {
            let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
            if x < 80.0 {
                90.0 + 0.4 * x + 0.2 * y
            } else {
                120.0 + 20.0 * ((x * 1.7).sin() * (y * 1.3).cos())
            }
        };
        let image = |sigma: f32| -> Vec<f32> {
            (0..(w * h) as usize)
                .map(|i| scene(i) + white_noise(i, 7, sigma))
                .collect()
        };
        // Without noise the mask cancels the ramp exactly: nothing is taken from a window.
        assert!(image_noise(&image(0.0), w, h) < 1e-3);
        for sigma in [1.0f32, 3.0, 6.0] {
            let est = image_noise(&image(sigma), w, h);
            eprintln!("σ {sigma}: estimated {est:.3}");
            // Measured: 0.900, 2.699 and 5.398 (the lower decile of 16-px blocks, 0.90σ).
            assert!(
                est > 0.85 * sigma && est < 0.95 * sigma,
                "σ {sigma}: estimated {est}"
            );
        }
        // Saturated blocks hold no noise and are skipped: two thirds of the image at 255.
        let clipped: Vec<f32> = image(3.0)
            .iter()
            .enumerate()
            .map(|(i, &v)| if i % w as usize >= 55 { 255.0 } else { v })
            .collect();
        let est = image_noise(&clipped, w, h);
        eprintln!("two thirds saturated, σ 3: estimated {est:.3}");
        // Measured: 2.625 (the left third's blocks alone).
        assert!(est > 2.4 && est < 2.85, "with saturation: {est}");
        // Too small for a block: nothing to estimate.
        assert_eq!(image_noise(&image(3.0)[..15 * 15], 15, 15), 0.0);
    }

    #[test]
    fn a_noisy_wall_is_flat_beyond_its_noise_and_texture_is_not() {
        // A wall of shading under noise of 3 grey levels, with a textured square in the
        // middle: around its mean every wall window spreads about 3 (half of them fail the
        // 3-level test); beyond the image's noise they pass, and the texture still fails.
        let (w, h) = (96u32, 72u32);
        let textured = |x: u32, y: u32| (36..60).contains(&x) && (24..48).contains(&y);
        let images: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let base = 100.0 + 0.3 * x as f32;
                let tex = if textured(x, y) {
                    25.0 * ((x as f32 * 1.1).sin() + (y as f32 * 0.9).cos())
                } else {
                    0.0
                };
                base + tex + white_noise(i as usize, 11, 3.0)
            })
            .collect();
        let problem = ViewProblem {
            view: 0,
            key: 0,
            scale: 0,
            width: w,
            height: h,
            k: [80.0, 80.0, 48.0, 36.0],
            depth_min: 1.0,
            depth_max: 5.0,
            images,
            sources: Vec::new(),
            source_views: Vec::new(),
        };
        let noise = image_noise(&problem.images, w, h);
        let raw = window_spread(&problem, 5, true, 0.0);
        let beyond = window_spread(&problem, 5, true, noise * noise);
        let params = Params {
            prior_regions: true,
            prior_flat_ramp: true,
            prior_flat_noise: true,
            ..Params::default()
        };
        assert_eq!(flat_spread(&problem, &params), beyond);
        let off = Params {
            prior_flat_noise: false,
            ..params.clone()
        };
        assert_eq!(flat_spread(&problem, &off), raw);
        // The wall's windows wholly away from the square.
        let wall: Vec<usize> = (0..(w * h) as usize)
            .filter(|&i| {
                let (x, y) = (i as u32 % w, i as u32 / w);
                !(25..71).contains(&x) || !(13..59).contains(&y)
            })
            .collect();
        let share = |s: &[f32], idx: &[usize]| {
            idx.iter().filter(|&&i| s[i] < FLAT_WINDOW_STD).count() as f64 / idx.len() as f64
        };
        let inside: Vec<usize> = (0..(w * h) as usize)
            .filter(|&i| {
                let (x, y) = (i as u32 % w, i as u32 / w);
                (41..55).contains(&x) && (29..43).contains(&y)
            })
            .collect();
        let (before, after) = (share(&raw, &wall), share(&beyond, &wall));
        // Measured: noise 2.58; the wall's windows flat 53.4% around their ramp, 100% beyond
        // the noise; the texture's none either way.
        eprintln!("noise {noise:.2}: wall flat {before:.3} -> {after:.3}");
        assert!(before < 0.8, "{before}");
        assert!(after > 0.99, "{after}");
        assert_eq!(share(&beyond, &inside), 0.0);
        // Never more than the raw spread.
        assert!(beyond.iter().zip(&raw).all(|(b, r)| b <= r));
    }

    #[test]
    fn the_oracle_admits_the_share_of_false_positives_asked_for() {
        // 1000 pixels at depth 1; the truth says 1 on the first half, 2 on the second
        // (wrong); the real test passes every even pixel; pixel 999's truth is unknown.
        let n = 1000;
        let plane = vec![[0.0, 0.0, -1.0, 1.0]; n];
        let mut truth: Vec<f32> = (0..n).map(|i| if i < 500 { 1.0 } else { 2.0 }).collect();
        truth[999] = 0.0;
        let real: Vec<f32> = (0..n).map(|i| if i % 2 == 0 { 0.5 } else { 9.0 }).collect();
        let none = oracle_errors_admitting(&plane, &truth, &real, 2.0, 0, 3);
        assert_eq!(none, oracle_errors(&plane, &truth));
        let all = oracle_errors_admitting(&plane, &truth, &real, 2.0, 100, 3);
        let strong = |e: &[f32]| (0..n).filter(|&i| e[i] < 2.0).collect::<Vec<_>>();
        // Every right pixel, and every wrong one the real test passes (with its own error).
        let expected: Vec<usize> = (0..n)
            .filter(|&i| i < 500 || (i % 2 == 0 && i != 999))
            .collect();
        assert_eq!(strong(&all), expected);
        assert_eq!(all[600], 0.5);
        // A third: about a third of the 250 false positives, a subset of all of them, and
        // another view draws other pixels.
        let third = strong(&oracle_errors_admitting(&plane, &truth, &real, 2.0, 33, 3));
        let admitted = third.iter().filter(|&&i| i >= 500).count();
        assert!((60..=105).contains(&admitted), "{admitted} of 250");
        assert!(third.iter().all(|i| expected.contains(i)));
        let other = strong(&oracle_errors_admitting(&plane, &truth, &real, 2.0, 33, 4));
        assert_ne!(third, other);
    }

    #[test]
    fn acos_approx_is_close_and_clamped() {
        for i in -100..=100 {
            let x = i as f32 / 100.0;
            assert!((acos_approx(x) - x.acos()).abs() < 2e-6, "{x}");
        }
        assert_eq!(acos_approx(1.000_001), 0.0);
        assert!((acos_approx(-1.5) - std::f32::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn the_prior_factor_peaks_at_the_prior_and_floors_at_gamma() {
        let params = Params::default();
        let t = PriorTerms::new(&params, 1.0, 5.0);
        let prior = [0.0, 0.0, -1.0, 3.0];
        let at = prior_factor(prior, prior, &t);
        assert!((at - 1.5).abs() < 1e-6, "{at}");
        // One σd away in depth: γ + e^(-1/2).
        let off = prior_factor([0.0, 0.0, -1.0, 3.0 + t.sigma_depth], prior, &t);
        assert!((off - (0.5 + (-0.5f32).exp())).abs() < 1e-5, "{off}");
        // One σθ away in angle.
        let a = 5f32.to_radians();
        let tilted = prior_factor([a.sin(), 0.0, -a.cos(), 3.0], prior, &t);
        assert!((tilted - (0.5 + (-0.5f32).exp())).abs() < 1e-4, "{tilted}");
        let far = prior_factor([0.0, 0.0, -1.0, 4.5], prior, &t);
        assert!((far - 0.5).abs() < 1e-6, "{far}");
    }

    fn point(x: u32, y: u32, depth: f32) -> SupportPoint {
        SupportPoint {
            x,
            y,
            depth,
            cost: 0.0,
            normal: [0.0, 0.0, -1.0],
        }
    }

    /// A window of shading (a ramp of 1.5 grey levels a pixel) is flat around its ramp and
    /// not around its mean; an edge (a step of 40 grey levels) or noise is flat around
    /// neither; at the border, where the window is clipped, the ramp is still taken out.
    #[test]
    fn a_shading_ramp_is_flat_around_its_plane() {
        let (w, h) = (40u32, 20u32);
        let problem = |f: &dyn Fn(u32, u32) -> f32| ViewProblem {
            view: 0,
            key: 0,
            scale: 0,
            width: w,
            height: h,
            k: [40.0, 40.0, 20.0, 10.0],
            depth_min: 1.0,
            depth_max: 10.0,
            images: (0..w * h).map(|i| f(i % w, i / w)).collect(),
            sources: Vec::new(),
            source_views: Vec::new(),
        };
        let ramp = problem(&|x, y| 60.0 + 1.5 * x as f32 + 0.5 * y as f32);
        let mean = window_spread(&ramp, 5, false, 0.0);
        let plane = window_spread(&ramp, 5, true, 0.0);
        for i in 0..(w * h) as usize {
            assert!(plane[i] < 0.05, "pixel {i}: {}", plane[i]);
            // Around the mean a whole 11x11 window of the ramp spreads by ~4.9 levels.
            let (x, y) = (i as u32 % w, i as u32 / w);
            if (5..w - 5).contains(&x) && (5..h - 5).contains(&y) {
                assert!(mean[i] > FLAT_WINDOW_STD, "pixel {i}: {}", mean[i]);
            }
        }
        // A step of 40 levels at x = 20 on the same ramp: the windows across it are not flat.
        let step = problem(&|x, y| {
            60.0 + 1.5 * x as f32 + 0.5 * y as f32 + if x >= 20 { 40.0 } else { 0.0 }
        });
        let across = window_spread(&step, 5, true, 0.0);
        // The ramp takes up part of a step (measured: 9.96 levels left of its 19.9 around the
        // mean), so an edge must be about 12 levels high to keep its window from being flat.
        let at = across[(10 * w + 20) as usize];
        assert!(at > 3.0 * FLAT_WINDOW_STD, "{at}");
        assert!(across[(10 * w + 5) as usize] < 0.05);
        // A ramp under noise of ±4 levels: the noise stays.
        let noisy = problem(&|x, y| {
            60.0 + 1.5 * x as f32 + if (x * 7 + y * 13) % 3 == 0 { 4.0 } else { -2.0 }
        });
        let n = window_spread(&noisy, 5, true, 0.0);
        assert!(
            n[(10 * w + 20) as usize] > 2.5,
            "{}",
            n[(10 * w + 20) as usize]
        );
    }

    /// A wall (grey 100 with ±1 of noise) beside a textured object (columns from 20 on, 40
    /// levels brighter and ±15 of texture): 3 px from the edge the window holds 33 object
    /// pixels of its 121 (12 of the cost's 36 samples), so over every pixel it is not flat, and under the adaptive
    /// weight, which leaves the object's samples out, it is as flat as the open wall. The
    /// authors' unsquared weight keeps the object's samples and the window not flat. The
    /// object's own windows are not flat under any weight.
    #[test]
    fn the_wall_beside_an_object_is_flat_as_the_cost_weighs_it() {
        let (w, h) = (40u32, 20u32);
        let noise = |x: u32, y: u32| {
            if (x * 7 + y * 13).is_multiple_of(3) {
                1.0
            } else {
                -0.5
            }
        };
        let texture = |x: u32, y: u32| ((x * 37 + y * 91) % 31) as f32 - 15.0;
        let problem = ViewProblem {
            view: 0,
            key: 0,
            scale: 0,
            width: w,
            height: h,
            k: [40.0, 40.0, 20.0, 10.0],
            depth_min: 1.0,
            depth_max: 10.0,
            images: (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    if x >= 20 {
                        140.0 + texture(x, y)
                    } else {
                        100.0 + noise(x, y)
                    }
                })
                .collect(),
            sources: Vec::new(),
            source_views: Vec::new(),
        };
        let at = |m: &[f32], x: u32| m[(10 * w + x) as usize];
        let every = window_spread(&problem, 5, true, 0.0);
        let adaptive = Params {
            prior_flat_ramp: true,
            prior_flat_weighted: true,
            bilateral_kernel: crate::acmm::params::BilateralKernel::Adaptive,
            ..Params::default()
        };
        let laplacian = Params {
            bilateral_kernel: crate::acmm::params::BilateralKernel::Laplacian,
            ..adaptive.clone()
        };
        let weighed = weighted_window_spread(&problem, &adaptive, 0.0);
        let authors = weighted_window_spread(&problem, &laplacian, 0.0);
        // The open wall: flat either way.
        assert!(at(&every, 8) < FLAT_WINDOW_STD && at(&weighed, 8) < FLAT_WINDOW_STD);
        // 3 px from the edge (x = 17: the window reaches x = 22).
        assert!(at(&every, 17) > FLAT_WINDOW_STD, "{}", at(&every, 17));
        assert!(at(&weighed, 17) < FLAT_WINDOW_STD, "{}", at(&weighed, 17));
        assert!(
            at(&weighed, 17) < 1.5 * at(&weighed, 8) + 0.1,
            "{} {}",
            at(&weighed, 17),
            at(&weighed, 8)
        );
        assert!(at(&authors, 17) > FLAT_WINDOW_STD, "{}", at(&authors, 17));
        // On the object: not flat under any weight.
        for x in 25..35 {
            assert!(
                at(&weighed, x) > FLAT_WINDOW_STD,
                "x {x}: {}",
                at(&weighed, x)
            );
            assert!(at(&every, x) > FLAT_WINDOW_STD, "x {x}: {}", at(&every, x));
        }
        // The dispatcher reads the option.
        assert_eq!(flat_spread(&problem, &adaptive), weighed);
        let plain = Params {
            prior_flat_weighted: false,
            ..adaptive.clone()
        };
        assert_eq!(flat_spread(&problem, &plain), every);
    }

    /// The 100x80 view (f = 100, principal point (50, 40)) of the region tests, with
    /// `sources`.
    fn wall_view(sources: Vec<GpuSource>) -> ViewProblem {
        let source_views = (1..=sources.len()).collect();
        ViewProblem {
            view: 0,
            key: 7,
            scale: 0,
            width: 100,
            height: 80,
            k: [100.0, 100.0, 50.0, 40.0],
            depth_min: 1.0,
            depth_max: 20.0,
            images: Vec::new(),
            sources,
            source_views,
        }
    }

    /// The region tests' wall in `wall_view`: 1/d = 0.05 u + 0.02 v + 0.25 (u, v normalised
    /// coordinates).
    fn slanted_wall(x: u32, y: u32) -> f32 {
        let (u, v) = ((x as f64 - 50.0) / 100.0, (y as f64 - 40.0) / 100.0);
        (1.0 / (0.05 * u + 0.02 * v + 0.25)) as f32
    }

    /// `prior_region_cover_seen`: a wall whose points are wrong (scattered too near) in its
    /// left 7 of 12 flat columns, seen by one source shifted so that the plane's points of the left
    /// 6 columns fall outside its image. The wall holds 5 columns of points, 42% of the
    /// region: RANSAC takes it, but counted over every cell it paints it holds too few and
    /// is dropped. Counting only the points a source could contradict (the 6 columns it sees),
    /// it holds 5 of 6 and paints the whole region, the unseen columns included; with the
    /// wrong points in the seen columns instead it is dropped either way.
    #[test]
    fn a_wall_is_judged_by_the_points_a_source_could_contradict() {
        let k = [100.0, 100.0, 50.0, 40.0];
        let shifted = GpuSource {
            k,
            r0: [1.0, 0.0, 0.0, 0.0],
            r1: [0.0, 1.0, 0.0, 0.0],
            r2: [0.0, 0.0, 1.0, 0.0],
            // X_src = X_ref - 1.2 x: a point at depth ~4.2 moves ~29 px left.
            t: [-1.2, 0.0, 0.0, 0.0],
            size: [100, 80, 0, 0],
        };
        let problem = wall_view(vec![shifted]);
        let wall = slanted_wall;
        let (cw, ch) = (20u32, 16u32);
        let mut records = vec![SupportRecord::default(); (cw * ch) as usize];
        for gy in 0..ch {
            for gx in 0..cw {
                records[(gy * cw + gx) as usize].normal[3] = if gx < 12 { 25.0 } else { 3.0 };
            }
        }
        // One point per flat cell at (5 gx + 2, 5 gy + 1); in the columns `wrong(gx)` too
        // near by 4-28%, seven depths along the diagonals (no plane holds a quarter of them).
        let points_with = |wrong: &dyn Fn(u32) -> bool| -> Vec<SupportPoint> {
            let mut points = Vec::new();
            for gy in 0..ch {
                for gx in 0..12 {
                    let (x, y) = (gx * 5 + 2, gy * 5 + 1);
                    let off = 0.04 * ((gx + gy) % 7 + 1) as f32;
                    let d = wall(x, y) * if wrong(gx) { 1.0 - off } else { 1.0 };
                    points.push(point(x, y, d));
                }
            }
            points
        };
        // The source sees the wall's points from column 6 on, none of columns 0-5.
        for gx in 0..12u32 {
            let (x, y) = (gx * 5 + 2, 41);
            assert_eq!(
                super::super::cpu::seen_by_a_source(&problem, wall(x, y), x, y),
                gx >= 6,
                "column {gx}"
            );
        }
        let regions = Params {
            prior_regions: true,
            ..Params::default()
        };
        let seen = Params {
            prior_region_cover_seen: true,
            ..regions.clone()
        };
        let left = points_with(&|gx| gx < 7);
        assert_eq!(
            fit_regions(&problem, &regions, &records, &left, None).counts(),
            (12 * 16, 0, 1, 0)
        );
        let fit = fit_regions(&problem, &seen, &records, &left, None);
        assert_eq!(fit.counts(), (12 * 16, 12 * 16, 1, 1));
        assert_eq!(fit.planes[0].inliers.len(), 5 * 16);
        // The plane is the wall's.
        let pl = fit.planes[0].plane;
        let (x, y) = (10u32, 30u32);
        let ray = [(x as f32 - 50.0) / 100.0, (y as f32 - 40.0) / 100.0, 1.0];
        let d = -pl[3] / (pl[0] * ray[0] + pl[1] * ray[1] + pl[2] * ray[2]);
        assert!((d - wall(x, y)).abs() < 1e-3 * wall(x, y), "{d}");
        // The same share wrong where the source sees them: the points contradict the wall.
        let right = points_with(&|gx| gx >= 5);
        assert_eq!(
            fit_regions(&problem, &seen, &records, &right, None).counts(),
            (12 * 16, 0, 1, 0)
        );
        // `prior_region_near` asks the same of each cell's neighbourhood: the unseen columns'
        // wrong points do not count there either, and the seen wrong column 6 does. Columns
        // 0-4 see no point that counts and keep the plane; column 5's counted neighbours are
        // column 6's wrong points, so it is left to its triangles; column 6 (its wrong points
        // against column 7's right ones, a tie) keeps it.
        let near = Params {
            prior_region_near: 1,
            ..seen.clone()
        };
        let local = fit_regions(&problem, &near, &records, &left, None);
        for gy in 0..ch {
            for gx in 0..12 {
                let painted = local.assigned[(gy * cw + gx) as usize] == 1;
                assert_eq!(painted, gx != 5, "({gx}, {gy})");
            }
        }
        let without = Params {
            prior_region_cover_seen: false,
            ..near.clone()
        };
        assert_eq!(
            fit_regions(&problem, &without, &records, &left, None)
                .counts()
                .1,
            0
        );
    }

    /// `prior_region_cover_band`: a noisy wall, 3 in 7 of its points on it and the rest
    /// 2.2% and 4.4% off it, as many nearer as farther (levels further apart than a plane's
    /// two tolerances, so no plane holds two of them, and none holds a quarter of the region
    /// but the wall). RANSAC finds the wall, but it holds under half the points it paints:
    /// the cover test drops it. With the band at 5 tolerances the rest balance and it paints
    /// the region. With the same offsets all farther (a surface bending away, half of them far
    /// past the band) the band adds nothing, and the plane is dropped.
    #[test]
    fn a_noisy_wall_keeps_its_plane_when_its_points_scatter_both_ways() {
        let problem = wall_view(Vec::new());
        let (cw, ch) = (20u32, 16u32);
        let mut records = vec![SupportRecord::default(); (cw * ch) as usize];
        for gy in 0..ch {
            for gx in 0..cw {
                records[(gy * cw + gx) as usize].normal[3] = if gx < 12 { 25.0 } else { 3.0 };
            }
        }
        let scene = |offsets: [f32; 4]| {
            let mut points = Vec::new();
            for gy in 0..ch {
                for gx in 0..12 {
                    let (x, y) = (gx * 5 + 2, gy * 5 + 1);
                    let k = ((gx + gy) % 7) as usize;
                    let off = if k < 3 { 0.0 } else { offsets[k - 3] };
                    points.push(point(x, y, slanted_wall(x, y) * (1.0 + off)));
                }
            }
            points
        };
        let off = Params {
            prior_regions: true,
            ..Params::default()
        };
        let on = Params {
            prior_region_cover_band: 5.0,
            ..off.clone()
        };
        let both_ways = scene([-0.022, 0.022, -0.044, 0.044]);
        let exact = both_ways
            .iter()
            .filter(|p| (p.depth - slanted_wall(p.x, p.y)).abs() < 1e-6 * p.depth);
        // 83 of the 192 points on the wall: RANSAC's plane, under the cover test's half.
        assert_eq!(exact.count(), 83);
        assert_eq!(
            fit_regions(&problem, &off, &records, &both_ways, None).counts(),
            (12 * 16, 0, 1, 0)
        );
        let fit = fit_regions(&problem, &on, &records, &both_ways, None);
        assert_eq!(fit.counts(), (12 * 16, 12 * 16, 1, 1));
        assert_eq!(fit.planes[0].inliers.len(), 83);
        let pl = fit.planes[0].plane;
        for (x, y) in [(10u32, 30u32), (52, 71)] {
            let ray = [(x as f32 - 50.0) / 100.0, (y as f32 - 40.0) / 100.0, 1.0];
            let d = -pl[3] / (pl[0] * ray[0] + pl[1] * ray[1] + pl[2] * ray[2]);
            assert!(
                (d - slanted_wall(x, y)).abs() < 1e-3 * slanted_wall(x, y),
                "{d}"
            );
        }
        // One way only: the points within the band are all farther, and the plane goes.
        let one_way = scene([0.022, 0.12, 0.044, 0.2]);
        assert_eq!(
            fit_regions(&problem, &on, &records, &one_way, None).counts(),
            (12 * 16, 0, 1, 0)
        );
        // A band of 3 tolerances takes in only the 2.2% points, 28 each way: 83 + 2 × 28 of
        // 192 pass.
        let narrow = Params {
            prior_region_cover_band: 3.0,
            ..off.clone()
        };
        assert_eq!(
            fit_regions(&problem, &narrow, &records, &both_ways, None).counts(),
            (12 * 16, 12 * 16, 1, 1)
        );
        // Both ways, but in patches: the same offsets, nearer on the region's left half
        // and farther on its right (a plane through a curved surface or across a fold).
        // The sides balance as before, yet neighbouring points lie on opposite sides only
        // along the seam, so the band counts nothing and the plane goes.
        let patches: Vec<SupportPoint> = both_ways
            .iter()
            .map(|p| {
                let wall = slanted_wall(p.x, p.y);
                let off = (p.depth / wall - 1.0).abs();
                let side = if p.x < 30 { -1.0 } else { 1.0 };
                point(p.x, p.y, wall * (1.0 + side * off))
            })
            .collect();
        let (near, far) = patches.iter().fold((0, 0), |(n, f), p| {
            let r = p.depth / slanted_wall(p.x, p.y) - 1.0;
            (n + usize::from(r < -1e-4), f + usize::from(r > 1e-4))
        });
        assert!(near > 40 && far > 40, "{near} nearer, {far} farther");
        assert_eq!(
            fit_regions(&problem, &on, &records, &patches, None).counts(),
            (12 * 16, 0, 1, 0)
        );
    }

    /// A 100x80 view (cells of 5: 20x16) whose left 12 columns of cells are flat: a slanted
    /// wall, a point per flat cell on it except two far off it, and points in the textured
    /// cells that are not on it.
    /// `prior_region_crease`: a region of one shade over a room's corner. Columns 0-9 of
    /// its cells are the slanted wall, columns 10-11 a second wall meeting it between
    /// columns 9 and 10 (32 of the region's 192 points, less than the quarter sequential
    /// RANSAC asks of a plane). Without the rule the first wall paints the second's cells;
    /// with it the second wall, crossing the first between every pair of their neighbouring
    /// points, is a plane of its own. The same columns 5% behind the wall (a step, as a
    /// patch of wrong depths lies off its wall) get no plane either way.
    #[test]
    fn a_region_folds_at_a_crease_but_not_at_a_step() {
        let problem = wall_view(Vec::new());
        let wall = |x: u32, y: u32| 1.0 / slanted_wall(x, y) as f64;
        // The corner at x = 49.5: the second wall's inverse depth leaves the first's by
        // 0.5 (u − u0), 5% at the nearest column of points (x = 52), 15% at x = 57.
        let u0 = (49.5 - 50.0) / 100.0;
        let folded = |x: u32, y: u32| {
            let u = (x as f64 - 50.0) / 100.0;
            (1.0 / (wall(x, y) + 0.5 * (u - u0))) as f32
        };
        let behind = |x: u32, y: u32| slanted_wall(x, y) * 1.05;
        let (cw, ch) = (20u32, 16u32);
        let mut records = vec![SupportRecord::default(); (cw * ch) as usize];
        let scene = |second: &dyn Fn(u32, u32) -> f32| {
            let mut points = Vec::new();
            for gy in 0..ch {
                for gx in 0..cw {
                    let (x, y) = (gx * 5 + 2, gy * 5 + 1);
                    if gx < 12 {
                        let d = if gx < 10 {
                            slanted_wall(x, y)
                        } else {
                            second(x, y)
                        };
                        points.push(point(x, y, d));
                    }
                }
            }
            points
        };
        for gy in 0..ch {
            for gx in 0..cw {
                records[(gy * cw + gx) as usize].normal[3] = if gx < 12 { 25.0 } else { 3.0 };
            }
        }
        let off = Params {
            prior_regions: true,
            ..Params::default()
        };
        let on = Params {
            prior_region_crease: true,
            ..off.clone()
        };
        let second_cells =
            || (0..ch).flat_map(move |gy| (10..12).map(move |gx| (gy * cw + gx) as usize));
        let corner = scene(&folded);
        let one = fit_regions(&problem, &off, &records, &corner, None);
        assert_eq!(one.counts(), (12 * 16, 12 * 16, 1, 1));
        assert!(second_cells().all(|c| one.assigned[c] == 1));
        let two = fit_regions(&problem, &on, &records, &corner, None);
        assert_eq!(two.counts(), (12 * 16, 12 * 16, 1, 2));
        assert_eq!(two.planes[1].inliers.len(), 32);
        assert!(second_cells().all(|c| two.assigned[c] == 2));
        assert!((0..ch).all(|gy| (0..10).all(|gx| two.assigned[(gy * cw + gx) as usize] == 1)));
        // The second plane is the second wall's: its depth at a point of it.
        let p = two.planes[1].plane;
        let ray = [(57.0 - 50.0) / 100.0, (41.0 - 40.0) / 100.0, 1.0];
        let d = -p[3] / (p[0] * ray[0] + p[1] * ray[1] + p[2] * ray[2]);
        assert!(
            (d - folded(57, 41)).abs() < 1e-3 * d,
            "{d} against {}",
            folded(57, 41)
        );
        // A step: the same columns 5% behind hold a plane as well as the folded ones did,
        // but it never crosses the wall's: no second plane, the wall paints them.
        let step = scene(&behind);
        for params in [&off, &on] {
            let fit = fit_regions(&problem, params, &records, &step, None);
            assert_eq!(fit.counts(), (12 * 16, 12 * 16, 1, 1));
        }
        // Deterministic.
        assert_eq!(fit_regions(&problem, &on, &records, &corner, None), two);
        // The second wall three columns wide (10-12) and its points loosely held: only
        // column 10's even rows on it, the rest scattered over nine depths (whose larger
        // planes, 16 and 13 points, are steps and rejected). The second wall's plane (8
        // points) crosses the wall's between 18 of 23 pairs, but holds too few of the
        // points of the cells nearest its own, so the painting's test drops it, and its
        // cells go back to the wall's plane, as without the rule (not to their triangles:
        // with the drop after the painting, as for other planes, this fails).
        let mut wide = records.clone();
        for gy in 0..ch {
            wide[(gy * cw + 12) as usize].normal[3] = 25.0;
        }
        let mut loose = Vec::new();
        for gy in 0..ch {
            for gx in 0..13 {
                let (x, y) = (gx * 5 + 2, gy * 5 + 1);
                let d = if gx < 10 {
                    slanted_wall(x, y)
                } else if gx == 10 && gy % 2 == 0 {
                    folded(x, y)
                } else {
                    folded(x, y) * (1.0 + 0.04 * ((gy * 5 + gx * 3) % 9 + 1) as f32)
                };
                loose.push(point(x, y, d));
            }
        }
        let without = fit_regions(&problem, &off, &wide, &loose, None);
        assert_eq!(without.counts(), (13 * 16, 13 * 16, 1, 1));
        assert_eq!(fit_regions(&problem, &on, &wide, &loose, None), without);
    }

    #[test]
    fn a_flat_region_takes_the_plane_most_of_its_points_agree_on() {
        let problem = wall_view(Vec::new());
        let k = problem.k;
        let params = Params {
            prior_regions: true,
            ..Params::default()
        };
        let wall = slanted_wall;
        let (cw, ch) = (20u32, 16u32);
        let mut records = vec![SupportRecord::default(); (cw * ch) as usize];
        let mut points = Vec::new();
        for gy in 0..ch {
            for gx in 0..cw {
                let cell = (gy * cw + gx) as usize;
                let (x, y) = (gx * 5 + 2, gy * 5 + 1);
                let flat = gx < 12;
                // A flat cell counts all 25 windows flat; a textured one a few.
                records[cell].normal[3] = if flat { 25.0 } else { 3.0 };
                let wrong = flat && (cell == 3 || cell == 45);
                let depth = if wrong || !flat {
                    wall(x, y) * 0.8
                } else {
                    wall(x, y)
                };
                // Every third textured cell and every flat one but cell 20 has a point.
                if (flat && cell != 20) || (!flat && cell.is_multiple_of(3)) {
                    points.push(point(x, y, depth));
                }
            }
        }
        let fit = fit_regions(&problem, &params, &records, &points, None);
        let (flat_cells, given, regions, planes) = fit.counts();
        assert_eq!((flat_cells, regions, planes), (12 * 16, 1, 1));
        // Every flat cell, those whose points are off the plane and the one without a point
        // included: they take their neighbours'.
        assert_eq!(given, 12 * 16);
        assert_eq!(fit.assigned[3], 1);
        assert_eq!(fit.assigned[45], 1);
        assert_eq!(fit.assigned[20], 1);
        assert!((0..ch).all(|gy| (12..cw).all(|gx| fit.assigned[(gy * cw + gx) as usize] == 0)));
        assert_eq!(fit.planes[0].inliers.len(), 12 * 16 - 3);
        // The plane paints the region's pixels with the wall's depth, before any triangle.
        let mesh = PriorMesh {
            width: 100,
            height: 80,
            points: points.clone(),
            triangles: Vec::new(),
            regions: Some(fit.clone()),
        };
        let list = mesh.paint_list(k, &params);
        assert!(list.extended());
        let labels = rasterise(list.triangles(), 100, 80);
        let planes = prior_planes(&problem, &labels, &list, None, None);
        // (17, 2) is in cell 3, whose point is 20% off: it takes the wall's depth all the same.
        for (x, y) in [(0, 0), (30, 40), (59, 79), (11, 2), (17, 2)] {
            let d = planes[(y * 100 + x) as usize][3];
            assert!(
                (d - wall(x, y)).abs() < 1e-4 * wall(x, y),
                "({x}, {y}): {d}"
            );
        }
        assert_eq!(planes[(40 * 100 + 80) as usize][3], NO_TRIANGLE, "textured");
        // Deterministic, and the same from any seed here (every plane is found).
        assert_eq!(fit_regions(&problem, &params, &records, &points, None), fit);
        // Not planar: the flat points spread over five depths 3% apart, a fifth on each
        // (each a plane no quarter of the points holds): no plane, no cell takes one.
        let mut spread = points.clone();
        for (i, p) in spread.iter_mut().enumerate() {
            p.depth *= 1.0 + 0.03 * ((i % 5) as f32 - 2.0);
        }
        let none = fit_regions(&problem, &params, &records, &spread, None);
        assert_eq!(none.counts(), (12 * 16, 0, 1, 0));
        // A plane must hold most of the points of the cells it paints. The wall holding 3 in
        // 10 of the points (the rest scattered over seven other depths, a tenth each): a
        // quarter of the region, so RANSAC takes it, but it explains too little of the
        // cells it would paint, and they keep their triangles. Holding 6 in 10: it paints
        // them all.
        let part = |on_wall: usize| {
            let mut p = points.clone();
            for (i, q) in p.iter_mut().enumerate() {
                if i % 10 >= on_wall {
                    q.depth *= 1.0 + 0.05 * ((i % 7) as f32 + 1.0);
                }
            }
            fit_regions(&problem, &params, &records, &p, None).counts()
        };
        assert_eq!(part(3), (12 * 16, 0, 1, 0));
        assert_eq!(part(6), (12 * 16, 12 * 16, 1, 1));
        // A curved flank (`prior_region_near`): the last three flat columns bend away from
        // the wall, more with every column and by a row's own step, so no plane holds them.
        // Over all, the wall holds 141 of 191 points and paints every cell; checked within
        // two cells of each, it leaves the flank's columns (held 0 of 3, 1 of 4, 2 of 5
        // columns near them) to their triangles and keeps column 8 (3 of 5) and the cells
        // beside the two wrong points.
        let mut flank = points.clone();
        for q in flank.iter_mut() {
            let (gx, gy) = (q.x / 5, q.y / 5);
            if (9..12).contains(&gx) {
                q.depth *= 1.0 + 0.03 * (gx - 8) as f32 + 0.015 * (gy % 3) as f32;
            }
        }
        let all_over = fit_regions(&problem, &params, &records, &flank, None);
        assert_eq!(all_over.counts(), (12 * 16, 12 * 16, 1, 1));
        let near = Params {
            prior_region_near: 2,
            ..params.clone()
        };
        let local = fit_regions(&problem, &near, &records, &flank, None);
        assert_eq!(local.counts(), (12 * 16, 9 * 16, 1, 1));
        for gy in 0..ch {
            for gx in 0..12 {
                let painted = local.assigned[(gy * cw + gx) as usize] == 1;
                assert_eq!(painted, gx < 9, "cell ({gx}, {gy})");
            }
        }
        // On the wall with its two scattered wrong points the check changes nothing.
        assert_eq!(fit_regions(&problem, &near, &records, &points, None), fit);
        // The band beside the texture: the first textured column has most of its windows
        // flat (13 of 25). It joins the region at the default share (most of the pixels) and
        // takes the wall's plane; with every pixel asked for it stays out.
        let mut band = records.clone();
        for gy in 0..ch {
            band[(gy * cw + 12) as usize].normal[3] = 13.0;
        }
        let most = fit_regions(&problem, &params, &band, &points, None);
        assert_eq!(most.counts(), (13 * 16, 13 * 16, 1, 1));
        assert!((0..ch).all(|gy| most.assigned[(gy * cw + 12) as usize] == 1));
        let every = Params {
            prior_region_flat_share: 1.0,
            ..params.clone()
        };
        assert_eq!(
            fit_regions(&problem, &every, &band, &points, None)
                .counts()
                .0,
            12 * 16
        );
    }

    /// `prior_region_axes`: a wall whose support points scatter about it (each depth off by
    /// up to ±2.5%, uniformly, so about 40% lie within the 1% tolerance). Given the view's
    /// Manhattan frame, one of whose axes is the wall's normal, the region's plane is on
    /// that axis: one free number, its offset, which the scattered points fix where three of
    /// them cannot fix a normal. Given a frame turned 25° away from the wall, no axis plane
    /// holds a quarter of the points and the region's planes are RANSAC's, as without one.
    /// Either way sequential RANSAC takes a second plane from the half of the points left
    /// (with the frame a parallel one, on the same axis): a noisy wall comes out as two
    /// slices, which the painting interleaves (docs/method.md, `prior_region_axes`).
    #[test]
    fn a_region_takes_its_plane_on_the_rooms_axis() {
        let problem = wall_view(Vec::new());
        let (cw, ch) = (20u32, 16u32);
        let mut records = vec![SupportRecord::default(); (cw * ch) as usize];
        let mut points = Vec::new();
        let mut noise = crate::rng::Stream::new(&[3]);
        for gy in 0..ch {
            for gx in 0..cw {
                records[(gy * cw + gx) as usize].normal[3] = 25.0;
                let (x, y) = (gx * 5 + 2, gy * 5 + 1);
                let e = 0.05 * (noise.next_f32() - 0.5);
                points.push(point(x, y, slanted_wall(x, y) * (1.0 + e)));
            }
        }
        let params = Params {
            prior_regions: true,
            prior_region_axes: true,
            ..Params::default()
        };
        // The wall's normal, in the camera's frame: its inverse depth is
        // 0.05 x + 0.02 y + 0.25 along the ray (x, y, 1).
        use glam::DVec3;
        let frame_on = |normal: DVec3| {
            let e1 = normal.cross(DVec3::Y).normalize();
            crate::acmm::lines::Frame {
                axes: [e1, normal, normal.cross(e1)].map(<[f64; 3]>::from),
                segments: Vec::new(),
                along: Vec::new(),
            }
        };
        let n = DVec3::new(0.05, 0.02, 0.25).normalize();
        // The largest error of the depth a region's first plane gives the cells' pixels.
        let worst = |fit: &RegionFit| {
            let plane = fit.planes[0].plane;
            let mut e = 0.0f32;
            for gy in 0..ch {
                for gx in 0..cw {
                    let (x, y) = (gx * 5 + 2, gy * 5 + 1);
                    let r = ray(problem.k, x as f32, y as f32);
                    let d = -plane[3] / (plane[0] * r[0] + plane[1] * r[1] + plane[2] * r[2]);
                    e = e.max((d / slanted_wall(x, y) - 1.0).abs());
                }
            }
            e
        };
        let axes = |fit: &RegionFit| fit.planes.iter().map(|p| p.axis).collect::<Vec<_>>();
        let free = fit_regions_framed(&problem, &params, &records, &points, None, None);
        assert_eq!(free.counts(), (320, 320, 1, 2));
        assert_eq!(axes(&free), [FREE_PLANE; 2]);
        let on = fit_regions_framed(
            &problem,
            &params,
            &records,
            &points,
            None,
            Some(frame_on(n)),
        );
        assert_eq!(on.counts(), (320, 320, 1, 2));
        assert_eq!(axes(&on), [1, 1]);
        let normal = on.planes[0].plane;
        let c = DVec3::new(normal[0] as f64, normal[1] as f64, normal[2] as f64)
            .dot(n)
            .abs();
        assert!(c > 1.0 - 1e-6, "normal {normal:?}");
        // Measured: the axis plane within 0.38% of the wall at every cell, RANSAC's plane
        // through three scattered points 1.83% off at the far corner.
        let (e_on, e_free) = (worst(&on), worst(&free));
        assert!(e_on < 0.005 && e_free > 0.01, "{e_on} {e_free}");
        // A frame 25° off the wall: RANSAC's plane, as without a frame.
        let (s, co) = (25f64.to_radians().sin(), 25f64.to_radians().cos());
        let off = DVec3::new(co * n.x + s * n.z, n.y, -s * n.x + co * n.z).normalize();
        let turned = fit_regions_framed(
            &problem,
            &params,
            &records,
            &points,
            None,
            Some(frame_on(off)),
        );
        assert_eq!(turned.planes, free.planes);
    }

    /// `prior_region_edge`: a wall (cell rows 0-12) above a floor (rows 13-15, 60 of the 320
    /// cells), every cell flat (as `prior_flat_weighted` makes the cells along their edge),
    /// every point right. Joined into one region, the floor holds less than a quarter of its
    /// points and gets no plane of its own, and the wall's plane, holding 81% of the cells it
    /// paints, paints the floor too. Stopped at the edge between their shades (grey 100 and
    /// 130, each with a shading ramp of 0.3 a pixel), each is its own region with its own
    /// plane. An object over 8 of one wall cell's 25 pixels does not move its median.
    #[test]
    fn a_region_stops_at_an_edge_between_two_flat_surfaces() {
        let problem = wall_view(Vec::new());
        let (cw, ch) = (20u32, 16u32);
        let floor = |x: u32, y: u32| {
            let (u, v) = ((x as f64 - 50.0) / 100.0, (y as f64 - 40.0) / 100.0);
            (1.0 / (0.01 * u + 0.3 * v + 0.2)) as f32
        };
        let on_floor = |y: u32| y >= 65;
        let gray: Vec<f32> = (0..100 * 80u32)
            .map(|i| {
                let (x, y) = (i % 100, i / 100);
                let object = (15..19).contains(&x) && (10..12).contains(&y);
                let base = if on_floor(y) { 130.0 } else { 100.0 };
                if object { 220.0 } else { base + 0.3 * x as f32 }
            })
            .collect();
        let mut records = vec![SupportRecord::default(); (cw * ch) as usize];
        let mut points = Vec::new();
        for gy in 0..ch {
            for gx in 0..cw {
                records[(gy * cw + gx) as usize].normal[3] = 25.0;
                let (x, y) = (gx * 5 + 2, gy * 5 + 1);
                let depth = if on_floor(y) {
                    floor(x, y)
                } else {
                    slanted_wall(x, y)
                };
                points.push(point(x, y, depth));
            }
        }
        let joined = Params {
            prior_regions: true,
            ..Params::default()
        };
        let stopped = Params {
            prior_region_edge: true,
            ..joined.clone()
        };
        // The depth a cell's plane gives its point's pixel, against the point's own.
        let painted_right = |fit: &RegionFit, cell: usize| {
            let p = &points[cell];
            let a = fit.assigned[cell];
            a > 0 && {
                let plane = fit.planes[a as usize - 1].plane;
                let r = ray(problem.k, p.x as f32, p.y as f32);
                let d = -plane[3] / (plane[0] * r[0] + plane[1] * r[1] + plane[2] * r[2]);
                (d - p.depth).abs() < 1e-3 * p.depth
            }
        };
        let one = fit_regions(&problem, &joined, &records, &points, Some(&gray));
        assert_eq!(one.counts(), (320, 320, 1, 1));
        assert!((0..260).all(|c| painted_right(&one, c)));
        assert!((260..320).all(|c| !painted_right(&one, c)));
        // No intensities: no edge to stop at.
        assert_eq!(
            fit_regions(&problem, &stopped, &records, &points, None),
            one
        );
        let two = fit_regions(&problem, &stopped, &records, &points, Some(&gray));
        assert_eq!(two.counts(), (320, 320, 2, 2));
        assert!(
            (0..320).all(|c| painted_right(&two, c)),
            "{:?}",
            two.assigned
        );
        assert!((0..260).all(|c| two.region[c] == 1) && (260..320).all(|c| two.region[c] == 2));
        // The shades: each cell's median (the lower middle of 25 values: its middle column),
        // the object's cell (3, 2) moved by two columns of the ramp only.
        let shades = cell_shades(&gray, 100, 80, 5);
        assert_eq!(shades[2 * 20 + 2], 100.0 + 0.3 * 12.0);
        assert_eq!(shades[2 * 20 + 3], 100.0 + 0.3 * 19.0);
        assert_eq!(shades[13 * 20], 130.0 + 0.3 * 2.0);
        assert!(!edge_between(shades[0], shades[1]) && edge_between(shades[240], shades[260]));
    }

    #[test]
    fn a_triangle_on_a_fronto_parallel_plane_gives_its_depth_everywhere() {
        let k = [100.0, 100.0, 50.0, 40.0];
        let p = [point(10, 10, 4.0), point(60, 12, 4.0), point(30, 70, 4.0)];
        let plane = triangle_plane(k, [&p[0], &p[1], &p[2]]).unwrap();
        assert!(
            (plane[2] + 1.0).abs() < 1e-6 && (plane[3] - 4.0).abs() < 1e-5,
            "{plane:?}"
        );
        // Collinear in the image: dropped.
        let q = [point(0, 0, 4.0), point(5, 5, 5.0), point(9, 9, 4.0)];
        assert!(triangle_plane(k, [&q[0], &q[1], &q[2]]).is_none());
    }

    #[test]
    fn a_slanted_plane_is_interpolated_perspective_correctly() {
        // The plane z = 4 + 0.02 x_cam... sampled at three pixels; every pixel inside gets the
        // plane's depth along its ray, not the linear interpolation of the vertex depths.
        let k = [100.0, 100.0, 50.0, 40.0];
        let plane_depth = |u: f32, v: f32| {
            // n = (-0.5, 0, 1) normalised: z - 0.5 x = 4 → d (1 - 0.5 (u - cx)/fx) = 4.
            let _ = v;
            4.0 / (1.0 - 0.5 * (u - k[2]) / k[0])
        };
        let pts = vec![
            point(5, 5, plane_depth(5.0, 5.0)),
            point(90, 8, plane_depth(90.0, 8.0)),
            point(40, 75, plane_depth(40.0, 75.0)),
        ];
        let keep_all = Params {
            prior_triangle_normal: 180.0,
            ..Params::default()
        };
        let mesh = triangulate(100, 80, k, &keep_all, pts.clone());
        assert_eq!(mesh.triangles.len(), 1);
        // The vertices' normals say fronto-parallel, the plane through them is 27° off:
        // inconsistent at the default 30°? No: kept; at 20°, dropped.
        let n = triangle_plane(k, [&pts[0], &pts[1], &pts[2]]).unwrap();
        let angle = (-n[2]).acos().to_degrees();
        assert!((angle - 26.57).abs() < 0.1, "{angle}");
        let strict = Params {
            prior_triangle_normal: 20.0,
            ..Params::default()
        };
        let dropped = triangulate(100, 80, k, &strict, pts.clone());
        assert_eq!(dropped.triangles[0].state, TriangleState::Inconsistent);
        assert_eq!(dropped.gpu_triangles()[0].b[2], 0);
        let kept = triangulate(100, 80, k, &Params::default(), pts);
        assert!(kept.triangles[0].kept());
        let problem = ViewProblem {
            view: 0,
            key: 0,
            scale: 0,
            width: 100,
            height: 80,
            k,
            depth_min: 1.0,
            depth_max: 20.0,
            images: Vec::new(),
            sources: Vec::new(),
            source_views: Vec::new(),
        };
        let list = mesh.paint_list(k, &keep_all);
        assert!(!list.extended());
        let labels = rasterise(list.triangles(), 100, 80);
        let planes = prior_planes(&problem, &labels, &list, None, None);
        let inside = (40 * 100 + 45) as usize;
        assert_eq!(labels[inside], 1);
        let d = planes[inside][3];
        assert!((d - plane_depth(45.0, 40.0)).abs() < 1e-4, "{d}");
        assert_eq!(planes[0][3], NO_TRIANGLE);
        // Past the hull: the corner pixels take the plane of the three points (the only
        // triple), at its depth along their rays.
        let past = Params {
            prior_extend: true,
            ..keep_all.clone()
        };
        let list = mesh.paint_list(k, &past);
        assert!(list.extended());
        assert_eq!(list.entries.len(), 1 + 20 * 16);
        let planes = prior_planes(
            &problem,
            &rasterise(list.triangles(), 100, 80),
            &list,
            None,
            None,
        );
        for (x, y) in [(0u32, 0u32), (99, 0), (0, 79), (99, 79)] {
            let d = planes[(y * 100 + x) as usize][3];
            assert!(
                (d - plane_depth(x as f32, y as f32)).abs() < 1e-3,
                "({x}, {y}): {d}"
            );
        }
        assert_eq!(
            planes[inside],
            prior_planes(
                &problem,
                &labels,
                &mesh.paint_list(k, &keep_all),
                None,
                None
            )[inside]
        );
        // Locked pixels (least reprojection error below the limit) get no prior.
        let mut errors = vec![5.0f32; 100 * 80];
        errors[inside] = 0.5;
        let locked = prior_planes(&problem, &labels, &list, Some((&errors, 2.0)), None);
        assert_eq!(locked[inside][3], LOCKED);
        assert_eq!(locked[0], planes[0]);
        assert!(no_prior_reason(LOCKED).is_some_and(|r| r.contains("locked")));
    }

    /// A weak pixel in a hole of a slanted plane: its anchors lie on the plane in every
    /// direction but one, where a fattened foreground pixel is nearer; the plane they agree
    /// on is the true one, the foreground anchor is not among them, and with too few
    /// agreeing anchors (or the pixel itself strong) there is none.
    #[test]
    fn a_weak_pixel_takes_the_plane_its_anchors_agree_on() {
        let k = [100.0, 100.0, 50.0, 40.0];
        let (w, h) = (100u32, 80u32);
        // The plane Z = 5 + 0.3 X: depth 5 / (1 - 0.003 (x - 50)) along pixel (x, y)'s ray.
        let depth = |x: f32, _y: f32| 5.0 / (1.0 - 0.003 * (x - 50.0));
        let mut planes = vec![[0.0f32, 0.0, -1.0, 0.0]; (w * h) as usize];
        let mut errors = vec![0.5f32; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                planes[(y * w + x) as usize][3] = depth(x as f32, y as f32);
            }
        }
        // A weak hole of radius 10 around (50, 40): not multi-view consistent.
        for y in 30..=50 {
            for x in 40..=60 {
                errors[(y * w + x) as usize] = 5.0;
            }
        }
        // A foreground pixel, consistent, right of the hole at 3 units.
        let fg = (40 * w + 66) as usize;
        planes[fg][3] = 3.0;
        // The top-left corner is weak too.
        errors[0] = 5.0;
        let problem = ViewProblem {
            view: 0,
            key: 0,
            scale: 0,
            width: w,
            height: h,
            k,
            depth_min: 1.0,
            depth_max: 20.0,
            images: Vec::new(),
            sources: Vec::new(),
            source_views: Vec::new(),
        };
        let a = Anchoring {
            planes: &planes,
            errors: &errors,
            limit: 2.0,
            tolerance: 0.01,
            inliers: 5,
        };
        let (code, plane) = anchor_plane(&problem, &a, 50, 40).expect("anchors");
        // Along +x the nearest strong pixel is the foreground one (16 px: 2, 4 and 8 fall in
        // the hole): it disagrees and is left out; the other 7 directions agree.
        assert_eq!(code & 7, 0, "the foreground anchor is not kept: {code:o}");
        let pixels = anchor_pixels(50, 40, code);
        assert_eq!(pixels.len(), 7, "{pixels:?}");
        assert!(pixels.contains(&(50, 24)) && pixels.contains(&(34, 24)));
        assert!((plane[3] - depth(50.0, 40.0)).abs() < 1e-4, "{plane:?}");
        // The plane's normal: perpendicular to the plane's points (back-projected).
        let p3 = |x: f32, y: f32| {
            let r = ray(k, x, y);
            let d = depth(x, y);
            [r[0] * d, r[1] * d, d]
        };
        let (p0, p1, p2) = (p3(10.0, 10.0), p3(90.0, 10.0), p3(10.0, 70.0));
        let e1 = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
        let e2 = [p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]];
        for e in [e1, e2] {
            assert!(dot3([plane[0], plane[1], plane[2]], e).abs() < 1e-3);
        }
        // A strong pixel has no anchors; neither has a weak one when a majority is asked of
        // only the directions that exist (a corner sees 3).
        assert!(anchor_plane(&problem, &a, 10, 10).is_none());
        assert!(anchor_plane(&problem, &a, 0, 0).is_none());
        let codes = anchor_codes(&problem, &a);
        assert_eq!(codes[(40 * w + 50) as usize], code);
        assert_eq!(codes[(10 * w + 10) as usize], 0);
        // Fewer agreeing anchors than asked for: none.
        let eight = Anchoring { inliers: 8, ..a };
        assert!(anchor_plane(&problem, &eight, 50, 40).is_none());
    }

    /// Past the hull a cell takes the first triple of its six nearest support points that
    /// makes a kept triangle: collinear triples and triples across a depth step are skipped.
    #[test]
    fn a_cell_past_the_hull_takes_the_first_kept_triple_of_its_nearest_points() {
        let k = [100.0, 100.0, 50.0, 40.0];
        // Three collinear points nearest the top-left corner (a row at y = 10), then a
        // fourth below them; all at depth 5 (fronto-parallel, normals (0, 0, -1)).
        let mut pts = vec![
            point(10, 10, 5.0),
            point(20, 10, 5.0),
            point(30, 10, 5.0),
            point(15, 30, 5.0),
        ];
        let params = Params {
            prior_extend: true,
            ..Params::default()
        };
        let mesh = PriorMesh {
            width: 100,
            height: 80,
            points: pts.clone(),
            triangles: Vec::new(),
            regions: None,
        };
        let planes = cell_planes(&mesh, k, &params);
        assert_eq!(planes.len(), 20 * 16);
        // Cell (0, 0), centre (2, 2): nearest are 0, 1, 2, 3; (0, 1, 3) is the first triple
        // that is not collinear.
        let t = planes[0];
        assert_eq!(t.b[2], 1);
        assert_eq!(
            [t.a[0], t.a[1], t.a[2], t.a[3], t.b[0], t.b[1]],
            [10, 10, 20, 10, 15, 30]
        );
        assert!(
            (t.plane[2] + 1.0).abs() < 1e-5 && (t.plane[3] - 5.0).abs() < 1e-4,
            "{:?}",
            t.plane
        );
        // A point far off the plane (a depth step) nearest the bottom-right corner: the
        // triples through it disagree with its normal and are skipped.
        pts.push(point(95, 75, 2.0));
        let mesh = PriorMesh {
            points: pts,
            ..mesh
        };
        let planes = cell_planes(&mesh, k, &params);
        let last = planes[planes.len() - 1];
        assert_eq!(last.b[2], 1);
        assert!((last.plane[3] - 5.0).abs() < 1e-4, "{:?}", last.plane);
        // Fewer than three points: no plane anywhere.
        let two = PriorMesh {
            width: 100,
            height: 80,
            points: vec![point(10, 10, 5.0), point(20, 10, 5.0)],
            triangles: Vec::new(),
            regions: None,
        };
        assert!(cell_planes(&two, k, &params).iter().all(|t| t.b[2] == 0));
    }

    /// The tree's nearest points are the brute-force ones, ties included (points on a grid
    /// give many equal distances), for clustered and spread points and every k up to 8.
    #[test]
    fn the_near_tree_finds_what_a_brute_force_search_finds() {
        let mut stream = crate::rng::Stream::new(&[7, 1]);
        for (n, spread) in [(1usize, 50.0f32), (7, 50.0), (300, 400.0), (300, 12.0)] {
            let points: Vec<(usize, [f64; 2])> = (0..n)
                .map(|i| {
                    let x = (stream.next_f32() * spread).floor() as f64;
                    let y = (stream.next_f32() * spread).floor() as f64;
                    (i, [x, y])
                })
                .collect();
            let tree = NearTree::new(points.clone());
            let mut got = Vec::new();
            for q in 0..60 {
                let qx = (stream.next_f32() * spread * 1.5) as f64 - 0.25 * spread as f64;
                let qy = if q % 3 == 0 {
                    qx.floor()
                } else {
                    (stream.next_f32() * spread) as f64
                };
                for k in [1usize, 3, 6, 8] {
                    let mut want: Vec<(f64, usize)> = points
                        .iter()
                        .map(|&(i, p)| ((p[0] - qx).powi(2) + (p[1] - qy).powi(2), i))
                        .collect();
                    want.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                    want.truncate(k);
                    tree.nearest([qx, qy], k, &mut got);
                    assert_eq!(got, want, "n {n}, query ({qx}, {qy}), k {k}");
                }
            }
        }
    }

    #[test]
    fn the_oracle_takes_depth_and_normal_from_the_truth_or_keeps_only_right_points() {
        // The truth: the slanted plane z - 0.5 x = 4 (normal (0.447, 0, -0.894) towards the
        // camera) at half the view's resolution, unknown in its last column.
        let k = [100.0, 100.0, 50.0, 40.0];
        let depth_at = |u: f32| 4.0 / (1.0 - 0.5 * (u - k[2]) / k[0]);
        let (tw, th) = (50u32, 40u32);
        let half: Vec<f32> = (0..tw * th)
            .map(|i| {
                let x = i % tw;
                if x == tw - 1 {
                    0.0
                } else {
                    depth_at((2 * x) as f32)
                }
            })
            .collect();
        let truth = crate::eval::resample_nearest(&half, tw, th, 100, 80);
        let points = vec![
            point(20, 20, depth_at(20.0)),         // right
            point(40, 30, depth_at(40.0) * 1.05),  // 5% off
            point(60, 10, depth_at(60.0) * 0.985), // 1.5% off: right
            point(99, 30, 3.0),                    // no truth under it
        ];
        let kept = apply_oracle(points.clone(), 100, 80, k, &truth, PriorOracle::Filter);
        assert_eq!(
            kept.iter().map(|p| (p.x, p.y)).collect::<Vec<_>>(),
            vec![(20, 20), (60, 10)]
        );
        assert_eq!(kept[1], points[2], "filtered points keep their estimate");
        let fixed = apply_oracle(points, 100, 80, k, &truth, PriorOracle::Depth);
        assert_eq!(fixed.len(), 3);
        let n = [0.5f32 / 1.25f32.sqrt(), 0.0, -1.0 / 1.25f32.sqrt()];
        for p in &fixed {
            // The truth is sampled at even pixels: the point takes its nearest sample.
            let want = depth_at((2 * (p.x / 2)) as f32);
            assert!((p.depth - want).abs() < 1e-5, "{p:?}");
            let dot: f32 = (0..3).map(|i| p.normal[i] * n[i]).sum();
            assert!(dot > 0.999, "{p:?}");
        }
    }

    #[test]
    fn shared_edges_belong_to_the_later_triangle_and_every_inner_pixel_is_covered() {
        // A square split into two triangles: every pixel of the square is covered, the
        // diagonal by the later triangle.
        let tris = [
            GpuTriangle {
                a: [0, 0, 9, 0],
                b: [0, 9, 1, 0],
                plane: [0.0; 4],
            },
            GpuTriangle {
                a: [9, 0, 9, 9],
                b: [0, 9, 1, 0],
                plane: [0.0; 4],
            },
        ];
        let labels = rasterise(&tris, 12, 12);
        for y in 0..12 {
            for x in 0..12 {
                let l = labels[y * 12 + x];
                if x > 9 || y > 9 {
                    assert_eq!(l, 0, "({x}, {y})");
                } else if x + y >= 9 {
                    assert_eq!(l, 2, "({x}, {y})");
                } else {
                    assert_eq!(l, 1, "({x}, {y})");
                }
            }
        }
    }
}
