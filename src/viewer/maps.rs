//! The GPU pass that turns one view's maps into a displayable image, and its CPU reference.
//!
//! Pass 1 ([`MapRenderer::extract`]) writes one `vec4<f32>` per pixel into
//! [`MapTarget::values`]: for scalar kinds x = value, y = 1 when valid (else 0), z = w = 0;
//! [`MapKind::Normal`]: xyz = normal, w = 1 when depth > 0; [`MapKind::Image`]: xyz = rgb in
//! [0, 1], w = 1. Pass 2 ([`MapRenderer::colorize`]) maps those values to the rgba8
//! [`MapTarget::texture`] through a [`Colormap`] over `[lo, hi]`. Both are compute shaders in
//! `shaders/map_view.wgsl`; [`extract_value`] gives the same bits as pass 1 and
//! [`colorize_value`] the same colours as pass 2 within 1 LSB.

use bytemuck::{Pod, Zeroable};

use crate::acmm::memory;
use crate::acmm::problem::Winner;
use crate::gpu::acmh::{array_view, plane_windows};
use crate::gpu::{GpuContext, GpuError, shader};
use crate::gpu::{storage_entry, uniform_entry};
use crate::image::Image;
use crate::session::{GpuMaps, ViewMaps};

/// A per-pixel quantity a map view shows.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
pub enum MapKind {
    /// The view's colour image.
    Image,
    /// Depth (plane w), valid where > 0.
    #[default]
    Depth,
    /// Camera-frame normal, valid where depth > 0.
    Normal,
    /// Aggregated matching cost, valid where depth > 0.
    Cost,
    /// Number of sources in the view-selection set.
    SelectedCount,
    /// Whether one source is in the view-selection set.
    SelectedBit,
    /// One source's view weight.
    Weight,
    /// Which hypothesis won: codes 0..=15 as themselves, the initial random plane as 16.
    Winner,
    /// Forward-backward reprojection error (geometric stages).
    ReprojectionError,
    /// C_init − C_photo of the detail restorer.
    RestorerDifference,
    /// Pixels the detail restorer replaced.
    Replaced,
    /// |d − gt| / gt against ground truth.
    DepthError,
    /// The planar prior's depth (ACMP, ACMMP), valid where the pixel has a prior; otherwise
    /// the value says why not (0 no triangle, −1 dropped triangle, −2 out of range).
    PriorDepth,
    /// The planar prior's normal.
    PriorNormal,
    /// The prior factor γ + exp(−Δd²/2σd²)·exp(−Δθ²/2σθ²) of the pixel's current plane: how
    /// much the prior favours it in the hypothesis score (in [γ, 1 + γ]).
    PriorWeight,
    /// At the prior-assisted pass's start, the pixels restarted from the prior; after one of
    /// its updates, where the prior changed the choice (aux bit 17).
    PriorEffect,
    /// The image with the credible support points drawn over it.
    SupportPoints,
    /// The image with the triangulation drawn over it (dropped triangles marked).
    Triangulation,
    /// How many sources agree with the pixel's depth (fusion's reprojection, depth and normal
    /// check: `confidence/%08d.pfm` of a run), from the last "Fuse" of the shown level.
    Confidence,
    /// How many anchors agree on a weak pixel's plane (`prior_anchors`, from the prior
    /// planes' step of the planar prior's stage; 0: a strong pixel, or none agree).
    Anchors,
    /// Each pixel's chessboard distance, in the shown scale's pixels, to the nearest pixel
    /// whose matching window varies by 3 grey levels or more: the paper's "texture richness
    /// is a relative measure" (Sec. 1) made visible, and what `scales_by_texture` measures
    /// (`acmm::pyramid_depth`). The window reaches texture where it is at most its radius.
    TextureReach,
}

/// Value of [`MapKind::Winner`] for [`Winner::Initial`] (codes 0..=15 keep their value).
pub const WINNER_INITIAL_VALUE: f32 = 16.0;

/// The winner map's colours (sRGB bytes), one per value: codes 0..=15 and
/// [`WINNER_INITIAL_VALUE`] last. Categories, not a ramp (turbo over the 17 codes put
/// "refined (d, n_pert)", "refined (d_pert, n_pert)" and "its prior plane" in three
/// near-identical dark reds, 11-14 apart in CIELAB): a hue per propagation direction (up
/// blue, down green, left purple, right brown; the V area dark, the strip light), warm
/// colours for the six refinement hypotheses, near-white for kept, magenta for a prior plane
/// no source sees, mid grey for a random initial plane. Every pair is at least 23 apart in
/// CIELAB (tests/map_view.rs).
pub const WINNER_COLORS: [[u8; 3]; 17] = [
    [31, 119, 180],
    [158, 202, 225],
    [44, 160, 44],
    [161, 217, 155],
    [117, 107, 177],
    [203, 160, 230],
    [140, 86, 75],
    [196, 156, 148],
    [235, 235, 235],
    [214, 39, 40],
    [255, 127, 14],
    [130, 16, 16],
    [255, 152, 150],
    [255, 187, 120],
    [240, 220, 60],
    [214, 0, 214],
    [96, 96, 96],
];

/// [`WINNER_COLORS`]' entry for a winner map value (clamped to the table).
pub fn winner_color(value: f32) -> [u8; 3] {
    let k = if value > 0.0 { value as usize } else { 0 };
    WINNER_COLORS[k.min(WINNER_COLORS.len() - 1)]
}

/// The value the winner map shows for a raw winner code (`Winner::code`, as the maps and
/// Python's `maps["winner"]` hold it): codes 0..=15 as themselves, the random initial plane
/// as [`WINNER_INITIAL_VALUE`]; `None` (drawn as invalid) for any other code.
pub fn winner_value(code: u32) -> Option<f32> {
    match code {
        0..=Winner::PRIOR_UNSEEN => Some(code as f32),
        Winner::INITIAL => Some(WINNER_INITIAL_VALUE),
        _ => None,
    }
}

