//! The ground-truth accuracy suite: DWTA, ACMH, ACMM, ACMP and ACMMP on the real scenes with
//! ground truth (Middlebury 2014 and 2005/2006 as ACMM folders with `gt/%08d.pfm` and optional
//! `gt/%08d_lowtex.png`) and on the synthetic scene and room, scored as `mvscope eval` scores:
//! the share of ground-truth pixels within 1% and 2% relative depth error, overall and on the
//! weak-texture pixels (there also within 5%); with `trace`, after every stage too (and the
//! planar prior itself after its stages). [`error_split`] tells whether the cost or the search
//! is to blame for a view's wrong depths. `mvscope bench --accuracy` prints the table; tests
//! assert on a subset.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use web_time::Instant;

use crate::acmm::params::{Method, Params};
use crate::acmm::planar::PriorOracle;
use crate::eval::{depth_accuracy_relative, resample_nearest};
use crate::gpu::GpuContext;
use crate::gpu::acmh::AcmhPipelines;
use crate::scene::{LoadOptions, Scene, SceneError};
use crate::session::{Session, SessionError, Stage, TruthDepth};

/// Ground truth of one view, at any size (sampled at the estimate's pixel centres).
#[derive(Clone, Debug)]
pub struct ViewTruth {
    pub width: u32,
    pub height: u32,
    /// Depth; 0 where unknown.
    pub depth: Vec<f32>,
    /// Weak-texture pixels, where the ground truth marks them.
    pub low_texture: Option<Vec<bool>>,
}

/// A scene of the suite: its views and the ground truth of those that have it.
#[derive(Clone, Debug)]
pub struct SuiteScene {
    pub name: String,
    pub scene: Scene,
    pub truth: Vec<Option<ViewTruth>>,
}

/// One scene scored for one method.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AccuracyRow {
    pub scene: String,
    pub method: String,
    /// Processed size of the first view.
    pub size: [u32; 2],
    /// Ground-truth pixels scored, all views with ground truth pooled.
    pub pixels: usize,
    pub within_1: f64,
    pub within_2: f64,
    /// Weak-texture pixels scored (0 when the scene has no mask).
    pub low_texture_pixels: usize,
    pub low_texture_within_1: Option<f64>,
    pub low_texture_within_2: Option<f64>,
    /// Within 5% on the weak-texture pixels: how much of a textureless surface is roughly
    /// right (the planar prior's target).
    pub low_texture_within_5: Option<f64>,
    /// Wall-clock seconds of the depth estimation (all views).
    pub seconds: f64,
    /// The same scores after every stage (the ground truth sampled at that stage's scale):
    /// where a method gains or loses accuracy.
    pub stages: Vec<StageAccuracy>,
    /// Whether the planar prior's support points came from the truth (a diagnosis, not a
    /// result of the method).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior_oracle: Option<PriorOracle>,
}

/// Accuracy of all views' maps when one stage of the schedule has finished.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StageAccuracy {
    /// "scale 2/3 · geometric 1".
    pub stage: String,
    pub within_1: f64,
    pub within_2: f64,
    pub low_texture_within_2: Option<f64>,
    /// After a planar prior stage: the prior itself scored (what the prior-assisted pass was
    /// pulled towards).
    pub prior: Option<PriorAccuracy>,
}

/// The planar prior of all views at one scale against the truth.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct PriorAccuracy {
    /// Support points kept, all views.
    pub points: usize,
    /// Share of them within 2% of the truth (of those with truth).
    pub points_within_2: f64,
    /// Share of the pixels with truth that have a prior, and of the weak-texture ones.
    pub covered: f64,
    pub low_texture_covered: Option<f64>,
    /// Share of the pixels with truth whose prior depth is within 2% (no prior: not within).
    pub within_2: f64,
    pub low_texture_within_2: Option<f64>,
}

#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    #[error("{0}")]
    Invalid(String),
}

/// Scene folders under `data` that have ground truth: `data/middlebury2014/*` and
/// `data/middlebury2006/*` (any folder there with a `gt/` folder), sorted by name.
pub fn discover(data: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for set in ["middlebury2014", "middlebury2006"] {
        let Ok(entries) = std::fs::read_dir(data.join(set)) else {
            continue;
        };
        let mut dirs: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.join("gt").is_dir())
            .collect();
        dirs.sort();
        found.extend(dirs);
    }
    found
}

