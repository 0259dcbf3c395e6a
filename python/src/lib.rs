//! The native half of the `mvscope` Python package: a thin layer over the library's public
//! API (Scene, Session, eval, fusion, io, synthetic). The pure-Python package in
//! python/mvscope wraps it: numpy arrays, docstrings, dataclasses.
//!
//! Rules of this layer:
//! * Every call that works (loads, runs the GPU, fuses, reads files) runs with the GIL
//!   released ([`unblocked`]) and inside `catch_unwind`, so no panic crosses into Python: a
//!   panic becomes `mvscope.InternalError`.
//! * Errors become the `mvscope.errors` classes ([`Failure`]), carrying the library's message
//!   (the CLI's) and, where known, the file, line and location.
//! * Long runs go in slices of steps; between slices the GIL is taken back and
//!   `check_signals` lets Ctrl-C (KeyboardInterrupt) stop them.
//! * Maps cross as `bytearray`s of native-endian values; Python views them with numpy.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use mvscope::gpu::acmh::AcmhPipelines;
use mvscope::gpu::{GpuContext, GpuError};
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyDict};

mod scene;
mod session;
mod tools;

/// Why a call failed, without Python objects (made with the GIL released); becomes an
/// exception of `mvscope.errors` once the GIL is back.
#[derive(Debug)]
pub(crate) enum Failure {
    /// A scene or one of its files (`mvscope.SceneError`).
    Scene {
        message: String,
        location: String,
        path: Option<PathBuf>,
        line: Option<usize>,
    },
    /// A parameter's name or value (`mvscope.ParameterError`).
    Parameter(String),
    /// No adapter, a device error, a run that does not fit (`mvscope.DeviceError`).
    Device(String),
    /// A step or read-back that failed (`mvscope.SessionError`).
    Session(String),
    /// A file that cannot be read or written (`mvscope.FileError`).
    File { message: String, path: PathBuf },
    /// Ground truth missing or unusable (`mvscope.EvalError`).
    Eval(String),
    /// A panic: a bug (`mvscope.InternalError`).
    Internal(String),
    /// Anything else (`mvscope.Error`).
    Other(String),
}

impl Failure {
    fn class_and_message(&self) -> (&'static str, &str) {
        match self {
            Failure::Scene { message, .. } => ("SceneError", message),
            Failure::Parameter(m) => ("ParameterError", m),
            Failure::Device(m) => ("DeviceError", m),
            Failure::Session(m) => ("SessionError", m),
            Failure::File { message, .. } => ("FileError", message),
            Failure::Eval(m) => ("EvalError", m),
            Failure::Internal(m) => ("InternalError", m),
            Failure::Other(m) => ("Error", m),
        }
    }

    /// The exception: the class of `mvscope.errors` named by the failure, with `path`, `line`
    /// and `location` set where known.
    pub(crate) fn into_pyerr(self, py: Python<'_>) -> PyErr {
        let (class, message) = self.class_and_message();
        let made = (|| -> PyResult<PyErr> {
            let errors = py.import("mvscope.errors")?;
            let kwargs = PyDict::new(py);
            match &self {
                Failure::Scene {
                    location,
                    path,
                    line,
                    ..
                } => {
                    kwargs.set_item("location", location)?;
                    kwargs.set_item("path", path.as_ref().map(|p| p.display().to_string()))?;
                    kwargs.set_item("line", *line)?;
                }
                Failure::File { path, .. } => {
                    kwargs.set_item("path", path.display().to_string())?;
                }
                _ => {}
            }
            let value = errors.getattr(class)?.call((message,), Some(&kwargs))?;
            Ok(PyErr::from_value(value))
        })();
        // Only when the Python half is missing (the native module imported alone).
        made.unwrap_or_else(|_| pyo3::exceptions::PyRuntimeError::new_err(message.to_string()))
    }
}

impl From<mvscope::scene::SceneError> for Failure {
    fn from(e: mvscope::scene::SceneError) -> Failure {
        Failure::Scene {
            message: e.to_string(),
            location: e.location.clone(),
            path: e.path.clone(),
            line: e.line,
        }
    }
}

impl From<GpuError> for Failure {
    fn from(e: GpuError) -> Failure {
        Failure::Device(e.to_string())
    }
}

impl From<mvscope::session::SessionError> for Failure {
    fn from(e: mvscope::session::SessionError) -> Failure {
        use mvscope::session::SessionError as E;
        match &e {
            E::Gpu(_) | E::Memory(_) => Failure::Device(e.to_string()),
            E::Params(_) => Failure::Parameter(e.to_string()),
            E::State(_) => Failure::Session(e.to_string()),
        }
    }
}

