//! The egui side of the viewer: panels, panes, the timeline, the inspector, parameters, the
//! comparison and the tour. All state worth testing lives in [`Model`].

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use egui::{Color32, Pos2, Rect, Sense, Vec2};

use super::ViewerOptions;
use super::cloud::{CloudView, ColorMode};
use super::inspector::{self, Inspection, RestorerPixel};
use super::maps::{
    Colormap, MapKind, MapRenderer, MapSources, MapTarget, describe_value, natural_range,
    percentile_range,
};
use super::model::{CloudSource, LoadResult, Model};
use super::timeline::{self, Group, Unit};
use super::tour;
use crate::acmm::params::{Method, Params};
use crate::acmm::session::{GpuMaps, ViewMaps};

/// Which big area is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tab {
    Maps,
    Cloud,
    Compare,
}

/// How a pane picks its colour range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RangeMode {
    /// 2nd to 98th percentile of the valid values (or the kind's natural range).
    Auto,
    /// The view's depth range (depth maps).
    DepthRange,
    Manual(f32, f32),
}

/// One map pane.
pub struct Pane {
    pub kind: MapKind,
    pub source: u32,
    pub colormap: Colormap,
    pub range_mode: RangeMode,
    /// The range the texture was coloured with.
    pub range: (f32, f32),
    target: Option<MapTarget>,
    texture: Option<egui::TextureId>,
    key: Option<PaneKey>,
    /// Per-pixel values of the drawn map (hover readout).
    pub values: Vec<[f32; 4]>,
    pub size: (u32, u32),
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct PaneKey {
    version: u64,
    view: usize,
    kind: MapKind,
    source: u32,
    colormap: Colormap,
    range_mode: RangeMode,
}

impl Pane {
    fn new(kind: MapKind) -> Pane {
        Pane {
            kind,
            source: 0,
            colormap: Colormap::Turbo,
            range_mode: RangeMode::Auto,
            range: (0.0, 1.0),
            target: None,
            texture: None,
            key: None,
            values: Vec::new(),
            size: (0, 0),
        }
    }

    /// The drawn texture, if any (tests read it back).
    pub fn target(&self) -> Option<&MapTarget> {
        self.target.as_ref()
    }
}

/// Zoom and pan shared by the panes: `zoom` screen points per map pixel (0: fit), `center`
/// the map pixel at the pane's centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapCamera {
    pub zoom: f32,
    pub center: Vec2,
}

/// What the inspector shows, computed once per step, view and pixel (not every frame: it
/// reads the view's maps back from the GPU and re-runs the CPU reference).
struct InspectorView {
    key: (u64, usize, (u32, u32)),
    inspection: Option<Inspection>,
    patches: Option<inspector::Patches>,
    /// The pixel's plane and cost now.
    now: Option<([f32; 4], f32)>,
    restorer: Option<RestorerPixel>,
}

/// The viewer application.
pub struct ViewerApp {
    pub model: Model,
    render_state: Option<egui_wgpu::RenderState>,
    renderer: Option<MapRenderer>,
    pub panes: Vec<Pane>,
    pub camera: MapCamera,
    pub tab: Tab,
    pub cloud_view: CloudView,
    pub unit: Unit,
    pub show_params: bool,
    pub show_inspector: bool,
    pub show_tour: bool,
    /// Text of the value under the cursor.
    pub hover: Option<String>,
    inspector_view: Option<InspectorView>,
    thumbs: HashMap<usize, egui::TextureHandle>,
    compare_targets: Vec<(MapTarget, egui::TextureId, u64)>,
    compare_diff: Option<(egui::TextureHandle, u64)>,
    compare_a: usize,
    compare_b: usize,
    frame_times: Vec<f32>,
    /// Parameters being edited (applied on change).
    edit: Params,
    /// Close the window after this many frames (`MVSCOPE_VIEW_FRAMES`, for smoke tests).
    pub exit_after_frames: Option<u64>,
    frames: u64,
    options: ViewerOptions,
    /// A scene being read on a worker thread (big images take seconds to decode).
    loading: Option<PendingLoad>,
}

/// A scene folder being loaded off the UI thread.
struct PendingLoad {
    path: PathBuf,
    started: Instant,
    result: mpsc::Receiver<LoadResult>,
}

const RECENT_KEY: &str = "mvscope.recent";

impl ViewerApp {
    /// The app on eframe's wgpu device, opening `options.scene` (or the demo scene).
    pub fn new(cc: &eframe::CreationContext<'_>, options: ViewerOptions) -> anyhow::Result<Self> {
        let Some(rs) = cc.wgpu_render_state.clone() else {
            anyhow::bail!("the viewer needs eframe's wgpu renderer (no wgpu render state)");
        };
        let ctx = super::context_from_render_state(&rs);
        let model = Model::new(ctx, options.params.clone(), options.method)
            .map_err(|e| anyhow::anyhow!("the ACMM shaders did not build: {e}"))?;
        let mut app = Self::bare(cc, model, options);
        if let Some(storage) = cc.storage
            && let Some(text) = storage.get_string(RECENT_KEY)
            && let Ok(recent) = serde_json::from_str(&text)
        {
            app.model.recent = recent;
        }
        app.open_initial();
        Ok(app)
    }

    /// The app on an existing model (headless use), opening `options.scene` or the demo.
    pub fn from_model(
        cc: &eframe::CreationContext<'_>,
        model: Model,
        options: ViewerOptions,
    ) -> Self {
        let mut app = Self::bare(cc, model, options);
        app.open_initial();
        app
    }

    fn bare(cc: &eframe::CreationContext<'_>, model: Model, options: ViewerOptions) -> Self {
        let render_state = cc.wgpu_render_state.clone();
        if let Some(rs) = &render_state {
            super::cloud::install(rs);
        }
        let renderer = match MapRenderer::new(&model.ctx) {
            Ok(r) => Some(r),
            Err(e) => {
                log::error!("map shaders: {e}");
                None
            }
        };
        let mut model = model;
        model.load_options = options.load.clone();
        ViewerApp {
            edit: model.params.clone(),
            model,
            render_state,
            renderer,
            panes: vec![Pane::new(MapKind::Depth)],
            camera: MapCamera {
                zoom: 0.0,
                center: Vec2::ZERO,
            },
            tab: Tab::Maps,
            cloud_view: CloudView::default(),
            unit: Unit::Half,
            show_params: false,
            show_inspector: false,
            show_tour: true,
            hover: None,
            inspector_view: None,
            thumbs: HashMap::new(),
            compare_targets: Vec::new(),
            compare_diff: None,
            compare_a: 1,
            compare_b: 0,
            frame_times: Vec::new(),
            options,
            exit_after_frames: None,
            frames: 0,
            loading: None,
        }
    }

