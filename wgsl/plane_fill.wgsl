// Temporal reprojection, step 3 of 3: read the reprojected plane back into plane samples.
// A cell that received a sample takes that sample (radiance at t+1, its new depth); an
// empty cell (a hole opened by motion) takes the deepest of its eight neighbours, the
// local background (seed 000 section V-a, thesis 5.3: "the neighbouring value with the
// highest depth"). A hole wider than that (a record that moves with its instance sees
// nearby surfaces shift by many cells: a record just above a floor sees rows of the floor
// spread apart) keeps the sample traced at t in the same cell: with nothing known about
// it at t+1, it is assumed unchanged, where a miss (black) would bias E(t+1), and so tau,
// low (up to 30 % on records at the foot of a moving cube). `samples` holds the plane
// traced at t (P x P per record); `estimate` receives the estimate at t+1 and `subset` the
// samples at t the estimate was moved from, both (P/stride)^2 per record (with stride 1,
// the whole plane at t). Reads only the reprojected cells, never filled ones, so the
// result does not depend on thread order. The estimate then goes through the ordinary
// record reduction to give E(t+1) and its gradients (with stride > 1, the subset at t too:
// tau is the ratio of the two).
//!include shared/records.wgsl

struct FillParams {
    estimate_resolution: u32,
    count: u32,
    resolution: u32,
    stride: u32,
}

@group(1) @binding(0) var<uniform> params: FillParams;
@group(1) @binding(1) var<storage, read> cells: array<u32>;
@group(1) @binding(2) var<storage, read> moved: array<vec4f>;
@group(1) @binding(3) var<storage, read> samples: array<PlaneSample>;   // traced at t
@group(1) @binding(4) var<storage, read_write> estimate: array<PlaneSample>;   // at t+1
@group(1) @binding(5) var<storage, read_write> subset: array<PlaneSample>;   // at t

fn sample_of(fine_base: u32, key: u32) -> PlaneSample {
    let m = moved[fine_base + reprojection_sample(key)];
    return PlaneSample(m.xyz, m.w);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let res = params.estimate_resolution;
    if id.x >= res || id.y >= res || id.z >= params.count {
        return;
    }
    let fine = params.resolution;
    let fine_base = id.z * fine * fine;
    let base = id.z * res * res;
    let cell = base + id.y * res + id.x;
    let own = ~cells[cell];   // stored complemented
    // The sample traced at t in this cell: the fallback for a wide hole.
    let traced = samples[fine_base + subset_pixel(id.y, params.stride, res) * fine
        + subset_pixel(id.x, params.stride, res)];
    var out = traced;
    if own != EMPTY_CELL {
        out = sample_of(fine_base, own);
    } else {
        // Deepest filled neighbour; the key orders by depth, then by sample index.
        var best = 0u;
        var found = false;
        for (var dy = -1; dy <= 1; dy++) {
            for (var dx = -1; dx <= 1; dx++) {
                let x = i32(id.x) + dx;
                let y = i32(id.y) + dy;
                if (dx == 0 && dy == 0) || x < 0 || y < 0 || x >= i32(res) || y >= i32(res) {
                    continue;
                }
                let key = ~cells[base + u32(y) * res + u32(x)];
                if key != EMPTY_CELL && (!found || key > best) {
                    best = key;
                    found = true;
                }
            }
        }
        if found {
            out = sample_of(fine_base, best);
        }
    }
    estimate[cell] = out;
    subset[cell] = traced;
}
