//! The irradiance cache's settings ([`CacheSettings`]: scene file `[cache]`, CLI flags),
//! their defaults, the rules derived from them and their checks.

use super::{Corral, HemispherePlane, PlaneMode, PlaneSpacing, RecordSource, kind, noise_widening};
use crate::light_maps::LightMapSettings;
use crate::{Error, Result};

/// The most Monte Carlo rays a glossy pixel traces through its lobe (`--glossy-samples`):
/// a dispatch each per chunk of them, so 2^32 filled the memory with commands.
pub const MAX_GLOSSY_SAMPLES: u32 = 1 << 16;

/// Settings of the irradiance cache (scene file `[cache]`, CLI flags).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CacheSettings {
    /// Ward's accuracy a: a record contributes where w >= 1/a.
    pub accuracy: f32,
    /// Plane resolution P (P x P rays per record).
    pub plane_resolution: u32,
    /// Plane field of view in degrees.
    pub plane_fov_degrees: f32,
    /// Plane border compensation.
    pub plane_mode: PlaneMode,
    /// How the plane's pixel edges are spaced ([`PlaneSpacing`]).
    pub plane_spacing: PlaneSpacing,
    /// Light samples per area light at each plane hit.
    pub plane_light_samples: u32,
    /// Lights sampled at each plane hit, chosen by what they give it unoccluded
    /// (systematic resampling, `shadow_loop_start_chosen`); 0, or at least the scene's
    /// light count: every light. Default 2: on the conference room's six panels the
    /// plane time falls by a third at the error of every light (docs/results.md).
    pub plane_light_choices: u32,
    /// R_min in pixels of validity radius: a R_min spans this many pixels at creation.
    /// Default [`Self::STILL_R_MIN_PIXELS`]; animations and the VPL and photon record
    /// sources were measured at [`Self::ANIMATION_R_MIN_PIXELS`].
    pub r_min_pixels: f32,
    /// A world-space lower bound on R_min as a fraction of the scene's bounding-box
    /// diagonal (like Radiance's `-ar`, whose minimum spacing is size x aa / ar): R_min is
    /// the larger of the two bounds. 0: the pixel bound alone.
    pub r_min_scene: f32,
    /// R_max / R_min (Ward: 64).
    pub r_max_factor: f32,
    /// What R (the distance that `accuracy` scales into a record's validity) measures.
    pub record_radius: RecordRadius,
    /// Neighbour clamping on insertion (Krivanek et al. 2006): a new record's R is at most
    /// R_j + |p - p_j| over the records placed before its batch. On by default (Cornell
    /// box 128x128: indirect error 2.03 % -> 1.72 % for 12 % more records; Sponza sun
    /// 1000x1000: 9.3 % -> 8.3 % for 55 % more). Past a few thousand earlier records the
    /// bound is searched in a grid ([`neighbour_grid`](mod@super::neighbour_grid)), the same bytes as a loop over
    /// every earlier record, whose cost grew with the square of the record count.
    pub neighbour_clamp: bool,
    /// The corral (after Radiance's ambcorral, [`Corral`]): where a record's
    /// [`Record::corral_allows`](super::Record::corral_allows) applies. Default [`Corral::Cover`].
    pub corral: Corral,
    /// Most records the cache may hold.
    pub record_budget: u32,
    /// Tail fill (`placement/mod.rs`): once at most this share of the visible pixels is
    /// left uncovered (and records are large on screen), new records cover at
    /// `tail_factor` times the accuracy, so that the sliver pixels around them are
    /// interpolated from the records reaching them there (only where none reaches them at
    /// the accuracy itself) instead of each getting a record. 0 turns it off. On Sponza sun
    /// at 1000x1000 the last 3.7 % of the pixels took 7,364 of 14,512 records.
    pub tail_share: f32,
    /// Tail fill's accuracy factor kappa: the tail is covered, and interpolated, at
    /// `kappa a` (Ward's error at most kappa a, weights `1 / err - 1 / (kappa a)`), at most
    /// [`Self::TAIL_MAX_ACCURACY`].
    pub tail_factor: f32,
    /// Records are interpolated (the frame's gather) at `interpolation_factor a`, wider
    /// than the accuracy a they are placed at: at least 1, so that every pixel placement
    /// covered is reached. Ward's weight `1 / err - 1 / a` falls to zero at the edge of a
    /// record's reach, so at 1 a pixel near that edge takes nearly all of its light from
    /// one record and each record's own plane noise shows as a disc; a wider interpolation
    /// averages more records there. Default [`Self::INTERPOLATION_FACTOR`]; still frames
    /// may widen it for noisy records ([`Self::noise_widening`]).
    pub interpolation_factor: f32,
    /// A still frame whose records' median relative noise exceeds `noise_widening a`
    /// interpolates wider than `interpolation_factor`, by the ratio, up to
    /// [`Self::MAX_INTERPOLATION_FACTOR`] (`noise_widening`), each pixel within
    /// [`Self::widening_tolerance`] of the gather at `interpolation_factor`; 0: never.
    /// Default [`Self::NOISE_WIDENING`].
    pub noise_widening: f32,
    /// Where a still frame is widened ([`Self::noise_widening`]), a pixel keeps the widened
    /// gather's irradiance only where it is within `widening_tolerance a` (relative, on the
    /// channel sum) of the gather at `interpolation_factor`, whose irradiance it takes
    /// elsewhere ([`noise_widening::WIDENING_TOLERANCE`], `wgsl/splat_consistency.wgsl`);
    /// infinite: the widened gather everywhere.
    pub widening_tolerance: f32,
    /// Store and use rotational and translational gradients.
    pub gradients: bool,
    /// How plane hits find their shadows: light-space maps traced once per prepared scene, or one
    /// shadow ray per sample (exact).
    pub plane_shadows: PlaneShadows,
    /// The maps' size (with [`PlaneShadows::Maps`] and [`PlaneShadows::Auto`]).
    pub light_maps: LightMapSettings,
    /// Adaptive plane refinement (Radiance's `-as`, Ward's "adaptive super-sampling" of
    /// high-variance strata, algorithms.md 1.7): the fraction of each record's plane
    /// pixels, those of highest contrast, that get `plane_refine_split^2` more rays
    /// ([`refine`](mod@super::refine); where fewer have contrast and the light maps see
    /// every lit surface, pixels near light take the rest, [`refine::select_pixels`](super::refine::select_pixels)). 0: none by contrast (dark planes still are, see
    /// [`Self::dark_plane_refine`]).
    pub plane_refine: f32,
    /// Sub-samples per axis of a refined pixel (`split x split` strata).
    pub plane_refine_split: u32,
    /// A plane that saw no light at all is refined everywhere (`split^2` more rays per
    /// pixel, [`refine::select_pixels`](super::refine::select_pixels)), whatever `plane_refine` says: P^2 centre rays
    /// miss bright patches of small solid angle, and a record that saw none is no evidence
    /// of darkness. On by default, for temporal caching's records too, whose planes are
    /// otherwise unrefined (a sunlit hall walked through had floors of exactly zero
    /// indirect light in every frame without it: docs/results.md, "Dark planes refined
    /// under temporal caching").
    pub dark_plane_refine: bool,
    /// A dark plane refines only the pixels whose rays can land near a lit surface, where
    /// the frame's light maps see every lit surface (every light mapped, no environment,
    /// no emitters of their own, one bounce: `LightMaps::see_every_lit_surface`); the
    /// light maps' lit grid says where those surfaces are (`light_maps::lit_grid`,
    /// [`refine::guided_pixels`](super::refine::guided_pixels)). Elsewhere, and with this off, a dark plane is refined
    /// everywhere. On by default (docs/results.md, "Dark planes refined near light").
    pub dark_plane_guide: bool,
    /// Lobe directions per glossy pixel for its glossy indirect light ([`crate::glossy`]:
    /// importance-sampled Monte Carlo), for a lobe that is all of the material's
    /// reflectance; a pixel takes this times the lobe's share (at least 1).
    pub glossy_samples: u32,
    /// Radiance records for low-frequency glossy lobes (issue 18): order, their own
    /// accuracy, which lobes they shade, how their frames are rotated.
    pub radiance: kind::RadianceSettings,
    /// Bounces past the first, carried by the surface bounce cache ([`crate::bounce`]) for
    /// plane records, by the VPL paths for VPL records.
    pub bounce: crate::bounce::BounceSettings,
    /// Where records get their irradiance ([`RecordSource`]).
    pub source: RecordSource,
    /// The VPLs of [`RecordSource::Vpl`].
    pub vpl: crate::vpl::VplSettings,
    /// The photon map of [`RecordSource::Photons`].
    pub photons: crate::photons::PhotonSettings,
}

