//! Smoke kernel: projects world points through a camera on the GPU (shaders/smoke_project.wgsl).
//! It proves the whole path — adapter, shader preprocessing, buffers, dispatch, readback — and
//! that the shared camera include agrees with `Camera::project`, its CPU reference.

use glam::DVec3;

use super::types::GpuCamera;
use super::{GpuContext, GpuError, shader};
use crate::camera::Camera;

/// A projected point: pixel, depth, and whether it is in front of the camera and on the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projected {
    pub pixel: [f32; 2],
    pub depth: f32,
    pub visible: bool,
}

/// CPU reference of the kernel's per-point math.
pub fn project_cpu(camera: &Camera, points: &[DVec3]) -> Vec<Projected> {
    points
        .iter()
        .map(|&p| {
            let depth = camera.camera_from_world(p).z;
            match camera.project(p) {
                Some((pixel, _)) => Projected {
                    pixel: [pixel.x as f32, pixel.y as f32],
                    depth: depth as f32,
                    visible: camera.contains(pixel),
                },
                None => Projected {
                    pixel: [0.0, 0.0],
                    depth: depth as f32,
                    visible: false,
                },
            }
        })
        .collect()
}

/// Runs the kernel.
pub fn project_gpu(
    ctx: &GpuContext,
    camera: &Camera,
    points: &[DVec3],
) -> Result<Vec<Projected>, GpuError> {
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let module = shader::create_module(
        ctx,
        "smoke_project",
        include_str!("../../shaders/smoke_project.wgsl"),
    )?;
    let pipeline = ctx.checked("smoke_project pipeline", || {
        ctx.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("smoke_project"),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            })
    })?;
    let cam = ctx.uniform_buffer("camera", &GpuCamera::from(camera));
    let input: Vec<[f32; 4]> = points
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
        .collect();
    let input = ctx.storage_buffer("points", &input);
    // Garbage, not zeros: the kernel must write every element.
    let output = ctx.storage_buffer("projected", &vec![[f32::NAN; 4]; points.len()]);
    let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("smoke_project"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: cam.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("smoke_project"),
        });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("smoke_project"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((points.len() as u32).div_ceil(64), 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    let raw: Vec<[f32; 4]> = ctx.read_buffer("projected points", &output)?;
    Ok(raw
        .into_iter()
        .map(|v| Projected {
            pixel: [v[0], v[1]],
            depth: v[2],
            visible: v[3] > 0.5,
        })
        .collect())
}
