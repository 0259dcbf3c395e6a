//! The GPU side: a [`GpuContext`] (device + queue, headless or shared with the viewer),
//! buffer helpers, the WGSL `#import` preprocessor, and one module per compute pass.

pub mod acmh;
pub mod planar;
pub mod shader;
pub mod smoke;
pub mod timer;
pub mod types;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use wgpu::util::DeviceExt;

/// Why no GPU could be used.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (backends: {backends}). Install a Vulkan driver: on Debian/Ubuntu \
         `apt-get install mesa-vulkan-drivers` gives the software device lavapipe; or set \
         WGPU_BACKEND=gl for OpenGL"
    )]
    NoAdapter { backends: String },
    #[error(
        "WGPU_ADAPTER_NAME={wanted} matches no adapter; available: {available}. Unset it or \
         use part of one of those names"
    )]
    AdapterNotFound { wanted: String, available: String },
    #[error("the adapter {adapter} refused to create a device: {message}")]
    RequestDevice { adapter: String, message: String },
    #[error("GPU validation error in {what}: {message}")]
    Validation { what: String, message: String },
    #[error("reading back {what} from the GPU failed: {message}")]
    Readback { what: String, message: String },
    #[error("shader {name}: {message}")]
    Shader { name: String, message: String },
}

/// A device and queue that ACMM's passes run on. In the viewer they are eframe's own, so maps
/// are drawn straight from the buffers the passes write.
#[derive(Clone, Debug)]
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// The limits the device was created with (the adapter's real ones, not the defaults).
    pub limits: wgpu::Limits,
    pub features: wgpu::Features,
    /// Bytes moved over the bus through this context (shared by its clones).
    pub traffic: Arc<Traffic>,
    /// The open batch, if any (shared by its clones): see [`GpuContext::begin_batch`].
    batch: Arc<Mutex<Batch>>,
}

/// Commands recorded for one submission. While a batch is open, [`GpuContext::record`]
/// appends to it instead of submitting, so passes over different views' buffers, one after
/// the other in one command buffer with no barrier between them, may run side by side on a
/// GPU (wgpu places a barrier only before a buffer's second use within a command buffer).
#[derive(Debug, Default)]
struct Batch {
    open: bool,
    encoder: Option<wgpu::CommandEncoder>,
    /// Counts the submissions made while open; a queue write meant for one submission
    /// checks it (see [`GpuContext::batch_generation`]).
    generation: u64,
}

/// Bytes moved between host and device: every upload (buffer contents, `write_buffer`) and
/// every read-back goes through [`GpuContext`]'s helpers, which count them here.
#[derive(Debug, Default)]
pub struct Traffic {
    to_device: AtomicU64,
    from_device: AtomicU64,
}

/// A reading of [`Traffic`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TrafficBytes {
    pub to_device: u64,
    pub from_device: u64,
}

impl std::ops::Sub for TrafficBytes {
    type Output = TrafficBytes;
    fn sub(self, rhs: TrafficBytes) -> TrafficBytes {
        TrafficBytes {
            to_device: self.to_device.saturating_sub(rhs.to_device),
            from_device: self.from_device.saturating_sub(rhs.from_device),
        }
    }
}

impl Traffic {
    pub fn add_to_device(&self, bytes: u64) {
        self.to_device.fetch_add(bytes, Ordering::Relaxed);
    }

    pub fn add_from_device(&self, bytes: u64) {
        self.from_device.fetch_add(bytes, Ordering::Relaxed);
    }

    pub fn read(&self) -> TrafficBytes {
        TrafficBytes {
            to_device: self.to_device.load(Ordering::Relaxed),
            from_device: self.from_device.load(Ordering::Relaxed),
        }
    }
}

