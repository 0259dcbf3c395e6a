//! PLY point clouds (via `ply-rs-bw`).
//!
//! [`write_ply`] writes `binary_little_endian 1.0` with one `vertex` element whose properties
//! are exactly `float x, float y, float z, float nx, float ny, float nz, uchar red,
//! uchar green, uchar blue` (27 bytes per point) — the layout ACMM's and COLMAP's fusion write
//! and MeshLab reads.
//!
//! [`read_ply`] reads ASCII, binary little-endian and binary big-endian files. It needs a
//! `vertex` element with scalar `x`, `y`, `z`; `nx`, `ny`, `nz` and `red`, `green`, `blue` are
//! optional (defaults: normal `[0, 0, 0]`, colour `[255, 255, 255]`). Any scalar type is
//! accepted and converted: positions and normals to `f32`; colours from integers clamped to
//! 0..=255 and from floats as 0..=1 scaled to 0..=255. Other elements (faces, ...) and other
//! properties are skipped.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult, PropertyDef,
    PropertyType, ScalarType,
};
use ply_rs_bw::writer::Writer;

use super::{IoError, write_atomic};

/// One point of a cloud: position, normal, RGB colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlyPoint {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub color: [u8; 3],
}

const POSITION: [&str; 3] = ["x", "y", "z"];
const NORMAL: [&str; 3] = ["nx", "ny", "nz"];
const COLOR: [&str; 3] = ["red", "green", "blue"];

/// A [`PlyPoint`] as `ply-rs-bw` sees it, for both reading and writing.
struct Vertex(PlyPoint);

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex(PlyPoint {
            position: [0.0; 3],
            normal: [0.0; 3],
            color: [255; 3],
        })
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let p = &mut self.0;
        let slot = |names: &[&str; 3]| names.iter().position(|&n| n == name);
        let set = if let Some(i) = slot(&POSITION) {
            scalar_f32(&property).map(|v| p.position[i] = v)
        } else if let Some(i) = slot(&NORMAL) {
            scalar_f32(&property).map(|v| p.normal[i] = v)
        } else if let Some(i) = slot(&COLOR) {
            color_u8(&property).map(|v| p.color[i] = v)
        } else {
            None
        };
        match set {
            Some(()) => PropertyAccessResult::Set,
            None => PropertyAccessResult::Ignored,
        }
    }

    fn get_float(&self, name: &str) -> Option<f32> {
        let p = &self.0;
        match name {
            "x" => Some(p.position[0]),
            "y" => Some(p.position[1]),
            "z" => Some(p.position[2]),
            "nx" => Some(p.normal[0]),
            "ny" => Some(p.normal[1]),
            "nz" => Some(p.normal[2]),
            _ => None,
        }
    }

    fn get_uchar(&self, name: &str) -> Option<u8> {
        let p = &self.0;
        match name {
            "red" => Some(p.color[0]),
            "green" => Some(p.color[1]),
            "blue" => Some(p.color[2]),
            _ => None,
        }
    }
}

fn scalar_f32(p: &Property) -> Option<f32> {
    match *p {
        Property::Double(v) => Some(v as f32),
        ref other => other.to_f32_lossy(),
    }
}

fn color_u8(p: &Property) -> Option<u8> {
    let v: f64 = match *p {
        Property::Float(v) => f64::from(v) * 255.0,
        Property::Double(v) => v * 255.0,
        ref other => f64::from(other.to_f32_lossy()?),
    };
    // NaN becomes 0 under `as`; the clamp keeps the cast exact.
    Some(v.round().clamp(0.0, 255.0) as u8)
}

/// The vertex element [`write_ply`] writes for `count` points.
fn vertex_def(count: usize) -> ElementDef {
    let mut vertex = ElementDef::new("vertex".to_string());
    vertex.count = count;
    let mut add = |name: &str, t: ScalarType| {
        vertex.properties.insert(
            name.to_string(),
            PropertyDef::new(name.to_string(), PropertyType::Scalar(t)),
        );
    };
    for n in POSITION.iter().chain(NORMAL.iter()) {
        add(n, ScalarType::Float);
    }
    for n in COLOR {
        add(n, ScalarType::UChar);
    }
    vertex
}

/// Writes points as a binary little-endian PLY (see the module docs for the exact layout),
/// atomically (see [`write_atomic`]).
pub fn write_ply(path: &Path, points: &[PlyPoint]) -> Result<(), IoError> {
    let vertex = vertex_def(points.len());
    let mut header = Header::new();
    header.encoding = Encoding::BinaryLittleEndian;
    header.elements.insert(vertex.name.clone(), vertex.clone());
    let writer = Writer::<Vertex>::new();
    write_atomic(path, |w| {
        writer.write_header(w, &header)?;
        for p in points {
            writer.write_little_endian_element(w, &Vertex(*p), &vertex)?;
        }
        Ok(())
    })
}

