// Projection of hemisphere planes onto hemispherical harmonics (records/radiance_projection.rs):
// lambda_k = sum_p L_p W_pk, W the basis integrated over each plane pixel's solid angle, and
// the translational gradient of every coefficient, sum over pixel edges of the radiance
// difference across the edge times the edge's H_k weight over the nearer depth
// (algorithms.md 3.3). One invocation per (coefficient, plane), its three channels, summing the
// pixels in order: deterministic. CPU mirror: radiance_projection::project_with_gradients.
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
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> params: ProjectParams;
@group(1) @binding(1) var<storage, read> table: array<f32>;   // per pixel: W, edge x, edge y
@group(1) @binding(2) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(3) var<storage, read> samples: array<PlaneSample>;
@group(1) @binding(4) var<storage, read_write> coefficients: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let n = params.coefficients;
    if id.x >= n || id.y >= params.count {
        return;
    }
    // Coefficient k of all three channels: each sample and table entry is read once.
    let k = id.x;
    let res = params.resolution;
    let base = id.y * params.pixels;
    var value = vec3f(0.0);
    var gx = vec3f(0.0);
    var gy = vec3f(0.0);
    for (var p = 0u; p < params.pixels; p++) {
        let s = samples[base + p];
        let t = p * 3u * n + k;
        value += s.radiance * table[t];
        if p % res + 1u < res {
            let right = samples[base + p + 1u];
            let z = nearer_depth(s.depth, right.depth);
            if z > 0.0 {
                gx += (right.radiance - s.radiance) * (table[t + n] / z);
            }
        }
        if p + res < params.pixels {
            let up = samples[base + p + res];
            let z = nearer_depth(s.depth, up.depth);
            if z > 0.0 {
                gy += (up.radiance - s.radiance) * (table[t + 2u * n] / z);
            }
        }
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
        coefficients[first + 3u * n + c * n + k] = gx[c];
        coefficients[first + 6u * n + c * n + k] = gy[c];
    }
}
