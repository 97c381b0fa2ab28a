// Splat tile bounds: per tile, the box of its visible pixels' world positions and of
// their shading normals (shared/splat.wgsl `TileBound`), so binning can drop a record from
// the tiles its screen bound overlaps but whose pixels it cannot reach
// (`tile_may_receive`): at grazing angles and across depth gaps most of them. One
// invocation per tile, its pixels in scan order (min and max do not depend on order).
// With EMPTY_ONLY (tail fill's gather, `SplatPass::fill_tile_bounds`) only the pixels whose
// first-gather sums are empty count: the only ones that gather can change, so tiles
// without such pixels bin no record (the same sums, fewer tests), and it lists those
// pixels for splat_fill.wgsl (in an order that depends on thread timing; each pixel's sums
// do not).
//!include shared/splat.wgsl

override EMPTY_ONLY: bool = false;

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read_write> bounds: array<TileBound>;
// The first gather's sums (EMPTY_ONLY; a placeholder otherwise).
@group(1) @binding(3) var<storage, read> sums: array<vec4f>;
// The visible pixels with empty sums and how many (EMPTY_ONLY; placeholders otherwise).
@group(1) @binding(4) var<storage, read_write> empty_pixels: array<u32>;
@group(1) @binding(5) var<storage, read_write> empty_count: array<atomic<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.tiles_x * params.tiles_y {
        return;
    }
    let r = tile_pixels(params, id.x);
    var b = TileBound(vec4f(1.0e30), vec4f(-1.0e30), vec4f(1.0e30), vec4f(-1.0e30));
    for (var y = r.y; y < r.w; y++) {
        for (var x = r.x; x < r.z; x++) {
            let pixel = y * params.width + x;
            if vis[pixel].instance == NO_HIT {
                continue;
            }
            if EMPTY_ONLY {
                if sums[pixel].w != 0.0 {
                    continue;
                }
                empty_pixels[atomicAdd(&empty_count[0], 1u)] = pixel;
            }
            let p = vis[pixel].position;
            let n = vis[pixel].shading_normal;
            b.lo = vec4f(min(b.lo.xyz, p), 0.0);
            b.hi = vec4f(max(b.hi.xyz, p), 0.0);
            b.normal_lo = vec4f(min(b.normal_lo.xyz, n), 0.0);
            b.normal_hi = vec4f(max(b.normal_hi.xyz, n), 0.0);
        }
    }
    bounds[id.x] = b;
}
