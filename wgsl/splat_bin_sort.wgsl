// Splat binning, step 4: order each tile's list by record id (rank sort: an entry's rank is
// the number of entries of its tile with a smaller id), so that every pixel sums its
// records in the same order on every run (no float atomics, algorithms.md decision 8).
//!include shared/splat.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> tile_offsets: array<u32>;
@group(1) @binding(2) var<storage, read> entries: array<vec2u>;
@group(1) @binding(3) var<storage, read_write> sorted: array<u32>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let e = flat_index(id, groups);
    let total = tile_offsets[params.tiles_x * params.tiles_y];
    if e >= total {
        return;
    }
    let entry = entries[e];
    let begin = tile_offsets[entry.y];
    let end = tile_offsets[entry.y + 1u];
    var rank = 0u;
    for (var j = begin; j < end; j++) {
        rank += select(0u, 1u, entries[j].x < entry.x);
    }
    sorted[begin + rank] = entry.x;
}
