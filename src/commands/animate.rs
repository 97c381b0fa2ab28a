//! `radsplat animate`: an animation with temporal radiance caching (or the per-frame
//! baseline), streamed frame by frame.

use super::{encode_png, load_scene_with, progress};
use crate::gpu::GpuContext;
use crate::output::{ImageFormat, OutputSet};
use crate::records::CacheSettings;
use crate::temporal::{TemporalGradients, TemporalSettings};
use crate::{Error, Renderer, Result};
use std::path::{Path, PathBuf};

/// What `radsplat animate` was asked for.
pub struct AnimateArgs<'a> {
    /// The scene file.
    pub scene_path: &'a Path,
    /// The frames to render (default: the scene's range).
    pub frames: Option<std::ops::RangeInclusive<u32>>,
    /// The image (`.exr` with AOVs or `.png`); default `<scene>.exr` (animate: a `####` pattern).
    pub output: Option<PathBuf>,
    /// Override of the scene's resolution.
    pub size: Option<(u32, u32)>,
    /// Override of the scene's light samples per area light (at least 1).
    pub light_samples: Option<u32>,
    /// The irradiance cache settings.
    pub cache: CacheSettings,
    /// a_t and dt_max given on the command line (else the scene's, else the defaults).
    pub temporal_accuracy: Option<f32>,
    /// See `temporal_accuracy`.
    pub max_lifespan: Option<u32>,
    /// `--max-new-records` (checked here, so the error names the flag).
    pub max_new_records: Option<u32>,
    /// None: the per-frame baseline.
    pub temporal: Option<TemporalSettings>,
    /// Record sites coloured by lifespan, one PNG per frame (a `####` pattern).
    pub lifespan_map: Option<PathBuf>,
    /// Statistics as JSON.
    pub stats: Option<PathBuf>,
    /// Time the GPU passes ([`GpuContext::set_pass_timing`]).
    pub time_passes: bool,
    /// No progress bar or summary.
    pub quiet: bool,
}

