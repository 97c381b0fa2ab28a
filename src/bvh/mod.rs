//! Two-level bounding volume hierarchy: one bottom-level BVH (BLAS) per mesh in object
//! space, and a top-level BVH (TLAS) over instances in world space, rebuilt whenever
//! instances move. Every hit is reported as (instance, mesh-local primitive, barycentrics),
//! which maps it to the same surface point in any later frame (`docs/architecture.md`).
//!
//! Both levels are built on the CPU, collapsed into 4-wide nodes with quantised child boxes
//! ([`wide`]) and uploaded in the [`gpu_layout`] formats that `wgsl/shared/bvh.wgsl`
//! traverses.
//!
//! **Builder choice** ([`build_robust`]). Ordinary inputs are built with obvhs (PLOC +
//! reinsertion, `medium_build` preset), whose trees traverse well. PLOC is quadratic in
//! time and builds chain-like trees on fans (disc caps, sphere poles), coincident copies
//! and nested boxes, so those inputs (found by the O(n) test [`bounded::degenerate`]) and
//! every obvhs tree whose traversal stack need exceeds its level's budget
//! ([`BLAS_STACK_BUDGET`], [`TLAS_STACK_BUDGET`]) are built by [`bounded`] instead: binned
//! SAH in O(n log n) with a height bound that keeps the stack need within the budget for
//! any input the GPU encoding accepts (< 2^27 triangles and instances). The two budgets
//! together fit the shader's stack ([`TRAVERSAL_STACK`]), so no scene is rejected for its
//! depth. See `docs/bvh-performance.md` ("Degenerate inputs").

pub mod bounded;
pub mod cpu_trace;
pub mod gpu_layout;
pub mod trace_pass;
pub mod wide;

use crate::scene::{Mesh, Scene};
use bounded::Degenerate;
use glam::{Vec3, Vec3A};
use gpu_layout::{GpuInstance, GpuNode, GpuTriangle, GpuTriangleShading};
use obvhs::{BvhBuildParams, aabb::Aabb, bvh2::Bvh2, triangle::Triangle};
use std::time::{Duration, Instant};
use wide::Open;

/// Entries of the GPU traversal stack (`BVH_STACK_SIZE` in `wgsl/shared/bvh.wgsl`).
///
/// 96 rather than a smaller power of two because no 4-wide tree over the largest inputs
/// the encoding accepts fits in less: 2^27 triangles in leaves of 8 need 12 wide levels
/// even perfectly balanced, 2^27 instances one per leaf 14, and each level pushes up to 3
/// entries (78 in all, at most 45 + 48 = 93 with the height slack of [`bounded`]).
pub const TRAVERSAL_STACK: u32 = 96;
/// Stack entries a BLAS may need. An obvhs BLAS above it is rebuilt with [`bounded`],
/// which stays within it for any mesh of fewer than 2^27 triangles.
pub const BLAS_STACK_BUDGET: u32 = 45;
/// Stack entries the TLAS may need (same rule, fewer than 2^27 instances).
pub const TLAS_STACK_BUDGET: u32 = 48;
const _: () = assert!(BLAS_STACK_BUDGET + TLAS_STACK_BUDGET < TRAVERSAL_STACK);

/// Which builder made a BVH, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Builder {
    /// obvhs (PLOC), the default.
    Obvhs,
    /// [`bounded`], because the input is degenerate for PLOC.
    Degenerate(Degenerate),
    /// [`bounded`], because obvhs's tree needed this many stack entries, above the budget
    /// (at least this many when it was too tall to collapse).
    TooDeep(u32),
}

impl Builder {
    /// How trees of this builder are collapsed to 4-wide nodes: obvhs's as before (the
    /// GPU bytes of ordinary scenes do not change), ours height first (which is what
    /// bounds their stack need).
    pub fn open(self) -> Open {
        match self {
            Builder::Obvhs => Open::LargestArea,
            _ => Open::Tallest,
        }
    }
}

/// A BVH2, the builder that made it and its 4-wide tree's stack need.
pub struct Built {
    pub bvh: Bvh2,
    pub builder: Builder,
    pub stack_need: u32,
}

