//! The hemisphere sampling plane (thesis section 4.4, algorithms.md section 3.2): `P x P`
//! pixels on the plane z = 1 above a record in its tangent frame, half-extent
//! `s = tan(fov / 2)`. With border stretching (the default, decision 6) the outer edge of
//! every border pixel is moved to infinity, so the pixels partition the open hemisphere
//! exactly and their cosine weights sum to pi, their solid angles to 2 pi.
//!
//! Every weight is an exact rectangle integral computed here in f64 once per
//! (resolution, field of view, mode) and uploaded as a table ([`PlanePixel`]); the GPU
//! reduction and its CPU mirror read the same f32 table.

use bytemuck::{Pod, Zeroable};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

/// How the plane's finite extent is compensated (thesis Table 4.1 compares the three).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PlaneMode {
    /// Border pixels stretched to infinity (Gautron; the default).
    Stretched,
    /// Plain plane, irradiance divided by its cosine-weighted coverage (\[LC04\]).
    CoverageRatio,
    /// Plain plane, no compensation: grazing directions are lost.
    Plain,
}

/// How the plane's pixel edges are spaced along each axis.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum PlaneSpacing {
    /// Evenly on the plane (the thesis's rasterised plane): a pixel at angle theta from the
    /// normal carries cos^4 theta of the central pixel's cosine weight, so at a 150 degree
    /// field of view the 1,024 pixels of a 32 x 32 plane are worth about 155 equally
    /// weighted ones (`(sum w)^2 / sum w^2`).
    Uniform,
    /// Evenly in `sin(atan x)` (the default): the marginal cosine-weighted density of the
    /// plane coordinate x is `(1 + x^2)^(-3/2) / 2`, whose integral is `sin(atan x) / 2`, so
    /// every column (and row) of pixels carries the same share of the cosine-weighted
    /// hemisphere, as in Ward and Heckbert's stratified hemisphere. The weights still vary
    /// (between about 0.26 and 4 times the central pixel's at 150 degrees, their product is
    /// not separable), but a 32 x 32 plane is worth about 950 equally weighted pixels: the
    /// same rays give a record about a sixth of the variance.
    Cosine,
}

impl PlaneSpacing {
    /// The plane coordinate at fraction `t` in [0, 1] of an axis of half-extent `s`.
    pub fn at(self, s: f64, t: f64) -> f64 {
        match self {
            PlaneSpacing::Uniform => -s + 2.0 * s * t,
            PlaneSpacing::Cosine => {
                let u = s / (1.0 + s * s).sqrt() * (2.0 * t - 1.0);
                u / (1.0 - u * u).sqrt()
            }
        }
    }

    /// The half-extent of an axis of half-extent `s` (plane coordinate) in the coordinate
    /// its pixel edges are even in: `s` itself for [`PlaneSpacing::Uniform`],
    /// `sin(atan s)` for [`PlaneSpacing::Cosine`].
    pub fn even_half_extent(self, s: f64) -> f64 {
        match self {
            PlaneSpacing::Uniform => s,
            PlaneSpacing::Cosine => s / (1.0 + s * s).sqrt(),
        }
    }

    /// The inverse of [`Self::at`]: the fraction of an axis of half-extent `s` at plane
    /// coordinate `x` (outside [0, 1] off the unstretched plane). Temporal reprojection bins
    /// moved plane hits into the estimated plane's cells by it (`plane_reproject.wgsl`).
    pub fn fraction(self, s: f64, x: f64) -> f64 {
        let u = match self {
            PlaneSpacing::Uniform => x,
            PlaneSpacing::Cosine => x / (1.0 + x * x).sqrt(),
        };
        (u / self.even_half_extent(s) + 1.0) * 0.5
    }
}

/// Per-pixel weights of the plane (Rust mirror of WGSL `PlanePixel`, 32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct PlanePixel {
    /// Cosine-weighted solid angle of the pixel: `E = sum L * cos_weight`.
    pub cos_weight: f32,
    /// Solid angle of the pixel (the stretched plane's sum to 2 pi).
    pub solid_angle: f32,
    /// Weight of the edge to the right neighbour (x + 1) in the translational gradient:
    /// the integral of `1 / (1 + x_b^2 + y^2)^2` along the edge (algorithms.md 3.3); 0 on
    /// the last column.
    pub edge_x: f32,
    /// Same for the edge to the neighbour above (y + 1); 0 on the last row.
    pub edge_y: f32,
    /// Rotational gradient weight: the integral of `n x w` over the pixel in the tangent
    /// frame, i.e. `(-int w_y dw, int w_x dw)` (the continuous form of algorithms.md 1.5).
    pub rotation: [f32; 2],
    /// Plane coordinates of the pixel centre: the sample's ray goes through (x, y, 1).
    pub center: [f32; 2],
}

