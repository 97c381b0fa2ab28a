//! Plain-Rust reference of record computation: the same plane rays traced by obvhs on the
//! CPU, the same shading (bit-identical light sample points), and the reduction of
//! `record_reduce.wgsl` summed in f64.

use super::{CacheSettings, HemispherePlane, PlaneSample, Record, RecordSite};
use crate::direct::reference::{DirectReference, offset_ray_origin};
use crate::sampling::{hash_u32, plane_light_first, record_frame};
use crate::scene::Scene;
use crate::visibility::{GpuCamera, VisSample};
use glam::{DVec3, Vec3};
use std::f32::consts::PI;

/// CPU record computation for one scene and settings.
pub struct RecordReference<'a> {
    pub shading: DirectReference<'a>,
    pub plane: HemispherePlane,
    pub settings: CacheSettings,
}

impl<'a> RecordReference<'a> {
    pub fn new(scene: &'a Scene, settings: &CacheSettings) -> Self {
        Self {
            shading: DirectReference::new(scene, settings.plane_light_samples),
            plane: settings.plane(settings.plane_resolution),
            settings: settings.clone(),
        }
    }

    /// The site `record_sites.wgsl` makes from a visibility sample.
    pub fn site_from_pixel(
        settings: &CacheSettings,
        camera: &GpuCamera,
        v: &VisSample,
        record_index: u32,
    ) -> RecordSite {
        let footprint = 2.0 * Vec3::from(camera.up).length() * v.t / camera.height as f32;
        RecordSite {
            position: v.position,
            r_min: settings.r_min_pixels * footprint / settings.accuracy,
            normal: v.shading_normal,
            seed: hash_u32(record_index),
            geometric_normal: v.geometric_normal,
            instance: v.instance,
        }
    }

    /// Traces and shades the plane of `site` (as `hemisphere_plane.wgsl`).
    pub fn trace_plane(&self, site: &RecordSite) -> Vec<PlaneSample> {
        self.trace_plane_with(&self.plane, site)
    }

    /// Same with another plane table (its pixel centres give the rays), reusing this
    /// reference's CPU BVH.
    pub fn trace_plane_with(&self, plane: &HemispherePlane, site: &RecordSite) -> Vec<PlaneSample> {
        plane
            .pixels
            .iter()
            .enumerate()
            .map(|(k, px)| self.trace_ray(site, px.center, k as u32))
            .collect()
    }

    /// One plane ray of `site` through plane coordinates `(x, y, 1)`, plane sample
    /// `index` of the record (its hit's light samples: [`plane_light_first`]; WGSL
    /// `trace_plane_ray`).
    pub fn trace_ray(&self, site: &RecordSite, xy: [f32; 2], index: u32) -> PlaneSample {
        self.trace_ray_noise(site, xy, index).0
    }

    /// [`Self::trace_ray`] and the channel sum of what its hit's environment samples gave it
    /// (WGSL `TracedSample::noise`, refinement's selection: [`super::refine::contrast_keys`]).
    pub fn trace_ray_noise(
        &self,
        site: &RecordSite,
        xy: [f32; 2],
        index: u32,
    ) -> (PlaneSample, f32) {
        let scene = self.shading.scene;
        let n = Vec3::from(site.normal);
        let ng = Vec3::from(site.geometric_normal);
        let frame = record_frame(n, site.seed);
        let origin = offset_ray_origin(site.position.into(), ng);
        let dir = (frame * Vec3::new(xy[0], xy[1], 1.0)).normalize();
        let miss = PlaneSample {
            radiance: [0.0; 3],
            depth: -1.0,
        };
        if dir.dot(ng) <= 0.0 {
            return (miss, 0.0);
        }
        let Some(hit) = self
            .shading
            .tracer
            .closest_hit(origin, dir, 0.0, f32::INFINITY)
        else {
            // The environment is sampled as a light: misses add nothing.
            return (miss, 0.0);
        };
        let s = self.shading.surface_at(&hit, dir);
        let (e, e_env) = self.shading.plane_direct_irradiance_split(
            &s,
            site.seed,
            plane_light_first(index, self.shading.light_samples),
            self.settings.plane_light_choices,
        );
        let m = &scene.materials[s.material as usize];
        let emission = if s.front_face && !m.sampled_light {
            m.emission
        } else {
            Vec3::ZERO
        };
        let albedo = self.shading.albedo(&s);
        let radiance = albedo / PI * e + emission;
        let sampled = albedo * (1.0 / PI) * e_env;
        (
            PlaneSample {
                radiance: radiance.into(),
                depth: hit.t * dir.dot(n),
            },
            (sampled.x + sampled.y) + sampled.z,
        )
    }

