//! ACMM's multi-scale passes on the GPU against their CPU reference, the Session's stepping,
//! checkpoint and determinism guarantees, and ACMM's accuracy against ACMH.

mod common;

use glam::Vec3;
use mvscope::acmm::cpu::{self, Geometric};
use mvscope::acmm::multiscale::{detail_restorer, joint_bilateral_upsample};
use mvscope::acmm::problem::ViewState;
use mvscope::acmm::{Method, Params, ViewProblem};
use mvscope::gpu::GpuContext;
use mvscope::gpu::acmh::{AcmhPipelines, GpuViewSolver, PassKind};
use mvscope::session::{Action, Session, Stage};
use mvscope::synthetic::{SyntheticOptions, SyntheticScene, generate};

fn scene(views: usize, width: u32, height: u32) -> SyntheticScene {
    generate(&SyntheticOptions {
        views,
        width,
        height,
        seed: 3,
        noise_sigma: 1.0,
        room: false,
        sources: mvscope::scene::geometry::DEFAULT_SOURCES,
    })
    .expect("synthetic scene")
}

fn gpu() -> (GpuContext, AcmhPipelines) {
    let ctx = GpuContext::new().expect("a GPU adapter (install mesa-vulkan-drivers)");
    let pipelines = AcmhPipelines::new(&ctx).expect("shaders compile");
    (ctx, pipelines)
}

/// Planes from the ground truth of a view (camera-frame normals).
fn gt_planes(s: &SyntheticScene, view: usize) -> Vec<[f32; 4]> {
    let cam = &s.scene.views[view].camera;
    let gt = &s.ground_truth[view];
    gt.depth
        .iter()
        .zip(&gt.normal_world)
        .map(|(&d, n)| {
            let c = cam.dir_camera_from_world(Vec3::from_array(*n).as_dvec3());
            [c.x as f32, c.y as f32, c.z as f32, d]
        })
        .collect()
}

fn planes_agree(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    let same = a
        .iter()
        .zip(b)
        .filter(|(p, q)| (0..4).all(|k| (p[k] - q[k]).abs() <= 1e-4 * (1.0 + p[k].abs())))
        .count();
    same as f64 / a.len() as f64
}

#[test]
fn joint_bilateral_upsample_matches_cpu() {
    let fine = scene(3, 48, 36);
    let params = Params::default();
    let coarse_scene = fine.scene.rescaled(0.5);
    let coarse = ViewProblem::new(&coarse_scene, 1, 0);
    // Coarse planes: ground truth at the coarse level (the scene's own cameras there).
    let coarse_gt = generate(&SyntheticOptions {
        views: 3,
        width: 24,
        height: 18,
        seed: 3,
        noise_sigma: 1.0,
        room: false,
        sources: mvscope::scene::geometry::DEFAULT_SOURCES,
    })
    .unwrap();
    let planes = gt_planes(&coarse_gt, 1);
    let problem = ViewProblem::new(&fine.scene, 1, 1);
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    solver.upload_state(&ctx, &ViewState::garbage(48, 36, problem.num_sources()));
    solver.upload_prior(&ctx, &planes);
    solver.upsample(
        &ctx,
        &pipes,
        &problem,
        &params,
        (coarse.width, coarse.height),
        coarse.k,
    );
    let g = solver.download_state(&ctx).unwrap();
    let c = joint_bilateral_upsample(
        &planes,
        24,
        18,
        &problem.images[..48 * 36],
        48,
        36,
        coarse.k,
        problem.k,
        &params,
    );
    assert!(planes_agree(&g.plane, &c) > 0.999);
    // And the upsampled depth is close to the fine ground truth away from edges: measured
    // 85% (1467 of 1728 pixels) within 2% at this size.
    let gt = &fine.ground_truth[1].depth;
    let close = c
        .iter()
        .zip(gt)
        .filter(|(p, d)| (p[3] - **d).abs() < 0.02 * **d)
        .count();
    eprintln!(
        "{close} of {} upsampled depths within 2% of the truth",
        gt.len()
    );
    assert!(close as f64 > 0.75 * gt.len() as f64, "{close}");
}