/// One sub-sample of adaptive plane refinement (mirror of WGSL `RefineSample`, 16 bytes):
/// see [`HemispherePlane::refine_samples`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RefineSample {
    /// Plane coordinates the sub-sample's ray goes through, (x, y, 1).
    pub center: [f32; 2],
    /// Its weight in the refined pixel's radiance (the centre ray weighs
    /// `1 / (1 + split^2)`; the weights of a pixel's sub-samples sum to the rest).
    pub weight: f32,
    pub _pad: f32,
}

/// The sampling plane's pixel table.
#[derive(Clone, Debug)]
pub struct HemispherePlane {
    pub resolution: u32,
    pub fov_degrees: f32,
    pub mode: PlaneMode,
    pub spacing: PlaneSpacing,
    /// `resolution^2` pixels, row-major, row j at y = `spacing.at(s, (j + 1/2) / resolution)`.
    pub pixels: Vec<PlanePixel>,
}

/// Cosine-weighted integral over [0,x] x [0,y] of the plane (algorithms.md 3.2, `G`), with
/// x or y infinite.
fn cos_integral(x: f64, y: f64) -> f64 {
    match (x.is_infinite(), y.is_infinite()) {
        (true, true) => x.signum() * y.signum() * FRAC_PI_4,
        (true, false) => x.signum() * FRAC_PI_4 * y / (1.0 + y * y).sqrt(),
        (false, true) => y.signum() * FRAC_PI_4 * x / (1.0 + x * x).sqrt(),
        (false, false) => {
            let cx = (1.0 + x * x).sqrt();
            let cy = (1.0 + y * y).sqrt();
            0.5 * (x / cx * (y / cx).atan() + y / cy * (x / cy).atan())
        }
    }
}

/// Solid angle of the plane rectangle \[x0,x1\] x \[y0,y1\] (edges may be infinite).
pub fn rect_solid_angle(x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    rect(solid_angle_integral, x0, x1, y0, y1)
}

/// Solid angle of [0,x] x [0,y] (algorithms.md 3.2, `S`).
fn solid_angle_integral(x: f64, y: f64) -> f64 {
    match (x.is_infinite(), y.is_infinite()) {
        (true, true) => x.signum() * y.signum() * FRAC_PI_2,
        (true, false) => x.signum() * y.atan(),
        (false, true) => y.signum() * x.atan(),
        (false, false) => (x * y / (1.0 + x * x + y * y).sqrt()).atan(),
    }
}

/// Antiderivative `F(x, y)` with `d2F/dxdy = x / (1 + x^2 + y^2)^2`, i.e. of `w_x dw` on the
/// plane: `F = -atan(y / sqrt(1 + x^2)) / (2 sqrt(1 + x^2))` (derived here; checked by the
/// tests against quadrature).
fn wx_integral(x: f64, y: f64) -> f64 {
    if x.is_infinite() {
        return 0.0;
    }
    let c = (1.0 + x * x).sqrt();
    let a = if y.is_infinite() {
        y.signum() * FRAC_PI_2
    } else {
        (y / c).atan()
    };
    -a / (2.0 * c)
}

/// Integral of `1 / (c2 + y^2)^2` from 0 to y, `c2 = 1 + x_b^2`.
fn edge_integral(c2: f64, y: f64) -> f64 {
    let c = c2.sqrt();
    if y.is_infinite() {
        return y.signum() * FRAC_PI_2 / (2.0 * c2 * c);
    }
    y / (2.0 * c2 * (c2 + y * y)) + (y / c).atan() / (2.0 * c2 * c)
}

/// Integral of `f` over the rectangle [x0,x1] x [y0,y1] from its corner antiderivative.
fn rect(f: impl Fn(f64, f64) -> f64, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)
}

