//! ACMH and ACMM end to end on the real scenes in ../shared/data, at reduced size for the
//! software GPU. Middlebury 2014 has ground-truth depth; the others are checked for
//! plausibility.

use std::path::PathBuf;

use mvscope::acmm::{Method, Params};
use mvscope::gpu::GpuContext;
use mvscope::scene::{LoadOptions, Scene};
use mvscope::session::Session;

/// ../shared/data beside the checkout; a missing folder fails the test.
fn shared_data() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    assert!(dir.is_dir(), "shared test data missing: {}", dir.display());
    dir
}

fn load(name: &str, max: u32) -> Scene {
    Scene::load(
        &shared_data().join(name),
        &LoadOptions {
            max_image_size: Some(max),
            ..LoadOptions::default()
        },
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn run(ctx: &GpuContext, scene: &Scene, params: Params, method: Method) -> Vec<Vec<f32>> {
    let mut s = Session::new(ctx, scene, params, method).unwrap();
    s.run_to_end().unwrap();
    s.final_maps()
        .unwrap()
        .into_iter()
        .map(|m| m.unwrap().state.depth())
        .collect()
}

#[test]
fn middlebury_teddy_against_ground_truth() {
    let scene = load("middlebury2014/Teddy", 240);
    let gt =
        mvscope::io::read_pfm(&shared_data().join("middlebury2014/Teddy/gt/00000000.pfm")).unwrap();
    let (w, h) = (scene.views[0].image.width, scene.views[0].image.height);
    assert_eq!((w, h), (240, 200));
    // Ground truth at each reduced pixel's centre (nearest full-size pixel), in millimetres.
    let (sx, sy) = (gt.width as f64 / w as f64, gt.height as f64 / h as f64);
    let g: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let u = (((x as f64 + 0.5) * sx - 0.5).round() as u32).min(gt.width - 1);
            let v = (((y as f64 + 0.5) * sy - 0.5).round() as u32).min(gt.height - 1);
            gt.get(u, v, 0)
        })
        .collect();
    let ctx = GpuContext::new().unwrap();
    let within = |d: &[f32], t| mvscope::eval::depth_accuracy_relative(d, &g, None, t).within;
    let acmh = run(&ctx, &scene, Params::default(), Method::Acmh);
    let acmm_small = run(
        &ctx,
        &scene,
        Params {
            original_pyramid: true,
            ..Params::default()
        },
        Method::Acmm,
    );
    let acmm = run(&ctx, &scene, Params::default(), Method::Acmm);
    let (a1, s1, m1, m2) = (
        within(&acmh[0], 0.01),
        within(&acmm_small[0], 0.01),
        within(&acmm[0], 0.01),
        within(&acmm[0], 0.02),
    );
    eprintln!(
        "Teddy 240x200: ACMH {a1:.3} @1%, ACMM (original pyramid) {s1:.3} @1%, ACMM k=3 {m1:.3} @1% {m2:.3} @2%"
    );
    // Measured on lavapipe: ACMH 0.831 within 1%; ACMM with the original code's pyramid rule
    // (one scale below 1000 px) 0.839; ACMM with the paper's k = 3 (a 60x50 coarsest scale)
    // 0.823 within 1% and 0.892 within 2% (at full size ACMM leads by 0.8 points within 1%,
    // docs/accuracy.md). Before the detail restorer refined the upsampled planes, k = 3 lost 12
    // points within 1% here.
    assert!(a1 > 0.79, "ACMH {a1}");
    assert!(
        s1 > 0.79 && s1 >= a1 - 0.01,
        "ACMM (original pyramid) {s1} vs ACMH {a1}"
    );
    assert!(m1 >= a1 - 0.02, "ACMM k=3 within 1%: {m1} vs ACMH {a1}");
    assert!(m2 > 0.85, "ACMM k=3 within 2%: {m2}");
}

#[test]
fn temple_and_fountain_run_end_to_end() {
    let ctx = GpuContext::new().unwrap();
    // (scene, max size, views, share of pixels with cost < 0.5 at least): measured on
    // lavapipe 0.604 / 0.544 / 0.238 for these temple views (a small object on black; view 2
    // keeps one source in this subset) and 0.844 / 0.938 / 0.908 for the fountain.
    for (name, max, views, good) in [
        ("templeSparseRing-acmm", 160, vec![0usize, 1, 2], 0.15),
        ("fountain-P11", 192, vec![4, 5, 6], 0.7),
    ] {
        let scene = load(name, max).subset(&views).unwrap();
        let mut s = Session::new(&ctx, &scene, Params::default(), Method::Acmm).unwrap();
        s.run_to_end().unwrap();
        for (i, m) in s.final_maps().unwrap().iter().enumerate() {
            let st = &m.as_ref().unwrap().state;
            let r = scene.views[i].depth_range;
            let n = st.plane.len() as f64;
            let in_range = st
                .plane
                .iter()
                .filter(|p| p[3] as f64 >= r.min * 0.999 && p[3] as f64 <= r.max * 1.001)
                .count() as f64;
            let low = st.cost.iter().filter(|&&c| c < 0.5).count() as f64;
            assert!(
                in_range / n > 0.99,
                "{name} view {i}: {in_range}/{n} in range"
            );
            assert!(
                low / n > good,
                "{name} view {i}: {:.3} with cost < 0.5",
                low / n
            );
        }
    }
}
