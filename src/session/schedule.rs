//! The schedule: stages, actions and labelled steps (scale, stage, view, iteration, half),
//! built per method, and interleaved for batch runs.

use super::*;

/// A stage of the algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Photometric ACMH (or DWTA) from random planes.
    Photometric,
    /// Upsampling, photometric ACMH at this scale, and the detail restorer.
    Restorer,
    /// The planar prior (ACMP, ACMMP): credible support points, their triangulation, the
    /// prior plane of every pixel, then the prior-assisted photometric pass.
    Planar,
    /// Geometric consistency pass 1, 2, ...
    Geometric(u32),
}

impl Stage {
    /// Whether the stage reads its sources' depths (the previous stage's snapshot): the
    /// geometric passes, and the planar prior's multi-view check of its support points.
    pub fn reads_sources(&self, params: &Params) -> bool {
        match self {
            Stage::Geometric(_) => true,
            Stage::Planar => params.prior_consistency > 0.0,
            Stage::Photometric | Stage::Restorer => false,
        }
    }
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
    /// The planar prior's credible support points: the lowest-cost pixel of each grid cell
    /// if its cost is below the threshold.
    SupportPoints,
    /// Delaunay triangulation of the support points in the image, a plane per triangle.
    Triangulate,
    /// The prior plane (depth and normal) of every pixel, rasterised from the triangles.
    PriorPlane,
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
            Stage::Planar => "planar prior".to_string(),
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
            Action::SupportPoints => "support points".to_string(),
            Action::Triangulate => "triangulate".to_string(),
            Action::PriorPlane => "prior plane".to_string(),
        };
        format!(
            "scale {}/{} · {stage} · view {} · {action}",
            self.level + 1,
            self.levels,
            self.view
        )
    }

    /// The action part of the label: "iteration 2 red", "support points", ...
    pub fn label_action(&self) -> String {
        self.label()
            .rsplit(" · ")
            .next()
            .unwrap_or_default()
            .to_string()
    }

    pub(super) fn same_unit(&self, other: &Step) -> bool {
        self.level == other.level && self.stage == other.stage && self.view == other.view
    }
}

/// The schedule of a run: stages in order, views in scene order within a stage.
///
/// Per scale: the first stage (photometric from random planes at the coarsest scale, the
/// detail restorer at the others), then for ACMP and ACMMP the planar prior stage, then for
/// the methods with geometric consistency `geometric_passes` geometric passes (with
/// `prior_after_geometric` or `prior_region_choice`, the first of them before the planar prior
/// stage; with `prior_region_choice` that pass begins with the support points of the
/// restorer's result and their triangulation).
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
        } else if method.has_geometric() {
            (Stage::Photometric, params.coarse_iterations)
        } else {
            (Stage::Photometric, params.iterations)
        };
        // Whether the first stage is the run's last (no prior or geometric stage follows).
        let ends_run = level + 1 == levels
            && !method.has_planar_prior()
            && (!method.has_geometric() || params.geometric_passes == 0)
            && !params.median_every_pass;
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
            // The restorer's last step may write planes (`random`); when it ends the run (no
            // geometric pass follows), the median on the final maps comes after it.
            let mut ending = vec![Action::Median];
            if first_stage == Stage::Restorer {
                if ends_run {
                    ending.insert(0, Action::Restore);
                } else {
                    ending.push(Action::Restore);
                }
            }
            for action in ending {
                steps.push(Step { action, ..base });
            }
        }
        let passes = if method.has_geometric() {
            params.geometric_passes
        } else {
            0
        };
        // With `prior_after_geometric` (or Regions' per-region choice) the prior is built
        // from the first geometric pass's result, and the passes after it follow the
        // prior-assisted pass.
        let passes_before = if method.has_planar_prior() && params.prior_follows_geometric() {
            passes.min(1)
        } else {
            0
        };
        let geometric = |steps: &mut Vec<Step>, passes: std::ops::RangeInclusive<u32>| {
            for g in passes {
                for &view in views {
                    let base = Step {
                        level,
                        levels,
                        stage: Stage::Geometric(g),
                        view,
                        action: Action::Init,
                    };
                    if g == 1 && params.early_support_points(method) {
                        // The restorer's support points, before the pass changes the
                        // planes: the earlier fit of the per-region choice.
                        for action in [Action::SupportPoints, Action::Triangulate] {
                            steps.push(Step { action, ..base });
                        }
                    }
                    steps.push(base);
                    halves(steps, base, params.geometric_iterations);
                    for action in [Action::Median, Action::Measure] {
                        steps.push(Step { action, ..base });
                    }
                }
            }
        };
        geometric(&mut steps, 1..=passes_before);
        if method.has_planar_prior() {
            for &view in views {
                let base = Step {
                    level,
                    levels,
                    stage: Stage::Planar,
                    view,
                    action: Action::SupportPoints,
                };
                for action in [
                    Action::SupportPoints,
                    Action::Triangulate,
                    Action::PriorPlane,
                    Action::Init,
                ] {
                    steps.push(Step { action, ..base });
                }
                halves(&mut steps, base, params.prior_iterations);
                steps.push(Step {
                    action: Action::Median,
                    ..base
                });
            }
        }
        geometric(&mut steps, passes_before + 1..=passes);
    }
    // The median filters the final depth maps (the paper); every pass's, if asked (the
    // original code).
    let last = steps.last().map(|s| (s.level, s.stage));
    steps.retain(|s| {
        s.action != Action::Median || params.median_every_pass || Some((s.level, s.stage)) == last
    });
    steps
}

