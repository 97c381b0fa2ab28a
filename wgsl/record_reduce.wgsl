// Record reduction: one workgroup per record sums its plane in a fixed order (each thread a
// fixed strided subset, then a tree), giving E, the harmonic mean distance R and both
// gradients straight from the plane (algorithms.md 3.3), then clamps R (decision 5, and
// optionally by its neighbours).
//!include shared/records.wgsl
//!include shared/corral.wgsl
//!include shared/record_hessian.wgsl
//!include shared/sampling.wgsl
//!include shared/neighbour_grid.wgsl
//!include shared/plane_texels.wgsl

const THREADS: u32 = 64u;
const SUM_LANES: u32 = 128u;

// 1: records::RecordRadius::Hessian (R from the irradiance's curvature); 0: the split
// sphere. A pipeline constant, so each pipeline carries only its rule's code.
override RECORD_RADIUS_HESSIAN: bool = false;
// 1: the records get corrals (shared/corral.wgsl; records::Corral::in_gathers): a pipeline
// constant, so that a pipeline without them carries none of their code.
override CORRAL: bool = false;

struct ReduceParams {
    resolution: u32,
    count: u32,
    first_record: u32,
    gradients: u32,         // 0: store zero gradients
    r_max_factor: f32,      // R_max = r_max_factor * R_min (Ward: 64)
    cos_weight_sum: f32,    // sum of the plane's cosine weights (pi when stretched)
    neighbour_clamp: u32,   // 1: R <= R_j + |p - p_j| over the records before this batch
    hessian_scale: f32,     // with RECORD_RADIUS_HESSIAN: R = hessian_scale sqrt(E / lambda)
}

@group(1) @binding(0) var<uniform> params: ReduceParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> plane: array<PlanePixel>;
@group(1) @binding(3) var<storage, read> samples: array<PlaneSample>;
@group(1) @binding(4) var<storage, read_write> records: array<Record>;
@group(1) @binding(5) var<uniform> grid: NeighbourGrid;
@group(1) @binding(6) var<storage, read> grid_offsets: array<u32>;   // cells + 1
@group(1) @binding(7) var<storage, read> grid_records: array<u32>;
// With TABLE_TEXELS: `samples` and `plane` as texel tables (shared/plane_texels.wgsl).
@group(1) @binding(8) var sample_texels: texture_2d<u32>;
@group(1) @binding(9) var pixel_texels: texture_2d<u32>;

struct Partial {
    irradiance: vec3f,
    inv_distance: f32,      // sum of cos_weight / r over hits
    rotation_x: vec3f,      // tangent-frame components, per channel
    rotation_y: vec3f,
    translation_x: vec3f,
    translation_y: vec3f,
    hessian: vec3f,         // luminance Hessian (xx, xy, yy), record_hessian.wgsl
    variance: f32,          // the plane's sampling variance (records::reference::plane_noise)
}

var<workgroup> partials: array<Partial, THREADS>;
var<workgroup> neighbour_bounds: array<f32, THREADS>;
var<workgroup> shared_radius: f32;
// Per corral vertex, the nearest horizon hit's horizontal distance h as ~bits(h): positive
// floats order like their bits, so the largest key is the nearest hit, whatever order the
// lanes add them in; 0 (workgroup memory starts zeroed) is no hit.
var<workgroup> corral_keys: array<atomic<u32>, CORRAL_SECTORS>;

fn add(a: Partial, b: Partial) -> Partial {
    return Partial(
        a.irradiance + b.irradiance,
        a.inv_distance + b.inv_distance,
        a.rotation_x + b.rotation_x,
        a.rotation_y + b.rotation_y,
        a.translation_x + b.translation_x,
        a.translation_y + b.translation_y,
        a.hessian + b.hessian,
        a.variance + b.variance,
    );
}

