// A record's walk over the tiles it may reach (binning, shared/splat.wgsl): the blocks of
// its tile bound first, a block it cannot reach dropping all of its tiles at one test,
// then, in row order, each tile of a reached block that holds visible pixels and that the
// record may reach. Binning counts (splat_bin_count.wgsl) and lists
// (splat_bin_scatter.wgsl) the tiles it visits, and the record-by-record cover
// (splat_cover_by_record.wgsl) tests their pixels: one walk, so all three see the same
// tiles. The including pass declares `params: SplatParams`, `bounds: array<TileBound>`, a
// `struct TileVisitor` (what its visits need) and `fn visit_tile(v: TileVisitor, tile: u32)`
// (WGSL has no closures; the driver inlines the call).

// Visits the tiles of `tiles` (a record's `sphere_tiles`, possibly empty) that a record at
// `center` with reach `reach` (a R_k) and normal `normal` may reach at `params.accuracy`.
fn walk_reached_tiles(v: TileVisitor, tiles: vec4u, center: vec3f, reach: f32, normal: vec3f) {
    if tiles.x > tiles.z {
        return;
    }
    for (var by = tiles.y / BLOCK_TILES; by <= tiles.w / BLOCK_TILES; by++) {
        for (var bx = tiles.x / BLOCK_TILES; bx <= tiles.z / BLOCK_TILES; bx++) {
            let block = bounds[block_bound_index(params, bx, by)];
            if !tile_may_receive(block, center, reach, normal, params.accuracy) {
                continue;
            }
            let inner = block_tiles(tiles, bx, by);
            for (var ty = inner.y; ty <= inner.w; ty++) {
                for (var tx = inner.x; tx <= inner.z; tx++) {
                    if !block_has_tile(block, tx, ty) {
                        continue;
                    }
                    let tile = ty * params.tiles_x + tx;
                    if tile_may_receive(bounds[tile], center, reach, normal, params.accuracy) {
                        visit_tile(v, tile);
                    }
                }
            }
        }
    }
}