/// What a record's R measures: the distance over which its irradiance may be extrapolated,
/// which `accuracy` scales into its validity radius `a R`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum RecordRadius {
    /// Ward's split sphere: the cosine-weighted harmonic mean distance of the plane's hits
    /// (algorithms.md 1.3). Near geometry shrinks a record whether or not the light changes
    /// there.
    SplitSphere,
    /// Second-order error control (Schwarzhaupt et al. 2012, Radiance 5's `ambcomp.c`):
    /// `R = scale sqrt(E / lambda)`, lambda the largest absolute eigenvalue of the
    /// tangent-plane Hessian of the irradiance's luminance read from the plane
    /// ([`hessian`](mod@super::hessian)), so the relative error left after the gradients, `lambda d^2 / 2 E`,
    /// is `(a scale)^2 / 2` at the validity radius `d = a R`. Records grow where the light is
    /// smooth and shrink at bright occlusion boundaries, whatever the geometry's distance.
    Hessian {
        /// `scale` above.
        scale: f32,
    },
}

impl RecordRadius {
    /// The scale the GPU reduction reads (0: split sphere).
    pub fn hessian_scale(self) -> f32 {
        match self {
            RecordRadius::SplitSphere => 0.0,
            RecordRadius::Hessian { scale } => scale,
        }
    }
}

