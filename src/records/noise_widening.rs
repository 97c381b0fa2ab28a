//! How wide a still frame's gather interpolates, from the noise of its records
//! (`CacheSettings::noise_widening`, `--noise-widening`; 0 turns it off).
//!
//! Each record's plane estimates E with noise. Where that noise, not interpolation, is the
//! image's error (planes that see small bright patches: a hall lit through small windows,
//! an object under an environment map), a gather that reaches farther averages more
//! records and the error falls; where records are quiet (a Cornell box), reaching farther
//! only adds interpolation error. Ward's accuracy a is the relative error the cache
//! tolerates, so a record's relative noise is read against it: where the frame's records
//! are typically noisier than `noise_widening a` (their median relative noise, an
//! estimate per record from its plane: [`super::reference::plane_noise`]), the frame
//! interpolates at `interpolation_factor x median / (noise_widening a)`, up to
//! [`super::CacheSettings::MAX_INTERPOLATION_FACTOR`] and to Ward's error 1
//! ([`MAX_INTERPOLATION_ACCURACY`]). Against a the rule keeps coarse
//! settings from widening records that are large already: at `-a 1.0` with 8x8 planes
//! Sponza's records are noisy (0.31) and their interpolation error larger still.
//!
//! A widened gather caps each record's weight near its own point ([`PLATEAU`]): Ward's
//! weight is singular there, and against a smoother average the record's own noise showed
//! as a dot.
//!
//! The widened gather is then checked against the gather at the settings' factor, pixel
//! by pixel ([`WIDENING_TOLERANCE`], `wgsl/splat_consistency.wgsl`): where the wider
//! average moves a pixel's irradiance by more than the tolerance, the pixel keeps the
//! narrower gather's. Noise alone cannot tell a peak of light narrower than the records'
//! spacing (the bright foot of a sunlit wall) from noise; the narrower gather keeps the
//! peak, and no pixel strays further than the tolerance from what the settings' factor
//! gives.
//!
//! One factor per frame, not one per record: a record's noise estimate is correlated
//! with its own error (a plane that caught a bright patch reads both brighter and
//! noisier than one that missed it), so widening or weighting each record by its own
//! estimate favoured the records that missed (docs/results.md, "Interpolating as wide as
//! the records' noise"). Records that carry no estimate (dark planes, VPL and photon
//! records) do not count; a frame without any keeps the settings' factor.

use super::{CacheSettings, Record, RecordSource};

/// The widest accuracy a widened gather interpolates at: Ward's error `|p - p_k| / R_k +
/// sqrt(1 - n.n_k)` at most 1 (on the nave at `-a 0.5` with 16x16 planes a factor of 4,
/// interpolation at 2, raised the indirect error from 34.4 to 38.3 %; 2.5 lowered it to
/// 30.5 %).
pub const MAX_INTERPOLATION_ACCURACY: f32 = 1.0;

/// The plateau of a widened gather's weight, as a share of the widening: a record's weight
/// `1 / err - 1 / (f a)` is capped at `err = PLATEAU (f - f_0) a` ([`weight_plateau`]).
/// Ward's weight is singular at the record's own point, so there the pixel takes the record
/// alone; against the smoother average of a widened gather each record's plane noise then
/// showed as a dot at its position. Measured at 0.08 / 0.15 / 0.3 / 1 (indirect error,
/// nave 160x160 / its second view / env-sphere 128x96; none: 10.99 / 10.41 / 2.87 %):
/// 10.82 / 10.30 / 2.86, 10.71 / 10.16 / 2.85, 10.90 / 9.94 / 2.84, 18.37 / 10.32 / 2.77 %.
pub const PLATEAU: f32 = 0.15;

/// The default [`CacheSettings::widening_tolerance`]: a pixel keeps the widened gather's
/// irradiance where it is within `0.4 a` (relative; 10 % at the default a 0.25) of the
/// default gather's (`wgsl/splat_consistency.wgsl`). Ward's accuracy a is the relative error
/// the cache tolerates; the widening may spend part of it. A wider gather averages more
/// records' plane noise away but also spreads a peak of light narrower than the records'
/// spacing over its darker neighbours: on the nave with the sun from the west one such block
/// held 57 % of the image's squared error, and the unchecked widened gather took it from 0.75
/// to 0.55 of the reference (16.5 -> 28.9 %; checked, 16.5 %). Measured on 13 configurations
/// of the nave and env-sphere at a 0.25 and on the nave at a 0.1-0.5 (docs/results.md, "The
/// widened gather checked against the default one"): 0.4 a gains up to 14 % (the nave's
/// defaults) and loses at most 1.8 %; a fixed 0.1 lost 5-9 % at a 0.1-0.15, 0.2 a gained
/// less.
pub const WIDENING_TOLERANCE: f32 = 0.4;

