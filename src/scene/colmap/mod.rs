//! COLMAP sparse models: reading and writing `cameras`, `images` and `points3D` in COLMAP's
//! binary (`.bin`) and text (`.txt`) encodings, and turning a model into a [`RawScene`].
//!
//! # Layout of a COLMAP scene
//!
//! The images are always in `ROOT/images/`, named as the model names them. The model is in
//! `ROOT/sparse/0/` (a COLMAP project), `ROOT/sparse/` (the dense workspace that
//! `colmap image_undistorter` writes) or `ROOT/` itself; see [`find_model`].
//!
//! # Conventions (and how they map onto mvscope's, see [`crate::camera`])
//!
//! * An image's pose `(qvec, tvec)` is `camera_from_world`: `X_cam = R(q) X_world + t` with the
//!   unit quaternion `q = (w, x, y, z)` (Hamilton convention), exactly mvscope's convention. The
//!   rotation and translation are taken over unchanged.
//! * COLMAP puts the centre of the top-left pixel at `(0.5, 0.5)`; mvscope puts it at `(0, 0)`.
//!   The principal point is therefore shifted by `-0.5` on import (`cx = cx_colmap - 0.5`, same
//!   for `cy`) and by `+0.5` on export. Focal lengths are unchanged.
//! * Cameras: `SIMPLE_PINHOLE` and `PINHOLE` are read as they are. `SIMPLE_RADIAL`, `RADIAL`,
//!   `OPENCV`, `FULL_OPENCV` and `OPENCV_FISHEYE` (what `colmap mapper` writes by default is
//!   `SIMPLE_RADIAL`) are undistorted on load: each image is resampled once to the pinhole
//!   camera with the same size, focal lengths and principal point (see
//!   [`super::undistort`]). The other models (`FOV`, the other fisheyes) are accepted only
//!   when they are pinhole in effect (non-fisheye with zero distortion); else the error points
//!   to `colmap image_undistorter`. A distortion that folds the image is refused.
//!
//! # Depth ranges and source views
//!
//! These follow the ACMM authors' converter `colmap2mvsnet_acm.py`:
//! * depth range of a view: the depths (camera `z`) of the sparse points it observes, sorted;
//!   `p1 = z[floor(0.01 n)]`, `p99 = z[floor(0.99 n)]`; range `[0.75 p1, 1.25 p99]`;
//! * score of a source view: the number of sparse points both views observe, set to 0 when the
//!   75th percentile (`angles[floor(0.75 n)]`, sorted) of the triangulation angles of those
//!   points (the angle at the point between the rays to the two camera centres) is below 1
//!   degree; the best `min(20, N - 1)` views with a positive score are kept, best first.
//!
//! Views are ordered by image name, not by COLMAP's image ids (which need not follow names).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3};

use super::undistort::{Distortion, Lens};

use super::text::parse_token;
use super::{DepthRange, RawScene, RawView, SceneFormat};
use crate::camera::{Camera, Intrinsics};
use crate::error::SceneError;

mod binary;
mod text;

use binary::*;
use text::*;

/// How many source views the authors' converter keeps at most.
pub const MAX_COLMAP_SOURCES: usize = 20;
/// Views whose 75th-percentile triangulation angle is below this (degrees) score 0.
pub const MIN_TRIANGULATION_ANGLE_DEG: f64 = 1.0;

/// COLMAP's camera models, with COLMAP's numeric ids (`cameras.bin`) and names (`cameras.txt`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CameraModel {
    /// `f, cx, cy`
    SimplePinhole,
    /// `fx, fy, cx, cy`
    Pinhole,
    /// `f, cx, cy, k`
    SimpleRadial,
    /// `f, cx, cy, k1, k2`
    Radial,
    /// `fx, fy, cx, cy, k1, k2, p1, p2`
    OpenCv,
    /// `fx, fy, cx, cy, k1, k2, k3, k4`
    OpenCvFisheye,
    /// `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6`
    FullOpenCv,
    /// `fx, fy, cx, cy, omega`
    Fov,
    /// `f, cx, cy, k`
    SimpleRadialFisheye,
    /// `f, cx, cy, k1, k2`
    RadialFisheye,
    /// `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1`
    ThinPrismFisheye,
}

impl CameraModel {
    /// Every model this reader knows, in id order.
    pub const ALL: [CameraModel; 11] = [
        CameraModel::SimplePinhole,
        CameraModel::Pinhole,
        CameraModel::SimpleRadial,
        CameraModel::Radial,
        CameraModel::OpenCv,
        CameraModel::OpenCvFisheye,
        CameraModel::FullOpenCv,
        CameraModel::Fov,
        CameraModel::SimpleRadialFisheye,
        CameraModel::RadialFisheye,
        CameraModel::ThinPrismFisheye,
    ];

    /// COLMAP's numeric model id.
    pub fn id(self) -> i32 {
        match self {
            CameraModel::SimplePinhole => 0,
            CameraModel::Pinhole => 1,
            CameraModel::SimpleRadial => 2,
            CameraModel::Radial => 3,
            CameraModel::OpenCv => 4,
            CameraModel::OpenCvFisheye => 5,
            CameraModel::FullOpenCv => 6,
            CameraModel::Fov => 7,
            CameraModel::SimpleRadialFisheye => 8,
            CameraModel::RadialFisheye => 9,
            CameraModel::ThinPrismFisheye => 10,
        }
    }

    /// COLMAP's model name.
    pub fn name(self) -> &'static str {
        match self {
            CameraModel::SimplePinhole => "SIMPLE_PINHOLE",
            CameraModel::Pinhole => "PINHOLE",
            CameraModel::SimpleRadial => "SIMPLE_RADIAL",
            CameraModel::Radial => "RADIAL",
            CameraModel::OpenCv => "OPENCV",
            CameraModel::OpenCvFisheye => "OPENCV_FISHEYE",
            CameraModel::FullOpenCv => "FULL_OPENCV",
            CameraModel::Fov => "FOV",
            CameraModel::SimpleRadialFisheye => "SIMPLE_RADIAL_FISHEYE",
            CameraModel::RadialFisheye => "RADIAL_FISHEYE",
            CameraModel::ThinPrismFisheye => "THIN_PRISM_FISHEYE",
        }
    }

    /// The names of the parameters, in file order.
    pub fn param_names(self) -> &'static [&'static str] {
        match self {
            CameraModel::SimplePinhole => &["f", "cx", "cy"],
            CameraModel::Pinhole => &["fx", "fy", "cx", "cy"],
            CameraModel::SimpleRadial | CameraModel::SimpleRadialFisheye => &["f", "cx", "cy", "k"],
            CameraModel::Radial | CameraModel::RadialFisheye => &["f", "cx", "cy", "k1", "k2"],
            CameraModel::OpenCv => &["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"],
            CameraModel::OpenCvFisheye => &["fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"],
            CameraModel::FullOpenCv => &[
                "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6",
            ],
            CameraModel::Fov => &["fx", "fy", "cx", "cy", "omega"],
            CameraModel::ThinPrismFisheye => &[
                "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "sx1", "sy1",
            ],
        }
    }

    /// Number of parameters a camera of this model stores.
    pub fn num_params(self) -> usize {
        self.param_names().len()
    }

    /// Number of focal-length parameters (1: `f`, 2: `fx, fy`); the principal point follows.
    fn num_focal(self) -> usize {
        match self {
            CameraModel::SimplePinhole
            | CameraModel::SimpleRadial
            | CameraModel::Radial
            | CameraModel::SimpleRadialFisheye
            | CameraModel::RadialFisheye => 1,
            _ => 2,
        }
    }

    /// Whether the projection is not pinhole even with all distortion parameters 0.
    pub fn is_fisheye(self) -> bool {
        matches!(
            self,
            CameraModel::OpenCvFisheye
                | CameraModel::SimpleRadialFisheye
                | CameraModel::RadialFisheye
                | CameraModel::ThinPrismFisheye
        )
    }

    pub fn from_id(id: i32) -> Option<CameraModel> {
        CameraModel::ALL.into_iter().find(|m| m.id() == id)
    }

    pub fn from_name(name: &str) -> Option<CameraModel> {
        CameraModel::ALL.into_iter().find(|m| m.name() == name)
    }
}

