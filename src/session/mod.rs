//! A steppable run of DWTA, ACMH, ACMM, ACMP or ACMMP over a scene (or a part of one).
//!
//! The [`Session`] owns an explicit schedule of labelled [`Step`]s — scale, stage, view,
//! iteration, red or black half, plus the upsample, init, median, restore, measure and planar
//! prior steps — that a UI shows as a timeline. It runs them one at a time (or to a target),
//! keeps every view's maps on the device, checkpoints after each view's unit of work (within a
//! budget) so it can step back or re-run after a parameter change, and exposes any view's maps
//! as CPU arrays or GPU buffers. A batch run ([`Session::set_batch`]) keeps no checkpoints and
//! interleaves each stage's views; [`Session::run_batches`] submits them together and reports
//! each submission.
//!
//! **Which depth maps a geometric pass reads.** Every stage works from a snapshot: the maps
//! all views had when the previous stage ended. A geometric pass of view v reads its sources'
//! depth maps from that snapshot, never from a view updated earlier in the same stage, so the
//! result does not depend on the order views are processed in. A stage's results become the
//! snapshot only when all its views are done.
//!
//! ACMP and ACMMP add the planar prior's stage after the first stage of each scale (support
//! points, triangulation, prior planes, the prior-assisted pass; ACMP-REFERENCE.md §1).
//!
//! Stages per scale (paper Sec. 5): at the coarsest scale, photometric ACMH, then
//! `geometric_passes` geometric consistency passes; at each finer scale, the detail restorer
//! stage (joint bilateral upsampling of the coarser maps, then the basic model started from
//! the upsampled planes: by default `refine`, which refines them with C_init kept; `gated`
//! also gates every update by C_init − ξ; `random` starts from random planes and replaces
//! where C_init − C_photo > ξ), then the geometric passes. ACMH and DWTA are one photometric
//! stage at the input scale.
//!
//! Submodules: `schedule` (the steps), `checkpoints`, `planar` (the prior's steps),
//! `pending` (values on their way from the device), `readback` (reading maps back),
//! `handoff` (a stage's state handed to another session: cluster units).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::acmm::cpu::MAX_COST;
use crate::acmm::multiscale::pyramid_scales;
use crate::acmm::params::{Method, Params, RestorerMode};
use crate::acmm::planar::{
    PriorMesh, PriorOracle, PriorTerms, apply_oracle, credible, triangulate,
};
use crate::acmm::problem::{NO_VIEW, ViewProblem, ViewState};
use crate::acmm::pyramid_depth::{self, TextureDepth};
use crate::gpu::acmh::{AcmhPipelines, DeviceCopy, GpuViewSolver, LevelImages, PassKind};
use crate::gpu::planar::PlanarBuffers;
use crate::gpu::{GpuContext, GpuError};
use crate::scene::Scene;

mod batches;
mod checkpoints;
mod handoff;
mod pending;
mod planar;
mod readback;
mod schedule;

pub use batches::{DecodeView, SessionOptions};
use batches::{GrayCache, HostStore, gray_of};
use checkpoints::*;
pub use handoff::HandoffView;
pub use pending::*;
use planar::*;
pub use schedule::*;

/// Everything a view has at a point of the run.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewMaps {
    pub level: u32,
    pub state: ViewState,
    /// C_init − C_photo of the detail restorer (restorer stages).
    pub restorer_difference: Option<Vec<f32>>,
    /// Pixels the detail restorer replaced.
    pub replaced: Option<Vec<bool>>,
    /// Mean forward-backward reprojection error over the sources (geometric stages).
    pub reprojection_error: Option<Vec<f32>>,
    /// The planar prior's planes at this level (ACMP, ACMMP, once built).
    pub prior: Option<Vec<[f32; 4]>>,
    /// Each pixel's anchor code (`prior_anchors`, as f32, from the prior planes' step on at
    /// this level; the restorer's difference is then gone).
    pub anchors: Option<Vec<f32>>,
    /// The prior score's constants for this view (with `prior`).
    pub prior_terms: Option<PriorTerms>,
    /// The prior's support points (x, y) (with `prior`).
    pub support_points: Option<Vec<[f32; 2]>>,
}

impl ViewMaps {
    /// Maps with no estimate anywhere: a view that cannot be estimated (no sources), or one
    /// the run has not reached yet. No depth, no winner, no most important view.
    pub fn empty(level: u32, width: u32, height: u32) -> ViewMaps {
        let n = width as usize * height as usize;
        ViewMaps {
            level,
            state: ViewState {
                width,
                height,
                num_sources: 0,
                plane: vec![[0.0, 0.0, -1.0, 0.0]; n],
                cost: vec![MAX_COST; n],
                selected: vec![0; n],
                weights: Vec::new(),
                aux: vec![0xff | (NO_VIEW << 8); n],
            },
            restorer_difference: None,
            replaced: None,
            reprojection_error: None,
            prior: None,
            anchors: None,
            prior_terms: None,
            support_points: None,
        }
    }
}

/// What a run keeps of a view: its planes (normal xyz, depth w) and costs.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanesCosts {
    /// Pyramid level of the maps (0 = coarsest).
    pub level: u32,
    pub width: u32,
    pub height: u32,
    pub plane: Vec<[f32; 4]>,
    pub cost: Vec<f32>,
}

/// A view's maps on the GPU, laid out as the passes write them (see
/// shaders/shared/problem.wgsl): planes (normal xyz, depth w), costs, selection bits, weights
/// (`num_sources` per pixel), aux (winner, v_t, replaced bit) and the two extra maps.
#[derive(Clone, Debug)]
pub struct GpuMaps {
    pub width: u32,
    pub height: u32,
    pub num_sources: usize,
    pub plane: wgpu::Buffer,
    pub cost: wgpu::Buffer,
    /// The selected-view masks: `n` words from byte `selected_offset` (a binding offset) of
    /// `selected` (the solver's aux buffer, or a buffer of their own).
    pub selected: wgpu::Buffer,
    pub selected_offset: u64,
    /// A layer per source (at least one).
    pub weights: wgpu::Texture,
    /// [0, n): winner, v_t and flags.
    pub aux: wgpu::Buffer,
    /// [0, n) restorer difference, [n, 2n) reprojection error.
    pub extra: wgpu::Buffer,
    /// The planar prior's planes (zeros, i.e. no prior anywhere, before it is built).
    pub prior: wgpu::Buffer,
    pub prior_terms: Option<PriorTerms>,
    /// The buffers the passes are writing right now.
    pub live: bool,
}

