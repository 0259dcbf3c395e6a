//! The Session: the library's [`Session`] stepped as the viewer steps it (its units, Back,
//! parameter changes), its maps, the pixel inspector, fusion and evaluation.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use mvscope::acmm::Method;
use mvscope::scene::Scene;
use mvscope::session::{Action, Session, Stage, Step, ViewMaps};
use mvscope::viewer::inspector::{self, Inspection, RestorerPixel};
use mvscope::viewer::model::Capture;
use mvscope::viewer::timeline::{self, Unit};
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyDict};

use crate::scene::PyScene;
use crate::{CloudBytes, Failure, byte_array, device, unblocked};

/// How long the GIL stays released in one slice of a run before Ctrl-C is looked at.
const SLICE: Duration = Duration::from_millis(200);

/// Steps submitted between waits for the device within a slice (so a slice's time is the
/// device's, not only the submissions').
const STEPS_PER_WAIT: usize = 4;

struct Inner {
    session: Session,
    scene: Arc<Scene>,
    /// Each view's index in the scene on disk.
    indices: Vec<usize>,
}

/// A run of one method over one scene, stepped like the viewer steps it.
#[pyclass(frozen, name = "Session", module = "mvscope._mvscope")]
pub struct PySession {
    inner: Mutex<Inner>,
    /// The cursor as of the last step or call, readable without the lock: another thread
    /// (a progress bar, a watchdog) sees a run's progress while a slice holds the lock.
    cursor: AtomicUsize,
}

/// The method named as the CLI's `--method` takes it.
pub(crate) fn parse_method(name: &str) -> Result<Method, Failure> {
    serde_json::from_value(serde_json::Value::String(name.to_lowercase())).map_err(|_| {
        Failure::Parameter(format!(
            "method={name:?}: one of \"acmm\", \"acmh\", \"dwta\", \"acmp\", \"acmmp\", \"regions\""
        ))
    })
}

fn parse_unit(name: &str) -> Result<Unit, Failure> {
    Unit::ALL
        .into_iter()
        .find(|u| u.title() == name)
        .ok_or_else(|| {
            Failure::Parameter(format!(
                "unit={name:?}: one of \"half\", \"iteration\", \"view\", \"stage\", \"scale\""
            ))
        })
}

/// Waits until the device has done the work submitted so far.
fn wait_idle(session: &Session) -> Result<(), Failure> {
    session
        .context()
        .device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|e| Failure::Device(format!("waiting for the device: {e}")))
}

/// The final maps' form (`mvscope run`'s PFMs): depth, 0 where nothing was estimated, and
/// world-frame unit normals, 0 there (src/pipeline.rs, `final_from_session`).
fn depth_and_world_normals(
    scene: &Scene,
    view: usize,
    planes: &[[f32; 4]],
) -> (Vec<f32>, Vec<[f32; 3]>) {
    let depth = planes.iter().map(|p| p[3].max(0.0)).collect();
    let normals = match scene.views.get(view) {
        Some(v) => planes
            .iter()
            .map(|p| {
                if p[3] <= 0.0 {
                    return [0.0; 3];
                }
                let n = glam::Vec3::new(p[0], p[1], p[2]).as_dvec3();
                let w = v.camera.dir_world_from_camera(n);
                [w.x as f32, w.y as f32, w.z as f32]
            })
            .collect(),
        None => vec![[0.0; 3]; planes.len()],
    };
    (depth, normals)
}

/// The written world normals in `view`'s camera frame: what `mvscope run` fuses.
fn camera_normals(scene: &Scene, view: usize, world: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let Some(v) = scene.views.get(view) else {
        return world.to_vec();
    };
    world
        .iter()
        .map(|n| {
            let c = v
                .camera
                .dir_camera_from_world(glam::Vec3::from_array(*n).as_dvec3());
            [c.x as f32, c.y as f32, c.z as f32]
        })
        .collect()
}

fn stage_name(stage: Stage) -> String {
    match stage {
        Stage::Photometric => "photometric".into(),
        Stage::Restorer => "detail restorer".into(),
        Stage::Planar => "planar prior".into(),
        Stage::Geometric(g) => format!("geometric {g}"),
    }
}

fn action_name(action: Action) -> &'static str {
    match action {
        Action::Upsample => "upsample",
        Action::Init => "init",
        Action::Half { .. } => "half",
        Action::Median => "median",
        Action::Restore => "restore",
        Action::Measure => "measure",
        Action::SupportPoints => "support points",
        Action::Triangulate => "triangulate",
        Action::PriorPlane => "prior plane",
    }
}

fn step_dict<'py>(py: Python<'py>, index: usize, s: &Step) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("index", index)?;
    d.set_item("level", s.level)?;
    d.set_item("scale", s.level + 1)?;
    d.set_item("scales", s.levels)?;
    d.set_item("stage", stage_name(s.stage))?;
    d.set_item(
        "geometric_pass",
        match s.stage {
            Stage::Geometric(g) => Some(g),
            _ => None,
        },
    )?;
    d.set_item("view", s.view)?;
    d.set_item("action", action_name(s.action))?;
    let (iteration, half) = match s.action {
        Action::Half { iteration, color } => (
            Some(iteration),
            Some(if color == 0 { "red" } else { "black" }),
        ),
        _ => (None, None),
    };
    d.set_item("iteration", iteration)?;
    d.set_item("half", half)?;
    d.set_item("label", s.label())?;
    Ok(d)
}

