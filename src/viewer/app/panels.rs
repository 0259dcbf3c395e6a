//! The window's frame: the menu, the toolbar, the status bar, the scene panel (views and
//! thumbnails) and the timeline.

use super::*;

impl ViewerApp {
    pub(super) fn menu(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                #[cfg(not(target_arch = "wasm32"))]
                if ui.button("Open scene folder...").clicked() {
                    self.open_dialog(Purpose::OpenScene);
                    ui.close();
                }
                // In the browser the page's own file chooser reads the files as bytes.
                #[cfg(target_arch = "wasm32")]
                {
                    if ui.button("Open scene folder...").clicked() {
                        crate::viewer::browser::choose_scene(true);
                        ui.close();
                    }
                    if ui.button("Open a zip of a scene folder...").clicked() {
                        crate::viewer::browser::choose_scene(false);
                        ui.close();
                    }
                }
                if ui.button("Open the demo scene").clicked() {
                    self.options.scene = None;
                    self.open_initial();
                    ui.close();
                }
                ui.menu_button("Recent", |ui| {
                    if self.model.recent.is_empty() {
                        ui.label("(none yet)");
                    }
                    for path in self.model.recent.clone() {
                        if ui.button(path.display().to_string()).clicked() {
                            self.open_folder(&path);
                            ui.close();
                        }
                    }
                });
                ui.separator();
                if ui.button("Load parameters (TOML)...").clicked() {
                    self.open_dialog(Purpose::LoadParams);
                    ui.close();
                }
                if ui.button("Save parameters (TOML)...").clicked() {
                    self.open_dialog(Purpose::SaveParams);
                    ui.close();
                }
            });
            ui.menu_button("View", |ui| {
                ui.checkbox(&mut self.show_params, "Parameters");
                ui.checkbox(&mut self.show_inspector, "Pixel inspector");
                ui.checkbox(&mut self.show_tour, "Guided tour");
                let wide = ui.ctx().content_rect().width() >= NARROW_WINDOW;
                let mut panels = self.side_panels.unwrap_or(wide);
                if ui
                    .checkbox(&mut panels, "Scene and timeline panels")
                    .changed()
                {
                    self.side_panels = Some(panels);
                }
                if ui.button("Two panes").clicked() {
                    if self.panes.len() < 2 {
                        self.panes.push(Pane::new(MapKind::Cost));
                    }
                    ui.close();
                }
                if ui.button("One pane").clicked() {
                    self.panes.truncate(1);
                    ui.close();
                }
            });
        });
    }

    pub(super) fn toolbar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            ui.selectable_value(&mut self.tab, Tab::Maps, "Maps");
            ui.selectable_value(&mut self.tab, Tab::Cloud, "3D");
            // The comparison starts from its tab's button (it runs two more methods).
            ui.selectable_value(&mut self.tab, Tab::Compare, "Compare");
            ui.separator();
            let mut method = self.model.method;
            egui::ComboBox::new("method", "method")
                .selected_text(method.to_string())
                .show_ui(ui, |ui| {
                    for m in Method::ALL {
                        ui.selectable_value(&mut method, m, m.to_string());
                    }
                });
            if method != self.model.method {
                self.model.set_method(method);
                // The panel shows the parameters the method runs with.
                self.edit = self.model.params.clone();
            }
            ui.separator();
            // Without a scene there is nothing to step: the controls say so instead of
            // doing nothing.
            let has_scene = self.model.session.is_some();
            let button = |ui: &mut egui::Ui, text: &str, key: &str| {
                ui.add_enabled(has_scene, egui::Button::new(text))
                    .on_hover_text(key)
                    .on_disabled_hover_text("open a scene first")
                    .clicked()
            };
            if button(ui, "Reset", "Home") {
                self.model.reset();
            }
            if button(ui, "< Back", "<-") {
                self.model.step_back(self.unit);
            }
            if button(ui, "Step >", "->") {
                self.model.step(self.unit);
            }
            egui::ComboBox::new("unit", "step unit")
                .selected_text(format!("by {}", self.unit.title()))
                .show_ui(ui, |ui| {
                    for (i, u) in Unit::ALL.into_iter().enumerate() {
                        ui.selectable_value(
                            &mut self.unit,
                            u,
                            format!("{} ({})", u.title(), i + 1),
                        );
                    }
                });
            if self.model.is_running() {
                if ui.button("Pause").on_hover_text("Space").clicked() {
                    self.model.pause();
                }
            } else if button(ui, "Run to end", "Space") {
                self.model.run_to_end();
            }
            if self.tab == Tab::Maps {
                ui.separator();
                if ui
                    .button("Fit")
                    .on_hover_text("show each pane's whole map (F; double-click a pane)")
                    .clicked()
                {
                    self.fit_panes();
                }
                if self.panes.len() > 1 {
                    ui.checkbox(&mut self.link_panes, "link panes")
                        .on_hover_text("zoom and pan all panes together");
                }
            }
            let total = self.model.schedule().len();
            let cursor = self.model.cursor();
            let progress = if has_scene {
                format!("{cursor}/{total} steps")
            } else {
                "no scene open".to_string()
            };
            ui.add(
                egui::ProgressBar::new(cursor as f32 / total.max(1) as f32)
                    .desired_width(160.0)
                    .text(progress),
            );
        });
    }

    pub(super) fn status(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            let label = self
                .model
                .current_step()
                .map(|s| s.label())
                .unwrap_or_else(|| "not started".into());
            ui.label(format!("Last step: {label}"));
            ui.separator();
            let step = if self.model.last_step.is_zero() {
                "step -".to_string()
            } else {
                format!("step {:.1} ms", self.model.last_step.as_secs_f64() * 1e3)
            };
            let frame = if self.frame_times.is_empty() {
                "frame -".to_string()
            } else {
                format!("frame {:.1} ms", mean(&self.frame_times) * 1e3)
            };
            ui.label(format!(
                "{step} · {frame} · {}",
                self.model.ctx.adapter_name()
            ))
            .on_hover_text(
                "step: the device time of the last step run; frame: the time the last frames \
                 took to build (not the idle gaps between them)",
            );
            // The CLI prints this under the adapter and report.json carries it; the window
            // says it where the adapter is named, so a user comparing its maps with a
            // Vulkan run's knows why they differ.
            if let Some(caveat) = self.model.ctx.caveat() {
                ui.separator();
                ui.label(
                    egui::RichText::new("OpenGL, not Vulkan: maps differ from a Vulkan run's")
                        .color(Color32::from_rgb(240, 180, 60)),
                )
                .on_hover_text(caveat);
            }
            if let Some(session) = &self.model.session
                && session.is_batched()
            {
                ui.separator();
                let plan = session.batch_plan();
                let budget = plan.budget.map_or("the adapter's limits".to_string(), |b| {
                    format!("the {} MiB device budget", b >> 20)
                });
                ui.label(format!(
                    "in batches: {} of up to {} view{}",
                    plan.batches.len(),
                    plan.largest_batch(),
                    if plan.largest_batch() == 1 { "" } else { "s" }
                ))
                .on_hover_text(format!(
                    "every view at once would exceed {budget}: each stage streams its views \
                     through the device batch by batch (the maps are the same), the others \
                     wait in host memory; stepping back replays from the start"
                ));
            } else if let Some(session) = &self.model.session {
                ui.separator();
                let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
                ui.label(format!(
                    "checkpoints {} · {:.0} of {:.0} MiB",
                    session.checkpoint_count(),
                    mib(session.checkpoint_bytes()),
                    mib(session.checkpoint_budget())
                ))
                .on_hover_text(
                    "stepping back restores the latest checkpoint before the target and \
                     replays from it; the oldest are dropped to stay within the budget",
                );
            }
            if let Some(h) = &self.hover {
                ui.separator();
                ui.label(h);
            }
            if let Some(n) = &self.model.notice {
                ui.separator();
                ui.label(&n.text);
            }
            if let Some(p) = &self.loading {
                ui.separator();
                ui.spinner();
                ui.label(format!(
                    "loading {} ({:.0} s)",
                    p.path.display(),
                    p.started.elapsed().as_secs_f32()
                ));
            }
        });
        if let Some(e) = self.model.error.clone() {
            ui.horizontal(|ui| {
                if ui.button("Dismiss").clicked() {
                    self.model.error = None;
                }
                ui.add(
                    egui::Label::new(
                        egui::RichText::new(format!("Error: {e}"))
                            .color(Color32::from_rgb(255, 110, 100)),
                    )
                    .wrap(),
                );
            });
        }
    }

    pub(super) fn scene_panel(&mut self, ui: &mut egui::Ui) {
        let Some(loaded) = &self.model.loaded else {
            ui.label("No scene. File > Open scene folder..., or drop a folder here.");
            return;
        };
        ui.heading(&loaded.name);
        let scene = loaded.scene.clone();
        ui.label(format!("{} views", scene.views.len()));
        egui::ScrollArea::vertical()
            .id_salt("views")
            .max_height(ui.available_height() * 0.6)
            .show(ui, |ui| {
                for (i, view) in scene.views.iter().enumerate() {
                    let thumb = self.thumbnail(ui.ctx(), i);
                    let selected = i == self.model.view;
                    ui.horizontal(|ui| {
                        if let Some(t) = &thumb {
                            let size = t.size_vec2();
                            let s = 56.0 / size.x.max(1.0);
                            ui.image((t.id(), size * s));
                        }
                        if ui
                            .selectable_label(selected, format!("{i}: {}", view.name))
                            .clicked()
                        {
                            self.model.set_view(i);
                        }
                    });
                }
            });
        ui.separator();
        if let Some(view) = scene.views.get(self.model.view) {
            ui.label(format!(
                "Reference {}: {}x{}, depth {:.3}..{:.3}",
                self.model.view,
                view.image.width,
                view.image.height,
                view.depth_range.min,
                view.depth_range.max
            ));
            ui.label("Sources (score):");
            for (j, s) in view.sources.iter().enumerate() {
                ui.label(format!(
                    "  #{j} view {} ({}) · {:.2}",
                    s.index, scene.views[s.index].name, s.score
                ));
            }
        }
    }

    pub(super) fn thumbnail(
        &mut self,
        ctx: &egui::Context,
        i: usize,
    ) -> Option<egui::TextureHandle> {
        if let Some(t) = self.thumbs.get(&i) {
            return Some(t.clone());
        }
        let view = self.model.scene()?.views.get(i)?;
        let w = 96u32;
        let h =
            ((view.image.height as f32 * w as f32 / view.image.width as f32).round() as u32).max(1);
        let small = view.image.resized(w, h);
        let mut rgba = Vec::with_capacity((w * h * 4) as usize);
        for px in &small.rgb {
            rgba.extend_from_slice(px);
            rgba.push(255);
        }
        let image = egui::ColorImage::from_rgba_unmultiplied([w as usize, h as usize], &rgba);
        let t = ctx.load_texture(format!("thumb{i}"), image, egui::TextureOptions::LINEAR);
        self.thumbs.insert(i, t.clone());
        Some(t)
    }

    pub(super) fn timeline_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Timeline");
        let groups = timeline::tree(self.model.schedule());
        let cursor = self.model.cursor();
        let mut goto = None;
        // When the run moved: open the path to the current step, fold the rest, and scroll
        // the current step into view. Otherwise leave the folding to the user.
        let moved = self.timeline_cursor != Some((cursor, groups.len()));
        self.timeline_cursor = Some((cursor, groups.len()));
        egui::ScrollArea::vertical()
            .id_salt("timeline")
            .show(ui, |ui| {
                for g in &groups {
                    timeline_group(ui, g, cursor, moved, &mut goto, 0);
                }
            });
        if let Some(t) = goto {
            self.model.run_to(t);
        }
    }
}

pub(super) fn timeline_group(
    ui: &mut egui::Ui,
    g: &Group,
    cursor: usize,
    moved: bool,
    goto: &mut Option<usize>,
    depth: usize,
) {
    let done = g.range.end <= cursor;
    // The group holding the last step run (or the first, before any).
    let current = g.range.start < cursor.max(1) && cursor.max(1) <= g.range.end;
    let mark = if done {
        "[x]"
    } else if current || (g.range.start <= cursor && cursor < g.range.end) {
        ">"
    } else {
        "[ ]"
    };
    if g.children.is_empty() {
        let text = format!("{mark} {}", g.title);
        let r = ui.selectable_label(g.range.end == cursor, text);
        if moved && g.range.end == cursor {
            r.scroll_to_me(Some(egui::Align::Center));
        }
        if r.clicked() {
            *goto = Some(g.range.end);
        }
        return;
    }
    let id = ui.make_persistent_id(("tl", g.range.start, g.range.end, depth));
    egui::CollapsingHeader::new(format!("{mark} {}", g.title))
        .id_salt(id)
        .open(moved.then_some(current))
        .show(ui, |ui| {
            for c in &g.children {
                timeline_group(ui, c, cursor, moved, goto, depth + 1);
            }
        });
}
