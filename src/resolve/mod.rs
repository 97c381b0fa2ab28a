//! Resolve (`wgsl/resolve.wgsl`): normalises the splat sums into reflected indirect light,
//! adds the glossy lobes' indirect light ([`crate::glossy`]) and adds both to the direct
//! image.

use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::splat::SplatBuffer;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ResolveParams {
    width: u32,
    height: u32,
    has_glossy: u32,
    _pad: u32,
}

/// Where the glossy lobes' indirect light comes from.
#[derive(Clone, Copy)]
pub enum GlossyInput<'a> {
    /// No glossy materials.
    None,
    /// The glossy indirect pass's output (`glossy_indirect.wgsl`).
    Indirect(&'a wgpu::Buffer),
    /// The radiance splat's `(specular * sum w L, sum w)`, when radiance records cover every
    /// glossy pixel: the resolve divides (what the glossy pass would only have copied).
    RadianceSums(&'a wgpu::Buffer),
}

/// The resolve pass.
pub struct ResolvePass {
    pass: std::sync::Arc<ComputePass>,
    /// Bound as the glossy input when a frame has none (the shader does not read it).
    no_glossy: wgpu::Buffer,
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
                    StorageRead,
                ],
            )?,
            no_glossy: ctx.storage_buffer_sized("no glossy indirect", 16)?,
        })
    }

    /// Adds `albedo / pi * E + glossy` to `beauty` in place and writes the indirect image.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        splat: &SplatBuffer,
        albedo: &wgpu::Buffer,
        beauty: &wgpu::Buffer,
        glossy: GlossyInput<'_>,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<wgpu::Buffer> {
        let (has_glossy, glossy) = match glossy {
            GlossyInput::None => (0, &self.no_glossy),
            GlossyInput::Indirect(b) => (1, b),
            GlossyInput::RadianceSums(b) => (2, b),
        };
        let indirect = ctx.storage_buffer_sized(
            "indirect",
            u64::from(splat.width) * u64::from(splat.height) * 16,
        )?;
        let params = ctx.uniform_buffer(
            "resolve params",
            &ResolveParams {
                width: splat.width,
                height: splat.height,
                has_glossy,
                _pad: 0,
            },
        );
        let bind = self.pass.bind(
            ctx,
            &[&params, &splat.sums, albedo, beauty, &indirect, glossy],
        );
        self.pass.record(
            encoder,
            &scene.bind_group,
            &bind,
            [splat.width.div_ceil(32), splat.height.div_ceil(8), 1],
            timestamps,
        );
        Ok(indirect)
    }
}