impl HemispherePlane {
    /// Builds the table for a `resolution x resolution` plane with the given full field of
    /// view (degrees, in (0, 180)) and pixel spacing.
    pub fn new(resolution: u32, fov_degrees: f32, mode: PlaneMode, spacing: PlaneSpacing) -> Self {
        let p = resolution as usize;
        let s = (f64::from(fov_degrees).to_radians() * 0.5).tan();
        let at = |t: f64| spacing.at(s, t);
        // Pixel edges; the outer ones go to infinity when stretched.
        let mut edges: Vec<f64> = (0..=p).map(|i| at(i as f64 / p as f64)).collect();
        if mode == PlaneMode::Stretched {
            edges[0] = f64::NEG_INFINITY;
            edges[p] = f64::INFINITY;
        }
        let plain_coverage = rect(cos_integral, -s, s, -s, s) / std::f64::consts::PI;
        let scale = if mode == PlaneMode::CoverageRatio {
            1.0 / plain_coverage
        } else {
            1.0
        };
        let mut pixels = Vec::with_capacity(p * p);
        for j in 0..p {
            let (y0, y1) = (edges[j], edges[j + 1]);
            for i in 0..p {
                let (x0, x1) = (edges[i], edges[i + 1]);
                let cos_weight = rect(cos_integral, x0, x1, y0, y1) * scale;
                let solid_angle = rect(solid_angle_integral, x0, x1, y0, y1) * scale;
                let wx = rect(wx_integral, x0, x1, y0, y1);
                let wy = rect(|x, y| wx_integral(y, x), x0, x1, y0, y1);
                let edge_x = if i + 1 < p {
                    let c2 = 1.0 + x1 * x1;
                    (edge_integral(c2, y1) - edge_integral(c2, y0)) * scale
                } else {
                    0.0
                };
                let edge_y = if j + 1 < p {
                    let c2 = 1.0 + y1 * y1;
                    (edge_integral(c2, x1) - edge_integral(c2, x0)) * scale
                } else {
                    0.0
                };
                pixels.push(PlanePixel {
                    cos_weight: cos_weight as f32,
                    solid_angle: solid_angle as f32,
                    edge_x: edge_x as f32,
                    edge_y: edge_y as f32,
                    rotation: [(-wy * scale) as f32, (wx * scale) as f32],
                    center: [
                        at((i as f64 + 0.5) / p as f64) as f32,
                        at((j as f64 + 0.5) / p as f64) as f32,
                    ],
                });
            }
        }
        Self {
            resolution,
            fov_degrees,
            mode,
            spacing,
            pixels,
        }
    }

    /// The sub-samples of adaptive refinement ([`RefineSample`]): `split x split` strata
    /// per pixel, `split^2` entries per pixel in pixel order, strata row-major. A finite
    /// pixel edge-interval is split evenly in the plane's spacing; an interval stretched to infinity
    /// (border pixels, [`PlaneMode::Stretched`]) is split evenly in angle, from the finite
    /// edge's angle to the horizon, so the sub-samples reach the grazing band the
    /// stretched pixel stands for. Each stratum's weight is its share of the pixel's
    /// cosine-weighted solid angle times `split^2 / (1 + split^2)`: the refined pixel is
    /// `L_centre / (1 + split^2) + sum weight_i L_i`, the mean of the centre ray and the
    /// stratified estimate, weighted by their ray counts. Computed in f64, stored in f32:
    /// the GPU and the CPU reference read the same numbers.
    pub fn refine_samples(&self, split: u32) -> Vec<RefineSample> {
        let p = self.resolution as usize;
        let m = split.max(1) as usize;
        let axes: Vec<_> = (0..p).map(|i| self.sub_intervals(i, m)).collect();
        let share = (m * m) as f64 / (1.0 + (m * m) as f64);
        let mut out = Vec::with_capacity(p * p * m * m);
        for (ye, yc) in &axes {
            for (xe, xc) in &axes {
                let cell = rect(cos_integral, xe[0], xe[m], ye[0], ye[m]);
                for qy in 0..m {
                    for qx in 0..m {
                        let w = rect(cos_integral, xe[qx], xe[qx + 1], ye[qy], ye[qy + 1]);
                        out.push(RefineSample {
                            center: [xc[qx] as f32, yc[qy] as f32],
                            weight: (share * w / cell) as f32,
                            _pad: 0.0,
                        });
                    }
                }
            }
        }
        out
    }

