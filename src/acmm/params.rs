//! Which method runs ([`Method`]: ACMH, DWTA, ACMM, ACMP, ACMMP) and every parameter of them
//! in one serde struct, each documented with its paper symbol: matching, propagation, the
//! multi-scale scheme, the planar prior and fusion. Defaults are the papers' and, where they
//! are silent, the authors' code's (see ACMM-REFERENCE.md, ACMP-REFERENCE.md).

use serde::{Deserialize, Serialize};

/// Which algorithm runs.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Multi-scale geometric consistency on top of ACMH (the paper's full method).
    #[default]
    Acmm,
    /// Adaptive checkerboard sampling + multi-hypothesis joint view selection, one scale.
    Acmh,
    /// The paper's ablation baseline: Gipuma's fixed 8-neighbour diffusion with top-k
    /// winner-take-all view selection.
    Dwta,
    /// ACMH with the planar prior (Xu & Tao, AAAI 2020), one scale: photometric ACMH, a
    /// prior from credible points triangulated in the image, the prior-assisted pass, then
    /// geometric consistency.
    Acmp,
    /// ACMM with the planar prior rebuilt at every scale (Xu, Kong, Tao et al., TPAMI 2022).
    Acmmp,
    /// Region planes: ACMMP whose prior gives each flat region (4-connected cells of flat
    /// matching windows) the plane most of its support points agree on (RANSAC), with
    /// support points taken on flat windows too and, in each cell, the one of best
    /// HPM-MVS++ support score (cost − multi-view confidence), a window flat around its
    /// ramp of shading, a prior past the support points' hull (HPM-MVS), a prior plane no
    /// source sees kept, a plane judged by the points a source could contradict, and
    /// windows weighted by the adaptive bilateral weight, which keeps a textured object's
    /// samples out of a weak window beside it, and regions that stop at an intensity edge:
    /// `prior_regions`, `prior_flat_points`, `prior_confirmed_points`,
    /// `prior_confidence_score`, `prior_flat_ramp`, `prior_extend`, `prior_keep_unseen`,
    /// `prior_region_cover_seen`, `prior_region_edge` and `prior_flat_noise` on,
    /// `prior_region_cover_band = 3`, `bilateral_kernel = "adaptive"` (docs/method.md,
    /// "Region planes").
    Regions,
}

impl Method {
    /// Every method, in the order lists and tables show them.
    pub const ALL: [Method; 6] = [
        Method::Dwta,
        Method::Acmh,
        Method::Acmm,
        Method::Acmp,
        Method::Acmmp,
        Method::Regions,
    ];

    /// Whether it runs a pyramid of scales (ACMM's multi-scale scheme).
    pub fn is_multiscale(self) -> bool {
        matches!(self, Method::Acmm | Method::Acmmp | Method::Regions)
    }

    /// Whether it runs geometric consistency passes (paper Sec. 5.1).
    pub fn has_geometric(self) -> bool {
        matches!(
            self,
            Method::Acmm | Method::Acmp | Method::Acmmp | Method::Regions
        )
    }

    /// Whether it builds the planar prior (ACMP-REFERENCE.md §1).
    pub fn has_planar_prior(self) -> bool {
        matches!(self, Method::Acmp | Method::Acmmp | Method::Regions)
    }

    /// Whether the images' texture decides the number of scales (ACMM and ACMMP with
    /// `params.scales_by_texture`).
    pub fn deepens_pyramid(self, params: &Params) -> bool {
        params.scales_by_texture && self.is_multiscale()
    }

    /// Its default parameters: [`Params::default`] with what the method itself turns on
    /// (Regions: `prior_regions`, `prior_flat_points`, `prior_confirmed_points`,
    /// `prior_confidence_score`, `prior_flat_ramp`, `prior_extend`, `prior_keep_unseen`,
    /// `prior_region_cover_seen`, `prior_region_edge`, `prior_flat_noise`, the cover band
    /// `prior_region_cover_band = 3`, and the adaptive bilateral weight, `bilateral_kernel`;
    /// the others set nothing). A session runs the parameters it is
    /// given as they are, so a run of a method starts from these: `--method regions --set
    /// prior_confidence_score=false` is Regions without the score.
    pub fn defaults(self) -> Params {
        let mut p = Params::default();
        if self == Method::Regions {
            p.prior_regions = true;
            p.prior_flat_points = true;
            p.prior_confirmed_points = true;
            p.prior_confidence_score = true;
            p.prior_flat_ramp = true;
            p.prior_extend = true;
            p.prior_keep_unseen = true;
            p.prior_region_cover_seen = true;
            p.prior_region_edge = true;
            p.prior_flat_noise = true;
            p.prior_region_cover_band = 3.0;
            p.bilateral_kernel = BilateralKernel::Adaptive;
        }
        p
    }

    /// `params`, chosen for a run of `from`, as this method runs them: every parameter the
    /// user changed from `from`'s default is kept, every other takes this method's default.
    /// Switching the viewer from ACMM to Regions turns Regions' options on; a change of τ0
    /// carries over; turning Regions' score off and comparing against ACMMP keeps it off.
    pub fn adopt(self, params: &Params, from: Method) -> Params {
        if self == from {
            return params.clone();
        }
        let (old, new) = (from.defaults(), self.defaults());
        let mut p = params.clone();
        macro_rules! carry {
            ($($field:ident),*) => {$(
                if params.$field == old.$field {
                    p.$field = new.$field;
                }
            )*};
        }
        // The fields a method's defaults set (see `defaults`); the rest are common.
        carry!(
            prior_regions,
            prior_flat_points,
            prior_confirmed_points,
            prior_confidence_score,
            prior_flat_ramp,
            prior_extend,
            prior_keep_unseen,
            prior_region_cover_seen,
            prior_region_edge,
            prior_flat_noise,
            prior_region_cover_band,
            bilateral_kernel
        );
        p
    }

    /// What a run's record of format 0 (written before a method's own options became
    /// defaults, when its session turned the options of the time on over the written ones)
    /// ran: [`Method::params`] of the written parameters, less `prior_flat_ramp`,
    /// `prior_extend`, `prior_keep_unseen`, `prior_region_cover_seen`, `bilateral_kernel`,
    /// `prior_region_edge`, `prior_flat_noise` and `prior_region_cover_band`, which became
    /// Regions' own after that format and which such a run used only as written.
    pub fn ran_at_format_0(self, written: &Params) -> Params {
        Params {
            prior_flat_ramp: written.prior_flat_ramp,
            prior_extend: written.prior_extend,
            prior_keep_unseen: written.prior_keep_unseen,
            prior_region_cover_seen: written.prior_region_cover_seen,
            bilateral_kernel: written.bilateral_kernel,
            prior_region_edge: written.prior_region_edge,
            prior_flat_noise: written.prior_flat_noise,
            prior_region_cover_band: written.prior_region_cover_band,
            ..self.params(written)
        }
    }

    /// One set of parameters shared by several methods (a comparison, a benchmark over
    /// methods, given relative to [`Params::default`]) as this method runs them: see
    /// [`Method::adopt`].
    pub fn params(self, shared: &Params) -> Params {
        self.adopt(shared, Method::Acmm)
    }

