//! Everything the viewer shows and does, without egui: which scene is open, the ACMM session
//! and how far it has run, stepping in frame-sized slices, parameter changes, captures for the
//! pixel inspector, the fused cloud and the method comparison. The app draws this; tests
//! drive it directly or through the app.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use web_time::Instant;

use super::cloud::{CloudScene, CloudVertex, Frustum, points_from_depth, points_from_fusion};
use super::maps::pack_rgba;
use super::timeline::{self, Unit};
use crate::acmm::params::{Method, Params};
use crate::acmm::problem::{ViewProblem, ViewState};
use crate::gpu::GpuContext;
use crate::gpu::acmh::AcmhPipelines;
use crate::scene::{LoadOptions, Scene};
use crate::session::{
    Action, GpuMaps, Pending, PlanesCosts, Session, SessionError, Stage, Step, ViewMaps,
};
use crate::vfs;

mod cloud_jobs;
mod comparison;

pub use comparison::*;

/// Ground-truth depth of a view (full resolution).
#[derive(Clone, Debug)]
pub struct GroundTruth {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
    /// Weak-texture pixels (`gt/%08d_lowtex.png`, or the demo's low-texture wall), where
    /// known.
    pub weak: Option<Vec<bool>>,
}

impl GroundTruth {
    /// Sampled at the pixel centres of a `width` x `height` map (nearest), as `mvscope eval`
    /// samples it.
    pub fn resampled(&self, width: u32, height: u32) -> Vec<f32> {
        crate::eval::resample_nearest(&self.depth, self.width, self.height, width, height)
    }

    /// The weak-texture mask sampled as [`GroundTruth::resampled`].
    pub fn weak_resampled(&self, width: u32, height: u32) -> Option<Vec<bool>> {
        let m = self.weak.as_ref()?;
        Some(crate::eval::resample_nearest(
            m,
            self.width,
            self.height,
            width,
            height,
        ))
    }
}

/// An open scene.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// What the title bar says.
    pub name: String,
    /// The folder, `None` for the built-in demo.
    pub path: Option<PathBuf>,
    pub scene: Scene,
    /// Per view, where known.
    pub ground_truth: Vec<Option<GroundTruth>>,
    /// [`Loaded::seen_by_sources`], made on first use: it depends on the scene and its truth
    /// only, not on the run that is scored.
    seen: std::sync::OnceLock<SeenBySources>,
}

/// Each view's truth at its view's size and the pixels of it a source sees
/// (`eval::seen_by_sources`); `None` for a view without truth.
#[derive(Clone, Debug)]
pub struct SeenBySources {
    pub truths: Vec<Option<Vec<f32>>>,
    pub seen: Vec<Option<Vec<bool>>>,
}

impl Loaded {
    pub fn new(
        name: String,
        path: Option<PathBuf>,
        scene: Scene,
        ground_truth: Vec<Option<GroundTruth>>,
    ) -> Loaded {
        Loaded {
            name,
            path,
            scene,
            ground_truth,
            seen: std::sync::OnceLock::new(),
        }
    }

    pub fn has_ground_truth(&self) -> bool {
        self.ground_truth.iter().any(Option::is_some)
    }

    /// The split `mvscope eval` makes by what the sources see, per pixel, at the views'
    /// sizes: computed once per scene (Compare scores every method against it).
    pub fn seen_by_sources(&self) -> &SeenBySources {
        self.seen.get_or_init(|| {
            let truths: Vec<Option<Vec<f32>>> = self
                .scene
                .views
                .iter()
                .enumerate()
                .map(|(v, s)| {
                    let gt = self.ground_truth.get(v)?.as_ref()?;
                    Some(gt.resampled(s.image.width, s.image.height))
                })
                .collect();
            let seen = (0..self.scene.views.len())
                .map(|v| crate::eval::seen_by_sources(&self.scene, v, &truths))
                .collect();
            SeenBySources { truths, seen }
        })
    }
}

/// The state of the last half-iteration of one colour of the inspected view: what the GPU
/// read and what it wrote, so the inspector can recompute any pixel on the CPU.
#[derive(Clone)]
pub struct Capture {
    /// Index of the step in the schedule.
    pub index: usize,
    pub step: Step,
    pub params: Params,
    pub method: Method,
    pub problem: ViewProblem,
    pub before: ViewState,
    pub after: ViewState,
    /// The sources' depth maps (geometric passes).
    pub source_depths: Option<Vec<f32>>,
    /// C_init of the gated detail restorer's pass.
    pub c_init: Option<Vec<f32>>,
    /// The planar prior's planes (the prior-assisted pass of ACMP, ACMMP).
    pub prior: Option<Vec<[f32; 4]>>,
    /// Each pixel's anchor code in the prior-assisted pass (`prior_anchors`).
    pub anchors: Option<Vec<u32>>,
    /// The flat regions and their planes the prior was painted from (Regions).
    pub regions: Option<crate::acmm::planar::RegionFit>,
}

/// What the shown view's last support-point step read, for the inspector's "why this
/// support point" ([`crate::acmm::planar::explain_cell`]).
#[derive(Clone, Debug)]
pub struct SupportCapture {
    /// Index of the step in the schedule.
    pub index: usize,
    pub params: Params,
    pub problem: ViewProblem,
    pub inputs: crate::session::SupportInputs,
}