/// The colour (sRGB bytes) the viewer's winner map gives a raw winner code, the invalid grey
/// for a code it does not draw (255, no update). Python's `mvscope.WINNER_COLORS` and
/// `winner_rgb` read it, so a notebook's winner map has the viewer's colours.
pub fn winner_code_color(code: u32) -> [u8; 3] {
    let value = match winner_value(code) {
        Some(v) => [v, 1.0, 0.0, 0.0],
        None => [0.0; 4],
    };
    let [r, g, b, _] = colorize_value(MapKind::Winner, value, Colormap::default(), 0.0, 1.0);
    [r, g, b]
}

impl MapKind {
    pub const ALL: [MapKind; 21] = [
        MapKind::Image,
        MapKind::Depth,
        MapKind::Normal,
        MapKind::Cost,
        MapKind::SelectedCount,
        MapKind::SelectedBit,
        MapKind::Weight,
        MapKind::Winner,
        MapKind::ReprojectionError,
        MapKind::RestorerDifference,
        MapKind::Replaced,
        MapKind::DepthError,
        MapKind::PriorDepth,
        MapKind::PriorNormal,
        MapKind::PriorWeight,
        MapKind::PriorEffect,
        MapKind::SupportPoints,
        MapKind::Triangulation,
        MapKind::Confidence,
        MapKind::Anchors,
        MapKind::TextureReach,
    ];

    /// Stable name (CLI, settings).
    pub fn name(self) -> &'static str {
        match self {
            MapKind::Image => "image",
            MapKind::Depth => "depth",
            MapKind::Normal => "normal",
            MapKind::Cost => "cost",
            MapKind::SelectedCount => "selected-count",
            MapKind::SelectedBit => "selected",
            MapKind::Weight => "weight",
            MapKind::Winner => "winner",
            MapKind::ReprojectionError => "reprojection-error",
            MapKind::RestorerDifference => "restorer-difference",
            MapKind::Replaced => "replaced",
            MapKind::DepthError => "depth-error",
            MapKind::PriorDepth => "prior-depth",
            MapKind::PriorNormal => "prior-normal",
            MapKind::PriorWeight => "prior-weight",
            MapKind::PriorEffect => "prior-effect",
            MapKind::SupportPoints => "support-points",
            MapKind::Triangulation => "triangulation",
            MapKind::Confidence => "confidence",
            MapKind::Anchors => "anchors",
            MapKind::TextureReach => "texture-reach",
        }
    }

    /// The kind called `name` (see [`MapKind::name`]).
    pub fn from_name(name: &str) -> Option<MapKind> {
        MapKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Label for the UI.
    pub fn title(self) -> &'static str {
        match self {
            MapKind::Image => "Image",
            MapKind::Depth => "Depth",
            MapKind::Normal => "Normal",
            MapKind::Cost => "Matching cost",
            MapKind::SelectedCount => "Selected views (count)",
            MapKind::SelectedBit => "Selected (one source)",
            MapKind::Weight => "View weight (one source)",
            MapKind::Winner => "Winning hypothesis",
            MapKind::ReprojectionError => "Reprojection error",
            MapKind::RestorerDifference => "Restorer C_init − C_photo",
            MapKind::Replaced => "Replaced by the restorer",
            MapKind::DepthError => "Relative depth error",
            MapKind::PriorDepth => "Planar prior: depth",
            MapKind::PriorNormal => "Planar prior: normal",
            MapKind::PriorWeight => "Planar prior: weight of the current plane",
            MapKind::PriorEffect => "Planar prior: restarted / changed the choice",
            MapKind::SupportPoints => "Planar prior: support points",
            MapKind::Triangulation => "Planar prior: triangulation",
            MapKind::Confidence => "Confidence: agreeing sources",
            MapKind::Anchors => "Anchors agreeing on the plane",
            MapKind::TextureReach => "Distance to texture (pyramid depth)",
        }
    }

    /// Whether the kind shows the planar prior (ACMP, ACMMP only).
    pub fn is_prior(self) -> bool {
        matches!(
            self,
            MapKind::PriorDepth
                | MapKind::PriorNormal
                | MapKind::PriorWeight
                | MapKind::PriorEffect
                | MapKind::SupportPoints
                | MapKind::Triangulation
                | MapKind::Anchors
        )
    }

    /// Whether the UI draws the prior's mesh over the image (points, or the triangles too).
    pub fn overlay(self) -> Option<bool> {
        match self {
            MapKind::SupportPoints => Some(false),
            MapKind::Triangulation => Some(true),
            _ => None,
        }
    }

    /// Whether the kind shows one source view (`source` of [`MapRenderer::extract`]).
    pub fn uses_source(self) -> bool {
        matches!(self, MapKind::SelectedBit | MapKind::Weight)
    }

    /// Whether the values are colours already (no colour map, no range).
    pub fn is_color(self) -> bool {
        matches!(
            self,
            MapKind::Image
                | MapKind::Normal
                | MapKind::PriorNormal
                | MapKind::SupportPoints
                | MapKind::Triangulation
        )
    }

    /// Unit of the values, "" when unitless or in scene units.
    pub fn unit(self) -> &'static str {
        match self {
            MapKind::ReprojectionError | MapKind::TextureReach => "px",
            MapKind::SelectedCount | MapKind::Confidence => "views",
            MapKind::Depth | MapKind::PriorDepth => "scene units",
            _ => "",
        }
    }

    /// The shader's kind code: the position in [`MapKind::ALL`]; the overlay kinds draw the
    /// image underneath.
    fn code(self) -> u32 {
        match self {
            MapKind::SupportPoints | MapKind::Triangulation => MapKind::Image as u32,
            _ => self as u32,
        }
    }

    /// The kind whose values the shader computes (the overlay kinds: the image's).
    fn base(self) -> MapKind {
        match self {
            MapKind::SupportPoints | MapKind::Triangulation => MapKind::Image,
            k => k,
        }
    }
}

/// Colour map of scalar kinds.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
pub enum Colormap {
    /// Google's Turbo: dark blue, cyan, green, yellow, red, dark red.
    #[default]
    Turbo,
    /// Matplotlib's viridis: purple, blue, green, yellow.
    Viridis,
    /// Black to white.
    Grey,
}

