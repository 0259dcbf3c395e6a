//! How deep ACMM's pyramid goes when the images decide (`Params::scales_by_texture`).
//!
//! The paper builds k = 3 scales because "the texture richness is a relative measure": a
//! weakly textured area that a fixed window cannot tell apart at full size becomes
//! discriminative once the image is downsampled far enough for the window to reach its
//! textured surroundings (Sec. 1, Fig. 2). A fixed k does that for the paper's images
//! (3000-3200 px, coarsest ~800 px) but not for a room whose walls span a third of the
//! frame. Here the depth follows from that argument, measured on the images: a pixel is
//! textured where its matching window (full, at full size) varies by at least
//! [`WEAK_WINDOW_STD`] grey levels; each pixel's chessboard distance to the nearest textured
//! one is what the window (radius r) must span; the [`REACH_QUANTILE`] of it over a view is
//! the view's reach, the median over up to [`SAMPLE_VIEWS`] views the scene's. The
//! coarsest scale is the first (η apart) at which r coarse pixels cover the reach, never
//! fewer scales than k and never so many that the coarsest long side holds fewer than
//! [`MIN_WINDOWS_ACROSS`] windows.

use crate::image::Image;

use super::params::{Method, Params};

/// A matching window whose grey levels vary less than this (standard deviation, 0..255)
/// counts as weak texture (the definition of the weak-texture masks of the shared scenes).
pub const WEAK_WINDOW_STD: f64 = 3.0;
/// Share of a view's pixels whose distance to texture the coarsest window must span.
pub const REACH_QUANTILE: f64 = 0.95;
/// The coarsest scale's long side holds at least this many matching windows.
pub const MIN_WINDOWS_ACROSS: u32 = 4;
/// At most this many views are measured (evenly spaced over the scene).
pub const SAMPLE_VIEWS: usize = 16;

/// What the images said about the pyramid's depth.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureDepth {
    /// The number of scales the run uses.
    pub scales: u32,
    /// The scene's reach: the median over the measured views of the distance (full-size
    /// pixels) from which 95% of a view's pixels see a textured pixel.
    pub reach: f64,
    /// The views measured (indices into the scene).
    pub views: Vec<usize>,
    /// Scales the reach asked for before the floor (k) and the ceiling (the coarsest size).
    pub wanted: u32,
    /// The window radius the texture was measured with (it defines a textured pixel).
    pub radius: u32,
}

impl std::fmt::Display for TextureDepth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} scales from the images' texture: 95% of the pixels lie within {:.0} px of texture (median of {} view{})",
            self.scales,
            self.reach,
            self.views.len(),
            if self.views.len() == 1 { "" } else { "s" },
        )?;
        match self.wanted.cmp(&self.scales) {
            std::cmp::Ordering::Greater => write!(
                f,
                "; {} would reach that, but the coarsest long side must hold {MIN_WINDOWS_ACROSS} windows",
                self.wanted
            ),
            std::cmp::Ordering::Less => {
                write!(f, "; {} would reach that, and k is the floor", self.wanted)
            }
            std::cmp::Ordering::Equal => Ok(()),
        }
    }
}

/// The views measured for a scene of `n` views: all of them up to [`SAMPLE_VIEWS`], else
/// that many evenly spaced.
pub fn sample_views(n: usize) -> Vec<usize> {
    let m = n.min(SAMPLE_VIEWS);
    (0..m).map(|i| i * n / m).collect()
}

