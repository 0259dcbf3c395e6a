//! ACMH on the GPU against its CPU reference, and accuracy on the synthetic scene.
//! Runs on lavapipe in CI: scenes are tiny.

use mvscope::acmm::cpu;
use mvscope::acmm::problem::ViewState;
use mvscope::acmm::{Method, Params, ViewProblem};
use mvscope::gpu::GpuContext;
use mvscope::gpu::acmh::{AcmhPipelines, GpuViewSolver};
use mvscope::synthetic::{SyntheticOptions, SyntheticScene, generate};

fn scene(views: usize, width: u32, height: u32) -> SyntheticScene {
    generate(&SyntheticOptions {
        views,
        width,
        height,
        seed: 11,
        noise_sigma: 1.0,
        room: false,
        sources: mvscope::scene::geometry::DEFAULT_SOURCES,
    })
    .expect("synthetic scene")
}

fn gpu() -> (GpuContext, AcmhPipelines) {
    let ctx = GpuContext::new().expect("a GPU adapter (install mesa-vulkan-drivers)");
    let pipelines = AcmhPipelines::new(&ctx).expect("ACMH shaders compile");
    (ctx, pipelines)
}

/// How two states differ: the share of pixels whose plane differs, and the largest cost
/// difference among pixels whose planes agree.
fn compare(a: &ViewState, b: &ViewState) -> (f64, f32) {
    let mut differing = 0;
    let mut max_cost = 0.0f32;
    for i in 0..a.plane.len() {
        let (p, q) = (a.plane[i], b.plane[i]);
        let same = (0..4).all(|k| (p[k] - q[k]).abs() <= 1e-4 * (1.0 + p[k].abs()));
        if same {
            max_cost = max_cost.max((a.cost[i] - b.cost[i]).abs());
        } else {
            differing += 1;
        }
    }
    (differing as f64 / a.plane.len() as f64, max_cost)
}

/// The largest absolute difference between two maps.
fn max_difference(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max)
}

#[test]
fn random_init_matches_cpu() {
    random_init_matches(&Params::default());
}

/// The Gaussian bilateral weight (`bilateral_kernel = "gaussian"`).
#[test]
fn random_init_with_the_gaussian_weight_matches_cpu() {
    random_init_matches(&gaussian());
}

/// The Gaussian weight with the window's own colour spread (`bilateral_kernel =
/// "adaptive"`): the median found by counting on the device, as on the CPU.
#[test]
fn random_init_with_the_adaptive_weight_matches_cpu() {
    random_init_matches(&adaptive());
}

fn gaussian() -> Params {
    Params {
        bilateral_kernel: mvscope::acmm::params::BilateralKernel::Gaussian,
        ..Params::default()
    }
}

fn adaptive() -> Params {
    Params {
        bilateral_kernel: mvscope::acmm::params::BilateralKernel::Adaptive,
        ..Params::default()
    }
}

fn random_init_matches(params: &Params) {
    let s = scene(3, 48, 40);
    let problem = ViewProblem::new(&s.scene, 1, 0);
    let params = params.clone();
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    solver.upload_state(&ctx, &ViewState::garbage(48, 40, problem.num_sources()));
    solver.random_init(&ctx, &pipes, &problem, &params);
    let g = solver.download_state(&ctx).unwrap();
    let mut c = ViewState::garbage(48, 40, problem.num_sources());
    cpu::random_init(&problem, &params, &mut c);
    let (differing, max_cost) = compare(&g, &c);
    // Same counter-based random numbers; only sin/cos/exp rounding differs.
    assert_eq!(differing, 0.0);
    assert!(max_cost < 2e-3, "{max_cost}");
    assert_eq!(g.selected, c.selected);
    assert_eq!(g.aux, c.aux);
}

fn half_step_matches(method: Method) {
    half_step_matches_with(method, &Params::default());
}

