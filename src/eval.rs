//! Evaluation against ground truth. Depth maps: the share of ground-truth pixels whose
//! estimate is within an absolute or relative threshold, a missing estimate counting as a
//! miss, per view and pooled, and on weak-texture pixels where a mask exists
//! ([`evaluate_run`], what `mvscope eval` prints). Point clouds: accuracy, completeness and
//! F1 at distance thresholds as ETH3D defines them ([`cloud_scores`]).

/// Accuracy of a depth map on the pixels where `mask` (if any) holds and ground truth exists.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct DepthAccuracy {
    /// Ground-truth pixels evaluated.
    pub pixels: usize,
    /// Share within the threshold.
    pub within: f64,
    /// Median absolute relative error over the evaluated pixels with an estimate.
    pub median_relative_error: f64,
}

/// Share of ground-truth pixels (depth > 0, and `mask` true where given) whose estimate is
/// within `relative` of the ground truth (|d - gt| <= relative * gt). A missing estimate
/// (depth <= 0 or not finite) counts as a miss.
pub fn depth_accuracy_relative(
    estimate: &[f32],
    ground_truth: &[f32],
    mask: Option<&[bool]>,
    relative: f64,
) -> DepthAccuracy {
    depth_accuracy(estimate, ground_truth, mask, |gt| relative * gt)
}

/// As [`depth_accuracy_relative`] with an absolute threshold in scene units.
pub fn depth_accuracy_absolute(
    estimate: &[f32],
    ground_truth: &[f32],
    mask: Option<&[bool]>,
    absolute: f64,
) -> DepthAccuracy {
    depth_accuracy(estimate, ground_truth, mask, |_| absolute)
}

fn depth_accuracy(
    estimate: &[f32],
    ground_truth: &[f32],
    mask: Option<&[bool]>,
    threshold: impl Fn(f64) -> f64,
) -> DepthAccuracy {
    let count = count_within(estimate, ground_truth, mask, threshold);
    let mut errors: Vec<f64> = pairs(estimate, ground_truth, mask)
        .map(|(d, g)| (d - g).abs() / g)
        .collect();
    DepthAccuracy {
        pixels: count.pixels,
        within: count.share(),
        median_relative_error: middle(&mut errors),
    }
}

/// The element at `len / 2` of `values` in `f64::total_cmp` order (the median as this module
/// takes it; NaN when empty), found without a full sort.
fn middle(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let k = values.len() / 2;
    *values.select_nth_unstable_by(k, f64::total_cmp).1
}

/// (estimate, truth) of the pixels with both, as f64: truth positive and finite, `mask`
/// true where given, estimate positive and finite.
fn pairs<'a>(
    estimate: &'a [f32],
    ground_truth: &'a [f32],
    mask: Option<&'a [bool]>,
) -> impl Iterator<Item = (f64, f64)> + 'a {
    estimate
        .iter()
        .zip(ground_truth)
        .enumerate()
        .filter(move |(i, (d, g))| {
            **g > 0.0 && g.is_finite() && mask.is_none_or(|m| m[*i]) && **d > 0.0 && d.is_finite()
        })
        .map(|(_, (&d, &g))| (d as f64, g as f64))
}

/// Truth pixels evaluated and estimates within a threshold among them: a share kept as its
/// two counts, so that views add up to the share of all their pixels pooled.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Count {
    pub pixels: usize,
    pub hits: usize,
}

impl Count {
    /// hits / pixels, 0 without pixels.
    pub fn share(&self) -> f64 {
        if self.pixels == 0 {
            0.0
        } else {
            self.hits as f64 / self.pixels as f64
        }
    }

    fn add(&mut self, other: Count) {
        self.pixels += other.pixels;
        self.hits += other.hits;
    }
}

/// [`Count`] of the truth pixels (positive and finite, `mask` true where given) whose
/// estimate is within `threshold(truth)` of the truth; a missing estimate is a miss.
fn count_within(
    estimate: &[f32],
    ground_truth: &[f32],
    mask: Option<&[bool]>,
    threshold: impl Fn(f64) -> f64,
) -> Count {
    let mut c = Count::default();
    for (i, (&d, &g)) in estimate.iter().zip(ground_truth).enumerate() {
        if g <= 0.0 || !g.is_finite() || mask.is_some_and(|m| !m[i]) {
            continue;
        }
        c.pixels += 1;
        if d > 0.0 && d.is_finite() && (d as f64 - g as f64).abs() <= threshold(g as f64) {
            c.hits += 1;
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_misses_and_masks() {
        let gt = [1.0, 2.0, 0.0, 4.0, 5.0];
        let est = [1.005, 2.5, 3.0, 0.0, 5.04];
        let a = depth_accuracy_relative(&est, &gt, None, 0.01);
        assert_eq!(a.pixels, 4); // gt 0 is not evaluated
        assert!((a.within - 2.0 / 4.0).abs() < 1e-12); // 1.005 and 5.04 are within 1%
        let mask = [true, true, true, false, false];
        let b = depth_accuracy_relative(&est, &gt, Some(&mask), 0.01);
        assert_eq!((b.pixels, b.within), (2, 0.5));
        let c = depth_accuracy_absolute(&est, &gt, None, 0.6);
        assert!((c.within - 3.0 / 4.0).abs() < 1e-12);
    }

    /// Views scored from an estimate `scale` times the truth, with errors of ±3% around
    /// that scattered both ways (a method's).
    fn report_scaled(scales: &[f64]) -> DepthReport {
        let gt: Vec<f32> = (0..400).map(|i| 1.0 + (i % 37) as f32 * 0.05).collect();
        let views = scales
            .iter()
            .enumerate()
            .map(|(v, &k)| {
                let est: Vec<f32> = gt
                    .iter()
                    .enumerate()
                    .map(|(i, &g)| {
                        let wobble = [-0.03, 0.0, 0.03, -0.01, 0.01][i % 5];
                        if i % 11 == 0 {
                            0.0 // no estimate: not in the ratio
                        } else {
                            (g as f64 * (k + wobble)) as f32
                        }
                    })
                    .collect();
                score(v, &est, &gt, None, &[], &[0.02])
            })
            .collect();
        DepthReport {
            overall: score(usize::MAX, &[], &[], None, &[], &[0.02]),
            views,
        }
    }

    /// The spans of `est` and `gt` (lengths `spans`) pooled as `evaluate_depths` pools its
    /// views, each scored with its scale-free shares: a single span gives that view's row,
    /// several the pooled row.
    fn score_with_scale(
        view: usize,
        est: &[f32],
        gt: &[f32],
        mask: Option<&[bool]>,
        spans: &[usize],
        abs: &[f64],
        rel: &[f64],
    ) -> ViewDepthEval {
        let (rows, overall) = pooled(est, gt, mask, spans, abs, rel, MEDIAN_KEEP);
        match rows.as_slice() {
            [one] => ViewDepthEval {
                view,
                ..one.clone()
            },
            _ => overall,
        }
    }

    /// Every span's row and the pooled row, the medians keeping `keep` values a pass.
    fn pooled(
        est: &[f32],
        gt: &[f32],
        mask: Option<&[bool]>,
        spans: &[usize],
        abs: &[f64],
        rel: &[f64],
        keep: usize,
    ) -> (Vec<ViewDepthEval>, ViewDepthEval) {
        let mut ranges = Vec::new();
        let mut start = 0;
        for &len in spans {
            ranges.push(start..start + len);
            start += len;
        }
        let mut pool = Pool::new(abs, rel, keep);
        let rows = ranges
            .iter()
            .enumerate()
            .map(|(v, r)| {
                let m = mask.map(|m| &m[r.clone()]);
                pool.add_view(v, &est[r.clone()], &gt[r.clone()], m)
            })
            .collect();
        pool.end_pass().expect("same values");
        let mut passes = 1;
        while pool.pending() {
            for r in &ranges {
                pool.feed(&est[r.clone()], &gt[r.clone()]);
            }
            pool.end_pass().expect("same values");
            passes += 1;
        }
        assert!(passes <= 4, "{passes} passes");
        (rows, pool.overall())
    }

    #[test]
    fn the_pooled_row_is_every_view_s_pixels_scored_together() {
        // Three views with their own scales, holes and masks (the last without one), and
        // repeated values: the pooled row, its medians found in passes of a few values, is
        // the row of all pixels scored as one map.
        let n = 300;
        let gt: Vec<f32> = (0..3 * n).map(|i| 1.0 + (i % 41) as f32 * 0.03).collect();
        let est: Vec<f32> = gt
            .iter()
            .enumerate()
            .map(|(i, &g)| match i % 13 {
                0 => 0.0,
                1 => f32::NAN,
                k => g * ([1.1, 0.97, 1.0][i / n] + [0.0, 0.004, -0.02, 0.011][k % 4]),
            })
            .collect();
        let mask: Vec<bool> = (0..3 * n).map(|i| i < 2 * n && i % 3 == 0).collect();
        let (abs, rel) = ([0.02, 0.1], [0.01, 0.02, 0.05]);
        let whole = score(usize::MAX, &est, &gt, Some(&mask), &abs, &rel);
        for keep in [MEDIAN_KEEP, 7, 1] {
            let (rows, all) = pooled(&est, &gt, Some(&mask), &[n, n, n], &abs, &rel, keep);
            assert_eq!(rows.len(), 3);
            assert_eq!(all.pixels, whole.pixels);
            assert_eq!(all.absolute, whole.absolute);
            assert_eq!(all.relative, whole.relative);
            assert_eq!(all.low_texture, whole.low_texture);
            assert_eq!(
                all.median_relative_error, whole.median_relative_error,
                "{keep}"
            );
            assert_eq!(all.median_ratio, whole.median_ratio, "{keep}");
        }
        // Without estimates the medians are none.
        let (_, none) = pooled(&[0.0; 8], &[1.0; 8], None, &[4, 4], &[], &[0.02], 1);
        assert!(none.median_ratio.is_nan() && none.median_relative_error.is_nan());
        assert!(none.scale_free.is_none());
    }

    #[test]
    fn a_median_select_finds_the_middle_in_any_number_of_passes() {
        let mut values: Vec<f64> = (0..1001)
            .map(|i| ((i * 7919) % 1009) as f64 * 1e-3 - 0.2)
            .collect();
        values.extend([0.0, -0.0, 1e300, -1e-300, 5e-324]);
        for keep in [usize::MAX, 100, 3, 0] {
            let mut m = MedianSelect::new(keep);
            let mut passes = 0;
            while m.pending() {
                values.iter().for_each(|&x| m.push(x));
                m.end_pass().expect("same values");
                passes += 1;
            }
            let mut sorted = values.clone();
            sorted.sort_by(f64::total_cmp);
            assert_eq!(m.median(), sorted[sorted.len() / 2], "keep {keep}");
            assert!(
                passes <= 4 && (keep < values.len()) == (passes > 1),
                "{passes}"
            );
        }
        // Values that change between passes are an error, not a wrong median.
        let mut m = MedianSelect::new(2);
        (0..10).for_each(|i| m.push(i as f64));
        m.end_pass().expect("first pass");
        (20..30).for_each(|i| m.push(i as f64));
        assert!(m.end_pass().is_err());
    }

    #[test]
    fn the_scale_free_shares_divide_out_each_view_s_own_scale() {
        // Two views, one 30% deeper than its truth, one right, both within 1% of their own
        // scale: as shipped only the second counts within 2%; scale-free both do.
        let gt: Vec<f32> = (0..200).map(|i| 1.0 + i as f32 * 0.01).collect();
        let wobble = |i: usize| [0.995, 1.0, 1.005, 0.998][i % 4];
        let deep: Vec<f32> = gt
            .iter()
            .enumerate()
            .map(|(i, &g)| g * 1.3 * wobble(i))
            .collect();
        let right: Vec<f32> = gt.iter().enumerate().map(|(i, &g)| g * wobble(i)).collect();
        let mask: Vec<bool> = (0..200).map(|i| i % 2 == 0).collect();
        let one = score_with_scale(0, &deep, &gt, Some(&mask), &[200], &[], &[0.02]);
        assert_eq!(one.relative[0].1, 0.0);
        let sf = one.scale_free.as_ref().unwrap();
        assert_eq!(sf.relative[0].1, 1.0);
        assert_eq!(sf.low_texture.as_ref().unwrap()[0].1, 1.0);
        // Pooled: each view by its own ratio (one pooled ratio would leave one view off).
        let est: Vec<f32> = deep.iter().chain(&right).copied().collect();
        let g2: Vec<f32> = gt.iter().chain(&gt).copied().collect();
        let pooled = score_with_scale(usize::MAX, &est, &g2, None, &[200, 200], &[], &[0.02]);
        assert!(
            (pooled.relative[0].1 - 0.5).abs() < 1e-9,
            "{:?}",
            pooled.relative
        );
        assert_eq!(pooled.scale_free.as_ref().unwrap().relative[0].1, 1.0);
        let whole = score_with_scale(usize::MAX, &est, &g2, None, &[400], &[], &[0.02]);
        assert!(whole.scale_free.unwrap().relative[0].1 < 0.6);
        // A missing estimate stays a miss, and a view without any has no ratio.
        let mut holes = right.clone();
        holes[..50].iter_mut().for_each(|d| *d = 0.0);
        let h = score_with_scale(0, &holes, &gt, None, &[200], &[], &[0.02]);
        assert_eq!(h.scale_free.unwrap().relative[0].1, 0.75);
        assert!(
            score_with_scale(0, &[0.0; 4], &[1.0; 4], None, &[4], &[], &[0.02])
                .scale_free
                .is_none()
        );
        // The table says it under the rows.
        let r = DepthReport {
            views: vec![one.clone()],
            overall: one,
        };
        assert!(
            format_depth_report(&r).contains("divided out (a scale the cameras or truth may carry): 100.0% within 2%; weak texture 100.0% within 2%"),
            "{}",
            format_depth_report(&r)
        );
    }

    #[test]
    fn a_scale_bias_in_most_views_is_named_as_the_data_s() {
        // The kitchens as shipped: every view 6-10% deeper than its truth.
        let r = report_scaled(&[1.06, 1.08, 1.10, 1.07]);
        for (v, k) in r.views.iter().zip([1.06, 1.08, 1.10, 1.07]) {
            assert!((v.median_ratio - k).abs() < 1e-6, "{} {k}", v.median_ratio);
        }
        let note = scale_bias_note(&r);
        assert!(
            note.contains("1.06-1.10x the truth at the median in 4 of 4 views, all deeper"),
            "{note}"
        );
        assert!(format_depth_report(&r).contains(&note));
        assert!(format_depth_report(&r).contains("  1.080\n"));
        // Shallower the same way.
        assert!(scale_bias_note(&report_scaled(&[0.9, 0.92, 1.0])).contains("all shallower"));
        // Scattered errors around the right scale (within 5%): nothing to say.
        assert_eq!(
            scale_bias_note(&report_scaled(&[1.0, 1.02, 0.97, 1.049])),
            ""
        );
        // One view off: named alone.
        let one = scale_bias_note(&report_scaled(&[1.0, 1.0, 1.2, 1.0]));
        assert!(one.contains("in view(s) 00000002 (1.20x)"), "{one}");
        // Half the views off, but both ways: not a common bias, each named.
        let mixed = scale_bias_note(&report_scaled(&[1.1, 0.9, 1.0, 1.0]));
        assert!(
            mixed.contains("00000000 (1.10x), 00000001 (0.90x)"),
            "{mixed}"
        );
        // No estimate at all: NaN, not a bias.
        let empty = score(0, &[0.0; 4], &[1.0; 4], None, &[], &[0.02]);
        assert!(empty.median_ratio.is_nan());
    }
}

/// Point cloud quality at one distance threshold (the ETH3D definitions): accuracy is the share
/// of reconstructed points within τ of the ground truth, completeness the share of
/// ground-truth points within τ of the reconstruction, F1 their harmonic mean.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CloudScore {
    pub threshold: f64,
    pub accuracy: f64,
    pub completeness: f64,
    pub f1: f64,
}

/// A uniform grid over points for radius queries (cell = the query radius).
struct Grid<'a> {
    cell: f64,
    points: &'a [[f32; 3]],
    cells: std::collections::HashMap<(i64, i64, i64), Vec<u32>>,
}

