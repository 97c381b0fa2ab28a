// Temporal reprojection, step 2 of 3: re-shade, with the lights of t+1 (shadow rays in
// the t+1 scene), the plane samples step 1 (plane_reproject.wgsl) could not keep from t.
// An indirect dispatch of 64-invocation groups over step 1's list, so every lane shades;
// each entry writes only its own sample's radiance, so the list's order does not matter.
//!include shared/reprojection.wgsl
//!include shared/work_items.wgsl
//!include shared/bounce_cache.wgsl

@group(1) @binding(0) var<uniform> params: ReprojectParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> hits: array<PlaneHit>;
@group(1) @binding(3) var<storage, read_write> moved: array<vec4f>;   // radiance at t+1, depth
@group(1) @binding(4) var<storage, read> motion: array<InstanceMotion>;
@group(1) @binding(5) var<storage, read> work: WorkItems;   // samples to re-shade
@group(1) @binding(6) var<storage, read> bounce_cache: array<u32>;   // frame t+1's

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let sample = work_item(group, groups, lane);
    if sample == NO_WORK {
        return;
    }
    let plane_size = params.resolution * params.resolution;
    let pixel = sample % plane_size;
    let m = moved_hit(sites[sample / plane_size], hits[sample], pixel);
    // The hit moves with its instance: same triangle and barycentrics at t+1; with
    // `--bounces` above 1 it reflects frame t+1's bounce cache too (as `hit_radiance`).
    let h = hits[sample];
    let e = plane_direct_irradiance(m.surface, m.seed, m.first, params.light_samples,
                                    params.light_choices)
        + bounce_irradiance(Hit(0.0, h.instance, h.triangle, h.u, h.v), m.surface.front_face);
    let radiance = surface_albedo(m.surface) * (1.0 / PI) * e + indirect_emission(m.surface);
    moved[sample] = vec4f(radiance, moved[sample].w);
}
