// Splat gather (thesis Algorithm 3 as a gather), run once per frame after placement:
// each pixel sums its tile's records in record order: Ward's weight with w >= 1/a (eq. 4.2-4.3), the "behind" test, gradient
// extrapolation clamped at 0. Output per pixel: (sum w E'_k, sum w); with `accumulate`
// the sums continue the previous ones, so adding records round by round gives the same
// bits as splatting them all at once. With `count_coverage`, every (record, pixel) pair that
// contributes adds 1 to the record's coverage (u32 atomics: exact, order-free); temporal
// caching uses it to delete expired records that no longer cover any pixel instead of
// replacing them (replaces the thesis's occlusion queries, algorithms.md 4.4). With
// `count_coverage` 2 only pixels that no record outliving this frame (`expiring[k] == 0`)
// contributes to are counted, and only for the expiring records that do: an expired record
// none of whose pixels needs it is deleted rather than replaced. With `accumulate` 2
// (tail fill, placement::PlacementPass) only pixels whose previous sums are empty (no
// record reached them at a) take these records' sums, at the tail's wider accuracy.
//!include shared/splat_weight.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read> records: array<Record>;
@group(1) @binding(3) var<storage, read> tile_offsets: array<u32>;
@group(1) @binding(4) var<storage, read> sorted: array<u32>;
@group(1) @binding(5) var<storage, read_write> splat: array<vec4f>;
@group(1) @binding(6) var<storage, read_write> coverage: array<atomic<u32>>;
@group(1) @binding(7) var<storage, read> expiring: array<u32>;   // 1: expires after this frame

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
}

fn pixel_start(x: u32, y: u32) -> PixelSum {
    var s = PixelSum(y * params.width + x, false, false, vec3f(0.0), vec3f(0.0), vec4f(0.0), false);
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
    // w = 1 / err - 1 / a (Ward's weight less its value at the edge of the validity area,
    // Krivanek & Gautron 2009 section 2.2), capped where p is the record's own point: a
    // record fades out at its edge instead of dropping from 1 / a to 0, which drew its
    // circle (the splotches; Cornell box 128x128: indirect error 2.54 % -> 2.43 %). Floored
    // so that a pixel at the edge of its only record still takes that record's irradiance.
    let w = splat_weight(err, params.accuracy);
    (*s).sum += vec4f(w * record_irradiance_at(r, (*s).p, (*s).n), w);
    if params.count_coverage == COUNT_NEEDED {
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

// Two pixels per invocation, half a tile row apart: each record of the tile's list is
// loaded once for both (storage loads, one per lane on lavapipe, are the gather's cost).
// Each pixel sums its records in list order with the same operations as one invocation per
// pixel: the same bytes.
@compute @workgroup_size(4, 8)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_id) local: vec3u) {
    let tile = group.y * params.tiles_x + group.x;
    let begin = tile_offsets[tile];
    let end = tile_offsets[tile + 1u];
    // Accumulating a round that binned nothing into this tile leaves its sums as they
    // are: skip the memory traffic (placement rounds touch few tiles of a large image).
    if params.accumulate != 0u && begin == end {
        return;
    }
    let x = group.x * TILE_SIZE + local.x;
    let y = group.y * TILE_SIZE + local.y;
    var a = pixel_start(x, y);
    var b = pixel_start(x + TILE_SIZE / 2u, y);
    if a.gathers || b.gathers {
        for (var j = begin; j < end; j++) {
            let k = sorted[j];
            var r = record_reach(k);
            let err_a = pixel_error(a, r);
            let err_b = pixel_error(b, r);
            if min(err_a, err_b) > params.accuracy {
                continue;
            }
            r = records[k];
            var covered = 0u;
            if err_a <= params.accuracy {
                pixel_add(&a, k, r, err_a);
                covered += 1u;
            }
            if err_b <= params.accuracy {
                pixel_add(&b, k, r, err_b);
                covered += 1u;
            }
            if params.count_coverage == COUNT_ALL {
                atomicAdd(&coverage[k], covered);
            }
        }
    }
    if params.count_coverage == COUNT_NEEDED {
        count_needed(a, begin, end);
        count_needed(b, begin, end);
    }
    if a.writes {
        splat[a.pixel] = a.sum;
    }
    if b.writes {
        splat[b.pixel] = b.sum;
    }
}
