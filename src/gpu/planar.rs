//! The planar prior's passes on the GPU (shaders/planar_prior.wgsl): credible support points
//! per grid cell (with `prior_consistency`, only among the pixels that passed the multi-view
//! check `GpuViewSolver::measure_consistency` left in the solver's error map), rasterising the host's triangulation into per-pixel labels, and every
//! pixel's prior plane, written into the view's `prior` buffer where the prior-assisted pass
//! (`PassKind::Planar`) reads it. CPU reference: `crate::acmm::planar`.
//!
//! The Delaunay triangulation between the first and second pass runs on the host: it is a
//! few thousand points per view, sequential by nature (incremental insertion with exact
//! predicates), and its result is small; what is per pixel stays on the device.

use bytemuck::{Pod, Zeroable};

use super::acmh::{GpuViewSolver, plane_windows};
use super::{GpuContext, GpuError, shader, storage_entry};
use crate::acmm::memory;
use crate::acmm::params::Params;
use crate::acmm::planar::{GpuTriangle, PaintList, SupportRecord, cell_grid, confirmation_scale};
use crate::acmm::problem::ViewProblem;

/// Keep in sync with `struct Planar` in shaders/planar_prior.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPlanar {
    pub k: [f32; 4],
    pub width: u32,
    pub height: u32,
    pub cell: u32,
    pub cells_x: u32,
    pub cells_y: u32,
    pub num_triangles: u32,
    pub depth_min: f32,
    pub depth_max: f32,
    pub threshold: f32,
    /// `prior_consistency` (pixels; 0: unchecked).
    pub consistency: f32,
    /// The first pixel of the planes' and prior planes' second window
    /// (`memory::plane_split`).
    pub split: u32,
    /// 1 when the cells' planes past the hull follow the triangles (`prior_extend`).
    pub extend: u32,
    /// Pixels whose least reprojection error is below this get no prior (`prior_lock`;
    /// 0: none are locked).
    pub lock: f32,
    /// 1: weak pixels look for anchors (`prior_anchors`), their codes written to the first
    /// extra map.
    pub anchors: u32,
    pub anchor_inliers: u32,
    pub anchor_tolerance: f32,
    /// `prior_flat_cost` with `prior_flat_points` (0: no points on flat windows); the
    /// windows' spread is in the first extra map (`GpuViewSolver::measure_spread`).
    pub flat_cost: f32,
    /// 1: each record's `normal[3]` counts its cell's flat windows (`prior_regions`).
    pub count_flat: u32,
    /// 1: each cell's point ranks its credible pixels by confirmation key (the second extra
    /// map, `GpuViewSolver::rank_confirmed`), then cost (`prior_confirmed_points`).
    pub confirmed: u32,
    /// With `confirmed`, > 0: rank by cost + key × this (one over the keys' scale,
    /// `planar::confirmation_scale`, a power of two), HPM-MVS++'s support score
    /// (`prior_confidence_score`); 0: by key, then cost.
    pub score_weight: f32,
}

/// The three compiled passes and their two bind group layouts (once per device): the
/// support points' (planes, costs, error maps, points) and the painting's (triangles,
/// labels, prior planes); one layout for all would bind ten storage buffers, two more than a
/// pass may.
pub struct PlanarPipelines {
    pub select_layout: wgpu::BindGroupLayout,
    pub paint_layout: wgpu::BindGroupLayout,
    pub support_points: wgpu::ComputePipeline,
    pub rasterise: wgpu::ComputePipeline,
    pub prior_plane: wgpu::ComputePipeline,
    pub keep_regions: wgpu::ComputePipeline,
}

impl PlanarPipelines {
    pub fn new(ctx: &GpuContext) -> Result<PlanarPipelines, GpuError> {
        // Bindings as in shaders/planar_prior.wgsl: 0 parameters, 1 and 8 the planes'
        // windows, 2 costs, 3 points, 7 error maps; 4 triangles, 5 labels, 6 and 9 the prior
        // planes' windows (the painting also reads the planes and writes the error maps: the
        // anchors).
        let layout = |label: &str, bindings: &[(u32, bool)]| {
            let entries: Vec<_> = bindings
                .iter()
                .map(|&(b, read_only)| storage_entry(b, read_only))
                .collect();
            ctx.layouts(label, &entries)
        };
        let (select_layout, select_pipeline) = layout(
            "planar prior support points",
            &[
                (0, true),
                (1, true),
                (8, true),
                (2, true),
                (3, false),
                // Declared writable for the painting's anchors; read only here.
                (7, false),
            ],
        )?;
        let (paint_layout, paint_pipeline) = layout(
            "planar prior painting",
            &[
                (0, true),
                (4, true),
                (5, false),
                (6, false),
                (9, false),
                (7, false),
                (1, true),
                (8, true),
            ],
        )?;
        let module = shader::create_module(
            ctx,
            "planar_prior",
            include_str!("../../shaders/planar_prior.wgsl"),
        )?;
        let make = |entry: &str, pipeline_layout: &wgpu::PipelineLayout| {
            super::acmh::compute_pipeline(ctx, pipeline_layout, "planar_prior", &module, entry, &[])
        };
        Ok(PlanarPipelines {
            support_points: make("support_points", &select_pipeline)?,
            rasterise: make("rasterise", &paint_pipeline)?,
            prior_plane: make("prior_plane", &paint_pipeline)?,
            keep_regions: make("keep_regions", &paint_pipeline)?,
            select_layout,
            paint_layout,
        })
    }
}