impl PySession {
    fn lock(&self) -> Result<MutexGuard<'_, Inner>, Failure> {
        self.inner.lock().map_err(|_| {
            Failure::Session(
                "this session stopped in an internal error earlier; create a new Session".into(),
            )
        })
    }

    /// Runs `f` on the session with the GIL released. The lock is only ever taken so: a
    /// thread holding the GIL while it waits for the lock could wait for ever on a thread
    /// that holds the lock and waits for the GIL.
    fn with<T, F>(&self, py: Python<'_>, f: F) -> PyResult<T>
    where
        T: Send,
        F: FnOnce(&mut Inner) -> Result<T, Failure> + Send,
    {
        unblocked(py, || {
            let mut inner = self.lock()?;
            let result = f(&mut inner);
            self.cursor.store(inner.session.cursor(), Ordering::Relaxed);
            result
        })
    }

    /// Moves to `target` steps run (clamped to the schedule): back from the latest checkpoint,
    /// forward in slices with the GIL released, Ctrl-C looked at between them.
    fn move_to(&self, py: Python<'_>, target: usize) -> PyResult<()> {
        loop {
            let arrived = unblocked(py, || {
                let mut inner = self.lock()?;
                let s = &mut inner.session;
                let target = target.min(s.schedule().len());
                if target < s.cursor() {
                    s.rewind(target);
                    self.cursor.store(s.cursor(), Ordering::Relaxed);
                }
                let started = Instant::now();
                let mut since_wait = 0;
                while s.cursor() < target {
                    s.step()?;
                    self.cursor.store(s.cursor(), Ordering::Relaxed);
                    since_wait += 1;
                    if since_wait == STEPS_PER_WAIT {
                        since_wait = 0;
                        wait_idle(s)?;
                        if started.elapsed() >= SLICE {
                            break;
                        }
                    }
                }
                wait_idle(s)?;
                Ok(s.cursor() >= target)
            })?;
            // Looked at after the last slice too: a Ctrl-C pressed during a call that ends
            // within one slice surfaces from that call, not at a later line of the script.
            py.check_signals()?;
            if arrived {
                return Ok(());
            }
        }
    }

    /// Where `n` units forward (or back) from the cursor ends, as the viewer's step buttons go.
    fn unit_target(&self, py: Python<'_>, n: usize, unit: &str, forward: bool) -> PyResult<usize> {
        let unit = parse_unit(unit).map_err(|e| e.into_pyerr(py))?;
        self.with(py, |inner| {
            let schedule = inner.session.schedule();
            let mut target = inner.session.cursor();
            for _ in 0..n {
                target = if forward {
                    timeline::advance(schedule, target, unit)
                } else {
                    timeline::retreat(schedule, target, unit)
                };
            }
            Ok(target)
        })
    }
}

#[pymethods]
impl PySession {
    #[new]
    #[pyo3(signature = (scene, method="acmm", sets=Vec::new(), seed=None, device_memory=None))]
    fn new(
        py: Python<'_>,
        scene: PyRef<'_, PyScene>,
        method: &str,
        sets: Vec<String>,
        seed: Option<u64>,
        device_memory: Option<f64>,
    ) -> PyResult<PySession> {
        let scene_data = scene.scene.clone();
        let indices = scene.indices.clone();
        let method = method.to_string();
        unblocked(py, move || {
            let method = parse_method(&method)?;
            // The method's defaults, then the caller's changes.
            let mut params = method
                .defaults()
                .with_overrides(&sets)
                .map_err(Failure::Parameter)?;
            if let Some(s) = seed {
                params.seed = s;
            }
            let d = device()?;
            // A budget the scene exceeds runs each stage in batches (the same maps).
            let options = mvscope::session::SessionOptions {
                device_budget: device_memory.map(|m| (m.max(0.0) * (1u64 << 20) as f64) as u64),
                ..Default::default()
            };
            let session =
                Session::with_options(&d.ctx, d.pipelines, &scene_data, params, method, options)?;
            Ok(PySession {
                inner: Mutex::new(Inner {
                    session,
                    scene: scene_data,
                    indices,
                }),
                cursor: AtomicUsize::new(0),
            })
        })
    }

    /// The parameters as params.toml names them, as JSON (f32 values in their shortest form).
    fn params_json(&self, py: Python<'_>) -> PyResult<String> {
        self.with(py, |inner| {
            serde_json::to_string(inner.session.params())
                .map_err(|e| Failure::Internal(e.to_string()))
        })
    }

    /// The method's name as the CLI's `--method` takes it.
    fn method(&self, py: Python<'_>) -> PyResult<String> {
        self.with(py, |inner| {
            Ok(serde_json::to_value(inner.session.method())
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default())
        })
    }

