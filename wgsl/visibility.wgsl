// Visibility pass: one camera ray per pixel, writing what every later pass needs.
//!include shared/shading.wgsl
//!include shared/camera.wgsl

@group(1) @binding(0) var<uniform> camera: Camera;
@group(1) @binding(1) var<storage, read_write> vis: array<VisSample>;

@compute @workgroup_size(8, 8)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    if id.x >= camera.width || id.y >= camera.height {
        return;
    }
    let dir = camera_ray_dir(camera, id.xy);
    let hit = trace_closest(Ray(camera.origin, camera.tmin, dir, INF));
    var out: VisSample;
    if hit.instance == NO_HIT {
        out.t = -1.0;
        out.instance = NO_HIT;
        out.triangle = NO_HIT;
        out.mesh_triangle = NO_HIT;
        out.material = NO_HIT;
    } else {
        let s = surface_at(hit, dir);
        out.position = s.position;
        out.t = hit.t;
        out.shading_normal = s.shading_normal;
        out.instance = hit.instance;
        out.geometric_normal = s.geometric_normal;
        out.mesh_triangle = s.mesh_triangle;
        out.bary = vec2f(hit.u, hit.v);
        out.material = s.material;
        out.triangle = hit.triangle;
    }
    vis[id.y * camera.width + id.x] = out;
}
