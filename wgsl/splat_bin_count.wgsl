// Splat binning, step 1: each record counts itself into every tile its footprint bounds
// (u32 atomics: exact, so the counts do not depend on thread timing).
//!include shared/records.wgsl
//!include shared/splat.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<uniform> camera: Camera;
@group(1) @binding(2) var<storage, read> records: array<Record>;
@group(1) @binding(3) var<storage, read_write> record_tiles: array<vec4u>;
@group(1) @binding(4) var<storage, read_write> tile_counts: array<atomic<u32>>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = flat_index(id, groups);
    let k = params.first_record + i;
    if k >= params.record_end {
        return;
    }
    let r = records[k];
    let tiles = sphere_tiles(camera, params, r.position, params.accuracy * r.radius);
    record_tiles[i] = tiles;
    for (var ty = tiles.y; ty <= tiles.w; ty++) {
        for (var tx = tiles.x; tx <= tiles.z; tx++) {
            atomicAdd(&tile_counts[ty * params.tiles_x + tx], 1u);
        }
    }
}
