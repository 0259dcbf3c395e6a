//! ACMH / DWTA / ACMM / ACMP passes on the GPU: initialisation (and its measuring modes: the
//! reprojection error, and the least one that checks support points), the red/black
//! adaptive-checkerboard update (photometric, geometric, restorer-gated or prior-assisted:
//! [`PassKind`]), the median filter, joint bilateral upsampling, the detail restorer, and
//! gathering a view's depths into the level's snapshot (shaders/initialize.wgsl,
//! adaptive_checkerboard.wgsl, median_filter.wgsl, joint_bilateral_upsample.wgsl,
//! detail_restorer.wgsl, gather_depth.wgsl). Mirrored by `crate::acmm::cpu`,
//! `crate::acmm::multiscale` and `crate::acmm::planar`.

use bytemuck::{Pod, Zeroable};

use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use super::timer::{PassTime, PassTimer};
use super::{GpuContext, GpuError, shader, storage_entry, uniform_entry};
use crate::acmm::cpu::pass_id;
use crate::acmm::memory;
use crate::acmm::params::{BilateralKernel, Method, Params};
use crate::acmm::planar::PriorTerms;
use crate::acmm::problem::{ViewProblem, ViewState};

mod buffers;
mod pipelines;

pub use buffers::*;
pub use pipelines::*;

/// Keep in sync with `struct Params` in shaders/shared/problem.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuParams {
    pub k: [f32; 4],
    pub coarse_k: [f32; 4],
    pub width: u32,
    pub height: u32,
    pub num_sources: u32,
    pub view: u32,
    pub scale: u32,
    pub pass_id: u32,
    pub iteration: u32,
    pub color: u32,
    pub seed_lo: u32,
    pub seed_hi: u32,
    pub method: u32,
    pub top_k: u32,
    pub depth_min: f32,
    pub depth_max: f32,
    pub tau_t: f32,
    pub tau1: f32,
    pub beta: f32,
    pub n1: u32,
    pub n2: u32,
    pub sigma_spatial: f32,
    pub sigma_color: f32,
    pub kernel: u32,
    pub window_radius: u32,
    pub window_step: u32,
    pub perturb_depth: f32,
    /// tan of `Params::perturb_normal`.
    pub perturb_normal_tan: f32,
    pub median_radius: u32,
    pub geometric: u32,
    pub lambda: f32,
    pub delta: f32,
    pub init_random: u32,
    pub xi: f32,
    pub coarse_width: u32,
    pub coarse_height: u32,
    pub jbu_radius: u32,
    pub jbu_sigma_spatial: f32,
    pub jbu_sigma_range: f32,
    /// The detail restorer's pass started from the upsampled planes: 0 not one, 1 gated, 2
    /// ungated (see `PassKind::Restorer`).
    pub restorer: u32,
    /// The first pixel of the second window of the planes and prior planes
    /// (`memory::plane_split`); set by the solver at each dispatch.
    pub split: u32,
    /// The reference's layer in the images texture.
    pub ref_layer: u32,
    /// The planar prior's prior-assisted pass (see `PassKind::Planar`): 0 not one, 1 every
    /// pixel updated, 2 only those with a prior; 3 a geometric pass the prior holds in
    /// (`Params::prior_holds_in`): every pixel updated, no restart at its start.
    pub prior: u32,
    pub prior_gamma: f32,
    pub prior_beta: f32,
    /// σd in depth units, 1/(2σd²) and 1/(2σθ²) (σθ in radians): `PriorTerms`.
    pub prior_sigma_depth: f32,
    pub prior_inv_2sd2: f32,
    pub prior_inv_2sn2: f32,
    pub prior_threshold: f32,
    pub prior_init_depth: f32,
    pub prior_init_normal_tan: f32,
    /// In units of σd.
    pub prior_refine_depth: f32,
    pub prior_refine_normal_tan: f32,
    /// Where the selected-view masks start in `aux` (`memory::selected_base`); set by the
    /// solver at each dispatch.
    pub selected_base: u32,
    /// 1 in the prior-assisted pass with `prior_anchors` (and the multi-view check): weak
    /// pixels' costs add their anchors' windows (codes in the first extra map).
    pub anchors: u32,
    pub anchor_weight: f32,
    /// `init_random` 5: how many sources must agree with a strong pixel
    /// (`prior_anchor_views`), within `prior_consistency` px.
    pub anchor_views: u32,
    pub anchor_limit: f32,
    /// `init_random` 7: a source confirms a depth whose round trip comes back within this
    /// share of it (`fusion_relative_depth`).
    pub confirm_depth: f32,
    /// `init_random` 7: 1 writes the key from the sources' summed confidence
    /// (`prior_confidence_score`), 0 from the number that confirm.
    pub confirm_score: u32,
    /// `init_random` 6: bit 0 measures the spread around the window's least-squares ramp
    /// (`prior_flat_ramp`), else around its mean; bit 1 over the matching window's samples
    /// under their bilateral weights (`prior_flat_weighted`), else over every pixel alike.
    pub flat_ramp: u32,
    /// 1 with `prior_keep_unseen`: in a pass with a prior, a pixel whose prior plane no
    /// source sees keeps it.
    pub prior_keep_unseen: u32,
    /// init_random = 6: the variance taken from each window's before its root, grey
    /// levels² (`prior_flat_noise`: the reference image's noise; 0 for none).
    pub flat_noise_var: f32,
    pub _pad: [u32; 3],
}