/// Samples at t = k / 32 of each colour map (from the published 256-entry tables); the
/// shader holds the same numbers and both interpolate linearly.
const TABLE_STEPS: usize = 32;

const TURBO: [[f32; 3]; TABLE_STEPS + 1] = [
    [0.1900, 0.0718, 0.2322],
    [0.2249, 0.1632, 0.4502],
    [0.2509, 0.2517, 0.6324],
    [0.2680, 0.3373, 0.7790],
    [0.2762, 0.4199, 0.8897],
    [0.2755, 0.4996, 0.9648],
    [0.2594, 0.5777, 0.9986],
    [0.2153, 0.6567, 0.9806],
    [0.1602, 0.7332, 0.9252],
    [0.1130, 0.8034, 0.8482],
    [0.0927, 0.8634, 0.7655],
    [0.1179, 0.9101, 0.6900],
    [0.1922, 0.9474, 0.5993],
    [0.2992, 0.9758, 0.4953],
    [0.4210, 0.9935, 0.3912],
    [0.5400, 0.9991, 0.3005],
    [0.6384, 0.9910, 0.2365],
    [0.7205, 0.9669, 0.2073],
    [0.7994, 0.9277, 0.2042],
    [0.8704, 0.8768, 0.2146],
    [0.9290, 0.8173, 0.2261],
    [0.9707, 0.7523, 0.2262],
    [0.9921, 0.6810, 0.2059],
    [0.9963, 0.5952, 0.1724],
    [0.9853, 0.5018, 0.1324],
    [0.9610, 0.4084, 0.0921],
    [0.9253, 0.3229, 0.0577],
    [0.8797, 0.2521, 0.0349],
    [0.8230, 0.1909, 0.0195],
    [0.7547, 0.1367, 0.0093],
    [0.6747, 0.0895, 0.0045],
    [0.5830, 0.0492, 0.0049],
    [0.4796, 0.0158, 0.0106],
];

const VIRIDIS: [[f32; 3]; TABLE_STEPS + 1] = [
    [0.2670, 0.0049, 0.3294],
    [0.2770, 0.0502, 0.3755],
    [0.2823, 0.0946, 0.4170],
    [0.2829, 0.1354, 0.4530],
    [0.2789, 0.1749, 0.4830],
    [0.2708, 0.2133, 0.5066],
    [0.2593, 0.2507, 0.5244],
    [0.2454, 0.2867, 0.5370],
    [0.2302, 0.3213, 0.5455],
    [0.2148, 0.3545, 0.5510],
    [0.2000, 0.3864, 0.5545],
    [0.1861, 0.4173, 0.5567],
    [0.1733, 0.4474, 0.5579],
    [0.1613, 0.4770, 0.5581],
    [0.1497, 0.5064, 0.5573],
    [0.1384, 0.5358, 0.5551],
    [0.1281, 0.5651, 0.5509],
    [0.1209, 0.5945, 0.5442],
    [0.1203, 0.6238, 0.5343],
    [0.1310, 0.6529, 0.5208],
    [0.1554, 0.6815, 0.5032],
    [0.1930, 0.7096, 0.4812],
    [0.2415, 0.7366, 0.4545],
    [0.2986, 0.7624, 0.4230],
    [0.3629, 0.7867, 0.3866],
    [0.4330, 0.8091, 0.3453],
    [0.5081, 0.8292, 0.2992],
    [0.5873, 0.8470, 0.2489],
    [0.6694, 0.8622, 0.1954],
    [0.7529, 0.8751, 0.1427],
    [0.8359, 0.8861, 0.1025],
    [0.9166, 0.8961, 0.1008],
    [0.9932, 0.9062, 0.1439],
];

/// Colour of invalid pixels (opaque dark grey).
const INVALID_GREY: f32 = 0.12;

/// The f32 nearest to 1/255 (the shader's `INV_255`).
const INV_255: f32 = 1.0 / 255.0;

impl Colormap {
    pub const ALL: [Colormap; 3] = [Colormap::Turbo, Colormap::Viridis, Colormap::Grey];

    /// Stable name (settings).
    pub fn name(self) -> &'static str {
        match self {
            Colormap::Turbo => "turbo",
            Colormap::Viridis => "viridis",
            Colormap::Grey => "grey",
        }
    }

    /// The colour map called `name`.
    pub fn from_name(name: &str) -> Option<Colormap> {
        Colormap::ALL.into_iter().find(|c| c.name() == name)
    }

    /// The shader's colour map code.
    fn code(self) -> u32 {
        self as u32
    }

    /// Colour at `t` (clamped to [0, 1]) in [0, 1].
    fn rgb(self, t: f32) -> [f32; 3] {
        // NaN goes to 0 (`!(t >= 0)`), like an empty range.
        let t = if t >= 0.0 { t.min(1.0) } else { 0.0 };
        let table = match self {
            Colormap::Turbo => &TURBO,
            Colormap::Viridis => &VIRIDIS,
            Colormap::Grey => return [t; 3],
        };
        let s = t * TABLE_STEPS as f32;
        let k = (s.floor() as usize).min(TABLE_STEPS - 1);
        let f = s - k as f32;
        let (a, b) = (table[k], table[k + 1]);
        [0, 1, 2].map(|c| a[c] + (b[c] - a[c]) * f)
    }

    /// 8-bit colour at `t` (clamped to [0, 1]): the CPU reference of the shader's.
    pub fn color(self, t: f32) -> [u8; 3] {
        self.rgb(t).map(unorm8)
    }
}

/// Float in [0, 1] to 8 bits, as an rgba8unorm store does (round to nearest).
fn unorm8(x: f32) -> u8 {
    let x = if x >= 0.0 { x.min(1.0) } else { 0.0 };
    (x * 255.0).round() as u8
}

