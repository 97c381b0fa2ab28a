// Photon record reduction (src/records/photon_records.rs; thesis Algorithm 7, eq. 6.2 and
// 6.5-6.11; algorithms.md section 5): one invocation per record. Its photons (the list the
// CPU placement gathered) are projected onto the record's tangent plane: E = sum Phi / A
// with A the area of their convex hull (gift wrapping) divided by the hull's mean shortfall
// for that many points; their flux binned per hemisphere cell (equal projected solid angle)
// gives L_jk = M N Phi_jk / (pi A), and Ward and Heckbert's rotational and translational
// gradients follow (algorithms.md 1.5) with the cells' harmonic mean photon distances; then
// Ward's gradient limit, on the gradients only. With the probed area (`area` 1,
// photons::PhotonArea::Probed) the hull is scaled by the share of its probe points that
// find the record's surface under them: a hull spanning gaps between coplanar pieces
// (chair seats, a wall between windows) otherwise counts surface that is not there.
// CPU mirror: photon_records::reference_record.
//!include shared/records.wgsl
//!include shared/shading.wgsl

struct PhotonReduceParams {
    count: u32,
    first_record: u32,
    gradients: u32,
    area: u32,       // 0: the hull; 1: the probed hull
}

// Rust: photons::Photon.
struct Photon {
    position: vec3f,
    distance: f32,
    direction: vec3f,
    bounce: u32,
    flux: vec3f,
    _pad0: f32,
    normal: vec3f,
    _pad1: f32,
}

