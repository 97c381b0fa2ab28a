//! Exclusive prefix sums of u32 counts on the GPU (`wgsl/prefix_sum.wgsl`, one workgroup):
//! the offsets of the bins that the counting passes of splat binning (tiles) and of the
//! neighbour grid (cells) fill.

use super::GpuContext;
use super::pipeline::{Binding, ComputePass};
use crate::Result;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PrefixSumParams {
    count: u32,
    _pad: [u32; 3],
}

/// The prefix-sum pipeline.
pub struct PrefixSumPass {
    pass: std::sync::Arc<ComputePass>,
}

impl PrefixSumPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            pass: ComputePass::new(
                ctx,
                "prefix_sum.wgsl",
                &[Uniform, StorageRead, StorageReadWrite],
            )?,
        })
    }

    /// Records, into `enc`, `offsets[i] = counts[0] + ... + counts[i - 1]` for
    /// `i <= count` (`offsets` holds `count + 1` u32: the total last).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &wgpu::BindGroup,
        counts: &wgpu::Buffer,
        offsets: &wgpu::Buffer,
        count: u32,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let params = ctx.uniform_buffer(
            "prefix sum params",
            &PrefixSumParams {
                count,
                _pad: [0; 3],
            },
        );
        let bind = self.pass.bind(ctx, &[&params, counts, offsets]);
        self.pass.record(enc, scene, &bind, [1, 1, 1], timestamps);
    }
}
