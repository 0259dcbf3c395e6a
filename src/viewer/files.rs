//! The viewer's own file dialog. The system dialog (rfd) only works where an
//! xdg-desktop-portal runs, and where none does it returns nothing, exactly as if the user
//! had cancelled. This dialog works on any desktop and headlessly: a path field, the
//! folder's entries, the recent scenes, and a button that tries the system dialog.

use std::path::{Path, PathBuf};

use egui::Color32;

/// What the dialog is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    OpenScene,
    LoadParams,
    SaveParams,
}

impl Purpose {
    pub fn title(self) -> &'static str {
        match self {
            Purpose::OpenScene => "Open scene folder",
            Purpose::LoadParams => "Load parameters (TOML)",
            Purpose::SaveParams => "Save parameters (TOML)",
        }
    }

    fn action(self) -> &'static str {
        match self {
            Purpose::OpenScene | Purpose::LoadParams => "Open",
            Purpose::SaveParams => "Save",
        }
    }

    /// Whether `path` (a file) is listed: parameter files only, for the parameter dialogs.
    fn lists_file(self, path: &Path) -> bool {
        match self {
            Purpose::OpenScene => false,
            Purpose::LoadParams | Purpose::SaveParams => path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("toml")),
        }
    }
}

/// One dialog, open.
pub struct PathDialog {
    pub purpose: Purpose,
    /// The folder listed.
    pub dir: PathBuf,
    /// The path typed or picked.
    pub text: String,
    entries: Vec<(String, bool)>,
    /// Why the last choice was not taken (shown in the dialog).
    pub message: Option<String>,
}

/// What the user chose.
pub enum Choice {
    /// Keep the dialog open.
    None,
    Cancel,
    Path(PathBuf),
}

impl PathDialog {
    /// A dialog listing `dir`, with `name` (a file to save) or `dir` itself in the field.
    pub fn new(purpose: Purpose, dir: &Path, name: Option<&str>) -> PathDialog {
        let mut d = PathDialog {
            purpose,
            dir: PathBuf::new(),
            text: String::new(),
            entries: Vec::new(),
            message: None,
        };
        d.enter(dir);
        if let Some(n) = name {
            d.text = dir.join(n).display().to_string();
        }
        d
    }

    /// Follows a typed path: lists the folder it names, or the folder of the file it
    /// names, keeping the text as typed.
    pub fn follow_text(&mut self) {
        let typed = PathBuf::from(&self.text);
        let dir = if typed.is_dir() {
            Some(typed)
        } else {
            typed.parent().filter(|p| p.is_dir()).map(Path::to_path_buf)
        };
        if let Some(dir) = dir
            && dir != self.dir
        {
            let text = self.text.clone();
            self.enter(&dir);
            self.text = text;
        }
    }

    /// Lists `dir` (sub-folders first, then the files this dialog is for).
    pub fn enter(&mut self, dir: &Path) {
        match std::fs::read_dir(dir) {
            Ok(read) => {
                let mut entries: Vec<(String, bool)> = read
                    .flatten()
                    .filter_map(|e| {
                        let path = e.path();
                        let name = e.file_name().to_string_lossy().into_owned();
                        if name.starts_with('.') {
                            return None;
                        }
                        let is_dir = path.is_dir();
                        (is_dir || self.purpose.lists_file(&path)).then_some((name, is_dir))
                    })
                    .collect();
                entries.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
                self.entries = entries;
                self.dir = dir.to_path_buf();
                self.text = dir.display().to_string();
                self.message = None;
            }
            Err(e) => {
                self.message = Some(format!("cannot list {}: {e}", dir.display()));
            }
        }
    }

    /// The listed entries: (name, is a folder).
    pub fn entries(&self) -> &[(String, bool)] {
        &self.entries
    }

    /// Checks the typed path for this dialog's purpose.
    pub fn check(&self) -> Result<PathBuf, String> {
        let text = self.text.trim();
        if text.is_empty() {
            return Err("type a path or pick one below".into());
        }
        let path = PathBuf::from(text);
        match self.purpose {
            Purpose::OpenScene if !path.is_dir() => Err(format!(
                "{} is not a folder: pick the scene's folder (COLMAP, ACMM, MVSNet, Middlebury \
                 or Strecha layout)",
                path.display()
            )),
            Purpose::LoadParams if !path.is_file() => {
                Err(format!("{} is not a file", path.display()))
            }
            Purpose::SaveParams if path.is_dir() => Err(format!(
                "{} is a folder: add a file name such as params.toml",
                path.display()
            )),
            Purpose::SaveParams
                if !path
                    .parent()
                    .is_none_or(|p| p.as_os_str().is_empty() || p.is_dir()) =>
            {
                Err(format!("the folder of {} does not exist", path.display()))
            }
            _ => Ok(path),
        }
    }

