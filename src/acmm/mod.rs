//! ACMH, ACMM, ACMP and ACMMP: parameters, the per-view problem, the device memory a run needs
//! (`memory`), and the CPU reference of the per-pixel math (the planar prior's in `planar`,
//! its hypothesis score in `prior`). The GPU passes live in `crate::gpu::acmh`.

pub mod cpu;
pub mod lines;
pub mod memory;
pub mod multiscale;
pub mod params;
pub mod planar;
pub mod prior;
pub mod problem;
pub mod pyramid_depth;

pub use params::{Method, Params, RestorerMode};
pub use problem::{ViewProblem, ViewState, Winner};
