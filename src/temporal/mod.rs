//! Temporal radiance caching (seed 000, thesis chapter 5, algorithms.md section 4):
//! records live over several frames. Every new record is also estimated at the next frame
//! by reprojecting its plane ([`ReprojectionPass`]); `tau = E(t+1) / E(t)` gives its
//! lifespan (`w_t = 1 / (|tau - 1| (t - t_k)) >= 1 / a_t` and `t - t_k < dt_max`,
//! decision 9) and the extrapolated temporal gradient. Records keep their world position;
//! an expired record that covers pixels of the new frame is replaced by a new record at
//! the same place, one that covers none is deleted ([`Replacement`]; the seed asks the
//! record's last frame instead). With [`RecordAnchor::Instance`] records move with the
//! instance they lie on instead ([`motion`]). Radiance records (glossy lobes) live by the
//! same rules in a second cache of this type beside the irradiance one ([`radiance`]:
//! tau, gradients and motion of their coefficient blocks).

pub mod animation;
pub mod buried;
pub mod estimate_error;
pub mod estimate_rule;
pub mod horizon;
pub mod instant;
pub mod lookahead;
pub mod motion;
pub mod plane_refresh;
pub mod radiance;
pub mod reference;
pub mod reprojection;

pub use estimate_rule::EstimateMode;
pub use lookahead::{Lookahead, PlanesAhead, RefreshStage, trace_planes_ahead};
pub use motion::{InstanceMotion, RecordAnchor};
pub use reprojection::{NextFrame, ReprojectionPass};

use crate::frame::{
    CachedFrameOptions, Frame, PreparedScene, RadianceCache, RadianceFrame, Renderer,
};
use crate::gpu::{GpuContext, SceneFeatures};
use crate::records::{
    CacheSettings, Record, RecordCache, RecordKind, RecordPass, RecordSite, RecordStage,
};
use crate::scene::{Camera, Scene};
use crate::splat::radiance::RadianceSplatPass;
use crate::visibility::VisibilityBuffer;
use crate::{Error, Result};
use glam::Mat4;
use std::collections::{HashSet, VecDeque};

/// The longest record lifespan accepted, in frames (45 minutes of animation at 24 frames
/// a second): per-frame statistics hold a bin per frame of lifespan (4294967295 asked for
/// 17 GB).
pub const MAX_LIFESPAN: u32 = 1 << 16;

/// Settings of temporal caching (decision 9; CLI `animate`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TemporalSettings {
    /// Temporal accuracy a_t: a record lives while `|tau - 1| (t - t_k) <= a_t`.
    pub accuracy: f32,
    /// dt_max: no record lives this many frames or more (1: recompute every frame).
    pub max_lifespan: u32,
    pub gradients: TemporalGradients,
    /// Where records stay while the scene moves (the thesis: world).
    pub anchor: RecordAnchor,
    /// Whether replacements refresh their predecessor's plane (trace again only what
    /// motion may have changed) instead of tracing it all: the same bytes for fewer rays
    /// (the test compares 8 frames; 60-frame cube sequences are byte-identical too).
    pub plane_refresh: RefreshMode,
    /// Most bytes of retained planes (for `plane_refresh`); records beyond it are traced.
    pub plane_budget_bytes: u64,
    /// Which expired records are replaced at the same place.
    pub replacement: Replacement,
    /// The E(t+1) estimate reprojects every `estimate_stride`-th plane sample each way
    /// (1: all). With interpolated gradients the estimate only gives tau (the ratio of
    /// E(t+1) to E(t) over the same samples), so 2 costs a quarter; extrapolated gradients
    /// then extrapolate the record by that ratio instead of by its own estimate. None:
    /// [`TemporalSettings::estimate_stride_for`] chooses.
    pub estimate_stride: Option<u32>,
    /// At most this many new records placed per frame (replacements are not counted);
    /// pixels left uncovered get records in later frames. Spreads the cost of a
    /// walkthrough's new views over frames. None: every uncovered pixel gets one.
    pub max_new_records: Option<u32>,
    /// Irradiance records' planes are refined as the cache settings say
    /// (`CacheSettings::plane_refine`; radiance records' never are). Off by default: on
    /// glossy Spheres 96x72 it lowers the error from 0.95 to 0.93 % and the flicker from
    /// 0.52 to 0.51 % for 16 % more time (with the even planes of stop 43: 1.28 to 1.11 %
    /// for 20 %; docs/results.md, "Refined planes under temporal caching" and stop 44).
    pub refine_planes: bool,
    /// Whether new records are estimated at t+1 every frame or only while the estimates
    /// win more frames of life than they cost ([`estimate_rule`]; the default, Auto).
    pub estimates: EstimateMode,
    /// How long records on an instance that moves from t to t+1 live.
    pub mover_records: MoverRecords,
}

/// How long a record on a moving instance lives ([`TemporalSettings::mover_records`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum MoverRecords {
    /// The frame it is computed in only (the default): the instance's next position gets
    /// a fresh record. The seed leaves records where they were computed, so a record on a
    /// moving object serves the frame it was made for and then the empty space the object
    /// left; carried with its instance ([`RecordAnchor::Instance`]) it can stay, but its
    /// reuse is what made moving objects flicker: on glossy Spheres 96x72 (frames 0..5,
    /// 1,024-spp references) the frame-to-frame change error on moving balls was 0.60 %
    /// with reuse and 0.30 % without (per-frame recomputation 0.18 %), unchanged pixels
    /// 0.56 % either way (docs/results.md, "Cosine-spaced planes and one-frame records on
    /// moving instances").
    OneFrame,
    /// As long as tau and dt_max allow, like every other record.
    ByChange,
}

/// When replacements refresh their predecessor's plane ([`plane_refresh`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum RefreshMode {
    Off,
    On,
    /// On while refreshing saves at least [`AUTO_REFRESH_MIN_SAVED`] of the plane rays
    /// of the records computed in frames with replacements (judged once
    /// [`AUTO_REFRESH_MIN_PLANES`] planes were refreshed); then off for the rest of the
    /// sequence, because retaining every plane and selecting what to trace again cost more
    /// than the rays saved. Cube in a box saved 52 % (refresh 1.2x faster), spheres 6 %
    /// (refresh 1.17x slower: few replacements are unmoved and 66 movers make selecting
    /// costly). Decided from exact counts, so runs stay deterministic; the images are the
    /// same bytes either way.
    Auto,
}

/// Refreshed planes [`RefreshMode::Auto`] waits for before judging.
pub const AUTO_REFRESH_MIN_PLANES: u64 = 64;
/// Fraction of plane rays [`RefreshMode::Auto`] needs refreshing to save.
pub const AUTO_REFRESH_MIN_SAVED: f64 = 0.2;

/// Which expired records are recomputed at the same place (the others are deleted; any
/// pixel left uncovered gets a new record from placement). Whatever the rule, a record
/// whose site an object that moved since its birth now covers is deleted ([`buried`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Replacement {
    /// Those that contributed to any pixel in their last frame (seed 000 section V-c, with
    /// coverage counts instead of occlusion queries).
    Covering,
    /// Those that contribute to a pixel of the frame their replacement would serve: the
    /// expired record, where it would be now, splatted over this frame's visibility
    /// buffer. The seed asks the record's last frame because its occlusion queries came
    /// back a frame late; the visibility buffer of this frame is at hand before any record
    /// is computed. On spheres a quarter of the records the seed's rule replaced covered
    /// nothing in their first frame (docs/results.md).
    Visible,
    /// Those that contribute to a pixel of this frame that no record kept from the last
    /// frame contributes to. Records that only overlap longer-lived ones go, so the cache
    /// does not grow denser than placement would make it.
    Needed,
}

impl Default for TemporalSettings {
    /// The seed's cube-in-a-box values: a_t = 0.05, dt_max = 20.
    fn default() -> Self {
        Self {
            accuracy: 0.05,
            max_lifespan: 20,
            gradients: TemporalGradients::Interpolated,
            anchor: RecordAnchor::Instance,
            plane_refresh: RefreshMode::Auto,
            plane_budget_bytes: 512 << 20,
            replacement: Replacement::Visible,
            estimate_stride: None,
            max_new_records: None,
            refine_planes: false,
            estimates: EstimateMode::Auto,
            mover_records: MoverRecords::OneFrame,
        }
    }
}

impl TemporalSettings {
    /// Takes a_t and dt_max from, in order: `accuracy` / `max_lifespan` when given (the
    /// command line), else the scene's `[animation]` values, else keeps its own.
    pub fn apply_scene(
        &mut self,
        animation: Option<&crate::scene::Animation>,
        accuracy: Option<f32>,
        max_lifespan: Option<u32>,
    ) {
        if let Some(a) = accuracy.or(animation.and_then(|a| a.temporal_accuracy)) {
            self.accuracy = a;
        }
        if let Some(d) = max_lifespan.or(animation.and_then(|a| a.max_lifespan)) {
            self.max_lifespan = d;
        }
    }

    /// Whether radiance records' estimates at t+1 carry coefficient values only
    /// (`Lookahead::values_only`): with interpolated gradients an estimate only gives tau,
    /// a function of the values, and a record with no successor extrapolates with its own
    /// translational gradients ([`radiance::keep_gradients`]).
    pub fn estimates_values_only(&self) -> bool {
        self.gradients == TemporalGradients::Interpolated
    }

    /// The estimate stride for planes of `plane_resolution` pixels: the one set, else 2
    /// with interpolated gradients where it divides the plane into at least 4 cells each
    /// way, else 1. With 2, spheres (20 frames) ran 1.15x faster, moving light 1.25x and
    /// cube in a box 1.11x (60 frames), with RMSE and flicker within 0.03 percentage points
    /// (docs/results.md).
    pub fn estimate_stride_for(&self, plane_resolution: u32) -> u32 {
        match self.estimate_stride {
            Some(stride) => stride,
            None if self.gradients == TemporalGradients::Interpolated
                && plane_resolution.is_multiple_of(2)
                && plane_resolution >= 8 =>
            {
                2
            }
            None => 1,
        }
    }

