//! The central tabs (maps, 3D, Compare) and the panels and windows beside them: parameters,
//! pixel inspector, guided tour.

use super::*;

impl ViewerApp {
    pub(super) fn maps_tab(&mut self, ui: &mut egui::Ui) {
        self.update_panes();
        let n = self.panes.len();
        let mut hover: Option<String> = None;
        let mut clicked = None;
        let mut gap = 60.0;
        self.refresh_inspector();
        // The markers belong to the inspector: none while it is closed or replaying.
        let inspecting = self.show_inspector && !self.model.is_replaying();
        let inspection_origins = self
            .inspector_view
            .as_ref()
            .and_then(|v| v.inspection.as_ref())
            .map(|i| (i.x, i.y, i.origins))
            .or_else(|| self.model.inspect().map(|(x, y)| (x, y, [None; 8])))
            .filter(|_| inspecting);
        let nsrc = self
            .model
            .session
            .as_ref()
            .and_then(|s| s.level_scene(0).views.get(self.model.view))
            .map_or(0, |v| v.sources.len());
        let available = ui.available_size();
        let pane_w = (available.x - 8.0 * (n as f32 - 1.0)) / n as f32;
        let mut moved: Option<usize> = None;
        let pc = PaneContext {
            nsrc,
            xi: self.model.params.xi,
            has_prior: self.model.method.has_planar_prior(),
        };
        let mesh = self
            .model
            .session
            .as_ref()
            .and_then(|s| s.planar_mesh(self.model.view));
        // Whether the shown view has had a step (before it, every map but the image is
        // blank), and whether the last step measured a reprojection error.
        let view = self.model.view;
        let started = self.model.schedule()[..self.model.cursor()]
            .iter()
            .any(|s| s.view == view);
        let geometric = self
            .model
            .current_step()
            .is_some_and(|s| matches!(s.stage, Stage::Geometric(_)));
        // Every pane's map starts at the same height: a header that wraps, or a notice,
        // pads the others (to the tallest header of the last frame).
        let header_target = self.pane_header;
        let mut header_max: f32 = 0.0;
        ui.horizontal_top(|ui| {
            for (p, pane) in self.panes.iter_mut().enumerate() {
                ui.allocate_ui(Vec2::new(pane_w, available.y), |ui| {
                    ui.vertical(|ui| {
                        let top = ui.cursor().top();
                        pane_controls(ui, p, n, pane, pc);
                        let notice = if pane.kind.is_prior() && mesh.is_none() {
                            Some("no planar prior at this step: it is built in the planar prior stage".into())
                        } else if pane.kind != MapKind::Image && !started {
                            Some(format!("view {view}: no estimate yet — press Step"))
                        } else if pane.kind == MapKind::ReprojectionError && !geometric {
                            Some("not available in this stage: the reprojection error is measured by a geometric consistency pass".into())
                        } else {
                            None
                        };
                        if let Some(text) = notice {
                            ui.colored_label(Color32::from_rgb(255, 220, 120), text);
                        }
                        let header = ui.cursor().top() - top;
                        header_max = header_max.max(header);
                        if n > 1 && header < header_target {
                            ui.add_space(header_target - header);
                        }
                        let overlay = pane.kind.overlay().map(|edges| (mesh, edges));
                        let out = draw_pane(ui, p, pane, inspection_origins, overlay);
                        if hover.is_none() {
                            hover = out.hover;
                        }
                        if clicked.is_none() && out.clicked.is_some() {
                            clicked = out.clicked;
                            // The candidate markers reach about 25 map pixels from the
                            // pixel (the farthest checkerboard samples): the inspector
                            // opens beyond them.
                            if let Some((rect, _)) = pane.drawn {
                                gap = (25.0 * pane.frame.scale(rect)).max(60.0);
                            }
                        }
                        if out.moved {
                            moved = Some(p);
                        }
                    });
                });
            }
        });
        self.pane_header = header_max;
        if self.link_panes
            && let Some(p) = moved
        {
            let lead = self.panes[p].frame;
            for (q, pane) in self.panes.iter_mut().enumerate() {
                if q != p {
                    pane.frame.link_to(&lead);
                }
            }
        }
        self.hover = hover;
        if let Some(px) = clicked {
            self.model.inspect_pixel(px);
            self.show_inspector = true;
            self.inspector_at = ui.ctx().pointer_interact_pos();
            self.maps_left = ui.max_rect().left();
            self.inspector_gap = gap;
        }
    }

