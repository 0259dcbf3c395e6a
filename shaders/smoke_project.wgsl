// Smoke test of the GPU path: project world points through a camera (shared/camera.wgsl).
#import camera

@group(0) @binding(0) var<uniform> cam: Camera;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
// x, y: pixel; z: depth; w: 1 when in front of the camera and on the image, else 0.
@group(0) @binding(2) var<storage, read_write> projected: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&points) {
        return;
    }
    let p = camera_from_world(cam, points[i].xyz);
    if p.z <= 0.0 {
        projected[i] = vec4<f32>(0.0, 0.0, p.z, 0.0);
        return;
    }
    let pixel = pixel_from_camera(cam, p);
    projected[i] = vec4<f32>(pixel, p.z, select(0.0, 1.0, camera_contains(cam, pixel)));
}
