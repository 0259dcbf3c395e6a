//! Map and point-cloud files: PFM, ACMM .dmb, COLMAP stereo .bin, PLY.
//!
//! Every map format is read into, and written from, one in-memory type, [`Map`]: row-major,
//! TOP row first, channels interleaved. Each format module converts from its own on-disk
//! convention (PFM stores rows bottom-to-top, COLMAP stores channels as planes) to this one.
//!
//! Every writer goes through [`write_atomic`], so an interrupted run never leaves a truncated
//! file under the final name. Every error is an [`IoError`] that names the file.

pub mod colmap_map;
pub mod dmb;
pub mod pfm;
pub mod ply;
pub mod png;

pub use colmap_map::{read_colmap_map, write_colmap_map};
pub use dmb::{read_dmb, write_dmb};
pub use pfm::{read_pfm, write_pfm};
pub use ply::{PlyPoint, read_ply, write_ply};
pub use png::write_png;

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A dense per-pixel map (depth, normal, cost, ...) of `channels` floats per pixel.
///
/// Layout: row-major, TOP row first, channels interleaved, i.e. the value of channel `c` at
/// column `x`, row `y` is `data[(y * width + x) * channels + c]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub data: Vec<f32>,
}

/// [`Map::from_data`] was given a data vector whose length does not match its size.
#[derive(Debug, thiserror::Error)]
#[error(
    "map data has {len} values but a {width}x{height} map with {channels} channel(s) needs \
     {expected}; pass width, height and channels that match the data"
)]
pub struct MapShapeError {
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub len: usize,
    /// `width * height * channels`, saturated at `usize::MAX`.
    pub expected: usize,
}

/// `width * height * channels` as `usize`, `None` on overflow.
fn value_count(width: u32, height: u32, channels: u32) -> Option<usize> {
    usize::try_from(width)
        .ok()?
        .checked_mul(usize::try_from(height).ok()?)?
        .checked_mul(usize::try_from(channels).ok()?)
}

impl Map {
    /// A zero-filled map.
    pub fn new(width: u32, height: u32, channels: u32) -> Map {
        let len = value_count(width, height, channels).unwrap_or(usize::MAX);
        Map {
            width,
            height,
            channels,
            data: vec![0.0; len],
        }
    }

    /// A map over existing data (top row first, channels interleaved); fails when
    /// `data.len() != width * height * channels`.
    pub fn from_data(
        width: u32,
        height: u32,
        channels: u32,
        data: Vec<f32>,
    ) -> Result<Map, MapShapeError> {
        let expected = value_count(width, height, channels);
        if expected != Some(data.len()) {
            return Err(MapShapeError {
                width,
                height,
                channels,
                len: data.len(),
                expected: expected.unwrap_or(usize::MAX),
            });
        }
        Ok(Map {
            width,
            height,
            channels,
            data,
        })
    }

    /// Index into [`Map::data`] of channel `c` at column `x`, row `y` (row 0 is the top).
    /// Does not check bounds.
    #[inline]
    pub fn index(&self, x: u32, y: u32, c: u32) -> usize {
        ((y as usize * self.width as usize) + x as usize) * self.channels as usize + c as usize
    }

    /// Whether `(x, y, c)` lies inside the map.
    #[inline]
    pub fn contains(&self, x: u32, y: u32, c: u32) -> bool {
        x < self.width && y < self.height && c < self.channels
    }

    /// Channel `c` at column `x`, row `y` (row 0 is the top).
    ///
    /// # Panics
    ///
    /// Like slice indexing, when `(x, y, c)` is outside the map; see [`Map::try_get`].
    #[inline]
    pub fn get(&self, x: u32, y: u32, c: u32) -> f32 {
        debug_assert!(self.contains(x, y, c), "({x}, {y}, {c}) outside the map");
        self.data[self.index(x, y, c)]
    }

    /// Channel `c` at column `x`, row `y`, or `None` outside the map.
    #[inline]
    pub fn try_get(&self, x: u32, y: u32, c: u32) -> Option<f32> {
        if self.contains(x, y, c) {
            self.data.get(self.index(x, y, c)).copied()
        } else {
            None
        }
    }

    /// Sets channel `c` at column `x`, row `y` (row 0 is the top).
    ///
    /// # Panics
    ///
    /// Like slice indexing, when `(x, y, c)` is outside the map.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, c: u32, v: f32) {
        debug_assert!(self.contains(x, y, c), "({x}, {y}, {c}) outside the map");
        let i = self.index(x, y, c);
        self.data[i] = v;
    }

    /// All channels of the pixel at column `x`, row `y`, or `None` outside the map.
    pub fn pixel(&self, x: u32, y: u32) -> Option<&[f32]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let start = self.index(x, y, 0);
        self.data.get(start..start + self.channels as usize)
    }

    /// Checks that the map can be written: non-zero sizes, data length matching them.
    fn check_writable(&self, path: &Path) -> Result<(), IoError> {
        if self.width == 0 || self.height == 0 || self.channels == 0 {
            return Err(IoError::invalid(
                path,
                format!(
                    "the map is {}x{} with {} channel(s); only maps with non-zero width, height \
                     and channels can be written",
                    self.width, self.height, self.channels
                ),
            ));
        }
        if value_count(self.width, self.height, self.channels) != Some(self.data.len()) {
            return Err(IoError::invalid(
                path,
                format!(
                    "the map says {}x{} with {} channel(s) but holds {} values; build it with \
                     Map::new or Map::from_data",
                    self.width,
                    self.height,
                    self.channels,
                    self.data.len()
                ),
            ));
        }
        Ok(())
    }
}

