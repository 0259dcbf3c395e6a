//! Device memory a run needs, known before it allocates anything, and the batches that keep
//! it within a budget.
//!
//! A run keeps its state on the device (see `crate::session`): per level, the intensities
//! and the depth snapshot of the views it holds (each a layer of two textures as large as
//! the largest of them: 8 B a pixel), and per estimated view its planes (16 B/pixel), cost,
//! selection, aux (4 B each), the source weights (4 B per source, a texture layer each), the
//! two extra maps and the median's scratch (12 B) and the kept planes (16 B). While a level starts, the coarser
//! level's images and a view's coarse buffers are still alive. Checkpoints (the viewer's)
//! come on top.
//!
//! When every view fits at once ([`BatchPlan::resident`]), a run holds them all for the whole
//! schedule. When not, each stage streams its views through the device in **batches**: a
//! batch holds its views' state and the images and depths of their sources, nothing of the
//! other views, whose states wait on the host (`crate::session`). Batches are ordered so that
//! neighbours share sources (what one batch decoded the next one reuses); the order changes
//! nothing in the maps (the snapshot rule), which tests check byte for byte.
//!
//! No binding grows with the number of views or sources: the images and depth snapshots are
//! texture arrays of a batch's views, the weights a texture array of a view's sources; the
//! largest binding is 8 bytes a pixel: half a view's planes (a vec4 map is bound as two
//! windows of its buffer), or two of its scalar maps (48 MiB for a 6.3 Mpx view of
//! Fountain-P11, 92 MiB for a 12 Mpx one, within the 128 MiB of llvmpipe and WebGPU's
//! default).
//!
//! The device's memory is not reported by wgpu: [`device_memory`] reads it from
//! `MVSCOPE_DEVICE_MEMORY_MB` when set, and for a software adapter (whose memory is the
//! host's) from the host's available memory; `--device-memory` overrides both.

use super::multiscale::pyramid_scales;
use super::params::{Method, Params};
use crate::scene::{Scene, scaled_size};

/// Bytes per pixel of a view's own buffers, besides 4 per source for the weights.
pub const VIEW_BYTES_PER_PIXEL: u64 = 16 + 4 + 4 + 4 + 12 + 16;

/// Bytes per texel of a held view's layers: its intensity and its depth in the snapshot.
pub const LAYER_BYTES_PER_PIXEL: u64 = 8;

/// The share of a figure of the device's memory (the environment's, or the host's for a
/// software adapter) that a run plans to use: the rest is headroom for the driver, the
/// viewer's own textures and what the figure does not count.
pub const HEADROOM: f64 = 0.85;

/// One pyramid level's needs when every view is held.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelMemory {
    /// 0 = coarsest.
    pub level: u32,
    pub scale: f64,
    /// The largest view at this level.
    pub largest_view: (u32, u32),
    /// Every view's intensities and depth snapshot (two texture arrays).
    pub images: u64,
    /// The textures' side (the largest view's width or height) and layers (views).
    pub texture_side: u32,
    pub layers: u32,
    /// Every estimated view's buffers.
    pub views: u64,
    /// The largest single binding (half of the largest view's planes, or its costs).
    pub largest_buffer: u64,
    /// The most held at once while this level runs (its start included).
    pub peak: u64,
}

/// A run's device memory, level by level, with every view held at once.
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryPlan {
    pub levels: Vec<LevelMemory>,
}

/// What a scene looks like to the plan: each view's size and its source views (indices).
#[derive(Clone, Debug, PartialEq)]
pub struct ViewShape {
    pub width: u32,
    pub height: u32,
    pub sources: Vec<usize>,
    /// Its name in messages (the image's file name).
    pub name: String,
}

impl ViewShape {
    pub fn of_scene(scene: &Scene) -> Vec<ViewShape> {
        scene
            .views
            .iter()
            .map(|v| ViewShape {
                width: v.image.width,
                height: v.image.height,
                sources: v.sources.iter().map(|s| s.index).collect(),
                name: v.name.clone(),
            })
            .collect()
    }
}

/// Why a run does not fit.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct MemoryError(pub String);

