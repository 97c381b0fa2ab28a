//! The work of each `radsplat` subcommand; `main.rs` parses the command line and calls
//! these. Each command checks its inputs and output paths before the work, shows progress
//! unless quiet, and commits its outputs together ([`crate::output::OutputSet`]).

pub mod animate;
pub mod brdf_projection;
pub mod compare;
pub mod export_rad;
pub mod info;
pub mod plane_error;
pub mod reference;
pub mod render;
pub mod temporal_error;

use crate::scene::load_scene;
use crate::{Error, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;

/// Loads a scene with the command line's overrides: an animation frame, the resolution
/// and the light samples (at least 1). A scene whose instances never move is traced as
/// one mesh ([`crate::scene::Scene::merge_static_instances`]).
pub fn load_scene_with(
    path: &Path,
    frame: Option<u32>,
    size: Option<(u32, u32)>,
    light_samples: Option<u32>,
) -> Result<crate::scene::Scene> {
    let mut scene = load_scene(path)?;
    if let Some(f) = frame {
        scene.try_set_frame(f as f32)?;
    }
    scene.merge_static_instances();
    if let Some((w, h)) = size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    if let Some(n) = light_samples {
        if n == 0 {
            return Err(Error::Usage("--light-samples must be at least 1".into()));
        }
        scene.settings.light_samples = n;
    }
    Ok(scene)
}

/// A progress bar of `steps` steps with elapsed time and ETA; hidden when `quiet`.
pub fn progress(quiet: bool, steps: u64) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(steps);
    if let Ok(style) = ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} (ETA {eta}) {msg}",
    ) {
        bar.set_style(style);
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

/// 8-bit RGB as PNG bytes, errors naming `path`.
pub fn encode_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    crate::output::png_out::encode_png_rgb8(width, height, rgb).map_err(|message| Error::Output {
        path: path.to_path_buf(),
        message,
    })
}
