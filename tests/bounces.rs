//! More than one bounce (`--bounces N`): the surface bounce cache's gather against its CPU
//! mirror, the N-bounce reference against its CPU mirror, both against the closed form of
//! a furnace (a closed emitting box, where radiance is uniform at every bounce count), and
//! determinism.

mod common;

use glam::Vec3;
use radsplat::Renderer;
use radsplat::bounce::reference::GatherReference;
use radsplat::bounce::{BounceGeometry, BounceLayout, BouncePass, BounceSettings};
use radsplat::bvh::SceneBvh;
use radsplat::direct::reference::DirectReference;
use radsplat::records::CacheSettings;
use radsplat::reference::cpu::IndirectReference;
use radsplat::reference::{ReferenceOptions, ReferencePass};
use radsplat::scene::Scene;

/// Emission and albedo of every wall of [`furnace`].
const LE: f32 = 0.2;
const RHO: f32 = 0.5;

/// A closed box of walls that all emit `LE` (MTL `Ke`: an emitter bounce rays see, not a
/// sampled light) and reflect `RHO`, faces wound inwards, the camera inside: radiance is
/// the same everywhere at every bounce count, so N bounces give exactly
/// indirect = LE (RHO + RHO^2 + ... + RHO^N).
fn furnace() -> Scene {
    common::scene_from_texts(
        "furnace",
        "mtllib scene.mtl\n\
         v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
         usemtl wall\n\
         f 1 2 3\nf 1 3 4\nf 5 7 6\nf 5 8 7\nf 1 8 5\nf 1 4 8\n\
         f 2 6 7\nf 2 7 3\nf 1 5 6\nf 1 6 2\nf 4 3 7\nf 4 7 8\n",
        "newmtl wall\nKd 0.5 0.5 0.5\nKe 0.2 0.2 0.2\n",
        "[camera]\nposition = [0.1, -0.2, 0.5]\ntarget = [-0.3, 0.2, -1]\nfov_y = 70\n\
         resolution = [16, 16]\n[[mesh]]\nfile = \"scene.obj\"\n",
    )
}

fn closed_form(bounces: u32) -> f32 {
    (1..=bounces).map(|k| LE * RHO.powi(k as i32)).sum()
}

fn cache_settings(bounces: u32) -> CacheSettings {
    CacheSettings {
        plane_resolution: 8,
        plane_refine: 0.0,
        bounce: BounceSettings {
            bounces,
            rays: 8,
            cell_size: 0.25,
            ..BounceSettings::default()
        },
        ..CacheSettings::default()
    }
}

/// The indirect light of one GI frame of `scene` with `settings`.
fn render_indirect(renderer: &Renderer, scene: &Scene, settings: &CacheSettings) -> Vec<[f32; 4]> {
    common::render_gi(renderer, scene, settings)
        .indirect
        .expect("indirect")
}

fn assert_uniform(what: &str, indirect: &[[f32; 4]], expected: f32, tolerance: f32) {
    let mut worst = 0.0f32;
    for p in indirect {
        for &c in &p[..3] {
            worst = worst.max((c / expected - 1.0).abs());
        }
    }
    assert!(
        worst < tolerance,
        "{what}: indirect off the furnace's {expected} by up to {:.4} %",
        100.0 * worst
    );
}

#[test]
fn furnace_renders_the_closed_form_at_every_bounce_count() {
    let scene = furnace();
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let pass = ReferencePass::new(&renderer.ctx).expect("reference pass");
    let prepared = renderer.prepare(&scene).expect("prepare");
    for bounces in 1..=3 {
        let expected = closed_form(bounces);
        // The cache renderer: records whose planes reflect the bounce cache.
        let indirect = render_indirect(&renderer, &scene, &cache_settings(bounces));
        assert_uniform(
            &format!("cache, {bounces} bounces"),
            &indirect,
            expected,
            2e-3,
        );
        // The path-traced reference.
        let frame = pass
            .render(
                &renderer,
                &prepared,
                &scene.camera,
                &ReferenceOptions::new(4).with_bounces(bounces),
                &mut |_, _| {},
            )
            .expect("reference");
        assert_uniform(
            &format!("reference, {bounces} bounces"),
            &frame.indirect,
            expected,
            2e-3,
        );
    }
}

