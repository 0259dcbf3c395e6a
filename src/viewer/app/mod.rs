//! The egui side of the viewer: panels, panes, the timeline, the inspector, parameters, the
//! comparison and the tour. All state worth testing lives in [`Model`].

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;
use web_time::Instant;

use egui::{Color32, Pos2, Rect, Sense, Vec2};

use super::ViewerOptions;
use super::cloud::{CloudView, ColorMode};
use super::compare;
use super::files::{Choice, PathDialog, Purpose};
use super::frame::{self, MapFrame, map_view};
use super::inspector::{self, Inspection, RestorerPixel};
use super::maps::{
    Colormap, MapKind, MapRenderer, MapSources, MapTarget, WINNER_INITIAL_VALUE, describe_value,
    natural_range, percentile_range, ramp, winner_color, winner_label,
};
use super::model::{CloudSource, LoadResult, Model, Notice};
use super::timeline::{self, Group, Unit};
use super::tour;

mod goal;
mod inspector_ui;
mod panels;
mod panes;
mod params;
mod tabs;

use crate::acmm::params::{Method, Params};
use crate::acmm::planar::PriorMesh;
use crate::acmm::problem::Winner;
use crate::session::{GpuMaps, Stage, ViewMaps};
pub use goal::*;
use inspector_ui::*;
pub use panes::*;
pub use params::*;

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
    /// What the legend says instead of a ramp when no pixel has a value ([`empty_legend`]).
    pub empty: Option<&'static str>,
    target: Option<MapTarget>,
    texture: Option<egui::TextureId>,
    key: Option<PaneKey>,
    /// Per-pixel values of the drawn map (hover readout).
    pub values: Vec<[f32; 4]>,
    pub size: (u32, u32),
    /// Zoom and pan, in map coordinates (refitted when the map's size changes).
    pub frame: MapFrame,
    /// Where the pane and its whole map were drawn last frame (tests check the framing).
    pub drawn: Option<(Rect, Rect)>,
    /// The inspected pixel marked on the map last frame.
    pub marked: Option<(u32, u32)>,
    /// The values of a new map on their way from the device: the pane is coloured (its range
    /// needs them) and shows it when they arrive; until then it shows the map before.
    pending: Option<PendingPane>,
}

/// A pane's extracted values being read back.
struct PendingPane {
    key: PaneKey,
    values: crate::gpu::Readback,
    size: (u32, u32),
    num_sources: usize,
    /// The frame that asked for them (see [`ViewerApp::hold_readbacks`]).
    asked: u64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct PaneKey {
    version: u64,
    /// The fusion shown (the confidence map's input).
    fused: u64,
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
            empty: None,
            target: None,
            texture: None,
            key: None,
            values: Vec::new(),
            size: (0, 0),
            frame: MapFrame::default(),
            drawn: None,
            marked: None,
            pending: None,
        }
    }

    /// Whether a new map's values are still on their way (tests wait for them).
    pub fn is_pending(&self) -> bool {
        self.pending.is_some()
    }

    /// The drawn texture, if any (tests read it back).
    pub fn target(&self) -> Option<&MapTarget> {
        self.target.as_ref()
    }
}

/// What the inspector shows, computed once per step, view and pixel (not every frame: it
/// reads the view's maps back from the GPU and re-runs the CPU reference).
struct InspectorView {
    key: (u64, usize, (u32, u32), bool),
    inspection: Option<Inspection>,
    patches: Option<inspector::Patches>,
    /// The pixel's plane and cost now.
    now: Option<([f32; 4], f32)>,
    restorer: Option<RestorerPixel>,
    /// The support point of the pixel's cell at the view's last support-point step (its
    /// index in the schedule), at the shown scale.
    support: Option<(usize, crate::acmm::planar::SupportCell)>,
}

