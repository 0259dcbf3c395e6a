//! Straight lines of an image and the Manhattan frame they point along (`prior_region_axes`,
//! docs/method.md). A room's walls, floor and ceiling, and most of what stands in it, meet
//! along three orthogonal directions; the image's straight segments point at their
//! vanishing points. Where the photometric cost leaves a grey wall's support points
//! scattered about its plane, that plane's normal is one of the frame's three axes, and a
//! region's plane then has one free number, its offset, where a plane through three
//! points has three.
//!
//! The segments are found as Grompone von Gioi et al.'s LSD finds them (IPOL 2012), in a
//! reduced form: the 2×2 gradient, pixels ordered by gradient magnitude, regions grown from
//! each seed over pixels whose level-line angle is within 22.5° of the region's, and a
//! region kept as a segment when its rectangle (the principal axis of its gradient
//! magnitudes) is long enough and at least 70% full. LSD's a-contrario test (the number of
//! false alarms) and its rectangle refinement are left out: the frame's RANSAC is what
//! rejects a segment that points nowhere. The frame is three orthogonal directions, the
//! one most segments point at: a segment points at a direction when the angle between the
//! direction and its interpretation plane (through the camera centre and the segment) is
//! under [`AXIS_TOLERANCE_DEG`].

use glam::DVec3;
use rayon::prelude::*;

/// A straight segment of the image, pixel coordinates (pixel centres at integers).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub a: [f32; 2],
    pub b: [f32; 2],
}

impl Segment {
    pub fn length(&self) -> f32 {
        (self.b[0] - self.a[0]).hypot(self.b[1] - self.a[1])
    }
}

/// A segment's level-line angle may differ from its region's by at most this (LSD's τ).
pub const LEVEL_LINE_TOLERANCE_DEG: f32 = 22.5;

/// The least share of a segment's rectangle its pixels fill (LSD's density threshold).
pub const SEGMENT_MIN_DENSITY: f32 = 0.7;

/// A segment points at a direction when the angle between the direction and the
/// segment's interpretation plane is under this.
pub const AXIS_TOLERANCE_DEG: f64 = 1.5;

/// The least share of the segments a frame must explain to be taken: four times the
/// share three random directions explain (3 · sin 1.5° ≈ 8%), so a scene whose lines point
/// every way (a pile of objects) has no frame.
pub const FRAME_MIN_SHARE: f64 = 1.0 / 3.0;

/// The fewest segments a frame must explain. Measured (docs/measurements/axes-2026-12-03/):
/// at 12 the shipped ICL's view 1 took a frame 16 of its 24 segments fit, its axis planes
/// put the view 15% too far (median est/gt 1.008 → 1.148) and the room lost 12.8 points
/// within 2%; at 40, 32.3 (38.7 weak) against Regions' 30.7 (36.7), and kitchen-a 37.9
/// (38.9) against 37.5 (37.6), its every finest-scale view keeping a frame (45-58 fit).
pub const FRAME_MIN_SEGMENTS: usize = 40;

/// Random triples of segments the frame's RANSAC tries.
pub const FRAME_SAMPLES: usize = 2000;

/// The shortest segment counted, in pixels, for an image whose larger side is `side`: a
/// twentieth of it (32 px at 640), and never under 8.
pub fn min_segment_length(side: u32) -> f32 {
    (side as f32 / 20.0).max(8.0)
}