/// Reads the `vertex` element of an ASCII or binary PLY (see the module docs for what is
/// required and how types are converted).
pub fn read_ply(path: &Path) -> Result<Vec<PlyPoint>, IoError> {
    let file = File::open(path).map_err(|e| IoError::io(path, "open", e))?;
    let mut reader = Reader::new(BufReader::new(file));
    let parser = Parser::<Vertex>::new();
    let header = parser
        .read_header(&mut reader)
        .map_err(|e| parse_error(path, "header", &e))?;
    let Some(vertex) = header.elements.get("vertex") else {
        let names: Vec<&str> = header.elements.keys().map(String::as_str).collect();
        return Err(IoError::malformed(
            path,
            format!(
                "no \"vertex\" element (elements: {names:?}); a point cloud PLY declares \
                 \"element vertex N\""
            ),
        ));
    };
    for (group, names) in [POSITION, NORMAL, COLOR].iter().enumerate() {
        for name in names {
            match vertex.properties.get(*name) {
                None if group == 0 => {
                    return Err(IoError::malformed(
                        path,
                        format!(
                            "the vertex element has no property \"{name}\"; points need \
                             scalar x, y and z"
                        ),
                    ));
                }
                Some(def) if !matches!(def.data_type, PropertyType::Scalar(_)) => {
                    return Err(IoError::malformed(
                        path,
                        format!(
                            "vertex property \"{name}\" is a list; it must be a scalar \
                             (float, double, uchar, ...)"
                        ),
                    ));
                }
                _ => {}
            }
        }
    }
    let mut payload = parser
        .read_payload(&mut reader, &header)
        .map_err(|e| parse_error(path, "data", &e))?;
    let vertices = payload.swap_remove("vertex").unwrap_or_default();
    Ok(vertices.into_iter().map(|v| v.0).collect())
}