fn half_step_matches_with(method: Method, params: &Params) {
    let s = scene(4, 48, 40);
    let problem = ViewProblem::new(&s.scene, 1, 0);
    let params = params.clone();
    // A realistic input state: the CPU's init plus one CPU iteration.
    let mut state = ViewState::garbage(48, 40, problem.num_sources());
    cpu::random_init(&problem, &params, &mut state);
    cpu::propagate_half(&problem, &params, method, &mut state, 1, 0);
    cpu::propagate_half(&problem, &params, method, &mut state, 1, 1);
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    for color in [0, 1] {
        solver.upload_state(&ctx, &state);
        solver.propagate(&ctx, &pipes, &problem, &params, method, 2, color);
        let g = solver.download_state(&ctx).unwrap();
        let mut c = state.clone();
        cpu::propagate_half(&problem, &params, method, &mut c, 2, color);
        let (differing, max_cost) = compare(&g, &c);
        // Near-ties may flip between f32 evaluation orders; none did when measured
        // (0 of 960 updated pixels), so allow at most 1%.
        assert!(
            differing < 0.01,
            "{method}: {:.2}% of pixels differ",
            differing * 100.0
        );
        assert!(max_cost < 2e-3, "{method}: cost differs by {max_cost}");
        let same_bits = g
            .selected
            .iter()
            .zip(&c.selected)
            .filter(|(a, b)| a == b)
            .count();
        assert!(same_bits as f64 > 0.99 * g.selected.len() as f64);
        let same_aux = g.aux.iter().zip(&c.aux).filter(|(a, b)| a == b).count();
        assert!(same_aux as f64 > 0.99 * g.aux.len() as f64);
        let max_w = max_difference(&g.weights, &c.weights);
        assert!(max_w < 1e-3, "{method}: weights differ by {max_w}");
        // Pixels of the other colour are untouched.
        for (i, (a, b)) in g.plane.iter().zip(&state.plane).enumerate() {
            let (x, y) = (i % 48, i / 48);
            if (x + y) % 2 != color as usize {
                assert_eq!(a, b, "pixel {i} of the other colour changed");
            }
        }
    }
}

/// The matching passes have a pipeline per window (its radius and step as pipeline
/// constants, so loops unroll). For windows other than the default as well, a half-iteration
/// follows the CPU reference, and the per-window pipeline gives exactly what the generic one
/// (window read from the parameters) gives.
#[test]
fn every_window_matches_the_cpu_with_and_without_its_own_pipeline() {
    let s = scene(3, 40, 32);
    let problem = ViewProblem::new(&s.scene, 1, 0);
    let (ctx, pipes) = gpu();
    for (radius, step) in [(3, 1), (7, 2), (4, 3)] {
        let params = Params {
            window_radius: radius,
            window_step: step,
            ..Params::default()
        };
        params.validate().unwrap();
        let mut state = ViewState::garbage(40, 32, problem.num_sources());
        cpu::random_init(&problem, &params, &mut state);
        let run = |specialise: bool| {
            pipes.set_specialise(specialise);
            let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
            solver.upload_state(&ctx, &state);
            for color in [0, 1] {
                solver.propagate(&ctx, &pipes, &problem, &params, Method::Acmh, 1, color);
            }
            solver.download_state(&ctx).unwrap()
        };
        let generic = run(false);
        let own = run(true);
        assert_eq!(
            own, generic,
            "window {radius}/{step}: own pipeline against generic"
        );
        let mut c = state.clone();
        cpu::propagate_half(&problem, &params, Method::Acmh, &mut c, 1, 0);
        cpu::propagate_half(&problem, &params, Method::Acmh, &mut c, 1, 1);
        let (differing, max_cost) = compare(&own, &c);
        // As in half_step_matches: near-ties may flip between evaluation orders.
        assert!(
            differing < 0.01,
            "window {radius}/{step}: {:.2}% differ",
            differing * 100.0
        );
        assert!(
            max_cost < 2e-3,
            "window {radius}/{step}: cost differs by {max_cost}"
        );
    }
}

#[test]
fn acmh_half_step_matches_cpu() {
    half_step_matches(Method::Acmh);
}

#[test]
fn dwta_half_step_matches_cpu() {
    half_step_matches(Method::Dwta);
}

#[test]
fn acmh_half_step_with_the_gaussian_weight_matches_cpu() {
    half_step_matches_with(Method::Acmh, &gaussian());
}

#[test]
fn acmh_half_step_with_the_adaptive_weight_matches_cpu() {
    half_step_matches_with(Method::Acmh, &adaptive());
}

#[test]
fn median_filter_matches_cpu_exactly() {
    let s = scene(3, 40, 32);
    let problem = ViewProblem::new(&s.scene, 0, 0);
    let params = Params::default();
    let mut state = ViewState::garbage(40, 32, problem.num_sources());
    cpu::random_init(&problem, &params, &mut state);
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    solver.upload_state(&ctx, &state);
    solver.median_filter(&ctx, &pipes, &problem, &params);
    let g = solver.download_state(&ctx).unwrap();
    cpu::median_filter(&mut state, params.median_radius);
    assert_eq!(g.depth(), state.depth());
}

