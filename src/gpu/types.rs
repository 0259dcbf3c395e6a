//! `#[repr(C)]` structs shared with WGSL. Keep each in sync with the shader named beside it.

use bytemuck::{Pod, Zeroable};

use crate::camera::Camera;

/// Keep in sync with `struct Camera` in shaders/shared/camera.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCamera {
    /// fx, fy, cx, cy
    pub k: [f32; 4],
    pub r0: [f32; 4],
    pub r1: [f32; 4],
    pub r2: [f32; 4],
    pub t: [f32; 4],
    pub size: [u32; 4],
}

impl From<&Camera> for GpuCamera {
    fn from(cam: &Camera) -> GpuCamera {
        let k = &cam.intrinsics;
        let row = |i: usize| {
            let r = cam.rotation.row(i);
            [r.x as f32, r.y as f32, r.z as f32, 0.0]
        };
        let t = cam.translation;
        GpuCamera {
            k: [k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32],
            r0: row(0),
            r1: row(1),
            r2: row(2),
            t: [t.x as f32, t.y as f32, t.z as f32, 0.0],
            size: [cam.width, cam.height, 0, 0],
        }
    }
}
