//! Device memory a run needs, known before it allocates anything.
//!
//! A run keeps its state on the device (see `crate::session`): per level, every view's
//! intensities (one f32 texel per pixel, each view a layer of one texture as large as the
//! largest view) and the depth snapshot (one f32 per pixel, one shared buffer), and per
//! estimated view its planes (16 B/pixel), cost, selection, aux (4 B each), the source weights
//! (4 B per source), the three extra maps (12 B) and the kept planes (16 B). While a level
//! starts, the coarser level's images and a view's coarse buffers are still alive. Checkpoints
//! (the viewer's) come on top: one copy of the views' maps per stage.
//!
//! [`MemoryPlan::check`] holds the peak of each level against the adapter's limits (largest
//! buffer and storage binding, texture side and layers) and, where known, its memory: wgpu reports no memory size, so
//! it is read from `MVSCOPE_DEVICE_MEMORY_MB` when set, and for a software adapter (whose
//! memory is the host's) from the host's available memory.

use super::multiscale::pyramid_scales;
use super::params::{Method, Params};
use crate::scene::{Scene, scaled_size};

/// Bytes per pixel of a view's own buffers, besides 4 per source for the weights.
pub const VIEW_BYTES_PER_PIXEL: u64 = 16 + 4 + 4 + 4 + 12 + 16;

/// One pyramid level's needs.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelMemory {
    /// 0 = coarsest.
    pub level: u32,
    pub scale: f64,
    /// The largest view at this level.
    pub largest_view: (u32, u32),
    /// Every view's intensities (the texture) plus the depth snapshot.
    pub images: u64,
    /// The texture's side (the largest view's width or height) and layers (views).
    pub texture_side: u32,
    pub layers: u32,
    /// Every estimated view's buffers.
    pub views: u64,
    /// The largest single buffer (the depth snapshot, or one view's weights or planes).
    pub largest_buffer: u64,
    /// The most held at once while this level runs (its start included).
    pub peak: u64,
}

/// A run's device memory, level by level.
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryPlan {
    pub levels: Vec<LevelMemory>,
}

/// What a scene looks like to the plan: each view's size and number of sources.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewShape {
    pub width: u32,
    pub height: u32,
    pub sources: usize,
}

impl ViewShape {
    pub fn of_scene(scene: &Scene) -> Vec<ViewShape> {
        scene
            .views
            .iter()
            .map(|v| ViewShape {
                width: v.image.width,
                height: v.image.height,
                sources: v.sources.len(),
            })
            .collect()
    }
}

/// Why a run does not fit.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct MemoryError(pub String);

/// The largest buffer one view's solver holds: its planes (16 bytes a pixel) or its view
/// weights (4 bytes a pixel per source).
pub fn largest_view_buffer(width: u32, height: u32, sources: usize) -> u64 {
    width as u64 * height as u64 * 16.max(4 * sources as u64)
}

/// The most one storage buffer may hold on an adapter with `limits`.
pub fn binding_limit(limits: &wgpu::Limits) -> u64 {
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
}

pub(crate) fn mib(bytes: u64) -> String {
    if bytes >= 10 << 30 {
        format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
    } else {
        format!("{} MiB", bytes.div_ceil(1 << 20))
    }
}

impl MemoryPlan {
    /// The plan of `views` (at the processed size) run with `method` and `params`.
    pub fn new(views: &[ViewShape], params: &Params, method: Method) -> MemoryPlan {
        let long_side = views
            .iter()
            .map(|v| v.width.max(v.height))
            .max()
            .unwrap_or(1);
        let mut levels: Vec<LevelMemory> = Vec::new();
        let mut previous: Option<(u64, u64)> = None; // images, largest coarse view
        for (level, &scale) in pyramid_scales(params, method, long_side).iter().enumerate() {
            let sizes: Vec<(u32, u32)> = views
                .iter()
                .map(|v| {
                    if (scale - 1.0).abs() < 1e-12 {
                        (v.width, v.height)
                    } else {
                        scaled_size(v.width, v.height, scale)
                    }
                })
                .collect();
            let pixels: Vec<u64> = sizes.iter().map(|&(w, h)| w as u64 * h as u64).collect();
            let max_w = sizes.iter().map(|s| s.0).max().unwrap_or(0) as u64;
            let max_h = sizes.iter().map(|s| s.1).max().unwrap_or(0) as u64;
            let snapshot = 4 * pixels.iter().sum::<u64>();
            let texture = 4 * max_w * max_h * sizes.len() as u64;
            let images = texture + snapshot;
            let per_view: Vec<u64> = views
                .iter()
                .zip(&pixels)
                .map(|(v, &n)| {
                    if v.sources == 0 {
                        0
                    } else {
                        n * (VIEW_BYTES_PER_PIXEL + 4 * v.sources as u64)
                    }
                })
                .collect();
            let views_bytes: u64 = per_view.iter().sum();
            let largest_view_bytes = per_view.iter().copied().max().unwrap_or(0);
            let largest_buffer = views
                .iter()
                .zip(&sizes)
                .map(|(v, &(w, h))| largest_view_buffer(w, h, v.sources))
                .max()
                .unwrap_or(0)
                .max(snapshot);
            let peak = match previous {
                Some((coarse_images, coarse_view)) => {
                    images + views_bytes + coarse_images + coarse_view
                }
                None => images + views_bytes,
            };
            levels.push(LevelMemory {
                level: level as u32,
                scale,
                largest_view: sizes
                    .iter()
                    .copied()
                    .max_by_key(|&(w, h)| w as u64 * h as u64)
                    .unwrap_or((0, 0)),
                images,
                texture_side: max_w.max(max_h) as u32,
                layers: sizes.len() as u32,
                views: views_bytes,
                largest_buffer,
                peak,
            });
            previous = Some((images, largest_view_bytes));
        }
        MemoryPlan { levels }
    }