/// The alignment of a storage binding's offset: WebGPU's largest allowed
/// `min_storage_buffer_offset_alignment`, so a window placed on it is valid on any adapter.
pub const BINDING_ALIGNMENT: u64 = 256;

/// Where a view of `pixels` pixels splits its vec4 maps (planes, prior planes) into the two
/// windows the passes bind (`plane_lo`, `plane_hi` in shaders/shared/problem.wgsl): the
/// first pixel of the second window, half the pixels rounded up to a binding offset. A view
/// too small to split (the second window would be empty) gets `pixels`: one window.
pub fn plane_split(pixels: u64) -> u64 {
    let half = pixels.div_ceil(2).next_multiple_of(BINDING_ALIGNMENT / 16);
    if half >= pixels { pixels } else { half }
}

/// Where the selected-view masks start in a view's `aux` buffer (u32 index): after its `n`
/// aux words, on a binding offset.
pub fn selected_base(pixels: u64) -> u64 {
    (pixels * 4).next_multiple_of(BINDING_ALIGNMENT) / 4
}

/// The largest binding one view's solver makes: a window of its planes (half of 16 bytes a
/// pixel; its kept planes alike), its aux words and selection masks or its two extra maps
/// (8 bytes a pixel each); its weights are texture layers, a layer per source. 8 bytes a
/// pixel: a 12 Mpx view (4000x3000) needs 92 MiB, within the 128 MiB of llvmpipe and
/// WebGPU's default.
pub fn largest_view_buffer(width: u32, height: u32) -> u64 {
    let n = width as u64 * height as u64;
    let split = plane_split(n);
    let planes = 16 * split.max(n - split);
    let aux = 4 * (selected_base(n) + n);
    planes.max(aux).max(8 * n)
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
    } else if bytes < 1 << 20 {
        format!("{:.2} MiB", bytes as f64 / (1u64 << 20) as f64)
    } else {
        format!("{} MiB", bytes.div_ceil(1 << 20))
    }
}

/// Each level's scale and every view's size at it, coarsest first (`long_side`: the whole
/// scene's longest image side, which sets the number of scales).
pub fn level_sizes(
    views: &[ViewShape],
    params: &Params,
    method: Method,
    long_side: u32,
) -> Vec<(f64, Vec<(u32, u32)>)> {
    pyramid_scales(params, method, long_side)
        .into_iter()
        .map(|scale| {
            let sizes = views
                .iter()
                .map(|v| {
                    if (scale - 1.0).abs() < 1e-12 {
                        (v.width, v.height)
                    } else {
                        scaled_size(v.width, v.height, scale)
                    }
                })
                .collect();
            (scale, sizes)
        })
        .collect()
}

fn long_side(views: &[ViewShape]) -> u32 {
    views
        .iter()
        .map(|v| v.width.max(v.height))
        .max()
        .unwrap_or(1)
}

/// A view's own buffers at `size` with `sources` sources (0: not estimated, no buffers), and
/// with `planar` (the grid cell, for a method with the planar prior) its prior's buffers.
fn view_bytes((w, h): (u32, u32), sources: usize, planar: Option<u32>) -> u64 {
    if sources == 0 {
        return 0;
    }
    w as u64 * h as u64 * (VIEW_BYTES_PER_PIXEL + 4 * sources as u64)
        + planar.map_or(0, |cell| planar_bytes((w, h), cell))
}

/// The planar prior's buffers of a view at `size` with grid cells of `cell` px
/// (`crate::gpu::planar::PlanarBuffers`, and the prior planes the prior-plane step keeps for
/// the view's maps): a support record a cell (32 B), room for three triangles a cell (48 B
/// each), a label a pixel (4 B), the copy of the prior planes (16 B a pixel) and the passes'
/// parameter block (at most [`PLANAR_PARAMS_BYTES`]).
pub fn planar_bytes((w, h): (u32, u32), cell: u32) -> u64 {
    let (cx, cy) = super::planar::cell_grid(w, h, cell.max(1));
    let cells = cx as u64 * cy as u64;
    let pixels = w as u64 * h as u64;
    cells * size_of::<super::planar::SupportRecord>() as u64
        + 3 * cells * size_of::<super::planar::GpuTriangle>() as u64
        + pixels * (4 + 16)
        + PLANAR_PARAMS_BYTES
}

