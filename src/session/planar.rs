//! The planar prior's steps of a view (support points, triangulation, prior planes) on the
//! device and the host.

use super::*;
use crate::acmm::planar::{
    choose_regions, fit_regions, flat_noise_variance, oracle_errors, oracle_errors_admitting,
    support_points_with,
};
use crate::eval::resample_nearest;

/// The planar prior's steps (ACMP-REFERENCE.md §2-3) for one view: the support points on the
/// device (checked against the other views' depths first, when `prior_consistency` asks), their triangulation on the host (the points read back, the triangles uploaded),
/// then every pixel's prior plane on the device, kept with the view's marks. With `oracle`
/// the support points are judged by, or take their depths from, the truth (a diagnosis).
/// `gray`: the reference's intensities at the step's level, which Regions' edge rule reads
/// (`prior_region_edge`) and the flat test's noise is estimated from (`prior_flat_noise`).
#[allow(clippy::too_many_arguments)]
pub(super) fn planar_step(
    ctx: &GpuContext,
    pipelines: &AcmhPipelines,
    params: &Params,
    problem: &ViewProblem,
    resident: &mut Resident,
    step: Step,
    oracle: Option<(PriorOracle, &TruthDepth, u32)>,
    gray: Option<&[f32]>,
) -> Result<(), SessionError> {
    let pipes = &pipelines.planar;
    if resident
        .planar
        .as_ref()
        .is_none_or(|p| p.cell() != params.prior_cell)
    {
        resident.planar = Some(PlanarBuffers::new(
            ctx,
            pipes,
            &resident.solver,
            params.prior_cell,
        )?);
    }
    let Some(planar) = resident.planar.as_ref() else {
        return Ok(());
    };
    match step.action {
        Action::SupportPoints => {
            if params.prior_consistency > 0.0 {
                // Against the snapshot of the stage before: every view's result of it.
                resident
                    .solver
                    .measure_consistency(ctx, pipelines, problem, params);
                if params.prior_support_views > 1 {
                    // Support points (and anchors) only where enough sources agree.
                    resident.solver.mark_few_views(
                        ctx,
                        pipelines,
                        problem,
                        params,
                        params.prior_support_views,
                    );
                }
                if params.prior_confirmed_points {
                    // The support points rank the consistent pixels by agreeing sources.
                    resident
                        .solver
                        .rank_confirmed(ctx, pipelines, problem, params);
                }
            }
            if params.prior_flat_points || params.prior_regions {
                // Which windows are flat, for the cells without a low-cost point. The
                // spread takes the first extra map: the restorer's difference is gone. With
                // `prior_flat_noise` it is the spread beyond the image's own noise.
                let (w, h) = resident.solver.size();
                let noise_var = gray.map_or(0.0, |g| flat_noise_variance(params, g, w, h));
                resident
                    .solver
                    .measure_spread(ctx, pipelines, problem, params, noise_var);
                resident.marks.difference = false;
            }
            planar.support_points(ctx, pipes, problem, params);
            resident.points = Some(planar.request_points(ctx));
        }
        Action::Triangulate => {
            let read = resident.points.take().ok_or_else(|| {
                SessionError::State(format!(
                    "{}: no support points to triangulate (its support-point step has not run)",
                    step.label()
                ))
            })?;
            let records = read.wait(ctx)?;
            if matches!(step.stage, Stage::Geometric(_)) {
                // The per-region choice's earlier points: kept for the prior stage.
                resident.marks.earlier = Some(Arc::new(records));
                return Ok(());
            }
            let (w, h) = resident.solver.size();
            // With the per-region choice, the restorer's points (read as this scale's first
            // geometric pass began) are the triangles' and the earlier fit's; this step's
            // are the later fit's.
            let earlier = resident
                .marks
                .earlier
                .clone()
                .filter(|_| params.prior_regions && params.prior_region_choice);
            if earlier.is_some() && oracle.is_some() {
                return Err(SessionError::Params(format!(
                    "{}: the prior oracle judges one set of support points; turn prior_region_choice off to use it",
                    step.label()
                )));
            }
            let mut points = credible(&records);
            if let Some((oracle, t, _)) = oracle {
                // The truth at this level's size, sampled as the accuracy scores sample it.
                let truth = resample_nearest(&t.depth, t.width, t.height, w, h);
                if oracle == PriorOracle::Select {
                    // Chosen again on the CPU (the reference of the GPU's choice) among the
                    // pixels the estimate has right.
                    let plane: Vec<[f32; 4]> = ctx.read_buffer("plane", &resident.solver.plane)?;
                    let cost: Vec<f32> = ctx.read_buffer("cost", &resident.solver.cost)?;
                    let only_right = Params {
                        prior_consistency: 1.0,
                        ..params.clone()
                    };
                    let errors = oracle_errors(&plane, &truth);
                    // The session's problem holds no intensities (they are on the device):
                    // the flat windows are those the device measured (`measure_spread` above,
                    // into the first extra map).
                    let spread = if params.prior_flat_points || params.prior_regions {
                        Some(resident.solver.download_extra(ctx)?.0)
                    } else {
                        None
                    };
                    let records = support_points_with(
                        problem,
                        &only_right,
                        &plane,
                        &cost,
                        Some(&errors),
                        spread.as_deref(),
                    );
                    points = credible(&records);
                }
                points = apply_oracle(points, w, h, problem.k, &truth, oracle);
            }
            let mut mesh = match earlier.as_deref() {
                Some(e) => triangulate(w, h, problem.k, params, credible(e)),
                // Only the choice reads this step's points after the triangulation.
                None => triangulate(w, h, problem.k, params, std::mem::take(&mut points)),
            };
            if params.prior_regions {
                // One plane per flat region, from its support points.
                mesh.regions = Some(match earlier.as_deref() {
                    // Per region, the earlier fit's planes unless this step's hold more of
                    // the region's points.
                    Some(e) => {
                        let mine = fit_regions(problem, params, e, &mesh.points, gray);
                        let later = fit_regions(problem, params, &records, &points, gray);
                        choose_regions(mine, later, points)
                    }
                    None => fit_regions(problem, params, &records, &mesh.points, gray),
                });
            }
            resident.mesh = Some(mesh);
        }
        Action::PriorPlane => {
            let mesh = resident.mesh.take().ok_or_else(|| {
                SessionError::State(format!(
                    "{}: no triangulation to rasterise (its triangulate step has not run)",
                    step.label()
                ))
            })?;
            let anchors = params.anchors_on();
            let oracle_anchors = anchors
                && oracle.is_some_and(|(o, _, _)| {
                    matches!(o, PriorOracle::Select | PriorOracle::Filter)
                });
            if anchors && params.prior_anchor_views > 1 && !oracle_anchors {
                // Pixels too few sources agree with are not strong.
                resident.solver.mark_few_views(
                    ctx,
                    pipelines,
                    problem,
                    params,
                    params.prior_anchor_views,
                );
            }
            if anchors && params.prior_anchor_distinct && !oracle_anchors {
                // Consistent pixels without a distinct cost minimum are not strong.
                resident
                    .solver
                    .mark_ambiguous(ctx, pipelines, problem, params);
            }
            if let Some((PriorOracle::Select | PriorOracle::Filter, t, admit)) = oracle
                && anchors
            {
                // The anchors too may sit only on pixels the estimate has right (and those
                // pixels need none): what a perfect test of strong pixels would give; with
                // `admit`, also on that share of the real test's false positives.
                let (w, h) = resident.solver.size();
                let truth = resample_nearest(&t.depth, t.width, t.height, w, h);
                let plane: Vec<[f32; 4]> = ctx.read_buffer("plane", &resident.solver.plane)?;
                let errors = if admit > 0 {
                    let (_, real) = resident.solver.download_extra(ctx)?;
                    oracle_errors_admitting(
                        &plane,
                        &truth,
                        &real,
                        params.prior_consistency,
                        admit,
                        step.view,
                    )
                } else {
                    oracle_errors(&plane, &truth)
                };
                resident
                    .solver
                    .upload_extra(ctx, &vec![0.0; errors.len()], &errors);
            }
            planar.rasterise(
                ctx,
                pipes,
                problem,
                params,
                &mesh.paint_list(problem.k, params),
            )?;
            if anchors {
                // The anchors' codes now fill the first extra map.
                resident.marks.difference = false;
                resident.marks.anchors = true;
            }
            let prior = crate::gpu::acmh::copy_on_device(ctx, "prior copy", &resident.solver.prior);
            resident.marks.planar = Some(Arc::new(PlanarSnapshot { mesh, prior }));
        }
        _ => {}
    }
    Ok(())
}

