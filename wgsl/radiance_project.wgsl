// Projection of hemisphere planes onto hemispherical harmonics (records/radiance_projection.rs):
// lambda_k = sum_p L_p W_pk, W the basis integrated over each plane pixel's solid angle
// (computed once per plane on the CPU). One invocation per (coefficient and channel,
// plane), summing the pixels in order: deterministic. CPU mirror: radiance_projection::project.

struct ProjectParams {
    pixels: u32,        // P^2
    coefficients: u32,  // order^2
    count: u32,         // planes
    _pad: u32,
}

// A plane sample (Rust: records::PlaneSample).
struct Sample {
    radiance: vec3f,
    depth: f32,
}

@group(1) @binding(0) var<uniform> params: ProjectParams;
@group(1) @binding(1) var<storage, read> weights: array<f32>;
@group(1) @binding(2) var<storage, read> samples: array<Sample>;
@group(1) @binding(3) var<storage, read_write> coefficients: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let n = params.coefficients;
    if id.x >= 3u * n || id.y >= params.count {
        return;
    }
    let c = id.x / n;
    let k = id.x % n;
    let base = id.y * params.pixels;
    var sum = 0.0;
    for (var p = 0u; p < params.pixels; p++) {
        sum += samples[base + p].radiance[c] * weights[p * n + k];
    }
    coefficients[id.y * 3u * n + id.x] = sum;
}
