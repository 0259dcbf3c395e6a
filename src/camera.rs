//! Pinhole cameras: the one place that states mvscope's conventions.
//!
//! # Conventions
//!
//! * **Pixel centres sit on integer coordinates.** Pixel `(i, j)` (column `i`, row `j`) covers the
//!   square `[i - 0.5, i + 0.5) x [j - 0.5, j + 0.5)` of the image plane and its centre is the
//!   point `(i, j)`. The top-left corner of the image is `(-0.5, -0.5)`. This is the convention of
//!   the ACMM / MVSNet cam files, OpenCV, Middlebury and Strecha; COLMAP puts the centre of the
//!   top-left pixel at `(0.5, 0.5)`, so its principal point is shifted by `-0.5` on import and
//!   `+0.5` on export (see `scene::colmap`).
//! * **`camera_from_world`**: a world point `X` has camera coordinates `R X + t` (the cam file's
//!   `extrinsic` matrix). The camera looks down `+z`, `x` to the right, `y` down.
//! * **Depth** is the camera-frame `z` of a point, not its distance along the ray.
//! * **Rescaling** an image from `w x h` to `w' x h'` maps the continuous coordinate `u` (pixel
//!   centres on integers) to `(u + 0.5) * w'/w - 0.5`: the image borders stay on the borders.
//!   [`Camera::rescaled`] applies exactly this to `K`, and `image::Image::resized` resamples
//!   the pixels with the same mapping.

use glam::{DMat3, DVec2, DVec3};
use serde::{Deserialize, Serialize};

/// Intrinsics of a pinhole camera without skew (skew is ignored, as in the original ACMM).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
}

impl Intrinsics {
    pub fn matrix(&self) -> DMat3 {
        DMat3::from_cols(
            DVec3::new(self.fx, 0.0, 0.0),
            DVec3::new(0.0, self.fy, 0.0),
            DVec3::new(self.cx, self.cy, 1.0),
        )
    }
}

