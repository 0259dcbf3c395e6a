//! A stage's results handed from one session to another: what a cluster task writes when
//! its part of a stage ends and the next stage's tasks start from (`crate::cluster`).
//!
//! A view's state at a stage boundary is every per-pixel buffer a later step reads (planes,
//! costs, view selection, weights, flags, the restorer's and reprojection maps, the prior
//! planes); a session given the states of a stage's views and their sources continues
//! exactly as the session that wrote them, which the cluster tests check byte for byte.

use super::{Session, SessionError, Stage};
use crate::gpu::acmh::GpuViewSolver;

/// The buffers of a view's state, in file order.
const BUFFERS: [&str; 7] = [
    "plane", "cost", "selected", "weights", "aux", "extra", "prior",
];
// 2: the extra maps are two (the median's scratch is its own buffer), the masks live in aux.
// 3: the earlier support points of the per-region choice follow the restorer's aux.
const MAGIC: &[u8; 8] = b"MVSHAND3";

/// Where each of `BUFFERS` lives on the device: a buffer and a byte range (the weights,
/// a texture, `None`).
fn state_ranges(s: &GpuViewSolver) -> [Option<(wgpu::Buffer, u64, u64)>; 7] {
    let whole = |b: &wgpu::Buffer| (b.clone(), 0, b.size());
    let (at, len) = s.selected_bytes();
    [
        Some(whole(&s.plane)),
        Some(whole(&s.cost)),
        Some((s.aux.clone(), at, len)),
        None,
        Some((s.aux.clone(), 0, s.aux_bytes())),
        Some(whole(&s.extra)),
        Some(whole(&s.prior)),
    ]
}

/// A view's state at a stage boundary, on the host.
#[derive(Clone, Debug, PartialEq)]
pub struct HandoffView {
    /// The pyramid level its maps are at.
    pub level: u32,
    pub width: u32,
    pub height: u32,
    /// extra[0, n) holds the detail restorer's difference.
    pub difference: bool,
    /// extra[n, 2n) holds the reprojection error.
    pub reprojection: bool,
    /// The device buffers' bytes: plane, cost, selected, weights (a layer per source, source
    /// j's at j·n), aux, extra, prior.
    pub buffers: Vec<Vec<u8>>,
    /// aux as the restorer's restore step left it, if it has run at this level.
    pub replaced: Option<Vec<u8>>,
    /// With `prior_region_choice`: the support records of the restorer's result at this
    /// level (32 bytes each), once the first geometric pass has read them.
    pub earlier: Option<Vec<u8>>,
}

/// The depths (plane w) of `w x h` planes given as bytes (16 a plane).
pub(super) fn depth_of_planes(plane: &[u8], w: u32, h: u32) -> Vec<f32> {
    plane
        .chunks_exact(16)
        .take(w as usize * h as usize)
        .map(|p| f32::from_le_bytes([p[12], p[13], p[14], p[15]]))
        .collect()
}

impl HandoffView {
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(64 + self.buffers.iter().map(Vec::len).sum::<usize>());
        out.extend_from_slice(MAGIC);
        let flags = self.difference as u32 | (self.reprojection as u32) << 1;
        for v in [self.level, self.width, self.height, flags] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        let mut put = |bytes: Option<&Vec<u8>>| match bytes {
            Some(b) => {
                out.extend_from_slice(&(b.len() as u64).to_le_bytes());
                out.extend_from_slice(b);
            }
            None => out.extend_from_slice(&u64::MAX.to_le_bytes()),
        };
        for b in &self.buffers {
            put(Some(b));
        }
        put(self.replaced.as_ref());
        put(self.earlier.as_ref());
        out
    }

    /// Parses [`HandoffView::to_bytes`]; the error says what is wrong with the bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<HandoffView, String> {
        let mut rest = bytes
            .strip_prefix(MAGIC.as_slice())
            .ok_or("not a stage hand-off file of this version (no MVSHAND3 header)")?;
        let mut take = |n: usize| -> Result<&[u8], String> {
            if rest.len() < n {
                return Err(format!("cut short ({} bytes in all)", bytes.len()));
            }
            let (head, tail) = rest.split_at(n);
            rest = tail;
            Ok(head)
        };
        let mut word = || -> Result<u32, String> {
            let b = take(4)?;
            Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        let (level, width, height, flags) = (word()?, word()?, word()?, word()?);
        let mut part = || -> Result<Option<Vec<u8>>, String> {
            let b = take(8)?;
            let len = u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]);
            if len == u64::MAX {
                return Ok(None);
            }
            Ok(Some(take(len as usize)?.to_vec()))
        };
        let mut buffers = Vec::with_capacity(BUFFERS.len());
        for name in BUFFERS {
            buffers.push(part()?.ok_or_else(|| format!("no {name} buffer"))?);
        }
        let replaced = part()?;
        let earlier = part()?;
        if earlier.as_ref().is_some_and(|e| e.len() % 32 != 0) {
            return Err("the earlier support points are cut short".into());
        }
        if !rest.is_empty() {
            return Err(format!("{} bytes after the end", rest.len()));
        }
        Ok(HandoffView {
            level,
            width,
            height,
            difference: flags & 1 != 0,
            reprojection: flags & 2 != 0,
            buffers,
            replaced,
            earlier,
        })
    }
}

