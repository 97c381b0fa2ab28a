// Neighbour grid, step 2: exclusive prefix sum of the cell counts (one workgroup; each lane
// sums a contiguous run of cells, then a scan over the 256 run totals) into `cell_offsets`
// (cells + 1 entries, the total last); the counts become each cell's write cursor (its
// offset) for step 3.
//!include shared/neighbour_grid.wgsl

@group(1) @binding(0) var<uniform> grid: NeighbourGrid;
@group(1) @binding(1) var<storage, read_write> cell_counts: array<u32>;
@group(1) @binding(2) var<storage, read_write> cell_offsets: array<u32>;

var<workgroup> run_totals: array<u32, 256>;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lane: u32) {
    let cells = grid.dims.x * grid.dims.y * grid.dims.z;
    let run = (cells + 255u) / 256u;
    let begin = min(lane * run, cells);
    let end = min(begin + run, cells);
    var total = 0u;
    for (var c = begin; c < end; c++) {
        total += cell_counts[c];
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
    for (var c = begin; c < end; c++) {
        let n = cell_counts[c];
        cell_offsets[c] = offset;
        cell_counts[c] = offset;
        offset += n;
    }
    if lane == 255u {
        cell_offsets[cells] = run_totals[255];
    }
}
