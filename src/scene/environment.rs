//! Environment maps (issue 18): an HDR latitude-longitude image of the radiance arriving
//! from every direction that leaves the scene, rotated about the up axis (+y), sampled by
//! importance for direct light (a piecewise-constant density over its texels, weighted by
//! their brightness and solid angle: the classic marginal/conditional tables).
//!
//! Directions: in the map's frame (the world turned by `-rotation` about +y),
//! `theta = acos(y)` from the zenith (row 0 is the top), `phi = atan2(x, -z)` in [0, 2 pi)
//! (column 0 looks along -z, columns run towards +x). Lookups take the nearest texel (no
//! filtering): the GPU reads the same numbers (`wgsl/shared/environment.wgsl`).

use crate::{Error, Result};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::path::Path;

/// Largest map side accepted (texels).
pub const MAX_ENVIRONMENT_SIDE: u32 = 4096;

/// A loaded environment map with its sampling tables.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance, row-major from the top row, already times the scene file's
    /// `radiance` (a tint / exposure).
    pub texels: Vec<Vec3>,
    /// Rotation about +y, radians.
    pub rotation: f32,
    /// Marginal CDF over rows (`height + 1` values, 0 to 1).
    pub row_cdf: Vec<f32>,
    /// Conditional CDF over the columns of each row (`height` runs of `width + 1`).
    pub column_cdf: Vec<f32>,
}

/// The sampling weight of a texel: its channel sum (as the GPU sums) times sin(theta) at
/// its row's centre (its solid angle). Black texels are never drawn: they add nothing.
fn texel_weight(c: Vec3, sin_theta: f32) -> f32 {
    ((c.x + c.y) + c.z) * sin_theta
}

impl EnvironmentMap {
    /// A map from texels (row-major, top row first), `scale` multiplying every texel.
    pub fn new(
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
        scale: Vec3,
        rotation_degrees: f32,
    ) -> Self {
        let texels: Vec<Vec3> = texels.into_iter().map(|c| c * scale).collect();
        let (w, h) = (width as usize, height as usize);
        let mut row_weights = Vec::with_capacity(h);
        let mut column_cdf = Vec::with_capacity(h * (w + 1));
        for j in 0..h {
            let sin_theta = (PI * (j as f32 + 0.5) / h as f32).sin();
            let row = &texels[j * w..(j + 1) * w];
            let weights: Vec<f32> = row.iter().map(|&c| texel_weight(c, sin_theta)).collect();
            let total: f32 = weights.iter().sum();
            row_weights.push(total);
            column_cdf.extend(cdf(&weights, total));
        }
        let total: f32 = row_weights.iter().sum();
        let row_cdf = cdf(&row_weights, total);
        Self {
            width,
            height,
            texels,
            rotation: rotation_degrees.to_radians(),
            row_cdf,
            column_cdf,
        }
    }

    /// Loads a Radiance `.hdr` (RGBE) or OpenEXR file (its R, G, B channels).
    pub fn load(path: &Path, scale: Vec3, rotation_degrees: f32) -> Result<Self> {
        crate::input::check_file(path, crate::input::MAX_DATA_BYTES)?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let (width, height, texels) = match ext.as_deref() {
            Some("exr") => load_exr(path)?,
            Some("hdr") | Some("pic") => load_hdr(path)?,
            _ => {
                return Err(Error::invalid(
                    path,
                    "environment.map",
                    "environment maps are Radiance .hdr or OpenEXR .exr files",
                ));
            }
        };
        if width == 0
            || height == 0
            || width > MAX_ENVIRONMENT_SIDE
            || height > MAX_ENVIRONMENT_SIDE
        {
            return Err(Error::invalid(
                path,
                "environment.map",
                format!("{width}x{height} texels: each side must be in 1..={MAX_ENVIRONMENT_SIDE}"),
            ));
        }
        if let Some((k, c)) = texels
            .iter()
            .enumerate()
            .find(|(_, c)| !c.is_finite() || c.min_element() < 0.0)
        {
            return Err(Error::invalid(
                path,
                format!("texel ({}, {})", k as u32 % width, k as u32 / width),
                format!("radiance must be finite and >= 0, got {c}"),
            ));
        }
        // Scaled, as every other light value, at most MAX_LIGHT_VALUE (the products the
        // renderer forms from it stay finite).
        let max = super::limits::MAX_LIGHT_VALUE;
        if let Some((k, c)) = texels.iter().enumerate().find(|(_, c)| {
            let scaled = (**c * scale).max_element();
            !scaled.is_finite() || scaled > max
        }) {
            return Err(Error::invalid(
                path,
                format!("texel ({}, {})", k as u32 % width, k as u32 / width),
                format!(
                    "radiance {c} times `[environment].radiance` {scale} exceeds \
                     {max:e}, the most any light value may be"
                ),
            ));
        }
        Ok(Self::new(width, height, texels, scale, rotation_degrees))
    }

