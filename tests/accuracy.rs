//! The ground-truth accuracy suite, as much of it as CI can afford: every method on
//! real Middlebury 2005/2006 scenes with weak-texture masks (full size, ~430x370, two views)
//! and on the synthetic scene, scored as `mvscope eval` scores. `mvscope bench --accuracy`
//! runs the whole set (docs/accuracy.md).
//!
//! Every threshold sits next to the number measured on lavapipe with default parameters.

use std::path::PathBuf;
use std::sync::Arc;

use mvscope::accuracy::{self, AccuracyRow, SuiteScene};
use mvscope::acmm::{Method, Params};
use mvscope::gpu::GpuContext;
use mvscope::gpu::acmh::AcmhPipelines;
use mvscope::image::Image;
use mvscope::rng::Stream;
use mvscope::synthetic::SyntheticOptions;

fn shared_data() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    assert!(dir.is_dir(), "shared test data missing: {}", dir.display());
    dir
}

fn run_all(suite: &SuiteScene) -> [AccuracyRow; 3] {
    run(suite, [Method::Dwta, Method::Acmh, Method::Acmm])
}

fn run<const N: usize>(suite: &SuiteScene, methods: [Method; N]) -> [AccuracyRow; N] {
    let ctx = GpuContext::new().unwrap();
    let pipes = Arc::new(AcmhPipelines::new(&ctx).unwrap());
    let params = Params::default();
    methods.map(|m| {
        let row = accuracy::evaluate(
            &ctx,
            pipes.clone(),
            suite,
            &m.params(&params),
            m,
            accuracy::Options::default(),
        )
        .unwrap();
        eprintln!(
            "{} {}: within 1% {:.3}, within 2% {:.3}, weak texture within 2% {:?}",
            row.scene, row.method, row.within_1, row.within_2, row.low_texture_within_2
        );
        row
    })
}

fn weak(row: &AccuracyRow) -> f64 {
    row.low_texture_within_2
        .expect("the scene has a weak-texture mask")
}

/// Asserts that Regions' share `regions` leads ACMM's `acmm` by at least `margin`;
/// `measured` is the pair the comment beside the call measured, for the message.
fn regions_ahead(what: &str, regions: f64, acmm: f64, margin: f64, measured: (f64, f64)) {
    assert!(
        regions >= acmm + margin,
        "{what}: Regions {regions:.3}, ACMM {acmm:.3} (measured {:.3} and {:.3})",
        measured.0,
        measured.1
    );
}

/// CI's room crop: views 0, 3 and 4 of the ICL-NUIM living room at half size, its cameras
/// as shipped.
fn icl_room_crop() -> SuiteScene {
    accuracy::load_room_crop(
        &shared_data().join("rgbd/icl-livingroom"),
        &[0, 3, 4],
        Some(320),
    )
    .unwrap()
}

/// [`icl_room_crop`] with its principal points corrected as `mvscope eval` solves them from
/// ACMM's maps at 640 (view 0 by (0, −2) px, view 3 by (−5.5, +1), view 4 by (+4, 0);
/// docs/accuracy.md, "ICL with its cameras corrected").
fn icl_room_crop_corrected() -> SuiteScene {
    let mut suite = icl_room_crop();
    for (view, (dx, dy)) in suite
        .scene
        .views
        .iter_mut()
        .zip([(0.0, -2.0), (-5.5, 1.0), (4.0, 0.0)])
    {
        let scale = view.camera.width as f64 / 640.0;
        view.camera.intrinsics.cx += dx * scale;
        view.camera.intrinsics.cy += dy * scale;
    }
    suite
}

