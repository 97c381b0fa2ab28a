// Hemisphere planes (thesis section 4.4, algorithms.md 3.2) and their adaptive refinement
// (Radiance's -as, algorithms.md 1.7), in one pipeline: tracing and shading a plane ray
// (shared/plane.wgsl) is the largest code radsplat compiles, and lavapipe inlines it at
// every call, so both share one call site and one build (a pipeline of its own cost the
// nave's start-up about 35 ms). No loop holds that call: on lavapipe a loop around it made
// every ray 1.2-1.5x as slow, whether the loop ran once or four times.
//
// Tracing (params.mode = MODE_TRACE): for each record of a batch, one ray per plane pixel
// through (x, y, 1) in the record's tangent frame, its hit shaded with direct light (shadow
// rays or light maps) plus emission not already sampled as a light. One invocation per
// (pixel, record).
//
// Refining (MODE_REFINE): for each pixel plane_refine_select.wgsl selected, `split^2`
// more rays through the pixel's strata (the plane table's entries after its P^2 pixels,
// records::PlaneTable), and the pixel's sample replaced by the weighted mean of its centre
// ray and those: radiance `L_c w_c + sum L_i w_i`, depth the same weighted harmonic mean of
// the hit depths (misses add 0 to the sum of 1/Z, as in R), so the reduction
// (record_reduce.wgsl) reads refined pixels. One invocation per stratum ray: a workgroup
// holds `per_group` pixels' strata, and each pixel's first invocation sums them in stratum
// order once all have traced (the same sums, in the same order, as
// records::refine::refine_plane). One workgroup per item the selection appended after the
// batch's selections (a record and which of its workgroups; an indirect dispatch the
// selection sized): a lit plane's selected pixels (up to K), a dark plane's (DARK_PLANE:
// all of them; DARK_GUIDED: those listed). So a plane with many pixels costs no workgroups
// on the others, a plane with none costs none (a dispatch of K pixels a record gave every
// dark plane K idle lanes' workgroups), and no plane idles on the largest.
//!include shared/plane.wgsl
//!include shared/bounce_cache.wgsl

// Rust: records::PlaneParams.
struct PlaneParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    record_hits: u32,   // 1: also write each sample's hit (temporal reprojection)
    light_choices: u32, // lights sampled per hit (`shadow_loop_start_chosen`; 0: all)
    record_noise: u32,  // 1: also write each sample's environment-sampled share (`noise`)
    mode: u32,          // MODE_*
    refined: u32,       // K selected pixels per lit plane
    subsamples: u32,    // split^2 strata per pixel
    centre_weight: f32, // 1 / (1 + split^2)
    slots: u32,         // selection slots per record (RefinePass::slots)
    per_group: u32,     // refined pixels per workgroup: 64 / split^2
}

const MODE_TRACE: u32 = 0u;
const MODE_REFINE: u32 = 1u;

// Every slot of a dark plane's selection (plane_refine_select.wgsl).
const DARK_PLANE: u32 = 0xffffffffu;
// A dark plane refined only at the pixels its selection lists: slot 1 holds their count,
// slots 2.. the pixels (records::refine::DARK_GUIDED).
const DARK_GUIDED: u32 = 0xfffffffdu;
// A lit plane's selection slot past its last pixel (records::refine::UNUSED_SLOT).
const UNUSED_SLOT: u32 = 0xfffffffcu;

@group(1) @binding(0) var<uniform> params: PlaneParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
// The plane's P^2 pixels, then each pixel's `subsamples` strata (centre: rot_center.zw,
// weight in the refined pixel: weights.x).
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
// Refining: the selection (plane_refine_select.wgsl), `slots` per record, then the records
// of the planes that saw no light.
@group(1) @binding(10) var<storage, read> selected: array<u32>;

// Secondary hits reflect the surface bounce cache's indirect irradiance (zero with one
// bounce: the cache is then empty).
fn hit_indirect_irradiance(shaded: ShadedHit, seed: u32, k: u32) -> vec3f {
    return bounce_irradiance(shaded.hit, shaded.surface.front_face);
}