/// Order of preference among adapter types: real GPUs first, software last.
fn adapter_rank(kind: wgpu::DeviceType) -> u8 {
    match kind {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// Sort key of an adapter, best first: device type, then a native backend over GL on the
/// same hardware (compute is what we need).
pub fn adapter_preference(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    (adapter_rank(info.device_type), backend)
}

/// What a user comparing numbers must know about an adapter, or `None`. wgpu reaches
/// OpenGL only when no Vulkan, Metal or DX12 adapter exists ([`GpuContext::with_options`]);
/// on Linux that means Mesa's GL driver where `mesa-vulkan-drivers` is missing, and its
/// maps are not Vulkan's (a session's Middlebury figures once moved by 4.8 points only
/// because one machine lacked lavapipe; docs/accuracy.md). So every command that prints the
/// adapter says so under it, and `bench` and `report.json` carry it.
pub fn adapter_caveat(info: &wgpu::AdapterInfo) -> Option<String> {
    if info.backend != wgpu::Backend::Gl {
        return None;
    }
    let software = if info.device_type == wgpu::DeviceType::Cpu {
        " software"
    } else {
        ""
    };
    Some(format!(
        "warning: this run is on the OpenGL backend ({}{software}), not Vulkan: its maps differ \
         from a Vulkan device's, so compare its numbers only with runs on the same adapter. \
         wgpu uses OpenGL only when it finds no Vulkan adapter; on Debian/Ubuntu \
         `apt-get install mesa-vulkan-drivers` gives the software Vulkan device (lavapipe), \
         and `WGPU_BACKEND=gl` chooses OpenGL on purpose",
        adapter_name(info)
    ))
}

/// An adapter's name, or its backend where the platform does not tell it (a browser's
/// WebGPU hides the name).
pub fn adapter_name(info: &wgpu::AdapterInfo) -> String {
    if info.name.is_empty() {
        format!("{:?} adapter", info.backend)
    } else {
        info.name.clone()
    }
}

/// A compute-stage uniform buffer binding.
pub fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A compute-stage storage buffer binding.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A compute-stage binding of an unfilterable float 2D-array texture.
pub fn texture_array_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    }
}

/// A compute-stage binding of a write-only r32float 2D-array storage texture (core WebGPU:
/// a pass writes a depth snapshot or view weights into layers of it).
pub fn storage_texture_array_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: wgpu::TextureFormat::R32Float,
            view_dimension: wgpu::TextureViewDimension::D2Array,
        },
        count: None,
    }
}

/// A compute-stage binding of a non-filtering sampler (`textureGather` needs one).
pub fn sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering),
        count: None,
    }
}

/// Features mvscope uses when the adapter has them (timestamp queries for `mvscope bench`).
pub fn optional_features() -> wgpu::Features {
    wgpu::Features::TIMESTAMP_QUERY
}

/// Which adapter to use.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Backends to consider (`None`: Vulkan/Metal/DX12, then GL; or `WGPU_BACKEND` via
    /// [`GpuOptions::from_env`]).
    pub backends: Option<wgpu::Backends>,
    /// A case-insensitive part of the adapter's name.
    pub adapter_name: Option<String>,
}

impl GpuOptions {
    /// `WGPU_BACKEND` (e.g. `vulkan`, `gl`) and `WGPU_ADAPTER_NAME`.
    pub fn from_env() -> GpuOptions {
        GpuOptions {
            backends: wgpu::Backends::from_env(),
            adapter_name: std::env::var("WGPU_ADAPTER_NAME")
                .ok()
                .filter(|s| !s.is_empty()),
        }
    }
}

