//! Projection of a record's hemisphere plane onto hemispherical harmonics (issue 18, the
//! incoming radiance a radiance record stores; algorithms.md 2.3):
//! `lambda_k = sum_p L_p W_pk` with `W_pk = integral over pixel p of H_k dw`, the basis
//! integrated over each pixel's solid angle (thesis: solid-angle weights, the cosine goes
//! into the BRDF). Integrating rather than sampling `H_k` at the pixel centre matters at
//! the stretched border, whose pixels stand for everything down to the horizon
//! (algorithms.md 3.2). Coefficients are in the record's (turned) frame, +z its normal.
//!
//! [`PlaneBasis`] computes `W` once per plane on the CPU (f64 quadrature, stored f32);
//! [`RadianceProjectionPass`] (`wgsl/radiance_project.wgsl`) projects planes on the GPU,
//! one invocation per (record, block of 16 coefficients) summing the pixels in order, so
//! the result is deterministic; [`project_with_gradients`] is its CPU mirror. The translational gradient
//! of every coefficient comes from the same plane (algorithms.md 3.3: each pixel edge
//! sweeps the radiance difference across it, weighted by `H_k` at the edge).
//! [`limit_gradients`] (`wgsl/radiance_limit.wgsl` on the GPU) then bounds those gradients
//! by Ward's rule over the record's reach, once the reduction has sized the record.

use super::{HemispherePlane, PlaneSample, RecordKind, nearer_depth, plane::rect_solid_angle};
use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::hsh::{basis_into, coefficient_count};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// The basis integrated over every pixel of a plane, and over every pixel edge for the
/// coefficients' translational gradients.
#[derive(Clone, Debug)]
pub struct PlaneBasis {
    pub order: u32,
    pub resolution: u32,
    /// `resolution^2` pixels, `order^2` values each: `W_pk`.
    pub weights: Vec<f32>,
    /// Per pixel, `order^2` weights of the edge to its right neighbour (x + 1) in the
    /// translational gradient (0 on the last column): algorithms.md 3.3 with `H_k` in place
    /// of the cosine, `integral along the edge of H_k(w_b) / (1 + x_b^2 + y^2)^(3/2) dy`.
    pub edge_x: Vec<f32>,
    /// The same for the edge to the neighbour above (y + 1).
    pub edge_y: Vec<f32>,
}

/// `integral over [t0, t1] of H(dir(x_b, c tan t)) cos(t) / c^2 dt` (`c^2 = 1 + x_b^2`),
/// the edge integral of algorithms.md 3.3 after `y = c tan t` (finite for infinite edges),
/// by the midpoint rule with `steps` steps; `swap` puts the edge's coordinate on y. `h` is
/// room for one basis evaluation.
fn edge_weights(
    order: u32,
    (x_b, y0, y1): (f64, f64, f64),
    steps: usize,
    swap: bool,
    h: &mut [f64],
) -> Vec<f64> {
    let c2 = 1.0 + x_b * x_b;
    let c = c2.sqrt();
    let (t0, t1) = ((y0 / c).atan(), (y1 / c).atan());
    let mut w = vec![0.0f64; coefficient_count(order)];
    for q in 0..steps {
        let t = t0 + (t1 - t0) * (q as f64 + 0.5) / steps as f64;
        let y = c * t.tan();
        let dir = if swap {
            DVec3::new(y, x_b, 1.0)
        } else {
            DVec3::new(x_b, y, 1.0)
        }
        .normalize();
        let dt = (t1 - t0) / steps as f64 * t.cos() / c2;
        basis_into(order, dir, h);
        for (wk, hk) in w.iter_mut().zip(h.iter()) {
            *wk += dt * hk;
        }
    }
    w
}