impl From<mvscope::io::IoError> for Failure {
    fn from(e: mvscope::io::IoError) -> Failure {
        Failure::File {
            path: e.path().to_path_buf(),
            message: e.to_string(),
        }
    }
}

impl From<mvscope::eval::EvalError> for Failure {
    fn from(e: mvscope::eval::EvalError) -> Failure {
        match e {
            mvscope::eval::EvalError::Io(io) => io.into(),
            mvscope::eval::EvalError::Scene(e) => e.into(),
            other => Failure::Eval(other.to_string()),
        }
    }
}

impl From<mvscope::fusion::FusionError> for Failure {
    fn from(e: mvscope::fusion::FusionError) -> Failure {
        Failure::Other(e.to_string())
    }
}

impl From<mvscope::pipeline::RunError> for Failure {
    fn from(e: mvscope::pipeline::RunError) -> Failure {
        use mvscope::pipeline::RunError as E;
        match e {
            E::Session(s) => s.into(),
            E::Io(io) => io.into(),
            E::Fusion(f) => f.into(),
            other => Failure::Other(other.to_string()),
        }
    }
}

/// Runs `f` with the GIL released and any panic caught: the calls that do the work.
pub(crate) fn unblocked<T, F>(py: Python<'_>, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> Result<T, Failure> + Send,
{
    py.detach(|| guarded(f)).map_err(|e| e.into_pyerr(py))
}

/// `f` with a panic turned into [`Failure::Internal`].
pub(crate) fn guarded<T>(f: impl FnOnce() -> Result<T, Failure>) -> Result<T, Failure> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(Failure::Internal(format!(
                "internal error in mvscope (a bug; please report it with the call that caused \
                 it): {what}"
            )))
        }
    }
}

/// The device every session of this process runs on, and its compiled passes (made once:
/// the CLI's adapter choice, `GpuContext::new`, honouring WGPU_BACKEND and
/// WGPU_ADAPTER_NAME).
#[derive(Clone)]
pub(crate) struct Device {
    pub ctx: GpuContext,
    pub pipelines: Arc<AcmhPipelines>,
}

static DEVICE: Mutex<Option<Device>> = Mutex::new(None);

/// The process's device, made on first use (call with the GIL released: it compiles the
/// passes). A failure is not kept: the next call tries again.
pub(crate) fn device() -> Result<Device, Failure> {
    let mut slot = DEVICE.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(d) = slot.as_ref() {
        return Ok(d.clone());
    }
    let ctx = GpuContext::new()?;
    let pipelines = Arc::new(AcmhPipelines::new(&ctx)?);
    let d = Device { ctx, pipelines };
    *slot = Some(d.clone());
    Ok(d)
}

/// Values as the bytes of a `bytearray` (native endianness), for numpy's `frombuffer`.
pub(crate) fn byte_array<'py, T: bytemuck::NoUninit>(
    py: Python<'py>,
    values: &[T],
) -> Bound<'py, PyByteArray> {
    PyByteArray::new(py, bytemuck::cast_slice(values))
}

/// A point cloud for Python: its size, then xyz, normals and rgb as bytes.
pub(crate) type CloudBytes<'py> = (
    usize,
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
);

/// The adapter sessions run on: `mvscope gpu`'s first line, as a dict.
#[pyfunction]
fn device_info(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = unblocked(py, device)?;
    let info = &d.ctx.info;
    let out = PyDict::new(py);
    out.set_item("name", d.ctx.adapter_name())?;
    out.set_item("backend", format!("{:?}", info.backend))?;
    out.set_item("device_type", format!("{:?}", info.device_type))?;
    out.set_item("driver", format!("{} {}", info.driver, info.driver_info))?;
    out.set_item("software", d.ctx.is_software())?;
    out.set_item("description", d.ctx.describe())?;
    Ok(out)
}

/// The library's version (the Cargo package's).
#[pyfunction]
fn library_version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

/// The viewer's colour (sRGB bytes) for a raw winner code, as `maps["winner"]` holds it:
/// the winner map's table for codes 0..=15 and the initial plane (254), the invalid grey for
/// any other code.
#[pyfunction]
fn winner_color(code: u8) -> (u8, u8, u8) {
    let [r, g, b] = mvscope::viewer::maps::winner_code_color(u32::from(code));
    (r, g, b)
}

#[pymodule]
fn _mvscope(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::PyScene>()?;
    m.add_class::<session::PySession>()?;
    m.add_function(wrap_pyfunction!(device_info, m)?)?;
    m.add_function(wrap_pyfunction!(library_version, m)?)?;
    m.add_function(wrap_pyfunction!(winner_color, m)?)?;
    tools::register(m)?;
    Ok(())
}