    /// The schedule: one dict per step.
    fn schedule<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let steps = self.with(py, |inner| Ok(inner.session.schedule().to_vec()))?;
        steps
            .iter()
            .enumerate()
            .map(|(i, s)| step_dict(py, i, s))
            .collect()
    }

    /// Steps run: exact between calls; during a run in another thread, where it has got to.
    fn cursor(&self) -> usize {
        self.cursor.load(Ordering::Relaxed)
    }

    fn num_levels(&self, py: Python<'_>) -> PyResult<u32> {
        self.with(py, |inner| Ok(inner.session.num_levels()))
    }

    /// (width, height) of `view` at pyramid level `level` (0 = coarsest).
    fn level_size(&self, py: Python<'_>, level: u32, view: usize) -> PyResult<(u32, u32)> {
        self.with(py, |inner| {
            let s = &inner.session;
            (level < s.num_levels())
                .then(|| s.level_scene(level).views.get(view))
                .flatten()
                .map(|v| (v.image.width, v.image.height))
                .ok_or_else(|| {
                    Failure::Parameter(format!(
                        "level {level}, view {view}: the session has {} levels of {} views",
                        s.num_levels(),
                        inner.scene.views.len()
                    ))
                })
        })
    }

    /// Runs (or goes back) to `target` steps run.
    fn goto(&self, py: Python<'_>, target: usize) -> PyResult<()> {
        self.move_to(py, target)
    }

    /// `n` of the viewer's units forward.
    fn step(&self, py: Python<'_>, n: usize, unit: &str) -> PyResult<()> {
        let target = self.unit_target(py, n, unit, true)?;
        self.move_to(py, target)
    }

    /// `n` of the viewer's units back.
    fn back(&self, py: Python<'_>, n: usize, unit: &str) -> PyResult<()> {
        let target = self.unit_target(py, n, unit, false)?;
        self.move_to(py, target)
    }

    /// Back to the start (nothing run).
    fn reset(&self, py: Python<'_>) -> PyResult<()> {
        self.with(py, |inner| {
            inner.session.reset();
            Ok(())
        })
    }

    /// Changes parameters (`NAME=VALUE`) as the viewer does: rewinds to the first step they
    /// affect and runs back to the same point of the schedule. Returns (first step re-run,
    /// cursor before, cursor now).
    fn set(&self, py: Python<'_>, sets: Vec<String>) -> PyResult<(usize, usize, usize)> {
        let (from_step, previous, resume_to) = self.with(py, |inner| {
            let s = &mut inner.session;
            let params = s
                .params()
                .with_overrides(&sets)
                .map_err(Failure::Parameter)?;
            let old_schedule = s.schedule().to_vec();
            let stood_at = s.cursor();
            let inv = s.set_params(params)?;
            let resume_to = timeline::same_point(&old_schedule, stood_at, s.schedule());
            Ok((inv.from_step, inv.previous_cursor, resume_to))
        })?;
        self.move_to(py, resume_to)?;
        Ok((from_step, previous, resume_to))
    }

    /// View `view`'s maps at the cursor: a dict of raw maps (bytearrays) and sizes, `None`
    /// before the view's first step.
    fn maps<'py>(&self, py: Python<'py>, view: usize) -> PyResult<Option<Bound<'py, PyDict>>> {
        let got = unblocked(py, || {
            let inner = self.lock()?;
            if view >= inner.scene.views.len() {
                return Err(Failure::Parameter(format!(
                    "view {view}: the scene has {} views",
                    inner.scene.views.len()
                )));
            }
            let Some(maps) = inner.session.maps(view)? else {
                return Ok(None);
            };
            let level_scene = inner.session.level_scene(maps.level);
            let (depth, normal) = depth_and_world_normals(level_scene, view, &maps.state.plane);
            let prior_weight = prior_weights(&maps);
            let anchors = inner.session.anchor_codes(view)?;
            Ok(Some((maps, depth, normal, prior_weight, anchors)))
        })?;
        let Some((maps, depth, normal, prior_weight, anchors)) = got else {
            return Ok(None);
        };
        let st = &maps.state;
        let d = PyDict::new(py);
        d.set_item("level", maps.level)?;
        d.set_item("width", st.width)?;
        d.set_item("height", st.height)?;
        d.set_item("num_sources", st.num_sources)?;
        d.set_item("plane", byte_array(py, &st.plane))?;
        d.set_item("depth", byte_array(py, &depth))?;
        d.set_item("normal", byte_array(py, &normal))?;
        d.set_item("cost", byte_array(py, &st.cost))?;
        d.set_item("selected", byte_array(py, &st.selected))?;
        d.set_item("weights", byte_array(py, &st.weights))?;
        d.set_item("aux", byte_array(py, &st.aux))?;
        let opt = |v: &Option<Vec<f32>>| v.as_ref().map(|v| byte_array(py, v));
        d.set_item("reprojection_error", opt(&maps.reprojection_error))?;
        d.set_item("restorer_difference", opt(&maps.restorer_difference))?;
        d.set_item(
            "replaced",
            maps.replaced.as_ref().map(|r| {
                let bytes: Vec<u8> = r.iter().map(|&b| u8::from(b)).collect();
                PyByteArray::new(py, &bytes)
            }),
        )?;
        d.set_item("prior", maps.prior.as_ref().map(|p| byte_array(py, p)))?;
        d.set_item(
            "prior_weight",
            prior_weight.as_ref().map(|p| byte_array(py, p)),
        )?;
        d.set_item(
            "support_points",
            maps.support_points.as_ref().map(|p| byte_array(py, p)),
        )?;
        d.set_item("anchor_codes", anchors.as_ref().map(|a| byte_array(py, a)))?;
        Ok(Some(d))
    }

    /// The pixel inspector at (x, y) of `view`'s maps as they stand: the pixel's colour's last
    /// half-iteration at the shown scale is replayed from its checkpoint and re-computed on
    /// the CPU reference (the viewer's inspector). `None` when no such half has run.
    fn inspect<'py>(
        &self,
        py: Python<'py>,
        view: usize,
        x: u32,
        y: u32,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let got = self.with(py, |inner| inspect_pixel(inner, view, x, y))?;
        let Some((inspection, restorer)) = got else {
            return Ok(None);
        };
        inspection_dict(py, &inspection, restorer).map(Some)
    }

    /// Why the cell holding pixel (x, y) of `view` has its support point (the planar prior):
    /// the view's last support-point step at the shown scale is replayed and its inputs
    /// read back, then explained on the CPU (the viewer's inspector). `None` when no such
    /// step has run.
    fn support_cell<'py>(
        &self,
        py: Python<'py>,
        view: usize,
        x: u32,
        y: u32,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let got = self.with(py, |inner| explain_support(inner, view, x, y))?;
        let Some((index, cell)) = got else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("step", index)?;
        d.set_item("origin", cell.origin)?;
        d.set_item("size", cell.size)?;
        d.set_item("chosen", cell.chosen)?;
        d.set_item("by_flat_window", cell.by_flat_window)?;
        let mut candidates = Vec::new();
        for c in &cell.candidates {
            use mvscope::acmm::planar::Eligibility;
            let c_d = PyDict::new(py);
            c_d.set_item("pixel", (c.x, c.y))?;
            c_d.set_item("depth", c.depth)?;
            c_d.set_item("cost", c.cost)?;
            c_d.set_item("flat", c.flat)?;
            c_d.set_item(
                "eligibility",
                match c.eligibility {
                    Eligibility::BelowCostLimit => "below cost limit",
                    Eligibility::FlatWindow => "flat window",
                    Eligibility::CostTooHigh => "cost too high",
                    Eligibility::Inconsistent => "views disagree",
                },
            )?;
            c_d.set_item("confidence", c.confidence)?;
            c_d.set_item("score", c.score)?;
            candidates.push(c_d);
        }
        d.set_item("candidates", candidates)?;
        Ok(Some(d))
    }

    /// View `view`'s planar prior at its current scale, as its triangulation step built it:
    /// the support points, the triangles and, with `prior_regions`, the flat regions and
    /// their planes (raw bytes and sizes). `None` before that step, or for a method without
    /// a planar prior.
    fn prior_mesh<'py>(
        &self,
        py: Python<'py>,
        view: usize,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let got = self.with(py, |inner| {
            if view >= inner.scene.views.len() {
                return Err(Failure::Parameter(format!(
                    "view {view}: the scene has {} views",
                    inner.scene.views.len()
                )));
            }
            Ok(inner.session.planar_mesh(view).cloned())
        })?;
        let Some(mesh) = got else {
            return Ok(None);
        };
        use mvscope::acmm::planar::TriangleState;
        let d = PyDict::new(py);
        d.set_item("width", mesh.width)?;
        d.set_item("height", mesh.height)?;
        let xy: Vec<[u32; 2]> = mesh.points.iter().map(|p| [p.x, p.y]).collect();
        let depth_cost: Vec<[f32; 2]> = mesh.points.iter().map(|p| [p.depth, p.cost]).collect();
        let normal: Vec<[f32; 3]> = mesh.points.iter().map(|p| p.normal).collect();
        d.set_item("points", byte_array(py, &xy))?;
        d.set_item("depth_cost", byte_array(py, &depth_cost))?;
        d.set_item("point_normals", byte_array(py, &normal))?;
        let vertices: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.vertices.map(|v| v as u32))
            .collect();
        let planes: Vec<[f32; 4]> = mesh.triangles.iter().map(|t| t.plane).collect();
        let states: Vec<u8> = mesh
            .triangles
            .iter()
            .map(|t| match t.state {
                TriangleState::Kept => 0,
                TriangleState::Degenerate => 1,
                TriangleState::Inconsistent => 2,
            })
            .collect();
        d.set_item("triangles", byte_array(py, &vertices))?;
        d.set_item("triangle_planes", byte_array(py, &planes))?;
        d.set_item("triangle_states", PyByteArray::new(py, &states))?;
        if let Some(fit) = &mesh.regions {
            let r = PyDict::new(py);
            r.set_item("cell", fit.cell)?;
            r.set_item("cells_x", fit.cells_x)?;
            r.set_item("cells_y", fit.cells_y)?;
            r.set_item("region", byte_array(py, &fit.region))?;
            r.set_item("assigned", byte_array(py, &fit.assigned))?;
            r.set_item("sizes", fit.sizes.clone())?;
            r.set_item("shades", byte_array(py, &fit.shades))?;
            let mut planes = Vec::with_capacity(fit.planes.len());
            for p in &fit.planes {
                let pd = PyDict::new(py);
                pd.set_item("region", p.region)?;
                pd.set_item("plane", p.plane.to_vec())?;
                pd.set_item("inliers", p.inliers.clone())?;
                // `prior_region_choice`: its inliers index `later_points`.
                pd.set_item("later", fit.is_later(p))?;
                // None for RANSAC's free plane.
                pd.set_item(
                    "axis",
                    (p.axis != mvscope::acmm::planar::FREE_PLANE).then_some(p.axis),
                )?;
                planes.push(pd);
            }
            r.set_item("planes", planes)?;
            let later: Vec<[f32; 3]> = fit
                .later_points
                .iter()
                .map(|p| [p.x as f32, p.y as f32, p.depth])
                .collect();
            r.set_item("later_points", byte_array(py, &later))?;
            // `prior_region_axes`: the view's Manhattan frame, when its lines gave one.
            if let Some(f) = &fit.frame {
                let fd = PyDict::new(py);
                fd.set_item(
                    "axes",
                    f.axes.iter().map(|a| a.to_vec()).collect::<Vec<_>>(),
                )?;
                let segments: Vec<[f32; 4]> = f
                    .segments
                    .iter()
                    .map(|s| [s.a[0], s.a[1], s.b[0], s.b[1]])
                    .collect();
                fd.set_item("segments", byte_array(py, &segments))?;
                fd.set_item("along", PyByteArray::new(py, &f.along))?;
                r.set_item("frame", fd)?;
            }
            d.set_item("regions", r)?;
        }
        Ok(Some(d))
    }

    /// Fuses the finished maps as `mvscope run` does (with `sets` overriding fusion
    /// parameters, as `mvscope fuse --set`): (points xyz, normals xyz, colours rgb), bytes.
    fn fuse<'py>(&self, py: Python<'py>, sets: Vec<String>) -> PyResult<CloudBytes<'py>> {
        let points = unblocked(py, || {
            let inner = self.lock()?;
            let s = &inner.session;
            if !s.is_finished() {
                return Err(Failure::Session(format!(
                    "fusion reads the final maps: run the session to its end first (it stands at step {} of {}; call run())",
                    s.cursor(),
                    s.schedule().len()
                )));
            }
            let params = s
                .params()
                .with_overrides(&sets)
                .map_err(Failure::Parameter)?;
            let scene = &inner.scene;
            let mut depths = Vec::with_capacity(scene.views.len());
            let mut normals = Vec::with_capacity(scene.views.len());
            for view in 0..scene.views.len() {
                let planes = s.planes_and_costs(view)?.ok_or_else(|| {
                    Failure::Session(format!("view {view} has no maps (internal error)"))
                })?;
                let (depth, world) = depth_and_world_normals(scene, view, &planes.plane);
                normals.push(camera_normals(scene, view, &world));
                depths.push(depth);
            }
            let fused = mvscope::fusion::fuse(
                &mvscope::fusion::FusionInput {
                    scene,
                    depths: &depths,
                    normals: &normals,
                },
                &params,
            )?;
            Ok(fused.points)
        })?;
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

    /// `mvscope eval` of the maps at the cursor against `gt` (each view's depth, numbered
    /// by its index in the scene on disk): (report as JSON, the CLI's table).
    fn evaluate(
        &self,
        py: Python<'_>,
        gt: std::path::PathBuf,
        abs: Vec<f64>,
        rel: Vec<f64>,
    ) -> PyResult<(String, String)> {
        unblocked(py, || {
            let inner = self.lock()?;
            let s = &inner.session;
            let mut failure = None;
            let mut depth_of = |local: usize| {
                let planes = match s.planes_and_costs(local) {
                    Ok(Some(p)) => p,
                    Ok(None) => {
                        return Err(mvscope::eval::EvalError::Missing(format!(
                            "view {} has no depth map yet: run the session first",
                            inner.indices.get(local).copied().unwrap_or(local)
                        )));
                    }
                    Err(e) => {
                        let message = e.to_string();
                        failure = Some(Failure::from(e));
                        return Err(mvscope::eval::EvalError::Missing(message));
                    }
                };
                let depth: Vec<f32> = planes.plane.iter().map(|p| p[3].max(0.0)).collect();
                mvscope::io::Map::from_data(planes.width, planes.height, 1, depth)
                    .map_err(|e| mvscope::eval::EvalError::Missing(e.to_string()))
            };
            let report = mvscope::eval::evaluate_depths(&inner.indices, &gt, &abs, &rel, |v| {
                depth_of(inner.indices.iter().position(|&i| i == v).unwrap_or(v))
            });
            // What the sources see, where the maps are at the scene's size (the finest scale).
            let local: Vec<usize> = (0..inner.indices.len()).collect();
            let seen = report.as_ref().ok().map(|_| {
                mvscope::eval::evaluate_seen(
                    &inner.scene,
                    &local,
                    &inner.indices,
                    &gt,
                    &mut depth_of,
                )
            });
            match (report, seen, failure) {
                (_, _, Some(f)) => Err(f),
                (Err(e), _, None) | (Ok(_), Some(Err(e)), None) => Err(e.into()),
                (Ok(r), seen, None) => {
                    crate::tools::with_seen(&r, seen.and_then(Result::ok).flatten().as_ref())
                }
            }
        })
    }

    /// The ground-truth cloud of `gt` through this session's cameras, its views numbered as
    /// on disk (`eval::truth_cloud_of`): (n, xyz float32 bytes), or None without truth.
    fn truth_cloud<'py>(
        &self,
        py: Python<'py>,
        gt: std::path::PathBuf,
        voxel: f64,
    ) -> PyResult<Option<(usize, Bound<'py, PyByteArray>)>> {
        let points = self.with(py, |inner| {
            if !(voxel.is_finite() && voxel > 0.0) {
                return Err(Failure::Parameter(format!(
                    "voxel {voxel}: give a positive size in scene units"
                )));
            }
            let cameras: Vec<&mvscope::camera::Camera> =
                inner.scene.views.iter().map(|v| &v.camera).collect();
            Ok(mvscope::eval::truth_cloud_of(
                &cameras,
                &inner.indices,
                &gt,
                voxel,
            )?)
        })?;
        Ok(points.map(|p| (p.len(), byte_array(py, &p))))
    }

    /// Each view's pixels a source sees (`eval::seen_masks`: what `evaluate` splits its
    /// scores by), from the truth in `gt` numbered as on disk, at the scene's processed size:
    /// (width, height, a byte per pixel, 1 where seen), or None for a view without truth.
    #[allow(clippy::type_complexity)]
    fn seen<'py>(
        &self,
        py: Python<'py>,
        gt: std::path::PathBuf,
    ) -> PyResult<Vec<Option<(u32, u32, Bound<'py, PyByteArray>)>>> {
        let masks = self.with(py, |inner| {
            let masks = mvscope::eval::seen_masks(&inner.scene, &inner.indices, &gt)?;
            Ok(inner
                .scene
                .views
                .iter()
                .zip(masks)
                .map(|(v, m)| {
                    m.map(|m| {
                        let bytes: Vec<u8> = m.into_iter().map(u8::from).collect();
                        (v.image.width, v.image.height, bytes)
                    })
                })
                .collect::<Vec<_>>())
        })?;
        Ok(masks
            .into_iter()
            .map(|m| m.map(|(w, h, b)| (w, h, byte_array(py, &b))))
            .collect())
    }

    /// Bytes the session holds on the device now (maps, level images, checkpoints).
    fn device_bytes(&self, py: Python<'_>) -> PyResult<u64> {
        self.with(py, |inner| Ok(inner.session.device_bytes()))
    }

    /// The most bytes Back's checkpoints may hold (oldest dropped first; default 512 MiB).
    #[getter]
    fn get_checkpoint_budget(&self, py: Python<'_>) -> PyResult<u64> {
        self.with(py, |inner| Ok(inner.session.checkpoint_budget()))
    }

    #[setter]
    fn set_checkpoint_budget(&self, py: Python<'_>, bytes: u64) -> PyResult<()> {
        self.with(py, |inner| {
            inner.session.set_checkpoint_budget(bytes);
            Ok(())
        })
    }
}

