//! Adaptive hemisphere-plane refinement: Radiance's `-as` ("adaptive super-sampling" of
//! the hemisphere: "super-sample high variance regions ... detect variance based on
//! neighborhood", Ward's course notes [S2 L326–334], algorithms.md 1.7), on the plane.
//!
//! After a record's `P x P` plane is traced, its `K = round(plane_refine P^2)` pixels of
//! highest contrast ([`contrast_keys`]) each get `split^2` more rays, one per stratum of
//! the pixel ([`HemispherePlane::refine_samples`]), and the pixel's sample becomes their
//! weighted mean with the centre ray ([`merge`]). The reduction is unchanged and reads the
//! refined pixels. Rays per record: `P^2 + K split^2` (a fixed cost: K pixels are refined
//! even where fewer have any contrast: the first pixels of no contrast by index fill the
//! rest, except where the frame's light maps see every lit surface, and there pixels of no
//! contrast near light, the heaviest first, and no others: [`select_pixels`],
//! [`near_light`]); a plane that saw no light at all is refined everywhere instead
//! ([`select_pixels`]), `P^2 (1 + split^2)` rays. Ward notes the naive
//! form is biased [S2 L276–287]: a pixel refined because its own centre ray differs from
//! its neighbours is replaced by a mean that undoes exactly the lucky hits (a centre ray
//! that caught a patch smaller than its pixel), while the unlucky pixels (a centre ray
//! that missed one) show no contrast and stay dark. So a pixel's contrast is read from
//! its neighbours alone (leave-one-out, [`contrast_keys`]): whether it is refined does not
//! depend on its own sample, and its mean stays unbiased. That bias had made a hall lit
//! through small windows 13 % too dark and Sponza 2.4 % (docs/results.md, "A hall lit
//! through small windows"). Where differences are light-sample noise they would bias the
//! ranking too: the contrast discounts what each sample's environment samples gave it.
//!
//! The depth of a refined pixel is the weighted harmonic mean of its rays' hit depths
//! (misses add 0 to the sum of 1/Z), so R stays the harmonic mean over every ray traced;
//! the translational gradient then takes the nearer of two neighbouring pixels as before
//! (Ward's min rule, between pixels).
//!
//! GPU: `plane_refine_select.wgsl` (per record, one workgroup: contrast, exact radix
//! select, selected pixels in pixel order; dark planes' records listed for a dispatch of
//! their own) and the plane pass's pipeline, `hemisphere_plane.wgsl`, in its refining
//! modes (one invocation per stratum ray, each pixel's strata merged in order). The
//! functions here are the CPU mirror.

use super::{CacheSettings, HemispherePlane, PlaneParams, PlaneSample, PlaneTable, RecordSite};
use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass, LazyPass, PassRecipe};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::texel_table::TexelCopy;
use crate::light_maps::lit_grid::{self, LitGridParams};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// The channel sum the contrast compares (not luminance: `(r + g) + b` has no product for
/// a GPU to fuse, so the GPU and the CPU compute the same bits).
fn channel_sum(s: &PlaneSample) -> f32 {
    (s.radiance[0] + s.radiance[1]) + s.radiance[2]
}

/// Every slot of a dark plane's selection ([`select_pixels`]): the plane is refined
/// everywhere (`DARK_PLANE` in `plane_refine_select.wgsl` and `hemisphere_plane.wgsl`).
pub const DARK_PLANE: u32 = u32::MAX;

/// The first slot of a selection that refines nothing: a dark plane when dark planes are
/// not refined (`CacheSettings::dark_plane_refine` off) but some pixels are by contrast,
/// whose other slots hold nothing meaningful (`NO_PIXELS` in `plane_refine_select.wgsl`
/// and `hemisphere_plane.wgsl`; on the CPU an empty selection).
pub const NO_PIXELS: u32 = u32::MAX - 1;

/// The first slot of a dark plane refined only where its rays can land near a lit surface
/// ([`guided_pixels`]; `DARK_GUIDED` in `plane_refine_select.wgsl` and
/// `hemisphere_plane.wgsl`): slot 1 holds the number of pixels, the slots after it the pixels
/// in pixel order. On the CPU the selection is the list itself.
pub const DARK_GUIDED: u32 = u32::MAX - 2;

/// A lit plane's selection slot past its last selected pixel: where the light maps see
/// every lit surface, a lit plane refines no pixel of no contrast that is far from light,
/// so it may select fewer than K (`plane_refine_select.wgsl`; the CPU's list is shorter).
pub const UNUSED_SLOT: u32 = u32::MAX - 3;

