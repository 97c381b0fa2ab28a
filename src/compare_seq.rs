//! Comparing an image sequence A against a reference sequence frame by frame
//! (`radsplat compare-seq`): the [`compare`](crate::compare) numbers per frame, and
//! temporal flicker.
//!
//! Flicker of frame f (for every frame after the first), over the P pixels p, with Y the
//! Rec. 709 luminance ([`luminance`]) of the beauty:
//!
//! ```text
//! flicker(f)          = 1/P Σ_p | |Y_A(f) − Y_A(f−1)| − |Y_ref(f) − Y_ref(f−1)| |
//! relative flicker(f) = flicker(f) / mean_p Y_ref(f)
//! ```
//!
//! It is zero when A changes from frame to frame exactly as much as the reference does,
//! whatever A's constant error, and grows with temporal noise or popping in A. The
//! summary's relative flicker is the mean flicker divided by the reference's mean
//! luminance over the whole sequence.

use crate::compare::{Comparison, RgbImage, compare, load_image, luminance};
use crate::output::plot::{Series, line_chart};
use crate::output::png_out::write_png;
use crate::output::{frame_path, write_atomically};
use crate::{Error, Result};
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

/// The numbers of one frame.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameComparison {
    pub frame: u32,
    /// Beauty, surfaces and indirect RMSE of A's frame against the reference's.
    pub comparison: Comparison,
    /// Mean luminance of the reference frame.
    pub reference_mean_luminance: f64,
    /// Flicker against the previous frame (module docs); `None` for the first frame.
    pub flicker: Option<f64>,
    /// `flicker / reference_mean_luminance` (infinite for a black reference with flicker).
    pub flicker_relative: Option<f64>,
}

/// Statistics over the whole sequence.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SequenceSummary {
    /// Number of frames compared.
    pub frames: usize,
    /// Mean, median and maximum over the frames of the beauty's relative RMSE.
    pub mean_relative_rmse: f64,
    pub median_relative_rmse: f64,
    pub max_relative_rmse: f64,
    /// The frame with the largest relative RMSE.
    pub max_relative_rmse_frame: u32,
    /// Mean luminance of the reference over all frames.
    pub reference_mean_luminance: f64,
    /// Mean of the per-frame flicker; `None` for a single frame.
    pub mean_flicker: Option<f64>,
    /// `mean_flicker / reference_mean_luminance`.
    pub mean_flicker_relative: Option<f64>,
}

/// The result of [`compare_sequence`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct SequenceComparison {
    pub a_pattern: PathBuf,
    pub reference_pattern: PathBuf,
    pub first_frame: u32,
    pub last_frame: u32,
    /// Box-filter factor applied to both images before comparing (1: none).
    pub downsample: u32,
    pub frames: Vec<FrameComparison>,
    pub summary: SequenceSummary,
    /// Image size after downsampling.
    pub width: u32,
    pub height: u32,
    /// Per pixel (row-major), the flicker term `| |ΔY_A| − |ΔY_ref| |` averaged over the
    /// frame pairs (empty for a single frame): where the sequence flickers.
    #[serde(skip)]
    pub flicker_map: Vec<f64>,
}

/// Flicker (relative to the reference's mean luminance) drawn white in `--flicker-map`;
/// larger values saturate.
pub const FLICKER_MAP_FULL_SCALE: f64 = 0.1;

/// Size of the `--plot` chart in pixels.
pub const PLOT_SIZE: (u32, u32) = (800, 400);
/// Colour of the relative RMSE curve in the plot.
pub const RMSE_COLOR: [u8; 3] = [31, 119, 180];
/// Colour of the relative flicker curve in the plot.
pub const FLICKER_COLOR: [u8; 3] = [230, 110, 0];

/// Mean over pixels of `| |a − a_prev| − |r − r_prev| |`, from luminance images of one size.
pub fn flicker(a_prev: &[f32], a: &[f32], ref_prev: &[f32], reference: &[f32]) -> f64 {
    let terms = flicker_terms(a_prev, a, ref_prev, reference);
    terms.iter().sum::<f64>() / terms.len().max(1) as f64
}

/// Per pixel, `| |a − a_prev| − |r − r_prev| |` (the terms [`flicker`] averages).
fn flicker_terms(a_prev: &[f32], a: &[f32], ref_prev: &[f32], reference: &[f32]) -> Vec<f64> {
    let n = a
        .len()
        .min(a_prev.len())
        .min(reference.len())
        .min(ref_prev.len());
    (0..n)
        .map(|p| {
            let da = (f64::from(a[p]) - f64::from(a_prev[p])).abs();
            let dr = (f64::from(reference[p]) - f64::from(ref_prev[p])).abs();
            (da - dr).abs()
        })
        .collect()
}