// Adds plane pixel k of the plane at `base` to `acc`. Each sample and plane pixel is loaded
// once here, for the Hessian's edges and the other sums alike (a storage load is a loop over
// the lanes on lavapipe; the Hessian's edges read the same neighbours again).
fn accumulate(acc: ptr<function, Partial>, base: u32, k: u32, res: u32, far: f32, turn: vec2f) {
    let count = res * res;
    let i = k % res;
    let s = plane_sample(base + k);
    let px = plane_pixel(k);
    // The corral: the plane's outermost ring holds the rays nearest the horizon.
    let j = k / res;
    if CORRAL && s.depth > 0.0 && (i == 0u || j == 0u || i + 1u == res || j + 1u == res) {
        let c = px.rot_center.zw;
        let h = s.depth * length(c);
        let t = corral_turn(turn.x * c.x - turn.y * c.y, turn.y * c.x + turn.x * c.y);
        // Within a quarter sector of vertex round(t).
        let vertex = u32(round(t));
        if abs(t - f32(vertex)) <= 0.25 {
            atomicMax(&corral_keys[vertex % CORRAL_SECTORS], ~bitcast<u32>(h));
        }
    }
    let has_right = i + 1u < res;
    let has_up = k + res < count;
    var right: PlaneSample;
    var up: PlaneSample;
    if has_right {
        right = plane_sample(base + k + 1u);
    }
    if has_up {
        up = plane_sample(base + k + res);
    }
    // Quad (i, j) exists where both its right and up edges are inside the plane.
    if RECORD_RADIUS_HESSIAN && has_right && has_up {
        let upright = plane_sample(base + k + res + 1u);
        let vp = hessian_vertex(px.rot_center.zw, s, far);
        let vr = hessian_vertex(plane_pixel(k + 1u).rot_center.zw, right, far);
        let vu = hessian_vertex(plane_pixel(k + res).rot_center.zw, up, far);
        let vur = hessian_vertex(plane_pixel(k + res + 1u).rot_center.zw, upright, far);
        let has_b = k >= res;
        let has_l = i > 0u;
        var vb = vec4f(0.0);
        var lb = 0.0;
        var vl = vec4f(0.0);
        var ll = 0.0;
        if has_b {
            let below = plane_sample(base + k + 1u - res);
            vb = hessian_vertex(plane_pixel(k + 1u - res).rot_center.zw, below, far);
            lb = dot(below.radiance, LUMINANCE);
        }
        if has_l {
            let left = plane_sample(base + k + res - 1u);
            vl = hessian_vertex(plane_pixel(k + res - 1u).rot_center.zw, left, far);
            ll = dot(left.radiance, LUMINANCE);
        }
        (*acc).hessian += hessian_edges(
            vp, dot(s.radiance, LUMINANCE),
            vr, dot(right.radiance, LUMINANCE),
            vu, dot(up.radiance, LUMINANCE),
            vur, dot(upright.radiance, LUMINANCE),
            has_b, vb, lb, has_l, vl, ll,
        );
    }
    let w = px.weights;
    (*acc).irradiance += s.radiance * w.x;
    if s.depth > 0.0 {
        let c = px.rot_center.zw;
        // r = Z / cos(theta) at the pixel centre.
        (*acc).inv_distance += w.x / (s.depth * sqrt(1.0 + dot(c, c)));
    }
    // Rotational gradient: sum L (n x w) dw (algorithms.md 3.3).
    (*acc).rotation_x += s.radiance * px.rot_center.x;
    (*acc).rotation_y += s.radiance * px.rot_center.y;
    // Translational gradient: each pixel edge sweeps with the nearer depth. The same edges
    // give the plane's sampling variance, w^2 (y_k - y_j)^2 / 4 per edge (plane_noise).
    let y = channel_sum(s.radiance);
    let w2 = w.x * w.x * 0.25;
    if has_right {
        let z = nearer_depth(s.depth, right.depth);
        if z > 0.0 {
            (*acc).translation_x += (right.radiance - s.radiance) * (w.z / z);
        }
        let dy = channel_sum(right.radiance) - y;
        (*acc).variance += w2 * dy * dy;
    }
    if has_up {
        let z = nearer_depth(s.depth, up.depth);
        if z > 0.0 {
            (*acc).translation_y += (up.radiance - s.radiance) * (w.w / z);
        }
        let dy = channel_sum(up.radiance) - y;
        (*acc).variance += w2 * dy * dy;
    }
}

// The record's relative noise sqrt(V) / (E_r + E_g + E_b) from its plane's sampling
// variance V (records::reference::plane_noise); 0 for a dark plane.
fn relative_noise(variance: f32, e: vec3f) -> f32 {
    let total = channel_sum(e);
    return select(0.0, sqrt(variance) / total, total > 0.0);
}