/// Where the lit surfaces are, for refining a dark plane near them alone: the frame's lit
/// grid (`light_maps::lit_grid`), read back, and the site whose plane it is.
#[derive(Clone, Copy)]
pub struct DarkGuide<'a> {
    pub grid: &'a LitGridParams,
    pub voxels: &'a [u32],
    pub site: &'a RecordSite,
}

/// The pixels of a dark plane whose rays can land near a lit surface (the GPU's guided
/// selection, `plane_refine_select.wgsl`): the ball around the pixel's hit that reaches
/// its 4-neighbours' hits (its footprint, and across an edge the farther surface) touches
/// a lit voxel whose lit side the pixel's direction can see
/// ([`LitGridParams::near`], [`lit_grid::faces_seen`]) and, where all four neighbours lie
/// on the pixel's own plane (so its sub-rays land on that surface), a lit side facing as
/// that surface does ([`lit_grid::faces_near`]); a pixel that missed is refined where a
/// neighbour hit. In pixel order.
pub fn guided_pixels(
    plane: &HemispherePlane,
    samples: &[PlaneSample],
    guide: &DarkGuide,
) -> Vec<u32> {
    let n = plane.resolution * plane.resolution;
    (0..n)
        .filter(|&k| near_light(plane, samples, guide, k, true))
        .collect()
}

/// Whether pixel `k`'s sub-rays can land near a lit surface of `guide`'s lit grid
/// (`near_light` in `plane_refine_select.wgsl`): the ball that reaches the pixel's
/// 4-neighbours' hits touches a lit voxel whose lit side the pixel's direction can see
/// ([`LitGridParams::near`], [`lit_grid::faces_seen`]) and, where all four neighbours lie
/// on one plane (so its sub-rays land on that surface), a lit side facing as that surface
/// does ([`lit_grid::faces_near`]); a pixel next to a miss is refined where a neighbour
/// hit. `own`: the ball is centred at the pixel's own hit and its own miss is an edge too
/// (a dark plane's [`guided_pixels`]); else at its neighbours' mean hit, its own sample left
/// out (a lit plane's spare slots, [`select_pixels`]: a centre ray that caught a patch
/// smaller than its pixel lands in a lit voxel, and refining for it would undo exactly the
/// lucky hits, the bias the module's note describes).
pub fn near_light(
    plane: &HemispherePlane,
    samples: &[PlaneSample],
    guide: &DarkGuide,
    k: u32,
    own: bool,
) -> bool {
    let site = guide.site;
    let frame = crate::sampling::record_frame(Vec3::from(site.normal), site.seed);
    let origin = Vec3::from(site.position);
    let res = plane.resolution;
    let n = res * res;
    let point = |k: u32| {
        let z = samples[k as usize].depth;
        let c = plane.pixels[k as usize].center;
        (z > 0.0).then(|| origin + frame * Vec3::new(c[0], c[1], 1.0) * z)
    };
    let i = k % res;
    let mut neighbours = Vec::with_capacity(4);
    if i > 0 {
        neighbours.push(k - 1);
    }
    if i + 1 < res {
        neighbours.push(k + 1);
    }
    if k >= res {
        neighbours.push(k - res);
    }
    if k + res < n {
        neighbours.push(k + res);
    }
    let qs: Vec<Option<Vec3>> = neighbours.into_iter().map(point).collect();
    let p = if own {
        point(k)
    } else {
        // The neighbours' mean hit, summed in the GPU's order.
        let (sum, hits) = qs
            .iter()
            .flatten()
            .fold((Vec3::ZERO, 0.0f32), |(s, h), &q| (s + q, h + 1.0));
        (hits > 0.0).then(|| sum / hits)
    };
    let (mut radius, mut missed, mut any_hit) = (0.0f32, own && p.is_none(), own && p.is_some());
    for &q in &qs {
        match (q, p) {
            (None, _) => missed = true,
            (Some(q), Some(p)) => {
                any_hit = true;
                radius = radius.max((q - p).length());
            }
            (Some(_), None) => any_hit = true,
        }
    }
    match p {
        _ if missed => any_hit,
        Some(p) => {
            let c = plane.pixels[k as usize].center;
            let d = (frame * Vec3::new(c[0], c[1], 1.0)).normalize();
            let mut faces = lit_grid::faces_seen(d);
            // All four neighbours on one plane: the pixel's sub-rays land on that
            // surface, whose lit side faces as it does.
            if let [Some(l), Some(r), Some(b), Some(t)] = qs[..] {
                let sn = (r - l).cross(t - b);
                let len = sn.length();
                if len > 0.0 {
                    let mut sn = sn / len;
                    if sn.dot(d) > 0.0 {
                        sn = -sn;
                    }
                    let flat = [l, r, b, t].iter().all(|&q| {
                        let e = q - p;
                        e.dot(sn).abs() <= 0.02 * e.length()
                    });
                    if flat {
                        faces &= lit_grid::faces_near(sn);
                    }
                }
            }
            guide.grid.near(guide.voxels, p, radius, faces)
        }
        None => false,
    }
}