/// Loads a scene folder (at most `max_image_size` on the long side) and its ground truth:
/// `gt/%08d.pfm` per view index, `gt/%08d_lowtex.png` where present.
pub fn load_scene(dir: &Path, max_image_size: Option<u32>) -> Result<SuiteScene, AccuracyError> {
    let scene = Scene::load(
        dir,
        &LoadOptions {
            max_image_size,
            ..LoadOptions::default()
        },
    )?;
    let mut truth = Vec::with_capacity(scene.views.len());
    for v in 0..scene.views.len() {
        let files = crate::eval::read_truth(dir, v).map_err(|e| match e {
            crate::eval::EvalError::Io(e) => AccuracyError::Io(e),
            crate::eval::EvalError::Missing(m) => AccuracyError::Invalid(m),
        })?;
        truth.push(files.map(|t| ViewTruth {
            width: t.depth.width,
            height: t.depth.height,
            depth: t.depth.data,
            low_texture: t.low_texture,
        }));
    }
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string());
    Ok(SuiteScene { name, scene, truth })
}

/// The synthetic scene or room (its ground truth in memory) as a suite scene.
pub fn synthetic_scene(
    options: &crate::synthetic::SyntheticOptions,
) -> Result<SuiteScene, AccuracyError> {
    let s = crate::synthetic::generate(options)?;
    let truth = s
        .ground_truth
        .into_iter()
        .map(|g| {
            Some(ViewTruth {
                width: g.width,
                height: g.height,
                depth: g.depth,
                low_texture: Some(g.low_texture),
            })
        })
        .collect();
    Ok(SuiteScene {
        name: format!(
            "synthetic-{}{}x{}",
            if options.room { "room-" } else { "" },
            options.width,
            options.height
        ),
        scene: s.scene,
        truth,
    })
}

/// Each view's final depth map (`None` for a view without an estimate).
pub type DepthMaps = Vec<Option<Vec<f32>>>;

/// A view's depth map with its size.
type SizedDepth = (u32, u32, Vec<f32>);

/// Each view's depth map (with its size) as the session's committed maps hold them.
fn committed_depths(session: &Session) -> Result<Vec<Option<SizedDepth>>, AccuracyError> {
    let mut out = Vec::new();
    for v in 0..session.level_scene(0).views.len() {
        out.push(session.planes_and_costs(v)?.map(|f| {
            let d = f.plane.iter().map(|p| p[3].max(0.0)).collect();
            (f.width, f.height, d)
        }));
    }
    Ok(out)
}

/// How a suite scene is run and scored beyond its method and parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// Also score every stage (and the planar prior after each of its stages).
    pub stages: bool,
    /// Take the planar prior's support points from the truth (a diagnosis).
    pub prior_oracle: Option<PriorOracle>,
}

/// Runs `method` on the whole scene and returns each view's final depth map, and with
/// `options.stages` the accuracy after every stage.
pub fn estimate(
    ctx: &GpuContext,
    pipelines: Arc<AcmhPipelines>,
    suite: &SuiteScene,
    params: &Params,
    method: Method,
    options: Options,
) -> Result<(DepthMaps, Vec<StageAccuracy>), AccuracyError> {
    let trace = options.stages;
    let mut session =
        Session::with_pipelines(ctx, pipelines, &suite.scene, params.clone(), method)?;
    session.set_batch()?;
    if let Some(oracle) = options.prior_oracle {
        let truth = suite
            .truth
            .iter()
            .map(|t| {
                t.as_ref().map(|t| TruthDepth {
                    width: t.width,
                    height: t.height,
                    depth: t.depth.clone(),
                })
            })
            .collect();
        session.set_prior_oracle(Some((oracle, truth)))?;
    }
    let mut stages = Vec::new();
    session.run_batches(
        |_, _, _| Ok::<(), AccuracyError>(()),
        |session, batch| {
            if !(trace && batch.stage_ended) {
                return Ok(());
            }
            let step = batch.first;
            let m = measure(suite, &committed_depths(session)?);
            let label = step.label();
            let stage = label.split(" · view").next().unwrap_or(&label).to_string();
            let prior = match step.stage {
                Stage::Planar => Some(prior_accuracy(suite, session)?),
                _ => None,
            };
            stages.push(StageAccuracy {
                stage,
                within_1: m.within_1,
                within_2: m.within_2,
                low_texture_within_2: m.low_texture_within_2,
                prior,
            });
            Ok(())
        },
    )?;
    let depths = committed_depths(&session)?
        .into_iter()
        .map(|d| d.map(|(_, _, d)| d))
        .collect();
    Ok((depths, stages))
}

