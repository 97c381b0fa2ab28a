//! The brute-force reference: direct light plus first-bounce indirect light by Monte Carlo
//! per pixel, deterministic, for judging the irradiance cache against.
//!
//! For each visible pixel with albedo ρ, shading normal n and `spp` = N, directions ω_k are
//! cosine-distributed around n (Owen-scrambled Sobol points, scramble seeded per pixel and
//! by [`ReferenceOptions::seed`]) and traced to their closest hit, whose outgoing radiance is
//!
//! ```text
//! L_k = ρ(hit) / π · E_direct(hit) + L_e,indirect(hit)            (Lambertian hit)
//! ```
//!
//! (`direct_irradiance` and `indirect_emission` of `wgsl/shared/shading.wgsl`). With the
//! cosine pdf p(ω) = cos θ / π, the irradiance estimate is E = π/N Σ L_k, and the reflected
//! indirect radiance is
//!
//! ```text
//! L_indirect = ρ / π · E = ρ / N · Σ L_k.
//! ```
//!
//! Rays that miss, and rays that hit emitters already sampled as lights (rect-light quads),
//! add nothing: the environment and those emitters are lights of `direct_irradiance`, so
//! counting them again would count them twice (Ward et al. 1988: "we count as zero any
//! samples that intersect a light source"). The beauty image is emission + direct + indirect.
//!
//! The GPU pass is `wgsl/reference_indirect.wgsl`; it runs in chunks of samples (and of rows
//! on large images) so that no single dispatch runs for long and progress can be shown. Each
//! chunk adds its samples, in sample order, to a per-pixel running sum, so the result does
//! not depend on the chunking and is the same bytes run to run. [`cpu`] is the plain-Rust
//! mirror that tests compare against.
//!
//! Seeds (`radsplat reference --seed N`): seed 0 is the historical sequence (the bytes of
//! builds without the option); any other seed hashes N into every pixel's scramble seed,
//! which gives an independent Owen scramble of the same Sobol points and independent light
//! samples at the bounce hits. Two seeds estimate the same integral with independent noise,
//! so their difference measures a reference's own noise (RMSE(A − B) / √2 per image). The
//! direct light at the pixel (the frame's pass) does not depend on the seed.

pub mod cpu;

use crate::frame::{Frame, PreparedScene, Renderer};
use crate::gpu::pipeline::Binding;
use crate::gpu::scene_pass::{ScenePass, ScenePassShader};
use crate::gpu::{GpuContext, SceneFeatures};
use crate::output::exr_out::{Channels, encode_exr_owned, frame_channels};
use crate::output::write_atomically;
use crate::scene::Camera;
use crate::visibility::GpuCamera;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use std::path::Path;
use std::time::Instant;

/// Sample-pixels per dispatch: about a second of lavapipe time on the Cornell box with 16
/// light samples (each sample-pixel costs one bounce ray and the hit's shadow rays).
pub const DEFAULT_CHUNK_WORK: u64 = 1 << 18;

pub use crate::gpu::context::{MAX_RAYS_PER_INVOCATION, max_samples_per_dispatch};

/// Rust mirror of WGSL `ReferenceParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct ReferenceParams {
    sample_begin: u32,
    sample_end: u32,
    row_begin: u32,
    row_end: u32,
    seed: u32,
    bounces: u32,
    _pad: [u32; 2],
}

/// One dispatch of the reference pass: samples `[samples.0, samples.1)` of rows
/// `[rows.0, rows.1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Chunk {
    pub samples: (u32, u32),
    pub rows: (u32, u32),
}

/// Splits `spp` samples of a `width x height` image into dispatches of at most about
/// `work` sample-pixels each (at least one sample of one row) and at most `max_samples`
/// samples ([`max_samples_per_dispatch`]). Rows are split only when one sample of the whole
/// image exceeds `work`. Samples are the outer loop, so every pixel receives its samples
/// in order.
pub fn plan_chunks(width: u32, height: u32, spp: u32, work: u64, max_samples: u32) -> Vec<Chunk> {
    let pixels = u64::from(width) * u64::from(height);
    let work = work.max(1);
    let (samples_per, rows_per) = if pixels >= work {
        (
            1,
            (work / u64::from(width.max(1))).clamp(1, u64::from(height)) as u32,
        )
    } else {
        (
            (work / pixels.max(1))
                .clamp(1, u64::from(spp.max(1)))
                .min(u64::from(max_samples.max(1))) as u32,
            height,
        )
    };
    let mut chunks = Vec::new();
    let mut s = 0;
    while s < spp {
        let s_end = s.saturating_add(samples_per).min(spp);
        let mut r = 0;
        while r < height {
            let r_end = r.saturating_add(rows_per).min(height);
            chunks.push(Chunk {
                samples: (s, s_end),
                rows: (r, r_end),
            });
            r = r_end;
        }
        s = s_end;
    }
    chunks
}