/// Whether no sample of the plane has light (its record's irradiance would be exactly
/// zero).
pub fn is_dark(plane: &HemispherePlane, samples: &[PlaneSample]) -> bool {
    let n = (plane.resolution * plane.resolution) as usize;
    samples[..n].iter().all(|s| channel_sum(s) == 0.0)
}

/// Each pixel's contrast as the bits of a non-negative f32 (they order as the floats): the
/// largest `|y_i - y_j| - (noise_i + noise_j)` (at least 0) over pairs of its
/// 4-neighbours on the plane, leaving its own sample out (so that whether it is refined
/// does not depend on it: the module's note on bias; a lone bright pixel is not refined,
/// its neighbours are, and an edge still refines the pixels on both of its sides), y the
/// channel sum and `noise` what the sample's environment
/// samples gave it (`hemisphere_plane.wgsl`; empty: none), times the pixel's cosine weight
/// (the share of E a wrong pixel costs). One shadow ray samples the environment from a hit
/// too coarsely for a difference in it to mean anything, and ranking pixels by that noise
/// biased the records (docs/results.md, "Plane refinement is biased where the light
/// samples are noisy"). As `plane_refine_select.wgsl`, bit for bit.
pub fn contrast_keys(plane: &HemispherePlane, samples: &[PlaneSample], noise: &[f32]) -> Vec<u32> {
    let res = plane.resolution as usize;
    let n = res * res;
    let noise_of = |k: usize| noise.get(k).copied().unwrap_or(0.0);
    (0..n)
        .map(|k| {
            let i = k % res;
            // The 4-neighbours' channel sums and environment shares.
            let mut around = [(0.0f32, 0.0f32); 4];
            let mut m = 0;
            let mut add = |j: usize| {
                around[m] = (channel_sum(&samples[j]), noise_of(j));
                m += 1;
            };
            if i > 0 {
                add(k - 1);
            }
            if i + 1 < res {
                add(k + 1);
            }
            if k >= res {
                add(k - res);
            }
            if k + res < n {
                add(k + res);
            }
            let mut c = 0.0f32;
            for (a, &(ya, na)) in around[..m].iter().enumerate() {
                for &(yb, nb) in &around[a + 1..m] {
                    c = c.max(((ya - yb).abs() - (na + nb)).max(0.0));
                }
            }
            (c * plane.pixels[k].cos_weight).to_bits()
        })
        .collect()
}

/// The `refined` pixels of highest contrast ([`contrast_keys`]), in pixel order; ties go
/// to the lower pixel index (the GPU's selection exactly).
///
/// With a `guide` (the frame's light maps see every lit surface) a lit plane with fewer than
/// `refined` pixels of contrast gives the rest to pixels of no contrast whose sub-rays can
/// land near a lit surface ([`near_light`], the dark planes' test), in [`filler_order`], and
/// to no other: the pixel of no contrast far from light has nothing its sub-rays could
/// find, and the one near light may hide a sunlit patch between the centre rays. It may
/// then select fewer than `refined`. Without a guide the first pixels of no contrast by
/// index take them (nothing says where the light is: an environment, emitters). On the
/// nave's four still variants this took the indirect error down by 4-10 % over five image
/// sizes each, for the same rays (docs/results.md, "Spare refinement slots near light").
///
/// A plane without light anywhere has no contrast to rank; its `refined` slots (at least
/// one) all say [`DARK_PLANE`] and every pixel of it is refined ([`refined_pixels`]): P^2 centre rays
/// can miss light of a small solid angle (Sponza's arcade floors see the sunlit court only
/// between columns, a few degrees above their horizon), and a record that misses it
/// spreads exact zeros over its footprint. Radiance's `-as` super-samples where the
/// samples disagree; a dark plane is where they cannot tell. With `dark_planes` false
/// (`CacheSettings::dark_plane_refine` off) a dark plane selects nothing: its pixels have
/// no contrast to rank either. With a `guide` (the frame's light maps see every lit
/// surface) a dark plane selects only the pixels [`guided_pixels`] lists.
pub fn select_pixels(
    plane: &HemispherePlane,
    samples: &[PlaneSample],
    noise: &[f32],
    refined: u32,
    dark_planes: bool,
    guide: Option<&DarkGuide>,
) -> Vec<u32> {
    if is_dark(plane, samples) {
        if !dark_planes {
            return Vec::new();
        }
        if let Some(guide) = guide {
            return guided_pixels(plane, samples, guide);
        }
        // One slot at least: with `refined` 0 (dark planes alone refined) it flags them.
        return vec![DARK_PLANE; refined.max(1) as usize];
    }
    if refined == 0 {
        return Vec::new();
    }
    let keys = contrast_keys(plane, samples, noise);
    let contrast = keys.iter().filter(|&&key| key != 0).count();
    if let Some(guide) = guide.filter(|_| contrast < refined as usize) {
        // Fewer than K pixels of contrast where the light maps see every lit surface: those
        // pixels, then pixels of no contrast near light in `filler_order`, up to K.
        let need = refined as usize - contrast;
        let mut chosen: Vec<u32> = (0..keys.len() as u32)
            .filter(|&k| keys[k as usize] != 0)
            .collect();
        chosen.extend(
            filler_order(plane)
                .into_iter()
                .filter(|&k| keys[k as usize] == 0 && near_light(plane, samples, guide, k, false))
                .take(need),
        );
        chosen.sort_unstable();
        return chosen;
    }
    let mut order: Vec<u32> = (0..keys.len() as u32).collect();
    order.sort_by_key(|&k| (std::cmp::Reverse(keys[k as usize]), k));
    order.truncate(refined as usize);
    order.sort_unstable();
    order
}