/// What pass 1 reads: a view's maps, its colour image and optionally ground-truth depth.
pub struct MapSources<'a> {
    pub maps: &'a GpuMaps,
    /// One u32 per pixel, `r | g << 8 | b << 16 | a << 24` (see [`pack_rgba`]), at the maps'
    /// size.
    pub image: &'a wgpu::Buffer,
    /// f32 depth per pixel at the maps' size, <= 0 where unknown.
    pub ground_truth: Option<&'a wgpu::Buffer>,
    /// f32 per pixel at the maps' size: how many sources agree with its depth
    /// ([`crate::fusion::confidence`]), where the maps have been fused.
    pub confidence: Option<&'a wgpu::Buffer>,
    /// f32 per pixel at the maps' size: its distance to texture ([`texture_reach`]).
    pub texture_reach: Option<&'a wgpu::Buffer>,
}

/// Where a map view is drawn: the per-pixel values of pass 1 and the texture of pass 2.
#[derive(Clone, Debug)]
pub struct MapTarget {
    pub width: u32,
    pub height: u32,
    /// Rgba8Unorm; STORAGE_BINDING | TEXTURE_BINDING | COPY_SRC.
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    /// One `vec4<f32>` per pixel; STORAGE | COPY_SRC | COPY_DST.
    pub values: wgpu::Buffer,
}

impl MapTarget {
    /// A target of `width` x `height`, clamped to at least 1 and to the device's limits (a
    /// clamped target then fails [`MapRenderer::extract`] with a size mismatch).
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> MapTarget {
        let max_side = ctx.limits.max_texture_dimension_2d.max(1);
        let width = width.clamp(1, max_side);
        let max_pixels =
            (ctx.limits.max_storage_buffer_binding_size).min(ctx.limits.max_buffer_size) / 16;
        let max_height = (max_pixels / u64::from(width)).clamp(1, u64::from(max_side)) as u32;
        let height = height.clamp(1, max_height);
        let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("map view"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let values = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("map view values"),
            size: u64::from(width) * u64::from(height) * 16,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        MapTarget {
            width,
            height,
            texture,
            view,
            values,
        }
    }

    fn pixels(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }
}

/// Keep in sync with `struct MapParams` in shaders/map_view.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct MapParams {
    width: u32,
    height: u32,
    kind: u32,
    source: u32,
    num_sources: u32,
    colormap: u32,
    lo: f32,
    hi: f32,
    /// Whether the kind's per-pixel input (ground truth, confidence) is bound.
    has_input: u32,
    /// γ, 1/(2σd²), 1/(2σθ²) of the prior factor (`PriorWeight`).
    prior_gamma: f32,
    prior_inv_2sd2: f32,
    prior_inv_2sn2: f32,
    /// The first pixel of the vec4 maps' second window (`memory::plane_split`).
    split: u32,
    _pad: [u32; 3],
}

/// The compiled map view passes (cheap to clone: wgpu handles are shared).
#[derive(Clone, Debug)]
pub struct MapRenderer {
    extract_layout: wgpu::BindGroupLayout,
    colorize_layout: wgpu::BindGroupLayout,
    extract: wgpu::ComputePipeline,
    colorize: wgpu::ComputePipeline,
    /// Bound where a kind reads no f32 / u32 map.
    dummy: wgpu::Buffer,
    /// The values' second window when a map is too small to split (`plane_windows`): a
    /// writable binding may not share its buffer with another.
    spare: wgpu::Buffer,
    /// Bound where a kind reads no weights.
    dummy_weights: wgpu::TextureView,
}

fn mismatch(what: &str, message: String) -> GpuError {
    GpuError::Validation {
        what: what.to_string(),
        message,
    }
}

/// Fails unless `buffer` holds at least `bytes`.
fn check_size(what: &str, buffer: &wgpu::Buffer, bytes: u64) -> Result<(), GpuError> {
    if buffer.size() < bytes {
        return Err(mismatch(
            "map view",
            format!(
                "the {what} buffer has {} bytes, the map needs {bytes}",
                buffer.size()
            ),
        ));
    }
    Ok(())
}

