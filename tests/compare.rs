//! `radsplat compare` and `radsplat::compare`: RMSE numbers on synthetic images (EXR and
//! Radiance pictures), the difference PNG, and clear errors for bad input.

use radsplat::compare::{LEGEND_ROWS, compare, load_image};
use radsplat::output::exr_out::{Channels, encode_exr};
use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("radsplat-compare-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Writes an EXR whose R, G, B are `rgb` (per pixel), plus `indirect.*` when given.
fn write_exr(path: &Path, w: u32, h: u32, rgb: &[[f32; 3]], indirect: Option<&[[f32; 3]]>) {
    let mut ch: Channels = Vec::new();
    for (c, n) in ["R", "G", "B"].iter().enumerate() {
        ch.push((n.to_string(), rgb.iter().map(|p| p[c]).collect()));
    }
    if let Some(ind) = indirect {
        for (c, n) in ["indirect.R", "indirect.G", "indirect.B"]
            .iter()
            .enumerate()
        {
            ch.push((n.to_string(), ind.iter().map(|p| p[c]).collect()));
        }
    }
    std::fs::write(path, encode_exr(w, h, &ch).expect("encode")).expect("write");
}

/// A Radiance picture, flat (uncompressed) RGBE scanlines, standard orientation.
fn write_radiance(path: &Path, w: u32, h: u32, header: &str, rgbe: [u8; 4]) {
    let mut bytes =
        format!("#?RADIANCE\n{header}FORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for _ in 0..w * h {
        bytes.extend_from_slice(&rgbe);
    }
    std::fs::write(path, bytes).expect("write");
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
fn rmse_of_synthetic_exr_images() {
    let dir = tmp_dir("rmse");
    let (w, h) = (4, 3);
    // Reference: every value 2. A: every value 2 except pixel 5, whose R is 5 (error 3).
    let b = vec![[2.0f32; 3]; 12];
    let mut a = b.clone();
    a[5][0] = 5.0;
    let ind_b = vec![[1.0f32; 3]; 12];
    let ind_a = vec![[1.5f32; 3]; 12];
    write_exr(&dir.join("a.exr"), w, h, &a, Some(&ind_a));
    write_exr(&dir.join("b.exr"), w, h, &b, Some(&ind_b));
    let (ia, ib) = (
        load_image(&dir.join("a.exr")).expect("a"),
        load_image(&dir.join("b.exr")).expect("b"),
    );
    let c = compare(&ia, &ib).expect("compare");
    // RMSE = sqrt(9 / 36) = 0.5; RMS(B) = 2; relative 0.25.
    assert!((c.beauty.rmse - 0.5).abs() < 1e-12, "{:?}", c.beauty);
    assert!((c.beauty.rms_reference - 2.0).abs() < 1e-12);
    assert!((c.beauty.relative_rmse - 0.25).abs() < 1e-12);
    let ind = c.indirect.expect("both files have indirect.*");
    assert!((ind.rmse - 0.5).abs() < 1e-12 && (ind.relative_rmse - 0.5).abs() < 1e-12);

    // Through the command line, with JSON and a difference image.
    let (json, diff) = (dir.join("c.json"), dir.join("diff.png"));
    let (code, out, err) = radsplat(&[
        "compare",
        s(&dir.join("a.exr")),
        s(&dir.join("b.exr")),
        "--json",
        s(&json),
        "--diff",
        s(&diff),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("relative RMSE 0.2500"), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    assert_eq!(v["beauty"]["rmse"].as_f64(), Some(0.5));
    assert_eq!(v["indirect"]["relative_rmse"].as_f64(), Some(0.5));
    let png = image::open(&diff).expect("diff png");
    assert_eq!((png.width(), png.height()), (w, h + LEGEND_ROWS));

    // Only one file with indirect.*: beauty only.
    write_exr(&dir.join("plain.exr"), w, h, &b, None);
    let plain = load_image(&dir.join("plain.exr")).expect("plain");
    let c = compare(&ia, &plain).expect("compare");
    assert!(c.indirect.is_none());
    assert_eq!(compare(&plain, &plain).expect("self").beauty.rmse, 0.0);
}

#[test]
fn radiance_pictures_are_read_as_radiance_with_exposure_divided_out() {
    let dir = tmp_dir("hdr");
    // RGBE (128, 64, 32, 129): mantissas / 256 * 2^(129 - 128) = 1, 0.5, 0.25.
    write_radiance(&dir.join("one.hdr"), 3, 2, "", [128, 64, 32, 129]);
    write_radiance(
        &dir.join("exp.hdr"),
        3,
        2,
        "EXPOSURE=2\n",
        [128, 64, 32, 129],
    );
    let one = load_image(&dir.join("one.hdr")).expect("hdr");
    assert_eq!((one.width, one.height), (3, 2));
    assert!(one.indirect.is_none());
    let p = one.beauty[0];
    for (got, want) in p.iter().zip([1.0f32, 0.5, 0.25]) {
        assert!((got - want).abs() <= 0.01 * want, "{p:?}");
    }
    let exp = load_image(&dir.join("exp.hdr")).expect("hdr");
    assert!(
        (exp.beauty[0][0] * 2.0 - p[0]).abs() < 1e-6,
        "EXPOSURE not divided out"
    );

    // An EXR against a Radiance picture: A = 1.1 x B's values.
    let a: Vec<[f32; 3]> = one.beauty.iter().map(|q| q.map(|c| 1.1 * c)).collect();
    write_exr(&dir.join("a.exr"), 3, 2, &a, Some(&a));
    let c = compare(&load_image(&dir.join("a.exr")).expect("a"), &one).expect("compare");
    assert!(
        (c.beauty.relative_rmse - 0.1).abs() < 1e-5,
        "{:?}",
        c.beauty
    );
    assert!(
        c.indirect.is_none(),
        "a Radiance picture has no indirect AOV"
    );
}

#[test]
fn bad_inputs_give_clear_errors() {
    let dir = tmp_dir("errors");
    let b = vec![[1.0f32; 3]; 6];
    write_exr(&dir.join("3x2.exr"), 3, 2, &b, None);
    write_exr(&dir.join("2x3.exr"), 2, 3, &b, None);
    let mut nan = b.clone();
    nan[4][1] = f32::NAN;
    write_exr(&dir.join("nan.exr"), 3, 2, &nan, None);
    let y_only: Channels = vec![("Y".into(), vec![1.0; 6])];
    std::fs::write(
        dir.join("y.exr"),
        encode_exr(3, 2, &y_only).expect("encode"),
    )
    .expect("w");
    std::fs::write(dir.join("text.exr"), "not an image").expect("w");
    let good = dir.join("3x2.exr");
    let cases: [(PathBuf, &str); 5] = [
        (dir.join("missing.exr"), "cannot read"),
        (dir.join("2x3.exr"), "image sizes differ"),
        (
            dir.join("y.exr"),
            "needs the channels R, G and B; the file has: Y",
        ),
        (
            dir.join("text.exr"),
            "neither an OpenEXR file nor a Radiance picture",
        ),
        (dir.join("nan.exr"), "pixel (1, 1)"),
    ];
    for (bad, want) in &cases {
        let diff = dir.join("diff.png");
        let (code, _, err) = radsplat(&["compare", s(bad), s(&good), "--diff", s(&diff)]);
        assert_ne!(code, 0, "{}", bad.display());
        assert!(
            err.contains(want),
            "{}: expected '{want}' in: {err}",
            bad.display()
        );
        assert!(err.contains(bad.file_name().and_then(|n| n.to_str()).unwrap_or("")));
        assert!(
            !diff.exists(),
            "a difference image was written for bad input"
        );
    }
    let (code, _, err) = radsplat(&["compare", s(&good), s(&good), "--diff-scale", "0"]);
    assert_ne!(code, 0);
    assert!(err.contains("--diff-scale"), "{err}");
}

#[test]
fn surfaces_exclude_pixels_where_the_reference_has_no_albedo() {
    // Pixel 0 is an emitter (albedo 0, radiance 10) that A gets badly wrong; pixel 1 is a
    // surface where A is 10 % too bright.
    let b = radsplat::compare::RgbImage {
        path: "b.exr".into(),
        width: 2,
        height: 1,
        beauty: vec![[10.0; 3], [1.0; 3]],
        indirect: None,
        albedo: Some(vec![[0.0; 3], [0.5; 3]]),
    };
    let a = radsplat::compare::RgbImage {
        path: "a.exr".into(),
        beauty: vec![[20.0; 3], [1.1; 3]],
        albedo: None,
        ..b.clone()
    };
    let c = compare(&a, &b).expect("compare");
    let s = c.surfaces.expect("B has albedo.*");
    assert!((s.relative_rmse - 0.1).abs() < 1e-6, "{s:?}");
    assert!(c.beauty.relative_rmse > 0.5);
    assert!(compare(&b, &a).expect("compare").surfaces.is_none());
}
