//! Logging a run to a Rerun recording (`.rrd` file), behind the `rerun` cargo feature.
//!
//! [`RunLogger`] writes the scene's cameras and images, the depth, normal and cost maps of every
//! stage, and the fused cloud, so a run can be replayed in the Rerun viewer
//! (`rerun FILE.rrd`). Only the Rerun SDK is linked: no viewer, no server.
//!
//! # Entity layout
//!
//! | entity                              | what                                   | time          |
//! |-------------------------------------|----------------------------------------|---------------|
//! | `world/views/{name}`                | `Transform3D`: the camera pose         | static        |
//! | `world/views/{name}/image`          | `Pinhole` (full size) + colour `Image` | static        |
//! | `world/views/{name}/maps`           | `Pinhole` at the maps' pyramid size    | `stage`       |
//! | `world/views/{name}/maps/depth`     | `DepthImage` (meter = 1)               | `stage`       |
//! | `world/views/{name}/maps/normal`    | RGB `Image` of the normals             | `stage`       |
//! | `world/views/{name}/maps/cost`      | greyscale `Image` of the cost          | `stage`       |
//! | `world/views/{name}/maps/prior`     | `DepthImage`: the planar prior's depth (ACMP, ACMMP) | `stage` |
//! | `world/views/{name}/maps/support_points` | `Points2D`: the prior's support points | `stage` |
//! | `steps`                             | `TextLog`: the step that produced maps | `stage`       |
//! | `world/fused`                       | `Points3D` with colours                | static        |
//!
//! Maps are logged on the sequence timeline `stage` (the caller's stage index), so scrubbing it
//! steps through the stages. The pose and the pinhole live on different entities: on one entity
//! they would describe the same child/parent relation, for which Rerun's `Pinhole` docs say a
//! `Transform3D` takes precedence.
//!
//! # Coordinate conversions
//!
//! * **Pose.** mvscope stores `camera_from_world` (`X_cam = R X_world + t`, see
//!   [`crate::camera`]). Rerun's `Transform3D` on `world/views/{name}` maps the entity's
//!   (camera) space into its parent's (world) space, so it is logged as `world_from_camera`:
//!   rotation `R^T` (its columns are the rows of `R`), translation the camera centre
//!   `C = -R^T t`. The world frame is the scene's, unchanged; no world up axis is imposed.
//! * **Camera axes.** mvscope's camera has `x` right, `y` down, `z` forward: Rerun's `RDF`
//!   view coordinates, which are also logged explicitly as the pinhole's `camera_xyz`.
//! * **Pixel centres.** mvscope puts pixel centres on integer coordinates (the top-left pixel's
//!   centre is `(0, 0)`, the image spans `[-0.5, w - 0.5]`). Rerun's image space spans
//!   `[0, w] x [0, h]` with the top-left pixel's centre at `(0.5, 0.5)`. So the logged
//!   intrinsics are `K` with the principal point shifted by `+0.5` in `x` and `y`; the focal
//!   lengths are unchanged.
//! * **Depth.** mvscope's depth is the camera-frame `z` (not the distance along the ray), as in
//!   Rerun's `DepthImage`, logged as `f32` in scene units with `meter = 1`, so the viewer
//!   back-projects it through the maps' pinhole onto the surfaces. Pixels without a valid depth
//!   (`<= 0` or not finite) are logged as `0`, which Rerun treats as "no depth".
//! * **Normals** are in the view's camera frame (`x` right, `y` down, `z` forward; they face the
//!   camera, so `z < 0`) and are shown as `rgb = round(255 * (n * 0.5 + 0.5))`; pixels without a
//!   valid depth are black.
//! * **Cost** (in `[0, MAX_COST]` = `[0, 2]`) is shown as 8-bit grey
//!   `round(255 * cost / MAX_COST)`: black is a perfect match, white the worst cost.
//! * **Maps at a coarser pyramid scale** get their own pinhole: the view's camera rescaled to the
//!   maps' size with [`crate::camera::Camera::rescaled`], then converted as above.

