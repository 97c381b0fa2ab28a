// Projection of hemisphere planes onto hemispherical harmonics (records/radiance_projection.rs):
// lambda_k = sum_p L_p W_pk, W the basis integrated over each plane pixel's solid angle, and
// the translational gradient of every coefficient, sum over pixel edges of the radiance
// difference across the edge over the nearer depth, times the edge's H_k weight
// (algorithms.md 3.3). One invocation per (plane, block of BLOCK coefficients), their three
// channels, summing the pixels in order: deterministic. The lanes of a workgroup are
// planes, so every lane reads the same basis weights (one load for the workgroup) and its
// own plane's samples, each sample and edge slope once per block. With `values_only` (an
// estimate at t+1 that only gives tau) the gradients are neither summed nor written.
// CPU mirror: radiance_projection::project_with_gradients.
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
    table_section: u32, // f32s per section of a pixel's table (order^2 padded to BLOCK)
}

@group(1) @binding(0) var<uniform> params: ProjectParams;
// Per pixel: W, edge x, edge y, each padded with zeros to table_section f32s.
@group(1) @binding(1) var<storage, read> table: array<f32>;
@group(1) @binding(2) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(3) var<storage, read> samples: array<PlaneSample>;
@group(1) @binding(4) var<storage, read_write> coefficients: array<f32>;

// Coefficients per invocation (records/radiance_projection.rs COEFFICIENTS_PER_INVOCATION),
// written out below as BLOCK accumulators (v, x, y: value and gradients). Measured on
// lavapipe, glossy Cornell box 256x256 (order 8): one coefficient per invocation with the
// samples staged in workgroup memory 2.7 s; a block of 4 1.2 s, 8 0.95 s, 16 0.80 s, 32
// 0.69 s (16 divides order 4's 16 coefficients and order 8's 64 without waste).
const BLOCK: u32 = 16u;

// (L_b - L_a) / z, z the nearer depth of the two samples; zero without one.
fn edge_slope(a: PlaneSample, b: PlaneSample) -> vec3f {
    let z = nearer_depth(a.depth, b.depth);
    if z > 0.0 {
        return (b.radiance - a.radiance) / z;
    }
    return vec3f(0.0);
}