/// A bound on the planar prior passes' parameter block (a uniform buffer a view).
pub const PLANAR_PARAMS_BYTES: u64 = 256;

/// The grid cell of `method`'s planar prior, `None` for a method without one.
fn planar_cell(params: &Params, method: Method) -> Option<u32> {
    method.has_planar_prior().then_some(params.prior_cell)
}

/// The layers of `held` views at `sizes`: every layer as large as the largest of them.
fn layer_bytes(sizes: &[(u32, u32)], held: impl Iterator<Item = usize>) -> (u64, u32, u32) {
    let (mut w, mut h, mut count) = (0u64, 0u64, 0u32);
    for v in held {
        w = w.max(sizes[v].0 as u64);
        h = h.max(sizes[v].1 as u64);
        count += 1;
    }
    (
        LAYER_BYTES_PER_PIXEL * w * h * count as u64,
        w.max(h) as u32,
        count,
    )
}

impl MemoryPlan {
    /// The plan of `views` (at the processed size) run with `method` and `params`, every view
    /// held at once.
    pub fn new(views: &[ViewShape], params: &Params, method: Method) -> MemoryPlan {
        Self::with_long_side(views, params, method, long_side(views))
    }

    /// As [`MemoryPlan::new`] for a part of a scene whose whole has `long_side`.
    pub fn with_long_side(
        views: &[ViewShape],
        params: &Params,
        method: Method,
        long_side: u32,
    ) -> MemoryPlan {
        let mut levels: Vec<LevelMemory> = Vec::new();
        let mut previous: Option<(u64, u64)> = None; // images, largest coarse view
        for (level, (scale, sizes)) in level_sizes(views, params, method, long_side)
            .into_iter()
            .enumerate()
        {
            let (images, texture_side, layers) = layer_bytes(&sizes, 0..sizes.len());
            let per_view: Vec<u64> = views
                .iter()
                .zip(&sizes)
                .map(|(v, &s)| view_bytes(s, v.sources.len(), planar_cell(params, method)))
                .collect();
            let views_bytes: u64 = per_view.iter().sum();
            let largest_view_bytes = per_view.iter().copied().max().unwrap_or(0);
            let largest_buffer = views
                .iter()
                .zip(&sizes)
                .filter(|(v, _)| !v.sources.is_empty())
                .map(|(_, &(w, h))| largest_view_buffer(w, h))
                .max()
                .unwrap_or(0);
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
                texture_side,
                layers,
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
    /// limits (`memory`: the budget, where known).
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
                    "{at} has {} views, beyond this adapter's {} texture layers; {}",
                    l.layers,
                    limits.max_texture_array_layers,
                    fix()
                )));
            }
            if l.largest_buffer > binding {
                return Err(MemoryError(format!(
                    "{at} needs a {} binding, beyond this adapter's {} per storage buffer; {}",
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
                "  scale {}/{count} (x{:.3}, views up to {w}x{h}): images + depth snapshot {}, view buffers {}, largest binding {}, peak {}\n",
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
    host_available_memory()
}

/// The host's available memory (Linux `MemAvailable`), bytes.
pub fn host_available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb << 10)
}

/// The budget a run plans with: `--device-memory` (MiB) as given, else [`HEADROOM`] of what
/// [`device_memory`] knows, else none (a hardware adapter whose memory nobody stated).
pub fn default_budget(explicit_mib: Option<u64>, software: bool) -> Option<u64> {
    match explicit_mib {
        Some(mb) => Some(mb << 20),
        None => device_memory(software).map(|m| (m as f64 * HEADROOM) as u64),
    }
}

/// How a run holds its views on the device: all at once, or stage by stage in batches.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchPlan {
    /// The estimated views in run order, in batches (one batch of all of them when
    /// `resident`).
    pub batches: Vec<Vec<usize>>,
    /// Every view held for the whole run (today's fast path).
    pub resident: bool,
    /// The most the run holds at once: the resident plan's peak, or the largest batch's.
    pub peak: u64,
    /// The budget planned against (`None`: unknown; only the adapter's limits count).
    pub budget: Option<u64>,
}

