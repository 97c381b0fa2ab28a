//! Whether a cache's E(t+1) estimates pay for themselves ([`EstimateMode::Auto`]).
//!
//! The estimate at t+1 (reprojection and re-shading of each new record's plane,
//! algorithms.md 4.3; for radiance records also its HSH projection) exists to give a record
//! more than one frame of life: a record whose estimate finds its incoming light changed by
//! more than a_t lives one frame (decision 9), and its estimate was spent for nothing. Where
//! nearly every record of a cache lives one frame (glossy Spheres: 5,459 of 6,524 radiance
//! records, the 66 balls change what a glossy record sees by a median 18 % a frame), the
//! estimates cost more than the frames they win. Then the cache stops estimating: its
//! records are computed as before, live one frame, and are replaced at the same place
//! (their sites are still kept); one frame in [`PROBE_PERIOD`] estimates anyway, so that a
//! cache whose scene calms down takes the estimates back.
//!
//! The rule compares counts, not times, so runs stay deterministic. Over the last
//! [`WINDOW_FRAMES`] frames that estimated, the records estimated `n` won `g` frames beyond
//! their first (the lifespans granted). Estimating costs each record a share `s` of what
//! computing it cost ([`cost_share`]); without estimates a record is computed again every
//! frame. So estimating pays while `g >= s n`: the frames won save whole records.

use std::collections::VecDeque;

/// Whether records are estimated at t+1 ([`super::TemporalSettings::estimates`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum EstimateMode {
    /// Every new record, every frame (the seed).
    Always,
    /// While the estimates win more frames of life than they cost (module docs), judged
    /// per cache (irradiance records and radiance records apart).
    Auto,
}

/// Estimating frames whose counts [`EstimateLedger`] judges by.
pub const WINDOW_FRAMES: usize = 4;
/// Records estimated (over the window) before the rule judges; fewer: estimate.
pub const MIN_RECORDS: u64 = 64;
/// A cache that stopped estimating estimates again every this many frames, to see whether
/// the estimates pay again.
pub const PROBE_PERIOD: u32 = 4;

/// The share of a record's computation its estimate at t+1 costs, from ray counts: a record
/// traces `rays` plane rays, each hit then `shadow_rays` shadow rays; its estimate re-shades
/// `cells` moved hits, each with the same shadow rays and no ray of its own (reprojection
/// moves hits without tracing). So `cells S / (rays (1 + S))`. Measured on glossy Spheres
/// 96x72 (48x48 radiance planes, stride 1, one light sample): 0.5 by this count, 0.44 by
/// the GPU time of the radiance estimates (re-shading, reprojection, their projection:
/// 16 s) against the records' planes and projection (36.5 s).
pub fn cost_share(rays: u64, cells: u64, shadow_rays: u32) -> f64 {
    let s = f64::from(shadow_rays.max(1));
    cells as f64 * s / (rays.max(1) as f64 * (1.0 + s))
}

/// (records, frames of life they won beyond their first) of a frame's lifespan histogram
/// (entry i: records used in i + 1 frames), what [`EstimateLedger::add_frame`] takes.
pub fn frames_won(lifespans: &[u32]) -> (u64, u64) {
    let records = lifespans.iter().map(|&n| u64::from(n)).sum();
    let won = (0u64..)
        .zip(lifespans)
        .map(|(i, &n)| i * u64::from(n))
        .sum();
    (records, won)
}

/// A cache's recent estimates and what they won ([`EstimateMode::Auto`]).
#[derive(Clone, Debug, Default)]
pub struct EstimateLedger {
    /// (records estimated, frames of life they won beyond their first) of the last
    /// [`WINDOW_FRAMES`] frames that estimated, newest last.
    recent: VecDeque<(u64, u64)>,
    /// Frames since the last one that estimated.
    skipped: u32,
}

impl EstimateLedger {
    /// Whether the next frame estimates its records, given `mode` and the [`cost_share`]
    /// `share` of an estimate.
    pub fn estimates(&self, mode: EstimateMode, share: f64) -> bool {
        match mode {
            EstimateMode::Always => true,
            EstimateMode::Auto => {
                let (n, won) = self
                    .recent
                    .iter()
                    .fold((0, 0), |(n, w), &(a, b)| (n + a, w + b));
                n < MIN_RECORDS
                    || won as f64 >= share * n as f64
                    || self.skipped + 1 >= PROBE_PERIOD
            }
        }
    }

    /// Adds a frame: `won` is `Some((records estimated, frames won))` when it estimated,
    /// None when it did not.
    pub fn add_frame(&mut self, won: Option<(u64, u64)>) {
        match won {
            Some(counts) => {
                self.skipped = 0;
                self.recent.push_back(counts);
                while self.recent.len() > WINDOW_FRAMES {
                    self.recent.pop_front();
                }
            }
            None => self.skipped += 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn estimates_that_win_no_frames_stop_and_are_probed_again() {
        let share = cost_share(2304, 2304, 1);
        assert!((share - 0.5).abs() < 1e-12);
        let mut ledger = EstimateLedger::default();
        // Too few records to judge: estimate.
        ledger.add_frame(Some((40, 0)));
        assert!(ledger.estimates(EstimateMode::Auto, share));
        // 100 records that won 20 frames: a fifth of a frame each, under half.
        ledger.add_frame(Some((60, 20)));
        assert!(!ledger.estimates(EstimateMode::Auto, share));
        assert!(ledger.estimates(EstimateMode::Always, share));
        // Skipped frames, then a probe on the PROBE_PERIOD-th.
        for _ in 1..PROBE_PERIOD {
            assert!(!ledger.estimates(EstimateMode::Auto, share));
            ledger.add_frame(None);
        }
        assert!(ledger.estimates(EstimateMode::Auto, share));
        // The probe finds long lives: estimating pays again (200 records, 260 frames).
        ledger.add_frame(Some((100, 240)));
        assert!(ledger.estimates(EstimateMode::Auto, share));
    }

    #[test]
    fn frames_won_count_the_lives_beyond_the_first() {
        // 3 records of one frame, 2 of two, 1 of four: 6 records, 2 + 3 frames won.
        assert_eq!(frames_won(&[3, 2, 0, 1]), (6, 5));
        assert_eq!(frames_won(&[]), (0, 0));
    }

    #[test]
    fn the_window_forgets_old_frames() {
        let share = 0.5;
        let mut ledger = EstimateLedger::default();
        ledger.add_frame(Some((1000, 5000)));
        for _ in 0..WINDOW_FRAMES {
            assert!(ledger.estimates(EstimateMode::Auto, share));
            ledger.add_frame(Some((100, 0)));
        }
        // The long-lived frame left the window: 400 records, no frame won.
        assert!(!ledger.estimates(EstimateMode::Auto, share));
    }

    #[test]
    fn a_cheap_estimate_pays_with_few_frames_won() {
        // Irradiance records at stride 2: a quarter of the cells.
        let share = cost_share(576, 144, 1);
        assert!((share - 0.125).abs() < 1e-12);
        let mut ledger = EstimateLedger::default();
        ledger.add_frame(Some((580, 80)));
        assert!(ledger.estimates(EstimateMode::Auto, share));
    }
}