impl SupportCapture {
    /// The support point of the cell holding pixel (x, y) and every pixel it was chosen
    /// among.
    pub fn explain(&self, x: u32, y: u32) -> Option<crate::acmm::planar::SupportCell> {
        let i = &self.inputs;
        crate::acmm::planar::explain_cell(
            &self.problem,
            &self.params,
            &i.plane,
            &i.cost,
            i.keys.as_deref(),
            i.spread.as_deref(),
            x,
            y,
        )
    }
}

/// A [`SupportCapture`] whose read-backs are on their way.
struct PendingSupport {
    index: usize,
    params: Params,
    problem: ViewProblem,
    inputs: crate::session::Pending<Option<crate::session::SupportInputs>>,
}

/// Checkpoint memory a parked session (one left by a method switch) keeps.
pub const PARKED_CHECKPOINT_BUDGET: u64 = crate::session::DEFAULT_CHECKPOINT_BUDGET / 4;

/// A line of the status bar, and when it goes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Notice {
    pub kind: NoticeKind,
    pub text: String,
}

/// What a notice reports, which says when it is stale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoticeKind {
    /// A re-run or a replay under way: gone when the run reaches its target.
    Running,
    /// A method switch, a fusion, a Compare mode: gone when the user moves the run.
    UntilMoved,
    /// Anything else: stays until another replaces it.
    Info,
}

impl Notice {
    pub fn running(text: String) -> Option<Notice> {
        Some(Notice {
            kind: NoticeKind::Running,
            text,
        })
    }

    pub fn until_moved(text: String) -> Option<Notice> {
        Some(Notice {
            kind: NoticeKind::UntilMoved,
            text,
        })
    }

    pub fn info(text: String) -> Option<Notice> {
        Some(Notice {
            kind: NoticeKind::Info,
            text,
        })
    }
}

/// The viewer's state.
pub struct Model {
    pub ctx: GpuContext,
    pipelines: Arc<AcmhPipelines>,
    pub load_options: LoadOptions,
    /// Device memory the sessions may hold (see `ViewerOptions::device_budget`).
    pub device_budget: Option<u64>,
    pub loaded: Option<Loaded>,
    pub session: Option<Session>,
    pub params: Params,
    pub method: Method,
    /// The reference view shown.
    pub view: usize,
    /// Running toward this cursor, a slice per frame.
    pub target: Option<usize>,
    /// Bumps whenever any map may have changed.
    pub version: u64,
    /// The last error, shown in the window until dismissed.
    pub error: Option<String>,
    /// Informational line of the status bar.
    pub notice: Option<Notice>,
    pub recent: Vec<PathBuf>,
    /// Set while [`Model::inspect_pixel`]'s replay runs.
    replaying: bool,
    /// How many parameter sets were applied (each one rewinds and re-runs).
    pub params_applied: u64,
    /// Time of the last step (GPU work included).
    pub last_step: Duration,
    /// The inspected pixel as picked, with the pyramid level it was picked at; see
    /// [`Model::inspect`] for where it is at the shown level.
    picked: Option<(u32, u32, u32)>,
    /// Last red and black half of the inspected view.
    pub captures: [Option<Capture>; 2],
    /// The shown view's last support-point step (planar prior), when it ran on the device.
    pub support: Option<SupportCapture>,
    pending_support: Option<PendingSupport>,
    pub cloud: Arc<CloudScene>,
    /// What the cloud shows.
    pub cloud_source: CloudSource,
    pub comparison: Option<Comparison>,
    gpu_maps: Option<(u64, usize, GpuMaps)>,
    /// The sessions of the methods not shown, with their progress (see [`Model::set_method`]).
    parked: HashMap<Method, Session>,
    images: HashMap<(usize, u32, u32), wgpu::Buffer>,
    truths: HashMap<(usize, u32, u32), Option<wgpu::Buffer>>,
    cloud_version: u64,
    /// The steps' GPU work not finished yet: the model never waits for the device; it
    /// submits at most [`MAX_IN_FLIGHT`] steps ahead and times each when its work is done.
    in_flight: Vec<InFlight>,
    /// Captures whose read-backs are on their way.
    pending_captures: Vec<PendingCapture>,
    /// The shown view's maps as of (version, view), asked for by [`Model::current_maps`].
    current: CurrentMaps,
    /// A fusion or back-projection waiting for its read-backs.
    pending_cloud: Option<PendingCloud>,
    /// How many sources agree with each pixel of every view, from the last "Fuse".
    confidence: Option<FusedConfidence>,
}

/// The confidence of the maps a fusion used ([`crate::fusion::confidence`]).
struct FusedConfidence {
    /// The model's version when they were fused: a later step makes them stale.
    version: u64,
    /// Per view, at the fused level's size.
    counts: Vec<Vec<u8>>,
}

/// A value of a [`Pending`] known to be ready.
fn taken<T>(x: Option<Result<T, SessionError>>) -> Result<T, SessionError> {
    x.unwrap_or_else(|| Err(SessionError::State("a read-back went missing".into())))
}

/// Steps a frame may submit ahead of the device's finished work.
pub const MAX_IN_FLIGHT: usize = 4;

/// A step's GPU work: submitted at `started`, done when the queue says so.
struct InFlight {
    started: Instant,
    done: Arc<Mutex<Option<Instant>>>,
}