/// The most bounce directions per pixel a reference takes: 2^24, hours of rays for one
/// pixel on a fast GPU, well inside the Sobol sequence's 2^32 points (more would only plan
/// dispatches that never finish).
pub const MAX_SPP: u32 = 1 << 24;

/// Options of a reference render.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceOptions {
    /// Bounce directions per pixel (N). At least 1; powers of two suit the Sobol points.
    pub spp: u32,
    /// Sample-pixels per dispatch ([`DEFAULT_CHUNK_WORK`]).
    pub chunk_work: u64,
    /// Sequence seed (module docs): 0, the default, gives the seed-less bytes.
    pub seed: u32,
    /// Bounces N (Radiance's `-ab N`): light reflected N times between the lights and the
    /// camera's surface, Lambertian at every hit after the first. 1, the default, is the
    /// first bounce alone.
    pub bounces: u32,
}

impl ReferenceOptions {
    /// `spp` directions per pixel, default chunking.
    pub fn new(spp: u32) -> Self {
        Self {
            spp,
            chunk_work: DEFAULT_CHUNK_WORK,
            seed: 0,
            bounces: 1,
        }
    }

    /// The same options with sequence seed `seed`.
    pub fn with_seed(self, seed: u32) -> Self {
        Self { seed, ..self }
    }

    /// The same options with `bounces` bounces.
    pub fn with_bounces(self, bounces: u32) -> Self {
        Self { bounces, ..self }
    }
}

/// Timings and sizes of a reference render.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ReferenceStats {
    pub spp: u32,
    /// Sequence seed ([`ReferenceOptions::seed`]).
    pub seed: u32,
    pub dispatches: usize,
    /// Visibility + direct frame (as `render`), ms.
    pub direct_ms: f64,
    /// All indirect dispatches, wall time, ms.
    pub indirect_ms: f64,
    /// Bounce rays traced (visible pixels × spp; each also casts the hit's shadow rays).
    pub bounce_rays: u64,
}

/// A reference frame: the direct frame with `beauty` = emission + direct + indirect, and the
/// reflected first-bounce indirect radiance per pixel.
#[derive(Clone, Debug)]
pub struct ReferenceFrame {
    pub frame: Frame,
    /// Reflected first-bounce indirect radiance (RGB + alpha 1), zero on background.
    pub indirect: Vec<[f32; 4]>,
    pub stats: ReferenceStats,
}

impl ReferenceFrame {
    /// EXR channels: those of [`frame_channels`] plus `indirect.R/G/B`.
    pub fn channels(&self) -> Channels {
        let mut ch = frame_channels(&self.frame);
        for (c, name) in ["indirect.R", "indirect.G", "indirect.B"]
            .iter()
            .enumerate()
        {
            ch.push((
                name.to_string(),
                self.indirect.iter().map(|p| p[c]).collect(),
            ));
        }
        ch
    }

    /// Encodes the frame and its AOVs (with `indirect.*`) as EXR bytes.
    pub fn encode_exr(&self) -> Result<Vec<u8>> {
        encode_exr_owned(self.frame.width, self.frame.height, self.channels())
            .map_err(|e| Error::Gpu(format!("internal: encoding EXR: {e}")))
    }

    /// Writes the EXR atomically; returns its bytes.
    pub fn write_exr(&self, path: &Path) -> Result<Vec<u8>> {
        let bytes = encode_exr_owned(self.frame.width, self.frame.height, self.channels())
            .map_err(|message| Error::Output {
                path: path.to_path_buf(),
                message,
            })?;
        write_atomically(path, &bytes)?;
        Ok(bytes)
    }
}

/// The compiled reference pass (`wgsl/reference_indirect.wgsl`).
pub struct ReferencePass {
    pass: ScenePass,
}

