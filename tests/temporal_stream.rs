//! Long animations with interpolated temporal gradients (issue 16): the second pass
//! follows the first at most dt_max frames behind, so frames are written while the range
//! is still being computed and memory is bounded by dt_max, not by the range; and the cap
//! on new records per frame from the command line.

mod common;

use radsplat::Error;
use radsplat::frame::Renderer;
use radsplat::records::CacheSettings;
use radsplat::temporal::TemporalSettings;
use radsplat::temporal::animation::{AnimationOptions, AnimationStep, render_animation};
use std::process::Command;

const DT_MAX: u32 = 4;

fn tiny_cache() -> CacheSettings {
    CacheSettings {
        accuracy: 0.25,
        plane_resolution: 8,
        // What the CLI gives animations and VPL/photon records (they were measured so).
        r_min_pixels: CacheSettings::ANIMATION_R_MIN_PIXELS,
        ..CacheSettings::default()
    }
}

/// What `on_frame` saw of one frame.
struct Seen {
    frame: u32,
    first_pass_at: Option<u32>,
    /// The largest frame `progress` reported computed by then.
    computed: Option<u32>,
    retained_records: usize,
    retained_frames: usize,
    alive: u32,
    /// Records computed so far (new and replacements, over the frames handed over).
    created: u64,
    beauty: Vec<u32>,
}

/// Frames of cube-in-box-anim (16 x 16, 8 x 8 planes, dt_max 4) over `frames`, until
/// `stop` frames were handed over (then `on_frame` stops the animation with an error).
fn run(
    renderer: &Renderer,
    frames: std::ops::RangeInclusive<u32>,
    stop: usize,
) -> (radsplat::Result<()>, Vec<Seen>) {
    let scene = common::load("cube-in-box-anim.toml", Some((16, 16)));
    let options = AnimationOptions {
        frames,
        cache: tiny_cache(),
        temporal: Some(TemporalSettings {
            max_lifespan: DT_MAX,
            ..TemporalSettings::default()
        }),
    };
    let computed = std::cell::Cell::new(None::<u32>);
    let mut seen = Vec::new();
    let mut created = 0;
    let result = render_animation(
        renderer,
        &scene,
        &options,
        |f| {
            created += u64::from(f.stats.temporal.new + f.stats.temporal.replaced);
            seen.push(Seen {
                frame: f.frame_number,
                first_pass_at: f.first_pass_at,
                computed: computed.get(),
                retained_records: f.retained_records,
                retained_frames: f.retained_frames,
                alive: f.stats.temporal.alive,
                created,
                beauty: f
                    .frame
                    .beauty
                    .iter()
                    .flatten()
                    .map(|c| c.to_bits())
                    .collect(),
            });
            if seen.len() >= stop {
                return Err(Error::Usage("stopped by the test".into()));
            }
            Ok(())
        },
        |t, step| {
            if step == AnimationStep::Computed {
                computed.set(Some(t));
            }
        },
    );
    renderer.ctx.check().expect("no wgpu errors");
    (result.map(|_| ()), seen)
}

