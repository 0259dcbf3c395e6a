//! Scale-out: a run as units of work over a shared work folder (`mvscope plan`, `mvscope
//! task`), for Slurm job arrays or Kubernetes Indexed Jobs.
//!
//! The schedule is a chain of stages (the Session's); each stage is a map over reference
//! views with a barrier, because a geometric pass reads the previous stage's depth of every
//! source. A **unit** is one stage of one chunk of views: it loads only its views and their
//! sources (`LoadOptions::decode_only`), runs a [`Session::for_part`] from the states the
//! previous stage's units handed off, and writes its views' states (or, at the last stage,
//! their final maps) into the folder. The fusion unit then fuses the final maps. The folder
//! ends up holding what `mvscope run` writes, the maps byte for byte.
//!
//! Every file is written atomically; a unit whose marker (`tasks/SS-CCC.json`) exists is
//! skipped, so a resubmitted chain continues where it stopped; a unit that finds its inputs
//! missing, or written by another plan (other parameters, seed or scene), stops and says
//! which.
//!
//! [`Session::for_part`]: crate::session::Session::for_part

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::acmm::memory::MemoryPlan;
use crate::acmm::multiscale::pyramid_scales;
use crate::io::{IoError, write_atomic};
use crate::pipeline::{RunError, RunRecord};
use crate::scene::{DepthRange, LoadOptions, Scene};
use crate::session::build_schedule;

pub mod scripts;
mod unit;

pub use unit::{UnitOutcome, fuse_unit, peak_resident_bytes, run_unit};

/// The plan's file in the work folder.
pub const PLAN_FILE: &str = "plan.json";

#[derive(Debug, thiserror::Error)]
pub enum ClusterError {
    #[error(transparent)]
    Run(#[from] RunError),
    #[error(transparent)]
    Io(#[from] IoError),
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    #[error(transparent)]
    Session(#[from] crate::session::SessionError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error(transparent)]
    Fusion(#[from] crate::fusion::FusionError),
    #[error(transparent)]
    Export(#[from] crate::export::ExportError),
    #[error("{0}")]
    Invalid(String),
}

/// What a plan's outputs are stamped with, so a unit knows files of another plan: the
/// parameters (without the seed), the seed, and the scene (its path, how it was read, the
/// views run).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stamp {
    pub params: String,
    pub seed: u64,
    pub scene: String,
}

impl Stamp {
    pub fn of(record: &RunRecord) -> Stamp {
        let mut params = record.params.clone();
        params.seed = 0;
        let params_text = format!(
            "{}\n{}",
            record.method,
            toml::to_string(&params).unwrap_or_default()
        );
        let scene_text = format!(
            "{}|{:?}|{:?}|{:?}|{:?}|{:?}",
            record.scene.display(),
            record.format,
            record.max_image_size,
            record.model,
            record.depth_range,
            record.views
        );
        Stamp {
            params: format!("{:016x}", fnv1a(params_text.as_bytes())),
            seed: record.params.seed,
            scene: format!("{:016x}", fnv1a(scene_text.as_bytes())),
        }
    }

    /// What differs from `other`, in words ("the parameters and the seed"); `None` if
    /// nothing does.
    pub fn differences(&self, other: &Stamp) -> Option<String> {
        let mut what = Vec::new();
        if self.params != other.params {
            what.push("the parameters");
        }
        if self.seed != other.seed {
            what.push("the seed");
        }
        if self.scene != other.scene {
            what.push("the scene (its path, loading options or views)");
        }
        (!what.is_empty()).then(|| what.join(" and "))
    }
}

/// FNV-1a, 64 bits: a stable fingerprint (the same on every machine and build).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A stage of the plan.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlannedStage {
    /// Pyramid level (0 = coarsest).
    pub level: u32,
    /// "photometric", "upsample + restorer", "planar prior", "geometric 1", ...
    pub name: String,
    /// Whether its passes read the sources' depths (its units need their sources' states).
    pub reads_sources: bool,
}

/// A chunk: the views one task of each stage estimates, and the views it holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Chunk {
    /// The views it estimates (indices in the run's scene, as the maps are numbered).
    pub views: Vec<usize>,
    /// Those views and their sources (indices in the run's scene): what it loads.
    pub holds: Vec<usize>,
    /// Host bytes of the images it decodes (colour and intensity at the processed size).
    pub host_bytes: u64,
    /// Device bytes at its peak (the memory plan of its views and sources).
    pub device_bytes: u64,
}

/// How a plan splits the views into chunks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Split {
    /// This many tasks per stage (chunks of about equal size).
    Tasks(usize),
    /// Chunks that each fit this much device memory (bytes): as many tasks as that takes.
    DeviceMemory(u64),
}

/// `plan.json`: how a run is split into units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    pub mvscope_version: String,
    /// What `params.toml` records (the same file `mvscope run` writes).
    pub record: RunRecord,
    pub stamp: Stamp,
    /// The longest image side of the run's scene (sets the pyramid of every part).
    pub long_side: u32,
    pub stages: Vec<PlannedStage>,
    pub chunks: Vec<Chunk>,
    pub fuse: bool,
    pub export_acmm: bool,
    pub export_colmap: bool,
}

