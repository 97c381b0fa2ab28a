//! Comparing an image A against a reference B: RMSE and relative RMSE of the beauty RGB
//! (and of the `indirect.*` AOV when both have it), and a false-colour difference image.
//!
//! Definitions, over all pixels p and the three channels c of an image with P pixels:
//!
//! ```text
//! RMSE          = sqrt( 1/(3P) Σ_p Σ_c (A_pc − B_pc)² )
//! RMS(B)        = sqrt( 1/(3P) Σ_p Σ_c B_pc² )
//! relative RMSE = RMSE / RMS(B)
//! ```
//!
//! Sums are taken in f64. Emitters seen by the camera can dominate RMS(B), so when B has an
//! `albedo.*` AOV the beauty is also measured over reflecting surfaces only (albedo > 0). Inputs are linear-radiance OpenEXR files (`R`, `G`, `B`, and
//! optionally `indirect.R/G/B`, as `radsplat render` / `reference` write them) or Radiance
//! RGBE pictures (`.hdr`/`.pic`, as `rpict` writes them; beauty only), told apart by their
//! magic bytes. A Radiance picture's `EXPOSURE` and `COLORCORR` header values are divided
//! out, so its pixels are radiance in W/(sr m²) per channel, the unit radsplat uses.

use crate::output::png_out::encode_png_rgb8;
use crate::output::{read_exr_channels, write_atomically};
use crate::scene::limits::check_image_size;
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// A linear RGB image with an optional indirect AOV, row-major, top row first.
#[derive(Clone, Debug)]
pub struct RgbImage {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub beauty: Vec<[f32; 3]>,
    /// `indirect.R/G/B`, when the file has all three.
    pub indirect: Option<Vec<[f32; 3]>>,
    /// `albedo.R/G/B`, when the file has all three.
    pub albedo: Option<Vec<[f32; 3]>>,
}

impl RgbImage {
    /// The beauty of `self` minus that of `other`, also as the indirect AOV: the indirect
    /// light of a renderer that writes only totals, e.g. rpict `-ab 1` minus `-ab 0`
    /// (same direct sampling), to compare with a reference's `indirect.*`.
    pub fn minus(&self, other: &RgbImage) -> Result<RgbImage> {
        check_same_size(self, other)?;
        let beauty: Vec<[f32; 3]> = self
            .beauty
            .iter()
            .zip(&other.beauty)
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
            .collect();
        Ok(RgbImage {
            path: self.path.clone(),
            width: self.width,
            height: self.height,
            indirect: Some(beauty.clone()),
            beauty,
            albedo: None,
        })
    }

    /// The image box-filtered by `factor` x `factor` pixels (rows and columns that do not
    /// fill a whole box are dropped). Comparing downsampled images measures the error at a
    /// coarser scale, where the per-pixel noise of a Monte Carlo reference averages out
    /// (a 64-spp reference downsampled by 4 has 1024 samples per compared pixel).
    pub fn downsample(&self, factor: u32) -> Result<RgbImage> {
        if factor == 0 || factor > self.width || factor > self.height {
            return Err(Error::Usage(format!(
                "--downsample {factor} does not fit {} ({}x{})",
                self.path.display(),
                self.width,
                self.height
            )));
        }
        let (w, h) = (self.width / factor, self.height / factor);
        let src_w = self.width as usize;
        let f = factor as usize;
        let inv = 1.0 / (f * f) as f32;
        let boxed = |pixels: &[[f32; 3]]| -> Vec<[f32; 3]> {
            let mut out = Vec::with_capacity((w * h) as usize);
            for y in 0..h as usize {
                for x in 0..w as usize {
                    let mut sum = [0.0f32; 3];
                    for dy in 0..f {
                        let row = (y * f + dy) * src_w;
                        for dx in 0..f {
                            let p = pixels[row + x * f + dx];
                            for c in 0..3 {
                                sum[c] += p[c];
                            }
                        }
                    }
                    out.push(sum.map(|v| v * inv));
                }
            }
            out
        };
        Ok(RgbImage {
            path: self.path.clone(),
            width: w,
            height: h,
            beauty: boxed(&self.beauty),
            indirect: self.indirect.as_deref().map(boxed),
            albedo: self.albedo.as_deref().map(boxed),
        })
    }
}

