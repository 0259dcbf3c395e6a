//! A scene larger than the device: each stage streams its views through it in batches
//! (`crate::acmm::memory::BatchPlan`), and the states of the views off the device wait on the
//! host, in memory or in a work folder.
//!
//! **What moves.** When a stage reaches a view of another batch, the batch on the device is
//! *parked*: its views' states are read back into the [`HostStore`] (with the depth each ended
//! the stage with), and their buffers, images and depth snapshot freed. The next batch is
//! *loaded*: the intensities of its views and their sources at the stage's level (decoded per
//! batch when the scene holds no pixels), the sources' depths as the previous stage left them
//! (the snapshot rule: a stage reads only the stage before), and its views' states. A state
//! from the level before (a level's first stage) puts its planes where the upsampling reads
//! them. So a batch computes exactly what the whole scene held at once computes, which tests
//! check byte for byte.
//!
//! **What a state keeps.** Everything the viewer shows, or (`slim`, batch runs) only what a
//! later stage reads: the planes, the costs and the flags (the winner and the most important
//! view v_t), and with Regions' `prior_region_hold` the prior planes, which its geometric
//! passes read; view selections, weights, the extra maps and (otherwise) the prior planes are
//! made anew by the pass that reads them.
//!
//! **Resuming.** With a work folder, a parked state is written there (atomically, one file per
//! view and stage, its depth beside it) and a manifest names the step the run stood at and the
//! files it needs; superseded files go only after the manifest that replaces them. A run that
//! holds every view writes its states at a stage's end, at most once per interval. A killed
//! run then resumes from the last manifest, exactly.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::handoff::depth_of_planes;
use super::*;
use crate::acmm::memory::BatchPlan;
use crate::image::Image;
use crate::io::write_atomic;
use crate::scene::SceneError;

/// A view's decoded image at the processed size (what `Scene::load` gives), by scene index:
/// where a session takes images its scene does not hold (a batch run decodes per batch).
pub type DecodeView = Arc<dyn Fn(usize) -> Result<Image, SceneError> + Send + Sync>;

/// What a session is given besides its scene, parameters and method.
#[derive(Clone, Default)]
pub struct SessionOptions {
    /// The scene is a part of a larger one (see [`Session::for_part`]).
    pub part: Option<Part>,
    /// Device memory the session may hold, bytes (`None`: what
    /// `crate::acmm::memory::default_budget` knows of the device).
    pub device_budget: Option<u64>,
    /// Batches of at most this many views, even when every view would fit (tests and
    /// benchmarks comparing the two).
    pub max_batch: Option<usize>,
    /// Decodes a view's image when the scene holds no pixels for it.
    pub images: Option<DecodeView>,
}

/// A view's depth at the end of a stage: what the next stage's sources read.
#[derive(Clone, Debug)]
pub(super) struct StageDepth {
    pub(super) stage: usize,
    pub(super) level: u32,
    pub(super) depth: Arc<Vec<f32>>,
}

/// The states of the views off the device, and the depths the views ended their last stages
/// with.
#[derive(Default)]
pub(super) struct HostStore {
    /// Each view's parked state and the stage it ended (`None`: on the device, or not begun).
    states: Vec<Option<(usize, Arc<HandoffView>)>>,
    /// Each view's depths at the end of its last two stages, newest last.
    depths: Vec<Vec<StageDepth>>,
    /// Keep only what later stages read (the states come so from `Session::read_state`).
    pub(super) slim: bool,
    /// The work folder the states are written to (resume points).
    pub(super) folder: Option<WorkFolder>,
    /// Views parked since the manifest was last written.
    dirty: Vec<bool>,
}

/// Where a run keeps its states on disk.
pub(super) struct WorkFolder {
    pub(super) dir: PathBuf,
    /// Names the run: a manifest of another run is never resumed.
    pub(super) stamp: String,
    /// States are read back from disk instead of kept in memory too.
    pub(super) disk_only: bool,
    /// The shortest time between two manifests of a run holding every view.
    pub(super) interval: std::time::Duration,
    pub(super) last_written: web_time::Instant,
    /// The files the last manifest named (removed when a newer one no longer names them).
    named: Vec<PathBuf>,
}