/// The plane's pixels by cosine weight, largest first, ties to the lower index: the order in
/// which a lit plane with fewer than K pixels of contrast gives its other slots to pixels
/// near light ([`select_pixels`]; `PlaneTable::filler_order` on the GPU). A refined pixel
/// corrects E by its cosine weight, so the heaviest are worth the rays first.
pub fn filler_order(plane: &HemispherePlane) -> Vec<u32> {
    let mut order: Vec<u32> = (0..plane.pixels.len() as u32).collect();
    order.sort_by_key(|&k| {
        (
            std::cmp::Reverse(plane.pixels[k as usize].cos_weight.to_bits()),
            k,
        )
    });
    order
}

/// The pixels a selection refines, in pixel order: every pixel of a dark plane
/// ([`DARK_PLANE`]), else the selection itself.
pub fn refined_pixels(resolution: u32, selected: &[u32]) -> Vec<u32> {
    if selected.first() == Some(&DARK_PLANE) {
        (0..resolution * resolution).collect()
    } else {
        selected.to_vec()
    }
}

/// A refined pixel: the centre sample weighted `centre_weight`, each sub-sample by its
/// stratum's weight, radiance averaged and depth harmonically (misses add 0 to the sum of
/// 1/Z; -1 when every ray missed). Same order of operations as `hemisphere_plane.wgsl`.
pub fn merge(
    centre: &PlaneSample,
    centre_weight: f32,
    subs: impl IntoIterator<Item = (PlaneSample, f32)>,
) -> PlaneSample {
    let mut radiance = glam::Vec3::from(centre.radiance) * centre_weight;
    let mut inv_depth = if centre.depth > 0.0 {
        centre_weight / centre.depth
    } else {
        0.0
    };
    for (s, w) in subs {
        radiance += glam::Vec3::from(s.radiance) * w;
        if s.depth > 0.0 {
            inv_depth += w / s.depth;
        }
    }
    PlaneSample {
        radiance: radiance.into(),
        depth: if inv_depth > 0.0 {
            1.0 / inv_depth
        } else {
            -1.0
        },
    }
}

/// The weight of the centre ray in a refined pixel, `1 / (1 + split^2)`.
pub fn centre_weight(split: u32) -> f32 {
    1.0 / (1 + split * split) as f32
}

