//! What a run leaves on disk and prints: a run that fails changes no output file (all of a
//! run's outputs are committed together or not at all), and a successful run prints only
//! radsplat's own messages (no driver noise such as libwayland's XDG_RUNTIME_DIR error).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory for one test's files, removed when the test ends.
fn tmp_dir(name: &str) -> common::TestDir {
    common::TestDir::new(&format!("out-{name}"))
}

/// Runs radsplat with XDG_RUNTIME_DIR removed (as in a container or over ssh).
fn radsplat(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_radsplat"))
        .args(args)
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("NODEVICE_SELECT")
        .output()
        .expect("run radsplat");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(!stderr.contains("panicked"), "radsplat panicked: {stderr}");
    (out.status.code().unwrap_or(-1), stdout, stderr)
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// `render -o out.exr --png nodir/x.png` used to write out.exr, then fail; an existing
/// out.exr was replaced by a run that reported failure. Every optional output is tried.
#[test]
fn a_failed_render_leaves_every_existing_output_as_it_was() {
    let dir = tmp_dir("render");
    let scene = common::bundled("cornell-box.toml");
    let old: Vec<(PathBuf, &[u8])> = vec![
        (dir.join("out.exr"), b"old exr"),
        (dir.join("out.png"), b"old png"),
        (dir.join("stats.json"), b"old stats"),
        (dir.join("map.png"), b"old map"),
    ];
    for (p, bytes) in &old {
        std::fs::write(p, bytes).expect("old output");
    }
    let bad = dir.join("nodir").join("x.png");
    let bad = s(&bad);
    let (exr, png, stats, map) = (s(&old[0].0), s(&old[1].0), s(&old[2].0), s(&old[3].0));
    let scene = s(&scene);
    let common_args = [
        "render",
        scene,
        "--size",
        "8x8",
        "--plane-resolution",
        "8",
        "--quiet",
    ];
    let cases: Vec<Vec<&str>> = vec![
        vec!["-o", exr, "--png", bad],
        vec!["-o", exr, "--png", png, "--stats", bad],
        vec!["-o", exr, "--record-map", bad, "--stats", stats],
        vec!["-o", bad, "--png", png, "--record-map", map],
        // The same file twice is refused before anything is rendered.
        vec!["-o", png, "--png", png],
    ];
    for case in cases {
        let args: Vec<&str> = common_args.iter().copied().chain(case.clone()).collect();
        let (code, _, err) = radsplat(&args);
        assert_ne!(code, 0, "{case:?} should fail");
        assert!(
            err.contains("nodir") || err.contains("twice"),
            "{case:?}: the error names the bad output: {err}"
        );
        for (p, bytes) in &old {
            assert_eq!(
                std::fs::read(p).expect("old output").as_slice(),
                *bytes,
                "{case:?} changed {}",
                p.display()
            );
        }
        assert_eq!(
            entries(&dir),
            ["map.png", "out.exr", "out.png", "stats.json"],
            "{case:?} left a file behind"
        );
    }
}

/// A good render ends its process once its outputs are committed, without tearing the
/// device down (`Rendered::end_process`): it exits 0 with every output written (and no
/// temporary file), its summary printed, and the pipeline cache saved where the device
/// keeps one, as a context's drop would.
#[test]
fn a_good_render_ends_with_its_outputs_and_pipeline_cache_written() {
    let dir = tmp_dir("render-ok");
    let cache_dir = dir.join("pipelines");
    let scene = common::bundled("cornell-box.toml");
    let (exr, png, stats) = (dir.join("out.exr"), dir.join("out.png"), dir.join("s.json"));
    let out = Command::new(env!("CARGO_BIN_EXE_radsplat"))
        .args([
            "render",
            s(&scene),
            "--size",
            "8x8",
            "--plane-resolution",
            "8",
            "-o",
            s(&exr),
            "--png",
            s(&png),
            "--stats",
            s(&stats),
        ])
        .env("RADSPLAT_CACHE_DIR", &cache_dir)
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .expect("run radsplat");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("wrote"), "the summary is printed: {err}");
    assert_eq!(entries(&dir), ["out.exr", "out.png", "pipelines", "s.json"]);
    assert!(std::fs::metadata(&exr).expect("exr").len() > 0);
    let ctx = common::gpu();
    if ctx
        .device
        .features()
        .contains(wgpu::Features::PIPELINE_CACHE)
    {
        let info = ctx.adapter_info.clone().expect("own adapter");
        let key = wgpu::util::pipeline_cache_key(&info).expect("key");
        let saved = std::fs::read(cache_dir.join(format!("{key}.bin")))
            .expect("the pipeline cache saved before the process ended");
        assert!(!saved.is_empty());
    }
}

