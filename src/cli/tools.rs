//! The commands around a run: `fuse`, `eval`, `demo`, `info`, `convert` and `gpu`.

use super::*;

pub(super) fn reload(dir: &Path) -> Result<(RunRecord, Scene)> {
    let record = RunRecord::read(&dir.join("params.toml"))?;
    let options = LoadOptions {
        format: record.format,
        max_image_size: record.max_image_size,
        depth_range: match record.depth_range {
            Some([a, b]) => Some(DepthRange::new(a, b).map_err(anyhow::Error::msg)?),
            None => None,
        },
        model: record.model,
        undistort_cache: Some(dir.join("undistorted")),
        decode_only: None,
    };
    let scene = Scene::load(&record.scene, &options).with_context(|| {
        format!(
            "reloading the scene recorded in {}/params.toml",
            dir.display()
        )
    })?;
    let scene = scene.subset(&record.views)?;
    Ok((record, scene))
}

pub(super) fn fuse(dir: PathBuf, sets: Vec<String>) -> Result<()> {
    let (record, scene) = reload(&dir)?;
    let params = record
        .params
        .with_overrides(&sets)
        .map_err(anyhow::Error::msg)?;
    let mut depths = Vec::new();
    let mut normals = Vec::new();
    for (local, &index) in record.views.iter().enumerate() {
        let d = mvscope::io::read_pfm(&dir.join(format!("depth/{index:08}.pfm")))?;
        let n = mvscope::io::read_pfm(&dir.join(format!("normal/{index:08}.pfm")))?;
        let cam = &scene.views[local].camera;
        normals.push(
            n.data
                .chunks_exact(3)
                .map(|c| {
                    let v = cam.dir_camera_from_world(glam::DVec3::new(
                        c[0] as f64,
                        c[1] as f64,
                        c[2] as f64,
                    ));
                    [v.x as f32, v.y as f32, v.z as f32]
                })
                .collect::<Vec<_>>(),
        );
        depths.push(d.data);
    }
    let result = mvscope::fusion::fuse(
        &mvscope::fusion::FusionInput {
            scene: &scene,
            depths: &depths,
            normals: &normals,
        },
        &params,
    )?;
    let path = dir.join("fused.ply");
    mvscope::io::write_ply(&path, &result.points)?;
    println!(
        "{} points written to {}",
        result.points.len(),
        path.display()
    );
    // The confidence maps follow the fusion thresholds.
    mvscope::pipeline::confidence_from_files(&scene, &dir, &params, &record.views)?;
    println!(
        "confidence maps (agreeing sources per pixel) in {}",
        dir.join("confidence").display()
    );
    Ok(())
}