/// What a [`Capture`] is made of, on its way from the device.
struct PendingCapture {
    color: u32,
    index: usize,
    step: Step,
    params: Params,
    method: Method,
    problem: ViewProblem,
    before: Pending<Option<ViewMaps>>,
    after: Pending<Option<ViewMaps>>,
    source_depths: Option<Pending<Vec<f32>>>,
    c_init: Pending<Option<Vec<f32>>>,
    prior: Option<Pending<Option<Vec<[f32; 4]>>>>,
    anchors: Pending<Option<Vec<u32>>>,
    regions: Option<crate::acmm::planar::RegionFit>,
}

/// The (version, view) a read of the shown maps belongs to.
type MapsKey = (u64, usize);

/// The shown view's maps, keyed by (version, view).
#[derive(Default)]
struct CurrentMaps {
    asked: Option<(MapsKey, Pending<Option<ViewMaps>>)>,
    arrived: Option<(MapsKey, Option<ViewMaps>)>,
}

/// What the 3D view is waiting for.
enum CloudJob {
    Fuse,
    Backproject { all: bool },
}

struct PendingCloud {
    job: CloudJob,
    /// Per view (the chosen one only for a single back-projection).
    reads: Vec<(usize, Pending<Option<PlanesCosts>>)>,
}

/// Which points the 3D view shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CloudSource {
    /// The fused cloud (after "Fuse").
    #[default]
    Fused,
    /// The chosen view's current depth map, back-projected.
    ViewDepth,
    /// Every view's current depth map, back-projected.
    AllDepths,
}

impl Model {
    /// A model on `ctx`, with nothing open.
    pub fn new(ctx: GpuContext, params: Params, method: Method) -> Result<Model, String> {
        let pipelines = Arc::new(AcmhPipelines::new(&ctx).map_err(|e| e.to_string())?);
        Ok(Model {
            ctx,
            pipelines,
            load_options: LoadOptions::default(),
            device_budget: None,
            loaded: None,
            session: None,
            params,
            method,
            view: 0,
            target: None,
            version: 0,
            error: None,
            notice: None,
            recent: Vec::new(),
            replaying: false,
            params_applied: 0,
            last_step: Duration::ZERO,
            picked: None,
            captures: [None, None],
            cloud: Arc::new(CloudScene {
                points: Vec::new(),
                frusta: Vec::new(),
                version: 0,
            }),
            cloud_source: CloudSource::Fused,
            comparison: None,
            gpu_maps: None,
            parked: HashMap::new(),
            images: HashMap::new(),
            truths: HashMap::new(),
            cloud_version: 0,
            in_flight: Vec::new(),
            pending_captures: Vec::new(),
            support: None,
            pending_support: None,
            current: CurrentMaps::default(),
            pending_cloud: None,
            confidence: None,
        })
    }

    /// Loads a scene folder (any format mvscope reads) with its ground truth if it has
    /// `gt/%08d.pfm` (as `mvscope demo` writes).
    pub fn load_folder(path: &Path, options: &LoadOptions) -> LoadResult {
        let scene = Scene::load(path, options).map_err(|e| e.to_string())?;
        let mut ground_truth = Vec::with_capacity(scene.views.len());
        for v in 0..scene.views.len() {
            let gt = path.join(format!("gt/{v:08}.pfm"));
            ground_truth.push(if vfs::is_file(&gt) {
                let map = crate::io::read_pfm(&gt).map_err(|e| e.to_string())?;
                let mask = path.join(format!("gt/{v:08}_lowtex.png"));
                let weak = if vfs::is_file(&mask) {
                    let bytes = vfs::read(&mask).map_err(|e| format!("{}: {e}", mask.display()))?;
                    let img = image::load_from_memory(&bytes).map_err(|e| {
                        format!(
                            "{}: not a readable mask ({e}); it should be an 8-bit PNG, 255 on \
                             weak texture",
                            mask.display()
                        )
                    })?;
                    let l = img.to_luma8();
                    let m: Vec<bool> = l.pixels().map(|p| p.0[0] > 127).collect();
                    Some(crate::eval::resample_nearest(
                        &m,
                        l.width(),
                        l.height(),
                        map.width,
                        map.height,
                    ))
                } else {
                    None
                };
                Some(GroundTruth {
                    width: map.width,
                    height: map.height,
                    depth: map.data,
                    weak,
                })
            } else {
                None
            });
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| path.display().to_string());
        Ok(Loaded::new(
            name,
            Some(path.to_path_buf()),
            scene,
            ground_truth,
        ))
    }

