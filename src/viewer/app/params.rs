//! The parameter editor: every parameter on a row with its paper symbol, its field and what
//! it does, a refused value said on its row; saving parameters to TOML.

use super::*;

/// Relative depth difference (a - b) / b of two methods' maps, coloured blue (-5%) to red (+5%).
/// What one parameter widget did this frame.
pub struct Edit {
    pub(super) response: egui::Response,
    /// A finished edit to apply (Enter or focus loss after typing, the end of a drag, a click).
    pub(super) commit: bool,
    /// Typed input that was refused, and why.
    pub(super) error: Option<String>,
}

impl Edit {
    fn clicked(response: egui::Response) -> Edit {
        Edit {
            commit: response.changed(),
            response,
            error: None,
        }
    }
}

/// A number field. Typing applies on Enter or focus loss, once; a typed value out of
/// `range` is refused with a message and the old value kept (never silently clamped).
/// Dragging clamps to `range` and applies when the drag ends, so a drag is one re-run.
pub(super) fn num<N: egui::emath::Numeric>(
    ui: &mut egui::Ui,
    value: &mut N,
    range: std::ops::RangeInclusive<N>,
    speed: f64,
) -> Edit {
    let before = *value;
    let response = ui.add(
        egui::DragValue::new(value)
            .speed(speed)
            .update_while_editing(false),
    );
    let (lo, hi) = (range.start().to_f64(), range.end().to_f64());
    let mut edit = Edit {
        commit: response.drag_stopped(),
        error: None,
        response,
    };
    let v = value.to_f64();
    if edit.response.dragged() {
        *value = N::from_f64(v.clamp(lo, hi));
    } else if edit.response.changed() {
        if !(lo..=hi).contains(&v) || !v.is_finite() {
            edit.error = Some(format!(
                "{} is outside {}..{}; kept {}",
                short(v),
                short(lo),
                short(hi),
                short(before.to_f64())
            ));
            *value = before;
        } else {
            edit.commit = true;
        }
    }
    edit
}

/// A number as a user typed it: integers whole, fractions at f32 precision (the parameters'
/// own), so 0.01 reads 0.01 and not 0.009999999776482582.
pub(super) fn short(x: f64) -> String {
    if x.fract() == 0.0 && x.abs() < 1e15 {
        format!("{x:.0}")
    } else {
        format!("{}", x as f32)
    }
}

/// What the parameter editor did this frame.
#[derive(Default)]
pub struct ParamsEdit {
    /// A finished edit: apply the parameters (once).
    pub commit: bool,
    /// A refused input, named by its parameter.
    pub error: Option<String>,
}

/// One editable parameter: symbol, explanation, and the widget.
pub(super) fn param_row(
    ui: &mut egui::Ui,
    symbol: &str,
    help: &str,
    widget: impl FnOnce(&mut egui::Ui) -> Edit,
) -> ParamsEdit {
    let label = ui.label(symbol).on_hover_text(help);
    // The widget is named by its symbol (accessibility, and the UI tests find it so).
    let edit = widget(ui);
    let _ = edit.response.labelled_by(label.id);
    // A refused value is said beside its field (and stays until the field is changed).
    let refused_id = egui::Id::unique("mvscope: the refused parameter value");
    if let Some(e) = &edit.error {
        ui.data_mut(|d| d.insert_temp(refused_id, (symbol.to_string(), e.clone())));
    } else if edit.commit {
        ui.data_mut(|d| {
            if d.get_temp::<(String, String)>(refused_id)
                .is_some_and(|(s, _)| s == symbol)
            {
                d.remove::<(String, String)>(refused_id);
            }
        });
    }
    match ui
        .data(|d| d.get_temp::<(String, String)>(refused_id))
        .filter(|(s, _)| s == symbol)
    {
        Some((_, e)) => {
            ui.colored_label(Color32::from_rgb(255, 120, 90), format!("refused: {e}"))
                .on_hover_text(help);
        }
        None => {
            ui.small(help);
        }
    }
    ui.end_row();
    ParamsEdit {
        commit: edit.commit,
        error: edit.error.map(|e| format!("{symbol}: {e}")),
    }
}

