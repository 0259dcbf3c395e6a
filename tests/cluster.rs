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
    for kind in ["depth", "normal", "cost", "confidence"] {
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
    // ACMM (geometric passes read the sources' states), ACMMP (the planar prior's
    // triangulation read back mid-stage, the prior planes handed on) and Regions with its
    // per-region choice (the restorer's support points, read in one stage, handed on to the
    // prior stage after it).
    let choice = ["--set", "prior_region_choice=true"];
    for (name, method, extra) in [
        ("acmm", "acmm", &[][..]),
        ("acmmp", "acmmp", &[][..]),
        ("choice", "regions", &choice[..]),
    ] {
        let one = tmp.path().join(format!("one-{name}"));
        let work = tmp.path().join(format!("work-{name}"));
        let mut args = vec!["run", s(&demo), "--out", s(&one), "--method", method];
        args.extend(extra);
        ok(&args);
        let mut args = vec![
            "plan",
            s(&demo),
            "--out",
            s(&work),
            "--method",
            method,
            "--tasks",
            "3",
        ];
        args.extend(extra);
        let planned = ok(&args);
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

// --- One machine, batch by batch: the same scheduler's units run in turn. ---

/// Parameters that keep the runs below short (fewer iterations; every stage still runs).
const QUICK: [&str; 8] = [
    "--set",
    "iterations=2",
    "--set",
    "coarse_iterations=2",
    "--set",
    "restorer_iterations=1",
    "--set",
    "geometric_iterations=1",
];

fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

fn demo_scene(tmp: &Path, width: u32, height: u32, views: usize) -> PathBuf {
    let demo = tmp.join("demo");
    ok(&[
        "demo",
        "--out",
        s(&demo),
        "--width",
        &width.to_string(),
        "--height",
        &height.to_string(),
        "--views",
        &views.to_string(),
    ]);
    demo
}

#[test]
fn a_run_in_batches_writes_the_maps_of_the_run_holding_every_view_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = demo_scene(tmp.path(), 64, 48, 5);
    // Regions' geometric passes read the prior planes its batches carry from the prior stage.
    // With the per-region choice, the restorer's support points are parked with each batch.
    let choice = ["--set", "prior_region_choice=true"];
    for (name, method, extra) in [
        ("dwta", "dwta", &[][..]),
        ("acmh", "acmh", &[][..]),
        ("acmm", "acmm", &[][..]),
        ("acmp", "acmp", &[][..]),
        ("acmmp", "acmmp", &[][..]),
        ("regions", "regions", &[][..]),
        ("choice", "regions", &choice[..]),
    ] {
        let one = tmp.path().join(format!("one-{name}"));
        let mut args = vec!["run", s(&demo), "--out", s(&one), "--method", method];
        args.extend(extra);
        args.extend(QUICK);
        ok(&args);
        let whole = report(&one);
        assert_eq!(whole["batches"], 1, "{whole}");
        // A third of what holding every view at once needs: batches of a view or two.
        let need = whole["device_memory_peak"].as_u64().unwrap();
        let budget = format!("{}", need as f64 / 3.0 / (1u64 << 20) as f64);
        let batched = tmp.path().join(format!("batched-{name}"));
        let mut args = vec![
            "run",
            s(&demo),
            "--out",
            s(&batched),
            "--method",
            method,
            "--device-memory",
            &budget,
        ];
        args.extend(extra);
        args.extend(QUICK);
        let said = ok(&args);
        let r = report(&batched);
        let batches = r["batches"].as_u64().unwrap();
        assert!(batches >= 2, "{method}: {r}");
        assert!(said.contains(&format!("{batches} batches")), "{said}");
        assert!(
            r["device_memory_peak"].as_u64().unwrap() <= need / 3 + 1,
            "{method}: {r}"
        );
        assert_same_outputs(&one, &batched);
        assert!(
            !batched.join("work").exists(),
            "the work folder is removed after a finished run"
        );
    }
    // The states kept on disk only (no host memory for them): the same maps again.
    let disk = tmp.path().join("disk");
    let need = report(&tmp.path().join("one-acmm"))["device_memory_peak"]
        .as_u64()
        .unwrap();
    let budget = format!("{}", need as f64 / 3.0 / (1u64 << 20) as f64);
    let mut args = vec![
        "run",
        s(&demo),
        "--out",
        s(&disk),
        "--device-memory",
        &budget,
        "--host-memory",
        "0",
        "--keep-work",
    ];
    args.extend(QUICK);
    ok(&args);
    assert_same_outputs(&tmp.path().join("one-acmm"), &disk);
    // Kept on request: the manifest and one state per view, slim (planes, costs, flags).
    let manifest = disk.join("work/manifest.json");
    assert!(manifest.is_file());
    let states = walk(&disk.join("work/stages"))
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "state"))
        .count();
    assert_eq!(states, 5, "one state per view, the superseded ones removed");
}

