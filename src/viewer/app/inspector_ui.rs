//! The pixel inspector's contents: the candidates and their cost matrix, the view-selection
//! votes and weights, the refinement, the planar prior's terms, the warped patches.

use super::*;

pub(super) fn inspection_ui(
    ui: &mut egui::Ui,
    ins: &Inspection,
    tau1: f32,
    patches: Option<&inspector::Patches>,
) {
    let u = &ins.update;
    ui.label(format!(
        "Explaining step {}: {}",
        ins.capture_index + 1,
        ins.label
    ));
    ui.label(format!(
        "Adopted: depth {:.4}, normal ({:.3}, {:.3}, {:.3}), cost {:.4}, winner: {}",
        u.plane[3],
        u.plane[0],
        u.plane[1],
        u.plane[2],
        u.cost,
        crate::viewer::maps::winner_label(u.winner.code())
    ));
    let (text, color) = if ins.agrees {
        (
            "CPU reference = GPU result (match)",
            Color32::from_rgb(120, 220, 120),
        )
    } else {
        (
            "CPU reference and GPU differ (a near tie?)",
            Color32::from_rgb(255, 160, 80),
        )
    };
    ui.colored_label(color, text);
    ui.label(format!(
        "GPU: depth {:.4}, cost {:.4}, winner: {}",
        ins.gpu.plane[3],
        ins.gpu.cost,
        crate::viewer::maps::winner_label(ins.gpu.winner)
    ));
    ui.separator();
    if u.winner == crate::acmm::problem::Winner::PriorUnseen {
        let d = u.plane[3];
        ui.label(format!(
            "Its prior plane (depth {d:.4}) puts the point in no source's image: no source can \
             score it, and the matching cost would score it as the worst match, so any depth \
             that throws the ray into some source's image would win, however it matches. \
             Regions keeps the prior plane here (prior_keep_unseen): no candidate, refinement \
             or view is scored, the cost is the maximum and no view is selected."
        ));
        return;
    }
    ui.label(format!(
        "τ(t) = {:.4} (green: m < τ(t)), τ1 = {:.3} (red: m > τ1). View set S_t: {}",
        u.tau_t,
        tau1,
        (0..u.votes.len())
            .filter(|&j| u.votes[j].selected)
            .map(|j| format!("#{j}"))
            .collect::<Vec<_>>()
            .join(" ")
    ));
    egui::Grid::new("cost_matrix").striped(true).show(ui, |ui| {
        ui.strong("cand.");
        for (j, v) in ins.source_views.iter().enumerate() {
            ui.strong(format!("#{j} (v{v})"));
        }
        ui.strong("cost");
        ui.end_row();
        for a in 0..8 {
            let origin = ins.origins[a]
                .map(|(x, y)| format!("{a} ({x},{y})"))
                .unwrap_or_else(|| format!("{a} -"));
            ui.label(origin);
            for col in &u.matrix {
                let m = col[a];
                let color = if ins.origins[a].is_none() {
                    Color32::GRAY
                } else if m < u.tau_t {
                    Color32::from_rgb(110, 220, 110)
                } else if m > tau1 {
                    Color32::from_rgb(240, 100, 90)
                } else {
                    Color32::from_rgb(220, 220, 120)
                };
                ui.colored_label(color, format!("{m:.3}"));
            }
            ui.label(format!("{:.4}", u.candidate_costs[a]));
            ui.end_row();
        }
        ui.label("votes");
        for v in &u.votes {
            ui.label(format!(
                "{}/{} {}",
                v.good,
                v.bad,
                if v.selected { "in S" } else { "" }
            ));
        }
        ui.end_row();
        ui.label("w'");
        for w in &u.weights {
            ui.label(format!("{w:.3}"));
        }
        ui.end_row();
        if let Some(re) = &ins.reprojection {
            ui.label("Δe (px)");
            for e in re {
                ui.label(format!("{e:.2}"));
            }
            ui.end_row();
        }
    });
    ui.label(format!("current plane's cost {:.4}", u.current_cost));
    ui.label(format!(
        "refinement costs: {}",
        u.refinement_costs
            .iter()
            .map(|c| format!("{c:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    if let Some(p) = &u.prior {
        prior_ui(ui, u, p, ins);
    }
    window_ui(ui, &ins.window);
    // Patches: the reference window and what the adopted plane warps it to.
    if let Some(patches) = patches {
        ui.label("Reference patch and its warps into each source (adopted plane):");
        ui.horizontal_wrapped(|ui| {
            patch_widget(ui, &patches.reference, patches.size, "ref");
            for (j, p) in patches.sources.iter().enumerate() {
                patch_widget(ui, p, patches.size, &format!("#{j}"));
            }
        });
    }
}

/// The planar prior's part of an update: each hypothesis's cost m (photometric, or with λΔe),
/// its photometric likelihood exp(−m²/β), its prior factor and the score S they multiply to,
/// which the pixel maximises; and whether the prior changed the choice.
pub(super) fn prior_ui(
    ui: &mut egui::Ui,
    u: &crate::acmm::cpu::PixelUpdate,
    p: &crate::acmm::cpu::PriorDetail,
    ins: &Inspection,
) {
    ui.separator();
    ui.label(format!(
        "Planar prior here: depth {:.4}, normal ({:.3}, {:.3}, {:.3}). Score S = exp(−m²/β) × (γ + exp(−Δd²/2σd²)·exp(−Δθ²/2σθ²)), largest wins:",
        p.prior_plane[3], p.prior_plane[0], p.prior_plane[1], p.prior_plane[2]
    ));
    if let Some(r) = &ins.region {
        let planes = r
            .planes
            .iter()
            .enumerate()
            .map(|(k, n)| match r.axes.get(k).copied().filter(|&a| a < 3) {
                Some(a) => format!(
                    "plane {} holds {n}, its normal the room's axis {}",
                    k + 1,
                    a + 1
                ),
                None => format!("plane {} holds {n}", k + 1),
            })
            .collect::<Vec<_>>()
            .join(", ");
        let text = match r.taken {
            Some(k) => format!(
                "In flat region {} ({} support points; {planes}): its prior is plane {} of the region, the one most of its points agree on, not a triangle through three of them.",
                r.region,
                r.points,
                k + 1
            ),
            None => format!(
                "In flat region {} ({} support points): no plane holds most of the points around this cell (it is not planar here), so its prior is its triangle's.",
                r.region, r.points
            ),
        };
        ui.label(text);
        if let Some((n, c)) = r.frame {
            ui.label(format!(
                "The view's straight lines give the room's three axes (its Manhattan frame): of its {n} segments, {} point at axis 1, {} at axis 2, {} at axis 3 (drawn in magenta, blue and yellow on the triangulation map). A plane on an axis has one free number, its offset, which the region's points fix where three of them cannot fix a normal; RANSAC's plane through three points only where no axis plane holds a quarter of them.",
                c[0], c[1], c[2]
            ));
        }
        if let Some((shade, cut)) = &r.edge {
            let sides = cut
                .iter()
                .map(|(side, v)| format!("{side} ({v:.1})"))
                .collect::<Vec<_>>()
                .join(", ");
            ui.label(if cut.is_empty() {
                format!(
                    "Its cell's shade (median grey) is {shade:.1}: no flat neighbour is 6 grey levels or more from it, so no edge stops the region here."
                )
            } else {
                format!(
                    "Its cell's shade (median grey) is {shade:.1}: an edge (6 grey levels or more, the step a window over both would fail the flat test with) cuts it from its flat neighbours {sides}, which the region does not join through it."
                )
            });
        }
    }
    if let Some(a) = &ins.anchors {
        ui.label(format!(
            "Anchored (a weak pixel): its prior is the plane its {} anchors agree on, at {}; each hypothesis's m = {:.2} × its own window's cost + {:.2} × the mean over the anchors' windows, all warped by the hypothesis's plane:",
            a.pixels.len(),
            a.pixels
                .iter()
                .map(|(x, y)| format!("({x},{y})"))
                .collect::<Vec<_>>()
                .join(" "),
            1.0 - a.weight,
            a.weight
        ));
        egui::Grid::new("anchor_terms")
            .striped(true)
            .show(ui, |ui| {
                for h in ["candidate", "own window", "anchors' windows", "m"] {
                    ui.strong(h);
                }
                ui.end_row();
                for k in 0..8 {
                    if let (Some(o), Some(n)) = (a.own[k], a.anchored[k]) {
                        ui.label(format!("{k}"));
                        ui.label(format!("{o:.3}"));
                        ui.label(format!("{n:.3}"));
                        ui.label(format!("{:.3}", u.candidate_costs[k]));
                        ui.end_row();
                    }
                }
            });
    }
    let winner = u.winner;
    egui::Grid::new("prior_terms").striped(true).show(ui, |ui| {
        for h in ["hypothesis", "depth", "m", "prior factor", "S"] {
            ui.strong(h);
        }
        ui.end_row();
        let row = |ui: &mut egui::Ui, name: String, depth: f32, m: f32, f: f32, sc: f32, won| {
            let text = |t: String| {
                if won {
                    egui::RichText::new(t)
                        .strong()
                        .color(Color32::from_rgb(120, 220, 120))
                } else {
                    egui::RichText::new(t)
                }
            };
            ui.label(text(name));
            ui.label(text(format!("{depth:.4}")));
            ui.label(text(format!("{m:.3}")));
            ui.label(text(format!("{f:.3}")));
            ui.label(text(format!("{sc:.4}")));
            ui.end_row();
        };
        row(
            ui,
            "current".into(),
            u.current_plane[3],
            u.current_cost,
            p.current_factor,
            p.current_score,
            winner == crate::acmm::problem::Winner::Kept,
        );
        for a in 0..8 {
            if ins.origins[a].is_none() {
                continue;
            }
            row(
                ui,
                format!("candidate {a}"),
                u.candidate_planes[a][3],
                u.candidate_costs[a],
                p.candidate_factors[a],
                p.candidate_scores[a],
                winner == crate::acmm::problem::Winner::Propagated(a as u8),
            );
        }
        for r in 0..6 {
            row(
                ui,
                format!("refinement {r}"),
                u.refinement_planes[r][3],
                u.refinement_costs[r],
                p.refinement_factors[r],
                p.refinement_scores[r],
                winner == crate::acmm::problem::Winner::Refined(r as u8),
            );
        }
    });
    if p.flipped {
        ui.colored_label(
            Color32::from_rgb(255, 200, 90),
            format!(
                "The prior changed the choice: the lowest cost alone would have taken {}.",
                crate::viewer::maps::winner_label(p.photometric_winner.code())
            ),
        );
    } else {
        ui.label("The prior agreed with the lowest cost here.");
    }
}

/// How the matching cost weighs the pixel's reference window: the kernel, its colour σ, the
/// weights and each sample's share of the weighted variance over the window (white: the
/// heaviest, black: none, blue: not sampled) and how many samples' worth of weight the NCC
/// matches on.
pub(super) fn window_ui(ui: &mut egui::Ui, w: &inspector::WindowWeights) {
    use crate::acmm::params::BilateralKernel;
    ui.separator();
    let kernel = match w.kernel {
        BilateralKernel::Laplacian => format!(
            "the authors' unsquared weight exp(−|Δx|/2σs² − |ΔI|/2σc²), σc = {:.1}",
            w.sigma
        ),
        BilateralKernel::Gaussian => format!(
            "the Gaussian weight exp(−|Δx|²/2σs² − |ΔI|²/2σ²), σ = σc = {:.1}",
            w.sigma
        ),
        BilateralKernel::Adaptive => format!(
            "the adaptive weight exp(−|Δx|²/2σs² − |ΔI|²/2σ²), σ = {:.1}: the window's \
             spread 1.4826 × median |ΔI| = {:.1}, never below σc",
            w.sigma, w.spread
        ),
    };
    let top = w
        .variance_share
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max);
    ui.label(format!(
        "Window weights ({kernel}): the NCC matches on {:.1} of its {} samples' worth of \
         weight, (Σw)²/Σw², and on the window's weighted variance, of which the largest \
         sample holds {:.0}%. A sample across an edge may weigh little and still hold most of \
         the variance: then it decides every hypothesis's cost, and a weak window is matched \
         at the depth beyond the edge.",
        w.effective,
        w.samples,
        100.0 * top
    ));
    ui.horizontal(|ui| {
        grid_widget(ui, &w.weights, w.size, 1.0, "weights");
        grid_widget(ui, &w.variance_share, w.size, top, "variance share");
    });
}

/// A window's per-pixel values drawn as grey, `full` white (NaN: dark blue, not sampled).
fn grid_widget(ui: &mut egui::Ui, values: &[f32], size: usize, full: f32, label: &str) {
    cells_widget(ui, values, size, 6.0, label, |v| {
        if v.is_finite() {
            let t = if full > 0.0 { v / full } else { 0.0 };
            Color32::from_gray((t.clamp(0.0, 1.0) * 255.0).round() as u8)
        } else {
            Color32::from_rgb(20, 30, 70)
        }
    });
}

/// A patch of grey values (0-255; NaN, where the plane does not face the camera, dark red).
pub(super) fn patch_widget(ui: &mut egui::Ui, values: &[f32], size: usize, label: &str) {
    cells_widget(ui, values, size, 4.0, label, |v| {
        if v.is_finite() {
            Color32::from_gray(v.clamp(0.0, 255.0) as u8)
        } else {
            Color32::from_rgb(80, 0, 0)
        }
    });
}

/// `size` x `size` values, row by row, as squares of `cell` points coloured by `color`, with
/// `label` under them.
fn cells_widget(
    ui: &mut egui::Ui,
    values: &[f32],
    size: usize,
    cell: f32,
    label: &str,
    color: impl Fn(f32) -> Color32,
) {
    ui.vertical(|ui| {
        let (rect, _) = ui.allocate_exact_size(Vec2::splat(cell * size as f32), Sense::hover());
        for (k, &v) in values.iter().enumerate() {
            let (x, y) = ((k % size) as f32, (k / size) as f32);
            ui.painter().rect_filled(
                Rect::from_min_size(rect.min + Vec2::new(x, y) * cell, Vec2::splat(cell)),
                0.0,
                color(v),
            );
        }
        ui.small(label);
    });
}

/// Why the pixel's cell has its support point (the planar prior's first step): every pixel
/// of the cell with its cost, whether the multi-view check passed, its confidence and
/// score, best first by the rule in force; the chosen one marked.
pub(super) fn support_ui(
    ui: &mut egui::Ui,
    index: usize,
    cell: &crate::acmm::planar::SupportCell,
    params: &Params,
) {
    let (x0, y0) = cell.origin;
    ui.strong(format!(
        "Support point of cell ({x0}, {y0}), {0}x{0} px (step {1})",
        cell.size,
        index + 1
    ));
    let rule = if params.prior_confirmed_points && params.prior_confidence_score {
        "lowest cost − confidence (HPM-MVS++'s score; confidence: Σ over the sources that confirm it of exp(−(e + c·Δd/(r·d))))"
    } else if params.prior_confirmed_points {
        "most sources confirming it, then lowest cost"
    } else {
        "lowest cost (ACMMP)"
    };
    ui.label(format!(
        "Chosen among the multi-view consistent pixels of cost below {:.2} by {rule}{}.",
        params.prior_cost_threshold,
        if params.prior_flat_points {
            format!(
                "; failing any, among the flat windows (spread under 3 grey levels around \
                 their {}{}{}) below {:.2}",
                if params.prior_flat_ramp {
                    "ramp of shading"
                } else {
                    "mean"
                },
                if params.prior_flat_weighted {
                    ", the samples under the cost's weights"
                } else {
                    ""
                },
                if params.prior_flat_noise {
                    ", beyond the image's noise"
                } else {
                    ""
                },
                params.prior_flat_cost
            )
        } else {
            String::new()
        }
    ));
    match cell.chosen {
        Some((x, y)) => ui.label(format!(
            "Chosen: ({x}, {y}){}",
            if cell.by_flat_window {
                ", a flat window (no consistent pixel below the cost limit)"
            } else {
                ""
            }
        )),
        None => ui.label("No support point: no pixel of the cell passes."),
    };
    let confidence = cell.candidates.iter().any(|c| c.confidence.is_some());
    egui::Grid::new("support_cell")
        .striped(true)
        .show(ui, |ui| {
            for h in ["pixel", "depth", "cost", "flat", "may be chosen"] {
                ui.strong(h);
            }
            if confidence {
                ui.strong(if params.prior_confidence_score {
                    "confidence"
                } else {
                    "sources"
                });
            }
            ui.strong("score");
            ui.end_row();
            // The best ones: a 5x5 cell has 25.
            for c in cell.candidates.iter().take(10) {
                let chosen = cell.chosen == Some((c.x, c.y));
                let text = format!("({}, {}){}", c.x, c.y, if chosen { " chosen" } else { "" });
                if chosen {
                    ui.colored_label(Color32::from_rgb(120, 220, 120), text);
                } else {
                    ui.label(text);
                }
                ui.label(format!("{:.4}", c.depth));
                ui.label(format!("{:.3}", c.cost));
                ui.label(if c.flat { "yes" } else { "" });
                use crate::acmm::planar::Eligibility;
                ui.label(match c.eligibility {
                    Eligibility::BelowCostLimit => "yes",
                    Eligibility::FlatWindow => "flat window",
                    Eligibility::CostTooHigh => "no: cost",
                    Eligibility::Inconsistent => "no: views disagree",
                });
                if confidence {
                    ui.label(c.confidence.map_or("-".into(), |v| format!("{v:.3}")));
                }
                ui.label(format!("{:.3}", c.score));
                ui.end_row();
            }
        });
}