impl GpuMaps {
    /// Stored maps uploaded in the passes' layout (weights of a view without sources: one 0;
    /// extra maps absent: 0).
    pub fn upload(ctx: &GpuContext, maps: &ViewMaps) -> GpuMaps {
        let st = &maps.state;
        let n = st.plane.len();
        let mut extra = vec![0.0f32; 2 * n];
        if let Some(d) = maps.restorer_difference.as_ref().or(maps.anchors.as_ref()) {
            extra[..n].copy_from_slice(d);
        }
        if let Some(e) = &maps.reprojection_error {
            extra[n..].copy_from_slice(e);
        }
        let weights = ctx.r32_layers("weights", st.width, st.height, st.num_sources as u32);
        let layers = crate::gpu::acmh::weights_to_layers(&st.weights, n, st.num_sources);
        ctx.write_layers(
            &weights,
            0,
            (st.width, st.height, st.num_sources as u32),
            bytemuck::cast_slice(&layers),
        );
        GpuMaps {
            width: st.width,
            height: st.height,
            num_sources: st.num_sources,
            plane: ctx.storage_buffer("plane", &st.plane),
            cost: ctx.storage_buffer("cost", &st.cost),
            selected: ctx.storage_buffer("selected", &st.selected),
            selected_offset: 0,
            weights,
            aux: ctx.storage_buffer("aux", &st.aux),
            extra: ctx.storage_buffer("extra", &extra),
            prior: match &maps.prior {
                Some(p) => ctx.storage_buffer("prior", p),
                None => ctx.zeroed_storage("prior", n as u64 * 16),
            },
            prior_terms: maps.prior_terms,
            live: false,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("parameter {0}")]
    Params(String),
    /// The run would not fit the device (see `crate::acmm::memory`).
    #[error("the run does not fit this device: {0}")]
    Memory(String),
    /// A step found what it works on missing (a bug, or a schedule run out of order).
    #[error("{0}")]
    State(String),
}

/// What a view's maps hold besides its state.
#[derive(Clone, Debug, Default)]
struct Marks {
    /// extra[0, n) holds the detail restorer's difference (set by its restore step, kept
    /// through the level's later stages).
    difference: bool,
    /// aux as the restore step left it (bit 16: replaced), copied on the device.
    replaced: Option<wgpu::Buffer>,
    /// extra[n, 2n) holds the mean reprojection error (the view's last unit was geometric).
    reprojection: bool,
    /// extra[0, n) holds the anchor codes (`prior_anchors`: the prior planes' step wrote
    /// them over the restorer's difference).
    anchors: bool,
    /// The planar prior built at this level: its triangulation and a device copy of the
    /// prior planes (the `prior` buffer holds them until the next level's upsampling).
    planar: Option<Arc<PlanarSnapshot>>,
    /// With `prior_region_choice`: the support points of the restorer's result at this
    /// level, read at the start of its first geometric pass, for the prior stage's earlier
    /// fit (handed off and checkpointed with the view).
    earlier: Option<Arc<Vec<crate::acmm::planar::SupportRecord>>>,
}

/// A view's planar prior read back: its level, triangulation and per-pixel prior planes.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarPriorMaps {
    pub level: u32,
    pub mesh: PriorMesh,
    /// Normal xyz, depth w (≤ 0: no prior; `crate::acmm::planar::no_prior_reason`).
    pub prior: Vec<[f32; 4]>,
}

/// A view's planar prior at a level (ACMP, ACMMP).
#[derive(Debug)]
pub struct PlanarSnapshot {
    /// The support points and their triangulation.
    pub mesh: PriorMesh,
    /// Every pixel's prior plane (normal, depth; depth ≤ 0: none), on the device.
    prior: wgpu::Buffer,
}

/// A view's state on the device: its solver (buffers and bind groups) at a level. It lives
/// from the view's first unit at the level to its upsampling into the next one.
struct Resident {
    level: u32,
    solver: GpuViewSolver,
    marks: Marks,
    /// The planar prior's buffers (made at the view's first support-point step).
    planar: Option<PlanarBuffers>,
    /// The support points on their way back, between the support-point and triangulate
    /// steps (the viewer steps on only once they have arrived: nothing waits).
    points: Option<crate::gpu::Readback>,
    /// The triangulation between its triangulate and prior-plane steps.
    mesh: Option<PriorMesh>,
    /// Its `prior` holds the coarse level's planes, put there when its state came back from
    /// the host: the upsampling reads them (no coarse buffers to copy from).
    upsample_ready: bool,
}

/// One submission of [`Session::run_batches`].
#[derive(Clone, Debug)]
pub struct Batch {
    /// Its first step.
    pub first: Step,
    /// The indices of the steps it ran.
    pub ran: std::ops::Range<usize>,
    /// Whether it ended its stage (every view's part of it).
    pub stage_ended: bool,
}

/// How a parameter change rewound the session.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Invalidation {
    /// The first step whose result changes; the session now stands there.
    pub from_step: usize,
    /// Where it stood before.
    pub previous_cursor: usize,
}

/// A run of one method over one scene, step by step.
pub struct Session {
    ctx: GpuContext,
    pipelines: Arc<AcmhPipelines>,
    params: Params,
    method: Method,
    /// What the images said about the pyramid's depth (`params.scales_by_texture`), measured
    /// once per session: the scene does not change, only the parameters that turn its reach
    /// into a number of scales.
    texture: Option<TextureDepth>,
    /// The scene at each pyramid level, coarsest first.
    levels: Vec<Scene>,
    /// Views that have sources (the others get empty maps).
    estimated: Vec<usize>,
    steps: Vec<Step>,
    cursor: usize,
    /// The current level's images and depth snapshot on the device.
    level_images: Option<(u32, LevelImages)>,
    /// Each view's state on the device (`None` before its first unit).
    residents: Vec<Option<Resident>>,
    /// The level of the last stage that ended (`None` before the first).
    committed_level: Option<u32>,
    /// The step of the unit in progress (its view's buffers are being written).
    active: Option<Step>,
    checkpoints: Vec<Checkpoint>,
    keep_checkpoints: bool,
    /// The most bytes the checkpoints may hold; the oldest go first.
    checkpoint_budget: u64,
    /// Views whose maps changed since the newest checkpoint (the others share its copies).
    changed: Vec<bool>,
    /// Whether the schedule is [`interleave`]d (batch runs) rather than view by view.
    interleaved: bool,
    /// Each view's number in the random numbers' key (its index in the whole scene).
    keys: Vec<u32>,
    /// Each level's problem headers, view by view (cameras, sources, the widened depth
    /// range, the key): built once, and again when the parameters change.
    headers: Vec<Vec<ViewProblem>>,
    /// Support points from the ground truth, a diagnosis ([`Session::set_prior_oracle`]).
    oracle: Option<(PriorOracle, Arc<Vec<Option<TruthDepth>>>)>,
    /// With a Select or Filter oracle and anchors: the share (percent) of the real test's
    /// false positives the anchors may also sit on ([`Session::set_oracle_admit`]).
    oracle_admit: u32,
    /// How the views are held on the device: all at once, or each stage in batches.
    plan: crate::acmm::memory::BatchPlan,
    /// Each estimated view's batch.
    batch_of: Vec<Option<usize>>,
    /// The batch on the device, and the level and stage (index in `stage_order`) it was
    /// loaded for.
    loaded: Option<(usize, u32, usize)>,
    /// The states of the views off the device (batches), and the work folder.
    store: HostStore,
    /// The schedule's stages in order, as (level, stage).
    stage_order: Vec<(u32, Stage)>,
    /// Where images come from when the scene holds no pixels (`SessionOptions::images`).
    decode: Option<DecodeView>,
    /// Decoded intensities kept between batches.
    grays: GrayCache,
    /// What the session was made with (a rebuild after a new pyramid keeps them).
    options: SessionOptions,
}

