//! Keyframed animation of instance transforms, lights and the camera.
//!
//! The scene file's `[animation]` table and `[[mesh.keyframe]]`, `[[light.keyframe]]` and
//! `[[camera.keyframe]]` entries (`docs/scene-format.md`, section "Animation") are parsed in
//! [`mod@super::file`] into the tracks kept here. Every track holds complete key values (fields
//! a keyframe omits were filled from the static entry at load), so evaluating one never
//! needs the file again.
//!
//! Evaluation is piecewise linear between keyframes, rotations are slerped (shortest arc),
//! and values before the first / after the last keyframe hold the end key. Frames are `f32`
//! so that in-between times (motion blur, sub-frame tests) can be evaluated too.

use super::{Camera, Light, Scene};
use glam::{Mat3, Mat4, Quat, Vec3};

/// The animation of a scene: frame range, rate and the keyframe tracks.
#[derive(Clone, Debug, Default)]
pub struct Animation {
    /// Frames per second (`[animation].fps`, > 0, default 25).
    pub fps: f32,
    /// First frame of the range to render (inclusive).
    pub first_frame: u32,
    /// Last frame of the range to render (inclusive, >= `first_frame`).
    pub last_frame: u32,
    /// The scene's temporal accuracy a_t (`[animation].temporal_accuracy`), when it sets
    /// one: `animate --temporal-accuracy` overrides it, the default applies without.
    pub temporal_accuracy: Option<f32>,
    /// The scene's dt_max in frames (`[animation].max_lifespan`), likewise.
    pub max_lifespan: Option<u32>,
    /// Transform tracks of animated instances, as (instance index, track), by index.
    pub(crate) instances: Vec<(usize, Track<TransformKey>)>,
    /// Tracks of animated lights, as (light index, track), by index.
    pub(crate) lights: Vec<(usize, LightTrack)>,
    /// The camera's track, when it has keyframes.
    pub(crate) camera: Option<Track<CameraKey>>,
}

/// A track's key value: anything that can be interpolated between two keys.
pub(crate) trait Interpolate: Clone {
    /// The value a fraction `t` in [0, 1] of the way from `a` to `b`.
    fn interpolate(a: &Self, b: &Self, t: f32) -> Self;
}

/// Keys at strictly increasing frames (checked at load); never empty.
#[derive(Clone, Debug)]
pub(crate) struct Track<T> {
    pub(crate) keys: Vec<(f32, T)>,
}

impl<T: Interpolate> Track<T> {
    /// The value at `frame`: linear between the neighbouring keys, the end key outside them.
    pub(crate) fn sample(&self, frame: f32) -> T {
        // Index of the first key after `frame`.
        let next = self.keys.partition_point(|(f, _)| *f <= frame);
        if next == 0 {
            return self.keys[0].1.clone();
        }
        if next == self.keys.len() {
            return self.keys[next - 1].1.clone();
        }
        let (f0, a) = &self.keys[next - 1];
        let (f1, b) = &self.keys[next];
        T::interpolate(a, b, (frame - f0) / (f1 - f0))
    }
}

/// One key of an instance transform, `M = T * R * S` (the static TRS convention, with the
/// Euler rotation `Rz * Ry * Rx` as a quaternion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TransformKey {
    pub(crate) translate: Vec3,
    pub(crate) rotation: Quat,
    pub(crate) scale: Vec3,
}

impl TransformKey {
    /// From the scene file's values: Euler angles in degrees, X applied first, then Y, then Z.
    pub(crate) fn from_trs(translate: Vec3, rotate_degrees: Vec3, scale: Vec3) -> Self {
        let r = rotate_degrees;
        // Intrinsic ZYX: Rz(z) * Ry(y) * Rx(x), the order of `mesh_transform`.
        let rotation = Quat::from_euler(
            glam::EulerRot::ZYX,
            r.z.to_radians(),
            r.y.to_radians(),
            r.x.to_radians(),
        );
        Self {
            translate,
            rotation,
            scale,
        }
    }

    pub(crate) fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translate)
    }
}

impl Interpolate for TransformKey {
    fn interpolate(a: &Self, b: &Self, t: f32) -> Self {
        Self {
            translate: a.translate.lerp(b.translate, t),
            // glam's slerp flips `b` when the dot product is negative: the shortest arc.
            rotation: a.rotation.slerp(b.rotation, t).normalize(),
            scale: a.scale.lerp(b.scale, t),
        }
    }
}