    /// Whether its views are coupled (a geometric pass reads the other views' depths), so
    /// they cannot be run or resumed one at a time.
    pub fn couples_views(self) -> bool {
        self.has_geometric()
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Method::Acmm => "ACMM",
            Method::Acmh => "ACMH",
            Method::Dwta => "DWTA",
            Method::Acmp => "ACMP",
            Method::Acmmp => "ACMMP",
            Method::Regions => "Regions",
        })
    }
}

/// The bilateral weight of a window sample (see [`Params::sigma_spatial`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BilateralKernel {
    /// `exp(-|Δx| / (2σs²) - |ΔI| / (2σc²))`: distances unsquared, the ACMM authors' form, for
    /// which σs = 5 and σc = 3 were tuned. The default of every method but Regions.
    Laplacian,
    /// `exp(-|Δx|² / (2σs²) - |ΔI|² / (2σc²))`: the form of Schönberger et al. (COLMAP's),
    /// whose bilateral NCC the paper cites. With σc = 3 a sample 10 grey levels from the
    /// centre weighs 0.004 (unsquared: 0.57), so a weak window is not matched at the depth of
    /// a textured object beside it; it gains on Middlebury, ICL and the synthetic scenes and
    /// loses on the kitchen (docs/accuracy.md, "Windows that stop at an edge"). A window's
    /// weights are taken relative to its heaviest sample, and the source side is shifted by it.
    Gaussian,
    /// The Gaussian form whose colour σ is the window's own spread: the robust standard
    /// deviation of its samples' differences from the centre (1.4826 × their median absolute
    /// value), never below σc. A weak window keeps σc and stops at an edge that covers less
    /// than half of it; a textured window keeps the samples of its own texture, which σc = 3
    /// cut away on a noisy sensor image (docs/accuracy.md, "A colour scale from the window").
    /// Regions' default.
    Adaptive,
}

/// How the detail restorer (Sec. 5.2) runs the basic model and uses C_init − C_photo > ξ.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RestorerMode {
    /// The basic model starts from the upsampled planes (C_init is their cost) and runs
    /// ungated, so every pixel is optimised at this scale; C_init − C_photo > ξ marks the
    /// errors in details it replaced (the difference map and replaced mask). The default:
    /// measured on ground truth it keeps the coarse scales' gain in weak texture and the
    /// finer scale's precision elsewhere (docs/method.md, "Detail restorer").
    Refine,
    /// As `Refine`, but a pixel adopts a new plane only where its cost beats C_init by ξ
    /// (the gate the authors' code intends). Pixels whose upsampled plane is slightly off
    /// keep it, and the geometric passes then hold that sub-pixel error in place.
    Gated,
    /// The basic model runs from random planes; afterwards C_init and C_photo are compared
    /// with its final view weights and the upsampled plane is kept unless the difference
    /// exceeds ξ (the paper's wording read literally).
    Random,
}

