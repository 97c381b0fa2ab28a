//! A compute pass compiled for one scene's features, which refuses a scene with others.
//!
//! The passes that trace and shade the scene itself (visibility, direct light, glossy
//! indirect light, the path-traced reference) compile their shader for the scene's kinds
//! of light, instances and textures alone ([`SceneFeatures`]): less code for the driver to
//! build and, on lavapipe, to run. Run on a scene with a feature it was not compiled for,
//! such a pass would leave that light out of every pixel, miss the instanced geometry or
//! shade it untextured, silently. [`ScenePass`] is that rule said once: it builds the
//! pipeline and hands it out only for scenes it was built for.

use super::pipeline::{Binding, ComputePass};
use super::{GpuContext, SceneFeatures};
use crate::Result;
use std::sync::Arc;

/// What a scene pass is: its shader, its own bindings, and how its refusal names it.
pub struct ScenePassShader {
    /// The pass's shader in `wgsl/` (entry point `main`).
    pub shader: &'static str,
    /// Its group-1 bindings, in order.
    pub bindings: &'static [Binding],
    /// The pass, as a refusal names it ("direct-light pass").
    pub name: &'static str,
    /// The constructor that builds it for a scene ("DirectLightPass::for_scene").
    pub builder: &'static str,
    /// Whether its hits reflect the surface bounce cache (more than one bounce). A pass
    /// that never does is compiled, and checked, without that feature.
    pub reads_bounce_cache: bool,
}

/// A compute pass compiled for scenes of some features ([`ScenePass::compile`]); it hands
/// out its pipeline only for such scenes ([`ScenePass::for_scene`]).
pub struct ScenePass {
    pass: Arc<ComputePass>,
    /// What the pipeline was compiled for.
    features: SceneFeatures,
    shader: &'static ScenePassShader,
}

impl ScenePass {
    /// Compiles `shader` for scenes of `features` alone; built once per device and set of
    /// features ([`ComputePass::with_constants`]).
    pub fn compile(
        ctx: &GpuContext,
        shader: &'static ScenePassShader,
        features: SceneFeatures,
    ) -> Result<Self> {
        let features = shader.relevant(features);
        Ok(Self {
            pass: ComputePass::with_constants(
                ctx,
                shader.shader,
                shader.bindings,
                &[features.constant()],
            )?,
            features,
            shader,
        })
    }

    /// The pass, for a scene of features `scene`; refused (a usage error naming the pass
    /// and the constructor to build it with) where the scene has a feature the pass was
    /// not compiled for.
    pub fn for_scene(&self, scene: SceneFeatures) -> Result<&ComputePass> {
        self.features.require(
            self.shader.relevant(scene),
            self.shader.name,
            self.shader.builder,
        )?;
        Ok(&self.pass)
    }
}

impl ScenePassShader {
    /// The part of `features` that the pass's code depends on.
    fn relevant(&self, features: SceneFeatures) -> SceneFeatures {
        if self.reads_bounce_cache {
            features
        } else {
            features.without_bounce_cache()
        }
    }
}