impl<'a> Grid<'a> {
    fn new(points: &'a [[f32; 3]], cell: f64) -> Grid<'a> {
        let mut cells: std::collections::HashMap<(i64, i64, i64), Vec<u32>> =
            std::collections::HashMap::new();
        for (i, p) in points.iter().enumerate() {
            cells.entry(Self::key(p, cell)).or_default().push(i as u32);
        }
        Grid {
            cell,
            points,
            cells,
        }
    }

    fn key(p: &[f32; 3], cell: f64) -> (i64, i64, i64) {
        (
            (p[0] as f64 / cell).floor() as i64,
            (p[1] as f64 / cell).floor() as i64,
            (p[2] as f64 / cell).floor() as i64,
        )
    }

    /// Whether any point lies within `radius` (<= cell) of `q`.
    fn any_within(&self, q: &[f32; 3], radius: f64) -> bool {
        let (kx, ky, kz) = Self::key(q, self.cell);
        let r2 = radius * radius;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(ids) = self.cells.get(&(kx + dx, ky + dy, kz + dz)) {
                        for &i in ids {
                            let p = self.points[i as usize];
                            let d2 = (0..3)
                                .map(|k| (p[k] as f64 - q[k] as f64).powi(2))
                                .sum::<f64>();
                            if d2 <= r2 {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    }
}

/// Scores a reconstruction against ground-truth points at each threshold (scene units).
pub fn cloud_scores(
    reconstruction: &[[f32; 3]],
    ground_truth: &[[f32; 3]],
    thresholds: &[f64],
) -> Vec<CloudScore> {
    use rayon::prelude::*;
    thresholds
        .iter()
        .map(|&t| {
            let share = |from: &[[f32; 3]], to: &[[f32; 3]]| -> f64 {
                if from.is_empty() {
                    return 0.0;
                }
                let grid = Grid::new(to, t);
                let hits = from.par_iter().filter(|p| grid.any_within(p, t)).count();
                hits as f64 / from.len() as f64
            };
            let accuracy = share(reconstruction, ground_truth);
            let completeness = share(ground_truth, reconstruction);
            let f1 = if accuracy + completeness > 0.0 {
                2.0 * accuracy * completeness / (accuracy + completeness)
            } else {
                0.0
            };
            CloudScore {
                threshold: t,
                accuracy,
                completeness,
                f1,
            }
        })
        .collect()
}

/// One view's ground-truth depth as [`truth_cloud`] reads it: its camera (at any size; it
/// is rescaled to the depth's) and the depth map, 0 or non-finite where unknown.
pub struct TruthView<'a> {
    pub camera: &'a crate::camera::Camera,
    pub width: u32,
    pub height: u32,
    pub depth: &'a [f32],
}

/// The voxel [`truth_cloud`] thins the truth to for cloud thresholds `thresholds`: half the
/// smallest (1 cm for ETH3D's 2 and 5 cm), so thinning moves no truth point by more than
/// half of any threshold's radius, while a wall seen by ten views counts once, not ten
/// times, in the completeness. `None` without a positive, finite threshold.
pub fn truth_voxel(thresholds: &[f64]) -> Option<f64> {
    thresholds
        .iter()
        .copied()
        .filter(|t| t.is_finite() && *t > 0.0)
        .reduce(f64::min)
        .map(|t| t * 0.5)
}

/// Every view's ground truth back-projected into the world, one point per `voxel`-sized cube
/// (the first in view and pixel order): the ground-truth cloud of scenes whose truth is
/// depth maps (the rgbd rooms, the demo scene), which `mvscope eval` and the accuracy suite
/// score fused clouds against.
pub fn truth_cloud<'a>(
    views: impl IntoIterator<Item = TruthView<'a>>,
    voxel: f64,
) -> Vec<[f32; 3]> {
    let mut cloud = TruthCloud::new(voxel);
    for t in views {
        cloud.add(t);
    }
    cloud.points
}

/// [`truth_cloud`] built one view at a time, so that a caller reading each view's truth from
/// disk holds one depth map, not all of them.
struct TruthCloud {
    voxel: f64,
    seen: std::collections::HashSet<(i64, i64, i64)>,
    points: Vec<[f32; 3]>,
}

impl TruthCloud {
    fn new(voxel: f64) -> TruthCloud {
        TruthCloud {
            voxel,
            seen: std::collections::HashSet::new(),
            points: Vec::new(),
        }
    }

    /// The view's points whose cube holds none yet.
    fn add(&mut self, t: TruthView) {
        // The camera at the truth's size (it may differ from the processed one).
        let camera = t.camera.rescaled(t.width, t.height);
        let voxel = self.voxel;
        for (i, &d) in t.depth.iter().enumerate() {
            if !(d > 0.0 && d.is_finite()) {
                continue;
            }
            let (x, y) = ((i as u32 % t.width) as f64, (i as u32 / t.width) as f64);
            let p = camera.unproject(glam::DVec2::new(x, y), d as f64);
            let key = (
                (p.x / voxel).floor() as i64,
                (p.y / voxel).floor() as i64,
                (p.z / voxel).floor() as i64,
            );
            if self.seen.insert(key) {
                self.points.push([p.x as f32, p.y as f32, p.z as f32]);
            }
        }
    }
}

/// [`truth_cloud`] of a scene folder: its cameras (`options` as a run loaded it; no image is
/// decoded) and `gt_dir/gt/%08d.pfm` of `views` (numbered as on disk; `None`: every view).
/// `None` where none of the views has ground truth.
pub fn truth_cloud_dir(
    scene: &std::path::Path,
    options: &crate::scene::LoadOptions,
    views: Option<&[usize]>,
    gt_dir: &std::path::Path,
    voxel: f64,
) -> Result<Option<Vec<[f32; 3]>>, EvalError> {
    let scene = crate::scene::Scene::load(scene, &options.cameras_only())?;
    let all: Vec<usize> = (0..scene.views.len()).collect();
    let views = views.unwrap_or(&all);
    if let Some(&v) = views.iter().find(|&&v| v >= scene.views.len()) {
        return Err(EvalError::Missing(format!(
            "view {v}: the scene at {} has {} views (0-{})",
            scene.root.display(),
            scene.views.len(),
            scene.views.len().saturating_sub(1)
        )));
    }
    let cameras: Vec<&crate::camera::Camera> =
        views.iter().map(|&v| &scene.views[v].camera).collect();
    truth_cloud_of(&cameras, views, gt_dir, voxel)
}

/// [`truth_cloud`] of views already loaded: `cameras[i]` is the view numbered `disk[i]` on
/// disk, whose truth is `gt_dir/gt/%08d.pfm`. `None` where none has ground truth.
pub fn truth_cloud_of(
    cameras: &[&crate::camera::Camera],
    disk: &[usize],
    gt_dir: &std::path::Path,
    voxel: f64,
) -> Result<Option<Vec<[f32; 3]>>, EvalError> {
    // One truth at a time: a hundred 12 Mpx truths would hold some 5 GB.
    let mut cloud = TruthCloud::new(voxel);
    let mut any = false;
    for (&camera, &v) in cameras.iter().zip(disk) {
        if let Some(t) = read_truth(gt_dir, v)? {
            any = true;
            cloud.add(TruthView {
                camera,
                width: t.depth.width,
                height: t.depth.height,
                depth: &t.depth.data,
            });
        }
    }
    Ok(any.then_some(cloud.points))
}

#[cfg(test)]
mod cloud_tests {
    use super::*;

    #[test]
    fn scores_follow_the_eth3d_definitions() {
        // Ground truth: a 10x10 grid at z = 0 with spacing 0.1.
        let gt: Vec<[f32; 3]> = (0..100)
            .map(|i| [(i % 10) as f32 * 0.1, (i / 10) as f32 * 0.1, 0.0])
            .collect();
        // Reconstruction: the left half of the grid lifted by 0.02, plus 10 outliers.
        let mut rec: Vec<[f32; 3]> = gt
            .iter()
            .filter(|p| p[0] < 0.45)
            .map(|p| [p[0], p[1], 0.02])
            .collect();
        rec.extend((0..10).map(|i| [i as f32, 5.0, 5.0]));
        let s = cloud_scores(&rec, &gt, &[0.01, 0.05]);
        assert_eq!(s[0].accuracy, 0.0); // 0.02 off: nothing within 1 cm
        assert!((s[1].accuracy - 50.0 / 60.0).abs() < 1e-12);
        assert!((s[1].completeness - 0.5).abs() < 1e-12);
        let f1 = 2.0 * (50.0 / 60.0) * 0.5 / (50.0 / 60.0 + 0.5);
        assert!((s[1].f1 - f1).abs() < 1e-12);
        assert_eq!(cloud_scores(&[], &gt, &[0.1])[0].f1, 0.0);
    }

    #[test]
    fn the_truth_cloud_is_the_truth_back_projected_once_per_voxel() {
        use crate::camera::{Camera, Intrinsics};
        use glam::{DMat3, DVec3};
        // A camera 1 m in front of the world origin, looking down +z; its truth a wall at
        // depth 2 (world z = 3) over a 40x30 map, one pixel unknown (0) and one NaN.
        let camera = Camera {
            intrinsics: Intrinsics {
                fx: 40.0,
                fy: 40.0,
                cx: 20.0,
                cy: 15.0,
            },
            rotation: DMat3::IDENTITY,
            translation: DVec3::new(0.0, 0.0, -1.0),
            width: 80,
            height: 60,
        };
        let mut depth = vec![2.0f32; 40 * 30];
        depth[0] = 0.0;
        depth[1] = f32::NAN;
        // The camera is at twice the truth's size: rescaled, a pixel is 2/20 = 0.1 m on
        // the wall, so a 0.01 voxel keeps every known pixel and a 0.2 voxel one in four.
        let view = || TruthView {
            camera: &camera,
            width: 40,
            height: 30,
            depth: &depth,
        };
        let fine = truth_cloud([view()], 0.01);
        assert_eq!(fine.len(), 40 * 30 - 2);
        assert!(
            fine.iter().all(|p| (p[2] - 3.0).abs() < 1e-5),
            "{:?}",
            fine[0]
        );
        // Pixel (2, 0), the principal point rescaled about pixel centres to (9.75, 7.25):
        // x = (2 − 9.75) / 20 · 2 = −0.775 m, y = (0 − 7.25) / 20 · 2 = −0.725 m.
        assert!((fine[0][0] + 0.775).abs() < 1e-5, "{:?}", fine[0]);
        assert!((fine[0][1] + 0.725).abs() < 1e-5, "{:?}", fine[0]);
        // The same view twice adds nothing; a coarser voxel thins.
        assert_eq!(truth_cloud([view(), view()], 0.01).len(), fine.len());
        let coarse = truth_cloud([view()], 0.2).len();
        assert!(
            coarse < fine.len() / 3 && coarse > fine.len() / 5,
            "{coarse}"
        );
        assert_eq!(truth_voxel(&[0.05, 0.02, 0.1]), Some(0.01));
        assert_eq!(truth_voxel(&[0.0, f64::NAN]), None);
        assert_eq!(
            truth_voxel(&crate::accuracy::CLOUD_THRESHOLDS),
            Some(crate::accuracy::TRUTH_VOXEL)
        );
    }

    #[test]
    fn grid_queries_cross_cell_borders() {
        let pts = [[0.999f32, 0.0, 0.0]];
        let g = Grid::new(&pts, 0.1);
        assert!(g.any_within(&[1.05, 0.0, 0.0], 0.1));
        assert!(!g.any_within(&[1.2, 0.0, 0.0], 0.1));
    }
}

/// Scores at thresholds: (threshold, share of ground-truth pixels within it).
pub type Shares = Vec<(f64, f64)>;

/// One view of `mvscope eval`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ViewDepthEval {
    pub view: usize,
    pub pixels: usize,
    pub absolute: Shares,
    pub relative: Shares,
    /// Relative thresholds on the low-texture mask, when the ground truth has one.
    pub low_texture: Option<Shares>,
    pub median_relative_error: f64,
    /// Median of estimate / truth over the pixels with both: 1 where the estimate has the
    /// truth's scale. A view far from 1 while its shares are low points at the cameras or
    /// the truth (a focal length, a depth unit, a pose), not at the method:
    /// [`scale_bias_note`].
    pub median_ratio: f64,
    /// The relative shares again with the estimate divided by its view's `median_ratio`
    /// (the pooled scores: each view by its own): a truth or cameras off by one scale per
    /// view, as [`scale_bias_note`] names, no longer decides which pixels count as within.
    /// None where the view has no estimate to take a ratio from.
    pub scale_free: Option<ScaleFree>,
}

/// [`ViewDepthEval::scale_free`]: the relative thresholds on every pixel and on the
/// low-texture mask, after the view's median scale is divided out.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ScaleFree {
    pub relative: Shares,
    pub low_texture: Option<Shares>,
}