/// A view's true depth at any size (0 where unknown): what a [`PriorOracle`] judges by, sampled
/// at each level's size where it is used (as the accuracy scores sample it).
#[derive(Clone, Debug, PartialEq)]
pub struct TruthDepth {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
}

/// Where a part of a scene sits in the whole (see [`Session::for_part`]).
#[derive(Clone, Debug)]
pub struct Part {
    /// Each view's index in the whole scene.
    pub indices: Vec<usize>,
    /// The longest image side of the whole scene (it sets the number of scales).
    pub long_side: u32,
}

/// What a view's support-point step read ([`Session::request_support_inputs`]).
#[derive(Clone, Debug)]
pub struct SupportInputs {
    pub step: Step,
    pub level: u32,
    pub plane: Vec<[f32; 4]>,
    pub cost: Vec<f32>,
    /// The multi-view check's least errors, or the confirmation keys
    /// (`prior_confirmed_points`); `None` without the check.
    pub keys: Option<Vec<f32>>,
    /// Each window's intensity spread (`prior_flat_points`, `prior_regions`).
    pub spread: Option<Vec<f32>>,
}

/// Checkpoint memory a session allows by default: enough for every stage of the demo scene
/// and of moderate scenes, bounded for big ones (oldest dropped first).
pub const DEFAULT_CHECKPOINT_BUDGET: u64 = 512 << 20;