impl std::ops::BitOrAssign for ParamsEdit {
    fn bitor_assign(&mut self, other: ParamsEdit) {
        self.commit |= other.commit;
        if other.error.is_some() {
            self.error = other.error;
        }
    }
}

/// The parameter editor: edits `p` in place, and says when an edit is finished (to apply)
/// or was refused.
pub fn params_editor(ui: &mut egui::Ui, p: &mut Params) -> ParamsEdit {
    let mut changed = ParamsEdit::default();
    let section = |ui: &mut egui::Ui, t: &str| {
        ui.strong(t);
        ui.end_row();
    };
    // The explanations wrap in their column, so the panel keeps its width.
    egui::Grid::new("params")
        .num_columns(3)
        .max_col_width(170.0)
        .striped(true)
        .show(ui, |ui| {
            section(ui, "View selection (Sec. 4.3)");
            changed |= param_row(
                ui,
                "τ0",
                "initial good-cost threshold; τ(t) = τ0·e^(-t²/α)",
                |ui| {
                    num(ui, &mut p.tau0, 0.01..=2.0, 0.01)
                },
            );
            changed |= param_row(ui, "τ1", "bad-cost threshold (τ1 > τ(t))", |ui| {
                num(ui, &mut p.tau1, 0.01..=2.0, 0.01)
            });
            changed |= param_row(
                ui,
                "α",
                "how fast τ(t) decays with the iteration t",
                |ui| {
                    num(ui, &mut p.alpha, 0.1..=1000.0, 0.1)
                },
            );
            changed |= param_row(ui, "β", "confidence C(m) = e^(-m²/2β²)", |ui| {
                num(ui, &mut p.beta, 0.01..=2.0, 0.01)
            });
            changed |= param_row(
                ui,
                "n1",
                "a view is selected when more than n1 costs are good...",
                |ui| num(ui, &mut p.n1, 0..=8, 1.0),
            );
            changed |= param_row(ui, "n2", "...and fewer than n2 are bad", |ui| {
                num(ui, &mut p.n2, 0..=9, 1.0)
            });
            section(ui, "Matching cost (bilateral NCC)");
            changed |= param_row(ui, "window", "half size of the matching window", |ui| {
                num(ui, &mut p.window_radius, 1..=10, 1.0)
            });
            changed |= param_row(ui, "step", "sample every step-th row and column", |ui| {
                num(ui, &mut p.window_step, 1..=5, 1.0)
            });
            changed |= param_row(
                ui,
                "σs",
                "spatial spread of the bilateral weight (px)",
                |ui| {
                    num(ui, &mut p.sigma_spatial, 0.1..=50.0, 0.1)
                },
            );
            changed |= param_row(
                ui,
                "σc",
                "intensity spread of the bilateral weight (grey levels)",
                |ui| {
                    num(ui, &mut p.sigma_color, 0.1..=255.0, 0.1)
                },
            );
            changed |= param_row(
                ui,
                "kernel",
                "bilateral weight: Laplacian (unsquared distances, the authors' form σs = 5, σc = 3 were tuned for), Gaussian (COLMAP's) or Adaptive (Gaussian, its colour σ the window's own robust spread, never below σc: Regions' default, so a weak window stops at an edge and a textured one keeps its samples)",
                |ui| {
                    use crate::acmm::params::BilateralKernel;
                    // Stacked, so the panel stays narrow.
                    ui.vertical(|ui| {
                        let mut r = ui.radio_value(
                            &mut p.bilateral_kernel,
                            BilateralKernel::Laplacian,
                            "Laplacian",
                        );
                        r |= ui.radio_value(
                            &mut p.bilateral_kernel,
                            BilateralKernel::Gaussian,
                            "Gaussian",
                        );
                        r |= ui.radio_value(
                            &mut p.bilateral_kernel,
                            BilateralKernel::Adaptive,
                            "Adaptive",
                        );
                        Edit::clicked(r)
                    })
                    .inner
                },
            );
            section(ui, "Propagation and refinement (Sec. 4.1-4.4)");
            changed |= param_row(
                ui,
                "K",
                "initial and DWTA cost: mean of the K best views",
                |ui| num(ui, &mut p.top_k, 1..=32, 1.0),
            );
            changed |= param_row(
                ui,
                "iterations",
                "red-black iterations of ACMH and DWTA as methods (paper: 6)",
                |ui| num(ui, &mut p.iterations, 1..=16, 1.0),
            );
            changed |= param_row(
                ui,
                "perturb d",
                "refinement: relative depth perturbation",
                |ui| {
                    num(ui, &mut p.perturb_depth, 0.0..=0.5, 0.001)
                },
            );
            changed |= param_row(ui, "perturb n", "refinement: normal tilt (rad)", |ui| {
                num(ui, &mut p.perturb_normal, 0.0..=1.0, 0.001)
            });
            changed |= param_row(
                ui,
                "median",
                "half size of the median filter on depth",
                |ui| num(ui, &mut p.median_radius, 0..=5, 1.0),
            );
            changed |= param_row(
                ui,
                "median every pass",
                "median-filter depth at the end of every pass (the original code) instead of once, on the final maps (the paper)",
                |ui| Edit::clicked(ui.checkbox(&mut p.median_every_pass, "")),
            );
            section(ui, "Multi-scale geometric consistency (Sec. 5)");
            changed |= param_row(ui, "k", "number of scales", |ui| {
                num(ui, &mut p.scales, 1..=6, 1.0)
            });
            changed |= param_row(
                ui,
                "coarsest size",
                "instead of k: as many scales as it takes for the coarsest long side to be at most this (px; 0 off)",
                |ui| num(ui, &mut p.coarsest_size, 0..=2000, 8.0),
            );
            changed |= param_row(
                ui,
                "scales by texture",
                "at least k scales, and more until the coarsest window reaches texture from 95% of the pixels (measured on the images; the coarsest long side keeps four windows)",
                |ui| Edit::clicked(ui.checkbox(&mut p.scales_by_texture, "")),
            );
            changed |= param_row(ui, "η", "downsampling factor between scales", |ui| {
                num(ui, &mut p.eta, 0.1..=0.9, 0.05)
            });
            changed |= param_row(ui, "δ", "truncation of the reprojection error (px)", |ui| {
                num(ui, &mut p.delta, 0.1..=20.0, 0.1)
            });
            changed |= param_row(ui, "λ", "weight of the reprojection error in m_geo", |ui| {
                num(ui, &mut p.lambda, 0.0..=2.0, 0.01)
            });
            // With the default `refine` the restorer replaces every plane it improves, and
            // ξ only marks which (the difference map, the Replaced mask): say so.
            let xi_hint = if p.restorer == crate::acmm::RestorerMode::Refine {
                "detail restorer: marks where C_init - C_photo > ξ (Replaced map); with `refine` it changes no depth, with `gated` or `random` it decides which planes are replaced"
            } else {
                "detail restorer: replace where C_init - C_photo > ξ"
            };
            changed |= param_row(ui, "ξ", xi_hint, |ui| num(ui, &mut p.xi, 0.0..=2.0, 0.01));
            changed |= param_row(
                ui,
                "restorer",
                "detail restorer: refine the upsampled planes (default), gate them by C_init - ξ, or start from random planes",
                |ui| {
                    use crate::acmm::RestorerMode;
                    ui.vertical(|ui| {
                        let mut r =
                            ui.radio_value(&mut p.restorer, RestorerMode::Refine, "refine");
                        r |= ui.radio_value(&mut p.restorer, RestorerMode::Gated, "gated");
                        r |= ui.radio_value(&mut p.restorer, RestorerMode::Random, "random");
                        Edit::clicked(r)
                    })
                    .inner
                },
            );
            changed |= param_row(
                ui,
                "coarse iterations",
                "ACMM's photometric iterations at the coarsest scale (paper: 3 + 2x2 = 7)",
                |ui| num(ui, &mut p.coarse_iterations, 1..=16, 1.0),
            );
            changed |= param_row(
                ui,
                "restorer iterations",
                "the detail restorer's iterations at finer scales (paper: 2 + 2x2 = 6)",
                |ui| num(ui, &mut p.restorer_iterations, 1..=16, 1.0),
            );
            changed |= param_row(
                ui,
                "geo iterations",
                "red-black iterations per geometric pass",
                |ui| num(ui, &mut p.geometric_iterations, 1..=16, 1.0),
            );
            changed |= param_row(
                ui,
                "geo passes",
                "geometric consistency passes per scale",
                |ui| num(ui, &mut p.geometric_passes, 0..=4, 1.0),
            );
            changed |= param_row(
                ui,
                "original pyramid",
                "build the scales the original code's way (halve until the long side is at most 1000 px) instead of k and η",
                |ui| Edit::clicked(ui.checkbox(&mut p.original_pyramid, "")),
            );
            changed |= param_row(
                ui,
                "JBU radius",
                "joint bilateral upsampling window (coarse px)",
                |ui| num(ui, &mut p.jbu_radius, 0..=5, 1.0),
            );
            changed |= param_row(
                ui,
                "JBU σs",
                "joint bilateral upsampling spatial σ",
                |ui| {
                    num(ui, &mut p.jbu_sigma_spatial, 0.1..=10.0, 0.1)
                },
            );
            changed |= param_row(
                ui,
                "JBU σr",
                "joint bilateral upsampling range σ (grey levels)",
                |ui| {
                    num(ui, &mut p.jbu_sigma_range, 0.1..=255.0, 0.5)
                },
            );
            section(ui, "Planar prior (ACMP, ACMMP)");
            changed |= param_row(
                ui,
                "cell",
                "support points: at most one per cell of this many pixels (authors: 5)",
                |ui| num(ui, &mut p.prior_cell, 2..=64, 1.0),
            );
            changed |= param_row(
                ui,
                "cost threshold",
                "a cell's lowest-cost pixel is credible below this cost (0.1); pixels at or above it restart from the prior",
                |ui| num(ui, &mut p.prior_cost_threshold, 0.001..=2.0, 0.005),
            );
            changed |= param_row(
                ui,
                "consistency",
                "a support point must reproject through a source's depth and back within this many pixels (2, fusion's ψ; 0 checks nothing, as the authors)",
                |ui| num(ui, &mut p.prior_consistency, 0.0..=10.0, 0.05),
            );
            changed |= param_row(
                ui,
                "support's sources",
                "how many sources must confirm a support point's depth within the consistency's pixels (1; 2 or more: HPM-MVS++'s multi-view confidence); anchors too",
                |ui| num(ui, &mut p.prior_support_views, 1..=8, 0.05),
            );
            changed |= param_row(
                ui,
                "triangle normal",
                "drop a triangle whose plane is further than this from a vertex's normal (degrees; 180 keeps all, as the authors)",
                |ui| num(ui, &mut p.prior_triangle_normal, 1.0..=180.0, 0.5),
            );
            changed |= param_row(
                ui,
                "γ",
                "score exp(-m²/β)·(γ + prior): the floor of the prior factor",
                |ui| num(ui, &mut p.prior_gamma, 0.0..=10.0, 0.01),
            );
            changed |= param_row(
                ui,
                "β (prior)",
                "score exp(-m²/β)·(...): the photometric likelihood's spread (0.18)",
                |ui| num(ui, &mut p.prior_beta, 0.001..=4.0, 0.005),
            );
            changed |= param_row(
                ui,
                "σd",
                "the prior's depth spread, as a share of the depth range (1/64)",
                |ui| num(ui, &mut p.prior_sigma_depth, 0.0001..=1.0, 0.001),
            );
            changed |= param_row(
                ui,
                "σθ",
                "the prior's normal spread (degrees, 5)",
                |ui| num(ui, &mut p.prior_sigma_normal, 0.1..=79.0, 0.1),
            );
            changed |= param_row(
                ui,
                "prior iterations",
                "red-black iterations of the prior-assisted pass (3)",
                |ui| num(ui, &mut p.prior_iterations, 1..=16, 1.0),
            );
            changed |= param_row(
                ui,
                "update every pixel",
                "the prior-assisted pass updates every pixel (the authors' code) instead of only those with a prior",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_everywhere, "")),
            );
            changed |= param_row(
                ui,
                "past the hull",
                "pixels no triangle covers take a plane from the support points nearest them (HPM-MVS), instead of no prior; where no source sees them Regions keeps it (Regions; off: ACMP and ACMMP)",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_extend, "")),
            );
            changed |= param_row(
                ui,
                "lock consistent",
                "pixels whose depth the other views already confirm get no prior and keep their plane (HPM-MVS++)",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_lock, "")),
            );
            changed |= param_row(
                ui,
                "after geometric 1",
                "the prior is built after each scale's first geometric pass, from depths the other views were reconciled with, and the second pass follows it (ACMMP: from the photometric pass before it)",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_after_geometric, "")),
            );
            changed |= param_row(
                ui,
                "most-confirmed points",
                "each cell's support point is, among its credible pixels, the one the most sources agree with (then the lowest cost) instead of the lowest-cost one: the same cells keep a point, a better-checked pixel speaks for each (needs the multi-view check)",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_confirmed_points, "")),
            );
            if p.prior_confirmed_points {
                changed |= param_row(
                    ui,
                    "confidence score",
                    "rank by cost minus confidence (HPM-MVS++'s support score): each confirming source adds exp(-(reprojection px + 2 x depth difference / 1%)), so close agreement counts more than many loose ones",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_confidence_score, "")),
                );
            }
            changed |= param_row(
                ui,
                "flat-window points",
                "a cell with no low-cost point takes its best pixel whose matching window is flat (no edge to borrow a match from) if its cost is below the limit: support points on weak walls",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_flat_points, "")),
            );
            if p.prior_flat_points {
                changed |= param_row(
                    ui,
                    "flat points' cost",
                    "the highest cost of a support point on a flat window (0.7)",
                    |ui| num(ui, &mut p.prior_flat_cost, 0.1..=2.0, 0.01),
                );
            }
            if p.prior_flat_points || p.prior_regions {
                changed |= param_row(
                    ui,
                    "flat around a ramp",
                    "a window is flat when its intensities are within 3 grey levels of their best plane (a ramp of shading, to which NCC is blind) rather than of their mean: shaded walls count as flat",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_flat_ramp, "")),
                );
                changed |= param_row(
                    ui,
                    "flat as weighed",
                    "a window is flat when the samples the matching cost weighs are (its bilateral weights), not every pixel alike: with the adaptive weight the wall right up to an object counts as flat",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_flat_weighted, "")),
                );
                changed |= param_row(
                    ui,
                    "flat beyond the noise",
                    "a window is flat when its intensities vary by less than 3 grey levels beyond the image's own sensor noise (estimated from its most homogeneous blocks): a wall photographed with noise of 3 grey levels or more still counts as flat",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_flat_noise, "")),
                );
            }
            changed |= param_row(
                ui,
                "region planes",
                "cells whose every window is flat form regions; each region takes the planes most of its support points agree on (RANSAC) instead of triangles through three of them (the Regions method has it on)",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_regions, "")),
            );
            if p.prior_regions {
                changed |= param_row(
                    ui,
                    "regions' tolerance",
                    "a support point agrees with a region's plane within this share of its depth (0.01)",
                    |ui| num(ui, &mut p.prior_region_tolerance, 0.001..=0.1, 0.001),
                );
                changed |= param_row(
                    ui,
                    "regions' flat share",
                    "a grid cell joins a flat region when at least this share of its pixels have a flat matching window (0.5: most of them)",
                    |ui| num(ui, &mut p.prior_region_flat_share, 0.05..=1.0, 0.05),
                );
                changed |= param_row(
                    ui,
                    "regions' local hold",
                    "a region's plane paints a cell only where it holds most of the support points of the cells it paints within this many cells (0: only over all of them); a curved object's flanks keep their triangles",
                    |ui| num(ui, &mut p.prior_region_near, 0..=8, 1.0),
                );
                changed |= param_row(
                    ui,
                    "regions' cover band",
                    "in the test that a region's plane holds most of the points it paints, the points it misses but lies within this many tolerances of count as held as far as as many are nearer as farther (a noisy wall scatters both ways, a curve or an object one way; 0: off)",
                    |ui| num(ui, &mut p.prior_region_cover_band, 0.0..=10.0, 0.5),
                );
                changed |= param_row(
                    ui,
                    "regions: choose the fit",
                    "the prior follows each scale's first geometric pass but triangulates the restorer's support points (read as that pass begins), as ACMMP would; each flat region takes the planes fitted to that pass's points only where they hold more of its points than the restorer's points' planes",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_region_choice, "")),
                );
                changed |= param_row(
                    ui,
                    "regions fold at creases",
                    "after the planes holding a quarter of a region's points each, the rest may hold smaller planes that meet an earlier one between their points (a room's corner, a wall and the ceiling in one shade); a patch off its wall, a step, gets none",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_region_crease, "")),
                );
                changed |= param_row(
                    ui,
                    "regions' cover: seen points",
                    "a support point a region's plane does not hold counts against the plane only where some source sees the plane's point there: where none does, the cost could not have found the plane's depth (Regions; off: every point counts)",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_region_cover_seen, "")),
                );
                changed |= param_row(
                    ui,
                    "regions stop at an edge",
                    "two neighbouring flat cells join one region only when their shades (each cell's median grey) are within 6 grey levels, the step a window half over each would fail the flat test with: a wall and the floor, flat as weighed up to their edge, stay two regions with a plane each",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_region_edge, "")),
                );
                changed |= param_row(
                    ui,
                    "regions on the room's axes",
                    "a region's plane is first sought with its normal along one of the three orthogonal directions most of the image's straight lines point at (the view's Manhattan frame), the offset most of its support points agree with; a plane through three points only where none holds enough (off: RANSAC's plane everywhere)",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_region_axes, "")),
                );
                changed |= param_row(
                    ui,
                    "prior holds in geometric passes",
                    "a pixel with a prior plane keeps choosing by the prior-weighted score in the geometric passes after the prior's stage, not by the cost alone (Regions; off: ACMMP's order)",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_region_hold, "")),
                );
                if p.prior_region_hold {
                    changed |= param_row(
                        ui,
                        "only region planes hold",
                        "after its prior stage a view keeps the prior planes of its flat regions only (RANSAC planes many support points agree on), not its triangles': the prior map then shows what holds",
                        |ui| Edit::clicked(ui.checkbox(&mut p.prior_hold_regions_only, "")),
                    );
                }
            }
            changed |= param_row(
                ui,
                "keep priors no source sees",
                "a pixel whose prior plane puts its point in no source's image keeps that plane (winner map: \"its prior plane\"): no source can score it, and the cost would pull the pixel to a depth some source sees, however it matches (Regions; off: ACMMP scores every hypothesis)",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_keep_unseen, "")),
            );
            changed |= param_row(
                ui,
                "anchors",
                "a pixel the other views do not confirm takes the plane most of its nearest confirmed pixels along 8 directions agree on, and matches each hypothesis in their windows too (APD-MVS); the inspector shows its anchors and both terms",
                |ui| Edit::clicked(ui.checkbox(&mut p.prior_anchors, "")),
            );
            if p.prior_anchors {
                changed |= param_row(
                    ui,
                    "anchors' share",
                    "share of the anchors' windows in an anchored pixel's cost (0.75)",
                    |ui| num(ui, &mut p.prior_anchor_weight, 0.0..=1.0, 0.01),
                );
                changed |= param_row(
                    ui,
                    "anchor tolerance",
                    "an anchor agrees with a plane within this share of its depth (0.01)",
                    |ui| num(ui, &mut p.prior_anchor_tolerance, 0.0..=0.2, 0.001),
                );
                changed |= param_row(
                    ui,
                    "anchor's sources",
                    "how many sources must confirm an anchor's depth (1: the support points' check; 2: HPM-MVS++'s multi-view confidence asks more than one)",
                    |ui| num(ui, &mut p.prior_anchor_views, 1..=8, 0.05),
                );
                changed |= param_row(
                    ui,
                    "distinct minimum",
                    "an anchor's depth must also be a distinct minimum of its cost along its best source's epipolar line (APD-MVS's weak-texture test)",
                    |ui| Edit::clicked(ui.checkbox(&mut p.prior_anchor_distinct, "")),
                );
                changed |= param_row(
                    ui,
                    "agreeing anchors",
                    "the fewest anchors of 8 that make a plane (5)",
                    |ui| num(ui, &mut p.prior_anchor_inliers, 3..=8, 0.05),
                );
            }
            changed |= param_row(
                ui,
                "restart depth ±",
                "a restarted pixel's depth: the prior's × (1 ± this) (0.06)",
                |ui| num(ui, &mut p.prior_init_depth, 0.0..=0.99, 0.005),
            );
            changed |= param_row(
                ui,
                "restart normal ±",
                "a restarted pixel's normal: the prior's tilted by up to this (degrees, 5.4)",
                |ui| num(ui, &mut p.prior_init_normal, 0.0..=79.0, 0.1),
            );
            changed |= param_row(
                ui,
                "refine depth ±",
                "refinement's random depth: within this many σd of the prior's (3)",
                |ui| num(ui, &mut p.prior_refine_depth, 0.0..=20.0, 0.1),
            );
            changed |= param_row(
                ui,
                "refine normal ±",
                "refinement's random normal: the prior's tilted by up to this (degrees, 2.5)",
                |ui| num(ui, &mut p.prior_refine_normal, 0.0..=79.0, 0.1),
            );
            section(ui, "Fusion (Sec. 6)");
            changed |= param_row(
                ui,
                "ψ",
                "largest reprojection error of a consistent match (px)",
                |ui| {
                    num(ui, &mut p.fusion_reprojection, 0.0..=20.0, 0.1)
                },
            );
            changed |= param_row(ui, "ε", "largest relative depth difference", |ui| {
                num(ui, &mut p.fusion_relative_depth, 0.0..=1.0, 0.001)
            });
            changed |= param_row(ui, "θ", "largest normal angle (degrees)", |ui| {
                num(ui, &mut p.fusion_normal_angle, 0.0..=180.0, 0.5)
            });
            changed |= param_row(ui, "n", "consistent views a point needs", |ui| {
                num(ui, &mut p.fusion_min_views, 1..=32, 1.0)
            });
            section(ui, "Depth range");
            changed |= param_row(
                ui,
                "range min ×",
                "each view's depth range starts at min × this (original code: 0.6)",
                |ui| {
                    num(ui, &mut p.depth_min_factor, 0.05..=1.0, 0.01)
                },
            );
            changed |= param_row(
                ui,
                "range max ×",
                "each view's depth range ends at max × this (original code: 1.2)",
                |ui| {
                    num(ui, &mut p.depth_max_factor, 1.0..=5.0, 0.01)
                },
            );
            section(ui, "Randomness");
            changed |= param_row(ui, "seed", "seed of every random number", |ui| {
                num(ui, &mut p.seed, 0..=u64::MAX, 1.0)
            });
        });
    changed
}

pub(super) fn save_params(params: &Params, path: &Path) -> Result<(), String> {
    let text = toml::to_string_pretty(params).map_err(|e| e.to_string())?;
    crate::io::write_atomic(path, |w| std::io::Write::write_all(w, text.as_bytes()))
        .map_err(|e| e.to_string())
}
