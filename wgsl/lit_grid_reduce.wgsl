// Lit grid, coarser levels (src/light_maps/lit_grid.rs): voxel c of `level` holds the OR of
// its 2x2x2 children's face bits at level - 1. One invocation per voxel.
//!include shared/lit_grid.wgsl

struct ReduceLevel {
    level: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> lit_grid_params: LitGridParams;
@group(1) @binding(1) var<storage, read_write> lit_grid: array<u32>;
@group(1) @binding(2) var<uniform> reduce: ReduceLevel;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let p = lit_grid_params;
    let level = reduce.level;
    let d = lit_grid_dims(p, level);
    let i = id.x;
    if i >= d.x * d.y * d.z {
        return;
    }
    let c = vec3u(i % d.x, (i / d.x) % d.y, i / (d.x * d.y));
    let fine = lit_grid_dims(p, level - 1u);
    var any = 0u;
    for (var z = 0u; z < 2u; z++) {
        for (var y = 0u; y < 2u; y++) {
            for (var x = 0u; x < 2u; x++) {
                let f = 2u * c + vec3u(x, y, z);
                if all(f < fine) {
                    any |= lit_grid[lit_grid_voxel(p, level - 1u, f)];
                }
            }
        }
    }
    lit_grid[lit_grid_voxel(p, level, c)] = any;
}