impl Session {
    /// A session over `scene` with its own compiled pipelines.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        params: Params,
        method: Method,
    ) -> Result<Session, SessionError> {
        let pipelines = Arc::new(AcmhPipelines::new(ctx)?);
        Self::with_pipelines(ctx, pipelines, scene, params, method)
    }

    /// A session sharing already compiled pipelines (a UI comparing methods).
    pub fn with_pipelines(
        ctx: &GpuContext,
        pipelines: Arc<AcmhPipelines>,
        scene: &Scene,
        params: Params,
        method: Method,
    ) -> Result<Session, SessionError> {
        Self::build(
            ctx,
            pipelines,
            scene,
            params,
            method,
            SessionOptions::default(),
        )
    }

    /// How a session over `scene` with `options` would hold it on `ctx`'s device: every
    /// view at once, or batches (known before anything is allocated or decoded: the scene
    /// needs its sizes and sources only). The error names a view that alone does not fit,
    /// what it needs, and the `--max-image-size` that would.
    pub fn plan(
        ctx: &GpuContext,
        scene: &Scene,
        params: &Params,
        method: Method,
        options: &SessionOptions,
    ) -> Result<crate::acmm::memory::BatchPlan, SessionError> {
        use crate::acmm::memory::{self, BatchPlan, Limits, ViewShape};
        let shapes = ViewShape::of_scene(scene);
        let budget = options
            .device_budget
            .or_else(|| memory::default_budget(None, ctx.is_software()));
        let limits = Limits {
            adapter: &ctx.limits,
            budget,
        };
        let plan = BatchPlan::new(&shapes, params, method, long_side(scene, options), &limits)
            .map_err(|e| {
                let fit = memory::largest_fitting_size(&shapes, params, method, &limits);
                SessionError::Memory(match fit {
                    Some(side) => format!(
                        "{e}; --max-image-size {side} would fit (the largest that does){}",
                        if budget.is_some() {
                            " or a larger --device-memory"
                        } else {
                            ""
                        }
                    ),
                    None => format!("{e}; use fewer source views"),
                })
            })?;
        Ok(match options.max_batch {
            Some(k) if plan.batches.concat().len() > k => plan.split(k),
            _ => plan,
        })
    }

    /// A session with `options`: a device budget, batches, images decoded on demand.
    pub fn with_options(
        ctx: &GpuContext,
        pipelines: Arc<AcmhPipelines>,
        scene: &Scene,
        params: Params,
        method: Method,
        options: SessionOptions,
    ) -> Result<Session, SessionError> {
        Self::build(ctx, pipelines, scene, params, method, options)
    }

    /// A session over part of a scene (`part`, e.g. `Scene::subset` of a cluster task's
    /// views and their sources) that computes what the whole scene's session computes for
    /// those views: its views draw the random numbers of their `whole` indices, and its
    /// pyramid has the whole scene's scales (from the whole scene's longest image side).
    pub fn for_part(
        ctx: &GpuContext,
        pipelines: Arc<AcmhPipelines>,
        part: &Scene,
        whole: Part,
        params: Params,
        method: Method,
    ) -> Result<Session, SessionError> {
        if whole.indices.len() != part.views.len() {
            return Err(SessionError::Params(format!(
                "a part of {} views given {} indices in the whole scene",
                part.views.len(),
                whole.indices.len()
            )));
        }
        let options = SessionOptions {
            part: Some(whole),
            ..SessionOptions::default()
        };
        Self::build(ctx, pipelines, part, params, method, options)
    }

    fn build(
        ctx: &GpuContext,
        pipelines: Arc<AcmhPipelines>,
        scene: &Scene,
        params: Params,
        method: Method,
        options: SessionOptions,
    ) -> Result<Session, SessionError> {
        params.validate().map_err(SessionError::Params)?;
        // The pyramid's depth from the images' texture, where they are at hand (a caller that
        // loaded sizes only, as `mvscope run` in batches or a cluster task, resolved it first).
        // The parameters as given: a method's own settings are its defaults
        // (`Method::defaults`), which the caller started from or changed.
        let mut params = params;
        let texture = if method.deepens_pyramid(&params)
            && options.part.is_none()
            && pyramid_depth::sample_decoded(scene)
        {
            pyramid_depth::resolve(&mut params, method, scene).map_err(SessionError::Params)?
        } else {
            None
        };
        // Before anything is allocated: every view at once, or batches that fit?
        let plan = Self::plan(ctx, scene, &params, method, &options)?;
        let budget = plan.budget;
        let long_side = long_side(scene, &options);
        let scales = pyramid_scales(&params, method, long_side);
        let levels: Vec<Scene> = scales
            .iter()
            .map(|&s| {
                if (s - 1.0).abs() < 1e-12 {
                    scene.clone()
                } else {
                    scene.rescaled(s)
                }
            })
            .collect();
        let n = scene.views.len();
        let mut batch_of = vec![None; n];
        for (b, views) in plan.batches.iter().enumerate() {
            for &v in views {
                batch_of[v] = Some(b);
            }
        }
        // Batch by batch within a stage (one batch: the scene's order).
        let estimated: Vec<usize> = plan.batches.concat();
        let steps = build_schedule(method, &params, &estimated, levels.len() as u32);
        let keys: Vec<u32> = match &options.part {
            Some(w) => w.indices.iter().map(|&i| i as u32).collect(),
            None => (0..n as u32).collect(),
        };
        let headers = problem_headers(&levels, &keys, &params);
        let stage_order = stage_order(method, &params, levels.len() as u32);
        // Decoded intensities kept between batches: a quarter of the budget, at least 256 MiB.
        let grays = GrayCache::new(budget.map_or(1 << 30, |b| (b / 4).max(256 << 20)));
        Ok(Session {
            keys,
            headers,
            ctx: ctx.clone(),
            pipelines,
            params,
            texture,
            method,
            levels,
            estimated,
            steps,
            cursor: 0,
            level_images: None,
            residents: (0..n).map(|_| None).collect(),
            committed_level: None,
            active: None,
            checkpoints: vec![Checkpoint::start(n)],
            keep_checkpoints: true,
            checkpoint_budget: DEFAULT_CHECKPOINT_BUDGET,
            changed: vec![false; n],
            interleaved: false,
            oracle: None,
            oracle_admit: 0,
            plan,
            batch_of,
            loaded: None,
            store: HostStore::new(n),
            stage_order,
            decode: options.images.clone(),
            grays,
            options,
        })
    }

    /// Takes the planar prior's support points from the ground truth (one entry per view of
    /// this session's scene, at any size) instead of the estimate: a diagnosis of what the
    /// prior would do with right points ([`PriorOracle`]); `None` turns it off. Only before
    /// the first step.
    pub fn set_prior_oracle(
        &mut self,
        oracle: Option<(PriorOracle, Vec<Option<TruthDepth>>)>,
    ) -> Result<(), SessionError> {
        if self.cursor != 0 {
            return Err(SessionError::Params(
                "support points from the truth: only before the first step".into(),
            ));
        }
        if let Some((_, truth)) = &oracle
            && truth.len() != self.residents.len()
        {
            return Err(SessionError::Params(format!(
                "support points from the truth: {} truth maps for {} views",
                truth.len(),
                self.residents.len()
            )));
        }
        self.oracle = oracle.map(|(o, t)| (o, Arc::new(t)));
        Ok(())
    }

    /// With a `select` or `filter` oracle and `prior_anchors`: the anchors may also sit on
    /// `percent` in 100 of the wrong pixels the real test of strong pixels passes
    /// ([`crate::acmm::planar::oracle_errors_admitting`]), so a run says how precise that
    /// test must be. Only before the first step; at most 100.
    pub fn set_oracle_admit(&mut self, percent: u32) -> Result<(), SessionError> {
        if self.cursor != 0 {
            return Err(SessionError::Params(
                "the oracle's false positives: only before the first step".into(),
            ));
        }
        if percent > 100 {
            return Err(SessionError::Params(format!(
                "the oracle's false positives: {percent}% is not a share (0 to 100)"
            )));
        }
        self.oracle_admit = percent;
        Ok(())
    }

    /// Runs each stage's views interleaved ([`interleave`]; only before the first step), so
    /// [`Session::step_views`] submits one action of all the stage's views together. The
    /// maps are the same as view by view, which tests check; a viewer stepping through a
    /// run keeps the view-by-view order, which is the one a user follows.
    pub fn set_interleaved(&mut self, on: bool) -> Result<(), SessionError> {
        if self.cursor != 0 {
            return Err(SessionError::Params(
                "interleaved order: only before the first step".into(),
            ));
        }
        self.interleaved = on;
        self.steps = self.schedule_for(&self.params, &self.estimated);
        Ok(())
    }

    /// The schedule over `views` in this session's order.
    fn schedule_for(&self, params: &Params, views: &[usize]) -> Vec<Step> {
        let steps = build_schedule(self.method, params, views, self.levels.len() as u32);
        if self.interleaved {
            interleave_by(&steps, &|v| {
                self.batch_of.get(v).copied().flatten().unwrap_or(0)
            })
        } else {
            steps
        }
    }

    /// Keep only the checkpoint needed to resume (saves memory in batch runs); stepping back
    /// then replays from the start.
    /// A batch run (`run`, a cluster unit, the benches, the accuracy suite): no checkpoints,
    /// and each stage's views interleaved (only before the first step).
    pub fn set_batch(&mut self) -> Result<(), SessionError> {
        self.set_keep_checkpoints(false);
        self.set_interleaved(true)
    }

    pub fn set_keep_checkpoints(&mut self, keep: bool) {
        self.keep_checkpoints = keep;
    }

    /// What the images said about the pyramid's depth, when `scales_by_texture` decided it.
    pub fn texture_depth(&self) -> Option<&TextureDepth> {
        self.texture.as_ref()
    }

    pub fn params(&self) -> &Params {
        &self.params
    }

    pub fn method(&self) -> Method {
        self.method
    }

    pub fn schedule(&self) -> &[Step] {
        &self.steps
    }

    /// Index of the next step to run (== schedule length when finished).
    pub fn cursor(&self) -> usize {
        self.cursor
    }

    pub fn is_finished(&self) -> bool {
        self.cursor >= self.steps.len()
    }

    /// The scene at pyramid level `level` (0 = coarsest).
    pub fn level_scene(&self, level: u32) -> &Scene {
        &self.levels[level as usize]
    }

    pub fn num_levels(&self) -> u32 {
        self.levels.len() as u32
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The view being processed and its live GPU buffers, if a stage is mid-view.
    pub fn active_gpu(&self) -> Option<(Step, &GpuViewSolver)> {
        let step = self.active?;
        let resident = self.residents.get(step.view)?.as_ref()?;
        Some((step, &resident.solver))
    }

    /// Whether the next step can run without waiting for the device: false only while a
    /// read-back it needs is on its way (the planar prior's support points before their
    /// triangulation). A viewer steps when this is true and tries again in a later frame;
    /// [`Session::step`] itself waits natively.
    pub fn next_step_ready(&self) -> bool {
        let Some(step) = self.steps.get(self.cursor) else {
            return true;
        };
        if step.action != Action::Triangulate {
            return true;
        }
        self.ctx.poll();
        self.residents
            .get(step.view)
            .and_then(Option::as_ref)
            .and_then(|r| r.points.as_ref())
            .is_none_or(|p| p.flag().is_set())
    }

    /// Runs the next step. Returns false when the schedule is finished.
    pub fn step(&mut self) -> Result<bool, SessionError> {
        if self.is_finished() {
            return Ok(false);
        }
        let step = self.steps[self.cursor];
        self.execute(step)?;
        self.cursor += 1;
        self.after_step(step)?;
        Ok(true)
    }

    /// Runs the next step and, in an interleaved schedule, the steps after it that do the same
    /// action for the stage's other views, at most up to `limit` steps run, as one
    /// submission: a GPU may run those views' passes side by side (they read and write
    /// different buffers, so no barrier separates them). Returns the indices of the steps
    /// run (empty when the schedule is finished).
    pub fn step_views(&mut self, limit: usize) -> Result<std::ops::Range<usize>, SessionError> {
        let start = self.cursor;
        let limit = limit.min(self.steps.len());
        if start >= limit {
            return Ok(start..start);
        }
        let first = self.steps[start];
        let mut end = start + 1;
        if self.interleaved {
            while end < limit {
                let s = self.steps[end];
                let same_action =
                    (s.level, s.stage, s.action) == (first.level, first.stage, first.action);
                if !same_action || self.steps[start..end].iter().any(|p| p.view == s.view) {
                    break;
                }
                end += 1;
            }
        }
        if end - start == 1 {
            self.step()?;
            return Ok(start..self.cursor);
        }
        self.ctx.begin_batch();
        let result = (start..end).try_for_each(|_| self.step().map(|_| ()));
        self.ctx.end_batch();
        result?;
        Ok(start..self.cursor)
    }

    /// Runs until `target` steps have run (or the end), checking `cancel` between submissions
    /// and telling `progress` (step, index, total) before each: a step, or in an interleaved
    /// schedule the first of the steps [`Session::step_views`] runs together. Returns whether
    /// it got there.
    pub fn run_until(
        &mut self,
        target: usize,
        cancel: Option<&AtomicBool>,
        progress: &mut dyn FnMut(&Step, usize, usize),
    ) -> Result<bool, SessionError> {
        let target = target.min(self.steps.len());
        while self.cursor < target {
            if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return Ok(false);
            }
            progress(&self.steps[self.cursor], self.cursor, self.steps.len());
            self.step_views(target)?;
        }
        Ok(true)
    }

    /// Runs every remaining step as [`Session::step_views`] submits them, telling `before`
    /// the first step of each submission (with its index and the schedule's length; an error
    /// stops the run, e.g. a cancellation) and `after` what ran: where a batch run writes the
    /// views it finished, scores or times a stage.
    pub fn run_batches<E: From<SessionError>>(
        &mut self,
        mut before: impl FnMut(&Step, usize, usize) -> Result<(), E>,
        mut after: impl FnMut(&Session, Batch) -> Result<(), E>,
    ) -> Result<(), E> {
        let total = self.steps.len();
        while !self.is_finished() {
            let first = self.steps[self.cursor];
            before(&first, self.cursor, total)?;
            let ran = self.step_views(total)?;
            let next = self.steps.get(self.cursor).copied();
            let stage_ended = next.is_none_or(|n| (n.level, n.stage) != (first.level, first.stage));
            after(
                self,
                Batch {
                    first,
                    ran,
                    stage_ended,
                },
            )?;
        }
        Ok(())
    }

    /// Runs every remaining step.
    pub fn run_to_end(&mut self) -> Result<(), SessionError> {
        self.run_until(self.steps.len(), None, &mut |_, _, _| {})?;
        Ok(())
    }

    /// Moves to `target` (steps run): forward by running, backward from the latest
    /// checkpoint at or before it, replaying the steps in between.
    pub fn goto(&mut self, target: usize) -> Result<(), SessionError> {
        let target = target.min(self.steps.len());
        self.rewind(target);
        self.run_until(target, None, &mut |_, _, _| {})?;
        Ok(())
    }

    /// Moves back to the latest checkpoint at or before `target` without replaying, and
    /// returns the cursor there: a UI then runs forward to `target` a few steps per frame.
    pub fn rewind(&mut self, target: usize) -> usize {
        let target = target.min(self.steps.len());
        if target < self.cursor {
            let cp = self
                .checkpoints
                .iter()
                .rev()
                .find(|c| c.cursor <= target)
                .cloned()
                .unwrap_or(Checkpoint::start(self.residents.len()));
            self.restore(cp);
        }
        self.cursor
    }

    /// One step back.
    pub fn step_back(&mut self) -> Result<(), SessionError> {
        self.goto(self.cursor.saturating_sub(1))
    }

    /// Back to the start.
    pub fn reset(&mut self) {
        self.restore(Checkpoint::start(self.residents.len()));
    }

    /// The first step a change from `old` to `new` affects (in a schedule both share).
    fn first_affected(&self, old: &Params, new: &Params) -> usize {
        // Everything but the values only some steps read, and the structure (handled by
        // comparing schedules): a change here alters every pass.
        let everything = Params {
            median_radius: old.median_radius,
            median_every_pass: old.median_every_pass,
            jbu_radius: old.jbu_radius,
            jbu_sigma_spatial: old.jbu_sigma_spatial,
            jbu_sigma_range: old.jbu_sigma_range,
            xi: old.xi,
            lambda: old.lambda,
            delta: old.delta,
            iterations: old.iterations,
            coarse_iterations: old.coarse_iterations,
            restorer_iterations: old.restorer_iterations,
            restorer: old.restorer,
            geometric_iterations: old.geometric_iterations,
            geometric_passes: old.geometric_passes,
            fusion_reprojection: old.fusion_reprojection,
            fusion_relative_depth: old.fusion_relative_depth,
            fusion_normal_angle: old.fusion_normal_angle,
            fusion_min_views: old.fusion_min_views,
            prior_cell: old.prior_cell,
            prior_cost_threshold: old.prior_cost_threshold,
            prior_triangle_normal: old.prior_triangle_normal,
            prior_consistency: old.prior_consistency,
            prior_gamma: old.prior_gamma,
            prior_beta: old.prior_beta,
            prior_sigma_depth: old.prior_sigma_depth,
            prior_sigma_normal: old.prior_sigma_normal,
            prior_iterations: old.prior_iterations,
            prior_everywhere: old.prior_everywhere,
            prior_extend: old.prior_extend,
            prior_lock: old.prior_lock,
            prior_anchors: old.prior_anchors,
            prior_anchor_weight: old.prior_anchor_weight,
            prior_anchor_tolerance: old.prior_anchor_tolerance,
            prior_anchor_inliers: old.prior_anchor_inliers,
            prior_anchor_distinct: old.prior_anchor_distinct,
            prior_anchor_views: old.prior_anchor_views,
            prior_support_views: old.prior_support_views,
            prior_after_geometric: old.prior_after_geometric,
            prior_region_choice: old.prior_region_choice,
            prior_flat_points: old.prior_flat_points,
            prior_flat_cost: old.prior_flat_cost,
            prior_flat_ramp: old.prior_flat_ramp,
            prior_flat_weighted: old.prior_flat_weighted,
            prior_flat_noise: old.prior_flat_noise,
            prior_confirmed_points: old.prior_confirmed_points,
            prior_confidence_score: old.prior_confidence_score,
            prior_regions: old.prior_regions,
            prior_region_tolerance: old.prior_region_tolerance,
            prior_region_flat_share: old.prior_region_flat_share,
            prior_region_near: old.prior_region_near,
            prior_region_crease: old.prior_region_crease,
            prior_region_cover_seen: old.prior_region_cover_seen,
            prior_region_cover_band: old.prior_region_cover_band,
            prior_region_edge: old.prior_region_edge,
            prior_region_axes: old.prior_region_axes,
            prior_region_hold: old.prior_region_hold,
            prior_hold_regions_only: old.prior_hold_regions_only,
            prior_keep_unseen: old.prior_keep_unseen,
            prior_init_depth: old.prior_init_depth,
            prior_init_normal: old.prior_init_normal,
            prior_refine_depth: old.prior_refine_depth,
            prior_refine_normal: old.prior_refine_normal,
            ..new.clone()
        };
        if everything != *old {
            return 0; // matching, view selection, refinement or the seed: every pass
        }
        let first = |pred: &dyn Fn(&Step) -> bool| {
            self.steps.iter().position(pred).unwrap_or(self.steps.len())
        };
        let mut from = self.steps.len();
        if new.median_radius != old.median_radius {
            from = from.min(first(&|s| s.action == Action::Median));
        }
        if (new.jbu_radius, new.jbu_sigma_spatial, new.jbu_sigma_range)
            != (old.jbu_radius, old.jbu_sigma_spatial, old.jbu_sigma_range)
        {
            from = from.min(first(&|s| s.action == Action::Upsample));
        }
        if new.restorer != old.restorer {
            from = from.min(first(&|s| s.stage == Stage::Restorer));
        }
        if new.xi != old.xi && new.restorer == RestorerMode::Gated {
            // The gate reads ξ in every update of the restorer's pass.
            from = from.min(first(&|s| s.stage == Stage::Restorer));
        }
        if new.xi != old.xi {
            from = from.min(first(&|s| s.action == Action::Restore));
        }
        let prior = |p: &Params| {
            (
                (
                    p.prior_cell,
                    p.prior_cost_threshold,
                    p.prior_triangle_normal,
                    p.prior_consistency,
                    p.prior_extend,
                    p.prior_lock,
                ),
                (p.prior_gamma, p.prior_beta, p.prior_everywhere),
                (p.prior_sigma_depth, p.prior_sigma_normal),
                (p.prior_init_depth, p.prior_init_normal),
                (p.prior_refine_depth, p.prior_refine_normal),
                (
                    p.prior_anchors,
                    p.prior_anchor_weight,
                    p.prior_anchor_tolerance,
                    p.prior_anchor_inliers,
                    p.prior_anchor_distinct,
                    p.prior_anchor_views,
                    p.prior_support_views,
                ),
                (
                    p.prior_flat_points,
                    p.prior_flat_cost,
                    p.prior_flat_ramp,
                    p.prior_flat_weighted,
                    p.prior_flat_noise,
                    p.prior_confirmed_points,
                    p.prior_confidence_score,
                ),
                (
                    p.prior_regions,
                    p.prior_region_tolerance,
                    p.prior_region_flat_share,
                    p.prior_region_near,
                    p.prior_region_crease,
                    p.prior_region_cover_seen,
                    p.prior_region_cover_band,
                    p.prior_region_edge,
                    p.prior_region_axes,
                    p.prior_region_hold,
                    p.prior_hold_regions_only,
                    p.prior_keep_unseen,
                ),
            )
        };
        if prior(new) != prior(old) {
            // The planar prior's stage reads them all (the support points and triangles the
            // cell, thresholds and angle, the prior-assisted pass the rest).
            // With the per-region choice the support points are first read at the start
            // of the first geometric pass.
            from = from.min(first(&|s| {
                s.stage == Stage::Planar || s.action == Action::SupportPoints
            }));
        }
        if (new.lambda, new.delta) != (old.lambda, old.delta) {
            from = from.min(first(&|s| matches!(s.stage, Stage::Geometric(_))));
        }
        // Fusion thresholds change no step: fusion runs on the finished maps.
        from
    }

    /// Changes parameters, rewinding to the first step whose result they change (the steps
    /// before it keep their results). Call `run_until(previous_cursor)` to see the effect
    /// where the session stood.
    pub fn set_params(&mut self, params: Params) -> Result<Invalidation, SessionError> {
        params.validate().map_err(SessionError::Params)?;
        let mut params = params;
        if let (true, Some(scene)) = (self.method.deepens_pyramid(&params), self.levels.last()) {
            let long_side = long_side(scene, &self.options);
            if let Some(depth) = self
                .texture
                .as_ref()
                .filter(|d| d.radius == params.window_radius)
            {
                params.scales = pyramid_depth::scales_for_reach(depth.reach, long_side, &params).0;
            } else if self.options.part.is_none() && pyramid_depth::sample_decoded(scene) {
                self.texture = pyramid_depth::resolve(&mut params, self.method, scene)
                    .map_err(SessionError::Params)?;
            }
        }
        let previous_cursor = self.cursor;
        let old = &self.params;
        if (
            params.scales,
            params.eta,
            params.original_pyramid,
            params.coarsest_size,
        ) != (old.scales, old.eta, old.original_pyramid, old.coarsest_size)
        {
            // Another pyramid: nothing carries over.
            if let Some(scene) = self.levels.last().cloned() {
                let keep = self.keep_checkpoints;
                let budget = self.checkpoint_budget;
                let interleaved = self.interleaved;
                *self = Session::with_options(
                    &self.ctx,
                    self.pipelines.clone(),
                    &scene,
                    params,
                    self.method,
                    self.options.clone(),
                )?;
                self.keep_checkpoints = keep;
                self.checkpoint_budget = budget;
                self.set_interleaved(interleaved)?;
            }
            return Ok(Invalidation {
                from_step: 0,
                previous_cursor,
            });
        }
        let new_steps = self.schedule_for(&params, &self.estimated);
        let common_prefix = self
            .steps
            .iter()
            .zip(&new_steps)
            .position(|(a, b)| a != b)
            .unwrap_or(self.steps.len().min(new_steps.len()));
        let from = common_prefix.min(self.first_affected(old, &params));
        let rewind_to = from.min(self.cursor);
        // The steps before `from` are the same under both parameter sets.
        self.goto(rewind_to)?;
        self.headers = problem_headers(&self.levels, &self.keys, &params);
        self.stage_order = stage_order(self.method, &params, self.levels.len() as u32);
        self.params = params;
        self.steps = new_steps;
        self.checkpoints.retain(|c| c.cursor <= rewind_to);
        Ok(Invalidation {
            from_step: rewind_to,
            previous_cursor,
        })
    }

    /// The prior score's constants of `view` at `level` (σd from its depth range).
    fn prior_terms(&self, view: usize, level: u32) -> PriorTerms {
        let p = &self.headers[level as usize][view];
        PriorTerms::new(&self.params, p.depth_min, p.depth_max)
    }

    /// Final maps of every view (after `run_to_end`), in scene order, read back.
    pub fn final_maps(&self) -> Result<Vec<Option<ViewMaps>>, SessionError> {
        (0..self.residents.len()).map(|v| self.maps(v)).collect()
    }

    /// The problem a step works on (its view at its scale), for CPU re-computation of a
    /// pixel (the viewer's pixel inspector).
    pub fn problem_for(&self, step: &Step) -> ViewProblem {
        // The images added to the header: its key and widened range are set in one place.
        let header = &self.headers[step.level as usize][step.view];
        ViewProblem {
            key: header.key,
            depth_min: header.depth_min,
            depth_max: header.depth_max,
            ..ViewProblem::new(&self.levels[step.level as usize], step.view, step.level)
        }
    }

    /// Whether the prior planes hold in some geometric pass (Regions' `prior_region_hold`):
    /// then a view's state keeps them from its prior stage to its last geometric pass.
    pub(crate) fn prior_holds(&self) -> bool {
        (1..=self.params.geometric_passes).any(|g| self.params.prior_holds_in(self.method, g))
    }

    /// The pass kind of a step (which random numbers it draws, what it aggregates).
    pub fn pass_kind(&self, step: &Step) -> PassKind {
        match step.stage {
            Stage::Geometric(g) => PassKind::Geometric(g),
            Stage::Planar => PassKind::Planar,
            Stage::Restorer => match self.params.restorer {
                RestorerMode::Refine => PassKind::Restorer { gated: false },
                RestorerMode::Gated => PassKind::Restorer { gated: true },
                RestorerMode::Random => PassKind::Photometric,
            },
            _ => PassKind::Photometric,
        }
    }

    /// Matching-cost evaluations (pixel x hypothesis x source) of the whole schedule, at the
    /// nominal 15 hypotheses per update (8 candidates, the current plane, 6 refinements) and
    /// one per source at each init.
    pub fn cost_evaluations(&self) -> u64 {
        self.steps
            .iter()
            .map(|s| {
                let v = &self.levels[s.level as usize].views[s.view];
                let n = v.image.width as u64 * v.image.height as u64;
                let sources = v.sources.len() as u64;
                match s.action {
                    Action::Half { .. } => n.div_ceil(2) * 15 * sources,
                    Action::Init => n * sources,
                    _ => 0,
                }
            })
            .sum()
    }

    /// Bytes the run holds on the device now: the level's images and depth snapshot, every
    /// view's buffers (with the planar prior's, and the prior planes kept for its maps), and
    /// the checkpoints.
    pub fn device_bytes(&self) -> u64 {
        let level = self.level_images.as_ref().map_or(0, |(_, l)| l.bytes());
        let views: u64 = self
            .residents
            .iter()
            .flatten()
            .map(|r| {
                r.solver.bytes()
                    + r.planar.as_ref().map_or(0, PlanarBuffers::bytes)
                    + r.marks.planar.as_ref().map_or(0, |p| p.prior.size())
            })
            .sum();
        level + views + self.checkpoint_bytes()
    }

    /// The level's images on the device, uploaded once when the run first needs them.
    fn ensure_level(&mut self, level: u32) -> Result<(), SessionError> {
        if self.level_images.as_ref().is_some_and(|(l, _)| *l == level) {
            return Ok(());
        }
        if !self.plan.resident {
            return Err(SessionError::State(format!(
                "level {level}: a batched session's images come with its batch (internal error)"
            )));
        }
        self.level_images = None; // free the previous level's first
        let n = self.levels[level as usize].views.len();
        let mut owned = Vec::with_capacity(n);
        for v in 0..n {
            owned.push(self.gray(level, v)?);
        }
        let scene = &self.levels[level as usize];
        let grays: Vec<(usize, u32, u32, &[f32])> = scene
            .views
            .iter()
            .zip(&owned)
            .enumerate()
            .map(|(i, (v, g))| {
                (
                    i,
                    v.image.width,
                    v.image.height,
                    gray_of(&self.levels, level, i, g),
                )
            })
            .collect();
        let images = LevelImages::upload(&self.ctx, &grays, n)?;
        self.level_images = Some((level, images));
        Ok(())
    }

    /// View `view`'s buffers at `level` (new, zeroed, if it has none there).
    fn ensure_resident(&mut self, view: usize, level: u32) -> Result<(), SessionError> {
        if self.residents[view]
            .as_ref()
            .is_some_and(|r| r.level == level)
        {
            return Ok(());
        }
        self.ensure_level(level)?;
        let problem = &self.headers[level as usize][view];
        let Some((_, images)) = &self.level_images else {
            return Ok(());
        };
        let solver = GpuViewSolver::resident(&self.ctx, &self.pipelines, problem, images)?;
        self.residents[view] = Some(Resident {
            level,
            solver,
            marks: Marks::default(),
            planar: None,
            points: None,
            mesh: None,
            upsample_ready: false,
        });
        Ok(())
    }

    fn execute(&mut self, step: Step) -> Result<(), SessionError> {
        self.ensure_batch(&step)?;
        self.ensure_level(step.level)?;
        let new_unit = self.active.is_none_or(|a| !a.same_unit(&step));
        let from_host = self.residents[step.view]
            .as_ref()
            .is_some_and(|r| r.level == step.level && r.upsample_ready);
        if new_unit && step.action == Action::Upsample && !from_host {
            // The coarse level's planes go straight into the fine buffers' prior; the coarse
            // buffers are freed.
            let coarse = self.residents[step.view].take();
            self.ensure_resident(step.view, step.level)?;
            if let (Some(c), Some(fine)) = (&coarse, &self.residents[step.view])
                && c.level + 1 == step.level
            {
                fine.solver.copy_prior_from(&self.ctx, &c.solver.plane);
            }
        } else {
            self.ensure_resident(step.view, step.level)?;
        }
        // Regions' edge rule and frame read the reference's intensities on the host, and the
        // flat test its noise.
        let gray = if (step.action == Action::Triangulate
            && self.params.prior_regions
            && (self.params.prior_region_edge || self.params.prior_region_axes))
            || (step.action == Action::SupportPoints
                && self.params.prior_flat_noise
                && (self.params.prior_flat_points || self.params.prior_regions))
        {
            Some(self.gray(step.level, step.view)?)
        } else {
            None
        };
        self.active = Some(step);
        self.changed[step.view] = true;
        let kind = self.pass_kind(&step);
        let coarse_k = (step.level > 0).then(|| {
            let k = self.levels[step.level as usize - 1].views[step.view]
                .camera
                .intrinsics;
            [k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32]
        });
        let coarse_size = (step.level > 0).then(|| {
            let v = &self.levels[step.level as usize - 1].views[step.view].image;
            (v.width, v.height)
        });
        let problem = &self.headers[step.level as usize][step.view];
        let Some(resident) = self.residents[step.view].as_mut() else {
            return Ok(());
        };
        if new_unit {
            resident.marks.reprojection = matches!(step.stage, Stage::Geometric(_));
        }
        if matches!(
            step.action,
            Action::SupportPoints | Action::Triangulate | Action::PriorPlane
        ) {
            if step.stage == Stage::Planar
                && step.action == Action::Triangulate
                && self.params.early_support_points(self.method)
                && resident.marks.earlier.is_none()
            {
                return Err(SessionError::State(format!(
                    "{}: the per-region choice has no earlier support points (its first geometric pass's support-point step has not run, or its state was handed on without them)",
                    step.label()
                )));
            }
            let oracle = self.oracle.as_ref().and_then(|(o, truth)| {
                truth
                    .get(step.view)
                    .and_then(Option::as_ref)
                    .map(|t| (*o, t, self.oracle_admit))
            });
            return planar_step(
                &self.ctx,
                &self.pipelines,
                &self.params,
                problem,
                resident,
                step,
                oracle,
                gray.as_ref()
                    .map(|g| gray_of(&self.levels, step.level, step.view, g)),
            );
        }
        let (ctx, pipes, params, method) = (&self.ctx, &*self.pipelines, &self.params, self.method);
        let solver = &resident.solver;
        match step.action {
            Action::Upsample => {
                if let (Some(size), Some(k)) = (coarse_size, coarse_k) {
                    solver.upsample(ctx, pipes, problem, params, size, k);
                }
            }
            Action::Init => match kind {
                PassKind::Photometric => solver.random_init(ctx, pipes, problem, params),
                // The upsampled planes are in place: their costs become C_init. A geometric
                // pass re-evaluates the view's planes against the level's depth snapshot.
                PassKind::Restorer { .. } | PassKind::Geometric(_) | PassKind::Planar => {
                    solver.evaluate(ctx, pipes, problem, params, kind)
                }
            },
            Action::Half { iteration, color } => {
                solver.propagate_kind(ctx, pipes, problem, params, method, kind, iteration, color)
            }
            Action::Median => solver.median_filter(ctx, pipes, problem, params),
            Action::Restore => {
                solver.restore(ctx, pipes, problem, params, kind);
                resident.marks.difference = true;
                // The aux words only (the selection masks follow them in the buffer).
                resident.marks.replaced = Some(crate::gpu::acmh::copy_start_on_device(
                    ctx,
                    "replaced",
                    &solver.aux,
                    solver.aux_bytes(),
                ));
            }
            Action::Measure => solver.measure(ctx, pipes, problem, params),
            // Run by `planar_step` above.
            Action::SupportPoints | Action::Triangulate | Action::PriorPlane => {}
        }
        Ok(())
    }

    /// Finishes a view's unit of work and a stage when their last step has run: at a stage's
    /// end the views' depths become the snapshot the next stage reads (gathered on the
    /// device), and a checkpoint keeps copies of the maps (on the device) when asked to.
    fn after_step(&mut self, step: Step) -> Result<(), SessionError> {
        let next = self.steps.get(self.cursor).copied();
        let unit_done = next.is_none_or(|n| !n.same_unit(&step));
        if unit_done {
            self.active = None;
        }
        // A view's prior stage ends with its last step in it (the stage's views interleave).
        if step.stage == Stage::Planar
            && self.params.prior_hold_regions_only
            && self.prior_holds()
            && !self.steps[self.cursor.min(self.steps.len())..]
                .iter()
                .take_while(|n| n.level == step.level && n.stage == step.stage)
                .any(|n| n.view == step.view)
        {
            self.keep_region_planes(step)?;
        }
        let stage_done = next.is_none_or(|n| n.level != step.level || n.stage != step.stage);
        if stage_done {
            if self.plan.resident {
                for r in self.residents.iter().flatten() {
                    if r.level == step.level {
                        r.solver.gather_depth(&self.ctx, &self.pipelines);
                    }
                }
            } else {
                // The stage's last batch goes to the host with the others: the next stage
                // reads every view's depth from there.
                self.park()?;
            }
            self.committed_level = Some(step.level);
            if next.is_some() {
                self.checkpoint_stage(&step, false)?;
            }
        }
        // A batched session keeps no device checkpoints (its views are not all there):
        // stepping back replays from the start.
        if !self.keep_checkpoints || !self.plan.resident {
            if stage_done {
                self.checkpoints.retain(|c| c.cursor == 0);
            }
            return Ok(());
        }
        if unit_done {
            self.push_checkpoint(step, stage_done);
        }
        Ok(())
    }
}

