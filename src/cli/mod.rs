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

mod bench;
mod cluster;
mod tools;
mod view;

use bench::*;
use tools::*;
use view::*;

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
        /// confidence, image; with ACMP/ACMMP also prior-depth, prior-normal, prior-weight,
        /// prior-effect, support-points, triangulation, anchors), `cloud` for the 3D view of the fused
        /// maps, or `compare` for the Compare tab with every method run to its end.
        #[arg(long, value_name = "NAME")]
        map: Option<String>,
        /// With --screenshot: window size.
        #[arg(long, value_name = "WxH", default_value = "1280x800")]
        size: String,
        /// With --screenshot: show the guided tour under the maps (hidden otherwise).
        #[arg(long)]
        tour: bool,
        /// Device memory to plan with, MiB: a scene beyond it runs each stage in batches,
        /// as `mvscope run --device-memory` does.
        #[arg(long, value_name = "MIB")]
        device_memory: Option<f64>,
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
        /// Continue an interrupted run in the same folder, from its last resume point
        /// (OUT/work: a batched run's last finished batch, else its last saved stage end;
        /// ACMH and DWTA also keep their finished views).
        #[arg(long)]
        resume: bool,
        #[command(flatten)]
        memory: MemoryArgs,
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
    Eval(EvalArgs),
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
        /// A closed room: textured side walls and ceiling meet the low-texture back wall.
        #[arg(long)]
        room: bool,
        /// The most source views a view gets (the best by geometry).
        #[arg(long, default_value_t = 20)]
        sources: usize,
    },
    /// Describe a scene: format, views, image sizes, depth ranges, source views, and
    /// whether a run fits this device (at once, or in batches).
    Info {
        /// Scene folder (ACMM/MVSNet, COLMAP, Strecha) or Middlebury *_par.txt.
        scene: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
        /// Device memory to plan with, MiB (default: what the adapter, MVSCOPE_DEVICE_MEMORY_MB
        /// or, for a software adapter, the host's memory says, less headroom).
        #[arg(long, value_name = "MIB")]
        device_memory: Option<f64>,
        /// The method whose run is planned.
        #[arg(long, value_enum, default_value = "acmm")]
        method: Method,
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
            default_value = "dwta,acmh,acmm,acmp,acmmp,regions"
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
        /// With --accuracy: run every scene and method once per seed (comma separated, e.g.
        /// 0,1,2,3) and show the mean with the least and greatest share within 2% over the
        /// seeds: how much of a difference the random initialisation alone makes.
        #[arg(long, value_delimiter = ',', value_name = "SEED,...")]
        seeds: Vec<u64>,
        /// With --accuracy: a diagnosis of the planar prior (ACMP, ACMMP), its support points
        /// judged by the ground truth. `depth`: they take the true depths (and normals);
        /// `filter`: only those within 2% of it are kept; `select`: each cell's is chosen
        /// among the pixels the estimate has within 2%. What changes bounds what better
        /// support points could give (docs/accuracy.md).
        #[arg(long, value_name = "MODE")]
        prior_oracle: Option<mvscope::acmm::planar::PriorOracle>,
        /// With --prior-oracle select or filter and prior_anchors: the anchors may also sit
        /// on this percentage of the wrong pixels the real test of strong pixels passes (its
        /// false positives), so runs at several values say how precise a test must be for the
        /// anchors to help (docs/accuracy.md).
        #[arg(long, value_name = "PERCENT", value_parser = clap::value_parser!(u32).range(0..=100))]
        prior_oracle_admit: Option<u32>,
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
        /// Instead: whole ACMM runs of demo scenes of these view counts (e.g. 25,100,400) at
        /// --size (default 64x48, 4 sources a view) within a fixed --device-memory (default
        /// 4 MiB), each `mvscope run` in its own process: device peak, host peak resident
        /// memory and time per view, which stay flat as the views grow.
        #[arg(long, value_delimiter = ',', value_name = "N,...")]
        scale: Vec<usize>,
        /// With --scene or --scale: the device memory to plan with, MiB.
        #[arg(long, value_name = "MIB")]
        device_memory: Option<f64>,
    },
}

/// What a run computes: its scene, method, parameters and views (`run` and `plan`).
/// `mvscope eval`'s arguments.
#[derive(clap::Args)]
struct EvalArgs {
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
    /// A ground-truth point cloud (PLY) to score DIR/fused.ply against (default: the
    /// truth's depth maps of the run's views back-projected, one point per cube of half the
    /// smallest threshold, as the accuracy suite scores the rooms).
    #[arg(long, value_name = "GT.ply")]
    cloud: Option<PathBuf>,
    /// Cloud distance thresholds in scene units.
    #[arg(long, value_delimiter = ',', default_value = "0.02,0.05,0.1")]
    cloud_thresholds: Vec<f64>,
    /// Where the camera check finds views whose images and cameras disagree: write the
    /// scene to this new folder as an ACMM folder (images, cams, pair.txt, and the
    /// truth's gt/) with those views' principal points corrected, to run and score again.
    #[arg(long, value_name = "DIR")]
    write_cameras: Option<PathBuf>,
}

