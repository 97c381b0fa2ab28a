//! Small helpers for creating, filling and reading back buffers.

use super::GpuContext;
use crate::{Error, Result};
use wgpu::util::DeviceExt;

impl GpuContext {
    /// Creates a storage buffer holding `data`: at least one zeroed `T` and 16 bytes, so
    /// that an empty table stays bindable as `array<T>` (shaders read only as many
    /// entries as their parameters count).
    /// Fails with [`Error::DeviceLimit`] when it exceeds the device's binding size.
    pub fn storage_buffer<T: bytemuck::Pod>(
        &self,
        label: &str,
        data: &[T],
    ) -> Result<wgpu::Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        self.check_binding_size(label, bytes.len() as u64)?;
        let least = std::mem::size_of::<T>().max(16);
        let mut padded;
        let contents = if bytes.len() < least {
            padded = bytes.to_vec();
            padded.resize(least, 0);
            &padded[..]
        } else {
            bytes
        };
        Ok(self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            }))
    }

    /// Creates an uninitialised (zeroed) storage buffer of `size` bytes.
    pub fn storage_buffer_sized(&self, label: &str, size: u64) -> Result<wgpu::Buffer> {
        self.check_binding_size(label, size)?;
        Ok(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        }))
    }

    /// Creates the two buffers of a work list (`wgsl/shared/work_list.wgsl`) with room for
    /// `capacity` items: the list (a count, then the items; created zeroed, so empty) and
    /// the indirect dispatch size its items raise (x y z, starting at 0 1 1).
    pub fn work_list(&self, label: &str, capacity: u64) -> Result<(wgpu::Buffer, wgpu::Buffer)> {
        let list = self.storage_buffer_sized(label, 4 + capacity * 4)?;
        let groups = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(&[0u32, 1, 1]),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
            });
        Ok((list, groups))
    }

    /// Creates a uniform buffer holding one `T`.
    pub fn uniform_buffer<T: bytemuck::Pod>(&self, label: &str, value: &T) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::bytes_of(value),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
    }

    /// Errors if a binding of `size` bytes would exceed the device limits.
    pub fn check_binding_size(&self, label: &str, size: u64) -> Result<()> {
        let max = self.max_binding_size();
        if size > max {
            return Err(Error::DeviceLimit(format!(
                "{label} needs {} MiB in one storage buffer; this device allows {} MiB",
                size.div_ceil(1 << 20),
                max >> 20
            )));
        }
        Ok(())
    }

    /// Copies a whole buffer back to the CPU (waits for the GPU).
    pub fn read_buffer<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer) -> Result<Vec<T>> {
        let mut all = self.read_buffers::<T>(&[buffer])?;
        Ok(all.pop().unwrap_or_default())
    }

    /// Copies several buffers back with one submission and one wait, in order.
    pub fn read_buffers<T: bytemuck::Pod>(&self, buffers: &[&wgpu::Buffer]) -> Result<Vec<Vec<T>>> {
        let whole: Vec<_> = buffers.iter().map(|&b| (b, 0..b.size())).collect();
        self.read_buffer_ranges(&whole)
    }

    /// Copies byte ranges of buffers back with one submission and one wait, in order
    /// (non-empty ranges whose ends are multiples of 4 bytes).
    pub fn read_buffer_ranges<T: bytemuck::Pod>(
        &self,
        ranges: &[(&wgpu::Buffer, std::ops::Range<u64>)],
    ) -> Result<Vec<Vec<T>>> {
        let mut enc = self.device.create_command_encoder(&Default::default());
        let staging: Vec<wgpu::Buffer> = ranges
            .iter()
            .map(|(b, range)| {
                let size = range.end.saturating_sub(range.start).max(4);
                let s = self.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("readback"),
                    size,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                if range.end > range.start {
                    enc.copy_buffer_to_buffer(b, range.start, &s, 0, size);
                }
                s
            })
            .collect();
        self.queue.submit([enc.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        for s in &staging {
            let tx = tx.clone();
            s.slice(..).map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        }
        drop(tx);
        self.wait()?;
        for _ in &staging {
            rx.recv()
                .map_err(|_| Error::Gpu("readback was cancelled".into()))?
                .map_err(|e| Error::Gpu(format!("readback failed: {e}")))?;
        }
        staging
            .iter()
            .map(|s| {
                let data = {
                    let view = s
                        .slice(..)
                        .get_mapped_range()
                        .map_err(|e| Error::Gpu(format!("readback mapping: {e}")))?;
                    let n = view.len() / std::mem::size_of::<T>();
                    bytemuck::cast_slice::<u8, T>(&view[..n * std::mem::size_of::<T>()]).to_vec()
                };
                s.unmap();
                Ok(data)
            })
            .collect()
    }
}
