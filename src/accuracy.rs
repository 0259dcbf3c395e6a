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
    /// Its units are metres and every view has ground truth (the rooms): the fused cloud is
    /// scored against the truth's, at 2 and 5 cm.
    pub metric: bool,
}

/// The distances (metres) at which a room's fused cloud is scored, ETH3D's 2 cm and 5 cm.
pub const CLOUD_THRESHOLDS: [f64; 2] = [0.02, 0.05];

/// The truth cloud's voxel: half the smaller threshold ([`crate::eval::truth_voxel`]).
pub const TRUTH_VOXEL: f64 = 0.01;

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
    /// Within 5%, all pixels (the rooms: the Kinect's depth is good to 1-2%).
    pub within_5: f64,
    /// Views whose truth fits the images worse than this method's depths do (by
    /// [`crate::eval::MISFIT_RATIO`], `mvscope eval`'s check): made with other cameras than
    /// the images, so shares within 1-2% there measure the data as much as the method.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub truth_misfit: Vec<usize>,
    /// Each view's median estimate / truth (views with both), `mvscope eval`'s `est/gt`:
    /// what [`crate::eval::scale_bias_note_for`] reads below the table.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub median_ratios: Vec<(usize, f64)>,
    /// Within 2% on all pixels and on the weak-texture pixels with each view's depth divided
    /// by its `median_ratios` entry (`mvscope eval`'s scale-free line): where the cameras or
    /// the truth carry one scale per view (the kitchens' focal length), what the method has
    /// right up to it. Printed under the scale note of a biased scene.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_free_within_2: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_free_low_texture_within_2: Option<f64>,
    /// The fused cloud against the truth's (ETH3D accuracy, completeness, F1) at
    /// [`CLOUD_THRESHOLDS`], for the metric scenes.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub cloud: Vec<crate::eval::CloudScore>,
    /// At matched coverage ([`MATCHED_COVERAGE`] of the ground-truth pixels): the share
    /// within 2% of the pixels kept by confidence (most agreeing sources first, the lower
    /// cost on a tie), and of those kept by cost alone (lowest first).
    pub confident_within_2: Option<f64>,
    pub lowest_cost_within_2: Option<f64>,
    /// Scored on the pixels whose true point a source view sees, and on those none sees
    /// ([`crate::eval::seen_by_sources`]): the share of a loss where no view offers
    /// evidence. `None` when no view has truth.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seen: Option<crate::eval::SeenScore>,
    /// Wall-clock seconds of the depth estimation (all views).
    pub seconds: f64,
    /// The same scores after every stage (the ground truth sampled at that stage's scale):
    /// where a method gains or loses accuracy.
    pub stages: Vec<StageAccuracy>,
    /// Whether the planar prior's support points came from the truth (a diagnosis, not a
    /// result of the method).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior_oracle: Option<PriorOracle>,
    /// With the oracle: the percentage of the real test's false positives the anchors were
    /// let sit on (`--prior-oracle-admit`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub oracle_admit: Option<u32>,
    /// Run with several seeds ([`mean_over_seeds`]): the seeds, in order, and each one's
    /// share within 2% (all pixels, and weak texture where the scene has a mask); every
    /// score above is then the mean over them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub seeds: Vec<u64>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub seed_within_2: Vec<f64>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub seed_low_texture_within_2: Vec<f64>,
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

/// Scene folders under `data` that have ground truth: `data/middlebury2014/*`,
/// `data/middlebury2006/*` and the rooms `data/rgbd/*` (any folder there with a `gt/`
/// folder), sorted by name within each set.
pub fn discover(data: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for set in ["middlebury2014", "middlebury2006", "rgbd"] {
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
            crate::eval::EvalError::Scene(e) => AccuracyError::Scene(e),
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
    // The rooms (rgbd/): metres, ground truth for every view.
    let metric = dir
        .parent()
        .and_then(|p| p.file_name())
        .is_some_and(|n| n == "rgbd")
        && truth.iter().all(Option::is_some);
    Ok(SuiteScene {
        name,
        scene,
        truth,
        metric,
    })
}

/// A room cropped for a quick test: the views `keep` (each keeps only the sources among
/// them) at most `max_image_size` on the long side (CI's share of the rooms).
pub fn load_room_crop(
    dir: &Path,
    keep: &[usize],
    max_image_size: Option<u32>,
) -> Result<SuiteScene, AccuracyError> {
    let suite = load_scene(dir, max_image_size)?;
    let truth = keep
        .iter()
        .map(|&v| suite.truth.get(v).cloned().flatten())
        .collect();
    Ok(SuiteScene {
        name: format!("{}-{}views", suite.name, keep.len()),
        scene: suite.scene.subset(keep)?,
        truth,
        metric: suite.metric,
    })
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
        metric: false,
    })
}

/// Each view's final depth map (`None` for a view without an estimate).
pub type DepthMaps = Vec<Option<Vec<f32>>>;

/// Each view's final planes (camera-frame normal, depth) and costs, `None` without an
/// estimate.
pub type PlaneMaps = Vec<Option<crate::session::PlanesCosts>>;

/// The share of the ground-truth pixels kept when the maps are scored at matched coverage
/// (OpenMVS keeps 35-40% of the pixels of a room; ACMM's cost is compared at the same share).
pub const MATCHED_COVERAGE: f64 = 0.35;

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
    /// With a `select` or `filter` oracle and anchors: the percentage of the real test's
    /// false positives the anchors may also sit on ([`Session::set_oracle_admit`]).
    pub oracle_admit: u32,
}

/// Runs `method` on the whole scene and returns each view's final planes, and with
/// `options.stages` the accuracy after every stage.
pub fn estimate(
    ctx: &GpuContext,
    pipelines: Arc<AcmhPipelines>,
    suite: &SuiteScene,
    params: &Params,
    method: Method,
    options: Options,
) -> Result<(PlaneMaps, Vec<StageAccuracy>), AccuracyError> {
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
        session.set_oracle_admit(options.oracle_admit)?;
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
    let mut planes = Vec::new();
    for v in 0..session.level_scene(0).views.len() {
        planes.push(session.planes_and_costs(v)?);
    }
    Ok((planes, stages))
}