    /// The direction in the map's frame of world direction `d`.
    fn to_map(&self, d: Vec3) -> Vec3 {
        let (s, c) = (-self.rotation).sin_cos();
        Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
    }

    /// The world direction of map-frame direction `m`.
    fn to_world(&self, m: Vec3) -> Vec3 {
        let (s, c) = self.rotation.sin_cos();
        Vec3::new(c * m.x + s * m.z, m.y, -s * m.x + c * m.z)
    }

    /// The texel of a world direction.
    fn texel_of(&self, d: Vec3) -> (u32, u32) {
        let m = self.to_map(d);
        let theta = m.y.clamp(-1.0, 1.0).acos();
        let mut phi = m.x.atan2(-m.z);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let i = ((phi / (2.0 * PI) * self.width as f32) as u32).min(self.width - 1);
        let j = ((theta / PI * self.height as f32) as u32).min(self.height - 1);
        (i, j)
    }

    /// Radiance arriving from world direction `d` (unit).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        let (i, j) = self.texel_of(d);
        self.texels[(j * self.width + i) as usize]
    }

    /// The direction drawn for `u` in [0, 1)^2 and its density per solid angle; None where
    /// the map is black everywhere.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let (j, fy) = invert(&self.row_cdf, u.x)?;
        let w = self.width as usize;
        let row = &self.column_cdf[j * (w + 1)..(j + 1) * (w + 1)];
        let (i, fx) = invert(row, u.y)?;
        let (x, y) = (
            (i as f32 + fx) / self.width as f32,
            (j as f32 + fy) / self.height as f32,
        );
        let theta = PI * y;
        let phi = 2.0 * PI * x;
        let st = theta.sin();
        let m = Vec3::new(st * phi.sin(), theta.cos(), -st * phi.cos());
        let d = self.to_world(m);
        let pdf = self.pdf_texel(i as u32, j as u32, st);
        Some((d, pdf))
    }

    /// The sampling density per solid angle at world direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let (i, j) = self.texel_of(d);
        let m = self.to_map(d);
        let st = (1.0 - m.y * m.y).max(0.0).sqrt();
        self.pdf_texel(i, j, st)
    }

    /// Density per solid angle of a direction in texel (i, j) at sin(theta) `st`: the
    /// texel's probability times `width height` (per unit of map area) over the map's
    /// Jacobian `2 pi^2 sin(theta)`.
    fn pdf_texel(&self, i: u32, j: u32, st: f32) -> f32 {
        let w = self.width as usize;
        let (i, j) = (i as usize, j as usize);
        let p_row = self.row_cdf[j + 1] - self.row_cdf[j];
        let row = &self.column_cdf[j * (w + 1)..(j + 1) * (w + 1)];
        let p_col = row[i + 1] - row[i];
        if st <= 0.0 {
            return 0.0;
        }
        p_row * p_col * (self.width * self.height) as f32 / (2.0 * PI * PI * st)
    }
}

/// The CDF of `weights` (summing to `total`), `len + 1` values from 0 to 1; a uniform one
/// when every weight is zero.
fn cdf(weights: &[f32], total: f32) -> Vec<f32> {
    let n = weights.len();
    let mut out = Vec::with_capacity(n + 1);
    out.push(0.0);
    let mut acc = 0.0f32;
    for (k, w) in weights.iter().enumerate() {
        acc += if total > 0.0 {
            w / total
        } else {
            1.0 / n as f32
        };
        out.push(if k + 1 == n { 1.0 } else { acc.min(1.0) });
    }
    out
}

/// The interval `k` with `cdf[k] <= u < cdf[k + 1]` (binary search, skipping empty
/// intervals) and where `u` falls inside it, in [0, 1).
fn invert(cdf: &[f32], u: f32) -> Option<(usize, f32)> {
    let n = cdf.len() - 1;
    if n == 0 {
        return None;
    }
    // The last k with cdf[k] <= u.
    let (mut lo, mut hi) = (0usize, n);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if cdf[mid] <= u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let width = cdf[lo + 1] - cdf[lo];
    if width <= 0.0 {
        return None;
    }
    Some((lo, ((u - cdf[lo]) / width).clamp(0.0, 0.999_999)))
}

fn load_hdr(path: &Path) -> Result<(u32, u32, Vec<Vec3>)> {
    let img = image::ImageReader::open(path)
        .map_err(|e| Error::io(path, e))?
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))?
        .decode()
        .map_err(|e| Error::invalid(path, "environment.map", format!("cannot decode: {e}")))?
        .into_rgb32f();
    let (w, h) = img.dimensions();
    let texels = img.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
    Ok((w, h, texels))
}

