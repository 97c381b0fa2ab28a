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
// none of whose pixels needs it is deleted rather than replaced. Tail fill (`accumulate`
// 2: only pixels whose sums are empty take the records' sums, at the tail's wider
// accuracy) runs splat_fill.wgsl over a list of those pixels, with the same per-pixel sum
// (shared/splat_pixel.wgsl).
//!include shared/splat_pixel.wgsl

// Four pixels per invocation, a quarter of a tile row apart: each record of the tile's
// list is loaded once for all four (storage loads, one per lane on lavapipe, are the
// gather's cost; two pixels took 12 % longer on Sponza 1000x1000). Each pixel sums its
// records in list order with the same operations as one invocation per pixel: the same
// bytes.
const QUARTER: u32 = TILE_SIZE / 4u;

@compute @workgroup_size(2, 8)
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
    var b = pixel_start(x + QUARTER, y);
    var c = pixel_start(x + 2u * QUARTER, y);
    var d = pixel_start(x + 3u * QUARTER, y);
    if a.gathers || b.gathers || c.gathers || d.gathers {
        for (var j = begin; j < end; j++) {
            let k = sorted[j];
            var r = record_reach(k);
            let err_a = pixel_error(a, r);
            let err_b = pixel_error(b, r);
            let err_c = pixel_error(c, r);
            let err_d = pixel_error(d, r);
            if min(min(err_a, err_b), min(err_c, err_d)) > params.accuracy {
                continue;
            }
            r = record_for_sums(k);
            var covered = 0u;
            if err_a <= params.accuracy {
                pixel_add(&a, k, r, err_a);
                covered += 1u;
            }
            if err_b <= params.accuracy {
                pixel_add(&b, k, r, err_b);
                covered += 1u;
            }
            if err_c <= params.accuracy {
                pixel_add(&c, k, r, err_c);
                covered += 1u;
            }
            if err_d <= params.accuracy {
                pixel_add(&d, k, r, err_d);
                covered += 1u;
            }
            if COUNTS_COVERAGE && params.count_coverage == COUNT_ALL {
                atomicAdd(&coverage[k], covered);
            }
        }
    }
    if COUNTS_COVERAGE && params.count_coverage == COUNT_NEEDED {
        count_needed(a, begin, end);
        count_needed(b, begin, end);
        count_needed(c, begin, end);
        count_needed(d, begin, end);
    }
    if a.writes {
        splat[a.pixel] = pixel_sums(a);
    }
    if b.writes {
        splat[b.pixel] = pixel_sums(b);
    }
    if c.writes {
        splat[c.pixel] = pixel_sums(c);
    }
    if d.writes {
        splat[d.pixel] = pixel_sums(d);
    }
}
