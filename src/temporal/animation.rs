//! Rendering an animation: the scene set to each frame, its BVH prepared, and every frame
//! rendered over a [`TemporalCache`] (records reused across frames) or, as the baseline,
//! over a fresh cache per frame (`--temporal off`).

use super::{FrameScenes, TemporalCache, TemporalFrameStats, TemporalGradients, TemporalSettings};
use crate::frame::{Frame, PreparedScene, Renderer};
use crate::records::{CacheSettings, Record};
use crate::scene::Scene;
use crate::{Error, Result};
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
/// after each. Returns the per-frame statistics.
pub fn render_animation(
    renderer: &Renderer,
    scene: &Scene,
    options: &AnimationOptions,
    mut on_frame: impl FnMut(AnimationFrame<'_>) -> Result<()>,
    mut progress: impl FnMut(u32, u32),
) -> Result<Vec<AnimationFrameStats>> {
    let (first, last) = (*options.frames.start(), *options.frames.end());
    if first > last {
        return Err(Error::Usage(format!("empty frame range {first}..{last}")));
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
            s.set_frame(t as f32);
            renderer.prepare_frame(s, &mut bvh, previous)
        };
    let mut temporal = match &options.temporal {
        Some(settings) => Some(TemporalCache::new(&renderer.ctx, &options.cache, settings)?),
        None => None,
    };
    // Interpolated gradients need every record's successor: a first pass places and
    // computes the records of the whole range, the second renders the frames.
    let two_pass = options
        .temporal
        .as_ref()
        .is_some_and(|t| t.gradients == TemporalGradients::Interpolated);
    let mut all = Vec::new();
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
        let frame_progress = |n: u32| progress(t, n);
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
                let (records, lifespans) = cache.alive_records(t);
                (frame, stats, records, lifespans)
            }
            None => {
                let mut cache = renderer.new_cache(&options.cache)?;
                let frame = renderer.render_gi_frame(
                    &prepared,
                    &current.camera,
                    &mut cache,
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
        if !two_pass {
            on_frame(AnimationFrame {
                frame_number: t,
                frame: &frame,
                scene: &current,
                records,
                lifespans,
                stats: &stats,
            })?;
        }
        all.push(stats);
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
                    current.set_frame((t + 1) as f32);
                    prepared
                }
                None => prepare(&mut current, t + 1, Some(&prepared))?,
            };
            prepare_ms = p0.elapsed().as_secs_f64() * 1e3;
        }
    }
    if let (true, Some(cache)) = (two_pass, temporal.as_mut()) {
        let mut scene_t = scene.clone();
        let mut prepared: Option<PreparedScene> = None;
        for (t, stats) in (first..=last).zip(all.iter_mut()) {
            let start = Instant::now();
            if prepared.is_none() || dynamic {
                prepared = Some(prepare(&mut scene_t, t, prepared.as_ref())?);
            } else {
                scene_t.set_frame(t as f32);
            }
            let Some(p) = prepared.as_ref() else {
                continue;
            };
            let frame = cache.render_second_pass(renderer, p, &scene_t.camera, t)?;
            stats.wall_ms += start.elapsed().as_secs_f64() * 1e3;
            // Both passes' GPU time in the frame's stats.
            let mut all = stats.frame_stats.pass_ms.clone();
            all.extend(frame.stats.pass_ms.iter().cloned());
            stats.frame_stats.pass_ms = crate::frame::sum_by_pass_owned(&all);
            let (records, lifespans) = cache.records_of_frame(t);
            on_frame(AnimationFrame {
                frame_number: t,
                frame: &frame,
                scene: &scene_t,
                records,
                lifespans,
                stats,
            })?;
        }
    }
    Ok(all)
}