/// Every view's depths and normals from its final planes (zeros for a view without maps),
/// as fusion and its confidence read them.
#[allow(clippy::type_complexity)]
fn depths_and_normals(scene: &Scene, planes: &PlaneMaps) -> (Vec<Vec<f32>>, Vec<Vec<[f32; 3]>>) {
    let mut depths = Vec::new();
    let mut normals = Vec::new();
    for (v, view) in scene.views.iter().enumerate() {
        let n = view.image.width as usize * view.image.height as usize;
        match planes.get(v).and_then(Option::as_ref) {
            Some(p) => {
                depths.push(p.plane.iter().map(|q| q[3].max(0.0)).collect());
                normals.push(p.plane.iter().map(|q| [q[0], q[1], q[2]]).collect());
            }
            None => {
                depths.push(vec![0.0; n]);
                normals.push(vec![[0.0; 3]; n]);
            }
        }
    }
    (depths, normals)
}

/// The fused cloud of final planes (fusion with `params`' thresholds) scored against the
/// cloud of the ground truth's depth maps, one point per 1 cm voxel (so that what many views
/// see counts once), at [`CLOUD_THRESHOLDS`].
pub fn score_cloud(
    suite: &SuiteScene,
    planes: &PlaneMaps,
    params: &Params,
) -> Result<Vec<crate::eval::CloudScore>, AccuracyError> {
    let scene = &suite.scene;
    let (depths, normals) = depths_and_normals(scene, planes);
    let fused = crate::fusion::fuse(
        &crate::fusion::FusionInput {
            scene,
            depths: &depths,
            normals: &normals,
        },
        params,
    )
    .map_err(|e| AccuracyError::Invalid(e.to_string()))?;
    let points: Vec<[f32; 3]> = fused.points.iter().map(|p| p.position).collect();
    Ok(crate::eval::cloud_scores(
        &points,
        &truth_cloud(suite, TRUTH_VOXEL),
        &CLOUD_THRESHOLDS,
    ))
}

/// The maps at matched coverage: of the ground-truth pixels with an estimate, the first
/// [`MATCHED_COVERAGE`] of all ground-truth pixels ranked by confidence (agreeing sources,
/// `crate::fusion::confidence`, then the lower cost) and by cost alone; each list's share
/// within 2%. `None` when fewer pixels than that have an estimate.
pub fn ranked_coverage(
    suite: &SuiteScene,
    planes: &PlaneMaps,
    params: &Params,
) -> Result<(Option<f64>, Option<f64>), AccuracyError> {
    let scene = &suite.scene;
    let (depths, normals) = depths_and_normals(scene, planes);
    let counts = crate::fusion::confidence(
        &crate::fusion::FusionInput {
            scene,
            depths: &depths,
            normals: &normals,
        },
        params,
    )
    .map_err(|e| AccuracyError::Invalid(e.to_string()))?;
    // (agreeing sources, cost, within 2%) of every ground-truth pixel with an estimate.
    let mut scored: Vec<(u8, f32, bool)> = Vec::new();
    let mut truth_pixels = 0usize;
    for (v, truth) in suite.truth.iter().enumerate() {
        let (Some(t), Some(Some(p))) = (truth, planes.get(v)) else {
            continue;
        };
        let gt = resample_nearest(&t.depth, t.width, t.height, p.width, p.height);
        for (i, &g) in gt.iter().enumerate() {
            if g <= 0.0 {
                continue;
            }
            truth_pixels += 1;
            let d = p.plane[i][3];
            if d > 0.0 {
                let right = (d - g).abs() <= 0.02 * g;
                scored.push((counts[v][i], p.cost[i], right));
            }
        }
    }
    let keep = (truth_pixels as f64 * MATCHED_COVERAGE).round() as usize;
    if keep == 0 || scored.len() < keep {
        return Ok((None, None));
    }
    let share =
        |list: &[(u8, f32, bool)]| list[..keep].iter().filter(|s| s.2).count() as f64 / keep as f64;
    scored.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.total_cmp(&b.1)));
    let confident = share(&scored);
    scored.sort_by(|a, b| a.1.total_cmp(&b.1));
    let by_cost = share(&scored);
    Ok((Some(confident), Some(by_cost)))
}

/// Every view's ground truth back-projected into the world, one point per `voxel`-sized cube
/// (the first in view and pixel order): [`crate::eval::truth_cloud`] of the suite's truth.
pub fn truth_cloud(suite: &SuiteScene, voxel: f64) -> Vec<[f32; 3]> {
    crate::eval::truth_cloud(
        suite
            .scene
            .views
            .iter()
            .zip(&suite.truth)
            .filter_map(|(view, truth)| {
                truth.as_ref().map(|t| crate::eval::TruthView {
                    camera: &view.camera,
                    width: t.width,
                    height: t.height,
                    depth: &t.depth,
                })
            }),
        voxel,
    )
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
    within_5: f64,
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
    let all5 = depth_accuracy_relative(&est, &gt, None, 0.05);
    let low1 = any_mask.then(|| depth_accuracy_relative(&est, &gt, Some(&mask), 0.01));
    let low2 = any_mask.then(|| depth_accuracy_relative(&est, &gt, Some(&mask), 0.02));
    let low5 = any_mask.then(|| depth_accuracy_relative(&est, &gt, Some(&mask), 0.05));
    Measured {
        low_texture_within_5: low5.map(|l| l.within),
        pixels: all1.pixels,
        within_1: all1.within,
        within_2: all2.within,
        within_5: all5.within,
        low_texture_pixels: low2.map_or(0, |l| l.pixels),
        low_texture_within_1: low1.map(|l| l.within),
        low_texture_within_2: low2.map(|l| l.within),
    }
}