impl Session {
    /// Processes views in this order within each stage (must be a permutation of the
    /// estimated views; only before the first step). Results do not depend on it — the
    /// snapshot rule — which tests check.
    pub fn set_view_order(&mut self, order: Vec<usize>) -> Result<(), SessionError> {
        let mut sorted = order.clone();
        sorted.sort_unstable();
        let mut estimated = self.estimated.clone();
        estimated.sort_unstable();
        if self.is_batched() {
            return Err(SessionError::Params(
                "view order: a batched session runs its views batch by batch".into(),
            ));
        }
        if self.cursor != 0 || sorted != estimated {
            return Err(SessionError::Params(
                "view order: give a permutation of the estimated views, before the first step"
                    .into(),
            ));
        }
        self.estimated = order;
        self.steps = self.schedule_for(&self.params, &self.estimated);
        Ok(())
    }
}

impl Session {
    /// Runs only these views (ACMH and DWTA, whose views are independent; before the first
    /// step): `mvscope run --resume` skips views that are already finished.
    pub fn restrict_views(&mut self, views: &[usize]) -> Result<(), SessionError> {
        if self.method.couples_views() {
            return Err(SessionError::Params(format!(
                "restrict_views: {} couples the views through geometric consistency",
                self.method
            )));
        }
        if self.cursor != 0 {
            return Err(SessionError::Params(
                "restrict_views: only before the first step".into(),
            ));
        }
        self.estimated.retain(|v| views.contains(v));
        self.steps = self.schedule_for(&self.params, &self.estimated);
        Ok(())
    }

