//! The 3D view's renderer on the GPU (lavapipe in CI) against its CPU references:
//! `project_point` for where a point lands and `point_color` for its colour.

use std::sync::Arc;

use egui_kittest::Harness;
use glam::Vec3;
use mvscope::gpu::GpuContext;
use mvscope::viewer::cloud::{
    self, BACKGROUND, CloudScene, CloudVertex, CloudView, ColorMode, Frustum, OrbitCamera,
    point_color, project_point, render_offscreen,
};

const SIZE: [u32; 2] = [96, 64];
const COST_RANGE: (f32, f32) = (0.0, 1.0);

fn camera() -> OrbitCamera {
    // Looks along -z at the origin from (0, 0, 5), +y up.
    OrbitCamera {
        distance: 5.0,
        ..OrbitCamera::default()
    }
}

fn point(position: [f32; 3], color: [f32; 3], normal: [f32; 3], cost: f32) -> CloudVertex {
    CloudVertex {
        position,
        cost,
        color,
        _pad0: 0.0,
        normal,
        _pad1: 0.0,
    }
}

/// Well separated points (>= 10 px apart at 96x64) with distinct colours, normals and costs.
fn points() -> Vec<CloudVertex> {
    let s = std::f32::consts::FRAC_1_SQRT_2;
    vec![
        point([-1.5, 0.8, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.05),
        point([1.5, 0.8, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], 0.3),
        point([0.0, 0.0, 0.5], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], 0.55),
        point([-1.2, -0.9, -0.5], [0.8, 0.6, 0.2], [s, s, 0.0], 0.8),
        point([1.3, -0.8, 0.3], [0.25, 0.5, 0.75], [0.0, -s, s], 1.4),
    ]
}

fn context() -> GpuContext {
    GpuContext::new().expect("a GPU adapter (install mesa-vulkan-drivers)")
}

fn pixel(image: &[u8], x: u32, y: u32) -> [u8; 4] {
    let i = ((y * SIZE[0] + x) * 4) as usize;
    [image[i], image[i + 1], image[i + 2], image[i + 3]]
}

/// Where the vertex shader's reference puts `position`'s centre (pixel coordinates, pixel
/// `(i, j)` covering `[i, i+1) x [j, j+1)`).
fn project(camera: &OrbitCamera, position: [f32; 3]) -> [f32; 2] {
    let vp = camera.view_proj(SIZE[0] as f32 / SIZE[1] as f32);
    project_point(vp, position, SIZE).expect("point in view")
}

/// The pixel containing `position`'s projection offset by `(dx, dy)` pixels.
fn pixel_at(camera: &OrbitCamera, position: [f32; 3], dx: f32, dy: f32) -> (u32, u32) {
    let [x, y] = project(camera, position);
    ((x + dx).floor() as u32, (y + dy).floor() as u32)
}

fn pixel_of(camera: &OrbitCamera, position: [f32; 3]) -> (u32, u32) {
    pixel_at(camera, position, 0.0, 0.0)
}

#[track_caller]
fn assert_color(got: [u8; 4], want: [f32; 3], what: &str) {
    for k in 0..3 {
        let g = got[k] as f32 / 255.0;
        assert!(
            (g - want[k]).abs() <= 2.0 / 255.0,
            "{what}: got {got:?}, want {want:?} (x255: {:?})",
            want.map(|c| c * 255.0)
        );
    }
    assert_eq!(got[3], 255, "{what}: alpha");
}

fn is_background(p: [u8; 4]) -> bool {
    (0..3).all(|k| (p[k] as f32 / 255.0 - BACKGROUND[k]).abs() <= 2.0 / 255.0)
}

#[test]
fn points_land_where_the_cpu_reference_puts_them_in_every_colour_mode() {
    let ctx = context();
    let cam = camera();
    let scene = CloudScene {
        points: points(),
        frusta: Vec::new(),
        version: 1,
    };
    for mode in ColorMode::ALL {
        let image = render_offscreen(&ctx, &scene, &cam, 5.0, mode, COST_RANGE, true, SIZE)
            .expect("render");
        assert_eq!(image.len(), (SIZE[0] * SIZE[1] * 4) as usize);
        let mut colors = Vec::new();
        for (k, p) in scene.points.iter().enumerate() {
            let (x, y) = pixel_of(&cam, p.position);
            let want = point_color(p, mode, COST_RANGE);
            assert_color(pixel(&image, x, y), want, &format!("{mode:?} point {k}"));
            // The square is 5 px wide: pixels whose centres are within 2.4 px of the point (each
            // axis) are the point, those 2.6 px or more away are not.
            for (dx, dy) in [(-1.9, 0.0), (1.9, 0.0), (0.0, -1.9), (0.0, 1.9), (1.9, 1.9)] {
                let (x, y) = pixel_at(&cam, p.position, dx, dy);
                let what = format!("{mode:?} point {k}, offset ({dx}, {dy})");
                assert_color(pixel(&image, x, y), want, &what);
            }
            for (dx, dy) in [(-3.1, 0.0), (3.0, 0.0), (0.0, -3.1), (0.0, 3.0)] {
                let (x, y) = pixel_at(&cam, p.position, dx, dy);
                assert!(
                    is_background(pixel(&image, x, y)),
                    "{mode:?} point {k}: lit at offset ({dx}, {dy}), the square is over 5 px"
                );
            }
            colors.push(want);
        }
        // The modes really differ per point (the test would not see a wrong mode otherwise).
        colors.dedup();
        assert_eq!(
            colors.len(),
            scene.points.len(),
            "{mode:?}: distinct colours"
        );
        // Far from every point: background.
        for (x, y) in [(0, 0), (SIZE[0] - 1, SIZE[1] - 1), (SIZE[0] / 2, 2)] {
            let p = pixel(&image, x, y);
            assert!(is_background(p), "{mode:?}: pixel ({x}, {y}) is {p:?}");
        }
    }
}