/// Scores every view's planar prior at the session's current scale: its depth as a map
/// (0 where there is none) and its support points, against the truth.
fn prior_accuracy(suite: &SuiteScene, session: &Session) -> Result<PriorAccuracy, AccuracyError> {
    let mut maps = Vec::new();
    let (mut points, mut points_right, mut points_scored) = (0, 0, 0);
    for (v, truth) in suite.truth.iter().enumerate() {
        let prior = session.planar_prior(v)?;
        let (Some(t), Some(p)) = (truth, prior) else {
            maps.push(None);
            continue;
        };
        let (w, h) = (p.mesh.width, p.mesh.height);
        let gt = resample_nearest(&t.depth, t.width, t.height, w, h);
        for sp in &p.mesh.points {
            points += 1;
            let d = gt[(sp.y * w + sp.x) as usize];
            if d > 0.0 {
                points_scored += 1;
                points_right += usize::from((sp.depth - d).abs() < 0.02 * d);
            }
        }
        let depth: Vec<f32> = p.prior.iter().map(|q| q[3].max(0.0)).collect();
        maps.push(Some((w, h, depth)));
    }
    let right = measure(suite, &maps);
    let covered_maps: Vec<Option<SizedDepth>> = maps
        .into_iter()
        .map(|m| m.map(|(w, h, d)| (w, h, d.iter().map(|&x| f32::from(x > 0.0)).collect())))
        .collect();
    let covered = coverage(suite, &covered_maps);
    Ok(PriorAccuracy {
        points,
        points_within_2: points_right as f64 / points_scored.max(1) as f64,
        covered: covered.0,
        low_texture_covered: covered.1,
        within_2: right.within_2,
        low_texture_within_2: right.low_texture_within_2,
    })
}

/// Share of the pixels with truth (and of the weak-texture ones) where `flags` (1 or 0 per
/// pixel, at any size) is set.
fn coverage(suite: &SuiteScene, flags: &[Option<SizedDepth>]) -> (f64, Option<f64>) {
    let (mut all, mut set, mut weak, mut weak_set) = (0usize, 0usize, 0usize, 0usize);
    for (v, truth) in suite.truth.iter().enumerate() {
        let (Some(t), Some(Some((w, h, f)))) = (truth, flags.get(v)) else {
            continue;
        };
        let gt = resample_nearest(&t.depth, t.width, t.height, *w, *h);
        let mask = t
            .low_texture
            .as_ref()
            .map(|m| resample_nearest(m, t.width, t.height, *w, *h));
        for (i, &d) in gt.iter().enumerate() {
            if d > 0.0 {
                all += 1;
                set += usize::from(f[i] > 0.0);
                if mask.as_ref().is_some_and(|m| m[i]) {
                    weak += 1;
                    weak_set += usize::from(f[i] > 0.0);
                }
            }
        }
    }
    let share = |a: usize, b: usize| a as f64 / b.max(1) as f64;
    (share(set, all), (weak > 0).then(|| share(weak_set, weak)))
}

struct Measured {
    pixels: usize,
    within_1: f64,
    within_2: f64,
    low_texture_pixels: usize,
    low_texture_within_1: Option<f64>,
    low_texture_within_2: Option<f64>,
    low_texture_within_5: Option<f64>,
}

