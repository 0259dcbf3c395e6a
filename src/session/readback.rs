//! Reading a session's maps: a view's maps, planes and costs, planar prior, restorer C_init
//! and the sources' depths as a pass reads them, asked for now and taken later
//! ([`Pending`]), or waited for; and any view's buffers as GPU maps (the live buffers of the
//! active view, device copies of the others).

use super::*;

impl Session {
    /// The maps of `view` as they stand now (the live GPU state for the active view), read
    /// back from the device, waiting for them (natively; the viewer uses
    /// [`Session::request_maps`]).
    pub fn maps(&self, view: usize) -> Result<Option<ViewMaps>, SessionError> {
        self.request_maps(view)?.wait(&self.ctx)
    }

    /// Asks for the maps of `view` as they stand now: the copies are recorded in queue order
    /// (so a later step does not change them) and taken when they arrive, nothing waiting.
    pub fn request_maps(&self, view: usize) -> Result<Pending<Option<ViewMaps>>, SessionError> {
        let Some(resident) = self.residents.get(view).and_then(Option::as_ref) else {
            return Ok(Pending::ready(self.off_device_maps(view)?));
        };
        let solver = &resident.solver;
        let marks = &resident.marks;
        let ctx = &self.ctx;
        let state = solver.request_state(ctx);
        let replaced = marks
            .replaced
            .as_ref()
            .map(|aux| ctx.read_later("replaced", aux, 0, aux.size()));
        let difference = marks.difference.then(|| solver.request_extra_map(ctx, 0));
        let anchors = marks.anchors.then(|| solver.request_extra_map(ctx, 0));
        let reprojection = marks.reprojection.then(|| solver.request_extra_map(ctx, 1));
        let prior = marks
            .planar
            .as_ref()
            .map(|p| ctx.read_later("prior planes", &p.prior, 0, p.prior.size()));
        let level = resident.level;
        let prior_terms = prior.as_ref().map(|_| self.prior_terms(view, level));
        let support_points = marks.planar.as_ref().map(|p| {
            p.mesh
                .points
                .iter()
                .map(|q| [q.x as f32, q.y as f32])
                .collect::<Vec<_>>()
        });
        let mut ready = state.flags();
        for r in [&replaced, &difference, &anchors, &reprojection, &prior]
            .into_iter()
            .flatten()
        {
            ready.push(r.flag());
        }
        Ok(Pending::new(ready, move |ctx| {
            let aux: Option<Vec<u32>> = crate::gpu::Readback::values_of(&replaced, ctx)?;
            Ok(Some(ViewMaps {
                level,
                state: state.values(ctx)?,
                restorer_difference: crate::gpu::Readback::values_of(&difference, ctx)?,
                replaced: aux.map(|a| a.iter().map(|a| a & (1 << 16) != 0).collect()),
                reprojection_error: crate::gpu::Readback::values_of(&reprojection, ctx)?,
                prior: crate::gpu::Readback::values_of(&prior, ctx)?,
                anchors: crate::gpu::Readback::values_of(&anchors, ctx)?,
                prior_terms,
                support_points,
            }))
        }))
    }

    /// A view without state on the device: its state on the host (a batched session), else
    /// none before the first stage ends and empty maps for a view that cannot be estimated.
    pub(super) fn off_device_maps(&self, view: usize) -> Result<Option<ViewMaps>, SessionError> {
        match self.parked_maps(view)? {
            Some(m) => Ok(Some(m)),
            None => Ok(self.empty_maps(view)),
        }
    }

    /// A view without state on the device or the host: none before the first stage ends,
    /// empty maps for a view that cannot be estimated.
    pub(super) fn empty_maps(&self, view: usize) -> Option<ViewMaps> {
        let level = self.committed_level?;
        if self.estimated.contains(&view) {
            return None;
        }
        let s = &self.levels.get(level as usize)?.views.get(view)?;
        Some(ViewMaps::empty(level, s.image.width, s.image.height))
    }

