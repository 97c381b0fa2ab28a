//! Records from virtual point lights (instant caching, Debattista et al. 2009, seed 003;
//! [`super::RecordSource::Vpl`]): a record's irradiance is the sum, over the scene's VPLs
//! ([`crate::vpl`]), of each VPL's light through one visibility ray (seed 003 eq. 1-3),
//! computed on the GPU by `wgsl/vpl_gather.wgsl` (one 64-lane workgroup per record, the
//! lanes' sums added in lane order: deterministic). Beside E a record gets:
//!
//! - **gradients** in closed form: a turn of the normal changes only each VPL's `cos_x`
//!   (rotational: `sum c / cos_x (n x w)`), a move of the site each term's distance and
//!   both cosines (translational: the derivative of `cos_x cos_y f(d) / d^2`, taken along
//!   the surface), with visibility held fixed as a plane holds its hits;
//! - **R**, the cosine-weighted harmonic mean of how far each visibility ray went (to its
//!   VPL, or to what blocks it), then clamped as plane records are (R_min..R_max,
//!   neighbours, Ward's gradient limit). Seed 003 eq. 5 drops R (its visibility rays are not
//!   spread over the hemisphere) and makes `a` a distance in scene units; keeping an R from
//!   the rays the record traced anyway keeps `-a` scale-free, shrinks records near
//!   occluders (where VPL visibility, which no gradient sees, changes fastest) and lets
//!   the one placement and splat serve every record source.
//!
//! [`reference_record`] is the CPU mirror tests compare against.

use super::{CacheSettings, Record, RecordSite};
use crate::bvh::cpu_trace::CpuTracer;
use crate::direct::reference::offset_ray_origin;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::{GpuScene, SceneVpls};
use crate::gpu::timer::{PassTimer, spanning};
use crate::vpl::Vpl;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Lanes per record (WGSL `LANES`).
pub const LANES: u32 = 64;

/// VPLs one dispatch gathers: each lane traces at most
/// [`crate::gpu::context::MAX_RAYS_PER_INVOCATION`] rays (llvmpipe's loop budget).
pub const VPLS_PER_DISPATCH: u32 = LANES * crate::gpu::context::MAX_RAYS_PER_INVOCATION;

/// Mirror of WGSL `VplGatherParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GatherParams {
    count: u32,
    first_record: u32,
    vpl_begin: u32,
    vpl_end: u32,
    vpl_count: u32,
    gradients: u32,
    r_max_factor: f32,
    neighbour_clamp: u32,
    clamp_distance: f32,
    mode: u32,
    visibility_words: u32,
    moving_count: u32,
    movers_lo: [f32; 4],
    movers_hi: [f32; 4],
}

/// Where a gather writes: records (the cache's buffer, records from `first_record`), and
/// their visibility bits when the cache keeps them (`words` per record; 0: none).
pub struct GatherTarget<'a> {
    pub records: &'a wgpu::Buffer,
    pub visibility: &'a wgpu::Buffer,
    pub visibility_words: u32,
}

impl<'a> GatherTarget<'a> {
    /// The records and visibility bits of `cache`.
    pub fn of(cache: &'a super::RecordCache) -> Self {
        Self {
            records: &cache.buffer,
            visibility: &cache.visibility,
            visibility_words: cache.visibility_words,
        }
    }
}

/// What changed between two frames, for an update ([`VplGatherPass::update`]).
pub struct FrameChange<'a> {
    /// One bit per VPL slot: set where the slot's VPL differs from the previous frame's.
    pub changed: &'a [u32],
    /// The instances that moved between the frames, as WGSL `MovingBounds` (160 bytes each,
    /// `temporal::motion::MovingBounds`), and the world box around them all.
    pub moving: &'a [u8],
    pub moving_count: u32,
    pub movers_lo: [f32; 4],
    pub movers_hi: [f32; 4],
}

