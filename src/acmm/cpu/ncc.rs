//! The matching cost's CPU reference: the reference patch and its bilateral weights, the
//! homography stepped along the window, bilinear sampling of a source layer, the bilateral
//! weighted NCC, and the top-K mean.

use super::*;

/// Bilateral weights of the reference window around (x, y) and the window's intensities.
pub struct RefPatch {
    pub x: u32,
    pub y: u32,
    /// The window's columns and rows (clamped to the image): sample `k` lies at
    /// `(xs[k % xs.len()], ys[k / xs.len()])`, row by row.
    pub xs: Vec<f32>,
    pub ys: Vec<f32>,
    /// Reference intensity minus the centre's.
    pub values: Vec<f32>,
    pub weights: Vec<f32>,
    pub weight_sum: f32,
    pub mean: f32,
    pub variance: f32,
    /// The sample whose source value the source side is shifted by ([`ncc_cost`]): the
    /// first with the Laplacian weight, the heaviest (weight 1) with the Gaussian forms.
    pub heaviest: usize,
}

/// The Gaussian bilateral weight's spatial exponent, `|Δx|² / (2σs²)`; a sample's exponent adds
/// `|ΔI|² / c` with `c` from [`color_scale`], and a window's weights are
/// `exp(least − exponent)`, relative to its heaviest sample ([`ref_patch_with`]).
pub fn spatial_exponent(params: &Params, dx: f32, dy: f32) -> f32 {
    let ss = 2.0 * params.sigma_spatial * params.sigma_spatial;
    (dx * dx + dy * dy) / ss
}

/// The lower median of `|v|` over a window's values: the value of rank `(n − 1) / 2`,
/// found by counting (the same count is written inline in `color_scale` in
/// shaders/shared/ncc.wgsl).
pub fn abs_median(values: &[f32]) -> f32 {
    let k = (values.len().max(1) - 1) / 2;
    for &a in values {
        let a = a.abs();
        let (mut less, mut leq) = (0usize, 0usize);
        for &b in values {
            let b = b.abs();
            less += usize::from(b < a);
            leq += usize::from(b <= a);
        }
        if less <= k && k < leq {
            return a;
        }
    }
    0.0
}

/// `2σc²` of a Gaussian window's colour term: σc itself, or with
/// [`BilateralKernel::Adaptive`] the window's own spread, the robust standard deviation of its
/// differences from the centre (1.4826 × their median absolute value), never below σc.
pub fn color_scale(params: &Params, values: &[f32]) -> f32 {
    let sigma = match params.bilateral_kernel {
        BilateralKernel::Adaptive => params.sigma_color.max(1.4826 * abs_median(values)),
        _ => params.sigma_color,
    };
    2.0 * sigma * sigma
}

/// The unsquared (authors') bilateral weight of a sample at offset (dx, dy) whose intensity
/// differs from the centre's by `dc`; the Gaussian forms are weighed by the window
/// ([`ref_patch_with`]).
pub fn bilateral_weight(params: &Params, dx: f32, dy: f32, dc: f32) -> f32 {
    let ss = 2.0 * params.sigma_spatial * params.sigma_spatial;
    let sc = 2.0 * params.sigma_color * params.sigma_color;
    (-(dx * dx + dy * dy).sqrt() / ss - dc.abs() / sc).exp()
}

/// The reference side of the bilateral NCC at (x, y) (independent of hypotheses).
pub fn ref_patch(problem: &ViewProblem, params: &Params, x: u32, y: u32) -> RefPatch {
    ref_patch_with(problem, params, x, y, &params.window_offsets())
}

/// The window of an anchor (`prior_anchors`): 3 x 3 samples `window_radius` apart, the
/// matching window's extent at a ninth of a default window's samples (APD-MVS's 11 x 11
/// window at step 5).
pub fn anchor_offsets(params: &Params) -> [i32; 3] {
    let r = params.window_radius as i32;
    [-r, 0, r]
}