/// The device's limits that decide a plan, and the budget.
#[derive(Clone, Debug)]
pub struct Limits<'a> {
    pub adapter: &'a wgpu::Limits,
    pub budget: Option<u64>,
}

impl BatchPlan {
    /// Holds every view at once when that fits (`force_batch`: a batch size asked for, in
    /// views, e.g. by a test or a benchmark comparing the two), else batches of views that
    /// fit. `long_side` is the whole scene's longest side (a part of a scene keeps its
    /// pyramid). Fails, naming the view, when a view and its sources alone do not fit.
    pub fn new(
        views: &[ViewShape],
        params: &Params,
        method: Method,
        long_side: u32,
        limits: &Limits,
    ) -> Result<BatchPlan, MemoryError> {
        let estimated: Vec<usize> = (0..views.len())
            .filter(|&v| !views[v].sources.is_empty())
            .collect();
        let resident = MemoryPlan::with_long_side(views, params, method, long_side);
        if resident
            .check(limits.adapter, limits.budget, &String::new)
            .is_ok()
        {
            return Ok(BatchPlan {
                batches: vec![estimated],
                resident: true,
                peak: resident.peak(),
                budget: limits.budget,
            });
        }
        let sizes = level_sizes(views, params, method, long_side);
        let planar = planar_cell(params, method);
        let need = |batch: &[usize]| batch_need(views, &sizes, batch, planar);
        // Each view alone, with its sources: what no batching can split.
        for &v in &estimated {
            if let Err(why) = fits(&need(&[v]), limits) {
                let name = if views[v].name.is_empty() {
                    String::new()
                } else {
                    format!("{}, ", views[v].name)
                };
                return Err(MemoryError(format!(
                    "view {v} ({name}{}x{} with {} sources) {why}",
                    views[v].width,
                    views[v].height,
                    views[v].sources.len()
                )));
            }
        }
        let batches = group_views(views, &|batch| fits(&need(batch), limits).is_ok());
        let peak = batches
            .iter()
            .map(|b| need(b).iter().map(|l| l.bytes).max().unwrap_or(0))
            .max()
            .unwrap_or(0);
        Ok(BatchPlan {
            batches,
            resident: false,
            peak,
            budget: limits.budget,
        })
    }

    /// The largest batch, in views.
    pub fn largest_batch(&self) -> usize {
        self.batches.iter().map(Vec::len).max().unwrap_or(0)
    }

    /// Splits into batches of at most `views` views each (keeping the order): a smaller plan
    /// than the budget needs, for tests and benchmarks that compare the two runs.
    pub fn split(mut self, views: usize) -> BatchPlan {
        let order: Vec<usize> = self.batches.concat();
        self.batches = order.chunks(views.max(1)).map(<[usize]>::to_vec).collect();
        self.resident = false;
        self
    }
}

/// The estimated views (those with sources) in batches, each closed when the next view would
/// not `fit` it: the scheduler's one way of splitting a run, whether its batches run in turn
/// on one device (`crate::session`) or as a cluster's tasks (`crate::cluster`). A batch grows
/// by the view that adds the fewest new held views (itself and its sources), so neighbours
/// share sources; the next starts from the view sharing most with the batch before (what it
/// decoded is reused). `fits` must accept any single view.
pub fn group_views(views: &[ViewShape], fits: &dyn Fn(&[usize]) -> bool) -> Vec<Vec<usize>> {
    use std::collections::{BTreeSet, HashSet};
    let holds_of = |v: usize| std::iter::once(v).chain(views[v].sources.iter().copied());
    let mut remaining: BTreeSet<usize> = (0..views.len())
        .filter(|&v| !views[v].sources.is_empty())
        .collect();
    let mut batches: Vec<Vec<usize>> = Vec::new();
    let mut previous: HashSet<usize> = HashSet::new();
    while let Some(&first) = remaining.iter().next() {
        let seed = remaining
            .iter()
            .copied()
            .max_by_key(|&v| {
                (
                    holds_of(v).filter(|h| previous.contains(h)).count(),
                    std::cmp::Reverse(v),
                )
            })
            .unwrap_or(first);
        let mut batch = vec![seed];
        remaining.remove(&seed);
        let mut held: HashSet<usize> = holds_of(seed).collect();
        while let Some(next) = remaining.iter().copied().min_by_key(|&v| {
            (
                holds_of(v).filter(|h| !held.contains(h)).count(),
                std::cmp::Reverse(holds_of(v).filter(|h| held.contains(h)).count()),
                v,
            )
        }) {
            batch.push(next);
            if !fits(&batch) {
                batch.pop();
                break;
            }
            remaining.remove(&next);
            held.extend(holds_of(next));
        }
        previous = held;
        batches.push(batch);
    }
    batches
}

