//! How a map pane frames its map: zoom and pan in the map's own coordinates, so that a
//! window resize, a second pane or a change of scale never leaves a map as a sliver or a
//! corner tile.

use egui::{Pos2, Rect, Vec2};

/// The framing of one pane. `zoom` is relative to the fit (1: the whole map fits the pane,
/// 2: twice that), `center` is the map point at the pane's centre as a fraction of the
/// map's width and height. Neither depends on the map's pixel size or the pane's size.
/// `size` is the map size the framing was made for: a map of another size is refitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapFrame {
    pub zoom: f32,
    pub center: Vec2,
    pub size: (u32, u32),
}

/// How far out and in a pane can zoom, relative to the fit.
pub const ZOOM_OUT: f32 = 0.25;
/// Enough to see single pixels of a 6000 px map in a small pane.
pub const ZOOM_IN: f32 = 512.0;

impl Default for MapFrame {
    fn default() -> Self {
        MapFrame::fit((0, 0))
    }
}

impl MapFrame {
    /// The whole map of `size` centred at its aspect ratio.
    pub fn fit(size: (u32, u32)) -> MapFrame {
        MapFrame {
            zoom: 1.0,
            center: Vec2::splat(0.5),
            size,
        }
    }

    /// Refits when the map's size changed since the framing was made; returns whether it
    /// did.
    pub fn follow_size(&mut self, size: (u32, u32)) -> bool {
        if self.size != size {
            *self = MapFrame::fit(size);
            true
        } else {
            false
        }
    }

    fn map_size(&self) -> Vec2 {
        Vec2::new(self.size.0.max(1) as f32, self.size.1.max(1) as f32)
    }

    /// Screen points per map pixel in `rect`.
    pub fn scale(&self, rect: Rect) -> f32 {
        let m = self.map_size();
        (rect.width() / m.x).min(rect.height() / m.y) * self.zoom
    }

    /// The screen position of map pixel coordinates `p` (pixel corners at integers).
    pub fn to_screen(&self, rect: Rect, p: Vec2) -> Pos2 {
        let m = self.map_size();
        rect.center() + (p - self.center * m) * self.scale(rect)
    }

    /// The map pixel coordinates under screen position `pos`.
    pub fn to_map(&self, rect: Rect, pos: Pos2) -> Vec2 {
        self.center * self.map_size() + (pos - rect.center()) / self.scale(rect)
    }

    /// Where the whole map lands on screen.
    /// The map pixel of a map of `size` under `pos`, if the map is there.
    pub fn pixel_at(&self, rect: Rect, pos: Pos2, size: (u32, u32)) -> Option<(u32, u32)> {
        let m = self.to_map(rect, pos);
        (m.x >= 0.0 && m.y >= 0.0 && m.x < size.0 as f32 && m.y < size.1 as f32)
            .then_some((m.x as u32, m.y as u32))
    }

    pub fn image_rect(&self, rect: Rect) -> Rect {
        Rect::from_min_max(
            self.to_screen(rect, Vec2::ZERO),
            self.to_screen(rect, self.map_size()),
        )
    }

    /// Zooms by `factor`, keeping the map point under `pos` in place.
    pub fn zoom_about(&mut self, rect: Rect, pos: Pos2, factor: f32) {
        let before = self.to_map(rect, pos);
        self.zoom = (self.zoom * factor).clamp(ZOOM_OUT, ZOOM_IN);
        let after = self.to_map(rect, pos);
        self.center += (before - after) / self.map_size();
    }

    /// Moves the map by `delta` screen points.
    pub fn pan(&mut self, rect: Rect, delta: Vec2) {
        self.center -= delta / self.scale(rect) / self.map_size();
    }

    /// The same view of the map as `other` (linked panes), kept for this pane's map size.
    pub fn link_to(&mut self, other: &MapFrame) {
        self.zoom = other.zoom;
        self.center = other.center;
    }
}

/// The parts of `outer` that none of `holes` covers, as disjoint rectangles (bands between
/// the holes' top and bottom edges, split at their sides).
pub fn uncovered(outer: Rect, holes: &[Rect]) -> Vec<Rect> {
    let holes: Vec<Rect> = holes
        .iter()
        .map(|h| h.intersect(outer))
        .filter(|h| h.is_positive())
        .collect();
    let mut ys: Vec<f32> = vec![outer.min.y, outer.max.y];
    ys.extend(holes.iter().flat_map(|h| [h.min.y, h.max.y]));
    ys.sort_by(f32::total_cmp);
    ys.dedup();
    let mut out = Vec::new();
    for band in ys.windows(2) {
        let (y0, y1) = (band[0], band[1]);
        let mut spans: Vec<(f32, f32)> = holes
            .iter()
            .filter(|h| h.min.y <= y0 && h.max.y >= y1)
            .map(|h| (h.min.x, h.max.x))
            .collect();
        spans.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut x = outer.min.x;
        for (a, b) in spans {
            if a > x {
                out.push(Rect::from_min_max(Pos2::new(x, y0), Pos2::new(a, y1)));
            }
            x = x.max(b);
        }
        if x < outer.max.x {
            out.push(Rect::from_min_max(
                Pos2::new(x, y0),
                Pos2::new(outer.max.x, y1),
            ));
        }
    }
    out.retain(|r| r.is_positive());
    out
}