fn load_exr(path: &Path) -> Result<(u32, u32, Vec<Vec3>)> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            (
                resolution.width(),
                vec![Vec3::ZERO; resolution.width() * resolution.height()],
            )
        },
        |(width, texels), position, (r, g, b, _a): (f32, f32, f32, f32)| {
            texels[position.y() * *width + position.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| crate::Error::invalid(path, "environment.map", format!("cannot read EXR: {e}")))?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    Ok((size.width() as u32, size.height() as u32, texels))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{hash_combine, hash_u32, u32_to_unit};

    fn unit(k: u32) -> Vec2 {
        let h = hash_u32(k);
        Vec2::new(u32_to_unit(h), u32_to_unit(hash_combine(h, 1)))
    }

    /// A small map: a dim sky, a bright spot, a black ground.
    fn map(rotation: f32) -> EnvironmentMap {
        let (w, h) = (32u32, 16u32);
        let mut t = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let c = if j >= h / 2 {
                    Vec3::ZERO
                } else if (i, j) == (5, 3) {
                    Vec3::new(400.0, 300.0, 200.0)
                } else {
                    Vec3::new(0.2, 0.3, 0.6)
                };
                t.push(c);
            }
        }
        EnvironmentMap::new(w, h, t, Vec3::ONE, rotation)
    }

    #[test]
    fn the_density_integrates_to_one_and_matches_the_samples() {
        let m = map(30.0);
        // int pdf dw over the sphere, by the midpoint rule on a grid 8x finer than the
        // map in (theta, phi): pdf sin(theta) is constant over a texel, so this is exact
        // up to rounding (the rotation only shifts which texel a grid cell falls in).
        let (nt, np) = (16 * 8, 32 * 8);
        let mut sum = 0.0f64;
        for a in 0..nt {
            let theta = PI * (a as f32 + 0.5) / nt as f32;
            for b in 0..np {
                let phi = 2.0 * PI * (b as f32 + 0.5) / np as f32;
                let d = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                sum += f64::from(m.pdf(d) * theta.sin())
                    * (std::f64::consts::PI / nt as f64)
                    * (2.0 * std::f64::consts::PI / np as f64);
            }
        }
        assert!((sum - 1.0).abs() < 0.01, "int pdf = {sum}");
        // Importance sampling estimates the map's integral int L dw with small variance,
        // and the pdf a sample reports is the pdf of its direction.
        let mut est = 0.0f64;
        let mut off = 0;
        for k in 0..20_000 {
            let (d, pdf) = m.sample(unit(k)).expect("sample");
            // A sample on a texel edge may be looked up in the neighbouring texel.
            off += usize::from((m.pdf(d) - pdf).abs() > 1e-3 * pdf.max(1.0));
            assert!(d.y >= -1e-5, "the black ground is never drawn: {d}");
            est += f64::from(m.radiance(d).x / pdf);
        }
        let est = est / 20_000.0;
        assert!(
            off < 100,
            "{off} of 20000 samples report another pdf than their direction's"
        );
        // Uniform sampling, for comparison (it rarely finds the bright texel).
        let mut uniform = 0.0f64;
        for k in 0..200_000 {
            let u = unit(k + 1_000_000);
            let z = 1.0 - 2.0 * u.x;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * u.y;
            let d = Vec3::new(r * phi.cos(), z, r * phi.sin());
            uniform += f64::from(m.radiance(d).x) * 4.0 * std::f64::consts::PI;
        }
        let uniform = uniform / 200_000.0;
        // The exact integral: sky texels times their solid angles plus the spot's.
        let (w, h) = (32.0f64, 16.0f64);
        let mut exact = 0.0;
        for j in 0..8 {
            let t0 = std::f64::consts::PI * j as f64 / h;
            let t1 = std::f64::consts::PI * (j + 1) as f64 / h;
            let omega = 2.0 * std::f64::consts::PI / w * (t0.cos() - t1.cos());
            exact += omega * (0.2 * 31.0 + if j == 3 { 400.0 } else { 0.2 });
        }
        assert!(
            (est - exact).abs() < 0.01 * exact,
            "importance {est} vs exact {exact}"
        );
        assert!(
            (uniform - exact).abs() < 0.2 * exact,
            "uniform {uniform} vs exact {exact}"
        );
    }

    #[test]
    fn rotation_turns_the_map_about_the_up_axis() {
        let a = map(0.0);
        let b = map(90.0);
        for k in 0..200 {
            let u = unit(k);
            let z = 1.0 - 2.0 * u.x;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * u.y;
            let d = Vec3::new(r * phi.cos(), z, r * phi.sin());
            // b sees in d what a sees in d turned back by 90 degrees.
            let back = Vec3::new(-d.z, d.y, d.x);
            let turned = glam::Quat::from_rotation_y(-90f32.to_radians()) * d;
            assert!((back - turned).length() < 1e-5);
            assert_eq!(b.radiance(d), a.radiance(turned));
        }
    }
}