/// Adds white sensor noise of `sigma` grey levels to every view's image, the same on the
/// three channels (a photograph's luminance noise), rounded to 8 bits; a function of the
/// view and pixel alone.
fn add_sensor_noise(suite: &mut SuiteScene, sigma: f32) {
    for (v, view) in suite.scene.views.iter_mut().enumerate() {
        let image = &view.image;
        let rgb = (0u32..)
            .zip(&image.rgb)
            .map(|(i, p)| {
                let n = sigma * Stream::new(&[0x006e_015e, v as u32, i]).next_gaussian();
                p.map(|c| (c as f32 + n).round().clamp(0.0, 255.0) as u8)
            })
            .collect();
        view.image = Image::from_rgb(image.width, image.height, rgb);
    }
}

/// Middlebury 2006 scenes that are about half weak texture: ACMM's multi-scale geometric
/// consistency must beat ACMH there, ACMH must not lose to DWTA, and ACMM must keep ACMH's
/// fine precision.
#[test]
fn acmm_beats_acmh_beats_dwta_on_weak_texture() {
    // (scene, measured DWTA / ACMH / ACMM weak-texture share within 2%, then ACMH / ACMM
    // within 1% overall), lavapipe, default parameters, full size:
    //   Lampshade1 0.653 / 0.667 / 0.739, 0.576 / 0.621
    //   Midd1      0.217 / 0.224 / 0.337, 0.438 / 0.480
    for (name, weak_gain) in [("Lampshade1", 0.04), ("Midd1", 0.06)] {
        let suite = accuracy::load_scene(&shared_data().join("middlebury2006").join(name), None)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let [dwta, acmh, acmm, acmp, acmmp, regions] = run(&suite, Method::ALL);
        planar_prior_keeps_its_ground(name, &acmh, &acmm, &acmp, &acmmp);
        region_planes_keep_their_ground(name, &acmm, &regions);
        assert!(
            weak(&acmm) >= weak(&acmh) + weak_gain,
            "{name} weak texture: ACMM {:.3} vs ACMH {:.3}",
            weak(&acmm),
            weak(&acmh)
        );
        // ACMH and DWTA differ little with one source view (no view to select): ACMH was
        // ahead by 0.7-1.4 points on both.
        assert!(
            weak(&acmh) >= weak(&dwta) - 0.005,
            "{name} weak texture: ACMH {:.3} vs DWTA {:.3}",
            weak(&acmh),
            weak(&dwta)
        );
        // No loss of fine precision: ACMM was 4.2-4.5 points ahead within 1%.
        assert!(
            acmm.within_1 >= acmh.within_1 + 0.01,
            "{name} within 1%: ACMM {:.3} vs ACMH {:.3}",
            acmm.within_1,
            acmh.within_1
        );
        assert!(acmm.within_2 >= acmh.within_2, "{name} within 2%");
    }
}

/// ACMP and ACMMP on a weakly textured scene (issue 24): the planar prior must not cost
/// ACMM's accuracy, and ACMP (ACMH with the prior and geometric consistency) must beat ACMH.
/// Measured (lavapipe, default parameters, full size), within 2% overall / weak texture:
///   Lampshade1 ACMH 65.6 / 66.7, ACMM 70.7 / 73.9, ACMP 69.6 / 72.0, ACMMP 70.9 / 74.1
///   Midd1      ACMH 49.9 / 22.4, ACMM 55.9 / 33.7, ACMP 52.8 / 27.3, ACMMP 56.0 / 33.7
/// The prior covers little of these scenes' weak texture (its credible points there are
/// wrong, and the triangles they make are dropped as inconsistent with their normals), so
/// ACMMP only ties ACMM: docs/accuracy.md, "The planar prior on the shared scenes".
fn planar_prior_keeps_its_ground(
    name: &str,
    acmh: &AccuracyRow,
    acmm: &AccuracyRow,
    acmp: &AccuracyRow,
    acmmp: &AccuracyRow,
) {
    assert!(
        acmmp.within_2 >= acmm.within_2 - 0.005,
        "{name} within 2%: ACMMP {:.3} vs ACMM {:.3}",
        acmmp.within_2,
        acmm.within_2
    );
    assert!(
        weak(acmmp) >= weak(acmm) - 0.01,
        "{name} weak texture: ACMMP {:.3} vs ACMM {:.3}",
        weak(acmmp),
        weak(acmm)
    );
    assert!(
        acmp.within_2 >= acmh.within_2 + 0.02,
        "{name} within 2%: ACMP {:.3} vs ACMH {:.3}",
        acmp.within_2,
        acmh.within_2
    );
}

