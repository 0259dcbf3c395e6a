//! Helpers for the integration tests: the shared real-data folder, small scenes written into
//! temporary folders, checks on errors and cameras, and ground truth laid out as the passes
//! read it. Each test crate uses a part of them.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use glam::DVec3;
use mvscope::camera::{Camera, Intrinsics};
use mvscope::image::Image;
use mvscope::scene::{LoadOptions, Scene, SceneError, SceneFormat};

/// The shared real scenes (`/work/shared/data`, see its README.md). Panics when missing: a test
/// that needs them must not pass without them.
pub fn shared_data() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    assert!(
        dir.is_dir(),
        "the shared test data folder is missing: {}",
        dir.display()
    );
    dir
}

/// A file or folder of the shared data; panics with its path when it is missing.
pub fn shared(relative: &str) -> PathBuf {
    let path = shared_data().join(relative);
    assert!(
        path.exists(),
        "shared test data is missing: {}",
        path.display()
    );
    path
}

pub fn options(format: Option<SceneFormat>, max_image_size: Option<u32>) -> LoadOptions {
    LoadOptions {
        format,
        max_image_size,
        ..LoadOptions::default()
    }
}

pub fn load_acmm(dir: &Path) -> Result<Scene, SceneError> {
    Scene::load(dir, &options(Some(SceneFormat::Acmm), None))
}

/// The error of a load that must fail.
#[track_caller]
pub fn expect_error(result: Result<Scene, SceneError>, what: &str) -> SceneError {
    match result {
        Ok(scene) => panic!(
            "{what}: the load succeeded with {} views; expected an error",
            scene.views.len()
        ),
        Err(e) => e,
    }
}

/// Checks that an error names `file` (and `line` when given, in both the message and
/// `err.line`) and contains `phrase`.
#[track_caller]
pub fn assert_error(err: &SceneError, file: &Path, line: Option<usize>, phrase: &str) {
    let text = err.to_string();
    let file_text = file.display().to_string();
    assert!(
        text.contains(&file_text),
        "the error does not name {file_text}: {text}"
    );
    if let Some(line) = line {
        assert_eq!(err.line, Some(line), "wrong line in: {text}");
        assert_eq!(err.path.as_deref(), Some(file), "wrong path in: {text}");
        assert!(
            text.contains(&format!("{file_text}:{line}")),
            "the message does not say {file_text}:{line}: {text}"
        );
    }
    assert!(
        text.contains(phrase),
        "the error does not say '{phrase}': {text}"
    );
}

/// `|a - b| <= tol * max(1, |a|)` for every parameter, and equal sizes.
#[track_caller]
pub fn assert_same_camera(a: &Camera, b: &Camera, tol: f64, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}: size");
    let ka = a.intrinsics;
    let kb = b.intrinsics;
    let pairs = [
        ("fx", ka.fx, kb.fx),
        ("fy", ka.fy, kb.fy),
        ("cx", ka.cx, kb.cx),
        ("cy", ka.cy, kb.cy),
    ]
    .into_iter()
    .chain(
        a.rotation
            .to_cols_array()
            .into_iter()
            .zip(b.rotation.to_cols_array())
            .map(|(x, y)| ("R", x, y)),
    )
    .chain(
        a.translation
            .to_array()
            .into_iter()
            .zip(b.translation.to_array())
            .map(|(x, y)| ("t", x, y)),
    );
    for (name, x, y) in pairs {
        assert!(
            (x - y).abs() <= tol * x.abs().max(1.0),
            "{what}: {name} differs: {x} vs {y}"
        );
    }
}

/// Camera `i` of `n` on a ring of radius 2 around the origin, looking at it.
pub fn ring_camera(i: usize, n: usize, width: u32, height: u32) -> Camera {
    let a = i as f64 / n as f64 * std::f64::consts::TAU;
    Camera::look_at(
        Intrinsics {
            fx: width as f64 * 1.25,
            fy: width as f64 * 1.25,
            cx: (width as f64 - 1.0) / 2.0,
            cy: (height as f64 - 1.0) / 2.0,
        },
        width,
        height,
        DVec3::new(2.0 * a.cos(), -0.3, 2.0 * a.sin()),
        DVec3::ZERO,
        DVec3::new(0.0, -1.0, 0.0),
    )
}

/// A small patterned image, different for each `seed`.
pub fn pattern_image(width: u32, height: u32, seed: usize) -> Image {
    let rgb = (0..height)
        .flat_map(|y| {
            (0..width).map(move |x| {
                let v = (x * 37 + y * 91 + seed as u32 * 53) % 256;
                [v as u8, (x * 13 % 256) as u8, (y * 29 % 256) as u8]
            })
        })
        .collect();
    Image::from_rgb(width, height, rgb)
}

/// Line of a cam file written by [`cam_text`] that holds the depth range.
pub const DEPTH_LINE: usize = 12;
/// Line of a cam file written by [`cam_text`] that holds the third row of `K`.
pub const K_ROW3_LINE: usize = 10;

