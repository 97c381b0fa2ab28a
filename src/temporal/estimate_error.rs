//! Thesis Table 5.1 / seed 000 Table I: how well a new record's E(t+1) is predicted by
//! reprojection, against the record really recomputed at t+1 at the same place, and
//! against the "no reprojection" prediction E(t+1) = E(t).

use crate::Result;
use crate::frame::{PreparedScene, Renderer};
use crate::records::reference::{RecordReference, reduce_plane};
use crate::records::{CacheSettings, PlaneSample, Record, RecordPass, RecordSite};
use crate::scene::Scene;
use crate::temporal::{NextFrame, ReprojectionPass};
use crate::visibility::GpuCamera;
use glam::Mat4;

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
    /// Of those, the records on an instance that moves from t to t+1 (with `anchored`
    /// they move too), and their errors.
    pub on_movers: usize,
    pub on_movers_reprojection: ErrorSummary,
    pub on_movers_no_reprojection: ErrorSummary,
    /// The lifespans (frames, decision 9 with the scene's a_t and dt_max) all the records
    /// (black ones too) get from tau estimated by reprojection, and from the true tau
    /// (the record really recomputed at t+1): what a perfect estimate would allow.
    pub lifespans: LifespanComparison,
}

/// Lifespans of the same records from the estimated and from the true tau.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct LifespanComparison {
    pub accuracy: f32,
    pub max_lifespan: u32,
    /// Mean lifespan in frames, and entry i: records living i + 1 frames.
    pub estimated_mean: f64,
    pub estimated: Vec<u32>,
    pub true_mean: f64,
    pub truth: Vec<u32>,
    /// The harmonic mean lifespans (estimated, true): records per frame that a cache
    /// keeping these records alive must recompute is count / harmonic mean, so with
    /// records placed as a frame places them ([`RecordSites::Placed`]) the true one
    /// bounds the records-computed ratio temporal caching can reach over per-frame
    /// recomputation (a perfect, free estimate, and no record more than a frame needs).
    pub estimated_harmonic: f64,
    pub true_harmonic: f64,
    /// Of the records, those on instances that move, and the true harmonic mean lifespan
    /// on those records and on the others.
    pub movers: usize,
    pub movers_true_harmonic: f64,
    pub still_true_harmonic: f64,
}