    /// The final maps of `view` that a run writes: planes (normal, depth) and costs, read
    /// back alone (`None` for a view without state), waiting for them.
    pub fn planes_and_costs(&self, view: usize) -> Result<Option<PlanesCosts>, SessionError> {
        self.request_planes_and_costs(view)?.wait(&self.ctx)
    }

    /// Asks for [`Session::planes_and_costs`] without waiting.
    pub fn request_planes_and_costs(
        &self,
        view: usize,
    ) -> Result<Pending<Option<PlanesCosts>>, SessionError> {
        let Some(r) = self.residents.get(view).and_then(Option::as_ref) else {
            return Ok(Pending::ready(self.off_device_maps(view)?.map(|m| {
                PlanesCosts {
                    level: m.level,
                    width: m.state.width,
                    height: m.state.height,
                    plane: m.state.plane,
                    cost: m.state.cost,
                }
            })));
        };
        let ctx = &self.ctx;
        let (width, height) = r.solver.size();
        let level = r.level;
        let plane = ctx.read_later("plane", &r.solver.plane, 0, r.solver.plane.size());
        let cost = ctx.read_later("cost", &r.solver.cost, 0, r.solver.cost.size());
        let ready = vec![plane.flag(), cost.flag()];
        Ok(Pending::new(ready, move |ctx| {
            Ok(Some(PlanesCosts {
                level,
                width,
                height,
                plane: plane.values_after(ctx)?,
                cost: cost.values_after(ctx)?,
            }))
        }))
    }

    /// The planar prior of `view` at its current level (ACMP, ACMMP): the support points and
    /// their triangulation, and every pixel's prior plane (read back, waiting); `None` before
    /// its prior-plane step has run at this level.
    pub fn planar_prior(&self, view: usize) -> Result<Option<PlanarPriorMaps>, SessionError> {
        self.request_planar_prior(view).wait(&self.ctx)
    }

    /// Asks for [`Session::planar_prior`] without waiting.
    pub fn request_planar_prior(&self, view: usize) -> Pending<Option<PlanarPriorMaps>> {
        let Some(r) = self.residents.get(view).and_then(Option::as_ref) else {
            return Pending::ready(None);
        };
        let Some(p) = &r.marks.planar else {
            return Pending::ready(None);
        };
        let read = self
            .ctx
            .read_later("prior planes", &p.prior, 0, p.prior.size());
        let (level, mesh) = (r.level, p.mesh.clone());
        let ready = vec![read.flag()];
        Pending::new(ready, move |ctx| {
            Ok(Some(PlanarPriorMaps {
                level,
                mesh,
                prior: read.values_after(ctx)?,
            }))
        })
    }

    /// The prior planes `view`'s passes read now (normal, depth; depth ≤ 0: none,
    /// `crate::acmm::planar::no_prior_reason`), `None` when the view is not on the device:
    /// in its prior stage every pixel's, after it only those that hold in the geometric
    /// passes (`crate::acmm::planar::held_prior`). Asked for before a step, they are what
    /// the step reads, in a run of batches too (a parked view keeps them in its state).
    pub fn request_prior_planes(
        &self,
        view: usize,
    ) -> Result<Pending<Option<Vec<[f32; 4]>>>, SessionError> {
        let Some(r) = self.residents.get(view).and_then(Option::as_ref) else {
            return Ok(Pending::ready(self.parked_prior_planes(view)?));
        };
        let (w, h) = r.solver.size();
        let read = self.ctx.read_later(
            "prior planes",
            &r.solver.prior,
            0,
            (w as u64 * h as u64 * 16).min(r.solver.prior.size()),
        );
        let ready = vec![read.flag()];
        Ok(Pending::new(ready, move |ctx| {
            Ok(Some(read.values_after(ctx)?))
        }))
    }

    /// [`Session::request_support_inputs`], waited for.
    pub fn support_inputs(&self, view: usize) -> Result<Option<SupportInputs>, SessionError> {
        self.request_support_inputs(view).wait(&self.ctx)
    }

