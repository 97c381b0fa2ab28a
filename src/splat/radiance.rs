//! Splatting radiance records onto glossy pixels (issue 18; thesis section 4.4 with the
//! records of chapter 3): the tables the splat reads, built once per scene, the pass
//! that marks which pixels need radiance records (placement of the radiance cache), and
//! the weighted gather (`wgsl/radiance_gather.wgsl`), with its CPU mirror
//! [`reference_gather`].
//!
//! Which lobes radiance records shade (algorithms.md 2.6: "low-frequency, moderately
//! glossy BRDFs"; sharper ones by importance-sampled Monte Carlo): a material's lobe gets
//! a slot when the order in use captures at least `min_lobe_accuracy` of its energy
//! (thesis eq. 3.32, averaged over outgoing directions by solid angle). With the defaults
//! (order 8, 0.9) Phong exponents up to about 35 qualify (Phong 20: 0.98, Phong 30:
//! 0.94, Phong 40: 0.89 by `radsplat brdf-projection`). Each slot's lobe keeps the fewest
//! bands holding `lobe_share` of its energy (`LobeTable::truncated`), and the records
//! carry the most bands any slot keeps ([`RadianceTables::bands_needed`]).

use super::{SplatPass, SplatSource};
use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass, image_groups};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::{PassTimer, spanning};
use crate::hsh::brdf_projection::{LobeTable, quadrature_for};
use crate::hsh::coefficient_count;
use crate::hsh::rotation::{RotationTable, kinds};
use crate::records::Record;
use crate::records::kind::FRAME_FLOATS;
pub use crate::records::kind::RadianceSettings;
use crate::scene::GlossyLobe;
use crate::visibility::{GpuCamera, VisSample};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};

/// `NO_LOBE_SLOT` in `wgsl/shared/radiance_records.wgsl`.
pub const NO_LOBE_SLOT: u32 = u32::MAX;
/// Outgoing angles per lobe table.
pub const LOBE_STEPS: u32 = 64;
/// Tilt matrices per rotation table.
pub const BETA_STEPS: u32 = 16;

/// Mirror of WGSL `RadianceParams`.
/// Mirror of WGSL `GatherChunk`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GatherChunk {
    entry_begin: u32,
    entry_end: u32,
    first: u32,
    last: u32,
}

/// Loop iterations one gather invocation may spend (llvmpipe stops an invocation after
/// 65,535 in all), leaving room for the per-pixel loops.
const GATHER_ITERATION_BUDGET: u32 = 60_000;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct RadianceParams {
    order: u32,
    coefficients: u32,
    stride: u32,
    materials: u32,
    lobe_steps: u32,
    beta_steps: u32,
    beta_max: f32,
    _pad: u32,
}

/// The tables of one scene at one setting: each material's lobe slot and specular, each
/// slot's lobe table, and the tilt matrices.
#[derive(Clone, Debug)]
pub struct RadianceTables {
    pub settings: RadianceSettings,
    /// Per material: its slot in `lobes`, or [`NO_LOBE_SLOT`].
    pub slots: Vec<u32>,
    pub specular: Vec<Vec3>,
    pub lobes: Vec<LobeTable>,
    /// Per material with a glossy lobe: the lobe's accuracy at the order (eq. 3.32).
    pub lobe_accuracy: Vec<Option<f64>>,
    /// Each material's lobe, as given.
    pub lobes_by_material: Vec<Option<GlossyLobe>>,
    pub rotation: RotationTable,
}

