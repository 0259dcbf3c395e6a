//! The job chain a plan writes for a scheduler: Slurm batch scripts and `submit.sh` (one job
//! array per stage, each after the previous with `--dependency=afterok`, then fusion), or
//! Kubernetes Indexed Jobs (one per stage, `JOB_COMPLETION_INDEX` as the chunk) and a script
//! that applies them in order.

use std::path::{Path, PathBuf};

use serde_json::json;

use super::{ClusterError, Plan};
use crate::io::{IoError, write_atomic};

/// What every Slurm job of the chain asks for.
#[derive(Clone, Debug, Default)]
pub struct SlurmOptions {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--gres`, e.g. `gpu:1`.
    pub gres: Option<String>,
    /// `--time`, e.g. `01:00:00`.
    pub time: Option<String>,
    /// `--mem`, e.g. `16G` (the plan prints what a task needs).
    pub mem: Option<String>,
    /// More `#SBATCH` options, one per entry (e.g. `--account=lab`).
    pub extra: Vec<String>,
}

/// What every Kubernetes Job of the chain uses.
#[derive(Clone, Debug)]
pub struct KubernetesOptions {
    /// The container image with mvscope on its PATH.
    pub image: String,
    /// The PersistentVolumeClaim of the shared storage holding the scene and work folder.
    pub claim: String,
    /// Where the claim is mounted in the pod: the work folder and the scene must have the
    /// same paths there as where the plan was made.
    pub mount: PathBuf,
    /// GPUs per pod (`nvidia.com/gpu`), 0 for none.
    pub gpus: u32,
}

/// A word for a POSIX shell, single-quoted where needed.
pub fn shell_quote(word: &str) -> String {
    if !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c))
    {
        return word.to_string();
    }
    format!("'{}'", word.replace('\'', r"'\''"))
}

fn write_text(path: &Path, text: &str, executable: bool) -> Result<(), ClusterError> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| IoError::io(parent, "create the folder", e))?;
    }
    write_atomic(path, |w| std::io::Write::write_all(w, text.as_bytes()))?;
    #[cfg(unix)]
    if executable {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
            .map_err(|e| IoError::io(path, "make it executable", e))?;
    }
    #[cfg(not(unix))]
    let _ = executable;
    Ok(())
}

fn display(path: &Path) -> String {
    shell_quote(&path.display().to_string())
}

/// Writes `DIR/slurm/*.sbatch` and `DIR/submit.sh` for the plan in `dir` (an absolute path
/// on the cluster's shared storage), running `mvscope` (an absolute path there too).
pub fn write_slurm(
    plan: &Plan,
    dir: &Path,
    mvscope: &Path,
    options: &SlurmOptions,
) -> Result<(), ClusterError> {
    let tasks = plan.chunks.len();
    let mut common = String::new();
    for (flag, value) in [
        ("partition", &options.partition),
        ("gres", &options.gres),
        ("time", &options.time),
        ("mem", &options.mem),
    ] {
        if let Some(v) = value {
            common.push_str(&format!("#SBATCH --{flag}={v}\n"));
        }
    }
    for line in &options.extra {
        common.push_str(&format!("#SBATCH {line}\n"));
    }
    let logs = dir.join("logs");
    let job = |name: &str, array: bool, command: &str| {
        let (array_line, log) = if array {
            (format!("#SBATCH --array=0-{}\n", tasks - 1), "%x-%a.out")
        } else {
            (String::new(), "%x.out")
        };
        format!(
            "#!/bin/bash\n\
             # Written by `mvscope plan`: one unit of the chain (see submit.sh).\n\
             #SBATCH --job-name={name}\n\
             {array_line}\
             #SBATCH --ntasks=1\n\
             #SBATCH --output={}/{log}\n\
             {common}\
             set -euo pipefail\n\
             exec {command}\n",
            logs.display()
        )
    };
    let exe = display(mvscope);
    let work = display(dir);
    let mut submit = format!(
        "#!/bin/bash\n\
         # Written by `mvscope plan`: submits the run's chain to Slurm, one job array of {tasks} \
         task(s) per stage,\n\
         # each after the previous stage's (afterok), then fusion. Run it on a login node:\n\
         #   bash {}/submit.sh\n\
         # Submitting again after a failure or a cancel continues: finished units are skipped.\n\
         set -euo pipefail\n\
         mkdir -p {}\n\
         dependency=()\n",
        dir.display(),
        display(&logs),
    );
    for (k, stage) in plan.stages.iter().enumerate() {
        let name = format!("mvscope-s{k:02}");
        let script = dir.join("slurm").join(format!("stage-{k:02}.sbatch"));
        let command = format!("{exe} task {work} --stage {k} --chunk \"$SLURM_ARRAY_TASK_ID\"");
        write_text(&script, &job(&name, true, &command), false)?;
        submit.push_str(&format!(
            "job=$(sbatch --parsable \"${{dependency[@]}}\" {})\n\
             job=${{job%%;*}}\n\
             echo \"stage {k} (scale {} {}): job array $job\"\n\
             dependency=(--kill-on-invalid-dep=yes --dependency=afterok:$job)\n",
            display(&script),
            stage.level + 1,
            stage.name
        ));
    }
    let script = dir.join("slurm").join("fuse.sbatch");
    write_text(
        &script,
        &job("mvscope-fuse", false, &format!("{exe} task {work} --fuse")),
        false,
    )?;
    submit.push_str(&format!(
        "job=$(sbatch --parsable \"${{dependency[@]}}\" {})\n\
         job=${{job%%;*}}\n\
         echo \"fusion: job $job\"\n\
         echo \"$job\" > {}\n",
        display(&script),
        display(&dir.join("slurm").join("last-job"))
    ));
    write_text(&dir.join("submit.sh"), &submit, true)
}

