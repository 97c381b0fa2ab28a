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

use super::limits::{MAX_LIGHT_VALUE, MAX_RECT_LIGHT_POWER};
use super::{Camera, Light, Scene};
use crate::{Error, Result};
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

impl<T> Track<T> {
    /// The keys `frame` lies strictly between, as (index, frame) of each: `None` on a key
    /// or outside the keys, where the value is a key's (validated at load).
    fn segment(&self, frame: f32) -> Option<((usize, f32), (usize, f32))> {
        let next = self.keys.partition_point(|(f, _)| *f <= frame);
        if next == 0 || next == self.keys.len() || self.keys[next - 1].0 == frame {
            return None;
        }
        Some(((next - 1, self.keys[next - 1].0), (next, self.keys[next].0)))
    }

    /// The integer frames strictly inside the key span, where interpolated values appear.
    fn inner_frames(&self) -> std::ops::RangeInclusive<i64> {
        let first = self.keys.first().map_or(0.0, |k| k.0);
        let last = self.keys.last().map_or(0.0, |k| k.0);
        (first.floor() as i64 + 1)..=(last.ceil() as i64 - 1)
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
    pub(crate) fn instance_track(&self, i: usize) -> Option<&Track<TransformKey>> {
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

/// The most integer frames inside keyframe spans that loading a scene evaluates and checks
/// (a fraction of a second): 2^18 frames are 2.9 hours at 25 frames a second. Frames beyond it are
/// checked by [`Scene::check_frame`] / [`Scene::try_set_frame`] when they are evaluated.
pub const MAX_FRAMES_CHECKED_AT_LOAD: u64 = 1 << 18;

/// Smallest |determinant| accepted for an instance transform (also at load).
pub(crate) const MIN_DETERMINANT: f32 = 1e-12;

/// Checks an object-to-world transform: finite and invertible.
pub(crate) fn check_transform(m: &Mat4) -> std::result::Result<(), String> {
    if !m.is_finite() {
        return Err("transform is not finite (NaN or infinity)".to_string());
    }
    let det = m.determinant();
    if !(det.is_finite() && det.abs() > MIN_DETERMINANT) {
        return Err(format!(
            "transform is singular (determinant {det}): the object collapses to a plane, a \
             line or a point"
        ));
    }
    Ok(())
}

/// A vector for messages: huge components in exponent notation (`3e38`, not 39 digits).
fn show(v: Vec3) -> String {
    let c = |x: f32| {
        if x.abs() >= 1e7 {
            format!("{x:e}")
        } else {
            format!("{x}")
        }
    };
    format!("[{}, {}, {}]", c(v.x), c(v.y), c(v.z))
}

/// A light value (radiance, intensity, irradiance): finite, non-negative and at most
/// [`MAX_LIGHT_VALUE`] per channel.
pub(crate) fn check_light_value(v: Vec3) -> std::result::Result<(), String> {
    if !v.is_finite() {
        return Err(format!("must be finite, got {v}"));
    }
    if v.min_element() < 0.0 {
        return Err(format!("must not be negative, got {v}"));
    }
    if v.max_element() > MAX_LIGHT_VALUE {
        return Err(format!(
            "{} is too large: at most {MAX_LIGHT_VALUE:e} per channel, so that the renderer's \
             sums of light stay finite in 32-bit floats",
            show(v)
        ));
    }
    Ok(())
}

/// Checks a light's state (a static light or one evaluated at a frame); the error names the
/// parameter at fault.
pub(crate) fn check_light(light: &Light) -> std::result::Result<(), (&'static str, String)> {
    let finite = |name: &'static str, v: Vec3| {
        if v.is_finite() {
            Ok(())
        } else {
            Err((name, format!("must be finite, got {v}")))
        }
    };
    match light {
        Light::Point {
            position,
            intensity,
        }
        | Light::Spot {
            position,
            intensity,
            ..
        } => {
            finite("position", *position)?;
            check_light_value(*intensity).map_err(|m| ("intensity", m))
        }
        Light::Rect {
            corner,
            edge_u,
            edge_v,
            radiance,
        } => {
            finite("corner", *corner)?;
            finite("edge_u", *edge_u)?;
            finite("edge_v", *edge_v)?;
            if edge_u.length() == 0.0 {
                return Err(("edge_u", "edge is zero: the light has no area".to_string()));
            }
            if edge_v.length() == 0.0 {
                return Err(("edge_v", "edge is zero: the light has no area".to_string()));
            }
            let area = edge_u.cross(*edge_v).length();
            if !area.is_finite() {
                return Err((
                    "edge_u",
                    format!(
                        "area |edge_u x edge_v| overflows (edges {} and {})",
                        show(*edge_u),
                        show(*edge_v)
                    ),
                ));
            }
            if area <= 1e-6 * edge_u.length() * edge_v.length() {
                return Err((
                    "edge_v",
                    format!("edges {edge_u} and {edge_v} are parallel: the rectangle has no area"),
                ));
            }
            check_light_value(*radiance).map_err(|m| ("radiance", m))?;
            let power = radiance.max_element() * area;
            if !(power.is_finite() && power <= MAX_RECT_LIGHT_POWER) {
                return Err((
                    "radiance",
                    format!(
                        "radiance {} x area {area:e} = {power:e} is too large: at most \
                         {MAX_RECT_LIGHT_POWER:e}, so that the renderer's light sums stay \
                         finite in 32-bit floats",
                        show(*radiance)
                    ),
                ));
            }
            Ok(())
        }
        Light::Sun { irradiance, .. } => {
            check_light_value(*irradiance).map_err(|m| ("irradiance", m))
        }
    }
}

/// Checks a camera view (static or evaluated at a frame); the error names the field.
pub(crate) fn check_camera_key(key: &CameraKey) -> std::result::Result<(), (&'static str, String)> {
    if !key.position.is_finite() {
        return Err(("position", format!("must be finite, got {}", key.position)));
    }
    if !key.target.is_finite() {
        return Err(("target", format!("must be finite, got {}", key.target)));
    }
    let Some(view) = (key.target - key.position).try_normalize() else {
        return Err((
            "target",
            format!(
                "equals the position {}: the camera has no view direction",
                key.position
            ),
        ));
    };
    if !key.up.is_finite() || view.cross(key.up).length() < 1e-6 {
        return Err((
            "up",
            format!(
                "{} is parallel to the view direction {view} (target - position): the image \
                 would have no orientation",
                key.up
            ),
        ));
    }
    let fov = key.fov_y_degrees;
    if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
        return Err((
            "fov_y",
            format!("vertical field of view must be in (0, 180) degrees, got {fov}"),
        ));
    }
    Ok(())
}

impl Scene {
    /// Checks the scene's state at `frame` without changing it: every animated instance
    /// transform finite and invertible, every animated light finite with a non-degenerate
    /// shape and a light value within [`MAX_LIGHT_VALUE`], the animated camera with a view
    /// direction that is not parallel to `up`. Keyframes are each valid on their own (checked
    /// at load), but the interpolation between two of them may pass through such a state
    /// (a scale through zero, an edge through zero, the view direction through `up`); the
    /// error names the frame, the entry and field, and the two keyframes.
    ///
    /// Loading a scene already checks every integer frame inside the keyframe spans (up to
    /// [`MAX_FRAMES_CHECKED_AT_LOAD`]); this is for other frames (sub-frame times, or spans
    /// longer than that).
    pub fn check_frame(&self, frame: f32) -> Result<()> {
        let Some(animation) = &self.animation else {
            return Ok(());
        };
        for (i, track) in &animation.instances {
            self.check_instance_at(*i, track, frame)?;
        }
        for (i, track) in &animation.lights {
            self.check_light_at(*i, &track.track, frame)?;
        }
        if let Some(track) = &animation.camera {
            self.check_camera_at(track, frame)?;
        }
        Ok(())
    }