#[test]
fn geometric_passes_match_cpu() {
    let s = scene(4, 48, 40);
    let problem = ViewProblem::new(&s.scene, 1, 0);
    let params = Params::default();
    let depths = common::source_truth_depths(&s, &problem);
    let geo = Geometric {
        depths: &depths,
        lambda: params.lambda,
        delta: params.delta,
        pass: 1,
    };
    let mut state = ViewState::garbage(48, 40, problem.num_sources());
    cpu::random_init(&problem, &params, &mut state);
    cpu::propagate_half(&problem, &params, Method::Acmh, &mut state, 1, 0);
    cpu::propagate_half(&problem, &params, Method::Acmh, &mut state, 1, 1);
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    solver.upload_depths(&ctx, &problem, &depths);

    // Re-evaluation at the start of a geometric pass, and its reprojection-error map.
    solver.upload_state(&ctx, &state);
    solver.evaluate(&ctx, &pipes, &problem, &params, PassKind::Geometric(1));
    let g = solver.download_state(&ctx).unwrap();
    let (_, g_err) = solver.download_extra(&ctx).unwrap();
    let mut c = state.clone();
    let mut c_err = Vec::new();
    cpu::initialize(
        &problem,
        &params,
        &mut c,
        Some(&geo),
        false,
        Some(&mut c_err),
    );
    assert_eq!(g.plane, c.plane, "evaluation keeps planes");
    let max_cost = g
        .cost
        .iter()
        .zip(&c.cost)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(max_cost < 2e-3, "{max_cost}");
    let max_err = g_err
        .iter()
        .zip(&c_err)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(max_err < 1e-2, "reprojection error differs by {max_err}");

    // A geometric half-iteration.
    for color in [0, 1] {
        solver.upload_state(&ctx, &c);
        solver.propagate_kind(
            &ctx,
            &pipes,
            &problem,
            &params,
            Method::Acmh,
            PassKind::Geometric(1),
            1,
            color,
        );
        let g = solver.download_state(&ctx).unwrap();
        let mut cc = c.clone();
        cpu::propagate_half_with(
            &problem,
            &params,
            Method::Acmh,
            &mut cc,
            Some(&geo),
            None,
            None,
            1,
            color,
        );
        let agree = planes_agree(&g.plane, &cc.plane);
        // Measured: every pixel agrees (1.0 for both colours).
        assert!(agree > 0.99, "{:.2}% agree", agree * 100.0);
    }
}

#[test]
fn reprojection_error_is_small_at_the_truth() {
    let s = scene(3, 64, 48);
    let problem = ViewProblem::new(&s.scene, 1, 0);
    let depths = common::source_truth_depths(&s, &problem);
    let planes = gt_planes(&s, 1);
    let (mut small, mut shifted_small, mut n) = (0, 0, 0);
    for y in (4..44).step_by(3) {
        for x in (4..60).step_by(3) {
            let p = planes[(y * 64 + x) as usize];
            let e = cpu::reprojection_error(&problem, &depths, 0, p, x, y, 3.0);
            let off = [p[0], p[1], p[2], p[3] * 1.1];
            let e2 = cpu::reprojection_error(&problem, &depths, 0, off, x, y, 3.0);
            n += 1;
            small += usize::from(e < 1.0);
            shifted_small += usize::from(e2 < 1.0);
        }
    }
    // Occlusions and image borders give δ; most pixels reproject within a pixel at the
    // truth (measured 226 of 266), almost none after a 10% depth error (measured 2 of 266).
    eprintln!(
        "{small} of {n} reproject within a pixel at the truth, {shifted_small} after a 10% error"
    );
    assert!(small as f64 > 0.6 * n as f64, "{small}/{n}");
    assert!(
        (shifted_small as f64) < 0.2 * n as f64,
        "{shifted_small}/{n}"
    );
}