impl MapRenderer {
    /// Compiles the two passes.
    pub fn new(ctx: &GpuContext) -> Result<MapRenderer, GpuError> {
        let module =
            shader::create_module(ctx, "map_view", include_str!("../../shaders/map_view.wgsl"))?;
        let extract_layout = ctx.checked("map view extract layout", || {
            ctx.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("map view extract"),
                    entries: &[
                        uniform_entry(0),
                        storage_entry(1, true),
                        storage_entry(7, true),
                        storage_entry(2, true),
                        storage_entry(3, true),
                        storage_entry(8, true),
                        storage_entry(9, true),
                        storage_entry(4, false),
                        storage_entry(10, false),
                        crate::gpu::texture_array_entry(6),
                    ],
                })
        })?;
        let colorize_layout = ctx.checked("map view colorize layout", || {
            ctx.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("map view colorize"),
                    entries: &[
                        uniform_entry(0),
                        storage_entry(4, false),
                        storage_entry(10, false),
                        wgpu::BindGroupLayoutEntry {
                            binding: 5,
                            visibility: wgpu::ShaderStages::COMPUTE,
                            ty: wgpu::BindingType::StorageTexture {
                                access: wgpu::StorageTextureAccess::WriteOnly,
                                format: wgpu::TextureFormat::Rgba8Unorm,
                                view_dimension: wgpu::TextureViewDimension::D2,
                            },
                            count: None,
                        },
                    ],
                })
        })?;
        let pipeline = |layout: &wgpu::BindGroupLayout, entry: &str| {
            ctx.checked(&format!("pipeline map_view::{entry}"), || {
                let pipeline_layout =
                    ctx.device
                        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                            label: Some("map view"),
                            bind_group_layouts: &[Some(layout)],
                            immediate_size: 0,
                        });
                ctx.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(entry),
                        layout: Some(&pipeline_layout),
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        cache: None,
                    })
            })
        };
        let extract = pipeline(&extract_layout, "extract")?;
        let colorize = pipeline(&colorize_layout, "colorize")?;
        let dummy = ctx.storage_buffer("map view dummy", &[0u32; 4]);
        let dummy_weights = array_view(&ctx.r32_layers("map view dummy weights", 1, 1, 1));
        Ok(MapRenderer {
            extract_layout,
            colorize_layout,
            extract,
            colorize,
            dummy,
            spare: ctx.zeroed_storage("map view spare window", 16),
            dummy_weights,
        })
    }

    /// Workgroups covering `width` x `height` with 8x8 groups.
    fn groups(ctx: &GpuContext, width: u32, height: u32) -> Result<(u32, u32), GpuError> {
        let groups = (width.div_ceil(8), height.div_ceil(8));
        let max = ctx.limits.max_compute_workgroups_per_dimension;
        if groups.0 > max || groups.1 > max {
            return Err(mismatch(
                "map view",
                format!(
                    "{width}x{height} needs more than this adapter's {max} workgroups per axis"
                ),
            ));
        }
        Ok(groups)
    }

    fn dispatch(
        ctx: &GpuContext,
        what: &str,
        pipeline: &wgpu::ComputePipeline,
        layout: &wgpu::BindGroupLayout,
        entries: &[wgpu::BindGroupEntry],
        groups: (u32, u32),
    ) -> Result<(), GpuError> {
        ctx.checked(what, || {
            let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(what),
                layout,
                entries,
            });
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(what) });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(what),
                    timestamp_writes: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            }
            ctx.queue.submit([encoder.finish()]);
        })
    }

    /// Pass 1: the per-pixel value of `kind` (of source `source` for
    /// [`MapKind::uses_source`] kinds) into `target.values`. The target must have the maps'
    /// size.
    pub fn extract(
        &self,
        ctx: &GpuContext,
        sources: &MapSources,
        kind: MapKind,
        source: u32,
        target: &MapTarget,
    ) -> Result<(), GpuError> {
        let maps = sources.maps;
        if (target.width, target.height) != (maps.width, maps.height) {
            return Err(mismatch(
                "map view",
                format!(
                    "the target is {}x{} but the maps are {}x{}",
                    target.width, target.height, maps.width, maps.height
                ),
            ));
        }
        let n = target.pixels();
        let nsrc = maps.num_sources as u64;
        let kind = kind.base();
        check_size("plane", &maps.plane, n * 16)?;
        check_size("values", &target.values, n * 16)?;
        let dummy = &self.dummy;
        // The prior kinds read the prior planes as `planes` (depth, normal) or as `floats`
        // (the weight); a view without a prior has a zeroed buffer: no prior anywhere.
        let planes = match kind {
            MapKind::PriorDepth | MapKind::PriorNormal => &maps.prior,
            _ => &maps.plane,
        };
        check_size("prior", planes, n * 16)?;
        let (floats, words) = match kind {
            MapKind::PriorDepth | MapKind::PriorNormal | MapKind::PriorWeight => (dummy, dummy),
            MapKind::PriorEffect => (dummy, &maps.aux),
            MapKind::SupportPoints | MapKind::Triangulation => (dummy, sources.image),
            MapKind::Image => (dummy, sources.image),
            MapKind::Depth | MapKind::Normal => (dummy, dummy),
            MapKind::Cost => (&maps.cost, dummy),
            MapKind::SelectedCount | MapKind::SelectedBit => (dummy, &maps.selected),
            MapKind::Weight => (dummy, dummy),
            MapKind::Winner | MapKind::Replaced => (dummy, &maps.aux),
            MapKind::ReprojectionError | MapKind::RestorerDifference | MapKind::Anchors => {
                (&maps.extra, dummy)
            }
            MapKind::DepthError => (sources.ground_truth.unwrap_or(dummy), dummy),
            MapKind::Confidence => (sources.confidence.unwrap_or(dummy), dummy),
            MapKind::TextureReach => (sources.texture_reach.unwrap_or(dummy), dummy),
        };
        let input = match kind {
            MapKind::Confidence => sources.confidence,
            MapKind::TextureReach => sources.texture_reach,
            _ => sources.ground_truth,
        };
        let float_bytes = match kind {
            MapKind::Cost => n * 4,
            MapKind::ReprojectionError | MapKind::RestorerDifference | MapKind::Anchors => n * 8,
            MapKind::DepthError | MapKind::Confidence | MapKind::TextureReach
                if input.is_some() =>
            {
                n * 4
            }
            _ => 0,
        };
        let word_bytes = match kind {
            MapKind::Image
            | MapKind::SelectedCount
            | MapKind::SelectedBit
            | MapKind::Winner
            | MapKind::Replaced
            | MapKind::PriorEffect => n * 4,
            _ => 0,
        };
        check_size(kind.name(), floats, float_bytes)?;
        // The masks start at `selected_offset` of their buffer (the solver's aux).
        let word_offset = match kind {
            MapKind::SelectedCount | MapKind::SelectedBit => maps.selected_offset,
            _ => 0,
        };
        check_size(kind.name(), words, word_offset + word_bytes)?;
        let split = memory::plane_split(n);
        let params = MapParams {
            width: target.width,
            height: target.height,
            kind: kind.code(),
            source,
            num_sources: u32::try_from(maps.num_sources).unwrap_or(u32::MAX),
            has_input: u32::from(input.is_some()),
            prior_gamma: maps.prior_terms.map_or(0.0, |t| t.gamma),
            prior_inv_2sd2: maps.prior_terms.map_or(0.0, |t| t.inv_two_sigma_depth2),
            prior_inv_2sn2: maps.prior_terms.map_or(0.0, |t| t.inv_two_sigma_normal2),
            split: split as u32,
            ..MapParams::default()
        };
        let uniform = ctx.uniform_buffer("map view params", &params);
        let groups = Self::groups(ctx, target.width, target.height)?;
        let [planes_lo, planes_hi] = plane_windows(planes, n, dummy);
        let [priors_lo, priors_hi] = match kind {
            MapKind::PriorWeight => plane_windows(&maps.prior, n, dummy),
            _ => [
                dummy.as_entire_buffer_binding(),
                dummy.as_entire_buffer_binding(),
            ],
        };
        let [values_lo, values_hi] = plane_windows(&target.values, n, &self.spare);
        let words = wgpu::BufferBinding {
            buffer: words,
            offset: word_offset,
            size: wgpu::BufferSize::new(word_bytes.max(4).min(words.size() - word_offset)),
        };
        let buffers = [
            (0, uniform.as_entire_buffer_binding()),
            (1, planes_lo),
            (7, planes_hi),
            (2, floats.as_entire_buffer_binding()),
            (3, words),
            (8, priors_lo),
            (9, priors_hi),
            (4, values_lo),
            (10, values_hi),
        ];
        let mut entries: Vec<wgpu::BindGroupEntry> = buffers
            .into_iter()
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding,
                resource: wgpu::BindingResource::Buffer(buffer),
            })
            .collect();
        let weights = match kind {
            MapKind::Weight if u64::from(source) < nsrc => array_view(&maps.weights),
            _ => self.dummy_weights.clone(),
        };
        entries.push(wgpu::BindGroupEntry {
            binding: 6,
            resource: wgpu::BindingResource::TextureView(&weights),
        });
        Self::dispatch(
            ctx,
            "map view extract",
            &self.extract,
            &self.extract_layout,
            &entries,
            groups,
        )
    }

    /// Pass 2: `target.values` (of `kind`) to `target.texture`, scalars through `colormap`
    /// over `[lo, hi]` (t = 0 everywhere when hi <= lo), invalid pixels dark grey.
    pub fn colorize(
        &self,
        ctx: &GpuContext,
        target: &MapTarget,
        kind: MapKind,
        colormap: Colormap,
        lo: f32,
        hi: f32,
    ) -> Result<(), GpuError> {
        check_size("values", &target.values, target.pixels() * 16)?;
        let params = MapParams {
            width: target.width,
            height: target.height,
            kind: kind.code(),
            colormap: colormap.code(),
            lo,
            hi,
            split: memory::plane_split(target.pixels()) as u32,
            ..MapParams::default()
        };
        let uniform = ctx.uniform_buffer("map view params", &params);
        let groups = Self::groups(ctx, target.width, target.height)?;
        let [values_lo, values_hi] = plane_windows(&target.values, target.pixels(), &self.spare);
        let entries = [
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::Buffer(values_lo),
            },
            wgpu::BindGroupEntry {
                binding: 10,
                resource: wgpu::BindingResource::Buffer(values_hi),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: wgpu::BindingResource::TextureView(&target.view),
            },
        ];
        Self::dispatch(
            ctx,
            "map view colorize",
            &self.colorize,
            &self.colorize_layout,
            &entries,
            groups,
        )
    }

    /// The values of pass 1 (blocking).
    pub fn read_values(
        &self,
        ctx: &GpuContext,
        target: &MapTarget,
    ) -> Result<Vec<[f32; 4]>, GpuError> {
        ctx.read_buffer("map view values", &target.values)
    }

    /// The texture of pass 2, row-major (blocking; for tests and screenshots).
    pub fn read_texture(
        &self,
        ctx: &GpuContext,
        target: &MapTarget,
    ) -> Result<Vec<[u8; 4]>, GpuError> {
        let row = target.width as usize * 4;
        let padded = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize);
        let height = target.height as usize;
        let staging = ctx.checked("map view texture readback", || {
            let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("map view texture readback"),
                size: (padded * height) as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("map view texture readback"),
                });
            encoder.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture: &target.texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer: &staging,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(padded as u32),
                        rows_per_image: Some(target.height),
                    },
                },
                wgpu::Extent3d {
                    width: target.width,
                    height: target.height,
                    depth_or_array_layers: 1,
                },
            );
            ctx.queue.submit([encoder.finish()]);
            staging
        })?;
        let bytes: Vec<u8> = ctx.read_buffer("map view texture", &staging)?;
        Ok(bytes
            .chunks(padded)
            .take(height)
            .flat_map(|r| r[..row.min(r.len())].chunks_exact(4))
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect())
    }
}