/// Builds a BVH2 over `boxes` with obvhs (`obvhs`, which must build over the same
/// primitives in the same order), unless the input is degenerate for PLOC or obvhs's tree
/// needs more than `budget` stack entries: then with [`bounded`] (leaves of at most
/// `max_leaf`). `corners` (triangles only) feed the fan test.
pub fn build_robust(
    boxes: &[Aabb],
    corners: Option<&[[Vec3A; 3]]>,
    max_leaf: u32,
    budget: u32,
    obvhs: impl FnOnce() -> Bvh2,
) -> Built {
    let ours = |builder| {
        let height = bounded::height_bound(boxes.len(), max_leaf, budget);
        let bvh = bounded::build(boxes, max_leaf, height);
        let stack_need = wide::stack_need(&wide::collapse(&bvh, 4, Open::Tallest, &|f, c| (f, c)));
        Built {
            bvh,
            builder,
            stack_need,
        }
    };
    if let Some(d) = bounded::degenerate(boxes, corners) {
        return ours(Builder::Degenerate(d));
    }
    let bvh = obvhs();
    // A wide level spans at most three BVH2 levels and pushes at least one entry, so a
    // taller tree is over budget; not collapsing it also keeps the recursion shallow.
    let height = bounded::node_heights(&bvh).first().copied().unwrap_or(0);
    if height > 3 * budget {
        return ours(Builder::TooDeep(height / 3));
    }
    let stack_need = wide::stack_need(&wide::collapse(&bvh, 4, Open::LargestArea, &|f, c| (f, c)));
    if stack_need > budget {
        return ours(Builder::TooDeep(stack_need));
    }
    Built {
        bvh,
        builder: Builder::Obvhs,
        stack_need,
    }
}

/// [`build_robust`] over triangles: obvhs's triangle builder with `params`, ours with
/// `params`' leaf size (at most 8, the GPU leaf encoding holds 16), within `budget`.
pub fn build_triangles(tris: &[Triangle], params: BvhBuildParams, budget: u32) -> Built {
    let boxes: Vec<Aabb> = tris.iter().map(|t| t.aabb()).collect();
    let corners: Vec<[Vec3A; 3]> = tris.iter().map(|t| [t.v0, t.v1, t.v2]).collect();
    let max_leaf = params.max_prims_per_leaf.clamp(1, 8);
    build_robust(&boxes, Some(&corners), max_leaf, budget, || {
        let mut core = Duration::ZERO;
        obvhs::bvh2::builder::build_bvh2_from_tris(tris, params, &mut core)
    })
}

/// obvhs build presets, from fastest build to best traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum BvhPreset {
    Fastest,
    VeryFast,
    Fast,
    /// The default: PLOC (medium search distance) + reinsertion, leaves of up to 8
    /// triangles; obvhs's "embree-like build time, faster traversal" setting. See
    /// `docs/architecture.md` for the measurements behind the choice. Every preset's leaf
    /// collapse weighs nodes against triangles by [`COLLAPSE_TRAVERSAL_COST`].
    #[default]
    Medium,
}

/// What visiting a BVH node costs against testing a triangle, in the SAH that obvhs's leaf
/// collapse weighs (`collapse_traversal_cost`; its presets say 3.0). A triangle test here
/// reads three storage vectors, each a loop over the SIMD lanes on lavapipe, while a node's
/// four boxes are texel gathers (`docs/bvh-performance.md`): so the triangles cost more
/// than the presets assume, and smaller leaves pay. Measured on lavapipe against 3.0
/// (docs/results.md, "Leaves sized for our traversal"): incoherent rays 0.94x on
/// nave-west, 0.85x on the Cornell box, 0.97x on Sponza 256x256 (1.0 made Sponza's
/// slower again); nave-west 0.966x the instructions of a whole render, the Cornell box
/// 0.93x the process wall time; the same bytes.
pub const COLLAPSE_TRAVERSAL_COST: f32 = 1.5;