    pub fn validate(&self) -> Result<()> {
        if !(self.accuracy.is_finite() && self.accuracy > 0.0) {
            return Err(Error::Usage(format!(
                "temporal accuracy must be a positive number, not {}",
                self.accuracy
            )));
        }
        if !(1..=MAX_LIFESPAN).contains(&self.max_lifespan) {
            return Err(Error::Usage(format!(
                "the maximum record lifespan (--max-lifespan, or the scene's \
                 animation.max_lifespan) must be from 1 to {MAX_LIFESPAN} frames, not {}",
                self.max_lifespan
            )));
        }
        if self.max_new_records == Some(0) {
            return Err(Error::Usage(
                "the most new records per frame must be at least 1, not 0 (none: no cap)".into(),
            ));
        }
        Ok(())
    }
}

/// The instance a record moves with ([`RecordAnchor::Instance`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    pub instance: u32,
    /// The instance's transform at the record's first frame.
    pub transform: Mat4,
}

impl Anchor {
    /// The motion carrying a record from its first frame to a frame where the instance's
    /// transform is `now` (the identity, exactly, when the instance has not moved).
    pub fn motion_to(&self, now: Mat4) -> Mat4 {
        if now == self.transform {
            Mat4::IDENTITY
        } else {
            now * self.transform.inverse()
        }
    }
}

/// One record over its life (CPU side; the GPU holds the records of the current frame).
#[derive(Clone, Copy, Debug)]
pub struct TemporalRecord {
    /// The record as computed at its first frame (world space at that frame).
    pub record: Record,
    /// Its estimate at the next frame (reprojection); equal to `record` when the scene
    /// does not change.
    pub next: Record,
    /// First frame t_k.
    pub birth: u32,
    /// Last frame it is used in (inclusive).
    pub last_frame: u32,
    /// Temporal irradiance ratio tau = Y(E(t_k + 1)) / Y(E(t_k)) (luminance); for
    /// radiance records `1 + delta` ([`radiance::coefficient_ratio`]); NaN for a record
    /// not estimated ([`estimate_rule`]).
    pub tau: f32,
    /// The record that replaced this one at the same place, once it expired.
    pub successor: Option<u32>,
    /// Its life ends where a light leaves the course its estimate saw, or an object that
    /// stood still starts ([`horizon`]): its successor, born after that break, is not
    /// interpolated towards (a light switched on at the break would fade in over the
    /// record's whole life, before it is on); it keeps its own extrapolated gradient
    /// instead. (Ends by moving objects are not breaks.)
    pub before_break: bool,
    /// The instance it moves with; None: it keeps its world position.
    pub anchor: Option<Anchor>,
    /// Where its plane was traced from (its successor inherits it while the record has
    /// not moved); None when it was computed without a next frame.
    pub site: Option<RecordSite>,
}

fn lerp<const N: usize>(a: &mut [f32; N], b: [f32; N], f: f32) {
    for c in 0..N {
        a[c] += (b[c] - a[c]) * f;
    }
}

impl TemporalRecord {
    /// Whether a range closed at frame `end` replaces this record there
    /// ([`TemporalCache::close_range_at`]): it is two or more frames old (one frame old,
    /// its estimate is of `end`).
    fn closes_at(&self, end: u32) -> bool {
        self.birth + 2 <= end
    }

    /// The record at frame `t` with the extrapolated temporal gradient (seed 000 eqs.
    /// 14-17): every irradiance and gradient term moves by (next - record) per frame.
    /// Where it lies: its place at its first frame.
    pub fn at(&self, t: u32) -> Record {
        let dt = t.saturating_sub(self.birth) as f32;
        if dt == 0.0 {
            return self.record;
        }
        Self::blend(&self.record, &self.next, dt)
    }

    /// The record at frame `t` with the interpolated temporal gradient (seed 000 eqs.
    /// 18-20): between this record and its successor `l` at the same place,
    /// `E + (E_l - E) (t - t_k) / (t_l - t_k)` for irradiance and both gradients.
    /// `successor.record` must be given at this record's place at its first frame.
    pub fn interpolated(&self, t: u32, successor: &TemporalRecord) -> Record {
        let span = successor.birth.saturating_sub(self.birth).max(1) as f32;
        let f = t.saturating_sub(self.birth) as f32 / span;
        Self::blend(&self.record, &successor.record, f)
    }

    /// `from` with irradiance and both gradients moved the fraction `f` towards `to`; its
    /// corral stays `from`'s (an integer bit field, not a quantity to interpolate).
    fn blend(from: &Record, to: &Record, f: f32) -> Record {
        let mut r = *from;
        lerp(&mut r.irradiance, to.irradiance, f);
        for c in 0..3 {
            lerp(&mut r.rotation_gradient[c], to.rotation_gradient[c], f);
            lerp(
                &mut r.translation_gradient[c],
                to.translation_gradient[c],
                f,
            );
        }
        r.set_corral(from.corral());
        r
    }
}

/// How records change over their lifespan (seed 000 section IV-F).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum TemporalGradients {
    /// From the record's own E(t+1) estimate: one pass.
    Extrapolated,
    /// Towards the record that replaces it: two passes (records of the whole range
    /// first), continuous in time. The default for animations.
    Interpolated,
}

fn luminance(e: [f32; 3]) -> f32 {
    0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]
}

/// tau = Y(E(t+1)) / Y(E(t)) of a record's irradiance `now` and its estimate at t+1
/// (seed 000 eqs. 6-8): infinite for a record born in the dark that lights up, 1 when
/// both are dark.
pub fn temporal_ratio(now: [f32; 3], next: [f32; 3]) -> f32 {
    let (e0, e1) = (luminance(now), luminance(next));
    if e0 > 0.0 {
        e1 / e0
    } else if e1 > 0.0 {
        f32::INFINITY
    } else {
        1.0
    }
}

/// A record at t+1 from an estimate over a subset of its plane (estimate stride > 1):
/// `record` with irradiance and gradients scaled, channel by channel, by the change of the
/// subset (`estimate / subset`); a channel whose subset is dark takes the estimate's
/// irradiance. Equal to `record` when the estimate equals the subset.
pub fn scaled_by_estimate(record: &Record, subset: &Record, estimate: &Record) -> Record {
    let mut r = *record;
    for c in 0..3 {
        let (e0, e1) = (subset.irradiance[c], estimate.irradiance[c]);
        if e0 > 0.0 {
            let ratio = e1 / e0;
            r.irradiance[c] *= ratio;
            for k in 0..3 {
                r.rotation_gradient[c][k] *= ratio;
                r.translation_gradient[c][k] *= ratio;
            }
        } else {
            r.irradiance[c] = e1;
        }
    }
    r
}

/// The lifespan rule (decision 9): the last frame at which a record born at `birth` with
/// ratio `tau` is still valid, `t - t_k <= a_t / |tau - 1|` and `t - t_k < dt_max`;
/// `dynamic` false (nothing in the scene moves or changes) lifts dt_max.
pub fn last_frame(birth: u32, tau: f32, settings: &TemporalSettings, dynamic: bool) -> u32 {
    let cap = if dynamic {
        settings.max_lifespan - 1
    } else {
        u32::MAX - birth
    };
    let change = (tau - 1.0).abs();
    let by_change = if change > 0.0 && change.is_finite() {
        (settings.accuracy / change).floor().min(u32::MAX as f32) as u32
    } else if change == 0.0 {
        u32::MAX
    } else {
        0 // tau infinite or NaN (a record born in the dark that lights up): one frame
    };
    birth + by_change.min(cap)
}

/// [`RefreshMode::Auto`]'s rule: given the planes refreshed so far, their samples traced
/// again and the records computed in frames with replacements (planes of `resolution`
/// pixels), whether refreshing goes on.
fn refresh_pays((planes, retraced, computed): (u64, u64, u64), resolution: u32) -> bool {
    let per_plane = u64::from(resolution).pow(2);
    let saved = (planes * per_plane).saturating_sub(retraced);
    planes < AUTO_REFRESH_MIN_PLANES
        || saved as f64 >= AUTO_REFRESH_MIN_SAVED * (computed * per_plane) as f64
}

/// What the temporal cache did in one frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct TemporalFrameStats {
    pub frame: u32,
    /// Records used in this frame (kept + replaced + new).
    pub alive: u32,
    /// Records carried over from the previous frame.
    pub kept: u32,
    /// Expired records recomputed at the same place.
    pub replaced: u32,
    /// Expired records dropped: they cover no pixel (in their last frame with
    /// [`Replacement::Covering`], in this one otherwise), or with [`Replacement::Needed`]
    /// none that a kept record does not cover.
    pub deleted: u32,
    /// Of `deleted`, those that cover pixels (all covered by kept records).
    pub redundant: u32,
    /// Of `deleted`, those that would have been replaced but whose site an object that
    /// moved since their birth now covers ([`buried`]).
    pub buried: u32,
    /// Records created by placement in this frame.
    pub new: u32,
    /// Hemisphere rays traced (replacements and new records; of refreshed planes, the
    /// samples traced again; refinement's sub-rays, but not the extra ones of planes that
    /// saw no light, which the frame's own statistics add).
    pub plane_rays: u64,
    /// Replacements whose planes were refreshed rather than traced.
    pub refreshed_planes: u32,
    /// Whether the records computed this frame were estimated at t+1 (false: no next
    /// frame, or [`EstimateMode::Auto`] found the estimates did not pay; they then live
    /// this frame only).
    pub estimated: bool,
    /// Samples of those planes traced again.
    pub retraced_samples: u64,
    /// Records computed this frame by lifespan: entry i counts those used in i + 1 frames
    /// (the last entry: dt_max frames, or more when nothing in the scene changes).
    pub lifespans: Vec<u32>,
    /// The same for the radiance records of the frame (their hemisphere rays are also in
    /// `plane_rays`); None without radiance records.
    pub radiance: Option<Box<TemporalFrameStats>>,
    /// Temporal instant caching (`--records vpl`): what the frame's update traced and
    /// reused; None otherwise.
    pub instant: Option<instant::InstantFrameStats>,
}

/// The scenes a temporal frame needs: frame t on the GPU and on the CPU (instance
/// transforms), and frame t+1 when records are estimated ahead.
pub struct FrameScenes<'a> {
    pub now: &'a PreparedScene,
    /// The CPU scene at t (set to frame t).
    pub scene: &'a Scene,
    /// The scene at t+1, GPU and CPU; None when there is no next frame or nothing that
    /// lights the scene changes (records are then not estimated ahead: tau = 1).
    pub next: Option<(&'a PreparedScene, &'a Scene)>,
}

/// The records one frame used, and where the instances were then.
struct FrameRecords {
    frame: u32,
    /// Record ids, in frame order.
    ids: Vec<u32>,
    /// Every instance's transform at that frame (to place anchored records).
    transforms: Vec<Mat4>,
    lights: FrameLights,
}