/// Bytes of one lane's running sums (WGSL `Partial`).
const PARTIAL_BYTES: u64 = 128;

/// The gather pass.
pub struct VplGatherPass {
    gather: std::sync::Arc<ComputePass>,
}

impl VplGatherPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            gather: ComputePass::new(
                ctx,
                "vpl_gather.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                ],
            )?,
        })
    }

    /// Records the gather of `count` records at `sites` from `scene`'s VPLs into
    /// `target` from index `first_record` (the records before it are the neighbours
    /// clamping R), timed as one span "vpl gather".
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        settings: &CacheSettings,
        sites: &wgpu::Buffer,
        first_record: u32,
        count: u32,
        target: &GatherTarget<'_>,
        timer: &mut PassTimer,
    ) -> Result<()> {
        let no_change = FrameChange {
            changed: &[0],
            moving: &[0; 160],
            moving_count: 0,
            movers_lo: [0.0; 4],
            movers_hi: [0.0; 4],
        };
        self.dispatch(
            ctx,
            enc,
            scene,
            settings,
            sites,
            (first_record, count),
            target,
            &no_change,
            MODE_GATHER,
            &ctx.storage_buffer_sized("vpl ray counters", 16)?,
            timer.next("vpl gather"),
        )
    }

    /// Records the update of records `0..count` of a cache that keeps visibility bits
    /// (temporal instant caching, seed 003 Algorithm 1) to `scene`'s VPLs at this frame:
    /// only the rays `change` may have changed are traced again. Timed as one span "vpl
    /// update". Returns a buffer of two u32: rays traced, rays whose bit was reused.
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        settings: &CacheSettings,
        count: u32,
        target: &GatherTarget<'_>,
        change: &FrameChange<'_>,
        timer: &mut PassTimer,
    ) -> Result<wgpu::Buffer> {
        if target.visibility_words == 0 {
            return Err(Error::Usage(
                "internal: an update needs records that keep their visibility bits".into(),
            ));
        }
        let counters = ctx.storage_buffer("vpl ray counters", &[0u32; 4])?;
        if count > 0 {
            let no_sites = ctx.storage_buffer("no sites", &[RecordSite::default()])?;
            self.dispatch(
                ctx,
                enc,
                scene,
                settings,
                &no_sites,
                (0, count),
                target,
                change,
                MODE_UPDATE,
                &counters,
                timer.next("vpl update"),
            )?;
        }
        Ok(counters)
    }

    #[allow(clippy::too_many_arguments)]
    fn dispatch(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        settings: &CacheSettings,
        sites: &wgpu::Buffer,
        (first_record, count): (u32, u32),
        target: &GatherTarget<'_>,
        change: &FrameChange<'_>,
        mode: u32,
        counters: &wgpu::Buffer,
        stamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<()> {
        let vpls = scene_vpls(scene)?;
        let partials = ctx.storage_buffer_sized(
            "vpl gather partials",
            u64::from(count.max(1)) * u64::from(LANES) * PARTIAL_BYTES,
        )?;
        let changed = ctx.storage_buffer("vpl changed bits", change.changed)?;
        let moving = ctx.storage_buffer("moving bounds", change.moving)?;
        let chunks = vpls.count.div_ceil(VPLS_PER_DISPATCH).max(1);
        for chunk in 0..chunks {
            let begin = chunk * VPLS_PER_DISPATCH;
            let params = ctx.uniform_buffer(
                "vpl gather params",
                &GatherParams {
                    count,
                    first_record,
                    vpl_begin: begin,
                    vpl_end: (begin + VPLS_PER_DISPATCH).min(vpls.count),
                    vpl_count: vpls.count,
                    gradients: u32::from(settings.gradients),
                    r_max_factor: settings.r_max_factor,
                    neighbour_clamp: u32::from(settings.neighbour_clamp),
                    clamp_distance: vpls.clamp_distance,
                    mode,
                    visibility_words: target.visibility_words,
                    moving_count: change.moving_count,
                    movers_lo: change.movers_lo,
                    movers_hi: change.movers_hi,
                },
            );
            let bind = self.gather.bind(
                ctx,
                &[
                    &params,
                    sites,
                    &vpls.buffer,
                    &partials,
                    target.records,
                    target.visibility,
                    &changed,
                    &moving,
                    counters,
                ],
            );
            self.gather.record(
                enc,
                &scene.bind_group,
                &bind,
                [count, 1, 1],
                spanning(stamps.as_ref(), chunk == 0, chunk + 1 == chunks),
            );
        }
        Ok(())
    }
}