/// How hemisphere-plane hits are shadowed (thesis section 4.4 uses shadow maps).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
pub enum PlaneShadows {
    /// Maps for the delta lights (sun, point, spot), whose visibility a map holds up to its
    /// resolution; shadow rays for rect lights, whose maps approximate a penumbra by a few
    /// cells (measured, indirect error after a 4x4 box filter: conference room 160x120
    /// at the defaults 3.56 % with 3x3 maps per panel against 3.18 % with rays, for
    /// 0.97x the frame time, the maps' trace included; at a 0.15 with 48x48 planes 2.79 %
    /// against 2.61 % for 0.84x; Cornell box 128x128 2.41 % against 2.33 % per pixel).
    Auto,
    /// Light-space visibility maps (`src/light_maps`) for every light, traced once
    /// per prepared scene.
    Maps,
    /// One shadow ray per light sample at every plane hit.
    Rays,
}

impl Default for CacheSettings {
    fn default() -> Self {
        Self {
            accuracy: 0.25,
            plane_resolution: 24,
            plane_fov_degrees: Self::PLANE_FOV_REFINED,
            plane_mode: PlaneMode::Stretched,
            plane_spacing: PlaneSpacing::Cosine,
            plane_light_samples: 1,
            plane_light_choices: 2,
            r_min_pixels: Self::STILL_R_MIN_PIXELS,
            r_min_scene: 1.0 / 32.0,
            r_max_factor: 64.0,
            record_radius: RecordRadius::Hessian {
                scale: Self::HESSIAN_SCALE,
            },
            neighbour_clamp: true,
            corral: Corral::Cover,
            record_budget: 200_000,
            tail_share: Self::TAIL_SHARE,
            tail_factor: Self::TAIL_FACTOR,
            interpolation_factor: Self::INTERPOLATION_FACTOR,
            noise_widening: Self::NOISE_WIDENING,
            widening_tolerance: noise_widening::WIDENING_TOLERANCE,
            gradients: true,
            plane_shadows: PlaneShadows::Auto,
            light_maps: LightMapSettings {
                resolution: 512,
                rect_grid: 3,
            },
            plane_refine: 0.1,
            plane_refine_split: 2,
            dark_plane_refine: true,
            dark_plane_guide: true,
            glossy_samples: 32,
            radiance: Default::default(),
            bounce: Default::default(),
            source: RecordSource::Planes,
            vpl: Default::default(),
            photons: Default::default(),
        }
    }
}

