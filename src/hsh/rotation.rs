//! Rotating HSH coefficients between two frames whose normals differ (thesis section 3.4,
//! algorithms.md 2.5): what a radiance record needs when it is splatted onto a pixel whose
//! normal is not its own.
//!
//! A rotation is split Z-Y-Z. The two turns about the normal are exact and cheap
//! ([`super::rotate_z`]); the tilt about the y axis by the angle `beta` between the normals
//! is a matrix `M(beta)` with `lambda_B = M(beta) lambda_A` (frame B is frame A turned by
//! `beta` about its y axis). The three methods of the thesis are three ways of building
//! that matrix; all three are tabulated over `beta` here, so on the GPU they cost the same
//! (one `n^2 x n^2` product per record and pixel) and differ only in accuracy:
//!
//! - [`RotationMethod::Tabulated`] (thesis eq. 3.31): the exact rotation of what the
//!   record saw, `M_ij = integral over {v in H, R_y v in H} of H_i(v) H_j(R_y v) dv`;
//!   directions of B's hemisphere that lie below A's horizon get nothing.
//! - [`RotationMethod::ConversionMatrix`] (eqs. 3.20-3.26): HSH to spherical harmonics of a
//!   higher order with the non-square conversion matrix `C`, the exact SH rotation, back:
//!   `M = C R_SH C^T`; lossy where the SH truncation rings.
//! - [`RotationMethod::DigonDeletion`] (eqs. 3.27-3.30): delete the digon that falls below
//!   the horizon, then apply the SH rotation matrix of the angle
//!   `arccos(2 cos(beta) - 1)` to the HSH coefficients as if they were SH ones.
//!
//! The integrals are Gauss-Legendre quadratures whose nodes follow the horizon cut (it is
//! an arc of every ring of constant theta), so they converge like smooth integrals.

use super::{basis, coefficient_count, gauss_legendre, index, legendre, normalisation};
use glam::DVec3;
use std::f64::consts::PI;

/// How the tilt matrix `M(beta)` is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum RotationMethod {
    /// Eq. 3.31: the projection of the tilted record, exact up to the quadrature.
    Tabulated,
    /// Eqs. 3.20-3.26: through spherical harmonics of twice the order.
    ConversionMatrix,
    /// Eqs. 3.27-3.30: digon deletion, then the SH rotation matrix of the mapped angle.
    DigonDeletion,
}

impl RotationMethod {
    pub const ALL: [RotationMethod; 3] = [
        RotationMethod::Tabulated,
        RotationMethod::ConversionMatrix,
        RotationMethod::DigonDeletion,
    ];

    /// The method's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            RotationMethod::Tabulated => "tabulated",
            RotationMethod::ConversionMatrix => "conversion-matrix",
            RotationMethod::DigonDeletion => "digon-deletion",
        }
    }
}

/// `v` turned by `beta` about +y (right-handed): B's local coordinates to A's.
pub fn rotate_y(beta: f64, v: DVec3) -> DVec3 {
    let (s, c) = beta.sin_cos();
    DVec3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z)
}

/// Real spherical harmonics of `order` (`l < order`, index `l (l + 1) + m`) at `w` on the
/// whole sphere: `K P_l^m(cos theta)` times `sqrt2 cos(m phi)` / `sqrt2 sin(|m| phi)`,
/// `K` with 4 pi (thesis eqs. 3.7-3.8).
pub fn sh_basis(order: u32, w: DVec3) -> Vec<f64> {
    let mut out = vec![0.0; coefficient_count(order)];
    let p = legendre(order, w.z.clamp(-1.0, 1.0));
    let phi = w.y.atan2(w.x);
    for l in 0..order {
        // K_SH = K_HSH / sqrt2 (4 pi instead of 2 pi).
        out[index(l, 0)] = normalisation(l, 0) / std::f64::consts::SQRT_2 * p[l as usize][0];
        for m in 1..=l {
            let k = normalisation(l, m) * p[l as usize][m as usize];
            let a = f64::from(m) * phi;
            out[index(l, m as i32)] = k * a.cos();
            out[index(l, -(m as i32))] = k * a.sin();
        }
    }
    out
}