/// Region planes on the two-view weak-texture scenes: no loss against ACMM. Measured
/// (lavapipe, default parameters, full size), within 2% overall / weak texture:
///   Lampshade1 ACMM 70.7 / 73.9, Regions 71.7 / 75.5 (71.0 / 74.2 before its prior held
///              in the geometric passes, `prior_region_hold`)
///   Midd1      ACMM 55.9 / 33.7, Regions 56.2 / 33.8 (55.9 / 33.4 before)
/// (before Regions ranked its support points by confirming sources; with them, at 320 px,
/// Lampshade1 68.1 → 68.6 / 72.9 → 73.8 and Midd1 49.9 → 49.4 / 24.8 → 24.1, and with the
/// cost − confidence score instead of the count 68.2 / 73.1 and 50.0 / 24.7, docs/accuracy.md;
/// at full size with the score, Lampshade1 72.0 / 76.0 and Midd1 55.9 / 33.2, this test's
/// own print, seventeenth session; with windows flat around their ramp, `prior_flat_ramp`,
/// Lampshade1 71.9 / 75.5 and Midd1 56.0 / 33.4 against ACMM's 70.7 / 73.9 and 55.9 / 33.7,
/// nineteenth session; keeping the prior planes no source sees, `prior_keep_unseen`,
/// Lampshade1 73.1 / 77.2 and Midd1 56.7 / 34.2, `bench --accuracy` at full size,
/// twenty-second session; with the prior past the hull, `prior_extend`, Lampshade1
/// 73.4 / 76.7 and Midd1 57.0 / 34.3, twenty-fourth session; with windows weighted by the
/// adaptive bilateral form, Lampshade1 74.9 / 77.5 and Midd1 57.4 / 34.2, this test's own
/// print, twenty-eighth session)
/// (these two-view scenes have few flat regions whose points half agree on a plane; the
/// margins allow the ties ACMMP is held to).
fn region_planes_keep_their_ground(name: &str, acmm: &AccuracyRow, regions: &AccuracyRow) {
    assert!(
        regions.within_2 >= acmm.within_2 - 0.005,
        "{name} within 2%: Regions {:.3} vs ACMM {:.3}",
        regions.within_2,
        acmm.within_2
    );
    assert!(
        weak(regions) >= weak(acmm) - 0.01,
        "{name} weak texture: Regions {:.3} vs ACMM {:.3}",
        weak(regions),
        weak(acmm)
    );
}

/// A well-textured scene: ACMM must not trade ACMH's precision for its multi-scale scheme
/// (before the detail restorer refined the upsampled planes, ACMM lost 27 points here).
#[test]
fn acmm_keeps_fine_precision_on_texture() {
    // Measured (lavapipe, default parameters, full size 437x370): within 1% DWTA 0.712,
    // ACMH 0.718, ACMM 0.725; within 2% 0.772 / 0.779 / 0.792.
    let suite =
        accuracy::load_scene(&shared_data().join("middlebury2006/Flowerpots"), None).unwrap();
    let [dwta, acmh, acmm] = run_all(&suite);
    assert!(
        acmm.within_1 >= acmh.within_1 - 0.005,
        "within 1%: ACMM {:.3} vs ACMH {:.3}",
        acmm.within_1,
        acmh.within_1
    );
    assert!(acmm.within_2 >= acmh.within_2, "within 2%");
    assert!(acmh.within_1 >= dwta.within_1 - 0.005, "ACMH vs DWTA");
    assert!(acmh.within_1 > 0.68, "ACMH within 1%: {:.3}", acmh.within_1);
}