/// [`ref_patch`] over the window `offsets` (the same along both axes).
pub fn ref_patch_with(
    problem: &ViewProblem,
    params: &Params,
    x: u32,
    y: u32,
    offsets: &[i32],
) -> RefPatch {
    let (w, h) = (problem.width as i32, problem.height as i32);
    let img = &problem.images;
    let centre = img[(y * problem.width + x) as usize];
    let mut patch = RefPatch {
        x,
        y,
        xs: offsets
            .iter()
            .map(|&dx| (x as i32 + dx).clamp(0, w - 1) as f32)
            .collect(),
        ys: offsets
            .iter()
            .map(|&dy| (y as i32 + dy).clamp(0, h - 1) as f32)
            .collect(),
        values: Vec::with_capacity(offsets.len() * offsets.len()),
        weights: Vec::with_capacity(offsets.len() * offsets.len()),
        weight_sum: 0.0,
        mean: 0.0,
        variance: 0.0,
        heaviest: 0,
    };
    let (mut s, mut ss) = (0.0f32, 0.0f32);
    let gaussian = params.bilateral_kernel != BilateralKernel::Laplacian;
    for &dy in offsets {
        for &dx in offsets {
            let sx = (x as i32 + dx).clamp(0, w - 1) as u32;
            let sy = (y as i32 + dy).clamp(0, h - 1) as u32;
            let v = img[(sy * problem.width + sx) as usize] - centre;
            patch.values.push(v);
            if gaussian {
                // The spatial exponent for now; the colour term and the weights follow.
                patch
                    .weights
                    .push(spatial_exponent(params, dx as f32, dy as f32));
                continue;
            }
            let wk = bilateral_weight(params, dx as f32, dy as f32, v);
            patch.weights.push(wk);
            patch.weight_sum += wk;
            s += wk * v;
            ss += wk * v * v;
        }
    }
    if gaussian {
        let sc = color_scale(params, &patch.values);
        let mut least = f32::INFINITY;
        for (k, (e, &v)) in patch.weights.iter_mut().zip(&patch.values).enumerate() {
            *e += v * v / sc;
            if *e < least {
                least = *e;
                patch.heaviest = k;
            }
        }
        // Relative to the window's heaviest sample: the NCC is the same for any common
        // factor of the weights, and a window whose every sample is far from the centre's
        // intensity (exponents past 87) would otherwise weigh nothing at all in f32.
        for (wk, &v) in patch.weights.iter_mut().zip(&patch.values) {
            *wk = (least - *wk).exp();
            patch.weight_sum += *wk;
            s += *wk * v;
            ss += *wk * v * v;
        }
    }
    patch.mean = s / patch.weight_sum;
    patch.variance = ss / patch.weight_sum - patch.mean * patch.mean;
    patch
}

/// Bilinear sample of a source image at continuous pixel coordinates (centres on integers),
/// clamped to the border. Along an axis where the sample lies outside the inner cells both
/// taps are the border pixel, written as a zero weight on the second tap (a + (b - a) * 0 = a,
/// the same value): the form shaders/shared/ncc.wgsl computes with one `textureGather`.
pub fn bilinear(problem: &ViewProblem, src: &GpuSource, u: f32, v: f32) -> f32 {
    let (w, h, offset) = (src.size[0] as i32, src.size[1] as i32, src.size[2] as usize);
    let x0 = u.floor();
    let y0 = v.floor();
    // `as` saturates, so a far-off sample clamps like any other.
    let (ix, iy) = (x0 as i32, y0 as i32);
    let fx = if ix < 0 || ix >= w - 1 { 0.0 } else { u - x0 };
    let fy = if iy < 0 || iy >= h - 1 { 0.0 } else { v - y0 };
    let (cx, cy) = (ix.clamp(0, w - 1), iy.clamp(0, h - 1));
    let (ix0, ix1) = (cx as usize, (cx + 1).min(w - 1) as usize);
    let (iy0, iy1) = (cy as usize, (cy + 1).min(h - 1) as usize);
    let img = &problem.images[offset..];
    let w = w as usize;
    let a = img[iy0 * w + ix0];
    let b = img[iy0 * w + ix1];
    let c = img[iy1 * w + ix0];
    let d = img[iy1 * w + ix1];
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    top + (bottom - top) * fy
}

