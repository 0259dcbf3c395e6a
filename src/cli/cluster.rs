//! `mvscope plan` and `mvscope task`: a run split over a cluster (`mvscope::cluster`).

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
    /// Tasks per stage (each a chunk of consecutive views).
    #[arg(long, default_value_t = 1)]
    tasks: usize,
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
    let plan = Plan::new(record, scene, args.tasks, fuse, export_acmm, export_colmap)?;
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
        eprintln!("GPU: {}", ctx.describe());
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