/// The weight plateau of a frame gathered at `factor` ([`PLATEAU`]): 0 where the factor is
/// the settings' own (the gather is not widened).
pub fn weight_plateau(settings: &CacheSettings, factor: f32) -> f32 {
    PLATEAU * settings.accuracy * (factor - settings.interpolation_factor).max(0.0)
}

/// The median relative noise of the records that carry one (None: no record does).
pub fn median_noise(records: &[Record]) -> Option<f32> {
    let mut noise: Vec<f32> = records
        .iter()
        .map(Record::relative_noise)
        .filter(|&n| n > 0.0)
        .collect();
    if noise.is_empty() {
        return None;
    }
    noise.sort_by(f32::total_cmp);
    Some(noise[noise.len() / 2])
}

/// The interpolation factor of a frame whose records' median relative noise is `median`
/// (see the module): the settings' factor where [`CacheSettings::noise_widening`] is 0,
/// the noise is unknown or the records do not come from planes alone (VPL and photon
/// records were measured with a fixed factor).
pub fn frame_interpolation_factor(settings: &CacheSettings, median: Option<f32>) -> f32 {
    let base = settings.interpolation_factor;
    match median {
        Some(noise) if settings.noise_widening > 0.0 && settings.source == RecordSource::Planes => {
            let budget = settings.noise_widening * settings.accuracy;
            // Never past Ward's error 1, where a record whose normal is at right angles
            // to the pixel's would still contribute (and never below the base factor).
            let widest = CacheSettings::MAX_INTERPOLATION_FACTOR
                .min(MAX_INTERPOLATION_ACCURACY / settings.accuracy)
                .max(base);
            (base * (noise / budget).max(1.0)).min(widest)
        }
        _ => base,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(noise: f32) -> Record {
        let mut r = Record::default();
        r.rotation_gradient[0][3] = noise;
        r
    }

    #[test]
    fn the_median_skips_records_without_a_noise_estimate() {
        let records: Vec<Record> = [0.0, 0.3, 0.1, 0.0, 0.2].map(record).to_vec();
        assert_eq!(median_noise(&records), Some(0.2));
        assert_eq!(median_noise(&[record(0.0)]), None);
        assert_eq!(median_noise(&[]), None);
    }

    #[test]
    fn noise_within_the_budget_keeps_the_factor_and_more_widens_it_up_to_the_limit() {
        let settings = CacheSettings {
            accuracy: 0.25,
            noise_widening: 0.4,
            ..CacheSettings::default()
        };
        let base = settings.interpolation_factor;
        // The budget is 0.4 x 0.25 = 0.1.
        assert_eq!(frame_interpolation_factor(&settings, None), base);
        assert_eq!(frame_interpolation_factor(&settings, Some(0.08)), base);
        assert!((frame_interpolation_factor(&settings, Some(0.2)) - 2.0 * base).abs() < 1e-6);
        assert_eq!(
            frame_interpolation_factor(&settings, Some(10.0)),
            CacheSettings::MAX_INTERPOLATION_FACTOR
        );
        // A coarser accuracy tolerates more noise, and widens no further than Ward's
        // error 1.
        let coarse = CacheSettings {
            accuracy: 1.0,
            ..settings.clone()
        };
        assert_eq!(frame_interpolation_factor(&coarse, Some(0.2)), base);
        assert_eq!(frame_interpolation_factor(&coarse, Some(10.0)), base);
        let half = CacheSettings {
            accuracy: 0.5,
            ..settings.clone()
        };
        assert_eq!(frame_interpolation_factor(&half, Some(10.0)), 2.0);
        let photons = CacheSettings {
            source: RecordSource::Photons,
            ..settings.clone()
        };
        assert_eq!(frame_interpolation_factor(&photons, Some(10.0)), base);
        let off = CacheSettings {
            noise_widening: 0.0,
            ..settings
        };
        assert_eq!(frame_interpolation_factor(&off, Some(10.0)), base);
        // No plateau where the gather is not widened.
        assert_eq!(weight_plateau(&off, base), 0.0);
        assert!((weight_plateau(&off, 4.0) - PLATEAU * 0.25 * 2.5).abs() < 1e-6);
    }
}
