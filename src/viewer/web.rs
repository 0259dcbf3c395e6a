//! The viewer as a web page (WebGPU), built by scripts/build-web.sh into `target/web/`: the
//! same [`ViewerApp`] as natively, on the browser's WebGPU device. This module is the page's
//! entry: reading the address (`?steps=N&map=NAME&method=M&size=WxH&views=V&tour=1`) and
//! starting eframe's web runner on the page's canvas; `browser` has what the app uses of the
//! page.

use wasm_bindgen::JsCast;

use super::ViewerOptions;
use super::app::{Goal, ViewerApp};
use super::browser::{document, listen_to_inputs, set_title};
use super::maps::MapKind;
use crate::acmm::params::Method;

/// What the page's address asks for.
fn options_and_goal() -> (ViewerOptions, Option<Goal>, bool, u64) {
    let search = web_sys::window()
        .and_then(|w| w.location().search().ok())
        .unwrap_or_default();
    let query = web_sys::UrlSearchParams::new_with_str(&search).ok();
    let get = |k: &str| query.as_ref().and_then(|q| q.get(k));
    let size = get("size").and_then(|s| {
        let (w, h) = s.split_once('x')?;
        Some((w.parse().ok()?, h.parse().ok()?))
    });
    let method = get("method")
        .and_then(|m| {
            Method::ALL
                .into_iter()
                .find(|x| x.to_string().eq_ignore_ascii_case(&m))
        })
        .unwrap_or_default();
    let options = ViewerOptions {
        method,
        // A 4:3 demo small enough for a laptop's integrated GPU, unless asked otherwise.
        demo_size: Some(size.unwrap_or((320, 240))),
        demo_views: get("views").and_then(|v| v.parse().ok()),
        ..ViewerOptions::default()
    };
    let steps = get("steps").map(|s| {
        if s == "all" {
            usize::MAX
        } else {
            s.parse().unwrap_or(0)
        }
    });
    let goal = steps.map(|steps| Goal::new(steps, get("map").and_then(|m| MapKind::from_name(&m))));
    let tour = get("tour").is_some_and(|t| t != "0") || goal.is_none();
    // A test hook: the panes' read-backs held this many frames, as on a busy device.
    let hold = get("hold").and_then(|h| h.parse().ok()).unwrap_or(0);
    (options, goal, tour, hold)
}

/// The page's entry point (the binary's `main` in the browser).
pub fn start() {
    console_error_panic_hook::set_once();
    let _ = eframe::WebLogger::init(log::LevelFilter::Info);
    let (options, goal, tour, hold) = options_and_goal();
    listen_to_inputs();
    wasm_bindgen_futures::spawn_local(async move {
        let status = document().and_then(|d| d.get_element_by_id("mvscope_status"));
        let Some(canvas) = document()
            .and_then(|d| d.get_element_by_id("mvscope_canvas"))
            .and_then(|c| c.dyn_into::<web_sys::HtmlCanvasElement>().ok())
        else {
            log::error!("the page has no canvas with id mvscope_canvas");
            return;
        };
        let web_options = eframe::WebOptions {
            wgpu_options: egui_wgpu::WgpuConfiguration {
                wgpu_setup: super::wgpu_setup(),
                ..Default::default()
            },
            ..Default::default()
        };
        let started = eframe::WebRunner::new()
            .start(
                canvas,
                web_options,
                Box::new(move |cc| {
                    let mut app = ViewerApp::new(cc, options)?;
                    app.goal = goal;
                    app.show_tour = tour;
                    app.hold_readbacks = hold;
                    Ok(Box::new(app))
                }),
            )
            .await;
        match started {
            Ok(()) => {
                if let Some(s) = status {
                    s.remove();
                }
            }
            Err(e) => {
                let text = format!(
                    "mvscope could not start: {e:?}. It needs a browser with WebGPU (Chrome or \
                     Edge 113+, Safari 26+, Firefox 141+ on Windows); a browser without a GPU \
                     may need WebGPU's software adapter enabled."
                );
                log::error!("{text}");
                if let Some(s) = status {
                    s.set_text_content(Some(&text));
                }
                set_title("mvscope: failed");
            }
        }
    });
}