use std::path::{Path, PathBuf};

use rerun::archetypes::{DepthImage, Image, Pinhole, Points2D, Points3D, TextLog, Transform3D};
use rerun::components::ViewCoordinates;
use rerun::datatypes::{ChannelDatatype, ColorModel};
use rerun::{EntityPath, EntityPathPart, RecordingStream, RecordingStreamBuilder};

use crate::acmm::cpu::MAX_COST;
use crate::camera::Camera;
use crate::io::ply::PlyPoint;
use crate::scene::{Scene, View};
use crate::session::ViewMaps;

/// Application id of the recordings mvscope writes.
pub const APPLICATION_ID: &str = "mvscope";

/// Name of the sequence timeline that maps are logged on.
pub const STAGE_TIMELINE: &str = "stage";

/// Image plane distance of the logged frusta, as a fraction of the view's minimum depth: the
/// frusta stay well in front of the surfaces they look at.
const IMAGE_PLANE_FRACTION: f64 = 0.2;

/// What can go wrong while logging to Rerun.
#[derive(Debug, thiserror::Error)]
pub enum RerunError {
    #[error("cannot create the Rerun recording {}: {source}", path.display())]
    Create {
        path: PathBuf,
        #[source]
        source: rerun::RecordingStreamError,
    },
    #[error("cannot log {entity} to the Rerun recording: {source}")]
    Log {
        entity: String,
        #[source]
        source: rerun::RecordingStreamError,
    },
    #[error("cannot flush the Rerun recording: {0}")]
    Flush(#[from] rerun::sink::SinkFlushError),
    #[error("view index {view} is out of range: the scene has {views} views")]
    NoSuchView { view: usize, views: usize },
    #[error(
        "the maps of view {name} are {width}x{height} but hold {planes} planes and {costs} costs"
    )]
    MapSize {
        name: String,
        width: u32,
        height: u32,
        planes: usize,
        costs: usize,
    },
}

/// Writes a run to a Rerun recording. Dropping it flushes and closes the file.
pub struct RunLogger {
    rec: RecordingStream,
}

impl RunLogger {
    /// Starts a recording written to `path` (an `.rrd` file, created or truncated). Logging is
    /// forced on, whatever the `RERUN` environment variable says: the caller asked for a file.
    pub fn to_file(path: &Path) -> Result<RunLogger, RerunError> {
        let rec = RecordingStreamBuilder::new(APPLICATION_ID)
            .enabled(true)
            .save(path)
            .map_err(|source| RerunError::Create {
                path: path.to_path_buf(),
                source,
            })?;
        Ok(RunLogger { rec })
    }

    /// The underlying stream, for logging anything else.
    pub fn stream(&self) -> &RecordingStream {
        &self.rec
    }

    /// Logs every view's pose, pinhole and colour image (static: they hold for the whole run).
    pub fn log_scene(&self, scene: &Scene) -> Result<(), RerunError> {
        for view in &scene.views {
            let camera = &view.camera;
            self.log_static(&view_path(view, &[]), &world_from_camera(camera))?;
            let image_path = view_path(view, &["image"]);
            self.log_static(&image_path, &pinhole(view, camera))?;
            let rgb: Vec<u8> = view.image.rgb.iter().flatten().copied().collect();
            let image = Image::from_rgb24(rgb, [view.image.width, view.image.height]);
            self.log_static(&image_path, &image)?;
        }
        Ok(())
    }

