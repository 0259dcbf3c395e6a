//! Temporary: ACMM and Regions on the ICL crop with its principal points corrected, seeds 0-2
//! (copy into tests/ as zz_tmp_reg_seeds.rs to run).
use std::path::PathBuf;
use std::sync::Arc;

use mvscope::accuracy;
use mvscope::acmm::{Method, Params};
use mvscope::gpu::GpuContext;
use mvscope::gpu::acmh::AcmhPipelines;

#[test]
fn reg_seeds() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/rgbd/icl-livingroom");
    let mut suite = accuracy::load_room_crop(&dir, &[0, 3, 4], Some(320)).unwrap();
    // mvscope eval's corrections at 640 px: view 0 (0, -2), view 3 (-5.5, +1), view 4 (+4, 0).
    for (view, (dx, dy)) in suite.scene.views.iter_mut().zip([(0.0, -2.0), (-5.5, 1.0), (4.0, 0.0)]) {
        let s = view.camera.width as f64 / 640.0;
        view.camera.intrinsics.cx += dx * s;
        view.camera.intrinsics.cy += dy * s;
    }
    let ctx = GpuContext::new().unwrap();
    let pipes = Arc::new(AcmhPipelines::new(&ctx).unwrap());
    for seed in [0u64, 1, 2] {
        for m in [Method::Acmm, Method::Regions] {
            let params = Params { seed, ..Params::default() };
            let t = std::time::Instant::now();
            let r = accuracy::evaluate(&ctx, pipes.clone(), &suite, &m.params(&params), m, accuracy::Options::default()).unwrap();
            eprintln!(
                "seed {seed} {}: within 1% {:.4}, 2% {:.4}, 5% {:.4}, weak2 {:.4}, weak5 {:.4}, F1 2cm {:.4} 5cm {:.4}, acc5 {:.4} comp5 {:.4}, {:.1} s",
                r.method, r.within_1, r.within_2, r.within_5, r.low_texture_within_2.unwrap(), r.low_texture_within_5.unwrap(),
                r.cloud[0].f1, r.cloud[1].f1, r.cloud[1].accuracy, r.cloud[1].completeness, t.elapsed().as_secs_f64()
            );
        }
    }
}
