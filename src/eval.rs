//! Evaluation against ground truth: the share of ground-truth pixels whose estimate is within
//! a threshold, a missing estimate counting as a miss.

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
