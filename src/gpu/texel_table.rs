//! A table of 16-byte rows read through texel fetches: a copy of a storage buffer in an
//! `Rgba32Uint` texture, one texel a row, [`TEXEL_TABLE_WIDTH`] texels a texture row
//! (`wgsl/shared/texel_table.wgsl` reads it).
//!
//! It exists for the hosts where [`TriangleFetch::Texture`](super::TriangleFetch) holds:
//! lavapipe without AVX-512 loads a storage buffer lane by lane, with a stall for every
//! lane's every component, while a texel fetch is a gather in straight-line code
//! (`gpu::triangle_fetch`). The passes that read a table many times a lane read this copy
//! there: the record reduction and refinement's selection (every plane sample and plane
//! pixel), the splat gathers (each contributing record). The copy itself is a memcpy on
//! lavapipe.

use super::GpuContext;
use crate::{Error, Result};

/// The pipeline constant that makes a pass read its tables from texel tables
/// (`wgsl/shared/texel_table.wgsl`), set with the triangle fetch.
pub const TABLE_TEXELS_CONSTANT: &str = "TABLE_TEXELS";

/// Texels a texture row: `texel_table.wgsl`'s `TEXEL_TABLE_WIDTH`. 2048 rows of 16 bytes
/// are 32 KiB, a multiple of the 256 bytes a buffer-to-texture copy needs a row.
pub const TEXEL_TABLE_WIDTH: u32 = 2048;

/// A texture that holds `capacity` 16-byte rows of a table (see the module doc).
pub struct TexelTable {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    capacity: u64,
}

impl TexelTable {
    /// A table of room for `rows` rows (at least one), named `label`; a device-limit error
    /// where the texture would be taller than the device allows.
    pub fn new(ctx: &GpuContext, label: &str, rows: u64) -> Result<Self> {
        let height = rows.max(1).div_ceil(u64::from(TEXEL_TABLE_WIDTH));
        let max = ctx.device.limits().max_texture_dimension_2d;
        if height > u64::from(max) {
            return Err(Error::DeviceLimit(format!(
                "{label}: {rows} rows need a {TEXEL_TABLE_WIDTH}x{height} texture; this \
                 device allows {max} rows"
            )));
        }
        let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: TEXEL_TABLE_WIDTH,
                height: height as u32,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Uint,
            // COPY_SRC: to read it back (tests).
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        Ok(Self {
            texture,
            view,
            capacity: height * u64::from(TEXEL_TABLE_WIDTH),
        })
    }

    /// A table holding `data` (16-byte rows), written now.
    pub fn with_data(ctx: &GpuContext, label: &str, data: &[u8]) -> Result<Self> {
        let rows = (data.len() as u64).div_ceil(16);
        let table = Self::new(ctx, label, rows)?;
        let mut padded = data.to_vec();
        padded.resize((table.capacity * 16) as usize, 0);
        let height = table.capacity / u64::from(TEXEL_TABLE_WIDTH);
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &table.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &padded,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(TEXEL_TABLE_WIDTH * 16),
                rows_per_image: None,
            },
            wgpu::Extent3d {
                width: TEXEL_TABLE_WIDTH,
                height: height as u32,
                depth_or_array_layers: 1,
            },
        );
        Ok(table)
    }

    /// How many rows it holds.
    pub fn capacity(&self) -> u64 {
        self.capacity
    }

    /// The texture (to read it back: tests).
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// The view a pass binds.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// Records the copy of the first `rows` 16-byte rows of `buffer` into the table (whole
    /// texture rows, then the last partial one). Rows past `rows` keep what they held.
    pub fn copy_from(&self, enc: &mut wgpu::CommandEncoder, buffer: &wgpu::Buffer, rows: u64) {
        debug_assert!(rows <= self.capacity && rows * 16 <= buffer.size());
        let width = u64::from(TEXEL_TABLE_WIDTH);
        let full = rows / width;
        let rest = rows % width;
        let copy = |enc: &mut wgpu::CommandEncoder, y: u64, w: u64, h: u64| {
            enc.copy_buffer_to_texture(
                wgpu::TexelCopyBufferInfo {
                    buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: y * width * 16,
                        bytes_per_row: Some(TEXEL_TABLE_WIDTH * 16),
                        rows_per_image: None,
                    },
                },
                wgpu::TexelCopyTextureInfo {
                    texture: &self.texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d {
                        x: 0,
                        y: y as u32,
                        z: 0,
                    },
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::Extent3d {
                    width: w as u32,
                    height: h as u32,
                    depth_or_array_layers: 1,
                },
            );
        };
        if full > 0 {
            copy(enc, 0, width, full);
        }
        if rest > 0 {
            copy(enc, full, rest, 1);
        }
    }
}

/// A texel-table copy of a storage buffer that a pass reads as texels, made where the
/// pass's pipeline reads texels ([`super::ComputePass::reads_texel_tables`]): one table,
/// grown to the largest copy asked of it, and a one-texel stand-in that the pass binds
/// where it reads the buffer.
pub struct TexelCopy {
    label: &'static str,
    table: std::sync::Mutex<Option<TexelTable>>,
    stand_in: TexelTable,
}

impl TexelCopy {
    /// A copy named `label`, with no table until the first copy.
    pub fn new(ctx: &GpuContext, label: &'static str) -> Result<Self> {
        Ok(Self {
            label,
            table: std::sync::Mutex::new(None),
            stand_in: TexelTable::new(ctx, label, 1)?,
        })
    }

    /// With `copy`, records the copy of `buffer`'s first `rows` 16-byte rows and returns
    /// the view of the table that holds them; without, the stand-in's view. The table is
    /// reused by later copies, which the queue orders after this one's readers.
    pub fn view(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        buffer: &wgpu::Buffer,
        rows: u64,
        copy: bool,
    ) -> Result<wgpu::TextureView> {
        if !copy {
            return Ok(self.stand_in.view().clone());
        }
        let mut table = self.table.lock().unwrap_or_else(|p| p.into_inner());
        let table = match table.take() {
            Some(t) if t.capacity() >= rows => table.insert(t),
            _ => table.insert(TexelTable::new(ctx, self.label, rows)?),
        };
        table.copy_from(enc, buffer, rows);
        Ok(table.view().clone())
    }
}
