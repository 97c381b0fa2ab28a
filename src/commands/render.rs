//! `radsplat render`: direct light plus first-bounce indirect light from the irradiance
//! cache, written as EXR/PNG with a record map and stats.

use super::{encode_png, load_scene_with, progress};
use crate::gpu::{GpuContext, SceneFeatures};
use crate::output::{ImageFormat, OutputSet};
use crate::records::CacheSettings;
use crate::{Error, Renderer, Result};
use std::path::{Path, PathBuf};

/// What `radsplat render` was asked for.
pub struct RenderArgs<'a> {
    /// The scene file.
    pub scene_path: &'a Path,
    /// The image (`.exr` with AOVs or `.png`); default `<scene>.exr` (animate: a `####` pattern).
    pub output: Option<PathBuf>,
    /// Also a tone-mapped PNG of the beauty image.
    pub png: Option<PathBuf>,
    /// Override of the scene's resolution.
    pub size: Option<(u32, u32)>,
    /// Override of the scene's light samples per area light (at least 1).
    pub light_samples: Option<u32>,
    /// Statistics as JSON.
    pub stats: Option<PathBuf>,
    /// Time the GPU passes ([`GpuContext::set_pass_timing`]).
    pub time_passes: bool,
    /// None: direct light only.
    pub cache: Option<CacheSettings>,
    /// The record sites drawn over the image (PNG).
    pub record_map: Option<PathBuf>,
    /// No progress bar or summary.
    pub quiet: bool,
}

/// What a render leaves once its outputs are committed: the device, its passes and the
/// scene's buffers. Dropping it tears the device down: about 10 ms of a small still's
/// 0.55 s on lavapipe (its pipelines' JIT code, its threads), and the process then took
/// 9 ms more from `main`'s return to its end. A process that ends right after can skip
/// most of that: [`Rendered::end_process`].
pub struct Rendered {
    renderer: Renderer,
    _scene: crate::PreparedScene,
}

impl Rendered {
    /// Ends the process (exit status 0) without tearing the device down: the outputs are
    /// committed, the pipeline cache is saved here, and the OS reclaims the rest. Ending
    /// this way took nave-west 160x160 0.96 of its time (16 alternating pairs;
    /// docs/results.md, "Pipelines built while the frame runs"). `radsplat render` ends so;
    /// a caller that goes on rendering drops it instead.
    pub fn end_process(self) -> ! {
        self.renderer.ctx.save_pipeline_cache();
        std::process::exit(0)
    }
}

