//! Bad input through the command line: a clear message naming the problem, a non-zero
//! exit code, no panic and no output file.

mod common;

use std::path::Path;
use std::process::Command;

/// A fresh, empty directory for one test's files, removed when the test ends.
fn tmp_dir(name: &str) -> common::TestDir {
    common::TestDir::new(&format!("cli-{name}"))
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

fn no_files_in(dir: &Path) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .expect("dir")
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert!(left.is_empty(), "output left behind: {left:?}");
}

#[test]
fn resolution_beyond_device_limits_is_refused() {
    let dir = tmp_dir("huge");
    let exr = dir.join("out.exr");
    let scene = common::bundled("cornell-box.toml");
    let (code, err) = radsplat(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--size",
        "100000x100000",
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(
        err.contains("100000x100000") && err.contains("device limit"),
        "{err}"
    );
    no_files_in(&dir);
}

#[test]
fn missing_scene_file_is_named() {
    let dir = tmp_dir("missing");
    let exr = dir.join("out.exr");
    let (code, err) = radsplat(&[
        "render",
        "no/such/scene.toml",
        "-o",
        exr.to_str().unwrap(),
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("no/such/scene.toml"), "{err}");
    no_files_in(&dir);
}

#[test]
fn malformed_size_is_a_usage_error() {
    let scene = common::bundled("cornell-box.toml");
    let (code, err) = radsplat(&["render", scene.to_str().unwrap(), "--size", "12xfoo"]);
    assert_ne!(code, 0);
    assert!(err.contains("foo"), "{err}");
}

#[test]
fn output_into_missing_directory_fails_cleanly() {
    let dir = tmp_dir("nodir");
    let exr = dir.join("not-here").join("out.exr");
    let scene = common::bundled("cornell-box.toml");
    let (code, err) = radsplat(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--size",
        "16x16",
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("not-here"), "{err}");
    no_files_in(&dir);
}

/// Outputs are renamed into place, so one named by a device or FIFO would replace it
/// (`--stats /dev/null` run as root replaced the system's /dev/null): refused before any
/// work. A PNG-only flag refuses a name that says another format.
#[cfg(unix)]
#[test]
fn outputs_onto_devices_or_in_the_wrong_format_are_refused() {
    let dir = tmp_dir("special-out");
    let exr = dir.join("out.exr");
    let scene = common::bundled("cornell-box.toml");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            exr.to_str().unwrap(),
            "--size",
            "16x16",
            "--quiet",
        ];
        args.extend_from_slice(extra);
        radsplat(&args)
    };
    let (code, err) = run(&["--stats", "/dev/null"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("/dev/null") && err.contains("not a regular file"),
        "{err}"
    );
    let jpg = dir.join("out.jpg");
    let (code, err) = run(&["--png", jpg.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(err.contains("out.jpg") && err.contains(".png"), "{err}");
    no_files_in(&dir);
    let meta = std::fs::metadata("/dev/null").expect("/dev/null");
    assert!(!meta.is_file(), "/dev/null is still a device");
}

/// A transform that carries geometry past what f32 resolves is refused, naming where the
/// scene reaches (a cube moved 1e20 away rendered without indirect light, silently).
#[test]
fn a_scene_carried_beyond_f32_precision_is_refused() {
    let dir = tmp_dir("far-scene");
    let cube = common::bundled("cube.obj");
    let scene = dir.join("far.toml");
    std::fs::write(
        &scene,
        format!(
            "[camera]\nposition = [0.0, 0.5, 3.0]\ntarget = [0.0, 0.5, 0.0]\nfov_y = 50.0\n\
             resolution = [8, 8]\n\n[[mesh]]\nfile = \"{}\"\n\n[[mesh]]\nfile = \"{}\"\n\
             translate = [1e20, 0.0, 0.0]\n\n[[light]]\ntype = \"point\"\n\
             position = [0.0, 3.0, 0.0]\nintensity = [10.0, 10.0, 10.0]\n",
            cube.display(),
            cube.display()
        ),
    )
    .expect("scene");
    let out = dir.join("out");
    std::fs::create_dir(&out).expect("out dir");
    let exr = out.join("far.exr");
    let (code, err) = radsplat(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("1e20") && err.contains("1e9"), "{err}");
    // A cube alone, 1e5 from the origin: within the coordinates' range, but rays would
    // leave its surfaces 3 units off them, more than the cube.
    std::fs::write(
        &scene,
        format!(
            "[camera]\nposition = [1e5, 0.5, 3.0]\ntarget = [1e5, 0.5, 0.0]\nfov_y = 50.0\n\
             resolution = [8, 8]\n\n[[mesh]]\nfile = \"{}\"\ntranslate = [1e5, 0.0, 0.0]\n\n\
             [[light]]\ntype = \"point\"\nposition = [1e5, 3.0, 0.0]\n\
             intensity = [10.0, 10.0, 10.0]\n",
            cube.display()
        ),
    )
    .expect("scene");
    let (code, err) = radsplat(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(
        err.contains("from the origin") && err.contains("of the scene"),
        "{err}"
    );
    no_files_in(&out);
}

/// Point lights cast one shadow ray each, whatever `light_samples` says: 17 of them with
/// 16 samples render on lavapipe (they were counted as 272 rays and refused), and past its
/// limit of 256 rays the message names the lights, not a setting already at 1.
#[test]
fn point_lights_count_one_shadow_ray_each() {
    let dir = tmp_dir("many-points");
    let cube = common::bundled("cube.obj");
    let scene_with = |lights: usize, samples: u32| {
        let mut text = format!(
            "[camera]\nposition = [0.0, 0.5, 3.0]\ntarget = [0.0, 0.5, 0.0]\nfov_y = 50.0\n\
             resolution = [8, 8]\n\n[render]\nlight_samples = {samples}\n\n[[mesh]]\n\
             file = \"{}\"\n",
            cube.display()
        );
        for i in 0..lights {
            text += &format!(
                "\n[[light]]\ntype = \"point\"\nposition = [{}, 3.0, 1.0]\n\
                 intensity = [0.1, 0.1, 0.1]\n",
                i as f32 * 0.01
            );
        }
        let path = dir.join(format!("points{lights}.toml"));
        std::fs::write(&path, text).expect("scene");
        path
    };
    let out = dir.join("out");
    std::fs::create_dir(&out).expect("out dir");
    let exr = out.join("o.exr");
    let render = |scene: &Path| {
        radsplat(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            exr.to_str().unwrap(),
            "--direct-only",
            "--quiet",
        ])
    };
    let (code, err) = render(&scene_with(17, 16));
    assert_eq!(code, 0, "{err}");
    std::fs::remove_file(&exr).expect("rendered");
    let (code, err) = render(&scene_with(257, 1));
    assert_ne!(code, 0);
    assert!(err.contains("257 point, spot and sun lights"), "{err}");
    no_files_in(&out);
}

/// A reference of more bounce directions than a run could ever trace is refused at once
/// (`--spp 4294967295` planned its dispatches until the machine ran out of memory).
#[test]
fn reference_samples_beyond_the_cap_are_refused() {
    let dir = tmp_dir("spp");
    let exr = dir.join("ref.exr");
    let scene = common::bundled("cornell-box.toml");
    let (code, err) = radsplat(&[
        "reference",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--size",
        "8x8",
        "--spp",
        "4294967295",
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("--spp") && err.contains("16777216"), "{err}");
    no_files_in(&dir);
}

#[test]
fn render_writes_exr_and_png() {
    let dir = tmp_dir("ok");
    let exr = dir.join("c.exr");
    let png = dir.join("c.png");
    let scene = common::bundled("cornell-box.toml");
    let (code, err) = radsplat(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--size",
        "32x32",
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
    let (w, h, channels) = radsplat::output::read_exr_channels(&exr).expect("read back");
    assert_eq!((w, h), (32, 32));
    for name in ["R", "G", "B", "albedo.R", "normal.X", "depth.Z", "direct.R"] {
        assert!(
            channels.iter().any(|(n, _)| n == name),
            "missing channel {name}"
        );
    }
    let img = image::open(&png).expect("png");
    assert_eq!((img.width(), img.height()), (32, 32));
}

#[test]
fn output_format_follows_the_extension() {
    let dir = tmp_dir("format");
    let scene = common::bundled("cornell-box.toml");
    let tif = dir.join("c.tif");
    let (code, err) = radsplat(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        tif.to_str().unwrap(),
        "--direct-only",
        "--size",
        "16x16",
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("c.tif") && err.contains(".png"), "{err}");
    no_files_in(&dir);

    let png = dir.join("c.png");
    let (code, err) = radsplat(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--direct-only",
        "--size",
        "16x16",
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
    let img = image::open(&png).expect("-o c.png writes a PNG");
    assert_eq!((img.width(), img.height()), (16, 16));
}

#[test]
fn animate_writes_one_image_per_frame_and_refuses_bad_patterns() {
    let dir = tmp_dir("animate");
    let scene = common::bundled("cube-in-box-anim.toml");
    // A pattern without '#' would overwrite one file: refused before rendering.
    let single = dir.join("frame.exr");
    let (code, err) = radsplat(&[
        "animate",
        scene.to_str().unwrap(),
        "--frames",
        "0..1",
        "-o",
        single.to_str().unwrap(),
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("frame.exr") && err.contains('#'), "{err}");
    no_files_in(&dir);
    // The lifespan map needs temporal caching.
    let pattern = dir.join("f_##.png");
    let (code, err) = radsplat(&[
        "animate",
        scene.to_str().unwrap(),
        "--frames",
        "0..1",
        "-o",
        pattern.to_str().unwrap(),
        "--temporal",
        "off",
        "--lifespan-map",
        dir.join("l_##.png").to_str().unwrap(),
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("--lifespan-map"), "{err}");
    no_files_in(&dir);
    // Directories that do not exist are refused before rendering (the second pass of
    // interpolated gradients writes the first image only after every record is computed),
    // and an estimate stride that does not divide the plane is named.
    for (flag, value) in [
        ("-o", dir.join("missing/f_##.png")),
        ("--stats", dir.join("missing/stats.json")),
        ("--lifespan-map", dir.join("missing/l_##.png")),
    ] {
        let mut args = vec![
            "animate".to_string(),
            scene.to_string_lossy().into_owned(),
            "--frames".into(),
            "0..1".into(),
            "--quiet".into(),
            flag.into(),
            value.to_string_lossy().into_owned(),
        ];
        if flag != "-o" {
            args.extend(["-o".into(), pattern.to_string_lossy().into_owned()]);
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, err) = radsplat(&args);
        assert_ne!(code, 0);
        assert!(
            err.contains("missing") && err.contains("does not exist"),
            "{flag}: {err}"
        );
        no_files_in(&dir);
    }
    let (code, err) = radsplat(&[
        "animate",
        scene.to_str().unwrap(),
        "--frames",
        "0..1",
        "--plane-resolution",
        "16",
        "--estimate-stride",
        "3",
        "-o",
        pattern.to_str().unwrap(),
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("estimate stride (3)"), "{err}");
    no_files_in(&dir);

    let stats = dir.join("stats.json");
    let (code, err) = radsplat(&[
        "animate",
        scene.to_str().unwrap(),
        "--frames",
        "3..5",
        "--size",
        "16x16",
        "--plane-resolution",
        "8",
        "-o",
        pattern.to_str().unwrap(),
        "--lifespan-map",
        dir.join("l_##.png").to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
    for f in 3..=5 {
        let img = image::open(dir.join(format!("f_{f:02}.png"))).expect("frame PNG");
        assert_eq!((img.width(), img.height()), (16, 16));
        assert!(dir.join(format!("l_{f:02}.png")).exists());
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).expect("stats")).expect("JSON");
    let frames = json["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), 3);
    assert_eq!(frames[0]["frame"], 3);
    assert!(frames[0]["temporal"]["new"].as_u64().unwrap_or(0) > 0);
}

#[test]
fn nonsense_cache_and_table_settings_name_the_flag_and_value() {
    let scene = common::bundled("cornell-box.toml");
    let scene = scene.to_str().unwrap();
    let dir = tmp_dir("nonsense-flags");
    let exr = dir.join("out.exr");
    let exr = exr.to_str().unwrap();
    // (arguments, what the message must contain)
    let cases: [(&[&str], &[&str]); 18] = [
        (
            &["render", scene, "-o", exr, "-a", "0"],
            &["--accuracy", "'0'", "(0, 1]"],
        ),
        (
            &["render", scene, "-o", exr, "--plane-fov", "200"],
            &["--plane-fov", "'200'", "(1, 179)"],
        ),
        (
            &["render", scene, "-o", exr, "--plane-resolution", "0"],
            &["--plane-resolution", "'0'", "2..=512"],
        ),
        (
            &["render", scene, "-o", exr, "--record-budget", "0"],
            &["--record-budget", "'0'", "--direct-only"],
        ),
        (
            &["render", scene, "-o", exr, "--r-max-factor", "nan"],
            &["--r-max-factor", "'nan'"],
        ),
        (
            &[
                "render",
                scene,
                "-o",
                exr,
                "--records",
                "vpl",
                "--vpl-paths",
                "0",
            ],
            &["--vpl-paths", "'0'"],
        ),
        (
            &[
                "render",
                scene,
                "-o",
                exr,
                "--records",
                "vpl",
                "--vpl-clamp",
                "nan",
            ],
            &["--vpl-clamp NaN", ">= 0"],
        ),
        (
            &["temporal-error", scene, "--record-count", "0"],
            &["--record-count 0", "at least 1"],
        ),
        (
            &[
                "render",
                scene,
                "-o",
                exr,
                "--records",
                "photons",
                "--photon-gather",
                "2",
            ],
            &["--photon-gather 2", "8 to 1024"],
        ),
        (
            &[
                "render",
                scene,
                "-o",
                exr,
                "--records",
                "photons",
                "--photon-area",
                "disc",
            ],
            &["--photon-area", "disc", "hull", "probed"],
        ),
        (
            &[
                "render",
                scene,
                "-o",
                exr,
                "--records",
                "photons",
                "--photon-paths",
                "0",
            ],
            &["--photon-paths", "'0'"],
        ),
        (
            &[
                "animate",
                scene,
                "--frames",
                "0..1",
                "-o",
                "out_##.exr",
                "--records",
                "photons",
            ],
            &["--records photons", "--temporal off"],
        ),
        // Counts past any use, which had filled the memory or wrapped around.
        (
            &["render", scene, "-o", exr, "--glossy-samples", "4294967295"],
            &["--glossy-samples", "4294967295", "65536"],
        ),
        (
            &[
                "animate",
                scene,
                "--frames",
                "0..1",
                "-o",
                "out_##.exr",
                "--max-lifespan",
                "4294967295",
            ],
            &["--max-lifespan", "4294967295", "65536"],
        ),
        (
            &["plane-error", scene, "--points", "4294967295"],
            &["--points (4294967295)", "1048576"],
        ),
        (
            &["plane-error", scene, "--mc-samples", "4294967295"],
            &["--mc-samples (4294967295)", "1048576"],
        ),
        (
            &["temporal-error", scene, "--frame", "4294967295"],
            &["--frame 4294967295", "past the last frame"],
        ),
        (
            &[
                "render",
                scene,
                "-o",
                exr,
                "--radiance-plane-resolution",
                "1",
            ],
            &["--radiance-plane-resolution", "1", "2..=512"],
        ),
    ];
    for (args, parts) in cases {
        let (code, err) = radsplat(args);
        assert_ne!(code, 0, "{args:?} succeeded");
        for part in parts {
            assert!(err.contains(part), "{args:?}: expected {part:?} in: {err}");
        }
    }
    // Radiance records' basis table past the device's binding: refused before its
    // integrals are computed (39 s for this one), naming the flags to lower.
    let glossy = common::bundled("cornell-box-glossy.toml");
    let t0 = std::time::Instant::now();
    let (code, err) = radsplat(&[
        "render",
        glossy.to_str().unwrap(),
        "-o",
        exr,
        "--size",
        "8x8",
        "--radiance-plane-resolution",
        "512",
        "--radiance-order",
        "10",
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(
        err.contains("--radiance-plane-resolution") && err.contains("--radiance-order"),
        "{err}"
    );
    eprintln!("refused in {:.1} s", t0.elapsed().as_secs_f64());
    // Thesis Table 4.1 over a scene nothing lights: an error, not a table of zeros.
    let dark = dir.join("dark.toml");
    std::fs::write(
        &dark,
        format!(
            "[camera]\nposition = [0.0, 0.5, 3.0]\ntarget = [0.0, 0.5, 0.0]\nfov_y = 50.0\n\
             resolution = [8, 8]\n\n[[mesh]]\nfile = \"{}\"\n",
            common::bundled("cube.obj").display()
        ),
    )
    .expect("scene");
    let (code, err) = radsplat(&[
        "plane-error",
        dark.to_str().unwrap(),
        "--points",
        "8",
        "--mc-samples",
        "16",
        "--quiet",
    ]);
    assert_ne!(code, 0);
    assert!(
        err.contains("dark.toml") && err.contains("no point"),
        "{err}"
    );
    std::fs::remove_file(&dark).expect("remove");
    no_files_in(&dir);
}

#[test]
fn cache_settings_errors_name_the_setting_flag_and_value() {
    use radsplat::records::CacheSettings;
    let cases = [
        (
            CacheSettings {
                accuracy: 0.0,
                ..CacheSettings::default()
            },
            "-a/--accuracy) 0",
        ),
        (
            CacheSettings {
                plane_fov_degrees: 200.0,
                ..CacheSettings::default()
            },
            "--plane-fov) 200",
        ),
        (
            CacheSettings {
                plane_resolution: 0,
                ..CacheSettings::default()
            },
            "--plane-resolution) 0",
        ),
        (
            CacheSettings {
                record_budget: 0,
                ..CacheSettings::default()
            },
            "--record-budget) 0",
        ),
        // Below 1 the gather would leave pixels that placement covered without a record.
        (
            CacheSettings {
                interpolation_factor: 0.9,
                ..CacheSettings::default()
            },
            "--interpolation-factor) 0.9",
        ),
        (
            CacheSettings {
                interpolation_factor: f32::NAN,
                ..CacheSettings::default()
            },
            "--interpolation-factor) NaN",
        ),
        (
            CacheSettings {
                noise_widening: -0.5,
                ..CacheSettings::default()
            },
            "--noise-widening) -0.5",
        ),
        (
            CacheSettings {
                noise_widening: f32::INFINITY,
                ..CacheSettings::default()
            },
            "--noise-widening) inf",
        ),
        (
            CacheSettings {
                widening_tolerance: -0.1,
                ..CacheSettings::default()
            },
            "--widening-tolerance) -0.1",
        ),
        (
            CacheSettings {
                widening_tolerance: f32::NAN,
                ..CacheSettings::default()
            },
            "--widening-tolerance) NaN",
        ),
    ];
    for (settings, want) in cases {
        let err = settings.validate().expect_err(want).to_string();
        assert!(err.contains(want), "expected {want:?} in: {err}");
    }
    CacheSettings::default()
        .validate()
        .expect("the defaults are valid");
}