#[test]
fn nearer_points_occlude_farther_ones() {
    let ctx = context();
    let cam = camera();
    let eye = cam.eye();
    let far = Vec3::new(0.6, -0.4, -1.0);
    let near = eye + (far - eye) * 0.5;
    let red = point(far.to_array(), [1.0, 0.0, 0.0], [0.0; 3], 0.0);
    let green = point(near.to_array(), [0.0, 1.0, 0.0], [0.0; 3], 0.0);
    let (x, y) = pixel_of(&cam, far.to_array());
    assert_eq!(pixel_of(&cam, near.to_array()), (x, y));
    // Both draw orders: the depth test decides, not the order.
    for points in [vec![red, green], vec![green, red]] {
        let scene = CloudScene {
            points,
            frusta: Vec::new(),
            version: 0,
        };
        let image = render_offscreen(
            &ctx,
            &scene,
            &cam,
            5.0,
            ColorMode::Rgb,
            COST_RANGE,
            false,
            SIZE,
        )
        .expect("render");
        assert_color(pixel(&image, x, y), [0.0, 1.0, 0.0], "nearer point");
    }
}

#[test]
fn frusta_draw_lines_only_when_enabled() {
    let ctx = context();
    let cam = camera();
    let color = [1.0, 0.5, 0.0];
    let frustum = Frustum {
        apex: [0.0, 0.0, 1.5],
        corners: [
            [-1.0, 0.7, -0.5],
            [1.0, 0.7, -0.5],
            [1.0, -0.7, -0.5],
            [-1.0, -0.7, -0.5],
        ],
        color,
    };
    let scene = CloudScene {
        points: Vec::new(),
        frusta: vec![frustum],
        version: 0,
    };
    let render = |show: bool| {
        render_offscreen(
            &ctx,
            &scene,
            &cam,
            5.0,
            ColorMode::Rgb,
            COST_RANGE,
            show,
            SIZE,
        )
        .expect("render")
    };
    let shown = render(true);
    let lit: Vec<[u8; 4]> = shown
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]])
        .filter(|&p| !is_background(p))
        .collect();
    // 8 edges of a frustum spanning a good part of the view: well over 100 pixels.
    assert!(lit.len() > 100, "{} line pixels", lit.len());
    let is_line =
        |p: [u8; 4]| (0..3).all(|k| (p[k] as f32 / 255.0 - color[k]).abs() <= 2.0 / 255.0);
    assert!(
        lit.iter().all(|&p| is_line(p)),
        "lines have the frustum's colour"
    );
    // A corner of the image rectangle is on two edges: lit.
    let (x, y) = pixel_of(&cam, frustum.corners[0]);
    let around = (-1i32..=1).flat_map(|dy| (-1i32..=1).map(move |dx| (dx, dy)));
    assert!(
        around.into_iter().any(|(dx, dy)| is_line(pixel(
            &shown,
            (x as i32 + dx) as u32,
            (y as i32 + dy) as u32
        ))),
        "no line near the frustum's top-left corner"
    );
    let hidden = render(false);
    assert!(
        hidden
            .chunks_exact(4)
            .all(|p| is_background([p[0], p[1], p[2], p[3]])),
        "frusta drawn while disabled"
    );
}

#[test]
fn empty_size_is_an_error_not_a_panic() {
    let ctx = context();
    let scene = CloudScene::default();
    let result = render_offscreen(
        &ctx,
        &scene,
        &camera(),
        5.0,
        ColorMode::Rgb,
        COST_RANGE,
        true,
        [0, 10],
    );
    assert!(result.is_err());
}

/// A window showing one [`CloudView`], on a renderer with the 3D view installed.
struct Window {
    view: CloudView,
    scene: Arc<CloudScene>,
    rect: Option<egui::Rect>,
}

