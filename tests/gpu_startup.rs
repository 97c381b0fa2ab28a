//! Start-up: a command builds only the pipelines it runs, shader compilation is reported
//! apart from the pass times (once per process, at first use), and the pipeline cache is
//! kept in a file between runs where the device offers one.

mod common;

use radsplat::Renderer;
use radsplat::gpu::context::PipelineCacheFile;
use radsplat::records::CacheSettings;

fn names(times: &[(String, f64)]) -> Vec<&str> {
    times.iter().map(|(n, _)| n.as_str()).collect()
}

/// A direct-light frame compiles the two passes it runs, and only those; the second frame
/// compiles nothing and gives the same bytes. Then a GI frame compiles the cache's passes,
/// not again the two it shares with the direct-light frame.
#[test]
fn each_pipeline_is_compiled_once_at_first_use_and_reported_apart() {
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    renderer.ctx.set_pass_timing(true);
    let scene = common::load("cornell-box.toml", Some((16, 16)));
    let prepared = renderer.prepare(&scene).expect("prepare");

    let first = renderer
        .render_frame(&prepared, &scene.camera)
        .expect("frame");
    assert_eq!(
        names(&first.stats.shader_compile_ms),
        ["visibility.wgsl", "direct_light.wgsl"],
        "a direct-light frame builds exactly its two pipelines"
    );
    assert!(
        first
            .stats
            .shader_compile_ms
            .iter()
            .all(|(_, ms)| *ms >= 0.0)
    );
    let second = renderer
        .render_frame(&prepared, &scene.camera)
        .expect("frame");
    assert!(
        second.stats.shader_compile_ms.is_empty(),
        "compiled again: {:?}",
        second.stats.shader_compile_ms
    );
    assert_eq!(
        first.beauty, second.beauty,
        "the compile dispatch changed the image"
    );

    let settings = CacheSettings {
        plane_resolution: 8,
        ..CacheSettings::default()
    };
    let mut cache = renderer.new_cache(&settings).expect("cache");
    let gi = renderer
        .render_gi_frame(&prepared, &scene.camera, &mut cache, None, |_| {})
        .expect("GI frame");
    let compiled = names(&gi.stats.shader_compile_ms);
    for pass in [
        "hemisphere_plane.wgsl",
        "record_reduce.wgsl",
        "splat_gather.wgsl",
        "resolve.wgsl",
    ] {
        assert!(
            compiled.contains(&pass),
            "{pass} not reported: {compiled:?}"
        );
    }
    for pass in ["visibility.wgsl", "direct_light.wgsl"] {
        assert!(
            !compiled.contains(&pass),
            "{pass} compiled twice: {compiled:?}"
        );
    }
    // A cache at another plane resolution (as tail fill's coarser planes and temporal
    // caching's records are) builds no pipeline of its own: no plane resolution is
    // compiled into a pipeline, so its record pass is built from the first cache's
    // (`ComputePass::shared`), and its frame compiles nothing.
    let mut other = renderer
        .new_cache(&CacheSettings {
            plane_resolution: 12,
            ..settings.clone()
        })
        .expect("cache");
    let gi_other = renderer
        .render_gi_frame(&prepared, &scene.camera, &mut other, None, |_| {})
        .expect("GI frame");
    assert!(
        gi_other.stats.shader_compile_ms.is_empty(),
        "a second record pass compiled pipelines again: {:?}",
        gi_other.stats.shader_compile_ms
    );
    assert_ne!(gi.beauty, gi_other.beauty, "the planes' resolution counts");
    // Pass times never include a compilation: the GI frame's direct pass costs what the
    // warm direct-light frame's did, within the noise of this machine (10x and 50 ms).
    let ms = |f: &radsplat::frame::Frame, n: &str| {
        f.stats
            .pass_ms
            .iter()
            .find(|(p, _)| p == n)
            .map(|(_, ms)| *ms)
    };
    if let (Some(warm), Some(first_ms)) = (ms(&second, "direct"), ms(&first, "direct")) {
        assert!(
            first_ms <= 10.0 * warm + 50.0,
            "first direct pass {first_ms} ms vs warm {warm} ms: compilation counted in it"
        );
    }
    renderer.ctx.check().expect("no device error");
}