/// A frame's lights and environment (plane refresh needs them unchanged).
type FrameLights = (Vec<crate::scene::Light>, glam::Vec3);

/// The records a frame computed (replacements, then new ones), read back from the GPU.
struct ComputedRecords {
    records: Vec<Record>,
    /// Their estimates at t+1 (the records themselves without a next frame).
    nexts: Vec<Record>,
    /// Radiance records: their coefficient blocks at t and t+1, one after another
    /// (empty for irradiance records).
    blocks: Vec<f32>,
    next_blocks: Vec<f32>,
    /// Their sites, where plane capture kept them.
    sites: Vec<Option<RecordSite>>,
    /// Samples of refreshed planes traced again.
    retraced_samples: u64,
}

/// A radiance record's coefficient blocks ([`crate::records::RecordKind::coefficient_floats`]
/// f32s each) at its first frame and estimated at the next: what [`TemporalRecord`] is to
/// its [`Record`]. Empty for irradiance records.
#[derive(Clone, Debug, Default)]
pub struct RecordBlocks {
    pub now: Vec<f32>,
    pub next: Vec<f32>,
}

/// What the first half of a frame of a cache leaves for the second
/// ([`TemporalCache::begin_frame`], [`TemporalCache::finish_frame`]).
struct FramePlan {
    /// Per instance: whether it moves from t to t+1 (empty without a next frame).
    moves_next: Vec<bool>,
    transforms: Vec<Mat4>,
    stats: TemporalFrameStats,
    times: Vec<(&'static str, f64)>,
    /// Ids of the records kept from the last frame, in frame order.
    kept: Vec<u32>,
    /// Ids of the records replaced, in order of birth (their successors come first
    /// among the records computed).
    replace: Vec<u32>,
    capture: plane_refresh::PlaneCapture,
    retraced_lists: Vec<wgpu::Buffer>,
    lights: FrameLights,
    /// Whether the records computed this frame are estimated at t+1 ([`estimate_rule`]).
    estimate: bool,
    /// How far the records' estimates can see the animation ahead (None: nothing
    /// animated or no next frame); `render_frame` sets it.
    horizon: Option<horizon::Horizon>,
}

/// Radiance records over an animation: a temporal cache of their own beside the
/// irradiance records ([`radiance`]), and the splat that shades glossy lobes with them.
struct RadianceTemporal {
    records: TemporalCache,
    splat: RadianceSplatPass,
}

impl RadianceTemporal {
    /// The radiance records of `scene` under the user's `cache` settings, or None when
    /// they are off or no lobe qualifies. They live by the same temporal settings, except
    /// that their planes are traced, never refreshed (refresh retains planes of the
    /// irradiance records' resolution), their estimate at t+1 reprojects the whole plane
    /// and replacement is decided on this frame (their coverage is not counted). An
    /// estimate from every other sample (the subset and the estimate projected with a
    /// basis of their coarser plane, the record moved by their difference) was tried and
    /// predicted the recomputed record worse than assuming no change (glossy cube in a box,
    /// order 8: 1.07 against 1.02 with 32x32 planes, 1.36 against 0.84 with 48x48; the
    /// whole plane: 1.01 against 1.31), so radiance records keep stride 1.
    fn new(
        ctx: &GpuContext,
        scene: &crate::gpu::scene_buffers::GpuScene,
        cache: &CacheSettings,
        settings: &TemporalSettings,
    ) -> Result<Option<Self>> {
        let Some((record_settings, tables)) = RadianceCache::record_settings(ctx, scene, cache)
        else {
            return Ok(None);
        };
        let settings = TemporalSettings {
            plane_refresh: RefreshMode::Off,
            estimate_stride: Some(1),
            replacement: match settings.replacement {
                Replacement::Covering => Replacement::Visible,
                other => other,
            },
            max_new_records: None,
            ..settings.clone()
        };
        Ok(Some(Self {
            records: TemporalCache::with_kind(
                ctx,
                &record_settings,
                &settings,
                tables.settings.kind(),
                scene.features(),
            )?,
            splat: RadianceSplatPass::new(ctx, tables)?,
        }))
    }
}

/// Replacements computed in one batch.
struct ReplacementRun {
    /// The frame the records were born in when their planes are refreshed; None: traced.
    refresh_from: Option<u32>,
    sites: Vec<RecordSite>,
    ids: Vec<u32>,
}

/// Records that persist across the frames of an animation (temporal radiance caching).
pub struct TemporalCache {
    pub settings: TemporalSettings,
    pass: RecordPass,
    reprojection: ReprojectionPass,
    refresh: plane_refresh::RefreshPass,
    /// Retained planes of live records (plane refresh).
    planes: plane_refresh::PlaneStore,
    /// Object-space BVHs of the large moving meshes the burial test searched.
    mesh_bvhs: buried::MeshBvhs,
    /// The records created so far, by id from `history_base` on (ids count every record
    /// ever created; [`TemporalCache::release_frames_before`] drops the oldest).
    history: VecDeque<TemporalRecord>,
    /// Id of `history[0]`.
    history_base: u32,
    /// Ids of the records used in the last frame, in frame order.
    alive: Vec<u32>,
    /// Per frame rendered and not released: the records used (the second pass of
    /// interpolated gradients renders exactly these). Released frames that are the birth
    /// of a live record stay, without their ids, for their transforms and lights (plane
    /// refresh).
    frames: Vec<FrameRecords>,
    /// Frames before this one are released: no second pass renders them any more.
    released_before: u32,
    /// Pixels each of `alive` covered in the last frame (for [`Replacement::Covering`]).
    coverage: Vec<u32>,
    /// The frame's records on the GPU and their estimates at t+1 (same indices), and with
    /// an estimate stride the records of the samples the estimates were moved from.
    frame_records: RecordCache,
    next_records: RecordCache,
    subset_records: RecordCache,
    /// The records of the frame the second pass renders: its own buffer, so that the
    /// first pass, running ahead, finds its own exactly as it left them.
    second_records: RecordCache,
    last_frame_rendered: Option<u32>,
    /// Planes refreshed so far, their samples traced again, and records computed in frames
    /// with replacements ([`RefreshMode::Auto`]).
    refresh_totals: (u64, u64, u64),
    /// Coefficient blocks of the records of `history`, in step with it.
    blocks: VecDeque<RecordBlocks>,
    /// The settings the user gave (radiance records derive theirs from them).
    user_settings: CacheSettings,
    /// The radiance records beside these, built at the first frame (None: the scene has
    /// no lobe they shade, radiance records are off, or this cache holds them).
    radiance: Option<Box<RadianceTemporal>>,
    radiance_checked: bool,
    /// What this cache's recent estimates at t+1 won ([`EstimateMode::Auto`]).
    estimate_ledger: estimate_rule::EstimateLedger,
    /// The last frame of the range rendered, where records are closed
    /// ([`TemporalCache::close_range_at`]).
    range_end: Option<u32>,
    /// The scene's animated objects, found at the first frame ([`horizon`]).
    animated_objects: Option<horizon::AnimatedObjects>,
}

impl TemporalCache {
    /// The settings temporal caching computes its records with, from the user's: plane
    /// hits trace their shadow rays (light maps would need tracing again every frame, and
    /// the re-shading at t+1 traces rays), planes are refined only where they saw no light
    /// (`CacheSettings::dark_plane_refine`; by contrast too where
    /// [`TemporalSettings::refine_planes`] says so, which the cache's own pass then
    /// applies), records are not neighbour-clamped nor tail-filled nor corralled; planes keep the user's
    /// spacing (reprojection bins moved hits by its inverse) and field of view, except that
    /// an evenly spaced plane at the refined default
    /// ([`CacheSettings::PLANE_FOV_REFINED`]) takes the plain even plane's best
    /// ([`CacheSettings::PLANE_FOV_PLAIN`], thesis Table 4.1); the static defaults' record
    /// sizing becomes the animation's ([`CacheSettings::for_animation`]).
    pub fn record_settings(cache: &CacheSettings) -> CacheSettings {
        // An evenly spaced plane crowds its pixels into the grazing band when wide: without
        // refinement its best field of view is thesis Table 4.1's 130 degrees, not the
        // refined default's 170. A cosine-spaced one is best at 170 refined or not
        // (docs/results.md, "Cosine spacing of the plane": 4.6 % against 9.1 % at 130).
        let refined_default_fov = cache.plane_refine > 0.0
            && cache.plane_fov_degrees == CacheSettings::PLANE_FOV_REFINED
            && cache.plane_spacing == crate::records::PlaneSpacing::Uniform;
        CacheSettings {
            plane_shadows: crate::records::PlaneShadows::Rays,
            plane_refine: 0.0,
            // A replacement sits at its predecessor's place: clamping would tie its R to
            // the record it replaces (unmeasured over time; the static default only).
            neighbour_clamp: false,
            // Temporal gathers count each record's pixels (deletion) in the first tier
            // only, and the tail's records would be the first to lapse: the static default
            // only (unmeasured over time).
            tail_share: 0.0,
            // A record lives several frames while occluders move: a corral taken from the
            // geometry at its birth would keep it from directions where a moving object no
            // longer stands (cube in a box 48x48, 24 frames: 2.74 -> 2.81 % with it).
            corral: crate::records::Corral::Off,
            plane_fov_degrees: if refined_default_fov {
                CacheSettings::PLANE_FOV_PLAIN
            } else {
                cache.plane_fov_degrees
            },
            ..cache.for_animation()
        }
    }

    pub fn new(
        ctx: &GpuContext,
        cache: &CacheSettings,
        settings: &TemporalSettings,
    ) -> Result<Self> {
        Self::for_scene(ctx, cache, settings, SceneFeatures::ALL)
    }

    /// [`Self::new`] with its record pass's plane pipelines compiled for the scene
    /// features `features` alone (`RecordPass::for_scene`; `SceneFeatures::of` the scene).
    pub fn for_scene(
        ctx: &GpuContext,
        cache: &CacheSettings,
        settings: &TemporalSettings,
        features: SceneFeatures,
    ) -> Result<Self> {
        Self::with_kind(ctx, cache, settings, RecordKind::Irradiance, features)
    }