impl LifespanComparison {
    /// Lifespans of records with irradiance `now` whose E(t+1) is `estimate` and truly
    /// `truth`, under `settings`' lifespan rule.
    /// `movers[i]`: estimate i's record lies on an instance that moves.
    fn of(estimates: &[Estimate], movers: &[bool], settings: &super::TemporalSettings) -> Self {
        let bins = settings.max_lifespan.max(1) as usize;
        let frames = |e: &Estimate, next: fn(&Estimate) -> [f32; 3]| -> u32 {
            super::last_frame(0, super::temporal_ratio(e.now, next(e)), settings, true) + 1
        };
        // Mean, harmonic mean and histogram of the lifespans of the records `keep` selects.
        let lifespans = |next: fn(&Estimate) -> [f32; 3], keep: &dyn Fn(usize) -> bool| {
            let mut histogram = vec![0u32; bins];
            let (mut sum, mut rate, mut n) = (0u64, 0f64, 0usize);
            let kept = estimates.iter().enumerate().filter(|(i, _)| keep(*i));
            for e in kept.map(|(_, e)| e) {
                let f = frames(e, next);
                histogram[(f as usize - 1).min(bins - 1)] += 1;
                sum += u64::from(f);
                rate += 1.0 / f64::from(f);
                n += 1;
            }
            let harmonic = if rate > 0.0 { n as f64 / rate } else { 0.0 };
            (sum as f64 / n.max(1) as f64, harmonic, histogram)
        };
        let all = |_: usize| true;
        let (estimated_mean, estimated_harmonic, estimated) = lifespans(|e| e.estimate, &all);
        let (true_mean, true_harmonic, truth) = lifespans(|e| e.truth, &all);
        let moving = |i: usize| movers.get(i).copied().unwrap_or(false);
        let (_, movers_true_harmonic, _) = lifespans(|e| e.truth, &moving);
        let (_, still_true_harmonic, _) = lifespans(|e| e.truth, &|i| !moving(i));
        Self {
            accuracy: settings.accuracy,
            max_lifespan: settings.max_lifespan,
            movers: (0..estimates.len()).filter(|&i| moving(i)).count(),
            estimated_mean,
            estimated,
            true_mean,
            truth,
            estimated_harmonic,
            true_harmonic,
            movers_true_harmonic,
            still_true_harmonic,
        }
    }
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

/// One record's irradiance at t, its E(t+1) estimated by reprojection, and the record
/// really recomputed at t+1 (from the moved site when records move with their instance).
#[derive(Clone, Copy, Debug)]
pub struct Estimate {
    pub now: [f32; 3],
    pub estimate: [f32; 3],
    pub truth: [f32; 3],
}

/// [`Estimate`]s of records at `sites` of `at_t` (prepared and CPU scenes), with `next`
/// the same scene one frame later. `anchored`: records move with the instance they lie
/// on. `stride`: the estimate reprojects every stride-th plane sample each way, and
/// E(t+1) is E(t) scaled by the change of that subset (as temporal caching does).
pub fn estimates_at_sites(
    renderer: &Renderer,
    at_t: (&PreparedScene, &Scene),
    next: (&PreparedScene, &Scene),
    settings: &CacheSettings,
    sites: &[RecordSite],
    anchored: bool,
    stride: u32,
) -> Result<Vec<Estimate>> {
    let ctx = &renderer.ctx;
    // The records temporal caching would compute (shadow rays, unrefined planes).
    let settings = &super::TemporalCache::record_settings(settings);
    let pass = RecordPass::new(ctx, settings)?;
    let reprojection = ReprojectionPass::new(ctx, settings, stride)?;
    let plane_of = |resolution: u32| settings.plane(resolution);
    let (plane, estimate_plane) = (
        plane_of(settings.plane_resolution),
        plane_of(reprojection.table.resolution),
    );
    let cells = plane.pixels.len();
    let estimate_cells = estimate_plane.pixels.len();
    let reduce = |site: &RecordSite, samples: &[PlaneSample]| -> Record {
        reduce_plane(&plane, settings, site, samples)
    };
    let reduce_estimate = |site: &RecordSite, samples: &[PlaneSample]| -> Record {
        reduce_plane(&estimate_plane, settings, site, samples)
    };
    let next_frame = NextFrame::new(ctx, &next.0.gpu, at_t.1, next.1, anchored)?;
    let motions = super::motion::instance_motions(at_t.1, next.1);
    let mut out = Vec::with_capacity(sites.len());
    for chunk in sites.chunks(pass.batch as usize) {
        let planes = super::trace_planes_ahead(
            &pass,
            ctx,
            &at_t.0.gpu,
            Some((&next_frame, &reprojection)),
            chunk,
        )?;
        let truth_sites: Vec<RecordSite> = chunk
            .iter()
            .map(|site| match motions.get(site.instance as usize) {
                Some(m) if anchored && m.moves != 0 => {
                    super::motion::move_site(site, &Mat4::from_cols_array_2d(&m.to_next))
                }
                _ => *site,
            })
            .collect();
        let truth = super::trace_planes_ahead(&pass, ctx, &next.0.gpu, None, &truth_sites)?.now;
        for (i, site) in chunk.iter().enumerate() {
            let span = i * cells..(i + 1) * cells;
            let estimated = i * estimate_cells..(i + 1) * estimate_cells;
            let now = reduce(site, &planes.now[span.clone()]);
            let ahead = reduce_estimate(site, &planes.estimate[estimated.clone()]);
            let estimate = if stride > 1 {
                let subset = reduce_estimate(site, &planes.subset[estimated]);
                super::scaled_by_estimate(&now, &subset, &ahead)
            } else {
                ahead
            };
            out.push(Estimate {
                now: now.irradiance,
                estimate: estimate.irradiance,
                truth: reduce(&truth_sites[i], &truth[span]).irradiance,
            });
        }
    }
    ctx.check()?;
    Ok(out)
}

/// Where [`estimate_error_table`] puts its records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordSites {
    /// At visible pixels evenly strided over the image (the thesis's table).
    Even,
    /// Where a frame rendered from scratch places its records (every `n`-th of them when
    /// it places more than `count`): the records per-frame recomputation computes.
    Placed,
}