impl CacheSettings {
    /// The hemisphere plane table of these settings at `resolution` (their field of view,
    /// border mode and spacing).
    pub fn plane(&self, resolution: u32) -> HemispherePlane {
        HemispherePlane::new(
            resolution,
            self.plane_fov_degrees,
            self.plane_mode,
            self.plane_spacing,
        )
    }

    /// The default plane field of view with refinement and cosine spacing (measured:
    /// Cornell box 128x128, a = 0.2, 32x32 planes refined 0.1, neighbour clamping: indirect
    /// error 1.71 % at 150 degrees, 1.62 % at 160, 1.44 % at 170, 1.47 % at 175; Sponza sun
    /// 1000x1000 at 24x24: 9.40 % at 150, 9.32 % at 170. Cosine spacing spends few rays on
    /// the grazing band that a wide evenly spaced plane wastes many on: with even spacing the
    /// best was 150, thesis Table 4.1's 130 without refinement).
    pub const PLANE_FOV_REFINED: f32 = 170.0;
    /// The default [`CacheSettings::tail_share`] (docs/results.md, "Tail fill").
    pub const TAIL_SHARE: f32 = 0.1;
    /// The default [`CacheSettings::tail_factor`].
    pub const TAIL_FACTOR: f32 = 2.0;

    /// The widest accuracy tail fill covers at. Past it Ward's error admits records whose
    /// normals differ by over 40 degrees: at `-a 1.0` a tail at 2.0 raised Sponza's error
    /// from 18.7 to 20.2 % and saved no time (docs/results.md, "Tail fill").
    pub const TAIL_MAX_ACCURACY: f32 = 0.5;

    /// The accuracy of a still frame's last gather tier: Ward's widest, where a record
    /// reaches as far as its radius R on its own plane (error `d / R + sqrt(1 - n.n_i)`
    /// below 1).
    pub const LAST_TIER_ACCURACY: f32 = 1.0;

    /// The accuracy at which the pixels that only dark records reach at the tail's
    /// accuracy take every record that reaches them, dark ones included
    /// ([`Self::LAST_TIER_ACCURACY`]); `None` where the tail's accuracy is already that wide.
    /// Dark records (planes that saw no light, refined or not) are no evidence of darkness
    /// (`SplatSource::dark_only_empty`), and a pixel they alone reach at the tail's accuracy
    /// read exactly zero; weighed against them, a lit record further off gives it a little
    /// light. Sponza lit from the west (400x400) had 15 such 4x4 blocks on a wall the
    /// reference lights at 1-3 % of the image's mean; with the last tier none, and the
    /// indirect error 11.49 -> 11.48 % (the other variants and harness scenes within 0.001
    /// point; docs/results.md, "The last tier").
    pub fn last_tier_accuracy(&self) -> Option<f32> {
        (self.tail_accuracy() < Self::LAST_TIER_ACCURACY).then_some(Self::LAST_TIER_ACCURACY)
    }

