//! `mvscope plan` and `mvscope task`: a run split over a cluster (`mvscope::cluster`); and
//! `mvscope bench --cluster`: a cluster task's peak memory as the scene grows.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use mvscope::cluster::scripts::{KubernetesOptions, SlurmOptions, write_kubernetes, write_slurm};
use mvscope::cluster::{Plan, UnitOutcome};
use mvscope::gpu::GpuContext;
use mvscope::pipeline::RunRecord;
use mvscope::scene::Scene;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Engine {
    /// DIR/submit.sh submits one job array per stage to Slurm.
    Slurm,
    /// DIR/kubernetes/: one Indexed Job per stage, and run.sh to apply them in order.
    Kubernetes,
}

/// How the run is split and what the scheduler is told.
#[derive(clap::Args)]
pub struct PlanArgs {
    /// The scheduler the chain is written for.
    #[arg(long, value_enum, default_value = "slurm")]
    engine: Engine,
    /// Tasks per stage (each a chunk of views that share sources, as `mvscope run` batches
    /// them).
    #[arg(long, default_value_t = 1, conflicts_with = "device_memory")]
    tasks: usize,
    /// Instead of --tasks: chunks that each fit this much device memory (MiB), as
    /// `mvscope run --device-memory` batches them; as many tasks as that takes.
    #[arg(long, value_name = "MIB")]
    device_memory: Option<f64>,
    /// The mvscope the jobs run (default: this one), as the nodes see it.
    #[arg(long, value_name = "PATH")]
    mvscope: Option<PathBuf>,
    /// Slurm: --partition of every job.
    #[arg(long)]
    partition: Option<String>,
    /// Slurm: --gres of every job, e.g. gpu:1.
    #[arg(long)]
    gres: Option<String>,
    /// Slurm: --time of every job, e.g. 01:00:00.
    #[arg(long)]
    time: Option<String>,
    /// Slurm: --mem of every job, e.g. 16G.
    #[arg(long)]
    mem: Option<String>,
    /// Slurm: another #SBATCH option for every job, e.g. --sbatch=--account=lab (repeatable).
    #[arg(long = "sbatch", value_name = "OPTION", allow_hyphen_values = true)]
    sbatch: Vec<String>,
    /// Kubernetes: the container image with mvscope on its PATH.
    #[arg(long, default_value = "mvscope:latest")]
    image: String,
    /// Kubernetes: the PersistentVolumeClaim of the shared storage.
    #[arg(long, default_value = "mvscope-work")]
    claim: String,
    /// Kubernetes: where the claim is mounted in the pods (the work folder and the scene
    /// must have the same paths there). Default: the work folder's parent.
    #[arg(long, value_name = "PATH")]
    mount: Option<PathBuf>,
    /// Kubernetes: GPUs per pod (nvidia.com/gpu).
    #[arg(long, default_value_t = 1)]
    gpus: u32,
}

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}