/// A view's planar-prior buffers: the cells' support points, the triangles, the per-pixel
/// labels, bound with the view's planes, costs and prior planes.
pub struct PlanarBuffers {
    params: wgpu::Buffer,
    points: wgpu::Buffer,
    triangles: wgpu::Buffer,
    labels: wgpu::Buffer,
    select_group: wgpu::BindGroup,
    paint_group: wgpu::BindGroup,
    split: u32,
    width: u32,
    height: u32,
    cell: u32,
    cells: (u32, u32),
    /// The most triangles a triangulation of one point per cell can have.
    capacity: u32,
}

impl PlanarBuffers {
    /// Buffers for `solver`'s view with grid cells of `cell` pixels.
    pub fn new(
        ctx: &GpuContext,
        pipelines: &PlanarPipelines,
        solver: &GpuViewSolver,
        cell: u32,
    ) -> Result<PlanarBuffers, GpuError> {
        let (width, height) = solver.size();
        let cells = cell_grid(width, height, cell.max(1));
        let count = cells.0 as u64 * cells.1 as u64;
        // A triangulation of V points has at most 2V - 5 triangles.
        // At most 2 per point (a planar triangulation), one point per cell; then one plane
        // past the hull per cell.
        let capacity = (3 * count).max(1) as u32;
        let params = ctx.params_buffer("planar params", &GpuPlanar::default());
        let points =
            ctx.zeroed_storage("support points", count * size_of::<SupportRecord>() as u64);
        let triangles = ctx.zeroed_storage(
            "prior triangles",
            capacity as u64 * size_of::<GpuTriangle>() as u64,
        );
        let labels = ctx.zeroed_storage("prior labels", width as u64 * height as u64 * 4);
        let pixels = width as u64 * height as u64;
        // One spare serves both: the windows are in different bind groups.
        let spare = ctx.zeroed_storage("unused window", 16);
        let [plane_lo, plane_hi] = plane_windows(&solver.plane, pixels, &spare);
        // The painting binds the planes read-only beside the prior planes' writable windows:
        // its own spare, so that one unused buffer is not bound both ways.
        let paint_spare = ctx.zeroed_storage("unused plane window", 16);
        let [plane_lo_paint, plane_hi_paint] = plane_windows(&solver.plane, pixels, &paint_spare);
        let [prior_lo, prior_hi] = plane_windows(&solver.prior, pixels, &spare);
        let select_group = ctx.buffer_group(
            "planar prior support points",
            &pipelines.select_layout,
            vec![
                (0, params.as_entire_buffer_binding()),
                (1, plane_lo),
                (8, plane_hi),
                (2, solver.cost.as_entire_buffer_binding()),
                (3, points.as_entire_buffer_binding()),
                (7, solver.extra.as_entire_buffer_binding()),
            ],
        )?;
        let paint_group = ctx.buffer_group(
            "planar prior painting",
            &pipelines.paint_layout,
            vec![
                (0, params.as_entire_buffer_binding()),
                (4, triangles.as_entire_buffer_binding()),
                (5, labels.as_entire_buffer_binding()),
                (6, prior_lo),
                (9, prior_hi),
                (7, solver.extra.as_entire_buffer_binding()),
                (1, plane_lo_paint),
                (8, plane_hi_paint),
            ],
        )?;
        Ok(PlanarBuffers {
            params,
            points,
            triangles,
            labels,
            select_group,
            paint_group,
            split: memory::plane_split(pixels) as u32,
            width,
            height,
            cell,
            cells,
            capacity,
        })
    }

    /// The grid cell these buffers were made for.
    pub fn cell(&self) -> u32 {
        self.cell
    }

    /// Bytes held on the device.
    pub fn bytes(&self) -> u64 {
        self.points.size() + self.triangles.size() + self.labels.size() + self.params.size()
    }

    fn write_params(
        &self,
        ctx: &GpuContext,
        problem: &ViewProblem,
        params: &Params,
        tris: u32,
        extend: bool,
    ) {
        let p = GpuPlanar {
            k: problem.k,
            width: self.width,
            height: self.height,
            cell: self.cell,
            cells_x: self.cells.0,
            cells_y: self.cells.1,
            num_triangles: tris,
            depth_min: problem.depth_min,
            depth_max: problem.depth_max,
            threshold: params.prior_cost_threshold,
            consistency: params.prior_consistency,
            split: self.split,
            extend: u32::from(extend),
            lock: if params.prior_lock && params.prior_consistency > 0.0 {
                params.prior_consistency
            } else {
                0.0
            },
            anchors: u32::from(params.anchors_on()),
            anchor_inliers: params.prior_anchor_inliers,
            anchor_tolerance: params.prior_anchor_tolerance,
            flat_cost: if params.prior_flat_points {
                params.prior_flat_cost
            } else {
                0.0
            },
            count_flat: u32::from(params.prior_regions),
            confirmed: u32::from(params.prior_confirmed_points && params.prior_consistency > 0.0),
            score_weight: if params.prior_confidence_score {
                confirmation_scale(params.prior_consistency, problem.num_sources() as u32).recip()
            } else {
                0.0
            },
        };
        ctx.write(&self.params, 0, std::slice::from_ref(&p));
    }