/// The image's straight segments, longest rectangles of aligned gradient (module doc),
/// `gray` in grey levels (0-255), row by row. Deterministic: pixels are visited by
/// decreasing gradient magnitude, ties in row order.
pub fn line_segments(gray: &[f32], width: u32, height: u32, min_length: f32) -> Vec<Segment> {
    let (w, h) = (width as usize, height as usize);
    if w < 2 || h < 2 || gray.len() < w * h {
        return Vec::new();
    }
    // LSD smooths before the gradient (its Gaussian subsampling), so that the steps of a
    // slanted edge's pixels do not turn the level-line angle: σ = 0.6 px, LSD's on its
    // subsampled grid.
    let smooth = gaussian(&gray[..w * h], w, h, SMOOTH_SIGMA);
    // The 2×2 gradient, at the centre of each 2×2 block (x + 0.5, y + 0.5).
    let (gw, gh) = (w - 1, h - 1);
    let at = |x: usize, y: usize| smooth[y * w + x];
    let grad: Vec<(f32, f32)> = (0..gw * gh)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % gw, i / gw);
            let (a, b, c, d) = (at(x, y), at(x + 1, y), at(x, y + 1), at(x + 1, y + 1));
            let gx = (b + d - a - c) / 2.0;
            let gy = (c + d - a - b) / 2.0;
            // Magnitude, level-line angle (the gradient turned a quarter).
            (gx.hypot(gy), gx.atan2(-gy))
        })
        .collect();
    let tau = LEVEL_LINE_TOLERANCE_DEG.to_radians();
    // LSD's gradient threshold: a quantisation error of 2 grey levels cannot turn the
    // level-line angle by more than τ above it.
    let rho = 2.0 / tau.sin();
    let mut order: Vec<usize> = (0..gw * gh).filter(|&i| grad[i].0 > rho).collect();
    order.sort_by(|&i, &j| grad[j].0.total_cmp(&grad[i].0).then(i.cmp(&j)));
    let mut used = vec![false; gw * gh];
    let diff = |a: f32, b: f32| {
        let mut d = (a - b).abs() % std::f32::consts::TAU;
        if d > std::f32::consts::PI {
            d = std::f32::consts::TAU - d;
        }
        d
    };
    let mut out = Vec::new();
    let mut region = Vec::new();
    for &seed in &order {
        if used[seed] {
            continue;
        }
        region.clear();
        region.push(seed);
        used[seed] = true;
        let (mut sx, mut sy) = (grad[seed].1.cos(), grad[seed].1.sin());
        let mut angle = grad[seed].1;
        let mut k = 0;
        while k < region.len() {
            let (x, y) = ((region[k] % gw) as i64, (region[k] / gw) as i64);
            k += 1;
            for (dx, dy) in super::NEIGHBOURS_8 {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= gw as i64 || ny >= gh as i64 {
                    continue;
                }
                let n = ny as usize * gw + nx as usize;
                if used[n] || grad[n].0 <= rho || diff(grad[n].1, angle) >= tau {
                    continue;
                }
                used[n] = true;
                region.push(n);
                sx += grad[n].1.cos();
                sy += grad[n].1.sin();
                angle = sy.atan2(sx);
            }
        }
        if (region.len() as f32) < min_length {
            continue;
        }
        if let Some(s) = rectangle(&region, &grad, gw, angle, tau)
            .filter(|(s, density)| s.length() >= min_length && *density >= SEGMENT_MIN_DENSITY)
            .map(|(s, _)| s)
        {
            out.push(s);
        }
    }
    out
}

/// The smoothing before the gradient, pixels (LSD's 0.6 of the subsampled grid).
pub const SMOOTH_SIGMA: f32 = 0.6;

/// A separable Gaussian of `sigma` (radius 3σ, borders clamped).
fn gaussian(img: &[f32], w: usize, h: usize, sigma: f32) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as i64;
    let mut k: Vec<f32> = (-r..=r)
        .map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f32 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    let pass = |src: &[f32], horizontal: bool| -> Vec<f32> {
        (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                k.iter()
                    .enumerate()
                    .map(|(j, kv)| {
                        let o = j as i64 - r;
                        let (sx, sy) = if horizontal {
                            ((x + o).clamp(0, w as i64 - 1), y)
                        } else {
                            (x, (y + o).clamp(0, h as i64 - 1))
                        };
                        kv * src[sy as usize * w + sx as usize]
                    })
                    .sum()
            })
            .collect()
    };
    pass(&pass(img, true), false)
}

