//! The `mvscope` command line (native only): a thin layer over the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use mvscope::acmm::{Method, Params};
use mvscope::gpu::GpuContext;
use mvscope::pipeline::{RunEvent, RunOptions, RunRecord};
use mvscope::scene::{DepthRange, LoadOptions, Scene, SceneFormat};
use mvscope::synthetic::{self, SyntheticOptions};

mod cluster;

/// ACMM multi-view stereo (Xu & Tao, CVPR 2019) on the GPU, with a CPU reference.
///
/// Reads ACMM/MVSNet folders, COLMAP models, Middlebury and Strecha scenes; writes depth,
/// normal and cost maps (PFM), a fused coloured point cloud (PLY), and optionally the
/// original ACMM layout and a COLMAP dense workspace.
#[derive(Parser)]
#[command(name = "mvscope", version)]
struct Cli {
    /// Without a command: the viewer on the built-in demo scene.
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ExportKind {
    /// The original ACMM output layout (ACMM/2333_%08d/*.dmb, ACMM/ACMM_model.ply).
    Acmm,
    /// A COLMAP dense workspace (colmap/: images, sparse, stereo/*.geometric.bin) that
    /// COLMAP's stereo_fusion reads.
    Colmap,
}

#[derive(Subcommand)]
enum Command {
    /// The interactive viewer: step through ACMM, inspect every map and pixel, tune
    /// parameters live, compare methods, orbit the fused cloud.
    ///
    /// Without SCENE, the built-in demo scene (with ground truth). With --screenshot, renders
    /// the window headlessly (no display server needed) to a PNG and exits.
    View {
        /// Scene folder (ACMM/MVSNet, COLMAP, Strecha) or Middlebury *_par.txt.
        scene: Option<PathBuf>,
        #[arg(long, value_enum, default_value = "acmm")]
        method: Method,
        #[command(flatten)]
        load: LoadArgs,
        /// Parameters from a TOML file (the one `mvscope run --params` reads).
        #[arg(long, value_name = "FILE.toml")]
        params: Option<PathBuf>,
        /// Set one parameter, e.g. --set tau0=0.7 (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        sets: Vec<String>,
        /// Size of the demo scene, e.g. 320x240 (default: 640x480 on a GPU, 320x240 on a
        /// software device).
        #[arg(long, value_name = "WxH")]
        demo_size: Option<String>,
        /// Render the window to this PNG and exit.
        #[arg(long, value_name = "FILE.png")]
        screenshot: Option<PathBuf>,
        /// With --screenshot: run this many steps first.
        #[arg(long, default_value_t = 0)]
        steps: usize,
        /// With --screenshot: the map to show (depth, normal, cost, selected-count, selected,
        /// weight, winner, reprojection-error, restorer-difference, replaced, depth-error,
        /// image), `cloud` for the 3D view of the fused maps, or `compare` for the Compare tab
        /// with every method run to its end.
        #[arg(long, value_name = "NAME")]
        map: Option<String>,
        /// With --screenshot: window size.
        #[arg(long, value_name = "WxH", default_value = "1280x800")]
        size: String,
        /// With --screenshot: show the guided tour under the maps (hidden otherwise).
        #[arg(long)]
        tour: bool,
    },
    /// Estimate depth maps for a scene and fuse them into a point cloud.
    ///
    /// Writes DIR/depth/%08d.pfm, DIR/normal/%08d.pfm (world frame), DIR/cost/%08d.pfm
    /// (indexed in the scene's view order, at the processed resolution), DIR/fused.ply,
    /// DIR/params.toml (everything to reproduce the run) and DIR/report.json.
    Run {
        #[command(flatten)]
        spec: RunSpec,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Also write other tools' layouts.
        #[arg(long, value_enum, value_delimiter = ',')]
        export: Vec<ExportKind>,
        /// Log cameras, maps per stage and the cloud to this Rerun file (needs a build with
        /// `--features rerun`).
        #[arg(long, value_name = "FILE.rrd")]
        rerun: Option<PathBuf>,
        /// Skip fusion.
        #[arg(long)]
        no_fuse: bool,
        /// Continue an interrupted run in the same folder: finished views are kept (ACMH and
        /// DWTA; ACMM resumes only a finished run, to fuse or export again).
        #[arg(long)]
        resume: bool,
    },
    /// Split a run over a cluster: writes a job chain into DIR (Slurm: DIR/submit.sh, one
    /// job array per stage, each after the previous, then fusion; Kubernetes: one Indexed
    /// Job per stage). When the chain has run, DIR holds what `mvscope run` writes, the maps
    /// byte for byte. Needs no GPU (plan on a login node).
    Plan {
        #[command(flatten)]
        spec: RunSpec,
        /// The work folder, on storage every node shares.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        cluster: cluster::PlanArgs,
        /// Also write other tools' layouts (in the fusion job).
        #[arg(long, value_enum, value_delimiter = ',')]
        export: Vec<ExportKind>,
        /// Skip fusion (the last job only writes report.json).
        #[arg(long)]
        no_fuse: bool,
    },
    /// Run one unit of a plan: a stage of a chunk of views, or the fusion. What the
    /// scheduler's jobs call; a unit whose outputs exist is skipped.
    Task {
        /// The work folder of `mvscope plan`.
        dir: PathBuf,
        /// The stage (0-based, as `mvscope plan` lists them).
        #[arg(long, conflicts_with = "fuse", required_unless_present = "fuse")]
        stage: Option<usize>,
        /// The chunk (default: $SLURM_ARRAY_TASK_ID or $JOB_COMPLETION_INDEX).
        #[arg(long)]
        chunk: Option<usize>,
        /// Fuse the finished maps and write report.json.
        #[arg(long)]
        fuse: bool,
    },
    /// Fuse the depth maps of a finished run again (e.g. with other thresholds).
    Fuse {
        /// The output folder of `mvscope run`.
        dir: PathBuf,
        /// Override a fusion parameter, e.g. --set fusion_min_views=3.
        #[arg(long = "set", value_name = "NAME=VALUE")]
        sets: Vec<String>,
    },
    /// Score a run's depth maps (and cloud) against ground truth.
    Eval {
        /// The output folder of `mvscope run`.
        dir: PathBuf,
        /// Ground truth: a scene folder with gt/%08d.pfm depth maps (the demo scene,
        /// Middlebury 2014 folders) and optional gt/%08d_lowtex.png masks.
        #[arg(long)]
        gt: PathBuf,
        /// Absolute depth thresholds in scene units (the paper's 2 cm and 10 cm).
        #[arg(long, value_delimiter = ',', default_value = "0.02,0.1")]
        abs: Vec<f64>,
        /// Relative depth thresholds.
        #[arg(long, value_delimiter = ',', default_value = "0.01,0.02,0.05")]
        rel: Vec<f64>,
        /// A ground-truth point cloud (PLY) to score DIR/fused.ply against.
        #[arg(long, value_name = "GT.ply")]
        cloud: Option<PathBuf>,
        /// Cloud distance thresholds in scene units.
        #[arg(long, value_delimiter = ',', default_value = "0.02,0.05,0.1")]
        cloud_thresholds: Vec<f64>,
    },
    /// Write the built-in synthetic scene (ACMM folder + ground truth in gt/).
    Demo {
        /// Output folder (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Number of views.
        #[arg(long, default_value_t = 5)]
        views: usize,
        /// Image width in pixels.
        #[arg(long, default_value_t = 640)]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 480)]
        height: u32,
        /// Seed of textures and sensor noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Sensor noise standard deviation in grey levels.
        #[arg(long, default_value_t = 1.0)]
        noise: f32,
    },
    /// Describe a scene: format, views, image sizes, depth ranges, source views.
    Info {
        /// Scene folder (ACMM/MVSNet, COLMAP, Strecha) or Middlebury *_par.txt.
        scene: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Convert a scene to another format (COLMAP model to ACMM folder, as the authors'
    /// converter does, or any scene to a COLMAP model).
    Convert {
        scene: PathBuf,
        /// Target format.
        #[arg(long, value_enum)]
        to: ExportKind,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Show the GPU adapter mvscope would use and its limits.
    Gpu,
    /// Benchmark ACMH: time per pass and cost evaluations per second, GPU and CPU reference;
    /// ACMM against ACMH per stage.
    Bench {
        /// Smaller scenes (320x240 and 640x480) for a quick look.
        #[arg(long)]
        quick: bool,
        /// Also benchmark this fountain-P11 folder (the paper's Strecha scene).
        #[arg(long, value_name = "DIR")]
        fountain: Option<PathBuf>,
        /// Cap the fountain's long side (default: full size on a hardware GPU, 800 on a
        /// software one).
        #[arg(long, value_name = "N")]
        fountain_max_size: Option<u32>,
        /// ACMH iterations per run.
        #[arg(long, default_value_t = 3)]
        iterations: u32,
        /// Skip the CPU-reference comparison.
        #[arg(long)]
        no_cpu: bool,
        /// Only these synthetic sizes (repeatable, e.g. --size 320x240) instead of the default
        /// pair.
        #[arg(long = "size", value_name = "WxH")]
        sizes: Vec<String>,
        /// Skip the whole-scene ACMM-against-ACMH comparison.
        #[arg(long)]
        no_methods: bool,
        /// Also time each size with the generic matching pipelines (window read from the
        /// parameters) against the per-window ones the runs use.
        #[arg(long)]
        window_ab: bool,
        /// Where to save the JSON report.
        #[arg(long, default_value = "mvscope-bench.json")]
        json: PathBuf,
        /// Instead: the viewer's frame time and parameter-change latency on the demo scene
        /// of this size (e.g. 640x480), rendered headlessly.
        #[arg(long, value_name = "WxH")]
        viewer: Option<String>,
        /// Instead: the ground-truth accuracy table — every method on every scene with
        /// ground truth under DATA (middlebury2014/*, middlebury2006/*) and on the synthetic
        /// scene: share within 1% and 2% depth error, overall and on weak texture.
        #[arg(long, value_name = "DATA", num_args = 0..=1, default_missing_value = "../shared/data")]
        accuracy: Option<PathBuf>,
        /// With --accuracy: cap every scene's long side (default: full size).
        #[arg(long, value_name = "N")]
        max_image_size: Option<u32>,
        /// With --accuracy: only scenes whose name contains one of these (comma separated;
        /// `synthetic` for the synthetic scene).
        #[arg(long, value_delimiter = ',')]
        scenes: Vec<String>,
        /// With --accuracy: the methods (comma separated).
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "dwta,acmh,acmm,acmp,acmmp"
        )]
        methods: Vec<Method>,
        /// With --accuracy: the synthetic scene's size.
        #[arg(long, value_name = "WxH", default_value = "320x240")]
        synthetic_size: String,
        /// With --accuracy: parameters from a TOML file.
        #[arg(long)]
        params: Option<PathBuf>,
        /// With --accuracy: set one parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        sets: Vec<String>,
        /// With --accuracy: also score every stage (where a method gains or loses accuracy).
        #[arg(long)]
        stages: bool,
        /// Instead: whole-scene runs of --methods on this scene (all views), the real path
        /// of `mvscope run` from loading to the written maps (fusion off): seconds per view,
        /// cost evaluations per second, bytes moved and device memory. --max-image-size caps
        /// the long side.
        #[arg(long, value_name = "DIR")]
        scene: Option<PathBuf>,
        /// Instead: a cluster task's peak resident memory as the scene grows — demo scenes
        /// of these view counts (comma separated, e.g. 50,100,200,400) at --size (default
        /// 160x120), in tasks of 4 views; stage 0 of the first task runs in its own process.
        #[arg(long, value_delimiter = ',', value_name = "N,...")]
        cluster: Vec<usize>,
    },
}

/// What a run computes: its scene, method, parameters and views (`run` and `plan`).
#[derive(clap::Args)]
struct RunSpec {
    /// Scene folder (ACMM/MVSNet, COLMAP, Strecha) or Middlebury *_par.txt.
    scene: PathBuf,
    /// Algorithm: ACMM (multi-scale, the paper's), ACMH (one scale), DWTA (baseline), ACMP
    /// or ACMMP (with the planar prior).
    #[arg(long, value_enum, default_value = "acmm")]
    method: Method,
    #[command(flatten)]
    load: LoadArgs,
    /// Seed of the random initialisation and refinement.
    #[arg(long)]
    seed: Option<u64>,
    /// Parameters from a TOML file (any subset; a run's params.toml works too).
    #[arg(long, value_name = "FILE.toml")]
    params: Option<PathBuf>,
    /// Set one parameter, e.g. --set tau0=0.7 (repeatable; names as in params.toml).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    sets: Vec<String>,
    /// Only these views, by scene index: e.g. 0,2,5-8.
    #[arg(long, value_name = "LIST")]
    views: Option<String>,
}

impl RunSpec {
    /// The parameters: defaults, then --params, then each --set, then --seed.
    fn params(&self) -> Result<Params> {
        let base = match &self.params {
            Some(p) => Params::from_toml_file(p).map_err(anyhow::Error::msg)?,
            None => Params::default(),
        };
        let mut params = base
            .with_overrides(&self.sets)
            .map_err(anyhow::Error::msg)?;
        if let Some(s) = self.seed {
            params.seed = s;
        }
        Ok(params)
    }

