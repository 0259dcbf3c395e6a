//! The session's schedule as a tree: scale > stage > view > iteration > half, and where "one
//! iteration", "one stage"... ends from a given point.

use crate::session::{Action, Stage, Step};

/// How far one press of a step button goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// One step: a red or black half-iteration, or an init/median/upsample/restore step.
    Half,
    /// To the end of the current iteration (both halves).
    Iteration,
    /// To the end of the current view's work in this stage.
    View,
    /// To the end of the current stage (all views).
    Stage,
    /// To the end of the current scale.
    Scale,
}

impl Unit {
    pub const ALL: [Unit; 5] = [
        Unit::Half,
        Unit::Iteration,
        Unit::View,
        Unit::Stage,
        Unit::Scale,
    ];

    pub fn title(self) -> &'static str {
        match self {
            Unit::Half => "half",
            Unit::Iteration => "iteration",
            Unit::View => "view",
            Unit::Stage => "stage",
            Unit::Scale => "scale",
        }
    }
}

/// The key two steps share when they belong to the same `unit`.
fn same(unit: Unit, a: &Step, b: &Step) -> bool {
    let scale = a.level == b.level;
    let stage = scale && a.stage == b.stage;
    let view = stage && a.view == b.view;
    match unit {
        Unit::Half => false,
        Unit::Iteration => {
            view && match (a.action, b.action) {
                (Action::Half { iteration: i, .. }, Action::Half { iteration: j, .. }) => i == j,
                _ => false,
            }
        }
        Unit::View => view,
        Unit::Stage => stage,
        Unit::Scale => scale,
    }
}

/// The cursor after running one `unit` from `cursor` (steps run so far): the end of the
/// group that the next step belongs to.
pub fn advance(schedule: &[Step], cursor: usize, unit: Unit) -> usize {
    let Some(first) = schedule.get(cursor) else {
        return schedule.len();
    };
    let mut end = cursor + 1;
    while end < schedule.len() && same(unit, first, &schedule[end]) {
        end += 1;
    }
    end
}

/// The cursor before the group of `unit` that the last run step belongs to (stepping back
/// by one `unit`).
pub fn retreat(schedule: &[Step], cursor: usize, unit: Unit) -> usize {
    if cursor == 0 || schedule.is_empty() {
        return 0;
    }
    let last = &schedule[cursor.min(schedule.len()) - 1];
    let mut start = cursor.min(schedule.len()) - 1;
    while start > 0 && same(unit, last, &schedule[start - 1]) {
        start -= 1;
    }
    start
}

/// A node of the timeline tree: a contiguous range of steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    pub title: String,
    /// Steps `range.start..range.end` of the schedule.
    pub range: std::ops::Range<usize>,
    pub children: Vec<Group>,
}

/// Order of a step's action within its view's work of a stage (iterations in order).
fn action_rank(a: Action) -> (u32, u32, u32) {
    match a {
        Action::Upsample => (0, 0, 0),
        Action::SupportPoints => (0, 1, 0),
        Action::Triangulate => (0, 2, 0),
        Action::PriorPlane => (0, 3, 0),
        Action::Init => (1, 0, 0),
        Action::Half { iteration, color } => (2, iteration, color),
        Action::Median => (3, 0, 0),
        Action::Restore => (4, 0, 0),
        Action::Measure => (5, 0, 0),
    }
}

/// Where a run that stood at `cursor` of `old` stands in `new` (the schedule after a
/// parameter change): after the same step (same scale, stage, view and action) when `new`
/// has it; with fewer iterations, after the last step of that view's stage work that comes
/// no later; at the end when it was at the end. A step number alone would land elsewhere
/// once the number of iterations changes.
pub fn same_point(old: &[Step], cursor: usize, new: &[Step]) -> usize {
    if cursor == 0 {
        return 0;
    }
    if cursor >= old.len() {
        return new.len();
    }
    let last = old[cursor - 1];
    if let Some(i) = new.iter().position(|s| *s == last) {
        return i + 1;
    }
    let group: Vec<usize> = (0..new.len())
        .filter(|&i| {
            let s = &new[i];
            s.level == last.level && s.stage == last.stage && s.view == last.view
        })
        .collect();
    match group
        .iter()
        .rev()
        .find(|&&i| action_rank(new[i].action) <= action_rank(last.action))
    {
        Some(&i) => i + 1,
        None => group.first().copied().unwrap_or(cursor.min(new.len())),
    }
}

