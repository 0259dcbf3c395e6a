//! The headless run behind `mvscope run`: a Session over the scene, then the stable output
//! contract in the output folder:
//!
//! * `depth/%08d.pfm` — final depth (camera z) of each view, indexed in the scene's view order,
//!   at the processed resolution; 0 where nothing was estimated;
//! * `normal/%08d.pfm` — unit normals in the world frame (3 channels);
//! * `cost/%08d.pfm` — aggregated matching cost in [0, 2];
//! * `fused.ply` — the fused, coloured point cloud (unless fusion is off);
//! * `params.toml` — everything needed to reproduce the run (written first);
//! * `report.json` — adapter, timings per stage, counts (written last).
//!
//! Every file is written atomically (temporary name, then rename). A view's three maps are
//! written as soon as they are final, depth last, so a depth file marks a finished view: with
//! `resume`, an interrupted ACMH/DWTA run skips its finished views (ACMM's, ACMP's and
//! ACMMP's views depend on each other, so they resume only a finished run, e.g. to fuse or
//! export again).

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use web_time::Instant;

use serde::{Deserialize, Serialize};

use crate::acmm::{Method, Params};
use crate::export::{self, ViewOutput};
use crate::fusion::{FusionInput, fuse};
use crate::gpu::GpuContext;
use crate::io::{IoError, Map, PlyPoint, read_pfm, write_atomic, write_pfm, write_ply};
use crate::scene::{Scene, SceneFormat};
use crate::session::{PlanesCosts, Session, SessionError, Stage, Step};

/// What `params.toml` records: enough to reproduce the run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub mvscope_version: String,
    pub method: Method,
    pub scene: PathBuf,
    pub format: Option<SceneFormat>,
    pub max_image_size: Option<u32>,
    /// COLMAP: the model number under sparse/ (`--model`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<u32>,
    pub depth_range: Option<[f64; 2]>,
    /// Scene indices of the views run (all of them unless `--views` chose some).
    pub views: Vec<usize>,
    pub params: Params,
}

impl RunRecord {
    /// The record of a run of `method` over every view of `scene`, loaded from `path` with
    /// the format's own depth ranges (benchmarks, generated scenes).
    pub fn whole(
        method: Method,
        path: &Path,
        scene: &Scene,
        max_image_size: Option<u32>,
        params: Params,
    ) -> RunRecord {
        RunRecord {
            mvscope_version: env!("CARGO_PKG_VERSION").to_string(),
            method,
            scene: path.to_path_buf(),
            format: scene.format,
            max_image_size,
            model: None,
            depth_range: None,
            views: (0..scene.views.len()).collect(),
            params,
        }
    }

    pub fn read(path: &Path) -> Result<RunRecord, RunError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| RunError::Io(IoError::io(path, "read", e)))?;
        toml::from_str(&text).map_err(|e| {
            RunError::Invalid(format!(
                "{}: not a params.toml written by mvscope run ({e})",
                path.display()
            ))
        })
    }
}

/// How to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    pub out: PathBuf,
    pub fuse: bool,
    pub export_acmm: bool,
    pub export_colmap: bool,
    pub resume: bool,
    /// Log cameras, maps per stage and the cloud to this .rrd (needs the `rerun` feature).
    pub rerun: Option<PathBuf>,
    pub record: RunRecord,
}

/// What a run tells its caller as it goes.
pub enum RunEvent<'a> {
    /// About to run step `index` of `total`.
    Step {
        step: &'a Step,
        index: usize,
        total: usize,
    },
    /// A phase after the session: "fusing", "exporting ACMM", ...
    Phase(&'a str),
}

/// Wall time of one stage (all views), in milliseconds.
#[derive(Clone, Debug, Serialize)]
pub struct StageTiming {
    pub level: u32,
    pub stage: String,
    pub ms: f64,
}