/// The manifest: the step a run stood at and, per view, the files of its state and depths.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Manifest {
    stamp: String,
    /// The first step not yet run.
    cursor: usize,
    steps: usize,
    /// Per view: the stage its state ended (and whether it is slim), and the stages of its
    /// depths.
    views: Vec<ManifestView>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct ManifestView {
    state: Option<usize>,
    depths: Vec<(usize, u32)>,
}

const MANIFEST: &str = "manifest.json";

impl WorkFolder {
    fn state_file(&self, view: usize, stage: usize) -> PathBuf {
        self.dir
            .join("stages")
            .join(format!("{stage:02}"))
            .join(format!("{view:08}.state"))
    }

    fn depth_file(&self, view: usize, stage: usize) -> PathBuf {
        self.dir
            .join("stages")
            .join(format!("{stage:02}"))
            .join(format!("{view:08}.depth"))
    }
}

fn io(path: &Path, what: &str, e: impl std::fmt::Display) -> SessionError {
    SessionError::State(format!("{}: cannot {what}: {e}", path.display()))
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), SessionError> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| io(parent, "create the folder", e))?;
    }
    write_atomic(path, |w| std::io::Write::write_all(w, bytes))
        .map_err(|e| SessionError::State(e.to_string()))
}

/// A depth file: level, then the values (little-endian).
fn depth_bytes(level: u32, depth: &[f32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 + depth.len() * 4);
    out.extend_from_slice(&level.to_le_bytes());
    out.extend_from_slice(bytemuck::cast_slice(depth));
    out
}

fn read_depth_file(path: &Path, stage: usize) -> Result<StageDepth, SessionError> {
    let bytes = std::fs::read(path).map_err(|e| io(path, "read the depth", e))?;
    if bytes.len() < 4 || bytes.len() % 4 != 0 {
        return Err(SessionError::State(format!(
            "{}: not a depth file of the work folder ({} bytes); remove the work folder to start over",
            path.display(),
            bytes.len()
        )));
    }
    let level = u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
    Ok(StageDepth {
        stage,
        level,
        depth: Arc::new(bytemuck::pod_collect_to_vec(&bytes[4..])),
    })
}

impl HostStore {
    pub(super) fn new(views: usize) -> HostStore {
        HostStore {
            states: vec![None; views],
            depths: vec![Vec::new(); views],
            slim: false,
            folder: None,
            dirty: vec![false; views],
        }
    }

    /// Forgets every state and depth (a restart; the work folder's files stay until a new
    /// manifest replaces them).
    pub(super) fn clear(&mut self) {
        let n = self.states.len();
        self.states = vec![None; n];
        self.depths = vec![Vec::new(); n];
        self.dirty = vec![false; n];
    }

    pub(super) fn has_states(&self) -> bool {
        self.states.iter().any(Option::is_some)
    }

    /// View `view`'s parked state (read from the work folder when not kept in memory).
    pub(super) fn state(&self, view: usize) -> Result<Option<Arc<HandoffView>>, SessionError> {
        let Some((stage, state)) = self.states.get(view).and_then(Option::as_ref) else {
            return Ok(None);
        };
        if !state.buffers.is_empty() {
            return Ok(Some(state.clone()));
        }
        // On disk only: the entry holds the header, the file the bytes.
        let Some(folder) = &self.folder else {
            return Ok(None);
        };
        let path = folder.state_file(view, *stage);
        let bytes = std::fs::read(&path).map_err(|e| io(&path, "read the state", e))?;
        HandoffView::from_bytes(&bytes)
            .map(|s| Some(Arc::new(s)))
            .map_err(|m| {
                SessionError::State(format!(
                    "{}: {m}; remove the work folder to start over",
                    path.display()
                ))
            })
    }