// Rust: records::photon_records::PhotonSite.
struct PhotonSite {
    position: vec3f,
    radius: f32,
    normal: vec3f,
    r_min: f32,
    first: u32,
    count: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> params: PhotonReduceParams;
@group(1) @binding(1) var<storage, read> sites: array<PhotonSite>;
@group(1) @binding(2) var<storage, read> list: array<u32>;
@group(1) @binding(3) var<storage, read> photons: array<Photon>;
@group(1) @binding(4) var<storage, read_write> records: array<Record>;

// Rust: photon_records::PROBES, MIN_PROBES_INSIDE; photons::map::SAME_SURFACE_*.
const PROBES: u32 = 64u;
const MIN_PROBES_INSIDE: u32 = 8u;
const SAME_SURFACE_COS: f32 = 0.9;
const SAME_SURFACE_SLOPE: f32 = 0.25;

const THETA_CELLS: u32 = 4u;
const PHI_CELLS: u32 = 8u;
const CELLS: u32 = 32u;

// Rust: photon_records::HULL_SHORTFALL (n, c(n)): the mean hull of n uniform points in a
// disc spans 1 - c(n) n^(-2/3) of it.
const SHORTFALL_N = array<f32, 17>(3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0, 48.0, 64.0,
    96.0, 128.0, 192.0, 256.0, 384.0, 512.0, 1024.0);
const SHORTFALL_C = array<f32, 17>(1.926, 2.151, 2.426, 2.575, 2.779, 2.887, 3.019, 3.074,
    3.156, 3.200, 3.240, 3.257, 3.297, 3.311, 3.337, 3.348, 3.369);

// Rust: photon_records::hull_correction.
fn hull_correction(count: u32) -> f32 {
    let n = f32(max(count, 3u));
    var c = SHORTFALL_C[16];
    if n < SHORTFALL_N[16] {
        c = SHORTFALL_C[0];
        for (var i = 0u; i < 16u; i++) {
            let n0 = SHORTFALL_N[i];
            let n1 = SHORTFALL_N[i + 1u];
            if n >= n0 && n <= n1 {
                let t = log(n / n0) / log(n1 / n0);
                c = SHORTFALL_C[i] + t * (SHORTFALL_C[i + 1u] - SHORTFALL_C[i]);
                break;
            }
        }
    }
    return 1.0 - c * pow(n, -2.0 / 3.0);
}

// Rust: photon_records::photon_cell.
fn photon_cell(local: vec3f) -> u32 {
    let sin2 = max(1.0 - local.z * local.z, 0.0);
    let j = min(u32(sin2 * f32(THETA_CELLS)), THETA_CELLS - 1u);
    var phi = atan2(local.y, local.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let k = min(u32(phi / (2.0 * PI) * f32(PHI_CELLS)), PHI_CELLS - 1u);
    return j * PHI_CELLS + k;
}

struct Projected {
    point: vec2f,
    used: bool,
}

// Photon i of the site projected onto its tangent plane; unused when it arrived from
// below the record's hemisphere.
fn projected(site: PhotonSite, frame_t: mat3x3f, i: u32) -> Projected {
    let ph = photons[list[site.first + i]];
    let q = frame_t * (ph.position - site.position);
    return Projected(q.xy, (frame_t * ph.direction).z > 0.0);
}

// Rust: photon_records::probe_point (a sunflower spiral over the unit disc).
fn probe_point(i: u32) -> vec2f {
    let r = sqrt((f32(i) + 0.5) / f32(PROBES));
    let theta = f32(i) * 2.3999632;
    return vec2f(r * cos(theta), r * sin(theta));
}

// The convex hull of the site's used photons: its area, and which of the probe points
// (over the disc of radius `rho`) lie outside it (bit i of outside[i / 32]).
struct Hull {
    area: f32,
    outside: vec2u,
}

// The hull by gift wrapping, counter-clockwise; each edge marks the probes on its right.
fn hull_of(site: PhotonSite, frame_t: mat3x3f, rho: f32) -> Hull {
    // The lowest x (then y) point is on the hull.
    var start = 0xffffffffu;
    var start_point = vec2f(0.0);
    for (var i = 0u; i < site.count; i++) {
        let pr = projected(site, frame_t, i);
        if pr.used && (start == 0xffffffffu || pr.point.x < start_point.x
            || (pr.point.x == start_point.x && pr.point.y < start_point.y)) {
            start = i;
            start_point = pr.point;
        }
    }
    var out = Hull(0.0, vec2u(0xffffffffu));
    if start == 0xffffffffu {
        return out;
    }
    out.outside = vec2u(0u);
    var area = 0.0;
    var current = start;
    var current_point = start_point;
    for (var steps = 0u; steps <= site.count; steps++) {
        // The next hull vertex: the candidate with every other point on its left.
        var next = 0xffffffffu;
        var next_point = vec2f(0.0);
        for (var i = 0u; i < site.count; i++) {
            if i == current {
                continue;
            }
            let pr = projected(site, frame_t, i);
            if !pr.used {
                continue;
            }
            if next == 0xffffffffu {
                next = i;
                next_point = pr.point;
                continue;
            }
            let a = next_point - current_point;
            let b = pr.point - current_point;
            let cr = a.x * b.y - a.y * b.x;
            if cr < 0.0 || (cr == 0.0 && dot(b, b) > dot(a, a)) {
                next = i;
                next_point = pr.point;
            }
        }
        if next == 0xffffffffu {
            break;
        }
        // Probes strictly right of this edge are outside (Rust: inside_hull); only the
        // probed area reads them.
        let edge = next_point - current_point;
        for (var i = 0u; i < PROBES && params.area == 1u; i++) {
            let b = probe_point(i) * rho - current_point;
            if edge.x * b.y - edge.y * b.x < 0.0 {
                out.outside[i / 32u] |= 1u << (i % 32u);
            }
        }
        area += current_point.x * next_point.y - next_point.x * current_point.y;
        current = next;
        current_point = next_point;
        if current == start {
            break;
        }
    }
    out.area = 0.5 * abs(area);
    return out;
}

// The share of the hull's probes that find the record's surface under them (Rust:
// photon_records::probed_share, probe_ray): a ray down along -n from above the tangent
// plane through the band the photons' slope bound admits; found if what it hits first has
// the photons' normal bound. 1 with fewer than MIN_PROBES_INSIDE probes inside the hull.
fn probed_share(site: PhotonSite, frame: mat3x3f, outside: vec2u, rho: f32) -> f32 {
    let n = site.normal;
    let p = site.position;
    let margin = max(1.0e-3 * rho, 1.0e-5 * max(max(abs(p.x), abs(p.y)), abs(p.z)));
    var inside = 0u;
    var found = 0u;
    for (var i = 0u; i < PROBES; i++) {
        if (outside[i / 32u] & (1u << (i % 32u))) != 0u {
            continue;
        }
        inside += 1u;
        let q = probe_point(i) * rho;
        let h = SAME_SURFACE_SLOPE * length(q) + margin;
        let ray = Ray(p + frame * vec3f(q, h), 0.0, -n, 2.0 * h);
        let hit = trace_closest(ray);
        if hit.instance != NO_HIT {
            let s = surface_at(hit, -n);
            if dot(s.shading_normal, n) >= SAME_SURFACE_COS {
                found += 1u;
            }
        }
    }
    if inside < MIN_PROBES_INSIDE {
        return 1.0;
    }
    return f32(max(found, 1u)) / f32(inside);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) lane: u32) {
    bvh_stack_init(lane);
    let s = id.x;
    if s >= params.count {
        return;
    }
    let site = sites[s];
    let frame = orthonormal_basis(site.normal);
    let frame_t = transpose(frame);
    var flux = vec3f(0.0);
    var cell_flux: array<vec3f, CELLS>;
    var cell_inv: array<f32, CELLS>;
    var cell_count: array<u32, CELLS>;
    var used = 0u;
    var rho = 0.0;
    for (var i = 0u; i < site.count; i++) {
        let ph = photons[list[site.first + i]];
        let local = frame_t * ph.direction;
        if local.z <= 0.0 {
            continue;
        }
        used += 1u;
        let q = frame_t * (ph.position - site.position);
        rho = max(rho, sqrt(q.x * q.x + q.y * q.y));
        flux += ph.flux;
        let c = photon_cell(local);
        cell_flux[c] += ph.flux;
        cell_inv[c] += 1.0 / max(ph.distance, 1.0e-12);
        cell_count[c] += 1u;
    }
    let hull = hull_of(site, frame_t, rho);
    var area = hull.area / hull_correction(used);
    if params.area == 1u && area > 0.0 {
        area *= probed_share(site, frame, hull.outside, rho);
    }
    var out: Record;
    out.position = site.position;
    out.radius = site.radius;
    out.normal = site.normal;
    out.r_min = site.r_min;
    out.irradiance = vec3f(0.0);
    out.instance = 0u;
    for (var c = 0u; c < 3u; c++) {
        out.rotation_gradient[c] = vec4f(0.0);
        out.translation_gradient[c] = vec4f(0.0);
    }
    if !(area > 0.0) {
        records[params.first_record + s] = out;
        return;
    }
    let e = flux / area; // thesis eq. 6.2
    out.irradiance = e;
    if params.gradients == 0u {
        records[params.first_record + s] = out;
        return;
    }
    // Cell radiance, eq. 6.11 with equal-projected-area strata: M N Phi / (pi A).
    let scale = f32(CELLS) / (PI * area);
    var rot_c: array<vec3f, 3>;
    var tr: array<vec3f, 3>;
    for (var k = 0u; k < PHI_CELLS; k++) {
        let phi_c = 2.0 * PI * (f32(k) + 0.5) / f32(PHI_CELLS);
        let phi_lo = 2.0 * PI * f32(k) / f32(PHI_CELLS);
        let w_k = vec3f(-sin(phi_c), cos(phi_c), 0.0);
        let u_k = vec3f(cos(phi_c), sin(phi_c), 0.0);
        let v_lo = vec3f(-sin(phi_lo), cos(phi_lo), 0.0);
        let k_prev = (k + PHI_CELLS - 1u) % PHI_CELLS;
        for (var j = 0u; j < THETA_CELLS; j++) {
            let sin2_c = (f32(j) + 0.5) / f32(THETA_CELLS);
            let tan_c = sqrt(sin2_c / (1.0 - sin2_c));
            let cj = j * PHI_CELLS + k;
            let lj = cell_flux[cj] * scale;
            let rj = select(site.radius, f32(cell_count[cj]) / cell_inv[cj], cell_count[cj] > 0u);
            let sin_lo = sqrt(f32(j) / f32(THETA_CELLS));
            let sin_hi = sqrt(f32(j + 1u) / f32(THETA_CELLS));
            let cp = j * PHI_CELLS + k_prev;
            let lp = cell_flux[cp] * scale;
            let rp = select(site.radius, f32(cell_count[cp]) / cell_inv[cp], cell_count[cp] > 0u);
            var cd = 0u;
            var rd = 0.0;
            var ld = vec3f(0.0);
            if j > 0u {
                cd = cj - PHI_CELLS;
                ld = cell_flux[cd] * scale;
                rd = select(site.radius, f32(cell_count[cd]) / cell_inv[cd], cell_count[cd] > 0u);
            }
            for (var c = 0u; c < 3u; c++) {
                // Rotational (algorithms.md 1.5): (pi / MN) sum_k w_k sum_j tan(theta_j) L_jk.
                rot_c[c] += w_k * (PI / f32(CELLS) * tan_c * lj[c]);
                // Translational, azimuthal edge between cells k-1 and k.
                tr[c] += v_lo * ((sin_hi - sin_lo) / min(rj, rp) * (lj[c] - lp[c]));
                // Translational, altitude edge between cells j-1 and j.
                if j > 0u {
                    let cos2_lo = 1.0 - f32(j) / f32(THETA_CELLS);
                    tr[c] += u_k * (2.0 * PI / f32(PHI_CELLS) * sin_lo * cos2_lo / min(rj, rd)
                        * (lj[c] - ld[c]));
                }
            }
        }
    }
    for (var c = 0u; c < 3u; c++) {
        rot_c[c] = frame * rot_c[c];
        tr[c] = frame * tr[c];
    }
    // Ward's gradient limit scales the gradients down and keeps R: placement (on the CPU,
    // before this pass) covered the photons with this R, and a smaller one would leave
    // holes between the records.
    out.radius = limit_by_gradient(site.radius, site.radius, e, &tr);
    for (var c = 0u; c < 3u; c++) {
        out.rotation_gradient[c] = vec4f(rot_c[c], 0.0);
        out.translation_gradient[c] = vec4f(tr[c], 0.0);
    }
    records[params.first_record + s] = out;
}
