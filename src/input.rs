//! Input files: what a path names must be a regular file of a size radsplat can hold.
//!
//! Reading a FIFO blocks until something writes to it, and `/dev/zero` or `/dev/urandom`
//! never end: a scene, mesh, image or reference named by mistake as one would hang the run
//! or take the machine's memory. So every input is checked to be a regular file (after
//! following symbolic links) and under a cap for its kind before it is read.

use crate::{Error, Result};
use std::path::Path;

/// The largest scene or MTL file read (text; a scene file is a few KiB).
pub const MAX_TEXT_BYTES: u64 = 256 << 20;
/// The largest mesh, image or texture file read.
pub const MAX_DATA_BYTES: u64 = 16 << 30;

/// Checks that `path` names a regular file of at most `max` bytes; returns its size.
pub fn check_file(path: &Path, max: u64) -> Result<u64> {
    let refuse = |message: String| {
        Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, message),
        )
    };
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return Err(refuse("is a directory, not a file".into()));
    }
    if !meta.is_file() {
        return Err(refuse(
            "not a regular file (a device, FIFO or socket): name the file itself".into(),
        ));
    }
    if meta.len() > max {
        return Err(refuse(format!(
            "{} bytes, more than the {max} an input of this kind may have",
            meta.len()
        )));
    }
    Ok(meta.len())
}

/// Reads the whole of `path` ([`check_file`] first).
pub fn read(path: &Path, max: u64) -> Result<Vec<u8>> {
    check_file(path, max)?;
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// Reads `path` as UTF-8 text ([`check_file`] first).
pub fn read_to_string(path: &Path, max: u64) -> Result<String> {
    check_file(path, max)?;
    std::fs::read_to_string(path).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Devices and directories are refused before a byte is read, and so is a file over
    /// its cap; a regular file reads.
    #[test]
    fn only_regular_files_within_the_cap_are_read() {
        #[cfg(unix)]
        {
            let e = read(Path::new("/dev/zero"), MAX_DATA_BYTES)
                .expect_err("a device")
                .to_string();
            assert!(
                e.contains("/dev/zero") && e.contains("not a regular file"),
                "{e}"
            );
        }
        let dir = std::env::temp_dir();
        let e = read(&dir, MAX_DATA_BYTES)
            .expect_err("a directory")
            .to_string();
        assert!(e.contains("directory"), "{e}");
        let file = dir.join(format!("radsplat-input-{}.txt", std::process::id()));
        std::fs::write(&file, b"12345").expect("write");
        assert_eq!(read_to_string(&file, 5).expect("within the cap"), "12345");
        let e = read(&file, 4).expect_err("over the cap").to_string();
        assert!(e.contains("5 bytes"), "{e}");
        std::fs::remove_file(&file).expect("remove");
    }
}
