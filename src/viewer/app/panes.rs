//! A map pane: its controls, legend and drawing (the map, the inspected pixel's markers,
//! the planar prior's mesh), and where a window opens beside a clicked pixel.

use super::*;

/// The name of pane `p` of `n` ("map", or "left map" / "right map"): not "map 0", which
/// reads like view 0.
pub fn pane_name(p: usize, n: usize) -> &'static str {
    match (n, p) {
        (1, _) => "map",
        (_, 0) => "left map",
        _ => "right map",
    }
}

/// What the pane controls need to know of the run.
#[derive(Clone, Copy)]
pub(super) struct PaneContext {
    pub(super) nsrc: usize,
    pub(super) xi: f32,
    /// The method builds a planar prior (its maps are offered).
    pub(super) has_prior: bool,
}

pub(super) fn pane_controls(
    ui: &mut egui::Ui,
    p: usize,
    n: usize,
    pane: &mut Pane,
    pc: PaneContext,
) {
    let (nsrc, xi) = (pc.nsrc, pc.xi);
    ui.horizontal_wrapped(|ui| {
        egui::ComboBox::new(("kind", p), pane_name(p, n))
            .selected_text(pane.kind.title())
            .show_ui(ui, |ui| {
                for k in MapKind::ALL {
                    if k.is_prior() && !pc.has_prior {
                        continue;
                    }
                    ui.selectable_value(&mut pane.kind, k, k.title());
                }
            });
        if pane.kind.uses_source() {
            egui::ComboBox::new(("src", p), "source")
                .selected_text(format!("source #{}", pane.source))
                .show_ui(ui, |ui| {
                    for j in 0..nsrc.max(1) as u32 {
                        ui.selectable_value(&mut pane.source, j, format!("source #{j}"));
                    }
                });
        }
        if !pane.kind.is_color() {
            // The winning hypothesis has colours of its own (maps::WINNER_COLORS).
            if pane.kind != MapKind::Winner {
                egui::ComboBox::new(("cmap", p), "colours")
                    .selected_text(pane.colormap.name())
                    .show_ui(ui, |ui| {
                        for c in Colormap::ALL {
                            ui.selectable_value(&mut pane.colormap, c, c.name());
                        }
                    });
            }
            let mut auto = matches!(pane.range_mode, RangeMode::Auto);
            if ui.checkbox(&mut auto, "auto range").changed() {
                pane.range_mode = if auto {
                    RangeMode::Auto
                } else {
                    RangeMode::Manual(pane.range.0, pane.range.1)
                };
            }
            if pane.kind == MapKind::Depth
                && ui
                    .selectable_label(pane.range_mode == RangeMode::DepthRange, "view range")
                    .clicked()
            {
                pane.range_mode = RangeMode::DepthRange;
            }
            if let RangeMode::Manual(mut lo, mut hi) = pane.range_mode {
                let speed = ((hi - lo).abs() * 0.005).max(1e-4);
                ui.add(egui::DragValue::new(&mut lo).speed(speed));
                ui.add(egui::DragValue::new(&mut hi).speed(speed));
                pane.range_mode = RangeMode::Manual(lo, hi);
            }
        }
    });
    if !pane.kind.is_color() {
        legend(ui, pane, xi);
    }
}

/// Where a window of `size` goes beside a clicked point `at` on `screen`: on the side with
/// more room, clear of the point and the candidate markers around it (the inspector over
/// the pixel it explains hid it).
pub fn beside(at: Pos2, size: Vec2, screen: Rect, gap: f32) -> Pos2 {
    let x = if screen.right() - at.x >= at.x - screen.left() {
        at.x + gap
    } else {
        at.x - gap - size.x
    };
    let x = x.clamp(screen.left(), (screen.right() - size.x).max(screen.left()));
    let y = (at.y - size.y / 3.0).clamp(
        screen.top() + 30.0,
        (screen.bottom() - size.y).max(screen.top() + 30.0),
    );
    Pos2::new(x, y)
}

