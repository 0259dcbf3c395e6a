//! The map view passes (src/viewer/maps.rs, shaders/map_view.wgsl) against their CPU
//! reference, on whatever adapter is present (lavapipe in CI), and the pure helpers.

use mvscope::acmm::problem::{ViewState, Winner};
use mvscope::gpu::GpuContext;
use mvscope::image::Image;
use mvscope::rng::{Stream, pcg_hash};
use mvscope::session::{GpuMaps, ViewMaps};
use mvscope::viewer::maps::{
    Colormap, MapKind, MapRenderer, MapSources, MapTarget, WINNER_COLORS, colorize_value,
    describe_value, extract_value, natural_range, pack_rgba, percentile_range, winner_code_color,
    winner_color,
};

/// Odd sizes, so the 8x8 workgroups overhang both edges.
const W: u32 = 37;
const H: u32 = 23;
const NSRC: usize = 5;

/// A random view: some pixels without depth (0 or negative), every winner code including
/// initial (254), none (255) and an unknown one, the replaced bit, both extra maps, a colour
/// image and a ground truth with unknown (0) pixels.
struct Fixture {
    maps: ViewMaps,
    image: Vec<u32>,
    gt: Vec<f32>,
}

fn fixture(width: u32, height: u32, nsrc: usize) -> Fixture {
    let n = (width * height) as usize;
    let mut rng = Stream::new(&[0x6d61_7073, width, height, nsrc as u32]);
    let mut word = {
        let mut k = 0u32;
        move || {
            k += 1;
            pcg_hash(k ^ 0x5bd1_e995)
        }
    };
    let mut state = ViewState::garbage(width, height, nsrc);
    let codes: Vec<u32> = (0..=Winner::PRIOR_UNSEEN)
        .chain([Winner::INITIAL, 255, 100])
        .collect();
    let mut gt = Vec::with_capacity(n);
    let mut image = Vec::with_capacity(n);
    let mut difference = Vec::with_capacity(n);
    let mut reprojection = Vec::with_capacity(n);
    let mut prior = Vec::with_capacity(n);
    for i in 0..n {
        let nx = rng.next_f32() * 2.0 - 1.0;
        let ny = rng.next_f32() * 2.0 - 1.0;
        let nz = -(rng.next_f32() * 0.9 + 0.1);
        let kind = rng.next_f32();
        let depth = if kind < 0.15 {
            0.0
        } else if kind < 0.2 {
            -rng.next_f32()
        } else {
            0.5 + 9.5 * rng.next_f32()
        };
        state.plane[i] = [nx, ny, nz, depth];
        state.cost[i] = 2.0 * rng.next_f32();
        // Mostly bits of real sources, sometimes stray high bits too.
        state.selected[i] = if i % 7 == 0 {
            word()
        } else {
            word() & ((1 << nsrc) - 1)
        };
        for j in 0..nsrc {
            state.weights[i * nsrc + j] = rng.next_f32();
        }
        let code = codes[i % codes.len()];
        let v_t = word() % 256;
        let replaced = u32::from(rng.next_f32() < 0.3);
        let prior_bit = u32::from(rng.next_f32() < 0.4);
        state.aux[i] = code | v_t << 8 | replaced << 16 | prior_bit << 17;
        // A prior near the plane, or none for each of the three reasons.
        let which = rng.next_f32();
        let prior_depth = match which {
            w if w < 0.1 => 0.0,
            w if w < 0.15 => -1.0,
            w if w < 0.2 => -2.0,
            _ => depth.abs() * (0.8 + 0.4 * rng.next_f32()) + 0.1,
        };
        let (px, py) = (nx + 0.2 * rng.next_f32(), ny - 0.2 * rng.next_f32());
        let len = (px * px + py * py + nz * nz).sqrt();
        prior.push([px / len, py / len, nz / len, prior_depth]);
        difference.push(rng.next_f32() * 2.0 - 1.0);
        reprojection.push(rng.next_f32() * 5.0);
        gt.push(if rng.next_f32() < 0.3 {
            0.0
        } else {
            depth.abs() * (0.9 + 0.2 * rng.next_f32()) + 0.25
        });
        image.push(word() | 0xff00_0000);
    }
    Fixture {
        maps: ViewMaps {
            level: 0,
            state,
            restorer_difference: Some(difference),
            replaced: None,
            reprojection_error: Some(reprojection),
            prior: Some(prior),
            anchors: None,
            prior_terms: Some(mvscope::acmm::planar::PriorTerms::new(
                &mvscope::acmm::Params::default(),
                0.5,
                10.0,
            )),
            support_points: None,
        },
        image,
        gt,
    }
}

