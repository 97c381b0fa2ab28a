//! Plain-Rust mirrors of the structs in `wgsl/shared/bvh.wgsl` and `wgsl/shared/scene.wgsl`.
//! Field order and padding match WGSL's std430 layout; sizes are checked by tests.

use crate::scene::Mesh;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use obvhs::{bvh2::node::Bvh2Node, triangle::Triangle};

/// Most primitives a leaf may hold: the traversal packs `count - 1` into 4 bits of a stack
/// entry (`wgsl/shared/bvh.wgsl`).
pub const MAX_LEAF_PRIMS: u32 = 16;

/// A BVH node, 32 bytes: bounds plus two words (WGSL reads it as two vec4s).
/// Inner node: `count == 0`, children at `index` and `index + 1` (siblings are always
/// adjacent: the traversal tests a pair of siblings per step).
/// Leaf: `count > 0` primitives starting at `index` (BLAS: triangles; TLAS: the instance id).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuNode {
    pub min: [f32; 3],
    pub index: u32,
    pub max: [f32; 3],
    pub count: u32,
}

impl GpuNode {
    /// Converts an obvhs node, adding the BLAS's base offsets so indices are absolute.
    pub fn from_obvhs(n: &Bvh2Node, node_base: u32, tri_base: u32) -> Self {
        assert!(
            n.prim_count <= MAX_LEAF_PRIMS,
            "BVH leaf of {} primitives exceeds {MAX_LEAF_PRIMS}",
            n.prim_count
        );
        let index = if n.prim_count > 0 {
            n.first_index + tri_base
        } else {
            n.first_index + node_base
        };
        GpuNode {
            min: n.aabb.min.into(),
            index,
            max: n.aabb.max.into(),
            count: n.prim_count,
        }
    }

    /// A leaf node.
    pub fn leaf(min: Vec3, max: Vec3, index: u32, count: u32) -> Self {
        GpuNode {
            min: min.into(),
            index,
            max: max.into(),
            count,
        }
    }
}

/// Triangle for intersection: `v0` and the two edges, 48 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 4],
    pub e1: [f32; 4],
    pub e2: [f32; 4],
}

impl GpuTriangle {
    pub fn new(t: &Triangle) -> Self {
        let (v0, v1, v2) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
        GpuTriangle {
            v0: v0.extend(0.0).into(),
            e1: (v1 - v0).extend(0.0).into(),
            e2: (v2 - v0).extend(0.0).into(),
        }
    }
}

/// Per-triangle shading data in the same (leaf) order as [`GpuTriangle`], 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuTriangleShading {
    /// Vertex normals (object space; zero = unusable, use the geometric normal); `.w` unused.
    pub n0: [f32; 3],
    /// Material index.
    pub material: u32,
    pub n1: [f32; 3],
    /// Index of the triangle in its mesh (what hits report).
    pub mesh_triangle: u32,
    pub n2: [f32; 3],
    pub _pad: u32,
    /// uv0.xy, uv1.xy
    pub uv01: [f32; 4],
    /// uv2.xy, unused
    pub uv2: [f32; 4],
}

impl GpuTriangleShading {
    pub fn new(mesh: &Mesh, tri: u32) -> Self {
        let idx = mesh.indices[tri as usize];
        let n = |k: usize| {
            mesh.normals
                .get(idx[k] as usize)
                .copied()
                .unwrap_or(Vec3::ZERO)
                .into()
        };
        let uv = |k: usize| mesh.uvs.get(idx[k] as usize).copied().unwrap_or_default();
        let (uv0, uv1, uv2) = (uv(0), uv(1), uv(2));
        GpuTriangleShading {
            n0: n(0),
            material: mesh.material_ids[tri as usize],
            n1: n(1),
            mesh_triangle: tri,
            n2: n(2),
            _pad: 0,
            uv01: [uv0.x, uv0.y, uv1.x, uv1.y],
            uv2: [uv2.x, uv2.y, 0.0, 0.0],
        }
    }
}

/// One instance, 160 bytes: affine transforms as three rows each.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuInstance {
    /// Rows of the object-to-world matrix (3x4).
    pub world_from_object: [[f32; 4]; 3],
    /// Rows of the world-to-object matrix (3x4).
    pub object_from_world: [[f32; 4]; 3],
    /// Rows of the normal matrix (inverse transpose of the linear part), `.w` unused.
    pub normal_to_world: [[f32; 4]; 3],
    /// First node of the mesh's BLAS.
    pub blas_root: u32,
    /// First triangle of the mesh.
    pub first_triangle: u32,
    pub mesh: u32,
    pub _pad: u32,
}

fn rows(m: Mat4) -> [[f32; 4]; 3] {
    let t = m.transpose();
    [t.x_axis.into(), t.y_axis.into(), t.z_axis.into()]
}

impl GpuInstance {
    pub fn new(transform: Mat4, blas_root: u32, first_triangle: u32, mesh: u32) -> Self {
        let n = Mat4::from_mat3(super::normal_matrix(transform));
        GpuInstance {
            world_from_object: rows(transform),
            object_from_world: rows(transform.inverse()),
            normal_to_world: rows(n),
            blas_root,
            first_triangle,
            mesh,
            _pad: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn sizes_match_wgsl() {
        assert_eq!(std::mem::size_of::<GpuNode>(), 32);
        assert_eq!(std::mem::size_of::<GpuTriangle>(), 48);
        assert_eq!(std::mem::size_of::<GpuTriangleShading>(), 80);
        assert_eq!(std::mem::size_of::<GpuInstance>(), 160);
    }
}