/// RMSE of one image pair (module docs).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ErrorStats {
    pub rmse: f64,
    /// RMS of the reference B.
    pub rms_reference: f64,
    /// `rmse / rms_reference` (infinite if the reference is black and A is not, 0 if both are).
    pub relative_rmse: f64,
    /// Mean of A over the mean of B (all channels): below 1, A is darker on the whole (a
    /// bias); 1 where both are black, infinite where only B is.
    pub mean_ratio: f64,
    /// Share of the squared error held by the 1 % of pixels where it is largest (at least
    /// one pixel): near 0.01, an error spread evenly (noise everywhere); near 1, a few
    /// pixels hold it (a misplaced record, a missed patch). 0 where there is no error.
    pub worst_share: f64,
}

/// The result of [`compare`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct Comparison {
    pub a: PathBuf,
    pub b: PathBuf,
    pub width: u32,
    pub height: u32,
    pub beauty: ErrorStats,
    /// Present when both images have `indirect.*`.
    pub indirect: Option<ErrorStats>,
    /// Share of the pixels the reference's indirect light reaches (luminance above 1 % of
    /// its mean) where A's indirect light is zero: holes (planes that missed the bright
    /// patches, uncovered pixels). Present when both images have `indirect.*`.
    pub indirect_unlit: Option<f64>,
    /// Beauty over the reflecting surfaces only: pixels where the reference B has a non-zero
    /// `albedo.*` (emitters, whose radiance can dominate RMS(B), and background excluded).
    /// Present when B has `albedo.*`.
    pub surfaces: Option<ErrorStats>,
}

