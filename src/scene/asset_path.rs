//! Finding asset files (OBJ, MTL, textures) named in scene, OBJ and MTL files.
//!
//! Like Radiance's `RAYPATH`, a relative name is looked up first next to the file that names
//! it, then in each directory of the colon-separated environment variable
//! [`ASSET_PATH_VAR`] (`RADSPLAT_ASSET_PATH`). This lets scene files in the repository refer
//! to large third-party models (e.g. `dabrovic-sponza/sponza.obj`) that live elsewhere.

use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// Name of the environment variable holding extra asset directories, separated by `:`.
pub const ASSET_PATH_VAR: &str = "RADSPLAT_ASSET_PATH";

/// The directories of `RADSPLAT_ASSET_PATH`, in order. Empty entries are ignored; an unset
/// (or non-UTF-8) variable gives an empty list.
pub fn asset_search_path() -> Vec<PathBuf> {
    match std::env::var_os(ASSET_PATH_VAR) {
        Some(value) => split_search_path(&value.to_string_lossy()),
        None => Vec::new(),
    }
}

/// Splits a colon-separated directory list, dropping empty entries (so `a::b:` is `[a, b]`).
fn split_search_path(value: &str) -> Vec<PathBuf> {
    value
        .split(':')
        .filter(|entry| !entry.is_empty())
        .map(PathBuf::from)
        .collect()
}

/// Resolves an asset `name` written in the scene file `scene_file` under the field `field`
/// (e.g. `"mesh[2].file"`, used in the error message).
///
/// Absolute names are taken as they are (and must exist). Relative names are tried next to
/// the scene file, then in each directory of [`asset_search_path`]. If none exists, the error
/// is [`Error::AssetNotFound`] listing every place that was searched.
pub fn resolve_asset(scene_file: &Path, field: &str, name: &str) -> Result<PathBuf> {
    resolve_asset_from(parent_dir(scene_file), scene_file, field, name)
}

/// Like [`resolve_asset`], but relative names are tried first in `base_dir` instead of next to
/// `referrer`. Used for names inside OBJ/MTL files: an MTL's textures are relative to the MTL
/// file's directory. `referrer` and `field` only appear in the error message.
pub fn resolve_asset_from(
    base_dir: &Path,
    referrer: &Path,
    field: &str,
    name: &str,
) -> Result<PathBuf> {
    let not_found = |searched: String| Error::AssetNotFound {
        scene: referrer.to_path_buf(),
        field: field.to_string(),
        name: name.to_string(),
        searched,
    };
    if name.trim().is_empty() {
        return Err(not_found("nowhere: the name is empty".to_string()));
    }
    let wanted = Path::new(name);
    if wanted.is_absolute() {
        return if wanted.is_file() {
            Ok(wanted.to_path_buf())
        } else {
            Err(not_found(name.to_string()))
        };
    }
    let mut searched = Vec::new();
    let dirs = std::iter::once(base_dir.to_path_buf()).chain(asset_search_path());
    for dir in dirs {
        let candidate = dir.join(wanted);
        if candidate.is_file() {
            return Ok(candidate);
        }
        searched.push(display_dir(&dir));
    }
    Err(not_found(format!(
        "{} (extra directories can be given in {ASSET_PATH_VAR}, separated by ':')",
        searched.join(", ")
    )))
}

/// The directory containing `file`, or `.` for a bare file name.
pub(crate) fn parent_dir(file: &Path) -> &Path {
    match file.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

fn display_dir(dir: &Path) -> String {
    if dir.as_os_str().is_empty() {
        ".".to_string()
    } else {
        dir.display().to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_ignores_empty_entries() {
        assert_eq!(
            split_search_path("a::b:"),
            vec![PathBuf::from("a"), PathBuf::from("b")]
        );
        assert!(split_search_path("").is_empty());
    }

    #[test]
    fn parent_of_bare_name_is_dot() {
        assert_eq!(parent_dir(Path::new("scene.toml")), Path::new("."));
        assert_eq!(parent_dir(Path::new("a/scene.toml")), Path::new("a"));
    }
}