/// Quadrature over `{v in H : -v.x sin(beta) + v.z cos(beta) >= 0}` (the directions of the
/// upper hemisphere that stay above the horizon when turned by `beta` about +y), or with
/// `mirror` its reflection `x -> -x`. `nodes` Gauss-Legendre nodes per segment in
/// `z = cos(theta)`, split where the cut starts (`z = sin(beta)`), and per arc in phi.
pub fn cut_quadrature(beta: f64, mirror: bool, nodes: usize) -> (Vec<DVec3>, Vec<f64>) {
    let (x, w) = gauss_legendre(nodes);
    let (sb, cb) = beta.sin_cos();
    let split = sb.clamp(0.0, 1.0);
    let mut dirs = Vec::new();
    let mut weights = Vec::new();
    let mut ring = |z: f64, wz: f64, lo: f64, hi: f64| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        for (xp, wp) in x.iter().zip(&w) {
            let phi = lo + (hi - lo) * 0.5 * (xp + 1.0);
            let vx = r * phi.cos();
            dirs.push(DVec3::new(if mirror { -vx } else { vx }, r * phi.sin(), z));
            weights.push(wz * wp * 0.5 * (hi - lo));
        }
    };
    for (a, b) in [(0.0, split), (split, 1.0)] {
        if b - a <= 0.0 {
            continue;
        }
        for (xz, wz) in x.iter().zip(&w) {
            let z = a + (b - a) * 0.5 * (xz + 1.0);
            let dz = wz * 0.5 * (b - a);
            let r = (1.0 - z * z).max(0.0).sqrt();
            // cos(phi) <= z cos(beta) / (r sin(beta)) keeps the direction.
            let k = if sb * r <= 1e-300 {
                2.0
            } else {
                z * cb / (r * sb)
            };
            if k >= 1.0 {
                ring(z, dz, 0.0, 2.0 * PI);
            } else {
                let c = k.max(-1.0).acos();
                ring(z, dz, c, 2.0 * PI - c);
            }
        }
    }
    (dirs, weights)
}

/// Quadrature over the whole sphere, exact for products of two functions of `order`.
fn sphere_quadrature(order: u32) -> (Vec<DVec3>, Vec<f64>) {
    let nodes = order as usize + 1;
    let (x, w) = gauss_legendre(nodes);
    let steps = 2 * nodes;
    let mut dirs = Vec::new();
    let mut weights = Vec::new();
    for (z, wz) in x.iter().zip(&w) {
        let r = (1.0 - z * z).max(0.0).sqrt();
        for k in 0..steps {
            let phi = 2.0 * PI * (k as f64 + 0.5) / steps as f64;
            dirs.push(DVec3::new(r * phi.cos(), r * phi.sin(), *z));
            weights.push(wz * 2.0 * PI / steps as f64);
        }
    }
    (dirs, weights)
}

/// `sum_q w_q f(q) g(q)^T` as an `n x m` row-major matrix.
fn outer_sum(
    n: usize,
    m: usize,
    points: impl Iterator<Item = (Vec<f64>, Vec<f64>, f64)>,
) -> Vec<f64> {
    let mut out = vec![0.0; n * m];
    for (f, g, w) in points {
        for i in 0..n {
            let fi = f[i] * w;
            if fi == 0.0 {
                continue;
            }
            let row = &mut out[i * m..(i + 1) * m];
            for (o, gj) in row.iter_mut().zip(&g) {
                *o += fi * gj;
            }
        }
    }
    out
}

fn mat_mul(a: &[f64], b: &[f64], n: usize, k: usize, m: usize) -> Vec<f64> {
    let mut out = vec![0.0; n * m];
    for i in 0..n {
        for p in 0..k {
            let aip = a[i * k + p];
            if aip == 0.0 {
                continue;
            }
            for j in 0..m {
                out[i * m + j] += aip * b[p * m + j];
            }
        }
    }
    out
}

fn transpose(a: &[f64], n: usize, m: usize) -> Vec<f64> {
    let mut out = vec![0.0; n * m];
    for i in 0..n {
        for j in 0..m {
            out[j * n + i] = a[i * m + j];
        }
    }
    out
}

