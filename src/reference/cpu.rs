//! Plain-Rust mirror of the reference pass (`wgsl/reference_indirect.wgsl`): the same
//! bounce directions (bit-identical Sobol points and seeds), the same sum order, with rays
//! traced by obvhs on the CPU ([`crate::bvh::cpu_trace`]) and direct light at the bounce
//! hits from [`DirectReference`]. Also the mirror of the glossy bounce
//! (`wgsl/shared/glossy_bounce.wgsl`) and of the glossy indirect pass
//! (`wgsl/glossy_indirect.wgsl`, [`crate::glossy`]).

use crate::direct::reference::{DirectReference, ReferencePixel, Surface, offset_ray_origin};
use crate::sampling::{cosine_hemisphere, hash_combine, hash_u32, orthonormal_basis, sobol_2d};
use crate::scene::Scene;
use crate::visibility::GpuCamera;
use glam::Vec3;
use std::f32::consts::PI;

/// One pixel of the CPU reference.
#[derive(Clone, Copy, Debug, Default)]
pub struct IndirectPixel {
    /// Visibility, emission + direct (beauty without indirect), albedo, direct.
    pub direct: ReferencePixel,
    /// Reflected first-bounce indirect radiance ρ / N · Σ L_k.
    pub indirect: Vec3,
    /// emission + direct + indirect.
    pub beauty: Vec3,
}

/// CPU reference of direct + first-bounce indirect light.
pub struct IndirectReference<'a> {
    pub direct: DirectReference<'a>,
    pub spp: u32,
    /// Sequence seed, as [`crate::reference::ReferenceOptions::seed`] (0 by default).
    pub seed: u32,
    /// Bounces N, as [`crate::reference::ReferenceOptions::bounces`] (1 by default).
    pub bounces: u32,
}

/// WGSL `PATH_SEED`: scrambles the directions of bounce b >= 2 (plus b).
pub const PATH_SEED: u32 = 0xb0;

/// Scramble seed of a pixel's hemisphere directions with sequence seed 0, as WGSL
/// `indirect_seed(pixel, 0u)`.
pub fn indirect_seed(pixel: u32) -> u32 {
    hash_combine(hash_u32(pixel), 0x1d1)
}

/// Scramble seed of a pixel's hemisphere directions for sequence seed `seed`, as WGSL
/// `indirect_seed(pixel, seed)`: seed 0 is [`indirect_seed`], others hash it in.
pub fn indirect_seed_with(pixel: u32, seed: u32) -> u32 {
    if seed == 0 {
        indirect_seed(pixel)
    } else {
        hash_combine(indirect_seed(pixel), seed)
    }
}

impl<'a> IndirectReference<'a> {
    /// `spp` bounce directions per pixel; `light_samples` as in the scene settings.
    pub fn new(scene: &'a Scene, light_samples: u32, spp: u32) -> Self {
        Self {
            direct: DirectReference::new(scene, light_samples),
            spp: spp.max(1),
            seed: 0,
            bounces: 1,
        }
    }

    /// Emission seen by a bounce ray, as WGSL `indirect_emission`
    /// ([`DirectReference::indirect_emission`]).
    pub fn indirect_emission(&self, s: &Surface) -> Vec3 {
        self.direct.indirect_emission(s)
    }

    /// Outgoing radiance of the closest hit along bounce direction `k`, as WGSL
    /// `bounce_radiance`: ρ(hit) / π · E_direct(hit) + L_e,indirect(hit); zero on a miss.
    pub fn bounce_radiance(&self, s: &Surface, seed: u32, k: u32) -> Vec3 {
        let dir = orthonormal_basis(s.shading_normal) * cosine_hemisphere(sobol_2d(k, seed));
        if dir.dot(s.geometric_normal) <= 0.0 {
            return Vec3::ZERO;
        }
        let origin = offset_ray_origin(s.position, s.geometric_normal);
        let Some(hit) = self
            .direct
            .tracer
            .closest_hit(origin, dir, 0.0, f32::INFINITY)
        else {
            return Vec3::ZERO;
        };
        let h = self.direct.surface_at(&hit, dir);
        let e = self.direct.direct_irradiance(&h, hash_combine(seed, k));
        self.hit_radiance(&h, e, seed, k)
    }

    /// Outgoing radiance of a secondary hit `h` with direct irradiance `e`, as WGSL
    /// `hit_radiance` in the reference: ρ / π · (E_direct + E_path) + L_e,indirect.
    pub fn hit_radiance(&self, h: &Surface, e: Vec3, seed: u32, k: u32) -> Vec3 {
        let e = e + self.path_irradiance(h, seed, k);
        self.direct.albedo(h) * (1.0 / PI) * e + self.indirect_emission(h)
    }

    /// Indirect irradiance at a bounce hit from bounces 2..N of its path, as WGSL
    /// `hit_indirect_irradiance` of `reference_indirect.wgsl`: zero with one bounce.
    pub fn path_irradiance(&self, hit: &Surface, seed: u32, k: u32) -> Vec3 {
        let mut l = Vec3::ZERO;
        let mut throughput = Vec3::ONE;
        let mut s = *hit;
        for b in 2..=self.bounces {
            let bounce_seed = hash_combine(seed, PATH_SEED + b);
            let dir =
                orthonormal_basis(s.shading_normal) * cosine_hemisphere(sobol_2d(k, bounce_seed));
            if dir.dot(s.geometric_normal) <= 0.0 {
                break;
            }
            let origin = offset_ray_origin(s.position, s.geometric_normal);
            let Some(next) = self
                .direct
                .tracer
                .closest_hit(origin, dir, 0.0, f32::INFINITY)
            else {
                break;
            };
            let h = self.direct.surface_at(&next, dir);
            let e = self
                .direct
                .direct_irradiance(&h, hash_combine(bounce_seed, k));
            let albedo = self.direct.albedo(&h);
            l += throughput * (albedo * (1.0 / PI) * e + self.indirect_emission(&h));
            throughput *= albedo;
            s = h;
        }
        PI * l
    }

