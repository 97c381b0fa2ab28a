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
// records::PlaneTable), each stratum's radiance and depth kept in `per_ray`;
// plane_refine_combine.wgsl then replaces the pixel's sample by the weighted mean of its
// centre ray and those. One invocation per stratum ray: a workgroup holds `per_group`
// pixels' strata (shared/plane_refine_items.wgsl). One workgroup per item the selection
// appended after the batch's selections (a record and which of its workgroups; an
// indirect dispatch the selection sized): a lit plane's selected pixels (up to K), a dark
// plane's (DARK_PLANE: all of them; DARK_GUIDED: those listed). So a plane with many
// pixels costs no workgroups on the others, a plane with none costs none (a dispatch of K
// pixels a record gave every dark plane K idle lanes' workgroups), and no plane idles on
// the largest. The sums are a pass of their own so that this one has no barrier:
// lavapipe runs a shader with a barrier as coroutines, and the plane rays traced 1.10x as
// many instructions with one (nave-west, refinement off; the same bytes).
//!include shared/plane.wgsl
//!include shared/bounce_cache.wgsl

//!include shared/plane_refine_items.wgsl
//!include shared/texel_table.wgsl

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
// Tracing: per sample, the channel sum of what its environment samples gave it
// (TracedSample.noise), for refinement's selection. Refining: per stratum ray, its
// radiance and depth (`stratum_offset`), for plane_refine_combine.wgsl.
@group(1) @binding(9) var<storage, read_write> per_ray: array<f32>;
// Refining: the selection (plane_refine_select.wgsl), `slots` per record, then the records
// of the planes that saw no light.
@group(1) @binding(10) var<storage, read> selected: array<u32>;
// With TABLE_TEXELS (shared/texel_table.wgsl): `sites` as a texel table, three rows a site,
// and `plane`, two rows a pixel. Every ray reads its site's 12 words (storage loads are a
// per-lane loop on lavapipe): from texels nave-west's plane rays took 0.96 of their time
// and their refinement 0.94, the Cornell box's 0.88 and 0.91. (Per-hit tables, inside the
// trace, are another matter: a texel fetch is a call that spills the shadow loop's
// registers; the lights from the node texture made both passes slower, 1.06 and 1.05.)
@group(1) @binding(11) var site_texels: texture_2d<u32>;
@group(1) @binding(12) var pixel_texels: texture_2d<u32>;

// The batch's site `record`.
fn plane_site(record: u32) -> RecordSite {
    if TABLE_TEXELS {
        let a = texel_row(site_texels, 3u * record);
        let b = texel_row(site_texels, 3u * record + 1u);
        let c = texel_row(site_texels, 3u * record + 2u);
        return RecordSite(bitcast<vec3f>(a.xyz), bitcast<f32>(a.w), bitcast<vec3f>(b.xyz), b.w,
                          bitcast<vec3f>(c.xyz), c.w);
    }
    return sites[record];
}

// The centre on the plane of the plane table's entry `k` (a pixel, or past the pixels a
// stratum).
fn plane_entry_centre(k: u32) -> vec2f {
    if TABLE_TEXELS {
        return bitcast<vec2f>(texel_row(pixel_texels, 2u * k + 1u).zw);
    }
    return plane[k].rot_center.zw;
}

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
    // The record and its workgroup; refining, the list item and the stratum ray.
    var record = group.z;
    var g = group.x;
    var stratum = RefineStratum(false, 0u, 0u, 0u, 0u, false);
    if refining {
        stratum = refine_stratum(group, lane);
        if !stratum.listed {
            return;
        }
        record = stratum.record;
    } else if group.z >= params.count {
        return;
    }
    let base = record * n;
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
        k = stratum.k;
        q = stratum.q;
        work = stratum.work;
    }
    var traced = TracedSample(PlaneSample(vec3f(0.0), -1.0), PlaneHit(NO_HIT, 0u, 0.0, 0.0), 0.0);
    if work {
        // Refining: stratum q of pixel k, numbered past the pixels for its light samples.
        let strat = n + k * params.subsamples + q;
        var index = k;
        if refining {
            index = strat;
        }
        let xy = plane_entry_centre(index);
        let site = plane_site(record);
        traced = trace_plane_ray(site, plane_point_direction(site, xy), index);
    }
    if !refining {
        if work {
            samples[base + k] = traced.sample;
            if params.record_hits != 0u {
                hits[base + k] = traced.hit;
            }
            if params.record_noise != 0u {
                per_ray[base + k] = traced.noise;
            }
        }
        return;
    }
    if work {
        let o = stratum_offset(stratum.item, lane);
        per_ray[o] = traced.sample.radiance.x;
        per_ray[o + 1u] = traced.sample.radiance.y;
        per_ray[o + 2u] = traced.sample.radiance.z;
        per_ray[o + 3u] = traced.sample.depth;
    }
}
