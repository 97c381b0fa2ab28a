// Placement (cache-miss detection): in every active cell of a grid, the uncovered visible
// pixel nearest the cell centre (ties: the first in scan order) becomes a candidate site.
// Cells are active by parity (one of the four 2x2 classes per round), so candidates of
// one round are at least a cell apart and new records do not crowd each other. One
// dispatch selects the classes `first_parity..4` together, against the same coverage
// (placement uses the first with candidates: src/placement): class after class in
// `candidates`, each its cells in order. (A dispatch a class cost about 80 us each on
// lavapipe, 43 of them in a frame of nave-west.)
//!include shared/ray.wgsl
//!include shared/camera.wgsl

const NO_CANDIDATE: u32 = 0xffffffffu;

struct SelectParams {
    width: u32,
    height: u32,
    cell_size: u32,
    cells_x: u32,
    cells_y: u32,
    first_parity: u32,   // 0..3: class p has the cells (cx % 2, cy % 2) == (p % 2, p / 2)
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> params: SelectParams;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read> covered: array<u32>;   // splat_cover.wgsl
@group(1) @binding(3) var<storage, read_write> candidates: array<u32>;

// Cells of parity class `parity` along x and y.
fn class_cells(parity: u32) -> vec2u {
    return vec2u((params.cells_x + 1u - parity % 2u) / 2u, (params.cells_y + 1u - parity / 2u) / 2u);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    // This invocation's class and cell in it.
    var parity = params.first_parity;
    var cell = id.x;
    var half = class_cells(parity);
    loop {
        if cell < half.x * half.y {
            break;
        }
        cell -= half.x * half.y;
        parity += 1u;
        if parity >= 4u {
            return;
        }
        half = class_cells(parity);
    }
    let cx = 2u * (cell % half.x) + parity % 2u;
    let cy = 2u * (cell / half.x) + parity / 2u;
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