/// `rects` filled with `color`, as one mesh: no anti-aliased edges, so that rectangles
/// meeting each other or a map leave no seam.
pub fn filled(rects: &[Rect], color: egui::Color32) -> egui::Shape {
    let mut mesh = egui::Mesh::default();
    for r in rects {
        mesh.add_colored_rect(*r, color);
    }
    egui::Shape::mesh(mesh)
}

fn painted_id() -> egui::Id {
    egui::Id::unique("mvscope: map panes painted this frame")
}

/// Tells the central panel that `rect` (as far as `ui` shows it) gets opaque pixels this
/// frame, so it does not fill under it.
pub fn mark_painted(ui: &egui::Ui, rect: Rect) {
    let painted = rect.intersect(ui.clip_rect());
    ui.ctx().data_mut(|d| {
        d.get_temp_mut_or_default::<Vec<Rect>>(painted_id())
            .push(painted)
    });
}

/// The rectangles map panes painted completely this frame (and forgets them): the central
/// panel leaves them out of its own fill.
pub fn take_painted(ctx: &egui::Context) -> Vec<Rect> {
    ctx.data_mut(|d| d.remove_temp::<Vec<Rect>>(painted_id()))
        .unwrap_or_default()
}

/// What drawing a map under its frame gave.
pub struct MapView {
    pub response: egui::Response,
    /// The pane's rectangle, and the map's on screen (None: no map to draw).
    pub rect: Rect,
    pub image_rect: Option<Rect>,
    /// The map pixel under the cursor.
    pub hovered: Option<(u32, u32)>,
    /// Whether the user zoomed, panned or refitted it this frame.
    pub moved: bool,
}

