//! GPU timestamps around compute passes, when the device supports them.

use super::GpuContext;
use crate::Result;

/// The part of one pass's timestamp writes that dispatch `first`/`last` of a pass split
/// over several dispatches records: the start on the first, the end on the last, so the
/// timer spans them all; None for the dispatches between.
pub fn spanning<'a>(
    stamps: Option<&wgpu::ComputePassTimestampWrites<'a>>,
    first: bool,
    last: bool,
) -> Option<wgpu::ComputePassTimestampWrites<'a>> {
    stamps
        .filter(|_| first || last)
        .map(|t| wgpu::ComputePassTimestampWrites {
            query_set: t.query_set,
            beginning_of_pass_write_index: t.beginning_of_pass_write_index.filter(|_| first),
            end_of_pass_write_index: t.end_of_pass_write_index.filter(|_| last),
        })
}

/// Collects begin/end timestamps for up to `capacity` passes of one submission.
pub struct PassTimer {
    set: Option<wgpu::QuerySet>,
    resolve: Option<wgpu::Buffer>,
    names: Vec<&'static str>,
    capacity: u32,
}

impl PassTimer {
    pub fn new(ctx: &GpuContext, capacity: u32) -> Self {
        if !ctx.times_passes() {
            return Self {
                set: None,
                resolve: None,
                names: Vec::new(),
                capacity,
            };
        }
        let set = ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timer"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity * 2,
        });
        let resolve = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pass timer resolve"),
            size: u64::from(capacity) * 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Self {
            set: Some(set),
            resolve: Some(resolve),
            names: Vec::new(),
            capacity,
        }
    }

    /// Timestamp writes for the next pass, named `name` (None when unsupported or full).
    pub fn next(&mut self, name: &'static str) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        if self.names.len() as u32 >= self.capacity {
            return None;
        }
        let i = self.names.len() as u32;
        self.names.push(name);
        self.set
            .as_ref()
            .map(|set| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(2 * i),
                end_of_pass_write_index: Some(2 * i + 1),
            })
    }

    /// Records the query resolve; call before finishing the encoder.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        if self.names.is_empty() {
            return;
        }
        if let (Some(set), Some(buf)) = (&self.set, &self.resolve) {
            encoder.resolve_query_set(set, 0..self.names.len() as u32 * 2, buf, 0);
        }
    }

    /// Per-pass durations in milliseconds (empty when unsupported). Waits for the GPU,
    /// except inside [`GpuContext::deferring_pass_times`], which reads them later: then
    /// the durations come from there, and this returns none.
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<(&'static str, f64)>> {
        let Some(buf) = &self.resolve else {
            return Ok(Vec::new());
        };
        if self.names.is_empty() {
            return Ok(Vec::new());
        }
        {
            let mut deferred = ctx.deferred_times.lock().unwrap_or_else(|p| p.into_inner());
            if let Some(pending) = deferred.as_mut() {
                pending.push(DeferredTimes {
                    names: self.names.clone(),
                    resolved: buf.clone(),
                });
                return Ok(Vec::new());
            }
        }
        let ticks: Vec<u64> = ctx.read_buffer(buf)?;
        let mut times = Vec::with_capacity(self.names.len());
        durations(ctx, &self.names, &ticks, &mut times)?;
        Ok(times)
    }
}

/// Appends `(name, ms)` for each pass of `names` from its begin/end timestamp pair in
/// `ticks`.
fn durations(
    ctx: &GpuContext,
    names: &[&'static str],
    ticks: &[u64],
    out: &mut Vec<(&'static str, f64)>,
) -> Result<()> {
    let period = f64::from(ctx.queue.get_timestamp_period());
    for (i, n) in names.iter().enumerate() {
        let (Some(&begin), Some(&end)) = (ticks.get(2 * i), ticks.get(2 * i + 1)) else {
            return Err(crate::Error::Gpu(
                "internal: pass timer readback incomplete".into(),
            ));
        };
        out.push((*n, end.saturating_sub(begin) as f64 * period * 1e-6));
    }
    Ok(())
}

/// A submitted timer whose timestamps are read later (its resolve buffer and pass names).
pub(crate) struct DeferredTimes {
    names: Vec<&'static str>,
    resolved: wgpu::Buffer,
}

impl GpuContext {
    /// Runs `work` with its pass timers read afterwards, all in one wait, instead of one
    /// wait per submission, and returns its result with their durations (in the order the
    /// timers were read). Placement submits a few passes per round, for tens of rounds: on
    /// a fast GPU each wait is a round trip of launch latency, and they, not the passes,
    /// made the frame's wall time (Sponza on an H200: 100 ms of passes in a 490 ms frame).
    /// Nested calls leave the timers to the outermost.
    pub fn deferring_pass_times<T>(
        &self,
        work: impl FnOnce() -> Result<T>,
    ) -> Result<(T, Vec<(&'static str, f64)>)> {
        let outermost = {
            let mut d = self
                .deferred_times
                .lock()
                .unwrap_or_else(|p| p.into_inner());
            let outermost = d.is_none();
            if outermost {
                *d = Some(Vec::new());
            }
            outermost
        };
        let result = work();
        if !outermost {
            return result.map(|r| (r, Vec::new()));
        }
        let pending = self
            .deferred_times
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
            .unwrap_or_default();
        let r = result?;
        if pending.is_empty() {
            return Ok((r, Vec::new()));
        }
        let buffers: Vec<&wgpu::Buffer> = pending.iter().map(|p| &p.resolved).collect();
        let ticks: Vec<Vec<u64>> = self.read_buffers(&buffers)?;
        let mut times = Vec::new();
        for (p, t) in pending.iter().zip(&ticks) {
            durations(self, &p.names, t, &mut times)?;
        }
        Ok((r, times))
    }
}
