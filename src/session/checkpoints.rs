//! Checkpoints: device copies of the views' maps after each view's unit of work, within a
//! budget, and putting one back (Back, a parameter change, a method resumed).

use super::*;

/// A view's maps at a checkpoint, kept on the device. Checkpoints share the copies of views
/// that did not change between them.
#[derive(Clone)]
pub(super) struct SavedView {
    pub(super) level: u32,
    pub(super) maps: Arc<DeviceCopy>,
    pub(super) marks: Marks,
}

/// A checkpoint inside a stage: the stage, and a copy of the depth snapshot its geometric
/// passes read (the stage's end replaces the snapshot, so it must come back with the maps).
/// The checkpoints of one stage share the copy.
#[derive(Clone)]
pub(super) struct Within {
    pub(super) level: u32,
    pub(super) stage: Stage,
    pub(super) snapshot: Arc<wgpu::Texture>,
}

/// The maps after a view's unit of work (each view's part of a stage): enough to resume from
/// there. Stepping back one view then replays at most one unit.
#[derive(Clone)]
pub(super) struct Checkpoint {
    /// The first step after the unit.
    pub(super) cursor: usize,
    /// The level of the last stage that ended (`None` before the first).
    pub(super) level: Option<u32>,
    pub(super) views: Vec<Option<SavedView>>,
    /// Set when the checkpoint lies inside a stage (`None` at a stage's end).
    pub(super) within: Option<Within>,
}

impl Checkpoint {
    pub(super) fn start(views: usize) -> Checkpoint {
        Checkpoint {
            cursor: 0,
            level: None,
            views: vec![None; views],
            within: None,
        }
    }
}

impl Session {
    /// Puts the maps of a checkpoint back into the views' buffers (on the device), and the
    /// depth snapshot the next step reads: gathered from the maps at a stage's end, the
    /// saved copy inside a stage.
    pub(super) fn restore(&mut self, cp: Checkpoint) {
        self.cursor = cp.cursor;
        self.active = None;
        self.committed_level = cp.level;
        self.checkpoints.retain(|c| c.cursor <= self.cursor);
        if cp.cursor == 0 || !self.plan.resident {
            // The start: nothing on the device or the host (a batched session has only this
            // checkpoint).
            self.cursor = 0;
            self.committed_level = None;
            self.store.clear();
            self.loaded = None;
            self.residents.iter_mut().for_each(|r| *r = None);
            self.level_images = None;
            self.checkpoints.truncate(1);
            self.changed.fill(true);
            return;
        }
        let images_level = cp.within.as_ref().map(|w| w.level).or(cp.level);
        // Inside a level's first stage some views are still at the level before.
        let mixed = cp
            .views
            .iter()
            .flatten()
            .any(|s| Some(s.level) != images_level);
        if images_level.is_none()
            || mixed
            || self.level_images.as_ref().map(|(l, _)| *l) != images_level
        {
            // Every view's buffers are made anew over their level's images, so that all the
            // views of a level read and gather into the same depth snapshot.
            self.residents.iter_mut().for_each(|r| *r = None);
            self.level_images = None;
        }
        // Coarser levels first: the images end at the stage's level.
        let mut order: Vec<usize> = (0..cp.views.len()).collect();
        order.sort_by_key(|&v| cp.views[v].as_ref().map(|s| s.level));
        let mut failed = false;
        for v in order {
            let Some(saved) = &cp.views[v] else {
                self.residents[v] = None;
                continue;
            };
            if self.ensure_resident(v, saved.level).is_err() {
                failed = true;
                break;
            }
            if let Some(r) = self.residents[v].as_mut() {
                r.solver.restore_copy(&self.ctx, &saved.maps);
                r.marks = saved.marks.clone();
                r.mesh = None;
                r.points = None;
                if let Some(p) = &r.marks.planar {
                    crate::gpu::acmh::copy_into(&self.ctx, &p.prior, &r.solver.prior);
                }
            }
        }
        if let Some(w) = &cp.within
            && !failed
        {
            failed = self.ensure_level(w.level).is_err();
            if let Some((_, images)) = &self.level_images {
                crate::gpu::acmh::copy_texture(&self.ctx, &w.snapshot, &images.depth);
            }
        }
        if failed {
            // The device refused the buffers it had before: start over, which needs none.
            self.cursor = 0;
            self.committed_level = None;
            self.residents.iter_mut().for_each(|r| *r = None);
            self.checkpoints.truncate(1);
            self.changed.fill(true);
            return;
        }
        if cp.within.is_none() {
            for r in self.residents.iter().flatten() {
                r.solver.gather_depth(&self.ctx, &self.pipelines);
            }
        }
        // The newest checkpoint is this one unless it was dropped: only then can the next
        // checkpoint share its copies.
        let fresh = self
            .checkpoints
            .last()
            .is_some_and(|c| c.cursor == self.cursor);
        self.changed.fill(!fresh);
    }