pub(super) fn eval(args: EvalArgs) -> Result<()> {
    let EvalArgs {
        dir,
        gt,
        abs,
        rel,
        cloud,
        cloud_thresholds,
        write_cameras,
    } = args;
    if let Some(out) = write_cameras.as_ref().filter(|o| o.exists()) {
        bail!(
            "{} exists; give --write-cameras a new folder (nothing was evaluated or written)",
            out.display()
        );
    }
    let Some(voxel) = mvscope::eval::truth_voxel(&cloud_thresholds)
        .filter(|_| cloud_thresholds.iter().all(|t| t.is_finite() && *t > 0.0))
    else {
        bail!(
            "--cloud-thresholds {cloud_thresholds:?}: give positive distances in scene units (e.g. 0.02,0.05); nothing was evaluated"
        );
    };
    let record = RunRecord::read(&dir.join("params.toml"))?;
    let report = mvscope::eval::evaluate_run(&dir, &record.views, &gt, &abs, &rel)?;
    print!("{}", mvscope::eval::format_depth_report(&report));
    let mut json = serde_json::json!({ "depth": report });
    match seen_by_truth(&record, &dir, &gt) {
        Ok(Some(seen)) => {
            print!("{}", mvscope::eval::format_seen(&seen));
            json["seen"] = serde_json::to_value(&seen)?;
        }
        Ok(None) => {}
        Err(e) => println!("(what the sources see was not measured: {e:#})"),
    }
    match truth_fits(&record, &dir, &gt) {
        Ok((fits, offsets)) if !fits.is_empty() => {
            print!("\n{}", mvscope::eval::format_photometric_fits(&fits));
            json["photometric_fit"] = serde_json::to_value(&fits)?;
            let flagged: Vec<_> = offsets.iter().filter(|o| o.is_offset()).cloned().collect();
            print!("{}", mvscope::eval::format_camera_offsets(&flagged));
            json["camera_offsets"] = serde_json::to_value(&flagged)?;
            if !flagged.is_empty() {
                let (fixes, missed) = mvscope::eval::principal_point_corrections(&offsets);
                print!(
                    "{}",
                    mvscope::eval::format_principal_point_corrections(&fixes, missed)
                );
                json["principal_point_corrections"] =
                    serde_json::json!({ "views": fixes, "largest_miss_px": missed });
                if let Some(out) = &write_cameras {
                    write_corrected(&record, &dir, &gt, &fixes, out)?;
                    json["corrected_scene"] = serde_json::json!(out);
                }
            } else if let Some(out) = &write_cameras {
                println!(
                    "every view's camera fits its images: no corrected scene written to {}",
                    out.display()
                );
            }
        }
        Ok(_) => {
            if let Some(out) = &write_cameras {
                println!(
                    "no view has the truth and a source to check its camera against: nothing written to {}",
                    out.display()
                );
            }
        }
        Err(e) => {
            println!("\n(the truth's fit to the images was not measured: {e:#})");
            if let Some(out) = &write_cameras {
                bail!(
                    "the cameras could not be checked, so no corrected scene was written to {}: {e:#}",
                    out.display()
                );
            }
        }
    }
    // The truth cloud: the PLY given, else the truth's depth maps of the run's views
    // back-projected (the accuracy suite's), where the run has a fused cloud.
    let fused = dir.join("fused.ply");
    let truth_cloud = match cloud {
        Some(gt_cloud) => {
            let g = mvscope::io::read_ply(&gt_cloud)?;
            Some((
                gt_cloud.display().to_string(),
                g.iter().map(|p| p.position).collect::<Vec<_>>(),
            ))
        }
        None if fused.is_file() => {
            match mvscope::eval::truth_cloud_dir(
                &record.scene,
                &record.load_options(&dir),
                Some(&record.views),
                &gt,
                voxel,
            ) {
                Ok(g) => g.map(|g| {
                    (
                        format!(
                            "the truth's depth maps back-projected, one point per {voxel} cube"
                        ),
                        g,
                    )
                }),
                Err(e) => {
                    println!(
                        "\n(the cloud was not scored: the truth cloud could not be built: {e:#}; pass --cloud GT.ply)"
                    );
                    None
                }
            }
        }
        None => None,
    };
    if let Some((label, g)) = truth_cloud {
        let rec = mvscope::io::read_ply(&fused)?;
        let r: Vec<[f32; 3]> = rec.iter().map(|p| p.position).collect();
        let scores = mvscope::eval::cloud_scores(&r, &g, &cloud_thresholds);
        println!(
            "\ncloud ({} points) against {label} ({} points):",
            r.len(),
            g.len()
        );
        println!(
            "  {:>10}  {:>9}  {:>12}  {:>6}",
            "threshold", "accuracy", "completeness", "F1"
        );
        for s in &scores {
            println!(
                "  {:>10}  {:>9.3}  {:>12.3}  {:>6.3}",
                s.threshold, s.accuracy, s.completeness, s.f1
            );
        }
        json["cloud"] = serde_json::to_value(&scores)?;
        json["cloud_truth"] = serde_json::json!({ "source": label, "points": g.len() });
    }
    let path = dir.join("eval.json");
    let text = serde_json::to_string_pretty(&json)?;
    mvscope::io::write_atomic(&path, |w| std::io::Write::write_all(w, text.as_bytes()))?;
    println!("\nsaved {}", path.display());
    Ok(())
}