/// The synthetic scene (5 views, a weakly textured back wall): ACMM's gain on the wall and
/// overall, and a wall that is not systematically off.
#[test]
fn synthetic_wall_ordering() {
    let suite = accuracy::synthetic_scene(&SyntheticOptions {
        width: 320,
        height: 240,
        ..SyntheticOptions::default()
    })
    .unwrap();
    let [dwta, acmh, acmm, regions] = run(
        &suite,
        [Method::Dwta, Method::Acmh, Method::Acmm, Method::Regions],
    );
    // Measured (lavapipe, 320x240, all 5 views, 8-bit images since the twenty-sixth session,
    // `bench --accuracy --scenes synthetic`, docs/measurements/synthetic8-2026-11-29):
    // weak texture within 2% DWTA 0.252, ACMH 0.323, ACMM 0.519; within 1% overall 0.528 /
    // 0.615 / 0.720. (The renderer's unrounded grey gave 0.265 / 0.343 / 0.535 and 0.531 /
    // 0.620 / 0.728.)
    // Region planes on the wall, and windows weighted by the adaptive bilateral form
    // (twenty-eighth session, docs/accuracy.md, "A colour scale from the window",
    // docs/measurements/adaptive-2026-11-29/syn-reg-ad.log): Regions 0.814 weak texture,
    // 0.897 within 2%, against ACMM's 0.519 and 0.765 (+29.5 and +13.2 points). With the
    // authors' unsquared weight (`--set bilateral_kernel=laplacian`) 0.722 and 0.856 (+20.3
    // and +9.1; seed 1 0.725 and 0.858): the wall within 8 px of an object in front took the
    // object's depth. Without counting only the points a source could contradict as well
    // (`--set prior_region_cover_seen=false`) 0.659 and 0.831: view 0's wall plane was
    // dropped (docs/accuracy.md, "The synthetic scenes in 8 bits"). The margins sit between
    // the adaptive and the unsquared weight, so that a window reaching across an edge again
    // fails. With regions that stop at an intensity edge and RANSAC drawn by a region's first
    // cell (`prior_region_edge`, thirty-first session, docs/measurements/edges-2026-12-02/
    // e-syn.log): 0.815 and 0.899. (Unrounded grey: 0.734 and 0.860 with the unsquared weight and the prior past
    // the hull, the wall's outcome flipping between two modes with the seed, which 8 bits
    // end.)
    assert!(
        weak(&regions) >= weak(&acmm) + 0.25,
        "wall: Regions {:.3} vs ACMM {:.3} (measured 0.814 and 0.519)",
        weak(&regions),
        weak(&acmm)
    );
    assert!(
        regions.within_2 >= acmm.within_2 + 0.11,
        "overall: Regions {:.3} vs ACMM {:.3} (measured 0.897 and 0.765)",
        regions.within_2,
        acmm.within_2
    );
    // What no source sees (5.5% of the pixels, `eval::seen_by_sources`): measured within 2%
    // ACMM 0.009, Regions 0.632 keeping the prior planes no source sees and with the prior
    // past the hull (0.635 with the unsquared weight; on the seen pixels 0.913 and 0.809,
    // 0.869 with the unsquared weight, so a margin of 0.08 fails without the adaptive
    // weight; without the keep, `--set
    // prior_keep_unseen=false`, Regions fell to about ACMM's there on the unrounded scene,
    // 0.010, docs/measurements/extend-2026-11-29/syn-ext0.log). A keep that stops keeping,
    // or keeps the wrong pixels, falls back to about ACMM's.
    let (sa, sr) = (
        acmm.seen.expect("ACMM split"),
        regions.seen.expect("Regions split"),
    );
    let (ua, ur) = (
        sa.unseen_within_2.expect("unseen pixels"),
        sr.unseen_within_2.expect("unseen pixels"),
    );
    assert!(
        ur >= ua + 0.12,
        "where no source sees: Regions {ur:.3} vs ACMM {ua:.3} (measured 0.632 and 0.009)"
    );
    assert!(
        sr.within_2 >= sa.within_2 + 0.08,
        "where a source sees: Regions {:.3} vs ACMM {:.3} (measured 0.913 and 0.809)",
        sr.within_2,
        sa.within_2
    );
    assert!(weak(&acmm) >= weak(&acmh) + 0.1, "wall: ACMM vs ACMH");
    assert!(weak(&acmh) >= weak(&dwta), "wall: ACMH vs DWTA");
    assert!(
        acmm.within_1 >= acmh.within_1 + 0.05,
        "overall: ACMM vs ACMH"
    );
    assert!(acmh.within_1 >= dwta.within_1, "overall: ACMH vs DWTA");
}

