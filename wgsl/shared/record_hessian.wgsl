// The second derivatives of a record's irradiance from its traced plane (Schwarzhaupt,
// Jensen & Jarosz 2012; Rust mirror and derivation notes: src/records/hessian.rs). The
// plane's hit points form a triangle mesh, each quad (i, j) split into triangle 1 =
// (i,j) (i+1,j) (i,j+1) and triangle 2 = (i+1,j+1) (i,j+1) (i+1,j), each carrying the
// luminance of its farthest vertex. Every interior edge adds the jump in luminance across
// it times the closed-form Hessian of its form-factor term; the outer ring's edges are left
// out. The including pass loads the samples (record_reduce.wgsl `accumulate`).
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

// A plane vertex: the hit point of sample `s` through plane coordinates `c` (a miss `far`
// away along its pixel's direction) with its distance in w (infinite for a miss).
fn hessian_vertex(c: vec2f, s: PlaneSample, far: f32) -> vec4f {
    let dir = vec3f(c, 1.0);
    if s.depth > 0.0 {
        let p = dir * s.depth;
        return vec4f(p, length(p));
    }
    return vec4f(dir * (far / length(dir)), 3.0e38);
}

// Of three vertices (points with their distance in w) and their luminances, the luminance of
// the farthest, the first of equals (`hessian::plane_hessian`'s rule).
fn farthest_luminance(p0: vec4f, l0: f32, p1: vec4f, l1: f32, p2: vec4f, l2: f32) -> f32 {
    var best = l0;
    var best_d = p0.w;
    if p1.w > best_d {
        best = l1;
        best_d = p1.w;
    }
    if p2.w > best_d {
        best = l2;
    }
    return best;
}

// The Hessian terms of the edges that start at the vertex `p` of quad (i, j) (right, up and
// the quad's diagonal), as `hessian::plane_hessian` sums them, from its neighbours' vertices
// and luminances: `r` (i+1, j), `u` (i, j+1), `ur` (i+1, j+1), and where they exist `b`
// (i+1, j-1, `has_b`) and `l` (i-1, j+1, `has_l`). A triangle's luminance is its farthest
// vertex's. The caller loads each sample once and only for quads inside the plane (the outer
// ring's edges are left out).
fn hessian_edges(
    p: vec4f, lp: f32, r: vec4f, lr: f32, u: vec4f, lu: f32, ur: vec4f, lur: f32,
    has_b: bool, b: vec4f, lb: f32, has_l: bool, l: vec4f, ll: f32,
) -> vec3f {
    var h = vec3f(0.0);
    let t1 = farthest_luminance(p, lp, r, lr, u, lu);
    let t2 = farthest_luminance(ur, lur, u, lu, r, lr);
    if t1 != t2 {
        h += (t1 - t2) * edge_hessian(r.xyz, u.xyz);
    }
    if has_b {
        let t2_below = farthest_luminance(r, lr, p, lp, b, lb);
        if t1 != t2_below {
            h += (t1 - t2_below) * edge_hessian(p.xyz, r.xyz);
        }
    }
    if has_l {
        let t2_left = farthest_luminance(u, lu, l, ll, p, lp);
        if t2_left != t1 {
            h += (t2_left - t1) * edge_hessian(p.xyz, u.xyz);
        }
    }
    return h;
}

// The largest absolute eigenvalue of the symmetric 2x2 matrix (xx, xy, yy).
fn largest_eigenvalue(h: vec3f) -> f32 {
    return abs(0.5 * (h.x + h.z)) + length(vec2f(0.5 * (h.x - h.z), h.y));
}