const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Loads an OpenEXR or Radiance RGBE image (format from the file's first bytes).
pub fn load_image(path: &Path) -> Result<RgbImage> {
    let bytes = crate::input::read(path, crate::input::MAX_DATA_BYTES)?;
    if bytes.starts_with(&EXR_MAGIC) {
        load_exr(path)
    } else if bytes.starts_with(b"#?") {
        load_radiance(path, &bytes)
    } else {
        Err(Error::invalid(
            path,
            "header",
            "neither an OpenEXR file nor a Radiance picture (#?RADIANCE)",
        ))
    }
}

fn load_exr(path: &Path) -> Result<RgbImage> {
    let (width, height, channels) = read_exr_channels(path)?;
    let find = |name: &str| channels.iter().find(|(n, _)| n == name).map(|(_, d)| d);
    let rgb = |names: [&str; 3]| -> Option<Vec<[f32; 3]>> {
        let (r, g, b) = (find(names[0])?, find(names[1])?, find(names[2])?);
        Some((0..r.len()).map(|i| [r[i], g[i], b[i]]).collect())
    };
    let beauty = rgb(["R", "G", "B"]).ok_or_else(|| {
        let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
        Error::invalid(
            path,
            "channels",
            format!(
                "needs the channels R, G and B; the file has: {}",
                names.join(", ")
            ),
        )
    })?;
    let indirect = rgb(["indirect.R", "indirect.G", "indirect.B"]);
    let albedo = rgb(["albedo.R", "albedo.G", "albedo.B"]);
    Ok(RgbImage {
        path: path.to_path_buf(),
        width,
        height,
        beauty,
        indirect,
        albedo,
    })
}

fn load_radiance(path: &Path, bytes: &[u8]) -> Result<RgbImage> {
    use image::ImageDecoder;
    use image::codecs::hdr::HdrDecoder;
    let bad = |m: String| Error::invalid(path, "Radiance picture", m);
    // The image crate parses the header (EXPOSURE, COLORCORR, orientation, size); the
    // pixels are decoded here, so that the claimed size is checked against the file before
    // anything is allocated from it, and the buffer grows only with what was decoded.
    let decoder =
        HdrDecoder::new_nonstrict(std::io::Cursor::new(bytes)).map_err(|e| bad(e.to_string()))?;
    let meta = decoder.metadata();
    if meta.orientation != ((1, 0), (0, 1)) {
        return Err(bad(format!(
            "only the standard orientation (-Y h +X w) is supported, not {:?}",
            meta.orientation
        )));
    }
    let format = meta
        .custom_attributes
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case("FORMAT"))
        .map(|(_, f)| f.trim());
    if let Some(f) = format.filter(|f| !f.eq_ignore_ascii_case("32-bit_rle_rgbe")) {
        return Err(bad(format!("FORMAT={f} is not 32-bit_rle_rgbe")));
    }
    let (width, height) = decoder.dimensions();
    let data = radiance_pixel_data(bytes)
        .ok_or_else(|| bad("no resolution line after the header".to_string()))?;
    // Every scanline starts with one whole 4-byte pixel, whatever its encoding (flat, old
    // run-length or per-component run-length), so h scanlines need at least 4h bytes.
    check_image_size(
        path,
        "Radiance picture",
        (u64::from(width), u64::from(height)),
        4 * u64::from(height),
        data.len() as u64,
    )?;
    let exposure = meta.exposure.unwrap_or(1.0);
    let cc = meta.color_correction.unwrap_or((1.0, 1.0, 1.0));
    if !(exposure > 0.0 && cc.0 > 0.0 && cc.1 > 0.0 && cc.2 > 0.0) {
        return Err(bad(format!(
            "EXPOSURE {exposure} or COLORCORR {cc:?} is not positive"
        )));
    }
    // Radiance stores value × EXPOSURE × COLORCORR: divide them out to get radiance.
    let scale = [
        1.0 / (exposure * cc.0),
        1.0 / (exposure * cc.1),
        1.0 / (exposure * cc.2),
    ];
    let mut reader = RgbeReader { data, pos: 0 };
    let mut beauty: Vec<[f32; 3]> = Vec::new();
    let mut row: Vec<[u8; 4]> = Vec::new();
    for y in 0..height {
        reader.scanline(width as usize, &mut row).map_err(|m| {
            bad(format!(
                "scanline {y} of {height} (byte {} of the pixel data): {m}",
                reader.pos
            ))
        })?;
        beauty.extend(row.iter().map(|&p| {
            let rgb = rgbe_to_rgb(p);
            [rgb[0] * scale[0], rgb[1] * scale[1], rgb[2] * scale[2]]
        }));
    }
    Ok(RgbImage {
        path: path.to_path_buf(),
        width,
        height,
        beauty,
        indirect: None,
        albedo: None,
    })
}

/// The bytes after a Radiance picture's header and resolution line: lines up to the first
/// empty one are the header, the next line is the resolution (the image crate's rule).
fn radiance_pixel_data(bytes: &[u8]) -> Option<&[u8]> {
    let header_end = bytes.windows(2).position(|w| w == b"\n\n")? + 2;
    let rest = &bytes[header_end..];
    let resolution_end = rest.iter().position(|&b| b == b'\n')? + 1;
    Some(&rest[resolution_end..])
}

/// An RGBE pixel as linear RGB, as the image crate converts it (`c * 2^(e - 136)`, so the
/// values are those radsplat has always read).
fn rgbe_to_rgb([r, g, b, e]: [u8; 4]) -> [f32; 3] {
    if e == 0 {
        return [0.0; 3];
    }
    let f = f32::exp2(f32::from(e) - 136.0);
    [f * f32::from(r), f * f32::from(g), f * f32::from(b)]
}

