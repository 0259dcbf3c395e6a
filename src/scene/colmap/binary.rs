//! COLMAP's binary model files (cameras.bin, images.bin, points3D.bin): reading, with every
//! count and record checked, and writing.

use super::*;

/// A little-endian reader over a file's bytes; every read is `None` past the end.
pub(super) struct Bytes<'a> {
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
}

impl<'a> Bytes<'a> {
    fn new(data: &'a [u8]) -> Bytes<'a> {
        Bytes { data, pos: 0 }
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let end = self.pos.checked_add(N)?;
        let bytes: [u8; N] = self.data.get(self.pos..end)?.try_into().ok()?;
        self.pos = end;
        Some(bytes)
    }

    fn u8(&mut self) -> Option<u8> {
        self.take::<1>().map(|b| b[0])
    }
    fn u32(&mut self) -> Option<u32> {
        self.take().map(u32::from_le_bytes)
    }
    fn i32(&mut self) -> Option<i32> {
        self.take().map(i32::from_le_bytes)
    }
    fn u64(&mut self) -> Option<u64> {
        self.take().map(u64::from_le_bytes)
    }
    fn i64(&mut self) -> Option<i64> {
        self.take().map(i64::from_le_bytes)
    }
    fn f64(&mut self) -> Option<f64> {
        self.take().map(f64::from_le_bytes)
    }

    /// Bytes up to a NUL (consumed, not returned); `None` when no NUL follows.
    fn c_string(&mut self) -> Option<&'a [u8]> {
        let rest = &self.data[self.pos..];
        let len = rest.iter().position(|&b| b == 0)?;
        self.pos += len + 1;
        Some(&rest[..len])
    }
}

pub(super) fn read_file(path: &Path) -> Result<Vec<u8>, SceneError> {
    crate::vfs::read(path).map_err(|e| SceneError::io(path, e))
}

pub(super) fn truncated(path: &Path, what: &str, index: u64, count: u64) -> SceneError {
    SceneError::file(
        path,
        format!("the file ends inside {what} {index} of {count}; it is truncated"),
    )
}

pub(super) fn read_count(path: &Path, r: &mut Bytes, what: &str) -> Result<u64, SceneError> {
    r.u64().ok_or_else(|| {
        SceneError::file(
            path,
            format!("the file is shorter than its 8-byte {what} count; it is empty or truncated"),
        )
    })
}

pub(super) fn check_trailing(
    path: &Path,
    r: &Bytes,
    count: u64,
    what: &str,
) -> Result<(), SceneError> {
    if r.remaining() > 0 {
        return Err(SceneError::file(
            path,
            format!(
                "{} bytes follow the {count} {what}(s) the file announces; it is corrupt or not a COLMAP model file",
                r.remaining()
            ),
        ));
    }
    Ok(())
}

pub(super) fn all_finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

pub(super) fn read_cameras_bin(path: &Path) -> Result<BTreeMap<u32, ColmapCamera>, SceneError> {
    let data = read_file(path)?;
    let mut r = Bytes::new(&data);
    let count = read_count(path, &mut r, "camera")?;
    let mut cameras = BTreeMap::new();
    for i in 0..count {
        let trunc = || truncated(path, "camera", i + 1, count);
        let id = r.u32().ok_or_else(trunc)?;
        let model_id = r.i32().ok_or_else(trunc)?;
        let width = r.u64().ok_or_else(trunc)?;
        let height = r.u64().ok_or_else(trunc)?;
        let model = CameraModel::from_id(model_id)
            .ok_or_else(|| SceneError::file(path, unknown_model(id, &model_id.to_string())))?;
        let mut params = Vec::with_capacity(model.num_params());
        for _ in 0..model.num_params() {
            params.push(r.f64().ok_or_else(trunc)?);
        }
        if !all_finite(&params) {
            return Err(SceneError::file(
                path,
                format!(
                    "camera {id} has a non-finite parameter (NaN or infinity); the file is corrupt"
                ),
            ));
        }
        let camera = ColmapCamera {
            id,
            model,
            width,
            height,
            params,
        };
        if cameras.insert(id, camera).is_some() {
            return Err(SceneError::file(path, duplicate("camera", id)));
        }
    }
    check_trailing(path, &r, count, "camera")?;
    Ok(cameras)
}

