//! The interactive viewer: an eframe app on wgpu whose device and queue are the ones the ACMM
//! [`Session`](crate::session::Session) computes on, so maps are drawn straight from the
//! buffers the passes write.
//!
//! - [`model`]: everything the window shows and does, without egui: the scene, the session,
//!   stepping in frame-sized slices, parameter changes, the method comparison.
//! - [`timeline`]: the schedule grouped scale > stage > view > iteration > half.
//! - [`maps`]: the GPU pass that turns a view's maps into a coloured texture (with its CPU
//!   reference).
//! - [`cloud`]: the 3D view (its own wgpu pipeline in an egui paint callback).
//! - [`inspector`]: why a pixel got its depth, recomputed on the CPU from the GPU's inputs.
//! - [`compare`]: the Compare tab's table and maps of every method.
//! - [`frame`]: a map pane's pan and zoom; [`files`]: the app's own file dialog;
//!   [`tour`]: the guided tour's pages, each with its section of the paper.
//! - [`app`]: the egui app (its panels, tabs, panes, parameter editor, inspector window).
//! - `web` and `browser` (wasm32 only): the page's entry (its address, eframe's web runner)
//!   and what the app uses of the page (file inputs, dropped files, title, console, clock).
//!
//! This module itself: the options, the shared wgpu set-up, the native window, headless
//! rendering (screenshots, kittests) and `mvscope bench --viewer`.

pub mod app;
#[cfg(target_arch = "wasm32")]
pub mod browser;
pub mod cloud;
pub mod compare;
pub mod files;
pub mod frame;
pub mod inspector;
pub mod maps;
pub mod model;
pub mod timeline;
pub mod tour;
#[cfg(target_arch = "wasm32")]
pub mod web;

use std::path::PathBuf;
use std::sync::Arc;

use crate::acmm::params::{Method, Params};
use crate::gpu::GpuContext;
use crate::scene::LoadOptions;

pub use app::ViewerApp;
pub use model::Model;

/// What the viewer opens with.
#[derive(Clone, Debug, Default)]
pub struct ViewerOptions {
    /// A scene folder; `None` opens the built-in demo scene.
    pub scene: Option<PathBuf>,
    pub load: LoadOptions,
    /// The parameters `method` runs with; `None`: its defaults ([`Method::defaults`]).
    pub params: Option<Params>,
    pub method: Method,
    /// Size of the built-in demo scene (width, height); `None`: 640x480 on a GPU, 320x240 on a
    /// software device.
    pub demo_size: Option<(u32, u32)>,
    /// Views of the demo scene.
    pub demo_views: Option<usize>,
    /// Device memory the sessions may hold, bytes (`--device-memory`; `None`: what the
    /// device is known to have). A scene beyond it runs each stage in batches, as
    /// `mvscope run` does.
    pub device_budget: Option<u64>,
}

impl ViewerOptions {
    /// The parameters the viewer opens with: `params`, or the method's defaults.
    pub fn start_params(&self) -> Params {
        self.params
            .clone()
            .unwrap_or_else(|| self.method.defaults())
    }
}

