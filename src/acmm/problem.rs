//! One reference view's matching problem in the f32 form that both the GPU passes and the CPU
//! reference consume, and the per-pixel state they produce. Building it once, in one place, is
//! what makes the two bit-comparable: they read the same rounded cameras.

use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DVec3};

use super::params::Params;
use crate::camera::Camera;
use crate::scene::{DepthRange, Scene};

/// A source view as seen from the reference: its intrinsics, the relative pose
/// `src_from_ref` (`X_src = R X_ref + t`), and where its pixels sit in the image buffer.
/// Keep in sync with `struct Source` in shaders/shared/problem.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSource {
    /// fx, fy, cx, cy
    pub k: [f32; 4],
    /// Rows of R (`src_from_ref`), w unused.
    pub r0: [f32; 4],
    pub r1: [f32; 4],
    pub r2: [f32; 4],
    /// t in xyz.
    pub t: [f32; 4],
    /// width, height, offset of the first pixel in the image buffer, unused.
    pub size: [u32; 4],
}

/// The reference view and its sources, in f32.
#[derive(Clone, Debug)]
pub struct ViewProblem {
    /// Index of the reference view in the scene (its images' place in the level's layout).
    pub view: u32,
    /// The view's number in every random number's key: `view`, or for a session over part
    /// of a scene (a cluster task), the view's index in the whole scene, so that the part
    /// draws the numbers the whole run draws.
    pub key: u32,
    /// Pyramid level (0 = finest) (part of the random key).
    pub scale: u32,
    pub width: u32,
    pub height: u32,
    /// fx, fy, cx, cy of the reference.
    pub k: [f32; 4],
    pub depth_min: f32,
    pub depth_max: f32,
    /// Reference intensities followed by each source's (offsets in `sources[j].size[2]`).
    pub images: Vec<f32>,
    pub sources: Vec<GpuSource>,
    /// Scene index of each source.
    pub source_views: Vec<usize>,
}

impl ViewProblem {
    /// The problem of view `index` of `scene` (at whatever scale the scene is).
    pub fn new(scene: &Scene, index: usize, scale: u32) -> ViewProblem {
        let view = &scene.views[index];
        let sources: Vec<usize> = view.sources.iter().map(|s| s.index).collect();
        let cameras: Vec<&Camera> = sources.iter().map(|&s| &scene.views[s].camera).collect();
        let grays: Vec<&[f32]> = sources
            .iter()
            .map(|&s| scene.views[s].image.gray.as_slice())
            .collect();
        Self::from_parts(
            index as u32,
            scale,
            &view.camera,
            &view.image.gray,
            view.depth_range,
            &cameras,
            &grays,
            sources,
        )
    }

    /// `new` without the intensities (`images` empty, every source's offset 0): what a solver
    /// that reads a level's shared images needs, without copying them.
    pub fn header(scene: &Scene, index: usize, scale: u32) -> ViewProblem {
        let view = &scene.views[index];
        let sources: Vec<usize> = view.sources.iter().map(|s| s.index).collect();
        let cameras: Vec<&Camera> = sources.iter().map(|&s| &scene.views[s].camera).collect();
        let grays: Vec<&[f32]> = vec![&[]; sources.len()];
        Self::from_parts(
            index as u32,
            scale,
            &view.camera,
            &[],
            view.depth_range,
            &cameras,
            &grays,
            sources,
        )
    }

    /// Assembles a problem from cameras and intensity images (`grays[j]` belongs to
    /// `cameras[j]` and has its size).
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        view: u32,
        scale: u32,
        reference: &Camera,
        reference_gray: &[f32],
        range: DepthRange,
        cameras: &[&Camera],
        grays: &[&[f32]],
        source_views: Vec<usize>,
    ) -> ViewProblem {
        let mut images = reference_gray.to_vec();
        let ref_rot: DMat3 = reference.rotation;
        let ref_t: DVec3 = reference.translation;
        let sources = cameras
            .iter()
            .zip(grays)
            .map(|(cam, gray)| {
                // src_from_ref = src_from_world * world_from_ref
                let r = cam.rotation * ref_rot.transpose();
                let t = cam.translation - r * ref_t;
                let row = |i: usize| {
                    let v = r.row(i);
                    [v.x as f32, v.y as f32, v.z as f32, 0.0]
                };
                let offset = images.len() as u32;
                images.extend_from_slice(gray);
                let k = &cam.intrinsics;
                GpuSource {
                    k: [k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32],
                    r0: row(0),
                    r1: row(1),
                    r2: row(2),
                    t: [t.x as f32, t.y as f32, t.z as f32, 0.0],
                    size: [cam.width, cam.height, offset, 0],
                }
            })
            .collect();
        let k = &reference.intrinsics;
        ViewProblem {
            view,
            key: view,
            scale,
            width: reference.width,
            height: reference.height,
            k: [k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32],
            depth_min: range.min as f32,
            depth_max: range.max as f32,
            images,
            sources,
            source_views,
        }
    }

    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    pub fn num_sources(&self) -> usize {
        self.sources.len()
    }
}