// The sources follow the parameters in one buffer: WGSL places them at a multiple of 16.
const _: () = assert!(std::mem::size_of::<GpuParams>().is_multiple_of(16));

/// Which kind of pass a dispatch belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    Photometric,
    /// Geometric consistency pass g (1-based): aggregated costs add λ times the reprojection
    /// error. The pass number is part of the random key, so passes draw different numbers.
    Geometric(u32),
    /// The detail restorer's basic model started from the upsampled planes (Sec. 5.2): its
    /// start keeps C_init, its updates track C_photo and, when `gated`, adopt a new plane
    /// only below C_init − ξ.
    Restorer {
        gated: bool,
    },
    /// The planar prior's prior-assisted pass (ACMP-REFERENCE.md §4): its start restarts the
    /// pixels of low confidence from their prior plane, its updates maximise the
    /// prior-weighted score where a pixel has a prior. The prior planes are in `prior`.
    Planar,
}

impl PassKind {
    /// The pass coordinate of the random key (see `crate::acmm::cpu::pass_id`).
    pub fn pass_key(self) -> u32 {
        match self {
            PassKind::Photometric | PassKind::Restorer { .. } => pass_id::PHOTOMETRIC,
            PassKind::Geometric(g) => pass_id::geometric(g),
            PassKind::Planar => pass_id::PLANAR,
        }
    }

    /// `GpuParams::restorer` for passes of this kind.
    pub fn restorer_code(self) -> u32 {
        match self {
            PassKind::Restorer { gated: true } => 1,
            PassKind::Restorer { gated: false } => 2,
            _ => 0,
        }
    }
}

impl GpuParams {
    pub fn new(
        problem: &ViewProblem,
        params: &Params,
        method: Method,
        pass: u32,
        iteration: u32,
        color: u32,
    ) -> GpuParams {
        let terms = PriorTerms::new(params, problem.depth_min, problem.depth_max);
        GpuParams {
            prior: match (pass == pass_id::PLANAR, params.prior_everywhere) {
                (false, _)
                    if pass_id::is_geometric(pass)
                        && params.prior_holds_in(method, pass_id::geometric_pass(pass)) =>
                {
                    3
                }
                (false, _) => 0,
                (true, true) => 1,
                (true, false) => 2,
            },
            prior_gamma: terms.gamma,
            prior_beta: terms.beta,
            prior_sigma_depth: terms.sigma_depth,
            prior_inv_2sd2: terms.inv_two_sigma_depth2,
            prior_inv_2sn2: terms.inv_two_sigma_normal2,
            prior_threshold: params.prior_cost_threshold,
            prior_init_depth: params.prior_init_depth,
            prior_init_normal_tan: params.prior_init_normal.to_radians().tan(),
            prior_refine_depth: params.prior_refine_depth,
            prior_refine_normal_tan: params.prior_refine_normal.to_radians().tan(),
            selected_base: 0,
            anchors: u32::from(pass == pass_id::PLANAR && params.anchors_on()),
            anchor_weight: params.prior_anchor_weight,
            anchor_views: params.prior_anchor_views,
            anchor_limit: params.prior_consistency,
            confirm_depth: params.fusion_relative_depth,
            confirm_score: u32::from(params.prior_confidence_score),
            flat_ramp: u32::from(params.prior_flat_ramp)
                | (u32::from(params.prior_flat_weighted) << 1),
            prior_keep_unseen: u32::from(params.prior_keep_unseen),
            flat_noise_var: 0.0,
            _pad: [0; 3],
            geometric: u32::from(pass_id::is_geometric(pass)),
            restorer: 0,
            lambda: params.lambda,
            delta: params.delta,
            init_random: 0,
            xi: params.xi,
            coarse_width: 0,
            coarse_height: 0,
            jbu_radius: params.jbu_radius,
            jbu_sigma_spatial: params.jbu_sigma_spatial,
            jbu_sigma_range: params.jbu_sigma_range,
            split: 0,
            ref_layer: 0,
            k: problem.k,
            coarse_k: [1.0, 1.0, 0.0, 0.0],
            width: problem.width,
            height: problem.height,
            num_sources: problem.num_sources() as u32,
            view: problem.key,
            scale: problem.scale,
            pass_id: pass,
            iteration,
            color,
            seed_lo: params.seed as u32,
            seed_hi: (params.seed >> 32) as u32,
            method: u32::from(method == Method::Dwta),
            top_k: params.top_k,
            depth_min: problem.depth_min,
            depth_max: problem.depth_max,
            tau_t: params.tau(iteration),
            tau1: params.tau1,
            beta: params.beta,
            n1: params.n1,
            n2: params.n2,
            sigma_spatial: params.sigma_spatial,
            sigma_color: params.sigma_color,
            kernel: match params.bilateral_kernel {
                BilateralKernel::Laplacian => 0,
                BilateralKernel::Gaussian => 1,
                BilateralKernel::Adaptive => 2,
            },
            window_radius: params.window_radius,
            window_step: params.window_step,
            perturb_depth: params.perturb_depth,
            perturb_normal_tan: params.perturb_normal.tan(),
            median_radius: params.median_radius,
        }
    }
}