#[test]
fn full_run_is_deterministic_and_follows_the_cpu() {
    let s = scene(3, 40, 32);
    let problem = ViewProblem::new(&s.scene, 1, 0);
    let params = Params {
        iterations: 2,
        ..Params::default()
    };
    let (ctx, pipes) = gpu();
    let a = mvscope::gpu::acmh::run_view(&ctx, &pipes, &problem, &params, Method::Acmh).unwrap();
    let b = mvscope::gpu::acmh::run_view(&ctx, &pipes, &problem, &params, Method::Acmh).unwrap();
    assert_eq!(a, b, "the same seed gives bit-identical maps");
    let c = cpu::run_view(&problem, &params, Method::Acmh);
    let (differing, _) = compare(&a, &c);
    // Measured: 0% after init + 2 iterations + median at 40x32.
    assert!(
        differing < 0.01,
        "{:.2}% of pixels differ from the CPU",
        differing * 100.0
    );
    let other = mvscope::gpu::acmh::run_view(
        &ctx,
        &pipes,
        &problem,
        &Params {
            seed: 7,
            ..params.clone()
        },
        Method::Acmh,
    )
    .unwrap();
    assert_ne!(a.plane, other.plane, "another seed gives other maps");
}

#[test]
fn acmh_is_accurate_and_beats_dwta() {
    use mvscope::eval::depth_accuracy_relative;
    let s = generate(&SyntheticOptions {
        views: 5,
        width: 160,
        height: 120,
        seed: 1,
        noise_sigma: 1.0,
        room: false,
        sources: mvscope::scene::geometry::DEFAULT_SOURCES,
    })
    .unwrap();
    let view = 2;
    let problem = ViewProblem::new(&s.scene, view, 0);
    let gt = &s.ground_truth[view];
    let textured: Vec<bool> = gt.low_texture.iter().map(|l| !l).collect();
    let params = Params::default();
    let (ctx, pipes) = gpu();
    let run = |method| {
        let st = mvscope::gpu::acmh::run_view(&ctx, &pipes, &problem, &params, method).unwrap();
        let d = st.depth();
        (
            depth_accuracy_relative(&d, &gt.depth, None, 0.01).within,
            depth_accuracy_relative(&d, &gt.depth, Some(&textured), 0.01).within,
        )
    };
    let (acmh_all, acmh_tex) = run(Method::Acmh);
    let (dwta_all, dwta_tex) = run(Method::Dwta);
    eprintln!("ACMH {acmh_all:.3} / {acmh_tex:.3}, DWTA {dwta_all:.3} / {dwta_tex:.3}");
    // Measured on lavapipe (160x120, 5 views, view 2, 3 iterations, seed 0):
    //   ACMH: 0.503 of all GT pixels and 0.787 of textured ones within 1%;
    //   DWTA: 0.416 and 0.634.
    // The low-texture wall (~40% of the view) is what ACMM's multi-scale scheme is for;
    // photometric ACMH gets ~0% of it at 1%, so the majority is asserted on textured pixels.
    assert!(
        acmh_tex > 0.65,
        "ACMH: {acmh_tex:.3} of textured pixels within 1%"
    );
    assert!(
        acmh_all > dwta_all + 0.05,
        "ACMH {acmh_all:.3} vs DWTA {dwta_all:.3}"
    );
    assert!(
        acmh_tex > dwta_tex + 0.08,
        "ACMH {acmh_tex:.3} vs DWTA {dwta_tex:.3}"
    );
}

/// Eleven views, view 5's sources all ten others, two of them rescaled (with their cameras)
/// to 36x30 and 64x52: the warps sample images of three sizes, so the texture's layers are
/// larger than most views.
fn mixed_size_problem() -> ViewProblem {
    let mut s = scene(11, 48, 40);
    for (v, (w, h)) in [(3usize, (36u32, 30u32)), (7, (64, 52))] {
        let view = &mut s.scene.views[v];
        view.image = view.image.resized(w, h);
        view.camera = view.camera.rescaled(w, h);
    }
    let reference = 5;
    s.scene.views[reference].sources = (0..11)
        .filter(|&j| j != reference)
        .map(|j| mvscope::scene::SourceView {
            index: j,
            score: 1.0,
        })
        .collect();
    ViewProblem::new(&s.scene, reference, 0)
}

