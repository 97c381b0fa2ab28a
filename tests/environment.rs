//! Environment maps (issue 18): loading (.hdr and EXR) with clear errors, direct light from
//! a map sampled by importance on the GPU against the CPU reference, the background seen
//! through the camera, and the reference and renderer agreeing on a scene lit by the map
//! alone (scenes/env-sphere.toml, under radsplat's own scenes/sky.hdr).

mod common;

use glam::Vec3;
use radsplat::Renderer;
use radsplat::direct::reference::DirectReference;
use radsplat::scene::EnvironmentMap;
use radsplat::scene::file::parse_scene;
use radsplat::visibility::GpuCamera;

fn env_scene(w: u32, h: u32) -> radsplat::scene::Scene {
    let mut scene = common::load("env-sphere.toml", Some((w, h)));
    scene.settings.light_samples = 8;
    scene
}

#[test]
fn the_bundled_sky_loads_and_exr_maps_load_the_same_texels() {
    let scene = env_scene(8, 6);
    let map = scene.environment_map.as_ref().expect("a map");
    assert_eq!((map.width, map.height), (64, 32));
    assert_eq!(
        scene.environment,
        Vec3::ZERO,
        "the map replaces the constant"
    );
    // The sun is the brightest direction, above the horizon.
    let (k, sun) = map
        .texels
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.x.total_cmp(&b.1.x))
        .unwrap();
    assert!(
        sun.x > 1000.0 && (k as u32) < 64 * 16,
        "sun {sun} at texel {k}"
    );
    // The same texels written as an EXR load back equal.
    let dir = std::env::temp_dir().join(format!("radsplat-env-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("sky.exr");
    let (w, h) = (map.width as usize, map.height as usize);
    let texels = map.texels.clone();
    exr::prelude::write_rgb_file(&path, w, h, |x, y| {
        let c = texels[y * w + x];
        (c.x, c.y, c.z)
    })
    .expect("write exr");
    let back = EnvironmentMap::load(&path, Vec3::ONE, 0.0).expect("load exr");
    assert_eq!(back.texels, map.texels);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_environment_settings_name_the_field() {
    let path = common::bundled("env-sphere.toml");
    let text = std::fs::read_to_string(&path).expect("scene");
    let err = parse_scene(&text.replace("sky.hdr", "no-such-sky.hdr"), &path)
        .expect_err("missing map")
        .to_string();
    assert!(
        err.contains("environment.map") && err.contains("no-such-sky.hdr"),
        "{err}"
    );
    let err = parse_scene(&text.replace("sky.hdr", "sphere.obj"), &path)
        .expect_err("not an image")
        .to_string();
    assert!(err.contains(".hdr") && err.contains("sphere.obj"), "{err}");
    let err = parse_scene(&text.replace("map = \"sky.hdr\"\n", ""), &path)
        .expect_err("rotation without a map")
        .to_string();
    assert!(
        err.contains("environment.rotation") && err.contains("map"),
        "{err}"
    );
}

// Tolerances as tests/gpu_direct.rs: the same light samples (Sobol points drawn through the
// same tables) in f32 with different instruction orders; a direction on a texel edge may
// land in the neighbouring texel (atan2/acos differ in the last bits) and a shadow ray may
// graze an edge, so the bound is on the 99th percentile.
#[test]
fn direct_light_from_the_map_matches_the_cpu_reference() {
    check_direct_against_cpu(env_scene(32, 24));
}

/// The same with the map turned about +y (the GPU's rotation against the CPU's): the sun
/// moves, so the shadows move too.
#[test]
fn a_rotated_map_matches_the_cpu_reference_and_moves_the_light() {
    let mut turned = env_scene(32, 24);
    let map = turned.environment_map.take().expect("map");
    turned.environment_map = Some(EnvironmentMap::new(
        map.width,
        map.height,
        map.texels.clone(),
        Vec3::ONE,
        70.0,
    ));
    let a = check_direct_against_cpu(env_scene(32, 24));
    let b = check_direct_against_cpu(turned);
    let moved = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| (**x - **y).abs() > 0.1 * x.max(**y))
        .count();
    assert!(
        moved > 50,
        "only {moved} pixels changed when the sky turned by 70 degrees"
    );
}

/// Compares the GPU's direct light with the CPU reference; returns the GPU's direct
/// luminance-like sums per pixel.
fn check_direct_against_cpu(scene: radsplat::scene::Scene) -> Vec<f32> {
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let frame = renderer
        .render_frame(&prepared, &scene.camera)
        .expect("frame");
    renderer.ctx.check().expect("no wgpu errors");
    let reference = DirectReference::new(&scene, scene.settings.light_samples);
    let cam = GpuCamera::new(&scene.camera);
    let (mut errors, mut background) = (Vec::new(), 0);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let i = (y * cam.width + x) as usize;
            let r = reference.pixel(&cam, x, y);
            let g = frame.visibility[i];
            if g.is_hit().then_some((g.instance, g.mesh_triangle)) != r.hit {
                continue;
            }
            let gpu = Vec3::new(frame.beauty[i][0], frame.beauty[i][1], frame.beauty[i][2]);
            if r.hit.is_none() {
                // The sky seen through the camera.
                background += 1;
                assert!(r.beauty.max_element() > 0.0);
            }
            errors.push((gpu - r.beauty).abs().max_element() / r.beauty.max_element().max(1e-2));
        }
    }
    assert!(background > 50, "{background} sky pixels");
    errors.sort_by(f32::total_cmp);
    let p99 = errors[errors.len() * 99 / 100];
    let mean = errors.iter().sum::<f32>() / errors.len() as f32;
    eprintln!(
        "{} pixels: relative error mean {mean:.2e}, 99th percentile {p99:.2e}",
        errors.len()
    );
    assert!(p99 < 1e-3, "99th percentile relative error {p99}");
    assert!(mean < 1e-3, "mean relative error {mean}");
    // The sun casts shadows: the floor under the spheres is darker than in the open.
    let direct: Vec<f32> = frame.direct.iter().map(|p| p[0] + p[1] + p[2]).collect();
    let (lit, shade) = (
        direct.iter().cloned().fold(0.0, f32::max),
        direct
            .iter()
            .filter(|&&d| d > 0.0)
            .cloned()
            .fold(f32::INFINITY, f32::min),
    );
    assert!(lit > 10.0 * shade, "lit {lit} vs shaded {shade}");
    direct
}
