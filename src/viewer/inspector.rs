//! Why a pixel got its depth: the CPU reference re-runs the pixel's last red/black update
//! from exactly the state the GPU read (a [`Capture`]) and the result is checked against what
//! the GPU wrote.

use super::model::Capture;
use crate::acmm::cpu::{self, Geometric, PixelUpdate};
use crate::acmm::params::Params;
use crate::acmm::planar::{Prior, PriorTerms};
use crate::acmm::problem::ViewProblem;
use crate::session::Stage;

/// What the GPU wrote for the pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuPixel {
    pub plane: [f32; 4],
    pub cost: f32,
    pub selected: u32,
    pub weights: Vec<f32>,
    /// `aux & 0xff` ([`Winner::code`](crate::acmm::Winner::code)).
    pub winner: u32,
}

/// The inspector's content for one pixel.
#[derive(Clone, Debug)]
pub struct Inspection {
    pub x: u32,
    pub y: u32,
    /// The explained half-iteration.
    pub capture_index: usize,
    pub label: String,
    pub geometric: bool,
    /// The CPU reference's account of the update.
    pub update: PixelUpdate,
    /// Where each of the 8 candidates came from (pixel coordinates).
    pub origins: [Option<(u32, u32)>; 8],
    pub gpu: GpuPixel,
    /// Whether CPU and GPU agree (plane within 1e-4 relative, cost within 2e-3, same
    /// selection and winner): the tolerance of the GPU-vs-CPU half-step tests.
    pub agrees: bool,
    /// Reprojection error Δe of the adopted plane per source (geometric passes).
    pub reprojection: Option<Vec<f32>>,
    /// Scene index of each source column.
    pub source_views: Vec<usize>,
    /// The pixel's anchors and each candidate's two terms (`prior_anchors`).
    pub anchors: Option<AnchorTerms>,
    /// Where the pixel's prior came from when it lies in a flat region (Regions).
    pub region: Option<RegionNote>,
    /// How the matching cost weighs the pixel's reference window.
    pub window: WindowWeights,
}

/// The bilateral weights of a pixel's reference window, as the matching cost weighs every
/// hypothesis's NCC there ([`cpu::ref_patch`]): what decides whether a weak window beside an
/// object in front is matched at the object's depth (foreground fattening, docs/accuracy.md
/// "Windows that stop at an edge").
#[derive(Clone, Debug, PartialEq)]
pub struct WindowWeights {
    pub kernel: crate::acmm::params::BilateralKernel,
    /// The colour term's σ in grey levels: σc, or with the adaptive kernel the window's own
    /// spread (1.4826 × the median |ΔI| of its samples), never below σc.
    pub sigma: f32,
    /// 1.4826 × the median |ΔI| of the window's samples (the adaptive kernel's estimate).
    pub spread: f32,
    /// `(2r+1)`: the weights are laid out row by row over every pixel of the window.
    pub size: usize,
    /// Each window pixel's weight relative to the window's heaviest sample (1); NaN at the
    /// pixels the window's step skips.
    pub weights: Vec<f32>,
    /// How many samples' worth of weight the window has, `(Σw)² / Σw²` (Kish's effective
    /// sample size): the number of samples a window with equal weights would match on.
    pub effective: f32,
    /// How many samples the window has.
    pub samples: usize,
    /// Each window pixel's share of the window's weighted variance, `w (ΔI − μ)² / Σ`, which
    /// is what the NCC matches (shares sum to 1; NaN where the step skips a pixel, 0 in a
    /// window without variance): a sample across an edge may weigh little and still hold
    /// most of it, and then it decides every hypothesis's cost.
    pub variance_share: Vec<f32>,
}

