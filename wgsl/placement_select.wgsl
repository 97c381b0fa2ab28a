// Placement (cache-miss detection): in every active cell of a grid, the uncovered visible
// pixel nearest the cell centre (ties: the first in scan order) becomes a candidate site.
// Cells are active by parity (one of the four 2x2 classes per round), so candidates of
// one round are at least a cell apart and new records do not crowd each other.
//!include shared/ray.wgsl
//!include shared/camera.wgsl

const NO_CANDIDATE: u32 = 0xffffffffu;

struct SelectParams {
    width: u32,
    height: u32,
    cell_size: u32,
    cells_x: u32,
    cells_y: u32,
    parity: u32,   // 0..3: active cells have (cx % 2, cy % 2) == (parity % 2, parity / 2)
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> params: SelectParams;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read> covered: array<u32>;   // splat_cover.wgsl
@group(1) @binding(3) var<storage, read_write> candidates: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let half_x = (params.cells_x + 1u - params.parity % 2u) / 2u;
    let half_y = (params.cells_y + 1u - params.parity / 2u) / 2u;
    if id.x >= half_x * half_y {
        return;
    }
    let cx = 2u * (id.x % half_x) + params.parity % 2u;
    let cy = 2u * (id.x / half_x) + params.parity / 2u;
    let x0 = cx * params.cell_size;
    let y0 = cy * params.cell_size;
    let x1 = min(x0 + params.cell_size, params.width);
    let y1 = min(y0 + params.cell_size, params.height);
    let center = vec2f(f32(x0 + x1), f32(y0 + y1)) * 0.5;
    var best = NO_CANDIDATE;
    var best_d2 = 1.0e30;
    for (var y = y0; y < y1; y++) {
        for (var x = x0; x < x1; x++) {
            let pixel = y * params.width + x;
            if vis[pixel].instance == NO_HIT || covered[pixel] != 0u {
                continue;
            }
            let d = vec2f(f32(x) + 0.5, f32(y) + 0.5) - center;
            let d2 = dot(d, d);
            if d2 < best_d2 {
                best_d2 = d2;
                best = pixel;
            }
        }
    }
    candidates[id.x] = best;
}
