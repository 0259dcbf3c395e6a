//! Drawing the cloud with mvscope's own wgpu pipelines: points, camera frusta, the targets
//! per view size, the egui paint callback, and an offscreen render for screenshots and tests.

use super::*;

/// Keep in sync with `Uniforms` in shaders/cloud.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct CloudUniforms {
    pub(super) view_proj: [[f32; 4]; 4],
    pub(super) viewport: [f32; 2],
    pub(super) point_size: f32,
    pub(super) color_mode: u32,
    pub(super) cost_range: [f32; 2],
    pub(super) blit_origin: [f32; 2],
}

/// Everything a frame's uniforms depend on.
#[derive(Clone, Copy, Debug)]
pub(super) struct DrawSettings {
    pub(super) camera: OrbitCamera,
    /// Pixels.
    pub(super) point_size: f32,
    pub(super) color_mode: ColorMode,
    pub(super) cost_range: (f32, f32),
    pub(super) show_frusta: bool,
}

impl DrawSettings {
    fn uniforms(&self, size: [u32; 2], blit_origin: [f32; 2]) -> CloudUniforms {
        let aspect = size[0] as f32 / size[1].max(1) as f32;
        CloudUniforms {
            view_proj: self.camera.view_proj(aspect).to_cols_array_2d(),
            viewport: [size[0] as f32, size[1] as f32],
            point_size: self.point_size,
            color_mode: self.color_mode.index(),
            cost_range: [self.cost_range.0, self.cost_range.1],
            blit_origin,
        }
    }
}

/// A frustum line's end (`vs_line`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct LineVertex {
    pub(super) position: [f32; 3],
    pub(super) color: [f32; 3],
}

/// Four edges from the apex and the four of the image rectangle, as a line list.
pub(super) fn frustum_lines(frusta: &[Frustum]) -> Vec<LineVertex> {
    let mut lines = Vec::with_capacity(frusta.len() * 16);
    for f in frusta {
        let v = |position: [f32; 3]| LineVertex {
            position,
            color: f.color,
        };
        for k in 0..4 {
            lines.push(v(f.apex));
            lines.push(v(f.corners[k]));
            lines.push(v(f.corners[k]));
            lines.push(v(f.corners[(k + 1) % 4]));
        }
    }
    lines
}

/// The offscreen pipelines (points and lines), shared by the callback and [`render_offscreen`].
pub(super) struct Pipelines {
    pub(super) uniform_layout: wgpu::BindGroupLayout,
    pub(super) points: wgpu::RenderPipeline,
    pub(super) lines: wgpu::RenderPipeline,
}

pub(super) fn shader_module(device: &wgpu::Device) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("cloud"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    })
}

impl Pipelines {
    fn new(device: &wgpu::Device, module: &wgpu::ShaderModule) -> Pipelines {
        let uniform_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cloud uniforms"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(
                        std::mem::size_of::<CloudUniforms>() as u64
                    ),
                },
                count: None,
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cloud"),
            bind_group_layouts: &[Some(&uniform_layout)],
            immediate_size: 0,
        });
        let point_attributes = wgpu::vertex_attr_array![
            0 => Float32x3, 1 => Float32, 2 => Float32x3, 3 => Float32x3
        ];
        // `normal` sits after `_pad0`: offsets 0, 12, 16, 32 of CloudVertex.
        let point_attributes = [
            point_attributes[0],
            point_attributes[1],
            point_attributes[2],
            wgpu::VertexAttribute {
                offset: 32,
                ..point_attributes[3]
            },
        ];
        let line_attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
        let pipeline = |label: &str,
                        entry: &str,
                        topology: wgpu::PrimitiveTopology,
                        buffer: wgpu::VertexBufferLayout<'_>| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some(entry),
                    buffers: &[Some(buffer)],
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                },
                primitive: wgpu::PrimitiveState {
                    topology,
                    cull_mode: None,
                    ..wgpu::PrimitiveState::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: wgpu::StencilState::default(),
                    bias: wgpu::DepthBiasState::default(),
                }),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some("fs_color"),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: COLOR_FORMAT,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                    compilation_options: wgpu::PipelineCompilationOptions::default(),
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let points = pipeline(
            "cloud points",
            "vs_point",
            wgpu::PrimitiveTopology::TriangleList,
            wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<CloudVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: &point_attributes,
            },
        );
        let lines = pipeline(
            "cloud frusta",
            "vs_line",
            wgpu::PrimitiveTopology::LineList,
            wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<LineVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &line_attributes,
            },
        );
        Pipelines {
            uniform_layout,
            points,
            lines,
        }
    }
}