/// The seed of sub-sample `q` of pixel `pixel` (the centre rays take seeds 0..P^2).
pub fn subsample_seed_index(resolution: u32, pixel: u32, subsamples: u32, q: u32) -> u32 {
    resolution * resolution + pixel * subsamples + q
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SelectParams {
    resolution: u32,
    count: u32,
    refined: u32,
    /// Selection slots per record: `max(refined, 1)` (a dark plane's flag needs one).
    slots: u32,
    /// 1: dark planes are refined everywhere (`CacheSettings::dark_plane_refine`).
    dark_planes: u32,
    /// 1: a dark plane refines only its pixels near a lit voxel (`light_maps::lit_grid`).
    guided: u32,
    /// Refined pixels per workgroup of the plane pass (`64 / split^2`).
    per_group: u32,
    _pad: u32,
}

/// Refined pixels per workgroup of the plane pass for `split x split` strata a pixel.
fn per_group(split: u32) -> u32 {
    (64 / (split * split)).max(1)
}

/// Bytes of the refinement's strata buffer for `count` records of `resolution^2` pixels:
/// every workgroup of their longest list, 64 rays of four floats each (`stratum_offset` in
/// wgsl/shared/plane_refine_items.wgsl).
pub fn strata_bytes(resolution: u32, split: u32, count: u32) -> u64 {
    let groups = u64::from(resolution.pow(2).div_ceil(per_group(split)));
    u64::from(count) * groups * 64 * 16
}

/// The GPU passes of refinement for one [`CacheSettings`] (built when `plane_refine`
/// selects at least one pixel or dark planes are refined, `dark_plane_refine`).
pub struct RefinePass {
    /// Built at first use (or ahead, from [`Self::select_recipe`]).
    select: LazyPass,
    /// Sums each refined pixel's strata into its sample (`plane_refine_combine.wgsl`;
    /// built as `select`, [`Self::combine_recipe`]).
    combine: LazyPass,
    /// The plane samples the selection reads as texels where its pipeline reads texels
    /// ([`ComputePass::reads_texel_tables`]).
    sample_texels: TexelCopy,
    /// What the refinement binds for the plane pass's hits (it writes none).
    no_hits: wgpu::Buffer,
    /// The indirect dispatch (x y z) that refines a batch's planes, which the selection
    /// sizes, and the number of its workgroups (element 3).
    refine_dispatch: wgpu::Buffer,
    /// The selection's ray counters since they were last cleared ([`Self::ray_counts`];
    /// u32 atomics: exact, whatever the order).
    ray_counts: wgpu::Buffer,
    resolution: u32,
    refined: u32,
    split: u32,
    light_samples: u32,
    light_choices: u32,
    /// Dark planes are refined everywhere (`CacheSettings::dark_plane_refine`).
    dark_planes_refined: bool,
    /// ... only near lit surfaces where the light maps allow (`CacheSettings::dark_plane_guide`).
    dark_plane_guide: bool,
}

impl RefinePass {
    /// What the selection's pipeline is built from.
    pub fn select_recipe(&self) -> &PassRecipe {
        self.select.recipe()
    }

    /// What the strata sums' pipeline is built from.
    pub fn combine_recipe(&self) -> &PassRecipe {
        self.combine.recipe()
    }

    /// The selection pass for `settings` (the refinement's rays are traced by the record
    /// pass's plane pipeline, [`Self::record`]); `None` when refinement is off.
    pub fn new(ctx: &GpuContext, settings: &CacheSettings) -> Result<Option<Self>> {
        use Binding::*;
        let refined = settings.refined_pixels();
        if refined == 0 && !settings.dark_plane_refine {
            return Ok(None);
        }
        let split = settings.plane_refine_split;
        Ok(Some(Self {
            // Ten storage buffers: with the scene's six, all 16 a stage may bind
            // (`gpu::context::STORAGE_BUFFERS_PER_STAGE`): another must share a buffer.
            select: LazyPass::new(
                "plane_refine_select.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                    Uniform,
                    StorageRead,
                    StorageReadWrite,
                    StorageRead,
                    Texels,
                    Texels,
                ],
                &[],
            ),
            sample_texels: TexelCopy::new(ctx, "refinement's plane sample texels")?,
            combine: LazyPass::new(
                "plane_refine_combine.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                ],
                &[],
            ),
            no_hits: ctx.storage_buffer_sized("no refined hits", 16)?,
            refine_dispatch: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("plane refinement dispatch"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::INDIRECT
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            ray_counts: ctx.storage_buffer("refinement ray counts", &[0u32; 4])?,
            resolution: settings.plane_resolution,
            refined,
            split,
            light_samples: settings.plane_light_samples,
            light_choices: settings.plane_light_choices,
            dark_planes_refined: settings.dark_plane_refine,
            dark_plane_guide: settings.dark_plane_guide,
        }))
    }

    /// Records the refinement of the `count` planes in `samples` (traced for `sites`, P^2
    /// each) in place: the selection, then `trace` (the record pass's plane pipeline,
    /// `hemisphere_plane.wgsl`, built for `table`) in its refining mode. `selected`
    /// receives [`Self::slots`] u32 per record (the K selected pixels, [`DARK_PLANE`] in
    /// each slot, or a [`DARK_GUIDED`] list), then the planes' refining workgroups (a buffer
    /// of [`Self::selected_bytes`]). `noise` holds each sample's environment share
    /// ([`contrast_keys`]; all zeros: plain contrast). `site_texels`: `sites` as `trace`
    /// reads them (`RecordPass`'s copy of the batch's sites, or its stand-in).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        trace: &ComputePass,
        table: &PlaneTable,
        sites: &wgpu::Buffer,
        site_texels: &wgpu::TextureView,
        samples: &wgpu::Buffer,
        selected: &wgpu::Buffer,
        noise: &wgpu::Buffer,
        count: u32,
        light_maps: &crate::light_maps::LightMaps,
        timer: &mut crate::gpu::timer::PassTimer,
    ) -> Result<()> {
        let n = u64::from(self.resolution).pow(2);
        let keys = ctx.storage_buffer_sized("refine keys", u64::from(count) * n * 4)?;
        // A dark plane refines only its pixels near lit surfaces where the light maps see
        // every lit surface (`CacheSettings::dark_plane_guide`).
        let guided = self.dark_planes_refined
            && self.dark_plane_guide
            && light_maps.see_every_lit_surface(scene);
        let select_params = ctx.uniform_buffer(
            "refine select params",
            &SelectParams {
                resolution: self.resolution,
                count,
                refined: self.refined,
                slots: self.slots(),
                dark_planes: u32::from(self.dark_planes_refined),
                guided: u32::from(guided),
                per_group: self.per_group(),
                _pad: 0,
            },
        );
        let select = self.select.get(ctx)?;
        let sample_texels = self.sample_texels.view(
            ctx,
            enc,
            samples,
            u64::from(count) * n,
            select.reads_texel_tables(),
        )?;
        let bind = select.bind_resources(
            ctx,
            &[
                select_params.as_entire_binding(),
                table.pixels.as_entire_binding(),
                samples.as_entire_binding(),
                keys.as_entire_binding(),
                selected.as_entire_binding(),
                self.ray_counts.as_entire_binding(),
                noise.as_entire_binding(),
                sites.as_entire_binding(),
                light_maps.lit_grid.params_buffer.as_entire_binding(),
                light_maps.lit_grid.voxels.as_entire_binding(),
                self.refine_dispatch.as_entire_binding(),
                table.filler_order.as_entire_binding(),
                wgpu::BindingResource::TextureView(&sample_texels),
                wgpu::BindingResource::TextureView(table.pixel_texels.view()),
            ],
        );
        enc.clear_buffer(&self.refine_dispatch, 0, None);
        // The planes' workgroups, appended after the selections (0: none).
        enc.clear_buffer(
            selected,
            u64::from(count) * u64::from(self.slots()) * 4,
            None,
        );
        select.record(
            enc,
            &scene.bind_group,
            &bind,
            [count, 1, 1],
            timer.next("plane refinement select"),
        );
        // The strata of `per_group` pixels a workgroup, every plane's in one dispatch the
        // selection sized.
        let params = ctx.uniform_buffer(
            "refine params",
            &PlaneParams {
                resolution: self.resolution,
                count,
                light_samples: self.light_samples,
                light_choices: self.light_choices,
                mode: PlaneParams::REFINE,
                refined: self.refined,
                subsamples: self.split * self.split,
                centre_weight: centre_weight(self.split),
                slots: self.slots(),
                per_group: self.per_group(),
                ..PlaneParams::zeroed()
            },
        );
        // Each stratum ray's radiance and depth, from the tracing pass to the sums: where
        // the plane pass keeps its environment shares when it traces (it writes none when
        // it refines; the selection has read them).
        let strata = ctx.storage_buffer_sized(
            "refinement strata",
            strata_bytes(self.resolution, self.split, count),
        )?;
        let bind = trace.bind_resources(
            ctx,
            &[
                params.as_entire_binding(),
                sites.as_entire_binding(),
                table.pixels.as_entire_binding(),
                samples.as_entire_binding(),
                self.no_hits.as_entire_binding(),
                light_maps.maps_buffer.as_entire_binding(),
                light_maps.depths.as_entire_binding(),
                light_maps.first_buffer.as_entire_binding(),
                scene.bounce_cache().as_entire_binding(),
                strata.as_entire_binding(),
                selected.as_entire_binding(),
                wgpu::BindingResource::TextureView(site_texels),
                wgpu::BindingResource::TextureView(table.pixel_texels.view()),
            ],
        );
        trace.record_indirect(
            enc,
            &scene.bind_group,
            &bind,
            &self.refine_dispatch,
            timer.next("plane refinement"),
        );
        let combine = self.combine.get(ctx)?;
        let bind = combine.bind(ctx, &[&params, &table.pixels, samples, selected, &strata]);
        combine.record_indirect(
            enc,
            &scene.bind_group,
            &bind,
            &self.refine_dispatch,
            timer.next("plane refinement sums"),
        );
        Ok(())
    }

    /// Refined pixels per workgroup of the plane pass: its 64 invocations trace one
    /// stratum each.
    fn per_group(&self) -> u32 {
        per_group(self.split)
    }

    /// Bytes of the selection buffer for `count` records.
    pub fn selected_bytes(&self, count: u32) -> u64 {
        let groups = self.resolution.pow(2).div_ceil(self.per_group());
        u64::from(count) * u64::from(self.slots() + groups) * 4
    }

    /// Pixels refined per record by contrast (K; 0 where dark planes alone are refined).
    pub fn refined(&self) -> u32 {
        self.refined
    }

    /// Selection slots per record: `max(K, 1)` (a dark plane's flag needs one), and where
    /// dark planes may be refined near light alone, room for a guided plane's list:
    /// [`DARK_GUIDED`], the count, and up to P^2 pixels.
    pub fn slots(&self) -> u32 {
        let contrast = self.refined.max(1);
        if self.dark_planes_refined && self.dark_plane_guide {
            contrast.max(self.resolution.pow(2) + 2)
        } else {
            contrast
        }
    }

    /// Rays a guided dark plane's refined pixel traces.
    pub fn rays_per_guided_pixel(&self) -> u64 {
        u64::from(self.split.pow(2))
    }

    /// Rays a plane refined everywhere traces beyond the `K split^2` of refinement.
    pub fn extra_rays_per_dark_plane(&self) -> u64 {
        u64::from(self.resolution.pow(2) - self.refined) * u64::from(self.split.pow(2))
    }

    /// The selection's ray counters (four u32: planes refined everywhere, pixels listed by
    /// guided dark planes, guided dark planes, lit planes' unused slots; read and cleared
    /// by `RecordPass::take_refinement_rays`).
    pub fn ray_counts(&self) -> &wgpu::Buffer {
        &self.ray_counts
    }
}

