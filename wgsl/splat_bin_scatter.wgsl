// Splat binning, step 3: each record writes (record, tile) into its tiles' lists. The slot
// order inside a list depends on thread timing; step 4 makes it deterministic. `entries`
// may be shorter than the lists (placement's cover sizes it before the total is known,
// SplatPass::cover_in_flight): entries past its end are not written, and the cover of such
// bins marks nothing.
//!include shared/records.wgsl
//!include shared/splat.wgsl
//!include shared/tile_walk.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> record_tiles: array<vec4u>;
@group(1) @binding(2) var<storage, read> tile_offsets: array<u32>;
@group(1) @binding(3) var<storage, read_write> tile_cursors: array<atomic<u32>>;
@group(1) @binding(4) var<storage, read_write> entries: array<vec2u>;
@group(1) @binding(5) var<storage, read> records: array<Record>;
@group(1) @binding(6) var<storage, read> bounds: array<TileBound>;

// Each tile the record may reach (the count's walk and tests, on the same values: the same
// tiles) gets (record, tile) in its list.
struct TileVisitor {
    record: u32,
}

fn visit_tile(v: TileVisitor, tile: u32) {
    let slot = atomicAdd(&tile_cursors[tile], 1u);
    let at = tile_offsets[tile] + slot;
    if at < arrayLength(&entries) {
        entries[at] = vec2u(v.record, tile);
    }
}

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = flat_index(id, groups);
    if params.first_record + i >= params.record_end {
        return;
    }
    let tiles = record_tiles[i];
    let k = params.first_record + i;
    let center = records[k].position;
    let reach = params.accuracy * records[k].radius;
    let normal = records[k].normal;
    walk_reached_tiles(TileVisitor(k), tiles, center, reach, normal);
}