/// How eframe (and the headless renderer) create the wgpu device: the same adapter choice as
/// [`GpuContext::new`] (a real GPU first, a software one as fallback) and the adapter's full
/// limits, which the ACMM passes need (more storage buffers per stage than wgpu's defaults).
pub fn wgpu_setup() -> egui_wgpu::WgpuSetup {
    let mut setup = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    if let Some(backends) = wgpu::Backends::from_env() {
        setup.instance_descriptor.backends = backends;
    }
    // Natively the browser's WebGPU is no backend to choose; in the browser it is the only
    // one mvscope's passes run on (WebGL2 lacks compute).
    #[cfg(not(target_arch = "wasm32"))]
    setup
        .instance_descriptor
        .backends
        .remove(wgpu::Backends::BROWSER_WEBGPU);
    #[cfg(target_arch = "wasm32")]
    {
        setup.instance_descriptor.backends = wgpu::Backends::BROWSER_WEBGPU;
    }
    let wanted = std::env::var("WGPU_ADAPTER_NAME")
        .ok()
        .filter(|s| !s.is_empty())
        .map(|s| s.to_lowercase());
    setup.native_adapter_selector = Some(Arc::new(move |adapters, surface| {
        let mut candidates: Vec<&wgpu::Adapter> = adapters
            .iter()
            .filter(|a| surface.is_none_or(|s| a.is_surface_supported(s)))
            .filter(|a| {
                wanted
                    .as_ref()
                    .is_none_or(|w| a.get_info().name.to_lowercase().contains(w))
            })
            .collect();
        candidates.sort_by_key(|a| crate::gpu::adapter_preference(&a.get_info()));
        candidates.first().map(|a| (*a).clone()).ok_or_else(|| {
            "no GPU adapter found: install a Vulkan driver (on Debian/Ubuntu \
             `apt-get install mesa-vulkan-drivers` gives the software device lavapipe)"
                .to_string()
        })
    }));
    setup.device_descriptor = Arc::new(|adapter: &wgpu::Adapter| wgpu::DeviceDescriptor {
        label: Some("mvscope viewer"),
        required_features: adapter.features() & crate::gpu::optional_features(),
        required_limits: adapter.limits(),
        experimental_features: wgpu::ExperimentalFeatures::disabled(),
        memory_hints: wgpu::MemoryHints::Performance,
        trace: wgpu::Trace::Off,
    });
    egui_wgpu::WgpuSetup::CreateNew(setup)
}

/// The compute context on eframe's device.
pub fn context_from_render_state(render_state: &egui_wgpu::RenderState) -> GpuContext {
    GpuContext::from_device(
        render_state.device.clone(),
        render_state.queue.clone(),
        render_state.adapter.get_info(),
    )
}

/// Runs `work` off the UI thread: a worker thread natively; in the browser, which has none
/// here, at once (the result then arrives by the same channel in the next frame).
pub(crate) fn in_background(work: impl FnOnce() + Send + 'static) {
    #[cfg(not(target_arch = "wasm32"))]
    std::thread::spawn(work);
    #[cfg(target_arch = "wasm32")]
    work();
}

/// Opens the viewer window.
#[cfg(not(target_arch = "wasm32"))]
pub fn run_native(options: ViewerOptions) -> anyhow::Result<()> {
    let native = eframe::NativeOptions {
        renderer: eframe::Renderer::Wgpu,
        wgpu_options: egui_wgpu::WgpuConfiguration {
            wgpu_setup: wgpu_setup(),
            ..Default::default()
        },
        viewport: egui::ViewportBuilder::default()
            .with_title("mvscope")
            .with_inner_size([1400.0, 900.0])
            .with_drag_and_drop(true),
        ..Default::default()
    };
    eframe::run_native(
        "mvscope",
        native,
        Box::new(move |cc| {
            let mut app = ViewerApp::new(cc, options)?;
            app.exit_after_frames = std::env::var("MVSCOPE_VIEW_FRAMES")
                .ok()
                .and_then(|v| v.parse().ok());
            if app.exit_after_frames.is_some() {
                // Keep frames coming (a smoke test steps through the run meanwhile).
                app.model.run_to_end();
            }
            Ok(Box::new(app))
        }),
    )
    .map_err(|e| {
        anyhow::anyhow!(
            "the viewer window failed: {e}. Without a display, `mvscope view --screenshot \
             FILE.png` renders the viewer headlessly and `mvscope run` computes without a window"
        )
    })
}

/// What `mvscope view --screenshot` renders.
#[derive(Clone, Debug)]
pub struct ScreenshotOptions {
    pub steps: usize,
    pub map: Option<maps::MapKind>,
    /// Show the 3D view (after fusing) instead of the maps.
    pub cloud: bool,
    pub size: (u32, u32),
    /// Show the guided tour (`--tour`); a screenshot shows the maps alone otherwise.
    pub tour: bool,
    /// Show the Compare tab with every method run to its end (`--map compare`).
    pub compare: bool,
    /// The longest wait for the maps to arrive before the picture is taken: past it the
    /// screenshot fails rather than show a map that has not arrived.
    pub timeout: std::time::Duration,
    /// A test hook: hold each pane's read-back this many frames (see
    /// `ViewerApp::hold_readbacks`).
    pub hold_readbacks: u64,
}

