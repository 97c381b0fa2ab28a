//! `radsplat compare` and `compare-seq`: errors against a reference, per image and per
//! frame of a sequence.

use super::encode_png;
use crate::output::OutputSet;
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// `radsplat compare`: RMSE and relative RMSE of `a` against the reference `b` (optionally
/// of `a` minus `minus`, box-filtered by `downsample`), a diff map and JSON.
#[allow(clippy::too_many_arguments)]
pub fn compare(
    a: &Path,
    b: &Path,
    minus: Option<&Path>,
    diff: Option<&Path>,
    scale: f32,
    downsample: u32,
    json: Option<&Path>,
) -> Result<()> {
    use crate::compare::{compare, diff_image, load_image};
    if !(scale.is_finite() && scale > 0.0) {
        return Err(Error::Usage(
            "--diff-scale must be a positive number".into(),
        ));
    }
    let mut outputs = OutputSet::new();
    if let Some(p) = diff {
        crate::output::check_png_name(p, "--diff")?;
    }
    outputs.plan_opt(diff)?;
    outputs.plan_opt(json)?;
    let mut ia = load_image(a)?;
    if let Some(c) = minus {
        ia = ia.minus(&load_image(c)?)?;
    }
    let mut ib = load_image(b)?;
    if downsample != 1 {
        ia = ia.downsample(downsample)?;
        ib = ib.downsample(downsample)?;
    }
    let c = compare(&ia, &ib)?;
    println!(
        "{} vs reference {} ({}x{}{})",
        a.display(),
        b.display(),
        c.width,
        c.height,
        if downsample != 1 {
            format!(", box-filtered {downsample}x{downsample}")
        } else {
            String::new()
        }
    );
    let line = |name: &str, s: &crate::compare::ErrorStats| {
        println!(
            "{name:<9} RMSE {:.6e}  RMS(ref) {:.6e}  relative RMSE {:.4} ({:.2} %)  \
             mean ratio {:.4}  worst 1 % of pixels: {:.1} % of the squared error",
            s.rmse,
            s.rms_reference,
            s.relative_rmse,
            100.0 * s.relative_rmse,
            s.mean_ratio,
            100.0 * s.worst_share
        );
    };
    line("beauty", &c.beauty);
    if let Some(s) = &c.surfaces {
        line("surfaces", s);
    }
    match &c.indirect {
        Some(s) => line("indirect", s),
        None => println!("indirect  (not in both files)"),
    }
    if let Some(share) = c.indirect_unlit {
        println!(
            "indirect  zero where the reference has some: {:.3} % of its lit pixels",
            100.0 * share
        );
    }
    if let Some(path) = diff {
        let rgb = diff_image(&ia, &ib, scale);
        // The diff image has a legend strip below the picture.
        let rows = (rgb.len() / 3) as u32 / ia.width.max(1);
        outputs.stage(path, &encode_png(path, ia.width, rows, &rgb)?)?;
        println!(
            "wrote {}: |Y(A)-Y(B)| / mean Y(B), viridis from 0 to {scale} (legend strip below)",
            path.display()
        );
    }
    if let Some(path) = json {
        #[derive(serde::Serialize)]
        struct Out<'a> {
            #[serde(flatten)]
            comparison: &'a crate::compare::Comparison,
            diff_scale: f32,
        }
        let text = serde_json::to_string_pretty(&Out {
            comparison: &c,
            diff_scale: scale,
        })
        .map_err(|e| Error::Output {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        outputs.stage(path, text.as_bytes())?;
    }
    outputs.commit()
}

/// `radsplat compare-seq`: per-frame RMSE and flicker of a sequence against reference
/// frames, with a plot, a flicker map and JSON.
pub fn compare_seq(
    a_pattern: &Path,
    ref_pattern: &Path,
    frames: std::ops::RangeInclusive<u32>,
    plot: Option<PathBuf>,
    json: Option<PathBuf>,
    flicker_map: Option<PathBuf>,
    downsample: u32,
) -> Result<()> {
    let mut outputs = OutputSet::new();
    if let Some(p) = &plot {
        crate::output::check_png_name(p, "--plot")?;
    }
    if let Some(p) = &flicker_map {
        crate::output::check_png_name(p, "--flicker-map")?;
    }
    outputs.plan_opt(plot.as_deref())?;
    outputs.plan_opt(json.as_deref())?;
    outputs.plan_opt(flicker_map.as_deref())?;
    let c = crate::compare_seq::compare_sequence(a_pattern, ref_pattern, frames, downsample)?;
    if let Some(path) = &flicker_map {
        outputs.stage_with(path, |tmp| c.write_flicker_map(tmp))?;
    }
    print!("{}", c.table());
    println!("{}", c.summary_line());
    if let Some(path) = &plot {
        outputs.stage_with(path, |tmp| c.write_plot(tmp))?;
    }
    if let Some(path) = &json {
        outputs.stage_with(path, |tmp| c.write_json(tmp))?;
    }
    outputs.commit()?;
    for path in [&flicker_map, &plot].into_iter().flatten() {
        println!("wrote {}", path.display());
    }
    Ok(())
}
