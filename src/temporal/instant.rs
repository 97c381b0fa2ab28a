//! Temporal instant caching (Debattista et al. 2009, seed 003; algorithms-other.md 2.4):
//! records gathered from VPLs (`--records vpl`) live for as long as the scene lets them,
//! and each frame traces again only the visibility rays that what moved may have changed.
//!
//! Every frame the VPLs are traced again with the same sequence (`crate::vpl`: an
//! unchanged scene gives the same VPLs, slot for slot), and:
//! 1. slots whose VPL differs from the last frame's are invalid (Cases 1-2: a light path
//!    newly occluded or freed by a moved object, a moved or changed light);
//! 2. records on an instance that moved are deleted (Case 5) and placed again where the
//!    new frame needs them, and so are records whose site a moved instance now covers
//!    (`super::buried`: updated in place they would gather from inside it);
//! 3. every other record is updated in place (`vpl_gather.wgsl`, update mode): a ray is
//!    traced again where its VPL is invalid or its segment meets the box of a moved
//!    instance at either frame (Cases 3-4, conservatively by boxes; shared/movers.wgsl),
//!    and keeps the visibility bit it had otherwise. E and its gradients are summed anew
//!    from every VPL (no quantisation drift), R is kept;
//! 4. placement adds records where no record covers a pixel, as in any frame.
//!
//! Records never expire otherwise (the seed leaves eviction to future work): a camera that
//! keeps discovering the scene keeps adding records.

use super::TemporalFrameStats;
use super::plane_refresh::span_bounds;
use crate::frame::{CachedFrameOptions, Frame, PreparedScene, Renderer};
use crate::records::vpl_gather::FrameChange;
use crate::records::vpl_update::VplUpdatePass;
use crate::records::{CacheSettings, RecordCache, RecordPass};
use crate::scene::Scene;
use crate::vpl::Vpl;
use crate::{Error, Result};
use glam::{Mat4, Vec3};

/// What an update saved (the `--stats` JSON of `animate --records vpl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct InstantFrameStats {
    /// VPL slots whose VPL changed since the last frame (all of them in the first).
    pub changed_vpls: u32,
    pub vpl_slots: u32,
    /// Instances that moved since the last frame.
    pub moved_instances: u32,
    /// Visibility rays of kept records traced again, and those whose bit was reused.
    pub traced_rays: u64,
    pub reused_rays: u64,
}

/// A cache of VPL records carried across frames.
pub struct InstantCache {
    settings: CacheSettings,
    pass: RecordPass,
    update: VplUpdatePass,
    records: Option<RecordCache>,
    /// The last frame's VPLs and instance transforms.
    previous: Option<(Vec<Vpl>, Vec<Mat4>)>,
    /// Object-space BVHs of the large moving meshes the burial test searched.
    mesh_bvhs: super::buried::MeshBvhs,
}

/// Whether two VPLs differ (beyond rounding: a BVH rebuilt around a moved instance may
/// break a tie between two triangles at a shared edge the other way).
fn vpl_changed(a: &Vpl, b: &Vpl) -> bool {
    let close = |x: [f32; 3], y: [f32; 3]| {
        let (x, y) = (Vec3::from(x), Vec3::from(y));
        (x - y).length() <= 1e-6 * x.length().max(y.length()).max(1e-3)
    };
    !(close(a.position, b.position) && close(a.normal, b.normal) && close(a.power, b.power))
}

impl InstantCache {
    pub fn new(renderer: &Renderer, settings: &CacheSettings) -> Result<Self> {
        Ok(Self {
            settings: settings.clone(),
            pass: RecordPass::new(&renderer.ctx, settings)?,
            update: VplUpdatePass::new(&renderer.ctx)?,
            records: None,
            previous: None,
            mesh_bvhs: Default::default(),
        })
    }

