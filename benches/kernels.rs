//! Criterion benchmarks of the ray kernels (the same kernels `radsplat bench` reports):
//! BVH build, GPU primary / shadow / incoherent rays, and obvhs's CPU traversal of the
//! incoherent rays on one thread; the driver's fixed costs that a frame pays per dispatch
//! and per wait, whatever the work (`driver`: on lavapipe these make much of a small
//! still's time, docs/results.md stop 69); and the CPU half of photon-mapped records
//! (indexing a photon map and Algorithm 6 placement over it, `--records photons`). Scene: the bundled Cornell box, or Sponza when
//! `RADSPLAT_ASSET_PATH` is set (`RADSPLAT_BENCH_SCENE` picks another scene file).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use radsplat::bench::make_rays;
use radsplat::bvh::SceneBvh;
use radsplat::bvh::cpu_trace::CpuTracer;
use radsplat::bvh::trace_pass::TraceRaysPass;
use radsplat::gpu::{GpuContext, GpuScene};
use radsplat::scene::load_scene;
use std::path::PathBuf;

fn scene_path() -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
    if let Ok(p) = std::env::var("RADSPLAT_BENCH_SCENE") {
        return PathBuf::from(p);
    }
    if std::env::var_os("RADSPLAT_ASSET_PATH").is_some() {
        root.join("sponza.toml")
    } else {
        root.join("cornell-box.toml")
    }
}

fn kernels(c: &mut Criterion) {
    let mut scene = load_scene(&scene_path()).expect("scene");
    scene.camera.width = 256;
    scene.camera.height = 256;
    let ctx = GpuContext::new().expect("gpu");
    let mut group = c.benchmark_group("bvh");
    group.sample_size(10);
    group.bench_function("build", |b| b.iter(|| SceneBvh::build(&scene)));
    group.finish();

    let bvh = SceneBvh::build(&scene);
    let gpu_scene = GpuScene::upload(&ctx, &scene, &bvh, 1).expect("upload");
    let tracer = CpuTracer::new(&scene);
    let rays = make_rays(&scene, &tracer);
    let pass = TraceRaysPass::new(&ctx).expect("pass");
    let mut group = c.benchmark_group("rays");
    group.sample_size(10);
    for (name, list, any_hit) in [
        ("gpu_primary", &rays.primary, false),
        ("gpu_shadow", &rays.shadow, true),
        ("gpu_incoherent", &rays.incoherent, false),
    ] {
        if list.is_empty() {
            continue;
        }
        let batch = pass.upload(&ctx, list, any_hit).expect("upload rays");
        pass.trace(&ctx, &gpu_scene, &batch).expect("warm-up");
        group.throughput(Throughput::Elements(list.len() as u64));
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                pass.record(&mut enc, &gpu_scene, &batch, None);
                ctx.queue.submit([enc.finish()]);
                ctx.wait().expect("gpu");
            })
        });
    }
    group.throughput(Throughput::Elements(rays.incoherent.len() as u64));
    group.bench_function("cpu_obvhs_incoherent_1_thread", |b| {
        b.iter(|| {
            rays.incoherent
                .iter()
                .filter(|r| {
                    tracer
                        .closest_hit(r.origin.into(), r.dir.into(), r.tmin, r.tmax)
                        .is_some()
                })
                .count()
        })
    });
    group.finish();

    // The driver's fixed costs, with the passes' own plumbing: a submission waited for
    // (nothing in it), and dispatches of the one-workgroup prefix sum over 64 counts
    // (its work is a few microseconds), 64 a submission, each in its own compute pass
    // with its own parameters and bind group as every pass of a frame records them:
    // into buffers made once, or into a new 256 KiB buffer each (as a frame's passes
    // make their scratch buffers; the driver then zeroes and maps fresh memory).
    let prefix = radsplat::gpu::prefix_sum::PrefixSumPass::new(&ctx).expect("prefix sum");
    let counts = ctx.storage_buffer("counts", &[1u32; 64]).expect("counts");
    let offsets = ctx
        .storage_buffer_sized("offsets", 65 * 4)
        .expect("offsets");
    let mut group = c.benchmark_group("driver");
    group.sample_size(20);
    group.bench_function("submit_and_wait", |b| {
        b.iter(|| {
            let enc = ctx.device.create_command_encoder(&Default::default());
            ctx.queue.submit([enc.finish()]);
            ctx.wait().expect("gpu");
        })
    });
    const DISPATCHES: u32 = 64;
    group.throughput(Throughput::Elements(u64::from(DISPATCHES)));
    for fresh in [false, true] {
        let name = if fresh {
            "dispatch_into_new_256k_buffer"
        } else {
            "dispatch"
        };
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                let mut scratch = Vec::new();
                for _ in 0..DISPATCHES {
                    let out = if fresh {
                        scratch.push(
                            ctx.storage_buffer_sized("scratch", 256 << 10)
                                .expect("buffer"),
                        );
                        scratch.last().expect("pushed")
                    } else {
                        &offsets
                    };
                    prefix.record(
                        &ctx,
                        &mut enc,
                        &gpu_scene.bind_group,
                        &counts,
                        out,
                        64,
                        None,
                    );
                }
                ctx.queue.submit([enc.finish()]);
                ctx.wait().expect("gpu");
            })
        });
    }
    group.finish();

    // Photon records' CPU work: the photon grid and Algorithm 6's walk, on 2^15 paths
    // traced by the CPU mirror (the GPU trace gives the same photons).
    let settings = radsplat::records::CacheSettings {
        source: radsplat::records::RecordSource::Photons,
        photons: radsplat::photons::PhotonSettings {
            paths: 1 << 15,
            gather: 64,
            ..Default::default()
        },
        ..Default::default()
    };
    let powers = radsplat::vpl::EmitterPowers::new(&scene, bvh.world_bounds());
    let plan = settings.photons.plan(&powers, 1);
    let direct = radsplat::direct::reference::DirectReference::new(&scene, 1);
    let photons = radsplat::photons::reference::trace_photons(&direct, &plan);
    let stored = photons.iter().filter(|p| !p.is_empty()).count() as u32;
    let cell = radsplat::photons::map::cell_for(stored, powers.surface_area, 64);
    let camera = radsplat::visibility::GpuCamera::new(&scene.camera);
    let mut group = c.benchmark_group("photons");
    group.sample_size(10);
    group.throughput(Throughput::Elements(u64::from(stored)));
    group.bench_function("map_index", |b| {
        b.iter(|| radsplat::photons::map::PhotonMap::new(photons.clone(), cell).len())
    });
    let map = radsplat::photons::map::PhotonMap::new(photons.clone(), cell);
    group.bench_function("placement_algorithm6", |b| {
        b.iter(|| {
            radsplat::records::photon_records::place(&map, &camera, &settings, 0.0)
                .sites
                .len()
        })
    });
    group.finish();
}

criterion_group!(benches, kernels);
criterion_main!(benches);