/// A vertex buffer that grows as needed.
#[derive(Default)]
pub(super) struct VertexBuffer {
    pub(super) buffer: Option<wgpu::Buffer>,
    pub(super) count: u32,
}

impl VertexBuffer {
    fn write<T: bytemuck::Pod>(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[T]) {
        self.count = 0;
        if data.is_empty() {
            return;
        }
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let size = bytes.len() as u64;
        if self.buffer.as_ref().is_none_or(|b| b.size() < size) {
            self.buffer = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cloud vertices"),
                size,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let Some(buffer) = &self.buffer else {
            return;
        };
        queue.write_buffer(buffer, 0, bytes);
        self.count = data.len().min(u32::MAX as usize) as u32;
    }

    /// The filled part, when there is one.
    fn filled<T>(&self) -> Option<(wgpu::BufferSlice<'_>, u32)> {
        let buffer = self.buffer.as_ref()?;
        if self.count == 0 {
            return None;
        }
        let bytes = self.count as u64 * std::mem::size_of::<T>() as u64;
        Some((buffer.slice(..bytes), self.count))
    }
}

/// One view's offscreen target, uniforms and uploaded scene.
pub(super) struct Target {
    pub(super) size: [u32; 2],
    pub(super) color: wgpu::Texture,
    pub(super) color_view: wgpu::TextureView,
    pub(super) depth_view: wgpu::TextureView,
    pub(super) uniforms: wgpu::Buffer,
    pub(super) uniform_bind_group: wgpu::BindGroup,
    /// The offscreen texture for the blit; rebuilt with the texture.
    pub(super) blit_bind_group: Option<wgpu::BindGroup>,
    pub(super) points: VertexBuffer,
    pub(super) lines: VertexBuffer,
    /// The scene (and its version) the buffers hold; the `Weak` keeps the allocation, so the
    /// pointer cannot be reused by another scene while it is compared.
    pub(super) uploaded: Option<(Weak<CloudScene>, u64)>,
    pub(super) last_used: u64,
    /// What the texture shows (uniforms and frusta switch), until the scene or size changes:
    /// an unchanged view is not drawn again (on a software device a redraw costs as much
    /// as the rest of the frame).
    pub(super) drawn: Option<Vec<u8>>,
}

impl Target {
    fn new(device: &wgpu::Device, pipelines: &Pipelines, size: [u32; 2]) -> Target {
        let (color, color_view, depth_view) = Self::textures(device, size);
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cloud uniforms"),
            size: std::mem::size_of::<CloudUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let uniform_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cloud uniforms"),
            layout: &pipelines.uniform_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        Target {
            size,
            color,
            color_view,
            depth_view,
            uniforms,
            uniform_bind_group,
            blit_bind_group: None,
            points: VertexBuffer::default(),
            lines: VertexBuffer::default(),
            uploaded: None,
            last_used: 0,
            drawn: None,
        }
    }