/// What every pixel holds between passes (and what the viewer shows).
#[derive(Clone, Debug, PartialEq)]
pub struct ViewState {
    pub width: u32,
    pub height: u32,
    pub num_sources: usize,
    /// Normal (reference camera frame, facing the camera) in xyz, depth in w.
    pub plane: Vec<[f32; 4]>,
    /// Aggregated matching cost of the plane, in [0, 2].
    pub cost: Vec<f32>,
    /// Bit j: source j is in the view-selection set S_t (DWTA: among the top K).
    pub selected: Vec<u32>,
    /// w'(I_j) of each source, `num_sources` per pixel.
    pub weights: Vec<f32>,
    /// Bits 0-7: which hypothesis won ([`Winner`]); bits 8-15: the most important view
    /// v_t ([`NO_VIEW`] when none).
    pub aux: Vec<u32>,
}

/// No view (for v_t) — also "no candidate".
pub const NO_VIEW: u32 = 255;

/// Which hypothesis a pixel adopted in its last update (`aux & 0xff`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Winner {
    /// The random initial plane.
    Initial,
    /// Adaptive checkerboard area 0..8 (up V, up strip, down V, down strip, left V, left
    /// strip, right V, right strip).
    Propagated(u8),
    /// The plane the pixel already had.
    Kept,
    /// Refinement hypothesis 0..6: (d_rand, n), (d, n_rand), (d_rand, n_rand), (d_pert, n),
    /// (d, n_pert), (d_pert, n_pert).
    Refined(u8),
    /// The pixel's prior plane, kept because no source's image holds its point
    /// (`Params::prior_keep_unseen`).
    PriorUnseen,
}

impl Winner {
    pub const INITIAL: u32 = 254;
    pub const KEPT: u32 = 8;
    pub const PRIOR_UNSEEN: u32 = 15;

    pub fn code(self) -> u32 {
        match self {
            Winner::Initial => Self::INITIAL,
            Winner::Propagated(i) => i as u32,
            Winner::Kept => Self::KEPT,
            Winner::Refined(i) => 9 + i as u32,
            Winner::PriorUnseen => Self::PRIOR_UNSEEN,
        }
    }

    pub fn from_code(code: u32) -> Option<Winner> {
        match code {
            0..=7 => Some(Winner::Propagated(code as u8)),
            8 => Some(Winner::Kept),
            9..=14 => Some(Winner::Refined((code - 9) as u8)),
            Self::PRIOR_UNSEEN => Some(Winner::PriorUnseen),
            Self::INITIAL => Some(Winner::Initial),
            _ => None,
        }
    }
}

impl ViewState {
    /// A state whose every value is garbage-but-valid-looking, so tests notice a pass that
    /// forgets to write something.
    pub fn garbage(width: u32, height: u32, num_sources: usize) -> ViewState {
        let n = width as usize * height as usize;
        ViewState {
            width,
            height,
            num_sources,
            plane: vec![[f32::NAN; 4]; n],
            cost: vec![f32::NAN; n],
            selected: vec![0xdead_beef; n],
            weights: vec![f32::NAN; n * num_sources],
            aux: vec![0xdead_beef; n],
        }
    }

    pub fn depth(&self) -> Vec<f32> {
        self.plane.iter().map(|p| p[3]).collect()
    }
}

/// Number of window samples the kernels use.
pub fn window_samples(params: &Params) -> usize {
    let n = params.window_offsets().len();
    n * n
}
