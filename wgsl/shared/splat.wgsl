// Tile binning of record footprints shared by the splat passes (algorithms.md decision 8):
// a record reaches at most the sphere of radius a R_k around p_k (thesis eq. 4.4); its
// bound on screen, in 8 x 8-pixel tiles, is where it is splatted. Binning walks that bound
// in blocks of BLOCK_TILES x BLOCK_TILES tiles first: a block whose bound the record cannot
// reach drops all its tiles at one test (most of a wide footprint's tiles, for tail fill's
// accuracy and at depth gaps).
//!include shared/ray.wgsl
//!include shared/camera.wgsl
//!include shared/linear_dispatch.wgsl

const TILE_SIZE: u32 = 8u;
const BLOCK_TILES: u32 = 8u;   // 64 tiles: one bit each in a block's two words
const NO_TILES: vec4u = vec4u(1u, 1u, 0u, 0u);   // empty: min > max

struct SplatParams {
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    first_record: u32,   // records [first_record, record_end) are splatted
    record_end: u32,
    accuracy: f32,
    accumulate: u32,     // 1: add onto the splat buffer's previous sums; 2: fill only empty ones
    count_coverage: u32, // 1: count the pixels each record contributes to; 2: only those
                         // no record outliving the frame contributes to (splat_gather.wgsl)
    plateau: f32,        // below this error a record's weight stops growing (splat_weight)
    dark_only_empty: u32, // 1: a pixel only records with E = 0 reach stays empty (SplatSource)
    _pad1: u32,
}

// The pixels of tile `tile` (row-major over `params.tiles_x`): x0, y0 inclusive, x1, y1
// exclusive, clipped to the image.
fn tile_pixels(params: SplatParams, tile: u32) -> vec4u {
    let x0 = (tile % params.tiles_x) * TILE_SIZE;
    let y0 = (tile / params.tiles_x) * TILE_SIZE;
    return vec4u(x0, y0, min(x0 + TILE_SIZE, params.width), min(y0 + TILE_SIZE, params.height));
}

// Screen-space tile rectangle (inclusive min.xy, max.zw) covered by a sphere, from the
// projections of its bounding cube's corners; the whole screen when the cube reaches
// behind the camera, NO_TILES when it is off screen.
fn sphere_tiles(cam: Camera, params: SplatParams, center: vec3f, radius: f32) -> vec4u {
    let right2 = dot(cam.right, cam.right);
    let up2 = dot(cam.up, cam.up);
    var lo = vec2f(1.0e30);
    var hi = vec2f(-1.0e30);
    for (var k = 0u; k < 8u; k++) {
        let corner = center + radius * vec3f(
            select(-1.0, 1.0, (k & 1u) != 0u),
            select(-1.0, 1.0, (k & 2u) != 0u),
            select(-1.0, 1.0, (k & 4u) != 0u),
        );
        let d = corner - cam.origin;
        let z = dot(d, cam.forward);
        if z <= 1.0e-6 * length(d) {
            return vec4u(0u, 0u, params.tiles_x - 1u, params.tiles_y - 1u);
        }
        let ndc = vec2f(dot(d, cam.right) / (right2 * z), dot(d, cam.up) / (up2 * z));
        let px = vec2f((ndc.x + 1.0) * 0.5 * f32(cam.width), (1.0 - ndc.y) * 0.5 * f32(cam.height));
        lo = min(lo, px);
        hi = max(hi, px);
    }
    if hi.x < 0.0 || hi.y < 0.0 || lo.x >= f32(cam.width) || lo.y >= f32(cam.height) {
        return NO_TILES;
    }
    let lo_px = vec2u(max(lo, vec2f(0.0)));
    let hi_px = vec2u(min(hi, vec2f(f32(cam.width) - 1.0, f32(cam.height) - 1.0)));
    return vec4u(lo_px / TILE_SIZE, hi_px / TILE_SIZE);
}

// Blocks across the image: the bounds buffer holds the tiles' bounds, then the blocks'.
fn blocks_x(params: SplatParams) -> u32 {
    return (params.tiles_x + BLOCK_TILES - 1u) / BLOCK_TILES;
}

// Index in the bounds buffer of block (bx, by)'s bound (after the tiles' own).
fn block_bound_index(params: SplatParams, bx: u32, by: u32) -> u32 {
    return params.tiles_x * params.tiles_y + by * blocks_x(params) + bx;
}

// The tiles of rectangle `tiles` (inclusive min.xy, max.zw) inside block (bx, by).
fn block_tiles(tiles: vec4u, bx: u32, by: u32) -> vec4u {
    let lo = vec2u(bx, by) * BLOCK_TILES;
    return vec4u(max(tiles.xy, lo), min(tiles.zw, lo + BLOCK_TILES - 1u));
}

// Whether tile (tx, ty) of the block with bound `block` sees anything: the block's bound
// carries one bit per tile in its lo.w and hi.w (splat_block_bounds.wgsl), so a walk over
// the block skips empty tiles without loading their bounds (tail fill's bounds count only
// the pixels still empty: most of its tiles are).
fn block_has_tile(block: TileBound, tx: u32, ty: u32) -> bool {
    let bit = (ty % BLOCK_TILES) * BLOCK_TILES + tx % BLOCK_TILES;
    let word = select(bitcast<u32>(block.lo.w), bitcast<u32>(block.hi.w), bit >= 32u);
    return (word & (1u << (bit % 32u))) != 0u;
}

// What a tile's visible pixels span (splat_tile_bounds.wgsl): the world-space box of their
// positions and the box of their shading normals; lo > hi where the tile sees nothing. A
// block's bound is the union of its tiles': it contains each, so a tile whose record passes
// `tile_may_receive` lies in a block that passes it too (the test is monotone in the box,
// also under rounding), and walking blocks first bins exactly the same tiles.
struct TileBound {
    lo: vec4f,
    hi: vec4f,
    normal_lo: vec4f,
    normal_hi: vec4f,
}

// Whether a record at `center` with validity radius `radius` (a R_k) and normal `normal`
// can contribute to any pixel of a tile with bound `b`, a test on the tile's content like
// tiled light culling's depth bounds. Conservative for Ward's error (eq. 4.2,
// shared/splat_weight.wgsl) err = |p - p_k| / R_k + sqrt(1 - n.n_k): over the tile's box,
// |p - p_k| is at least the box's distance from p_k, and n.n_k at most its maximum over the
// normal box (a linear function's maximum over a box is at a corner, per component), so
// err is at least the sum of the two bounds, and the record reaches the tile only if that
// is at most a (each term alone was the test before: the sum drops the tiles where both
// use part of the budget). The slack keeps the test conservative under rounding.
fn tile_may_receive(b: TileBound, center: vec3f, radius: f32, normal: vec3f, accuracy: f32) -> bool {
    let gap = max(max(b.lo.xyz - center, center - b.hi.xyz), vec3f(0.0));
    let reach = radius * 1.001;
    let gap2 = dot(gap, gap);
    if gap2 > reach * reach {
        return false;
    }
    let best = dot(max(normal * b.normal_lo.xyz, normal * b.normal_hi.xyz), vec3f(1.0));
    let least_error = sqrt(gap2) / reach * accuracy + sqrt(max(0.0, 1.0 - best - 1.0e-3));
    return least_error <= accuracy;
}