/// Decodes RGBE scanlines (flat, old run-length and per-component run-length, as Radiance's
/// `freadcolrs`) from the pixel data, never reading past it and never allocating more than
/// one scanline of pixels that were actually decoded.
struct RgbeReader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl RgbeReader<'_> {
    fn byte(&mut self) -> std::result::Result<u8, String> {
        let b = *self
            .data
            .get(self.pos)
            .ok_or_else(|| "the file ends inside the pixel data".to_string())?;
        self.pos += 1;
        Ok(b)
    }

    fn pixel(&mut self) -> std::result::Result<[u8; 4], String> {
        Ok([self.byte()?, self.byte()?, self.byte()?, self.byte()?])
    }

    /// One scanline of `width` pixels into `row` (cleared first).
    fn scanline(
        &mut self,
        width: usize,
        row: &mut Vec<[u8; 4]>,
    ) -> std::result::Result<(), String> {
        row.clear();
        let first = self.pixel()?;
        // Radiance writes the per-component encoding only for widths 8..=32767, and its
        // reader only looks for it there: elsewhere (2, 2, x, y) is an ordinary pixel.
        let is_new_rle =
            (8..=0x7fff).contains(&width) && first[0] == 2 && first[1] == 2 && first[2] < 128;
        if !is_new_rle {
            return self.old_rle(first, width, row);
        }
        let encoded_width = (usize::from(first[2]) << 8) | usize::from(first[3]);
        if encoded_width != width {
            return Err(format!(
                "run-length scanline of {encoded_width} pixels in an image {width} wide"
            ));
        }
        // Each component is stored as runs (count > 128: one value repeated count - 128
        // times) and dumps (count <= 128 literal values), one component after the other.
        row.resize(width, [0; 4]);
        for component in 0..4 {
            let mut x = 0;
            while x < width {
                let count = usize::from(self.byte()?);
                let (run, n) = if count > 128 {
                    (true, count - 128)
                } else {
                    (false, count)
                };
                if x + n > width {
                    return Err(format!(
                        "run of {n} at pixel {x} does not fit a scanline of {width}"
                    ));
                }
                if run {
                    let value = self.byte()?;
                    row[x..x + n].iter_mut().for_each(|p| p[component] = value);
                } else {
                    for p in &mut row[x..x + n] {
                        p[component] = self.byte()?;
                    }
                }
                x += n;
            }
        }
        Ok(())
    }

    /// The old encoding: flat pixels, where (1, 1, 1, n) repeats the previous pixel n times,
    /// and consecutive repeat markers multiply by 256 (n, then n << 8, ...).
    fn old_rle(
        &mut self,
        first: [u8; 4],
        width: usize,
        row: &mut Vec<[u8; 4]>,
    ) -> std::result::Result<(), String> {
        let is_marker = |p: [u8; 4]| p[0] == 1 && p[1] == 1 && p[2] == 1;
        if is_marker(first) {
            return Err("a scanline starts with a repeat marker".to_string());
        }
        row.push(first);
        let mut shift = 0u32;
        while row.len() < width {
            let p = self.pixel()?;
            if is_marker(p) {
                let count = u64::from(p[3]).checked_shl(shift).filter(|_| shift < 32);
                let last = *row.last().unwrap_or(&first);
                match count.and_then(|c| usize::try_from(c).ok()) {
                    Some(c) if row.len() + c <= width => row.resize(row.len() + c, last),
                    _ => {
                        return Err(format!(
                            "repeat marker at pixel {} runs past the scanline of {width}",
                            row.len()
                        ));
                    }
                }
                shift += 8;
            } else {
                row.push(p);
                shift = 0;
            }
        }
        Ok(())
    }
}

/// RMSE, RMS of the reference and relative RMSE of `a` against `b` (same length).
pub fn error_stats(a: &[[f32; 3]], b: &[[f32; 3]]) -> ErrorStats {
    let (mut se, mut sb) = (0.0f64, 0.0f64);
    let (mut mean_a, mut mean_b) = (0.0f64, 0.0f64);
    let mut per_pixel = Vec::with_capacity(a.len().min(b.len()));
    for (pa, pb) in a.iter().zip(b) {
        let mut pixel = 0.0;
        for c in 0..3 {
            let d = f64::from(pa[c]) - f64::from(pb[c]);
            pixel += d * d;
            sb += f64::from(pb[c]) * f64::from(pb[c]);
            mean_a += f64::from(pa[c]);
            mean_b += f64::from(pb[c]);
        }
        se += pixel;
        per_pixel.push(pixel);
    }
    let mean_ratio = if mean_b != 0.0 {
        mean_a / mean_b
    } else if mean_a == 0.0 {
        1.0
    } else {
        f64::INFINITY
    };
    let worst_share = worst_share(&mut per_pixel, se);
    let n = (3 * a.len().min(b.len())).max(1) as f64;
    let rmse = (se / n).sqrt();
    let rms_reference = (sb / n).sqrt();
    let relative_rmse = if rms_reference > 0.0 {
        rmse / rms_reference
    } else if rmse == 0.0 {
        0.0
    } else {
        f64::INFINITY
    };
    ErrorStats {
        rmse,
        rms_reference,
        relative_rmse,
        mean_ratio,
        worst_share,
    }
}