    /// [`Scene::check_frame`] for every frame of `frames`. Only frames strictly inside some
    /// track's keyframe span are evaluated (elsewhere every value is a key's), so the cost is
    /// bounded by the keyframe spans, not by the range.
    pub fn check_frames(&self, frames: std::ops::RangeInclusive<u32>) -> Result<()> {
        self.check_inner_frames(
            i64::from(*frames.start())..=i64::from(*frames.end()),
            u64::MAX,
        )
    }

    /// Checks the state at `frame` ([`Scene::check_frame`]), then moves the scene there
    /// ([`Scene::set_frame`]); on an error the scene is unchanged.
    pub fn try_set_frame(&mut self, frame: f32) -> Result<()> {
        self.check_frame(frame)?;
        self.set_frame(frame);
        Ok(())
    }

    /// The load-time check: the integer frames inside every track's keyframe span, at most
    /// [`MAX_FRAMES_CHECKED_AT_LOAD`] in all (the rest are logged as left to
    /// [`Scene::check_frame`]).
    pub(crate) fn check_keyframe_spans(&self) -> Result<()> {
        self.check_inner_frames(i64::MIN..=i64::MAX, MAX_FRAMES_CHECKED_AT_LOAD)
    }

    /// Checks each track at the integer frames of `range` inside its key span, evaluating at
    /// most `budget` frames in all.
    fn check_inner_frames(&self, range: std::ops::RangeInclusive<i64>, budget: u64) -> Result<()> {
        let Some(animation) = &self.animation else {
            return Ok(());
        };
        let mut left = budget;
        let mut frames_of = |inner: std::ops::RangeInclusive<i64>| {
            let lo = (*inner.start()).max(*range.start());
            let hi = (*inner.end()).min(*range.end());
            let count = u64::try_from(hi.saturating_sub(lo).saturating_add(1)).unwrap_or(0);
            let take = count.min(left);
            left -= take;
            if take < count {
                log::warn!(
                    "{}: keyframes span more than {budget} frames; frames after {} are \
                     checked when they are rendered",
                    self.source.display(),
                    lo.saturating_add(take as i64 - 1)
                );
            }
            (0..take as i64).map(move |k| (lo + k) as f32)
        };
        for (i, track) in &animation.instances {
            for frame in frames_of(track.inner_frames()) {
                self.check_instance_at(*i, track, frame)?;
            }
        }
        for (i, track) in &animation.lights {
            for frame in frames_of(track.track.inner_frames()) {
                self.check_light_at(*i, &track.track, frame)?;
            }
        }
        if let Some(track) = &animation.camera {
            for frame in frames_of(track.inner_frames()) {
                self.check_camera_at(track, frame)?;
            }
        }
        Ok(())
    }