    /// The plane of `site` traced and, with `settings.plane_refine > 0`, adaptively refined
    /// (as `plane_refine_select.wgsl` and `hemisphere_plane.wgsl`'s refinement): the refined plane and the
    /// pixels refined.
    pub fn refined_plane(&self, site: &RecordSite) -> (Vec<PlaneSample>, Vec<u32>) {
        let (coarse, noise): (Vec<PlaneSample>, Vec<f32>) = self
            .plane
            .pixels
            .iter()
            .enumerate()
            .map(|(k, px)| self.trace_ray_noise(site, px.center, k as u32))
            .unzip();
        self.refine(site, &coarse, &noise)
    }

    /// Refines a traced plane of `site` with its samples' environment shares `noise` (see
    /// [`super::refine`]).
    pub fn refine(
        &self,
        site: &RecordSite,
        coarse: &[PlaneSample],
        noise: &[f32],
    ) -> (Vec<PlaneSample>, Vec<u32>) {
        self.refine_guided(site, coarse, noise, None)
    }

    /// [`Self::refine`] with a dark plane refined only near the lit surfaces of `guide`'s
    /// lit grid ([`super::refine::guided_pixels`]; `None`: everywhere).
    pub fn refine_guided(
        &self,
        site: &RecordSite,
        coarse: &[PlaneSample],
        noise: &[f32],
        guide: Option<&super::refine::DarkGuide>,
    ) -> (Vec<PlaneSample>, Vec<u32>) {
        super::refine::refine_plane(
            &self.plane,
            &self.settings,
            site,
            coarse,
            noise,
            guide,
            |s, xy, seed| self.trace_ray(s, xy, seed),
        )
    }

    /// Reduces a traced plane to a record (as `record_reduce.wgsl`, summed in f64).
    pub fn reduce(&self, site: &RecordSite, samples: &[PlaneSample]) -> Record {
        reduce_plane(&self.plane, &self.settings, site, samples)
    }

    /// Computes the record of `site` entirely on the CPU (refined as the settings say).
    pub fn record(&self, site: &RecordSite) -> Record {
        self.reduce(site, &self.refined_plane(site).0)
    }
}

