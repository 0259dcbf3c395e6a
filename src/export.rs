//! Results and scenes in other tools' layouts: the original ACMM's output folder
//! ([`export_acmm`]), a COLMAP dense workspace that `colmap stereo_fusion` can fuse
//! ([`export_colmap`]), and scene conversion for `mvscope convert SCENE --to acmm|colmap`
//! ([`convert_to_acmm`], [`convert_to_colmap`]).
//!
//! Every file goes through [`write_atomic`] (directly or through the `io` writers), so an
//! interrupted export never leaves a truncated file under its final name. The COLMAP sparse
//! model is written by [`colmap::write_model`] into a staging folder, synced, and each file is
//! then renamed into place.
//!
//! # Conventions of the outputs
//!
//! mvscope puts pixel centres on integer coordinates (see [`crate::camera`]); depth is camera
//! `z`; a depth `<= 0` (or not finite) means "no depth" and is written as `0` everywhere.
//!
//! * **ACMM** (`ACMM/2333_%08d/*.dmb`): the original's layout and `.dmb` format (see
//!   [`crate::io::dmb`]); normals in the **world** frame, as `ACMM-REFERENCE.md` specifies.
//! * **COLMAP**: cameras are `PINHOLE` with the principal point shifted by `+0.5` (COLMAP puts
//!   the centre of the top-left pixel at `(0.5, 0.5)`); poses are `camera_from_world`, as in
//!   mvscope. Normal maps are in the **camera** frame of their image and face the camera.
//!
//! # What was verified in COLMAP's source (colmap/colmap, read, not copied)
//!
//! * `src/colmap/mvs/workspace.cc` (`Workspace::GetFileName`, constructor): maps live in
//!   `stereo/depth_maps/` and `stereo/normal_maps/`, named `IMAGE_NAME.INPUT_TYPE.bin` where
//!   `IMAGE_NAME` is the model's image name including its extension and `INPUT_TYPE` is
//!   `geometric` for `stereo_fusion`'s default input; images are read from `images/IMAGE_NAME`.
//! * `src/colmap/mvs/model.cc` (`Model::ReadFromCOLMAP`): the model is read from `sparse/`;
//!   `Model::GetMaxOverlappingImages` and `Model::ComputeDepthRanges` use only the sparse
//!   points' tracks.
//! * `src/colmap/mvs/fusion.cc` (`StereoFusion::Run`, `StereoFusion::Fuse`): `fusion.cfg` is
//!   read with `ReadTextFileLines` (one image name per line, lines trimmed, blank lines
//!   skipped, no comments); pixels with `depth <= 0` are skipped, so `0` marks missing depth;
//!   the world normal is `R^T * normal_map(row, col)`, i.e. **normal maps are in the camera
//!   frame** of their image; a fused point only grows across the image's *overlapping images*,
//!   which come from shared sparse points — **with no sparse points fusion keeps nothing**
//!   (each pixel stays alone, below `min_num_pixels`). [`export_colmap`] therefore writes sparse
//!   points sampled from the depth maps (see below). Fusion unprojects pixel `(col, row)` at
//!   image coordinates `(col, row)` with the model's `K`, i.e. half a pixel from COLMAP's own
//!   pixel-centre convention; COLMAP's own patch-match maps carry the same offset
//!   (`ComputePointAtDepth` in `patch_match_cuda.cu`), so the maps are written per pixel, as
//!   they are, and the model keeps COLMAP's documented convention (`+0.5`).
//! * `src/colmap/mvs/patch_match.cc` (`PatchMatchController::ReadProblems`): `patch-match.cfg`
//!   holds pairs of lines, the reference image name, then either `__auto__, N`, `__all__` or
//!   the source image names separated by `,` or `;` (each trimmed); `#` lines are comments.
//! * `src/colmap/mvs/patch_match_cuda.cu` (`GenerateRandomNormal`, `PerturbNormal`, the
//!   filter) and `normal_map.cc` (`NormalMap::ToBitmap`): normals satisfy `n · ray <= 0` (they
//!   face the camera, `z <= 0` for a surface seen head-on), filtered pixels get depth 0 and
//!   normal `(0, 0, 0)` — the same facing convention as mvscope's normals.
//!
//! # Image names in a COLMAP workspace
//!
//! Images are always written as PNG at the scene's (processed) size. The COLMAP name of a view
//! is its name when that ends in `.png` (any case), else the name with `.png` appended
//! (`00000003` -> `00000003.png`, `IMG_1.JPG` -> `IMG_1.JPG.png`): the extension always tells
//! the truth about the content, and names stay unique. See [`colmap_image_name`].

use std::collections::HashSet;
use std::fs::File;
use std::path::{Component, Path};
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::error::SceneError;
use crate::io::{IoError, Map, PlyPoint, write_atomic, write_colmap_map, write_dmb, write_ply};
use crate::scene::colmap::{
    self, CameraModel, ColmapCamera, ColmapImage, ColmapModel, ColmapPoint3D, Encoding,
    qvec_from_rotation,
};
use crate::scene::{Scene, View, acmm};

/// What `__auto__` asks COLMAP for in `patch-match.cfg` when a view has no source views
/// (the number `colmap image_undistorter` writes).
pub const COLMAP_AUTO_SOURCES: usize = 20;

/// About how many pixels per view [`export_colmap`] samples for its sparse points.
pub const SPARSE_SAMPLES_PER_VIEW: u32 = 1024;

/// Relative depth difference under which a sampled point counts as seen by another view
/// (COLMAP's default `max_depth_error` of fusion).
pub const SPARSE_DEPTH_TOLERANCE: f64 = 0.01;

/// The maps of one view, in scene order, at the scene's image size (row-major, top row first).
#[derive(Clone, Copy, Debug)]
pub struct ViewOutput<'a> {
    /// Camera-`z` depth per pixel; `<= 0` (or not finite) means no depth.
    pub depth: &'a [f32],
    /// Unit surface normal per pixel in the world frame, facing the camera.
    pub normal_world: &'a [[f32; 3]],
    /// Matching cost per pixel (ACMM's `1 - NCC` scale, 0..2).
    pub cost: &'a [f32],
}