/// [`crate::eval::SeenScore`] of depth maps at the views' processed sizes (views without
/// truth or map left out).
fn seen_score(
    suite: &SuiteScene,
    depths: &[Option<(u32, u32, Vec<f32>)>],
) -> Option<crate::eval::SeenScore> {
    let views = &suite.scene.views;
    let at_size = |v: usize, t: &ViewTruth| {
        let (w, h) = (views[v].image.width, views[v].image.height);
        (
            resample_nearest(&t.depth, t.width, t.height, w, h),
            t.low_texture
                .as_ref()
                .map(|m| resample_nearest(m, t.width, t.height, w, h)),
        )
    };
    let (truths, masks): (Vec<_>, Vec<_>) = suite
        .truth
        .iter()
        .enumerate()
        .map(|(v, t)| {
            let (d, m) = t.as_ref().map(|t| at_size(v, t)).unzip();
            (d, m.flatten())
        })
        .unzip();
    let all: Vec<usize> = (0..views.len()).collect();
    let report =
        crate::eval::seen_of_maps(
            &suite.scene,
            &all,
            &all,
            &truths,
            &masks,
            |v| match depths.get(v) {
                Some(Some((w, h, d))) => crate::io::Map::from_data(*w, *h, 1, d.clone())
                    .map_err(|e| crate::eval::EvalError::Missing(e.to_string())),
                _ => Err(crate::eval::EvalError::Missing(format!("view {v}: no map"))),
            },
        );
    report.ok().flatten().map(|r| r.score)
}

/// `depths` as [`measure`] takes them: each with its view's processed size, a view without
/// an estimate as zeros (all its truth missed).
fn at_view_sizes(
    suite: &SuiteScene,
    depths: &[Option<Vec<f32>>],
) -> Vec<Option<(u32, u32, Vec<f32>)>> {
    suite
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
        .collect()
}

/// Within 2% on all pixels and on the weak texture once each view's depth is divided by its
/// median est/gt (`ratios`, [`median_ratios`]; a view without one is scored as it is), as
/// `mvscope eval`'s scale-free line pools them; `None` without any ratio.
pub fn scale_free_within_2(
    suite: &SuiteScene,
    depths: &[Option<Vec<f32>>],
    ratios: &[(usize, f64)],
) -> Option<(f64, Option<f64>)> {
    if ratios.is_empty() {
        return None;
    }
    let divided: Vec<Option<Vec<f32>>> = depths
        .iter()
        .enumerate()
        .map(|(v, d)| {
            let k = ratios
                .iter()
                .find(|(i, _)| *i == v)
                .map_or(f64::NAN, |&(_, k)| k);
            d.as_ref()
                .map(|d| crate::eval::divided_by_ratio(d, k).unwrap_or_else(|| d.clone()))
        })
        .collect();
    let m = measure(suite, &at_view_sizes(suite, &divided));
    Some((m.within_2, m.low_texture_within_2))
}

/// Scores final depth maps (each at its view's processed size, `None` for a view without an
/// estimate: all its ground truth counts as missed) against the suite scene's truth.
pub fn score(
    suite: &SuiteScene,
    method: Method,
    depths: &[Option<Vec<f32>>],
    seconds: f64,
) -> AccuracyRow {
    let sized = at_view_sizes(suite, depths);
    let m = measure(suite, &sized);
    let seen = seen_score(suite, &sized);
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
        within_5: m.within_5,
        truth_misfit: Vec::new(),
        median_ratios: Vec::new(),
        scale_free_within_2: None,
        scale_free_low_texture_within_2: None,
        cloud: Vec::new(),
        confident_within_2: None,
        lowest_cost_within_2: None,
        seen,
        seconds,
        stages: Vec::new(),
        prior_oracle: None,
        oracle_admit: None,
        seeds: Vec::new(),
        seed_within_2: Vec::new(),
        seed_low_texture_within_2: Vec::new(),
    }
}

