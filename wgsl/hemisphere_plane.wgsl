// Hemisphere planes (thesis section 4.4, algorithms.md 3.2): for each record of a batch,
// one ray per plane pixel through (x, y, 1) in the record's tangent frame. Each hit is
// shaded with direct light (shadow rays) plus emission not already sampled as a light.
// The sample itself is shared/plane.wgsl. One invocation per
// (pixel, record).
//!include shared/plane.wgsl
//!include shared/bounce_cache.wgsl

struct PlaneParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    record_hits: u32,   // 1: also write each sample's hit (temporal reprojection)
    light_choices: u32, // lights sampled per hit (`shadow_loop_start_chosen`; 0: all)
    record_noise: u32,  // 1: also write each sample's environment-sampled share (`noise`)
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> params: PlaneParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> plane: array<PlanePixel>;
@group(1) @binding(3) var<storage, read_write> samples: array<PlaneSample>;
@group(1) @binding(4) var<storage, read_write> hits: array<PlaneHit>;
@group(1) @binding(5) var<storage, read> light_maps: array<LightMap>;
@group(1) @binding(6) var<storage, read> light_map_depths: array<f32>;
@group(1) @binding(7) var<storage, read> light_map_first: array<u32>;
@group(1) @binding(8) var<storage, read> bounce_cache: array<u32>;
// Per sample: the channel sum of what its environment samples gave it (TracedSample.noise),
// for refinement's selection.
@group(1) @binding(9) var<storage, read_write> noise: array<f32>;

// Secondary hits reflect the surface bounce cache's indirect irradiance (zero with one
// bounce: the cache is then empty).
fn hit_indirect_irradiance(shaded: ShadedHit, seed: u32, k: u32) -> vec3f {
    return bounce_irradiance(shaded.hit, shaded.surface.front_face);
}

// The plane's pixels in scan order, 64 a workgroup: no idle lanes but the last few of each
// record's plane, whatever P (8 x 8 tiles of a 17 x 17 plane, the tail's at the defaults,
// left a SIMD group with one live lane at the end of every row).
@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let res = params.resolution;
    let pixel = id.x;
    if pixel >= res * res || id.z >= params.count {
        return;
    }
    let traced = trace_plane_sample(sites[id.z], pixel);
    samples[id.z * res * res + pixel] = traced.sample;
    if params.record_hits != 0u {
        hits[id.z * res * res + pixel] = traced.hit;
    }
    if params.record_noise != 0u {
        noise[id.z * res * res + pixel] = traced.noise;
    }
}