/// Exporting or converting failed. Each message names the view or the file and says what to do.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The maps given do not fit the scene; nothing was written.
    #[error("{message}")]
    Input { message: String },
    /// A view's name cannot be used as a file name in the output.
    #[error("view {view}: {message}")]
    Name { view: String, message: String },
    /// Writing a file failed.
    #[error("{}{source}{}", view_prefix(view.as_deref()), io_hint(source))]
    Io {
        /// The view the file belongs to, if any.
        view: Option<String>,
        #[source]
        source: IoError,
    },
    /// Writing the COLMAP sparse model failed.
    #[error(
        "writing the COLMAP model failed: {0}; check that the output folder is writable and has free space"
    )]
    Model(#[from] SceneError),
    /// The scene to write could not be read.
    #[error("{0}")]
    Read(SceneError),
}

fn view_prefix(view: Option<&str>) -> String {
    view.map(|v| format!("view {v}: ")).unwrap_or_default()
}

fn io_hint(error: &IoError) -> &'static str {
    match error {
        IoError::Io { .. } => {
            "; check that the output folder is writable and has free space, then export again"
        }
        _ => "",
    }
}

impl From<IoError> for ExportError {
    fn from(source: IoError) -> ExportError {
        ExportError::Io { view: None, source }
    }
}

impl ExportError {
    /// The file the error is about, when there is one.
    pub fn path(&self) -> Option<&Path> {
        match self {
            ExportError::Io { source, .. } => Some(source.path()),
            ExportError::Model(e) => e.path.as_deref(),
            _ => None,
        }
    }
}

/// Wraps an [`IoError`] of the files of view `name`.
fn in_view(name: &str) -> impl FnOnce(IoError) -> ExportError + '_ {
    move |source| ExportError::Io {
        view: Some(name.to_string()),
        source,
    }
}

fn mkdir(path: &Path) -> Result<(), IoError> {
    std::fs::create_dir_all(path).map_err(|e| IoError::io(path, "create the folder", e))
}

fn create_dir(path: &Path) -> Result<(), ExportError> {
    Ok(mkdir(path)?)
}

fn write_text(path: &Path, text: &str) -> Result<(), ExportError> {
    write_atomic(path, |w| std::io::Write::write_all(w, text.as_bytes()))?;
    Ok(())
}

fn valid_depth(d: f32) -> bool {
    d.is_finite() && d > 0.0
}

/// Checks that there is one [`ViewOutput`] per view, each at its view's image size.
fn check_views(scene: &Scene, views: &[ViewOutput]) -> Result<(), ExportError> {
    if views.len() != scene.views.len() {
        return Err(ExportError::Input {
            message: format!(
                "maps were given for {} view(s) but the scene has {}; pass one ViewOutput per view, in scene order",
                views.len(),
                scene.views.len()
            ),
        });
    }
    for (view, out) in scene.views.iter().zip(views) {
        let (w, h) = (view.image.width, view.image.height);
        let n = w as usize * h as usize;
        for (what, len) in [
            ("depth map", out.depth.len()),
            ("normal map", out.normal_world.len()),
            ("cost map", out.cost.len()),
        ] {
            if len != n {
                return Err(ExportError::Input {
                    message: format!(
                        "view {}: the {what} has {len} pixels but the image is {w}x{h} ({n} pixels); pass maps at the scene's image size (the size the scene was processed at)",
                        view.name
                    ),
                });
            }
        }
    }
    Ok(())
}

fn map(
    name: &str,
    width: u32,
    height: u32,
    channels: u32,
    data: Vec<f32>,
) -> Result<Map, ExportError> {
    Map::from_data(width, height, channels, data).map_err(|e| ExportError::Input {
        message: format!("view {name}: {e}"),
    })
}

