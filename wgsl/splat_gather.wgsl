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

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let pixel = id.y * params.width + id.x;
    let tile = (id.y / TILE_SIZE) * params.tiles_x + id.x / TILE_SIZE;
    // Accumulating a round that binned nothing into this tile leaves its sums as they
    // are: skip the memory traffic (placement rounds touch few tiles of a large image).
    if params.accumulate != 0u && tile_offsets[tile] == tile_offsets[tile + 1u] {
        return;
    }
    var sum = vec4f(0.0);
    if params.accumulate == ACCUMULATE {
        sum = splat[pixel];
    }
    if params.accumulate == FILL_EMPTY && splat[pixel].w != 0.0 {
        return;
    }
    let v = vis[pixel];
    if v.instance != NO_HIT {
        let p = v.position;
        let n = v.shading_normal;
        var survivor = false;   // a record that outlives this frame contributes here
        for (var j = tile_offsets[tile]; j < tile_offsets[tile + 1u]; j++) {
            let k = sorted[j];
            let err = contribution_error(k, p, n);
            if err <= params.accuracy {
                let r = records[k];
                // w = 1 / err - 1 / a (Ward's weight less its value at the edge of the
                // validity area, Krivanek & Gautron 2009 section 2.2), capped where p is the
                // record's own point: a record fades out at its edge instead of dropping
                // from 1 / a to 0, which drew its circle (the splotches; Cornell box
                // 128x128: indirect error 2.54 % -> 2.43 %). Floored so that a pixel at the
                // edge of its only record still takes that record's irradiance.
                let w = splat_weight(err, params.accuracy);
                sum += vec4f(w * record_irradiance_at(r, p, n), w);
                if params.count_coverage == COUNT_ALL {
                    atomicAdd(&coverage[k], 1u);
                }
                if params.count_coverage == COUNT_NEEDED {
                    survivor = survivor || expiring[k] == 0u;
                }
            }
        }
        if params.count_coverage == COUNT_NEEDED && !survivor {
            // Every record contributing here expires: each is needed.
            for (var j = tile_offsets[tile]; j < tile_offsets[tile + 1u]; j++) {
                let k = sorted[j];
                if contribution_error(k, p, n) <= params.accuracy {
                    atomicAdd(&coverage[k], 1u);
                }
            }
        }
    }
    splat[pixel] = sum;
}
