//! The Compare tab: every method on one view, large, in a grid with linked zoom and hover,
//! one legend, error maps against ground truth, the accuracy table `mvscope eval` would
//! print, and a one-line summary in the paper's terms.
//!
//! A method stopped at a coarser scale has a smaller map: its error map, hover readout and
//! table row all compare it with the ground truth sampled at its own size (as `mvscope eval`
//! does), and it is drawn stretched over the same frame as the others.

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

/// Two shares in one table cell, as "a / b" (percent, one decimal; "-" where missing).
pub fn pair(a: Option<f64>, b: Option<f64>) -> String {
    format!("{} / {}", pct(a), pct(b))
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

/// Pixel (`x`, `y`) of a `size` map at the same spot of a `w x h` one (pixel centres, as
/// `crate::eval::resample_nearest` maps them).
pub fn pixel_at(x: u32, y: u32, size: (u32, u32), w: u32, h: u32) -> (u32, u32) {
    let map = |v: u32, from: u32, to: u32| {
        let f = to as f64 / from.max(1) as f64;
        ((((v as f64 + 0.5) * f - 0.5).round().max(0.0)) as u32).min(to.saturating_sub(1))
    };
    (map(x, size.0, w), map(y, size.1, h))
}

/// Each compared method's map of the chosen view with the ground truth at its own size.
pub fn compared_maps(model: &super::model::Model) -> Vec<ComparedMap<'_>> {
    model
        .comparison_depths()
        .into_iter()
        .map(|(method, map)| ComparedMap {
            method,
            map,
            truth: map.and_then(|d| model.truth_at(d.width, d.height)),
        })
        .collect()
}

/// One compared method's map and the ground truth sampled at its size.
pub struct ComparedMap<'a> {
    pub method: Method,
    pub map: Option<&'a DepthMap>,
    pub truth: Option<Vec<f32>>,
}