/// The reference pass's shader and bindings: the camera, the visibility buffer, its
/// parameters and its two sums (Lambertian and glossy). It traces every bounce itself, so
/// the bounce cache plays no part in it.
static SHADER: ScenePassShader = ScenePassShader {
    shader: "reference_indirect.wgsl",
    bindings: &[
        Binding::Uniform,
        Binding::StorageRead,
        Binding::Uniform,
        Binding::StorageReadWrite,
        Binding::StorageReadWrite,
    ],
    name: "reference pass",
    builder: "ReferencePass::for_scene",
    reads_bounce_cache: false,
};

impl ReferencePass {
    /// Compiles the pass on `ctx`, for any scene.
    /// [`Self::for_scene`] compiles it for one scene's features alone (`SceneFeatures::of`),
    /// which lavapipe builds and runs faster: an engine that knows its scene should use that.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Self::for_scene(ctx, SceneFeatures::ALL)
    }

    /// Compiles the pass for scenes of `features` alone (their kinds of light, instances,
    /// textures): less code for the driver to build and, on lavapipe, to run per path.
    /// [`Self::render`] refuses a scene with another feature.
    pub fn for_scene(ctx: &GpuContext, features: SceneFeatures) -> Result<Self> {
        Ok(Self {
            pass: ScenePass::compile(ctx, &SHADER, features)?,
        })
    }

    /// Renders the reference: `renderer.render_frame` for visibility and direct light, then
    /// the indirect dispatches planned by [`plan_chunks`]. `progress(done, total)` is called
    /// after each dispatch has finished.
    pub fn render(
        &self,
        renderer: &Renderer,
        prepared: &PreparedScene,
        camera: &Camera,
        options: &ReferenceOptions,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<ReferenceFrame> {
        let pass = self.pass.for_scene(prepared.gpu.features())?;
        if !(1..=MAX_SPP).contains(&options.spp) {
            return Err(Error::Usage(format!(
                "spp {} must be between 1 and {MAX_SPP}",
                options.spp
            )));
        }
        let ctx = &renderer.ctx;
        let t0 = Instant::now();
        let mut frame = renderer.render_frame(prepared, camera)?;
        let direct_ms = t0.elapsed().as_secs_f64() * 1e3;

        let t1 = Instant::now();
        let (width, height) = (frame.width, frame.height);
        let camera_buffer = ctx.uniform_buffer("reference camera", &GpuCamera::new(camera));
        let vis = ctx.storage_buffer("reference visibility", &frame.visibility)?;
        let sums =
            ctx.storage_buffer_sized("radiance sums", u64::from(width) * u64::from(height) * 16)?;
        // Written only at glossy pixels: a placeholder when the scene has none.
        let glossy_bytes = if prepared.gpu.has_glossy {
            u64::from(width) * u64::from(height) * 16
        } else {
            16
        };
        let glossy_sums = ctx.storage_buffer_sized("glossy sums", glossy_bytes)?;
        // Shadow rays per bounce hit, at most; glossy pixels trace a second bounce per sample.
        let info = &prepared.gpu.info;
        // Each of the sample's paths (two on glossy pixels) has N hits, each with its
        // shadow rays, and N - 1 rays past the first hit.
        let paths = if prepared.gpu.has_glossy { 2 } else { 1 };
        let bounces = u64::from(options.bounces.max(1));
        let shadow_rays =
            paths * (bounces * info.max_shadow_rays(info.light_samples.max(1)) + bounces - 1);
        let chunks = plan_chunks(
            width,
            height,
            options.spp,
            options.chunk_work,
            max_samples_per_dispatch(shadow_rays),
        );
        for (i, chunk) in chunks.iter().enumerate() {
            let params = ctx.uniform_buffer(
                "reference params",
                &ReferenceParams {
                    sample_begin: chunk.samples.0,
                    sample_end: chunk.samples.1,
                    row_begin: chunk.rows.0,
                    row_end: chunk.rows.1,
                    seed: options.seed,
                    bounces: options.bounces.max(1),
                    _pad: [0; 2],
                },
            );
            let bind = pass.bind(ctx, &[&camera_buffer, &vis, &params, &sums, &glossy_sums]);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            pass.record(
                &mut encoder,
                &prepared.gpu.bind_group,
                &bind,
                [
                    width.div_ceil(8),
                    (chunk.rows.1 - chunk.rows.0).div_ceil(8),
                    1,
                ],
                None,
            );
            ctx.queue.submit([encoder.finish()]);
            ctx.wait()?;
            progress(i + 1, chunks.len());
        }
        let sums: Vec<[f32; 4]> = ctx.read_buffer(&sums)?;
        let mut indirect = finish_indirect(&frame.albedo, &sums, options.spp);
        if prepared.gpu.has_glossy {
            let glossy_sums: Vec<[f32; 4]> = ctx.read_buffer(&glossy_sums)?;
            add_glossy_indirect(&mut indirect, &glossy_sums, options.spp);
        }
        for (b, ind) in frame.beauty.iter_mut().zip(&indirect) {
            for (bc, ic) in b.iter_mut().zip(&ind[..3]) {
                *bc += ic;
            }
        }
        let visible = frame.visibility.iter().filter(|v| v.is_hit()).count() as u64;
        Ok(ReferenceFrame {
            frame,
            indirect,
            stats: ReferenceStats {
                spp: options.spp,
                seed: options.seed,
                dispatches: chunks.len(),
                direct_ms,
                indirect_ms: t1.elapsed().as_secs_f64() * 1e3,
                bounce_rays: visible * u64::from(options.spp),
            },
        })
    }
}

