//! The direct-light pass: shadow rays to every light (area lights and the environment
//! with a deterministic low-discrepancy sequence), textured diffuse albedo, visible
//! emitters. [`reference`](mod@reference) is its plain-Rust counterpart used by tests.

pub mod reference;

use crate::Result;
use crate::gpu::pipeline::{Binding, image_groups};
use crate::gpu::scene_pass::{ScenePass, ScenePassShader};
use crate::gpu::{GpuContext, GpuScene, SceneFeatures};
use crate::visibility::VisibilityBuffer;

/// Per-pixel outputs of the direct pass, resident on the GPU (RGBA f32 each).
pub struct DirectOutput {
    /// Emission + reflected direct light (environment on background pixels).
    pub beauty: wgpu::Buffer,
    /// Diffuse albedo (textured), zero on background pixels.
    pub albedo: wgpu::Buffer,
    /// Reflected direct light only.
    pub direct: wgpu::Buffer,
}

/// The direct-light pass (`wgsl/direct_light.wgsl`).
pub struct DirectLightPass {
    pass: ScenePass,
}

/// The direct-light pass's shader and bindings: the camera, the visibility buffer, and
/// the beauty, albedo and direct outputs. Its hits are not shaded with the bounce cache.
static SHADER: ScenePassShader = ScenePassShader {
    shader: "direct_light.wgsl",
    bindings: &[
        Binding::Uniform,
        Binding::StorageRead,
        Binding::StorageReadWrite,
        Binding::StorageReadWrite,
        Binding::StorageReadWrite,
    ],
    name: "direct-light pass",
    builder: "DirectLightPass::for_scene",
    reads_bounce_cache: false,
};

impl DirectLightPass {
    /// The pass for any scene.
    /// [`Self::for_scene`] compiles it for one scene's features alone (`SceneFeatures::of`),
    /// which lavapipe builds and runs faster: an engine that knows its scene should use that.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Self::for_scene(ctx, SceneFeatures::ALL)
    }

    /// The pass compiled for scenes of `features` alone (their kinds of light, instances and
    /// textures: `gpu::SceneFeatures`); built once per device and set of features.
    pub fn for_scene(ctx: &GpuContext, features: SceneFeatures) -> Result<Self> {
        Ok(Self {
            pass: ScenePass::compile(ctx, &SHADER, features)?,
        })
    }

    /// Records the pass for a visibility buffer.
    pub fn record(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<DirectOutput> {
        let pass = self.pass.for_scene(scene.features())?;
        let bytes = u64::from(vis.width) * u64::from(vis.height) * 16;
        let out = DirectOutput {
            beauty: ctx.storage_buffer_sized("beauty", bytes)?,
            albedo: ctx.storage_buffer_sized("albedo", bytes)?,
            direct: ctx.storage_buffer_sized("direct", bytes)?,
        };
        let bind = pass.bind(
            ctx,
            &[
                &vis.camera_buffer,
                &vis.samples,
                &out.beauty,
                &out.albedo,
                &out.direct,
            ],
        );
        pass.record(
            encoder,
            &scene.bind_group,
            &bind,
            image_groups(vis.width, vis.height),
            timestamps,
        );
        Ok(out)
    }
}