    fn open_initial(&mut self) {
        let loaded = match &self.options.scene {
            Some(path) => Model::load_folder(path, &self.options.load),
            None => {
                let software = self.model.ctx.info.device_type == wgpu::DeviceType::Cpu;
                let (w, h) = self.options.demo_size.unwrap_or(if software {
                    (320, 240)
                } else {
                    (640, 480)
                });
                let views = self.options.demo_views.unwrap_or(5);
                if software && self.options.demo_size.is_none() {
                    self.model.notice = Some(format!(
                        "software GPU ({}): the demo scene runs at {w}x{h}",
                        self.model.ctx.info.name
                    ));
                }
                Model::demo(w, h, views)
            }
        };
        self.show_loaded(loaded);
    }

    /// Makes `loaded` the open scene (or shows its error). A folder still loading is
    /// superseded: it was asked for before this.
    fn show_loaded(&mut self, loaded: LoadResult) {
        self.loading = None;
        self.model.open(loaded);
        self.thumbs.clear();
        self.compare_targets.clear();
    }

    /// Shows `kind` in pane `pane` (adding panes as needed).
    pub fn set_map(&mut self, pane: usize, kind: MapKind) {
        while self.panes.len() <= pane {
            self.panes.push(Pane::new(MapKind::Image));
        }
        self.panes[pane].kind = kind;
        self.tab = Tab::Maps;
    }

    pub fn show_cloud(&mut self) {
        self.tab = Tab::Cloud;
    }

    /// Re-draws every pane whose inputs changed (a GPU extract + colourize each).
    pub fn update_panes(&mut self) {
        for p in 0..self.panes.len() {
            if let Err(e) = self.update_pane(p) {
                self.model.error = Some(e);
            }
        }
    }

    fn update_pane(&mut self, p: usize) -> Result<(), String> {
        let Some(renderer) = &self.renderer else {
            return Ok(());
        };
        let pane = &self.panes[p];
        let key = PaneKey {
            version: self.model.version,
            view: self.model.view,
            kind: pane.kind,
            source: pane.source,
            colormap: pane.colormap,
            range_mode: pane.range_mode,
        };
        if pane.key == Some(key) {
            return Ok(());
        }
        let view = self.model.view;
        let maps: GpuMaps = match self.model.gpu_maps().map_err(|e| e.to_string())? {
            Some(m) => m,
            None => match self.blank_maps() {
                Some(m) => m,
                None => return Ok(()),
            },
        };
        let (w, h) = (maps.width, maps.height);
        let Some(image) = self.model.image_buffer(view, w, h) else {
            return Ok(());
        };
        let truth = self.model.truth_buffer(view, w, h);
        let ctx = &self.model.ctx;
        let pane = &mut self.panes[p];
        if pane
            .target
            .as_ref()
            .is_none_or(|t| (t.width, t.height) != (w, h))
        {
            pane.target = Some(MapTarget::new(ctx, w, h));
        }
        let Some(target) = &pane.target else {
            return Ok(());
        };
        let sources = MapSources {
            maps: &maps,
            image: &image,
            ground_truth: truth.as_ref(),
        };
        renderer
            .extract(ctx, &sources, pane.kind, pane.source, target)
            .map_err(|e| e.to_string())?;
        pane.values = renderer
            .read_values(ctx, target)
            .map_err(|e| e.to_string())?;
        let depth_range = self
            .model
            .session
            .as_ref()
            .and_then(|s| {
                s.level_scene(0)
                    .views
                    .get(view)
                    .map(|v| (v.depth_range.min as f32, v.depth_range.max as f32))
            })
            .unwrap_or((0.0, 1.0));
        pane.range = match pane.range_mode {
            RangeMode::Manual(lo, hi) => (lo, hi),
            RangeMode::DepthRange if pane.kind == MapKind::Depth => depth_range,
            _ => natural_range(pane.kind, maps.num_sources)
                .or_else(|| percentile_range(pane.kind, &pane.values, 2.0, 98.0))
                .unwrap_or((0.0, 1.0)),
        };
        renderer
            .colorize(
                ctx,
                target,
                pane.kind,
                pane.colormap,
                pane.range.0,
                pane.range.1,
            )
            .map_err(|e| e.to_string())?;
        pane.size = (w, h);
        if let Some(rs) = &self.render_state {
            let mut r = rs.renderer.write();
            match pane.texture {
                Some(id) => r.update_egui_texture_from_wgpu_texture(
                    &rs.device,
                    &target.view,
                    wgpu::FilterMode::Nearest,
                    id,
                ),
                None => {
                    pane.texture = Some(r.register_native_texture(
                        &rs.device,
                        &target.view,
                        wgpu::FilterMode::Nearest,
                    ))
                }
            }
        }
        pane.key = Some(key);
        Ok(())
    }

    /// Maps with no estimate yet (before the view's first step): the image still shows.
    fn blank_maps(&self) -> Option<GpuMaps> {
        let scene = self.model.session.as_ref()?.level_scene(0);
        let view = scene.views.get(self.model.view)?;
        let empty = ViewMaps::empty(0, view.image.width, view.image.height);
        Some(GpuMaps::upload(&self.model.ctx, &empty))
    }

    /// What the inspector shows for the inspected pixel, if a capture covers it.
    pub fn inspection(&self) -> Option<Inspection> {
        let (x, y) = self.model.inspect()?;
        inspector::inspect(self.model.capture_for(x, y)?, x, y)
    }