    fn dispatch(
        &self,
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        groups: (u32, u32),
    ) {
        ctx.record("planar prior", |encoder| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("planar prior"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        });
    }

    /// Each cell's credible support point from the view's current planes and costs (and,
    /// with `prior_consistency`, the least reprojection errors `measure_consistency` left in
    /// the solver's error map).
    pub fn support_points(
        &self,
        ctx: &GpuContext,
        pipelines: &PlanarPipelines,
        problem: &ViewProblem,
        params: &Params,
    ) {
        self.write_params(ctx, problem, params, 0, false);
        let cells = self.cells.0 * self.cells.1;
        self.dispatch(
            ctx,
            &pipelines.support_points,
            &self.select_group,
            (cells.div_ceil(64), 1),
        );
    }

    /// Asks for the cells' records (taken when they arrive).
    pub fn request_points(&self, ctx: &GpuContext) -> crate::gpu::Readback {
        ctx.read_later("support points", &self.points, 0, self.points.size())
    }

    /// The cells' records as `support_points` wrote them (read back).
    pub fn download_points(&self, ctx: &GpuContext) -> Result<Vec<SupportRecord>, GpuError> {
        ctx.read_buffer("support points", &self.points)
    }

    /// The per-pixel labels of the last `rasterise` (read back; tests).
    pub fn download_labels(&self, ctx: &GpuContext) -> Result<Vec<u32>, GpuError> {
        ctx.read_buffer("prior labels", &self.labels)
    }

    /// Checks `list` against the view's buffers (its cell size, and no more entries than a
    /// triangulation of one point per cell can have), then writes the pass parameters and
    /// uploads the entries; returns the number of triangles. Both passes that read a paint
    /// list (`rasterise`, `keep_regions`) load it here.
    fn load_list(
        &self,
        ctx: &GpuContext,
        problem: &ViewProblem,
        params: &Params,
        list: &PaintList,
    ) -> Result<u32, GpuError> {
        let triangles = &list.entries;
        if list.extended() && list.cell != self.cell {
            return Err(GpuError::Validation {
                what: format!("view {} planar prior", problem.view),
                message: format!(
                    "planes past the hull for cells of {} px, buffers for cells of {} px",
                    list.cell, self.cell
                ),
            });
        }
        if triangles.len() > self.capacity as usize {
            return Err(GpuError::Validation {
                what: format!("view {} planar prior", problem.view),
                message: format!(
                    "{} triangles, more than the {} a triangulation of one point per cell can have",
                    triangles.len(),
                    self.capacity
                ),
            });
        }
        let tris = list.triangles().len() as u32;
        self.write_params(ctx, problem, params, tris, list.extended());
        if !triangles.is_empty() {
            ctx.write(&self.triangles, 0, triangles);
        }
        Ok(tris)
    }

    /// Keeps the prior plane of the pixels whose cell `list` gives a flat region's plane,
    /// and takes the others' (`held_prior`): the list must be the one the view's prior
    /// planes were painted from.
    pub fn keep_regions(
        &self,
        ctx: &GpuContext,
        pipelines: &PlanarPipelines,
        problem: &ViewProblem,
        params: &Params,
        list: &PaintList,
    ) -> Result<(), GpuError> {
        self.load_list(ctx, problem, params, list)?;
        self.dispatch(
            ctx,
            &pipelines.keep_regions,
            &self.paint_group,
            (self.width.div_ceil(8), self.height.div_ceil(8)),
        );
        Ok(())
    }

    /// Rasterises `triangles` and writes every pixel's prior plane into the view's `prior`.
    pub fn rasterise(
        &self,
        ctx: &GpuContext,
        pipelines: &PlanarPipelines,
        problem: &ViewProblem,
        params: &Params,
        list: &PaintList,
    ) -> Result<(), GpuError> {
        let tris = self.load_list(ctx, problem, params, list)?;
        ctx.record("clear labels", |encoder| {
            encoder.clear_buffer(&self.labels, 0, None);
        });
        if tris > 0 {
            let groups = tris.div_ceil(64);
            self.dispatch(ctx, &pipelines.rasterise, &self.paint_group, (groups, 1));
        }
        self.dispatch(
            ctx,
            &pipelines.prior_plane,
            &self.paint_group,
            (self.width.div_ceil(8), self.height.div_ceil(8)),
        );
        Ok(())
    }
}