fn scalar(x: f32, valid: bool) -> [f32; 4] {
    [x, if valid { 1.0 } else { 0.0 }, 0.0, 0.0]
}

/// CPU reference of pass 1 at pixel `i`: the same bits as the shader, except
/// [`MapKind::DepthError`], whose division WGSL only bounds to 2.5 ULP. Where
/// `maps.restorer_difference` / `reprojection_error` are `None` the value is 0 (what
/// `Session::gpu_maps` uploads); [`MapKind::Replaced`] reads aux bit 16. `input` is the
/// kind's per-pixel input where it has one: the ground-truth depth of
/// [`MapKind::DepthError`], the agreeing sources of [`MapKind::Confidence`].
pub fn extract_value(
    kind: MapKind,
    source: u32,
    maps: &ViewMaps,
    image: &[u32],
    input: Option<&[f32]>,
    i: usize,
) -> [f32; 4] {
    let st = &maps.state;
    let plane = st.plane.get(i).copied().unwrap_or_default();
    let depth = plane[3];
    let aux = st.aux.get(i).copied().unwrap_or(0);
    let extra =
        |map: &Option<Vec<f32>>| map.as_ref().and_then(|m| m.get(i)).copied().unwrap_or(0.0);
    let prior = maps
        .prior
        .as_ref()
        .and_then(|p| p.get(i))
        .copied()
        .unwrap_or_default();
    match kind {
        MapKind::PriorDepth => scalar(prior[3], prior[3] > 0.0),
        MapKind::PriorNormal => [
            prior[0],
            prior[1],
            prior[2],
            if prior[3] > 0.0 { 1.0 } else { 0.0 },
        ],
        MapKind::PriorWeight => match &maps.prior_terms {
            Some(t) if prior[3] > 0.0 && depth > 0.0 => {
                scalar(crate::acmm::planar::prior_factor(plane, prior, t), true)
            }
            _ => scalar(0.0, false),
        },
        MapKind::PriorEffect => scalar(((aux >> 17) & 1) as f32, true),
        MapKind::SupportPoints | MapKind::Triangulation => {
            extract_value(MapKind::Image, source, maps, image, input, i)
        }
        MapKind::Image => {
            let c = image.get(i).copied().unwrap_or(0);
            let channel = |shift: u32| ((c >> shift) & 0xff) as f32 * INV_255;
            [channel(0), channel(8), channel(16), 1.0]
        }
        MapKind::Depth => scalar(depth, depth > 0.0),
        MapKind::Normal => [
            plane[0],
            plane[1],
            plane[2],
            if depth > 0.0 { 1.0 } else { 0.0 },
        ],
        MapKind::Cost => scalar(st.cost.get(i).copied().unwrap_or(0.0), depth > 0.0),
        MapKind::SelectedCount => scalar(
            st.selected.get(i).copied().unwrap_or(0).count_ones() as f32,
            true,
        ),
        MapKind::SelectedBit => {
            if (source as usize) < st.num_sources.min(32) {
                let bits = st.selected.get(i).copied().unwrap_or(0);
                scalar(((bits >> source) & 1) as f32, true)
            } else {
                scalar(0.0, false)
            }
        }
        MapKind::Weight => {
            if (source as usize) < st.num_sources {
                let w = st
                    .weights
                    .get(i * st.num_sources + source as usize)
                    .copied()
                    .unwrap_or(0.0);
                scalar(w, true)
            } else {
                scalar(0.0, false)
            }
        }
        MapKind::Winner => match winner_value(aux & 0xff) {
            Some(v) => scalar(v, true),
            None => scalar(0.0, false),
        },
        MapKind::ReprojectionError => scalar(extra(&maps.reprojection_error), true),
        MapKind::RestorerDifference => scalar(extra(&maps.restorer_difference), true),
        MapKind::Anchors => {
            // The first extra map as `GpuMaps::upload` fills it.
            let first = maps.restorer_difference.as_ref().or(maps.anchors.as_ref());
            let code = first.and_then(|m| m.get(i)).copied().unwrap_or(0.0) as u32;
            scalar(
                (0..8).filter(|k| (code >> (3 * k)) & 7 != 0).count() as f32,
                true,
            )
        }
        MapKind::Replaced => scalar(((aux >> 16) & 1) as f32, true),
        MapKind::Confidence => match input.and_then(|c| c.get(i)) {
            Some(&c) if depth > 0.0 => scalar(c, true),
            _ => scalar(0.0, false),
        },
        MapKind::TextureReach => match input.and_then(|c| c.get(i)) {
            Some(&c) => scalar(c, true),
            None => scalar(0.0, false),
        },
        MapKind::DepthError => {
            let gt = input.and_then(|g| g.get(i)).copied().unwrap_or(0.0);
            if gt > 0.0 && depth > 0.0 {
                scalar((depth - gt).abs() / gt, true)
            } else {
                scalar(0.0, false)
            }
        }
    }
}

