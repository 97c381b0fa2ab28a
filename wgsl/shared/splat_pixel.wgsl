// One pixel's part of a splat gather (splat_gather.wgsl, splat_fill.wgsl): its sums over
// its tile's records in list order, Ward's weight and the gradients' extrapolation, and
// the bindings both gathers share (bindings 0-8; splat_fill adds its pixel list after).
//!include shared/splat_weight.wgsl
//!include shared/texel_table.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read> records: array<Record>;
@group(1) @binding(3) var<storage, read> tile_offsets: array<u32>;
@group(1) @binding(4) var<storage, read> sorted: array<u32>;
@group(1) @binding(5) var<storage, read_write> splat: array<vec4f>;
@group(1) @binding(6) var<storage, read_write> coverage: array<atomic<u32>>;
@group(1) @binding(7) var<storage, read> expiring: array<u32>;   // 1: expires after this frame
// With TABLE_TEXELS: `records` as a texel table, nine rows a record (`record_for_sums`).
@group(1) @binding(8) var record_texels: texture_2d<u32>;

// Record k, whole, for `pixel_add` (from its copy with TABLE_TEXELS: a contributing
// record's 36 words were over half of nave-west's gather as storage loads).
fn record_for_sums(k: u32) -> Record {
    if TABLE_TEXELS {
        var t: array<vec4f, 9>;
        for (var i = 0u; i < 9u; i++) {
            t[i] = bitcast<vec4f>(texel_row(record_texels, 9u * k + i));
        }
        return Record(t[0].xyz, t[0].w, t[1].xyz, t[1].w, t[2].xyz, bitcast<u32>(t[2].w),
                      array<vec4f, 3>(t[3], t[4], t[5]), array<vec4f, 3>(t[6], t[7], t[8]));
    }
    return records[k];
}

// Whether this pipeline counts coverage (`count_coverage` 1 or 2). A still frame counts
// nothing, and its gathers are compiled without the count (src/splat, `GatherPipelines`):
// lavapipe runs a branch on a uniform like any other, lanes masked off, and the count's
// loads and atomic for every record of a tile's list were a fifth of Sponza's gather.
override COUNTS_COVERAGE: bool = true;

const ACCUMULATE: u32 = 1u;
const FILL_EMPTY: u32 = 2u;
const COUNT_ALL: u32 = 1u;
const COUNT_NEEDED: u32 = 2u;

// One pixel's part of the gather.
struct PixelSum {
    pixel: u32,
    writes: bool,    // inside the image and, in tail fill, still empty
    gathers: bool,   // writes and sees a surface
    p: vec3f,
    n: vec3f,
    sum: vec4f,
    survivor: bool,  // a record that outlives this frame contributes here
    lit: bool,       // a record with some irradiance contributes here
}

fn pixel_start(x: u32, y: u32) -> PixelSum {
    var s = PixelSum(y * params.width + x, false, false, vec3f(0.0), vec3f(0.0), vec4f(0.0), false, false);
    if x >= params.width || y >= params.height {
        return s;
    }
    if params.accumulate == FILL_EMPTY && splat[s.pixel].w != 0.0 {
        return s;
    }
    s.writes = true;
    if params.accumulate == ACCUMULATE {
        s.sum = splat[s.pixel];
    }
    let v = vis[s.pixel];
    s.gathers = v.instance != NO_HIT;
    s.p = v.position;
    s.n = v.shading_normal;
    return s;
}

// Ward's error of record r (its reach) at the pixel, NOT_REACHED where it does not
// contribute.
fn pixel_error(s: PixelSum, r: Record) -> f32 {
    if !s.gathers {
        return NOT_REACHED;
    }
    return reach_error(r, s.p, s.n);
}

// Adds record k (r, fully loaded) with error err <= a to the pixel's sums.
fn pixel_add(s: ptr<function, PixelSum>, k: u32, r: Record, err: f32) {
    // Whether a record with some light reaches the pixel (pixel_sums).
    (*s).lit = (*s).lit || any(r.irradiance != vec3f(0.0));
    // w = 1 / err - 1 / a (Ward's weight less its value at the edge of the validity area,
    // Krivanek & Gautron 2009 section 2.2), capped where p is the record's own point: a
    // record fades out at its edge instead of dropping from 1 / a to 0, which drew its
    // circle (the splotches; Cornell box 128x128: indirect error 2.54 % -> 2.43 %). Floored
    // so that a pixel at the edge of its only record still takes that record's irradiance.
    let w = splat_weight(err, params.accuracy, params.plateau);
    (*s).sum += vec4f(w * record_irradiance_at(r, (*s).p, (*s).n), w);
    if COUNTS_COVERAGE && params.count_coverage == COUNT_NEEDED {
        (*s).survivor = (*s).survivor || expiring[k] == 0u;
    }
}

// Every record contributing to the pixel expires: each is needed (count_coverage 2).
fn count_needed(s: PixelSum, begin: u32, end: u32) {
    if !s.gathers || s.survivor {
        return;
    }
    for (var j = begin; j < end; j++) {
        let k = sorted[j];
        if contribution_error(k, s.p, s.n) <= params.accuracy {
            atomicAdd(&coverage[k], 1u);
        }
    }
}


// The sums a gather writes for pixel s. Where only dark records (E exactly 0: planes that
// saw no light) reached it and the gather says so (params.dark_only_empty), none: such
// records are no evidence of darkness, and the pixel is left to tail fill instead of
// reading exactly zero (SplatSource::dark_only_empty).
fn pixel_sums(s: PixelSum) -> vec4f {
    if params.dark_only_empty != 0u && !s.lit {
        return vec4f(0.0);
    }
    return s.sum;
}
