//! Thesis Table 4.1 reproduced: RMS error of plane irradiance against full-hemisphere Monte
//! Carlo at random visible points, for the plain plane, the plane divided by its coverage
//! ratio (\[LC04\]) and the stretched border (Gautron), at several fields of view. Runs on the
//! CPU reference (same rays and shading as the GPU passes). With a [`RefineComparison`],
//! also the stretched plane adaptively refined ([`super::refine`]) against a plain
//! stretched plane of (about) the same ray count, and for each the share of points whose
//! plane irradiance is zero where the Monte Carlo reference's is not.

use super::reference::RecordReference;
use super::{CacheSettings, HemispherePlane, PlaneMode, PlaneSample, RecordSite};
use crate::direct::reference::offset_ray_origin;
use crate::sampling::{cosine_hemisphere, hash_combine, hash_u32, orthonormal_basis, sobol_2d};
use crate::scene::Scene;
use crate::visibility::GpuCamera;
use glam::{DVec3, Vec3};
use std::f32::consts::PI;

/// One row of the table.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PlaneErrorRow {
    pub fov_degrees: f32,
    /// RMS relative error (fractions) of the three estimators.
    pub plain: f64,
    pub coverage_ratio: f64,
    pub stretched: f64,
    /// Share of the points whose stretched-plane E is exactly zero (every channel) where
    /// the Monte Carlo E is not.
    pub stretched_zero: f64,
    /// With a [`RefineComparison`]: the stretched plane refined, and the plain stretched
    /// plane at the equal-rays resolution.
    pub refine: Option<RefineRow>,
}

/// The refinement columns of a [`PlaneErrorRow`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct RefineRow {
    /// RMS relative error of the refined stretched plane (P^2 + K split^2 rays).
    pub refined: f64,
    pub refined_zero: f64,
    /// RMS relative error of the plain stretched plane at the equal-rays resolution.
    pub equal_rays: f64,
    pub equal_rays_zero: f64,
}

/// Refined planes against plain planes of the same ray count.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RefineComparison {
    /// Fraction of pixels refined (`--plane-refine`).
    pub fraction: f32,
    /// Sub-samples per axis (`--plane-refine-split`).
    pub split: u32,
    /// Resolution Q of the plain plane compared at equal rays (Q^2 close to
    /// `P^2 + K split^2`, see [`RefineComparison::equal_resolution`]).
    pub equal_resolution: u32,
    /// Rays per record of the refined plane and of the equal-rays plane.
    pub refined_rays: u64,
    pub equal_rays: u64,
}

impl RefineComparison {
    /// The plain resolution whose ray count is closest to the refined plane's.
    pub fn equal_resolution(settings: &CacheSettings) -> u32 {
        let rays = settings.plane_rays_per_record() as f64;
        rays.sqrt().round() as u32
    }
}

/// The table and what it was computed from.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PlaneErrorTable {
    pub points: usize,
    pub mc_samples: u32,
    pub plane_resolution: u32,
    pub refine: Option<RefineComparison>,
    pub rows: Vec<PlaneErrorRow>,
}

/// Random visible points of the scene's camera (deterministic).
fn visible_sites(
    reference: &RecordReference,
    camera: &GpuCamera,
    points: usize,
) -> Vec<RecordSite> {
    let mut sites = Vec::with_capacity(points);
    let mut k = 0u32;
    while sites.len() < points && k < 100 * points as u32 + 1000 {
        let h = hash_u32(k);
        k += 1;
        let x = h % camera.width;
        let y = hash_combine(h, 1) % camera.height;
        let dir = camera.ray_dir(x, y);
        let Some(hit) = reference.shading.tracer.closest_hit(
            camera.origin.into(),
            dir,
            camera.tmin,
            f32::INFINITY,
        ) else {
            continue;
        };
        let s = reference.shading.surface_at(&hit, dir);
        sites.push(RecordSite {
            position: s.position.into(),
            r_min: 1.0,
            normal: s.shading_normal.into(),
            seed: hash_u32(sites.len() as u32),
            geometric_normal: s.geometric_normal.into(),
            instance: hit.instance,
        });
    }
    sites
}