/// The depth map as written: invalid depths (`<= 0`, not finite) become 0.
fn depth_values(depth: &[f32]) -> Vec<f32> {
    depth
        .iter()
        .map(|&d| if valid_depth(d) { d } else { 0.0 })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// ACMM

/// Writes the original ACMM's output layout inside `dir/ACMM/`:
///
/// * `2333_%08d/depths.dmb` — depth (1 channel), `%08d` = the view's index in scene order;
///   invalid depths are written as 0;
/// * `2333_%08d/depths_geom.dmb` — the same depth: mvscope's final maps are the geometric ones;
/// * `2333_%08d/normals.dmb` — normals (3 channels) in the **world** frame, as given;
/// * `2333_%08d/costs.dmb` — matching cost (1 channel), as given;
/// * `ACMM_model.ply` — the fused cloud when `cloud` is given (binary little-endian,
///   `float x y z nx ny nz`, `uchar red green blue`).
///
/// `.dmb` is the original's format: int32 `1, height, width, channels`, then float32 values,
/// row-major, top row first, channels interleaved (see [`crate::io::dmb`]).
pub fn export_acmm(
    scene: &Scene,
    views: &[ViewOutput],
    cloud: Option<&[PlyPoint]>,
    dir: &Path,
) -> Result<(), ExportError> {
    check_views(scene, views)?;
    let root = dir.join("ACMM");
    create_dir(&root)?;
    for (i, (view, out)) in scene.views.iter().zip(views).enumerate() {
        let (w, h) = (view.image.width, view.image.height);
        let name = view.name.as_str();
        let folder = root.join(format!("2333_{i:08}"));
        mkdir(&folder).map_err(in_view(name))?;
        let depth = map(name, w, h, 1, depth_values(out.depth))?;
        write_dmb(&folder.join("depths.dmb"), &depth).map_err(in_view(name))?;
        write_dmb(&folder.join("depths_geom.dmb"), &depth).map_err(in_view(name))?;
        let normals = map(
            name,
            w,
            h,
            3,
            out.normal_world.iter().flatten().copied().collect(),
        )?;
        write_dmb(&folder.join("normals.dmb"), &normals).map_err(in_view(name))?;
        let costs = map(name, w, h, 1, out.cost.to_vec())?;
        write_dmb(&folder.join("costs.dmb"), &costs).map_err(in_view(name))?;
    }
    if let Some(points) = cloud {
        write_ply(&root.join("ACMM_model.ply"), points)?;
    }
    Ok(())
}

/// Writes the scene as an ACMM / MVSNet folder (`images/%08d.png`, `cams/%08d_cam.txt`,
/// `pair.txt`, views numbered in scene order) via [`acmm::write_scene`].
pub fn convert_to_acmm(scene: &Scene, dir: &Path) -> Result<(), ExportError> {
    create_dir(dir)?;
    acmm::write_scene(scene, dir)?;
    Ok(())
}

/// Writes the scene at `root` (read with `options`, at its own size) as an ACMM folder whose
/// cameras carry `fixes`: each listed view's principal point moved by its (dx, dy) pixels,
/// as `mvscope eval` measures them against ground truth ([`crate::eval::principal_point_corrections`]).
/// Images are decoded and written one view at a time (undistorted where the format needs
/// it); with `truth`, the files of its `gt/` folder come along (hard links where the file
/// system allows), so `out` is a scene the accuracy tools read as it is. The folder is
/// written beside `out` under a temporary name and renamed when complete; an `out` that
/// exists is refused, so nothing is overwritten and nothing half-written is left.
pub fn write_corrected_scene(
    root: &Path,
    options: &crate::scene::LoadOptions,
    fixes: &[crate::eval::PrincipalPointFix],
    truth: Option<&Path>,
    out: &Path,
) -> Result<(), ExportError> {
    if out.exists() {
        return Err(ExportError::Input {
            message: format!(
                "{} exists; give a new folder for the scene with corrected cameras",
                out.display()
            ),
        });
    }
    let raw = crate::scene::RawScene::read(root, options).map_err(ExportError::Read)?;
    let mut scene = raw
        .clone()
        .finish(
            &crate::scene::LoadOptions {
                max_image_size: None,
                ..options.clone()
            }
            .cameras_only(),
        )
        .map_err(ExportError::Read)?;
    for fix in fixes {
        let Some(view) = scene.views.get_mut(fix.view) else {
            return Err(ExportError::Input {
                message: format!(
                    "a correction names view {} but {} has {} views",
                    fix.view,
                    root.display(),
                    scene.views.len()
                ),
            });
        };
        view.camera.intrinsics.cx += fix.dx;
        view.camera.intrinsics.cy += fix.dy;
    }
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_else(|| "scene".to_string());
    let partial = out.with_file_name(format!(".{name}.partial"));
    if partial.exists() {
        std::fs::remove_dir_all(&partial)
            .map_err(|e| IoError::io(&partial, "remove the unfinished folder", e))?;
    }
    let written = (|| -> Result<(), ExportError> {
        create_dir(&partial)?;
        let full = crate::scene::LoadOptions {
            max_image_size: None,
            ..options.clone()
        };
        acmm::write_scene_with(&scene, &partial, &mut |i, path| {
            let image = raw.views[i].decode(&full).map_err(|e| IoError::Invalid {
                path: path.to_path_buf(),
                message: format!("the view's image could not be read: {e}"),
            })?;
            image.save_png(path)
        })?;
        if let Some(gt) = truth.map(|t| t.join("gt")).filter(|g| g.is_dir()) {
            let into = partial.join("gt");
            create_dir(&into)?;
            let entries =
                std::fs::read_dir(&gt).map_err(|e| IoError::io(&gt, "list the folder", e))?;
            for entry in entries {
                let from = entry
                    .map_err(|e| IoError::io(&gt, "list the folder", e))?
                    .path();
                if !from.is_file() {
                    continue;
                }
                let Some(file) = from.file_name() else {
                    continue;
                };
                let to = into.join(file);
                if std::fs::hard_link(&from, &to).is_err() {
                    std::fs::copy(&from, &to).map_err(|e| IoError::io(&to, "copy", e))?;
                }
            }
        }
        std::fs::rename(&partial, out)
            .map_err(|e| IoError::io(out, "move the finished folder to", e))?;
        Ok(())
    })();
    if written.is_err() {
        // Best effort: the error that stopped the writing is the one to report.
        let _ = std::fs::remove_dir_all(&partial);
    }
    written
}

// ---------------------------------------------------------------------------------------------
// COLMAP

/// The COLMAP image name of a view: its name if it ends in `.png` (any case), else the name
/// with `.png` appended (images are always written as PNG; see the module docs).
pub fn colmap_image_name(view_name: &str) -> String {
    let is_png = Path::new(view_name)
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        view_name.to_string()
    } else {
        format!("{view_name}.png")
    }
}

/// Checks that a COLMAP image name can be a relative path under the output folder and a line
/// of COLMAP's config files.
fn check_colmap_name(view: &str, name: &str) -> Result<(), ExportError> {
    let fail = |message: &str| {
        Err(ExportError::Name {
            view: view.to_string(),
            message: format!("its COLMAP image name {name:?} {message}; rename the view"),
        })
    };
    if name.trim() != name || name.contains(['\n', '\r', '\0']) {
        return fail(
            "starts or ends with white space or holds a line break or NUL, which COLMAP's config files cannot hold",
        );
    }
    if name.contains([',', ';']) {
        return fail("holds ',' or ';', which separate the source names in patch-match.cfg");
    }
    let path = Path::new(name);
    if path.is_absolute()
        || path
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return fail("is absolute or has '..', so it would be written outside the output folder");
    }
    Ok(())
}

/// The COLMAP image names of all views, checked and unique.
fn colmap_names(scene: &Scene) -> Result<Vec<String>, ExportError> {
    let mut seen = HashSet::new();
    let mut names = Vec::with_capacity(scene.views.len());
    for view in &scene.views {
        let name = colmap_image_name(&view.name);
        check_colmap_name(&view.name, &name)?;
        if !seen.insert(name.clone()) {
            return Err(ExportError::Name {
                view: view.name.clone(),
                message: format!(
                    "its COLMAP image name {name:?} is also another view's (a '.png' is appended to names without one); rename one of the views"
                ),
            });
        }
        names.push(name);
    }
    Ok(names)
}

/// COLMAP's id of the view at `index` (ids start at 1).
fn colmap_id(index: usize) -> Result<u32, ExportError> {
    u32::try_from(index + 1).map_err(|_| ExportError::Input {
        message: format!(
            "the scene has more than {} views, more than a COLMAP model can number",
            u32::MAX
        ),
    })
}