    /// Brings [`InspectorView`] up to date with the step, view and inspected pixel.
    fn refresh_inspector(&mut self) {
        let Some(pixel) = self.model.inspect() else {
            self.inspector_view = None;
            return;
        };
        let key = (self.model.version, self.model.view, pixel);
        if self.inspector_view.as_ref().is_some_and(|v| v.key == key) {
            return;
        }
        let (x, y) = pixel;
        let inspection = self.inspection();
        let patches = inspection.as_ref().and_then(|ins| {
            let cap = self.model.capture_for(x, y)?;
            Some(inspector::warped_patches(
                &cap.problem,
                &cap.params,
                ins.update.plane,
                x,
                y,
            ))
        });
        let maps = self.model.maps();
        let pixel_index = maps.as_ref().and_then(|m| {
            (x < m.state.width && y < m.state.height).then_some((y * m.state.width + x) as usize)
        });
        let (now, restorer) = match (&maps, pixel_index) {
            (Some(m), Some(i)) => (
                Some((m.state.plane[i], m.state.cost[i])),
                RestorerPixel::from_maps(m, i),
            ),
            _ => (None, None),
        };
        self.inspector_view = Some(InspectorView {
            key,
            inspection,
            patches,
            now,
            restorer,
        });
    }

    fn keyboard(&mut self, ctx: &egui::Context) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        use egui::Key;
        let pressed = |k: Key| ctx.input(|i| i.key_pressed(k));
        if pressed(Key::ArrowRight) {
            self.model.step(self.unit);
        }
        if pressed(Key::ArrowLeft) {
            self.model.step_back(self.unit);
        }
        if pressed(Key::Space) {
            if self.model.is_running() {
                self.model.pause();
            } else {
                self.model.run_to_end();
            }
        }
        if pressed(Key::Home) {
            self.model.reset();
        }
        for (k, u) in [Key::Num1, Key::Num2, Key::Num3, Key::Num4, Key::Num5]
            .into_iter()
            .zip(Unit::ALL)
        {
            if pressed(k) {
                self.unit = u;
            }
        }
    }

    fn dropped_files(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .collect()
        });
        if let Some(path) = dropped.into_iter().next() {
            let folder = if path.is_dir() {
                path
            } else {
                path.parent().map(|p| p.to_path_buf()).unwrap_or(path)
            };
            self.open_folder(&folder);
        }
    }

    /// Opens a scene folder (errors appear in the window).
    /// Starts loading a scene folder on a worker thread; the open scene stays usable until
    /// it arrives (errors appear in the window). A newer request supersedes an older one.
    pub fn open_folder(&mut self, path: &Path) {
        let (tx, rx) = mpsc::channel();
        let folder = path.to_path_buf();
        let options = self.model.load_options.clone();
        std::thread::spawn(move || {
            // The receiver may be gone (superseded); nothing to do then.
            let _ = tx.send(Model::load_folder(&folder, &options));
        });
        self.loading = Some(PendingLoad {
            path: path.to_path_buf(),
            started: Instant::now(),
            result: rx,
        });
    }

    /// Whether a scene folder is being loaded.
    pub fn is_loading(&self) -> bool {
        self.loading.is_some()
    }

    /// Takes the loaded scene when the worker is done.
    fn poll_loading(&mut self, ctx: &egui::Context) {
        let Some(pending) = &self.loading else {
            return;
        };
        let loaded = match pending.result.try_recv() {
            Ok(loaded) => loaded,
            Err(mpsc::TryRecvError::Empty) => {
                ctx.request_repaint_after(Duration::from_millis(50));
                return;
            }
            Err(mpsc::TryRecvError::Disconnected) => Err(format!(
                "loading {} stopped without a result (the loader thread panicked)",
                pending.path.display()
            )),
        };
        self.show_loaded(loaded);
        ctx.request_repaint();
    }

    fn menu(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open scene folder...").clicked() {
                    if let Some(path) = rfd::FileDialog::new().pick_folder() {
                        self.open_folder(&path);
                    }
                    ui.close();
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
                    if let Some(path) = rfd::FileDialog::new()
                        .add_filter("TOML", &["toml"])
                        .pick_file()
                    {
                        match Params::from_toml_file(&path) {
                            Ok(p) => {
                                self.edit = p.clone();
                                self.model.set_params(p);
                            }
                            Err(e) => self.model.error = Some(e.to_string()),
                        }
                    }
                    ui.close();
                }
                if ui.button("Save parameters (TOML)...").clicked() {
                    if let Some(path) = rfd::FileDialog::new()
                        .add_filter("TOML", &["toml"])
                        .set_file_name("params.toml")
                        .save_file()
                        && let Err(e) = save_params(&self.model.params, &path)
                    {
                        self.model.error = Some(e);
                    }
                    ui.close();
                }
            });
            ui.menu_button("View", |ui| {
                ui.checkbox(&mut self.show_params, "Parameters");
                ui.checkbox(&mut self.show_inspector, "Pixel inspector");
                ui.checkbox(&mut self.show_tour, "Guided tour");
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

    fn toolbar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            ui.selectable_value(&mut self.tab, Tab::Maps, "Maps");
            ui.selectable_value(&mut self.tab, Tab::Cloud, "3D");
            if ui
                .selectable_value(&mut self.tab, Tab::Compare, "Compare")
                .clicked()
                && self.model.comparison.is_none()
            {
                self.model.start_comparison();
            }
            ui.separator();
            let mut method = self.model.method;
            egui::ComboBox::new("method", "method")
                .selected_text(method.to_string())
                .show_ui(ui, |ui| {
                    for m in [Method::Acmm, Method::Acmh, Method::Dwta] {
                        ui.selectable_value(&mut method, m, m.to_string());
                    }
                });
            if method != self.model.method {
                self.model.set_method(method);
            }
            ui.separator();
            if ui.button("Reset").on_hover_text("Home").clicked() {
                self.model.reset();
            }
            if ui.button("< Back").on_hover_text("<-").clicked() {
                self.model.step_back(self.unit);
            }
            if ui.button("Step >").on_hover_text("->").clicked() {
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
            } else if ui.button("Run to end").on_hover_text("Space").clicked() {
                self.model.run_to_end();
            }
            let total = self.model.schedule().len().max(1);
            let cursor = self.model.cursor();
            ui.add(
                egui::ProgressBar::new(cursor as f32 / total as f32)
                    .desired_width(160.0)
                    .text(format!("{cursor}/{total} steps")),
            );
        });
    }

    fn status(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            let label = self
                .model
                .current_step()
                .map(|s| s.label())
                .unwrap_or_else(|| "not started".into());
            ui.label(format!("Last step: {label}"));
            ui.separator();
            ui.label(format!(
                "step {:.1} ms · frame {:.1} ms · {}",
                self.model.last_step.as_secs_f64() * 1e3,
                mean(&self.frame_times) * 1e3,
                self.model.ctx.info.name
            ));
            if let Some(h) = &self.hover {
                ui.separator();
                ui.label(h);
            }
            if let Some(n) = &self.model.notice {
                ui.separator();
                ui.label(n);
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

    fn scene_panel(&mut self, ui: &mut egui::Ui) {
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

    fn thumbnail(&mut self, ctx: &egui::Context, i: usize) -> Option<egui::TextureHandle> {
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

    fn timeline_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Timeline");
        let groups = timeline::tree(self.model.schedule());
        let cursor = self.model.cursor();
        let mut goto = None;
        egui::ScrollArea::vertical()
            .id_salt("timeline")
            .show(ui, |ui| {
                for g in &groups {
                    timeline_group(ui, g, cursor, &mut goto, 0);
                }
            });
        if let Some(t) = goto {
            self.model.run_to(t);
        }
    }

    fn maps_tab(&mut self, ui: &mut egui::Ui) {
        self.update_panes();
        let n = self.panes.len();
        let mut hover: Option<String> = None;
        let mut clicked = None;
        self.refresh_inspector();
        let inspection_origins = self
            .inspector_view
            .as_ref()
            .and_then(|v| v.inspection.as_ref())
            .map(|i| (i.x, i.y, i.origins))
            .or_else(|| self.model.inspect().map(|(x, y)| (x, y, [None; 8])));
        let camera = &mut self.camera;
        let nsrc = self
            .model
            .session
            .as_ref()
            .and_then(|s| s.level_scene(0).views.get(self.model.view))
            .map_or(0, |v| v.sources.len());
        let available = ui.available_size();
        let pane_w = (available.x - 8.0 * (n as f32 - 1.0)) / n as f32;
        ui.horizontal_top(|ui| {
            for (p, pane) in self.panes.iter_mut().enumerate() {
                ui.allocate_ui(Vec2::new(pane_w, available.y), |ui| {
                    ui.vertical(|ui| {
                        pane_controls(ui, p, pane, nsrc);
                        let (h, c) = draw_pane(ui, p, pane, camera, inspection_origins);
                        if hover.is_none() {
                            hover = h;
                        }
                        if clicked.is_none() {
                            clicked = c;
                        }
                    });
                });
            }
        });
        self.hover = hover;
        if let Some(px) = clicked {
            self.model.inspect_pixel(px);
            self.show_inspector = true;
        }
    }

    fn cloud_tab(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            if ui
                .button("Fuse")
                .on_hover_text("re-fuse the current maps")
                .clicked()
                && let Err(e) = self.model.refuse()
            {
                self.model.error = Some(e.to_string());
            }
            if ui.button("This view's depth").clicked() {
                self.model.backproject(false);
            }
            if ui.button("All views' depth").clicked() {
                self.model.backproject(true);
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
        self.cloud_view.ui(ui, &scene);
    }

    fn compare_tab(&mut self, ui: &mut egui::Ui) {
        let Some(cmp) = &self.model.comparison else {
            ui.label("Open a scene to compare ACMH, ACMM and DWTA.");
            if ui.button("Start").clicked() {
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
            return;
        }
        if !cmp.is_finished() {
            let (a, b) = cmp.progress();
            ui.add(
                egui::ProgressBar::new(a as f32 / b.max(1) as f32)
                    .text(format!("running ACMH, ACMM and DWTA: {a}/{b} steps")),
            );
            return;
        }
        let stops: Vec<String> = cmp
            .runs
            .iter()
            .map(|r| {
                let at = r
                    .session
                    .cursor()
                    .checked_sub(1)
                    .and_then(|i| r.session.schedule().get(i))
                    .map(|s| s.label())
                    .unwrap_or_else(|| "not started".into());
                let note = if r.matched {
                    ""
                } else {
                    " (its end: no such step)"
                };
                format!("{}: {at}{note}", r.method)
            })
            .collect();
        let results = self.model.comparison_depths();
        let accuracy: Vec<Vec<Option<(f64, f64)>>> =
            cmp.runs.iter().map(|r| r.accuracy.clone()).collect();
        let view = self.model.view;
        // The pictures change with the view and where the runs stopped, not with the main
        // session's steps.
        let key = {
            use std::hash::{Hash, Hasher};
            let mut h = std::collections::hash_map::DefaultHasher::new();
            view.hash(&mut h);
            for r in &cmp.runs {
                r.session.cursor().hash(&mut h);
            }
            h.finish()
        };
        if self.compare_targets.len() != results.len()
            || self.compare_targets.iter().any(|t| t.2 != key)
        {
            self.build_compare_textures(&results);
            for t in &mut self.compare_targets {
                t.2 = key;
            }
            self.compare_diff = None;
        }
        ui.label(format!(
            "View {view}, same parameters, depth in one colour range. Stopped at:"
        ));
        for s in &stops {
            ui.small(s);
        }
        ui.horizontal_top(|ui| {
            let w = (ui.available_width() - 24.0) / 4.0;
            for (k, (method, _)) in results.iter().enumerate() {
                ui.vertical(|ui| {
                    ui.strong(method.to_string());
                    if let Some((t, id, _)) = self.compare_targets.get(k) {
                        let s = w / t.width as f32;
                        ui.image((*id, Vec2::new(t.width as f32, t.height as f32) * s));
                    }
                    match accuracy.get(k).and_then(|a| a.get(view).copied().flatten()) {
                        Some((a1, a2)) => {
                            ui.label(format!(
                                "within 1%: {:.1}%  within 2%: {:.1}%",
                                a1 * 100.0,
                                a2 * 100.0
                            ));
                        }
                        None => {
                            ui.label("no ground truth");
                        }
                    }
                });
            }
            ui.vertical(|ui| {
                ui.horizontal(|ui| {
                    let names: Vec<String> = results.iter().map(|r| r.0.to_string()).collect();
                    let mut a = self.compare_a;
                    let mut b = self.compare_b;
                    egui::ComboBox::new("cmp_a", "minus")
                        .selected_text(names.get(a).cloned().unwrap_or_default())
                        .show_ui(ui, |ui| {
                            for (i, n) in names.iter().enumerate() {
                                ui.selectable_value(&mut a, i, n);
                            }
                        });
                    egui::ComboBox::new("cmp_b", "difference")
                        .selected_text(names.get(b).cloned().unwrap_or_default())
                        .show_ui(ui, |ui| {
                            for (i, n) in names.iter().enumerate() {
                                ui.selectable_value(&mut b, i, n);
                            }
                        });
                    if (a, b) != (self.compare_a, self.compare_b) {
                        self.compare_a = a;
                        self.compare_b = b;
                        self.compare_diff = None;
                    }
                });
                if self.compare_diff.as_ref().is_none_or(|d| d.1 != key) {
                    self.compare_diff =
                        difference_texture(ui.ctx(), &results, self.compare_a, self.compare_b)
                            .map(|t| (t, key));
                }
                if let Some((t, _)) = &self.compare_diff {
                    let size = t.size_vec2();
                    ui.image((t.id(), size * (w / size.x.max(1.0))));
                    ui.label("relative depth difference, blue -5% ... red +5%");
                }
            });
        });
    }

    fn build_compare_textures(&mut self, results: &[(Method, Option<ViewMaps>)]) {
        if let Some(rs) = &self.render_state {
            let mut r = rs.renderer.write();
            for (_, id, _) in &self.compare_targets {
                r.free_texture(id);
            }
        }
        self.compare_targets.clear();
        let (Some(renderer), Some(rs)) = (&self.renderer, &self.render_state) else {
            return;
        };
        let view = self.model.view;
        let range = self
            .model
            .scene()
            .and_then(|s| s.views.get(view))
            .map(|v| (v.depth_range.min as f32, v.depth_range.max as f32))
            .unwrap_or((0.0, 1.0));
        for (_, maps) in results {
            let Some(m) = maps else { continue };
            let st = &m.state;
            let ctx = &self.model.ctx;
            let n = st.plane.len();
            let gm = GpuMaps::upload(ctx, m);
            let image = ctx.storage_buffer("image", &vec![0u32; n]);
            let target = MapTarget::new(ctx, st.width, st.height);
            let sources = MapSources {
                maps: &gm,
                image: &image,
                ground_truth: None,
            };
            let ok = renderer
                .extract(ctx, &sources, MapKind::Depth, 0, &target)
                .and_then(|_| {
                    renderer.colorize(
                        ctx,
                        &target,
                        MapKind::Depth,
                        Colormap::Turbo,
                        range.0,
                        range.1,
                    )
                });
            if let Err(e) = ok {
                self.model.error = Some(e.to_string());
                return;
            }
            let id = rs.renderer.write().register_native_texture(
                &rs.device,
                &target.view,
                wgpu::FilterMode::Nearest,
            );
            self.compare_targets.push((target, id, view as u64));
        }
    }

    fn params_window(&mut self, ctx: &egui::Context) {
        let mut open = self.show_params;
        let mut changed = false;
        let right = ctx.content_rect().right_top();
        egui::Window::new("Parameters")
            .open(&mut open)
            .default_width(360.0)
            .default_pos(right + Vec2::new(-700.0, 90.0))
            .vscroll(true)
            .show(ctx, |ui| {
                changed = params_editor(ui, &mut self.edit);
                ui.separator();
                ui.horizontal(|ui| {
                    if ui.button("Reset to defaults").clicked() {
                        self.edit = Params::default();
                        changed = true;
                    }
                });
            });
        self.show_params = open;
        if changed && self.edit != self.model.params {
            match self.edit.validate() {
                Ok(()) => self.model.set_params(self.edit.clone()),
                Err(e) => self.model.notice = Some(format!("not applied: {e}")),
            }
        }
    }

    fn inspector_window(&mut self, ctx: &egui::Context) {
        let mut open = self.show_inspector;
        self.refresh_inspector();
        let view = self.inspector_view.as_ref();
        let right = ctx.content_rect().right_top();
        egui::Window::new("Pixel inspector")
            .open(&mut open)
            .default_width(460.0)
            .default_pos(right + Vec2::new(-480.0, 60.0))
            .vscroll(true)
            .show(ctx, |ui| {
                let Some((x, y)) = self.model.inspect() else {
                    ui.label("Click a pixel of a map.");
                    return;
                };
                ui.label(format!("Pixel ({x}, {y}) of view {}", self.model.view));
                if let Some((p, cost)) = view.and_then(|v| v.now) {
                    ui.label(format!(
                        "now: depth {:.4}, normal ({:.3}, {:.3}, {:.3}), cost {cost:.4}",
                        p[3], p[0], p[1], p[2]
                    ));
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
        self.show_inspector = open;
    }

    fn tour_window(&mut self, ctx: &egui::Context) {
        let mut open = self.show_tour;
        let step = self.model.current_step();
        let page = tour::page(step.as_ref(), self.model.method);
        let mut look = None;
        egui::Window::new("Guided tour")
            .open(&mut open)
            .default_width(320.0)
            .anchor(egui::Align2::LEFT_BOTTOM, Vec2::new(8.0, -40.0))
            .show(ctx, |ui| {
                ui.strong(format!("{} - {}", page.section, page.title));
                ui.label(&page.text);
                if ui
                    .button(format!("Show the {} map", page.look_at))
                    .clicked()
                {
                    look = MapKind::from_name(page.look_at);
                }
            });
        if let Some(k) = look {
            self.set_map(0, k);
        }
        self.show_tour = open;
    }
}

fn mean(v: &[f32]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
    }
}

fn save_params(params: &Params, path: &Path) -> Result<(), String> {
    let text = toml::to_string_pretty(params).map_err(|e| e.to_string())?;
    crate::io::write_atomic(path, |w| std::io::Write::write_all(w, text.as_bytes()))
        .map_err(|e| e.to_string())
}

fn timeline_group(
    ui: &mut egui::Ui,
    g: &Group,
    cursor: usize,
    goto: &mut Option<usize>,
    depth: usize,
) {
    let done = g.range.end <= cursor;
    let current = g.range.start <= cursor && cursor < g.range.end;
    let mark = if done {
        "[x]"
    } else if current {
        ">"
    } else {
        "[ ]"
    };
    if g.children.is_empty() {
        let text = format!("{mark} {}", g.title);
        let r = ui.selectable_label(g.range.end == cursor, text);
        if r.clicked() {
            *goto = Some(g.range.end);
        }
        return;
    }
    let id = ui.make_persistent_id(("tl", g.range.start, g.range.end, depth));
    egui::CollapsingHeader::new(format!("{mark} {}", g.title))
        .id_salt(id)
        .open(current.then_some(true))
        .show(ui, |ui| {
            for c in &g.children {
                timeline_group(ui, c, cursor, goto, depth + 1);
            }
        });
}

fn pane_controls(ui: &mut egui::Ui, p: usize, pane: &mut Pane, nsrc: usize) {
    ui.horizontal_wrapped(|ui| {
        egui::ComboBox::new(("kind", p), format!("map {p}"))
            .selected_text(pane.kind.title())
            .show_ui(ui, |ui| {
                for k in MapKind::ALL {
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
            egui::ComboBox::new(("cmap", p), "colours")
                .selected_text(pane.colormap.name())
                .show_ui(ui, |ui| {
                    for c in Colormap::ALL {
                        ui.selectable_value(&mut pane.colormap, c, c.name());
                    }
                });
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
        legend(ui, pane.colormap, pane.range, pane.kind.unit());
    }
}

fn legend(ui: &mut egui::Ui, cmap: Colormap, range: (f32, f32), unit: &str) {
    ui.horizontal(|ui| {
        ui.label(format!("{:.4}", range.0));
        let (rect, _) = ui.allocate_exact_size(Vec2::new(160.0, 12.0), Sense::hover());
        let steps = 64;
        for s in 0..steps {
            let t = s as f32 / (steps - 1) as f32;
            let c = cmap.color(t);
            let x0 = rect.left() + rect.width() * s as f32 / steps as f32;
            let x1 = rect.left() + rect.width() * (s + 1) as f32 / steps as f32;
            ui.painter().rect_filled(
                Rect::from_min_max(Pos2::new(x0, rect.top()), Pos2::new(x1, rect.bottom())),
                0.0,
                Color32::from_rgb(c[0], c[1], c[2]),
            );
        }
        ui.label(format!("{:.4} {unit}", range.1));
    });
}

/// The inspected pixel and where its 8 candidates came from.
type Inspected = (u32, u32, [Option<(u32, u32)>; 8]);

/// Draws a pane's texture with the shared zoom/pan; returns the hover text and a clicked pixel.
fn draw_pane(
    ui: &mut egui::Ui,
    index: usize,
    pane: &Pane,
    camera: &mut MapCamera,
    inspected: Option<Inspected>,
) -> (Option<String>, Option<(u32, u32)>) {
    let size = ui.available_size();
    let (rect, response) = ui.allocate_exact_size(size, Sense::click_and_drag());
    response.widget_info(|| {
        egui::WidgetInfo::labeled(egui::Role::Image, true, format!("map pane {index}"))
    });
    ui.painter().rect_filled(rect, 0.0, Color32::from_gray(20));
    let Some(texture) = pane.texture else {
        ui.painter().text(
            rect.center(),
            egui::Align2::CENTER_CENTER,
            "no map",
            egui::FontId::proportional(14.0),
            Color32::GRAY,
        );
        return (None, None);
    };
    let (w, h) = (pane.size.0 as f32, pane.size.1 as f32);
    let fit = (rect.width() / w).min(rect.height() / h);
    if camera.zoom <= 0.0 {
        camera.zoom = fit;
        camera.center = Vec2::new(w / 2.0, h / 2.0);
    }
    if response.hovered() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if scroll != 0.0 {
            let factor = (scroll * 0.002).exp();
            if let Some(pos) = response.hover_pos() {
                // Keep the map pixel under the cursor in place.
                let before = camera.center + (pos - rect.center()) / camera.zoom;
                camera.zoom = (camera.zoom * factor).clamp(fit * 0.25, 64.0);
                camera.center = before - (pos - rect.center()) / camera.zoom;
            }
        }
    }
    if response.dragged() {
        camera.center -= response.drag_delta() / camera.zoom;
    }
    if response.double_clicked() {
        camera.zoom = fit;
        camera.center = Vec2::new(w / 2.0, h / 2.0);
    }
    let to_screen =
        |px: f32, py: f32| rect.center() + (Vec2::new(px, py) - camera.center) * camera.zoom;
    let image_rect = Rect::from_min_max(to_screen(0.0, 0.0), to_screen(w, h));
    ui.painter().with_clip_rect(rect).image(
        texture,
        image_rect,
        Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
        Color32::WHITE,
    );
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
            Rect::from_center_size(c, Vec2::splat(camera.zoom.max(6.0))),
            0.0,
            egui::Stroke::new(1.5, Color32::YELLOW),
            egui::StrokeKind::Outside,
        );
    }
    let pixel_at = |pos: Pos2| {
        let m = camera.center + (pos - rect.center()) / camera.zoom;
        (m.x >= 0.0 && m.y >= 0.0 && m.x < w && m.y < h).then_some((m.x as u32, m.y as u32))
    };
    let hover = response.hover_pos().and_then(pixel_at).and_then(|(x, y)| {
        let i = (y * pane.size.0 + x) as usize;
        let v = pane.values.get(i)?;
        Some(format!("({x}, {y}) {}", describe_value(pane.kind, *v)))
    });
    let clicked = if response.clicked() {
        response.interact_pointer_pos().and_then(pixel_at)
    } else {
        None
    };
    (hover, clicked)
}

fn inspection_ui(
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
        super::maps::winner_label(u.winner.code())
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
        super::maps::winner_label(ins.gpu.winner)
    ));
    ui.separator();
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

fn patch_widget(ui: &mut egui::Ui, values: &[f32], size: usize, label: &str) {
    ui.vertical(|ui| {
        let cell = 4.0;
        let (rect, _) = ui.allocate_exact_size(Vec2::splat(cell * size as f32), Sense::hover());
        for (k, v) in values.iter().enumerate() {
            let (x, y) = ((k % size) as f32, (k / size) as f32);
            let c = if v.is_finite() {
                Color32::from_gray(v.clamp(0.0, 255.0) as u8)
            } else {
                Color32::from_rgb(80, 0, 0)
            };
            ui.painter().rect_filled(
                Rect::from_min_size(rect.min + Vec2::new(x, y) * cell, Vec2::splat(cell)),
                0.0,
                c,
            );
        }
        ui.small(label);
    });
}

/// Relative depth difference (a - b) / b of two methods' maps, coloured blue (-5%) to red (+5%).
fn difference_texture(
    ctx: &egui::Context,
    results: &[(Method, Option<ViewMaps>)],
    a: usize,
    b: usize,
) -> Option<egui::TextureHandle> {
    let ma = results.get(a)?.1.as_ref()?;
    let mb = results.get(b)?.1.as_ref()?;
    if (ma.state.width, ma.state.height) != (mb.state.width, mb.state.height) {
        return None;
    }
    let rgba: Vec<u8> = ma
        .state
        .plane
        .iter()
        .zip(&mb.state.plane)
        .flat_map(|(pa, pb)| {
            let (da, db) = (pa[3], pb[3]);
            if da > 0.0 && db > 0.0 {
                let t = ((da - db) / db / 0.05).clamp(-1.0, 1.0);
                let (r, g, bl) = if t >= 0.0 {
                    (255.0, 255.0 * (1.0 - t), 255.0 * (1.0 - t))
                } else {
                    (255.0 * (1.0 + t), 255.0 * (1.0 + t), 255.0)
                };
                [r as u8, g as u8, bl as u8, 255]
            } else {
                [30, 30, 30, 255]
            }
        })
        .collect();
    let image = egui::ColorImage::from_rgba_unmultiplied(
        [ma.state.width as usize, ma.state.height as usize],
        &rgba,
    );
    Some(ctx.load_texture("compare-diff", image, egui::TextureOptions::NEAREST))
}

/// One editable parameter: symbol, explanation, and the widget.
fn param_row(
    ui: &mut egui::Ui,
    symbol: &str,
    help: &str,
    widget: impl FnOnce(&mut egui::Ui) -> egui::Response,
) -> bool {
    let label = ui.label(symbol).on_hover_text(help);
    // The widget is named by its symbol (accessibility, and the UI tests find it so).
    let r = widget(ui).labelled_by(label.id);
    ui.small(help);
    ui.end_row();
    r.changed()
}

/// The parameter editor; returns whether anything changed.
pub fn params_editor(ui: &mut egui::Ui, p: &mut Params) -> bool {
    let mut changed = false;
    let section = |ui: &mut egui::Ui, t: &str| {
        ui.strong(t);
        ui.end_row();
    };
    egui::Grid::new("params")
        .num_columns(3)
        .striped(true)
        .show(ui, |ui| {
            section(ui, "View selection (Sec. 4.3)");
            changed |= param_row(
                ui,
                "τ0",
                "initial good-cost threshold; τ(t) = τ0·e^(-t²/α)",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.tau0)
                            .speed(0.01)
                            .range(0.01..=2.0),
                    )
                },
            );
            changed |= param_row(ui, "τ1", "bad-cost threshold (τ1 > τ(t))", |ui| {
                ui.add(
                    egui::DragValue::new(&mut p.tau1)
                        .speed(0.01)
                        .range(0.01..=2.0),
                )
            });
            changed |= param_row(
                ui,
                "α",
                "how fast τ(t) decays with the iteration t",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.alpha)
                            .speed(0.1)
                            .range(0.1..=1000.0),
                    )
                },
            );
            changed |= param_row(ui, "β", "confidence C(m) = e^(-m²/2β²)", |ui| {
                ui.add(
                    egui::DragValue::new(&mut p.beta)
                        .speed(0.01)
                        .range(0.01..=2.0),
                )
            });
            changed |= param_row(
                ui,
                "n1",
                "a view is selected when more than n1 costs are good...",
                |ui| ui.add(egui::DragValue::new(&mut p.n1).range(0..=8)),
            );
            changed |= param_row(ui, "n2", "...and fewer than n2 are bad", |ui| {
                ui.add(egui::DragValue::new(&mut p.n2).range(0..=9))
            });
            section(ui, "Matching cost (bilateral NCC)");
            changed |= param_row(ui, "window", "half size of the matching window", |ui| {
                ui.add(egui::DragValue::new(&mut p.window_radius).range(1..=10))
            });
            changed |= param_row(ui, "step", "sample every step-th row and column", |ui| {
                ui.add(egui::DragValue::new(&mut p.window_step).range(1..=5))
            });
            changed |= param_row(
                ui,
                "σs",
                "spatial spread of the bilateral weight (px)",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.sigma_spatial)
                            .speed(0.1)
                            .range(0.1..=50.0),
                    )
                },
            );
            changed |= param_row(
                ui,
                "σc",
                "intensity spread of the bilateral weight (grey levels)",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.sigma_color)
                            .speed(0.1)
                            .range(0.1..=255.0),
                    )
                },
            );
            section(ui, "Propagation and refinement (Sec. 4.1-4.4)");
            changed |= param_row(
                ui,
                "K",
                "initial and DWTA cost: mean of the K best views",
                |ui| ui.add(egui::DragValue::new(&mut p.top_k).range(1..=32)),
            );
            changed |= param_row(
                ui,
                "iterations",
                "red-black iterations of ACMH and DWTA as methods (paper: 6)",
                |ui| ui.add(egui::DragValue::new(&mut p.iterations).range(1..=16)),
            );
            changed |= param_row(
                ui,
                "perturb d",
                "refinement: relative depth perturbation",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.perturb_depth)
                            .speed(0.001)
                            .range(0.0..=0.5),
                    )
                },
            );
            changed |= param_row(ui, "perturb n", "refinement: normal tilt (rad)", |ui| {
                ui.add(
                    egui::DragValue::new(&mut p.perturb_normal)
                        .speed(0.001)
                        .range(0.0..=1.0),
                )
            });
            changed |= param_row(
                ui,
                "median",
                "half size of the median filter on depth",
                |ui| ui.add(egui::DragValue::new(&mut p.median_radius).range(0..=5)),
            );
            section(ui, "Multi-scale geometric consistency (Sec. 5)");
            changed |= param_row(ui, "k", "number of scales", |ui| {
                ui.add(egui::DragValue::new(&mut p.scales).range(1..=6))
            });
            changed |= param_row(ui, "η", "downsampling factor between scales", |ui| {
                ui.add(
                    egui::DragValue::new(&mut p.eta)
                        .speed(0.05)
                        .range(0.1..=0.9),
                )
            });
            changed |= param_row(ui, "δ", "truncation of the reprojection error (px)", |ui| {
                ui.add(
                    egui::DragValue::new(&mut p.delta)
                        .speed(0.1)
                        .range(0.1..=20.0),
                )
            });
            changed |= param_row(ui, "λ", "weight of the reprojection error in m_geo", |ui| {
                ui.add(
                    egui::DragValue::new(&mut p.lambda)
                        .speed(0.01)
                        .range(0.0..=2.0),
                )
            });
            changed |= param_row(
                ui,
                "ξ",
                "detail restorer: replace where C_init - C_photo > ξ",
                |ui| ui.add(egui::DragValue::new(&mut p.xi).speed(0.01).range(0.0..=2.0)),
            );
            changed |= param_row(
                ui,
                "restorer",
                "detail restorer: refine the upsampled planes (default), gate them by C_init - ξ, or start from random planes",
                |ui| {
                    use crate::acmm::RestorerMode;
                    let mut r = ui.radio_value(&mut p.restorer, RestorerMode::Refine, "refine");
                    r |= ui.radio_value(&mut p.restorer, RestorerMode::Gated, "gated");
                    r |= ui.radio_value(&mut p.restorer, RestorerMode::Random, "random");
                    r
                },
            );
            changed |= param_row(
                ui,
                "coarse iterations",
                "ACMM's photometric iterations at the coarsest scale (paper: 3 + 2x2 = 7)",
                |ui| ui.add(egui::DragValue::new(&mut p.coarse_iterations).range(1..=16)),
            );
            changed |= param_row(
                ui,
                "restorer iterations",
                "the detail restorer's iterations at finer scales (paper: 2 + 2x2 = 6)",
                |ui| ui.add(egui::DragValue::new(&mut p.restorer_iterations).range(1..=16)),
            );
            changed |= param_row(
                ui,
                "geo iterations",
                "red-black iterations per geometric pass",
                |ui| ui.add(egui::DragValue::new(&mut p.geometric_iterations).range(1..=16)),
            );
            changed |= param_row(
                ui,
                "geo passes",
                "geometric consistency passes per scale",
                |ui| ui.add(egui::DragValue::new(&mut p.geometric_passes).range(0..=4)),
            );
            changed |= param_row(
                ui,
                "JBU radius",
                "joint bilateral upsampling window (coarse px)",
                |ui| ui.add(egui::DragValue::new(&mut p.jbu_radius).range(0..=5)),
            );
            changed |= param_row(
                ui,
                "JBU σs",
                "joint bilateral upsampling spatial σ",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.jbu_sigma_spatial)
                            .speed(0.1)
                            .range(0.1..=10.0),
                    )
                },
            );
            changed |= param_row(
                ui,
                "JBU σr",
                "joint bilateral upsampling range σ (grey levels)",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.jbu_sigma_range)
                            .speed(0.5)
                            .range(0.1..=255.0),
                    )
                },
            );
            section(ui, "Fusion (Sec. 6)");
            changed |= param_row(
                ui,
                "ψ",
                "largest reprojection error of a consistent match (px)",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.fusion_reprojection)
                            .speed(0.1)
                            .range(0.0..=20.0),
                    )
                },
            );
            changed |= param_row(ui, "ε", "largest relative depth difference", |ui| {
                ui.add(
                    egui::DragValue::new(&mut p.fusion_relative_depth)
                        .speed(0.001)
                        .range(0.0..=1.0),
                )
            });
            changed |= param_row(ui, "θ", "largest normal angle (degrees)", |ui| {
                ui.add(
                    egui::DragValue::new(&mut p.fusion_normal_angle)
                        .speed(0.5)
                        .range(0.0..=180.0),
                )
            });
            changed |= param_row(ui, "n", "consistent views a point needs", |ui| {
                ui.add(egui::DragValue::new(&mut p.fusion_min_views).range(1..=32))
            });
            section(ui, "Depth range");
            changed |= param_row(
                ui,
                "range min ×",
                "each view's depth range starts at min × this (original code: 0.6)",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.depth_min_factor)
                            .speed(0.01)
                            .range(0.05..=1.0),
                    )
                },
            );
            changed |= param_row(
                ui,
                "range max ×",
                "each view's depth range ends at max × this (original code: 1.2)",
                |ui| {
                    ui.add(
                        egui::DragValue::new(&mut p.depth_max_factor)
                            .speed(0.01)
                            .range(1.0..=5.0),
                    )
                },
            );
            section(ui, "Randomness");
            changed |= param_row(ui, "seed", "seed of every random number", |ui| {
                ui.add(egui::DragValue::new(&mut p.seed))
            });
        });
    changed
}