#[test]
fn reference_paths_match_their_cpu_mirror() {
    let mut scene = common::load("cornell-box.toml", Some((12, 12)));
    scene.settings.light_samples = 1;
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let pass = ReferencePass::new(&renderer.ctx).expect("reference pass");
    let options = ReferenceOptions::new(8).with_bounces(3);
    let frame = pass
        .render(
            &renderer,
            &prepared,
            &scene.camera,
            &options,
            &mut |_, _| {},
        )
        .expect("reference");
    let mut cpu = IndirectReference::new(&scene, 1, 8);
    cpu.bounces = 3;
    let camera = radsplat::visibility::GpuCamera::new(&scene.camera);
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    let mut one_bounce = 0.0f64;
    let mut cpu1 = IndirectReference::new(&scene, 1, 8);
    cpu1.bounces = 1;
    for y in 0..12 {
        for x in 0..12 {
            let p = cpu.pixel(&camera, x, y);
            let g = frame.indirect[(y * 12 + x) as usize];
            let g = Vec3::new(g[0], g[1], g[2]);
            diff += f64::from((g - p.indirect).length_squared());
            norm += f64::from(p.indirect.length_squared());
            one_bounce += f64::from(cpu1.pixel(&camera, x, y).indirect.length_squared());
        }
    }
    let rel = (diff / norm).sqrt();
    assert!(
        rel < 0.02,
        "GPU three-bounce reference off its CPU mirror by {rel}"
    );
    // Three bounces carry visibly more light than one on the Cornell box.
    assert!(
        norm > 1.2 * one_bounce,
        "three bounces {norm} against one {one_bounce}"
    );
}

/// The GPU cache of `scene` with `settings` and the values of its last level.
fn gpu_values(
    renderer: &Renderer,
    scene: &Scene,
    layout: &BounceLayout,
    settings: &BounceSettings,
) -> Vec<f32> {
    let prepared = renderer.prepare(scene).expect("prepare");
    let pass = BouncePass::new(&renderer.ctx).expect("bounce pass");
    let no_maps = radsplat::light_maps::LightMaps::none(&renderer.ctx).expect("no maps");
    let cache = pass
        .build(
            &renderer.ctx,
            &prepared.gpu,
            layout,
            settings,
            1,
            &no_maps,
            &mut Vec::new(),
        )
        .expect("cache");
    let words: Vec<u32> = renderer.ctx.read_buffer(&cache.buffer).expect("read");
    words[layout.values_word() as usize..]
        .iter()
        .map(|&w| f32::from_bits(w))
        .collect()
}

#[test]
fn gather_matches_its_cpu_mirror_at_two_levels() {
    let scene = common::load("cornell-box.toml", Some((8, 8)));
    let bvh = SceneBvh::build(&scene);
    let mut settings = BounceSettings {
        bounces: 2,
        rays: 16,
        cell_size: 0.2,
        ..BounceSettings::default()
    };
    let layout = layout(&scene, &bvh, &settings);
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let level1 = gpu_values(&renderer, &scene, &layout, &settings);
    settings.bounces = 3;
    let level2 = gpu_values(&renderer, &scene, &layout, &settings);
    for (level, gpu, previous) in [(1, &level1, &[][..]), (2, &level2, &level1[..])] {
        let cpu = GatherReference::new(
            DirectReference::new(&scene, 1),
            &bvh,
            &layout,
            previous,
            settings.rays,
        );
        let (mut diff, mut norm, mut lit) = (0.0f64, 0.0f64, 0);
        for side in (0..layout.sides()).step_by(3) {
            let c = cpu.side_value(side);
            let g = Vec3::from_slice(&gpu[3 * side as usize..3 * side as usize + 3]);
            diff += f64::from((g - c).length_squared());
            norm += f64::from(c.length_squared());
            lit += usize::from(c.max_element() > 0.0);
        }
        let rel = (diff / norm).sqrt();
        assert!(lit > 20, "level {level}: only {lit} lit sides");
        eprintln!("level {level}: {lit} lit sides, relative RMS difference {rel}");
        assert!(
            rel < 1e-4,
            "level {level}: GPU gather off its CPU mirror by {rel}"
        );
    }
}

/// The cache layout of `scene` (whose BVH is `bvh`) with `settings`.
fn layout(scene: &Scene, bvh: &SceneBvh, settings: &BounceSettings) -> BounceLayout {
    let (lo, hi) = bvh.world_bounds();
    BounceLayout::new(
        &BounceGeometry::new(bvh, scene),
        settings,
        (hi - lo).length(),
    )
    .expect("layout")
}

