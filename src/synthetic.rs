//! Synthetic scenes with exact ground truth: the built-in demo scene and the test scenes.
//!
//! A small world (y up, metres) is ray cast from `N` cameras on an arc: a large back wall with
//! almost no texture (the low-texture surface ACMM's multi-scale scheme is for), a textured
//! floor seen at a grazing angle, a textured panel slanted 35° away from the cameras, a sphere and
//! a capped cylinder (curved surfaces), and thin poles (thin structures). Albedo is a solid
//! texture — a function of the world position — so every surface looks the same from every
//! view; shading is Lambertian under a directional light plus ambient, so the images are
//! photo-consistent across views. Each pixel averages 4x4 sub-pixel rays, then gets Gaussian
//! sensor noise. Everything is a function of the seed. `room` closes the scene into a room
//! (textured side walls and ceiling meeting the back wall at corners in view).

use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;

use crate::camera::{Camera, Intrinsics};
use crate::image::Image;
use crate::io::{IoError, Map, write_pfm, write_png};
use crate::rng::{Stream, hash_coords, pcg_hash};
use crate::scene::{DepthRange, Scene, SceneError, View, acmm, geometry};
use std::path::Path;

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntheticOptions {
    pub views: usize,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    /// Standard deviation of the sensor noise in grey levels (0..255).
    pub noise_sigma: f32,
    /// A closed room: textured side walls and a ceiling meet the low-texture back wall, so
    /// that its corners are in view (the case the planar prior of ACMP/ACMMP is for: a
    /// textureless plane bounded by textured parts that lie on it).
    pub room: bool,
    /// The most source views a view gets (the best by geometry; default 20).
    pub sources: usize,
}

impl Default for SyntheticOptions {
    fn default() -> Self {
        SyntheticOptions {
            views: 5,
            width: 640,
            height: 480,
            seed: 1,
            noise_sigma: 1.0,
            room: false,
            sources: geometry::DEFAULT_SOURCES,
        }
    }
}

/// Ground truth of one view.
#[derive(Clone, Debug)]
pub struct GroundTruth {
    pub width: u32,
    pub height: u32,
    /// Camera-`z` depth at each pixel centre; 0 where the ray hits nothing.
    pub depth: Vec<f32>,
    /// Unit surface normal in the world frame, facing the camera; zero where depth is 0.
    pub normal_world: Vec<[f32; 3]>,
    /// Pixels whose surface is a low-texture one.
    pub low_texture: Vec<bool>,
}