#[test]
fn detail_restorer_matches_cpu() {
    let s = scene(3, 48, 40);
    let problem = ViewProblem::new(&s.scene, 1, 1);
    let params = Params::default();
    // Photometric ACMH's result, and "upsampled" planes = the truth with noise in one half.
    let mut photo = ViewState::garbage(48, 40, problem.num_sources());
    cpu::random_init(&problem, &params, &mut photo);
    for t in 1..=2 {
        cpu::propagate_half(&problem, &params, Method::Acmh, &mut photo, t, 0);
        cpu::propagate_half(&problem, &params, Method::Acmh, &mut photo, t, 1);
    }
    let mut up = gt_planes(&s, 1);
    for (i, p) in up.iter_mut().enumerate() {
        if i % 48 < 24 {
            p[3] *= 1.0 + 0.2 * ((i % 7) as f32 / 7.0 - 0.5);
        }
    }
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    solver.upload_state(&ctx, &photo);
    solver.upload_prior(&ctx, &up);
    solver.restore(&ctx, &pipes, &problem, &params, PassKind::Photometric);
    let g = solver.download_state(&ctx).unwrap();
    let (g_diff, _) = solver.download_extra(&ctx).unwrap();
    let mut c = photo.clone();
    let (c_diff, c_replaced) = detail_restorer(&problem, &params, &up, &mut c);
    assert!(planes_agree(&g.plane, &c.plane) > 0.995);
    let max = g_diff
        .iter()
        .zip(&c_diff)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(max < 2e-3, "{max}");
    let g_replaced: Vec<bool> = g.aux.iter().map(|a| a & (1 << 16) != 0).collect();
    let same = g_replaced
        .iter()
        .zip(&c_replaced)
        .filter(|(a, b)| a == b)
        .count();
    assert!(same as f64 > 0.995 * c_replaced.len() as f64);
    // The perturbed half is replaced far more often than the true half.
    let rate = |left: bool| {
        let (mut r, mut n) = (0, 0);
        for (i, &rep) in c_replaced.iter().enumerate() {
            if (i % 48 < 24) == left {
                n += 1;
                r += usize::from(rep);
            }
        }
        r as f64 / n as f64
    };
    assert!(
        rate(true) > rate(false) + 0.1,
        "{} vs {}",
        rate(true),
        rate(false)
    );
}

#[test]
fn gated_detail_restorer_matches_cpu() {
    restorer_from_upsampled_matches_cpu(true);
}

#[test]
fn refining_detail_restorer_matches_cpu() {
    restorer_from_upsampled_matches_cpu(false);
}

fn restorer_from_upsampled_matches_cpu(gated: bool) {
    let kind = PassKind::Restorer { gated };
    let s = scene(3, 48, 40);
    let problem = ViewProblem::new(&s.scene, 1, 1);
    let params = Params::default();
    // "Upsampled" planes: the truth, with depth errors of up to ±10% in the left half.
    let mut up = gt_planes(&s, 1);
    for (i, p) in up.iter_mut().enumerate() {
        if i % 48 < 24 {
            p[3] *= 1.0 + 0.2 * ((i % 7) as f32 / 7.0 - 0.5);
        }
    }
    let mut state = ViewState::garbage(48, 40, problem.num_sources());
    state.plane = up.clone();
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    solver.upload_state(&ctx, &state);
    solver.evaluate(&ctx, &pipes, &problem, &params, kind);
    let g = solver.download_state(&ctx).unwrap();
    let (g_init, g_photo) = solver.download_extra(&ctx).unwrap();
    let mut c = state.clone();
    let mut gate = cpu::restorer_init(&problem, &params, &mut c, gated);
    assert_eq!(g.plane, c.plane, "the start keeps the upsampled planes");
    assert_eq!(g.aux, c.aux);
    let max_init = g_init
        .iter()
        .zip(&gate.c_init)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(max_init < 2e-3, "C_init differs by {max_init}");
    assert!(g_photo.iter().all(|&v| v == cpu::MAX_COST));

    // Gated half-iterations, each from the CPU's state (as the half-step tests do).
    for (t, color) in [(1, 0), (1, 1), (2, 0), (2, 1)] {
        solver.upload_state(&ctx, &c);
        solver.upload_extra(&ctx, &gate.c_init, &gate.c_photo);
        solver.propagate_kind(
            &ctx,
            &pipes,
            &problem,
            &params,
            Method::Acmh,
            kind,
            t,
            color,
        );
        let g = solver.download_state(&ctx).unwrap();
        let (_, g_photo) = solver.download_extra(&ctx).unwrap();
        cpu::propagate_half_with(
            &problem,
            &params,
            Method::Acmh,
            &mut c,
            None,
            Some(&mut gate),
            None,
            t,
            color,
        );
        let agree = planes_agree(&g.plane, &c.plane);
        // Measured: every pixel agrees.
        assert!(agree > 0.99, "{:.2}% agree", agree * 100.0);
        let same_bit = g
            .aux
            .iter()
            .zip(&c.aux)
            .filter(|(a, b)| (*a & cpu::REPLACED_BIT) == (*b & cpu::REPLACED_BIT))
            .count();
        assert!(same_bit as f64 > 0.99 * c.aux.len() as f64);
        let photo_close = g_photo
            .iter()
            .zip(&gate.c_photo)
            .filter(|(a, b)| (*a - *b).abs() < 2e-3)
            .count();
        assert!(photo_close as f64 > 0.99 * c.aux.len() as f64);
    }
    // Gated, no pixel left its plane without beating C_init by ξ; ungated, every pixel
    // may be refined.
    let moved = (0..c.plane.len()).filter(|&i| c.plane[i] != up[i]).count();
    eprintln!(
        "gated {gated}: {moved} of {} pixels left the upsampled plane",
        c.plane.len()
    );
    for (i, upsampled) in up.iter().enumerate() {
        if !gated {
            break;
        }
        if c.aux[i] & cpu::REPLACED_BIT == 0 {
            assert_eq!(
                &c.plane[i], upsampled,
                "pixel {i} moved without passing the gate"
            );
        } else {
            assert!(c.cost[i] < gate.c_init[i] - params.xi + 1e-6, "pixel {i}");
        }
    }
    assert!(moved > 0);
    // The erroneous half is replaced more often than the true half.
    let mut marked = c.clone();
    let (_, replaced) = mvscope::acmm::multiscale::restorer_result(&gate, &mut marked, params.xi);
    let rate = |left: bool| {
        let (mut r, mut n) = (0, 0);
        for (i, &rep) in replaced.iter().enumerate() {
            if (i % 48 < 24) == left {
                n += 1;
                r += usize::from(rep);
            }
        }
        r as f64 / n as f64
    };
    eprintln!("replaced: left {:.3}, right {:.3}", rate(true), rate(false));
    assert!(
        rate(true) > rate(false),
        "{} vs {}",
        rate(true),
        rate(false)
    );

    // The last step writes C_init − C_photo (and, ungated, marks the errors in details).
    solver.upload_state(&ctx, &c);
    solver.upload_extra(&ctx, &gate.c_init, &gate.c_photo);
    solver.restore(&ctx, &pipes, &problem, &params, kind);
    let (g_diff, _) = solver.download_extra(&ctx).unwrap();
    let g = solver.download_state(&ctx).unwrap();
    let max = g_diff
        .iter()
        .zip(&c.aux)
        .zip(&gate.c_init)
        .zip(&gate.c_photo)
        .map(|(((d, _), i), p)| (d - (i - p)).abs())
        .fold(0.0f32, f32::max);
    assert!(max < 1e-6, "difference map differs by {max}");
    assert_eq!(g.plane, c.plane, "the last step moves no plane");
    assert_eq!(g.aux, marked.aux, "replaced bits");
}

