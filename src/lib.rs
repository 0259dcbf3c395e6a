//! mvscope: ACMM multi-view stereo ("Multi-Scale Geometric Consistency Guided Multi-View
//! Stereo", Xu & Tao, CVPR 2019) on wgpu, with a CPU reference of its per-pixel math.
//!
//! Data flows one way: [`scene::Scene`] -> session (pyramid, passes, schedule) -> maps ->
//! fusion -> cloud. The CLI and the viewer only drive the library.

pub mod accuracy;
pub mod acmm;
pub mod bench;
pub mod camera;
pub mod cluster;
pub mod error;
pub mod eval;
pub mod export;
pub mod fusion;
pub mod gpu;
pub mod image;
pub mod io;
pub mod pipeline;
#[cfg(feature = "rerun")]
pub mod rerun_log;
pub mod rng;
pub mod scene;
pub mod session;
pub mod synthetic;
pub mod vfs;
pub mod viewer;
