//! Tone-mapped 8-bit sRGB PNG output.

use super::write_atomically;
use crate::{Error, Result};
use std::path::Path;

/// Linear → sRGB-encoded value in [0, 1] (IEC 61966-2-1).
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Tone maps linear RGB to 8-bit sRGB: exposure, then the ACES filmic fit of Narkowicz
/// (2015), which rolls highlights off smoothly instead of clipping them.
pub fn tonemap_to_srgb8(pixels: &[[f32; 4]], exposure: f32) -> Vec<u8> {
    let aces = |x: f32| {
        // Capped where the curve is long flat at 1: past about 1e19 its products overflow
        // to inf / inf = NaN, which turned the brightest pixels black.
        let x = (x * exposure).clamp(0.0, 1e6);
        ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
    };
    let mut out = Vec::with_capacity(pixels.len() * 3);
    for p in pixels {
        for c in &p[..3] {
            let v = if c.is_finite() { aces(*c) } else { 0.0 };
            out.push((linear_to_srgb(v) * 255.0 + 0.5) as u8);
        }
    }
    out
}

/// Encodes 8-bit RGB as PNG bytes.
pub fn encode_png_rgb8(
    width: u32,
    height: u32,
    rgb: &[u8],
) -> std::result::Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut bytes);
    image::ImageEncoder::write_image(encoder, rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// Writes 8-bit RGB pixels as a PNG, atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    let bytes = encode_png_rgb8(width, height, rgb).map_err(|message| Error::Output {
        path: path.to_path_buf(),
        message,
    })?;
    write_atomically(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brightest pixels a scene may hold (lights up to 1e20, any exposure) are white,
    /// not black; black stays black and the curve rises in between.
    #[test]
    fn bright_pixels_tone_map_to_white() {
        for (value, exposure) in [(1e20, 1.0), (1e6, 1.0), (1.0, 3e38), (f32::MAX, 1.0)] {
            let rgb = tonemap_to_srgb8(&[[value, value, value, 1.0]], exposure);
            assert_eq!(rgb, [255, 255, 255], "{value} at exposure {exposure}");
        }
        assert_eq!(tonemap_to_srgb8(&[[0.0; 4]], 1.0), [0, 0, 0]);
        let mid = tonemap_to_srgb8(&[[0.2, 0.5, 1.0, 1.0]], 1.0);
        assert!(
            mid[0] < mid[1] && mid[1] < mid[2] && mid[2] < 255,
            "{mid:?}"
        );
    }
}