    /// The accuracy tail fill covers and interpolates at: `tail_factor a`, at most
    /// [`Self::TAIL_MAX_ACCURACY`], when tail fill is on and that is above `a`, else `a`
    /// (no tail fill).
    pub fn tail_accuracy(&self) -> f32 {
        if self.tail_share > 0.0 {
            (self.accuracy * self.tail_factor)
                .min(Self::TAIL_MAX_ACCURACY)
                .max(self.accuracy)
        } else {
            self.accuracy
        }
    }

    /// The plane resolution of the tail's records: `P sqrt(a / a_tail)` per side (rounded;
    /// at least 8, or P when P is smaller), P when tail fill is off: half the rays at the
    /// default factor 2 (17x17 for 24x24). A tail record answers to the tail's wider
    /// accuracy and reaches few pixels of its own (on Sponza sun 1000x1000 about a tenth
    /// of what each record before the tail reaches), so its plane may be noisier; the
    /// variance-optimal allocation puts rays per record ~ the square root of the pixels
    /// it reaches. Measured against `P a / a_tail` (a quarter of the rays): that costs the
    /// Cornell box 256x256, whose error is mostly record noise, 1.65 -> 1.87 % indirect
    /// error, this 1.68 %; on Sponza both cost about 1 % of its error (docs/results.md,
    /// issue 17 eighth pass).
    pub fn tail_plane_resolution(&self) -> u32 {
        let p = self.plane_resolution;
        let ratio = f64::from(self.accuracy) / f64::from(self.tail_accuracy());
        let scaled = (f64::from(p) * ratio.sqrt()).round() as u32;
        scaled.clamp(p.min(Self::TAIL_MIN_PLANE_RESOLUTION), p)
    }

    /// The accuracy records are interpolated at before a still frame widens it for noisy
    /// records: `interpolation_factor a` ([`Self::interpolation_factor`],
    /// [`noise_widening::frame_interpolation_factor`]).
    pub fn interpolation_accuracy(&self) -> f32 {
        self.accuracy * self.interpolation_factor
    }

    /// The default [`Self::interpolation_factor`] (measured, docs/results.md "Interpolating
    /// wider than placing"; indirect error after a 4x4 box filter unless said, factor
    /// 1 -> 1.5): Sponza sun 1000x1000 10.05 -> 9.69 %, a hall lit through small windows
    /// 160x160 15.79 -> 14.57 %, conference room 160x120 3.10 -> 3.01 %, Cornell box
    /// 128x128 1.36 -> 1.37 % (at 2 it rose to 1.54 %); animations: cube in a box 48x48
    /// (frames 0..23, P 16) 3.23 -> 2.86 %, Spheres 64x64 (frames 0..11, beauty) 1.04 ->
    /// 0.98 % with less flicker; VPL and photon records on the Cornell box 8.02 -> 7.90 %
    /// and 5.49 -> 5.08 %; env-sphere 128x96 5.48 -> 5.02 %. Small boxes whose error is
    /// interpolation lose a little (96x96: cornell-sphere 1.48 -> 1.52 %, cube-in-box 1.34
    /// -> 1.40 %; moving-light gains, 2.00 -> 1.88 %). Radiance records' gather keeps their
    /// own accuracy (the glossy Cornell box did not gain).
    pub const INTERPOLATION_FACTOR: f32 = 1.5;

    /// The default [`Self::noise_widening`] (docs/results.md, "Interpolating as wide as
    /// the records' noise" and "The widened gather checked against the default one").
    /// Median record noise at the defaults: Cornell box 0.041, conference room 0.042,
    /// Sponza sun 0.105 (none widen: the same bytes); env-sphere 0.188 (factor 2.25,
    /// indirect error 3.11 -> 2.87 %), a hall lit through small windows 0.470 (factor 4,
    /// 14.57 -> 12.58 % at 160x160). Widened everywhere (stop 49, no tolerance) the same
    /// hall with the sun from another side went from 16.5 to 28.9 %; checked against the
    /// default gather ([`Self::widening_tolerance`]) it is 16.5 %, and twelve of thirteen
    /// configurations of the hall and env-sphere gain (one loses 3 %).
    pub const NOISE_WIDENING: f32 = 0.5;

