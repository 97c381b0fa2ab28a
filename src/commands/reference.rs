//! `radsplat reference`: the brute-force Monte Carlo reference render.

use super::{load_scene_with, progress};
use crate::gpu::GpuContext;
use crate::output::{ImageFormat, OutputSet};
use crate::{Error, Renderer, Result};
use std::path::{Path, PathBuf};

/// `radsplat reference`: the deterministic brute-force reference (`spp` cosine directions
/// per pixel, sequence `seed`: 0 the historical one), optionally at animation frame `frame`.
#[allow(clippy::too_many_arguments)]
pub fn reference(
    scene_path: &Path,
    options: crate::reference::ReferenceOptions,
    frame: Option<u32>,
    output: Option<PathBuf>,
    png: Option<PathBuf>,
    size: Option<(u32, u32)>,
    light_samples: Option<u32>,
    stats: Option<PathBuf>,
    quiet: bool,
) -> Result<()> {
    use crate::reference::ReferencePass;
    let spp = options.spp;
    if !(1..=crate::reference::MAX_SPP).contains(&spp) {
        return Err(Error::Usage(format!(
            "--spp {spp} must be between 1 and {}",
            crate::reference::MAX_SPP
        )));
    }
    let scene = load_scene_with(scene_path, frame, size, light_samples)?;
    let output = output.unwrap_or_else(|| {
        let stem = scene_path.file_stem().unwrap_or_default().to_string_lossy();
        PathBuf::from(format!("{stem}-reference.exr"))
    });
    let format = ImageFormat::from_path(&output)?;
    let mut outputs = OutputSet::new();
    outputs.plan(&output)?;
    if let Some(p) = &png {
        crate::output::check_png_name(p, "--png")?;
    }
    outputs.plan_opt(png.as_deref())?;
    outputs.plan_opt(stats.as_deref())?;
    let t0 = std::time::Instant::now();
    let ctx = GpuContext::new()?;
    // Its summary reports shader compilation apart from the passes; against the
    // reference's seconds of tracing, what timing costs is lost in the noise.
    ctx.set_pass_timing(true);
    let renderer = Renderer::new(ctx)?;
    crate::visibility::check_resolution(&renderer.ctx, scene.camera.width, scene.camera.height)?;
    let prepared = renderer.prepare(&scene)?;
    let pass = ReferencePass::for_scene(&renderer.ctx, prepared.gpu.features())?;
    let bar = progress(quiet, 1);
    bar.set_message(format!("reference, {spp} spp"));
    let result = pass.render(
        &renderer,
        &prepared,
        &scene.camera,
        &options,
        &mut |done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        },
    )?;
    bar.finish_and_clear();
    let exposure = scene.settings.exposure;
    crate::output::check_finite(&output, &result.frame)?;
    let bytes = match format {
        ImageFormat::Exr => result.encode_exr()?,
        ImageFormat::Png => format.encode_frame(&output, &result.frame, exposure)?,
    };
    outputs.stage(&output, &bytes)?;
    if let Some(png) = &png {
        outputs.stage(
            png,
            &ImageFormat::Png.encode_frame(png, &result.frame, exposure)?,
        )?;
    }
    let wall_ms = t0.elapsed().as_secs_f64() * 1e3;
    if let Some(stats_path) = &stats {
        #[derive(serde::Serialize)]
        struct Stats<'a> {
            bvh: &'a crate::frame::BvhStats,
            frame: &'a crate::FrameStats,
            reference: &'a crate::reference::ReferenceStats,
            wall_ms: f64,
        }
        let json = serde_json::to_string_pretty(&Stats {
            bvh: &prepared.bvh_stats,
            frame: &result.frame.stats,
            reference: &result.stats,
            wall_ms,
        })
        .unwrap_or_default();
        outputs.stage(stats_path, json.as_bytes())?;
    }
    outputs.commit()?;
    if !quiet {
        // Compilation of the passes (the frame's, and the reference pass's own).
        let compile: f64 = result
            .frame
            .stats
            .shader_compile_ms
            .iter()
            .map(|(_, ms)| *ms)
            .chain(renderer.ctx.take_compile_times().iter().map(|(_, ms)| *ms))
            .sum();
        eprintln!(
            "{}x{}, {spp} spp, {} light samples: shader compilation {compile:.0} ms, direct \
             {:.0} ms, indirect {:.0} ms in {} dispatches ({} bounce rays); wrote {}{}",
            result.frame.width,
            result.frame.height,
            scene.settings.light_samples,
            result.stats.direct_ms,
            result.stats.indirect_ms,
            result.stats.dispatches,
            result.stats.bounce_rays,
            output.display(),
            png.map(|p| format!(" and {}", p.display()))
                .unwrap_or_default()
        );
    }
    Ok(())
}
