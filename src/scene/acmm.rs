//! ACMM / MVSNet folders: `images/%08d.{jpg,png}`, `cams/%08d_cam.txt`, `pair.txt`.
//!
//! A cam file holds `extrinsic` (4x4 `camera_from_world`, last row ignored), `intrinsic` (3x3
//! `K`, skew ignored) and a depth line: `min interval count max` (ACMM), `min interval` (MVSNet,
//! 192 planes implied) or `min interval count`. pair.txt holds the view count, then per view its
//! id, its number of sources and `id score` pairs. Views are those pair.txt lists, in its order.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DMat3, DVec3};

use super::text::{TextFile, parse_token};
use super::{DepthRange, RawScene, RawView, Scene, SceneFormat};
use crate::camera::{Camera, Intrinsics};
use crate::error::SceneError;
use crate::image::Image;
use crate::io::{IoError, write_atomic};

/// Planes an MVSNet cam file implies when its depth line has two numbers.
const MVSNET_PLANES: f64 = 192.0;

/// A parsed cam file.
#[derive(Clone, Debug)]
pub struct CamFile {
    pub rotation: DMat3,
    pub translation: DVec3,
    pub intrinsics: Intrinsics,
    pub depth_range: Option<DepthRange>,
}

/// Reads one `%08d_cam.txt`.
pub fn read_cam(path: &Path) -> Result<CamFile, SceneError> {
    let mut f = TextFile::open(path)?;
    f.expect_keyword("extrinsic")?;
    let mut e = [0.0f64; 16];
    for (i, v) in e.iter_mut().enumerate() {
        *v = f.next(&format!("extrinsic[{}][{}]", i / 4, i % 4))?;
    }
    f.expect_keyword("intrinsic")?;
    let mut k = [0.0f64; 9];
    let mut k_end = 0; // line of K's last value
    for (i, v) in k.iter_mut().enumerate() {
        k_end = f.line();
        *v = f.next(&format!("intrinsic[{}][{}]", i / 3, i % 3))?;
    }
    // The depth line is read line-wise: if K's last value shares a line with more values, K
    // has a value too few or too many and would silently swallow part of the depth line.
    if !f.at_end() && f.line() == k_end {
        return Err(SceneError::line(
            path,
            k_end,
            "the intrinsic matrix's 9 values end in the middle of this line: K has a value missing or one too many (it must be 3 rows of 3), or the depth range is not on a line of its own",
        ));
    }
    let rotation = DMat3::from_cols(
        DVec3::new(e[0], e[4], e[8]),
        DVec3::new(e[1], e[5], e[9]),
        DVec3::new(e[2], e[6], e[10]),
    );
    let translation = DVec3::new(e[3], e[7], e[11]);
    let intrinsics = Intrinsics {
        fx: k[0],
        fy: k[4],
        cx: k[2],
        cy: k[5],
    };
    let depth_range = match f.next_line() {
        None => None,
        Some((line, tokens)) => {
            let values = tokens
                .iter()
                .map(|t| parse_token::<f64>(path, line, t, "a depth value"))
                .collect::<Result<Vec<_>, _>>()?;
            let (min, max) = match values.as_slice() {
                [min, _interval, _count, max] => (*min, *max),
                [min, interval, count] => (*min, min + interval * (count - 1.0)),
                [min, interval] => (*min, min + interval * (MVSNET_PLANES - 1.0)),
                _ => {
                    return Err(SceneError::line(
                        path,
                        line,
                        format!(
                            "the depth line has {} values; expected 'min interval count max' (ACMM) or 'min interval' (MVSNet)",
                            values.len()
                        ),
                    ));
                }
            };
            Some(DepthRange::new(min, max).map_err(|m| SceneError::line(path, line, m))?)
        }
    };
    if !f.at_end() {
        let line = f.line();
        return Err(SceneError::line(
            path,
            line,
            "unexpected values after the depth line",
        ));
    }
    Ok(CamFile {
        rotation,
        translation,
        intrinsics,
        depth_range,
    })
}

/// One pair.txt entry: a reference id and its (source id, score) list, with line numbers.
#[derive(Clone, Debug)]
pub struct PairEntry {
    pub id: u32,
    /// Line of the reference id.
    pub line: usize,
    /// `(source id, score, line of the source id)`.
    pub sources: Vec<(u32, f64, usize)>,
}

/// Reads pair.txt.
pub fn read_pair(path: &Path) -> Result<Vec<PairEntry>, SceneError> {
    let mut f = TextFile::open(path)?;
    let n: usize = f.next("the number of views")?;
    let mut entries = Vec::with_capacity(n.min(100_000));
    for _ in 0..n {
        let line = f.line();
        let id: u32 = f.next("a view id")?;
        let count: usize = f.next("the number of source views")?;
        let mut sources = Vec::with_capacity(count.min(10_000));
        for _ in 0..count {
            let src_line = f.line();
            let src: u32 = f.next("a source view id")?;
            let score: f64 = f.next("a source view score")?;
            sources.push((src, score, src_line));
        }
        entries.push(PairEntry { id, line, sources });
    }
    if !f.at_end() {
        let line = f.line();
        return Err(f.error(
            line,
            format!("unexpected values after the {n} views the first line announces"),
        ));
    }
    Ok(entries)
}

fn find_image(images: &Path, id: u32) -> Option<PathBuf> {
    ["jpg", "png", "jpeg", "JPG", "PNG"]
        .iter()
        .map(|ext| images.join(format!("{id:08}.{ext}")))
        .find(|p| crate::vfs::is_file(p))
}

