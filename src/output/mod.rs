//! Output files: linear EXR with AOVs, tone-mapped sRGB PNG, false-colour PNGs, line
//! charts ([`plot`]), and frame path patterns for image sequences ([`sequence`]). Every
//! file is written atomically: to a temporary file next to it, then renamed, so a
//! failure never leaves a half-written output.

pub mod commit;
pub mod exr_out;
pub mod plot;
pub mod png_out;
pub mod record_map;
pub mod sequence;

pub use commit::OutputSet;
pub use exr_out::{read_exr_channels, write_exr};
pub use png_out::{tonemap_to_srgb8, write_png};
pub use record_map::{lifespan_map, record_map};
pub use sequence::{check_pattern, frame_path, parse_frame_range};

use crate::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

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
    /// tone-mapped with `exposure` as PNG. Refuses a frame with a non-finite pixel.
    pub fn write_frame(
        self,
        path: &Path,
        frame: &crate::frame::Frame,
        exposure: f32,
    ) -> Result<()> {
        write_atomically(path, &self.encode_frame(path, frame, exposure)?)
    }

    /// The bytes [`ImageFormat::write_frame`] writes (`path` only names the output in
    /// errors).
    pub fn encode_frame(
        self,
        path: &Path,
        frame: &crate::frame::Frame,
        exposure: f32,
    ) -> Result<Vec<u8>> {
        check_finite(path, frame)?;
        let err = |message: String| Error::Output {
            path: path.to_path_buf(),
            message,
        };
        match self {
            ImageFormat::Exr => {
                exr_out::encode_exr_owned(frame.width, frame.height, exr_out::frame_channels(frame))
                    .map_err(err)
            }
            ImageFormat::Png => {
                let rgb = tonemap_to_srgb8(&frame.beauty, exposure);
                png_out::encode_png_rgb8(frame.width, frame.height, &rgb).map_err(err)
            }
        }
    }
}

/// Refuses to write a frame with a NaN or infinite pixel in any image (beauty, albedo,
/// direct, indirect; the depth AOV is +inf on background by definition): such a pixel is
/// a scene value that overflowed f32 or degenerated, and a user would rather get an error
/// naming the pixel than a picture with holes that poisons every average taken of it.
pub fn check_finite(path: &Path, frame: &crate::frame::Frame) -> Result<()> {
    let images = [
        ("beauty", Some(&frame.beauty)),
        ("albedo", Some(&frame.albedo)),
        ("direct", Some(&frame.direct)),
        ("indirect", frame.indirect.as_ref()),
    ];
    for (name, image) in images {
        let Some(image) = image else { continue };
        let bad = image
            .iter()
            .filter(|p| p.iter().any(|c| !c.is_finite()))
            .count();
        if let Some(first) = image.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            let w = frame.width.max(1) as usize;
            return Err(Error::Output {
                path: path.to_path_buf(),
                message: format!(
                    "not written: {bad} of {} pixels of the {name} image are not finite \
                     (first at x {} y {}: {:?}); a light or material value overflows f32 or \
                     the scene degenerates at this frame",
                    image.len(),
                    first % w,
                    first / w,
                    image[first]
                ),
            });
        }
    }
    Ok(())
}

/// Refuses an output that `flag` writes as PNG whose name says otherwise (`--png o.jpg`
/// would have written PNG bytes under a JPEG name).
pub fn check_png_name(path: &Path, flag: &str) -> Result<()> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if ext.as_deref() == Some("png") {
        return Ok(());
    }
    Err(Error::Output {
        path: path.to_path_buf(),
        message: format!("{flag} writes a PNG image: name a .png file"),
    })
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

/// The file an output named `path` replaces: `path` itself, or where a symbolic link at
/// `path` points (followed through every link, so the link stays and its target gets the
/// output). Refuses a path that names something other than a regular file or nothing (a
/// directory, a device such as `/dev/null`, a FIFO, a socket): outputs are written by
/// renaming a finished file into place, which would replace it.
pub fn output_target(path: &Path) -> Result<PathBuf> {
    let err = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    let mut target = path.to_path_buf();
    // A chain of links, followed by hand so that a link to a file not yet written works.
    for _ in 0..40 {
        let Ok(meta) = std::fs::symlink_metadata(&target) else {
            return Ok(target); // nothing there yet: a new file
        };
        let kind = meta.file_type();
        if kind.is_symlink() {
            let link = std::fs::read_link(&target)
                .map_err(|e| err(format!("cannot read the link {}: {e}", target.display())))?;
            target = match target.parent() {
                Some(dir) if link.is_relative() => dir.join(link),
                _ => link,
            };
            continue;
        }
        if kind.is_dir() {
            return Err(err("is a directory, not a file name".into()));
        }
        if !kind.is_file() {
            return Err(err(
                "is not a regular file (a device, FIFO or socket): outputs are written to a \
                 temporary file and renamed into place, which would replace it; name a \
                 regular file"
                    .into(),
            ));
        }
        return Ok(target);
    }
    Err(err("too many levels of symbolic links".into()))
}

/// Writes `bytes` to `path` atomically (temp file in the same directory, fsync, rename;
/// through a symbolic link to its target, [`output_target`]).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let err = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    let target = output_target(path)?;
    let dir = output_dir(&target)?;
    let file_name = target
        .file_name()
        .ok_or_else(|| err("not a file name".into()))?
        .to_string_lossy();
    let tmp = dir.join(format!(".{file_name}.{}.tmp", std::process::id()));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, &target)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(beauty: Vec<[f32; 4]>) -> crate::frame::Frame {
        let n = beauty.len();
        crate::frame::Frame {
            width: n as u32,
            height: 1,
            beauty,
            albedo: vec![[0.5; 4]; n],
            direct: vec![[0.0; 4]; n],
            indirect: None,
            visibility: Vec::new(),
            stats: Default::default(),
        }
    }

    /// A NaN or infinite pixel is refused with its count and place; finite frames pass.
    #[test]
    fn frames_with_non_finite_pixels_are_not_written() {
        let path = Path::new("out.exr");
        check_finite(path, &frame(vec![[1.0, 2.0, 3.0, 1.0]; 3])).expect("finite frame");
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let f = frame(vec![[1.0; 4], [1.0, bad, 0.0, 1.0], [bad; 4]]);
            let e = check_finite(path, &f).expect_err("non-finite").to_string();
            assert!(
                e.contains("2 of 3 pixels") && e.contains("beauty") && e.contains("x 1 y 0"),
                "{e}"
            );
            let e = ImageFormat::Png
                .encode_frame(Path::new("out.png"), &f, 1.0)
                .expect_err("PNG too")
                .to_string();
            assert!(e.contains("out.png"), "{e}");
        }
        let mut f = frame(vec![[1.0; 4]; 2]);
        f.indirect = Some(vec![[0.0; 4], [f32::NAN; 4]]);
        let e = check_finite(path, &f).expect_err("indirect").to_string();
        assert!(e.contains("indirect"), "{e}");
    }
}