/// A batch's needs at one level.
#[derive(Clone, Debug)]
struct BatchLevel {
    level: usize,
    largest: (u32, u32),
    bytes: u64,
    texture_side: u32,
    layers: u32,
    largest_buffer: u64,
}

/// What `batch` holds at each level: the layers of its views and their sources, and its
/// views' buffers.
fn batch_need(
    views: &[ViewShape],
    sizes: &[(f64, Vec<(u32, u32)>)],
    batch: &[usize],
    planar: Option<u32>,
) -> Vec<BatchLevel> {
    let mut held: Vec<usize> = batch
        .iter()
        .flat_map(|&v| std::iter::once(v).chain(views[v].sources.iter().copied()))
        .collect();
    held.sort_unstable();
    held.dedup();
    sizes
        .iter()
        .enumerate()
        .map(|(level, (_, sizes))| {
            let (layers_bytes, texture_side, layers) = layer_bytes(sizes, held.iter().copied());
            let own: u64 = batch
                .iter()
                .map(|&v| view_bytes(sizes[v], views[v].sources.len(), planar))
                .sum();
            BatchLevel {
                level,
                largest: batch
                    .iter()
                    .map(|&v| sizes[v])
                    .max_by_key(|&(w, h)| w as u64 * h as u64)
                    .unwrap_or((0, 0)),
                bytes: layers_bytes + own,
                texture_side,
                layers,
                largest_buffer: batch
                    .iter()
                    .map(|&v| largest_view_buffer(sizes[v].0, sizes[v].1))
                    .max()
                    .unwrap_or(0),
            }
        })
        .collect()
}

/// Whether a batch's needs fit; the reason when not ("needs ... at scale 3/3").
fn fits(need: &[BatchLevel], limits: &Limits) -> Result<(), String> {
    let count = need.len();
    for l in need {
        let (w, h) = l.largest;
        let at = format!("at scale {}/{count} ({w}x{h})", l.level + 1);
        if l.texture_side > limits.adapter.max_texture_dimension_2d {
            return Err(format!(
                "needs a texture of side {} {at}, beyond this adapter's {}",
                l.texture_side, limits.adapter.max_texture_dimension_2d
            ));
        }
        if l.layers > limits.adapter.max_texture_array_layers {
            return Err(format!(
                "holds {} views {at}, beyond this adapter's {} texture layers",
                l.layers, limits.adapter.max_texture_array_layers
            ));
        }
        let binding = binding_limit(limits.adapter);
        if l.largest_buffer > binding {
            return Err(format!(
                "needs a {} binding {at}, beyond this adapter's {} per storage buffer",
                mib(l.largest_buffer),
                mib(binding)
            ));
        }
        if let Some(budget) = limits.budget
            && l.bytes > budget
        {
            return Err(format!(
                "needs {} of device memory {at}, beyond the budget of {}",
                mib(l.bytes),
                mib(budget)
            ));
        }
    }
    Ok(())
}

/// `views` with their long side capped at `side` (as `--max-image-size` loads them).
fn capped(views: &[ViewShape], side: u32) -> Vec<ViewShape> {
    views
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
                sources: v.sources.clone(),
                name: v.name.clone(),
            }
        })
        .collect()
}

