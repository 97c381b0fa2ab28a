// Hemisphere planes (thesis section 4.4, algorithms.md 3.2): for each record of a batch,
// one ray per plane pixel through (x, y, 1) in the record's tangent frame. Each hit is
// shaded with direct light (shadow rays) plus emission not already sampled as a light.
// Misses add nothing: the constant environment is sampled as a light by direct lighting
// (at the pixel and at every plane hit), so counting it again here would double it (Ward's
// "count as zero any samples that intersect a light source"; decision 7's "misses see the
// environment" holds for an environment that is not a light). One invocation per
// (pixel, record).
//!include shared/shading.wgsl
//!include shared/records.wgsl

struct PlaneParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    record_hits: u32,   // 1: also write each sample's hit (temporal reprojection)
}

@group(1) @binding(0) var<uniform> params: PlaneParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> plane: array<PlanePixel>;
@group(1) @binding(3) var<storage, read_write> samples: array<PlaneSample>;
@group(1) @binding(4) var<storage, read_write> hits: array<PlaneHit>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let res = params.resolution;
    if id.x >= res || id.y >= res || id.z >= params.count {
        return;
    }
    let pixel = id.y * res + id.x;
    let site = sites[id.z];
    let frame = orthonormal_basis(site.normal);
    let dir = normalize(frame * vec3f(plane[pixel].rot_center.zw, 1.0));
    var out: PlaneSample;
    out.radiance = vec3f(0.0);
    out.depth = -1.0;
    var hit_out = PlaneHit(NO_HIT, 0u, 0.0, 0.0);
    // Directions below the geometric surface (shading normals differ from it) see the
    // surface itself: no light, no distance.
    if dot(dir, site.geometric_normal) > 0.0 {
        let origin = offset_ray_origin(site.position, site.geometric_normal);
        let hit = trace_closest(Ray(origin, 0.0, dir, INF));
        if hit.instance != NO_HIT {
            let s = surface_at(hit, dir);
            let e = direct_irradiance_samples(s, hash_combine(site.seed, pixel), params.light_samples);
            out.radiance = surface_albedo(s) * (1.0 / PI) * e + indirect_emission(s);
            out.depth = hit.t * dot(dir, site.normal);
            hit_out = PlaneHit(hit.instance, hit.triangle, hit.u, hit.v);
        }
    }
    samples[id.z * res * res + pixel] = out;
    if params.record_hits != 0u {
        hits[id.z * res * res + pixel] = hit_out;
    }
}
