//! Scripted runs (the web page's `?steps=` links, its test): a goal the app pursues frame
//! by frame, and the JSON report it prints when done.

use super::*;

/// A scripted run (the web page's `?steps=N&map=NAME`): run the open scene `steps` steps
/// (all of them at most), show `map`, and once everything has arrived score every view
/// against the ground truth and report it.
#[derive(Debug)]
pub struct Goal {
    pub steps: usize,
    pub map: Option<MapKind>,
    pub(super) started: Option<Instant>,
    /// Frames seen with nothing left to do (a few, so that the last maps are drawn).
    pub(super) idle_frames: u32,
    /// The maps to score, on their way.
    pub(super) scoring: Option<Vec<crate::session::Pending<Option<crate::session::PlanesCosts>>>>,
    /// The report once made (JSON: steps, seconds, and the shares within 1% and 2% of every
    /// view and pooled, as `mvscope eval` names them).
    pub report: Option<String>,
}

impl Goal {
    pub fn new(steps: usize, map: Option<MapKind>) -> Goal {
        Goal {
            steps,
            map,
            started: None,
            idle_frames: 0,
            scoring: None,
            report: None,
        }
    }

    pub fn is_done(&self) -> bool {
        self.report.is_some()
    }
}

/// The JSON a scripted run reports: steps run, seconds, and for each view with ground
/// truth and pooled, the shares of its pixels within 1% and 2% (as `mvscope eval` scores
/// them, the truth sampled at each map's size).
///
/// With `pane`, where the first map pane and its map were drawn (points) and the map's size:
/// a screenshot test checks the framing against the pixels.
pub(super) fn goal_report(
    model: &Model,
    maps: &[Option<crate::session::PlanesCosts>],
    steps: usize,
    seconds: f64,
    pane: Option<(Rect, Rect, (u32, u32))>,
) -> String {
    use crate::eval::depth_accuracy_relative as rel;
    let (mut all_d, mut all_t) = (Vec::new(), Vec::new());
    let mut views = Vec::new();
    for (v, m) in maps.iter().enumerate() {
        let Some(m) = m else { continue };
        let Some(gt) = model
            .loaded
            .as_ref()
            .and_then(|l| l.ground_truth.get(v)?.as_ref())
        else {
            continue;
        };
        let d: Vec<f32> = m.plane.iter().map(|p| p[3]).collect();
        let t = gt.resampled(m.width, m.height);
        views.push(serde_json::json!({
            "view": v,
            "size": [m.width, m.height],
            "within_1": rel(&d, &t, None, 0.01).within,
            "within_2": rel(&d, &t, None, 0.02).within,
        }));
        all_d.extend(d);
        all_t.extend(t);
    }
    serde_json::json!({
        "method": model.method.to_string(),
        "adapter": model.ctx.describe(),
        "steps": steps,
        "seconds": seconds,
        "views": views,
        "within_1": rel(&all_d, &all_t, None, 0.01).within,
        "within_2": rel(&all_d, &all_t, None, 0.02).within,
        "pane": pane.map(|(r, i, size)| serde_json::json!({
            "rect": [r.min.x, r.min.y, r.max.x, r.max.y],
            "image": [i.min.x, i.min.y, i.max.x, i.max.y],
            "map": [size.0, size.1],
        })),
    })
    .to_string()
}
