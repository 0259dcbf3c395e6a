//! Scenes: an ordered list of calibrated views with depth ranges and source views.
//!
//! Every input format is parsed into a [`RawScene`] (cameras, image paths, and whatever depth
//! ranges and source views the format carries); [`RawScene::finish`] then does what all formats
//! share: it checks image sizes against cameras, decodes images in parallel, fills missing depth
//! ranges and source views from camera geometry, and applies the source limit.

pub mod acmm;
pub mod colmap;
pub mod geometry;
pub mod middlebury;
pub mod strecha;
pub mod text;
pub mod undistort;
use crate::vfs;

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::camera::Camera;
pub use crate::error::SceneError;
use crate::image::Image;

/// The original ACMM keeps per-pixel source selections in a 32-bit mask.
pub const MAX_SOURCES: usize = 32;

/// Depth (camera `z`) interval in which a view's surfaces lie.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DepthRange {
    pub min: f64,
    pub max: f64,
}

impl DepthRange {
    pub fn new(min: f64, max: f64) -> Result<DepthRange, String> {
        if !(min.is_finite() && max.is_finite()) || min <= 0.0 || max <= min {
            return Err(format!(
                "the depth range [{min}, {max}] is invalid: it needs 0 < min < max"
            ));
        }
        Ok(DepthRange { min, max })
    }
}

/// A source view of a reference view, with the score that ranked it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SourceView {
    /// Index into [`Scene::views`].
    pub index: usize,
    pub score: f64,
}

/// One calibrated image of a scene.
#[derive(Clone, Debug)]
pub struct View {
    pub name: String,
    pub image: Image,
    pub camera: Camera,
    pub depth_range: DepthRange,
    /// Best first; at most [`MAX_SOURCES`].
    pub sources: Vec<SourceView>,
    /// Where the image came from (None for generated scenes).
    pub image_path: Option<PathBuf>,
}

/// The input formats mvscope reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum SceneFormat {
    /// ACMM / MVSNet folder: images/, cams/, pair.txt.
    Acmm,
    /// COLMAP sparse model (binary or text) beside images/.
    Colmap,
    /// Middlebury multi-view: *_par.txt beside the images.
    Middlebury,
    /// Strecha: IMAGE.camera beside each image.
    Strecha,
}

impl std::fmt::Display for SceneFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SceneFormat::Acmm => "ACMM/MVSNet folder",
            SceneFormat::Colmap => "COLMAP model",
            SceneFormat::Middlebury => "Middlebury multi-view",
            SceneFormat::Strecha => "Strecha",
        })
    }
}

/// How to load a scene.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Skip detection and read this format.
    pub format: Option<SceneFormat>,
    /// Downscale images (and cameras) so that the long side is at most this many pixels.
    pub max_image_size: Option<u32>,
    /// Use this depth range for every view instead of the format's or the estimated one.
    pub depth_range: Option<DepthRange>,
    /// COLMAP: read the model in `sparse/N` (default: `sparse/0`, else `sparse/`, else the
    /// folder itself).
    pub model: Option<u32>,
    /// Keep images undistorted on load here (PNG, keyed by file and lens) and reuse them.
    pub undistort_cache: Option<PathBuf>,
    /// Decode only these views' images (indices as loaded); the others keep their size and
    /// no pixels. A cluster task holds its views and their sources, never the whole scene.
    pub decode_only: Option<Vec<usize>>,
}

impl LoadOptions {
    /// These options with no image decoded: the cameras, sizes and sources only (what a
    /// scorer, a planner or an export reads before any pixel).
    pub fn cameras_only(&self) -> LoadOptions {
        LoadOptions {
            decode_only: Some(Vec::new()),
            ..self.clone()
        }
    }
}

/// A loaded scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The folder (or file) it was loaded from; empty for generated scenes.
    pub root: PathBuf,
    pub format: Option<SceneFormat>,
    pub views: Vec<View>,
    /// Things the user should know (sources dropped, ranges estimated, images downscaled).
    pub warnings: Vec<String>,
}