    /// The edges (`m + 1`) and centres (`m`) of `m` sub-intervals of pixel interval `i`
    /// along one axis, in plane coordinates: a finite interval split evenly in the plane's
    /// spacing, an interval stretched to infinity (the border of [`PlaneMode::Stretched`])
    /// split evenly in angle, its outer edge infinite.
    pub fn sub_intervals(&self, i: usize, m: usize) -> (Vec<f64>, Vec<f64>) {
        let p = self.resolution as usize;
        let s = (f64::from(self.fov_degrees).to_radians() * 0.5).tan();
        let spacing = self.spacing;
        let stretched = self.mode == PlaneMode::Stretched;
        {
            let edge = |t: f64| spacing.at(s, (i as f64 + t) / p as f64);
            let (lo, hi) = (edge(0.0), edge(1.0));
            let to_lo = stretched && i == 0;
            let to_hi = stretched && i + 1 == p;
            let at = |t: f64| -> f64 {
                match (to_lo, to_hi) {
                    // Both edges infinite (a 1 x 1 plane): the whole angle range.
                    (true, true) => (-FRAC_PI_2 + t * std::f64::consts::PI).tan(),
                    (false, true) => {
                        let a = lo.atan();
                        (a + t * (FRAC_PI_2 - a)).tan()
                    }
                    (true, false) => {
                        let a = hi.atan();
                        (a - (1.0 - t) * (a + FRAC_PI_2)).tan()
                    }
                    (false, false) => edge(t),
                }
            };
            let mut edges: Vec<f64> = (0..=m).map(|q| at(q as f64 / m as f64)).collect();
            if to_lo {
                edges[0] = f64::NEG_INFINITY;
            }
            if to_hi {
                edges[m] = f64::INFINITY;
            }
            let centres = (0..m).map(|q| at((q as f64 + 0.5) / m as f64)).collect();
            (edges, centres)
        }
    }

