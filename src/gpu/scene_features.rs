//! What a scene's rays meet, for pipelines compiled for one scene: the plane passes leave out
//! the shading of the kinds of light the scene has not, the instance transforms of a scene
//! whose rays never leave one BLAS, the texture lookup of a scene without textures and the
//! bounce cache's lookup when there is one bounce (`SCENE_FEATURES` in
//! `wgsl/shared/scene.wgsl`).
//!
//! Lavapipe (Mesa 22.3) runs both sides of every branch with lanes masked off, so code a
//! scene never takes still costs its instructions on every pass through it. Leaving the
//! other light kinds out made Sponza's plane pass 19 % and its refinement 23 % faster (400x400,
//! a sun alone); leaving the TLAS leaf's instance loads out of the traversal loop, the nave's
//! planes and refinement 9 %; the texture and bounce-cache lookups, a further 9 %. The same
//! bytes every time (docs/results.md).

use super::scene_buffers::{LIGHT_POINT, LIGHT_RECT, LIGHT_SPOT, LIGHT_SUN};
use crate::scene::{Light, Scene};

/// A set of scene features: bit `1 << kind` for each kind of light as the GPU numbers them
/// (`scene_buffers::LIGHT_*`), one bit for the environment (a map, or a constant that is not
/// black), one for instances (rays may reach a TLAS leaf and enter an instance's object
/// space), one for textured materials, and one for a surface bounce cache (`--bounces`
/// above 1: hits reflect more than their direct light).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneFeatures(u32);

impl SceneFeatures {
    /// Every feature: what a pipeline that does not know its scene is compiled for.
    pub const ALL: SceneFeatures = SceneFeatures(u32::MAX);

    /// The environment's bit (`ENVIRONMENT_KIND_BIT` in WGSL).
    const ENVIRONMENT_BIT: u32 = 1 << 4;

    /// The instances' bit (`FEATURE_INSTANCES` in WGSL): without it, traversal starts in the
    /// BLAS of the scene's one instance, in world space, and never meets a TLAS leaf
    /// (`bvh::SceneBvh::traversal_start`).
    const INSTANCES_BIT: u32 = 1 << 5;

    /// The textures' bit (`FEATURE_TEXTURES` in WGSL): some material's albedo is a texture.
    const TEXTURES_BIT: u32 = 1 << 6;

    /// The bounce cache's bit (`FEATURE_BOUNCE_CACHE` in WGSL): the frame's surface bounce
    /// cache is not empty, so hits look their indirect irradiance up in it.
    const BOUNCE_CACHE_BIT: u32 = 1 << 7;

    /// The features of `scene`, over every frame of its animation: its kinds of light (an
    /// animation keeps them), instances unless it is one instance placed as modelled that no
    /// keyframe moves, and textures if a material has one. Not the bounce cache, which the
    /// render settings make ([`Self::with_bounce_cache`]).
    pub fn of(scene: &Scene) -> SceneFeatures {
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
        let one_still_instance = matches!(
            scene.instances.as_slice(),
            [only] if only.transform == glam::Mat4::IDENTITY
        ) && scene.animation.is_none();
        if !one_still_instance {
            bits |= Self::INSTANCES_BIT;
        }
        if scene.materials.iter().any(|m| m.albedo_texture.is_some()) {
            bits |= Self::TEXTURES_BIT;
        }
        SceneFeatures(bits)
    }

    /// These features, with the bounce cache added when `reflects` (hits reflect a cache
    /// that is not empty: more than one bounce).
    pub fn with_bounce_cache(self, reflects: bool) -> SceneFeatures {
        if reflects {
            SceneFeatures(self.0 | Self::BOUNCE_CACHE_BIT)
        } else {
            self
        }
    }

    /// These features without the bounce cache: for passes that shade no secondary hit's
    /// indirect light (visibility, direct light), so that one and several bounces share
    /// their pipelines.
    pub fn without_bounce_cache(self) -> SceneFeatures {
        SceneFeatures(self.0 & !Self::BOUNCE_CACHE_BIT)
    }

    /// These features, with instances added when the uploaded BVH's traversal does not start
    /// in a BLAS (what the shaders will meet, whatever the scene description said).
    pub fn with_traversal(self, starts_in_blas: bool) -> SceneFeatures {
        if starts_in_blas {
            self
        } else {
            SceneFeatures(self.0 | Self::INSTANCES_BIT)
        }
    }

    /// Of these features, what a pass that traces rays but shades no hit needs: whether
    /// rays enter instances (the light-map trace).
    pub fn traversal_only(self) -> SceneFeatures {
        SceneFeatures(self.0 & Self::INSTANCES_BIT)
    }

    /// Whether hits are lit by an environment (a map, or a constant that is not black).
    pub fn has_environment(self) -> bool {
        self.0 & Self::ENVIRONMENT_BIT != 0
    }

