//! Portable Float Map (PFM) files: 1-channel (`Pf`) and 3-channel (`PF`) float images.
//!
//! Layout: an ASCII header of four whitespace-separated tokens — the magic `PF` (3 channels)
//! or `Pf` (1 channel), the width, the height and a scale whose sign gives the byte order
//! (negative: little-endian, positive: big-endian; its magnitude is ignored) — then exactly
//! one whitespace byte, then float32 rows stored BOTTOM-TO-TOP with channels interleaved.
//!
//! That is the standard PFM layout (Middlebury, Netpbm); MVSNet-style writers flip their
//! images before writing so standard readers see them upright — the "MVSNet convention" is
//! this same on-disk layout. [`read_pfm`] flips rows so the returned [`Map`] is top-first;
//! [`write_pfm`] writes little-endian (scale `-1.0`) with the bottom row first.

use std::io::Write;
use std::path::Path;

use super::{IoError, Map, check_data_len, checked_count, parse_size, read_all, write_atomic};

const HINT: &str = "a PFM header is \"Pf\" or \"PF\", then width, height and scale";

/// Whitespace-separated tokens at the start of a byte buffer.
struct Tokens<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Tokens<'a> {
    fn next_token(&mut self) -> Option<&'a [u8]> {
        while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        // Header tokens are short; a long run without whitespace is not a PFM header.
        while self.pos < self.bytes.len()
            && !self.bytes[self.pos].is_ascii_whitespace()
            && self.pos - start < 64
        {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.bytes[start..self.pos])
    }
}

fn header_token<'a>(path: &Path, tokens: &mut Tokens<'a>, what: &str) -> Result<&'a [u8], IoError> {
    tokens.next_token().ok_or_else(|| {
        IoError::malformed(
            path,
            format!(
                "the PFM header ends before its {what}; the file was not written completely \
                 ({HINT})"
            ),
        )
    })
}

