// One hemisphere-plane sample (thesis section 4.4, algorithms.md 3.2), shared by the
// plane pass (hemisphere_plane.wgsl) and the plane refresh's re-trace
// (plane_retrace.wgsl), which must give the same bytes. The including pass declares
// `plane: array<PlanePixel>` (the plane table), a `params` uniform with a
// `light_samples` and a `light_choices` field, the light-map bindings of shared/light_map_lookup.wgsl and
// `hit_indirect_irradiance` (shared/trace_and_shade.wgsl).
//!include shared/trace_and_shade.wgsl
//!include shared/light_map_lookup.wgsl
//!include shared/plane_direction.wgsl

struct TracedSample {
    sample: PlaneSample,
    hit: PlaneHit,
    // The channel sum of the radiance the hit's environment samples gave it: noise that
    // adaptive refinement must not chase (plane_refine_select.wgsl).
    noise: f32,
}

// Plane hits look shadows up in the frame's light maps where it has them
// (`light_map_visibility`).
fn shadow_from_maps(st: ShadowLoop, s: Surface) -> f32 {
    return light_map_visibility(st, s);
}

// One ray through plane pixel `pixel` of the record at `site`, its hit shaded with direct
// light from the lights chosen by weight (`shadow_loop_start_chosen`; shadow rays or
// light-map lookups) plus emission not already sampled as a light. Misses add nothing:
// the constant environment is sampled as a light by direct lighting (at the pixel and at
// every plane hit), so counting it again here would double it (Ward's "count as zero any
// samples that intersect a light source"; decision 7's "misses see the environment" holds
// for an environment that is not a light).
fn trace_plane_sample(site: RecordSite, pixel: u32) -> TracedSample {
    return trace_plane_ray(site, plane_direction(site, pixel), pixel);
}

// The same for any direction `dir` (world space) above the record, as plane sample `index`
// of the record: its hit's light samples are those of `plane_light_first(index, count)` on
// (adaptive refinement's sub-samples, hemisphere_plane.wgsl, number theirs past the pixels).
fn trace_plane_ray(site: RecordSite, dir: vec3f, index: u32) -> TracedSample {
    var out = TracedSample(PlaneSample(vec3f(0.0), -1.0), PlaneHit(NO_HIT, 0u, 0.0, 0.0), 0.0);
    // Directions below the geometric surface (shading normals differ from it) see the
    // surface itself: no light, no distance.
    if dot(dir, site.geometric_normal) > 0.0 {
        let origin = offset_ray_origin(site.position, site.geometric_normal);
        // The ray and its hit's shadow rays through one traversal (cheaper to compile).
        let shaded = trace_and_shade_at(
            Ray(origin, 0.0, dir, INF), site.seed, plane_light_first(index, params.light_samples),
            params.light_samples, params.light_choices);
        let hit = shaded.hit;
        if hit.instance != NO_HIT {
            let albedo = surface_albedo(shaded.surface);
            out.sample.radiance = hit_radiance_with_albedo(shaded, albedo, site.seed, index);
            let sampled = albedo * (1.0 / PI) * shaded.env_irradiance;
            out.noise = (sampled.x + sampled.y) + sampled.z;
            out.sample.depth = hit.t * dot(dir, site.normal);
            out.hit = PlaneHit(hit.instance, hit.triangle, hit.u, hit.v);
        }
    }
    return out;
}