/// The prior factor of each pixel's current plane where it has a prior (the viewer's
/// "prior weight" map), 0 elsewhere.
fn prior_weights(maps: &ViewMaps) -> Option<Vec<f32>> {
    let (prior, terms) = (maps.prior.as_ref()?, maps.prior_terms.as_ref()?);
    Some(
        maps.state
            .plane
            .iter()
            .zip(prior)
            .map(|(&plane, &p)| {
                if p[3] > 0.0 && plane[3] > 0.0 {
                    mvscope::acmm::planar::prior_factor(plane, p, terms)
                } else {
                    0.0
                }
            })
            .collect(),
    )
}

/// The scale `view`'s maps stand at (that of its last step run; `None` before any), after
/// checking the view exists.
fn shown_level(inner: &Inner, view: usize) -> Result<Option<u32>, Failure> {
    if view >= inner.scene.views.len() {
        return Err(Failure::Parameter(format!(
            "view {view}: the scene has {} views",
            inner.scene.views.len()
        )));
    }
    let s = &inner.session;
    let done = s.schedule().get(..s.cursor()).unwrap_or_default();
    Ok(done
        .iter()
        .rev()
        .find(|st| st.view == view)
        .map(|st| st.level))
}

/// The viewer's pixel inspection: replays the last half of the pixel's colour at the shown
/// scale with the state it read captured, explains it on the CPU, and comes back to where
/// the session stood (replays are exact: the random numbers are fixed per step).
fn inspect_pixel(
    inner: &mut Inner,
    view: usize,
    x: u32,
    y: u32,
) -> Result<Option<(Inspection, Option<RestorerPixel>)>, Failure> {
    let Some(level) = shown_level(inner, view)? else {
        return Ok(None);
    };
    let s = &mut inner.session;
    let cursor = s.cursor();
    let done = s.schedule().get(..cursor).unwrap_or_default();
    let size = s
        .level_scene(level)
        .views
        .get(view)
        .map(|v| (v.image.width, v.image.height))
        .unwrap_or((0, 0));
    if x >= size.0 || y >= size.1 {
        return Err(Failure::Parameter(format!(
            "pixel ({x}, {y}) is outside view {view}'s maps ({}x{} at scale {}/{})",
            size.0,
            size.1,
            level + 1,
            s.num_levels()
        )));
    }
    let color = (x + y) % 2;
    let Some(half) = done.iter().rposition(|st| {
        st.view == view
            && st.level == level
            && matches!(st.action, Action::Half { color: c, .. } if c == color)
    }) else {
        return Ok(None);
    };
    let step = done[half];
    s.goto(half)?;
    let before = s.maps(view)?;
    s.step()?;
    let problem = s.problem_for(&step);
    let source_depths = match step.stage {
        Stage::Geometric(_) => Some(s.source_depths(&problem)?),
        _ => None,
    };
    let prior = match step.stage {
        Stage::Planar => s.planar_prior(view)?.map(|m| m.prior),
        _ => None,
    };
    let c_init = s.restorer_c_init(view)?;
    let anchors = s.anchor_codes(view)?;
    let regions = (step.stage == Stage::Planar)
        .then(|| s.planar_mesh(view))
        .flatten()
        .and_then(|m| m.regions.clone());
    let after = s.maps(view)?;
    let capture = before.zip(after).map(|(before, after)| Capture {
        index: half,
        step,
        params: s.params().clone(),
        method: s.method(),
        problem,
        before: before.state,
        after: after.state,
        source_depths,
        c_init,
        prior,
        anchors,
        regions,
    });
    s.goto(cursor)?;
    let Some(capture) = capture else {
        return Ok(None);
    };
    let Some(inspection) = inspector::inspect(&capture, x, y) else {
        return Ok(None);
    };
    let restorer = s
        .maps(view)?
        .and_then(|m| RestorerPixel::from_maps(&m, (y * size.0 + x) as usize));
    Ok(Some((inspection, restorer)))
}