/// The text under the cursor at pixel (`x`, `y`) of the `size` frame: every method's depth
/// and error at that spot of its own map, against the truth at its size; the truth of the
/// first map that has it.
pub fn hover_text(x: u32, y: u32, size: (u32, u32), maps: &[ComparedMap<'_>]) -> String {
    let mut parts = vec![format!("({x}, {y})")];
    let mut truth_value = None;
    for c in maps {
        let method = c.method;
        let Some(m) = c.map else { continue };
        let (mx, my) = pixel_at(x, y, size, m.width, m.height);
        if mx >= m.width || my >= m.height {
            continue;
        }
        let i = (my * m.width + mx) as usize;
        let d = m.depth[i];
        let g = c
            .truth
            .as_ref()
            .and_then(|t| t.get(i).copied())
            .filter(|g| *g > 0.0);
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
    /// Textures by method (each at its map's own size), and the key they were made for.
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
    /// Each method's map of the view, with the truth at its size.
    pub maps: Vec<ComparedMap<'a>>,
    pub range: (f32, f32),
    pub version: u64,
}

impl Shown<'_> {
    /// The frame the panes share: the largest map's size.
    pub fn frame_size(&self) -> (u32, u32) {
        self.maps
            .iter()
            .filter_map(|c| c.map.map(|d| (d.width, d.height)))
            .max_by_key(|(w, h)| *w as u64 * *h as u64)
            .unwrap_or((1, 1))
    }

    fn has_truth(&self) -> bool {
        self.maps.iter().any(|c| c.truth.is_some())
    }
}

/// Columns of the grid that shows `n` maps of aspect `aspect` (width / height) largest in
/// an `avail` area, with `gap` between panes and `title` above each.
pub fn grid_columns(n: usize, aspect: f32, avail: Vec2, gap: f32, title: f32) -> usize {
    let n = n.max(1);
    let scale = |cols: usize| {
        let rows = n.div_ceil(cols);
        let w = (avail.x - gap * (cols as f32 - 1.0)) / cols as f32;
        let h = (avail.y - gap * (rows as f32 - 1.0)) / rows as f32 - title;
        (w / aspect.max(1e-3)).min(h)
    };
    (1..=n)
        .max_by(|&a, &b| scale(a).total_cmp(&scale(b)))
        .unwrap_or(1)
}

impl CompareView {
    /// Draws the finished comparison: summary, table, mode, the panes and the legend.
    pub fn ui(&mut self, ui: &mut egui::Ui, shown: &Shown<'_>) {
        let cmp = shown.cmp;
        let pooled: Vec<(Method, Option<Score>)> =
            cmp.runs.iter().map(|r| (r.method, r.overall)).collect();
        ui.label(egui::RichText::new(summary(&pooled)).strong());
        ui.add_space(4.0);
        // Each cell pairs two figures, and the figures come before the step each method
        // stopped at, so that they fit between the side panels at a laptop's width (twelve
        // single-figure columns after "stopped at" ran past a 1280-px window's panel edge,
        // cutting the seen / unseen split off); what does not fit scrolls sideways, its bar
        // floating over the last row so that the panes below keep their height (a style set for
        // this area only).
        ui.scope(|ui| {
            ui.spacing_mut().scroll = egui::style::ScrollStyle {
                floating_allocated_width: 0.0,
                ..egui::style::ScrollStyle::floating()
            };
            egui::ScrollArea::horizontal()
                .id_salt("compare-table-scroll")
                .content_margin(egui::Margin::ZERO)
                .show(ui, |ui| {
                    egui::Grid::new("compare-table")
                        .striped(true)
                        .num_columns(7)
                        .show(ui, |ui| {
                            ui.strong("method");
                            for h in [
                                format!("view {} <1% / <2%", shown.view),
                                "weak <1% / <2%".into(),
                                "all views <1% / <2%".into(),
                                "weak <1% / <2%".into(),
                                "seen / unseen <2%".into(),
                                "stopped at".into(),
                            ] {
                                let header = ui.strong(h.as_str());
                                if h.starts_with("seen") {
                                    header.on_hover_text(
                                        "seen: all views' pixels whose true point one of the \
                                         view's sources sees (projected into it, not hidden by its \
                                         truth); unseen: the rest, where no view offers evidence \
                                         and only a prior can give the depth",
                                    );
                                }
                            }
                            ui.end_row();
                            for r in &cmp.runs {
                                ui.label(r.method.to_string());
                                let view = r.scores.get(shown.view).copied().flatten();
                                for s in [view, r.overall] {
                                    ui.label(pair(s.map(|s| s.within1), s.map(|s| s.within2)));
                                    ui.label(pair(
                                        s.and_then(|s| s.weak1),
                                        s.and_then(|s| s.weak2),
                                    ));
                                }
                                ui.label(pair(
                                    r.seen.map(|s| s.within_2),
                                    r.seen.and_then(|s| s.unseen_within_2),
                                ));
                                let note = if r.matched { "" } else { " (its end)" };
                                ui.label(format!(
                                    "{}{note}",
                                    r.stopped.clone().unwrap_or_else(|| "-".into())
                                ));
                                ui.end_row();
                            }
                        });
                });
        });
        let seen = cmp.runs.iter().find_map(|r| r.seen).map(|s| s.seen);
        ui.small(format!(
            "Shares of ground-truth pixels within 1% / 2% of their depth (no estimate counts \
             as a miss), as `mvscope eval` scores them; weak: the weak-texture mask; seen / \
             unseen: pixels a source of their view sees, and the rest{} (finest scale; hover \
             the column).",
            seen.map_or(String::new(), |s| format!(", {:.1}% seen", s * 100.0))
        ));
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.mode, CompareMode::Depth, "depth");
            ui.add_enabled_ui(shown.has_truth(), |ui| {
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
                .filter_map(|c| {
                    let d = c.map?;
                    let image = map_image(self.mode, d, c.truth.as_deref(), shown.range);
                    let name = format!("compare-{}", c.method);
                    Some((
                        c.method,
                        ui.ctx()
                            .load_texture(name, image, egui::TextureOptions::NEAREST),
                    ))
                })
                .collect();
            self.key = Some(key);
        }
        let size = shown.frame_size();
        self.frame.follow_size(size);
        let n = shown.maps.len().max(1);
        let avail = ui.available_size() - Vec2::new(0.0, 24.0);
        let (gap, title) = (8.0, 20.0);
        let aspect = size.0 as f32 / size.1.max(1) as f32;
        let cols = grid_columns(n, aspect, avail, gap, title);
        let rows = n.div_ceil(cols);
        let w = ((avail.x - gap * (cols as f32 - 1.0)) / cols as f32).max(40.0);
        let h = ((avail.y - gap * (rows as f32 - 1.0)) / rows as f32).max(40.0);
        let mut hovered: Option<(u32, u32)> = None;
        let mut drawn = Vec::new();
        for row in shown.maps.chunks(cols) {
            ui.horizontal_top(|ui| {
                for c in row {
                    ui.vertical(|ui| {
                        ui.strong(c.method.to_string());
                        let texture = self
                            .textures
                            .iter()
                            .find(|t| t.0 == c.method)
                            .map(|(_, tex)| tex.id());
                        let view = map_view(
                            ui,
                            Vec2::new(w, h - title),
                            &format!("compared {}", c.method),
                            &mut self.frame,
                            size,
                            texture,
                        );
                        hovered = hovered.or(view.hovered);
                        drawn.push(view.rect);
                    });
                }
            });
        }
        // The hovered spot, marked on every pane.
        if let Some((x, y)) = hovered {
            for rect in &drawn {
                let c = self
                    .frame
                    .to_screen(*rect, Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                let side = self.frame.scale(*rect).max(6.0);
                ui.painter().with_clip_rect(*rect).rect_stroke(
                    egui::Rect::from_center_size(c, Vec2::splat(side)),
                    0.0,
                    egui::Stroke::new(1.5, Color32::WHITE),
                    egui::StrokeKind::Outside,
                );
            }
        }
        self.hover = hovered.map(|(x, y)| hover_text(x, y, size, &shown.maps));
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
        super::maps::ramp(ui, cmap, 180.0);
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
        let truth = || Some(vec![2.0, 1.0]);
        let maps = [
            ComparedMap {
                method: Method::Acmh,
                map: Some(&a),
                truth: truth(),
            },
            ComparedMap {
                method: Method::Acmm,
                map: Some(&b),
                truth: truth(),
            },
        ];
        let t = hover_text(0, 0, (2, 1), &maps);
        assert_eq!(
            t,
            "(0, 0) · ACMH 2.0200 (+1.00%) · ACMM 1.9000 (-5.00%) · truth 2.0000"
        );
        let t = hover_text(1, 0, (2, 1), &maps);
        assert_eq!(
            t,
            "(1, 0) · ACMH no estimate · ACMM 1.0000 (+0.00%) · truth 1.0000"
        );
        // A map at half size is read at the same spot, against the truth at its size.
        let coarse = DepthMap {
            width: 1,
            height: 1,
            depth: vec![1.5],
        };
        let maps = [ComparedMap {
            method: Method::Acmm,
            map: Some(&coarse),
            truth: Some(vec![1.5]),
        }];
        assert_eq!(
            hover_text(1, 0, (2, 1), &maps),
            "(1, 0) · ACMM 1.5000 (+0.00%) · truth 1.5000"
        );
    }

    #[test]
    fn five_maps_go_in_the_grid_that_shows_them_largest() {
        // 4:3 maps in a wide, short area: one row; in a squarer area: 3 + 2.
        assert_eq!(
            grid_columns(5, 4.0 / 3.0, Vec2::new(2000.0, 300.0), 8.0, 20.0),
            5
        );
        assert_eq!(
            grid_columns(5, 4.0 / 3.0, Vec2::new(1000.0, 700.0), 8.0, 20.0),
            3
        );
        assert_eq!(
            grid_columns(1, 4.0 / 3.0, Vec2::new(1000.0, 700.0), 8.0, 20.0),
            1
        );
        assert_eq!(pixel_at(3, 1, (4, 2), 2, 1), (1, 0));
        assert_eq!(pixel_at(0, 0, (4, 2), 2, 1), (0, 0));
    }
}
