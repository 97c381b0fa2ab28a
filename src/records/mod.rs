//! Irradiance records (thesis chapter 4, Ward's irradiance caching underneath): what a
//! record holds, where new ones go ([`RecordSite`]), how they are computed on the GPU
//! ([`RecordPass`]: sites → records, from hemisphere planes or from virtual point lights,
//! [`RecordSource`] says which) and the cache that holds them across frames
//! ([`RecordCache`]). [`reference`](mod@reference) and [`vpl_gather::reference_record`]
//! mirror the computations on the CPU.

pub mod hessian;
pub mod kind;
pub mod neighbour_grid;
pub mod noise_widening;
pub mod photon_records;
pub mod plane;
pub mod plane_error;
pub mod radiance_projection;
pub mod reference;
pub mod refine;
pub mod source;
pub mod stage;
pub mod vpl_gather;
pub mod vpl_update;

use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::{GpuContext, SceneFeatures};
use crate::light_maps::{LightMapSettings, LightMaps};
use crate::visibility::VisibilityBuffer;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
pub use kind::RecordKind;
pub use plane::{HemispherePlane, PlaneMode, PlanePixel, PlaneSpacing, RefineSample};
pub use source::RecordSource;
pub use stage::{PlaneBatch, RecordStage};
use std::sync::Arc;

/// One irradiance record (Rust mirror of WGSL `Record`, 144 bytes): p, n, R, E and the
/// rotational and translational gradients per colour channel (algorithms.md decision 3).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Record {
    pub position: [f32; 3],
    /// R_k: harmonic mean distance, clamped to `[r_min, r_max_factor * r_min]` and by
    /// Ward's gradient limit.
    pub radius: f32,
    pub normal: [f32; 3],
    /// The R_min the record was computed with.
    pub r_min: f32,
    /// E_k (rgb).
    pub irradiance: [f32; 3],
    /// The instance the record lies on (temporal caching can move records with it).
    pub instance: u32,
    /// Per channel (r, g, b): the world-space rotational gradient (xyz). The red
    /// channel's w holds the record's relative noise ([`Record::relative_noise`]); the
    /// green and blue channels' w its corral ([`Record::corral`]; 0 without one).
    pub rotation_gradient: [[f32; 4]; 3],
    /// Per channel: the world-space translational gradient.
    pub translation_gradient: [[f32; 4]; 3],
}

impl Record {
    pub fn position(&self) -> Vec3 {
        self.position.into()
    }
    pub fn normal(&self) -> Vec3 {
        self.normal.into()
    }
    pub fn irradiance(&self) -> Vec3 {
        Vec3::new(self.irradiance[0], self.irradiance[1], self.irradiance[2])
    }

    /// The relative noise of the record's irradiance, estimated from its plane
    /// ([`reference::plane_noise`]); 0 where its source estimates none (VPL and photon
    /// records) and for dark planes.
    pub fn relative_noise(&self) -> f32 {
        self.rotation_gradient[0][3]
    }

    /// Whether its plane saw no light (E = 0 in every channel). Where only such records
    /// reach a pixel of a still frame, tail fill gives it the lit records that reach it at
    /// the tail's accuracy (`SplatSource::dark_only_empty`).
    pub fn is_dark(&self) -> bool {
        self.irradiance() == Vec3::ZERO
    }

    /// Ward's error term `|p - p_k| / R_k + sqrt(1 - n.n_k)` (thesis eq. 4.2 is its inverse).
    pub fn error_at(&self, p: Vec3, n: Vec3) -> f32 {
        (p - self.position()).length() / self.radius + (1.0 - n.dot(self.normal())).max(0.0).sqrt()
    }

    /// The "behind" test of WGSL `record_in_front`.
    pub fn in_front_of(&self, p: Vec3, n: Vec3, accuracy: f32) -> bool {
        (p - self.position()).dot(n + self.normal()) * 0.5 >= -1.0e-2 * accuracy * self.radius
    }

    /// Whether the record contributes at (p, n) at `accuracy`: Ward's error within it, not
    /// behind and inside its corral (WGSL `reach_error` below `NOT_REACHED`).
    pub fn reaches(&self, p: Vec3, n: Vec3, accuracy: f32) -> bool {
        self.reaches_corralled(p, n, accuracy, true)
    }

    /// [`Record::reaches`] with the corral weighed or not (tail fill's gather weighs
    /// none; placement's cover and the other gathers as [`Corral`] says).
    pub fn reaches_corralled(&self, p: Vec3, n: Vec3, accuracy: f32, corral: bool) -> bool {
        self.error_at(p, n) <= accuracy
            && self.in_front_of(p, n, accuracy)
            && (!corral || self.corral_allows(p))
    }

    /// The corral: [`CORRAL_BITS`] bits per vertex of the polygon of [`CORRAL_SECTORS`]
    /// vertices around the normal (the levels of [`corral_level`]), eight vertices in each
    /// of the green and blue channels' unused rotational-gradient w, as exact integers (0:
    /// no vertex near; records without a plane keep 0).
    pub fn corral(&self) -> [u32; 2] {
        [
            self.rotation_gradient[1][3] as u32,
            self.rotation_gradient[2][3] as u32,
        ]
    }

    /// Stores the corral (see [`Record::corral`]).
    pub fn set_corral(&mut self, corral: [u32; 2]) {
        debug_assert!(corral.iter().all(|&w| w < 1 << 24), "exact in an f32");
        self.rotation_gradient[1][3] = corral[0] as f32;
        self.rotation_gradient[2][3] = corral[1] as f32;
    }

    /// Whether the corral lets the record reach `p` (WGSL `corral_allows`): p's offset
    /// along the record's tangent plane lies on the record's side of the polygon's edge
    /// across p's sector.
    pub fn corral_allows(&self, p: Vec3) -> bool {
        let words = self.corral();
        if words == [0, 0] {
            return true;
        }
        let base = crate::sampling::orthonormal_basis(self.normal());
        let d = p - self.position();
        let q = glam::Vec2::new(d.dot(base.x_axis), d.dot(base.y_axis));
        // In the frame of q's quarter turn (WGSL `corral_quarter`), as the GPU computes it.
        let (quarter, xy) = corral_quarter(q.x, q.y);
        let k = corral_sub_sector(xy);
        let s = 4 * quarter + k;
        let level = |b: u32| {
            (words[(b / CORRAL_PER_WORD) as usize] >> (CORRAL_BITS * (b % CORRAL_PER_WORD))) & 7
        };
        let (l0, l1) = (level(s), level((s + 1) % CORRAL_SECTORS));
        if l0 == 0 && l1 == 0 {
            return true;
        }
        let direction = |k: u32| glam::Vec2::from(CORRAL_DIRECTIONS[k as usize + 8]);
        let p0 = direction(k) * (CORRAL_DISTANCE[l0 as usize] * self.radius);
        let p1 = direction(k + 1) * (CORRAL_DISTANCE[l1 as usize] * self.radius);
        let edge = p1 - p0;
        let side_q = edge.x * (xy.y - p0.y) - edge.y * (xy.x - p0.x);
        let side_o = edge.x * (-p0.y) - edge.y * (-p0.x);
        side_q * side_o >= 0.0
    }

    /// E_k extrapolated to (p, n) with the gradients, clamped at 0 (WGSL
    /// `record_irradiance_at`).
    pub fn irradiance_at(&self, p: Vec3, n: Vec3) -> Vec3 {
        let axis = self.normal().cross(n);
        let d = p - self.position();
        let g = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
        let mut e = self.irradiance();
        for c in 0..3 {
            e[c] += axis.dot(g(self.rotation_gradient[c])) + d.dot(g(self.translation_gradient[c]));
        }
        e.max(Vec3::ZERO)
    }
}

/// Where the records' corrals ([`Record::corral_allows`]: a record does not reach pixels
/// beyond a surface its plane's horizon rays hit near it, so records on the dark side of
/// a wall's end do not darken the floor in front of its lit face, nor the lit side's
/// records light the dark one) apply.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, clap::ValueEnum)]
pub enum Corral {
    /// No corral: records are computed without one (animations: a record outlives the
    /// geometry its corral saw).
    Off,
    /// Placement's cover weighs the corrals, the gathers do not (the default): a pixel
    /// beyond the corral of every record that reaches it gets a record of its own, and the
    /// gathers then weigh that record beside the others. Where a lit surface's end stands
    /// beside the floor (the nave with the sun 34 degrees up) 16.6 -> 9.0 %, the nave
    /// 13.2 -> 11.2 %; Sponza's views 2-8 % worse (relative), the rest within 2 %; about
    /// 1.00-1.05x the process time on lavapipe (docs/results.md, "The corral in placement's
    /// cover alone").
    #[default]
    Cover,
    /// The gathers weigh no record beyond its corral; placement covers as without (the
    /// same records), so a pixel that only corralled records reach takes them in tail
    /// fill's gather rather than reading black. The nave 13.07 -> 12.58 %, the conference
    /// room 2.55 -> 2.47 %, the nave with the sun 34 degrees up 16.56 -> 13.56 %, Sponza's
    /// west sun 10.70 -> 10.83 %, for 1.03-1.09x the process time.
    Gather,
    /// Placement's cover and the gathers: pixels beyond a record's corral get records of
    /// their own and do not take it. Where a lit surface's end stands beside the floor
    /// (the nave with the sun 34 degrees up) 16.6 -> 6.8 %, for 1.1-1.2x the time on
    /// lavapipe (the gathers' corral test).
    Placement,
}