/// Whether each pixel's window (radius `radius`, every pixel, clipped at the border) varies
/// by at least [`WEAK_WINDOW_STD`] grey levels.
pub fn textured_mask(gray: &[f32], width: u32, height: u32, radius: u32) -> Vec<bool> {
    let (w, h) = (width as usize, height as usize);
    if gray.len() != w * h || w == 0 || h == 0 {
        return Vec::new();
    }
    // Summed-area tables of I and I² (f64: exact enough for 12 Mpx of 0..255).
    let mut s1 = vec![0.0f64; (w + 1) * (h + 1)];
    let mut s2 = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let (mut r1, mut r2) = (0.0, 0.0);
        for x in 0..w {
            let v = gray[y * w + x] as f64;
            r1 += v;
            r2 += v * v;
            s1[(y + 1) * (w + 1) + x + 1] = s1[y * (w + 1) + x + 1] + r1;
            s2[(y + 1) * (w + 1) + x + 1] = s2[y * (w + 1) + x + 1] + r2;
        }
    }
    let r = radius as usize;
    let box_sum = |s: &[f64], x0: usize, y0: usize, x1: usize, y1: usize| {
        s[y1 * (w + 1) + x1] - s[y0 * (w + 1) + x1] - s[y1 * (w + 1) + x0] + s[y0 * (w + 1) + x0]
    };
    let limit = WEAK_WINDOW_STD * WEAK_WINDOW_STD;
    let mut out = vec![false; w * h];
    for y in 0..h {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
            let n = ((x1 - x0) * (y1 - y0)) as f64;
            let m = box_sum(&s1, x0, y0, x1, y1) / n;
            let var = box_sum(&s2, x0, y0, x1, y1) / n - m * m;
            out[y * w + x] = var >= limit;
        }
    }
    out
}

/// Each pixel's chessboard distance to the nearest `true` pixel (`u32::MAX` where there is
/// none): two raster passes over the 8-neighbourhood (Rosenfeld & Pfaltz).
pub fn chessboard_distance(mask: &[bool], width: u32, height: u32) -> Vec<u32> {
    let (w, h) = (width as usize, height as usize);
    let far = u32::MAX;
    let mut d: Vec<u32> = mask.iter().map(|&t| if t { 0 } else { far }).collect();
    if d.len() != w * h {
        return Vec::new();
    }
    let step = |a: u32| a.saturating_add(1);
    for y in 0..h {
        for x in 0..w {
            let mut v = d[y * w + x];
            if x > 0 {
                v = v.min(step(d[y * w + x - 1]));
            }
            if y > 0 {
                let up = (y - 1) * w;
                v = v.min(step(d[up + x]));
                if x > 0 {
                    v = v.min(step(d[up + x - 1]));
                }
                if x + 1 < w {
                    v = v.min(step(d[up + x + 1]));
                }
            }
            d[y * w + x] = v;
        }
    }
    for y in (0..h).rev() {
        for x in (0..w).rev() {
            let mut v = d[y * w + x];
            if x + 1 < w {
                v = v.min(step(d[y * w + x + 1]));
            }
            if y + 1 < h {
                let down = (y + 1) * w;
                v = v.min(step(d[down + x]));
                if x > 0 {
                    v = v.min(step(d[down + x - 1]));
                }
                if x + 1 < w {
                    v = v.min(step(d[down + x + 1]));
                }
            }
            d[y * w + x] = v;
        }
    }
    d
}

/// A view's reach: the distance (pixels) within which [`REACH_QUANTILE`] of its pixels see a
/// textured pixel; the long side where the view has no textured pixel at all. `None` for an
/// image without pixels.
pub fn view_reach(image: &Image, radius: u32) -> Option<f64> {
    let (w, h) = (image.width, image.height);
    let mask = textured_mask(&image.gray, w, h, radius);
    if mask.is_empty() {
        return None;
    }
    let dist = chessboard_distance(&mask, w, h);
    let long = w.max(h);
    // A histogram, not a sort: a 12 Mpx view's distances are bounded by its long side.
    let mut hist = vec![0u64; long as usize + 1];
    for &d in &dist {
        hist[d.min(long) as usize] += 1;
    }
    let wanted = (REACH_QUANTILE * dist.len() as f64).ceil() as u64;
    let mut seen = 0u64;
    for (d, &c) in hist.iter().enumerate() {
        seen += c;
        if seen >= wanted.max(1) {
            return Some(d as f64);
        }
    }
    Some(long as f64)
}

