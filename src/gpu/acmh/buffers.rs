//! A level's images and depth snapshot on the device, device copies of a view's buffers
//! (checkpoints), and the copy helpers.

use super::*;

/// The views a level's passes read, each a layer of two textures as large as the largest of
/// them: their intensities (uploaded once) and the depth snapshot the level's geometric
/// passes read (a view's depths are gathered into its layer on the device when a stage ends,
/// or written from the host when its state comes back from it). A run holding every view
/// has them all; a batch has its views and their sources (`crate::acmm::memory`), so no
/// binding grows with the scene.
#[derive(Clone, Debug)]
pub struct LevelImages {
    pub texture: wgpu::Texture,
    /// View v in layer `layer_of[v]` (what the matching cost samples).
    pub layers: wgpu::TextureView,
    /// The depth snapshot, in the same layers.
    pub depth: wgpu::Texture,
    /// `depth` as the passes read it (sampled) and as the gathering writes it (storage).
    pub depth_read: wgpu::TextureView,
    pub depth_write: wgpu::TextureView,
    /// Each scene view's layer (`None`: not held).
    pub layer_of: Vec<Option<u32>>,
    /// Each layer's view size.
    pub sizes: Vec<(u32, u32)>,
}

impl LevelImages {
    /// What the level holds on the device: its two textures.
    pub fn bytes(&self) -> u64 {
        let t = &self.texture;
        t.width() as u64 * t.height() as u64 * t.depth_or_array_layers() as u64 * 8
    }

    /// Uploads `views` (scene index, width, height and intensities of each) of a scene of
    /// `scene_views` views, and makes a zeroed depth snapshot of their layers.
    pub fn upload(
        ctx: &GpuContext,
        views: &[(usize, u32, u32, &[f32])],
        scene_views: usize,
    ) -> Result<LevelImages, GpuError> {
        let mut layer_of = vec![None; scene_views];
        for (layer, v) in views.iter().enumerate() {
            let slot = layer_of.get_mut(v.0).ok_or_else(|| GpuError::Validation {
                what: "the level's images".into(),
                message: format!("view {} of a scene of {scene_views}", v.0),
            })?;
            *slot = Some(layer as u32);
        }
        let images: Vec<(u32, u32, &[f32])> = views.iter().map(|v| (v.1, v.2, v.3)).collect();
        let (texture, layers) = ctx.image_layers("the level's images", &images)?;
        let depth = ctx.r32_layers(
            "depth snapshot",
            texture.width(),
            texture.height(),
            texture.depth_or_array_layers(),
        );
        // Zeros: no depth anywhere until a stage ends (a texture starts zeroed in wgpu).
        Ok(LevelImages {
            depth_read: array_view(&depth),
            depth_write: array_view(&depth),
            depth,
            texture,
            layers,
            layer_of,
            sizes: views.iter().map(|v| (v.1, v.2)).collect(),
        })
    }

    /// View `view`'s layer, or an error naming it.
    pub fn layer(&self, view: usize) -> Result<u32, GpuError> {
        self.layer_of
            .get(view)
            .copied()
            .flatten()
            .ok_or_else(|| GpuError::Validation {
                what: format!("view {view}"),
                message: "it is not among the views held on the device".into(),
            })
    }

    /// Writes `depth` (the view's size) into `view`'s layer of the snapshot.
    pub fn write_depth(
        &self,
        ctx: &GpuContext,
        view: usize,
        depth: &[f32],
    ) -> Result<(), GpuError> {
        let layer = self.layer(view)?;
        let (w, h) = self.sizes[layer as usize];
        if depth.len() != w as usize * h as usize {
            return Err(GpuError::Validation {
                what: format!("view {view}'s depth"),
                message: format!("{} values for a {w}x{h} view", depth.len()),
            });
        }
        ctx.write_layers(&self.depth, layer, (w, h, 1), bytemuck::cast_slice(depth));
        Ok(())
    }

    /// Asks for `view`'s layer of the snapshot (its size).
    pub fn request_depth(
        &self,
        ctx: &GpuContext,
        view: usize,
    ) -> Result<crate::gpu::Readback, GpuError> {
        let layer = self.layer(view)?;
        let (w, h) = self.sizes[layer as usize];
        Ok(ctx.read_layers_later("depth snapshot", &self.depth, layer, (w, h, 1)))
    }
}

/// A 2D-array view of every layer of `t`.
pub fn array_view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

/// Copies every layer of `from` into `to` (textures of the same size), on the device.
pub fn copy_texture(ctx: &GpuContext, from: &wgpu::Texture, to: &wgpu::Texture) {
    ctx.record("copy texture", |encoder| {
        encoder.copy_texture_to_texture(
            from.as_image_copy(),
            to.as_image_copy(),
            wgpu::Extent3d {
                width: from.width().min(to.width()),
                height: from.height().min(to.height()),
                depth_or_array_layers: from.depth_or_array_layers().min(to.depth_or_array_layers()),
            },
        );
    });
}

/// A texture's copy on the device.
pub fn texture_copy(ctx: &GpuContext, label: &str, from: &wgpu::Texture) -> wgpu::Texture {
    let to = ctx.r32_layers(
        label,
        from.width(),
        from.height(),
        from.depth_or_array_layers(),
    );
    copy_texture(ctx, from, &to);
    to
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
    /// A layer per source (see [`GpuViewSolver`]).
    pub weights: wgpu::Texture,
    /// The aux words and the selected-view masks (see [`GpuViewSolver::aux`]).
    pub aux: wgpu::Buffer,
    pub extra: wgpu::Buffer,
}

impl DeviceCopy {
    pub fn bytes(&self) -> u64 {
        [&self.plane, &self.cost, &self.aux, &self.extra]
            .iter()
            .map(|b| b.size())
            .sum::<u64>()
            + texture_bytes(&self.weights)
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
    copy_start_on_device(ctx, label, from, from.size())
}

/// A copy of a buffer's first `bytes` (a multiple of 4), on the device.
pub fn copy_start_on_device(
    ctx: &GpuContext,
    label: &str,
    from: &wgpu::Buffer,
    bytes: u64,
) -> wgpu::Buffer {
    let bytes = bytes.min(from.size());
    let to = ctx.zeroed_storage(label, bytes);
    ctx.record(label, |encoder| {
        encoder.copy_buffer_to_buffer(from, 0, &to, 0, bytes);
    });
    to
}

/// Bytes of an r32float texture.
pub fn texture_bytes(t: &wgpu::Texture) -> u64 {
    t.width() as u64 * t.height() as u64 * t.depth_or_array_layers() as u64 * 4
}