impl Corral {
    /// Whether records get corrals.
    pub fn in_records(self) -> bool {
        self != Corral::Off
    }

    /// Whether the gathers weigh them.
    pub fn in_gathers(self) -> bool {
        matches!(self, Corral::Gather | Corral::Placement)
    }

    /// Whether placement's cover weighs them too.
    pub fn in_cover(self) -> bool {
        matches!(self, Corral::Placement | Corral::Cover)
    }
}

/// Vertices of a record's corral polygon around its normal (WGSL `CORRAL_SECTORS`,
/// shared/corral.wgsl), 22.5 degrees apart.
pub const CORRAL_SECTORS: u32 = 16;
/// Bits of a corral vertex's level.
pub const CORRAL_BITS: u32 = 3;
/// Vertices in each of the two words of a corral (24 bits, exact in an f32).
pub const CORRAL_PER_WORD: u32 = 8;
/// A corral vertex's distance from the record in units of R, by level (0: far).
pub const CORRAL_DISTANCE: [f32; 8] = [2.0, 0.0625, 0.125, 0.1875, 0.25, 0.375, 0.5, 0.75];

/// Where a tangent-plane offset (u, v) along [`crate::sampling::orthonormal_basis`]'s
/// first two axes lies around the normal, in sectors (WGSL `corral_turn`): vertex b at b.
pub fn corral_turn(u: f32, v: f32) -> f32 {
    (v.atan2(u) + std::f32::consts::PI) * (CORRAL_SECTORS as f32 / std::f32::consts::TAU)
}

/// The level of a corral vertex whose nearest hit lies `h` away along the tangent plane
/// (negative: none), for a record of radius `radius` (WGSL `corral_level`): the farthest
/// [`CORRAL_DISTANCE`] within h (the nearest, R / 16, below it); 0 (far) for h >= R.
pub fn corral_level(h: f32, radius: f32) -> u32 {
    if h < 0.0 || h >= radius {
        return 0;
    }
    (2..8u32)
        .filter(|&l| CORRAL_DISTANCE[l as usize] * radius <= h)
        .max()
        .unwrap_or(1)
}

/// The corral vertices' directions in the tangent plane: vertex b at -pi + b pi / 8
/// (WGSL `CORRAL_DIRECTIONS`, the same constants).
pub const CORRAL_DIRECTIONS: [[f32; 2]; 16] = [
    [-1.0, 0.0],
    [-0.923_879_5, -0.382_683_43],
    [-0.707_106_77, -0.707_106_77],
    [-0.382_683_43, -0.923_879_5],
    [0.0, -1.0],
    [0.382_683_43, -0.923_879_5],
    [0.707_106_77, -0.707_106_77],
    [0.923_879_5, -0.382_683_43],
    [1.0, 0.0],
    [0.923_879_5, 0.382_683_43],
    [0.707_106_77, 0.707_106_77],
    [0.382_683_43, 0.923_879_5],
    [0.0, 1.0],
    [-0.382_683_43, 0.923_879_5],
    [-0.707_106_77, 0.707_106_77],
    [-0.923_879_5, 0.382_683_43],
];

/// tan(22.5 degrees) (WGSL `CORRAL_TAN`).
const CORRAL_TAN: f32 = 0.414_213_57;

/// The sector (0..15) of a tangent-plane offset (u, v), between vertices s and s + 1: the
/// whole part of [`corral_turn`] but at its edges, from comparisons alone (WGSL
/// `corral_sector`: no atan2 where every reached pixel tests a record).
pub fn corral_sector(u: f32, v: f32) -> u32 {
    let (quarter, xy) = corral_quarter(u, v);
    4 * quarter + corral_sub_sector(xy)
}

/// The quarter turn from -pi that a tangent-plane offset (u, v) lies in (vertices
/// 4 quarter .. 4 quarter + 4), and the offset in that quarter's frame: x along its first
/// vertex, y along its last (WGSL `corral_quarter`; a turn by a multiple of 90 degrees,
/// exact in floats).
pub fn corral_quarter(u: f32, v: f32) -> (u32, glam::Vec2) {
    if v < 0.0 && u >= 0.0 {
        (1, glam::Vec2::new(-v, u))
    } else if v >= 0.0 && u >= 0.0 {
        (2, glam::Vec2::new(u, v))
    } else if v >= 0.0 {
        (3, glam::Vec2::new(v, -u))
    } else {
        (0, glam::Vec2::new(-u, -v))
    }
}

/// The sector within a quarter (0..3) of a point of its frame (WGSL `corral_sub_sector`).
fn corral_sub_sector(xy: glam::Vec2) -> u32 {
    u32::from(xy.y >= xy.x * CORRAL_TAN)
        + u32::from(xy.y >= xy.x)
        + u32::from(xy.y * CORRAL_TAN >= xy.x)
}

/// The corral of `h`, the nearest horizon hit per vertex (negative: none), for a record of
/// radius `radius`: the two words [`Record::set_corral`] stores.
pub fn corral_words(h: &[f32; CORRAL_SECTORS as usize], radius: f32) -> [u32; 2] {
    let mut words = [0u32; 2];
    for (b, &h) in h.iter().enumerate() {
        let b = b as u32;
        words[(b / CORRAL_PER_WORD) as usize] |=
            corral_level(h, radius) << (CORRAL_BITS * (b % CORRAL_PER_WORD));
    }
    words
}

/// How the records' radii R sit between their R_min and R_max (the `render --stats`
/// JSON): records at R_min mark where the harmonic mean distance, or Ward's gradient
/// limit, asked for less than the pixel footprint allows.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct RadiusStats {
    pub records: usize,
    /// Share of records with R = R_min (within 0.1 %).
    pub at_r_min: f64,
    /// Share of records with R = R_max (within 0.1 %).
    pub at_r_max: f64,
    /// Quartiles of R / R_min.
    pub ratio_quartiles: [f32; 3],
    /// Share of records whose plane saw no light (E = 0 in every channel): where only such
    /// records reach, a pixel's indirect light is exactly zero.
    pub dark: f64,
    /// Quartiles of [`Record::relative_noise`].
    pub noise_quartiles: [f32; 3],
}

impl RadiusStats {
    pub fn of(records: &[Record], r_max_factor: f32) -> Self {
        if records.is_empty() {
            return Self::default();
        }
        let mut ratios: Vec<f32> = records
            .iter()
            .map(|r| r.radius / r.r_min.max(f32::MIN_POSITIVE))
            .collect();
        ratios.sort_by(f32::total_cmp);
        let n = ratios.len();
        let share =
            |f: &dyn Fn(f32) -> bool| ratios.iter().filter(|&&x| f(x)).count() as f64 / n as f64;
        Self {
            records: n,
            at_r_min: share(&|x| x <= 1.001),
            at_r_max: share(&|x| x >= r_max_factor * 0.999),
            ratio_quartiles: quartiles(&ratios),
            dark: records.iter().filter(|r| r.is_dark()).count() as f64 / n as f64,
            noise_quartiles: {
                let mut noise: Vec<f32> = records.iter().map(Record::relative_noise).collect();
                noise.sort_by(f32::total_cmp);
                quartiles(&noise)
            },
        }
    }
}

/// The quartiles of sorted, non-empty `values`.
fn quartiles(values: &[f32]) -> [f32; 3] {
    let n = values.len();
    [values[n / 4], values[n / 2], values[(3 * n) / 4]]
}

/// Where a new record goes (mirror of WGSL `RecordSite`, 48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RecordSite {
    pub position: [f32; 3],
    pub r_min: f32,
    /// Shading normal (the record's hemisphere).
    pub normal: [f32; 3],
    /// Scrambles the light samples of the plane's hits.
    pub seed: u32,
    /// Geometric normal (offsets ray origins).
    pub geometric_normal: [f32; 3],
    /// The instance the site lies on.
    pub instance: u32,
}