/// The reduction of `record_reduce.wgsl` in f64: E, cosine-weighted harmonic mean distance,
/// gradients from the plane (algorithms.md 3.3), R clamps and Ward's gradient limit.
pub fn reduce_plane(
    plane: &HemispherePlane,
    settings: &CacheSettings,
    site: &RecordSite,
    samples: &[PlaneSample],
) -> Record {
    let res = plane.resolution as usize;
    let l = |s: &PlaneSample| DVec3::from(Vec3::from(s.radiance));
    let nearer = super::nearer_depth;
    let mut e = DVec3::ZERO;
    let mut inv_distance = 0.0f64;
    let mut weight_sum = 0.0f64;
    let (mut rx, mut ry, mut tx, mut ty) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    let mut variance = 0.0f64;
    let y = |s: &PlaneSample| l(s).element_sum();
    // The corral: per vertex, the nearest horizontal distance of a hit on the plane's
    // outermost ring (the rays nearest the horizon), in f32 as record_reduce.wgsl.
    let mut corral_h = [-1.0f32; super::CORRAL_SECTORS as usize];
    let (turn_c, turn_s) = crate::sampling::record_frame_turn(site.seed);
    for (k, (s, px)) in samples.iter().zip(&plane.pixels).enumerate() {
        let (i, j) = (k % res, k / res);
        if settings.corral.in_records()
            && s.depth > 0.0
            && (i == 0 || j == 0 || i + 1 == res || j + 1 == res)
        {
            let c = Vec3::new(px.center[0], px.center[1], 0.0);
            let h = s.depth * c.length();
            let t = super::corral_turn(turn_c * c.x - turn_s * c.y, turn_s * c.x + turn_c * c.y);
            // Within a quarter sector of vertex round(t).
            let vertex = t.round();
            if (t - vertex).abs() <= 0.25 {
                let b = (vertex as usize) % super::CORRAL_SECTORS as usize;
                if corral_h[b] < 0.0 || h < corral_h[b] {
                    corral_h[b] = h;
                }
            }
        }
        let w2 = f64::from(px.cos_weight).powi(2) * 0.25;
        let w = f64::from(px.cos_weight);
        weight_sum += w;
        e += l(s) * w;
        if s.depth > 0.0 {
            let c = glam::DVec2::new(px.center[0].into(), px.center[1].into());
            inv_distance += w / (f64::from(s.depth) * (1.0 + c.dot(c)).sqrt());
        }
        rx += l(s) * f64::from(px.rotation[0]);
        ry += l(s) * f64::from(px.rotation[1]);
        if k % res + 1 < res {
            let right = &samples[k + 1];
            let z = nearer(s.depth, right.depth);
            if z > 0.0 {
                tx += (l(right) - l(s)) * (f64::from(px.edge_x) / f64::from(z));
            }
            variance += w2 * (y(right) - y(s)).powi(2);
        }
        if k + res < samples.len() {
            let up = &samples[k + res];
            let z = nearer(s.depth, up.depth);
            if z > 0.0 {
                ty += (l(up) - l(s)) * (f64::from(px.edge_y) / f64::from(z));
            }
            variance += w2 * (y(up) - y(s)).powi(2);
        }
    }
    let r_min = f64::from(site.r_min);
    let r_max = r_min * f64::from(settings.r_max_factor);
    // Ward's split sphere: the cosine-weighted harmonic mean distance (R_max without hits).
    let split_sphere = if inv_distance > 0.0 {
        (weight_sum / inv_distance).clamp(r_min, r_max)
    } else {
        r_max
    };
    let mut radius = match settings.record_radius {
        super::RecordRadius::SplitSphere => split_sphere,
        super::RecordRadius::Hessian { scale } => {
            let far = super::hessian::MISS_DISTANCE * r_max;
            let h = super::hessian::plane_hessian(plane, samples, far);
            let lambda = super::hessian::largest_eigenvalue(h);
            let lum = super::hessian::LUMINANCE
                .iter()
                .zip(e.to_array())
                .map(|(w, c)| w * c)
                .sum::<f64>()
                / std::f64::consts::PI;
            if lum > 0.0 && lambda > 0.0 {
                (f64::from(scale) * (lum / lambda).sqrt()).clamp(r_min, r_max)
            } else if lum <= 0.0 {
                // A dark plane: the split sphere's radius (record_reduce.wgsl).
                split_sphere
            } else {
                r_max
            }
        }
    };
    let frame = record_frame(site.normal.into(), site.seed).as_dmat3();
    let mut rot = [DVec3::ZERO; 3];
    let mut tr = [DVec3::ZERO; 3];
    if settings.gradients {
        for c in 0..3 {
            rot[c] = frame * DVec3::new(rx[c], ry[c], 0.0);
            tr[c] = frame * DVec3::new(tx[c], ty[c], 0.0);
        }
        let mut limited = radius;
        for c in 0..3 {
            let g = tr[c].length();
            if g * limited > e[c] {
                limited = e[c] / g;
            }
        }
        radius = limited.max(r_min);
        for c in 0..3 {
            let g = tr[c].length();
            if g * radius > e[c] {
                tr[c] *= e[c] / (g * radius);
            }
        }
    }
    let v4 = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
    let mut rotation_gradient = [v4(rot[0]), v4(rot[1]), v4(rot[2])];
    rotation_gradient[0][3] = plane_noise(variance, e) as f32;
    let mut record = Record {
        position: site.position,
        radius: radius as f32,
        normal: site.normal,
        r_min: site.r_min,
        irradiance: [e.x as f32, e.y as f32, e.z as f32],
        instance: site.instance,
        rotation_gradient,
        translation_gradient: [v4(tr[0]), v4(tr[1]), v4(tr[2])],
    };
    record.set_corral(super::corral_words(&corral_h, record.radius));
    record
}

/// A record's relative noise from its plane (`record_reduce.wgsl` `relative_noise`):
/// `sqrt(V) / (E_r + E_g + E_b)`, 0 for a dark plane. `variance` is a stratified estimate
/// of the variance of the plane's sum over the channel sums y: each stratum's variance is
/// read from its differences with its right and upper neighbours, `V = sum over those
/// edges of w_k^2 (y_k - y_j)^2 / 4` (half a squared difference estimates a variance, and
/// a pixel has about two such edges). An edge in the radiance counts as noise too: the
/// pixels that straddle one are where a stratified estimate errs.
pub fn plane_noise(variance: f64, e: DVec3) -> f64 {
    let total = e.element_sum();
    if total > 0.0 {
        variance.sqrt() / total
    } else {
        0.0
    }
}
