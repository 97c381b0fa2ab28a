// Irradiance records, the hemisphere plane's tables and Ward's weighting, shared by the
// record, splat and placement passes (Rust mirrors: src/records/mod.rs, plane.rs).
//!include shared/sampling.wgsl

// One irradiance record (144 bytes; Rust: records::Record). Gradients are per colour
// channel and additive (algorithms.md decision 3), stored as world-space vectors.
struct Record {
    position: vec3f,
    radius: f32,                   // R_k, harmonic mean distance clamped to [R_min, R_max]
    normal: vec3f,
    r_min: f32,
    irradiance: vec3f,             // E_k (rgb)
    instance: u32,                 // the instance it lies on (temporal records can move with it)
    rotation_gradient: array<vec4f, 3>,     // per channel: grad_r (xyz); [0].w relative noise, [1].w [2].w corral
    translation_gradient: array<vec4f, 3>,  // per channel: grad_t (xyz)
}

// A radiance record's coefficient block (records/kind.rs) starts with its plane frame:
// tangent and bitangent, each padded to a vec4.
const FRAME_FLOATS: u32 = 8u;

// The channel sum r + g + b, added in that order (no product for a GPU to fuse, so the GPU
// and the CPU mirrors, records::refine and records::reference, compute the same bits):
// refinement's contrast and a record's relative noise.
fn channel_sum(c: vec3f) -> f32 {
    return (c.x + c.y) + c.z;
}

// Depth of the nearer of two plane samples (Ward's min rule for the translational
// gradients' pixel edges); <= 0 when both are misses. Rust: records::nearer_depth.
fn nearer_depth(a: f32, b: f32) -> f32 {
    if a <= 0.0 {
        return b;
    }
    if b <= 0.0 {
        return a;
    }
    return min(a, b);
}

// Rust: records::plane::PlanePixel.
struct PlanePixel {
    weights: vec4f,   // cos_weight, solid_angle, edge_x, edge_y
    rot_center: vec4f,// rotation gradient weight (xy), pixel centre on the plane (zw)
}

// One traced plane pixel (Rust: records::PlaneSample).
struct PlaneSample {
    radiance: vec3f,
    depth: f32,       // hit depth along the record normal, Z = r cos(theta); < 0 on a miss
}

// What a plane sample hit (Rust: records::PlaneHit): the surface is rebuilt from it at
// the next frame, where only instance transforms have changed (temporal reprojection).
struct PlaneHit {
    instance: u32,    // NO_HIT on a miss
    triangle: u32,
    u: f32,
    v: f32,
}

// Reprojected plane cells (temporal caching): a u32 key per cell, (depth bits, sample
// index), so atomicMin keeps the nearest sample and breaks depth ties by index. Depths are
// positive floats, whose bit patterns order like their values; the low 14 bits give way
// to the index (planes up to 128 x 128), leaving a relative depth precision of 2^-9.
const REPROJECTION_INDEX_BITS: u32 = 14u;
const REPROJECTION_INDEX_MASK: u32 = 0x3fffu;
const EMPTY_CELL: u32 = 0xffffffffu;
// Depth of a miss: farther than any hit, its key still below EMPTY_CELL.
const MISS_DEPTH: f32 = 3.0e38;

fn reprojection_key(depth: f32, sample: u32) -> u32 {
    return (bitcast<u32>(depth) & ~REPROJECTION_INDEX_MASK) | sample;
}

fn reprojection_sample(key: u32) -> u32 {
    return key & REPROJECTION_INDEX_MASK;
}

// The E(t+1) estimate may use every `stride`-th plane sample each way (a plane of P/stride
// cells, `estimate_resolution`): cell i of that plane takes the plane pixel of the
// stride x stride block i nearest the plane's centre, so the subset is symmetric about it.
// stride 1: pixel i. Mirrored by `temporal::reprojection::subset_pixel`.
fn subset_pixel(i: u32, stride: u32, estimate_resolution: u32) -> u32 {
    return i * stride + select(0u, stride - 1u, 2u * i + 1u < estimate_resolution);
}

