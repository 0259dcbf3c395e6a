//! Depth ranges and source views from camera geometry alone, for formats that carry neither
//! (Middlebury, Strecha) and for the synthetic scenes.

use glam::{DVec2, DVec3};

use super::{DepthRange, SourceView};
use crate::camera::Camera;

/// How many sources to keep per view (the ACMM authors' converter keeps min(20, N-1)).
pub const DEFAULT_SOURCES: usize = 20;

/// Triangulation-angle preference of a source view (MVSNet's view-selection score):
/// `exp(-(θ-θ0)²/(2σ²))` with θ0 = 5°, σ = 1° below θ0 and 10° above. Near-zero angles (the
/// same pose, as templeSparseRing's views 0 and 10) score almost nothing.
pub fn angle_score(theta_deg: f64) -> f64 {
    const THETA0: f64 = 5.0;
    let sigma = if theta_deg <= THETA0 { 1.0 } else { 10.0 };
    (-(theta_deg - THETA0).powi(2) / (2.0 * sigma * sigma)).exp()
}

/// Per view, a depth range estimated from where the principal axes of the cameras meet.
///
/// For each other camera, the closest approach of the two principal rays gives a depth on this
/// view's axis (pairs closer than 1° to parallel or meeting behind either camera are skipped);
/// the median `d` of these depths gives `[d / 2, 2 d]`. Inward-looking rigs (Middlebury rings,
/// Strecha façades) converge on the object; a rig with parallel axes gives `None`.
pub fn depth_ranges_from_geometry(cameras: &[Camera]) -> Vec<Option<DepthRange>> {
    cameras
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let (ca, da) = (a.center(), a.forward());
            let mut depths: Vec<f64> = cameras
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .filter_map(|(_, b)| {
                    let (cb, db) = (b.center(), b.forward());
                    let cross = da.cross(db);
                    if cross.length() < 1.0f64.to_radians().sin() {
                        return None;
                    }
                    // Closest points ca + s da and cb + u db of the two lines.
                    let w = ca - cb;
                    let (a11, a12, a22) = (da.dot(da), da.dot(db), db.dot(db));
                    let (b1, b2) = (da.dot(w), db.dot(w));
                    let det = a11 * a22 - a12 * a12;
                    let s = (a12 * b2 - a22 * b1) / det;
                    let u = (a11 * b2 - a12 * b1) / det;
                    (s > 0.0 && u > 0.0).then_some(s)
                })
                .collect();
            if depths.is_empty() {
                return None;
            }
            depths.sort_by(f64::total_cmp);
            let d = depths[depths.len() / 2];
            DepthRange::new(d * 0.5, d * 2.0).ok()
        })
        .collect()
}

/// Per view, its best `max_sources` source views by summed triangulation-angle score over
/// sample points: a 16x12 grid of the view's pixels at three depths of its range, counted for a
/// source where the point is in front of it and inside its image.
pub fn sources_from_geometry(
    cameras: &[Camera],
    ranges: &[DepthRange],
    max_sources: usize,
) -> Vec<Vec<SourceView>> {
    cameras
        .iter()
        .zip(ranges)
        .enumerate()
        .map(|(i, (reference, range))| {
            let mut points = Vec::new();
            for depth_t in [0.25, 0.5, 0.75] {
                let depth = range.min + (range.max - range.min) * depth_t;
                for gy in 0..12 {
                    for gx in 0..16 {
                        let pixel = DVec2::new(
                            (gx as f64 + 0.5) / 16.0 * reference.width as f64 - 0.5,
                            (gy as f64 + 0.5) / 12.0 * reference.height as f64 - 0.5,
                        );
                        points.push(reference.unproject(pixel, depth));
                    }
                }
            }
            let c_ref = reference.center();
            let mut scored: Vec<SourceView> = cameras
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(j, source)| {
                    let c_src = source.center();
                    let score: f64 = points
                        .iter()
                        .filter(|p| {
                            source
                                .project(**p)
                                .is_some_and(|(pixel, _)| source.contains(pixel))
                        })
                        .map(|p| {
                            let a: DVec3 = (c_ref - *p).normalize();
                            let b: DVec3 = (c_src - *p).normalize();
                            angle_score(a.dot(b).clamp(-1.0, 1.0).acos().to_degrees())
                        })
                        .sum();
                    SourceView {
                        index: j,
                        score: score / points.len() as f64,
                    }
                })
                .filter(|s| s.score > 1e-4)
                .collect();
            scored.sort_by(|a, b| b.score.total_cmp(&a.score));
            scored.truncate(max_sources);
            scored
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Intrinsics;

    fn ring(n: usize, radius: f64) -> Vec<Camera> {
        let k = Intrinsics {
            fx: 200.0,
            fy: 200.0,
            cx: 79.5,
            cy: 59.5,
        };
        (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * std::f64::consts::TAU;
                Camera::look_at(
                    k,
                    160,
                    120,
                    DVec3::new(radius * a.cos(), -0.3, radius * a.sin()),
                    DVec3::ZERO,
                    DVec3::new(0.0, -1.0, 0.0),
                )
            })
            .collect()
    }

    #[test]
    fn ring_depth_range_contains_the_centre() {
        let cams = ring(8, 2.0);
        for (cam, range) in cams.iter().zip(depth_ranges_from_geometry(&cams)) {
            let range = range.expect("a ring converges");
            let (_, depth) = cam.project(DVec3::ZERO).expect("centre is visible");
            assert!(
                range.min < depth && depth < range.max,
                "{range:?} vs {depth}"
            );
            assert!(range.min > 0.5 && range.max < 8.0, "{range:?}");
        }
    }

    #[test]
    fn parallel_cameras_give_no_range() {
        let k = Intrinsics {
            fx: 100.0,
            fy: 100.0,
            cx: 50.0,
            cy: 50.0,
        };
        let cams: Vec<Camera> = (0..3)
            .map(|i| {
                let eye = DVec3::new(i as f64, 0.0, 0.0);
                Camera::look_at(k, 100, 100, eye, eye + DVec3::Z, DVec3::new(0.0, -1.0, 0.0))
            })
            .collect();
        assert!(
            depth_ranges_from_geometry(&cams)
                .iter()
                .all(Option::is_none)
        );
    }

    #[test]
    fn neighbours_beat_opposite_and_identical_views() {
        let mut cams = ring(24, 2.0); // neighbours 15 degrees apart
        cams.push(cams[0]); // same pose as view 0
        let ranges = vec![DepthRange::new(1.0, 3.0).unwrap(); cams.len()];
        let sources = sources_from_geometry(&cams, &ranges, 4);
        let best: Vec<usize> = sources[0].iter().map(|s| s.index).collect();
        assert!(
            best[..2].contains(&1) && best[..2].contains(&23),
            "{best:?}"
        );
        assert!(
            !best.contains(&24),
            "identical pose must not be a good source: {best:?}"
        );
        assert!(
            !best.contains(&12),
            "the opposite camera sees nothing in common: {best:?}"
        );
        assert_eq!(sources[0].len(), 4);
    }
}