/// Replays `view`'s last support-point step at the shown scale, reads back what it read,
/// explains pixel (x, y)'s cell and comes back to where the session stood.
fn explain_support(
    inner: &mut Inner,
    view: usize,
    x: u32,
    y: u32,
) -> Result<Option<(usize, mvscope::acmm::planar::SupportCell)>, Failure> {
    let Some(level) = shown_level(inner, view)? else {
        return Ok(None);
    };
    let s = &mut inner.session;
    let cursor = s.cursor();
    let done = s.schedule().get(..cursor).unwrap_or_default();
    let Some(index) = done
        .iter()
        .rposition(|st| st.view == view && st.level == level && st.action == Action::SupportPoints)
    else {
        return Ok(None);
    };
    let step = done[index];
    s.goto(index)?;
    s.step()?;
    let inputs = s.support_inputs(view)?;
    let problem = s.problem_for(&step);
    let params = s.params().clone();
    s.goto(cursor)?;
    let Some(inputs) = inputs else {
        return Ok(None);
    };
    if x >= problem.width || y >= problem.height {
        return Err(Failure::Parameter(format!(
            "pixel ({x}, {y}) is outside view {view}'s maps ({}x{} at scale {}/{})",
            problem.width,
            problem.height,
            level + 1,
            s.num_levels()
        )));
    }
    let cell = mvscope::acmm::planar::explain_cell(
        &problem,
        &params,
        &inputs.plane,
        &inputs.cost,
        inputs.keys.as_deref(),
        inputs.spread.as_deref(),
        x,
        y,
    );
    Ok(cell.map(|c| (index, c)))
}