/// One reference view's buffers on the GPU, and the passes over them. A solver made by
/// [`GpuViewSolver::new`] owns its problem's images; one made by
/// [`GpuViewSolver::resident`] reads its level's (or batch's) shared images and depth
/// snapshot and lives across a level's stages (a run's state stays on the device).
pub struct GpuViewSolver {
    pub problem_view: u32,
    width: u32,
    height: u32,
    num_sources: usize,
    ref_layer: u32,
    /// The pass parameters (rewritten per dispatch, at offset 0) and the sources after them.
    problem: wgpu::Buffer,
    /// Normal xyz and depth per pixel, bound as two windows (`memory::plane_split`).
    pub plane: wgpu::Buffer,
    pub cost: wgpu::Buffer,
    /// w'(I_j): a layer per source (`max(num_sources, 1)` layers of the view's size), so no
    /// binding grows with the sources.
    pub weights: wgpu::Texture,
    /// [0, n) winner, v_t and flags; from `memory::selected_base(n)` on, the selected-view
    /// masks (one binding: a pass may bind eight storage buffers).
    pub aux: wgpu::Buffer,
    /// [0, n) restorer difference, [n, 2n) reprojection error.
    pub extra: wgpu::Buffer,
    /// The median filter's output before it is stored into the planes.
    scratch: wgpu::Buffer,
    /// Kept planes, as `plane` (two windows).
    pub prior: wgpu::Buffer,
    /// The images and depth snapshot of a solver made by `new` (a resident one reads its
    /// level's).
    own: Option<LevelImages>,
    bind_group: wgpu::BindGroup,
    /// The detail restorer's: the same buffers, the weights read instead of written.
    restore_group: wgpu::BindGroup,
    median_group: wgpu::BindGroup,
    gather: wgpu::BindGroup,
    timer: RefCell<Option<PassTimer>>,
    /// The parameters last written for an open batch, and its generation.
    written: Cell<Option<(u64, GpuParams)>>,
}

impl GpuViewSolver {
    /// A solver over `problem` with its own images (uploaded; layer 0 the reference, layer
    /// j + 1 source j) and an empty depth snapshot in the same layers (`upload_depths`
    /// fills it): tests, benchmarks, one-off views.
    pub fn new(
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
    ) -> Result<GpuViewSolver, GpuError> {
        Self::check(ctx, problem)?;
        let slice = |w: u32, h: u32, offset: u32| {
            let start = offset as usize;
            problem
                .images
                .get(start..start + w as usize * h as usize)
                .ok_or_else(|| GpuError::Validation {
                    what: format!("view {}", problem.view),
                    message: format!(
                        "its images hold {} values, too few for a {w}x{h} image at {offset}",
                        problem.images.len()
                    ),
                })
        };
        let mut views = vec![(
            0,
            problem.width,
            problem.height,
            slice(problem.width, problem.height, 0)?,
        )];
        let mut sources = problem.sources.clone();
        for (j, src) in sources.iter_mut().enumerate() {
            views.push((
                j + 1,
                src.size[0],
                src.size[1],
                slice(src.size[0], src.size[1], src.size[2])?,
            ));
            src.size[3] = j as u32 + 1;
        }
        let own = LevelImages::upload(ctx, &views, views.len())?;
        let mut solver = Self::build(ctx, pipelines, problem, &sources, 0, &own)?;
        solver.own = Some(own);
        Ok(solver)
    }

    /// A solver over view `problem.view` of a level whose images are in `level` (the
    /// problem's own images are not read and may be empty).
    pub fn resident(
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        level: &LevelImages,
    ) -> Result<GpuViewSolver, GpuError> {
        Self::check(ctx, problem)?;
        let mut sources = problem.sources.clone();
        for (src, &v) in sources.iter_mut().zip(&problem.source_views) {
            src.size[2] = 0;
            src.size[3] = level.layer(v)?;
        }
        let ref_layer = level.layer(problem.view as usize)?;
        Self::build(ctx, pipelines, problem, &sources, ref_layer, level)
    }

    fn check(ctx: &GpuContext, problem: &ViewProblem) -> Result<(), GpuError> {
        if problem.num_sources() == 0 {
            return Err(GpuError::Validation {
                what: format!("view {}", problem.view),
                message: "it has no source views; depth cannot be estimated".into(),
            });
        }
        // The memory plan's own figure: a session has checked its plan already, a solver
        // made alone (tests, one-off views) checks its view here.
        let largest = memory::largest_view_buffer(problem.width, problem.height);
        let limit = memory::binding_limit(&ctx.limits);
        if largest > limit {
            return Err(GpuError::Validation {
                what: format!("view {}", problem.view),
                message: format!(
                    "it needs a {} binding, beyond this adapter's {} per storage buffer; lower --max-image-size",
                    memory::mib(largest),
                    memory::mib(limit)
                ),
            });
        }
        let groups = problem.width.div_ceil(8).max(problem.height.div_ceil(8));
        if groups > ctx.limits.max_compute_workgroups_per_dimension {
            return Err(GpuError::Validation {
                what: format!("view {}", problem.view),
                message: format!(
                    "{}x{} needs {groups} workgroups along one axis, beyond this adapter's {}; lower --max-image-size",
                    problem.width, problem.height, ctx.limits.max_compute_workgroups_per_dimension
                ),
            });
        }
        Ok(())
    }