/// The largest `--max-image-size` (long side, a multiple of 16) at which `views` can run
/// (in batches if need be), if any below their current size.
pub fn largest_fitting_size(
    views: &[ViewShape],
    params: &Params,
    method: Method,
    limits: &Limits,
) -> Option<u32> {
    let long = long_side(views);
    let fits = |side: u32| {
        let scaled = capped(views, side);
        BatchPlan::new(&scaled, params, method, long_side(&scaled), limits).is_ok()
    };
    // Fitting shrinks monotonically with the size: bisect over multiples of 16.
    let (mut lo, mut hi) = (0u32, long.div_ceil(16));
    if hi == 0 || !fits(16) {
        return None;
    }
    lo += 1;
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if mid * 16 < long && fits(mid * 16) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    (lo * 16 < long).then_some(lo * 16)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` views of `w x h`, each with the next `sources` views (cyclically) as sources.
    fn shapes(n: usize, w: u32, h: u32, sources: usize) -> Vec<ViewShape> {
        (0..n)
            .map(|v| ViewShape {
                width: w,
                height: h,
                sources: (1..=sources).map(|k| (v + k) % n).collect(),
                name: String::new(),
            })
            .collect()
    }

    fn limits(budget: Option<u64>) -> (wgpu::Limits, Option<u64>) {
        let adapter = wgpu::Limits {
            max_storage_buffer_binding_size: 128 << 20,
            max_buffer_size: 256 << 20,
            max_texture_dimension_2d: 8192,
            max_texture_array_layers: 256,
            ..wgpu::Limits::default()
        };
        (adapter, budget)
    }

    #[test]
    fn levels_follow_the_pyramid_and_count_every_buffer() {
        let params = Params::default();
        let plan = MemoryPlan::new(&shapes(3, 400, 300, 2), &params, Method::Acmm);
        assert_eq!(plan.levels.len() as u32, params.scales);
        let fine = plan.levels.last().unwrap();
        assert_eq!(fine.largest_view, (400, 300));
        let n = 400 * 300;
        assert_eq!(fine.images, 3 * n * 8, "intensity and depth layers");
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
    fn vec4_maps_split_into_two_windows_on_binding_offsets() {
        for n in [
            1u64,
            15,
            16,
            31,
            32,
            33,
            100,
            160 * 120,
            3072 * 2048,
            4000 * 3000,
        ] {
            let split = plane_split(n);
            assert!(split <= n, "{n}");
            if split < n {
                // Both windows non-empty, the second on a binding offset, neither larger
                // than half the map plus one offset.
                assert_eq!((split * 16) % BINDING_ALIGNMENT, 0, "{n}");
                assert!(split * 16 <= 8 * n + BINDING_ALIGNMENT, "{n}");
                assert!((n - split) * 16 <= 8 * n, "{n}");
            } else {
                // Too small to split: one window of at most one binding offset.
                assert!(n * 16 <= 2 * BINDING_ALIGNMENT, "{n}");
            }
            assert_eq!((selected_base(n) * 4) % BINDING_ALIGNMENT, 0);
            assert!(selected_base(n) >= n);
        }
    }

    #[test]
    fn no_binding_grows_with_the_views_or_their_sources() {
        // A window of a view's planes is its largest binding (with its aux words and masks:
        // 8 bytes a pixel): Fountain-P11 at full size (3072x2048) needs 48 MiB, a 12 Mpx
        // view (4000x3000) 92 MiB, a 16 Mpx one 123 MiB, all within llvmpipe's and
        // WebGPU's 128 MiB, with 10 sources or 2.
        assert_eq!(largest_view_buffer(3072, 2048), 48 << 20);
        assert_eq!(largest_view_buffer(4000, 3000).div_ceil(1 << 20), 92);
        assert!(largest_view_buffer(4608, 3456) <= 128 << 20);
        assert!(largest_view_buffer(4000, 3000) >= 8 * 12_000_000);
        let params = Params::default();
        let few = MemoryPlan::new(&shapes(3, 3072, 2048, 2), &params, Method::Acmm);
        let many = MemoryPlan::new(&shapes(300, 3072, 2048, 10), &params, Method::Acmm);
        let largest = |p: &MemoryPlan| p.levels.iter().map(|l| l.largest_buffer).max();
        assert_eq!(largest(&few), Some(48 << 20));
        assert_eq!(largest(&few), largest(&many));
        // Batches of it fit llvmpipe's limits and a 4 GiB budget.
        let (adapter, _) = limits(None);
        let plan = BatchPlan::new(
            &shapes(11, 3072, 2048, 10),
            &params,
            Method::Acmm,
            3072,
            &Limits {
                adapter: &adapter,
                budget: Some(4 << 30),
            },
        )
        .unwrap();
        assert!(!plan.resident && plan.peak <= 4 << 30, "{plan:?}");
    }

    #[test]
    fn a_scene_beyond_the_budget_runs_in_batches_that_each_fit() {
        let params = Params::default();
        let views = shapes(12, 320, 240, 4);
        let whole = MemoryPlan::new(&views, &params, Method::Acmm).peak();
        let (adapter, _) = limits(None);
        // Everything fits: one batch of all views, held for the whole run.
        let plan = BatchPlan::new(
            &views,
            &params,
            Method::Acmm,
            320,
            &Limits {
                adapter: &adapter,
                budget: Some(whole),
            },
        )
        .unwrap();
        assert!(plan.resident);
        assert_eq!(plan.batches, vec![(0..12).collect::<Vec<_>>()]);
        // A third of that: batches, each within the budget, every view once.
        let budget = whole / 3;
        let plan = BatchPlan::new(
            &views,
            &params,
            Method::Acmm,
            320,
            &Limits {
                adapter: &adapter,
                budget: Some(budget),
            },
        )
        .unwrap();
        assert!(!plan.resident);
        assert!(plan.batches.len() >= 3, "{:?}", plan.batches);
        assert!(plan.peak <= budget, "{} > {budget}", plan.peak);
        let mut all: Vec<usize> = plan.batches.concat();
        all.sort_unstable();
        assert_eq!(all, (0..12).collect::<Vec<_>>());
        // Neighbours share sources: with ring sources (v+1..v+4), a batch is a run of
        // consecutive views, not a scatter (which would hold more source layers).
        for b in &plan.batches {
            let mut s = b.clone();
            s.sort_unstable();
            let spread = s.windows(2).filter(|w| w[1] != w[0] + 1).count();
            assert!(spread <= 1, "batch {b:?} is scattered");
        }
    }

    #[test]
    fn a_view_that_alone_exceeds_the_budget_is_named_with_a_size_that_fits() {
        let params = Params::default();
        let views = shapes(4, 3072, 2048, 3);
        let (adapter, _) = limits(None);
        let small = Limits {
            adapter: &adapter,
            budget: Some(200 << 20),
        };
        let err = BatchPlan::new(&views, &params, Method::Acmm, 3072, &small)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("view 0 (3072x2048 with 3 sources) needs"),
            "{err}"
        );
        assert!(err.contains("budget of 200 MiB"), "{err}");
        let side = largest_fitting_size(&views, &params, Method::Acmm, &small).unwrap();
        assert!(side < 3072 && side.is_multiple_of(16));
        let at = |s: u32| {
            let v = capped(&views, s);
            BatchPlan::new(&v, &params, Method::Acmm, s, &small).is_ok()
        };
        assert!(at(side), "{side} fits");
        assert!(!at(side + 16), "{} does not", side + 16);
    }

    #[test]
    fn views_beyond_the_texture_limits_are_refused_before_anything_is_allocated() {
        // A 12000 px view is beyond an 8192 px texture at the finest scale, in any batch.
        let params = Params::default();
        let (adapter, _) = limits(None);
        let l = Limits {
            adapter: &adapter,
            budget: None,
        };
        let wide = shapes(3, 12000, 800, 2);
        let err = BatchPlan::new(&wide, &params, Method::Acmh, 12000, &l)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("texture of side 12000") && err.contains("8192"),
            "{err}"
        );
        assert_eq!(
            largest_fitting_size(&wide, &params, Method::Acmh, &l),
            Some(8192)
        );
        // 300 views are beyond 256 texture layers held at once: batches hold fewer.
        let many = shapes(300, 64, 48, 2);
        let plan = BatchPlan::new(&many, &params, Method::Acmm, 64, &l).unwrap();
        assert!(!plan.resident && plan.batches.len() >= 2);
    }
}