impl eframe::App for ViewerApp {
    fn logic(&mut self, ctx: &egui::Context, _frame: &mut eframe::Frame) {
        let dt = ctx.input(|i| i.unstable_dt);
        self.frame_times.push(dt);
        if self.frame_times.len() > 60 {
            self.frame_times.remove(0);
        }
        self.keyboard(ctx);
        // Polled before new drops, so a load started this frame shows in this frame.
        self.poll_loading(ctx);
        self.dropped_files(ctx);
        self.frames += 1;
        if self.exit_after_frames.is_some_and(|n| self.frames >= n) {
            println!(
                "viewer: {} frames on {}, {} steps run",
                self.frames,
                self.model.ctx.info.name,
                self.model.cursor()
            );
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        // A slice of the run per frame keeps the UI responsive.
        if self.model.tick(Duration::from_millis(30)) {
            ctx.request_repaint();
        }
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        egui::Panel::top("menu").show(ui, |ui| {
            self.menu(ui);
            self.toolbar(ui);
        });
        egui::Panel::bottom("status").show(ui, |ui| self.status(ui));
        egui::Panel::left("scene")
            .default_size(240.0)
            .show(ui, |ui| self.scene_panel(ui));
        egui::Panel::right("timeline")
            .default_size(240.0)
            .show(ui, |ui| self.timeline_panel(ui));
        egui::CentralPanel::default_margins().show(ui, |ui| match self.tab {
            Tab::Maps => self.maps_tab(ui),
            Tab::Cloud => self.cloud_tab(ui),
            Tab::Compare => self.compare_tab(ui),
        });
        if self.show_params {
            self.params_window(&ctx);
        }
        if self.show_inspector && self.tab == Tab::Maps {
            self.inspector_window(&ctx);
        }
        if self.show_tour {
            self.tour_window(&ctx);
        }
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        if let Ok(text) = serde_json::to_string(&self.model.recent) {
            storage.set_string(RECENT_KEY, text);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saved_parameters_load_back_identically() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        let p = Params {
            tau0: 0.55,
            xi: 0.07,
            seed: 99,
            ..Params::default()
        };
        save_params(&p, &path).unwrap();
        assert_eq!(Params::from_toml_file(&path).unwrap(), p);
        // The same file `mvscope run --params` reads: a subset also loads.
        std::fs::write(&path, "tau0 = 0.6\n").unwrap();
        assert_eq!(Params::from_toml_file(&path).unwrap().tau0, 0.6);
    }
}