// 64 invocations a workgroup. Tracing: the plane's pixels in scan order, no idle lanes but
// the last few of each record's plane, whatever P (8 x 8 tiles of a 17 x 17 plane, the
// tail's at the defaults, left a SIMD group with one live lane at the end of every row);
// where P is a multiple of 4 (the default 24), in blocks of 4 x 2 pixels, one a SIMD group
// of eight lanes, still without idle lanes: their rays' directions are closer than a row's
// eight, so they walk more of the BVH together (Sponza's planes 0.973 [0.917, 0.988] of
// their time, 6 pairs; the nave's 0.985; the same samples, each pixel traced as before).
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) group: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let n = params.resolution * params.resolution;
    let refining = params.mode != MODE_TRACE;
    // The record and its workgroup (uniform over the workgroup: the barrier below needs
    // it).
    var record = group.z;
    var g = group.x;
    if refining {
        // The list holds up to ceil(P^2 / per_group) items a record, zeros past its end.
        let i = group.x + group.y * 65535u;
        let capacity = params.count * ((n + params.per_group - 1u) / params.per_group);
        if i >= capacity {
            return;     // past the list in the last row
        }
        let item = selected[params.count * params.slots + i];
        if item == 0u {
            return;     // past the last item
        }
        record = (item - 1u) & 0xffffu;
        g = (item - 1u) >> 16u;
    } else if group.z >= params.count {
        return;
    }
    let base = record * n;
    let row = record * params.slots;
    // This invocation's ray: pixel k's centre ray, or its stratum q.
    var k = g * 64u + lane;
    var q = 0u;
    var work = k < n;
    let res = params.resolution;
    if !refining && res % 4u == 0u {
        // Invocation i traces pixel (px, py) of 4 x 2 block i / 8, the blocks in scan order.
        let i = g * 64u + lane;
        let block = i / 8u;
        let within = i % 8u;
        let per_row = res / 4u;
        let px = (block % per_row) * 4u + within % 4u;
        let py = (block / per_row) * 2u + within / 4u;
        k = py * res + px;
        work = py < res;
    }
    if refining {
        let first_slot = selected[row];
        // Slot j of the selection: a lit plane's K, a guided plane's listed pixels, or
        // every pixel of a plane refined everywhere.
        let j = g * params.per_group + lane / params.subsamples;
        q = lane % params.subsamples;
        var count = params.refined;
        if first_slot == DARK_GUIDED {
            count = selected[row + 1u];
        } else if first_slot == DARK_PLANE {
            count = n;
        }
        work = lane < params.per_group * params.subsamples && j < count;
        if first_slot == DARK_GUIDED {
            k = selected[row + 2u + min(j, n - 1u)];
        } else if first_slot == DARK_PLANE {
            k = j;
        } else {
            k = selected[row + min(j, params.refined - 1u)];
            if k == UNUSED_SLOT {
                // Past a lit plane's last pixel (fewer than K near light).
                work = false;
                k = 0u;
            }
        }
    }
    var traced = TracedSample(PlaneSample(vec3f(0.0), -1.0), PlaneHit(NO_HIT, 0u, 0.0, 0.0), 0.0);
    if work {
        // Refining: stratum q of pixel k, numbered past the pixels for its light samples.
        let stratum = n + k * params.subsamples + q;
        var xy = plane[k].rot_center.zw;
        var index = k;
        if refining {
            xy = plane[stratum].rot_center.zw;
            index = stratum;
        }
        let site = sites[record];
        traced = trace_plane_ray(site, plane_point_direction(site, xy), index);
    }
    if !refining {
        if work {
            samples[base + k] = traced.sample;
            if params.record_hits != 0u {
                hits[base + k] = traced.hit;
            }
            if params.record_noise != 0u {
                noise[base + k] = traced.noise;
            }
        }
        return;
    }
    bvh_slice_store(lane, vec4f(traced.sample.radiance, traced.sample.depth));
    workgroupBarrier();
    if work && q == 0u {
        let centre = samples[base + k];
        var radiance = centre.radiance * params.centre_weight;
        var inv_depth = select(0.0, params.centre_weight / centre.depth, centre.depth > 0.0);
        for (var t = 0u; t < params.subsamples; t++) {
            let s = bvh_slice_load(lane + t);
            let weight = plane[n + k * params.subsamples + t].weights.x;
            radiance += s.xyz * weight;
            if s.w > 0.0 {
                inv_depth += weight / s.w;
            }
        }
        samples[base + k] = PlaneSample(radiance, select(-1.0, 1.0 / inv_depth, inv_depth > 0.0));
    }
}
