//! COLMAP's dense stereo maps: `stereo/depth_maps/*.{geometric,photometric}.bin` (1 channel)
//! and `stereo/normal_maps/*.bin` (3 channels).
//!
//! Layout (COLMAP `mvs::Mat<float>::Read/Write`): an ASCII header `WIDTH&HEIGHT&CHANNELS&`,
//! then `width * height * channels` little-endian float32 values stored PLANAR — the value of
//! channel `c` at row `y` (row 0 is the top), column `x` is at index
//! `c * width * height + y * width + x`. [`Map`] interleaves channels, so the reader and the
//! writer transpose between the two.

use std::io::Write;
use std::path::Path;

use super::{
    IoError, Map, check_data_len, checked_count, f32s_le, parse_size, read_all, write_atomic,
};

const HINT: &str = "a COLMAP map header is \"WIDTH&HEIGHT&CHANNELS&\"";
/// The header is three decimal numbers; anything longer is not a COLMAP header.
const MAX_HEADER_LEN: usize = 64;

/// Reads a COLMAP depth or normal map into an interleaved, top-row-first [`Map`].
pub fn read_colmap_map(path: &Path) -> Result<Map, IoError> {
    let bytes = read_all(path)?;
    let mut fields = [0u32; 3];
    let mut pos = 0usize;
    for (i, what) in ["width", "height", "channels"].into_iter().enumerate() {
        let rest = &bytes[pos..];
        let limit = rest.len().min(MAX_HEADER_LEN);
        let Some(amp) = rest[..limit].iter().position(|&b| b == b'&') else {
            return Err(IoError::malformed(
                path,
                if rest.len() < MAX_HEADER_LEN && i > 0 {
                    format!(
                        "the header ends before its {what}; the file was not written \
                         completely ({HINT})"
                    )
                } else {
                    format!(
                        "no '&' after the {what} in the header; the file is not a COLMAP \
                         depth or normal map ({HINT})"
                    )
                },
            ));
        };
        let token = String::from_utf8_lossy(&rest[..amp]);
        fields[i] = parse_size(path, what, &token, HINT)?;
        pos += amp + 1;
    }
    let [width, height, channels] = fields;
    let count = checked_count(path, width, height, channels)?;
    let data = &bytes[pos..];
    check_data_len(path, data, count)?;

    let plane = width as usize * height as usize;
    let c_n = channels as usize;
    let mut out = vec![0.0f32; count];
    for (i, v) in f32s_le(data).enumerate() {
        let (c, p) = (i / plane, i % plane);
        out[p * c_n + c] = v;
    }
    Ok(Map {
        width,
        height,
        channels,
        data: out,
    })
}

/// Writes a [`Map`] as a COLMAP depth/normal map (planar channels), atomically
/// (see [`write_atomic`]).
pub fn write_colmap_map(path: &Path, map: &Map) -> Result<(), IoError> {
    map.check_writable(path)?;
    let c_n = map.channels as usize;
    write_atomic(path, |w| {
        write!(w, "{}&{}&{}&", map.width, map.height, map.channels)?;
        for c in 0..c_n {
            for v in map.data.iter().skip(c).step_by(c_n) {
                w.write_all(&v.to_le_bytes())?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::io::testing::bits;

    fn pattern(width: u32, height: u32, channels: u32) -> Map {
        crate::io::testing::pattern(width, height, channels, 0x4000_0000, 2_246_822_519)
    }

    fn expect_err(bytes: &[u8], name: &str) -> String {
        crate::io::testing::expect_err(bytes, name, read_colmap_map)
    }

    #[test]
    fn colmap_round_trip_depth_and_normal() {
        let dir = tempfile::tempdir().unwrap();
        for (w, h, c) in [(5, 3, 1), (7, 4, 3), (1, 1, 3), (2, 5, 2)] {
            let path = dir.path().join(format!("v{w}x{h}x{c}.geometric.bin"));
            let m = pattern(w, h, c);
            write_colmap_map(&path, &m).unwrap();
            let back = read_colmap_map(&path).unwrap();
            assert_eq!((back.width, back.height, back.channels), (w, h, c));
            assert_eq!(bits(&back), bits(&m));
        }
    }

    #[test]
    fn colmap_layout_is_planar() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("n.bin");
        // 2 wide, 1 tall, 3 channels: pixel 0 = (1, 2, 3), pixel 1 = (4, 5, 6).
        let m = Map::from_data(2, 1, 3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        write_colmap_map(&path, &m).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let header = b"2&1&3&";
        assert!(bytes.starts_with(header));
        let data: Vec<f32> = f32s_le(&bytes[header.len()..]).collect();
        assert_eq!(data, vec![1.0, 4.0, 2.0, 5.0, 3.0, 6.0]);
    }

    #[test]
    fn colmap_reads_hand_written_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.photometric.bin");
        // 3 wide, 2 tall depth map, row 0 (top) = 1 2 3, row 1 = 4 5 6.
        let mut bytes = b"3&2&1&".to_vec();
        for v in [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        std::fs::write(&path, &bytes).unwrap();
        let m = read_colmap_map(&path).unwrap();
        assert_eq!((m.width, m.height, m.channels), (3, 2, 1));
        assert_eq!(m.get(2, 0, 0), 3.0);
        assert_eq!(m.get(0, 1, 0), 4.0);
    }

    #[test]
    fn colmap_rejects_bad_headers() {
        let msg = expect_err(
            b"\x89PNG\r\n\x1a\n0000000000000000000000000000000000000000000000000000000000000000",
            "png.bin",
        );
        assert!(msg.contains("not a COLMAP"), "{msg}");
        let msg = expect_err(b"-4&2&1&", "neg.bin");
        assert!(msg.contains("width -4"), "{msg}");
        let msg = expect_err(b"4&0&1&", "zero.bin");
        assert!(msg.contains("height 0"), "{msg}");
        let msg = expect_err(b"4&2&", "short_header.bin");
        assert!(msg.contains("ends before its channels"), "{msg}");
        let msg = expect_err(b"a&2&1&", "text.bin");
        assert!(msg.contains("not an integer"), "{msg}");
    }

    #[test]
    fn colmap_truncated() {
        let mut bytes = b"450&375&1&".to_vec();
        bytes.extend_from_slice(&[0u8; 1000]);
        let msg = expect_err(&bytes, "cut.geometric.bin");
        assert!(
            msg.contains("truncated: expected 675000 bytes of data, found 1000"),
            "{msg}"
        );
    }
}