impl PlaneBasis {
    /// `W` of `plane` at `order`, each pixel split into `sub x sub` cells whose exact solid
    /// angles weigh the basis at their centres; the edge weights with `4 sub` steps.
    ///
    /// About a million basis evaluations at 48 x 48, order 8 (1.4 s on one core here, 1.7 s
    /// on the H200 machine's, more than its whole GPU frame): the rows are computed on every
    /// core ([`crate::parallel::ordered_map`]), each exactly as one thread would, so the
    /// table's bits do not depend on the thread count.
    pub fn new(plane: &HemispherePlane, order: u32, sub: u32) -> Self {
        let p = plane.resolution as usize;
        let m = sub.max(1) as usize;
        let n = coefficient_count(order);
        let axes: Vec<_> = (0..p).map(|i| plane.sub_intervals(i, m)).collect();
        let rows = crate::parallel::ordered_map(p, |j| {
            let (ye, yc) = &axes[j];
            let mut h = vec![0.0f64; n];
            let mut weights = Vec::with_capacity(p * n);
            let mut edge_x = Vec::with_capacity(p * n);
            let mut edge_y = Vec::with_capacity(p * n);
            for (i, (xe, xc)) in axes.iter().enumerate() {
                let mut w = vec![0.0f64; n];
                for qy in 0..m {
                    for qx in 0..m {
                        let omega = rect_solid_angle(xe[qx], xe[qx + 1], ye[qy], ye[qy + 1]);
                        let dir = DVec3::new(xc[qx], yc[qy], 1.0).normalize();
                        basis_into(order, dir, &mut h);
                        for (wk, hk) in w.iter_mut().zip(&h) {
                            *wk += omega * hk;
                        }
                    }
                }
                weights.extend(w.iter().map(|&x| x as f32));
                let ex = if i + 1 < p {
                    edge_weights(order, (xe[m], ye[0], ye[m]), 4 * m, false, &mut h)
                } else {
                    vec![0.0; n]
                };
                let ey = if j + 1 < p {
                    edge_weights(order, (ye[m], xe[0], xe[m]), 4 * m, true, &mut h)
                } else {
                    vec![0.0; n]
                };
                edge_x.extend(ex.iter().map(|&x| x as f32));
                edge_y.extend(ey.iter().map(|&x| x as f32));
            }
            (weights, edge_x, edge_y)
        });
        let (mut weights, mut edge_x, mut edge_y) = (
            Vec::with_capacity(p * p * n),
            Vec::with_capacity(p * p * n),
            Vec::with_capacity(p * p * n),
        );
        for (w, ex, ey) in rows {
            weights.extend(w);
            edge_x.extend(ex);
            edge_y.extend(ey);
        }
        Self {
            order,
            resolution: plane.resolution,
            weights,
            edge_x,
            edge_y,
        }
    }

    /// The GPU table: per pixel `W`, edge-x and edge-y weights, each padded with zeros to
    /// [`Self::gpu_section`] f32s (a whole number of the kernel's coefficient blocks, so
    /// it reads no weight past a section's end).
    pub fn gpu_table(&self) -> Vec<f32> {
        let n = coefficient_count(self.order);
        let section = self.gpu_section() as usize;
        let mut out = Vec::with_capacity(self.weights.len() / n * 3 * section);
        for p in 0..self.weights.len() / n {
            for weights in [&self.weights, &self.edge_x, &self.edge_y] {
                out.extend_from_slice(&weights[p * n..(p + 1) * n]);
                out.resize(out.len() + section - n, 0.0);
            }
        }
        out
    }

    /// f32s per section of [`Self::gpu_table`]: `order^2` rounded up to a multiple of
    /// the coefficients one invocation sums.
    pub fn gpu_section(&self) -> u32 {
        (coefficient_count(self.order) as u32).next_multiple_of(COEFFICIENTS_PER_INVOCATION)
    }
}

/// The coefficients of one plane (`P^2` samples): `order^2` per channel, channel-major
/// (all red coefficients, then green, then blue), summed over pixels in order as the GPU.
pub fn project(basis: &PlaneBasis, samples: &[PlaneSample]) -> Vec<f32> {
    project_with_gradients(basis, samples)[..3 * coefficient_count(basis.order)].to_vec()
}

