//! A level's images and depth snapshot on the device, device copies of a view's buffers
//! (checkpoints), and the copy helpers.

use super::*;

/// A pyramid level's intensities, every view a layer of one texture uploaded once per level,
/// and the depth snapshot the level's geometric passes read (every view's pixels one after
/// the other; a view's depths are gathered on the device when a stage ends).
#[derive(Clone, Debug)]
pub struct LevelImages {
    pub texture: wgpu::Texture,
    /// View v in layer v (what the matching cost samples).
    pub layers: wgpu::TextureView,
    pub depths: wgpu::Buffer,
    /// Where each view's pixels start in `depths` (in values).
    pub offsets: Vec<u32>,
}

impl LevelImages {
    /// What the level holds on the device: its texture and depth snapshot.
    pub fn bytes(&self) -> u64 {
        let t = &self.texture;
        t.width() as u64 * t.height() as u64 * t.depth_or_array_layers() as u64 * 4
            + self.depths.size()
    }

    /// Uploads `views` (width, height and intensities of each, in scene order) and makes a
    /// zeroed depth snapshot.
    pub fn upload(ctx: &GpuContext, views: &[(u32, u32, &[f32])]) -> Result<LevelImages, GpuError> {
        let total: usize = views.iter().map(|v| v.2.len()).sum();
        let bytes = total as u64 * 4;
        let limit = ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size);
        if bytes > limit {
            return Err(GpuError::Validation {
                what: "the level's depth snapshot".into(),
                message: format!(
                    "{} views need a {} MiB buffer, beyond this adapter's limit of {} MiB per storage binding; lower --max-image-size",
                    views.len(),
                    bytes >> 20,
                    limit >> 20
                ),
            });
        }
        let mut offsets = Vec::with_capacity(views.len());
        let mut offset = 0u32;
        for v in views {
            offsets.push(offset);
            offset += v.2.len() as u32;
        }
        let (texture, layers) = ctx.image_layers("the level's images", views)?;
        Ok(LevelImages {
            texture,
            layers,
            depths: ctx.zeroed_storage("level depths", bytes),
            offsets,
        })
    }
}

/// The per-pixel math of shaders/gather_depth.wgsl: a view's depths from its planes.
pub fn gather_depth(plane: &[[f32; 4]]) -> Vec<f32> {
    plane.iter().map(|p| p[3]).collect()
}

/// Copies of a view's per-pixel buffers on the device (a checkpoint: nothing is read back).
#[derive(Clone, Debug)]
pub struct DeviceCopy {
    pub plane: wgpu::Buffer,
    pub cost: wgpu::Buffer,
    pub selected: wgpu::Buffer,
    pub weights: wgpu::Buffer,
    pub aux: wgpu::Buffer,
    pub extra: wgpu::Buffer,
}

impl DeviceCopy {
    pub fn bytes(&self) -> u64 {
        [
            &self.plane,
            &self.cost,
            &self.selected,
            &self.weights,
            &self.aux,
            &self.extra,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }
}

/// Copies `from` into `to` (as much as both hold), on the device.
pub fn copy_into(ctx: &GpuContext, from: &wgpu::Buffer, to: &wgpu::Buffer) {
    ctx.record("copy into", |encoder| {
        encoder.copy_buffer_to_buffer(from, 0, to, 0, from.size().min(to.size()));
    });
}

/// A buffer's copy on the device.
pub fn copy_on_device(ctx: &GpuContext, label: &str, from: &wgpu::Buffer) -> wgpu::Buffer {
    let to = ctx.zeroed_storage(label, from.size());
    ctx.record(label, |encoder| {
        encoder.copy_buffer_to_buffer(from, 0, &to, 0, from.size());
    });
    to
}