/// A sparse point sampled from the depth maps: position, colour and the pixels (mvscope's
/// convention) of the views that see it.
struct SparsePoint {
    xyz: DVec3,
    rgb: [u8; 3],
    observations: Vec<(usize, DVec2)>,
}

/// Samples every view's depth map on a grid of about [`SPARSE_SAMPLES_PER_VIEW`] pixels and
/// keeps the points that at least one other view's depth map confirms (projected inside it,
/// relative depth difference at most [`SPARSE_DEPTH_TOLERANCE`]). Their tracks tell COLMAP
/// which images overlap (fusion, `__auto__`) and give it depth ranges (patch match).
fn sparse_points(scene: &Scene, views: &[ViewOutput]) -> Vec<SparsePoint> {
    let per_view: Vec<Vec<SparsePoint>> = (0..scene.views.len())
        .into_par_iter()
        .map(|r| {
            let view = &scene.views[r];
            let cam = &view.camera;
            let (w, h) = (view.image.width, view.image.height);
            let pixels = w as f64 * h as f64;
            let step = ((pixels / SPARSE_SAMPLES_PER_VIEW as f64).sqrt().ceil() as u32).max(1);
            let mut points = Vec::new();
            for y in (step / 2..h).step_by(step as usize) {
                for x in (step / 2..w).step_by(step as usize) {
                    let i = y as usize * w as usize + x as usize;
                    let Some(&d) = views[r].depth.get(i) else {
                        continue;
                    };
                    if !valid_depth(d) {
                        continue;
                    }
                    let pixel = DVec2::new(x as f64, y as f64);
                    let xyz = cam.unproject(pixel, d as f64);
                    let mut observations = vec![(r, pixel)];
                    for (v, other) in scene.views.iter().enumerate() {
                        if v == r {
                            continue;
                        }
                        if let Some(p) = confirmed_in(other, views[v].depth, xyz) {
                            observations.push((v, p));
                        }
                    }
                    if observations.len() >= 2 {
                        points.push(SparsePoint {
                            xyz,
                            rgb: view.image.rgb.get(i).copied().unwrap_or([255; 3]),
                            observations,
                        });
                    }
                }
            }
            points
        })
        .collect();
    per_view.into_iter().flatten().collect()
}

/// Where `xyz` appears in `view` if that view's depth map agrees with it.
fn confirmed_in(view: &View, depth: &[f32], xyz: DVec3) -> Option<DVec2> {
    let cam = &view.camera;
    let (p, z) = cam.project(xyz)?;
    if !cam.contains(p) {
        return None;
    }
    let (w, h) = (view.image.width, view.image.height);
    let x = (p.x.round().max(0.0) as u32).min(w.saturating_sub(1));
    let y = (p.y.round().max(0.0) as u32).min(h.saturating_sub(1));
    let d = *depth.get(y as usize * w as usize + x as usize)?;
    if !valid_depth(d) {
        return None;
    }
    let d = d as f64;
    (((z - d) / d).abs() <= SPARSE_DEPTH_TOLERANCE).then_some(p)
}

/// The scene as a COLMAP model: one `PINHOLE` camera per view (id = image id = scene index + 1)
/// with the principal point shifted by `+0.5`, poses taken over, and `points` as 3D points
/// with their 2D observations (COLMAP's pixel convention).
fn colmap_model(
    scene: &Scene,
    names: &[String],
    points: &[SparsePoint],
) -> Result<ColmapModel, ExportError> {
    let mut model = ColmapModel::default();
    for (i, (view, name)) in scene.views.iter().zip(names).enumerate() {
        let id = colmap_id(i)?;
        let cam = &view.camera;
        let k = &cam.intrinsics;
        model.cameras.insert(
            id,
            ColmapCamera {
                id,
                model: CameraModel::Pinhole,
                width: u64::from(cam.width),
                height: u64::from(cam.height),
                // COLMAP: centre of the top-left pixel at (0.5, 0.5); mvscope: at (0, 0).
                params: vec![k.fx, k.fy, k.cx + 0.5, k.cy + 0.5],
            },
        );
        model.images.insert(
            id,
            ColmapImage {
                id,
                qvec: qvec_from_rotation(cam.rotation),
                tvec: cam.translation.to_array(),
                camera_id: id,
                name: name.clone(),
                points2d: Vec::new(),
            },
        );
    }
    for (k, point) in points.iter().enumerate() {
        let point_id = k as u64 + 1;
        let mut track = Vec::with_capacity(point.observations.len());
        for &(v, pixel) in &point.observations {
            let image_id = colmap_id(v)?;
            let Some(image) = model.images.get_mut(&image_id) else {
                continue;
            };
            let index = u32::try_from(image.points2d.len()).map_err(|_| ExportError::Input {
                message: format!(
                    "view {}: more 2D points than images.bin can index",
                    image.name
                ),
            })?;
            image
                .points2d
                .push(([pixel.x + 0.5, pixel.y + 0.5], point_id as i64));
            track.push((image_id, index));
        }
        model.points.insert(
            point_id,
            ColmapPoint3D {
                id: point_id,
                xyz: point.xyz.to_array(),
                rgb: point.rgb,
                error: 0.0,
                track,
            },
        );
    }
    Ok(model)
}

static STAGING_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes the binary model into `dir` without ever leaving a truncated file under a final
/// name: [`colmap::write_model`] fills a staging folder inside `dir`, each file is synced and
/// renamed into `dir`, and the staging folder is removed.
fn write_model_atomic(dir: &Path, model: &ColmapModel) -> Result<(), ExportError> {
    create_dir(dir)?;
    let staging = dir.join(format!(
        ".staging-{}-{}",
        std::process::id(),
        STAGING_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        colmap::write_model(&staging, model, Encoding::Binary)?;
        for file in ["cameras.bin", "images.bin", "points3D.bin"] {
            let from = staging.join(file);
            let to = dir.join(file);
            File::open(&from)
                .and_then(|f| f.sync_all())
                .map_err(|e| IoError::io(&to, "sync", e))?;
            std::fs::rename(&from, &to)
                .map_err(|e| IoError::io(&to, "rename the temporary file to", e))?;
        }
        Ok(())
    })();
    // Best effort: nothing is left in it after success, and partial files after a failure.
    let _ = std::fs::remove_dir_all(&staging);
    result
}

