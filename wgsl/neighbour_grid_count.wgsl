// Neighbour grid, step 1: each earlier record counts itself into its cell (u32 atomics:
// exact, in any order).
//!include shared/records.wgsl
//!include shared/neighbour_grid.wgsl
//!include shared/linear_dispatch.wgsl

@group(1) @binding(0) var<uniform> grid: NeighbourGrid;
@group(1) @binding(1) var<storage, read> records: array<Record>;
@group(1) @binding(2) var<storage, read_write> cell_counts: array<atomic<u32>>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let j = flat_index(id, groups);
    if j >= grid.records {
        return;
    }
    let c = neighbour_grid_cell(grid, records[j].position);
    atomicAdd(&cell_counts[neighbour_grid_index(grid, c)], 1u);
}
