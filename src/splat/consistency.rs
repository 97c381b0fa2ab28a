//! A widened gather checked against the default one (`wgsl/splat_consistency.wgsl`;
//! [`crate::records::noise_widening`], `CacheSettings::widening_tolerance`): per pixel, the
//! widened gather's sums stay where their irradiance is within the tolerance of the default
//! gather's, and the default's replace them elsewhere. [`super::reference::keep_consistent`]
//! is the same rule on the CPU.

use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass, linear_groups};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use bytemuck::{Pod, Zeroable};

use super::SplatBuffer;

/// Mirror of WGSL `ConsistencyParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ConsistencyParams {
    pixels: u32,
    tolerance: f32,
    _pad: [u32; 2],
}

/// The pass of `wgsl/splat_consistency.wgsl`.
pub struct ConsistencyPass {
    pass: std::sync::Arc<ComputePass>,
}

impl ConsistencyPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            pass: ComputePass::new(
                ctx,
                "splat_consistency.wgsl",
                &[Uniform, StorageRead, StorageReadWrite, StorageReadWrite],
            )?,
        })
    }

    /// Keeps `wide`'s sums at the pixels where their irradiance (channel sum) is within
    /// `tolerance` (relative) of `narrow`'s and where `narrow` has none; elsewhere copies
    /// `narrow`'s into `wide`. Returns how many pixels kept `wide`'s sums where both had
    /// some. The two buffers are of the same image.
    pub fn keep_consistent(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        narrow: &SplatBuffer,
        wide: &SplatBuffer,
        tolerance: f32,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<u32> {
        let pixels = narrow.width * narrow.height;
        let params = ctx.uniform_buffer(
            "consistency params",
            &ConsistencyParams {
                pixels,
                tolerance,
                _pad: [0; 2],
            },
        );
        let kept = ctx.storage_buffer("consistency kept", &[0u32])?;
        let bind = self
            .pass
            .bind(ctx, &[&params, &narrow.sums, &wide.sums, &kept]);
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.pass.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            linear_groups(ctx, pixels),
            timer.next("splat: consistency"),
        );
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        let kept: Vec<u32> = ctx.read_buffer(&kept)?;
        Ok(kept.first().copied().unwrap_or(0))
    }
}