#[test]
fn two_bounces_are_deterministic_and_brighter_than_one() {
    let scene = common::load("cornell-box.toml", Some((24, 24)));
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let two = cache_settings(2);
    let a = render_indirect(&renderer, &scene, &two);
    let b = render_indirect(&renderer, &scene, &two);
    assert!(a == b, "two renders with two bounces differ");
    let one = render_indirect(&renderer, &scene, &cache_settings(1));
    let sum = |img: &[[f32; 4]]| {
        img.iter()
            .map(|p| f64::from(p[0] + p[1] + p[2]))
            .sum::<f64>()
    };
    assert!(
        sum(&a) > 1.2 * sum(&one),
        "two bounces {} against one {}",
        sum(&a),
        sum(&one)
    );
}

/// Mean indirect light (channel sum) of each frame of cube-in-box-anim, frames 0..5 at
/// 32x32, and each frame's EXR bytes.
fn animation(
    renderer: &Renderer,
    bounces: u32,
    temporal: Option<radsplat::temporal::TemporalSettings>,
) -> (Vec<f64>, Vec<Vec<u8>>) {
    use radsplat::temporal::animation::{AnimationOptions, render_animation};
    let scene = common::load("cube-in-box-anim.toml", Some((32, 32)));
    let options = AnimationOptions {
        frames: 0..=5,
        cache: cache_settings(bounces),
        temporal,
    };
    let (mut means, mut exrs) = (Vec::new(), Vec::new());
    render_animation(
        renderer,
        &scene,
        &options,
        |f| {
            let indirect = f.frame.indirect.as_ref().expect("indirect");
            let sum: f64 = indirect.iter().map(|p| f64::from(p[0] + p[1] + p[2])).sum();
            means.push(sum / indirect.len() as f64);
            let channels = radsplat::output::exr_out::frame_channels(f.frame);
            exrs.push(
                radsplat::output::exr_out::encode_exr(f.frame.width, f.frame.height, &channels)
                    .expect("exr"),
            );
            Ok(())
        },
        |_, _| {},
    )
    .expect("animation");
    renderer.ctx.check().expect("no wgpu errors");
    (means, exrs)
}

#[test]
fn temporal_caching_carries_two_bounces() {
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let temporal = Some(radsplat::temporal::TemporalSettings::default());
    let (two, bytes) = animation(&renderer, 2, temporal.clone());
    let (_, again) = animation(&renderer, 2, temporal.clone());
    assert!(
        bytes == again,
        "two temporal animations with two bounces differ"
    );
    let (one, _) = animation(&renderer, 1, temporal);
    let (per_frame, _) = animation(&renderer, 2, None);
    let (per_frame_one, _) = animation(&renderer, 1, None);
    for f in 0..two.len() {
        // What the second bounce adds, kept records and their estimates at t+1 included,
        // is what recomputing every frame adds (temporal records use the thesis's plane,
        // which gives both bounce counts a few per cent less light at 8 x 8).
        let gain = two[f] / one[f];
        let per_frame_gain = per_frame[f] / per_frame_one[f];
        assert!(gain > 1.3, "frame {f}: two bounces only {gain} x one");
        assert!(
            (gain / per_frame_gain - 1.0).abs() < 0.05,
            "frame {f}: the second bounce adds {gain} x under temporal caching, \
             {per_frame_gain} x per frame"
        );
    }
}

#[test]
fn irradiance_bound_is_a_hemisphere_of_the_brightest_emitter() {
    // The Cornell box: one rect light of radiance (17, 12, 4) and no environment.
    let scene = common::load("cornell-box.toml", Some((8, 8)));
    let bound = radsplat::bounce::direct_irradiance_bound(&scene, 1.0);
    assert!(
        (bound - std::f32::consts::PI * 17.0).abs() < 1e-3,
        "bound {bound}"
    );
    // No true irradiance on the box exceeds it: the largest cell of a level stays below
    // it too (each cell reflects at most albedo < 1 of what reaches its hits).
    let bvh = SceneBvh::build(&scene);
    let settings = BounceSettings {
        bounces: 2,
        rays: 8,
        cell_size: 0.1,
        ..BounceSettings::default()
    };
    let layout = layout(&scene, &bvh, &settings);
    assert_eq!(layout.irradiance_bound, bound);
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let values = gpu_values(&renderer, &scene, &layout, &settings);
    let largest = values.iter().copied().fold(0.0f32, f32::max);
    assert!(
        largest > 0.0 && largest < bound,
        "largest cell {largest}, bound {bound}"
    );
}