/// A region's rectangle: centred at its magnitude-weighted centroid, along the principal
/// axis of its magnitudes, as long and wide as its pixels reach; with the share of the
/// rectangle its pixels fill. None when the axis is not the region's level-line direction
/// (within τ): then the pixels are not a line.
fn rectangle(
    region: &[usize],
    grad: &[(f32, f32)],
    gw: usize,
    angle: f32,
    tau: f32,
) -> Option<(Segment, f32)> {
    let pos = |i: usize| ((i % gw) as f64 + 0.5, (i / gw) as f64 + 0.5);
    let (mut m, mut cx, mut cy) = (0.0f64, 0.0f64, 0.0f64);
    for &i in region {
        let g = grad[i].0 as f64;
        let (x, y) = pos(i);
        m += g;
        cx += g * x;
        cy += g * y;
    }
    if m <= 0.0 {
        return None;
    }
    (cx, cy) = (cx / m, cy / m);
    let (mut sxx, mut syy, mut sxy) = (0.0f64, 0.0f64, 0.0f64);
    for &i in region {
        let g = grad[i].0 as f64;
        let (x, y) = pos(i);
        sxx += g * (x - cx) * (x - cx);
        syy += g * (y - cy) * (y - cy);
        sxy += g * (x - cx) * (y - cy);
    }
    // The larger eigenvector of [[sxx, sxy], [sxy, syy]].
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (dx, dy) = (theta.cos(), theta.sin());
    // The axis is the level line's (either way along it).
    let lx = (angle as f64).cos();
    let ly = (angle as f64).sin();
    if (dx * lx + dy * ly).abs() < (tau as f64).cos() {
        return None;
    }
    // Its length: as far as its pixels reach along the axis. Its width: that of a band
    // filled evenly with the same spread across the axis (√12 standard deviations), not
    // the farthest pixels', so that a blurred edge's few outlying pixels do not halve a
    // straight segment's density; a curve's sagitta widens the spread itself.
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    let (mut sa, mut saa) = (0.0f64, 0.0f64);
    for &i in region {
        let (x, y) = pos(i);
        let along = (x - cx) * dx + (y - cy) * dy;
        let across = -(x - cx) * dy + (y - cy) * dx;
        lo = lo.min(along);
        hi = hi.max(along);
        sa += across;
        saa += across * across;
    }
    let nr = region.len() as f64;
    let spread = (saa / nr - (sa / nr) * (sa / nr)).max(0.0).sqrt();
    let area = (hi - lo + 1.0) * (12f64.sqrt() * spread).max(1.0);
    let seg = Segment {
        a: [(cx + lo * dx) as f32, (cy + lo * dy) as f32],
        b: [(cx + hi * dx) as f32, (cy + hi * dy) as f32],
    };
    Some((seg, (region.len() as f64 / area) as f32))
}

/// A view's Manhattan frame: three orthogonal unit directions in its camera's frame, and
/// which of them each segment points at.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub axes: [[f64; 3]; 3],
    pub segments: Vec<Segment>,
    /// Per segment: the axis it points at (0-2), or 3 for none.
    pub along: Vec<u8>,
}

impl Frame {
    /// How many segments point at each axis.
    pub fn counts(&self) -> [usize; 3] {
        let mut c = [0; 3];
        for &a in &self.along {
            if let Some(n) = c.get_mut(a as usize) {
                *n += 1;
            }
        }
        c
    }
}

/// `a` scaled to length 1, when it has a length.
fn unit(a: DVec3) -> Option<DVec3> {
    let n = a.length();
    (n.is_finite() && n > 1e-9).then(|| a / n)
}

/// The unit normal of a segment's interpretation plane (through the camera centre and the
/// segment), `k` = [fx, fy, cx, cy].
pub fn interpretation_plane(k: [f32; 4], s: &Segment) -> Option<[f64; 3]> {
    let r = |p: [f32; 2]| {
        DVec3::new(
            (p[0] as f64 - k[2] as f64) / k[0] as f64,
            (p[1] as f64 - k[3] as f64) / k[1] as f64,
            1.0,
        )
    };
    unit(r(s.a).cross(r(s.b))).map(<[f64; 3]>::from)
}

