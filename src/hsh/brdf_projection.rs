//! BRDF projection (thesis eqs. 3.33-3.36, algorithms.md 2.4): per glossy material, the HSH
//! coefficients of the cosine-weighted glossy lobe `f(wo, wi) cos(theta_i)` for a grid of
//! outgoing directions `wo` on the Heidrich-Seidel paraboloid map (32 x 32 in the thesis),
//! computed once per scene. Shading a pixel from a radiance record is then the dot product
//! of these coefficients (for the pixel's view direction) with the record's incoming
//! radiance coefficients. The Lambertian lobe is not projected: it is `albedo / pi` times
//! the irradiance, with the albedo per texel.
//!
//! The lobe's reflectance (`specular`, RGB) multiplies the projected shape, so one table of
//! scalars per material serves every channel. How much of the lobe an order holds is the
//! thesis's accuracy metric (eq. 3.32): `sum_k c_k^2 / integral (f cos)^2 dw`, the share
//! of the lobe's energy the coefficients capture (1 for a lobe the order holds exactly).

use super::{HemisphereQuadrature, basis, coefficient_count};
use crate::scene::GlossyLobe;
use glam::{DVec3, Vec3};

/// The unit outgoing direction (local frame, +z the normal) at paraboloid-map coordinates
/// `(u, v)` in [0, 1]^2 (`u = (1 + x / (1 + z)) / 2`, `v = (1 + y / (1 + z)) / 2`); outside the
/// unit disc of the map, the nearest direction on the horizon.
pub fn paraboloid_direction(u: f64, v: f64) -> DVec3 {
    let (mut x, mut y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    let r2 = x * x + y * y;
    if r2 > 1.0 {
        let r = r2.sqrt();
        x /= r;
        y /= r;
    }
    let r2 = (x * x + y * y).min(1.0);
    DVec3::new(2.0 * x, 2.0 * y, 1.0 - r2) / (1.0 + r2)
}

/// Paraboloid-map coordinates of a unit direction with `w.z >= 0`.
pub fn paraboloid_coordinates(w: DVec3) -> (f64, f64) {
    let d = 1.0 + w.z.max(0.0);
    (0.5 * (1.0 + w.x / d), 0.5 * (1.0 + w.y / d))
}

/// One material's projected lobe.
#[derive(Clone, Debug)]
pub struct ProjectedLobe {
    pub order: u32,
    /// Map resolution: `resolution^2` outgoing directions, row-major in (v, u).
    pub resolution: u32,
    /// `order^2` coefficients per outgoing direction, of the lobe's shape (multiply by its
    /// `specular` for each channel).
    pub coefficients: Vec<f32>,
    /// The accuracy metric (eq. 3.32) per outgoing direction.
    pub accuracy: Vec<f64>,
}

impl ProjectedLobe {
    /// Projects `lobe` (its shape, specular 1) at `order` on a `resolution^2` map with
    /// `quadrature` (from [`quadrature_for`]).
    pub fn new(lobe: &GlossyLobe, order: u32, resolution: u32, quadrature: &Quadrature) -> Self {
        let n = coefficient_count(order);
        let shape = unit_shape(lobe);
        let cells = (resolution * resolution) as usize;
        let mut coefficients = Vec::with_capacity(cells * n);
        let mut accuracy = Vec::with_capacity(cells);
        for j in 0..resolution {
            for i in 0..resolution {
                let wo = paraboloid_direction(
                    (f64::from(i) + 0.5) / f64::from(resolution),
                    (f64::from(j) + 0.5) / f64::from(resolution),
                );
                let (c, a) = project_for(&shape, wo, n, quadrature);
                accuracy.push(a);
                coefficients.extend(c.iter().map(|&x| x as f32));
            }
        }
        Self {
            order,
            resolution,
            coefficients,
            accuracy,
        }
    }

    /// The coefficients of the map cell nearest to `wo` (local frame).
    pub fn at(&self, wo: DVec3) -> &[f32] {
        let (u, v) = paraboloid_coordinates(wo);
        let r = self.resolution as f64;
        let i = ((u * r) as u32).min(self.resolution - 1);
        let j = ((v * r) as u32).min(self.resolution - 1);
        let n = coefficient_count(self.order);
        let k = (j * self.resolution + i) as usize * n;
        &self.coefficients[k..k + n]
    }

    /// Mean and least accuracy over the map's directions inside the hemisphere (cells
    /// whose centre lies in the map's unit disc).
    pub fn accuracy_summary(&self) -> (f64, f64) {
        let r = f64::from(self.resolution);
        let mut sum = 0.0;
        let mut least = f64::INFINITY;
        let mut count = 0usize;
        for j in 0..self.resolution {
            for i in 0..self.resolution {
                let x = 2.0 * (f64::from(i) + 0.5) / r - 1.0;
                let y = 2.0 * (f64::from(j) + 0.5) / r - 1.0;
                if x * x + y * y > 1.0 {
                    continue;
                }
                let a = self.accuracy[(j * self.resolution + i) as usize];
                sum += a;
                least = least.min(a);
                count += 1;
            }
        }
        (sum / count.max(1) as f64, least)
    }
}

/// The projected lobe of an isotropic BRDF as the splat reads it: coefficients for
/// outgoing directions in the xz half-plane (`phi_o = 0`) at `steps` even angles
/// `theta_o` in `[0, pi/2]`. A lobe that is the same all around the normal (Phong is) has
/// at `(theta_o, phi_o)` the coefficients at `(theta_o, 0)` turned about the normal by
/// `phi_o` ([`crate::hsh::rotate_z`], exact), so a 1-D table and one exact turn replace
/// the paraboloid map's 2-D interpolation, which blurs the lobe in azimuth.
#[derive(Clone, Debug)]
pub struct LobeTable {
    pub order: u32,
    pub steps: u32,
    /// `steps x order^2` f32 coefficients of the lobe's shape (specular 1); those of bands
    /// `bands` and above are zero ([`LobeTable::truncated`]).
    pub coefficients: Vec<f32>,
    /// The accuracy metric (eq. 3.32) at each angle, of the coefficients as stored.
    pub accuracy: Vec<f64>,
    /// Bands `l < bands` hold the lobe (`bands <= order`): the splat skips the rest.
    pub bands: u32,
}

impl LobeTable {
    pub fn new(lobe: &GlossyLobe, order: u32, steps: u32, quadrature: &Quadrature) -> Self {
        let n = coefficient_count(order);
        let shape = unit_shape(lobe);
        let steps = steps.max(2);
        let mut coefficients = Vec::with_capacity(steps as usize * n);
        let mut accuracy = Vec::with_capacity(steps as usize);
        for s in 0..steps {
            // Grazing outgoing directions sit just above the horizon.
            let t = (f64::from(s) / f64::from(steps - 1)).min(0.999) * std::f64::consts::FRAC_PI_2;
            let wo = DVec3::new(t.sin(), 0.0, t.cos());
            let (c, a) = project_for(&shape, wo, n, quadrature);
            accuracy.push(a);
            coefficients.extend(c.iter().map(|&x| x as f32));
        }
        Self {
            order,
            steps,
            coefficients,
            accuracy,
            bands: order,
        }
    }

    /// The table with the fewest bands whose projection still holds `share` of the lobe's
    /// energy (eq. 3.32, [`LobeTable::mean_accuracy`]); all `order` bands when even they hold
    /// less. The bands dropped are zeroed. A broad lobe needs few bands (Phong 1 holds 99.7 %
    /// at order 4), and the splat's tilt costs in proportion to the bands of the lobe
    /// (`wgsl/radiance_gather.wgsl`): records keep every band of the incoming radiance,
    /// the lobe sets how many of them reach the pixel.
    pub fn truncated(mut self, share: f64) -> Self {
        let n = coefficient_count(self.order);
        let steps = self.steps as usize;
        // Accuracy with `bands` bands at each angle: the energy the first bands^2
        // coefficients hold, a share of what all of them hold (orthonormal basis).
        let accuracy_at = |bands: u32| -> Vec<f64> {
            let kept = coefficient_count(bands);
            (0..steps)
                .map(|s| {
                    let c = &self.coefficients[s * n..(s + 1) * n];
                    let all: f64 = c.iter().map(|&x| f64::from(x) * f64::from(x)).sum();
                    let held: f64 = c[..kept].iter().map(|&x| f64::from(x) * f64::from(x)).sum();
                    if all > 0.0 {
                        self.accuracy[s] * held / all
                    } else {
                        self.accuracy[s]
                    }
                })
                .collect()
        };
        let Some(bands) = (1..self.order).find(|&b| mean_over_angles(&accuracy_at(b)) >= share)
        else {
            return self;
        };
        self.accuracy = accuracy_at(bands);
        let kept = coefficient_count(bands);
        for row in self.coefficients.chunks_mut(n) {
            row[kept..].fill(0.0);
        }
        self.bands = bands;
        self
    }

    /// The coefficients for `wo` (local frame), interpolated in theta and turned to its
    /// azimuth, as the GPU splat computes them.
    pub fn at(&self, wo: DVec3) -> Vec<f64> {
        let n = coefficient_count(self.order);
        let theta = wo.z.clamp(0.0, 1.0).acos();
        let t = (theta / std::f64::consts::FRAC_PI_2 * f64::from(self.steps - 1))
            .clamp(0.0, f64::from(self.steps - 1));
        let i = (t.floor() as u32).min(self.steps - 2) as usize;
        let f = t - i as f64;
        let c: Vec<f64> = (0..n)
            .map(|k| {
                f64::from(self.coefficients[i * n + k]) * (1.0 - f)
                    + f64::from(self.coefficients[(i + 1) * n + k]) * f
            })
            .collect();
        crate::hsh::rotate_z(&c, self.order, wo.y.atan2(wo.x))
    }

    /// The accuracy (eq. 3.32) averaged over outgoing directions by solid angle.
    pub fn mean_accuracy(&self) -> f64 {
        mean_over_angles(&self.accuracy)
    }
}

/// Values at even angles `theta_o` on `[0, pi/2]`, averaged by solid angle.
fn mean_over_angles(values: &[f64]) -> f64 {
    let last = values.len().saturating_sub(1).max(1) as f64;
    let mut sum = 0.0;
    let mut weight = 0.0;
    for (s, a) in values.iter().enumerate() {
        let t = s as f64 / last * std::f64::consts::FRAC_PI_2;
        let w = t.sin().max(1e-3);
        sum += a * w;
        weight += w;
    }
    sum / weight
}

/// A quadrature rule with the basis precomputed at its directions.
pub struct Quadrature {
    pub rule: HemisphereQuadrature,
    basis: Vec<f64>,
    basis_stride: usize,
}

/// A rule fine enough for `lobe` at `order`: Gauss-Legendre nodes in cos(theta) for the
/// basis (`order`) and for the lobe's width (about `1 / sqrt(exponent)` radians).
pub fn quadrature_for(lobe: &GlossyLobe, order: u32) -> Quadrature {
    let width_nodes = (12.0 * f64::from(lobe.exponent()).max(1.0).sqrt()) as usize;
    let nodes = (2 * order as usize).max(width_nodes).clamp(16, 512);
    let rule = HemisphereQuadrature::new(nodes);
    let stride = coefficient_count(order);
    let mut b = Vec::with_capacity(rule.directions.len() * stride);
    for w in &rule.directions {
        b.extend(basis(order, *w));
    }
    Quadrature {
        rule,
        basis: b,
        basis_stride: stride,
    }
}

/// The `n` coefficients of the cosine-weighted `shape` for the outgoing direction `wo`
/// (local frame), and the share of its energy they hold (eq. 3.32).
fn project_for(
    shape: &GlossyLobe,
    wo: DVec3,
    n: usize,
    quadrature: &Quadrature,
) -> (Vec<f64>, f64) {
    let stride = quadrature.basis_stride;
    let mut c = vec![0.0f64; n];
    let mut energy = 0.0;
    for (q, (wi, dw)) in quadrature
        .rule
        .directions
        .iter()
        .zip(&quadrature.rule.weights)
        .enumerate()
    {
        let g = f64::from(shape.eval(Vec3::Z, wo.as_vec3(), wi.as_vec3()).x) * wi.z;
        if g == 0.0 {
            continue;
        }
        energy += g * g * dw;
        let h = &quadrature.basis[q * stride..q * stride + n];
        for (ck, hk) in c.iter_mut().zip(h) {
            *ck += g * dw * hk;
        }
    }
    let captured: f64 = c.iter().map(|x| x * x).sum();
    (c, if energy > 0.0 { captured / energy } else { 1.0 })
}

/// The lobe with unit reflectance (its shape).
fn unit_shape(lobe: &GlossyLobe) -> GlossyLobe {
    match *lobe {
        GlossyLobe::Phong { exponent, .. } => GlossyLobe::Phong {
            specular: Vec3::ONE,
            exponent,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paraboloid_map_round_trips_directions() {
        for k in 0..50 {
            let t = 1.5 * (k as f64 + 0.5) / 50.0;
            let p = 0.9 * k as f64;
            let w = DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
            let (u, v) = paraboloid_coordinates(w);
            assert!((paraboloid_direction(u, v) - w).length() < 1e-12);
        }
        // The map's centre is the normal, its unit circle the horizon.
        assert!((paraboloid_direction(0.5, 0.5) - DVec3::Z).length() < 1e-15);
        assert!(paraboloid_direction(1.0, 0.5).z.abs() < 1e-15);
    }

    #[test]
    fn projected_lobes_shade_like_the_lobe_and_capture_more_with_order() {
        let lobe = GlossyLobe::Phong {
            specular: Vec3::ONE,
            exponent: 20.0,
        };
        let mut last = 0.0;
        for order in [3u32, 6, 10] {
            let q = quadrature_for(&lobe, order);
            let p = ProjectedLobe::new(&lobe, order, 8, &q);
            let (mean, least) = p.accuracy_summary();
            assert!(
                mean > last,
                "order {order}: accuracy {mean} not above {last}"
            );
            assert!(least <= mean && mean <= 1.0 + 1e-9);
            last = mean;
        }
        assert!(last > 0.9, "order 10 holds {last} of a Phong-20 lobe");
        // Shading by dot product: constant incoming radiance 1 gives the directional
        // albedo, which at normal incidence is the specular (1 here).
        let order = 10;
        let q = quadrature_for(&lobe, order);
        let p = ProjectedLobe::new(&lobe, order, 33, &q);
        let one = q.rule.project(order, |_| 1.0);
        let albedo: f64 = p
            .at(DVec3::Z)
            .iter()
            .zip(&one)
            .map(|(a, b)| f64::from(*a) * b)
            .sum();
        assert!((albedo - 1.0).abs() < 0.02, "albedo {albedo} head on");
    }

    #[test]
    fn a_broad_lobe_keeps_only_the_bands_it_needs() {
        let table = |exponent: f32, order: u32| {
            let lobe = GlossyLobe::Phong {
                specular: Vec3::ONE,
                exponent,
            };
            LobeTable::new(&lobe, order, 16, &quadrature_for(&lobe, order))
        };
        // Phong 1 at order 8: 99.97 % of its energy; 4 bands hold over 99.5 %.
        let full = table(1.0, 8);
        let cut = full.clone().truncated(0.995);
        assert!(cut.bands < 8 && cut.bands >= 2, "{} bands", cut.bands);
        assert!(cut.mean_accuracy() >= 0.995);
        // One band less would not hold the share.
        let coarser = full.clone().truncated(cut.mean_accuracy() + 1e-9);
        assert!(coarser.bands > cut.bands);
        let n = coefficient_count(8);
        let kept = coefficient_count(cut.bands);
        for (row, whole) in cut.coefficients.chunks(n).zip(full.coefficients.chunks(n)) {
            assert_eq!(&row[..kept], &whole[..kept]);
            assert!(row[kept..].iter().all(|&c| c == 0.0));
        }
        // A Phong-20 lobe holds under 99.5 % at order 8: every band stays.
        let sharp = table(20.0, 8).truncated(0.995);
        assert_eq!(sharp.bands, 8);
    }
}