/// A view as a format describes it, before images are decoded.
#[derive(Clone, Debug)]
pub struct RawView {
    pub name: String,
    pub image_path: PathBuf,
    pub camera: Camera,
    /// Where the camera came from, for error messages (a file, `file:line`, `images.bin`).
    pub camera_source: String,
    pub depth_range: Option<DepthRange>,
    /// Source views as (view index, score), `None` when the format has none.
    pub sources: Option<Vec<(usize, f64)>>,
    /// The image is distorted by this lens: it is resampled to the pinhole `camera` on load.
    pub lens: Option<undistort::Lens>,
}

impl RawView {
    /// The image's size on disk, checked against the view's camera.
    fn checked_size(&self) -> Result<(u32, u32), SceneError> {
        let (w, h) = Image::dimensions(&self.image_path)?;
        if (w, h) != (self.camera.width, self.camera.height) {
            return Err(SceneError::file(
                &self.image_path,
                format!(
                    "the image is {w}x{h} but its camera ({}) is for {}x{}; use the undistorted images the calibration belongs to",
                    self.camera_source, self.camera.width, self.camera.height
                ),
            ));
        }
        Ok((w, h))
    }

    /// The view's image as a loaded scene holds it: undistorted (kept in
    /// `options.undistort_cache` where given) and downscaled to `options.max_image_size`.
    pub fn decode(&self, options: &LoadOptions) -> Result<Image, SceneError> {
        let (w, h) = self.checked_size()?;
        let image = match (&self.lens, &options.undistort_cache) {
            (None, _) => Image::load(&self.image_path)?,
            (Some(lens), None) => lens.undistort_image(&Image::load(&self.image_path)?),
            (Some(lens), Some(dir)) => {
                let stem: String = self
                    .name
                    .chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect();
                let key = lens.cache_key(&self.image_path);
                let cached = dir.join(format!("{stem}-{key:016x}.png"));
                match Image::load(&cached) {
                    Ok(image) if (image.width, image.height) == (w, h) => image,
                    _ => {
                        let image = lens.undistort_image(&Image::load(&self.image_path)?);
                        std::fs::create_dir_all(dir).map_err(|e| SceneError::io(dir, e))?;
                        image.save_png(&cached).map_err(|e| {
                            SceneError::file(
                                &cached,
                                format!("cannot keep the undistorted image: {e}"),
                            )
                        })?;
                        image
                    }
                }
            }
        };
        Ok(match options.max_image_size {
            Some(max) if w.max(h) > max => {
                let scale = max as f64 / w.max(h) as f64;
                let (nw, nh) = scaled_size(w, h, scale);
                image.resized(nw.min(max), nh.min(max))
            }
            _ => image,
        })
    }
}

/// A scene as a format describes it.
#[derive(Clone, Debug)]
pub struct RawScene {
    pub root: PathBuf,
    pub format: SceneFormat,
    pub views: Vec<RawView>,
    pub warnings: Vec<String>,
}

