//! ACMH and ACMM: parameters, the per-view problem, and the CPU reference of the per-pixel
//! math. The GPU passes live in `crate::gpu::acmh`.

pub mod cpu;
pub mod memory;
pub mod multiscale;
pub mod params;
pub mod problem;
pub mod session;

pub use params::{Method, Params, RestorerMode};
pub use problem::{ViewProblem, ViewState, Winner};