/// A cam file in the MVSNet layout with the given depth line (line [`DEPTH_LINE`]).
pub fn cam_text(camera: &Camera, depth_line: &str) -> String {
    let r = camera.rotation;
    let t = camera.translation;
    let k = camera.intrinsics;
    let mut text = String::from("extrinsic\n");
    for row in 0..3 {
        let rr = r.row(row);
        text += &format!("{} {} {} {}\n", rr.x, rr.y, rr.z, t[row]);
    }
    text += "0 0 0 1\n\nintrinsic\n";
    text += &format!("{} 0 {}\n0 {} {}\n0 0 1\n\n", k.fx, k.cx, k.fy, k.cy);
    text += depth_line;
    text += "\n";
    text
}

/// `pair.txt` text: per entry, the id on one line and `count (id score)*` on the next, so entry
/// `k` starts on line `2 + 2k` and its sources are on line `3 + 2k`.
pub fn pair_text(entries: &[(u32, Vec<(u32, f64)>)]) -> String {
    let mut text = format!("{}\n", entries.len());
    for (id, sources) in entries {
        text += &format!("{id}\n{}", sources.len());
        for (src, score) in sources {
            text += &format!(" {src} {score}");
        }
        text += "\n";
    }
    text
}

/// Replaces line `line` (1-based) of a text file.
pub fn replace_line(path: &Path, line: usize, new: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    assert!(
        line >= 1 && line <= lines.len(),
        "{} has no line {line}",
        path.display()
    );
    lines[line - 1] = new;
    std::fs::write(path, lines.join("\n") + "\n").unwrap();
}

/// A valid ACMM folder of `n` ring views with `width x height` images, depth range [1, 3]
/// and, per view, its two ring neighbours as sources.
pub fn tiny_acmm(n: usize, width: u32, height: u32) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::create_dir_all(root.join("images")).unwrap();
    std::fs::create_dir_all(root.join("cams")).unwrap();
    let mut entries = Vec::new();
    for i in 0..n {
        let camera = ring_camera(i, n, width, height);
        pattern_image(width, height, i)
            .save_png(&root.join(format!("images/{i:08}.png")))
            .unwrap();
        std::fs::write(
            root.join(format!("cams/{i:08}_cam.txt")),
            cam_text(&camera, "1 0.0104712 192 3"),
        )
        .unwrap();
        let mut sources = vec![((i + 1) % n) as u32, ((i + n - 1) % n) as u32];
        sources.dedup();
        sources.retain(|&s| s as usize != i);
        let scored = sources
            .into_iter()
            .enumerate()
            .map(|(k, s)| (s, 0.9 - 0.1 * k as f64))
            .collect();
        entries.push((i as u32, scored));
    }
    std::fs::write(root.join("pair.txt"), pair_text(&entries)).unwrap();
    dir
}

pub fn cam_path(root: &Path, id: u32) -> PathBuf {
    root.join(format!("cams/{id:08}_cam.txt"))
}

pub fn image_path(root: &Path, id: u32) -> PathBuf {
    root.join(format!("images/{id:08}.png"))
}

/// One line of a Middlebury `*_par.txt`: name, K, R (row-major), t.
pub fn middlebury_line(name: &str, camera: &Camera) -> String {
    let k = camera.intrinsics;
    let mut values = vec![k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0];
    for row in 0..3 {
        values.extend(camera.rotation.row(row).to_array());
    }
    values.extend(camera.translation.to_array());
    let numbers: Vec<String> = values.iter().map(|v| v.to_string()).collect();
    format!("{name} {}", numbers.join(" "))
}

/// A valid Middlebury folder of `n` ring views with 16x16 images `s%04d.png` (0-based) and
/// `s_par.txt`, whose line `2 + i` describes view `i`.
pub fn tiny_middlebury(n: usize) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut text = format!("{n}\n");
    for i in 0..n {
        let name = format!("s{i:04}.png");
        pattern_image(16, 16, i)
            .save_png(&dir.path().join(&name))
            .unwrap();
        text += &middlebury_line(&name, &ring_camera(i, n, 16, 16));
        text += "\n";
    }
    std::fs::write(dir.path().join("s_par.txt"), text).unwrap();
    dir
}

/// Whether the current user can read `path` (root reads files whatever their mode).
pub fn readable(path: &Path) -> bool {
    std::fs::read(path).is_ok()
}

/// The true depths of a problem's sources, laid out like its images: the depth snapshot a
/// geometric pass (and the support points' multi-view check) reads, from the ground truth.
pub fn source_truth_depths(
    s: &mvscope::synthetic::SyntheticScene,
    problem: &mvscope::acmm::ViewProblem,
) -> Vec<f32> {
    let mut depths = vec![0.0; problem.images.len()];
    for (j, &src) in problem.source_views.iter().enumerate() {
        let offset = problem.sources[j].size[2] as usize;
        let d = &s.ground_truth[src].depth;
        depths[offset..offset + d.len()].copy_from_slice(d);
    }
    depths
}
