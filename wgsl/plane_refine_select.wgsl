// Adaptive plane refinement, step 1 (Radiance's -as, Ward's "super-sample high variance
// regions ... detect variance based on neighborhood", algorithms.md 1.7): per record, one
// workgroup ranks the plane's pixels by contrast and writes the `refined` pixels of highest
// contrast, in pixel order, to `selected`. Contrast: the largest difference of the channel
// sum r + g + b between two of the pixel's 4-neighbours (its own sample left out, so that
// refining it does not depend on it: refining pixels for their own extreme sample undid
// only the lucky hits of patches smaller than a pixel, a bias, records::refine), times
// the pixel's cosine weight (what a wrong pixel costs E). Ties go to the lower pixel
// index. The selection is exact and deterministic: a radix select on the contrast's bits
// (non-negative floats order as their bits) with integer workgroup histograms, then
// prefix sums in pixel order. A plane without light anywhere
// has no contrast to rank: its K slots all say DARK_PLANE, and hemisphere_plane.wgsl then
// refines every pixel of it (or those a guided selection lists, DARK_GUIDED). Every plane
// with pixels to refine appends its workgroups after the batch's selections, and sizes the
// indirect dispatch that refines them (`refine_dispatch`). The CPU mirror is
// records::refine::select_pixels.
//!include shared/records.wgsl
//!include shared/lit_grid_query.wgsl
//!include shared/refine_selection.wgsl
//!include shared/plane_texels.wgsl

// 64 threads: a 24x24 plane gives each 9 pixels. On lavapipe a workgroup's threads run as
// SIMD loops split at every barrier, so the select's dozen barriers cost per thread: 256
// threads (2-3 pixels each) spent more on them than on the pixels.
const THREADS: u32 = 64u;