fn inspection_dict<'py>(
    py: Python<'py>,
    i: &Inspection,
    restorer: Option<RestorerPixel>,
) -> PyResult<Bound<'py, PyDict>> {
    let u = &i.update;
    let d = PyDict::new(py);
    d.set_item("x", i.x)?;
    d.set_item("y", i.y)?;
    d.set_item("step", i.capture_index)?;
    d.set_item("label", &i.label)?;
    d.set_item("geometric", i.geometric)?;
    d.set_item("source_views", i.source_views.clone())?;
    d.set_item("tau_t", u.tau_t)?;
    let candidates = (0..8)
        .map(|k| {
            let c = PyDict::new(py);
            c.set_item("origin", i.origins[k])?;
            c.set_item("plane", u.candidate_planes[k].to_vec())?;
            c.set_item("cost", u.candidate_costs[k])?;
            c.set_item("valid", u.candidates[k].is_some())?;
            Ok(c)
        })
        .collect::<PyResult<Vec<_>>>()?;
    d.set_item("candidates", candidates)?;
    // Candidates x sources.
    let matrix: Vec<Vec<f32>> = (0..8)
        .map(|k| u.matrix.iter().map(|col| col[k]).collect())
        .collect();
    d.set_item("cost_matrix", matrix)?;
    d.set_item("current_plane", u.current_plane.to_vec())?;
    d.set_item("current_costs", u.current_costs.clone())?;
    d.set_item("current_cost", u.current_cost)?;
    let votes = u
        .votes
        .iter()
        .map(|v| {
            let o = PyDict::new(py);
            o.set_item("good", v.good)?;
            o.set_item("bad", v.bad)?;
            o.set_item("selected", v.selected)?;
            o.set_item("weight", v.weight)?;
            o.set_item("weight_prime", v.weight_prime)?;
            Ok(o)
        })
        .collect::<PyResult<Vec<_>>>()?;
    d.set_item("votes", votes)?;
    let refinement = PyDict::new(py);
    refinement.set_item(
        "planes",
        u.refinement_planes
            .iter()
            .map(|p| p.to_vec())
            .collect::<Vec<_>>(),
    )?;
    refinement.set_item("costs", u.refinement_costs.to_vec())?;
    d.set_item("refinement", refinement)?;
    let cpu = PyDict::new(py);
    cpu.set_item("plane", u.plane.to_vec())?;
    cpu.set_item("cost", u.cost)?;
    cpu.set_item("selected", u.selected)?;
    cpu.set_item("weights", u.weights.clone())?;
    cpu.set_item("winner", u.winner.code())?;
    cpu.set_item("best_view", u.best_view)?;
    cpu.set_item("photo_cost", u.photo_cost)?;
    cpu.set_item("replaced", u.replaced)?;
    d.set_item("cpu", cpu)?;
    let gpu = PyDict::new(py);
    gpu.set_item("plane", i.gpu.plane.to_vec())?;
    gpu.set_item("cost", i.gpu.cost)?;
    gpu.set_item("selected", i.gpu.selected)?;
    gpu.set_item("weights", i.gpu.weights.clone())?;
    gpu.set_item("winner", i.gpu.winner)?;
    d.set_item("gpu", gpu)?;
    d.set_item("agrees", i.agrees)?;
    d.set_item("reprojection", i.reprojection.clone())?;
    let prior = match &u.prior {
        Some(p) => {
            let o = PyDict::new(py);
            o.set_item("prior_plane", p.prior_plane.to_vec())?;
            o.set_item("candidate_factors", p.candidate_factors.to_vec())?;
            o.set_item("current_factor", p.current_factor)?;
            o.set_item("refinement_factors", p.refinement_factors.to_vec())?;
            o.set_item("candidate_scores", p.candidate_scores.to_vec())?;
            o.set_item("current_score", p.current_score)?;
            o.set_item("refinement_scores", p.refinement_scores.to_vec())?;
            o.set_item("photometric_winner", p.photometric_winner.code())?;
            o.set_item("flipped", p.flipped)?;
            Some(o)
        }
        None => None,
    };
    d.set_item("prior", prior)?;
    let anchors = match &i.anchors {
        Some(a) => {
            let o = PyDict::new(py);
            o.set_item("pixels", &a.pixels)?;
            o.set_item("weight", a.weight)?;
            o.set_item("own", a.own.to_vec())?;
            o.set_item("anchored", a.anchored.to_vec())?;
            Some(o)
        }
        None => None,
    };
    d.set_item("anchors", anchors)?;
    let w = &i.window;
    let window = PyDict::new(py);
    window.set_item(
        "kernel",
        match w.kernel {
            mvscope::acmm::params::BilateralKernel::Laplacian => "laplacian",
            mvscope::acmm::params::BilateralKernel::Gaussian => "gaussian",
            mvscope::acmm::params::BilateralKernel::Adaptive => "adaptive",
        },
    )?;
    window.set_item("sigma", w.sigma)?;
    window.set_item("spread", w.spread)?;
    // (2r+1) rows of (2r+1).
    let rows =
        |v: &[f32]| -> Vec<Vec<f32>> { v.chunks(w.size.max(1)).map(<[f32]>::to_vec).collect() };
    window.set_item("weights", rows(&w.weights))?;
    window.set_item("effective", w.effective)?;
    window.set_item("variance_share", rows(&w.variance_share))?;
    window.set_item("samples", w.samples)?;
    d.set_item("window", window)?;
    let restorer = match restorer {
        Some(r) => {
            let o = PyDict::new(py);
            o.set_item("difference", r.difference)?;
            o.set_item("replaced", r.replaced)?;
            Some(o)
        }
        None => None,
    };
    d.set_item("restorer", restorer)?;
    Ok(d)
}