    /// The error for `field` at `frame`, naming the keyframes it lies between.
    fn frame_error<T>(
        &self,
        frame: f32,
        track: &Track<T>,
        prefix: &str,
        field: &str,
        message: String,
    ) -> Error {
        let between = match track.segment(frame) {
            Some(((j0, f0), (j1, f1))) => format!(
                " (interpolated between {prefix}.keyframe[{j0}] at frame {f0} and \
                 {prefix}.keyframe[{j1}] at frame {f1}, each valid on its own; add a keyframe \
                 in between that avoids this)"
            ),
            None => String::new(),
        };
        Error::invalid(
            &self.source,
            format!("frame {frame}: {prefix}.{field}"),
            format!("{message}{between}"),
        )
    }

    fn check_instance_at(&self, i: usize, track: &Track<TransformKey>, frame: f32) -> Result<()> {
        let key = track.sample(frame);
        check_transform(&key.matrix()).map_err(|m| {
            let name = self
                .instances
                .get(i)
                .and_then(|inst| self.meshes.get(inst.mesh as usize))
                .map_or(String::new(), |mesh| format!(" of mesh '{}'", mesh.name));
            // Lerped finite keys overflow only in the translation; otherwise the scale is
            // what makes a rotation-and-scale matrix singular.
            let (field, value) = if key.translate.is_finite() {
                ("scale", key.scale)
            } else {
                ("translate", key.translate)
            };
            self.frame_error(
                frame,
                track,
                &format!("mesh[{i}]"),
                field,
                format!("{field} {value}{name}: {m}"),
            )
        })
    }

    fn check_light_at(&self, i: usize, track: &Track<Light>, frame: f32) -> Result<()> {
        check_light(&track.sample(frame))
            .map_err(|(field, m)| self.frame_error(frame, track, &format!("light[{i}]"), field, m))
    }

    fn check_camera_at(&self, track: &Track<CameraKey>, frame: f32) -> Result<()> {
        check_camera_key(&track.sample(frame))
            .map_err(|(field, m)| self.frame_error(frame, track, "camera", field, m))
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
        let n = crate::scene::normal_matrix(m) * quad.edge_u.cross(quad.edge_v);
        assert!(n.normalize().abs_diff_eq(u.cross(v).normalize(), 1e-6));
    }
}