    fn build(
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        sources: &[crate::acmm::problem::GpuSource],
        ref_layer: u32,
        level: &LevelImages,
    ) -> Result<GpuViewSolver, GpuError> {
        let n = problem.pixels() as u64;
        let nsrc = problem.num_sources();
        let mut bytes = bytemuck::bytes_of(&GpuParams::default()).to_vec();
        bytes.extend_from_slice(bytemuck::cast_slice(sources));
        let problem_buffer = ctx.storage_buffer("acmh params and sources", &bytes);
        // Every map starts as zeros made on the device; nothing crosses the bus.
        let plane = ctx.zeroed_storage("plane", n * 16);
        let cost = ctx.zeroed_storage("cost", n * 4);
        let weights = ctx.r32_layers("weights", problem.width, problem.height, nsrc as u32);
        let aux = ctx.zeroed_storage("aux", (memory::selected_base(n) + n) * 4);
        let extra = ctx.zeroed_storage("extra", 2 * n * 4);
        let scratch = ctx.zeroed_storage("median scratch", n * 4);
        // Big enough for the coarse level's planes too (a coarser level has fewer pixels).
        let prior = ctx.zeroed_storage("prior", n * 16);
        let weights_view = array_view(&weights);
        let spares = [
            ctx.zeroed_storage("unused plane window", 16),
            ctx.zeroed_storage("unused prior window", 16),
        ];
        let [plane_lo, plane_hi] = plane_windows(&plane, n, &spares[0]);
        let [prior_lo, prior_hi] = plane_windows(&prior, n, &spares[1]);
        let buffers = [
            (0, problem_buffer.as_entire_buffer_binding()),
            (3, plane_lo.clone()),
            (2, plane_hi.clone()),
            (4, cost.as_entire_buffer_binding()),
            (7, aux.as_entire_buffer_binding()),
            (8, extra.as_entire_buffer_binding()),
            (9, prior_lo),
            (5, prior_hi),
        ];
        let group = |layout: &wgpu::BindGroupLayout, label: &str| {
            let mut entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .map(|(binding, buf)| wgpu::BindGroupEntry {
                    binding: *binding,
                    resource: wgpu::BindingResource::Buffer(buf.clone()),
                })
                .collect();
            for (binding, view) in [
                (1, &level.layers),
                (6, &weights_view),
                (10, &level.depth_read),
            ] {
                entries.push(wgpu::BindGroupEntry {
                    binding,
                    resource: wgpu::BindingResource::TextureView(view),
                });
            }
            entries.push(wgpu::BindGroupEntry {
                binding: 11,
                resource: wgpu::BindingResource::Sampler(&pipelines.sampler),
            });
            ctx.checked(label, || {
                ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(label),
                    layout,
                    entries: &entries,
                })
            })
        };
        let bind_group = group(&pipelines.layout, "acmh")?;
        let restore_group = group(&pipelines.restore_layout, "detail restorer")?;
        let median_group = ctx.buffer_group(
            "median filter",
            &pipelines.median_layout,
            vec![
                (0, problem_buffer.as_entire_buffer_binding()),
                (3, plane_lo.clone()),
                (2, plane_hi.clone()),
                (12, scratch.as_entire_buffer_binding()),
            ],
        )?;
        let gather_uniform = ctx.uniform_buffer(
            "gather params",
            &[
                problem.width,
                problem.height,
                ref_layer,
                memory::plane_split(n) as u32,
            ],
        );
        let gather = ctx.checked("gather bind group", || {
            ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("gather_depth"),
                layout: &pipelines.gather_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: gather_uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Buffer(plane_lo.clone()),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::Buffer(plane_hi.clone()),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(&level.depth_write),
                    },
                ],
            })
        })?;
        Ok(GpuViewSolver {
            problem_view: problem.view,
            width: problem.width,
            height: problem.height,
            num_sources: nsrc,
            ref_layer,
            problem: problem_buffer,
            plane,
            cost,
            weights,
            aux,
            extra,
            scratch,
            prior,
            own: None,
            bind_group,
            restore_group,
            median_group,
            gather,
            timer: RefCell::new(None),
            written: Cell::new(None),
        })
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    pub fn num_sources(&self) -> usize {
        self.num_sources
    }

    /// Bytes of this view's own buffers on the device.
    pub fn bytes(&self) -> u64 {
        [
            &self.plane,
            &self.cost,
            &self.aux,
            &self.extra,
            &self.scratch,
            &self.prior,
        ]
        .iter()
        .map(|b| b.size())
        .sum::<u64>()
            + texture_bytes(&self.weights)
    }

    /// Writes this view's depths (plane w) into its layer of the depth snapshot (for a
    /// resident solver: its level's).
    pub fn gather_depth(&self, ctx: &GpuContext, pipelines: &AcmhPipelines) {
        let (gx, gy) = self.full_groups();
        ctx.record("gather depth", |encoder| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("gather depth"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&pipelines.gather_depth);
            pass.set_bind_group(0, &self.gather, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        });
    }

    /// The coarse level's planes into `prior` (the input of `upsample`), copied on the device.
    pub fn copy_prior_from(&self, ctx: &GpuContext, coarse_plane: &wgpu::Buffer) {
        copy_into(ctx, coarse_plane, &self.prior);
    }

    /// Copies of the per-pixel buffers, made on the device.
    pub fn device_copy(&self, ctx: &GpuContext) -> DeviceCopy {
        DeviceCopy {
            plane: copy_on_device(ctx, "plane copy", &self.plane),
            cost: copy_on_device(ctx, "cost copy", &self.cost),
            weights: texture_copy(ctx, "weights copy", &self.weights),
            aux: copy_on_device(ctx, "aux copy", &self.aux),
            extra: copy_on_device(ctx, "extra copy", &self.extra),
        }
    }

    /// Puts a [`DeviceCopy`] of a solver of the same size back, on the device.
    pub fn restore_copy(&self, ctx: &GpuContext, copy: &DeviceCopy) {
        for (from, to) in [
            (&copy.plane, &self.plane),
            (&copy.cost, &self.cost),
            (&copy.aux, &self.aux),
            (&copy.extra, &self.extra),
        ] {
            copy_into(ctx, from, to);
        }
        copy_texture(ctx, &copy.weights, &self.weights);
    }

    /// The final maps: planes (normal, depth) and costs, nothing else.
    pub fn download_planes_costs(
        &self,
        ctx: &GpuContext,
    ) -> Result<(Vec<[f32; 4]>, Vec<f32>), GpuError> {
        Ok((
            ctx.read_buffer("plane", &self.plane)?,
            ctx.read_buffer("cost", &self.cost)?,
        ))
    }

    /// Pixels of this view.
    fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// Where the selected-view masks are in `aux` and how long they are, in bytes.
    pub fn selected_bytes(&self) -> (u64, u64) {
        let n = self.pixels();
        (memory::selected_base(n) * 4, n * 4)
    }

    /// The aux words' length in `aux`, in bytes (they start at 0).
    pub fn aux_bytes(&self) -> u64 {
        self.pixels() * 4
    }

    /// One of the two extra maps (0 restorer difference or C_init, 1 reprojection error or
    /// C_photo).
    pub fn download_extra_map(&self, ctx: &GpuContext, index: u64) -> Result<Vec<f32>, GpuError> {
        let n = self.pixels() * 4;
        ctx.read_buffer_range("extra map", &self.extra, index * n, n)
    }

    fn dispatch(
        &self,
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        gpu_params: &GpuParams,
        groups: (u32, u32),
        label: &str,
    ) {
        self.dispatch_with(ctx, pipeline, &self.bind_group, gpu_params, groups, label);
    }

    /// `dispatch` with another bind group of the same buffers (the detail restorer's).
    fn dispatch_with(
        &self,
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        gpu_params: &GpuParams,
        groups: (u32, u32),
        label: &str,
    ) {
        let mut p = *gpu_params;
        p.ref_layer = self.ref_layer;
        p.split = memory::plane_split(self.pixels()) as u32;
        p.selected_base = memory::selected_base(self.pixels()) as u32;
        let mut timer = self.timer.borrow_mut();
        if timer.is_none() {
            self.write_params(ctx, &p);
            ctx.record(label, |encoder| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(label),
                    timestamp_writes: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            });
            return;
        }
        // Timed: a submission of its own, waited on.
        ctx.write(&self.problem, 0, std::slice::from_ref(&p));
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        {
            let timestamp_writes = timer.as_mut().and_then(|t| t.begin(label));
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        }
        ctx.queue.submit([encoder.finish()]);
        if let Some(t) = timer.as_mut() {
            t.end(ctx);
        }
    }

    /// Writes the pass's parameters. In an open batch, the write lands before the batch's
    /// next submission; a pass of this view already recorded in it with other parameters
    /// would read the new ones, so the batch is submitted first. A pass with the same
    /// parameters (the median filter's two) shares the write.
    fn write_params(&self, ctx: &GpuContext, p: &GpuParams) {
        let generation = ctx.batch_generation();
        if let (Some(g), Some((last_g, last))) = (generation, self.written.get())
            && g == last_g
        {
            if bytemuck::bytes_of(&last) == bytemuck::bytes_of(p) {
                return;
            }
            ctx.flush();
        }
        ctx.write_for_batch(&self.problem, 0, std::slice::from_ref(p));
        self.written.set(ctx.batch_generation().map(|g| (g, *p)));
    }

    /// Times every following pass (benchmarks); each pass is then waited on.
    pub fn enable_timing(&self, ctx: &GpuContext, max_passes: u32) {
        *self.timer.borrow_mut() = Some(PassTimer::new(ctx, max_passes));
    }

    /// The timings recorded since `enable_timing`, which stops timing.
    pub fn take_timings(&self, ctx: &GpuContext) -> Result<Vec<PassTime>, GpuError> {
        match self.timer.borrow_mut().take() {
            Some(t) => t.finish(ctx),
            None => Ok(Vec::new()),
        }
    }

    fn full_groups(&self) -> (u32, u32) {
        (self.width.div_ceil(8), self.height.div_ceil(8))
    }

    /// Section 4.1 on every pixel.
    pub fn random_init(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
    ) {
        let mut p = GpuParams::new(problem, params, Method::Acmh, pass_id::RANDOM_INIT, 0, 0);
        p.init_random = 1;
        self.dispatch(
            ctx,
            &pipelines.for_window(ctx, WindowPass::Initialize, p.window_radius, p.window_step),
            &p,
            self.full_groups(),
            "random_init",
        );
    }

    /// Re-evaluates every pixel's current plane: the start of a geometric pass (its cost with
    /// λΔe, and the reprojection-error map; needs `upload_depths` first) or of the gated
    /// detail restorer (the upsampled plane's cost, kept as C_init).
    pub fn evaluate(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
        kind: PassKind,
    ) {
        let mut p = GpuParams::new(problem, params, Method::Acmh, kind.pass_key(), 0, 0);
        p.restorer = kind.restorer_code();
        self.dispatch(
            ctx,
            &pipelines.for_window(ctx, WindowPass::Initialize, p.window_radius, p.window_step),
            &p,
            self.full_groups(),
            "evaluate",
        );
    }

    /// Measures each pixel's mean reprojection error (geometric passes, for display) without
    /// touching the planes; needs `upload_depths` first.
    pub fn measure(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
    ) {
        self.measure_errors(ctx, pipelines, problem, params, 2, "measure");
    }

    /// Measures each pixel's least reprojection error over its sources (the planar prior's
    /// multi-view check of support points) into the error map, without touching the planes;
    /// reads the level's depth snapshot.
    pub fn measure_consistency(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
    ) {
        self.measure_errors(ctx, pipelines, problem, params, 3, "measure consistency");
    }

    /// Marks the pixels whose depth is no distinct minimum of their matching cost along
    /// their ray (`init_random` 4; `crate::acmm::planar::distinct_minimum`): their least
    /// reprojection error in the second extra map becomes
    /// [`AMBIGUOUS_ERROR`](crate::acmm::planar::AMBIGUOUS_ERROR), so that no
    /// anchor sits on them.
    pub fn mark_ambiguous(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
    ) {
        self.measure_errors(ctx, pipelines, problem, params, 4, "distinct minimum");
    }

    /// Marks the pixels fewer than `views` sources agree with (reprojection error below
    /// `prior_consistency`; `init_random` 5, `crate::acmm::planar::mark_few_views`) as
    /// [`AMBIGUOUS_ERROR`](crate::acmm::planar::AMBIGUOUS_ERROR).
    pub fn mark_few_views(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
        views: u32,
    ) {
        let asked = Params {
            prior_anchor_views: views,
            ..params.clone()
        };
        self.measure_errors(ctx, pipelines, problem, &asked, 5, "agreeing views");
    }

    /// Gives every consistent pixel of the error map its confirmation key, lower the more
    /// sources agree (`init_random` 7, `crate::acmm::planar::rank_confirmed`): what the
    /// support points rank by with `prior_confirmed_points`; needs `measure_consistency`
    /// first.
    pub fn rank_confirmed(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
    ) {
        self.measure_errors(ctx, pipelines, problem, params, 7, "confirming views");
    }

    /// Each pixel's spread of the reference intensities over its whole window into the
    /// first extra map (`init_random` 6, `crate::acmm::planar::window_spread`): what the
    /// flat-window support points read (`prior_flat_points`). `noise_var` (grey levels²) is
    /// taken from each window's variance first (`prior_flat_noise`,
    /// `crate::acmm::planar::flat_noise_variance`; 0 for none).
    pub fn measure_spread(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
        noise_var: f32,
    ) {
        let mut p = GpuParams::new(problem, params, Method::Acmh, pass_id::geometric(0), 0, 0);
        p.flat_noise_var = noise_var;
        self.measure_with(ctx, pipelines, p, 6, "window spread");
    }

    /// The initialisation pass in one of its measuring modes (`init_random` 2: mean error, 3:
    /// least error, 4: the distinct-minimum mark, 5: the agreeing-views mark, 6: the
    /// windows' spread, 7: the confirmation key).
    fn measure_errors(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
        mode: u32,
        label: &str,
    ) {
        let p = GpuParams::new(problem, params, Method::Acmh, pass_id::geometric(0), 0, 0);
        self.measure_with(ctx, pipelines, p, mode, label);
    }

    /// [`Self::measure_errors`] with the pass's parameters given.
    fn measure_with(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        mut p: GpuParams,
        mode: u32,
        label: &str,
    ) {
        p.init_random = mode;
        self.dispatch(
            ctx,
            &pipelines.for_window(ctx, WindowPass::Initialize, p.window_radius, p.window_step),
            &p,
            self.full_groups(),
            label,
        );
    }

    /// Joint bilateral upsampling of the coarse planes (already in `prior` via
    /// `upload_prior`) into `plane`, which is then also kept in `prior` for the restorer.
    pub fn upsample(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
        coarse_size: (u32, u32),
        coarse_k: [f32; 4],
    ) {
        let mut p = GpuParams::new(problem, params, Method::Acmh, 0, 0, 0);
        p.coarse_k = coarse_k;
        p.coarse_width = coarse_size.0;
        p.coarse_height = coarse_size.1;
        self.dispatch(
            ctx,
            &pipelines.joint_bilateral_upsample,
            &p,
            self.full_groups(),
            "joint_bilateral_upsample",
        );
        // The upsampled planes stay in `prior`: C_init's planes for the restorer.
        copy_into(ctx, &self.plane, &self.prior);
    }

    /// The detail restorer's last step, for a pass of `kind`. After a `PassKind::Restorer`
    /// pass it writes C_init − C_photo (and, ungated, marks the pixels where it exceeds ξ as
    /// replaced). After a photometric pass from random planes it compares the upsampled
    /// planes (`prior`) with the basic model's (`plane`) and keeps the upsampled ones except
    /// where they are errors in the details.
    pub fn restore(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
        kind: PassKind,
    ) {
        let mut p = GpuParams::new(problem, params, Method::Acmh, 0, 0, 0);
        p.restorer = kind.restorer_code();
        self.dispatch_with(
            ctx,
            &pipelines.detail_restorer,
            &self.restore_group,
            &p,
            self.full_groups(),
            "detail_restorer",
        );
    }

    /// The sources' current depth maps, laid out like the problem's images, into the depth
    /// snapshot of a solver made by `new` (a resident one reads its level's; this then does
    /// nothing).
    pub fn upload_depths(&self, ctx: &GpuContext, problem: &ViewProblem, depths: &[f32]) {
        let Some(own) = &self.own else {
            return;
        };
        for (j, src) in problem.sources.iter().enumerate() {
            let start = src.size[2] as usize;
            let n = src.size[0] as usize * src.size[1] as usize;
            if let Some(d) = depths.get(start..start + n) {
                // Layer j + 1 is source j's (see `new`).
                let _ = own.write_depth(ctx, j + 1, d);
            }
        }
    }

    /// The per-pixel prior planes (the planar prior's, or the upsampled planes), read back.
    pub fn download_prior(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        ctx.read_buffer("prior", &self.prior)
    }

    /// Planes into `prior` (the coarse level's, before `upsample`).
    pub fn upload_prior(&self, ctx: &GpuContext, planes: &[[f32; 4]]) {
        ctx.write(&self.prior, 0, planes);
    }

    /// Sets the two extra maps `download_extra` reads (tests; the inspector's replays).
    pub fn upload_extra(&self, ctx: &GpuContext, first: &[f32], second: &[f32]) {
        ctx.write(&self.extra, 0, first);
        ctx.write(&self.extra, self.pixels() * 4, second);
    }

    /// The restorer's difference map and the mean reprojection-error map (during the gated
    /// restorer pass: C_init and the lowest photometric cost found so far).
    pub fn download_extra(&self, ctx: &GpuContext) -> Result<(Vec<f32>, Vec<f32>), GpuError> {
        let n = self.pixels() as usize;
        let mut both: Vec<f32> =
            ctx.read_buffer_range("extra maps", &self.extra, 0, n as u64 * 8)?;
        let second = both.split_off(n);
        Ok((both, second))
    }

    /// One half-iteration (`color` 0 red, 1 black) of iteration `iteration` (1-based).
    #[allow(clippy::too_many_arguments)]
    pub fn propagate(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
        method: Method,
        iteration: u32,
        color: u32,
    ) {
        let kind = PassKind::Photometric;
        self.propagate_kind(
            ctx, pipelines, problem, params, method, kind, iteration, color,
        );
    }

    /// A half-iteration of any kind (geometric needs `upload_depths` first; the restorer's
    /// needs its `evaluate` first).
    #[allow(clippy::too_many_arguments)]
    pub fn propagate_kind(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
        method: Method,
        kind: PassKind,
        iteration: u32,
        color: u32,
    ) {
        let mut p = GpuParams::new(problem, params, method, kind.pass_key(), iteration, color);
        p.restorer = kind.restorer_code();
        let groups = (self.width.div_ceil(2).div_ceil(8), self.height.div_ceil(8));
        let label = format!(
            "iteration {iteration} {}",
            if color == 0 { "red" } else { "black" }
        );
        let pipeline = pipelines.for_window(
            ctx,
            WindowPass::Checkerboard,
            p.window_radius,
            p.window_step,
        );
        self.dispatch(ctx, &pipeline, &p, groups, &label);
    }

    /// The final median filter on depth.
    pub fn median_filter(
        &self,
        ctx: &GpuContext,
        pipelines: &AcmhPipelines,
        problem: &ViewProblem,
        params: &Params,
    ) {
        let p = GpuParams::new(problem, params, Method::Acmh, 0, 0, 0);
        self.dispatch_with(
            ctx,
            &pipelines.median,
            &self.median_group,
            &p,
            self.full_groups(),
            "median_filter",
        );
        self.dispatch_with(
            ctx,
            &pipelines.median_store,
            &self.median_group,
            &p,
            self.full_groups(),
            "median_store",
        );
    }

    /// Replaces the per-pixel state (tests, checkpoints).
    pub fn upload_state(&self, ctx: &GpuContext, state: &ViewState) {
        ctx.write(&self.plane, 0, &state.plane);
        ctx.write(&self.cost, 0, &state.cost);
        ctx.write(&self.aux, self.selected_bytes().0, &state.selected);
        let n = self.width as usize * self.height as usize;
        let layers = weights_to_layers(&state.weights, n, self.num_sources);
        self.upload_weight_layers(ctx, &layers);
        ctx.write(&self.aux, 0, &state.aux);
    }

    /// Asks for the per-pixel state (see [`GpuContext::read_later`]).
    pub fn request_state(&self, ctx: &GpuContext) -> StateReads {
        let read = |what: &str, b: &wgpu::Buffer| ctx.read_later(what, b, 0, b.size());
        let (at, len) = self.selected_bytes();
        StateReads {
            width: self.width,
            height: self.height,
            num_sources: self.num_sources,
            plane: read("plane", &self.plane),
            cost: read("cost", &self.cost),
            selected: ctx.read_later("selected", &self.aux, at, len),
            weights: self.request_weight_layers(ctx),
            aux: ctx.read_later("aux", &self.aux, 0, self.aux_bytes()),
        }
    }

    /// Asks for the weights, layer after layer (source j's at j·n).
    pub fn request_weight_layers(&self, ctx: &GpuContext) -> crate::gpu::Readback {
        let layers = self.num_sources.max(1) as u32;
        ctx.read_layers_later(
            "weights",
            &self.weights,
            0,
            (self.width, self.height, layers),
        )
    }

    /// Writes the weights, layer after layer (as [`GpuViewSolver::request_weight_layers`]
    /// gives them).
    pub fn upload_weight_layers(&self, ctx: &GpuContext, layers: &[f32]) {
        let count = (layers.len() / (self.width as usize * self.height as usize).max(1)) as u32;
        ctx.write_layers(
            &self.weights,
            0,
            (
                self.width,
                self.height,
                count.min(self.num_sources.max(1) as u32),
            ),
            bytemuck::cast_slice(layers),
        );
    }

    /// Asks for one of the two extra maps (see [`GpuViewSolver::download_extra_map`]).
    pub fn request_extra_map(&self, ctx: &GpuContext, index: u64) -> crate::gpu::Readback {
        let n = self.pixels() * 4;
        ctx.read_later("extra map", &self.extra, index * n, n)
    }

    /// Reads the per-pixel state back.
    pub fn download_state(&self, ctx: &GpuContext) -> Result<ViewState, GpuError> {
        let (at, len) = self.selected_bytes();
        Ok(ViewState {
            width: self.width,
            height: self.height,
            num_sources: self.num_sources,
            plane: ctx.read_buffer("plane", &self.plane)?,
            cost: ctx.read_buffer("cost", &self.cost)?,
            selected: ctx.read_buffer_range("selected", &self.aux, at, len)?,
            weights: weights_from_layers(
                &self.request_weight_layers(ctx).wait::<f32>(ctx)?,
                self.width as usize * self.height as usize,
                self.num_sources,
            ),
            aux: ctx.read_buffer_range("aux", &self.aux, 0, self.aux_bytes())?,
        })
    }
}