/// The share of `total` (the sum of `per_pixel`) in the largest 1 % of `per_pixel`, at
/// least one pixel (reorders `per_pixel`).
fn worst_share(per_pixel: &mut [f64], total: f64) -> f64 {
    if per_pixel.is_empty() || total <= 0.0 {
        return 0.0;
    }
    let k = per_pixel.len().div_ceil(100);
    let first = per_pixel.len() - k;
    per_pixel.select_nth_unstable_by(first, |x, y| x.total_cmp(y));
    per_pixel[first..].iter().sum::<f64>() / total
}

fn check_finite(img: &RgbImage, what: &str, pixels: &[[f32; 3]]) -> Result<()> {
    if let Some(i) = pixels.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        let w = img.width.max(1) as usize;
        return Err(Error::invalid(
            &img.path,
            format!("{what} pixel ({}, {})", i % w, i / w),
            "is not finite (NaN or infinity)",
        ));
    }
    Ok(())
}

/// A usage error naming both files when their sizes differ.
fn check_same_size(a: &RgbImage, b: &RgbImage) -> Result<()> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::Usage(format!(
            "image sizes differ: {} is {}x{}, {} is {}x{}",
            a.path.display(),
            a.width,
            a.height,
            b.path.display(),
            b.width,
            b.height
        )));
    }
    Ok(())
}

/// Compares image `a` against the reference `b`. Errors when the sizes differ or a
/// pixel is not finite.
pub fn compare(a: &RgbImage, b: &RgbImage) -> Result<Comparison> {
    check_same_size(a, b)?;
    check_finite(a, "beauty", &a.beauty)?;
    check_finite(b, "beauty", &b.beauty)?;
    let (indirect, indirect_unlit) = match (&a.indirect, &b.indirect) {
        (Some(ia), Some(ib)) => {
            check_finite(a, "indirect", ia)?;
            check_finite(b, "indirect", ib)?;
            (Some(error_stats(ia, ib)), Some(unlit_share(ia, ib)))
        }
        _ => (None, None),
    };
    if let Some(albedo) = &b.albedo {
        check_finite(b, "albedo", albedo)?;
    }
    let surfaces = b.albedo.as_ref().map(|albedo| {
        let (sa, sb): (Vec<[f32; 3]>, Vec<[f32; 3]>) = a
            .beauty
            .iter()
            .zip(&b.beauty)
            .zip(albedo)
            .filter(|(_, al)| al.iter().any(|&c| c > 0.0))
            .map(|(pair, _)| pair)
            .unzip();
        error_stats(&sa, &sb)
    });
    Ok(Comparison {
        a: a.path.clone(),
        b: b.path.clone(),
        width: a.width,
        height: a.height,
        beauty: error_stats(&a.beauty, &b.beauty),
        indirect,
        indirect_unlit,
        surfaces,
    })
}