    /// The name [`Self::for_scene`] had while the features were only kinds of light.
    #[deprecated(note = "renamed `for_scene`")]
    pub fn for_lights(
        ctx: &GpuContext,
        cache: &CacheSettings,
        settings: &TemporalSettings,
        features: SceneFeatures,
    ) -> Result<Self> {
        Self::for_scene(ctx, cache, settings, features)
    }

    /// A temporal cache of `kind` records (radiance records: one beside the irradiance
    /// cache, [`RadianceTemporal`]; they have none of their own).
    fn with_kind(
        ctx: &GpuContext,
        cache: &CacheSettings,
        settings: &TemporalSettings,
        kind: RecordKind,
        features: SceneFeatures,
    ) -> Result<Self> {
        settings.validate()?;
        let user_settings = cache.clone();
        // Every pass (records, reprojection, plane store) with the same record settings.
        let cache = &Self::record_settings(cache);
        // With `refine_planes`, irradiance records' planes are refined as the user's
        // settings say (the estimate at t+1 moves the traced plane and tau compares it
        // with that plane, `Lookahead::reduced`). Radiance records' never are: on
        // glossy Spheres refining them too lowered the error 1.11 -> 1.07 % at the time
        // per-frame recomputation takes for 0.87 % (docs/results.md, stop 43).
        let pass = RecordPass::for_scene(
            ctx,
            &CacheSettings {
                plane_refine: match kind {
                    RecordKind::Irradiance if settings.refine_planes => user_settings.plane_refine,
                    _ => 0.0,
                },
                // Dark irradiance planes are refined as the user's settings say (by
                // default: CacheSettings::dark_plane_refine); radiance records' planes
                // stay as traced.
                dark_plane_refine: kind == RecordKind::Irradiance
                    && user_settings.dark_plane_refine,
                ..cache.clone()
            },
            kind,
            features,
        )?;
        // The temporal stages trace and shade like the record pass: compiled for the same
        // features (its bounce cache included).
        let features = pass.features();
        Ok(Self {
            settings: settings.clone(),
            pass,
            reprojection: ReprojectionPass::for_scene(
                ctx,
                cache,
                settings.estimate_stride_for(cache.plane_resolution),
                features,
            )?,
            refresh: plane_refresh::RefreshPass::for_scene(ctx, features)?,
            planes: plane_refresh::PlaneStore::new(
                settings.plane_budget_bytes,
                cache.plane_resolution,
            ),
            mesh_bvhs: buried::MeshBvhs::default(),
            history: VecDeque::new(),
            history_base: 0,
            alive: Vec::new(),
            frames: Vec::new(),
            released_before: 0,
            coverage: Vec::new(),
            frame_records: RecordCache::with_kind(ctx, kind)?,
            next_records: RecordCache::with_kind(ctx, kind)?,
            subset_records: RecordCache::with_kind(ctx, kind)?,
            second_records: RecordCache::with_kind(ctx, kind)?,
            last_frame_rendered: None,
            range_end: None,
            animated_objects: None,
            refresh_totals: (0, 0, 0),
            blocks: VecDeque::new(),
            user_settings,
            radiance: None,
            // Only an irradiance cache holds radiance records beside it.
            radiance_checked: kind != RecordKind::Irradiance,
            estimate_ledger: Default::default(),
        })
    }

    /// Whether this frame's new records are estimated at t+1 ([`estimate_rule`]): always
    /// when nothing in the scene moves or changes (`dynamic` false: records then live as
    /// long as their estimate finds them unchanged), else as the ledger judges.
    fn estimating(&self, dynamic: bool) -> bool {
        let settings = &self.pass.settings;
        let share = estimate_rule::cost_share(
            settings.plane_rays_per_record(),
            u64::from(self.reprojection.table.resolution).pow(2),
            settings.plane_light_samples,
        );
        !dynamic
            || self
                .estimate_ledger
                .estimates(self.settings.estimates, share)
    }

    /// Whether replacements refresh retained planes from now on ([`RefreshMode`]).
    fn refreshing(&self) -> bool {
        match self.settings.plane_refresh {
            RefreshMode::Off => false,
            RefreshMode::On => true,
            RefreshMode::Auto => {
                refresh_pays(self.refresh_totals, self.pass.settings.plane_resolution)
            }
        }
    }

    pub fn cache_settings(&self) -> &CacheSettings {
        &self.pass.settings
    }

    /// How many live records keep their traced plane (for plane refresh).
    pub fn retained_planes(&self) -> usize {
        self.planes.planes.len()
    }

    /// Ids of the records used in the last frame, in frame order.
    pub fn alive(&self) -> &[u32] {
        &self.alive
    }

    /// Record `id` over its life; None for an id not created yet or released
    /// ([`TemporalCache::release_frames_before`]).
    pub fn record(&self, id: u32) -> Option<&TemporalRecord> {
        id.checked_sub(self.history_base)
            .and_then(|i| self.history.get(i as usize))
    }

    /// The coefficient blocks of record `id` at its first frame and estimated at the next
    /// (empty for irradiance records); None for an id not retained.
    pub fn blocks(&self, id: u32) -> Option<&RecordBlocks> {
        id.checked_sub(self.history_base)
            .and_then(|i| self.blocks.get(i as usize))
    }

    /// The temporal cache of the radiance records beside these irradiance records (built
    /// at the first frame; None before, or when the scene has no lobe they shade).
    pub fn radiance_records(&self) -> Option<&TemporalCache> {
        self.radiance.as_deref().map(|r| &r.records)
    }

    /// The records retained, with their ids, oldest first (all records ever created
    /// unless frames were released).
    pub fn records(&self) -> impl Iterator<Item = (u32, &TemporalRecord)> {
        (self.history_base..).zip(&self.history)
    }

    /// How many records the cache retains (their history: first frame, estimate, tau,
    /// successor). Without [`TemporalCache::release_frames_before`] it grows with every
    /// record created; with it, it stays about the records of 2 dt_max frames.
    pub fn history_len(&self) -> usize {
        self.history.len()
    }

    /// How many frames' record lists the cache retains (see
    /// [`TemporalCache::history_len`]).
    pub fn frames_retained(&self) -> usize {
        self.frames.len()
    }

    /// Record `id`, which must be retained (ids come from the cache's own lists).
    fn rec(&self, id: u32) -> &TemporalRecord {
        &self.history[(id - self.history_base) as usize]
    }

    fn rec_mut(&mut self, id: u32) -> &mut TemporalRecord {
        &mut self.history[(id - self.history_base) as usize]
    }

    /// The id the next record created gets.
    fn next_id(&self) -> u64 {
        u64::from(self.history_base) + self.history.len() as u64
    }

    /// Says that frame `last` ends the range rendered. With interpolated gradients a record
    /// moves towards its successor; one still alive at the range's end has none, and would
    /// be extrapolated from its estimate at t+1 over up to dt_max frames (cube in a box,
    /// frames 0..59: the indirect error climbed from 2.4 to 4.5 % over frames 40-59, while
    /// the same frames of a longer range stayed at 2.4-2.7 %). So in frame `last` every
    /// live record at least two frames old expires and is replaced (or deleted) as any
    /// expired record is: the frames before it then interpolate towards a recomputation
    /// at its place. (A record one frame old is exact there: its estimate is of frame
    /// `last`.) Static scenes and extrapolated gradients are left alone.
    pub fn close_range_at(&mut self, last: u32) {
        self.range_end = Some(last);
        if let Some(r) = self.radiance.as_deref_mut() {
            r.records.close_range_at(last);
        }
    }

    /// Whether frame `t` closes the range ([`TemporalCache::close_range_at`]).
    fn closes(&self, t: u32) -> bool {
        self.range_end == Some(t) && self.settings.gradients == TemporalGradients::Interpolated
    }

    /// Whether frame `t`, rendered by the first pass, can be rendered by the second pass
    /// now, with the bytes it would have once frame `end` (the last of the range) is
    /// rendered: every record of frame t has met its successor or its end. A record's
    /// successor (or its deletion) is decided in the first frame rendered after its last
    /// frame L, and never changes after; a record with L >= `end` gets none in the range.
    /// With dt_max, L < t_k + dt_max <= t + dt_max, so the first pass needs to be at most
    /// dt_max frames ahead (exactly L + 1 for the longest-lived record of frame t).
    pub fn second_pass_ready(&self, t: u32, end: u32) -> bool {
        let Some(rendered) = self.last_frame_rendered else {
            return false;
        };
        if t < self.released_before {
            return false;
        }
        // Records alive at the range's end get a successor there when it closes the range.
        let closes = self.closes(end);
        let ready = match self.frames.iter().find(|f| f.frame == t) {
            Some(f) => f.ids.iter().all(|&id| {
                let r = self.rec(id);
                r.last_frame < rendered || (r.last_frame >= end && !(closes && r.closes_at(end)))
            }),
            None => false,
        };
        ready
            && self
                .radiance
                .as_deref()
                .is_none_or(|r| r.records.second_pass_ready(t, end))
    }

    /// Releases what only frames before `t` needed: their record lists and the records no
    /// later frame uses (the second pass of interpolated gradients calls this behind
    /// itself, so memory stays bounded by dt_max frames, not the range). Records still
    /// alive and the lists of frames from `t` on stay, and so do the instance transforms
    /// and lights of the first frames of live records (plane refresh compares with them).
    pub fn release_frames_before(&mut self, t: u32) {
        self.released_before = self.released_before.max(t);
        let (from, current) = (self.released_before, self.last_frame_rendered);
        let births: HashSet<u32> = self.alive.iter().map(|&id| self.rec(id).birth).collect();
        self.frames.retain_mut(|f| {
            if f.frame >= from || Some(f.frame) == current {
                true
            } else if births.contains(&f.frame) {
                f.ids = Vec::new();
                true
            } else {
                false
            }
        });
        // Ids grow with the frame a record is born in, and a record's successor comes
        // after it: everything from the lowest id a kept frame or the last frame uses on
        // is kept (deleted records among them too: at most those born since).
        let needed = self
            .frames
            .iter()
            .flat_map(|f| f.ids.iter())
            .chain(&self.alive)
            .copied()
            .min();
        let keep_from = needed.map_or(self.next_id(), u64::from);
        while u64::from(self.history_base) < keep_from && !self.history.is_empty() {
            self.history.pop_front();
            self.blocks.pop_front();
            self.history_base += 1;
        }
        if let Some(r) = self.radiance.as_deref_mut() {
            r.records.release_frames_before(t);
        }
    }

