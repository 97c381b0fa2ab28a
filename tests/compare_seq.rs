//! `radsplat compare-seq` and `radsplat::compare_seq`: per-frame RMSE and flicker on tiny
//! synthetic EXR sequences, the plot, and clear errors.

mod common;

use radsplat::Error;
use radsplat::compare_seq::{PLOT_SIZE, compare_sequence};
use radsplat::output::exr_out::{Channels, encode_exr};
use std::path::{Path, PathBuf};
use std::process::Command;

const W: u32 = 4;
const H: u32 = 3;

/// A fresh, empty directory for one test's files, removed when the test ends.
fn tmp_dir(name: &str) -> common::TestDir {
    common::TestDir::new(&format!("compare-seq-{name}"))
}

/// Writes frames 1, 2, 3 of `dir/{prefix}_####.exr`, frame k uniformly grey at `values[k-1]`
/// (R = G = B, so the luminance is the value). Returns the pattern.
fn write_sequence(dir: &Path, prefix: &str, values: [f32; 3]) -> PathBuf {
    for (k, v) in values.iter().enumerate() {
        let ch: Channels = ["R", "G", "B"]
            .iter()
            .map(|n| (n.to_string(), vec![*v; (W * H) as usize]))
            .collect();
        let path = dir.join(format!("{prefix}_{:04}.exr", k + 1));
        std::fs::write(path, encode_exr(W, H, &ch).expect("encode")).expect("write");
    }
    dir.join(format!("{prefix}_####.exr"))
}

fn radsplat(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_radsplat"))
        .args(args)
        .output()
        .expect("run radsplat");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "radsplat panicked: {stderr}");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).to_string(),
        stderr,
    )
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