/// One traced plane pixel (mirror of WGSL `PlaneSample`, 16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct PlaneSample {
    pub radiance: [f32; 3],
    /// Hit depth along the record normal (`r cos(theta)`), negative on a miss.
    pub depth: f32,
}

/// Depth of the nearer of two plane samples (Ward's min rule for the edges of the
/// translational gradients); <= 0 when both are misses. WGSL: `nearer_depth`, records.wgsl.
pub(crate) fn nearer_depth(a: f32, b: f32) -> f32 {
    if a <= 0.0 {
        b
    } else if b <= 0.0 {
        a
    } else {
        a.min(b)
    }
}

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
    /// bound is searched in a grid ([`neighbour_grid`]), the same bytes as a loop over
    /// every earlier record, whose cost grew with the square of the record count.
    pub neighbour_clamp: bool,
    /// The corral (after Radiance's ambcorral, [`Corral`]): where a record's
    /// [`Record::corral_allows`] applies. Default [`Corral::Cover`].
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
    /// ([`refine`]). 0: none by contrast (dark planes still are, see
    /// [`Self::dark_plane_refine`]).
    pub plane_refine: f32,
    /// Sub-samples per axis of a refined pixel (`split x split` strata).
    pub plane_refine_split: u32,
    /// A plane that saw no light at all is refined everywhere (`split^2` more rays per
    /// pixel, [`refine::select_pixels`]), whatever `plane_refine` says: P^2 centre rays
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
    /// [`refine::guided_pixels`]). Elsewhere, and with this off, a dark plane is refined
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
    /// ([`hessian`]), so the relative error left after the gradients, `lambda d^2 / 2 E`,
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

/// The records of a scene, resident on the GPU, with room to grow (view-independent: a
/// new camera reuses them, thesis section 4.7.2). A cache holds records of one
/// [`RecordKind`]; radiance records keep their coefficients in `coefficients`, one block
/// per record at the record's index.
pub struct RecordCache {
    pub buffer: wgpu::Buffer,
    /// The kind's per-record blocks beside `buffer` ([`RecordKind::coefficient_floats`]
    /// f32 each); a 16-byte placeholder for irradiance records.
    pub coefficients: wgpu::Buffer,
    pub kind: RecordKind,
    /// Records in use (the first `count` of the buffer).
    pub count: u32,
    capacity: u32,
    /// Records gathered from VPLs under temporal instant caching keep one visibility bit
    /// per VPL slot (`visibility_words` u32 per record, at the record's index): which of
    /// their rays reached their VPL, so that a later frame traces again only the rays what
    /// moved may have changed. A 16-byte placeholder when `visibility_words` is 0.
    pub visibility: wgpu::Buffer,
    pub visibility_words: u32,
}

/// Bytes per record.
pub const RECORD_BYTES: u64 = std::mem::size_of::<Record>() as u64;

impl RecordCache {
    /// A view of the first `count` records (the same GPU buffer): what the cache held
    /// before later records were added.
    pub fn prefix(&self, count: u32) -> RecordCache {
        RecordCache {
            buffer: self.buffer.clone(),
            coefficients: self.coefficients.clone(),
            kind: self.kind,
            count: count.min(self.count),
            capacity: self.capacity,
            visibility: self.visibility.clone(),
            visibility_words: self.visibility_words,
        }
    }

    /// An empty cache of irradiance records.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Self::with_kind(ctx, RecordKind::Irradiance)
    }

    /// An empty cache of `kind` records.
    pub fn with_kind(ctx: &GpuContext, kind: RecordKind) -> Result<Self> {
        let capacity = 1024;
        Ok(Self {
            buffer: ctx.storage_buffer_sized("records", u64::from(capacity) * RECORD_BYTES)?,
            coefficients: ctx.storage_buffer_sized(
                "record coefficients",
                (u64::from(capacity) * kind.coefficient_bytes()).max(16),
            )?,
            kind,
            count: 0,
            capacity,
            visibility: ctx.storage_buffer_sized("record vpl visibility", 16)?,
            visibility_words: 0,
        })
    }

    /// An empty cache of irradiance records that keep a visibility bit per VPL slot
    /// (`slots` of them; temporal instant caching).
    pub fn with_vpl_visibility(ctx: &GpuContext, slots: u32) -> Result<Self> {
        let mut cache = Self::with_kind(ctx, RecordKind::Irradiance)?;
        cache.visibility_words = slots.div_ceil(32).max(1);
        cache.visibility = ctx.storage_buffer_sized(
            "record vpl visibility",
            u64::from(cache.capacity) * cache.visibility_bytes(),
        )?;
        Ok(cache)
    }

    /// Bytes of one record's visibility bits.
    fn visibility_bytes(&self) -> u64 {
        u64::from(self.visibility_words) * 4
    }

    /// Most records of this cache's kind one binding holds on `ctx`'s device.
    pub fn max_records(&self, ctx: &GpuContext) -> u64 {
        Self::max_records_of(ctx, self.kind)
            .min(ctx.max_binding_size() / self.visibility_bytes().max(1))
    }

    /// Most records of `kind` one binding holds on `ctx`'s device (the records or their
    /// coefficient blocks, whichever is larger per record).
    pub fn max_records_of(ctx: &GpuContext, kind: RecordKind) -> u64 {
        ctx.max_binding_size() / RECORD_BYTES.max(kind.coefficient_bytes())
    }

    /// Makes room for `extra` more records, growing the buffers (copying the records) or
    /// failing with a device-limit error naming the record count.
    pub fn reserve(&mut self, ctx: &GpuContext, extra: u32) -> Result<()> {
        let needed = u64::from(self.count) + u64::from(extra);
        if needed <= u64::from(self.capacity) {
            return Ok(());
        }
        let max_records = self.max_records(ctx);
        if needed > max_records {
            let per = RECORD_BYTES
                .max(self.kind.coefficient_bytes())
                .max(self.visibility_bytes());
            let hint = match self.kind {
                RecordKind::Irradiance => String::new(),
                RecordKind::Radiance { .. } => {
                    "; a lower --radiance-order or a larger --radiance-accuracy needs fewer bytes"
                        .into()
                }
            };
            return Err(Error::DeviceLimit(format!(
                "{needed} {} need {} MiB in one buffer; this device allows {} \
                 records ({} MiB per binding){hint}",
                self.kind.describe(),
                (needed * per).div_ceil(1 << 20),
                max_records,
                ctx.max_binding_size() >> 20
            )));
        }
        let capacity = (needed.max(u64::from(self.capacity) * 2)).min(max_records) as u32;
        let buffer = ctx.storage_buffer_sized("records", u64::from(capacity) * RECORD_BYTES)?;
        let block = self.kind.coefficient_bytes();
        let coefficients =
            ctx.storage_buffer_sized("record coefficients", (u64::from(capacity) * block).max(16))?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(
            &self.buffer,
            0,
            &buffer,
            0,
            u64::from(self.count) * RECORD_BYTES,
        );
        if block > 0 && self.count > 0 {
            enc.copy_buffer_to_buffer(
                &self.coefficients,
                0,
                &coefficients,
                0,
                u64::from(self.count) * block,
            );
        }
        let bits = self.visibility_bytes();
        if bits > 0 {
            let visibility =
                ctx.storage_buffer_sized("record vpl visibility", u64::from(capacity) * bits)?;
            if self.count > 0 {
                enc.copy_buffer_to_buffer(
                    &self.visibility,
                    0,
                    &visibility,
                    0,
                    u64::from(self.count) * bits,
                );
            }
            self.visibility = visibility;
        }
        ctx.queue.submit([enc.finish()]);
        self.buffer = buffer;
        self.coefficients = coefficients;
        self.capacity = capacity;
        Ok(())
    }

    /// Reads the visibility bits back (`visibility_words` per record; empty without).
    pub fn read_visibility(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        if self.visibility_words == 0 {
            return Ok(Vec::new());
        }
        let mut all: Vec<u32> = ctx.read_buffer(&self.visibility)?;
        all.truncate((self.count * self.visibility_words) as usize);
        Ok(all)
    }

    /// Replaces the contents with `records` and their visibility bits
    /// (`visibility_words` per record, in order).
    pub fn upload_with_visibility(
        &mut self,
        ctx: &GpuContext,
        records: &[Record],
        bits: &[u32],
    ) -> Result<()> {
        if bits.len() != records.len() * self.visibility_words as usize {
            return Err(Error::Usage(format!(
                "internal: {} visibility words for {} records",
                bits.len(),
                records.len()
            )));
        }
        self.upload(ctx, records)?;
        if !bits.is_empty() {
            ctx.queue
                .write_buffer(&self.visibility, 0, bytemuck::cast_slice(bits));
        }
        Ok(())
    }

    /// Reads the records back.
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<Record>> {
        if self.count == 0 {
            return Ok(Vec::new());
        }
        // The records alone, not the buffer's spare capacity.
        let bytes = u64::from(self.count) * RECORD_BYTES;
        let mut read = ctx.read_buffer_ranges::<Record>(&[(&self.buffer, 0..bytes)])?;
        let mut all = read.pop().unwrap_or_default();
        all.truncate(self.count as usize);
        Ok(all)
    }

    /// Reads the coefficient blocks back (`count x coefficient_floats` f32; empty for
    /// irradiance records).
    pub fn read_coefficients(&self, ctx: &GpuContext) -> Result<Vec<f32>> {
        if self.kind.coefficient_floats() == 0 {
            return Ok(Vec::new());
        }
        let mut all: Vec<f32> = ctx.read_buffer(&self.coefficients)?;
        all.truncate(self.count as usize * self.kind.coefficient_floats());
        Ok(all)
    }

    /// The byte range of records `first..first + count`, for
    /// [`GpuContext::read_buffer_ranges`].
    pub fn byte_range(first: u32, count: u32) -> std::ops::Range<u64> {
        u64::from(first) * RECORD_BYTES..u64::from(first + count) * RECORD_BYTES
    }

    /// Replaces the contents with `records` (tests, cache files); radiance records keep
    /// whatever coefficients their blocks held.
    pub fn upload(&mut self, ctx: &GpuContext, records: &[Record]) -> Result<()> {
        self.count = 0;
        self.reserve(ctx, records.len() as u32)?;
        ctx.queue
            .write_buffer(&self.buffer, 0, bytemuck::cast_slice(records));
        self.count = records.len() as u32;
        Ok(())
    }

    /// Replaces the contents with `records` and their coefficient blocks (`coefficients`:
    /// [`RecordKind::coefficient_floats`] per record, in order; empty for irradiance).
    pub fn upload_with_coefficients(
        &mut self,
        ctx: &GpuContext,
        records: &[Record],
        coefficients: &[f32],
    ) -> Result<()> {
        if coefficients.len() != records.len() * self.kind.coefficient_floats() {
            return Err(Error::Usage(format!(
                "internal: {} coefficients for {} {}",
                coefficients.len(),
                records.len(),
                self.kind.describe()
            )));
        }
        self.upload(ctx, records)?;
        if !coefficients.is_empty() {
            ctx.queue
                .write_buffer(&self.coefficients, 0, bytemuck::cast_slice(coefficients));
        }
        Ok(())
    }

    /// The byte range of the coefficient blocks of records `first..first + count`.
    pub fn coefficient_range(&self, first: u32, count: u32) -> std::ops::Range<u64> {
        let block = self.kind.coefficient_bytes();
        u64::from(first) * block..u64::from(first + count) * block
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SiteParams {
    count: u32,
    first_record: u32,
    r_min_pixels: f32,
    accuracy: f32,
    r_min_world: f32,
    _pad: [u32; 3],
}

/// Parameters of the plane pass and its refinement (`hemisphere_plane.wgsl`), and of the
/// plane refresh's re-trace (`plane_retrace.wgsl`, which reads the first eight fields).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct PlaneParams {
    pub resolution: u32,
    pub count: u32,
    pub light_samples: u32,
    /// 1: also write each sample's hit.
    pub record_hits: u32,
    /// [`CacheSettings::plane_light_choices`].
    pub light_choices: u32,
    /// 1: also write each sample's environment-sampled share (refinement's selection).
    pub record_noise: u32,
    /// [`Self::TRACE`], [`Self::REFINE_LIT`] or [`Self::REFINE_DARK`].
    pub mode: u32,
    /// Refining: K pixels selected per lit plane by contrast.
    pub refined: u32,
    /// Refining: strata per pixel, `split^2`.
    pub subsamples: u32,
    /// Refining: the centre ray's weight, `1 / (1 + split^2)`.
    pub centre_weight: f32,
    /// Refining: selection slots per record ([`refine::RefinePass::slots`]).
    pub slots: u32,
    /// Refining: pixels per workgroup, `64 / split^2` (one invocation per stratum).
    pub per_group: u32,
}