/// Reads a PFM file (either byte order) into a top-row-first [`Map`] of 1 or 3 channels.
pub fn read_pfm(path: &Path) -> Result<Map, IoError> {
    let bytes = read_all(path)?;
    let mut tokens = Tokens {
        bytes: &bytes,
        pos: 0,
    };
    let magic = header_token(path, &mut tokens, "magic")?;
    let channels = match magic {
        b"Pf" => 1,
        b"PF" => 3,
        other => {
            return Err(IoError::malformed(
                path,
                format!(
                    "wrong magic {:?}: a PFM file starts with \"Pf\" (1 channel) or \"PF\" \
                     (3 channels); the file is not a PFM",
                    String::from_utf8_lossy(other)
                ),
            ));
        }
    };
    let width_token = String::from_utf8_lossy(header_token(path, &mut tokens, "width")?);
    let width = parse_size(path, "width", &width_token, HINT)?;
    let height_token = String::from_utf8_lossy(header_token(path, &mut tokens, "height")?);
    let height = parse_size(path, "height", &height_token, HINT)?;
    let scale_token = String::from_utf8_lossy(header_token(path, &mut tokens, "scale")?);
    let scale: f64 = scale_token.parse().map_err(|_| {
        IoError::malformed(
            path,
            format!("scale {scale_token:?} in the header is not a number; {HINT}"),
        )
    })?;
    if !scale.is_finite() || scale == 0.0 {
        return Err(IoError::malformed(
            path,
            format!(
                "scale {scale_token} in the header does not give the byte order; it must be \
                 negative (little-endian) or positive (big-endian)"
            ),
        ));
    }
    let little_endian = scale < 0.0;
    // Exactly one whitespace byte separates the header from the data.
    let data_start = (tokens.pos + 1).min(bytes.len());
    let data = &bytes[data_start..];

    let count = checked_count(path, width, height, channels)?;
    check_data_len(path, data, count)?;

    let row_len = width as usize * channels as usize;
    let mut out = vec![0.0f32; count];
    // File row r is image row height-1-r: PFM stores the bottom row first.
    for (file_row, chunk) in data.chunks_exact(row_len * 4).enumerate() {
        let y = height as usize - 1 - file_row;
        let dst = &mut out[y * row_len..(y + 1) * row_len];
        for (d, b) in dst.iter_mut().zip(chunk.chunks_exact(4)) {
            let b = [b[0], b[1], b[2], b[3]];
            *d = if little_endian {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
        }
    }
    Ok(Map {
        width,
        height,
        channels,
        data: out,
    })
}

/// Writes a 1- or 3-channel [`Map`] as a little-endian PFM (scale `-1.0`), bottom row first,
/// atomically (see [`write_atomic`]).
pub fn write_pfm(path: &Path, map: &Map) -> Result<(), IoError> {
    map.check_writable(path)?;
    let magic = match map.channels {
        1 => "Pf",
        3 => "PF",
        n => {
            return Err(IoError::invalid(
                path,
                format!("PFM stores 1 or 3 channels, the map has {n}; use .dmb for other counts"),
            ));
        }
    };
    let row_len = map.width as usize * map.channels as usize;
    write_atomic(path, |w| {
        write!(w, "{magic}\n{} {}\n-1.0\n", map.width, map.height)?;
        let mut buf = Vec::with_capacity(row_len * 4);
        for row in map.data.chunks_exact(row_len).rev() {
            buf.clear();
            for v in row {
                buf.extend_from_slice(&v.to_le_bytes());
            }
            w.write_all(&buf)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::IoError;

    fn pattern(width: u32, height: u32, channels: u32) -> Map {
        let mut m = Map::new(width, height, channels);
        for (i, v) in m.data.iter_mut().enumerate() {
            *v = (i as f32) * 0.37 - 11.0;
        }
        // Values that only survive a bit-exact path.
        m.data[0] = f32::NAN;
        if m.data.len() > 3 {
            m.data[1] = -0.0;
            m.data[2] = f32::INFINITY;
            m.data[3] = f32::from_bits(1); // subnormal
        }
        m
    }

    fn assert_bits_eq(a: &Map, b: &Map) {
        assert_eq!(
            (a.width, a.height, a.channels),
            (b.width, b.height, b.channels)
        );
        let ab: Vec<u32> = a.data.iter().map(|v| v.to_bits()).collect();
        let bb: Vec<u32> = b.data.iter().map(|v| v.to_bits()).collect();
        assert_eq!(ab, bb);
    }

    fn expect_err(bytes: &[u8], name: &str) -> String {
        crate::io::testing::expect_err(bytes, name, read_pfm)
    }

    #[test]
    fn pfm_round_trip_one_channel_odd_size() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.pfm");
        let m = pattern(5, 3, 1);
        write_pfm(&path, &m).unwrap();
        assert_bits_eq(&read_pfm(&path).unwrap(), &m);
    }

    #[test]
    fn pfm_round_trip_three_channels_non_square() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("n.pfm");
        let m = pattern(7, 4, 3);
        write_pfm(&path, &m).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.starts_with(b"PF\n7 4\n-1.0\n"));
        assert_bits_eq(&read_pfm(&path).unwrap(), &m);
    }

    #[test]
    fn pfm_round_trip_single_pixel() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.pfm");
        let m = Map::from_data(1, 1, 1, vec![42.5]).unwrap();
        write_pfm(&path, &m).unwrap();
        assert_bits_eq(&read_pfm(&path).unwrap(), &m);
    }

    #[test]
    fn pfm_stores_bottom_row_first() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("o.pfm");
        // 2 wide, 3 tall: top row [1, 2], middle [3, 4], bottom [5, 6].
        let m = Map::from_data(2, 3, 1, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        write_pfm(&path, &m).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let header = b"Pf\n2 3\n-1.0\n";
        assert!(bytes.starts_with(header));
        let data: Vec<f32> = bytes[header.len()..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(data, vec![5.0, 6.0, 3.0, 4.0, 1.0, 2.0]);
        let back = read_pfm(&path).unwrap();
        assert_eq!(back.get(0, 0, 0), 1.0);
        assert_eq!(back.get(1, 2, 0), 6.0);
    }

    #[test]
    fn pfm_reads_big_endian_and_any_whitespace() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("be.pfm");
        let mut bytes = b"PF \t2\r\n  1\n\n1.0\n".to_vec();
        for v in [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0] {
            bytes.extend_from_slice(&v.to_be_bytes());
        }
        std::fs::write(&path, &bytes).unwrap();
        let m = read_pfm(&path).unwrap();
        assert_eq!((m.width, m.height, m.channels), (2, 1, 3));
        assert_eq!(m.data, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    }

    #[test]
    fn pfm_truncated_says_how_much_is_missing() {
        let mut bytes = b"Pf\n450 375\n-1.0\n".to_vec();
        bytes.extend_from_slice(&[0u8; 1000]);
        let msg = expect_err(&bytes, "short.pfm");
        assert!(
            msg.contains("truncated: expected 675000 bytes of data, found 1000"),
            "{msg}"
        );
    }

    #[test]
    fn pfm_rejects_bad_headers() {
        let msg = expect_err(b"P6\n2 2\n255\n0000", "magic.pfm");
        assert!(msg.contains("wrong magic"), "{msg}");
        let msg = expect_err(b"Pf\n-2 2\n-1.0\n", "neg.pfm");
        assert!(msg.contains("width -2"), "{msg}");
        assert!(msg.contains("not positive"), "{msg}");
        let msg = expect_err(b"Pf\n2 0\n-1.0\n", "zero.pfm");
        assert!(msg.contains("height 0"), "{msg}");
        let msg = expect_err(b"Pf\n2 x\n-1.0\n", "nan_size.pfm");
        assert!(msg.contains("not an integer"), "{msg}");
        let msg = expect_err(b"Pf\n1 1\n0\n\0\0\0\0", "scale.pfm");
        assert!(msg.contains("byte order"), "{msg}");
        let msg = expect_err(b"Pf\n1 1\n", "early.pfm");
        assert!(msg.contains("ends before its scale"), "{msg}");
        let msg = expect_err(b"", "empty.pfm");
        assert!(msg.contains("ends before its magic"), "{msg}");
        let msg = expect_err(b"Pf\n1 1\n-1.0\n\0\0\0\0\0\0\0\0", "long.pfm");
        assert!(msg.contains("4 bytes after the data"), "{msg}");
        let msg = expect_err(b"Pf\n99999 99999\n-1.0\n", "huge.pfm");
        assert!(msg.contains("truncated"), "{msg}");
    }

    #[test]
    fn pfm_write_rejects_unstorable_maps() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("two.pfm");
        let err = write_pfm(&path, &Map::new(2, 2, 2)).unwrap_err();
        assert!(matches!(err, IoError::Invalid { .. }));
        assert!(err.to_string().contains("two.pfm"), "{err}");
        let err = write_pfm(&path, &Map::new(0, 2, 1)).unwrap_err();
        assert!(err.to_string().contains("two.pfm"), "{err}");
        let bad = Map {
            width: 2,
            height: 2,
            channels: 1,
            data: vec![0.0; 3],
        };
        assert!(write_pfm(&path, &bad).is_err());
        assert!(!path.exists());
    }

    /// The last non-empty line of an MVSNet cam file: `min interval count max`.
    fn depth_range(cam: &Path) -> (f32, f32) {
        let text = std::fs::read_to_string(cam)
            .unwrap_or_else(|e| panic!("shared data missing: {}: {e}", cam.display()));
        let line = text.lines().rev().find(|l| !l.trim().is_empty()).unwrap();
        let v: Vec<f32> = line
            .split_whitespace()
            .map(|t| t.parse().unwrap())
            .collect();
        assert_eq!(v.len(), 4, "depth line of {}: {line:?}", cam.display());
        (v[0], v[3])
    }

    fn check_middlebury_gt(name: &str) -> Map {
        let root = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/data/middlebury2014"
        ));
        let gt = root.join(name).join("gt/00000000.pfm");
        let cam = root.join(name).join("cams/00000000_cam.txt");
        assert!(
            gt.is_file(),
            "shared data missing: {} (the Middlebury 2014 test data)",
            gt.display()
        );
        let m = read_pfm(&gt).unwrap();
        assert_eq!(m.channels, 1);
        let (min, max) = depth_range(&cam);
        let tol = 1e-3 * max;
        let mut nonzero = 0usize;
        for &d in &m.data {
            assert!(d.is_finite(), "{name}: non-finite GT depth {d}");
            if d != 0.0 {
                nonzero += 1;
                assert!(
                    d >= min - tol && d <= max + tol,
                    "{name}: GT depth {d} outside the cam range {min}..{max}"
                );
            }
        }
        // Orientation on real data: these scenes have the floor/table near the camera at the
        // image bottom and the background at the top, so a correctly flipped map is deeper at
        // the top.
        let band_mean = |rows: std::ops::Range<u32>| {
            let v: Vec<f32> = rows
                .flat_map(|y| (0..m.width).map(move |x| (x, y)))
                .map(|(x, y)| m.get(x, y, 0))
                .filter(|&d| d != 0.0)
                .collect();
            v.iter().sum::<f32>() / v.len() as f32
        };
        let (top, bottom) = (band_mean(0..20), band_mean(m.height - 20..m.height));
        assert!(
            top > bottom,
            "{name}: top rows (mean depth {top}) should be farther than bottom rows ({bottom}); \
             the PFM rows were not flipped"
        );
        let share = nonzero as f64 / m.data.len() as f64;
        assert!(
            share > 0.5,
            "{name}: only {:.1}% of GT pixels are nonzero",
            share * 100.0
        );
        m
    }

    #[test]
    fn pfm_reads_middlebury_teddy_gt() {
        let m = check_middlebury_gt("Teddy");
        assert_eq!((m.width, m.height), (450, 375));
    }

    #[test]
    fn pfm_reads_middlebury_adirondack_gt() {
        let m = check_middlebury_gt("Adirondack");
        assert_eq!((m.width, m.height), (718, 496));
    }

    #[test]
    fn pfm_reads_middlebury_artl_gt() {
        let m = check_middlebury_gt("ArtL");
        assert_eq!((m.width, m.height), (347, 277));
    }
}
