//! A steppable ACMM / ACMH / DWTA run over a whole scene.
//!
//! The [`Session`] owns an explicit schedule of labelled [`Step`]s — scale, stage, view,
//! iteration, red or black half, plus the upsample, init, median and restore steps — that a UI
//! shows as a timeline. It runs them one at a time (or to a target), keeps every view's maps,
//! checkpoints at stage boundaries so it can step back or re-run a stage with new parameters,
//! and exposes any map of any view as CPU arrays and the active view's as GPU buffers.
//!
//! **Which depth maps a geometric pass reads.** Every stage works from a snapshot: the maps
//! all views had when the previous stage ended. A geometric pass of view v reads its sources'
//! depth maps from that snapshot, never from a view updated earlier in the same stage, so the
//! result does not depend on the order views are processed in. A stage's results become the
//! snapshot only when all its views are done.
//!
//! Stages per scale (paper Sec. 5): at the coarsest scale, photometric ACMH, then
//! `geometric_passes` geometric consistency passes; at each finer scale, the detail restorer
//! stage (joint bilateral upsampling of the coarser maps, then the basic model: by default
//! started from the upsampled planes with C_init kept and every update gated by
//! C_init − ξ; or from random planes, compared and replaced where C_init − C_photo > ξ), then
//! the geometric passes. ACMH and DWTA are one photometric stage at the input scale.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use super::params::{Method, Params, RestorerMode};
use super::problem::{NO_VIEW, ViewProblem, ViewState};
use crate::acmm::cpu::MAX_COST;
use crate::acmm::multiscale::pyramid_scales;
use crate::gpu::acmh::{AcmhPipelines, GpuViewSolver, PassKind};
use crate::gpu::{GpuContext, GpuError};
use crate::scene::Scene;

/// A stage of the algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Photometric ACMH (or DWTA) from random planes.
    Photometric,
    /// Upsampling, photometric ACMH at this scale, and the detail restorer.
    Restorer,
    /// Geometric consistency pass 1, 2, ...
    Geometric(u32),
}

/// What one step does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    /// Joint bilateral upsampling of the coarser scale's planes.
    Upsample,
    /// Random planes (photometric) or re-evaluation of the current ones (geometric).
    Init,
    /// One red (`color` 0) or black (1) half of iteration `iteration` (1-based).
    Half { iteration: u32, color: u32 },
    /// The 5x5 median filter on depth.
    Median,
    /// Compare C_init with C_photo and replace errors in the details.
    Restore,
    /// Measure the reprojection error of the pass's result (for display).
    Measure,
}

/// One labelled unit of work.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Step {
    /// Pyramid level, 0 = coarsest (the paper's l).
    pub level: u32,
    pub levels: u32,
    pub stage: Stage,
    /// Scene index of the reference view.
    pub view: usize,
    pub action: Action,
}

impl Step {
    /// "scale 1/3 · geometric 2 · view 4 · iteration 1 red".
    pub fn label(&self) -> String {
        let stage = match self.stage {
            Stage::Photometric => "photometric".to_string(),
            Stage::Restorer => "detail restorer".to_string(),
            Stage::Geometric(g) => format!("geometric {g}"),
        };
        let action = match self.action {
            Action::Upsample => "upsample".to_string(),
            Action::Init => "init".to_string(),
            Action::Half { iteration, color } => format!(
                "iteration {iteration} {}",
                if color == 0 { "red" } else { "black" }
            ),
            Action::Median => "median".to_string(),
            Action::Restore => "restore".to_string(),
            Action::Measure => "measure".to_string(),
        };
        format!(
            "scale {}/{} · {stage} · view {} · {action}",
            self.level + 1,
            self.levels,
            self.view
        )
    }

    fn same_unit(&self, other: &Step) -> bool {
        self.level == other.level && self.stage == other.stage && self.view == other.view
    }
}