    /// Renders frame `t` of `scene` (prepared as `prepared`) over the records of the
    /// frames before, updated to this one.
    pub fn render_frame(
        &mut self,
        renderer: &Renderer,
        prepared: &PreparedScene,
        scene: &Scene,
        t: u32,
        progress: impl FnMut(u32),
    ) -> Result<(Frame, TemporalFrameStats, InstantFrameStats)> {
        let ctx = &renderer.ctx;
        let mut times = Vec::new();
        let vpl_stats = renderer
            .scene_vpls(prepared, &self.settings, &mut times)?
            .ok_or_else(|| Error::Usage("internal: instant caching needs --records vpl".into()))?;
        let set = prepared
            .gpu
            .vpls()
            .ok_or_else(|| Error::Gpu("internal: no VPLs after tracing".into()))?;
        let mut vpls: Vec<Vpl> = ctx.read_buffer(&set.buffer)?;
        vpls.truncate(set.count as usize);
        let transforms: Vec<Mat4> = scene.instances.iter().map(|i| i.transform).collect();
        let slots = vpl_stats.slots;
        if self
            .records
            .as_ref()
            .is_none_or(|r| r.visibility_words != slots.div_ceil(32).max(1))
        {
            self.records = Some(RecordCache::with_vpl_visibility(ctx, slots)?);
            self.previous = None;
        }
        let Some(records) = self.records.as_mut() else {
            return Err(Error::Gpu("internal: no record cache".into()));
        };
        let mut stats = InstantFrameStats {
            changed_vpls: slots,
            vpl_slots: slots,
            ..Default::default()
        };
        let (mut deleted, mut buried) = (0, 0);
        if let Some((old_vpls, old_transforms)) = self.previous.take() {
            // Cases 1-2: VPL slots that changed.
            let mut changed = vec![0u32; slots.div_ceil(32).max(1) as usize];
            stats.changed_vpls = 0;
            for (j, (a, b)) in vpls.iter().zip(&old_vpls).enumerate() {
                if vpl_changed(a, b) {
                    changed[j / 32] |= 1 << (j % 32);
                    stats.changed_vpls += 1;
                }
            }
            // Case 5: records on moved instances go.
            let (movers, moved) = span_bounds(scene, &old_transforms, &transforms);
            stats.moved_instances = moved.iter().filter(|&&m| m != 0).count() as u32;
            let all = records.read(ctx)?;
            let bits = records.read_visibility(ctx)?;
            let words = records.visibility_words as usize;
            let (mut kept, mut kept_bits) = (Vec::new(), Vec::new());
            // A kept record whose site a moved instance now covers would gather its VPLs
            // from inside it (buried.rs): it goes too, and placement covers its pixels.
            let moved_instances: Vec<usize> = (0..moved.len()).filter(|&j| moved[j] != 0).collect();
            let mut burial = super::buried::SiteBurial::new(scene, &mut self.mesh_bvhs);
            for (k, r) in all.iter().enumerate() {
                if moved.get(r.instance as usize).copied().unwrap_or(0) != 0 {
                    deleted += 1;
                    continue;
                }
                // The site the update gathers from (its shading normal lifts the rays).
                let site = crate::records::vpl_gather::site_of(r);
                if !moved_instances.is_empty() && burial.buried(&site, &moved_instances) {
                    deleted += 1;
                    buried += 1;
                    continue;
                }
                kept.push(*r);
                kept_bits.extend_from_slice(&bits[k * words..(k + 1) * words]);
            }
            records.upload_with_visibility(ctx, &kept, &kept_bits)?;
            // Cases 1-4: the kept records' rays.
            let (lo, hi) = crate::temporal::motion::MovingBounds::union(&movers);
            let moving = if movers.is_empty() {
                vec![0u8; 160]
            } else {
                bytemuck::cast_slice(&movers).to_vec()
            };
            let change = FrameChange {
                changed: &changed,
                moving: &moving,
                moving_count: movers.len() as u32,
                movers_lo: lo,
                movers_hi: hi,
            };
            let counts = self.update.run(
                ctx,
                &prepared.gpu,
                &self.settings,
                records,
                &change,
                &mut times,
            )?;
            stats.traced_rays = counts.traced;
            stats.reused_rays = counts.reused;
        }
        let kept = records.count;
        let (mut frame, _) = renderer.render_cached_frame(
            prepared,
            &scene.camera,
            records,
            &self.pass,
            CachedFrameOptions::default(),
            progress,
        )?;
        // The update's GPU time (and the VPL trace's) beside the frame's passes.
        let mut all: Vec<(String, f64)> = times
            .iter()
            .map(|(name, ms)| (name.to_string(), *ms))
            .collect();
        all.extend(frame.stats.pass_ms.iter().cloned());
        frame.stats.pass_ms = crate::frame::sum_by_pass_owned(&all);
        let c = frame.stats.cache.clone().unwrap_or_default();
        let new = c.placement.new_records;
        let temporal = TemporalFrameStats {
            frame: t,
            alive: records.count,
            kept,
            deleted,
            buried,
            new,
            plane_rays: stats.traced_rays + c.plane_rays,
            ..Default::default()
        };
        self.previous = Some((vpls, transforms));
        Ok((frame, temporal, stats))
    }

    /// The records alive now.
    pub fn records(&self, ctx: &crate::gpu::GpuContext) -> Result<Vec<crate::records::Record>> {
        match &self.records {
            Some(r) => r.read(ctx),
            None => Ok(Vec::new()),
        }
    }
}