/// All parameters of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    // --- Multi-hypothesis joint view selection (Sec. 4.3) ---
    /// τ0: initial good-matching-cost threshold; τ(t) = τ0·exp(-t²/α).
    pub tau0: f32,
    /// τ1: fixed bad-matching-cost threshold (τ1 > τ(t)).
    pub tau1: f32,
    /// α: how fast τ(t) decays with the iteration t.
    pub alpha: f32,
    /// β: confidence C(m) = exp(-m²/(2β²)).
    pub beta: f32,
    /// n1: a view is selected when MORE than n1 of the 8 costs are below τ(t)...
    pub n1: u32,
    /// n2: ...and FEWER than n2 costs are above τ1.
    pub n2: u32,

    // --- Matching cost: bilateral weighted NCC (Sec. 4.3, after Schönberger et al.) ---
    /// Half size of the matching window (5: an 11x11 window).
    pub window_radius: u32,
    /// Sample every `window_step`-th row and column (2: 36 of the 121 pixels).
    pub window_step: u32,
    /// σs: spatial spread of the bilateral weight, in pixels.
    pub sigma_spatial: f32,
    /// σc: intensity spread of the bilateral weight, in grey levels (0..255).
    pub sigma_color: f32,
    /// Form of the bilateral weight.
    pub bilateral_kernel: BilateralKernel,

    // --- Initialisation, propagation, refinement (Sec. 4.1, 4.2, 4.4) ---
    /// K: the initial cost (and DWTA's cost) is the mean of the K best per-view costs.
    pub top_k: u32,
    /// Red-black iterations of ACMH and DWTA run as methods of their own (the paper's runtime
    /// section: both converge after 6).
    pub iterations: u32,
    /// Refinement: a perturbed depth is d·(1 ± this), uniformly.
    pub perturb_depth: f32,
    /// Refinement: a perturbed normal tilts by up to ± this along each of two tangent
    /// directions, in radians (the original's 0.01π per spherical angle).
    pub perturb_normal: f32,
    /// Half size of the final median filter on depth (2: the paper's 5x5).
    pub median_radius: u32,
    /// Median-filter depth at the end of every pass (the original code, which ends each run
    /// of its basic model with it) instead of once, on the final depth maps (the paper: "at
    /// the end, a median filter of size 5x5 is applied to our final depth maps"). Same for
    /// ACMH and DWTA, which have one pass.
    pub median_every_pass: bool,

    // --- Multi-scale geometric consistency (Sec. 5) ---
    /// k: number of scales.
    pub scales: u32,
    /// Instead of k: as many scales as it takes (at most 8) for the coarsest one's long side
    /// to be at most this many pixels (0: off, the paper's fixed k). The paper's reason for
    /// the pyramid is that texture richness is relative to the window; a fixed k leaves a
    /// 12 Mpx photo's coarsest scale at 1000x750 (docs/accuracy.md, "Full size").
    pub coarsest_size: u32,
    /// Instead of k alone: at least k scales, and as many more as it takes (η apart) for the
    /// matching window at the coarsest scale to reach textured pixels from 95% of the pixels,
    /// measured on the images (chessboard distance to the nearest pixel whose window varies
    /// by 3 grey levels or more); the coarsest long side keeps at least four windows. The
    /// paper's reason for the pyramid, "texture richness is a relative measure", made to
    /// decide its depth (`acmm::pyramid_depth`; docs/method.md).
    pub scales_by_texture: bool,
    /// η: downsampling factor between scales.
    pub eta: f32,
    /// δ: truncation of the forward-backward reprojection error, in pixels.
    pub delta: f32,
    /// λ: weight of the reprojection error in m_geo.
    pub lambda: f32,
    /// ξ: the detail restorer replaces a pixel where C_init − C_photo > ξ.
    pub xi: f32,
    /// Red-black iterations of ACMM's photometric pass at the coarsest scale (3: with two
    /// geometric passes of 2, the paper's 7 iterations at the coarsest scale).
    pub coarse_iterations: u32,
    /// Red-black iterations of the detail restorer's basic model at each finer scale (2: with
    /// two geometric passes of 2, the paper's 6 iterations at the other scales).
    pub restorer_iterations: u32,
    /// How the detail restorer runs (see [`RestorerMode`]).
    pub restorer: RestorerMode,
    /// Red-black iterations of each geometric consistency pass.
    pub geometric_iterations: u32,
    /// Geometric consistency passes per scale (the paper runs it twice).
    pub geometric_passes: u32,
    /// Build the pyramid the original code's way instead of k and η: halve until the long
    /// side is at most 1000 px.
    pub original_pyramid: bool,
    /// Joint bilateral upsampling: half size of the window in coarse pixels (2: 5x5).
    pub jbu_radius: u32,
    /// Joint bilateral upsampling: spatial σ in coarse pixels.
    pub jbu_sigma_spatial: f32,
    /// Joint bilateral upsampling: range σ on the fine image's intensity (0..255).
    pub jbu_sigma_range: f32,

    // --- Planar prior (ACMP and ACMMP; ACMP-REFERENCE.md §2-4) ---
    /// Side of the grid cells (pixels) in each of which at most one credible support point,
    /// the cell's lowest-cost pixel, is picked (the authors' 5).
    pub prior_cell: u32,
    /// A cell's lowest-cost pixel is a credible support point when its cost is below this
    /// (0.1); the prior-assisted pass restarts from the prior plane the pixels whose cost is
    /// at least this.
    pub prior_cost_threshold: f32,
    /// A triangle is dropped when the plane through its three support points is more than
    /// this many degrees from any of its vertices' own normals (30, fusion's θ): it bridges a
    /// depth discontinuity or has a wrong vertex. 180 keeps every triangle (the authors'
    /// code, which checks nothing).
    pub prior_triangle_normal: f32,
    /// A support point must also be multi-view consistent: its depth reprojected into a
    /// source view and back through that source's depth (the previous stage's snapshot, as
    /// the geometric term reads it) lands within this many pixels of it, for at least one
    /// source; the cell's lowest-cost such pixel is taken. 0 takes the lowest-cost pixel
    /// unchecked (the authors' code). Default 2 px, fusion's ψ (docs/method.md, departure 3).
    pub prior_consistency: f32,
    /// γ: the floor of the prior factor γ + exp(−Δd²/2σd²)·exp(−Δθ²/2σθ²) in the score
    /// exp(−m²/β)·(γ + ...), so a hypothesis far from the prior keeps a photometric say.
    pub prior_gamma: f32,
    /// β of the prior-weighted score: the photometric likelihood exp(−m²/β) (0.18, i.e.
    /// 2σ² with σ = 0.3). Not the view-selection β above.
    pub prior_beta: f32,
    /// σd as a share of the view's depth range: σd = this · (d_max − d_min) (1/64).
    pub prior_sigma_depth: f32,
    /// σθ: the spread of the angle between a hypothesis's normal and the prior's, degrees (5).
    pub prior_sigma_normal: f32,
    /// Red-black iterations of the prior-assisted pass (3).
    pub prior_iterations: u32,
    /// The prior-assisted pass updates every pixel (the authors' code), instead of only the
    /// pixels that have a prior. Off by default: for the others it is only more photometric
    /// iterations at the same scale, which cost ACMM accuracy in weak texture (docs/accuracy.md).
    pub prior_everywhere: bool,
    /// The prior past the support points' hull (HPM-MVS): a pixel no triangle covers takes
    /// the plane of the first non-collinear triple, among the 6 support points nearest its
    /// grid cell's centre, that agrees with its points' normals as a triangle must. Off by
    /// default (ACMP and ACMMP have no prior there; docs/method.md); on in Regions, where a
    /// pixel no source sees keeps it (`prior_keep_unseen`).
    pub prior_extend: bool,
    /// Pixels whose depth is already multi-view consistent (the support points' check: least
    /// reprojection error below `prior_consistency`) get no prior and keep their plane through
    /// the prior-assisted pass (HPM-MVS++'s locking): a prior made from other surfaces cannot
    /// replace a depth the other views confirm. Off by default (ACMP and ACMMP restart every
    /// pixel of high cost; docs/method.md).
    pub prior_lock: bool,
    /// Anchors for the weak pixels (APD-MVS's non-local anchors, without its cost curve test):
    /// a pixel whose depth is not multi-view consistent looks along 8 directions, at 2, 4,
    /// 8, ... 128 px, for the nearest pixel that is (the support points' check, so it needs
    /// `prior_consistency` > 0); the plane through three of those anchors whose triangle holds
    /// the pixel, agreed on by the most of them (at least `prior_anchor_inliers`, each within
    /// `prior_anchor_tolerance` of its depth), becomes the pixel's prior, and in the
    /// prior-assisted pass its matching cost becomes (1 − `prior_anchor_weight`) × its own
    /// window's cost + `prior_anchor_weight` × the mean cost of its agreeing anchors' windows,
    /// all warped by the pixel's own hypothesis: on a textureless wall the right plane is the
    /// one that also matches the textured pixels around it. Off by default (docs/method.md).
    pub prior_anchors: bool,
    /// Share of the anchors' windows in a weak pixel's cost (APD-MVS: 0.75).
    pub prior_anchor_weight: f32,
    /// An anchor agrees with a plane when the plane's depth on its ray is within this share
    /// of its own depth (APD-MVS: 1% of the depth range, tightened per round).
    pub prior_anchor_tolerance: f32,
    /// The fewest agreeing anchors (of at most 8) that make a plane: 5, a majority.
    pub prior_anchor_inliers: u32,
    /// An anchor's pixel must also have a distinct cost minimum at its depth (APD-MVS's
    /// weak-texture test: along its most important source's epipolar line, ±30 one-pixel
    /// steps, the lowest cost within 2 steps, at most 0.5, no other local minimum within 0.2
    /// of it), besides being multi-view consistent. Off: on ICL it took ACMMP with anchors
    /// from 17.5 to 16.2% within 2% (docs/accuracy.md, "Anchors: what the tool found").
    pub prior_anchor_distinct: bool,
    /// How many sources must agree with an anchor's depth (reprojection error below
    /// `prior_consistency`): 1, the support points' check; 2 or more asks what HPM-MVS++'s
    /// multi-view confidence asks.
    pub prior_anchor_views: u32,
    /// How many sources must agree with a support point's depth (reprojection error below
    /// `prior_consistency`, with `prior_consistency` > 0): 1, departure 3's check; 2 or more
    /// asks what HPM-MVS++'s multi-view confidence asks of its support points. With anchors,
    /// their pixels must pass it too. Off (1): on ICL at 320 (mean of seeds 0-3) it took ACMMP
    /// from 16.8 to 17.5 (2) and 18.1% (3) within 2%, towards ACMM's 19.0, by giving fewer
    /// pixels a prior; on two-view scenes (one source) any value above 1 leaves no support
    /// point (docs/accuracy.md, "Seeds, and support points more sources confirm").
    pub prior_support_views: u32,
    /// The planar prior stage after the first geometric consistency pass of each scale
    /// instead of before all of them: its support points, their multi-view check and the
    /// lock read a result the other views have already been reconciled with, and the
    /// remaining geometric passes follow the prior-assisted pass (the same number of passes
    /// as ACMMP's order). Off by default (ACMP and ACMMP build the prior from the
    /// photometric pass just before it; docs/method.md).
    pub prior_after_geometric: bool,
    /// Regions' planes chosen region by region between two fits (docs/method.md, "The
    /// per-region choice"): each scale's first geometric pass begins with the support
    /// points of the restorer's result (the authors' order's), kept with the view; the prior
    /// stage then follows that pass, as with `prior_after_geometric`, triangulates those
    /// earlier points, and each flat region takes the planes fitted to that pass's points
    /// only where they hold more of its points than the earlier points' planes
    /// ([`crate::acmm::planar::choose_regions`]). Needs `prior_regions`; off by default.
    pub prior_region_choice: bool,
    /// Support points on flat windows (docs/method.md, `prior_flat_points`): a cell whose
    /// lowest-cost pixel is not credible (cost at least `prior_cost_threshold`) takes its
    /// lowest-cost pixel among those whose matching window is flat (intensities varying by
    /// less than 3 grey levels, [`crate::acmm::planar::FLAT_WINDOW_STD`]) when that cost is
    /// below `prior_flat_cost`. On a weak wall the right depth matches only moderately
    /// (cost 0.3-0.7), and the low-cost points there are the fattened ones, whose window
    /// borrows an edge of the object in front; a flat window has no edge to borrow. Off by
    /// default (ACMP and ACMMP take only low-cost points).
    pub prior_flat_points: bool,
    /// The highest cost of a support point on a flat window (0.7: a correlation of 0.3).
    pub prior_flat_cost: f32,
    /// A window is flat when its intensities differ from their least-squares plane over the
    /// window (a ramp of shading) by less than [`crate::acmm::planar::FLAT_WINDOW_STD`],
    /// instead of from their mean: NCC is blind to an affine change of intensity, and a ramp
    /// moved along itself is the same ramp plus a constant, so a shaded wall is as
    /// featureless to the matching cost as a uniform one (docs/method.md,
    /// `prior_flat_ramp`). Read by `prior_flat_points` and `prior_regions`. Off by default; on
    /// in Regions.
    pub prior_flat_ramp: bool,
    /// A window is flat when the samples the matching cost weighs are: its spread is taken
    /// over the matching window's samples under their bilateral weights (the kernel in
    /// force; around their weighted least-squares ramp with `prior_flat_ramp`), not over
    /// every pixel of the window alike. With a weight that keeps an object's samples out of
    /// a wall window beside it (`bilateral_kernel = "adaptive"`), the wall up to the object
    /// is as flat to the test as it is to the cost, so its cells join the wall's region
    /// instead of leaving a band the window's width along every edge without a plane
    /// (docs/method.md, `prior_flat_weighted`). Read by `prior_flat_points` and
    /// `prior_regions`. Off by default: with `prior_region_edge` it gains where the cameras
    /// are right (registered ICL, synthetic, Middlebury, kitchen-a) but takes the wall planes
    /// of two views of the shipped ICL, whose cameras are 2-7 px off (docs/accuracy.md,
    /// "Regions that stop at an edge").
    pub prior_flat_weighted: bool,
    /// A window is flat when its intensities vary by less than
    /// [`crate::acmm::planar::FLAT_WINDOW_STD`] beyond the image's sensor noise: the noise's
    /// variance, estimated from the reference image at the step's level
    /// ([`crate::acmm::planar::image_noise`], Immerkær's Laplacian difference over the most
    /// homogeneous blocks), is taken from each window's variance before the test. A wall
    /// photographed with noise of 3 grey levels or more has no window under 3 otherwise, so
    /// it gets no flat support points and no region (docs/method.md, `prior_flat_noise`).
    /// Read by `prior_flat_points` and `prior_regions`. Off by default, on in Regions'
    /// (with `prior_region_cover_band`, which keeps the noisy wall's planes the cover test
    /// would drop by chance; docs/accuracy.md, "Regions under sensor noise, by default").
    pub prior_flat_noise: bool,
    /// Support points the most sources confirm (HPM-MVS++'s multi-view confidence used to
    /// rank, docs/method.md): among a cell's credible pixels (cost below the limit, depth in
    /// range, multi-view consistent), the one the most sources agree with (reprojection
    /// error through their depths below `prior_consistency`), the lowest cost among those,
    /// instead of the lowest cost alone. The cells that keep a point are the same; only
    /// which pixel speaks for the cell changes. Needs `prior_consistency` > 0. Off by
    /// default (ACMP and ACMMP take the lowest cost).
    pub prior_confirmed_points: bool,
    /// With `prior_confirmed_points`: rank a cell's credible pixels by HPM-MVS++'s support
    /// score, cost − confidence, instead of the number of confirming sources, then cost. The
    /// confidence sums, over the sources that confirm the pixel, exp(−(e + c·Δd/(r·d))), e
    /// the round trip's distance in pixels, Δd/d its relative depth difference, c =
    /// `prior_consistency` and r = `fusion_relative_depth` (HPM-MVS++'s e + 200·Δd/d at the
    /// defaults; its normal term is left out, the depth snapshot holding no normals): a
    /// source that agrees closely counts near 1, one at the limits near e⁻⁴, so the rank
    /// prefers precise agreement over many loose ones. Off by default (Regions has it on).
    pub prior_confidence_score: bool,
    /// One plane per flat region (docs/method.md, "Region planes"): the grid cells most of
    /// whose pixels (`prior_region_flat_share`) have a flat matching window
    /// ([`crate::acmm::planar::FLAT_WINDOW_STD`]) form 4-connected regions; in each, RANSAC
    /// finds the planes most of the region's
    /// support points agree on (each within `prior_region_tolerance` of a point's depth,
    /// held by at least a quarter of the region's points and by
    /// [`crate::acmm::planar::REGION_MIN_POINTS`]), and every cell of the region takes the
    /// plane of the nearest cell whose point agrees with one, in place of its triangles: on
    /// a textureless wall a few wrong points spoil every triangle they belong to, but not a
    /// plane most of the wall's points vote for. Off by default (ACMP and ACMMP triangulate).
    pub prior_regions: bool,
    /// A support point agrees with a region's plane when the plane's depth on its ray is
    /// within this share of its own depth (0.01: fusion's ε).
    pub prior_region_tolerance: f32,
    /// A grid cell joins a flat region when at least this share of its pixels have a flat
    /// matching window: 0.5, most of them (1, every pixel, leaves a band of cells along every
    /// edge to the triangles: on the registered ICL at 320, 60.1% within 2% against 62.1;
    /// docs/accuracy.md, "Regions").
    pub prior_region_flat_share: f32,
    /// A region's plane must also hold most of the support points near each cell it paints:
    /// of the cells it paints within this many cells of it (Chebyshev), the ones with a
    /// point, at least [`crate::acmm::planar::REGION_MIN_COVER`]; a cell where it holds fewer
    /// keeps its triangles. A plane through a curved object's middle holds most of its points
    /// over all but not towards its flanks (docs/method.md, `prior_region_near`). 0: only the
    /// test over all the cells a plane paints. Off (0) by default.
    pub prior_region_near: u32,
    /// With `prior_regions`: after the planes that each hold a quarter of a region's support
    /// points, the points left may hold more planes of any size (at least
    /// [`crate::acmm::planar::REGION_MIN_POINTS`]) where each meets an earlier plane of the
    /// region along the border between their points, the two planes crossing between most
    /// pairs of neighbouring cells one holds and the other: a flat region of one shade may
    /// fold (a room's corner, a wall meeting the ceiling) but not step, and a patch of wrong
    /// depths shared by the views sits off its wall (docs/method.md, `prior_region_crease`).
    /// Off by default.
    pub prior_region_crease: bool,
    /// With `prior_regions`: a support point a region's plane does not hold counts against
    /// the plane (in the test that it holds most of the points of the cells it paints) only
    /// where some source's image holds the plane's point on that pixel's ray. Where none
    /// does, the matching cost scores the plane's depth as the worst match, so the point's
    /// own depth could not have been the plane's whatever the surface: its disagreement is
    /// no evidence (docs/method.md, `prior_region_cover_seen`). On in Regions' defaults.
    pub prior_region_cover_seen: bool,
    /// With `prior_regions`, in the test that a region's plane holds most of the support
    /// points of the cells it paints: the points it does not hold but that lie within this
    /// many `prior_region_tolerance`s of it count as held as far as they balance, as many
    /// nearer than the plane as farther (twice the smaller side). A right plane through a
    /// noisy wall's points, about half of them within the tolerance, holds the rest on both
    /// sides; a plane through a curved object or over a foreground object has them on one
    /// side. They count only where the sides are mixed in the image as noise mixes them:
    /// of the pairs of these points in neighbouring cells, at least half as many as at
    /// random must lie on opposite sides (a secant plane through a curved surface, or one
    /// across a fold, balances its sides in two patches). docs/method.md,
    /// `prior_region_cover_band`. 0: off, the default; 3 in Regions'.
    pub prior_region_cover_band: f32,
    /// With `prior_regions`: two neighbouring flat cells join one region only where no
    /// intensity edge lies between them, their shades (the median of each cell's
    /// intensities) within 2 × [`crate::acmm::planar::FLAT_WINDOW_STD`] of each other:
    /// DPE-MVS's rule that a region stops at an image edge, in the form of the edge the
    /// every-pixel flat test stops a region at (a window half over each cell would fail it).
    /// With `prior_flat_weighted` the cells along an edge between two flat surfaces (a wall
    /// and the floor, two walls at a corner of shading) are flat, and without this rule the
    /// two surfaces join one region that neither's plane covers (docs/method.md,
    /// `prior_region_edge`). Off by default, on in Regions.
    pub prior_region_edge: bool,
    /// With `prior_regions`: a region's plane is first sought among the planes whose normal
    /// is an axis of the view's Manhattan frame (the three orthogonal directions most of
    /// its image's straight segments point at, [`crate::acmm::lines`]), each with the offset
    /// most of the region's support points agree with; RANSAC's plane through three points
    /// only where no such plane holds enough of them, and on views whose lines give no
    /// frame. A wall's support points scattered about its plane then fix one number, not
    /// three (docs/method.md, `prior_region_axes`). Off by default.
    pub prior_region_axes: bool,
    /// With `prior_regions`: the prior holds through the geometric passes that follow its
    /// stage. A pixel with a prior plane chooses there, as in the prior-assisted pass, by the
    /// prior-weighted score of its hypotheses' costs (photometric + λ × reprojection) and
    /// draws its random refinement around the prior; no pixel restarts from it. ACMMP's
    /// geometric passes have no prior (ACMP-REFERENCE.md §1); without it Regions' passes
    /// after the first drift back to where the photometric cost alone leads on a wall
    /// (registered ICL at 320: 62.1% within 2% without, 65.7 with; docs/accuracy.md,
    /// "After the prior"). On by default, read only by Regions.
    pub prior_region_hold: bool,
    /// With `prior_region_hold`: only the flat regions' planes hold. At the end of a view's
    /// prior stage it keeps the prior planes of its region cells alone
    /// (`planar::held_prior`: a RANSAC plane many support points agree on, not a triangle of
    /// three). Off: every prior plane holds. Measured at 320 (docs/accuracy.md, "Only the
    /// region planes hold"): Aloe's weak texture 96.3 against 95.6, the synthetic scenes
    /// +0.2 (+0.5 weak), but the registered ICL 62.6 against 64.2 and the shipped ICL 19.2
    /// against 19.7 (means over seeds), so not the default.
    pub prior_hold_regions_only: bool,
    /// In a pass with a prior (the prior-assisted pass, and the geometric passes Regions'
    /// prior holds in), a pixel whose prior plane puts its point in no source's image keeps
    /// that plane, at cost [`MAX_COST`](crate::acmm::cpu::MAX_COST) and with no view
    /// selected. No source can score such a plane: the matching cost gives it the worst
    /// score, so any depth that throws the ray into some source's image wins there, however
    /// it matches (docs/accuracy.md, "What no source sees"). On by default for Regions;
    /// ACMP and ACMMP score every hypothesis, as the authors' code does.
    pub prior_keep_unseen: bool,
    /// The prior-assisted pass's start: a restarted pixel's depth is the prior depth
    /// × (1 ± this), uniformly (0.06).
    pub prior_init_depth: f32,
    /// ... and its normal the prior normal tilted by up to ± this along each of two tangent
    /// directions, degrees (the authors' ±0.03π per Euler angle: 5.4).
    pub prior_init_normal: f32,
    /// Refinement with a prior: the random depth lies within ± this many σd of the prior
    /// depth (3).
    pub prior_refine_depth: f32,
    /// ... and the random normal is the prior normal tilted by up to ± this, degrees (2.5).
    pub prior_refine_normal: f32,

    // --- Fusion (Sec. 6) ---
    /// ψ: largest reprojection error of a consistent match, in pixels.
    pub fusion_reprojection: f32,
    /// ε: largest relative depth difference of a consistent match.
    pub fusion_relative_depth: f32,
    /// θ: largest angle between the normals of a consistent match, in degrees (the paper's
    /// 30; the original code used 10).
    pub fusion_normal_angle: f32,
    /// n: consistent source views a depth needs to become a point.
    pub fusion_min_views: u32,

    // --- Depth range ---
    /// Each view's input depth range is widened to [min·this, max·`depth_max_factor`] before
    /// sampling (the original code: 0.6 and 1.2; a range from sparse points can clip true
    /// surfaces). 1 keeps the range as given.
    pub depth_min_factor: f32,
    /// See `depth_min_factor`.
    pub depth_max_factor: f32,

    /// Seed of every random number (initialisation, refinement).
    pub seed: u64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            tau0: 0.8,
            tau1: 1.2,
            alpha: 90.0,
            beta: 0.3,
            n1: 2,
            n2: 3,
            window_radius: 5,
            window_step: 2,
            sigma_spatial: 5.0,
            sigma_color: 3.0,
            bilateral_kernel: BilateralKernel::Laplacian,
            top_k: 4,
            iterations: 6,
            perturb_depth: 0.02,
            perturb_normal: 0.01 * std::f32::consts::PI,
            median_radius: 2,
            median_every_pass: false,
            scales: 3,
            coarsest_size: 0,
            scales_by_texture: false,
            eta: 0.5,
            delta: 3.0,
            lambda: 0.2,
            xi: 0.1,
            coarse_iterations: 3,
            restorer_iterations: 2,
            restorer: RestorerMode::Refine,
            geometric_iterations: 2,
            geometric_passes: 2,
            original_pyramid: false,
            jbu_radius: 2,
            jbu_sigma_spatial: 0.5,
            jbu_sigma_range: 25.5,
            prior_cell: 5,
            prior_cost_threshold: 0.1,
            prior_triangle_normal: 30.0,
            prior_consistency: 2.0,
            prior_gamma: 0.5,
            prior_beta: 0.18,
            prior_sigma_depth: 1.0 / 64.0,
            prior_sigma_normal: 5.0,
            prior_iterations: 3,
            prior_everywhere: false,
            prior_extend: false,
            prior_lock: false,
            prior_anchors: false,
            prior_anchor_weight: 0.75,
            prior_anchor_tolerance: 0.01,
            prior_anchor_inliers: 5,
            prior_anchor_distinct: false,
            prior_anchor_views: 1,
            prior_support_views: 1,
            prior_after_geometric: false,
            prior_region_choice: false,
            prior_flat_points: false,
            prior_regions: false,
            prior_region_tolerance: 0.01,
            prior_region_flat_share: 0.5,
            prior_region_near: 0,
            prior_region_crease: false,
            prior_region_cover_seen: false,
            prior_region_cover_band: 0.0,
            prior_region_edge: false,
            prior_region_axes: false,
            prior_region_hold: true,
            prior_hold_regions_only: false,
            prior_keep_unseen: false,
            prior_flat_cost: 0.7,
            prior_flat_ramp: false,
            prior_flat_weighted: false,
            prior_flat_noise: false,
            prior_confirmed_points: false,
            prior_confidence_score: false,
            prior_init_depth: 0.06,
            prior_init_normal: 5.4,
            prior_refine_depth: 3.0,
            prior_refine_normal: 2.5,
            fusion_reprojection: 2.0,
            fusion_relative_depth: 0.01,
            fusion_normal_angle: 30.0,
            fusion_min_views: 2,
            depth_min_factor: 1.0,
            depth_max_factor: 1.0,
            seed: 0,
        }
    }
}

