// Splat cover, record by record (placement's cache-miss test on small images,
// SplatPass::cover_in_flight): one workgroup a new record marks the visible pixels it
// contributes to. It walks the tiles the binning would list it in (shared/tile_walk.wgsl,
// binning's own walk) and tests each of their pixels as splat_cover.wgsl tests the pixel
// against its tile's list (the same shared test, shared/splat_weight.wgsl): so the same
// (record, pixel) pairs decide, and the mask is the same. It needs no bins: one dispatch where the binned cover makes five, and on
// lavapipe a dispatch costs about 81 us whatever its work (docs/results.md, stop 69).
// Records of one dispatch may mark the same pixel: `atomicExchange` lets the first count
// it (integer atomics: exact, order-free).
//!include shared/splat_weight.wgsl
//!include shared/tile_walk.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<uniform> camera: Camera;
@group(1) @binding(2) var<storage, read> vis: array<VisSample>;
@group(1) @binding(3) var<storage, read> records: array<Record>;
@group(1) @binding(4) var<storage, read> bounds: array<TileBound>;
@group(1) @binding(5) var<storage, read_write> covered: array<atomic<u32>>;   // 1: covered
// [0]: pixels this mask's covers have marked (splat_cover.wgsl).
@group(1) @binding(6) var<storage, read_write> marked: array<atomic<u32>>;

// The pixel of tile `tile` this invocation tests (TILE_SIZE x TILE_SIZE = 64 invocations),
// marked if record `r` contributes to it and no record did before.
fn cover_pixel(r: Record, tile: u32, lane: u32) {
    let px = tile_pixels(params, tile);
    let x = px.x + lane % TILE_SIZE;
    let y = px.y + lane / TILE_SIZE;
    if x >= px.z || y >= px.w {
        return;
    }
    let pixel = y * params.width + x;
    if atomicLoad(&covered[pixel]) != 0u {
        return;
    }
    let v = vis[pixel];
    if v.instance == NO_HIT {
        return;
    }
    if reach_error(r, v.position, v.shading_normal) <= params.accuracy {
        if atomicExchange(&covered[pixel], 1u) == 0u {
            atomicAdd(&marked[0], 1u);
        }
    }
}

// The record (its reach, `record_reach`) and this invocation's pixel of each tile.
struct TileVisitor {
    record: Record,
    lane: u32,
}

fn visit_tile(v: TileVisitor, tile: u32) {
    cover_pixel(v.record, tile, v.lane);
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    // One workgroup a record, split over y past the per-dimension limit.
    let k = params.first_record + group.y * groups.x + group.x;
    if k >= params.record_end {
        return;
    }
    // The record's reach (uniform over the workgroup: every invocation walks the same tiles).
    let r = record_reach(k);
    let reach = params.accuracy * r.radius;
    let tiles = sphere_tiles(camera, params, r.position, reach);
    walk_reached_tiles(TileVisitor(r, lane), tiles, r.position, reach, r.normal);
}