    /// Logs the depth, normal and cost maps `maps` of view `view` at `stage_index` on the
    /// `stage` timeline, with `step_label` (e.g. [`crate::session::Step::label`]) as a
    /// text entry. Maps at a coarser scale than the scene's images get a pinhole of their own.
    pub fn log_maps(
        &self,
        step_label: &str,
        stage_index: i64,
        view: usize,
        scene: &Scene,
        maps: &ViewMaps,
    ) -> Result<(), RerunError> {
        let v = scene.views.get(view).ok_or(RerunError::NoSuchView {
            view,
            views: scene.views.len(),
        })?;
        let state = &maps.state;
        let (width, height) = (state.width, state.height);
        let n = width as usize * height as usize;
        if state.plane.len() != n || state.cost.len() != n {
            return Err(RerunError::MapSize {
                name: v.name.clone(),
                width,
                height,
                planes: state.plane.len(),
                costs: state.cost.len(),
            });
        }

        self.rec.set_time_sequence(STAGE_TIMELINE, stage_index);
        let result = self.log_maps_now(step_label, v, maps);
        // Only this timeline: whatever else the caller set on the stream stays.
        self.rec.disable_timeline(STAGE_TIMELINE);
        result
    }

    fn log_maps_now(
        &self,
        step_label: &str,
        view: &View,
        maps: &ViewMaps,
    ) -> Result<(), RerunError> {
        let state = &maps.state;
        let size = [state.width, state.height];
        let camera = view.camera.rescaled(state.width, state.height);
        self.log(&view_path(view, &["maps"]), &pinhole(view, &camera))?;

        let valid = |p: &[f32; 4]| p[3].is_finite() && p[3] > 0.0;
        let depth: Vec<f32> = state
            .plane
            .iter()
            .map(|p| if valid(p) { p[3] } else { 0.0 })
            .collect();
        let depth_image =
            DepthImage::from_data_type_and_bytes(f32_bytes(&depth), size, ChannelDatatype::F32)
                .with_meter(1.0)
                .with_depth_range([view.depth_range.min, view.depth_range.max]);
        self.log(&view_path(view, &["maps", "depth"]), &depth_image)?;

        let normal: Vec<u8> = state
            .plane
            .iter()
            .flat_map(|p| {
                if valid(p) {
                    [unit_to_u8(p[0]), unit_to_u8(p[1]), unit_to_u8(p[2])]
                } else {
                    [0; 3]
                }
            })
            .collect();
        let normal_image =
            Image::from_color_model_and_bytes(normal, size, ColorModel::RGB, ChannelDatatype::U8);
        self.log(&view_path(view, &["maps", "normal"]), &normal_image)?;

        let cost: Vec<u8> = state.cost.iter().map(|&c| cost_to_u8(c)).collect();
        self.log(
            &view_path(view, &["maps", "cost"]),
            &Image::from_l8(cost, size),
        )?;

        if let Some(prior) = &maps.prior {
            // The planar prior's depth; pixels without a prior (depth <= 0) are "no depth".
            let depth: Vec<f32> = prior.iter().map(|p| p[3].max(0.0)).collect();
            let prior_image =
                DepthImage::from_data_type_and_bytes(f32_bytes(&depth), size, ChannelDatatype::F32)
                    .with_meter(1.0)
                    .with_depth_range([view.depth_range.min, view.depth_range.max]);
            self.log(&view_path(view, &["maps", "prior"]), &prior_image)?;
        }
        if let Some(points) = &maps.support_points {
            // Pixel centres in Rerun's image space (+0.5, see the module docs).
            let positions = points.iter().map(|p| (p[0] + 0.5, p[1] + 0.5));
            self.log(
                &view_path(view, &["maps", "support_points"]),
                &Points2D::new(positions),
            )?;
        }

        self.log(
            &EntityPath::new(vec![EntityPathPart::new("steps")]),
            &TextLog::new(format!("view {}: {step_label}", view.name)),
        )
    }

    /// Logs the fused cloud at `world/fused` (static), with its colours. Normals are not shown.
    pub fn log_cloud(&self, points: &[PlyPoint]) -> Result<(), RerunError> {
        let cloud = Points3D::new(points.iter().map(|p| p.position))
            .with_colors(points.iter().map(|p| p.color));
        self.log_static(&fused_path(), &cloud)
    }

    /// Waits until everything logged so far is written to the file.
    pub fn flush(&self) -> Result<(), RerunError> {
        self.rec.flush_blocking()?;
        Ok(())
    }

