// Splat binning, step 2b: the list of tiles that binned any record (after the scan), so
// that placement's cover runs one workgroup per such tile instead of one per tile of the
// image (an empty workgroup still costs about a microsecond on lavapipe: 19 ms a round at
// 1000x1000, most of a late round's cover). The list's order depends on thread timing;
// the cover's result does not (each tile is covered once, an "or" per pixel). Each listed
// tile also raises the cover's indirect dispatch, one workgroup per tile (x up to 65535,
// then rows; the maxima do not depend on thread order), so that no wait for the count on
// the CPU comes between the bins and the cover.
//!include shared/splat.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> tile_offsets: array<u32>;
@group(1) @binding(2) var<storage, read_write> busy_tiles: array<u32>;
@group(1) @binding(3) var<storage, read_write> busy_count: array<atomic<u32>>;
// x y z, starting at 0 1 1.
@group(1) @binding(4) var<storage, read_write> cover_groups: array<atomic<u32>, 3>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let tile = flat_index(id, groups);
    if tile >= params.tiles_x * params.tiles_y || tile_offsets[tile] == tile_offsets[tile + 1u] {
        return;
    }
    let slot = atomicAdd(&busy_count[0], 1u);
    busy_tiles[slot] = tile;
    atomicMax(&cover_groups[0], min(slot + 1u, 65535u));
    atomicMax(&cover_groups[1], slot / 65535u + 1u);
}
