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
//! one invocation per (record, coefficient) summing the pixels in order, so the result is
//! deterministic; [`project`] is its CPU mirror.

use super::{HemispherePlane, PlaneSample, plane::rect_solid_angle};
use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::hsh::{basis, coefficient_count};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// The basis integrated over every pixel of a plane.
#[derive(Clone, Debug)]
pub struct PlaneBasis {
    pub order: u32,
    pub resolution: u32,
    /// `resolution^2` pixels, `order^2` values each.
    pub weights: Vec<f32>,
}

impl PlaneBasis {
    /// `W` of `plane` at `order`, each pixel split into `sub x sub` cells whose exact solid
    /// angles weigh the basis at their centres.
    pub fn new(plane: &HemispherePlane, order: u32, sub: u32) -> Self {
        let p = plane.resolution as usize;
        let m = sub.max(1) as usize;
        let n = coefficient_count(order);
        let axes: Vec<_> = (0..p).map(|i| plane.sub_intervals(i, m)).collect();
        let mut weights = Vec::with_capacity(p * p * n);
        for (ye, yc) in &axes {
            for (xe, xc) in &axes {
                let mut w = vec![0.0f64; n];
                for qy in 0..m {
                    for qx in 0..m {
                        let omega = rect_solid_angle(xe[qx], xe[qx + 1], ye[qy], ye[qy + 1]);
                        let dir = DVec3::new(xc[qx], yc[qy], 1.0).normalize();
                        for (wk, hk) in w.iter_mut().zip(basis(order, dir)) {
                            *wk += omega * hk;
                        }
                    }
                }
                weights.extend(w.iter().map(|&x| x as f32));
            }
        }
        Self {
            order,
            resolution: plane.resolution,
            weights,
        }
    }
}

/// The coefficients of one plane (`P^2` samples): `order^2` per channel, channel-major
/// (all red coefficients, then green, then blue), summed over pixels in order as the GPU.
pub fn project(basis: &PlaneBasis, samples: &[PlaneSample]) -> Vec<f32> {
    let n = coefficient_count(basis.order);
    let mut out = vec![0.0f32; 3 * n];
    for c in 0..3 {
        for k in 0..n {
            let mut sum = 0.0f32;
            for (p, s) in samples.iter().enumerate() {
                sum += s.radiance[c] * basis.weights[p * n + k];
            }
            out[c * n + k] = sum;
        }
    }
    out
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ProjectParams {
    pixels: u32,
    coefficients: u32,
    count: u32,
    _pad: u32,
}

/// The GPU projection pass with its plane basis.
pub struct RadianceProjectionPass {
    pass: ComputePass,
    pub basis: PlaneBasis,
    weights: wgpu::Buffer,
}

impl RadianceProjectionPass {
    /// The pass for planes of `plane` at HSH `order` (`sub x sub` quadrature cells per
    /// pixel for the basis integrals).
    pub fn new(ctx: &GpuContext, plane: &HemispherePlane, order: u32, sub: u32) -> Result<Self> {
        use Binding::*;
        let basis = PlaneBasis::new(plane, order, sub);
        Ok(Self {
            pass: ComputePass::new(
                ctx,
                "radiance_project.wgsl",
                &[Uniform, StorageRead, StorageRead, StorageReadWrite],
            )?,
            weights: ctx.storage_buffer("plane basis integrals", &basis.weights)?,
            basis,
        })
    }

    /// Projects `count` planes (`samples`: `P^2` [`PlaneSample`]s each) into `out`
    /// (`3 order^2` f32 per plane, as [`project`]).
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        samples: &wgpu::Buffer,
        out: &wgpu::Buffer,
        count: u32,
    ) {
        let n = coefficient_count(self.basis.order) as u32;
        let params = ctx.uniform_buffer(
            "projection params",
            &ProjectParams {
                pixels: self.basis.resolution * self.basis.resolution,
                coefficients: n,
                count,
                _pad: 0,
            },
        );
        let bind = self.pass.bind(ctx, &[&params, &self.weights, samples, out]);
        self.pass.record(
            enc,
            &scene.bind_group,
            &bind,
            [(3 * n).div_ceil(64), count, 1],
            None,
        );
    }
}