pub fn plan(
    record: RunRecord,
    scene: &Scene,
    out: &Path,
    args: &PlanArgs,
    fuse: bool,
    export_acmm: bool,
    export_colmap: bool,
) -> Result<()> {
    let dir = std::fs::canonicalize(out)
        .with_context(|| format!("cannot resolve the work folder {}", out.display()))?;
    let split = match args.device_memory {
        Some(mib) => mvscope::cluster::Split::DeviceMemory(super::mib_bytes(mib)),
        None => mvscope::cluster::Split::Tasks(args.tasks),
    };
    let plan = Plan::new(record, scene, split, fuse, export_acmm, export_colmap)?;
    plan.write(&dir)?;
    let next = match args.engine {
        Engine::Slurm => {
            let exe = match &args.mvscope {
                Some(p) => p.clone(),
                None => std::env::current_exe().context("cannot tell where this mvscope is")?,
            };
            let options = SlurmOptions {
                partition: args.partition.clone(),
                gres: args.gres.clone(),
                time: args.time.clone(),
                mem: args.mem.clone(),
                extra: args.sbatch.clone(),
            };
            write_slurm(&plan, &dir, &exe, &options)?;
            format!(
                "submit on a Slurm login node: bash {}/submit.sh",
                dir.display()
            )
        }
        Engine::Kubernetes => {
            let mount = match &args.mount {
                Some(m) => m.clone(),
                None => dir.parent().map(Path::to_path_buf).unwrap_or(dir.clone()),
            };
            let options = KubernetesOptions {
                image: args.image.clone(),
                claim: args.claim.clone(),
                mount,
                gpus: args.gpus,
            };
            write_kubernetes(&plan, &dir, &options)?;
            format!("apply in order: bash {}/kubernetes/run.sh", dir.display())
        }
    };
    println!(
        "{} on {} views: {} stages x {} tasks, then fusion; plan in {}",
        plan.record.method,
        plan.record.views.len(),
        plan.stages.len(),
        plan.chunks.len(),
        dir.display()
    );
    for (k, s) in plan.stages.iter().enumerate() {
        println!("  stage {k}: scale {} {}", s.level + 1, s.name);
    }
    for (i, c) in plan.chunks.iter().enumerate() {
        println!(
            "  task {i}: {} views, holds {} (with their sources): host {:.0} MiB of images, device {:.0} MiB",
            c.views.len(),
            c.holds.len(),
            mib(c.host_bytes),
            mib(c.device_bytes)
        );
    }
    let (host, device) = plan.peak_task_bytes();
    println!(
        "  per task at most: host {:.0} MiB of images, device {:.0} MiB (the memory plan)",
        mib(host),
        mib(device)
    );
    println!("{next}");
    Ok(())
}

/// The chunk from the scheduler's environment.
fn chunk_from_env() -> Result<usize> {
    for name in ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"] {
        if let Ok(v) = std::env::var(name) {
            return v
                .trim()
                .parse()
                .with_context(|| format!("${name} is {v:?}, not a chunk number"));
        }
    }
    bail!("--chunk is missing (and neither $SLURM_ARRAY_TASK_ID nor $JOB_COMPLETION_INDEX is set)")
}

pub fn task(dir: &Path, stage: Option<usize>, chunk: Option<usize>, fuse: bool) -> Result<()> {
    let outcome = if fuse {
        mvscope::cluster::fuse_unit(dir)?
    } else {
        let Some(stage) = stage else {
            bail!("give --stage K (or --fuse)");
        };
        let chunk = match chunk {
            Some(c) => c,
            None => chunk_from_env()?,
        };
        let ctx = GpuContext::new()?;
        eprintln!("GPU: {}", ctx.describe_with_caveat());
        mvscope::cluster::run_unit(&ctx, dir, stage, chunk)?
    };
    let what = match stage.filter(|_| !fuse) {
        Some(k) => format!(
            "stage {k} chunk {}",
            chunk.map_or("(from env)".into(), |c| c.to_string())
        ),
        None => "fusion".to_string(),
    };
    match outcome {
        UnitOutcome::Skipped => println!("{what}: already done, skipped"),
        UnitOutcome::Done(r) => println!(
            "{what}: {} views in {:.1} s, peak resident {:.0} MiB",
            r.views.len(),
            r.total_ms / 1e3,
            r.host_memory_peak.map_or(0.0, mib)
        ),
    }
    Ok(())
}

/// A folder removed when dropped.
pub(super) struct TempFolder(pub(super) PathBuf);