/// Places `count` record sites in `at_t` (`placement`: at visible pixels evenly strided
/// over the image, or where a frame places its records), computes each record at t, its
/// reprojected estimate at t+1 (`next`: the same scene one frame later) and the record
/// recomputed at t+1, and summarises the errors. `anchored`: records move with the
/// instance they lie on (the thesis keeps them in place), so the record recomputed at t+1
/// is traced from the moved site. `stride`: as [`estimates_at_sites`]. `temporal`: a_t
/// and dt_max for the lifespans.
#[allow(clippy::too_many_arguments)]
pub fn estimate_error_table(
    renderer: &Renderer,
    at_t: &Scene,
    next: &Scene,
    settings: &CacheSettings,
    count: usize,
    anchored: bool,
    stride: u32,
    temporal: &super::TemporalSettings,
    placement: RecordSites,
) -> Result<EstimateErrorTable> {
    let ctx = &renderer.ctx;
    // The records an animation would make (CacheSettings::for_animation).
    let settings = &settings.for_animation();
    let prepared = renderer.prepare(at_t)?;
    let prepared_next = renderer.prepare(next)?;
    let mut cache = renderer.new_cache(settings)?;
    let sites: Vec<RecordSite> = match placement {
        RecordSites::Even => {
            let (vis, _) = renderer.splat_cache(&prepared, &at_t.camera, &cache, false)?;
            let camera = GpuCamera::new(&at_t.camera);
            let visible: Vec<_> = vis.iter().filter(|v| v.is_hit()).collect();
            let spacing = (visible.len() / count.max(1)).max(1);
            visible
                .iter()
                .step_by(spacing)
                .take(count)
                .enumerate()
                .map(|(i, v)| RecordReference::site_from_pixel(settings, &camera, v, i as u32))
                .collect()
        }
        RecordSites::Placed => {
            renderer.render_gi_frame(&prepared, &at_t.camera, &mut cache, None, |_| {})?;
            let records = cache.read(ctx)?;
            let spacing = records.len().div_ceil(count.max(1)).max(1);
            records
                .iter()
                .step_by(spacing)
                .enumerate()
                .map(|(i, r)| RecordSite {
                    position: r.position,
                    r_min: r.r_min,
                    normal: r.normal,
                    seed: i as u32,
                    // Records keep only the shading normal (a site's geometric normal
                    // is kept for replacements only, `TemporalRecord::site`).
                    geometric_normal: r.normal,
                    instance: r.instance,
                })
                .collect()
        }
    };
    let motions = super::motion::instance_motions(at_t, next);
    let moving = |site: &RecordSite| {
        motions
            .get(site.instance as usize)
            .is_some_and(|m| m.moves != 0)
    };
    let (mut with, mut without, mut movers) = (Vec::new(), Vec::new(), Vec::new());
    // Lifespans count every record (one that goes dark lives one frame), errors only
    // those whose true E(t+1) is not black.
    let (mut all, mut all_movers) = (Vec::new(), Vec::new());
    for (site, e) in sites.iter().zip(estimates_at_sites(
        renderer,
        (&prepared, at_t),
        (&prepared_next, next),
        settings,
        &sites,
        anchored,
        stride,
    )?) {
        if let (Some(a), Some(b)) = (
            relative_error(e.estimate, e.truth),
            relative_error(e.now, e.truth),
        ) {
            with.push(a);
            without.push(b);
            movers.push(moving(site));
        }
        all.push(e);
        all_movers.push(moving(site));
    }
    ctx.check()?;
    let of_movers = |errors: &[f64]| -> Vec<f64> {
        errors
            .iter()
            .zip(&movers)
            .filter(|(_, m)| **m)
            .map(|(e, _)| *e)
            .collect()
    };
    Ok(EstimateErrorTable {
        records: with.len(),
        reprojection: ErrorSummary::of(&with),
        no_reprojection: ErrorSummary::of(&without),
        on_movers: movers.iter().filter(|m| **m).count(),
        on_movers_reprojection: ErrorSummary::of(&of_movers(&with)),
        on_movers_no_reprojection: ErrorSummary::of(&of_movers(&without)),
        lifespans: LifespanComparison::of(&all, &all_movers, temporal),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lifespans_follow_the_rule_for_estimated_and_true_tau() {
        let e = |now: f32, estimate: f32, truth: f32| Estimate {
            now: [now; 3],
            estimate: [estimate; 3],
            truth: [truth; 3],
        };
        // a_t 0.05, dt_max 5: |tau - 1| 0 -> 5 frames, 0.02 -> 3, 0.1 -> 1 (capped bins).
        let settings = crate::temporal::TemporalSettings {
            accuracy: 0.05,
            max_lifespan: 5,
            ..Default::default()
        };
        let l = LifespanComparison::of(
            &[e(1.0, 1.0, 1.02), e(1.0, 1.1, 1.0)],
            &[true, false],
            &settings,
        );
        assert_eq!(l.estimated, vec![1, 0, 0, 0, 1]);
        assert_eq!(l.truth, vec![0, 0, 1, 0, 1]);
        assert_eq!((l.estimated_mean, l.true_mean), (3.0, 4.0));
        // Harmonic means: 2 / (1/1 + 1/5) and 2 / (1/3 + 1/5); per class, one record each.
        assert!((l.estimated_harmonic - 2.0 / 1.2).abs() < 1e-12);
        assert!((l.true_harmonic - 2.0 / (1.0 / 3.0 + 0.2)).abs() < 1e-12);
        assert_eq!((l.movers_true_harmonic, l.still_true_harmonic), (3.0, 5.0));
        assert_eq!(l.movers, 1);
    }
}