    pub fn for_scene(scene: &Scene, params: &Params, method: Method) -> MemoryPlan {
        Self::new(&ViewShape::of_scene(scene), params, method)
    }

    /// The most any level holds at once.
    pub fn peak(&self) -> u64 {
        self.levels.iter().map(|l| l.peak).max().unwrap_or(0)
    }

    /// Fails, naming the level, the view size and the figure, when a level does not fit the
    /// limits (`memory`: the device's memory where known).
    pub fn check(
        &self,
        limits: &wgpu::Limits,
        memory: Option<u64>,
        fix: &dyn Fn() -> String,
    ) -> Result<(), MemoryError> {
        let binding = binding_limit(limits);
        let count = self.levels.len();
        for l in &self.levels {
            let (w, h) = l.largest_view;
            let at = format!("scale {}/{count} (views up to {w}x{h})", l.level + 1);
            if l.texture_side > limits.max_texture_dimension_2d {
                return Err(MemoryError(format!(
                    "{at} needs a texture of side {}, beyond this adapter's {}; {}",
                    l.texture_side,
                    limits.max_texture_dimension_2d,
                    fix()
                )));
            }
            if l.layers > limits.max_texture_array_layers {
                return Err(MemoryError(format!(
                    "{at} has {} views, beyond this adapter's {} texture layers; run fewer views",
                    l.layers, limits.max_texture_array_layers
                )));
            }
            if l.largest_buffer > binding {
                return Err(MemoryError(format!(
                    "{at} needs a {} buffer, beyond this adapter's {} per storage buffer; {}",
                    mib(l.largest_buffer),
                    mib(binding),
                    fix()
                )));
            }
            if let Some(memory) = memory
                && l.peak > memory
            {
                return Err(MemoryError(format!(
                    "{at} needs {} of device memory, beyond the {} available; {}",
                    mib(l.peak),
                    mib(memory),
                    fix()
                )));
            }
        }
        Ok(())
    }

    /// The table `mvscope info` prints.
    pub fn describe(&self) -> String {
        let count = self.levels.len();
        let mut out = String::new();
        for l in &self.levels {
            let (w, h) = l.largest_view;
            out.push_str(&format!(
                "  scale {}/{count} (x{:.3}, views up to {w}x{h}): images + depth snapshot {}, view buffers {}, largest buffer {}, peak {}\n",
                l.level + 1,
                l.scale,
                mib(l.images),
                mib(l.views),
                mib(l.largest_buffer),
                mib(l.peak)
            ));
        }
        out
    }
}

/// The device's memory where it can be known: `MVSCOPE_DEVICE_MEMORY_MB`, else for a
/// software adapter the host's available memory (Linux), else `None`.
pub fn device_memory(software: bool) -> Option<u64> {
    if let Some(mb) = std::env::var("MVSCOPE_DEVICE_MEMORY_MB")
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok())
    {
        return Some(mb << 20);
    }
    if !software {
        return None;
    }
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb << 10)
}