    fn log(&self, entity: &EntityPath, data: &impl rerun::AsComponents) -> Result<(), RerunError> {
        self.rec
            .log(entity.clone(), data)
            .map_err(|source| RerunError::Log {
                entity: entity.to_string(),
                source,
            })
    }

    fn log_static(
        &self,
        entity: &EntityPath,
        data: &impl rerun::AsComponents,
    ) -> Result<(), RerunError> {
        self.rec
            .log_static(entity.clone(), data)
            .map_err(|source| RerunError::Log {
                entity: entity.to_string(),
                source,
            })
    }
}

/// `world/views/{name}/{children...}`, with the view name taken verbatim (not parsed as a path).
fn view_path(view: &View, children: &[&str]) -> EntityPath {
    let mut parts = vec![
        EntityPathPart::new("world"),
        EntityPathPart::new("views"),
        EntityPathPart::new(view.name.as_str()),
    ];
    parts.extend(children.iter().map(|&c| EntityPathPart::new(c)));
    EntityPath::new(parts)
}

fn fused_path() -> EntityPath {
    EntityPath::new(vec![
        EntityPathPart::new("world"),
        EntityPathPart::new("fused"),
    ])
}

/// The camera pose as Rerun's parent-from-child transform: `world_from_camera`, rotation `R^T`
/// and translation `C = -R^T t` (see the module docs).
fn world_from_camera(camera: &Camera) -> Transform3D {
    let r = camera.rotation;
    let c = camera.center();
    // Column j of R^T is row j of R; Rerun takes the 3x3 matrix as columns.
    let columns = [0, 1, 2].map(|j| r.row(j).as_vec3().to_array());
    Transform3D::from_translation_mat3x3(c.as_vec3().to_array(), columns)
}

/// The pinhole of `camera` in Rerun's pixel convention: principal point `+0.5` (see the module
/// docs), `RDF` camera axes, image plane at a fifth of the view's minimum depth.
fn pinhole(view: &View, camera: &Camera) -> Pinhole {
    let k = &camera.intrinsics;
    let (fx, fy) = (k.fx as f32, k.fy as f32);
    let (cx, cy) = ((k.cx + 0.5) as f32, (k.cy + 0.5) as f32);
    Pinhole::new([[fx, 0.0, 0.0], [0.0, fy, 0.0], [cx, cy, 1.0]])
        .with_resolution([camera.width as f32, camera.height as f32])
        .with_camera_xyz(ViewCoordinates::RDF)
        .with_image_plane_distance((view.depth_range.min * IMAGE_PLANE_FRACTION) as f32)
}

/// A value in `[-1, 1]` as `round(255 * (x * 0.5 + 0.5))`, clamped.
fn unit_to_u8(x: f32) -> u8 {
    if x.is_finite() {
        ((x * 0.5 + 0.5).clamp(0.0, 1.0) * 255.0).round() as u8
    } else {
        0
    }
}

/// A cost in `[0, MAX_COST]` as `round(255 * cost / MAX_COST)`; not finite counts as the worst.
fn cost_to_u8(cost: f32) -> u8 {
    if cost.is_finite() {
        ((cost / MAX_COST).clamp(0.0, 1.0) * 255.0).round() as u8
    } else {
        255
    }
}