/// Rows of one scene and method run with several seeds (`runs`: each seed with its row, in
/// the seeds' order) merged into one: every score the mean over the seeds (support points
/// rounded), and the seeds with each one's share within 2% kept, so a table can show the
/// spread the random initialisation alone makes. `None` without rows or when the rows are
/// of different scenes, methods or stages.
pub fn mean_over_seeds(runs: &[(u64, AccuracyRow)]) -> Option<AccuracyRow> {
    let (_, first) = runs.first()?;
    if runs.iter().any(|(_, r)| {
        r.scene != first.scene || r.method != first.method || r.stages.len() != first.stages.len()
    }) {
        return None;
    }
    let n = runs.len() as f64;
    let mean = |f: &dyn Fn(&AccuracyRow) -> f64| runs.iter().map(|(_, r)| f(r)).sum::<f64>() / n;
    // A share some rows lack (no mask, no cloud) stays absent.
    let mean_opt = |f: &dyn Fn(&AccuracyRow) -> Option<f64>| {
        let v: Option<Vec<f64>> = runs.iter().map(|(_, r)| f(r)).collect();
        v.map(|v| v.iter().sum::<f64>() / n)
    };
    let mut row = first.clone();
    row.truth_misfit = runs
        .iter()
        .flat_map(|(_, r)| r.truth_misfit.clone())
        .collect();
    row.truth_misfit.sort_unstable();
    row.truth_misfit.dedup();
    row.within_1 = mean(&|r| r.within_1);
    row.within_2 = mean(&|r| r.within_2);
    row.within_5 = mean(&|r| r.within_5);
    row.low_texture_within_1 = mean_opt(&|r| r.low_texture_within_1);
    row.low_texture_within_2 = mean_opt(&|r| r.low_texture_within_2);
    row.low_texture_within_5 = mean_opt(&|r| r.low_texture_within_5);
    row.confident_within_2 = mean_opt(&|r| r.confident_within_2);
    row.lowest_cost_within_2 = mean_opt(&|r| r.lowest_cost_within_2);
    row.scale_free_within_2 = mean_opt(&|r| r.scale_free_within_2);
    row.scale_free_low_texture_within_2 = mean_opt(&|r| r.scale_free_low_texture_within_2);
    row.seen = runs
        .iter()
        .map(|(_, r)| r.seen)
        .collect::<Option<Vec<_>>>()
        .map(|v| {
            use crate::eval::SeenScore;
            let m = |f: &dyn Fn(&SeenScore) -> f64| v.iter().map(f).sum::<f64>() / n;
            let mo = |f: &dyn Fn(&SeenScore) -> Option<f64>| {
                let x: Option<Vec<f64>> = v.iter().map(f).collect();
                x.map(|x| x.iter().sum::<f64>() / n)
            };
            SeenScore {
                seen: m(&|s| s.seen),
                within_2: m(&|s| s.within_2),
                low_texture_within_2: mo(&|s| s.low_texture_within_2),
                unseen_within_2: mo(&|s| s.unseen_within_2),
            }
        });
    row.seconds = mean(&|r| r.seconds);
    if runs.iter().all(|(_, r)| r.cloud.len() == first.cloud.len()) {
        for (k, c) in row.cloud.iter_mut().enumerate() {
            c.accuracy = mean(&|r| r.cloud[k].accuracy);
            c.completeness = mean(&|r| r.cloud[k].completeness);
            c.f1 = mean(&|r| r.cloud[k].f1);
        }
    } else {
        row.cloud.clear();
    }
    for (k, st) in row.stages.iter_mut().enumerate() {
        st.within_1 = mean(&|r| r.stages[k].within_1);
        st.within_2 = mean(&|r| r.stages[k].within_2);
        st.low_texture_within_2 = mean_opt(&|r| r.stages[k].low_texture_within_2);
        if let Some(p) = st.prior.as_mut() {
            let prior = |r: &AccuracyRow| r.stages[k].prior;
            if runs.iter().all(|(_, r)| prior(r).is_some()) {
                let get =
                    |f: &dyn Fn(&PriorAccuracy) -> f64| mean(&|r| prior(r).map_or(0.0, |p| f(&p)));
                p.points = get(&|p| p.points as f64).round() as usize;
                p.points_within_2 = get(&|p| p.points_within_2);
                p.covered = get(&|p| p.covered);
                p.within_2 = get(&|p| p.within_2);
                p.low_texture_covered = mean_opt(&|r| prior(r).and_then(|p| p.low_texture_covered));
                p.low_texture_within_2 =
                    mean_opt(&|r| prior(r).and_then(|p| p.low_texture_within_2));
            } else {
                st.prior = None;
            }
        }
    }
    row.seeds = runs.iter().map(|(s, _)| *s).collect();
    row.seed_within_2 = runs.iter().map(|(_, r)| r.within_2).collect();
    row.seed_low_texture_within_2 = runs
        .iter()
        .filter_map(|(_, r)| r.low_texture_within_2)
        .collect();
    if row.seed_low_texture_within_2.len() != runs.len() {
        row.seed_low_texture_within_2.clear();
    }
    Some(row)
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
    let (planes, stages) = estimate(ctx, pipelines, suite, params, method, options)?;
    let seconds = started.elapsed().as_secs_f64();
    let depths: DepthMaps = planes
        .iter()
        .map(|p| {
            p.as_ref()
                .map(|p| p.plane.iter().map(|q| q[3].max(0.0)).collect())
        })
        .collect();
    let mut row = score(suite, method, &depths, seconds);
    row.truth_misfit = truth_misfit(suite, &depths);
    row.median_ratios = median_ratios(suite, &depths);
    if let Some((all, weak)) = scale_free_within_2(suite, &depths, &row.median_ratios) {
        row.scale_free_within_2 = Some(all);
        row.scale_free_low_texture_within_2 = weak;
    }
    row.stages = stages;
    row.prior_oracle = options.prior_oracle;
    row.oracle_admit = options.prior_oracle.map(|_| options.oracle_admit);
    if suite.metric {
        row.cloud = score_cloud(suite, &planes, params)?;
    }
    let ranked = ranked_coverage(suite, &planes, params)?;
    row.confident_within_2 = ranked.0;
    row.lowest_cost_within_2 = ranked.1;
    Ok(row)
}

/// Each view's median estimate / truth ([`crate::eval::median_ratio`]), the truth at the
/// view's processed size; views without truth, estimate or common pixels are left out.
pub fn median_ratios(suite: &SuiteScene, depths: &[Option<Vec<f32>>]) -> Vec<(usize, f64)> {
    suite
        .truth
        .iter()
        .enumerate()
        .filter_map(|(v, truth)| {
            let (Some(t), Some(Some(estimate))) = (truth, depths.get(v)) else {
                return None;
            };
            let img = &suite.scene.views[v].image;
            let gt =
                crate::eval::resample_nearest(&t.depth, t.width, t.height, img.width, img.height);
            let r = crate::eval::median_ratio(estimate, &gt);
            r.is_finite().then_some((v, r))
        })
        .collect()
}

/// The views of `suite` whose truth fits the images worse than `depths` (at the views'
/// processed sizes) by more than [`crate::eval::MISFIT_RATIO`] (`mvscope eval`'s check).
pub fn truth_misfit(suite: &SuiteScene, depths: &[Option<Vec<f32>>]) -> Vec<usize> {
    let at_size = |t: &ViewTruth, v: usize| {
        let img = &suite.scene.views[v].image;
        crate::eval::resample_nearest(&t.depth, t.width, t.height, img.width, img.height)
    };
    let mut misfit = Vec::new();
    for (v, truth) in suite.truth.iter().enumerate() {
        let (Some(truth), Some(Some(estimate))) = (truth, depths.get(v)) else {
            continue;
        };
        let Some(source) = suite.scene.views[v].sources.first().map(|s| s.index) else {
            continue;
        };
        let seen = suite
            .truth
            .get(source)
            .and_then(|t| t.as_ref())
            .map(|t| at_size(t, source));
        let fit = crate::eval::photometric_fit(
            &suite.scene,
            v,
            &at_size(truth, v),
            estimate,
            seen.as_deref(),
        );
        if fit.is_some_and(|f| f.truth_fits_worse()) {
            misfit.push(v);
        }
    }
    misfit
}