    /// Renders frame `t` (frames must come in increasing order). `dynamic`: whether
    /// anything that affects irradiance (instances, lights) is animated; when false,
    /// records never expire (dt_max is lifted: nothing can change later).
    /// `placement_only`: the first pass of interpolated gradients (records only: no direct
    /// light, no images in the returned frame). Glossy lobes the scene's radiance records
    /// shade get a radiance-record cache of their own, with the same lifecycle
    /// ([`radiance`]).
    #[allow(clippy::too_many_arguments)]
    pub fn render_frame(
        &mut self,
        renderer: &Renderer,
        scenes: FrameScenes<'_>,
        camera: &Camera,
        t: u32,
        dynamic: bool,
        placement_only: bool,
        progress: impl FnMut(u32),
    ) -> Result<(Frame, TemporalFrameStats)> {
        let ctx = &renderer.ctx;
        if !self.radiance_checked {
            self.radiance_checked = true;
            self.radiance =
                RadianceTemporal::new(ctx, &scenes.now.gpu, &self.user_settings, &self.settings)?
                    .map(Box::new);
            if let (Some(r), Some(last)) = (self.radiance.as_deref_mut(), self.range_end) {
                r.records.close_range_at(last);
            }
        }
        // Bounces past the first: the bounce caches of frame t (its replacements and
        // placed records reflect it) and of t+1 (the estimates re-shade with it; the next
        // frame finds it built).
        let mut bounce_times = Vec::new();
        renderer.scene_bounce_cache(scenes.now, &self.pass.settings, &mut bounce_times)?;
        if let Some((next, _)) = scenes.next {
            renderer.scene_bounce_cache(next, &self.pass.settings, &mut bounce_times)?;
        }
        // The visibility buffer of frame t, traced once for the replacement decisions of
        // both caches and the frame.
        let mut vis = None;
        // Frame t+1 as the reprojection sees it, once for every estimate of the frame.
        let anchored = self.settings.anchor == RecordAnchor::Instance;
        let next_frame = match scenes.next {
            Some((next, next_cpu)) => {
                let mut f = NextFrame::new(ctx, &next.gpu, scenes.scene, next_cpu, anchored)?;
                f.skip_movers = self.settings.mover_records == MoverRecords::OneFrame;
                Some(f)
            }
            None => None,
        };
        let estimate = self.estimating(dynamic);
        let mut plan = self.begin_frame(
            renderer,
            &scenes,
            camera,
            t,
            next_frame.as_ref(),
            estimate,
            &mut vis,
        )?;
        // How far the estimates see the animation ahead, once for both caches (radiance
        // records live by the same a_t and dt_max).
        let objects = self
            .animated_objects
            .get_or_insert_with(|| horizon::AnimatedObjects::of(scenes.scene));
        plan.horizon = scenes.next.and_then(|_| {
            horizon::Horizon::ahead(
                scenes.scene,
                objects,
                t,
                self.settings.max_lifespan,
                self.settings.accuracy,
            )
        });
        let mut radiance_plan = match self.radiance.as_deref_mut() {
            Some(r) => Some(r.records.begin_frame(
                renderer,
                &scenes,
                camera,
                t,
                next_frame.as_ref(),
                r.records.estimating(dynamic),
                &mut vis,
            )?),
            None => None,
        };
        if let Some(p) = radiance_plan.as_mut() {
            p.horizon.clone_from(&plan.horizon);
        }
        let mut lookahead = next_frame.as_ref().map(|next| {
            Lookahead::new(
                next,
                &self.reprojection,
                &mut self.next_records,
                &mut self.subset_records,
                Some(&mut plan.capture),
                self.settings.estimates_values_only(),
                plan.estimate,
            )
        });
        let mut radiance_lookahead = None;
        let mut radiance_before = 0;
        let radiance = match (self.radiance.as_deref_mut(), radiance_plan.as_mut()) {
            (Some(r), Some(rp)) => {
                let rc = &mut r.records;
                radiance_before = rc.frame_records.count;
                radiance_lookahead = next_frame.as_ref().map(|next| {
                    Lookahead::new(
                        next,
                        &rc.reprojection,
                        &mut rc.next_records,
                        &mut rc.subset_records,
                        Some(&mut rp.capture),
                        rc.settings.estimates_values_only(),
                        rp.estimate,
                    )
                });
                Some(RadianceFrame {
                    records: &mut rc.frame_records,
                    pass: &rc.pass,
                    splat: &r.splat,
                    stage: radiance_lookahead
                        .as_mut()
                        .map(|la| la as &mut dyn RecordStage),
                    max_new_records: None,
                })
            }
            _ => None,
        };
        let before_new = self.frame_records.count;
        let (mut frame, coverage) = renderer.render_cached_frame(
            scenes.now,
            camera,
            &mut self.frame_records,
            &self.pass,
            CachedFrameOptions {
                max_new_records: self.settings.max_new_records,
                stage: lookahead.as_mut().map(|la| la as &mut dyn RecordStage),
                count_coverage: self.settings.replacement == Replacement::Covering,
                placement_only,
                visibility: vis.take(),
                radiance,
            },
            progress,
        )?;
        drop(lookahead);
        drop(radiance_lookahead);
        let new = self.frame_records.count - before_new;
        let has_next = scenes.next.is_some();
        let mut times = std::mem::take(&mut plan.times);
        times.extend(bounce_times);
        let mut stats = self.finish_frame(ctx, plan, t, has_next, dynamic, coverage, new)?;
        if let (Some(r), Some(mut rp)) = (self.radiance.as_deref_mut(), radiance_plan) {
            // Their replacements' passes under the radiance cache's names.
            times.extend(
                rp.times
                    .drain(..)
                    .map(|(name, ms)| (crate::frame::radiance_pass_name(name), ms)),
            );
            let new = r.records.frame_records.count - radiance_before;
            let rs = r
                .records
                .finish_frame(ctx, rp, t, has_next, dynamic, Vec::new(), new)?;
            stats.plane_rays += rs.plane_rays;
            stats.radiance = Some(Box::new(rs));
        }
        if let Some(cache_stats) = frame.stats.cache.as_mut() {
            cache_stats.plane_rays = stats.plane_rays + cache_stats.dark_plane_rays;
            cache_stats.reused_records = stats.kept;
        }
        let mut all = frame.stats.pass_ms.clone();
        all.extend(times.iter().map(|(n, ms)| (n.to_string(), *ms)));
        frame.stats.pass_ms = crate::frame::sum_by_pass_owned(&all);
        Ok((frame, stats))
    }

    /// The first half of a frame of this cache: expiry, the replacement decisions (on
    /// frame t's visibility buffer `vis`, traced here if not yet), the kept records
    /// uploaded at t and the replacements computed (each estimated at t+1 when there is a
    /// next frame, `next_frame`). Placement, in the frame, appends the new records.
    #[allow(clippy::too_many_arguments)]
    fn begin_frame(
        &mut self,
        renderer: &Renderer,
        scenes: &FrameScenes<'_>,
        camera: &Camera,
        t: u32,
        next_frame: Option<&NextFrame<'_>>,
        estimate: bool,
        vis: &mut Option<VisibilityBuffer>,
    ) -> Result<FramePlan> {
        let ctx = &renderer.ctx;
        if let Some(prev) = self.last_frame_rendered {
            if t <= prev {
                return Err(Error::Usage(format!(
                    "temporal frames must increase: frame {t} after frame {prev}"
                )));
            }
        }
        let transforms: Vec<Mat4> = scenes.scene.instances.iter().map(|i| i.transform).collect();
        let mut stats = TemporalFrameStats {
            frame: t,
            ..Default::default()
        };
        // Expiry: keep what is still valid; replace expired records that cover pixels, in
        // their last frame (the seed, section V-c) or in this one; delete the others.
        // (index among the last frame's records, id)
        let closing = self.closes(t);
        let (kept, expired) = self
            .alive
            .iter()
            .copied()
            .enumerate()
            .partition::<Vec<_>, _>(|&(_, id)| {
                let r = self.rec(id);
                t <= r.last_frame && !(closing && r.closes_at(t))
            });
        // Closed at the range's end: used up to the frame before.
        for &(_, id) in &expired {
            let r = self.rec_mut(id);
            r.last_frame = r.last_frame.min(t.saturating_sub(1));
        }
        let kept: Vec<u32> = kept.into_iter().map(|(_, id)| id).collect();
        let kept_records: Vec<Record> = kept
            .iter()
            .map(|&id| self.world_record(self.rec(id).at(t), id, &transforms))
            .collect();
        let mut times = Vec::new();
        let (deciding, covering) = self.expired_coverage(
            renderer,
            scenes.now,
            camera,
            t,
            &kept_records,
            &expired,
            &transforms,
            vis,
            &mut times,
        )?;
        let mut replace: Vec<u32> = Vec::new();
        let mut mesh_bvhs = std::mem::take(&mut self.mesh_bvhs);
        let mut burial = buried::SiteBurial::new(scenes.scene, &mut mesh_bvhs);
        for (k, &(_, id)) in expired.iter().enumerate() {
            let needed = deciding.get(k).copied().unwrap_or(0) > 0;
            if needed && self.replacement_buried(id, t, &transforms, &mut burial) {
                // Its site is now inside a moved object: placement covers its pixels
                // from visible points instead (buried.rs).
                stats.deleted += 1;
                stats.buried += 1;
                self.planes.planes.remove(&id);
            } else if needed {
                replace.push(id);
            } else {
                stats.deleted += 1;
                stats.redundant += u32::from(covering.get(k).copied().unwrap_or(0) > 0);
                self.planes.planes.remove(&id);
            }
        }
        self.mesh_bvhs = mesh_bvhs;
        stats.kept = kept.len() as u32;
        stats.replaced = replace.len() as u32;
        let kept_blocks: Vec<f32> = kept
            .iter()
            .flat_map(|&id| self.block_at_with(id, t, &transforms))
            .collect();
        self.frame_records
            .upload_with_coefficients(ctx, &kept_records, &kept_blocks)?;
        for records in [&mut self.next_records, &mut self.subset_records] {
            records.count = 0;
            records.reserve(ctx, self.frame_records.count)?;
            records.count = self.frame_records.count;
        }

        // Replacements at the same place, in order of birth (runs of refreshable ones
        // share what moved since).
        let lights = (scenes.scene.lights.clone(), scenes.scene.environment);
        // Refresh mode auto decides on the frames before this one.
        let refreshing = self.refreshing();
        replace.sort_by_key(|&id| (self.rec(id).birth, id));
        let runs = self.replacement_runs(&replace, t, &transforms, &lights, refreshing);
        let mut capture = plane_refresh::PlaneCapture {
            planes: refreshing,
            budget: self.planes.free(),
            ..Default::default()
        };
        let mut lookahead = next_frame.map(|next| {
            Lookahead::new(
                next,
                &self.reprojection,
                &mut self.next_records,
                &mut self.subset_records,
                Some(&mut capture),
                self.settings.estimates_values_only(),
                estimate,
            )
        });
        let mut retraced_lists = Vec::new();
        for ReplacementRun {
            refresh_from,
            sites,
            ids,
        } in &runs
        {
            let buf = ctx.storage_buffer("replacement sites", sites)?;
            let span;
            let refresh = match refresh_from {
                Some(birth) => {
                    let then = self
                        .frames
                        .iter()
                        .find(|f| f.frame == *birth)
                        .map_or(&[][..], |f| f.transforms.as_slice());
                    span = plane_refresh::SpanMotion::new(ctx, scenes.scene, then, &transforms)?;
                    Some(plane_refresh::PlaneRefresh {
                        pass: &self.refresh,
                        planes: ids
                            .iter()
                            .filter_map(|id| self.planes.planes.get(id))
                            .collect(),
                        motion: &span,
                        retraced: Default::default(),
                    })
                }
                None => None,
            };
            let mut stage = RefreshStage {
                refresh: refresh.as_ref(),
                lookahead: lookahead.as_mut(),
            };
            let stage = (stage.refresh.is_some() || stage.lookahead.is_some())
                .then_some(&mut stage as &mut dyn RecordStage);
            times.extend(self.pass.compute(
                ctx,
                &scenes.now.gpu,
                &buf,
                sites.len() as u32,
                &mut self.frame_records,
                None,
                stage,
                |_| {},
            )?);
            if let Some(r) = refresh {
                stats.refreshed_planes += r.planes.len() as u32;
                retraced_lists.extend(r.retraced.take());
            }
        }
        drop(lookahead);
        for id in &replace {
            self.planes.planes.remove(id);
        }
        let moves_next: Vec<bool> = match scenes.next {
            Some((_, next)) => next
                .instances
                .iter()
                .zip(&transforms)
                .map(|(i, &m)| i.transform != m)
                .collect(),
            None => Vec::new(),
        };
        Ok(FramePlan {
            moves_next,
            transforms,
            stats,
            times,
            kept,
            replace,
            capture,
            retraced_lists,
            lights,
            estimate,
            // Set by `render_frame`, once for both caches.
            horizon: None,
        })
    }

