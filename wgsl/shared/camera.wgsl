// Pinhole camera and the visibility-buffer sample layout, shared by every per-pixel pass.

struct Camera {
    origin: vec3f,
    width: u32,
    forward: vec3f,
    height: u32,
    right: vec3f,    // scaled by tan(fov_y / 2) * aspect
    tmin: f32,       // where camera rays start (visibility::GpuCamera::tmin)
    up: vec3f,       // scaled by tan(fov_y / 2)
    _pad1: u32,
}

// Unit direction through the centre of pixel (x, y); y grows downwards.
fn camera_ray_dir(cam: Camera, px: vec2u) -> vec3f {
    let ndc = vec2f(
        2.0 * (f32(px.x) + 0.5) / f32(cam.width) - 1.0,
        1.0 - 2.0 * (f32(px.y) + 0.5) / f32(cam.height),
    );
    return normalize(cam.forward + ndc.x * cam.right + ndc.y * cam.up);
}

// One pixel of the visibility buffer (64 bytes; Rust mirror: visibility::VisSample).
struct VisSample {
    position: vec3f,
    t: f32,                  // distance along the unit camera ray; < 0 on a miss
    shading_normal: vec3f,
    instance: u32,           // NO_HIT on a miss
    geometric_normal: vec3f,
    mesh_triangle: u32,      // triangle index within the instance's mesh
    bary: vec2f,             // barycentrics of v1, v2
    material: u32,
    triangle: u32,           // absolute triangle index (BVH leaf order) for shading data
}
