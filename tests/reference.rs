//! The reference renderer (direct + first-bounce indirect by Monte Carlo) against its
//! plain-Rust mirror, its determinism and independence of chunking, and a physical sanity
//! check on the Cornell box.

mod common;

use glam::Vec3;
use radsplat::{PreparedScene, Renderer};

use radsplat::compare::luminance;
use radsplat::reference::cpu::{IndirectPixel, IndirectReference};
use radsplat::reference::{
    ReferenceFrame, ReferenceOptions, ReferencePass, max_samples_per_dispatch,
};
use radsplat::scene::Scene;
use radsplat::visibility::GpuCamera;

fn render(scene: &Scene, options: &ReferenceOptions) -> ReferenceFrame {
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(scene).expect("prepare");
    let pass = ReferencePass::new(&renderer.ctx).expect("reference pass");
    let frame = render_with(&pass, &renderer, &prepared, scene, options).expect("reference frame");
    renderer.ctx.check().expect("no wgpu errors");
    frame
}

/// `pass`'s reference of `scene`, prepared on `renderer` as `prepared`, without progress.
fn render_with(
    pass: &ReferencePass,
    renderer: &Renderer,
    prepared: &PreparedScene,
    scene: &Scene,
    options: &ReferenceOptions,
) -> radsplat::Result<ReferenceFrame> {
    pass.render(renderer, prepared, &scene.camera, options, &mut |_, _| {})
}

fn cornell(size: u32, light_samples: u32) -> Scene {
    let mut scene = common::load("cornell-box.toml", Some((size, size)));
    scene.settings.light_samples = light_samples;
    scene
}

fn v(p: [f32; 4]) -> Vec3 {
    Vec3::new(p[0], p[1], p[2])
}

/// The GPU reference of `scene` at `spp` and, for each pixel whose camera ray hits the same
/// triangle on both sides (a traversal tie is the visibility tests' business), its index
/// and the CPU mirror's pixel.
fn gpu_and_cpu(scene: &Scene, spp: u32) -> (ReferenceFrame, Vec<(usize, IndirectPixel)>) {
    let gpu = render(scene, &ReferenceOptions::new(spp));
    let cpu = IndirectReference::new(scene, scene.settings.light_samples, spp);
    let cam = GpuCamera::new(&scene.camera);
    let mut pixels = Vec::new();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let i = (y * cam.width + x) as usize;
            let r = cpu.pixel(&cam, x, y);
            let g = gpu.frame.visibility[i];
            if g.is_hit().then_some((g.instance, g.mesh_triangle)) == r.direct.hit {
                pixels.push((i, r));
            }
        }
    }
    (gpu, pixels)
}

// Tolerance: GPU and CPU draw bit-identical directions and light samples and sum them in the
// same order, so values agree to f32 rounding (~1e-5) except where a bounce or shadow ray
// grazes an edge and the two traversals disagree: one of 16 bounce samples then changes,
// which moves that pixel's indirect value by up to a few percent (measured on lavapipe:
// mean 1.2e-7, 99th percentile 1.6e-6, max 5.4e-6, i.e. no flips). We bound the 99th
// percentile of the per-pixel relative error at 1e-3 and the mean at 1e-4, relative to
// max(|CPU|, 1 % of the image's mean indirect) so that near-black pixels do not dominate.
#[test]
fn reference_matches_cpu_mirror_cornell_box() {
    let scene = cornell(24, 8);
    let (gpu, pixels) = gpu_and_cpu(&scene, 16);
    let mean_indirect = gpu
        .indirect
        .iter()
        .map(|p| v(*p).max_element())
        .sum::<f32>()
        / gpu.indirect.len() as f32;
    assert!(mean_indirect > 0.0, "no indirect light at all");
    let floor = 0.01 * mean_indirect;
    let mut errors = Vec::new();
    for (i, r) in &pixels {
        for (gv, cv) in [
            (v(gpu.indirect[*i]), r.indirect),
            (v(gpu.frame.beauty[*i]), r.beauty),
        ] {
            errors.push((gv - cv).abs().max_element() / cv.max_element().max(floor));
        }
    }
    let n = gpu.indirect.len();
    assert!(
        errors.len() > 2 * n * 9 / 10,
        "too few pixels agree on the camera hit"
    );
    let mean = errors.iter().sum::<f32>() / errors.len() as f32;
    errors.sort_by(f32::total_cmp);
    let p99 = errors[errors.len() * 99 / 100];
    eprintln!(
        "{} values: relative error mean {mean:.2e}, 99th percentile {p99:.2e}, max {:.2e}",
        errors.len(),
        errors[errors.len() - 1]
    );
    assert!(p99 < 1e-3, "99th percentile relative error {p99}");
    assert!(mean < 1e-4, "mean relative error {mean}");
}

