//! `mvscope view`: the viewer, or a headless screenshot of it.

use super::*;

pub(super) struct ViewArgs {
    pub(super) scene: Option<PathBuf>,
    pub(super) method: Method,
    pub(super) load: Result<LoadOptions>,
    pub(super) params: Option<PathBuf>,
    pub(super) sets: Vec<String>,
    pub(super) demo_size: Option<String>,
    pub(super) screenshot: Option<PathBuf>,
    pub(super) steps: usize,
    pub(super) map: Option<String>,
    pub(super) size: String,
    pub(super) tour: bool,
    /// `--device-memory`, MiB.
    pub(super) device_memory: Option<f64>,
}

impl ViewArgs {
    pub(super) fn demo() -> ViewArgs {
        ViewArgs {
            scene: None,
            method: Method::Acmm,
            load: Ok(LoadOptions::default()),
            params: None,
            sets: Vec::new(),
            demo_size: None,
            screenshot: None,
            steps: 0,
            map: None,
            size: "1280x800".into(),
            tour: false,
            device_memory: None,
        }
    }
}

/// "640x480" -> (640, 480).
pub(super) fn parse_size(flag: &str, text: &str) -> Result<(u32, u32)> {
    let parsed = text
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match parsed {
        Some((w, h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => bail!("{flag}: '{text}' is not a size like 640x480"),
    }
}

pub(super) fn view(args: ViewArgs) -> Result<()> {
    let params = load_params(args.method, args.params.as_deref(), &args.sets)?;
    let options = mvscope::viewer::ViewerOptions {
        scene: args.scene,
        load: args.load?,
        params: Some(params),
        method: args.method,
        demo_size: args
            .demo_size
            .as_deref()
            .map(|s| parse_size("--demo-size", s))
            .transpose()?,
        demo_views: None,
        device_budget: args.device_memory.map(mib_bytes),
    };
    let Some(out) = args.screenshot else {
        if args.map.is_some() || args.steps > 0 || args.tour {
            bail!("--steps, --map and --tour go with --screenshot");
        }
        return mvscope::viewer::run_native(options);
    };
    let (map, cloud, compare) = match args.map.as_deref() {
        None => (None, false, false),
        Some("cloud") => (None, true, false),
        Some("compare") => (None, false, true),
        Some(name) => match mvscope::viewer::maps::MapKind::from_name(name) {
            Some(k) => (Some(k), false, false),
            None => bail!(
                "--map: unknown map '{name}'; one of {}, cloud or compare",
                mvscope::viewer::maps::MapKind::ALL
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
    };
    let shot = mvscope::viewer::ScreenshotOptions {
        steps: args.steps,
        map,
        cloud,
        size: parse_size("--size", &args.size)?,
        tour: args.tour,
        compare,
        // A test hook: read-backs held back, as on a busy device.
        hold_readbacks: std::env::var("MVSCOPE_HOLD_READBACKS")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(0),
        ..Default::default()
    };
    mvscope::viewer::screenshot(options, &shot, &out)?;
    println!("wrote {}", out.display());
    Ok(())
}