impl std::fmt::Display for CameraModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One camera (intrinsics) of a COLMAP model; `params` in COLMAP's pixel convention.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapCamera {
    pub id: u32,
    pub model: CameraModel,
    pub width: u64,
    pub height: u64,
    pub params: Vec<f64>,
}

/// One registered image of a COLMAP model.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapImage {
    pub id: u32,
    /// Rotation of `camera_from_world` as a quaternion `(w, x, y, z)`.
    pub qvec: [f64; 4],
    /// Translation of `camera_from_world`.
    pub tvec: [f64; 3],
    pub camera_id: u32,
    /// File name relative to the image folder (may contain `/`).
    pub name: String,
    /// Keypoints (COLMAP pixel convention) and the id of the 3D point each observes, or -1.
    pub points2d: Vec<([f64; 2], i64)>,
}

/// One triangulated point of a COLMAP model.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapPoint3D {
    pub id: u64,
    pub xyz: [f64; 3],
    pub rgb: [u8; 3],
    /// Mean reprojection error in pixels (not checked for finiteness: mvscope does not use it).
    pub error: f64,
    /// `(image id, index into that image's points2d)`.
    pub track: Vec<(u32, u32)>,
}

/// A COLMAP sparse model, keyed by id.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColmapModel {
    pub cameras: BTreeMap<u32, ColmapCamera>,
    pub images: BTreeMap<u32, ColmapImage>,
    pub points: BTreeMap<u64, ColmapPoint3D>,
}

/// The two encodings COLMAP writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// `cameras.bin`, `images.bin`, `points3D.bin` (little-endian).
    Binary,
    /// `cameras.txt`, `images.txt`, `points3D.txt`.
    Text,
}

impl Encoding {
    fn ext(self) -> &'static str {
        match self {
            Encoding::Binary => "bin",
            Encoding::Text => "txt",
        }
    }
}

fn holds_model(dir: &Path) -> bool {
    ["bin", "txt"].iter().any(|ext| {
        crate::vfs::is_file(&dir.join(format!("cameras.{ext}")))
            && crate::vfs::is_file(&dir.join(format!("images.{ext}")))
    })
}

/// The model folder of a scene folder: `root/sparse/0` (a COLMAP project; the lowest numbered
/// model when there is no 0), `root/sparse` (a
/// dense workspace written by `colmap image_undistorter`) or `root` itself, the first that holds
/// `cameras.{bin,txt}` and `images.{bin,txt}`.
pub fn find_model(root: &Path) -> Option<PathBuf> {
    let first = list_models(root).first().copied().unwrap_or(0);
    [
        root.join("sparse").join(first.to_string()),
        root.join("sparse"),
        root.to_path_buf(),
    ]
    .into_iter()
    .find(|dir| holds_model(dir))
}

/// The numbered models under `root/sparse/` (what `colmap mapper` writes when it splits a
/// reconstruction), by number.
pub fn list_models(root: &Path) -> Vec<u32> {
    let mut found: Vec<u32> = crate::vfs::read_dir(&root.join("sparse"))
        .into_iter()
        .flatten()
        .filter_map(|path| {
            let n: u32 = path.file_name()?.to_str()?.parse().ok()?;
            holds_model(&path).then_some(n)
        })
        .collect();
    found.sort_unstable();
    found
}

/// Which encoding a model folder uses: binary when `cameras.bin` and `images.bin` exist, else
/// text when `cameras.txt` and `images.txt` do.
pub fn model_encoding(dir: &Path) -> Option<Encoding> {
    [Encoding::Binary, Encoding::Text].into_iter().find(|e| {
        crate::vfs::is_file(&dir.join(format!("cameras.{}", e.ext())))
            && crate::vfs::is_file(&dir.join(format!("images.{}", e.ext())))
    })
}

/// Reads a model folder, binary or text (see [`model_encoding`]). Checks that every image's
/// camera and every track's image exist.
pub fn read_model(dir: &Path) -> Result<ColmapModel, SceneError> {
    let Some(encoding) = model_encoding(dir) else {
        return Err(SceneError::file(
            dir,
            "no COLMAP model here: expected cameras.bin + images.bin + points3D.bin or cameras.txt + images.txt + points3D.txt",
        ));
    };
    let ext = encoding.ext();
    let cameras_path = dir.join(format!("cameras.{ext}"));
    let images_path = dir.join(format!("images.{ext}"));
    let points_path = dir.join(format!("points3D.{ext}"));
    if !crate::vfs::is_file(&points_path) {
        return Err(SceneError::file(
            &points_path,
            format!(
                "the model has cameras.{ext} and images.{ext} but no points3D.{ext}; copy the whole model folder (the sparse points give depth ranges and source views)"
            ),
        ));
    }
    match encoding {
        Encoding::Binary => {
            let cameras = read_cameras_bin(&cameras_path)?;
            let images = read_images_bin(&images_path, &cameras)?;
            let points = read_points_bin(&points_path, &images)?;
            Ok(ColmapModel {
                cameras,
                images,
                points,
            })
        }
        Encoding::Text => {
            let cameras = read_cameras_txt(&cameras_path)?;
            let images = read_images_txt(&images_path, &cameras)?;
            let points = read_points_txt(&points_path, &images)?;
            Ok(ColmapModel {
                cameras,
                images,
                points,
            })
        }
    }
}