    /// Parks `view`'s state as stage `stage` ended it (and keeps the depth it ended with).
    pub(super) fn put(
        &mut self,
        view: usize,
        stage: usize,
        state: HandoffView,
    ) -> Result<(), SessionError> {
        let plane = state.buffers.first().map(Vec::as_slice).unwrap_or(&[]);
        let depth = Arc::new(depth_of_planes(plane, state.width, state.height));
        self.put_depth(
            view,
            StageDepth {
                stage,
                level: state.level,
                depth,
            },
        );
        let mut kept = state;
        if let Some(folder) = &self.folder {
            write_file(&folder.state_file(view, stage), &kept.to_bytes())?;
            if let Some(d) = self.depths[view].last_mut() {
                write_file(
                    &folder.depth_file(view, stage),
                    &depth_bytes(d.level, &d.depth),
                )?;
                if folder.disk_only {
                    // Read back from the file when a batch needs it.
                    d.depth = Arc::new(Vec::new());
                }
            }
            if folder.disk_only {
                kept.buffers = Vec::new();
            }
        }
        self.states[view] = Some((stage, Arc::new(kept)));
        self.dirty[view] = true;
        Ok(())
    }

    fn put_depth(&mut self, view: usize, d: StageDepth) {
        let list = &mut self.depths[view];
        list.retain(|x| x.stage != d.stage);
        list.push(d);
        list.sort_by_key(|x| x.stage);
        while list.len() > 2 {
            list.remove(0);
        }
    }

    /// `view`'s depth at the end of stage `stage`, if kept (read from the work folder when
    /// the store keeps it on disk only).
    pub(super) fn depth(
        &self,
        view: usize,
        stage: usize,
    ) -> Result<Option<StageDepth>, SessionError> {
        let Some(d) = self
            .depths
            .get(view)
            .and_then(|l| l.iter().find(|d| d.stage == stage))
        else {
            return Ok(None);
        };
        match &self.folder {
            Some(folder) if d.depth.is_empty() => {
                read_depth_file(&folder.depth_file(view, stage), stage).map(Some)
            }
            _ => Ok(Some(d.clone())),
        }
    }

    /// Takes `view`'s state off the store (it goes onto the device).
    pub(super) fn take(&mut self, view: usize) -> Result<Option<HandoffView>, SessionError> {
        let state = self.state(view)?;
        if let Some(slot) = self.states.get_mut(view) {
            *slot = None;
        }
        Ok(state.map(Arc::unwrap_or_clone))
    }

    /// Writes the manifest of a run standing at `cursor` of `steps` (when the work folder
    /// keeps one), then removes the files the previous manifest named and this one does not.
    pub(super) fn write_manifest(
        &mut self,
        cursor: usize,
        steps: usize,
    ) -> Result<(), SessionError> {
        let Some(folder) = &mut self.folder else {
            return Ok(());
        };
        let mut named = Vec::new();
        let views = (0..self.states.len())
            .map(|v| {
                let state = self.states[v].as_ref().map(|(k, _)| *k);
                if let Some(k) = state {
                    named.push(folder.state_file(v, k));
                }
                let depths: Vec<(usize, u32)> =
                    self.depths[v].iter().map(|d| (d.stage, d.level)).collect();
                for &(k, _) in &depths {
                    named.push(folder.depth_file(v, k));
                }
                ManifestView { state, depths }
            })
            .collect();
        let manifest = Manifest {
            stamp: folder.stamp.clone(),
            cursor,
            steps,
            views,
        };
        let json = serde_json::to_string(&manifest)
            .map_err(|e| SessionError::State(format!("the work folder's manifest: {e}")))?;
        write_file(&folder.dir.join(MANIFEST), json.as_bytes())?;
        for old in std::mem::replace(&mut folder.named, named.clone()) {
            if !named.contains(&old) {
                let _ = std::fs::remove_file(&old);
            }
        }
        folder.last_written = web_time::Instant::now();
        self.dirty.fill(false);
        Ok(())
    }

    /// Writes the states (and depths) a resident run holds on the device now, as stage
    /// `stage` ended them, to the work folder.
    fn put_all(
        &mut self,
        states: Vec<(usize, HandoffView)>,
        stage: usize,
    ) -> Result<(), SessionError> {
        for (v, s) in states {
            self.put(v, stage, s)?;
            // The device holds them; the store keeps only the files' names.
            if let Some(Some((_, st))) = self.states.get_mut(v) {
                Arc::make_mut(st).buffers = Vec::new();
            }
        }
        Ok(())
    }

