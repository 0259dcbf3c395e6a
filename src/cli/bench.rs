//! `mvscope bench`: per-pass timings, whole-scene runs, the ground-truth accuracy table and
//! the viewer's frame times and memory.

use super::*;

/// Bytes moved and device memory of a run, in one line.
pub(super) fn traffic_line(report: &mvscope::pipeline::RunReport) -> String {
    let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
    format!(
        "moved {:.1} MiB to the device and {:.1} MiB back ({:.2}x the least possible: images once per level, final maps once); device memory peak {:.1} MiB",
        mib(report.bytes_to_device),
        mib(report.bytes_from_device),
        (report.bytes_to_device + report.bytes_from_device) as f64
            / report.bytes_minimum.max(1) as f64,
        mib(report.device_memory_peak)
    )
}

pub(super) struct SceneBenchArgs {
    pub(super) dir: PathBuf,
    pub(super) max_image_size: Option<u32>,
    pub(super) methods: Vec<Method>,
    pub(super) params: Option<PathBuf>,
    pub(super) sets: Vec<String>,
    pub(super) json: PathBuf,
    /// `--device-memory`, MiB: the budget the runs plan with.
    pub(super) device_memory: Option<f64>,
}

/// `mvscope bench --scene DIR`: each method over the whole scene through `pipeline::run`.
pub(super) fn bench_scene(args: SceneBenchArgs) -> Result<()> {
    // Each method starts from its own defaults (`Method::defaults`).
    let method_params = |m: Method| load_params(m, args.params.as_deref(), &args.sets);
    let started = web_time::Instant::now();
    let options = LoadOptions {
        max_image_size: args.max_image_size,
        ..LoadOptions::default()
    }
    .cameras_only();
    // Sizes first: a scene that runs in batches is decoded per batch, as `mvscope run` does.
    let sized = Scene::load(&args.dir, &options)?;
    let ctx = GpuContext::new()?;
    let session_options = mvscope::session::SessionOptions {
        device_budget: args.device_memory.map(mib_bytes),
        ..Default::default()
    };
    let mut batched = false;
    for &m in &args.methods {
        batched |=
            mvscope::session::Session::plan(&ctx, &sized, &method_params(m)?, m, &session_options)
                .map_or(true, |p| !p.resident);
    }
    let scene = if batched {
        sized
    } else {
        Scene::load(
            &args.dir,
            &LoadOptions {
                decode_only: None,
                ..options.clone()
            },
        )?
    };
    let load_s = started.elapsed().as_secs_f64();
    let (w, h) = scene
        .views
        .iter()
        .map(|v| (v.image.width, v.image.height))
        .max_by_key(|&(w, h)| w as u64 * h as u64)
        .unwrap_or((0, 0));
    println!(
        "{}: {} views up to {w}x{h}, loaded in {load_s:.2} s, on {}",
        args.dir.display(),
        scene.views.len(),
        ctx.describe_with_caveat()
    );
    let cancel = AtomicBool::new(false);
    let mut reports = Vec::new();
    for &method in &args.methods {
        let out =
            std::env::temp_dir().join(format!("mvscope-bench-{}-{method}", std::process::id()));
        let record = RunRecord::whole(
            method,
            &args.dir,
            &scene,
            args.max_image_size,
            method_params(method)?,
        );
        let run_options = RunOptions {
            out: out.clone(),
            fuse: false,
            export_acmm: false,
            export_colmap: false,
            resume: false,
            rerun: None,
            record,
            memory: mvscope::pipeline::MemoryOptions {
                device_budget: args.device_memory.map(mib_bytes),
                ..Default::default()
            },
        };
        let images = if batched {
            Some(mvscope::pipeline::decoder(&run_options.record, &options)?)
        } else {
            None
        };
        let report =
            mvscope::pipeline::run(&ctx, &scene, images, &run_options, &mut |_| {}, &cancel);
        let _ = std::fs::remove_dir_all(&out);
        let report = report?;
        let estimated = scene.views.iter().filter(|v| !v.sources.is_empty()).count();
        println!(
            "{method}: {:.2} s for {} views ({:.3} s per view; session {:.2} s), {:.3e} cost evaluations per second",
            report.total_ms / 1e3,
            estimated,
            report.total_ms / 1e3 / estimated.max(1) as f64,
            report.session_ms / 1e3,
            report.cost_evaluations as f64 / (report.session_ms / 1e3).max(1e-9)
        );
        for s in &report.stages {
            println!(
                "  scale {} {:<20} {:>9.3} s",
                s.level + 1,
                s.stage,
                s.ms / 1e3
            );
        }
        println!("  {}", traffic_line(&report));
        reports.push(report);
    }
    let json = serde_json::to_string_pretty(&reports)?;
    mvscope::io::write_atomic(&args.json, |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    println!("report: {}", args.json.display());
    Ok(())
}

pub(super) struct PassBenchArgs {
    pub(super) quick: bool,
    pub(super) fountain: Option<PathBuf>,
    pub(super) fountain_max_size: Option<u32>,
    pub(super) iterations: u32,
    pub(super) no_cpu: bool,
    pub(super) sizes: Vec<String>,
    pub(super) no_methods: bool,
    pub(super) window_ab: bool,
    pub(super) json: PathBuf,
}

pub(super) fn bench(args: PassBenchArgs) -> Result<()> {
    let PassBenchArgs {
        quick,
        fountain,
        fountain_max_size,
        iterations,
        no_cpu,
        sizes,
        no_methods,
        window_ab,
        json,
    } = args;
    if iterations == 0 {
        bail!("--iterations must be at least 1");
    }
    let sizes = sizes
        .iter()
        .map(|s| parse_size("--size", s))
        .collect::<Result<Vec<_>>>()?;
    let ctx = GpuContext::new()?;
    let software = ctx.is_software();
    let options = mvscope::bench::BenchOptions {
        synthetic_sizes: if !sizes.is_empty() {
            sizes
        } else if quick {
            vec![(320, 240), (640, 480)]
        } else {
            vec![(640, 480), (1600, 1200)]
        },
        fountain: fountain.map(|p| {
            let cap = fountain_max_size.or(if software { Some(800) } else { None });
            (p, cap)
        }),
        iterations,
        cpu: !no_cpu,
        methods_size: if no_methods {
            None
        } else {
            Some(if quick { (320, 240) } else { (640, 480) })
        },
        window_ab,
    };
    let report = mvscope::bench::run(&ctx, &options, |m| eprintln!("bench: {m}"))?;
    print!("{}", mvscope::bench::format_report(&report));
    mvscope::bench::write_json(&report, &json)?;
    println!("\nsaved {}", json.display());
    Ok(())
}

pub(super) struct AccuracyArgs {
    pub(super) data: PathBuf,
    pub(super) max_image_size: Option<u32>,
    pub(super) scenes: Vec<String>,
    pub(super) methods: Vec<Method>,
    pub(super) synthetic_size: String,
    pub(super) params: Option<PathBuf>,
    pub(super) sets: Vec<String>,
    pub(super) json: PathBuf,
    /// `--seeds`: every scene and method once per seed, merged (empty: the parameters' seed).
    pub(super) seeds: Vec<u64>,
    pub(super) options: mvscope::accuracy::Options,
}

pub(super) fn bench_accuracy(args: AccuracyArgs) -> Result<()> {
    use mvscope::accuracy;
    // Each method starts from its own defaults (`Method::defaults`); the checks below read
    // the common ones.
    let method_params = |m: Method| load_params(m, args.params.as_deref(), &args.sets);
    let params = method_params(Method::Acmm)?;
    if args.options.oracle_admit > 0 {
        use mvscope::acmm::planar::PriorOracle;
        if !matches!(
            args.options.prior_oracle,
            Some(PriorOracle::Select | PriorOracle::Filter)
        ) || !params.prior_anchors
        {
            bail!(
                "--prior-oracle-admit {}: it admits false positives among the anchors the oracle chooses; add --prior-oracle select (or filter) and --set prior_anchors=true",
                args.options.oracle_admit
            );
        }
    }
    let wanted = |name: &str| {
        args.scenes.is_empty() || args.scenes.iter().any(|s| name.contains(s.as_str()))
    };
    let dirs: Vec<PathBuf> = accuracy::discover(&args.data)
        .into_iter()
        .filter(|d| {
            wanted(
                &d.file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default(),
            )
        })
        .collect();
    // The synthetic scenes by the names the table prints: `synthetic` picks both,
    // `synthetic-320` the scene, `synthetic-room` the room.
    let (width, height) = parse_size("--synthetic-size", &args.synthetic_size)?;
    let with_synthetic = wanted(&format!("synthetic-{width}x{height}"));
    let with_room = wanted(&format!("synthetic-room-{width}x{height}"));
    if dirs.is_empty() && !with_synthetic && !with_room {
        bail!(
            "{}: no scene with ground truth (expected middlebury2014/* or middlebury2006/* folders with gt/)",
            args.data.display()
        );
    }
    let ctx = GpuContext::new()?;
    let pipelines = std::sync::Arc::new(mvscope::gpu::acmh::AcmhPipelines::new(&ctx)?);
    eprintln!("accuracy on {}", ctx.describe_with_caveat());
    let mut suites = Vec::new();
    for d in &dirs {
        suites.push(accuracy::load_scene(d, args.max_image_size)?);
    }
    for (room, wanted) in [(false, with_synthetic), (true, with_room)] {
        if wanted {
            suites.push(accuracy::synthetic_scene(
                &mvscope::synthetic::SyntheticOptions {
                    width,
                    height,
                    room,
                    ..Default::default()
                },
            )?);
        }
    }
    // Each seed once, in the order given (a mean row pairs the rows seed by seed).
    let mut seeds = args.seeds.clone();
    let mut seen = std::collections::HashSet::new();
    seeds.retain(|s| seen.insert(*s));
    if !seeds.is_empty()
        && args
            .sets
            .iter()
            .any(|s| s.trim_start().starts_with("seed="))
    {
        bail!(
            "--seeds and --set seed=...: give the seeds once (--seeds {})",
            {
                let s: Vec<String> = seeds.iter().map(u64::to_string).collect();
                s.join(",")
            }
        );
    }
    let mut rows = Vec::new();
    for suite in &suites {
        for &method in &args.methods {
            let params = method_params(method)?;
            let mut runs = Vec::new();
            for &seed in seeds.iter().chain(seeds.is_empty().then_some(&params.seed)) {
                let seeded = Params {
                    seed,
                    ..params.clone()
                };
                let row = accuracy::evaluate(
                    &ctx,
                    pipelines.clone(),
                    suite,
                    &seeded,
                    method,
                    args.options,
                )?;
                if seeds.len() > 1 {
                    eprintln!(
                        "{} {} seed {seed}: {:.1}% within 2%, weak texture within 2%: {}",
                        row.scene,
                        row.method,
                        100.0 * row.within_2,
                        row.low_texture_within_2
                            .map_or("-".into(), |v| format!("{:.1}%", 100.0 * v)),
                    );
                }
                runs.push((seed, row));
            }
            let row = if runs.len() > 1 {
                accuracy::mean_over_seeds(&runs).ok_or_else(|| {
                    anyhow::anyhow!("{}: the seeds' runs differ in their stages", suite.name)
                })?
            } else {
                match runs.pop() {
                    Some((_, row)) => row,
                    None => continue,
                }
            };
            for st in &row.stages {
                eprintln!(
                    "  {:<36} {:5.1}% within 1%, {:5.1}% within 2%, weak texture within 2%: {}",
                    st.stage,
                    100.0 * st.within_1,
                    100.0 * st.within_2,
                    st.low_texture_within_2
                        .map_or("-".into(), |v| format!("{:.1}%", 100.0 * v))
                );
                if let Some(p) = &st.prior {
                    let pct =
                        |v: Option<f64>| v.map_or("-".into(), |v| format!("{:.1}%", 100.0 * v));
                    eprintln!(
                        "  {:<36} {} support points, {:.1}% of them within 2%; covers {:.1}% (weak texture {}), within 2% {:.1}% (weak texture {})",
                        "  the prior itself:",
                        p.points,
                        100.0 * p.points_within_2,
                        100.0 * p.covered,
                        pct(p.low_texture_covered),
                        100.0 * p.within_2,
                        pct(p.low_texture_within_2),
                    );
                }
            }
            eprintln!(
                "{} {}: {:.1}% within 1%, {:.1}% within 2%, weak texture within 2%: {}, {:.1} s",
                row.scene,
                row.method,
                100.0 * row.within_1,
                100.0 * row.within_2,
                row.low_texture_within_2
                    .map_or("-".into(), |v| format!("{:.1}%", 100.0 * v)),
                row.seconds
            );
            rows.push(row);
        }
    }
    if let Some(oracle) = args.options.prior_oracle {
        let admit = if args.options.oracle_admit > 0 {
            format!(
                ", the anchors also on {}% of the real test's false positives",
                args.options.oracle_admit
            )
        } else {
            String::new()
        };
        println!(
            "(a diagnosis: the planar prior's support points judged by the ground truth, --prior-oracle {}{admit})",
            serde_json::to_value(oracle)?.as_str().unwrap_or("?")
        );
    }
    print!("{}", accuracy::format_table(&rows));
    let text = serde_json::to_string_pretty(&rows)?;
    std::fs::write(&args.json, text)
        .with_context(|| format!("{}: cannot write it", args.json.display()))?;
    println!("\nsaved {}", args.json.display());
    Ok(())
}

pub(super) fn bench_viewer(size: &str) -> Result<()> {
    let size = parse_size("--viewer", size)?;
    let window = (1400, 900);
    let b = mvscope::viewer::bench(size, window, 30)?;
    println!(
        "viewer on {} — demo scene {}x{}, {}x{} window",
        b.adapter, b.width, b.height, window.0, window.1
    );
    let frame = |(total, ui): (f64, f64)| format!("{total:8.2} ms (UI pass {ui:6.2} ms)");
    println!("  idle frame, two map panes:   {}", frame(b.frame_ms_maps));
    println!("  frame, hovering a map:       {}", frame(b.frame_ms_hover));
    println!("  frame, zooming a map:        {}", frame(b.frame_ms_zoom));
    println!(
        "  idle frame, 3D ({:>7} pts):  {}",
        b.cloud_points,
        frame(b.frame_ms_cloud)
    );
    println!(
        "  τ0 change -> map updated:    {:8.1} ms (ACMH, re-ran {} steps)",
        b.tau0_update_ms, b.steps
    );
    let [setup, run, compare, again] = b.rss_mib;
    println!(
        "  resident memory: {setup:.0} MiB set up, {run:.0} after an ACMM run, {compare:.0} \
         after a Compare, {again:.0} after both again (checkpoints: at most {:.0} MiB per \
         session)",
        b.checkpoint_budget_mib
    );
    let [setup, run, compare, again] = b.held_mib;
    println!(
        "  held by the sessions on the device: {setup:.0} / {run:.0} / {compare:.0} / {again:.0} MiB"
    );
    Ok(())
}

/// One row of `mvscope bench --scale`.
#[derive(serde::Serialize)]
struct ScaleRow {
    views: usize,
    batches: usize,
    device_budget: Option<u64>,
    device_peak: u64,
    host_peak: Option<u64>,
    seconds: f64,
    seconds_per_view: f64,
}

/// `mvscope bench --scale 25,100,400`: ACMM over demo scenes of growing view counts at a fixed
/// size and device budget, each `mvscope run` in its own process (so its peak resident
/// memory is its own): the device peak, the host peak and the time per view.
pub(super) fn bench_scale(
    counts: &[usize],
    sizes: &[String],
    device_mib: f64,
    json: &Path,
) -> Result<()> {
    let size = match sizes.first() {
        Some(s) => parse_size("--size", s)?,
        None => (64, 48),
    };
    let exe = std::env::current_exe().context("cannot tell where this mvscope is")?;
    let root = super::cluster::TempFolder(
        std::env::temp_dir().join(format!("mvscope-bench-scale-{}", std::process::id())),
    );
    std::fs::create_dir_all(&root.0).context("a temporary folder for the scenes")?;
    println!(
        "ACMM, demo scenes of {}x{} with 4 sources a view, device budget {device_mib} MiB, states between stages on disk, each run in its own process",
        size.0, size.1
    );
    println!(
        "{:>6} {:>8} {:>16} {:>16} {:>10} {:>10}",
        "views", "batches", "device peak MiB", "host peak MiB", "run s", "s/view"
    );
    let mut rows = Vec::new();
    for &n in counts {
        let scene_dir = root.0.join(format!("scene-{n}"));
        let out_dir = root.0.join(format!("out-{n}"));
        // Four sources a view, its neighbours (a sequence of photos, as a walk-through
        // gives): what a view holds does not grow with the scene.
        let options = mvscope::synthetic::SyntheticOptions {
            views: n,
            width: size.0,
            height: size.1,
            sources: 4,
            ..Default::default()
        };
        let generated = mvscope::synthetic::generate(&options)?;
        mvscope::synthetic::write_demo(&generated, &scene_dir)?;
        drop(generated);
        let started = std::time::Instant::now();
        let out = std::process::Command::new(&exe)
            .arg("run")
            .arg(&scene_dir)
            .arg("--out")
            .arg(&out_dir)
            .args(["--no-fuse", "--device-memory", &device_mib.to_string()])
            // The states between stages on disk only (OUT/work), as for a scene whose states
            // do not fit the host: what stays in memory is then the batch at hand.
            .args(["--host-memory", "0"])
            .output()
            .context("running mvscope run")?;
        if !out.status.success() {
            bail!("the run failed: {}", String::from_utf8_lossy(&out.stderr));
        }
        let seconds = started.elapsed().as_secs_f64();
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out_dir.join("report.json"))?)?;
        let _ = std::fs::remove_dir_all(&out_dir);
        let _ = std::fs::remove_dir_all(&scene_dir);
        let row = ScaleRow {
            views: n,
            batches: report["batches"].as_u64().unwrap_or(0) as usize,
            device_budget: report["device_budget"].as_u64(),
            device_peak: report["device_memory_peak"].as_u64().unwrap_or(0),
            host_peak: report["host_memory_peak"].as_u64(),
            seconds,
            seconds_per_view: seconds / n.max(1) as f64,
        };
        let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
        println!(
            "{:>6} {:>8} {:>16.1} {:>16.1} {:>10.1} {:>10.3}",
            row.views,
            row.batches,
            mib(row.device_peak),
            row.host_peak.map_or(f64::NAN, mib),
            row.seconds,
            row.seconds_per_view
        );
        rows.push(row);
    }
    let text = serde_json::to_string_pretty(&rows)?;
    std::fs::write(json, text).with_context(|| format!("writing {}", json.display()))?;
    println!("report: {}", json.display());
    Ok(())
}