/// The table `mvscope bench --accuracy` prints: one row per scene and method, then the mean
/// per kind of scene and method. Columns: within 1/2/5%, on weak texture within 1/2/5%, the
/// rooms' fused cloud (F1 at 2 and 5 cm, completeness at 2 cm), and within 2% at matched
/// coverage ([`MATCHED_COVERAGE`]) kept by confidence (`conf35`) and by cost (`cost35`);
/// the share of the pixels whose true point a source sees (`seen`) and within 2% on them,
/// all and weak (`seen<2%`, `sweak<2%`; [`crate::eval::seen_by_sources`]). Rows merged over seeds ([`mean_over_seeds`]) show their means, and two more columns the
/// least and greatest share within 2% over the seeds (all pixels, weak texture); a mean
/// row's range is that of the per-seed means.
pub fn format_table(rows: &[AccuracyRow]) -> String {
    let pct = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.1}", 100.0 * v));
    let seeded = rows.iter().any(|r| !r.seeds.is_empty());
    let range = |v: &[f64]| -> String {
        if v.is_empty() {
            return "-".into();
        }
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        format!("{:.1}-{:.1}", 100.0 * lo, 100.0 * hi)
    };
    let line = |name: &str,
                method: &str,
                size: &str,
                cells: [Option<f64>; 14],
                seconds: f64,
                spread: [&[f64]; 2]| {
        let c = cells.map(pct);
        let tail = if seeded {
            format!(" {:>11} {:>11}", range(spread[0]), range(spread[1]))
        } else {
            String::new()
        };
        format!(
            "{name:<22} {method:<6} {size:>9} {:>6} {:>6} {:>6} {:>8} {:>8} {:>8} {:>7} {:>7} {:>7} {:>7} {:>7} {:>5} {:>7} {:>8} {seconds:>8.1}{tail}\n",
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12], c[13]
        )
    };
    let cells = |r: &AccuracyRow| {
        let f1 = |k: usize| r.cloud.get(k).map(|c| c.f1);
        [
            Some(r.within_1),
            Some(r.within_2),
            Some(r.within_5),
            r.low_texture_within_1,
            r.low_texture_within_2,
            r.low_texture_within_5,
            f1(0),
            f1(1),
            r.cloud.first().map(|c| c.completeness),
            r.confident_within_2,
            r.lowest_cost_within_2,
            r.seen.map(|s| s.seen),
            r.seen.map(|s| s.within_2),
            r.seen.and_then(|s| s.low_texture_within_2),
        ]
    };
    let mut out = format!(
        "{:<22} {:<6} {:>9} {:>6} {:>6} {:>6} {:>8} {:>8} {:>8} {:>7} {:>7} {:>7} {:>7} {:>7} {:>5} {:>7} {:>8} {:>8}\n",
        "scene",
        "method",
        "size",
        "<1%",
        "<2%",
        "<5%",
        "weak<1%",
        "weak<2%",
        "weak<5%",
        "F1@2cm",
        "F1@5cm",
        "comp2cm",
        "conf35",
        "cost35",
        "seen",
        "seen<2%",
        "sweak<2%",
        "seconds"
    );
    if seeded {
        out.pop();
        out += &format!(" {:>11} {:>11}\n", "<2% seeds", "weak seeds");
    }
    // Every line's per-seed shares, for the paired differences below the table.
    let mut seeded_lines: Vec<SeededLine> = Vec::new();
    for r in rows {
        out += &line(
            &r.scene,
            &r.method,
            &format!("{}x{}", r.size[0], r.size[1]),
            cells(r),
            r.seconds,
            [&r.seed_within_2, &r.seed_low_texture_within_2],
        );
        seeded_lines.push(SeededLine {
            label: r.scene.clone(),
            method: r.method.clone(),
            seeds: r.seeds.clone(),
            within_2: r.seed_within_2.clone(),
            weak_within_2: r.seed_low_texture_within_2.clone(),
        });
    }
    // Means per kind of scene: the real stereo pairs, the rooms, the synthetic scenes.
    let kind = |r: &AccuracyRow| {
        if r.scene.starts_with("synthetic") {
            "synthetic"
        } else if !r.cloud.is_empty() {
            "rooms"
        } else {
            "pairs"
        }
    };
    let mut methods: Vec<&str> = Vec::new();
    for r in rows {
        if !methods.contains(&r.method.as_str()) {
            methods.push(&r.method);
        }
    }
    for group in ["pairs", "rooms", "synthetic"] {
        for &m in &methods {
            let of: Vec<&AccuracyRow> = rows
                .iter()
                .filter(|r| r.method == m && kind(r) == group)
                .collect();
            if of.is_empty() {
                continue;
            }
            let mut mean = [None; 14];
            for (k, slot) in mean.iter_mut().enumerate() {
                let v: Vec<f64> = of.iter().filter_map(|r| cells(r)[k]).collect();
                *slot = (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
            }
            // Per seed, the group's mean (the rows ran the same seeds in the same order).
            let per_seed = |f: &dyn Fn(&AccuracyRow) -> &[f64]| -> Vec<f64> {
                let k = f(of[0]).len();
                if k == 0 || of.iter().any(|r| f(r).len() != k) {
                    return Vec::new();
                }
                (0..k)
                    .map(|s| of.iter().map(|r| f(r)[s]).sum::<f64>() / of.len() as f64)
                    .collect()
            };
            let all = per_seed(&|r| &r.seed_within_2);
            let weak = per_seed(&|r| &r.seed_low_texture_within_2);
            let label = format!("mean of {} {group}", of.len());
            out += &line(
                &label,
                m,
                "",
                mean,
                of.iter().map(|r| r.seconds).sum::<f64>(),
                [&all, &weak],
            );
            let seeds = of[0].seeds.clone();
            if of.iter().all(|r| r.seeds == seeds) {
                seeded_lines.push(SeededLine {
                    label,
                    method: m.to_string(),
                    seeds,
                    within_2: all,
                    weak_within_2: weak,
                });
            }
        }
    }
    // Scenes whose estimate is off the truth the same way in most views, once per scene
    // (before the paired section, which ends at the first empty line or the text's end).
    let mut biased: Vec<&str> = Vec::new();
    for r in rows {
        let note = crate::eval::scale_bias_note_for(&r.median_ratios);
        if note.is_empty() || biased.contains(&r.scene.as_str()) {
            continue;
        }
        biased.push(&r.scene);
        out += &format!("{} ({}): {note}", r.scene, r.method);
        let divided: Vec<String> = rows
            .iter()
            .filter(|o| o.scene == r.scene)
            .filter_map(|o| {
                let all = o.scale_free_within_2?;
                Some(match o.scale_free_low_texture_within_2 {
                    Some(w) => format!("{} {:.1} ({:.1})", o.method, 100.0 * all, 100.0 * w),
                    None => format!("{} {:.1}", o.method, 100.0 * all),
                })
            })
            .collect();
        if !divided.is_empty() {
            out += &format!(
                "  with each view's median est/gt divided out, within 2% (weak texture): {}\n",
                divided.join(", ")
            );
        }
    }
    out += &paired_by_seed(&seeded_lines);
    // Scenes whose truth cannot judge some views, once per scene.
    let mut named: Vec<&str> = Vec::new();
    for r in rows.iter().filter(|r| !r.truth_misfit.is_empty()) {
        if named.contains(&r.scene.as_str()) {
            continue;
        }
        named.push(&r.scene);
        let views: Vec<String> = r.truth_misfit.iter().map(|v| v.to_string()).collect();
        out += &format!(
            "{}: the truth fits the images worse than {}'s depths on view(s) {} (`mvscope eval` shows the residuals): shares within 1-2% there measure the data's cameras as much as the method\n",
            r.scene,
            r.method,
            views.join(", ")
        );
    }
    out
}