/// The largest `--max-image-size` (long side, a multiple of 16) at which `views` fit, if any
/// below their current size.
pub fn largest_fitting_size(
    views: &[ViewShape],
    params: &Params,
    method: Method,
    limits: &wgpu::Limits,
    memory: Option<u64>,
) -> Option<u32> {
    let long_side = views
        .iter()
        .map(|v| v.width.max(v.height))
        .max()
        .unwrap_or(0);
    let fits = |side: u32| {
        let scaled: Vec<ViewShape> = views
            .iter()
            .map(|v| {
                let long = v.width.max(v.height);
                let (width, height) = if long > side {
                    let (w, h) = scaled_size(v.width, v.height, side as f64 / long as f64);
                    (w.min(side), h.min(side))
                } else {
                    (v.width, v.height)
                };
                ViewShape {
                    width,
                    height,
                    sources: v.sources,
                }
            })
            .collect();
        MemoryPlan::new(&scaled, params, method)
            .check(limits, memory, &String::new)
            .is_ok()
    };
    let mut best = None;
    let mut side = 16;
    while side < long_side {
        if fits(side) {
            best = Some(side);
        } else {
            break;
        }
        side += 16;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shapes(n: usize, w: u32, h: u32, sources: usize) -> Vec<ViewShape> {
        (0..n)
            .map(|_| ViewShape {
                width: w,
                height: h,
                sources,
            })
            .collect()
    }

    #[test]
    fn levels_follow_the_pyramid_and_count_every_buffer() {
        let params = Params::default();
        let plan = MemoryPlan::new(&shapes(3, 400, 300, 2), &params, Method::Acmm);
        assert_eq!(plan.levels.len() as u32, params.scales);
        let fine = plan.levels.last().unwrap();
        assert_eq!(fine.largest_view, (400, 300));
        let n = 400 * 300;
        assert_eq!(fine.images, 3 * n * 8, "texture layers and snapshot");
        assert_eq!((fine.texture_side, fine.layers), (400, 3));
        assert_eq!(fine.views, 3 * n * (VIEW_BYTES_PER_PIXEL + 8));
        // The coarse level's images and one coarse view are still alive at the start.
        let coarse = &plan.levels[plan.levels.len() - 2];
        let coarse_view = coarse.views / 3;
        assert_eq!(
            fine.peak,
            fine.images + fine.views + coarse.images + coarse_view
        );
        let acmh = MemoryPlan::new(&shapes(3, 400, 300, 2), &params, Method::Acmh);
        assert_eq!(acmh.levels.len(), 1);
    }

    #[test]
    fn views_beyond_the_texture_limits_are_refused_before_anything_is_allocated() {
        // The intensities are layers of one texture: its side is the largest view's, its
        // layers the views. 12000 px is beyond a 8192 px texture limit at the finest scale
        // only; 300 views are beyond 256 layers at every scale.
        let params = Params::default();
        let limits = wgpu::Limits {
            max_texture_dimension_2d: 8192,
            max_texture_array_layers: 256,
            ..wgpu::Limits::default()
        };
        let wide = shapes(3, 12000, 800, 2);
        let err = MemoryPlan::new(&wide, &params, Method::Acmh)
            .check(&limits, None, &|| "use --max-image-size 8192".into())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("texture of side 12000") && err.contains("8192"),
            "{err}"
        );
        let fit = largest_fitting_size(&wide, &params, Method::Acmh, &limits, None);
        assert_eq!(fit, Some(8192));
        let many = shapes(300, 64, 48, 2);
        let err = MemoryPlan::new(&many, &params, Method::Acmm)
            .check(&limits, None, &String::new)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("scale 1/") && err.contains("300 views") && err.contains("256"),
            "{err}"
        );
    }

    #[test]
    fn a_views_largest_buffer_is_its_planes_or_its_weights() {
        // Four sources or fewer: the planes (16 B a pixel); more: the view weights.
        assert_eq!(largest_view_buffer(640, 480, 2), 640 * 480 * 16);
        assert_eq!(largest_view_buffer(3072, 2048, 10), 3072 * 2048 * 40);
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: 128 << 20,
            max_buffer_size: 256 << 20,
            ..wgpu::Limits::default()
        };
        assert_eq!(binding_limit(&limits), 128 << 20);
        // 240 MiB of weights: beyond a laptop-like binding; what a solver made alone refuses.
        assert!(largest_view_buffer(3072, 2048, 10) > binding_limit(&limits));
    }

    #[test]
    fn a_large_scene_against_a_small_limit_names_level_size_and_fix() {
        // Eleven 6000x4000 views with ten sources each against a laptop-like adapter:
        // 128 MiB per storage binding, 4 GiB of memory.
        let views = shapes(11, 6000, 4000, 10);
        let params = Params::default();
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: 128 << 20,
            max_buffer_size: 256 << 20,
            ..wgpu::Limits::default()
        };
        let plan = MemoryPlan::new(&views, &params, Method::Acmm);
        let fit = largest_fitting_size(&views, &params, Method::Acmm, &limits, Some(4 << 30));
        let side = fit.expect("a smaller size fits");
        let err = plan
            .check(&limits, Some(4 << 30), &|| {
                format!("use --max-image-size {side} or less")
            })
            .unwrap_err()
            .to_string();
        // Scale 1/3 (1500x1000) fits; at 2/3 the eleven views' depth snapshot alone is
        // 11 x 3000 x 2000 x 4 B = 252 MiB, beyond the 128 MiB binding.
        assert!(
            err.contains("scale 2/3"),
            "the first level that fails: {err}"
        );
        assert!(err.contains("views up to 3000x2000"), "{err}");
        assert!(
            err.contains("MiB") && err.contains("--max-image-size"),
            "{err}"
        );
        // The suggested size really fits, and 16 px more does not.
        let at = |s: u32| {
            let (w, h) = scaled_size(6000, 4000, s as f64 / 6000.0);
            let scaled = shapes(11, w.min(s), h.min(s), 10);
            MemoryPlan::new(&scaled, &params, Method::Acmm)
                .check(&limits, Some(4 << 30), &String::new)
                .is_ok()
        };
        assert!(at(side), "{side} fits");
        assert!(!at(side + 16), "{} does not", side + 16);
        // Without a memory figure only the binding limit decides.
        assert!(
            largest_fitting_size(&views, &params, Method::Acmm, &limits, None).unwrap() >= side
        );
    }
}
