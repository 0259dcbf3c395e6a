//! The Compare tab: ACMH, ACMM and DWTA side by side on one view, large, with linked zoom
//! and hover, one legend, error maps against ground truth, the accuracy table `mvscope eval`
//! would print, and a one-line summary in the paper's terms.

use egui::{Color32, Sense, Vec2};

use super::frame::{MapFrame, map_view};
use super::maps::Colormap;
use super::model::{Comparison, DepthMap, Score};
use crate::acmm::params::Method;

/// What the compared panes show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompareMode {
    /// Depth, all methods in one colour range (the view's depth range).
    Depth,
    /// |d − gt| / gt against ground truth, 0 to [`ERROR_SCALE`].
    Error,
}

/// The relative error at the top of the error colour ramp (5%).
pub const ERROR_SCALE: f32 = 0.05;
/// Colour of pixels without an estimate.
const NO_ESTIMATE: [u8; 3] = [60, 60, 60];
/// Colour of pixels without ground truth (error mode).
const NO_TRUTH: [u8; 3] = [10, 10, 10];

/// The colour of one pixel of a compared map.
pub fn pixel_color(
    mode: CompareMode,
    depth: f32,
    truth: Option<f32>,
    range: (f32, f32),
) -> [u8; 3] {
    if !(depth > 0.0 && depth.is_finite()) {
        return NO_ESTIMATE;
    }
    match mode {
        CompareMode::Depth => {
            let span = range.1 - range.0;
            let t = if span > 0.0 {
                (depth - range.0) / span
            } else {
                0.0
            };
            Colormap::Turbo.color(t.clamp(0.0, 1.0))
        }
        CompareMode::Error => match truth {
            Some(g) if g > 0.0 && g.is_finite() => {
                let e = (depth - g).abs() / g;
                Colormap::Viridis.color((e / ERROR_SCALE).clamp(0.0, 1.0))
            }
            _ => NO_TRUTH,
        },
    }
}

/// The RGBA image of a compared map.
pub fn map_image(
    mode: CompareMode,
    map: &DepthMap,
    truth: Option<&[f32]>,
    range: (f32, f32),
) -> egui::ColorImage {
    let rgba: Vec<u8> = map
        .depth
        .iter()
        .enumerate()
        .flat_map(|(i, &d)| {
            let [r, g, b] = pixel_color(mode, d, truth.and_then(|t| t.get(i).copied()), range);
            [r, g, b, 255]
        })
        .collect();
    egui::ColorImage::from_rgba_unmultiplied([map.width as usize, map.height as usize], &rgba)
}

/// A share as the table prints it ("87.3"), "-" where not known.
fn pct(x: Option<f64>) -> String {
    x.map_or("-".into(), |v| format!("{:.1}", v * 100.0))
}

/// The difference in the paper's terms, from the pooled scores of all views: what ACMM's
/// multi-scale geometric consistency adds to ACMH (most of all in weak texture), what
/// ACMH's adaptive checkerboard sampling and multi-hypothesis view selection add to DWTA,
/// and what the planar prior adds to ACMM (ACMMP).
pub fn summary(scores: &[(Method, Option<Score>)]) -> String {
    let get = |m: Method| scores.iter().find(|s| s.0 == m).and_then(|s| s.1);
    let points = |a: f64, b: f64| {
        let d = (a - b) * 100.0;
        format!("{}{d:.1} points", if d >= 0.0 { "+" } else { "" })
    };
    let mut parts = Vec::new();
    if let (Some(m), Some(h)) = (get(Method::Acmm), get(Method::Acmh)) {
        let weak = match (m.weak2, h.weak2) {
            (Some(a), Some(b)) => format!(", {} on weak texture", points(a, b)),
            _ => String::new(),
        };
        parts.push(format!(
            "ACMM vs ACMH: {} within 2%{weak} (multi-scale geometric consistency, Sec. 5: the \
             paper expects the gain in weakly textured areas)",
            points(m.within2, h.within2)
        ));
    }
    if let (Some(h), Some(d)) = (get(Method::Acmh), get(Method::Dwta)) {
        parts.push(format!(
            "ACMH vs DWTA: {} within 2% (adaptive checkerboard sampling and multi-hypothesis \
             view selection, Sec. 4)",
            points(h.within2, d.within2)
        ));
    }
    if let (Some(p), Some(m)) = (get(Method::Acmmp), get(Method::Acmm)) {
        let weak = match (p.weak2, m.weak2) {
            (Some(a), Some(b)) => format!(", {} on weak texture", points(a, b)),
            _ => String::new(),
        };
        parts.push(format!(
            "ACMMP vs ACMM: {} within 2%{weak} (the planar prior: triangulated credible \
             points carry planes into textureless areas)",
            points(p.within2, m.within2)
        ));
    }
    if parts.is_empty() {
        "No ground truth for this scene: compare the maps by eye.".into()
    } else {
        parts.join(". ")
    }
}

