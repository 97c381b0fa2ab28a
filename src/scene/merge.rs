//! A scene whose instances never move, traced as one mesh in world space.
//!
//! Rays of a scene of one instance placed as modelled start in its BLAS, and its plane
//! pipelines leave instance traversal out (`bvh::SceneBvh::traversal_start`,
//! `gpu::SceneFeatures`): no TLAS, no ray transform, no instance loads, and on lavapipe no
//! code in the traversal loop for the branch no lane takes. A static scene of several OBJ
//! files pays all of that on every ray. [`Scene::merge_static_instances`] bakes such a
//! scene's instances into one mesh (cube in a box, a room and a cube: planes about 0.8 and
//! the frame 0.88 of their time; docs/results.md, stop 57).
//!
//! The commands do this for every scene whose instances do not move
//! (`commands::load_scene_with`); a loaded [`Scene`] keeps its instances, so that a program
//! embedding radsplat can still move them frame by frame. The merged scene's hits are
//! rounded in world space rather than in each instance's, so its images can differ from the
//! instanced scene's in the last bits.

use super::{Instance, Mesh, Scene};
use glam::{Mat3, Mat4};

/// Most triangles a baked scene may have when baking repeats shared meshes (about 50 MiB
/// of triangles and shading data on the GPU); without sharing it never grows.
pub const MAX_GROWN_TRIANGLES: usize = 1 << 20;