fn window(pixels_per_point: f32) -> (Harness<'static, Window>, GpuContext) {
    let render_state = egui_kittest::wgpu::create_render_state(
        egui_kittest::wgpu::default_wgpu_setup(),
        egui_wgpu::RendererOptions::PREDICTABLE,
    );
    cloud::install(&render_state);
    // The same device renders offscreen, so both rasterise identically.
    let ctx = GpuContext::from_device(
        render_state.device.clone(),
        render_state.queue.clone(),
        render_state.adapter.get_info(),
    );
    let scene = CloudScene {
        points: points(),
        frusta: vec![Frustum {
            apex: [0.0, 0.0, 1.5],
            corners: [
                [-1.0, 0.7, -0.5],
                [1.0, 0.7, -0.5],
                [1.0, -0.7, -0.5],
                [-1.0, -0.7, -0.5],
            ],
            color: [1.0, 0.5, 0.0],
        }],
        version: 1,
    };
    let state = Window {
        view: CloudView {
            point_size: 3.0,
            ..CloudView::default()
        },
        scene: Arc::new(scene),
        rect: None,
    };
    let harness = Harness::builder()
        .with_size(egui::vec2(170.0, 110.0))
        .with_pixels_per_point(pixels_per_point)
        .renderer(egui_kittest::wgpu::WgpuTestRenderer::from_render_state(
            render_state,
        ))
        .build_ui_state(
            |ui, w: &mut Window| {
                w.rect = Some(w.view.ui(ui, &w.scene).rect);
            },
            state,
        );
    (harness, ctx)
}

#[test]
fn the_window_shows_exactly_the_offscreen_render() {
    // 1.5 pixels per point: the view's pixel rect and point size are scaled and rounded.
    let ppp = 1.5;
    let (mut harness, ctx) = window(ppp);
    harness.run();
    let shot = harness.render().expect("render the window");
    let w = harness.state();
    let rect = w.rect.expect("the view was shown");
    let camera = w.view.camera.expect("fitted on the first frame");
    let left = (rect.min.x * ppp).round() as u32;
    let top = (rect.min.y * ppp).round() as u32;
    let size = [
        (rect.max.x * ppp).round() as u32 - left,
        (rect.max.y * ppp).round() as u32 - top,
    ];
    assert!(size[0] > 100 && size[1] > 60, "view of {size:?} px");
    let expect = render_offscreen(
        &ctx,
        &w.scene,
        &camera,
        w.view.point_size * ppp,
        w.view.color_mode,
        w.view.cost_range,
        w.view.show_frusta,
        size,
    )
    .expect("offscreen render");
    let mut lit = 0;
    for y in 0..size[1] {
        for x in 0..size[0] {
            let got = shot.get_pixel(left + x, top + y).0;
            let i = ((y * size[0] + x) * 4) as usize;
            let want = &expect[i..i + 4];
            let close = (0..3).all(|k| got[k].abs_diff(want[k]) <= 2);
            assert!(
                close,
                "pixel ({x}, {y}) of the view: {got:?}, offscreen {want:?}"
            );
            lit += usize::from(!is_background(got));
        }
    }
    assert!(
        lit > 100,
        "only {lit} non-background pixels: nothing drawn?"
    );
    // Just outside the view: not the 3D view's background (egui's panel).
    if left > 0 {
        let outside = shot.get_pixel(left - 1, top + size[1] / 2).0;
        assert!(!is_background(outside), "the blit spills left: {outside:?}");
    }
}

#[test]
fn dragging_orbits_and_pans() {
    let (mut harness, _) = window(1.0);
    harness.run();
    let rect = harness.state().rect.expect("shown");
    let fitted = harness.state().view.camera.expect("fitted");
    let drag = |harness: &mut Harness<'static, Window>, button: egui::PointerButton| {
        let from = rect.center();
        let to = from + egui::vec2(30.0, 10.0);
        let press = |pos, pressed| egui::Event::PointerButton {
            pos,
            button,
            pressed,
            modifiers: egui::Modifiers::NONE,
        };
        harness.hover_at(from);
        harness.event(press(from, true));
        harness.step();
        for k in 1..=3 {
            harness.hover_at(from + (to - from) * k as f32 / 3.0);
            harness.step();
        }
        harness.event(press(to, false));
        harness.step();
    };
    drag(&mut harness, egui::PointerButton::Primary);
    let orbited = harness.state().view.camera.expect("camera");
    assert!(orbited.yaw > fitted.yaw && orbited.pitch > fitted.pitch);
    assert_eq!(orbited.target, fitted.target);
    assert_eq!(orbited.distance, fitted.distance);
    drag(&mut harness, egui::PointerButton::Secondary);
    let panned = harness.state().view.camera.expect("camera");
    assert_ne!(panned.target, orbited.target);
    assert_eq!((panned.yaw, panned.pitch), (orbited.yaw, orbited.pitch));
}
