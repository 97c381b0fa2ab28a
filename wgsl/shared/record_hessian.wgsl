// The second derivatives of a record's irradiance from its traced plane (Schwarzhaupt,
// Jensen & Jarosz 2012; Rust mirror and derivation notes: src/records/hessian.rs). The
// plane's hit points form a triangle mesh, each quad (i, j) split into triangle 1 =
// (i,j) (i+1,j) (i,j+1) and triangle 2 = (i+1,j+1) (i,j+1) (i+1,j), each carrying the
// luminance of its farthest vertex. Every interior edge adds the jump in luminance across
// it times the closed-form Hessian of its form-factor term; the outer ring's edges are left
// out. Needs `plane`, `samples` (records.wgsl layouts) bound by the including pass.
//!include shared/records.wgsl

// Misses sit this many R_max away along their pixel's direction (`hessian::MISS_DISTANCE`).
const HESSIAN_MISS_DISTANCE: f32 = 100.0;
const LUMINANCE: vec3f = vec3f(0.2126, 0.7152, 0.0722);
const INV_PI: f32 = 0.3183098861837907;

// Tangent-plane block (xx, xy, yy) of the Hessian, with respect to the receiver (origin,
// normal +z), of the edge term (1 / 2 pi) theta (n . r0 x r1) / |r0 x r1|.
fn edge_hessian(r0: vec3f, r1: vec3f) -> vec3f {
    let e = r1 - r0;
    let c = cross(r0, r1);
    let cc = dot(c, c);
    let ee = dot(e, e);
    if cc <= 0.0 || ee <= 0.0 {
        return vec3f(0.0);
    }
    let inv_r0 = 1.0 / dot(r0, r0);
    let inv_r1 = 1.0 / dot(r1, r1);
    let e_r0 = dot(e, r0);
    let e_r1 = dot(e, r1);
    let theta = atan2(sqrt(cc), dot(r0, r1));
    // Edge integrals (hessian.rs): I1, I2, J2, then I3, J3, K3.
    let i1 = theta / sqrt(cc);
    let i2 = (e_r1 * inv_r1 - e_r0 * inv_r0 + ee * i1) * 0.5 / cc;
    let j2 = (0.5 * (inv_r0 - inv_r1) - e_r0 * i2) / ee;
    let i3 = (e_r1 * inv_r1 * inv_r1 - e_r0 * inv_r0 * inv_r0 + 3.0 * ee * i2) / (4.0 * cc);
    let j3 = (0.25 * (inv_r0 * inv_r0 - inv_r1 * inv_r1) - e_r0 * i3) / ee;
    let k3 = (i2 - i3 / inv_r0 - 2.0 * e_r0 * j3) / ee;
    let a = r0 * i2 + e * j2;
    let m = vec3f(-e.y, e.x, 0.0);
    let s_ma = vec3f(2.0 * m.x * a.x, m.x * a.y + m.y * a.x, 2.0 * m.y * a.y);
    let s_rr = vec3f(2.0 * r0.x * r0.x, 2.0 * r0.x * r0.y, 2.0 * r0.y * r0.y);
    let s_ee = vec3f(2.0 * e.x * e.x, 2.0 * e.x * e.y, 2.0 * e.y * e.y);
    let s_re = vec3f(2.0 * r0.x * e.x, r0.x * e.y + r0.y * e.x, 2.0 * r0.y * e.y);
    let cz = c.z;
    return (s_ma + 2.0 * cz * (i3 * s_rr + k3 * s_ee + 2.0 * j3 * s_re) - cz * i2 * vec3f(1.0, 0.0, 1.0)) * INV_PI;
}

// Hit point of plane sample k of the plane at `base` (misses `far` away) and its distance
// (infinite for a miss).
fn hessian_point(base: u32, k: u32, far: f32) -> vec4f {
    let c = plane[k].rot_center.zw;
    let dir = vec3f(c, 1.0);
    let depth = samples[base + k].depth;
    if depth > 0.0 {
        let p = dir * depth;
        return vec4f(p, length(p));
    }
    return vec4f(dir * (far / length(dir)), 3.0e38);
}

// Of three vertices (points with their distance in w), the index of the farthest, the
// first of equals (`hessian::plane_hessian`'s rule).
fn farthest_of(k0: u32, p0: vec4f, k1: u32, p1: vec4f, k2: u32, p2: vec4f) -> u32 {
    var best = k0;
    var best_d = p0.w;
    if p1.w > best_d {
        best = k1;
        best_d = p1.w;
    }
    if p2.w > best_d {
        best = k2;
    }
    return best;
}

fn sample_luminance(base: u32, k: u32) -> f32 {
    return dot(samples[base + k].radiance, LUMINANCE);
}

// The Hessian terms of the edges that start at vertex k = j res + i (right, up and the
// diagonal of quad (i, j)), as `hessian::plane_hessian` sums them. Each point is read
// once; a triangle's luminance is its farthest vertex's.
fn hessian_edges_at(base: u32, k: u32, res: u32, far: f32) -> vec3f {
    let i = k % res;
    let j = k / res;
    let last = res - 1u;
    var h = vec3f(0.0);
    if i == last || j == last {
        // No quad (i, j): its right and up edges lie on the outer ring.
        return h;
    }
    let p = hessian_point(base, k, far);
    let right = hessian_point(base, k + 1u, far);
    let up = hessian_point(base, k + res, far);
    let upright = hessian_point(base, k + res + 1u, far);
    let t1 = sample_luminance(base, farthest_of(k, p, k + 1u, right, k + res, up));
    let t2 = sample_luminance(base, farthest_of(k + res + 1u, upright, k + res, up, k + 1u, right));
    if t1 != t2 {
        h += (t1 - t2) * edge_hessian(right.xyz, up.xyz);
    }
    if j > 0u {
        let below = hessian_point(base, k + 1u - res, far);
        let t2_below = sample_luminance(base, farthest_of(k + 1u, right, k, p, k + 1u - res, below));
        if t1 != t2_below {
            h += (t1 - t2_below) * edge_hessian(p.xyz, right.xyz);
        }
    }
    if i > 0u {
        let left = hessian_point(base, k + res - 1u, far);
        let t2_left = sample_luminance(base, farthest_of(k + res, up, k + res - 1u, left, k, p));
        if t2_left != t1 {
            h += (t2_left - t1) * edge_hessian(p.xyz, up.xyz);
        }
    }
    return h;
}

// The largest absolute eigenvalue of the symmetric 2x2 matrix (xx, xy, yy).
fn largest_eigenvalue(h: vec3f) -> f32 {
    return abs(0.5 * (h.x + h.z)) + length(vec2f(0.5 * (h.x - h.z), h.y));
}