#[derive(clap::Args)]
struct RunSpec {
    /// Scene folder (ACMM/MVSNet, COLMAP, Strecha) or Middlebury *_par.txt.
    scene: PathBuf,
    /// Algorithm: ACMM (multi-scale, the paper's), ACMH (one scale), DWTA (baseline), ACMP
    /// or ACMMP (with the planar prior), Regions (ACMMP with one plane per flat region).
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

/// The parameters every command builds the same way: the method's defaults
/// (`Method::defaults`), then `--params FILE`, then each `--set NAME=VALUE`.
fn load_params(method: Method, file: Option<&Path>, sets: &[String]) -> Result<Params> {
    let base = match file {
        Some(p) => {
            Params::from_toml_file_over(p, &method.defaults()).map_err(anyhow::Error::msg)?
        }
        None => method.defaults(),
    };
    base.with_overrides(sets).map_err(anyhow::Error::msg)
}

impl RunSpec {
    /// The parameters: defaults, then --params, then each --set, then --seed.
    fn params(&self) -> Result<Params> {
        let mut params = load_params(self.method, self.params.as_deref(), &self.sets)?;
        if let Some(s) = self.seed {
            params.seed = s;
        }
        Ok(params)
    }

    /// The scene (images decoded if `decode`; distorted images undistorted into
    /// OUT/undistorted) and the record `params.toml` keeps.
    fn load(&self, out: &Path, decode: bool) -> Result<(RunRecord, Scene)> {
        self.load_quietly(out, decode, false)
    }