/// The weights of the reference window around (x, y), from the CPU reference's patch.
pub fn window_weights(problem: &ViewProblem, params: &Params, x: u32, y: u32) -> WindowWeights {
    let patch = cpu::ref_patch(problem, params, x, y);
    let offsets = params.window_offsets();
    let r = params.window_radius as i32;
    let size = (2 * r + 1) as usize;
    let heaviest = patch.weights.iter().copied().fold(0.0f32, f32::max);
    let mut weights = vec![f32::NAN; size * size];
    let mut variance_share = vec![f32::NAN; size * size];
    let spreads: Vec<f32> = patch
        .weights
        .iter()
        .zip(&patch.values)
        .map(|(&w, &v)| w * (v - patch.mean) * (v - patch.mean))
        .collect();
    let total: f32 = spreads.iter().sum();
    let n = offsets.len();
    for (k, &w) in patch.weights.iter().enumerate() {
        let (dx, dy) = (offsets[k % n], offsets[k / n]);
        let cell = ((dy + r) as usize) * size + (dx + r) as usize;
        weights[cell] = if heaviest > 0.0 { w / heaviest } else { 0.0 };
        variance_share[cell] = if total > 0.0 { spreads[k] / total } else { 0.0 };
    }
    let (sum, squares) = patch
        .weights
        .iter()
        .fold((0.0f32, 0.0f32), |(s, q), &w| (s + w, q + w * w));
    let spread = 1.4826 * cpu::abs_median(&patch.values);
    WindowWeights {
        kernel: params.bilateral_kernel,
        sigma: (cpu::color_scale(params, &patch.values) / 2.0).sqrt(),
        spread,
        size,
        weights,
        effective: if squares > 0.0 {
            sum * sum / squares
        } else {
            0.0
        },
        samples: patch.weights.len(),
        variance_share,
    }
}