fn tiny_session(ctx: &GpuContext, s: &SyntheticScene, params: Params) -> Session {
    Session::new(ctx, &s.scene, params, Method::Acmm).unwrap()
}

fn small_params() -> Params {
    Params {
        iterations: 1,
        coarse_iterations: 1,
        restorer_iterations: 1,
        geometric_iterations: 1,
        scales: 2,
        ..Params::default()
    }
}

fn all_maps(s: &Session) -> Vec<ViewState> {
    s.final_maps()
        .unwrap()
        .into_iter()
        .map(|m| m.expect("every view has maps").state)
        .collect()
}

#[test]
fn stepping_resuming_and_view_order_give_identical_maps() {
    let s = scene(3, 40, 32);
    let ctx = GpuContext::new().unwrap();
    let mut a = tiny_session(&ctx, &s, small_params());
    a.run_to_end().unwrap();
    let reference = all_maps(&a);

    // One step at a time, reading the active view's maps in between.
    let mut b = tiny_session(&ctx, &s, small_params());
    while b.step().unwrap() {
        let view = b.schedule()[b.cursor() - 1].view;
        let _ = b.maps(view).unwrap();
    }
    assert_eq!(all_maps(&b), reference, "stepping changes nothing");

    // The same seed in a new session.
    let mut c = tiny_session(&ctx, &s, small_params());
    c.run_to_end().unwrap();
    assert_eq!(all_maps(&c), reference);

    // Back to a stage boundary in the middle (a checkpoint), then forward again.
    let mid = a
        .schedule()
        .iter()
        .position(|st| st.level == 1 && st.stage == Stage::Restorer)
        .unwrap();
    a.goto(mid + 5).unwrap();
    assert_eq!(a.cursor(), mid + 5);
    a.run_to_end().unwrap();
    assert_eq!(
        all_maps(&a),
        reference,
        "resuming from a checkpoint reproduces the maps"
    );

    // A checkpoint budget smaller than two stages' maps: the oldest go, memory stays within
    // the budget (the newest checkpoint is always kept), and stepping back replays from an
    // earlier one to the same maps.
    let mut f = tiny_session(&ctx, &s, small_params());
    f.run_to_end().unwrap();
    let all = f.checkpoint_bytes();
    let count = f.checkpoint_count();
    assert!(count > 3, "{count} checkpoints");
    let budget = all / 2;
    f.set_checkpoint_budget(budget);
    assert!(f.checkpoint_count() < count);
    assert!(
        f.checkpoint_bytes() <= budget || f.checkpoint_count() == 2,
        "{} > {budget}",
        f.checkpoint_bytes()
    );
    f.goto(mid + 5).unwrap();
    f.run_to_end().unwrap();
    assert_eq!(
        all_maps(&f),
        reference,
        "replaying past dropped checkpoints"
    );

    // Another order of views within each stage: each stage reads the previous stage's
    // snapshot, so the order cannot matter.
    let mut d = tiny_session(&ctx, &s, small_params());
    d.set_view_order(vec![2, 0, 1]).unwrap();
    d.run_to_end().unwrap();
    assert_eq!(all_maps(&d), reference, "view order changes nothing");

    // Each stage's views interleaved, one action of all views per submission (batch runs),
    // with and without checkpoints, and resumed from the middle of an action's views.
    for keep in [false, true] {
        let mut g = tiny_session(&ctx, &s, small_params());
        g.set_keep_checkpoints(keep);
        g.set_interleaved(true).unwrap();
        assert_ne!(g.schedule(), a.schedule(), "another order");
        let mut batched = 0;
        while !g.is_finished() {
            let ran = g.step_views(usize::MAX).unwrap();
            batched = batched.max(ran.len());
        }
        assert_eq!(batched, 3, "an action of all three views at once");
        assert_eq!(
            all_maps(&g),
            reference,
            "interleaved views, checkpoints {keep}"
        );
        assert!(
            g.set_interleaved(false).is_err(),
            "only before the first step"
        );
        if keep {
            g.goto(mid + 4).unwrap();
            assert_eq!(g.cursor(), mid + 4);
            g.run_to_end().unwrap();
            assert_eq!(all_maps(&g), reference, "resumed interleaved");
        }
    }

    // Another seed changes the maps.
    let mut e = tiny_session(
        &ctx,
        &s,
        Params {
            seed: 9,
            ..small_params()
        },
    );
    e.run_to_end().unwrap();
    assert_ne!(all_maps(&e), reference);
}

