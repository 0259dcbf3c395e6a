// Pinhole camera shared by every pass. Keep in sync with `GpuCamera` in src/gpu/types.rs.
// Conventions (src/camera.rs): pixel centres on integer coordinates, X_cam = R X_world + t,
// depth = camera z.

struct Camera {
    // fx, fy, cx, cy
    k: vec4<f32>,
    // Rows of R (camera_from_world), w unused.
    r0: vec4<f32>,
    r1: vec4<f32>,
    r2: vec4<f32>,
    // t in xyz; w unused.
    t: vec4<f32>,
    // width, height, 0, 0
    size: vec4<u32>,
}

fn camera_from_world(cam: Camera, p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(cam.r0.xyz, p), dot(cam.r1.xyz, p), dot(cam.r2.xyz, p)) + cam.t.xyz;
}

fn world_from_camera(cam: Camera, p: vec3<f32>) -> vec3<f32> {
    let q = p - cam.t.xyz;
    return cam.r0.xyz * q.x + cam.r1.xyz * q.y + cam.r2.xyz * q.z;
}

// Pixel coordinates of a camera-frame point (caller checks z > 0).
fn pixel_from_camera(cam: Camera, p: vec3<f32>) -> vec2<f32> {
    return vec2<f32>(cam.k.x * p.x / p.z + cam.k.z, cam.k.y * p.y / p.z + cam.k.w);
}

// Camera-frame ray through a pixel with z = 1.
fn ray_in_camera(cam: Camera, pixel: vec2<f32>) -> vec3<f32> {
    return vec3<f32>((pixel.x - cam.k.z) / cam.k.x, (pixel.y - cam.k.w) / cam.k.y, 1.0);
}

// Whether pixel coordinates fall on the image (inside the outer pixel borders).
fn camera_contains(cam: Camera, pixel: vec2<f32>) -> bool {
    let size = vec2<f32>(cam.size.xy);
    return all(pixel >= vec2<f32>(-0.5)) && all(pixel < size - vec2<f32>(0.5));
}