impl RadianceTables {
    /// The tables for materials whose glossy lobes are `lobes` (index: material).
    pub fn new(lobes: &[Option<GlossyLobe>], settings: RadianceSettings) -> Self {
        let order = settings.order.max(1);
        let mut slots = Vec::with_capacity(lobes.len());
        let mut specular = Vec::with_capacity(lobes.len());
        let mut tables: Vec<(f32, LobeTable)> = Vec::new();
        let mut lobe_accuracy = Vec::with_capacity(lobes.len());
        for lobe in lobes {
            let Some(lobe) = lobe else {
                slots.push(NO_LOBE_SLOT);
                specular.push(Vec3::ZERO);
                lobe_accuracy.push(None);
                continue;
            };
            specular.push(lobe.specular());
            let exponent = lobe.exponent();
            // Lobes of one shape share a table.
            let slot = match tables.iter().position(|(e, _)| *e == exponent) {
                Some(s) => s,
                None => {
                    let q = quadrature_for(lobe, order);
                    let table = LobeTable::new(lobe, order, LOBE_STEPS, &q).truncated(f64::from(
                        settings.lobe_share.max(settings.min_lobe_accuracy),
                    ));
                    tables.push((exponent, table));
                    tables.len() - 1
                }
            };
            let accuracy = tables[slot].1.mean_accuracy();
            lobe_accuracy.push(Some(accuracy));
            let usable = settings.order > 0 && accuracy >= f64::from(settings.min_lobe_accuracy);
            slots.push(if usable { slot as u32 } else { NO_LOBE_SLOT });
        }
        Self {
            rotation: RotationTable::new(settings.rotation, order, settings.beta_max(), BETA_STEPS),
            settings,
            slots,
            specular,
            lobes: tables.into_iter().map(|(_, t)| t).collect(),
            lobe_accuracy,
            lobes_by_material: lobes.to_vec(),
        }
    }

    /// The bands radiance records need: the most any lobe they shade keeps
    /// ([`LobeTable::bands`]); the order when none shade any.
    pub fn bands_needed(&self) -> u32 {
        self.slots
            .iter()
            .filter(|&&s| s != NO_LOBE_SLOT)
            .map(|&s| self.lobes[s as usize].bands)
            .max()
            .unwrap_or(self.settings.order)
    }

    /// The largest Phong exponent among the lobes radiance records shade (0: none).
    pub fn sharpest_exponent(&self) -> f32 {
        let mut sharpest = 0.0f32;
        for (slot, lobe) in self.slots.iter().zip(&self.lobes_by_material) {
            if let (true, Some(lobe)) = (*slot != NO_LOBE_SLOT, lobe) {
                sharpest = sharpest.max(lobe.exponent());
            }
        }
        sharpest
    }

    /// Whether radiance records shade every glossy lobe of the scene: once their placement
    /// has covered every pixel it should, no glossy pixel needs Monte Carlo.
    pub fn every_lobe_has_slot(&self) -> bool {
        self.lobes_by_material
            .iter()
            .zip(&self.slots)
            .all(|(lobe, slot)| lobe.is_none() || *slot != NO_LOBE_SLOT)
    }

    /// Whether any material is shaded by radiance records.
    pub fn any_slot(&self) -> bool {
        self.slots.iter().any(|&s| s != NO_LOBE_SLOT)
    }

    /// The GPU tilt table: per tabulated angle, `M^T`'s cosine-kind block then its sine-kind
    /// block (the tilt never mixes the kinds, `hsh::rotation::is_sine_kind`), each row padded
    /// with zeros to a multiple of 4 (`radiance_gather.wgsl` reads it as vec4s); rows and
    /// columns in the order of `hsh::rotation::kinds`.
    fn gpu_rotations(&self) -> Vec<f32> {
        let n2 = coefficient_count(self.rotation.order);
        let (cosine, sine) = kinds(self.rotation.order);
        let mut out = Vec::new();
        for m in self.rotation.matrices.chunks(n2 * n2) {
            for block in [&cosine, &sine] {
                let padded = block.len().div_ceil(4) * 4;
                for &row in block {
                    out.extend(
                        (0..padded).map(|c| block.get(c).map_or(0.0, |&col| m[col * n2 + row])),
                    );
                }
            }
        }
        out
    }

