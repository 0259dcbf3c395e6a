//! One unit of a plan (`mvscope task DIR --stage K --chunk I`, or `--fuse`): what a Slurm
//! array element or a Kubernetes Job's pod runs, and what a user can run by hand.

use std::path::Path;
use std::sync::Arc;
use web_time::Instant;

use serde::{Deserialize, Serialize};

use super::{ClusterError, Plan, Stamp, load_options};
use crate::fusion::{FusionError, LoadedView, fuse_streamed};
use crate::gpu::GpuContext;
use crate::gpu::acmh::AcmhPipelines;
use crate::io::{IoError, write_atomic, write_ply};
use crate::pipeline::{
    FinalMaps, RunOptions, RunReport, StageTiming, create_dir, final_from_disk, final_from_session,
    fuse_and_export, write_final,
};
use crate::scene::{RawScene, Scene};
use crate::session::{HandoffView, Part, Session};

/// What a unit did.
#[derive(Clone, Debug)]
pub enum UnitOutcome {
    /// It ran and wrote its outputs.
    Done(Box<UnitReport>),
    /// Its outputs were there already (a resubmitted chain).
    Skipped,
}

/// A unit's marker (`tasks/SS-CCC.json`, `tasks/fuse.json`), written after its outputs: its
/// plan's stamp and its figures, which the fusion unit sums into `report.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct UnitReport {
    pub stamp: Stamp,
    /// The stage (`None`: fusion) and chunk.
    pub stage: Option<usize>,
    pub chunk: usize,
    /// The views it estimated (the run's numbering).
    pub views: Vec<usize>,
    pub adapter: String,
    /// [`crate::gpu::adapter_caveat`] of its adapter (absent in markers written before it).
    #[serde(default)]
    pub adapter_caveat: Option<String>,
    pub steps: usize,
    pub session_ms: f64,
    pub total_ms: f64,
    pub cost_evaluations: u64,
    pub bytes_to_device: u64,
    pub bytes_from_device: u64,
    /// The device memory its part of the scene needs at the peak (the memory plan).
    pub device_memory_peak: u64,
    /// The process's peak resident memory (Linux `VmHWM`), bytes.
    pub host_memory_peak: Option<u64>,
}

/// The process's peak resident set size (Linux), in bytes.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

fn read_marker(path: &Path) -> Result<UnitReport, ClusterError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| IoError::io(path, "read the unit's marker", e))?;
    serde_json::from_str(&text).map_err(|e| {
        ClusterError::Invalid(format!(
            "{}: not a unit marker written by mvscope task ({e}); remove it to run the unit again",
            path.display()
        ))
    })
}

/// Whether the unit of `marker` has run for this plan: `Ok(true)` if so, an error naming
/// what differs if another plan's unit wrote it.
fn already_done(plan: &Plan, marker: &Path) -> Result<bool, ClusterError> {
    if !marker.is_file() {
        return Ok(false);
    }
    let done = read_marker(marker)?;
    match done.stamp.differences(&plan.stamp) {
        None => Ok(true),
        Some(what) => Err(ClusterError::Invalid(format!(
            "{}: written by another plan ({what} differ); remove the work folder's stages/ and tasks/ (or plan into a new folder) to start over",
            marker.display()
        ))),
    }
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), ClusterError> {
    if let Some(parent) = path.parent() {
        create_dir(parent)?;
    }
    let json =
        serde_json::to_string_pretty(value).map_err(|e| ClusterError::Invalid(e.to_string()))?;
    write_atomic(path, |w| std::io::Write::write_all(w, json.as_bytes()))?;
    Ok(())
}

/// The header line of a state file: which plan, stage and view wrote it.
#[derive(Serialize, Deserialize)]
struct StateHeader {
    stamp: Stamp,
    stage: usize,
    view: usize,
}

fn write_state(path: &Path, header: &StateHeader, state: &HandoffView) -> Result<(), ClusterError> {
    if let Some(parent) = path.parent() {
        create_dir(parent)?;
    }
    let head = serde_json::to_string(header).map_err(|e| ClusterError::Invalid(e.to_string()))?;
    let body = state.to_bytes();
    write_atomic(path, |w| {
        std::io::Write::write_all(w, head.as_bytes())?;
        std::io::Write::write_all(w, b"\n")?;
        std::io::Write::write_all(w, &body)
    })?;
    Ok(())
}

