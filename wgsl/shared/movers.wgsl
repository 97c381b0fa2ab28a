// Instances that move over a span of frames, as world boxes, and whether a ray or a
// point's shadow rays can meet one of them: the test behind every reuse of traced
// radiance across frames (reprojection, plane refresh). The including pass declares
// `moving: array<MovingBounds>` and a `params` uniform with a `moving_count` field.
//!include shared/shading.wgsl

// World box of an instance that moves over the span, covering it at every frame of the
// span, slightly enlarged (Rust: temporal::motion::MovingBounds).
struct MovingBounds {
    lo: vec4f,
    hi: vec4f,
}

// Whether the ray o + x d, x in [0, x_max], meets the box (slab test).
fn segment_meets_box(o: vec3f, d: vec3f, x_max: f32, b: MovingBounds) -> bool {
    // Axis-parallel rays: a huge finite inverse keeps the slabs free of NaN.
    let inv = 1.0 / select(d, vec3f(1.0e-30), abs(d) < vec3f(1.0e-30));
    let t0 = (b.lo.xyz - o) * inv;
    let t1 = (b.hi.xyz - o) * inv;
    let near = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), 0.0));
    let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), x_max));
    return near <= far;
}

fn meets_a_mover(o: vec3f, d: vec3f, x_max: f32) -> bool {
    for (var i = 0u; i < params.moving_count; i++) {
        if segment_meets_box(o, d, x_max, moving[i]) {
            return true;
        }
    }
    return false;
}

// Whether any shadow ray `direct_irradiance_samples(s, seed, count)` may trace passes
// through the box of an instance that moves over the span. When none does (and the
// lights and s itself do not move), every shadow ray has the same outcome at the end of
// the span as at its start, so the radiance traced then is exactly the radiance now.
// Conservative: it tests every sample, including those the cosine tests would skip.
fn shadows_may_change(s: Surface, seed: u32, count: u32) -> bool {
    if params.moving_count == 0u {
        return false;
    }
    let origin = offset_ray_origin(s.position, s.geometric_normal);
    for (var li = 0u; li < scene_info.light_count; li++) {
        let light = lights[li];
        let kind = bitcast<u32>(light.a.w);
        if kind == LIGHT_POINT || kind == LIGHT_SPOT {
            if meets_a_mover(origin, light.a.xyz - origin, 1.0) {
                return true;
            }
        } else if kind == LIGHT_SUN {
            if meets_a_mover(origin, light.a.xyz, INF) {
                return true;
            }
        } else if kind == LIGHT_RECT {
            let light_seed = hash_combine(seed, li);
            for (var k = 0u; k < count; k++) {
                if meets_a_mover(origin, rect_light_point(light, k, light_seed) - origin, 1.0) {
                    return true;
                }
            }
        }
    }
    if any(scene_info.environment != vec3f(0.0)) {
        let frame = orthonormal_basis(s.shading_normal);
        let env_seed = hash_combine(seed, ENVIRONMENT_SEED);
        for (var k = 0u; k < count; k++) {
            let dir = frame * cosine_hemisphere(sobol_2d(k, env_seed));
            if meets_a_mover(origin, dir, INF) {
                return true;
            }
        }
    }
    return false;
}