/// The text under the cursor: every method's depth and error at pixel (`x`, `y`).
pub fn hover_text(
    x: u32,
    y: u32,
    maps: &[(Method, Option<&DepthMap>)],
    truth: Option<&[f32]>,
) -> String {
    let mut parts = vec![format!("({x}, {y})")];
    let mut truth_value = None;
    for (method, map) in maps {
        let Some(m) = map else { continue };
        if x >= m.width || y >= m.height {
            continue;
        }
        let i = (y * m.width + x) as usize;
        let d = m.depth[i];
        let g = truth.and_then(|t| t.get(i).copied()).filter(|g| *g > 0.0);
        truth_value = truth_value.or(g);
        let text = if d > 0.0 && d.is_finite() {
            match g {
                Some(g) => format!("{method} {d:.4} ({:+.2}%)", (d - g) / g * 100.0),
                None => format!("{method} {d:.4}"),
            }
        } else {
            format!("{method} no estimate")
        };
        parts.push(text);
    }
    if let Some(g) = truth_value {
        parts.push(format!("truth {g:.4}"));
    }
    parts.join(" · ")
}

/// The tab's own state: framing shared by the panes (linked), mode, textures.
pub struct CompareView {
    pub mode: CompareMode,
    pub frame: MapFrame,
    /// Textures by method, and the key they were made for.
    textures: Vec<(Method, egui::TextureHandle)>,
    key: Option<(u64, usize, CompareMode)>,
    /// Hover readout (tests read it).
    pub hover: Option<String>,
}

impl Default for CompareView {
    fn default() -> Self {
        CompareView {
            mode: CompareMode::Depth,
            frame: MapFrame::default(),
            textures: Vec::new(),
            key: None,
            hover: None,
        }
    }
}

/// Everything the tab shows of a finished comparison.
pub struct Shown<'a> {
    pub cmp: &'a Comparison,
    pub view: usize,
    pub maps: Vec<(Method, Option<&'a DepthMap>)>,
    pub truth: Option<Vec<f32>>,
    pub range: (f32, f32),
    pub version: u64,
}