impl Drop for TempFolder {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// One row of `mvscope bench --cluster`.
#[derive(serde::Serialize)]
struct ClusterBenchRow {
    views: usize,
    tasks: usize,
    /// The measured task's views and the views it holds (with their sources).
    task_views: usize,
    task_holds: usize,
    /// Decoded images (colour and intensity) of the task, and of the whole scene.
    task_image_bytes: u64,
    scene_image_bytes: u64,
    task_device_bytes: u64,
    /// The task's process: peak resident memory and wall time.
    task_peak_resident_bytes: Option<u64>,
    task_seconds: f64,
}

/// A cluster task's memory as the scene grows: demo scenes of each view count at `size`,
/// planned in tasks of `per_task` views; stage 0 of task 0 runs in its own process, whose
/// peak resident memory its marker records.
pub fn bench_cluster(
    counts: &[usize],
    sizes: &[String],
    per_task: usize,
    json: &Path,
) -> Result<()> {
    let size = match sizes.first() {
        Some(s) => super::parse_size("--size", s)?,
        None => (160, 120),
    };
    let exe = std::env::current_exe().context("cannot tell where this mvscope is")?;
    let root = TempFolder(
        std::env::temp_dir().join(format!("mvscope-bench-cluster-{}", std::process::id())),
    );
    std::fs::create_dir_all(&root.0).context("a temporary folder for the scenes")?;
    let mut rows = Vec::new();
    println!(
        "{:>6} {:>6} {:>10} {:>16} {:>16} {:>14} {:>14} {:>8}",
        "views",
        "tasks",
        "task views",
        "task images MiB",
        "scene images MiB",
        "task device MiB",
        "task peak MiB",
        "task s"
    );
    for &n in counts {
        let scene_dir = root.0.as_path().join(format!("scene-{n}"));
        let options = mvscope::synthetic::SyntheticOptions {
            views: n,
            width: size.0,
            height: size.1,
            ..Default::default()
        };
        let generated = mvscope::synthetic::generate(&options)?;
        mvscope::synthetic::write_demo(&generated, &scene_dir)?;
        drop(generated);
        let load = mvscope::scene::LoadOptions::default().cameras_only();
        let scene = Scene::load(&scene_dir, &load)?;
        let record = RunRecord::whole(
            mvscope::acmm::Method::Acmm,
            &scene_dir,
            &scene,
            None,
            mvscope::acmm::Params::default(),
        );
        let tasks = n.div_ceil(per_task.max(1));
        let work = root.0.as_path().join(format!("work-{n}"));
        let plan = Plan::new(
            record,
            &scene,
            mvscope::cluster::Split::Tasks(tasks),
            false,
            false,
            false,
        )?;
        plan.write(&work)?;
        let scene_image_bytes = scene
            .views
            .iter()
            .map(|v| v.image.width as u64 * v.image.height as u64 * 7)
            .sum();
        drop(scene);
        let started = std::time::Instant::now();
        let out = std::process::Command::new(&exe)
            .args(["task"])
            .arg(&work)
            .args(["--stage", "0", "--chunk", "0"])
            .output()
            .context("running the task")?;
        if !out.status.success() {
            bail!("the task failed: {}", String::from_utf8_lossy(&out.stderr));
        }
        let task_seconds = started.elapsed().as_secs_f64();
        let marker: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(Plan::marker(&work, 0, 0))?)?;
        let c = &plan.chunks[0];
        let row = ClusterBenchRow {
            views: n,
            tasks,
            task_views: c.views.len(),
            task_holds: c.holds.len(),
            task_image_bytes: c.host_bytes,
            scene_image_bytes,
            task_device_bytes: c.device_bytes,
            task_peak_resident_bytes: marker["host_memory_peak"].as_u64(),
            task_seconds,
        };
        println!(
            "{:>6} {:>6} {:>4} of {:>3} {:>16.1} {:>16.1} {:>14.1} {:>14.1} {:>8.2}",
            row.views,
            row.tasks,
            row.task_views,
            row.task_holds,
            mib(row.task_image_bytes),
            mib(row.scene_image_bytes),
            mib(row.task_device_bytes),
            row.task_peak_resident_bytes.map_or(f64::NAN, mib),
            row.task_seconds
        );
        rows.push(row);
    }
    let text = serde_json::to_string_pretty(&rows)?;
    std::fs::write(json, text).with_context(|| format!("writing {}", json.display()))?;
    println!(
        "(task views: estimated of held, with their sources; saved to {})",
        json.display()
    );
    Ok(())
}
