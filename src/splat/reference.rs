//! Plain-Rust splat: every record against every pixel, in record order, with the same
//! weight, "behind" test and extrapolation as `splat_gather.wgsl`.

use crate::records::Record;
use crate::visibility::VisSample;
use glam::Vec3;

/// Adds records `records[first..]` to per-pixel sums `(sum w E', sum w)` (`sums` holds the
/// previous sums, or zeros), weighing the records' corrals or not (a gather built with
/// `CORRAL` or without: `SplatSource::corral`).
pub fn splat_records(
    records: &[Record],
    first: usize,
    vis: &[VisSample],
    accuracy: f32,
    corral: bool,
    sums: &mut [[f32; 4]],
) {
    splat_records_widened(records, first, vis, accuracy, 0.0, corral, sums);
}

/// `SplatSource::dark_only_empty` (a still frame's plane records) on the `sums` a splat of
/// `records` at `accuracy` gave: a pixel that no lit record reaches, only dark ones
/// ([`Record::is_dark`]), gets empty sums, as `pixel_sums` in `shared/splat_pixel.wgsl`;
/// the records' corrals weighed or not, as in that splat (tail fill's tier weighs none).
pub fn empty_where_only_dark(
    records: &[Record],
    vis: &[VisSample],
    accuracy: f32,
    corral: bool,
    sums: &mut [[f32; 4]],
) {
    for (v, sum) in vis.iter().zip(sums.iter_mut()) {
        if !v.is_hit() || sum[3] == 0.0 {
            continue;
        }
        let p = Vec3::from(v.position);
        let n = Vec3::from(v.shading_normal);
        let lit = records
            .iter()
            .any(|r| !r.is_dark() && r.reaches_corralled(p, n, accuracy, corral));
        if !lit {
            *sum = [0.0; 4];
        }
    }
}

/// [`splat_records`] with the weight's plateau of a widened gather ([`splat_weight`]).
pub fn splat_records_widened(
    records: &[Record],
    first: usize,
    vis: &[VisSample],
    accuracy: f32,
    plateau: f32,
    corral: bool,
    sums: &mut [[f32; 4]],
) {
    for (v, sum) in vis.iter().zip(sums.iter_mut()) {
        if !v.is_hit() {
            continue;
        }
        let p = Vec3::from(v.position);
        let n = Vec3::from(v.shading_normal);
        for r in &records[first.min(records.len())..] {
            let err = r.error_at(p, n);
            if err <= accuracy && r.in_front_of(p, n, accuracy) && (!corral || r.corral_allows(p)) {
                let w = splat_weight(err, accuracy, plateau);
                let e = r.irradiance_at(p, n);
                sum[0] += w * e.x;
                sum[1] += w * e.y;
                sum[2] += w * e.z;
                sum[3] += w;
            }
        }
    }
}

/// `wgsl/splat_consistency.wgsl` on the CPU: each pixel of `wide` keeps its sums where
/// both `narrow` and `wide` have some and the irradiance channel sums `Y = (r + g + b) / w`
/// differ by at most `tolerance Y_narrow`, or where `narrow` has none; elsewhere it takes
/// `narrow`'s. Returns how many pixels kept `wide`'s sums where both had some.
pub fn keep_consistent(wide: &mut [[f32; 4]], narrow: &[[f32; 4]], tolerance: f32) -> u32 {
    let mut kept = 0;
    for (w, n) in wide.iter_mut().zip(narrow) {
        if n[3] <= 0.0 || w[3] <= 0.0 {
            continue;
        }
        let y_narrow = ((n[0] + n[1]) + n[2]) / n[3];
        let y_wide = ((w[0] + w[1]) + w[2]) / w[3];
        if (y_wide - y_narrow).abs() <= tolerance * y_narrow {
            kept += 1;
        } else {
            *w = *n;
        }
    }
    kept
}