    pub(super) fn cloud_tab(&mut self, ui: &mut egui::Ui) {
        // A finished run is fused when the 3D tab is first shown for it, instead of showing
        // "0 points" until Fuse is found.
        let finished = self.model.session.as_ref().is_some_and(|s| s.is_finished());
        if finished
            && self.model.cloud.points.is_empty()
            && self.model.cloud_source == CloudSource::Fused
            && self.auto_fused != Some(self.model.version)
        {
            self.auto_fused = Some(self.model.version);
            if let Err(e) = self.model.request_fusion() {
                self.model.error = Some(e);
            }
        }
        ui.horizontal_wrapped(|ui| {
            if ui
                .button("Fuse")
                .on_hover_text("re-fuse the current maps")
                .clicked()
                && let Err(e) = self.model.request_fusion()
            {
                self.model.error = Some(e);
            }
            if ui.button("This view's depth").clicked() {
                self.model.request_backprojection(false);
            }
            if ui.button("All views' depth").clicked() {
                self.model.request_backprojection(true);
            }
            ui.label(match self.model.cloud_source {
                CloudSource::Fused => "showing: fused cloud",
                CloudSource::ViewDepth => "showing: this view back-projected",
                CloudSource::AllDepths => "showing: all views back-projected",
            });
            ui.separator();
            ui.add(
                egui::Slider::new(&mut self.cloud_view.point_size, 1.0..=12.0).text("point size"),
            );
            ui.selectable_value(&mut self.cloud_view.color_mode, ColorMode::Rgb, "RGB");
            ui.selectable_value(&mut self.cloud_view.color_mode, ColorMode::Normal, "normal");
            ui.selectable_value(&mut self.cloud_view.color_mode, ColorMode::Cost, "cost");
            ui.checkbox(&mut self.cloud_view.show_frusta, "cameras");
            if ui.button("Fit").clicked() {
                self.cloud_view.camera = None;
            }
            ui.label(format!("{} points", self.model.cloud.points.len()));
        });
        let scene = self.model.cloud.clone();
        if scene.points.is_empty() {
            ui.add_space(40.0);
            ui.vertical_centered(|ui| {
                ui.label(
                    "No points yet. Fuse builds the cloud from the maps as they stand (the run \
                     is fused by itself when it ends); \"This view's depth\" back-projects one \
                     map.",
                );
                if ui
                    .add_enabled(
                        self.model.session.is_some(),
                        egui::Button::new("Fuse the current maps"),
                    )
                    .clicked()
                    && let Err(e) = self.model.request_fusion()
                {
                    self.model.error = Some(e);
                }
            });
            return;
        }
        self.cloud_view.ui(ui, &scene);
    }

