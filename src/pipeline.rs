//! The headless run behind `mvscope run`: a Session over the scene, then the stable output
//! contract in the output folder:
//!
//! * `depth/%08d.pfm` — final depth (camera z) of each view, indexed in the scene's view order,
//!   at the processed resolution; 0 where nothing was estimated;
//! * `normal/%08d.pfm` — unit normals in the world frame (3 channels);
//! * `cost/%08d.pfm` — aggregated matching cost in [0, 2];
//! * `confidence/%08d.pfm` — per pixel, how many of the view's sources agree with its depth
//!   by fusion's three checks (`crate::fusion::confidence`): keep `>= k` for a filtered map;
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
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use web_time::Instant;

use serde::{Deserialize, Serialize};

use crate::acmm::{Method, Params};
use crate::export::{self, ViewOutput};
use crate::fusion::{FusionError, FusionInput, fuse};
use crate::gpu::GpuContext;
use crate::gpu::acmh::AcmhPipelines;
use crate::io::{IoError, Map, PlyPoint, read_pfm, write_atomic, write_pfm, write_ply};
use crate::scene::{Scene, SceneFormat};
use crate::session::{DecodeView, PlanesCosts, Session, SessionError, SessionOptions, Stage, Step};

/// What `params.toml` records: enough to reproduce the run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub mvscope_version: String,
    /// The record's format: [`RunRecord::FORMAT`]; 0 (absent) in records written before a
    /// method's own options became defaults in `params` (see [`RunRecord::read`]).
    #[serde(default)]
    pub record_format: u32,
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
    /// Format 1: `params` are what the run ran with, a method's own options included.
    pub const FORMAT: u32 = 1;

    /// How to load the run's scene again as the run saw it, for the checks `mvscope eval`
    /// makes: its format, model and size, undistorted images kept in the run's folder `dir`.
    pub fn load_options(&self, dir: &Path) -> crate::scene::LoadOptions {
        crate::scene::LoadOptions {
            format: self.format,
            model: self.model,
            max_image_size: self.max_image_size,
            undistort_cache: Some(dir.join("undistorted")),
            ..Default::default()
        }
    }

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
            record_format: Self::FORMAT,
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

    /// Reads a params.toml. A record of format 0 kept the parameters as given, and its
    /// session turned the method's own options on over them (Regions'); it is read as that
    /// run ran ([`Method::params`]), so a resumed run or a cluster task of a work folder
    /// planned before computes what it began with.
    pub fn read(path: &Path) -> Result<RunRecord, RunError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| RunError::Io(IoError::io(path, "read", e)))?;
        let mut record: RunRecord = toml::from_str(&text).map_err(|e| {
            RunError::Invalid(format!(
                "{}: not a params.toml written by mvscope run ({e})",
                path.display()
            ))
        })?;
        if record.record_format == 0 {
            record.params = record.method.ran_at_format_0(&record.params);
            record.record_format = Self::FORMAT;
        }
        Ok(record)
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
    /// How the run holds the scene on the device and the host.
    pub memory: MemoryOptions,
}

/// A run's memory: the device budget that decides whether it runs in batches, and its work
/// folder (`OUT/work`: the states between stages, the resume points).
#[derive(Clone, Debug)]
pub struct MemoryOptions {
    /// Device memory to plan with, bytes (`--device-memory`; `None`: what
    /// `crate::acmm::memory::default_budget` knows).
    pub device_budget: Option<u64>,
    /// Batches of at most this many views (tests, `bench --scale`).
    pub max_batch: Option<usize>,
    /// Host memory the states may take before they are kept on disk only, bytes (`None`:
    /// half of the host's available memory).
    pub host_budget: Option<u64>,
    /// Keep the work folder after a finished run.
    pub keep_work: bool,
    /// The shortest time between two resume points of a run holding every view (a batched
    /// run has one at every batch).
    pub checkpoint_interval: std::time::Duration,
}

impl Default for MemoryOptions {
    fn default() -> MemoryOptions {
        MemoryOptions {
            device_budget: None,
            max_batch: None,
            host_budget: None,
            keep_work: false,
            checkpoint_interval: std::time::Duration::from_secs(60),
        }
    }
}

/// The work folder of a run in `out`.
pub fn work_folder(out: &Path) -> PathBuf {
    out.join("work")
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
    /// [`crate::gpu::adapter_caveat`]: set when the run was on OpenGL, whose maps are not
    /// a Vulkan device's.
    pub adapter_caveat: Option<String>,
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
    /// The process's peak resident memory, bytes (a cluster run: the largest task's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host_memory_peak: Option<u64>,
    /// The batches each stage ran its views in (1: every view held at once).
    pub batches: usize,
    /// The device budget the run planned with, bytes (`None`: unknown).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_budget: Option<u64>,
    /// The step a resumed run continued from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resumed_at_step: Option<usize>,
}

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
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

