//! GPU foundation tests; they run on whatever adapter is present (lavapipe in CI).

use glam::{DVec2, DVec3};
use mvscope::camera::{Camera, Intrinsics};
use mvscope::gpu::{GpuContext, GpuError, GpuOptions, smoke};

fn camera() -> Camera {
    Camera::look_at(
        Intrinsics {
            fx: 150.0,
            fy: 140.0,
            cx: 63.5,
            cy: 47.5,
        },
        128,
        96,
        DVec3::new(0.5, 0.3, -3.0),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::Y,
    )
}

#[test]
fn context_prefers_what_it_reports() {
    let ctx = GpuContext::new().expect("a GPU adapter (install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());
    // The device was created with the adapter's real limits, not the small defaults.
    assert!(ctx.limits.max_storage_buffer_binding_size >= 128 << 20);
    assert_eq!(ctx.limits, ctx.device.limits());
}

#[test]
fn smoke_kernel_matches_cpu_reference() {
    let ctx = GpuContext::new().expect("a GPU adapter");
    let cam = camera();
    // Points on the image, off it, and behind the camera.
    let mut points = Vec::new();
    for j in 0..20 {
        for i in 0..25 {
            let pixel = DVec2::new(i as f64 * 6.0 - 8.25, j as f64 * 5.5 - 6.25);
            points.push(cam.unproject(pixel, 1.0 + (i + j) as f64 * 0.1));
        }
    }
    points.push(cam.center() - cam.forward() * 2.0);
    let gpu = smoke::project_gpu(&ctx, &cam, &points).expect("kernel runs");
    let cpu = smoke::project_cpu(&cam, &points);
    assert_eq!(gpu.len(), cpu.len());
    let mut visible = 0;
    for (k, (g, c)) in gpu.iter().zip(&cpu).enumerate() {
        assert!(
            (g.depth - c.depth).abs() < 1e-4,
            "point {k}: {g:?} vs {c:?}"
        );
        if c.visible {
            visible += 1;
            // f32 on the GPU against f64 on the CPU: well under a thousandth of a pixel.
            assert!(
                (g.pixel[0] - c.pixel[0]).abs() < 2e-3,
                "point {k}: {g:?} vs {c:?}"
            );
            assert!(
                (g.pixel[1] - c.pixel[1]).abs() < 2e-3,
                "point {k}: {g:?} vs {c:?}"
            );
        }
        // Points exactly on the border could flip either way in f32; none are placed there.
        assert_eq!(g.visible, c.visible, "point {k}: {g:?} vs {c:?}");
    }
    assert!(visible > 300 && visible < points.len(), "{visible}");
}

#[test]
fn unknown_adapter_name_is_a_clear_error() {
    let err = GpuContext::with_options(&GpuOptions {
        backends: None,
        adapter_name: Some("no-such-gpu-xyz".into()),
    })
    .expect_err("no adapter has that name");
    assert!(matches!(err, GpuError::AdapterNotFound { .. }), "{err}");
    assert!(err.to_string().contains("available:"), "{err}");
}

#[test]
fn no_backend_names_the_fix() {
    // An empty backend set finds nothing: the message must say what to install.
    let err = GpuContext::with_options(&GpuOptions {
        backends: Some(wgpu::Backends::empty()),
        adapter_name: None,
    })
    .expect_err("no backends, no adapter");
    assert!(err.to_string().contains("mesa-vulkan-drivers"), "{err}");
}