/// A pixel's flat region (Regions): its support points, the planes RANSAC found in it, and
/// the plane its cell takes (none: the region has none, and the cell keeps its triangle).
#[derive(Clone, Debug, PartialEq)]
pub struct RegionNote {
    /// 1-based region number.
    pub region: u32,
    pub points: usize,
    /// Each plane of the region: how many of its points it holds.
    pub planes: Vec<usize>,
    /// Which of them (0-based in `planes`) the pixel's cell takes.
    pub taken: Option<usize>,
    /// Each plane's axis of the view's Manhattan frame (`prior_region_axes`; 0-2), or
    /// [`crate::acmm::planar::FREE_PLANE`] for RANSAC's plane through three points.
    pub axes: Vec<u8>,
    /// With a frame: its segments, and how many point at each axis.
    pub frame: Option<(usize, [usize; 3])>,
    /// With `prior_region_edge`: the cell's shade, and its flat neighbours (left, right,
    /// above, below) an edge cuts it from, with their shades.
    pub edge: Option<(f32, Vec<(&'static str, f32)>)>,
}

/// The pixel's flat region in `fit`, if it lies in one.
pub fn region_note(
    fit: &crate::acmm::planar::RegionFit,
    cell: u32,
    x: u32,
    y: u32,
) -> Option<RegionNote> {
    let c = ((y / cell.max(1)) * fit.cells_x + x / cell.max(1)) as usize;
    let r = *fit.region.get(c).filter(|&&r| r > 0)?;
    let of_region: Vec<usize> = fit
        .planes
        .iter()
        .enumerate()
        .filter(|(_, p)| p.region + 1 == r)
        .map(|(k, _)| k)
        .collect();
    let taken = fit.assigned.get(c).and_then(|a| a.checked_sub(1));
    Some(RegionNote {
        region: r,
        points: fit.sizes.get(r as usize - 1).copied().unwrap_or(0),
        planes: of_region
            .iter()
            .map(|&k| fit.planes[k].inliers.len())
            .collect(),
        taken: taken.and_then(|k| of_region.iter().position(|&q| q == k as usize)),
        axes: of_region.iter().map(|&k| fit.planes[k].axis).collect(),
        frame: fit.frame.as_ref().map(|f| (f.segments.len(), f.counts())),
        edge: fit.shades.get(c).map(|&shade| {
            let (gx, gy) = (c as u32 % fit.cells_x, c as u32 / fit.cells_x);
            let w = fit.cells_x as usize;
            let near = [
                ("left", (gx > 0).then(|| c - 1)),
                ("right", (gx + 1 < fit.cells_x).then_some(c + 1)),
                ("above", (gy > 0).then(|| c - w)),
                ("below", (gy + 1 < fit.cells_y).then_some(c + w)),
            ];
            let cut = near
                .into_iter()
                .filter_map(|(side, n)| {
                    let n = n?;
                    let other = *fit.shades.get(n)?;
                    (fit.region.get(n).is_some_and(|&q| q > 0)
                        && crate::acmm::planar::edge_between(shade, other))
                    .then_some((side, other))
                })
                .collect();
            (shade, cut)
        }),
    })
}

/// A weak pixel's anchored cost, split (`prior_anchors`): its anchors, and for each of the 8
/// candidates the view-weighted mean over the sources of its own window's cost and of its
/// anchors' windows' mean cost; its m is (1 − weight) × own + weight × anchors.
#[derive(Clone, Debug, PartialEq)]
pub struct AnchorTerms {
    pub pixels: Vec<(i32, i32)>,
    pub weight: f32,
    pub own: [Option<f32>; 8],
    pub anchored: [Option<f32>; 8],
}

fn anchor_terms(
    problem: &ViewProblem,
    params: &Params,
    update: &PixelUpdate,
    code: u32,
    x: u32,
    y: u32,
) -> Option<AnchorTerms> {
    if code == 0 {
        return None;
    }
    let patch = cpu::ref_patch(problem, params, x, y);
    let none = cpu::AnchorPatches {
        patches: Vec::new(),
        weight: 0.0,
    };
    // The anchors' windows alone (weight 1), made once.
    let only = cpu::AnchorPatches {
        weight: 1.0,
        ..cpu::AnchorPatches::new(problem, params, x, y, code)
    };
    let nsrc = problem.num_sources();
    let wsum: f32 = update.weights.iter().sum();
    let mean = |f: &dyn Fn(usize) -> f32| -> f32 {
        if wsum > 0.0 {
            (0..nsrc).map(|j| update.weights[j] * f(j)).sum::<f32>() / wsum
        } else {
            (0..nsrc).map(f).sum::<f32>() / nsrc.max(1) as f32
        }
    };
    let mut own = [None; 8];
    let mut anchored = [None; 8];
    for a in 0..8 {
        if update.candidates[a].is_none() {
            continue;
        }
        let h = update.candidate_planes[a];
        own[a] = Some(mean(&|j| cpu::match_cost(problem, &patch, &none, j, h)));
        anchored[a] = Some(mean(&|j| cpu::match_cost(problem, &patch, &only, j, h)));
    }
    Some(AnchorTerms {
        pixels: crate::acmm::planar::anchor_pixels(x, y, code),
        weight: params.prior_anchor_weight,
        own,
        anchored,
    })
}

/// Explains pixel (x, y) with the capture of its colour. `None` when outside the map or the
/// capture is of the other colour.
pub fn inspect(capture: &Capture, x: u32, y: u32) -> Option<Inspection> {
    let problem = &capture.problem;
    if x >= problem.width || y >= problem.height {
        return None;
    }
    let crate::session::Action::Half { iteration, color } = capture.step.action else {
        return None;
    };
    if (x + y) % 2 != color {
        return None;
    }
    let geometric = matches!(capture.step.stage, Stage::Geometric(_));
    let pass = match capture.step.stage {
        Stage::Geometric(g) => g,
        _ => 0,
    };
    let geo = capture.source_depths.as_ref().map(|depths| Geometric {
        depths,
        lambda: capture.params.lambda,
        delta: capture.params.delta,
        pass,
    });
    let i = (y * problem.width + x) as usize;
    let prior = capture.prior.as_ref().map(|planes| Prior {
        planes,
        terms: PriorTerms::new(&capture.params, problem.depth_min, problem.depth_max),
        anchors: capture.anchors.as_deref(),
    });
    let update = cpu::update_pixel(
        problem,
        &capture.params,
        capture.method,
        &capture.before,
        geo.as_ref(),
        capture.c_init.as_ref().map(|c| c[i]),
        prior.as_ref(),
        iteration,
        x,
        y,
    );
    let after = &capture.after;
    let n = after.num_sources;
    let gpu = GpuPixel {
        plane: after.plane[i],
        cost: after.cost[i],
        selected: after.selected[i],
        weights: after.weights[i * n..(i + 1) * n].to_vec(),
        winner: after.aux[i] & 0xff,
    };
    let plane_ok = (0..4)
        .all(|k| (gpu.plane[k] - update.plane[k]).abs() <= 1e-4 * (1.0 + update.plane[k].abs()));
    let agrees = plane_ok
        && (gpu.cost - update.cost).abs() <= 2e-3
        && gpu.selected == update.selected
        && gpu.winner == update.winner.code();
    let w = problem.width as usize;
    let origins = update
        .candidates
        .map(|c| c.map(|p| ((p % w) as u32, (p / w) as u32)));
    let reprojection = geo.as_ref().map(|g| {
        (0..problem.num_sources())
            .map(|j| cpu::reprojection_error(problem, g.depths, j, update.plane, x, y, g.delta))
            .collect()
    });
    let anchors = capture
        .anchors
        .as_ref()
        .and_then(|c| anchor_terms(problem, &capture.params, &update, c[i], x, y));
    let region = capture
        .regions
        .as_ref()
        .and_then(|f| region_note(f, f.cell, x, y));
    Some(Inspection {
        window: window_weights(problem, &capture.params, x, y),
        anchors,
        region,
        x,
        y,
        capture_index: capture.index,
        label: capture.step.label(),
        geometric,
        origins,
        gpu,
        agrees,
        reprojection,
        source_views: problem.source_views.clone(),
        update,
    })
}

/// The reference patch and what the plane's homography warps it to in each source:
/// `(2r+1)²` grey values each (every pixel of the window, not only the sampled ones), NaN
/// where the plane does not face the camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Patches {
    pub size: usize,
    pub reference: Vec<f32>,
    pub sources: Vec<Vec<f32>>,
}

pub fn warped_patches(
    problem: &ViewProblem,
    params: &Params,
    plane: [f32; 4],
    x: u32,
    y: u32,
) -> Patches {
    let r = params.window_radius as i32;
    let size = (2 * r + 1) as usize;
    let (w, h) = (problem.width as i32, problem.height as i32);
    let mut reference = Vec::with_capacity(size * size);
    for dy in -r..=r {
        for dx in -r..=r {
            let (px, py) = (
                (x as i32 + dx).clamp(0, w - 1),
                (y as i32 + dy).clamp(0, h - 1),
            );
            reference.push(problem.images[(py * w + px) as usize]);
        }
    }
    let sources = problem
        .sources
        .iter()
        .map(|src| {
            let Some((hm, _)) = cpu::homography(problem.k, src, plane, x as f32, y as f32) else {
                return vec![f32::NAN; size * size];
            };
            let mut out = Vec::with_capacity(size * size);
            for dy in -r..=r {
                for dx in -r..=r {
                    let (u, v) = ((x as i32 + dx) as f32, (y as i32 + dy) as f32);
                    let z = hm[2][0] * u + hm[2][1] * v + hm[2][2];
                    if z <= 0.0 {
                        out.push(f32::NAN);
                        continue;
                    }
                    let su = (hm[0][0] * u + hm[0][1] * v + hm[0][2]) / z;
                    let sv = (hm[1][0] * u + hm[1][1] * v + hm[1][2]) / z;
                    out.push(cpu::bilinear(problem, src, su, sv));
                }
            }
            out
        })
        .collect();
    Patches {
        size,
        reference,
        sources,
    }
}

/// The detail restorer's account of a pixel from the maps after the restore step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestorerPixel {
    /// C_init − C_photo.
    pub difference: f32,
    /// Whether the restorer judged the upsampled plane an error in the details.
    pub replaced: bool,
}

