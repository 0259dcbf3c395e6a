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
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