/// The Manhattan frame most of the segments point at (module doc): RANSAC over
/// [`FRAME_SAMPLES`] triples drawn from `stream` (two segments give the first direction,
/// the crossing of their interpretation planes; a third the second, in its plane and
/// orthogonal to the first; their cross product the third), scored by MSAC's truncated
/// cost (each segment's squared sine to its nearest axis, at most the tolerance's). None when the best explains fewer than
/// [`FRAME_MIN_SEGMENTS`] or [`FRAME_MIN_SHARE`] of them.
pub fn manhattan_frame(
    k: [f32; 4],
    segments: Vec<Segment>,
    stream: &mut crate::rng::Stream,
) -> Option<Frame> {
    let (segments, planes): (Vec<Segment>, Vec<DVec3>) = segments
        .into_iter()
        .filter_map(|s| interpretation_plane(k, &s).map(|l| (s, DVec3::from(l))))
        .unzip();
    let n = planes.len();
    if n < 3 {
        return None;
    }
    let tol = AXIS_TOLERANCE_DEG.to_radians().sin();
    let along = |axes: &[DVec3; 3], l: DVec3| -> u8 {
        // The axis nearest the plane, when within the tolerance.
        let (mut best, mut at) = (tol, 3u8);
        for (i, a) in axes.iter().enumerate() {
            let c = a.dot(l).abs();
            if c < best {
                best = c;
                at = i as u8;
            }
        }
        at
    };
    // MSAC's truncated cost, not the count: a frame the segments fit tightly beats one
    // their tolerance merely admits (a camera facing a wall admits its own axes as well).
    let cost = |axes: &[DVec3; 3]| -> f64 {
        planes
            .iter()
            .map(|&l| {
                axes.iter()
                    .map(|a| a.dot(l).powi(2))
                    .fold(tol * tol, f64::min)
            })
            .sum()
    };
    let mut best: Option<([DVec3; 3], f64)> = None;
    for _ in 0..FRAME_SAMPLES {
        let mut pick = || ((stream.next_f32() * n as f32) as usize).min(n - 1);
        let (i, j, q) = (pick(), pick(), pick());
        if i == j || j == q || i == q {
            continue;
        }
        let Some(d1) = unit(planes[i].cross(planes[j])) else {
            continue;
        };
        let Some(d2) = unit(planes[q].cross(d1)) else {
            continue;
        };
        let axes = [d1, d2, d1.cross(d2)];
        let c = cost(&axes);
        if best.is_none_or(|(_, b)| c < b) {
            best = Some((axes, c));
        }
    }
    let (axes, _) = best?;
    let fit = planes.iter().filter(|&&l| along(&axes, l) < 3).count();
    if fit < FRAME_MIN_SEGMENTS || (fit as f64) < FRAME_MIN_SHARE * n as f64 {
        return None;
    }
    let along = planes.iter().map(|&l| along(&axes, l)).collect();
    Some(Frame {
        axes: axes.map(<[f64; 3]>::from),
        segments,
        along,
    })
}