/// The SH rotation `R_jk = integral over the sphere of Y_j(v) Y_k(R_y v) dv` at `order`:
/// the SH coefficients of `g(v) = f(R_y(beta) v)` are `R` times those of `f`.
fn sh_rotation(order: u32, beta: f64) -> Vec<f64> {
    let n = coefficient_count(order);
    let (dirs, weights) = sphere_quadrature(order);
    outer_sum(
        n,
        n,
        dirs.iter()
            .zip(&weights)
            .map(|(v, w)| (sh_basis(order, *v), sh_basis(order, rotate_y(beta, *v)), *w)),
    )
}

/// Nodes per segment for the cut quadratures at `order`.
fn cut_nodes(order: u32) -> usize {
    (3 * order as usize + 8).min(64)
}

/// `M(beta)` (`n^2 x n^2`, row-major, `lambda_B = M lambda_A`) by `method`.
pub fn rotation_matrix(method: RotationMethod, order: u32, beta: f64) -> Vec<f64> {
    let n = coefficient_count(order);
    match method {
        RotationMethod::Tabulated => {
            let (dirs, weights) = cut_quadrature(beta, false, cut_nodes(order));
            outer_sum(
                n,
                n,
                dirs.iter()
                    .zip(&weights)
                    .map(|(v, w)| (basis(order, *v), basis(order, rotate_y(beta, *v)), *w)),
            )
        }
        RotationMethod::ConversionMatrix => {
            let sh_order = (2 * order).min(20);
            let ns = coefficient_count(sh_order);
            // C_ij = integral over H of H_i Y_j (eq. 3.20).
            let (dirs, weights) = cut_quadrature(0.0, false, (order + sh_order) as usize);
            let c = outer_sum(
                n,
                ns,
                dirs.iter()
                    .zip(&weights)
                    .map(|(v, w)| (basis(order, *v), sh_basis(sh_order, *v), *w)),
            );
            let r = sh_rotation(sh_order, beta);
            let cr = mat_mul(&c, &r, n, ns, ns);
            mat_mul(&cr, &transpose(&c, n, ns), n, ns, n)
        }
        RotationMethod::DigonDeletion => {
            // D_ij = integral over H minus the digon of H_i H_j (eq. 3.27): the digon is what
            // the tilt carries below B's horizon.
            let (dirs, weights) = cut_quadrature(beta, true, cut_nodes(order));
            let d = outer_sum(
                n,
                n,
                dirs.iter()
                    .zip(&weights)
                    .map(|(v, w)| (basis(order, *v), basis(order, *v), *w)),
            );
            // Eq. 3.30: the SH angle of an HSH tilt.
            let beta_sh = (2.0 * beta.cos() - 1.0).clamp(-1.0, 1.0).acos();
            mat_mul(&sh_rotation(order, beta_sh), &d, n, n, n)
        }
    }
}

/// Whether HSH coefficient `i` is of the sine kind (`m < 0`, `sin(|m| phi)`) rather than
/// the cosine kind (`m >= 0`). The tilt about y commutes with the reflection `y -> -y`
/// (`phi -> -phi`), which keeps every cosine-kind function and negates every sine-kind one,
/// so `M(beta)` never maps one kind onto the other: it is block diagonal in the two kinds
/// (order 8: blocks of 36 and 28 against 64 x 64, under half the products).
pub fn is_sine_kind(i: usize) -> bool {
    let l = (i as f64).sqrt() as usize;
    // Guard the float square root at perfect squares.
    let l = if (l + 1) * (l + 1) <= i { l + 1 } else { l };
    i < l * (l + 1)
}

/// The coefficients of each kind at `order`, in index order: the cosine kind, `n (n + 1) /
/// 2` of them, and the sine kind, `n (n - 1) / 2` (`n = order`). `radiance_gather.wgsl`
/// enumerates them the same way: `l` ascending, then `|m|` ascending.
pub fn kinds(order: u32) -> (Vec<usize>, Vec<usize>) {
    let mut cosine = Vec::new();
    let mut sine = Vec::new();
    for l in 0..order {
        for m in 0..=l {
            cosine.push(index(l, m as i32));
        }
        for m in 1..=l {
            sine.push(index(l, -(m as i32)));
        }
    }
    (cosine, sine)
}