    /// The (level, stage) of the schedule's last stage: a view's maps are final once its
    /// work in that stage is done.
    pub fn last_stage(&self) -> Option<(u32, Stage)> {
        self.steps.last().map(|s| (s.level, s.stage))
    }

    /// Whether `step` is the last step of its view in the last stage (its maps are final),
    /// in either order. (A run asking for every step takes [`Session::final_steps`] once.)
    pub fn completes_view(&self, index: usize) -> bool {
        let Some(step) = self.steps.get(index) else {
            return false;
        };
        let last_of_view = self.steps[index + 1..].iter().all(|n| n.view != step.view);
        last_of_view && self.last_stage() == Some((step.level, step.stage))
    }

    /// The index of each view's last step when it lies in the last stage (its maps are final
    /// after it): [`Session::completes_view`] for every step in one pass.
    pub fn final_steps(&self) -> Vec<Option<usize>> {
        let mut last = vec![None; self.residents.len()];
        let end = self.last_stage();
        for (i, s) in self.steps.iter().enumerate().rev() {
            if let Some(slot) = last.get_mut(s.view)
                && slot.is_none()
            {
                *slot = Some((end == Some((s.level, s.stage))).then_some(i));
            }
        }
        last.into_iter().map(Option::flatten).collect()
    }
}

