// Records from virtual point lights (instant caching, seed 003; src/records/vpl_gather.rs):
// one 64-lane workgroup per record. Lane l takes the VPLs of the 32-slot words l, l + 64,
// ... of [vpl_begin, vpl_end) (llvmpipe's loop budget splits the VPLs over dispatches;
// each lane keeps its running sums in `partials`), finds whether each VPL in front of the
// site is visible and sums, in that fixed order:
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
//
// Two modes. Gather (mode 0): new records at `sites`, every visibility ray traced. Update
// (mode 1, temporal instant caching, seed 003 Algorithm 1): records 0..count of the cache
// at frame t, whose visibility bits (one per VPL slot, `visibility`) say what their rays
// found at t - 1; a ray is traced again only where its VPL changed (`changed`: Cases 1-2)
// or the segment meets the box of an instance that moved between t - 1 and t at either
// end (`moving`, shared/movers.wgsl: Cases 3-4, conservatively by boxes as the seed allows
// for Case 4); elsewhere its bit is reused. The record keeps its R (the lengths of reused
// rays are not kept), then Ward's gradient limit applies to the new gradients. Records on
// moved instances are deleted before (Case 5). `counters` counts traced and reused rays.
//!include shared/sampling.wgsl
//!include shared/movers.wgsl
//!include shared/records.wgsl
//!include shared/vpl.wgsl

const LANES: u32 = 64u;
const MODE_GATHER: u32 = 0u;
const MODE_UPDATE: u32 = 1u;

struct VplGatherParams {
    count: u32,
    first_record: u32,
    vpl_begin: u32,          // a multiple of 32 * LANES
    vpl_end: u32,
    vpl_count: u32,
    gradients: u32,
    r_max_factor: f32,
    neighbour_clamp: u32,
    clamp_distance: f32,     // min_d of seed 003 eq. 2
    mode: u32,
    visibility_words: u32,   // per record; 0: no bits kept
    moving_count: u32,       // shared/movers.wgsl
    movers_lo: vec4f,
    movers_hi: vec4f,
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
@group(1) @binding(5) var<storage, read_write> visibility: array<u32>;
@group(1) @binding(6) var<storage, read> changed: array<u32>;
@group(1) @binding(7) var<storage, read> moving: array<MovingBounds>;
@group(1) @binding(8) var<storage, read_write> counters: array<atomic<u32>>;  // traced, reused

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

// The site of record `index` updated in place: its geometric normal is not kept, so its
// shading normal offsets the rays (Rust: vpl_gather::site_of).
fn site_of(r: Record) -> RecordSite {
    return RecordSite(r.position, r.r_min, r.normal, 0u, r.normal, r.instance);
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) lane: u32) {
    bvh_stack_init(lane);
    let record = group.x;
    let index = params.first_record + record;
    let slot = record * LANES + lane;
    let update = params.mode == MODE_UPDATE;
    var site: RecordSite;
    if update {
        site = site_of(records[index]);
    } else {
        site = sites[record];
    }
    let n = site.normal;
    let origin = offset_ray_origin(site.position, site.geometric_normal);
    let min_d = params.clamp_distance;
    let bits_base = index * params.visibility_words;
    var acc = zero_partial();
    if params.vpl_begin > 0u {
        acc = partials[slot];
    }
    var traced = 0u;
    var reused = 0u;
    let words_end = (params.vpl_end + 31u) / 32u;
    for (var word = params.vpl_begin / 32u + lane; word < words_end; word += LANES) {
        var old = 0u;
        var stale = 0xffffffffu;
        if update {
            old = visibility[bits_base + word];
            stale = changed[word];
        }
        var bits = 0u;
        for (var b = 0u; b < 32u; b++) {
            let j = word * 32u + b;
            if j >= params.vpl_end {
                break;
            }
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
            var visible = ((old >> b) & 1u) != 0u;
            var t = d;
            if ((stale >> b) & 1u) != 0u || meets_a_mover(origin, to_vpl, 1.0) {
                let h = trace(Ray(origin, 0.0, to_vpl, 1.0 - 1.0e-4), false);
                visible = h.instance == NO_HIT;
                if !visible {
                    t = h.t * length(to_vpl);
                }
                traced++;
            } else {
                reused++;
            }
            if !update {
                acc.inv_distance += cos_x / t;
                acc.cos_sum += cos_x;
            }
            if !visible {
                continue;
            }
            bits |= 1u << b;
            let f = vpl_bound(d, min_d);
            let g = cos_x * cos_y / d2 * f;
            acc.irradiance += v.power * g;
            // d/dx of a b f(d) / d^4 with a = n.w, b = -n_y.w, w = y - x.
            let a = cos_x * d;
            let bb = cos_y * d;
            let d4 = d2 * d2;
            let grad = (f / d4) * (v.normal * a - n * bb + w * (4.0 * a * bb / d2))
                - w * (a * bb / d4 * vpl_bound_derivative(d, min_d) / d);
            let turn = cross(n, dir) * (g / cos_x);
            for (var c = 0u; c < 3u; c++) {
                acc.rotation[c] += vec4f(turn * v.power[c], 0.0);
                acc.translation[c] += vec4f(grad * v.power[c], 0.0);
            }
        }
        if params.visibility_words > 0u {
            visibility[bits_base + word] = bits;
        }
    }
    if update {
        atomicAdd(&counters[0], traced);
        atomicAdd(&counters[1], reused);
    }
    let last = params.vpl_end >= params.vpl_count;
    if last && !update && params.neighbour_clamp != 0u {
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
    if update {
        radius = records[index].radius;
    } else {
        if sum.inv_distance > 0.0 {
            radius = clamp(sum.cos_sum / sum.inv_distance, site.r_min, r_max);
        }
        radius = max(min(radius, sum.neighbour_bound), site.r_min);
    }
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
        radius = limit_by_gradient(radius, site.r_min, e, &tr);
    }
    out.radius = radius;
    for (var c = 0u; c < 3u; c++) {
        out.rotation_gradient[c] = vec4f(rot[c], 0.0);
        out.translation_gradient[c] = vec4f(tr[c], 0.0);
    }
    records[index] = out;
}
