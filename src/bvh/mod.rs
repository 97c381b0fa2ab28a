//! Two-level bounding volume hierarchy: one bottom-level BVH (BLAS) per mesh in object
//! space, and a top-level BVH (TLAS) over instances in world space, rebuilt whenever
//! instances move. Every hit is reported as (instance, mesh-local primitive, barycentrics),
//! which maps it to the same surface point in any later frame (`docs/architecture.md`).
//!
//! Both levels are built on the CPU with obvhs (PLOC + reinsertion, `medium_build` preset),
//! collapsed into 4-wide nodes with quantised child boxes ([`wide`]) and uploaded in the
//! [`gpu_layout`] formats that `wgsl/shared/bvh.wgsl` traverses.

pub mod cpu_trace;
pub mod gpu_layout;
pub mod trace_pass;
pub mod wide;

use crate::scene::{Mesh, Scene};
use glam::{Mat4, Vec3, Vec3A};
use gpu_layout::{GpuInstance, GpuNode, GpuTriangle, GpuTriangleShading};
use obvhs::{BvhBuildParams, aabb::Aabb, bvh2::Bvh2, triangle::Triangle};
use std::time::{Duration, Instant};

/// obvhs build presets, from fastest build to best traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum BvhPreset {
    Fastest,
    VeryFast,
    Fast,
    /// The default: PLOC (medium search distance) + reinsertion, leaves of up to 8
    /// triangles; obvhs's "embree-like build time, faster traversal" setting. See
    /// `docs/architecture.md` for the measurements behind the choice.
    #[default]
    Medium,
}

impl BvhPreset {
    pub fn params(self) -> BvhBuildParams {
        match self {
            BvhPreset::Fastest => BvhBuildParams::fastest_build(),
            BvhPreset::VeryFast => BvhBuildParams::very_fast_build(),
            BvhPreset::Fast => BvhBuildParams::fast_build(),
            BvhPreset::Medium => BvhBuildParams::medium_build(),
        }
    }
}

/// BVH build parameters for meshes (the default preset).
pub fn blas_params() -> BvhBuildParams {
    BvhPreset::default().params()
}

/// TLAS preset: one instance per leaf so a TLAS leaf names its instance directly.
pub fn tlas_params() -> BvhBuildParams {
    BvhBuildParams {
        max_prims_per_leaf: 1,
        ..BvhBuildParams::medium_build()
    }
}

/// The bottom-level BVH of one mesh, with its triangles in leaf order.
pub struct Blas {
    /// Nodes in obvhs order (root at 0), child/primitive indices local to this BLAS.
    pub bvh: Bvh2,
    /// Object-space triangles in BVH leaf order.
    pub triangles: Vec<Triangle>,
    /// For each triangle in leaf order, its index in the mesh.
    pub mesh_triangle: Vec<u32>,
}

impl Blas {
    /// Builds the BLAS of a mesh.
    pub fn build(mesh: &Mesh, preset: BvhPreset) -> Blas {
        Self::build_params(mesh, preset.params())
    }

    /// Builds the BLAS of a mesh with explicit obvhs parameters.
    pub fn build_params(mesh: &Mesh, params: BvhBuildParams) -> Blas {
        let tris: Vec<Triangle> = mesh
            .indices
            .iter()
            .map(|t| Triangle {
                v0: mesh.positions[t[0] as usize].into(),
                v1: mesh.positions[t[1] as usize].into(),
                v2: mesh.positions[t[2] as usize].into(),
            })
            .collect();
        let mut core = Duration::ZERO;
        let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, params, &mut core);
        let mesh_triangle = bvh.primitive_indices.clone();
        let triangles = mesh_triangle.iter().map(|&i| tris[i as usize]).collect();
        Blas {
            bvh,
            triangles,
            mesh_triangle,
        }
    }
}

/// Timings of one BVH build, in milliseconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct BuildTimes {
    pub blas_ms: f64,
    pub tlas_ms: f64,
}

/// The whole scene's acceleration structure, in GPU layout (ready for upload).
pub struct SceneBvh {
    /// TLAS nodes (4-wide, root first); inner children's indices point into
    /// [`SceneBvh::gpu_nodes`], i.e. are offset by `blas_nodes.len()`. Leaf entries hold
    /// one instance id each.
    pub tlas_nodes: Vec<GpuNode>,
    /// Every mesh's BLAS nodes (4-wide, each BLAS root first), indices absolute in this
    /// array.
    pub blas_nodes: Vec<GpuNode>,
    pub triangles: Vec<GpuTriangle>,
    pub shading: Vec<GpuTriangleShading>,
    pub instances: Vec<GpuInstance>,
    /// Per mesh: first node of its BLAS in `blas_nodes`, first triangle in `triangles`.
    pub mesh_offsets: Vec<(u32, u32)>,
    pub times: BuildTimes,
    /// Traversal stack entries needed at most: the worst BLAS plus the TLAS (each level
    /// of a path pushes up to three children; see [`wide::stack_need`]).
    pub max_depth: u32,
}