    /// Reads the manifest in `dir` (if it is this run's, `stamp`) into the store, keeping the
    /// states on disk: the step to resume from.
    fn read_manifest(&mut self, views: usize) -> Result<Option<usize>, SessionError> {
        let Some(folder) = &mut self.folder else {
            return Ok(None);
        };
        let path = folder.dir.join(MANIFEST);
        let Ok(text) = std::fs::read_to_string(&path) else {
            return Ok(None);
        };
        let m: Manifest = serde_json::from_str(&text).map_err(|e| {
            SessionError::State(format!(
                "{}: not a manifest of mvscope's work folder ({e}); remove the folder to start over",
                path.display()
            ))
        })?;
        if m.stamp != folder.stamp || m.views.len() != views {
            return Err(SessionError::State(format!(
                "{} holds the states of another run (other parameters, seed, scene or build); remove it, or run without --resume, to start over",
                folder.dir.display()
            )));
        }
        let mut named = Vec::new();
        for (v, mv) in m.views.iter().enumerate() {
            if let Some(k) = mv.state {
                let file = folder.state_file(v, k);
                let bytes = std::fs::read(&file).map_err(|e| io(&file, "read the state", e))?;
                let mut state = HandoffView::from_bytes(&bytes).map_err(|msg| {
                    SessionError::State(format!(
                        "{}: {msg}; remove the work folder to start over",
                        file.display()
                    ))
                })?;
                named.push(file);
                if folder.disk_only {
                    state.buffers = Vec::new();
                }
                self.states[v] = Some((k, Arc::new(state)));
            }
            for &(k, level) in &mv.depths {
                let file = folder.depth_file(v, k);
                let depth = if folder.disk_only {
                    StageDepth {
                        stage: k,
                        level,
                        depth: Arc::new(Vec::new()),
                    }
                } else {
                    read_depth_file(&file, k)?
                };
                self.depths[v].push(depth);
                named.push(file);
            }
        }
        folder.named = named;
        Ok(Some(m.cursor))
    }
}

impl Session {
    /// How the session holds its views: all at once, or in batches.
    pub fn batch_plan(&self) -> &BatchPlan {
        &self.plan
    }

    /// Whether each stage streams its views through the device in batches.
    pub fn is_batched(&self) -> bool {
        !self.plan.resident
    }

    /// The index of `step`'s stage in the schedule's order of stages.
    pub(super) fn stage_index(&self, step: &Step) -> usize {
        self.stage_order
            .iter()
            .position(|&s| s == (step.level, step.stage))
            .unwrap_or(0)
    }

    /// Keeps the states in `dir` (created): each parked state is written there, with a
    /// manifest to resume from ([`Session::resume`]); `slim` keeps only what later stages
    /// read; `disk_only` reads them back from disk instead of keeping them in memory too. A
    /// session holding every view writes its states at a stage's end, at most once per
    /// `interval`. Only before the first step.
    pub fn set_work_folder(
        &mut self,
        dir: PathBuf,
        stamp: String,
        slim: bool,
        disk_only: bool,
        interval: std::time::Duration,
    ) -> Result<(), SessionError> {
        if self.cursor != 0 {
            return Err(SessionError::Params(
                "a work folder: only before the first step".into(),
            ));
        }
        std::fs::create_dir_all(&dir).map_err(|e| io(&dir, "create the work folder", e))?;
        self.store.slim = slim;
        self.store.folder = Some(WorkFolder {
            dir,
            stamp,
            disk_only,
            interval,
            last_written: web_time::Instant::now(),
            named: Vec::new(),
        });
        Ok(())
    }

    /// Continues from the work folder's manifest, if it is this run's: the views' states and
    /// depths are taken from it and the cursor set where it stood. Returns the cursor, or
    /// `None` when there is nothing to resume (no manifest). Only before the first step.
    pub fn resume(&mut self) -> Result<Option<usize>, SessionError> {
        if self.cursor != 0 {
            return Err(SessionError::Params(
                "resuming: only before the first step".into(),
            ));
        }
        let views = self.residents.len();
        let Some(cursor) = self.store.read_manifest(views)? else {
            return Ok(None);
        };
        if cursor > self.steps.len() {
            return Err(SessionError::State(format!(
                "the work folder stands at step {cursor} of a schedule of {}; remove it to start over",
                self.steps.len()
            )));
        }
        self.cursor = cursor;
        self.loaded = None;
        self.residents.iter_mut().for_each(|r| *r = None);
        self.level_images = None;
        self.committed_level = cursor
            .checked_sub(1)
            .and_then(|c| self.steps.get(c))
            .map(|s| s.level);
        // The stage before the cursor's ended: its level is the committed one, unless the
        // cursor is inside a stage (batches), whose level it shares.
        if let (Some(prev), Some(next)) = (
            cursor.checked_sub(1).and_then(|c| self.steps.get(c)),
            self.steps.get(cursor),
        ) && (prev.level, prev.stage) == (next.level, next.stage)
        {
            let k = self.stage_index(next);
            self.committed_level = k
                .checked_sub(1)
                .and_then(|p| self.stage_order.get(p))
                .map(|s| s.0);
        }
        self.checkpoints.truncate(1);
        Ok(Some(cursor))
    }