/// `mvscope eval` over the views that have ground truth, and all their pixels pooled.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DepthReport {
    pub views: Vec<ViewDepthEval>,
    pub overall: ViewDepthEval,
}

#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// The run's scene, loaded for its cameras ([`evaluate_seen_dir`]).
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    #[error("{0}")]
    Missing(String),
}

/// Nearest-pixel resampling of a `sw x sh` map to `dw x dh` (pixel centres, camera.rs): how
/// ground truth of another size is compared with an estimate.
pub fn resample_nearest<T: Copy>(src: &[T], sw: u32, sh: u32, dw: u32, dh: u32) -> Vec<T> {
    let (fx, fy) = (sw as f64 / dw as f64, sh as f64 / dh as f64);
    (0..dw * dh)
        .map(|i| {
            let (x, y) = (i % dw, i / dw);
            let u = (((x as f64 + 0.5) * fx - 0.5).round().max(0.0) as u32).min(sw - 1);
            let v = (((y as f64 + 0.5) * fy - 0.5).round().max(0.0) as u32).min(sh - 1);
            src[(v * sw + u) as usize]
        })
        .collect()
}

/// `data` (`sw` x `sh`) at `dw` x `dh` by [`resample_nearest`], moved rather than copied
/// when it already is: a 12 Mpx truth is 48 MB.
pub fn resample_nearest_owned<T: Copy>(data: Vec<T>, sw: u32, sh: u32, dw: u32, dh: u32) -> Vec<T> {
    if (sw, sh) == (dw, dh) && data.len() == dw as usize * dh as usize {
        data
    } else {
        resample_nearest(&data, sw, sh, dw, dh)
    }
}

/// A view's [`Count`]s at every threshold: what [`ViewDepthEval`]'s shares are made of, and
/// what pooling adds up view by view.
#[derive(Clone, Debug, Default)]
struct Counts {
    absolute: Vec<(f64, Count)>,
    relative: Vec<(f64, Count)>,
    /// The relative thresholds on the weak-texture mask, where there is one.
    low_texture: Option<Vec<(f64, Count)>>,
}

impl Counts {
    fn of(est: &[f32], gt: &[f32], mask: Option<&[bool]>, abs: &[f64], rel: &[f64]) -> Counts {
        let relative = |m: Option<&[bool]>| -> Vec<(f64, Count)> {
            rel.iter()
                .map(|&t| (t, count_within(est, gt, m, |g| t * g)))
                .collect()
        };
        Counts {
            absolute: abs
                .iter()
                .map(|&t| (t, count_within(est, gt, None, |_| t)))
                .collect(),
            relative: relative(None),
            low_texture: mask.map(|m| relative(Some(m))),
        }
    }

    /// No pixel yet, at the thresholds `abs` and `rel`: what pooling starts from.
    fn zero(abs: &[f64], rel: &[f64]) -> Counts {
        let zero = |ts: &[f64]| ts.iter().map(|&t| (t, Count::default())).collect();
        Counts {
            absolute: zero(abs),
            relative: zero(rel),
            low_texture: None,
        }
    }

    /// `other`'s pixels and hits added (same thresholds); a view without a mask adds no
    /// weak-texture pixel, as in a pooled mask where its pixels are false.
    fn add(&mut self, other: &Counts) {
        let add = |a: &mut Vec<(f64, Count)>, b: &[(f64, Count)]| {
            a.iter_mut().zip(b).for_each(|(x, y)| x.1.add(y.1));
        };
        add(&mut self.absolute, &other.absolute);
        add(&mut self.relative, &other.relative);
        match (&mut self.low_texture, &other.low_texture) {
            (Some(a), Some(b)) => add(a, b),
            (None, Some(b)) => self.low_texture = Some(b.clone()),
            (_, None) => {}
        }
    }

    fn shares(c: &[(f64, Count)]) -> Shares {
        c.iter().map(|(t, c)| (*t, c.share())).collect()
    }

    fn scale_free(&self) -> ScaleFree {
        ScaleFree {
            relative: Counts::shares(&self.relative),
            low_texture: self.low_texture.as_deref().map(Counts::shares),
        }
    }

    fn eval(&self, view: usize, pixels: usize, median_error: f64, ratio: f64) -> ViewDepthEval {
        ViewDepthEval {
            view,
            pixels,
            absolute: Counts::shares(&self.absolute),
            relative: Counts::shares(&self.relative),
            low_texture: self.low_texture.as_deref().map(Counts::shares),
            median_relative_error: median_error,
            median_ratio: ratio,
            scale_free: None,
        }
    }
}

/// One view's scores, without the scale-free shares, and the counts they were made of.
fn score_counts(
    view: usize,
    est: &[f32],
    gt: &[f32],
    mask: Option<&[bool]>,
    abs: &[f64],
    rel: &[f64],
) -> (ViewDepthEval, Counts) {
    let counts = Counts::of(est, gt, mask, abs, rel);
    let base = depth_accuracy_relative(est, gt, None, 0.01);
    let e = counts.eval(
        view,
        base.pixels,
        base.median_relative_error,
        median_ratio(est, gt),
    );
    (e, counts)
}

#[cfg(test)]
fn score(
    view: usize,
    est: &[f32],
    gt: &[f32],
    mask: Option<&[bool]>,
    abs: &[f64],
    rel: &[f64],
) -> ViewDepthEval {
    score_counts(view, est, gt, mask, abs, rel).0
}

/// `depth` divided by `ratio`, a view's median est/gt ([`median_ratio`]); `None` where
/// `ratio` is none (NaN: the view had no estimate to take one from).
pub fn divided_by_ratio(depth: &[f32], ratio: f64) -> Option<Vec<f32>> {
    (ratio.is_finite() && ratio > 0.0)
        .then(|| depth.iter().map(|&d| (d as f64 / ratio) as f32).collect())
}

/// How many values a [`MedianSelect`] keeps in one pass (8 bytes each) before it needs
/// another pass: a run of up to 4 Mpx in all needs one pass, as when every map was kept.
const MEDIAN_KEEP: usize = 1 << 22;

/// The exact median (the element at n / 2 in `f64::total_cmp` order, as [`middle`] takes
/// it) of values that arrive in passes, in bounded memory: a radix select over the values'
/// ordered bits, 16 bits a pass. Each pass counts the candidates (the values whose leading
/// bits are those earlier passes fixed) by their next 16 bits and keeps them while they
/// number at most `keep`. A pass that kept them all ends the search; otherwise the 16 bits
/// holding the median are fixed and the values are asked for again: at most four passes.
struct MedianSelect {
    keep: usize,
    /// Leading bits fixed so far (0, 16, 32 or 48), and their value.
    fixed: u32,
    prefix: u64,
    /// The median's rank among this pass's candidates; unknown in the first pass.
    rank: Option<usize>,
    counts: Vec<usize>,
    kept: Vec<u64>,
    overflow: bool,
    candidates: usize,
    found: Option<f64>,
}

/// `x`'s bits as an integer in `f64::total_cmp` order.
fn ordered_bits(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 { !b } else { b | 1 << 63 }
}

fn from_ordered_bits(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

impl MedianSelect {
    fn new(keep: usize) -> MedianSelect {
        MedianSelect {
            keep,
            fixed: 0,
            prefix: 0,
            rank: None,
            counts: vec![0; 1 << 16],
            kept: Vec::new(),
            overflow: false,
            candidates: 0,
            found: None,
        }
    }

    fn pending(&self) -> bool {
        self.found.is_none()
    }

    fn push(&mut self, x: f64) {
        if self.found.is_some() {
            return;
        }
        let k = ordered_bits(x);
        if self.fixed > 0 && k >> (64 - self.fixed) != self.prefix {
            return;
        }
        self.counts[((k >> (48 - self.fixed)) & 0xffff) as usize] += 1;
        self.candidates += 1;
        if !self.overflow {
            if self.kept.len() < self.keep {
                self.kept.push(k);
            } else {
                self.overflow = true;
                self.kept = Vec::new();
            }
        }
    }

    /// Ends a pass: the median found, or the next 16 bits fixed for another pass. Values
    /// that differ from the first pass's (a map that changed between passes) are an error.
    fn end_pass(&mut self) -> Result<(), EvalError> {
        if self.found.is_some() {
            return Ok(());
        }
        let rank = *self.rank.get_or_insert(self.candidates / 2);
        let changed = || {
            EvalError::Missing(
                "the depth maps changed while they were scored (a pooled median reads them twice)"
                    .into(),
            )
        };
        if self.candidates == 0 && self.fixed == 0 {
            self.found = Some(f64::NAN);
            return Ok(());
        }
        if rank >= self.candidates {
            return Err(changed());
        }
        if !self.overflow {
            let k = *self.kept.select_nth_unstable(rank).1;
            self.found = Some(from_ordered_bits(k));
        } else {
            let mut below = 0;
            let digit = self
                .counts
                .iter()
                .position(|&c| {
                    below += c;
                    below > rank
                })
                .ok_or_else(changed)?;
            self.rank = Some(rank - (below - self.counts[digit]));
            self.prefix = self.prefix << 16 | digit as u64;
            self.fixed += 16;
            if self.fixed == 64 {
                self.found = Some(from_ordered_bits(self.prefix));
            }
        }
        self.counts.iter_mut().for_each(|c| *c = 0);
        self.kept = Vec::new();
        self.overflow = false;
        self.candidates = 0;
        Ok(())
    }

    fn median(&self) -> f64 {
        self.found.unwrap_or(f64::NAN)
    }
}

/// `mvscope eval`'s pooled row, built view by view: the counts add up and the two pooled
/// medians come from [`MedianSelect`]s, so no view's maps are kept (before, every view's
/// estimate, truth and mask were: 9 bytes a pixel of the run, and 8 more while sorting).
struct Pool<'t> {
    abs: &'t [f64],
    rel: &'t [f64],
    pixels: usize,
    counts: Counts,
    /// Each view divided by its own median ratio (undivided where it has none).
    scale_free: Counts,
    any_ratio: bool,
    errors: MedianSelect,
    ratios: MedianSelect,
}