/// Scores depth maps (each `(width, height, depth)`, at any size) against the truth.
fn measure(suite: &SuiteScene, depths: &[Option<(u32, u32, Vec<f32>)>]) -> Measured {
    let (mut est, mut gt, mut mask) = (Vec::new(), Vec::new(), Vec::new());
    let mut any_mask = false;
    for (v, truth) in suite.truth.iter().enumerate() {
        let Some(t) = truth else { continue };
        let Some(Some((w, h, d))) = depths.get(v) else {
            continue;
        };
        let (w, h) = (*w, *h);
        gt.extend(resample_nearest(&t.depth, t.width, t.height, w, h));
        match &t.low_texture {
            Some(m) => {
                any_mask = true;
                mask.extend(resample_nearest(m, t.width, t.height, w, h));
            }
            None => mask.extend(std::iter::repeat_n(false, d.len())),
        }
        est.extend_from_slice(d);
    }
    let all1 = depth_accuracy_relative(&est, &gt, None, 0.01);
    let all2 = depth_accuracy_relative(&est, &gt, None, 0.02);
    let low1 = any_mask.then(|| depth_accuracy_relative(&est, &gt, Some(&mask), 0.01));
    let low2 = any_mask.then(|| depth_accuracy_relative(&est, &gt, Some(&mask), 0.02));
    let low5 = any_mask.then(|| depth_accuracy_relative(&est, &gt, Some(&mask), 0.05));
    Measured {
        low_texture_within_5: low5.map(|l| l.within),
        pixels: all1.pixels,
        within_1: all1.within,
        within_2: all2.within,
        low_texture_pixels: low2.map_or(0, |l| l.pixels),
        low_texture_within_1: low1.map(|l| l.within),
        low_texture_within_2: low2.map(|l| l.within),
    }
}

/// Scores final depth maps (each at its view's processed size, `None` for a view without an
/// estimate: all its ground truth counts as missed) against the suite scene's truth.
pub fn score(
    suite: &SuiteScene,
    method: Method,
    depths: &[Option<Vec<f32>>],
    seconds: f64,
) -> AccuracyRow {
    let sized: Vec<Option<(u32, u32, Vec<f32>)>> = suite
        .scene
        .views
        .iter()
        .enumerate()
        .map(|(v, view)| {
            let (w, h) = (view.image.width, view.image.height);
            let d = depths
                .get(v)
                .cloned()
                .flatten()
                .unwrap_or_else(|| vec![0.0; (w * h) as usize]);
            Some((w, h, d))
        })
        .collect();
    let m = measure(suite, &sized);
    let first = &suite.scene.views[0].image;
    AccuracyRow {
        scene: suite.name.clone(),
        method: method.to_string(),
        size: [first.width, first.height],
        pixels: m.pixels,
        within_1: m.within_1,
        within_2: m.within_2,
        low_texture_pixels: m.low_texture_pixels,
        low_texture_within_1: m.low_texture_within_1,
        low_texture_within_2: m.low_texture_within_2,
        low_texture_within_5: m.low_texture_within_5,
        seconds,
        stages: Vec::new(),
        prior_oracle: None,
    }
}

/// Runs and scores one method on one suite scene.
pub fn evaluate(
    ctx: &GpuContext,
    pipelines: Arc<AcmhPipelines>,
    suite: &SuiteScene,
    params: &Params,
    method: Method,
    options: Options,
) -> Result<AccuracyRow, AccuracyError> {
    let started = Instant::now();
    let (depths, stages) = estimate(ctx, pipelines, suite, params, method, options)?;
    let mut row = score(suite, method, &depths, started.elapsed().as_secs_f64());
    row.stages = stages;
    row.prior_oracle = options.prior_oracle;
    Ok(row)
}