// Ward's weight denominator |p - p_k| / R_k + sqrt(1 - n.n_k) (thesis eq. 4.2): the record
// contributes iff it is <= a (w >= 1/a, eq. 4.3) and p is not behind p_k.
fn record_error(r: Record, p: vec3f, n: vec3f) -> f32 {
    return length(p - r.position) / r.radius + sqrt(max(0.0, 1.0 - dot(n, r.normal)));
}

// "Behind" test (Ward, algorithms.md 1.4): (p - p_k).(n + n_k)/2 >= -eps, eps relative to
// the record's validity radius so it does not depend on the scene's scale.
fn record_in_front(r: Record, p: vec3f, n: vec3f, accuracy: f32) -> bool {
    return dot(p - r.position, n + r.normal) * 0.5 >= -1.0e-2 * accuracy * r.radius;
}

// Irradiance of record k extrapolated to (p, n) with its gradients (decision 3), each
// channel clamped at 0.
fn record_irradiance_at(r: Record, p: vec3f, n: vec3f) -> vec3f {
    let axis = cross(r.normal, n);
    let d = p - r.position;
    var e = r.irradiance;
    e.x += dot(axis, r.rotation_gradient[0].xyz) + dot(d, r.translation_gradient[0].xyz);
    e.y += dot(axis, r.rotation_gradient[1].xyz) + dot(d, r.translation_gradient[1].xyz);
    e.z += dot(axis, r.rotation_gradient[2].xyz) + dot(d, r.translation_gradient[2].xyz);
    return max(e, vec3f(0.0));
}

// Where a new record goes (48 bytes; Rust: records::RecordSite).
struct RecordSite {
    position: vec3f,
    r_min: f32,                // smallest allowed R (tied to the pixel footprint)
    normal: vec3f,             // shading normal: the record's hemisphere
    seed: u32,                 // scrambles the plane's light samples
    geometric_normal: vec3f,   // offsets ray origins off the surface
    instance: u32,             // the instance it lies on
}

// Index of the first light sample of plane sample `index` (a pixel, or past the pixels a
// refinement sub-sample) in its record's sequences: every light sample of one record's plane
// comes from one Owen-scrambled Sobol sequence per light (seeded by the site's seed), `count`
// per sample, so the one or few samples each hit takes stratify the light over the whole
// plane instead of being drawn independently per hit (measured on the Cornell box 128x128,
// a 0.1: indirect error 1.39 % -> 1.19 %).
fn plane_light_first(index: u32, count: u32) -> u32 {
    return index * count;
}

// The tangent frame of a record's hemisphere plane: Duff et al.'s basis around the normal,
// turned about it by an angle drawn from the site's seed. Planes of nearby records with the
// same normal would otherwise put their pixel centres along the same directions, and their
// errors (which pixels see a small bright patch) would be the same error: turned, the
// overlapping records a pixel interpolates err independently and average out.
fn record_frame(site: RecordSite) -> mat3x3f {
    let base = orthonormal_basis(site.normal);
    let turn = record_frame_turn(site);
    let c = turn.x;
    let s = turn.y;
    return mat3x3f(c * base[0] + s * base[1], c * base[1] - s * base[0], base[2]);
}

// (cos, sin) of the angle `record_frame` turns Duff's basis by: a plane coordinate (x, y)
// lies along (c x - s y, s x + c y) in Duff's basis (the corral's sectors).
fn record_frame_turn(site: RecordSite) -> vec2f {
    let angle = 6.283185307179586 * u32_to_unit(hash_combine(site.seed, 0x7f4a7c15u));
    return vec2f(cos(angle), sin(angle));
}

// Ward's gradient limit (decision 5): where |grad_t| R would exceed E, shrink R (not below
// R_min), then scale down the translational gradients that still exceed. Returns R. Used
// by every record source's reduction (record_reduce.wgsl, vpl_gather.wgsl).
fn limit_by_gradient(radius: f32, r_min: f32, e: vec3f, tr: ptr<function, array<vec3f, 3>>) -> f32 {
    var limited = radius;
    for (var c = 0u; c < 3u; c++) {
        let g = length((*tr)[c]);
        if g * limited > e[c] {
            limited = e[c] / g;
        }
    }
    let r = max(limited, r_min);
    for (var c = 0u; c < 3u; c++) {
        let g = length((*tr)[c]);
        if g * r > e[c] {
            (*tr)[c] *= e[c] / (g * r);
        }
    }
    return r;
}