impl<'t> Pool<'t> {
    fn new(abs: &'t [f64], rel: &'t [f64], keep: usize) -> Pool<'t> {
        Pool {
            abs,
            rel,
            pixels: 0,
            counts: Counts::zero(abs, rel),
            scale_free: Counts::zero(&[], rel),
            any_ratio: false,
            errors: MedianSelect::new(keep),
            ratios: MedianSelect::new(keep),
        }
    }

    /// View `v` scored (with its scale-free shares) and added: the medians' first pass.
    fn add_view(
        &mut self,
        v: usize,
        est: &[f32],
        gt: &[f32],
        mask: Option<&[bool]>,
    ) -> ViewDepthEval {
        let (mut e, counts) = score_counts(v, est, gt, mask, self.abs, self.rel);
        let divided = divided_by_ratio(est, e.median_ratio);
        let free = Counts::of(divided.as_deref().unwrap_or(est), gt, mask, &[], self.rel);
        if divided.is_some() {
            e.scale_free = Some(free.scale_free());
            self.any_ratio = true;
        }
        self.scale_free.add(&free);
        self.counts.add(&counts);
        self.pixels += e.pixels;
        self.feed(est, gt);
        e
    }

    fn pending(&self) -> bool {
        self.errors.pending() || self.ratios.pending()
    }

    /// A view's values for the medians (every view once per pass).
    fn feed(&mut self, est: &[f32], gt: &[f32]) {
        for (d, g) in pairs(est, gt, None) {
            self.errors.push((d - g).abs() / g);
            self.ratios.push(d / g);
        }
    }

    fn end_pass(&mut self) -> Result<(), EvalError> {
        self.errors.end_pass()?;
        self.ratios.end_pass()
    }

    /// The pooled row, once no pass is pending.
    fn overall(&self) -> ViewDepthEval {
        let mut e = self.counts.eval(
            usize::MAX,
            self.pixels,
            self.errors.median(),
            self.ratios.median(),
        );
        e.scale_free = self.any_ratio.then(|| self.scale_free.scale_free());
        e
    }
}

/// Median of `est / gt` over the pixels where both are positive and finite (NaN: none).
pub fn median_ratio(est: &[f32], gt: &[f32]) -> f64 {
    let mut r: Vec<f64> = pairs(est, gt, None).map(|(d, g)| d / g).collect();
    middle(&mut r)
}

/// How far a view's median estimate / truth may be from 1 before [`scale_bias_note`] names
/// it. Measured with ACMM at 320 px (docs/accuracy.md): kitchen-a with its colour focal
/// length is 0.8-2.7% deeper than its truth in every view, the views of ICL's living room
/// its sources see 0.2-2.8%; the kitchens as shipped, whose cameras carry the depth
/// camera's focal length, 5.8-9.8% in every view, and kitchen-b with the colour focal length
/// still 7.4-15.4%. Single views go past it too: ICL's view 2, whose truth was made with
/// other cameras (5.4%), and view 1, which its sources barely see (74%).
pub const SCALE_BIAS: f64 = 0.05;

/// A note on the views whose estimate is more than [`SCALE_BIAS`] deeper or shallower than
/// their truth at the median, or "" where none is. A method's errors scatter both ways; a
/// whole view off one way by 5% or more, and most views the same way, is what a camera or
/// truth made for another camera gives (a wrong focal length or baseline, depth in other
/// units, a truth on the depth sensor's grid): judge the data before the method.
pub fn scale_bias_note(report: &DepthReport) -> String {
    let ratios: Vec<(usize, f64)> = report
        .views
        .iter()
        .map(|v| (v.view, v.median_ratio))
        .collect();
    scale_bias_note_for(&ratios)
}

/// [`scale_bias_note`] from each view's (index, median estimate / truth), as `bench
/// --accuracy` holds them.
pub fn scale_bias_note_for(ratios: &[(usize, f64)]) -> String {
    let off: Vec<(usize, f64)> = ratios
        .iter()
        .copied()
        .filter(|(_, r)| (r - 1.0).abs() > SCALE_BIAS)
        .collect();
    if off.is_empty() {
        return String::new();
    }
    let deeper = off.iter().filter(|(_, r)| *r > 1.0).count();
    let (lo, hi) = off.iter().fold((f64::MAX, f64::MIN), |(lo, hi), (_, r)| {
        (lo.min(*r), hi.max(*r))
    });
    let range = if (hi - lo).abs() < 0.005 {
        format!("{lo:.2}x")
    } else {
        format!("{lo:.2}-{hi:.2}x")
    };
    let n = ratios.len();
    if off.len() * 2 >= n && (deeper == off.len() || deeper == 0) {
        format!(
            "scale: the estimate is {range} the truth at the median in {} of {n} views, all {}: \
             a bias the same way in most views is the cameras' or the truth's (focal length, \
             baseline, depth units, truth on another camera's grid), not the method's; \
             check them before judging shares within 1-2% (`mvscope eval`'s `est/gt`)\n",
            off.len(),
            if deeper > 0 { "deeper" } else { "shallower" },
        )
    } else {
        let names: Vec<String> = off
            .iter()
            .map(|(v, r)| format!("{v:08} ({r:.2}x)"))
            .collect();
        format!(
            "scale: the estimate's median is more than {:.0}% off the truth's in view(s) {}: \
             their cameras or truth, or views their sources barely see (`mvscope eval`'s `est/gt`)\n",
            SCALE_BIAS * 100.0,
            names.join(", ")
        )
    }
}

/// A view's ground truth as `mvscope demo` and the shared scenes store it: depth in
/// `gt/%08d.pfm`, and where present the weak-texture mask `gt/%08d_lowtex.png` (8-bit, 255 on
/// weak texture) at the depth's size.
pub struct TruthFiles {
    pub depth: crate::io::Map,
    pub low_texture: Option<Vec<bool>>,
}

/// View `v`'s ground-truth depth under `gt_dir`, without its mask (`None` where it has none).
pub fn read_truth_depth(
    gt_dir: &std::path::Path,
    v: usize,
) -> Result<Option<crate::io::Map>, EvalError> {
    let path = gt_dir.join(format!("gt/{v:08}.pfm"));
    if !path.is_file() {
        return Ok(None);
    }
    Ok(Some(crate::io::read_pfm(&path)?))
}

/// View `v`'s ground truth under `gt_dir` (`None` where it has none).
pub fn read_truth(gt_dir: &std::path::Path, v: usize) -> Result<Option<TruthFiles>, EvalError> {
    let Some(depth) = read_truth_depth(gt_dir, v)? else {
        return Ok(None);
    };
    let path = gt_dir.join(format!("gt/{v:08}.pfm"));
    let mask_path = gt_dir.join(format!("gt/{v:08}_lowtex.png"));
    let low_texture = if mask_path.is_file() {
        let img = image::open(&mask_path).map_err(|e| {
            EvalError::Missing(format!(
                "{}: not a readable mask ({e}); it should be an 8-bit PNG, 255 on weak texture",
                mask_path.display()
            ))
        })?;
        let l = img.to_luma8();
        if (l.width(), l.height()) != (depth.width, depth.height) {
            return Err(EvalError::Missing(format!(
                "{}: {}x{}, but {} is {}x{}",
                mask_path.display(),
                l.width(),
                l.height(),
                path.display(),
                depth.width,
                depth.height
            )));
        }
        Some(l.pixels().map(|p| p.0[0] > 127).collect())
    } else {
        None
    };
    Ok(Some(TruthFiles { depth, low_texture }))
}

/// Scores `dir/depth/%08d.pfm` of `views` against `gt_dir/gt/%08d.pfm` (and the masks
/// `gt/%08d_lowtex.png` where present). Ground truth of another size is sampled at the
/// estimate's pixel centres. Views without ground truth are skipped; none at all is an error.
pub fn evaluate_run(
    dir: &std::path::Path,
    views: &[usize],
    gt_dir: &std::path::Path,
    abs: &[f64],
    rel: &[f64],
) -> Result<DepthReport, EvalError> {
    evaluate_depths(views, gt_dir, abs, rel, |v| {
        Ok(crate::io::read_pfm(&dir.join(format!("depth/{v:08}.pfm")))?)
    })
}

/// [`evaluate_run`] on depth maps from anywhere (the Python package's sessions and arrays):
/// `estimate(v)` gives view `v`'s depth map, asked for only where `v` has ground truth. One
/// view's maps are held at a time; the pooled medians may ask for every map again (a run of
/// more than 4 Mpx in all, [`MEDIAN_KEEP`]).
pub fn evaluate_depths(
    views: &[usize],
    gt_dir: &std::path::Path,
    abs: &[f64],
    rel: &[f64],
    estimate: impl FnMut(usize) -> Result<crate::io::Map, EvalError>,
) -> Result<DepthReport, EvalError> {
    evaluate_depths_keeping(views, gt_dir, abs, rel, MEDIAN_KEEP, estimate)
}

/// [`evaluate_depths`] with the medians keeping at most `keep` values a pass.
fn evaluate_depths_keeping(
    views: &[usize],
    gt_dir: &std::path::Path,
    abs: &[f64],
    rel: &[f64],
    keep: usize,
    mut estimate: impl FnMut(usize) -> Result<crate::io::Map, EvalError>,
) -> Result<DepthReport, EvalError> {
    // A view's estimate, and its truth and mask sampled at the estimate's size.
    #[allow(clippy::type_complexity)]
    let mut load =
        |v: usize| -> Result<Option<(Vec<f32>, Vec<f32>, Option<Vec<bool>>)>, EvalError> {
            let Some(truth) = read_truth(gt_dir, v)? else {
                return Ok(None);
            };
            let est = estimate(v)?;
            let gt = truth.depth;
            let (w, h) = (est.width, est.height);
            let g = resample_nearest_owned(gt.data, gt.width, gt.height, w, h);
            let mask = truth
                .low_texture
                .map(|m| resample_nearest_owned(m, gt.width, gt.height, w, h));
            Ok(Some((est.data, g, mask)))
        };
    let mut pool = Pool::new(abs, rel, keep);
    let mut per_view = Vec::new();
    for &v in views {
        if let Some((est, g, mask)) = load(v)? {
            per_view.push(pool.add_view(v, &est, &g, mask.as_deref()));
        }
    }
    if per_view.is_empty() {
        return Err(EvalError::Missing(format!(
            "no ground truth for these views: expected {}/gt/%08d.pfm (as `mvscope demo` writes)",
            gt_dir.display()
        )));
    }
    pool.end_pass()?;
    while pool.pending() {
        for &v in views {
            if let Some((est, g, _)) = load(v)? {
                pool.feed(&est, &g);
            }
        }
        pool.end_pass()?;
    }
    Ok(DepthReport {
        views: per_view,
        overall: pool.overall(),
    })
}

/// The report as a table.
pub fn format_depth_report(report: &DepthReport) -> String {
    let first = &report.overall;
    let mut header = format!("{:>8} {:>9}", "view", "pixels");
    for (t, _) in &first.absolute {
        header += &format!(" {:>8}", format!("<{t}"));
    }
    for (t, _) in &first.relative {
        header += &format!(" {:>8}", format!("<{}%", t * 100.0));
    }
    if let Some(l) = &first.low_texture {
        for (t, _) in l {
            header += &format!(" {:>10}", format!("low<{}%", t * 100.0));
        }
    }
    header += &format!(" {:>7}", "est/gt");
    let mut out = header + "\n";
    let row = |name: String, e: &ViewDepthEval| {
        let mut s = format!("{:>8} {:>9}", name, e.pixels);
        for (_, v) in e.absolute.iter().chain(&e.relative) {
            s += &format!(" {:>8.3}", v);
        }
        if let Some(l) = &e.low_texture {
            for (_, v) in l {
                s += &format!(" {:>10.3}", v);
            }
        }
        s + &format!(" {:>7.3}\n", e.median_ratio)
    };
    for v in &report.views {
        out += &row(format!("{:08}", v.view), v);
    }
    out += &row("all".into(), &report.overall);
    out + &scale_free_line(&report.overall) + &scale_bias_note(report)
}

