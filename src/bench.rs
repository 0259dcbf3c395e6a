//! `mvscope bench`: where ACMH's time goes, per pass, and its throughput in
//! pixel-hypothesis-view cost evaluations per second, on the GPU and on the CPU reference;
//! and ACMM against ACMH per stage. (The other benches: `--scene` and `--cluster` in the CLI,
//! `--accuracy` in `accuracy`, `--viewer` in `viewer`.)

use std::path::{Path, PathBuf};
use web_time::Instant;

use serde::Serialize;

use crate::acmm::problem::ViewState;
use crate::acmm::{Method, Params, ViewProblem, cpu};
use crate::gpu::acmh::{AcmhPipelines, GpuViewSolver};
use crate::gpu::timer::PassTime;
use crate::gpu::{GpuContext, GpuError};
use crate::scene::{LoadOptions, Scene, SceneError};
use crate::synthetic::{SyntheticOptions, generate};

/// Hypotheses a pixel update scores per source: 8 candidates, the current plane, and 6
/// refinement planes (fewer candidates near borders; this is the nominal count).
pub const HYPOTHESES_PER_UPDATE: u64 = 15;

/// What to benchmark.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Synthetic scenes (width, height), 5 views, reference = the middle one.
    pub synthetic_sizes: Vec<(u32, u32)>,
    /// Also the fountain-P11 scene at this path, with the long side capped (None: full size).
    pub fountain: Option<(PathBuf, Option<u32>)>,
    /// ACMH iterations per run.
    pub iterations: u32,
    /// Time the CPU reference on one half-iteration of the same problem.
    pub cpu: bool,
    /// Time whole-scene ACMH and ACMM per stage on a synthetic scene of this size.
    pub methods_size: Option<(u32, u32)>,
    /// Also time each synthetic size with the generic matching pipelines.
    pub window_ab: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchCase {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub sources: usize,
    pub iterations: u32,
    pub passes: Vec<PassTime>,
    /// Sum of the passes' GPU times (timestamps) when available, else of their wall times.
    pub gpu_total_ms: f64,
    pub timed_by: &'static str,
    /// Cost evaluations of the whole run (init + iterations).
    pub evaluations: u64,
    pub gpu_evaluations_per_s: f64,
    /// One red half-iteration on the CPU reference (rayon), same problem and state.
    pub cpu_half_iteration_ms: Option<f64>,
    pub cpu_evaluations_per_s: Option<f64>,
    /// GPU throughput over CPU throughput.
    pub speedup: Option<f64>,
    /// The same passes with the generic matching pipelines (the window read from the
    /// parameters instead of pipeline constants), when asked for.
    pub generic_window_ms: Option<f64>,
}

/// Time one stage of one pyramid level took across all views.
#[derive(Clone, Debug, Serialize)]
pub struct StageTime {
    pub level: u32,
    pub stage: String,
    pub ms: f64,
}

/// A whole-scene run of one method, timed per stage.
#[derive(Clone, Debug, Serialize)]
pub struct MethodRun {
    pub method: String,
    pub total_ms: f64,
    pub stages: Vec<StageTime>,
}

/// ACMM's full time against ACMH's on the same scene (the paper keeps ACMM under 2x ACMH).
#[derive(Clone, Debug, Serialize)]
pub struct MethodComparison {
    pub scene: String,
    pub runs: Vec<MethodRun>,
    pub acmm_over_acmh: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub adapter: String,
    pub software: bool,
    /// [`crate::gpu::adapter_caveat`].
    pub adapter_caveat: Option<String>,
    pub timestamp_queries: bool,
    pub cpu_threads: usize,
    pub cases: Vec<BenchCase>,
    pub methods: Option<MethodComparison>,
}

#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Session(#[from] crate::session::SessionError),
}

fn half_updates(problem: &ViewProblem) -> u64 {
    (problem.pixels() as u64).div_ceil(2)
}