struct SelectParams {
    resolution: u32,
    count: u32,
    refined: u32,       // K pixels to select per record by contrast (0 <= K <= P^2)
    slots: u32,         // selection slots per record, max(K, 1): a dark plane's flag
    dark_planes: u32,   // 1: dark planes are refined everywhere (dark_plane_refine)
    guided: u32,        // 1: a dark plane refines only pixels near a lit voxel
    per_group: u32,     // refined pixels per workgroup of hemisphere_plane.wgsl
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> params: SelectParams;
@group(1) @binding(1) var<storage, read> plane: array<PlanePixel>;
@group(1) @binding(2) var<storage, read> samples: array<PlaneSample>;
@group(1) @binding(3) var<storage, read_write> keys: array<u32>;
@group(1) @binding(4) var<storage, read_write> selected: array<u32>;
// For the frame's ray count (RecordPass::take_refinement_rays): planes refined everywhere,
// pixels listed by guided dark planes, guided dark planes, lit planes' unused slots.
@group(1) @binding(5) var<storage, read_write> ray_counts: array<atomic<u32>>;
// Per sample: what its environment samples gave it (hemisphere_plane.wgsl `noise`; zeros
// where the plane pass did not write them).
@group(1) @binding(6) var<storage, read> noise: array<f32>;
@group(1) @binding(7) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(8) var<uniform> lit_grid_params: LitGridParams;
@group(1) @binding(9) var<storage, read> lit_grid: array<u32>;
// The indirect dispatch (x y z, cleared before this pass) that refines the planes, and
// (element 3) how many workgroups it holds: one per `per_group` pixels of each plane.
@group(1) @binding(10) var<storage, read_write> refine_dispatch: array<atomic<u32>, 4>;
// The plane's pixels by cosine weight, largest first (ties: lower index), for
// `fill_near_light` (records::refine::filler_order).
@group(1) @binding(11) var<storage, read> filler_order: array<u32>;
// With TABLE_TEXELS: `samples` and `plane` as texel tables (shared/plane_texels.wgsl).
@group(1) @binding(12) var sample_texels: texture_2d<u32>;
@group(1) @binding(13) var pixel_texels: texture_2d<u32>;

// Appends the workgroups that refine `record`, a plane with `pixels` pixels to refine,
// after the batch's selections (cleared before this pass): workgroup g of the plane is
// item `(g << 16 | record) + 1` (0: none), so that no workgroup of that dispatch is idle
// (as one sized by the largest plane's pixels left most, or one that gave the dark planes
// a lit plane's K). Their order varies from run to run; each refines its own pixels, so
// the result does not.
fn push_refined_plane(record: u32, pixels: u32) {
    let groups = (pixels + params.per_group - 1u) / params.per_group;
    if groups == 0u {
        return;
    }
    let start = atomicAdd(&refine_dispatch[3], groups);
    let tail = params.count * params.slots;
    for (var g = 0u; g < groups; g++) {
        selected[tail + start + g] = refine_item(record, g);
    }
    // x up to 65535 a row, then y rows (shared/work_list.wgsl's rule).
    let end = start + groups;
    atomicMax(&refine_dispatch[0], min(end, 65535u));
    atomicMax(&refine_dispatch[1], (end - 1u) / 65535u + 1u);
    atomicMax(&refine_dispatch[2], 1u);
}

// Hit point of pixel k of the plane at `base` (w: 0 on a miss).
fn plane_hit_point(frame: mat3x3f, origin: vec3f, base: u32, k: u32) -> vec4f {
    let z = plane_sample(base + k).depth;
    if z <= 0.0 {
        return vec4f(0.0);
    }
    return vec4f(origin + frame * vec3f(plane_pixel(k).rot_center.zw, 1.0) * z, 1.0);
}

// How far a pixel's footprint reaches (the largest distance from its hit to a
// neighbour's), whether it or a neighbour missed, and whether any of them hit.
struct NeighbourReach {
    radius: f32,
    missed: bool,
    any_hit: bool,
}

// Takes neighbour hit `q` (w: 0 on a miss) of the pixel hit `p` into `reach` if `present`.
fn reach_neighbour(reach: ptr<function, NeighbourReach>, p: vec4f, q: vec4f, present: bool) {
    if !present {
        return;
    }
    if q.w == 0.0 {
        (*reach).missed = true;
    } else {
        (*reach).any_hit = true;
        if p.w != 0.0 {
            (*reach).radius = max((*reach).radius, length(q.xyz - p.xyz));
        }
    }
}

// Whether offset `e` from a pixel's hit lies on the plane of normal `sn` through it (within
// 2 % of its length).
fn on_plane(e: vec3f, sn: vec3f) -> bool {
    return abs(dot(e, sn)) <= 0.02 * length(e);
}

// Whether pixel k's sub-rays can land near a lit surface (records::refine::near_light):
// the ball that reaches the pixel's 4-neighbours' hits (the pixel's footprint, and across
// an edge the farther surface) must touch a lit voxel whose lit side the pixel's direction
// can see, and where all four neighbours lie on one plane, a lit side facing as that
// surface does. A pixel next to a miss is refined where a neighbour hit (an edge). `own`:
// the ball is centred at the pixel's own hit, and its own miss is an edge too (a dark
// plane, whose samples are all zero); else at its neighbours' mean hit, its own sample
// left out, so that choosing it does not depend on that sample (a lit plane: a centre
// ray that caught a patch smaller than its pixel lands in a lit voxel, and refining the
// pixels whose own ray did undoes exactly the lucky hits, a bias: records::refine).
fn near_light(site: RecordSite, frame: mat3x3f, base: u32, k: u32, own: bool) -> bool {
    let res = params.resolution;
    let n = res * res;
    let i = k % res;
    let p = plane_hit_point(frame, site.position, base, k);
    // The 4-neighbours in fixed slots with a flag each (a dynamically indexed
    // local array is a tree of branches at every access on lavapipe); an
    // absent one loads the pixel itself, unused.
    let has_l = i > 0u;
    let has_r = i + 1u < res;
    let has_d = k >= res;
    let has_u = k + res < n;
    let ql = plane_hit_point(frame, site.position, base, select(k, k - 1u, has_l));
    let qr = plane_hit_point(frame, site.position, base, select(k, k + 1u, has_r));
    let qd = plane_hit_point(frame, site.position, base, select(k, k - res, has_d));
    let qu = plane_hit_point(frame, site.position, base, select(k, k + res, has_u));
    var centre = p;
    if !own {
        // The present neighbours' hits (w: 1 each), summed in a fixed order.
        let sum = select(vec4f(0.0), ql, has_l) + select(vec4f(0.0), qr, has_r)
            + select(vec4f(0.0), qd, has_d) + select(vec4f(0.0), qu, has_u);
        centre = select(vec4f(0.0), vec4f(sum.xyz / sum.w, 1.0), sum.w > 0.0);
    }
    var reach = NeighbourReach(0.0, own && p.w == 0.0, own && p.w != 0.0);
    reach_neighbour(&reach, centre, ql, has_l);
    reach_neighbour(&reach, centre, qr, has_r);
    reach_neighbour(&reach, centre, qd, has_d);
    reach_neighbour(&reach, centre, qu, has_u);
    let radius = reach.radius;
    let missed = reach.missed;
    let any_hit = reach.any_hit;
    var refine = false;
    if missed {
        refine = any_hit;   // an edge against a miss: refine it
    } else if centre.w != 0.0 {
        let d = normalize(frame * vec3f(plane_pixel(k).rot_center.zw, 1.0));
        var faces = lit_faces_seen(d);
        if has_l && has_r && has_d && has_u {
            // All four neighbours on one plane: the pixel's sub-rays land on that
            // surface, whose lit side is one of the faces its normal is near (facing
            // the record).
            var sn = cross(qr.xyz - ql.xyz, qu.xyz - qd.xyz);
            let len = length(sn);
            if len > 0.0 {
                sn = sn / len;
                if dot(sn, d) > 0.0 {
                    sn = -sn;
                }
                let c = centre.xyz;
                let flat = on_plane(ql.xyz - c, sn) && on_plane(qr.xyz - c, sn)
                    && on_plane(qd.xyz - c, sn) && on_plane(qu.xyz - c, sn);
                if flat {
                    faces &= lit_faces_near(sn);
                }
            }
        }
        refine = lit_near(centre.xyz, radius, faces);
    }
    return refine;
}

var<workgroup> histogram: array<atomic<u32>, 256>;
var<workgroup> lit: atomic<u32>;   // any sample of the plane has light
var<workgroup> plane_dark: u32;    // `lit` read once, for a uniform branch
var<workgroup> counts: array<u32, THREADS>;
var<workgroup> prefix_key: u32;
var<workgroup> remaining: u32;
var<workgroup> settled: u32;       // radix select: 1, the bin found takes all its keys; 2, T is 0;
                                   // 3, filled near light: every key above 0
var<workgroup> zero_keys: atomic<u32>;
var<workgroup> need: u32;          // pixels of no contrast still to select near light

// Gives the first `need` pixels of no contrast near light, in `filler_order` (cosine
// weight, largest first; records::refine::filler_order), key 1: above every zero, so that
// the selection takes them. A workgroup tests 64 pixels a step, and stops once it has
// found enough (most lit planes of a hall lit through windows: in a step or two).
fn fill_near_light(lane: u32, record: u32, base: u32) {
    let n = params.resolution * params.resolution;
    let site = sites[record];
    let frame = record_frame(site);
    for (var start = 0u; start < n; start += THREADS) {
        let wanted = workgroupUniformLoad(&need);
        if wanted == 0u {
            break;
        }
        let i = start + lane;
        var k = 0u;
        var found = false;
        if i < n {
            k = filler_order[i];
            found = keys[base + k] == 0u && near_light(site, frame, base, k, false);
        }
        counts[lane] = u32(found);
        scan_counts(lane);
        if found && counts[lane] < wanted {
            keys[base + k] = 1u;
        }
        if lane == THREADS - 1u {
            need = wanted - min(wanted, counts[lane] + u32(found));
        }
    }
    // The keys written here are read by the threads that own their pixels.
    storageBarrier();
}

// The contrast of two samples (channel sums `ya`, `yb`): their difference less what the
// two got from environment samples (`na`, `nb`, from `noise`), which one shadow ray a hit
// samples too coarsely for a difference in it to mean anything. Ranking pixels by that
// noise picked those whose sample happened to be extreme and replaced them by their
// sub-rays' mean, a bias (env-sphere: 0.956 of the reference's mean indirect light,
// docs/results.md). Lights and light maps are exact at a hit (suns, points) or nearly so:
// their differences still count. With no environment it is |ya - yb| bit for bit.
fn edge_contrast(ya: f32, na: f32, yb: f32, nb: f32) -> f32 {
    return max(abs(ya - yb) - (na + nb), 0.0);
}

// Exclusive prefix sum of `counts` in thread order (serial by thread 0: THREADS entries).
fn scan_counts(lane: u32) {
    workgroupBarrier();
    if lane == 0u {
        var sum = 0u;
        for (var t = 0u; t < THREADS; t++) {
            let c = counts[t];
            counts[t] = sum;
            sum += c;
        }
    }
    workgroupBarrier();
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) lane: u32) {
    let record = group.x;
    let res = params.resolution;
    let n = res * res;
    let base = record * n;
    // Each thread owns a contiguous run of pixels (pixel order is thread order).
    let chunk = (n + THREADS - 1u) / THREADS;
    let first = min(lane * chunk, n);
    let last = min(first + chunk, n);
    // A plane without light anywhere (the record's irradiance would be exactly zero) is
    // refined everywhere instead: P^2 centre rays can miss light of a small solid angle
    // (an arcade's floor that sees the sunlit court only between columns, a few degrees
    // above its horizon), and a record that misses it spreads exact zeros. CPU mirror:
    // `select_pixels`.
    if lane == 0u {
        atomicStore(&lit, 0u);
        atomicStore(&zero_keys, 0u);
    }
    workgroupBarrier();
    for (var k = first; k < last; k++) {
        if channel_sum(plane_sample(base + k).radiance) != 0.0 {
            atomicOr(&lit, 1u);
            break;
        }
    }
    workgroupBarrier();
    if lane == 0u {
        plane_dark = u32(atomicLoad(&lit) == 0u);
    }
    if workgroupUniformLoad(&plane_dark) != 0u {
        if params.dark_planes == 0u {
            // Not refined (nor ranked: it has no contrast), however many pixels lit
            // planes refine.
            if lane == 0u {
                selected[record * params.slots] = NO_PIXELS;
            }
            return;
        }
        if params.guided != 0u {
            // Only the pixels whose sub-rays can land near a lit surface
            // (records::refine::guided_pixels): the ball around the pixel's hit that
            // reaches its 4-neighbours' hits (the pixel's footprint, and across an edge
            // the farther surface) must touch a lit voxel whose lit side the pixel's
            // direction can see, and where all four neighbours lie on the pixel's own
            // plane, a lit side facing as that surface does. A pixel that missed is
            // refined where a neighbour hit (an edge). The light maps see every lit
            // surface of such a scene (every light mapped, no environment, no emitters of
            // their own, one bounce: the caller's rule), so the other pixels' sub-rays
            // could only find darkness.
            let site = sites[record];
            let frame = record_frame(site);
            var mine = 0u;
            for (var k = first; k < last; k++) {
                let refine = near_light(site, frame, base, k, true);
                keys[base + k] = u32(refine);
                mine += u32(refine);
            }
            // The listed pixels, in pixel order (each thread's run after the earlier ones).
            atomicAdd(&ray_counts[1], mine);
            counts[lane] = mine;
            scan_counts(lane);
            let row = record * params.slots;
            var slot = counts[lane];
            for (var k = first; k < last; k++) {
                if keys[base + k] != 0u {
                    selected[row + 2u + slot] = k;
                    slot += 1u;
                }
            }
            if lane == THREADS - 1u {
                atomicAdd(&ray_counts[2], 1u);
                selected[row] = DARK_GUIDED;
                selected[row + 1u] = slot;
                push_refined_plane(record, slot);
            }
            return;
        }
        if lane == 0u {
            atomicAdd(&ray_counts[0], 1u);
            push_refined_plane(record, n);
        }
        for (var slot = lane; slot < params.slots; slot += THREADS) {
            selected[record * params.slots + slot] = DARK_PLANE;
        }
        return;
    }
    // Dark planes alone are refined (K = 0, CacheSettings::dark_plane_refine): a lit plane
    // keeps its samples. Its slot says so (it may hold an earlier batch's flag), and
    // hemisphere_plane.wgsl refines none of its pixels.
    if params.refined == 0u {
        if lane == 0u {
            selected[record * params.slots] = 0u;
        }
        return;
    }
    // Keys of exactly zero (no contrast), counted as they are made: the radix select below
    // settles on them.
    var zeros = 0u;
    for (var k = first; k < last; k++) {
        let i = k % res;
        // The 4-neighbours' channel sums and environment shares, each loaded once (a
        // storage load is a per-lane loop on lavapipe), in fixed slots with a flag each:
        // a dynamically indexed local array is a tree of branches at every access there.
        let has_l = i > 0u;
        let has_r = i + 1u < res;
        let has_d = k >= res;
        let has_u = k + res < n;
        let kl = select(k, k - 1u, has_l);
        let kr = select(k, k + 1u, has_r);
        let kd = select(k, k - res, has_d);
        let ku = select(k, k + res, has_u);
        let yl = channel_sum(plane_sample(base + kl).radiance);
        let yr = channel_sum(plane_sample(base + kr).radiance);
        let yd = channel_sum(plane_sample(base + kd).radiance);
        let yu = channel_sum(plane_sample(base + ku).radiance);
        let nl = noise[base + kl];
        let nr = noise[base + kr];
        let nd = noise[base + kd];
        let nu = noise[base + ku];
        // The largest contrast over the pairs of present neighbours (max is exact: the
        // same bits in any order).
        var c = 0.0;
        c = max(c, select(0.0, edge_contrast(yl, nl, yr, nr), has_l && has_r));
        c = max(c, select(0.0, edge_contrast(yl, nl, yd, nd), has_l && has_d));
        c = max(c, select(0.0, edge_contrast(yl, nl, yu, nu), has_l && has_u));
        c = max(c, select(0.0, edge_contrast(yr, nr, yd, nd), has_r && has_d));
        c = max(c, select(0.0, edge_contrast(yr, nr, yu, nu), has_r && has_u));
        c = max(c, select(0.0, edge_contrast(yd, nd, yu, nu), has_d && has_u));
        let key = bitcast<u32>(c * plane_pixel(k).weights.x);
        keys[base + k] = key;
        zeros += u32(key == 0u);
    }
    if zeros != 0u {
        atomicAdd(&zero_keys, zeros);
    }
    if lane == 0u {
        prefix_key = 0u;
        remaining = params.refined;
        settled = 0u;
    }
    if params.guided != 0u {
        // Fewer than K pixels of contrast, where the light maps see every lit surface: the
        // rest of the K go to pixels of no contrast whose sub-rays can land near a lit
        // surface (`near_light`, as a dark plane's), the largest cosine weights first, and
        // none to the others: a sunlit patch between the centre rays is found where it
        // can be, and no ray goes where the lit grid says it cannot find light (the first
        // rows of the plane took them before, by pixel index). Every pixel of a key above
        // 0 is then selected: no radix select.
        workgroupBarrier();
        if lane == 0u {
            let contrast = n - atomicLoad(&zero_keys);
            need = select(0u, params.refined - contrast, contrast < params.refined);
            if need != 0u {
                settled = 3u;
            }
        }
        if workgroupUniformLoad(&need) != 0u {
            fill_near_light(lane, record, base);
        }
    }
    // Radix select, 8 bits a round from the top: the K-th largest key T, and how many of
    // the keys equal to T are taken (`remaining`). Two cases settle it before the fourth
    // round, with the pixels the rounds left would select:
    // - a round's bin holds exactly the keys still to take: every key in that bin and
    //   above is taken, every key below it is not, whatever their lower bits (the rounds
    //   left would narrow the bin down to its smallest key and take all of its ties);
    // - the first round's bin is 0 and holds only zeros (`zero_keys`): T is 0, and the
    //   rounds left would find bin 0 with nothing above it each time. Most lit planes of a
    //   hall lit through windows see fewer than K pixels of contrast (nave-west: all).
    // Each skips the rounds' histograms, the bulk of this pass's work.
    for (var round = 0u; round < 4u; round++) {
        if workgroupUniformLoad(&settled) != 0u {
            break;
        }
        let shift = 24u - 8u * round;
        var mask = 0u;
        if round > 0u {
            mask = 0xffffffffu << (shift + 8u);
        }
        for (var b = lane; b < 256u; b += THREADS) {
            atomicStore(&histogram[b], 0u);
        }
        workgroupBarrier();
        let prefix = prefix_key;
        for (var k = first; k < last; k++) {
            let key = keys[base + k];
            if (key & mask) == prefix {
                atomicAdd(&histogram[(key >> shift) & 255u], 1u);
            }
        }
        workgroupBarrier();
        // The bin of the K-th largest key, from the top: the highest bin where the keys in
        // it and above reach `remaining` (bin 0 if none). Each thread sums its four bins
        // first, so thread 0 walks 64 sums and then four bins, not up to 256 bins (on
        // lavapipe each of its loads is a loop over the lanes: the walk was a third of
        // this pass on the nave). The same bin and count as the walk over every bin.
        let group = (THREADS - 1u - lane) * 4u;   // 252 for thread 0: the top bins first
        counts[lane] = atomicLoad(&histogram[group]) + atomicLoad(&histogram[group + 1u])
            + atomicLoad(&histogram[group + 2u]) + atomicLoad(&histogram[group + 3u]);
        workgroupBarrier();
        if lane == 0u {
            var above = 0u;
            var t = 0u;
            loop {
                if above + counts[t] >= remaining || t == THREADS - 1u {
                    break;
                }
                above += counts[t];
                t += 1u;
            }
            var bin = (THREADS - 1u - t) * 4u + 3u;
            loop {
                let h = atomicLoad(&histogram[bin]);
                if above + h >= remaining || bin == 0u {
                    break;
                }
                above += h;
                bin -= 1u;
            }
            remaining -= above;
            prefix_key = prefix | (bin << shift);
            // (A bin of a zero prefix may hold zeros, which no threshold one below it
            // leaves out: the second case, or the rounds.)
            if round < 3u && prefix_key != 0u && atomicLoad(&histogram[bin]) == remaining {
                settled = 1u;
            } else if round == 0u && prefix_key == 0u
                && atomicLoad(&zero_keys) == atomicLoad(&histogram[0]) {
                settled = 2u;
            }
        }
        workgroupBarrier();
    }
    // Settled on a bin: the keys from the bin's lowest value up (T - 1 taken as the
    // threshold, with no ties); else T (0 where settled on zeros) and its ties.
    var threshold = prefix_key;
    var ties = remaining;
    if settled == 1u {
        threshold = prefix_key - 1u;
        ties = 0u;
    } else if settled == 3u {
        ties = 0u;      // T = 0: every key above it, no zero
    }
    // Rank of each key equal to T among them, in pixel order.
    var equal = 0u;
    for (var k = first; k < last; k++) {
        equal += u32(keys[base + k] == threshold);
    }
    counts[lane] = equal;
    scan_counts(lane);
    let tie_rank = counts[lane];
    // Selected pixels, in pixel order.
    var mine = 0u;
    var rank = tie_rank;
    for (var k = first; k < last; k++) {
        let key = keys[base + k];
        if key > threshold || (key == threshold && rank < ties) {
            mine += 1u;
        }
        rank += u32(key == threshold);
    }
    workgroupBarrier();
    counts[lane] = mine;
    scan_counts(lane);
    var slot = counts[lane];
    rank = tie_rank;
    for (var k = first; k < last; k++) {
        let key = keys[base + k];
        if key > threshold || (key == threshold && rank < ties) {
            selected[record * params.slots + slot] = k;
            slot += 1u;
        }
        rank += u32(key == threshold);
    }
    if lane == THREADS - 1u {
        if slot < params.refined {
            // Fewer than K near light: the slots after the last pixel say so.
            atomicAdd(&ray_counts[3], params.refined - slot);
            for (var s = slot; s < params.refined; s++) {
                selected[record * params.slots + s] = UNUSED_SLOT;
            }
        }
        push_refined_plane(record, slot);
    }
}