fn read_state(
    plan: &Plan,
    path: &Path,
    stage: usize,
    chunk: usize,
) -> Result<HandoffView, ClusterError> {
    let bytes = std::fs::read(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            ClusterError::Invalid(format!(
                "stage {} chunk {chunk} needs {}, which is missing: stage {stage} ({}) has not finished (a unit failed or was cancelled); run its units first, e.g. submit the chain again (finished units are skipped)",
                stage + 1,
                path.display(),
                plan.stages[stage].name
            ))
        } else {
            IoError::io(path, "read the stage state", e).into()
        }
    })?;
    let bad = |m: String| {
        ClusterError::Invalid(format!(
            "{}: {m}; remove it and run stage {stage} again",
            path.display()
        ))
    };
    let split = bytes
        .iter()
        .position(|&b| b == b'\n')
        .ok_or_else(|| bad("no header line".into()))?;
    let header: StateHeader =
        serde_json::from_slice(&bytes[..split]).map_err(|e| bad(format!("bad header ({e})")))?;
    if let Some(what) = header.stamp.differences(&plan.stamp) {
        return Err(ClusterError::Invalid(format!(
            "{}: written by another plan ({what} differ); remove the work folder's stages/ and tasks/ (or plan into a new folder) to start over",
            path.display()
        )));
    }
    if header.stage != stage {
        return Err(bad(format!("written by stage {}", header.stage)));
    }
    HandoffView::from_bytes(&bytes[split + 1..]).map_err(bad)
}

/// Runs stage `stage` of chunk `chunk` of the plan in `dir` (skipped if its marker says it
/// has run).
pub fn run_unit(
    ctx: &GpuContext,
    dir: &Path,
    stage: usize,
    chunk: usize,
) -> Result<UnitOutcome, ClusterError> {
    let started = Instant::now();
    let plan = Plan::read(dir)?;
    if stage >= plan.stages.len() {
        return Err(ClusterError::Invalid(format!(
            "--stage {stage}: the plan in {} has stages 0..{}",
            dir.display(),
            plan.stages.len() - 1
        )));
    }
    let Some(c) = plan.chunks.get(chunk) else {
        return Err(ClusterError::Invalid(format!(
            "--chunk {chunk}: the plan in {} has chunks 0..{}",
            dir.display(),
            plan.chunks.len() - 1
        )));
    };
    let marker = Plan::marker(dir, stage, chunk);
    if already_done(&plan, &marker)? {
        return Ok(UnitOutcome::Skipped);
    }
    let record = &plan.record;
    // The states the stage starts from: its views', and its sources' if it reads them.
    let estimated = |v: usize| plan.chunks.iter().any(|c| c.views.contains(&v));
    let position = |v: usize| c.holds.binary_search(&v).unwrap_or(0);
    let mut states = Vec::new();
    if stage > 0 {
        let from: &[usize] = if plan.stages[stage].reads_sources {
            &c.holds
        } else {
            &c.views
        };
        for &v in from.iter().filter(|&&v| estimated(v)) {
            let state = read_state(&plan, &plan.state_file(dir, stage - 1, v), stage - 1, chunk)?;
            states.push((position(v), state));
        }
    }
    // Only the chunk's views and their sources are decoded.
    let options = load_options(record, dir, Some(&c.holds))?;
    let scene = Scene::load(&record.scene, &options)?.subset(&record.views)?;
    for &v in &c.views {
        if let Some(s) = scene.views[v]
            .sources
            .iter()
            .find(|s| c.holds.binary_search(&s.index).is_err())
        {
            return Err(ClusterError::Invalid(format!(
                "view {} ({}) now has source {}, which the plan did not give its chunk: the scene changed since planning; plan again",
                record.views[v], scene.views[v].name, record.views[s.index]
            )));
        }
    }
    let part = scene.subset(&c.holds)?;
    drop(scene);
    let pipelines = Arc::new(AcmhPipelines::new(ctx)?);
    let mut session = Session::for_part(
        ctx,
        pipelines,
        &part,
        Part {
            indices: c.holds.clone(),
            long_side: plan.long_side,
        },
        record.params.clone(),
        record.method,
    )?;
    session.set_batch()?;
    let schedule: Vec<(u32, String)> = session
        .stages()
        .iter()
        .map(|&(l, s)| (l, crate::pipeline::stage_name(s)))
        .collect();
    let planned: Vec<(u32, String)> = plan
        .stages
        .iter()
        .map(|s| (s.level, s.name.clone()))
        .collect();
    if schedule != planned {
        return Err(ClusterError::Invalid(format!(
            "this mvscope ({}) schedules other stages than the plan's (made by mvscope {}): plan again with the build the tasks run",
            env!("CARGO_PKG_VERSION"),
            plan.mvscope_version
        )));
    }
    let views: Vec<usize> = c.views.iter().map(|&v| position(v)).collect();
    session.begin_stage(stage, &views, states)?;
    let traffic_before = ctx.traffic.read();
    let cost_evaluations = session.cost_evaluations();
    let steps = session.schedule().len();
    let session_started = Instant::now();
    session.run_batches(|_, _, _| Ok::<(), ClusterError>(()), |_, _| Ok(()))?;
    let last = stage + 1 == plan.stages.len();
    for (&v, &p) in c.views.iter().zip(&views) {
        if last {
            let maps = session.planes_and_costs(p)?.ok_or_else(|| {
                ClusterError::Invalid(format!(
                    "view {}: no maps at the end (internal error)",
                    record.views[v]
                ))
            })?;
            for kind in ["depth", "normal", "cost"] {
                create_dir(&dir.join(kind))?;
            }
            let image = &part.views[p].image;
            let f = final_from_session(&part, p, maps);
            write_final(dir, record.views[v], &f, image.width, image.height)?;
        } else {
            let state = session.handoff(p)?.ok_or_else(|| {
                ClusterError::Invalid(format!(
                    "view {}: no state at the end (internal error)",
                    record.views[v]
                ))
            })?;
            let header = StateHeader {
                stamp: plan.stamp.clone(),
                stage,
                view: record.views[v],
            };
            write_state(&plan.state_file(dir, stage, v), &header, &state)?;
        }
    }
    let session_ms = session_started.elapsed().as_secs_f64() * 1e3;
    let traffic = ctx.traffic.read() - traffic_before;
    let report = UnitReport {
        stamp: plan.stamp.clone(),
        stage: Some(stage),
        chunk,
        views: c.views.iter().map(|&v| record.views[v]).collect(),
        adapter: ctx.describe(),
        adapter_caveat: ctx.caveat(),
        steps,
        session_ms,
        total_ms: started.elapsed().as_secs_f64() * 1e3,
        cost_evaluations,
        bytes_to_device: traffic.to_device,
        bytes_from_device: traffic.from_device,
        device_memory_peak: c.device_bytes,
        host_memory_peak: peak_resident_bytes(),
    };
    write_json(&marker, &report)?;
    Ok(UnitOutcome::Done(Box::new(report)))
}

