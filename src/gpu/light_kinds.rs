//! Which kinds of light a scene has, for pipelines compiled for one scene: the plane passes
//! leave out the shading of the kinds it has not (`SHADED_LIGHT_KINDS` in
//! `wgsl/shared/shading.wgsl`; Sponza 400x400, a sun alone: plane pass 19 % and refinement
//! 23 % faster, the same bytes).

use super::scene_buffers::{LIGHT_POINT, LIGHT_RECT, LIGHT_SPOT, LIGHT_SUN};
use crate::scene::{Light, Scene};

/// A set of light kinds: bit `1 << kind` for each kind as the GPU numbers them
/// (`scene_buffers::LIGHT_*`), and one bit for the environment (a map, or a constant that is
/// not black).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightKinds(u32);

impl LightKinds {
    /// Every kind: what a pipeline that does not know its scene shades.
    pub const ALL: LightKinds = LightKinds(u32::MAX);

    /// The environment's bit (`ENVIRONMENT_KIND_BIT` in WGSL).
    const ENVIRONMENT_BIT: u32 = 1 << 4;

    /// The kinds `scene` has (an animation's lights keep their kinds over its frames).
    pub fn of(scene: &Scene) -> LightKinds {
        let mut bits = 0;
        for light in &scene.lights {
            bits |= 1
                << match light {
                    Light::Point { .. } => LIGHT_POINT,
                    Light::Spot { .. } => LIGHT_SPOT,
                    Light::Rect { .. } => LIGHT_RECT,
                    Light::Sun { .. } => LIGHT_SUN,
                };
        }
        if scene.environment != glam::Vec3::ZERO || scene.environment_map.is_some() {
            bits |= Self::ENVIRONMENT_BIT;
        }
        LightKinds(bits)
    }

    /// The bits the shaders' `SHADED_LIGHT_KINDS` takes.
    pub fn bits(self) -> u32 {
        self.0
    }

    /// Whether every kind in `other` is in this set.
    pub fn contains(self, other: LightKinds) -> bool {
        self.0 & other.0 == other.0
    }

    /// The pipeline-overridable constant that compiles a pass for these kinds.
    pub fn constant(self) -> (&'static str, f64) {
        ("SHADED_LIGHT_KINDS", f64::from(self.0))
    }
}
