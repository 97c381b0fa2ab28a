// Temporal reprojection, step 1 of 2 (seed 000 section IV-G, thesis 5.2.4; algorithms.md
// 4.3): estimate a new record's plane at the next frame. Bound with the scene of frame
// t+1 at group 0: each plane sample's hit (instance, triangle, u, v) is rebuilt there,
// which moves it with its instance's transform, and re-shaded with the lights of t+1
// (shadow rays in the t+1 scene). The moved point is projected onto the record's plane
// (the record keeps its world position and frame) and written into that pixel's cell
// with a depth test: the smallest (depth bits, sample index) key wins whatever the thread
// order (stored complemented, atomicMax on cells cleared to 0, so no fill pass is needed). A miss keeps its own pixel at the farthest depth, so any
// surface moving in front of it wins. One invocation per (sample, record).
//!include shared/shading.wgsl
//!include shared/records.wgsl

struct ReprojectParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    stretched: u32,      // 1: border pixels reach infinity (decision 6)
    half_extent: f32,    // tan(fov / 2): the plane spans [-s, s]^2 at z = 1
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> params: ReprojectParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> hits: array<PlaneHit>;
@group(1) @binding(3) var<storage, read_write> cells: array<atomic<u32>>;
@group(1) @binding(4) var<storage, read_write> moved: array<vec4f>;   // radiance at t+1, depth

// Plane pixel of plane coordinate x in [-s, s] (clamped into the border pixels when they
// are stretched); -1 outside an unstretched plane.
fn plane_index(x: f32) -> i32 {
    let res = i32(params.resolution);
    let i = i32(floor((x + params.half_extent) / (2.0 * params.half_extent) * f32(res)));
    if params.stretched != 0u {
        return clamp(i, 0, res - 1);
    }
    return select(-1, i, i >= 0 && i < res);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let res = params.resolution;
    if id.x >= res || id.y >= res || id.z >= params.count {
        return;
    }
    let pixel = id.y * res + id.x;
    let base = id.z * res * res;
    let sample = base + pixel;
    let site = sites[id.z];
    let h = hits[sample];
    if h.instance == NO_HIT {
        atomicMax(&cells[sample], ~reprojection_key(MISS_DEPTH, pixel));
        moved[sample] = vec4f(0.0, 0.0, 0.0, -1.0);
        return;
    }
    let frame = orthonormal_basis(site.normal);
    let origin = offset_ray_origin(site.position, site.geometric_normal);
    // Where the hit point is at t+1 (its triangle, moved with its instance).
    let probe = surface_at(Hit(0.0, h.instance, h.triangle, h.u, h.v), site.normal);
    let to_point = probe.position - origin;
    let s = surface_at(Hit(0.0, h.instance, h.triangle, h.u, h.v), normalize(to_point));
    let e = direct_irradiance_samples(s, hash_combine(site.seed, pixel), params.light_samples);
    let radiance = surface_albedo(s) * (1.0 / PI) * e + indirect_emission(s);
    // Tangent-frame coordinates of the moved point (frame columns are t, b, n).
    let local = vec3f(dot(to_point, frame[0]), dot(to_point, frame[1]), dot(to_point, frame[2]));
    moved[sample] = vec4f(radiance, local.z);
    if local.z <= 0.0 {
        return;   // moved below the record's tangent plane: out of its hemisphere
    }
    let ix = plane_index(local.x / local.z);
    let iy = plane_index(local.y / local.z);
    if ix < 0 || iy < 0 {
        return;
    }
    let cell = base + u32(iy) * res + u32(ix);
    atomicMax(&cells[cell], ~reprojection_key(local.z, pixel));
}