/// `M(beta)` tabulated at `steps` even angles on `[0, beta_max]` and interpolated linearly
/// between them (what the GPU splat reads, `wgsl/radiance_gather.wgsl`).
#[derive(Clone, Debug)]
pub struct RotationTable {
    pub method: RotationMethod,
    pub order: u32,
    pub beta_max: f64,
    pub steps: u32,
    /// `steps` matrices of `n^2 x n^2` f32, row-major.
    pub matrices: Vec<f32>,
}

impl RotationTable {
    pub fn new(method: RotationMethod, order: u32, beta_max: f64, steps: u32) -> Self {
        let steps = steps.max(2);
        let n = coefficient_count(order);
        // One matrix per angle, each on whichever core takes it (a quadrature of a few
        // hundred directions each: most of a glossy animation's first-frame host setup).
        let per_step = crate::parallel::ordered_map(steps as usize, |s| {
            let beta = beta_max * s as f64 / f64::from(steps - 1);
            // The entries between the two kinds are zero but for the quadrature's rounding
            // (`is_sine_kind`): store exact zeros, which the GPU's block-wise tilt skips.
            rotation_matrix(method, order, beta)
                .iter()
                .enumerate()
                .map(|(k, &x)| {
                    if is_sine_kind(k / n) == is_sine_kind(k % n) {
                        x as f32
                    } else {
                        0.0
                    }
                })
                .collect::<Vec<f32>>()
        });
        let matrices = per_step.concat();
        Self {
            method,
            order,
            beta_max,
            steps,
            matrices,
        }
    }

    /// The interpolated matrix at `beta` (clamped to the table), as the GPU reads it.
    pub fn at(&self, beta: f64) -> Vec<f64> {
        let n2 = coefficient_count(self.order).pow(2);
        let t = (beta / self.beta_max).clamp(0.0, 1.0) * f64::from(self.steps - 1);
        let i = (t.floor() as u32).min(self.steps - 2) as usize;
        let f = t - i as f64;
        let a = &self.matrices[i * n2..(i + 1) * n2];
        let b = &self.matrices[(i + 1) * n2..(i + 2) * n2];
        a.iter()
            .zip(b)
            .map(|(x, y)| f64::from(*x) * (1.0 - f) + f64::from(*y) * f)
            .collect()
    }
}

/// `M x` for a square `n x n` row-major matrix.
pub fn apply(m: &[f64], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|i| {
            m[i * n..(i + 1) * n]
                .iter()
                .zip(x)
                .map(|(a, b)| a * b)
                .sum()
        })
        .collect()
}