/// llvmpipe stops running a loop after 65,535 iterations in one invocation, summed over
/// every entry: a pixel that traced all of its 128 x (1 + 16) rays in one dispatch saw every
/// bounce after about the 55th miss (its indirect light came out 56 % too dark, silently).
/// Dispatches now hold at most `MAX_RAYS_PER_INVOCATION` rays per pixel; the GPU must still
/// match its CPU mirror at many samples per pixel.
#[test]
fn reference_matches_cpu_mirror_with_many_samples_per_pixel() {
    let scene = cornell(8, 16);
    let (gpu, pixels) = gpu_and_cpu(&scene, 128);
    let (mut sum_gpu, mut sum_cpu) = (0.0f64, 0.0f64);
    let mut worst = 0.0f32;
    for (i, r) in &pixels {
        let (gv, cv) = (v(gpu.indirect[*i]), r.indirect);
        sum_gpu += f64::from(gv.element_sum());
        sum_cpu += f64::from(cv.element_sum());
        worst = worst.max((gv - cv).abs().max_element());
    }
    eprintln!("mean indirect GPU {sum_gpu:.5} CPU {sum_cpu:.5}, worst pixel {worst:.2e}");
    assert!(sum_cpu > 0.0, "no indirect light");
    assert!(
        ((sum_gpu - sum_cpu) / sum_cpu).abs() < 1e-4,
        "GPU indirect {sum_gpu} against CPU {sum_cpu}"
    );
    // f32 sums in the same order: only a ray grazing an edge could differ, by one sample.
    let mean_pixel = (sum_cpu / pixels.len().max(1) as f64) as f32;
    assert!(
        worst < 0.01 * mean_pixel,
        "worst pixel off by {worst} (mean {mean_pixel})"
    );
}

#[test]
fn reference_is_deterministic_and_independent_of_chunking() {
    let scene = cornell(24, 4);
    let spp = 8;
    let whole = render(&scene, &ReferenceOptions::new(spp));
    let again = render(&scene, &ReferenceOptions::new(spp));
    // One light with 4 samples (and the environment's 4): 9 rays per sample, 7 samples per
    // dispatch at most (MAX_RAYS_PER_INVOCATION).
    assert_eq!(max_samples_per_dispatch(8), 7);
    assert_eq!(whole.stats.dispatches, 2);
    let bytes = whole.encode_exr().expect("exr");
    assert_eq!(bytes, again.encode_exr().expect("exr"), "two runs differ");
    // 240 sample-pixels per dispatch: one sample of 10 rows at a time (24 dispatches).
    let chunked = render(
        &scene,
        &ReferenceOptions {
            spp,
            chunk_work: 240,
            seed: 0,
            bounces: 1,
        },
    );
    assert_eq!(chunked.stats.dispatches, 24);
    assert_eq!(
        bytes,
        chunked.encode_exr().expect("exr"),
        "chunking changed the image"
    );
}

/// A reference pass compiled for the scene's features alone (what `radsplat reference`
/// builds: less code to build and, on lavapipe, to run per path) renders the bytes of the
/// pass compiled for every feature, and refuses a scene with a feature it left out.
#[test]
fn a_reference_pass_for_the_scenes_features_gives_the_same_bytes_and_refuses_other_scenes() {
    let scene = cornell(24, 4);
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let options = ReferenceOptions::new(8);
    let every = ReferencePass::new(&renderer.ctx).expect("reference pass");
    let every = render_with(&every, &renderer, &prepared, &scene, &options).expect("reference");
    let own = ReferencePass::for_scene(&renderer.ctx, prepared.gpu.features())
        .expect("reference pass for the scene");
    let frame = render_with(&own, &renderer, &prepared, &scene, &options).expect("reference");
    assert_eq!(
        frame.encode_exr().expect("exr"),
        every.encode_exr().expect("exr"),
        "the pass compiled for the Cornell box's features changed its pixels"
    );
    // The environment sphere has an environment and no rect light.
    let other = common::load("env-sphere.toml", Some((16, 16)));
    let other_prepared = renderer.prepare(&other).expect("prepare");
    let refused = render_with(&own, &renderer, &other_prepared, &other, &options);
    let message = refused.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        message.contains("compiled for the scene features"),
        "a scene with other features was not refused: {message:?}"
    );
    renderer.ctx.check().expect("no wgpu errors");
}

