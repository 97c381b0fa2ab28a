// Rays, hits and robust ray offsets, shared by every pass.

const INF: f32 = 3.0e38;
const NO_HIT: u32 = 0xffffffffu;
const PI: f32 = 3.14159265358979;

struct Ray {
    origin: vec3f,
    tmin: f32,
    dir: vec3f,   // need not be normalised: t is measured in units of |dir|
    tmax: f32,
}

struct Hit {
    t: f32,
    instance: u32,   // NO_HIT on a miss
    triangle: u32,   // absolute index into `triangles` / `shading` (BVH leaf order)
    u: f32,          // barycentric of v1
    v: f32,          // barycentric of v2
}

// Moves a surface point off its surface along the geometric normal by a few ulps of its
// coordinates, so a ray leaving it cannot re-hit the same triangle at any scene scale.
// Wächter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection",
// Ray Tracing Gems ch. 6. `n` must point to the side the ray leaves towards.
fn offset_ray_origin(p: vec3f, n: vec3f) -> vec3f {
    let int_scale = 256.0;
    let float_scale = 1.0 / 65536.0;
    let origin = 1.0 / 32.0;
    let of_i = vec3i(int_scale * n);
    let p_i = vec3f(
        bitcast<f32>(bitcast<i32>(p.x) + select(of_i.x, -of_i.x, p.x < 0.0)),
        bitcast<f32>(bitcast<i32>(p.y) + select(of_i.y, -of_i.y, p.y < 0.0)),
        bitcast<f32>(bitcast<i32>(p.z) + select(of_i.z, -of_i.z, p.z < 0.0)),
    );
    return vec3f(
        select(p_i.x, p.x + float_scale * n.x, abs(p.x) < origin),
        select(p_i.y, p.y + float_scale * n.y, abs(p.y) < origin),
        select(p_i.z, p.z + float_scale * n.z, abs(p.z) < origin),
    );
}
