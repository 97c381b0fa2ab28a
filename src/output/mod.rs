//! Output files: linear EXR with AOVs, tone-mapped sRGB PNG, false-colour PNGs, line
//! charts ([`plot`]), and frame path patterns for image sequences ([`sequence`]). Every
//! file is written atomically: to a temporary file next to it, then renamed, so a
//! failure never leaves a half-written output.

pub mod exr_out;
pub mod plot;
pub mod png_out;
pub mod record_map;
pub mod sequence;

pub use exr_out::{read_exr_channels, write_exr};
pub use png_out::{tonemap_to_srgb8, write_png};
pub use record_map::{lifespan_map, record_map};
pub use sequence::{check_pattern, frame_path, parse_frame_range};

use crate::{Error, Result};
use std::io::Write;
use std::path::Path;

/// The kind of image an output path asks for, from its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// Linear OpenEXR with every AOV (`.exr`).
    Exr,
    /// Tone-mapped sRGB 8-bit PNG of the beauty image (`.png`).
    Png,
}

impl ImageFormat {
    /// `.exr` or `.png` (any case); anything else is an error naming the path, raised
    /// before any rendering so no work is wasted on an output that cannot be written.
    pub fn from_path(path: &Path) -> Result<ImageFormat> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("exr") => Ok(ImageFormat::Exr),
            Some("png") => Ok(ImageFormat::Png),
            _ => Err(Error::Output {
                path: path.to_path_buf(),
                message: "unknown image format: the output must end in .exr or .png".into(),
            }),
        }
    }
}

impl ImageFormat {
    /// Writes `frame` to `path` in this format: the EXR with every AOV, or the beauty
    /// tone-mapped with `exposure` as PNG.
    pub fn write_frame(
        self,
        path: &Path,
        frame: &crate::frame::Frame,
        exposure: f32,
    ) -> Result<()> {
        match self {
            ImageFormat::Exr => write_exr(path, frame).map(|_| ()),
            ImageFormat::Png => {
                let rgb = tonemap_to_srgb8(&frame.beauty, exposure);
                write_png(path, frame.width, frame.height, &rgb)
            }
        }
    }
}

/// The directory `path` will be written in, checked to exist (so long jobs can refuse a
/// bad output path before they start).
pub fn output_dir(path: &Path) -> Result<&Path> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::Output {
            path: path.to_path_buf(),
            message: format!("directory {} does not exist", dir.display()),
        });
    }
    Ok(dir)
}

/// Writes `bytes` to `path` atomically (temp file in the same directory, fsync, rename).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let err = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    let dir = output_dir(path)?;
    let file_name = path
        .file_name()
        .ok_or_else(|| err("not a file name".into()))?
        .to_string_lossy();
    let tmp = dir.join(format!(".{file_name}.{}.tmp", std::process::id()));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(e.to_string()));
    }
    Ok(())
}

/// SHA-256 of a byte string, lowercase hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}