/// Full-hemisphere Monte Carlo irradiance (cosine-distributed Sobol directions), hits shaded
/// as plane hits are.
pub fn monte_carlo_irradiance(
    reference: &RecordReference,
    site: &RecordSite,
    samples: u32,
) -> Vec3 {
    let scene = reference.shading.scene;
    let n = Vec3::from(site.normal);
    let ng = Vec3::from(site.geometric_normal);
    let frame = orthonormal_basis(n);
    let origin = offset_ray_origin(site.position.into(), ng);
    let mut sum = DVec3::ZERO;
    for k in 0..samples {
        let dir = frame * cosine_hemisphere(sobol_2d(k, hash_combine(site.seed, 0x3c)));
        if dir.dot(ng) <= 0.0 {
            continue;
        }
        let l = match reference
            .shading
            .tracer
            .closest_hit(origin, dir, 0.0, f32::INFINITY)
        {
            // The environment is sampled as a light (direct): misses add nothing.
            None => Vec3::ZERO,
            Some(hit) => {
                let s = reference.shading.surface_at(&hit, dir);
                let m = &scene.materials[s.material as usize];
                let emission = if s.front_face && !m.sampled_light {
                    m.emission
                } else {
                    Vec3::ZERO
                };
                let e = reference
                    .shading
                    .direct_irradiance(&s, hash_combine(site.seed, k));
                reference.shading.albedo(&s) / PI * e + emission
            }
        };
        sum += l.as_dvec3();
    }
    (sum * (std::f64::consts::PI / f64::from(samples))).as_vec3()
}

fn plane_irradiance(plane: &HemispherePlane, samples: &[PlaneSample]) -> DVec3 {
    samples
        .iter()
        .zip(&plane.pixels)
        .map(|(s, p)| Vec3::from(s.radiance).as_dvec3() * f64::from(p.cos_weight))
        .sum()
}

/// Computes the table; `progress` gets the number of points done. With
/// `settings.plane_refine > 0` it adds the refinement columns, the plain plane compared
/// at `equal_resolution` (None: [`RefineComparison::equal_resolution`]).
pub fn plane_error_table(
    scene: &Scene,
    settings: &CacheSettings,
    points: usize,
    mc_samples: u32,
    fovs: &[f32],
    equal_resolution: Option<u32>,
    mut progress: impl FnMut(usize),
) -> PlaneErrorTable {
    let refine = (settings.refined_pixels() > 0).then(|| {
        let q = equal_resolution.unwrap_or_else(|| RefineComparison::equal_resolution(settings));
        RefineComparison {
            fraction: settings.plane_refine,
            split: settings.plane_refine_split,
            equal_resolution: q,
            refined_rays: settings.plane_rays_per_record(),
            equal_rays: u64::from(q) * u64::from(q),
        }
    });
    let camera = GpuCamera::new(&scene.camera);
    let base = RecordReference::new(scene, settings);
    let sites = visible_sites(&base, &camera, points);
    let references: Vec<Vec3> = sites
        .iter()
        .enumerate()
        .map(|(i, s)| {
            progress(i / 2);
            monte_carlo_irradiance(&base, s, mc_samples)
        })
        .collect();
    // The three tables per field of view, built once; their pixel centres (the rays) are
    // the same, so one traced plane serves all three.
    const MODES: [PlaneMode; 3] = [
        PlaneMode::Plain,
        PlaneMode::CoverageRatio,
        PlaneMode::Stretched,
    ];
    let tables: Vec<[HemispherePlane; 3]> = fovs
        .iter()
        .map(|&fov| {
            MODES.map(|mode| {
                HemispherePlane::new(settings.plane_resolution, fov, mode, settings.plane_spacing)
            })
        })
        .collect();
    let equal_tables: Vec<Option<HemispherePlane>> = fovs
        .iter()
        .map(|&fov| {
            refine.as_ref().map(|r| {
                HemispherePlane::new(
                    r.equal_resolution,
                    fov,
                    PlaneMode::Stretched,
                    settings.plane_spacing,
                )
            })
        })
        .collect();
    // Per field of view: squared errors of plain, coverage ratio, stretched, refined,
    // equal rays; zero counts of stretched, refined, equal rays.
    let mut squared = vec![[0.0f64; 5]; fovs.len()];
    let mut zeros = vec![[0usize; 3]; fovs.len()];
    let mut counted = 0usize;
    for (i, (site, mc)) in sites.iter().zip(&references).enumerate() {
        progress(sites.len() / 2 + i / 2);
        let mc = mc.as_dvec3();
        if mc.length() <= 1e-6 {
            continue; // a point in full darkness has no relative error
        }
        counted += 1;
        let err = |e: DVec3| ((e - mc).length() / mc.length()).powi(2);
        let zero = |e: DVec3| usize::from(e.max_element() <= 0.0);
        for (f, planes) in tables.iter().enumerate() {
            let (samples, noise): (Vec<PlaneSample>, Vec<f32>) = planes[2]
                .pixels
                .iter()
                .enumerate()
                .map(|(k, px)| base.trace_ray_noise(site, px.center, k as u32))
                .unzip();
            for (m, plane) in planes.iter().enumerate() {
                squared[f][m] += err(plane_irradiance(plane, &samples));
            }
            zeros[f][0] += zero(plane_irradiance(&planes[2], &samples));
            if let Some(equal) = &equal_tables[f] {
                let fov_settings = CacheSettings {
                    plane_fov_degrees: fovs[f],
                    plane_mode: PlaneMode::Stretched,
                    ..settings.clone()
                };
                let (refined, _) = super::refine::refine_plane(
                    &planes[2],
                    &fov_settings,
                    site,
                    &samples,
                    &noise,
                    None,
                    |s, xy, seed| base.trace_ray(s, xy, seed),
                );
                let e = plane_irradiance(&planes[2], &refined);
                squared[f][3] += err(e);
                zeros[f][1] += zero(e);
                let e = plane_irradiance(equal, &base.trace_plane_with(equal, site));
                squared[f][4] += err(e);
                zeros[f][2] += zero(e);
            }
        }
    }
    let rms = |s: f64| (s / counted.max(1) as f64).sqrt();
    let share = |z: usize| z as f64 / counted.max(1) as f64;
    PlaneErrorTable {
        points: counted,
        mc_samples,
        plane_resolution: settings.plane_resolution,
        rows: fovs
            .iter()
            .zip(squared.iter().zip(&zeros))
            .map(|(&fov_degrees, (s, z))| PlaneErrorRow {
                fov_degrees,
                plain: rms(s[0]),
                coverage_ratio: rms(s[1]),
                stretched: rms(s[2]),
                stretched_zero: share(z[0]),
                refine: refine.as_ref().map(|_| RefineRow {
                    refined: rms(s[3]),
                    refined_zero: share(z[1]),
                    equal_rays: rms(s[4]),
                    equal_rays_zero: share(z[2]),
                }),
            })
            .collect(),
        refine,
    }
}