/// The track of one light, and for a rect light the instance and material of its quad.
#[derive(Clone, Debug)]
pub(crate) struct LightTrack {
    /// Complete lights of the same type as the static one.
    pub(crate) track: Track<Light>,
    /// For a rect light: its emissive quad, which must follow the light.
    pub(crate) quad: Option<RectQuad>,
}

/// The emissive quad the loader added for a rect light.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RectQuad {
    /// Index of the quad's instance in [`Scene::instances`].
    pub(crate) instance: usize,
    /// Index of the quad's material in [`Scene::materials`] (its emission is the radiance).
    pub(crate) material: usize,
    /// The parallelogram the quad mesh was built from (object space of the quad instance).
    pub(crate) corner: Vec3,
    pub(crate) edge_u: Vec3,
    pub(crate) edge_v: Vec3,
    /// Whether `corner`, `edge_u` or `edge_v` have keyframes (else the quad never moves).
    pub(crate) moves: bool,
}

impl RectQuad {
    /// The affine map taking the quad mesh's parallelogram onto `corner + s*u + t*v`: the
    /// edges map to the edges, the unit normal to the new unit normal, so the map is exact
    /// for the quad's vertices and keeps its normals facing along `cross(u, v)`.
    fn transform(&self, corner: Vec3, u: Vec3, v: Vec3) -> Mat4 {
        let from = Mat3::from_cols(
            self.edge_u,
            self.edge_v,
            self.edge_u.cross(self.edge_v).normalize_or_zero(),
        );
        let to = Mat3::from_cols(u, v, u.cross(v).normalize_or_zero());
        // Both edge pairs were checked non-parallel at load, so `from` is invertible.
        let linear = to * from.inverse();
        let translation = corner - linear * self.corner;
        Mat4::from_mat3_translation(linear, translation)
    }
}

/// Interpolates a unit direction: linear, then normalised. Consecutive keys are never
/// opposite (checked at load), so the sum is non-zero; `a` is kept if it ever were.
fn interpolate_direction(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a.lerp(b, t).try_normalize().unwrap_or(a)
}

impl Interpolate for Light {
    fn interpolate(a: &Self, b: &Self, t: f32) -> Self {
        match (a, b) {
            (
                Light::Point {
                    position: p0,
                    intensity: i0,
                },
                Light::Point {
                    position: p1,
                    intensity: i1,
                },
            ) => Light::Point {
                position: p0.lerp(*p1, t),
                intensity: i0.lerp(*i1, t),
            },
            (
                Light::Spot {
                    position: p0,
                    direction: d0,
                    intensity: i0,
                    cos_inner,
                    cos_outer,
                },
                Light::Spot {
                    position: p1,
                    direction: d1,
                    intensity: i1,
                    ..
                },
            ) => Light::Spot {
                position: p0.lerp(*p1, t),
                direction: interpolate_direction(*d0, *d1, t),
                intensity: i0.lerp(*i1, t),
                cos_inner: *cos_inner,
                cos_outer: *cos_outer,
            },
            (
                Light::Rect {
                    corner: c0,
                    edge_u: u0,
                    edge_v: v0,
                    radiance: r0,
                },
                Light::Rect {
                    corner: c1,
                    edge_u: u1,
                    edge_v: v1,
                    radiance: r1,
                },
            ) => Light::Rect {
                corner: c0.lerp(*c1, t),
                edge_u: u0.lerp(*u1, t),
                edge_v: v0.lerp(*v1, t),
                radiance: r0.lerp(*r1, t),
            },
            (
                Light::Sun {
                    direction: d0,
                    irradiance: e0,
                },
                Light::Sun {
                    direction: d1,
                    irradiance: e1,
                },
            ) => Light::Sun {
                direction: interpolate_direction(*d0, *d1, t),
                irradiance: e0.lerp(*e1, t),
            },
            // The loader builds every key of a track from the same static light, so the
            // types always agree; holding `a` keeps this total without a panic.
            _ => a.clone(),
        }
    }
}

/// One key of the camera (the resolution is not animated).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CameraKey {
    pub(crate) position: Vec3,
    pub(crate) target: Vec3,
    pub(crate) up: Vec3,
    pub(crate) fov_y_degrees: f32,
}

