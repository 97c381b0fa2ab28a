// Splat fill: tail fill's gather (SplatPass::fill_empty). The pixels that no record reached
// at the first gather's accuracy (their sums empty, listed by splat_tile_bounds.wgsl with
// EMPTY_ONLY) take every record of their tile that reaches them at the tail's wider
// accuracy, in list order: splat_gather.wgsl's sums with `accumulate` 2, one invocation per
// listed pixel instead of per pixel of the busy tiles (a handful of empty pixels in a tile
// kept its whole SIMD group looping over the tile's list).
//!include shared/splat_pixel.wgsl
//!include shared/linear_dispatch.wgsl

@group(1) @binding(9) var<storage, read> empty_pixels: array<u32>;
@group(1) @binding(10) var<storage, read> empty_count: array<u32>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = flat_index(id, groups);
    if i >= empty_count[0] {
        return;
    }
    let pixel = empty_pixels[i];
    let x = pixel % params.width;
    let y = pixel / params.width;
    var s = pixel_start(x, y);
    if !s.writes {
        return;
    }
    let tile = (y / TILE_SIZE) * params.tiles_x + x / TILE_SIZE;
    let begin = tile_offsets[tile];
    let end = tile_offsets[tile + 1u];
    if s.gathers {
        for (var j = begin; j < end; j++) {
            let k = sorted[j];
            var r = record_reach(k);
            let err = pixel_error(s, r);
            if err > params.accuracy {
                continue;
            }
            r = record_for_sums(k);
            pixel_add(&s, k, r, err);
            if COUNTS_COVERAGE && params.count_coverage == COUNT_ALL {
                atomicAdd(&coverage[k], 1u);
            }
        }
    }
    if COUNTS_COVERAGE && params.count_coverage == COUNT_NEEDED {
        count_needed(s, begin, end);
    }
    splat[pixel] = pixel_sums(s);
}