    /// Loop iterations of `radiance_gather.wgsl` per contributing record at most (a tilted
    /// one): lobe copy, two turns, the tilt (its two blocks, their gather and scatter), the
    /// dot product.
    pub fn iterations_per_record(&self) -> u32 {
        let n = self.settings.order.max(1);
        let n2 = n * n;
        let cosine = n * (n + 1) / 2;
        let sine = n * (n - 1) / 2;
        // Rows (one iteration each and one per vec4 of the row), the gather into the
        // blocks (n2, padding, the loops over l) and the loops over l of the rows.
        let tilt =
            cosine * (1 + cosine.div_ceil(4)) + sine * (1 + sine.div_ceil(4)) + n2 + 4 * n + 8;
        n2 + n * (n - 1) + tilt + n2 + 4
    }

    /// The GPU lobe table: per material (slot, specular rgb bits), then the slots' tables.
    fn gpu_lobe_table(&self) -> Vec<u32> {
        let mut out = Vec::new();
        for (slot, ks) in self.slots.iter().zip(&self.specular) {
            out.extend([*slot, ks.x.to_bits(), ks.y.to_bits(), ks.z.to_bits()]);
        }
        for t in &self.lobes {
            out.extend([t.bands, 0, 0, 0]);
            out.extend(t.coefficients.iter().map(|c| c.to_bits()));
        }
        if out.is_empty() {
            out.push(NO_LOBE_SLOT);
        }
        out
    }
}

/// The radiance splat passes with one scene's tables on the GPU.
pub struct RadianceSplatPass {
    need: std::sync::Arc<ComputePass>,
    gather: std::sync::Arc<ComputePass>,
    pub tables: RadianceTables,
    lobe_table: wgpu::Buffer,
    rotations: wgpu::Buffer,
    params: wgpu::Buffer,
}

impl RadianceSplatPass {
    pub fn new(ctx: &GpuContext, tables: RadianceTables) -> Result<Self> {
        use Binding::*;
        let n = coefficient_count(tables.settings.order.max(1)) as u32;
        let params = ctx.uniform_buffer(
            "radiance params",
            &RadianceParams {
                order: tables.settings.order.max(1),
                coefficients: n,
                stride: tables.settings.kind().coefficient_floats() as u32,
                materials: tables.slots.len() as u32,
                lobe_steps: LOBE_STEPS,
                beta_steps: tables.rotation.steps,
                beta_max: tables.rotation.beta_max as f32,
                _pad: 0,
            },
        );
        Ok(Self {
            need: ComputePass::new(
                ctx,
                "radiance_need.wgsl",
                &[Uniform, StorageRead, StorageRead, StorageReadWrite],
            )?,
            gather: ComputePass::new(
                ctx,
                "radiance_gather.wgsl",
                &[
                    Uniform,
                    Uniform,
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    Uniform,
                ],
            )?,
            lobe_table: ctx.storage_buffer("radiance lobe table", &tables.gpu_lobe_table())?,
            rotations: ctx.storage_buffer("radiance tilt matrices", &tables.gpu_rotations())?,
            params,
            tables,
        })
    }