/// Writes `images/NAME` (PNG at the scene's size) for every view.
fn write_images(scene: &Scene, names: &[String], dir: &Path) -> Result<(), ExportError> {
    let images = dir.join("images");
    create_dir(&images)?;
    for (view, name) in scene.views.iter().zip(names) {
        let path = images.join(name);
        if let Some(parent) = path.parent() {
            mkdir(parent).map_err(in_view(&view.name))?;
        }
        view.image.save_png(&path).map_err(in_view(&view.name))?;
    }
    Ok(())
}

/// Writes a COLMAP dense workspace of the scene and its maps into `dir`, one that
/// `colmap stereo_fusion --workspace_path DIR --input_type geometric` fuses:
///
/// * `images/NAME` — the scene's images at its (processed) size, PNG; `NAME` is
///   [`colmap_image_name`] of the view;
/// * `sparse/{cameras,images,points3D}.bin` — `PINHOLE` cameras at the scene's size with the
///   principal point shifted by `+0.5` to COLMAP's convention, `camera_from_world` poses as
///   quaternion `(w, x, y, z)` + translation, and sparse points sampled from the depth maps
///   (about [`SPARSE_SAMPLES_PER_VIEW`] per view, each confirmed by at least one other view's
///   depth map within [`SPARSE_DEPTH_TOLERANCE`]): COLMAP's fusion only grows points across
///   images that share sparse points, so without them it fuses nothing;
/// * `stereo/depth_maps/NAME.geometric.bin` — camera-`z` depth, 0 where there is none;
/// * `stereo/normal_maps/NAME.geometric.bin` — normals in the **camera** frame of the image
///   (`R n_world`), facing the camera; `(0, 0, 0)` where there is no depth;
/// * `stereo/fusion.cfg` — one image name per line, scene order;
/// * `stereo/patch-match.cfg` — per view its name, then its source views' names separated by
///   `", "` (best first), or `__auto__, 20` when it has none.
///
/// Maps use COLMAP's `Mat` format ([`write_colmap_map`]). Costs have no place in a COLMAP
/// workspace and are not written. See the module docs for what was verified in COLMAP.
pub fn export_colmap(scene: &Scene, views: &[ViewOutput], dir: &Path) -> Result<(), ExportError> {
    check_views(scene, views)?;
    let names = colmap_names(scene)?;
    create_dir(dir)?;
    write_images(scene, &names, dir)?;
    let points = sparse_points(scene, views);
    let model = colmap_model(scene, &names, &points)?;
    write_model_atomic(&dir.join("sparse"), &model)?;

    let stereo = dir.join("stereo");
    let depth_dir = stereo.join("depth_maps");
    let normal_dir = stereo.join("normal_maps");
    for (view, (out, name)) in scene.views.iter().zip(views.iter().zip(&names)) {
        let (w, h) = (view.image.width, view.image.height);
        let file = format!("{name}.geometric.bin");
        let depth_path = depth_dir.join(&file);
        let normal_path = normal_dir.join(&file);
        for path in [&depth_path, &normal_path] {
            if let Some(parent) = path.parent() {
                mkdir(parent).map_err(in_view(&view.name))?;
            }
        }
        let depth = depth_values(out.depth);
        let mut normals = Vec::with_capacity(depth.len() * 3);
        for (&d, n) in depth.iter().zip(out.normal_world) {
            let n_cam = view
                .camera
                .dir_camera_from_world(DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64))
                .as_vec3();
            if d > 0.0 && n_cam.is_finite() {
                normals.extend_from_slice(&n_cam.to_array());
            } else {
                normals.extend_from_slice(&[0.0; 3]);
            }
        }
        let depth = map(&view.name, w, h, 1, depth)?;
        let normals = map(&view.name, w, h, 3, normals)?;
        write_colmap_map(&depth_path, &depth).map_err(in_view(&view.name))?;
        write_colmap_map(&normal_path, &normals).map_err(in_view(&view.name))?;
    }

    let mut fusion = String::new();
    let mut patch_match = String::new();
    for (view, name) in scene.views.iter().zip(&names) {
        fusion += name;
        fusion += "\n";
        patch_match += name;
        patch_match += "\n";
        if view.sources.is_empty() {
            patch_match += &format!("__auto__, {COLMAP_AUTO_SOURCES}\n");
        } else {
            let sources: Vec<&str> = view
                .sources
                .iter()
                .filter_map(|s| names.get(s.index).map(String::as_str))
                .collect();
            patch_match += &sources.join(", ");
            patch_match += "\n";
        }
    }
    write_text(&stereo.join("fusion.cfg"), &fusion)?;
    write_text(&stereo.join("patch-match.cfg"), &patch_match)?;
    Ok(())
}