/// Per-pixel sums with tail fill (`splat_gather.wgsl` with `accumulate` 2): every record
/// at `accuracy`, as [`splat_records`]; then, where no record reaches the pixel, the records
/// that reach it at `tail_accuracy`, weighted at that accuracy, their corrals ignored (the
/// first tier weighs them with `corral`). With `dark_only_empty` (a still frame's plane
/// records), both tiers leave the pixels only dark records reach empty
/// ([`empty_where_only_dark`]), and a last tier at `last_accuracy`
/// (`CacheSettings::last_tier_accuracy`), when there is one, gives the pixels still empty
/// every record that reaches them there, as the tail's tier does at its accuracy.
pub fn splat_records_with_tail(
    records: &[Record],
    vis: &[VisSample],
    accuracy: f32,
    tail_accuracy: f32,
    last_accuracy: Option<f32>,
    dark_only_empty: bool,
    corral: bool,
) -> Vec<[f32; 4]> {
    let mut sums = vec![[0.0f32; 4]; vis.len()];
    splat_records(records, 0, vis, accuracy, corral, &mut sums);
    if dark_only_empty {
        empty_where_only_dark(records, vis, accuracy, corral, &mut sums);
    }
    // The wider tiers ignore the corrals: a pixel that the corrals keep from every lit
    // record at the accuracy takes them at the tail's rather than reading black.
    let last = last_accuracy.filter(|_| dark_only_empty);
    for tier_accuracy in [Some(tail_accuracy), last].into_iter().flatten() {
        let mut tier = vec![[0.0f32; 4]; vis.len()];
        splat_records_widened(records, 0, vis, tier_accuracy, 0.0, false, &mut tier);
        if dark_only_empty {
            empty_where_only_dark(records, vis, tier_accuracy, false, &mut tier);
        }
        for (sum, t) in sums.iter_mut().zip(tier) {
            if sum[3] == 0.0 {
                *sum = t;
            }
        }
    }
    sums
}

/// Per record, the pixels it contributes to (`count_coverage` 1 in `splat_gather.wgsl`);
/// with `expiring`, only those where no record it leaves unmarked does, and 0 for unmarked
/// records (`count_coverage` 2). The records' corrals weighed or not, as by that gather.
pub fn record_coverage(
    records: &[Record],
    expiring: Option<&[bool]>,
    vis: &[VisSample],
    accuracy: f32,
    corral: bool,
) -> Vec<u32> {
    let mut counts = vec![0u32; records.len()];
    let mut contributors = Vec::new();
    for v in vis.iter().filter(|v| v.is_hit()) {
        let p = Vec3::from(v.position);
        let n = Vec3::from(v.shading_normal);
        contributors.clear();
        contributors.extend(
            records
                .iter()
                .enumerate()
                .filter_map(|(k, r)| r.reaches_corralled(p, n, accuracy, corral).then_some(k)),
        );
        let counted = match expiring {
            Some(flags) => contributors
                .iter()
                .all(|&k| flags.get(k).copied().unwrap_or(false)),
            None => true,
        };
        if counted {
            for &k in &contributors {
                counts[k] += 1;
            }
        }
    }
    counts
}

/// The weight of a record with Ward's error `err <= accuracy` at a pixel (WGSL
/// `splat_weight`): `1 / err - 1 / a`, so that it falls to zero at the edge of the record's
/// validity area, floored at 1e-6; `1 / err` is capped at `1 / plateau` (0 in every gather
/// but a widened one: `records::noise_widening::weight_plateau`).
pub fn splat_weight(err: f32, accuracy: f32, plateau: f32) -> f32 {
    (1.0 / err.max(plateau.max(1e-6)) - 1.0 / accuracy).max(1e-6)
}

#[cfg(test)]
mod tests {
    use super::splat_weight;

    #[test]
    fn splat_weights_fall_to_zero_at_the_validity_edge() {
        let a = 0.2;
        // Inside: Ward's 1/err less its value at the edge.
        assert!((splat_weight(0.05, a, 0.0) - 15.0).abs() < 1e-4);
        assert!((splat_weight(0.1, a, 0.0) - 5.0).abs() < 1e-4);
        // Decreasing, continuous to (almost) zero at err = a: no step at the edge.
        let mut last = f32::INFINITY;
        for k in 1..=100 {
            let w = splat_weight(a * k as f32 / 100.0, a, 0.0);
            assert!(w > 0.0 && w <= last, "k {k}: {w}");
            last = w;
        }
        assert!(splat_weight(a, a, 0.0) <= 1e-5);
        // The record's own point: capped, finite.
        assert!(splat_weight(0.0, a, 0.0).is_finite());
    }

    #[test]
    fn a_plateau_caps_the_weight_near_the_record_and_nothing_beyond_it() {
        let a = 0.8;
        // Within the plateau every error weighs as the plateau's edge.
        let top = splat_weight(0.1, a, 0.1);
        assert!((top - (10.0 - 1.25)).abs() < 1e-4);
        assert_eq!(splat_weight(0.0, a, 0.1), top);
        assert_eq!(splat_weight(0.05, a, 0.1), top);
        // Beyond it, Ward's weight as without one.
        assert_eq!(splat_weight(0.4, a, 0.1), splat_weight(0.4, a, 0.0));
    }
}
