//! Plain-Rust mirrors of the structs in `wgsl/shared/bvh.wgsl` and `wgsl/shared/scene.wgsl`.
//! Field order and padding match WGSL's std430 layout; sizes are checked by tests.

use super::wide::{self, Child, WideNode};
use crate::scene::Mesh;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec3A};
use obvhs::{aabb::Aabb, triangle::Triangle};

/// Most primitives a leaf may hold: the traversal packs `count - 1` into 4 bits of a
/// traversal entry (`wgsl/shared/bvh.wgsl`).
pub const MAX_LEAF_PRIMS: u32 = 16;

/// A 4-wide BVH node with quantised child boxes, 64 bytes: four `rgba32uint` texels of
/// the node texture, so one node costs four texel fetches (`wgsl/shared/bvh.wgsl`).
/// - words 0-2: the node's min corner (f32 bits), the origin of the quantisation grid;
///   word 3: biased exponents (bytes 0-2) of the x, y, z grid steps (powers of two);
/// - words 4-9: child boxes in grid steps, one byte per child (child `i` in byte `i`):
///   lo.x, hi.x, lo.y, hi.y, lo.z, hi.z. A plane is `origin + q * step`, rounded
///   outwards when built, so every dequantised box contains the exact one;
/// - words 10-11: unused;
/// - words 12-15: the children's traversal entries: a node index, or `LEAF_BIT |
///   first << 4 | (count - 1)` for a leaf (BLAS: triangles; TLAS: the instance), or
///   `EMPTY` for an unused slot.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuNode {
    pub words: [u32; 16],
}

impl GpuNode {
    /// Encodes a collapsed node; inner children's indices are offset by `node_base`.
    pub fn new(n: &WideNode, node_base: u32) -> Self {
        assert!(
            n.children.len() <= 4,
            "a GPU BVH node has at most 4 children"
        );
        let mut w = [0u32; 16];
        let mut node = Aabb::empty();
        for b in &n.bounds {
            node = node.union(b);
        }
        if n.bounds.is_empty() {
            node = Aabb {
                min: Vec3A::ZERO,
                max: Vec3A::ZERO,
            };
        }
        let mut step = [0f32; 3];
        for a in 0..3 {
            let (origin, eb) = wide::frame(node.min[a], node.max[a]);
            step[a] = f32::from_bits(eb << 23);
            w[a] = origin.to_bits();
            w[3] |= eb << (8 * a);
        }
        for s in 0..4 {
            match (n.bounds.get(s), n.children.get(s)) {
                (Some(b), Some(c)) => {
                    if let Child::Leaf { count, .. } = c {
                        assert!(
                            (1..=MAX_LEAF_PRIMS).contains(count),
                            "BVH leaf of {count} primitives exceeds {MAX_LEAF_PRIMS}"
                        );
                    }
                    for a in 0..3 {
                        let origin = f32::from_bits(w[a]);
                        let (lo, hi) = wide::quantise(b.min[a], b.max[a], origin, step[a]);
                        w[4 + 2 * a] |= lo << (8 * s);
                        w[5 + 2 * a] |= hi << (8 * s);
                    }
                    w[12 + s] = wide::entry(c, node_base);
                }
                _ => w[12 + s] = wide::EMPTY,
            }
        }
        GpuNode { words: w }
    }

    /// Dequantised bounds of child `slot` (as the shader computes them), for tests.
    pub fn child_bounds(&self, slot: usize) -> (Vec3, Vec3) {
        let w = &self.words;
        let q = |word: u32| (word >> (8 * slot)) & 255;
        let mut lo = [0f32; 3];
        let mut hi = [0f32; 3];
        for a in 0..3 {
            let origin = f32::from_bits(w[a]);
            let step = f32::from_bits(((w[3] >> (8 * a)) & 255) << 23);
            lo[a] = wide::plane(origin, q(w[4 + 2 * a]), step);
            hi[a] = wide::plane(origin, q(w[5 + 2 * a]), step);
        }
        (lo.into(), hi.into())
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
        assert_eq!(std::mem::size_of::<GpuNode>(), 64);
        assert_eq!(std::mem::size_of::<GpuTriangle>(), 48);
        assert_eq!(std::mem::size_of::<GpuTriangleShading>(), 80);
        assert_eq!(std::mem::size_of::<GpuInstance>(), 160);
    }
}