/// The pooled scale-free shares as a line under the table ("" where there are none): what
/// the relative shares would be with each view's median scale divided out.
pub fn scale_free_line(overall: &ViewDepthEval) -> String {
    let Some(sf) = &overall.scale_free else {
        return String::new();
    };
    let fmt = |s: &Shares| {
        s.iter()
            .map(|(t, v)| format!("{:.1}% within {}%", 100.0 * v, t * 100.0))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut line = format!(
        "with each view's median est/gt divided out (a scale the cameras or truth may carry): {}",
        fmt(&sf.relative)
    );
    if let Some(l) = &sf.low_texture {
        line += &format!("; weak texture {}", fmt(l));
    }
    line + "\n"
}

/// How well a depth map explains the images under the scene's cameras: the reference's
/// textured pixels warped by a depth into a source, and their grey-level difference. Run
/// on the truth and on the estimate, it says whether the truth can judge the estimate: a
/// truth that fits the images worse than the estimate does was made with other cameras
/// than the images were (a calibration or registration error), and shares within 1-2% then
/// measure that error as much as the method (docs/accuracy.md, "ICL's images and its truth").
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PhotometricFit {
    pub view: usize,
    /// The view's best source (the first of its list), which the pixels are warped into.
    pub source: usize,
    /// Textured pixels (central-difference gradient above [`TEXTURED_GRADIENT`] grey
    /// levels per pixel) where both depths exist and both warps land in the source.
    pub pixels: usize,
    /// Median |I_ref − I_source(warp)| in grey levels (0-255), warped by the truth.
    pub truth_residual: f64,
    /// The same, warped by the estimate.
    pub estimate_residual: f64,
}

impl PhotometricFit {
    /// Truth residual over estimate residual.
    pub fn ratio(&self) -> f64 {
        self.truth_residual / self.estimate_residual.max(1e-6)
    }

    /// Whether the truth fits the images clearly worse than the estimate
    /// ([`MISFIT_RATIO`]).
    pub fn truth_fits_worse(&self) -> bool {
        self.ratio() > MISFIT_RATIO
    }
}

/// Where a pixel counts as textured for [`photometric_fit`]: a grey-level gradient above 4
/// per pixel, so that a warp a pixel off changes its grey level by more than the noise of
/// an 8-bit camera.
pub const TEXTURED_GRADIENT: f32 = 4.0;

/// The fitness above which the truth fits the images clearly worse than the estimate (truth
/// residual over estimate residual): Middlebury's pairs and the synthetic scenes measure
/// 0.9-1.1, ICL's living room 1.1-2.9 (docs/accuracy.md).
pub const MISFIT_RATIO: f64 = 1.5;

fn bilinear_gray(img: &crate::image::Image, x: f64, y: f64) -> Option<f32> {
    let (w, h) = (img.width as f64, img.height as f64);
    if x.is_nan() || y.is_nan() || x < 0.0 || y < 0.0 || x > w - 1.0 || y > h - 1.0 {
        return None;
    }
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = (
        (x0 + 1).min(img.width as usize - 1),
        (y0 + 1).min(img.height as usize - 1),
    );
    let (a, b) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let at = |x: usize, y: usize| img.gray[y * img.width as usize + x];
    let top = at(x0, y0) + (at(x1, y0) - at(x0, y0)) * a;
    let bottom = at(x0, y1) + (at(x1, y1) - at(x0, y1)) * a;
    Some(top + (bottom - top) * b)
}

fn median(mut v: Vec<f32>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    // The element a sort would put in the middle, without the sort: the camera check takes
    // 91 of these a view, of up to a value per pixel.
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f32::total_cmp).1 as f64
}

/// [`PhotometricFit`] of view `view` of `scene` (decoded) into its first source, with
/// `truth` and `estimate` at the view's image size (0 = no depth). With the source's truth
/// (at its image size) only pixels the source sees count: the truth's point lands within 2%
/// of the source's true depth there (not occluded). `None` when the view has no source or
/// no textured pixel lands in it.
pub fn photometric_fit(
    scene: &crate::scene::Scene,
    view: usize,
    truth: &[f32],
    estimate: &[f32],
    source_truth: Option<&[f32]>,
) -> Option<PhotometricFit> {
    let r = scene.views.get(view)?;
    let seen = match source_truth {
        Some(_) => Some(seen_pixels(scene, r, truth, source_truth)?),
        None => None,
    };
    let pixels = textured_pixels(&r.image, seen.as_deref())?;
    let fit = photometric_fit_with(scene, view, &r.camera, truth, Some(estimate), &pixels)?;
    Some(PhotometricFit {
        view,
        source: fit.source,
        pixels: fit.pixels,
        truth_residual: fit.truth_residual,
        estimate_residual: fit.estimate_residual?,
    })
}

/// What [`photometric_fit_with`] measures: the estimate's residual only where it was given.
struct Residuals {
    source: usize,
    pixels: usize,
    truth_residual: f64,
    estimate_residual: Option<f64>,
}

/// The pixels a photometric fit of `image` compares (row-major indices): inside a
/// one-pixel border, textured (central-difference gradient above [`TEXTURED_GRADIENT`]) and
/// marked by `only` (all without it). The same for every camera [`measure_camera_offset`]
/// tries, so it finds them once. `None` for an image without grey levels or of more than
/// 2^32 pixels.
fn textured_pixels(image: &crate::image::Image, only: Option<&[bool]>) -> Option<Vec<u32>> {
    let (w, h) = (image.width as usize, image.height as usize);
    let g = &image.gray;
    if g.len() != w * h || u32::try_from(w * h).is_err() {
        return None;
    }
    let mut pixels = Vec::new();
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let i = y * w + x;
            if only.is_some_and(|m| !m.get(i).copied().unwrap_or(false)) {
                continue;
            }
            let gx = (g[i + 1] - g[i - 1]) * 0.5;
            let gy = (g[i + w] - g[i - w]) * 0.5;
            if (gx * gx + gy * gy).sqrt() > TEXTURED_GRADIENT {
                pixels.push(i as u32);
            }
        }
    }
    Some(pixels)
}

/// [`photometric_fit`] with the reference seen through `camera` (its own, or one moved by
/// [`camera_offset`]), over `pixels` ([`textured_pixels`]). Without an `estimate` only the
/// truth is warped (the camera check's 91 fits a view), over the same pixels: those where
/// the truth's warp lands.
fn photometric_fit_with(
    scene: &crate::scene::Scene,
    view: usize,
    camera: &crate::camera::Camera,
    truth: &[f32],
    estimate: Option<&[f32]>,
    pixels: &[u32],
) -> Option<Residuals> {
    use glam::DVec2;
    let r = scene.views.get(view)?;
    let source = r.sources.first()?.index;
    let s = scene.views.get(source)?;
    let (w, h) = (r.image.width as usize, r.image.height as usize);
    if truth.len() != w * h || estimate.is_some_and(|e| e.len() != w * h) || s.image.gray.is_empty()
    {
        return None;
    }
    let g = &r.image.gray;
    let warp = |i: usize, d: f32| -> Option<f32> {
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        let p = DVec2::new((i % w) as f64, (i / w) as f64);
        let (q, z) = s.camera.project(camera.unproject(p, d as f64))?;
        if z <= 0.0 {
            return None;
        }
        bilinear_gray(&s.image, q.x, q.y).map(|v| (v - g[i]).abs())
    };
    let mut by_truth = Vec::with_capacity(pixels.len());
    let mut by_estimate = Vec::with_capacity(estimate.map_or(0, |_| pixels.len()));
    for &i in pixels {
        let i = i as usize;
        let Some(a) = warp(i, truth[i]) else {
            continue;
        };
        match estimate {
            Some(e) => {
                if let Some(b) = warp(i, e[i]) {
                    by_truth.push(a);
                    by_estimate.push(b);
                }
            }
            None => by_truth.push(a),
        }
    }
    if by_truth.is_empty() {
        return None;
    }
    Some(Residuals {
        source,
        pixels: by_truth.len(),
        truth_residual: median(by_truth),
        estimate_residual: estimate.map(|_| median(by_estimate)),
    })
}

/// A principal-point shift that makes the truth fit the images clearly better: the
/// reference camera moved by (dx, dy) px, the truth's residual unmoved and moved.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CameraOffset {
    pub view: usize,
    pub source: usize,
    pub dx: f64,
    pub dy: f64,
    pub residual: f64,
    pub moved_residual: f64,
}

/// Below this share of the unmoved residual a moved camera counts as a better fit: on
/// Middlebury's Bowling1 the unmoved camera is best and 2 px doubles the residual; ICL's
/// views 0, 2 and 4 fall to 0.5-0.65 (docs/accuracy.md).
pub const OFFSET_GAIN: f64 = 0.75;

/// Whether view `view`'s truth fits its best source better with the reference camera's
/// principal point moved by up to 8 px (2 px steps, then 1 px around the best): a test of
/// the cameras against the images that needs no estimate. `None` when the unmoved camera
/// fits as well (within [`OFFSET_GAIN`]) or nothing lands in the source.
pub fn camera_offset(
    scene: &crate::scene::Scene,
    view: usize,
    truth: &[f32],
    source_truth: Option<&[f32]>,
) -> Option<CameraOffset> {
    measure_camera_offset(scene, view, truth, source_truth).filter(CameraOffset::is_offset)
}

/// [`camera_offset`]'s search, whatever it finds: the best shift and both residuals, also
/// where the unmoved camera fits as well (what [`principal_point_corrections`] needs: a
/// view that fits its source ties the two together). `None` when nothing lands in the
/// source.
pub fn measure_camera_offset(
    scene: &crate::scene::Scene,
    view: usize,
    truth: &[f32],
    source_truth: Option<&[f32]>,
) -> Option<CameraOffset> {
    // The pixels: textured and seen by the source through the unmoved camera, the same
    // for every shift (a moved camera must not choose its own, flatter pixels).
    let r = scene.views.get(view)?;
    let pixels = textured_pixels(&r.image, Some(&seen_pixels(scene, r, truth, source_truth)?))?;
    let residual = |dx: f64, dy: f64| -> Option<f64> {
        let mut moved = r.camera;
        moved.intrinsics.cx += dx;
        moved.intrinsics.cy += dy;
        photometric_fit_with(scene, view, &moved, truth, None, &pixels).map(|f| f.truth_residual)
    };
    let base = residual(0.0, 0.0)?;
    let mut best = (base, 0.0, 0.0);
    for step in [2.0f64, 1.0] {
        let (cx, cy) = (best.1, best.2);
        let reach = if step == 2.0 { 4 } else { 1 };
        for i in -reach..=reach {
            for j in -reach..=reach {
                let (dx, dy) = (cx + i as f64 * step, cy + j as f64 * step);
                if let Some(r) = residual(dx, dy)
                    && r < best.0
                {
                    best = (r, dx, dy);
                }
            }
        }
    }
    let source = r.sources.first()?.index;
    Some(CameraOffset {
        view,
        source,
        dx: best.1,
        dy: best.2,
        residual: base,
        moved_residual: best.0,
    })
}

impl CameraOffset {
    /// Whether the moved camera fits clearly better ([`OFFSET_GAIN`]).
    pub fn is_offset(&self) -> bool {
        self.moved_residual < OFFSET_GAIN * self.residual
    }

    /// The shift this measurement stands for: its own where it is an offset, none where the
    /// unmoved camera fits as well.
    fn shift(&self) -> (f64, f64) {
        if self.is_offset() {
            (self.dx, self.dy)
        } else {
            (0.0, 0.0)
        }
    }
}

/// One principal-point correction per view that explains every measured pair.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PrincipalPointFix {
    pub view: usize,
    /// Pixels to add to the view's cx and cy.
    pub dx: f64,
    pub dy: f64,
}

/// The principal-point corrections that explain the pairwise measurements of
/// [`measure_camera_offset`]. A measurement of view v against its source s (moving v's
/// principal point by d fits best) is the difference of their corrections, d = c_v − c_s:
/// moving the source moves its side of the warp. Least squares over the pairs (conjugate
/// gradients on the normal equations); pairs alone fix the corrections only up to a
/// common shift, so each connected group of views is shifted by its median per axis (the
/// fewest and smallest corrections). Returns the corrections of the views in some pair,
/// and the largest pair the solution misses, in pixels (one error per view explains the
/// measurements when it is about the search's 1 px step).
pub fn principal_point_corrections(pairs: &[CameraOffset]) -> (Vec<PrincipalPointFix>, f64) {
    let mut views: Vec<usize> = pairs.iter().flat_map(|p| [p.view, p.source]).collect();
    views.sort_unstable();
    views.dedup();
    let at = |v: usize| views.binary_search(&v).unwrap_or(0);
    let n = views.len();
    // The pairs as edges (v, s, d): the normal equations of Σ (c_v − c_s − d)² are the
    // graph Laplacian's, solved by conjugate gradients per axis (exact in n steps; a tiny
    // ridge keeps each group's common shift at zero until the median sets it).
    let edges: Vec<(usize, usize, (f64, f64))> = pairs
        .iter()
        .filter(|p| p.view != p.source)
        .map(|p| (at(p.view), at(p.source), p.shift()))
        .collect();
    let apply = |x: &[f64]| {
        let mut y: Vec<f64> = x.iter().map(|v| 1e-9 * v).collect();
        for &(v, s, _) in &edges {
            let t = x[v] - x[s];
            y[v] += t;
            y[s] -= t;
        }
        y
    };
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let solve = |axis: usize| {
        let mut b = vec![0.0; n];
        for &(v, s, d) in &edges {
            let d = if axis == 0 { d.0 } else { d.1 };
            b[v] += d;
            b[s] -= d;
        }
        let mut x = vec![0.0; n];
        let mut r = b.clone();
        let mut p = r.clone();
        let mut rr = dot(&r, &r);
        for _ in 0..(4 * n + 10) {
            if rr <= 1e-24 * (1.0 + dot(&b, &b)) {
                break;
            }
            let q = apply(&p);
            let alpha = rr / dot(&p, &q);
            for i in 0..n {
                x[i] += alpha * p[i];
                r[i] -= alpha * q[i];
            }
            let next = dot(&r, &r);
            for i in 0..n {
                p[i] = r[i] + next / rr * p[i];
            }
            rr = next;
        }
        x
    };
    let (cx, cy) = (solve(0), solve(1));
    let c: Vec<(f64, f64)> = cx.into_iter().zip(cy).collect();
    // Connected groups, each shifted by its median.
    let mut group: Vec<usize> = (0..n).collect();
    let find = |g: &Vec<usize>, mut i: usize| {
        while g[i] != i {
            i = g[i];
        }
        i
    };
    for p in pairs {
        let (a, b) = (find(&group, at(p.view)), find(&group, at(p.source)));
        if a != b {
            group[a.max(b)] = a.min(b);
        }
    }
    let roots: Vec<usize> = (0..n).map(|i| find(&group, i)).collect();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    let mut shifted = c.clone();
    for root in 0..n {
        let members: Vec<usize> = (0..n).filter(|&i| roots[i] == root).collect();
        if members.is_empty() {
            continue;
        }
        let mx = median(members.iter().map(|&i| c[i].0).collect());
        let my = median(members.iter().map(|&i| c[i].1).collect());
        for &i in &members {
            shifted[i] = (c[i].0 - mx, c[i].1 - my);
        }
    }
    let missed = pairs
        .iter()
        .filter(|p| p.view != p.source)
        .map(|p| {
            let (dx, dy) = p.shift();
            let (a, b) = (shifted[at(p.view)], shifted[at(p.source)]);
            (dx - (a.0 - b.0)).abs().max((dy - (a.1 - b.1)).abs())
        })
        .fold(0.0, f64::max);
    let fixes = views
        .iter()
        .zip(&shifted)
        .map(|(&view, &(dx, dy))| PrincipalPointFix {
            view,
            dx: (dx * 10.0).round() / 10.0,
            dy: (dy * 10.0).round() / 10.0,
        })
        .collect();
    (fixes, missed)
}