/// `--seed`: seed 0 is the default sequence, another seed gives different pixels (an
/// independent scramble) whose image mean agrees within the noise, and the GPU still
/// matches its CPU mirror under that seed.
#[test]
fn reference_seeds_give_independent_noise_with_the_same_mean() {
    let scene = cornell(24, 4);
    let spp = 8;
    let zero = render(&scene, &ReferenceOptions::new(spp).with_seed(0));
    let default = render(&scene, &ReferenceOptions::new(spp));
    assert_eq!(
        zero.encode_exr().expect("exr"),
        default.encode_exr().expect("exr"),
        "seed 0 is not the default sequence"
    );
    let one = render(&scene, &ReferenceOptions::new(spp).with_seed(1));
    assert_eq!(one.stats.seed, 1);
    let lum = |f: &ReferenceFrame| -> Vec<f64> {
        f.indirect
            .iter()
            .map(|p| f64::from(luminance([p[0], p[1], p[2]])))
            .collect()
    };
    let (a, b) = (lum(&zero), lum(&one));
    let mean_a = a.iter().sum::<f64>() / a.len() as f64;
    let mean_b = b.iter().sum::<f64>() / b.len() as f64;
    let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    let lit = a.iter().filter(|x| **x > 0.0).count();
    eprintln!(
        "mean indirect seed 0 {mean_a:.5}, seed 1 {mean_b:.5}; {differing} of {lit} lit pixels differ"
    );
    assert!(mean_a > 0.0, "no indirect light");
    assert!(
        differing > lit * 9 / 10,
        "seed 1 left most pixels unchanged"
    );
    // 576 pixels x 8 samples: the image means agree to a few percent.
    assert!(
        ((mean_a - mean_b) / mean_a).abs() < 0.05,
        "means differ: {mean_a} against {mean_b}"
    );
    // The CPU mirror under seed 1, on a few pixels of the middle row.
    let mut cpu = IndirectReference::new(&scene, scene.settings.light_samples, spp);
    cpu.seed = 1;
    let cam = GpuCamera::new(&scene.camera);
    for x in [4, 12, 20] {
        let i = (12 * cam.width + x) as usize;
        let r = cpu.pixel(&cam, x, 12);
        let g = v(one.indirect[i]);
        assert!(
            (g - r.indirect).abs().max_element() <= 1e-3 * r.indirect.max_element().max(1e-3),
            "pixel ({x}, 12): GPU {g} against CPU {}",
            r.indirect
        );
    }
}

#[test]
fn cornell_box_indirect_is_a_plausible_fraction_of_direct() {
    let scene = cornell(32, 8);
    let r = render(&scene, &ReferenceOptions::new(32));
    let (mut direct, mut indirect) = (0.0f64, 0.0f64);
    let rgb = |p: [f32; 4]| [p[0], p[1], p[2]];
    for (i, &indirect_px) in r.indirect.iter().enumerate() {
        let ind = v(indirect_px);
        assert!(
            ind.min_element() >= 0.0 && ind.is_finite(),
            "pixel {i}: {ind}"
        );
        let vis = r.frame.visibility[i];
        if !vis.is_hit() {
            assert_eq!(ind, Vec3::ZERO, "background pixel {i} has indirect light");
        }
        // beauty = emission + direct + indirect
        let sum = v(r.frame.beauty[i]) - v(r.frame.direct[i]) - ind;
        assert!(
            sum.min_element() > -1e-4,
            "pixel {i}: beauty < direct + indirect"
        );
        direct += f64::from(luminance(rgb(r.frame.direct[i])));
        indirect += f64::from(luminance(rgb(indirect_px)));
    }
    let ratio = indirect / direct;
    eprintln!("Cornell box: indirect / direct luminance = {ratio:.3}");
    // Walls of albedo ~0.7 lit by a small ceiling light: the first bounce adds a fair share
    // of the direct light (the ceiling, lit only indirectly, makes it more than the albedo
    // alone would suggest) but not more than the direct light itself.
    assert!((0.15..0.8).contains(&ratio), "indirect / direct = {ratio}");
}

fn radsplat(args: &[&str]) -> (i32, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_radsplat"))
        .args(args)
        .output()
        .expect("run radsplat");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "radsplat panicked: {stderr}");
    (out.status.code().unwrap_or(-1), stderr)
}

/// A fresh, empty directory for one test's files, removed when the test ends.
fn tmp_dir(name: &str) -> common::TestDir {
    common::TestDir::new(&format!("ref-{name}"))
}