/// `radsplat render`: loads the scene, renders direct light and (unless `cache` is
/// None) first-bounce indirect light, and commits the EXR/PNG, record map and stats.
pub fn render(args: RenderArgs) -> Result<Rendered> {
    let RenderArgs {
        scene_path,
        output,
        png,
        size,
        light_samples,
        stats,
        time_passes,
        cache,
        record_map,
        quiet,
    } = args;
    if let Some(c) = &cache {
        c.validate()?;
    }
    if let Some(p) = &png {
        crate::output::check_png_name(p, "--png")?;
    }
    if let Some(p) = &record_map {
        crate::output::check_png_name(p, "--record-map")?;
    }
    if record_map.is_some() && cache.is_none() {
        return Err(Error::Usage(
            "--record-map needs GI (drop --direct-only)".into(),
        ));
    }
    let bar = progress(quiet, 5);
    // Where the command's wall time goes, outside the frame's own passes (--stats
    // `command_ms`): on a fast GPU the frame is the smaller part (docs/results.md, H200).
    let mut phases = Phases::start();
    bar.set_message("loading scene");
    // The device starts on its own thread while the scene loads and its BVH is built
    // (neither needs the device): on an H200 machine the start took 170 ms and loading
    // Sponza 230 ms, one after the other. A scene error is reported before a device one.
    // The scene's features (kinds of light, instances, textures) go to the threads building
    // the record, visibility and direct-light passes as soon as the scene has loaded: their
    // pipelines are compiled for those alone (the other passes build meanwhile). A scene
    // that fails to load sends none; they are then built for every feature, and the
    // scene's error is the one reported.
    let (features_tx, features_rx) = std::sync::mpsc::channel::<SceneFeatures>();
    let features_rx = std::sync::Mutex::new(features_rx);
    let (loaded, started) = std::thread::scope(|s| {
        // The passes this frame runs are built there too, each on its own thread.
        let starting = s.spawn(|| {
            let ctx = GpuContext::new()?;
            ctx.set_pass_timing(time_passes);
            let renderer = Renderer::new(ctx)?;
            let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
            // Asked for by several building threads: the first receives, the others wait.
            let received = std::sync::OnceLock::new();
            let features = || {
                *received.get_or_init(|| {
                    features_rx
                        .lock()
                        .ok()
                        .and_then(|rx| rx.recv().ok())
                        .unwrap_or(SceneFeatures::ALL)
                })
            };
            let gi_cache = renderer.build_frame_start_passes(cache.as_ref(), cores, &features)?;
            Ok::<_, Error>((renderer, gi_cache))
        });
        let loaded = (|| {
            let scene = load_scene_with(scene_path, None, size, light_samples);
            let scene = match scene {
                Ok(scene) => {
                    // The receiver may be gone (a device error): nothing waits then.
                    let _ = features_tx.send(SceneFeatures::of(&scene));
                    scene
                }
                Err(e) => {
                    drop(features_tx);
                    return Err(e);
                }
            };
            let output = output.unwrap_or_else(|| {
                let stem = scene_path.file_stem().unwrap_or_default().to_string_lossy();
                PathBuf::from(format!("{stem}.exr"))
            });
            let format = ImageFormat::from_path(&output)?;
            // Every output is checked now and replaced only once all of them are written.
            let mut outputs = OutputSet::new();
            outputs.plan(&output)?;
            outputs.plan_opt(png.as_deref())?;
            outputs.plan_opt(record_map.as_deref())?;
            outputs.plan_opt(stats.as_deref())?;
            phases.end("load scene");
            bar.inc(1);
            bar.set_message("building BVH");
            let t0 = std::time::Instant::now();
            let bvh = crate::bvh::SceneBvh::build(&scene);
            let build_ms = t0.elapsed().as_secs_f64() * 1e3;
            phases.end("build BVH");
            Ok::<_, Error>((scene, output, format, outputs, bvh, build_ms))
        })();
        let started = starting
            .join()
            .unwrap_or_else(|_| Err(Error::Gpu("starting the GPU panicked".into())));
        (loaded, started)
    });
    let (scene, output, format, mut outputs, bvh, build_ms) = loaded?;
    bar.inc(1);
    bar.set_message("starting GPU");
    let (renderer, gi_cache) = started?;
    crate::visibility::check_resolution(&renderer.ctx, scene.camera.width, scene.camera.height)?;
    phases.end("wait for GPU start");
    let prepared = renderer.prepare_built(&scene, &bvh, build_ms)?;
    drop(bvh);
    phases.end("upload scene");
    bar.inc(1);
    bar.set_message("rendering");
    let mut records = Vec::new();
    // The passes the frame asks for after its visibility pass (the direct light, the light
    // maps, the record pass's pipelines, placement's covers, the gathers, the resolve)
    // build on other threads meanwhile, at the lowest priority, on the cores lavapipe
    // leaves idle
    // (`Renderer::build_ahead`); the frame builds any it reaches first itself and waits for
    // one being built. A build that fails there fails again, with its message, in the
    // frame.
    let ahead = gi_cache
        .as_ref()
        .map(|c| (c.pass.pipeline_recipes(), c.pass.settings.clone()));
    let frame = std::thread::scope(|s| {
        if let Some((recipes, settings)) = &ahead {
            s.spawn(|| {
                let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
                let idle = crate::frame::BuildPriority::IdleCores;
                let features = SceneFeatures::of(&scene);
                if let Err(e) = renderer.build_ahead(recipes, settings, features, cores, idle) {
                    log::debug!("building ahead: {e}");
                }
            });
        }
        match gi_cache {
            None => renderer.render_frame(&prepared, &scene.camera),
            Some(mut cache) => {
                let frame =
                    renderer.render_gi_frame(&prepared, &scene.camera, &mut cache, None, |n| {
                        bar.set_message(format!("rendering: {n} records"));
                    })?;
                if record_map.is_some() || stats.is_some() {
                    records = cache.read(&renderer.ctx)?;
                }
                Ok(frame)
            }
        }
    })?;
    phases.end("frame");
    bar.inc(1);
    bar.set_message("writing");
    let exposure = scene.settings.exposure;
    outputs.stage(&output, &format.encode_frame(&output, &frame, exposure)?)?;
    phases.end("encode image");
    if let Some(path) = &record_map {
        let camera = crate::visibility::GpuCamera::new(&scene.camera);
        let rgb = crate::output::record_map(&frame, &camera, &records, exposure);
        outputs.stage(path, &encode_png(path, frame.width, frame.height, &rgb)?)?;
    }
    if let Some(png) = &png {
        outputs.stage(png, &ImageFormat::Png.encode_frame(png, &frame, exposure)?)?;
    }
    if let Some(stats_path) = &stats {
        let radii = cache
            .as_ref()
            .map(|c| crate::records::RadiusStats::of(&records, c.r_max_factor));
        // The commit (writing the files) comes after the stats are encoded: not counted.
        phases.end("other outputs");
        let json = serde_json_string(&prepared.bvh_stats, &frame.stats, radii, &phases.done);
        outputs.stage(stats_path, json.as_bytes())?;
    }
    outputs.commit()?;
    bar.inc(1);
    bar.finish_and_clear();
    if !quiet {
        let passes: Vec<String> = frame
            .stats
            .pass_ms
            .iter()
            .map(|(n, ms)| format!("{n} {ms:.1} ms"))
            .collect();
        if let Some(c) = &frame.stats.cache {
            eprintln!(
                "records: {} ({} new in {} rounds{}), {} plane rays, {} visible pixels uncovered, wall {:.0} ms, {} GPU waits",
                c.records,
                c.placement.new_records,
                c.placement.rounds,
                if c.placement.limit_reached {
                    ", LIMIT REACHED"
                } else {
                    ""
                },
                c.plane_rays,
                c.uncovered_pixels,
                frame.stats.wall_ms,
                frame.stats.gpu_waits
            );
            if c.radiance_records > 0 {
                eprintln!(
                    "radiance records: {} of HSH order {} for glossy lobes",
                    c.radiance_records, c.radiance_order
                );
            }
        }
        // Drivers that compile at the first dispatch (lavapipe) report compilations only
        // when passes are timed.
        let compile: f64 = frame.stats.shader_compile_ms.iter().map(|(_, ms)| ms).sum();
        let compiled = if frame.stats.shader_compile_ms.is_empty() {
            String::new()
        } else {
            format!(
                ", shader compilation {compile:.0} ms ({} pipelines)",
                frame.stats.shader_compile_ms.len()
            )
        };
        eprintln!(
            "{}x{}, {} triangles, BVH {:.1} ms{compiled}, GPU: {}; wrote {}{}",
            frame.width,
            frame.height,
            prepared.bvh_stats.triangles,
            prepared.bvh_stats.build_ms,
            if !time_passes {
                "pass times with --time-passes".to_string()
            } else if passes.is_empty() {
                "no timestamps".to_string()
            } else {
                passes.join(", ")
            },
            output.display(),
            png.map(|p| format!(" and {}", p.display()))
                .unwrap_or_default()
        );
    }
    Ok(Rendered {
        renderer,
        _scene: prepared,
    })
}