/// `reference --png nodir/x.png` likewise leaves its EXR alone; a good run writes both.
#[test]
fn a_failed_reference_leaves_its_exr_alone_and_a_good_one_writes_all() {
    let dir = tmp_dir("reference");
    let scene = common::bundled("cornell-box.toml");
    let exr = dir.join("ref.exr");
    std::fs::write(&exr, b"old").expect("old");
    let bad = dir.join("nodir").join("x.png");
    let args = [
        "reference",
        s(&scene),
        "--spp",
        "1",
        "--size",
        "8x8",
        "--quiet",
    ];
    let (code, _, err) = radsplat(&[&args[..], &["-o", s(&exr), "--png", s(&bad)]].concat());
    assert_ne!(code, 0);
    assert!(err.contains("nodir"), "{err}");
    assert_eq!(std::fs::read(&exr).expect("exr"), b"old");
    let png = dir.join("ref.png");
    let (code, _, err) = radsplat(&[&args[..], &["-o", s(&exr), "--png", s(&png)]].concat());
    assert_eq!(code, 0, "{err}");
    assert_ne!(
        std::fs::read(&exr).expect("exr"),
        b"old",
        "the EXR was rewritten"
    );
    assert!(png.is_file());
    assert_eq!(
        entries(&dir),
        ["ref.exr", "ref.png"],
        "no temporary file left"
    );
}

/// Without XDG_RUNTIME_DIR, libwayland (called by Mesa's device-select layer) printed
/// "error: XDG_RUNTIME_DIR is invalid or not set in the environment." twice on every run,
/// even with --quiet: a user sees only radsplat's own messages now.
#[test]
fn a_quiet_successful_run_prints_nothing() {
    let dir = tmp_dir("quiet");
    let scene = common::bundled("cornell-box.toml");
    let exr = dir.join("out.exr");
    let (code, out, err) = radsplat(&[
        "render",
        s(&scene),
        "--size",
        "8x8",
        "--direct-only",
        "-o",
        s(&exr),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(err, "", "stderr of a quiet run");
    assert_eq!(out, "", "stdout of a quiet run");
    let (code, out, err) = radsplat(&["info"]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("XDG_RUNTIME_DIR"), "{err}");
    assert!(out.contains("adapter:"), "{out}");
}

/// The CLI gives lavapipe two compute threads per core (its static split of each dispatch
/// left a thread idle while the other finished a costlier share: nave-west 0.86x the time),
/// unless the user chose a count, which it keeps.
#[test]
fn the_cli_gives_lavapipe_two_threads_per_core_unless_the_user_chose() {
    let run = |threads: Option<&str>| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_radsplat"));
        cmd.arg("info")
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("LP_NUM_THREADS");
        if let Some(t) = threads {
            cmd.env("LP_NUM_THREADS", t);
        }
        let out = cmd.output().expect("run radsplat info");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    let out = run(None);
    if !out.contains("device type:  Cpu") {
        // Another kind of device ignores the variable and `info` does not print it; the
        // suite runs on lavapipe (README.md), where this is checked.
        assert!(!out.contains("LP_NUM_THREADS"), "{out}");
        return;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let expected = (2 * cores).min(32);
    assert!(
        out.contains(&format!("LP_NUM_THREADS={expected}")),
        "{cores} cores: {out}"
    );
    assert!(run(Some("3")).contains("LP_NUM_THREADS=3"));
}

/// `animate` checks its stats path before the first frame: a bad one writes no frame.
#[test]
fn an_animation_with_a_bad_stats_path_writes_no_frame() {
    let dir = tmp_dir("animate");
    let scene = common::bundled("cube-in-box-anim.toml");
    let pattern = dir.join("f_####.exr");
    let bad = dir.join("nodir").join("s.json");
    let (code, _, err) = radsplat(&[
        "animate",
        s(&scene),
        "--frames",
        "0..1",
        "--size",
        "8x8",
        "--plane-resolution",
        "8",
        "-o",
        s(&pattern),
        "--stats",
        s(&bad),
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("nodir"), "{err}");
    assert!(entries(&dir).is_empty(), "{:?}", entries(&dir));
}

/// `render` times its passes only with `--time-passes` (a profile that costs on lavapipe):
/// without it `--stats` has no pass times and the summary says how to get them; with it
/// both have them. The image is the same bytes either way.
#[test]
fn render_times_its_passes_only_with_time_passes() {
    let dir = tmp_dir("time-passes");
    let scene = common::bundled("cornell-box.toml");
    let mut runs = Vec::new();
    for timed in [false, true] {
        let exr = dir.join(format!("out-{timed}.exr"));
        let stats = dir.join(format!("stats-{timed}.json"));
        let mut args = vec![
            "render",
            s(&scene),
            "--size",
            "16x16",
            "--plane-resolution",
            "8",
            "-o",
            s(&exr),
            "--stats",
            s(&stats),
        ];
        if timed {
            args.push("--time-passes");
        }
        let (code, _, err) = radsplat(&args);
        assert_eq!(code, 0, "{err}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).expect("stats")).expect("json");
        let passes = json["frame"]["pass_ms"].as_array().expect("pass_ms").len();
        runs.push((std::fs::read(&exr).expect("exr"), passes, err));
    }
    let (untimed_exr, untimed_passes, untimed_err) = &runs[0];
    let (timed_exr, timed_passes, timed_err) = &runs[1];
    assert_eq!(*untimed_passes, 0, "untimed --stats has pass times");
    assert!(
        untimed_err.contains("pass times with --time-passes"),
        "{untimed_err}"
    );
    assert!(untimed_exr == timed_exr, "timing changed the image");
    let (_, info, _) = radsplat(&["info"]);
    if info.contains("TIMESTAMP_QUERY (per-pass GPU times, with --time-passes): true") {
        assert!(*timed_passes > 5, "timed: {timed_passes} pass times");
        assert!(timed_err.contains("hemisphere planes"), "{timed_err}");
    } else {
        assert!(timed_err.contains("no timestamps"), "{timed_err}");
    }
}
