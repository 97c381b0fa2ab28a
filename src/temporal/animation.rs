//! Rendering an animation: the scene set to each frame, its BVH prepared, and every frame
//! rendered over a [`TemporalCache`] (records reused across frames) or, as the baseline,
//! over a fresh cache per frame (`--temporal off`).

use super::{FrameScenes, TemporalCache, TemporalFrameStats, TemporalGradients, TemporalSettings};
use crate::frame::{Frame, PreparedScene, Renderer};
use crate::records::{CacheSettings, Record, RecordSource};
use crate::scene::Scene;
use crate::{Error, Result};
use std::collections::VecDeque;
use std::ops::RangeInclusive;
use std::time::Instant;

/// What to render.
#[derive(Clone, Debug)]
pub struct AnimationOptions {
    pub frames: RangeInclusive<u32>,
    pub cache: CacheSettings,
    /// None: the per-frame baseline (a new cache every frame).
    pub temporal: Option<TemporalSettings>,
}

/// One rendered frame, handed to the caller to write out.
pub struct AnimationFrame<'a> {
    pub frame_number: u32,
    pub frame: &'a Frame,
    /// The scene at this frame (camera, lights).
    pub scene: &'a Scene,
    /// Records used in this frame (at this frame's time) and their lifespans in frames;
    /// empty for the per-frame baseline.
    pub records: Vec<Record>,
    pub lifespans: Vec<u32>,
    pub stats: &'a AnimationFrameStats,
    /// With interpolated gradients, the last frame the first pass has computed when this
    /// one is handed over (at most dt_max frames ahead, see
    /// [`TemporalCache::second_pass_ready`]); None with one pass.
    pub first_pass_at: Option<u32>,
    /// Records and frame lists the temporal cache retains at this point
    /// ([`TemporalCache::history_len`], [`TemporalCache::frames_retained`]); 0 for the
    /// per-frame baseline.
    pub retained_records: usize,
    pub retained_frames: usize,
}

/// What [`render_animation`] reports as it goes (for a progress display), with the frame
/// it concerns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnimationStep {
    /// Placing the frame's records: this many new so far (in the only pass, or in the
    /// first of interpolated gradients).
    Placing { new_records: u32 },
    /// The first pass of interpolated gradients computed the frame's records. The frame
    /// is rendered (and handed to `on_frame`) once each of its records has its successor
    /// or has ended: at most dt_max frames later.
    Computed,
}

/// Totals over the frames rendered (each frame's statistics go to `on_frame`).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct AnimationSummary {
    pub frames: u32,
    /// Sum of the frames' wall times (ms).
    pub wall_ms: f64,
    /// Hemisphere rays of the records computed.
    pub plane_rays: u64,
    /// Records computed (new and replacements).
    pub records_computed: u64,
    /// The most records and frame lists the temporal cache retained at once (bounded by
    /// dt_max, not by the range).
    pub max_retained_records: usize,
    pub max_retained_frames: usize,
}

impl AnimationSummary {
    fn add(&mut self, stats: &AnimationFrameStats, retained: (usize, usize)) {
        self.frames += 1;
        self.wall_ms += stats.wall_ms;
        self.plane_rays += stats.temporal.plane_rays;
        self.records_computed += u64::from(stats.temporal.new + stats.temporal.replaced);
        self.max_retained_records = self.max_retained_records.max(retained.0);
        self.max_retained_frames = self.max_retained_frames.max(retained.1);
    }
}

/// Statistics of one animation frame (the `--stats` JSON of `animate`).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct AnimationFrameStats {
    pub frame: u32,
    /// Wall time of the frame: scene update and BVH, rendering, readback (ms).
    pub wall_ms: f64,
    /// Setting the scene to the frame, building its BVH and uploading it (ms).
    pub prepare_ms: f64,
    pub frame_stats: crate::frame::FrameStats,
    pub temporal: TemporalFrameStats,
}

/// Whether anything that changes irradiance (instances, lights) moves in the scene.
pub fn scene_is_dynamic(scene: &Scene) -> bool {
    (0..scene.instances.len()).any(|i| scene.instance_is_animated(i)) || scene.lights_are_animated()
}

