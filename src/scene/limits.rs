//! Caps on what untrusted input may claim, checked before anything is allocated from it.
//!
//! Image headers (Radiance, OpenEXR, PNG, JPEG) state a width and height that size the
//! decoder's buffers; a 60-byte file claiming 100000 x 100000 pixels would otherwise make
//! the reader ask for 120 GB and abort the process. Every reader therefore checks the
//! claimed size twice before decoding: against a fixed cap ([`MAX_IMAGE_PIXELS`],
//! [`MAX_IMAGE_SAMPLES`]) and against the least number of bytes the format needs to store
//! that many pixels ([`check_image_size`]), so that a header that lies about the file it
//! heads is refused in microseconds, with a message naming the file, the claimed size and
//! what the file holds.
//!
//! Light values get a cap too ([`MAX_LIGHT_VALUE`]): radiances near `f32::MAX` are finite
//! in the scene file but overflow to infinity in the renderer's first product.

use crate::{Error, Result};
use std::path::Path;

/// The most pixels an input image may have: 16384 x 16384, the largest 2D texture most GPUs
/// allow. (A Radiance or EXR image this size already takes 3 GiB as RGB f32.)
pub const MAX_IMAGE_PIXELS: u64 = 1 << 28;

/// The most channel values (pixels x channels) of one EXR layer: 2^30, 4 GiB as f32.
pub const MAX_IMAGE_SAMPLES: u64 = 1 << 30;

/// The largest light value accepted anywhere (radiance, intensity, irradiance, emission,
/// environment, per channel). Far above any physical light (the sun's disc is about 2e7
/// W/(sr m^2)), and far enough below `f32::MAX` (3.4e38) that the renderer's products
/// (area x cosines / distance^2, sums over light samples, lights, plane pixels and records)
/// stay finite.
pub const MAX_LIGHT_VALUE: f32 = 1e20;

/// The largest Phong exponent accepted (MTL `Ns`, a material's `exponent`): a lobe of a
/// few thousandths of a degree, a mirror in effect. The normalised lobe's peak (n + 2) / 2π
/// times cos^n stays exact in f32 only while cos θ can resolve the lobe's width: at 1e10
/// the images were 1.5x too bright, at 3e38 1e30x.
pub const MAX_PHONG_EXPONENT: f32 = 1e6;

/// The largest coordinate a vertex (or the camera) may have, in its file and in the world:
/// past about 4e9 a triangle's edge cross product overflows f32 when normalised (a Cornell
/// box scaled by 3e10 rendered black), and near 1e19 the scene's diagonal (it turned the
/// indirect light off). Precision gives out long before for a scene far from the origin
/// ([`ray_offset`]): `GpuScene::upload` warns then.
pub const MAX_COORDINATE: f32 = 1e9;

/// How far a ray leaving a surface at distance `far` from the origin starts off it, at
/// most: Ray Tracing Gems' offset (`offset_ray_origin` in wgsl/shared/ray.wgsl) moves it
/// by 256 units in the last place of each coordinate, 1/65536 near the origin.
pub fn ray_offset(far: f32) -> f32 {
    (256.0 * f32::EPSILON * far).max(1.0 / 65536.0)
}

/// The largest value of radiance x area of a rect light (its power over π): the same
/// headroom argument as [`MAX_LIGHT_VALUE`], for the area-sampling estimator, which
/// multiplies the radiance by the light's area.
pub const MAX_RECT_LIGHT_POWER: f32 = 1e30;

/// Checks an image size claimed by the header of `path` before decoding it.
///
/// `format` names the kind of file in messages ("Radiance picture", "OpenEXR", "PNG" ...).
/// `min_data_bytes` is the least number of bytes the format needs to store `width x height`
/// pixels (computed by the caller from the format's best possible compression), and
/// `data_bytes` what the file holds after the header. Errors (an [`Error::Invalid`] at
/// "header") when the size is zero, above [`MAX_IMAGE_PIXELS`], or needs more bytes than
/// the file has.
pub fn check_image_size(
    path: &Path,
    format: &str,
    (width, height): (u64, u64),
    min_data_bytes: u64,
    data_bytes: u64,
) -> Result<()> {
    let bad = |m: String| Error::invalid(path, "header", format!("{format}: {m}"));
    let pixels = width.saturating_mul(height);
    if pixels == 0 {
        return Err(bad(format!("the header claims {width}x{height} pixels")));
    }
    if pixels > MAX_IMAGE_PIXELS {
        return Err(bad(format!(
            "the header claims {width}x{height} pixels ({pixels}); at most {MAX_IMAGE_PIXELS} \
             (16384x16384) are accepted"
        )));
    }
    if min_data_bytes > data_bytes {
        return Err(bad(format!(
            "the header claims {width}x{height} pixels, which need at least {min_data_bytes} \
             bytes of pixel data, but the file holds {data_bytes} (truncated, or the header \
             lies)"
        )));
    }
    Ok(())
}

/// The length of the file at `path` in bytes, checked to be a regular file within
/// [`crate::input::MAX_DATA_BYTES`].
pub fn file_len(path: &Path) -> Result<u64> {
    crate::input::check_file(path, crate::input::MAX_DATA_BYTES)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_beyond_the_cap_or_the_file_are_refused() {
        let p = Path::new("x.hdr");
        assert!(check_image_size(p, "f", (4, 4), 64, 64).is_ok());
        let e = check_image_size(p, "f", (100_000, 100_000), 0, 60)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("100000x100000") && e.contains("268435456"),
            "{e}"
        );
        let e = check_image_size(p, "f", (1000, 1000), 4000, 60)
            .unwrap_err()
            .to_string();
        assert!(e.contains("4000") && e.contains("holds 60"), "{e}");
        assert!(check_image_size(p, "f", (0, 4), 0, 60).is_err());
        assert!(check_image_size(p, "f", (u64::MAX, u64::MAX), 0, 60).is_err());
    }
}