    /// The widest [`Self::interpolation_factor`] [`Self::validate`] admits.
    pub const MAX_INTERPOLATION_FACTOR: f32 = 4.0;

    /// The smallest plane resolution [`Self::tail_plane_resolution`] reduces to.
    pub const TAIL_MIN_PLANE_RESOLUTION: u32 = 8;

    /// The best field of view of plain (unrefined) stretched planes (thesis Table 4.1).
    pub const PLANE_FOV_PLAIN: f32 = 130.0;

    /// The default [`RecordRadius::Hessian`] scale, chosen with the default accuracy 0.25
    /// on the peer harness's scenes (docs/results.md, "Records sized by the irradiance's
    /// Hessian"): Cornell box 128x128 indirect error 1.72 % (split sphere, a 0.2) -> 1.34 %
    /// for 3 % more records; Sponza sun 1000x1000 9.71 % -> 10.19 % for 28 % fewer.
    pub const HESSIAN_SCALE: f32 = 0.8;

    /// The CLI's default accuracy for animations and for VPL and photon records (the
    /// static default, 0.25, is chosen with Hessian-sized plane records).
    pub const ANIMATION_ACCURACY: f32 = 0.2;

    /// The default pixel bound on R_min of still frames: a validity radius `a R_min` of at
    /// least 2 pixels (R >= 8 pixels at a 0.25; Mitsuba's TL04 clamp is R >= 3). A bound in
    /// pixels is a coarse world size in a small image: at 3 pixels, half the records of a
    /// 160x160 hall lit through small windows (scenes/nave.toml) sat at it and its indirect
    /// error was 20.9 %; at 2 pixels 15.8 % for 11 % more time (Cornell box 128x128 1.56 ->
    /// 1.36 %, conference room 160x120 3.32 -> 3.10 %; Sponza 1000x1000, where the world
    /// bound binds, the same bytes; docs/results.md, "A hall lit through small windows").
    pub const STILL_R_MIN_PIXELS: f32 = 2.0;

    /// The CLI's pixel bound for animations and for VPL and photon records, which were
    /// measured with it (as [`Self::ANIMATION_ACCURACY`]); library callers that animate set
    /// it themselves.
    pub const ANIMATION_R_MIN_PIXELS: f32 = 3.0;

    /// These settings as a frame uses them: animations (`animated`) and the VPL and photon
    /// record sources size their records by Ward's split sphere, the sizing they were
    /// measured with and their tests hold (temporal caching and its per-frame baseline,
    /// instant caching, photon records and their plane fallback: docs/results.md); Hessian
    /// sizing is measured on plane records of still frames only. The CLI also gives them
    /// their measured accuracy, [`Self::ANIMATION_ACCURACY`], when `-a` is not given.
    pub fn resolved(&self, animated: bool) -> CacheSettings {
        if animated || self.source != RecordSource::Planes {
            // Their interpolation factor is fixed too: an animation's would change its
            // smoothing from frame to frame, and VPL and photon records were measured
            // with a fixed one.
            CacheSettings {
                record_radius: RecordRadius::SplitSphere,
                noise_widening: 0.0,
                ..self.clone()
            }
        } else {
            self.clone()
        }
    }

    /// [`Self::resolved`] for an animation.
    pub fn for_animation(&self) -> CacheSettings {
        self.resolved(true)
    }

    /// Pixels refined per record: `round(plane_refine * P^2)` (0: refinement off).
    pub fn refined_pixels(&self) -> u32 {
        let all = self.plane_resolution * self.plane_resolution;
        ((f64::from(self.plane_refine) * f64::from(all)).round() as u32).min(all)
    }