/// Reads an ACMM / MVSNet folder.
pub fn read(root: &Path) -> Result<RawScene, SceneError> {
    let images = root.join("images");
    let cams = root.join("cams");
    let pair_path = root.join("pair.txt");
    for dir in [&images, &cams] {
        if !crate::vfs::is_dir(dir) {
            return Err(SceneError::file(
                dir,
                "the folder is missing; an ACMM/MVSNet scene has images/, cams/ and pair.txt",
            ));
        }
    }
    let entries = read_pair(&pair_path)?;
    let mut index_of: HashMap<u32, usize> = HashMap::new();
    for (i, e) in entries.iter().enumerate() {
        if index_of.insert(e.id, i).is_some() {
            return Err(SceneError::line(
                &pair_path,
                e.line,
                format!("view {} is listed twice; remove the duplicate", e.id),
            ));
        }
    }
    let mut views = Vec::with_capacity(entries.len());
    for e in &entries {
        let cam_path = cams.join(format!("{:08}_cam.txt", e.id));
        if !crate::vfs::is_file(&cam_path) {
            return Err(SceneError::line(
                &pair_path,
                e.line,
                format!(
                    "view {} has no camera file {}; add it or remove the view from pair.txt",
                    e.id,
                    cam_path.display()
                ),
            ));
        }
        let image_path = find_image(&images, e.id).ok_or_else(|| {
            SceneError::line(
                &pair_path,
                e.line,
                format!(
                    "view {} has no image {}/{:08}.jpg or .png; add it or remove the view from pair.txt",
                    e.id,
                    images.display(),
                    e.id
                ),
            )
        })?;
        let mut sources = Vec::with_capacity(e.sources.len());
        for &(src, score, src_line) in &e.sources {
            if src == e.id {
                return Err(SceneError::line(
                    &pair_path,
                    src_line,
                    format!("view {} names itself as a source; remove it", e.id),
                ));
            }
            let index = *index_of.get(&src).ok_or_else(|| {
                SceneError::line(
                    &pair_path,
                    src_line,
                    format!(
                        "view {} names source view {src}, which pair.txt does not list as a view",
                        e.id
                    ),
                )
            })?;
            sources.push((index, score));
        }
        let cam = read_cam(&cam_path)?;
        let (width, height) = Image::dimensions(&image_path)?;
        views.push(RawView {
            name: format!("{:08}", e.id),
            image_path,
            camera: Camera {
                intrinsics: cam.intrinsics,
                rotation: cam.rotation,
                translation: cam.translation,
                width,
                height,
            },
            camera_source: cam_path.display().to_string(),
            depth_range: cam.depth_range,
            sources: Some(sources),
            lens: None,
        });
    }
    Ok(RawScene {
        root: root.to_path_buf(),
        format: SceneFormat::Acmm,
        views,
        warnings: Vec::new(),
    })
}

/// Writes a cam file in the ACMM layout (4-value depth line, `count` planes).
pub fn write_cam(path: &Path, camera: &Camera, range: DepthRange) -> Result<(), IoError> {
    let mut out = String::from("extrinsic\n");
    let r = camera.rotation;
    let t = camera.translation;
    for row in 0..3 {
        let rr = r.row(row);
        out += &format!("{:.10} {:.10} {:.10} {:.10}\n", rr.x, rr.y, rr.z, t[row]);
    }
    out += "0.0 0.0 0.0 1.0\n\nintrinsic\n";
    let k = &camera.intrinsics;
    out += &format!(
        "{:.10} 0.0 {:.10}\n0.0 {:.10} {:.10}\n0.0 0.0 1.0\n\n",
        k.fx, k.cx, k.fy, k.cy
    );
    let count = MVSNET_PLANES;
    let interval = (range.max - range.min) / (count - 1.0);
    out += &format!("{} {} {} {}\n", range.min, interval, count, range.max);
    write_atomic(path, |w| std::io::Write::write_all(w, out.as_bytes()))
}

/// Writes a scene as an ACMM folder (`images/%08d.png`, `cams/`, `pair.txt`) with views
/// numbered in scene order.
pub fn write_scene(scene: &Scene, dir: &Path) -> Result<(), IoError> {
    write_scene_with(scene, dir, &mut |i, path| {
        scene.views[i].image.save_png(path)
    })
}

/// [`write_scene`] with each view's image written by `image(view, path)`: a scene loaded
/// without its pixels can decode one view at a time (12 Mpx views need not all be held).
pub fn write_scene_with(
    scene: &Scene,
    dir: &Path,
    image: &mut dyn FnMut(usize, &Path) -> Result<(), IoError>,
) -> Result<(), IoError> {
    for sub in ["images", "cams"] {
        let path = dir.join(sub);
        std::fs::create_dir_all(&path).map_err(|e| IoError::io(&path, "create the folder", e))?;
    }
    let mut pair = format!("{}\n", scene.views.len());
    for (i, view) in scene.views.iter().enumerate() {
        image(i, &dir.join(format!("images/{i:08}.png")))?;
        write_cam(
            &dir.join(format!("cams/{i:08}_cam.txt")),
            &view.camera,
            view.depth_range,
        )?;
        pair += &format!("{i}\n{}", view.sources.len());
        for s in &view.sources {
            pair += &format!(" {} {:.4}", s.index, s.score);
        }
        pair += "\n";
    }
    write_atomic(&dir.join("pair.txt"), |w| {
        std::io::Write::write_all(w, pair.as_bytes())
    })
}
