//! `Scene.open`: a scene loaded as `mvscope run` loads it, and its views' cameras.

use std::path::PathBuf;
use std::sync::Arc;

use mvscope::scene::{DepthRange, LoadOptions, Scene, SceneFormat};
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyDict};

use crate::{Failure, byte_array, unblocked};

/// A loaded scene (at the processed size), and the indices of its views in the scene on
/// disk (a `views=` subset keeps them: outputs and ground truth are numbered by them).
#[pyclass(frozen, name = "Scene", module = "mvscope._mvscope")]
pub struct PyScene {
    pub scene: Arc<Scene>,
    pub indices: Vec<usize>,
    pub path: PathBuf,
    pub max_image_size: Option<u32>,
}

/// A format's name as the CLI's `--format` takes it.
fn parse_format(name: &str) -> Result<SceneFormat, Failure> {
    serde_json::from_value(serde_json::Value::String(name.to_lowercase())).map_err(|_| {
        Failure::Parameter(format!(
            "format={name:?}: one of \"acmm\", \"colmap\", \"middlebury\", \"strecha\""
        ))
    })
}

fn format_name(format: Option<SceneFormat>) -> Option<String> {
    let value = serde_json::to_value(format?).ok()?;
    value.as_str().map(str::to_string)
}

/// `views=`: indices into the scene on disk (checked as `--views` checks them).
fn check_views(views: &[usize], count: usize) -> Result<(), Failure> {
    if views.is_empty() {
        return Err(Failure::Parameter("views: no view given".into()));
    }
    if let Some(&bad) = views.iter().find(|&&v| v >= count) {
        return Err(Failure::Parameter(format!(
            "views: the scene has views 0..{} ({bad} is not one)",
            count.saturating_sub(1)
        )));
    }
    Ok(())
}

#[pymethods]
impl PyScene {
    #[staticmethod]
    #[pyo3(signature = (path, max_image_size=None, views=None, model=None, format=None, depth_range=None))]
    fn open(
        py: Python<'_>,
        path: PathBuf,
        max_image_size: Option<u32>,
        views: Option<Vec<usize>>,
        model: Option<u32>,
        format: Option<String>,
        depth_range: Option<(f64, f64)>,
    ) -> PyResult<PyScene> {
        unblocked(py, move || {
            if max_image_size == Some(0) {
                return Err(Failure::Parameter(
                    "max_image_size must be at least 1".into(),
                ));
            }
            let depth_range = match depth_range {
                Some((a, b)) => Some(
                    DepthRange::new(a, b)
                        .map_err(|m| Failure::Parameter(format!("depth_range: {m}")))?,
                ),
                None => None,
            };
            let options = LoadOptions {
                format: format.as_deref().map(parse_format).transpose()?,
                max_image_size,
                depth_range,
                model,
                undistort_cache: None,
                decode_only: None,
            };
            let full = Scene::load(&path, &options)?;
            let (scene, indices) = match views {
                Some(v) => {
                    check_views(&v, full.views.len())?;
                    (full.subset(&v)?, v)
                }
                None => {
                    let all = (0..full.views.len()).collect();
                    (full, all)
                }
            };
            Ok(PyScene {
                scene: Arc::new(scene),
                indices,
                path: std::fs::canonicalize(&path).unwrap_or(path),
                max_image_size,
            })
        })
    }

    /// Every view's name, size, camera, sources and depth range.
    fn views<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.scene
            .views
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let d = PyDict::new(py);
                let cam = &v.camera;
                let k = &cam.intrinsics;
                d.set_item("index", i)?;
                d.set_item("scene_index", self.indices.get(i).copied().unwrap_or(i))?;
                d.set_item("name", &v.name)?;
                d.set_item("width", v.image.width)?;
                d.set_item("height", v.image.height)?;
                d.set_item("fx_fy_cx_cy", (k.fx, k.fy, k.cx, k.cy))?;
                // Column-major, as glam stores it.
                d.set_item("R_columns", cam.rotation.to_cols_array().to_vec())?;
                d.set_item("t", cam.translation.to_array().to_vec())?;
                let sources: Vec<(usize, f64)> =
                    v.sources.iter().map(|s| (s.index, s.score)).collect();
                d.set_item("sources", sources)?;
                d.set_item("depth_range", (v.depth_range.min, v.depth_range.max))?;
                d.set_item(
                    "image_path",
                    v.image_path.as_ref().map(|p| p.display().to_string()),
                )?;
                Ok(d)
            })
            .collect()
    }

    /// View `view`'s colour image: (width, height, row-major RGB bytes).
    fn image<'py>(
        &self,
        py: Python<'py>,
        view: usize,
    ) -> PyResult<(u32, u32, Bound<'py, PyByteArray>)> {
        let v = self.scene.views.get(view).ok_or_else(|| {
            Failure::Parameter(format!(
                "view {view}: the scene has {} views",
                self.scene.views.len()
            ))
            .into_pyerr(py)
        })?;
        let rgb: &[[u8; 3]] = &v.image.rgb;
        Ok((v.image.width, v.image.height, byte_array(py, rgb)))
    }

    /// View `view`'s intensity (BT.601 grey, 0..255, float32), what matching reads.
    fn gray<'py>(
        &self,
        py: Python<'py>,
        view: usize,
    ) -> PyResult<(u32, u32, Bound<'py, PyByteArray>)> {
        let v = self.scene.views.get(view).ok_or_else(|| {
            Failure::Parameter(format!(
                "view {view}: the scene has {} views",
                self.scene.views.len()
            ))
            .into_pyerr(py)
        })?;
        Ok((v.image.width, v.image.height, byte_array(py, &v.image.gray)))
    }

    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    #[getter]
    fn format(&self) -> Option<String> {
        format_name(self.scene.format)
    }

    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.scene.warnings.clone()
    }

    #[getter]
    fn indices(&self) -> Vec<usize> {
        self.indices.clone()
    }

    #[getter]
    fn max_image_size(&self) -> Option<u32> {
        self.max_image_size
    }

    fn __len__(&self) -> usize {
        self.scene.views.len()
    }
}