/// Legend entries of a kind with a few discrete values (counts, masks, hypotheses), each
/// with its name; None for continuous kinds.
pub fn discrete_legend(kind: MapKind, range: (f32, f32)) -> Option<Vec<(f32, String)>> {
    let values = |lo: f32, hi: f32| (lo.round() as i64..=hi.round() as i64).map(|v| v as f32);
    match kind {
        MapKind::SelectedCount => Some(
            values(range.0, range.1)
                .map(|v| {
                    let noun = if v == 1.0 { "view" } else { "views" };
                    (v, format!("{v} {noun}"))
                })
                .collect(),
        ),
        MapKind::SelectedBit => Some(vec![(0.0, "not selected".into()), (1.0, "selected".into())]),
        MapKind::Replaced => Some(vec![(0.0, "kept".into()), (1.0, "replaced".into())]),
        MapKind::PriorEffect => Some(vec![
            (0.0, "the prior did not decide".into()),
            (1.0, "restarted / chosen by the prior".into()),
        ]),
        MapKind::Winner => Some(
            values(range.0, range.1)
                .map(|v| {
                    // The map shows Winner::Initial as WINNER_INITIAL_VALUE.
                    let code = if v == WINNER_INITIAL_VALUE {
                        Winner::INITIAL
                    } else {
                        v as u32
                    };
                    (v, winner_label(code))
                })
                .collect(),
        ),
        _ => None,
    }
}

/// What a continuous map's legend says instead of a colour ramp when none of its pixels
/// holds a value (a ramp over a made-up range would suggest one): `None` when some does.
pub fn empty_legend(kind: MapKind, values: &[[f32; 4]]) -> Option<&'static str> {
    if kind.is_color() || discrete_legend(kind, (0.0, 1.0)).is_some() {
        return None;
    }
    if values.iter().any(|v| v[1] > 0.5 && v[0].is_finite()) {
        return None;
    }
    Some(if kind.is_prior() {
        "no pixel has a prior here (no colour scale)"
    } else if kind == MapKind::Confidence {
        "not fused yet: Fuse on the 3D tab counts the agreeing sources (a finished run fuses by itself)"
    } else {
        "no pixel has a value here (no colour scale)"
    })
}

/// A number for a legend: enough digits for its range, no more.
pub(super) fn legend_number(x: f32, span: f32) -> String {
    let digits = if span <= 0.0 {
        3
    } else {
        (2.0 - span.log10().floor()).clamp(0.0, 6.0) as usize
    };
    format!("{x:.digits$}")
}

