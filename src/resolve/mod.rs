//! Resolve (`wgsl/resolve.wgsl`): normalises the splat sums into reflected indirect light
//! and adds it to the direct image.

use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass, image_groups};
use crate::gpu::scene_buffers::GpuScene;
use crate::splat::SplatBuffer;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ResolveParams {
    width: u32,
    height: u32,
    _pad: [u32; 2],
}

/// The resolve pass.
pub struct ResolvePass {
    pass: ComputePass,
}

impl ResolvePass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            pass: ComputePass::new(
                ctx,
                "resolve.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                ],
            )?,
        })
    }

    /// Adds `albedo / pi * E` to `beauty` in place and writes the indirect image.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        splat: &SplatBuffer,
        albedo: &wgpu::Buffer,
        beauty: &wgpu::Buffer,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<wgpu::Buffer> {
        let indirect = ctx.storage_buffer_sized(
            "indirect",
            u64::from(splat.width) * u64::from(splat.height) * 16,
        )?;
        let params = ctx.uniform_buffer(
            "resolve params",
            &ResolveParams {
                width: splat.width,
                height: splat.height,
                _pad: [0; 2],
            },
        );
        let bind = self
            .pass
            .bind(ctx, &[&params, &splat.sums, albedo, beauty, &indirect]);
        self.pass.record(
            encoder,
            &scene.bind_group,
            &bind,
            image_groups(splat.width, splat.height),
            timestamps,
        );
        Ok(indirect)
    }
}