/// The Kubernetes Job of stage `k` (`None`: fusion) as JSON (which `kubectl apply -f`
/// reads like YAML).
pub fn kubernetes_job(
    plan: &Plan,
    dir: &Path,
    stage: Option<usize>,
    options: &KubernetesOptions,
) -> serde_json::Value {
    let tasks = plan.chunks.len();
    let work = dir.display().to_string();
    let (name, command, completions) = match stage {
        Some(k) => (
            format!("mvscope-s{k:02}"),
            vec![
                "mvscope".to_string(),
                "task".into(),
                work,
                "--stage".into(),
                k.to_string(),
            ],
            tasks,
        ),
        None => (
            "mvscope-fuse".to_string(),
            vec!["mvscope".into(), "task".into(), work, "--fuse".into()],
            1,
        ),
    };
    let mut container = json!({
        "name": "mvscope",
        "image": options.image,
        "command": command,
        "volumeMounts": [{ "name": "work", "mountPath": options.mount.display().to_string() }],
    });
    if options.gpus > 0 && stage.is_some() {
        container["resources"] = json!({ "limits": { "nvidia.com/gpu": options.gpus } });
    }
    json!({
        "apiVersion": "batch/v1",
        "kind": "Job",
        "metadata": {
            "name": name,
            "labels": { "app.kubernetes.io/name": "mvscope" },
        },
        "spec": {
            // Pod k runs chunk k: `mvscope task` reads JOB_COMPLETION_INDEX.
            "completionMode": "Indexed",
            "completions": completions,
            "parallelism": completions,
            "backoffLimit": 2 * completions,
            "template": {
                "spec": {
                    "restartPolicy": "Never",
                    "containers": [container],
                    "volumes": [{
                        "name": "work",
                        "persistentVolumeClaim": { "claimName": options.claim },
                    }],
                },
            },
        },
    })
}

/// Writes `DIR/kubernetes/stage-KK.json`, `fuse.json` and `run.sh` (which applies each Job
/// and waits for it to complete before the next).
pub fn write_kubernetes(
    plan: &Plan,
    dir: &Path,
    options: &KubernetesOptions,
) -> Result<(), ClusterError> {
    let folder = dir.join("kubernetes");
    let mut run = String::from(
        "#!/bin/bash\n\
         # Written by `mvscope plan --engine kubernetes`: one Indexed Job per stage, each after\n\
         # the previous completes, then fusion. Applying again continues: finished units are\n\
         # skipped (delete the old Jobs first: kubectl delete job -l app.kubernetes.io/name=mvscope).\n\
         set -euo pipefail\n",
    );
    let stages = (0..plan.stages.len()).map(Some).chain([None]);
    for stage in stages {
        let job = kubernetes_job(plan, dir, stage, options);
        let file = match stage {
            Some(k) => folder.join(format!("stage-{k:02}.json")),
            None => folder.join("fuse.json"),
        };
        let text =
            serde_json::to_string_pretty(&job).map_err(|e| ClusterError::Invalid(e.to_string()))?;
        write_text(&file, &text, false)?;
        let name = job["metadata"]["name"].as_str().unwrap_or("mvscope");
        run.push_str(&format!(
            "kubectl apply -f {}\nkubectl wait --for=condition=complete --timeout=-1s job/{name}\n",
            display(&file)
        ));
    }
    write_text(&folder.join("run.sh"), &run, true)
}