impl BvhPreset {
    /// obvhs's preset, with the leaf collapse weighed for radsplat's traversal
    /// ([`COLLAPSE_TRAVERSAL_COST`]).
    pub fn params(self) -> BvhBuildParams {
        let preset = match self {
            BvhPreset::Fastest => BvhBuildParams::fastest_build(),
            BvhPreset::VeryFast => BvhBuildParams::very_fast_build(),
            BvhPreset::Fast => BvhBuildParams::fast_build(),
            BvhPreset::Medium => BvhBuildParams::medium_build(),
        };
        BvhBuildParams {
            collapse_traversal_cost: COLLAPSE_TRAVERSAL_COST,
            ..preset
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
    /// Which builder made `bvh` (and so how it is collapsed).
    pub builder: Builder,
    /// Traversal stack entries of its 4-wide tree, at most [`BLAS_STACK_BUDGET`] for
    /// meshes of fewer than 2^27 triangles.
    pub stack_need: u32,
}

impl Blas {
    /// Builds the BLAS of a mesh.
    pub fn build(mesh: &Mesh, preset: BvhPreset) -> Blas {
        Self::build_params(mesh, preset.params())
    }

    /// Builds the BLAS of a mesh with explicit obvhs parameters (used when obvhs builds
    /// it, see [`build_robust`]).
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
        let built = build_triangles(&tris, params, BLAS_STACK_BUDGET);
        let bvh = built.bvh;
        let mesh_triangle = bvh.primitive_indices.clone();
        let triangles = mesh_triangle.iter().map(|&i| tris[i as usize]).collect();
        if built.builder != Builder::Obvhs {
            log::debug!(
                "mesh '{}' ({} triangles): BVH built by radsplat's bounded builder ({:?}), \
                 stack need {}",
                mesh.name,
                tris.len(),
                built.builder,
                built.stack_need
            );
        }
        Blas {
            bvh,
            triangles,
            mesh_triangle,
            builder: built.builder,
            stack_need: built.stack_need,
        }
    }
}

/// Timings of one BVH build, in milliseconds. After [`SceneBvh::update_instances`] or
/// [`SceneBvh::refit_instances`], `blas_ms` is 0 (no BLAS was built) and `tlas_ms` is the
/// update's time.
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
    /// of a path pushes up to three children; see [`wide::stack_need`]). At most
    /// `BLAS_STACK_BUDGET + TLAS_STACK_BUDGET`, below [`TRAVERSAL_STACK`], for any scene
    /// the GPU encoding accepts.
    pub max_depth: u32,
    /// The mesh whose BLAS needs the most stack entries (`None` without meshes), and
    /// that need, for the device-limit message.
    pub deepest_blas: Option<(u32, u32)>,
    /// Per mesh, the builder of its BLAS.
    pub blas_builders: Vec<Builder>,
    /// The builder of the TLAS.
    pub tlas_builder: Builder,
    /// Stack need of the worst BLAS alone, so that `max_depth` can be recomputed when only
    /// the TLAS changes.
    blas_stack_need: u32,
    /// The TLAS before collapsing, kept for [`SceneBvh::refit_instances`].
    tlas_bvh: Bvh2,
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
        let mut deepest_blas = None;
        for (mi, (mesh, blas)) in scene.meshes.iter().zip(&blases).enumerate() {
            let node_base = blas_nodes.len() as u32;
            let tri_base = triangles.len() as u32;
            mesh_offsets.push((node_base, tri_base));
            let wide = wide::collapse(&blas.bvh, 4, blas.builder.open(), &|first, count| {
                (first + tri_base, count)
            });
            let need = wide::stack_need(&wide);
            if deepest_blas.is_none_or(|(_, worst)| need > worst) {
                deepest_blas = Some((mi as u32, need));
            }
            max_depth = max_depth.max(need);
            blas_nodes.extend(wide.iter().map(|n| GpuNode::new(n, node_base)));
            for (tri, &mesh_tri) in blas.triangles.iter().zip(&blas.mesh_triangle) {
                triangles.push(GpuTriangle::new(tri));
                shading.push(GpuTriangleShading::new(mesh, mesh_tri));
            }
        }