/// What [`principal_point_corrections`] found, for a person: nothing where no view is off.
pub fn format_principal_point_corrections(fixes: &[PrincipalPointFix], missed: f64) -> String {
    let moved: Vec<String> = fixes
        .iter()
        .filter(|f| f.dx != 0.0 || f.dy != 0.0)
        .map(|f| format!("view {:08} by ({:+.1}, {:+.1}) px", f.view, f.dx, f.dy))
        .collect();
    if moved.is_empty() {
        return String::new();
    }
    format!(
        "one principal-point error per view explains these offsets to within {missed:.1} px: add to cx, cy of {} (intrinsics only; then run again)\n",
        moved.join(", ")
    )
}

/// The reference's pixels whose true point the first source sees (its true depth there
/// within 2%, or every pixel landing in it without the source's truth).
fn seen_pixels(
    scene: &crate::scene::Scene,
    r: &crate::scene::View,
    truth: &[f32],
    source_truth: Option<&[f32]>,
) -> Option<Vec<bool>> {
    let s = scene.views.get(r.sources.first()?.index)?;
    let w = r.image.width as usize;
    if source_truth.is_some_and(|t| t.len() != (s.image.width * s.image.height) as usize) {
        return None;
    }
    Some(
        (0..truth.len())
            .map(|i| {
                let d = truth[i] as f64;
                if d.is_nan() || d <= 0.0 {
                    return false;
                }
                let p = glam::DVec2::new((i % w) as f64, (i / w) as f64);
                let Some((j, z)) = pixel_in(s, r.camera.unproject(p, d)) else {
                    return false;
                };
                source_truth.is_none_or(|t| {
                    let there = t[j] as f64;
                    there > 0.0 && ((z - there) / there).abs() < 0.02
                })
            })
            .collect(),
    )
}

/// The pixel of `view`'s image (row-major index) a world point projects to, rounded, and the
/// point's depth in that camera; `None` behind the camera or outside the image.
fn pixel_in(view: &crate::scene::View, world: glam::DVec3) -> Option<(usize, f64)> {
    let (q, z) = view.camera.project(world)?;
    let (w, h) = (view.image.width as f64, view.image.height as f64);
    let (u, v) = (q.x.round(), q.y.round());
    (u >= 0.0 && v >= 0.0 && u < w && v < h)
        .then(|| (v as usize * view.image.width as usize + u as usize, z))
}

/// How much nearer than a point a source's truth must be to hide it from that source
/// ([`seen_by_sources`]): more than the truth's own noise (the Kinect's 1-2%) and the step of
/// one pixel on a slanted wall, less than the gap to an occluder in a room.
pub const OCCLUSION_TOLERANCE: f64 = 0.03;

/// The pixels of view `v` whose true point one of its sources sees: the truth (each view's
/// at its processed size, `truths[view]`) unprojected, projected into every source, inside
/// its image and not hidden there by the source's truth (nearer than the point by more than
/// [`OCCLUSION_TOLERANCE`]; a source pixel without truth hides nothing). Pixels without
/// truth are false. What the method can match at all: a pixel no source sees has no
/// photometric or geometric evidence, only what a prior extends to it. `None` when `v` has
/// no truth of its image's size.
pub fn seen_by_sources(
    scene: &crate::scene::Scene,
    v: usize,
    truths: &[Option<Vec<f32>>],
) -> Option<Vec<bool>> {
    let own = truths.get(v)?.as_deref()?;
    let mut memory = TruthsInMemory { truths, masks: &[] };
    // Truths in memory are never read, so this cannot fail.
    seen_source_by_source(scene, v, own, &mut memory)
        .ok()
        .flatten()
}

/// [`seen_by_sources`] of view `v`, whose truth is `own`, with its sources' truths asked
/// of `truths` one at a time, in pair.txt's order: a pixel is seen as soon as one source
/// sees it (the union does not depend on the order), so a source's truth is needed only
/// while its own test runs, and none has to be held beside the others.
fn seen_source_by_source(
    scene: &crate::scene::Scene,
    v: usize,
    own: &[f32],
    truths: &mut dyn TruthSource<'_>,
) -> Result<Option<Vec<bool>>, EvalError> {
    let Some(r) = scene.views.get(v) else {
        return Ok(None);
    };
    let w = r.image.width as usize;
    if own.len() != w * r.image.height as usize {
        return Ok(None);
    }
    let mut seen = vec![false; own.len()];
    for s in &r.sources {
        let Some(source) = scene.views.get(s.index) else {
            continue;
        };
        let n = (source.image.width * source.image.height) as usize;
        truths.with_source(scene, s.index, &mut |t| {
            let t = t.filter(|t| t.len() == n);
            for (i, (seen, &d)) in seen.iter_mut().zip(own).enumerate() {
                let d = d as f64;
                if *seen || !(d.is_finite() && d > 0.0) {
                    continue;
                }
                let world = r
                    .camera
                    .unproject(glam::DVec2::new((i % w) as f64, (i / w) as f64), d);
                let Some((j, z)) = pixel_in(source, world) else {
                    continue;
                };
                *seen = t.is_none_or(|t| {
                    let there = t[j] as f64;
                    !(there > 0.0 && there < z * (1.0 - OCCLUSION_TOLERANCE))
                });
            }
        })?;
    }
    Ok(Some(seen))
}

/// Depth maps scored on the pixels a source sees ([`seen_by_sources`]) and on those none
/// sees: how much of a loss is where no view offers evidence.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SeenScore {
    /// Share of the ground-truth pixels a source sees.
    pub seen: f64,
    /// Within 2% on the seen pixels, and on the seen weak-texture pixels (where masked).
    pub within_2: f64,
    pub low_texture_within_2: Option<f64>,
    /// Within 2% on the pixels no source sees (None: a source sees every pixel).
    pub unseen_within_2: Option<f64>,
}

/// [`SeenScore`] of pooled maps: `estimate`, `truth`, `seen` and (optional) weak-texture
/// `mask`, pixel for pixel. `None` without truth pixels.
pub fn seen_score(
    estimate: &[f32],
    truth: &[f32],
    seen: &[bool],
    mask: Option<&[bool]>,
) -> Option<SeenScore> {
    SeenCounts::of(estimate, truth, seen, mask).score()
}

/// The counts a [`SeenScore`] is made of, added view by view.
#[derive(Clone, Copy, Debug, Default)]
struct SeenCounts {
    /// Truth pixels.
    pixels: usize,
    /// Within 2% on the seen, the unseen and the seen weak-texture pixels.
    seen: Count,
    unseen: Count,
    low_texture: Option<Count>,
}

impl SeenCounts {
    fn of(estimate: &[f32], truth: &[f32], seen: &[bool], mask: Option<&[bool]>) -> SeenCounts {
        let within = |m: &[bool]| count_within(estimate, truth, Some(m), |g| 0.02 * g);
        let unseen: Vec<bool> = seen.iter().map(|s| !s).collect();
        SeenCounts {
            pixels: truth.iter().filter(|g| **g > 0.0 && g.is_finite()).count(),
            seen: within(seen),
            unseen: within(&unseen),
            low_texture: mask.map(|m| {
                let both: Vec<bool> = m.iter().zip(seen).map(|(a, b)| *a && *b).collect();
                within(&both)
            }),
        }
    }

    fn add(&mut self, other: SeenCounts) {
        self.pixels += other.pixels;
        self.seen.add(other.seen);
        self.unseen.add(other.unseen);
        if let Some(o) = other.low_texture {
            self.low_texture.get_or_insert_default().add(o);
        }
    }

    fn score(&self) -> Option<SeenScore> {
        (self.pixels > 0).then(|| SeenScore {
            seen: self.seen.pixels as f64 / self.pixels as f64,
            within_2: self.seen.share(),
            low_texture_within_2: self.low_texture.filter(|l| l.pixels > 0).map(|l| l.share()),
            unseen_within_2: (self.unseen.pixels > 0).then(|| self.unseen.share()),
        })
    }
}

/// [`SeenScore`] of a run's maps, and each view's share of pixels seen.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SeenReport {
    pub score: SeenScore,
    /// (view, as numbered on disk; share of its truth pixels a source sees).
    pub per_view: Vec<(usize, f64)>,
}

/// [`SeenReport`] of the depth maps of `views` (indices into `scene.views`): each view's
/// truth read from `gt_dir` as numbered on disk (`disk[view]`), at its view's processed
/// size; `estimate(view)` gives its map, asked for only where it has truth. Every view of
/// the scene with truth can hide points from the others. `None` when no view of `views` has
/// truth and a map of its size. A view's truth is read when it or a view it is a source of
/// is scored; a source's is kept for the next views only within [`SOURCE_TRUTHS_KEPT`]
/// ([`TruthReader`]).
pub fn evaluate_seen(
    scene: &crate::scene::Scene,
    views: &[usize],
    disk: &[usize],
    gt_dir: &std::path::Path,
    estimate: impl FnMut(usize) -> Result<crate::io::Map, EvalError>,
) -> Result<Option<SeenReport>, EvalError> {
    seen_of(
        scene,
        views,
        disk,
        &mut TruthReader::new(gt_dir, disk),
        estimate,
    )
}

/// Each view's pixels a source sees ([`seen_by_sources`]), at its processed size, from the
/// truth in `gt_dir` numbered as on disk (`disk[view]`): what [`evaluate_seen`] splits the
/// scores by, per pixel. `None` for a view without truth.
pub fn seen_masks(
    scene: &crate::scene::Scene,
    disk: &[usize],
    gt_dir: &std::path::Path,
) -> Result<Vec<Option<Vec<bool>>>, EvalError> {
    let mut reader = TruthReader::new(gt_dir, disk);
    (0..scene.views.len())
        .map(|v| match reader.view(scene, v)? {
            Some(own) => seen_source_by_source(scene, v, &own.depth, &mut reader),
            None => Ok(None),
        })
        .collect()
}

/// Each view's truth and weak-texture mask at its processed size, as [`seen_of`] asks for
/// them: the view scored, then its sources' truths one at a time.
trait TruthSource<'a> {
    /// View `v`'s truth and mask (`None`: it has no truth).
    fn view(
        &mut self,
        scene: &crate::scene::Scene,
        v: usize,
    ) -> Result<Option<ViewTruth<'a>>, EvalError>;
    /// Calls `f` with view `i`'s truth (`None`: it has none), asked for as a source of the
    /// view last given by [`TruthSource::view`].
    fn with_source(
        &mut self,
        scene: &crate::scene::Scene,
        i: usize,
        f: &mut dyn FnMut(Option<&[f32]>),
    ) -> Result<(), EvalError>;
}

/// A view's truth and weak-texture mask at its processed size, borrowed or read.
struct ViewTruth<'a> {
    depth: std::borrow::Cow<'a, [f32]>,
    mask: Option<std::borrow::Cow<'a, [bool]>>,
}

/// Truths and masks already in memory, indexed by view.
struct TruthsInMemory<'a> {
    truths: &'a [Option<Vec<f32>>],
    masks: &'a [Option<Vec<bool>>],
}

impl<'a> TruthSource<'a> for TruthsInMemory<'a> {
    fn view(
        &mut self,
        _: &crate::scene::Scene,
        v: usize,
    ) -> Result<Option<ViewTruth<'a>>, EvalError> {
        let (truths, masks) = (self.truths, self.masks);
        Ok(truths.get(v).and_then(|t| t.as_deref()).map(|t| ViewTruth {
            depth: std::borrow::Cow::Borrowed(t),
            mask: masks
                .get(v)
                .and_then(|m| m.as_deref())
                .map(std::borrow::Cow::Borrowed),
        }))
    }

    fn with_source(
        &mut self,
        _: &crate::scene::Scene,
        i: usize,
        f: &mut dyn FnMut(Option<&[f32]>),
    ) -> Result<(), EvalError> {
        f(self.truths.get(i).and_then(|t| t.as_deref()));
        Ok(())
    }
}