/// Steps (cursors) where one view's unit of work ends inside a stage.
fn unit_ends_inside_stages(steps: &[mvscope::session::Step]) -> Vec<usize> {
    (1..steps.len())
        .filter(|&c| {
            let (p, n) = (steps[c - 1], steps[c]);
            p.view != n.view && p.level == n.level && p.stage == n.stage
        })
        .collect()
}

#[test]
fn stepping_back_one_view_inside_a_stage_resumes_from_that_views_checkpoint() {
    let s = scene(3, 40, 32);
    let ctx = GpuContext::new().unwrap();
    let mut a = tiny_session(&ctx, &s, small_params());
    a.run_to_end().unwrap();
    let reference = all_maps(&a);
    let steps = a.schedule().to_vec();
    let ends = unit_ends_inside_stages(&steps);
    // Inside level 1's first stage (some views still at level 0, some upsampled) and inside
    // one of its geometric stages (whose passes read the stage's depth snapshot).
    let in_restorer = *ends
        .iter()
        .find(|&&c| steps[c].level == 1 && steps[c].stage == Stage::Restorer)
        .unwrap();
    let in_geometric = *ends
        .iter()
        .find(|&&c| steps[c].level == 1 && matches!(steps[c].stage, Stage::Geometric(_)))
        .unwrap();
    for at in [in_restorer, in_geometric] {
        // Every view's end is a checkpoint: nothing to replay.
        assert_eq!(a.rewind(at), at, "rewinding to step {at}");
        a.run_to_end().unwrap();
        assert_eq!(
            all_maps(&a),
            reference,
            "resuming inside a stage from step {at}"
        );
    }
    // A step inside the next view's unit goes back to that view's start, not the stage's.
    assert_eq!(a.rewind(in_geometric + 2), in_geometric);
    a.goto(in_geometric + 2).unwrap();
    a.run_to_end().unwrap();
    assert_eq!(all_maps(&a), reference, "replaying part of a unit");

    // Memory: each view's end copies that view's maps only; the other views' copies and the
    // stage's depth snapshot are shared with the checkpoint before.
    let mut b = tiny_session(&ctx, &s, small_params());
    let first_stage: Vec<usize> = ends.iter().copied().filter(|&c| c < 3 * 3).collect();
    assert_eq!(first_stage, [3, 6], "3 views x 3 steps in the first stage");
    let mut bytes = Vec::new();
    for at in [3, 6, 9] {
        b.goto(at).unwrap();
        bytes.push(b.checkpoint_bytes());
    }
    let one_view = bytes[1] - bytes[0];
    assert!(one_view > 0);
    assert_eq!(bytes[2] - bytes[1], one_view, "{bytes:?}");
    assert!(
        bytes[0] > one_view,
        "the first also holds the snapshot: {bytes:?}"
    );
    assert_eq!(b.checkpoint_count(), 4, "the start and one per view");
}

