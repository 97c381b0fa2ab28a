//! `radsplat temporal-error`: thesis Table 5.1, the E(t+1) estimate against records
//! recomputed at t+1.

use super::load_scene_with;
use crate::gpu::GpuContext;
use crate::output::OutputSet;
use crate::records::CacheSettings;
use crate::temporal::TemporalSettings;
use crate::{Error, Renderer, Result};
use std::path::Path;

/// `radsplat temporal-error`: the error of the E(t+1) estimate of thesis Table 5.1 at
/// frame `frame`, and the lifespans it grants.
pub fn temporal_error(
    scene_path: &Path,
    frame: u32,
    (records, sites): (usize, &str),
    size: Option<(u32, u32)>,
    settings: &CacheSettings,
    (record_anchor, stride): (&str, u32),
    json: Option<&Path>,
) -> Result<()> {
    use crate::temporal::estimate_error::{RecordSites, estimate_error_table};
    settings.validate()?;
    let mut outputs = OutputSet::new();
    outputs.plan_opt(json)?;
    // Statistics over no records would print a table of 0.00 % errors.
    if records == 0 {
        return Err(Error::Usage(
            "--record-count 0: must be at least 1 (the table summarises the records' errors)"
                .into(),
        ));
    }
    if stride == 0 {
        return Err(Error::Usage(
            "--estimate-stride 0: must be at least 1 (1: the whole plane)".into(),
        ));
    }
    let mut scene = load_scene_with(scene_path, None, size, None)?;
    let mut next = scene.clone();
    scene.try_set_frame(frame as f32)?;
    let Some(following) = frame.checked_add(1) else {
        return Err(Error::Usage(format!(
            "--frame {frame}: the frame after it is past the last frame number"
        )));
    };
    next.try_set_frame(following as f32)?;
    let renderer = Renderer::new(GpuContext::new()?)?;
    let anchored = record_anchor == "instance";
    // The scene's a_t and dt_max, as `animate` would use them.
    let mut temporal = TemporalSettings::default();
    temporal.apply_scene(scene.animation.as_ref(), None, None);
    let sites = if sites == "placed" {
        RecordSites::Placed
    } else {
        RecordSites::Even
    };
    let table = estimate_error_table(
        &renderer, &scene, &next, settings, records, anchored, stride, &temporal, sites,
    )?;
    if table.records == 0 {
        return Err(Error::Usage(format!(
            "{}: no record could be placed at frame {frame} (no visible surface?), so there \
             are no errors to report",
            scene_path.display()
        )));
    }
    println!(
        "{}: {} records placed at frame {frame}, E(t+1) estimate vs recomputed (RGB RMS relative error)",
        scene_path.display(),
        table.records
    );
    println!(
        "{:<18} {:>8} {:>8} {:>8} {:>8}",
        "", "min", "max", "mean", "median"
    );
    for (name, s) in [
        ("reprojection", &table.reprojection),
        ("no reprojection", &table.no_reprojection),
        ("  on movers: repr.", &table.on_movers_reprojection),
        ("  on movers: none", &table.on_movers_no_reprojection),
    ] {
        println!(
            "{name:<18} {:>7.2}% {:>7.2}% {:>7.2}% {:>7.2}%",
            100.0 * s.min,
            100.0 * s.max,
            100.0 * s.mean,
            100.0 * s.median
        );
    }
    let l = &table.lifespans;
    println!(
        "lifespans (a_t {}, dt_max {}): mean {:.2} frames from the estimated tau, {:.2} from \
         the true tau; records living 1, 2, ... frames: {:?} estimated, {:?} true",
        l.accuracy, l.max_lifespan, l.estimated_mean, l.true_mean, l.estimated, l.truth
    );
    println!(
        "harmonic mean lifespans (records recomputed per frame = records / it): {:.2} \
         estimated, {:.2} true; true on movers ({} records) {:.2}, on the others {:.2}",
        l.estimated_harmonic,
        l.true_harmonic,
        l.movers,
        l.movers_true_harmonic,
        l.still_true_harmonic
    );
    if let Some(path) = json {
        let text =
            serde_json::to_string_pretty(&table).map_err(|e| Error::Usage(format!("JSON: {e}")))?;
        outputs.stage(path, text.as_bytes())?;
    }
    outputs.commit()
}