/// Reflected indirect radiance from per-pixel radiance sums: ρ / N · Σ L_k (module docs),
/// alpha 1. Background pixels have albedo 0, hence give 0.
pub fn finish_indirect(albedo: &[[f32; 4]], sums: &[[f32; 4]], spp: u32) -> Vec<[f32; 4]> {
    let inv_n = 1.0 / spp.max(1) as f32;
    albedo
        .iter()
        .zip(sums)
        .map(|(a, s)| {
            [
                a[0] * (s[0] * inv_n),
                a[1] * (s[1] * inv_n),
                a[2] * (s[2] * inv_n),
                1.0,
            ]
        })
        .collect()
}

/// Adds the glossy lobes' indirect light, `1 / N * sum f cos / pdf L_k` (the sums are zero
/// where a pixel has no glossy lobe).
pub fn add_glossy_indirect(indirect: &mut [[f32; 4]], glossy_sums: &[[f32; 4]], spp: u32) {
    let inv_n = 1.0 / spp.max(1) as f32;
    for (i, g) in indirect.iter_mut().zip(glossy_sums) {
        for c in 0..3 {
            i[c] += g[c] * inv_n;
        }
    }
}

/// Renders a reference frame of a prepared scene with `spp` bounce directions per pixel
/// (compiles the pass; keep a [`ReferencePass`] to render several frames).
pub fn render_reference(
    renderer: &Renderer,
    prepared: &PreparedScene,
    camera: &Camera,
    spp: u32,
) -> Result<ReferenceFrame> {
    ReferencePass::for_scene(&renderer.ctx, prepared.gpu.features())?.render(
        renderer,
        prepared,
        camera,
        &ReferenceOptions::new(spp),
        &mut |_, _| {},
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_cover_every_sample_of_every_row_once_in_order() {
        for (w, h, spp, work, max_samples) in [
            (24, 24, 16, 1 << 18, 1000),
            (128, 128, 256, 1 << 18, 1000),
            (64, 64, 1024, 1 << 18, 3),
            (1000, 700, 3, 1 << 18, 1),
            (7, 5, 9, 4, 2),
            (3, 1, 1, 1, 1),
        ] {
            let chunks = plan_chunks(w, h, spp, work, max_samples);
            let mut next = vec![0u32; h as usize];
            for c in &chunks {
                assert!(c.samples.0 < c.samples.1 && c.rows.0 < c.rows.1);
                for r in c.rows.0..c.rows.1 {
                    assert_eq!(next[r as usize], c.samples.0, "{w}x{h} spp {spp}");
                    next[r as usize] = c.samples.1;
                }
                let cost = u64::from(c.samples.1 - c.samples.0)
                    * u64::from(c.rows.1 - c.rows.0)
                    * u64::from(w);
                assert!(cost <= work.max(u64::from(w)), "{c:?} costs {cost}");
                assert!(c.samples.1 - c.samples.0 <= max_samples, "{c:?}");
            }
            assert!(next.iter().all(|&n| n == spp));
        }
    }
}