/// A generated scene and its ground truth, one entry per view.
#[derive(Clone, Debug)]
pub struct SyntheticScene {
    pub scene: Scene,
    pub ground_truth: Vec<GroundTruth>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Material {
    /// Nearly uniform (±1.5% slow variation): the low-texture surface.
    LowTexture,
    /// Fine multi-octave noise.
    Noise,
    /// Tiles with noise: strong edges.
    Tiles,
    /// Bands along the vertical axis, for thin poles.
    Stripes,
}

#[derive(Clone, Copy, Debug)]
enum Shape {
    /// A rectangle: centre, unit normal, in-plane unit axes with half extents.
    Rect {
        center: DVec3,
        normal: DVec3,
        u: DVec3,
        v: DVec3,
        half: DVec2,
    },
    Sphere {
        center: DVec3,
        radius: f64,
    },
    /// A vertical cylinder with caps.
    Cylinder {
        base: DVec3,
        radius: f64,
        height: f64,
    },
}

#[derive(Clone, Copy, Debug)]
struct Object {
    shape: Shape,
    material: Material,
    color: Vec3,
}

struct Hit {
    t: f64,
    normal: DVec3,
    object: usize,
}

fn rect(center: DVec3, normal: DVec3, up_hint: DVec3, half: DVec2) -> Shape {
    let normal = normal.normalize();
    let u = up_hint.cross(normal).normalize();
    let v = normal.cross(u);
    Shape::Rect {
        center,
        normal,
        u,
        v,
        half,
    }
}

/// The world: fixed geometry (with a room's side walls and ceiling when asked); the seed
/// changes textures and noise.
fn world(room: bool) -> Vec<Object> {
    let y = DVec3::Y;
    let slant = 35f64.to_radians();
    let mut objects = vec![
        // Back wall: large and low-textured.
        Object {
            shape: rect(
                DVec3::new(0.0, 2.5, 2.5),
                -DVec3::Z,
                y,
                DVec2::new(12.0, 6.0),
            ),
            material: Material::LowTexture,
            color: Vec3::new(0.78, 0.74, 0.68),
        },
        // Floor, seen at a grazing angle.
        Object {
            shape: rect(
                DVec3::new(0.0, -1.0, -2.0),
                y,
                DVec3::Z,
                DVec2::new(12.0, 4.5),
            ),
            material: Material::Tiles,
            color: Vec3::new(0.62, 0.55, 0.45),
        },
        // Slanted textured panel.
        Object {
            shape: rect(
                DVec3::new(-1.5, 0.4, 1.3),
                DVec3::new(slant.sin(), 0.0, -slant.cos()),
                y,
                DVec2::new(0.8, 1.2),
            ),
            material: Material::Noise,
            color: Vec3::new(0.45, 0.6, 0.8),
        },
        Object {
            shape: Shape::Sphere {
                center: DVec3::new(1.1, -0.25, 0.6),
                radius: 0.75,
            },
            material: Material::Noise,
            color: Vec3::new(0.85, 0.5, 0.4),
        },
        Object {
            shape: Shape::Cylinder {
                base: DVec3::new(-0.1, -1.0, 1.5),
                radius: 0.4,
                height: 1.9,
            },
            material: Material::Tiles,
            color: Vec3::new(0.5, 0.75, 0.5),
        },
    ];
    if room {
        // Side walls (x = ±3.2) and a ceiling (y = 2.2) from the room's open front (z = -2) to
        // the back wall: their edges with it are the wall's corners, in every view.
        for side in [-1.0, 1.0] {
            objects.push(Object {
                shape: rect(
                    DVec3::new(3.2 * side, 0.6, 0.25),
                    DVec3::new(-side, 0.0, 0.0),
                    y,
                    DVec2::new(2.25, 1.6),
                ),
                material: Material::Noise,
                color: Vec3::new(0.7, 0.62, 0.5),
            });
        }
        objects.push(Object {
            shape: rect(
                DVec3::new(0.0, 2.2, 0.25),
                -y,
                DVec3::Z,
                DVec2::new(3.2, 2.25),
            ),
            material: Material::Tiles,
            color: Vec3::new(0.8, 0.8, 0.78),
        });
    }
    // Thin poles in front.
    for (x, z, r) in [(-0.55, -0.4, 0.035), (0.45, -0.7, 0.05), (2.1, 0.0, 0.04)] {
        objects.push(Object {
            shape: Shape::Cylinder {
                base: DVec3::new(x, -1.0, z),
                radius: r,
                height: 2.6,
            },
            material: Material::Stripes,
            color: Vec3::new(0.9, 0.85, 0.3),
        });
    }
    objects
}

fn intersect(shape: &Shape, origin: DVec3, dir: DVec3) -> Option<(f64, DVec3)> {
    const EPS: f64 = 1e-9;
    match *shape {
        Shape::Rect {
            center,
            normal,
            u,
            v,
            half,
        } => {
            let denom = dir.dot(normal);
            if denom.abs() < EPS {
                return None;
            }
            let t = (center - origin).dot(normal) / denom;
            if t <= EPS {
                return None;
            }
            let d = origin + dir * t - center;
            (d.dot(u).abs() <= half.x && d.dot(v).abs() <= half.y).then_some((t, normal))
        }
        Shape::Sphere { center, radius } => {
            let oc = origin - center;
            let b = oc.dot(dir);
            let c = oc.length_squared() - radius * radius;
            let disc = b * b - c;
            if disc < 0.0 {
                return None;
            }
            let s = disc.sqrt();
            let t = if -b - s > EPS { -b - s } else { -b + s };
            (t > EPS).then(|| (t, (origin + dir * t - center) / radius))
        }
        Shape::Cylinder {
            base,
            radius,
            height,
        } => {
            let mut best: Option<(f64, DVec3)> = None;
            let mut consider = |t: f64, n: DVec3| {
                if t > EPS && best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, n));
                }
            };
            // Side: solve in the xz plane.
            let (ox, oz) = (origin.x - base.x, origin.z - base.z);
            let a = dir.x * dir.x + dir.z * dir.z;
            if a > EPS {
                let b = ox * dir.x + oz * dir.z;
                let c = ox * ox + oz * oz - radius * radius;
                let disc = b * b - a * c;
                if disc >= 0.0 {
                    for t in [(-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a] {
                        let y = origin.y + dir.y * t;
                        if y >= base.y && y <= base.y + height {
                            let p = origin + dir * t;
                            consider(t, DVec3::new(p.x - base.x, 0.0, p.z - base.z) / radius);
                        }
                    }
                }
            }
            // Caps.
            if dir.y.abs() > EPS {
                for (cap_y, n) in [(base.y + height, DVec3::Y), (base.y, -DVec3::Y)] {
                    let t = (cap_y - origin.y) / dir.y;
                    let p = origin + dir * t;
                    if (p.x - base.x).powi(2) + (p.z - base.z).powi(2) <= radius * radius {
                        consider(t, n);
                    }
                }
            }
            best
        }
    }
}