fn stage_title(stage: Stage) -> String {
    match stage {
        // ACMH, DWTA, or ACMM's coarsest scale: the same photometric stage.
        Stage::Photometric => "photometric".into(),
        Stage::Restorer => "detail restorer".into(),
        Stage::Planar => "planar prior".into(),
        Stage::Geometric(g) => format!("geometric consistency {g}"),
    }
}

fn action_title(action: Action) -> String {
    match action {
        Action::Upsample => "joint bilateral upsampling".into(),
        Action::Init => "init".into(),
        Action::Half { color, .. } => if color == 0 { "red" } else { "black" }.into(),
        Action::Median => "median filter".into(),
        Action::Restore => "restore details".into(),
        Action::Measure => "measure reprojection error".into(),
        Action::SupportPoints => "support points".into(),
        Action::Triangulate => "triangulate".into(),
        Action::PriorPlane => "prior plane".into(),
    }
}

/// Splits `range` into runs of equal `key`.
fn runs<K: PartialEq>(
    schedule: &[Step],
    range: std::ops::Range<usize>,
    key: impl Fn(&Step) -> K,
) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = range.start;
    for i in range.clone() {
        if i + 1 == range.end || key(&schedule[i + 1]) != key(&schedule[i]) {
            out.push(start..i + 1);
            start = i + 1;
        }
    }
    out
}