/// Why the synthetic wall comes out too near: score the true plane and the estimated one with
/// the CPU reference of the matching cost on the wall pixels ACMH gets wrong, with the
/// scene's sensor noise and without it.
#[test]
fn wall_error_is_in_the_cost_and_comes_from_noise() {
    use mvscope::acmm::ViewProblem;
    use mvscope::session::Session;
    let ctx = GpuContext::new().unwrap();
    let params = Params::default();
    let view = 2;
    let split = |noise_sigma: f32| {
        let s = mvscope::synthetic::generate(&SyntheticOptions {
            views: 6,
            width: 160,
            height: 120,
            noise_sigma,
            ..SyntheticOptions::default()
        })
        .unwrap();
        let mut session = Session::new(&ctx, &s.scene, params.clone(), Method::Acmh).unwrap();
        session.run_to_end().unwrap();
        let maps = session.final_maps().unwrap();
        let est = &maps[view].as_ref().unwrap().state.plane;
        let gt = &s.ground_truth[view];
        let cam = &s.scene.views[view].camera;
        let truth: Vec<[f32; 4]> = gt
            .depth
            .iter()
            .zip(&gt.normal_world)
            .map(|(&d, n)| {
                let n = cam.dir_camera_from_world(glam::DVec3::new(
                    n[0] as f64,
                    n[1] as f64,
                    n[2] as f64,
                ));
                [n.x as f32, n.y as f32, n.z as f32, d]
            })
            .collect();
        let problem = ViewProblem::new(&s.scene, view, 0);
        let split =
            accuracy::error_split(&problem, &params, est, &truth, Some(&gt.low_texture), 0.05);
        eprintln!("noise {noise_sigma}: view {view} wall: {split:?}");
        split
    };
    let noisy = split(1.0);
    let clean = split(0.0);
    // Measured (lavapipe, 160x120, 6 views, view 2): with the scene's noise (σ = 1 grey
    // level) 5204 of 7689 wall pixels are off by more than 5%, with a median ratio of 0.68
    // (too near), and for 4617 of them (89%) the matching cost of the wrong plane is lower
    // than that of the true one: the cost, not the search, prefers it. Without noise 3137
    // (41%) are off, and the cost still prefers the estimate for 96% of those: noise at the
    // texture's level (±1.8 grey levels) causes most of the bias, the weak texture the rest.
    let wrong_share = |s: &accuracy::ErrorSplit| s.wrong as f64 / s.pixels as f64;
    assert!(wrong_share(&noisy) > 0.5, "{noisy:?}");
    assert!(noisy.median_ratio_of_wrong < 0.85, "{noisy:?}");
    assert!(
        noisy.cost_prefers_estimate as f64 > 0.75 * noisy.wrong as f64,
        "{noisy:?}"
    );
    assert!(
        wrong_share(&clean) < wrong_share(&noisy) - 0.15,
        "noise-free {clean:?} vs noisy {noisy:?}"
    );
}