/// Reading or writing a map or point-cloud file failed. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused an operation on the file.
    #[error("{}: cannot {action}: {error}{}", path.display(), io_hint(error))]
    Io {
        path: PathBuf,
        /// What was attempted, e.g. "read", "write", "rename the temporary file to".
        action: &'static str,
        error: std::io::Error,
    },
    /// The file ends before the data its header announces.
    #[error(
        "{}: truncated: expected {expected} bytes of {part}, found {found}; the file was not \
         written completely",
        path.display()
    )]
    Truncated {
        path: PathBuf,
        /// "header" or "data".
        part: &'static str,
        expected: u64,
        found: u64,
    },
    /// The file is not in the expected format; `message` says what is wrong and what to do.
    #[error("{}: {message}", path.display())]
    Malformed { path: PathBuf, message: String },
    /// The data given to a writer cannot be stored in the format; nothing was written.
    #[error("{}: cannot write: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
}

fn io_hint(error: &std::io::Error) -> &'static str {
    match error.kind() {
        std::io::ErrorKind::NotFound => "; check the path",
        std::io::ErrorKind::PermissionDenied => "; check the file's permissions",
        std::io::ErrorKind::UnexpectedEof => "; the file was not written completely",
        _ => "",
    }
}

impl IoError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            IoError::Io { path, .. }
            | IoError::Truncated { path, .. }
            | IoError::Malformed { path, .. }
            | IoError::Invalid { path, .. } => path,
        }
    }

    pub fn io(path: &Path, action: &'static str, error: std::io::Error) -> IoError {
        IoError::Io {
            path: path.to_path_buf(),
            action,
            error,
        }
    }

    pub(crate) fn malformed(path: &Path, message: impl Into<String>) -> IoError {
        IoError::Malformed {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub fn invalid(path: &Path, message: impl Into<String>) -> IoError {
        IoError::Invalid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn truncated(path: &Path, part: &'static str, expected: u64, found: u64) -> IoError {
        IoError::Truncated {
            path: path.to_path_buf(),
            part,
            expected,
            found,
        }
    }
}

/// Reads a whole file.
/// A file's bytes (on disk, or among a scene's files in memory: `crate::vfs`).
pub(crate) fn read_all(path: &Path) -> Result<Vec<u8>, IoError> {
    crate::vfs::read(path).map_err(|e| IoError::io(path, "read", e))
}

/// Checks that `data` (what follows the header) holds exactly `count` float32 values.
pub(crate) fn check_data_len(path: &Path, data: &[u8], count: usize) -> Result<(), IoError> {
    let expected = count as u64 * 4;
    let found = data.len() as u64;
    if found < expected {
        return Err(IoError::truncated(path, "data", expected, found));
    }
    if found > expected {
        return Err(IoError::malformed(
            path,
            format!(
                "{} bytes after the data the header announces ({expected} bytes); the header's \
                 sizes do not match the data, so the file is damaged or not in this format",
                found - expected
            ),
        ));
    }
    Ok(())
}

/// Parses a header size: a positive decimal integer that fits `u32`.
pub(crate) fn parse_size(path: &Path, what: &str, token: &str, hint: &str) -> Result<u32, IoError> {
    let value: i64 = token.trim().parse().map_err(|_| {
        IoError::malformed(
            path,
            format!("{what} {token:?} in the header is not an integer; {hint}"),
        )
    })?;
    if value <= 0 {
        return Err(IoError::malformed(
            path,
            format!("{what} {value} in the header is not positive; {hint}"),
        ));
    }
    u32::try_from(value).map_err(|_| {
        IoError::malformed(
            path,
            format!("{what} {value} in the header is too large; {hint}"),
        )
    })
}

/// Element count `width * height * channels` of a map read from `path`, as an error when it
/// does not fit memory.
pub(crate) fn checked_count(
    path: &Path,
    width: u32,
    height: u32,
    channels: u32,
) -> Result<usize, IoError> {
    value_count(width, height, channels)
        .filter(|n| n.checked_mul(4).is_some())
        .ok_or_else(|| {
            IoError::malformed(
                path,
                format!(
                    "the header's size {width}x{height}x{channels} is too large; the header is \
                     damaged"
                ),
            )
        })
}

/// Decodes little-endian float32 values.
pub(crate) fn f32s_le(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: `write` fills a temporary file `.NAME.tmp-PID-N` in the same
/// directory, which is flushed, fsynced and then renamed over `path`.
///
/// On any error the temporary file is removed and an existing `path` is left untouched, so an
/// interrupted or failed write never leaves a truncated file under the final name.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let name = path.file_name().ok_or_else(|| {
        IoError::invalid(
            path,
            "the path has no file name; give a path to a file, not a directory",
        )
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(
        ".tmp-{}-{}",
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let temp = dir.join(temp_name);

    let result = write_temp(path, &temp, write);
    if result.is_err() {
        // Best effort: the temp file may not exist when creating it failed.
        let _ = std::fs::remove_file(&temp);
        return result;
    }
    if let Err(e) = std::fs::rename(&temp, path) {
        let _ = std::fs::remove_file(&temp);
        return Err(IoError::io(path, "rename the temporary file to", e));
    }
    // Make the rename itself durable; best effort (not all platforms can open directories).
    #[cfg(unix)]
    if let Ok(d) = File::open(&dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

fn write_temp(
    path: &Path,
    temp: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let file =
        File::create(temp).map_err(|e| IoError::io(path, "create a temporary file for", e))?;
    let mut out = BufWriter::new(file);
    write(&mut out).map_err(|e| IoError::io(path, "write", e))?;
    out.flush().map_err(|e| IoError::io(path, "write", e))?;
    let file = out
        .into_inner()
        .map_err(|e| IoError::io(path, "write", e.into_error()))?;
    file.sync_all().map_err(|e| IoError::io(path, "sync", e))?;
    Ok(())
}

/// What the map formats' tests share: maps of arbitrary bits, their bits, and the error a
/// reader gives for bad bytes.
#[cfg(test)]
pub(crate) mod testing {
    use super::{IoError, Map};
    use std::path::Path;

    /// A map of arbitrary bit patterns (`seed` and `mul` vary them per format): only a
    /// bit-exact path keeps them.
    pub fn pattern(width: u32, height: u32, channels: u32, seed: u32, mul: u32) -> Map {
        let mut m = Map::new(width, height, channels);
        for (i, v) in m.data.iter_mut().enumerate() {
            *v = f32::from_bits(seed ^ (i as u32).wrapping_mul(mul));
        }
        m
    }

    pub fn bits(m: &Map) -> Vec<u32> {
        m.data.iter().map(|v| v.to_bits()).collect()
    }

    /// Writes `bytes` to a file called `name`, reads it with `read` and returns the error's
    /// text, which must name the file.
    pub fn expect_err(
        bytes: &[u8],
        name: &str,
        read: impl Fn(&Path) -> Result<Map, IoError>,
    ) -> String {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let msg = read(&path).unwrap_err().to_string();
        assert!(msg.contains(name), "message does not name the file: {msg}");
        msg
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn map_layout_is_top_first_interleaved() {
        let mut m = Map::new(3, 2, 2);
        assert_eq!(m.data.len(), 12);
        m.set(2, 1, 1, 7.5);
        assert_eq!(m.data[(3 + 2) * 2 + 1], 7.5); // (y * width + x) * channels + c
        assert_eq!(m.get(2, 1, 1), 7.5);
        assert_eq!(m.try_get(3, 0, 0), None);
        assert_eq!(m.try_get(0, 0, 2), None);
        assert_eq!(m.pixel(2, 1), Some(&[0.0, 7.5][..]));
        assert_eq!(m.pixel(0, 2), None);
    }

    #[test]
    fn from_data_checks_length() {
        assert!(Map::from_data(2, 3, 1, vec![0.0; 6]).is_ok());
        let e = Map::from_data(2, 3, 3, vec![0.0; 6]).unwrap_err();
        assert_eq!(e.expected, 18);
        assert!(e.to_string().contains("has 6 values"), "{e}");
    }

    #[test]
    fn write_atomic_replaces_target() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        std::fs::write(&path, b"old").unwrap();
        write_atomic(&path, |w| w.write_all(b"new contents")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new contents");
        assert_eq!(entries(dir.path()), vec!["out.bin".to_string()]);
    }

    #[test]
    fn write_atomic_failure_keeps_target_and_removes_temp() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("keep.pfm");
        std::fs::write(&path, b"original").unwrap();
        let err = write_atomic(&path, |w| {
            w.write_all(&[1u8; 100_000])?;
            Err(std::io::Error::other("disk on fire"))
        })
        .unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("keep.pfm"), "{msg}");
        assert!(msg.contains("disk on fire"), "{msg}");
        assert_eq!(std::fs::read(&path).unwrap(), b"original");
        assert_eq!(entries(dir.path()), vec!["keep.pfm".to_string()]);
    }

    #[test]
    fn write_atomic_failure_without_target_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("new.dmb");
        let err = write_atomic(&path, |_| Err(std::io::Error::other("nope"))).unwrap_err();
        assert_eq!(err.path(), path.as_path());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn write_atomic_missing_directory_names_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no_such_dir").join("x.pfm");
        let err = write_atomic(&path, |w| w.write_all(b"x")).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("x.pfm"), "{msg}");
        assert!(msg.contains("check the path"), "{msg}");
    }

    #[test]
    fn read_missing_file_names_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing_depth.dmb");
        let msg = read_all(&path).unwrap_err().to_string();
        assert!(msg.contains("missing_depth.dmb"), "{msg}");
    }
}