impl GpuContext {
    /// A headless context. Honours `WGPU_BACKEND` and `WGPU_ADAPTER_NAME`; otherwise prefers a
    /// hardware adapter and falls back to any, Mesa's lavapipe included.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn new() -> Result<GpuContext, GpuError> {
        Self::with_options(&GpuOptions::from_env())
    }

    /// As [`GpuContext::new`] with explicit choices (native: it waits for the adapter).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn with_options(options: &GpuOptions) -> Result<GpuContext, GpuError> {
        pollster::block_on(Self::with_options_async(options))
    }

    pub async fn with_options_async(options: &GpuOptions) -> Result<GpuContext, GpuError> {
        // Without an explicit choice, try the native compute APIs first and OpenGL only when
        // they have nothing (probing GL also prints display-server noise on headless machines).
        let tries = match options.backends {
            Some(b) => vec![b],
            None => vec![wgpu::Backends::PRIMARY, wgpu::Backends::GL],
        };
        let mut adapters = Vec::new();
        let mut tried = wgpu::Backends::empty();
        for backends in tries {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            desc.backends = backends;
            tried |= backends;
            let instance = wgpu::Instance::new(desc);
            adapters = instance.enumerate_adapters(backends).await;
            if !adapters.is_empty() {
                break;
            }
        }
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter {
                backends: format!("{tried:?}"),
            });
        }
        if let Some(wanted) = options.adapter_name.clone() {
            let needle = wanted.to_lowercase();
            let available = adapters
                .iter()
                .map(|a| a.get_info().name)
                .collect::<Vec<_>>()
                .join(", ");
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(&needle));
            if adapters.is_empty() {
                return Err(GpuError::AdapterNotFound { wanted, available });
            }
        }
        adapters.sort_by_key(|a| adapter_preference(&a.get_info()));
        let adapter = adapters.remove(0);
        let info = adapter.get_info();
        let features = adapter.features() & optional_features();
        let limits = adapter.limits();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("mvscope"),
                required_features: features,
                required_limits: limits.clone(),
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| GpuError::RequestDevice {
                adapter: info.name.clone(),
                message: e.to_string(),
            })?;
        log::info!(
            "GPU: {} ({:?}, {:?}, driver {} {})",
            info.name,
            info.device_type,
            info.backend,
            info.driver,
            info.driver_info
        );
        Ok(GpuContext {
            device,
            queue,
            info,
            limits,
            features,
            traffic: Arc::default(),
            batch: Arc::default(),
        })
    }

    /// A context over a device someone else created (the viewer's eframe renderer).
    pub fn from_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        info: wgpu::AdapterInfo,
    ) -> GpuContext {
        let limits = device.limits();
        let features = device.features();
        GpuContext {
            device,
            queue,
            info,
            limits,
            features,
            traffic: Arc::default(),
            batch: Arc::default(),
        }
    }

    fn batch(&self) -> MutexGuard<'_, Batch> {
        // A panic elsewhere while holding the lock leaves nothing half-done in a `Batch`.
        self.batch.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Opens a batch: until [`GpuContext::end_batch`], recorded commands wait in one command
    /// buffer. Queue writes and read-backs submit it first, so the order of operations is
    /// always the order of the calls. Opening an open batch does nothing.
    pub fn begin_batch(&self) {
        self.batch().open = true;
    }

    /// Submits what the batch holds and closes it.
    pub fn end_batch(&self) {
        self.submit_batch(true);
    }

    /// Submits what an open batch holds so far (it stays open).
    pub fn flush(&self) {
        self.submit_batch(false);
    }

    /// Takes the batch's commands (and closes it if `close`) under one lock, then submits.
    fn submit_batch(&self, close: bool) {
        let encoder = {
            let mut b = self.batch();
            let e = b.encoder.take();
            if e.is_some() || close {
                b.generation += 1;
            }
            b.open &= !close;
            e
        };
        if let Some(e) = encoder {
            self.queue.submit([e.finish()]);
        }
    }

    /// While a batch is open, a number that changes with each of its submissions: a queue
    /// write made for the commands being recorded holds until then. `None` when no batch is
    /// open (every command is submitted as it is recorded).
    pub fn batch_generation(&self) -> Option<u64> {
        let b = self.batch();
        b.open.then_some(b.generation)
    }

    /// Records commands with `f`: into the open batch, or submitted at once when none is open.
    pub fn record(&self, label: &str, f: impl FnOnce(&mut wgpu::CommandEncoder)) {
        let mut b = self.batch();
        if b.open {
            let encoder = b.encoder.get_or_insert_with(|| {
                self.device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("batch"),
                    })
            });
            f(encoder);
            return;
        }
        drop(b);
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        f(&mut encoder);
        self.queue.submit([encoder.finish()]);
    }

    /// Whether this is a software rasteriser (lavapipe, SwiftShader, WARP).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// One line describing the adapter, for logs and reports.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, {})",
            self.adapter_name(),
            self.info.device_type,
            self.info.backend,
            self.info.driver_info
        )
    }

    /// [`adapter_caveat`] of this context's adapter.
    pub fn caveat(&self) -> Option<String> {
        adapter_caveat(&self.info)
    }

    /// [`GpuContext::describe`], and under it the [`adapter_caveat`] when there is one.
    pub fn describe_with_caveat(&self) -> String {
        match self.caveat() {
            Some(c) => format!("{}\n{c}", self.describe()),
            None => self.describe(),
        }
    }

    /// [`adapter_name`] of this context's adapter.
    pub fn adapter_name(&self) -> String {
        adapter_name(&self.info)
    }

    /// A storage buffer holding `data` (uploaded, and counted in `traffic`).
    pub fn storage_buffer<T: bytemuck::Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        self.traffic
            .add_to_device(std::mem::size_of_val(data) as u64);
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(data),
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
            })
    }

    /// A storage buffer of `bytes` zeros, made on the device (nothing crosses the bus: wgpu
    /// zero-initialises new buffers there).
    pub fn zeroed_storage(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            // A binding cannot be empty.
            size: bytes.max(4).next_multiple_of(4),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// `queue.write_buffer`, counted in `traffic`.
    /// An open batch is submitted first: a queue write lands before the next submission.
    pub fn write<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer, offset: u64, data: &[T]) {
        self.flush();
        self.write_for_batch(buffer, offset, data);
    }

    /// `queue.write_buffer` for the commands being recorded: it lands before the batch's
    /// next submission, so it must not change what commands already recorded in it read
    /// (the caller checks with [`GpuContext::batch_generation`]). Counted in `traffic`.
    pub fn write_for_batch<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        offset: u64,
        data: &[T],
    ) {
        self.traffic
            .add_to_device(std::mem::size_of_val(data) as u64);
        self.queue
            .write_buffer(buffer, offset, bytemuck::cast_slice(data));
    }

    /// Intensities of several images as the layers of one R32Float 2D-array texture, each
    /// layer as large as the largest image (a smaller one fills its top-left corner; the
    /// shaders never read past an image's own size). `what` names them in errors.
    pub fn image_layers(
        &self,
        what: &str,
        images: &[(u32, u32, &[f32])],
    ) -> Result<(wgpu::Texture, wgpu::TextureView), GpuError> {
        let width = images.iter().map(|i| i.0).max().unwrap_or(1).max(1);
        let height = images.iter().map(|i| i.1).max().unwrap_or(1).max(1);
        let layers = (images.len() as u32).max(1);
        let l = &self.limits;
        if width.max(height) > l.max_texture_dimension_2d {
            return Err(GpuError::Validation {
                what: what.into(),
                message: format!(
                    "{width}x{height} is beyond this adapter's largest texture side of {}; lower --max-image-size to {} or less",
                    l.max_texture_dimension_2d, l.max_texture_dimension_2d
                ),
            });
        }
        if layers > l.max_texture_array_layers {
            return Err(GpuError::Validation {
                what: what.into(),
                message: format!(
                    "{layers} views are more than this adapter's {} texture layers; use fewer views",
                    l.max_texture_array_layers
                ),
            });
        }
        // The uploads are queue writes: an open batch is submitted before them.
        self.flush();
        let texture = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(what),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: layers,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        for (layer, &(w, h, values)) in images.iter().enumerate() {
            if values.len() != w as usize * h as usize {
                return Err(GpuError::Validation {
                    what: what.into(),
                    message: format!(
                        "layer {layer} holds {} values for a {w}x{h} image",
                        values.len()
                    ),
                });
            }
            if values.is_empty() {
                continue;
            }
            self.traffic
                .add_to_device(std::mem::size_of_val(values) as u64);
            self.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d {
                        x: 0,
                        y: 0,
                        z: layer as u32,
                    },
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(values),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(w * 4),
                    rows_per_image: Some(h),
                },
                wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
            );
        }
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        Ok((texture, view))
    }

    /// A uniform buffer holding `value`.
    pub fn uniform_buffer<T: bytemuck::Pod>(&self, label: &str, value: &T) -> wgpu::Buffer {
        self.buffer_holding(label, value, wgpu::BufferUsages::UNIFORM)
    }

    /// A small parameter block bound as read-only storage (see
    /// `acmh::STORAGE_BUFFERS` for why not as a uniform), rewritten before each dispatch.
    pub fn params_buffer<T: bytemuck::Pod>(&self, label: &str, value: &T) -> wgpu::Buffer {
        self.buffer_holding(label, value, wgpu::BufferUsages::STORAGE)
    }

    /// A buffer of `usage` (and COPY_DST) holding `value`, counted in `traffic`.
    fn buffer_holding<T: bytemuck::Pod>(
        &self,
        label: &str,
        value: &T,
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        self.traffic.add_to_device(std::mem::size_of::<T>() as u64);
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::bytes_of(value),
                usage: usage | wgpu::BufferUsages::COPY_DST,
            })
    }

    /// Copies a buffer back to the CPU, waiting for it (native only; the viewer asks with
    /// [`GpuContext::read_later`] and takes the bytes in a later frame instead).
    pub fn read_buffer<T: bytemuck::Pod>(
        &self,
        what: &str,
        buffer: &wgpu::Buffer,
    ) -> Result<Vec<T>, GpuError> {
        self.read_buffer_range(what, buffer, 0, buffer.size())
    }

    /// Copies `size` bytes from `offset` of a buffer back to the CPU, waiting for them (both
    /// multiples of 4). In the browser nothing may wait on the GPU: there this is an error.
    pub fn read_buffer_range<T: bytemuck::Pod>(
        &self,
        what: &str,
        buffer: &wgpu::Buffer,
        offset: u64,
        size: u64,
    ) -> Result<Vec<T>, GpuError> {
        self.read_later(what, buffer, offset, size).wait(self)
    }

    /// Asks for `size` bytes from `offset` of a buffer (both multiples of 4): the copy is
    /// recorded now, in queue order after everything submitted so far, and the bytes are
    /// taken later with [`Readback::take`] once [`Readback::is_ready`]: nothing waits.
    pub fn read_later(
        &self,
        what: &str,
        buffer: &wgpu::Buffer,
        offset: u64,
        size: u64,
    ) -> Readback {
        let state: Arc<Mutex<Option<Result<(), String>>>> = Arc::default();
        if size == 0 {
            *lock(&state) = Some(Ok(()));
            return Readback {
                what: what.to_string(),
                staging: None,
                rows: None,
                state,
            };
        }
        self.flush();
        self.traffic.add_from_device(size);
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("readback"),
            });
        encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, size);
        self.queue.submit([encoder.finish()]);
        let done = state.clone();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            *lock(&done) = Some(r.map_err(|e| e.to_string()));
        });
        Readback {
            what: what.to_string(),
            staging: Some(staging),
            rows: None,
            state,
        }
    }

    /// An r32float 2D-array texture of `layers` layers of `width x height` (at least 1x1x1)
    /// that passes read (sampled), write (storage) and that is copied to and from.
    pub fn r32_layers(&self, label: &str, width: u32, height: u32, layers: u32) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: width.max(1),
                height: height.max(1),
                depth_or_array_layers: layers.max(1),
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        })
    }

    /// Writes `values` (`layers` layers of `width x height`, layer after layer) into the
    /// top-left corner of `texture` from layer `first` (a queue write: an open batch is
    /// submitted first).
    pub fn write_layers(
        &self,
        texture: &wgpu::Texture,
        first: u32,
        (width, height, layers): (u32, u32, u32),
        values: &[u8],
    ) {
        if values.is_empty() || width == 0 || height == 0 {
            return;
        }
        self.flush();
        self.traffic.add_to_device(values.len() as u64);
        self.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: first,
                },
                aspect: wgpu::TextureAspect::All,
            },
            values,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(width * 4),
                rows_per_image: Some(height),
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: layers,
            },
        );
    }

    /// Asks for the `width x height` corner of layers `first..first + layers` of an r32float
    /// `texture`, layer after layer, as [`GpuContext::read_later`] does for a buffer.
    pub fn read_layers_later(
        &self,
        what: &str,
        texture: &wgpu::Texture,
        first: u32,
        (width, height, layers): (u32, u32, u32),
    ) -> Readback {
        let state: Arc<Mutex<Option<Result<(), String>>>> = Arc::default();
        let row = width as usize * 4;
        if row == 0 || height == 0 || layers == 0 {
            *lock(&state) = Some(Ok(()));
            return Readback {
                what: what.to_string(),
                staging: None,
                rows: None,
                state,
            };
        }
        // A texture copy's rows are 256-byte aligned in the buffer.
        let padded = row.div_ceil(256) * 256;
        let size = (padded * height as usize * layers as usize) as u64;
        self.flush();
        self.traffic
            .add_from_device((row * height as usize * layers as usize) as u64);
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("readback"),
            });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: first,
                },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded as u32),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: layers,
            },
        );
        self.queue.submit([encoder.finish()]);
        let done = state.clone();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            *lock(&done) = Some(r.map_err(|e| e.to_string()));
        });
        Readback {
            what: what.to_string(),
            staging: Some(staging),
            rows: Some((row, padded)),
            state,
        }
    }

    /// Runs `f` and turns any validation error it causes into a [`GpuError`] instead of the
    /// default handler's panic.
    ///
    /// Natively the error is known when the scope closes (wgpu validates on the CPU). In the
    /// browser it arrives later and nothing may wait for it: there the value is returned and
    /// an error, if any, goes to the browser's console naming `what`.
    pub fn checked<R>(&self, what: &str, f: impl FnOnce() -> R) -> Result<R, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let value = f();
        #[cfg(target_arch = "wasm32")]
        {
            // Popped now, in order with every other scope; its answer is awaited later.
            let answer = scope.pop();
            let what = what.to_string();
            wasm_bindgen_futures::spawn_local(async move {
                if let Some(e) = answer.await {
                    log::error!("GPU validation error in {what}: {e}");
                }
            });
            Ok(value)
        }
        #[cfg(not(target_arch = "wasm32"))]
        match pollster::block_on(scope.pop()) {
            None => Ok(value),
            Some(e) => Err(GpuError::Validation {
                what: what.to_string(),
                message: e.to_string(),
            }),
        }
    }

    /// A bind group layout of `entries` and a pipeline layout of it alone, validated.
    pub fn layouts(
        &self,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> Result<(wgpu::BindGroupLayout, wgpu::PipelineLayout), GpuError> {
        let layout = self.checked(label, || {
            self.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries,
                })
        })?;
        let pipeline_layout = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        Ok((layout, pipeline_layout))
    }

    /// A bind group of `layout` binding each buffer range to its binding number, validated.
    pub fn buffer_group(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        buffers: Vec<(u32, wgpu::BufferBinding)>,
    ) -> Result<wgpu::BindGroup, GpuError> {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .into_iter()
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding,
                resource: wgpu::BindingResource::Buffer(buffer),
            })
            .collect();
        self.checked(label, || {
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &entries,
            })
        })
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// A read-back on its way from the device ([`GpuContext::read_later`]).
#[derive(Debug)]
pub struct Readback {
    what: String,
    /// `None` for an empty read.
    staging: Option<wgpu::Buffer>,
    /// A texture's rows in the staging buffer: (bytes of a row, bytes between rows), so the
    /// padding a texture copy needs is dropped when the values are taken.
    rows: Option<(usize, usize)>,
    /// Set by the mapping's callback.
    state: Arc<Mutex<Option<Result<(), String>>>>,
}

