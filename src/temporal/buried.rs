//! Replacement sites that a moving object has swallowed. A record is replaced at its own
//! place (seed 000 section IV-D), but a moving object may since have come to rest over
//! that place: a floor record a sliding cube has covered would trace its plane from inside
//! the cube and see nothing but the cube's unlit inside, and its replacement would splat
//! that darkness onto the visible floor beside the cube (cube in a box, 48x48: patches
//! 70-90 % too dark at the cube's leading edge, docs/results.md). Per-frame computation
//! never places a record there, as placement only picks visible points. Such a record is
//! deleted instead, and placement covers its pixels from visible points again.
//!
//! The test: a ray from the site (lifted off its surface as plane rays are) along its
//! geometric normal whose first hit on the moved object is a back face starts inside that
//! object, for a closed mesh whose faces point outwards. A mesh that is not closed can
//! only make the test delete a record placement then replaces, never keep a buried one
//! it would have kept before.

use crate::bvh::{Blas, BvhPreset};
use crate::direct::reference::offset_ray_origin;
use crate::records::RecordSite;
use crate::scene::{Mesh, Scene};
use glam::{Mat4, Vec3};
use obvhs::ray::{Ray, RayHit};
use std::cell::OnceCell;
use std::collections::HashMap;

/// Meshes with more triangles than this are searched through an object-space BVH (built
/// the first time a site lies in their box, kept for the sequence: only transforms change
/// from frame to frame) rather than triangle by triangle.
const BVH_ABOVE_TRIANGLES: usize = 256;

/// The object-space BVHs of the large meshes burial tests have searched, by mesh index,
/// kept across frames by the cache that tests (a mesh's triangles do not change during an
/// animation; a BVH that no longer matches its mesh is built again).
#[derive(Default)]
pub struct MeshBvhs {
    built: HashMap<usize, Blas>,
}

impl MeshBvhs {
    /// The BVH of mesh `index` of the scene, built if it is missing or was built for
    /// other triangles.
    fn of(&mut self, index: usize, mesh: &Mesh) -> &Blas {
        let matches = |blas: &Blas| {
            blas.mesh_triangle.len() == mesh.indices.len()
                && blas
                    .mesh_triangle
                    .first()
                    .zip(blas.triangles.first())
                    .is_none_or(|(&k, t)| {
                        mesh.indices
                            .get(k as usize)
                            .and_then(|tri| mesh.positions.get(tri[0] as usize))
                            .is_some_and(|&p| Vec3::from(t.v0) == p)
                    })
        };
        if !self.built.get(&index).is_some_and(matches) {
            self.built.insert(index, Blas::build(mesh, BvhPreset::Fast));
        }
        &self.built[&index]
    }
}

/// The burial test over one frame's scene: the world box of each instance asked about,
/// computed the first time, and the cache's mesh BVHs.
pub struct SiteBurial<'a> {
    scene: &'a Scene,
    boxes: Vec<OnceCell<(Vec3, Vec3)>>,
    bvhs: &'a mut MeshBvhs,
}

impl<'a> SiteBurial<'a> {
    /// The test at `scene`'s current transforms.
    pub fn new(scene: &'a Scene, bvhs: &'a mut MeshBvhs) -> Self {
        Self {
            scene,
            boxes: vec![OnceCell::new(); scene.instances.len()],
            bvhs,
        }
    }

    /// Whether `site` lies inside one of the `instances` (indices into the scene's): see
    /// the module documentation.
    pub fn buried(&mut self, site: &RecordSite, instances: &[usize]) -> bool {
        let Some(ray) = lifted_ray(site) else {
            return false;
        };
        let scene = self.scene;
        instances.iter().any(|&i| {
            let Some(inst) = scene.instances.get(i) else {
                return false;
            };
            let Some(mesh) = scene.meshes.get(inst.mesh as usize) else {
                return false;
            };
            let Some(&(lo, hi)) = self
                .boxes
                .get(i)
                .map(|b| b.get_or_init(|| world_box(&mesh.positions, &inst.transform)))
            else {
                return false;
            };
            if ray.0.cmplt(lo).any() || ray.0.cmpgt(hi).any() {
                false
            } else if mesh.indices.len() > BVH_ABOVE_TRIANGLES {
                let blas = self.bvhs.of(inst.mesh as usize, mesh);
                ray_starts_inside_bvh(blas, &inst.transform, ray)
            } else {
                ray_starts_inside(mesh, &inst.transform, ray)
            }
        })
    }
}

/// Whether a ray from `site` (lifted off its surface as plane rays are) along its
/// geometric normal first meets the back of `mesh` placed by `transform`.
pub fn site_inside(mesh: &Mesh, transform: &Mat4, site: &RecordSite) -> bool {
    lifted_ray(site).is_some_and(|ray| {
        let (lo, hi) = world_box(&mesh.positions, transform);
        !(ray.0.cmplt(lo).any() || ray.0.cmpgt(hi).any()) && ray_starts_inside(mesh, transform, ray)
    })
}

