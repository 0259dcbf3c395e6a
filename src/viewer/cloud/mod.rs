//! The 3D view: a point cloud (per-view depth maps or the fused cloud) and the cameras' frusta,
//! drawn with mvscope's own wgpu pipeline inside an egui paint callback.
//!
//! [`CloudView::ui`] handles the orbit camera and adds the callback. The callback's `prepare`
//! renders into an offscreen colour + depth target the size of the view (points as instanced
//! screen-space squares, frusta as lines, `shaders/cloud.wgsl`); its `paint` copies that target
//! 1:1 into egui's render pass. [`render_offscreen`] runs the same draw code into a texture it
//! reads back (tests, screenshots). [`project_point`] and [`point_color`] are the CPU references
//! of the vertex and fragment shaders.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Weak};

use glam::{DVec2, Mat4, Vec3, Vec4Swizzles};

use crate::camera::Camera;
use crate::gpu::{GpuContext, GpuError};
use crate::io::ply::PlyPoint;
use crate::scene::View;

mod render;

pub use render::*;

/// Background of the 3D view (display values, 0..1).
pub const BACKGROUND: [f32; 3] = [0.08, 0.08, 0.08];

/// Format of the offscreen colour target: display (sRGB-encoded) values stored as they are.
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

const SHADER: &str = include_str!("../../../shaders/cloud.wgsl");

/// One point as the GPU reads it (an instance of `vs_point` in `shaders/cloud.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CloudVertex {
    /// World position.
    pub position: [f32; 3],
    /// Matching cost (ACMM's `1 - NCC`, 0 for fused points).
    pub cost: f32,
    /// RGB in 0..1 (display values).
    pub color: [f32; 3],
    pub _pad0: f32,
    /// World-frame unit normal (zero when unknown).
    pub normal: [f32; 3],
    pub _pad1: f32,
}

/// A camera drawn as a pyramid: its centre and the image corners at some depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    /// Camera centre (world).
    pub apex: [f32; 3],
    /// Image corners (world): top-left, top-right, bottom-right, bottom-left.
    pub corners: [[f32; 3]; 4],
    /// Line colour, RGB 0..1.
    pub color: [f32; 3],
}

impl Frustum {
    /// The frustum of `camera` with its image corners (outer pixel borders) at `depth`.
    pub fn from_camera(camera: &Camera, depth: f32, color: [f32; 3]) -> Frustum {
        let w = camera.width as f64;
        let h = camera.height as f64;
        let corner = |x: f64, y: f64| {
            camera
                .unproject(DVec2::new(x, y), depth as f64)
                .as_vec3()
                .to_array()
        };
        Frustum {
            apex: camera.center().as_vec3().to_array(),
            corners: [
                corner(-0.5, -0.5),
                corner(w - 0.5, -0.5),
                corner(w - 0.5, h - 0.5),
                corner(-0.5, h - 0.5),
            ],
            color,
        }
    }

    /// Viewing direction and image-up direction (world, unit, perpendicular); `None` when
    /// degenerate.
    fn axes(&self) -> Option<(Vec3, Vec3)> {
        let apex = Vec3::from(self.apex);
        let c = self.corners.map(Vec3::from);
        let forward = ((c[0] + c[1] + c[2] + c[3]) * 0.25 - apex).try_normalize()?;
        let up = c[0] - c[3];
        let up = (up - forward * up.dot(forward)).try_normalize()?;
        Some((forward, up))
    }
}

/// What a point's colour shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColorMode {
    /// The image colour.
    #[default]
    Rgb,
    /// The world normal as `n * 0.5 + 0.5`.
    Normal,
    /// The cost on a blue-cyan-yellow-red ramp over [`CloudView::cost_range`].
    Cost,
}

impl ColorMode {
    /// All modes, in menu order.
    pub const ALL: [ColorMode; 3] = [ColorMode::Rgb, ColorMode::Normal, ColorMode::Cost];

    /// Name shown in the UI.
    pub fn label(self) -> &'static str {
        match self {
            ColorMode::Rgb => "RGB",
            ColorMode::Normal => "normal",
            ColorMode::Cost => "cost",
        }
    }

    fn index(self) -> u32 {
        match self {
            ColorMode::Rgb => 0,
            ColorMode::Normal => 1,
            ColorMode::Cost => 2,
        }
    }
}

