//! Criterion benchmark of temporal radiance caching against per-frame recomputation: the
//! same frames of an animated scene rendered end to end (scene update, BVH, visibility,
//! records, splat, resolve) over one temporal cache, and over a fresh cache per frame.
//! Scene: the bundled cube in a box (`scenes/cube-in-box-anim.toml`, its own a_t and
//! dt_max), 48×48, 32×32 hemisphere planes, frames 0..=11; `RADSPLAT_BENCH_ANIMATION`
//! picks another scene file. The full-size comparison (60 or 400 frames, RMSE and flicker
//! against a reference) is `benches/temporal/compare_temporal.py`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use radsplat::frame::Renderer;
use radsplat::gpu::GpuContext;
use radsplat::records::CacheSettings;
use radsplat::scene::load_scene;
use radsplat::temporal::TemporalSettings;
use radsplat::temporal::animation::{AnimationOptions, render_animation};
use std::path::PathBuf;

const FRAMES: u32 = 12;

fn animation(c: &mut Criterion) {
    let path = std::env::var("RADSPLAT_BENCH_ANIMATION").map_or_else(
        |_| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cube-in-box-anim.toml"),
        PathBuf::from,
    );
    let mut scene = load_scene(&path).expect("scene");
    scene.camera.width = 48;
    scene.camera.height = 48;
    let renderer = Renderer::new(GpuContext::new().expect("GPU")).expect("renderer");
    let cache = CacheSettings {
        plane_resolution: 32,
        ..CacheSettings::default()
    };
    let mut temporal = TemporalSettings::default();
    temporal.apply_scene(scene.animation.as_ref(), None, None);

    let mut group = c.benchmark_group("animation");
    group.sample_size(10);
    group.throughput(Throughput::Elements(u64::from(FRAMES)));
    for (name, temporal) in [
        ("per_frame_recomputation", None),
        ("temporal_caching", Some(temporal)),
    ] {
        let options = AnimationOptions {
            frames: 0..=FRAMES - 1,
            cache: cache.clone(),
            temporal,
        };
        group.bench_function(name, |b| {
            b.iter(|| {
                render_animation(&renderer, &scene, &options, |_| Ok(()), |_, _| {})
                    .expect("animation")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, animation);
criterion_main!(benches);