// Coefficient k of plane `plane`'s record block: its value and, unless values only, its
// two gradients.
fn write_coefficient(out: u32, k: u32, value: vec3f, gx: vec3f, gy: vec3f, gradients: bool) {
    let n = params.coefficients;
    if k >= n {
        return;
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

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let plane = id.x;
    if plane >= params.count {
        return;
    }
    let res = params.resolution;
    let k0 = id.y * BLOCK;
    let gradients = params.values_only == 0u;
    let base = plane * params.pixels;
    // Coefficients past the last (the section's zero padding) are summed, never written.
    let w = params.table_section;
    var v0 = vec3f(0.0);
    var x0 = vec3f(0.0);
    var y0 = vec3f(0.0);
    var v1 = vec3f(0.0);
    var x1 = vec3f(0.0);
    var y1 = vec3f(0.0);
    var v2 = vec3f(0.0);
    var x2 = vec3f(0.0);
    var y2 = vec3f(0.0);
    var v3 = vec3f(0.0);
    var x3 = vec3f(0.0);
    var y3 = vec3f(0.0);
    var v4 = vec3f(0.0);
    var x4 = vec3f(0.0);
    var y4 = vec3f(0.0);
    var v5 = vec3f(0.0);
    var x5 = vec3f(0.0);
    var y5 = vec3f(0.0);
    var v6 = vec3f(0.0);
    var x6 = vec3f(0.0);
    var y6 = vec3f(0.0);
    var v7 = vec3f(0.0);
    var x7 = vec3f(0.0);
    var y7 = vec3f(0.0);
    var v8 = vec3f(0.0);
    var x8 = vec3f(0.0);
    var y8 = vec3f(0.0);
    var v9 = vec3f(0.0);
    var x9 = vec3f(0.0);
    var y9 = vec3f(0.0);
    var v10 = vec3f(0.0);
    var x10 = vec3f(0.0);
    var y10 = vec3f(0.0);
    var v11 = vec3f(0.0);
    var x11 = vec3f(0.0);
    var y11 = vec3f(0.0);
    var v12 = vec3f(0.0);
    var x12 = vec3f(0.0);
    var y12 = vec3f(0.0);
    var v13 = vec3f(0.0);
    var x13 = vec3f(0.0);
    var y13 = vec3f(0.0);
    var v14 = vec3f(0.0);
    var x14 = vec3f(0.0);
    var y14 = vec3f(0.0);
    var v15 = vec3f(0.0);
    var x15 = vec3f(0.0);
    var y15 = vec3f(0.0);
    if gradients {
        for (var p = 0u; p < params.pixels; p++) {
            let s = samples[base + p];
            var sx = vec3f(0.0);
            if p % res + 1u < res {
                sx = edge_slope(s, samples[base + p + 1u]);
            }
            var sy = vec3f(0.0);
            if p + res < params.pixels {
                sy = edge_slope(s, samples[base + p + res]);
            }
            let t = p * 3u * w + k0;
            v0 += s.radiance * table[t];
            x0 += sx * table[t + w];
            y0 += sy * table[t + 2u * w];
            v1 += s.radiance * table[t + 1u];
            x1 += sx * table[t + w + 1u];
            y1 += sy * table[t + 2u * w + 1u];
            v2 += s.radiance * table[t + 2u];
            x2 += sx * table[t + w + 2u];
            y2 += sy * table[t + 2u * w + 2u];
            v3 += s.radiance * table[t + 3u];
            x3 += sx * table[t + w + 3u];
            y3 += sy * table[t + 2u * w + 3u];
            v4 += s.radiance * table[t + 4u];
            x4 += sx * table[t + w + 4u];
            y4 += sy * table[t + 2u * w + 4u];
            v5 += s.radiance * table[t + 5u];
            x5 += sx * table[t + w + 5u];
            y5 += sy * table[t + 2u * w + 5u];
            v6 += s.radiance * table[t + 6u];
            x6 += sx * table[t + w + 6u];
            y6 += sy * table[t + 2u * w + 6u];
            v7 += s.radiance * table[t + 7u];
            x7 += sx * table[t + w + 7u];
            y7 += sy * table[t + 2u * w + 7u];
            v8 += s.radiance * table[t + 8u];
            x8 += sx * table[t + w + 8u];
            y8 += sy * table[t + 2u * w + 8u];
            v9 += s.radiance * table[t + 9u];
            x9 += sx * table[t + w + 9u];
            y9 += sy * table[t + 2u * w + 9u];
            v10 += s.radiance * table[t + 10u];
            x10 += sx * table[t + w + 10u];
            y10 += sy * table[t + 2u * w + 10u];
            v11 += s.radiance * table[t + 11u];
            x11 += sx * table[t + w + 11u];
            y11 += sy * table[t + 2u * w + 11u];
            v12 += s.radiance * table[t + 12u];
            x12 += sx * table[t + w + 12u];
            y12 += sy * table[t + 2u * w + 12u];
            v13 += s.radiance * table[t + 13u];
            x13 += sx * table[t + w + 13u];
            y13 += sy * table[t + 2u * w + 13u];
            v14 += s.radiance * table[t + 14u];
            x14 += sx * table[t + w + 14u];
            y14 += sy * table[t + 2u * w + 14u];
            v15 += s.radiance * table[t + 15u];
            x15 += sx * table[t + w + 15u];
            y15 += sy * table[t + 2u * w + 15u];
        }
    } else {
        for (var p = 0u; p < params.pixels; p++) {
            let r = samples[base + p].radiance;
            let t = p * 3u * w + k0;
            v0 += r * table[t];
            v1 += r * table[t + 1u];
            v2 += r * table[t + 2u];
            v3 += r * table[t + 3u];
            v4 += r * table[t + 4u];
            v5 += r * table[t + 5u];
            v6 += r * table[t + 6u];
            v7 += r * table[t + 7u];
            v8 += r * table[t + 8u];
            v9 += r * table[t + 9u];
            v10 += r * table[t + 10u];
            v11 += r * table[t + 11u];
            v12 += r * table[t + 12u];
            v13 += r * table[t + 13u];
            v14 += r * table[t + 14u];
            v15 += r * table[t + 15u];
        }
    }
    let out = (params.first_record + plane) * params.stride;
    if id.y == 0u {
        let frame = record_frame(sites[plane]);
        coefficients[out] = frame[0].x;
        coefficients[out + 1u] = frame[0].y;
        coefficients[out + 2u] = frame[0].z;
        coefficients[out + 3u] = 0.0;
        coefficients[out + 4u] = frame[1].x;
        coefficients[out + 5u] = frame[1].y;
        coefficients[out + 6u] = frame[1].z;
        coefficients[out + 7u] = 0.0;
    }
    write_coefficient(out, k0 + 0u, v0, x0, y0, gradients);
    write_coefficient(out, k0 + 1u, v1, x1, y1, gradients);
    write_coefficient(out, k0 + 2u, v2, x2, y2, gradients);
    write_coefficient(out, k0 + 3u, v3, x3, y3, gradients);
    write_coefficient(out, k0 + 4u, v4, x4, y4, gradients);
    write_coefficient(out, k0 + 5u, v5, x5, y5, gradients);
    write_coefficient(out, k0 + 6u, v6, x6, y6, gradients);
    write_coefficient(out, k0 + 7u, v7, x7, y7, gradients);
    write_coefficient(out, k0 + 8u, v8, x8, y8, gradients);
    write_coefficient(out, k0 + 9u, v9, x9, y9, gradients);
    write_coefficient(out, k0 + 10u, v10, x10, y10, gradients);
    write_coefficient(out, k0 + 11u, v11, x11, y11, gradients);
    write_coefficient(out, k0 + 12u, v12, x12, y12, gradients);
    write_coefficient(out, k0 + 13u, v13, x13, y13, gradients);
    write_coefficient(out, k0 + 14u, v14, x14, y14, gradients);
    write_coefficient(out, k0 + 15u, v15, x15, y15, gradients);
}