impl Interpolate for CameraKey {
    fn interpolate(a: &Self, b: &Self, t: f32) -> Self {
        Self {
            position: a.position.lerp(b.position, t),
            target: a.target.lerp(b.target, t),
            up: interpolate_direction(a.up, b.up, t),
            fov_y_degrees: a.fov_y_degrees + (b.fov_y_degrees - a.fov_y_degrees) * t,
        }
    }
}

impl Animation {
    /// The transform track of instance `i`, if it has one.
    fn instance_track(&self, i: usize) -> Option<&Track<TransformKey>> {
        self.instances
            .binary_search_by_key(&i, |(j, _)| *j)
            .ok()
            .map(|k| &self.instances[k].1)
    }

    /// The rect light track whose moving quad is instance `i`, if any.
    fn quad_of_instance(&self, i: usize) -> Option<(&LightTrack, &RectQuad)> {
        self.lights.iter().find_map(|(_, t)| match &t.quad {
            Some(q) if q.moves && q.instance == i => Some((t, q)),
            _ => None,
        })
    }
}

/// The quad transform of a rect light track at `frame`.
fn quad_transform(track: &LightTrack, quad: &RectQuad, frame: f32) -> Option<Mat4> {
    match track.track.sample(frame) {
        Light::Rect {
            corner,
            edge_u,
            edge_v,
            ..
        } => Some(quad.transform(corner, edge_u, edge_v)),
        _ => None,
    }
}

impl Scene {
    /// Moves the scene to `frame`: sets animated instances' transforms, lights (with the
    /// emissive quads and emission of animated rect lights) and the camera to their values
    /// at that frame. Only small per-instance and per-light values are written; mesh data is
    /// untouched. A scene without animation is left unchanged.
    pub fn set_frame(&mut self, frame: f32) {
        let Some(animation) = self.animation.take() else {
            return;
        };
        for (i, track) in &animation.instances {
            self.instances[*i].transform = track.sample(frame).matrix();
        }
        for (i, light_track) in &animation.lights {
            let light = light_track.track.sample(frame);
            if let (Some(quad), Light::Rect { radiance, .. }) = (&light_track.quad, &light) {
                self.materials[quad.material].emission = *radiance;
                // Nested, not a let chain: the crate's MSRV (1.87) predates them.
                if quad.moves {
                    if let Some(m) = quad_transform(light_track, quad, frame) {
                        self.instances[quad.instance].transform = m;
                    }
                }
            }
            self.lights[*i] = light;
        }
        if let Some(track) = &animation.camera {
            self.camera = camera_from_key(&self.camera, &track.sample(frame));
        }
        self.animation = Some(animation);
    }

    /// The frames to render: `[animation].frames`, or `0..=0` for a static scene.
    pub fn frames(&self) -> std::ops::RangeInclusive<u32> {
        match &self.animation {
            Some(a) => a.first_frame..=a.last_frame,
            None => 0..=0,
        }
    }

    /// Whether instance `i`'s transform changes over time (a mesh with keyframes, or the
    /// quad of a rect light whose geometry has keyframes).
    pub fn instance_is_animated(&self, i: usize) -> bool {
        self.animation
            .as_ref()
            .is_some_and(|a| a.instance_track(i).is_some() || a.quad_of_instance(i).is_some())
    }

    /// Whether any light has keyframes.
    pub fn lights_are_animated(&self) -> bool {
        self.animation
            .as_ref()
            .is_some_and(|a| !a.lights.is_empty())
    }

    /// Whether the camera has keyframes.
    pub fn camera_is_animated(&self) -> bool {
        self.animation.as_ref().is_some_and(|a| a.camera.is_some())
    }

    /// Object-to-world transform of instance `i` at `frame`, without changing the scene.
    /// Non-animated instances return their current transform.
    ///
    /// # Panics
    /// If `i` is not an instance index.
    pub fn instance_transform_at(&self, i: usize, frame: f32) -> Mat4 {
        if let Some(animation) = &self.animation {
            if let Some(track) = animation.instance_track(i) {
                return track.sample(frame).matrix();
            }
            if let Some(m) = animation
                .quad_of_instance(i)
                .and_then(|(track, quad)| quad_transform(track, quad, frame))
            {
                return m;
            }
        }
        self.instances[i].transform
    }