// R in [R_min, R_max] from the reduced plane, before neighbour clamping.
fn unclamped_radius(sum: Partial, site: RecordSite) -> f32 {
    let r_max = site.r_min * params.r_max_factor;
    // Harmonic mean distance, cosine-weighted (misses add 0 to the sum of 1/r).
    var radius = r_max;
    let lum = dot(sum.irradiance, LUMINANCE) * INV_PI;
    // A plane that saw no light at all (lum 0) says nothing of the irradiance's curvature:
    // it takes the split sphere's radius, as Ward's records, rather than R_max, which
    // spread its zero over whole floors (docs/results.md, "Dark records").
    let split_sphere = !RECORD_RADIUS_HESSIAN || lum <= 0.0;
    if !split_sphere {
        // Second-order error control (records::RecordRadius::Hessian): the relative
        // curvature lambda / E of the irradiance sets R, so that the error left after the
        // gradients, lambda d^2 / 2E, is (a hessian_scale)^2 / 2 at d = a R.
        let lambda = largest_eigenvalue(sum.hessian);
        if lambda > 0.0 {
            radius = clamp(params.hessian_scale * sqrt(lum / lambda), site.r_min, r_max);
        }
    } else if sum.inv_distance > 0.0 {
        radius = clamp(params.cos_weight_sum / sum.inv_distance, site.r_min, r_max);
    }
    return radius;
}

// The minimum of `v` over the workgroup's lanes (every lane gets it).
fn workgroup_min(lane: u32, v: f32) -> f32 {
    neighbour_bounds[lane] = v;
    workgroupBarrier();
    // One lane takes the minimum (any order gives the same value): one barrier, where a
    // tree takes one a level (lavapipe runs every invocation to each barrier).
    if lane == 0u {
        var m = neighbour_bounds[0];
        for (var i = 1u; i < THREADS; i++) {
            m = min(m, neighbour_bounds[i]);
        }
        neighbour_bounds[0] = m;
    }
    let m = workgroupUniformLoad(&neighbour_bounds[0]);
    // Nobody writes the array again before every lane has read it.
    workgroupBarrier();
    return m;
}