    fn textures(
        device: &wgpu::Device,
        size: [u32; 2],
    ) -> (wgpu::Texture, wgpu::TextureView, wgpu::TextureView) {
        let extent = wgpu::Extent3d {
            width: size[0],
            height: size[1],
            depth_or_array_layers: 1,
        };
        let texture = |label: &str, format: wgpu::TextureFormat, usage: wgpu::TextureUsages| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: extent,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let color = texture(
            "cloud colour",
            COLOR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture(
            "cloud depth",
            DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let color_view = color.create_view(&wgpu::TextureViewDescriptor::default());
        let depth_view = depth.create_view(&wgpu::TextureViewDescriptor::default());
        (color, color_view, depth_view)
    }

    fn resize(&mut self, device: &wgpu::Device, size: [u32; 2]) {
        if self.size != size {
            (self.color, self.color_view, self.depth_view) = Self::textures(device, size);
            self.size = size;
            self.blit_bind_group = None;
            self.drawn = None;
        }
    }

    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &CloudScene) {
        self.drawn = None;
        self.points.write(device, queue, &scene.points);
        self.lines
            .write(device, queue, &frustum_lines(&scene.frusta));
    }

    /// Uploads `scene` unless this very `Arc` at this version is already there.
    fn upload_if_changed(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Arc<CloudScene>,
    ) {
        let same = self.uploaded.as_ref().is_some_and(|(weak, version)| {
            std::ptr::eq(weak.as_ptr(), Arc::as_ptr(scene)) && *version == scene.version
        });
        if !same {
            self.upload(device, queue, scene);
            self.uploaded = Some((Arc::downgrade(scene), scene.version));
        }
    }

    /// Clears the target and draws points (and frusta) with the uniforms already written.
    fn encode(&self, encoder: &mut wgpu::CommandEncoder, pipelines: &Pipelines, frusta: bool) {
        let [r, g, b] = BACKGROUND.map(f64::from);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("cloud"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.uniform_bind_group, &[]);
        if let Some((slice, count)) = self.points.filled::<CloudVertex>() {
            pass.set_pipeline(&pipelines.points);
            pass.set_vertex_buffer(0, slice);
            pass.draw(0..6, 0..count);
        }
        if frusta && let Some((slice, count)) = self.lines.filled::<LineVertex>() {
            pass.set_pipeline(&pipelines.lines);
            pass.set_vertex_buffer(0, slice);
            pass.draw(0..count, 0..1);
        }
    }
}

/// The 3D view's GPU state in egui's callback resources (see [`install`]).
pub struct CloudResources {
    pub(super) pipelines: Pipelines,
    pub(super) blit: wgpu::RenderPipeline,
    pub(super) texture_layout: wgpu::BindGroupLayout,
    /// One per [`CloudView`] on screen, by its response id.
    pub(super) targets: HashMap<egui::Id, Target>,
    /// Counts `prepare` calls, to drop targets of views no longer shown.
    pub(super) frame: u64,
}

/// Targets not drawn for this many callbacks are freed.
pub(super) const TARGET_TTL: u64 = 120;

impl CloudResources {
    /// Pipelines for an egui render pass on `target_format` with the given depth format and
    /// sample count (what `egui_wgpu::RendererOptions` was made with).
    pub fn new(
        device: &wgpu::Device,
        target_format: wgpu::TextureFormat,
        depth_stencil_format: Option<wgpu::TextureFormat>,
        msaa_samples: u32,
    ) -> CloudResources {
        let module = shader_module(device);
        let pipelines = Pipelines::new(device, &module);
        let texture_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cloud blit"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cloud blit"),
            bind_group_layouts: &[Some(&pipelines.uniform_layout), Some(&texture_layout)],
            immediate_size: 0,
        });
        let blit = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("cloud blit"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_blit"),
                buffers: &[],
                compilation_options: wgpu::PipelineCompilationOptions::default(),
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: depth_stencil_format.map(|format| wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: msaa_samples.max(1),
                ..wgpu::MultisampleState::default()
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(if target_format.is_srgb() {
                    "fs_blit_srgb_target"
                } else {
                    "fs_blit"
                }),
                targets: &[Some(wgpu::ColorTargetState {
                    format: target_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                compilation_options: wgpu::PipelineCompilationOptions::default(),
            }),
            multiview_mask: None,
            cache: None,
        });
        CloudResources {
            pipelines,
            blit,
            texture_layout,
            targets: HashMap::new(),
            frame: 0,
        }
    }

    fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pixels_per_point: f32,
        encoder: &mut wgpu::CommandEncoder,
        callback: &CloudCallback,
    ) {
        self.frame += 1;
        let frame = self.frame;
        self.targets
            .retain(|_, t| frame.saturating_sub(t.last_used) < TARGET_TTL);
        // The rect in physical pixels, rounded as egui rounds the viewport it sets for paint.
        let r = callback.rect;
        let left = (r.min.x * pixels_per_point).round();
        let top = (r.min.y * pixels_per_point).round();
        let right = (r.max.x * pixels_per_point).round();
        let bottom = (r.max.y * pixels_per_point).round();
        let max = device.limits().max_texture_dimension_2d;
        let size = [
            ((right - left).max(0.0) as u32).min(max),
            ((bottom - top).max(0.0) as u32).min(max),
        ];
        if size[0] == 0 || size[1] == 0 {
            return;
        }
        let pipelines = &self.pipelines;
        let target = self
            .targets
            .entry(callback.id)
            .or_insert_with(|| Target::new(device, pipelines, size));
        target.resize(device, size);
        target.last_used = frame;
        if target.blit_bind_group.is_none() {
            target.blit_bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("cloud blit"),
                layout: &self.texture_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&target.color_view),
                }],
            }));
        }
        target.upload_if_changed(device, queue, &callback.scene);
        let settings = DrawSettings {
            camera: callback.camera,
            point_size: callback.point_size * pixels_per_point,
            color_mode: callback.color_mode,
            cost_range: callback.cost_range,
            show_frusta: callback.show_frusta,
        };
        let uniforms = settings.uniforms(size, [left, top]);
        let mut key = bytemuck::bytes_of(&uniforms).to_vec();
        key.push(u8::from(settings.show_frusta));
        if target.drawn.as_ref() == Some(&key) {
            return;
        }
        queue.write_buffer(&target.uniforms, 0, bytemuck::bytes_of(&uniforms));
        target.encode(encoder, pipelines, settings.show_frusta);
        target.drawn = Some(key);
    }
}