impl Session {
    /// Puts a view's handed-off state into its buffers (made at the state's level).
    pub(super) fn restore_handoff(
        &mut self,
        view: usize,
        state: HandoffView,
    ) -> Result<(), SessionError> {
        self.ensure_resident(view, state.level)?;
        let Some(r) = self.residents[view].as_mut() else {
            return Ok(());
        };
        let s = &r.solver;
        if s.size() != (state.width, state.height) {
            return Err(SessionError::State(format!(
                "view {view}: a state of {}x{} for maps of {}x{}",
                state.width,
                state.height,
                s.size().0,
                s.size().1
            )));
        }
        // Writes go with the next submission: the recorded work before them first.
        self.ctx.flush();
        let targets = state_ranges(s);
        for ((buffer, bytes), name) in targets.into_iter().zip(&state.buffers).zip(BUFFERS) {
            if bytes.is_empty() {
                // A slim state (`HostStore`): this buffer is made anew by the pass that
                // reads it; the fresh one holds zeros.
                continue;
            }
            let Some((buffer, at, len)) = buffer else {
                // The weights, a texture layer per source.
                let (w, h) = s.size();
                let layers = s.num_sources().max(1) as u64;
                if bytes.len() as u64 != w as u64 * h as u64 * 4 * layers {
                    return Err(SessionError::State(format!(
                        "view {view}: {} bytes of weights for {layers} layers of {w}x{h}",
                        bytes.len()
                    )));
                }
                s.upload_weight_layers(&self.ctx, bytemuck::cast_slice(bytes));
                continue;
            };
            if bytes.len() as u64 != len {
                return Err(SessionError::State(format!(
                    "view {view}: {} bytes of {name} for a map of {len}",
                    bytes.len(),
                )));
            }
            self.ctx.queue.write_buffer(&buffer, at, bytes);
            self.ctx.traffic.add_to_device(bytes.len() as u64);
        }
        r.marks.difference = state.difference;
        r.marks.reprojection = state.reprojection;
        r.marks.replaced = state.replaced.map(|bytes| {
            let b = self.ctx.zeroed_storage("replaced", bytes.len() as u64);
            self.ctx.queue.write_buffer(&b, 0, &bytes);
            b
        });
        r.marks.earlier = state
            .earlier
            .map(|bytes| std::sync::Arc::new(bytemuck::pod_collect_to_vec(&bytes)));
        Ok(())
    }

    /// The schedule's stages in order, as (level, stage).
    pub fn stages(&self) -> Vec<(u32, Stage)> {
        let mut out: Vec<(u32, Stage)> = Vec::new();
        for s in &self.steps {
            if out.last() != Some(&(s.level, s.stage)) {
                out.push((s.level, s.stage));
            }
        }
        out
    }

    /// Whether view `view` is estimated (has sources; the others have no state).
    pub fn estimates(&self, view: usize) -> bool {
        self.estimated.contains(&view)
    }

    /// View `view`'s state now: read from the device, or the host's copy of a view a batched
    /// session holds there (`None` before its first step).
    pub fn handoff(&self, view: usize) -> Result<Option<HandoffView>, SessionError> {
        if self.residents.get(view).and_then(Option::as_ref).is_none() {
            return Ok(self.store.state(view)?.map(std::sync::Arc::unwrap_or_clone));
        }
        self.read_state(view, false)
    }