/// The table as text.
pub fn format_table(t: &PlaneErrorTable) -> String {
    let mut out = format!(
        "RMS error of plane irradiance vs {}-sample Monte Carlo, {} points, {}x{} plane\n\
         {:>8} {:>10} {:>16} {:>10}\n",
        t.mc_samples,
        t.points,
        t.plane_resolution,
        t.plane_resolution,
        "FOV",
        "plain",
        "coverage ratio",
        "stretched"
    );
    for r in &t.rows {
        out += &format!(
            "{:>7.0}° {:>9.1}% {:>15.1}% {:>9.1}%\n",
            r.fov_degrees,
            100.0 * r.plain,
            100.0 * r.coverage_ratio,
            100.0 * r.stretched
        );
    }
    if let Some(c) = &t.refine {
        let p = t.plane_resolution;
        out += &format!(
            "Adaptive refinement (stretched; {:.0} % of pixels x {}x{} sub-samples): RMS error \
             / share of points with plane E = 0 where Monte Carlo E > 0\n\
             {:>8} {:>22} {:>22} {:>22}\n",
            100.0 * c.fraction,
            c.split,
            c.split,
            "FOV",
            format!("{p}x{p} ({} rays)", p * p),
            format!("refined ({} rays)", c.refined_rays),
            format!("{0}x{0} ({1} rays)", c.equal_resolution, c.equal_rays),
        );
        for r in &t.rows {
            let Some(f) = &r.refine else { continue };
            let cell = |e: f64, z: f64| format!("{:.2}% / {:.2}%", 100.0 * e, 100.0 * z);
            out += &format!(
                "{:>7.0}° {:>22} {:>22} {:>22}\n",
                r.fov_degrees,
                cell(r.stretched, r.stretched_zero),
                cell(f.refined, f.refined_zero),
                cell(f.equal_rays, f.equal_rays_zero),
            );
        }
    }
    out
}
