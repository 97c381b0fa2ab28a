//! Temporal caching of radiance records (issue 18 item 6): radiance records kept over
//! frames reproduce the frame exactly, their estimate at t+1 (the reprojected plane
//! projected onto HSH) predicts the record recomputed at t+1, and animations with them are
//! deterministic through both passes of interpolated gradients.

mod common;

use glam::{Mat4, Vec3};
use radsplat::frame::{Frame, PreparedScene, Renderer};
use radsplat::records::{CacheSettings, RecordCache, RecordPass, RecordSite};
use radsplat::scene::Scene;
use radsplat::temporal::radiance::coefficient_ratio;
use radsplat::temporal::{FrameScenes, TemporalCache, TemporalGradients, TemporalSettings};

/// cube-in-box with the glossy back wall of spheres-glossy (Phong 20 on `Kd 0.45`), at
/// `width x height`.
fn glossy_cube_in_box(width: u32, height: u32) -> Scene {
    let dir = std::env::temp_dir().join(format!("radsplat-trc-glossy-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let toml = format!(
        "[camera]\nposition = [0.0, 2.0, 1.95]\ntarget = [0.2, 1.2, -1.0]\nfov_y = 70.0\n\
         resolution = [{width}, {height}]\n\n[render]\nlight_samples = 4\n\n\
         [[mesh]]\nfile = {room:?}\nname = \"room\"\n\n\
         [[mesh]]\nfile = {cube:?}\nname = \"cube\"\ntranslate = [0.4, 0.0, -0.3]\n\
         rotate = [0.0, 30.0, 0.0]\n\n\
         [[light]]\ntype = \"rect\"\ncorner = [-0.6, 3.99, -0.6]\nedge_u = [1.2, 0.0, 0.0]\n\
         edge_v = [0.0, 0.0, 1.2]\nradiance = [20.0, 19.0, 17.0]\n",
        room = scenes.join("room-glossy.obj").display().to_string(),
        cube = scenes.join("cube.obj").display().to_string(),
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).expect("toml");
    let scene = radsplat::scene::load_scene(&path).expect("scene");
    let _ = std::fs::remove_dir_all(&dir);
    scene
}

/// Temporal caching's record settings at a = 0.3, 12x12 irradiance planes (radiance
/// records: their own accuracy, the default order, planes from the lobe rule).
fn settings() -> CacheSettings {
    TemporalCache::record_settings(&CacheSettings {
        accuracy: 0.3,
        plane_resolution: 12,
        // What the CLI gives animations and VPL/photon records (they were measured so).
        r_min_pixels: CacheSettings::ANIMATION_R_MIN_PIXELS,
        ..CacheSettings::default()
    })
}

/// The scene with its cube moved `dx` metres along +x per frame, frames 0..=`frames`.
fn sliding(
    renderer: &Renderer,
    scene: &Scene,
    dx: f32,
    frames: u32,
) -> Vec<(Scene, PreparedScene)> {
    let base = scene.instances[1].transform;
    (0..=frames)
        .map(|t| {
            let mut s = scene.clone();
            s.instances[1].transform =
                Mat4::from_translation(Vec3::new(dx * t as f32, 0.0, 0.0)) * base;
            let prepared = renderer.prepare(&s).expect("prepare");
            (s, prepared)
        })
        .collect()
}

#[test]
fn kept_radiance_records_reproduce_the_static_render() {
    let scene = glossy_cube_in_box(40, 32);
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    // The still frame with the records an animation makes (CacheSettings::for_animation).
    let mut cache = renderer
        .new_cache(&settings().for_animation())
        .expect("cache");
    let still = renderer
        .render_gi_frame(&prepared, &scene.camera, &mut cache, None, |_| {})
        .expect("static frame");
    let mut temporal = TemporalCache::new(&renderer.ctx, &settings(), &TemporalSettings::default())
        .expect("temporal cache");
    for t in 0..3 {
        let (frame, stats) = temporal
            .render_frame(
                &renderer,
                FrameScenes {
                    now: &prepared,
                    scene: &scene,
                    next: None,
                },
                &scene.camera,
                t,
                false,
                false,
                |_| {},
            )
            .expect("temporal frame");
        renderer.ctx.check().expect("no wgpu errors");
        let radiance = stats.radiance.expect("radiance records on the glossy wall");
        if t == 0 {
            assert!(radiance.new > 0, "no radiance record placed");
        } else {
            // Kept, with the coefficient blocks uploaded back from the CPU.
            assert_eq!((radiance.new, radiance.replaced), (0, 0), "frame {t}");
            assert_eq!(radiance.kept, radiance.alive);
        }
        assert_eq!(
            frame.beauty, still.beauty,
            "frame {t} differs from the static render with radiance records"
        );
    }
}

/// The luminance-coefficient distance |b - a| / |a| of two coefficient blocks.
fn distance(a: &[f32], b: &[f32]) -> f32 {
    coefficient_ratio(a, b) - 1.0
}

#[test]
fn radiance_estimate_at_t_plus_1_predicts_the_recomputed_record() {
    // Radiance planes from the lobe rule (24x24 at these 12x12 irradiance planes); the
    // estimate reprojects the whole plane.
    let (changed, estimate_error, still_error) = estimate_against_truth(settings());
    // Measured: 0.77 of the no-change error: the reprojected plane bins moved hits into
    // cells and re-shades them, which the coefficients of order 8 see more than an
    // irradiance.
    assert!(
        changed >= 3 && estimate_error < 0.85 * still_error,
        "the estimate at t+1 ({estimate_error:.3}) does not predict the change \
         ({still_error:.3}) of {changed} records"
    );
}

/// Frame 0 of the sliding glossy cube (6 cm a frame) under `cache`: its radiance records
/// on the room, each estimated at t+1 and recomputed at t+1 at the same site. Returns the
/// records whose true change exceeds 2 % and, over them, the sums of the relative L2
/// distances of the estimate and of "no change" from the recomputed record.
fn estimate_against_truth(cache: CacheSettings) -> (usize, f32, f32) {
    let scene = glossy_cube_in_box(40, 32);
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    // 6 cm a frame: records near the cube see their hemisphere change.
    let frames = sliding(&renderer, &scene, 0.06, 1);
    let mut temporal = TemporalCache::new(&renderer.ctx, &cache, &TemporalSettings::default())
        .expect("temporal cache");
    temporal
        .render_frame(
            &renderer,
            FrameScenes {
                now: &frames[0].1,
                scene: &frames[0].0,
                next: Some((&frames[1].1, &frames[1].0)),
            },
            &scene.camera,
            0,
            true,
            false,
            |_| {},
        )
        .expect("frame 0");
    let radiance = temporal.radiance_records().expect("radiance records");
    // Records on the room (they stay where they are) with their sites and blocks.
    let mut sites: Vec<RecordSite> = Vec::new();
    let mut blocks = Vec::new();
    for (id, r) in radiance.records() {
        if let (Some(site), 0) = (r.site, r.record.instance) {
            sites.push(site);
            blocks.push(radiance.blocks(id).expect("blocks").clone());
        }
    }
    assert!(
        sites.len() >= 10,
        "{} radiance records on the room",
        sites.len()
    );
    // The same sites traced again at t+1.
    let kind = cache.radiance.kind();
    let pass = RecordPass::with_kind(&renderer.ctx, radiance.cache_settings(), kind).expect("pass");
    let mut truth = RecordCache::with_kind(&renderer.ctx, kind).expect("cache");
    let buf = renderer
        .ctx
        .storage_buffer("sites", &sites)
        .expect("sites buffer");
    pass.compute(
        &renderer.ctx,
        &frames[1].1.gpu,
        &buf,
        sites.len() as u32,
        &mut truth,
        None,
        None,
        |_| {},
    )
    .expect("records at t+1");
    let truth = truth.read_coefficients(&renderer.ctx).expect("read");
    let floats = kind.coefficient_floats();
    let (mut changed, mut estimate_error, mut still_error) = (0, 0.0f32, 0.0f32);
    for (k, b) in blocks.iter().enumerate() {
        let true_next = &truth[k * floats..(k + 1) * floats];
        let change = distance(&b.now, true_next);
        if change > 0.02 {
            changed += 1;
            estimate_error += distance(true_next, &b.next);
            still_error += distance(true_next, &b.now);
        }
    }
    println!(
        "{changed} of {} records change by over 2 %: estimate off by {estimate_error:.3}, \
         no change off by {still_error:.3} (sums of relative L2 distances)",
        blocks.len()
    );
    (changed, estimate_error, still_error)
}

/// Renders frames 0..`count` of the sliding cube with `gradients` (interpolated: the
/// first pass over the whole range, then the second pass of every frame); the images in
/// frame order.
fn render_sliding(renderer: &Renderer, gradients: TemporalGradients, count: u32) -> Vec<Frame> {
    let scene = glossy_cube_in_box(32, 24);
    let frames = sliding(renderer, &scene, 0.03, count);
    let temporal_settings = TemporalSettings {
        gradients,
        max_lifespan: 3,
        ..TemporalSettings::default()
    };
    let mut temporal =
        TemporalCache::new(&renderer.ctx, &settings(), &temporal_settings).expect("temporal");
    let two_pass = gradients == TemporalGradients::Interpolated;
    let mut out = Vec::new();
    for t in 0..count {
        let i = t as usize;
        let (frame, stats) = temporal
            .render_frame(
                renderer,
                FrameScenes {
                    now: &frames[i].1,
                    scene: &frames[i].0,
                    next: Some((&frames[i + 1].1, &frames[i + 1].0)),
                },
                &scene.camera,
                t,
                true,
                two_pass,
                |_| {},
            )
            .expect("frame");
        renderer.ctx.check().expect("no wgpu errors");
        let radiance = stats.radiance.expect("radiance stats");
        if t > 0 {
            assert!(
                radiance.kept + radiance.replaced > 0,
                "frame {t}: no radiance record carried over"
            );
        }
        if !two_pass {
            out.push(frame);
        }
    }
    if two_pass {
        for t in 0..count {
            assert!(
                temporal.second_pass_ready(t, count - 1),
                "frame {t} not ready"
            );
            let i = t as usize;
            out.push(
                temporal
                    .render_second_pass(renderer, &frames[i].1, &scene.camera, t)
                    .expect("second pass"),
            );
        }
    }
    out
}

#[test]
fn animations_with_radiance_records_are_deterministic_in_both_gradient_modes() {
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    for gradients in [
        TemporalGradients::Extrapolated,
        TemporalGradients::Interpolated,
    ] {
        let a = render_sliding(&renderer, gradients, 5);
        let b = render_sliding(&renderer, gradients, 5);
        assert_eq!(a.len(), 5);
        for (t, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!(
                x.beauty.iter().flatten().all(|v| v.is_finite()),
                "{gradients:?} frame {t}: non-finite pixels"
            );
            assert_eq!(
                x.beauty, y.beauty,
                "{gradients:?} frame {t} differs between runs"
            );
        }
    }
}