/// Passes are timed only when asked (`GpuContext::set_pass_timing`): an untimed GI frame
/// reports no pass times and no compilation on a driver that compiles at the first
/// dispatch (its first real dispatch compiles, with nothing waited for apart), and gives
/// the bytes a timed frame gives. Timing asked for later starts with the next frame, and
/// a pipeline the untimed frame compiled is not reported as compiled again.
#[test]
fn passes_are_timed_only_when_asked_and_the_image_does_not_change() {
    let scene = common::load("cornell-box.toml", Some((32, 32)));
    let settings = CacheSettings {
        plane_resolution: 8,
        ..CacheSettings::default()
    };
    // A GI frame from a fresh cache.
    let gi_frame = |renderer: &Renderer, prepared: &radsplat::PreparedScene| {
        let mut cache = renderer.new_cache(&settings).expect("cache");
        renderer
            .render_gi_frame(prepared, &scene.camera, &mut cache, None, |_| {})
            .expect("GI frame")
    };
    let untimed = Renderer::new(common::gpu()).expect("renderer");
    let prepared = untimed.prepare(&scene).expect("prepare");
    let quiet = gi_frame(&untimed, &prepared);
    assert!(
        quiet.stats.pass_ms.is_empty(),
        "untimed, yet pass times: {:?}",
        quiet.stats.pass_ms
    );
    if untimed.ctx.compiles_at_first_dispatch() {
        assert!(
            quiet.stats.shader_compile_ms.is_empty(),
            "untimed, yet compilations timed apart: {:?}",
            quiet.stats.shader_compile_ms
        );
    }

    let timed = Renderer::new(common::gpu()).expect("renderer");
    timed.ctx.set_pass_timing(true);
    let profiled = gi_frame(&timed, &timed.prepare(&scene).expect("prepare"));
    assert_eq!(quiet.beauty, profiled.beauty, "timing changed the image");
    if timed.ctx.times_passes() {
        let names = names(&profiled.stats.pass_ms);
        for pass in [
            "visibility",
            "hemisphere planes",
            "splat: gather",
            "resolve",
        ] {
            assert!(names.contains(&pass), "no time for {pass}: {names:?}");
        }
    }
    if timed.ctx.compiles_at_first_dispatch() {
        assert!(
            names(&profiled.stats.shader_compile_ms).contains(&"hemisphere_plane.wgsl"),
            "{:?}",
            profiled.stats.shader_compile_ms
        );
    }

    // Switched on after an untimed frame: the next frame is timed, and the pipelines the
    // first one compiled are not reported again.
    untimed.ctx.set_pass_timing(true);
    let later = gi_frame(&untimed, &prepared);
    assert_eq!(later.beauty, quiet.beauty, "the same frame again");
    assert!(
        later.stats.shader_compile_ms.is_empty(),
        "compiled twice: {:?}",
        later.stats.shader_compile_ms
    );
    if untimed.ctx.times_passes() {
        assert!(
            !later.stats.pass_ms.is_empty(),
            "timing switched on, no pass times"
        );
    }
    untimed.ctx.check().expect("no device error");
}

/// The pipeline cache lives in `<dir>/<wgpu's key for the adapter>.bin`; a saved cache is
/// found and loaded by the next context on the same adapter.
#[test]
fn the_pipeline_cache_is_kept_in_a_file_between_runs() {
    let ctx = common::gpu();
    let info = ctx.adapter_info.clone().expect("own adapter");
    let dir = common::TestDir::new("pcache");
    // Open in a directory that does not exist yet: the cache creates it.
    let dir = dir.join("cache");
    if !ctx
        .device
        .features()
        .contains(wgpu::Features::PIPELINE_CACHE)
    {
        // Not every backend has one (wgpu offers it on Vulkan): then there is no file.
        assert!(PipelineCacheFile::open_in(&ctx.device, &info, &dir).is_none());
        return;
    }
    let cache = PipelineCacheFile::open_in(&ctx.device, &info, &dir).expect("a cache");
    let key = wgpu::util::pipeline_cache_key(&info).expect("key");
    assert_eq!(cache.path(), dir.join(format!("{key}.bin")));
    cache.save();
    drop(cache);
    let saved = std::fs::read(dir.join(format!("{key}.bin"))).expect("cache file written");
    assert!(!saved.is_empty());
    // A second open loads it (wgpu validates the header; a foreign file would be dropped).
    let again = PipelineCacheFile::open_in(&ctx.device, &info, &dir).expect("reopened");
    assert!(again.cache.get_data().is_some());
    // Garbage in the file only costs a compilation: wgpu falls back to an empty cache.
    std::fs::write(dir.join(format!("{key}.bin")), b"not a pipeline cache").expect("garbage");
    assert!(PipelineCacheFile::open_in(&ctx.device, &info, &dir).is_some());
    let left: Vec<_> = std::fs::read_dir(&dir)
        .expect("dir")
        .flatten()
        .map(|e| e.file_name())
        .filter(|n| n.to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}
