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

/// A grid cell's eight neighbours as (x, y) steps, row by row: the segment detector's
/// region growing (`lines`) and the regions' crease test (`planar`) walk them.
pub(crate) const NEIGHBOURS_8: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];