/// The same steps with each stage's views interleaved: a stage's first action for every
/// view, then its second for every view, and so on. A stage's views are independent (each
/// reads the previous stage's depth snapshot), so this order gives the same maps; it lets a
/// batch run submit the views' passes of one action together (see [`Session::step_views`]).
pub fn interleave(steps: &[Step]) -> Vec<Step> {
    interleave_by(steps, &|_| 0)
}

/// [`interleave`] within each group of views (`group(view)`: a batch of a session streaming
/// its views through the device), the groups in order of first appearance in each stage.
pub fn interleave_by(steps: &[Step], group: &dyn Fn(usize) -> usize) -> Vec<Step> {
    let mut out = Vec::with_capacity(steps.len());
    let mut start = 0;
    while start < steps.len() {
        let (level, stage) = (steps[start].level, steps[start].stage);
        let end = steps[start..]
            .iter()
            .position(|s| (s.level, s.stage) != (level, stage))
            .map_or(steps.len(), |p| start + p);
        // The stage's units in order of first appearance, each its view's steps in order.
        let mut units: Vec<Vec<Step>> = Vec::new();
        for s in &steps[start..end] {
            match units.iter_mut().find(|u| u[0].view == s.view) {
                Some(u) => u.push(*s),
                None => units.push(vec![*s]),
            }
        }
        let mut groups: Vec<usize> = Vec::new();
        for u in &units {
            let g = group(u[0].view);
            if !groups.contains(&g) {
                groups.push(g);
            }
        }
        for g in groups {
            let members: Vec<&Vec<Step>> = units.iter().filter(|u| group(u[0].view) == g).collect();
            let longest = members.iter().map(|u| u.len()).max().unwrap_or(0);
            for k in 0..longest {
                out.extend(members.iter().filter_map(|u| u.get(k)));
            }
        }
        start = end;
    }
    out
}

/// The stages of a schedule in order, as (level, stage): the same for every view.
pub fn stage_order(method: Method, params: &Params, levels: u32) -> Vec<(u32, Stage)> {
    let mut out: Vec<(u32, Stage)> = Vec::new();
    for s in build_schedule(method, params, &[0], levels) {
        if out.last() != Some(&(s.level, s.stage)) {
            out.push((s.level, s.stage));
        }
    }
    out
}