pub(super) fn read_images_bin(
    path: &Path,
    cameras: &BTreeMap<u32, ColmapCamera>,
) -> Result<BTreeMap<u32, ColmapImage>, SceneError> {
    let data = read_file(path)?;
    let mut r = Bytes::new(&data);
    let count = read_count(path, &mut r, "image")?;
    let mut images = BTreeMap::new();
    for i in 0..count {
        let trunc = || truncated(path, "image", i + 1, count);
        let id = r.u32().ok_or_else(trunc)?;
        let mut pose = [0.0; 7];
        for v in &mut pose {
            *v = r.f64().ok_or_else(trunc)?;
        }
        let camera_id = r.u32().ok_or_else(trunc)?;
        let name_bytes = r.c_string().ok_or_else(trunc)?;
        let name = String::from_utf8(name_bytes.to_vec()).map_err(|_| {
            SceneError::file(
                path,
                format!("the name of image {id} is not UTF-8; the file is corrupt"),
            )
        })?;
        let num_points = r.u64().ok_or_else(trunc)?;
        // Each 2D point takes 24 bytes: never reserve more than the file can hold.
        let capacity = usize::try_from(num_points)
            .unwrap_or(usize::MAX)
            .min(r.remaining() / 24);
        let mut points2d = Vec::with_capacity(capacity);
        for _ in 0..num_points {
            let x = r.f64().ok_or_else(trunc)?;
            let y = r.f64().ok_or_else(trunc)?;
            let point_id = r.i64().ok_or_else(trunc)?;
            points2d.push(([x, y], point_id));
        }
        let image = ColmapImage {
            id,
            qvec: [pose[0], pose[1], pose[2], pose[3]],
            tvec: [pose[4], pose[5], pose[6]],
            camera_id,
            name,
            points2d,
        };
        check_image(&image, cameras).map_err(|m| SceneError::file(path, m))?;
        if images.insert(id, image).is_some() {
            return Err(SceneError::file(path, duplicate("image", id)));
        }
    }
    check_trailing(path, &r, count, "image")?;
    Ok(images)
}

pub(super) fn read_points_bin(
    path: &Path,
    images: &BTreeMap<u32, ColmapImage>,
) -> Result<BTreeMap<u64, ColmapPoint3D>, SceneError> {
    let data = read_file(path)?;
    let mut r = Bytes::new(&data);
    let count = read_count(path, &mut r, "point")?;
    let mut points = BTreeMap::new();
    for i in 0..count {
        let trunc = || truncated(path, "point", i + 1, count);
        let id = r.u64().ok_or_else(trunc)?;
        let xyz = [
            r.f64().ok_or_else(trunc)?,
            r.f64().ok_or_else(trunc)?,
            r.f64().ok_or_else(trunc)?,
        ];
        let rgb = [
            r.u8().ok_or_else(trunc)?,
            r.u8().ok_or_else(trunc)?,
            r.u8().ok_or_else(trunc)?,
        ];
        let error = r.f64().ok_or_else(trunc)?;
        let track_len = r.u64().ok_or_else(trunc)?;
        // Each track element takes 8 bytes.
        let capacity = usize::try_from(track_len)
            .unwrap_or(usize::MAX)
            .min(r.remaining() / 8);
        let mut track = Vec::with_capacity(capacity);
        for _ in 0..track_len {
            let image_id = r.u32().ok_or_else(trunc)?;
            let point2d_idx = r.u32().ok_or_else(trunc)?;
            track.push((image_id, point2d_idx));
        }
        let point = ColmapPoint3D {
            id,
            xyz,
            rgb,
            error,
            track,
        };
        check_point(&point, images).map_err(|m| SceneError::file(path, m))?;
        if points.insert(id, point).is_some() {
            return Err(SceneError::file(path, duplicate("3D point", id)));
        }
    }
    check_trailing(path, &r, count, "point")?;
    Ok(points)
}

pub(super) fn cameras_bin(model: &ColmapModel) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&(model.cameras.len() as u64).to_le_bytes());
    for camera in model.cameras.values() {
        out.extend_from_slice(&camera.id.to_le_bytes());
        out.extend_from_slice(&camera.model.id().to_le_bytes());
        out.extend_from_slice(&camera.width.to_le_bytes());
        out.extend_from_slice(&camera.height.to_le_bytes());
        for p in &camera.params {
            out.extend_from_slice(&p.to_le_bytes());
        }
    }
    out
}

pub(super) fn images_bin(path: &Path, model: &ColmapModel) -> Result<Vec<u8>, SceneError> {
    let mut out = Vec::new();
    out.extend_from_slice(&(model.images.len() as u64).to_le_bytes());
    for image in model.images.values() {
        if image.name.contains('\0') {
            return Err(SceneError::file(
                path,
                format!(
                    "the name of image {} contains a NUL byte, which images.bin cannot store",
                    image.id
                ),
            ));
        }
        out.extend_from_slice(&image.id.to_le_bytes());
        for v in image.qvec.iter().chain(&image.tvec) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&image.camera_id.to_le_bytes());
        out.extend_from_slice(image.name.as_bytes());
        out.push(0);
        out.extend_from_slice(&(image.points2d.len() as u64).to_le_bytes());
        for ([x, y], point_id) in &image.points2d {
            out.extend_from_slice(&x.to_le_bytes());
            out.extend_from_slice(&y.to_le_bytes());
            out.extend_from_slice(&point_id.to_le_bytes());
        }
    }
    Ok(out)
}

pub(super) fn points_bin(model: &ColmapModel) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&(model.points.len() as u64).to_le_bytes());
    for point in model.points.values() {
        out.extend_from_slice(&point.id.to_le_bytes());
        for v in &point.xyz {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&point.rgb);
        out.extend_from_slice(&point.error.to_le_bytes());
        out.extend_from_slice(&(point.track.len() as u64).to_le_bytes());
        for (image_id, idx) in &point.track {
            out.extend_from_slice(&image_id.to_le_bytes());
            out.extend_from_slice(&idx.to_le_bytes());
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Checks shared by both encodings