/// What the 3D view draws.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CloudScene {
    pub points: Vec<CloudVertex>,
    pub frusta: Vec<Frustum>,
    /// Bump it when the contents change: GPU buffers are re-uploaded only then (or when the
    /// view is given a different `Arc`).
    pub version: u64,
}

/// Back-projects a depth map computed at `width x height` for `view` (its camera rescaled to
/// that size). Pixels whose depth is not finite and positive are skipped; colours are the
/// nearest pixel of `view.image`; normals are rotated camera -> world. `normals_camera` and
/// `cost` may be shorter than the map (missing entries: zero normal, cost 0); a non-finite
/// cost becomes 2, ACMM's worst.
pub fn points_from_depth(
    view: &View,
    width: u32,
    height: u32,
    depth: &[f32],
    normals_camera: &[[f32; 3]],
    cost: &[f32],
) -> Vec<CloudVertex> {
    if width == 0 || height == 0 {
        return Vec::new();
    }
    let camera = view.camera.rescaled(width, height);
    let image = &view.image;
    let sx = image.width as f64 / width as f64;
    let sy = image.height as f64 / height as f64;
    let n = width as usize * height as usize;
    let mut points = Vec::new();
    for (i, &d) in depth.iter().enumerate().take(n) {
        if !(d.is_finite() && d > 0.0) {
            continue;
        }
        let x = i % width as usize;
        let y = i / width as usize;
        let world = camera.unproject(DVec2::new(x as f64, y as f64), d as f64);
        // Nearest image pixel under the same border-preserving mapping as Camera::rescaled.
        let ix = (((x as f64 + 0.5) * sx) as usize).min(image.width.saturating_sub(1) as usize);
        let iy = (((y as f64 + 0.5) * sy) as usize).min(image.height.saturating_sub(1) as usize);
        let color = image
            .rgb
            .get(iy * image.width as usize + ix)
            .map_or([0.5; 3], |p| p.map(|c| c as f32 / 255.0));
        let normal = normals_camera.get(i).map_or(Vec3::ZERO, |&n| {
            camera
                .dir_world_from_camera(Vec3::from(n).as_dvec3())
                .normalize_or_zero()
                .as_vec3()
        });
        let cost = cost
            .get(i)
            .map_or(0.0, |&c| if c.is_finite() { c } else { 2.0 });
        points.push(CloudVertex {
            position: world.as_vec3().to_array(),
            cost,
            color,
            _pad0: 0.0,
            normal: normal.to_array(),
            _pad1: 0.0,
        });
    }
    points
}

/// A fused cloud as 3D-view points (cost 0).
pub fn points_from_fusion(points: &[PlyPoint]) -> Vec<CloudVertex> {
    points
        .iter()
        .map(|p| CloudVertex {
            position: p.position,
            cost: 0.0,
            color: p.color.map(|c| c as f32 / 255.0),
            _pad0: 0.0,
            normal: p.normal,
            _pad1: 0.0,
        })
        .collect()
}

/// The blue -> cyan -> yellow -> red ramp of [`ColorMode::Cost`] at `t` in [0, 1].
pub fn cost_ramp(t: f32) -> [f32; 3] {
    let mix = |a: [f32; 3], b: [f32; 3], s: f32| {
        [
            a[0] + (b[0] - a[0]) * s,
            a[1] + (b[1] - a[1]) * s,
            a[2] + (b[2] - a[2]) * s,
        ]
    };
    const BLUE: [f32; 3] = [0.0, 0.0, 1.0];
    const CYAN: [f32; 3] = [0.0, 1.0, 1.0];
    const YELLOW: [f32; 3] = [1.0, 1.0, 0.0];
    const RED: [f32; 3] = [1.0, 0.0, 0.0];
    if t < 1.0 / 3.0 {
        mix(BLUE, CYAN, t * 3.0)
    } else if t < 2.0 / 3.0 {
        mix(CYAN, YELLOW, t * 3.0 - 1.0)
    } else {
        mix(YELLOW, RED, t * 3.0 - 2.0)
    }
}