fn trace(objects: &[Object], origin: DVec3, dir: DVec3) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (i, o) in objects.iter().enumerate() {
        if let Some((t, normal)) = intersect(&o.shape, origin, dir)
            && best.as_ref().is_none_or(|b| t < b.t)
        {
            best = Some(Hit {
                t,
                normal,
                object: i,
            });
        }
    }
    best
}

/// Smooth 3D value noise in [0, 1] on a lattice of unit spacing.
fn value_noise(p: DVec3, seed: u32) -> f64 {
    let cell = p.floor();
    let f = p - cell;
    let smooth = f * f * (DVec3::splat(3.0) - 2.0 * f);
    let lattice = |dx: i32, dy: i32, dz: i32| -> f64 {
        let h = hash_coords(&[
            seed,
            (cell.x as i32 + dx) as u32,
            (cell.y as i32 + dy) as u32,
            (cell.z as i32 + dz) as u32,
        ]);
        (pcg_hash(h) >> 8) as f64 / 16_777_216.0
    };
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(lattice(0, 0, 0), lattice(1, 0, 0), smooth.x);
    let x10 = lerp(lattice(0, 1, 0), lattice(1, 1, 0), smooth.x);
    let x01 = lerp(lattice(0, 0, 1), lattice(1, 0, 1), smooth.x);
    let x11 = lerp(lattice(0, 1, 1), lattice(1, 1, 1), smooth.x);
    lerp(lerp(x00, x10, smooth.y), lerp(x01, x11, smooth.y), smooth.z)
}

/// Multi-octave noise in about [0, 1]: features from `base` metres down to `base / 2^(octaves-1)`.
fn fbm(p: DVec3, seed: u32, base: f64, octaves: u32) -> f64 {
    let mut sum = 0.0;
    let mut amp = 0.5;
    let mut norm = 0.0;
    let mut scale = 1.0 / base;
    for o in 0..octaves {
        sum += amp * value_noise(p * scale, seed.wrapping_add(o * 7919));
        norm += amp;
        amp *= 0.6;
        scale *= 2.0;
    }
    sum / norm
}

/// Half the peak-to-peak albedo variation of the low-texture wall: about ±1.8 grey levels,
/// comparable to the sensor noise at full resolution, so photometric matching at the input
/// scale mostly fails there while coarser scales (noise averaged away, windows covering more
/// of the pattern) still match — the regime ACMM's multi-scale scheme is for. Measured at
/// 320x240 (view 2): ACMH puts 26% of the wall within 1% depth, ACMM 45%. (A wall with no
/// texture at all defeats both; a stronger one lets ACMH alone succeed.)
const LOW_TEXTURE_AMPLITUDE: f64 = 0.015;
/// Feature size of the low-texture wall's pattern, in metres.
const LOW_TEXTURE_FEATURE: f64 = 0.25;

fn albedo(o: &Object, p: DVec3, seed: u32) -> Vec3 {
    let k = match o.material {
        Material::LowTexture => {
            1.0 + LOW_TEXTURE_AMPLITUDE * 2.0 * (fbm(p, seed, LOW_TEXTURE_FEATURE, 3) - 0.5)
        }
        Material::Noise => 0.25 + 1.2 * fbm(p, seed ^ 0x51, 0.35, 5),
        Material::Tiles => {
            let tile = |x: f64| (x / 0.3).rem_euclid(1.0) < 0.06;
            let grout = tile(p.x) || tile(p.z) || tile(p.y + 0.02);
            let base = 0.45 + 0.9 * fbm(p, seed ^ 0xa3, 0.25, 4);
            if grout { base * 0.45 } else { base }
        }
        Material::Stripes => {
            let band = ((p.y / 0.08).floor() as i64).rem_euclid(2) == 0;
            (if band { 0.55 } else { 1.1 }) * (0.8 + 0.4 * fbm(p, seed ^ 0x77, 0.1, 2))
        }
    };
    o.color * k as f32
}