/// Renders `options.frames` of `scene` (set to each frame in turn), calling `on_frame`
/// after each frame is rendered, in order, and `progress` as the work goes. With
/// interpolated gradients the first pass (records) runs ahead and the second (images)
/// follows it at most dt_max frames behind, as soon as every record of its frame has its
/// successor: the first frame is written after about dt_max frames, whatever the range,
/// and the cache releases what only rendered frames needed, so memory is bounded by
/// dt_max frames, not by the range (the bytes are those of two passes over the whole
/// range). Returns the totals; each frame's statistics go to `on_frame`.
pub fn render_animation(
    renderer: &Renderer,
    scene: &Scene,
    options: &AnimationOptions,
    mut on_frame: impl FnMut(AnimationFrame<'_>) -> Result<()>,
    mut progress: impl FnMut(u32, AnimationStep),
) -> Result<AnimationSummary> {
    let (first, last) = (*options.frames.start(), *options.frames.end());
    if first > last {
        return Err(Error::Usage(format!("empty frame range {first}..{last}")));
    }
    // Animations keep the record sizing they were measured with (CacheSettings::resolved).
    let options = &AnimationOptions {
        cache: options.cache.for_animation(),
        ..options.clone()
    };
    if options.temporal.is_some() && options.cache.source == RecordSource::Photons {
        return Err(Error::Usage(
            "records from photons (--records photons) do not work with temporal caching \
             yet: use --temporal off (each frame its own photon records) or --records \
             planes or vpl"
                .into(),
        ));
    }
    if options.temporal.is_some() && options.cache.source == RecordSource::Vpl {
        return render_instant(renderer, scene, options, on_frame, progress);
    }
    let dynamic = scene_is_dynamic(scene);
    let mut current = scene.clone();
    let mut next_scene = scene.clone();
    // Mesh BVHs are built once; each frame rebuilds the top level (TLAS rebuild and
    // refit cost about the same here, see docs/results.md, and a rebuild never degrades)
    let mut bvh = None;
    // and shares the mesh and texture buffers of the frame before.
    let mut prepare =
        |s: &mut Scene, t: u32, previous: Option<&PreparedScene>| -> Result<PreparedScene> {
            // Checked: an interpolated state that degenerates is an error naming the frame.
            s.try_set_frame(t as f32)?;
            renderer.prepare_frame(s, &mut bvh, previous)
        };
    // Record passes' plane pipelines compiled for this scene's features alone (the same
    // bytes, less code to run per plane ray); `SceneFeatures::of` holds over every frame.
    let features = crate::gpu::SceneFeatures::of(scene);
    let mut temporal = match &options.temporal {
        Some(settings) => Some(TemporalCache::for_scene(
            &renderer.ctx,
            &options.cache,
            settings,
            features,
        )?),
        None => None,
    };
    // Interpolated gradients need every record's successor: a first pass places and
    // computes the records, the second renders each frame once its records' successors
    // are known (at most dt_max frames later).
    let two_pass = options
        .temporal
        .as_ref()
        .is_some_and(|t| t.gradients == TemporalGradients::Interpolated);
    // The records alive at the range's end are closed there, so that the last frames
    // interpolate too (TemporalCache::close_range_at).
    if let (Some(cache), true) = (temporal.as_mut(), two_pass && dynamic) {
        cache.close_range_at(last);
    }
    let mut summary = AnimationSummary::default();
    // Frames the first pass computed that wait for the second (at most dt_max + 1), and
    // the second pass's own scene (it runs behind the first).
    let mut pending: VecDeque<AnimationFrameStats> = VecDeque::new();
    let mut second = SecondPass {
        scene: scene.clone(),
        prepared: None,
    };
    // The per-frame baseline's cache (records emptied every frame).
    let mut per_frame: Option<crate::frame::IrradianceCache> = None;
    let t0 = Instant::now();
    let mut prepared = prepare(&mut current, first, None)?;
    let mut prepare_ms = t0.elapsed().as_secs_f64() * 1e3;
    for t in first..=last {
        let start = Instant::now();
        // The scene at t+1 (for the E(t+1) estimate); reused as the next frame's scene.
        let ahead = if temporal.is_some() && dynamic && t < last {
            let p0 = Instant::now();
            let p = prepare(&mut next_scene, t + 1, Some(&prepared))?;
            prepare_ms += p0.elapsed().as_secs_f64() * 1e3;
            Some(p)
        } else {
            None
        };
        let frame_progress = |n: u32| progress(t, AnimationStep::Placing { new_records: n });
        let (frame, temporal_stats, records, lifespans) = match temporal.as_mut() {
            Some(cache) => {
                let (frame, stats) = cache.render_frame(
                    renderer,
                    FrameScenes {
                        now: &prepared,
                        scene: &current,
                        next: ahead.as_ref().map(|p| (p, &next_scene)),
                    },
                    &current.camera,
                    t,
                    dynamic,
                    two_pass,
                    frame_progress,
                )?;
                let (records, lifespans) = if two_pass {
                    (Vec::new(), Vec::new())
                } else {
                    cache.alive_records(t)
                };
                (frame, stats, records, lifespans)
            }
            None => {
                // A fresh cache every frame, computed by passes built once (building a
                // record pass compiles its pipelines: ~170 ms a frame on lavapipe that
                // recomputation itself does not need).
                let cache = match per_frame.as_mut() {
                    Some(cache) => {
                        cache.records = crate::records::RecordCache::new(&renderer.ctx)?;
                        if let Some(r) = cache.radiance.as_mut() {
                            r.records = crate::records::RecordCache::with_kind(
                                &renderer.ctx,
                                r.records.kind,
                            )?;
                        }
                        cache
                    }
                    None => per_frame.insert(renderer.new_cache_for(&options.cache, features)?),
                };
                let frame = renderer.render_gi_frame(
                    &prepared,
                    &current.camera,
                    cache,
                    None,
                    frame_progress,
                )?;
                let c = frame.stats.cache.clone().unwrap_or_default();
                let stats = TemporalFrameStats {
                    frame: t,
                    alive: c.records,
                    new: c.placement.new_records,
                    plane_rays: c.plane_rays,
                    // A fresh cache every frame: each record serves one frame.
                    lifespans: vec![c.placement.new_records],
                    ..Default::default()
                };
                (frame, stats, Vec::new(), Vec::new())
            }
        };
        let stats = AnimationFrameStats {
            frame: t,
            wall_ms: start.elapsed().as_secs_f64() * 1e3 + prepare_ms,
            prepare_ms,
            frame_stats: frame.stats.clone(),
            temporal: temporal_stats,
        };
        match temporal.as_mut() {
            Some(cache) if two_pass => {
                pending.push_back(stats);
                progress(t, AnimationStep::Computed);
                // Every frame whose records all have their successors, in order.
                while pending
                    .front()
                    .is_some_and(|s| cache.second_pass_ready(s.frame, last))
                {
                    let Some(stats) = pending.pop_front() else {
                        break;
                    };
                    second.render(
                        renderer,
                        cache,
                        &mut prepare,
                        dynamic,
                        stats,
                        t,
                        &mut on_frame,
                        &mut summary,
                    )?;
                }
            }
            _ => {
                let retained = temporal
                    .as_ref()
                    .map_or((0, 0), |c| (c.history_len(), c.frames_retained()));
                on_frame(AnimationFrame {
                    frame_number: t,
                    frame: &frame,
                    scene: &current,
                    records,
                    lifespans,
                    stats: &stats,
                    first_pass_at: None,
                    retained_records: retained.0,
                    retained_frames: retained.1,
                })?;
                summary.add(&stats, retained);
                // Nothing renders this frame again.
                if let Some(cache) = temporal.as_mut() {
                    cache.release_frames_before(t + 1);
                }
            }
        }
        // Next frame's scene: the one prepared ahead, else prepare it now.
        if t < last {
            let p0 = Instant::now();
            prepared = match ahead {
                Some(p) => {
                    std::mem::swap(&mut current, &mut next_scene);
                    p
                }
                // Nothing that lights the scene moves: only the camera changes.
                None if !dynamic => {
                    current.try_set_frame((t + 1) as f32)?;
                    prepared
                }
                None => prepare(&mut current, t + 1, Some(&prepared))?,
            };
            prepare_ms = p0.elapsed().as_secs_f64() * 1e3;
        }
    }
    // The range is done: every record has its successor or has ended.
    if let Some(cache) = temporal.as_mut() {
        while let Some(stats) = pending.pop_front() {
            second.render(
                renderer,
                cache,
                &mut prepare,
                dynamic,
                stats,
                last,
                &mut on_frame,
                &mut summary,
            )?;
        }
    }
    Ok(summary)
}

/// The second pass of interpolated gradients: its scene, behind the first pass's.
struct SecondPass {
    scene: Scene,
    prepared: Option<PreparedScene>,
}

impl SecondPass {
    /// Renders frame `stats.frame` over the records of the first pass (which is at frame
    /// `first_pass_at`), hands it to `on_frame` and releases what only it needed.
    #[allow(clippy::too_many_arguments)]
    fn render(
        &mut self,
        renderer: &Renderer,
        cache: &mut TemporalCache,
        prepare: &mut impl FnMut(&mut Scene, u32, Option<&PreparedScene>) -> Result<PreparedScene>,
        dynamic: bool,
        mut stats: AnimationFrameStats,
        first_pass_at: u32,
        on_frame: &mut impl FnMut(AnimationFrame<'_>) -> Result<()>,
        summary: &mut AnimationSummary,
    ) -> Result<()> {
        let t = stats.frame;
        let start = Instant::now();
        let p = match self.prepared.take() {
            Some(p) if !dynamic => {
                self.scene.try_set_frame(t as f32)?;
                p
            }
            previous => prepare(&mut self.scene, t, previous.as_ref())?,
        };
        let frame = cache.render_second_pass(renderer, &p, &self.scene.camera, t)?;
        self.prepared = Some(p);
        stats.wall_ms += start.elapsed().as_secs_f64() * 1e3;
        // Both passes' GPU time in the frame's stats.
        let mut all = stats.frame_stats.pass_ms.clone();
        all.extend(frame.stats.pass_ms.iter().cloned());
        stats.frame_stats.pass_ms = crate::frame::sum_by_pass_owned(&all);
        stats
            .frame_stats
            .shader_compile_ms
            .extend(frame.stats.shader_compile_ms.iter().cloned());
        let (records, lifespans) = cache.records_of_frame(t);
        let retained = (cache.history_len(), cache.frames_retained());
        on_frame(AnimationFrame {
            frame_number: t,
            frame: &frame,
            scene: &self.scene,
            records,
            lifespans,
            stats: &stats,
            first_pass_at: Some(first_pass_at),
            retained_records: retained.0,
            retained_frames: retained.1,
        })?;
        summary.add(&stats, retained);
        cache.release_frames_before(t + 1);
        Ok(())
    }
}

/// [`render_animation`] with temporal instant caching (`--records vpl`,
/// [`super::instant`]): one pass, each frame's records updated from the last frame's.
fn render_instant(
    renderer: &Renderer,
    scene: &Scene,
    options: &AnimationOptions,
    mut on_frame: impl FnMut(AnimationFrame<'_>) -> Result<()>,
    mut progress: impl FnMut(u32, AnimationStep),
) -> Result<AnimationSummary> {
    let (first, last) = (*options.frames.start(), *options.frames.end());
    let dynamic = scene_is_dynamic(scene);
    let mut current = scene.clone();
    let mut bvh = None;
    let mut cache = super::instant::InstantCache::new(renderer, &options.cache)?;
    let mut summary = AnimationSummary::default();
    let mut prepared: Option<PreparedScene> = None;
    for t in first..=last {
        let start = Instant::now();
        current.try_set_frame(t as f32)?;
        // A scene where nothing that lights it moves keeps its BVH and its VPLs.
        let p = match prepared.take() {
            Some(p) if !dynamic => p,
            previous => renderer.prepare_frame(&current, &mut bvh, previous.as_ref())?,
        };
        let prepare_ms = start.elapsed().as_secs_f64() * 1e3;
        let (frame, mut temporal, instant) =
            cache.render_frame(renderer, &p, &current, t, |n| {
                progress(t, AnimationStep::Placing { new_records: n })
            })?;
        temporal.instant = Some(instant);
        let stats = AnimationFrameStats {
            frame: t,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
            prepare_ms,
            frame_stats: frame.stats.clone(),
            temporal,
        };
        let records = cache.records(&renderer.ctx)?;
        let retained = (records.len(), 0);
        on_frame(AnimationFrame {
            frame_number: t,
            frame: &frame,
            scene: &current,
            // Records from VPLs have no lifespan: they live until their instance moves.
            lifespans: Vec::new(),
            records,
            stats: &stats,
            first_pass_at: None,
            retained_records: retained.0,
            retained_frames: retained.1,
        })?;
        summary.add(&stats, retained);
        prepared = Some(p);
    }
    Ok(summary)
}
