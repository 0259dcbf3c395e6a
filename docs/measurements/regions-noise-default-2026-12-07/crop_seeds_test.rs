// Temporary: measures the noisy corrected crop over seeds (not committed).
use mvscope::accuracy::{self, SuiteScene};
use mvscope::acmm::{Method, Params};
use mvscope::gpu::GpuContext;
use mvscope::gpu::acmh::AcmhPipelines;
use mvscope::image::Image;
use mvscope::rng::Stream;
use std::path::PathBuf;
use std::sync::Arc;

fn crop(noise: f32) -> SuiteScene {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/rgbd/icl-livingroom");
    let mut suite = accuracy::load_room_crop(&dir, &[0, 3, 4], Some(320)).unwrap();
    let shipped = std::env::var("SHIPPED").is_ok();
    for (view, (dx, dy)) in suite.scene.views.iter_mut().filter(|_| !shipped).zip([
        (0.0, -2.0),
        (-5.5, 1.0),
        (4.0, 0.0),
    ]) {
        let scale = view.camera.width as f64 / 640.0;
        view.camera.intrinsics.cx += dx * scale;
        view.camera.intrinsics.cy += dy * scale;
    }
    if noise > 0.0 {
        for (v, view) in suite.scene.views.iter_mut().enumerate() {
            let image = &view.image;
            let rgb = (0u32..)
                .zip(&image.rgb)
                .map(|(i, p)| {
                    let n = noise * Stream::new(&[0x006e_015e, v as u32, i]).next_gaussian();
                    p.map(|c| (c as f32 + n).round().clamp(0.0, 255.0) as u8)
                })
                .collect();
            view.image = Image::from_rgb(image.width, image.height, rgb);
        }
    }
    suite
}

#[test]
#[ignore]
fn seeds() {
    let which = std::env::var("WHICH").unwrap_or_default();
    let noise: f32 = std::env::var("NOISE")
        .map(|s| s.parse().unwrap())
        .unwrap_or(3.0);
    let suite = crop(noise);
    let ctx = GpuContext::new().unwrap();
    let pipes = Arc::new(AcmhPipelines::new(&ctx).unwrap());
    for seed in 0..3u64 {
        for (name, m, off) in [
            ("ACMM", Method::Acmm, false),
            ("Regions", Method::Regions, false),
            ("Regions-off", Method::Regions, true),
        ] {
            if !which.is_empty() && !which.split(',').any(|w| w == name) {
                continue;
            }
            let mut p = m.params(&Params::default());
            p.seed = seed;
            if off {
                p.prior_flat_noise = false;
                p.prior_region_cover_band = 0.0;
            }
            let row = accuracy::evaluate(
                &ctx,
                pipes.clone(),
                &suite,
                &p,
                m,
                accuracy::Options::default(),
            )
            .unwrap();
            eprintln!(
                "noise {noise} seed {seed} {name}: within 2% {:.3}, weak {:.3}, within 5% {:.3}, F1 5cm {:.3}, 2cm {:.3}",
                row.within_2,
                row.low_texture_within_2.unwrap(),
                row.within_5,
                row.cloud[1].f1,
                row.cloud[0].f1
            );
        }
    }
}