/// Radiance (0..255 per channel) of a hit seen from direction `dir`.
fn shade(objects: &[Object], hit: &Hit, origin: DVec3, dir: DVec3, seed: u32) -> Vec3 {
    let p = origin + dir * hit.t;
    let light = DVec3::new(-0.4, 0.8, -0.45).normalize();
    let n = if hit.normal.dot(dir) > 0.0 {
        -hit.normal
    } else {
        hit.normal
    };
    let diffuse = n.dot(light).max(0.0);
    let irradiance = (0.35 + 0.65 * diffuse) as f32;
    albedo(&objects[hit.object], p, seed) * irradiance * 235.0
}

/// The cameras: `n` views on an arc around the scene, alternating in height.
fn cameras(options: &SyntheticOptions) -> Vec<Camera> {
    let (w, h) = (options.width, options.height);
    let f = 0.95 * w as f64;
    let intrinsics = Intrinsics {
        fx: f,
        fy: f,
        cx: (w as f64 - 1.0) / 2.0,
        cy: (h as f64 - 1.0) / 2.0,
    };
    let target = DVec3::new(0.1, -0.1, 0.8);
    let n = options.views.max(1);
    (0..n)
        .map(|i| {
            let t = if n == 1 {
                0.0
            } else {
                i as f64 / (n - 1) as f64 - 0.5
            };
            let angle = (t * 40.0).to_radians();
            let height = if i % 2 == 0 { 0.55 } else { 1.05 };
            let eye = DVec3::new(6.0 * angle.sin(), height, 0.8 - 6.0 * angle.cos());
            Camera::look_at(intrinsics, w, h, eye, target, DVec3::Y)
        })
        .collect()
}

/// Sub-pixel rays per axis: each pixel integrates its area like a sensor does (a box filter),
/// which keeps texture finer than a pixel from aliasing differently in each view.
const SUPERSAMPLING: u32 = 4;

/// Renders one view and its ground truth.
fn render(
    objects: &[Object],
    camera: &Camera,
    view: u32,
    options: &SyntheticOptions,
) -> (Image, GroundTruth) {
    let seed = options.seed as u32 ^ (options.seed >> 32) as u32;
    let (w, h) = (camera.width, camera.height);
    let origin = camera.center();
    let ray = |px: f64, py: f64| -> DVec3 {
        camera
            .dir_world_from_camera(camera.ray_in_camera(DVec2::new(px, py)))
            .normalize()
    };
    type Row = (Vec<[f32; 3]>, Vec<f32>, Vec<[f32; 3]>, Vec<bool>);
    let rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut rgb = Vec::with_capacity(w as usize);
            let mut depth = Vec::with_capacity(w as usize);
            let mut normal = Vec::with_capacity(w as usize);
            let mut low = Vec::with_capacity(w as usize);
            for x in 0..w {
                let (fx, fy) = (x as f64, y as f64);
                let mut color = Vec3::ZERO;
                for sub in 0..SUPERSAMPLING * SUPERSAMPLING {
                    let ox = ((sub % SUPERSAMPLING) as f64 + 0.5) / SUPERSAMPLING as f64 - 0.5;
                    let oy = ((sub / SUPERSAMPLING) as f64 + 0.5) / SUPERSAMPLING as f64 - 0.5;
                    let dir = ray(fx + ox, fy + oy);
                    if let Some(hit) = trace(objects, origin, dir) {
                        color += shade(objects, &hit, origin, dir, seed);
                    }
                }
                color /= (SUPERSAMPLING * SUPERSAMPLING) as f32;
                let mut noise = Stream::new(&[seed, view, x, y, 0x4e01]);
                let sigma = options.noise_sigma;
                let c = color
                    + Vec3::new(
                        noise.next_gaussian(),
                        noise.next_gaussian(),
                        noise.next_gaussian(),
                    ) * sigma;
                rgb.push(c.clamp(Vec3::ZERO, Vec3::splat(255.0)).to_array());

                let dir = ray(fx, fy);
                match trace(objects, origin, dir) {
                    Some(hit) => {
                        let p = origin + dir * hit.t;
                        depth.push(camera.camera_from_world(p).z as f32);
                        let n = if hit.normal.dot(dir) > 0.0 {
                            -hit.normal
                        } else {
                            hit.normal
                        };
                        normal.push(n.as_vec3().to_array());
                        low.push(objects[hit.object].material == Material::LowTexture);
                    }
                    None => {
                        depth.push(0.0);
                        normal.push([0.0; 3]);
                        low.push(false);
                    }
                }
            }
            (rgb, depth, normal, low)
        })
        .collect();
    let mut rgb = Vec::with_capacity((w * h) as usize);
    let mut gt = GroundTruth {
        width: w,
        height: h,
        depth: Vec::with_capacity((w * h) as usize),
        normal_world: Vec::with_capacity((w * h) as usize),
        low_texture: Vec::with_capacity((w * h) as usize),
    };
    for (c, d, n, l) in rows {
        rgb.extend(c);
        gt.depth.extend(d);
        gt.normal_world.extend(n);
        gt.low_texture.extend(l);
    }
    (Image::from_rgb_f32(w, h, &rgb), gt)
}

