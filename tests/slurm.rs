//! The job chain of `mvscope plan` on a real Slurm: Debian's slurm-wlm as a one-node
//! cluster on localhost (`bash scripts/slurm-local.sh`, as root; .ci/run starts it). Run
//! with `cargo test --test slurm -- --ignored` once the cluster is up.
//!
//! The chain's maps and cloud are byte for byte those of `mvscope run`; a chain with one
//! array element cancelled stops there, leaves no half-written file, and submitted again
//! finishes with the same result.

use std::path::Path;
use std::process::{Command, Output};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// One chain at a time: the cluster has 2 CPUs.
static CLUSTER: Mutex<()> = Mutex::new(());

fn run(program: &str, args: &[&str]) -> Output {
    Command::new(program)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{program}: {e}"))
}

fn ok(program: &str, args: &[&str]) -> String {
    let out = run(program, args);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{program} {args:?} failed:\n{text}");
    text
}

fn mvscope(args: &[&str]) -> String {
    ok(env!("CARGO_BIN_EXE_mvscope"), args)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn require_slurm() {
    let up = Command::new("squeue")
        .arg("-h")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        up,
        "no Slurm answers (squeue failed): start the one-node cluster with `bash scripts/slurm-local.sh` (as root)"
    );
}

/// Submits the chain; returns (stage or "fusion", job id) in order.
fn submit(work: &Path) -> Vec<(String, String)> {
    let out = ok("bash", &[s(&work.join("submit.sh"))]);
    let jobs: Vec<(String, String)> = out
        .lines()
        .filter_map(|l| {
            let (what, id) = l
                .rsplit_once(" job array ")
                .or_else(|| l.rsplit_once(" job "))?;
            Some((
                what.trim_end_matches(':').to_string(),
                id.trim().to_string(),
            ))
        })
        .collect();
    assert!(jobs.len() >= 2, "{out}");
    jobs
}

/// Waits until none of `jobs` is queued, running or completing.
fn wait_for(jobs: &[(String, String)], limit: Duration) {
    let start = Instant::now();
    loop {
        let queue = ok("squeue", &["-h", "-o", "%F %T %r"]);
        let ours: Vec<&str> = queue
            .lines()
            .filter(|l| {
                jobs.iter()
                    .any(|(_, id)| l.split_whitespace().next() == Some(id))
            })
            .collect();
        if ours.is_empty() {
            return;
        }
        assert!(
            start.elapsed() < limit,
            "the chain did not drain in {limit:?}: {ours:?}"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
}

fn assert_same(one: &Path, work: &Path) {
    let mut n = 0;
    for kind in ["depth", "normal", "cost", "confidence"] {
        for e in std::fs::read_dir(one.join(kind)).unwrap() {
            let p = e.unwrap().path();
            let other = work.join(kind).join(p.file_name().unwrap());
            assert!(
                std::fs::read(&p).unwrap() == std::fs::read(&other).unwrap(),
                "{} differs",
                other.display()
            );
            n += 1;
        }
    }
    assert_eq!(n, 20, "5 views x 4 maps");
    for f in ["fused.ply", "params.toml"] {
        assert!(
            std::fs::read(one.join(f)).unwrap() == std::fs::read(work.join(f)).unwrap(),
            "{f} differs"
        );
    }
}

/// A demo scene and its one-machine run.
fn scene_and_run(root: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let demo = root.join("demo");
    let one = root.join("one");
    mvscope(&[
        "demo",
        "--out",
        s(&demo),
        "--width",
        "64",
        "--height",
        "48",
        "--views",
        "5",
    ]);
    mvscope(&["run", s(&demo), "--out", s(&one)]);
    (demo, one)
}

#[test]
#[ignore = "needs a running Slurm: bash scripts/slurm-local.sh, then cargo test --test slurm -- --ignored"]
fn a_chain_on_slurm_writes_what_one_machine_writes() {
    let _one_at_a_time = CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    require_slurm();
    let tmp = tempfile::tempdir().unwrap();
    let (demo, one) = scene_and_run(tmp.path());
    let work = tmp.path().join("work");
    mvscope(&["plan", s(&demo), "--out", s(&work), "--tasks", "3"]);
    let jobs = submit(&work);
    wait_for(&jobs, Duration::from_secs(900));
    assert_same(&one, &work);
    let report = std::fs::read_to_string(work.join("report.json")).unwrap();
    assert!(report.contains("\"tasks\": 3"), "{report}");
}

#[test]
#[ignore = "needs a running Slurm: bash scripts/slurm-local.sh, then cargo test --test slurm -- --ignored"]
fn a_cancelled_element_stops_the_chain_cleanly_and_a_resubmission_finishes_it() {
    let _one_at_a_time = CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    require_slurm();
    let tmp = tempfile::tempdir().unwrap();
    let (demo, one) = scene_and_run(tmp.path());
    let work = tmp.path().join("work");
    mvscope(&["plan", s(&demo), "--out", s(&work), "--tasks", "3"]);
    let jobs = submit(&work);
    // Element 1 of stage 1, cancelled before it runs: stage 1's other elements run, the
    // stages after it are cancelled (--kill-on-invalid-dep) and the queue drains.
    let (what, stage1) = &jobs[1];
    assert!(what.starts_with("stage 1"), "{jobs:?}");
    ok("scancel", &[&format!("{stage1}_1")]);
    wait_for(&jobs, Duration::from_secs(900));
    let done = |name: &str| work.join("tasks").join(name).is_file();
    assert!(done("00-000.json") && done("00-001.json") && done("00-002.json"));
    assert!(
        !done("01-001.json"),
        "the cancelled element left its marker"
    );
    assert!(!work.join("fused.ply").exists());
    assert!(
        !work.join("depth").exists(),
        "no final map before the last stage"
    );
    // Nothing half-written under a final name: every marker and state parses.
    for entry in walk(&work) {
        let name = entry.file_name().unwrap().to_string_lossy().to_string();
        if name.ends_with(".json") && !name.starts_with('.') {
            let text = std::fs::read_to_string(&entry).unwrap();
            serde_json::from_str::<serde_json::Value>(&text)
                .unwrap_or_else(|e| panic!("{}: {e}", entry.display()));
        }
        if name.ends_with(".state") && !name.starts_with('.') {
            let bytes = std::fs::read(&entry).unwrap();
            let header = bytes.split(|&b| b == b'\n').next().unwrap();
            serde_json::from_slice::<serde_json::Value>(header)
                .unwrap_or_else(|e| panic!("{}: {e}", entry.display()));
        }
    }
    // Submitted again: the finished units are skipped and the chain completes.
    let marker = work.join("tasks/00-000.json");
    let before = std::fs::read(&marker).unwrap();
    let jobs = submit(&work);
    wait_for(&jobs, Duration::from_secs(900));
    assert_eq!(
        std::fs::read(&marker).unwrap(),
        before,
        "a finished unit ran again"
    );
    let log = std::fs::read_to_string(work.join("logs/mvscope-s00-0.out")).unwrap();
    assert!(log.contains("already done, skipped"), "{log}");
    assert_same(&one, &work);
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}