/// Largest K of the top-K mean the kernels keep (they keep the K best costs in registers).
pub const MAX_TOP_K: u32 = 8;

/// Window samples per axis the GPU kernels hold in registers; `validate` keeps windows within.
pub const MAX_WINDOW_SAMPLES_PER_AXIS: u32 = 8;

impl Params {
    /// Window offsets along one axis: `-r, -r+step, ..., r`, skipping 0 when the step is even
    /// (the centre pixel is not sampled, but its intensity drives the weights).
    pub fn window_offsets(&self) -> Vec<i32> {
        let r = self.window_radius as i32;
        let step = self.window_step.max(1) as i32;
        (0..)
            .map(|i| -r + i * step)
            .take_while(|&o| o <= r)
            .collect()
    }

    /// Checks ranges; the message names the parameter and what is allowed.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("tau0", self.tau0),
            ("tau1", self.tau1),
            ("alpha", self.alpha),
            ("beta", self.beta),
            ("sigma_spatial", self.sigma_spatial),
            ("sigma_color", self.sigma_color),
            ("eta", self.eta),
            ("delta", self.delta),
            ("prior_beta", self.prior_beta),
            ("prior_sigma_depth", self.prior_sigma_depth),
            ("prior_sigma_normal", self.prior_sigma_normal),
            ("prior_cost_threshold", self.prior_cost_threshold),
            ("prior_flat_cost", self.prior_flat_cost),
            ("prior_region_tolerance", self.prior_region_tolerance),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} = {v}: it must be a positive number"));
            }
        }
        for (name, v) in [
            ("lambda", self.lambda),
            ("xi", self.xi),
            ("perturb_depth", self.perturb_depth),
            ("perturb_normal", self.perturb_normal),
            ("prior_gamma", self.prior_gamma),
            ("prior_consistency", self.prior_consistency),
            ("prior_anchor_tolerance", self.prior_anchor_tolerance),
            ("prior_init_depth", self.prior_init_depth),
            ("prior_init_normal", self.prior_init_normal),
            ("prior_refine_depth", self.prior_refine_depth),
            ("prior_refine_normal", self.prior_refine_normal),
            ("prior_region_cover_band", self.prior_region_cover_band),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{name} = {v}: it must be zero or positive"));
            }
        }
        if self.tau1 <= self.tau0 {
            return Err(format!(
                "tau1 = {} must exceed tau0 = {} (the paper requires τ1 > τ(t))",
                self.tau1, self.tau0
            ));
        }
        if self.n1 >= 8 || self.n2 == 0 || self.n2 > 8 {
            return Err(format!(
                "n1 = {} and n2 = {}: a view needs more than n1 of 8 good costs (n1 < 8) and fewer than n2 bad ones (1 <= n2 <= 8)",
                self.n1, self.n2
            ));
        }
        if self.window_step == 0 || self.window_radius == 0 {
            return Err("window_radius and window_step must be at least 1".into());
        }
        let n = self.window_offsets().len() as u32;
        if n > MAX_WINDOW_SAMPLES_PER_AXIS {
            return Err(format!(
                "window_radius = {} with window_step = {} samples {n} pixels per axis; at most {MAX_WINDOW_SAMPLES_PER_AXIS} are supported (raise the step or shrink the window)",
                self.window_radius, self.window_step
            ));
        }
        if self.top_k == 0 || self.top_k > MAX_TOP_K {
            return Err(format!("top_k = {}: between 1 and {MAX_TOP_K}", self.top_k));
        }
        for (name, v) in [
            ("iterations", self.iterations),
            ("coarse_iterations", self.coarse_iterations),
            ("restorer_iterations", self.restorer_iterations),
            ("prior_iterations", self.prior_iterations),
        ] {
            if v == 0 {
                return Err(format!("{name} must be at least 1"));
            }
        }
        if !(self.depth_min_factor.is_finite()
            && self.depth_min_factor > 0.0
            && self.depth_max_factor.is_finite()
            && self.depth_max_factor >= self.depth_min_factor)
        {
            return Err(format!(
                "depth_min_factor = {} and depth_max_factor = {}: both positive, the max factor at least the min (the original code: 0.6 and 1.2)",
                self.depth_min_factor, self.depth_max_factor
            ));
        }
        if !(self.prior_anchor_weight.is_finite()
            && (0.0..=1.0).contains(&self.prior_anchor_weight))
        {
            return Err(format!(
                "prior_anchor_weight = {}: between 0 (the pixel's own window only) and 1 (its anchors' only)",
                self.prior_anchor_weight
            ));
        }
        if self.prior_anchor_views == 0 {
            return Err("prior_anchor_views must be at least 1".into());
        }
        if self.prior_support_views == 0 {
            return Err("prior_support_views must be at least 1".into());
        }
        if !(3..=8).contains(&self.prior_anchor_inliers) {
            return Err(format!(
                "prior_anchor_inliers = {}: between 3 (a plane) and 8 (every direction)",
                self.prior_anchor_inliers
            ));
        }
        if self.median_radius > 3 {
            return Err(format!(
                "median_radius = {}: at most 3 (a 7x7 median) is supported",
                self.median_radius
            ));
        }
        if self.scales == 0 || self.scales > 8 {
            return Err(format!("scales = {}: between 1 and 8", self.scales));
        }
        if self.coarsest_size > 0 && self.coarsest_size < 16 {
            return Err(format!(
                "coarsest_size = {}: 0 (off: `scales` decides) or at least 16 px",
                self.coarsest_size
            ));
        }
        if self.scales_by_texture && (self.coarsest_size > 0 || self.original_pyramid) {
            return Err(
                "scales_by_texture decides the number of scales; unset coarsest_size and original_pyramid"
                    .into(),
            );
        }
        if !(self.jbu_sigma_spatial > 0.0 && self.jbu_sigma_range > 0.0) {
            return Err("jbu_sigma_spatial and jbu_sigma_range must be positive".into());
        }
        if self.jbu_radius > 4 {
            return Err(format!("jbu_radius = {}: at most 4", self.jbu_radius));
        }
        if !(self.fusion_reprojection > 0.0
            && self.fusion_relative_depth > 0.0
            && self.fusion_normal_angle > 0.0
            && self.fusion_normal_angle <= 180.0)
        {
            return Err(
                "fusion thresholds must be positive (the normal angle at most 180 degrees)".into(),
            );
        }
        if !(2..=64).contains(&self.prior_cell) {
            return Err(format!(
                "prior_cell = {}: between 2 and 64 pixels (the authors' 5)",
                self.prior_cell
            ));
        }
        for (name, v) in [
            ("prior_sigma_normal", self.prior_sigma_normal),
            ("prior_init_normal", self.prior_init_normal),
            ("prior_refine_normal", self.prior_refine_normal),
        ] {
            if v >= 80.0 {
                return Err(format!("{name} = {v}: an angle in degrees below 80"));
            }
        }
        if !(self.prior_triangle_normal > 0.0 && self.prior_triangle_normal <= 180.0) {
            return Err(format!(
                "prior_triangle_normal = {}: an angle in degrees in (0, 180] (180 keeps every triangle)",
                self.prior_triangle_normal
            ));
        }
        if !(self.prior_region_flat_share > 0.0 && self.prior_region_flat_share <= 1.0) {
            return Err(format!(
                "prior_region_flat_share = {}: a share of a cell's pixels in (0, 1] (1: every pixel's window flat)",
                self.prior_region_flat_share
            ));
        }
        if self.prior_init_depth >= 1.0 {
            return Err(format!(
                "prior_init_depth = {}: a share of the depth below 1 (the authors' 0.06)",
                self.prior_init_depth
            ));
        }
        if self.eta >= 1.0 {
            return Err(format!("eta = {}: it must be below 1", self.eta));
        }
        Ok(())
    }

    /// Reads a TOML file of parameters (any subset; the rest keep their defaults). A run's
    /// params.toml works too: its `[params]` table is used.
    pub fn from_toml_file(path: &std::path::Path) -> Result<Params, String> {
        Self::from_toml_file_over(path, &Params::default())
    }

    /// [`Params::from_toml_file`] with the parameters the file leaves out taken from `base`
    /// (a method's [`Method::defaults`]).
    pub fn from_toml_file_over(path: &std::path::Path, base: &Params) -> Result<Params, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read it ({e})", path.display()))?;
        let value: toml::Table = text
            .parse()
            .map_err(|e| format!("{}: not valid TOML: {e}", path.display()))?;
        // A run's record of format 0 (no `record_format`) kept the parameters as given, and
        // its method turned its own options on over them: read as that run ran.
        let ran_as = match (value.get("params"), value.get("record_format")) {
            (Some(_), None) => value
                .get("method")
                .and_then(|m| m.clone().try_into::<Method>().ok()),
            _ => None,
        };
        let given = match value.get("params") {
            Some(toml::Value::Table(t)) => t.clone(),
            _ => value,
        };
        // A record of format 0 holds every parameter of its time; the later ones take the
        // common defaults, which its run had.
        let base = if ran_as.is_some() {
            &Params::default()
        } else {
            base
        };
        let mut table = match toml::Value::try_from(base) {
            Ok(toml::Value::Table(t)) => t,
            _ => return Err("internal: parameters do not serialise to a table".into()),
        };
        table.extend(given);
        let mut params: Params = toml::Value::Table(table)
            .try_into()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        if let Some(method) = ran_as {
            params = method.ran_at_format_0(&params);
        }
        params
            .validate()
            .map_err(|m| format!("{}: {m}", path.display()))?;
        Ok(params)
    }

    /// Applies `NAME=VALUE` overrides (`--set`); names are the fields of this struct, values
    /// are parsed as the field's type. The message of an error names the parameter and says
    /// what is allowed.
    pub fn with_overrides(&self, sets: &[String]) -> Result<Params, String> {
        let mut table = match toml::Value::try_from(self) {
            Ok(toml::Value::Table(t)) => t,
            _ => return Err("internal: parameters do not serialise to a table".into()),
        };
        for set in sets {
            let Some((name, value)) = set.split_once('=') else {
                return Err(format!("--set {set}: expected NAME=VALUE, e.g. tau0=0.7"));
            };
            let (name, value) = (name.trim(), value.trim());
            let Some(old) = table.get(name) else {
                let mut known: Vec<&String> = table.keys().collect();
                known.sort();
                let known: Vec<&str> = known.iter().map(|s| s.as_str()).collect();
                return Err(format!(
                    "--set {name}: unknown parameter; known: {}",
                    known.join(", ")
                ));
            };
            let new = match old {
                toml::Value::Float(_) => value.parse::<f64>().ok().map(toml::Value::Float),
                toml::Value::Integer(_) => value.parse::<i64>().ok().map(toml::Value::Integer),
                toml::Value::Boolean(_) => value.parse::<bool>().ok().map(toml::Value::Boolean),
                toml::Value::String(_) => Some(toml::Value::String(value.to_string())),
                _ => None,
            }
            .ok_or_else(|| {
                format!(
                    "--set {name}={value}: not a valid {} (current value {old})",
                    old.type_str()
                )
            })?;
            table.insert(name.to_string(), new);
        }
        let params: Params = toml::Value::Table(table)
            .try_into()
            .map_err(|e| format!("--set: {e}"))?;
        params.validate()?;
        Ok(params)
    }

    /// τ(t) = τ0·exp(-t²/α) for the t-th iteration (1-based).
    pub fn tau(&self, t: u32) -> f32 {
        self.tau0 * (-((t * t) as f32) / self.alpha).exp()
    }
}