/// The ray a site is tested with: from its position lifted along its geometric normal
/// (`offset_ray_origin`, as plane rays start), along that normal.
fn lifted_ray(site: &RecordSite) -> Option<(Vec3, Vec3)> {
    let normal = Vec3::from(site.geometric_normal);
    if !normal.is_finite() || normal.length_squared() == 0.0 {
        return None;
    }
    let dir = normal.normalize();
    Some((offset_ray_origin(Vec3::from(site.position), dir), dir))
}

/// The world box of `positions` placed by `transform`.
fn world_box(positions: &[Vec3], transform: &Mat4) -> (Vec3, Vec3) {
    positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| {
            let w = transform.transform_point3(*p);
            (lo.min(w), hi.max(w))
        },
    )
}

/// The world-space ray `(origin, dir)` in the object space of `transform`; None for a
/// transform that cannot be inverted. The ray parameter is not a distance there, but the
/// nearest hit is the same hit, and the mesh's own winding says which side is its outside
/// (a mirrored placement of a solid is still a solid).
fn object_ray(transform: &Mat4, (origin, dir): (Vec3, Vec3)) -> Option<(Vec3, Vec3)> {
    let det = transform.determinant();
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inverse = transform.inverse();
    Some((
        inverse.transform_point3(origin),
        inverse.transform_vector3(dir),
    ))
}

/// Whether the world-space ray `ray` first meets the back of `mesh` placed by
/// `transform`, triangle by triangle.
fn ray_starts_inside(mesh: &Mesh, transform: &Mat4, ray: (Vec3, Vec3)) -> bool {
    let Some((o, d)) = object_ray(transform, ray) else {
        return false;
    };
    let mut nearest = f32::INFINITY;
    let mut back = false;
    for tri in &mesh.indices {
        let [a, b, c] = tri.map(|k| mesh.positions.get(k as usize).copied().unwrap_or(Vec3::NAN));
        if let Some((t, facing)) = intersect(o, d, a, b, c) {
            if t < nearest {
                nearest = t;
                back = facing > 0.0;
            }
        }
    }
    nearest.is_finite() && back
}

/// [`ray_starts_inside`] through the mesh's object-space BVH.
fn ray_starts_inside_bvh(blas: &Blas, transform: &Mat4, ray: (Vec3, Vec3)) -> bool {
    let Some((o, d)) = object_ray(transform, ray) else {
        return false;
    };
    let ray = Ray::new(o.into(), d.into(), 0.0, f32::INFINITY);
    let mut hit = RayHit::none();
    if !blas
        .bvh
        .ray_traverse(ray, &mut hit, |r, id| blas.triangles[id].intersect(r))
    {
        return false;
    }
    blas.triangles
        .get(hit.primitive_id as usize)
        .is_some_and(|t| {
            let (a, b, c) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
            d.dot((b - a).cross(c - a)) > 0.0
        })
}