impl PlaneParams {
    /// `mode`: trace the planes (`MODE_TRACE` in `hemisphere_plane.wgsl`).
    pub const TRACE: u32 = 0;
    /// `mode`: refine the pixels selected on lit planes in place
    /// ([`refine::RefinePass::record`]).
    pub const REFINE_LIT: u32 = 1;
    /// `mode`: refine the pixels of the planes that saw no light.
    pub const REFINE_DARK: u32 = 2;
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ReduceParams {
    resolution: u32,
    count: u32,
    first_record: u32,
    gradients: u32,
    r_max_factor: f32,
    cos_weight_sum: f32,
    neighbour_clamp: u32,
    hessian_scale: f32,
}

/// Planes traced and refined by [`RecordPass::trace_planes_refined`].
#[derive(Clone, Debug, Default)]
pub struct RefinedPlanes {
    /// The traced planes, P^2 samples per site.
    pub coarse: Vec<PlaneSample>,
    /// The same after refinement.
    pub refined: Vec<PlaneSample>,
    /// Each traced sample's environment-sampled share (zeros without refinement).
    pub noise: Vec<f32>,
    /// The K refined pixels of each site, in pixel order.
    pub selected: Vec<u32>,
}

/// The records a reduction writes: `count` records from `first_record`, at `sites`.
pub struct ReductionBatch<'a> {
    pub sites: &'a wgpu::Buffer,
    pub first_record: u32,
    pub count: u32,
}

/// A [`HemispherePlane`]'s pixel table on the GPU, as the record reduction reads it: its
/// `P^2` pixels, then where its settings refine planes, each pixel's `split^2` strata as
/// pixels of their own (centre in `center`, weight in the refined pixel in `cos_weight`:
/// [`HemispherePlane::refine_samples`]), which the plane pass's refinement traces.
pub struct PlaneTable {
    pub resolution: u32,
    pub pixels: wgpu::Buffer,
    /// Sum of the pixels' cosine weights (pi when the border is stretched).
    pub cos_weight_sum: f32,
}

impl PlaneTable {
    /// The table of a `resolution` x `resolution` plane with `settings`' field of view and
    /// border mode.
    pub fn new(ctx: &GpuContext, resolution: u32, settings: &CacheSettings) -> Result<Self> {
        let table = settings.plane(resolution);
        let cos_weight_sum = table
            .pixels
            .iter()
            .map(|p| f64::from(p.cos_weight))
            .sum::<f64>();
        let mut pixels = table.pixels.clone();
        if settings.refined_pixels() > 0 || settings.dark_plane_refine {
            pixels.extend(
                table
                    .refine_samples(settings.plane_refine_split)
                    .iter()
                    .map(|s| PlanePixel {
                        cos_weight: s.weight,
                        center: s.center,
                        ..PlanePixel::default()
                    }),
            );
        }
        Ok(Self {
            resolution,
            pixels: ctx.storage_buffer("plane table", &pixels)?,
            cos_weight_sum: cos_weight_sum as f32,
        })
    }
}

/// Computes records on the GPU: `record_sites.wgsl` (pixels → sites),
/// `hemisphere_plane.wgsl` (trace and shade the planes), `record_reduce.wgsl` (E, R,
/// gradients), in batches sized to the device.
pub struct RecordPass {
    /// Every record pass of a device has the same pipelines (built once per device,
    /// [`ComputePass::with_constants`]): tail fill's ([`Self::tail_pass`]), radiance
    /// records', temporal caching's.
    sites: Arc<ComputePass>,
    plane: Arc<ComputePass>,
    reduce: Arc<ComputePass>,
    /// The grid over earlier records that neighbour clamping searches.
    neighbour_grid: neighbour_grid::NeighbourGridPass,
    /// The plane table for `settings`.
    table: PlaneTable,
    /// Adaptive plane refinement, when `settings.plane_refine` selects any pixel.
    refine: Option<refine::RefinePass>,
    pub settings: CacheSettings,
    /// Records per plane dispatch.
    pub batch: u32,
    /// What plane passes bind when a frame has no light maps.
    no_light_maps: LightMaps,
    /// What plane passes bind when no sample's environment share is kept (zeros).
    no_noise: wgpu::Buffer,
    /// What the plane pass binds as refinement's selection when it traces.
    no_selection: wgpu::Buffer,
    /// The kind of records computed; radiance records also project their planes.
    pub kind: RecordKind,
    /// The scene features its plane pipelines are compiled for ([`Self::for_scene`]).
    features: SceneFeatures,
    projection: Option<radiance_projection::RadianceProjectionPass>,
    /// The gather of VPL records ([`RecordSource::Vpl`]).
    vpl: Option<vpl_gather::VplGatherPass>,
    /// The pass of tail fill's records: planes at
    /// [`CacheSettings::tail_plane_resolution`] (irradiance records from planes, when that
    /// is below the plane resolution). Built on first use; no plane resolution is compiled
    /// into a pipeline, so its pipelines are this pass's and only its plane table and
    /// buffers are new.
    tail: std::sync::OnceLock<Box<RecordPass>>,
}

