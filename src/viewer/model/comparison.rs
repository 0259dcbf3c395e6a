//! Compare: every method's run toward the same point (or its end), reusing the main or a
//! parked session where it already stands there, and scored against ground truth like
//! `mvscope eval`.

use super::*;

/// Every method on the same scene and parameters, each run to the end or to the step
/// the main session stands at (where that method's schedule has the same step).
pub struct Comparison {
    pub runs: Vec<ComparisonRun>,
    /// Follow the main session's last step instead of running to the end.
    pub follow: bool,
    /// The step the runs stop after (`None`: the end).
    pub at: Option<Step>,
    /// When the runs were (re)started, and the steps they had then: for the ETA.
    pub(super) started: Instant,
    pub(super) done_at_start: usize,
}

/// Where a compared method's maps come from.
pub enum RunSource {
    /// A session of its own, running toward the target.
    Own(Box<Session>),
    /// The main session, which already stands where the comparison asks (its results are
    /// reused, not recomputed).
    Main,
    /// Finished: the maps were read and the session let go (its device memory with it).
    Finished,
    /// The session of this method parked by a method switch, which already stands where
    /// the comparison asks (a finished run is read, not run again).
    Parked,
}

/// Accuracy against ground truth as `mvscope eval` scores it (the same functions): shares
/// within 1% and 2% relative depth error, overall and on the weak-texture mask's pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Score {
    pub within1: f64,
    pub within2: f64,
    pub weak1: Option<f64>,
    pub weak2: Option<f64>,
}

impl Score {
    /// Scores `depth` against `truth` (already at the depth's size), with `weak` the
    /// weak-texture mask at that size where known.
    pub fn of(depth: &[f32], truth: &[f32], weak: Option<&[bool]>) -> Score {
        use crate::eval::depth_accuracy_relative as rel;
        let weak_share = |t: f64| {
            weak.filter(|m| m.iter().any(|&b| b))
                .map(|m| rel(depth, truth, Some(m), t).within)
        };
        Score {
            within1: rel(depth, truth, None, 0.01).within,
            within2: rel(depth, truth, None, 0.02).within,
            weak1: weak_share(0.01),
            weak2: weak_share(0.02),
        }
    }
}

/// One view's depth where a compared run stopped.
#[derive(Clone, Debug)]
pub struct DepthMap {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
}

pub struct ComparisonRun {
    pub method: Method,
    pub source: RunSource,
    /// Where this run stops (steps run).
    pub target: usize,
    /// Whether its schedule has the step compared at (else it is shown at its end).
    pub matched: bool,
    /// The step label it stopped at (after it finished).
    pub stopped: Option<String>,
    /// Steps run when it stopped.
    pub cursor: usize,
    /// Each view's depth where it stopped (empty until it has).
    pub depths: Vec<Option<DepthMap>>,
    /// Those depths on their way from the device (the run has reached its target).
    pub(super) reading: Option<Vec<Pending<Option<PlanesCosts>>>>,
    /// Each view's score against ground truth, and all views' pixels pooled (as `mvscope
    /// eval`'s overall line).
    pub scores: Vec<Option<Score>>,
    pub overall: Option<Score>,
    /// All views' pixels split by what the sources see (`eval::seen_by_sources`, as `mvscope
    /// eval` splits them), where every map is at its view's size (the finest scale).
    pub seen: Option<crate::eval::SeenScore>,
}

impl ComparisonRun {
    pub(super) fn retarget_own(session: &mut Session, at: Option<Step>) -> (usize, bool) {
        let schedule = session.schedule();
        let found = at.and_then(|step| schedule.iter().position(|s| *s == step));
        let target = found.map_or(schedule.len(), |i| i + 1);
        if target < session.cursor() {
            session.rewind(target);
        }
        (target, at.is_none() || found.is_some())
    }

    /// Whether its maps are read and scored.
    pub fn done(&self) -> bool {
        !self.depths.is_empty() && self.reading.is_none()
    }

    /// Steps run toward the target (its own session's; the others have none to run).
    pub(super) fn progress(&self) -> (usize, usize) {
        match &self.source {
            RunSource::Own(s) => (s.cursor().min(self.target), self.target),
            _ => (self.target, self.target),
        }
    }
}

impl Comparison {
    pub fn is_finished(&self) -> bool {
        self.runs.iter().all(ComparisonRun::done)
    }

    /// Steps run over steps to run, across the methods that run their own sessions.
    pub fn progress(&self) -> (usize, usize) {
        self.runs.iter().fold((0, 0), |(a, b), r| {
            let (x, y) = r.progress();
            (a + x, b + y)
        })
    }

    /// Seconds left at the rate so far (None until a step has run).
    pub fn eta(&self) -> Option<f64> {
        let (done, total) = self.progress();
        let run = done.checked_sub(self.done_at_start)?;
        if run == 0 {
            return None;
        }
        let rate = self.started.elapsed().as_secs_f64() / run as f64;
        Some(rate * (total - done) as f64)
    }
}

/// What a load produced: the scene or a message for the window.
pub type LoadResult = Result<Loaded, String>;

