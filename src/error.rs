//! Errors of loading and validating input: each says where (file, line, view), what is wrong,
//! and what to do.

use std::path::{Path, PathBuf};

/// Something wrong with a scene or one of its files.
#[derive(Debug, thiserror::Error)]
#[error("{location}: {message}")]
pub struct SceneError {
    /// `file`, `file:line`, `view NAME` or the scene folder.
    pub location: String,
    /// What is wrong and what to do about it.
    pub message: String,
    pub path: Option<PathBuf>,
    pub line: Option<usize>,
}

impl SceneError {
    /// A problem with a whole file.
    pub fn file(path: &Path, message: impl Into<String>) -> SceneError {
        SceneError {
            location: path.display().to_string(),
            message: message.into(),
            path: Some(path.to_path_buf()),
            line: None,
        }
    }

    /// A problem on one line (1-based) of a text file.
    pub fn line(path: &Path, line: usize, message: impl Into<String>) -> SceneError {
        SceneError {
            location: format!("{}:{line}", path.display()),
            message: message.into(),
            path: Some(path.to_path_buf()),
            line: Some(line),
        }
    }

    /// A problem with one view of a scene.
    pub fn view(name: &str, message: impl Into<String>) -> SceneError {
        SceneError {
            location: format!("view {name}"),
            message: message.into(),
            path: None,
            line: None,
        }
    }

    /// A file that cannot be opened or read.
    pub fn io(path: &Path, err: std::io::Error) -> SceneError {
        let what = match err.kind() {
            std::io::ErrorKind::NotFound => "the file is missing".to_string(),
            std::io::ErrorKind::PermissionDenied => {
                "the file cannot be read (permission denied)".to_string()
            }
            _ => format!("the file cannot be read ({err})"),
        };
        SceneError::file(
            path,
            format!("{what}; check the path and the scene's layout"),
        )
    }
}