/// The plane-induced homography from reference pixels to a source's pixels:
/// `H = K_s (R + t nᵀ / c) K_r⁻¹` with `c = n · X_p`, as 3 rows, plus `g` such that
/// `g · (u, v, 1) < 0` exactly for reference pixels whose ray meets the plane in front of
/// the camera. `None` when the plane does not face the camera at (x, y).
pub fn homography(
    k_ref: [f32; 4],
    src: &GpuSource,
    plane: [f32; 4],
    x: f32,
    y: f32,
) -> Option<([[f32; 3]; 3], [f32; 3])> {
    let n = [plane[0], plane[1], plane[2]];
    let r = ray(k_ref, x, y);
    let c = plane[3] * dot(n, r);
    if c >= 0.0 {
        return None;
    }
    let (fx, fy, cx, cy) = (k_ref[0], k_ref[1], k_ref[2], k_ref[3]);
    // A = R + t nᵀ / c, then H = K_s A K_r⁻¹.
    let rows = [src.r0, src.r1, src.r2];
    let mut a = [[0.0f32; 3]; 3];
    for (i, row) in a.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = rows[i][j] + src.t[i] * n[j] / c;
        }
    }
    // A K_r⁻¹: columns scaled by 1/f, last column shifted by the principal point.
    let mut ak = [[0.0f32; 3]; 3];
    for i in 0..3 {
        ak[i][0] = a[i][0] / fx;
        ak[i][1] = a[i][1] / fy;
        ak[i][2] = a[i][2] - a[i][0] * cx / fx - a[i][1] * cy / fy;
    }
    let ks = src.k;
    let mut hm = [[0.0f32; 3]; 3];
    for j in 0..3 {
        hm[0][j] = ks[0] * ak[0][j] + ks[2] * ak[2][j];
        hm[1][j] = ks[1] * ak[1][j] + ks[3] * ak[2][j];
        hm[2][j] = ak[2][j];
    }
    let g = [n[0] / fx, n[1] / fy, n[2] - n[0] * cx / fx - n[1] * cy / fy];
    Some((hm, g))
}

