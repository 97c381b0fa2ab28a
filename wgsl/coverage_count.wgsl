// Coverage count for placement's tail fill: how many pixels are visible and how many of
// those a coverage mask marks. One invocation per splat tile, its pixels in scan order,
// two integer atomics per tile (exact, order-free).
//!include shared/splat.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read> covered: array<u32>;
@group(1) @binding(3) var<storage, read_write> counts: array<atomic<u32>>;   // visible, covered

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.tiles_x * params.tiles_y {
        return;
    }
    let r = tile_pixels(params, id.x);
    var visible = 0u;
    var marked = 0u;
    for (var y = r.y; y < r.w; y++) {
        for (var x = r.x; x < r.z; x++) {
            let pixel = y * params.width + x;
            if vis[pixel].instance != NO_HIT {
                visible += 1u;
                marked += u32(covered[pixel] != 0u);
            }
        }
    }
    if visible > 0u {
        atomicAdd(&counts[0], visible);
        atomicAdd(&counts[1], marked);
    }
}