    /// Brings `step`'s batch onto the device before it runs: in a batched session the batch
    /// there is parked and `step`'s loaded; a session holding every view loads them once (at
    /// its start after [`Session::resume`]).
    pub(super) fn ensure_batch(&mut self, step: &Step) -> Result<(), SessionError> {
        let stage = self.stage_index(step);
        let Some(&batch) = self.batch_of.get(step.view).and_then(Option::as_ref) else {
            return Ok(());
        };
        if self.plan.resident {
            if self.loaded.is_none() {
                if self.store.has_states() {
                    self.load(batch, step.level, stage)?;
                }
                self.loaded = Some((batch, step.level, stage));
            }
            return Ok(());
        }
        if self.loaded == Some((batch, step.level, stage)) {
            return Ok(());
        }
        if self.loaded.is_some() {
            self.park()?;
        }
        self.load(batch, step.level, stage)
    }

    /// The views a batch holds: its own and their sources.
    pub(super) fn held_views(&self, batch: usize) -> Vec<usize> {
        let scene = &self.levels[0];
        let mut held: Vec<usize> = self.plan.batches[batch]
            .iter()
            .flat_map(|&v| std::iter::once(v).chain(scene.views[v].sources.iter().map(|s| s.index)))
            .collect();
        held.sort_unstable();
        held.dedup();
        held
    }

    /// The intensities of `view` at `level`: the scene's own (no copy), or decoded (and kept
    /// a while). Read them with [`gray_of`].
    pub(super) fn gray(&mut self, level: u32, view: usize) -> Result<Gray, SessionError> {
        let v = &self.levels[level as usize].views[view];
        if !v.image.gray.is_empty() || v.image.width as usize * v.image.height as usize == 0 {
            return Ok(Gray::Scene);
        }
        if let Some(g) = self.grays.get(level, view) {
            return Ok(Gray::Decoded(g));
        }
        let Some(decode) = &self.decode else {
            return Err(SessionError::State(format!(
                "view {view}: the scene holds no pixels for it and the session was given no way to decode them"
            )));
        };
        let image = decode(view).map_err(|e| SessionError::State(e.to_string()))?;
        let (w, h) = (v.image.width, v.image.height);
        let gray = Arc::new(image.resized(w, h).gray);
        self.grays.put(level, view, gray.clone());
        Ok(Gray::Decoded(gray))
    }