/// Writes the scene as a COLMAP scene that [`colmap::read`] (and COLMAP) reads back:
/// `images/NAME` (PNG, [`colmap_image_name`]) and `sparse/{cameras,images,points3D}.bin` with
/// `PINHOLE` cameras at the scene's size (principal point `+0.5`) and the scene's poses.
///
/// There are no depth maps to sample sparse points from, so `points3D.bin` is empty: depth
/// ranges and source views are not stored, and a reader re-estimates them (mvscope from the
/// camera geometry, with a warning).
pub fn convert_to_colmap(scene: &Scene, dir: &Path) -> Result<(), ExportError> {
    let names = colmap_names(scene)?;
    create_dir(dir)?;
    write_images(scene, &names, dir)?;
    let model = colmap_model(scene, &names, &[])?;
    write_model_atomic(&dir.join("sparse"), &model)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{read_colmap_map, read_dmb, read_ply};
    use crate::scene::colmap::{read_model, rotation_from_qvec};
    use crate::scene::{LoadOptions, SceneFormat};
    use crate::synthetic::{GroundTruth, SyntheticOptions, SyntheticScene, generate};

    fn tiny() -> SyntheticScene {
        generate(&SyntheticOptions {
            views: 3,
            width: 32,
            height: 24,
            seed: 7,
            noise_sigma: 1.0,
            room: false,
            sources: crate::scene::geometry::DEFAULT_SOURCES,
        })
        .unwrap()
    }

    /// Costs that differ per pixel and per view, so that a mix-up shows.
    fn costs(s: &SyntheticScene) -> Vec<Vec<f32>> {
        s.ground_truth
            .iter()
            .enumerate()
            .map(|(v, gt)| {
                (0..gt.depth.len())
                    .map(|i| (i as f32 * 0.001 + v as f32 * 0.1) % 2.0)
                    .collect()
            })
            .collect()
    }

    fn outputs<'a>(gt: &'a [GroundTruth], costs: &'a [Vec<f32>]) -> Vec<ViewOutput<'a>> {
        gt.iter()
            .zip(costs)
            .map(|(g, c)| ViewOutput {
                depth: &g.depth,
                normal_world: &g.normal_world,
                cost: c,
            })
            .collect()
    }

    fn header_ints(path: &Path) -> [i32; 4] {
        let bytes = std::fs::read(path).unwrap();
        let int = |i: usize| i32::from_le_bytes(bytes[i * 4..i * 4 + 4].try_into().unwrap());
        [int(0), int(1), int(2), int(3)]
    }

    #[test]
    fn export_acmm_writes_the_original_layout() {
        let s = tiny();
        let c = costs(&s);
        let mut gt = s.ground_truth.clone();
        gt[1].depth[5] = -1.0; // "no depth" must be written as 0
        let outs = outputs(&gt, &c);
        let cloud = vec![
            PlyPoint {
                position: [1.0, -2.0, 3.5],
                normal: [0.0, 0.6, -0.8],
                color: [10, 20, 30],
            },
            PlyPoint {
                position: [0.25, 0.5, 0.75],
                normal: [1.0, 0.0, 0.0],
                color: [255, 0, 128],
            },
        ];
        let dir = tempfile::tempdir().unwrap();
        export_acmm(&s.scene, &outs, Some(&cloud), dir.path()).unwrap();
        let root = dir.path().join("ACMM");
        for (i, (g, cost)) in gt.iter().zip(&c).enumerate() {
            let folder = root.join(format!("2333_{i:08}"));
            let (w, h) = (g.width as i32, g.height as i32);
            for (file, channels) in [
                ("depths.dmb", 1),
                ("depths_geom.dmb", 1),
                ("normals.dmb", 3),
                ("costs.dmb", 1),
            ] {
                assert_eq!(
                    header_ints(&folder.join(file)),
                    [1, h, w, channels],
                    "{file} of view {i}: type 1, height, width, channels"
                );
            }
            let expected_depth: Vec<f32> = g.depth.iter().map(|&d| d.max(0.0)).collect();
            for file in ["depths.dmb", "depths_geom.dmb"] {
                let m = read_dmb(&folder.join(file)).unwrap();
                assert_eq!(m.data, expected_depth, "{file} of view {i}");
            }
            let n = read_dmb(&folder.join("normals.dmb")).unwrap();
            for (p, normal) in g.normal_world.iter().enumerate() {
                assert_eq!(&n.data[p * 3..p * 3 + 3], normal, "world normal, pixel {p}");
            }
            let cm = read_dmb(&folder.join("costs.dmb")).unwrap();
            assert_eq!(&cm.data, cost);
        }
        assert_eq!(
            read_dmb(&root.join("2333_00000001/depths.dmb"))
                .unwrap()
                .data[5],
            0.0
        );
        // PLY: exact header, then 27-byte little-endian records.
        let bytes = std::fs::read(root.join("ACMM_model.ply")).unwrap();
        let header = "ply\nformat binary_little_endian 1.0\nelement vertex 2\n\
                      property float x\nproperty float y\nproperty float z\n\
                      property float nx\nproperty float ny\nproperty float nz\n\
                      property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
        assert_eq!(
            String::from_utf8_lossy(&bytes[..header.len().min(bytes.len())]),
            header
        );
        let body = &bytes[header.len()..];
        assert_eq!(body.len(), 2 * 27);
        let f = |o: usize| f32::from_le_bytes(body[o..o + 4].try_into().unwrap());
        assert_eq!([f(0), f(4), f(8)], [1.0, -2.0, 3.5]);
        assert_eq!([f(12), f(16), f(20)], [0.0, 0.6, -0.8]);
        assert_eq!(&body[24..27], &[10, 20, 30]);
        assert_eq!(read_ply(&root.join("ACMM_model.ply")).unwrap(), cloud);
    }

    #[test]
    fn export_acmm_without_cloud_writes_no_ply() {
        let s = tiny();
        let c = costs(&s);
        let outs = outputs(&s.ground_truth, &c);
        let dir = tempfile::tempdir().unwrap();
        export_acmm(&s.scene, &outs, None, dir.path()).unwrap();
        assert!(!dir.path().join("ACMM/ACMM_model.ply").exists());
        assert!(dir.path().join("ACMM/2333_00000002/costs.dmb").is_file());
    }

    #[test]
    fn export_rejects_maps_that_do_not_fit() {
        let s = tiny();
        let c = costs(&s);
        let outs = outputs(&s.ground_truth, &c);
        let dir = tempfile::tempdir().unwrap();
        let e = export_acmm(&s.scene, &outs[..2], None, dir.path()).unwrap_err();
        assert!(
            e.to_string().contains("2 view(s) but the scene has 3"),
            "{e}"
        );
        let mut short = outs.clone();
        short[1].cost = &c[1][..10];
        let e = export_colmap(&s.scene, &short, dir.path()).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("view 00000001") && msg.contains("cost map"),
            "{msg}"
        );
        assert!(
            !dir.path().join("ACMM").exists() && !dir.path().join("images").exists(),
            "nothing is written when the input is wrong"
        );
    }

    #[test]
    fn export_colmap_writes_a_fusable_workspace() {
        let s = tiny();
        let c = costs(&s);
        let mut gt = s.ground_truth.clone();
        gt[0].depth[3] = 0.0;
        let outs = outputs(&gt, &c);
        let dir = tempfile::tempdir().unwrap();
        export_colmap(&s.scene, &outs, dir.path()).unwrap();
        let names: Vec<String> = (0..3).map(|i| format!("{i:08}.png")).collect();

        // Sparse model: cameras, poses, names.
        let model = read_model(&dir.path().join("sparse")).unwrap();
        assert_eq!(model.cameras.len(), 3);
        assert_eq!(model.images.len(), 3);
        for (i, view) in s.scene.views.iter().enumerate() {
            let id = i as u32 + 1;
            let cam = &model.cameras[&id];
            let k = &view.camera.intrinsics;
            assert_eq!(cam.model, CameraModel::Pinhole);
            assert_eq!((cam.width, cam.height), (32, 24));
            assert_eq!(cam.params, vec![k.fx, k.fy, k.cx + 0.5, k.cy + 0.5]);
            let image = &model.images[&id];
            assert_eq!(image.name, names[i]);
            assert_eq!(image.camera_id, id);
            let r = rotation_from_qvec(image.qvec).unwrap();
            assert!(r.abs_diff_eq(view.camera.rotation, 1e-12));
            assert_eq!(image.tvec, view.camera.translation.to_array());
            assert!(dir.path().join("images").join(&names[i]).is_file());
        }
        let back = image::open(dir.path().join("images").join(&names[1]))
            .unwrap()
            .to_rgb8();
        assert_eq!(back.dimensions(), (32, 24));
        let rgb: Vec<[u8; 3]> = back.pixels().map(|p| p.0).collect();
        assert_eq!(rgb, s.scene.views[1].image.rgb);

        // Sparse points: tracks of >= 2 views whose 2D points are the projections (COLMAP's
        // pixel convention) and point back at the 3D point.
        assert!(!model.points.is_empty());
        let mut shared = [[0usize; 3]; 3];
        for point in model.points.values() {
            assert!(point.track.len() >= 2);
            let xyz = DVec3::from_array(point.xyz);
            for &(image_id, idx) in &point.track {
                let image = &model.images[&image_id];
                let (xy, pid) = image.points2d[idx as usize];
                assert_eq!(pid, point.id as i64);
                let view = &s.scene.views[image_id as usize - 1];
                let (p, _) = view.camera.project(xyz).unwrap();
                assert!((p + DVec2::splat(0.5) - DVec2::from_array(xy)).length() < 1e-6);
            }
            for &(a, _) in &point.track {
                for &(b, _) in &point.track {
                    shared[a as usize - 1][b as usize - 1] += 1;
                }
            }
        }
        for (i, view) in s.scene.views.iter().enumerate() {
            let best = view.sources[0].index;
            assert!(
                shared[i][best] > 0,
                "view {i} shares sparse points with its best source {best} (fusion needs it)"
            );
        }

        // Maps: depth (0 = none) and camera-frame normals.
        for (i, (view, g)) in s.scene.views.iter().zip(&gt).enumerate() {
            let file = format!("{}.geometric.bin", names[i]);
            let stereo = dir.path().join("stereo");
            let d = read_colmap_map(&stereo.join("depth_maps").join(&file)).unwrap();
            assert_eq!((d.width, d.height, d.channels), (32, 24, 1));
            assert_eq!(d.data, g.depth);
            let n = read_colmap_map(&stereo.join("normal_maps").join(&file)).unwrap();
            assert_eq!((n.width, n.height, n.channels), (32, 24, 3));
            let mut checked = 0;
            for (p, nw) in g.normal_world.iter().enumerate() {
                let got = DVec3::new(
                    n.data[p * 3] as f64,
                    n.data[p * 3 + 1] as f64,
                    n.data[p * 3 + 2] as f64,
                );
                if g.depth[p] <= 0.0 {
                    assert_eq!(got, DVec3::ZERO, "no depth, no normal");
                    continue;
                }
                let world = DVec3::new(nw[0] as f64, nw[1] as f64, nw[2] as f64);
                let expected = view.camera.rotation * world;
                assert!((got - expected).length() < 1e-6, "pixel {p}");
                // COLMAP's convention: the normal faces the camera (n . ray <= 0).
                let (x, y) = ((p % 32) as f64, (p / 32) as f64);
                let ray = view.camera.ray_in_camera(DVec2::new(x, y));
                assert!(got.dot(ray) <= 1e-6, "pixel {p} faces the camera");
                checked += 1;
            }
            assert!(checked > 0);
        }
        let d0 = read_colmap_map(
            &dir.path()
                .join("stereo/depth_maps/00000000.png.geometric.bin"),
        )
        .unwrap();
        assert_eq!(d0.data[3], 0.0);

        // Config files.
        let fusion = std::fs::read_to_string(dir.path().join("stereo/fusion.cfg")).unwrap();
        assert_eq!(fusion, format!("{}\n", names.join("\n")));
        let pm = std::fs::read_to_string(dir.path().join("stereo/patch-match.cfg")).unwrap();
        let lines: Vec<&str> = pm.lines().collect();
        assert_eq!(lines.len(), 6);
        for (i, view) in s.scene.views.iter().enumerate() {
            assert_eq!(lines[2 * i], names[i]);
            let expected: Vec<String> = view
                .sources
                .iter()
                .map(|src| names[src.index].clone())
                .collect();
            assert_eq!(lines[2 * i + 1], expected.join(", "));
        }
        // No temporary files or staging folders are left behind.
        let leftovers: Vec<String> = std::fs::read_dir(dir.path().join("sparse"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with('.'))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
    }

    #[test]
    fn export_colmap_workspace_loads_as_a_scene() {
        let s = tiny();
        let c = costs(&s);
        let outs = outputs(&s.ground_truth, &c);
        let dir = tempfile::tempdir().unwrap();
        export_colmap(&s.scene, &outs, dir.path()).unwrap();
        let back = Scene::load(dir.path(), &LoadOptions::default()).unwrap();
        assert_eq!(back.format, Some(SceneFormat::Colmap));
        assert_eq!(back.views.len(), 3);
        for (g, b) in s.ground_truth.iter().zip(&back.views) {
            // The sparse points give depth ranges that bracket (nearly) all true depths, and
            // source views: no warning says either was estimated from camera geometry.
            let valid: Vec<f64> = g
                .depth
                .iter()
                .filter(|&&d| d > 0.0)
                .map(|&d| d as f64)
                .collect();
            let inside = valid
                .iter()
                .filter(|&&d| d >= b.depth_range.min && d <= b.depth_range.max)
                .count();
            assert!(
                inside * 100 >= valid.len() * 98,
                "{inside} of {} depths inside the range",
                valid.len()
            );
            assert!(!b.sources.is_empty());
        }
        assert!(
            back.warnings.iter().all(|w| !w.contains("geometry")),
            "{:?}",
            back.warnings
        );
    }

    #[test]
    fn patch_match_cfg_uses_auto_without_sources() {
        let s = tiny();
        let mut scene = s.scene.clone();
        scene.views[2].sources.clear();
        let c = costs(&s);
        let outs = outputs(&s.ground_truth, &c);
        let dir = tempfile::tempdir().unwrap();
        export_colmap(&scene, &outs, dir.path()).unwrap();
        let pm = std::fs::read_to_string(dir.path().join("stereo/patch-match.cfg")).unwrap();
        let lines: Vec<&str> = pm.lines().collect();
        assert_eq!(lines[4], "00000002.png");
        assert_eq!(lines[5], "__auto__, 20");
    }

    #[test]
    fn colmap_names_follow_the_documented_rule() {
        assert_eq!(colmap_image_name("00000003"), "00000003.png");
        assert_eq!(colmap_image_name("a/b.PNG"), "a/b.PNG");
        assert_eq!(colmap_image_name("IMG_1.JPG"), "IMG_1.JPG.png");
        assert!(check_colmap_name("v", "../x.png").is_err());
        assert!(check_colmap_name("v", "/abs.png").is_err());
        assert!(check_colmap_name("v", "a,b.png").is_err());
        assert!(check_colmap_name("v", " a.png").is_err());
        assert!(check_colmap_name("v", "sub/a.png").is_ok());

        let s = tiny();
        let mut scene = s.scene.clone();
        scene.views[0].name = "x".into();
        scene.views[1].name = "x.png".into();
        let dir = tempfile::tempdir().unwrap();
        let e = convert_to_colmap(&scene, dir.path()).unwrap_err();
        assert!(matches!(e, ExportError::Name { .. }), "{e}");
        assert!(e.to_string().contains("view x.png"), "{e}");
    }

    #[test]
    fn convert_to_colmap_round_trips() {
        let s = tiny();
        let dir = tempfile::tempdir().unwrap();
        convert_to_colmap(&s.scene, dir.path()).unwrap();
        assert!(
            !dir.path().join("stereo").exists(),
            "images/ and sparse/ only"
        );
        let back = Scene::load(dir.path(), &LoadOptions::default()).unwrap();
        assert_eq!(back.format, Some(SceneFormat::Colmap));
        assert_eq!(back.views.len(), s.scene.views.len());
        for (a, b) in s.scene.views.iter().zip(&back.views) {
            assert_eq!(b.name, colmap_image_name(&a.name));
            let (ka, kb) = (&a.camera.intrinsics, &b.camera.intrinsics);
            for (x, y) in [
                (ka.fx, kb.fx),
                (ka.fy, kb.fy),
                (ka.cx, kb.cx),
                (ka.cy, kb.cy),
            ] {
                assert!((x - y).abs() < 1e-6, "{x} vs {y}");
            }
            assert!(a.camera.rotation.abs_diff_eq(b.camera.rotation, 1e-6));
            assert!(a.camera.translation.abs_diff_eq(b.camera.translation, 1e-6));
            assert_eq!(
                (a.camera.width, a.camera.height),
                (b.camera.width, b.camera.height)
            );
            assert!(
                a.image.rgb == b.image.rgb,
                "view {}: the pixels differ",
                a.name
            );
        }
    }

    #[test]
    fn convert_to_acmm_round_trips() {
        let s = tiny();
        let dir = tempfile::tempdir().unwrap();
        convert_to_acmm(&s.scene, dir.path()).unwrap();
        let back = Scene::load(dir.path(), &LoadOptions::default()).unwrap();
        assert_eq!(back.format, Some(SceneFormat::Acmm));
        assert_eq!(back.views.len(), s.scene.views.len());
        for (a, b) in s.scene.views.iter().zip(&back.views) {
            assert_eq!(a.name, b.name);
            let (ka, kb) = (&a.camera.intrinsics, &b.camera.intrinsics);
            for (x, y) in [
                (ka.fx, kb.fx),
                (ka.fy, kb.fy),
                (ka.cx, kb.cx),
                (ka.cy, kb.cy),
            ] {
                assert!((x - y).abs() < 1e-6, "{x} vs {y}");
            }
            assert!(a.camera.rotation.abs_diff_eq(b.camera.rotation, 1e-6));
            assert!(a.camera.translation.abs_diff_eq(b.camera.translation, 1e-6));
            assert!((a.depth_range.min - b.depth_range.min).abs() < 1e-9);
            assert!((a.depth_range.max - b.depth_range.max).abs() < 1e-9);
            let ia: Vec<usize> = a.sources.iter().map(|s| s.index).collect();
            let ib: Vec<usize> = b.sources.iter().map(|s| s.index).collect();
            assert_eq!(ia, ib);
            assert!(
                a.image.rgb == b.image.rgb,
                "view {}: the pixels differ",
                a.name
            );
        }
    }

    #[test]
    fn io_errors_name_the_view_and_the_file() {
        let s = tiny();
        let c = costs(&s);
        let outs = outputs(&s.ground_truth, &c);
        let dir = tempfile::tempdir().unwrap();
        // A file where the view's folder must go.
        std::fs::create_dir_all(dir.path().join("ACMM")).unwrap();
        std::fs::write(dir.path().join("ACMM/2333_00000001"), b"x").unwrap();
        let e = export_acmm(&s.scene, &outs, None, dir.path()).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("view 00000001: "), "{msg}");
        assert!(msg.contains("2333_00000001"), "{msg}");
        assert!(msg.contains("writable"), "{msg}");
        assert!(e.path().is_some());
    }
}
