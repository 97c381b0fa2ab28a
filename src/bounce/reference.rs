//! Plain-Rust mirror of one level of the bounce cache's gather (`wgsl/bounce_gather.wgsl`):
//! the same cell centroids, directions (Owen-scrambled Sobol with the same seeds), light
//! seeds and sum order, with rays traced by obvhs on the CPU and the hits' direct light
//! from [`DirectReference`]. Tests compare the GPU's values with it.

use super::layout::{BounceLayout, cell_centroid};
use crate::bvh::SceneBvh;
use crate::bvh::cpu_trace::CpuHit;
use crate::direct::reference::{DirectReference, Surface, offset_ray_origin};
use crate::sampling::{cosine_hemisphere, hash_combine, hash_u32, orthonormal_basis, sobol_2d};
use glam::Vec3;
use std::f32::consts::PI;

/// WGSL `side_seed`.
pub fn side_seed(side: u32) -> u32 {
    hash_combine(hash_u32(side), 0xb0c)
}

/// The CPU gather of one level over a scene whose GPU BVH is `bvh`.
pub struct GatherReference<'a> {
    pub direct: DirectReference<'a>,
    pub layout: &'a BounceLayout,
    /// The previous level's values (3 per cell side; empty: level 1).
    pub previous: &'a [f32],
    pub rays: u32,
    /// Leaf-order triangle of (mesh's first leaf triangle + mesh triangle).
    leaf_of: Vec<u32>,
    /// Mesh triangle of each leaf-order triangle (the GPU shading table's).
    mesh_triangle_of: Vec<u32>,
    /// First leaf triangle of each instance.
    first_of_instance: Vec<u32>,
}

impl<'a> GatherReference<'a> {
    /// `direct` must use the gather's light samples.
    pub fn new(
        direct: DirectReference<'a>,
        bvh: &SceneBvh,
        layout: &'a BounceLayout,
        previous: &'a [f32],
        rays: u32,
    ) -> Self {
        let mut leaf_of = vec![0; bvh.shading.len()];
        let firsts: Vec<u32> = bvh.mesh_offsets.iter().map(|&(_, t)| t).collect();
        let mut mesh = 0;
        for (leaf, sh) in bvh.shading.iter().enumerate() {
            while mesh + 1 < firsts.len() && firsts[mesh + 1] as usize <= leaf {
                mesh += 1;
            }
            leaf_of[(firsts[mesh] + sh.mesh_triangle) as usize] = leaf as u32;
        }
        Self {
            direct,
            layout,
            previous,
            rays,
            leaf_of,
            mesh_triangle_of: bvh.shading.iter().map(|sh| sh.mesh_triangle).collect(),
            first_of_instance: bvh.instances.iter().map(|i| i.first_triangle).collect(),
        }
    }

    /// The previous level's irradiance at a CPU hit seen from its front or back.
    fn lookup(&self, hit: &CpuHit, front: bool) -> Vec3 {
        let Some(&first) = self.first_of_instance.get(hit.instance as usize) else {
            return Vec3::ZERO;
        };
        let leaf = self.leaf_of[(first + hit.triangle) as usize];
        match self
            .layout
            .side_of(hit.instance, first, leaf, hit.u, hit.v, front)
        {
            Some(side) if 3 * side + 2 < self.previous.len() => Vec3::new(
                self.previous[3 * side],
                self.previous[3 * side + 1],
                self.previous[3 * side + 2],
            ),
            _ => Vec3::ZERO,
        }
    }

    /// The surface of cell side `side`, as the gather builds it.
    pub fn side_surface(&self, side: u32) -> Surface {
        let c = self.layout.cells[(side / 2) as usize];
        let (u, v) = cell_centroid(c.cell, c.n);
        let hit = CpuHit {
            t: 0.0,
            instance: c.instance,
            triangle: self.mesh_triangle_of[c.triangle as usize],
            u,
            v,
            leaf: 0,
        };
        let back = self.direct.surface_at(&hit, Vec3::ZERO);
        if side & 1 == 0 {
            self.direct.surface_at(&hit, back.geometric_normal)
        } else {
            back
        }
    }

    /// The value of cell side `side` at this level: pi / K times the sum of its rays'
    /// radiance.
    pub fn side_value(&self, side: u32) -> Vec3 {
        let s = self.side_surface(side);
        let seed = side_seed(side);
        let basis = orthonormal_basis(s.shading_normal);
        let origin = offset_ray_origin(s.position, s.geometric_normal);
        let mut sum = Vec3::ZERO;
        for k in 0..self.rays {
            let dir = basis * cosine_hemisphere(sobol_2d(k, seed));
            if dir.dot(s.geometric_normal) <= 0.0 {
                continue;
            }
            let Some(hit) = self
                .direct
                .tracer
                .closest_hit(origin, dir, 0.0, f32::INFINITY)
            else {
                continue;
            };
            let h = self.direct.surface_at(&hit, dir);
            let e = self
                .direct
                .direct_irradiance(&h, hash_combine(seed, k))
                .min(Vec3::splat(self.layout.irradiance_bound))
                + self.lookup(&hit, h.front_face);
            sum += self.direct.albedo(&h) * (1.0 / PI) * e + self.direct.indirect_emission(&h);
        }
        sum * (PI / self.rays as f32)
    }
}
