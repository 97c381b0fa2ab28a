// Adaptive plane refinement, step 2: for each selected pixel of each record
// (plane_refine_select.wgsl), `split^2` more rays through the pixel's strata (the
// `subs` table, records::plane::HemispherePlane::refine_samples), and the pixel's sample
// replaced by the weighted mean of its centre ray and those: radiance
// `L_c w_c + sum L_i w_i`, depth the same weighted harmonic mean of the hit depths (misses
// add 0 to the sum of 1/Z, as in R), so the reduction (record_reduce.wgsl, unchanged)
// reads refined pixels. One invocation per (selected pixel, record). A dark plane's
// selection is DARK_PLANE in every slot: then the record's invocations share all its
// pixels, each refined once (records::refine::refine_plane).
//!include shared/plane.wgsl
//!include shared/bounce_cache.wgsl

struct RefineParams {
    resolution: u32,
    count: u32,
    refined: u32,           // K selected pixels per record (0: dark planes alone)
    light_samples: u32,
    subsamples: u32,        // split^2
    centre_weight: f32,     // 1 / (1 + split^2)
    light_choices: u32,     // lights sampled per hit (`shadow_loop_start_chosen`)
    slots: u32,             // selection slots per record (RefinePass::slots)
}

// Every slot of a dark plane's selection (plane_refine_select.wgsl).
const DARK_PLANE: u32 = 0xffffffffu;
// A selection that refines nothing (records::refine::NO_PIXELS).
const NO_PIXELS: u32 = 0xfffffffeu;
// A dark plane refined only at the pixels its selection lists: slot 1 holds their count,
// slots 2.. the pixels (records::refine::DARK_GUIDED).
const DARK_GUIDED: u32 = 0xfffffffdu;

// Rust: records::plane::RefineSample.
struct RefineSample {
    center: vec2f,
    weight: f32,
    _pad: f32,
}

@group(1) @binding(0) var<uniform> params: RefineParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> plane: array<PlanePixel>;
@group(1) @binding(3) var<storage, read> subs: array<RefineSample>;
@group(1) @binding(4) var<storage, read> selected: array<u32>;
@group(1) @binding(5) var<storage, read_write> samples: array<PlaneSample>;
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
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    if id.z >= params.count {
        return;
    }
    let n = params.resolution * params.resolution;
    let site = sites[id.z];
    let base = id.z * n;
    // One selected pixel per invocation; a dark plane's pixels j, j + L, ... for each of
    // the dispatch's L lanes of the record (K rounded up to whole workgroups), and a guided
    // dark plane's listed pixels the same way: every lane works, and one loop holds the
    // tracing, so that it is compiled once (lavapipe inlines every call of it).
    let row = id.z * params.slots;
    let first_slot = selected[row];
    if first_slot == NO_PIXELS {
        return;     // a dark plane, dark planes not refined
    }
    let guided = first_slot == DARK_GUIDED;
    let dark = first_slot == DARK_PLANE;
    let lanes = ((max(params.refined, 1u) + 63u) / 64u) * 64u;
    var j = id.x;
    var step = lanes;
    var end = n;
    if guided {
        end = selected[row + 1u];
    } else if !dark {
        if id.x >= params.refined {
            return;
        }
        step = 1u;
        end = id.x + 1u;
    }
    for (; j < end; j += step) {
        var k = j;
        if guided {
            k = selected[row + 2u + j];
        } else if !dark {
            k = selected[row + j];
        }
        let centre = samples[base + k];
        var radiance = centre.radiance * params.centre_weight;
        var inv_depth = select(0.0, params.centre_weight / centre.depth, centre.depth > 0.0);
        for (var q = 0u; q < params.subsamples; q++) {
            let sub = subs[k * params.subsamples + q];
            let dir = plane_point_direction(site, sub.center);
            let s = trace_plane_ray(site, dir, n + k * params.subsamples + q).sample;
            radiance += s.radiance * sub.weight;
            if s.depth > 0.0 {
                inv_depth += sub.weight / s.depth;
            }
        }
        samples[base + k] = PlaneSample(radiance, select(-1.0, 1.0 / inv_depth, inv_depth > 0.0));
    }
}
