// Records from virtual point lights (instant caching, seed 003; src/records/vpl_gather.rs):
// one 64-lane workgroup per record site. Lane l takes the VPLs l, l + 64, ... of
// [vpl_begin, vpl_end) (llvmpipe's loop budget splits the VPLs over dispatches; each lane
// keeps its running sums in `partials`), traces one visibility ray to each VPL in front of
// the site and sums, in that fixed order:
// - E = sum power cos_x cos_y / d^2 f(d) over the visible VPLs (seed 003 eq. 1-3, rho
//   applied at the pixel as for every record);
// - the rotational gradient sum c / cos_x (n x w) (a turn of n changes only cos_x);
// - the translational gradient, the derivative of each visible term by the site's
//   position (visibility held fixed, as Ward's gradients of a plane hold its hits);
// - 1 / t over every ray in front, cosine-weighted, t the distance to the VPL or to what
//   blocks it: a harmonic mean distance R of what surrounds the site, so that `-a` keeps
//   its meaning (seed 003 eq. 5 drops R and makes a a distance; algorithms.md 1.3).
// The dispatch that ends the VPLs sums the 64 lanes in lane order (lane 0), clamps R like
// the plane reduction (record_reduce.wgsl: [R_min, R_max], neighbours, Ward's gradient
// limit) and writes the record. CPU mirror: records::vpl_gather::reference_record.
//!include shared/bvh.wgsl
//!include shared/sampling.wgsl
//!include shared/records.wgsl
//!include shared/vpl.wgsl

const LANES: u32 = 64u;

struct VplGatherParams {
    count: u32,
    first_record: u32,
    vpl_begin: u32,
    vpl_end: u32,
    vpl_count: u32,
    gradients: u32,
    r_max_factor: f32,
    neighbour_clamp: u32,
    clamp_distance: f32,   // min_d of seed 003 eq. 2
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// One lane's running sums (Rust: records::vpl_gather::Partial).
struct Partial {
    irradiance: vec3f,
    inv_distance: f32,            // sum of cos_x / t
    rotation: array<vec4f, 3>,    // per channel, world space
    translation: array<vec4f, 3>,
    cos_sum: f32,
    neighbour_bound: f32,
    _pad: vec2f,
}

@group(1) @binding(0) var<uniform> params: VplGatherParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> vpls: array<Vpl>;
@group(1) @binding(3) var<storage, read_write> partials: array<Partial>;
@group(1) @binding(4) var<storage, read_write> records: array<Record>;

fn zero_partial() -> Partial {
    var p: Partial;
    p.irradiance = vec3f(0.0);
    p.inv_distance = 0.0;
    for (var c = 0u; c < 3u; c++) {
        p.rotation[c] = vec4f(0.0);
        p.translation[c] = vec4f(0.0);
    }
    p.cos_sum = 0.0;
    p.neighbour_bound = 1.0e30;
    p._pad = vec2f(0.0);
    return p;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) lane: u32) {
    bvh_stack_init(lane);
    let record = group.x;
    let slot = record * LANES + lane;
    let site = sites[record];
    let n = site.normal;
    let origin = offset_ray_origin(site.position, site.geometric_normal);
    let min_d = params.clamp_distance;
    var acc = zero_partial();
    if params.vpl_begin > 0u {
        acc = partials[slot];
    }
    for (var j = params.vpl_begin + lane; j < params.vpl_end; j += LANES) {
        let v = vpls[j];
        if all(v.power == vec3f(0.0)) {
            continue;
        }
        let w = v.position - site.position;
        let d2 = dot(w, w);
        let d = sqrt(d2);
        let dir = w / d;
        let cos_x = dot(n, dir);
        let cos_y = -dot(v.normal, dir);
        if !(cos_x > 0.0 && cos_y > 0.0 && dot(site.geometric_normal, dir) > 0.0) {
            continue;
        }
        let to_vpl = v.position - origin;
        let h = trace(Ray(origin, 0.0, to_vpl, 1.0 - 1.0e-4), false);
        var t = d;
        if h.instance != NO_HIT {
            t = h.t * length(to_vpl);
        }
        acc.inv_distance += cos_x / t;
        acc.cos_sum += cos_x;
        if h.instance != NO_HIT {
            continue;
        }
        let f = vpl_bound(d, min_d);
        let g = cos_x * cos_y / d2 * f;
        acc.irradiance += v.power * g;
        // d/dx of a b f(d) / d^4 with a = n.w, b = -n_y.w, w = y - x.
        let a = cos_x * d;
        let b = cos_y * d;
        let d4 = d2 * d2;
        let grad = (f / d4) * (v.normal * a - n * b + w * (4.0 * a * b / d2))
            - w * (a * b / d4 * vpl_bound_derivative(d, min_d) / d);
        let turn = cross(n, dir) * (g / cos_x);
        for (var c = 0u; c < 3u; c++) {
            acc.rotation[c] += vec4f(turn * v.power[c], 0.0);
            acc.translation[c] += vec4f(grad * v.power[c], 0.0);
        }
    }
    let last = params.vpl_end >= params.vpl_count;
    if last && params.neighbour_clamp != 0u {
        // Neighbour clamping on insertion (as record_reduce.wgsl), strided over the lanes.
        for (var k = lane; k < params.first_record; k += LANES) {
            acc.neighbour_bound = min(acc.neighbour_bound,
                                      records[k].radius + length(records[k].position - site.position));
        }
    }
    partials[slot] = acc;
    if !last {
        return;
    }
    storageBarrier();
    if lane != 0u {
        return;
    }
    var sum = zero_partial();
    for (var l = 0u; l < LANES; l++) {
        let p = partials[record * LANES + l];
        sum.irradiance += p.irradiance;
        sum.inv_distance += p.inv_distance;
        sum.cos_sum += p.cos_sum;
        sum.neighbour_bound = min(sum.neighbour_bound, p.neighbour_bound);
        for (var c = 0u; c < 3u; c++) {
            sum.rotation[c] += p.rotation[c];
            sum.translation[c] += p.translation[c];
        }
    }
    var out: Record;
    out.position = site.position;
    out.normal = n;
    out.r_min = site.r_min;
    out.irradiance = sum.irradiance;
    out.instance = site.instance;
    let r_max = site.r_min * params.r_max_factor;
    var radius = r_max;
    if sum.inv_distance > 0.0 {
        radius = clamp(sum.cos_sum / sum.inv_distance, site.r_min, r_max);
    }
    radius = max(min(radius, sum.neighbour_bound), site.r_min);
    let e = sum.irradiance;
    var rot = array<vec3f, 3>(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    var tr = array<vec3f, 3>(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    if params.gradients != 0u {
        for (var c = 0u; c < 3u; c++) {
            rot[c] = sum.rotation[c].xyz;
            // Along the surface only, as a plane's gradients.
            let g = sum.translation[c].xyz;
            tr[c] = g - n * dot(n, g);
        }
        // Ward's gradient limit, as record_reduce.wgsl.
        var limited = radius;
        for (var c = 0u; c < 3u; c++) {
            let g = length(tr[c]);
            if g * limited > e[c] {
                limited = e[c] / g;
            }
        }
        radius = max(limited, site.r_min);
        for (var c = 0u; c < 3u; c++) {
            let g = length(tr[c]);
            if g * radius > e[c] {
                tr[c] *= e[c] / (g * radius);
            }
        }
    }
    out.radius = radius;
    for (var c = 0u; c < 3u; c++) {
        out.rotation_gradient[c] = vec4f(rot[c], 0.0);
        out.translation_gradient[c] = vec4f(tr[c], 0.0);
    }
    records[params.first_record + record] = out;
}