impl Params {
    /// Whether the prior holds in geometric pass `g` (1-based) of a scale: with
    /// `prior_regions` and `prior_region_hold`, in the passes after the prior's stage (from
    /// the second where the prior follows the first, [`Params::prior_follows_geometric`]).
    pub fn prior_holds_in(&self, method: Method, g: u32) -> bool {
        method.has_planar_prior()
            && self.prior_regions
            && self.prior_region_hold
            && g > u32::from(self.prior_follows_geometric())
    }

    /// Whether a scale's planar prior stage follows its first geometric pass:
    /// `prior_after_geometric`, or Regions' per-region choice (`prior_region_choice`),
    /// whose later fit reads that pass.
    pub fn prior_follows_geometric(&self) -> bool {
        self.prior_after_geometric || (self.prior_regions && self.prior_region_choice)
    }

    /// Whether each scale's first geometric pass begins with the support points of the
    /// restorer's result, kept for the per-region choice (`prior_region_choice`).
    pub fn early_support_points(&self, method: Method) -> bool {
        method.has_planar_prior()
            && method.has_geometric()
            && self.geometric_passes > 0
            && self.prior_regions
            && self.prior_region_choice
    }

    /// Whether the prior stage looks for anchors: `prior_anchors`, which needs the
    /// multi-view check (`prior_consistency` > 0) to tell strong pixels from weak ones.
    pub fn anchors_on(&self) -> bool {
        self.prior_anchors && self.prior_consistency > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A method's defaults differ from the common ones only in the fields `adopt` carries,
    /// so switching methods can never keep another method's setting by mistake.
    #[test]
    fn methods_differ_only_in_the_options_adopt_carries() {
        let table = |p: &Params| match toml::Value::try_from(p) {
            Ok(toml::Value::Table(t)) => t,
            other => panic!("{other:?}"),
        };
        let common = table(&Params::default());
        let carried = [
            "prior_regions",
            "prior_flat_points",
            "prior_confirmed_points",
            "prior_confidence_score",
            "prior_flat_ramp",
            "prior_extend",
            "prior_keep_unseen",
            "prior_region_cover_seen",
            "prior_region_edge",
            "prior_flat_noise",
            "prior_region_cover_band",
            "bilateral_kernel",
        ];
        for m in Method::ALL {
            let own = table(&m.defaults());
            for (k, v) in &own {
                if common[k] != *v {
                    assert!(carried.contains(&k.as_str()), "{m} sets {k}");
                }
            }
            assert_eq!(m.params(&Params::default()), m.defaults(), "{m}");
        }
        // Regions turns every carried option on (the band at 3 tolerances) and weighs its
        // windows' samples by the adaptive form; the others keep the common defaults.
        let regions = table(&Method::Regions.defaults());
        for k in carried {
            let (on, off) = match k {
                "bilateral_kernel" => (
                    toml::Value::from("adaptive"),
                    toml::Value::from("laplacian"),
                ),
                "prior_region_cover_band" => (toml::Value::from(3.0), toml::Value::from(0.0)),
                _ => (toml::Value::Boolean(true), toml::Value::Boolean(false)),
            };
            assert_eq!(regions[k], on, "{k}");
            assert_eq!(common[k], off, "{k}");
        }
    }

    /// The user's changes survive a method switch and a method's own options follow the
    /// method; an option the user turned off stays off (the fault: Regions forced its
    /// options on over `--set prior_confidence_score=false`).
    #[test]
    fn adopt_keeps_the_users_changes_and_takes_the_methods_defaults() {
        let user = Params {
            tau0: 0.6,
            ..Method::Acmm.defaults()
        };
        let regions = Method::Regions.adopt(&user, Method::Acmm);
        assert_eq!(
            regions,
            Params {
                tau0: 0.6,
                ..Method::Regions.defaults()
            }
        );
        // Back to ACMM: Regions' options were its defaults, so they go.
        assert_eq!(Method::Acmm.adopt(&regions, Method::Regions), user);
        // Regions without the score: the change is the user's, so it stays.
        let no_score = Params {
            prior_confidence_score: false,
            ..regions.clone()
        };
        assert!(
            !Method::Regions
                .adopt(&no_score, Method::Regions)
                .prior_confidence_score
        );
        let acmmp = Method::Acmmp.adopt(&no_score, Method::Regions);
        assert!(!acmmp.prior_confidence_score);
        // Regions' other options were its defaults: ACMMP's apply.
        assert!(!acmmp.prior_regions && !acmmp.prior_flat_points);
        assert_eq!(acmmp.tau0, 0.6);
        // ACMMP with region planes turned on by the user keeps them in ACMP.
        let planes = Params {
            prior_regions: true,
            ..acmmp
        };
        assert!(Method::Acmp.adopt(&planes, Method::Acmmp).prior_regions);
        // Shared parameters (a comparison) mean the common defaults.
        assert!(Method::Regions.params(&user).prior_confidence_score);
    }

    /// A params.toml that names some parameters leaves the rest at the base given: the
    /// method's defaults (`--method regions --params FILE`).
    #[test]
    fn a_params_file_fills_the_rest_from_the_methods_defaults() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        std::fs::write(&path, "tau0 = 0.6\nprior_flat_points = false\n").unwrap();
        let p = Params::from_toml_file_over(&path, &Method::Regions.defaults()).unwrap();
        assert_eq!(
            p,
            Params {
                tau0: 0.6,
                prior_flat_points: false,
                ..Method::Regions.defaults()
            }
        );
        let p = Params::from_toml_file(&path).unwrap();
        assert!(!p.prior_regions && p.tau0 == 0.6);
        std::fs::write(&path, "tau7 = 1\n").unwrap();
        let e = Params::from_toml_file_over(&path, &Method::Regions.defaults()).unwrap_err();
        assert!(e.contains("p.toml") && e.contains("tau7"), "{e}");
    }