/// A room (ICL-NUIM's living room: rendered walls, floor and furniture, exact depth for
/// every view), CI's share: views 0, 3 and 4 at half size. ACMM's multi-scale geometric
/// consistency must beat ACMH on the room's pixels within 2% and 5% and on its fused cloud
/// (ETH3D F1 at 5 cm against the cloud of the true depth maps), and Regions must not fall
/// behind ACMM.
#[test]
fn acmm_beats_acmh_in_a_real_room() {
    let suite = icl_room_crop();
    assert!(suite.metric, "the rooms are scored in metres");
    let [acmh, acmm, regions] = run(&suite, [Method::Acmh, Method::Acmm, Method::Regions]);
    for r in [&acmh, &acmm, &regions] {
        eprintln!(
            "{} {}: within 5% {:.3}, weak within 5% {:?}, cloud {:?}, seen {:?}",
            r.scene, r.method, r.within_5, r.low_texture_within_5, r.cloud, r.seen
        );
    }
    let f1 = |r: &AccuracyRow| r.cloud[1].f1;
    // Measured (lavapipe, views 0, 3, 4 of the ICL-NUIM living room at 320x240 with its
    // cameras as shipped, principal points up to 5.5 px off, which
    // `regions_fill_the_room_crop_on_its_corrected_cameras` corrects; docs/accuracy.md): ACMH within 2%
    // 0.120, within 5% 0.352, F1 at 5 cm 0.034; ACMM 0.239, 0.521, 0.199 (+11.9 and +16.9
    // points, F1 5.9x). The margins are about half of that: a multi-scale scheme that stops
    // helping on a real room's walls fails them.
    assert!(
        acmm.within_2 > acmh.within_2 + 0.06,
        "within 2%: ACMM {:.3}, ACMH {:.3} (measured 0.239 and 0.120)",
        acmm.within_2,
        acmh.within_2
    );
    assert!(
        acmm.within_5 > acmh.within_5 + 0.08,
        "within 5%: ACMM {:.3}, ACMH {:.3} (measured 0.521 and 0.352)",
        acmm.within_5,
        acmh.within_5
    );
    assert!(
        f1(&acmm) > 2.0 * f1(&acmh),
        "F1 at 5 cm: ACMM {:.3}, ACMH {:.3} (measured 0.199 and 0.034)",
        f1(&acmm),
        f1(&acmh)
    );
    // Split by what the sources see (the truth projected, not occluded): measured 76.6% of
    // the crop's pixels seen; within 2% there ACMH 0.143, ACMM 0.295 (+15.1 points, more
    // than the +11.9 overall); on the unseen ACMH 0.045, ACMM 0.058. The gain is on the
    // pixels a source sees, and what no source sees stays below half of that (no evidence:
    // a split that mislabels seen pixels as unseen, or the reverse, fails one of these).
    let (sh, sm) = (
        acmh.seen.expect("ACMH split"),
        acmm.seen.expect("ACMM split"),
    );
    assert!(
        (sm.seen - 0.766).abs() < 0.01 && sm.seen == sh.seen,
        "seen share: ACMM {:.3}, ACMH {:.3} (measured 0.766 for both)",
        sm.seen,
        sh.seen
    );
    assert!(
        sm.within_2 > sh.within_2 + 0.075,
        "within 2% where a source sees: ACMM {:.3}, ACMH {:.3} (measured 0.295 and 0.143)",
        sm.within_2,
        sh.within_2
    );
    let unseen = sm.unseen_within_2.expect("unseen pixels");
    assert!(
        unseen < 0.5 * sm.within_2,
        "ACMM within 2% where no source sees {unseen:.3}, where one does {:.3} (measured 0.058 and 0.295)",
        sm.within_2
    );
    // Regions, the method that fills the walls, must not fall behind ACMM in a room (issue
    // 34: no room more than a point behind). Measured on this crop over seeds 0-2 (the test
    // runs seed 0; docs/measurements/slices-2026-12-06/crop-seeds-base.log): within 2%
    // Regions 0.252 / 0.253 / 0.251 against ACMM 0.239 / 0.243 / 0.237 (+1.0 to +1.4
    // points), weak texture within 2% 0.282 / 0.282 / 0.279 against 0.262 / 0.267 / 0.260
    // (+1.5 to +2.0), within 5% 0.540 / 0.541 / 0.540 against 0.521 / 0.519 / 0.518 (+1.9 to
    // +2.2). The margins are about half the smallest gain over seeds. With the flat test
    // beyond the image's noise and the cover band, Regions' defaults since the forty-ninth
    // session (docs/measurements/regions-noise-default-2026-12-07/crop-shipped-seeds.log):
    // 0.253 / 0.253 / 0.251, weak 0.285 / 0.282 / 0.278, within 5% 0.536 / 0.542 / 0.539
    // (+1.0 to +1.4, +1.5 to +2.3, +1.5 to +2.3). (Its fused cloud is
    // behind ACMM's on these cameras, F1 at 5 cm 0.184 / 0.183 / 0.182 against 0.199 / 0.200
    // / 0.198: view 3's principal point is 5.5 px off, its wall's plane is 2.9% near, and
    // the clouds miss each other; on the corrected cameras Regions' cloud leads, held by the
    // next test. docs/accuracy.md, "Regions' cloud on the room crop".)
    regions_ahead(
        "within 2%",
        regions.within_2,
        acmm.within_2,
        0.005,
        (0.252, 0.239),
    );
    regions_ahead(
        "weak texture within 2%",
        weak(&regions),
        weak(&acmm),
        0.007,
        (0.282, 0.262),
    );
    regions_ahead(
        "within 5%",
        regions.within_5,
        acmm.within_5,
        0.009,
        (0.540, 0.521),
    );
}

