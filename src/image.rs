//! Images as mvscope keeps them: colour for fusion and display, grayscale 0..255 floats for
//! matching (the original ACMM matches on grayscale intensity 0..255).

use std::path::Path;

use crate::error::SceneError;

/// An RGB image with its grayscale twin.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Row-major colour pixels.
    pub rgb: Vec<[u8; 3]>,
    /// Row-major intensity in 0..255 (ITU-R BT.601 luma of `rgb`, before rounding).
    pub gray: Vec<f32>,
}

/// BT.601 luma, the weights OpenCV's RGB-to-gray uses (what the original's image loading did).
pub fn luma(rgb: [f32; 3]) -> f32 {
    0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2]
}

impl Image {
    pub fn from_rgb(width: u32, height: u32, rgb: Vec<[u8; 3]>) -> Image {
        let gray = rgb
            .iter()
            .map(|p| luma([p[0] as f32, p[1] as f32, p[2] as f32]))
            .collect();
        Image {
            width,
            height,
            rgb,
            gray,
        }
    }

    /// An image from linear float colour in 0..255 (the synthetic renderer's output), rounded
    /// to 8 bits as a camera's PNG holds it: `gray` is the luma of the rounded colour, so the
    /// image is exactly the one its PNG loads back as. (Until the twenty-sixth session `gray`
    /// kept the unrounded intensity, a texture finer than any 8-bit photo: the accuracy suite's
    /// synthetic scenes then scored differently from the same scene written by `mvscope demo`.)
    pub fn from_rgb_f32(width: u32, height: u32, rgb: &[[f32; 3]]) -> Image {
        let to_u8 = |x: f32| x.round().clamp(0.0, 255.0) as u8;
        Image::from_rgb(
            width,
            height,
            rgb.iter()
                .map(|p| [to_u8(p[0]), to_u8(p[1]), to_u8(p[2])])
                .collect(),
        )
    }

    /// Decodes an image file (PNG, JPEG; 8 or 16 bit, gray or colour).
    pub fn load(path: &Path) -> Result<Image, SceneError> {
        let decoded = reader(path)?
            .with_guessed_format()
            .map_err(|e| SceneError::io(path, e))?
            .decode()
            .map_err(|e| {
                SceneError::file(
                    path,
                    format!("the image does not decode ({e}); replace it with a valid PNG or JPEG"),
                )
            })?;
        let rgb8 = decoded.to_rgb8();
        let (width, height) = rgb8.dimensions();
        let rgb = rgb8.pixels().map(|p| p.0).collect();
        Ok(Image::from_rgb(width, height, rgb))
    }

    /// Width and height from the file header, without decoding the pixels.
    pub fn dimensions(path: &Path) -> Result<(u32, u32), SceneError> {
        reader(path)?
            .with_guessed_format()
            .map_err(|e| SceneError::io(path, e))?
            .into_dimensions()
            .map_err(|e| {
                SceneError::file(
                    path,
                    format!("the image header does not decode ({e}); replace it with a valid PNG or JPEG"),
                )
            })
    }

    /// Writes the colour image as a PNG (atomically).
    pub fn save_png(&self, path: &Path) -> Result<(), crate::io::IoError> {
        let flat: Vec<u8> = self.rgb.iter().flatten().copied().collect();
        crate::io::write_png(path, self.width, self.height, 3, &flat)
    }