#[test]
fn matching_cost_samples_borders_and_layers_of_every_size_like_the_cpu() {
    // Random planes warp patches across every border of every source; each pixel's cost is
    // the top-K mean over ten sources of three sizes, all sampled by textureGather. A wrong
    // tap moves costs by far more: swapping two corners by up to 0.80, interpolating past
    // the right border by 0.65, past the bottom border by 0.48 (each mutation measured).
    // Rounding (the planes' sin/cos, exp) moved them by at most 6.6e-6.
    let problem = mixed_size_problem();
    let params = Params::default();
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    solver.upload_state(&ctx, &ViewState::garbage(48, 40, 10));
    solver.random_init(&ctx, &pipes, &problem, &params);
    let g = solver.download_state(&ctx).unwrap();
    let mut c = ViewState::garbage(48, 40, 10);
    cpu::random_init(&problem, &params, &mut c);
    // The same random planes (up to sin/cos rounding), so the costs are of the same warps.
    let (differing, _) = compare(&g, &c);
    assert_eq!(differing, 0.0);
    let scored = c.cost.iter().filter(|&&v| v < cpu::MAX_COST).count();
    assert!(
        scored > c.cost.len() / 2,
        "only {scored} pixels have a finite cost"
    );
    let max_cost = max_difference(&g.cost, &c.cost);
    assert!(max_cost < 1e-4, "costs differ by up to {max_cost}");
    let same = g
        .selected
        .iter()
        .zip(&c.selected)
        .filter(|(a, b)| a == b)
        .count();
    assert!(
        same as f64 > 0.99 * g.selected.len() as f64,
        "the same top-K sources at only {same} pixels"
    );
}

#[test]
fn sources_of_other_sizes_and_many_sources_match_cpu() {
    let problem = mixed_size_problem();
    assert_eq!(problem.num_sources(), 10);
    let params = Params::default();
    let mut state = ViewState::garbage(48, 40, 10);
    cpu::random_init(&problem, &params, &mut state);
    cpu::propagate_half(&problem, &params, Method::Acmh, &mut state, 1, 0);
    cpu::propagate_half(&problem, &params, Method::Acmh, &mut state, 1, 1);
    let (ctx, pipes) = gpu();
    let solver = GpuViewSolver::new(&ctx, &pipes, &problem).unwrap();
    solver.upload_state(&ctx, &state);
    solver.propagate(&ctx, &pipes, &problem, &params, Method::Acmh, 2, 1);
    let g = solver.download_state(&ctx).unwrap();
    let mut c = state.clone();
    cpu::propagate_half(&problem, &params, Method::Acmh, &mut c, 2, 1);
    let (differing, max_cost) = compare(&g, &c);
    assert!(differing < 0.01, "{:.2}% differ", differing * 100.0);
    assert!(max_cost < 2e-3);
    // Views of every size got selected somewhere, so the mixed-size path really ran.
    let union = g.selected.iter().fold(0u32, |m, s| m | s);
    let rescaled: Vec<usize> = [3usize, 7]
        .iter()
        .map(|v| problem.source_views.iter().position(|s| s == v).unwrap())
        .collect();
    for j in rescaled {
        assert!(
            union & (1 << j) != 0,
            "rescaled source {j} never selected: {union:#b}"
        );
    }
    let w = g.weights.len() / g.plane.len();
    assert_eq!(w, 10);
}

#[test]
fn bench_report_accounts_for_every_pass() {
    // Checks the benchmark's bookkeeping, not its speed.
    let s = scene(3, 32, 24);
    let problem = ViewProblem::new(&s.scene, 1, 0);
    let params = Params {
        iterations: 2,
        ..Params::default()
    };
    let (ctx, pipes) = gpu();
    let case =
        mvscope::bench::bench_problem(&ctx, &pipes, "tiny", &problem, &params, true).unwrap();
    let labels: Vec<&str> = case.passes.iter().map(|p| p.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "random_init",
            "iteration 1 red",
            "iteration 1 black",
            "iteration 2 red",
            "iteration 2 black",
            "median_filter",
            "median_store"
        ]
    );
    let nsrc = problem.num_sources() as u64;
    let px = (32 * 24) as u64;
    assert_eq!(case.evaluations, px * nsrc + 2 * 2 * (px / 2) * 15 * nsrc);
    assert!(case.gpu_total_ms > 0.0 && case.cpu_evaluations_per_s.is_some());
    let text = mvscope::bench::format_report(&mvscope::bench::BenchReport {
        adapter: ctx.describe(),
        software: ctx.is_software(),
        // As on a machine without mesa-vulkan-drivers, where wgpu falls back to Mesa's GL.
        adapter_caveat: mvscope::gpu::adapter_caveat(&wgpu::AdapterInfo {
            backend: wgpu::Backend::Gl,
            ..ctx.info.clone()
        }),
        timestamp_queries: false,
        cpu_threads: 1,
        cases: vec![case],
        methods: None,
    });
    assert!(text.contains("where the time goes") && text.contains("iteration 2 black"));
    // The caveat is the report's second line, before any figure.
    let second = text.lines().nth(1).unwrap_or_default();
    assert!(
        second.starts_with("warning: this run is on the OpenGL backend"),
        "{text}"
    );
}
