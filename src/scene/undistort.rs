//! Lens distortion of COLMAP's camera models, its numerical inverse, and the resampling of a
//! distorted image to an undistorted pinhole camera (what `colmap image_undistorter` does
//! before dense matching; mvscope does it on load).
//!
//! Distortion acts on normalised pinhole coordinates `(u, v) = ((x - cx) / fx, (y - cy) / fy)`
//! and gives the normalised coordinates where the lens put the point (COLMAP's conventions):
//!
//! * `SIMPLE_RADIAL` (k), `RADIAL` (k1, k2), `OPENCV` (k1, k2, p1, p2) and `FULL_OPENCV` (k1,
//!   k2, p1, p2, k3, k4, k5, k6) are one model: radial factor `(1 + k1 r² + k2 r⁴ + k3 r⁶) /
//!   (1 + k4 r² + k5 r⁴ + k6 r⁶)` plus tangential terms `2 p1 u v + p2 (r² + 2u²)`, `p1 (r² +
//!   2v²) + 2 p2 u v`.
//! * `OPENCV_FISHEYE` (k1..k4): the equidistant model, `θ = atan(r)`, `θ_d = θ (1 + k1 θ² + k2
//!   θ⁴ + k3 θ⁶ + k4 θ⁸)`, `(u, v) θ_d / r`.
//!
//! The undistorted image keeps the size, focal lengths and principal point of the original
//! (the whole image with a blank border where the lens saw nothing: 0, which matches no
//! texture) — COLMAP's undistorter can also crop to the largest valid rectangle; mvscope keeps
//! every pixel so depth maps stay aligned with the user's images. `mvscope run` caches the
//! resampled images in its output folder (`undistorted/`), never in the input folder. The inverse (a distorted
//! pixel to the undistorted one, e.g. for sparse observations) is solved by Newton's method.

use crate::image::Image;

/// A lens distortion in normalised coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Distortion {
    /// SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV (missing coefficients are 0).
    OpenCv { k: [f64; 6], p: [f64; 2] },
    /// OPENCV_FISHEYE.
    Fisheye { k: [f64; 4] },
}

impl Distortion {
    /// Where the lens puts the normalised point `(u, v)`.
    pub fn distort(&self, u: f64, v: f64) -> (f64, f64) {
        match *self {
            Distortion::OpenCv { k, p } => {
                let r2 = u * u + v * v;
                let r4 = r2 * r2;
                let r6 = r4 * r2;
                let radial = (1.0 + k[0] * r2 + k[1] * r4 + k[2] * r6)
                    / (1.0 + k[3] * r2 + k[4] * r4 + k[5] * r6);
                (
                    u * radial + 2.0 * p[0] * u * v + p[1] * (r2 + 2.0 * u * u),
                    v * radial + p[0] * (r2 + 2.0 * v * v) + 2.0 * p[1] * u * v,
                )
            }
            Distortion::Fisheye { k } => {
                let r = (u * u + v * v).sqrt();
                if r < 1e-12 {
                    return (u, v);
                }
                let theta = r.atan();
                let t2 = theta * theta;
                let thetad = theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
                (u * thetad / r, v * thetad / r)
            }
        }
    }

    /// The normalised point the lens put at `(ud, vd)`: Newton's method on `distort` with a
    /// central-difference Jacobian. `None` when it does not converge to 1e-12.
    pub fn undistort(&self, ud: f64, vd: f64) -> Option<(f64, f64)> {
        let (mut u, mut v) = (ud, vd);
        let h = 1e-7;
        for _ in 0..50 {
            let (du, dv) = self.distort(u, v);
            let (ex, ey) = (du - ud, dv - vd);
            if ex * ex + ey * ey < 1e-24 {
                return Some((u, v));
            }
            let (a1, a2) = self.distort(u + h, v);
            let (b1, b2) = self.distort(u - h, v);
            let (c1, c2) = self.distort(u, v + h);
            let (d1, d2) = self.distort(u, v - h);
            let j = [
                [(a1 - b1) / (2.0 * h), (c1 - d1) / (2.0 * h)],
                [(a2 - b2) / (2.0 * h), (c2 - d2) / (2.0 * h)],
            ];
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if !det.is_finite() || det.abs() < 1e-12 {
                return None;
            }
            u -= (j[1][1] * ex - j[0][1] * ey) / det;
            v -= (-j[1][0] * ex + j[0][0] * ey) / det;
            if !(u.is_finite() && v.is_finite()) {
                return None;
            }
        }
        let (du, dv) = self.distort(u, v);
        ((du - ud).powi(2) + (dv - vd).powi(2) < 1e-20).then_some((u, v))
    }