/// `radsplat animate`: renders the frame range with temporal radiance caching (or the
/// per-frame baseline), writing each frame as it is done.
pub fn animate(mut args: AnimateArgs) -> Result<()> {
    use crate::output::{frame_path, lifespan_map};
    use crate::temporal::animation::{AnimationOptions, AnimationStep, render_animation};
    args.cache.validate()?;
    match (args.max_new_records, args.temporal.as_mut()) {
        (Some(0), _) => {
            return Err(Error::Usage(
                "--max-new-records 0: the cap on new records per frame must be at least 1".into(),
            ));
        }
        (Some(n), None) => {
            return Err(Error::Usage(format!(
                "--max-new-records {n} caps the records a frame adds to the temporal cache: \
                 drop --temporal off (a frame from scratch would stay partly uncovered)"
            )));
        }
        (n, Some(t)) => t.max_new_records = n,
        (None, None) => {}
    }
    let scene = load_scene_with(args.scene_path, None, args.size, args.light_samples)?;
    if let Some(t) = args.temporal.as_mut() {
        t.apply_scene(
            scene.animation.as_ref(),
            args.temporal_accuracy,
            args.max_lifespan,
        );
        // The stride chosen, so that --stats records it.
        t.estimate_stride = Some(t.estimate_stride_for(args.cache.plane_resolution));
        t.validate()?;
    }
    let frames = args.frames.clone().unwrap_or_else(|| scene.frames());
    // Every frame's state before any work (its cost follows the keyframe spans, not the
    // range): a keyframe pair that interpolates through a degenerate state is refused here.
    scene.check_frames(frames.clone())?;
    let output = args.output.unwrap_or_else(|| {
        let stem = args
            .scene_path
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy();
        PathBuf::from(format!("{stem}_####.exr"))
    });
    // Check every output name and directory before rendering anything.
    let format = ImageFormat::from_path(&frame_path(&output, *frames.start())?)?;
    crate::output::output_dir(&frame_path(&output, *frames.start())?)?;
    // The stats JSON is written at the end; its path is checked and reserved now.
    let mut stats_output = OutputSet::new();
    stats_output.plan_opt(args.stats.as_deref())?;
    if args.temporal.is_some() && args.cache.source == crate::records::RecordSource::Photons {
        return Err(Error::Usage(
            "records from photons (--records photons) do not work with temporal caching \
             yet: use --temporal off (each frame its own photon records) or --records \
             planes or vpl"
                .into(),
        ));
    }
    if let Some(map) = &args.lifespan_map {
        crate::output::check_png_name(map, "--lifespan-map")?;
        if args.temporal.is_none() {
            return Err(Error::Usage(
                "--lifespan-map needs temporal caching (drop --temporal off)".into(),
            ));
        }
        if args.cache.source == crate::records::RecordSource::Vpl {
            return Err(Error::Usage(
                "--lifespan-map draws record lifespans; records from VPLs (--records vpl) \
                 have none: they live until what they stand on moves"
                    .into(),
            ));
        }
        if ImageFormat::from_path(&frame_path(map, *frames.start())?)? != ImageFormat::Png {
            return Err(Error::Usage(
                "--lifespan-map writes PNG: use a .png pattern".into(),
            ));
        }
        crate::output::output_dir(&frame_path(map, *frames.start())?)?;
    }
    let ctx = GpuContext::new()?;
    ctx.set_pass_timing(args.time_passes);
    let renderer = Renderer::new(ctx)?;
    crate::visibility::check_resolution(&renderer.ctx, scene.camera.width, scene.camera.height)?;
    let count = frames.end() - frames.start() + 1;
    let options = AnimationOptions {
        frames: frames.clone(),
        cache: args.cache.clone(),
        temporal: args.temporal.clone(),
    };
    // Interpolated gradients: pass 1 computes the records, pass 2 renders each frame up to
    // dt_max frames behind it; the bar counts the steps of both.
    // (Temporal instant caching, `--records vpl`, runs one pass.)
    let two_pass = args.cache.source == crate::records::RecordSource::Planes
        && args
            .temporal
            .as_ref()
            .is_some_and(|t| t.gradients == TemporalGradients::Interpolated);
    let passes = if two_pass { 2 } else { 1 };
    let bar = progress(args.quiet, u64::from(count) * passes);
    bar.set_message("rendering");
    // The last frame written (pass 2's position), for the messages of pass 1.
    let written = std::cell::Cell::new(None::<u32>);
    let pass_2 = || match written.get() {
        Some(t) => format!("; pass 2 (images) wrote frame {t}"),
        None => "; pass 2 (images) waits for the records' successors".to_string(),
    };
    let max_lifespan = args.temporal.as_ref().map_or(1, |t| t.max_lifespan);
    let exposure = scene.settings.exposure;
    // Per-frame statistics only for --stats (their JSON is written at the end; without
    // --stats nothing grows with the range).
    let mut per_frame = Vec::new();
    let summary = render_animation(
        &renderer,
        &scene,
        &options,
        |f| {
            // A frame's image and its lifespan map appear together or not at all.
            let path = frame_path(&output, f.frame_number)?;
            let mut frame_outputs = OutputSet::new();
            frame_outputs.plan(&path)?;
            let map_path = match &args.lifespan_map {
                Some(map) => Some(frame_path(map, f.frame_number)?),
                None => None,
            };
            frame_outputs.plan_opt(map_path.as_deref())?;
            frame_outputs.stage(&path, &format.encode_frame(&path, f.frame, exposure)?)?;
            if let Some(map_path) = &map_path {
                let camera = crate::visibility::GpuCamera::new(&f.scene.camera);
                let rgb = lifespan_map(
                    f.frame,
                    &camera,
                    &f.records,
                    &f.lifespans,
                    max_lifespan,
                    exposure,
                );
                let png = encode_png(map_path, f.frame.width, f.frame.height, &rgb)?;
                frame_outputs.stage(map_path, &png)?;
            }
            frame_outputs.commit()?;
            if args.stats.is_some() {
                per_frame.push(f.stats.clone());
            }
            written.set(Some(f.frame_number));
            let s = &f.stats.temporal;
            bar.inc(1);
            let pass_1 = match f.first_pass_at {
                Some(t) => format!("pass 1 (records) at frame {t}; pass 2 (images) wrote "),
                None => "wrote ".to_string(),
            };
            bar.set_message(format!(
                "{pass_1}frame {}: {} records ({} new, {} replaced, {} deleted)",
                f.frame_number, s.alive, s.new, s.replaced, s.deleted
            ));
            Ok(())
        },
        |t, step| match step {
            AnimationStep::Placing { new_records } if two_pass => bar.set_message(format!(
                "pass 1 (records) frame {t}: {new_records} new records{}",
                pass_2()
            )),
            AnimationStep::Placing { new_records } => {
                bar.set_message(format!("frame {t}: {new_records} new records"))
            }
            AnimationStep::Computed => bar.inc(1),
        },
    )?;
    bar.finish_and_clear();
    let wall_s = summary.wall_ms / 1e3;
    let rays = summary.plane_rays;
    let created = summary.records_computed;
    if !args.quiet {
        println!(
            "{count} frames in {wall_s:.2} s ({:.2} s/frame); records computed {created}, \
             plane rays {rays}; temporal caching {}",
            wall_s / f64::from(count),
            if args.temporal.is_some() { "on" } else { "off" }
        );
    }
    if let Some(path) = &args.stats {
        #[derive(serde::Serialize)]
        struct Summary<'a> {
            scene: &'a Path,
            cache: &'a CacheSettings,
            temporal: &'a Option<TemporalSettings>,
            wall_s: f64,
            records_computed: u64,
            plane_rays: u64,
            frames: &'a [crate::temporal::animation::AnimationFrameStats],
        }
        let json = serde_json::to_string_pretty(&Summary {
            scene: args.scene_path,
            cache: &args.cache,
            temporal: &args.temporal,
            wall_s,
            records_computed: created,
            plane_rays: rays,
            frames: &per_frame,
        })
        .map_err(|e| Error::Usage(format!("stats JSON: {e}")))?;
        stats_output.stage(path, json.as_bytes())?;
    }
    stats_output.commit()
}
