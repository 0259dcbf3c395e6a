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
    natural_range, percentile_range, ramp, winner_label,
};
use super::model::{CloudSource, LoadResult, Model};
use super::timeline::{self, Group, Unit};
use super::tour;
use crate::acmm::params::{Method, Params};
use crate::acmm::planar::PriorMesh;
use crate::acmm::problem::Winner;
use crate::session::{GpuMaps, Stage, ViewMaps};

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

/// A scripted run (the web page's `?steps=N&map=NAME`): run the open scene `steps` steps
/// (all of them at most), show `map`, and once everything has arrived score every view
/// against the ground truth and report it.
#[derive(Debug)]
pub struct Goal {
    pub steps: usize,
    pub map: Option<MapKind>,
    started: Option<Instant>,
    /// Frames seen with nothing left to do (a few, so that the last maps are drawn).
    idle_frames: u32,
    /// The maps to score, on their way.
    scoring: Option<Vec<crate::session::Pending<Option<crate::session::PlanesCosts>>>>,
    /// The report once made (JSON: steps, seconds, and the shares within 1% and 2% of every
    /// view and pooled, as `mvscope eval` names them).
    pub report: Option<String>,
}

impl Goal {
    pub fn new(steps: usize, map: Option<MapKind>) -> Goal {
        Goal {
            steps,
            map,
            started: None,
            idle_frames: 0,
            scoring: None,
            report: None,
        }
    }

    pub fn is_done(&self) -> bool {
        self.report.is_some()
    }
}