const MODE_GATHER: u32 = 0;
const MODE_UPDATE: u32 = 1;

/// The VPLs of `scene`, or an error saying none were traced.
pub fn scene_vpls(scene: &GpuScene) -> Result<SceneVpls> {
    scene.vpls().ok_or_else(|| {
        Error::Usage(
            "internal: records from VPLs (--records vpl) need the scene's VPLs traced first \
             (Renderer::scene_vpls)"
                .into(),
        )
    })
}

/// WGSL `vpl_bound`: seed 003's f(0.8 min_d, 1.2 min_d, d).
pub fn bound(d: f32, min_d: f32) -> f32 {
    if min_d <= 0.0 {
        return 1.0;
    }
    let t = ((d - 0.8 * min_d) / (0.4 * min_d)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// WGSL `vpl_bound_derivative`.
pub fn bound_derivative(d: f32, min_d: f32) -> f32 {
    if min_d <= 0.0 {
        return 0.0;
    }
    let t = (d - 0.8 * min_d) / (0.4 * min_d);
    if t <= 0.0 || t >= 1.0 {
        return 0.0;
    }
    6.0 * t * (1.0 - t) / (0.4 * min_d)
}

/// One lane's sums (WGSL `Partial`).
#[derive(Clone, Copy, Debug)]
struct Partial {
    irradiance: Vec3,
    inv_distance: f32,
    rotation: [Vec3; 3],
    translation: [Vec3; 3],
    cos_sum: f32,
    neighbour_bound: f32,
}

impl Default for Partial {
    fn default() -> Self {
        Self {
            irradiance: Vec3::ZERO,
            inv_distance: 0.0,
            rotation: [Vec3::ZERO; 3],
            translation: [Vec3::ZERO; 3],
            cos_sum: 0.0,
            neighbour_bound: 1.0e30,
        }
    }
}

/// One VPL's terms at a site (the body of the WGSL loop).
#[allow(clippy::too_many_arguments)]
fn gather_one(
    tracer: &CpuTracer,
    acc: &mut Partial,
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    origin: Vec3,
    v: &Vpl,
    min_d: f32,
) {
    if v.is_empty() {
        return;
    }
    let y = Vec3::from(v.position);
    let ny = Vec3::from(v.normal);
    let power = Vec3::from(v.power);
    let w = y - p;
    let d2 = w.dot(w);
    let d = d2.sqrt();
    let dir = w / d;
    let cos_x = n.dot(dir);
    let cos_y = -ny.dot(dir);
    if !(cos_x > 0.0 && cos_y > 0.0 && ng.dot(dir) > 0.0) {
        return;
    }
    let to_vpl = y - origin;
    let hit = tracer.closest_hit(origin, to_vpl, 0.0, 1.0 - 1.0e-4);
    let t = match &hit {
        Some(h) => h.t * to_vpl.length(),
        None => d,
    };
    acc.inv_distance += cos_x / t;
    acc.cos_sum += cos_x;
    if hit.is_some() {
        return;
    }
    let f = bound(d, min_d);
    let g = cos_x * cos_y / d2 * f;
    acc.irradiance += power * g;
    let (a, b) = (cos_x * d, cos_y * d);
    let d4 = d2 * d2;
    let grad = (f / d4) * (ny * a - n * b + w * (4.0 * a * b / d2))
        - w * (a * b / d4 * bound_derivative(d, min_d) / d);
    let turn = n.cross(dir) * (g / cos_x);
    for c in 0..3 {
        acc.rotation[c] += turn * power[c];
        acc.translation[c] += grad * power[c];
    }
}

/// The record the GPU gathers at `site` from `vpls` with bounding distance `min_d`, after
/// the records `previous` (its neighbours), on the CPU: the same terms in the same order
/// (lanes, then lane 0's sum), rays traced by obvhs.
pub fn reference_record(
    tracer: &CpuTracer,
    site: &RecordSite,
    vpls: &[Vpl],
    min_d: f32,
    previous: &[Record],
    settings: &CacheSettings,
) -> Record {
    let p = Vec3::from(site.position);
    let n = Vec3::from(site.normal);
    let ng = Vec3::from(site.geometric_normal);
    let origin = offset_ray_origin(p, ng);
    let mut lanes = vec![Partial::default(); LANES as usize];
    for (lane, acc) in lanes.iter_mut().enumerate() {
        // Lane l takes the 32-slot words l, l + 64, ... (WGSL: each lane owns the words
        // of visibility bits it writes).
        let words = vpls.len().div_ceil(32);
        for word in (lane..words).step_by(LANES as usize) {
            for v in vpls.iter().skip(32 * word).take(32) {
                gather_one(tracer, acc, p, n, ng, origin, v, min_d);
            }
        }
        if settings.neighbour_clamp {
            for r in previous.iter().skip(lane).step_by(LANES as usize) {
                acc.neighbour_bound = acc
                    .neighbour_bound
                    .min(r.radius + (r.position() - p).length());
            }
        }
    }
    let mut sum = Partial::default();
    for l in &lanes {
        sum.irradiance += l.irradiance;
        sum.inv_distance += l.inv_distance;
        sum.cos_sum += l.cos_sum;
        sum.neighbour_bound = sum.neighbour_bound.min(l.neighbour_bound);
        for c in 0..3 {
            sum.rotation[c] += l.rotation[c];
            sum.translation[c] += l.translation[c];
        }
    }
    let r_max = site.r_min * settings.r_max_factor;
    let mut radius = r_max;
    if sum.inv_distance > 0.0 {
        radius = (sum.cos_sum / sum.inv_distance).clamp(site.r_min, r_max);
    }
    radius = radius.min(sum.neighbour_bound).max(site.r_min);
    let e = sum.irradiance;
    let mut rot = [Vec3::ZERO; 3];
    let mut tr = [Vec3::ZERO; 3];
    if settings.gradients {
        for c in 0..3 {
            rot[c] = sum.rotation[c];
            let g = sum.translation[c];
            tr[c] = g - n * n.dot(g);
        }
        let mut limited = radius;
        for c in 0..3 {
            let g = tr[c].length();
            if g * limited > e[c] {
                limited = e[c] / g;
            }
        }
        radius = limited.max(site.r_min);
        for c in 0..3 {
            let g = tr[c].length();
            if g * radius > e[c] {
                tr[c] *= e[c] / (g * radius);
            }
        }
    }
    let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
    Record {
        position: site.position,
        radius,
        normal: site.normal,
        r_min: site.r_min,
        irradiance: e.into(),
        instance: site.instance,
        rotation_gradient: [v4(rot[0]), v4(rot[1]), v4(rot[2])],
        translation_gradient: [v4(tr[0]), v4(tr[1]), v4(tr[2])],
    }
}

/// The site a record is updated at (WGSL `site_of`): its geometric normal is not kept,
/// so its shading normal offsets the rays.
pub fn site_of(r: &Record) -> RecordSite {
    RecordSite {
        position: r.position,
        r_min: r.r_min,
        normal: r.normal,
        seed: 0,
        geometric_normal: r.normal,
        instance: r.instance,
    }
}