/// The viewer application.
pub struct ViewerApp {
    pub model: Model,
    render_state: Option<egui_wgpu::RenderState>,
    renderer: Option<MapRenderer>,
    pub panes: Vec<Pane>,
    /// Zoom and pan in one pane move the others too.
    pub link_panes: bool,
    pub tab: Tab,
    pub cloud_view: CloudView,
    pub unit: Unit,
    pub show_params: bool,
    pub show_inspector: bool,
    pub show_tour: bool,
    /// A scripted run to carry out, if any.
    pub goal: Option<Goal>,
    /// Text of the value under the cursor.
    pub hover: Option<String>,
    inspector_view: Option<InspectorView>,
    /// Where the last pixel was clicked (screen): the inspector opens beside it.
    inspector_at: Option<Pos2>,
    /// Where the inspector window was drawn last frame (tests check it).
    pub inspector_rect: Option<Rect>,
    /// Where parameters were last loaded or saved: their dialogs open there.
    params_dir: Option<PathBuf>,
    /// The tallest map pane header of the last frame (the others are padded to it).
    pane_header: f32,
    /// The left edge of the maps' area (the inspector stays right of it).
    maps_left: f32,
    /// How far from the clicked pixel the inspector opens (clear of its markers).
    inspector_gap: f32,
    thumbs: HashMap<usize, egui::TextureHandle>,
    compare_view: compare::CompareView,
    frame_times: Vec<f32>,
    /// Parameters being edited (applied when an edit is finished).
    edit: Params,
    /// The run (model version) fused on its own when the 3D tab showed it finished.
    auto_fused: Option<u64>,
    /// Side panels: None follows the window width, Some is the user's choice.
    pub side_panels: Option<bool>,
    /// The cursor (and scale count) the timeline was last laid out for.
    timeline_cursor: Option<(usize, usize)>,
    /// The file dialog, while open.
    pub dialog: Option<PathDialog>,
    /// The last refused parameter input, shown in the panel until the next accepted edit.
    pub param_error: Option<String>,
    /// Close the window after this many frames (`MVSCOPE_VIEW_FRAMES`, for smoke tests).
    pub exit_after_frames: Option<u64>,
    frames: u64,
    /// A test hook: a pane takes its values only this many frames after it asked for them,
    /// as on a device busy with other work (`MVSCOPE_HOLD_READBACKS`, the page's `hold=`).
    pub hold_readbacks: u64,
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

/// Window width (points) below which the side panels fold away by themselves.
pub const NARROW_WINDOW: f32 = 900.0;

impl ViewerApp {
    /// The app on eframe's wgpu device, opening `options.scene` (or the demo scene).
    pub fn new(cc: &eframe::CreationContext<'_>, options: ViewerOptions) -> anyhow::Result<Self> {
        let Some(rs) = cc.wgpu_render_state.clone() else {
            anyhow::bail!("the viewer needs eframe's wgpu renderer (no wgpu render state)");
        };
        let ctx = super::context_from_render_state(&rs);
        let model = Model::new(ctx, options.start_params(), options.method)
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
        model.device_budget = options.device_budget;
        ViewerApp {
            edit: model.params.clone(),
            param_error: None,
            dialog: None,
            timeline_cursor: None,
            auto_fused: None,
            side_panels: None,
            model,
            render_state,
            renderer,
            panes: vec![Pane::new(MapKind::Depth)],
            link_panes: false,
            tab: Tab::Maps,
            cloud_view: CloudView::default(),
            unit: Unit::Half,
            show_params: false,
            show_inspector: false,
            show_tour: true,
            goal: None,
            hover: None,
            inspector_view: None,
            inspector_at: None,
            inspector_rect: None,
            params_dir: None,
            pane_header: 0.0,
            maps_left: 0.0,
            inspector_gap: 60.0,
            thumbs: HashMap::new(),
            compare_view: compare::CompareView::default(),
            frame_times: Vec::new(),
            options,
            exit_after_frames: None,
            frames: 0,
            hold_readbacks: 0,
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
                    self.model.notice = Notice::info(format!(
                        "software GPU ({}): the demo scene runs at {w}x{h}",
                        self.model.ctx.adapter_name()
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
        self.compare_view = compare::CompareView::default();
    }

    /// Opens the viewer's file dialog for `purpose`, in the open scene's folder (or the
    /// working directory).
    pub fn open_dialog(&mut self, purpose: Purpose) {
        // Parameters where they were last loaded or saved; scenes beside the last one.
        let params_dir = matches!(purpose, Purpose::LoadParams | Purpose::SaveParams)
            .then(|| self.params_dir.clone())
            .flatten();
        let dir = params_dir
            .or_else(|| {
                self.model
                    .recent
                    .first()
                    .and_then(|p| p.parent().map(Path::to_path_buf))
            })
            .or_else(|| std::env::current_dir().ok())
            .unwrap_or_else(|| PathBuf::from("."));
        let name = (purpose == Purpose::SaveParams).then_some("params.toml");
        self.dialog = Some(PathDialog::new(purpose, &dir, name));
    }

    /// Shows the open file dialog and carries out what was chosen.
    fn dialog_window(&mut self, ctx: &egui::Context) {
        let Some(dialog) = &mut self.dialog else {
            return;
        };
        let purpose = dialog.purpose;
        let path = match dialog.show(ctx, &self.model.recent) {
            Choice::None => return,
            Choice::Cancel => {
                self.dialog = None;
                return;
            }
            Choice::Path(p) => p,
        };
        if matches!(purpose, Purpose::LoadParams | Purpose::SaveParams) {
            self.params_dir = path.parent().map(Path::to_path_buf);
        }
        let result = match purpose {
            Purpose::OpenScene => {
                self.open_folder(&path);
                Ok(())
            }
            Purpose::LoadParams => {
                Params::from_toml_file_over(&path, &self.model.method.defaults())
                    .map_err(|e| e.to_string())
                    .and_then(|p| p.validate().map(|()| p).map_err(|e| e.to_string()))
                    .map(|p| {
                        self.edit = p.clone();
                        self.model.set_params(p);
                    })
            }
            Purpose::SaveParams => save_params(&self.model.params, &path).map(|()| {
                self.model.notice = Notice::info(format!("parameters saved to {}", path.display()));
            }),
        };
        match (result, &mut self.dialog) {
            (Err(e), Some(d)) => d.message = Some(e),
            _ => self.dialog = None,
        }
    }

    /// The Compare tab's hover readout (every method's depth and error at the pixel).
    pub fn compare_hover(&self) -> Option<String> {
        self.compare_view.hover.clone()
    }

    /// Frames every pane's whole map (the Fit button and the F key).
    pub fn fit_panes(&mut self) {
        for pane in &mut self.panes {
            pane.frame = MapFrame::fit(pane.size);
        }
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

    /// Extracts pane `p`'s map when its key changed and asks for the values; colours and
    /// shows it once they have arrived (a later frame: nothing waits for the device).
    fn update_pane(&mut self, p: usize) -> Result<(), String> {
        let Some(renderer) = &self.renderer else {
            return Ok(());
        };
        let pane = &self.panes[p];
        let key = PaneKey {
            version: self.model.version,
            fused: self.model.cloud_version(),
            view: self.model.view,
            kind: pane.kind,
            source: pane.source,
            colormap: pane.colormap,
            range_mode: pane.range_mode,
        };
        if pane.key == Some(key) || pane.pending.as_ref().is_some_and(|q| q.key == key) {
            return self.finish_pane(p);
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
        let wants_confidence = pane.kind == MapKind::Confidence;
        let confidence = wants_confidence
            .then(|| self.model.confidence_buffer(view, w, h))
            .flatten();
        // The agreeing sources come from fusion: a finished run is fused once when its
        // Confidence map is first shown (as the 3D tab does), instead of an empty map.
        if wants_confidence
            && confidence.is_none()
            && self.model.session.as_ref().is_some_and(|s| s.is_finished())
            && self.auto_fused != Some(self.model.version)
        {
            self.auto_fused = Some(self.model.version);
            if let Err(e) = self.model.request_fusion() {
                self.model.error = Some(e);
            }
        }
        let reach = (pane.kind == MapKind::TextureReach)
            .then(|| self.model.texture_reach_buffer(view, w, h))
            .flatten();
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
            confidence: confidence.as_ref(),
            texture_reach: reach.as_ref(),
        };
        renderer
            .extract(ctx, &sources, pane.kind, pane.source, target)
            .map_err(|e| e.to_string())?;
        pane.pending = Some(PendingPane {
            key,
            values: ctx.read_later("map view values", &target.values, 0, target.values.size()),
            size: (w, h),
            num_sources: maps.num_sources,
            asked: self.frames,
        });
        self.finish_pane(p)
    }

    /// Colours pane `p`'s new map once its values have arrived and shows it.
    fn finish_pane(&mut self, p: usize) -> Result<(), String> {
        let Some(renderer) = &self.renderer else {
            return Ok(());
        };
        let ctx = &self.model.ctx;
        let Some(pending) = &self.panes[p].pending else {
            return Ok(());
        };
        if self.frames < pending.asked + self.hold_readbacks {
            return Ok(());
        }
        let Some(values) = pending.values.take::<[f32; 4]>(ctx) else {
            return Ok(());
        };
        let values = values.map_err(|e| e.to_string())?;
        let depth_range = self
            .model
            .session
            .as_ref()
            .and_then(|s| {
                s.level_scene(0)
                    .views
                    .get(pending.key.view)
                    .map(|v| (v.depth_range.min as f32, v.depth_range.max as f32))
            })
            .unwrap_or((0.0, 1.0));
        let pane = &mut self.panes[p];
        let Some(pending) = pane.pending.take() else {
            return Ok(());
        };
        let Some(target) = &pane.target else {
            return Ok(());
        };
        if (target.width, target.height) != pending.size {
            // Superseded by a map of another size; its own read-back follows.
            return Ok(());
        }
        pane.values = values;
        pane.empty = empty_legend(pane.kind, &pane.values);
        pane.range = match pane.range_mode {
            RangeMode::Manual(lo, hi) => (lo, hi),
            RangeMode::DepthRange if pane.kind == MapKind::Depth => depth_range,
            _ => natural_range(pane.kind, pending.num_sources)
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
        pane.size = pending.size;
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
        pane.key = Some(pending.key);
        Ok(())
    }

    /// Maps with no estimate yet (before the view's first step): the image still shows.
    fn blank_maps(&self) -> Option<GpuMaps> {
        let scene = self.model.session.as_ref()?.level_scene(0);
        let view = scene.views.get(self.model.view)?;
        let empty = ViewMaps::empty(0, view.image.width, view.image.height);
        Some(GpuMaps::upload(&self.model.ctx, &empty))
    }

    /// Each compared method's map of the chosen view with the ground truth at its own size
    /// (what the Compare tab draws and hovers): a method stopped at a coarser scale is
    /// compared as `mvscope eval` and the table compare it.
    pub fn compared_maps(&self) -> Vec<compare::ComparedMap<'_>> {
        compare::compared_maps(&self.model)
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
        // The maps now arrive a frame or more after they are asked for: the view is made
        // again when they do.
        let arrived = self.model.current_maps().is_some();
        let key = (self.model.version, self.model.view, pixel, arrived);
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
        let maps = self.model.current_maps().cloned();
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
        let level = self.model.shown_level();
        let support = self
            .model
            .support
            .as_ref()
            .filter(|c| c.inputs.step.view == self.model.view && c.inputs.level == level)
            .and_then(|c| Some((c.index, c.explain(x, y)?)));
        self.inspector_view = Some(InspectorView {
            key,
            inspection,
            patches,
            now,
            restorer,
            support,
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
        if pressed(Key::F) {
            self.fit_panes();
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

    /// A dropped scene: natively a zip of a scene folder, or a path into a folder; in the
    /// browser, which gives bytes and no paths, a zip or the files of a scene (read
    /// asynchronously and opened when they have arrived).
    fn dropped_files(&mut self, ctx: &egui::Context) {
        let dropped = ctx.input(|i| i.raw.dropped_files.clone());
        if dropped.is_empty() {
            return;
        }
        #[cfg(target_arch = "wasm32")]
        {
            super::browser::read_dropped(dropped);
        }
        #[cfg(not(target_arch = "wasm32"))]
        {
            let is_zip = |p: &Path| {
                p.extension()
                    .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case("zip"))
            };
            if let Some(zip) = dropped.iter().find(|f| is_zip(f.path())) {
                let name = zip.path().display().to_string();
                match zip
                    .bytes()
                    .and_then(|b| crate::vfs::MemoryFiles::from_zip(&b))
                {
                    Ok(files) => self.open_files(files),
                    Err(e) => self.model.error = Some(format!("{name}: {e}")),
                }
                return;
            }
            let dropped: Vec<PathBuf> = dropped.iter().map(|f| f.path().to_path_buf()).collect();
            self.open_dropped_path(dropped);
        }
    }

    /// Opens the folder of the first dropped path (natively).
    #[cfg(not(target_arch = "wasm32"))]
    fn open_dropped_path(&mut self, dropped: Vec<PathBuf>) {
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
        super::in_background(move || {
            // The receiver may be gone (superseded); nothing to do then.
            let _ = tx.send(Model::load_folder(&folder, &options));
        });
        self.loading = Some(PendingLoad {
            path: path.to_path_buf(),
            started: Instant::now(),
            result: rx,
        });
    }

    /// Carries a scripted run ([`Goal`]) forward by one frame.
    fn pursue_goal(&mut self) {
        let busy = !self.is_settled();
        let Some(goal) = &mut self.goal else {
            return;
        };
        if goal.report.is_some() || self.model.session.is_none() {
            return;
        }
        let Some(started) = goal.started else {
            let map = goal.map;
            let end = self.model.schedule().len();
            self.model.run_to(goal.steps.min(end));
            goal.started = Some(Instant::now());
            if let Some(kind) = map {
                self.set_map(0, kind);
            }
            return;
        };
        let target = goal.steps.min(self.model.schedule().len());
        if busy || self.model.cursor() < target {
            goal.idle_frames = 0;
            return;
        }
        goal.idle_frames += 1;
        if goal.idle_frames < 3 {
            return;
        }
        let ctx = self.model.ctx.clone();
        match &mut goal.scoring {
            None => {
                let Some(session) = &self.model.session else {
                    return;
                };
                let views = session.level_scene(0).views.len();
                let reads: Result<Vec<_>, _> = (0..views)
                    .map(|v| session.request_planes_and_costs(v))
                    .collect();
                match reads {
                    Ok(r) => goal.scoring = Some(r),
                    Err(e) => self.model.error = Some(e.to_string()),
                }
            }
            Some(reads) => {
                if !reads.iter().all(|r| r.is_ready(&ctx)) {
                    return;
                }
                let maps: Vec<Option<crate::session::PlanesCosts>> = reads
                    .iter_mut()
                    .map(|r| r.take(&ctx).and_then(Result::ok).flatten())
                    .collect();
                let seconds = started.elapsed().as_secs_f64();
                let pane = self
                    .panes
                    .first()
                    .and_then(|p| p.drawn.map(|(rect, image)| (rect, image, p.size)));
                let report = goal_report(&self.model, &maps, self.model.cursor(), seconds, pane);
                #[cfg(target_arch = "wasm32")]
                {
                    super::browser::console_log(&format!("mvscope report {report}"));
                    super::browser::set_title("mvscope: done");
                }
                #[cfg(not(target_arch = "wasm32"))]
                log::info!("mvscope report {report}");
                goal.report = Some(report);
            }
        }
    }

    /// Opens a scene given as files in memory (a dropped zip; in the browser, a chosen
    /// folder or zip), loaded off the UI thread like a folder.
    pub fn open_files(&mut self, files: crate::vfs::MemoryFiles) {
        let (tx, rx) = mpsc::channel();
        let options = self.model.load_options.clone();
        let label = files.root();
        super::in_background(move || {
            let _ = tx.send(Model::load_files(files, &options));
        });
        self.loading = Some(PendingLoad {
            path: label,
            started: Instant::now(),
            result: rx,
        });
    }

    /// Whether anything the window shows is still on its way: a run, results from the
    /// device, a pane's new map (tests step frames until it is not).
    pub fn is_busy(&self) -> bool {
        self.model.is_running() || self.panes.iter().any(Pane::is_pending) || self.is_loading()
    }

    /// Whether the window shows the state it stands at: nothing queued or on its way, and
    /// (on the Maps tab) every pane drawn from the current maps, its read-back landed. What a
    /// scripted picture waits for before it is taken (`screenshot`, the page's `?steps=`).
    pub fn is_settled(&self) -> bool {
        if self.is_busy() {
            return false;
        }
        if self.tab != Tab::Maps || self.renderer.is_none() || self.model.session.is_none() {
            return true;
        }
        self.panes.iter().all(|p| {
            p.key
                == Some(PaneKey {
                    version: self.model.version,
                    fused: self.model.cloud_version(),
                    view: self.model.view,
                    kind: p.kind,
                    source: p.source,
                    colormap: p.colormap,
                    range_mode: p.range_mode,
                })
        })
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
}

fn mean(v: &[f32]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
    }
}

impl eframe::App for ViewerApp {
    fn logic(&mut self, ctx: &egui::Context, frame: &mut eframe::Frame) {
        // The time a frame takes to build (the UI pass of the last frame, which egui
        // measures), not the gap between frames: an idle window draws seldom.
        if let Some(cpu) = frame.info().cpu_usage {
            self.frame_times.push(cpu);
            if self.frame_times.len() > 60 {
                self.frame_times.remove(0);
            }
        }
        self.keyboard(ctx);
        // Polled before new drops, so a load started this frame shows in this frame.
        self.poll_loading(ctx);
        self.dropped_files(ctx);
        #[cfg(target_arch = "wasm32")]
        for incoming in super::browser::take_incoming() {
            match incoming.files {
                Ok(files) => self.open_files(files),
                Err(e) => self.model.error = Some(e),
            }
        }
        self.pursue_goal();
        #[cfg(target_arch = "wasm32")]
        if self.frames == 0 {
            super::browser::console_log(&format!(
                "mvscope first frame at {:.0} ms",
                super::browser::now_ms()
            ));
        }
        self.frames += 1;
        if self.exit_after_frames.is_some_and(|n| self.frames >= n) {
            println!(
                "viewer: {} frames on {}, {} steps run",
                self.frames,
                self.model.ctx.adapter_name(),
                self.model.cursor()
            );
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        // A slice of the run per frame keeps the UI responsive; results on their way from
        // the device (maps, captures) are picked up by the frames that follow, which `ui`
        // asks for (a request made here, before the frame's pass begins, is not kept on the
        // web).
        self.model.tick(Duration::from_millis(30));
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        egui::Panel::top("menu").show(ui, |ui| {
            self.menu(ui);
            self.toolbar(ui);
        });
        egui::Panel::bottom("status").show(ui, |ui| self.status(ui));
        // Below this width the side panels would squeeze the maps to a sliver: they fold
        // away unless the user asks for them (View menu).
        let wide = ctx.content_rect().width() >= NARROW_WINDOW;
        if self.side_panels.unwrap_or(wide) {
            egui::Panel::left("scene")
                .default_size(240.0)
                .show(ui, |ui| self.scene_panel(ui));
            egui::Panel::right("timeline")
                .default_size(240.0)
                .show(ui, |ui| self.timeline_panel(ui));
        }
        if self.show_params {
            self.params_panel(ui);
        }
        // The tour talks about the maps' step: under them, unless the window is too small to
        // spare the room.
        if self.show_tour && self.tab == Tab::Maps && self.side_panels.unwrap_or(wide) {
            self.tour_panel(ui);
        }
        // The central panel is filled where no map pane painted: on the software device a
        // layer of fill under the maps would cost as much as the maps.
        let _ = frame::take_painted(&ctx);
        let fill = ui.style().visuals.panel_fill;
        let central = egui::CentralPanel::default_margins()
            .frame(egui::Frame::central_panel(ui.style()).fill(Color32::TRANSPARENT))
            .show(ui, |ui| {
                let background = ui.painter().add(egui::Shape::Noop);
                match self.tab {
                    Tab::Maps => self.maps_tab(ui),
                    Tab::Cloud => self.cloud_tab(ui),
                    Tab::Compare => self.compare_tab(ui),
                }
                (ui.layer_id(), background)
            });
        let (layer, background) = central.inner;
        let rect = central.response.rect;
        let rest = frame::uncovered(rect, &frame::take_painted(&ctx));
        egui::Painter::new(ctx.clone(), layer, rect).set(background, frame::filled(&rest, fill));

        if self.show_inspector && self.tab == Tab::Maps {
            self.inspector_window(&ctx);
        }
        self.dialog_window(&ctx);
        // More frames while anything is queued or on its way from the device: nothing waits
        // for the GPU, so a later frame takes what it has finished.
        if self.is_busy() || self.goal.as_ref().is_some_and(|g| !g.is_done()) {
            ctx.request_repaint();
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
    fn counts_masks_and_hypotheses_get_discrete_legends_with_names() {
        let count = discrete_legend(MapKind::SelectedCount, (0.0, 3.0)).unwrap();
        assert_eq!(
            count.iter().map(|e| e.1.as_str()).collect::<Vec<_>>(),
            ["0 views", "1 view", "2 views", "3 views"]
        );
        let replaced = discrete_legend(MapKind::Replaced, (0.0, 1.0)).unwrap();
        assert_eq!(replaced[1].1, "replaced");
        let winner = discrete_legend(MapKind::Winner, (0.0, WINNER_INITIAL_VALUE)).unwrap();
        assert_eq!(winner.len(), 17);
        assert_eq!(winner[16].1, "initial (random plane)");
        assert_eq!(winner[15].1, "its prior plane (no source sees it)");
        assert_eq!(winner[8].1, "kept");
        assert!(discrete_legend(MapKind::Depth, (1.0, 2.0)).is_none());
        // A map without a single value says so instead of a ramp over a made-up range.
        let none = vec![[0.0, 0.0, 0.0, 0.0]; 4];
        let mut one = none.clone();
        one[2] = [3.5, 1.0, 0.0, 0.0];
        assert!(
            empty_legend(MapKind::PriorDepth, &none)
                .unwrap()
                .contains("has a prior")
        );
        assert!(empty_legend(MapKind::PriorDepth, &one).is_none());
        assert!(empty_legend(MapKind::Depth, &none).is_some());
        assert!(
            empty_legend(MapKind::Confidence, &none)
                .unwrap()
                .contains("Fuse")
        );
        assert!(
            empty_legend(MapKind::PriorEffect, &none).is_none(),
            "discrete"
        );
        assert!(
            empty_legend(MapKind::PriorNormal, &none).is_none(),
            "colours"
        );
        assert_eq!(legend_number(0.0123, 0.05), "0.0123");
        assert_eq!(legend_number(1234.4, 900.0), "1234");
    }

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
