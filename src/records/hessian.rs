//! The second derivatives of a record's irradiance, read from its traced hemisphere plane
//! (Schwarzhaupt, Jensen & Jarosz 2012, "Practical Hessian-based error control for
//! irradiance caching"; Radiance's `ambcomp.c` sizes its records this way).
//!
//! The plane's hit points are joined into a triangle mesh (each grid quad split along the
//! diagonal from its (i+1, j) corner to its (i, j+1) corner), every triangle carrying the
//! radiance of its farthest vertex (the background of an occlusion edge). The irradiance at
//! the record is then `E = sum_T L_T F_T` with `F_T` the point-to-triangle form factor,
//! which Stokes' theorem writes as a sum over the triangle's edges. Moving the receiver
//! while the hit points stay put (occluders do not move with it) changes each edge's term;
//! its second derivative has a closed form (the paper's edge integrals I, J, K). Summed
//! over the mesh, interior edges carry the jump in radiance across them, so a region of
//! uniform radiance adds nothing whatever its depth: records grow where the light is
//! smooth, however close the geometry, and shrink at bright occlusion boundaries. Edges on
//! the mesh's outer ring are left out (the plane stops short of the horizon; what lies
//! beyond is taken to continue the ring's radiance).
//!
//! `record_reduce.wgsl` (`shared/record_hessian.wgsl`) computes the same sum in f32; this
//! module is its f64 mirror, and its tests check the edge formulas against finite
//! differences of the form factor.

use super::PlaneSample;
use super::plane::HemispherePlane;
use glam::{DVec2, DVec3};
use std::f64::consts::PI;

/// Tangent-plane block `(xx, xy, yy)` of the Hessian of one edge's form-factor term
/// `(1 / 2 pi) theta (n . r0 x r1) / |r0 x r1|` with respect to the receiver's position,
/// the receiver at the origin with normal +z, `r0` and `r1` the edge's ends.
pub fn edge_hessian(r0: DVec3, r1: DVec3) -> [f64; 3] {
    let e = r1 - r0;
    let c = r0.cross(r1);
    let cc = c.length_squared();
    let ee = e.length_squared();
    if cc <= 0.0 || ee <= 0.0 {
        return [0.0; 3];
    }
    let inv_r0 = 1.0 / r0.length_squared();
    let inv_r1 = 1.0 / r1.length_squared();
    let e_r0 = e.dot(r0);
    let e_r1 = e.dot(r1);
    let theta = cc.sqrt().atan2(r0.dot(r1));
    // Edge integrals over t in [0, 1] of |r0 + t e|^-2, ^-4 and t |.|^-4 (I1, I2, J2),
    // then the ^-6 family (I3, J3, K3 with t^2).
    let i1 = theta / cc.sqrt();
    let i2 = (e_r1 * inv_r1 - e_r0 * inv_r0 + ee * i1) * 0.5 / cc;
    let j2 = (0.5 * (inv_r0 - inv_r1) - e_r0 * i2) / ee;
    let i3 = (e_r1 * inv_r1 * inv_r1 - e_r0 * inv_r0 * inv_r0 + 3.0 * ee * i2) / (4.0 * cc);
    let j3 = (0.25 * (inv_r0 * inv_r0 - inv_r1 * inv_r1) - e_r0 * i3) / ee;
    let k3 = (i2 - i3 / inv_r0 - 2.0 * e_r0 * j3) / ee;
    let a = r0 * i2 + e * j2;
    let m = DVec3::new(-e.y, e.x, 0.0); // n x e
    let sym = |u: DVec3, v: DVec3| [2.0 * u.x * v.x, u.x * v.y + u.y * v.x, 2.0 * u.y * v.y];
    let s_ma = sym(m, a);
    let s_rr = sym(r0, r0);
    let s_ee = sym(e, e);
    let s_re = sym(r0, e);
    let cz = c.z;
    let diagonal = [1.0, 0.0, 1.0];
    let mut h = [0.0; 3];
    for k in 0..3 {
        h[k] = (s_ma[k] + 2.0 * cz * (i3 * s_rr[k] + k3 * s_ee[k] + 2.0 * j3 * s_re[k])
            - cz * i2 * diagonal[k])
            / PI;
    }
    h
}

/// One edge's form-factor term (Stokes: a polygon's form factor is the sum of these over
/// its edges, counter-clockwise seen from the receiver), receiver at `x` with normal +z.
pub fn edge_form_factor(x: DVec3, p0: DVec3, p1: DVec3) -> f64 {
    let r0 = p0 - x;
    let r1 = p1 - x;
    let c = r0.cross(r1);
    let len = c.length();
    if len <= 0.0 {
        return 0.0;
    }
    len.atan2(r0.dot(r1)) * c.z / len / (2.0 * PI)
}