/// The maps as `Session::gpu_maps` uploads them.
fn upload(ctx: &GpuContext, maps: &ViewMaps) -> GpuMaps {
    GpuMaps::upload(ctx, maps)
}

fn context() -> GpuContext {
    let ctx = GpuContext::new().expect("a GPU adapter (install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());
    ctx
}

/// Sources a kind is tried with: in range, the last, just out of range, far out.
fn sources_for(kind: MapKind, nsrc: usize) -> Vec<u32> {
    if kind.uses_source() {
        vec![
            0,
            3.min(nsrc as u32),
            nsrc.saturating_sub(1) as u32,
            nsrc as u32,
            40,
        ]
    } else {
        vec![0]
    }
}

/// Distance in units in the last place between two finite f32 of the same sign.
fn ulps(a: f32, b: f32) -> u32 {
    (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs() as u32
}

/// Runs pass 1 into a target pre-filled with NaN (so a pixel the shader skips shows).
fn run_extract(
    ctx: &GpuContext,
    renderer: &MapRenderer,
    sources: &MapSources,
    kind: MapKind,
    source: u32,
) -> (MapTarget, Vec<[f32; 4]>) {
    let target = MapTarget::new(ctx, sources.maps.width, sources.maps.height);
    let n = (target.width * target.height) as usize;
    ctx.queue.write_buffer(
        &target.values,
        0,
        bytemuck::cast_slice(&vec![[f32::NAN; 4]; n]),
    );
    renderer
        .extract(ctx, sources, kind, source, &target)
        .expect("extract runs");
    let values = renderer
        .read_values(ctx, &target)
        .expect("values read back");
    assert_eq!(values.len(), n);
    (target, values)
}

fn check_extract(ctx: &GpuContext, renderer: &MapRenderer, fx: &Fixture, with_gt: bool) {
    let gpu_maps = upload(ctx, &fx.maps);
    let image = ctx.storage_buffer("image", &fx.image);
    let gt_buffer = ctx.storage_buffer("gt", &fx.gt);
    let sources = MapSources {
        maps: &gpu_maps,
        image: &image,
        ground_truth: with_gt.then_some(&gt_buffer),
        // The same floats stand for the agreeing sources of the confidence map and for the
        // distance to texture.
        confidence: with_gt.then_some(&gt_buffer),
        texture_reach: with_gt.then_some(&gt_buffer),
    };
    let gt = with_gt.then_some(fx.gt.as_slice());
    let nsrc = fx.maps.state.num_sources;
    for kind in MapKind::ALL {
        for source in sources_for(kind, nsrc) {
            let (_, values) = run_extract(ctx, renderer, &sources, kind, source);
            for (i, got) in values.iter().enumerate() {
                let want = extract_value(kind, source, &fx.maps, &fx.image, gt, i);
                let same = got
                    .iter()
                    .zip(&want)
                    .enumerate()
                    .all(|(c, (g, w))| match (kind, c) {
                        // WGSL bounds its division to 2.5 ULP and its exp to a few ULP
                        // more than the argument's size; everything else is exact.
                        (MapKind::DepthError, 0) => ulps(*g, *w) <= 2,
                        (MapKind::PriorWeight, 0) => (g - w).abs() <= 1e-5 * w.abs(),
                        _ => g.to_bits() == w.to_bits(),
                    });
                assert!(
                    same,
                    "{} source {source} gt {with_gt} nsrc {nsrc}: pixel {i} GPU {got:?} CPU {want:?}",
                    kind.name()
                );
            }
        }
    }
}

#[test]
fn extract_matches_cpu_reference_bit_for_bit() {
    let ctx = context();
    let renderer = MapRenderer::new(&ctx).expect("map view pipelines");
    let fx = fixture(W, H, NSRC);
    check_extract(&ctx, &renderer, &fx, true);
    check_extract(&ctx, &renderer, &fx, false);
    // A view without sources, its weights buffer a single 0.0, no extra maps on the CPU side.
    let mut empty = fixture(W, H, 0);
    empty.maps.restorer_difference = None;
    empty.maps.reprojection_error = None;
    check_extract(&ctx, &renderer, &empty, true);
}

/// The reference itself, against facts of the fixture, so the GPU cannot agree with a wrong
/// reference.
#[test]
fn extract_reference_means_what_it_says() {
    let fx = fixture(W, H, NSRC);
    let st = &fx.maps.state;
    let value = |kind, source, i| extract_value(kind, source, &fx.maps, &fx.image, Some(&fx.gt), i);
    let (mut initial, mut none, mut no_depth, mut depth_error) = (0, 0, 0, 0);
    for i in 0..st.plane.len() {
        let d = st.plane[i][3];
        assert_eq!(
            value(MapKind::Depth, 0, i),
            [d, f32::from(d > 0.0), 0.0, 0.0]
        );
        assert_eq!(value(MapKind::Cost, 0, i)[1], f32::from(d > 0.0));
        // The confidence input passes through where there is an estimate, and not without
        // one (nor without an input).
        assert_eq!(
            value(MapKind::Confidence, 0, i)[..2],
            [if d > 0.0 { fx.gt[i] } else { 0.0 }, f32::from(d > 0.0)]
        );
        assert_eq!(
            extract_value(MapKind::Confidence, 0, &fx.maps, &fx.image, None, i)[1],
            0.0
        );
        no_depth += usize::from(d <= 0.0);
        let normal = value(MapKind::Normal, 0, i);
        assert_eq!(&normal[..3], &st.plane[i][..3]);
        let rgb = value(MapKind::Image, 0, i);
        let c = fx.image[i];
        assert!((rgb[0] * 255.0 - (c & 0xff) as f32).abs() < 1e-3);
        assert!((rgb[2] * 255.0 - ((c >> 16) & 0xff) as f32).abs() < 1e-3);
        assert_eq!(rgb[3], 1.0);
        let bits = st.selected[i];
        assert_eq!(
            value(MapKind::SelectedCount, 0, i)[0],
            bits.count_ones() as f32
        );
        for j in 0..NSRC as u32 {
            assert_eq!(
                value(MapKind::SelectedBit, j, i)[0],
                ((bits >> j) & 1) as f32
            );
            assert_eq!(
                value(MapKind::Weight, j, i)[0],
                st.weights[i * NSRC + j as usize]
            );
        }
        assert_eq!(value(MapKind::SelectedBit, NSRC as u32, i)[1], 0.0);
        assert_eq!(value(MapKind::Weight, NSRC as u32, i)[1], 0.0);
        let winner = value(MapKind::Winner, 0, i);
        match st.aux[i] & 0xff {
            Winner::INITIAL => {
                initial += 1;
                assert_eq!(winner, [16.0, 1.0, 0.0, 0.0]);
            }
            code @ 0..=Winner::PRIOR_UNSEEN => {
                assert_eq!(winner, [code as f32, 1.0, 0.0, 0.0])
            }
            _ => {
                none += 1;
                assert_eq!(winner[1], 0.0);
            }
        }
        assert_eq!(
            value(MapKind::Replaced, 0, i)[0],
            ((st.aux[i] >> 16) & 1) as f32
        );
        let g = fx.gt[i];
        let e = value(MapKind::DepthError, 0, i);
        if g > 0.0 && d > 0.0 {
            depth_error += 1;
            assert!((e[0] - (d - g).abs() / g).abs() <= 1e-6 * e[0].max(1.0));
            assert_eq!(e[1], 1.0);
        } else {
            assert_eq!(e[1], 0.0);
        }
        let diff = fx.maps.restorer_difference.as_ref().unwrap()[i];
        assert_eq!(
            value(MapKind::RestorerDifference, 0, i),
            [diff, 1.0, 0.0, 0.0]
        );
    }
    // The fixture exercises what it claims to.
    assert!(initial > 0 && none > 0 && no_depth > 0 && depth_error > 0);
}

fn ranges(kind: MapKind, values: &[[f32; 4]], nsrc: usize) -> Vec<(f32, f32)> {
    let mut out = vec![(1.0, 1.0), (2.0, -1.0)];
    if let Some(r) = percentile_range(kind, values, 2.0, 98.0) {
        out.push(r);
        // A narrow range: most values clamp to one end or the other.
        let mid = 0.5 * (r.0 + r.1);
        out.push((mid - 0.05 * (r.1 - r.0), mid + 0.05 * (r.1 - r.0)));
    }
    out.extend(natural_range(kind, nsrc));
    out
}

#[test]
fn colorize_matches_cpu_reference_within_one_lsb() {
    let ctx = context();
    let renderer = MapRenderer::new(&ctx).expect("map view pipelines");
    let fx = fixture(W, H, NSRC);
    let gpu_maps = upload(&ctx, &fx.maps);
    let image = ctx.storage_buffer("image", &fx.image);
    let gt = ctx.storage_buffer("gt", &fx.gt);
    let sources = MapSources {
        maps: &gpu_maps,
        image: &image,
        ground_truth: Some(&gt),
        confidence: None,
        texture_reach: None,
    };
    let mut distinct = std::collections::HashSet::new();
    for kind in MapKind::ALL {
        let source = if kind.uses_source() { 2 } else { 0 };
        let (_, values) = run_extract(&ctx, &renderer, &sources, kind, source);
        for colormap in Colormap::ALL {
            for (lo, hi) in ranges(kind, &values, NSRC) {
                // A fresh target: its texture starts transparent black, so a pixel the shader
                // skips fails the alpha check.
                let (target, values) = run_extract(&ctx, &renderer, &sources, kind, source);
                renderer
                    .colorize(&ctx, &target, kind, colormap, lo, hi)
                    .expect("colorize runs");
                let texels = renderer.read_texture(&ctx, &target).expect("texture reads");
                assert_eq!(texels.len(), values.len());
                for (i, (got, v)) in texels.iter().zip(&values).enumerate() {
                    let want = colorize_value(kind, *v, colormap, lo, hi);
                    let close = got.iter().zip(&want).all(|(g, w)| g.abs_diff(*w) <= 1);
                    assert!(
                        close && got[3] == 255,
                        "{} {} [{lo}, {hi}] pixel {i} value {v:?}: GPU {got:?} CPU {want:?}",
                        kind.name(),
                        colormap.name()
                    );
                    distinct.insert(want);
                }
            }
        }
    }
    // Real colours came out, not one flat fill.
    assert!(distinct.len() > 500, "{} distinct colours", distinct.len());
}

#[test]
fn colorize_reference_rules() {
    let grey = [31, 31, 31, 255];
    // Invalid pixels are dark grey whatever the kind.
    assert_eq!(
        colorize_value(
            MapKind::Depth,
            [5.0, 0.0, 0.0, 0.0],
            Colormap::Turbo,
            0.0,
            10.0
        ),
        grey
    );
    assert_eq!(
        colorize_value(
            MapKind::Normal,
            [0.0, 0.0, -1.0, 0.0],
            Colormap::Turbo,
            0.0,
            1.0
        ),
        grey
    );
    // Normal: x right, y down, z into the scene, shown as (x, -y, -z) * 0.5 + 0.5.
    assert_eq!(
        colorize_value(
            MapKind::Normal,
            [0.0, 0.0, -1.0, 1.0],
            Colormap::Turbo,
            0.0,
            1.0
        ),
        [128, 128, 255, 255]
    );
    assert_eq!(
        colorize_value(
            MapKind::Image,
            [1.0, 0.5, 0.0, 1.0],
            Colormap::Grey,
            0.0,
            1.0
        ),
        [255, 128, 0, 255]
    );
    // Scalars: (x - lo) / (hi - lo), clamped; an empty range gives t = 0.
    let grey_at = |x: f32, lo: f32, hi: f32| {
        colorize_value(MapKind::Cost, [x, 1.0, 0.0, 0.0], Colormap::Grey, lo, hi)[0]
    };
    assert_eq!(grey_at(3.0, 2.0, 4.0), 128);
    assert_eq!(grey_at(9.0, 2.0, 4.0), 255);
    assert_eq!(grey_at(-9.0, 2.0, 4.0), 0);
    assert_eq!(grey_at(9.0, 4.0, 4.0), 0);
    assert_eq!(grey_at(9.0, 5.0, 4.0), 0);
}

/// The winner map is categories: each code has its own colour whatever the colormap and
/// range, every pair far enough apart to tell by eye (the turbo ramp over the 17 values it
/// replaces put "refined (d, n_pert)", "refined (d_pert, n_pert)" and "its prior plane",
/// codes 13, 14 and 15, in near-identical dark reds), and none near the invalid grey.
#[test]
fn winner_colours_are_categories_far_apart() {
    // CIE76 colour difference: Euclidean distance in CIELAB (D65) from sRGB bytes.
    let lab = |c: [u8; 3]| {
        let [r, g, b] = c.map(|u| {
            let u = u as f64 / 255.0;
            if u <= 0.04045 {
                u / 12.92
            } else {
                ((u + 0.055) / 1.055).powf(2.4)
            }
        });
        let x = (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047;
        let y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
        let z = (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883;
        let f = |q: f64| {
            if q > 0.008856 {
                q.cbrt()
            } else {
                7.787 * q + 16.0 / 116.0
            }
        };
        let (fx, fy, fz) = (f(x), f(y), f(z));
        [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
    };
    let delta_e = |a: [u8; 3], b: [u8; 3]| {
        let (a, b) = (lab(a), lab(b));
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    // Measured: the nearest pair, "propagated (up strip)" and "kept", is 23.2 apart (a
    // just-noticeable difference is about 2.3); the nearest to the invalid grey, 29.0.
    for (i, a) in WINNER_COLORS.iter().enumerate() {
        assert!(delta_e(*a, [31, 31, 31]) >= 20.0, "code {i} {a:?}");
        for (j, b) in WINNER_COLORS.iter().enumerate().skip(i + 1) {
            assert!(delta_e(*a, *b) >= 20.0, "codes {i} {a:?} and {j} {b:?}");
        }
    }
    // The ramp it replaces: codes 13 and 14 are 11.2 apart, 14 and 15 13.5.
    let turbo = |v: f32| Colormap::Turbo.color(v / 16.0);
    assert!(delta_e(turbo(13.0), turbo(14.0)) < 15.0);
    assert!(delta_e(turbo(14.0), turbo(15.0)) < 15.0);
    for (v, colour) in WINNER_COLORS.iter().enumerate() {
        let value = [v as f32, 1.0, 0.0, 0.0];
        let want = winner_color(v as f32);
        assert_eq!(want, *colour);
        for colormap in Colormap::ALL {
            for (lo, hi) in [(0.0, 16.0), (3.0, 9.0)] {
                let got = colorize_value(MapKind::Winner, value, colormap, lo, hi);
                assert_eq!(got, [want[0], want[1], want[2], 255], "code {v}");
            }
        }
    }
    // A pixel without a winner is the invalid grey.
    assert_eq!(
        colorize_value(
            MapKind::Winner,
            [3.0, 0.0, 0.0, 0.0],
            Colormap::Turbo,
            0.0,
            16.0
        ),
        [31, 31, 31, 255]
    );
}

/// Python's `WINNER_COLORS` / `winner_rgb` take a raw code's colour from
/// `winner_code_color`: it must be the colour the map pass draws for a pixel with that code,
/// every code the fixture holds (0..=15, initial, none and an unknown one) included.
#[test]
fn a_raw_winner_codes_colour_is_the_one_the_map_draws() {
    let fx = fixture(W, H, NSRC);
    let mut seen = std::collections::BTreeSet::new();
    for (i, aux) in fx.maps.state.aux.iter().enumerate() {
        let code = aux & 0xff;
        let value = extract_value(MapKind::Winner, 0, &fx.maps, &fx.image, None, i);
        let [r, g, b, _] = colorize_value(MapKind::Winner, value, Colormap::Viridis, 2.0, 5.0);
        assert_eq!(winner_code_color(code), [r, g, b], "pixel {i}, code {code}");
        seen.insert(code);
    }
    assert_eq!(seen.len(), 19, "the fixture holds every code: {seen:?}");
    assert_eq!(winner_code_color(Winner::PRIOR_UNSEEN), WINNER_COLORS[15]);
    assert_eq!(winner_code_color(Winner::INITIAL), WINNER_COLORS[16]);
    assert_eq!(winner_code_color(255), [31, 31, 31]);
}

#[test]
fn colormap_endpoints() {
    // Turbo: dark blue to dark red.
    let [r, g, b] = Colormap::Turbo.color(0.0);
    assert!(
        b > r && b > g && b < 90 && r < 70,
        "turbo(0) = {:?}",
        [r, g, b]
    );
    let [r, g, b] = Colormap::Turbo.color(1.0);
    assert!(
        r > 100 && r < 150 && g < 20 && b < 20,
        "turbo(1) = {:?}",
        [r, g, b]
    );
    // Its middle is green-yellow and bright.
    let [r, g, b] = Colormap::Turbo.color(0.5);
    assert!(g > 200 && g > r && g > b, "turbo(0.5) = {:?}", [r, g, b]);
    // Viridis: purple to yellow.
    let [r, g, b] = Colormap::Viridis.color(0.0);
    assert!(
        r > g && b > g && b > 70 && g < 10,
        "viridis(0) = {:?}",
        [r, g, b]
    );
    let [r, g, b] = Colormap::Viridis.color(1.0);
    assert!(r > 240 && g > 220 && b < 50, "viridis(1) = {:?}", [r, g, b]);
    assert_eq!(Colormap::Grey.color(0.0), [0, 0, 0]);
    assert_eq!(Colormap::Grey.color(1.0), [255, 255, 255]);
    assert_eq!(Colormap::Grey.color(0.5), [128, 128, 128]);
    for c in Colormap::ALL {
        assert_eq!(c.color(-3.0), c.color(0.0));
        assert_eq!(c.color(7.0), c.color(1.0));
        assert_eq!(c.color(f32::NAN), c.color(0.0));
        // Continuous: neighbouring t are close.
        for k in 0..1000 {
            let (a, b) = (c.color(k as f32 / 1000.0), c.color((k + 1) as f32 / 1000.0));
            assert!(
                a.iter().zip(&b).all(|(x, y)| x.abs_diff(*y) <= 3),
                "{} at {k}",
                c.name()
            );
        }
    }
}

#[test]
fn names_round_trip() {
    let mut names = std::collections::HashSet::new();
    for kind in MapKind::ALL {
        assert_eq!(MapKind::from_name(kind.name()), Some(kind));
        assert!(names.insert(kind.name()), "duplicate name {}", kind.name());
        assert!(!kind.title().is_empty());
    }
    assert_eq!(
        MapKind::from_name("selected-count"),
        Some(MapKind::SelectedCount)
    );
    assert_eq!(MapKind::from_name("depth-error"), Some(MapKind::DepthError));
    assert_eq!(MapKind::from_name("Depth"), None);
    assert_eq!(MapKind::from_name("bogus"), None);
    for c in Colormap::ALL {
        assert_eq!(Colormap::from_name(c.name()), Some(c));
    }
    assert_eq!(MapKind::default(), MapKind::Depth);
    assert_eq!(Colormap::default(), Colormap::Turbo);
    let sourced: Vec<_> = MapKind::ALL
        .into_iter()
        .filter(|k| k.uses_source())
        .collect();
    assert_eq!(sourced, [MapKind::SelectedBit, MapKind::Weight]);
    let colour: Vec<_> = MapKind::ALL.into_iter().filter(|k| k.is_color()).collect();
    assert_eq!(
        colour,
        [
            MapKind::Image,
            MapKind::Normal,
            MapKind::PriorNormal,
            MapKind::SupportPoints,
            MapKind::Triangulation
        ]
    );
}

#[test]
fn percentile_range_uses_valid_values_only() {
    let mut values: Vec<[f32; 4]> = (0..=100).rev().map(|v| [v as f32, 1.0, 0.0, 0.0]).collect();
    // Invalid and non-finite values do not count.
    values.push([1e9, 0.0, 0.0, 0.0]);
    values.push([-1e9, 0.0, 0.0, 0.0]);
    values.push([f32::NAN, 1.0, 0.0, 0.0]);
    values.push([f32::INFINITY, 1.0, 0.0, 0.0]);
    assert_eq!(
        percentile_range(MapKind::Depth, &values, 2.0, 98.0),
        Some((2.0, 98.0))
    );
    assert_eq!(
        percentile_range(MapKind::Depth, &values, 0.0, 100.0),
        Some((0.0, 100.0))
    );
    assert_eq!(
        percentile_range(MapKind::Cost, &values, -5.0, 500.0),
        Some((0.0, 100.0))
    );
    // Linear between ranks.
    let two = [[0.0, 1.0, 0.0, 0.0], [10.0, 1.0, 0.0, 0.0]];
    assert_eq!(
        percentile_range(MapKind::Depth, &two, 25.0, 50.0),
        Some((2.5, 5.0))
    );
    let one = [[4.0, 1.0, 0.0, 0.0]];
    assert_eq!(
        percentile_range(MapKind::Depth, &one, 2.0, 98.0),
        Some((4.0, 4.0))
    );
    let invalid = [[4.0, 0.0, 0.0, 0.0]];
    assert_eq!(percentile_range(MapKind::Depth, &invalid, 2.0, 98.0), None);
    assert_eq!(percentile_range(MapKind::Depth, &[], 2.0, 98.0), None);
    assert_eq!(percentile_range(MapKind::Normal, &values, 2.0, 98.0), None);
    assert_eq!(percentile_range(MapKind::Image, &values, 2.0, 98.0), None);
}

#[test]
fn natural_ranges_and_descriptions() {
    assert_eq!(natural_range(MapKind::SelectedBit, 5), Some((0.0, 1.0)));
    assert_eq!(natural_range(MapKind::Replaced, 5), Some((0.0, 1.0)));
    assert_eq!(natural_range(MapKind::SelectedCount, 7), Some((0.0, 7.0)));
    assert_eq!(natural_range(MapKind::Winner, 5), Some((0.0, 16.0)));
    assert_eq!(natural_range(MapKind::Cost, 5), Some((0.0, 2.0)));
    assert_eq!(natural_range(MapKind::Anchors, 5), Some((0.0, 8.0)));
    assert_eq!(natural_range(MapKind::Depth, 5), None);
    let valid = |x: f32| [x, 1.0, 0.0, 0.0];
    assert_eq!(
        describe_value(MapKind::Depth, valid(3.41234)),
        "depth 3.412"
    );
    assert_eq!(describe_value(MapKind::Depth, [0.0; 4]), "no estimate");
    assert_eq!(
        describe_value(MapKind::Normal, [0.12, -0.4, -0.91, 1.0]),
        "normal (0.12, -0.40, -0.91)"
    );
    assert_eq!(
        describe_value(MapKind::Winner, valid(13.0)),
        "winner: refined (d, n_pert)"
    );
    assert_eq!(describe_value(MapKind::Winner, valid(8.0)), "winner: kept");
    assert_eq!(
        describe_value(MapKind::Winner, valid(2.0)),
        "winner: propagated (down V)"
    );
    assert_eq!(
        describe_value(MapKind::Winner, valid(15.0)),
        "winner: its prior plane (no source sees it)"
    );
    assert_eq!(
        describe_value(MapKind::Winner, valid(16.0)),
        "winner: initial (random plane)"
    );
    assert_eq!(describe_value(MapKind::Winner, [0.0; 4]), "winner: none");
    assert_eq!(describe_value(MapKind::SelectedBit, valid(1.0)), "selected");
    assert_eq!(
        describe_value(MapKind::Image, [1.0, 0.5, 0.0, 1.0]),
        "rgb (255, 128, 0)"
    );
    assert_eq!(
        describe_value(MapKind::DepthError, valid(0.0123)),
        "depth error 1.23 %"
    );
}

#[test]
fn pack_rgba_layout() {
    let image = Image::from_rgb(2, 1, vec![[1, 2, 3], [255, 0, 128]]);
    assert_eq!(pack_rgba(&image), [0xff03_0201, 0xff80_00ff]);
}

#[test]
fn mismatched_target_is_an_error() {
    let ctx = context();
    let renderer = MapRenderer::new(&ctx).expect("map view pipelines");
    let fx = fixture(W, H, NSRC);
    let gpu_maps = upload(&ctx, &fx.maps);
    let image = ctx.storage_buffer("image", &fx.image);
    let sources = MapSources {
        maps: &gpu_maps,
        image: &image,
        ground_truth: None,
        confidence: None,
        texture_reach: None,
    };
    let target = MapTarget::new(&ctx, W + 1, H);
    let err = renderer
        .extract(&ctx, &sources, MapKind::Depth, 0, &target)
        .expect_err("a target of another size");
    assert!(err.to_string().contains("38x23"), "{err}");
    // An image buffer too small for the maps.
    let small = ctx.storage_buffer("image", &fx.image[..10]);
    let sources = MapSources {
        image: &small,
        ..sources
    };
    let target = MapTarget::new(&ctx, W, H);
    assert!(
        renderer
            .extract(&ctx, &sources, MapKind::Image, 0, &target)
            .is_err()
    );
    // Other kinds do not read the image.
    renderer
        .extract(&ctx, &sources, MapKind::Depth, 0, &target)
        .expect("depth does not read the image");
}
