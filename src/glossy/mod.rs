//! Glossy indirect light (issue 18): the first-bounce indirect light that pixels with a
//! glossy lobe ([`crate::scene::GlossyLobe`]) reflect through it, by importance-sampled
//! Monte Carlo (`wgsl/glossy_indirect.wgsl`, algorithms.md 2.6): `samples` lobe directions
//! per pixel, each hit shaded with direct light. The resolve adds it to the Lambertian
//! indirect light from the irradiance cache. The seeds shade lobes too sharp for the
//! radiance cache this way; pixels that radiance records cover (`splat/radiance.rs`) take
//! the records' value instead. The CPU mirror is `reference::cpu::glossy_indirect` (the
//! CPU references sit above the passes they mirror).

use crate::Result;
use crate::gpu::context::max_samples_per_dispatch;
use crate::gpu::pipeline::{Binding, image_groups};
use crate::gpu::scene_pass::{ScenePass, ScenePassShader};
use crate::gpu::timer::spanning;
use crate::gpu::{GpuContext, GpuScene, SceneFeatures};
use crate::visibility::VisibilityBuffer;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GlossyParams {
    sample_begin: u32,
    sample_end: u32,
    samples: u32,
    use_radiance: u32,
    monte_carlo: u32,
    _pad: [u32; 3],
}

/// The glossy indirect pass.
pub struct GlossyIndirectPass {
    pass: ScenePass,
}

/// The glossy pass's shader and bindings: the camera, the visibility buffer, its
/// parameters, its output, the radiance splat and the bounce cache, which its lobe rays'
/// hits reflect.
static SHADER: ScenePassShader = ScenePassShader {
    shader: "glossy_indirect.wgsl",
    bindings: &[
        Binding::Uniform,
        Binding::StorageRead,
        Binding::Uniform,
        Binding::StorageReadWrite,
        Binding::StorageRead,
        Binding::StorageRead,
    ],
    name: "glossy indirect pass",
    builder: "GlossyIndirectPass::for_scene",
    reads_bounce_cache: true,
};

impl GlossyIndirectPass {
    /// The pass for any scene.
    /// [`Self::for_scene`] compiles it for one scene's features alone (`SceneFeatures::of`),
    /// which lavapipe builds and runs faster: an engine that knows its scene should use that.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Self::for_scene(ctx, SceneFeatures::ALL)
    }

    /// The pass compiled for scenes of `features` alone (their kinds of light, instances,
    /// textures, bounce cache: `gpu::SceneFeatures`); built once per device and set of
    /// features.
    pub fn for_scene(ctx: &GpuContext, features: SceneFeatures) -> Result<Self> {
        Ok(Self {
            pass: ScenePass::compile(ctx, &SHADER, features)?,
        })
    }

    /// Records the pass for a visibility buffer: a buffer of RGBA f32 per pixel, the glossy
    /// indirect radiance (zero where a pixel has no glossy lobe). With `radiance` (the
    /// radiance splat's `(sum w L, sum w)` per pixel), pixels it covers take its mean and
    /// trace nothing; with `radiance_covers_all` no pixel traces lobe rays (the radiance
    /// records cover every glossy pixel: one dispatch copies their values).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        samples: u32,
        radiance: Option<&wgpu::Buffer>,
        radiance_covers_all: bool,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<wgpu::Buffer> {
        let pass = self.pass.for_scene(scene.features())?;
        let placeholder;
        let radiance_buf = match radiance {
            Some(b) => b,
            None => {
                placeholder = ctx.storage_buffer_sized("no radiance splat", 16)?;
                &placeholder
            }
        };
        let out = ctx.storage_buffer_sized(
            "glossy indirect",
            u64::from(vis.width) * u64::from(vis.height) * 16,
        )?;
        let samples = samples.max(1);
        // Samples per dispatch: each traces a lobe ray and its hit's shadow rays.
        let monte_carlo = !(radiance.is_some() && radiance_covers_all);
        let per_dispatch = if monte_carlo {
            max_samples_per_dispatch(scene.info.max_shadow_rays(scene.info.light_samples.max(1)))
        } else {
            samples
        };
        let mut begin = 0;
        while begin < samples {
            let end = (begin + per_dispatch).min(samples);
            let stamps = spanning(timestamps.as_ref(), begin == 0, end == samples);
            let params = ctx.uniform_buffer(
                "glossy params",
                &GlossyParams {
                    sample_begin: begin,
                    sample_end: end,
                    samples,
                    use_radiance: u32::from(radiance.is_some()),
                    monte_carlo: u32::from(monte_carlo),
                    _pad: [0; 3],
                },
            );
            let bind = pass.bind(
                ctx,
                &[
                    &vis.camera_buffer,
                    &vis.samples,
                    &params,
                    &out,
                    radiance_buf,
                    &scene.bounce_cache(),
                ],
            );
            pass.record(
                encoder,
                &scene.bind_group,
                &bind,
                image_groups(vis.width, vis.height),
                stamps,
            );
            begin = end;
        }
        Ok(out)
    }
}