/// The coefficients and their translational gradients along the plane's x and y axes
/// (`9 order^2`, laid out as [`super::RecordKind::coefficient_floats`] after the frame):
/// each pixel edge sweeps the radiance difference across it over the nearer depth (the
/// edge's slope, algorithms.md 3.3) times the edge's weight, summed in pixel order as the
/// GPU.
pub fn project_with_gradients(basis: &PlaneBasis, samples: &[PlaneSample]) -> Vec<f32> {
    let n = coefficient_count(basis.order);
    let res = basis.resolution as usize;
    let mut out = vec![0.0f32; 9 * n];
    for c in 0..3 {
        for k in 0..n {
            let (mut v, mut gx, mut gy) = (0.0f32, 0.0f32, 0.0f32);
            for (p, s) in samples.iter().enumerate() {
                v += s.radiance[c] * basis.weights[p * n + k];
                if p % res + 1 < res {
                    let right = &samples[p + 1];
                    let z = nearer_depth(s.depth, right.depth);
                    if z > 0.0 {
                        gx += (right.radiance[c] - s.radiance[c]) / z * basis.edge_x[p * n + k];
                    }
                }
                if p + res < samples.len() {
                    let up = &samples[p + res];
                    let z = nearer_depth(s.depth, up.depth);
                    if z > 0.0 {
                        gy += (up.radiance[c] - s.radiance[c]) / z * basis.edge_y[p * n + k];
                    }
                }
            }
            out[c * n + k] = v;
            out[3 * n + c * n + k] = gx;
            out[6 * n + c * n + k] = gy;
        }
    }
    out
}