/// Benchmarks one problem.
pub fn bench_problem(
    ctx: &GpuContext,
    pipelines: &AcmhPipelines,
    name: &str,
    problem: &ViewProblem,
    params: &Params,
    run_cpu: bool,
) -> Result<BenchCase, GpuError> {
    let solver = GpuViewSolver::new(ctx, pipelines, problem)?;
    // Warm-up: every pipeline runs once, so drivers that compile on first dispatch
    // (lavapipe) keep that cost out of the numbers.
    solver.random_init(ctx, pipelines, problem, params);
    solver.propagate(ctx, pipelines, problem, params, Method::Acmh, 1, 0);
    solver.median_filter(ctx, pipelines, problem, params);
    let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
    solver.enable_timing(ctx, 4 + 2 * params.iterations);
    solver.random_init(ctx, pipelines, problem, params);
    for t in 1..=params.iterations {
        solver.propagate(ctx, pipelines, problem, params, Method::Acmh, t, 0);
        solver.propagate(ctx, pipelines, problem, params, Method::Acmh, t, 1);
    }
    solver.median_filter(ctx, pipelines, problem, params);
    let passes = solver.take_timings(ctx)?;
    let have_gpu = passes.iter().all(|p| p.gpu_ms.is_some());
    let gpu_total_ms: f64 = passes
        .iter()
        .map(|p| {
            if have_gpu {
                p.gpu_ms.unwrap_or(0.0)
            } else {
                p.wall_ms
            }
        })
        .sum();
    let nsrc = problem.num_sources() as u64;
    let init_evals = problem.pixels() as u64 * nsrc;
    let evaluations = init_evals
        + 2 * params.iterations as u64 * half_updates(problem) * HYPOTHESES_PER_UPDATE * nsrc;
    let gpu_evaluations_per_s = evaluations as f64 / (gpu_total_ms * 1e-3);

    let (cpu_half_iteration_ms, cpu_evaluations_per_s) = if run_cpu {
        let mut state: ViewState = solver.download_state(ctx)?;
        let started = Instant::now();
        cpu::propagate_half(problem, params, Method::Acmh, &mut state, 1, 0);
        let ms = started.elapsed().as_secs_f64() * 1e3;
        let evals = half_updates(problem) * HYPOTHESES_PER_UPDATE * nsrc;
        (Some(ms), Some(evals as f64 / (ms * 1e-3)))
    } else {
        (None, None)
    };
    Ok(BenchCase {
        name: name.to_string(),
        width: problem.width,
        height: problem.height,
        sources: problem.num_sources(),
        iterations: params.iterations,
        passes,
        gpu_total_ms,
        timed_by: if have_gpu {
            "timestamp queries"
        } else {
            "wall clock"
        },
        evaluations,
        gpu_evaluations_per_s,
        cpu_half_iteration_ms,
        cpu_evaluations_per_s,
        speedup: cpu_evaluations_per_s.map(|c| gpu_evaluations_per_s / c),
        generic_window_ms: None,
    })
}

/// Runs the whole scene with `method` as a batch run does (a stage's views interleaved),
/// waiting on the GPU after each submission and adding its wall time to its (level, stage).
pub fn time_method(
    ctx: &GpuContext,
    scene: &Scene,
    params: &Params,
    method: Method,
) -> Result<MethodRun, BenchError> {
    use crate::session::Session;
    let mut session = Session::new(ctx, scene, params.clone(), method)?;
    session.set_batch()?;
    let mut stages: Vec<StageTime> = Vec::new();
    let started = Instant::now();
    // When the batch under way was submitted (both closures read it).
    let t = std::cell::Cell::new(Instant::now());
    session.run_batches(
        |_, _, _| {
            t.set(Instant::now());
            Ok::<(), BenchError>(())
        },
        |_, batch| {
            let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
            let ms = t.get().elapsed().as_secs_f64() * 1e3;
            let step = batch.first;
            let name = crate::pipeline::stage_name(step.stage);
            match stages.last_mut() {
                Some(last) if last.level == step.level && last.stage == name => last.ms += ms,
                _ => stages.push(StageTime {
                    level: step.level,
                    stage: name,
                    ms,
                }),
            }
            Ok(())
        },
    )?;
    Ok(MethodRun {
        method: method.to_string(),
        total_ms: started.elapsed().as_secs_f64() * 1e3,
        stages,
    })
}