    /// Fraction of the cosine-weighted hemisphere the unstretched plane covers
    /// (algorithms.md 3.2 table: 0.787 at 120 degrees).
    pub fn plain_coverage(fov_degrees: f32) -> f64 {
        let s = (f64::from(fov_degrees).to_radians() * 0.5).tan();
        rect(cos_integral, -s, s, -s, s) / std::f64::consts::PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn sums(p: &HemispherePlane) -> (f64, f64) {
        p.pixels.iter().fold((0.0, 0.0), |(c, s), px| {
            (c + f64::from(px.cos_weight), s + f64::from(px.solid_angle))
        })
    }

    #[test]
    fn stretched_weights_partition_the_hemisphere() {
        for spacing in [PlaneSpacing::Uniform, PlaneSpacing::Cosine] {
            for resolution in [4, 16, 64, 128] {
                for fov in [60.0, 90.0, 120.0, 150.0, 170.0] {
                    let plane =
                        HemispherePlane::new(resolution, fov, PlaneMode::Stretched, spacing);
                    let (c, s) = sums(&plane);
                    assert!((c - PI).abs() < 1e-4, "{resolution} {fov}: cos sum {c}");
                    assert!(
                        (s - 2.0 * PI).abs() < 1e-4,
                        "{resolution} {fov}: sa sum {s}"
                    );
                    assert!(plane.pixels.iter().all(|p| p.cos_weight > 0.0));
                }
            }
        }
    }

    #[test]
    fn coverage_matches_the_digest_table() {
        for (fov, f) in [(90.0, 0.554), (120.0, 0.787), (150.0, 0.945)] {
            assert!((HemispherePlane::plain_coverage(fov) - f).abs() < 1e-3);
            for spacing in [PlaneSpacing::Uniform, PlaneSpacing::Cosine] {
                let plain = HemispherePlane::new(32, fov, PlaneMode::Plain, spacing);
                assert!((sums(&plain).0 / PI - f).abs() < 1e-3);
                let ratio = HemispherePlane::new(32, fov, PlaneMode::CoverageRatio, spacing);
                assert!((sums(&ratio).0 - PI).abs() < 1e-4);
            }
        }
    }

    /// Midpoint quadrature of a function of the plane coordinates over a finite rectangle.
    fn quad(f: impl Fn(f64, f64) -> f64, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
        let n = 400;
        let (dx, dy) = ((x1 - x0) / n as f64, (y1 - y0) / n as f64);
        let mut sum = 0.0;
        for j in 0..n {
            for i in 0..n {
                sum += f(x0 + (i as f64 + 0.5) * dx, y0 + (j as f64 + 0.5) * dy);
            }
        }
        sum * dx * dy
    }

    #[test]
    fn closed_forms_match_quadrature() {
        // Solid angle density on the plane z = 1 is (1 + x^2 + y^2)^(-3/2); w = (x, y, 1) / norm.
        let (x0, x1, y0, y1) = (0.3, 0.9, -0.7, 0.2);
        let q = |g: &dyn Fn(f64, f64) -> f64| quad(g, x0, x1, y0, y1);
        let r2 = |x: f64, y: f64| 1.0 + x * x + y * y;
        let cos = q(&|x, y| r2(x, y).powi(-2));
        let sa = q(&|x, y| r2(x, y).powf(-1.5));
        let wx = q(&|x, y| x * r2(x, y).powi(-2));
        let wy = q(&|x, y| y * r2(x, y).powi(-2));
        assert!((rect(cos_integral, x0, x1, y0, y1) - cos).abs() < 1e-6);
        assert!((rect(solid_angle_integral, x0, x1, y0, y1) - sa).abs() < 1e-6);
        assert!((rect(wx_integral, x0, x1, y0, y1) - wx).abs() < 1e-6);
        assert!((rect(|x, y| wx_integral(y, x), x0, x1, y0, y1) - wy).abs() < 1e-6);
        let c2 = 1.0 + 0.4 * 0.4;
        let n = 10000;
        let e: f64 = (0..n)
            .map(|k| {
                let y = y0 + (k as f64 + 0.5) * (y1 - y0) / n as f64;
                (c2 + y * y).powi(-2) * (y1 - y0) / n as f64
            })
            .sum();
        assert!((edge_integral(c2, y1) - edge_integral(c2, y0) - e).abs() < 1e-8);
    }

    #[test]
    fn refine_samples_lie_in_their_pixels_and_their_weights_sum_to_the_rest() {
        for mode in [PlaneMode::Stretched, PlaneMode::Plain] {
            let plane = HemispherePlane::new(8, 130.0, mode, PlaneSpacing::Uniform);
            let s = (65.0f64).to_radians().tan() as f32;
            let delta = 2.0 * s / 8.0;
            let subs = plane.refine_samples(2);
            assert_eq!(subs.len(), 8 * 8 * 4);
            for (k, px) in plane.pixels.iter().enumerate() {
                let mine = &subs[4 * k..4 * k + 4];
                let w: f64 = mine.iter().map(|q| f64::from(q.weight)).sum();
                assert!((w - 0.8).abs() < 1e-5, "{mode:?} pixel {k}: weights {w}");
                for q in mine {
                    for a in 0..2 {
                        let (c, i) = (q.center[a], [k % 8, k / 8][a]);
                        let lo = -s + i as f32 * delta;
                        let inside = c >= lo - 1e-5 && c <= lo + delta + 1e-5;
                        let beyond = mode == PlaneMode::Stretched
                            && ((i == 0 && c < lo + delta) || (i == 7 && c > lo));
                        assert!(inside || beyond, "{mode:?} pixel {k}: {c} vs {px:?}");
                    }
                }
            }
            // Inner pixels: 2 x 2 at the quarter points, equal-ish weights.
            let k = 3 * 8 + 4;
            let c = plane.pixels[k].center;
            assert!((subs[4 * k].center[0] - (c[0] - delta / 4.0)).abs() < 1e-5);
            assert!((subs[4 * k + 3].center[1] - (c[1] + delta / 4.0)).abs() < 1e-5);
        }
        // A stretched corner's sub-samples go past the plane's edge toward the horizon.
        let plane = HemispherePlane::new(8, 130.0, PlaneMode::Stretched, PlaneSpacing::Uniform);
        let corner = plane.refine_samples(2)[4 * 63 + 3];
        assert!(corner.center[0] > plane.pixels[63].center[0] * 2.0);
    }

    #[test]
    fn rotation_weights_integrate_to_zero_and_are_antisymmetric() {
        // Over the whole hemisphere, int (n x w) dw = 0 by symmetry.
        let plane = HemispherePlane::new(16, 120.0, PlaneMode::Stretched, PlaneSpacing::Cosine);
        let (sx, sy) = plane.pixels.iter().fold((0.0f64, 0.0f64), |(a, b), p| {
            (a + f64::from(p.rotation[0]), b + f64::from(p.rotation[1]))
        });
        assert!(sx.abs() < 1e-5 && sy.abs() < 1e-5);
        // A pixel right of centre (x > 0) has n x w pointing along +y.
        let right = plane.pixels[8 * 16 + 12];
        assert!(right.rotation[1] > 0.0 && right.rotation[0].abs() < right.rotation[1]);
    }

    /// (sum w)^2 / sum w^2: how many equally weighted pixels the plane's pixels are worth.
    fn effective_pixels(p: &HemispherePlane) -> f64 {
        let (s, s2) = p.pixels.iter().fold((0.0, 0.0), |(a, b), px| {
            let w = f64::from(px.cos_weight);
            (a + w, b + w * w)
        });
        s * s / s2
    }

    #[test]
    fn fraction_inverts_the_spacing() {
        for spacing in [PlaneSpacing::Uniform, PlaneSpacing::Cosine] {
            for fov in [90.0f64, 130.0, 170.0] {
                let s = (fov.to_radians() * 0.5).tan();
                for k in 0..=20 {
                    let t = f64::from(k) / 20.0;
                    let back = spacing.fraction(s, spacing.at(s, t));
                    assert!((back - t).abs() < 1e-9, "{spacing:?} {fov}: {t} -> {back}");
                }
                // Past the plane's edge the fraction leaves [0, 1] (the stretched border).
                assert!(spacing.fraction(s, 2.0 * s) > 1.0);
                assert!(spacing.fraction(s, -2.0 * s) < 0.0);
            }
        }
    }

    #[test]
    fn cosine_spacing_gives_every_column_the_same_weight() {
        // Columns of an unstretched cosine-spaced plane: equal shares of the covered
        // cosine-weighted solid angle up to the rows' finite extent, within a few %;
        // the uniform plane's columns differ by an order of magnitude.
        let column_weights = |spacing| {
            let p = HemispherePlane::new(16, 150.0, PlaneMode::Plain, spacing);
            (0..16)
                .map(|i| {
                    (0..16)
                        .map(|j| f64::from(p.pixels[j * 16 + i].cos_weight))
                        .sum::<f64>()
                })
                .collect::<Vec<f64>>()
        };
        let spread = |w: Vec<f64>| {
            let max = w.iter().cloned().fold(f64::MIN, f64::max);
            let min = w.iter().cloned().fold(f64::MAX, f64::min);
            max / min
        };
        let cosine = spread(column_weights(PlaneSpacing::Cosine));
        let uniform = spread(column_weights(PlaneSpacing::Uniform));
        assert!(cosine < 1.6, "cosine-spaced columns spread {cosine}");
        assert!(uniform > 10.0, "uniform columns spread {uniform}");
        // The figures of PlaneSpacing's documentation (32 x 32 at 150 degrees).
        let worth =
            |spacing| effective_pixels(&HemispherePlane::new(32, 150.0, PlaneMode::Plain, spacing));
        let (u, c) = (worth(PlaneSpacing::Uniform), worth(PlaneSpacing::Cosine));
        assert!((140.0..170.0).contains(&u), "uniform worth {u}");
        assert!((900.0..1000.0).contains(&c), "cosine worth {c}");
        // Edges and centres: odd-symmetric, increasing, the outer edge at tan(fov / 2).
        let s = 75f64.to_radians().tan();
        assert!((PlaneSpacing::Cosine.at(s, 1.0) - s).abs() < 1e-9);
        assert!(PlaneSpacing::Cosine.at(s, 0.5).abs() < 1e-12);
        let p = HemispherePlane::new(8, 150.0, PlaneMode::Stretched, PlaneSpacing::Cosine);
        for i in 0..7 {
            assert!(p.pixels[i].center[0] < p.pixels[i + 1].center[0]);
            assert!((p.pixels[i].center[0] + p.pixels[7 - i].center[0]).abs() < 1e-6);
        }
    }

    #[test]
    fn cosine_spaced_refine_samples_lie_in_their_pixels() {
        let plane = HemispherePlane::new(8, 150.0, PlaneMode::Plain, PlaneSpacing::Cosine);
        let s = 75f64.to_radians().tan();
        let edge = |i: usize| PlaneSpacing::Cosine.at(s, i as f64 / 8.0) as f32;
        let subs = plane.refine_samples(2);
        for k in 0..64 {
            let w: f64 = subs[4 * k..4 * k + 4]
                .iter()
                .map(|q| f64::from(q.weight))
                .sum();
            assert!((w - 0.8).abs() < 1e-5, "pixel {k}: weights {w}");
            for q in &subs[4 * k..4 * k + 4] {
                for (a, i) in [(0, k % 8), (1, k / 8)] {
                    let c = q.center[a];
                    assert!(
                        c > edge(i) - 1e-5 && c < edge(i + 1) + 1e-5,
                        "pixel {k}: {c}"
                    );
                }
            }
        }
    }
}