/// The two windows a vec4 map of `pixels` pixels (planes, prior planes) is bound as: pixels
/// [0, split) and [split, n) (`memory::plane_split`). A map too small to split is bound
/// whole in the first; the second is then `spare` (never read; a buffer of its own, as
/// WebGPU forbids overlapping bindings of a buffer where one is writable).
pub fn plane_windows<'a>(
    buffer: &'a wgpu::Buffer,
    pixels: u64,
    spare: &'a wgpu::Buffer,
) -> [wgpu::BufferBinding<'a>; 2] {
    let split = memory::plane_split(pixels);
    let window = |offset: u64, len: u64| wgpu::BufferBinding {
        buffer,
        offset,
        size: wgpu::BufferSize::new(len.max(16)),
    };
    if split >= pixels {
        return [window(0, pixels * 16), spare.as_entire_buffer_binding()];
    }
    [
        window(0, split * 16),
        window(split * 16, (pixels - split) * 16),
    ]
}

/// Per-pixel weights (`ViewState::weights`, pixel i's source j at i·nsrc + j) as texture
/// layers (source j's at j·n).
pub fn weights_to_layers(weights: &[f32], n: usize, nsrc: usize) -> Vec<f32> {
    let mut out = vec![0.0; n * nsrc];
    for (i, w) in weights.chunks_exact(nsrc.max(1)).enumerate().take(n) {
        for (j, &v) in w.iter().enumerate() {
            out[j * n + i] = v;
        }
    }
    out
}

