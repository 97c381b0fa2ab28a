// Splat binning, step 1: each record counts itself into every tile its footprint bounds on
// screen whose visible pixels it can reach (`tile_may_receive`; u32 atomics: exact, so the
// counts do not depend on thread timing).
//!include shared/records.wgsl
//!include shared/splat.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<uniform> camera: Camera;
@group(1) @binding(2) var<storage, read> records: array<Record>;
@group(1) @binding(3) var<storage, read_write> record_tiles: array<vec4u>;
@group(1) @binding(4) var<storage, read_write> tile_counts: array<atomic<u32>>;
@group(1) @binding(5) var<storage, read> bounds: array<TileBound>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = flat_index(id, groups);
    let k = params.first_record + i;
    if k >= params.record_end {
        return;
    }
    let r = records[k];
    let reach = params.accuracy * r.radius;
    let tiles = sphere_tiles(camera, params, r.position, reach);
    record_tiles[i] = tiles;
    if tiles.x > tiles.z {
        return;
    }
    for (var by = tiles.y / BLOCK_TILES; by <= tiles.w / BLOCK_TILES; by++) {
        for (var bx = tiles.x / BLOCK_TILES; bx <= tiles.z / BLOCK_TILES; bx++) {
            let block = bounds[block_bound_index(params, bx, by)];
            if !tile_may_receive(block, r.position, reach, r.normal, params.accuracy) {
                continue;
            }
            let inner = block_tiles(tiles, bx, by);
            for (var ty = inner.y; ty <= inner.w; ty++) {
                for (var tx = inner.x; tx <= inner.z; tx++) {
                    if !block_has_tile(block, tx, ty) {
                        continue;
                    }
                    let tile = ty * params.tiles_x + tx;
                    if tile_may_receive(bounds[tile], r.position, reach, r.normal, params.accuracy) {
                        atomicAdd(&tile_counts[tile], 1u);
                    }
                }
            }
        }
    }
}