/// The schedule of a run: stages in order, views in scene order within a stage.
pub fn build_schedule(method: Method, params: &Params, views: &[usize], levels: u32) -> Vec<Step> {
    let mut steps = Vec::new();
    let halves = |steps: &mut Vec<Step>, base: Step, iterations: u32| {
        for iteration in 1..=iterations {
            for color in [0, 1] {
                steps.push(Step {
                    action: Action::Half { iteration, color },
                    ..base
                });
            }
        }
    };
    for level in 0..levels {
        let (first_stage, iterations) = if level > 0 {
            (Stage::Restorer, params.restorer_iterations)
        } else if method == Method::Acmm {
            (Stage::Photometric, params.coarse_iterations)
        } else {
            (Stage::Photometric, params.iterations)
        };
        for &view in views {
            let base = Step {
                level,
                levels,
                stage: first_stage,
                view,
                action: Action::Init,
            };
            if first_stage == Stage::Restorer {
                steps.push(Step {
                    action: Action::Upsample,
                    ..base
                });
            }
            steps.push(base);
            halves(&mut steps, base, iterations);
            steps.push(Step {
                action: Action::Median,
                ..base
            });
            if first_stage == Stage::Restorer {
                steps.push(Step {
                    action: Action::Restore,
                    ..base
                });
            }
        }
        if method != Method::Acmm {
            continue;
        }
        for g in 1..=params.geometric_passes {
            for &view in views {
                let base = Step {
                    level,
                    levels,
                    stage: Stage::Geometric(g),
                    view,
                    action: Action::Init,
                };
                steps.push(base);
                halves(&mut steps, base, params.geometric_iterations);
                for action in [Action::Median, Action::Measure] {
                    steps.push(Step { action, ..base });
                }
            }
        }
    }
    steps
}

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
        }
    }
}

/// A view's maps on the GPU, laid out as the passes write them (see
/// shaders/shared/problem.wgsl): planes (normal xyz, depth w), costs, selection bits, weights
/// (`num_sources` per pixel), aux (winner, v_t, replaced bit) and the three extra maps.
#[derive(Clone, Debug)]
pub struct GpuMaps {
    pub width: u32,
    pub height: u32,
    pub num_sources: usize,
    pub plane: wgpu::Buffer,
    pub cost: wgpu::Buffer,
    pub selected: wgpu::Buffer,
    pub weights: wgpu::Buffer,
    pub aux: wgpu::Buffer,
    /// [0, n) scratch, [n, 2n) restorer difference, [2n, 3n) reprojection error.
    pub extra: wgpu::Buffer,
    /// The buffers the passes are writing right now.
    pub live: bool,
}

impl GpuMaps {
    /// Stored maps uploaded in the passes' layout (weights of a view without sources: one 0;
    /// extra maps absent: 0).
    pub fn upload(ctx: &GpuContext, maps: &ViewMaps) -> GpuMaps {
        let st = &maps.state;
        let n = st.plane.len();
        let mut extra = vec![0.0f32; 3 * n];
        if let Some(d) = &maps.restorer_difference {
            extra[n..2 * n].copy_from_slice(d);
        }
        if let Some(e) = &maps.reprojection_error {
            extra[2 * n..].copy_from_slice(e);
        }
        let weights = if st.weights.is_empty() {
            vec![0.0f32; 1]
        } else {
            st.weights.clone()
        };
        GpuMaps {
            width: st.width,
            height: st.height,
            num_sources: st.num_sources,
            plane: ctx.storage_buffer("plane", &st.plane),
            cost: ctx.storage_buffer("cost", &st.cost),
            selected: ctx.storage_buffer("selected", &st.selected),
            weights: ctx.storage_buffer("weights", &weights),
            aux: ctx.storage_buffer("aux", &st.aux),
            extra: ctx.storage_buffer("extra", &extra),
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
}

/// The maps at a stage boundary: enough to resume from there.
#[derive(Clone)]
struct Checkpoint {
    /// The first step after the boundary.
    cursor: usize,
    committed: Vec<Option<ViewMaps>>,
}

struct Active {
    step: Step,
    problem: ViewProblem,
    solver: GpuViewSolver,
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
    /// The scene at each pyramid level, coarsest first.
    levels: Vec<Scene>,
    /// Views that have sources (the others get empty maps).
    estimated: Vec<usize>,
    steps: Vec<Step>,
    cursor: usize,
    /// Each view's maps at the last stage boundary (what the current stage reads).
    committed: Vec<Option<ViewMaps>>,
    /// Maps of views that finished the current stage.
    pending: Vec<Option<ViewMaps>>,
    active: Option<Active>,
    checkpoints: Vec<Checkpoint>,
    keep_checkpoints: bool,
}

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
        params.validate().map_err(SessionError::Params)?;
        let long_side = scene
            .views
            .iter()
            .map(|v| v.image.width.max(v.image.height))
            .max()
            .unwrap_or(1);
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
        let estimated: Vec<usize> = (0..scene.views.len())
            .filter(|&v| !scene.views[v].sources.is_empty())
            .collect();
        let steps = build_schedule(method, &params, &estimated, levels.len() as u32);
        let n = scene.views.len();
        Ok(Session {
            ctx: ctx.clone(),
            pipelines,
            params,
            method,
            levels,
            estimated,
            steps,
            cursor: 0,
            committed: vec![None; n],
            pending: vec![None; n],
            active: None,
            checkpoints: vec![Checkpoint {
                cursor: 0,
                committed: vec![None; n],
            }],
            keep_checkpoints: true,
        })
    }