    pub(super) fn compare_tab(&mut self, ui: &mut egui::Ui) {
        let Some(cmp) = &self.model.comparison else {
            ui.heading("Compare DWTA, ACMH, ACMM, ACMP, ACMMP and Regions");
            ui.label(
                "Runs every method on this scene with the same parameters and shows them \
                 side by side, with error maps and the accuracy table where the scene has \
                 ground truth. A method whose run is finished (the main run, or one you \
                 switched away from) is reused, not recomputed.",
            );
            if self.model.session.as_ref().is_some_and(|s| s.is_finished()) {
                ui.label(format!(
                    "{} is finished in the main run: its maps are reused.",
                    self.model.method
                ));
            }
            if ui
                .add_enabled(
                    self.model.loaded.is_some(),
                    egui::Button::new("Run the comparison"),
                )
                .on_disabled_hover_text("open a scene first")
                .clicked()
            {
                self.model.start_comparison();
            }
            return;
        };
        let mut follow = cmp.follow;
        if ui
            .checkbox(
                &mut follow,
                "at the current step (each method that has it; the others at their end)",
            )
            .changed()
        {
            self.model.set_comparison_follow(follow);
            // Say it: the results go and the methods run again to the new point.
            self.model.notice = Notice::until_moved(if follow {
                "Compare follows the current step now: the methods run again to it".into()
            } else {
                "Compare shows each method at its end now: the methods run again to it".into()
            });
            return;
        }
        if !cmp.is_finished() {
            let (a, b) = cmp.progress();
            let eta = cmp
                .eta()
                .map_or("estimating the time left".to_string(), |s| {
                    format!("about {s:.0} s left")
                });
            let running: Vec<String> = cmp
                .runs
                .iter()
                .filter(|r| !r.done())
                .map(|r| r.method.to_string())
                .collect();
            ui.add(
                egui::ProgressBar::new(a as f32 / b.max(1) as f32)
                    .desired_width(ui.available_width().min(600.0))
                    .text(format!(
                        "running {}: {a}/{b} steps, {eta}",
                        running.join(", ")
                    )),
            );
            if ui.button("Stop").clicked() {
                self.model.comparison = None;
            }
            return;
        }
        let view = self.model.view;
        let maps = compare::compared_maps(&self.model);
        let range = self
            .model
            .scene()
            .and_then(|s| s.views.get(view))
            .map(|v| (v.depth_range.min as f32, v.depth_range.max as f32))
            .unwrap_or((0.0, 1.0));
        let shown = compare::Shown {
            cmp,
            view,
            maps,
            range,
            version: self.model.version,
        };
        self.compare_view.ui(ui, &shown);
    }

    /// The parameters as a side panel beside the maps (a window over them hid both panes).
    pub(super) fn params_panel(&mut self, ui: &mut egui::Ui) {
        let mut open = self.show_params;
        let mut changed = false;
        egui::Panel::right("parameters")
            .resizable(true)
            .default_size(440.0)
            .size_range(300.0..=640.0)
            .show(ui, |ui| {
                ui.horizontal(|ui| {
                    ui.heading("Parameters");
                    if ui.button("Close").clicked() {
                        open = false;
                    }
                });
                egui::ScrollArea::vertical().show(ui, |ui| {
                    let edit = params_editor(ui, &mut self.edit);
                    changed = edit.commit;
                    if let Some(e) = edit.error {
                        self.param_error = Some(e);
                    } else if edit.commit {
                        self.param_error = None;
                    }
                    if let Some(e) = &self.param_error {
                        ui.colored_label(
                            Color32::from_rgb(255, 120, 90),
                            format!("not applied: {e}"),
                        );
                    }
                    ui.separator();
                    ui.horizontal(|ui| {
                        if ui.button("Reset to defaults").clicked() {
                            self.edit = self.model.method.defaults();
                            changed = true;
                        }
                    });
                });
            });
        self.show_params = open;
        if changed && self.edit != self.model.params {
            match self.edit.validate() {
                Ok(()) => self.model.set_params(self.edit.clone()),
                Err(e) => self.param_error = Some(e.to_string()),
            }
        }
    }