    /// Loads batch `batch` for stage `stage` at `level`: the held views' images and their
    /// depths as the stage before left them, and the batch's views' states.
    fn load(&mut self, batch: usize, level: u32, stage: usize) -> Result<(), SessionError> {
        let held = if self.plan.resident {
            (0..self.residents.len()).collect()
        } else {
            self.held_views(batch)
        };
        self.residents.iter_mut().for_each(|r| *r = None);
        self.level_images = None;
        let mut grays = Vec::with_capacity(held.len());
        for &v in &held {
            grays.push((v, self.gray(level, v)?));
        }
        let scene = &self.levels[level as usize];
        let list: Vec<(usize, u32, u32, &[f32])> = grays
            .iter()
            .map(|(v, g)| {
                let i = &scene.views[*v].image;
                (*v, i.width, i.height, gray_of(&self.levels, level, *v, g))
            })
            .collect();
        let images = LevelImages::upload(&self.ctx, &list, scene.views.len())?;
        // The snapshot this stage reads: every held view's depth at the stage before's end.
        if let Some(before) = stage.checked_sub(1) {
            for &v in &held {
                if let Some(d) = self.store.depth(v, before)?
                    && d.level == level
                {
                    images.write_depth(&self.ctx, v, &d.depth)?;
                }
            }
        }
        self.level_images = Some((level, images));
        let views: Vec<usize> = if self.plan.resident {
            self.estimated.clone()
        } else {
            self.plan.batches[batch].clone()
        };
        for v in views {
            let Some(state) = self.store.take(v)? else {
                continue;
            };
            if state.level == level {
                self.restore_handoff(v, state)?;
            } else if state.level + 1 == level {
                // A level's first stage: the coarse planes are what the upsampling reads.
                self.ensure_resident(v, level)?;
                let plane = state.buffers.first().map(Vec::as_slice).unwrap_or(&[]);
                if let Some(r) = self.residents[v].as_mut() {
                    self.ctx.flush();
                    let size = (plane.len() as u64).min(r.solver.prior.size());
                    self.ctx
                        .queue
                        .write_buffer(&r.solver.prior, 0, &plane[..size as usize]);
                    self.ctx.traffic.add_to_device(size);
                    r.upsample_ready = true;
                }
            } else {
                return Err(SessionError::State(format!(
                    "view {v}: a state at level {} for a stage at level {level}",
                    state.level
                )));
            }
        }
        self.loaded = Some((batch, level, stage));
        Ok(())
    }

    /// Reads the states of the views on the device back into the store (as the loaded stage
    /// ended them) and frees their buffers; in a work folder, writes the manifest.
    pub(super) fn park(&mut self) -> Result<(), SessionError> {
        let Some((_, _, stage)) = self.loaded else {
            return Ok(());
        };
        let views: Vec<usize> = (0..self.residents.len())
            .filter(|&v| self.residents[v].is_some())
            .collect();
        for v in views {
            if let Some(state) = self.read_state(v, self.store.slim)? {
                self.store.put(v, stage, state)?;
            }
        }
        self.residents.iter_mut().for_each(|r| *r = None);
        self.level_images = None;
        self.loaded = None;
        if self.store.folder.as_ref().is_some_and(|f| !f.disk_only) {
            // In memory too: the manifest at most once per interval.
            let due = self
                .store
                .folder
                .as_ref()
                .is_some_and(|f| f.last_written.elapsed() >= f.interval);
            if due {
                self.store.write_manifest(self.cursor, self.steps.len())?;
            }
        } else {
            self.store.write_manifest(self.cursor, self.steps.len())?;
        }
        Ok(())
    }

    /// At the end of stage `step`'s stage in a session holding every view: its states into
    /// the work folder, when one is kept and its interval has passed (or `now`).
    pub(super) fn checkpoint_stage(&mut self, step: &Step, now: bool) -> Result<(), SessionError> {
        let due = self
            .store
            .folder
            .as_ref()
            .is_some_and(|f| now || f.last_written.elapsed() >= f.interval);
        if !due || !self.plan.resident {
            return Ok(());
        }
        let stage = self.stage_index(step);
        let mut states = Vec::new();
        for v in 0..self.residents.len() {
            if let Some(s) = self.read_state(v, self.store.slim)? {
                states.push((v, s));
            }
        }
        self.store.put_all(states, stage)?;
        self.store.write_manifest(self.cursor, self.steps.len())
    }

    /// The prior planes a parked view's state keeps (buffer 6: every state of a run whose
    /// prior holds in its geometric passes), `None` when it keeps none.
    pub(super) fn parked_prior_planes(
        &self,
        view: usize,
    ) -> Result<Option<Vec<[f32; 4]>>, SessionError> {
        let Some(state) = self.store.state(view)? else {
            return Ok(None);
        };
        let n = state.width as usize * state.height as usize;
        Ok(state.buffers.get(6).and_then(|b| b.get(..n * 16)).map(|b| {
            bytemuck::pod_collect_to_vec::<u8, f32>(b)
                .chunks_exact(4)
                .map(|p| [p[0], p[1], p[2], p[3]])
                .collect()
        }))
    }