    /// Renders one pixel (its own camera ray, traced on the CPU).
    pub fn pixel(&self, camera: &GpuCamera, x: u32, y: u32) -> IndirectPixel {
        let direct = self.direct.pixel(camera, x, y);
        if direct.hit.is_none() {
            return IndirectPixel {
                direct,
                indirect: Vec3::ZERO,
                beauty: direct.beauty,
            };
        }
        let dir = camera.ray_dir(x, y);
        let Some(hit) =
            self.direct
                .tracer
                .closest_hit(camera.origin.into(), dir, camera.tmin, f32::INFINITY)
        else {
            return IndirectPixel {
                direct,
                ..Default::default()
            };
        };
        let s = self.direct.surface_at(&hit, dir);
        let pixel = y * camera.width + x;
        let seed = indirect_seed_with(pixel, self.seed);
        // Same sum order as the GPU: sample 0 first.
        let mut sum = Vec3::ZERO;
        for k in 0..self.spp {
            sum += self.bounce_radiance(&s, seed, k);
        }
        let mut indirect = direct.albedo * (sum * (1.0 / self.spp as f32));
        // The glossy lobe's own importance-sampled estimate, as the GPU's `glossy_sum`.
        if self.direct.scene.materials[s.material as usize]
            .glossy
            .is_some()
        {
            let mut g = Vec3::ZERO;
            for k in 0..self.spp {
                g += glossy_bounce(self, &s, -dir, seed, k);
            }
            indirect += g * (1.0 / self.spp as f32);
        }
        IndirectPixel {
            direct,
            indirect,
            beauty: direct.beauty + indirect,
        }
    }
}

/// WGSL `GLOSSY_SEED`.
pub const GLOSSY_SEED: u32 = 0x6c055;

/// WGSL `glossy_pixel_seed`: the glossy indirect pass's scramble for a pixel.
pub fn glossy_pixel_seed(pixel: u32) -> u32 {
    hash_combine(hash_u32(pixel), 0x910)
}

/// Lobe sample `k` of surface `s` seen from `wo`, as WGSL `glossy_bounce`: the closest
/// hit's radiance (direct light, Lambertian, and emission not sampled as a light) times
/// f cos / pdf; zero without a glossy lobe, below the surface or on a miss.
pub fn glossy_bounce(r: &IndirectReference<'_>, s: &Surface, wo: Vec3, seed: u32, k: u32) -> Vec3 {
    let Some(lobe) = r.direct.scene.materials[s.material as usize].glossy else {
        return Vec3::ZERO;
    };
    let n = s.shading_normal;
    let (wi, _) = lobe.sample(n, wo, sobol_2d(k, hash_combine(seed, GLOSSY_SEED)));
    let cos_i = wi.dot(n);
    if cos_i <= 0.0 || wi.dot(s.geometric_normal) <= 0.0 {
        return Vec3::ZERO;
    }
    let pdf = lobe.pdf(n, wo, wi);
    if pdf <= 0.0 {
        return Vec3::ZERO;
    }
    let origin = offset_ray_origin(s.position, s.geometric_normal);
    let Some(hit) = r.direct.tracer.closest_hit(origin, wi, 0.0, f32::INFINITY) else {
        return Vec3::ZERO;
    };
    let h = r.direct.surface_at(&hit, wi);
    let e = r
        .direct
        .direct_irradiance(&h, hash_combine(seed, k ^ GLOSSY_SEED));
    let l = r.hit_radiance(&h, e, hash_combine(seed, GLOSSY_SEED), k);
    lobe.eval(n, wo, wi) * (cos_i / pdf) * l
}

/// The glossy indirect radiance of pixel `(x, y)` with `samples` lobe directions, as
/// `glossy_indirect.wgsl`.
pub fn glossy_indirect(
    r: &IndirectReference<'_>,
    camera: &GpuCamera,
    x: u32,
    y: u32,
    samples: u32,
) -> Vec3 {
    let dir = camera.ray_dir(x, y);
    let Some(hit) =
        r.direct
            .tracer
            .closest_hit(camera.origin.into(), dir, camera.tmin, f32::INFINITY)
    else {
        return Vec3::ZERO;
    };
    let s = r.direct.surface_at(&hit, dir);
    let Some(count) = glossy_sample_count(r, &s, samples) else {
        return Vec3::ZERO;
    };
    let seed = glossy_pixel_seed(y * camera.width + x);
    let mut g = Vec3::ZERO;
    for k in 0..count {
        g += glossy_bounce(r, &s, -dir, seed, k);
    }
    g / count as f32
}

/// Lobe samples the glossy pass takes at surface `s` with `samples` per pixel, as WGSL
/// `glossy_sample_count`: `samples` times the lobe's share of the reflectance (channel
/// sums), at least 1; None without a glossy lobe.
pub fn glossy_sample_count(r: &IndirectReference<'_>, s: &Surface, samples: u32) -> Option<u32> {
    let lobe = r.direct.scene.materials[s.material as usize].glossy?;
    let samples = samples.max(1);
    let ks = lobe.specular();
    let kd = r.direct.albedo(s);
    let g = (ks.x + ks.y) + ks.z;
    let share = g / ((kd.x + kd.y) + kd.z + g).max(1e-6);
    Some(((samples as f32 * share).ceil() as u32).clamp(1, samples))
}