/// Runs every case; `progress` hears about each as it starts.
pub fn run(
    ctx: &GpuContext,
    options: &BenchOptions,
    mut progress: impl FnMut(&str),
) -> Result<BenchReport, BenchError> {
    let pipelines = AcmhPipelines::new(ctx)?;
    let params = Params {
        iterations: options.iterations,
        ..Params::default()
    };
    let mut cases = Vec::new();
    for &(w, h) in &options.synthetic_sizes {
        let name = format!("synthetic {w}x{h}");
        progress(&format!("{name}: generating"));
        let s = generate(&SyntheticOptions {
            views: 5,
            width: w,
            height: h,
            ..SyntheticOptions::default()
        })?;
        progress(&format!("{name}: running"));
        let problem = ViewProblem::new(&s.scene, 2, 0);
        let mut case = bench_problem(ctx, &pipelines, &name, &problem, &params, options.cpu)?;
        if options.window_ab {
            progress(&format!("{name}: generic pipelines"));
            pipelines.set_specialise(false);
            let generic = bench_problem(ctx, &pipelines, &name, &problem, &params, false);
            pipelines.set_specialise(true);
            case.generic_window_ms = Some(generic?.gpu_total_ms);
        }
        cases.push(case);
    }
    if let Some((path, max)) = &options.fountain {
        progress("fountain-P11: loading");
        let scene = Scene::load(
            path,
            &LoadOptions {
                max_image_size: *max,
                ..LoadOptions::default()
            },
        )?;
        let mut scene = scene;
        // The middle view with 10 sources: the paper's setting.
        let reference = scene.views.len() / 2;
        scene.views[reference].sources.truncate(10);
        let problem = ViewProblem::new(&scene, reference, 0);
        let v = &scene.views[reference];
        let name = format!(
            "fountain-P11 {}x{} view {}",
            v.image.width, v.image.height, v.name
        );
        progress(&format!("{name}: running"));
        cases.push(bench_problem(
            ctx,
            &pipelines,
            &name,
            &problem,
            &params,
            options.cpu,
        )?);
    }
    let methods = match options.methods_size {
        Some((w, h)) => {
            let name = format!("synthetic {w}x{h}, 5 views");
            progress(&format!("{name}: ACMH vs ACMM"));
            let s = generate(&SyntheticOptions {
                views: 5,
                width: w,
                height: h,
                ..SyntheticOptions::default()
            })?;
            // Each method with its paper schedule (ACMH 6 iterations; ACMM 7 at the coarsest
            // scale and 6 at the others), not the per-pass benchmark's iteration count.
            let paper = Params::default();
            let acmh = time_method(ctx, &s.scene, &paper, Method::Acmh)?;
            let acmm = time_method(ctx, &s.scene, &paper, Method::Acmm)?;
            Some(MethodComparison {
                scene: name,
                acmm_over_acmh: acmm.total_ms / acmh.total_ms,
                runs: vec![acmh, acmm],
            })
        }
        None => None,
    };
    Ok(BenchReport {
        methods,
        adapter: ctx.describe(),
        software: ctx.is_software(),
        adapter_caveat: ctx.caveat(),
        timestamp_queries: ctx.features.contains(wgpu::Features::TIMESTAMP_QUERY),
        cpu_threads: rayon::current_num_threads(),
        cases,
    })
}

/// The report as text: where the time goes first, then throughput.
pub fn format_report(report: &BenchReport) -> String {
    let mut out = format!(
        "adapter: {}{}\n",
        report.adapter,
        if report.software {
            " (software: numbers are not GPU numbers)"
        } else {
            ""
        }
    );
    if let Some(caveat) = &report.adapter_caveat {
        out += caveat;
        out.push('\n');
    }
    for case in &report.cases {
        out += &format!(
            "\n{} — {} sources, {} iterations, {:.1} ms on the GPU ({})\n",
            case.name, case.sources, case.iterations, case.gpu_total_ms, case.timed_by
        );
        out += "  where the time goes:\n";
        for p in &case.passes {
            let ms = p.gpu_ms.unwrap_or(p.wall_ms);
            out += &format!(
                "    {:<22} {:>10.2} ms  {:>5.1}%\n",
                p.label,
                ms,
                100.0 * ms / case.gpu_total_ms.max(1e-9)
            );
        }
        out += &format!(
            "  throughput: {:.3e} pixel-hypothesis-view evaluations/s on the GPU",
            case.gpu_evaluations_per_s
        );
        if let (Some(c), Some(s)) = (case.cpu_evaluations_per_s, case.speedup) {
            out += &format!(", {c:.3e}/s on the CPU reference ({s:.1}x)");
        }
        out += "\n";
        if let Some(g) = case.generic_window_ms {
            out += &format!(
                "  window as pipeline constants: {:.1} ms; generic pipelines: {g:.1} ms ({:.2}x)\n",
                case.gpu_total_ms,
                g / case.gpu_total_ms.max(1e-9)
            );
        }
    }
    if let Some(m) = &report.methods {
        out += &format!(
            "\nwhole scene, {}: ACMM takes {:.2}x ACMH (the paper: under 2x)\n",
            m.scene, m.acmm_over_acmh
        );
        for run in &m.runs {
            out += &format!("  {} {:.0} ms\n", run.method, run.total_ms);
            for st in &run.stages {
                out += &format!(
                    "    scale {} {:<20} {:>10.0} ms  {:>5.1}%\n",
                    st.level + 1,
                    st.stage,
                    st.ms,
                    100.0 * st.ms / run.total_ms.max(1e-9)
                );
            }
        }
    }
    out
}

/// Writes the report as JSON (atomically).
pub fn write_json(report: &BenchReport, path: &Path) -> Result<(), crate::io::IoError> {
    let text = serde_json::to_string_pretty(report)
        .map_err(|e| crate::io::IoError::invalid(path, e.to_string()))?;
    crate::io::write_atomic(path, |w| std::io::Write::write_all(w, text.as_bytes()))
}