/// The bytes of `values` in memory order (little-endian on every target mvscope builds for), as
/// Rerun's image buffers expect.
fn f32_bytes(values: &[f32]) -> Vec<u8> {
    bytemuck::cast_slice(values).to_vec()
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;
    use std::io::BufReader;

    use rerun::components::{
        ImageBuffer, PinholeProjection, Position3D, TransformMat3x3, Translation3D,
    };
    use rerun::external::re_log_encoding::{DecoderApp, RRD_FOURCC};
    use rerun::log::{Chunk, LogMsg};
    use rerun::{Component, ComponentDescriptor, TimelineName};

    use super::*;
    use crate::acmm::problem::ViewState;
    use crate::synthetic::{SyntheticOptions, generate};

    /// Maps of a view made from the synthetic ground truth: normals turned into the camera
    /// frame, a cost that varies over the image.
    fn maps_from_ground_truth(camera: &Camera, gt: &crate::synthetic::GroundTruth) -> ViewMaps {
        let n = gt.width as usize * gt.height as usize;
        let plane = gt
            .depth
            .iter()
            .zip(&gt.normal_world)
            .map(|(&d, nw)| {
                let nc = camera.dir_camera_from_world(glam::DVec3::new(
                    nw[0] as f64,
                    nw[1] as f64,
                    nw[2] as f64,
                ));
                [nc.x as f32, nc.y as f32, nc.z as f32, d]
            })
            .collect();
        let cost = (0..n).map(|i| (i % 9) as f32 * 0.25).collect();
        ViewMaps {
            level: 0,
            state: ViewState {
                width: gt.width,
                height: gt.height,
                num_sources: 0,
                plane,
                cost,
                selected: vec![0; n],
                weights: Vec::new(),
                aux: vec![0; n],
            },
            restorer_difference: None,
            replaced: None,
            reprojection_error: None,
            anchors: None,
            prior: None,
            prior_terms: None,
            support_points: None,
        }
    }

    /// Constant maps at another size (a coarser pyramid scale).
    fn flat_maps(width: u32, height: u32, depth: f32) -> ViewMaps {
        let n = width as usize * height as usize;
        ViewMaps {
            level: 0,
            state: ViewState {
                width,
                height,
                num_sources: 0,
                plane: vec![[0.0, 0.0, -1.0, depth]; n],
                cost: vec![MAX_COST; n],
                selected: vec![0; n],
                weights: Vec::new(),
                aux: vec![0; n],
            },
            restorer_difference: None,
            replaced: None,
            reprojection_error: None,
            anchors: None,
            prior: None,
            prior_terms: None,
            support_points: None,
        }
    }

    /// Every chunk of an .rrd file, by entity.
    fn read_chunks(path: &Path) -> HashMap<EntityPath, Vec<Chunk>> {
        let file = std::fs::File::open(path).expect("open the recording");
        let mut chunks: HashMap<EntityPath, Vec<Chunk>> = HashMap::new();
        let mut store_infos = 0;
        for msg in DecoderApp::decode_eager(BufReader::new(file)).expect("an RRD stream") {
            match msg.expect("a valid message") {
                LogMsg::SetStoreInfo(info) => {
                    assert_eq!(info.info.application_id().as_str(), APPLICATION_ID);
                    store_infos += 1;
                }
                LogMsg::ArrowMsg(_, arrow) => {
                    let chunk = Chunk::from_arrow_msg(&arrow).expect("a valid chunk");
                    chunks
                        .entry(chunk.entity_path().clone())
                        .or_default()
                        .push(chunk);
                }
                LogMsg::BlueprintActivationCommand(_) => {}
            }
        }
        assert!(store_infos >= 1, "the recording announces its store");
        chunks
    }

    /// All values of one component at one entity, with the `stage` time of each row (None when
    /// static).
    fn values<C: Component + Clone>(
        chunks: &HashMap<EntityPath, Vec<Chunk>>,
        entity: &EntityPath,
        descriptor: &ComponentDescriptor,
    ) -> Vec<(Option<i64>, Vec<C>)> {
        let stage = TimelineName::from_static_str(STAGE_TIMELINE);
        let mut out = Vec::new();
        for chunk in chunks.get(entity).map(Vec::as_slice).unwrap_or_default() {
            let rows = chunk
                .iter_component_indices(stage, descriptor.component)
                .zip(chunk.iter_component::<C>(descriptor.component));
            for ((time, _row), batch) in rows {
                let time = (!chunk.is_static()).then(|| time.as_i64());
                out.push((time, batch.to_vec()));
            }
        }
        out
    }

    /// The bytes of an image buffer.
    fn buffer_bytes(buffer: &ImageBuffer) -> &[u8] {
        &buffer.0
    }

    #[test]
    fn a_logged_run_reads_back_with_its_cameras_maps_and_cloud() {
        let synthetic = generate(&SyntheticOptions {
            views: 3,
            width: 32,
            height: 24,
            seed: 7,
            noise_sigma: 0.0,
            room: false,
            sources: crate::scene::geometry::DEFAULT_SOURCES,
        })
        .expect("synthetic scene");
        let scene = &synthetic.scene;
        let maps0 = maps_from_ground_truth(&scene.views[0].camera, &synthetic.ground_truth[0]);
        let maps1 = flat_maps(16, 12, 5.0);
        let points = vec![
            PlyPoint {
                position: [0.0, 0.5, 1.0],
                normal: [0.0, 0.0, -1.0],
                color: [255, 0, 0],
            },
            PlyPoint {
                position: [0.25, -0.5, 2.0],
                normal: [0.0, 1.0, 0.0],
                color: [0, 128, 255],
            },
        ];

        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("run.rrd");
        {
            let logger = RunLogger::to_file(&path).expect("create the recording");
            logger.log_scene(scene).expect("log the scene");
            logger
                .log_maps("photometric · view 0", 0, 0, scene, &maps0)
                .expect("log maps of view 0");
            logger
                .log_maps("geometric 1 · view 1", 3, 1, scene, &maps1)
                .expect("log maps of view 1");
            logger.log_cloud(&points).expect("log the cloud");
            logger.flush().expect("flush");
        }

        // The file: an RRD stream of reasonable size.
        let file = std::fs::read(&path).expect("read the recording");
        assert!(file.len() > 1000, "only {} bytes", file.len());
        assert_eq!(file[..4], RRD_FOURCC, "RRD magic bytes");

        // Decoded: every entity, with the logged values.
        let chunks = read_chunks(&path);
        for view in &scene.views {
            let camera = &view.camera;

            let pose = view_path(view, &[]);
            let t = values::<Translation3D>(&chunks, &pose, &Transform3D::descriptor_translation());
            assert_eq!(t.len(), 1, "one static pose for {pose}");
            assert_eq!(t[0].0, None, "the pose is static");
            let centre = camera.center();
            for (got, want) in t[0].1[0].0.0.iter().zip(centre.to_array()) {
                assert!((*got as f64 - want).abs() < 1e-5);
            }
            let m = values::<TransformMat3x3>(&chunks, &pose, &Transform3D::descriptor_mat3x3());
            // Column-major R^T is row-major R.
            let rt = m[0].1[0].0.0;
            for (i, want) in camera
                .rotation
                .transpose()
                .to_cols_array()
                .iter()
                .enumerate()
            {
                assert!((rt[i] as f64 - want).abs() < 1e-6);
            }
            let k = camera.intrinsics;

            let image = view_path(view, &["image"]);
            let p = values::<PinholeProjection>(
                &chunks,
                &image,
                &Pinhole::descriptor_image_from_camera(),
            );
            let m = p[0].1[0].0.0;
            assert_eq!(m[0], k.fx as f32);
            assert_eq!(m[4], k.fy as f32);
            assert_eq!(
                m[6],
                (k.cx + 0.5) as f32,
                "principal point in Rerun's convention"
            );
            assert_eq!(m[7], (k.cy + 0.5) as f32);
            let rgb = values::<ImageBuffer>(&chunks, &image, &Image::descriptor_buffer());
            let want: Vec<u8> = view.image.rgb.iter().flatten().copied().collect();
            assert_eq!(rgb.len(), 1);
            assert_eq!(buffer_bytes(&rgb[0].1[0]), want.as_slice(), "colour image");
        }

        // Maps of view 0 at stage 0: depth bit-exact, normals and cost encoded.
        let v0 = &scene.views[0];
        let depth = values::<ImageBuffer>(
            &chunks,
            &view_path(v0, &["maps", "depth"]),
            &DepthImage::descriptor_buffer(),
        );
        assert_eq!(depth.len(), 1);
        assert_eq!(depth[0].0, Some(0), "on the stage timeline at stage 0");
        let want: Vec<f32> = maps0
            .state
            .plane
            .iter()
            .map(|p| if p[3] > 0.0 { p[3] } else { 0.0 })
            .collect();
        assert_eq!(buffer_bytes(&depth[0].1[0]), f32_bytes(&want).as_slice());
        let normal = values::<ImageBuffer>(
            &chunks,
            &view_path(v0, &["maps", "normal"]),
            &Image::descriptor_buffer(),
        );
        assert_eq!(normal[0].1[0].0.len(), 3 * want.len());
        let cost = values::<ImageBuffer>(
            &chunks,
            &view_path(v0, &["maps", "cost"]),
            &Image::descriptor_buffer(),
        );
        let got_cost = buffer_bytes(&cost[0].1[0]).to_vec();
        assert_eq!(got_cost[..3], [0, 32, 64], "cost 0, 0.25, 0.5 of 2 as grey");

        // Maps of view 1 at stage 3, at half size: their own pinhole, rescaled.
        let v1 = &scene.views[1];
        let maps_pinhole = values::<PinholeProjection>(
            &chunks,
            &view_path(v1, &["maps"]),
            &Pinhole::descriptor_image_from_camera(),
        );
        assert_eq!(maps_pinhole[0].0, Some(3));
        let half = v1.camera.rescaled(16, 12);
        assert_eq!(
            maps_pinhole[0].1[0].0.0[6],
            (half.intrinsics.cx + 0.5) as f32
        );
        assert!(
            ((half.intrinsics.cx + 0.5) - (v1.camera.intrinsics.cx + 0.5) * 0.5).abs() < 1e-9,
            "in Rerun's convention rescaling is a plain scale"
        );
        let depth1 = values::<ImageBuffer>(
            &chunks,
            &view_path(v1, &["maps", "depth"]),
            &DepthImage::descriptor_buffer(),
        );
        assert_eq!(depth1[0].0, Some(3));
        assert_eq!(depth1[0].1[0].0.len(), 16 * 12 * 4);

        // The cloud.
        let cloud = values::<Position3D>(&chunks, &fused_path(), &Points3D::descriptor_positions());
        assert_eq!(cloud.len(), 1);
        let got: Vec<[f32; 3]> = cloud[0].1.iter().map(|p| p.0.0).collect();
        let want: Vec<[f32; 3]> = points.iter().map(|p| p.position).collect();
        assert_eq!(got, want);
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        let dir = tempfile::tempdir().expect("temp dir");
        let missing = dir.path().join("no/such/dir/run.rrd");
        assert!(matches!(
            RunLogger::to_file(&missing),
            Err(RerunError::Create { .. })
        ));

        let synthetic = generate(&SyntheticOptions {
            views: 2,
            width: 16,
            height: 16,
            seed: 1,
            noise_sigma: 0.0,
            room: false,
            sources: crate::scene::geometry::DEFAULT_SOURCES,
        })
        .expect("synthetic scene");
        let logger = RunLogger::to_file(&dir.path().join("run.rrd")).expect("create");
        let maps = flat_maps(4, 4, 1.0);
        assert!(matches!(
            logger.log_maps("x", 0, 5, &synthetic.scene, &maps),
            Err(RerunError::NoSuchView { view: 5, views: 2 })
        ));
        let mut bad = maps.clone();
        bad.state.cost.pop();
        assert!(matches!(
            logger.log_maps("x", 0, 0, &synthetic.scene, &bad),
            Err(RerunError::MapSize { .. })
        ));
    }

    #[test]
    fn encodings_of_normals_and_cost() {
        assert_eq!(unit_to_u8(-1.0), 0);
        assert_eq!(unit_to_u8(1.0), 255);
        assert_eq!(unit_to_u8(0.0), 128);
        assert_eq!(cost_to_u8(0.0), 0);
        assert_eq!(cost_to_u8(MAX_COST), 255);
        assert_eq!(cost_to_u8(f32::NAN), 255);
    }
}