    pub(super) fn inspector_window(&mut self, ctx: &egui::Context) {
        let mut open = self.show_inspector;
        self.refresh_inspector();
        let view = self.inspector_view.as_ref();
        let screen = ctx.content_rect();
        // Big enough for the cost matrix, votes and weights, left of the timeline.
        let size = Vec2::new(480.0, 620.0);
        let mut window = egui::Window::new("Pixel inspector")
            .open(&mut open)
            .default_size(size)
            .default_pos(screen.right_top() + Vec2::new(-820.0, 60.0))
            .vscroll(true);
        if let Some(at) = self.inspector_at.take() {
            // Within the maps' side of the window: the scene panel's view list stays free.
            let area = Rect::from_min_max(
                Pos2::new(self.maps_left.max(screen.left()), screen.top()),
                screen.right_bottom(),
            );
            window = window.current_pos(beside(at, size, area, self.inspector_gap));
        }
        let shown = window.show(ctx, |ui| {
            let Some((x, y)) = self.model.inspect() else {
                ui.label("Click a pixel of a map.");
                return;
            };
            ui.label(format!("Pixel ({x}, {y}) of view {}", self.model.view));
            if self.model.is_replaying() {
                // The maps are those of earlier steps until the replay ends.
                ui.label(format!(
                    "replaying... the numbers appear when the replay is back at step {}",
                    self.model.target.unwrap_or(0)
                ));
                return;
            }
            if let Some((p, cost)) = view.and_then(|v| v.now) {
                ui.label(format!(
                    "now: depth {:.4}, normal ({:.3}, {:.3}, {:.3}), cost {cost:.4}",
                    p[3], p[0], p[1], p[2]
                ));
            }
            if let Some((index, cell)) = view.and_then(|v| v.support.as_ref()) {
                ui.separator();
                support_ui(ui, *index, cell, &self.model.params);
            }
            if let Some(r) = view.and_then(|v| v.restorer) {
                ui.separator();
                ui.strong("Detail restorer (Sec. 5.2)");
                ui.label(format!(
                    "C_init - C_photo = {:.4} -> {}",
                    r.difference,
                    if r.replaced {
                        "an error in the details: replaced by this scale's plane (> ξ)"
                    } else {
                        "not an error in the details (≤ ξ)"
                    }
                ));
            }
            ui.separator();
            match view.and_then(|v| v.inspection.as_ref().map(|i| (i, &v.patches))) {
                Some((ins, patches)) => {
                    inspection_ui(ui, ins, self.model.params.tau1, patches.as_ref())
                }
                None if self.model.is_running() => {
                    ui.label("Replaying to record the state this pixel's last update read...");
                }
                None => {
                    ui.label(
                        "No half-iteration of this pixel's colour has run in this view at \
                             this scale yet: step forward to see how it is updated.",
                    );
                }
            }
        });
        self.inspector_rect = shown.map(|r| r.response.rect);
        self.show_inspector = open;
    }

    /// The guided tour as a strip under the maps (a window over them hid the map's corner
    /// in every screenshot): the page of the current step, its paper section, and a button
    /// that shows the map it talks about.
    pub(super) fn tour_panel(&mut self, ui: &mut egui::Ui) {
        let mut open = self.show_tour;
        let step = self.model.current_step();
        let page = tour::page(step.as_ref(), self.model.method);
        let mut look = None;
        egui::Panel::bottom("tour")
            .resizable(true)
            .default_size(120.0)
            .size_range(60.0..=320.0)
            .show(ui, |ui| {
                ui.horizontal(|ui| {
                    ui.strong("Guided tour");
                    if ui.small_button("Close").clicked() {
                        open = false;
                    }
                    if self.model.session.is_some() {
                        ui.separator();
                        ui.strong(format!("{} - {}", page.section, page.title));
                    }
                });
                egui::ScrollArea::vertical().show(ui, |ui| {
                    if self.model.session.is_none() {
                        ui.strong("No scene open");
                        ui.label(
                            "Open a scene to start: File > Open scene folder..., File > Open the \
                             demo scene, or drop a scene's folder or one of its files on the window.",
                        );
                        return;
                    }
                    ui.label(&page.text);
                    if ui
                        .button(format!("Show the {} map", page.look_at))
                        .clicked()
                    {
                        look = MapKind::from_name(page.look_at);
                    }
                });
            });
        if let Some(k) = look {
            self.set_map(0, k);
        }
        self.show_tour = open;
    }
}