    /// What `view`'s support-point step read, asked for right after it ran (the step just
    /// run is that view's `SupportPoints`; else `None`): its planes and costs, the keys the
    /// choice ranked by (the multi-view check's least errors, or with
    /// `prior_confirmed_points` the confirmation keys) and the windows' spread, for
    /// [`crate::acmm::planar::explain_cell`] (the inspector's "why this support point").
    pub fn request_support_inputs(&self, view: usize) -> Pending<Option<SupportInputs>> {
        let last = self.cursor.checked_sub(1).and_then(|i| self.steps.get(i));
        let (Some(step), Some(r)) = (last, self.residents.get(view).and_then(Option::as_ref))
        else {
            return Pending::ready(None);
        };
        if step.view != view || step.action != Action::SupportPoints {
            return Pending::ready(None);
        }
        let solver = &r.solver;
        let (w, h) = solver.size();
        let n = w as u64 * h as u64;
        let ctx = &self.ctx;
        let plane = ctx.read_later("plane", &solver.plane, 0, (n * 16).min(solver.plane.size()));
        let cost = ctx.read_later("cost", &solver.cost, 0, (n * 4).min(solver.cost.size()));
        let p = &self.params;
        let keys = (p.prior_consistency > 0.0).then(|| solver.request_extra_map(ctx, 1));
        let spread =
            (p.prior_flat_points || p.prior_regions).then(|| solver.request_extra_map(ctx, 0));
        let mut ready = vec![plane.flag(), cost.flag()];
        ready.extend(keys.iter().chain(&spread).map(|r| r.flag()));
        let (level, step) = (r.level, *step);
        Pending::new(ready, move |ctx| {
            Ok(Some(SupportInputs {
                step,
                level,
                plane: plane.values_after(ctx)?,
                cost: cost.values_after(ctx)?,
                keys: crate::gpu::Readback::values_of(&keys, ctx)?,
                spread: crate::gpu::Readback::values_of(&spread, ctx)?,
            }))
        })
    }

    /// The triangulation of `view`'s planar prior at its current level, without a read-back.
    pub fn planar_mesh(&self, view: usize) -> Option<&PriorMesh> {
        let r = self.residents.get(view)?.as_ref()?;
        r.marks.planar.as_ref().map(|p| &p.mesh)
    }

    /// C_init of each pixel while `view` is in the gated detail restorer's pass (what its
    /// updates are gated by), else `None` (the ungated pass reads C_init only at its end).
    pub fn restorer_c_init(&self, view: usize) -> Result<Option<Vec<f32>>, SessionError> {
        self.request_restorer_c_init(view).wait(&self.ctx)
    }

    /// Asks for [`Session::restorer_c_init`] without waiting.
    pub fn request_restorer_c_init(&self, view: usize) -> Pending<Option<Vec<f32>>> {
        match (self.active, self.active_gpu()) {
            (Some(step), Some((_, solver)))
                if step.view == view
                    && self.pass_kind(&step) == PassKind::Restorer { gated: true }
                    && step.action != Action::Restore =>
            {
                let read = solver.request_extra_map(&self.ctx, 0);
                let ready = vec![read.flag()];
                Pending::new(ready, move |ctx| Ok(Some(read.values_after(ctx)?)))
            }
            _ => Pending::ready(None),
        }
    }

    /// [`Session::request_anchor_codes`], waited for.
    pub fn anchor_codes(&self, view: usize) -> Result<Option<Vec<u32>>, SessionError> {
        self.request_anchor_codes(view).wait(&self.ctx)
    }

    /// The anchor codes of `view` (`prior_anchors`, src/acmm/planar.rs `anchor_plane`) while
    /// it is in its prior stage, from the prior planes' step on (the first extra map holds
    /// them until the stage ends); else none.
    pub fn request_anchor_codes(&self, view: usize) -> Pending<Option<Vec<u32>>> {
        match (self.active, self.active_gpu()) {
            (Some(step), Some((_, solver)))
                if step.view == view
                    && self.pass_kind(&step) == PassKind::Planar
                    && self.params.anchors_on()
                    && matches!(
                        step.action,
                        Action::PriorPlane | Action::Init | Action::Half { .. }
                    ) =>
            {
                let read = solver.request_extra_map(&self.ctx, 0);
                let ready = vec![read.flag()];
                Pending::new(ready, move |ctx| {
                    let codes: Vec<f32> = read.values_after(ctx)?;
                    Ok(Some(codes.iter().map(|&c| c as u32).collect()))
                })
            }
            _ => Pending::ready(None),
        }
    }