    /// Whether the distortion folds the image (stops growing with the radius) anywhere within
    /// normalised radius `max_r`, along the axes and diagonals: such an image cannot be
    /// undistorted one to one.
    pub fn folds_within(&self, max_r: f64) -> bool {
        let steps = 400;
        let d = std::f64::consts::FRAC_1_SQRT_2;
        for (cx, cy) in [(1.0, 0.0), (0.0, 1.0), (d, d), (-d, d)] {
            let mut last = 0.0f64;
            for i in 1..=steps {
                let r = max_r * i as f64 / steps as f64;
                let (du, dv) = self.distort(r * cx, r * cy);
                let rd = (du * du + dv * dv).sqrt();
                if !rd.is_finite() || rd <= last {
                    return true;
                }
                last = rd;
            }
        }
        false
    }
}

/// A distorted camera: pinhole intrinsics (mvscope's convention: the top-left pixel's centre
/// at (0, 0)) and its distortion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub distortion: Distortion,
}

impl Lens {
    /// Where the lens images the pixel `(x, y)` of the undistorted pinhole camera.
    pub fn distort_pixel(&self, x: f64, y: f64) -> (f64, f64) {
        let (u, v) = self
            .distortion
            .distort((x - self.cx) / self.fx, (y - self.cy) / self.fy);
        (u * self.fx + self.cx, v * self.fy + self.cy)
    }

    /// The undistorted pixel of the distorted pixel `(x, y)`.
    pub fn undistort_pixel(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let (u, v) = self
            .distortion
            .undistort((x - self.cx) / self.fx, (y - self.cy) / self.fy)?;
        Some((u * self.fx + self.cx, v * self.fy + self.cy))
    }

    /// The largest normalised radius of a `width x height` image's corners.
    pub fn max_radius(&self, width: u32, height: u32) -> f64 {
        let mut r: f64 = 0.0;
        for (x, y) in [
            (0.0, 0.0),
            (width as f64 - 1.0, 0.0),
            (0.0, height as f64 - 1.0),
            (width as f64 - 1.0, height as f64 - 1.0),
        ] {
            let u = (x - self.cx) / self.fx;
            let v = (y - self.cy) / self.fy;
            r = r.max((u * u + v * v).sqrt());
        }
        r
    }

    /// `image` resampled to the undistorted pinhole camera of the same size and intrinsics
    /// (bilinear; 0 where the lens saw nothing).
    pub fn undistort_image(&self, image: &Image) -> Image {
        let (w, h) = (image.width as usize, image.height as usize);
        let mut rgb = vec![[0.0f32; 3]; w * h];
        let at = |x: usize, y: usize| image.rgb[y * w + x];
        for y in 0..h {
            for x in 0..w {
                let (sx, sy) = self.distort_pixel(x as f64, y as f64);
                if !(sx >= 0.0 && sy >= 0.0 && sx <= (w - 1) as f64 && sy <= (h - 1) as f64) {
                    continue;
                }
                let (x0, y0) = (sx.floor() as usize, sy.floor() as usize);
                let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
                let (fx, fy) = ((sx - x0 as f64) as f32, (sy - y0 as f64) as f32);
                let mut out = [0.0f32; 3];
                for (c, o) in out.iter_mut().enumerate() {
                    let a = at(x0, y0)[c] as f32;
                    let b = at(x1, y0)[c] as f32;
                    let d = at(x0, y1)[c] as f32;
                    let e = at(x1, y1)[c] as f32;
                    let top = a + (b - a) * fx;
                    let bottom = d + (e - d) * fx;
                    *o = top + (bottom - top) * fy;
                }
                rgb[y * w + x] = out;
            }
        }
        // Rounded to 8 bits before the intensities are taken, so a cached copy (PNG) of the
        // result is the same image.
        let to_u8 = |x: f32| x.round().clamp(0.0, 255.0) as u8;
        let rgb = rgb
            .iter()
            .map(|p| [to_u8(p[0]), to_u8(p[1]), to_u8(p[2])])
            .collect();
        Image::from_rgb(image.width, image.height, rgb)
    }