impl Default for ScreenshotOptions {
    fn default() -> ScreenshotOptions {
        ScreenshotOptions {
            steps: 0,
            map: None,
            cloud: false,
            size: (1280, 800),
            tour: false,
            compare: false,
            timeout: std::time::Duration::from_secs(300),
            hold_readbacks: 0,
        }
    }
}

/// What a screenshot showed in each map pane (tests check it against the picture).
#[derive(Clone, Debug)]
pub struct ShotPane {
    pub kind: maps::MapKind,
    /// Where the pane and its whole map were drawn (points).
    pub drawn: Option<(egui::Rect, egui::Rect)>,
    /// The legend's text when no pixel has a value.
    pub empty: Option<&'static str>,
    /// The map's size.
    pub size: (u32, u32),
}

/// A render state on the device [`wgpu_setup`] picks, for headless rendering.
#[cfg(not(target_arch = "wasm32"))]
pub fn headless_render_state() -> anyhow::Result<egui_wgpu::RenderState> {
    let setup = wgpu_setup();
    let instance = pollster::block_on(setup.new_instance());
    pollster::block_on(egui_wgpu::RenderState::create(
        &egui_wgpu::WgpuConfiguration {
            wgpu_setup: setup,
            ..Default::default()
        },
        &instance,
        None,
        egui_wgpu::RendererOptions::PREDICTABLE,
    ))
    .map_err(|e| anyhow::anyhow!("no GPU device for headless rendering: {e}"))
}

/// The real app in a headless egui harness (no window, no display server): what
/// `mvscope view --screenshot` and the UI tests drive.
#[cfg(not(target_arch = "wasm32"))]
pub fn headless_harness(
    options: ViewerOptions,
    size: (u32, u32),
) -> anyhow::Result<egui_kittest::Harness<'static, ViewerApp>> {
    let render_state = headless_render_state()?;
    let model = Model::new(
        context_from_render_state(&render_state),
        options.start_params(),
        options.method,
    )
    .map_err(|e| anyhow::anyhow!("the ACMM shaders did not build: {e}"))?;
    let renderer = egui_kittest::wgpu::WgpuTestRenderer::from_render_state(render_state);
    let harness = egui_kittest::Harness::builder()
        .with_size(egui::vec2(size.0 as f32, size.1 as f32))
        .with_max_steps(64)
        .renderer(renderer)
        .build_eframe(move |cc| ViewerApp::from_model(cc, model, options));
    Ok(harness)
}