    /// Plane rays per record: `P^2 + K split^2` with K [`Self::refined_pixels`].
    pub fn plane_rays_per_record(&self) -> u64 {
        u64::from(self.plane_resolution).pow(2)
            + u64::from(self.refined_pixels()) * u64::from(self.plane_refine_split).pow(2)
    }

    /// Checks the ranges. Errors name the setting, the value given and the command-line
    /// flag that sets it.
    pub fn validate(&self) -> Result<()> {
        self.bounce.validate()?;
        self.vpl.validate()?;
        self.photons.validate()?;
        let bad = |setting: &str, flag: &str, value: String, rule: &str| {
            Err(Error::Usage(format!(
                "cache setting {setting} ({flag}) {value}: {rule}"
            )))
        };
        if !(self.accuracy > 0.0 && self.accuracy <= 1.0) {
            return bad(
                "accuracy",
                "-a/--accuracy",
                self.accuracy.to_string(),
                "must be in (0, 1]",
            );
        }
        if !(self.interpolation_factor >= 1.0
            && self.interpolation_factor <= Self::MAX_INTERPOLATION_FACTOR)
        {
            return bad(
                "interpolation factor",
                "--interpolation-factor",
                self.interpolation_factor.to_string(),
                "must be in [1, 4] (below 1, pixels that placement covered would get no record)",
            );
        }
        if self.widening_tolerance.is_nan() || self.widening_tolerance < 0.0 {
            return bad(
                "widening tolerance",
                "--widening-tolerance",
                self.widening_tolerance.to_string(),
                "must be a fraction of the accuracy >= 0 ('inf': no check)",
            );
        }
        if !(self.noise_widening >= 0.0 && self.noise_widening.is_finite()) {
            return bad(
                "noise widening",
                "--noise-widening",
                self.noise_widening.to_string(),
                "must be a finite fraction of the accuracy >= 0 (0: never widen)",
            );
        }
        if !(1..=MAX_GLOSSY_SAMPLES).contains(&self.glossy_samples) {
            return bad(
                "glossy samples",
                "--glossy-samples",
                self.glossy_samples.to_string(),
                &format!("must be from 1 to {MAX_GLOSSY_SAMPLES}"),
            );
        }
        let r = &self.radiance;
        if r.order > crate::hsh::MAX_ORDER {
            return bad(
                "radiance order",
                "--radiance-order",
                r.order.to_string(),
                "must be at most 10 (100 coefficients per channel); 0 turns radiance records off",
            );
        }
        if !(r.accuracy > 0.0 && r.accuracy <= 1.0) {
            return bad(
                "radiance accuracy",
                "--radiance-accuracy",
                r.accuracy.to_string(),
                "must be in (0, 1]",
            );
        }
        if !(0.0..=1.0).contains(&r.min_lobe_accuracy) {
            return bad(
                "radiance lobe accuracy",
                "--radiance-lobe-accuracy",
                r.min_lobe_accuracy.to_string(),
                "must be in [0, 1]",
            );
        }
        if !(0.0..=1.0).contains(&r.lobe_share) {
            return bad(
                "radiance lobe share",
                "--radiance-lobe-share",
                r.lobe_share.to_string(),
                "must be in [0, 1]",
            );
        }
        // 0: chosen from the irradiance records' P and the sharpest lobe
        // (`RadianceSettings::plane_resolution_for`).
        if r.plane_resolution != 0 && !(2..=512).contains(&r.plane_resolution) {
            return bad(
                "radiance plane resolution",
                "--radiance-plane-resolution",
                r.plane_resolution.to_string(),
                "must be in 2..=512, or 0 to choose it from --plane-resolution and the \
                 sharpest lobe",
            );
        }
        if !(2..=512).contains(&self.plane_resolution) {
            return bad(
                "plane_resolution",
                "--plane-resolution",
                self.plane_resolution.to_string(),
                "must be in 2..=512",
            );
        }
        if !(self.plane_fov_degrees > 1.0 && self.plane_fov_degrees < 179.0) {
            return bad(
                "plane_fov_degrees",
                "--plane-fov",
                self.plane_fov_degrees.to_string(),
                "must be in (1, 179) degrees",
            );
        }
        if !(16..=4096).contains(&self.light_maps.resolution) {
            return bad(
                "light_maps.resolution",
                "--light-map-resolution",
                self.light_maps.resolution.to_string(),
                "must be in 16..=4096",
            );
        }
        if !(1..=8).contains(&self.light_maps.rect_grid) {
            return bad(
                "light_maps.rect_grid",
                "--light-map-grid",
                self.light_maps.rect_grid.to_string(),
                "must be in 1..=8",
            );
        }
        if self.plane_light_samples == 0 {
            return bad(
                "plane_light_samples",
                "--plane-light-samples",
                "0".into(),
                "must be at least 1",
            );
        }
        if !(self.r_min_scene >= 0.0 && self.r_min_scene < 1.0) {
            return bad(
                "r_min_scene",
                "--r-min-scene",
                self.r_min_scene.to_string(),
                "must be in [0, 1) (a fraction of the scene's diagonal)",
            );
        }
        if !(self.r_min_pixels > 0.0 && self.r_min_pixels.is_finite()) {
            return bad(
                "r_min_pixels",
                "--r-min-pixels",
                self.r_min_pixels.to_string(),
                "must be a positive number",
            );
        }
        if let RecordRadius::Hessian { scale } = self.record_radius
            && !(scale > 0.0 && scale.is_finite())
        {
            return bad(
                "record_radius",
                "--hessian-scale",
                scale.to_string(),
                "must be a positive number",
            );
        }
        if !(self.r_max_factor >= 1.0 && self.r_max_factor.is_finite()) {
            return bad(
                "r_max_factor",
                "--r-max-factor",
                self.r_max_factor.to_string(),
                "must be a number >= 1",
            );
        }
        if !(0.0..=1.0).contains(&self.plane_refine) {
            return bad(
                "plane_refine",
                "--plane-refine",
                self.plane_refine.to_string(),
                "must be a fraction in [0, 1]",
            );
        }
        if !(1..=8).contains(&self.plane_refine_split) {
            return bad(
                "plane_refine_split",
                "--plane-refine-split",
                self.plane_refine_split.to_string(),
                "must be in 1..=8",
            );
        }
        if self.record_budget == 0 {
            return bad(
                "record_budget",
                "--record-budget",
                "0".into(),
                "must be at least 1 (no records means no indirect light; for direct light \
                 only, render with --direct-only)",
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::CacheSettings;

    fn tail_resolution(plane_resolution: u32, accuracy: f32, tail_share: f32) -> u32 {
        CacheSettings {
            plane_resolution,
            accuracy,
            tail_share,
            ..CacheSettings::default()
        }
        .tail_plane_resolution()
    }

    #[test]
    fn tail_planes_shrink_with_the_tails_accuracy() {
        // Defaults: a = 0.25, tail at 0.5: half the rays, 24 / sqrt 2 = 16.97 per side.
        assert_eq!(tail_resolution(24, 0.25, 0.1), 17);
        // The tail's accuracy is capped at 0.5: a = 0.3 gives 24 sqrt 0.6 = 18.6.
        assert_eq!(tail_resolution(24, 0.3, 0.1), 19);
        // Never below 8 per side, nor above the plane itself.
        assert_eq!(tail_resolution(10, 0.25, 0.1), 8);
        assert_eq!(tail_resolution(6, 0.25, 0.1), 6);
        // a = 0.5: no wider tail, no coarser planes; tail fill off: the plane itself.
        assert_eq!(tail_resolution(24, 0.5, 0.1), 24);
        assert_eq!(tail_resolution(24, 0.25, 0.0), 24);
    }
}
