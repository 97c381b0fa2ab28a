// The uniform grid over earlier records that neighbour clamping searches (record_reduce.wgsl;
// built by neighbour_grid_count.wgsl, prefix_sum.wgsl and neighbour_grid_scatter.wgsl;
// Rust: records::neighbour_grid). Cells are cubes of side `cell_size` from `origin`; a position outside the grid belongs to the
// border cell it is clamped to (border cells extend outwards), so a record in a cell k
// cells away (Chebyshev) from a point's cell is at least (k - 1) cell_size away from it.

struct NeighbourGrid {
    origin: vec3f,
    cell_size: f32,
    dims: vec3u,
    // 1: records::neighbour_grid built the grid for this reduction; 0: search every
    // earlier record (few of them, or no clamping).
    enabled: u32,
    // Records in the grid (the records before the reduced batch).
    records: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

fn neighbour_grid_cell(grid: NeighbourGrid, p: vec3f) -> vec3u {
    let c = floor((p - grid.origin) / grid.cell_size);
    return vec3u(clamp(c, vec3f(0.0), vec3f(grid.dims - vec3u(1u))));
}

fn neighbour_grid_index(grid: NeighbourGrid, c: vec3u) -> u32 {
    return c.x + grid.dims.x * (c.y + grid.dims.y * c.z);
}