fn serde_json_string(
    bvh: &crate::frame::BvhStats,
    frame: &crate::FrameStats,
    record_radii: Option<crate::records::RadiusStats>,
    command_ms: &[(&'static str, f64)],
) -> String {
    #[derive(serde::Serialize)]
    struct Stats<'a> {
        bvh: &'a crate::frame::BvhStats,
        frame: &'a crate::FrameStats,
        #[serde(skip_serializing_if = "Option::is_none")]
        record_radii: Option<crate::records::RadiusStats>,
        command_ms: &'a [(&'static str, f64)],
    }
    serde_json::to_string_pretty(&Stats {
        bvh,
        frame,
        record_radii,
        command_ms,
    })
    .unwrap_or_default()
}

/// Wall time of the command's phases, in milliseconds, in order.
struct Phases {
    since: std::time::Instant,
    done: Vec<(&'static str, f64)>,
}

impl Phases {
    fn start() -> Self {
        Phases {
            since: std::time::Instant::now(),
            done: Vec::new(),
        }
    }

    /// Ends the phase running since the last call (or the start).
    fn end(&mut self, name: &'static str) {
        let now = std::time::Instant::now();
        self.done
            .push((name, (now - self.since).as_secs_f64() * 1e3));
        self.since = now;
    }
}