// min over earlier records j of R_j + |p - p_j|, searched in the grid ring by ring
// (Chebyshev distance k from p's cell), stopping once the rings left (all at least k
// cells away, so at least k cell_size from p) cannot beat what was found or `limit`
// (the record's R before clamping: bounds above it change nothing). Exact where it
// matters: it returns the brute-force minimum whenever that is below `limit`, else a
// value at least `limit`. The 1e-3 cell margin covers the rounding of positions into
// cells.
fn grid_neighbour_bound(p: vec3f, limit: f32, lane: u32) -> f32 {
    let h = grid.cell_size;
    let c = vec3i(neighbour_grid_cell(grid, p));
    let top = vec3i(grid.dims) - vec3i(1);
    let reach = max(max(max(c.x, top.x - c.x), max(c.y, top.y - c.y)), max(c.z, top.z - c.z));
    var best = 1.0e30;
    var k = 0;
    loop {
        let lo = max(c - vec3i(k), vec3i(0));
        let hi = min(c + vec3i(k), top);
        let size = vec3u(hi - lo + vec3i(1));
        let total = size.x * size.y * size.z;
        for (var t = lane; t < total; t += THREADS) {
            let o = lo + vec3i(vec3u(t % size.x, (t / size.x) % size.y, t / (size.x * size.y)));
            let d = abs(o - c);
            if max(d.x, max(d.y, d.z)) != k {
                continue;     // an inner ring's cell, already searched
            }
            let cell = neighbour_grid_index(grid, vec3u(o));
            let end = grid_offsets[cell + 1u];
            for (var i = grid_offsets[cell]; i < end; i++) {
                let j = grid_records[i];
                best = min(best, records[j].radius + length(records[j].position - p));
            }
        }
        let found = workgroup_min(lane, best);
        if k >= reach || (f32(k) - 1.0e-3) * h >= min(found, limit) {
            break;
        }
        k += 1;
    }
    return best;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) lane: u32) {
    let record = group.x;
    let res = params.resolution;
    let count = res * res;
    let base = record * count;
    // The sums run over SUM_LANES = 2 THREADS strided subsets of the plane, two per
    // invocation, reduced by a tree whose first level each invocation does itself: the
    // same order of additions, the same bytes, as 128 invocations of one subset each
    // (lavapipe ran the reduction in 0.8x the time with 64: its barriers cost per
    // invocation).
    var low = Partial(vec3f(0.0), 0.0, vec3f(0.0), vec3f(0.0), vec3f(0.0), vec3f(0.0), vec3f(0.0), 0.0);
    var high = low;
    if record < params.count {
        let far = HESSIAN_MISS_DISTANCE * sites[record].r_min * params.r_max_factor;
        let turn = record_frame_turn(sites[record]);
        // One loop over both subsets, alternately (`low` takes k = lane, lane + 128, ...,
        // `high` lane + 64, lane + 192, ...: each the same terms in the same order as a loop
        // of its own), so that `accumulate` is inlined once: its second copy was a fifth of
        // this pipeline's build on lavapipe (nave-west 25 -> 20 ms, docs/results.md stop 68).
        for (var k = lane; k < count; k += THREADS) {
            let odd = ((k - lane) / THREADS) % 2u == 1u;
            var acc = low;
            if odd {
                acc = high;
            }
            accumulate(&acc, base, k, res, far, turn);
            if odd {
                high = acc;
            } else {
                low = acc;
            }
        }
    }
    partials[lane] = add(low, high);
    workgroupBarrier();
    // The tree's additions, level by level, done by one lane: the same sums in the same
    // order (so the same bits) behind one barrier (the uniform load's) instead of one a
    // level. Then R before its neighbours bound it (the grid search below stops by it).
    if lane == 0u {
        for (var stride = THREADS / 2u; stride > 0u; stride /= 2u) {
            for (var i = 0u; i < stride; i++) {
                partials[i] = add(partials[i], partials[i + stride]);
            }
        }
        if record < params.count {
            shared_radius = unclamped_radius(partials[0], sites[record]);
        }
    }
    let unclamped = workgroupUniformLoad(&shared_radius);
    // Neighbour clamping on insertion (Krivanek et al. 2006, algorithms.md 1.8): R_new <=
    // R_j + |p_new - p_j| for every record j placed before this batch, the triangle
    // inequality of the distance to the nearest surface, so a record cannot claim a wider
    // validity than its neighbours' distances allow (records are never shrunk after they
    // are placed, so coverage stays exact). The minimum does not depend on the order in
    // which records are visited, so both searches give the same bytes.
    // A record already at R_min keeps it whatever the bound (R = max(min(R, bound), R_min)):
    // no search (on Sponza sun at the defaults, over half the records).
    var bound = 1.0e30;
    if params.neighbour_clamp != 0u && record < params.count && unclamped > sites[record].r_min {
        let p = sites[record].position;
        if grid.enabled != 0u {
            bound = grid_neighbour_bound(p, unclamped, lane);
        } else {
            // Every earlier record, each lane a strided subset.
            for (var j = lane; j < params.first_record; j += THREADS) {
                bound = min(bound, records[j].radius + length(records[j].position - p));
            }
        }
    }
    bound = workgroup_min(lane, bound);
    if lane != 0u || record >= params.count {
        return;
    }
    let sum = partials[0];
    let site = sites[record];
    var out: Record;
    out.position = site.position;
    out.normal = site.normal;
    out.r_min = site.r_min;
    out.irradiance = sum.irradiance;
    out.instance = site.instance;
    var radius = max(min(unclamped, bound), site.r_min);
    let frame = record_frame(site);
    let e = sum.irradiance;
    var rot = array<vec3f, 3>(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    var tr = array<vec3f, 3>(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    if params.gradients != 0u {
        for (var c = 0u; c < 3u; c++) {
            rot[c] = frame * vec3f(sum.rotation_x[c], sum.rotation_y[c], 0.0);
            tr[c] = frame * vec3f(sum.translation_x[c], sum.translation_y[c], 0.0);
        }
        radius = limit_by_gradient(radius, site.r_min, e, &tr);
    }
    out.radius = radius;
    for (var c = 0u; c < 3u; c++) {
        out.rotation_gradient[c] = vec4f(rot[c], 0.0);
        out.translation_gradient[c] = vec4f(tr[c], 0.0);
    }
    out.rotation_gradient[0].w = relative_noise(sum.variance, e);
    if CORRAL {
        // The corral's vertices against the final R (shared/corral.wgsl), eight a word, each word
        // stored as an exact integer (under 2^24).
        var words = vec2u(0u);
        for (var vertex = 0u; vertex < CORRAL_SECTORS; vertex++) {
            let key = atomicLoad(&corral_keys[vertex]);
            let h = select(-1.0, bitcast<f32>(~key), key != 0u);
            let bits = corral_level(h, radius) << (CORRAL_BITS * (vertex % CORRAL_PER_WORD));
            if vertex < CORRAL_PER_WORD {
                words.x |= bits;
            } else {
                words.y |= bits;
            }
        }
        out.rotation_gradient[1].w = f32(words.x);
        out.rotation_gradient[2].w = f32(words.y);
    }
    records[params.first_record + record] = out;
}
