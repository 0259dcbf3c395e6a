//! What the viewer uses of the browser page it runs in (the web build, see `web`): the file
//! inputs that hand a scene folder or a zip over as bytes, files dropped on the page, the page
//! title that says when a scripted run is done, the console and the page's clock.

use std::cell::RefCell;

use wasm_bindgen::JsCast;
use wasm_bindgen::prelude::*;

use crate::vfs::MemoryFiles;

/// A scene the page's file inputs read: its files in memory, and what to call it.
pub struct Incoming {
    pub files: Result<MemoryFiles, String>,
}

thread_local! {
    static INCOMING: RefCell<Vec<Incoming>> = const { RefCell::new(Vec::new()) };
}

/// Scenes the page has read since the last call (the app opens the newest).
pub fn take_incoming() -> Vec<Incoming> {
    INCOMING.with(|i| std::mem::take(&mut *i.borrow_mut()))
}

pub(super) fn document() -> Option<web_sys::Document> {
    web_sys::window()?.document()
}

/// Sets the page's title (what a headless browser waits for).
pub fn set_title(title: &str) {
    if let Some(d) = document() {
        d.set_title(title);
    }
}

/// Writes a line to the browser's console (`console.log`).
pub fn console_log(text: &str) {
    web_sys::console::log_1(&JsValue::from_str(text));
}

/// Milliseconds since the page started loading (`performance.now()`).
pub fn now_ms() -> f64 {
    web_sys::window()
        .and_then(|w| w.performance())
        .map_or(0.0, |p| p.now())
}

/// Opens the browser's file chooser for a scene folder (`folder`) or a zip of one: clicks
/// the page's hidden file input (the click in the app is the user's gesture it needs).
pub fn choose_scene(folder: bool) {
    let id = if folder {
        "mvscope_open_folder"
    } else {
        "mvscope_open_zip"
    };
    if let Some(input) = document()
        .and_then(|d| d.get_element_by_id(id))
        .and_then(|e| e.dyn_into::<web_sys::HtmlInputElement>().ok())
    {
        input.set_value("");
        input.click();
    }
}

/// Reads the files an input was given (every file of a folder, with its path inside it; or
/// one zip) and queues them for the app.
async fn read_input(input: web_sys::HtmlInputElement) {
    let Some(list) = input.files() else {
        return;
    };
    let mut files = Vec::new();
    let mut zip = None;
    for i in 0..list.length() {
        let Some(file) = list.get(i) else {
            continue;
        };
        let name = file.name();
        // A folder's files carry their path inside it; a single file only its name.
        let path = js_sys::Reflect::get(&file, &JsValue::from_str("webkitRelativePath"))
            .ok()
            .and_then(|v| v.as_string())
            .filter(|p| !p.is_empty())
            .unwrap_or_else(|| name.clone());
        let bytes = match wasm_bindgen_futures::JsFuture::from(file.array_buffer()).await {
            Ok(buffer) => js_sys::Uint8Array::new(&buffer).to_vec(),
            Err(e) => {
                let message = format!("{path}: the browser did not read it ({e:?})");
                INCOMING.with(|q| {
                    q.borrow_mut().push(Incoming {
                        files: Err(message),
                    })
                });
                return;
            }
        };
        if name.to_lowercase().ends_with(".zip") && list.length() == 1 {
            zip = Some(bytes);
        } else {
            files.push((path, bytes));
        }
    }
    let files = match zip {
        Some(bytes) => MemoryFiles::from_zip(&bytes),
        None => Ok(MemoryFiles::from_files(files)),
    };
    INCOMING.with(|q| q.borrow_mut().push(Incoming { files }));
}

/// Reads files dropped on the page (a zip, or the loose files of a scene) and queues them.
pub fn read_dropped(dropped: Vec<egui::DroppedFileHandle>) {
    wasm_bindgen_futures::spawn_local(async move {
        let mut files = Vec::new();
        for f in &dropped {
            let name = f.path().to_string_lossy().into_owned();
            match f.bytes_async().await {
                Ok(bytes) => files.push((name, bytes)),
                Err(e) => {
                    let message = format!("{name}: the browser did not read it ({e})");
                    INCOMING.with(|q| {
                        q.borrow_mut().push(Incoming {
                            files: Err(message),
                        })
                    });
                    return;
                }
            }
        }
        let zip = files
            .iter()
            .position(|(n, _)| n.to_lowercase().ends_with(".zip"));
        let files = match zip {
            Some(i) => MemoryFiles::from_zip(&files[i].1),
            None => Ok(MemoryFiles::from_files(files)),
        };
        INCOMING.with(|q| q.borrow_mut().push(Incoming { files }));
    });
}

/// Wires the page's file inputs to [`read_input`].
pub(super) fn listen_to_inputs() {
    for id in ["mvscope_open_folder", "mvscope_open_zip"] {
        let Some(input) = document()
            .and_then(|d| d.get_element_by_id(id))
            .and_then(|e| e.dyn_into::<web_sys::HtmlInputElement>().ok())
        else {
            continue;
        };
        let target = input.clone();
        let on_change = Closure::<dyn FnMut()>::new(move || {
            wasm_bindgen_futures::spawn_local(read_input(target.clone()));
        });
        let _ =
            input.add_event_listener_with_callback("change", on_change.as_ref().unchecked_ref());
        // The page lives as long as the listener: keep the closure.
        on_change.forget();
    }
}
