//! Plain-Rust mirror of the photon trace (`wgsl/photon_trace.wgsl`): the VPL paths'
//! emission ([`crate::vpl::reference::emit`]), the same continuation and slots, rays traced
//! by obvhs on the CPU. Tests compare the GPU's photons with it.

use super::Photon;
use crate::direct::reference::{DirectReference, offset_ray_origin};
use crate::sampling::{cosine_hemisphere, orthonormal_basis, sobol_2d};
use crate::vpl::VplPlan;
use crate::vpl::reference::{emit, emitter_seed};

/// The photons of `plan` (every slot, empty ones included), traced on the CPU.
pub fn trace_photons(direct: &DirectReference<'_>, plan: &VplPlan) -> Vec<Photon> {
    let mut out = vec![Photon::default(); plan.slots() as usize];
    for p in 0..plan.paths {
        let index = plan
            .emitters
            .iter()
            .rposition(|e| e.first_path <= p)
            .unwrap_or(0) as u32;
        let k = p - plan.emitters[index as usize].first_path;
        let (mut origin, mut dir, mut flux) = emit(direct, plan, index, k);
        let mut alive = flux.min_element() >= 0.0 && flux.max_element() > 0.0;
        for d in 0..=plan.bounces {
            if !alive {
                break;
            }
            let Some(hit) = direct.tracer.closest_hit(origin, dir, 0.0, f32::INFINITY) else {
                break;
            };
            let s = direct.surface_at(&hit, dir);
            if d > 0 {
                out[(p * plan.bounces + d - 1) as usize] = Photon {
                    position: s.position.into(),
                    distance: hit.t,
                    direction: (-dir).into(),
                    bounce: d,
                    flux: flux.into(),
                    normal: s.shading_normal.into(),
                    ..Default::default()
                };
            }
            flux *= direct.albedo(&s);
            alive = flux.max_element() > 0.0;
            dir = orthonormal_basis(s.shading_normal)
                * cosine_hemisphere(sobol_2d(k, emitter_seed(index, 2 + d)));
            origin = offset_ray_origin(s.position, s.geometric_normal);
            if dir.dot(s.geometric_normal) <= 0.0 {
                alive = false;
            }
        }
    }
    out
}