    /// Starts `mask` as the radiance cache's placement needs it: every pixel covered except
    /// the visible ones with a radiance lobe.
    pub fn need_mask(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &crate::visibility::VisibilityBuffer,
        mask: &super::CoverageMask,
    ) {
        let bind = self.need.bind(
            ctx,
            &[
                &vis.camera_buffer,
                &vis.samples,
                &self.lobe_table,
                &mask.covered,
            ],
        );
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.need.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            image_groups(vis.width, vis.height),
            None,
        );
        ctx.queue.submit([enc.finish()]);
    }

    /// Gathers `src`'s radiance records into a new buffer of per-pixel
    /// `(specular * sum w L, sum w)` (RGBA f32).
    pub fn gather(
        &self,
        ctx: &GpuContext,
        splat: &SplatPass,
        src: SplatSource,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<wgpu::Buffer> {
        let vis = src.vis;
        let out = ctx.storage_buffer_sized(
            "radiance splat",
            u64::from(vis.width) * u64::from(vis.height) * 16,
        )?;
        let bins = splat.bin(ctx, src, (super::SplatInto::Fresh, 0), times)?;
        // Entries per dispatch: as many records as fit the iteration budget when every
        // one of them is tilted, over the longest tile list.
        let offsets: Vec<u32> = ctx.read_buffer(&bins.tile_offsets)?;
        let tiles = (bins.tiles[0] * bins.tiles[1]) as usize;
        let longest = offsets
            .windows(2)
            .take(tiles)
            .map(|w| w[1].saturating_sub(w[0]))
            .max()
            .unwrap_or(0);
        let per_pixel = 2 * coefficient_count(self.tables.settings.order.max(1)) as u32;
        let per_dispatch =
            ((GATHER_ITERATION_BUDGET - per_pixel) / self.tables.iterations_per_record()).max(1);
        let dispatches = longest.div_ceil(per_dispatch).max(1);
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let stamps = timer.next("splat: radiance gather");
        for d in 0..dispatches {
            let chunk = ctx.uniform_buffer(
                "radiance gather chunk",
                &GatherChunk {
                    entry_begin: d * per_dispatch,
                    entry_end: (d + 1) * per_dispatch,
                    first: u32::from(d == 0),
                    last: u32::from(d + 1 == dispatches),
                },
            );
            let bind = self.gather.bind(
                ctx,
                &[
                    &bins.params,
                    &self.params,
                    &vis.camera_buffer,
                    &vis.samples,
                    &src.records.buffer,
                    &src.records.coefficients,
                    &bins.tile_offsets,
                    &bins.sorted,
                    &self.lobe_table,
                    &self.rotations,
                    &out,
                    &chunk,
                ],
            );
            let ts = spanning(stamps.as_ref(), d == 0, d + 1 == dispatches);
            self.gather.record(
                &mut enc,
                &src.scene.bind_group,
                &bind,
                image_groups(vis.width, vis.height),
                ts,
            );
        }
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(out)
    }
}

/// One radiance record as the CPU reads it from the cache: the record and its block.
pub struct RadianceRecord<'a> {
    pub record: &'a Record,
    /// [`crate::records::RecordKind::coefficient_floats`] f32: frame, values, x- and y-gradients.
    pub block: &'a [f32],
}

/// What radiance record `r` reflects through `tables`' lobe `slot` at `p` (normal `n`)
/// towards `wo`: the record's coefficients moved by their gradients, tilted into the
/// pixel's frame and dotted with the lobe (unit specular), per channel, clamped at 0. The
/// math of `wgsl/radiance_gather.wgsl` in f64.
pub fn record_radiance_at(
    tables: &RadianceTables,
    slot: u32,
    r: &RadianceRecord<'_>,
    p: Vec3,
    n: Vec3,
    wo: Vec3,
) -> Vec3 {
    let order = tables.settings.order.max(1);
    let n2 = coefficient_count(order);
    let (p, np, wo) = (p.as_dvec3(), n.as_dvec3(), wo.as_dvec3());
    let nk = Vec3::from(r.record.normal).as_dvec3();
    let pk = Vec3::from(r.record.position).as_dvec3();
    let b = r.block;
    let tk = DVec3::new(b[0].into(), b[1].into(), b[2].into());
    let bk = DVec3::new(b[4].into(), b[5].into(), b[6].into());
    let axis = nk.cross(np);
    let sin_b = axis.length();
    let cos_b = nk.dot(np).clamp(-1.0, 1.0);
    let tilt = sin_b > 1e-4;
    let (u, xa) = if tilt {
        let u = axis / sin_b;
        (u, u.cross(nk))
    } else {
        (bk, tk)
    };
    let xb = xa * cos_b - nk * sin_b;
    let lobe = &tables.lobes[slot as usize];
    // c_B: the lobe for wo expressed in frame B = (x_B, u, n_p).
    let wo_b = DVec3::new(wo.dot(xb), wo.dot(u), wo.dot(np));
    let mut c = lobe.at(wo_b);
    if tilt {
        let m = tables.rotation.at(sin_b.atan2(cos_b));
        // c_A = M^T c_B.
        c = (0..n2)
            .map(|j| (0..n2).map(|k| m[k * n2 + j] * c[k]).sum())
            .collect();
    }
    let c = crate::hsh::rotate_z(&c, order, xa.dot(bk).atan2(xa.dot(tk)));
    let d = p - pk;
    let (dx, dy) = (d.dot(tk), d.dot(bk));
    let values = &b[FRAME_FLOATS..];
    let mut l = [0.0f64; 3];
    for (ch, lc) in l.iter_mut().enumerate() {
        *lc = (0..n2)
            .map(|q| {
                let base = ch * n2 + q;
                let lambda = f64::from(values[base])
                    + dx * f64::from(values[3 * n2 + base])
                    + dy * f64::from(values[6 * n2 + base]);
                c[q] * lambda
            })
            .sum::<f64>()
            .max(0.0);
    }
    DVec3::from(l).as_vec3()
}