/// Creates the 3D view's pipelines for `render_state.target_format` and stores them in the
/// renderer's callback resources. Assumes egui's default render pass (no depth buffer, one
/// sample); see [`install_with`] otherwise.
pub fn install(render_state: &egui_wgpu::RenderState) {
    install_with(render_state, None, 1);
}

/// [`install`] for an egui renderer made with a depth buffer or multisampling.
pub fn install_with(
    render_state: &egui_wgpu::RenderState,
    depth_stencil_format: Option<wgpu::TextureFormat>,
    msaa_samples: u32,
) {
    let resources = CloudResources::new(
        &render_state.device,
        render_state.target_format,
        depth_stencil_format,
        msaa_samples,
    );
    render_state
        .renderer
        .write()
        .callback_resources
        .insert(resources);
    INSTALLED.store(true, Ordering::Relaxed);
}

/// One frame of one [`CloudView`].
pub(super) struct CloudCallback {
    pub(super) id: egui::Id,
    /// Where the view is, in UI points.
    pub(super) rect: egui::Rect,
    pub(super) scene: Arc<CloudScene>,
    pub(super) camera: OrbitCamera,
    /// UI points.
    pub(super) point_size: f32,
    pub(super) color_mode: ColorMode,
    pub(super) cost_range: (f32, f32),
    pub(super) show_frusta: bool,
}

impl egui_wgpu::CallbackTrait for CloudCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        screen_descriptor: &egui_wgpu::ScreenDescriptor,
        egui_encoder: &mut wgpu::CommandEncoder,
        callback_resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        if let Some(resources) = callback_resources.get_mut::<CloudResources>() {
            resources.prepare(
                device,
                queue,
                screen_descriptor.pixels_per_point,
                egui_encoder,
                self,
            );
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        render_pass: &mut wgpu::RenderPass<'static>,
        callback_resources: &egui_wgpu::CallbackResources,
    ) {
        // egui has set the viewport to the view's rect (clamped to the window) and the scissor
        // to its clip rect; the blit reads texel = fragment position - blit_origin.
        let Some(resources) = callback_resources.get::<CloudResources>() else {
            return;
        };
        let Some(target) = resources.targets.get(&self.id) else {
            return;
        };
        let Some(texture) = &target.blit_bind_group else {
            return;
        };
        render_pass.set_pipeline(&resources.blit);
        render_pass.set_bind_group(0, &target.uniform_bind_group, &[]);
        render_pass.set_bind_group(1, texture, &[]);
        render_pass.draw(0..3, 0..1);
    }
}

/// Renders `scene` as the 3D view would (point size in pixels) into a `size` image and reads it
/// back: RGBA8 rows, top row first, display values.
#[expect(clippy::too_many_arguments)]
pub fn render_offscreen(
    ctx: &GpuContext,
    scene: &CloudScene,
    camera: &OrbitCamera,
    point_size: f32,
    mode: ColorMode,
    cost_range: (f32, f32),
    show_frusta: bool,
    size: [u32; 2],
) -> Result<Vec<u8>, GpuError> {
    let [width, height] = size;
    if width == 0 || height == 0 {
        return Err(GpuError::Validation {
            what: "cloud render_offscreen".into(),
            message: format!("the image size {width}x{height} is empty"),
        });
    }
    let device = &ctx.device;
    let pipelines = ctx.checked("cloud pipelines", || {
        Pipelines::new(device, &shader_module(device))
    })?;
    let mut target = ctx.checked("cloud target", || Target::new(device, &pipelines, size))?;
    target.upload(device, &ctx.queue, scene);
    let settings = DrawSettings {
        camera: *camera,
        point_size,
        color_mode: mode,
        cost_range,
        show_frusta,
    };
    let uniforms = settings.uniforms(size, [0.0, 0.0]);
    ctx.queue
        .write_buffer(&target.uniforms, 0, bytemuck::bytes_of(&uniforms));
    let row_bytes = width * 4;
    let padded_row =
        row_bytes.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cloud image"),
        size: padded_row as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    ctx.checked("cloud render", || {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cloud"),
        });
        target.encode(&mut encoder, &pipelines, show_frusta);
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &target.color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        ctx.queue.submit([encoder.finish()]);
    })?;
    let padded: Vec<u8> = ctx.read_buffer("cloud image", &readback)?;
    Ok(padded
        .chunks_exact(padded_row as usize)
        .flat_map(|row| &row[..row_bytes as usize])
        .copied()
        .collect())
}
