//! Loading albedo textures (PNG, JPEG) into 8-bit RGBA, with a cache so a file used by several
//! materials is decoded once.

use super::Texture;
use super::limits::{MAX_IMAGE_PIXELS, check_image_size, file_len};
use crate::{Error, Result};
use image::imageops::FilterType;
use image::{ImageDecoder, ImageFormat};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Largest texture side kept as it is. Bigger images are downsampled at load: albedo detail
/// beyond this is invisible at our resolutions and would only cost GPU memory.
pub const MAX_TEXTURE_SIZE: u32 = 2048;

/// Loads an image file as an RGBA8 [`Texture`]: colour bytes as stored (sRGB-encoded), rows top
/// first. Grey, grey+alpha and RGB images get expanded; 16-bit images are reduced to 8 bits.
/// Images larger than [`MAX_TEXTURE_SIZE`] on a side are downsampled (triangle filter, aspect
/// ratio kept) so that the larger side is `MAX_TEXTURE_SIZE`.
///
/// Only PNG and JPEG files are read (told apart by their content). The size the image's
/// header claims is checked before decoding: at most [`MAX_IMAGE_PIXELS`], and no more than
/// the file's bytes can hold (`min_encoded_bytes`).
pub fn load_texture(path: &Path) -> Result<Texture> {
    let file_bytes = file_len(path)?;
    let mut reader = image::ImageReader::open(path)
        .map_err(|e| Error::io(path, e))?
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))?;
    let format = match reader.format() {
        Some(f @ (ImageFormat::Png | ImageFormat::Jpeg)) => f,
        other => {
            let found = other.map_or("an unknown format".to_string(), |f| format!("{f:?}"));
            return Err(Error::invalid(
                path,
                "image data",
                format!("a texture must be a PNG or JPEG image; this file is {found}"),
            ));
        }
    };
    // The largest decoded buffer is 16-bit RGBA (8 bytes a pixel) of the largest image.
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_IMAGE_PIXELS * 8);
    reader.limits(limits);
    let cannot_decode = |e: image::ImageError| {
        Error::invalid(path, "image data", format!("cannot decode image: {e}"))
    };
    let decoder = reader.into_decoder().map_err(cannot_decode)?;
    let (width, height) = decoder.dimensions();
    let name = if format == ImageFormat::Png {
        "PNG"
    } else {
        "JPEG"
    };
    let pixels = u64::from(width) * u64::from(height);
    check_image_size(
        path,
        name,
        (u64::from(width), u64::from(height)),
        min_encoded_bytes(format, pixels),
        file_bytes,
    )?;
    let image = image::DynamicImage::from_decoder(decoder).map_err(cannot_decode)?;
    let mut rgba = image.to_rgba8();
    let (width, height) = rgba.dimensions();
    if width == 0 || height == 0 {
        return Err(Error::invalid(path, "image data", "image has no pixels"));
    }
    if width.max(height) > MAX_TEXTURE_SIZE {
        let (new_width, new_height) = capped_size(width, height);
        log::info!(
            "{}: downsampling texture {width}x{height} to {new_width}x{new_height} \
             (limit {MAX_TEXTURE_SIZE})",
            path.display()
        );
        rgba = image::imageops::resize(&rgba, new_width, new_height, FilterType::Triangle);
    }
    let (width, height) = rgba.dimensions();
    let texels = rgba
        .into_raw()
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]])
        .collect();
    Ok(Texture {
        path: path.to_path_buf(),
        width,
        height,
        texels,
    })
}

/// The least number of bytes a PNG or JPEG file of `pixels` pixels can have, from each
/// format's best compression: a PNG holds at least 1 bit a pixel (1-bit grey) deflated at
/// most 1032:1; a JPEG codes every 8x8 block of its full-resolution component with at least
/// one bit (a DC code), so 1/512 byte a pixel.
fn min_encoded_bytes(format: ImageFormat, pixels: u64) -> u64 {
    match format {
        ImageFormat::Png => pixels / (8 * 1032),
        _ => pixels / 512,
    }
}

/// Size after scaling the larger side down to [`MAX_TEXTURE_SIZE`], keeping the aspect ratio
/// (each side at least 1).
fn capped_size(width: u32, height: u32) -> (u32, u32) {
    let scale = MAX_TEXTURE_SIZE as f64 / width.max(height) as f64;
    let scaled = |side: u32| ((side as f64 * scale).round() as u32).clamp(1, MAX_TEXTURE_SIZE);
    (scaled(width), scaled(height))
}

/// Textures loaded so far, keyed by file, so that each file is decoded once however many
/// materials use it.
#[derive(Debug, Default)]
pub struct TextureCache {
    textures: Vec<Texture>,
    by_path: HashMap<PathBuf, u32>,
}

impl TextureCache {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// Index of the texture loaded from `path`, loading it if this is the first request.
    /// Paths are compared after canonicalisation, so `a/../t.png` and `t.png` are one texture.
    pub fn get_or_load(&mut self, path: &Path) -> Result<u32> {
        let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if let Some(&index) = self.by_path.get(&key) {
            return Ok(index);
        }
        let texture = load_texture(path)?;
        let index = u32::try_from(self.textures.len())
            .map_err(|_| Error::invalid(path, "texture", "too many textures"))?;
        self.textures.push(texture);
        self.by_path.insert(key, index);
        Ok(index)
    }

    /// The textures in load order (indices returned by [`Self::get_or_load`]).
    pub fn into_textures(self) -> Vec<Texture> {
        self.textures
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capped_size_keeps_aspect() {
        assert_eq!(capped_size(4096, 1024), (2048, 512));
        assert_eq!(capped_size(1000, 8192), (250, 2048));
        assert_eq!(capped_size(100_000, 1), (2048, 1));
    }
}