/// Window width (points) below which the side panels fold away by themselves.
pub const NARROW_WINDOW: f32 = 900.0;

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
            Purpose::LoadParams => Params::from_toml_file(&path)
                .map_err(|e| e.to_string())
                .and_then(|p| p.validate().map(|()| p).map_err(|e| e.to_string()))
                .map(|p| {
                    self.edit = p.clone();
                    self.model.set_params(p);
                }),
            Purpose::SaveParams => save_params(&self.model.params, &path).map(|()| {
                self.model.notice = Some(format!("parameters saved to {}", path.display()));
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
        pane.pending = Some(PendingPane {
            key,
            values: ctx.read_later("map view values", &target.values, 0, target.values.size()),
            size: (w, h),
            num_sources: maps.num_sources,
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
            super::web::read_dropped(dropped);
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
                    .and_then(|b| crate::scene::vfs::MemoryFiles::from_zip(&b))
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
        let busy = self.is_busy();
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
                    super::web::console_log(&format!("mvscope report {report}"));
                    super::web::set_title("mvscope: done");
                }
                #[cfg(not(target_arch = "wasm32"))]
                log::info!("mvscope report {report}");
                goal.report = Some(report);
            }
        }
    }

    /// Opens a scene given as files in memory (a dropped zip; in the browser, a chosen
    /// folder or zip), loaded off the UI thread like a folder.
    pub fn open_files(&mut self, files: crate::scene::vfs::MemoryFiles) {
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
                #[cfg(not(target_arch = "wasm32"))]
                if ui.button("Open scene folder...").clicked() {
                    self.open_dialog(Purpose::OpenScene);
                    ui.close();
                }
                // In the browser the page's own file chooser reads the files as bytes.
                #[cfg(target_arch = "wasm32")]
                {
                    if ui.button("Open scene folder...").clicked() {
                        super::web::choose_scene(true);
                        ui.close();
                    }
                    if ui.button("Open a zip of a scene folder...").clicked() {
                        super::web::choose_scene(false);
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

    fn toolbar(&mut self, ui: &mut egui::Ui) {
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

    fn status(&mut self, ui: &mut egui::Ui) {
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
            ui.label(format!("{step} · {frame} · {}", self.model.ctx.info.name))
                .on_hover_text(
                    "step: the device time of the last step run; frame: the time the last frames \
                 took to build (not the idle gaps between them)",
                );
            if let Some(session) = &self.model.session {
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

    fn maps_tab(&mut self, ui: &mut egui::Ui) {
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

    fn cloud_tab(&mut self, ui: &mut egui::Ui) {
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

    fn compare_tab(&mut self, ui: &mut egui::Ui) {
        let Some(cmp) = &self.model.comparison else {
            ui.heading("Compare DWTA, ACMH, ACMM, ACMP and ACMMP");
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
            self.model.notice = Some(if follow {
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
    fn params_panel(&mut self, ui: &mut egui::Ui) {
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
                            self.edit = Params::default();
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

    fn inspector_window(&mut self, ctx: &egui::Context) {
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
    fn tour_panel(&mut self, ui: &mut egui::Ui) {
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

/// The JSON a scripted run reports: steps run, seconds, and for each view with ground
/// truth and pooled, the shares of its pixels within 1% and 2% (as `mvscope eval` scores
/// them, the truth sampled at each map's size).
///
/// With `pane`, where the first map pane and its map were drawn (points) and the map's size:
/// a screenshot test checks the framing against the pixels.
fn goal_report(
    model: &Model,
    maps: &[Option<crate::session::PlanesCosts>],
    steps: usize,
    seconds: f64,
    pane: Option<(Rect, Rect, (u32, u32))>,
) -> String {
    use crate::eval::depth_accuracy_relative as rel;
    let (mut all_d, mut all_t) = (Vec::new(), Vec::new());
    let mut views = Vec::new();
    for (v, m) in maps.iter().enumerate() {
        let Some(m) = m else { continue };
        let Some(gt) = model
            .loaded
            .as_ref()
            .and_then(|l| l.ground_truth.get(v)?.as_ref())
        else {
            continue;
        };
        let d: Vec<f32> = m.plane.iter().map(|p| p[3]).collect();
        let t = gt.resampled(m.width, m.height);
        views.push(serde_json::json!({
            "view": v,
            "size": [m.width, m.height],
            "within_1": rel(&d, &t, None, 0.01).within,
            "within_2": rel(&d, &t, None, 0.02).within,
        }));
        all_d.extend(d);
        all_t.extend(t);
    }
    serde_json::json!({
        "method": model.method.to_string(),
        "adapter": model.ctx.describe(),
        "steps": steps,
        "seconds": seconds,
        "views": views,
        "within_1": rel(&all_d, &all_t, None, 0.01).within,
        "within_2": rel(&all_d, &all_t, None, 0.02).within,
        "pane": pane.map(|(r, i, size)| serde_json::json!({
            "rect": [r.min.x, r.min.y, r.max.x, r.max.y],
            "image": [i.min.x, i.min.y, i.max.x, i.max.y],
            "map": [size.0, size.1],
        })),
    })
    .to_string()
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
struct PaneContext {
    nsrc: usize,
    xi: f32,
    /// The method builds a planar prior (its maps are offered).
    has_prior: bool,
}

fn pane_controls(ui: &mut egui::Ui, p: usize, n: usize, pane: &mut Pane, pc: PaneContext) {
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

/// A number for a legend: enough digits for its range, no more.
fn legend_number(x: f32, span: f32) -> String {
    let digits = if span <= 0.0 {
        3
    } else {
        (2.0 - span.log10().floor()).clamp(0.0, 6.0) as usize
    };
    format!("{x:.digits$}")
}

/// The pane's legend: swatches with names for discrete kinds; otherwise a ramp with its
/// ends, the unit, and for the restorer difference a mark at ξ (where it replaces).
fn legend(ui: &mut egui::Ui, pane: &Pane, xi: f32) {
    let (cmap, range, kind) = (pane.colormap, pane.range, pane.kind);
    let span = range.1 - range.0;
    let t_of = |v: f32| {
        if span > 0.0 {
            ((v - range.0) / span).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    if let Some(entries) = discrete_legend(kind, range) {
        ui.horizontal_wrapped(|ui| {
            for (v, name) in entries {
                let c = cmap.color(t_of(v));
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
struct PaneOutput {
    hover: Option<String>,
    clicked: Option<(u32, u32)>,
    moved: bool,
}

/// Draws a pane's texture with its own zoom and pan (refitted when the map's size changed).
/// The planar prior drawn over a pane: its mesh (none yet: a notice), and whether to draw
/// the triangles or the support points only.
type PriorOverlay<'a> = (Option<&'a PriorMesh>, bool);

fn draw_pane(
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

/// The support points (green dots) and, with `edges`, the triangles over the image: kept
/// ones outlined in white, dropped ones (inconsistent with their points' normals, or
/// degenerate) filled in red.
fn draw_prior_mesh(
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
    if edges {
        let kept = egui::Stroke::new(1.0, Color32::from_rgba_unmultiplied(255, 255, 255, 170));
        let dropped = egui::Stroke::new(1.0, Color32::from_rgb(255, 70, 60));
        for t in &mesh.triangles {
            let v = t.vertices.map(at);
            if t.kept() {
                for k in 0..3 {
                    painter.line_segment([v[k], v[(k + 1) % 3]], kept);
                }
            } else {
                painter.add(egui::Shape::convex_polygon(
                    v.to_vec(),
                    Color32::from_rgba_unmultiplied(255, 40, 30, 70),
                    dropped,
                ));
            }
        }
    }
    let radius = (0.35 * scale).clamp(1.5, 4.0);
    for i in 0..mesh.points.len() {
        painter.circle_filled(at(i), radius, Color32::from_rgb(60, 230, 90));
    }
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
    if let Some(p) = &u.prior {
        prior_ui(ui, u, p, ins);
    }
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
fn prior_ui(
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
                super::maps::winner_label(p.photometric_winner.code())
            ),
        );
    } else {
        ui.label("The prior agreed with the lowest cost here.");
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
/// What one parameter widget did this frame.
pub struct Edit {
    response: egui::Response,
    /// A finished edit to apply (Enter or focus loss after typing, the end of a drag, a click).
    commit: bool,
    /// Typed input that was refused, and why.
    error: Option<String>,
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
fn num<N: egui::emath::Numeric>(
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
fn short(x: f64) -> String {
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
fn param_row(
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
                "bilateral weight: Laplacian (unsquared distances, the authors' form σs = 5, σc = 3 were tuned for) or Gaussian (COLMAP's)",
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
            changed |= param_row(ui, "η", "downsampling factor between scales", |ui| {
                num(ui, &mut p.eta, 0.1..=0.9, 0.05)
            });
            changed |= param_row(ui, "δ", "truncation of the reprojection error (px)", |ui| {
                num(ui, &mut p.delta, 0.1..=20.0, 0.1)
            });
            changed |= param_row(ui, "λ", "weight of the reprojection error in m_geo", |ui| {
                num(ui, &mut p.lambda, 0.0..=2.0, 0.01)
            });
            changed |= param_row(
                ui,
                "ξ",
                "detail restorer: replace where C_init - C_photo > ξ",
                |ui| num(ui, &mut p.xi, 0.0..=2.0, 0.01),
            );
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
        for incoming in super::web::take_incoming() {
            match incoming.files {
                Ok(files) => self.open_files(files),
                Err(e) => self.model.error = Some(e),
            }
        }
        self.pursue_goal();
        #[cfg(target_arch = "wasm32")]
        if self.frames == 0 {
            super::web::console_log(&format!(
                "mvscope first frame at {:.0} ms",
                super::web::now_ms()
            ));
        }
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
            ["0 views", "1 views", "2 views", "3 views"]
        );
        let replaced = discrete_legend(MapKind::Replaced, (0.0, 1.0)).unwrap();
        assert_eq!(replaced[1].1, "replaced");
        let winner = discrete_legend(MapKind::Winner, (0.0, WINNER_INITIAL_VALUE)).unwrap();
        assert_eq!(winner.len(), 16);
        assert_eq!(winner[15].1, "initial (random plane)");
        assert_eq!(winner[8].1, "kept");
        assert!(discrete_legend(MapKind::Depth, (1.0, 2.0)).is_none());
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