/// The refined plane of `site` from its traced `coarse` plane (and its samples'
/// environment shares `noise`, [`contrast_keys`]), with `trace(dir_xy, seed)`
/// tracing one sub-sample through plane coordinates `dir_xy` with the light-sample seed
/// index (CPU reference); also returns the selected pixels. `guide`: where the lit
/// surfaces are, when the frame's light maps see them all ([`guided_pixels`]).
pub fn refine_plane(
    plane: &HemispherePlane,
    settings: &CacheSettings,
    site: &RecordSite,
    coarse: &[PlaneSample],
    noise: &[f32],
    guide: Option<&DarkGuide>,
    mut trace: impl FnMut(&RecordSite, [f32; 2], u32) -> PlaneSample,
) -> (Vec<PlaneSample>, Vec<u32>) {
    let refined = settings.refined_pixels();
    let mut out = coarse.to_vec();
    if refined == 0 && !settings.dark_plane_refine {
        return (out, Vec::new());
    }
    let split = settings.plane_refine_split;
    let subs = plane.refine_samples(split);
    let m = split * split;
    let guide = guide.filter(|_| settings.dark_plane_guide);
    let selected = select_pixels(
        plane,
        coarse,
        noise,
        refined,
        settings.dark_plane_refine,
        guide,
    );
    for k in refined_pixels(plane.resolution, &selected) {
        let mine = &subs[(k * m) as usize..((k + 1) * m) as usize];
        let traced: Vec<(PlaneSample, f32)> = mine
            .iter()
            .enumerate()
            .map(|(q, s)| {
                let seed = subsample_seed_index(plane.resolution, k, m, q as u32);
                (trace(site, s.center, seed), s.weight)
            })
            .collect();
        out[k as usize] = merge(&coarse[k as usize], centre_weight(split), traced);
    }
    (out, selected)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::records::PlaneMode;

    fn sample(v: f32) -> PlaneSample {
        PlaneSample {
            radiance: [v, v, v],
            depth: 1.0,
        }
    }

    /// A plain 4 x 4 plane at 90 degrees: its centre pixels weigh more than its edges.
    fn plain_4x4() -> HemispherePlane {
        HemispherePlane::new(
            4,
            90.0,
            PlaneMode::Plain,
            crate::records::PlaneSpacing::Uniform,
        )
    }

    #[test]
    fn selection_takes_the_highest_contrast_and_breaks_ties_by_index() {
        let plane = plain_4x4();
        let mut samples = vec![sample(0.0); 16];
        // Pixel (1, 1) alone is bright: its four neighbours see it beside a dark pixel and
        // share one contrast; it sees only dark neighbours, so its own extreme sample does
        // not get it refined (an unbiased mean).
        samples[5] = sample(1.0);
        let keys = contrast_keys(&plane, &samples, &[]);
        assert!(keys.iter().enumerate().all(|(k, &c)| {
            let near = [1, 4, 6, 9].contains(&k);
            near == (c > 0)
        }));
        // The plain plane's centre pixels (6, 9) weigh more than its edge ones (1, 4),
        // which tie: the lower index.
        let chosen = select_pixels(&plane, &samples, &[], 3, true, None);
        assert_eq!(chosen, vec![1, 6, 9]);
        // All equal: the lowest indices.
        assert_eq!(
            select_pixels(&plane, &vec![sample(0.5); 16], &[], 3, true, None),
            vec![0, 1, 2]
        );
        assert_eq!(
            select_pixels(&plane, &samples, &[], 16, true, None).len(),
            16
        );
    }

    /// With no pixel to refine by contrast (K = 0), a dark plane still takes one slot that
    /// flags it, and every pixel of it is refined; a lit plane selects nothing.
    #[test]
    fn dark_planes_are_flagged_when_no_pixel_is_refined_by_contrast() {
        let plane = plain_4x4();
        let dark = vec![sample(0.0); 16];
        assert_eq!(
            select_pixels(&plane, &dark, &[], 0, true, None),
            vec![DARK_PLANE]
        );
        assert_eq!(
            select_pixels(&plane, &dark, &[], 3, true, None),
            vec![DARK_PLANE; 3]
        );
        assert_eq!(
            refined_pixels(4, &select_pixels(&plane, &dark, &[], 0, true, None)),
            (0..16).collect::<Vec<u32>>()
        );
        let mut lit = dark.clone();
        lit[5] = sample(1.0);
        assert!(select_pixels(&plane, &lit, &[], 0, true, None).is_empty());
        assert!(refined_pixels(4, &[]).is_empty());
    }

    #[test]
    fn an_edge_refines_the_pixels_on_both_sides() {
        let plane = plain_4x4();
        // Columns 0 and 1 dark, 2 and 3 bright: the pixels of columns 1 and 2 see the
        // edge between two of their neighbours, the outer columns do not.
        let samples: Vec<PlaneSample> = (0..16)
            .map(|k| sample(if k % 4 >= 2 { 1.0 } else { 0.0 }))
            .collect();
        let keys = contrast_keys(&plane, &samples, &[]);
        for (k, &c) in keys.iter().enumerate() {
            assert_eq!(c > 0, k % 4 == 1 || k % 4 == 2, "pixel {k}");
        }
    }

    #[test]
    fn contrast_from_environment_samples_does_not_count() {
        let plane = plain_4x4();
        let mut samples = vec![sample(0.2); 16];
        // Pixel 5's one environment sample saw the sky where its neighbours' did not.
        samples[5] = sample(1.0);
        let mut noise = vec![0.0; 16];
        noise[5] = 2.4;
        // Pixel 10 is brighter than its neighbours by more than environment samples
        // explain: a light's (exact) difference.
        samples[10] = sample(0.6);
        noise[10] = 0.3;
        let keys = contrast_keys(&plane, &samples, &noise);
        // Pixel 5's neighbours (1, 4, 6, 9) compare it with the others: its difference is
        // what its environment sample explains. Pixel 6 sees pixel 10 beside pixel 7.
        for k in [1, 4] {
            assert_eq!(
                keys[k], 0,
                "pixel {k}: a difference an environment sample explains"
            );
        }
        let expected = (3.0 * 0.6 - 3.0 * 0.2 - 0.3) * plane.pixels[6].cos_weight;
        assert!((f32::from_bits(keys[6]) - expected).abs() < 1e-6);
        // Pixel 10's neighbours (6, 9, 11, 14) share that contrast, the centre ones first;
        // without the environment shares pixel 5's neighbours come first.
        assert_eq!(
            select_pixels(&plane, &samples, &noise, 3, true, None),
            vec![6, 9, 11]
        );
        assert_eq!(select_pixels(&plane, &samples, &[], 1, true, None), vec![6]);
    }

    #[test]
    fn merge_weights_radiance_and_depth() {
        let c = PlaneSample {
            radiance: [1.0, 0.0, 0.0],
            depth: 2.0,
        };
        let miss = PlaneSample {
            radiance: [0.0; 3],
            depth: -1.0,
        };
        let m = merge(&c, 0.5, [(miss, 0.5)]);
        assert_eq!(m.radiance, [0.5, 0.0, 0.0]);
        assert_eq!(m.depth, 4.0); // half the rays hit at 2: 1/Z = 0.25
        assert_eq!(merge(&miss, 0.5, [(miss, 0.5)]).depth, -1.0);
    }
}