impl Scene {
    /// Bakes every instance into one world-space mesh with an identity instance, when no
    /// instance moves (no instance keyframes, no moving rect-light quad) and there are
    /// several. Meshes that several instances share are repeated, so a scene is baked only
    /// where that at most doubles its triangles and keeps them under
    /// [`MAX_GROWN_TRIANGLES`] (four chairs in a room, not a forest of one tree instanced a
    /// thousand times). Returns whether it did.
    ///
    /// Each triangle keeps its vertices' normals (carried by the normal matrix, so that
    /// shading interpolates the same directions: they need not be unit length then),
    /// texture coordinates and material; a mirroring
    /// transform swaps two vertices so that the winding still faces the way the instance's
    /// normals do (emitters are one-sided). The OBJ's triangles come in instance order. A
    /// scene whose world positions would not be finite (a transform scaling to f32's
    /// limits) is left as it is.
    pub fn merge_static_instances(&mut self) -> bool {
        if self.instances.len() < 2 {
            return false;
        }
        if let Some(animation) = &self.animation
            && (!animation.instances.is_empty()
                || animation.lights.iter().any(|(_, t)| t.quad.is_some()))
        {
            return false;
        }
        // Baking repeats a shared mesh's triangles once per instance: only where that at
        // most doubles what the GPU holds, and stays small.
        let mut used = vec![false; self.meshes.len()];
        let (mut distinct, mut baked) = (0usize, 0usize);
        for instance in &self.instances {
            let triangles = self.meshes[instance.mesh as usize].indices.len();
            baked += triangles;
            if !std::mem::replace(&mut used[instance.mesh as usize], true) {
                distinct += triangles;
            }
        }
        if baked > distinct && (baked > 2 * distinct || baked > MAX_GROWN_TRIANGLES) {
            return false;
        }
        let mut merged = Mesh {
            name: self
                .instances
                .iter()
                .map(|i| self.meshes[i.mesh as usize].name.as_str())
                .collect::<Vec<_>>()
                .join(" + "),
            ..Mesh::default()
        };
        for instance in &self.instances {
            let mesh = &self.meshes[instance.mesh as usize];
            let m = instance.transform;
            let base = merged.positions.len() as u32;
            if m == Mat4::IDENTITY {
                merged.positions.extend_from_slice(&mesh.positions);
                merged.normals.extend_from_slice(&mesh.normals);
            } else {
                // Shading interpolates a triangle's vertex normals, then carries the result
                // by the normal matrix and normalises it. The matrix is linear, so carrying
                // each vertex normal first, unnormalised, gives the same direction: one
                // common factor (the largest column's length) only keeps the lengths near 1.
                // (Normalising each would reweigh the interpolation under a non-uniform
                // scale.) A zero normal marks a vertex without a usable one: it stays zero.
                let nm = super::normal_matrix(m);
                let scale = nm
                    .x_axis
                    .length()
                    .max(nm.y_axis.length())
                    .max(nm.z_axis.length());
                let nm = nm * (1.0 / scale);
                merged
                    .positions
                    .extend(mesh.positions.iter().map(|&p| m.transform_point3(p)));
                merged.normals.extend(mesh.normals.iter().map(|&n| nm * n));
            }
            merged.uvs.extend_from_slice(&mesh.uvs);
            let mirrored = Mat3::from_mat4(m).determinant() < 0.0;
            merged.indices.extend(mesh.indices.iter().map(|t| {
                let [a, b, c] = t.map(|i| i + base);
                if mirrored { [a, c, b] } else { [a, b, c] }
            }));
            merged.material_ids.extend_from_slice(&mesh.material_ids);
        }
        if !merged.positions.iter().all(|p| p.is_finite()) {
            return false;
        }
        self.meshes = vec![merged];
        self.instances = vec![Instance {
            mesh: 0,
            transform: Mat4::IDENTITY,
        }];
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::bundled;
    use glam::{Vec2, Vec3};

    fn triangle(name: &str) -> Mesh {
        Mesh {
            name: name.into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z, Vec3::Z, Vec3::ZERO],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y],
            indices: vec![[0, 1, 2]],
            material_ids: vec![0],
        }
    }

    /// The Cornell box's camera, materials and light around two one-triangle meshes.
    fn scene(instances: Vec<Instance>) -> Scene {
        Scene {
            meshes: vec![triangle("a"), triangle("b"), triangle("c")],
            instances,
            ..bundled("cornell-box.toml")
        }
    }

    /// Each baked triangle is its instance's triangle in world space, facing the same way,
    /// with its normals carried as shading carries them.
    #[test]
    fn baked_triangles_are_the_instances_triangles_in_world_space() {
        let mirror = Mat4::from_scale(Vec3::new(-1.0, 2.0, 1.0));
        let moved = Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0))
            * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
        let instances = vec![
            Instance {
                mesh: 0,
                transform: Mat4::IDENTITY,
            },
            Instance {
                mesh: 1,
                transform: moved,
            },
            Instance {
                mesh: 2,
                transform: mirror,
            },
        ];
        let original = scene(instances.clone());
        let mut s = original.clone();
        assert!(s.merge_static_instances());
        assert_eq!(s.instances.len(), 1);
        assert_eq!(s.instances[0].transform, Mat4::IDENTITY);
        assert_eq!(s.meshes.len(), 1);
        assert_eq!(s.triangle_count(), original.triangle_count());
        let mesh = &s.meshes[0];
        assert_eq!(mesh.name, "a + b + c");
        for (k, instance) in instances.iter().enumerate() {
            let m = instance.transform;
            let source = &original.meshes[instance.mesh as usize];
            let [a, b, c] = mesh.indices[k].map(|i| i as usize);
            let p = |i: usize| mesh.positions[i];
            let want = |i: usize| m.transform_point3(source.positions[i]);
            // The winding's normal points along the instance's carried normal.
            let carried = (crate::scene::normal_matrix(m) * Vec3::Z).normalize();
            let winding = (p(b) - p(a)).cross(p(c) - p(a)).normalize();
            assert!(
                (winding - carried).length() < 1e-6,
                "instance {k}: {winding} vs {carried}"
            );
            assert!((p(a) - want(0)).length() < 1e-6);
            let mut corners = [p(b), p(c)];
            corners.sort_by(|x, y| x.x.total_cmp(&y.x).then(x.y.total_cmp(&y.y)));
            let mut expected = [want(1), want(2)];
            expected.sort_by(|x, y| x.x.total_cmp(&y.x).then(x.y.total_cmp(&y.y)));
            assert!((corners[0] - expected[0]).length() < 1e-6);
            assert!((corners[1] - expected[1]).length() < 1e-6);
            assert!((mesh.normals[a].normalize() - carried).length() < 1e-6);
            // The vertex without a normal keeps its zero mark, with its uv.
            let zero = mesh.indices[k]
                .into_iter()
                .find(|&i| mesh.normals[i as usize] == Vec3::ZERO);
            assert_eq!(zero.map(|i| mesh.uvs[i as usize]), Some(Vec2::Y));
        }
    }

    /// Nothing changes a scene of one instance, one that may move, one that would more than
    /// double its triangles, or one whose world positions would overflow.
    #[test]
    fn scenes_that_can_or_need_not_be_merged_are_left_alone() {
        let one = vec![Instance {
            mesh: 0,
            transform: Mat4::IDENTITY,
        }];
        let mut s = scene(one);
        assert!(!s.merge_static_instances());

        // One triangle instanced three times would be three: more than twice one.
        let shared = |n: usize| {
            (0..n)
                .map(|k| Instance {
                    mesh: 1,
                    transform: Mat4::from_translation(Vec3::X * k as f32),
                })
                .collect::<Vec<_>>()
        };
        let mut s = scene(shared(3));
        assert!(!s.merge_static_instances());
        assert_eq!((s.instances.len(), s.meshes.len()), (3, 3));
        let mut s = scene(shared(2));
        assert!(s.merge_static_instances(), "twice is baked");
        assert_eq!(s.triangle_count(), 2);

        let huge = vec![
            Instance {
                mesh: 0,
                transform: Mat4::IDENTITY,
            },
            Instance {
                mesh: 1,
                transform: Mat4::from_translation(Vec3::splat(3.0e38))
                    * Mat4::from_scale(Vec3::splat(1.0e38)),
            },
        ];
        let mut s = scene(huge);
        assert!(!s.merge_static_instances());
        assert_eq!(s.instances.len(), 2);

        let mut animated = bundled("cube-in-box-anim.toml");
        let instances = animated.instances.len();
        assert!(!animated.merge_static_instances());
        assert_eq!(animated.instances.len(), instances);

        let mut still = bundled("cube-in-box.toml");
        assert_eq!(still.instances.len(), 3, "room, cube, the light's quad");
        assert!(still.merge_static_instances());
        assert_eq!(still.instances.len(), 1);
    }
}