fn relative(v: f64, norm: f64) -> f64 {
    if norm > 0.0 {
        v / norm
    } else if v == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

fn load(path: &Path, downsample: u32) -> Result<RgbImage> {
    let img = load_image(path)?;
    if downsample == 1 {
        Ok(img)
    } else {
        img.downsample(downsample)
    }
}

/// Compares the frames `frames` of the sequence `a_pattern` against those of
/// `reference_pattern` (patterns as in [`frame_path`]), each pair box-filtered by
/// `downsample` (1: not at all) first. Every frame file is checked to exist before any is
/// read; errors name the missing or bad file, and images whose sizes differ (between A
/// and the reference, or from one frame to the next).
pub fn compare_sequence(
    a_pattern: &Path,
    reference_pattern: &Path,
    frames: RangeInclusive<u32>,
    downsample: u32,
) -> Result<SequenceComparison> {
    if frames.is_empty() {
        return Err(Error::Usage(format!(
            "the frame range {}..{} is empty",
            frames.start(),
            frames.end()
        )));
    }
    let mut paths = Vec::new();
    for f in frames.clone() {
        let pair = (frame_path(a_pattern, f)?, frame_path(reference_pattern, f)?);
        for p in [&pair.0, &pair.1] {
            std::fs::metadata(p).map_err(|e| Error::io(p, e))?;
        }
        paths.push((f, pair));
    }
    let mut results = Vec::with_capacity(paths.len());
    // The previous frame: luminance of A and of the reference, A's file and the size.
    struct Prev {
        ya: Vec<f32>,
        yr: Vec<f32>,
        path: PathBuf,
        size: (u32, u32),
    }
    let mut prev: Option<Prev> = None;
    let mut flicker_map: Vec<f64> = Vec::new();
    let mut pairs = 0u32;
    for (frame, (pa, pr)) in paths {
        let (a, r) = (load(&pa, downsample)?, load(&pr, downsample)?);
        let comparison = compare(&a, &r)?;
        let ya: Vec<f32> = a.beauty.iter().map(|&p| luminance(p)).collect();
        let yr: Vec<f32> = r.beauty.iter().map(|&p| luminance(p)).collect();
        let reference_mean_luminance = mean(yr.iter().map(|&y| f64::from(y))).unwrap_or_default();
        let flicker = match &prev {
            Some(p) if p.size != (a.width, a.height) => {
                return Err(Error::Usage(format!(
                    "frame sizes differ: {} is {}x{}, {} is {}x{}",
                    p.path.display(),
                    p.size.0,
                    p.size.1,
                    pa.display(),
                    a.width,
                    a.height
                )));
            }
            Some(p) => {
                let terms = flicker_terms(&p.ya, &ya, &p.yr, &yr);
                flicker_map.resize(terms.len(), 0.0);
                for (m, t) in flicker_map.iter_mut().zip(&terms) {
                    *m += t;
                }
                pairs += 1;
                Some(terms.iter().sum::<f64>() / terms.len().max(1) as f64)
            }
            None => None,
        };
        results.push(FrameComparison {
            frame,
            comparison,
            reference_mean_luminance,
            flicker,
            flicker_relative: flicker.map(|v| relative(v, reference_mean_luminance)),
        });
        prev = Some(Prev {
            ya,
            yr,
            path: pa,
            size: (a.width, a.height),
        });
    }
    let summary = summarize(&results);
    for m in &mut flicker_map {
        *m /= f64::from(pairs.max(1));
    }
    let (width, height) = prev.map_or((0, 0), |p| p.size);
    Ok(SequenceComparison {
        a_pattern: a_pattern.to_path_buf(),
        reference_pattern: reference_pattern.to_path_buf(),
        first_frame: *frames.start(),
        last_frame: *frames.end(),
        downsample,
        frames: results,
        summary,
        width,
        height,
        flicker_map,
    })
}

fn summarize(frames: &[FrameComparison]) -> SequenceSummary {
    let rel: Vec<f64> = frames
        .iter()
        .map(|f| f.comparison.beauty.relative_rmse)
        .collect();
    let mut sorted = rel.clone();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    let median = match n {
        0 => 0.0,
        _ if n % 2 == 1 => sorted[n / 2],
        _ => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
    };
    let (max_frame, max) = frames
        .iter()
        .map(|f| (f.frame, f.comparison.beauty.relative_rmse))
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .unwrap_or_default();
    let reference_mean_luminance =
        mean(frames.iter().map(|f| f.reference_mean_luminance)).unwrap_or_default();
    let mean_flicker = mean(frames.iter().filter_map(|f| f.flicker));
    SequenceSummary {
        frames: n,
        mean_relative_rmse: mean(rel.iter().copied()).unwrap_or_default(),
        median_relative_rmse: median,
        max_relative_rmse: max,
        max_relative_rmse_frame: max_frame,
        reference_mean_luminance,
        mean_flicker,
        mean_flicker_relative: mean_flicker.map(|v| relative(v, reference_mean_luminance)),
    }
}

impl SequenceComparison {
    /// A text table, one row per frame: frame, RMSE, relative RMSE (%), flicker and
    /// relative flicker (%; `-` for the first frame).
    pub fn table(&self) -> String {
        let mut out = format!(
            "{:>6}  {:>12}  {:>9}  {:>12}  {:>9}\n",
            "frame", "RMSE", "rel RMSE%", "flicker", "flicker%"
        );
        for f in &self.frames {
            let (flicker, rel) = match (f.flicker, f.flicker_relative) {
                (Some(v), Some(r)) => (format!("{v:.6e}"), format!("{:.3}", 100.0 * r)),
                _ => ("-".into(), "-".into()),
            };
            out += &format!(
                "{:>6}  {:>12.6e}  {:>9.3}  {:>12}  {:>9}\n",
                f.frame,
                f.comparison.beauty.rmse,
                100.0 * f.comparison.beauty.relative_rmse,
                flicker,
                rel
            );
        }
        out
    }

    /// One line: mean / median / max relative RMSE and the mean flicker.
    pub fn summary_line(&self) -> String {
        let s = &self.summary;
        let flicker = match (s.mean_flicker, s.mean_flicker_relative) {
            (Some(v), Some(r)) => {
                format!("mean flicker {v:.6e} ({:.3} % of mean Y(ref))", 100.0 * r)
            }
            _ => "flicker: needs two frames or more".into(),
        };
        format!(
            "{} frames: relative RMSE mean {:.3} %, median {:.3} %, max {:.3} % (frame {}); {flicker}",
            s.frames,
            100.0 * s.mean_relative_rmse,
            100.0 * s.median_relative_rmse,
            100.0 * s.max_relative_rmse,
            s.max_relative_rmse_frame
        )
    }

    /// Writes the per-frame numbers and the summary as pretty JSON, atomically.
    pub fn write_json(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::Output {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        write_atomically(path, text.as_bytes())
    }

    /// Writes the flicker map as a PNG, atomically: per pixel, the mean flicker term
    /// relative to the reference's mean luminance, from black (none) through red and
    /// yellow to white at [`FLICKER_MAP_FULL_SCALE`].
    pub fn write_flicker_map(&self, path: &Path) -> Result<()> {
        if self.flicker_map.is_empty() {
            return Err(Error::Usage(
                "a flicker map needs two frames or more".into(),
            ));
        }
        let norm = self.summary.reference_mean_luminance * FLICKER_MAP_FULL_SCALE;
        let rgb: Vec<u8> = self
            .flicker_map
            .iter()
            .flat_map(|&m| heat(if norm > 0.0 { m / norm } else { 0.0 }))
            .collect();
        write_png(path, self.width, self.height, &rgb)
    }

    /// Writes a [`PLOT_SIZE`] PNG line chart, atomically: x = frame; the beauty's relative
    /// RMSE ([`RMSE_COLOR`], left axis) and the relative flicker ([`FLICKER_COLOR`], right
    /// axis), each on its own scale from 0 to its maximum, legend boxes at the top.
    pub fn write_plot(&self, path: &Path) -> Result<()> {
        let rmse = Series {
            label: "REL RMSE".into(),
            color: RMSE_COLOR,
            values: self
                .frames
                .iter()
                .map(|f| Some(f.comparison.beauty.relative_rmse))
                .collect(),
            percent: true,
        };
        let flicker = Series {
            label: "FLICKER".into(),
            color: FLICKER_COLOR,
            values: self.frames.iter().map(|f| f.flicker_relative).collect(),
            percent: true,
        };
        line_chart(PLOT_SIZE.0, PLOT_SIZE.1, self.first_frame, &[rmse, flicker])?.write_png(path)
    }
}

/// Black → red → yellow → white for `t` from 0 to 1 (clamped).
fn heat(t: f64) -> [u8; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let channel = |lo: f64| ((3.0 * t - lo).clamp(0.0, 1.0) * 255.0).round() as u8;
    [channel(0.0), channel(1.0), channel(2.0)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flicker_is_the_mean_difference_of_temporal_changes() {
        // A steps by +1 and -3, the reference by +1 and +1: | 1 - 1 | and | 3 - 1 |.
        let f = flicker(&[0.0, 5.0], &[1.0, 2.0], &[0.0, 0.0], &[1.0, 1.0]);
        assert!((f - 1.0).abs() < 1e-12);
        // A constant offset from the reference does not flicker.
        assert_eq!(flicker(&[3.0], &[4.0], &[1.0], &[2.0]), 0.0);
        assert_eq!(relative(0.0, 0.0), 0.0);
        assert!(relative(1.0, 0.0).is_infinite());
    }
}