/// A range of 10^9 frames: the first frame is written once the first pass is dt_max
/// frames ahead (the old two passes wrote nothing before the whole range was computed,
/// and kept every frame's statistics), every later frame follows at most dt_max behind,
/// and the records and frame lists retained stay bounded by dt_max while the records
/// computed grow with the frames. The frames whose records all end within a shorter
/// range are the same bytes as that range's: each frame's bytes do not depend on how far
/// the range goes beyond its records' successors.
#[test]
fn a_long_range_streams_its_frames_with_bounded_memory() {
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let stop = 40;
    let (result, seen) = run(&renderer, 0..=999_999_999, stop);
    match result {
        Err(Error::Usage(m)) if m == "stopped by the test" => {}
        other => panic!("the animation should stop at the test's error: {other:?}"),
    }
    assert_eq!(
        seen.iter().map(|s| s.frame).collect::<Vec<_>>(),
        (0..stop as u32).collect::<Vec<_>>(),
        "frames handed over in order"
    );
    for s in &seen {
        let at = s.first_pass_at.expect("two passes");
        assert!(
            at >= s.frame && at <= s.frame + DT_MAX,
            "frame {} handed over with the first pass at {at} (dt_max {DT_MAX})",
            s.frame
        );
        assert_eq!(
            s.computed,
            Some(at),
            "progress reported the first pass's frame"
        );
    }
    // The first frame goes out after at most dt_max frames of the first pass.
    assert!(seen[0].first_pass_at.is_some_and(|at| at <= DT_MAX));
    // Bounded: the frame lists of the window, and the records born in about 2 dt_max
    // frames (each frame creates at most the records it uses).
    let max_alive = seen.iter().map(|s| s.alive as usize).max().unwrap_or(0);
    assert!(max_alive > 0);
    for s in &seen {
        assert!(
            s.retained_frames <= DT_MAX as usize + 2,
            "frame {}: {} frame lists retained",
            s.frame,
            s.retained_frames
        );
        assert!(
            s.retained_records <= (2 * DT_MAX as usize + 2) * max_alive,
            "frame {}: {} records retained (at most {max_alive} alive)",
            s.frame,
            s.retained_records
        );
    }
    let end = seen.last().expect("frames");
    eprintln!(
        "{} frames: {} records computed, {} retained at the end (most {}), {max_alive} alive at most",
        seen.len(),
        end.created,
        end.retained_records,
        seen.iter().map(|s| s.retained_records).max().unwrap_or(0)
    );
    assert!(
        (end.retained_records as u64) * 2 < end.created,
        "{} records retained of {} computed: nothing released",
        end.retained_records,
        end.created
    );

    // A 30-frame range: the records of its frames up to 29 - dt_max all end before frame
    // 29, so they have the same successors as in the long range.
    let (result, short) = run(&renderer, 0..=29, usize::MAX);
    result.expect("30 frames");
    assert_eq!(short.len(), 30);
    // Its last frame waits for the end of the range.
    assert_eq!(short[29].first_pass_at, Some(29));
    for t in 0..=(29 - DT_MAX) as usize {
        assert!(
            short[t].beauty == seen[t].beauty,
            "frame {t} differs between the 30-frame and the long range"
        );
    }
}

fn radsplat(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_radsplat"))
        .args(args)
        .output()
        .expect("run radsplat");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "radsplat panicked: {stderr}");
    (out.status.code().unwrap_or(-1), stderr)
}

/// `animate --max-new-records N`: no frame places more than N records, the frames go on
/// covering what is left, and 0 or the per-frame baseline are refused, naming the flag.
#[test]
fn animate_caps_new_records_per_frame() {
    let dir = std::env::temp_dir().join(format!("radsplat-max-new-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let scene = common::bundled("cube-in-box-anim.toml");
    let scene = scene.to_str().expect("path");
    let out = dir.join("f_##.png");
    let out = out.to_str().expect("path");
    let stats = dir.join("stats.json");
    let base = [
        "animate",
        scene,
        "--frames",
        "0..3",
        "--size",
        "16x16",
        "--plane-resolution",
        "8",
        "-o",
        out,
        "--quiet",
    ];
    for (extra, expected) in [
        (&["--max-new-records", "0"][..], "--max-new-records 0"),
        (
            &["--max-new-records", "2", "--temporal", "off"][..],
            "--max-new-records 2",
        ),
    ] {
        let (code, err) = radsplat(&[&base[..], extra].concat());
        assert_ne!(code, 0);
        assert!(err.contains(expected), "{err}");
        assert!(!dir.join("f_00.png").exists(), "a frame was written: {err}");
    }
    let cap = 3;
    let (code, err) = radsplat(
        &[
            &base[..],
            &[
                "--max-new-records",
                &cap.to_string(),
                "--stats",
                stats.to_str().expect("path"),
            ],
        ]
        .concat(),
    );
    assert_eq!(code, 0, "{err}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&stats).expect("stats")).expect("JSON");
    assert_eq!(json["temporal"]["max_new_records"], cap);
    let new: Vec<u64> = json["frames"]
        .as_array()
        .expect("frames")
        .iter()
        .map(|f| f["temporal"]["new"].as_u64().expect("new"))
        .collect();
    assert_eq!(new.len(), 4, "{new:?}");
    // Capped in every frame, and still placing after the first (16 x 16 needs more).
    assert!(new.iter().all(|&n| n <= cap), "{new:?}");
    assert!(new[1..].iter().any(|&n| n > 0), "{new:?}");
    for t in 0..4 {
        assert!(dir.join(format!("f_{t:02}.png")).exists(), "frame {t}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