/// Share of the pixels where the reference `b` has light (luminance above 1 % of its mean)
/// and `a` has none.
pub fn unlit_share(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let n = b.len().max(1) as f64;
    let mean = b.iter().map(|&p| f64::from(luminance(p))).sum::<f64>() / n;
    let lit: Vec<bool> = b
        .iter()
        .map(|&p| f64::from(luminance(p)) > 0.01 * mean)
        .collect();
    let lit_count = lit.iter().filter(|&&l| l).count();
    if lit_count == 0 {
        return 0.0;
    }
    let holes = a
        .iter()
        .zip(&lit)
        .filter(|&(&p, &l)| l && luminance(p) <= 0.0)
        .count();
    holes as f64 / lit_count as f64
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(p: [f32; 3]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// Viridis (matplotlib's perceptually uniform map) at 9 stops, linearly interpolated.
const VIRIDIS: [[f32; 3]; 9] = [
    [68.0, 1.0, 84.0],
    [71.0, 44.0, 122.0],
    [59.0, 81.0, 139.0],
    [44.0, 113.0, 142.0],
    [33.0, 144.0, 141.0],
    [39.0, 173.0, 129.0],
    [92.0, 200.0, 99.0],
    [170.0, 220.0, 50.0],
    [253.0, 231.0, 37.0],
];

/// Viridis colour of `t` in [0, 1] (clamped), 8-bit sRGB.
pub fn viridis(t: f32) -> [u8; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let x = t * (VIRIDIS.len() - 1) as f32;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f32;
    let c = |k: usize| (VIRIDIS[i][k] + f * (VIRIDIS[i + 1][k] - VIRIDIS[i][k]) + 0.5) as u8;
    [c(0), c(1), c(2)]
}

/// Height in pixels of the legend strip under the difference image.
pub const LEGEND_ROWS: u32 = 12;

/// False-colour difference image, 8-bit RGB, `width x (height + LEGEND_ROWS)`.
///
/// Each pixel shows `e = |Y(A) − Y(B)| / mean_p Y(B)` (luminance difference relative to the
/// reference's mean luminance, so dark pixels do not blow up) through [`viridis`], from
/// 0 (dark purple) to `scale` and above (yellow). The legend strip below the image runs
/// from 0 at the left to `scale` at the right, with ticks at quarters.
pub fn diff_image(a: &RgbImage, b: &RgbImage, scale: f32) -> Vec<u8> {
    let (w, h) = (a.width as usize, a.height as usize);
    let mean_b = b
        .beauty
        .iter()
        .map(|&p| f64::from(luminance(p)))
        .sum::<f64>()
        / b.beauty.len().max(1) as f64;
    let norm = if mean_b > 0.0 { mean_b as f32 } else { 1.0 };
    let scale = if scale > 0.0 { scale } else { 1.0 };
    let mut rgb = Vec::with_capacity(w * (h + LEGEND_ROWS as usize) * 3);
    for (pa, pb) in a.beauty.iter().zip(&b.beauty) {
        let e = (luminance(*pa) - luminance(*pb)).abs() / norm;
        rgb.extend_from_slice(&viridis(e / scale));
    }
    for row in 0..LEGEND_ROWS {
        for x in 0..w {
            let t = (x as f32 + 0.5) / w as f32;
            let tick = row < 3 && (0..=4).any(|q| (q * (w - 1)) / 4 == x);
            if row < 2 || tick {
                rgb.extend_from_slice(&if tick { [255, 255, 255] } else { [0, 0, 0] });
            } else {
                rgb.extend_from_slice(&viridis(t));
            }
        }
    }
    rgb
}

/// Writes [`diff_image`] as a PNG, atomically.
pub fn write_diff_png(path: &Path, a: &RgbImage, b: &RgbImage, scale: f32) -> Result<()> {
    let rgb = diff_image(a, b, scale);
    let bytes = encode_png_rgb8(a.width, a.height + LEGEND_ROWS, &rgb).map_err(|message| {
        Error::Output {
            path: path.to_path_buf(),
            message,
        }
    })?;
    write_atomically(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bias shows in the mean ratio and spreads its error evenly; one bad pixel holds
    /// all of it.
    #[test]
    fn mean_ratio_and_worst_share_tell_a_bias_from_an_outlier() {
        let b: Vec<[f32; 3]> = (0..1000).map(|i| [1.0 + (i % 7) as f32; 3]).collect();
        let darker: Vec<[f32; 3]> = b.iter().map(|p| p.map(|c| 0.9 * c)).collect();
        let s = error_stats(&darker, &b);
        assert!((s.mean_ratio - 0.9).abs() < 1e-6, "{}", s.mean_ratio);
        // The 10 worst pixels (1 %) of an error proportional to the value: the brightest
        // values, 7 against a mean square of 20: about 2.5 % of the error.
        assert!(
            s.worst_share > 0.01 && s.worst_share < 0.05,
            "{}",
            s.worst_share
        );
        let mut outlier = b.clone();
        outlier[123] = [100.0; 3];
        let s = error_stats(&outlier, &b);
        assert!((s.worst_share - 1.0).abs() < 1e-12);
        assert!(s.mean_ratio > 1.0);
        // No error: nothing to share; black against black: a ratio of 1.
        assert_eq!(error_stats(&b, &b).worst_share, 0.0);
        let black = vec![[0.0; 3]; 10];
        assert_eq!(error_stats(&black, &black).mean_ratio, 1.0);
        assert!(error_stats(&b[..10], &black).mean_ratio.is_infinite());
    }

    #[test]
    fn rmse_of_known_images() {
        let b = vec![[1.0, 1.0, 1.0]; 4];
        let mut a = b.clone();
        a[0] = [3.0, 1.0, 1.0]; // one difference of 2 among 12 values
        let s = error_stats(&a, &b);
        assert!((s.rmse - (4.0f64 / 12.0).sqrt()).abs() < 1e-12);
        assert!((s.rms_reference - 1.0).abs() < 1e-12);
        assert!((s.relative_rmse - s.rmse).abs() < 1e-12);
        assert_eq!(error_stats(&b, &b).relative_rmse, 0.0);
        let black = vec![[0.0; 3]; 4];
        assert_eq!(error_stats(&black, &black).relative_rmse, 0.0);
        assert!(error_stats(&b, &black).relative_rmse.is_infinite());
    }

    #[test]
    fn unlit_share_counts_holes_where_the_reference_is_lit() {
        let b = vec![[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [0.0; 3], [1.0, 1.0, 1.0]];
        let a = vec![[0.0; 3], [0.5, 0.5, 0.5], [0.0; 3], [2.0, 2.0, 2.0]];
        // Three lit pixels in b; a is dark at one of them (b's dark pixel does not count).
        assert!((unlit_share(&a, &b) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(unlit_share(&b, &b), 0.0);
    }

    #[test]
    fn downsample_averages_boxes() {
        let img = RgbImage {
            path: PathBuf::from("x"),
            width: 4,
            height: 3,
            beauty: (0..12).map(|i| [i as f32, 0.0, 1.0]).collect(),
            indirect: None,
            albedo: None,
        };
        let d = img.downsample(2).unwrap();
        assert_eq!((d.width, d.height), (2, 1));
        // Boxes {0,1,4,5} and {2,3,6,7}; the last row is dropped.
        assert_eq!(d.beauty, vec![[2.5, 0.0, 1.0], [4.5, 0.0, 1.0]]);
        assert!(img.downsample(0).is_err());
        assert!(img.downsample(5).is_err());
    }

    /// A reference whose `albedo.*` holds a NaN is refused, naming the pixel (its surface
    /// error had been reported over no pixel at all).
    #[test]
    fn a_non_finite_reference_albedo_is_refused() {
        let image = |albedo: [f32; 3]| RgbImage {
            path: PathBuf::from("ref.exr"),
            width: 2,
            height: 1,
            beauty: vec![[1.0; 3]; 2],
            indirect: None,
            albedo: Some(vec![[0.5; 3], albedo]),
        };
        assert!(compare(&image([0.5; 3]), &image([0.5; 3])).is_ok());
        let e = compare(&image([0.5; 3]), &image([f32::NAN, 0.5, 0.5]))
            .expect_err("NaN albedo")
            .to_string();
        assert!(
            e.contains("ref.exr") && e.contains("albedo") && e.contains("(1, 0)"),
            "{e}"
        );
    }

    #[test]
    fn viridis_ends() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(viridis(7.0), [253, 231, 37]);
        assert_eq!(viridis(f32::NAN), [253, 231, 37]);
    }
}
