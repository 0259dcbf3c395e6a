//! The compiled passes: every ACMH/ACMM pipeline and their shared bind group layout (the
//! generic matching pipelines, and those made per matching window on first use), the
//! depth-gathering pipeline and the planar prior's.

use super::*;

/// The compiled passes and their shared bind group layout (create once per device).
pub struct AcmhPipelines {
    /// Every pass's bindings: the weights (binding 6) written.
    pub layout: wgpu::BindGroupLayout,
    /// The detail restorer's: the same with the weights read (a sampled texture).
    pub restore_layout: wgpu::BindGroupLayout,
    /// The median filter's: the parameters, the planes' two windows and its scratch map.
    pub median_layout: wgpu::BindGroupLayout,
    /// Nearest, clamp to edge: the matching cost's `textureGather`.
    pub sampler: wgpu::Sampler,
    pub initialize: wgpu::ComputePipeline,
    pub adaptive_checkerboard: wgpu::ComputePipeline,
    pub median: wgpu::ComputePipeline,
    pub median_store: wgpu::ComputePipeline,
    pub joint_bilateral_upsample: wgpu::ComputePipeline,
    pub detail_restorer: wgpu::ComputePipeline,
    /// Copies a view's depths (plane w) into a level's depth snapshot (shaders/gather_depth.wgsl).
    pub gather_depth: wgpu::ComputePipeline,
    pub gather_layout: wgpu::BindGroupLayout,
    /// The planar prior's passes (shaders/planar_prior.wgsl).
    pub planar: crate::gpu::planar::PlanarPipelines,
    /// What the matching passes are re-made from for one window ([`AcmhPipelines::for_window`]).
    pub(super) pipeline_layout: wgpu::PipelineLayout,
    pub(super) initialize_module: wgpu::ShaderModule,
    pub(super) checkerboard_module: wgpu::ShaderModule,
    /// Matching passes made for one window (radius, step), as they are first needed.
    pub(super) by_window: Mutex<HashMap<(u32, u32), [wgpu::ComputePipeline; 2]>>,
    /// Whether passes use [`AcmhPipelines::for_window`] (on) or the generic pipelines, which
    /// read the window from the parameters (tests compare the two).
    pub(super) specialise: AtomicBool,
}

/// A compute pipeline from `module`'s `entry` with pipeline-overridable `constants`; a
/// validation error becomes a [`GpuError`] naming the pipeline.
pub(crate) fn compute_pipeline(
    ctx: &GpuContext,
    layout: &wgpu::PipelineLayout,
    name: &str,
    module: &wgpu::ShaderModule,
    entry: &str,
    constants: &[(&str, f64)],
) -> Result<wgpu::ComputePipeline, GpuError> {
    ctx.checked(&format!("pipeline {name}::{entry} {constants:?}"), || {
        ctx.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(layout),
                module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                cache: None,
            })
    })
}

/// A matching pass that has a pipeline per window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindowPass {
    /// shaders/initialize.wgsl
    Initialize,
    /// shaders/adaptive_checkerboard.wgsl
    Checkerboard,
}

/// Storage buffers one pass binds; adapters must allow this many per shader stage. The
/// parameters are one of them, not a uniform buffer: Mesa's lavapipe (22.x) inlines uniform
/// values into a new shader variant at every dispatch of the matching kernels and never frees
/// it (~1.5 MB per dispatch, whatever the image size: 35 MiB per ACMH run of 160x120, with
/// the sessions' own memory flat). As a read-only storage buffer the same bytes give
/// identical results and no growth.
pub const STORAGE_BUFFERS: u32 = 8;

