//! PNG output (images, masks, visualisations), written atomically.

use std::path::Path;

use image::ImageEncoder;

use super::{IoError, write_atomic};

/// Writes 8-bit pixels (`channels` = 1 gray, 3 RGB, 4 RGBA) as a PNG.
pub fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    channels: u32,
    bytes: &[u8],
) -> Result<(), IoError> {
    let color = match channels {
        1 => image::ExtendedColorType::L8,
        3 => image::ExtendedColorType::Rgb8,
        4 => image::ExtendedColorType::Rgba8,
        _ => {
            return Err(IoError::invalid(
                path,
                format!("a PNG holds 1, 3 or 4 channels, not {channels}"),
            ));
        }
    };
    if bytes.len() as u64 != width as u64 * height as u64 * channels as u64 {
        return Err(IoError::invalid(
            path,
            format!(
                "{} bytes do not make a {width}x{height} image with {channels} channel(s)",
                bytes.len()
            ),
        ));
    }
    write_atomic(path, |w| {
        image::codecs::png::PngEncoder::new(w)
            .write_image(bytes, width, height, color)
            .map_err(std::io::Error::other)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gray_png_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.png");
        let bytes: Vec<u8> = (0..12u8).map(|i| i * 20).collect();
        write_png(&path, 4, 3, 1, &bytes).unwrap();
        let back = image::open(&path).unwrap().to_luma8();
        assert_eq!(back.dimensions(), (4, 3));
        assert_eq!(back.into_raw(), bytes);
        assert!(write_png(&path, 5, 3, 1, &bytes).is_err());
    }
}