    /// The second half of a frame of this cache, once the frame placed `new` records
    /// (and counted each record's `coverage`, when it did): the records computed this
    /// frame read back and added to the history, the frame's record list kept.
    #[allow(clippy::too_many_arguments)]
    fn finish_frame(
        &mut self,
        ctx: &GpuContext,
        plan: FramePlan,
        t: u32,
        has_next: bool,
        dynamic: bool,
        coverage: Vec<u32>,
        new: u32,
    ) -> Result<TemporalFrameStats> {
        let FramePlan {
            moves_next,
            transforms,
            mut stats,
            kept,
            replace,
            capture,
            retraced_lists,
            lights,
            estimate,
            horizon,
            ..
        } = plan;
        stats.new = new;
        // The records computed this frame (replacements, then new ones) come back from
        // the GPU in one wait; kept records are on the CPU.
        let first = kept.len();
        let estimated = has_next && estimate;
        let computed = self.read_computed(ctx, first, estimated, &capture, &retraced_lists)?;
        stats.retraced_samples = computed.retraced_samples;
        let count = computed.records.len();
        // Without an estimate (a next frame the cache chose not to estimate), a record
        // lives its first frame only; at the last frame, as long as it would anyway.
        let one_frame = has_next && !estimate;
        let (new_ids, lifespans, movers) = self.register_computed(
            computed,
            first,
            capture.kept,
            &replace,
            t,
            dynamic,
            one_frame,
            &transforms,
            &moves_next,
            horizon.as_ref(),
        )?;
        if has_next && dynamic {
            // Records on movers were not estimated (`NextFrame::skip_movers`): the ledger
            // weighs what the estimates of the others cost and won.
            self.estimate_ledger.add_frame(estimated.then(|| {
                let (records, won) = estimate_rule::frames_won(&lifespans);
                (records - movers, won)
            }));
        }
        stats.estimated = estimated;
        stats.lifespans = lifespans;
        let mut alive = kept;
        alive.extend(new_ids);
        self.frames.push(FrameRecords {
            frame: t,
            ids: alive.clone(),
            transforms,
            lights,
        });
        self.alive = alive;
        self.coverage = coverage;
        self.last_frame_rendered = Some(t);
        stats.alive = self.alive.len() as u32;
        let refreshed = u64::from(stats.refreshed_planes);
        // Traced planes; refreshed ones re-trace some samples; both are then refined.
        let settings = &self.pass.settings;
        let plane = u64::from(settings.plane_resolution).pow(2);
        let refined = settings.plane_rays_per_record() - plane;
        stats.plane_rays =
            (count as u64 - refreshed) * plane + stats.retraced_samples + count as u64 * refined;
        if stats.replaced > 0 {
            self.refresh_totals.0 += refreshed;
            self.refresh_totals.1 += stats.retraced_samples;
            self.refresh_totals.2 += count as u64;
        }
        if !self.refreshing() {
            self.planes.planes.clear();
        }
        Ok(stats)
    }

    /// Reads back the records of the current frame from cache index `first` on (the
    /// replacements and new records), their estimates at t+1 (`has_next`), their
    /// coefficient blocks (radiance records), the sites `capture` kept (by cache index,
    /// for their successors) and the lengths of the `retraced` sample lists of plane
    /// refresh, in one wait.
    fn read_computed(
        &self,
        ctx: &GpuContext,
        first: usize,
        has_next: bool,
        capture: &plane_refresh::PlaneCapture,
        retraced: &[wgpu::Buffer],
    ) -> Result<ComputedRecords> {
        let computed = (self.frame_records.count as usize).saturating_sub(first);
        let site_bytes = std::mem::size_of::<RecordSite>() as u64;
        let blocks = self.frame_records.kind.coefficient_floats() > 0;
        let mut ranges: Vec<(&wgpu::Buffer, std::ops::Range<u64>)> = Vec::new();
        if computed > 0 {
            let range = RecordCache::byte_range(first as u32, computed as u32);
            ranges.push((&self.frame_records.buffer, range.clone()));
            if has_next {
                ranges.push((&self.next_records.buffer, range.clone()));
                // The subset tau is taken against (`Lookahead::reduced`).
                if self.reprojection.stride > 1 || self.pass.refines_by_contrast() {
                    ranges.push((&self.subset_records.buffer, range));
                }
            }
        }
        let record_ranges = ranges.len();
        if computed > 0 && blocks {
            let range = self
                .frame_records
                .coefficient_range(first as u32, computed as u32);
            ranges.push((&self.frame_records.coefficients, range.clone()));
            if has_next {
                ranges.push((&self.next_records.coefficients, range));
            }
        }
        let block_ranges = ranges.len() - record_ranges;
        ranges.extend(
            capture
                .site_batches
                .iter()
                .map(|(_, n, b)| (b, 0..u64::from(*n) * site_bytes)),
        );
        // The first word of each list of samples traced again is its length.
        ranges.extend(retraced.iter().map(|b| (b, 0..4)));
        let mut read = if ranges.is_empty() {
            Vec::new()
        } else {
            ctx.read_buffer_ranges::<u32>(&ranges)?
        }
        .into_iter();
        // The next range read, as `T`s (empty past the last).
        fn next_range<T: bytemuck::Pod>(read: &mut impl Iterator<Item = Vec<u32>>) -> Vec<T> {
            read.next()
                .map(|words| bytemuck::pod_collect_to_vec(&words))
                .unwrap_or_default()
        }
        let records: Vec<Record> = if record_ranges > 0 {
            next_range(&mut read)
        } else {
            Vec::new()
        };
        // Without a next frame the records are their own estimates.
        let mut nexts: Vec<Record> = if record_ranges >= 2 {
            next_range(&mut read)
        } else {
            records.clone()
        };
        // With an estimate stride, tau is the ratio of the estimate to the subset it was
        // moved from, and the record at t+1 is the record scaled by it, channel by channel.
        let subsets = if record_ranges == 3 {
            let subsets: Vec<Record> = next_range(&mut read);
            for ((next, subset), record) in nexts.iter_mut().zip(&subsets).zip(&records) {
                *next = scaled_by_estimate(record, subset, next);
            }
            Some(subsets)
        } else {
            None
        };
        let blocks_now: Vec<f32> = if block_ranges > 0 {
            next_range(&mut read)
        } else {
            Vec::new()
        };
        let floats = self.frame_records.kind.coefficient_floats();
        let mut blocks_next: Vec<f32> = if block_ranges == 2 {
            next_range(&mut read)
        } else {
            blocks_now.clone()
        };
        // Estimates projected without their gradients keep the record's own.
        if self.settings.estimates_values_only() && floats > 0 {
            for (next, now) in blocks_next
                .chunks_exact_mut(floats)
                .zip(blocks_now.chunks_exact(floats))
            {
                radiance::keep_gradients(next, now);
            }
        }
        if records.len() != computed
            || nexts.len() != computed
            || subsets.is_some_and(|s| s.len() != computed)
            || blocks_now.len() != computed * floats
            || blocks_next.len() != computed * floats
        {
            return Err(Error::Gpu("internal: record readback incomplete".into()));
        }
        let mut sites_at = vec![None; computed];
        for ((index, _, _), words) in capture.site_batches.iter().zip(read.by_ref()) {
            let sites: Vec<RecordSite> = bytemuck::pod_collect_to_vec(&words);
            for (k, site) in sites.into_iter().enumerate() {
                if let Some(slot) = (*index as usize + k)
                    .checked_sub(first)
                    .and_then(|j| sites_at.get_mut(j))
                {
                    *slot = Some(site);
                }
            }
        }
        let retraced_samples = read
            .map(|w| u64::from(w.first().copied().unwrap_or(0)))
            .sum();
        Ok(ComputedRecords {
            records,
            nexts,
            blocks: blocks_now,
            next_blocks: blocks_next,
            sites: sites_at,
            retraced_samples,
        })
    }