/// A pane of `size` showing `texture` (a map of `map_size` pixels) under `frame`: the wheel
/// zooms about the cursor, a drag pans, a double-click fits. The caller keeps the frame
/// following the map's size; without a texture the pane says "no map".
pub fn map_view(
    ui: &mut egui::Ui,
    size: Vec2,
    label: &str,
    frame: &mut MapFrame,
    map_size: (u32, u32),
    texture: Option<egui::TextureId>,
) -> MapView {
    let (rect, response) = ui.allocate_exact_size(size, egui::Sense::click_and_drag());
    response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, label));
    let background = egui::Color32::from_gray(20);
    mark_painted(ui, rect);
    let mut view = MapView {
        response,
        rect,
        image_rect: None,
        hovered: None,
        moved: false,
    };
    let Some(texture) = texture else {
        ui.painter().add(filled(&[rect], background));
        ui.painter().text(
            rect.center(),
            egui::Align2::CENTER_CENTER,
            "no map",
            egui::FontId::proportional(14.0),
            egui::Color32::GRAY,
        );
        return view;
    };
    let response = &view.response;
    if response.hovered() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if scroll != 0.0
            && let Some(pos) = response.hover_pos()
        {
            frame.zoom_about(rect, pos, (scroll * 0.002).exp());
            view.moved = true;
        }
    }
    if response.dragged() && response.drag_delta() != Vec2::ZERO {
        frame.pan(rect, response.drag_delta());
        view.moved = true;
    }
    if response.double_clicked() {
        *frame = MapFrame::fit(map_size);
        view.moved = true;
    }
    let image_rect = frame.image_rect(rect);
    // The maps are opaque: the background goes only where the map is not, and the central
    // panel's fill not under the pane (see `take_painted`). On the software device each
    // layer of fill over a 1400x900 window costs about 45 ms.
    ui.painter()
        .add(filled(&uncovered(rect, &[image_rect]), background));
    ui.painter().with_clip_rect(rect).image(
        texture,
        image_rect,
        Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
        egui::Color32::WHITE,
    );
    view.image_rect = Some(image_rect);
    view.hovered = response
        .hover_pos()
        .and_then(|pos| frame.pixel_at(rect, pos, map_size));
    view
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uncovered_parts_tile_the_rest_exactly_once() {
        let outer = Rect::from_min_max(Pos2::new(0.0, 0.0), Pos2::new(100.0, 60.0));
        let area = |rs: &[Rect]| rs.iter().map(|r| r.area()).sum::<f32>();
        let disjoint = |rs: &[Rect]| {
            rs.iter()
                .enumerate()
                .all(|(i, a)| rs[i + 1..].iter().all(|b| !a.intersect(*b).is_positive()))
        };
        // A map fitted in a wider pane: bars left and right.
        let inner = Rect::from_min_max(Pos2::new(20.0, 0.0), Pos2::new(80.0, 60.0));
        let bars = uncovered(outer, &[inner]);
        assert_eq!(bars.len(), 2);
        assert_eq!(area(&bars), outer.area() - inner.area());
        assert!(bars.iter().all(|b| !b.intersect(inner).is_positive()));
        // Zoomed in past the pane: nothing to fill.
        assert!(uncovered(outer, &[outer.expand(30.0)]).is_empty());
        // Panned partly out of the pane.
        let inner = Rect::from_min_max(Pos2::new(50.0, 30.0), Pos2::new(150.0, 90.0));
        let rest = uncovered(outer, &[inner]);
        assert_eq!(area(&rest), outer.area() - 50.0 * 30.0);
        assert!(disjoint(&rest));
        // Out of sight: all of it.
        let away = Rect::from_min_max(Pos2::new(200.0, 0.0), Pos2::new(300.0, 60.0));
        assert_eq!(uncovered(outer, &[away]), vec![outer]);
        // Two panes side by side with a gap, and a caption row above them.
        let left = Rect::from_min_max(Pos2::new(5.0, 10.0), Pos2::new(45.0, 55.0));
        let right = Rect::from_min_max(Pos2::new(55.0, 12.0), Pos2::new(95.0, 55.0));
        let rest = uncovered(outer, &[left, right]);
        assert!(disjoint(&rest));
        assert!((area(&rest) - (outer.area() - left.area() - right.area())).abs() < 1e-3);
        assert!(
            rest.iter()
                .all(|r| !r.intersect(left).is_positive() && !r.intersect(right).is_positive())
        );
    }

    fn pane() -> Rect {
        Rect::from_min_size(Pos2::new(100.0, 50.0), Vec2::new(400.0, 500.0))
    }

    #[test]
    fn a_fitted_map_is_whole_centred_and_keeps_its_aspect() {
        let f = MapFrame::fit((320, 240));
        let r = f.image_rect(pane());
        assert!((r.width() - 400.0).abs() < 1e-3, "{r:?}");
        assert!((r.height() - 300.0).abs() < 1e-3, "{r:?}");
        assert!((r.center() - pane().center()).length() < 1e-3);
    }

    #[test]
    fn zoom_keeps_the_point_under_the_cursor_and_pan_moves_with_the_pointer() {
        let mut f = MapFrame::fit((320, 240));
        let pos = Pos2::new(180.0, 260.0);
        let before = f.to_map(pane(), pos);
        f.zoom_about(pane(), pos, 3.0);
        assert!((f.to_map(pane(), pos) - before).length() < 1e-3);
        assert_eq!(f.zoom, 3.0);
        let p = f.to_screen(pane(), Vec2::new(10.0, 20.0));
        f.pan(pane(), Vec2::new(15.0, -7.0));
        let q = f.to_screen(pane(), Vec2::new(10.0, 20.0));
        assert!((q - p - Vec2::new(15.0, -7.0)).length() < 1e-3);
    }

    #[test]
    fn framing_is_kept_in_map_coordinates_across_pane_sizes_and_refits_on_a_new_size() {
        let mut f = MapFrame::fit((320, 240));
        f.zoom_about(pane(), Pos2::new(150.0, 100.0), 4.0);
        // Half the pane: the same map point stays at the centre, the same share is shown.
        let small = Rect::from_min_size(Pos2::ZERO, Vec2::new(200.0, 250.0));
        let c_big = f.to_map(pane(), pane().center());
        let c_small = f.to_map(small, small.center());
        assert!((c_big - c_small).length() < 1e-3);
        // A new map size (a change of scale): the whole map again.
        assert!(!f.follow_size((320, 240)));
        assert!(f.follow_size((960, 720)));
        assert_eq!(f, MapFrame::fit((960, 720)));
        // Linked panes show the same part of maps of different sizes.
        let mut g = MapFrame::fit((160, 120));
        let mut h = MapFrame::fit((320, 240));
        h.zoom_about(pane(), Pos2::new(150.0, 100.0), 4.0);
        g.link_to(&h);
        let a = h.to_map(pane(), pane().center()) / Vec2::new(320.0, 240.0);
        let b = g.to_map(pane(), pane().center()) / Vec2::new(160.0, 120.0);
        assert!((a - b).length() < 1e-5);
    }
}
