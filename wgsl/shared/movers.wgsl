// Instances that move over a span of frames, as boxes that turn with them, and whether a ray or a
// point's shadow rays can meet one of them: the test behind every reuse of traced
// radiance across frames (reprojection, plane refresh). The including pass declares
// `moving: array<MovingBounds>` and a `params` uniform with `moving_count` and the world
// box around every mover's, `movers_lo` and `movers_hi`.
//!include shared/shading.wgsl

// An instance that moves over the span: its mesh box in its own space (slightly
// enlarged), a world box around that box at both ends, and the rows of its affine
// world-to-instance transform at the span's first and last frames (Rust:
// temporal::motion::MovingBounds). Only the two ends matter: what was traced at the start
// is compared with the scene at the end.
struct MovingBounds {
    world_lo: vec4f,   // world box around both: a quick reject
    world_hi: vec4f,
    lo: vec4f,
    hi: vec4f,
    start: array<vec4f, 3>,
    end: array<vec4f, 3>,
}

// Whether the ray o + x d, x in [0, x_max], meets the box lo..hi (slab test).
fn segment_meets_box(o: vec3f, d: vec3f, x_max: f32, lo: vec3f, hi: vec3f) -> bool {
    // Axis-parallel rays: a huge finite inverse keeps the slabs free of NaN.
    let inv = 1.0 / select(d, vec3f(1.0e-30), abs(d) < vec3f(1.0e-30));
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let near = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), 0.0));
    let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), x_max));
    return near <= far;
}

// The segment o + x d, x in [0, x_max], in instance space (an affine map keeps x).
fn segment_meets_instance_box(o: vec3f, d: vec3f, x_max: f32, r0: vec4f, r1: vec4f, r2: vec4f,
                              lo: vec3f, hi: vec3f) -> bool {
    let lo_o = vec3f(dot(r0.xyz, o) + r0.w, dot(r1.xyz, o) + r1.w, dot(r2.xyz, o) + r2.w);
    let lo_d = vec3f(dot(r0.xyz, d), dot(r1.xyz, d), dot(r2.xyz, d));
    return segment_meets_box(lo_o, lo_d, x_max, lo, hi);
}

// Whether the segment meets mover i's box at the start or at the end of the span. Reads
// the world box first and the rest only when needed (loading the whole struct for every
// segment costs lavapipe noticeably).
fn segment_meets_mover(o: vec3f, d: vec3f, x_max: f32, i: u32) -> bool {
    if !segment_meets_box(o, d, x_max, moving[i].world_lo.xyz, moving[i].world_hi.xyz) {
        return false;
    }
    let lo = moving[i].lo.xyz;
    let hi = moving[i].hi.xyz;
    return segment_meets_instance_box(o, d, x_max, moving[i].start[0], moving[i].start[1], moving[i].start[2], lo, hi)
        || segment_meets_instance_box(o, d, x_max, moving[i].end[0], moving[i].end[1], moving[i].end[2], lo, hi);
}

fn meets_a_mover(o: vec3f, d: vec3f, x_max: f32) -> bool {
    for (var i = 0u; i < params.moving_count; i++) {
        if segment_meets_mover(o, d, x_max, i) {
            return true;
        }
    }
    return false;
}

// Whether the box lo..hi lies entirely on the positive side of the plane through `p` with
// normal `n` (the box corner furthest towards -n is still in front).
fn box_in_front(lo: vec3f, hi: vec3f, p: vec3f, n: vec3f) -> bool {
    return dot(n, select(hi, lo, n > vec3f(0.0)) - p) > 0.0;
}

// The pyramid from an apex to a parallelogram (every shadow ray to a rect light): its
// bounding box and the outward normals of its four sides.
struct Pyramid {
    apex: vec3f,
    lo: vec3f,
    hi: vec3f,
    n0: vec3f,
    n1: vec3f,
    n2: vec3f,
    n3: vec3f,
}

fn pyramid(apex: vec3f, corner: vec3f, eu: vec3f, ev: vec3f) -> Pyramid {
    let c0 = corner;
    let c1 = corner + eu;
    let c2 = corner + eu + ev;
    let c3 = corner + ev;
    // Side normals point away from the parallelogram's centre.
    let inward = corner + 0.5 * (eu + ev) - apex;
    let n0 = cross(c0 - apex, c1 - apex);
    let n1 = cross(c1 - apex, c2 - apex);
    let n2 = cross(c2 - apex, c3 - apex);
    let n3 = cross(c3 - apex, c0 - apex);
    return Pyramid(
        apex,
        min(min(apex, c0), min(min(c1, c2), c3)),
        max(max(apex, c0), max(max(c1, c2), c3)),
        select(n0, -n0, dot(n0, inward) > 0.0),
        select(n1, -n1, dot(n1, inward) > 0.0),
        select(n2, -n2, dot(n2, inward) > 0.0),
        select(n3, -n3, dot(n3, inward) > 0.0),
    );
}