/// The table `mvscope bench --accuracy` prints: one row per scene and method, then the mean
/// over the scenes per method.
pub fn format_table(rows: &[AccuracyRow]) -> String {
    let pct = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.1}", 100.0 * v));
    let mut out = format!(
        "{:<22} {:<6} {:>9} {:>7} {:>7} {:>9} {:>9} {:>9} {:>8}\n",
        "scene", "method", "size", "<1%", "<2%", "weak<1%", "weak<2%", "weak<5%", "seconds"
    );
    for r in rows {
        out += &format!(
            "{:<22} {:<6} {:>9} {:>7} {:>7} {:>9} {:>9} {:>9} {:>8.1}\n",
            r.scene,
            r.method,
            format!("{}x{}", r.size[0], r.size[1]),
            pct(Some(r.within_1)),
            pct(Some(r.within_2)),
            pct(r.low_texture_within_1),
            pct(r.low_texture_within_2),
            pct(r.low_texture_within_5),
            r.seconds
        );
    }
    let mut methods: Vec<&str> = Vec::new();
    for r in rows {
        if !methods.contains(&r.method.as_str()) {
            methods.push(&r.method);
        }
    }
    for m in methods {
        let of: Vec<&AccuracyRow> = rows.iter().filter(|r| r.method == m).collect();
        let mean = |f: &dyn Fn(&AccuracyRow) -> Option<f64>| {
            let v: Vec<f64> = of.iter().filter_map(|r| f(r)).collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        out += &format!(
            "{:<22} {:<6} {:>9} {:>7} {:>7} {:>9} {:>9} {:>9} {:>8.1}\n",
            format!("mean of {}", of.len()),
            m,
            "",
            pct(mean(&|r| Some(r.within_1))),
            pct(mean(&|r| Some(r.within_2))),
            pct(mean(&|r| r.low_texture_within_1)),
            pct(mean(&|r| r.low_texture_within_2)),
            pct(mean(&|r| r.low_texture_within_5)),
            of.iter().map(|r| r.seconds).sum::<f64>()
        );
    }
    out
}

/// Where a method's wrong depths come from, on the pixels of one view (Sec. 4: the search
/// maximises the photometric consistency; if the true plane scores worse than the estimate,
/// no search will find it).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ErrorSplit {
    /// Pixels scored (ground truth and the mask, if any).
    pub pixels: usize,
    /// Of those, estimates off by more than the tolerance.
    pub wrong: usize,
    /// Of the wrong ones, those whose estimated plane has a lower photometric cost (top-K
    /// mean over the sources, as at initialisation) than the true plane: the cost, not the
    /// search, prefers the wrong depth.
    pub cost_prefers_estimate: usize,
    /// Median of estimate / truth over the wrong ones (below 1: too near).
    pub median_ratio_of_wrong: f64,
}

/// Splits the wrong estimates of a view into cost errors and search errors by scoring the
/// true plane (`truth`: camera-frame normal and depth per pixel, depth 0 = unknown) and the
/// estimated one with the CPU reference of the matching cost.
pub fn error_split(
    problem: &crate::acmm::ViewProblem,
    params: &Params,
    estimate: &[[f32; 4]],
    truth: &[[f32; 4]],
    mask: Option<&[bool]>,
    tolerance: f32,
) -> ErrorSplit {
    use crate::acmm::cpu::{TopK, ncc_cost, ref_patch};
    use rayon::prelude::*;
    let w = problem.width;
    let nsrc = problem.num_sources();
    let cost = |patch: &crate::acmm::cpu::RefPatch, plane: [f32; 4]| {
        let mut top = TopK::new(params.top_k as usize);
        for j in 0..nsrc {
            top.insert(ncc_cost(problem, patch, j, plane));
        }
        top.mean()
    };
    let scored: Vec<(bool, bool, f32)> = (0..problem.pixels())
        .into_par_iter()
        .filter(|&i| truth[i][3] > 0.0 && mask.is_none_or(|m| m[i]))
        .map(|i| {
            let (e, t) = (estimate[i], truth[i]);
            let ratio = e[3] / t[3];
            if (ratio - 1.0).abs() <= tolerance {
                return (false, false, ratio);
            }
            let patch = ref_patch(problem, params, i as u32 % w, i as u32 / w);
            (true, cost(&patch, e) < cost(&patch, t), ratio)
        })
        .collect();
    let mut ratios: Vec<f32> = scored.iter().filter(|s| s.0).map(|s| s.2).collect();
    ratios.sort_by(f32::total_cmp);
    ErrorSplit {
        pixels: scored.len(),
        wrong: ratios.len(),
        cost_prefers_estimate: scored.iter().filter(|s| s.0 && s.1).count(),
        median_ratio_of_wrong: ratios.get(ratios.len() / 2).map_or(1.0, |&r| r as f64),
    }
}