/// Whether a read-back has arrived (a handle on its flag that outlives the borrow).
#[derive(Clone, Debug)]
pub struct ReadyFlag(Arc<Mutex<Option<Result<(), String>>>>);

impl ReadyFlag {
    pub fn is_set(&self) -> bool {
        lock(&self.0).is_some()
    }
}

impl GpuContext {
    /// Lets the device make progress (mapping callbacks, finished work) without waiting:
    /// natively a non-blocking poll; in the browser the page's event loop does it.
    pub fn poll(&self) {
        #[cfg(not(target_arch = "wasm32"))]
        let _ = self.device.poll(wgpu::PollType::Poll);
    }

    /// Waits until the work submitted so far has run (natively; in the browser, which cannot
    /// wait, nothing): what a wall-clock time of a stage must do before it reads the clock,
    /// since a submission returns as soon as the work is queued.
    pub fn finish(&self) -> Result<(), GpuError> {
        #[cfg(not(target_arch = "wasm32"))]
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Readback {
                what: "the device's work".into(),
                message: e.to_string(),
            })?;
        Ok(())
    }

    /// Waits until every flag is set: natively by polling the device until its work is
    /// done; in the browser, which cannot wait, an error unless they already are.
    pub fn wait_for(&self, flags: &[ReadyFlag]) -> Result<(), GpuError> {
        self.poll();
        if flags.iter().all(ReadyFlag::is_set) {
            return Ok(());
        }
        self.finish()?;
        if flags.iter().all(ReadyFlag::is_set) {
            Ok(())
        } else {
            Err(GpuError::Readback {
                what: "a read-back".into(),
                message: "not arrived yet, and nothing may wait for the GPU in the browser".into(),
            })
        }
    }
}

