//! Materials' reflectance: a Lambertian lobe (`albedo / pi`) plus an optional glossy lobe
//! ([`GlossyLobe`]). The glossy lobe is an enum so that another model (glTF's GGX) is one
//! more variant, evaluated, sampled and projected where the Phong one is
//! ([`GlossyLobe::eval`], [`GlossyLobe::sample`], `crate::hsh::brdf_projection`).
//!
//! Directions are unit vectors pointing away from the surface: `wo` towards the viewer,
//! `wi` towards the light, `n` the shading normal.

use glam::Vec3;
use std::f32::consts::PI;

/// The glossy lobe of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GlossyLobe {
    /// Energy-conserving ("modified", normalised) Phong (Lafortune & Willems 1994):
    /// `f = specular (n + 2) / (2 pi) cos^n(alpha)`, alpha the angle between `wi` and the
    /// mirror direction of `wo`. Its directional albedo is at most `specular` (equal at
    /// normal incidence when no lobe falls under the horizon), so `albedo + specular <= 1`
    /// per channel conserves energy. The thesis's glossy scenes use exponents 20 and 15.
    Phong { specular: Vec3, exponent: f32 },
}

impl GlossyLobe {
    /// The lobe's reflectance (the largest share of light it can reflect).
    pub fn specular(&self) -> Vec3 {
        match *self {
            GlossyLobe::Phong { specular, .. } => specular,
        }
    }

    /// The Phong exponent, the lobe's sharpness.
    pub fn exponent(&self) -> f32 {
        match *self {
            GlossyLobe::Phong { exponent, .. } => exponent,
        }
    }

    /// The BRDF value of the lobe (not cosine-weighted); zero when either direction lies
    /// below the surface.
    pub fn eval(&self, n: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        if n.dot(wo) <= 0.0 || n.dot(wi) <= 0.0 {
            return Vec3::ZERO;
        }
        match *self {
            GlossyLobe::Phong { specular, exponent } => {
                let cos_alpha = mirror(n, wo).dot(wi);
                if cos_alpha <= 0.0 {
                    return Vec3::ZERO;
                }
                specular * ((exponent + 2.0) / (2.0 * PI) * cos_alpha.powf(exponent))
            }
        }
    }

    /// A direction drawn from the lobe's shape for `u` in [0, 1)^2 (Phong: `cos^n` about the
    /// mirror direction) and its probability density per solid angle. Directions below the
    /// surface are returned too (their BRDF is zero): the caller counts them as misses.
    pub fn sample(&self, n: Vec3, wo: Vec3, u: glam::Vec2) -> (Vec3, f32) {
        match *self {
            GlossyLobe::Phong { exponent, .. } => {
                let r = mirror(n, wo);
                let cos_a = u.x.powf(1.0 / (exponent + 1.0));
                let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
                let phi = 2.0 * PI * u.y;
                let basis = crate::sampling::orthonormal_basis(r);
                let wi = basis * Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a);
                (wi, self.pdf(n, wo, wi))
            }
        }
    }

    /// The density of [`GlossyLobe::sample`] at `wi`.
    pub fn pdf(&self, n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
        match *self {
            GlossyLobe::Phong { exponent, .. } => {
                let cos_a = mirror(n, wo).dot(wi);
                if cos_a <= 0.0 {
                    return 0.0;
                }
                (exponent + 1.0) / (2.0 * PI) * cos_a.powf(exponent)
            }
        }
    }
}

/// The mirror direction of `wo` about `n`.
pub fn mirror(n: Vec3, wo: Vec3) -> Vec3 {
    2.0 * n.dot(wo) * n - wo
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{hash_combine, hash_u32, u32_to_unit};

    fn unit(k: u32) -> glam::Vec2 {
        let h = hash_u32(k);
        glam::Vec2::new(u32_to_unit(h), u32_to_unit(hash_combine(h, 1)))
    }

    /// Directional albedo by importance sampling: int f cos dwi.
    fn albedo(lobe: &GlossyLobe, n: Vec3, wo: Vec3, samples: u32) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for k in 0..samples {
            let (wi, pdf) = lobe.sample(n, wo, unit(k));
            if pdf > 0.0 && n.dot(wi) > 0.0 {
                sum += lobe.eval(n, wo, wi) * n.dot(wi) / pdf;
            }
        }
        sum / samples as f32
    }

    #[test]
    fn normalised_phong_reflects_at_most_its_specular_and_all_of_it_head_on() {
        let lobe = GlossyLobe::Phong {
            specular: Vec3::new(0.5, 0.25, 1.0),
            exponent: 20.0,
        };
        let n = Vec3::Z;
        // Head on, the lobe lies above the horizon: the albedo is `specular` up to the
        // cosine inside the lobe, (n + 2) / (n + 1) * E[cos theta_i] = 1 - O(1/n).
        let head_on = albedo(&lobe, n, Vec3::Z, 20_000);
        assert!(
            (head_on.x - 0.5).abs() < 0.02,
            "albedo {head_on} at normal incidence"
        );
        // Never more than the specular, at any angle.
        for deg in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
            let t = deg.to_radians();
            let wo = Vec3::new(t.sin(), 0.0, t.cos());
            let a = albedo(&lobe, n, wo, 20_000);
            assert!(a.z <= 1.0 + 0.01, "albedo {a} at {deg} degrees exceeds 1");
        }
    }

    #[test]
    fn the_sampling_density_integrates_to_one_and_matches_the_samples() {
        let lobe = GlossyLobe::Phong {
            specular: Vec3::ONE,
            exponent: 15.0,
        };
        let n = Vec3::Z;
        let wo = Vec3::new(0.3, -0.2, 0.93).normalize();
        // int pdf dw over the sphere by a uniform-sphere estimator.
        let mut sum = 0.0;
        let count = 200_000;
        for k in 0..count {
            let u = unit(k);
            let z = 1.0 - 2.0 * u.x;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * u.y;
            let w = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            sum += lobe.pdf(n, wo, w) * 4.0 * PI;
        }
        let mean = sum / count as f32;
        assert!((mean - 1.0).abs() < 0.02, "int pdf = {mean}");
        // Samples concentrate about the mirror direction as cos^n says: E[cos a] = (n+1)/(n+2).
        let m = mirror(n, wo);
        let mean_cos: f32 = (0..20_000)
            .map(|k| lobe.sample(n, wo, unit(k)).0.dot(m))
            .sum::<f32>()
            / 20_000.0;
        assert!(
            (mean_cos - 16.0 / 17.0).abs() < 0.003,
            "E[cos a] = {mean_cos}"
        );
    }

    #[test]
    fn the_lobe_is_symmetric_in_its_directions_and_zero_below_the_surface() {
        let lobe = GlossyLobe::Phong {
            specular: Vec3::splat(0.4),
            exponent: 20.0,
        };
        let n = Vec3::new(0.2, 0.1, 1.0).normalize();
        let a = Vec3::new(0.5, 0.1, 0.8).normalize();
        let b = Vec3::new(-0.4, -0.1, 0.9).normalize();
        assert!(
            (lobe.eval(n, a, b) - lobe.eval(n, b, a))
                .abs()
                .max_element()
                < 1e-5
        );
        assert_eq!(lobe.eval(n, a, -b), Vec3::ZERO);
        assert_eq!(lobe.eval(n, -a, b), Vec3::ZERO);
    }
}
