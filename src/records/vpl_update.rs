//! Temporal instant caching's update of VPL records (seed 003 Algorithm 1; the frame loop
//! is `temporal::instant`, a layer above): which rays to trace again, tracing them
//! together, then every record summed anew from its visibility bits.
//!
//! 1. `vpl_update_select.wgsl` (a workgroup per record): a ray is listed where its VPL
//!    changed or its segment meets a moved instance's box at either frame; every other ray
//!    keeps its bit.
//! 2. `vpl_update_trace.wgsl` (an invocation per listed ray): rays that reach their VPL
//!    set their bit (u32 atomic OR: the bits do not depend on the list's order).
//! 3. `vpl_gather.wgsl` in update mode with nothing stale: E and its gradients summed
//!    anew from the bits, R kept.
//!
//! Listing before tracing keeps the traced rays together: traced in the records'
//! workgroups, a few rays scattered among 64 lanes cost nearly as much as tracing all of
//! them (measured on cube in a box: 14 % of the rays for half the time of a full gather).

use super::vpl_gather::{FrameChange, GatherTarget, VplGatherPass, scene_vpls};
use super::{CacheSettings, RecordCache};
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};

/// Mirror of WGSL `SelectParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SelectParams {
    count: u32,
    visibility_words: u32,
    vpl_count: u32,
    moving_count: u32,
    movers_lo: [f32; 4],
    movers_hi: [f32; 4],
    capacity: u32,
    first: u32,
    _pad: [u32; 2],
}

/// Mirror of WGSL `TraceParams` (vpl_update_trace.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct TraceParams {
    first: u32,
    count: u32,
    visibility_words: u32,
    _pad: u32,
}

/// Rays one trace dispatch takes (65,535 workgroups of 64).
const RAYS_PER_DISPATCH: u32 = 65_535 * 64;

/// What an update traced and reused.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UpdateCounts {
    pub traced: u64,
    pub reused: u64,
}

/// The three passes of an update.
pub struct VplUpdatePass {
    select: std::sync::Arc<ComputePass>,
    trace: std::sync::Arc<ComputePass>,
    gather: VplGatherPass,
}

impl VplUpdatePass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            select: ComputePass::new(
                ctx,
                "vpl_update_select.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                ],
            )?,
            trace: ComputePass::new(
                ctx,
                "vpl_update_trace.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageRead,
                ],
            )?,
            gather: VplGatherPass::new(ctx)?,
        })
    }

    /// Updates records `0..cache.count` (which keep visibility bits) to `scene`'s VPLs
    /// after `change`, timed as "vpl update: select", "vpl update: trace" and "vpl update"
    /// (the sums) in `times`.
    pub fn run(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        settings: &CacheSettings,
        cache: &RecordCache,
        change: &FrameChange<'_>,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<UpdateCounts> {
        let mut counts = UpdateCounts::default();
        if cache.count == 0 {
            return Ok(counts);
        }
        if cache.visibility_words == 0 {
            return Err(Error::Usage(
                "internal: an update needs records that keep their visibility bits".into(),
            ));
        }
        let vpls = scene_vpls(scene)?;
        let changed = ctx.storage_buffer("vpl changed bits", change.changed)?;
        let moving = ctx.storage_buffer("moving bounds", change.moving)?;
        // The ray list holds every ray of a batch of records (or what one binding holds).
        let per_record = u64::from(vpls.count.max(1));
        let capacity = (ctx.max_binding_size() / 8).min(u64::from(u32::MAX));
        let batch = (capacity / per_record).clamp(1, 65_535) as u32;
        let list_len = (u64::from(batch.min(cache.count)) * per_record).min(capacity);
        let rays = ctx.storage_buffer_sized("vpl update rays", list_len * 8)?;
        let mut first = 0;
        while first < cache.count {
            let n = (cache.count - first).min(batch);
            let counters = ctx.storage_buffer("vpl update counters", &[0u32; 4])?;
            let params = ctx.uniform_buffer(
                "vpl select params",
                &SelectParams {
                    count: cache.count,
                    visibility_words: cache.visibility_words,
                    vpl_count: vpls.count,
                    moving_count: change.moving_count,
                    movers_lo: change.movers_lo,
                    movers_hi: change.movers_hi,
                    capacity: list_len as u32,
                    first,
                    _pad: [0; 2],
                },
            );
            let bind = self.select.bind(
                ctx,
                &[
                    &params,
                    &cache.buffer,
                    &vpls.buffer,
                    &cache.visibility,
                    &changed,
                    &moving,
                    &rays,
                    &counters,
                ],
            );
            let mut timer = PassTimer::new(ctx, 1);
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            self.select.record(
                &mut enc,
                &scene.bind_group,
                &bind,
                [n, 1, 1],
                timer.next("vpl update: select"),
            );
            timer.resolve(&mut enc);
            ctx.queue.submit([enc.finish()]);
            times.extend(timer.read(ctx)?);
            let counted: Vec<u32> = ctx.read_buffer(&counters)?;
            let listed = counted[0];
            if u64::from(listed) > list_len {
                return Err(Error::Gpu(format!(
                    "internal: {listed} rays listed for a list of {list_len}"
                )));
            }
            counts.traced += u64::from(listed);
            counts.reused += u64::from(counted[1]);
            let mut timer = PassTimer::new(ctx, 1);
            let stamps = timer.next("vpl update: trace");
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            let dispatches = listed.div_ceil(RAYS_PER_DISPATCH);
            for d in 0..dispatches {
                let begin = d * RAYS_PER_DISPATCH;
                let count = (listed - begin).min(RAYS_PER_DISPATCH);
                let params = ctx.uniform_buffer(
                    "vpl trace params",
                    &TraceParams {
                        first: begin,
                        count,
                        visibility_words: cache.visibility_words,
                        _pad: 0,
                    },
                );
                let bind = self.trace.bind(
                    ctx,
                    &[
                        &params,
                        &cache.buffer,
                        &vpls.buffer,
                        &cache.visibility,
                        &rays,
                    ],
                );
                self.trace.record(
                    &mut enc,
                    &scene.bind_group,
                    &bind,
                    [count.div_ceil(64), 1, 1],
                    crate::gpu::timer::spanning(stamps.as_ref(), d == 0, d + 1 == dispatches),
                );
            }
            timer.resolve(&mut enc);
            ctx.queue.submit([enc.finish()]);
            times.extend(timer.read(ctx)?);
            first += n;
        }
        // Every bit is now this frame's: sum the records from them.
        let words = vec![0u32; cache.visibility_words as usize];
        let nothing = FrameChange {
            changed: &words,
            moving: &[0; 160],
            moving_count: 0,
            movers_lo: [0.0; 4],
            movers_hi: [0.0; 4],
        };
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.gather.update(
            ctx,
            &mut enc,
            scene,
            settings,
            cache.count,
            &GatherTarget::of(cache),
            &nothing,
            &mut timer,
        )?;
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(counts)
    }
}