impl Readback {
    /// Its arrival flag.
    pub fn flag(&self) -> ReadyFlag {
        ReadyFlag(self.state.clone())
    }

    /// The values of a read-back that has arrived (an error if it has not).
    pub fn values_after<T: bytemuck::Pod>(&self, ctx: &GpuContext) -> Result<Vec<T>, GpuError> {
        match self.take(ctx) {
            Some(v) => v,
            None => Err(GpuError::Readback {
                what: self.what.clone(),
                message: "taken before it arrived".into(),
            }),
        }
    }

    /// The values of an optional read-back that has arrived.
    pub fn values_of<T: bytemuck::Pod>(
        read: &Option<Readback>,
        ctx: &GpuContext,
    ) -> Result<Option<Vec<T>>, GpuError> {
        read.as_ref().map(|r| r.values_after(ctx)).transpose()
    }

    /// Whether the bytes have arrived. Natively this lets the device make progress without
    /// waiting (`poll`); in the browser the page's event loop does that between frames.
    pub fn is_ready(&self, ctx: &GpuContext) -> bool {
        ctx.poll();
        lock(&self.state).is_some()
    }

    /// The values once they have arrived (`None` before; see [`Readback::is_ready`]).
    pub fn take<T: bytemuck::Pod>(&self, ctx: &GpuContext) -> Option<Result<Vec<T>, GpuError>> {
        if !self.is_ready(ctx) {
            return None;
        }
        Some(self.values())
    }