/// `report.json`.
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    pub mvscope_version: String,
    pub adapter: String,
    pub software_adapter: bool,
    pub method: String,
    pub views: usize,
    pub image_sizes: Vec<[u32; 2]>,
    pub steps: usize,
    pub resumed_views: Vec<usize>,
    pub stages: Vec<StageTiming>,
    /// Bytes moved host to device during the run (images once per level, parameters, the
    /// maps the viewer or a resume needs).
    pub bytes_to_device: u64,
    /// Bytes read back from the device (the final depth, normal and cost maps).
    pub bytes_from_device: u64,
    /// Images once per level plus the final planes and costs: the least a run can move.
    pub bytes_minimum: u64,
    /// The device memory the run needs at its peak (`mvscope info` shows it per level).
    pub device_memory_peak: u64,
    /// Matching-cost evaluations (pixel x hypothesis x source) of the session.
    pub cost_evaluations: u64,
    pub session_ms: f64,
    pub fusion_ms: f64,
    pub fused_points: Option<usize>,
    pub total_ms: f64,
    /// A cluster run (`mvscope plan`): its tasks per stage (the figures above are their
    /// sums; `device_memory_peak` is the largest task's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tasks: Option<usize>,
    /// A cluster run: the largest task's peak resident memory, bytes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host_memory_peak: Option<u64>,
}

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error(transparent)]
    Io(#[from] IoError),
    #[error(transparent)]
    Fusion(#[from] crate::fusion::FusionError),
    #[error(transparent)]
    Export(#[from] crate::export::ExportError),
    #[error("{0}")]
    Invalid(String),
    #[error("cancelled; finished views are kept and `--resume` continues from them")]
    Cancelled,
}

pub(crate) fn view_file(dir: &Path, kind: &str, index: usize) -> PathBuf {
    dir.join(kind).join(format!("{index:08}.pfm"))
}

pub(crate) fn create_dir(path: &Path) -> Result<(), RunError> {
    std::fs::create_dir_all(path)
        .map_err(|e| RunError::Io(IoError::io(path, "create the folder", e)))
}

/// A view's final maps in output form.
pub(crate) struct FinalMaps {
    pub depth: Vec<f32>,
    pub normal_world: Vec<[f32; 3]>,
    /// The written world normals in the camera frame: what fusion reads, the same whether
    /// the maps come from the session or from the files (a cluster's fusion job), so both
    /// fuse the same cloud.
    pub normal_camera: Vec<[f32; 3]>,
    pub cost: Vec<f32>,
}

/// The written (world) normals in `camera`'s frame.
fn camera_normals(camera: &crate::camera::Camera, world: &[[f32; 3]]) -> Vec<[f32; 3]> {
    world
        .iter()
        .map(|n| {
            let c = camera.dir_camera_from_world(glam::Vec3::from_array(*n).as_dvec3());
            [c.x as f32, c.y as f32, c.z as f32]
        })
        .collect()
}

pub(crate) fn final_from_session(scene: &Scene, view: usize, st: PlanesCosts) -> FinalMaps {
    let cam = &scene.views[view].camera;
    let normal_world: Vec<[f32; 3]> = st
        .plane
        .iter()
        .map(|p| {
            if p[3] <= 0.0 {
                return [0.0; 3];
            }
            let w = cam.dir_world_from_camera(glam::Vec3::new(p[0], p[1], p[2]).as_dvec3());
            [w.x as f32, w.y as f32, w.z as f32]
        })
        .collect();
    FinalMaps {
        depth: st.plane.iter().map(|p| p[3].max(0.0)).collect(),
        normal_camera: camera_normals(cam, &normal_world),
        normal_world,
        cost: st.cost,
    }
}

pub(crate) fn final_from_disk(
    scene: &Scene,
    view: usize,
    dir: &Path,
    index: usize,
) -> Result<FinalMaps, RunError> {
    let depth = read_pfm(&view_file(dir, "depth", index))?;
    let normal = read_pfm(&view_file(dir, "normal", index))?;
    let cost = read_pfm(&view_file(dir, "cost", index))?;
    let v = &scene.views[view];
    let (w, h) = (v.image.width, v.image.height);
    for (m, c, kind) in [
        (&depth, 1, "depth"),
        (&normal, 3, "normal"),
        (&cost, 1, "cost"),
    ] {
        if (m.width, m.height, m.channels) != (w, h, c) {
            return Err(RunError::Invalid(format!(
                "{}: {}x{}x{} does not match view {index} ({w}x{h}); remove --resume to recompute",
                view_file(dir, kind, index).display(),
                m.width,
                m.height,
                m.channels
            )));
        }
    }
    let normal_world: Vec<[f32; 3]> = normal
        .data
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let normal_camera = camera_normals(&v.camera, &normal_world);
    Ok(FinalMaps {
        depth: depth.data,
        normal_world,
        normal_camera,
        cost: cost.data,
    })
}

pub(crate) fn write_final(
    dir: &Path,
    index: usize,
    maps: &FinalMaps,
    w: u32,
    h: u32,
) -> Result<(), RunError> {
    let map = |c: u32, data: Vec<f32>| {
        Map::from_data(w, h, c, data).map_err(|e| RunError::Invalid(e.to_string()))
    };
    write_pfm(&view_file(dir, "cost", index), &map(1, maps.cost.clone())?)?;
    let normals = maps.normal_world.iter().flatten().copied().collect();
    write_pfm(&view_file(dir, "normal", index), &map(3, normals)?)?;
    // Depth last: its presence marks the view finished.
    write_pfm(
        &view_file(dir, "depth", index),
        &map(1, maps.depth.clone())?,
    )?;
    Ok(())
}

/// Fusion (`options.fuse`) into `fused.ply` and the other tools' layouts asked for, from
/// the final maps of every view: the end of a run, on one machine or in a cluster's last job.
pub(crate) fn fuse_and_export(
    scene: &Scene,
    finals: &[FinalMaps],
    options: &RunOptions,
    progress: &mut dyn FnMut(RunEvent),
) -> Result<Option<Vec<PlyPoint>>, RunError> {
    let out = &options.out;
    let mut cloud: Option<Vec<PlyPoint>> = None;
    if options.fuse {
        progress(RunEvent::Phase("fusing"));
        let depths: Vec<Vec<f32>> = finals.iter().map(|f| f.depth.clone()).collect();
        let normals: Vec<Vec<[f32; 3]>> = finals.iter().map(|f| f.normal_camera.clone()).collect();
        let fused = fuse(
            &FusionInput {
                scene,
                depths: &depths,
                normals: &normals,
            },
            &options.record.params,
        )?;
        write_ply(&out.join("fused.ply"), &fused.points)?;
        cloud = Some(fused.points);
    }
    let outputs: Vec<ViewOutput> = finals
        .iter()
        .map(|f| ViewOutput {
            depth: &f.depth,
            normal_world: &f.normal_world,
            cost: &f.cost,
        })
        .collect();
    if options.export_acmm {
        progress(RunEvent::Phase("exporting the ACMM layout"));
        export::export_acmm(scene, &outputs, cloud.as_deref(), out)?;
    }
    if options.export_colmap {
        progress(RunEvent::Phase("exporting a COLMAP workspace"));
        export::export_colmap(scene, &outputs, &out.join("colmap"))?;
    }
    Ok(cloud)
}

pub(crate) fn stage_name(stage: Stage) -> String {
    match stage {
        Stage::Photometric => "photometric".into(),
        Stage::Restorer => "upsample + restorer".into(),
        Stage::Planar => "planar prior".into(),
        Stage::Geometric(g) => format!("geometric {g}"),
    }
}

/// Runs the method over `scene` (already loaded, at the processed size, restricted to
/// `options.record.views` in that order) and writes the outputs.
pub fn run(
    ctx: &GpuContext,
    scene: &Scene,
    options: &RunOptions,
    progress: &mut dyn FnMut(RunEvent),
    cancel: &AtomicBool,
) -> Result<RunReport, RunError> {
    let started = Instant::now();
    let out = &options.out;
    let record = &options.record;
    if record.views.len() != scene.views.len() {
        return Err(RunError::Invalid(format!(
            "{} view indices recorded for a scene of {} views",
            record.views.len(),
            scene.views.len()
        )));
    }
    for kind in ["depth", "normal", "cost"] {
        create_dir(&out.join(kind))?;
    }
    let params_path = out.join("params.toml");
    let mut done: Vec<usize> = Vec::new(); // local view indices already finished
    if options.resume && params_path.is_file() {
        let previous = RunRecord::read(&params_path)?;
        let same = RunRecord {
            mvscope_version: record.mvscope_version.clone(),
            ..previous.clone()
        } == *record;
        if !same {
            return Err(RunError::Invalid(format!(
                "{}: the earlier run used other parameters, views or scene; run without --resume (or into another --out) to start over",
                params_path.display()
            )));
        }
        done = (0..scene.views.len())
            .filter(|&v| view_file(out, "depth", record.views[v]).is_file())
            .collect();
    }
    let text = toml::to_string(record).map_err(|e| RunError::Invalid(e.to_string()))?;
    write_atomic(&params_path, |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;

    #[cfg(feature = "rerun")]
    let logger = match &options.rerun {
        Some(path) => {
            let l = crate::rerun_log::RunLogger::to_file(path)
                .map_err(|e| RunError::Invalid(e.to_string()))?;
            l.log_scene(scene)
                .map_err(|e| RunError::Invalid(e.to_string()))?;
            Some(l)
        }
        None => None,
    };
    #[cfg(not(feature = "rerun"))]
    if options.rerun.is_some() {
        return Err(RunError::Invalid(
            "--rerun needs mvscope built with the `rerun` feature (cargo build --features rerun)"
                .into(),
        ));
    }

    let method = record.method;
    let all_done = done.len() == scene.views.len();
    let mut session = Session::new(ctx, scene, record.params.clone(), method)?;
    // A stage's views one action at a time, submitted together (same maps).
    session.set_batch()?;
    let mut resumed = Vec::new();
    if all_done {
        session.restrict_views(&[]).ok();
        resumed = done.clone();
    } else if !done.is_empty() && !method.couples_views() {
        let todo: Vec<usize> = (0..scene.views.len())
            .filter(|v| !done.contains(v))
            .collect();
        session.restrict_views(&todo)?;
        resumed = done.clone();
    }
    let skip_session = all_done && method.couples_views();
    let traffic_before = ctx.traffic.read();
    let cost_evaluations = if skip_session {
        0
    } else {
        session.cost_evaluations()
    };
    let bytes_minimum = if skip_session {
        0
    } else {
        (0..session.num_levels())
            .map(|l| {
                let level = session.level_scene(l);
                level
                    .views
                    .iter()
                    .map(|v| v.image.width as u64 * v.image.height as u64 * 4)
                    .sum::<u64>()
            })
            .sum::<u64>()
            + scene
                .views
                .iter()
                .filter(|v| !v.sources.is_empty())
                .map(|v| v.image.width as u64 * v.image.height as u64 * 20)
                .sum::<u64>()
    };

    // The session, writing each view's maps as soon as they are final.
    let mut finals: Vec<Option<FinalMaps>> = (0..scene.views.len()).map(|_| None).collect();
    let mut stages: Vec<StageTiming> = Vec::new();
    let session_started = Instant::now();
    let mut stage_started = Instant::now();
    let total = session.schedule().len();
    if !skip_session {
        session.run_batches(
            |step, index, total| {
                if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                    return Err(RunError::Cancelled);
                }
                progress(RunEvent::Step { step, index, total });
                Ok(())
            },
            |session, batch| {
                for i in batch.ran {
                    let view = session.schedule()[i].view;
                    if session.completes_view(i)
                        && let Some(maps) = session.planes_and_costs(view)?
                    {
                        let f = final_from_session(scene, view, maps);
                        let v = &scene.views[view];
                        write_final(out, record.views[view], &f, v.image.width, v.image.height)?;
                        finals[view] = Some(f);
                    }
                }
                if batch.stage_ended {
                    let step = batch.first;
                    stages.push(StageTiming {
                        level: step.level,
                        stage: stage_name(step.stage),
                        ms: stage_started.elapsed().as_secs_f64() * 1e3,
                    });
                    stage_started = Instant::now();
                    #[cfg(feature = "rerun")]
                    if let Some(l) = &logger {
                        for (v, m) in session.final_maps()?.iter().enumerate() {
                            if let Some(m) = m {
                                let label = format!("{} · {}", session.method(), step.label());
                                l.log_maps(&label, stages.len() as i64, v, scene, m)
                                    .map_err(|e| RunError::Invalid(e.to_string()))?;
                            }
                        }
                    }
                }
                Ok(())
            },
        )?;
    }
    let session_ms = session_started.elapsed().as_secs_f64() * 1e3;
    let traffic = ctx.traffic.read() - traffic_before;
    for &v in &resumed {
        finals[v] = Some(final_from_disk(scene, v, out, record.views[v])?);
    }
    let finals: Vec<FinalMaps> = finals
        .into_iter()
        .enumerate()
        .map(|(v, f)| {
            f.ok_or_else(|| {
                RunError::Invalid(format!("view {v} finished without maps (internal error)"))
            })
        })
        .collect::<Result<_, _>>()?;

    let fusion_started = Instant::now();
    let cloud = fuse_and_export(scene, &finals, options, progress)?;
    let fusion_ms = fusion_started.elapsed().as_secs_f64() * 1e3;
    #[cfg(feature = "rerun")]
    if let (Some(l), Some(c)) = (&logger, &cloud) {
        l.log_cloud(c)
            .map_err(|e| RunError::Invalid(e.to_string()))?;
        l.flush().map_err(|e| RunError::Invalid(e.to_string()))?;
    }

    let report = RunReport {
        mvscope_version: env!("CARGO_PKG_VERSION").to_string(),
        adapter: ctx.describe(),
        software_adapter: ctx.is_software(),
        method: method.to_string(),
        views: scene.views.len(),
        image_sizes: scene
            .views
            .iter()
            .map(|v| [v.image.width, v.image.height])
            .collect(),
        steps: total,
        resumed_views: resumed.iter().map(|&v| record.views[v]).collect(),
        stages,
        bytes_to_device: traffic.to_device,
        bytes_from_device: traffic.from_device,
        bytes_minimum,
        device_memory_peak: crate::acmm::memory::MemoryPlan::for_scene(
            scene,
            &record.params,
            method,
        )
        .peak(),
        cost_evaluations,
        session_ms,
        fusion_ms,
        fused_points: cloud.as_ref().map(Vec::len),
        total_ms: started.elapsed().as_secs_f64() * 1e3,
        tasks: None,
        host_memory_peak: None,
    };
    let json =
        serde_json::to_string_pretty(&report).map_err(|e| RunError::Invalid(e.to_string()))?;
    write_atomic(&out.join("report.json"), |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    Ok(report)
}