impl RestorerPixel {
    /// From the maps after a restore step (`None` before one).
    pub fn from_maps(maps: &crate::session::ViewMaps, i: usize) -> Option<RestorerPixel> {
        Some(RestorerPixel {
            difference: *maps.restorer_difference.as_ref()?.get(i)?,
            replaced: *maps.replaced.as_ref()?.get(i)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acmm::params::BilateralKernel;

    /// The inspector's edge note (`prior_region_edge`): a cell's shade and the flat
    /// neighbours it is cut from, the non-flat ones and those within 6 grey levels left out.
    #[test]
    fn the_region_note_names_the_edges_that_cut_a_cell() {
        use crate::acmm::planar::{RegionFit, RegionPlane};
        // 3 x 2 cells of 5 px: the top row a region of shades 100, 104, 130; below, a flat
        // cell of 150 under the first and two cells that are not flat.
        let fit = RegionFit {
            cell: 5,
            cells_x: 3,
            cells_y: 2,
            region: vec![1, 1, 2, 3, 0, 0],
            assigned: vec![1, 1, 0, 0, 0, 0],
            sizes: vec![8, 1, 1],
            planes: vec![RegionPlane {
                region: 0,
                plane: [0.0, 0.0, -1.0, 4.0],
                inliers: (0..8).collect(),
                axis: crate::acmm::planar::FREE_PLANE,
            }],
            shades: vec![100.0, 104.0, 130.0, 150.0, 10.0, 10.0],
            frame: None,
            ..RegionFit::default()
        };
        let note = region_note(&fit, 5, 2, 2).expect("in region 1");
        assert_eq!((note.region, note.points, note.taken), (1, 8, Some(0)));
        assert_eq!(
            (note.axes.clone(), note.frame),
            (vec![crate::acmm::planar::FREE_PLANE], None)
        );
        assert_eq!(note.edge, Some((100.0, vec![("below", 150.0)])));
        let middle = region_note(&fit, 5, 7, 2).expect("in region 1");
        assert_eq!(middle.edge, Some((104.0, vec![("right", 130.0)])));
        assert!(region_note(&fit, 5, 7, 7).is_none(), "not flat");
        let without = RegionFit {
            shades: Vec::new(),
            ..fit
        };
        assert_eq!(
            region_note(&without, 5, 2, 2).expect("in region 1").edge,
            None
        );
        // With a frame (`prior_region_axes`): the plane's axis and the segments' counts.
        let seg = crate::acmm::lines::Segment {
            a: [0.0, 0.0],
            b: [9.0, 0.0],
        };
        let mut framed = without.clone();
        framed.planes[0].axis = 2;
        framed.frame = Some(crate::acmm::lines::Frame {
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            segments: vec![seg; 4],
            along: vec![2, 0, 3, 2],
        });
        let note = region_note(&framed, 5, 2, 2).expect("in region 1");
        assert_eq!((note.axes, note.frame), (vec![2], Some((4, [1, 0, 2]))));
    }

    /// A weak wall (grey 100, ±1 of noise) with an object in front from column 20 on
    /// (grey 150), or a textured window (±20 grey levels) everywhere.
    fn problem(textured: bool) -> ViewProblem {
        let (w, h) = (40u32, 30u32);
        let images = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if textured {
                    100.0 + ((x * 7 + y * 13) % 9) as f32 * 5.0 - 20.0
                } else if x >= 20 {
                    150.0
                } else {
                    100.0 + ((x * 7 + y * 3) % 3) as f32 - 1.0
                }
            })
            .collect();
        ViewProblem {
            view: 0,
            key: 0,
            scale: 0,
            width: w,
            height: h,
            k: [40.0, 40.0, 20.0, 15.0],
            depth_min: 1.0,
            depth_max: 10.0,
            images,
            sources: Vec::new(),
            source_views: Vec::new(),
        }
    }

    fn with(kernel: BilateralKernel) -> Params {
        Params {
            bilateral_kernel: kernel,
            ..Params::default()
        }
    }

    /// The weight of the window pixel at offset (dx, dy).
    fn at(ww: &WindowWeights, dx: i32, dy: i32) -> f32 {
        let r = (ww.size / 2) as i32;
        ww.weights[((dy + r) * ww.size as i32 + dx + r) as usize]
    }

    /// The variance share of the window pixel at offset (dx, dy).
    fn at_share(ww: &WindowWeights, dx: i32, dy: i32) -> f32 {
        let r = (ww.size / 2) as i32;
        ww.variance_share[((dy + r) * ww.size as i32 + dx + r) as usize]
    }

    #[test]
    fn the_window_weights_are_the_reference_patchs_laid_out_over_the_window() {
        let p = problem(false);
        for kernel in [
            BilateralKernel::Laplacian,
            BilateralKernel::Gaussian,
            BilateralKernel::Adaptive,
        ] {
            let params = with(kernel);
            let ww = window_weights(&p, &params, 17, 15);
            let patch = cpu::ref_patch(&p, &params, 17, 15);
            // 11 x 11 pixels, of which the step samples 6 x 6.
            assert_eq!((ww.size, ww.samples), (11, 36));
            assert_eq!(ww.weights.iter().filter(|w| w.is_nan()).count(), 121 - 36);
            let heaviest = patch.weights.iter().copied().fold(0.0f32, f32::max);
            let offsets = params.window_offsets();
            for (k, &w) in patch.weights.iter().enumerate() {
                let got = at(&ww, offsets[k % 6], offsets[k / 6]);
                assert_eq!(got, w / heaviest, "{kernel:?} sample {k}");
            }
            assert!(
                ww.effective >= 1.0 && ww.effective <= 36.0,
                "{}",
                ww.effective
            );
        }
    }

    #[test]
    fn beside_an_edge_the_adaptive_window_drops_the_object_and_on_texture_keeps_its_samples() {
        // Pixel (17, 15): the window's columns 20 and 22 (12 of its 36 samples) are the
        // object, 50 grey levels above the wall.
        let edge = problem(false);
        let adaptive = window_weights(&edge, &with(BilateralKernel::Adaptive), 17, 15);
        let laplacian = window_weights(&edge, &with(BilateralKernel::Laplacian), 17, 15);
        // The wall's samples decide the median: σ stays σc.
        assert_eq!(adaptive.sigma, 3.0);
        assert!(adaptive.spread < 3.0, "{}", adaptive.spread);
        for dy in [-5, -3, -1, 1, 3, 5] {
            for dx in [3, 5] {
                // exp(-2500 / 18) under the adaptive weight; the authors' unsquared weight
                // leaves the object exp(-|Δx| / 50 - 50 / 18) ≥ 0.05 of the heaviest sample.
                assert!(at(&adaptive, dx, dy) < 1e-30, "({dx}, {dy})");
                assert!(at(&laplacian, dx, dy) > 0.05, "({dx}, {dy})");
            }
        }
        // So the object's 12 samples count in the authors' window and not in the adaptive one
        // (measured: 25.5 and 22.1 samples' worth)...
        assert!(adaptive.effective < 24.0, "{}", adaptive.effective);
        assert!(laplacian.effective > 24.0, "{}", laplacian.effective);
        // ...and at 6% of the weight each they hold 96% of the authors' window's variance,
        // which is what the NCC matches: the object decides the wall pixel's cost.
        let object = |ww: &WindowWeights| -> f32 {
            [-5, -3, -1, 1, 3, 5]
                .iter()
                .flat_map(|&dy| [3, 5].map(|dx| at_share(ww, dx, dy)))
                .sum()
        };
        assert!(object(&laplacian) > 0.9, "{}", object(&laplacian));
        assert!(object(&adaptive) < 1e-6, "{}", object(&adaptive));
        for ww in [&adaptive, &laplacian] {
            let total: f32 = ww.variance_share.iter().filter(|v| !v.is_nan()).sum();
            assert!((total - 1.0).abs() < 1e-5, "{total}");
        }
        // On texture the adaptive σ is the window's spread and it matches on far more samples
        // than the Gaussian weight with σc = 3, which starves it.
        let texture = problem(true);
        let adaptive = window_weights(&texture, &with(BilateralKernel::Adaptive), 17, 15);
        let gaussian = window_weights(&texture, &with(BilateralKernel::Gaussian), 17, 15);
        assert_eq!(adaptive.sigma, adaptive.spread);
        assert!(adaptive.sigma > 3.0, "{}", adaptive.sigma);
        assert!(
            adaptive.effective > 2.0 * gaussian.effective,
            "adaptive {} against Gaussian {}",
            adaptive.effective,
            gaussian.effective
        );
    }
}