    /// Keep only the checkpoint needed to resume (saves memory in batch runs); stepping back
    /// then replays from the start.
    pub fn set_keep_checkpoints(&mut self, keep: bool) {
        self.keep_checkpoints = keep;
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
        self.active.as_ref().map(|a| (a.step, &a.solver))
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

    /// Runs until `target` steps have run (or the end), checking `cancel` between steps and
    /// telling `progress` (step, index, total) before each. Returns whether it got there.
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
            self.step()?;
        }
        Ok(true)
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
                .unwrap_or(Checkpoint {
                    cursor: 0,
                    committed: vec![None; self.committed.len()],
                });
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
        let cp = Checkpoint {
            cursor: 0,
            committed: vec![None; self.committed.len()],
        };
        self.restore(cp);
    }

    fn restore(&mut self, cp: Checkpoint) {
        self.cursor = cp.cursor;
        self.committed = cp.committed;
        self.pending = vec![None; self.committed.len()];
        self.active = None;
        self.checkpoints.retain(|c| c.cursor <= self.cursor);
    }

    /// The first step a change from `old` to `new` affects (in a schedule both share).
    fn first_affected(&self, old: &Params, new: &Params) -> usize {
        // Everything but the values only some steps read, and the structure (handled by
        // comparing schedules): a change here alters every pass.
        let everything = Params {
            median_radius: old.median_radius,
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
        let previous_cursor = self.cursor;
        let old = &self.params;
        if (params.scales, params.eta, params.original_pyramid)
            != (old.scales, old.eta, old.original_pyramid)
        {
            // Another pyramid: nothing carries over.
            if let Some(scene) = self.levels.last().cloned() {
                let keep = self.keep_checkpoints;
                *self = Session::with_pipelines(
                    &self.ctx,
                    self.pipelines.clone(),
                    &scene,
                    params,
                    self.method,
                )?;
                self.keep_checkpoints = keep;
            }
            return Ok(Invalidation {
                from_step: 0,
                previous_cursor,
            });
        }
        let new_steps = build_schedule(
            self.method,
            &params,
            &self.estimated,
            self.levels.len() as u32,
        );
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
        self.params = params;
        self.steps = new_steps;
        self.checkpoints.retain(|c| c.cursor <= rewind_to);
        Ok(Invalidation {
            from_step: rewind_to,
            previous_cursor,
        })
    }

    /// The maps of `view` as they stand now (the live GPU state for the active view).
    pub fn maps(&self, view: usize) -> Result<Option<ViewMaps>, SessionError> {
        if let Some(active) = &self.active
            && active.step.view == view
        {
            let state = active.solver.download_state(&self.ctx)?;
            let (difference, error) = active.solver.download_extra(&self.ctx)?;
            let is_restorer = active.step.stage == Stage::Restorer;
            let is_geometric = matches!(active.step.stage, Stage::Geometric(_));
            let restored = is_restorer && active.step.action == Action::Restore;
            return Ok(Some(ViewMaps {
                level: active.step.level,
                replaced: restored.then(|| state.aux.iter().map(|a| a & (1 << 16) != 0).collect()),
                restorer_difference: restored.then_some(difference),
                reprojection_error: is_geometric.then_some(error),
                state,
            }));
        }
        Ok(self.pending[view]
            .clone()
            .or_else(|| self.committed[view].clone()))
    }

    /// C_init of each pixel while `view` is in the gated detail restorer's pass (what its
    /// updates are gated by), else `None` (the ungated pass reads C_init only at its end).
    pub fn restorer_c_init(&self, view: usize) -> Result<Option<Vec<f32>>, SessionError> {
        match &self.active {
            Some(active)
                if active.step.view == view
                    && self.pass_kind(&active.step) == PassKind::Restorer { gated: true }
                    && active.step.action != Action::Restore =>
            {
                Ok(Some(active.solver.download_extra(&self.ctx)?.0))
            }
            _ => Ok(None),
        }
    }

    /// The maps of `view` as GPU buffers, for drawing without a CPU round trip: the live
    /// buffers while the view is being processed, else buffers made from its stored maps.
    pub fn gpu_maps(&self, view: usize) -> Result<Option<GpuMaps>, SessionError> {
        if let Some(active) = &self.active
            && active.step.view == view
        {
            let s = &active.solver;
            return Ok(Some(GpuMaps {
                width: active.problem.width,
                height: active.problem.height,
                num_sources: active.problem.num_sources(),
                plane: s.plane.clone(),
                cost: s.cost.clone(),
                selected: s.selected.clone(),
                weights: s.weights.clone(),
                aux: s.aux.clone(),
                extra: s.extra.clone(),
                live: true,
            }));
        }
        Ok(self
            .maps(view)?
            .map(|maps| GpuMaps::upload(&self.ctx, &maps)))
    }

    /// Final maps of every view (after `run_to_end`), in scene order.
    pub fn final_maps(&self) -> Vec<Option<ViewMaps>> {
        self.committed.clone()
    }

    /// The problem a step works on (its view at its scale), for CPU re-computation of a
    /// pixel (the viewer's pixel inspector).
    pub fn problem_for(&self, step: &Step) -> ViewProblem {
        let mut problem =
            ViewProblem::new(&self.levels[step.level as usize], step.view, step.level);
        problem.depth_min *= self.params.depth_min_factor;
        problem.depth_max *= self.params.depth_max_factor;
        problem
    }

    /// The pass kind of a step (which random numbers it draws, what it aggregates).
    pub fn pass_kind(&self, step: &Step) -> PassKind {
        match step.stage {
            Stage::Geometric(g) => PassKind::Geometric(g),
            Stage::Restorer => match self.params.restorer {
                RestorerMode::Refine => PassKind::Restorer { gated: false },
                RestorerMode::Gated => PassKind::Restorer { gated: true },
                RestorerMode::Random => PassKind::Photometric,
            },
            _ => PassKind::Photometric,
        }
    }

    /// The sources' committed depth maps laid out like the problem's images: what a
    /// geometric pass of `problem` reads.
    pub fn source_depths(&self, problem: &ViewProblem) -> Vec<f32> {
        let mut depths = vec![0.0f32; problem.images.len()];
        for (j, &src) in problem.source_views.iter().enumerate() {
            let offset = problem.sources[j].size[2] as usize;
            if let Some(maps) = &self.committed[src] {
                for (k, p) in maps.state.plane.iter().enumerate() {
                    depths[offset + k] = p[3];
                }
            }
        }
        depths
    }

    fn execute(&mut self, step: Step) -> Result<(), SessionError> {
        let needs_new = self
            .active
            .as_ref()
            .is_none_or(|a| !a.step.same_unit(&step));
        if needs_new {
            let problem = self.problem_for(&step);
            let solver = GpuViewSolver::new(&self.ctx, &self.pipelines, &problem)?;
            self.active = Some(Active {
                step,
                problem,
                solver,
            });
        }
        let kind = self.pass_kind(&step);
        let geometric = matches!(kind, PassKind::Geometric(_));
        let depths = if geometric && step.action == Action::Init {
            self.active.as_ref().map(|a| self.source_depths(&a.problem))
        } else {
            None
        };
        // Only upsampling and the start of a geometric pass read the view's committed maps;
        // cloning them on every half-iteration would copy whole maps per step.
        let committed_self = match step.action {
            Action::Upsample => self.committed[step.view].clone(),
            Action::Init if geometric => self.committed[step.view].clone(),
            _ => None,
        };
        let coarse = if step.action == Action::Upsample {
            let k = self.levels[step.level as usize - 1].views[step.view]
                .camera
                .intrinsics;
            committed_self
                .clone()
                .map(|m| (m, [k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32]))
        } else {
            None
        };
        let Some(active) = self.active.as_mut() else {
            return Ok(());
        };
        active.step = step;
        let (ctx, pipes, params, method) = (&self.ctx, &*self.pipelines, &self.params, self.method);
        let (solver, problem) = (&active.solver, &active.problem);
        match step.action {
            Action::Upsample => {
                if let Some((coarse, k)) = coarse {
                    solver.upload_prior(ctx, &coarse.state.plane);
                    solver.upsample(
                        ctx,
                        pipes,
                        problem,
                        params,
                        (coarse.state.width, coarse.state.height),
                        k,
                    );
                }
            }
            Action::Init => match kind {
                PassKind::Photometric => solver.random_init(ctx, pipes, problem, params),
                // The upsampled planes are in place: their costs become C_init.
                PassKind::Restorer { .. } => solver.evaluate(ctx, pipes, problem, params, kind),
                PassKind::Geometric(_) => {
                    if let Some(maps) = &committed_self {
                        solver.upload_state(ctx, &maps.state);
                    }
                    if let Some(d) = &depths {
                        solver.upload_depths(ctx, d);
                    }
                    solver.evaluate(ctx, pipes, problem, params, kind);
                }
            },
            Action::Half { iteration, color } => {
                solver.propagate_kind(ctx, pipes, problem, params, method, kind, iteration, color)
            }
            Action::Median => solver.median_filter(ctx, pipes, problem, params),
            Action::Restore => solver.restore(ctx, pipes, problem, params, kind),
            Action::Measure => solver.measure(ctx, pipes, problem, params),
        }
        Ok(())
    }

    /// Finishes a view's unit of work and a stage when their last step has run.
    fn after_step(&mut self, step: Step) -> Result<(), SessionError> {
        let next = self.steps.get(self.cursor).copied();
        let unit_done = next.is_none_or(|n| !n.same_unit(&step));
        if unit_done {
            let mut maps = self.maps(step.view)?;
            // Later stages of a level keep showing what the restorer did there.
            if let (Some(m), Some(prev)) = (maps.as_mut(), self.committed[step.view].as_ref())
                && m.level == prev.level
                && m.restorer_difference.is_none()
            {
                m.restorer_difference = prev.restorer_difference.clone();
                m.replaced = prev.replaced.clone();
            }
            self.pending[step.view] = maps;
            self.active = None;
        }
        let stage_done = next.is_none_or(|n| n.level != step.level || n.stage != step.stage);
        if stage_done {
            // The stage's results become the snapshot the next stage reads.
            for v in 0..self.committed.len() {
                if let Some(m) = self.pending[v].take() {
                    self.committed[v] = Some(m);
                } else if !self.estimated.contains(&v) {
                    let s = &self.levels[step.level as usize].views[v];
                    self.committed[v] =
                        Some(ViewMaps::empty(step.level, s.image.width, s.image.height));
                }
            }
            let cp = Checkpoint {
                cursor: self.cursor,
                committed: self.committed.clone(),
            };
            if !self.keep_checkpoints {
                self.checkpoints.retain(|c| c.cursor == 0);
            }
            self.checkpoints.push(cp);
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
        if self.cursor != 0 || sorted != self.estimated {
            return Err(SessionError::Params(
                "view order: give a permutation of the estimated views, before the first step"
                    .into(),
            ));
        }
        self.estimated = order;
        self.steps = build_schedule(
            self.method,
            &self.params,
            &self.estimated,
            self.levels.len() as u32,
        );
        Ok(())
    }
}

impl Session {
    /// Runs only these views (ACMH and DWTA, whose views are independent; before the first
    /// step): `mvscope run --resume` skips views that are already finished.
    pub fn restrict_views(&mut self, views: &[usize]) -> Result<(), SessionError> {
        if self.method == Method::Acmm {
            return Err(SessionError::Params(
                "restrict_views: ACMM couples the views through geometric consistency".into(),
            ));
        }
        if self.cursor != 0 {
            return Err(SessionError::Params(
                "restrict_views: only before the first step".into(),
            ));
        }
        self.estimated.retain(|v| views.contains(v));
        self.steps = build_schedule(
            self.method,
            &self.params,
            &self.estimated,
            self.levels.len() as u32,
        );
        Ok(())
    }

    /// The (level, stage) of the schedule's last stage: a view's maps are final once its
    /// work in that stage is done.
    pub fn last_stage(&self) -> Option<(u32, Stage)> {
        self.steps.last().map(|s| (s.level, s.stage))
    }

    /// Whether `step` is the last step of its view in the last stage (its maps are final).
    pub fn completes_view(&self, index: usize) -> bool {
        let Some(step) = self.steps.get(index) else {
            return false;
        };
        let last_of_unit = self.steps.get(index + 1).is_none_or(|n| !n.same_unit(step));
        last_of_unit && self.last_stage() == Some((step.level, step.stage))
    }
}
