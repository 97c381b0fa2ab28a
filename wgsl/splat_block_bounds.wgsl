// Splat block bounds: per block of BLOCK_TILES x BLOCK_TILES tiles, the union of its tiles'
// bounds (shared/splat.wgsl), written after the tiles' own, so binning can drop a block of
// tiles at one test, and which of its tiles see anything (a bit each, in lo.w and hi.w:
// shared/splat.wgsl block_has_tile). Run after splat_tile_bounds.wgsl on the same buffer. One invocation per
// block, its tiles in scan order (min and max do not depend on order).
//!include shared/splat.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read_write> bounds: array<TileBound>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let bx_count = blocks_x(params);
    let by_count = (params.tiles_y + BLOCK_TILES - 1u) / BLOCK_TILES;
    if id.x >= bx_count * by_count {
        return;
    }
    let bx = id.x % bx_count;
    let by = id.x / bx_count;
    let all = vec4u(0u, 0u, params.tiles_x - 1u, params.tiles_y - 1u);
    let tiles = block_tiles(all, bx, by);
    var b = TileBound(vec4f(1.0e30), vec4f(-1.0e30), vec4f(1.0e30), vec4f(-1.0e30));
    var occupied = vec2u(0u);
    for (var ty = tiles.y; ty <= tiles.w; ty++) {
        for (var tx = tiles.x; tx <= tiles.z; tx++) {
            let t = bounds[ty * params.tiles_x + tx];
            if t.lo.x > t.hi.x {
                continue;   // sees nothing
            }
            b.lo = min(b.lo, t.lo);
            b.hi = max(b.hi, t.hi);
            b.normal_lo = min(b.normal_lo, t.normal_lo);
            b.normal_hi = max(b.normal_hi, t.normal_hi);
            let bit = (ty % BLOCK_TILES) * BLOCK_TILES + tx % BLOCK_TILES;
            occupied[bit / 32u] |= 1u << (bit % 32u);
        }
    }
    b.lo.w = bitcast<f32>(occupied.x);
    b.hi.w = bitcast<f32>(occupied.y);
    bounds[block_bound_index(params, bx, by)] = b;
}