/// The run's maps scored on the pixels whose true point a source sees and on the others
/// ([`mvscope::eval::evaluate_seen_dir`]): the scene's cameras at the run's size.
fn seen_by_truth(
    record: &RunRecord,
    dir: &Path,
    gt: &Path,
) -> Result<Option<mvscope::eval::SeenReport>> {
    Ok(mvscope::eval::evaluate_seen_dir(
        &record.scene,
        &record.load_options(dir),
        dir,
        &record.views,
        gt,
    )?)
}

/// The options the camera check loads the run's scene with: its own size, undistorted
/// images kept in the run's folder.
fn check_options(record: &RunRecord, dir: &Path) -> LoadOptions {
    LoadOptions {
        format: record.format,
        model: record.model,
        undistort_cache: Some(dir.join("undistorted")),
        ..Default::default()
    }
}

/// `eval --write-cameras`: the run's scene with the corrections applied, as a new folder.
fn write_corrected(
    record: &RunRecord,
    dir: &Path,
    gt: &Path,
    fixes: &[mvscope::eval::PrincipalPointFix],
    out: &Path,
) -> Result<()> {
    let moved: Vec<_> = fixes
        .iter()
        .filter(|f| f.dx != 0.0 || f.dy != 0.0)
        .cloned()
        .collect();
    mvscope::export::write_corrected_scene(
        &record.scene,
        &check_options(record, dir),
        &moved,
        Some(gt),
        out,
    )
    .with_context(|| {
        format!(
            "writing the scene with corrected cameras to {}",
            out.display()
        )
    })?;
    println!(
        "wrote {} with the principal points of {} view(s) corrected (images, cams, pair.txt, gt/): run it again (`mvscope run {}`) and score against it (`--gt {}`)",
        out.display(),
        moved.len(),
        out.display(),
        out.display()
    );
    Ok(())
}

/// The evaluated views whose images and truths [`truth_fits`] holds at once (with their
/// best sources): a scene of a hundred 12 Mpx views would otherwise hold all of them, some
/// 10 GB, where the run itself held a batch. Each batch loads the scene's cameras again
/// (no pixels but its own), which costs little beside the fits.
const FIT_BATCH: usize = 2;

/// The truth's and the estimate's fit to the images (`mvscope::eval::photometric_fit`) for
/// every evaluated view with a source, at the images' full size, [`FIT_BATCH`] views (and
/// their best sources) decoded at a time.
fn truth_fits(
    record: &RunRecord,
    dir: &Path,
    gt: &Path,
) -> Result<(
    Vec<mvscope::eval::PhotometricFit>,
    Vec<mvscope::eval::CameraOffset>,
)> {
    let options = check_options(record, dir).cameras_only();
    let sizes = Scene::load(&record.scene, &options)?;
    // Each evaluated view with a truth file and a source: (view, its best source).
    let pairs: Vec<(usize, usize)> = record
        .views
        .iter()
        .filter_map(|&v| {
            let source = sizes.views.get(v)?.sources.first()?.index;
            gt.join(format!("gt/{v:08}.pfm"))
                .is_file()
                .then_some((v, source))
        })
        .collect();
    let (mut fits, mut offsets) = (Vec::new(), Vec::new());
    for batch in pairs.chunks(FIT_BATCH) {
        let mut wanted: Vec<usize> = batch.iter().flat_map(|&(v, s)| [v, s]).collect();
        wanted.sort_unstable();
        wanted.dedup();
        let mut scene = Scene::load(
            &record.scene,
            &LoadOptions {
                decode_only: Some(wanted),
                ..options.clone()
            },
        )?;
        // The fits compare grey levels: the colours (3 of a view's 7 bytes a pixel) go.
        for view in &mut scene.views {
            view.image.rgb = Vec::new();
        }
        // Depths only (no weak-texture masks), each moved rather than copied where it is
        // at its image's size already.
        let at_size = |m: mvscope::io::Map, view: usize| {
            let img = &scene.views[view].image;
            mvscope::eval::resample_nearest_owned(m.data, m.width, m.height, img.width, img.height)
        };
        for &(v, source) in batch {
            let Some(truth) = mvscope::eval::read_truth_depth(gt, v)? else {
                continue;
            };
            let truth = at_size(truth, v);
            let seen = mvscope::eval::read_truth_depth(gt, source)?.map(|t| at_size(t, source));
            let est = at_size(
                mvscope::io::read_pfm(&dir.join(format!("depth/{v:08}.pfm")))?,
                v,
            );
            fits.extend(mvscope::eval::photometric_fit(
                &scene,
                v,
                &truth,
                &est,
                seen.as_deref(),
            ));
            drop(est);
            offsets.extend(mvscope::eval::measure_camera_offset(
                &scene,
                v,
                &truth,
                seen.as_deref(),
            ));
        }
    }
    Ok((fits, offsets))
}