/// Generates the scene. Deterministic: the same options give bit-identical output.
pub fn generate(options: &SyntheticOptions) -> Result<SyntheticScene, SceneError> {
    if options.views < 2 {
        return Err(SceneError::view(
            "synthetic",
            format!(
                "{} view(s) asked for; at least two are needed",
                options.views
            ),
        ));
    }
    if options.width < 16 || options.height < 16 {
        return Err(SceneError::view(
            "synthetic",
            format!(
                "{}x{} is too small; use at least 16x16",
                options.width, options.height
            ),
        ));
    }
    let objects = world(options.room);
    let cams = cameras(options);
    let rendered: Vec<(Image, GroundTruth)> = cams
        .iter()
        .enumerate()
        .map(|(i, cam)| render(&objects, cam, i as u32, options))
        .collect();
    // Depth ranges: the ground truth's extent, widened by 10% each way (a sparse model would
    // give a similar bracket).
    let ranges: Vec<DepthRange> = rendered
        .iter()
        .map(|(_, gt)| {
            let (lo, hi) = gt
                .depth
                .iter()
                .filter(|&&d| d > 0.0)
                .fold((f64::MAX, 0.0f64), |(lo, hi), &d| {
                    (lo.min(d as f64), hi.max(d as f64))
                });
            DepthRange::new(lo * 0.9, hi * 1.1).map_err(|m| SceneError::view("synthetic", m))
        })
        .collect::<Result<_, _>>()?;
    let sources = geometry::sources_from_geometry(&cams, &ranges, options.sources.max(1));
    let mut views = Vec::with_capacity(cams.len());
    let mut ground_truth = Vec::with_capacity(cams.len());
    for (i, ((image, gt), camera)) in rendered.into_iter().zip(cams).enumerate() {
        views.push(View {
            name: format!("{i:08}"),
            image,
            camera,
            depth_range: ranges[i],
            sources: sources[i].clone(),
            image_path: None,
        });
        ground_truth.push(gt);
    }
    Ok(SyntheticScene {
        scene: Scene::from_views(views)?,
        ground_truth,
    })
}

