// Splat cover (placement's cache-miss test): marks each visible pixel that at least one
// of records [first_record, record_end) contributes to (shared/splat_weight.wgsl, the
// gather's own test). Placement only needs to know which pixels are covered, not the
// weighted sums, so a round runs this instead of the gather: a covered pixel is skipped,
// an uncovered one stops at its first contributing record, and the list order does not
// matter (an "or" of its records), so the unsorted tile lists serve. The weighted gather
// runs once, after placement (splat_gather.wgsl). The test is at `params.accuracy`: a
// tail-fill round's cover passes the wider accuracy there. One workgroup per tile that
// binned any of the new records (splat_bin_tiles.wgsl's list, in any order).
//!include shared/splat_weight.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read> records: array<Record>;
@group(1) @binding(3) var<storage, read> tile_offsets: array<u32>;
@group(1) @binding(4) var<storage, read> entries: array<vec2u>;   // (record, tile)
@group(1) @binding(5) var<storage, read_write> covered: array<u32>;   // 1: covered
// [0]: pixels this mask's covers have marked (integer atomics: exact, order-free), which
// placement's tail fill reads to know the share still uncovered.
@group(1) @binding(6) var<storage, read_write> marked: array<atomic<u32>>;
@group(1) @binding(7) var<storage, read> busy_tiles: array<u32>;
@group(1) @binding(8) var<storage, read> busy_count: array<u32>;

@compute @workgroup_size(TILE_SIZE, TILE_SIZE)
fn main(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_id) local: vec3u,
) {
    let slot = group.y * groups.x + group.x;
    if slot >= busy_count[0] {
        return;
    }
    // Lists cut short by a too small `entries` (splat_bin_scatter.wgsl): mark nothing, so
    // that the cover placement repeats with room marks exactly what one cover would
    // (SplatPass::cover_in_flight).
    if tile_offsets[params.tiles_x * params.tiles_y] > arrayLength(&entries) {
        return;
    }
    let tile = busy_tiles[slot];
    let x = (tile % params.tiles_x) * TILE_SIZE + local.x;
    let y = (tile / params.tiles_x) * TILE_SIZE + local.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let pixel = y * params.width + x;
    if covered[pixel] != 0u {
        return;
    }
    let v = vis[pixel];
    if v.instance == NO_HIT {
        return;
    }
    for (var j = tile_offsets[tile]; j < tile_offsets[tile + 1u]; j++) {
        if contribution_error(entries[j].x, v.position, v.shading_normal) <= params.accuracy {
            covered[pixel] = 1u;
            atomicAdd(&marked[0], 1u);
            return;
        }
    }
}