#[test]
fn schedule_is_labelled_and_parameter_changes_rewind_exactly() {
    let s = scene(3, 40, 32);
    let ctx = GpuContext::new().unwrap();
    let mut session = tiny_session(&ctx, &s, small_params());
    let steps = session.schedule().to_vec();
    // 2 levels; level 0: photometric (init, 2 halves) + 2 geometric passes (init, 2 halves,
    // measure); level 1: restorer (upsample, init, 2 halves, restore) + 2 geometric passes,
    // the last with the median on the final maps; for each of 3 views.
    assert_eq!(steps.len(), 3 * (3 + 2 * 4) + 3 * (5 + 4 + 5));
    let medians: Vec<_> = steps
        .iter()
        .filter(|s| s.action == Action::Median)
        .collect();
    assert_eq!(medians.len(), 3);
    assert!(
        medians
            .iter()
            .all(|s| (s.level, s.stage) == (1, Stage::Geometric(2)))
    );
    // The original code's median at the end of every pass: one per pass and view.
    let every = Params {
        median_every_pass: true,
        ..small_params()
    };
    let with_every = Session::new(&ctx, &s.scene, every.clone(), Method::Acmm).unwrap();
    let every_medians = with_every
        .schedule()
        .iter()
        .filter(|s| s.action == Action::Median)
        .count();
    assert_eq!(every_medians, 3 * 6);
    // Without geometric passes the restorer ends the run, and its last step (which may write
    // planes) comes before the median on the final maps.
    let no_geo = Params {
        geometric_passes: 0,
        ..small_params()
    };
    let no_geo = Session::new(&ctx, &s.scene, no_geo, Method::Acmm).unwrap();
    let last_actions: Vec<Action> = no_geo.schedule()[no_geo.schedule().len() - 2..]
        .iter()
        .map(|s| s.action)
        .collect();
    assert_eq!(last_actions, [Action::Restore, Action::Median]);
    assert_eq!(steps[0].label(), "scale 1/2 · photometric · view 0 · init");
    assert!(steps.iter().any(|s| {
        s.label()
            .contains("geometric 2 · view 2 · iteration 1 black")
    }));
    session.run_to_end().unwrap();
    let before = all_maps(&session);
    let end = session.cursor();

    // ξ only decides which pixels the (ungated) detail restorer marks as errors in the
    // details: the session rewinds to its first restore step, and only the marks change.
    let first_restore = steps
        .iter()
        .position(|s| s.action == Action::Restore)
        .unwrap();
    let replaced = |s: &Session| -> Vec<Option<Vec<bool>>> {
        s.final_maps()
            .unwrap()
            .into_iter()
            .map(|m| m.unwrap().replaced)
            .collect()
    };
    let marks_before = replaced(&session);
    let inv = session
        .set_params(Params {
            xi: 0.5,
            ..small_params()
        })
        .unwrap();
    assert_eq!((inv.from_step, inv.previous_cursor), (first_restore, end));
    assert_eq!(session.cursor(), first_restore);
    session.run_to_end().unwrap();
    assert_eq!(all_maps(&session), before, "ξ moves no plane");
    assert_ne!(
        replaced(&session),
        marks_before,
        "a larger ξ marks fewer pixels"
    );

    // Gated, ξ is read by every update of the restorer's pass: the session rewinds to the
    // pass's first step, and the maps change.
    let gated = |xi: f32| Params {
        xi,
        restorer: mvscope::acmm::RestorerMode::Gated,
        ..small_params()
    };
    session.set_params(gated(0.1)).unwrap();
    session.run_to_end().unwrap();
    let gated_before = all_maps(&session);
    let first_restorer = steps
        .iter()
        .position(|s| s.stage == Stage::Restorer)
        .unwrap();
    let inv = session.set_params(gated(0.5)).unwrap();
    assert_eq!(inv.from_step, first_restorer);
    session.run_to_end().unwrap();
    assert_ne!(
        all_maps(&session),
        gated_before,
        "a larger ξ lets fewer pixels through"
    );
    session.set_params(small_params()).unwrap();
    session.run_to_end().unwrap();

    // λ only affects geometric passes.
    let first_geo = steps
        .iter()
        .position(|s| matches!(s.stage, Stage::Geometric(_)))
        .unwrap();
    let inv = session
        .set_params(Params {
            xi: 0.5,
            lambda: 0.5,
            ..small_params()
        })
        .unwrap();
    assert_eq!(inv.from_step, first_geo);

    // τ0 affects everything.
    let inv = session
        .set_params(Params {
            tau0: 0.7,
            xi: 0.5,
            lambda: 0.5,
            ..small_params()
        })
        .unwrap();
    assert_eq!(inv.from_step, 0);

    // The median at the end of every pass: the schedules part where the first pass of
    // view 0 ends (3 steps in), and the maps change.
    session.set_params(small_params()).unwrap();
    session.run_to_end().unwrap();
    let inv = session.set_params(every).unwrap();
    assert_eq!(inv.from_step, 3);
    session.run_to_end().unwrap();
    assert_ne!(
        all_maps(&session),
        before,
        "intermediate medians change the run"
    );

    // Going back to the original parameters reproduces the original maps.
    session.set_params(small_params()).unwrap();
    session.run_to_end().unwrap();
    assert_eq!(all_maps(&session), before);
    assert!(
        session
            .set_params(Params {
                tau1: 0.1,
                ..small_params()
            })
            .is_err()
    );
}