    #[test]
    fn default_window_is_the_originals() {
        let p = Params::default();
        assert_eq!(p.window_offsets(), vec![-5, -3, -1, 1, 3, 5]);
        assert!(p.validate().is_ok());
    }

    #[test]
    fn tau_decays() {
        let p = Params::default();
        assert!((p.tau(1) - 0.8 * (-1.0f32 / 90.0).exp()).abs() < 1e-7);
        assert!(p.tau(6) < p.tau(1));
    }

    #[test]
    fn validation_names_the_parameter() {
        let p = Params {
            tau1: 0.5,
            ..Params::default()
        };
        assert!(p.validate().unwrap_err().contains("tau1"));
        let p = Params {
            window_radius: 9,
            window_step: 1,
            ..Params::default()
        };
        assert!(p.validate().unwrap_err().contains("window_radius"));
    }

    #[test]
    fn overrides_parse_by_type_and_name_the_problem() {
        let p = Params::default();
        let q = p
            .with_overrides(&[
                "tau0=0.7".into(),
                "n1=1".into(),
                "original_pyramid=true".into(),
            ])
            .unwrap();
        assert_eq!((q.tau0, q.n1, q.original_pyramid), (0.7, 1, true));
        let q = p
            .with_overrides(&["bilateral_kernel=gaussian".into()])
            .unwrap();
        assert_eq!(q.bilateral_kernel, BilateralKernel::Gaussian);
        let e = p.with_overrides(&["tau9=1".into()]).unwrap_err();
        assert!(e.contains("unknown parameter") && e.contains("tau0"), "{e}");
        let e = p.with_overrides(&["n1=two".into()]).unwrap_err();
        assert!(e.contains("n1=two") && e.contains("integer"), "{e}");
        let e = p.with_overrides(&["tau1=0.1".into()]).unwrap_err();
        assert!(e.contains("tau1"), "{e}");
        assert!(p.with_overrides(&["tau0".into()]).is_err());
        assert!(p.with_overrides(&["n1=-3".into()]).is_err());
    }

    #[test]
    fn toml_round_trip_and_unknown_fields() {
        let p = Params {
            tau0: 0.7,
            seed: 9,
            ..Params::default()
        };
        let text = toml::to_string(&p).unwrap();
        let back: Params = toml::from_str(&text).unwrap();
        assert_eq!(p, back);
        assert!(toml::from_str::<Params>("tau9 = 1.0").is_err());
        let partial: Params = toml::from_str("lambda = 0.5").unwrap();
        assert_eq!(partial.lambda, 0.5);
        assert_eq!(partial.tau0, 0.8);
    }
}