/// Renders the real app headlessly after `steps` steps and writes a PNG.
#[cfg(not(target_arch = "wasm32"))]
pub fn screenshot(
    options: ViewerOptions,
    shot: &ScreenshotOptions,
    out: &std::path::Path,
) -> anyhow::Result<Vec<ShotPane>> {
    use anyhow::Context as _;
    let mut harness = headless_harness(options, shot.size)?;
    harness.step();
    {
        let app = harness.state_mut();
        if let Some(e) = app.model.error.clone() {
            anyhow::bail!("{e}");
        }
        app.hold_readbacks = shot.hold_readbacks;
        app.show_tour = shot.tour;
        app.model.run_steps_now(shot.steps)?;
        if let Some(kind) = shot.map {
            app.set_map(0, kind);
        }
        if shot.cloud {
            app.model.refuse()?;
            app.show_cloud();
        }
        if shot.compare {
            app.tab = app::Tab::Compare;
            app.model.start_comparison();
        }
    }
    if shot.compare {
        // Every method runs to its end (the window's own slices, frame by frame).
        while harness
            .state()
            .model
            .comparison
            .as_ref()
            .is_some_and(|c| !c.is_finished())
        {
            harness.step();
            if let Some(e) = harness.state().model.error.clone() {
                anyhow::bail!("{e}");
            }
        }
    }
    // The picture is the state at the step asked for: every visible pane's read-back landed
    // and drawn (nothing waits for the device, so a busy one takes frames), within a limit.
    let started = std::time::Instant::now();
    loop {
        harness.step();
        let app = harness.state();
        if let Some(e) = app.model.error.clone() {
            anyhow::bail!("{e}");
        }
        if app.is_settled() {
            break;
        }
        if started.elapsed() > shot.timeout {
            anyhow::bail!(
                "the maps had not arrived from the device after {:.0} s; no picture was written (a busy device: try again, or give it longer)",
                shot.timeout.as_secs_f64()
            );
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    // Drawn once more with everything in place.
    harness.step();
    let panes = harness
        .state()
        .panes
        .iter()
        .map(|p| ShotPane {
            kind: p.kind,
            drawn: p.drawn,
            empty: p.empty,
            size: p.size,
        })
        .collect();
    let image = harness
        .render()
        .map_err(|e| anyhow::anyhow!("rendering the window failed: {e}"))?;
    let (w, h) = (image.width(), image.height());
    crate::io::write_png(out, w, h, 4, image.as_raw())
        .with_context(|| format!("writing the screenshot {}", out.display()))?;
    Ok(panes)
}

/// Frame and latency numbers of the viewer on the demo scene (`mvscope bench --viewer`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ViewerBench {
    pub adapter: String,
    pub width: u32,
    pub height: u32,
    pub window: (u32, u32),
    /// Steps run before measuring (ACMH: the first view's photometric stage, and 3 more).
    pub steps: usize,
    /// Mean time of an idle frame (UI pass + GPU render + read back) with two map panes:
    /// nothing changed, so nothing but drawing should happen.
    /// Each frame time comes with the share of it the UI pass took (update, layout and
    /// tessellation; the rest is drawing and the read-back).
    pub frame_ms_maps: (f64, f64),
    /// Frames with the pointer moving over a map (hover readout).
    pub frame_ms_hover: (f64, f64),
    /// Frames zooming a map with the wheel.
    pub frame_ms_zoom: (f64, f64),
    /// The same idle frame with the first view's depth map back-projected in the 3D view.
    pub frame_ms_cloud: (f64, f64),
    pub cloud_points: usize,
    /// From a τ0 change to the updated map drawn: every step from the first (τ0 affects
    /// all of them) back to where the session stood, then the map pass.
    pub tau0_update_ms: f64,
    /// Resident memory of the process (MiB): after the set-up, after ACMM ran to the end,
    /// after a Compare of the three methods, and after both once more (flat if nothing
    /// leaks).
    pub rss_mib: [f64; 4],
    /// At the same points, what the sessions hold on the device (MiB: level images, views'
    /// buffers, checkpoints; host memory on a software device). The rest of the resident
    /// memory is the program, the driver and the UI.
    pub held_mib: [f64; 4],
    /// The checkpoint memory budget of a session (MiB).
    pub checkpoint_budget_mib: f64,
}

/// Resident memory of this process in MiB (Linux; 0 elsewhere).
pub fn resident_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|t| {
            let line = t.lines().find(|l| l.starts_with("VmRSS:"))?;
            line.split_whitespace().nth(1)?.parse::<f64>().ok()
        })
        .map_or(0.0, |kib| kib / 1024.0)
}

