//! A run split over a cluster (`mvscope plan`, `mvscope task`), unit by unit on this machine:
//! the work folder ends up holding what `mvscope run` writes, byte for byte; finished units
//! are skipped; missing or foreign inputs stop a unit with a message that says which; the
//! Kubernetes manifests have the shape an Indexed Job needs. (tests/slurm.rs submits the
//! same chain to a real Slurm.)

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn mvscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mvscope"))
        .args(args)
        .env(
            "XDG_RUNTIME_DIR",
            std::env::var("XDG_RUNTIME_DIR").unwrap_or_else(|_| "/tmp".into()),
        )
        .output()
        .expect("the mvscope binary runs")
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

fn ok(args: &[&str]) -> String {
    let out = mvscope(args);
    assert!(
        out.status.success(),
        "mvscope {args:?} failed:\n{}",
        text(&out)
    );
    text(&out)
}

fn fails(args: &[&str]) -> String {
    let out = mvscope(args);
    let t = text(&out);
    assert!(!out.status.success(), "mvscope {args:?} should fail:\n{t}");
    assert!(!t.contains("panicked"), "a panic instead of an error:\n{t}");
    t
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The files `mvscope run` writes that must match byte for byte.
fn outputs(dir: &Path) -> Vec<PathBuf> {
    let mut files = vec![dir.join("fused.ply"), dir.join("params.toml")];
    for kind in ["depth", "normal", "cost"] {
        let mut maps: Vec<PathBuf> = std::fs::read_dir(dir.join(kind))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        maps.sort();
        files.extend(maps);
    }
    files
}

fn assert_same_outputs(one: &Path, work: &Path) {
    let files = outputs(one);
    assert!(files.len() > 2, "{files:?}");
    for f in files {
        let rel = f.strip_prefix(one).unwrap();
        let a = std::fs::read(&f).unwrap();
        let b = std::fs::read(work.join(rel))
            .unwrap_or_else(|e| panic!("{}: {e}", work.join(rel).display()));
        assert!(a == b, "{} differs from the one-machine run", rel.display());
    }
}

fn stages(work: &Path) -> usize {
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(work.join("plan.json")).unwrap()).unwrap();
    plan["stages"].as_array().unwrap().len()
}

fn run_chain(work: &Path, tasks: usize) {
    for k in 0..stages(work) {
        for c in 0..tasks {
            ok(&[
                "task",
                s(work),
                "--stage",
                &k.to_string(),
                "--chunk",
                &c.to_string(),
            ]);
        }
    }
    ok(&["task", s(work), "--fuse"]);
}

#[test]
fn a_chain_run_unit_by_unit_writes_what_run_writes_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = tmp.path().join("demo");
    ok(&[
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
    // ACMM (geometric passes read the sources' states) and ACMMP (the planar prior's
    // triangulation read back mid-stage, the prior planes handed on).
    for method in ["acmm", "acmmp"] {
        let one = tmp.path().join(format!("one-{method}"));
        let work = tmp.path().join(format!("work-{method}"));
        ok(&["run", s(&demo), "--out", s(&one), "--method", method]);
        let planned = ok(&[
            "plan",
            s(&demo),
            "--out",
            s(&work),
            "--method",
            method,
            "--tasks",
            "3",
        ]);
        assert!(planned.contains("3 tasks"), "{planned}");
        run_chain(&work, 3);
        assert_same_outputs(&one, &work);
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(work.join("report.json")).unwrap())
                .unwrap();
        assert_eq!(report["tasks"], 3);
        assert_eq!(report["views"], 5);
        assert!(report["cost_evaluations"].as_u64().unwrap() > 0);
        assert_eq!(
            report["stages"].as_array().unwrap().len(),
            stages(&work),
            "{report}"
        );
    }
}

#[test]
fn units_skip_what_is_done_and_name_missing_or_foreign_inputs() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = tmp.path().join("demo");
    ok(&[
        "demo",
        "--out",
        s(&demo),
        "--width",
        "48",
        "--height",
        "36",
        "--views",
        "4",
    ]);
    let work = tmp.path().join("work");
    ok(&["plan", s(&demo), "--out", s(&work), "--tasks", "2"]);
    // Stage 1 before stage 0: its inputs are missing, and the message says which.
    let e = fails(&["task", s(&work), "--stage", "1", "--chunk", "0"]);
    assert!(
        e.contains("00000000.state") && e.contains("stage 0 (photometric) has not finished"),
        "{e}"
    );
    // Fusion before the units: it names the first unit not done.
    let e = fails(&["task", s(&work), "--fuse"]);
    assert!(e.contains("stage 0 (photometric) chunk 0 is not"), "{e}");
    // A unit runs once; again, it is skipped.
    let first = ok(&["task", s(&work), "--stage", "0", "--chunk", "0"]);
    assert!(first.contains("stage 0 chunk 0: 2 views"), "{first}");
    let state = work.join("stages/00/00000000.state");
    let written = std::fs::read(&state).unwrap();
    let again = ok(&["task", s(&work), "--stage", "0", "--chunk", "0"]);
    assert!(again.contains("already done, skipped"), "{again}");
    assert_eq!(std::fs::read(&state).unwrap(), written);
    // The chunk comes from the scheduler's environment.
    let out = Command::new(env!("CARGO_BIN_EXE_mvscope"))
        .args(["task", s(&work), "--stage", "0"])
        .env("SLURM_ARRAY_TASK_ID", "1")
        .output()
        .unwrap();
    assert!(
        text(&out).contains("stage 0 chunk (from env): 2 views"),
        "{}",
        text(&out)
    );
    // Planning into the folder again with another seed is refused: its results would mix.
    let e = fails(&[
        "plan",
        s(&demo),
        "--out",
        s(&work),
        "--tasks",
        "2",
        "--seed",
        "7",
    ]);
    assert!(
        e.contains("the seed differ") && e.contains("another plan"),
        "{e}"
    );
    // A plan changed under the units (here: its parameters) is named by the next unit.
    let plan_path = work.join("plan.json");
    let mut plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&plan_path).unwrap()).unwrap();
    plan["stamp"]["params"] = "0000000000000000".into();
    std::fs::write(&plan_path, serde_json::to_string(&plan).unwrap()).unwrap();
    let e = fails(&["task", s(&work), "--stage", "1", "--chunk", "0"]);
    assert!(e.contains("another plan (the parameters differ)"), "{e}");
    // Out of range stage and chunk.
    let e = fails(&["task", s(&work), "--stage", "99", "--chunk", "0"]);
    assert!(e.contains("--stage 99"), "{e}");
}

