// Projection of hemisphere planes onto hemispherical harmonics (records/radiance_projection.rs):
// lambda_k = sum_p L_p W_pk, W the basis integrated over each plane pixel's solid angle, and
// the translational gradient of every coefficient, sum over pixel edges of the radiance
// difference across the edge over the nearer depth, times the edge's H_k weight
// (algorithms.md 3.3). One invocation per (coefficient, plane), its three channels, summing the
// pixels in order: deterministic; a workgroup (64 coefficients of one plane) stages the
// plane's samples and edge slopes in workgroup memory, CHUNK pixels at a time, so each
// difference and division is done once per pixel, not once per coefficient. With
// `values_only` (an estimate at t+1 that only gives tau) the gradients are neither summed
// nor written. CPU mirror: radiance_projection::project_with_gradients.
// Writes the radiance record's block (records/kind.rs): its frame, then values, x- and
// y-gradients, channel-major.
//!include shared/records.wgsl

struct ProjectParams {
    pixels: u32,        // P^2
    resolution: u32,    // P
    coefficients: u32,  // order^2
    count: u32,         // planes
    first_record: u32,  // index of the batch's first record
    stride: u32,        // f32s per record block
    values_only: u32,   // 1: coefficient values only (gradients left as they are)
    _pad0: u32,
}

@group(1) @binding(0) var<uniform> params: ProjectParams;
@group(1) @binding(1) var<storage, read> table: array<f32>;   // per pixel: W, edge x, edge y
@group(1) @binding(2) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(3) var<storage, read> samples: array<PlaneSample>;
@group(1) @binding(4) var<storage, read_write> coefficients: array<f32>;

// Pixels staged in workgroup memory per round: each sample and its two edge slopes are
// read and computed once per workgroup instead of once per coefficient.
const CHUNK: u32 = 256u;
var<workgroup> chunk_radiance: array<vec3f, CHUNK>;
// The radiance difference across the pixel's right (up) edge over the nearer depth; zero
// where there is no edge or both sides miss (nearer depth <= 0).
var<workgroup> chunk_slope_x: array<vec3f, CHUNK>;
var<workgroup> chunk_slope_y: array<vec3f, CHUNK>;

// (L_b - L_a) / z, z the nearer depth of the two samples; zero without one.
fn edge_slope(a: PlaneSample, b: PlaneSample) -> vec3f {
    let z = nearer_depth(a.depth, b.depth);
    if z > 0.0 {
        return (b.radiance - a.radiance) / z;
    }
    return vec3f(0.0);
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    let n = params.coefficients;
    // No early return: every invocation reaches the barriers (the workgroup is one plane).
    let plane_valid = id.y < params.count;
    let computing = plane_valid && id.x < n;
    // Coefficient k of all three channels, the pixels summed in order (as the CPU mirror).
    let k = id.x;
    let res = params.resolution;
    let base = id.y * params.pixels;
    var value = vec3f(0.0);
    var gx = vec3f(0.0);
    var gy = vec3f(0.0);
    let gradients = params.values_only == 0u;
    for (var start = 0u; start < params.pixels; start += CHUNK) {
        let len = min(CHUNK, params.pixels - start);
        if plane_valid {
            for (var j = lane; j < len; j += 64u) {
                let p = start + j;
                let s = samples[base + p];
                chunk_radiance[j] = s.radiance;
                if gradients {
                    var sx = vec3f(0.0);
                    if p % res + 1u < res {
                        sx = edge_slope(s, samples[base + p + 1u]);
                    }
                    chunk_slope_x[j] = sx;
                    var sy = vec3f(0.0);
                    if p + res < params.pixels {
                        sy = edge_slope(s, samples[base + p + res]);
                    }
                    chunk_slope_y[j] = sy;
                }
            }
        }
        workgroupBarrier();
        if computing {
            if gradients {
                for (var j = 0u; j < len; j++) {
                    let t = (start + j) * 3u * n + k;
                    value += chunk_radiance[j] * table[t];
                    gx += chunk_slope_x[j] * table[t + n];
                    gy += chunk_slope_y[j] * table[t + 2u * n];
                }
            } else {
                for (var j = 0u; j < len; j++) {
                    value += chunk_radiance[j] * table[(start + j) * 3u * n + k];
                }
            }
        }
        workgroupBarrier();
    }
    if !computing {
        return;
    }
    let out = (params.first_record + id.y) * params.stride;
    if k == 0u {
        let frame = record_frame(sites[id.y]);
        coefficients[out] = frame[0].x;
        coefficients[out + 1u] = frame[0].y;
        coefficients[out + 2u] = frame[0].z;
        coefficients[out + 3u] = 0.0;
        coefficients[out + 4u] = frame[1].x;
        coefficients[out + 5u] = frame[1].y;
        coefficients[out + 6u] = frame[1].z;
        coefficients[out + 7u] = 0.0;
    }
    let first = out + FRAME_FLOATS;
    for (var c = 0u; c < 3u; c++) {
        coefficients[first + c * n + k] = value[c];
        if gradients {
            coefficients[first + 3u * n + c * n + k] = gx[c];
            coefficients[first + 6u * n + c * n + k] = gy[c];
        }
    }
}
