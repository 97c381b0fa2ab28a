//! Glossy indirect light (issue 18): the first-bounce indirect light that pixels with a
//! glossy lobe ([`crate::scene::GlossyLobe`]) reflect through it, by importance-sampled
//! Monte Carlo (`wgsl/glossy_indirect.wgsl`, algorithms.md 2.6): `samples` lobe directions
//! per pixel, each hit shaded with direct light. The resolve adds it to the Lambertian
//! indirect light from the irradiance cache. The seeds shade lobes too sharp for the
//! radiance cache this way; radiance records (HSH, [`crate::hsh`]) will take over the
//! low-frequency ones. The CPU mirror is `reference::cpu::glossy_indirect` (the CPU
//! references sit above the passes they mirror).

use crate::Result;
use crate::gpu::context::max_samples_per_dispatch;
use crate::gpu::pipeline::{Binding, ComputePass, image_groups};
use crate::gpu::{GpuContext, GpuScene};
use crate::visibility::VisibilityBuffer;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GlossyParams {
    sample_begin: u32,
    sample_end: u32,
    samples: u32,
    _pad: u32,
}

/// The glossy indirect pass.
pub struct GlossyIndirectPass {
    pass: ComputePass,
}

impl GlossyIndirectPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            pass: ComputePass::new(
                ctx,
                "glossy_indirect.wgsl",
                &[Uniform, StorageRead, Uniform, StorageReadWrite],
            )?,
        })
    }

    /// Records the pass for a visibility buffer: a buffer of RGBA f32 per pixel, the glossy
    /// indirect radiance (zero where a pixel has no glossy lobe).
    pub fn record(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        samples: u32,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<wgpu::Buffer> {
        let out = ctx.storage_buffer_sized(
            "glossy indirect",
            u64::from(vis.width) * u64::from(vis.height) * 16,
        )?;
        let samples = samples.max(1);
        // Samples per dispatch: each traces a lobe ray and its hit's shadow rays.
        let per_dispatch =
            max_samples_per_dispatch(scene.info.max_shadow_rays(scene.info.light_samples.max(1)));
        let mut begin = 0;
        while begin < samples {
            let end = (begin + per_dispatch).min(samples);
            // The timer spans every dispatch: its start on the first, its end on the last.
            let first_or_last = begin == 0 || end == samples;
            let stamps = timestamps.as_ref().filter(|_| first_or_last).map(|t| {
                wgpu::ComputePassTimestampWrites {
                    query_set: t.query_set,
                    beginning_of_pass_write_index: if begin == 0 {
                        t.beginning_of_pass_write_index
                    } else {
                        None
                    },
                    end_of_pass_write_index: if end == samples {
                        t.end_of_pass_write_index
                    } else {
                        None
                    },
                }
            });
            let params = ctx.uniform_buffer(
                "glossy params",
                &GlossyParams {
                    sample_begin: begin,
                    sample_end: end,
                    samples,
                    _pad: 0,
                },
            );
            let bind = self
                .pass
                .bind(ctx, &[&vis.camera_buffer, &vis.samples, &params, &out]);
            self.pass.record(
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
