//! COLMAP's text model files (cameras.txt, images.txt, points3D.txt): reading, with errors
//! naming the file and line, and writing.

use super::*;

/// The data lines of a COLMAP text file: 1-based number and trimmed content; comments (`#`)
/// and blank lines are skipped by [`DataLines::next_data`].
pub(super) struct DataLines<'a> {
    pub(super) lines: std::iter::Enumerate<std::str::Lines<'a>>,
}

impl<'a> DataLines<'a> {
    fn new(text: &'a str) -> DataLines<'a> {
        DataLines {
            lines: text.lines().enumerate(),
        }
    }

    fn next_data(&mut self) -> Option<(usize, &'a str)> {
        for (i, line) in self.lines.by_ref() {
            let line = line.trim();
            if !line.is_empty() && !line.starts_with('#') {
                return Some((i + 1, line));
            }
        }
        None
    }

    /// The next line whatever it holds (images.txt's second line per image may be empty).
    fn next_raw(&mut self) -> Option<(usize, &'a str)> {
        self.lines.next().map(|(i, line)| (i + 1, line.trim()))
    }
}

pub(super) fn read_text(path: &Path) -> Result<String, SceneError> {
    let bytes = read_file(path)?;
    String::from_utf8(bytes)
        .map_err(|_| SceneError::file(path, "the file is not UTF-8 text; is this the right file?"))
}

pub(super) fn read_cameras_txt(path: &Path) -> Result<BTreeMap<u32, ColmapCamera>, SceneError> {
    let text = read_text(path)?;
    let mut lines = DataLines::new(&text);
    let mut cameras = BTreeMap::new();
    while let Some((line, content)) = lines.next_data() {
        let tokens: Vec<&str> = content.split_whitespace().collect();
        if tokens.len() < 4 {
            return Err(SceneError::line(
                path,
                line,
                format!(
                    "a camera line needs CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], found {} value(s)",
                    tokens.len()
                ),
            ));
        }
        let id: u32 = parse_token(path, line, tokens[0], "CAMERA_ID")?;
        let model = CameraModel::from_name(tokens[1])
            .ok_or_else(|| SceneError::line(path, line, unknown_model(id, tokens[1])))?;
        let width: u64 = parse_token(path, line, tokens[2], "WIDTH")?;
        let height: u64 = parse_token(path, line, tokens[3], "HEIGHT")?;
        let params_tokens = &tokens[4..];
        if params_tokens.len() != model.num_params() {
            return Err(SceneError::line(
                path,
                line,
                format!(
                    "camera {id}: a {model} camera has {} parameters ({}), found {}",
                    model.num_params(),
                    model.param_names().join(", "),
                    params_tokens.len()
                ),
            ));
        }
        let params = params_tokens
            .iter()
            .zip(model.param_names())
            .map(|(tok, what)| parse_token::<f64>(path, line, tok, what))
            .collect::<Result<Vec<f64>, SceneError>>()?;
        let camera = ColmapCamera {
            id,
            model,
            width,
            height,
            params,
        };
        if cameras.insert(id, camera).is_some() {
            return Err(SceneError::line(path, line, duplicate("camera", id)));
        }
    }
    Ok(cameras)
}

pub(super) fn read_images_txt(
    path: &Path,
    cameras: &BTreeMap<u32, ColmapCamera>,
) -> Result<BTreeMap<u32, ColmapImage>, SceneError> {
    const POSE: [&str; 7] = ["QW", "QX", "QY", "QZ", "TX", "TY", "TZ"];
    let text = read_text(path)?;
    let mut lines = DataLines::new(&text);
    let mut images = BTreeMap::new();
    while let Some((line, content)) = lines.next_data() {
        let tokens: Vec<&str> = content.split_whitespace().collect();
        if tokens.len() < 10 {
            return Err(SceneError::line(
                path,
                line,
                format!(
                    "an image line needs IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, found {} value(s) (images.txt has two lines per image: this one, then the 2D points, which may be empty)",
                    tokens.len()
                ),
            ));
        }
        let id: u32 = parse_token(path, line, tokens[0], "IMAGE_ID")?;
        let mut pose = [0.0; 7];
        for (k, v) in pose.iter_mut().enumerate() {
            *v = parse_token(path, line, tokens[1 + k], POSE[k])?;
        }
        let camera_id: u32 = parse_token(path, line, tokens[8], "CAMERA_ID")?;
        // COLMAP's own reader takes one token; a name with spaces is kept whole here.
        let name = tokens[9..].join(" ");
        let mut points2d = Vec::new();
        if let Some((pline, pcontent)) = lines.next_raw() {
            let ptokens: Vec<&str> = pcontent.split_whitespace().collect();
            if !ptokens.len().is_multiple_of(3) {
                return Err(SceneError::line(
                    path,
                    pline,
                    format!(
                        "the 2D points of image {id} must be X Y POINT3D_ID triples, found {} value(s) (images.txt has two lines per image; the second may be empty but must be there)",
                        ptokens.len()
                    ),
                ));
            }
            points2d.reserve(ptokens.len() / 3);
            for triple in ptokens.chunks_exact(3) {
                let x: f64 = parse_token(path, pline, triple[0], "X")?;
                let y: f64 = parse_token(path, pline, triple[1], "Y")?;
                let point_id: i64 = parse_token(path, pline, triple[2], "POINT3D_ID")?;
                points2d.push(([x, y], point_id));
            }
        }
        let image = ColmapImage {
            id,
            qvec: [pose[0], pose[1], pose[2], pose[3]],
            tvec: [pose[4], pose[5], pose[6]],
            camera_id,
            name,
            points2d,
        };
        check_image(&image, cameras).map_err(|m| SceneError::line(path, line, m))?;
        if images.insert(id, image).is_some() {
            return Err(SceneError::line(path, line, duplicate("image", id)));
        }
    }
    Ok(images)
}

pub(super) fn read_points_txt(
    path: &Path,
    images: &BTreeMap<u32, ColmapImage>,
) -> Result<BTreeMap<u64, ColmapPoint3D>, SceneError> {
    let text = read_text(path)?;
    let mut lines = DataLines::new(&text);
    let mut points = BTreeMap::new();
    while let Some((line, content)) = lines.next_data() {
        let tokens: Vec<&str> = content.split_whitespace().collect();
        if tokens.len() < 8 || !(tokens.len() - 8).is_multiple_of(2) {
            return Err(SceneError::line(
                path,
                line,
                format!(
                    "a point line needs POINT3D_ID X Y Z R G B ERROR and (IMAGE_ID POINT2D_IDX) pairs, found {} value(s)",
                    tokens.len()
                ),
            ));
        }
        let id: u64 = parse_token(path, line, tokens[0], "POINT3D_ID")?;
        let mut xyz = [0.0; 3];
        for (k, (v, what)) in xyz.iter_mut().zip(["X", "Y", "Z"]).enumerate() {
            *v = parse_token(path, line, tokens[1 + k], what)?;
        }
        let mut rgb = [0u8; 3];
        for (k, (v, what)) in rgb.iter_mut().zip(["R", "G", "B"]).enumerate() {
            let value: u32 = parse_token(path, line, tokens[4 + k], what)?;
            *v = u8::try_from(value).map_err(|_| {
                SceneError::line(path, line, format!("{what} = {value} is not in 0..=255"))
            })?;
        }
        let error: f64 = tokens[7].parse().map_err(|_| {
            SceneError::line(
                path,
                line,
                format!("ERROR must be a number, found '{}'", tokens[7]),
            )
        })?;
        let mut track = Vec::with_capacity((tokens.len() - 8) / 2);
        for pair in tokens[8..].chunks_exact(2) {
            let image_id: u32 = parse_token(path, line, pair[0], "IMAGE_ID")?;
            let idx: u32 = parse_token(path, line, pair[1], "POINT2D_IDX")?;
            track.push((image_id, idx));
        }
        let point = ColmapPoint3D {
            id,
            xyz,
            rgb,
            error,
            track,
        };
        check_point(&point, images).map_err(|m| SceneError::line(path, line, m))?;
        if points.insert(id, point).is_some() {
            return Err(SceneError::line(path, line, duplicate("3D point", id)));
        }
    }
    Ok(points)
}

/// `{}` of an `f64` is the shortest text that reads back to the same value.
pub(super) fn join_numbers(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

pub(super) fn cameras_txt(model: &ColmapModel) -> String {
    let mut out = String::from(
        "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n",
    );
    out.push_str(&format!("# Number of cameras: {}\n", model.cameras.len()));
    for c in model.cameras.values() {
        out.push_str(&format!(
            "{} {} {} {} {}\n",
            c.id,
            c.model.name(),
            c.width,
            c.height,
            join_numbers(&c.params)
        ));
    }
    out
}

pub(super) fn images_txt(path: &Path, model: &ColmapModel) -> Result<String, SceneError> {
    let observations: usize = model.images.values().map(|i| i.points2d.len()).sum();
    let mut out = String::from(
        "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n",
    );
    out.push_str(&format!(
        "# Number of images: {}, number of observations: {observations}\n",
        model.images.len()
    ));
    for image in model.images.values() {
        if image.name.is_empty() || image.name.chars().any(char::is_whitespace) {
            return Err(SceneError::file(
                path,
                format!(
                    "the name '{}' of image {} is empty or has whitespace, which images.txt cannot store; write the binary encoding",
                    image.name, image.id
                ),
            ));
        }
        out.push_str(&format!(
            "{} {} {} {} {}\n",
            image.id,
            join_numbers(&image.qvec),
            join_numbers(&image.tvec),
            image.camera_id,
            image.name
        ));
        let points: Vec<String> = image
            .points2d
            .iter()
            .map(|([x, y], id)| format!("{x} {y} {id}"))
            .collect();
        out.push_str(&points.join(" "));
        out.push('\n');
    }
    Ok(out)
}

pub(super) fn points_txt(model: &ColmapModel) -> String {
    let mut out = String::from(
        "# 3D point list with one line of data per point:\n#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n",
    );
    out.push_str(&format!("# Number of points: {}\n", model.points.len()));
    for p in model.points.values() {
        out.push_str(&format!(
            "{} {} {} {} {} {}",
            p.id,
            join_numbers(&p.xyz),
            p.rgb[0],
            p.rgb[1],
            p.rgb[2],
            p.error
        ));
        for (image_id, idx) in &p.track {
            out.push_str(&format!(" {image_id} {idx}"));
        }
        out.push('\n');
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Conversion to mvscope's scene
