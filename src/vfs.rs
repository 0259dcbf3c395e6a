//! Where the scene loaders read files from: the disk, or files held in memory (a zip of a
//! scene folder, or a folder a browser handed over file by file, which has no paths on disk).
//!
//! The loaders call [`read`], [`is_file`], [`is_dir`] and [`read_dir`] instead of `std::fs`.
//! They read the disk unless [`with_files`] runs them over a [`MemoryFiles`]: then every path
//! is looked up among its files (the first component of a relative path is the archive's top
//! folder, as a path on disk would name it), case-insensitively as a last resort since zips
//! made on other systems do not keep case the way a folder name was typed. The files are set
//! per thread for the duration of the call, so loading from memory needs no change to the
//! loaders' signatures.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::io;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

/// A scene's files in memory, by path relative to [`MemoryFiles::root`]'s parent.
#[derive(Clone, Debug, Default)]
pub struct MemoryFiles {
    files: BTreeMap<PathBuf, Arc<Vec<u8>>>,
}

thread_local! {
    static FILES: RefCell<Option<Arc<MemoryFiles>>> = const { RefCell::new(None) };
}

/// A path as a key: its normal components, without a leading `/` or `./`.
fn key(path: &Path) -> PathBuf {
    path.components()
        .filter_map(|c| match c {
            Component::Normal(s) => Some(s),
            _ => None,
        })
        .collect()
}

impl MemoryFiles {
    /// Files given by (path, bytes), paths with `/` separators (a browser's
    /// `webkitRelativePath`, e.g. `scene/images/00000000.jpg`).
    pub fn from_files(files: impl IntoIterator<Item = (String, Vec<u8>)>) -> MemoryFiles {
        MemoryFiles {
            files: files
                .into_iter()
                .map(|(p, b)| (key(Path::new(&p)), Arc::new(b)))
                .collect(),
        }
    }

    /// The files of a zip archive (folders skipped). The message of an error says what is
    /// wrong with the archive and names the entry.
    pub fn from_zip(bytes: &[u8]) -> Result<MemoryFiles, String> {
        let mut archive = zip::ZipArchive::new(io::Cursor::new(bytes))
            .map_err(|e| format!("not a readable zip archive ({e})"))?;
        let mut files = BTreeMap::new();
        for i in 0..archive.len() {
            let mut entry = archive
                .by_index(i)
                .map_err(|e| format!("zip entry {i}: {e}"))?;
            if entry.is_dir() {
                continue;
            }
            let Some(path) = entry.enclosed_name() else {
                return Err(format!(
                    "zip entry {}: a path that leaves the archive",
                    entry.name()
                ));
            };
            let mut data = Vec::with_capacity(entry.size() as usize);
            io::copy(&mut entry, &mut data)
                .map_err(|e| format!("zip entry {}: {e}", path.display()))?;
            files.insert(key(&path), Arc::new(data));
        }
        if files.is_empty() {
            return Err("the zip archive holds no files".into());
        }
        Ok(MemoryFiles { files })
    }

    /// The folder to open: the deepest folder that holds every file (a zip of `scene/` has
    /// `scene`; files dropped loose have the empty path).
    pub fn root(&self) -> PathBuf {
        let mut paths = self.files.keys();
        let Some(first) = paths.next() else {
            return PathBuf::new();
        };
        let mut common: Vec<_> = first.parent().map_or(Vec::new(), |p| {
            p.components().map(|c| c.as_os_str().to_owned()).collect()
        });
        for p in paths {
            let parts: Vec<_> = p.components().map(|c| c.as_os_str().to_owned()).collect();
            let same = common
                .iter()
                .zip(&parts[..parts.len().saturating_sub(1)])
                .take_while(|(a, b)| a == b)
                .count();
            common.truncate(same);
        }
        common.into_iter().collect()
    }

    /// How many files.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    fn get(&self, path: &Path) -> Option<&Arc<Vec<u8>>> {
        let k = key(path);
        self.files.get(&k).or_else(|| {
            let lower = k.to_string_lossy().to_lowercase();
            self.files
                .iter()
                .find(|(p, _)| p.to_string_lossy().to_lowercase() == lower)
                .map(|(_, b)| b)
        })
    }

    fn is_dir(&self, path: &Path) -> bool {
        let k = key(path);
        k.as_os_str().is_empty() || self.files.keys().any(|p| p.starts_with(&k) && *p != k)
    }

    fn read_dir(&self, path: &Path) -> Vec<PathBuf> {
        let k = key(path);
        let mut out: Vec<PathBuf> = self
            .files
            .keys()
            .filter_map(|p| p.strip_prefix(&k).ok())
            .filter_map(|rest| rest.components().next())
            .map(|c| path.join(c.as_os_str()))
            .collect();
        out.dedup();
        out
    }
}