/// The error of one method on a test field (the `hsh-rotation` command, docs/results.md):
/// a record at frame A projects `field` (a function of A-local directions, defined on the
/// whole sphere), is tilted by `beta` with `method`, and is compared with the ideal
/// rotation (the projection in B of the record's own function, at its order: B's
/// directions that lie below A's horizon get nothing) and with the record a pixel of frame B would compute directly.
/// Returns the relative L2 errors of the coefficients against the ideal and against the
/// direct ones.
pub fn rotation_error(
    method: RotationMethod,
    order: u32,
    beta: f64,
    field: impl Fn(DVec3) -> f64,
) -> (f64, f64) {
    let n = coefficient_count(order);
    let nodes = cut_nodes(order).max(48);
    let project = |dirs: &[DVec3], weights: &[f64], f: &dyn Fn(DVec3) -> f64| {
        let mut c = vec![0.0; n];
        for (v, w) in dirs.iter().zip(weights) {
            let fv = f(*v) * w;
            for (ck, hk) in c.iter_mut().zip(basis(order, *v)) {
                *ck += fv * hk;
            }
        }
        c
    };
    let (full, full_w) = cut_quadrature(0.0, false, nodes);
    let lambda_a = project(&full, &full_w, &field);
    // B-local v is A-local R_y v.
    let in_b = |v: DVec3| field(rotate_y(beta, v));
    let direct = project(&full, &full_w, &in_b);
    // The ideal: the record's own function (its order-n reconstruction) turned into B,
    // nothing where A never looked.
    let (cut, cut_w) = cut_quadrature(beta, false, nodes);
    let seen = |v: DVec3| super::evaluate(&lambda_a, order, rotate_y(beta, v));
    let ideal = project(&cut, &cut_w, &seen);
    let rotated = apply(&rotation_matrix(method, order, beta), &lambda_a);
    let norm = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt()
    };
    let len = direct.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
    let ideal_len = ideal.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
    (
        norm(&rotated, &ideal) / ideal_len,
        norm(&rotated, &direct) / len,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_tilt_is_the_identity_for_every_method() {
        let order = 4;
        let n = coefficient_count(order);
        for method in RotationMethod::ALL {
            let m = rotation_matrix(method, order, 0.0);
            let worst = (0..n * n)
                .map(|k| (m[k] - if k / n == k % n { 1.0 } else { 0.0 }).abs())
                .fold(0.0, f64::max);
            // The conversion matrix loses what order-8 SH cannot hold of the hemisphere
            // basis cut at the horizon (measured 0.51: C C^T is far from I, the method's
            // own loss, which is why it is not the default).
            let tol = if method == RotationMethod::ConversionMatrix {
                0.6
            } else {
                1e-9
            };
            assert!(worst < tol, "{method:?}: max |M - I| = {worst}");
        }
    }

    #[test]
    fn the_tabulated_tilt_matches_projecting_the_tilted_record() {
        // A smooth field with a bright lobe towards +x: tilting moves it across the
        // hemisphere.
        let field = |v: DVec3| 1.0 + 0.5 * v.x + 2.0 * (v.x.max(0.0)).powi(3) + 0.3 * v.y * v.z;
        let order = 4;
        for beta in [0.1, 0.3] {
            let (tab, _) = rotation_error(RotationMethod::Tabulated, order, beta, field);
            let (conv, _) = rotation_error(RotationMethod::ConversionMatrix, order, beta, field);
            // The tabulated rotation is the ideal one (the record never saw what it lacks).
            assert!(tab < 1e-4, "beta {beta}: tabulated {tab} against the ideal");
            assert!(conv.is_finite() && conv > tab);
        }
    }

    #[test]
    fn the_tilt_never_mixes_cosine_and_sine_kinds() {
        let order = 5;
        let n = coefficient_count(order);
        let (cosine, sine) = kinds(order);
        assert_eq!((cosine.len(), sine.len()), (15, 10));
        assert!(cosine.iter().all(|&i| !is_sine_kind(i)));
        assert!(sine.iter().all(|&i| is_sine_kind(i)));
        for method in RotationMethod::ALL {
            for beta in [0.2, 0.9, 1.4] {
                let m = rotation_matrix(method, order, beta);
                let largest = m.iter().fold(0.0f64, |a, x| a.max(x.abs()));
                let across = (0..n * n)
                    .filter(|k| is_sine_kind(k / n) != is_sine_kind(k % n))
                    .map(|k| m[k].abs())
                    .fold(0.0, f64::max);
                assert!(
                    across < 1e-9 * largest,
                    "{method:?} beta {beta}: |M| across kinds {across} (largest {largest})"
                );
            }
        }
    }

    #[test]
    fn the_table_interpolates_between_its_angles() {
        let t = RotationTable::new(RotationMethod::Tabulated, 3, 0.5, 9);
        let exact = rotation_matrix(RotationMethod::Tabulated, 3, 0.5 * 3.0 / 8.0);
        let tabled = t.at(0.5 * 3.0 / 8.0);
        for (a, b) in exact.iter().zip(&tabled) {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
        let mid = t.at(0.5 * 3.5 / 8.0);
        let exact_mid = rotation_matrix(RotationMethod::Tabulated, 3, 0.5 * 3.5 / 8.0);
        let worst = mid
            .iter()
            .zip(&exact_mid)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 5e-3, "linear interpolation error {worst}");
    }
}