/// The number of scales for a scene whose reach is `reach` px and whose longest side is
/// `long_side`: the first level (η apart) whose window radius covers the reach, at least
/// `params.scales`, at most 8, and no coarser than [`MIN_WINDOWS_ACROSS`] windows across.
/// Returns (scales, scales the reach alone asked for).
pub fn scales_for_reach(reach: f64, long_side: u32, params: &Params) -> (u32, u32) {
    let radius = params.window_radius.max(1) as f64;
    let eta = params.eta as f64;
    // Level l (0 = full size) shrinks by η^l, so its window spans radius / η^l full pixels.
    let mut wanted = 1u32;
    while wanted < 8 && radius / eta.powi(wanted as i32 - 1) < reach {
        wanted += 1;
    }
    let window = (2 * params.window_radius + 1) as f64;
    let smallest = MIN_WINDOWS_ACROSS as f64 * window;
    let mut scales = wanted.max(params.scales);
    while scales > params.scales && long_side as f64 * eta.powi(scales as i32 - 1) < smallest {
        scales -= 1;
    }
    (scales, wanted)
}

/// The pyramid's depth from `images` (the measured views, each with its index), for a scene
/// whose longest side is `long_side`. `Err` names a view without pixels.
pub fn texture_depth(
    images: &[(usize, &Image)],
    long_side: u32,
    params: &Params,
) -> Result<TextureDepth, String> {
    let mut reaches = Vec::with_capacity(images.len());
    for &(v, image) in images {
        reaches.push((v, reach_or_error(v, image, params.window_radius)?));
    }
    from_reaches(reaches, long_side, params)
}

fn reach_or_error(view: usize, image: &Image, radius: u32) -> Result<f64, String> {
    view_reach(image, radius).ok_or_else(|| {
        format!("the pyramid's depth is measured on the images, and view {view}'s is not decoded")
    })
}

/// The pyramid's depth from each measured view's reach (view index, reach in pixels).
pub fn from_reaches(
    mut reaches: Vec<(usize, f64)>,
    long_side: u32,
    params: &Params,
) -> Result<TextureDepth, String> {
    if reaches.is_empty() {
        return Err("the pyramid's depth is measured on the images, and the scene has none".into());
    }
    let views = reaches.iter().map(|&(v, _)| v).collect();
    reaches.sort_by(|a, b| a.1.total_cmp(&b.1));
    let reach = reaches[reaches.len() / 2].1;
    let (scales, wanted) = scales_for_reach(reach, long_side, params);
    Ok(TextureDepth {
        scales,
        reach,
        views,
        wanted,
        radius: params.window_radius,
    })
}

/// With `params.scales_by_texture` (and a multi-scale method), sets `params.scales` for a
/// scene of `views` views whose longest side is `long_side`, from the reach `reach_of` gives
/// for each sampled view (one image at a time: a caller without the pixels decodes each and
/// lets it go), and says what decided it; `Ok(None)` when off.
pub fn resolve_with(
    params: &mut Params,
    method: Method,
    views: usize,
    long_side: u32,
    mut reach_of: impl FnMut(usize) -> Result<f64, String>,
) -> Result<Option<TextureDepth>, String> {
    if !method.deepens_pyramid(params) {
        return Ok(None);
    }
    let mut reaches = Vec::new();
    for v in sample_views(views) {
        reaches.push((v, reach_of(v)?));
    }
    let depth = from_reaches(reaches, long_side, params)?;
    params.scales = depth.scales;
    Ok(Some(depth))
}

/// [`resolve_with`] on the images `scene` holds (the sampled views must be decoded; `Err`
/// names the first that is not).
pub fn resolve(
    params: &mut Params,
    method: Method,
    scene: &crate::scene::Scene,
) -> Result<Option<TextureDepth>, String> {
    let long_side = scene.long_side();
    let radius = params.window_radius;
    resolve_with(params, method, scene.views.len(), long_side, |v| {
        reach_or_error(v, &scene.views[v].image, radius)
    })
}