/// The room crop of `acmm_beats_acmh_in_a_real_room` with its principal points corrected as
/// `mvscope eval` solves them from ACMM's maps at 640 (view 0 by (0, −2) px, view 3 by
/// (−5.5, +1), view 4 by (+4, 0); docs/accuracy.md, "ICL with its cameras corrected"): on
/// cameras that fit its images, Regions must lead ACMM on the room's maps and on its fused
/// cloud (issue 34's walls, and its "no room more than a point behind ACMM").
#[test]
fn regions_fill_the_room_crop_on_its_corrected_cameras() {
    let suite = icl_room_crop_corrected();
    let [acmm, regions] = run(&suite, [Method::Acmm, Method::Regions]);
    for r in [&acmm, &regions] {
        eprintln!(
            "{} {}: within 5% {:.3}, cloud {:?}",
            r.scene, r.method, r.within_5, r.cloud
        );
    }
    // Measured over seeds 0 / 1 / 2 (lavapipe, release; the test runs seed 0;
    // docs/measurements/cloud-2026-12-06/reg-seeds.log): within 2% ACMM 0.606 / 0.605 /
    // 0.605, Regions 0.670 / 0.669 / 0.685 (+6.4 to +8.1 points); weak texture within 2%
    // 0.669 / 0.667 / 0.669 against 0.738 / 0.739 / 0.750 (+7.0 to +8.1); within 5% 0.709 /
    // 0.708 / 0.710 against 0.763 / 0.773 / 0.783 (+5.4 to +7.3); F1 at 5 cm 0.278 / 0.277
    // / 0.280 against 0.304 / 0.305 / 0.298 (+1.8 to +2.8); at 2 cm 0.192 / 0.192 / 0.190
    // against 0.205 / 0.203 / 0.201 (+1.1 to +1.3). Each margin is about half the smallest
    // gain over the seeds. With Regions' defaults of the forty-ninth session (the flat test
    // beyond the image's noise and the cover band;
    // docs/measurements/regions-noise-default-2026-12-07/crop-corrected-seeds.log): within
    // 2% 0.679 / 0.673 / 0.682 (+6.8 to +7.7), weak 0.744 / 0.743 / 0.748 (+7.5 to +7.9),
    // within 5% 0.784 / 0.771 / 0.776 (+6.3 to +7.5), F1 at 5 cm 0.305 / 0.303 / 0.302 (+2.2
    // to +2.7), at 2 cm 0.206 / 0.204 / 0.206 (+1.2 to +1.6): the margins stand.
    let f1 = |r: &AccuracyRow, k: usize| r.cloud[k].f1;
    regions_ahead(
        "within 2%",
        regions.within_2,
        acmm.within_2,
        0.03,
        (0.670, 0.606),
    );
    regions_ahead(
        "weak texture within 2%",
        weak(&regions),
        weak(&acmm),
        0.035,
        (0.738, 0.669),
    );
    regions_ahead(
        "within 5%",
        regions.within_5,
        acmm.within_5,
        0.027,
        (0.763, 0.709),
    );
    regions_ahead(
        "F1 at 5 cm",
        f1(&regions, 1),
        f1(&acmm, 1),
        0.009,
        (0.304, 0.278),
    );
    regions_ahead(
        "F1 at 2 cm",
        f1(&regions, 0),
        f1(&acmm, 0),
        0.005,
        (0.205, 0.192),
    );
}

