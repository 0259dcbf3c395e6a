//! The `mvscope` command line: a thin layer over the library.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use mvscope::gpu::GpuContext;
use mvscope::scene::{DepthRange, LoadOptions, Scene, SceneFormat};
use mvscope::synthetic::{self, SyntheticOptions};

/// ACMM multi-view stereo (Xu & Tao, CVPR 2019) on the GPU, with a CPU reference.
#[derive(Parser)]
#[command(name = "mvscope", version, arg_required_else_help = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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
    /// Show the GPU adapter mvscope would use and its limits.
    Gpu,
    /// Benchmark ACMH: time per pass and cost evaluations per second, GPU and CPU reference.
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
        /// Where to save the JSON report.
        #[arg(long, default_value = "mvscope-bench.json")]
        json: PathBuf,
    },
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
        })
    }
}

fn demo(out: PathBuf, options: SyntheticOptions) -> Result<()> {
    let started = std::time::Instant::now();
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
        "limits: storage binding {} MiB, buffer {} MiB, texture 2D {} px, workgroup {} invocations",
        l.max_storage_buffer_binding_size >> 20,
        l.max_buffer_size >> 20,
        l.max_texture_dimension_2d,
        l.max_compute_invocations_per_workgroup
    );
    Ok(())
}

fn bench(
    quick: bool,
    fountain: Option<PathBuf>,
    fountain_max_size: Option<u32>,
    iterations: u32,
    no_cpu: bool,
    json: PathBuf,
) -> Result<()> {
    if iterations == 0 {
        bail!("--iterations must be at least 1");
    }
    let ctx = GpuContext::new()?;
    let software = ctx.is_software();
    let options = mvscope::bench::BenchOptions {
        synthetic_sizes: if quick {
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
        methods_size: Some(if quick { (320, 240) } else { (640, 480) }),
    };
    let report = mvscope::bench::run(&ctx, &options, |m| eprintln!("bench: {m}"))?;
    print!("{}", mvscope::bench::format_report(&report));
    mvscope::bench::write_json(&report, &json)?;
    println!("\nsaved {}", json.display());
    Ok(())
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("mvscope=info"))
        .format_timestamp(None)
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
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
        Command::Gpu => gpu(),
        Command::Bench {
            quick,
            fountain,
            fountain_max_size,
            iterations,
            no_cpu,
            json,
        } => bench(quick, fountain, fountain_max_size, iterations, no_cpu, json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