impl Scene {
    /// Loads a scene, detecting its format from the folder unless `options.format` says it.
    pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
        RawScene::read(path, options)?.finish(options)
    }

    /// A scene made in memory (synthetic scenes, tests); checked like a loaded one.
    pub fn from_views(views: Vec<View>) -> Result<Scene, SceneError> {
        let scene = Scene {
            root: PathBuf::new(),
            format: None,
            views,
            warnings: Vec::new(),
        };
        scene.validate()?;
        Ok(scene)
    }

    /// The longest image side over the views (1 for no views): what sets the number of
    /// pyramid scales.
    pub fn long_side(&self) -> u32 {
        self.views
            .iter()
            .map(|v| v.image.width.max(v.image.height))
            .max()
            .unwrap_or(1)
    }

    /// The index of the view with this name.
    pub fn view_index(&self, name: &str) -> Option<usize> {
        self.views.iter().position(|v| v.name == name)
    }

    /// What every scene must satisfy, whatever its format.
    pub fn validate(&self) -> Result<(), SceneError> {
        let location = if self.root.as_os_str().is_empty() {
            "scene".to_string()
        } else {
            self.root.display().to_string()
        };
        if self.views.len() < 2 {
            return Err(SceneError {
                location,
                message: format!(
                    "the scene has {} view(s); multi-view stereo needs at least two",
                    self.views.len()
                ),
                path: Some(self.root.clone()),
                line: None,
            });
        }
        let mut names = HashSet::new();
        for (i, view) in self.views.iter().enumerate() {
            if !names.insert(view.name.as_str()) {
                return Err(SceneError::view(
                    &view.name,
                    "the scene has two views with this name; remove the duplicate",
                ));
            }
            view.camera
                .validate()
                .map_err(|m| SceneError::view(&view.name, m))?;
            if (view.image.width, view.image.height) != (view.camera.width, view.camera.height) {
                return Err(SceneError::view(
                    &view.name,
                    format!(
                        "the image is {}x{} but its camera is for {}x{}",
                        view.image.width, view.image.height, view.camera.width, view.camera.height
                    ),
                ));
            }
            for s in &view.sources {
                if s.index >= self.views.len() || s.index == i {
                    return Err(SceneError::view(
                        &view.name,
                        format!("source view index {} is invalid", s.index),
                    ));
                }
            }
            if view.sources.len() > MAX_SOURCES {
                return Err(SceneError::view(
                    &view.name,
                    format!(
                        "{} sources; at most {MAX_SOURCES} are supported",
                        view.sources.len()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Only the views at `indices` (in that order), with sources remapped and sources outside
    /// the subset dropped. Fails on an index out of range or repeated.
    pub fn subset(&self, indices: &[usize]) -> Result<Scene, SceneError> {
        let mut new_index = vec![usize::MAX; self.views.len()];
        for (k, &i) in indices.iter().enumerate() {
            if i >= self.views.len() {
                return Err(SceneError::view(
                    &i.to_string(),
                    format!("no such view: the scene has views 0..{}", self.views.len()),
                ));
            }
            if new_index[i] != usize::MAX {
                return Err(SceneError::view(&i.to_string(), "the view is listed twice"));
            }
            new_index[i] = k;
        }
        let views = indices
            .iter()
            .map(|&i| {
                let mut v = self.views[i].clone();
                v.sources = v
                    .sources
                    .iter()
                    .filter(|s| new_index[s.index] != usize::MAX)
                    .map(|s| SourceView {
                        index: new_index[s.index],
                        score: s.score,
                    })
                    .collect();
                v
            })
            .collect();
        let scene = Scene {
            root: self.root.clone(),
            format: self.format,
            views,
            warnings: self.warnings.clone(),
        };
        scene.validate()?;
        Ok(scene)
    }

    /// The scene with every image (and camera) resampled by `scale` (e.g. 0.5 for half size),
    /// each size rounded to whole pixels; cameras follow the rounded size exactly.
    pub fn rescaled(&self, scale: f64) -> Scene {
        let mut scene = self.clone();
        scene.views.par_iter_mut().for_each(|view| {
            let (w, h) = scaled_size(view.image.width, view.image.height, scale);
            view.image = view.image.resized(w, h);
            view.camera = view.camera.rescaled(w, h);
        });
        scene
    }
}

/// `width x height` scaled by `scale`, rounded, at least 1x1.
pub fn scaled_size(width: u32, height: u32, scale: f64) -> (u32, u32) {
    let w = ((width as f64 * scale).round() as u32).max(1);
    let h = ((height as f64 * scale).round() as u32).max(1);
    (w, h)
}

impl RawScene {
    /// Decodes images, checks sizes, fills what the format lacked and applies `options`.
    /// The scene at `path` as its format describes it, nothing decoded (the format detected
    /// unless `options.format` says it).
    pub fn read(path: &Path, options: &LoadOptions) -> Result<RawScene, SceneError> {
        let format = match options.format {
            Some(f) => f,
            None => detect_format(path)?,
        };
        match format {
            SceneFormat::Acmm => acmm::read(path),
            SceneFormat::Colmap => colmap::read_model_at(path, options.model),
            SceneFormat::Middlebury => middlebury::read(path),
            SceneFormat::Strecha => strecha::read(path),
        }
    }

    pub fn finish(mut self, options: &LoadOptions) -> Result<Scene, SceneError> {
        if self.views.len() < 2 {
            return Err(SceneError::file(
                &self.root,
                format!(
                    "the {} has {} view(s); multi-view stereo needs at least two",
                    self.format,
                    self.views.len()
                ),
            ));
        }
        let mut names = HashSet::new();
        for view in &self.views {
            if !names.insert(view.name.clone()) {
                return Err(SceneError::view(
                    &view.name,
                    format!(
                        "the {} lists this view twice ({}); remove the duplicate",
                        self.format, view.camera_source
                    ),
                ));
            }
            view.camera.validate().map_err(|m| SceneError {
                location: view.camera_source.clone(),
                message: format!("view {}: {m}", view.name),
                path: None,
                line: None,
            })?;
        }

        // Decode all images in parallel; the first error (in view order) wins.
        let images: Vec<Result<Image, SceneError>> = self
            .views
            .par_iter()
            .enumerate()
            .map(|(index, view)| {
                if options
                    .decode_only
                    .as_ref()
                    .is_some_and(|only| !only.contains(&index))
                {
                    // The size the decoded image would have, without its pixels.
                    let (w, h) = view.checked_size()?;
                    let (w, h) = match options.max_image_size {
                        Some(max) if w.max(h) > max => {
                            let (nw, nh) = scaled_size(w, h, max as f64 / w.max(h) as f64);
                            (nw.min(max), nh.min(max))
                        }
                        _ => (w, h),
                    };
                    return Ok(Image {
                        width: w,
                        height: h,
                        rgb: Vec::new(),
                        gray: Vec::new(),
                    });
                }
                view.decode(options)
            })
            .collect();
        let images = images.into_iter().collect::<Result<Vec<_>, _>>()?;

        let mut cameras: Vec<Camera> = self
            .views
            .iter()
            .zip(&images)
            .map(|(v, img)| v.camera.rescaled(img.width, img.height))
            .collect();
        for cam in &mut cameras {
            *cam = cam.orthonormalized();
        }
        if let Some(max) = options.max_image_size
            && images
                .iter()
                .zip(&self.views)
                .any(|(img, v)| img.width != v.camera.width || img.height != v.camera.height)
        {
            self.warnings.push(format!(
                "images were downscaled so that their long side is at most {max} px"
            ));
        }

        // Depth ranges: the override, the format's, or estimated from geometry.
        let estimated = geometry::depth_ranges_from_geometry(&cameras);
        let mut depth_ranges = Vec::with_capacity(self.views.len());
        let mut estimated_names = Vec::new();
        for (i, view) in self.views.iter().enumerate() {
            let range = match (options.depth_range, view.depth_range) {
                (Some(r), _) => r,
                (None, Some(r)) => r,
                (None, None) => match estimated[i] {
                    Some(r) => {
                        estimated_names.push(view.name.as_str());
                        r
                    }
                    None => {
                        return Err(SceneError::view(
                            &view.name,
                            "the input has no depth range and none can be estimated from the cameras (their axes do not converge); pass --depth-range MIN MAX",
                        ));
                    }
                },
            };
            depth_ranges.push(range);
        }
        if !estimated_names.is_empty() {
            let (lo, hi) = depth_ranges.iter().fold((f64::MAX, 0.0f64), |(lo, hi), r| {
                (lo.min(r.min), hi.max(r.max))
            });
            self.warnings.push(format!(
                "{} of {} views have no depth range in the input ({}); estimated from where the camera axes meet, within [{lo:.4}, {hi:.4}] (pass --depth-range MIN MAX to set one)",
                estimated_names.len(),
                self.views.len(),
                abbreviate(&estimated_names),
            ));
        }

        // Source views: the format's, or chosen from geometry.
        let need_geometry = self.views.iter().any(|v| v.sources.is_none());
        let geometric_sources = if need_geometry {
            geometry::sources_from_geometry(&cameras, &depth_ranges, geometry::DEFAULT_SOURCES)
        } else {
            Vec::new()
        };
        let n = self.views.len();
        let mut views = Vec::with_capacity(n);
        for (i, (raw, image)) in self.views.into_iter().zip(images).enumerate() {
            let mut sources: Vec<SourceView> = match raw.sources {
                Some(list) => {
                    let mut seen = HashSet::new();
                    let mut kept = Vec::new();
                    for (index, score) in list {
                        if index >= n || index == i {
                            return Err(SceneError::view(
                                &raw.name,
                                format!(
                                    "source view index {index} is not another view of the scene"
                                ),
                            ));
                        }
                        if score <= 0.0 || !seen.insert(index) {
                            continue; // the original drops sources with score <= 0
                        }
                        kept.push(SourceView { index, score });
                    }
                    kept
                }
                None => geometric_sources[i].clone(),
            };
            sources.sort_by(|a, b| b.score.total_cmp(&a.score));
            if sources.len() > MAX_SOURCES {
                self.warnings.push(format!(
                    "view {}: {} source views; keeping the best {MAX_SOURCES}",
                    raw.name,
                    sources.len()
                ));
                sources.truncate(MAX_SOURCES);
            }
            if sources.is_empty() {
                self.warnings.push(format!(
                    "view {}: no usable source view (all scores <= 0); its depth cannot be estimated",
                    raw.name
                ));
            }
            views.push(View {
                name: raw.name,
                image,
                camera: cameras[i],
                depth_range: depth_ranges[i],
                sources,
                image_path: Some(raw.image_path),
            });
        }
        let scene = Scene {
            root: self.root,
            format: Some(self.format),
            views,
            warnings: self.warnings,
        };
        scene.validate()?;
        Ok(scene)
    }
}

/// "a, b, c" or "a, b, ... (16 in all)" for long lists.
fn abbreviate(names: &[&str]) -> String {
    if names.len() <= 4 {
        names.join(", ")
    } else {
        format!(
            "{}, ... {} ({} in all)",
            names[..2].join(", "),
            names[names.len() - 1],
            names.len()
        )
    }
}

/// Detects the format of a scene folder (or a Middlebury `*_par.txt` file).
pub fn detect_format(path: &Path) -> Result<SceneFormat, SceneError> {
    if vfs::is_file(path) {
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.ends_with("_par.txt") {
            return Ok(SceneFormat::Middlebury);
        }
        return Err(SceneError::file(
            path,
            "this is a file; give the scene folder (or a Middlebury *_par.txt)",
        ));
    }
    if !vfs::is_dir(path) {
        return Err(SceneError::file(
            path,
            "the scene folder does not exist; check the path",
        ));
    }
    if vfs::is_dir(&path.join("cams")) && vfs::is_dir(&path.join("images")) {
        return Ok(SceneFormat::Acmm);
    }
    if colmap::find_model(path).is_some() {
        return Ok(SceneFormat::Colmap);
    }
    let entries: Vec<String> = vfs::read_dir(path)
        .map_err(|e| SceneError::io(path, e))?
        .iter()
        .filter_map(|p| p.file_name()?.to_str().map(str::to_string))
        .collect();
    if entries.iter().any(|n| n.ends_with("_par.txt")) {
        return Ok(SceneFormat::Middlebury);
    }
    if entries.iter().any(|n| n.ends_with(".camera")) {
        return Ok(SceneFormat::Strecha);
    }
    Err(SceneError::file(
        path,
        "cannot tell the scene format: expected images/ + cams/ (ACMM/MVSNet), images/ + sparse/ or sparse/0/ (COLMAP), a *_par.txt (Middlebury) or *.camera files (Strecha); pass --format to choose",
    ))
}

/// Image files of a folder with these extensions, sorted by name.
pub fn list_images(dir: &Path) -> Result<Vec<PathBuf>, SceneError> {
    let mut files: Vec<PathBuf> = vfs::read_dir(dir)
        .map_err(|e| SceneError::io(dir, e))?
        .into_iter()
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg"))
        })
        .collect();
    files.sort();
    Ok(files)
}