    /// Adds the records `computed` at frame `t` (cache indices from `first` on) to the
    /// history: each with its tau and last frame (decision 9), its anchor, its site and
    /// its plane if kept (`kept_planes`, by cache index); the first `replace.len()` of them
    /// succeed the records of `replace`; `moves_next` says per instance whether it moves
    /// to t+1 ([`MoverRecords`]); `horizon` ends lifespans where a light or an object
    /// leaves the course the estimate saw ([`horizon`]). Returns their ids, their lifespan
    /// histogram (entry i: records used in i + 1 frames) and how many of them lie on
    /// movers and live one frame for that.
    #[allow(clippy::too_many_arguments)]
    fn register_computed(
        &mut self,
        computed: ComputedRecords,
        first: usize,
        kept_planes: Vec<(u32, wgpu::Buffer)>,
        replace: &[u32],
        t: u32,
        dynamic: bool,
        one_frame: bool,
        transforms: &[Mat4],
        moves_next: &[bool],
        horizon: Option<&horizon::Horizon>,
    ) -> Result<(Vec<u32>, Vec<u32>, u64)> {
        let movers_one_frame = self.settings.mover_records == MoverRecords::OneFrame;
        let first_id = self.next_id();
        // Ids are u32 (the light-sample seeds of replacements hash them).
        if first_id + computed.records.len() as u64 > u64::from(u32::MAX) {
            return Err(Error::Usage(format!(
                "frame {t}: more than {} records created in one animation (ids are 32-bit); \
                 render the range in parts",
                u32::MAX
            )));
        }
        let first_id = first_id as u32;
        for (index, plane) in kept_planes {
            if let Some(j) = (index as usize).checked_sub(first) {
                self.planes.planes.insert(first_id + j as u32, plane);
            }
        }
        for (j, &old) in replace.iter().enumerate() {
            self.rec_mut(old).successor = Some(first_id + j as u32);
        }
        let bins = self.settings.max_lifespan.max(1) as usize;
        let mut lifespans = if computed.records.is_empty() {
            Vec::new()
        } else {
            vec![0; bins]
        };
        let floats = self.frame_records.kind.coefficient_floats();
        let block = |all: &[f32], k: usize| -> Vec<f32> {
            all.get(k * floats..(k + 1) * floats)
                .map_or_else(Vec::new, <[f32]>::to_vec)
        };
        let mut ids = Vec::with_capacity(computed.records.len());
        let mut movers = 0u64;
        for (k, ((&record, &next), site)) in computed
            .records
            .iter()
            .zip(&computed.nexts)
            .zip(computed.sites)
            .enumerate()
        {
            let blocks = RecordBlocks {
                now: block(&computed.blocks, k),
                next: block(&computed.next_blocks, k),
            };
            // Radiance records: tau of their coefficient vectors (radiance.rs). A record
            // not estimated has none and lives this frame only.
            // A record on an instance that moves to t+1 lives this frame only
            // (MoverRecords::OneFrame) and was not estimated (`NextFrame::skip_movers`).
            let on_mover = movers_one_frame
                && moves_next
                    .get(record.instance as usize)
                    .copied()
                    .unwrap_or(false);
            movers += u64::from(on_mover);
            let mut before_break = false;
            let (tau, last) = if one_frame || on_mover {
                (f32::NAN, t)
            } else {
                let tau = if floats > 0 {
                    radiance::coefficient_ratio(&blocks.now, &blocks.next)
                } else {
                    temporal_ratio(record.irradiance, next.irradiance)
                };
                let last = last_frame(t, tau, &self.settings, dynamic);
                // Not past what the estimate can see of the animation (horizon.rs).
                match horizon.and_then(|h| h.end(record.position())) {
                    Some(end) if end.last_frame <= last => {
                        before_break = end.broken;
                        (tau, end.last_frame)
                    }
                    _ => (tau, last),
                }
            };
            let anchor = match self.settings.anchor {
                RecordAnchor::World => None,
                RecordAnchor::Instance => {
                    transforms
                        .get(record.instance as usize)
                        .map(|&transform| Anchor {
                            instance: record.instance,
                            transform,
                        })
                }
            };
            let id = self.next_id() as u32;
            lifespans[((last - t) as usize).min(bins - 1)] += 1;
            self.history.push_back(TemporalRecord {
                record,
                next,
                birth: t,
                last_frame: last,
                tau,
                successor: None,
                before_break,
                anchor,
                site,
            });
            self.blocks.push_back(blocks);
            ids.push(id);
        }
        Ok((ids, lifespans, movers))
    }

    /// The sites of the replacements `replace` (ids in order of birth) at frame `t`, in
    /// runs that are computed together: where the record is now (its world position, or
    /// carried by its instance). A record that has not moved hands on its site (position,
    /// frame, seed), so its plane can be refreshed rather than traced when `refreshing`
    /// and the lights are as they were (plane_refresh.rs); such records born in the same
    /// frame form one run, as they share what moved since.
    fn replacement_runs(
        &self,
        replace: &[u32],
        t: u32,
        transforms: &[Mat4],
        lights: &FrameLights,
        refreshing: bool,
    ) -> Vec<ReplacementRun> {
        let mut runs: Vec<ReplacementRun> = Vec::new();
        for &id in replace {
            let rec = self.rec(id);
            let (site, unmoved) = self.replacement_site(id, t, transforms);
            let refreshable = refreshing
                && unmoved
                && rec.site.is_some()
                && self.planes.planes.contains_key(&id)
                && self
                    .frames
                    .iter()
                    .find(|f| f.frame == rec.birth)
                    .is_some_and(|f| &f.lights == lights);
            let refresh_from = refreshable.then_some(rec.birth);
            match runs.last_mut() {
                Some(run) if run.refresh_from == refresh_from => {
                    run.sites.push(site);
                    run.ids.push(id);
                }
                _ => runs.push(ReplacementRun {
                    refresh_from,
                    sites: vec![site],
                    ids: vec![id],
                }),
            }
        }
        runs
    }

    /// Where the replacement of record `id` at frame `t` is computed (its site, carried by
    /// its instance if it moved with it), and whether the record is where it was born.
    fn replacement_site(&self, id: u32, t: u32, transforms: &[Mat4]) -> (RecordSite, bool) {
        let rec = self.rec(id);
        let unmoved = rec
            .anchor
            .is_none_or(|a| transforms.get(a.instance as usize) == Some(&a.transform));
        // The record's motion since its birth, if it moved with its instance.
        let motion = rec.anchor.filter(|_| !unmoved).and_then(|a| {
            transforms
                .get(a.instance as usize)
                .map(|&now| a.motion_to(now))
        });
        let site = motion::replacement_site(
            rec.site,
            &rec.record,
            motion.as_ref(),
            crate::sampling::hash_combine(id, t),
        );
        (site, unmoved)
    }

    /// Whether the replacement site of record `id` at frame `t` lies inside an object that
    /// moved since the record's birth (every other object if its own moved with it, or if
    /// the birth frame's transforms are gone; its own too when the record stayed at its
    /// world position, which the moved object may have swallowed):
    /// [`buried::SiteBurial::buried`].
    fn replacement_buried(
        &self,
        id: u32,
        t: u32,
        transforms: &[Mat4],
        burial: &mut buried::SiteBurial<'_>,
    ) -> bool {
        let (site, _) = self.replacement_site(id, t, transforms);
        let rec = self.rec(id);
        let then = self.transforms_of_frame(rec.birth);
        let own = site.instance as usize;
        let own_moved = then.get(own) != transforms.get(own);
        let carried = rec.anchor.is_some();
        let movers: Vec<usize> = (0..transforms.len())
            .filter(|&j| {
                if j == own {
                    own_moved && !carried
                } else {
                    own_moved || then.get(j) != transforms.get(j)
                }
            })
            .collect();
        !movers.is_empty() && burial.buried(&site, &movers)
    }