/// The schedule as a tree: scale > stage > view > iteration (halves as leaves; the other
/// actions are leaves at the iteration level).
pub fn tree(schedule: &[Step]) -> Vec<Group> {
    let leaf = |i: usize| Group {
        title: action_title(schedule[i].action),
        range: i..i + 1,
        children: Vec::new(),
    };
    runs(schedule, 0..schedule.len(), |s| s.level)
        .into_iter()
        .map(|scale| {
            let s0 = schedule[scale.start];
            Group {
                title: format!("scale {}/{}", s0.level + 1, s0.levels),
                range: scale.clone(),
                children: runs(schedule, scale, |s| s.stage)
                    .into_iter()
                    .map(|stage| Group {
                        title: stage_title(schedule[stage.start].stage),
                        range: stage.clone(),
                        children: runs(schedule, stage, |s| s.view)
                            .into_iter()
                            .map(|view| Group {
                                title: format!("view {}", schedule[view.start].view),
                                range: view.clone(),
                                children: runs(schedule, view, |s| match s.action {
                                    Action::Half { iteration, .. } => Some(iteration),
                                    _ => None,
                                })
                                .into_iter()
                                .flat_map(|it| match schedule[it.start].action {
                                    Action::Half { iteration, .. } => vec![Group {
                                        title: format!("iteration {iteration}"),
                                        range: it.clone(),
                                        children: it.map(leaf).collect(),
                                    }],
                                    _ => it.map(leaf).collect(),
                                })
                                .collect(),
                            })
                            .collect(),
                    })
                    .collect(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acmm::params::{Method, Params};
    use crate::session::build_schedule;

    fn schedule() -> Vec<Step> {
        let params = Params {
            iterations: 2,
            coarse_iterations: 2,
            restorer_iterations: 2,
            geometric_iterations: 1,
            geometric_passes: 1,
            ..Params::default()
        };
        build_schedule(Method::Acmm, &params, &[0, 1], 2)
    }

    #[test]
    fn advance_ends_groups() {
        let s = schedule();
        // Step 0 is the init of view 0: one "half" is one step, an iteration is the init.
        assert_eq!(s[0].action, Action::Init);
        assert_eq!(advance(&s, 0, Unit::Half), 1);
        assert_eq!(advance(&s, 0, Unit::Iteration), 1);
        // From the first red half: both halves of iteration 1.
        assert_eq!(
            s[1].action,
            Action::Half {
                iteration: 1,
                color: 0
            }
        );
        assert_eq!(advance(&s, 1, Unit::Iteration), 3);
        // A view's stage work ends where view 1 starts.
        let v = advance(&s, 0, Unit::View);
        assert_eq!(s[v].view, 1);
        assert_eq!(s[v - 1].view, 0);
        // A stage ends where the next stage starts; a scale where level 1 starts.
        let st = advance(&s, 0, Unit::Stage);
        assert_ne!(s[st].stage, s[0].stage);
        let sc = advance(&s, 0, Unit::Scale);
        assert_eq!(s[sc].level, 1);
        assert_eq!(s[sc - 1].level, 0);
        assert_eq!(advance(&s, s.len(), Unit::Scale), s.len());
        assert_eq!(advance(&s, sc, Unit::Scale), s.len());
    }

    #[test]
    fn a_parameter_change_returns_to_the_same_point_of_the_schedule() {
        let old = schedule();
        let more = build_schedule(
            Method::Acmm,
            &Params {
                iterations: 4,
                coarse_iterations: 4,
                restorer_iterations: 4,
                geometric_iterations: 1,
                geometric_passes: 1,
                ..Params::default()
            },
            &[0, 1],
            2,
        );
        // Every step of the old schedule is in the longer one: the same step, not the same
        // number.
        for c in 1..old.len() {
            let n = same_point(&old, c, &more);
            assert_eq!(more[n - 1], old[c - 1], "cursor {c}");
        }
        assert_eq!(same_point(&old, old.len(), &more), more.len());
        assert_eq!(same_point(&old, 0, &more), 0);
        // Fewer iterations: iteration 3 of a view ends up after that view's last iteration.
        let c = more
            .iter()
            .position(|s| {
                s.level == 1
                    && s.view == 1
                    && s.action
                        == Action::Half {
                            iteration: 3,
                            color: 1,
                        }
            })
            .unwrap()
            + 1;
        let n = same_point(&more, c, &old);
        let at = old[n - 1];
        assert_eq!((at.level, at.view, at.stage), (1, 1, more[c - 1].stage));
        assert_eq!(
            at.action,
            Action::Half {
                iteration: 2,
                color: 1
            }
        );
    }

    #[test]
    fn retreat_inverts_advance() {
        let s = schedule();
        for unit in Unit::ALL {
            let mut c = 0;
            while c < s.len() {
                let next = advance(&s, c, unit);
                assert!(next > c);
                assert_eq!(retreat(&s, next, unit), c, "{unit:?} at {c}");
                c = next;
            }
        }
    }

    #[test]
    fn tree_covers_the_schedule_in_order() {
        let s = schedule();
        let t = tree(&s);
        assert_eq!(t.len(), 2);
        let mut leaves = Vec::new();
        fn walk(g: &Group, out: &mut Vec<usize>) {
            if g.children.is_empty() {
                out.extend(g.range.clone());
            }
            for c in &g.children {
                assert!(c.range.start >= g.range.start && c.range.end <= g.range.end);
                walk(c, out);
            }
        }
        for g in &t {
            walk(g, &mut leaves);
        }
        assert_eq!(leaves, (0..s.len()).collect::<Vec<_>>());
        assert_eq!(t[0].title, "scale 1/2");
        assert_eq!(t[1].children[0].title, "detail restorer");
        let view0 = &t[0].children[0].children[0];
        assert_eq!(view0.title, "view 0");
        assert_eq!(view0.children[1].title, "iteration 1");
        assert_eq!(view0.children[1].children.len(), 2);
    }
}