fn walk(dir: &Path) -> Vec<PathBuf> {
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

/// A run through the library, cancelled once it reaches step `stop` (if given).
fn library_run(
    scene_dir: &Path,
    out: &Path,
    method: mvscope::acmm::Method,
    budget: Option<u64>,
    interval: u64,
    resume: bool,
    stop: Option<usize>,
) -> Result<mvscope::pipeline::RunReport, mvscope::pipeline::RunError> {
    use mvscope::pipeline::{MemoryOptions, RunEvent, RunOptions, RunRecord};
    let load = mvscope::scene::LoadOptions {
        decode_only: Some(Vec::new()),
        ..Default::default()
    };
    let scene = mvscope::scene::Scene::load(scene_dir, &load).unwrap();
    let params = mvscope::acmm::Params::default()
        .with_overrides(
            &QUICK
                .iter()
                .skip(1)
                .step_by(2)
                .map(|s| s.to_string())
                .collect::<Vec<_>>(),
        )
        .unwrap();
    let record = RunRecord::whole(method, scene_dir, &scene, None, params);
    let options = RunOptions {
        out: out.to_path_buf(),
        fuse: true,
        export_acmm: false,
        export_colmap: false,
        resume,
        rerun: None,
        memory: MemoryOptions {
            device_budget: budget,
            checkpoint_interval: std::time::Duration::from_secs(interval),
            ..Default::default()
        },
        record,
    };
    let images = mvscope::pipeline::decoder(&options.record, &load).unwrap();
    let ctx = mvscope::gpu::GpuContext::new().expect("a GPU (install mesa-vulkan-drivers)");
    let cancel = std::sync::atomic::AtomicBool::new(false);
    mvscope::pipeline::run(
        &ctx,
        &scene,
        Some(images),
        &options,
        &mut |e| {
            if let (RunEvent::Step { index, .. }, Some(stop)) = (e, stop)
                && index >= stop
            {
                cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        },
        &cancel,
    )
}

#[test]
fn a_killed_run_resumes_from_its_last_batch_or_stage_and_ends_as_an_uninterrupted_one() {
    use mvscope::acmm::Method;
    let tmp = tempfile::tempdir().unwrap();
    let demo = demo_scene(tmp.path(), 48, 36, 4);
    for (method, batched) in [
        (Method::Acmm, true),
        (Method::Acmmp, true),
        (Method::Regions, true),
        (Method::Acmm, false),
    ] {
        let name = format!("{method}-{batched}");
        let whole = tmp.path().join(format!("whole-{name}"));
        let first = library_run(&demo, &whole, method, None, 3600, false, None).unwrap();
        let budget = batched.then_some(first.device_memory_peak / 3);
        // Stopped two thirds of the way (a batched run has a resume point at every batch;
        // one holding every view at every stage's end when its interval is 0).
        let out = tmp.path().join(format!("resumed-{name}"));
        let stop = first.steps * 2 / 3;
        let e = library_run(&demo, &out, method, budget, 0, false, Some(stop)).unwrap_err();
        assert!(
            matches!(e, mvscope::pipeline::RunError::Cancelled),
            "{name}: {e}"
        );
        assert!(out.join("work/manifest.json").is_file(), "{name}");
        let r = library_run(&demo, &out, method, budget, 0, true, None).unwrap();
        let at = r.resumed_at_step.expect("resumed");
        assert!(
            at > first.steps / 3 && at <= stop,
            "{name}: resumed at {at}"
        );
        assert_eq!(r.batches > 1, batched, "{name}");
        assert_same_outputs(&whole, &out);
    }
}

#[test]
fn a_view_beyond_the_budget_is_refused_by_name_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = demo_scene(tmp.path(), 64, 48, 3);
    let out = tmp.path().join("out");
    // 0.1 MiB: less than a 64x48 view and its two sources need at full size (0.3 MiB).
    let e = fails(&["run", s(&demo), "--out", s(&out), "--device-memory", "0.1"]);
    assert!(
        e.contains("view 0 (00000000, 64x48 with 2 sources) needs")
            && e.contains("beyond the budget of 0.10 MiB")
            && e.contains("--max-image-size"),
        "{e}"
    );
    assert!(!out.exists(), "nothing written: {:?}", walk(tmp.path()));
    // `info` says the same in its last line, and that a smaller size would fit.
    let said = ok(&["info", s(&demo), "--device-memory", "0.1"]);
    let last = said.lines().last().unwrap();
    assert!(
        last.starts_with("does not fit on ") && last.contains("--max-image-size"),
        "{last}"
    );
    // With room for every view: one batch; with a third of that: several.
    let said = ok(&["info", s(&demo)]);
    let last = said.lines().last().unwrap();
    assert!(
        last.starts_with("fits on ") && last.contains(": 1 batch of up to 3 views, peak"),
        "{last}"
    );
}

/// Paints a plain grey rectangle over the middle of every image of an `mvscope demo` scene:
/// a wall whose pixels lie up to ~60 px from texture at 400x300.
fn plain_wall(demo: &Path) {
    for entry in std::fs::read_dir(demo.join("images")).unwrap() {
        let path = entry.unwrap().path();
        let mut img = image::open(&path).unwrap().to_rgb8();
        for y in 60..240 {
            for x in 80..320 {
                img.put_pixel(x, y, image::Rgb([128, 128, 128]));
            }
        }
        img.save(&path).unwrap();
    }
}

#[test]
fn a_plan_keeps_the_number_of_scales_the_images_decided() {
    // `plan` loads sizes only, as a run in batches does: the images' texture is measured on
    // the sampled views' pixels and the record keeps its number of scales, so no task (which
    // holds only its views) measures again.
    let tmp = tempfile::tempdir().unwrap();
    let demo = demo_scene(tmp.path(), 400, 300, 3);
    plain_wall(&demo);
    let paper = tmp.path().join("paper");
    let said_paper = ok(&["plan", s(&demo), "--out", s(&paper), "--tasks", "1"]);
    let work = tmp.path().join("work");
    let said = ok(&[
        "plan",
        s(&demo),
        "--out",
        s(&work),
        "--tasks",
        "1",
        "--set",
        "scales_by_texture=true",
    ]);
    // The wall's 95% reach is ~59 px; 5 px windows span 40 px at the 4th scale, 80 at the
    // 5th, whose 25 px image holds fewer than four windows: 4.
    assert!(
        said.contains("pyramid: 4 scales from the images' texture") && said.contains("5 would"),
        "{said}"
    );
    let params = |dir: &Path| std::fs::read_to_string(dir.join("params.toml")).unwrap();
    assert!(
        params(&paper).contains("\nscales = 3\n"),
        "{}",
        params(&paper)
    );
    assert!(
        params(&work).contains("\nscales = 4\n"),
        "{}",
        params(&work)
    );
    assert!(params(&work).contains("scales_by_texture = true"));
    // 3 stages at the coarsest scale and 3 at each finer one.
    assert!(said.contains("ACMM on 3 views: 12 stages"), "{said}");
    assert!(
        said_paper.contains("ACMM on 3 views: 9 stages"),
        "{said_paper}"
    );
    // Both ways of choosing the number of scales at once is refused by name.
    let e = fails(&[
        "plan",
        s(&demo),
        "--out",
        s(&tmp.path().join("both")),
        "--set",
        "scales_by_texture=true",
        "--set",
        "coarsest_size=100",
    ]);
    assert!(
        e.contains("scales_by_texture") && e.contains("coarsest_size"),
        "{e}"
    );
}

/// A method's own options are defaults the user's `--set` and `--params` override: Regions'
/// record (what every task runs) keeps `prior_confidence_score=false` when asked, and its
/// other options on (the fault: Regions forced its options over `--set`, so comparing
/// Regions with and without one of its parts silently ran the same).
#[test]
fn a_set_turns_off_an_option_the_method_sets() {
    let tmp = tempfile::tempdir().unwrap();
    let demo = demo_scene(tmp.path(), 64, 48, 3);
    let file = tmp.path().join("p.toml");
    // Regions' planned record (what every task runs) with these extra arguments.
    let planned = |name: &str, extra: &[&str]| {
        let out = tmp.path().join(name);
        let mut args = vec!["plan", s(&demo), "--out", s(&out), "--tasks", "1"];
        args.extend(["--method", "regions"]);
        args.extend(extra);
        ok(&args);
        mvscope::pipeline::RunRecord::read(&out.join("params.toml"))
            .unwrap()
            .params
    };
    let p = planned("plain", &[]);
    assert!(p.prior_regions && p.prior_flat_points && p.prior_confirmed_points);
    assert!(p.prior_confidence_score);
    let p = planned("off", &["--set", "prior_confidence_score=false"]);
    assert!(p.prior_regions && p.prior_flat_points && p.prior_confirmed_points);
    assert!(!p.prior_confidence_score);
    // A parameter file that leaves them out keeps the method's; one that names one wins.
    std::fs::write(&file, "tau0 = 0.7\n").unwrap();
    let p = planned("file", &["--params", s(&file)]);
    assert!(p.prior_regions && p.prior_confidence_score && p.tau0 == 0.7);
    std::fs::write(&file, "prior_regions = false\n").unwrap();
    let p = planned("named", &["--params", s(&file)]);
    assert!(!p.prior_regions && p.prior_flat_points);
}