// Whether the pyramid may meet mover i's world box.
fn pyramid_meets_mover(p: Pyramid, i: u32) -> bool {
    return pyramid_meets_box(p, moving[i].world_lo.xyz, moving[i].world_hi.xyz);
}

// Whether the pyramid may meet the box blo..bhi: separating axes from the box's faces (the
// bounding boxes overlap) and from the pyramid's four sides. Conservative: a box it clears
// misses the pyramid.
fn pyramid_meets_box(p: Pyramid, blo: vec3f, bhi: vec3f) -> bool {
    if !(all(p.lo <= bhi) && all(p.hi >= blo)) {
        return false;
    }
    return !(box_in_front(blo, bhi, p.apex, p.n0) || box_in_front(blo, bhi, p.apex, p.n1)
        || box_in_front(blo, bhi, p.apex, p.n2) || box_in_front(blo, bhi, p.apex, p.n3));
}

// At most this many movers near one shadow pyramid are tested ray by ray; with more, the
// shadows are taken as changed (conservative).
const NEAR_MOVERS: u32 = 8u;

// Whether any shadow ray `shadow_loop_start_at(s, seed, first, count)` may trace passes
// through the box of an instance that moves over the span. When none does (and the
// lights and s itself do not move), every shadow ray has the same outcome at the end of
// the span as at its start, so the radiance traced then is exactly the radiance now.
// Conservative: it tests every sample, including those the cosine tests would skip.
fn shadows_may_change(s: Surface, seed: u32, first: u32, count: u32) -> bool {
    if params.moving_count == 0u {
        return false;
    }
    let origin = offset_ray_origin(s.position, s.geometric_normal);
    for (var li = 0u; li < scene_info.light_count; li++) {
        let light = lights[li];
        let kind = bitcast<u32>(light.a.w);
        // (The kinds a pipeline does not shade are left out: shared/shading.wgsl.)
        if (SHADES_POINT || SHADES_SPOT) && (kind == LIGHT_POINT || kind == LIGHT_SPOT) {
            if meets_a_mover(origin, light.a.xyz - origin, 1.0) {
                return true;
            }
        } else if SHADES_SUN && kind == LIGHT_SUN {
            if meets_a_mover(origin, light.a.xyz, INF) {
                return true;
            }
        } else if SHADES_RECT && kind == LIGHT_RECT {
            // Every shadow ray lies in the pyramid from the origin to the rectangle: only
            // the movers whose world box it meets can change one, and with many movers
            // (bouncing spheres) those are few.
            let p = pyramid(origin, light.a.xyz, light.b.xyz, light.c.xyz);
            // One test against the box around every mover first: from most points the
            // pyramid clears the whole group (a uniform, no per-mover loads).
            if !pyramid_meets_box(p, params.movers_lo.xyz, params.movers_hi.xyz) {
                continue;
            }
            var near: array<u32, NEAR_MOVERS>;
            var n = 0u;
            for (var i = 0u; i < params.moving_count; i++) {
                if pyramid_meets_mover(p, i) {
                    if n == NEAR_MOVERS {
                        return true;
                    }
                    near[n] = i;
                    n++;
                }
            }
            if n == 0u {
                continue;
            }
            let light_seed = hash_combine(seed, li);
            for (var k = 0u; k < count; k++) {
                let d = rect_light_point(light, s.position, first + k, light_seed) - origin;
                for (var j = 0u; j < n; j++) {
                    if segment_meets_mover(origin, d, 1.0, near[j]) {
                        return true;
                    }
                }
            }
        }
    }
    // A map's importance-sampled directions are not mirrored here: assume a change.
    if SHADES_ENVIRONMENT && has_environment_map() {
        return true;
    }
    if SHADES_ENVIRONMENT && any(scene_info.environment != vec3f(0.0)) {
        let frame = orthonormal_basis(s.shading_normal);
        let env_seed = hash_combine(seed, ENVIRONMENT_SEED);
        for (var k = 0u; k < count; k++) {
            let dir = frame * cosine_hemisphere(sobol_2d(first + k, env_seed));
            if meets_a_mover(origin, dir, INF) {
                return true;
            }
        }
    }
    return false;
}
