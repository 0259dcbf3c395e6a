//! Strecha et al.'s format: each image `NAME.png` has a `NAME.png.camera` beside it holding
//! `K` (3 rows), the radial distortion (one row), `R` (3 rows, `world_from_camera` rotation:
//! its columns are the camera axes in the world), the camera centre `t`, and `width height`.
//! The projection is `P = K [R^T | -R^T t]`. No depth ranges or source views: they come from
//! camera geometry in `RawScene::finish`.

use std::path::{Path, PathBuf};

use glam::{DMat3, DVec3};

use super::text::TextFile;
use super::{RawScene, RawView, SceneFormat, list_images};
use crate::camera::{Camera, Intrinsics};
use crate::error::SceneError;

fn read_camera(path: &Path) -> Result<Camera, SceneError> {
    let mut f = TextFile::open(path)?;
    let mut k = [0.0f64; 9];
    for (i, v) in k.iter_mut().enumerate() {
        *v = f.next(&format!("K[{}][{}]", i / 3, i % 3))?;
    }
    let line = f.line();
    let mut distortion = [0.0f64; 3];
    for v in &mut distortion {
        *v = f.next("a distortion coefficient")?;
    }
    if distortion.iter().any(|&d| d != 0.0) {
        return Err(SceneError::line(
            path,
            line,
            format!(
                "the camera has lens distortion {distortion:?}; mvscope needs undistorted images (undistort them, e.g. with COLMAP's image_undistorter, and set the distortion to 0 0 0)"
            ),
        ));
    }
    let mut r = [0.0f64; 9];
    for (i, v) in r.iter_mut().enumerate() {
        *v = f.next(&format!("R[{}][{}]", i / 3, i % 3))?;
    }
    let mut c = [0.0f64; 3];
    for v in &mut c {
        *v = f.next("the camera centre")?;
    }
    let width: u32 = f.next("the image width")?;
    let height: u32 = f.next("the image height")?;
    if !f.at_end() {
        let line = f.line();
        return Err(f.error(line, "unexpected values after the image size"));
    }
    // r is the row-major world_from_camera rotation R; camera_from_world is R^T.
    let world_from_camera = DMat3::from_cols(
        DVec3::new(r[0], r[3], r[6]),
        DVec3::new(r[1], r[4], r[7]),
        DVec3::new(r[2], r[5], r[8]),
    );
    let rotation = world_from_camera.transpose();
    let center = DVec3::from_array(c);
    Ok(Camera {
        intrinsics: Intrinsics {
            fx: k[0],
            fy: k[4],
            cx: k[2],
            cy: k[5],
        },
        rotation,
        translation: -(rotation * center),
        width,
        height,
    })
}

pub fn read(root: &Path) -> Result<RawScene, SceneError> {
    let mut views = Vec::new();
    for image_path in list_images(root)? {
        let Some(file_name) = image_path.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        let camera_path = root.join(format!("{file_name}.camera"));
        if !crate::vfs::is_file(&camera_path) {
            continue; // images without a camera are not part of the scene
        }
        let camera = read_camera(&camera_path)?;
        views.push(RawView {
            name: image_path
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or(file_name)
                .to_string(),
            image_path,
            camera,
            camera_source: camera_path.display().to_string(),
            depth_range: None,
            sources: None,
            lens: None,
        });
    }
    // A camera whose image is missing would otherwise drop its view without a word.
    let mut orphans: Vec<PathBuf> = crate::vfs::read_dir(root)
        .map_err(|e| SceneError::io(root, e))?
        .into_iter()
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_suffix(".camera"))
                .is_some_and(|image| !crate::vfs::is_file(&root.join(image)))
        })
        .collect();
    orphans.sort();
    let warnings = orphans
        .iter()
        .map(|p| {
            format!(
                "{}: its image is missing, so this view is left out of the scene",
                p.display()
            )
        })
        .collect();
    Ok(RawScene {
        root: root.to_path_buf(),
        format: SceneFormat::Strecha,
        views,
        warnings,
    })
}

/// Writes a Strecha `.camera` file (tests and conversions).
pub fn write_camera(path: &Path, camera: &Camera) -> std::io::Result<()> {
    let k = &camera.intrinsics;
    let r = camera.rotation.transpose(); // world_from_camera, written row-major
    let c = camera.center();
    let text = format!(
        "{} 0 {}\n0 {} {}\n0 0 1\n0 0 0\n{} {} {}\n{} {} {}\n{} {} {}\n{} {} {}\n{} {}\n",
        k.fx,
        k.cx,
        k.fy,
        k.cy,
        r.row(0).x,
        r.row(0).y,
        r.row(0).z,
        r.row(1).x,
        r.row(1).y,
        r.row(1).z,
        r.row(2).x,
        r.row(2).y,
        r.row(2).z,
        c.x,
        c.y,
        c.z,
        camera.width,
        camera.height
    );
    std::fs::write(path, text)
}
