//! Hemispherical harmonics (HSH, thesis section 3.3, algorithms.md 2.2): an orthonormal
//! basis of functions on the upper hemisphere, what radiance records store incoming
//! radiance in (issue 18) and what materials' cosine-weighted BRDFs are projected on
//! ([`brdf_projection`]).
//!
//! `H_l^m(theta, phi) = sqrt2 K_l^m cos(m phi) P_l^m(2 cos(theta) - 1)` for m > 0,
//! `sqrt2 K_l^m sin(|m| phi) P_l^|m|(2 cos(theta) - 1)` for m < 0 and
//! `K_l^0 P_l^0(2 cos(theta) - 1)` for m = 0 (thesis eqs. 3.18-3.19), with
//! `K_l^m = sqrt((2l + 1) (l - |m|)! / (2 pi (l + |m|)!))` (2 pi where spherical harmonics
//! have 4 pi) and the Condon-Shortley phase in `P_l^m` (eq. 3.5). Order `n` means
//! `l = 0 .. n - 1`: `n^2` coefficients, indexed `l (l + 1) + m`.
//!
//! Directions are in a local frame whose +z is the surface normal (theta from +z, phi
//! from +x towards +y). Everything is f64: projections and tests compare to 1e-9.

pub mod brdf_projection;
pub mod rotation;

use glam::DVec3;
use std::f64::consts::PI;

/// Orders up to this are supported (the thesis's highest, 100 coefficients per channel).
pub const MAX_ORDER: u32 = 10;

/// Coefficients of order `order` (`order^2`).
pub fn coefficient_count(order: u32) -> usize {
    (order * order) as usize
}

/// The index of `(l, m)`: `l (l + 1) + m`.
pub fn index(l: u32, m: i32) -> usize {
    (i64::from(l) * (i64::from(l) + 1) + i64::from(m)) as usize
}

/// Every associated Legendre polynomial `P_l^m(x)`, `0 <= m <= l < order`, with the
/// Condon-Shortley phase, by the stable recurrences of eqs. 3.4-3.6; `out[l][m]`.
/// Any order (the SH rotation's quadrature asks for more than [`MAX_ORDER`]).
pub(crate) fn legendre(order: u32, x: f64) -> Vec<Vec<f64>> {
    let n = order as usize;
    let mut p = vec![0.0; n * n];
    legendre_rows(order, x, &mut p);
    p.chunks(n.max(1)).map(<[f64]>::to_vec).collect()
}

/// [`legendre`] into `p[l * order + m]` (`order^2` values): no allocation of its own.
fn legendre_rows(order: u32, x: f64, p: &mut [f64]) {
    let n = order as usize;
    let s = (1.0 - x * x).max(0.0).sqrt();
    let mut pmm = 1.0;
    for m in 0..n {
        if m > 0 {
            // P_m^m = -(2m - 1) sqrt(1 - x^2) P_{m-1}^{m-1}.
            pmm *= -((2 * m - 1) as f64) * s;
        }
        p[m * n + m] = pmm;
        if m + 1 < n {
            p[(m + 1) * n + m] = x * (2 * m + 1) as f64 * pmm;
        }
        for l in m + 2..n {
            p[l * n + m] = (x * (2 * l - 1) as f64 * p[(l - 1) * n + m]
                - (l + m - 1) as f64 * p[(l - 2) * n + m])
                / (l - m) as f64;
        }
    }
}

/// `K_l^m` of the hemispherical basis.
pub(crate) fn normalisation(l: u32, m: u32) -> f64 {
    // (l - m)! / (l + m)! as a product, without overflowing factorials.
    let mut ratio = 1.0;
    for k in (l - m + 1)..=(l + m) {
        ratio /= f64::from(k);
    }
    (f64::from(2 * l + 1) * ratio / (2.0 * PI)).sqrt()
}

/// The `order^2` basis functions at the unit direction `w` of the upper hemisphere (local
/// frame, `w.z >= 0`; below the horizon the basis is not defined and this returns zeros).
pub fn basis(order: u32, w: DVec3) -> Vec<f64> {
    let mut out = vec![0.0; coefficient_count(order)];
    basis_into(order, w, &mut out);
    out
}

/// [`basis`] into `out` (`order^2` values; up to [`MAX_ORDER`] no allocation): what the
/// plane bases of radiance records evaluate a million times per plane resolution
/// (`PlaneBasis::new`).
pub fn basis_into(order: u32, w: DVec3, out: &mut [f64]) {
    let out = &mut out[..coefficient_count(order)];
    if w.z < 0.0 {
        out.fill(0.0);
        return;
    }
    let n = order as usize;
    let mut table = [0.0; (MAX_ORDER * MAX_ORDER) as usize];
    let mut heap = Vec::new();
    let p = if order <= MAX_ORDER {
        &mut table[..n * n]
    } else {
        heap.resize(n * n, 0.0);
        &mut heap[..]
    };
    let cos_theta = w.z.min(1.0);
    let phi = w.y.atan2(w.x);
    legendre_rows(order, 2.0 * cos_theta - 1.0, p);
    for l in 0..order {
        let row = &p[l as usize * n..];
        out[index(l, 0)] = scaled_normalisation(l, 0) * row[0];
        for m in 1..=l {
            let k = scaled_normalisation(l, m) * row[m as usize];
            let a = f64::from(m) * phi;
            out[index(l, m as i32)] = k * a.cos();
            out[index(l, -(m as i32))] = k * a.sin();
        }
    }
}