impl Model {
    /// Starts comparing every method (the Compare tab's button) on the open scene with the
    /// current parameters. A method whose results the main session already has where the
    /// comparison asks is not recomputed.
    pub fn start_comparison(&mut self) {
        if self.loaded.is_none() {
            return;
        }
        self.clear_switch_notice();
        let mut runs = Vec::new();
        for method in Method::ALL {
            runs.push(ComparisonRun {
                method,
                source: RunSource::Finished,
                target: 0,
                matched: true,
                stopped: None,
                cursor: 0,
                depths: Vec::new(),
                reading: None,
                scores: Vec::new(),
                overall: None,
                seen: None,
            });
        }
        self.comparison = Some(Comparison {
            runs,
            follow: false,
            at: None,
            started: Instant::now(),
            done_at_start: 0,
        });
        self.retarget_comparison(None);
    }

    /// Whether the main session stands where a comparison at `at` asks for `method`.
    pub(super) fn main_has(&self, method: Method, at: Option<Step>) -> bool {
        let Some(session) = &self.session else {
            return false;
        };
        method == self.method
            && match at {
                None => session.is_finished(),
                Some(step) => self.current_step() == Some(step),
            }
    }

    /// The parked session of `method` if it stands where a comparison at `at` asks, with the
    /// current parameters.
    pub(super) fn parked_at(&self, method: Method, at: Option<Step>) -> Option<&Session> {
        let session = self.parked.get(&method)?;
        let stands = match at {
            None => session.is_finished(),
            Some(step) => {
                session
                    .cursor()
                    .checked_sub(1)
                    .and_then(|i| session.schedule().get(i))
                    == Some(&step)
            }
        };
        (stands && session.params() == &self.params_for(method)).then_some(session)
    }

    /// Points every compared run at `at` (None: the end), reusing the main session where it
    /// stands there and starting sessions where needed.
    pub(super) fn retarget_comparison(&mut self, at: Option<Step>) {
        let Some(mut cmp) = self.comparison.take() else {
            return;
        };
        cmp.at = at;
        for run in &mut cmp.runs {
            run.depths.clear();
            run.reading = None;
            run.scores.clear();
            run.overall = None;
            run.seen = None;
            run.stopped = None;
            if self.main_has(run.method, at) {
                run.source = RunSource::Main;
                run.target = self.cursor();
                run.matched = true;
                continue;
            }
            if let Some(parked) = self.parked_at(run.method, at) {
                run.source = RunSource::Parked;
                run.target = parked.cursor();
                run.matched = true;
                continue;
            }
            if !matches!(run.source, RunSource::Own(_)) {
                match self.new_session(run.method) {
                    Ok(mut session) => {
                        // Beside the main session: they step back only when the comparison
                        // follows the main run backwards, so they hold less.
                        session
                            .set_checkpoint_budget(crate::session::DEFAULT_CHECKPOINT_BUDGET / 4);
                        run.source = RunSource::Own(Box::new(session));
                    }
                    Err(e) => {
                        // The comparison cannot go on without this run: it ends here, and
                        // the message says why.
                        self.error = Some(e);
                        self.version += 1;
                        return;
                    }
                }
            }
            if let RunSource::Own(session) = &mut run.source {
                let (target, matched) = ComparisonRun::retarget_own(session, at);
                run.target = target;
                run.matched = matched;
            }
        }
        cmp.started = Instant::now();
        cmp.done_at_start = cmp.progress().0;
        self.comparison = Some(cmp);
        self.version += 1;
    }

    /// Compares at the main session's last step (`true`) or at the end of each run.
    pub fn set_comparison_follow(&mut self, follow: bool) {
        let at = if follow { self.current_step() } else { None };
        if let Some(cmp) = &mut self.comparison {
            cmp.follow = follow;
        }
        self.retarget_comparison(at);
    }