/// shaders/gather_depth.wgsl against `gather_depth`: a view's depths land in its layer of the
/// level's snapshot, and nowhere else.
#[test]
fn gather_depth_matches_cpu() {
    let s = scene(3, 40, 32);
    let (ctx, pipelines) = gpu();
    let grays: Vec<(usize, u32, u32, &[f32])> = s
        .scene
        .views
        .iter()
        .enumerate()
        .map(|(i, v)| (i, v.image.width, v.image.height, v.image.gray.as_slice()))
        .collect();
    let level = mvscope::gpu::acmh::LevelImages::upload(&ctx, &grays, 3).unwrap();
    let problem = ViewProblem::header(&s.scene, 1, 0);
    let solver = GpuViewSolver::resident(&ctx, &pipelines, &problem, &level).unwrap();
    let mut state = ViewState::garbage(40, 32, problem.num_sources());
    for (i, p) in state.plane.iter_mut().enumerate() {
        *p = [0.0, 0.0, -1.0, 1.0 + i as f32 * 0.37];
    }
    solver.upload_state(&ctx, &state);
    solver.gather_depth(&ctx, &pipelines);
    let layer = |v: usize| -> Vec<f32> {
        level
            .request_depth(&ctx, v)
            .unwrap()
            .wait::<f32>(&ctx)
            .unwrap()
    };
    assert_eq!(
        layer(1),
        mvscope::gpu::acmh::gather_depth(&state.plane),
        "view 1's layer"
    );
    for v in [0, 2] {
        assert!(layer(v).iter().all(|&d| d == 0.0), "view {v}'s layer");
    }
}

/// A resident solver (shared level images, each view a layer of them; here in another order
/// than the scene's, as a batch holds them) computes exactly what a solver with its own
/// images does.
#[test]
fn resident_solver_matches_a_standalone_one() {
    let s = scene(3, 40, 32);
    let (ctx, pipelines) = gpu();
    let params = Params::default();
    let grays: Vec<(usize, u32, u32, &[f32])> = s
        .scene
        .views
        .iter()
        .enumerate()
        .rev()
        .map(|(i, v)| (i, v.image.width, v.image.height, v.image.gray.as_slice()))
        .collect();
    let level = mvscope::gpu::acmh::LevelImages::upload(&ctx, &grays, 3).unwrap();
    assert_eq!(level.layer_of, vec![Some(2), Some(1), Some(0)]);
    let full = ViewProblem::new(&s.scene, 2, 0);
    let header = ViewProblem::header(&s.scene, 2, 0);
    assert!(header.images.is_empty());
    let a = GpuViewSolver::new(&ctx, &pipelines, &full).unwrap();
    let b = GpuViewSolver::resident(&ctx, &pipelines, &header, &level).unwrap();
    for solver in [&a, &b] {
        solver.random_init(&ctx, &pipelines, &header, &params);
        for color in [0, 1] {
            solver.propagate(&ctx, &pipelines, &header, &params, Method::Acmh, 1, color);
        }
    }
    assert_eq!(
        a.download_state(&ctx).unwrap(),
        b.download_state(&ctx).unwrap()
    );
}