#[test]
fn reference_command_writes_indirect_aov_and_refuses_zero_spp() {
    let dir = tmp_dir("cli");
    let scene = common::bundled("cornell-box.toml");
    let exr = dir.join("r.exr");
    let args = |spp: &'static str| {
        vec![
            "reference".to_string(),
            scene.display().to_string(),
            "--spp".into(),
            spp.into(),
            "--size".into(),
            "8x8".into(),
            "-o".into(),
            exr.display().to_string(),
            "--quiet".into(),
        ]
    };
    let zero = args("0");
    let (code, err) = radsplat(&zero.iter().map(String::as_str).collect::<Vec<_>>());
    assert_ne!(code, 0);
    assert!(err.contains("--spp 0 must be between 1 and"), "{err}");
    assert!(!exr.exists());
    let ok = args("4");
    let (code, err) = radsplat(&ok.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(code, 0, "{err}");
    let (w, h, channels) = radsplat::output::read_exr_channels(&exr).expect("exr");
    assert_eq!((w, h), (8, 8));
    for name in ["R", "direct.G", "indirect.R", "indirect.G", "indirect.B"] {
        assert!(channels.iter().any(|(n, _)| n == name), "no channel {name}");
    }
}

#[test]
fn export_rad_writes_radiance_scene_and_textureless_variant() {
    let dir = tmp_dir("export");
    let scene = common::bundled("cornell-box.toml");
    let (code, err) = radsplat(&[
        "export-rad",
        scene.to_str().unwrap_or_default(),
        dir.to_str().unwrap_or_default(),
        "--size",
        "32x24",
    ]);
    assert_eq!(code, 0, "{err}");
    let rad = std::fs::read_to_string(dir.join("scene.rad")).expect("scene.rad");
    assert!(
        rad.contains("void light m3___rect_light_0 0 0 3 17 12 4"),
        "{rad}"
    );
    assert!(rad.contains("void plastic m0_white 0 0 5 0.725 0.71 0.68 0 0"));
    assert_eq!(
        rad.lines()
            .filter(|l| l.starts_with("m3___rect_light_0 polygon ") && l.contains(" 0 0 12 "))
            .count(),
        1,
        "the rect light as one 4-vertex polygon"
    );
    assert_eq!(
        rad.matches(" polygon ").count(),
        31,
        "30 box triangles + the light's quad"
    );
    let view = std::fs::read_to_string(dir.join("view.vf")).expect("view.vf");
    // -vh = 2 atan(tan(39.3° / 2) · 32/24)
    let vh = 2.0
        * ((39.3f64.to_radians() / 2.0).tan() * 32.0 / 24.0)
            .atan()
            .to_degrees();
    let got: f64 = view
        .split_once("-vv 39.3 -vh ")
        .and_then(|(_, rest)| rest.trim().parse().ok())
        .unwrap_or_else(|| panic!("no -vv/-vh in {view}"));
    assert!((got - vh).abs() < 1e-4, "-vh {got}, expected {vh}");
    let notex = radsplat::scene::load_scene(&dir.join("notex.toml")).expect("notex.toml loads");
    let original = common::load("cornell-box.toml", None);
    assert_eq!(notex.triangle_count(), original.triangle_count());
    assert_eq!(notex.lights, original.lights);

    if common::shared_scenes_enabled() {
        let sponza = common::bundled("sponza.toml");
        let out = dir.join("sponza");
        let (code, err) = radsplat(&[
            "export-rad",
            sponza.to_str().unwrap_or_default(),
            out.to_str().unwrap_or_default(),
        ]);
        assert_eq!(code, 0, "{err}");
        let s = radsplat::scene::load_scene(&out.join("notex.toml")).expect("loads");
        assert!(s.textures.is_empty() || s.materials.iter().all(|m| m.albedo_texture.is_none()));
        let rad = std::fs::read_to_string(out.join("scene.rad")).expect("scene.rad");
        assert!(rad.contains("source sun0 0 0 4") && rad.contains("sky_mat source sky"));
    }
}

/// The peer comparison renders the same scene on both sides: Radiance gets Lambertian
/// `plastic`, so `notex.toml` removes glossy lobes as it removes textures, and the export
/// says so.
#[test]
fn export_rad_strips_glossy_lobes_from_the_comparison_scene() {
    let dir = tmp_dir("export-glossy");
    let scene = common::bundled("cornell-box-glossy.toml");
    let (code, err) = radsplat(&[
        "export-rad",
        scene.to_str().unwrap_or_default(),
        dir.to_str().unwrap_or_default(),
        "--size",
        "16x16",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("glossy lobes of 1 material"), "{err}");
    let notex = radsplat::scene::load_scene(&dir.join("notex.toml")).expect("notex.toml");
    assert!(
        notex.materials.iter().all(|m| m.glossy.is_none()),
        "notex.toml keeps a glossy lobe"
    );
    let original = radsplat::scene::load_scene(&scene).expect("scene");
    assert!(original.materials.iter().any(|m| m.glossy.is_some()));
    let _ = std::fs::remove_dir_all(&dir);
}