/// CPU reference of pass 2 for one value (alpha always 255).
pub fn colorize_value(
    kind: MapKind,
    value: [f32; 4],
    colormap: Colormap,
    lo: f32,
    hi: f32,
) -> [u8; 4] {
    let rgb = match kind {
        MapKind::Image | MapKind::SupportPoints | MapKind::Triangulation if value[3] > 0.5 => {
            [value[0], value[1], value[2]]
        }
        MapKind::Normal | MapKind::PriorNormal if value[3] > 0.5 => [
            value[0] * 0.5 + 0.5,
            (-value[1]) * 0.5 + 0.5,
            (-value[2]) * 0.5 + 0.5,
        ],
        k if k.is_color() => [INVALID_GREY; 3],
        MapKind::Winner if value[1] > 0.5 => winner_color(value[0]).map(|c| c as f32 * INV_255),
        _ if value[1] > 0.5 => {
            let span = hi - lo;
            let t = if span > 0.0 {
                (value[0] - lo) / span
            } else {
                0.0
            };
            colormap.rgb(t)
        }
        _ => [INVALID_GREY; 3],
    };
    let [r, g, b] = rgb.map(unorm8);
    [r, g, b, 255]
}

/// The values between percentiles `lo_pct` and `hi_pct` (0..=100, linear between ranks) of
/// the valid, finite values; `None` when there are none or `kind.is_color()`.
pub fn percentile_range(
    kind: MapKind,
    values: &[[f32; 4]],
    lo_pct: f32,
    hi_pct: f32,
) -> Option<(f32, f32)> {
    if kind.is_color() {
        return None;
    }
    let mut valid: Vec<f32> = values
        .iter()
        .filter(|v| v[1] > 0.5 && v[0].is_finite())
        .map(|v| v[0])
        .collect();
    if valid.is_empty() {
        return None;
    }
    valid.sort_by(f32::total_cmp);
    let at = |pct: f32| {
        let pct = if pct >= 0.0 { pct.min(100.0) } else { 0.0 };
        let pos = f64::from(pct) / 100.0 * (valid.len() - 1) as f64;
        let k = pos.floor() as usize;
        let next = (k + 1).min(valid.len() - 1);
        let f = pos - k as f64;
        (f64::from(valid[k]) + (f64::from(valid[next]) - f64::from(valid[k])) * f) as f32
    };
    let (a, b) = (at(lo_pct), at(hi_pct));
    Some((a.min(b), a.max(b)))
}

/// The fixed range of a kind whose values have one: SelectedBit and Replaced 0..1,
/// SelectedCount 0..num_sources, Winner 0..15 (15 = initial), Cost 0..2.
pub fn natural_range(kind: MapKind, num_sources: usize) -> Option<(f32, f32)> {
    match kind {
        MapKind::SelectedBit | MapKind::Replaced | MapKind::PriorEffect => Some((0.0, 1.0)),
        MapKind::SelectedCount => Some((0.0, num_sources as f32)),
        MapKind::Winner => Some((0.0, WINNER_INITIAL_VALUE)),
        MapKind::Cost => Some((0.0, 2.0)),
        MapKind::Anchors => Some((0.0, 8.0)),
        _ => None,
    }
}