/// The most bytes of sources' truths [`TruthReader`] keeps from one view to the next (256
/// MiB): every source ([`crate::scene::MAX_SOURCES`]) of a 1920x1080 view, five of a 12 Mpx
/// one. A source past it is read each time a view asks for it, so the seen split holds a
/// view's truth and mask, this, and one more source's truth, however many sources a view
/// has.
pub const SOURCE_TRUTHS_KEPT: usize = 256 << 20;

/// Truths read from `gt_dir` (view `v` numbered `disk[v]`) as [`seen_of`] asks for them:
/// the view scored with its mask, read for it alone, and its sources' depths (never their
/// masks), kept for the next view while they are within `budget` bytes and the view scored
/// next has them as sources too. Without the budget a view of 32 sources at 12 Mpx would
/// hold 1.5 GB of their truths.
struct TruthReader<'a> {
    gt_dir: &'a std::path::Path,
    disk: &'a [usize],
    kept: std::collections::HashMap<usize, Option<Vec<f32>>>,
    budget: usize,
}

impl<'a> TruthReader<'a> {
    fn new(gt_dir: &'a std::path::Path, disk: &'a [usize]) -> TruthReader<'a> {
        TruthReader {
            gt_dir,
            disk,
            kept: std::collections::HashMap::new(),
            budget: SOURCE_TRUTHS_KEPT,
        }
    }

    fn kept_bytes(&self) -> usize {
        self.kept
            .values()
            .map(|t| {
                t.as_ref()
                    .map_or(0, |t| std::mem::size_of_val(t.as_slice()))
            })
            .sum()
    }
}

impl<'t> TruthSource<'t> for TruthReader<'_> {
    fn view(
        &mut self,
        scene: &crate::scene::Scene,
        v: usize,
    ) -> Result<Option<ViewTruth<'t>>, EvalError> {
        let Some(view) = scene.views.get(v) else {
            return Ok(None);
        };
        self.kept
            .retain(|k, _| view.sources.iter().any(|s| s.index == *k));
        Ok(
            truth_at_view_size(scene, self.disk, self.gt_dir, v)?.map(|(depth, mask)| ViewTruth {
                depth: std::borrow::Cow::Owned(depth),
                mask: mask.map(std::borrow::Cow::Owned),
            }),
        )
    }

    fn with_source(
        &mut self,
        scene: &crate::scene::Scene,
        i: usize,
        f: &mut dyn FnMut(Option<&[f32]>),
    ) -> Result<(), EvalError> {
        if let Some(t) = self.kept.get(&i) {
            f(t.as_deref());
            return Ok(());
        }
        let t = match (scene.views.get(i), self.disk.get(i)) {
            (Some(view), Some(&d)) => read_truth_depth(self.gt_dir, d)?.map(|t| {
                resample_nearest_owned(
                    t.data,
                    t.width,
                    t.height,
                    view.image.width,
                    view.image.height,
                )
            }),
            _ => None,
        };
        f(t.as_deref());
        let bytes = t
            .as_ref()
            .map_or(0, |t| std::mem::size_of_val(t.as_slice()));
        if self.kept_bytes() + bytes <= self.budget {
            self.kept.insert(i, t);
        }
        Ok(())
    }
}

/// A view's truth and mask at its processed size.
type TruthAtSize = (Vec<f32>, Option<Vec<bool>>);

/// View `v`'s truth and weak-texture mask from `gt_dir` (numbered `disk[v]`), sampled at the
/// view's processed size; `None` where it has none.
fn truth_at_view_size(
    scene: &crate::scene::Scene,
    disk: &[usize],
    gt_dir: &std::path::Path,
    v: usize,
) -> Result<Option<TruthAtSize>, EvalError> {
    let (Some(view), Some(&d)) = (scene.views.get(v), disk.get(v)) else {
        return Ok(None);
    };
    let (w, h) = (view.image.width, view.image.height);
    Ok(read_truth(gt_dir, d)?.map(|t| {
        let (dw, dh) = (t.depth.width, t.depth.height);
        (
            resample_nearest_owned(t.depth.data, dw, dh, w, h),
            t.low_texture
                .map(|m| resample_nearest_owned(m, dw, dh, w, h)),
        )
    }))
}

/// [`evaluate_seen`] of a run's folder: the scene at `scene` loaded with `options` as the
/// run loaded it (its `max_image_size`, format and model; no image is decoded, so only the
/// cameras and sizes are read), the maps `dir/depth/%08d.pfm` of `views` (the views run, as
/// numbered on disk: the whole scene is loaded, so they index it).
pub fn evaluate_seen_dir(
    scene: &std::path::Path,
    options: &crate::scene::LoadOptions,
    dir: &std::path::Path,
    views: &[usize],
    gt_dir: &std::path::Path,
) -> Result<Option<SeenReport>, EvalError> {
    let scene = crate::scene::Scene::load(scene, &options.cameras_only())?;
    let disk: Vec<usize> = (0..scene.views.len()).collect();
    evaluate_seen(&scene, views, &disk, gt_dir, |v| {
        Ok(crate::io::read_pfm(&dir.join(format!("depth/{v:08}.pfm")))?)
    })
}

/// [`evaluate_seen`] with the truth in memory: `truths[view]` and the weak-texture
/// `masks[view]` at each view's processed size.
pub fn seen_of_maps(
    scene: &crate::scene::Scene,
    views: &[usize],
    disk: &[usize],
    truths: &[Option<Vec<f32>>],
    masks: &[Option<Vec<bool>>],
    estimate: impl FnMut(usize) -> Result<crate::io::Map, EvalError>,
) -> Result<Option<SeenReport>, EvalError> {
    seen_of(
        scene,
        views,
        disk,
        &mut TruthsInMemory { truths, masks },
        estimate,
    )
}

/// [`SeenReport`] of `views`, their truths from `truths`, their counts added view by view
/// (per_view numbered as on disk, `disk[view]`).
fn seen_of(
    scene: &crate::scene::Scene,
    views: &[usize],
    disk: &[usize],
    truths: &mut dyn TruthSource<'_>,
    mut estimate: impl FnMut(usize) -> Result<crate::io::Map, EvalError>,
) -> Result<Option<SeenReport>, EvalError> {
    let mut counts = SeenCounts::default();
    let mut per_view = Vec::new();
    for &v in views {
        let Some(truth) = truths.view(scene, v)? else {
            continue;
        };
        let g: &[f32] = &truth.depth;
        let map = estimate(v)?;
        let Some(s) = seen_source_by_source(scene, v, g, truths)?
            .filter(|s| s.len() == map.data.len() && g.len() == s.len())
        else {
            continue;
        };
        let mask = truth.mask.as_deref().filter(|m| m.len() == g.len());
        let with_truth = g.iter().filter(|&&d| d > 0.0 && d.is_finite()).count();
        let n = s.iter().filter(|&&b| b).count();
        per_view.push((
            disk.get(v).copied().unwrap_or(v),
            n as f64 / with_truth.max(1) as f64,
        ));
        counts.add(SeenCounts::of(&map.data, g, &s, mask));
    }
    Ok(counts.score().map(|score| SeenReport { score, per_view }))
}

/// [`SeenReport`] as `mvscope eval` prints it below the table.
pub fn format_seen(report: &SeenReport) -> String {
    let s = &report.score;
    let weak = s.low_texture_within_2.map_or(String::new(), |w| {
        format!(" (weak texture {:.1}%)", 100.0 * w)
    });
    let unseen = s.unseen_within_2.map_or(String::new(), |u| {
        format!(
            "; on the {:.1}% no source sees, {:.1}% (only a prior reaches them)",
            100.0 * (1.0 - s.seen),
            100.0 * u
        )
    });
    let views: Vec<String> = report
        .per_view
        .iter()
        .map(|(v, f)| format!("{v:08} {:.0}%", 100.0 * f))
        .collect();
    format!(
        "seen by a source (the truth projected into the view's sources, not occluded): {:.1}% of the pixels, {:.1}% of them within 2%{weak}{unseen}\n  seen per view: {}\n",
        100.0 * s.seen,
        100.0 * s.within_2,
        views.join(", ")
    )
}

/// The fits as a table, and what they say.
pub fn format_photometric_fits(fits: &[PhotometricFit]) -> String {
    let mut out = String::from(
        "the truth against the images (median grey difference of textured pixels warped into the best source):\n",
    );
    out += &format!(
        "{:>8} {:>8} {:>9} {:>8} {:>9} {:>6}\n",
        "view", "source", "pixels", "truth", "estimate", "ratio"
    );
    for f in fits {
        out += &format!(
            "{:>8} {:>8} {:>9} {:>8.2} {:>9.2} {:>6.2}\n",
            format!("{:08}", f.view),
            format!("{:08}", f.source),
            f.pixels,
            f.truth_residual,
            f.estimate_residual,
            f.ratio()
        );
    }
    let misfit: Vec<String> = fits
        .iter()
        .filter(|f| f.truth_fits_worse())
        .map(|f| format!("{:08}", f.view))
        .collect();
    if misfit.is_empty() {
        out += "the truth fits the images about as well as the estimate (this does not clear the cameras: where no depth fits, as with a wrong focal length, both residuals are high)\n";
    } else {
        out += &format!(
            "the truth fits the images worse than the estimate (by more than {MISFIT_RATIO}x) on view(s) {}: its depths were made with other cameras than the images were, so shares within 1-2% there measure that error as much as the method\n",
            misfit.join(", ")
        );
    }
    out
}

/// The camera offsets found (or that none was), as lines.
pub fn format_camera_offsets(offsets: &[CameraOffset]) -> String {
    if offsets.is_empty() {
        return "no camera offset: moving a camera's principal point by up to 9 px makes no truth fit its source better\n".into();
    }
    offsets
        .iter()
        .map(|o| {
            format!(
                "camera offset: view {:08}'s truth fits source {:08} best with the principal point moved by ({:+}, {:+}) px (median residual {:.2} -> {:.2}): its image and its camera disagree by about that much\n",
                o.view, o.source, o.dx, o.dy, o.residual, o.moved_residual
            )
        })
        .collect()
}

#[cfg(test)]
mod photometric_tests {
    use super::*;
    use crate::synthetic::{SyntheticOptions, generate};

    fn fit_of(s: &crate::synthetic::SyntheticScene, estimate: &[f32]) -> PhotometricFit {
        let source = s.scene.views[0].sources[0].index;
        let seen = Some(s.ground_truth[source].depth.as_slice());
        photometric_fit(&s.scene, 0, &s.ground_truth[0].depth, estimate, seen).expect("a fit")
    }

    fn truths(s: &crate::synthetic::SyntheticScene) -> Vec<Option<Vec<f32>>> {
        s.ground_truth
            .iter()
            .map(|g| Some(g.depth.clone()))
            .collect()
    }

    #[test]
    fn a_point_is_seen_where_a_source_frames_it_and_nothing_nearer_hides_it() {
        let mut s = generate(&SyntheticOptions {
            views: 3,
            width: 96,
            height: 72,
            ..Default::default()
        })
        .expect("synthetic scene");
        let source = s.scene.views[0].sources[0].index;
        s.scene.views[0].sources.truncate(1);
        let mut t = truths(&s);
        let seen = seen_by_sources(&s.scene, 0, &t).expect("view 0 has truth");
        let share = seen.iter().filter(|&&b| b).count() as f64 / seen.len() as f64;
        // The source frames most of the reference but not all of it: its border strip.
        assert!(share > 0.5 && share < 1.0, "seen share {share:.3}");
        // Every seen pixel's point lands inside the source; every pixel landing inside
        // with the source's truth at the same depth is seen.
        let (r, src) = (&s.scene.views[0], &s.scene.views[source]);
        let w = r.image.width as usize;
        for (i, &b) in seen.iter().enumerate() {
            let d = s.ground_truth[0].depth[i] as f64;
            let world = r
                .camera
                .unproject(glam::DVec2::new((i % w) as f64, (i / w) as f64), d);
            let (q, z) = src.camera.project(world).expect("in front");
            let (u, v) = (q.x.round(), q.y.round());
            let inside =
                u >= 0.0 && v >= 0.0 && u < src.image.width as f64 && v < src.image.height as f64;
            assert!(!b || inside, "pixel {i} seen outside the source");
            if inside {
                let there = s.ground_truth[source].depth
                    [v as usize * src.image.width as usize + u as usize]
                    as f64;
                if (there - z).abs() < 0.005 * z {
                    assert!(b, "pixel {i} lands on its own surface but is not seen");
                }
            }
        }
        // An occluder in front of the whole source hides every point.
        t[source] = Some(
            s.ground_truth[source]
                .depth
                .iter()
                .map(|d| 0.5 * d)
                .collect(),
        );
        let hidden = seen_by_sources(&s.scene, 0, &t).expect("truth");
        assert!(hidden.iter().all(|&b| !b), "an occluder hides nothing");
        // A source without truth hides nothing: seen is then the frame alone, at least as
        // much as with the truth.
        t[source] = None;
        let framed = seen_by_sources(&s.scene, 0, &t).expect("truth");
        assert!(seen.iter().zip(&framed).all(|(a, b)| !a || *b));
        // A source turned away sees nothing.
        let cam = &mut s.scene.views[source].camera;
        let turn = glam::DMat3::from_rotation_y(std::f64::consts::PI);
        (cam.rotation, cam.translation) = (turn * cam.rotation, turn * cam.translation);
        let away = seen_by_sources(&s.scene, 0, &t).expect("truth");
        assert!(away.iter().all(|&b| !b), "a camera facing away sees points");
        // Truth of another size than the view's: nothing to say.
        t[0] = Some(vec![1.0; 10]);
        assert!(seen_by_sources(&s.scene, 0, &t).is_none());
    }