/// Whether `scene`'s sampled views hold their pixels (a scene loaded for its sizes only
/// does not).
pub fn sample_decoded(scene: &crate::scene::Scene) -> bool {
    sample_views(scene.views.len()).into_iter().all(|v| {
        let i = &scene.views[v].image;
        i.width > 0 && i.gray.len() == (i.width * i.height) as usize
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> Image {
        let rgb = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let v = f(x, y);
                [v, v, v]
            })
            .collect();
        Image::from_rgb(w, h, rgb)
    }

    /// A noise-like texture: a hash of the position, 0..255.
    fn texture(x: u32, y: u32) -> u8 {
        (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)).wrapping_mul(2_654_435_761) as u8
    }

    #[test]
    fn chessboard_distance_is_the_max_of_the_offsets() {
        let (w, h) = (9u32, 7u32);
        let mut mask = vec![false; 63];
        mask[3 * 9 + 2] = true;
        let d = chessboard_distance(&mask, w, h);
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let want = (x - 2).abs().max((y - 3).abs()) as u32;
                assert_eq!(d[(y * 9 + x) as usize], want, "({x}, {y})");
            }
        }
        assert!(
            chessboard_distance(&[false; 4], 2, 2)
                .iter()
                .all(|&v| v == u32::MAX)
        );
    }

    #[test]
    fn a_window_is_weak_below_three_grey_levels() {
        // Columns alternating 0/4: std 2 (weak); 0/8: std 4 (textured).
        let weak = image(20, 20, |x, _| if x % 2 == 0 { 0 } else { 4 });
        let strong = image(20, 20, |x, _| if x % 2 == 0 { 0 } else { 8 });
        assert!(textured_mask(&weak.gray, 20, 20, 5).iter().all(|&t| !t));
        assert!(textured_mask(&strong.gray, 20, 20, 5).iter().all(|&t| t));
    }

    #[test]
    fn a_plain_wall_framed_by_texture_asks_for_scales_until_the_window_spans_it() {
        let p = Params::default();
        // 640x480, textured everywhere: the paper's k.
        let busy = image(640, 480, texture);
        assert_eq!(view_reach(&busy, 5), Some(0.0));
        assert_eq!(scales_for_reach(0.0, 640, &p), (3, 1));
        // A plain 400x300 wall in the middle of a textured frame: 95% of the pixels lie
        // within ~(the wall's half-height less the window radius) of texture.
        let wall = image(640, 480, |x, y| {
            if (120..520).contains(&x) && (90..390).contains(&y) {
                128
            } else {
                texture(x, y)
            }
        });
        let reach = view_reach(&wall, 5).expect("pixels");
        assert!((100.0..=150.0).contains(&reach), "reach {reach}");
        // 5 px windows span 5, 10, 20, 40, 80, 160 px at levels 0..5: six scales asked,
        // four kept (640 / 8 = 80 px holds four 11 px windows, 40 px does not).
        let (scales, wanted) = scales_for_reach(reach, 640, &p);
        assert_eq!((scales, wanted), (4, 6));
        // A 4000 px photo of the same room (reach x 6.25) asks for the most (8) and keeps
        // seven: 4000 / 64 = 62.5 px holds five windows, 31 px does not.
        assert_eq!(scales_for_reach(reach * 6.25, 4000, &p), (7, 8));
        // A small image never goes below the paper's k.
        assert_eq!(scales_for_reach(reach, 200, &p).0, 3);
    }

    #[test]
    fn resolve_sets_k_from_the_sampled_views_and_names_an_undecoded_one() {
        let mut p = Params {
            scales_by_texture: true,
            ..Params::default()
        };
        let wall = image(640, 480, |x, y| {
            if (120..520).contains(&x) && (90..390).contains(&y) {
                128
            } else {
                texture(x, y)
            }
        });
        let busy = image(640, 480, texture);
        let images = [(0, &wall), (1, &wall), (2, &busy)];
        let d = texture_depth(&images, 640, &p).expect("decoded");
        assert_eq!(d.scales, 4);
        assert_eq!(d.views, vec![0, 1, 2]);
        p.scales = d.scales;
        assert!(
            d.to_string()
                .starts_with("4 scales from the images' texture")
        );
        let empty = Image {
            width: 640,
            height: 480,
            rgb: Vec::new(),
            gray: Vec::new(),
        };
        let err = texture_depth(&[(0, &wall), (7, &empty)], 640, &p).unwrap_err();
        assert!(err.contains("view 7"), "{err}");
        assert_eq!(sample_views(40).len(), SAMPLE_VIEWS);
        assert_eq!(sample_views(40)[1], 2);
        assert_eq!(sample_views(3), vec![0, 1, 2]);
    }
}