    /// [`RunSpec::load`], saying the scene's warnings unless `quiet` (a second load of it).
    fn load_quietly(&self, out: &Path, decode: bool, quiet: bool) -> Result<(RunRecord, Scene)> {
        let params = self.params()?;
        let mut options = self.load.options()?;
        options.undistort_cache = Some(out.join("undistorted"));
        if !decode {
            options.decode_only = Some(Vec::new());
        }
        let full = Scene::load(&self.scene, &options)?;
        if !quiet {
            for w in &full.warnings {
                eprintln!("warning: {w}");
            }
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
        let mut params = params;
        if self.method.deepens_pyramid(&params) {
            // The record keeps the number of scales the images decided, so a batch, a
            // resumed run and a cluster task build the same pyramid without the pixels.
            use mvscope::acmm::pyramid_depth;
            let depth = if pyramid_depth::sample_decoded(&scene) {
                pyramid_depth::resolve(&mut params, self.method, &scene)
            } else {
                // One sampled image at a time: 16 decoded 12 Mpx views would hold gigabytes.
                let long_side = scene.long_side();
                let radius = params.window_radius;
                let n = scene.views.len();
                pyramid_depth::resolve_with(&mut params, self.method, n, long_side, |v| {
                    let mut one = options.clone();
                    one.decode_only = Some(vec![indices[v]]);
                    let loaded = Scene::load(&self.scene, &one).map_err(|e| e.to_string())?;
                    let image = &loaded.views[indices[v]].image;
                    pyramid_depth::view_reach(image, radius).ok_or_else(|| {
                        format!("view {v}'s image could not be measured for the pyramid's depth")
                    })
                })
            }
            .map_err(anyhow::Error::msg)?;
            if let (Some(depth), false) = (depth, quiet) {
                eprintln!("pyramid: {depth}");
            }
        }
        let record = RunRecord {
            mvscope_version: env!("CARGO_PKG_VERSION").to_string(),
            record_format: RunRecord::FORMAT,
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

/// `--device-memory` and `--host-memory` (MiB, fractions allowed) in bytes.
pub(crate) fn mib_bytes(mib: f64) -> u64 {
    (mib.max(0.0) * (1u64 << 20) as f64) as u64
}

/// How a run uses the device's and the host's memory.
#[derive(clap::Args, Clone, Debug, Default)]
pub(crate) struct MemoryArgs {
    /// Device memory to plan with, MiB. When every view does not fit at once, each stage
    /// streams its views through the device in batches that fit (same maps, byte for byte).
    /// Default: what MVSCOPE_DEVICE_MEMORY_MB or, for a software adapter, the host's memory
    /// says, less headroom; on a GPU, no limit unless given.
    #[arg(long, value_name = "MIB")]
    device_memory: Option<f64>,
    /// Host memory the states between stages may take before a batched run keeps them on
    /// disk only (OUT/work), MiB (default: half of the available memory).
    #[arg(long, value_name = "MIB")]
    host_memory: Option<f64>,
    /// Keep OUT/work (the states between stages and the resume point) after the run.
    #[arg(long)]
    keep_work: bool,
    /// Seconds between two resume points of a run that holds every view at once (saved at
    /// a stage's end; a batched run saves one at every batch).
    #[arg(long, value_name = "SECS", default_value_t = 60)]
    checkpoint_interval: u64,
}

impl MemoryArgs {
    fn options(&self) -> mvscope::pipeline::MemoryOptions {
        mvscope::pipeline::MemoryOptions {
            device_budget: self.device_memory.map(mib_bytes),
            max_batch: None,
            host_budget: self.host_memory.map(mib_bytes),
            keep_work: self.keep_work,
            checkpoint_interval: std::time::Duration::from_secs(self.checkpoint_interval),
        }
    }
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
    memory: MemoryArgs,
) -> Result<()> {
    // Sizes and sources first: whether the run fits, and how, before anything is decoded
    // or written.
    let (record, sized) = spec.load(&out, false)?;
    let ctx = GpuContext::new()?;
    eprintln!("GPU: {}", ctx.describe_with_caveat());
    let memory = memory.options();
    let session_options = mvscope::session::SessionOptions {
        device_budget: memory.device_budget,
        ..Default::default()
    };
    let plan = mvscope::session::Session::plan(
        &ctx,
        &sized,
        &record.params,
        record.method,
        &session_options,
    )?;
    // Fail on an unwritable output before the long work.
    writable_folder(&out)?;
    let (scene, images) = if plan.resident {
        // Every view at once: decoded now, in parallel.
        let (_, scene) = spec.load_quietly(&out, true, true)?;
        (scene, None)
    } else {
        eprintln!(
            "{} batches of up to {} view{} (device budget {:.1} MiB, every view at once needs more): each view's image is decoded when its batch runs",
            plan.batches.len(),
            plan.largest_batch(),
            if plan.largest_batch() == 1 { "" } else { "s" },
            plan.budget.unwrap_or(0) as f64 / (1u64 << 20) as f64
        );
        let mut options = spec.load.options()?;
        options.undistort_cache = Some(out.join("undistorted"));
        let decode = mvscope::pipeline::decoder(&record, &options)?;
        (sized, Some(decode))
    };
    let run_options = RunOptions {
        out: out.clone(),
        fuse: !no_fuse,
        export_acmm: export.contains(&ExportKind::Acmm),
        export_colmap: export.contains(&ExportKind::Colmap),
        resume,
        rerun,
        record,
        memory,
    };
    let cancel = cancel_flag();
    let bar = progress_bar(1);
    let report = mvscope::pipeline::run(
        &ctx,
        &scene,
        images,
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
        "{} on {} views in {:.1} s ({} steps{}{}); outputs in {}",
        report.method,
        report.views,
        report.total_ms / 1e3,
        report.steps,
        match report.fused_points {
            Some(n) => format!(", {n} fused points"),
            None => String::new(),
        },
        if report.batches > 1 {
            format!(", {} batches", report.batches)
        } else {
            String::new()
        },
        out.display()
    );
    if let Some(step) = report.resumed_at_step {
        println!("  resumed at step {step}");
    }
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
            device_memory,
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
            device_memory,
        }),
        Command::Run {
            spec,
            out,
            export,
            rerun,
            no_fuse,
            resume,
            memory,
        } => run(spec, out, export, rerun, no_fuse, resume, memory),
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
        Command::Eval(args) => eval(args),
        Command::Demo {
            out,
            views,
            width,
            height,
            seed,
            noise,
            room,
            sources,
        } => demo(
            out,
            SyntheticOptions {
                views,
                width,
                height,
                seed,
                noise_sigma: noise,
                room,
                sources,
            },
        ),
        Command::Info {
            scene,
            load,
            device_memory,
            method,
        } => info(scene, load, device_memory, method),
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
            seeds,
            prior_oracle,
            prior_oracle_admit,
            scene,
            cluster,
            scale,
            device_memory,
        } => match (viewer, accuracy) {
            (Some(size), _) => bench_viewer(&size),
            (None, None) if !scale.is_empty() => {
                bench_scale(&scale, &sizes, device_memory.unwrap_or(4.0), &json)
            }
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
                device_memory,
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
                seeds,
                options: mvscope::accuracy::Options {
                    stages,
                    prior_oracle,
                    oracle_admit: prior_oracle_admit.unwrap_or(0),
                },
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