/// `K_l^0`, and `sqrt(2) K_l^m` for m > 0: the factor of `P_l^m` in [`basis`]; tabulated
/// once below [`MAX_ORDER`] (the same products, the same bits).
fn scaled_normalisation(l: u32, m: u32) -> f64 {
    fn direct(l: u32, m: u32) -> f64 {
        if m == 0 {
            normalisation(l, 0)
        } else {
            std::f64::consts::SQRT_2 * normalisation(l, m)
        }
    }
    static TABLE: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    if l >= MAX_ORDER {
        return direct(l, m);
    }
    TABLE.get_or_init(|| {
        let mut k = vec![0.0; coefficient_count(MAX_ORDER)];
        for l in 0..MAX_ORDER {
            for m in 0..=l {
                k[index(l, m as i32)] = direct(l, m);
            }
        }
        k
    })[index(l, m as i32)]
}

/// A quadrature rule on the upper hemisphere: directions and solid-angle weights
/// (Gauss-Legendre in cos(theta) times an even rule in phi), exact for the basis products
/// up to the order it was built for.
pub struct HemisphereQuadrature {
    pub directions: Vec<DVec3>,
    pub weights: Vec<f64>,
}

impl HemisphereQuadrature {
    /// `nodes` Gauss-Legendre nodes in cos(theta) on [0, 1] and `2 nodes` even steps in phi:
    /// exact for products of two order-`order` functions when `nodes >= order` (they are
    /// polynomials of degree `2 (order - 1)` in cos(theta) and trigonometric of degree
    /// `2 (order - 1)` in phi); more nodes resolve sharper integrands (a glossy lobe).
    pub fn new(nodes: usize) -> Self {
        let (x, w) = gauss_legendre(nodes);
        let steps = 2 * nodes;
        let mut directions = Vec::with_capacity(nodes * steps);
        let mut weights = Vec::with_capacity(nodes * steps);
        for (xi, wi) in x.iter().zip(&w) {
            // [-1, 1] -> [0, 1].
            let z = 0.5 * (xi + 1.0);
            let r = (1.0 - z * z).max(0.0).sqrt();
            for k in 0..steps {
                let phi = 2.0 * PI * (k as f64 + 0.5) / steps as f64;
                directions.push(DVec3::new(r * phi.cos(), r * phi.sin(), z));
                weights.push(0.5 * wi * 2.0 * PI / steps as f64);
            }
        }
        Self {
            directions,
            weights,
        }
    }

    /// `integral f(w) H_k(w) dw` for every basis function of `order`.
    pub fn project(&self, order: u32, f: impl Fn(DVec3) -> f64) -> Vec<f64> {
        let mut c = vec![0.0; coefficient_count(order)];
        for (w, dw) in self.directions.iter().zip(&self.weights) {
            let v = f(*w) * dw;
            if v == 0.0 {
                continue;
            }
            for (ck, hk) in c.iter_mut().zip(basis(order, *w)) {
                *ck += v * hk;
            }
        }
        c
    }

    /// `integral f(w) dw`.
    pub fn integrate(&self, f: impl Fn(DVec3) -> f64) -> f64 {
        self.directions
            .iter()
            .zip(&self.weights)
            .map(|(w, dw)| f(*w) * dw)
            .sum()
    }
}

/// The function the coefficients `c` stand for, at `w`.
pub fn evaluate(c: &[f64], order: u32, w: DVec3) -> f64 {
    c.iter().zip(basis(order, w)).map(|(a, b)| a * b).sum()
}