/// Möller–Trumbore: the ray parameter of the hit (> 0) and `dot(dir, e1 x e2)` (positive:
/// the ray meets the triangle's back, the side its winding does not face).
fn intersect(o: Vec3, d: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<(f32, f32)> {
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-20 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0).then(|| (t, d.dot(e1.cross(e2))))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube, x and z in [-0.5, 0.5], y in [0, 1], faces pointing outwards (the
    /// cube of scenes/cube.obj).
    fn cube() -> Mesh {
        let p = |x: f32, y: f32, z: f32| Vec3::new(x - 0.5, y, z - 0.5);
        let positions = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(1.0, 0.0, 1.0),
            p(1.0, 1.0, 1.0),
            p(0.0, 1.0, 1.0),
        ];
        let quads = [
            [0, 3, 2, 1], // z = 0, facing -z
            [4, 5, 6, 7], // z = 1, facing +z
            [0, 4, 7, 3], // x = 0, facing -x
            [1, 2, 6, 5], // x = 1, facing +x
            [0, 1, 5, 4], // y = 0, facing -y
            [3, 7, 6, 2], // y = 1, facing +y
        ];
        let indices: Vec<[u32; 3]> = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        mesh("cube", positions, indices)
    }

    /// A mesh of `positions` and `indices` with no normals, texture coordinates or
    /// materials of note.
    fn mesh(name: &str, positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Mesh {
        Mesh {
            name: name.into(),
            normals: vec![Vec3::ZERO; positions.len()],
            uvs: vec![glam::Vec2::ZERO; positions.len()],
            material_ids: vec![0; indices.len()],
            positions,
            indices,
        }
    }

    fn cube_at(translate: Vec3, turn_degrees: f32) -> Mat4 {
        Mat4::from_translation(translate) * Mat4::from_rotation_y(turn_degrees.to_radians())
    }

    fn floor_site(x: f32, z: f32) -> RecordSite {
        RecordSite {
            position: [x, 0.0, z],
            r_min: 0.01,
            normal: [0.0, 1.0, 0.0],
            seed: 0,
            geometric_normal: [0.0, 1.0, 0.0],
            instance: 7,
        }
    }

    #[test]
    fn a_floor_site_under_a_resting_cube_is_buried_and_one_beside_it_is_not() {
        let (mesh, m) = (cube(), cube_at(Vec3::new(-0.4, 0.0, -0.5), 30.0));
        // Under the cube's middle, and just inside its turned footprint.
        assert!(site_inside(&mesh, &m, &floor_site(-0.4, -0.5)));
        assert!(site_inside(&mesh, &m, &floor_site(-0.4 + 0.55, -0.5)));
        // Beside it: outside the footprint (along x the turned cube reaches 0.577).
        assert!(!site_inside(&mesh, &m, &floor_site(-0.4 + 0.75, -0.5)));
        assert!(!site_inside(&mesh, &m, &floor_site(1.5, 1.5)));
    }

    #[test]
    fn a_site_facing_the_cube_from_outside_is_not_buried() {
        // The cube turned 45 degrees: (0.65, 0.5, 0.3) lies in its world box but outside
        // the cube, and its normal points at the cube, whose front face the ray meets.
        let m = cube_at(Vec3::ZERO, 45.0);
        let site = RecordSite {
            position: [0.65, 0.5, 0.3],
            normal: [-1.0, 0.0, 0.0],
            geometric_normal: [-1.0, 0.0, 0.0],
            ..floor_site(0.0, 0.0)
        };
        assert!(!site_inside(&cube(), &m, &site));
        // The same point turned to face away, inside the cube (0.3, 0.5, 0.1): buried.
        let inside = RecordSite {
            position: [0.3, 0.5, 0.1],
            ..site
        };
        assert!(site_inside(&cube(), &m, &inside));
    }

    /// The cube with every face cut into n x n quads (12 n^2 triangles), windings kept.
    fn fine_cube(n: u32) -> Mesh {
        let coarse = cube();
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for tri_pair in coarse.indices.chunks(2) {
            // Each face is two triangles [q0 q1 q2], [q0 q2 q3].
            let q = [
                tri_pair[0][0],
                tri_pair[0][1],
                tri_pair[0][2],
                tri_pair[1][2],
            ]
            .map(|k| coarse.positions[k as usize]);
            let at = |i: u32, j: u32| {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                q[0] + (q[1] - q[0]) * u + (q[3] - q[0]) * v
            };
            for i in 0..n {
                for j in 0..n {
                    let base = positions.len() as u32;
                    positions.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                    indices.push([base, base + 1, base + 2]);
                    indices.push([base, base + 2, base + 3]);
                }
            }
        }
        mesh("fine cube", positions, indices)
    }

    #[test]
    fn a_kept_bvh_is_built_again_for_other_triangles() {
        let mut bvhs = MeshBvhs::default();
        let fine = fine_cube(8);
        assert_eq!(bvhs.of(3, &fine).mesh_triangle.len(), fine.indices.len());
        let coarser = fine_cube(6);
        assert_eq!(
            bvhs.of(3, &coarser).mesh_triangle.len(),
            coarser.indices.len()
        );
    }

    #[test]
    fn the_bvh_search_agrees_with_the_triangle_by_triangle_one() {
        let mesh = fine_cube(8);
        assert!(mesh.indices.len() > BVH_ABOVE_TRIANGLES);
        let blas = Blas::build(&mesh, BvhPreset::Fast);
        let m = cube_at(Vec3::new(-0.4, 0.0, -0.5), 30.0);
        let mut inside = 0;
        for k in 0..400 {
            // Off the fine mesh's vertices and edges (a ray through a shared vertex may
            // miss every triangle in either search).
            let (x, z) = (
                (k % 20) as f32 * 0.07 - 1.087,
                (k / 20) as f32 * 0.07 - 1.213,
            );
            let site = floor_site(x, z);
            let ray = lifted_ray(&site).expect("ray");
            let brute = ray_starts_inside(&mesh, &m, ray);
            assert_eq!(
                brute,
                ray_starts_inside_bvh(&blas, &m, ray),
                "site {x}, {z}"
            );
            assert_eq!(brute, site_inside(&cube(), &m, &site), "site {x}, {z}");
            inside += usize::from(brute);
        }
        // The turned unit cube's square metre lies within the 1.4 m x 1.4 m grid around
        // it: about half of its 400 sites.
        assert!((180..=230).contains(&inside), "{inside} sites inside");
    }

    #[test]
    fn a_mirrored_cube_still_buries_the_site_under_it() {
        let m = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        assert!(site_inside(&cube(), &m, &floor_site(0.1, 0.1)));
        assert!(!site_inside(&cube(), &m, &floor_site(0.7, 0.1)));
    }
}