#[test]
fn a_truncated_state_is_refused_with_its_name() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = tmp.path().join("demo");
    ok(&[
        "demo",
        "--out",
        s(&demo),
        "--width",
        "48",
        "--height",
        "36",
        "--views",
        "3",
    ]);
    let work = tmp.path().join("work");
    ok(&["plan", s(&demo), "--out", s(&work), "--tasks", "1"]);
    ok(&["task", s(&work), "--stage", "0", "--chunk", "0"]);
    let state = work.join("stages/00/00000001.state");
    let bytes = std::fs::read(&state).unwrap();
    std::fs::write(&state, &bytes[..bytes.len() / 2]).unwrap();
    let e = fails(&["task", s(&work), "--stage", "1", "--chunk", "0"]);
    assert!(
        e.contains("00000001.state") && e.contains("cut short"),
        "{e}"
    );
}

#[test]
fn kubernetes_manifests_are_indexed_jobs_one_per_stage_then_fusion() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = tmp.path().join("demo");
    ok(&[
        "demo",
        "--out",
        s(&demo),
        "--width",
        "48",
        "--height",
        "36",
        "--views",
        "4",
    ]);
    let work = tmp.path().join("work");
    ok(&[
        "plan",
        s(&demo),
        "--out",
        s(&work),
        "--engine",
        "kubernetes",
        "--tasks",
        "2",
        "--image",
        "lab/mvscope:1",
        "--claim",
        "scratch",
        "--gpus",
        "1",
    ]);
    let work = work.canonicalize().unwrap();
    let n = stages(&work);
    assert!(n >= 3, "ACMM has several stages: {n}");
    let folder = work.join("kubernetes");
    let run = std::fs::read_to_string(folder.join("run.sh")).unwrap();
    let mut last = 0;
    for k in 0..=n {
        let (file, name) = if k < n {
            (format!("stage-{k:02}.json"), format!("mvscope-s{k:02}"))
        } else {
            ("fuse.json".to_string(), "mvscope-fuse".to_string())
        };
        let job: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(folder.join(&file)).unwrap()).unwrap();
        assert_eq!(job["apiVersion"], "batch/v1");
        assert_eq!(job["kind"], "Job");
        assert_eq!(job["metadata"]["name"], name.as_str());
        let spec = &job["spec"];
        assert_eq!(spec["completionMode"], "Indexed");
        let completions = if k < n { 2 } else { 1 };
        assert_eq!(spec["completions"], completions);
        assert_eq!(spec["parallelism"], completions);
        let pod = &spec["template"]["spec"];
        assert_eq!(pod["restartPolicy"], "Never");
        let c = &pod["containers"][0];
        assert_eq!(c["image"], "lab/mvscope:1");
        let command: Vec<&str> = c["command"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        let k_text = k.to_string();
        let expected = if k < n {
            vec!["mvscope", "task", s(&work), "--stage", k_text.as_str()]
        } else {
            vec!["mvscope", "task", s(&work), "--fuse"]
        };
        assert_eq!(command, expected);
        assert_eq!(c["volumeMounts"][0]["mountPath"], s(work.parent().unwrap()));
        assert_eq!(
            pod["volumes"][0]["persistentVolumeClaim"]["claimName"],
            "scratch"
        );
        assert_eq!(
            c["resources"]["limits"]["nvidia.com/gpu"].as_u64(),
            (k < n).then_some(1)
        );
        // Applied in order, each waited for before the next.
        let at = run.find(&format!("job/{name}")).expect(&name);
        assert!(at > last, "{name} out of order in run.sh");
        last = at;
    }
    // The chunk of a pod is its completion index.
    let out = Command::new(env!("CARGO_BIN_EXE_mvscope"))
        .args(["task", s(&work), "--stage", "0"])
        .env("JOB_COMPLETION_INDEX", "1")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    assert!(work.join("tasks/00-001.json").is_file());
}