        let mut bvh = SceneBvh {
            tlas_nodes: Vec::new(),
            blas_nodes,
            triangles,
            shading,
            instances: Vec::new(),
            mesh_offsets,
            times: BuildTimes::default(),
            max_depth,
            deepest_blas,
            blas_builders: blases.iter().map(|b| b.builder).collect(),
            tlas_builder: Builder::Obvhs,
            blas_stack_need: max_depth,
            tlas_bvh: Bvh2::default(),
        };
        bvh.update_instances(scene);
        bvh.times.blas_ms = blas_ms;
        bvh
    }

    /// Rebuilds the TLAS and the instance table for the scene's current instance
    /// transforms, reusing the BLASes: for a scene whose meshes are those this was built
    /// from (only transforms changed, e.g. after [`Scene::set_frame`]), the result equals
    /// a fresh [`SceneBvh::build`] of it, node for node.
    ///
    /// # Panics
    /// If the scene has a different number of meshes than the one this was built from.
    pub fn update_instances(&mut self, scene: &Scene) {
        self.check_meshes(scene);
        let t0 = Instant::now();
        let built = build_tlas(&instance_bounds(scene));
        self.tlas_bvh = built.bvh;
        self.tlas_builder = built.builder;
        self.encode_instances(scene);
        self.times = BuildTimes {
            blas_ms: 0.0,
            tlas_ms: t0.elapsed().as_secs_f64() * 1e3,
        };
    }

    /// Like [`SceneBvh::update_instances`], but keeps the TLAS's tree and only recomputes
    /// its boxes for the new transforms: faster, but the tree degrades as instances move
    /// away from where it was built, so rebuild now and then (or when traversal slows).
    ///
    /// # Panics
    /// If the scene has a different number of meshes or instances than the one this was
    /// built from.
    pub fn refit_instances(&mut self, scene: &Scene) {
        self.check_meshes(scene);
        assert_eq!(
            scene.instances.len(),
            self.instances.len(),
            "a TLAS refit needs the instances it was built for"
        );
        let t0 = Instant::now();
        let bounds = instance_bounds(scene);
        let bvh = &mut self.tlas_bvh;
        for node in &mut bvh.nodes {
            if node.is_leaf() {
                let first = node.first_index as usize;
                let mut aabb = Aabb::empty();
                for &prim in &bvh.primitive_indices[first..first + node.prim_count as usize] {
                    aabb = aabb.union(&bounds[prim as usize]);
                }
                node.set_aabb(aabb);
            }
        }
        bvh.refit_all();
        self.encode_instances(scene);
        self.times = BuildTimes {
            blas_ms: 0.0,
            tlas_ms: t0.elapsed().as_secs_f64() * 1e3,
        };
    }

    fn check_meshes(&self, scene: &Scene) {
        assert_eq!(
            scene.meshes.len(),
            self.mesh_offsets.len(),
            "a TLAS update needs the meshes the BLASes were built from"
        );
    }

    /// Collapses and encodes `tlas_bvh`, and writes the instance table and `max_depth`.
    fn encode_instances(&mut self, scene: &Scene) {
        let node_base = self.blas_nodes.len() as u32;
        let bvh = &self.tlas_bvh;
        // One instance per leaf (tlas_params): a leaf entry names the instance itself.
        let wide = wide::collapse(bvh, 4, self.tlas_builder.open(), &|first, _| {
            (bvh.primitive_indices[first as usize], 1)
        });
        self.tlas_nodes = wide.iter().map(|n| GpuNode::new(n, node_base)).collect();
        self.max_depth = self.blas_stack_need + wide::stack_need(&wide);
        self.instances = scene
            .instances
            .iter()
            .map(|inst| {
                let (node_base, tri_base) = self.mesh_offsets[inst.mesh as usize];
                GpuInstance::new(inst.transform, node_base, tri_base, inst.mesh)
            })
            .collect();
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

    /// World-space bounds of every instance: the TLAS root's box, the union of the
    /// instance boxes ([`scene_bounds`] without another pass over the vertices).
    pub fn world_bounds(&self) -> (Vec3, Vec3) {
        match self.tlas_bvh.nodes.first() {
            Some(root) => (root.aabb().min.into(), root.aabb().max.into()),
            None => (Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// Index of the TLAS root in [`SceneBvh::gpu_nodes`].
    pub fn tlas_root(&self) -> u32 {
        self.blas_nodes.len() as u32
    }

    /// Where a GPU ray's traversal starts (`scene_info.tlas_root` and
    /// `scene_info.root_in_blas` in `wgsl/shared/bvh.wgsl`). A one-instance TLAS is a root
    /// with one leaf: visiting it cost every ray a node's four texel loads and its box
    /// test, and entering the instance the loads of its transform (lavapipe loops over the
    /// lanes for each), for nothing. So with a single instance rays start at its TLAS leaf,
    /// and where its transform is the identity in the BLAS itself, in world space;
    /// otherwise at the TLAS root. The same bytes; on lavapipe the nave's plane rays take
    /// about 8 % less time, Sponza's and the conference room's the same within noise, the
    /// Cornell box's about 4 % more (docs/results.md, "A one-instance scene's rays start in
    /// its BLAS").
    pub fn traversal_start(&self) -> TraversalStart {
        match self.instances.as_slice() {
            [only] if only.object_from_world == IDENTITY_ROWS => TraversalStart {
                entry: only.blas_root,
                in_blas: true,
            },
            [_] => TraversalStart {
                entry: wide::entry(&wide::Child::Leaf { first: 0, count: 1 }, 0),
                in_blas: false,
            },
            _ => TraversalStart {
                entry: self.tlas_root(),
                in_blas: false,
            },
        }
    }
}

/// The rows of a 3x4 identity matrix ([`GpuInstance::object_from_world`]).
pub const IDENTITY_ROWS: [[f32; 4]; 3] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
];

/// Where traversal starts ([`SceneBvh::traversal_start`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraversalStart {
    /// The first traversal entry: a node index or a leaf (`wide::entry`).
    pub entry: u32,
    /// The entry is in instance 0's BLAS, whose object space is world space.
    pub in_blas: bool,
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

/// Builds the TLAS (BVH2) over instance bounds; leaves hold exactly one instance.
fn build_tlas(bounds: &[Aabb]) -> Built {
    build_robust(bounds, None, 1, TLAS_STACK_BUDGET, || {
        let mut core = Duration::ZERO;
        obvhs::bvh2::builder::build_bvh2(bounds, tlas_params(), &mut core)
    })
}

pub use crate::scene::normal_matrix;

/// Scene bounds over all instances (for ray offsets and camera sanity checks).
pub fn scene_bounds(scene: &Scene) -> (Vec3, Vec3) {
    let mut aabb = Aabb::empty();
    for b in instance_bounds(scene) {
        aabb = aabb.union(&b);
    }
    (aabb.min.into(), aabb.max.into())
}

/// Actual depth of a BVH in nodes (a lone leaf has depth 1; obvhs's `max_depth` field is
/// a stack-size hint, not the depth). Iterative, so chain-like trees cannot overflow the
/// call stack.
pub fn tree_depth(bvh: &Bvh2) -> u32 {
    bounded::node_heights(bvh).first().map_or(0, |h| h + 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::bundled;
    use glam::Mat4;

    fn bytes<T: bytemuck::Pod>(v: &[T]) -> &[u8] {
        bytemuck::cast_slice(v)
    }

    /// Everything the GPU gets from a SceneBvh, compared byte for byte.
    fn assert_same(a: &SceneBvh, b: &SceneBvh) {
        assert_eq!(bytes(&a.gpu_nodes()), bytes(&b.gpu_nodes()), "nodes");
        assert_eq!(a.tlas_root(), b.tlas_root(), "TLAS root");
        assert_eq!(bytes(&a.instances), bytes(&b.instances), "instances");
        assert_eq!(bytes(&a.triangles), bytes(&b.triangles), "triangles");
        assert_eq!(bytes(&a.shading), bytes(&b.shading), "shading");
        assert_eq!(a.mesh_offsets, b.mesh_offsets, "mesh offsets");
        assert_eq!(a.max_depth, b.max_depth, "stack need");
    }

    /// The cube-in-box scene with its room and cube (instances 0 and 1) moved.
    fn moved_cube_in_box() -> (Scene, Scene) {
        let scene = bundled("cube-in-box.toml");
        let mut moved = scene.clone();
        moved.instances[0].transform =
            Mat4::from_translation(Vec3::new(0.5, -1.0, 2.0)) * moved.instances[0].transform;
        moved.instances[1].transform = Mat4::from_translation(Vec3::new(-1.0, 0.5, 0.7))
            * Mat4::from_rotation_y(1.0)
            * Mat4::from_scale(Vec3::splat(1.5));
        (scene, moved)
    }

    #[test]
    fn instance_update_equals_fresh_build() {
        let (scene, moved) = moved_cube_in_box();
        let mut bvh = SceneBvh::build(&scene);
        bvh.update_instances(&moved);
        assert_same(&bvh, &SceneBvh::build(&moved));
        // And back: nothing of the moved state is left over.
        bvh.update_instances(&scene);
        assert_same(&bvh, &SceneBvh::build(&scene));
    }

    /// A one-instance scene's rays start at the TLAS root's only entry, its leaf (so they
    /// enter the instance's BLAS at once); with several instances at the TLAS root.
    #[test]
    fn traversal_starts_in_the_blas_of_a_single_instance() {
        let mut scene = bundled("nave.toml");
        let one = SceneBvh::build(&scene);
        assert_eq!(one.instances.len(), 1);
        // An identity transform: the BLAS root, in world space.
        assert_eq!(
            one.traversal_start(),
            TraversalStart {
                entry: one.instances[0].blas_root,
                in_blas: true
            }
        );
        // Moved: the TLAS root's only entry, its leaf.
        scene.instances[0].transform = Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let moved = SceneBvh::build(&scene);
        let root = moved.tlas_nodes[0];
        let entries: Vec<u32> = (12..16)
            .map(|w| root.words[w])
            .filter(|&e| e != wide::EMPTY)
            .collect();
        let start = moved.traversal_start();
        assert_eq!(entries, vec![start.entry]);
        assert!(!start.in_blas && start.entry & wide::LEAF_BIT != 0);
        let two = SceneBvh::build(&bundled("cube-in-box.toml"));
        assert!(two.instances.len() > 1);
        assert_eq!(
            two.traversal_start(),
            TraversalStart {
                entry: two.tlas_root(),
                in_blas: false
            }
        );
    }

    #[test]
    fn refit_without_motion_equals_fresh_build() {
        let scene = bundled("cube-in-box.toml");
        let mut bvh = SceneBvh::build(&scene);
        bvh.refit_instances(&scene);
        assert_same(&bvh, &SceneBvh::build(&scene));
    }

    /// A refitted TLAS bounds the moved instances and writes the same instance table.
    #[test]
    fn refit_after_motion_bounds_every_instance() {
        let (scene, moved) = moved_cube_in_box();
        let mut refit = SceneBvh::build(&scene);
        refit.refit_instances(&moved);
        let fresh = SceneBvh::build(&moved);
        assert_eq!(bytes(&refit.instances), bytes(&fresh.instances));
        // The root's children together bound every instance (the boxes were refitted).
        let root = refit.tlas_nodes[0];
        let (lo, hi) = (0..4)
            .filter(|&s| root.words[12 + s] != wide::EMPTY)
            .map(|s| root.child_bounds(s))
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (a, b)| {
                (lo.min(a), hi.max(b))
            });
        for b in instance_bounds(&moved) {
            assert!(Vec3::from(b.min).cmpge(lo).all() && Vec3::from(b.max).cmple(hi).all());
        }
    }

    /// The bundled scenes are ordinary: every BLAS, the TLAS and the CPU reference's
    /// flattened BVH stay obvhs's (so their GPU bytes and golden images do not change).
    #[test]
    fn bundled_scenes_keep_obvhs_trees() {
        let mut names = vec![
            "cornell-box.toml",
            "cornell-sphere.toml",
            "cube-in-box.toml",
            "cube-in-box-anim.toml",
            "moving-light.toml",
            "spheres.toml",
        ];
        // Sponza (a third-party asset) too where the shared scenes are installed.
        if std::env::var_os("RADSPLAT_ASSET_PATH").is_some_and(|v| !v.is_empty()) {
            names.push("sponza.toml");
        } else {
            eprintln!("RADSPLAT_ASSET_PATH is not set: sponza.toml not checked");
        }
        for name in names {
            let scene = bundled(name);
            let bvh = SceneBvh::build(&scene);
            assert!(
                bvh.blas_builders.iter().all(|&b| b == Builder::Obvhs),
                "{name}: {:?}",
                bvh.blas_builders
            );
            assert_eq!(bvh.tlas_builder, Builder::Obvhs, "{name}");
            let mut flat = Vec::new();
            for inst in &scene.instances {
                let mesh = &scene.meshes[inst.mesh as usize];
                for t in &mesh.indices {
                    let p = |k: usize| {
                        Vec3A::from(
                            inst.transform
                                .transform_point3(mesh.positions[t[k] as usize]),
                        )
                    };
                    flat.push(Triangle {
                        v0: p(0),
                        v1: p(1),
                        v2: p(2),
                    });
                }
            }
            let built = build_triangles(&flat, blas_params(), BLAS_STACK_BUDGET);
            assert_eq!(built.builder, Builder::Obvhs, "{name}: CPU reference");
            eprintln!(
                "{name}: stack need {} (worst BLAS {:?}), CPU reference {}",
                bvh.max_depth, bvh.deepest_blas, built.stack_need
            );
        }
    }

    /// An obvhs tree over budget is replaced by ours even when the input looks ordinary:
    /// here obvhs's builder is stood in for by a chain (one primitive per level).
    #[test]
    fn over_budget_tree_is_rebuilt_within_budget() {
        use obvhs::bvh2::node::Bvh2Node;
        let n = 300;
        let boxes: Vec<Aabb> = (0..n)
            .map(|i| Aabb {
                min: Vec3A::new(2.0 * i as f32, 0.0, 0.0),
                max: Vec3A::new(2.0 * i as f32 + 1.0, 1.0, 1.0),
            })
            .collect();
        assert_eq!(bounded::degenerate(&boxes, None), None, "an ordinary input");
        let chain = || {
            // Inner node k (at 2k, root 0) has leaf k at 2k+1 and the next inner at 2k+2.
            let mut nodes = vec![Bvh2Node::default(); 2 * n - 1];
            let mut below = boxes[n - 1];
            nodes[2 * n - 2] = Bvh2Node::new(boxes[n - 1], 1, (n - 1) as u32);
            for k in (0..n - 1).rev() {
                nodes[2 * k + 1] = Bvh2Node::new(boxes[k], 1, k as u32);
                below = below.union(&boxes[k]);
                nodes[2 * k] = Bvh2Node::new(below, 0, 2 * k as u32 + 1);
            }
            Bvh2 {
                nodes,
                primitive_indices: (0..n as u32).collect(),
                max_depth: 2 * n,
                ..Bvh2::default()
            }
        };
        let chain_need =
            wide::stack_need(&wide::collapse(&chain(), 4, Open::LargestArea, &|f, c| {
                (f, c)
            }));
        assert!(
            chain_need > TLAS_STACK_BUDGET,
            "the chain is over budget: {chain_need}"
        );
        let built = build_robust(&boxes, None, 1, TLAS_STACK_BUDGET, chain);
        assert!(
            matches!(built.builder, Builder::TooDeep(_)),
            "{:?}",
            built.builder
        );
        assert!(
            built.stack_need <= TLAS_STACK_BUDGET,
            "{}",
            built.stack_need
        );
        assert_eq!(built.bvh.primitive_indices.len(), n);
    }

    /// Frame-to-frame update costs on the 66 bouncing spheres: a full build, a TLAS
    /// rebuild and a TLAS refit per frame, in milliseconds (median over the frames).
    /// `cargo test --release --lib bvh::tests::tlas_update_timings -- --ignored --nocapture`
    #[test]
    #[ignore = "a measurement, not a check"]
    fn tlas_update_timings() {
        let mut scene = bundled("spheres.toml");
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let frames: Vec<u32> = scene.frames().collect();
        let (mut full, mut rebuild, mut refit) = (vec![], vec![], vec![]);
        let mut rebuilt = SceneBvh::build(&scene);
        let mut refitted = SceneBvh::build(&scene);
        for &frame in &frames {
            scene.set_frame(frame as f32);
            let t = Instant::now();
            let fresh = SceneBvh::build(&scene);
            full.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            rebuilt.update_instances(&scene);
            rebuild.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            refitted.refit_instances(&scene);
            refit.push(t.elapsed().as_secs_f64() * 1e3);
            assert_eq!(bytes(&fresh.gpu_nodes()), bytes(&rebuilt.gpu_nodes()));
        }
        eprintln!(
            "{} instances, {} frames: full build {:.3} ms, TLAS rebuild {:.3} ms, \
             TLAS refit {:.3} ms (medians)",
            scene.instances.len(),
            frames.len(),
            median(full),
            median(rebuild),
            median(refit)
        );
    }
}