pub(super) fn demo(out: PathBuf, options: SyntheticOptions) -> Result<()> {
    let started = web_time::Instant::now();
    let scene = synthetic::generate(&options)?;
    synthetic::write_demo(&scene, &out)
        .with_context(|| format!("writing the demo scene to {}", out.display()))?;
    println!(
        "wrote {} views of {}x{} (seed {}) to {} in {:.1} s",
        options.views,
        options.width,
        options.height,
        options.seed,
        out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

pub(super) fn info(
    path: PathBuf,
    load: LoadArgs,
    device_memory: Option<f64>,
    method: Method,
) -> Result<()> {
    // Sizes and sources only: nothing is decoded.
    let mut options = load.options()?;
    options.decode_only = Some(Vec::new());
    let scene = Scene::load(&path, &options)?;
    let format = scene.format.map(|f| f.to_string()).unwrap_or_default();
    println!("{} — {format}, {} views", path.display(), scene.views.len());
    if scene.format == Some(SceneFormat::Colmap) {
        print_colmap_cameras(&path, load.model);
    }
    let models = mvscope::scene::colmap::list_models(&path);
    if scene.format == Some(SceneFormat::Colmap) && models.len() > 1 {
        println!(
            "COLMAP models under sparse/: {} (this is {}; choose another with --model N)",
            models
                .iter()
                .map(u32::to_string)
                .collect::<Vec<_>>()
                .join(", "),
            load.model.unwrap_or(models[0])
        );
    }
    println!(
        "{:>4}  {:<20} {:>11}  {:>23}  sources (index:score)",
        "#", "view", "size", "depth range"
    );
    for (i, v) in scene.views.iter().enumerate() {
        let sources: Vec<String> = v
            .sources
            .iter()
            .map(|s| format!("{}:{:.3}", s.index, s.score))
            .collect();
        println!(
            "{i:>4}  {:<20} {:>11}  [{:>9.4}, {:>9.4}]  {}",
            v.name,
            format!("{}x{}", v.image.width, v.image.height),
            v.depth_range.min,
            v.depth_range.max,
            sources.join(" ")
        );
    }
    for w in &scene.warnings {
        println!("warning: {w}");
    }
    // What a run at this size holds on the device with every view at once (default
    // parameters; the viewer's checkpoints come on top), and the verdict on this adapter.
    let params = mvscope::acmm::Params::default();
    let plan = mvscope::acmm::memory::MemoryPlan::for_scene(&scene, &params, method);
    println!(
        "device memory, {method} (default parameters), every view at once: peak {:.1} MiB",
        plan.peak() as f64 / (1u64 << 20) as f64
    );
    print!("{}", plan.describe());
    println!("{}", fit_verdict(&scene, &params, method, device_memory)?);
    Ok(())
}

/// The last line of `mvscope info`: whether a run of `method` fits this device, and how.
pub(super) fn fit_verdict(
    scene: &Scene,
    params: &mvscope::acmm::Params,
    method: Method,
    device_memory: Option<f64>,
) -> Result<String> {
    let ctx = mvscope::gpu::GpuContext::new()?;
    let options = mvscope::session::SessionOptions {
        device_budget: device_memory.map(mib_bytes),
        ..Default::default()
    };
    let mib = |b: u64| {
        let m = b as f64 / (1u64 << 20) as f64;
        if m < 100.0 {
            format!("{m:.1} MiB")
        } else {
            format!("{m:.0} MiB")
        }
    };
    let budget = |b: Option<u64>| match b {
        Some(b) => mib(b),
        None => "an unstated amount (pass --device-memory MIB)".to_string(),
    };
    Ok(
        match mvscope::session::Session::plan(&ctx, scene, params, method, &options) {
            Ok(plan) => format!(
                "fits on {}: {} batch{} of up to {} view{}, peak {} of {}",
                ctx.adapter_name(),
                plan.batches.len(),
                if plan.batches.len() == 1 { "" } else { "es" },
                plan.largest_batch(),
                if plan.largest_batch() == 1 { "" } else { "s" },
                mib(plan.peak),
                budget(plan.budget)
            ),
            Err(e) => {
                let why = e.to_string();
                let why = why
                    .strip_prefix("the run does not fit this device: ")
                    .unwrap_or(&why);
                format!("does not fit on {}: {why}", ctx.adapter_name())
            }
        },
    )
}

/// Each camera of the COLMAP model read: its model, its size, how many images use it, and
/// whether mvscope undistorts it on load.
pub(super) fn print_colmap_cameras(root: &Path, model: Option<u32>) {
    use mvscope::scene::colmap;
    let dir = match model {
        Some(n) => Some(root.join("sparse").join(n.to_string())),
        None => colmap::find_model(root),
    };
    let Some(Ok(m)) = dir.map(|d| colmap::read_model(&d)) else {
        return;
    };
    for camera in m.cameras.values() {
        let users = m
            .images
            .values()
            .filter(|i| i.camera_id == camera.id)
            .count();
        let how = match colmap::camera_lens(camera) {
            Ok((_, Some(_))) => "undistorted on load to PINHOLE".to_string(),
            Ok((_, None)) => "pinhole, read as it is".to_string(),
            Err(e) => format!("unusable: {e}"),
        };
        println!(
            "camera {}: {} {}x{}, {users} image(s), {how}",
            camera.id, camera.model, camera.width, camera.height
        );
    }
}

pub(super) fn convert(path: PathBuf, to: ExportKind, out: PathBuf, load: LoadArgs) -> Result<()> {
    let scene = Scene::load(&path, &load.options()?)?;
    match to {
        ExportKind::Acmm => mvscope::export::convert_to_acmm(&scene, &out)?,
        ExportKind::Colmap => mvscope::export::convert_to_colmap(&scene, &out)?,
    }
    println!(
        "wrote {} views of {} as {:?} to {}",
        scene.views.len(),
        path.display(),
        to,
        out.display()
    );
    Ok(())
}

pub(super) fn gpu() -> Result<()> {
    let ctx = GpuContext::new()?;
    println!("adapter: {}", ctx.describe_with_caveat());
    println!(
        "timestamp queries: {}",
        ctx.features.contains(wgpu::Features::TIMESTAMP_QUERY)
    );
    let l = &ctx.limits;
    println!(
        "limits: storage binding {} MiB, buffer {} MiB, {} storage buffers per stage, texture 2D {} px, workgroup {} invocations",
        l.max_storage_buffer_binding_size >> 20,
        l.max_buffer_size >> 20,
        l.max_storage_buffers_per_shader_stage,
        l.max_texture_dimension_2d,
        l.max_compute_invocations_per_workgroup
    );
    Ok(())
}