/// Loading options of a run's scene (`decode_only`: the views whose pixels are wanted, in
/// the run's numbering).
pub(crate) fn load_options(
    record: &RunRecord,
    dir: &Path,
    decode_only: Option<&[usize]>,
) -> Result<LoadOptions, ClusterError> {
    Ok(LoadOptions {
        format: record.format,
        max_image_size: record.max_image_size,
        depth_range: match record.depth_range {
            Some([a, b]) => Some(DepthRange::new(a, b).map_err(ClusterError::Invalid)?),
            None => None,
        },
        model: record.model,
        undistort_cache: Some(dir.join("undistorted")),
        decode_only: decode_only.map(|d| d.iter().map(|&v| record.views[v]).collect()),
    })
}

impl Plan {
    /// Splits the run `record` of `scene` (loaded for the record, its images decoded or
    /// not) into chunks of views that share sources, as a batched run on one machine does
    /// (`crate::acmm::memory::group_views`): `split` says how many, or how large. Needs no
    /// GPU: a login node plans.
    pub fn new(
        record: RunRecord,
        scene: &Scene,
        split: Split,
        fuse: bool,
        export_acmm: bool,
        export_colmap: bool,
    ) -> Result<Plan, ClusterError> {
        if split == Split::Tasks(0) {
            return Err(ClusterError::Invalid("--tasks must be at least 1".into()));
        }
        record
            .params
            .validate()
            .map_err(|e| ClusterError::Invalid(format!("parameter {e}")))?;
        let method = record.method;
        let params = &record.params;
        let long_side = scene.long_side();
        let levels = pyramid_scales(params, method, long_side).len() as u32;
        let estimated: Vec<usize> = (0..scene.views.len())
            .filter(|&v| !scene.views[v].sources.is_empty())
            .collect();
        let mut stages: Vec<PlannedStage> = Vec::new();
        for s in build_schedule(method, params, &estimated, levels) {
            let name = crate::pipeline::stage_name(s.stage);
            if stages
                .last()
                .is_none_or(|l| (l.level, l.name.as_str()) != (s.level, name.as_str()))
            {
                stages.push(PlannedStage {
                    level: s.level,
                    name,
                    reads_sources: s.stage.reads_sources(params),
                });
            }
        }
        let shapes = crate::acmm::memory::ViewShape::of_scene(scene);
        let groups = match split {
            Split::Tasks(tasks) => {
                let per = estimated.len().div_ceil(tasks.max(1)).max(1);
                crate::acmm::memory::group_views(&shapes, &|b| b.len() <= per)
            }
            Split::DeviceMemory(bytes) => {
                // A node's adapter is not known here: WebGPU's default limits stand for it.
                let adapter = wgpu::Limits::default();
                let limits = crate::acmm::memory::Limits {
                    adapter: &adapter,
                    budget: Some(bytes),
                };
                crate::acmm::memory::BatchPlan::new(&shapes, params, method, long_side, &limits)
                    .map_err(|e| ClusterError::Invalid(format!("--device-memory: {e}")))?
                    .batches
            }
        };
        let mut chunks = Vec::with_capacity(groups.len());
        for mut views in groups {
            // Each chunk's views in scene order (the maps do not depend on it).
            views.sort_unstable();
            let mut holds = views.clone();
            for &v in &views {
                holds.extend(scene.views[v].sources.iter().map(|s| s.index));
            }
            holds.sort_unstable();
            holds.dedup();
            let host_bytes = holds
                .iter()
                .map(|&v| {
                    let i = &scene.views[v].image;
                    // Colour (3 bytes) and intensity (4) per pixel.
                    i.width as u64 * i.height as u64 * 7
                })
                .sum();
            let part = scene.subset(&holds)?;
            let device_bytes = MemoryPlan::for_scene(&part, params, method).peak();
            chunks.push(Chunk {
                views,
                holds,
                host_bytes,
                device_bytes,
            });
        }
        Ok(Plan {
            mvscope_version: env!("CARGO_PKG_VERSION").to_string(),
            stamp: Stamp::of(&record),
            record,
            long_side,
            stages,
            chunks,
            fuse,
            export_acmm,
            export_colmap,
        })
    }

