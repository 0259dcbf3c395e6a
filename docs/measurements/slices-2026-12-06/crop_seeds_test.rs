//! Temporary: Regions and ACMM on the accuracy test's ICL crop over seeds 0-2.
use std::path::PathBuf;
use std::sync::Arc;

use mvscope::accuracy;
use mvscope::acmm::{Method, Params};
use mvscope::gpu::GpuContext;
use mvscope::gpu::acmh::AcmhPipelines;

#[test]
fn crop_seeds() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/rgbd/icl-livingroom");
    let suite = accuracy::load_room_crop(&dir, &[0, 3, 4], Some(320)).unwrap();
    let ctx = GpuContext::new().unwrap();
    let pipes = Arc::new(AcmhPipelines::new(&ctx).unwrap());
    for seed in [0u64, 1, 2] {
        for m in [Method::Acmm, Method::Regions] {
            let params = Params { seed, ..Params::default() };
            let t = std::time::Instant::now();
            let r = accuracy::evaluate(&ctx, pipes.clone(), &suite, &m.params(&params), m, accuracy::Options::default()).unwrap();
            eprintln!(
                "seed {seed} {}: within 1% {:.4}, 2% {:.4}, 5% {:.4}, weak2 {:?}, weak5 {:?}, f1 {:.4} {:.4}, cloud {:?}, {:.1} s",
                r.method, r.within_1, r.within_2, r.within_5, r.low_texture_within_2, r.low_texture_within_5,
                r.cloud[0].f1, r.cloud[1].f1, r.cloud, t.elapsed().as_secs_f64()
            );
        }
    }
}
