//! Middlebury multi-view: a `NAME_par.txt` beside the images. Its first line is the image
//! count; then one line per image: `imgname k11 k12 k13 k21 k22 k23 k31 k32 k33 r11 r12 r13 r21
//! r22 r23 r31 r32 r33 t1 t2 t3`, with `P = K [R | t]` (`camera_from_world`). It carries no depth
//! ranges or source views: `RawScene::finish` derives them from camera geometry.

use std::path::{Path, PathBuf};

use glam::{DMat3, DVec3};

use super::text::{TextFile, parse_token};
use super::{RawScene, RawView, SceneFormat};
use crate::camera::{Camera, Intrinsics};
use crate::error::SceneError;
use crate::image::Image;

/// The `*_par.txt` of a folder (or the file itself).
fn find_par(path: &Path) -> Result<PathBuf, SceneError> {
    if crate::vfs::is_file(path) {
        return Ok(path.to_path_buf());
    }
    let mut found: Vec<PathBuf> = crate::vfs::read_dir(path)
        .map_err(|e| SceneError::io(path, e))?
        .into_iter()
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.ends_with("_par.txt"))
        })
        .collect();
    found.sort();
    match found.len() {
        0 => Err(SceneError::file(
            path,
            "no *_par.txt file here; a Middlebury scene has NAME_par.txt beside its images",
        )),
        1 => Ok(found.remove(0)),
        _ => Err(SceneError::file(
            path,
            format!(
                "{} *_par.txt files here; give the one to use as the scene path",
                found.len()
            ),
        )),
    }
}

pub fn read(path: &Path) -> Result<RawScene, SceneError> {
    let par = find_par(path)?;
    let dir = par.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mut f = TextFile::open(&par)?;
    let n: usize = f.next("the number of images")?;
    let mut views = Vec::with_capacity(n.min(10_000));
    for i in 0..n {
        let Some((line, tokens)) = f.next_line() else {
            return Err(SceneError::line(
                &par,
                f.line(),
                format!("the file ends after {i} of the {n} images its first line announces"),
            ));
        };
        if tokens.len() != 22 {
            return Err(SceneError::line(
                &par,
                line,
                format!(
                    "expected 22 values (image name, K row-major, R row-major, t), found {}",
                    tokens.len()
                ),
            ));
        }
        let v = tokens[1..]
            .iter()
            .map(|t| parse_token::<f64>(&par, line, t, "a camera value"))
            .collect::<Result<Vec<f64>, _>>()?;
        let name = tokens[0].to_string();
        let image_path = dir.join(&name);
        if !crate::vfs::is_file(&image_path) {
            return Err(SceneError::line(
                &par,
                line,
                format!("image {} is missing", image_path.display()),
            ));
        }
        let (width, height) = Image::dimensions(&image_path)?;
        let rotation = DMat3::from_cols(
            DVec3::new(v[9], v[12], v[15]),
            DVec3::new(v[10], v[13], v[16]),
            DVec3::new(v[11], v[14], v[17]),
        );
        views.push(RawView {
            name: Path::new(&name)
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or(&name)
                .to_string(),
            image_path,
            camera: Camera {
                intrinsics: Intrinsics {
                    fx: v[0],
                    fy: v[4],
                    cx: v[2],
                    cy: v[5],
                },
                rotation,
                translation: DVec3::new(v[18], v[19], v[20]),
                width,
                height,
            },
            camera_source: format!("{}:{line}", par.display()),
            depth_range: None,
            sources: None,
            lens: None,
        });
    }
    if !f.at_end() {
        let line = f.line();
        return Err(f.error(
            line,
            format!("more lines than the {n} images the first line announces"),
        ));
    }
    Ok(RawScene {
        root: dir,
        format: SceneFormat::Middlebury,
        views,
        warnings: Vec::new(),
    })
}