/// A view's frame from its intensities (`gray`, grey levels, row by row) and intrinsics:
/// [`line_segments`] at [`min_segment_length`], then [`manhattan_frame`], the draw keyed by
/// `key` (seed, view, scale).
pub fn view_frame(
    gray: &[f32],
    width: u32,
    height: u32,
    k: [f32; 4],
    key: &[u32],
) -> Option<Frame> {
    let segments = line_segments(gray, width, height, min_segment_length(width.max(height)));
    let mut stream = crate::rng::Stream::new(key);
    manhattan_frame(k, segments, &mut stream)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A room's corner seen by a camera turned about two axes: the three walls' edges and a
    /// grid of lines on each wall, drawn as dark strokes on grey, point along the room's
    /// three axes. The segments are found and the frame recovered within a degree.
    fn corner_image(w: u32, h: u32, k: [f32; 4], rot: [[f64; 3]; 3]) -> Vec<f32> {
        let mut img = vec![160.0f32; (w * h) as usize];
        // World lines: along x, y, z through a lattice of points in front of the camera.
        let project = |p: [f64; 3]| {
            let row = |i: usize| DVec3::from(rot[i]).dot(DVec3::from(p));
            let c = [row(0), row(1), row(2) + 6.0]; // the room lies 6 units in front
            (c[2] > 0.1).then(|| {
                [
                    k[0] as f64 * c[0] / c[2] + k[2] as f64,
                    k[1] as f64 * c[1] / c[2] + k[3] as f64,
                ]
            })
        };
        let mut stroke = |a: [f64; 3], b: [f64; 3]| {
            for t in 0..=2000 {
                let t = t as f64 / 2000.0;
                let p = [
                    a[0] + (b[0] - a[0]) * t,
                    a[1] + (b[1] - a[1]) * t,
                    a[2] + (b[2] - a[2]) * t,
                ];
                // Drawn as a lens draws it: a dark line of Gaussian profile (σ 0.8 px),
                // not staircases of whole pixels.
                if let Some([px, py]) = project(p) {
                    let (x0, y0) = (px.round() as i64, py.round() as i64);
                    for dy in -3..=3 {
                        for dx in -3..=3 {
                            let (x, y) = (x0 + dx, y0 + dy);
                            if x >= 0 && y >= 0 && x < w as i64 && y < h as i64 {
                                let d2 = (x as f64 - px).powi(2) + (y as f64 - py).powi(2);
                                let v = 160.0 - 120.0 * (-d2 / (2.0 * 0.64)).exp();
                                let i = (y as u32 * w + x as u32) as usize;
                                img[i] = img[i].min(v as f32);
                            }
                        }
                    }
                }
            }
        };
        for i in -2..=2 {
            let s = i as f64;
            stroke([-3.0, s, 0.0], [3.0, s, 0.0]); // along x
            stroke([s, -3.0, 0.0], [s, 3.0, 0.0]); // along y
            stroke([-3.0, 0.0, s], [-3.0, 0.0, s + 0.8]); // along z, short
            stroke([3.0, s, -2.0], [3.0, s, 2.0]); // along z on a side wall
        }
        img
    }

    fn rotation(a: f64, b: f64) -> [[f64; 3]; 3] {
        let (ca, sa, cb, sb) = (a.cos(), a.sin(), b.cos(), b.sin());
        // About y by a, then about x by b.
        let ry = [[ca, 0.0, sa], [0.0, 1.0, 0.0], [-sa, 0.0, ca]];
        let rx = [[1.0, 0.0, 0.0], [0.0, cb, -sb], [0.0, sb, cb]];
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = (0..3).map(|q| rx[i][q] * ry[q][j]).sum();
            }
        }
        m
    }

    #[test]
    fn a_rooms_lines_give_its_frame() {
        let (w, h) = (320u32, 240u32);
        let k = [260.0, 260.0, 160.0, 120.0];
        let rot = rotation(0.35, -0.2);
        let img = corner_image(w, h, k, rot);
        let segs = line_segments(&img, w, h, min_segment_length(w));
        assert!(segs.len() >= 12, "{} segments", segs.len());
        let frame = view_frame(&img, w, h, k, &[0, 1, 2]).expect("a frame");
        // Each world axis, in the camera's frame, is one of the frame's axes within 1°.
        for (j, truth) in (0..3).map(|j| (j, [rot[0][j], rot[1][j], rot[2][j]])) {
            let best = frame
                .axes
                .iter()
                .map(|a| {
                    DVec3::from(*a)
                        .dot(DVec3::from(truth))
                        .abs()
                        .min(1.0)
                        .acos()
                        .to_degrees()
                })
                .fold(f64::MAX, f64::min);
            assert!(
                best < 1.0,
                "world axis {j}: nearest frame axis {best:.2} deg off"
            );
        }
        let c = frame.counts();
        assert!(c.iter().filter(|&&n| n >= 3).count() >= 2, "{c:?}");
        // The same draw gives the same frame.
        assert_eq!(view_frame(&img, w, h, k, &[0, 1, 2]), Some(frame));
    }

    #[test]
    fn lines_that_point_every_way_give_no_frame() {
        // Eighty strokes at random angles and positions (a pile of objects): no three
        // orthogonal directions explain a third of their edges.
        let (w, h) = (320u32, 240u32);
        let mut img = vec![160.0f32; (w * h) as usize];
        let mut rng = crate::rng::Stream::new(&[7]);
        for _ in 0..80 {
            let (x0, y0) = (rng.next_f32() * w as f32, rng.next_f32() * h as f32);
            let a = rng.next_f32() * std::f32::consts::PI;
            for t in 0..60 {
                let (x, y) = (x0 + a.cos() * t as f32, y0 + a.sin() * t as f32);
                let (x, y) = (x.round() as i64, y.round() as i64);
                if x >= 0 && y >= 0 && x + 1 < w as i64 && y + 1 < h as i64 {
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        img[((y + dy) as u32 * w + (x + dx) as u32) as usize] = 40.0;
                    }
                }
            }
        }
        let k = [260.0, 260.0, 160.0, 120.0];
        let segs = line_segments(&img, w, h, min_segment_length(w));
        assert!(segs.len() >= 20, "{} segments", segs.len());
        assert_eq!(view_frame(&img, w, h, k, &[0, 1, 2]), None);
    }

    #[test]
    fn a_flat_image_has_no_segments() {
        let img = vec![128.0f32; 64 * 48];
        assert!(line_segments(&img, 64, 48, 8.0).is_empty());
        assert!(line_segments(&[], 0, 0, 8.0).is_empty());
    }
}
