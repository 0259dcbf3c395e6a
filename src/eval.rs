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
    let mut pixels = 0usize;
    let mut hits = 0usize;
    let mut errors = Vec::new();
    for (i, (&d, &g)) in estimate.iter().zip(ground_truth).enumerate() {
        if g <= 0.0 || !g.is_finite() || mask.is_some_and(|m| !m[i]) {
            continue;
        }
        pixels += 1;
        if d > 0.0 && d.is_finite() {
            let err = (d as f64 - g as f64).abs();
            errors.push(err / g as f64);
            if err <= threshold(g as f64) {
                hits += 1;
            }
        }
    }
    errors.sort_by(f64::total_cmp);
    DepthAccuracy {
        pixels,
        within: if pixels == 0 {
            0.0
        } else {
            hits as f64 / pixels as f64
        },
        median_relative_error: errors.get(errors.len() / 2).copied().unwrap_or(f64::NAN),
    }
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

fn score(
    view: usize,
    est: &[f32],
    gt: &[f32],
    mask: Option<&[bool]>,
    abs: &[f64],
    rel: &[f64],
) -> ViewDepthEval {
    let a: Shares = abs
        .iter()
        .map(|&t| (t, depth_accuracy_absolute(est, gt, None, t).within))
        .collect();
    let r: Shares = rel
        .iter()
        .map(|&t| (t, depth_accuracy_relative(est, gt, None, t).within))
        .collect();
    let low = mask.map(|m| {
        rel.iter()
            .map(|&t| (t, depth_accuracy_relative(est, gt, Some(m), t).within))
            .collect()
    });
    let base = depth_accuracy_relative(est, gt, None, 0.01);
    ViewDepthEval {
        view,
        pixels: base.pixels,
        absolute: a,
        relative: r,
        low_texture: low,
        median_relative_error: base.median_relative_error,
    }
}

/// A view's ground truth as `mvscope demo` and the shared scenes store it: depth in
/// `gt/%08d.pfm`, and where present the weak-texture mask `gt/%08d_lowtex.png` (8-bit, 255 on
/// weak texture) at the depth's size.
pub struct TruthFiles {
    pub depth: crate::io::Map,
    pub low_texture: Option<Vec<bool>>,
}

/// View `v`'s ground truth under `gt_dir` (`None` where it has none).
pub fn read_truth(gt_dir: &std::path::Path, v: usize) -> Result<Option<TruthFiles>, EvalError> {
    let path = gt_dir.join(format!("gt/{v:08}.pfm"));
    if !path.is_file() {
        return Ok(None);
    }
    let depth = crate::io::read_pfm(&path)?;
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
/// `estimate(v)` gives view `v`'s depth map, asked for only where `v` has ground truth.
pub fn evaluate_depths(
    views: &[usize],
    gt_dir: &std::path::Path,
    abs: &[f64],
    rel: &[f64],
    mut estimate: impl FnMut(usize) -> Result<crate::io::Map, EvalError>,
) -> Result<DepthReport, EvalError> {
    let mut per_view = Vec::new();
    let (mut all_est, mut all_gt, mut all_mask) = (Vec::new(), Vec::new(), Vec::new());
    let mut any_mask = false;
    for &v in views {
        let Some(truth) = read_truth(gt_dir, v)? else {
            continue;
        };
        let est = estimate(v)?;
        let gt = truth.depth;
        let (w, h) = (est.width, est.height);
        let g = resample_nearest(&gt.data, gt.width, gt.height, w, h);
        let mask = truth
            .low_texture
            .map(|m| resample_nearest(&m, gt.width, gt.height, w, h));
        any_mask |= mask.is_some();
        per_view.push(score(v, &est.data, &g, mask.as_deref(), abs, rel));
        all_mask.extend(mask.unwrap_or_else(|| vec![false; g.len()]));
        all_est.extend(est.data);
        all_gt.extend(g);
    }
    if per_view.is_empty() {
        return Err(EvalError::Missing(format!(
            "no ground truth for these views: expected {}/gt/%08d.pfm (as `mvscope demo` writes)",
            gt_dir.display()
        )));
    }
    let overall = score(
        usize::MAX,
        &all_est,
        &all_gt,
        any_mask.then_some(all_mask.as_slice()),
        abs,
        rel,
    );
    Ok(DepthReport {
        views: per_view,
        overall,
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
        s + "\n"
    };
    for v in &report.views {
        out += &row(format!("{:08}", v.view), v);
    }
    out += &row("all".into(), &report.overall);
    out
}