    /// A checkpoint after `step`, the last of a view's unit: copies of the views that
    /// changed since the newest checkpoint, that checkpoint's copies of the others, and
    /// inside a stage the stage's depth snapshot (copied once per stage).
    pub(super) fn push_checkpoint(&mut self, step: Step, stage_done: bool) {
        let newest = self.checkpoints.last();
        let views = self
            .residents
            .iter()
            .enumerate()
            .map(|(v, r)| {
                let r = r.as_ref()?;
                let kept = newest
                    .and_then(|c| c.views[v].as_ref())
                    .filter(|s| !self.changed[v] && s.level == r.level);
                Some(match kept {
                    Some(saved) => saved.clone(),
                    None => SavedView {
                        level: r.level,
                        maps: Arc::new(r.solver.device_copy(&self.ctx)),
                        marks: r.marks.clone(),
                    },
                })
            })
            .collect();
        let within = if stage_done {
            None
        } else {
            let shared = newest
                .and_then(|c| c.within.clone())
                .filter(|w| w.level == step.level && w.stage == step.stage);
            let copy = || {
                self.level_images.as_ref().map(|(_, images)| Within {
                    level: step.level,
                    stage: step.stage,
                    snapshot: Arc::new(crate::gpu::acmh::texture_copy(
                        &self.ctx,
                        "depth snapshot copy",
                        &images.depth,
                    )),
                })
            };
            shared.or_else(copy)
        };
        self.checkpoints.push(Checkpoint {
            cursor: self.cursor,
            level: self.committed_level,
            views,
            within,
        });
        self.changed.fill(false);
        self.enforce_checkpoint_budget();
    }

    /// Drops the oldest checkpoints (never the start) while they hold more than the budget:
    /// stepping back past them then replays from an earlier one, which is slower but
    /// exact.
    pub(super) fn enforce_checkpoint_budget(&mut self) {
        while self.checkpoints.len() > 2 && self.checkpoint_bytes() > self.checkpoint_budget {
            self.checkpoints.remove(1);
        }
    }

    /// Bytes the checkpoints hold on the device (a copy shared by several counted once).
    pub fn checkpoint_bytes(&self) -> u64 {
        let mut seen = std::collections::HashSet::new();
        let mut bytes = 0;
        for c in &self.checkpoints {
            for saved in c.views.iter().flatten() {
                if seen.insert(Arc::as_ptr(&saved.maps) as usize) {
                    bytes += saved.maps.bytes();
                }
            }
            if let Some(w) = &c.within
                && seen.insert(Arc::as_ptr(&w.snapshot) as usize)
            {
                bytes += crate::gpu::acmh::texture_bytes(&w.snapshot);
            }
        }
        bytes
    }

    /// Checkpoints held (the start included).
    pub fn checkpoint_count(&self) -> usize {
        self.checkpoints.len()
    }

    /// The most bytes the checkpoints may hold (the newest is always kept).
    pub fn set_checkpoint_budget(&mut self, bytes: u64) {
        self.checkpoint_budget = bytes;
        self.enforce_checkpoint_budget();
    }

    pub fn checkpoint_budget(&self) -> u64 {
        self.checkpoint_budget
    }
}
