// Ward's gradient limit for radiance records (records/radiance_projection.rs; CPU mirror
// `limit_gradients`): the irradiance records' rule (records.wgsl `limit_by_gradient`, Ward &
// Heckbert 1992) applied to the whole coefficient vector over the record's reach a R (a the
// radiance accuracy: the splat uses a record only within a R of it, thesis eq. 4.4).
// Per channel, with V = |lambda| (the L2 norm of the incoming radiance over the hemisphere,
// the HSH basis being orthonormal) and G = sqrt(sum_k |grad lambda_k|^2): R shrinks to
// V / (a G), never below R_min; where R_min binds, the gradients are scaled so that
// a G R = V. The first-order extrapolation (thesis eq. 4.6 with eq. 3.33's gradients) then
// moves the coefficients by at most their own norm anywhere the record is used.
// Why: a record a few cm from an object (the back wall behind the Cornell box's tall block,
// a floor beside a cube) sees it at depths far below its reach, and the edge slopes
// (L_b - L_a) / z are exact only over displacements below z. Unlimited, they carried the
// wall's pixels beside the block to 20-70x their light (docs/results.md).
// One workgroup per record; the norms are summed by lane in a fixed order, then a tree:
// deterministic.
//!include shared/records.wgsl

const THREADS: u32 = 64u;

struct LimitParams {
    coefficients: u32,  // order^2
    count: u32,         // records in the batch
    first_record: u32,
    stride: u32,        // f32s per coefficient block
    reach: f32,         // a: the record is used within a R
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> params: LimitParams;
@group(1) @binding(1) var<storage, read_write> records: array<Record>;
@group(1) @binding(2) var<storage, read_write> coefficients: array<f32>;

// Per lane: squared norms of the values and of the gradients, per channel.
var<workgroup> value_sums: array<vec3f, THREADS>;
var<workgroup> gradient_sums: array<vec3f, THREADS>;
var<workgroup> scale: vec3f;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wg: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    let record = wg.x;
    if record >= params.count {
        return;
    }
    let n = params.coefficients;
    let base = (params.first_record + record) * params.stride + FRAME_FLOATS;
    var v = vec3f(0.0);
    var g = vec3f(0.0);
    for (var k = lane; k < n; k += THREADS) {
        for (var c = 0u; c < 3u; c++) {
            let value = coefficients[base + c * n + k];
            let gx = coefficients[base + 3u * n + c * n + k];
            let gy = coefficients[base + 6u * n + c * n + k];
            v[c] += value * value;
            g[c] += gx * gx + gy * gy;
        }
    }
    value_sums[lane] = v;
    gradient_sums[lane] = g;
    workgroupBarrier();
    for (var stride = THREADS / 2u; stride > 0u; stride /= 2u) {
        if lane < stride {
            value_sums[lane] += value_sums[lane + stride];
            gradient_sums[lane] += gradient_sums[lane + stride];
        }
        workgroupBarrier();
    }
    if lane == 0u {
        let i = params.first_record + record;
        let norm = sqrt(value_sums[0]);
        let slope = sqrt(gradient_sums[0]) * params.reach;
        var limited = records[i].radius;
        for (var c = 0u; c < 3u; c++) {
            if slope[c] * limited > norm[c] {
                limited = norm[c] / slope[c];
            }
        }
        let r = max(limited, records[i].r_min);
        records[i].radius = r;
        var s = vec3f(1.0);
        for (var c = 0u; c < 3u; c++) {
            if slope[c] * r > norm[c] {
                s[c] = norm[c] / (slope[c] * r);
            }
        }
        scale = s;
    }
    let s = workgroupUniformLoad(&scale);
    if all(s == vec3f(1.0)) {
        return;
    }
    for (var k = lane; k < n; k += THREADS) {
        for (var c = 0u; c < 3u; c++) {
            coefficients[base + 3u * n + c * n + k] *= s[c];
            coefficients[base + 6u * n + c * n + k] *= s[c];
        }
    }
}