    /// The scene (images decoded if `decode`; distorted images undistorted into
    /// OUT/undistorted) and the record `params.toml` keeps.
    fn load(&self, out: &Path, decode: bool) -> Result<(RunRecord, Scene)> {
        let params = self.params()?;
        let mut options = self.load.options()?;
        options.undistort_cache = Some(out.join("undistorted"));
        if !decode {
            options.decode_only = Some(Vec::new());
        }
        let full = Scene::load(&self.scene, &options)?;
        for w in &full.warnings {
            eprintln!("warning: {w}");
        }
        let indices = match &self.views {
            Some(list) => parse_views(list, full.views.len())?,
            None => (0..full.views.len()).collect(),
        };
        let scene = if self.views.is_some() {
            full.subset(&indices)?
        } else {
            full
        };
        let record = RunRecord {
            mvscope_version: env!("CARGO_PKG_VERSION").to_string(),
            method: self.method,
            scene: std::fs::canonicalize(&self.scene).unwrap_or(self.scene.clone()),
            format: scene.format,
            max_image_size: self.load.max_image_size,
            model: self.load.model,
            depth_range: options.depth_range.map(|r| [r.min, r.max]),
            views: indices,
            params,
        };
        Ok((record, scene))
    }
}

/// Creates `out` and checks that it is writable, before any long work.
fn writable_folder(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create the output folder {}", out.display()))?;
    let probe = out.join(".mvscope-write-test");
    std::fs::write(&probe, b"")
        .with_context(|| format!("the output folder {} is not writable", out.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// How to read a scene.
#[derive(clap::Args)]
struct LoadArgs {
    /// Read this format instead of detecting it.
    #[arg(long, value_enum)]
    format: Option<SceneFormat>,
    /// Downscale images so that their long side is at most N pixels.
    #[arg(long, value_name = "N")]
    max_image_size: Option<u32>,
    /// Depth range of every view, overriding the input's.
    #[arg(long, num_args = 2, value_names = ["MIN", "MAX"])]
    depth_range: Option<Vec<f64>>,
    /// COLMAP: the model in sparse/N (`mvscope info` lists them; default 0).
    #[arg(long, value_name = "N")]
    model: Option<u32>,
}

impl LoadArgs {
    fn options(&self) -> Result<LoadOptions> {
        let depth_range = match self.depth_range.as_deref() {
            None => None,
            Some([min, max]) => Some(
                DepthRange::new(*min, *max).map_err(|m| anyhow::anyhow!("--depth-range: {m}"))?,
            ),
            Some(_) => bail!("--depth-range takes two numbers: MIN MAX"),
        };
        if self.max_image_size == Some(0) {
            bail!("--max-image-size must be at least 1");
        }
        Ok(LoadOptions {
            format: self.format,
            max_image_size: self.max_image_size,
            depth_range,
            model: self.model,
            undistort_cache: None,
            decode_only: None,
        })
    }
}

/// "0,2,5-8" -> [0, 2, 5, 6, 7, 8].
fn parse_views(list: &str, count: usize) -> Result<Vec<usize>> {
    let mut views = Vec::new();
    for part in list.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let parse = |s: &str| -> Result<usize> {
            s.trim()
                .parse()
                .with_context(|| format!("--views: '{s}' is not a view index"))
        };
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (parse(a)?, parse(b)?);
                if a > b {
                    bail!("--views: range {part} runs backwards");
                }
                views.extend(a..=b);
            }
            None => views.push(parse(part)?),
        }
    }
    if let Some(&bad) = views.iter().find(|&&v| v >= count) {
        bail!(
            "--views: the scene has views 0..{} ({bad} is not one)",
            count.saturating_sub(1)
        );
    }
    if views.is_empty() {
        bail!("--views: no view given");
    }
    Ok(views)
}

fn progress_bar(total: u64) -> ProgressBar {
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}

fn cancel_flag() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = flag.clone();
    if let Err(e) = ctrlc::set_handler(move || {
        f.store(true, Ordering::Relaxed);
    }) {
        log::warn!("Ctrl-C will stop the run abruptly: {e}");
    }
    flag
}

#[allow(clippy::too_many_arguments)]
fn run(
    spec: RunSpec,
    out: PathBuf,
    export: Vec<ExportKind>,
    rerun: Option<PathBuf>,
    no_fuse: bool,
    resume: bool,
) -> Result<()> {
    // Fail on an unwritable output before the long work.
    writable_folder(&out)?;
    let (record, scene) = spec.load(&out, true)?;
    let ctx = GpuContext::new()?;
    eprintln!("GPU: {}", ctx.describe());
    let run_options = RunOptions {
        out: out.clone(),
        fuse: !no_fuse,
        export_acmm: export.contains(&ExportKind::Acmm),
        export_colmap: export.contains(&ExportKind::Colmap),
        resume,
        rerun,
        record,
    };
    let cancel = cancel_flag();
    let bar = progress_bar(1);
    let report = mvscope::pipeline::run(
        &ctx,
        &scene,
        &run_options,
        &mut |event| match event {
            RunEvent::Step { step, index, total } => {
                bar.set_length(total as u64);
                bar.set_position(index as u64);
                bar.set_message(step.label());
            }
            RunEvent::Phase(p) => bar.set_message(p.to_string()),
        },
        &cancel,
    );
    bar.finish_and_clear();
    let report = report?;
    println!(
        "{} on {} views in {:.1} s ({} steps{}); outputs in {}",
        report.method,
        report.views,
        report.total_ms / 1e3,
        report.steps,
        match report.fused_points {
            Some(n) => format!(", {n} fused points"),
            None => String::new(),
        },
        out.display()
    );
    for s in &report.stages {
        println!(
            "  scale {} {:<20} {:>8.1} s",
            s.level + 1,
            s.stage,
            s.ms / 1e3
        );
    }
    println!("  {}", traffic_line(&report));
    Ok(())
}

/// Bytes moved and device memory of a run, in one line.
fn traffic_line(report: &mvscope::pipeline::RunReport) -> String {
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

struct SceneBenchArgs {
    dir: PathBuf,
    max_image_size: Option<u32>,
    methods: Vec<Method>,
    params: Option<PathBuf>,
    sets: Vec<String>,
    json: PathBuf,
}

/// `mvscope bench --scene DIR`: each method over the whole scene through `pipeline::run`.
fn bench_scene(args: SceneBenchArgs) -> Result<()> {
    let base = match &args.params {
        Some(p) => Params::from_toml_file(p).map_err(anyhow::Error::msg)?,
        None => Params::default(),
    };
    let params = base
        .with_overrides(&args.sets)
        .map_err(anyhow::Error::msg)?;
    let started = web_time::Instant::now();
    let options = LoadOptions {
        max_image_size: args.max_image_size,
        ..LoadOptions::default()
    };
    let scene = Scene::load(&args.dir, &options)?;
    let load_s = started.elapsed().as_secs_f64();
    let ctx = GpuContext::new()?;
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
        ctx.describe()
    );
    let cancel = AtomicBool::new(false);
    let mut reports = Vec::new();
    for &method in &args.methods {
        let out =
            std::env::temp_dir().join(format!("mvscope-bench-{}-{method}", std::process::id()));
        let record = RunRecord {
            mvscope_version: env!("CARGO_PKG_VERSION").to_string(),
            method,
            scene: args.dir.clone(),
            format: scene.format,
            max_image_size: args.max_image_size,
            model: None,
            depth_range: None,
            views: (0..scene.views.len()).collect(),
            params: params.clone(),
        };
        let run_options = RunOptions {
            out: out.clone(),
            fuse: false,
            export_acmm: false,
            export_colmap: false,
            resume: false,
            rerun: None,
            record,
        };
        let report = mvscope::pipeline::run(&ctx, &scene, &run_options, &mut |_| {}, &cancel);
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

fn reload(dir: &Path) -> Result<(RunRecord, Scene)> {
    let record = RunRecord::read(&dir.join("params.toml"))?;
    let options = LoadOptions {
        format: record.format,
        max_image_size: record.max_image_size,
        depth_range: match record.depth_range {
            Some([a, b]) => Some(DepthRange::new(a, b).map_err(anyhow::Error::msg)?),
            None => None,
        },
        model: record.model,
        undistort_cache: Some(dir.join("undistorted")),
        decode_only: None,
    };
    let scene = Scene::load(&record.scene, &options).with_context(|| {
        format!(
            "reloading the scene recorded in {}/params.toml",
            dir.display()
        )
    })?;
    let scene = scene.subset(&record.views)?;
    Ok((record, scene))
}

fn fuse(dir: PathBuf, sets: Vec<String>) -> Result<()> {
    let (record, scene) = reload(&dir)?;
    let params = record
        .params
        .with_overrides(&sets)
        .map_err(anyhow::Error::msg)?;
    let mut depths = Vec::new();
    let mut normals = Vec::new();
    for (local, &index) in record.views.iter().enumerate() {
        let d = mvscope::io::read_pfm(&dir.join(format!("depth/{index:08}.pfm")))?;
        let n = mvscope::io::read_pfm(&dir.join(format!("normal/{index:08}.pfm")))?;
        let cam = &scene.views[local].camera;
        normals.push(
            n.data
                .chunks_exact(3)
                .map(|c| {
                    let v = cam.dir_camera_from_world(glam::DVec3::new(
                        c[0] as f64,
                        c[1] as f64,
                        c[2] as f64,
                    ));
                    [v.x as f32, v.y as f32, v.z as f32]
                })
                .collect::<Vec<_>>(),
        );
        depths.push(d.data);
    }
    let result = mvscope::fusion::fuse(
        &mvscope::fusion::FusionInput {
            scene: &scene,
            depths: &depths,
            normals: &normals,
        },
        &params,
    )?;
    let path = dir.join("fused.ply");
    mvscope::io::write_ply(&path, &result.points)?;
    println!(
        "{} points written to {}",
        result.points.len(),
        path.display()
    );
    Ok(())
}

fn eval(
    dir: PathBuf,
    gt: PathBuf,
    abs: Vec<f64>,
    rel: Vec<f64>,
    cloud: Option<PathBuf>,
    cloud_thresholds: Vec<f64>,
) -> Result<()> {
    let record = RunRecord::read(&dir.join("params.toml"))?;
    let report = mvscope::eval::evaluate_run(&dir, &record.views, &gt, &abs, &rel)?;
    print!("{}", mvscope::eval::format_depth_report(&report));
    let mut json = serde_json::json!({ "depth": report });
    if let Some(gt_cloud) = cloud {
        let rec = mvscope::io::read_ply(&dir.join("fused.ply"))?;
        let gtp = mvscope::io::read_ply(&gt_cloud)?;
        let r: Vec<[f32; 3]> = rec.iter().map(|p| p.position).collect();
        let g: Vec<[f32; 3]> = gtp.iter().map(|p| p.position).collect();
        let scores = mvscope::eval::cloud_scores(&r, &g, &cloud_thresholds);
        println!(
            "\ncloud ({} points) against {} ({} points):",
            r.len(),
            gt_cloud.display(),
            g.len()
        );
        println!(
            "  {:>10}  {:>9}  {:>12}  {:>6}",
            "threshold", "accuracy", "completeness", "F1"
        );
        for s in &scores {
            println!(
                "  {:>10}  {:>9.3}  {:>12.3}  {:>6.3}",
                s.threshold, s.accuracy, s.completeness, s.f1
            );
        }
        json["cloud"] = serde_json::to_value(&scores)?;
    }
    let path = dir.join("eval.json");
    let text = serde_json::to_string_pretty(&json)?;
    mvscope::io::write_atomic(&path, |w| std::io::Write::write_all(w, text.as_bytes()))?;
    println!("\nsaved {}", path.display());
    Ok(())
}

fn demo(out: PathBuf, options: SyntheticOptions) -> Result<()> {
    let started = web_time::Instant::now();
    let scene = synthetic::generate(&options)?;
    synthetic::write_demo(&scene, &out)
        .with_context(|| format!("writing the demo scene to {}", out.display()))?;
    println!(
        "wrote {} views of {}x{} (seed {}) to {} in {:.1} s",
        options.views,
        options.width,
        options.height,
        options.seed,
        out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn info(path: PathBuf, load: LoadArgs) -> Result<()> {
    let scene = Scene::load(&path, &load.options()?)?;
    let format = scene.format.map(|f| f.to_string()).unwrap_or_default();
    println!("{} — {format}, {} views", path.display(), scene.views.len());
    if scene.format == Some(SceneFormat::Colmap) {
        print_colmap_cameras(&path, load.model);
    }
    let models = mvscope::scene::colmap::list_models(&path);
    if scene.format == Some(SceneFormat::Colmap) && models.len() > 1 {
        println!(
            "COLMAP models under sparse/: {} (this is {}; choose another with --model N)",
            models
                .iter()
                .map(u32::to_string)
                .collect::<Vec<_>>()
                .join(", "),
            load.model.unwrap_or(models[0])
        );
    }
    println!(
        "{:>4}  {:<20} {:>11}  {:>23}  sources (index:score)",
        "#", "view", "size", "depth range"
    );
    for (i, v) in scene.views.iter().enumerate() {
        let sources: Vec<String> = v
            .sources
            .iter()
            .map(|s| format!("{}:{:.3}", s.index, s.score))
            .collect();
        println!(
            "{i:>4}  {:<20} {:>11}  [{:>9.4}, {:>9.4}]  {}",
            v.name,
            format!("{}x{}", v.image.width, v.image.height),
            v.depth_range.min,
            v.depth_range.max,
            sources.join(" ")
        );
    }
    for w in &scene.warnings {
        println!("warning: {w}");
    }
    // What a run at this size holds on the device (default parameters; the viewer's
    // checkpoints come on top), checked against the adapter when a run starts.
    let params = mvscope::acmm::Params::default();
    for method in [Method::Acmm, Method::Acmh] {
        let plan = mvscope::acmm::memory::MemoryPlan::for_scene(&scene, &params, method);
        println!(
            "device memory, {method} (default parameters): peak {:.1} MiB",
            plan.peak() as f64 / (1u64 << 20) as f64
        );
        print!("{}", plan.describe());
    }
    Ok(())
}

/// Each camera of the COLMAP model read: its model, its size, how many images use it, and
/// whether mvscope undistorts it on load.
fn print_colmap_cameras(root: &Path, model: Option<u32>) {
    use mvscope::scene::colmap;
    let dir = match model {
        Some(n) => Some(root.join("sparse").join(n.to_string())),
        None => colmap::find_model(root),
    };
    let Some(Ok(m)) = dir.map(|d| colmap::read_model(&d)) else {
        return;
    };
    for camera in m.cameras.values() {
        let users = m
            .images
            .values()
            .filter(|i| i.camera_id == camera.id)
            .count();
        let how = match colmap::camera_lens(camera) {
            Ok((_, Some(_))) => "undistorted on load to PINHOLE".to_string(),
            Ok((_, None)) => "pinhole, read as it is".to_string(),
            Err(e) => format!("unusable: {e}"),
        };
        println!(
            "camera {}: {} {}x{}, {users} image(s), {how}",
            camera.id, camera.model, camera.width, camera.height
        );
    }
}

fn convert(path: PathBuf, to: ExportKind, out: PathBuf, load: LoadArgs) -> Result<()> {
    let scene = Scene::load(&path, &load.options()?)?;
    match to {
        ExportKind::Acmm => mvscope::export::convert_to_acmm(&scene, &out)?,
        ExportKind::Colmap => mvscope::export::convert_to_colmap(&scene, &out)?,
    }
    println!(
        "wrote {} views of {} as {:?} to {}",
        scene.views.len(),
        path.display(),
        to,
        out.display()
    );
    Ok(())
}

fn gpu() -> Result<()> {
    let ctx = GpuContext::new()?;
    println!("adapter: {}", ctx.describe());
    println!(
        "timestamp queries: {}",
        ctx.features.contains(wgpu::Features::TIMESTAMP_QUERY)
    );
    let l = &ctx.limits;
    println!(
        "limits: storage binding {} MiB, buffer {} MiB, {} storage buffers per stage, texture 2D {} px, workgroup {} invocations",
        l.max_storage_buffer_binding_size >> 20,
        l.max_buffer_size >> 20,
        l.max_storage_buffers_per_shader_stage,
        l.max_texture_dimension_2d,
        l.max_compute_invocations_per_workgroup
    );
    Ok(())
}

struct PassBenchArgs {
    quick: bool,
    fountain: Option<PathBuf>,
    fountain_max_size: Option<u32>,
    iterations: u32,
    no_cpu: bool,
    sizes: Vec<String>,
    no_methods: bool,
    window_ab: bool,
    json: PathBuf,
}

fn bench(args: PassBenchArgs) -> Result<()> {
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

struct AccuracyArgs {
    data: PathBuf,
    max_image_size: Option<u32>,
    scenes: Vec<String>,
    methods: Vec<Method>,
    synthetic_size: String,
    params: Option<PathBuf>,
    sets: Vec<String>,
    json: PathBuf,
    stages: bool,
}

fn bench_accuracy(args: AccuracyArgs) -> Result<()> {
    use mvscope::accuracy;
    let base = match &args.params {
        Some(p) => Params::from_toml_file(p).map_err(anyhow::Error::msg)?,
        None => Params::default(),
    };
    let params = base
        .with_overrides(&args.sets)
        .map_err(anyhow::Error::msg)?;
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
    let with_synthetic = wanted("synthetic");
    if dirs.is_empty() && !with_synthetic {
        bail!(
            "{}: no scene with ground truth (expected middlebury2014/* or middlebury2006/* folders with gt/)",
            args.data.display()
        );
    }
    let ctx = GpuContext::new()?;
    let pipelines = std::sync::Arc::new(mvscope::gpu::acmh::AcmhPipelines::new(&ctx)?);
    eprintln!("accuracy on {}", ctx.describe());
    let mut suites = Vec::new();
    for d in &dirs {
        suites.push(accuracy::load_scene(d, args.max_image_size)?);
    }
    if with_synthetic {
        let (width, height) = parse_size("--synthetic-size", &args.synthetic_size)?;
        suites.push(accuracy::synthetic_scene(
            &mvscope::synthetic::SyntheticOptions {
                width,
                height,
                ..Default::default()
            },
        )?);
    }
    let mut rows = Vec::new();
    for suite in &suites {
        for &method in &args.methods {
            let row =
                accuracy::evaluate(&ctx, pipelines.clone(), suite, &params, method, args.stages)?;
            for st in &row.stages {
                eprintln!(
                    "  {:<36} {:5.1}% within 1%, {:5.1}% within 2%, weak texture within 2%: {}",
                    st.stage,
                    100.0 * st.within_1,
                    100.0 * st.within_2,
                    st.low_texture_within_2
                        .map_or("-".into(), |v| format!("{:.1}%", 100.0 * v))
                );
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
    print!("{}", accuracy::format_table(&rows));
    let text = serde_json::to_string_pretty(&rows)?;
    std::fs::write(&args.json, text)
        .with_context(|| format!("{}: cannot write it", args.json.display()))?;
    println!("\nsaved {}", args.json.display());
    Ok(())
}

fn bench_viewer(size: &str) -> Result<()> {
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

struct ViewArgs {
    scene: Option<PathBuf>,
    method: Method,
    load: Result<LoadOptions>,
    params: Option<PathBuf>,
    sets: Vec<String>,
    demo_size: Option<String>,
    screenshot: Option<PathBuf>,
    steps: usize,
    map: Option<String>,
    size: String,
    tour: bool,
}

impl ViewArgs {
    fn demo() -> ViewArgs {
        ViewArgs {
            scene: None,
            method: Method::Acmm,
            load: Ok(LoadOptions::default()),
            params: None,
            sets: Vec::new(),
            demo_size: None,
            screenshot: None,
            steps: 0,
            map: None,
            size: "1280x800".into(),
            tour: false,
        }
    }
}

/// "640x480" -> (640, 480).
pub(crate) fn parse_size(flag: &str, text: &str) -> Result<(u32, u32)> {
    let parsed = text
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match parsed {
        Some((w, h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => bail!("{flag}: '{text}' is not a size like 640x480"),
    }
}

fn view(args: ViewArgs) -> Result<()> {
    let params = match &args.params {
        Some(p) => Params::from_toml_file(p).map_err(anyhow::Error::msg)?,
        None => Params::default(),
    }
    .with_overrides(&args.sets)
    .map_err(anyhow::Error::msg)?;
    let options = mvscope::viewer::ViewerOptions {
        scene: args.scene,
        load: args.load?,
        params,
        method: args.method,
        demo_size: args
            .demo_size
            .as_deref()
            .map(|s| parse_size("--demo-size", s))
            .transpose()?,
        demo_views: None,
    };
    let Some(out) = args.screenshot else {
        if args.map.is_some() || args.steps > 0 || args.tour {
            bail!("--steps, --map and --tour go with --screenshot");
        }
        return mvscope::viewer::run_native(options);
    };
    let (map, cloud, compare) = match args.map.as_deref() {
        None => (None, false, false),
        Some("cloud") => (None, true, false),
        Some("compare") => (None, false, true),
        Some(name) => match mvscope::viewer::maps::MapKind::from_name(name) {
            Some(k) => (Some(k), false, false),
            None => bail!(
                "--map: unknown map '{name}'; one of {}, cloud or compare",
                mvscope::viewer::maps::MapKind::ALL
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
    };
    let shot = mvscope::viewer::ScreenshotOptions {
        steps: args.steps,
        map,
        cloud,
        size: parse_size("--size", &args.size)?,
        tour: args.tour,
        compare,
    };
    mvscope::viewer::screenshot(options, &shot, &out)?;
    println!("wrote {}", out.display());
    Ok(())
}

pub fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("mvscope=warn"))
        .format_timestamp(None)
        .init();
    let cli = Cli::parse();
    let Some(command) = cli.command else {
        return finish(view(ViewArgs::demo()));
    };
    let result = match command {
        Command::View {
            scene,
            method,
            load,
            params,
            sets,
            demo_size,
            screenshot,
            steps,
            map,
            size,
            tour,
        } => view(ViewArgs {
            scene,
            method,
            load: load.options(),
            params,
            sets,
            demo_size,
            screenshot,
            steps,
            map,
            size,
            tour,
        }),
        Command::Run {
            spec,
            out,
            export,
            rerun,
            no_fuse,
            resume,
        } => run(spec, out, export, rerun, no_fuse, resume),
        Command::Plan {
            spec,
            out,
            cluster,
            export,
            no_fuse,
        } => (|| {
            writable_folder(&out)?;
            let (record, scene) = spec.load(&out, false)?;
            cluster::plan(
                record,
                &scene,
                &out,
                &cluster,
                !no_fuse,
                export.contains(&ExportKind::Acmm),
                export.contains(&ExportKind::Colmap),
            )
        })(),
        Command::Task {
            dir,
            stage,
            chunk,
            fuse,
        } => cluster::task(&dir, stage, chunk, fuse),
        Command::Fuse { dir, sets } => fuse(dir, sets),
        Command::Eval {
            dir,
            gt,
            abs,
            rel,
            cloud,
            cloud_thresholds,
        } => eval(dir, gt, abs, rel, cloud, cloud_thresholds),
        Command::Demo {
            out,
            views,
            width,
            height,
            seed,
            noise,
        } => demo(
            out,
            SyntheticOptions {
                views,
                width,
                height,
                seed,
                noise_sigma: noise,
            },
        ),
        Command::Info { scene, load } => info(scene, load),
        Command::Convert {
            scene,
            to,
            out,
            load,
        } => convert(scene, to, out, load),
        Command::Gpu => gpu(),
        Command::Bench {
            quick,
            fountain,
            fountain_max_size,
            iterations,
            no_cpu,
            sizes,
            no_methods,
            window_ab,
            json,
            viewer,
            accuracy,
            max_image_size,
            scenes,
            methods,
            synthetic_size,
            params,
            sets,
            stages,
            scene,
            cluster,
        } => match (viewer, accuracy) {
            (Some(size), _) => bench_viewer(&size),
            (None, None) if !cluster.is_empty() => {
                cluster::bench_cluster(&cluster, &sizes, 4, &json)
            }
            (None, None) if scene.is_some() => bench_scene(SceneBenchArgs {
                dir: scene.unwrap_or_default(),
                max_image_size,
                methods,
                params,
                sets,
                json,
            }),
            (None, Some(data)) => bench_accuracy(AccuracyArgs {
                data,
                max_image_size,
                scenes,
                methods,
                synthetic_size,
                params,
                sets,
                json,
                stages,
            }),
            (None, None) => bench(PassBenchArgs {
                quick,
                fountain,
                fountain_max_size,
                iterations,
                no_cpu,
                sizes,
                no_methods,
                window_ab,
                json,
            }),
        },
    };
    finish(result)
}

fn finish(result: Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if let Some(mvscope::pipeline::RunError::Cancelled) = e.downcast_ref() {
                eprintln!("stopped: {e}");
                return ExitCode::from(130);
            }
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