/// CPU reference of the fragment colour: `Rgb` the point's colour, `Normal` `n * 0.5 + 0.5`,
/// `Cost` [`cost_ramp`] of `(cost - lo) / (hi - lo)` clamped to [0, 1] (0 when `hi <= lo`).
pub fn point_color(v: &CloudVertex, mode: ColorMode, cost_range: (f32, f32)) -> [f32; 3] {
    match mode {
        ColorMode::Rgb => v.color,
        ColorMode::Normal => v.normal.map(|n| n * 0.5 + 0.5),
        ColorMode::Cost => {
            let (lo, hi) = cost_range;
            let span = hi - lo;
            let t = if span > 0.0 {
                ((v.cost - lo) / span).clamp(0.0, 1.0)
            } else {
                0.0
            };
            cost_ramp(t)
        }
    }
}

/// CPU reference of the vertex shader: the pixel coordinates (x right, y down, pixel `(i, j)`
/// covering `[i, i+1) x [j, j+1)`, so its centre is at `+0.5`) of `position` in a `size` target,
/// or `None` when it is outside the view volume.
pub fn project_point(view_proj: Mat4, position: [f32; 3], size: [u32; 2]) -> Option<[f32; 2]> {
    let clip = view_proj * Vec3::from(position).extend(1.0);
    if clip.w <= 0.0 {
        return None;
    }
    let ndc = clip.xyz() / clip.w;
    if !(ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0 && (0.0..=1.0).contains(&ndc.z)) {
        return None;
    }
    Some([
        (ndc.x * 0.5 + 0.5) * size[0] as f32,
        (0.5 - ndc.y * 0.5) * size[1] as f32,
    ])
}

/// Radians of orbit per pixel dragged.
const ORBIT_PER_PIXEL: f32 = 0.006;
/// Zoom factor exponent per point scrolled (a wheel notch is ~50 points: ~10 %).
const ZOOM_PER_POINT: f32 = 0.002;
/// Pitch stays this far from straight up/down, where the view's roll is undefined.
const MAX_PITCH: f32 = std::f32::consts::FRAC_PI_2 - 0.01;

/// A turntable camera around `target`: yaw turns about `up`, pitch tilts towards it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// The point orbited around (centre of the screen).
    pub target: Vec3,
    /// Radians about `up`; positive turns the viewing direction towards the screen's right.
    pub yaw: f32,
    /// Radians; positive raises the eye (looks down on the target).
    pub pitch: f32,
    /// Eye to target.
    pub distance: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// World up (unit); the screen's up at pitch 0.
    pub up: Vec3,
    /// Viewing direction at yaw = pitch = 0 (unit, perpendicular to `up`).
    pub forward: Vec3,
    /// Size of the fitted scene: sets the far plane and the zoom limits.
    pub radius: f32,
}

impl Default for OrbitCamera {
    fn default() -> Self {
        OrbitCamera {
            target: Vec3::ZERO,
            yaw: 0.0,
            pitch: 0.0,
            distance: 3.0,
            fov_y: 45f32.to_radians(),
            up: Vec3::Y,
            forward: Vec3::NEG_Z,
            radius: 1.0,
        }
    }
}

impl OrbitCamera {
    /// Frames the 2-98 percentile box of the points (of the frusta when there are none) so that
    /// it fits the vertical field of view, looking along the first frustum's viewing direction
    /// with its image up (else along -z with +y up).
    pub fn fit(points: &[CloudVertex], frusta: &[Frustum]) -> OrbitCamera {
        let (forward, up) = frusta
            .first()
            .and_then(Frustum::axes)
            .unwrap_or((Vec3::NEG_Z, Vec3::Y));
        let mut camera = OrbitCamera {
            up,
            forward,
            ..OrbitCamera::default()
        };
        // At most ~100k samples: percentiles of a strided subset are as good and stay fast.
        let stride = points.len() / 100_000 + 1;
        let mut positions: Vec<Vec3> = points
            .iter()
            .step_by(stride)
            .map(|p| Vec3::from(p.position))
            .filter(|p| p.is_finite())
            .collect();
        if positions.is_empty() {
            positions = frusta
                .iter()
                .flat_map(|f| std::iter::once(f.apex).chain(f.corners))
                .map(Vec3::from)
                .filter(|p| p.is_finite())
                .collect();
        }
        if positions.is_empty() {
            return camera;
        }
        let mut lo = Vec3::ZERO;
        let mut hi = Vec3::ZERO;
        let mut axis: Vec<f32> = Vec::with_capacity(positions.len());
        for k in 0..3 {
            axis.clear();
            axis.extend(positions.iter().map(|p| p[k]));
            axis.sort_unstable_by(f32::total_cmp);
            let at = |q: f32| axis[((axis.len() - 1) as f32 * q).round() as usize];
            lo[k] = at(0.02);
            hi[k] = at(0.98);
        }
        let center = (lo + hi) * 0.5;
        // 10 % margin for the points beyond the percentiles and for the point size.
        let radius = ((hi - lo).length() * 0.5 * 1.1).max(1e-3 * center.length().max(1.0));
        camera.target = center;
        camera.radius = radius;
        camera.distance = radius / (camera.fov_y * 0.5).sin();
        camera
    }