/// Bilateral weighted NCC cost (1 − NCC, in [0, 2]) of `plane` at the patch's pixel against
/// source `j`. [`MAX_COST`] when the warped centre leaves the source image, the plane is
/// behind either camera for any sample, or either patch is flat.
pub fn ncc_cost(problem: &ViewProblem, patch: &RefPatch, j: usize, plane: [f32; 4]) -> f32 {
    let src = &problem.sources[j];
    let Some((hm, g)) = homography(problem.k, src, plane, patch.x as f32, patch.y as f32) else {
        return MAX_COST;
    };
    let warp = |u: f32, v: f32| -> [f32; 3] {
        [
            hm[0][0] * u + hm[0][1] * v + hm[0][2],
            hm[1][0] * u + hm[1][1] * v + hm[1][2],
            hm[2][0] * u + hm[2][1] * v + hm[2][2],
        ]
    };
    let centre = warp(patch.x as f32, patch.y as f32);
    if centre[2] <= 0.0 {
        return MAX_COST;
    }
    let (cu, cv) = (centre[0] / centre[2], centre[1] / centre[2]);
    let (sw, sh) = (src.size[0] as f32, src.size[1] as f32);
    if !(cu >= -0.5 && cv >= -0.5 && cu < sw - 0.5 && cv < sh - 0.5) {
        return MAX_COST;
    }
    let (mut s, mut ss, mut rs) = (0.0f32, 0.0f32, 0.0f32);
    let mut shift = 0.0f32;
    // The homography stepped along the window: the part of a row (its v and the constant
    // column) once per row, then one multiply-add per coordinate and sample. The same
    // operations in the same order as shaders/shared/ncc.wgsl, so the two agree bit for bit.
    let stepped = |qx: f32, qy: f32| -> Option<f32> {
        let row = [
            hm[0][1] * qy + hm[0][2],
            hm[1][1] * qy + hm[1][2],
            hm[2][1] * qy + hm[2][2],
        ];
        let p = [
            hm[0][0] * qx + row[0],
            hm[1][0] * qx + row[1],
            hm[2][0] * qx + row[2],
        ];
        if g[0] * qx + (g[1] * qy + g[2]) >= 0.0 || p[2] <= 0.0 {
            return None;
        }
        Some(bilinear(problem, src, p[0] / p[2], p[1] / p[2]))
    };
    if patch.heaviest > 0 {
        // Shifted by the heaviest sample's value: with Gaussian weights the first sample may
        // weigh nothing and lie far off the weighted mean, and the variance would then be
        // the difference of two large sums (f32 cancels, and the GPU's exp rounding with it).
        let n = patch.xs.len();
        match stepped(patch.xs[patch.heaviest % n], patch.ys[patch.heaviest / n]) {
            Some(value) => shift = value,
            None => return MAX_COST,
        }
    }
    let mut k = 0;
    for &qy in &patch.ys {
        let row = [
            hm[0][1] * qy + hm[0][2],
            hm[1][1] * qy + hm[1][2],
            hm[2][1] * qy + hm[2][2],
        ];
        let g_row = g[1] * qy + g[2];
        for &qx in &patch.xs {
            let p = [
                hm[0][0] * qx + row[0],
                hm[1][0] * qx + row[1],
                hm[2][0] * qx + row[2],
            ];
            if g[0] * qx + g_row >= 0.0 || p[2] <= 0.0 {
                return MAX_COST;
            }
            let value = bilinear(problem, src, p[0] / p[2], p[1] / p[2]);
            if k == 0 && patch.heaviest == 0 {
                // Shift by the first sample: variances are shift-invariant, and small sums
                // keep f32 from cancelling on low-contrast patches.
                shift = value;
            }
            let v = value - shift;
            let wk = patch.weights[k];
            s += wk * v;
            ss += wk * v * v;
            rs += wk * patch.values[k] * v;
            k += 1;
        }
    }
    let mean = s / patch.weight_sum;
    let variance = ss / patch.weight_sum - mean * mean;
    if patch.variance < MIN_VARIANCE || variance < MIN_VARIANCE {
        return MAX_COST;
    }
    let covariance = rs / patch.weight_sum - patch.mean * mean;
    let ncc = covariance / (patch.variance * variance).sqrt();
    (1.0 - ncc).clamp(0.0, MAX_COST)
}

/// The K smallest costs, kept sorted (K <= 8); their mean is DWTA's and the initial cost.
#[derive(Clone, Copy, Debug)]
pub struct TopK {
    pub(super) k: usize,
    pub(super) n: usize,
    pub(super) v: [f32; 8],
}

impl TopK {
    pub fn new(k: usize) -> TopK {
        TopK {
            k: k.clamp(1, 8),
            n: 0,
            v: [0.0; 8],
        }
    }

    pub fn insert(&mut self, cost: f32) {
        let mut i = self.n.min(self.k);
        if i == self.k && cost >= self.v[self.k - 1] {
            return;
        }
        if i == self.k {
            i -= 1;
        }
        while i > 0 && self.v[i - 1] > cost {
            self.v[i] = self.v[i - 1];
            i -= 1;
        }
        self.v[i] = cost;
        self.n = (self.n + 1).min(self.k);
    }

    pub fn mean(&self) -> f32 {
        if self.n == 0 {
            return MAX_COST;
        }
        let mut sum = 0.0f32;
        for i in 0..self.n {
            sum += self.v[i];
        }
        sum / self.n as f32
    }
}