    /// View `view`'s state read from the device; `slim`: only what later stages read (the
    /// planes, costs and flags, and the prior planes where the prior holds in the geometric
    /// passes; the other buffers empty).
    pub(super) fn read_state(
        &self,
        view: usize,
        slim: bool,
    ) -> Result<Option<HandoffView>, SessionError> {
        let Some(r) = self.residents.get(view).and_then(Option::as_ref) else {
            return Ok(None);
        };
        let s = &r.solver;
        // The prior planes (6) are read again by the geometric passes a prior holds in.
        let holds = self.prior_holds();
        let kept = |k: usize| [0, 1, 4].contains(&k) || (k == 6 && holds);
        let reads: Vec<_> = state_ranges(s)
            .into_iter()
            .zip(BUFFERS)
            .enumerate()
            .map(|(k, (b, name))| match b {
                _ if slim && !kept(k) => self.ctx.read_later(name, &s.plane, 0, 0),
                Some((b, at, len)) => self.ctx.read_later(name, &b, at, len),
                None => s.request_weight_layers(&self.ctx),
            })
            .collect();
        let replaced = r
            .marks
            .replaced
            .as_ref()
            .filter(|_| !slim)
            .map(|b| self.ctx.read_later("replaced", b, 0, b.size()));
        let mut buffers = Vec::with_capacity(reads.len());
        for read in reads {
            buffers.push(read.wait::<u8>(&self.ctx)?);
        }
        let replaced = match replaced {
            Some(read) => Some(read.wait::<u8>(&self.ctx)?),
            None => None,
        };
        let (width, height) = s.size();
        Ok(Some(HandoffView {
            level: r.level,
            width,
            height,
            difference: r.marks.difference && !slim,
            reprojection: r.marks.reprojection && !slim,
            buffers,
            replaced,
            // Slim or not: the prior stage reads them.
            earlier: r
                .marks
                .earlier
                .as_ref()
                .map(|e| bytemuck::cast_slice(e.as_slice()).to_vec()),
        }))
    }

    /// Makes this session run only stage `index` of its schedule, for `views` only, from
    /// `states`: each state as the stage before left it, of the views and of the sources
    /// whose depths the stage reads (only before the first step). The stage's results are
    /// then those of the whole run: [`Session::handoff`] them to the next stage's sessions.
    pub fn begin_stage(
        &mut self,
        index: usize,
        views: &[usize],
        states: Vec<(usize, HandoffView)>,
    ) -> Result<(), SessionError> {
        if self.cursor != 0 {
            return Err(SessionError::Params(
                "begin_stage: only before the first step".into(),
            ));
        }
        if self.is_batched() {
            return Err(SessionError::Memory(format!(
                "a unit's views and sources must fit the device at once, and these need batches ({} views in {} batches); plan with more --tasks",
                self.estimated.len(),
                self.plan.batches.len()
            )));
        }
        let stages = self.stages();
        let Some(&(level, stage)) = stages.get(index) else {
            return Err(SessionError::Params(format!(
                "stage {index}: the schedule has {} stages",
                stages.len()
            )));
        };
        let previous = index.checked_sub(1).map(|p| stages[p].0);
        if let Some(bad) = states.iter().find(|(_, s)| Some(s.level) != previous) {
            return Err(SessionError::State(format!(
                "view {}: its state is at level {}, stage {index} starts from level {previous:?}",
                bad.0, bad.1.level
            )));
        }
        self.steps
            .retain(|s| (s.level, s.stage) == (level, stage) && views.contains(&s.view));
        self.committed_level = previous;
        self.keep_checkpoints = false;
        let mut sources = Vec::new();
        for (view, state) in states {
            if views.contains(&view) {
                self.restore_handoff(view, state)?;
            } else {
                sources.push((view, state));
            }
        }
        // The depth snapshot the stage reads: its views' depths gathered on the device, the
        // sources' written straight into it (a source only lends its depth: it needs no
        // buffers of its own, nor its own sources in this part of the scene).
        for r in self.residents.iter().flatten() {
            if Some(r.level) == previous {
                r.solver.gather_depth(&self.ctx, &self.pipelines);
            }
        }
        if let (Some(level), false) = (previous, sources.is_empty()) {
            self.ensure_level(level)?;
            let Some((_, images)) = &self.level_images else {
                return Ok(());
            };
            self.ctx.flush();
            for (view, state) in sources {
                let scene_view = &self.levels[level as usize].views[view];
                let (w, h) = (scene_view.image.width, scene_view.image.height);
                let plane = state.buffers.first().map(Vec::as_slice).unwrap_or(&[]);
                if (state.width, state.height) != (w, h)
                    || plane.len() < w as usize * h as usize * 16
                {
                    return Err(SessionError::State(format!(
                        "source view {view}: a state of {}x{} for maps of {w}x{h}",
                        state.width, state.height
                    )));
                }
                images.write_depth(&self.ctx, view, &depth_of_planes(plane, w, h))?;
            }
        }
        Ok(())
    }
}
