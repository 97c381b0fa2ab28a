//! Image sequences: frame path patterns (`frame_####.exr`) and frame ranges (`1..24`).

use crate::{Error, Result};
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

/// The file name of `pattern` and the byte range of its last run of `#` characters.
fn hash_run(pattern: &Path) -> Result<(&str, std::ops::Range<usize>)> {
    let name = pattern
        .file_name()
        .ok_or_else(|| {
            Error::Usage(format!(
                "frame pattern {} has no file name (expected e.g. frame_####.exr)",
                pattern.display()
            ))
        })?
        .to_str()
        .ok_or_else(|| {
            Error::Usage(format!(
                "frame pattern {}: the file name is not valid UTF-8",
                pattern.display()
            ))
        })?;
    let end = name.rfind('#').ok_or_else(|| {
        Error::Usage(format!(
            "frame pattern {} has no '#' in its file name: write the frame number's place \
             as a run of '#', e.g. frame_####.exr",
            pattern.display()
        ))
    })? + 1;
    let start = name[..end].trim_end_matches('#').len();
    Ok((name, start..end))
}

/// Checks that `pattern` is a usable frame path pattern: its file name contains at least
/// one `#`. The error ([`Error::Usage`]) names the pattern and says what is missing.
pub fn check_pattern(pattern: &Path) -> Result<()> {
    hash_run(pattern).map(|_| ())
}

/// The path of frame `frame` in the sequence `pattern`: the last run of `#` characters in
/// the file name is replaced by the frame number, zero-padded to the run's length
/// (`frame_####.exr`, 12 → `frame_0012.exr`); a number wider than the run is written in
/// full (`f_#.exr`, 12 → `f_12.exr`). The directory part is kept as it is, `#` included.
///
/// Errors ([`Error::Usage`]) when the file name has no `#`.
pub fn frame_path(pattern: &Path, frame: u32) -> Result<PathBuf> {
    let (name, run) = hash_run(pattern)?;
    let width = run.len();
    let file = format!("{}{frame:0width$}{}", &name[..run.start], &name[run.end..]);
    Ok(pattern.with_file_name(file))
}

/// Parses a frame range: `A..B` (inclusive, A ≤ B) or a single frame number `A`.
/// Errors ([`Error::Usage`]) say what is wrong with the text.
pub fn parse_frame_range(s: &str) -> Result<RangeInclusive<u32>> {
    let number = |v: &str| {
        v.trim().parse::<u32>().map_err(|_| {
            Error::Usage(format!(
                "frame range '{s}': '{}' is not a frame number (expected A..B or A, e.g. 1..24)",
                v.trim()
            ))
        })
    };
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (number(a)?, number(b.strip_prefix('=').unwrap_or(b))?),
        None => {
            let a = number(s)?;
            (a, a)
        }
    };
    if a > b {
        return Err(Error::Usage(format!(
            "frame range '{s}': the first frame {a} is after the last frame {b}"
        )));
    }
    Ok(a..=b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fp(p: &str, f: u32) -> String {
        frame_path(Path::new(p), f)
            .expect("pattern")
            .display()
            .to_string()
    }

    #[test]
    fn frame_numbers_fill_the_last_run_of_hashes() {
        assert_eq!(fp("frame_####.exr", 12), "frame_0012.exr");
        assert_eq!(fp("out/frame_####.exr", 0), "out/frame_0000.exr");
        assert_eq!(fp("f_#.exr", 7), "f_7.exr");
        assert_eq!(fp("f_#.exr", 12), "f_12.exr");
        assert_eq!(fp("f_##.exr", 12345), "f_12345.exr");
        // Only the last run is replaced; directories keep their '#'.
        assert_eq!(fp("a#/v##_t###.exr", 5), "a#/v##_t005.exr");
        assert_eq!(fp("###", 3), "003");
    }

    #[test]
    fn a_pattern_without_hashes_is_refused() {
        for p in ["frame.exr", "dir#/frame.exr", ""] {
            let e = check_pattern(Path::new(p)).expect_err(p);
            assert!(matches!(e, Error::Usage(_)), "{e}");
            assert!(frame_path(Path::new(p), 1).is_err());
        }
        let e = check_pattern(Path::new("frame.exr")).expect_err("no #");
        assert!(e.to_string().contains("frame.exr") && e.to_string().contains("'#'"));
        assert!(check_pattern(Path::new("x/f_##.exr")).is_ok());
    }

    #[test]
    fn frame_ranges() {
        assert_eq!(parse_frame_range("1..3").expect("range"), 1..=3);
        assert_eq!(parse_frame_range(" 2 .. 2 ").expect("range"), 2..=2);
        assert_eq!(parse_frame_range("0..=4").expect("range"), 0..=4);
        assert_eq!(parse_frame_range("7").expect("single"), 7..=7);
        for bad in ["3..1", "a..2", "1..", "..2", "-1..2", "1-3", ""] {
            let e = parse_frame_range(bad).expect_err(bad);
            assert!(e.to_string().contains(bad), "{bad}: {e}");
        }
        assert!(
            parse_frame_range("3..1")
                .expect_err("reversed")
                .to_string()
                .contains("after")
        );
    }
}
