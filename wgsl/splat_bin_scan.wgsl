// Splat binning, step 2: exclusive prefix sum of the tile counts (one workgroup; each lane
// sums a contiguous run, then a scan over the 256 run totals). Writes the total last.
//!include shared/splat.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> tile_counts: array<u32>;
@group(1) @binding(2) var<storage, read_write> tile_offsets: array<u32>;   // tiles + 1

var<workgroup> run_totals: array<u32, 256>;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lane: u32) {
    let tiles = params.tiles_x * params.tiles_y;
    let run = (tiles + 255u) / 256u;
    let begin = min(lane * run, tiles);
    let end = min(begin + run, tiles);
    var total = 0u;
    for (var t = begin; t < end; t++) {
        total += tile_counts[t];
    }
    run_totals[lane] = total;
    workgroupBarrier();
    // Hillis-Steele inclusive scan of the run totals.
    for (var stride = 1u; stride < 256u; stride *= 2u) {
        var v = run_totals[lane];
        if lane >= stride {
            v += run_totals[lane - stride];
        }
        workgroupBarrier();
        run_totals[lane] = v;
        workgroupBarrier();
    }
    var offset = run_totals[lane] - total;
    for (var t = begin; t < end; t++) {
        tile_offsets[t] = offset;
        offset += tile_counts[t];
    }
    if lane == 255u {
        tile_offsets[tiles] = run_totals[255];
    }
}