/// The last unit: fuses the final maps (and writes the other layouts asked for) and writes
/// `report.json` with the units' figures summed. Needs no GPU.
pub fn fuse_unit(dir: &Path) -> Result<UnitOutcome, ClusterError> {
    let started = Instant::now();
    let plan = Plan::read(dir)?;
    let marker = Plan::fuse_marker(dir);
    if already_done(&plan, &marker)? {
        return Ok(UnitOutcome::Skipped);
    }
    let mut units = Vec::new();
    for stage in 0..plan.stages.len() {
        for chunk in 0..plan.chunks.len() {
            let m = Plan::marker(dir, stage, chunk);
            if !already_done(&plan, &m)? {
                return Err(ClusterError::Invalid(format!(
                    "fusion needs every unit done, and stage {stage} ({}) chunk {chunk} is not ({} is missing); run it first, e.g. submit the chain again (finished units are skipped)",
                    plan.stages[stage].name,
                    m.display()
                )));
            }
            units.push(read_marker(&m)?);
        }
    }
    let record = &plan.record;
    let fusion_started = Instant::now();
    let (scene, cloud) = if plan.export_acmm || plan.export_colmap {
        // The other layouts are written from every view's maps at once.
        let options = load_options(record, dir, None)?;
        let scene = Scene::load(&record.scene, &options)?.subset(&record.views)?;
        let finals: Vec<FinalMaps> = (0..scene.views.len())
            .map(|v| final_from_disk(&scene, v, dir, record.views[v]))
            .collect::<Result<_, _>>()?;
        let run_options = RunOptions {
            out: dir.to_path_buf(),
            fuse: plan.fuse,
            export_acmm: plan.export_acmm,
            export_colmap: plan.export_colmap,
            resume: false,
            rerun: None,
            record: record.clone(),
            memory: Default::default(),
        };
        let cloud = fuse_and_export(&scene, &finals, &run_options, &mut |_| {})?;
        (scene, cloud)
    } else {
        // Streamed: the scene's cameras and sources (read once), and only the maps and
        // images of the reference view at hand and its sources.
        let options = load_options(record, dir, Some(&[]))?;
        let raw = RawScene::read(&record.scene, &options)?;
        let scene = raw.clone().finish(&options)?.subset(&record.views)?;
        let cloud = if plan.fuse {
            let mut load = |views: &[usize]| -> Result<Vec<LoadedView>, FusionError> {
                let failed = |e: String| FusionError::Load(e);
                views
                    .iter()
                    .map(|&v| {
                        let image = raw.views[record.views[v]]
                            .decode(&options)
                            .map_err(|e| failed(e.to_string()))?;
                        let f = final_from_disk(&scene, v, dir, record.views[v])
                            .map_err(|e| failed(e.to_string()))?;
                        Ok(LoadedView {
                            depth: f.depth,
                            normal: f.normal_camera,
                            rgb: image.rgb,
                        })
                    })
                    .collect()
            };
            let fused = fuse_streamed(&scene, &record.params, &mut load)?;
            write_ply(&dir.join("fused.ply"), &fused.points)?;
            Some(fused.points)
        } else {
            None
        };
        (scene, cloud)
    };
    let fusion_ms = fusion_started.elapsed().as_secs_f64() * 1e3;
    // Each depth's confidence, as `mvscope run` writes it beside the maps.
    crate::pipeline::confidence_from_files(&scene, dir, &record.params, &record.views)?;

    // The units' figures summed: per stage, its chunks' session time.
    let stages: Vec<StageTiming> = plan
        .stages
        .iter()
        .enumerate()
        .map(|(k, s)| StageTiming {
            level: s.level,
            stage: s.name.clone(),
            ms: units
                .iter()
                .filter(|u| u.stage == Some(k))
                .map(|u| u.session_ms)
                .sum(),
        })
        .collect();
    let mut adapters: Vec<String> = units.iter().map(|u| u.adapter.clone()).collect();
    adapters.sort();
    adapters.dedup();
    let sum = |f: fn(&UnitReport) -> u64| units.iter().map(f).sum::<u64>();
    let report = RunReport {
        mvscope_version: env!("CARGO_PKG_VERSION").to_string(),
        adapter: adapters.join("; "),
        software_adapter: units.iter().any(|u| u.adapter.contains("llvmpipe")),
        adapter_caveat: units.iter().find_map(|u| u.adapter_caveat.clone()),
        method: record.method.to_string(),
        views: scene.views.len(),
        image_sizes: scene
            .views
            .iter()
            .map(|v| [v.image.width, v.image.height])
            .collect(),
        steps: units.iter().map(|u| u.steps).sum(),
        resumed_views: Vec::new(),
        stages,
        bytes_to_device: sum(|u| u.bytes_to_device),
        bytes_from_device: sum(|u| u.bytes_from_device),
        bytes_minimum: 0,
        device_memory_peak: units
            .iter()
            .map(|u| u.device_memory_peak)
            .max()
            .unwrap_or(0),
        cost_evaluations: sum(|u| u.cost_evaluations),
        session_ms: units.iter().map(|u| u.session_ms).sum(),
        fusion_ms,
        fused_points: cloud.as_ref().map(Vec::len),
        total_ms: units.iter().map(|u| u.total_ms).sum::<f64>()
            + started.elapsed().as_secs_f64() * 1e3,
        tasks: Some(plan.chunks.len()),
        host_memory_peak: units.iter().filter_map(|u| u.host_memory_peak).max(),
        batches: plan.chunks.len(),
        device_budget: None,
        resumed_at_step: None,
    };
    write_json(&dir.join("report.json"), &report)?;
    let done = UnitReport {
        stamp: plan.stamp.clone(),
        stage: None,
        chunk: 0,
        views: record.views.clone(),
        adapter: String::new(),
        adapter_caveat: None,
        steps: 0,
        session_ms: 0.0,
        total_ms: started.elapsed().as_secs_f64() * 1e3,
        cost_evaluations: 0,
        bytes_to_device: 0,
        bytes_from_device: 0,
        device_memory_peak: 0,
        host_memory_peak: peak_resident_bytes(),
    };
    write_json(&marker, &done)?;
    Ok(UnitOutcome::Done(Box::new(done)))
}