    fn values<T: bytemuck::Pod>(&self) -> Result<Vec<T>, GpuError> {
        let err = |message: String| GpuError::Readback {
            what: self.what.clone(),
            message,
        };
        lock(&self.state).clone().unwrap_or(Ok(())).map_err(err)?;
        let Some(staging) = &self.staging else {
            return Ok(Vec::new());
        };
        let data = {
            let view = staging
                .get_mapped_range(..)
                .map_err(|e| err(e.to_string()))?;
            match self.rows {
                None => bytemuck::pod_collect_to_vec(&view),
                Some((row, padded)) => {
                    let bytes: Vec<u8> = view
                        .chunks(padded)
                        .flat_map(|r| &r[..row.min(r.len())])
                        .copied()
                        .collect();
                    bytemuck::pod_collect_to_vec(&bytes)
                }
            }
        };
        staging.unmap();
        Ok(data)
    }

    /// Waits for the values: natively by polling the device until the copy is done; in the
    /// browser, which cannot wait, an error unless they have already arrived.
    pub fn wait<T: bytemuck::Pod>(self, ctx: &GpuContext) -> Result<Vec<T>, GpuError> {
        ctx.wait_for(&[self.flag()])?;
        self.values()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(
        name: &str,
        device_type: wgpu::DeviceType,
        backend: wgpu::Backend,
    ) -> wgpu::AdapterInfo {
        wgpu::AdapterInfo {
            name: name.to_string(),
            ..wgpu::AdapterInfo::new(device_type, backend)
        }
    }

    /// Mesa's GL fallback (what wgpu gives on a machine without mesa-vulkan-drivers) is
    /// named with what to install; lavapipe and a real GPU on Vulkan carry no caveat.
    #[test]
    fn the_gl_fallback_is_named_and_vulkan_is_not() {
        let gl = adapter_caveat(&info(
            "llvmpipe (LLVM 19.1.7, 256 bits)",
            wgpu::DeviceType::Cpu,
            wgpu::Backend::Gl,
        ))
        .expect("GL carries a caveat");
        assert!(gl.contains("OpenGL"), "{gl}");
        assert!(
            gl.contains("llvmpipe (LLVM 19.1.7, 256 bits) software"),
            "{gl}"
        );
        assert!(gl.contains("mesa-vulkan-drivers"), "{gl}");
        let hw = adapter_caveat(&info(
            "Mesa Intel(R) UHD",
            wgpu::DeviceType::IntegratedGpu,
            wgpu::Backend::Gl,
        ))
        .expect("GL carries a caveat");
        assert!(hw.contains("(Mesa Intel(R) UHD), not Vulkan"), "{hw}");
        for (name, kind) in [
            ("llvmpipe (LLVM 19.1.7, 256 bits)", wgpu::DeviceType::Cpu),
            ("NVIDIA H100 80GB HBM3", wgpu::DeviceType::DiscreteGpu),
        ] {
            assert_eq!(
                adapter_caveat(&info(name, kind, wgpu::Backend::Vulkan)),
                None
            );
        }
        assert_eq!(
            adapter_caveat(&info(
                "Apple M2",
                wgpu::DeviceType::IntegratedGpu,
                wgpu::Backend::Metal
            )),
            None
        );
    }
}