impl Session {
    /// At the end of a view's prior stage, where only the region planes hold in the
    /// geometric passes (Regions' `prior_region_hold` with `prior_hold_regions_only`): the
    /// view's prior planes become those of its flat regions alone (`held_prior`, the CPU reference of `PlanarBuffers::keep_regions`).
    /// The prior-assisted pass has used them all; what holds afterwards is what many support
    /// points agree on, not a triangle of three (docs/method.md, "Only the region planes
    /// hold"). The view's kept prior (its maps' prior, what a checkpoint from here on
    /// restores) becomes a new copy: the checkpoints taken inside the prior stage keep
    /// every plane.
    pub(super) fn keep_region_planes(&mut self, step: Step) -> Result<(), SessionError> {
        let problem = &self.headers[step.level as usize][step.view];
        let Some(r) = self.residents[step.view].as_mut() else {
            return Ok(());
        };
        let (Some(planar), Some(snapshot)) = (r.planar.as_ref(), r.marks.planar.as_ref()) else {
            return Ok(());
        };
        let list = snapshot.mesh.paint_list(problem.k, &self.params);
        planar.keep_regions(
            &self.ctx,
            &self.pipelines.planar,
            problem,
            &self.params,
            &list,
        )?;
        let held = PlanarSnapshot {
            mesh: snapshot.mesh.clone(),
            prior: crate::gpu::acmh::copy_on_device(&self.ctx, "held prior", &r.solver.prior),
        };
        r.marks.planar = Some(Arc::new(held));
        Ok(())
    }
}