impl SceneBvh {
    /// Builds every mesh's BLAS (default preset) and the TLAS for the scene's current
    /// instance transforms.
    pub fn build(scene: &Scene) -> SceneBvh {
        Self::build_with(scene, BvhPreset::default())
    }

    /// As [`SceneBvh::build`] with a chosen BLAS preset.
    pub fn build_with(scene: &Scene, preset: BvhPreset) -> SceneBvh {
        let t0 = Instant::now();
        let blases: Vec<Blas> = scene
            .meshes
            .iter()
            .map(|m| Blas::build(m, preset))
            .collect();
        let blas_ms = t0.elapsed().as_secs_f64() * 1e3;

        let mut blas_nodes = Vec::new();
        let mut triangles = Vec::new();
        let mut shading = Vec::new();
        let mut mesh_offsets = Vec::new();
        let mut max_depth = 0u32;
        for (mesh, blas) in scene.meshes.iter().zip(&blases) {
            let node_base = blas_nodes.len() as u32;
            let tri_base = triangles.len() as u32;
            mesh_offsets.push((node_base, tri_base));
            let wide = wide::collapse(&blas.bvh, 4, &|first, count| (first + tri_base, count));
            max_depth = max_depth.max(wide::stack_need(&wide));
            blas_nodes.extend(wide.iter().map(|n| GpuNode::new(n, node_base)));
            for (tri, &mesh_tri) in blas.triangles.iter().zip(&blas.mesh_triangle) {
                triangles.push(GpuTriangle::new(tri));
                shading.push(GpuTriangleShading::new(mesh, mesh_tri));
            }
        }

        let t1 = Instant::now();
        let (tlas_nodes, tlas_stack) = build_tlas(scene, blas_nodes.len() as u32);
        let tlas_ms = t1.elapsed().as_secs_f64() * 1e3;
        let instances = scene
            .instances
            .iter()
            .map(|inst| {
                let (node_base, tri_base) = mesh_offsets[inst.mesh as usize];
                GpuInstance::new(inst.transform, node_base, tri_base, inst.mesh)
            })
            .collect();
        SceneBvh {
            tlas_nodes,
            blas_nodes,
            triangles,
            shading,
            instances,
            mesh_offsets,
            times: BuildTimes { blas_ms, tlas_ms },
            max_depth: max_depth + tlas_stack,
        }
    }

    /// The node array the GPU traverses: every BLAS, then the TLAS (root at
    /// [`SceneBvh::tlas_root`]). One array means traversal loads never branch on the level,
    /// and a TLAS rebuild only rewrites the tail.
    pub fn gpu_nodes(&self) -> Vec<GpuNode> {
        let mut nodes = Vec::with_capacity(self.blas_nodes.len() + self.tlas_nodes.len());
        nodes.extend_from_slice(&self.blas_nodes);
        nodes.extend_from_slice(&self.tlas_nodes);
        nodes
    }

    /// Index of the TLAS root in [`SceneBvh::gpu_nodes`].
    pub fn tlas_root(&self) -> u32 {
        self.blas_nodes.len() as u32
    }
}

/// World-space bounds of every instance.
pub fn instance_bounds(scene: &Scene) -> Vec<Aabb> {
    scene
        .instances
        .iter()
        .map(|inst| {
            let mesh = &scene.meshes[inst.mesh as usize];
            let mut aabb = Aabb::empty();
            for p in &mesh.positions {
                aabb.extend(Vec3A::from(inst.transform.transform_point3(*p)));
            }
            aabb
        })
        .collect()
}

/// Builds the TLAS over instance bounds; leaves hold exactly one instance. Inner nodes'
/// child indices are offset by `node_base`, where the TLAS starts in the GPU node array.
/// Also returns the TLAS's stack need.
fn build_tlas(scene: &Scene, node_base: u32) -> (Vec<GpuNode>, u32) {
    let bounds = instance_bounds(scene);
    let mut core = Duration::ZERO;
    let bvh = obvhs::bvh2::builder::build_bvh2(&bounds, tlas_params(), &mut core);
    // One instance per leaf (tlas_params): a leaf entry names the instance itself.
    let wide = wide::collapse(&bvh, 4, &|first, _| {
        (bvh.primitive_indices[first as usize], 1)
    });
    let nodes = wide.iter().map(|n| GpuNode::new(n, node_base)).collect();
    (nodes, wide::stack_need(&wide))
}

/// Object-space transform helpers shared by the CPU reference and the GPU layout.
pub fn normal_matrix(transform: Mat4) -> glam::Mat3 {
    glam::Mat3::from_mat4(transform).inverse().transpose()
}

/// Scene bounds over all instances (for ray offsets and camera sanity checks).
pub fn scene_bounds(scene: &Scene) -> (Vec3, Vec3) {
    let mut aabb = Aabb::empty();
    for b in instance_bounds(scene) {
        aabb = aabb.union(&b);
    }
    (aabb.min.into(), aabb.max.into())
}

/// Actual depth of a BVH (obvhs's `max_depth` field is a stack-size hint, not the depth).
pub fn tree_depth(bvh: &Bvh2) -> u32 {
    if bvh.nodes.is_empty() {
        0
    } else {
        bvh.depth(0) as u32
    }
}
