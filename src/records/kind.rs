//! What a record of each kind stores and how it is splatted: the one place that says it
//! (issue 18). Both kinds share the [`super::Record`] (p, n, R and the irradiance fields
//! the reduction writes), placement, binning and the temporal machinery; a radiance record
//! adds a block of HSH coefficients in a buffer beside the records
//! ([`super::RecordCache::coefficients`]), one block per record at the same index.
//!
//! - [`RecordKind::Irradiance`]: E and its gradients, splatted on Lambertian lobes
//!   (`wgsl/splat_gather.wgsl`, thesis eq. 4.1).
//! - [`RecordKind::Radiance`]: incoming radiance in hemispherical harmonics of `order`
//!   (thesis chapter 3, algorithms.md 2.1), with the 2-D translational gradient of every
//!   coefficient, splatted on glossy lobes (`wgsl/radiance_gather.wgsl`: rotated into the
//!   pixel's frame, dotted with the lobe's coefficients).

use crate::hsh::coefficient_count;
use crate::hsh::rotation::RotationMethod;

/// The kind of a record cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum RecordKind {
    Irradiance,
    Radiance { order: u32 },
}

/// f32s of a radiance record's frame header: its plane's tangent and bitangent (the
/// turned frame its coefficients are in, `record_frame` in `wgsl/shared/records.wgsl`),
/// each padded to a vec4.
pub const FRAME_FLOATS: usize = 8;

impl RecordKind {
    /// f32s per record in the coefficient buffer: the frame, then per channel `order^2`
    /// coefficients, then their gradients along the frame's x and y axes (channel-major:
    /// values r, g, b; x-gradients r, g, b; y-gradients r, g, b). The thesis's 900 values
    /// at order 10 plus the frame; 0 for irradiance records.
    pub fn coefficient_floats(self) -> usize {
        match self {
            RecordKind::Irradiance => 0,
            RecordKind::Radiance { order } => FRAME_FLOATS + 9 * coefficient_count(order),
        }
    }

    /// Bytes per record in the coefficient buffer.
    pub fn coefficient_bytes(self) -> u64 {
        self.coefficient_floats() as u64 * 4
    }

    /// What the kind is called in messages.
    pub fn describe(self) -> String {
        match self {
            RecordKind::Irradiance => "irradiance records".into(),
            RecordKind::Radiance { order } => format!("radiance records of HSH order {order}"),
        }
    }
}

/// What the radiance cache is set to (`CacheSettings::radiance`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RadianceSettings {
    /// HSH order n (n^2 coefficients per channel); 0 turns radiance records off (every
    /// glossy lobe by Monte Carlo).
    pub order: u32,
    /// The radiance records' own accuracy a (thesis: 0.25 on the Cornell box).
    pub accuracy: f32,
    /// Lobes whose projection at `order` holds less of their energy (eq. 3.32) are shaded
    /// by Monte Carlo.
    pub min_lobe_accuracy: f32,
    /// Each lobe is evaluated with the fewest bands (up to `order`) whose projection holds
    /// this share of its energy (eq. 3.32; `hsh::brdf_projection::LobeTable::truncated`);
    /// 1 keeps every band. The default, 0.995, is what the thesis's 100 coefficients hold
    /// of its Phong-20 lobe.
    pub lobe_share: f32,
    /// How record frames are tilted into pixels' frames.
    pub rotation: RotationMethod,
    /// Plane resolution P of radiance records; 0 (the default): from the sharpest lobe
    /// they shade ([`RadianceSettings::plane_resolution_for`]).
    pub plane_resolution: u32,
}

impl Default for RadianceSettings {
    fn default() -> Self {
        Self {
            order: 8,
            accuracy: 0.25,
            min_lobe_accuracy: 0.9,
            lobe_share: 0.995,
            rotation: RotationMethod::Tabulated,
            plane_resolution: 0,
        }
    }
}

impl RadianceSettings {
    /// The record kind these settings cache.
    pub fn kind(&self) -> RecordKind {
        RecordKind::Radiance { order: self.order }
    }

    /// The largest tilt between a record's normal and a pixel's that Ward's weight admits
    /// at this accuracy: `sqrt(1 - n.n_k) <= a`.
    pub fn beta_max(&self) -> f64 {
        let a = f64::from(self.accuracy);
        (1.0 - a * a).clamp(-1.0, 1.0).acos().max(1e-3)
    }
}

impl RadianceSettings {
    /// The plane resolution of radiance records serving lobes up to Phong exponent
    /// `sharpest`, beside irradiance records' `irradiance_resolution`: the setting when
    /// given, else `P_irr sqrt(n / 5)` rounded to a multiple of 8, between `P_irr` and
    /// `2 P_irr`. A Phong-n lobe is about `1 / sqrt(n)` radians wide (`cos^n(x) ~
    /// exp(-n x^2 / 2)`), so the plane's pixels shrink with it to resolve it as well;
    /// irradiance records' P serves the cosine lobe and lobes as broad (n <= 5). Measured
    /// (docs/results.md): the glossy Cornell box (Phong 20) at 1000x1000 has 2.39 % error
    /// above the reference's noise with P = 48 against 2.75 % with 24, for 1 s of 15; on
    /// Sponza, whose one lobe is Phong 1, P = 48 would cost 2.5 s of 22 for nothing.
    pub fn plane_resolution_for(&self, irradiance_resolution: u32, sharpest: f32) -> u32 {
        if self.plane_resolution > 0 {
            return self.plane_resolution;
        }
        let p = f64::from(irradiance_resolution);
        let scaled = p * (f64::from(sharpest.max(0.0)) / 5.0).sqrt();
        let rounded = ((scaled / 8.0).round() * 8.0) as u32;
        rounded.clamp(irradiance_resolution, 2 * irradiance_resolution)
    }
}