    #[test]
    fn the_seen_split_read_from_disk_is_the_split_of_the_truths_in_memory() {
        // Five views, three of them scored: the truth read as each view and its sources
        // need it gives the report of every truth held at once, numbered as on disk.
        let s = generate(&SyntheticOptions {
            views: 5,
            width: 64,
            height: 48,
            ..Default::default()
        })
        .expect("synthetic scene");
        let dir = tempfile::tempdir().expect("temp dir");
        crate::synthetic::write_demo(&s, dir.path()).expect("demo written");
        let estimate = |v: usize| {
            let g = &s.ground_truth[v];
            let d = g
                .depth
                .iter()
                .enumerate()
                .map(|(i, &d)| d * [1.0, 1.01, 1.03, 0.985][(i + v) % 4])
                .collect();
            Ok(crate::io::Map::from_data(g.width, g.height, 1, d).expect("map"))
        };
        let views = [4, 1, 2];
        let disk: Vec<usize> = (0..5).map(|v| v + 10).collect();
        // On disk the views are numbered 0-4; `disk` renumbers only what the report says.
        let on_disk: Vec<usize> = (0..5).collect();
        let read = evaluate_seen(&s.scene, &views, &on_disk, dir.path(), estimate)
            .expect("scored")
            .expect("truth");
        let masks: Vec<Option<Vec<bool>>> = s
            .ground_truth
            .iter()
            .map(|g| Some(g.low_texture.clone()))
            .collect();
        let held = seen_of_maps(&s.scene, &views, &disk, &truths(&s), &masks, estimate)
            .expect("scored")
            .expect("truth");
        assert_eq!(read.score, held.score);
        assert!(read.score.low_texture_within_2.is_some());
        let numbers = |r: &SeenReport| r.per_view.iter().map(|p| p.0).collect::<Vec<_>>();
        assert_eq!(numbers(&read), vec![4, 1, 2]);
        assert_eq!(numbers(&held), vec![14, 11, 12]);
        for (a, b) in read.per_view.iter().zip(&held.per_view) {
            assert_eq!(a.1, b.1);
        }
        // The reader keeps sources' truths only while the view scored has them as
        // sources, and only within its budget; the split does not depend on what it kept.
        let one = 64 * 48 * std::mem::size_of::<f32>();
        for budget in [SOURCE_TRUTHS_KEPT, 2 * one, one - 1, 0] {
            let mut reader = TruthReader::new(dir.path(), &on_disk);
            reader.budget = budget;
            for v in [0, 3, 1, 2] {
                let own = reader.view(&s.scene, v).expect("read").expect("truth");
                let seen =
                    seen_source_by_source(&s.scene, v, &own.depth, &mut reader).expect("read");
                assert_eq!(seen, seen_by_sources(&s.scene, v, &truths(&s)), "view {v}");
                let sources: Vec<usize> =
                    s.scene.views[v].sources.iter().map(|x| x.index).collect();
                assert!(reader.kept.keys().all(|k| sources.contains(k)), "view {v}");
                assert_eq!(
                    reader.kept.len(),
                    sources.len().min(budget / one),
                    "view {v}"
                );
                assert!(reader.kept_bytes() <= budget);
            }
        }
        // And the masks the Python package asks for are the in-memory ones.
        let from_disk = seen_masks(&s.scene, &on_disk, dir.path()).expect("masks");
        for (v, m) in from_disk.iter().enumerate() {
            assert_eq!(m, &seen_by_sources(&s.scene, v, &truths(&s)), "view {v}");
        }
    }

    #[test]
    fn seen_scores_split_the_pixels_by_what_the_sources_see() {
        // Six pixels with truth (one without): seen 0-3, unseen 4-5.
        let truth = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0];
        let est = [1.01, 1.5, 1.0, 0.0, 1.0, 2.0, 1.0];
        let seen = [true, true, true, true, false, false, true];
        let weak = [true, true, false, false, true, true, true];
        let s = seen_score(&est, &truth, &seen, Some(&weak)).expect("pixels");
        assert!((s.seen - 4.0 / 6.0).abs() < 1e-12, "{s:?}");
        assert!((s.within_2 - 0.5).abs() < 1e-12, "{s:?}");
        assert_eq!(s.low_texture_within_2, Some(0.5));
        assert_eq!(s.unseen_within_2, Some(0.5));
        let all = seen_score(&est, &truth, &[true; 7], None).expect("pixels");
        assert_eq!(
            (all.unseen_within_2, all.low_texture_within_2),
            (None, None)
        );
        assert!(seen_score(&est, &[0.0; 7], &seen, None).is_none());
    }

    #[test]
    fn a_median_is_the_middle_of_the_sorted_values() {
        let mut rng = crate::rng::Stream::new(&[7]);
        for n in [1, 2, 3, 6, 101, 1000] {
            let v: Vec<f32> = (0..n)
                .map(|i| match i % 7 {
                    0 => -0.0,
                    1 => 0.0,
                    2 => 5.0,
                    _ => rng.next_f32() * 10.0 - 2.0,
                })
                .collect();
            let mut sorted = v.clone();
            sorted.sort_by(f32::total_cmp);
            assert_eq!(
                median(v).to_bits(),
                (sorted[n / 2] as f64).to_bits(),
                "n {n}"
            );
        }
        assert!(median(Vec::new()).is_nan());
    }

    #[test]
    fn the_truth_fits_its_own_images_and_a_moved_camera_shows() {
        let mut s = generate(&SyntheticOptions {
            views: 3,
            width: 128,
            height: 96,
            ..Default::default()
        })
        .expect("synthetic scene");
        let truth = s.ground_truth[0].depth.clone();
        // Exact cameras: the truth explains the images, a depth 5% off does not.
        let exact = fit_of(&s, &truth);
        assert_eq!(exact.truth_residual, exact.estimate_residual);
        let far: Vec<f32> = truth.iter().map(|d| d * 1.05).collect();
        let off = fit_of(&s, &far);
        assert!(off.estimate_residual > 1.5 * off.truth_residual, "{off:?}");
        assert!(format_photometric_fits(&[off]).contains("about as well"));
        // The source's camera moved by 3 px (as if calibrated apart from its image): the
        // truth no longer fits, and the report names the view.
        let source = exact.source;
        s.scene.views[source].camera.intrinsics.cx += 3.0;
        let moved = fit_of(&s, &far);
        assert!(
            moved.truth_residual > MISFIT_RATIO * exact.truth_residual,
            "{moved:?} vs {exact:?}"
        );
        // The estimate-free test: the unmoved reference camera is best; the reference's
        // principal point moved 3 px from where its image was rendered is found again.
        let seen = Some(s.ground_truth[source].depth.as_slice());
        s.scene.views[source].camera.intrinsics.cx -= 3.0;
        assert_eq!(camera_offset(&s.scene, 0, &truth, seen), None);
        assert!(format_camera_offsets(&[]).contains("no camera offset"));
        s.scene.views[0].camera.intrinsics.cx += 3.0;
        let found = camera_offset(&s.scene, 0, &truth, seen).expect("an offset");
        assert_eq!((found.dx, found.dy), (-3.0, 0.0), "{found:?}");
        // The check warps the truth alone, over the pixels a fit with an estimate uses: the
        // count and residual of the truth fitted beside itself.
        let r = &s.scene.views[0];
        let pixels = textured_pixels(&r.image, None).expect("grey levels");
        assert!(!pixels.is_empty() && pixels.len() < truth.len());
        let fit = |e| photometric_fit_with(&s.scene, 0, &r.camera, &truth, e, &pixels);
        let (alone, paired) = (fit(None).expect("a fit"), fit(Some(&truth)).expect("a fit"));
        assert_eq!(
            (alone.pixels, alone.truth_residual, alone.estimate_residual),
            (paired.pixels, paired.truth_residual, None)
        );
        assert_eq!(paired.estimate_residual, Some(paired.truth_residual));
        assert!(format_camera_offsets(&[found]).contains("view 00000000's truth"));
        let text = format_photometric_fits(&[PhotometricFit {
            estimate_residual: exact.truth_residual,
            ..moved.clone()
        }]);
        assert!(
            text.contains("worse than the estimate") && text.contains("00000000"),
            "{text}"
        );
        // Every view measured against its source: only view 0's camera is off, and the
        // joint correction says so (the sources' measurements tie them to each other).
        let pairs: Vec<CameraOffset> = (0..3)
            .filter_map(|v| {
                let src = s.scene.views[v].sources.first()?.index;
                measure_camera_offset(
                    &s.scene,
                    v,
                    &s.ground_truth[v].depth,
                    Some(s.ground_truth[src].depth.as_slice()),
                )
            })
            .collect();
        assert_eq!(pairs.len(), 3, "{pairs:?}");
        let (fixes, missed) = principal_point_corrections(&pairs);
        let of = |v: usize| fixes.iter().find(|f| f.view == v).map(|f| (f.dx, f.dy));
        assert_eq!(of(0), Some((-3.0, 0.0)), "{fixes:?} {pairs:?}");
        assert!(
            fixes
                .iter()
                .filter(|f| f.view != 0)
                .all(|f| (f.dx, f.dy) == (0.0, 0.0))
        );
        assert!(missed <= 1.0, "{missed}");
        assert!(
            format_principal_point_corrections(&fixes, missed)
                .contains("view 00000000 by (-3.0, +0.0) px")
        );
    }

    fn pair(view: usize, source: usize, d: (f64, f64), offset: bool) -> CameraOffset {
        CameraOffset {
            view,
            source,
            dx: d.0,
            dy: d.1,
            residual: 10.0,
            moved_residual: if offset { 4.0 } else { 9.0 },
        }
    }

    #[test]
    fn one_principal_point_error_per_view_explains_the_pairs() {
        // ICL's pattern: five views, each measured against its best source, d = c_v - c_s.
        let c = [(0.0, 0.0), (-6.5, 1.0), (0.0, 5.0), (-5.5, 3.0), (4.0, 2.0)];
        let d = |v: usize, s: usize| (c[v].0 - c[s].0, c[v].1 - c[s].1);
        let pairs =
            [(0, 3), (3, 0), (1, 3), (2, 0), (4, 0)].map(|(v, s)| pair(v, s, d(v, s), true));
        let (fixes, missed) = principal_point_corrections(&pairs);
        assert!(missed < 1e-6, "{missed}");
        // Pairs fix differences only; the median per axis is moved to zero: x's median is
        // 0, y's is 2.
        let want: Vec<(f64, f64)> = c.iter().map(|&(x, y)| (x, y - 2.0)).collect();
        let got: Vec<(f64, f64)> = fixes.iter().map(|f| (f.dx, f.dy)).collect();
        assert_eq!(got, want);
        assert_eq!(
            fixes.iter().map(|f| f.view).collect::<Vec<_>>(),
            vec![0, 1, 2, 3, 4]
        );
        // A pair whose unmoved camera fits as well counts as no shift, whatever the search's
        // best: no view is off, nothing to say.
        let calm = [
            pair(0, 1, (1.0, 0.0), false),
            pair(1, 0, (-1.0, 0.0), false),
        ];
        let (fixes, missed) = principal_point_corrections(&calm);
        assert!(fixes.iter().all(|f| (f.dx, f.dy) == (0.0, 0.0)) && missed == 0.0);
        assert_eq!(format_principal_point_corrections(&fixes, missed), "");
        // A long chain (each view measured against the next), where averaging sweeps would
        // crawl: solved exactly.
        let truth: Vec<(f64, f64)> = (0..300)
            .map(|i| ((i as f64 * 0.7).sin() * 5.0, (i as f64 * 0.3).cos() * 3.0))
            .collect();
        let chain: Vec<CameraOffset> = (0..299)
            .map(|i| {
                let d = (truth[i].0 - truth[i + 1].0, truth[i].1 - truth[i + 1].1);
                pair(i, i + 1, d, true)
            })
            .collect();
        let (fixes, missed) = principal_point_corrections(&chain);
        assert!(missed < 0.11, "{missed}");
        let med = |k: usize| {
            let mut v: Vec<f64> = truth
                .iter()
                .map(|t| if k == 0 { t.0 } else { t.1 })
                .collect();
            v.sort_by(f64::total_cmp);
            v[150]
        };
        for f in &fixes {
            let t = truth[f.view];
            assert!((f.dx - (t.0 - med(0))).abs() <= 0.051, "{f:?}");
            assert!((f.dy - (t.1 - med(1))).abs() <= 0.051, "{f:?}");
        }
        // Pairs one error per view cannot explain show as a large miss.
        let odd = [pair(0, 1, (4.0, 0.0), true), pair(1, 0, (4.0, 0.0), true)];
        assert!(principal_point_corrections(&odd).1 >= 3.9);
    }
}