/// Texture layers back to per-pixel weights (the layers past `nsrc`, a view without
/// sources' one layer, dropped).
pub fn weights_from_layers(layers: &[f32], n: usize, nsrc: usize) -> Vec<f32> {
    let mut out = vec![0.0; n * nsrc];
    for j in 0..nsrc {
        for (i, &v) in layers.iter().skip(j * n).take(n).enumerate() {
            out[i * nsrc + j] = v;
        }
    }
    out
}

/// A view's per-pixel state on its way back from the device.
pub struct StateReads {
    width: u32,
    height: u32,
    num_sources: usize,
    plane: crate::gpu::Readback,
    cost: crate::gpu::Readback,
    selected: crate::gpu::Readback,
    weights: crate::gpu::Readback,
    aux: crate::gpu::Readback,
}

impl StateReads {
    /// The read-backs' arrival flags.
    pub fn flags(&self) -> Vec<crate::gpu::ReadyFlag> {
        [
            &self.plane,
            &self.cost,
            &self.selected,
            &self.weights,
            &self.aux,
        ]
        .iter()
        .map(|r| r.flag())
        .collect()
    }

    /// The state once every read-back has arrived.
    pub fn values(&self, ctx: &GpuContext) -> Result<ViewState, GpuError> {
        Ok(ViewState {
            width: self.width,
            height: self.height,
            num_sources: self.num_sources,
            plane: self.plane.values_after(ctx)?,
            cost: self.cost.values_after(ctx)?,
            selected: self.selected.values_after(ctx)?,
            weights: weights_from_layers(
                &self.weights.values_after::<f32>(ctx)?,
                self.width as usize * self.height as usize,
                self.num_sources,
            ),
            aux: self.aux.values_after(ctx)?,
        })
    }
}

/// Runs ACMH (or DWTA) on one view on the GPU: init, `params.iterations` red-black iterations,
/// median filter; returns the final state.
pub fn run_view(
    ctx: &GpuContext,
    pipelines: &AcmhPipelines,
    problem: &ViewProblem,
    params: &Params,
    method: Method,
) -> Result<ViewState, GpuError> {
    let solver = GpuViewSolver::new(ctx, pipelines, problem)?;
    solver.random_init(ctx, pipelines, problem, params);
    for t in 1..=params.iterations {
        solver.propagate(ctx, pipelines, problem, params, method, t, 0);
        solver.propagate(ctx, pipelines, problem, params, method, t, 1);
    }
    solver.median_filter(ctx, pipelines, problem, params);
    solver.download_state(ctx)
}