/// One line of the table run with several seeds: its label (scene or mean), method, seeds
/// and each seed's share within 2% (all pixels, weak texture).
struct SeededLine {
    label: String,
    method: String,
    seeds: Vec<u64>,
    within_2: Vec<f64>,
    weak_within_2: Vec<f64>,
}

/// The differences paired by seed: each method's share within 2% minus the first method's
/// on the same scene (or mean) with the same seed, in points, with their mean and on how
/// many seeds the method is ahead. The seed alone moves a weak-texture room by points
/// (ICL at 320: ACMM 17.6-20.5%), so two methods' means can be within each other's ranges
/// while one is ahead on every seed; the pairing shows which. Empty without seeds or with
/// one method.
fn paired_by_seed(lines: &[SeededLine]) -> String {
    let Some(base) = lines.iter().find(|l| !l.seeds.is_empty()) else {
        return String::new();
    };
    let base_method = base.method.clone();
    let diffs = |a: &[f64], b: &[f64]| -> String {
        if a.is_empty() || a.len() != b.len() {
            return "-".into();
        }
        // In tenths of a point, as shown: +0.0 is neither ahead nor behind.
        let tenths = |v: f64| (10.0 * v).round() as i64;
        let shown = |t: i64| {
            format!(
                "{}{}.{}",
                if t < 0 { "-" } else { "+" },
                t.abs() / 10,
                t.abs() % 10
            )
        };
        let d: Vec<i64> = a
            .iter()
            .zip(b)
            .map(|(x, y)| tenths(100.0 * (x - y)))
            .collect();
        let each: Vec<String> = d.iter().map(|&t| shown(t)).collect();
        let mean = 100.0 * (a.iter().sum::<f64>() - b.iter().sum::<f64>()) / a.len() as f64;
        let ahead = d.iter().filter(|t| **t > 0).count();
        let behind = d.iter().filter(|t| **t < 0).count();
        format!(
            "{} (mean {}, ahead on {ahead}, behind on {behind} of {})",
            each.join(" "),
            shown(tenths(mean)),
            d.len()
        )
    };
    let mut out = String::new();
    for l in lines.iter().filter(|l| l.method != base_method) {
        let Some(b) = lines
            .iter()
            .find(|b| b.method == base_method && b.label == l.label && b.seeds == l.seeds)
        else {
            continue;
        };
        if l.seeds.is_empty() {
            continue;
        }
        out += &format!(
            "{:<22} {:<6} {:<58} weak: {}\n",
            l.label,
            l.method,
            diffs(&l.within_2, &b.within_2),
            diffs(&l.weak_within_2, &b.weak_within_2)
        );
    }
    if out.is_empty() {
        return out;
    }
    format!(
        "\npaired by seed against {base_method} (same scene and seed; points within 2%, seeds {}):\n{out}",
        base.seeds
            .iter()
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
            .join(",")
    )
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

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, method: &str, within_2: f64, weak: Option<f64>) -> AccuracyRow {
        AccuracyRow {
            scene: scene.into(),
            method: method.into(),
            size: [32, 24],
            pixels: 768,
            within_1: within_2 / 2.0,
            within_2,
            low_texture_pixels: 100,
            low_texture_within_1: None,
            low_texture_within_2: weak,
            low_texture_within_5: None,
            within_5: within_2 + 0.1,
            truth_misfit: Vec::new(),
            median_ratios: Vec::new(),
            scale_free_within_2: None,
            scale_free_low_texture_within_2: None,
            cloud: Vec::new(),
            confident_within_2: None,
            lowest_cost_within_2: None,
            seen: None,
            seconds: 2.0,
            stages: vec![StageAccuracy {
                stage: "scale 1/1 · photometric".into(),
                within_1: 0.0,
                within_2: within_2 - 0.1,
                low_texture_within_2: None,
                prior: None,
            }],
            prior_oracle: None,
            oracle_admit: None,
            seeds: Vec::new(),
            seed_within_2: Vec::new(),
            seed_low_texture_within_2: Vec::new(),
        }
    }

    #[test]
    fn methods_run_with_seeds_are_compared_seed_by_seed() {
        let seeded = |method: &str, shares: [f64; 3], weak: [f64; 3]| {
            let runs: Vec<(u64, AccuracyRow)> = (0..3)
                .map(|s| (s as u64, row("icl", method, shares[s], Some(weak[s]))))
                .collect();
            mean_over_seeds(&runs).expect("one scene and method")
        };
        let acmm = seeded("ACMM", [0.205, 0.197, 0.181], [0.245, 0.235, 0.213]);
        // Behind on the mean, ahead on one seed; weak texture ahead on two.
        let acmmp = seeded("ACMMP", [0.193, 0.199, 0.180], [0.228, 0.240, 0.220]);
        // A difference shown as +0.0 counts as neither ahead nor behind.
        let level = seeded("ACMP", [0.2054, 0.1966, 0.181], [0.245, 0.235, 0.213]);
        let table = format_table(&[acmm.clone(), acmmp, level]);
        let paired = table
            .split("paired by seed against ACMM")
            .nth(1)
            .expect("a paired section");
        assert!(paired.starts_with(" (same scene and seed; points within 2%, seeds 0,1,2):"));
        let icl = paired
            .lines()
            .find(|l| l.starts_with("icl"))
            .expect("icl's line");
        assert!(
            icl.contains("-1.2 +0.2 -0.1 (mean -0.4, ahead on 1, behind on 2 of 3)"),
            "{icl}"
        );
        assert!(
            icl.contains("weak: -1.7 +0.5 +0.7 (mean -0.2, ahead on 2, behind on 1 of 3)"),
            "{icl}"
        );
        let acmp = paired
            .lines()
            .find(|l| l.contains("ACMP "))
            .expect("ACMP's line");
        assert!(
            acmp.contains("+0.0 +0.0 +0.0 (mean +0.0, ahead on 0, behind on 0 of 3)"),
            "{acmp}"
        );
        // The mean over the rooms pairs too; ACMM is not paired with itself.
        assert!(paired.lines().any(|l| l.starts_with("mean of 1 pairs")));
        assert!(!paired.contains("ACMM  "));
        // One method, or no seeds: no section.
        assert!(!format_table(&[acmm]).contains("paired"));
        let plain = [
            row("icl", "ACMM", 0.2, None),
            row("icl", "ACMMP", 0.19, None),
        ];
        assert!(!format_table(&plain).contains("paired"));
    }

    #[test]
    fn seeds_merge_into_their_mean_and_keep_each_seeds_share() {
        let runs = [
            (0, row("icl", "ACMM", 0.20, Some(0.24))),
            (1, row("icl", "ACMM", 0.18, Some(0.22))),
            (2, row("icl", "ACMM", 0.19, Some(0.20))),
        ];
        let m = mean_over_seeds(&runs).expect("one scene and method");
        assert!((m.within_2 - 0.19).abs() < 1e-12);
        assert!((m.within_5 - 0.29).abs() < 1e-12);
        assert!((m.low_texture_within_2.unwrap() - 0.22).abs() < 1e-12);
        assert!((m.stages[0].within_2 - 0.09).abs() < 1e-12);
        assert_eq!(m.seeds, [0, 1, 2]);
        assert_eq!(m.seed_within_2, [0.20, 0.18, 0.19]);
        assert_eq!(m.seed_low_texture_within_2, [0.24, 0.22, 0.20]);
        let mut scaled = runs.clone();
        for (k, (_, r)) in scaled.iter_mut().enumerate() {
            r.scale_free_within_2 = Some(0.30 + 0.01 * k as f64);
        }
        let sm = mean_over_seeds(&scaled).unwrap();
        assert!((sm.scale_free_within_2.unwrap() - 0.31).abs() < 1e-12);
        assert_eq!(sm.scale_free_low_texture_within_2, None);
        // A share one seed lacks is absent from the mean, not averaged over fewer.
        let mut partial = runs.clone();
        partial[1].1.low_texture_within_2 = None;
        let p = mean_over_seeds(&partial).unwrap();
        assert_eq!(p.low_texture_within_2, None);
        assert!(p.seed_low_texture_within_2.is_empty());
        // Rows of different methods do not merge.
        let mut mixed = runs.clone();
        mixed[2].1.method = "ACMMP".into();
        assert!(mean_over_seeds(&mixed).is_none());
        assert!(mean_over_seeds(&[]).is_none());

        // The table shows the means and each row's and each group's range over the seeds.
        let other = mean_over_seeds(&[
            (0, row("kitchen", "ACMM", 0.10, Some(0.06))),
            (1, row("kitchen", "ACMM", 0.12, Some(0.08))),
            (2, row("kitchen", "ACMM", 0.08, Some(0.04))),
        ])
        .unwrap();
        let mut room = m.clone();
        room.cloud = vec![crate::eval::CloudScore {
            threshold: 0.02,
            accuracy: 0.5,
            completeness: 0.5,
            f1: 0.5,
        }];
        let mut kitchen = other;
        kitchen.cloud = room.cloud.clone();
        let table = format_table(&[room, kitchen]);
        assert!(
            table
                .lines()
                .next()
                .unwrap()
                .ends_with("<2% seeds  weak seeds")
        );
        let icl = table.lines().find(|l| l.starts_with("icl")).unwrap();
        assert!(
            icl.contains(" 19.0 ") && icl.ends_with("18.0-20.0   20.0-24.0"),
            "{icl}"
        );
        // Per seed the rooms' mean is 15.0, 15.0, 13.5 (weak 15, 15, 12).
        let mean = table
            .lines()
            .find(|l| l.starts_with("mean of 2 rooms"))
            .unwrap();
        assert!(mean.ends_with("13.5-15.0   12.0-15.0"), "{mean}");
        // Without seeds, no range columns.
        assert!(!format_table(&[row("icl", "ACMM", 0.2, None)]).contains("seeds"));
    }

    #[test]
    fn what_the_sources_see_is_averaged_over_seeds_and_shown() {
        let seen = |within_2: f64, unseen: Option<f64>| crate::eval::SeenScore {
            seen: 0.7,
            within_2,
            low_texture_within_2: Some(within_2 + 0.1),
            unseen_within_2: unseen,
        };
        let mut runs = [
            (0, row("icl", "Regions", 0.60, Some(0.7))),
            (1, row("icl", "Regions", 0.62, Some(0.7))),
        ];
        runs[0].1.seen = Some(seen(0.80, Some(0.2)));
        runs[1].1.seen = Some(seen(0.90, Some(0.4)));
        let m = mean_over_seeds(&runs)
            .expect("one scene and method")
            .seen
            .expect("seen");
        assert!((m.within_2 - 0.85).abs() < 1e-12 && (m.seen - 0.7).abs() < 1e-12);
        assert!((m.low_texture_within_2.unwrap() - 0.95).abs() < 1e-12);
        assert!((m.unseen_within_2.unwrap() - 0.3).abs() < 1e-12);
        // A seed without the split leaves the mean without it; one without unseen pixels
        // leaves the unseen share out.
        let mut partial = runs.clone();
        partial[1].1.seen = None;
        assert!(mean_over_seeds(&partial).unwrap().seen.is_none());
        partial[1].1.seen = Some(seen(0.9, None));
        let p = mean_over_seeds(&partial).unwrap().seen.unwrap();
        assert_eq!(p.unseen_within_2, None);
        // The table's columns: seen, within 2% on the seen, on the seen weak pixels.
        let mut one = runs[0].1.clone();
        one.cloud = vec![crate::eval::CloudScore {
            threshold: 0.02,
            accuracy: 0.5,
            completeness: 0.5,
            f1: 0.5,
        }];
        let table = format_table(&[one.clone(), row("Teddy", "ACMM", 0.9, None)]);
        let head = table.lines().next().unwrap();
        assert!(head.contains(" seen seen<2% sweak<2%  seconds"), "{head}");
        let icl = table.lines().find(|l| l.starts_with("icl")).unwrap();
        assert!(icl.ends_with(" 70.0    80.0     90.0      2.0"), "{icl}");
        let teddy = table.lines().find(|l| l.starts_with("Teddy")).unwrap();
        assert!(
            teddy.ends_with("     -       -        -      2.0"),
            "{teddy}"
        );
    }

    #[test]
    fn views_whose_truth_misfits_are_merged_over_seeds_and_named_once_per_scene() {
        let mut a = row("icl", "ACMM", 0.20, None);
        a.truth_misfit = vec![2];
        let mut b = row("icl", "ACMM", 0.18, None);
        b.truth_misfit = vec![0, 2];
        let m = mean_over_seeds(&[(0, a), (1, b)]).unwrap();
        assert_eq!(m.truth_misfit, [0, 2], "any seed's");
        let mut p = m.clone();
        p.method = "ACMMP".into();
        let table = format_table(&[m, p, row("Teddy", "ACMM", 0.9, None)]);
        let notes: Vec<&str> = table
            .lines()
            .filter(|l| l.contains("the truth fits the images worse"))
            .collect();
        assert_eq!(notes.len(), 1, "{table}");
        assert!(notes[0].starts_with("icl:") && notes[0].contains("view(s) 0, 2"));
        assert!(!format_table(&[row("Teddy", "ACMM", 0.9, None)]).contains("truth fits"));
    }

    #[test]
    fn the_scale_free_share_divides_each_view_by_its_own_ratio() {
        let suite = synthetic_scene(&crate::synthetic::SyntheticOptions {
            views: 3,
            width: 48,
            height: 36,
            ..Default::default()
        })
        .unwrap();
        // View 0 25% deep, view 1 right, view 2 10% shallow, each within 1% of its scale.
        let scales = [1.25f32, 1.0, 0.9];
        let wobble = [0.995f32, 1.0, 1.005, 0.998];
        let depths: Vec<Option<Vec<f32>>> = suite
            .truth
            .iter()
            .zip(scales)
            .map(|(t, k)| {
                let t = t.as_ref().unwrap();
                Some(
                    t.depth
                        .iter()
                        .enumerate()
                        .map(|(i, &g)| g * k * wobble[i % 4])
                        .collect(),
                )
            })
            .collect();
        let shipped = score(&suite, Method::Acmm, &depths, 0.0);
        let third = 1.0 / 3.0;
        assert!(
            (shipped.within_2 - third).abs() < 0.02,
            "{}",
            shipped.within_2
        );
        let ratios = median_ratios(&suite, &depths);
        assert_eq!(ratios.len(), 3);
        assert!((ratios[0].1 - 1.25).abs() < 0.01 && (ratios[2].1 - 0.9).abs() < 0.01);
        let (all, weak) = scale_free_within_2(&suite, &depths, &ratios).unwrap();
        assert!(all > 0.99, "{all}");
        assert!(weak.unwrap() > 0.99);
        // One pooled ratio could not do it; no ratio, no share.
        let pooled = [(0, 1.0), (1, 1.0), (2, 1.0)];
        let (one, _) = scale_free_within_2(&suite, &depths, &pooled).unwrap();
        assert!((one - shipped.within_2).abs() < 1e-9);
        assert!(scale_free_within_2(&suite, &depths, &[]).is_none());
    }

    #[test]
    fn a_scale_bias_in_most_views_is_named_below_the_table_once_per_scene() {
        // kitchen-b with the colour focal length: 1.07-1.15 in all ten views (ACMM, 320).
        let mut a = row("kitchen-b", "ACMM", 0.10, None);
        a.median_ratios = (0..10).map(|v| (v, 1.07 + 0.008 * v as f64)).collect();
        let mut b = a.clone();
        b.method = "Regions".into();
        let mut c = row("kitchen-a", "ACMM", 0.36, None);
        c.median_ratios = (0..10).map(|v| (v, 1.008 + 0.002 * v as f64)).collect();
        a.scale_free_within_2 = Some(0.076);
        a.scale_free_low_texture_within_2 = Some(0.089);
        b.scale_free_within_2 = Some(0.080);
        b.scale_free_low_texture_within_2 = Some(0.097);
        c.scale_free_within_2 = Some(0.37);
        let table = format_table(&[a, b, c.clone()]);
        let notes: Vec<&str> = table.lines().filter(|l| l.contains("scale:")).collect();
        assert_eq!(notes.len(), 1, "{table}");
        // Each method's scale-free share under the biased scene's note, none under the other.
        let divided: Vec<&str> = table
            .lines()
            .filter(|l| l.contains("divided out"))
            .collect();
        assert_eq!(
            divided,
            [
                "  with each view's median est/gt divided out, within 2% (weak texture): ACMM 7.6 (8.9), Regions 8.0 (9.7)"
            ],
            "{table}"
        );
        assert!(
            notes[0].starts_with("kitchen-b (ACMM): scale:")
                && notes[0].contains("in 10 of 10 views, all deeper"),
            "{}",
            notes[0]
        );
        let json = serde_json::to_string(&c).unwrap();
        assert!(json.contains("median_ratios"), "{json}");
        assert!(
            !serde_json::to_string(&row("Teddy", "ACMM", 0.9, None))
                .unwrap()
                .contains("median_ratios")
        );
    }
}
