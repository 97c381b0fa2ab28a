//! CPU reference ray tracer: every instance's triangles flattened into world space, in one
//! BVH2 ([`super::build_triangles`]: obvhs's, or ours for degenerate input) traversed with
//! obvhs's own CPU traversal. It is independent of our two-level GPU
//! layout, which is what makes it a useful reference for the GPU kernels.

use crate::scene::Scene;
use glam::{Vec3, Vec3A};
use obvhs::{
    bvh2::Bvh2,
    ray::{Ray, RayHit},
    triangle::Triangle,
};

/// A closest hit found on the CPU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuHit {
    pub t: f32,
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub triangle: u32,
    /// Barycentrics of v1 and v2 (hit = (1-u-v) v0 + u v1 + v v2).
    pub u: f32,
    pub v: f32,
    /// Index into [`CpuTracer::triangles`].
    pub leaf: u32,
}

/// World-space triangles of a whole scene in one obvhs BVH.
pub struct CpuTracer {
    pub bvh: Bvh2,
    /// World-space triangles in leaf order.
    pub triangles: Vec<Triangle>,
    /// (instance, mesh triangle) of each triangle in leaf order.
    pub ids: Vec<(u32, u32)>,
}

impl CpuTracer {
    /// Flattens the scene and builds the BVH (obvhs `medium_build`, see
    /// [`super::build_triangles`]).
    pub fn new(scene: &Scene) -> Self {
        let mut tris = Vec::new();
        let mut ids = Vec::new();
        for (ii, inst) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[inst.mesh as usize];
            for (ti, t) in mesh.indices.iter().enumerate() {
                let p = |k: usize| {
                    Vec3A::from(
                        inst.transform
                            .transform_point3(mesh.positions[t[k] as usize]),
                    )
                };
                tris.push(Triangle {
                    v0: p(0),
                    v1: p(1),
                    v2: p(2),
                });
                ids.push((ii as u32, ti as u32));
            }
        }
        // obvhs's tree for ordinary scenes, ours where PLOC degenerates (the same choice
        // as for a BLAS; a CPU traversal has no fixed stack, the budget only keeps the
        // tree shallow).
        let bvh = super::build_triangles(&tris, super::blas_params(), super::BLAS_STACK_BUDGET).bvh;
        let triangles = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        let ids = bvh
            .primitive_indices
            .iter()
            .map(|&i| ids[i as usize])
            .collect();
        CpuTracer {
            bvh,
            triangles,
            ids,
        }
    }

    /// Closest hit along `origin + t dir`, `t` in `[tmin, tmax]`.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<CpuHit> {
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        let mut hit = RayHit::none();
        if !self
            .bvh
            .ray_traverse(ray, &mut hit, |r, id| self.triangles[id].intersect(r))
        {
            return None;
        }
        let id = hit.primitive_id as usize;
        let (u, v) = barycentrics(&self.triangles[id], origin, dir);
        let (instance, triangle) = self.ids[id];
        Some(CpuHit {
            t: hit.t,
            instance,
            triangle,
            u,
            v,
            leaf: id as u32,
        })
    }

    /// Whether anything blocks the segment `origin + t dir`, `t` in `[tmin, tmax]`.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        !self
            .bvh
            .ray_traverse_miss(ray, |r, id| self.triangles[id].intersect(r))
    }
}

/// Möller–Trumbore barycentrics (u at v1, v at v2), the same formulation as `wgsl/shared/bvh.wgsl`.
pub fn barycentrics(t: &Triangle, origin: Vec3, dir: Vec3) -> (f32, f32) {
    let (v0, v1, v2) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let p = dir.cross(e2);
    let inv_det = 1.0 / e1.dot(p);
    let s = origin - v0;
    let u = s.dot(p) * inv_det;
    let q = s.cross(e1);
    let v = dir.dot(q) * inv_det;
    (u, v)
}
