//! ACMM's `.dmb` map files (depth, normal and cost maps).
//!
//! Layout, all little-endian: int32 `type` (always 1), int32 height, int32 width, int32
//! channels, then `height * width * channels` float32 values, row-major, TOP row first,
//! channels interleaved — the same layout as [`Map`], so no reordering is needed.

use std::io::Write;
use std::path::Path;

use super::{
    IoError, Map, check_data_len, checked_count, f32s_le, parse_size, read_all, write_atomic,
};

const HEADER_LEN: usize = 16;
const HINT: &str = "a .dmb header is int32 type (1), height, width, channels";

/// Reads an ACMM `.dmb` file.
pub fn read_dmb(path: &Path) -> Result<Map, IoError> {
    let bytes = read_all(path)?;
    if bytes.len() < HEADER_LEN {
        return Err(IoError::truncated(
            path,
            "header",
            HEADER_LEN as u64,
            bytes.len() as u64,
        ));
    }
    let int = |i: usize| {
        let b = &bytes[i * 4..i * 4 + 4];
        i32::from_le_bytes([b[0], b[1], b[2], b[3]])
    };
    let kind = int(0);
    if kind != 1 {
        return Err(IoError::malformed(
            path,
            format!(
                "type {kind} in the header is not 1, the only type ACMM writes; the file is \
                 not an ACMM .dmb map"
            ),
        ));
    }
    let height = parse_size(path, "height", &int(1).to_string(), HINT)?;
    let width = parse_size(path, "width", &int(2).to_string(), HINT)?;
    let channels = parse_size(path, "channels", &int(3).to_string(), HINT)?;
    let count = checked_count(path, width, height, channels)?;
    let data = &bytes[HEADER_LEN..];
    check_data_len(path, data, count)?;
    Ok(Map {
        width,
        height,
        channels,
        data: f32s_le(data).collect(),
    })
}

/// Writes a [`Map`] as an ACMM `.dmb` file, atomically (see [`write_atomic`]).
pub fn write_dmb(path: &Path, map: &Map) -> Result<(), IoError> {
    map.check_writable(path)?;
    let as_i32 = |what: &str, v: u32| {
        i32::try_from(v).map_err(|_| {
            IoError::invalid(
                path,
                format!("{what} {v} does not fit the format's int32 header"),
            )
        })
    };
    let header = [
        1,
        as_i32("height", map.height)?,
        as_i32("width", map.width)?,
        as_i32("channels", map.channels)?,
    ];
    write_atomic(path, |w| {
        for v in header {
            w.write_all(&v.to_le_bytes())?;
        }
        for v in &map.data {
            w.write_all(&v.to_le_bytes())?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::io::testing::bits;

    fn pattern(width: u32, height: u32, channels: u32) -> Map {
        crate::io::testing::pattern(width, height, channels, 0x3f80_0000, 2_654_435_761)
    }

    fn header(kind: i32, h: i32, w: i32, c: i32) -> Vec<u8> {
        [kind, h, w, c]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect()
    }

    fn expect_err(bytes: &[u8], name: &str) -> String {
        crate::io::testing::expect_err(bytes, name, read_dmb)
    }

    #[test]
    fn dmb_round_trip_one_and_three_channels() {
        let dir = tempfile::tempdir().unwrap();
        for (w, h, c) in [(5, 3, 1), (7, 4, 3), (1, 1, 1), (3, 9, 2)] {
            let path = dir.path().join(format!("m{w}x{h}x{c}.dmb"));
            let m = pattern(w, h, c);
            write_dmb(&path, &m).unwrap();
            let back = read_dmb(&path).unwrap();
            assert_eq!((back.width, back.height, back.channels), (w, h, c));
            assert_eq!(bits(&back), bits(&m));
        }
    }

    #[test]
    fn dmb_layout_is_acmm() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("layout.dmb");
        // 3 wide, 2 tall, 1 channel: top row [1, 2, 3], bottom row [4, 5, 6].
        let m = Map::from_data(3, 2, 1, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        write_dmb(&path, &m).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len(), 16 + 6 * 4);
        assert_eq!(&bytes[..16], header(1, 2, 3, 1).as_slice());
        let data: Vec<f32> = f32s_le(&bytes[16..]).collect();
        assert_eq!(data, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    }

    #[test]
    fn dmb_rejects_wrong_type() {
        let mut bytes = header(2, 1, 1, 1);
        bytes.extend_from_slice(&1.0f32.to_le_bytes());
        let msg = expect_err(&bytes, "type2.dmb");
        assert!(msg.contains("type 2"), "{msg}");
    }

    #[test]
    fn dmb_rejects_bad_sizes() {
        let msg = expect_err(&header(1, -3, 2, 1), "neg.dmb");
        assert!(msg.contains("height -3"), "{msg}");
        let msg = expect_err(&header(1, 2, 0, 1), "zero.dmb");
        assert!(msg.contains("width 0"), "{msg}");
        let msg = expect_err(&header(1, 2, 2, 0), "nochan.dmb");
        assert!(msg.contains("channels 0"), "{msg}");
    }

    #[test]
    fn dmb_truncated() {
        let msg = expect_err(&[1, 0, 0], "tiny.dmb");
        assert!(
            msg.contains("truncated: expected 16 bytes of header, found 3"),
            "{msg}"
        );
        let mut bytes = header(1, 375, 450, 1);
        bytes.extend_from_slice(&[0u8; 1000]);
        let msg = expect_err(&bytes, "cut.dmb");
        assert!(
            msg.contains("truncated: expected 675000 bytes of data, found 1000"),
            "{msg}"
        );
        let mut bytes = header(1, 1, 1, 1);
        bytes.extend_from_slice(&[0u8; 8]);
        let msg = expect_err(&bytes, "long.dmb");
        assert!(msg.contains("4 bytes after the data"), "{msg}");
    }
}