    /// A parked view's maps, from the store.
    pub(super) fn parked_maps(&self, view: usize) -> Result<Option<ViewMaps>, SessionError> {
        let Some(state) = self.store.state(view)? else {
            return Ok(None);
        };
        let n = state.width as usize * state.height as usize;
        let nsrc = self.levels[0].views[view].sources.len();
        let bytes = |k: usize| state.buffers.get(k).map(Vec::as_slice).unwrap_or(&[]);
        let floats = |k: usize, per: usize, fill: f32| -> Vec<f32> {
            let b = bytes(k);
            if b.len() == n * per * 4 {
                bytemuck::pod_collect_to_vec(b)
            } else {
                vec![fill; n * per]
            }
        };
        let words = |k: usize, fill: u32| -> Vec<u32> {
            let b = bytes(k);
            if b.len() == n * 4 {
                bytemuck::pod_collect_to_vec(b)
            } else {
                vec![fill; n]
            }
        };
        let plane: Vec<[f32; 4]> = floats(0, 4, 0.0)
            .chunks_exact(4)
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect();
        let extra = floats(5, 2, 0.0);
        let replaced = state.replaced.as_ref().and_then(|b| {
            (b.len() == n * 4).then(|| {
                bytemuck::pod_collect_to_vec::<u8, u32>(b)
                    .iter()
                    .map(|a| a & (1 << 16) != 0)
                    .collect()
            })
        });
        Ok(Some(ViewMaps {
            level: state.level,
            state: ViewState {
                width: state.width,
                height: state.height,
                num_sources: nsrc,
                plane,
                cost: floats(1, 1, MAX_COST),
                selected: words(2, 0),
                weights: crate::gpu::acmh::weights_from_layers(&floats(3, nsrc, 0.0), n, nsrc),
                aux: words(4, 0xff | (NO_VIEW << 8)),
            },
            restorer_difference: (state.difference && extra.len() == 2 * n)
                .then(|| extra[..n].to_vec()),
            replaced,
            reprojection_error: (state.reprojection && extra.len() == 2 * n)
                .then(|| extra[n..].to_vec()),
            prior: None,
            anchors: None,
            prior_terms: None,
            support_points: None,
        }))
    }
}

/// A cached decoded image: when it was last used, and its intensities.
type GrayEntry = (u64, Arc<Vec<f32>>);

/// Where a view's intensities are: in the scene itself, or a decoded copy the cache shares.
pub(super) enum Gray {
    Scene,
    Decoded(Arc<Vec<f32>>),
}

/// The intensities `gray` found, borrowed from the scene or from the decoded copy.
pub(super) fn gray_of<'a>(
    levels: &'a [Scene],
    level: u32,
    view: usize,
    gray: &'a Gray,
) -> &'a [f32] {
    match gray {
        Gray::Scene => &levels[level as usize].views[view].image.gray,
        Gray::Decoded(g) => g,
    }
}

/// Decoded intensities kept between batches (neighbouring batches share sources), up to a
/// byte budget, the least recently used dropped first.
#[derive(Default)]
pub(super) struct GrayCache {
    /// (level, view) -> (last use, intensities).
    entries: std::collections::HashMap<(u32, usize), GrayEntry>,
    bytes: u64,
    tick: u64,
    pub(super) budget: u64,
}

impl GrayCache {
    pub(super) fn new(budget: u64) -> GrayCache {
        GrayCache {
            budget,
            ..GrayCache::default()
        }
    }

    fn get(&mut self, level: u32, view: usize) -> Option<Arc<Vec<f32>>> {
        self.tick += 1;
        let e = self.entries.get_mut(&(level, view))?;
        e.0 = self.tick;
        Some(e.1.clone())
    }

    fn put(&mut self, level: u32, view: usize, gray: Arc<Vec<f32>>) {
        self.tick += 1;
        self.bytes += gray.len() as u64 * 4;
        if let Some(old) = self.entries.insert((level, view), (self.tick, gray)) {
            self.bytes -= old.1.len() as u64 * 4;
        }
        while self.entries.len() > 1 && self.bytes > self.budget {
            let Some(oldest) = self.entries.iter().min_by_key(|e| e.1.0).map(|e| *e.0) else {
                break;
            };
            if let Some(e) = self.entries.remove(&oldest) {
                self.bytes -= e.1.len() as u64 * 4;
            }
        }
    }
}