    /// Runs the compared methods' own sessions toward their targets for at most `budget`
    /// (never waiting for the device), asks for a run's maps when it gets there and scores
    /// them when they arrive. Returns whether there is more to do.
    pub(super) fn tick_comparison(&mut self, budget: Duration) -> bool {
        let start = Instant::now();
        let current = self.current_step();
        let Some(cmp) = &self.comparison else {
            return false;
        };
        if cmp.follow && cmp.at != current {
            self.retarget_comparison(current);
        }
        let Some(mut cmp) = self.comparison.take() else {
            return false;
        };
        let ctx = self.ctx.clone();
        let mut more = false;
        for run in &mut cmp.runs {
            if run.done() {
                continue;
            }
            if run.reading.is_none() {
                if let RunSource::Own(session) = &mut run.source {
                    while session.cursor() < run.target {
                        if !session.next_step_ready() {
                            more = true;
                            break;
                        }
                        if let Err(e) = session.step() {
                            self.error = Some(format!("{}: {e}", run.method));
                            return false;
                        }
                        if start.elapsed() >= budget {
                            more = true;
                            break;
                        }
                    }
                    if more {
                        break;
                    }
                }
                let session = match &run.source {
                    RunSource::Own(s) => s,
                    RunSource::Main => match &self.session {
                        Some(s) => s,
                        None => continue,
                    },
                    // Switched to since: it is the main session now.
                    RunSource::Parked => match self.parked.get(&run.method) {
                        Some(s) => s,
                        None if run.method == self.method => match &self.session {
                            Some(s) => s,
                            None => continue,
                        },
                        None => continue,
                    },
                    RunSource::Finished => continue,
                };
                let views = session.level_scene(0).views.len();
                let reads: Result<Vec<_>, _> = (0..views)
                    .map(|v| session.request_planes_and_costs(v))
                    .collect();
                match reads {
                    Ok(r) => run.reading = Some(r),
                    Err(e) => {
                        self.error = Some(format!("{}: {e}", run.method));
                        return false;
                    }
                }
                run.cursor = session.cursor();
                run.stopped = Some(
                    session
                        .cursor()
                        .checked_sub(1)
                        .and_then(|i| session.schedule().get(i))
                        .map(|s| s.label())
                        .unwrap_or_else(|| "not started".into()),
                );
            }
            let Some(reads) = &mut run.reading else {
                continue;
            };
            if !reads.iter().all(|r| r.is_ready(&ctx)) {
                more = true;
                continue;
            }
            let mut depths = Vec::with_capacity(reads.len());
            for r in reads.iter_mut() {
                match taken(r.take(&ctx)) {
                    Ok(m) => depths.push(m.map(|m| DepthMap {
                        width: m.width,
                        height: m.height,
                        depth: m.plane.iter().map(|p| p[3]).collect(),
                    })),
                    Err(e) => {
                        self.error = Some(format!("{}: {e}", run.method));
                        return false;
                    }
                }
            }
            run.reading = None;
            run.depths = depths;
            self.score_run(run);
            // At the end there is nowhere else to go: let the session go.
            if !cmp.follow && matches!(run.source, RunSource::Own(_)) {
                run.source = RunSource::Finished;
            }
            self.version += 1;
        }
        self.comparison = Some(cmp);
        more
    }

    /// Scores a run's depths against the ground truth, per view and pooled.
    pub(super) fn score_run(&self, run: &mut ComparisonRun) {
        let Some(loaded) = &self.loaded else {
            return;
        };
        let (mut all_d, mut all_t, mut all_w) = (Vec::new(), Vec::new(), Vec::new());
        let mut any_weak = false;
        run.scores = run
            .depths
            .iter()
            .enumerate()
            .map(|(v, d)| {
                let d = d.as_ref()?;
                let gt = loaded.ground_truth.get(v)?.as_ref()?;
                let t = gt.resampled(d.width, d.height);
                let w = gt.weak_resampled(d.width, d.height);
                any_weak |= w.is_some();
                all_w.extend(w.clone().unwrap_or_else(|| vec![false; t.len()]));
                all_d.extend_from_slice(&d.depth);
                all_t.extend_from_slice(&t);
                Some(Score::of(&d.depth, &t, w.as_deref()))
            })
            .collect();
        run.overall = (!all_t.is_empty())
            .then(|| Score::of(&all_d, &all_t, any_weak.then_some(all_w.as_slice())));
        run.seen = seen_split(loaded, &run.depths);
    }

    /// The chosen view's depth for each compared method where its run stopped.
    pub fn comparison_depths(&self) -> Vec<(Method, Option<&DepthMap>)> {
        let Some(cmp) = &self.comparison else {
            return Vec::new();
        };
        cmp.runs
            .iter()
            .map(|r| (r.method, r.depths.get(self.view).and_then(Option::as_ref)))
            .collect()
    }
}

/// The pooled scores split by what the sources see, as `mvscope eval` splits them
/// (`Loaded::seen_by_sources`, `eval::seen_score`): `None` unless every map is at its view's
/// size (a coarser scale has no cameras of its own here) and some view has truth.
fn seen_split(loaded: &Loaded, depths: &[Option<DepthMap>]) -> Option<crate::eval::SeenScore> {
    let views = &loaded.scene.views;
    let at_size = |v: usize, d: &DepthMap| {
        views
            .get(v)
            .is_some_and(|s| (s.image.width, s.image.height) == (d.width, d.height))
    };
    if !depths
        .iter()
        .enumerate()
        .all(|(v, d)| d.as_ref().is_none_or(|d| at_size(v, d)))
    {
        return None;
    }
    let by_sources = loaded.seen_by_sources();
    let (mut est, mut truth, mut seen, mut weak) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut any_weak = false;
    for (v, d) in depths.iter().enumerate() {
        let (Some(d), Some(Some(t)), Some(Some(s))) =
            (d, by_sources.truths.get(v), by_sources.seen.get(v))
        else {
            continue;
        };
        let w = loaded
            .ground_truth
            .get(v)
            .and_then(Option::as_ref)
            .and_then(|g| g.weak_resampled(d.width, d.height));
        any_weak |= w.is_some();
        weak.extend(w.unwrap_or_else(|| vec![false; t.len()]));
        est.extend_from_slice(&d.depth);
        truth.extend_from_slice(t);
        seen.extend_from_slice(s);
    }
    crate::eval::seen_score(&est, &truth, &seen, any_weak.then_some(weak.as_slice()))
}
