// Splat binning, step 1: each record counts itself into every tile its footprint bounds on
// screen whose visible pixels it can reach (`tile_may_receive`; u32 atomics: exact, so the
// counts do not depend on thread timing).
//!include shared/records.wgsl
//!include shared/splat.wgsl
//!include shared/tile_walk.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<uniform> camera: Camera;
@group(1) @binding(2) var<storage, read> records: array<Record>;
@group(1) @binding(3) var<storage, read_write> record_tiles: array<vec4u>;
@group(1) @binding(4) var<storage, read_write> tile_counts: array<atomic<u32>>;
@group(1) @binding(5) var<storage, read> bounds: array<TileBound>;

// Each tile the record may reach gets one more entry in its count.
struct TileVisitor {
    record: u32,
}

fn visit_tile(v: TileVisitor, tile: u32) {
    atomicAdd(&tile_counts[tile], 1u);
}

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
    walk_reached_tiles(TileVisitor(k), tiles, r.position, reach, r.normal);
}
