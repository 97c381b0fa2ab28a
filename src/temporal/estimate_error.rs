//! Thesis Table 5.1 / seed 000 Table I: how well a new record's E(t+1) is predicted by
//! reprojection, against the record really recomputed at t+1 at the same place, and
//! against the "no reprojection" prediction E(t+1) = E(t).

use crate::Result;
use crate::frame::Renderer;
use crate::records::reference::{RecordReference, reduce_plane};
use crate::records::{CacheSettings, PlaneSample, Record, RecordPass};
use crate::scene::Scene;
use crate::temporal::{NextFrame, ReprojectionPass};
use crate::visibility::GpuCamera;

/// Min / max / mean / median of per-record relative errors.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct ErrorSummary {
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    pub median: f64,
}

impl ErrorSummary {
    pub fn of(errors: &[f64]) -> Self {
        if errors.is_empty() {
            return Self::default();
        }
        let mut v = errors.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Self {
            min: v[0],
            max: v[n - 1],
            mean: v.iter().sum::<f64>() / n as f64,
            median,
        }
    }
}

/// The table: errors of E(t+1) predicted with and without reprojection.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct EstimateErrorTable {
    /// Records compared (sites whose true E(t+1) is not black).
    pub records: usize,
    pub reprojection: ErrorSummary,
    pub no_reprojection: ErrorSummary,
}

/// RGB RMS relative error of `estimate` against `truth`.
fn relative_error(estimate: [f32; 3], truth: [f32; 3]) -> Option<f64> {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for c in 0..3 {
        let d = f64::from(estimate[c]) - f64::from(truth[c]);
        num += d * d;
        den += f64::from(truth[c]).powi(2);
    }
    (den > 0.0).then(|| (num / den).sqrt())
}

/// Places record sites at `count` visible pixels of `at_t` (evenly strided over the
/// image), computes each record at t, its reprojected estimate at t+1 (`next`: the same
/// scene one frame later) and the record recomputed at t+1, and summarises the errors.
pub fn estimate_error_table(
    renderer: &Renderer,
    at_t: &Scene,
    next: &Scene,
    settings: &CacheSettings,
    count: usize,
) -> Result<EstimateErrorTable> {
    let ctx = &renderer.ctx;
    let prepared = renderer.prepare(at_t)?;
    let prepared_next = renderer.prepare(next)?;
    let cache = renderer.new_cache(settings)?;
    let (vis, _) = renderer.splat_cache(&prepared, &at_t.camera, &cache)?;
    let camera = GpuCamera::new(&at_t.camera);
    let visible: Vec<_> = vis.iter().filter(|v| v.is_hit()).collect();
    let stride = (visible.len() / count.max(1)).max(1);
    let sites: Vec<_> = visible
        .iter()
        .step_by(stride)
        .take(count)
        .enumerate()
        .map(|(i, v)| RecordReference::site_from_pixel(settings, &camera, v, i as u32))
        .collect();
    let pass = RecordPass::new(ctx, settings)?;
    let reprojection = ReprojectionPass::new(ctx)?;
    let plane = crate::records::HemispherePlane::new(
        settings.plane_resolution,
        settings.plane_fov_degrees,
        settings.plane_mode,
    );
    let cells = (settings.plane_resolution * settings.plane_resolution) as usize;
    let reduce =
        |site, samples: &[PlaneSample]| -> Record { reduce_plane(&plane, settings, site, samples) };
    // Records keep their world position here, as in the thesis's table.
    let next_frame = NextFrame::new(ctx, &prepared_next.gpu, at_t, next, false)?;
    let (mut with, mut without) = (Vec::new(), Vec::new());
    for chunk in sites.chunks(pass.batch as usize) {
        let (now, ahead) = pass.trace_planes_ahead(
            ctx,
            &prepared.gpu,
            Some((&next_frame, &reprojection)),
            chunk,
        )?;
        let (truth, _) = pass.trace_planes_ahead(ctx, &prepared_next.gpu, None, chunk)?;
        for (i, site) in chunk.iter().enumerate() {
            let span = i * cells..(i + 1) * cells;
            let e_now = reduce(site, &now[span.clone()]).irradiance;
            let e_ahead = reduce(site, &ahead[span.clone()]).irradiance;
            let e_true = reduce(site, &truth[span]).irradiance;
            if let (Some(a), Some(b)) = (
                relative_error(e_ahead, e_true),
                relative_error(e_now, e_true),
            ) {
                with.push(a);
                without.push(b);
            }
        }
    }
    ctx.check()?;
    Ok(EstimateErrorTable {
        records: with.len(),
        reprojection: ErrorSummary::of(&with),
        no_reprojection: ErrorSummary::of(&without),
    })
}