/// Runs `f` with the loaders reading `files` instead of the disk (on this thread).
pub fn with_files<R>(files: Arc<MemoryFiles>, f: impl FnOnce() -> R) -> R {
    let before = FILES.with(|c| c.replace(Some(files)));
    let out = f();
    FILES.with(|c| *c.borrow_mut() = before);
    out
}

fn memory() -> Option<Arc<MemoryFiles>> {
    FILES.with(|c| c.borrow().clone())
}

/// A file's bytes.
pub fn read(path: &Path) -> io::Result<Vec<u8>> {
    match memory() {
        Some(m) => m
            .get(path)
            .map(|b| b.as_ref().clone())
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, "not among the files given")),
        None => std::fs::read(path),
    }
}

/// Whether `path` is a file.
pub fn is_file(path: &Path) -> bool {
    match memory() {
        Some(m) => m.get(path).is_some(),
        None => path.is_file(),
    }
}

/// Whether `path` is a folder.
pub fn is_dir(path: &Path) -> bool {
    match memory() {
        Some(m) => m.is_dir(path),
        None => path.is_dir(),
    }
}

/// The entries of a folder, as paths (`path` joined with each name), unsorted.
pub fn read_dir(path: &Path) -> io::Result<Vec<PathBuf>> {
    match memory() {
        Some(m) if m.is_dir(path) => Ok(m.read_dir(path)),
        Some(_) => Err(io::Error::new(
            io::ErrorKind::NotFound,
            "no such folder among the files given",
        )),
        None => std::fs::read_dir(path)?
            .map(|e| e.map(|e| e.path()))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_files_answer_like_a_folder_and_leave_the_disk_alone() {
        let files = Arc::new(MemoryFiles::from_files([
            ("scene/pair.txt".to_string(), b"2".to_vec()),
            ("scene/images/00000000.jpg".to_string(), vec![1, 2]),
            ("scene/Cams/00000000_cam.txt".to_string(), vec![3]),
        ]));
        assert_eq!(files.root(), PathBuf::from("scene"));
        with_files(files, || {
            let root = Path::new("scene");
            assert!(is_dir(root) && is_dir(&root.join("images")));
            assert!(is_file(&root.join("pair.txt")) && !is_dir(&root.join("pair.txt")));
            assert_eq!(read(&root.join("images/00000000.jpg")).unwrap(), vec![1, 2]);
            // A case-insensitive match when the exact one is missing.
            assert_eq!(read(&root.join("cams/00000000_cam.txt")).unwrap(), vec![3]);
            let mut entries = read_dir(root).unwrap();
            entries.sort();
            assert_eq!(
                entries,
                ["scene/Cams", "scene/images", "scene/pair.txt"].map(PathBuf::from)
            );
            assert!(read(&root.join("missing")).is_err());
            assert!(read_dir(&root.join("missing")).is_err());
        });
        // Outside the call, the disk again.
        assert!(!is_file(Path::new("scene/pair.txt")));
    }

    #[test]
    fn a_zip_holds_the_same_files() {
        use std::io::Write;
        let mut buf = io::Cursor::new(Vec::new());
        {
            let mut z = zip::ZipWriter::new(&mut buf);
            let opts = zip::write::SimpleFileOptions::default();
            z.add_directory("demo/", opts).unwrap();
            z.start_file("demo/pair.txt", opts).unwrap();
            z.write_all(b"1\n").unwrap();
            z.start_file("demo/images/00000000.png", opts).unwrap();
            z.write_all(&[9; 10]).unwrap();
            z.finish().unwrap();
        }
        let files = MemoryFiles::from_zip(buf.get_ref()).unwrap();
        assert_eq!(files.len(), 2);
        assert_eq!(files.root(), PathBuf::from("demo"));
        let err = MemoryFiles::from_zip(b"not a zip").unwrap_err();
        assert!(err.contains("zip"), "{err}");
    }
}