/// Where the Hessian puts a plane sample that missed: far along its pixel's direction
/// (`MISS_DISTANCE` times R_max; WGSL `HESSIAN_MISS_DISTANCE`), so it adds almost nothing but its radiance jump's
/// direction.
pub const MISS_DISTANCE: f64 = 100.0;

/// The hit point of plane sample `k` in the record's tangent frame (misses far away).
pub fn sample_point(plane: &HemispherePlane, samples: &[PlaneSample], k: usize, far: f64) -> DVec3 {
    let c = plane.pixels[k].center;
    let dir = DVec3::new(c[0].into(), c[1].into(), 1.0);
    let depth = f64::from(samples[k].depth);
    if depth > 0.0 {
        dir * depth
    } else {
        dir * (far / dir.length())
    }
}

/// Luminance weights of the radiance channels (Rec. 709, as Radiance's `bright`).
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// The luminance of the mesh triangle with vertices `ks` (plane sample indices): its
/// farthest vertex's, the first of equals in the given order (the background of an
/// occlusion edge; misses are farthest).
pub fn triangle_luminance(
    plane: &HemispherePlane,
    samples: &[PlaneSample],
    far: f64,
    ks: [usize; 3],
) -> f64 {
    let distance = |k: usize| {
        if samples[k].depth > 0.0 {
            sample_point(plane, samples, k, far).length()
        } else {
            f64::INFINITY
        }
    };
    let mut best = ks[0];
    for &k in &ks[1..] {
        if distance(k) > distance(best) {
            best = k;
        }
    }
    let l = samples[best].radiance;
    LUMINANCE[0] * f64::from(l[0]) + LUMINANCE[1] * f64::from(l[1]) + LUMINANCE[2] * f64::from(l[2])
}

/// The tangent-plane Hessian `(xx, xy, yy)` of the irradiance's luminance over `pi` (the
/// mesh's `sum L_T F_T`) at a record whose traced plane is `samples`; `far` is where misses
/// go.
pub fn plane_hessian(plane: &HemispherePlane, samples: &[PlaneSample], far: f64) -> [f64; 3] {
    let res = plane.resolution as usize;
    let point = |k: usize| sample_point(plane, samples, k, far);
    // Triangle 1 (a, b, c) or 2 (d, c, b) of the quad at (i, j).
    let farthest = |ks: [usize; 3]| triangle_luminance(plane, samples, far, ks);
    let at = |i: usize, j: usize| j * res + i;
    let t1 = |i: usize, j: usize| farthest([at(i, j), at(i + 1, j), at(i, j + 1)]);
    let t2 = |i: usize, j: usize| farthest([at(i + 1, j + 1), at(i, j + 1), at(i + 1, j)]);
    let mut h = [0.0; 3];
    let mut add = |jump: f64, a: usize, b: usize| {
        if jump != 0.0 {
            let e = edge_hessian(point(a), point(b));
            for k in 0..3 {
                h[k] += jump * e[k];
            }
        }
    };
    let last = res - 1;
    for j in 0..res {
        for i in 0..res {
            // Edge (i, j) -> (i + 1, j): triangle 1 of quad (i, j) on its left, triangle 2
            // of quad (i, j - 1) on its right.
            if i < last && j > 0 && j < last {
                add(t1(i, j) - t2(i, j - 1), at(i, j), at(i + 1, j));
            }
            // Edge (i, j) -> (i, j + 1): triangle 2 of quad (i - 1, j) on its left,
            // triangle 1 of quad (i, j) on its right.
            if j < last && i > 0 && i < last {
                add(t2(i - 1, j) - t1(i, j), at(i, j), at(i, j + 1));
            }
            // Diagonal (i + 1, j) -> (i, j + 1): triangle 1 left, triangle 2 right.
            if i < last && j < last {
                add(t1(i, j) - t2(i, j), at(i + 1, j), at(i, j + 1));
            }
        }
    }
    h
}