    /// A key for a cached undistortion of the image at `path` through this lens: the path,
    /// the file's size and modification time, and the lens (FNV-1a, stable across builds).
    pub fn cache_key(&self, path: &std::path::Path) -> u64 {
        let meta = std::fs::metadata(path).ok();
        let modified = meta
            .as_ref()
            .and_then(|m| m.modified().ok())
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos());
        let text = format!(
            "{}|{}|{modified}|{self:?}",
            path.display(),
            meta.map_or(0, |m| m.len())
        );
        text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lenses() -> Vec<(&'static str, Lens)> {
        let lens = |distortion| Lens {
            fx: 500.0,
            fy: 510.0,
            cx: 319.5,
            cy: 239.5,
            distortion,
        };
        vec![
            (
                "SIMPLE_RADIAL",
                lens(Distortion::OpenCv {
                    k: [-0.08, 0.0, 0.0, 0.0, 0.0, 0.0],
                    p: [0.0; 2],
                }),
            ),
            (
                "RADIAL",
                lens(Distortion::OpenCv {
                    k: [-0.1, 0.03, 0.0, 0.0, 0.0, 0.0],
                    p: [0.0; 2],
                }),
            ),
            (
                "OPENCV",
                lens(Distortion::OpenCv {
                    k: [-0.12, 0.04, 0.0, 0.0, 0.0, 0.0],
                    p: [0.001, -0.0007],
                }),
            ),
            (
                "FULL_OPENCV",
                lens(Distortion::OpenCv {
                    k: [-0.12, 0.04, 0.002, 0.01, -0.003, 0.0005],
                    p: [0.0008, 0.0005],
                }),
            ),
            (
                "OPENCV_FISHEYE",
                lens(Distortion::Fisheye {
                    k: [0.03, -0.01, 0.002, -0.0003],
                }),
            ),
        ]
    }

    #[test]
    fn distort_of_undistort_is_the_identity_over_the_whole_image() {
        for (name, lens) in lenses() {
            let mut worst: f64 = 0.0;
            for y in (0..480).step_by(7) {
                for x in (0..640).step_by(7) {
                    let (x, y) = (x as f64, y as f64);
                    let (ux, uy) = lens
                        .undistort_pixel(x, y)
                        .unwrap_or_else(|| panic!("{name}: ({x}, {y}) does not invert"));
                    let (dx, dy) = lens.distort_pixel(ux, uy);
                    worst = worst.max((dx - x).hypot(dy - y));
                }
            }
            assert!(worst < 1e-3, "{name}: {worst} px");
            assert!(
                !lens.distortion.folds_within(lens.max_radius(640, 480)),
                "{name}"
            );
        }
    }

    #[test]
    fn a_strong_barrel_folds() {
        let d = Distortion::OpenCv {
            k: [-0.6, 0.0, 0.0, 0.0, 0.0, 0.0],
            p: [0.0; 2],
        };
        // r (1 - 0.6 r²) stops growing at r = 0.75.
        assert!(d.folds_within(1.0));
        assert!(!d.folds_within(0.7));
    }
}