/// Writes `cameras`, `images` and `points3D` in `encoding` into `dir` (created if missing),
/// in id order, as COLMAP does. Text numbers are written so that they read back exactly.
pub fn write_model(dir: &Path, model: &ColmapModel, encoding: Encoding) -> Result<(), SceneError> {
    std::fs::create_dir_all(dir).map_err(|e| SceneError::io(dir, e))?;
    let ext = encoding.ext();
    let cameras_path = dir.join(format!("cameras.{ext}"));
    let images_path = dir.join(format!("images.{ext}"));
    let points_path = dir.join(format!("points3D.{ext}"));
    let (cameras, images, points) = match encoding {
        Encoding::Binary => (
            cameras_bin(model),
            images_bin(&images_path, model)?,
            points_bin(model),
        ),
        Encoding::Text => (
            cameras_txt(model).into_bytes(),
            images_txt(&images_path, model)?.into_bytes(),
            points_txt(model).into_bytes(),
        ),
    };
    for (path, bytes) in [
        (&cameras_path, cameras),
        (&images_path, images),
        (&points_path, points),
    ] {
        std::fs::write(path, bytes).map_err(|e| SceneError::io(path, e))?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Binary encoding

fn duplicate(what: &str, id: impl std::fmt::Display) -> String {
    format!("{what} id {id} appears twice; the model is corrupt")
}

fn unknown_model(camera_id: u32, model: &str) -> String {
    let known: Vec<String> = CameraModel::ALL
        .iter()
        .map(|m| format!("{} = {}", m.id(), m.name()))
        .collect();
    format!(
        "camera {camera_id} has the unknown camera model '{model}' (known: {}); newer COLMAP models are distorted or fisheye anyway: run `colmap image_undistorter` and give mvscope its output folder",
        known.join(", ")
    )
}

fn check_image(image: &ColmapImage, cameras: &BTreeMap<u32, ColmapCamera>) -> Result<(), String> {
    let what = format!("image {} ({})", image.id, image.name);
    if image.name.is_empty() {
        return Err(format!("image {} has an empty name", image.id));
    }
    if !all_finite(&image.qvec) || !all_finite(&image.tvec) {
        return Err(format!(
            "{what} has a non-finite pose (NaN or infinity); the model is corrupt"
        ));
    }
    if !cameras.contains_key(&image.camera_id) {
        return Err(format!(
            "{what} uses camera {}, which the cameras file does not have; the model is incomplete or its files come from different models",
            image.camera_id
        ));
    }
    for (i, (xy, point_id)) in image.points2d.iter().enumerate() {
        if !all_finite(xy) {
            return Err(format!(
                "{what}: 2D point {i} has a non-finite coordinate; the model is corrupt"
            ));
        }
        if *point_id < -1 {
            return Err(format!(
                "{what}: 2D point {i} refers to the invalid 3D point id {point_id} (ids are >= 0, or -1 for none)"
            ));
        }
    }
    Ok(())
}

fn check_point(point: &ColmapPoint3D, images: &BTreeMap<u32, ColmapImage>) -> Result<(), String> {
    if !all_finite(&point.xyz) {
        return Err(format!(
            "3D point {} has a non-finite position; the model is corrupt",
            point.id
        ));
    }
    if point.id > i64::MAX as u64 {
        return Err(format!("3D point id {} is out of range", point.id));
    }
    for (image_id, _) in &point.track {
        if !images.contains_key(image_id) {
            return Err(format!(
                "the track of 3D point {} refers to image {image_id}, which the images file does not have; the model is incomplete or its files come from different models",
                point.id
            ));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Text encoding

/// The rotation of a COLMAP quaternion `(w, x, y, z)`, normalised first; `None` when it is
/// (nearly) zero or not finite.
pub fn rotation_from_qvec(qvec: [f64; 4]) -> Option<DMat3> {
    let [w, x, y, z] = qvec;
    let q = DQuat::from_xyzw(x, y, z, w);
    let norm = q.length();
    if !norm.is_finite() || norm < 1e-12 {
        return None;
    }
    Some(DMat3::from_quat(q / norm))
}

/// The COLMAP quaternion `(w, x, y, z)` of a rotation matrix, with `w >= 0` (for export).
pub fn qvec_from_rotation(rotation: DMat3) -> [f64; 4] {
    let q = DQuat::from_mat3(&rotation).normalize();
    let q = if q.w < 0.0 { -q } else { q };
    [q.w, q.x, q.y, q.z]
}

/// mvscope intrinsics of a COLMAP camera: `Err` (a sentence) unless it is an undistorted
/// pinhole. The principal point moves by -0.5 px (see the module docs).
pub fn pinhole_intrinsics(camera: &ColmapCamera) -> Result<Intrinsics, String> {
    let model = camera.model;
    let p = &camera.params;
    if p.len() != model.num_params() {
        return Err(format!(
            "camera {}: a {model} camera has {} parameters, found {}",
            camera.id,
            model.num_params(),
            p.len()
        ));
    }
    let undistort = "mvscope needs undistorted pinhole images: run `colmap image_undistorter --image_path IMAGES --input_path MODEL --output_path OUT` and give mvscope the folder OUT (its images/ and sparse/)";
    if model.is_fisheye() {
        return Err(format!(
            "camera {} is a {model} (fisheye) camera; {undistort}",
            camera.id
        ));
    }
    let nf = model.num_focal();
    let extra = &p[nf + 2..];
    if extra.iter().any(|&k| k != 0.0) {
        let names = &model.param_names()[nf + 2..];
        let listed: Vec<String> = names
            .iter()
            .zip(extra)
            .map(|(n, v)| format!("{n} = {v}"))
            .collect();
        return Err(format!(
            "camera {} is a {model} camera with lens distortion ({}); {undistort}",
            camera.id,
            listed.join(", ")
        ));
    }
    let (fx, fy) = if nf == 1 { (p[0], p[0]) } else { (p[0], p[1]) };
    Ok(Intrinsics {
        fx,
        fy,
        // COLMAP: centre of the top-left pixel at (0.5, 0.5); mvscope: at (0, 0).
        cx: p[nf] - 0.5,
        cy: p[nf + 1] - 0.5,
    })
}

/// mvscope intrinsics of a COLMAP camera and, for a distorted camera mvscope undistorts on
/// load, its lens. `Err` (a sentence naming the camera) for a camera it cannot use.
pub fn camera_lens(camera: &ColmapCamera) -> Result<(Intrinsics, Option<Lens>), String> {
    let model = camera.model;
    let p = &camera.params;
    if p.len() == model.num_params() && !all_finite(p) {
        return Err(format!(
            "camera {} ({model}) has a parameter that is not a number ({:?}); the model is corrupt: re-export it from COLMAP",
            camera.id, p
        ));
    }
    let distortion = match model {
        CameraModel::SimpleRadial if p.len() == 4 => Some(Distortion::OpenCv {
            k: [p[3], 0.0, 0.0, 0.0, 0.0, 0.0],
            p: [0.0; 2],
        }),
        CameraModel::Radial if p.len() == 5 => Some(Distortion::OpenCv {
            k: [p[3], p[4], 0.0, 0.0, 0.0, 0.0],
            p: [0.0; 2],
        }),
        CameraModel::OpenCv if p.len() == 8 => Some(Distortion::OpenCv {
            k: [p[4], p[5], 0.0, 0.0, 0.0, 0.0],
            p: [p[6], p[7]],
        }),
        CameraModel::FullOpenCv if p.len() == 12 => Some(Distortion::OpenCv {
            k: [p[4], p[5], p[8], p[9], p[10], p[11]],
            p: [p[6], p[7]],
        }),
        CameraModel::OpenCvFisheye if p.len() == 8 => Some(Distortion::Fisheye {
            k: [p[4], p[5], p[6], p[7]],
        }),
        _ => None,
    };
    let Some(distortion) = distortion else {
        return pinhole_intrinsics(camera).map(|k| (k, None));
    };
    let nf = model.num_focal();
    let (fx, fy) = if nf == 1 { (p[0], p[0]) } else { (p[0], p[1]) };
    let intrinsics = Intrinsics {
        fx,
        fy,
        cx: p[nf] - 0.5,
        cy: p[nf + 1] - 0.5,
    };
    let pinhole_already =
        model != CameraModel::OpenCvFisheye && p[nf + 2..].iter().all(|&k| k == 0.0);
    if pinhole_already {
        return Ok((intrinsics, None));
    }
    if !(fx > 0.0 && fy > 0.0) {
        return Err(format!(
            "camera {} ({model}) has focal lengths {fx}, {fy}; they must be positive",
            camera.id
        ));
    }
    let lens = Lens {
        fx,
        fy,
        cx: intrinsics.cx,
        cy: intrinsics.cy,
        distortion,
    };
    let (w, h) = (
        camera.width.min(u32::MAX as u64) as u32,
        camera.height.min(u32::MAX as u64) as u32,
    );
    if distortion.folds_within(lens.max_radius(w, h)) {
        return Err(format!(
            "camera {} ({model}, {}) folds the image: its distortion stops growing with the radius inside the {w}x{h} image, so the image cannot be undistorted one to one; check the calibration (re-run the mapper with fixed or refined intrinsics)",
            camera.id,
            model
                .param_names()
                .iter()
                .zip(p)
                .skip(nf + 2)
                .map(|(n, v)| format!("{n} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok((intrinsics, Some(lens)))
}

/// Reads the COLMAP scene folder `root`: the model found by [`find_model`] and the images in
/// `root/images/`.
pub fn read(root: &Path) -> Result<RawScene, SceneError> {
    read_model_at(root, None)
}

/// [`read`] with the model in `root/sparse/N` when `model` is `Some(N)`.
pub fn read_model_at(root: &Path, model: Option<u32>) -> Result<RawScene, SceneError> {
    if let Some(n) = model {
        let dir = root.join("sparse").join(n.to_string());
        if !holds_model(&dir) {
            let models = list_models(root);
            let listed = if models.is_empty() {
                "there are no numbered models under sparse/".to_string()
            } else {
                format!(
                    "the models there are {}",
                    models
                        .iter()
                        .map(u32::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            return Err(SceneError::file(
                &dir,
                format!("--model {n}: no COLMAP model in this folder; {listed}"),
            ));
        }
        let mut raw = read_with(&dir, &root.join("images"))?;
        raw.root = root.to_path_buf();
        return Ok(raw);
    }
    let Some(model_dir) = find_model(root) else {
        return Err(SceneError::file(
            root,
            "no COLMAP model found: expected cameras.{bin,txt} and images.{bin,txt} (with points3D) in sparse/0/ (a COLMAP project), sparse/ (an image_undistorter workspace) or the folder itself, and the images in images/",
        ));
    };
    let mut raw = read_with(&model_dir, &root.join("images"))?;
    raw.root = root.to_path_buf();
    Ok(raw)
}

/// Reads the model in `model_dir` with the images in `images_dir`; see the module docs for the
/// conventions, depth ranges and source views. Views are sorted by image name.
pub fn read_with(model_dir: &Path, images_dir: &Path) -> Result<RawScene, SceneError> {
    if !crate::vfs::is_dir(images_dir) {
        return Err(SceneError::file(
            images_dir,
            "the image folder does not exist; a COLMAP scene keeps its (undistorted) images in images/ beside sparse/, named as in the model's images file",
        ));
    }
    let model = read_model(model_dir)?;
    let encoding = model_encoding(model_dir).unwrap_or(Encoding::Binary);
    let images_file = model_dir.join(format!("images.{}", encoding.ext()));
    let cameras_file = model_dir.join(format!("cameras.{}", encoding.ext()));

    let mut images: Vec<&ColmapImage> = model.images.values().collect();
    images.sort_by(|a, b| a.name.cmp(&b.name).then(a.id.cmp(&b.id)));

    let mut warnings = Vec::new();
    // Images the model lists but the folder lacks: the run goes on without them.
    let (present, missing): (Vec<&ColmapImage>, Vec<&ColmapImage>) = images
        .into_iter()
        .partition(|i| crate::vfs::is_file(&images_dir.join(&i.name)));
    let images = present;
    if !missing.is_empty() {
        let names: Vec<&str> = missing.iter().map(|i| i.name.as_str()).collect();
        if images.len() < 2 {
            return Err(SceneError::file(
                images_dir,
                format!(
                    "{} of the model's {} images are missing here ({}); multi-view stereo needs at least two: copy the images into this folder under the names the model gives",
                    missing.len(),
                    missing.len() + images.len(),
                    names.join(", ")
                ),
            ));
        }
        warnings.push(format!(
            "{} image(s) of the model are missing from {} and were left out: {}",
            missing.len(),
            images_dir.display(),
            names.join(", ")
        ));
    }
    let mut undistorted = BTreeSet::new();
    let mut views = Vec::with_capacity(images.len());
    for image in &images {
        // check_image guarantees the camera exists; stay panic-free anyway.
        let camera = model.cameras.get(&image.camera_id).ok_or_else(|| {
            SceneError::file(
                &images_file,
                format!(
                    "image {} uses the missing camera {}",
                    image.id, image.camera_id
                ),
            )
        })?;
        let (intrinsics, lens) = camera_lens(camera).map_err(|m| {
            SceneError::file(&cameras_file, format!("{m} (used by image {})", image.name))
        })?;
        if lens.is_some() && undistorted.insert(camera.id) {
            let users = model
                .images
                .values()
                .filter(|i| i.camera_id == camera.id)
                .count();
            warnings.push(format!(
                "camera {} ({}, used by {users} image(s)) was undistorted on load to a PINHOLE camera of the same size",
                camera.id, camera.model
            ));
        }
        let rotation = rotation_from_qvec(image.qvec).ok_or_else(|| {
            SceneError::file(
                &images_file,
                format!(
                    "image {} ({}) has the zero quaternion {:?}; the model is corrupt",
                    image.id, image.name, image.qvec
                ),
            )
        })?;
        let size = |v: u64, what: &str| {
            u32::try_from(v).map_err(|_| {
                SceneError::file(
                    &cameras_file,
                    format!("camera {}: {what} {v} is too large", camera.id),
                )
            })
        };
        views.push(RawView {
            name: image.name.clone(),
            image_path: images_dir.join(&image.name),
            camera: Camera {
                intrinsics,
                rotation,
                translation: DVec3::from_array(image.tvec),
                width: size(camera.width, "width")?,
                height: size(camera.height, "height")?,
            },
            camera_source: format!(
                "{} (image {}, {})",
                images_file.display(),
                image.id,
                image.name
            ),
            depth_range: None,
            sources: None,
            lens,
        });
    }

    // Distinct existing 3D points each view observes.
    let observed: Vec<Vec<u64>> = images
        .iter()
        .zip(&views)
        .map(|(image, view)| {
            let mut ids = BTreeSet::new();
            let mut dangling = 0usize;
            for (_, point_id) in &image.points2d {
                if *point_id < 0 {
                    continue;
                }
                let id = *point_id as u64;
                if model.points.contains_key(&id) {
                    ids.insert(id);
                } else {
                    dangling += 1;
                }
            }
            if dangling > 0 {
                warnings.push(format!(
                    "view {}: {dangling} of its 2D points refer to 3D points missing from the points3D file; they were ignored",
                    view.name
                ));
            }
            ids.into_iter().collect()
        })
        .collect();

    for (i, view) in views.iter_mut().enumerate() {
        let depths: Vec<f64> = observed[i]
            .iter()
            .filter_map(|id| model.points.get(id))
            .map(|p| view.camera.camera_from_world(DVec3::from_array(p.xyz)).z)
            .collect();
        view.depth_range = depth_range_from_depths(depths);
        if view.depth_range.is_none() {
            warnings.push(format!(
                "view {}: {} sparse point(s) in front of it do not give a depth range (it needs at least 2, with positive depths); it will be estimated from camera geometry",
                view.name,
                observed[i].len()
            ));
        }
    }

    let centers: Vec<DVec3> = views.iter().map(|v| v.camera.center()).collect();
    let scores = source_scores(&observed, &centers, &model.points);
    let n = views.len();
    for (i, view) in views.iter_mut().enumerate() {
        let mut list: Vec<(usize, f64)> = (0..n)
            .filter(|&j| j != i)
            .map(|j| (j, scores.get(&(i.min(j), i.max(j))).copied().unwrap_or(0.0)))
            .filter(|&(_, s)| s > 0.0)
            .collect();
        list.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        list.truncate(MAX_COLMAP_SOURCES.min(n.saturating_sub(1)));
        if list.is_empty() {
            warnings.push(format!(
                "view {}: no other view shares sparse points with it at a triangulation angle of at least {MIN_TRIANGULATION_ANGLE_DEG} degree; its source views will be chosen from camera geometry",
                view.name
            ));
            view.sources = None;
        } else {
            view.sources = Some(list);
        }
    }

    let root = images_dir
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| model_dir.to_path_buf());
    Ok(RawScene {
        root,
        format: SceneFormat::Colmap,
        views,
        warnings,
    })
}

/// Index of the `q` quantile in `n` sorted values as the authors' converter takes it
/// (`int(n * q)`), kept inside the slice.
fn quantile_index(n: usize, q: f64) -> usize {
    ((n as f64 * q) as usize).min(n.saturating_sub(1))
}

/// `[0.75 z[floor(0.01 n)], 1.25 z[floor(0.99 n)]]` of the sorted depths; `None` with fewer
/// than 2 depths or a non-positive lower end.
fn depth_range_from_depths(mut depths: Vec<f64>) -> Option<DepthRange> {
    if depths.len() < 2 {
        return None;
    }
    depths.sort_by(f64::total_cmp);
    let n = depths.len();
    let p1 = depths[quantile_index(n, 0.01)];
    let p99 = depths[quantile_index(n, 0.99)];
    if p1 <= 0.0 {
        return None;
    }
    DepthRange::new(p1 * 0.75, p99 * 1.25).ok()
}

/// Score of a view pair from the triangulation angles (degrees) of the points both observe:
/// their number, or 0 when the 75th percentile angle is below 1 degree.
fn pair_score(mut angles: Vec<f64>) -> f64 {
    if angles.is_empty() {
        return 0.0;
    }
    angles.sort_by(f64::total_cmp);
    if angles[quantile_index(angles.len(), 0.75)] < MIN_TRIANGULATION_ANGLE_DEG {
        0.0
    } else {
        angles.len() as f64
    }
}

/// Triangulation angle (degrees) at `point` between the rays to `a` and `b`; 0 when a ray is
/// degenerate.
fn triangulation_angle_deg(point: DVec3, a: DVec3, b: DVec3) -> f64 {
    let (ra, rb) = (a - point, b - point);
    let denom = ra.length() * rb.length();
    if denom <= 0.0 || !denom.is_finite() {
        return 0.0;
    }
    (ra.dot(rb) / denom).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Scores of all view pairs `(i, j)`, `i < j`, that share points (see [`pair_score`]).
fn source_scores(
    observed: &[Vec<u64>],
    centers: &[DVec3],
    points: &BTreeMap<u64, ColmapPoint3D>,
) -> HashMap<(usize, usize), f64> {
    let mut viewers: HashMap<u64, Vec<usize>> = HashMap::new();
    for (view, ids) in observed.iter().enumerate() {
        for id in ids {
            viewers.entry(*id).or_default().push(view);
        }
    }
    let mut angles: HashMap<(usize, usize), Vec<f64>> = HashMap::new();
    for (id, views) in &viewers {
        let Some(point) = points.get(id) else {
            continue;
        };
        let p = DVec3::from_array(point.xyz);
        for (k, &a) in views.iter().enumerate() {
            for &b in &views[k + 1..] {
                let key = (a.min(b), a.max(b));
                let angle = triangulation_angle_deg(p, centers[a], centers[b]);
                angles.entry(key).or_default().push(angle);
            }
        }
    }
    angles
        .into_iter()
        .map(|(key, list)| (key, pair_score(list)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/");

    fn data(sub: &str) -> PathBuf {
        let path = Path::new(DATA).join(sub);
        assert!(
            path.exists(),
            "test data missing: {} (see shared/data/README.md)",
            path.display()
        );
        path
    }

    fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
        assert!(
            (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs())),
            "{what}: {a} vs {b}"
        );
    }

    fn assert_same_scene(a: &RawScene, b: &RawScene, tol: f64) {
        assert_eq!(a.views.len(), b.views.len());
        for (va, vb) in a.views.iter().zip(&b.views) {
            assert_eq!(va.name, vb.name);
            let (ca, cb) = (&va.camera, &vb.camera);
            assert_eq!((ca.width, ca.height), (cb.width, cb.height));
            let ka = [
                ca.intrinsics.fx,
                ca.intrinsics.fy,
                ca.intrinsics.cx,
                ca.intrinsics.cy,
            ];
            let kb = [
                cb.intrinsics.fx,
                cb.intrinsics.fy,
                cb.intrinsics.cx,
                cb.intrinsics.cy,
            ];
            let xa = ka
                .into_iter()
                .chain(ca.rotation.to_cols_array())
                .chain(ca.translation.to_array());
            let xb = kb
                .into_iter()
                .chain(cb.rotation.to_cols_array())
                .chain(cb.translation.to_array());
            for (x, y) in xa.zip(xb) {
                assert_close(x, y, tol, &va.name);
            }
            match (va.depth_range, vb.depth_range) {
                (Some(ra), Some(rb)) => {
                    assert_close(ra.min, rb.min, tol, &va.name);
                    assert_close(ra.max, rb.max, tol, &va.name);
                }
                (ra, rb) => assert_eq!(ra, rb, "{}", va.name),
            }
            assert_eq!(va.sources, vb.sources, "{}", va.name);
        }
    }

    #[test]
    fn fountain_binary_and_text_models_agree() {
        let root = data("fountain-P11");
        let images = root.join("images");
        assert_eq!(find_model(&root), Some(root.join("sparse").join("0")));
        let bin_model = read_model(&root.join("sparse/0")).unwrap();
        let txt_model = read_model(&root.join("sparse_txt")).unwrap();
        assert_eq!(bin_model.images.len(), 11);
        assert_eq!(bin_model.cameras.len(), txt_model.cameras.len());
        assert_eq!(bin_model.points.len(), txt_model.points.len());
        for (a, b) in bin_model.images.values().zip(txt_model.images.values()) {
            assert_eq!((a.id, &a.name, a.camera_id), (b.id, &b.name, b.camera_id));
            assert_eq!(a.points2d.len(), b.points2d.len());
        }

        let bin = read_with(&root.join("sparse/0"), &images).unwrap();
        let txt = read_with(&root.join("sparse_txt"), &images).unwrap();
        assert_eq!(bin.views.len(), 11);
        assert_same_scene(&bin, &txt, 1e-9);
        let names: Vec<&str> = bin.views.iter().map(|v| v.name.as_str()).collect();
        let mut sorted = names.clone();
        sorted.sort();
        assert_eq!(names, sorted);
        for view in &bin.views {
            assert!(view.image_path.is_file(), "{}", view.image_path.display());
            view.camera.validate().unwrap();
            let range = view.depth_range.expect("fountain views see many points");
            // The fountain is a few metres to ~20 m from the cameras.
            assert!(range.min > 0.5 && range.max < 100.0, "{range:?}");
            let sources = view.sources.as_ref().expect("sources from points");
            assert!(!sources.is_empty() && sources.len() <= 10);
            assert!(sources.windows(2).all(|w| w[0].1 >= w[1].1));
        }
        // read() finds sparse/0 and gives the same scene as the binary model.
        let via_root = read(&root).unwrap();
        assert_same_scene(&via_root, &bin, 0.0);
        assert_eq!(via_root.root, root);
    }

    /// Parses an ACMM cam file by hand: `extrinsic` 4x4, `intrinsic` 3x3.
    fn cam_file(path: &Path) -> (DMat3, DVec3, [f64; 4]) {
        let text = std::fs::read_to_string(path).unwrap();
        let tokens: Vec<&str> = text.split_whitespace().collect();
        assert_eq!(tokens[0], "extrinsic");
        assert_eq!(tokens[17], "intrinsic");
        let e: Vec<f64> = tokens[1..17].iter().map(|t| t.parse().unwrap()).collect();
        let k: Vec<f64> = tokens[18..27].iter().map(|t| t.parse().unwrap()).collect();
        let rotation = DMat3::from_cols(
            DVec3::new(e[0], e[4], e[8]),
            DVec3::new(e[1], e[5], e[9]),
            DVec3::new(e[2], e[6], e[10]),
        );
        (
            rotation,
            DVec3::new(e[3], e[7], e[11]),
            [k[0], k[4], k[2], k[5]],
        )
    }

    #[test]
    fn temple_poses_match_the_acmm_cam_files() {
        let root = data("templeSparseRing-colmap");
        let cams = data("templeSparseRing-acmm/cams");
        let scene = read(&root).unwrap();
        assert_eq!(scene.views.len(), 16);
        for (i, view) in scene.views.iter().enumerate() {
            assert_eq!(view.name, format!("{i:08}.png"));
            let (r, t, k) = cam_file(&cams.join(format!("{i:08}_cam.txt")));
            let cam = &view.camera;
            for (a, b) in cam.rotation.to_cols_array().iter().zip(r.to_cols_array()) {
                assert!((a - b).abs() < 1e-6, "view {i}: rotation {a} vs {b}");
            }
            for (a, b) in cam.translation.to_array().iter().zip(t.to_array()) {
                assert!((a - b).abs() < 1e-6, "view {i}: translation {a} vs {b}");
            }
            assert_eq!((cam.width, cam.height), (640, 480));
            assert!((cam.intrinsics.fx - k[0]).abs() < 1e-9);
            assert!((cam.intrinsics.fy - k[1]).abs() < 1e-9);
            // The dataset authors copied the cam file's principal point into cameras.bin
            // unchanged, but COLMAP's pixel centres sit half a pixel off mvscope's (and the cam
            // file's), so ours is the cam file's minus 0.5. (Strictly, the COLMAP model should
            // have been written with cx + 0.5; the data carries that half-pixel error.)
            assert!((cam.intrinsics.cx - (k[2] - 0.5)).abs() < 1e-9);
            assert!((cam.intrinsics.cy - (k[3] - 0.5)).abs() < 1e-9);
        }
        // Views 0 and 10 have the same pose: they share many points, but at a triangulation
        // angle of 0, so neither may be the other's source.
        let model = read_model(&root.join("sparse/0")).unwrap();
        let ids = |name: &str| -> BTreeSet<i64> {
            let image = model.images.values().find(|im| im.name == name).unwrap();
            image
                .points2d
                .iter()
                .map(|p| p.1)
                .filter(|&id| id >= 0)
                .collect()
        };
        let shared = ids("00000000.png")
            .intersection(&ids("00000010.png"))
            .count();
        assert!(
            shared > 0,
            "views 0 and 10 share no points; the test proves nothing"
        );
        for (a, b) in [(0, 10), (10, 0)] {
            if let Some(sources) = &scene.views[a].sources {
                assert!(sources.iter().all(|s| s.0 != b), "view {a} picks {b}");
            }
        }
    }

    /// Three cameras looking down +z at a column of points at depths 1..=100: camera 0 at the
    /// origin, camera 1 10 units to its right, camera 2 at camera 0's centre, turned 5 degrees.
    fn synthetic_model() -> ColmapModel {
        let mut model = ColmapModel::default();
        model.cameras.insert(
            7,
            ColmapCamera {
                id: 7,
                model: CameraModel::Pinhole,
                width: 200,
                height: 100,
                params: vec![100.0, 110.0, 100.0, 50.0],
            },
        );
        let turn = 5f64.to_radians();
        let poses = [
            ([1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
            ([1.0, 0.0, 0.0, 0.0], [-10.0, 0.0, 0.0]),
            (
                [(turn / 2.0).cos(), 0.0, (turn / 2.0).sin(), 0.0],
                [0.0, 0.0, 0.0],
            ),
        ];
        // How many of the points (the nearest first) each image observes.
        let seen = [100usize, 80, 50];
        // Ids not in name order, as in the shared data.
        let ids = [30u32, 20, 10];
        for (k, ((qvec, tvec), count)) in poses.iter().zip(seen).enumerate() {
            let points2d = (0..count)
                .map(|p| ([p as f64, 1.0], p as i64 + 1))
                .chain([([0.0, 0.0], -1)])
                .collect();
            model.images.insert(
                ids[k],
                ColmapImage {
                    id: ids[k],
                    qvec: *qvec,
                    tvec: *tvec,
                    camera_id: 7,
                    name: format!("view{k}.png"),
                    points2d,
                },
            );
        }
        for p in 0..100u64 {
            let track = (0..3)
                .filter(|&k| (p as usize) < seen[k])
                .map(|k| (ids[k], p as u32))
                .collect();
            model.points.insert(
                p + 1,
                ColmapPoint3D {
                    id: p + 1,
                    xyz: [0.01 * p as f64, -0.02 * p as f64, (p + 1) as f64],
                    rgb: [p as u8, 2, 3],
                    error: 0.5,
                    track,
                },
            );
        }
        model
    }

    fn write_scene(model: &ColmapModel, encoding: Encoding) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("images")).unwrap();
        // The files only need to exist: reading a model does not decode them.
        for image in model.images.values() {
            std::fs::write(dir.path().join("images").join(&image.name), b"").unwrap();
        }
        write_model(&dir.path().join("sparse/0"), model, encoding).unwrap();
        dir
    }

    #[test]
    fn round_trip_binary_and_text() {
        let mut model = synthetic_model();
        model.cameras.insert(
            3,
            ColmapCamera {
                id: 3,
                model: CameraModel::FullOpenCv,
                width: 4000,
                height: 3000,
                params: vec![
                    1.0 / 3.0,
                    2.5e-17,
                    1e300,
                    -0.0,
                    1.,
                    2.,
                    3.,
                    4.,
                    5.,
                    6.,
                    7.,
                    8.,
                ],
            },
        );
        model.points.get_mut(&5).unwrap().error = f64::NAN;
        for encoding in [Encoding::Binary, Encoding::Text] {
            let dir = tempfile::tempdir().unwrap();
            write_model(dir.path(), &model, encoding).unwrap();
            assert_eq!(model_encoding(dir.path()), Some(encoding));
            let back = read_model(dir.path()).unwrap();
            // NaN != NaN: compare that field apart.
            assert!(back.points[&5].error.is_nan());
            let mut back = back;
            let mut want = model.clone();
            back.points.get_mut(&5).unwrap().error = 0.0;
            want.points.get_mut(&5).unwrap().error = 0.0;
            assert_eq!(back, want, "{encoding:?}");
        }
    }

    #[test]
    fn quaternions_round_trip() {
        let r = rotation_from_qvec([0.3, -0.5, 0.7, 0.1]).unwrap();
        let q = qvec_from_rotation(r);
        let r2 = rotation_from_qvec(q).unwrap();
        for (a, b) in r.to_cols_array().iter().zip(r2.to_cols_array()) {
            assert!((a - b).abs() < 1e-12);
        }
        assert!(q[0] >= 0.0);
        assert!(rotation_from_qvec([0.0; 4]).is_none());
        // A quarter turn about z maps x to y (Hamilton convention, as COLMAP / Eigen).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let rz = rotation_from_qvec([h, 0.0, 0.0, h]).unwrap();
        assert!((rz * DVec3::X - DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn synthetic_depth_ranges_and_sources() {
        let dir = write_scene(&synthetic_model(), Encoding::Binary);
        let scene = read(dir.path()).unwrap();
        let names: Vec<&str> = scene.views.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["view0.png", "view1.png", "view2.png"]);

        // View 0 sees depths 1..=100: z[floor(1.0)] = 2, z[floor(99.0)] = 100.
        let r0 = scene.views[0].depth_range.unwrap();
        assert_close(r0.min, 2.0 * 0.75, 1e-12, "min 0");
        assert_close(r0.max, 100.0 * 1.25, 1e-12, "max 0");
        // View 1 (translated along x) sees depths 1..=80: z[floor(0.8)] = 1, z[floor(79.2)] = 80.
        let r1 = scene.views[1].depth_range.unwrap();
        assert_close(r1.min, 0.75, 1e-12, "min 1");
        assert_close(r1.max, 100.0, 1e-12, "max 1");
        // View 2 is turned: depths are its camera z, not the world z.
        let cam2 = scene.views[2].camera;
        let mut z: Vec<f64> = (0..50)
            .map(|p| {
                let x = DVec3::new(0.01 * p as f64, -0.02 * p as f64, (p + 1) as f64);
                cam2.camera_from_world(x).z
            })
            .collect();
        z.sort_by(f64::total_cmp);
        let r2 = scene.views[2].depth_range.unwrap();
        assert_close(r2.min, z[0] * 0.75, 1e-12, "min 2");
        assert_close(r2.max, z[49] * 1.25, 1e-12, "max 2");
        assert!((z[49] - 50.0).abs() > 1e-3, "the turn must change depths");

        // Principal point: COLMAP (100, 50) -> mvscope (99.5, 49.5).
        let k = scene.views[0].camera.intrinsics;
        assert_eq!((k.fx, k.fy, k.cx, k.cy), (100.0, 110.0, 99.5, 49.5));

        // Scores = shared points, except views 0 and 2, which share 50 points but have the
        // same centre (every triangulation angle is 0).
        assert_eq!(scene.views[0].sources, Some(vec![(1, 80.0)]));
        assert_eq!(scene.views[1].sources, Some(vec![(0, 80.0), (2, 50.0)]));
        assert_eq!(scene.views[2].sources, Some(vec![(1, 50.0)]));
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    }

    #[test]
    fn the_angle_cut_uses_the_75th_percentile() {
        // 8 angles: index floor(0.75 * 8) = 6 of the sorted list decides.
        let mut angles = vec![0.1; 6];
        angles.extend([2.0, 3.0]);
        assert_eq!(pair_score(angles), 8.0);
        // Seven small ones put a small angle at index 6, whatever the largest is.
        let mut low = vec![0.5; 7];
        low.push(30.0);
        assert_eq!(pair_score(low), 0.0);
        assert_eq!(pair_score(vec![]), 0.0);
        assert_eq!(pair_score(vec![0.99]), 0.0);
        assert_eq!(pair_score(vec![1.0]), 1.0);
        // Angle at the point between the rays to the two centres.
        let a = triangulation_angle_deg(DVec3::ZERO, DVec3::X, DVec3::Y);
        assert_close(a, 90.0, 1e-12, "angle");
        assert_eq!(triangulation_angle_deg(DVec3::X, DVec3::X, DVec3::Y), 0.0);
    }

    #[test]
    fn few_points_give_no_depth_range() {
        assert_eq!(depth_range_from_depths(vec![]), None);
        assert_eq!(depth_range_from_depths(vec![3.0]), None);
        assert_eq!(depth_range_from_depths(vec![-1.0, 3.0, 4.0]), None);
        let r = depth_range_from_depths(vec![4.0, 2.0]).unwrap();
        assert_eq!((r.min, r.max), (1.5, 5.0));

        // An image without points: no depth range, sources from geometry, and a warning.
        let mut model = synthetic_model();
        for (_, id) in &mut model.images.get_mut(&10).unwrap().points2d {
            *id = -1;
        }
        for point in model.points.values_mut() {
            point.track.retain(|t| t.0 != 10);
        }
        let dir = write_scene(&model, Encoding::Text);
        let scene = read(dir.path()).unwrap();
        assert_eq!(scene.views[2].depth_range, None);
        assert_eq!(scene.views[2].sources, None);
        assert_eq!(scene.views[0].sources, Some(vec![(1, 80.0)]));
        assert_eq!(scene.warnings.len(), 2, "{:?}", scene.warnings);
        assert!(scene.warnings.iter().all(|w| w.contains("view2.png")));
    }

    #[test]
    fn truncated_images_bin_is_refused() {
        let dir = write_scene(&synthetic_model(), Encoding::Binary);
        let path = dir.path().join("sparse/0/images.bin");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 10]).unwrap();
        let err = read(dir.path()).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("images.bin"), "{msg}");
        assert!(
            msg.contains("ends inside image 3 of 3; it is truncated"),
            "{msg}"
        );

        // An absurd image count must not allocate or loop forever.
        let mut bad = bytes.clone();
        bad[..8].copy_from_slice(&u64::MAX.to_le_bytes());
        std::fs::write(&path, &bad).unwrap();
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains(&format!("image 4 of {}", u64::MAX)), "{msg}");

        // Nor an absurd 2D point count (the first image's, after id, pose, camera and name).
        let mut bad = bytes.clone();
        let at = 8 + 4 + 56 + 4 + "view2.png".len() + 1;
        bad[at..at + 8].copy_from_slice(&(u64::MAX / 2).to_le_bytes());
        std::fs::write(&path, &bad).unwrap();
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("ends inside image 1 of 3"), "{msg}");

        // Trailing bytes.
        let mut bad = bytes.clone();
        bad.extend([1, 2, 3]);
        std::fs::write(&path, &bad).unwrap();
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("3 bytes follow"), "{msg}");
    }

    #[test]
    fn corrupt_binary_values_are_refused() {
        let dir = write_scene(&synthetic_model(), Encoding::Binary);
        let cameras = dir.path().join("sparse/0/cameras.bin");
        let bytes = std::fs::read(&cameras).unwrap();
        let mut bad = bytes.clone();
        bad[12..16].copy_from_slice(&42i32.to_le_bytes());
        std::fs::write(&cameras, &bad).unwrap();
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("unknown camera model '42'"), "{msg}");
        assert!(msg.contains("cameras.bin"), "{msg}");
        std::fs::write(&cameras, &bytes).unwrap();

        let images = dir.path().join("sparse/0/images.bin");
        let mut bad = std::fs::read(&images).unwrap();
        bad[12..20].copy_from_slice(&f64::NAN.to_le_bytes()); // qw of the first image
        std::fs::write(&images, &bad).unwrap();
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("non-finite pose"), "{msg}");
    }

    #[test]
    fn text_camera_line_with_a_missing_token_names_the_line() {
        let dir = write_scene(&synthetic_model(), Encoding::Text);
        let path = dir.path().join("sparse/0/cameras.txt");
        let text = std::fs::read_to_string(&path).unwrap();
        let line = text
            .lines()
            .position(|l| l.starts_with("7 PINHOLE"))
            .unwrap()
            + 1;
        let broken: Vec<String> = text
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i + 1 == line {
                    l.rsplit_once(' ').unwrap().0.to_string()
                } else {
                    l.to_string()
                }
            })
            .collect();
        std::fs::write(&path, broken.join("\n")).unwrap();
        let err = read(dir.path()).unwrap_err();
        assert_eq!(err.line, Some(line));
        let msg = err.to_string();
        assert!(msg.contains(&format!("cameras.txt:{line}")), "{msg}");
        assert!(
            msg.contains("has 4 parameters (fx, fy, cx, cy), found 3"),
            "{msg}"
        );

        // A non-finite value and an unknown name are refused on their line as well.
        std::fs::write(
            &path,
            text.replace("7 PINHOLE 200 100 100", "7 PINHOLE 200 100 inf"),
        )
        .unwrap();
        let err = read(dir.path()).unwrap_err();
        assert_eq!(err.line, Some(line));
        assert!(err.to_string().contains("not finite"), "{err}");
        std::fs::write(&path, text.replace("PINHOLE", "PINHOLE_X")).unwrap();
        let err = read(dir.path()).unwrap_err();
        assert!(
            err.to_string().contains("unknown camera model 'PINHOLE_X'"),
            "{err}"
        );
    }

    #[test]
    fn text_images_need_their_points_line() {
        let dir = write_scene(&synthetic_model(), Encoding::Text);
        let path = dir.path().join("sparse/0/images.txt");
        let text = std::fs::read_to_string(&path).unwrap();
        // Drop the points line of the first image: the next image line is read as points.
        let mut lines: Vec<&str> = text.lines().collect();
        let first = lines.iter().position(|l| !l.starts_with('#')).unwrap();
        lines.remove(first + 1);
        std::fs::write(&path, lines.join("\n")).unwrap();
        let err = read(dir.path()).unwrap_err();
        assert_eq!(err.line, Some(first + 2));
        assert!(err.to_string().contains("two lines per image"), "{err}");
    }

    #[test]
    fn distorted_cameras_are_undistorted_or_refused() {
        let mut model = synthetic_model();
        model.cameras.insert(
            7,
            ColmapCamera {
                id: 7,
                model: CameraModel::OpenCv,
                width: 200,
                height: 100,
                params: vec![100.0, 110.0, 100.0, 50.0, 0.1, 0.0, 0.0, 0.0],
            },
        );
        // OPENCV with distortion: undistorted on load, and said so.
        let dir = write_scene(&model, Encoding::Binary);
        let scene = read(dir.path()).unwrap();
        let lens = scene.views[0].lens.expect("a lens to undistort");
        assert_eq!(
            (lens.fx, lens.fy, lens.cx, lens.cy),
            (100.0, 110.0, 99.5, 49.5)
        );
        assert_eq!(scene.views[0].camera.intrinsics.cx, 99.5);
        assert!(
            scene
                .warnings
                .iter()
                .any(|w| w.contains("camera 7 (OPENCV") && w.contains("undistorted")),
            "{:?}",
            scene.warnings
        );

        // Zero distortion is a pinhole: nothing to resample.
        model.cameras.get_mut(&7).unwrap().params[4] = 0.0;
        let dir = write_scene(&model, Encoding::Binary);
        let scene = read(dir.path()).unwrap();
        assert!(scene.views[0].lens.is_none());
        // OPENCV_FISHEYE is equidistant even without coefficients: undistorted.
        model.cameras.get_mut(&7).unwrap().model = CameraModel::OpenCvFisheye;
        let dir = write_scene(&model, Encoding::Binary);
        assert!(read(dir.path()).unwrap().views[0].lens.is_some());
        // Other fisheyes are refused with the way out.
        model.cameras.get_mut(&7).unwrap().model = CameraModel::ThinPrismFisheye;
        model.cameras.get_mut(&7).unwrap().params = vec![
            100.0, 110.0, 100.0, 50.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ];
        let dir = write_scene(&model, Encoding::Binary);
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(
            msg.contains("fisheye") && msg.contains("image_undistorter"),
            "{msg}"
        );
        // A distortion that folds the image, and a NaN parameter, name the camera.
        let camera = model.cameras.get_mut(&7).unwrap();
        camera.model = CameraModel::SimpleRadial;
        camera.params = vec![100.0, 100.0, 50.0, -0.9];
        let dir = write_scene(&model, Encoding::Binary);
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("camera 7") && msg.contains("folds"), "{msg}");
        model.cameras.get_mut(&7).unwrap().params[3] = f64::NAN;
        let msg = camera_lens(&model.cameras[&7]).unwrap_err();
        assert!(
            msg.contains("camera 7") && msg.contains("not a number"),
            "{msg}"
        );
        // SIMPLE_PINHOLE has one focal length.
        let camera = model.cameras.get_mut(&7).unwrap();
        camera.model = CameraModel::SimplePinhole;
        camera.params = vec![90.0, 10.5, 20.5];
        let k = pinhole_intrinsics(camera).unwrap();
        assert_eq!((k.fx, k.fy, k.cx, k.cy), (90.0, 90.0, 10.0, 20.0));
    }

    #[test]
    fn dangling_references_are_refused() {
        let mut model = synthetic_model();
        model.images.get_mut(&20).unwrap().camera_id = 99;
        for encoding in [Encoding::Binary, Encoding::Text] {
            let dir = write_scene(&model, encoding);
            let msg = read(dir.path()).unwrap_err().to_string();
            assert!(msg.contains("uses camera 99"), "{msg}");
            assert!(msg.contains("images."), "{msg}");
        }

        let mut model = synthetic_model();
        model.points.get_mut(&3).unwrap().track.push((77, 0));
        for encoding in [Encoding::Binary, Encoding::Text] {
            let dir = write_scene(&model, encoding);
            let msg = read(dir.path()).unwrap_err().to_string();
            assert!(msg.contains("3D point 3 refers to image 77"), "{msg}");
            assert!(msg.contains("points3D."), "{msg}");
        }
    }

    #[test]
    fn missing_folders_are_explained() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(find_model(dir.path()), None);
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("no COLMAP model found"), "{msg}");

        // A dense workspace (sparse/ without 0/) is found; its images/ folder must exist.
        write_model(
            &dir.path().join("sparse"),
            &synthetic_model(),
            Encoding::Text,
        )
        .unwrap();
        assert_eq!(find_model(dir.path()), Some(dir.path().join("sparse")));
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("image folder does not exist"), "{msg}");
        std::fs::create_dir(dir.path().join("images")).unwrap();
        for image in synthetic_model().images.values() {
            std::fs::write(dir.path().join("images").join(&image.name), b"").unwrap();
        }
        assert_eq!(read(dir.path()).unwrap().views.len(), 3);

        std::fs::remove_file(dir.path().join("sparse/points3D.txt")).unwrap();
        let msg = read(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("no points3D.txt"), "{msg}");
    }
}