    /// A scene handed over as files in memory (a zip, or a folder a browser gave file by
    /// file): loaded from the deepest folder that holds them all, as from disk.
    pub fn load_files(files: vfs::MemoryFiles, options: &LoadOptions) -> LoadResult {
        if files.is_empty() {
            return Err("no files were given".into());
        }
        let root = files.root();
        let name = root
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "dropped files".into());
        vfs::with_files(Arc::new(files), || {
            let mut loaded = Self::load_folder(&root, options)?;
            loaded.name = name;
            // Not a folder on disk: nothing to reopen from "recent".
            loaded.path = None;
            Ok(loaded)
        })
    }

    /// The built-in demo scene (generated, with ground truth).
    pub fn demo(width: u32, height: u32, views: usize) -> LoadResult {
        let synthetic = crate::synthetic::generate(&crate::synthetic::SyntheticOptions {
            views,
            width,
            height,
            ..Default::default()
        })
        .map_err(|e| e.to_string())?;
        Ok(Loaded::new(
            format!("demo scene ({width}x{height}, {views} views)"),
            None,
            synthetic.scene,
            synthetic
                .ground_truth
                .iter()
                .map(|g| {
                    Some(GroundTruth {
                        width: g.width,
                        height: g.height,
                        depth: g.depth.clone(),
                        weak: Some(g.low_texture.clone()),
                    })
                })
                .collect(),
        ))
    }

    /// Opens a loaded scene: a fresh session from its first step. Errors stay in the window.
    pub fn open(&mut self, loaded: LoadResult) {
        match loaded {
            Ok(loaded) => {
                if let Some(p) = &loaded.path {
                    self.recent.retain(|r| r != p);
                    self.recent.insert(0, p.clone());
                    self.recent.truncate(8);
                }
                self.loaded = Some(loaded);
                self.view = 0;
                self.error = None;
                self.images.clear();
                self.truths.clear();
                self.comparison = None;
                // Sessions of other methods belong to the scene before.
                self.parked.clear();
                self.notice = None;
                self.rebuild_session();
            }
            Err(e) => self.error = Some(e),
        }
    }

    /// A new session with the current method and parameters.
    pub fn rebuild_session(&mut self) {
        self.session = None;
        // The last step's time was another session's.
        self.last_step = Duration::ZERO;
        self.target = None;
        self.clear_captures();
        self.gpu_maps = None;
        self.version += 1;
        if self.loaded.is_none() {
            return;
        }
        match self.new_session(self.method) {
            Ok(s) => self.session = Some(s),
            Err(e) => self.error = Some(e),
        }
        self.set_cloud(Vec::new());
    }

    /// Device bytes every session holds: the main one, the parked ones and the compared
    /// runs (on a software device, host memory).
    pub fn device_bytes(&self) -> u64 {
        let own = self
            .comparison
            .iter()
            .flat_map(|c| &c.runs)
            .filter_map(|r| match &r.source {
                RunSource::Own(s) => Some(s.device_bytes()),
                _ => None,
            });
        self.session.iter().map(Session::device_bytes).sum::<u64>()
            + self.parked.values().map(Session::device_bytes).sum::<u64>()
            + own.sum::<u64>()
    }

    /// The current parameters as `method` runs them (the method shown's as they are; another
    /// method's with its own defaults where the user changed nothing: [`Method::adopt`]).
    pub fn params_for(&self, method: Method) -> Params {
        method.adopt(&self.params, self.method)
    }

    /// A session of `method` on the loaded scene with the current parameters.
    fn new_session(&self, method: Method) -> Result<Session, String> {
        let loaded = self.loaded.as_ref().ok_or("no scene open")?;
        Session::with_options(
            &self.ctx,
            self.pipelines.clone(),
            &loaded.scene,
            self.params_for(method),
            method,
            crate::session::SessionOptions {
                device_budget: self.device_budget,
                ..Default::default()
            },
        )
        .map_err(|e| format!("cannot start {method}: {e}"))
    }

    pub fn scene(&self) -> Option<&Scene> {
        self.loaded.as_ref().map(|l| &l.scene)
    }

    pub fn cursor(&self) -> usize {
        self.session.as_ref().map_or(0, Session::cursor)
    }

    pub fn schedule(&self) -> &[Step] {
        self.session.as_ref().map_or(&[], |s| s.schedule())
    }

    /// The last step run, if any.
    pub fn current_step(&self) -> Option<Step> {
        let c = self.cursor();
        (c > 0).then(|| self.schedule()[c - 1])
    }

    /// Whether steps are queued, or results of steps run are still on their way from the
    /// device (captures, a fusion, a comparison's maps).
    pub fn is_running(&self) -> bool {
        self.target.is_some()
            || !self.in_flight.is_empty()
            || !self.pending_captures.is_empty()
            || self.pending_support.is_some()
            || self.pending_cloud.is_some()
            || self.comparison.as_ref().is_some_and(|c| !c.is_finished())
    }

    /// Whether the run is replaying steps to record an inspected pixel's last update: the
    /// maps meanwhile are those of earlier steps, not the ones the pixel was picked on.
    pub fn is_replaying(&self) -> bool {
        self.replaying && self.target.is_some()
    }

    /// Starts running one `unit` forward.
    pub fn step(&mut self, unit: Unit) {
        let target = timeline::advance(self.schedule(), self.cursor(), unit);
        self.run_to(target);
    }

    /// Goes back one `unit` (from the latest checkpoint, replayed in slices).
    pub fn step_back(&mut self, unit: Unit) {
        let target = timeline::retreat(self.schedule(), self.cursor(), unit);
        self.run_to(target);
    }

    /// Shows reference view `view`. The inspected pixel and its captures belonged to the
    /// previous view, so they go.
    pub fn set_view(&mut self, view: usize) {
        if view != self.view {
            self.view = view;
            self.picked = None;
            self.clear_captures();
            self.version += 1;
        }
    }

    /// Inspects pixel `px` of the shown view. Its colour's last half-iteration is replayed
    /// with the capture on when it was not recorded (the pixel was picked after the fact):
    /// the session rewinds to the checkpoint before that half and runs back to where it
    /// stood, in slices. Replays are exact (the random streams are fixed per step), so the
    /// maps come back bit for bit.
    pub fn inspect_pixel(&mut self, px: (u32, u32)) {
        let level = self.shown_level();
        self.picked = Some((px.0, px.1, level));
        let color = (px.0 + px.1) % 2;
        let Some(session) = &mut self.session else {
            return;
        };
        let cursor = session.cursor();
        let view = self.view;
        let last_half = session.schedule()[..cursor].iter().rposition(|s| {
            s.view == view
                && s.level == level
                && matches!(s.action, Action::Half { color: c, .. } if c == color)
        });
        let Some(half) = last_half else {
            return;
        };
        if self.captures[color as usize]
            .as_ref()
            .is_some_and(|c| c.index == half)
        {
            return;
        }
        let resume_to = self.target.unwrap_or(cursor).max(cursor);
        let from = session.rewind(half);
        self.clear_captures_from(from);
        self.version += 1;
        self.notice = Notice::running(format!(
            "replaying steps {}..{} to record how pixel ({}, {}) was updated",
            from + 1,
            resume_to,
            px.0,
            px.1
        ));
        self.target = (resume_to > from).then_some(resume_to);
        self.replaying = self.target.is_some();
    }

    /// The capture of the last half that updated pixel (`x`, `y`) of the shown maps (its
    /// colour's, at the shown scale), if one was recorded.
    pub fn capture_for(&self, x: u32, y: u32) -> Option<&Capture> {
        let level = self.shown_level();
        self.captures[((x + y) % 2) as usize]
            .as_ref()
            .filter(|c| c.step.view == self.view && c.step.level == level)
    }

    /// Pyramid level of the shown view's maps: that of the view's last step run.
    pub fn shown_level(&self) -> u32 {
        let schedule = self.schedule();
        schedule[..self.cursor().min(schedule.len())]
            .iter()
            .rev()
            .find(|s| s.view == self.view)
            .map_or(0, |s| s.level)
    }

    /// The inspected pixel of the shown maps: the spot picked, scaled to the shown level
    /// when ACMM has changed scale since (upsampling forward, a rewind back). Derived from
    /// the pick each time, so stepping back and forth never drifts.
    pub fn inspect(&self) -> Option<(u32, u32)> {
        let (x, y, picked) = self.picked?;
        let level = self.shown_level();
        if level == picked {
            return Some((x, y));
        }
        let session = self.session.as_ref()?;
        let size = |l: u32| {
            (l < session.num_levels())
                .then(|| session.level_scene(l).views.get(self.view))
                .flatten()
                .map(|v| (v.image.width.max(1), v.image.height.max(1)))
        };
        let ((w0, h0), (w1, h1)) = (size(picked)?, size(level)?);
        let scale = |v: u32, from: u32, to: u32| {
            (((v as f64 + 0.5) * to as f64 / from as f64) as u32).min(to - 1)
        };
        Some((scale(x, w0, w1), scale(y, h0, h1)))
    }

    /// Runs (or rewinds) toward `target` steps, a slice per frame.
    pub fn run_to(&mut self, target: usize) {
        self.replaying = false;
        self.clear_switch_notice();
        let Some(session) = &mut self.session else {
            return;
        };
        let target = target.min(session.schedule().len());
        let rewound = target < session.cursor();
        if rewound {
            session.rewind(target);
        }
        let cursor = session.cursor();
        if rewound {
            self.clear_captures_from(cursor);
            self.version += 1;
        }
        self.target = (target > cursor).then_some(target);
    }

    pub fn run_to_end(&mut self) {
        let end = self.schedule().len();
        self.run_to(end);
    }

    pub fn pause(&mut self) {
        self.target = None;
        self.replaying = false;
    }

    pub fn reset(&mut self) {
        self.target = None;
        if let Some(s) = &mut self.session {
            s.reset();
        }
        self.clear_captures();
        self.version += 1;
    }

    /// Runs steps toward the target for at most `budget`, never waiting for the device: a
    /// step is submitted only while fewer than [`MAX_IN_FLIGHT`] are unfinished and the
    /// read-backs it needs have arrived; what arrived since the last frame is taken. Returns
    /// whether there is more to do (ask again next frame).
    pub fn tick(&mut self, budget: Duration) -> bool {
        let start = Instant::now();
        self.poll_device();
        while let Some(target) = self.target {
            if self.cursor() >= target {
                self.target = None;
                self.end_of_run();
                break;
            }
            let ready = self.session.as_ref().is_some_and(Session::next_step_ready);
            if self.in_flight.len() >= MAX_IN_FLIGHT || !ready {
                break;
            }
            if let Err(e) = self.step_one() {
                self.error = Some(e.to_string());
                self.target = None;
                break;
            }
            if start.elapsed() >= budget {
                break;
            }
        }
        let comparing = self.tick_comparison(budget.saturating_sub(start.elapsed()));
        self.poll_device();
        comparing || self.is_running()
    }

    /// Takes what the device has finished since the last look: step timings, captures, the
    /// shown maps, a cloud's maps.
    fn poll_device(&mut self) {
        self.ctx.poll();
        let mut finished = None;
        self.in_flight.retain(|f| {
            let done = *f.done.lock().unwrap_or_else(|e| e.into_inner());
            if let Some(t) = done {
                finished = Some(t.saturating_duration_since(f.started));
            }
            done.is_none()
        });
        if let Some(d) = finished {
            self.last_step = d;
        }
        self.poll_captures();
        self.poll_cloud();
    }

    /// Waits (natively) until every step's work and read-back is done: scripts and tests.
    #[cfg(not(target_arch = "wasm32"))]
    fn settle_device(&mut self) -> Result<(), SessionError> {
        let _ = self.ctx.device.poll(wgpu::PollType::wait_indefinitely());
        self.poll_device();
        if let Some(e) = self.error.clone()
            && (!self.pending_captures.is_empty() || self.pending_cloud.is_some())
        {
            return Err(SessionError::State(e));
        }
        Ok(())
    }

    /// The notice of a method switch, a fusion or a Compare mode ("ACMH resumed at step
    /// ...") is stale once the user moves the run.
    fn clear_switch_notice(&mut self) {
        if self
            .notice
            .as_ref()
            .is_some_and(|n| n.kind == NoticeKind::UntilMoved)
        {
            self.notice = None;
        }
    }

    /// A run reached its target: a notice about it ("re-running...", "replaying...") is now
    /// stale.
    fn end_of_run(&mut self) {
        self.replaying = false;
        if self
            .notice
            .as_ref()
            .is_some_and(|n| n.kind == NoticeKind::Running)
        {
            self.notice = None;
        }
    }

    /// Runs `n` steps now and waits for their results (scripts, screenshots, tests;
    /// natively: the window's own stepping never waits).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn run_steps_now(&mut self, n: usize) -> Result<(), SessionError> {
        for _ in 0..n {
            if self.session.as_ref().is_none_or(Session::is_finished) {
                break;
            }
            self.step_one()?;
        }
        self.settle_device()
    }

    /// Runs everything queued and waits for it (tests; natively).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn finish_now(&mut self) -> Result<(), SessionError> {
        while let Some(t) = self.target {
            if self.cursor() >= t {
                self.target = None;
                self.end_of_run();
                break;
            }
            self.step_one()?;
        }
        self.settle_device()?;
        while self.tick_comparison(Duration::from_secs(3600)) {
            self.settle_device()?;
        }
        self.settle_device()
    }

    /// Submits one step. With the inspector on, the state before and after it (and what the
    /// step read) are asked for in queue order and become a capture when they arrive.
    fn step_one(&mut self) -> Result<(), SessionError> {
        let Some(session) = &mut self.session else {
            return Ok(());
        };
        let index = session.cursor();
        let Some(&step) = session.schedule().get(index) else {
            return Ok(());
        };
        let capture = self.picked.is_some()
            && step.view == self.view
            && matches!(step.action, Action::Half { .. });
        // The prior planes where the pass weighs them: the prior-assisted pass, and the
        // geometric passes the prior holds in (Regions' `prior_region_hold`). Read before the
        // step, as the pass reads them: the end of a view's prior stage keeps only its
        // regions' planes.
        let weighs_prior = match step.stage {
            Stage::Planar => true,
            Stage::Geometric(g) => session.params().prior_holds_in(session.method(), g),
            _ => false,
        };
        let (before, prior) = if capture {
            (
                Some(session.request_maps(step.view)?),
                weighs_prior
                    .then(|| session.request_prior_planes(step.view))
                    .transpose()?,
            )
        } else {
            (None, None)
        };
        let started = Instant::now();
        session.step()?;
        let done: Arc<Mutex<Option<Instant>>> = Arc::default();
        let flag = done.clone();
        self.ctx.queue.on_submitted_work_done(move || {
            *flag.lock().unwrap_or_else(|e| e.into_inner()) = Some(Instant::now());
        });
        self.in_flight.push(InFlight { started, done });
        if step.view == self.view && step.action == Action::SupportPoints {
            // What the choice read, for the inspector (small: four maps of one view).
            self.pending_support = Some(PendingSupport {
                index,
                params: session.params().clone(),
                problem: session.problem_for(&step),
                inputs: session.request_support_inputs(step.view),
            });
        }
        if let (Some(before), Action::Half { color, .. }) = (before, step.action) {
            let problem = session.problem_for(&step);
            let source_depths = matches!(step.stage, Stage::Geometric(_))
                .then(|| session.request_source_depths(&problem));
            self.pending_captures.push(PendingCapture {
                color,
                index,
                step,
                params: session.params().clone(),
                method: session.method(),
                c_init: session.request_restorer_c_init(step.view),
                anchors: session.request_anchor_codes(step.view),
                regions: weighs_prior
                    .then(|| session.planar_mesh(step.view))
                    .flatten()
                    .and_then(|m| m.regions.clone()),
                after: session.request_maps(step.view)?,
                problem,
                before,
                source_depths,
                prior,
            });
        }
        self.version += 1;
        Ok(())
    }

    /// Forgets the captures (the maps they explain are gone: a rewind, another method,
    /// view or scene).
    fn clear_captures(&mut self) {
        self.clear_captures_from(0);
    }

    /// Forgets the captures of the steps from `cursor` on (a rewind to `cursor`): the
    /// support-point step's inputs stay when that step is before it (they are what it read).
    fn clear_captures_from(&mut self, cursor: usize) {
        self.captures = [None, None];
        if self.support.as_ref().is_some_and(|s| s.index >= cursor) {
            self.support = None;
        }
        if self
            .pending_support
            .as_ref()
            .is_some_and(|s| s.index >= cursor)
        {
            self.pending_support = None;
        }
    }

    /// Makes captures of those whose read-backs have all arrived.
    fn poll_captures(&mut self) {
        let ctx = self.ctx.clone();
        if let Some(p) = &mut self.pending_support
            && let Some(inputs) = p.inputs.take(&ctx)
        {
            let p = self.pending_support.take();
            match (inputs, p) {
                (Ok(Some(inputs)), Some(p)) => {
                    self.support = Some(SupportCapture {
                        index: p.index,
                        params: p.params,
                        problem: p.problem,
                        inputs,
                    });
                    self.version += 1;
                }
                (Err(e), _) => self.error = Some(e.to_string()),
                _ => {}
            }
        }
        let mut i = 0;
        while i < self.pending_captures.len() {
            let p = &self.pending_captures[i];
            let ready = p.before.is_ready(&ctx)
                && p.after.is_ready(&ctx)
                && p.c_init.is_ready(&ctx)
                && p.anchors.is_ready(&ctx)
                && p.source_depths.as_ref().is_none_or(|d| d.is_ready(&ctx))
                && p.prior.as_ref().is_none_or(|d| d.is_ready(&ctx));
            if !ready {
                i += 1;
                continue;
            }
            let mut p = self.pending_captures.remove(i);
            let made = (|| -> Result<Option<Capture>, SessionError> {
                let before = taken(p.before.take(&ctx))?;
                let after = taken(p.after.take(&ctx))?;
                let c_init = taken(p.c_init.take(&ctx))?;
                let anchors = taken(p.anchors.take(&ctx))?;
                let source_depths = match &mut p.source_depths {
                    Some(d) => Some(taken(d.take(&ctx))?),
                    None => None,
                };
                let prior = match &mut p.prior {
                    Some(d) => taken(d.take(&ctx))?,
                    None => None,
                };
                Ok(before.zip(after).map(|(before, after)| Capture {
                    index: p.index,
                    step: p.step,
                    params: p.params.clone(),
                    method: p.method,
                    problem: p.problem.clone(),
                    before: before.state,
                    after: after.state,
                    source_depths,
                    c_init,
                    prior,
                    anchors,
                    regions: p.regions.take(),
                }))
            })();
            match made {
                Ok(Some(c)) => {
                    self.captures[p.color as usize] = Some(c);
                    self.version += 1;
                }
                Ok(None) => {}
                Err(e) => self.error = Some(e.to_string()),
            }
        }
    }

    /// The shown view's maps as they stand, read back without waiting: `None` until they
    /// have arrived (asked for here whenever the maps or the view changed).
    pub fn current_maps(&mut self) -> Option<&ViewMaps> {
        let key = (self.version, self.view);
        if self
            .current
            .arrived
            .as_ref()
            .is_some_and(|(k, _)| *k == key)
        {
            return self.current.arrived.as_ref().and_then(|(_, m)| m.as_ref());
        }
        if self.current.asked.as_ref().is_none_or(|(k, _)| *k != key) {
            let session = self.session.as_ref()?;
            match session.request_maps(self.view) {
                Ok(p) => self.current.asked = Some((key, p)),
                Err(e) => {
                    self.error = Some(e.to_string());
                    return None;
                }
            }
        }
        let (k, pending) = self.current.asked.as_mut()?;
        match pending.take(&self.ctx)? {
            Ok(maps) => {
                let k = *k;
                self.current.asked = None;
                self.current.arrived = Some((k, maps));
            }
            Err(e) => {
                self.current.asked = None;
                self.error = Some(e.to_string());
            }
        }
        self.current.arrived.as_ref().and_then(|(_, m)| m.as_ref())
    }

    /// Changes parameters: the session rewinds to the first step they affect and runs back
    /// to where it stood.
    pub fn set_params(&mut self, params: Params) {
        if let Err(e) = params.validate() {
            self.error = Some(format!("parameters: {e}"));
            return;
        }
        self.params = params.clone();
        self.params_applied += 1;
        self.comparison = None;
        let Some(session) = &mut self.session else {
            return;
        };
        let old_schedule = session.schedule().to_vec();
        let stood_at = self.target.unwrap_or(session.cursor());
        match session.set_params(params) {
            Ok(inv) => {
                // Back to the same scale, stage, view and iteration, not the same step number
                // (the number of iterations may have changed the schedule).
                let resume_to = timeline::same_point(&old_schedule, stood_at, session.schedule());
                self.notice = Notice::running(format!(
                    "re-running from step {} of {}",
                    inv.from_step + 1,
                    session.schedule().len()
                ));
                self.clear_captures();
                self.version += 1;
                self.run_to(resume_to);
                if self.target.is_none() {
                    self.end_of_run();
                }
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// Switches method. The session left is kept (with its progress) and the one switched to
    /// resumes where it stood, brought up to the current parameters; only a method not run
    /// before on this scene starts from the beginning. The parameters become the new
    /// method's: what the user changed carries over, the rest are its defaults
    /// ([`Method::adopt`]; Regions turns its options on).
    pub fn set_method(&mut self, method: Method) {
        if method == self.method {
            return;
        }
        let left = self.method;
        self.params = method.adopt(&self.params, left);
        self.method = method;
        if let Some(mut s) = self.session.take() {
            // A parked session keeps its newest checkpoints within a quarter of the budget
            // (every stage of the demo scene's run): Back after switching back steps back
            // without replaying, and memory stays bounded however often the method is
            // switched (at most four parked sessions).
            s.set_checkpoint_budget(PARKED_CHECKPOINT_BUDGET);
            self.parked.insert(left, s);
        }
        let Some(mut session) = self.parked.remove(&method) else {
            self.notice = None;
            self.rebuild_session();
            return;
        };
        self.target = None;
        self.replaying = false;
        self.clear_captures();
        self.gpu_maps = None;
        self.version += 1;
        session.set_checkpoint_budget(crate::session::DEFAULT_CHECKPOINT_BUDGET);
        let stood_at = session.cursor();
        let mut resume_to = stood_at;
        if session.params() != &self.params {
            // Parameters changed meanwhile: re-run from the first step they affect back to
            // the same point.
            let old_schedule = session.schedule().to_vec();
            if let Err(e) = session.set_params(self.params.clone()) {
                self.error = Some(format!("cannot resume {method}: {e}"));
                self.rebuild_session();
                return;
            }
            resume_to = timeline::same_point(&old_schedule, stood_at, session.schedule());
        }
        self.last_step = Duration::ZERO;
        let notice = format!(
            "{method} resumed at step {resume_to} of {} with {} checkpoints (switching keeps each method's progress)",
            session.schedule().len(),
            session.checkpoint_count()
        );
        self.session = Some(session);
        self.run_to(resume_to);
        self.notice = Notice::until_moved(notice);
        self.set_cloud(Vec::new());
    }

    /// The chosen view's maps now, waiting for them (tests; the window uses
    /// [`Model::current_maps`]).
    pub fn maps(&self) -> Option<ViewMaps> {
        let session = self.session.as_ref()?;
        session.maps(self.view).ok().flatten()
    }

    /// The chosen view's maps as GPU buffers (cached per version).
    pub fn gpu_maps(&mut self) -> Result<Option<GpuMaps>, SessionError> {
        if let Some((v, view, maps)) = &self.gpu_maps
            && *v == self.version
            && *view == self.view
        {
            return Ok(Some(maps.clone()));
        }
        let Some(session) = &self.session else {
            return Ok(None);
        };
        let maps = session.gpu_maps(self.view)?;
        if let Some(m) = &maps {
            self.gpu_maps = Some((self.version, self.view, m.clone()));
        }
        Ok(maps)
    }

    /// The chosen view's image as packed RGBA at `width` x `height` (a pyramid level).
    pub fn image_buffer(&mut self, view: usize, width: u32, height: u32) -> Option<wgpu::Buffer> {
        let key = (view, width, height);
        if let Some(b) = self.images.get(&key) {
            return Some(b.clone());
        }
        let image = &self.loaded.as_ref()?.scene.views.get(view)?.image;
        let image = if (image.width, image.height) == (width, height) {
            image.clone()
        } else {
            image.resized(width, height)
        };
        let buffer = self.ctx.storage_buffer("map image", &pack_rgba(&image));
        self.images.insert(key, buffer.clone());
        Some(buffer)
    }

    /// Ground-truth depth of `view` at `width` x `height` on the GPU, if the scene has it.
    pub fn truth_buffer(&mut self, view: usize, width: u32, height: u32) -> Option<wgpu::Buffer> {
        let key = (view, width, height);
        if let Some(b) = self.truths.get(&key) {
            return b.clone();
        }
        let buffer = self
            .loaded
            .as_ref()
            .and_then(|l| l.ground_truth.get(view)?.as_ref())
            .map(|gt| {
                self.ctx
                    .storage_buffer("ground truth", &gt.resampled(width, height))
            });
        self.truths.insert(key, buffer.clone());
        buffer
    }

    /// How many sources agree with each pixel of `view` (as f32, for the map view), when the
    /// maps shown are the ones last fused and the size is theirs.
    pub fn confidence_buffer(&self, view: usize, width: u32, height: u32) -> Option<wgpu::Buffer> {
        let floats = self.confidence_at(view, width, height)?;
        Some(self.ctx.storage_buffer("confidence", &floats))
    }

    /// Each pixel's distance to texture for `view` at `width` x `height` (the image as the
    /// Image map shows it at that scale), under the run's window radius.
    pub fn texture_reach_at(&self, view: usize, width: u32, height: u32) -> Option<Vec<f32>> {
        let image = &self.loaded.as_ref()?.scene.views.get(view)?.image;
        let image = if (image.width, image.height) == (width, height) {
            image.clone()
        } else {
            image.resized(width, height)
        };
        Some(crate::viewer::maps::texture_reach(
            &image,
            self.params.window_radius,
        ))
    }

    /// [`Model::texture_reach_at`] on the GPU, for the map view.
    pub fn texture_reach_buffer(
        &self,
        view: usize,
        width: u32,
        height: u32,
    ) -> Option<wgpu::Buffer> {
        let floats = self.texture_reach_at(view, width, height)?;
        Some(self.ctx.storage_buffer("texture reach", &floats))
    }

    /// [`Model::confidence_buffer`]'s values (CPU).
    pub fn confidence_at(&self, view: usize, width: u32, height: u32) -> Option<Vec<f32>> {
        let fused = self.confidence.as_ref()?;
        let counts = fused.counts.get(view)?;
        if fused.version != self.version || counts.len() != width as usize * height as usize {
            return None;
        }
        Some(counts.iter().map(|&c| f32::from(c)).collect())
    }

    /// Which fusion the 3D view and the confidence map show (changes with every new cloud).
    pub fn cloud_version(&self) -> u64 {
        self.cloud_version
    }

    /// Ground truth of the chosen view at `width` x `height` (CPU).
    pub fn truth(&self, view: usize, width: u32, height: u32) -> Option<Vec<f32>> {
        let gt = self.loaded.as_ref()?.ground_truth.get(view)?.as_ref()?;
        Some(gt.resampled(width, height))
    }

    /// The chosen view's ground truth at `width` x `height`, where known.
    pub fn truth_at(&self, width: u32, height: u32) -> Option<Vec<f32>> {
        let gt = self
            .loaded
            .as_ref()?
            .ground_truth
            .get(self.view)?
            .as_ref()?;
        Some(gt.resampled(width, height))
    }
}