impl RecordPass {
    /// A pass computing irradiance records.
    pub fn new(ctx: &GpuContext, settings: &CacheSettings) -> Result<Self> {
        Self::with_kind(ctx, settings, RecordKind::Irradiance)
    }

    /// A pass computing `kind` records: radiance records are irradiance records whose
    /// planes are also projected onto HSH (`radiance_project.wgsl`). Its plane hits are
    /// shaded for every kind of light ([`Self::for_scene`] compiles fewer).
    pub fn with_kind(ctx: &GpuContext, settings: &CacheSettings, kind: RecordKind) -> Result<Self> {
        Self::for_scene(ctx, settings, kind, SceneFeatures::ALL)
    }

    /// [`Self::with_kind`] with the plane and refinement pipelines compiled for the scene
    /// features `features` alone (its kinds of light, instances or one BLAS, textures; the
    /// bounce cache its settings make is added): a scene with others is refused by
    /// [`Self::check_features`].
    pub fn for_scene(
        ctx: &GpuContext,
        settings: &CacheSettings,
        kind: RecordKind,
        features: SceneFeatures,
    ) -> Result<Self> {
        settings.validate()?;
        // Its plane hits reflect the bounce cache its settings make (none with one bounce).
        let features = features.with_bounce_cache(settings.bounce.levels() > 0);
        // Photon records leave holes that plane records fill.
        let planes = settings.source != RecordSource::Vpl;
        if settings.source != RecordSource::Planes && kind != RecordKind::Irradiance {
            return Err(Error::Usage(format!(
                "{} come from hemisphere planes only (--records {} is for irradiance records)",
                kind.describe(),
                settings.source.name()
            )));
        }
        let projection = match kind {
            RecordKind::Irradiance => None,
            RecordKind::Radiance { order } => {
                let plane = settings.plane(settings.plane_resolution);
                Some(radiance_projection::RadianceProjectionPass::new(
                    ctx, &plane, order, 16,
                )?)
            }
        };
        let plane_bytes = u64::from(settings.plane_resolution).pow(2) * 16;
        // As many records per dispatch as fit one binding, at most 256 (a few seconds of
        // rays on a CPU device, so progress stays visible).
        let batch = (ctx.max_binding_size() / plane_bytes).clamp(1, 256) as u32;
        // The refinement's selection compiles on a thread of their own while this one
        // compiles the plane's (which also refines: one copy of the traversal and
        // shading, which lavapipe compiles in about 0.1 s); the record pass is the longest
        // of the passes a frame builds at start-up (`Renderer::build_passes`).
        let (refine, built) = std::thread::scope(|s| {
            let refine = s.spawn(|| {
                if planes {
                    refine::RefinePass::new(ctx, settings)
                } else {
                    Ok(None)
                }
            });
            let built =
                Self::without_refinement(ctx, settings, kind, planes, projection, batch, features);
            let refine = refine
                .join()
                .unwrap_or_else(|_| Err(Error::Gpu("building the refinement panicked".into())));
            (refine, built)
        });
        let mut pass = built?;
        pass.refine = refine?;
        Ok(pass)
    }