/// Label of a winner code (`aux & 0xff`).
pub fn winner_label(code: u32) -> String {
    const AREAS: [&str; 8] = [
        "up V",
        "up strip",
        "down V",
        "down strip",
        "left V",
        "left strip",
        "right V",
        "right strip",
    ];
    const REFINED: [&str; 6] = [
        "d_rand, n",
        "d, n_rand",
        "d_rand, n_rand",
        "d_pert, n",
        "d, n_pert",
        "d_pert, n_pert",
    ];
    match Winner::from_code(code) {
        Some(Winner::Initial) => "initial (random plane)".to_string(),
        Some(Winner::Propagated(a)) => format!(
            "propagated ({})",
            AREAS.get(a as usize).copied().unwrap_or("?")
        ),
        Some(Winner::Kept) => "kept".to_string(),
        Some(Winner::PriorUnseen) => "its prior plane (no source sees it)".to_string(),
        Some(Winner::Refined(r)) => format!(
            "refined ({})",
            REFINED.get(r as usize).copied().unwrap_or("?")
        ),
        None => "none".to_string(),
    }
}

/// Text of a value for the hover readout ("depth 3.412", "winner: refined (d, n_pert)",
/// "no estimate").
pub fn describe_value(kind: MapKind, value: [f32; 4]) -> String {
    let [x, y, z, w] = value;
    let valid = if kind.is_color() { w > 0.5 } else { y > 0.5 };
    if !valid {
        return match kind {
            MapKind::Winner => "winner: none".to_string(),
            MapKind::SelectedBit | MapKind::Weight => "no such source".to_string(),
            MapKind::DepthError => "no estimate or no ground truth".to_string(),
            MapKind::Confidence => "no estimate, or not fused yet (Fuse)".to_string(),
            MapKind::TextureReach => "not measured".to_string(),
            MapKind::PriorDepth | MapKind::PriorNormal => {
                let reason = crate::acmm::planar::no_prior_reason(if kind == MapKind::PriorDepth {
                    x
                } else {
                    0.0
                });
                format!("no prior: {}", reason.unwrap_or("none here"))
            }
            MapKind::PriorWeight => "no prior here".to_string(),
            _ => "no estimate".to_string(),
        };
    }
    match kind {
        MapKind::Image | MapKind::SupportPoints | MapKind::Triangulation => {
            let [r, g, b] = [x, y, z].map(unorm8);
            format!("rgb ({r}, {g}, {b})")
        }
        MapKind::PriorDepth => format!("prior depth {x:.3}"),
        MapKind::PriorNormal => format!("prior normal ({x:.2}, {y:.2}, {z:.2})"),
        MapKind::PriorWeight => format!("prior factor {x:.3} (γ … 1 + γ)"),
        MapKind::PriorEffect => {
            if x > 0.5 {
                "restarted from / chosen by the prior".to_string()
            } else {
                "the prior did not decide".to_string()
            }
        }
        MapKind::Depth => format!("depth {x:.3}"),
        MapKind::Normal => format!("normal ({x:.2}, {y:.2}, {z:.2})"),
        MapKind::Cost => format!("cost {x:.3}"),
        MapKind::SelectedCount => format!("{x} views selected"),
        MapKind::SelectedBit => {
            if x > 0.5 {
                "selected".to_string()
            } else {
                "not selected".to_string()
            }
        }
        MapKind::Weight => format!("weight {x:.3}"),
        MapKind::Winner => {
            let code = if x >= WINNER_INITIAL_VALUE {
                Winner::INITIAL
            } else {
                x as u32
            };
            format!("winner: {}", winner_label(code))
        }
        MapKind::ReprojectionError => format!("reprojection error {x:.2} px"),
        MapKind::RestorerDifference => format!("C_init − C_photo {x:.3}"),
        MapKind::Replaced => {
            if x > 0.5 {
                "replaced by the restorer".to_string()
            } else {
                "not replaced".to_string()
            }
        }
        MapKind::DepthError => format!("depth error {:.2} %", x * 100.0),
        MapKind::Confidence => format!("{x:.0} source(s) agree"),
        MapKind::Anchors => format!("{x:.0} anchor(s) agree on its plane"),
        MapKind::TextureReach => format!("{x:.0} px to texture at this scale"),
    }
}

/// [`MapKind::TextureReach`]'s input: each pixel's chessboard distance (pixels of `image`)
/// to the nearest pixel whose window of `radius` varies by 3 grey levels or more; the long
/// side where the image has no textured pixel.
pub fn texture_reach(image: &Image, radius: u32) -> Vec<f32> {
    use crate::acmm::pyramid_depth::{chessboard_distance, textured_mask};
    let mask = textured_mask(&image.gray, image.width, image.height, radius);
    let far = image.width.max(image.height);
    chessboard_distance(&mask, image.width, image.height)
        .into_iter()
        .map(|d| d.min(far) as f32)
        .collect()
}

/// An image as pass 1 reads it: `r | g << 8 | b << 16 | 255 << 24` per pixel.
pub fn pack_rgba(image: &Image) -> Vec<u32> {
    image
        .rgb
        .iter()
        .map(|p| u32::from(p[0]) | u32::from(p[1]) << 8 | u32::from(p[2]) << 16 | 0xff << 24)
        .collect()
}

/// A colour ramp of `cmap`, `width` points wide, from its low end on the left.
pub fn ramp(ui: &mut egui::Ui, cmap: Colormap, width: f32) -> egui::Rect {
    let (rect, _) = ui.allocate_exact_size(egui::Vec2::new(width, 12.0), egui::Sense::hover());
    let steps = 64;
    for s in 0..steps {
        let c = cmap.color(s as f32 / (steps - 1) as f32);
        let x0 = rect.left() + rect.width() * s as f32 / steps as f32;
        let x1 = rect.left() + rect.width() * (s + 1) as f32 / steps as f32;
        ui.painter().rect_filled(
            egui::Rect::from_min_max(egui::pos2(x0, rect.top()), egui::pos2(x1, rect.bottom())),
            0.0,
            egui::Color32::from_rgb(c[0], c[1], c[2]),
        );
    }
    rect
}