/// The pane's legend: swatches with names for discrete kinds; otherwise a ramp with its
/// ends, the unit, and for the restorer difference a mark at ξ (where it replaces).
pub(super) fn legend(ui: &mut egui::Ui, pane: &Pane, xi: f32) {
    let (cmap, range, kind) = (pane.colormap, pane.range, pane.kind);
    let span = range.1 - range.0;
    let t_of = |v: f32| {
        if span > 0.0 {
            ((v - range.0) / span).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    if let Some(text) = pane.empty {
        ui.label(text);
        return;
    }
    if let Some(entries) = discrete_legend(kind, range) {
        ui.horizontal_wrapped(|ui| {
            for (v, name) in entries {
                let c = if kind == MapKind::Winner {
                    winner_color(v)
                } else {
                    cmap.color(t_of(v))
                };
                let (rect, _) = ui.allocate_exact_size(Vec2::splat(12.0), Sense::hover());
                ui.painter()
                    .rect_filled(rect, 2.0, Color32::from_rgb(c[0], c[1], c[2]));
                ui.label(name);
            }
        });
        return;
    }
    ui.horizontal(|ui| {
        ui.label(legend_number(range.0, span));
        let rect = ramp(ui, cmap, 160.0);
        let unit = kind.unit();
        ui.label(format!("{} {unit}", legend_number(range.1, span)));
        if kind == MapKind::RestorerDifference && (range.0..=range.1).contains(&xi) {
            let x = rect.left() + rect.width() * t_of(xi);
            ui.painter().line_segment(
                [
                    Pos2::new(x, rect.top() - 3.0),
                    Pos2::new(x, rect.bottom() + 3.0),
                ],
                egui::Stroke::new(2.0, Color32::WHITE),
            );
            ui.label(format!("| ξ = {xi}: replaced above"));
        }
    });
}

/// The inspected pixel and where its 8 candidates came from.
type Inspected = (u32, u32, [Option<(u32, u32)>; 8]);

/// What drawing a pane gave: the value under the cursor, a clicked pixel, and whether the
/// user zoomed or panned it.
pub(super) struct PaneOutput {
    pub(super) hover: Option<String>,
    pub(super) clicked: Option<(u32, u32)>,
    pub(super) moved: bool,
}

/// Draws a pane's texture with its own zoom and pan (refitted when the map's size changed).
/// The planar prior drawn over a pane: its mesh (none yet: a notice), and whether to draw
/// the triangles or the support points only.
type PriorOverlay<'a> = (Option<&'a PriorMesh>, bool);

pub(super) fn draw_pane(
    ui: &mut egui::Ui,
    index: usize,
    pane: &mut Pane,
    inspected: Option<Inspected>,
    overlay: Option<PriorOverlay>,
) -> PaneOutput {
    if pane.texture.is_some() {
        pane.frame.follow_size(pane.size);
    }
    let view = map_view(
        ui,
        ui.available_size(),
        &format!("map pane {index}"),
        &mut pane.frame,
        pane.size,
        pane.texture,
    );
    let mut out = PaneOutput {
        hover: None,
        clicked: None,
        moved: view.moved,
    };
    let (rect, Some(image_rect)) = (view.rect, view.image_rect) else {
        pane.drawn = None;
        pane.marked = None;
        return out;
    };
    let frame = pane.frame;
    let scale = frame.scale(rect);
    let to_screen = |px: f32, py: f32| frame.to_screen(rect, Vec2::new(px, py));
    pane.drawn = Some((rect, image_rect));
    pane.marked = inspected.map(|(x, y, _)| (x, y));
    if let Some((Some(mesh), edges)) = overlay
        && (mesh.width, mesh.height) == pane.size
    {
        let painter = ui.painter().with_clip_rect(rect);
        draw_prior_mesh(&painter, mesh, edges, &to_screen, scale);
    }
    if let Some((x, y, origins)) = inspected {
        let painter = ui.painter().with_clip_rect(rect);
        let c = to_screen(x as f32 + 0.5, y as f32 + 0.5);
        for (a, o) in origins.iter().enumerate() {
            if let Some((ox, oy)) = o {
                let p = to_screen(*ox as f32 + 0.5, *oy as f32 + 0.5);
                painter.line_segment(
                    [c, p],
                    egui::Stroke::new(1.0, Color32::from_rgb(255, 255, 255)),
                );
                painter.circle_filled(p, 3.0, Color32::from_rgb(255, 60, 200));
                painter.text(
                    p + Vec2::new(4.0, -4.0),
                    egui::Align2::LEFT_BOTTOM,
                    a.to_string(),
                    egui::FontId::monospace(10.0),
                    Color32::WHITE,
                );
            }
        }
        painter.rect_stroke(
            Rect::from_center_size(c, Vec2::splat(scale.max(6.0))),
            0.0,
            egui::Stroke::new(1.5, Color32::YELLOW),
            egui::StrokeKind::Outside,
        );
    }
    out.hover = view.hovered.and_then(|(x, y)| {
        let i = (y * pane.size.0 + x) as usize;
        let v = pane.values.get(i)?;
        Some(format!("({x}, {y}) {}", describe_value(pane.kind, *v)))
    });
    if view.response.clicked() {
        out.clicked = view
            .response
            .interact_pointer_pos()
            .and_then(|pos| frame.pixel_at(rect, pos, pane.size));
    }
    out
}

/// Fill colours of the region planes (Regions), by plane index.
const REGION_COLOURS: [(u8, u8, u8); 6] = [
    (70, 150, 255),
    (255, 200, 40),
    (200, 90, 255),
    (40, 220, 200),
    (255, 120, 60),
    (150, 230, 60),
];

/// Colours of the Manhattan frame's three axes (`prior_region_axes`): magenta, blue and
/// yellow, the segments that point at each. Not red: the dropped triangles are filled red.
pub(super) const AXIS_COLOURS: [(u8, u8, u8, u8); 3] = [
    (255, 60, 230, 240),
    (60, 140, 255, 240),
    (250, 230, 40, 240),
];

/// A segment on no axis.
const NO_AXIS_COLOUR: (u8, u8, u8, u8) = (200, 200, 200, 120);

/// A dropped triangle's fill and outline (unmultiplied RGBA).
const DROPPED_FILL: (u8, u8, u8, u8) = (255, 40, 30, 70);
const DROPPED_EDGE: (u8, u8, u8, u8) = (255, 70, 60, 255);

fn rgba((r, g, b, a): (u8, u8, u8, u8)) -> Color32 {
    Color32::from_rgba_unmultiplied(r, g, b, a)
}

/// The colour of a segment pointing at axis `a` (0-2; any other: none).
fn axis_colour(a: u8) -> Color32 {
    rgba(
        AXIS_COLOURS
            .get(a as usize)
            .copied()
            .unwrap_or(NO_AXIS_COLOUR),
    )
}

/// The support points (green dots) and, with `edges`, the triangles over the image: kept
/// ones outlined in white, dropped ones (inconsistent with their points' normals, or
/// degenerate) filled in red. With region planes (Regions), first the flat regions' cells:
/// filled in their plane's colour where they take it, darkened where no plane holds them;
/// the points a plane holds are drawn in its colour; with a Manhattan frame
/// (`prior_region_axes`) its segments, coloured by axis, over the triangles.
pub(super) fn draw_prior_mesh(
    painter: &egui::Painter,
    mesh: &PriorMesh,
    edges: bool,
    to_screen: &dyn Fn(f32, f32) -> egui::Pos2,
    scale: f32,
) {
    let at = |i: usize| {
        let p = &mesh.points[i];
        to_screen(p.x as f32 + 0.5, p.y as f32 + 0.5)
    };
    let colour = |k: usize, alpha: u8| {
        let (r, g, b) = REGION_COLOURS[k % REGION_COLOURS.len()];
        Color32::from_rgba_unmultiplied(r, g, b, alpha)
    };
    let mut held = vec![None; mesh.points.len()];
    if let Some(fit) = &mesh.regions {
        let cell = fit.cell.max(1) as f32;
        // One mesh for every cell: a view of 640x480 in 8-pixel cells has 4,800 of them.
        let mut cells = egui::Mesh::default();
        for (i, (&r, &a)) in fit.region.iter().zip(&fit.assigned).enumerate() {
            if r == 0 {
                continue;
            }
            let (gx, gy) = (
                (i as u32 % fit.cells_x) as f32,
                (i as u32 / fit.cells_x) as f32,
            );
            let fill = match a.checked_sub(1) {
                Some(k) => colour(k as usize, 60),
                None => Color32::from_rgba_unmultiplied(0, 0, 0, 110),
            };
            cells.add_colored_rect(
                egui::Rect::from_two_pos(
                    to_screen(gx * cell, gy * cell),
                    to_screen((gx + 1.0) * cell, (gy + 1.0) * cell),
                ),
                fill,
            );
        }
        if !cells.is_empty() {
            painter.add(egui::Shape::mesh(cells));
        }
        for (k, pl) in fit.planes.iter().enumerate() {
            if fit.is_later(pl) {
                // Its points are the later fit's (`prior_region_choice`): drawn below.
                continue;
            }
            for &i in &pl.inliers {
                if let Some(h) = held.get_mut(i) {
                    *h = Some(k);
                }
            }
        }
    }
    if edges {
        let kept = egui::Stroke::new(1.0, Color32::from_rgba_unmultiplied(255, 255, 255, 170));
        let dropped = egui::Stroke::new(1.0, rgba(DROPPED_EDGE));
        // A dropped triangle is often a sliver along the hull (nearly collinear points).
        // epaint joins a closed path's corners by unbounded miters, and its fill's
        // feathering pushes along the same normals, so a polygon shape with a corner of a
        // fraction of a degree draws a spike hundreds of pixels long out of the image. So
        // the fills are a plain mesh (no feathering), one for all of them, under every
        // outline, and each outline three segments (butt ends), as the kept triangles' are.
        let mut fills = egui::Mesh::default();
        for t in mesh.triangles.iter().filter(|t| !t.kept()) {
            let base = fills.vertices.len() as u32;
            for p in t.vertices.map(at) {
                fills.colored_vertex(p, rgba(DROPPED_FILL));
            }
            fills.add_triangle(base, base + 1, base + 2);
        }
        if !fills.is_empty() {
            painter.add(egui::Shape::mesh(fills));
        }
        for t in &mesh.triangles {
            let v = t.vertices.map(at);
            let stroke = if t.kept() { kept } else { dropped };
            for k in 0..3 {
                painter.line_segment([v[k], v[(k + 1) % 3]], stroke);
            }
        }
    }
    // With `prior_region_axes`: the straight segments the view's frame came from, each in
    // the colour of the axis it points at (grey: none), over the triangles (a dropped one's
    // fill hid them), on a dark underlay so they read as lines on any fill.
    if let Some(frame) = mesh.regions.as_ref().and_then(|fit| fit.frame.as_ref()) {
        let under = egui::Stroke::new(4.0, Color32::from_rgba_unmultiplied(0, 0, 0, 160));
        for (s, &a) in frame.segments.iter().zip(&frame.along) {
            let ends = [
                to_screen(s.a[0] + 0.5, s.a[1] + 0.5),
                to_screen(s.b[0] + 0.5, s.b[1] + 0.5),
            ];
            painter.line_segment(ends, under);
            painter.line_segment(ends, egui::Stroke::new(2.0, axis_colour(a)));
        }
    }
    let radius = (0.35 * scale).clamp(1.5, 4.0);
    for (i, h) in held.iter().enumerate() {
        let fill = h.map_or(Color32::from_rgb(60, 230, 90), |k| colour(k, 255));
        painter.circle_filled(at(i), radius, fill);
    }
    // With the per-region choice (`prior_region_choice`), the points of the regions that
    // took the fit to the first geometric pass's points: in their plane's colour, ringed in
    // white (they are not the triangles' points).
    if let Some(fit) = &mesh.regions {
        let ring = egui::Stroke::new(1.0, Color32::WHITE);
        for (k, pl) in fit.planes.iter().enumerate() {
            if !fit.is_later(pl) {
                continue;
            }
            for &i in &pl.inliers {
                if let Some(p) = fit.later_points.get(i) {
                    let c = to_screen(p.x as f32 + 0.5, p.y as f32 + 0.5);
                    painter.circle(c, radius, colour(k, 255), ring);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acmm::lines::{Frame, Segment};
    use crate::acmm::planar::{PriorTriangle, RegionFit, SupportPoint, TriangleState};

    /// One frame of `draw_prior_mesh` on `mesh`, 4 screen points a pixel: the context (to
    /// tessellate with) and what it painted.
    fn frame(mesh: &PriorMesh) -> (egui::Context, egui::FullOutput) {
        let ctx = egui::Context::default();
        let mut out = ctx.run_ui(egui::RawInput::default(), |ui| {
            let painter = ui.ctx().layer_painter(egui::LayerId::background());
            draw_prior_mesh(
                &painter,
                mesh,
                true,
                &|x, y| egui::pos2(4.0 * x, 4.0 * y),
                4.0,
            );
        });
        // The font atlas it built is never uploaded (epaint asserts that in debug builds).
        out.textures_delta.clear();
        (ctx, out)
    }

    /// The paint list of [`frame`].
    fn painted(mesh: &PriorMesh) -> Vec<egui::Shape> {
        frame(mesh).1.shapes.into_iter().map(|c| c.shape).collect()
    }

    /// A support point at (x, y), 2 deep, facing the camera.
    fn point(x: u32, y: u32) -> SupportPoint {
        SupportPoint {
            x,
            y,
            depth: 2.0,
            cost: 0.1,
            normal: [0.0, 0.0, -1.0],
        }
    }

    /// Within 90 of each other in the sum of |ΔR|, |ΔG|, |ΔB| (alpha aside).
    fn near(a: (u8, u8, u8, u8), b: (u8, u8, u8, u8)) -> bool {
        let d = |p: u8, q: u8| (p as i32 - q as i32).abs();
        d(a.0, b.0) + d(a.1, b.1) + d(a.2, b.2) < 90
    }

    /// A frame's segment across a dropped triangle is painted after the triangle's red fill
    /// (before, the fill covered it), and no axis is drawn in the dropped triangles' red.
    #[test]
    fn the_frames_segments_are_drawn_over_dropped_triangles() {
        let frame = Frame {
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            segments: vec![Segment {
                a: [2.0, 5.0],
                b: [18.0, 5.0],
            }],
            along: vec![0],
        };
        let mesh = PriorMesh {
            width: 20,
            height: 20,
            points: vec![point(0, 0), point(19, 0), point(0, 19)],
            triangles: vec![PriorTriangle {
                vertices: [0, 1, 2],
                plane: [0.0, 0.0, -1.0, 2.0],
                state: TriangleState::Inconsistent,
            }],
            regions: Some(RegionFit {
                cell: 4,
                cells_x: 5,
                cells_y: 5,
                region: vec![0; 25],
                assigned: vec![0; 25],
                frame: Some(frame),
                ..RegionFit::default()
            }),
        };
        let shapes = painted(&mesh);
        let fill = shapes
            .iter()
            .position(|s| matches!(s, egui::Shape::Mesh(m) if m.vertices.len() == 3))
            .expect("the dropped triangle's fill");
        let segment = shapes
            .iter()
            .position(|s| {
                matches!(s, egui::Shape::LineSegment { stroke, .. } if stroke.color == axis_colour(0))
            })
            .expect("the segment in its axis' colour");
        assert!(
            segment > fill,
            "segment painted at {segment}, under the triangle's fill at {fill}"
        );
        for axis in AXIS_COLOURS {
            assert!(
                !near(axis, DROPPED_FILL) && !near(axis, DROPPED_EDGE),
                "axis colour {axis:?} is the dropped triangles' red"
            );
        }
    }

    /// With the per-region choice, a plane from the later fit marks its own points (the
    /// later fit's, ringed in white, at their place) and none of the mesh's points.
    #[test]
    fn a_later_planes_points_are_drawn_ringed_where_they_are() {
        use crate::acmm::planar::{FREE_PLANE, RegionPlane};
        let mesh = PriorMesh {
            width: 20,
            height: 20,
            points: vec![point(0, 0), point(19, 0)],
            triangles: Vec::new(),
            regions: Some(RegionFit {
                cell: 10,
                cells_x: 2,
                cells_y: 2,
                region: vec![1, 1, 0, 0],
                assigned: vec![1, 1, 0, 0],
                sizes: vec![1],
                planes: vec![RegionPlane {
                    region: 0,
                    plane: [0.0, 0.0, -1.0, 2.0],
                    inliers: vec![1],
                    axis: FREE_PLANE,
                }],
                later: vec![true],
                later_points: vec![point(3, 3), point(7, 11)],
                ..RegionFit::default()
            }),
        };
        let circles: Vec<egui::epaint::CircleShape> = painted(&mesh)
            .into_iter()
            .filter_map(|s| match s {
                egui::Shape::Circle(c) => Some(c),
                _ => None,
            })
            .collect();
        let green = Color32::from_rgb(60, 230, 90);
        // The mesh's two points stay green (the plane holds none of them).
        assert_eq!(circles.iter().filter(|c| c.fill == green).count(), 2);
        let ringed: Vec<_> = circles
            .iter()
            .filter(|c| c.stroke.color == Color32::WHITE)
            .collect();
        assert_eq!(ringed.len(), 1, "the plane's one later point");
        assert_eq!(ringed[0].center, egui::pos2(4.0 * 7.5, 4.0 * 11.5));
        assert_ne!(ringed[0].fill, green);
    }

    /// However many cells and dropped triangles, one mesh holds the cells and one the
    /// dropped triangles' fills, both under every outline; each cell keeps its colour.
    #[test]
    fn cells_and_dropped_fills_are_one_mesh_each_under_the_outlines() {
        let points: Vec<SupportPoint> = (0..10)
            .flat_map(|y| (0..10).map(move |x| point(4 * x, 4 * y)))
            .collect();
        let triangles: Vec<PriorTriangle> = (0..9)
            .flat_map(|y| (0..9).map(move |x| y * 10 + x))
            .map(|i| PriorTriangle {
                vertices: [i, i + 1, i + 10],
                plane: [0.0, 0.0, -1.0, 2.0],
                state: if i % 3 == 0 {
                    TriangleState::Kept
                } else {
                    TriangleState::Inconsistent
                },
            })
            .collect();
        let dropped = triangles.iter().filter(|t| !t.kept()).count();
        let mesh = PriorMesh {
            width: 40,
            height: 40,
            points,
            triangles,
            regions: Some(RegionFit {
                cell: 4,
                cells_x: 10,
                cells_y: 10,
                // Cells of region 1: the first half with plane 1, the rest with none.
                region: (0..100).map(|i| u32::from(i % 2 == 0)).collect(),
                assigned: (0..100).map(|i| u32::from(i % 2 == 0 && i < 50)).collect(),
                ..RegionFit::default()
            }),
        };
        let shapes = painted(&mesh);
        let meshes: Vec<(usize, &egui::Mesh)> = shapes
            .iter()
            .enumerate()
            .filter_map(|(k, s)| match s {
                egui::Shape::Mesh(m) => Some((k, m.as_ref())),
                _ => None,
            })
            .collect();
        assert_eq!(meshes.len(), 2, "one mesh for the cells, one for the fills");
        let (cells, fills) = (meshes[0].1, meshes[1].1);
        assert_eq!(
            cells.vertices.len(),
            4 * 50,
            "four corners for each of 50 cells"
        );
        let plane = cells.vertices.iter().filter(|v| v.color.a() == 60).count();
        assert_eq!(plane, 4 * 25, "25 cells in their plane's colour");
        assert_eq!(fills.indices.len(), 3 * dropped);
        assert!(
            fills.vertices.iter().all(|v| v.color == rgba(DROPPED_FILL)),
            "a fill in another colour"
        );
        let first_outline = shapes
            .iter()
            .position(|s| matches!(s, egui::Shape::LineSegment { .. }))
            .expect("outlines");
        assert!(meshes[1].0 < first_outline, "a fill over an outline");
        let outlines = shapes
            .iter()
            .filter(|s| matches!(s, egui::Shape::LineSegment { .. }))
            .count();
        assert_eq!(outlines, 3 * 81);
    }

    /// A dropped sliver along the hull's top (its corners a fraction of a degree) draws
    /// within its own box: as a feathered polygon, epaint's unbounded miter drew it as a
    /// spike some 140 screen pixels up out of the image (the demo scene's view 0 at 160x120).
    #[test]
    fn a_dropped_sliver_stays_within_its_box() {
        let mesh = PriorMesh {
            width: 160,
            height: 120,
            points: vec![point(0, 2), point(80, 1), point(159, 2)],
            triangles: vec![PriorTriangle {
                vertices: [0, 1, 2],
                plane: [0.0, 0.0, -1.0, 2.0],
                state: TriangleState::Inconsistent,
            }],
            regions: None,
        };
        let (ctx, out) = frame(&mesh);
        let mut points = 0;
        for clipped in ctx.tessellate(out.shapes, out.pixels_per_point) {
            let egui::epaint::Primitive::Mesh(m) = clipped.primitive else {
                continue;
            };
            for v in &m.vertices {
                points += 1;
                // The box of the three points' screen positions, widened by the strokes'
                // width and a pixel's feather (the dots' radius is 1.5).
                assert!(
                    (-4.0..=4.0 * 160.0 + 4.0).contains(&v.pos.x)
                        && (4.0 * 1.5 - 4.0..=4.0 * 2.5 + 4.0).contains(&v.pos.y),
                    "vertex at {:?} outside the sliver's box",
                    v.pos
                );
            }
        }
        assert!(points > 0, "nothing was drawn");
    }
}
