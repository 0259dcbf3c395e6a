//! What surrounds a run: the demo scene, `mvscope eval` on folders and arrays, PLY and PFM
//! files, the default parameters.

use std::path::PathBuf;

use mvscope::eval::{DepthReport, EvalError};
use mvscope::io::{Map, PlyPoint};
use mvscope::pipeline::RunRecord;
use mvscope::synthetic::{self, SyntheticOptions};
use pyo3::prelude::*;
use pyo3::types::PyByteArray;

use crate::session::parse_method;
use crate::{CloudBytes, Failure, byte_array, unblocked};

/// A report as `eval.json`'s "depth" (JSON) and as `mvscope eval` prints it.
/// [`report_strings`] with the split by what the sources see beside the report (`"seen"`)
/// and below its table, where there is one.
pub(crate) fn with_seen(
    report: &DepthReport,
    seen: Option<&mvscope::eval::SeenReport>,
) -> Result<(String, String), Failure> {
    let Some(seen) = seen else {
        return report_strings(report);
    };
    // One serialisation (a re-parse of the report's text would round floats by an ulp).
    let json = serde_json::to_string(&serde_json::json!({
        "views": report.views,
        "overall": report.overall,
        "seen": seen,
    }))
    .map_err(|e| Failure::Internal(e.to_string()))?;
    let table = mvscope::eval::format_depth_report(report) + &mvscope::eval::format_seen(seen);
    Ok((json, table))
}

pub(crate) fn report_strings(report: &DepthReport) -> Result<(String, String), Failure> {
    let json = serde_json::to_string(report).map_err(|e| Failure::Internal(e.to_string()))?;
    Ok((json, mvscope::eval::format_depth_report(report)))
}

/// `mvscope demo`: writes the synthetic scene (ACMM folder and ground truth in gt/).
#[pyfunction]
#[allow(clippy::too_many_arguments)] // the options of `mvscope demo`, as Python passes them
fn demo(
    py: Python<'_>,
    out: PathBuf,
    views: usize,
    width: u32,
    height: u32,
    seed: u64,
    room: bool,
    noise: f32,
) -> PyResult<()> {
    unblocked(py, || {
        let scene = synthetic::generate(&SyntheticOptions {
            views,
            width,
            height,
            seed,
            noise_sigma: noise,
            room,
            ..SyntheticOptions::default()
        })?;
        synthetic::write_demo(&scene, &out)?;
        Ok(())
    })
}

/// `mvscope eval DIR --gt GT`: the views recorded in DIR/params.toml.
#[pyfunction]
fn evaluate_dir(
    py: Python<'_>,
    dir: PathBuf,
    gt: PathBuf,
    abs: Vec<f64>,
    rel: Vec<f64>,
) -> PyResult<(String, String)> {
    unblocked(py, || {
        let record = RunRecord::read(&dir.join("params.toml"))?;
        let report = mvscope::eval::evaluate_run(&dir, &record.views, &gt, &abs, &rel)?;
        // The split needs the run's scene for its cameras; a scene moved or deleted since
        // the run leaves the report without it, as `mvscope eval` does.
        let seen = mvscope::eval::evaluate_seen_dir(
            &record.scene,
            &record.load_options(&dir),
            &dir,
            &record.views,
            &gt,
        )
        .ok()
        .flatten();
        with_seen(&report, seen.as_ref())
    })
}

/// `mvscope eval` of depth maps given as (view index, width, height, float32 bytes).
#[pyfunction]
fn evaluate_arrays(
    py: Python<'_>,
    depths: Vec<(usize, u32, u32, Vec<u8>)>,
    gt: PathBuf,
    abs: Vec<f64>,
    rel: Vec<f64>,
) -> PyResult<(String, String)> {
    unblocked(py, move || {
        let views: Vec<usize> = depths.iter().map(|d| d.0).collect();
        let report = mvscope::eval::evaluate_depths(&views, &gt, &abs, &rel, |v| {
            let Some((_, w, h, bytes)) = depths.iter().find(|d| d.0 == v) else {
                return Err(EvalError::Missing(format!("view {v}: no depth map given")));
            };
            let values: Vec<f32> = bytes
                .chunks_exact(4)
                .map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            Map::from_data(*w, *h, 1, values)
                .map_err(|e| EvalError::Missing(format!("view {v}: {e}")))
        })?;
        report_strings(&report)
    })
}

/// The ground-truth cloud of `gt` as `mvscope eval` builds it (its depth maps
/// back-projected, one point per `voxel` cube): with `run`, the run's views through its
/// scene's cameras (`eval DIR --gt GT`); without, every view of the scene folder `gt`.
/// (n, xyz float32 bytes), or None where no view has ground truth.
#[pyfunction]
#[pyo3(signature = (gt, voxel, run=None))]
fn truth_cloud<'py>(
    py: Python<'py>,
    gt: PathBuf,
    voxel: f64,
    run: Option<PathBuf>,
) -> PyResult<Option<(usize, Bound<'py, PyByteArray>)>> {
    let points = unblocked(py, || {
        if !(voxel.is_finite() && voxel > 0.0) {
            return Err(Failure::Parameter(format!(
                "voxel {voxel}: give a positive size in scene units"
            )));
        }
        Ok(match &run {
            Some(dir) => {
                let record = RunRecord::read(&dir.join("params.toml"))?;
                mvscope::eval::truth_cloud_dir(
                    &record.scene,
                    &record.load_options(dir),
                    Some(&record.views),
                    &gt,
                    voxel,
                )?
            }
            None => mvscope::eval::truth_cloud_dir(&gt, &Default::default(), None, &gt, voxel)?,
        })
    })?;
    Ok(points.map(|p| (p.len(), byte_array(py, &p))))
}