/// A calibrated pinhole camera with its image size.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub intrinsics: Intrinsics,
    /// Rotation of `camera_from_world` (`X_cam = R X_world + t`).
    pub rotation: DMat3,
    /// Translation of `camera_from_world`.
    pub translation: DVec3,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// Camera centre in world coordinates (`-R^T t`).
    pub fn center(&self) -> DVec3 {
        -(self.rotation.transpose() * self.translation)
    }

    /// World point to camera frame.
    pub fn camera_from_world(&self, pos_in_world: DVec3) -> DVec3 {
        self.rotation * pos_in_world + self.translation
    }

    /// Camera frame to world.
    pub fn world_from_camera(&self, pos_in_camera: DVec3) -> DVec3 {
        self.rotation.transpose() * (pos_in_camera - self.translation)
    }

    /// Direction a camera-frame vector has in the world frame (normals, rays).
    pub fn dir_world_from_camera(&self, dir_in_camera: DVec3) -> DVec3 {
        self.rotation.transpose() * dir_in_camera
    }

    /// Direction a world-frame vector has in the camera frame.
    pub fn dir_camera_from_world(&self, dir_in_world: DVec3) -> DVec3 {
        self.rotation * dir_in_world
    }

    /// Viewing direction (`+z` of the camera) in the world frame.
    pub fn forward(&self) -> DVec3 {
        self.rotation.row(2)
    }

    /// Camera-frame point to pixel coordinates; `None` when it is not in front of the camera.
    pub fn pixel_from_camera(&self, pos_in_camera: DVec3) -> Option<DVec2> {
        if pos_in_camera.z <= 0.0 {
            return None;
        }
        let k = &self.intrinsics;
        Some(DVec2::new(
            k.fx * pos_in_camera.x / pos_in_camera.z + k.cx,
            k.fy * pos_in_camera.y / pos_in_camera.z + k.cy,
        ))
    }

    /// Projects a world point: pixel coordinates and depth, `None` behind the camera.
    pub fn project(&self, pos_in_world: DVec3) -> Option<(DVec2, f64)> {
        let pos_in_camera = self.camera_from_world(pos_in_world);
        self.pixel_from_camera(pos_in_camera)
            .map(|pixel| (pixel, pos_in_camera.z))
    }

    /// Camera-frame ray through a pixel, scaled so that its `z` is 1.
    pub fn ray_in_camera(&self, pixel: DVec2) -> DVec3 {
        let k = &self.intrinsics;
        DVec3::new((pixel.x - k.cx) / k.fx, (pixel.y - k.cy) / k.fy, 1.0)
    }

    /// The camera-frame point at `depth` (camera `z`) seen through `pixel`.
    pub fn unproject_to_camera(&self, pixel: DVec2, depth: f64) -> DVec3 {
        self.ray_in_camera(pixel) * depth
    }

    /// The world point at `depth` (camera `z`) seen through `pixel`.
    pub fn unproject(&self, pixel: DVec2, depth: f64) -> DVec3 {
        self.world_from_camera(self.unproject_to_camera(pixel, depth))
    }

    /// Whether pixel coordinates fall on the image (within the outer pixel borders).
    pub fn contains(&self, pixel: DVec2) -> bool {
        pixel.x >= -0.5
            && pixel.y >= -0.5
            && pixel.x < self.width as f64 - 0.5
            && pixel.y < self.height as f64 - 0.5
    }

    /// The same camera for the image resampled to `width x height` (see the module docs).
    pub fn rescaled(&self, width: u32, height: u32) -> Camera {
        let sx = width as f64 / self.width as f64;
        let sy = height as f64 / self.height as f64;
        let k = &self.intrinsics;
        Camera {
            intrinsics: Intrinsics {
                fx: k.fx * sx,
                fy: k.fy * sy,
                cx: (k.cx + 0.5) * sx - 0.5,
                cy: (k.cy + 0.5) * sy - 0.5,
            },
            width,
            height,
            ..*self
        }
    }

    /// Checks what a loader must not accept: non-finite numbers, a singular `K`, a rotation that
    /// is not one, an empty image. Returns a sentence saying what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        let k = &self.intrinsics;
        let numbers = [k.fx, k.fy, k.cx, k.cy]
            .into_iter()
            .chain(self.rotation.to_cols_array())
            .chain(self.translation.to_array());
        if numbers.into_iter().any(|x| !x.is_finite()) {
            return Err("the camera has a non-finite number (NaN or infinity)".into());
        }
        if k.fx.abs() < 1e-9 || k.fy.abs() < 1e-9 {
            return Err(format!(
                "the intrinsic matrix K is singular (fx = {}, fy = {})",
                k.fx, k.fy
            ));
        }
        if k.fx <= 0.0 || k.fy <= 0.0 {
            return Err(format!(
                "the focal lengths must be positive (fx = {}, fy = {})",
                k.fx, k.fy
            ));
        }
        let r = self.rotation;
        let gram = r.transpose() * r;
        let off = (gram - DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        // Published calibrations are orthonormal to about 1e-6; 1e-3 catches a wrong matrix
        // (a scaled one, a transposed projection, a typo) without refusing real data.
        if off > 1e-3 || (r.determinant() - 1.0).abs() > 1e-3 {
            return Err(format!(
                "the rotation is not a rotation matrix (|R^T R - I| = {off:.2e}, det R = {:.4})",
                r.determinant()
            ));
        }
        if self.width == 0 || self.height == 0 {
            return Err(format!(
                "the image size {}x{} is empty",
                self.width, self.height
            ));
        }
        Ok(())
    }

    /// Makes `rotation` exactly orthonormal (nearest rotation by Gram-Schmidt on its rows), so
    /// calibrations that are rotations only to 1e-6 do not drift through repeated use.
    pub fn orthonormalized(mut self) -> Camera {
        let r0 = self.rotation.row(0).normalize();
        let r1 = (self.rotation.row(1) - r0 * r0.dot(self.rotation.row(1))).normalize();
        let r2 = r0.cross(r1);
        self.rotation = DMat3::from_cols(r0, r1, r2).transpose();
        self
    }

    /// A camera at `eye` looking at `target` with `up` roughly up in the image (`-y`).
    pub fn look_at(
        intrinsics: Intrinsics,
        width: u32,
        height: u32,
        eye: DVec3,
        target: DVec3,
        up: DVec3,
    ) -> Camera {
        let z = (target - eye).normalize();
        let x = z.cross(up).normalize();
        let y = z.cross(x);
        // Rows of camera_from_world are the camera axes in world coordinates; y points down.
        let rotation = DMat3::from_cols(x, y, z).transpose();
        Camera {
            intrinsics,
            rotation,
            translation: -(rotation * eye),
            width,
            height,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_camera() -> Camera {
        Camera::look_at(
            Intrinsics {
                fx: 100.0,
                fy: 110.0,
                cx: 63.5,
                cy: 47.5,
            },
            128,
            96,
            DVec3::new(1.0, -0.5, -4.0),
            DVec3::new(0.2, 0.1, 0.3),
            DVec3::new(0.0, -1.0, 0.0),
        )
    }

    #[test]
    fn principal_point_is_where_the_optical_axis_lands() {
        let cam = test_camera();
        let on_axis = cam.center() + cam.forward() * 3.0;
        let (pixel, depth) = cam.project(on_axis).expect("in front");
        assert!((pixel - DVec2::new(63.5, 47.5)).length() < 1e-9);
        assert!((depth - 3.0).abs() < 1e-9);
    }

    #[test]
    fn pixel_centres_are_integers_and_borders_are_half_pixels() {
        let cam = test_camera();
        assert!(cam.contains(DVec2::new(-0.5, -0.5)));
        assert!(cam.contains(DVec2::new(127.49, 95.49)));
        assert!(!cam.contains(DVec2::new(127.5, 10.0)));
        assert!(!cam.contains(DVec2::new(10.0, -0.51)));
    }

    #[test]
    fn project_unproject_round_trip() {
        let cam = test_camera();
        for (u, v, d) in [(0.0, 0.0, 1.0), (127.0, 95.0, 7.5), (40.25, 13.75, 2.0)] {
            let world = cam.unproject(DVec2::new(u, v), d);
            let (pixel, depth) = cam.project(world).expect("in front");
            assert!((pixel - DVec2::new(u, v)).length() < 1e-9);
            assert!((depth - d).abs() < 1e-9);
        }
        assert!(
            cam.project(cam.center() - cam.forward()).is_none(),
            "a point behind the camera does not project"
        );
    }

    #[test]
    fn look_at_has_y_down_and_is_a_rotation() {
        let cam = test_camera();
        assert!(cam.validate().is_ok());
        // A point above the target (world up is -y here) appears higher in the image.
        let target = DVec3::new(0.2, 0.1, 0.3);
        let above = target + DVec3::new(0.0, -1.0, 0.0) * 0.1;
        let (p_target, _) = cam.project(target).expect("visible");
        let (p_above, _) = cam.project(above).expect("visible");
        assert!(p_above.y < p_target.y);
    }

    #[test]
    fn rescaling_keeps_image_borders_on_borders() {
        let cam = test_camera();
        let half = cam.rescaled(64, 48);
        // The outer corner of the image is the outer corner at any scale.
        let world = cam.unproject(DVec2::new(-0.5, -0.5), 2.0);
        let (p, _) = half.project(world).expect("visible");
        assert!((p - DVec2::new(-0.5, -0.5)).length() < 1e-9);
        let world = cam.unproject(DVec2::new(127.5, 95.5), 2.0);
        let (p, _) = half.project(world).expect("visible");
        assert!((p - DVec2::new(63.5, 47.5)).length() < 1e-9);
        // The centre of fine pixels (0,0),(1,0),(0,1),(1,1) is the centre of coarse pixel (0,0).
        let world = cam.unproject(DVec2::new(0.5, 0.5), 2.0);
        let (p, _) = half.project(world).expect("visible");
        assert!(p.length() < 1e-9);
        // Round trip.
        let back = half.rescaled(128, 96);
        assert!((back.intrinsics.cx - cam.intrinsics.cx).abs() < 1e-12);
        assert!((back.intrinsics.fy - cam.intrinsics.fy).abs() < 1e-12);
    }

    #[test]
    fn validate_rejects_bad_cameras() {
        let good = test_camera();
        let mut c = good;
        c.intrinsics.fx = 0.0;
        assert!(c.validate().unwrap_err().contains("singular"));
        let mut c = good;
        c.rotation *= 2.0;
        assert!(c.validate().unwrap_err().contains("not a rotation"));
        let mut c = good;
        c.translation.x = f64::NAN;
        assert!(c.validate().unwrap_err().contains("non-finite"));
        let mut c = good;
        c.rotation = -c.rotation; // a reflection: orthogonal but det = -1
        assert!(c.validate().is_err());
    }

    #[test]
    fn orthonormalize_fixes_small_drift() {
        let mut cam = test_camera();
        cam.rotation.x_axis.x += 1e-6;
        let fixed = cam.orthonormalized();
        let gram = fixed.rotation.transpose() * fixed.rotation;
        assert!((gram - DMat3::IDENTITY).abs_diff_eq(DMat3::ZERO, 1e-12));
        assert!((fixed.rotation - cam.rotation).abs_diff_eq(DMat3::ZERO, 1e-5));
    }
}