    /// Writes `plan.json` and `params.toml` into `dir` (atomically), refusing a folder that
    /// holds another plan's results.
    pub fn write(&self, dir: &Path) -> Result<(), ClusterError> {
        std::fs::create_dir_all(dir).map_err(|e| IoError::io(dir, "create the folder", e))?;
        let path = dir.join(PLAN_FILE);
        if path.is_file() {
            let old = Plan::read(dir)?;
            if let Some(what) = old.stamp.differences(&self.stamp)
                && (dir.join("stages").exists() || dir.join("tasks").exists())
            {
                return Err(ClusterError::Invalid(format!(
                    "{} holds the results of another plan ({what} differ): plan into another folder, or remove its stages/ and tasks/ to start over",
                    dir.display()
                )));
            }
        }
        let json =
            serde_json::to_string_pretty(self).map_err(|e| ClusterError::Invalid(e.to_string()))?;
        write_atomic(&path, |w| std::io::Write::write_all(w, json.as_bytes()))?;
        let toml =
            toml::to_string(&self.record).map_err(|e| ClusterError::Invalid(e.to_string()))?;
        write_atomic(&dir.join("params.toml"), |w| {
            std::io::Write::write_all(w, toml.as_bytes())
        })?;
        Ok(())
    }

    pub fn read(dir: &Path) -> Result<Plan, ClusterError> {
        let path = dir.join(PLAN_FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            ClusterError::Invalid(format!(
                "{}: cannot read the plan ({e}); run `mvscope plan SCENE --out {}` first",
                path.display(),
                dir.display()
            ))
        })?;
        serde_json::from_str(&text).map_err(|e| {
            ClusterError::Invalid(format!(
                "{}: not a plan written by mvscope plan ({e})",
                path.display()
            ))
        })
    }

    /// The unit's marker file: written last, when all its outputs are in place.
    pub fn marker(dir: &Path, stage: usize, chunk: usize) -> PathBuf {
        dir.join("tasks")
            .join(format!("{stage:02}-{chunk:03}.json"))
    }

    /// A view's state at the end of `stage` (`view` in the run's numbering).
    pub fn state_file(&self, dir: &Path, stage: usize, view: usize) -> PathBuf {
        dir.join("stages")
            .join(format!("{stage:02}"))
            .join(format!("{:08}.state", self.record.views[view]))
    }

    /// The fusion unit's marker.
    pub fn fuse_marker(dir: &Path) -> PathBuf {
        dir.join("tasks").join("fuse.json")
    }

    /// The largest task's host and device bytes.
    pub fn peak_task_bytes(&self) -> (u64, u64) {
        self.chunks.iter().fold((0, 0), |(h, d), c| {
            (h.max(c.host_bytes), d.max(c.device_bytes))
        })
    }
}