/// Plain-Rust radiance gather over every record (the GPU sums its tile's records in
/// record order; a record outside a pixel's tile lists never contributes there): per
/// pixel `(specular * sum w L, sum w)`.
pub fn reference_gather(
    tables: &RadianceTables,
    records: &[Record],
    coefficients: &[f32],
    camera: &GpuCamera,
    vis: &[VisSample],
) -> Vec<[f32; 4]> {
    let stride = tables.settings.kind().coefficient_floats();
    let a = tables.settings.accuracy;
    let mut out = vec![[0.0f32; 4]; vis.len()];
    for (pixel, v) in vis.iter().enumerate() {
        if !v.is_hit() {
            continue;
        }
        let Some(&slot) = tables.slots.get(v.material as usize) else {
            continue;
        };
        let p = Vec3::from(v.position);
        let n = Vec3::from(v.shading_normal);
        let x = pixel as u32 % camera.width;
        let y = pixel as u32 / camera.width;
        let wo = -camera.ray_dir(x, y);
        if slot == NO_LOBE_SLOT || wo.dot(n) <= 0.0 {
            continue;
        }
        let mut sum = [0.0f32; 4];
        for (k, r) in records.iter().enumerate() {
            let err = r.error_at(p, n);
            if err <= a && r.in_front_of(p, n, a) {
                let w = super::reference::splat_weight(err, a, 0.0);
                let rr = RadianceRecord {
                    record: r,
                    block: &coefficients[k * stride..(k + 1) * stride],
                };
                let l = record_radiance_at(tables, slot, &rr, p, n, wo);
                sum[0] += w * l.x;
                sum[1] += w * l.y;
                sum[2] += w * l.z;
                sum[3] += w;
            }
        }
        let ks = tables.specular[v.material as usize];
        out[pixel] = [ks.x * sum[0], ks.y * sum[1], ks.z * sum[2], sum[3]];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn phong(exponent: f32) -> Option<GlossyLobe> {
        Some(GlossyLobe::Phong {
            specular: Vec3::splat(0.3),
            exponent,
        })
    }

    #[test]
    fn radiance_records_take_the_lobes_their_order_holds_and_leave_sharp_ones_to_monte_carlo() {
        let lobes = [None, phong(20.0), phong(400.0), phong(20.0)];
        let t = RadianceTables::new(&lobes, RadianceSettings::default());
        // Phong 20 holds 98 % of its energy at order 8, Phong 400 far less than 0.9.
        assert_eq!(t.slots, vec![NO_LOBE_SLOT, 0, NO_LOBE_SLOT, 0]);
        assert_eq!(t.lobes.len(), 2, "one table per lobe shape");
        assert!(t.lobe_accuracy[1].is_some_and(|a| a > 0.97));
        assert!(t.lobe_accuracy[2].is_some_and(|a| a < 0.5));
        assert!(t.any_slot());
        // Order 0 turns radiance records off.
        let off = RadianceTables::new(
            &lobes,
            RadianceSettings {
                order: 0,
                ..Default::default()
            },
        );
        assert!(!off.any_slot());
    }
}