/// Measures [`ViewerBench`]; `size` of the demo scene, `window` of the headless window.
#[cfg(not(target_arch = "wasm32"))]
pub fn bench(size: (u32, u32), window: (u32, u32), frames: usize) -> anyhow::Result<ViewerBench> {
    use web_time::Instant;
    // ACMH: the full-resolution photometric maps are what a user tunes τ0 on.
    let options = ViewerOptions {
        demo_size: Some(size),
        method: crate::acmm::params::Method::Acmh,
        ..ViewerOptions::default()
    };
    let mut h = headless_harness(options, window)?;
    h.step();
    let steps = {
        let app = h.state_mut();
        if let Some(e) = app.model.error.clone() {
            anyhow::bail!("{e}");
        }
        // Through the first view's photometric stage and into the second view.
        let schedule = app.model.schedule().to_vec();
        let n = timeline::advance(&schedule, 0, timeline::Unit::View) + 3;
        app.model.run_steps_now(n)?;
        app.set_map(1, maps::MapKind::SelectedCount);
        n
    };
    type H = egui_kittest::Harness<'static, ViewerApp>;
    let held = |h: &H| h.state().model.device_bytes() as f64 / (1u64 << 20) as f64;
    let mut rss_mib = [resident_mib(), 0.0, 0.0, 0.0];
    let mut held_mib = [held(&h), 0.0, 0.0, 0.0];
    let render = |h: &mut H| -> anyhow::Result<()> {
        h.step();
        h.render().map_err(anyhow::Error::msg)?;
        Ok(())
    };
    // Mean frame time, and the part of it the UI pass takes (the app's update, layout and
    // tessellation; the rest is the renderer's draw and the read-back of the window).
    let time_frames = |h: &mut H, input: &dyn Fn(&mut H, usize)| -> anyhow::Result<(f64, f64)> {
        render(h)?;
        let t = Instant::now();
        let mut ui = std::time::Duration::ZERO;
        for i in 0..frames {
            input(h, i);
            let u = Instant::now();
            h.step();
            ui += u.elapsed();
            h.render().map_err(anyhow::Error::msg)?;
        }
        let per = |d: std::time::Duration| d.as_secs_f64() * 1e3 / frames.max(1) as f64;
        Ok((per(t.elapsed()), per(ui)))
    };
    let frame_ms_maps = time_frames(&mut h, &|_, _| {})?;
    let pane = h
        .state()
        .panes
        .first()
        .and_then(|p| p.drawn)
        .map(|(rect, _)| rect)
        .ok_or_else(|| anyhow::anyhow!("the map pane was not drawn"))?;
    let frame_ms_hover = time_frames(&mut h, &|h, i| {
        let t = i as f32 / frames.max(1) as f32;
        h.hover_at(pane.lerp_inside(egui::vec2(0.2 + 0.6 * t, 0.3 + 0.4 * t)));
    })?;
    let frame_ms_zoom = time_frames(&mut h, &|h, i| {
        let delta = if i % 2 == 0 { 60.0 } else { -60.0 };
        h.event(egui::Event::MouseWheel {
            unit: egui::MouseWheelUnit::Point,
            delta: egui::vec2(0.0, delta),
            phase: egui::TouchPhase::Move,
            source: egui::MouseWheelSource::Unknown,
            modifiers: egui::Modifiers::NONE,
        });
    })?;
    h.remove_cursor();
    let t = Instant::now();
    {
        let app = h.state_mut();
        let mut p = app.model.params.clone();
        p.tau0 *= 0.8;
        app.model.set_params(p);
        app.model.finish_now()?;
    }
    render(&mut h)?;
    let tau0_update_ms = t.elapsed().as_secs_f64() * 1e3;
    let cloud_points = {
        let app = h.state_mut();
        app.model.backproject(false);
        app.show_cloud();
        app.model.cloud.points.len()
    };
    let frame_ms_cloud = time_frames(&mut h, &|_, _| {})?;
    // Memory: a full ACMM run, then a Compare, twice.
    for round in 0..2 {
        {
            let app = h.state_mut();
            app.tab = app::Tab::Maps;
            app.model.set_method(crate::acmm::params::Method::Acmm);
            app.model.run_to_end();
            app.model.finish_now()?;
        }
        render(&mut h)?;
        if round == 0 {
            rss_mib[1] = resident_mib();
            held_mib[1] = held(&h);
        }
        {
            let app = h.state_mut();
            app.tab = app::Tab::Compare;
            app.model.start_comparison();
            app.model.finish_now()?;
        }
        render(&mut h)?;
        rss_mib[2 + round] = resident_mib();
        held_mib[2 + round] = held(&h);
        // The second round switches back to ACMM from the comparison's start: a fresh run.
        if round == 0 {
            let app = h.state_mut();
            app.model.set_method(crate::acmm::params::Method::Acmh);
        }
    }
    let adapter = h.state().model.ctx.info.name.clone();
    let checkpoint_budget_mib = h
        .state()
        .model
        .session
        .as_ref()
        .map_or(0.0, |s| s.checkpoint_budget() as f64 / (1u64 << 20) as f64);
    Ok(ViewerBench {
        adapter,
        width: size.0,
        height: size.1,
        window,
        steps,
        frame_ms_maps,
        frame_ms_hover,
        frame_ms_zoom,
        frame_ms_cloud,
        cloud_points,
        tau0_update_ms,
        rss_mib,
        held_mib,
        checkpoint_budget_mib,
    })
}
