//! The 3D view's points: the fused cloud or back-projected maps, asked for and taken when
//! their maps have arrived.

use super::*;

impl Model {
    pub(super) fn set_cloud(&mut self, points: Vec<CloudVertex>) {
        self.cloud_version += 1;
        let frusta = self.frusta();
        self.cloud = Arc::new(CloudScene {
            points,
            frusta,
            version: self.cloud_version,
        });
    }

    pub(super) fn frusta(&self) -> Vec<Frustum> {
        let Some(scene) = self.scene() else {
            return Vec::new();
        };
        let depth = scene
            .views
            .iter()
            .map(|v| v.depth_range.min as f32)
            .fold(f32::INFINITY, f32::min);
        let depth = if depth.is_finite() && depth > 0.0 {
            depth * 0.5
        } else {
            0.5
        };
        scene
            .views
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let color = if i == self.view {
                    [1.0, 0.8, 0.2]
                } else {
                    [0.6, 0.6, 0.7]
                };
                Frustum::from_camera(&v.camera, depth, color)
            })
            .collect()
    }

    /// Fuses the current maps of every view (at the finest scale any of them reached) when
    /// they have arrived from the device: asked for now, fused in a later frame.
    pub fn request_fusion(&mut self) -> Result<(), String> {
        self.request_cloud(CloudJob::Fuse)
    }

    /// Back-projects the current depth of the chosen view (or all views) into the 3D view,
    /// once the maps have arrived.
    pub fn request_backprojection(&mut self, all: bool) {
        if let Err(e) = self.request_cloud(CloudJob::Backproject { all }) {
            self.error = Some(e);
        }
    }

    pub(super) fn request_cloud(&mut self, job: CloudJob) -> Result<(), String> {
        let session = self.session.as_ref().ok_or("open a scene first")?;
        let views: Vec<usize> = match job {
            CloudJob::Backproject { all: false } => vec![self.view],
            _ => (0..session.level_scene(0).views.len()).collect(),
        };
        let reads = views
            .into_iter()
            .map(|v| Ok((v, session.request_planes_and_costs(v)?)))
            .collect::<Result<Vec<_>, SessionError>>()
            .map_err(|e| e.to_string())?;
        self.pending_cloud = Some(PendingCloud { job, reads });
        Ok(())
    }

    /// Finishes a fusion or back-projection whose maps have all arrived.
    pub(super) fn poll_cloud(&mut self) {
        let ctx = self.ctx.clone();
        let ready = self
            .pending_cloud
            .as_ref()
            .is_some_and(|p| p.reads.iter().all(|(_, r)| r.is_ready(&ctx)));
        if !ready {
            return;
        }
        let Some(mut pending) = self.pending_cloud.take() else {
            return;
        };
        let mut maps = Vec::new();
        for (v, r) in &mut pending.reads {
            match r.take(&ctx) {
                Some(Ok(m)) => maps.push((*v, m)),
                Some(Err(e)) => {
                    self.error = Some(e.to_string());
                    return;
                }
                None => return,
            }
        }
        match pending.job {
            CloudJob::Fuse => {
                if let Err(e) = self.fuse_maps(&maps) {
                    self.error = Some(format!("fusion: {e}"));
                }
            }
            CloudJob::Backproject { all } => self.backproject_maps(&maps, all),
        }
    }

    /// Fuses now, waiting for the maps (scripts, tests; natively).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn refuse(&mut self) -> anyhow::Result<usize> {
        self.request_fusion().map_err(anyhow::Error::msg)?;
        let maps = self.wait_cloud()?;
        self.fuse_maps(&maps)
    }

    /// Back-projects now, waiting for the maps (scripts, tests; natively).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn backproject(&mut self, all: bool) {
        self.request_backprojection(all);
        match self.wait_cloud() {
            Ok(maps) => self.backproject_maps(&maps, all),
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    #[cfg(not(target_arch = "wasm32"))]
    pub(super) fn wait_cloud(&mut self) -> anyhow::Result<Vec<(usize, Option<PlanesCosts>)>> {
        let Some(pending) = self.pending_cloud.take() else {
            return Ok(Vec::new());
        };
        pending
            .reads
            .into_iter()
            .map(|(v, r)| Ok((v, r.wait(&self.ctx)?)))
            .collect()
    }

    /// Fuses `maps` (view, planes and costs) at the finest level any view reached.
    pub(super) fn fuse_maps(
        &mut self,
        maps: &[(usize, Option<PlanesCosts>)],
    ) -> anyhow::Result<usize> {
        let Some(session) = &self.session else {
            anyhow::bail!("open a scene first");
        };
        let n = session.level_scene(0).views.len();
        let level = maps
            .iter()
            .filter_map(|(_, m)| m.as_ref())
            .map(|m| m.level)
            .max();
        let Some(level) = level else {
            anyhow::bail!("no view has a depth map yet: run some steps first");
        };
        let scene = session.level_scene(level).clone();
        let mut depths = Vec::with_capacity(n);
        let mut normals = Vec::with_capacity(n);
        for v in 0..n {
            let view = &scene.views[v];
            let px = view.image.width as usize * view.image.height as usize;
            match maps
                .iter()
                .find(|(w, _)| *w == v)
                .and_then(|(_, m)| m.as_ref())
            {
                Some(m) if m.level == level => {
                    depths.push(m.plane.iter().map(|p| p[3]).collect());
                    normals.push(m.plane.iter().map(|p| [p[0], p[1], p[2]]).collect());
                }
                _ => {
                    depths.push(vec![0.0; px]);
                    normals.push(vec![[0.0, 0.0, -1.0]; px]);
                }
            }
        }
        let input = crate::fusion::FusionInput {
            scene: &scene,
            depths: &depths,
            normals: &normals,
        };
        let fused = crate::fusion::fuse(&input, &self.params)?;
        let counts = crate::fusion::confidence(&input, &self.params)?;
        self.confidence = Some(super::FusedConfidence {
            version: self.version,
            counts,
        });
        let count = fused.points.len();
        let levels = session.num_levels();
        self.cloud_source = CloudSource::Fused;
        self.set_cloud(points_from_fusion(&fused.points));
        self.notice = Notice::until_moved(format!(
            "fused {count} points from scale {}/{levels}",
            level + 1
        ));
        Ok(count)
    }

    /// Back-projects `maps` (view, planes and costs) into the 3D view.
    pub(super) fn backproject_maps(&mut self, maps: &[(usize, Option<PlanesCosts>)], all: bool) {
        let Some(session) = &self.session else {
            return;
        };
        let mut points = Vec::new();
        for (v, m) in maps {
            let Some(m) = m else {
                continue;
            };
            let scene = session.level_scene(m.level);
            let depth: Vec<f32> = m.plane.iter().map(|p| p[3]).collect();
            let normals: Vec<[f32; 3]> = m.plane.iter().map(|p| [p[0], p[1], p[2]]).collect();
            points.extend(points_from_depth(
                &scene.views[*v],
                m.width,
                m.height,
                &depth,
                &normals,
                &m.cost,
            ));
        }
        self.cloud_source = if all {
            CloudSource::AllDepths
        } else {
            CloudSource::ViewDepth
        };
        self.set_cloud(points);
    }
}