/// ETH3D's accuracy, completeness and F1 of `points` against `truth` (xyz float32 bytes)
/// at each threshold, as `eval.json`'s "cloud" (JSON).
#[pyfunction]
fn cloud_scores(
    py: Python<'_>,
    points: Vec<u8>,
    truth: Vec<u8>,
    thresholds: Vec<f64>,
) -> PyResult<String> {
    unblocked(py, move || {
        if let Some(t) = thresholds.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
            return Err(Failure::Parameter(format!(
                "threshold {t}: give positive distances in scene units (e.g. 0.02, 0.05)"
            )));
        }
        let xyz = |b: &[u8]| -> Vec<[f32; 3]> {
            floats(b)
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect()
        };
        let scores = mvscope::eval::cloud_scores(&xyz(&points), &xyz(&truth), &thresholds);
        serde_json::to_string(&scores).map_err(|e| Failure::Internal(e.to_string()))
    })
}

fn floats(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

/// Writes a binary little-endian PLY of `n` points (xyz, normals, rgb as bytes).
#[pyfunction]
fn write_ply(
    py: Python<'_>,
    path: PathBuf,
    n: usize,
    points: Vec<u8>,
    normals: Vec<u8>,
    colors: Vec<u8>,
) -> PyResult<()> {
    unblocked(py, move || {
        let (p, q) = (floats(&points), floats(&normals));
        if p.len() != 3 * n || q.len() != 3 * n || colors.len() != 3 * n {
            return Err(Failure::Parameter(format!(
                "{}: {n} points need {n}x3 positions, normals and colours",
                path.display()
            )));
        }
        let cloud: Vec<PlyPoint> = (0..n)
            .map(|i| PlyPoint {
                position: [p[3 * i], p[3 * i + 1], p[3 * i + 2]],
                normal: [q[3 * i], q[3 * i + 1], q[3 * i + 2]],
                color: [colors[3 * i], colors[3 * i + 1], colors[3 * i + 2]],
            })
            .collect();
        mvscope::io::write_ply(&path, &cloud)?;
        Ok(())
    })
}

/// Reads a PLY point cloud: (n, xyz, normals, rgb) as bytes.
#[pyfunction]
fn read_ply<'py>(py: Python<'py>, path: PathBuf) -> PyResult<CloudBytes<'py>> {
    let points = unblocked(py, || Ok(mvscope::io::read_ply(&path)?))?;
    let pos: Vec<[f32; 3]> = points.iter().map(|p| p.position).collect();
    let nrm: Vec<[f32; 3]> = points.iter().map(|p| p.normal).collect();
    let col: Vec<[u8; 3]> = points.iter().map(|p| p.color).collect();
    Ok((
        points.len(),
        byte_array(py, &pos),
        byte_array(py, &nrm),
        byte_array(py, &col),
    ))
}

/// Reads a PFM map, top row first: (width, height, channels, float32 bytes).
#[pyfunction]
fn read_pfm<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<(u32, u32, u32, Bound<'py, PyByteArray>)> {
    let map = unblocked(py, || Ok(mvscope::io::read_pfm(&path)?))?;
    Ok((
        map.width,
        map.height,
        map.channels,
        byte_array(py, &map.data),
    ))
}

/// Writes a PFM map given top row first (as `mvscope run` writes its maps).
#[pyfunction]
fn write_pfm(
    py: Python<'_>,
    path: PathBuf,
    width: u32,
    height: u32,
    channels: u32,
    data: Vec<u8>,
) -> PyResult<()> {
    unblocked(py, move || {
        let map = Map::from_data(width, height, channels, floats(&data))
            .map_err(|e| Failure::Parameter(format!("{}: {e}", path.display())))?;
        mvscope::io::write_pfm(&path, &map)?;
        Ok(())
    })
}

/// A method's default parameters as JSON (params.toml's names).
#[pyfunction]
#[pyo3(signature = (method="acmm"))]
fn default_params_json(py: Python<'_>, method: &str) -> PyResult<String> {
    let method = parse_method(method).map_err(|e| e.into_pyerr(py))?;
    serde_json::to_string(&method.defaults())
        .map_err(|e| Failure::Internal(e.to_string()).into_pyerr(py))
}

/// Parameters from `NAME=VALUE` strings over a method's defaults (`--set`), checked, as
/// JSON.
#[pyfunction]
#[pyo3(signature = (sets, method="acmm"))]
fn params_json_with(py: Python<'_>, sets: Vec<String>, method: &str) -> PyResult<String> {
    let method = parse_method(method).map_err(|e| e.into_pyerr(py))?;
    let params = method
        .defaults()
        .with_overrides(&sets)
        .map_err(|e| Failure::Parameter(e).into_pyerr(py))?;
    serde_json::to_string(&params).map_err(|e| Failure::Internal(e.to_string()).into_pyerr(py))
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(demo, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_dir, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(truth_cloud, m)?)?;
    m.add_function(wrap_pyfunction!(cloud_scores, m)?)?;
    m.add_function(wrap_pyfunction!(write_ply, m)?)?;
    m.add_function(wrap_pyfunction!(read_ply, m)?)?;
    m.add_function(wrap_pyfunction!(read_pfm, m)?)?;
    m.add_function(wrap_pyfunction!(write_pfm, m)?)?;
    m.add_function(wrap_pyfunction!(default_params_json, m)?)?;
    m.add_function(wrap_pyfunction!(params_json_with, m)?)?;
    Ok(())
}