/// Rotates coefficients about the normal (+z) by `alpha`: the coefficients of
/// `f'(theta, phi) = f(theta, phi - alpha)`. Exact (algorithms.md 2.5): the m = 0
/// coefficients stay, and each pair (m, -m) turns by `m alpha` as for spherical harmonics.
pub fn rotate_z(c: &[f64], order: u32, alpha: f64) -> Vec<f64> {
    let mut out = c.to_vec();
    for l in 0..order {
        for m in 1..=l as i32 {
            let (s, co) = (f64::from(m) * alpha).sin_cos();
            let (p, q) = (c[index(l, m)], c[index(l, -m)]);
            out[index(l, m)] = p * co - q * s;
            out[index(l, -m)] = p * s + q * co;
        }
    }
    out
}

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton iteration on `P_n`).
pub(crate) fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 0 { 1.0 } else { p1 };
            let pn1 = if n == 1 { 1.0 } else { p0 };
            // P_n'(z) = n (z P_n - P_{n-1}) / (z^2 - 1).
            let dp = n as f64 * (z * pn - pn1) / (z * z - 1.0);
            let dz = pn / dp;
            z -= dz;
            if dz.abs() < 1e-15 {
                let (mut q0, mut q1) = (1.0, z);
                for k in 2..=n {
                    let q2 = ((2 * k - 1) as f64 * z * q1 - (k - 1) as f64 * q0) / k as f64;
                    q0 = q1;
                    q1 = q2;
                }
                let d = n as f64 * (z * q1 - q0) / (z * z - 1.0);
                x[i] = z;
                w[i] = 2.0 / ((1.0 - z * z) * d * d);
                break;
            }
        }
    }
    (x, w)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The allocation-free basis (tables of Legendre values and normalisations) gives the
    /// bits of the direct formula at every order up to MAX_ORDER, and higher orders (the
    /// SH rotation's quadrature) still evaluate.
    #[test]
    fn tabulated_basis_is_bit_identical_to_the_direct_formula() {
        let dirs = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.3, -0.5, 0.81).normalize(),
            DVec3::new(-0.9, 0.1, 0.05).normalize(),
            DVec3::new(0.999, 0.0, 1e-4).normalize(),
        ];
        for order in 1..=MAX_ORDER {
            for &w in &dirs {
                // The formula as `basis` had it, with per-call tables.
                let mut direct = vec![0.0; coefficient_count(order)];
                let p = legendre(order, 2.0 * w.z.min(1.0) - 1.0);
                let phi = w.y.atan2(w.x);
                for l in 0..order {
                    direct[index(l, 0)] = normalisation(l, 0) * p[l as usize][0];
                    for m in 1..=l {
                        let k = std::f64::consts::SQRT_2
                            * normalisation(l, m)
                            * p[l as usize][m as usize];
                        let a = f64::from(m) * phi;
                        direct[index(l, m as i32)] = k * a.cos();
                        direct[index(l, -(m as i32))] = k * a.sin();
                    }
                }
                let fast = basis(order, w);
                let same = fast
                    .iter()
                    .zip(&direct)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same, "order {order} at {w:?}");
            }
        }
        let high = basis(MAX_ORDER + 5, dirs[1]);
        assert_eq!(high.len(), coefficient_count(MAX_ORDER + 5));
        assert!(high.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn the_basis_is_orthonormal_over_the_hemisphere() {
        let order = MAX_ORDER;
        let q = HemisphereQuadrature::new(order as usize + 2);
        let n = coefficient_count(order);
        let mut gram = vec![0.0; n * n];
        for (w, dw) in q.directions.iter().zip(&q.weights) {
            let h = basis(order, *w);
            for i in 0..n {
                for j in 0..n {
                    gram[i * n + j] += h[i] * h[j] * dw;
                }
            }
        }
        let worst = (0..n * n)
            .map(|k| (gram[k] - if k / n == k % n { 1.0 } else { 0.0 }).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-10, "max |G - I| = {worst} over {n} functions");
    }

    #[test]
    fn four_coefficients_hold_the_cosine_lobe_exactly() {
        // cos(theta) = (P~_1^0 + P~_0^0) / 2 lies in the span of l <= 1 (algorithms.md
        // 2.2), so order 2 reproduces it everywhere and its integral is pi.
        let q = HemisphereQuadrature::new(8);
        let c = q.project(2, |w| w.z);
        assert_eq!(c.len(), 4);
        for k in 0..200 {
            let t = 0.5 * PI * (k as f64 + 0.5) / 200.0;
            let p = 0.37 * k as f64;
            let w = DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
            assert!((evaluate(&c, 2, w) - w.z).abs() < 1e-12);
        }
        // Irradiance of a constant radiance 1: the dot product of its coefficients with
        // the cosine's is pi.
        let one = q.project(2, |_| 1.0);
        let e: f64 = one.iter().zip(&c).map(|(a, b)| a * b).sum();
        assert!((e - PI).abs() < 1e-12, "E = {e}");
        // Only the m = 0 coefficients are non-zero.
        assert!(c[index(1, 1)].abs() < 1e-14 && c[index(1, -1)].abs() < 1e-14);
    }

    #[test]
    fn rotating_about_the_normal_equals_projecting_the_rotated_function() {
        let order = 6;
        let q = HemisphereQuadrature::new(16);
        let f = |w: DVec3| (1.0 + 2.0 * w.x + w.y * w.y * 3.0 - w.x * w.y) * w.z;
        let alpha: f64 = 0.7;
        let c = q.project(order, f);
        let rotated = q.project(order, |w| {
            let (s, co) = (-alpha).sin_cos();
            f(DVec3::new(co * w.x - s * w.y, s * w.x + co * w.y, w.z))
        });
        let turned = rotate_z(&c, order, alpha);
        for (a, b) in turned.iter().zip(&rotated) {
            assert!((a - b).abs() < 1e-10, "{a} vs {b}");
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let (x, w) = gauss_legendre(5);
        // Exact up to degree 9: int x^8 dx over [-1, 1] = 2 / 9.
        let v: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(8)).sum();
        assert!((v - 2.0 / 9.0).abs() < 1e-14);
        assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-14);
    }
}