/// The largest absolute eigenvalue of the symmetric 2x2 matrix `(xx, xy, yy)`.
pub fn largest_eigenvalue(h: [f64; 3]) -> f64 {
    let mean = 0.5 * (h[0] + h[2]);
    let half = DVec2::new(0.5 * (h[0] - h[2]), h[1]).length();
    mean.abs() + half
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central second differences of one edge's form-factor term in x and y.
    fn finite_difference(p0: DVec3, p1: DVec3, step: f64) -> [f64; 3] {
        let f = |dx: f64, dy: f64| edge_form_factor(DVec3::new(dx, dy, 0.0), p0, p1);
        let f0 = f(0.0, 0.0);
        let xx = (f(step, 0.0) - 2.0 * f0 + f(-step, 0.0)) / (step * step);
        let yy = (f(0.0, step) - 2.0 * f0 + f(0.0, -step)) / (step * step);
        let xy = (f(step, step) - f(step, -step) - f(-step, step) + f(-step, -step))
            / (4.0 * step * step);
        [xx, xy, yy]
    }

    #[test]
    fn edge_hessian_matches_finite_differences_of_the_form_factor() {
        let edges = [
            (DVec3::new(0.3, -0.2, 1.0), DVec3::new(0.5, 0.4, 1.3)),
            (DVec3::new(-2.0, 1.0, 0.4), DVec3::new(-1.5, 1.6, 0.5)),
            (DVec3::new(0.1, 0.1, 0.2), DVec3::new(4.0, -3.0, 2.0)),
            (DVec3::new(0.0, 0.5, 3.0), DVec3::new(0.2, 0.5, 3.0)),
        ];
        for (p0, p1) in edges {
            let exact = edge_hessian(p0, p1);
            let fd = finite_difference(p0, p1, 1.0e-4);
            let scale = exact.iter().map(|v| v.abs()).fold(0.0, f64::max);
            for k in 0..3 {
                assert!(
                    (exact[k] - fd[k]).abs() <= 1.0e-4 * scale + 1.0e-9,
                    "edge {p0} -> {p1}: component {k}: closed form {} against differences {}",
                    exact[k],
                    fd[k]
                );
            }
        }
    }

    /// A plane whose hits lie on a tilted wall, with a bright patch of nearer geometry in
    /// the middle: the mesh Hessian (interior edges) equals the second differences of
    /// `sum_T (L_T - L_ring) F_T`, where L_ring is the radiance of every triangle touching
    /// the outer ring (the boundary edges' terms are what the sum leaves out).
    #[test]
    fn plane_hessian_is_the_second_difference_of_the_mesh_irradiance() {
        use super::super::{PlaneMode, PlaneSpacing};
        let plane = HemispherePlane::new(16, 150.0, PlaneMode::Stretched, PlaneSpacing::Cosine);
        let res = 16usize;
        let ring = 0.5f32;
        let samples: Vec<PlaneSample> = (0..res * res)
            .map(|k| {
                let (i, j) = (k % res, k / res);
                let c = plane.pixels[k].center;
                // Wall z = 2 + 0.3 x' (x' the hit's x), met by the ray (x, y, 1) at this depth.
                let wall = 2.0 / (1.0 - 0.3 * c[0]).max(0.2);
                let patch = (5..9).contains(&i) && (6..11).contains(&j);
                let (l, depth) = if patch {
                    (4.0, 0.8)
                } else if i == 12 && j == 4 {
                    (0.1, -1.0)
                } else {
                    (ring, wall)
                };
                PlaneSample {
                    radiance: [l, l, l],
                    depth,
                }
            })
            .collect();
        let far = 1.0e3;
        let h = plane_hessian(&plane, &samples, far);
        let point = |k: usize| sample_point(&plane, &samples, k, far);
        let farthest = |ks: [usize; 3]| triangle_luminance(&plane, &samples, far, ks);
        let irradiance = |x: DVec3| {
            let mut e = 0.0;
            let at = |i: usize, j: usize| j * res + i;
            for j in 0..res - 1 {
                for i in 0..res - 1 {
                    let tris = [
                        [at(i, j), at(i + 1, j), at(i, j + 1)],
                        [at(i + 1, j + 1), at(i, j + 1), at(i + 1, j)],
                    ];
                    for t in tris {
                        let v = farthest(t) - f64::from(ring);
                        for m in 0..3 {
                            e += v * edge_form_factor(x, point(t[m]), point(t[(m + 1) % 3]));
                        }
                    }
                }
            }
            e
        };
        let step = 1.0e-3;
        let f = |dx: f64, dy: f64| irradiance(DVec3::new(dx, dy, 0.0));
        let f0 = f(0.0, 0.0);
        let fd = [
            (f(step, 0.0) - 2.0 * f0 + f(-step, 0.0)) / (step * step),
            (f(step, step) - f(step, -step) - f(-step, step) + f(-step, -step))
                / (4.0 * step * step),
            (f(0.0, step) - 2.0 * f0 + f(0.0, -step)) / (step * step),
        ];
        let scale = h.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(scale > 0.1, "the patch should give a clear Hessian: {h:?}");
        for k in 0..3 {
            assert!(
                (h[k] - fd[k]).abs() <= 1.0e-3 * scale,
                "component {k}: mesh {h:?} against differences {fd:?}"
            );
        }
    }
}