    /// Per record of `expired` (the last frame's records that end before frame `t`, in
    /// frame order, as (index in that frame, id)), the pixels it covers that decide its
    /// replacement ([`Replacement`]) and the pixels it covers at all. Except
    /// with the seed's rule, both are of frame t: the expired records where they would be
    /// now (and, for [`Replacement::Needed`], the `kept` ones) splatted over frame t's
    /// visibility buffer, which is returned for the frame to reuse.
    #[allow(clippy::too_many_arguments)]
    fn expired_coverage(
        &mut self,
        renderer: &Renderer,
        now: &PreparedScene,
        camera: &Camera,
        t: u32,
        kept: &[Record],
        expired: &[(usize, u32)],
        transforms: &[Mat4],
        vis: &mut Option<VisibilityBuffer>,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<(Vec<u32>, Vec<u32>)> {
        let mode = self.settings.replacement;
        if mode == Replacement::Covering {
            // Counted by the last frame's splat, for every record of that frame.
            let expired_then: Vec<u32> = expired
                .iter()
                .map(|&(i, _)| self.coverage.get(i).copied().unwrap_or(0))
                .collect();
            return Ok((expired_then.clone(), expired_then));
        }
        if expired.is_empty() {
            return Ok((Vec::new(), Vec::new()));
        }
        let ctx = &renderer.ctx;
        if vis.is_none() {
            *vis = Some(renderer.visibility(now, camera, times)?);
        }
        let Some(vis) = vis.as_ref() else {
            return Err(Error::Usage("internal: no visibility buffer".into()));
        };
        // Needed: the kept records first, so that the count sees which pixels they cover.
        let first = if mode == Replacement::Needed {
            kept.len()
        } else {
            0
        };
        let mut candidates = kept[..first].to_vec();
        candidates.extend(
            expired
                .iter()
                .map(|&(_, id)| self.world_record(self.rec(id).at(t), id, transforms)),
        );
        self.frame_records.upload(ctx, &candidates)?;
        let accuracy = self.pass.settings.accuracy;
        let mut count = |flags: Option<&[bool]>| -> Result<Vec<u32>> {
            let all =
                renderer.record_coverage(now, vis, &self.frame_records, flags, accuracy, times)?;
            Ok(all[first..].to_vec())
        };
        let covering = count(None)?;
        let deciding = if mode == Replacement::Needed {
            let flags: Vec<bool> = (0..candidates.len()).map(|i| i >= first).collect();
            count(Some(&flags))?
        } else {
            covering.clone()
        };
        Ok((deciding, covering))
    }

    /// `record` (record `id` as given at its first frame's place) where record `id` is
    /// when the instances have `transforms`: unchanged for records that keep their world
    /// position, carried by its instance's motion since then otherwise.
    fn world_record(&self, record: Record, id: u32, transforms: &[Mat4]) -> Record {
        match &self.rec(id).anchor {
            Some(anchor) => match transforms.get(anchor.instance as usize) {
                Some(&now) => motion::move_record(&record, &anchor.motion_to(now)),
                None => record,
            },
            None => record,
        }
    }

    /// The record `id` at frame `t` with this cache's temporal gradients (interpolated
    /// towards its successor when it has one, else extrapolated), where it is at frame `t`
    /// (which must have been rendered). `id` must be retained ([`TemporalCache::record`]).
    pub fn record_at(&self, id: u32, t: u32) -> Record {
        self.record_at_with(id, t, self.transforms_of_frame(t))
    }

    /// Every instance's transform at rendered frame `t` (empty if it was not rendered).
    fn transforms_of_frame(&self, t: u32) -> &[Mat4] {
        self.frames
            .iter()
            .find(|f| f.frame == t)
            .map(|f| f.transforms.as_slice())
            .unwrap_or(&[])
    }

    /// [`TemporalCache::record_at`] with frame `t`'s instance transforms already looked up
    /// (one lookup per frame, not per record).
    fn record_at_with(&self, id: u32, t: u32, transforms: &[Mat4]) -> Record {
        let r = self.rec(id);
        let at_birth_place = match (self.settings.gradients, r.successor) {
            (TemporalGradients::Interpolated, Some(l)) if !r.before_break => {
                let mut successor = *self.rec(l);
                // The successor as it would be at this record's place at its first frame
                // (the same place on the instance).
                if let (Some(mine), Some(its)) = (r.anchor, successor.anchor) {
                    successor.record =
                        motion::move_record(&successor.record, &its.motion_to(mine.transform));
                }
                r.interpolated(t, &successor)
            }
            _ => r.at(t),
        };
        self.world_record(at_birth_place, id, transforms)
    }

    /// The coefficient block of record `id` at frame `t`, as [`TemporalCache::record_at`]
    /// gives the record: every coefficient interpolated towards its successor's or
    /// extrapolated by its estimate at t+1 (radiance.rs), where the record is when the
    /// instances have `transforms`. Empty for irradiance records.
    fn block_at_with(&self, id: u32, t: u32, transforms: &[Mat4]) -> Vec<f32> {
        let r = self.rec(id);
        let blocks = &self.blocks[(id - self.history_base) as usize];
        if blocks.now.is_empty() {
            return Vec::new();
        }
        let at_birth_place = match (self.settings.gradients, r.successor) {
            (TemporalGradients::Interpolated, Some(l)) if !r.before_break => {
                let successor = self.rec(l);
                let mut to = self.blocks[(l - self.history_base) as usize].now.clone();
                if let (Some(mine), Some(its)) = (r.anchor, successor.anchor) {
                    to = radiance::move_coefficients(&to, &its.motion_to(mine.transform));
                }
                let span = successor.birth.saturating_sub(r.birth).max(1) as f32;
                let f = t.saturating_sub(r.birth) as f32 / span;
                radiance::blend_coefficients(&blocks.now, &to, f)
            }
            // Extrapolated: c + (c(t+1) - c) (t - t_k).
            _ => radiance::blend_coefficients(
                &blocks.now,
                &blocks.next,
                t.saturating_sub(r.birth) as f32,
            ),
        };
        match (
            &r.anchor,
            r.anchor.and_then(|a| transforms.get(a.instance as usize)),
        ) {
            (Some(anchor), Some(&now)) => {
                radiance::move_coefficients(&at_birth_place, &anchor.motion_to(now))
            }
            _ => at_birth_place,
        }
    }

    /// The records of rendered frame `t` as the second pass renders them, with their
    /// coefficient blocks; None when frame `t` was not rendered.
    fn second_pass_records(&self, t: u32) -> Option<(Vec<Record>, Vec<f32>)> {
        let ids = &self.frames.iter().find(|f| f.frame == t)?.ids;
        let transforms = self.transforms_of_frame(t);
        let records = ids
            .iter()
            .map(|&id| self.record_at_with(id, t, transforms))
            .collect();
        let blocks = ids
            .iter()
            .flat_map(|&id| self.block_at_with(id, t, transforms))
            .collect();
        Some((records, blocks))
    }

    /// Second pass of interpolated gradients: renders frame `t` again over exactly the
    /// records the first pass used there, now interpolated between each record and its
    /// successor (no placement: coverage is the first pass's). Its bytes are final once
    /// [`TemporalCache::second_pass_ready`] says so; frames released are refused.
    pub fn render_second_pass(
        &mut self,
        renderer: &Renderer,
        scene: &PreparedScene,
        camera: &Camera,
        t: u32,
    ) -> Result<Frame> {
        if t < self.released_before {
            return Err(Error::Usage(format!(
                "frame {t} was released (frames before {} are)",
                self.released_before
            )));
        }
        let not_rendered = || Error::Usage(format!("frame {t} was not rendered by the first pass"));
        let (records, blocks) = self.second_pass_records(t).ok_or_else(not_rendered)?;
        self.second_records
            .upload_with_coefficients(&renderer.ctx, &records, &blocks)?;
        // Radiance records, interpolated the same way, over exactly the first pass's too.
        let radiance = match self.radiance.as_deref_mut() {
            Some(r) => {
                let (records, blocks) =
                    r.records.second_pass_records(t).ok_or_else(not_rendered)?;
                let rc = &mut r.records;
                rc.second_records
                    .upload_with_coefficients(&renderer.ctx, &records, &blocks)?;
                Some(RadianceFrame {
                    records: &mut rc.second_records,
                    pass: &rc.pass,
                    splat: &r.splat,
                    stage: None,
                    max_new_records: Some(0),
                })
            }
            None => None,
        };
        let (frame, _) = renderer.render_cached_frame(
            scene,
            camera,
            &mut self.second_records,
            &self.pass,
            CachedFrameOptions {
                max_new_records: Some(0),
                radiance,
                ..Default::default()
            },
            |_| {},
        )?;
        Ok(frame)
    }

    /// The records used in the last frame at frame `t`, with their lifespans in frames
    /// (for the lifespan map).
    pub fn alive_records(&self, t: u32) -> (Vec<Record>, Vec<u32>) {
        self.records_with_lifespans(&self.alive, t)
    }

    /// Same for the records frame `t` used (any frame rendered so far and not released;
    /// empty otherwise).
    pub fn records_of_frame(&self, t: u32) -> (Vec<Record>, Vec<u32>) {
        match self.frames.iter().find(|f| f.frame == t) {
            Some(f) if t >= self.released_before => self.records_with_lifespans(&f.ids, t),
            _ => (Vec::new(), Vec::new()),
        }
    }

    fn records_with_lifespans(&self, ids: &[u32], t: u32) -> (Vec<Record>, Vec<u32>) {
        let transforms = self.transforms_of_frame(t);
        ids.iter()
            .map(|&id| {
                let r = self.rec(id);
                let lifespan = r.last_frame.saturating_sub(r.birth).saturating_add(1);
                (self.record_at_with(id, t, transforms), lifespan)
            })
            .unzip()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(e: [f32; 3], g: f32) -> Record {
        Record {
            irradiance: e,
            rotation_gradient: [[g, g, g, 0.0]; 3],
            translation_gradient: [[-g, -g, -g, 0.0]; 3],
            ..Record::default()
        }
    }

    #[test]
    fn a_record_at_t_plus_1_scales_by_its_subsets_change_channel_by_channel() {
        let r = record([1.0, 2.0, 4.0], 0.5);
        // Unchanged subset: the record itself, bit for bit (tau exactly 1).
        let same = scaled_by_estimate(
            &r,
            &record([0.3, 0.2, 0.1], 0.0),
            &record([0.3, 0.2, 0.1], 9.0),
        );
        assert_eq!(same, r);
        assert_eq!(temporal_ratio(r.irradiance, same.irradiance), 1.0);
        // Red doubles, green halves; blue's subset is dark: it takes the estimate.
        let next = scaled_by_estimate(
            &r,
            &record([0.5, 0.4, 0.0], 0.0),
            &record([1.0, 0.2, 0.25], 0.0),
        );
        assert_eq!(next.irradiance, [2.0, 1.0, 0.25]);
        assert_eq!(next.rotation_gradient[0], [1.0, 1.0, 1.0, 0.0]);
        assert_eq!(next.translation_gradient[1], [-0.25, -0.25, -0.25, 0.0]);
        assert_eq!(next.rotation_gradient[2], [0.5, 0.5, 0.5, 0.0]);
        let tau = temporal_ratio(r.irradiance, next.irradiance);
        let expected = luminance([2.0, 1.0, 0.25]) / luminance([1.0, 2.0, 4.0]);
        assert!((tau - expected).abs() < 1e-6, "{tau} vs {expected}");
    }

    #[test]
    fn auto_refresh_goes_on_where_it_saved_a_fifth_of_the_rays() {
        // Measured: cube in a box, frames 1..59 (P 64), and spheres, frames 1..9 (P 32).
        assert!(refresh_pays((566, 566 * 4096 / 4, 812), 64));
        assert!(!refresh_pays((763, 763 * 1024 * 59 / 100, 4995), 32));
        // Too few refreshed planes to judge yet.
        assert!(refresh_pays((63, 63 * 1024, 4995), 32));
        // The threshold: saving exactly a fifth of the rays.
        assert!(refresh_pays((100, 0, 500), 8));
        assert!(!refresh_pays((100, 1, 500), 8));
    }

    #[test]
    fn estimate_stride_defaults_to_2_only_where_it_fits_and_tau_is_its_only_use() {
        let interpolated = TemporalSettings::default();
        assert_eq!(interpolated.estimate_stride_for(32), 2);
        assert_eq!(interpolated.estimate_stride_for(8), 2);
        assert_eq!(interpolated.estimate_stride_for(6), 1);
        assert_eq!(interpolated.estimate_stride_for(33), 1);
        let extrapolated = TemporalSettings {
            gradients: TemporalGradients::Extrapolated,
            ..TemporalSettings::default()
        };
        assert_eq!(extrapolated.estimate_stride_for(32), 1);
        let set = TemporalSettings {
            estimate_stride: Some(4),
            ..extrapolated
        };
        assert_eq!(set.estimate_stride_for(32), 4);
    }
}
