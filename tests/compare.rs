//! `radsplat compare` and `radsplat::compare`: RMSE numbers on synthetic images (EXR and
//! Radiance pictures), the difference PNG, and clear errors for bad input.

mod common;

use radsplat::compare::{LEGEND_ROWS, compare, load_image};
use radsplat::output::exr_out::{Channels, encode_exr};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory for one test's files, removed when the test ends.
fn tmp_dir(name: &str) -> common::TestDir {
    common::TestDir::new(&format!("compare-{name}"))
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
    // Beauty's error is one pixel's: the worst 1 % (one pixel of 12) holds all of it.
    // Indirect's is a bias of 1.5x spread over every pixel: one pixel holds 1/12.
    assert_eq!(v["beauty"]["worst_share"].as_f64(), Some(1.0));
    assert_eq!(v["indirect"]["mean_ratio"].as_f64(), Some(1.5));
    let share = v["indirect"]["worst_share"].as_f64().expect("worst_share");
    assert!((share - 1.0 / 12.0).abs() < 1e-12, "{share}");
    assert!(out.contains("mean ratio 1.5000"), "{out}");
    assert!(out.contains("worst 1 % of pixels: 100.0 %"), "{out}");
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

// ---------------------------------------------------------------------------------------------
// Headers that lie (issue 16): refused before anything is allocated from them.

/// A Radiance header claiming `w x h` followed by `data` as the pixel bytes.
fn radiance_claiming(path: &Path, w: u32, h: u32, data: &[u8]) {
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    bytes.extend_from_slice(data);
    std::fs::write(path, bytes).expect("write");
}

#[test]
fn radiance_header_that_lies_is_refused_fast() {
    let dir = tmp_dir("hdr-lies");
    let start = std::time::Instant::now();
    // 60-byte files: one claims 120 GB of pixels, one 10 GB (below u32 overflow, above the
    // cap), one a size the cap allows but the file cannot hold.
    for (w, h, want) in [
        (100_000, 100_000, "at most 268435456"),
        (30_000, 30_000, "at most 268435456"),
        (10_000, 10_000, "need at least 40000 bytes"),
    ] {
        let path = dir.join(format!("{w}.hdr"));
        radiance_claiming(&path, w, h, &[128, 64, 32, 129]);
        assert!(std::fs::metadata(&path).expect("meta").len() <= 64);
        let err = load_image(&path).expect_err("lying header").to_string();
        for part in [path.to_str().unwrap_or(""), &format!("{w}x{h}"), want] {
            assert!(err.contains(part), "expected '{part}' in: {err}");
        }
        // The command line refuses it too, without an abort.
        let (code, _, err) = radsplat(&["compare", s(&path), s(&path)]);
        assert_ne!(code, 0);
        assert!(err.contains(&format!("{w}x{h}")), "{err}");
    }
    assert!(
        start.elapsed().as_secs() < 10,
        "refusing took {:?}",
        start.elapsed()
    );
    // Long enough for the minimum, but the flat pixels run out: the scanline is named.
    let path = dir.join("short.hdr");
    radiance_claiming(&path, 4, 4, &[[128, 64, 32, 129]; 5].concat());
    let err = load_image(&path).expect_err("truncated").to_string();
    assert!(
        err.contains("scanline 1 of 4") && err.contains("ends"),
        "{err}"
    );
}

#[test]
fn radiance_run_length_encodings_decode_like_flat_pixels() {
    let dir = tmp_dir("hdr-rle");
    let px = |x: u8| [100 + x, 50, 20 + 2 * x, 130];
    // 8 x 2 flat: row 0 is px(0..8), row 1 is px(3) eight times.
    let rows: Vec<Vec<[u8; 4]>> = vec![(0..8).map(px).collect(), vec![px(3); 8]];
    let flat: Vec<u8> = rows.iter().flatten().flatten().copied().collect();
    radiance_claiming(&dir.join("flat.hdr"), 8, 2, &flat);
    // Per-component run-length: row 0 as dumps of 8 values, row 1 as runs of 8.
    let mut rle = Vec::new();
    for (y, row) in rows.iter().enumerate() {
        rle.extend_from_slice(&[2, 2, 0, 8]);
        for c in 0..4 {
            if y == 0 {
                rle.push(8);
                rle.extend(row.iter().map(|p| p[c]));
            } else {
                rle.extend_from_slice(&[128 + 8, row[0][c]]);
            }
        }
    }
    radiance_claiming(&dir.join("rle.hdr"), 8, 2, &rle);
    // Old run-length (a repeat marker (1, 1, 1, n)) in a 4-pixel-wide image.
    let mut old = Vec::new();
    old.extend_from_slice(&px(1));
    old.extend_from_slice(&[1, 1, 1, 3]);
    old.extend_from_slice(&px(2));
    old.extend_from_slice(&[1, 1, 1, 3]);
    radiance_claiming(&dir.join("old.hdr"), 4, 2, &old);
    radiance_claiming(
        &dir.join("old-flat.hdr"),
        4,
        2,
        &[[px(1); 4], [px(2); 4]].concat().concat(),
    );
    let load = |n: &str| load_image(&dir.join(n)).unwrap_or_else(|e| panic!("{n}: {e}"));
    let (flat, rle) = (load("flat.hdr"), load("rle.hdr"));
    assert_eq!(flat.beauty.len(), 16);
    assert_eq!(flat.beauty, rle.beauty);
    // px(0) = (100, 50, 20) at exponent 130: x 2^(130 - 136).
    assert_eq!(flat.beauty[0], [100.0 / 64.0, 50.0 / 64.0, 20.0 / 64.0]);
    assert_eq!(load("old.hdr").beauty, load("old-flat.hdr").beauty);
    // A repeat marker that runs past the scanline is an error, not a write out of bounds.
    let mut bad = px(1).to_vec();
    bad.extend_from_slice(&[1, 1, 1, 200]);
    radiance_claiming(&dir.join("bad.hdr"), 4, 1, &bad);
    let err = load_image(&dir.join("bad.hdr"))
        .expect_err("overrun")
        .to_string();
    assert!(err.contains("runs past the scanline"), "{err}");
}

/// A valid 4x4 EXR whose data window then claims `w x h` pixels.
fn exr_claiming(path: &Path, w: i32, h: i32) {
    let ch: Channels = ["R", "G", "B"]
        .iter()
        .map(|n| (n.to_string(), vec![1.0; 16]))
        .collect();
    let mut bytes = encode_exr(4, 4, &ch).expect("encode");
    let key = b"dataWindow\0box2i\0";
    let at = bytes
        .windows(key.len())
        .position(|win| win == key)
        .expect("dataWindow attribute")
        + key.len()
        + 4; // the attribute's size
    // xMin, yMin, xMax, yMax (inclusive).
    bytes[at + 8..at + 12].copy_from_slice(&(w - 1).to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&(h - 1).to_le_bytes());
    std::fs::write(path, bytes).expect("write");
}

#[test]
fn exr_header_that_lies_is_refused_fast() {
    let dir = tmp_dir("exr-lies");
    let start = std::time::Instant::now();
    for (w, h, want) in [
        (100_000, 100_000, "at most 268435456"),
        (16_000, 16_000, "need at least"),
    ] {
        let path = dir.join(format!("{w}.exr"));
        exr_claiming(&path, w, h);
        let err = load_image(&path).expect_err("lying header").to_string();
        for part in [path.to_str().unwrap_or(""), &format!("{w}x{h}"), want] {
            assert!(err.contains(part), "expected '{part}' in: {err}");
        }
    }
    assert!(start.elapsed().as_secs() < 10, "{:?}", start.elapsed());
    // The honest file still loads.
    exr_claiming(&dir.join("ok.exr"), 4, 4);
    let ok = load_image(&dir.join("ok.exr")).expect("honest EXR");
    assert_eq!((ok.width, ok.height), (4, 4));
}