fn parse_error(path: &Path, part: &str, e: &ply_rs_bw::parser::ParseError) -> IoError {
    let what = if e.kind() == std::io::ErrorKind::UnexpectedEof {
        "the file is truncated (it was not written completely)"
    } else {
        "the file is damaged or not a PLY"
    };
    IoError::malformed(
        path,
        format!(
            "cannot parse the PLY {part}: {}; {what}",
            e.to_string().replace(['\n', '\t'], " ")
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points() -> Vec<PlyPoint> {
        (0..17)
            .map(|i| {
                let f = i as f32;
                PlyPoint {
                    position: [f * 0.1 - 0.7, -f * 1e-7, 1e6 + f],
                    normal: [0.6, -0.8, f32::from_bits(i as u32 + 1)],
                    color: [i as u8 * 15, 255 - i as u8, 128],
                }
            })
            .collect()
    }

    fn bits(p: &[PlyPoint]) -> Vec<([u32; 3], [u32; 3], [u8; 3])> {
        p.iter()
            .map(|p| {
                (
                    p.position.map(f32::to_bits),
                    p.normal.map(f32::to_bits),
                    p.color,
                )
            })
            .collect()
    }

    fn expect_err(text: &[u8], name: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let msg = read_ply(&path).unwrap_err().to_string();
        assert!(msg.contains(name), "message does not name the file: {msg}");
        msg
    }

    const EXPECTED_HEADER: &str = "ply\n\
        format binary_little_endian 1.0\n\
        element vertex 17\n\
        property float x\n\
        property float y\n\
        property float z\n\
        property float nx\n\
        property float ny\n\
        property float nz\n\
        property uchar red\n\
        property uchar green\n\
        property uchar blue\n\
        end_header\n";

    #[test]
    fn ply_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cloud.ply");
        let pts = points();
        write_ply(&path, &pts).unwrap();
        assert_eq!(bits(&read_ply(&path).unwrap()), bits(&pts));
    }

    #[test]
    fn ply_round_trip_empty() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.ply");
        write_ply(&path, &[]).unwrap();
        assert!(read_ply(&path).unwrap().is_empty());
    }

    #[test]
    fn ply_header_and_size_are_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.ply");
        let pts = points();
        write_ply(&path, &pts).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert!(
            bytes.starts_with(EXPECTED_HEADER.as_bytes()),
            "header: {:?}",
            String::from_utf8_lossy(&bytes[..EXPECTED_HEADER.len().min(bytes.len())])
        );
        assert_eq!(bytes.len(), EXPECTED_HEADER.len() + 27 * pts.len());
        // First point, field by field, little-endian.
        let d = &bytes[EXPECTED_HEADER.len()..];
        assert_eq!(d[0..4], pts[0].position[0].to_le_bytes());
        assert_eq!(d[20..24], pts[0].normal[2].to_le_bytes());
        assert_eq!(d[24..27], pts[0].color);
    }

    #[test]
    fn ply_reads_hand_written_ascii_with_doubles_and_faces() {
        let text = "ply\n\
            format ascii 1.0\n\
            comment written by hand\n\
            element vertex 3\n\
            property double x\n\
            property double y\n\
            property double z\n\
            property float nx\n\
            property float ny\n\
            property float nz\n\
            property uchar red\n\
            property uchar green\n\
            property uchar blue\n\
            property float quality\n\
            element face 1\n\
            property list uchar int vertex_indices\n\
            end_header\n\
            1.5 -2 3e2 0 0 1 10 20 30 0.5\n\
            0 0 0 1 0 0 255 0 0 0.25\n\
            -1 -1 -1 0 1 0 0 0 255 1\n\
            3 0 1 2\n";
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hand.ply");
        std::fs::write(&path, text).unwrap();
        let pts = read_ply(&path).unwrap();
        assert_eq!(
            pts,
            vec![
                PlyPoint {
                    position: [1.5, -2.0, 300.0],
                    normal: [0.0, 0.0, 1.0],
                    color: [10, 20, 30],
                },
                PlyPoint {
                    position: [0.0, 0.0, 0.0],
                    normal: [1.0, 0.0, 0.0],
                    color: [255, 0, 0],
                },
                PlyPoint {
                    position: [-1.0, -1.0, -1.0],
                    normal: [0.0, 1.0, 0.0],
                    color: [0, 0, 255],
                },
            ]
        );
    }

    #[test]
    fn ply_defaults_normal_and_colour_when_absent() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("xyz.ply");
        std::fs::write(
            &path,
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
             property float z\nend_header\n1 2 3\n",
        )
        .unwrap();
        let pts = read_ply(&path).unwrap();
        assert_eq!(
            pts,
            vec![PlyPoint {
                position: [1.0, 2.0, 3.0],
                normal: [0.0; 3],
                color: [255; 3],
            }]
        );
    }

    #[test]
    fn ply_reads_big_endian_with_float_colours() {
        let mut bytes = b"ply\nformat binary_big_endian 1.0\nelement vertex 2\n\
            property float x\nproperty float y\nproperty float z\n\
            property float red\nproperty float green\nproperty float blue\nend_header\n"
            .to_vec();
        for v in [
            1.0f32, 2.0, 3.0, 1.0, 0.5, 0.0, -4.0, 5.0, 6.5, 2.0, -1.0, 0.2,
        ] {
            bytes.extend_from_slice(&v.to_be_bytes());
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("be.ply");
        std::fs::write(&path, &bytes).unwrap();
        let pts = read_ply(&path).unwrap();
        assert_eq!(pts.len(), 2);
        assert_eq!(pts[0].position, [1.0, 2.0, 3.0]);
        assert_eq!(pts[0].color, [255, 128, 0]);
        assert_eq!(pts[1].position, [-4.0, 5.0, 6.5]);
        assert_eq!(pts[1].color, [255, 0, 51]);
        assert_eq!(pts[1].normal, [0.0; 3]);
    }

    #[test]
    fn ply_without_x_is_an_error() {
        let msg = expect_err(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\n\
              end_header\n1 2\n",
            "nox.ply",
        );
        assert!(msg.contains("no property \"x\""), "{msg}");
    }

    #[test]
    fn ply_without_vertex_is_an_error() {
        let msg = expect_err(
            b"ply\nformat ascii 1.0\nelement point 1\nproperty float x\nend_header\n1\n",
            "novertex.ply",
        );
        assert!(msg.contains("no \"vertex\" element"), "{msg}");
    }

    #[test]
    fn ply_truncated_and_garbage_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("full.ply");
        write_ply(&path, &points()).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let msg = expect_err(&bytes[..bytes.len() - 5], "cut.ply");
        assert!(msg.contains("truncated"), "{msg}");
        let msg = expect_err(b"P6\n2 2\n255\n", "notply.ply");
        assert!(msg.contains("cannot parse the PLY header"), "{msg}");
        let msg = expect_err(b"", "empty.ply");
        assert!(msg.contains("empty.ply"), "{msg}");
        let dir2 = tempfile::tempdir().unwrap();
        let missing = dir2.path().join("missing.ply");
        let msg = read_ply(&missing).unwrap_err().to_string();
        assert!(msg.contains("missing.ply"), "{msg}");
    }
}