/// The longest image side of the whole scene (a part's is its whole's).
fn long_side(scene: &Scene, options: &SessionOptions) -> u32 {
    match &options.part {
        Some(w) => w.long_side,
        None => scene.long_side(),
    }
}

/// `Session::problem_for` without the images (a resident solver reads its level's) for every
/// view of every level: the cameras, sources, widened depth range and random-number key.
fn problem_headers(levels: &[Scene], keys: &[u32], params: &Params) -> Vec<Vec<ViewProblem>> {
    levels
        .iter()
        .enumerate()
        .map(|(level, scene)| {
            (0..scene.views.len())
                .map(|view| {
                    let mut problem = ViewProblem::header(scene, view, level as u32);
                    problem.key = keys[view];
                    problem.depth_min *= params.depth_min_factor;
                    problem.depth_max *= params.depth_max_factor;
                    problem
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interleave_runs_each_action_for_every_view_and_keeps_each_views_order() {
        let params = Params {
            geometric_passes: 2,
            ..Params::default()
        };
        let views = [3, 0, 5];
        let steps = build_schedule(Method::Acmm, &params, &views, 3);
        let mixed = interleave(&steps);
        assert_eq!(mixed.len(), steps.len());
        // Each view's own steps in the same order.
        for &v in &views {
            let own = |s: &[Step]| {
                s.iter()
                    .filter(|x| x.view == v)
                    .copied()
                    .collect::<Vec<_>>()
            };
            assert_eq!(own(&mixed), own(&steps), "view {v}");
        }
        // Stages in the same order, and inside a stage each run of three is one action of
        // the three views, in the schedule's view order.
        let stages = |s: &[Step]| {
            let mut out: Vec<(u32, Stage)> = s.iter().map(|x| (x.level, x.stage)).collect();
            out.dedup();
            out
        };
        assert_eq!(stages(&mixed), stages(&steps));
        for group in mixed.chunks(3) {
            assert!(group.iter().all(|s| s.action == group[0].action
                && (s.level, s.stage) == (group[0].level, group[0].stage)));
            assert_eq!(group.iter().map(|s| s.view).collect::<Vec<_>>(), views);
        }
        assert_ne!(mixed, steps);
        assert_eq!(interleave(&mixed), mixed, "already interleaved");
    }
}