/// A weak pixel's anchors (`prior_anchors`): their reference windows, so that each
/// hypothesis of the pixel is also matched where the anchors are.
pub struct AnchorPatches {
    pub patches: Vec<RefPatch>,
    /// The share of the anchors' mean cost in the pixel's cost.
    pub weight: f32,
}

impl AnchorPatches {
    /// The windows of the anchors of pixel (x, y) named by `code` (none for code 0).
    pub fn new(problem: &ViewProblem, params: &Params, x: u32, y: u32, code: u32) -> Self {
        let offsets = anchor_offsets(params);
        let patches = crate::acmm::planar::anchor_pixels(x, y, code)
            .into_iter()
            .map(|(ax, ay)| ref_patch_with(problem, params, ax as u32, ay as u32, &offsets))
            .collect();
        AnchorPatches {
            patches,
            weight: params.prior_anchor_weight,
        }
    }
}

/// The matching cost of `plane` at the patch's pixel against source j: its own window's,
/// or with anchors (1 − w) × that + w × the mean over the anchors' windows of the same plane's
/// cost there (APD-MVS; as `match_cost` in shaders/shared/ncc.wgsl).
pub fn match_cost(
    problem: &ViewProblem,
    patch: &RefPatch,
    anchors: &AnchorPatches,
    j: usize,
    plane: [f32; 4],
) -> f32 {
    let own = ncc_cost(problem, patch, j, plane);
    if anchors.patches.is_empty() {
        return own;
    }
    let mut sum = 0.0f32;
    for a in &anchors.patches {
        let h = super::plane_at_pixel(problem.k, plane, patch.x, patch.y, a.x, a.y);
        sum += ncc_cost(problem, a, j, h);
    }
    let mean = sum / anchors.patches.len() as f32;
    (1.0 - anchors.weight) * own + anchors.weight * mean
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(kernel: BilateralKernel) -> Params {
        Params {
            bilateral_kernel: kernel,
            ..Params::default()
        }
    }

    #[test]
    fn the_median_is_the_lower_one_of_the_absolute_values() {
        assert_eq!(abs_median(&[3.0, -1.0, 2.0, -5.0]), 2.0);
        assert_eq!(abs_median(&[-4.0, 1.0, 9.0]), 4.0);
        assert_eq!(abs_median(&[0.0, 0.0, 0.0, 7.0]), 0.0);
        assert_eq!(abs_median(&[2.0, -2.0, 2.0]), 2.0);
        assert_eq!(abs_median(&[]), 0.0);
    }

    #[test]
    fn the_adaptive_scale_keeps_sigma_c_beside_an_edge_and_widens_on_texture() {
        // A weak wall's window with an object in front over 16 of its 36 samples: the
        // wall's samples decide the median, so the colour scale stays σc's and the
        // object's samples (50 grey levels off) weigh exp(-2500 / 18) ≈ 0.
        let mut edge: Vec<f32> = (0..20).map(|i| [-1.0, 0.5, 1.0, -0.5][i % 4]).collect();
        edge.extend(std::iter::repeat_n(50.0, 16));
        let adaptive = with(BilateralKernel::Adaptive);
        let sigma_c = 2.0 * 3.0 * 3.0;
        assert_eq!(color_scale(&adaptive, &edge), sigma_c);
        // A textured window, its samples spread over ±20 levels: the scale is the spread's
        // robust standard deviation, 1.4826 × the median |difference| (9.7 here).
        let texture: Vec<f32> = (0..36).map(|i| (i as f32 - 17.5) * 20.0 / 17.5).collect();
        let m = abs_median(&texture);
        assert!((m - 8.5 * 20.0 / 17.5).abs() < 1e-4, "{m}");
        let sigma = 1.4826 * m;
        assert_eq!(color_scale(&adaptive, &texture), 2.0 * sigma * sigma);
        // The fixed forms keep σc whatever the window holds.
        for kernel in [BilateralKernel::Gaussian, BilateralKernel::Laplacian] {
            assert_eq!(color_scale(&with(kernel), &texture), sigma_c);
        }
    }
}