/// Inside a batch (one submission for many recorded passes), the calls still happen in their
/// order: a solver's second pass with other parameters does not make its first read them, and
/// a queue write or a read-back in the middle sees what the passes before it did.
#[test]
fn a_batch_keeps_the_order_of_the_calls() {
    let s = scene(3, 40, 32);
    let (ctx, pipelines) = gpu();
    let params = Params::default();
    let problem = ViewProblem::new(&s.scene, 1, 0);
    let run = |batched: bool, read_between: bool| {
        let solver = GpuViewSolver::new(&ctx, &pipelines, &problem).unwrap();
        if batched {
            ctx.begin_batch();
        }
        solver.random_init(&ctx, &pipelines, &problem, &params);
        let mut middle = None;
        for iteration in 1..=2 {
            for color in [0, 1] {
                solver.propagate(
                    &ctx,
                    &pipelines,
                    &problem,
                    &params,
                    Method::Acmh,
                    iteration,
                    color,
                );
            }
            if read_between && iteration == 1 {
                middle = Some(solver.download_state(&ctx).unwrap());
            }
        }
        solver.median_filter(&ctx, &pipelines, &problem, &params);
        if batched {
            ctx.end_batch();
        }
        assert_eq!(ctx.batch_generation(), None, "closed");
        (solver.download_state(&ctx).unwrap(), middle)
    };
    let (reference, _) = run(false, false);
    let (_, unbatched_middle) = run(false, true);
    let (batched, _) = run(true, false);
    assert_eq!(
        batched, reference,
        "five passes with other parameters, one batch"
    );
    let (batched, batched_middle) = run(true, true);
    assert_eq!(batched, reference);
    assert_eq!(
        batched_middle, unbatched_middle,
        "a read-back inside a batch"
    );

    // A write between two recorded copies lands between them.
    let a = ctx.storage_buffer("a", &[1.0f32; 4]);
    let b = ctx.zeroed_storage("b", 16);
    let c = ctx.zeroed_storage("c", 16);
    ctx.begin_batch();
    mvscope::gpu::acmh::copy_into(&ctx, &a, &b);
    ctx.write(&a, 0, &[2.0f32; 4]);
    mvscope::gpu::acmh::copy_into(&ctx, &a, &c);
    ctx.end_batch();
    assert_eq!(ctx.read_buffer::<f32>("b", &b).unwrap(), vec![1.0; 4]);
    assert_eq!(ctx.read_buffer::<f32>("c", &c).unwrap(), vec![2.0; 4]);
}

#[test]
fn the_images_texture_decides_the_pyramids_depth_in_a_session() {
    // A plain 240x180 wall in the middle of 400x300 textured views: 95% of the pixels lie
    // within ~59 px of texture, which the 5 px window spans at the 5th scale; the 4th is the
    // last whose long side (50 px) holds four 11 px windows.
    let mut s = scene(3, 400, 300);
    for view in &mut s.scene.views {
        let mut rgb = view.image.rgb.clone();
        for y in 60..240 {
            for x in 80..320 {
                rgb[y * 400 + x] = [128, 128, 128];
            }
        }
        view.image = mvscope::image::Image::from_rgb(400, 300, rgb);
    }
    let ctx = GpuContext::new().unwrap();
    let by_texture = Params {
        scales_by_texture: true,
        ..Params::default()
    };
    let mut session = Session::new(&ctx, &s.scene, by_texture.clone(), Method::Acmm).unwrap();
    assert_eq!(session.num_levels(), 4);
    assert_eq!(session.params().scales, 4);
    let depth = session.texture_depth().expect("measured").clone();
    assert_eq!((depth.scales, depth.wanted), (4, 5));
    assert!((50.0..70.0).contains(&depth.reach), "{}", depth.reach);
    // Off: the paper's k; on again: the same four, from the measurement kept.
    session.set_params(Params::default()).unwrap();
    assert_eq!(session.num_levels(), 3);
    session.set_params(by_texture.clone()).unwrap();
    assert_eq!(session.num_levels(), 4);
    // k stays the floor, even past the four windows: k = 5 gives five.
    session
        .set_params(Params {
            scales: 5,
            ..by_texture.clone()
        })
        .unwrap();
    assert_eq!(session.num_levels(), 5);
    // A one-scale method is untouched.
    let acmh = Session::new(&ctx, &s.scene, by_texture, Method::Acmh).unwrap();
    assert_eq!(acmh.num_levels(), 1);
    assert!(acmh.texture_depth().is_none());
}
