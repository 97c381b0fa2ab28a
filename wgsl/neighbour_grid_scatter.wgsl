// Neighbour grid, step 3: each earlier record writes its index into its cell's range. The
// order within a cell depends on thread timing, which is harmless: the search takes a
// minimum, whose value does not depend on the order.
//!include shared/records.wgsl
//!include shared/neighbour_grid.wgsl
//!include shared/linear_dispatch.wgsl

@group(1) @binding(0) var<uniform> grid: NeighbourGrid;
@group(1) @binding(1) var<storage, read> records: array<Record>;
@group(1) @binding(2) var<storage, read_write> cell_cursors: array<atomic<u32>>;
@group(1) @binding(3) var<storage, read_write> cell_records: array<u32>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let j = flat_index(id, groups);
    if j >= grid.records {
        return;
    }
    let c = neighbour_grid_cell(grid, records[j].position);
    let slot = atomicAdd(&cell_cursors[neighbour_grid_index(grid, c)], 1u);
    cell_records[slot] = j;
}