impl AcmhPipelines {
    pub fn new(ctx: &GpuContext) -> Result<AcmhPipelines, GpuError> {
        let mut entries = vec![storage_entry(0, true)];
        if ctx.limits.max_storage_buffers_per_shader_stage < STORAGE_BUFFERS {
            return Err(GpuError::Validation {
                what: "ACMH passes".into(),
                message: format!(
                    "they bind {STORAGE_BUFFERS} storage buffers but this adapter allows {} per stage; use a Vulkan, Metal or DX12 adapter",
                    ctx.limits.max_storage_buffers_per_shader_stage
                ),
            });
        }
        entries.push(crate::gpu::texture_array_entry(1));
        // The planes' two windows (3, 2), cost, aux and masks, the extra maps, the prior
        // planes' two windows (9, 5): shaders/shared/problem.wgsl.
        for b in [2, 3, 4, 5, 7, 8, 9] {
            entries.push(storage_entry(b, false));
        }
        // The depth snapshot (sampled) and the sampler.
        entries.push(crate::gpu::texture_array_entry(10));
        entries.push(crate::gpu::sampler_entry(11));
        let with_weights = |weights: wgpu::BindGroupLayoutEntry, label: &str| {
            let mut all = entries.clone();
            all.push(weights);
            ctx.checked(label, || {
                ctx.device
                    .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                        label: Some(label),
                        entries: &all,
                    })
            })
        };
        let layout = with_weights(
            crate::gpu::storage_texture_array_entry(6),
            "ACMH bind group layout",
        )?;
        let restore_layout = with_weights(
            crate::gpu::texture_array_entry(6),
            "detail restorer bind group layout",
        )?;
        let restore_pipeline_layout =
            ctx.device
                .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("detail restorer"),
                    bind_group_layouts: &[Some(&restore_layout)],
                    immediate_size: 0,
                });
        let pipeline_layout = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("acmh"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let from_module = |name: &str, module: &wgpu::ShaderModule, entry: &str| {
            compute_pipeline(ctx, &pipeline_layout, name, module, entry, &[])
        };
        let make =
            |name: &str, source: &str, entry: &str| -> Result<wgpu::ComputePipeline, GpuError> {
                let module = shader::create_module(ctx, name, source)?;
                from_module(name, &module, entry)
            };
        let initialize_module = shader::create_module(
            ctx,
            "initialize",
            include_str!("../../../shaders/initialize.wgsl"),
        )?;
        let checkerboard_module = shader::create_module(
            ctx,
            "adaptive_checkerboard",
            include_str!("../../../shaders/adaptive_checkerboard.wgsl"),
        )?;
        let median_src = include_str!("../../../shaders/median_filter.wgsl");
        let median_entries = [
            storage_entry(0, true),
            storage_entry(2, false),
            storage_entry(3, false),
            storage_entry(12, false),
        ];
        let (median_layout, median_pipeline_layout) =
            ctx.layouts("median_filter", &median_entries)?;
        let median_module = shader::create_module(ctx, "median_filter", median_src)?;
        let median_pipeline = |entry: &str| {
            compute_pipeline(
                ctx,
                &median_pipeline_layout,
                "median_filter",
                &median_module,
                entry,
                &[],
            )
        };
        let gather_entries = [
            uniform_entry(0),
            storage_entry(1, true),
            storage_entry(3, true),
            crate::gpu::storage_texture_array_entry(2),
        ];
        let (gather_layout, gather_pipeline_layout) =
            ctx.layouts("gather_depth", &gather_entries)?;
        let gather_module = shader::create_module(
            ctx,
            "gather_depth",
            include_str!("../../../shaders/gather_depth.wgsl"),
        )?;
        let gather_depth = compute_pipeline(
            ctx,
            &gather_pipeline_layout,
            "gather_depth",
            &gather_module,
            "main",
            &[],
        )?;
        // Clamp to edge and nearest: `textureGather` then returns the four texels of a
        // bilinear footprint exactly as `bilinear` in src/acmm/cpu.rs clamps them.
        let sampler = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("images"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            address_mode_w: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Nearest,
            min_filter: wgpu::FilterMode::Nearest,
            mipmap_filter: wgpu::MipmapFilterMode::Nearest,
            ..Default::default()
        });
        Ok(AcmhPipelines {
            planar: crate::gpu::planar::PlanarPipelines::new(ctx)?,
            sampler,
            gather_depth,
            gather_layout,
            initialize: from_module("initialize", &initialize_module, "main")?,
            joint_bilateral_upsample: make(
                "joint_bilateral_upsample",
                include_str!("../../../shaders/joint_bilateral_upsample.wgsl"),
                "main",
            )?,
            detail_restorer: compute_pipeline(
                ctx,
                &restore_pipeline_layout,
                "detail_restorer",
                &shader::create_module(
                    ctx,
                    "detail_restorer",
                    include_str!("../../../shaders/detail_restorer.wgsl"),
                )?,
                "main",
                &[],
            )?,
            adaptive_checkerboard: from_module(
                "adaptive_checkerboard",
                &checkerboard_module,
                "main",
            )?,
            median: median_pipeline("median")?,
            median_store: median_pipeline("store")?,
            layout,
            restore_layout,
            median_layout,
            pipeline_layout,
            initialize_module,
            checkerboard_module,
            by_window: Mutex::default(),
            specialise: AtomicBool::new(true),
        })
    }

    /// Turns the per-window pipelines on (the default) or off (the generic ones).
    pub fn set_specialise(&self, on: bool) {
        self.specialise.store(on, Ordering::Relaxed);
    }

    /// `pass` for a window of `radius` and `step`: with the window as pipeline constants
    /// (loops of constant bounds, which a driver unrolls), made on first use and kept. The
    /// numbers are the generic pipeline's. With specialisation off, the generic pipeline;
    /// should the per-window ones fail to build, too (said once in the log, and kept for
    /// that window so the build is not tried again).
    pub fn for_window(
        &self,
        ctx: &GpuContext,
        pass: WindowPass,
        radius: u32,
        step: u32,
    ) -> wgpu::ComputePipeline {
        let generic = match pass {
            WindowPass::Initialize => &self.initialize,
            WindowPass::Checkerboard => &self.adaptive_checkerboard,
        };
        if radius == 0 || !self.specialise.load(Ordering::Relaxed) {
            return generic.clone();
        }
        let index = pass as usize;
        let mut cache = self.by_window.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = cache.get(&(radius, step)) {
            return p[index].clone();
        }
        let constants = [
            ("WINDOW_RADIUS", f64::from(radius)),
            ("WINDOW_STEP", f64::from(step.max(1))),
        ];
        let make = |name: &str, module: &wgpu::ShaderModule| {
            compute_pipeline(ctx, &self.pipeline_layout, name, module, "main", &constants)
        };
        match (
            make("initialize", &self.initialize_module),
            make("adaptive_checkerboard", &self.checkerboard_module),
        ) {
            (Ok(a), Ok(b)) => {
                let pipelines = [a, b];
                let chosen = pipelines[index].clone();
                cache.insert((radius, step), pipelines);
                chosen
            }
            (a, b) => {
                if let Some(e) = a.err().or(b.err()) {
                    log::warn!("window {radius}/{step}: the generic matching pipelines run: {e}");
                }
                cache.insert(
                    (radius, step),
                    [self.initialize.clone(), self.adaptive_checkerboard.clone()],
                );
                generic.clone()
            }
        }
    }
}