/// Runs the method over `scene` (loaded at the processed size, restricted to
/// `options.record.views` in that order; its pixels, or `images` to decode each view when a
/// batch needs it) and writes the outputs. A run that cannot start (a view that alone does
/// not fit the device, a bad parameter) writes nothing.
pub fn run(
    ctx: &GpuContext,
    scene: &Scene,
    images: Option<DecodeView>,
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
    #[cfg(not(feature = "rerun"))]
    if options.rerun.is_some() {
        return Err(RunError::Invalid(
            "--rerun needs mvscope built with the `rerun` feature (cargo build --features rerun)"
                .into(),
        ));
    }
    let method = record.method;
    // The session first: a run that does not fit stops before it writes anything.
    let mut session = Session::with_options(
        ctx,
        Arc::new(AcmhPipelines::new(ctx)?),
        scene,
        record.params.clone(),
        method,
        SessionOptions {
            device_budget: options.memory.device_budget,
            max_batch: options.memory.max_batch,
            images: images.clone(),
            ..SessionOptions::default()
        },
    )?;
    // A stage's views one action at a time, submitted together (same maps).
    session.set_batch()?;
    let batched = session.is_batched();

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

    // The work folder: the states between stages when they do not fit in memory, and the
    // resume points (a batched run's every batch; a resident run's stage ends, at most once
    // per interval).
    let work = work_folder(out);
    let state_bytes: u64 = scene
        .views
        .iter()
        .map(|v| v.image.width as u64 * v.image.height as u64 * STORE_BYTES_PER_PIXEL)
        .sum();
    let host_budget = options
        .memory
        .host_budget
        .or_else(|| crate::acmm::memory::host_available_memory().map(|m| m / 2));
    let disk_only = host_budget.is_some_and(|b| state_bytes > b);
    let stamp = crate::cluster::Stamp::of(record);
    session.set_work_folder(
        work.clone(),
        format!(
            "{}|{}|{}|{}",
            stamp.params,
            stamp.seed,
            stamp.scene,
            env!("CARGO_PKG_VERSION")
        ),
        true,
        disk_only,
        options.memory.checkpoint_interval,
    )?;
    let mut resumed_at = None;
    if options.resume && done.len() < scene.views.len() {
        resumed_at = session.resume()?;
    }

    let all_done = done.len() == scene.views.len();
    let mut resumed = Vec::new();
    if all_done {
        session.restrict_views(&[]).ok();
        resumed = done.clone();
    } else if resumed_at.is_none() && !done.is_empty() && !method.couples_views() {
        let todo: Vec<usize> = (0..scene.views.len())
            .filter(|v| !done.contains(v))
            .collect();
        session.restrict_views(&todo)?;
        resumed = done.clone();
    } else if resumed_at.is_some() {
        // Views whose maps were written before the run stopped.
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

    // The session, writing each view's maps as soon as they are final (kept in memory for
    // fusion only when every view is held at once: a batched run fuses from the files).
    let keep_finals = !batched && scene.views.iter().all(|v| !v.image.rgb.is_empty());
    let mut finals: Vec<Option<FinalMaps>> = (0..scene.views.len()).map(|_| None).collect();
    let mut stages: Vec<StageTiming> = Vec::new();
    let session_started = Instant::now();
    let mut stage_started = Instant::now();
    let total = session.schedule().len();
    let final_steps = session.final_steps();
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
                    if final_steps.get(view) == Some(&Some(i))
                        && let Some(maps) = session.planes_and_costs(view)?
                    {
                        let f = final_from_session(scene, view, maps);
                        let v = &scene.views[view];
                        write_final(out, record.views[view], &f, v.image.width, v.image.height)?;
                        if keep_finals {
                            finals[view] = Some(f);
                        }
                    }
                }
                if batch.stage_ended {
                    // The stage's work is queued, not necessarily done: wait for it, or a
                    // fast GPU charges every stage's time to the last one (seen on an H200).
                    ctx.finish()?;
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
    let batches = session.batch_plan().batches.len();
    let device_memory_peak = session.batch_plan().peak;
    let device_budget = session.batch_plan().budget;
    drop(session);

    // Each depth's confidence (its agreeing sources), beside the maps.
    progress(RunEvent::Phase("confidence"));
    create_dir(&out.join("confidence"))?;
    if keep_finals && resumed.is_empty() && finals.iter().all(Option::is_some) {
        let depths: Vec<Vec<f32>> = finals.iter().flatten().map(|f| f.depth.clone()).collect();
        let normals: Vec<Vec<[f32; 3]>> = finals
            .iter()
            .flatten()
            .map(|f| f.normal_camera.clone())
            .collect();
        let counts = crate::fusion::confidence(
            &FusionInput {
                scene,
                depths: &depths,
                normals: &normals,
            },
            &record.params,
        )?;
        for (v, c) in counts.into_iter().enumerate() {
            write_confidence(scene, out, record.views[v], v, &c)?;
        }
    } else {
        confidence_from_files(scene, out, &record.params, &record.views)?;
    }

    let fusion_started = Instant::now();
    // In memory when the session held every view and the scene its pixels; else from the
    // written maps, a view and its sources at a time (the same cloud, point for point).
    let in_memory =
        !batched && resumed_at.is_none() && scene.views.iter().all(|v| !v.image.rgb.is_empty());
    let cloud = if in_memory {
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
        fuse_and_export(scene, &finals, options, progress)?
    } else {
        fuse_from_files(scene, images.as_ref(), options, progress)?
    };
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
        adapter_caveat: ctx.caveat(),
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
        device_memory_peak,
        cost_evaluations,
        session_ms,
        fusion_ms,
        fused_points: cloud.as_ref().map(Vec::len),
        total_ms: started.elapsed().as_secs_f64() * 1e3,
        tasks: None,
        host_memory_peak: crate::cluster::peak_resident_bytes(),
        batches,
        device_budget,
        resumed_at_step: resumed_at,
    };
    let json =
        serde_json::to_string_pretty(&report).map_err(|e| RunError::Invalid(e.to_string()))?;
    write_atomic(&out.join("report.json"), |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    if !options.memory.keep_work {
        let _ = std::fs::remove_dir_all(&work);
    }
    Ok(report)
}

/// Writes view `v`'s confidence (`index` in the run's numbering) as `confidence/%08d.pfm`.
fn write_confidence(
    scene: &Scene,
    out: &Path,
    index: usize,
    v: usize,
    counts: &[u8],
) -> Result<(), RunError> {
    let i = &scene.views[v].image;
    let map = Map::from_data(
        i.width,
        i.height,
        1,
        counts.iter().map(|&c| f32::from(c)).collect(),
    )
    .map_err(|e| RunError::Invalid(e.to_string()))?;
    write_pfm(&view_file(out, "confidence", index), &map)?;
    Ok(())
}

/// Every view's confidence from the written maps, a view and its sources at a time
/// (`mvscope fuse` again, a batched or resumed run).
pub fn confidence_from_files(
    scene: &Scene,
    out: &Path,
    params: &Params,
    indices: &[usize],
) -> Result<(), RunError> {
    create_dir(&out.join("confidence"))?;
    let mut load = |views: &[usize]| -> Result<Vec<crate::fusion::LoadedView>, FusionError> {
        views
            .iter()
            .map(|&v| {
                let f = final_from_disk(scene, v, out, indices[v])
                    .map_err(|e| FusionError::Load(e.to_string()))?;
                Ok(crate::fusion::LoadedView {
                    depth: f.depth,
                    normal: f.normal_camera,
                    rgb: Vec::new(),
                })
            })
            .collect()
    };
    let mut failed: Option<RunError> = None;
    let result = crate::fusion::confidence_streamed(scene, params, &mut load, &mut |v, counts| {
        write_confidence(scene, out, indices[v], v, &counts).map_err(|e| {
            let message = e.to_string();
            failed = Some(e);
            FusionError::Load(message)
        })
    });
    if let Some(e) = failed {
        return Err(e);
    }
    result?;
    Ok(())
}

/// Decodes the views of `record`'s scene one at a time (as `Scene::load` with `options`
/// decodes them): what a batched run gives its session, which decodes a batch's views only.
pub fn decoder(
    record: &RunRecord,
    options: &crate::scene::LoadOptions,
) -> Result<DecodeView, RunError> {
    let raw = crate::scene::RawScene::read(&record.scene, options)
        .map_err(|e| RunError::Invalid(e.to_string()))?;
    let options = options.clone();
    let indices = record.views.clone();
    Ok(Arc::new(move |v: usize| {
        let i = indices.get(v).copied().unwrap_or(v);
        match raw.views.get(i) {
            Some(view) => view.decode(&options),
            None => Err(crate::scene::SceneError::file(
                &raw.root,
                format!("view {i} is not in the scene"),
            )),
        }
    }))
}

/// Bytes per pixel a batched run keeps of a view between stages: its slim state (planes,
/// costs, flags: 24) and its depths at the last two stages' ends (8).
pub const STORE_BYTES_PER_PIXEL: u64 = 32;

/// Fusion and the other layouts from the written maps: views are read (and their images
/// decoded) a view and its sources at a time, so the host holds no more than that; the
/// other layouts, which are written from every view's maps at once, read them all.
pub(crate) fn fuse_from_files(
    scene: &Scene,
    images: Option<&DecodeView>,
    options: &RunOptions,
    progress: &mut dyn FnMut(RunEvent),
) -> Result<Option<Vec<PlyPoint>>, RunError> {
    let out = &options.out;
    let record = &options.record;
    let rgb = |v: usize| -> Result<Vec<[u8; 3]>, RunError> {
        let image = &scene.views[v].image;
        if !image.rgb.is_empty() {
            return Ok(image.rgb.clone());
        }
        match images {
            Some(decode) => Ok(decode(v).map_err(|e| RunError::Invalid(e.to_string()))?.rgb),
            None => Ok(Vec::new()),
        }
    };
    if options.export_acmm || options.export_colmap {
        let finals: Vec<FinalMaps> = (0..scene.views.len())
            .map(|v| final_from_disk(scene, v, out, record.views[v]))
            .collect::<Result<_, _>>()?;
        let mut with_pixels = scene.clone();
        for v in 0..scene.views.len() {
            if with_pixels.views[v].image.rgb.is_empty()
                && let Some(decode) = images
            {
                with_pixels.views[v].image =
                    decode(v).map_err(|e| RunError::Invalid(e.to_string()))?;
            }
        }
        return fuse_and_export(&with_pixels, &finals, options, progress);
    }
    if !options.fuse {
        return Ok(None);
    }
    progress(RunEvent::Phase("fusing"));
    let mut load = |views: &[usize]| -> Result<Vec<crate::fusion::LoadedView>, FusionError> {
        views
            .iter()
            .map(|&v| {
                let failed = |e: RunError| FusionError::Load(e.to_string());
                let f = final_from_disk(scene, v, out, record.views[v]).map_err(failed)?;
                Ok(crate::fusion::LoadedView {
                    depth: f.depth,
                    normal: f.normal_camera,
                    rgb: rgb(v).map_err(failed)?,
                })
            })
            .collect()
    };
    let fused = crate::fusion::fuse_streamed(scene, &record.params, &mut load)?;
    write_ply(&out.join("fused.ply"), &fused.points)?;
    Ok(Some(fused.points))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record written before a method's own options became defaults (no `record_format`)
    /// is read as its run ran: Regions with its options on, though its params say off. A
    /// record of format 1 is read as written, an option turned off included; a params file
    /// given to `--params` reads the same way.
    #[test]
    fn a_record_of_format_0_is_read_as_its_run_ran() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("params.toml");
        let mut record = RunRecord {
            mvscope_version: "0.1.0".into(),
            record_format: RunRecord::FORMAT,
            method: Method::Regions,
            scene: dir.path().to_path_buf(),
            format: None,
            max_image_size: None,
            model: None,
            depth_range: None,
            views: vec![0, 1],
            params: Params {
                prior_confidence_score: false,
                ..Method::Regions.defaults()
            },
        };
        std::fs::write(&path, toml::to_string(&record).unwrap()).unwrap();
        assert_eq!(RunRecord::read(&path).unwrap(), record);
        assert!(
            !Params::from_toml_file(&path)
                .unwrap()
                .prior_confidence_score
        );
        // Format 0: written without the field, the options as the user gave them (off).
        record.params = Params::default();
        // (and without the parameters that came later)
        let text = toml::to_string(&record)
            .unwrap()
            .replace("record_format = 1\n", "")
            .replace("prior_flat_ramp = false\n", "")
            .replace("prior_keep_unseen = false\n", "")
            .replace("prior_region_cover_seen = false\n", "");
        assert!(!text.contains("record_format") && !text.contains("prior_flat_ramp"));
        assert!(!text.contains("prior_keep_unseen"));
        std::fs::write(&path, text).unwrap();
        let read = RunRecord::read(&path).unwrap();
        // The four options the session forced then; `prior_flat_ramp`, `prior_extend`,
        // `prior_keep_unseen`, `prior_region_cover_seen`, the adaptive kernel,
        // `prior_region_edge`, `prior_flat_noise` and the cover band, Regions' own later,
        // stay as written.
        let ran = Params {
            prior_flat_ramp: false,
            prior_extend: false,
            prior_keep_unseen: false,
            prior_region_cover_seen: false,
            prior_region_edge: false,
            prior_flat_noise: false,
            prior_region_cover_band: 0.0,
            bilateral_kernel: crate::acmm::params::BilateralKernel::Laplacian,
            ..Method::Regions.defaults()
        };
        assert_eq!(read.params, ran);
        assert_eq!(read.record_format, RunRecord::FORMAT);
        assert_eq!(Params::from_toml_file(&path).unwrap(), ran);
        // Another method's old record is read as written.
        record.method = Method::Acmmp;
        let text = toml::to_string(&record)
            .unwrap()
            .replace("record_format = 1\n", "");
        std::fs::write(&path, text).unwrap();
        assert_eq!(RunRecord::read(&path).unwrap().params, Params::default());
    }
}