/// The corrected room crop of `regions_fill_the_room_crop_on_its_corrected_cameras`
/// with white sensor noise of 3 grey levels added (a photograph's grey wall): at the finest
/// scale few wall windows stay under Regions' flat test of 3 grey levels unless the test
/// reads the spread beyond the image's noise (`prior_flat_noise`), and a noisy wall's
/// planes pass the cover test by chance unless it counts the points that miss them evenly
/// on both sides (`prior_region_cover_band`); both are Regions' defaults since the
/// forty-ninth session. Regions must keep most of its clean lead over ACMM there.
#[test]
fn regions_keep_the_walls_under_sensor_noise() {
    let mut suite = icl_room_crop_corrected();
    add_sensor_noise(&mut suite, 3.0);
    let [acmm, regions] = run(&suite, [Method::Acmm, Method::Regions]);
    for r in [&acmm, &regions] {
        eprintln!(
            "{} {}: within 5% {:.3}, cloud {:?}",
            r.scene, r.method, r.within_5, r.cloud
        );
    }
    // Measured over seeds 0 / 1 / 2 (lavapipe, release; the test runs seed 0;
    // docs/measurements/regions-noise-default-2026-12-07/crop-noise3-seeds.log): within 2%
    // ACMM 0.520 / 0.519 / 0.518, Regions 0.636 / 0.658 / 0.691 (+11.6 to +17.3 points);
    // weak texture within 2% 0.567 / 0.565 / 0.566 against 0.708 / 0.730 / 0.771 (+14.1 to
    // +20.5); within 5% 0.648 / 0.646 / 0.646 against 0.753 / 0.760 / 0.763 (+10.5 to
    // +11.7); F1 at 5 cm 0.256 / 0.255 / 0.255 against 0.297 / 0.308 / 0.312 (+4.1 to +5.7).
    // Regions with both options off (its defaults before the forty-ninth session) gave
    // 0.544 / 0.541 / 0.542, 0.595 / 0.592 / 0.594, 0.672 / 0.669 / 0.675 and 0.258 / 0.257 /
    // 0.258: +2.2 to +2.8, +0.2 to +0.3 in the cloud. Each margin is about half the smallest
    // gain over the seeds, so Regions without either fails every one of them.
    let f1 = |r: &AccuracyRow| r.cloud[1].f1;
    regions_ahead(
        "within 2%",
        regions.within_2,
        acmm.within_2,
        0.06,
        (0.636, 0.520),
    );
    regions_ahead(
        "weak texture within 2%",
        weak(&regions),
        weak(&acmm),
        0.07,
        (0.708, 0.567),
    );
    regions_ahead(
        "within 5%",
        regions.within_5,
        acmm.within_5,
        0.05,
        (0.753, 0.648),
    );
    regions_ahead("F1 at 5 cm", f1(&regions), f1(&acmm), 0.02, (0.297, 0.256));
}