#[test]
fn identical_sequences_have_no_error_and_no_flicker() {
    let dir = tmp_dir("same");
    let a = write_sequence(&dir, "a", [1.0, 3.0, 2.0]);
    let r = write_sequence(&dir, "ref", [1.0, 3.0, 2.0]);
    let c = compare_sequence(&a, &r, 1..=3, 1).expect("compare");
    assert_eq!(c.frames.len(), 3);
    for f in &c.frames {
        assert_eq!(f.comparison.beauty.rmse, 0.0);
        assert_eq!(f.comparison.beauty.relative_rmse, 0.0);
    }
    assert_eq!(c.frames[0].flicker, None);
    assert_eq!(c.frames[1].flicker, Some(0.0));
    assert_eq!(c.frames[2].flicker, Some(0.0));
    assert_eq!(c.summary.mean_flicker, Some(0.0));
    assert_eq!(c.summary.max_relative_rmse, 0.0);

    // Through the command line, with JSON and the plot.
    let (json, plot) = (dir.join("seq.json"), dir.join("seq.png"));
    let (code, out, err) = radsplat(&[
        "compare-seq",
        s(&a),
        s(&r),
        "--frames",
        "1..3",
        "--json",
        s(&json),
        "--plot",
        s(&plot),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("3 frames"), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    assert_eq!(v["frames"].as_array().map(Vec::len), Some(3));
    assert_eq!(
        v["frames"][1]["comparison"]["beauty"]["rmse"].as_f64(),
        Some(0.0)
    );
    assert_eq!(v["summary"]["mean_flicker"].as_f64(), Some(0.0));
    let png = image::open(&plot).expect("plot png");
    assert_eq!((png.width(), png.height()), PLOT_SIZE);
}

#[test]
fn alternating_brightness_flickers_by_the_analytic_amount() {
    let dir = tmp_dir("flicker");
    // A steps 2 -> 2.5 -> 2 while the reference stays at 2: every pixel's luminance change
    // differs by 0.5 from the reference's (0), so flicker = 0.5 and, relative to the
    // reference's mean luminance 2, 0.25. Frame 2's relative RMSE is 0.5 / 2.
    let a = write_sequence(&dir, "a", [2.0, 2.5, 2.0]);
    let r = write_sequence(&dir, "ref", [2.0, 2.0, 2.0]);
    let c = compare_sequence(&a, &r, 1..=3, 1).expect("compare");
    let close = |x: Option<f64>, y: f64| x.is_some_and(|x| (x - y).abs() < 1e-5);
    for f in &c.frames[1..] {
        assert!(close(f.flicker, 0.5), "{:?}", f.flicker);
        assert!(close(f.flicker_relative, 0.25), "{:?}", f.flicker_relative);
    }
    assert!(close(c.summary.mean_flicker, 0.5));
    assert!(close(c.summary.mean_flicker_relative, 0.25));
    assert!(close(
        Some(c.frames[1].comparison.beauty.relative_rmse),
        0.25
    ));
    assert!(close(Some(c.summary.max_relative_rmse), 0.25));
    assert_eq!(c.summary.max_relative_rmse_frame, 2);
    assert_eq!(c.summary.median_relative_rmse, 0.0);

    // The same sequence downsampled, and through the command line.
    let c2 = compare_sequence(&a, &r, 1..=3, 2).expect("downsampled");
    assert_eq!(
        (
            c2.frames[0].comparison.width,
            c2.frames[0].comparison.height
        ),
        (2, 1)
    );
    assert!(close(c2.summary.mean_flicker, 0.5));
    let json = dir.join("seq.json");
    let (code, out, err) = radsplat(&[
        "compare-seq",
        s(&a),
        s(&r),
        "--frames",
        "1..3",
        "--json",
        s(&json),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("25.000 % of mean Y(ref)"), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    let rel = v["summary"]["mean_flicker_relative"]
        .as_f64()
        .expect("number");
    assert!((rel - 0.25).abs() < 1e-5, "{rel}");
    assert_eq!(v["frames"][0]["flicker"], serde_json::Value::Null);
}

#[test]
fn errors_name_the_problem() {
    let dir = tmp_dir("errors");
    let a = write_sequence(&dir, "a", [1.0, 1.0, 1.0]);
    let r = write_sequence(&dir, "ref", [1.0, 1.0, 1.0]);
    let missing = dir.join("a_0002.exr");
    std::fs::remove_file(&missing).expect("remove");

    let e = compare_sequence(&a, &r, 1..=3, 1).expect_err("missing frame");
    assert!(
        matches!(&e, Error::Io { path, .. } if path == &missing),
        "{e}"
    );
    let (code, _, err) = radsplat(&["compare-seq", s(&a), s(&r), "--frames", "1..3"]);
    assert_ne!(code, 0);
    assert!(err.contains(s(&missing)), "{err}");
    // Frame 1 alone is still there.
    let (code, out, err) = radsplat(&["compare-seq", s(&a), s(&r), "--frames", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("1 frames"), "{out}");

    for bad in ["3..1", "1..x", "one"] {
        let (code, _, err) = radsplat(&["compare-seq", s(&a), s(&r), "--frames", bad]);
        assert_ne!(code, 0, "--frames {bad}");
        assert!(err.contains(bad), "{err}");
    }
    let (code, _, err) = radsplat(&["compare-seq", s(&dir.join("a.exr")), s(&r), "--frames", "1"]);
    assert_ne!(code, 0);
    assert!(err.contains("'#'") && err.contains("a.exr"), "{err}");

    // Frame 3 of both sequences at another size: the error names both frames.
    let ch: Channels = ["R", "G", "B"]
        .iter()
        .map(|n| (n.to_string(), vec![1.0; 4]))
        .collect();
    let bytes = encode_exr(2, 2, &ch).expect("encode");
    for name in ["a_0003.exr", "ref_0003.exr"] {
        std::fs::write(dir.join(name), &bytes).expect("write");
    }
    let e = compare_sequence(&a, &r, 1..=1, 1).map(|_| ());
    assert!(e.is_ok(), "{e:?}");
    std::fs::copy(dir.join("a_0001.exr"), &missing).expect("restore");
    let e = compare_sequence(&a, &r, 2..=3, 1).expect_err("size change");
    assert!(
        e.to_string().contains("a_0002.exr") && e.to_string().contains("a_0003.exr"),
        "{e}"
    );

    // A plot into a directory that does not exist: the error names the path.
    let plot = dir.join("nowhere").join("plot.png");
    let (code, _, err) = radsplat(&[
        "compare-seq",
        s(&a),
        s(&r),
        "--frames",
        "1",
        "--plot",
        s(&plot),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("plot.png"), "{err}");
}