    /// [`Self::with_kind`]'s pass, its refinement (built apart) not yet in it.
    fn without_refinement(
        ctx: &GpuContext,
        settings: &CacheSettings,
        kind: RecordKind,
        planes: bool,
        projection: Option<radiance_projection::RadianceProjectionPass>,
        batch: u32,
        features: SceneFeatures,
    ) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            sites: ComputePass::new(
                ctx,
                "record_sites.wgsl",
                &[Uniform, Uniform, StorageRead, StorageRead, StorageReadWrite],
            )?,
            // Traces the planes and refines them (`refine::RefinePass::record`). Ten storage
            // buffers: with the scene's six, the 16 a stage may bind
            // (`gpu::context::STORAGE_BUFFERS_PER_STAGE`).
            plane: ComputePass::with_constants(
                ctx,
                "hemisphere_plane.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageRead,
                ],
                &[features.constant()],
            )?,
            // The Hessian's mesh sum only in the pipeline that uses it (lavapipe ran the
            // split-sphere reduction slower with the unused branch compiled in).
            reduce: ComputePass::with_constants(
                ctx,
                "record_reduce.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    Uniform,
                    StorageRead,
                    StorageRead,
                ],
                &[
                    (
                        "RECORD_RADIUS_HESSIAN",
                        f64::from(u8::from(matches!(
                            settings.record_radius,
                            RecordRadius::Hessian { .. }
                        ))),
                    ),
                    // The corral's code only where records get one (lavapipe's start-up
                    // built the larger pipeline 1.2x as slowly).
                    ("CORRAL", f64::from(u8::from(settings.corral.in_records()))),
                ],
            )?,
            neighbour_grid: neighbour_grid::NeighbourGridPass::new(ctx)?,
            table: PlaneTable::new(ctx, settings.plane_resolution, settings)?,
            refine: None,
            settings: settings.clone(),
            batch,
            no_light_maps: LightMaps::none(ctx)?,
            no_noise: ctx.storage_buffer_sized("no plane noise", 16)?,
            no_selection: ctx.storage_buffer_sized("no refinement selection", 16)?,
            kind,
            features,
            projection,
            vpl: if planes {
                None
            } else {
                Some(vpl_gather::VplGatherPass::new(ctx)?)
            },
            tail: std::sync::OnceLock::new(),
        })
    }

    /// Rays traced since the last call by planes that saw no light and were refined
    /// everywhere ([`refine::select_pixels`]), beyond [`CacheSettings::plane_rays_per_record`]:
    /// those of `passes` and their tail passes, read in one wait for the device (none when
    /// no pass refines), the counters then cleared.
    pub fn take_dark_plane_rays(ctx: &GpuContext, passes: &[&RecordPass]) -> Result<u64> {
        let refines: Vec<&refine::RefinePass> = passes
            .iter()
            .flat_map(|&pass| std::iter::once(pass).chain(pass.tail.get().map(|t| &**t)))
            .filter_map(|pass| pass.refine.as_ref())
            .collect();
        if refines.is_empty() {
            return Ok(0);
        }
        let counters: Vec<&wgpu::Buffer> = refines.iter().map(|r| r.dark_planes()).collect();
        let counts: Vec<Vec<u32>> = ctx.read_buffers(&counters)?;
        let mut rays = 0;
        for (r, count) in refines.iter().zip(&counts) {
            rays += u64::from(count.first().copied().unwrap_or(0)) * r.extra_rays_per_dark_plane();
            // Guided dark planes: their flagged pixels instead of the K by contrast.
            let flagged = u64::from(count.get(1).copied().unwrap_or(0));
            let guided = u64::from(count.get(2).copied().unwrap_or(0));
            rays += flagged * r.rays_per_guided_pixel();
            rays = rays.saturating_sub(guided * u64::from(r.refined()) * r.rays_per_guided_pixel());
            ctx.queue
                .write_buffer(r.dark_planes(), 0, bytemuck::bytes_of(&[0u32; 3]));
        }
        Ok(rays)
    }

    /// Selection slots per record of its refinement (`max(K, 1)`; 0 without refinement):
    /// how [`RefinedPlanes::selected`] is laid out.
    pub fn refine_slots(&self) -> u32 {
        self.refine.as_ref().map_or(0, |r| r.slots())
    }

    /// Whether this pass refines its planes ([`refine`]): by contrast, or dark planes alone.
    pub fn refines(&self) -> bool {
        self.refine.is_some()
    }

    /// Whether this pass refines lit planes too (by contrast, `plane_refine` > 0): only
    /// then does a lit record differ from its plane as traced, which temporal caching's
    /// tau must then be taken against (`temporal::Lookahead`). A plane refined because it
    /// was dark has nothing for the estimate to compare with.
    pub fn refines_by_contrast(&self) -> bool {
        self.refine.as_ref().is_some_and(|r| r.refined() > 0)
    }

    /// The pass that computes tail fill's records ([`CacheSettings::tail_plane_resolution`]):
    /// this one when their planes are not coarser (radiance and VPL records, no tail).
    pub fn tail_pass(&self, ctx: &GpuContext) -> Result<&RecordPass> {
        let tail_resolution = self.settings.tail_plane_resolution();
        if self.kind != RecordKind::Irradiance
            || self.settings.source != RecordSource::Planes
            || tail_resolution >= self.settings.plane_resolution
        {
            return Ok(self);
        }
        if let Some(pass) = self.tail.get() {
            return Ok(pass);
        }
        let tail_settings = CacheSettings {
            plane_resolution: tail_resolution,
            ..self.settings.clone()
        };
        let pass = Self::for_scene(ctx, &tail_settings, self.kind, self.features)?;
        Ok(self.tail.get_or_init(|| Box::new(pass)))
    }

    /// The name [`Self::for_scene`] had while the features were only kinds of light.
    #[deprecated(note = "renamed `for_scene`")]
    pub fn for_lights(
        ctx: &GpuContext,
        settings: &CacheSettings,
        kind: RecordKind,
        features: SceneFeatures,
    ) -> Result<Self> {
        Self::for_scene(ctx, settings, kind, features)
    }

    /// The name [`Self::check_features`] had while the features were only kinds of light.
    #[deprecated(note = "renamed `check_features`")]
    pub fn check_lights(&self, scene: &GpuScene) -> Result<()> {
        self.check_features(scene)
    }

    /// The scene features its plane pipelines were compiled for (the bounce cache its
    /// settings make included).
    pub fn features(&self) -> SceneFeatures {
        self.features
    }

    /// Refuses a scene with a feature this pass's plane pipelines were not compiled for
    /// ([`Self::for_scene`]): its hits would be shaded without that light, or its rays
    /// would not enter its instances.
    pub fn check_features(&self, scene: &GpuScene) -> Result<()> {
        self.features
            .require(scene.features(), "record pass", "RecordPass::for_scene")
    }

    /// Sites for the visibility-buffer `pixels` (one per new record, in order), computed on
    /// the GPU; `first_record` is the index the first of them will get.
    pub fn sites_from_pixels(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        pixels: &[u32],
        first_record: u32,
    ) -> Result<wgpu::Buffer> {
        let count = pixels.len() as u32;
        let params = ctx.uniform_buffer(
            "site params",
            &SiteParams {
                count,
                first_record,
                r_min_pixels: self.settings.r_min_pixels,
                accuracy: self.settings.accuracy,
                r_min_world: self.settings.r_min_scene * scene.diagonal,
                _pad: [0; 3],
            },
        );
        let pixel_buf = ctx.storage_buffer("site pixels", pixels)?;
        let sites = ctx.storage_buffer_sized(
            "record sites",
            u64::from(count) * std::mem::size_of::<RecordSite>() as u64,
        )?;
        let bind = self.sites.bind(
            ctx,
            &[
                &params,
                &vis.camera_buffer,
                &vis.samples,
                &pixel_buf,
                &sites,
            ],
        );
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.sites.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            [count.div_ceil(64), 1, 1],
            None,
        );
        ctx.queue.submit([enc.finish()]);
        Ok(sites)
    }

    /// Computes records for `count` sites (a buffer of [`RecordSite`]) and appends them to
    /// `cache`; `on_batch` is called after each batch with the number done. Returns the
    /// per-pass GPU times. Each batch goes to the settings' [`RecordSource`]: VPL records
    /// are one gather (`vpl_gather.wgsl`); plane records are traced, refined, projected
    /// (radiance records) and reduced. A `stage` (temporal caching of plane records) runs
    /// inside each batch ([`RecordStage`]): it may replace the tracing, read the planes and
    /// their hits, and reduce more planes.
    #[allow(clippy::too_many_arguments)]
    pub fn compute(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &wgpu::Buffer,
        count: u32,
        cache: &mut RecordCache,
        light_maps: Option<&LightMaps>,
        mut stage: Option<&mut (dyn RecordStage + '_)>,
        mut on_batch: impl FnMut(u32),
    ) -> Result<Vec<(&'static str, f64)>> {
        self.check_features(scene)?;
        let light_maps = light_maps.unwrap_or(&self.no_light_maps);
        if self.vpl.is_some() && stage.is_some() {
            return Err(Error::Usage(
                "records from VPLs (--records vpl) do not work with temporal caching yet: \
                 use --records planes or --temporal off"
                    .into(),
            ));
        }
        if cache.kind != self.kind {
            return Err(Error::Usage(format!(
                "internal: a pass for {} appends to a cache of {}",
                self.kind.describe(),
                cache.kind.describe()
            )));
        }
        cache.reserve(ctx, count)?;
        let res = self.settings.plane_resolution;
        // Sized to this call's largest batch: small placement rounds stay small.
        let batch_records = self.batch.min(count.max(1));
        // VPL records trace no planes.
        let plane_pixels = if self.vpl.is_some() { 1 } else { res * res };
        let batch_samples = u64::from(batch_records) * u64::from(plane_pixels);
        let samples = ctx.storage_buffer_sized("plane samples", batch_samples * 16)?;
        // A stage (temporal caching) reads the hit of each sample.
        let record_hits = stage.is_some();
        let hits = ctx.storage_buffer_sized(
            "plane hits",
            if record_hits { batch_samples * 16 } else { 16 },
        )?;
        if let Some(st) = stage.as_deref_mut() {
            st.begin(ctx, cache, count, batch_records)?;
        }
        let selected = match &self.refine {
            Some(r) => {
                ctx.storage_buffer_sized("refined pixels", r.selected_bytes(batch_records))?
            }
            None => ctx.storage_buffer_sized("refined pixels", 16)?,
        };
        // Each sample's environment-sampled share, for refinement's selection.
        let noise = match &self.refine {
            Some(_) => Some(ctx.storage_buffer_sized("plane noise", batch_samples * 4)?),
            None => None,
        };
        // A stage reads the planes as traced beside their hits: refinement keeps a copy.
        let traced = if self.refine.is_some() && stage.is_some() {
            Some(ctx.storage_buffer_sized("traced plane samples", batch_samples * 16)?)
        } else {
            None
        };
        let mut times = Vec::new();
        let site_bytes = std::mem::size_of::<RecordSite>() as u64;
        let mut done = 0;
        while done < count {
            let n = (count - done).min(self.batch);
            // The batch's sites, as their own binding (offsets need 256-byte alignment).
            let batch_sites = ctx.storage_buffer_sized("batch sites", u64::from(n) * site_bytes)?;
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            enc.copy_buffer_to_buffer(
                sites,
                u64::from(done) * site_bytes,
                &batch_sites,
                0,
                u64::from(n) * site_bytes,
            );
            let batch = PlaneBatch {
                sites: &batch_sites,
                samples: &samples,
                traced: &samples,
                hits: &hits,
                first_record: cache.count,
                first_site: done,
                count: n,
            };
            let mut timer = crate::gpu::timer::PassTimer::new(ctx, 24);
            if let Some(vpl) = &self.vpl {
                // Records from VPLs: one gather writes them (RecordSource::Vpl).
                vpl.record(
                    ctx,
                    &mut enc,
                    scene,
                    &self.settings,
                    &batch_sites,
                    cache.count,
                    n,
                    &vpl_gather::GatherTarget::of(cache),
                    &mut timer,
                )?;
                timer.resolve(&mut enc);
                ctx.queue.submit([enc.finish()]);
                times.extend(timer.read(ctx)?);
                cache.count += n;
                done += n;
                on_batch(done);
                continue;
            }
            let replaced = match stage.as_deref_mut() {
                Some(st) => st.replace_tracing(
                    ctx,
                    &mut enc,
                    scene,
                    &self.settings,
                    &self.table,
                    &batch,
                    &mut timer,
                )?,
                None => false,
            };
            if !replaced {
                self.record_planes(
                    ctx,
                    &mut enc,
                    scene,
                    &batch,
                    record_hits,
                    noise.as_ref(),
                    light_maps,
                    timer.next("hemisphere planes"),
                );
            }
            // Refinement follows the planes however they were made: a refreshed plane is
            // its traced plane exactly (temporal caching's plane refresh), so refining it
            // gives the record a fresh trace would.
            if let Some(r) = &self.refine {
                if let Some(traced) = &traced {
                    enc.copy_buffer_to_buffer(
                        &samples,
                        0,
                        traced,
                        0,
                        u64::from(n) * u64::from(plane_pixels) * 16,
                    );
                }
                let noise = noise.as_ref().unwrap_or(&self.no_noise);
                if replaced {
                    // Refreshed planes keep no environment shares: rank them by plain
                    // contrast rather than by a previous batch's.
                    enc.clear_buffer(noise, 0, None);
                }
                r.record(
                    ctx,
                    &mut enc,
                    scene,
                    &self.plane,
                    &self.table,
                    &batch_sites,
                    &samples,
                    &selected,
                    noise,
                    n,
                    light_maps,
                    &mut timer,
                )?;
            }
            // Refined planes: the stage reads their traced copy beside the hits.
            let batch = match &traced {
                Some(traced) => PlaneBatch { traced, ..batch },
                None => batch,
            };
            if let Some(st) = stage.as_deref_mut() {
                st.planes_ready(ctx, &mut enc, &batch, res)?;
            }
            self.record_projection(
                ctx,
                &mut enc,
                scene,
                &batch_sites,
                &samples,
                &cache.coefficients,
                cache.count,
                n,
                false,
                &mut timer,
            );
            let reduction = ReductionBatch {
                sites: &batch_sites,
                first_record: cache.count,
                count: n,
            };
            self.record_reduction(
                ctx,
                &mut enc,
                scene,
                &self.table,
                &reduction,
                &samples,
                &cache.buffer,
                &mut timer,
            )?;
            self.record_radiance_limit(
                ctx,
                &mut enc,
                scene,
                &cache.buffer,
                &cache.coefficients,
                cache.count,
                n,
                &mut timer,
            );
            if let Some(st) = stage.as_deref_mut() {
                st.reduced(ctx, &mut enc, scene, self, &batch, &mut timer)?;
            }
            timer.resolve(&mut enc);
            ctx.queue.submit([enc.finish()]);
            times.extend(timer.read(ctx)?);
            cache.count += n;
            if let Some(st) = stage.as_deref_mut() {
                st.batch_done(n);
            }
            done += n;
            on_batch(done);
        }
        Ok(times)
    }

    /// Records the HSH projection (`radiance_project.wgsl`) of `count` planes of this
    /// pass's resolution in `samples`, traced from `sites`, into the coefficient blocks of
    /// records `first_record..` of `coefficients`; nothing for irradiance records. Stages
    /// project their own planes with it (temporal caching: the planes estimated at t+1);
    /// `values_only` leaves the coefficients' gradients out (and their floats as they are).
    #[allow(clippy::too_many_arguments)]
    pub fn record_projection(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        sites: &wgpu::Buffer,
        samples: &wgpu::Buffer,
        coefficients: &wgpu::Buffer,
        first_record: u32,
        count: u32,
        values_only: bool,
        timer: &mut crate::gpu::timer::PassTimer,
    ) {
        if let Some(projection) = &self.projection {
            projection.record(
                ctx,
                enc,
                scene,
                sites,
                samples,
                coefficients,
                first_record,
                count,
                values_only,
                timer.next("radiance projection"),
            );
        }
    }

    /// Records Ward's gradient limit on radiance records `first_record..first_record +
    /// count` of `records` and `coefficients` (`radiance_limit.wgsl`,
    /// [`radiance_projection::limit_gradients`]) after their projection and reduction;
    /// nothing for irradiance records or without gradients. Stages that project gradients
    /// of their own limit them with it.
    #[allow(clippy::too_many_arguments)]
    pub fn record_radiance_limit(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        records: &wgpu::Buffer,
        coefficients: &wgpu::Buffer,
        first_record: u32,
        count: u32,
        timer: &mut crate::gpu::timer::PassTimer,
    ) {
        if let Some(projection) = &self.projection
            && self.settings.gradients
        {
            projection.record_limit(
                ctx,
                enc,
                scene,
                records,
                coefficients,
                first_record,
                count,
                // The records' own accuracy (the radiance accuracy, `record_settings`).
                self.settings.accuracy,
                timer.next("radiance limit"),
            );
        }
    }

    /// Records the plane pass (`hemisphere_plane.wgsl`) for `batch`: its samples, and with
    /// `record_hits` what each sample hit.
    #[allow(clippy::too_many_arguments)]
    fn record_planes(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        batch: &PlaneBatch<'_>,
        record_hits: bool,
        noise: Option<&wgpu::Buffer>,
        light_maps: &LightMaps,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let res = self.settings.plane_resolution;
        let plane_params = ctx.uniform_buffer(
            "plane params",
            &PlaneParams {
                resolution: res,
                count: batch.count,
                light_samples: self.settings.plane_light_samples,
                record_hits: u32::from(record_hits),
                light_choices: self.settings.plane_light_choices,
                record_noise: u32::from(noise.is_some()),
                mode: PlaneParams::TRACE,
                ..PlaneParams::zeroed()
            },
        );
        let plane_bind = self.plane.bind(
            ctx,
            &[
                &plane_params,
                batch.sites,
                &self.table.pixels,
                batch.samples,
                batch.hits,
                &light_maps.maps_buffer,
                &light_maps.depths,
                &light_maps.first_buffer,
                &scene.bounce_cache(),
                noise.unwrap_or(&self.no_noise),
                &self.no_selection,
            ],
        );
        self.plane.record(
            enc,
            &scene.bind_group,
            &plane_bind,
            [(res * res).div_ceil(64), 1, batch.count],
            timestamps,
        );
    }

    /// Records the reduction of a batch's planes (`table`'s resolution, in `samples`) into
    /// `records` (`record_reduce.wgsl`). Stages reduce their own planes with it (temporal
    /// caching: the planes estimated at t+1 into the records at t+1).
    #[allow(clippy::too_many_arguments)]
    pub fn record_reduction(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        table: &PlaneTable,
        batch: &ReductionBatch<'_>,
        samples: &wgpu::Buffer,
        records: &wgpu::Buffer,
        timer: &mut crate::gpu::timer::PassTimer,
    ) -> Result<()> {
        let built = if self.settings.neighbour_clamp {
            self.neighbour_grid.record(
                ctx,
                enc,
                scene,
                records,
                batch.first_record,
                timer.next("neighbour grid"),
            )?
        } else {
            None
        };
        let grid = built.as_ref().unwrap_or(&self.neighbour_grid.disabled);
        let params = ctx.uniform_buffer(
            "reduce params",
            &ReduceParams {
                resolution: table.resolution,
                count: batch.count,
                first_record: batch.first_record,
                gradients: u32::from(self.settings.gradients),
                r_max_factor: self.settings.r_max_factor,
                cos_weight_sum: table.cos_weight_sum,
                neighbour_clamp: u32::from(self.settings.neighbour_clamp),
                hessian_scale: self.settings.record_radius.hessian_scale(),
            },
        );
        let bind = self.reduce.bind(
            ctx,
            &[
                &params,
                batch.sites,
                &table.pixels,
                samples,
                records,
                &grid.params,
                &grid.offsets,
                &grid.records,
            ],
        );
        self.reduce.record(
            enc,
            &scene.bind_group,
            &bind,
            [batch.count, 1, 1],
            timer.next("record reduction"),
        );
        Ok(())
    }

    /// Traces the planes of `sites` and refines them as the settings say: the traced
    /// (coarse) planes, the refined ones and each site's `max(K, 1)` selection slots
    /// (the K pixels refined by contrast, or `DARK_PLANE`; tests).
    /// Without refinement the refined planes are the coarse ones and no pixel is listed.
    pub fn trace_planes_refined(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
    ) -> Result<RefinedPlanes> {
        self.trace_planes_refined_with(ctx, scene, sites, &self.no_light_maps)
    }

    /// [`Self::trace_planes_refined`] with the plane hits shadowed by `light_maps` (and
    /// dark planes refined near their lit grid's lit surfaces where it sees them all).
    pub fn trace_planes_refined_with(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
        light_maps: &LightMaps,
    ) -> Result<RefinedPlanes> {
        let Some(r) = &self.refine else {
            let coarse = self.trace_planes(ctx, scene, sites)?;
            return Ok(RefinedPlanes {
                refined: coarse.clone(),
                noise: vec![0.0; coarse.len()],
                coarse,
                selected: Vec::new(),
            });
        };
        let res = self.settings.plane_resolution;
        let n = sites.len() as u32;
        let samples_len = (n * res * res) as usize;
        let noise = ctx.storage_buffer_sized("plane noise", (samples_len as u64 * 4).max(16))?;
        let (coarse, ()) = self.trace_planes_with(
            ctx,
            scene,
            sites,
            false,
            Some(&noise),
            light_maps,
            |_, _| Ok(()),
        )?;
        let mut noise_values: Vec<f32> = ctx.read_buffer(&noise)?;
        noise_values.truncate(samples_len);
        let sites_buf = ctx.storage_buffer("record sites", sites)?;
        let samples = ctx.storage_buffer("plane samples", &coarse)?;
        let selected = ctx.storage_buffer_sized("refined pixels", r.selected_bytes(n).max(4))?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let mut timer = crate::gpu::timer::PassTimer::new(ctx, 3);
        r.record(
            ctx,
            &mut enc,
            scene,
            &self.plane,
            &self.table,
            &sites_buf,
            &samples,
            &selected,
            &noise,
            n,
            light_maps,
            &mut timer,
        )?;
        ctx.queue.submit([enc.finish()]);
        let mut refined: Vec<PlaneSample> = ctx.read_buffer(&samples)?;
        refined.truncate(coarse.len());
        let mut selected: Vec<u32> = ctx.read_buffer(&selected)?;
        selected.truncate((n * r.slots()) as usize);
        Ok(RefinedPlanes {
            coarse,
            refined,
            noise: noise_values,
            selected,
        })
    }

    /// Traces the planes of `count` sites and returns their samples, unrefined (tests,
    /// Table 4.1; [`RecordPass::trace_planes_refined`] refines them).
    pub fn trace_planes(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
    ) -> Result<Vec<PlaneSample>> {
        Ok(self
            .trace_planes_then(ctx, scene, sites, false, |_, _| Ok(()))?
            .0)
    }

    /// Traces the planes of `sites` (at most one batch), with `record_hits` also what each
    /// sample hit, and lets `then` record more work on the planes in the same submission
    /// (temporal caching's reprojection, `temporal::trace_planes_ahead`). Returns the
    /// samples, unrefined, and what `then` returned.
    pub fn trace_planes_then<T>(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
        record_hits: bool,
        then: impl FnOnce(&mut wgpu::CommandEncoder, &PlaneBatch<'_>) -> Result<T>,
    ) -> Result<(Vec<PlaneSample>, T)> {
        self.trace_planes_with(
            ctx,
            scene,
            sites,
            record_hits,
            None,
            &self.no_light_maps,
            then,
        )
    }

    /// [`Self::trace_planes_then`], with `noise` also receiving each sample's
    /// environment-sampled share (`hemisphere_plane.wgsl`).
    #[allow(clippy::too_many_arguments)]
    fn trace_planes_with<T>(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
        record_hits: bool,
        noise: Option<&wgpu::Buffer>,
        light_maps: &LightMaps,
        then: impl FnOnce(&mut wgpu::CommandEncoder, &PlaneBatch<'_>) -> Result<T>,
    ) -> Result<(Vec<PlaneSample>, T)> {
        self.check_features(scene)?;
        let res = self.settings.plane_resolution;
        let n = sites.len() as u32;
        if n > self.batch {
            return Err(Error::Usage(format!(
                "trace_planes: {n} sites exceed the batch of {}",
                self.batch
            )));
        }
        let sites_buf = ctx.storage_buffer("record sites", sites)?;
        let plane_bytes = u64::from(n) * u64::from(res * res) * 16;
        let samples = ctx.storage_buffer_sized("plane samples", plane_bytes)?;
        let hits =
            ctx.storage_buffer_sized("plane hits", if record_hits { plane_bytes } else { 16 })?;
        let batch = PlaneBatch {
            sites: &sites_buf,
            samples: &samples,
            traced: &samples,
            hits: &hits,
            first_record: 0,
            first_site: 0,
            count: n,
        };
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.record_planes(
            ctx,
            &mut enc,
            scene,
            &batch,
            record_hits,
            noise,
            light_maps,
            None,
        );
        let out = then(&mut enc, &batch)?;
        ctx.queue.submit([enc.finish()]);
        let mut now: Vec<PlaneSample> = ctx.read_buffer(&samples)?;
        now.truncate((n * res * res) as usize);
        Ok((now, out))
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

    /// A record on a floor (normal +y) 0.1 m from the end of a wall, its corral from the
    /// horizontal distances at which its vertices' directions meet the wall.
    fn record_beside(wall: impl Fn(glam::Vec3) -> Option<f32>) -> super::Record {
        use super::{CORRAL_SECTORS, Record, corral_words};
        let mut r: Record = bytemuck::Zeroable::zeroed();
        r.normal = [0.0, 1.0, 0.0];
        r.radius = 1.0;
        r.irradiance = [1.0; 3];
        let base = crate::sampling::orthonormal_basis(glam::Vec3::Y);
        let mut h = [-1.0f32; CORRAL_SECTORS as usize];
        for (b, h) in h.iter_mut().enumerate() {
            let angle =
                b as f32 * std::f32::consts::TAU / CORRAL_SECTORS as f32 - std::f32::consts::PI;
            let dir = angle.cos() * base.x_axis + angle.sin() * base.y_axis;
            *h = wall(dir).unwrap_or(-1.0);
        }
        r.set_corral(corral_words(&h, r.radius));
        r
    }

    #[test]
    fn the_corral_keeps_a_record_from_beyond_a_wall_and_not_from_along_it() {
        use glam::Vec3;
        // A wall along z at x = 0.1, as long as the floor: every direction with x > 0
        // meets it at 0.1 / x.
        let r = record_beside(|d| (d.x > 1e-3).then(|| 0.1 / d.x));
        assert!(r.corral() != [0, 0]);
        // Beyond the wall: cut off (the corral rounds its vertices in, to 1/16 R here).
        assert!(!r.corral_allows(Vec3::new(0.3, 0.0, 0.0)));
        assert!(!r.corral_allows(Vec3::new(0.3, 0.0, 0.2)));
        // In front of it, along it and away from it: kept.
        assert!(r.corral_allows(Vec3::new(0.05, 0.0, 0.0)));
        assert!(r.corral_allows(Vec3::new(0.02, 0.0, 0.8)));
        assert!(r.corral_allows(Vec3::new(0.02, 0.0, -0.8)));
        assert!(r.corral_allows(Vec3::new(-0.6, 0.0, 0.3)));
        // Ward's test with the corral: the pixel beyond is not reached, the one along is.
        assert!(!r.reaches(Vec3::new(0.2, 0.0, 0.0), Vec3::Y, 0.25));
        assert!(r.reaches(Vec3::new(0.0, 0.0, 0.2), Vec3::Y, 0.25));

        // The end of a wall (the wall for z > 0 only, its end 0.02 beside the record): the
        // floor in front of its far side (x > 0.1, z < 0) is cut off where the segment from
        // the record crosses the wall, the floor past its end (z < -0.2) is not.
        let end = record_beside(|d| (d.x > 1e-3).then(|| 0.1 / d.x).filter(|t| d.z * t > 0.02));
        assert!(!end.corral_allows(Vec3::new(0.3, 0.0, 0.3)));
        assert!(end.corral_allows(Vec3::new(0.3, 0.0, -0.4)));
        assert!(end.corral_allows(Vec3::new(-0.3, 0.0, 0.3)));
        // Nothing near: no corral, every pixel kept.
        let open = record_beside(|_| None);
        assert_eq!(open.corral(), [0, 0]);
        assert!(open.corral_allows(Vec3::new(0.9, 0.0, 0.0)));
    }

    #[test]
    fn corral_sectors_follow_the_angle_and_the_directions_table() {
        use super::{CORRAL_DIRECTIONS, corral_sector, corral_turn};
        for k in 0..720 {
            // Away from the sectors' edges, the sector is the whole part of the turn.
            let angle = (k as f32 + 0.37) * std::f32::consts::TAU / 720.0 - std::f32::consts::PI;
            let (u, v) = (2.5 * angle.cos(), 2.5 * angle.sin());
            let turn = corral_turn(u, v);
            if (turn - turn.round()).abs() > 1e-3 {
                assert_eq!(corral_sector(u, v), turn.floor() as u32, "angle {angle}");
            }
        }
        for (b, d) in CORRAL_DIRECTIONS.iter().enumerate() {
            let turn = corral_turn(d[0], d[1]);
            let expected = if b == 0 { 16.0 } else { b as f32 };
            assert!((turn - expected).abs() < 1e-4, "vertex {b}: turn {turn}");
        }
    }

    #[test]
    fn corral_levels_round_in_and_fit_an_f32() {
        use super::{CORRAL_DISTANCE, corral_level};
        for &h in &[0.0f32, 0.01, 0.07, 0.13, 0.2, 0.3, 0.45, 0.6, 0.8, 0.99] {
            let level = corral_level(h, 1.0);
            assert!((1..8).contains(&level), "h {h}: level {level}");
            // Rounded in (the nearest vertex, R / 16, may lie past a nearer hit).
            assert!(CORRAL_DISTANCE[level as usize] <= h.max(CORRAL_DISTANCE[1]));
        }
        assert_eq!(corral_level(1.0, 1.0), 0);
        assert_eq!(corral_level(-1.0, 1.0), 0);
        let words = super::corral_words(&[0.0; 16], 1.0);
        assert!(words.iter().all(|&w| w < 1 << 24));
    }
}