/// Coefficients one invocation of `radiance_project.wgsl` sums (its `BLOCK`).
const COEFFICIENTS_PER_INVOCATION: u32 = 16;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ProjectParams {
    pixels: u32,
    resolution: u32,
    coefficients: u32,
    count: u32,
    first_record: u32,
    stride: u32,
    values_only: u32,
    table_section: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LimitParams {
    coefficients: u32,
    count: u32,
    first_record: u32,
    stride: u32,
    reach: f32,
    _pad: [u32; 3],
}

/// Ward's gradient limit on one radiance record (CPU mirror of `radiance_limit.wgsl`):
/// `block` holds the record's coefficients and their gradients (`9 order^2` f32s, laid out
/// as [`super::RecordKind::coefficient_floats`] after the frame). Per channel, with `V` the
/// coefficients' norm and `G` their gradients' (`sqrt(sum_k |grad lambda_k|^2)`), the radius
/// shrinks to `V / (reach G)`, never below `r_min`; where `r_min` binds the gradients are
/// scaled so that `reach G R = V`. `reach` is the radiance accuracy a: the splat uses a
/// record within `a R` of it. Returns the new radius.
///
/// The first-order extrapolation then moves the coefficients by at most their own norm
/// wherever the record is used. A record a few cm from an object sees it at depths far
/// below its reach, where the edge slopes `(L_b - L_a) / z` hold only over displacements
/// under `z` (docs/results.md, "Radiance records beside an object").
pub fn limit_gradients(block: &mut [f32], order: u32, radius: f32, r_min: f32, reach: f32) -> f32 {
    let n = coefficient_count(order);
    let (mut norm, mut slope) = ([0.0f32; 3], [0.0f32; 3]);
    for c in 0..3 {
        for k in 0..n {
            let (v, gx, gy) = (
                block[c * n + k],
                block[3 * n + c * n + k],
                block[6 * n + c * n + k],
            );
            norm[c] += v * v;
            slope[c] += gx * gx + gy * gy;
        }
        norm[c] = norm[c].sqrt();
        slope[c] = slope[c].sqrt() * reach;
    }
    let mut limited = radius;
    for c in 0..3 {
        if slope[c] * limited > norm[c] {
            limited = norm[c] / slope[c];
        }
    }
    let r = limited.max(r_min);
    for c in 0..3 {
        if slope[c] * r > norm[c] {
            let s = norm[c] / (slope[c] * r);
            for k in 0..n {
                block[3 * n + c * n + k] *= s;
                block[6 * n + c * n + k] *= s;
            }
        }
    }
    r
}

/// The GPU projection pass with its plane basis.
pub struct RadianceProjectionPass {
    pass: std::sync::Arc<ComputePass>,
    /// Ward's gradient limit on the coefficients (`radiance_limit.wgsl`), after the
    /// reduction has sized the records.
    limit: std::sync::Arc<ComputePass>,
    pub basis: PlaneBasis,
    table: wgpu::Buffer,
}

impl RadianceProjectionPass {
    /// The pass for planes of `plane` at HSH `order` (`sub x sub` quadrature cells per
    /// pixel for the basis integrals).
    pub fn new(ctx: &GpuContext, plane: &HemispherePlane, order: u32, sub: u32) -> Result<Self> {
        use Binding::*;
        // The table's size is known before its integrals are computed (they took 39 s for
        // a 512 x 512 plane at order 10, only for the buffer to be refused then).
        let least = plane.pixels.len() as u64 * 3 * coefficient_count(order) as u64 * 4;
        if least > ctx.max_binding_size() {
            return Err(crate::Error::DeviceLimit(format!(
                "radiance records' plane basis integrals ({0} x {0} plane, order {order}) \
                 need {1} MiB or more in one storage buffer; this device allows {2} MiB: \
                 lower --radiance-plane-resolution or --radiance-order",
                plane.resolution,
                least.div_ceil(1 << 20),
                ctx.max_binding_size() >> 20
            )));
        }
        let basis = PlaneBasis::new(plane, order, sub);
        Ok(Self {
            pass: ComputePass::new(
                ctx,
                "radiance_project.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                ],
            )?,
            limit: ComputePass::new(
                ctx,
                "radiance_limit.wgsl",
                &[Uniform, StorageReadWrite, StorageReadWrite],
            )?,
            table: ctx.storage_buffer("plane basis integrals", &basis.gpu_table())?,
            basis,
        })
    }

    /// Projects the `count` planes of `sites` (`samples`: `P^2` [`PlaneSample`]s each)
    /// into the radiance records `first_record..` of `out` (a coefficient buffer laid out
    /// as [`RecordKind::coefficient_floats`]): each record's frame, coefficients and their
    /// gradients; with `values_only`, the frame and coefficient values only (the
    /// gradients' floats are left as they are: an estimate at t+1 that only gives tau
    /// needs no gradients, and skipping them costs a third as much).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        sites: &wgpu::Buffer,
        samples: &wgpu::Buffer,
        out: &wgpu::Buffer,
        first_record: u32,
        count: u32,
        values_only: bool,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let n = coefficient_count(self.basis.order) as u32;
        let kind = RecordKind::Radiance {
            order: self.basis.order,
        };
        let params = ctx.uniform_buffer(
            "projection params",
            &ProjectParams {
                pixels: self.basis.resolution * self.basis.resolution,
                resolution: self.basis.resolution,
                coefficients: n,
                count,
                first_record,
                stride: kind.coefficient_floats() as u32,
                values_only: u32::from(values_only),
                table_section: self.basis.gpu_section(),
            },
        );
        let bind = self
            .pass
            .bind(ctx, &[&params, &self.table, sites, samples, out]);
        self.pass.record(
            enc,
            &scene.bind_group,
            &bind,
            [
                count.div_ceil(64),
                n.div_ceil(COEFFICIENTS_PER_INVOCATION),
                1,
            ],
            timestamps,
        );
    }

    /// Records Ward's gradient limit ([`limit_gradients`], `radiance_limit.wgsl`) on the
    /// radiance records `first_record..first_record + count` of `records` and
    /// `coefficients`, once the reduction has written their radii and the projection their
    /// gradients. `reach` is the radiance accuracy a.
    #[allow(clippy::too_many_arguments)]
    pub fn record_limit(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        records: &wgpu::Buffer,
        coefficients: &wgpu::Buffer,
        first_record: u32,
        count: u32,
        reach: f32,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let kind = RecordKind::Radiance {
            order: self.basis.order,
        };
        let params = ctx.uniform_buffer(
            "radiance limit params",
            &LimitParams {
                coefficients: coefficient_count(self.basis.order) as u32,
                count,
                first_record,
                stride: kind.coefficient_floats() as u32,
                reach,
                _pad: [0; 3],
            },
        );
        let bind = self.limit.bind(ctx, &[&params, records, coefficients]);
        self.limit
            .record(enc, &scene.bind_group, &bind, [count, 1, 1], timestamps);
    }
}