/// Writes the scene as an ACMM folder plus its ground truth: `gt/%08d.pfm` (depth, 0 where
/// nothing was hit), `gt/%08d_normal.pfm` (world-frame normals) and `gt/%08d_lowtex.png`
/// (255 on low-texture pixels). Every file is written atomically.
pub fn write_demo(synthetic: &SyntheticScene, dir: &Path) -> Result<(), IoError> {
    acmm::write_scene(&synthetic.scene, dir)?;
    let gt_dir = dir.join("gt");
    std::fs::create_dir_all(&gt_dir).map_err(|e| IoError::io(&gt_dir, "create the folder", e))?;
    for (i, gt) in synthetic.ground_truth.iter().enumerate() {
        let (w, h) = (gt.width, gt.height);
        let depth = Map::from_data(w, h, 1, gt.depth.clone())
            .map_err(|e| IoError::invalid(&gt_dir, e.to_string()))?;
        write_pfm(&gt_dir.join(format!("{i:08}.pfm")), &depth)?;
        let normal = Map::from_data(w, h, 3, gt.normal_world.iter().flatten().copied().collect())
            .map_err(|e| IoError::invalid(&gt_dir, e.to_string()))?;
        write_pfm(&gt_dir.join(format!("{i:08}_normal.pfm")), &normal)?;
        let mask: Vec<u8> = gt
            .low_texture
            .iter()
            .map(|&l| if l { 255 } else { 0 })
            .collect();
        write_png(&gt_dir.join(format!("{i:08}_lowtex.png")), w, h, 1, &mask)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> SyntheticOptions {
        SyntheticOptions {
            views: 4,
            width: 96,
            height: 72,
            seed: 3,
            noise_sigma: 1.0,
            room: false,
            sources: geometry::DEFAULT_SOURCES,
        }
    }

    #[test]
    fn deterministic_for_a_seed() {
        let a = generate(&small()).unwrap();
        let b = generate(&small()).unwrap();
        let c = generate(&SyntheticOptions { seed: 4, ..small() }).unwrap();
        for i in 0..4 {
            assert_eq!(a.scene.views[i].image, b.scene.views[i].image);
            assert_eq!(a.ground_truth[i].depth, b.ground_truth[i].depth);
        }
        assert_ne!(a.scene.views[0].image, c.scene.views[0].image);
        // Geometry does not depend on the seed.
        assert_eq!(a.ground_truth[0].depth, c.ground_truth[0].depth);
    }

    #[test]
    fn ground_truth_depth_reprojects_consistently() {
        // A pixel's GT point, seen from another view where that view's GT agrees (not
        // occluded), must land on a pixel whose colour matches: the scene is photo-consistent.
        let s = generate(&SyntheticOptions {
            noise_sigma: 0.0,
            room: false,
            ..small()
        })
        .unwrap();
        let (a, b) = (&s.scene.views[0], &s.scene.views[1]);
        let (gta, gtb) = (&s.ground_truth[0], &s.ground_truth[1]);
        let mut checked = 0;
        let mut consistent = 0;
        for y in (4..68).step_by(3) {
            for x in (4..92).step_by(3) {
                let d = gta.depth[(y * 96 + x) as usize];
                if d <= 0.0 {
                    continue;
                }
                let p = a.camera.unproject(DVec2::new(x as f64, y as f64), d as f64);
                let Some((q, depth_b)) = b.camera.project(p) else {
                    continue;
                };
                let (qx, qy) = (q.x.round() as i64, q.y.round() as i64);
                if qx < 0 || qy < 0 || qx >= 96 || qy >= 72 {
                    continue;
                }
                let j = (qy * 96 + qx) as usize; // nearest pixel, for the occlusion test
                if (gtb.depth[j] as f64 - depth_b).abs() > 0.02 * depth_b {
                    continue; // occluded in b
                }
                checked += 1;
                // Bilinear sample of b's intensity at the exact projection.
                let (x0, y0) = (q.x.floor().max(0.0) as usize, q.y.floor().max(0.0) as usize);
                let (x1, y1) = ((x0 + 1).min(95), (y0 + 1).min(71));
                let (fx, fy) = ((q.x - x0 as f64) as f32, (q.y - y0 as f64) as f32);
                let g = |x: usize, y: usize| b.image.gray[y * 96 + x];
                let sample = (g(x0, y0) * (1.0 - fx) + g(x1, y0) * fx) * (1.0 - fy)
                    + (g(x0, y1) * (1.0 - fx) + g(x1, y1) * fx) * fy;
                if (a.image.gray[(y * 96 + x) as usize] - sample).abs() < 10.0 {
                    consistent += 1;
                }
            }
        }
        assert!(checked > 300, "{checked}");
        eprintln!("{consistent} of {checked} within 10 grey levels");
        // Within 10 grey levels: measured 89.2% (480/538) at 96x72, seed 3, 4x4 supersampling
        // (2x2 gave 79.6%: sub-pixel texture aliases differently in each view). The misses are
        // texture edges, where bilinear interpolation of b is not what b's sensor integrated.
        assert!(
            consistent as f64 > 0.85 * checked as f64,
            "{consistent}/{checked}"
        );
    }

    /// The room closes the scene: its side walls and ceiling take the image's top and side
    /// borders from the back wall, which still fills the middle (its corners in view).
    #[test]
    fn the_room_puts_the_back_walls_corners_in_view() {
        let open = generate(&small()).unwrap();
        let room = generate(&SyntheticOptions {
            room: true,
            ..small()
        })
        .unwrap();
        for (v, (o, r)) in open.ground_truth.iter().zip(&room.ground_truth).enumerate() {
            let (w, h) = (r.width as usize, r.height as usize);
            let low = |g: &GroundTruth, x: usize, y: usize| g.low_texture[y * w + x];
            // Top row: the open scene's wall reaches it; in the room it is ceiling.
            let top = |g: &GroundTruth| (0..w).filter(|&x| low(g, x, 0)).count();
            assert!(
                top(o) > w / 2,
                "view {v}: the open scene's wall reaches the top"
            );
            assert_eq!(top(r), 0, "view {v}: the room's top row is ceiling");
            // The back wall still fills much of the image, and every ray hits something.
            let wall = r.low_texture.iter().filter(|&&l| l).count();
            assert!(wall > w * h / 10, "view {v}: back wall {wall} pixels");
            assert!(r.depth.iter().all(|&d| d > 0.0), "view {v}: a closed room");
            // A side wall meets the back wall in view: some row has back wall with a textured
            // surface to its left or right before the image's border.
            let corner = (0..h / 2).any(|y| {
                let first = (0..w).find(|&x| low(r, x, y));
                let last = (0..w).rev().find(|&x| low(r, x, y));
                matches!((first, last), (Some(a), Some(b)) if a > 0 || b < w - 1)
            });
            assert!(corner, "view {v}: a corner of the back wall in view");
        }
    }

    #[test]
    fn has_every_kind_of_surface() {
        let s = generate(&small()).unwrap();
        let gt = &s.ground_truth[0];
        let n = gt.depth.len() as f64;
        let low = gt.low_texture.iter().filter(|&&l| l).count() as f64 / n;
        let valid = gt.depth.iter().filter(|&&d| d > 0.0).count() as f64 / n;
        assert!(low > 0.15 && low < 0.7, "low-texture share {low}");
        assert!(valid > 0.99, "every ray should hit something: {valid}");
        // The low-texture wall really is low-texture: its local intensity spread is far below
        // that of the textured surfaces.
        let img = &s.scene.views[0].image;
        let spread = |want_low: bool| {
            let mut sum = 0.0;
            let mut count = 0.0;
            for y in 1..71usize {
                for x in 1..95usize {
                    let i = y * 96 + x;
                    let all_same = [i - 1, i + 1, i - 96, i + 96]
                        .iter()
                        .all(|&j| gt.low_texture[j] == want_low);
                    if gt.low_texture[i] == want_low && all_same {
                        sum += (img.gray[i + 1] - img.gray[i - 1]).abs() as f64;
                        count += 1.0;
                    }
                }
            }
            sum / count
        };
        let (lo, hi) = (spread(true), spread(false));
        assert!(lo * 4.0 < hi, "low-texture gradient {lo} vs textured {hi}");
        // Normals are unit length and face the camera.
        for (i, n) in gt.normal_world.iter().enumerate().step_by(97) {
            let n = glam::Vec3::from_array(*n).as_dvec3();
            assert!((n.length() - 1.0).abs() < 1e-5);
            let x = (i % 96) as f64;
            let y = (i / 96) as f64;
            let ray = s.scene.views[0]
                .camera
                .dir_world_from_camera(s.scene.views[0].camera.ray_in_camera(DVec2::new(x, y)));
            assert!(n.dot(ray) < 0.0);
        }
    }

    #[test]
    fn sources_are_neighbours_on_the_arc() {
        let s = generate(&SyntheticOptions {
            views: 5,
            ..small()
        })
        .unwrap();
        let first = &s.scene.views[2].sources;
        assert!(!first.is_empty());
        let best = first[0].index;
        assert!(best == 1 || best == 3, "{first:?}");
    }

    #[test]
    fn refuses_degenerate_requests() {
        assert!(
            generate(&SyntheticOptions {
                views: 1,
                ..small()
            })
            .is_err()
        );
        assert!(
            generate(&SyntheticOptions {
                width: 4,
                ..small()
            })
            .is_err()
        );
    }
}
