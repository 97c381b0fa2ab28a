//! Plain-Rust mirror of the VPL trace (`wgsl/vpl_trace.wgsl`): the same emitters, sample
//! points (Owen-scrambled Sobol with the same seeds), emission, path continuation and slots,
//! with rays traced by obvhs on the CPU and surfaces from [`DirectReference`]. Tests compare
//! the GPU's VPLs with it.

use super::{ENVIRONMENT, Vpl, VplPlan};
use crate::direct::reference::{DirectReference, offset_ray_origin};
use crate::sampling::{cosine_hemisphere, hash_combine, hash_u32, orthonormal_basis, sobol_2d};
use crate::scene::Light;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// WGSL `emitter_seed`.
pub fn emitter_seed(emitter: u32, dimension: u32) -> u32 {
    hash_combine(hash_u32(emitter), 0x7e10 + dimension)
}

fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn disk_point(centre: Vec3, axis: Vec3, r: f32, u: Vec2) -> Vec3 {
    let rho = r * u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    centre + orthonormal_basis(axis) * Vec3::new(rho * phi.cos(), rho * phi.sin(), 0.0)
}

/// GLSL/WGSL `smoothstep`.
fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The first ray (origin, direction) and flux of path `k` of emitter `index` of `plan`
/// (WGSL `emit`, shared/light_paths.wgsl).
pub fn emit(
    direct: &DirectReference<'_>,
    plan: &VplPlan,
    index: u32,
    k: u32,
) -> (Vec3, Vec3, Vec3) {
    let e = plan.emitters[index as usize];
    let u_pos = sobol_2d(k, emitter_seed(index, 0));
    let u_dir = sobol_2d(k, emitter_seed(index, 1));
    let n = e.paths as f32;
    let (centre, radius) = plan.sphere;
    let scene = direct.scene;
    if e.light == ENVIRONMENT {
        let (w, l_over_pdf) = match &scene.environment_map {
            Some(map) => match map.sample(u_dir) {
                Some((w, pdf)) if pdf > 0.0 => (w, map.radiance(w) / pdf),
                Some((w, _)) => (w, Vec3::ZERO),
                None => (Vec3::Y, Vec3::ZERO),
            },
            None => (uniform_sphere(u_dir), scene.environment * (4.0 * PI)),
        };
        let origin = disk_point(centre + w * radius, w, radius, u_pos);
        return (origin, -w, l_over_pdf * (PI * radius * radius / n));
    }
    match scene.lights[e.light as usize] {
        Light::Point {
            position,
            intensity,
        } => (position, uniform_sphere(u_dir), intensity * (4.0 * PI / n)),
        Light::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
        } => {
            let c = 1.0 - u_dir.x * (1.0 - cos_outer);
            let s = (1.0 - c * c).max(0.0).sqrt();
            let phi = 2.0 * PI * u_dir.y;
            let dir = orthonormal_basis(direction) * Vec3::new(s * phi.cos(), s * phi.sin(), c);
            let falloff = smoothstep(cos_outer, cos_inner, c);
            (
                position,
                dir,
                intensity * (falloff * 2.0 * PI * (1.0 - cos_outer) / n),
            )
        }
        Light::Rect {
            corner,
            edge_u,
            edge_v,
            radiance,
        } => {
            let cr = edge_u.cross(edge_v);
            let nl = cr / cr.length();
            let q = corner + u_pos.x * edge_u + u_pos.y * edge_v;
            (
                offset_ray_origin(q, nl),
                orthonormal_basis(nl) * cosine_hemisphere(u_dir),
                radiance * (PI * cr.length() / n),
            )
        }
        Light::Sun {
            direction,
            irradiance,
        } => (
            disk_point(centre + direction * radius, direction, radius, u_pos),
            -direction,
            irradiance * (PI * radius * radius / n),
        ),
    }
}

/// The VPLs of `plan` (every slot, empty ones included), traced on the CPU.
pub fn trace_vpls(direct: &DirectReference<'_>, plan: &VplPlan) -> Vec<Vpl> {
    let mut out = vec![Vpl::default(); plan.slots() as usize];
    for p in 0..plan.paths {
        let index = plan
            .emitters
            .iter()
            .rposition(|e| e.first_path <= p)
            .unwrap_or(0) as u32;
        let k = p - plan.emitters[index as usize].first_path;
        let (mut origin, mut dir, mut flux) = emit(direct, plan, index, k);
        let mut alive = flux.min_element() >= 0.0 && flux.max_element() > 0.0;
        for d in 0..plan.bounces {
            if !alive {
                break;
            }
            let Some(hit) = direct.tracer.closest_hit(origin, dir, 0.0, f32::INFINITY) else {
                break;
            };
            let s = direct.surface_at(&hit, dir);
            let albedo = direct.albedo(&s);
            let position = offset_ray_origin(s.position, s.geometric_normal);
            out[(p * plan.bounces + d) as usize] = Vpl {
                position: position.into(),
                normal: s.shading_normal.into(),
                power: (flux * albedo * (1.0 / PI)).into(),
                ..Default::default()
            };
            flux *= albedo;
            alive = flux.max_element() > 0.0;
            dir = orthonormal_basis(s.shading_normal)
                * cosine_hemisphere(sobol_2d(k, emitter_seed(index, 2 + d)));
            origin = position;
            if dir.dot(s.geometric_normal) <= 0.0 {
                alive = false;
            }
        }
    }
    out
}