    /// Draws the dialog; `recent` scenes are offered for opening a scene.
    pub fn show(&mut self, ctx: &egui::Context, recent: &[PathBuf]) -> Choice {
        let mut choice = Choice::None;
        let mut open = true;
        egui::Window::new(self.purpose.title())
            .open(&mut open)
            .default_width(480.0)
            .collapsible(false)
            .show(ctx, |ui| {
                let field = ui.horizontal(|ui| {
                    let label = ui.label("path");
                    ui.add(
                        egui::TextEdit::singleline(&mut self.text)
                            .desired_width(f32::INFINITY)
                            .hint_text("a folder or file path"),
                    )
                    .labelled_by(label.id)
                });
                let field = field.inner;
                if field.changed() {
                    self.follow_text();
                }
                let entered = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
                ui.horizontal(|ui| {
                    if ui.button("Up").clicked()
                        && let Some(parent) = self.dir.parent().map(Path::to_path_buf)
                    {
                        self.enter(&parent);
                    }
                    ui.label(self.dir.display().to_string());
                });
                let mut go: Option<PathBuf> = None;
                egui::ScrollArea::vertical()
                    .max_height(220.0)
                    .id_salt("entries")
                    .show(ui, |ui| {
                        for (name, is_dir) in &self.entries {
                            let label = if *is_dir {
                                format!("{name}/")
                            } else {
                                name.clone()
                            };
                            let r = ui.selectable_label(false, label);
                            if r.double_clicked() && *is_dir {
                                go = Some(self.dir.join(name));
                            } else if r.clicked() {
                                self.text = self.dir.join(name).display().to_string();
                            }
                        }
                        if self.entries.is_empty() {
                            ui.weak("(nothing to list here)");
                        }
                    });
                if let Some(dir) = go {
                    self.enter(&dir);
                }
                if self.purpose == Purpose::OpenScene && !recent.is_empty() {
                    ui.separator();
                    ui.label("Recent scenes");
                    for r in recent {
                        if ui
                            .selectable_label(false, r.display().to_string())
                            .clicked()
                        {
                            self.text = r.display().to_string();
                        }
                    }
                }
                if let Some(m) = &self.message {
                    ui.colored_label(Color32::from_rgb(255, 120, 90), m);
                }
                ui.separator();
                ui.horizontal(|ui| {
                    let accept = ui.button(self.purpose.action()).clicked() || entered;
                    if accept {
                        match self.check() {
                            Ok(p) => choice = Choice::Path(p),
                            Err(e) => self.message = Some(e),
                        }
                    }
                    if ui.button("Cancel").clicked() {
                        choice = Choice::Cancel;
                    }
                    if ui
                        .button("System dialog...")
                        .on_hover_text("the desktop's own dialog (needs an xdg-desktop-portal)")
                        .clicked()
                    {
                        match self.system_dialog() {
                            Some(p) => choice = Choice::Path(p),
                            None => {
                                self.message = Some(
                                    "the system dialog returned nothing: it was cancelled, or \
                                     no xdg-desktop-portal runs here. Type or pick the path \
                                     above."
                                        .into(),
                                )
                            }
                        }
                    }
                });
            });
        if !open {
            choice = Choice::Cancel;
        }
        choice
    }

    /// The desktop's file dialog (none in the browser: the page has its own file input).
    #[cfg(target_arch = "wasm32")]
    fn system_dialog(&self) -> Option<PathBuf> {
        None
    }

    #[cfg(not(target_arch = "wasm32"))]
    fn system_dialog(&self) -> Option<PathBuf> {
        let dialog = rfd::FileDialog::new().set_directory(&self.dir);
        match self.purpose {
            Purpose::OpenScene => dialog.pick_folder(),
            Purpose::LoadParams => dialog.add_filter("TOML", &["toml"]).pick_file(),
            Purpose::SaveParams => dialog
                .add_filter("TOML", &["toml"])
                .set_file_name("params.toml")
                .save_file(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_folders_first_and_only_the_files_the_dialog_is_for() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("scene")).unwrap();
        std::fs::write(dir.path().join("p.toml"), "tau0 = 0.5\n").unwrap();
        std::fs::write(dir.path().join("image.png"), b"x").unwrap();
        std::fs::write(dir.path().join(".hidden"), b"x").unwrap();
        let d = PathDialog::new(Purpose::LoadParams, dir.path(), None);
        assert_eq!(
            d.entries(),
            &[("scene".to_string(), true), ("p.toml".to_string(), false)]
        );
        let d = PathDialog::new(Purpose::OpenScene, dir.path(), None);
        assert_eq!(d.entries(), &[("scene".to_string(), true)]);
    }

    #[test]
    fn the_listing_follows_a_typed_path() {
        let tmp = tempfile::tempdir().unwrap();
        std::fs::create_dir(tmp.path().join("scene")).unwrap();
        std::fs::write(tmp.path().join("scene/params.toml"), "").unwrap();
        let mut d = PathDialog::new(Purpose::LoadParams, &std::env::temp_dir(), None);
        // A folder typed: listed, the text as typed.
        d.text = tmp.path().join("scene").display().to_string();
        d.follow_text();
        assert_eq!(d.dir, tmp.path().join("scene"));
        assert_eq!(d.entries(), &[("params.toml".to_string(), false)]);
        // A file typed (half of its name): its folder listed.
        d.text = tmp.path().join("sce").display().to_string();
        d.follow_text();
        assert_eq!(d.dir, tmp.path());
        assert!(d.text.ends_with("sce"));
        // Nothing that exists: the listing stays.
        d.text = "/no/such/place/x".into();
        d.follow_text();
        assert_eq!(d.dir, tmp.path());
    }

    #[test]
    fn a_wrong_kind_of_path_is_refused_with_a_reason() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.toml");
        std::fs::write(&file, "").unwrap();
        let mut d = PathDialog::new(Purpose::OpenScene, dir.path(), None);
        d.text = file.display().to_string();
        assert!(d.check().unwrap_err().contains("not a folder"));
        let mut d = PathDialog::new(Purpose::SaveParams, dir.path(), Some("params.toml"));
        assert_eq!(d.check().unwrap(), dir.path().join("params.toml"));
        d.text = dir.path().join("missing/params.toml").display().to_string();
        assert!(d.check().unwrap_err().contains("does not exist"));
        d.text = dir.path().display().to_string();
        assert!(d.check().unwrap_err().contains("is a folder"));
    }
}