    /// The maps of `view` as GPU buffers, for drawing without a CPU round trip: the live
    /// buffers while the view is being processed, else copies of its buffers made on the
    /// device (maps absent from the view read 0).
    pub fn gpu_maps(&self, view: usize) -> Result<Option<GpuMaps>, SessionError> {
        let Some(resident) = self.residents.get(view).and_then(Option::as_ref) else {
            return Ok(self
                .off_device_maps(view)?
                .map(|maps| GpuMaps::upload(&self.ctx, &maps)));
        };
        let s = &resident.solver;
        let (width, height) = s.size();
        let live = self.active.is_some_and(|a| a.view == view);
        let (prior, prior_terms) = match &resident.marks.planar {
            Some(p) => (
                p.prior.clone(),
                Some(self.prior_terms(view, resident.level)),
            ),
            None => (
                self.ctx
                    .zeroed_storage("no prior", width as u64 * height as u64 * 16),
                None,
            ),
        };
        if live {
            return Ok(Some(GpuMaps {
                width,
                height,
                num_sources: s.num_sources(),
                plane: s.plane.clone(),
                cost: s.cost.clone(),
                selected: s.aux.clone(),
                selected_offset: s.selected_bytes().0,
                weights: s.weights.clone(),
                aux: s.aux.clone(),
                extra: s.extra.clone(),
                prior,
                prior_terms,
                live: true,
            }));
        }
        let copy = s.device_copy(&self.ctx);
        let n = width as u64 * height as u64 * 4;
        self.ctx.record("absent maps", |encoder| {
            if !resident.marks.difference && !resident.marks.anchors {
                encoder.clear_buffer(&copy.extra, 0, Some(n));
            }
            if !resident.marks.reprojection {
                encoder.clear_buffer(&copy.extra, n, Some(n));
            }
        });
        Ok(Some(GpuMaps {
            width,
            height,
            num_sources: s.num_sources(),
            plane: copy.plane,
            cost: copy.cost,
            selected: copy.aux.clone(),
            selected_offset: s.selected_bytes().0,
            weights: copy.weights,
            aux: copy.aux,
            extra: copy.extra,
            prior,
            prior_terms,
            live: false,
        }))
    }

    /// The sources' depth maps as the current stage reads them (the snapshot of the last
    /// stage boundary, read back from the device), laid out like the problem's images: what a
    /// geometric pass of `problem` reads.
    pub fn source_depths(&self, problem: &ViewProblem) -> Result<Vec<f32>, SessionError> {
        self.request_source_depths(problem).wait(&self.ctx)
    }

    /// Asks for [`Session::source_depths`] without waiting.
    pub fn request_source_depths(&self, problem: &ViewProblem) -> Pending<Vec<f32>> {
        let len = problem.images.len();
        let Some((level, images)) = &self.level_images else {
            return Pending::ready(vec![0.0; len]);
        };
        if *level != problem.scale || self.committed_level != Some(*level) {
            return Pending::ready(vec![0.0; len]);
        }
        let mut parts = Vec::new();
        for (j, &src) in problem.source_views.iter().enumerate() {
            let offset = problem.sources[j].size[2] as usize;
            let Ok(read) = images.request_depth(&self.ctx, src) else {
                continue;
            };
            parts.push((offset, read));
        }
        let ready = parts.iter().map(|(_, r)| r.flag()).collect();
        Pending::new(ready, move |ctx| {
            let mut depths = vec![0.0f32; len];
            for (offset, read) in &parts {
                let values: Vec<f32> = read.values_after(ctx)?;
                depths[*offset..*offset + values.len()].copy_from_slice(&values);
            }
            Ok(depths)
        })
    }
}