    /// `up` and `forward` made unit and perpendicular (whatever the fields were set to).
    fn frame(&self) -> (Vec3, Vec3) {
        let up = self.up.try_normalize().unwrap_or(Vec3::Y);
        let forward = (self.forward - up * self.forward.dot(up))
            .try_normalize()
            .unwrap_or_else(|| up.any_orthonormal_vector());
        (up, forward)
    }

    /// Viewing direction (unit), right and screen-up vectors.
    fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let (up, forward) = self.frame();
        let right0 = forward.cross(up);
        let pitch = self.pitch.clamp(-MAX_PITCH, MAX_PITCH);
        let horizontal = forward * self.yaw.cos() + right0 * self.yaw.sin();
        let dir = horizontal * pitch.cos() - up * pitch.sin();
        let right = dir.cross(up).try_normalize().unwrap_or(right0);
        let screen_up = right.cross(dir);
        (dir, right, screen_up)
    }

    /// Unit viewing direction (eye towards target).
    pub fn view_dir(&self) -> Vec3 {
        self.basis().0
    }

    /// Eye position (world).
    pub fn eye(&self) -> Vec3 {
        self.target - self.view_dir() * self.distance
    }

    /// Turns the eye about the target: `dx` yaw, `dy` pitch (dragging down raises the eye).
    pub fn orbit(&mut self, dx_px: f32, dy_px: f32) {
        if !(dx_px.is_finite() && dy_px.is_finite()) {
            return;
        }
        self.yaw = (self.yaw + dx_px * ORBIT_PER_PIXEL).rem_euclid(std::f32::consts::TAU);
        self.pitch = (self.pitch + dy_px * ORBIT_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves the target in the screen plane so that what lies at the target's depth follows
    /// the pointer (`viewport_height_px` in the same unit as the deltas).
    pub fn pan(&mut self, dx_px: f32, dy_px: f32, viewport_height_px: f32) {
        if !(dx_px.is_finite() && dy_px.is_finite() && viewport_height_px > 0.0) {
            return;
        }
        let (_, right, screen_up) = self.basis();
        let world_per_px = 2.0 * self.distance * (self.fov_y * 0.5).tan() / viewport_height_px;
        self.target += (screen_up * dy_px - right * dx_px) * world_per_px;
    }

    /// Scales the distance by `exp(-scroll * 0.002)`: scrolling up (positive) moves closer.
    /// The distance stays within `radius * [1e-4, 1e4]`.
    pub fn zoom(&mut self, scroll: f32) {
        if scroll.is_finite() {
            self.scale_distance((-scroll * ZOOM_PER_POINT).exp());
        }
    }

    fn scale_distance(&mut self, factor: f32) {
        let radius = self.radius.max(1e-9);
        let scaled = self.distance * factor;
        if scaled.is_nan() {
            return;
        }
        self.distance = scaled.clamp(radius * 1e-4, radius * 1e4);
    }

    /// Projection times view, wgpu clip space (z in [0, 1]); near and far planes follow the
    /// distance (1 % of it, and 100 times it plus ten scene radii).
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        let (dir, _, screen_up) = self.basis();
        let eye = self.target - dir * self.distance;
        let near = (self.distance * 0.01).max(1e-7);
        let far = self.distance * 100.0 + self.radius.max(0.0) * 10.0;
        glam::camera::rh::proj::directx::perspective(self.fov_y, aspect, near, far.max(near * 2.0))
            * glam::camera::rh::view::look_at_mat4(eye, self.target, screen_up)
    }
}

/// The 3D view's settings and camera; one per panel that shows a cloud.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudView {
    /// `None` until the first frame (or after a reset): then fitted to the scene.
    pub camera: Option<OrbitCamera>,
    /// Side of a point's square, in UI points (physical pixels = this * pixels per point).
    pub point_size: f32,
    pub color_mode: ColorMode,
    pub show_frusta: bool,
    /// Costs mapped to the ends of the ramp in [`ColorMode::Cost`].
    pub cost_range: (f32, f32),
}

