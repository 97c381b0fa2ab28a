// Plane refresh, step 2 of 2: trace again the samples step 1 (plane_refresh.wgsl) listed,
// exactly as the plane pass would (shared/plane.wgsl), over the retained plane. An
// indirect dispatch of 64-invocation groups over the list; each item writes only its own
// sample.
//!include shared/plane.wgsl
//!include shared/bounce_cache.wgsl
//!include shared/work_items.wgsl

struct PlaneParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    record_hits: u32,
    light_choices: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> params: PlaneParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> plane: array<PlanePixel>;
@group(1) @binding(3) var<storage, read_write> samples: array<PlaneSample>;
@group(1) @binding(4) var<storage, read_write> hits: array<PlaneHit>;
@group(1) @binding(5) var<storage, read> work: WorkItems;   // samples to trace again
@group(1) @binding(6) var<storage, read> light_maps: array<LightMap>;
@group(1) @binding(7) var<storage, read> light_map_depths: array<f32>;
@group(1) @binding(8) var<storage, read> light_map_first: array<u32>;
@group(1) @binding(9) var<storage, read> bounce_cache: array<u32>;

// Secondary hits reflect the surface bounce cache's indirect irradiance (zero with one
// bounce: the cache is then empty).
fn hit_indirect_irradiance(shaded: ShadedHit, seed: u32, k: u32) -> vec3f {
    return bounce_irradiance(shaded.hit, shaded.surface.front_face);
}

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
    let traced = trace_plane_sample(sites[sample / plane_size], sample % plane_size);
    samples[sample] = traced.sample;
    hits[sample] = traced.hit;
}