    /// Resamples to `width x height` with the convention of `camera.rs` (borders stay borders),
    /// averaging each output pixel over the input area it covers. Exact for downscaling (a 2x
    /// reduction averages 2x2 blocks); upscaling degrades to nearest-neighbour-like sampling.
    pub fn resized(&self, width: u32, height: u32) -> Image {
        if width == self.width && height == self.height {
            return self.clone();
        }
        if self.gray.is_empty() {
            // An image known by its size only (a scene loaded without pixels).
            return Image {
                width,
                height,
                rgb: Vec::new(),
                gray: Vec::new(),
            };
        }
        let wx = area_weights(self.width, width);
        let wy = area_weights(self.height, height);
        let src_w = self.width as usize;
        let mut rgb = Vec::with_capacity(width as usize * height as usize);
        let mut gray = Vec::with_capacity(width as usize * height as usize);
        for row_weights in &wy {
            for col_weights in &wx {
                let mut acc = [0.0f64; 4];
                for &(y, wyv) in row_weights {
                    for &(x, wxv) in col_weights {
                        let i = y * src_w + x;
                        let w = wyv * wxv;
                        let p = self.rgb[i];
                        acc[0] += w * p[0] as f64;
                        acc[1] += w * p[1] as f64;
                        acc[2] += w * p[2] as f64;
                        acc[3] += w * self.gray[i] as f64;
                    }
                }
                let to_u8 = |x: f64| x.round().clamp(0.0, 255.0) as u8;
                rgb.push([to_u8(acc[0]), to_u8(acc[1]), to_u8(acc[2])]);
                gray.push(acc[3] as f32);
            }
        }
        Image {
            width,
            height,
            rgb,
            gray,
        }
    }
}

/// For each output sample, the input samples it overlaps and their normalised weights.
fn area_weights(src: u32, dst: u32) -> Vec<Vec<(usize, f64)>> {
    let scale = src as f64 / dst as f64; // input pixels per output pixel
    (0..dst)
        .map(|i| {
            let lo = i as f64 * scale;
            let hi = (i as f64 + 1.0) * scale;
            let (lo, hi) = if scale < 1.0 {
                // Upscaling: use the input pixel under the output centre.
                let c = (lo + hi) * 0.5;
                (c.floor(), c.floor() + 1.0)
            } else {
                (lo, hi)
            };
            let mut weights = Vec::new();
            let mut x = lo.floor() as i64;
            while (x as f64) < hi {
                let overlap = (hi.min(x as f64 + 1.0) - lo.max(x as f64)).max(0.0);
                if overlap > 1e-12 {
                    let xi = x.clamp(0, src as i64 - 1) as usize;
                    weights.push((xi, overlap));
                }
                x += 1;
            }
            let total: f64 = weights.iter().map(|w| w.1).sum();
            weights.iter_mut().for_each(|w| w.1 /= total);
            weights
        })
        .collect()
}

/// A reader of the image file at `path` (on disk, or among the files a scene was given in
/// memory: `crate::vfs`).
fn reader(path: &Path) -> Result<image::ImageReader<std::io::Cursor<Vec<u8>>>, SceneError> {
    let bytes = crate::vfs::read(path).map_err(|e| SceneError::io(path, e))?;
    Ok(image::ImageReader::new(std::io::Cursor::new(bytes)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halving_averages_2x2_blocks() {
        let rgb: Vec<[u8; 3]> = (0..16u8).map(|i| [i * 10, 0, 255 - i]).collect();
        let img = Image::from_rgb(4, 4, rgb);
        let half = img.resized(2, 2);
        // Block (0,0) holds pixels 0,1,4,5 -> mean 2.5 -> red 25.
        assert_eq!(half.rgb[0][0], 25);
        assert!(
            (half.gray[0] - (img.gray[0] + img.gray[1] + img.gray[4] + img.gray[5]) / 4.0).abs()
                < 1e-4
        );
        assert_eq!(
            half.rgb[3][0],
            ((10 + 11 + 14 + 15) as f64 * 10.0 / 4.0).round() as u8
        );
    }

    #[test]
    fn non_integer_factor_keeps_mean_intensity() {
        let rgb: Vec<[u8; 3]> = (0..(30 * 20)).map(|i| [(i % 251) as u8, 7, 9]).collect();
        let img = Image::from_rgb(30, 20, rgb);
        let small = img.resized(17, 11);
        let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
        assert!((mean(&img.gray) - mean(&small.gray)).abs() < 0.5);
        assert_eq!(small.rgb.len(), 17 * 11);
    }

    #[test]
    fn gray_is_bt601_luma() {
        let img = Image::from_rgb(1, 1, vec![[255, 0, 0]]);
        assert!((img.gray[0] - 76.245).abs() < 1e-3);
    }
}