impl Default for CloudView {
    fn default() -> Self {
        CloudView {
            camera: None,
            point_size: 2.0,
            color_mode: ColorMode::Rgb,
            show_frusta: true,
            cost_range: (0.0, 1.0),
        }
    }
}

/// Set by [`install`]: whether any renderer in this process has the 3D view's pipelines.
static INSTALLED: AtomicBool = AtomicBool::new(false);

impl CloudView {
    /// The 3D view over the whole available rect. Primary drag orbits; secondary, middle or
    /// shift + primary drag pans; scroll (or pinch) zooms; double click refits the camera.
    pub fn ui(&mut self, ui: &mut egui::Ui, scene: &Arc<CloudScene>) -> egui::Response {
        let (rect, response) =
            ui.allocate_exact_size(ui.available_size(), egui::Sense::click_and_drag());
        if response.double_clicked() {
            self.camera = None;
        }
        let camera = self
            .camera
            .get_or_insert_with(|| OrbitCamera::fit(&scene.points, &scene.frusta));
        let shift = ui.input(|i| i.modifiers.shift);
        let delta = response.drag_delta();
        if response.dragged_by(egui::PointerButton::Primary) && !shift {
            camera.orbit(delta.x, delta.y);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
            || (response.dragged_by(egui::PointerButton::Primary) && shift)
        {
            camera.pan(delta.x, delta.y, rect.height());
        }
        if response.hovered() {
            let (scroll, pinch) = ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta()));
            if scroll != 0.0 {
                camera.zoom(scroll);
            }
            if pinch != 1.0 && pinch > 0.0 {
                camera.scale_distance(1.0 / pinch);
            }
        }
        let camera = *camera;
        if !INSTALLED.load(Ordering::Relaxed) {
            ui.put(
                rect,
                egui::Label::new("3D view unavailable: the viewer is not running on wgpu"),
            );
            return response;
        }
        // The view fills its rect with opaque pixels: the panel need not fill under it.
        super::frame::mark_painted(ui, rect);
        ui.painter().add(egui_wgpu::Callback::new_paint_callback(
            rect,
            CloudCallback {
                id: response.id,
                rect,
                scene: Arc::clone(scene),
                camera,
                point_size: self.point_size,
                color_mode: self.color_mode,
                cost_range: self.cost_range,
                show_frusta: self.show_frusta,
            },
        ));
        response
    }

    /// Point size, colour mode, cost range, frusta toggle and a camera reset.
    pub fn settings_ui(&mut self, ui: &mut egui::Ui) {
        ui.add(egui::Slider::new(&mut self.point_size, 1.0..=12.0).text("point size"));
        ui.horizontal(|ui| {
            ui.label("colour");
            for mode in ColorMode::ALL {
                ui.selectable_value(&mut self.color_mode, mode, mode.label());
            }
        });
        if self.color_mode == ColorMode::Cost {
            ui.horizontal(|ui| {
                ui.label("cost range");
                ui.add(egui::DragValue::new(&mut self.cost_range.0).speed(0.01));
                ui.add(egui::DragValue::new(&mut self.cost_range.1).speed(0.01));
            });
        }
        ui.checkbox(&mut self.show_frusta, "cameras");
        if ui.button("Reset camera").clicked() {
            self.camera = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Intrinsics;
    use crate::image::Image;
    use crate::scene::DepthRange;
    use glam::DVec3;

    const SIZE: [u32; 2] = [160, 100];

    fn aspect() -> f32 {
        SIZE[0] as f32 / SIZE[1] as f32
    }

    fn vertex(position: [f32; 3]) -> CloudVertex {
        CloudVertex {
            position,
            cost: 0.0,
            color: [1.0; 3],
            _pad0: 0.0,
            normal: [0.0; 3],
            _pad1: 0.0,
        }
    }

    /// Deterministic points uniform in a box.
    fn box_cloud(n: usize, lo: Vec3, hi: Vec3) -> Vec<CloudVertex> {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let t = Vec3::new(next(), next(), next());
                vertex((lo + (hi - lo) * t).to_array())
            })
            .collect()
    }

    fn some_camera() -> OrbitCamera {
        OrbitCamera {
            target: Vec3::new(0.3, -1.0, 2.0),
            yaw: 0.7,
            pitch: -0.4,
            distance: 4.0,
            ..OrbitCamera::default()
        }
    }

    fn scene_camera() -> Camera {
        Camera::look_at(
            Intrinsics {
                fx: 80.0,
                fy: 90.0,
                cx: 31.5,
                cy: 23.5,
            },
            64,
            48,
            DVec3::new(1.0, -2.0, -5.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.0, -1.0, 0.0),
        )
    }

    #[test]
    fn view_proj_puts_the_target_at_the_centre() {
        let cam = some_camera();
        let p = project_point(cam.view_proj(aspect()), cam.target.to_array(), SIZE)
            .expect("target visible");
        assert!(
            (p[0] - 80.0).abs() < 1e-3 && (p[1] - 50.0).abs() < 1e-3,
            "{p:?}"
        );
        // The eye is `distance` from the target, looking at it.
        assert!((cam.eye().distance(cam.target) - cam.distance).abs() < 1e-4);
        // Behind the eye: not projected.
        let behind = cam.eye() - cam.view_dir();
        assert!(project_point(cam.view_proj(aspect()), behind.to_array(), SIZE).is_none());
    }

    #[test]
    fn screen_axes_follow_the_camera() {
        let cam = OrbitCamera::default(); // looks along -z, +y up
        let vp = cam.view_proj(aspect());
        let right = project_point(vp, [0.5, 0.0, 0.0], SIZE).expect("visible");
        let above = project_point(vp, [0.0, 0.5, 0.0], SIZE).expect("visible");
        assert!(right[0] > 80.5 && (right[1] - 50.0).abs() < 1e-3);
        assert!(above[1] < 49.5 && (above[0] - 80.0).abs() < 1e-3);
    }

    #[test]
    fn orbit_keeps_the_distance_and_moves_the_eye() {
        let mut cam = some_camera();
        let eye0 = cam.eye();
        cam.orbit(37.0, -21.0);
        assert!((cam.eye().distance(cam.target) - 4.0).abs() < 1e-4);
        assert!(cam.eye().distance(eye0) > 0.1);
        // Dragging right turns the eye left: the target-relative eye moves against `right`.
        let mut cam = OrbitCamera::default();
        cam.orbit(10.0, 0.0);
        assert!(cam.eye().x < 0.0, "{:?}", cam.eye());
        // Dragging down raises the eye; pitch stays short of the pole.
        let mut cam = OrbitCamera::default();
        cam.orbit(0.0, 10_000.0);
        assert!(cam.eye().y > 0.0 && cam.pitch < std::f32::consts::FRAC_PI_2);
        assert!(cam.view_proj(1.0).is_finite());
    }

    #[test]
    fn pan_moves_the_target_in_the_screen_plane_with_the_pointer() {
        let mut cam = some_camera();
        let before = cam;
        let old_target = cam.target;
        cam.pan(12.0, -7.0, SIZE[1] as f32);
        let moved = cam.target - old_target;
        assert!(moved.length() > 1e-3);
        assert!(moved.dot(cam.view_dir()).abs() < 1e-5 * moved.length().max(1.0));
        assert_eq!(cam.distance, before.distance);
        // What was at the centre now sits (12, -7) pixels away: it followed the pointer.
        let p =
            project_point(cam.view_proj(aspect()), old_target.to_array(), SIZE).expect("visible");
        assert!(
            (p[0] - 92.0).abs() < 1e-2 && (p[1] - 43.0).abs() < 1e-2,
            "{p:?}"
        );
    }

    #[test]
    fn zoom_is_monotonic_and_stays_positive() {
        let mut cam = some_camera();
        let mut last = cam.distance;
        for _ in 0..20 {
            cam.zoom(50.0);
            assert!(cam.distance < last && cam.distance > 0.0);
            last = cam.distance;
        }
        for _ in 0..20 {
            cam.zoom(-50.0);
            assert!(cam.distance > last);
            last = cam.distance;
        }
        cam.zoom(1e9);
        assert!(cam.distance > 0.0 && cam.distance.is_finite());
        assert!(cam.view_proj(1.0).is_finite());
        cam.zoom(-1e9);
        assert!(cam.distance.is_finite());
        cam.zoom(f32::NAN);
        assert!(cam.distance.is_finite());
    }

    #[test]
    fn fit_frames_every_point() {
        let lo = Vec3::new(-3.0, 1.0, 10.0);
        let hi = Vec3::new(2.0, 1.5, 14.0);
        let points = box_cloud(4000, lo, hi);
        let frustum = Frustum::from_camera(&scene_camera(), 1.0, [1.0, 0.0, 0.0]);
        for frusta in [vec![], vec![frustum]] {
            let cam = OrbitCamera::fit(&points, &frusta);
            for aspect in [1.0, 1.6] {
                let size = [(100.0 * aspect) as u32, 100];
                let vp = cam.view_proj(aspect);
                for p in &points {
                    let px = project_point(vp, p.position, size);
                    assert!(px.is_some(), "{:?} not framed by {cam:?}", p.position);
                }
            }
            // Not absurdly far either: the box fills a good part of the view.
            assert!(cam.distance < 3.0 * (hi - lo).length());
        }
    }

    #[test]
    fn fit_looks_along_the_first_frustum_and_ignores_outliers() {
        let camera = scene_camera();
        let frustum = Frustum::from_camera(&camera, 1.0, [1.0, 0.0, 0.0]);
        let mut points = box_cloud(2000, Vec3::splat(-1.0), Vec3::splat(1.0));
        let tight = OrbitCamera::fit(&points, &[frustum]);
        let forward = camera.forward().as_vec3();
        assert!(tight.view_dir().dot(forward) > 0.9999);
        // Image up of the camera (its -y) is screen up.
        let up = -camera.rotation.row(1).as_vec3();
        let vp = tight.view_proj(1.0);
        let above =
            project_point(vp, (tight.target + up * 0.1).to_array(), [100, 100]).expect("visible");
        assert!(
            above[1] < 49.0 && (above[0] - 50.0).abs() < 0.5,
            "{above:?}"
        );
        // A few far outliers do not move the fit.
        points.extend((0..10).map(|k| vertex([1e6, k as f32, -1e6])));
        let robust = OrbitCamera::fit(&points, &[frustum]);
        assert!((robust.distance / tight.distance - 1.0).abs() < 0.1);
        assert!(robust.target.distance(tight.target) < 0.1);
    }

    #[test]
    fn fit_degenerate_inputs() {
        let cam = OrbitCamera::fit(&[], &[]);
        assert!(cam.view_proj(1.0).is_finite());
        let cam = OrbitCamera::fit(&[vertex([1.0, 2.0, 3.0])], &[]);
        assert!(cam.distance > 0.0 && cam.view_proj(1.0).is_finite());
        let p = project_point(cam.view_proj(1.0), [1.0, 2.0, 3.0], [10, 10]).expect("visible");
        assert!((p[0] - 5.0).abs() < 1e-3 && (p[1] - 5.0).abs() < 1e-3);
        let frustum = Frustum::from_camera(&scene_camera(), 1.0, [1.0; 3]);
        let cam = OrbitCamera::fit(&[vertex([f32::NAN; 3])], &[frustum]);
        for p in std::iter::once(frustum.apex).chain(frustum.corners) {
            assert!(project_point(cam.view_proj(1.0), p, [10, 10]).is_some());
        }
    }

    fn view(image: Image) -> View {
        View {
            name: "v".into(),
            image,
            camera: scene_camera(),
            depth_range: DepthRange::new(0.5, 20.0).expect("valid"),
            sources: Vec::new(),
            image_path: None,
        }
    }

    #[test]
    fn points_from_depth_project_back_to_their_pixels() {
        let image = Image::from_rgb(
            64,
            48,
            (0..64 * 48)
                .map(|i| [(i % 64 * 4) as u8, (i / 64 * 5) as u8, 7])
                .collect(),
        );
        let view = view(image);
        // A half-size map.
        let (w, h) = (32u32, 24u32);
        let n = (w * h) as usize;
        let mut depth: Vec<f32> = (0..n).map(|i| 2.0 + (i % 7) as f32 * 0.5).collect();
        depth[3] = 0.0;
        depth[4] = f32::NAN;
        depth[5] = -1.0;
        depth[6] = f32::INFINITY;
        let normals = vec![[0.0, 0.0, -1.0]; n];
        let cost: Vec<f32> = (0..n).map(|i| i as f32 * 1e-3).collect();
        let points = points_from_depth(&view, w, h, &depth, &normals, &cost);
        assert_eq!(points.len(), n - 4);
        let small = view.camera.rescaled(w, h);
        let mut valid = (0..n).filter(|&i| !(3..=6).contains(&i));
        for p in &points {
            let i = valid.next().expect("as many points as valid pixels");
            let (x, y) = (i % w as usize, i / w as usize);
            let (pixel, d) = small
                .project(Vec3::from(p.position).as_dvec3())
                .expect("in front");
            assert!((pixel - DVec2::new(x as f64, y as f64)).length() < 1e-3);
            assert!((d as f32 - depth[i]).abs() < 1e-4 * depth[i]);
            assert_eq!(p.cost, cost[i]);
            // Coarse pixel (x, y) covers fine pixels 2x..2x+1: nearest is 2x+1 (the lower-right
            // of the four, floor of the coarse centre mapped to the fine image).
            let expect = [((2 * x + 1) * 4) as u8, ((2 * y + 1) * 5) as u8, 7];
            assert_eq!(p.color, expect.map(|c| c as f32 / 255.0));
            // The camera's -z is the world direction towards the camera.
            let n = Vec3::from(p.normal);
            assert!((n + view.camera.forward().as_vec3()).length() < 1e-5);
        }
        // Missing normals and costs are zero; a short map yields fewer points, no panic.
        let points = points_from_depth(&view, w, h, &depth[..10], &[], &[]);
        assert_eq!(points.len(), 6);
        assert!(points.iter().all(|p| p.normal == [0.0; 3] && p.cost == 0.0));
        assert!(points_from_depth(&view, 0, 0, &depth, &[], &[]).is_empty());
    }

    #[test]
    fn frustum_corners_are_the_image_corners_at_depth() {
        let camera = scene_camera();
        let f = Frustum::from_camera(&camera, 2.5, [0.0, 1.0, 0.0]);
        assert!((Vec3::from(f.apex).as_dvec3() - camera.center()).length() < 1e-5);
        let expect = [(-0.5, -0.5), (63.5, -0.5), (63.5, 47.5), (-0.5, 47.5)];
        for (corner, (x, y)) in f.corners.iter().zip(expect) {
            let (pixel, d) = camera
                .project(Vec3::from(*corner).as_dvec3())
                .expect("in front");
            assert!((pixel - DVec2::new(x, y)).length() < 1e-3 && (d - 2.5).abs() < 1e-5);
        }
        assert_eq!(frustum_lines(&[f, f]).len(), 32);
    }

    #[test]
    fn point_colors() {
        let v = CloudVertex {
            position: [0.0; 3],
            cost: 0.25,
            color: [0.1, 0.2, 0.3],
            _pad0: 0.0,
            normal: [1.0, 0.0, -1.0],
            _pad1: 0.0,
        };
        assert_eq!(point_color(&v, ColorMode::Rgb, (0.0, 1.0)), [0.1, 0.2, 0.3]);
        assert_eq!(
            point_color(&v, ColorMode::Normal, (0.0, 1.0)),
            [1.0, 0.5, 0.0]
        );
        assert_eq!(
            point_color(&v, ColorMode::Cost, (0.0, 0.5)),
            [0.5, 1.0, 0.5]
        );
        assert_eq!(
            point_color(&v, ColorMode::Cost, (0.5, 1.0)),
            [0.0, 0.0, 1.0]
        );
        assert_eq!(
            point_color(&v, ColorMode::Cost, (-1.0, 0.25)),
            [1.0, 0.0, 0.0]
        );
        assert_eq!(
            point_color(&v, ColorMode::Cost, (1.0, 1.0)),
            [0.0, 0.0, 1.0]
        );
        assert_eq!(cost_ramp(1.0 / 6.0), [0.0, 0.5, 1.0]);
    }

    #[test]
    fn uniforms_match_the_shader_layout() {
        // mat4 (64) + vec2 + f32 + u32 (16) + vec2 + vec2 (16): WGSL's size for `Uniforms`.
        assert_eq!(std::mem::size_of::<CloudUniforms>(), 96);
        assert_eq!(std::mem::size_of::<CloudVertex>(), 48);
        assert_eq!(std::mem::offset_of!(CloudVertex, normal), 32);
        assert_eq!(std::mem::size_of::<LineVertex>(), 24);
    }
}