    /// Whether hits reflect a surface bounce cache (more than one bounce).
    pub fn has_bounce_cache(self) -> bool {
        self.0 & Self::BOUNCE_CACHE_BIT != 0
    }

    /// The bits the shaders' `SCENE_FEATURES` takes.
    pub fn bits(self) -> u32 {
        self.0
    }

    /// Whether every feature in `other` is in this set.
    pub fn contains(self, other: SceneFeatures) -> bool {
        self.0 & other.0 == other.0
    }

    /// The pipeline-overridable constant that compiles a pass for these features.
    pub fn constant(self) -> (&'static str, f64) {
        ("SCENE_FEATURES", f64::from(self.0))
    }

    /// Refuses a scene of features `scene` that a pass compiled for these lacks (its hits
    /// would be shaded without that light, or its rays would not enter its instances):
    /// `pass` names the pass, `build` the constructor that builds it for the scene.
    pub fn require(self, scene: SceneFeatures, pass: &str, build: &str) -> crate::Result<()> {
        if self.contains(scene) {
            return Ok(());
        }
        Err(crate::Error::Usage(format!(
            "this {pass} was compiled for the scene features (light kinds, instances, \
             textures, bounce cache) {:#x} and the scene has {:#x}: build it for the \
             scene's (`{build}`, `SceneFeatures::of`)",
            self.0, scene.0
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::bundled;

    /// What `of` says of a scene decides which code its plane pipelines leave out: a wrong
    /// "no" would shade without that code (and be refused only where the GPU scene says
    /// otherwise), so each rule is checked on its own.
    #[test]
    fn a_scenes_features_follow_its_instances_animation_and_textures() {
        let has = |f: SceneFeatures, bit: u32| f.0 & bit != 0;
        // The nave: one OBJ placed as modelled, lit by the sun.
        let nave = bundled("nave.toml");
        let plain = SceneFeatures::of(&nave);
        assert!(
            !has(plain, SceneFeatures::INSTANCES_BIT),
            "one instance placed as modelled"
        );
        assert!(!has(plain, SceneFeatures::TEXTURES_BIT));
        assert!(!has(plain, SceneFeatures::BOUNCE_CACHE_BIT));
        assert!(has(plain, 1 << LIGHT_SUN));
        assert!(!has(plain, 1 << LIGHT_RECT));
        // A static rect light's quad joins a scene's one static mesh (the Cornell box stays
        // one instance); beside two mesh entries it is an instance of its own.
        let cornell = bundled("cornell-box.toml");
        assert_eq!(cornell.instances.len(), 1);
        let lit = SceneFeatures::of(&cornell);
        assert!(!has(lit, SceneFeatures::INSTANCES_BIT));
        assert!(has(lit, 1 << LIGHT_RECT));
        let cube = bundled("cube-in-box.toml");
        assert_eq!(cube.instances.len(), 3);
        assert!(has(SceneFeatures::of(&cube), SceneFeatures::INSTANCES_BIT));

        let mut moved = nave.clone();
        moved.instances[0].transform = glam::Mat4::from_translation(glam::Vec3::X);
        assert!(has(SceneFeatures::of(&moved), SceneFeatures::INSTANCES_BIT));

        let mut two = nave.clone();
        two.instances.push(two.instances[0].clone());
        assert!(has(SceneFeatures::of(&two), SceneFeatures::INSTANCES_BIT));

        // An animation may move its one instance at a later frame.
        let mut animated = nave.clone();
        animated.animation = bundled("cube-in-box-anim.toml").animation;
        assert!(animated.animation.is_some());
        assert!(has(
            SceneFeatures::of(&animated),
            SceneFeatures::INSTANCES_BIT
        ));

        let mut textured = nave.clone();
        textured.materials[0].albedo_texture = Some(0);
        assert!(has(
            SceneFeatures::of(&textured),
            SceneFeatures::TEXTURES_BIT
        ));

        assert!(has(
            plain.with_bounce_cache(true),
            SceneFeatures::BOUNCE_CACHE_BIT
        ));
    }

    #[test]
    fn instances_bit_follows_the_traversal_start() {
        let f = SceneFeatures(1 << LIGHT_SUN);
        assert_eq!(f.with_traversal(true), f);
        assert!(f.with_traversal(false).contains(f));
        assert_ne!(f.with_traversal(false), f);
        // A pipeline without instances refuses a scene that has them, not the reverse.
        assert!(!f.contains(f.with_traversal(false)));
        assert!(f.with_traversal(false).contains(f));
        assert!(SceneFeatures::ALL.contains(f.with_traversal(false)));
        // The same for the bounce cache, which settings add and never remove.
        assert!(!f.contains(f.with_bounce_cache(true)));
        assert_eq!(f.with_bounce_cache(false), f);
        assert_eq!(
            SceneFeatures::ALL.with_bounce_cache(true),
            SceneFeatures::ALL
        );
    }
}