    /// All lights at `frame`, without changing the scene (same order as [`Scene::lights`]).
    pub fn lights_at(&self, frame: f32) -> Vec<Light> {
        let mut lights = self.lights.clone();
        if let Some(animation) = &self.animation {
            for (i, track) in &animation.lights {
                lights[*i] = track.track.sample(frame);
            }
        }
        lights
    }

    /// The camera at `frame`, without changing the scene.
    pub fn camera_at(&self, frame: f32) -> Camera {
        match self.animation.as_ref().and_then(|a| a.camera.as_ref()) {
            Some(track) => camera_from_key(&self.camera, &track.sample(frame)),
            None => self.camera.clone(),
        }
    }
}

/// `camera` with the animated fields of `key`.
fn camera_from_key(camera: &Camera, key: &CameraKey) -> Camera {
    Camera {
        position: key.position,
        target: key.target,
        up: key.up,
        fov_y_degrees: key.fov_y_degrees,
        ..camera.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scalar_track(keys: &[(f32, f32)]) -> Track<CameraKey> {
        Track {
            keys: keys
                .iter()
                .map(|&(f, v)| {
                    (
                        f,
                        CameraKey {
                            position: Vec3::splat(v),
                            target: Vec3::ZERO,
                            up: Vec3::Y,
                            fov_y_degrees: v,
                        },
                    )
                })
                .collect(),
        }
    }

    #[test]
    fn track_is_linear_and_holds_ends() {
        let track = scalar_track(&[(10.0, 1.0), (20.0, 3.0), (30.0, -1.0)]);
        let at = |f: f32| track.sample(f).fov_y_degrees;
        assert_eq!(at(-5.0), 1.0);
        assert_eq!(at(10.0), 1.0);
        assert_eq!(at(15.0), 2.0);
        assert_eq!(at(20.0), 3.0);
        assert_eq!(at(27.5), 0.0);
        assert_eq!(at(30.0), -1.0);
        assert_eq!(at(1e6), -1.0);
    }

    #[test]
    fn euler_quaternion_matches_static_convention() {
        let r = Vec3::new(20.0, -35.0, 70.0);
        let key = TransformKey::from_trs(Vec3::new(1.0, 2.0, 3.0), r, Vec3::new(2.0, 1.0, 0.5));
        let expected = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
            * Mat4::from_rotation_z(r.z.to_radians())
            * Mat4::from_rotation_y(r.y.to_radians())
            * Mat4::from_rotation_x(r.x.to_radians())
            * Mat4::from_scale(Vec3::new(2.0, 1.0, 0.5));
        assert!(key.matrix().abs_diff_eq(expected, 1e-5));
    }

    #[test]
    fn slerp_takes_the_shortest_arc() {
        let a = TransformKey::from_trs(Vec3::ZERO, Vec3::new(0.0, 170.0, 0.0), Vec3::ONE);
        let b = TransformKey::from_trs(Vec3::ZERO, Vec3::new(0.0, -170.0, 0.0), Vec3::ONE);
        // The short way from 170° to -170° passes 180°, not 0°.
        let mid = TransformKey::interpolate(&a, &b, 0.5).matrix();
        let x = mid.transform_vector3(Vec3::X);
        assert!((x - Vec3::NEG_X).length() < 1e-5, "{x}");
    }

    #[test]
    fn rect_quad_transform_maps_corners_and_normal() {
        let quad = RectQuad {
            instance: 0,
            material: 0,
            corner: Vec3::new(-0.5, 3.0, -0.5),
            edge_u: Vec3::X,
            edge_v: Vec3::Z,
            moves: true,
        };
        let (c, u, v) = (
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::NEG_X,
        );
        let m = quad.transform(c, u, v);
        let p =
            |s: f32, t: f32| m.transform_point3(quad.corner + s * quad.edge_u + t * quad.edge_v);
        assert!(p(0.0, 0.0).abs_diff_eq(c, 1e-6));
        assert!(p(1.0, 0.0).abs_diff_eq(c + u, 1e-6));
        assert!(p(1.0, 1.0).abs_diff_eq(c + u + v, 1e-6));
        let n = crate::bvh::normal_matrix(m) * quad.edge_u.cross(quad.edge_v);
        assert!(n.normalize().abs_diff_eq(u.cross(v).normalize(), 1e-6));
    }
}