impl CompareView {
    /// Draws the finished comparison: summary, table, mode, the panes and the legend.
    pub fn ui(&mut self, ui: &mut egui::Ui, shown: &Shown<'_>) {
        let cmp = shown.cmp;
        let pooled: Vec<(Method, Option<Score>)> =
            cmp.runs.iter().map(|r| (r.method, r.overall)).collect();
        ui.label(egui::RichText::new(summary(&pooled)).strong());
        ui.add_space(4.0);
        egui::Grid::new("compare-table")
            .striped(true)
            .num_columns(10)
            .show(ui, |ui| {
                ui.strong("method");
                ui.strong("stopped at");
                for h in [
                    format!("view {} <1%", shown.view),
                    "<2%".into(),
                    "weak <1%".into(),
                    "weak <2%".into(),
                    "all views <1%".into(),
                    "<2%".into(),
                    "weak <1%".into(),
                    "weak <2%".into(),
                ] {
                    ui.strong(h);
                }
                ui.end_row();
                for r in &cmp.runs {
                    ui.label(r.method.to_string());
                    let note = if r.matched { "" } else { " (its end)" };
                    ui.label(format!(
                        "{}{note}",
                        r.stopped.clone().unwrap_or_else(|| "-".into())
                    ));
                    let view = r.scores.get(shown.view).copied().flatten();
                    for s in [view, r.overall] {
                        ui.label(pct(s.map(|s| s.within1)));
                        ui.label(pct(s.map(|s| s.within2)));
                        ui.label(pct(s.and_then(|s| s.weak1)));
                        ui.label(pct(s.and_then(|s| s.weak2)));
                    }
                    ui.end_row();
                }
            });
        ui.small(
            "Shares of ground-truth pixels whose depth is within 1% / 2% (a missing estimate \
             counts as a miss), as `mvscope eval` scores them; weak: the scene's weak-texture \
             mask.",
        );
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.mode, CompareMode::Depth, "depth");
            ui.add_enabled_ui(shown.truth.is_some(), |ui| {
                ui.selectable_value(&mut self.mode, CompareMode::Error, "error vs ground truth")
            });
            if ui.button("Fit").clicked() {
                self.frame = MapFrame::fit(self.frame.size);
            }
            self.legend(ui, shown.range);
        });
        let key = (shown.version, shown.view, self.mode);
        if self.key != Some(key) {
            self.textures = shown
                .maps
                .iter()
                .filter_map(|(m, d)| {
                    let d = (*d)?;
                    let image = map_image(self.mode, d, shown.truth.as_deref(), shown.range);
                    let name = format!("compare-{m}");
                    Some((
                        *m,
                        ui.ctx()
                            .load_texture(name, image, egui::TextureOptions::NEAREST),
                    ))
                })
                .collect();
            self.key = Some(key);
        }
        let size = shown
            .maps
            .iter()
            .find_map(|(_, d)| d.map(|d| (d.width, d.height)))
            .unwrap_or((1, 1));
        self.frame.follow_size(size);
        let n = shown.maps.len().max(1) as f32;
        let avail = ui.available_size() - Vec2::new(0.0, 24.0);
        let w = ((avail.x - 8.0 * (n - 1.0)) / n).max(40.0);
        let h = avail.y.max(40.0);
        let mut hovered: Option<(u32, u32)> = None;
        ui.horizontal_top(|ui| {
            for (method, _) in &shown.maps {
                ui.vertical(|ui| {
                    ui.strong(method.to_string());
                    let texture = self
                        .textures
                        .iter()
                        .find(|t| t.0 == *method)
                        .map(|(_, tex)| tex.id());
                    let view = map_view(
                        ui,
                        Vec2::new(w, h - 20.0),
                        &format!("compared {method}"),
                        &mut self.frame,
                        size,
                        texture,
                    );
                    hovered = hovered.or(view.hovered);
                });
            }
        });
        self.hover = hovered.map(|(x, y)| hover_text(x, y, &shown.maps, shown.truth.as_deref()));
        ui.label(
            self.hover
                .clone()
                .unwrap_or_else(|| "hover a map: every method's depth and error there".into()),
        );
    }

    /// One legend for all panes, with units.
    fn legend(&self, ui: &mut egui::Ui, range: (f32, f32)) {
        let (cmap, lo, hi, unit) = match self.mode {
            CompareMode::Depth => (Colormap::Turbo, range.0, range.1, "scene units"),
            CompareMode::Error => (Colormap::Viridis, 0.0, ERROR_SCALE * 100.0, "% error"),
        };
        ui.separator();
        ui.label(format!("{lo:.3}"));
        super::app::ramp(ui, cmap, 180.0);
        ui.label(format!("{hi:.3} {unit}"));
        let swatch = |ui: &mut egui::Ui, c: [u8; 3], text: &str| {
            let (r, _) = ui.allocate_exact_size(Vec2::splat(12.0), Sense::hover());
            ui.painter()
                .rect_filled(r, 2.0, Color32::from_rgb(c[0], c[1], c[2]));
            ui.label(text);
        };
        swatch(ui, NO_ESTIMATE, "no estimate");
        if self.mode == CompareMode::Error {
            swatch(ui, NO_TRUTH, "no ground truth");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn score(w2: f64, weak2: Option<f64>) -> Score {
        Score {
            within1: w2 - 0.1,
            within2: w2,
            weak1: weak2.map(|w| w - 0.1),
            weak2,
        }
    }

    #[test]
    fn the_summary_states_the_gains_in_the_papers_terms() {
        let s = summary(&[
            (Method::Acmh, Some(score(0.80, Some(0.50)))),
            (Method::Acmm, Some(score(0.83, Some(0.62)))),
            (Method::Dwta, Some(score(0.81, Some(0.45)))),
        ]);
        assert!(s.contains("ACMM vs ACMH: +3.0 points within 2%"), "{s}");
        assert!(s.contains("+12.0 points on weak texture"), "{s}");
        assert!(s.contains("ACMH vs DWTA: -1.0 points"), "{s}");
        assert!(summary(&[(Method::Acmh, None)]).contains("No ground truth"));
    }

    #[test]
    fn error_colours_follow_the_error_and_missing_values_have_their_own() {
        let range = (1.0, 3.0);
        assert_eq!(
            pixel_color(CompareMode::Depth, 0.0, None, range),
            NO_ESTIMATE
        );
        assert_eq!(pixel_color(CompareMode::Error, 2.0, None, range), NO_TRUTH);
        let exact = pixel_color(CompareMode::Error, 2.0, Some(2.0), range);
        let off = pixel_color(CompareMode::Error, 2.1, Some(2.0), range);
        assert_eq!(exact, Colormap::Viridis.color(0.0));
        assert_eq!(off, Colormap::Viridis.color(1.0));
        assert_eq!(
            pixel_color(CompareMode::Depth, 3.0, None, range),
            Colormap::Turbo.color(1.0)
        );
    }

    #[test]
    fn the_hover_names_every_methods_depth_and_error() {
        let a = DepthMap {
            width: 2,
            height: 1,
            depth: vec![2.02, 0.0],
        };
        let b = DepthMap {
            width: 2,
            height: 1,
            depth: vec![1.9, 1.0],
        };
        let maps = [(Method::Acmh, Some(&a)), (Method::Acmm, Some(&b))];
        let t = hover_text(0, 0, &maps, Some(&[2.0, 1.0]));
        assert_eq!(
            t,
            "(0, 0) · ACMH 2.0200 (+1.00%) · ACMM 1.9000 (-5.00%) · truth 2.0000"
        );
        let t = hover_text(1, 0, &maps, Some(&[2.0, 1.0]));
        assert_eq!(
            t,
            "(1, 0) · ACMH no estimate · ACMM 1.0000 (+0.00%) · truth 1.0000"
        );
    }
}
