//! Irradiance records (thesis chapter 4, Ward's irradiance caching underneath): what a
//! record holds, where new ones go ([`RecordSite`]), how they are computed on the GPU
//! ([`RecordPass`]: sites → records, from hemisphere planes or from virtual point lights,
//! [`RecordSource`] says which) and the cache that holds them across frames
//! ([`RecordCache`]). [`reference`](mod@reference) and [`vpl_gather::reference_record`]
//! mirror the computations on the CPU.
//!
//! This file holds the record and the cache; the pass that computes records is in
//! `record_pass.rs`, the cache's settings and their checks in `settings.rs`, and
//! Radiance's corral (the horizon a record may not reach past) in `corral.rs`.

mod corral;
pub mod hessian;
pub mod kind;
pub mod neighbour_grid;
pub mod noise_widening;
pub mod photon_records;
pub mod plane;
pub mod plane_error;
pub mod radiance_projection;
mod record_pass;
pub mod reference;
pub mod refine;
mod settings;
pub mod source;
pub mod stage;
pub mod vpl_gather;
pub mod vpl_update;

use crate::gpu::GpuContext;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use corral::corral_sub_sector;
pub use corral::{
    CORRAL_BITS, CORRAL_DIRECTIONS, CORRAL_DISTANCE, CORRAL_PER_WORD, CORRAL_SECTORS, Corral,
    corral_level, corral_quarter, corral_sector, corral_turn, corral_words,
};
use glam::Vec3;
pub use kind::RecordKind;
pub use plane::{HemispherePlane, PlaneMode, PlanePixel, PlaneSpacing, RefineSample};
pub(crate) use record_pass::PlaneParams;
pub use record_pass::{PlaneTable, RecordPass, ReductionBatch, RefinedPlanes, RefinementRays};
pub use settings::{CacheSettings, MAX_GLOSSY_SAMPLES, PlaneShadows, RecordRadius};
pub use source::RecordSource;
pub use stage::{PlaneBatch, RecordStage};

/// One irradiance record (Rust mirror of WGSL `Record`, 144 bytes): p, n, R, E and the
/// rotational and translational gradients per colour channel (algorithms.md decision 3).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Record {
    pub position: [f32; 3],
    /// R_k: harmonic mean distance, clamped to `[r_min, r_max_factor * r_min]` and by
    /// Ward's gradient limit.
    pub radius: f32,
    pub normal: [f32; 3],
    /// The R_min the record was computed with.
    pub r_min: f32,
    /// E_k (rgb).
    pub irradiance: [f32; 3],
    /// The instance the record lies on (temporal caching can move records with it).
    pub instance: u32,
    /// Per channel (r, g, b): the world-space rotational gradient (xyz). The red
    /// channel's w holds the record's relative noise ([`Record::relative_noise`]); the
    /// green and blue channels' w its corral ([`Record::corral`]; 0 without one).
    pub rotation_gradient: [[f32; 4]; 3],
    /// Per channel: the world-space translational gradient.
    pub translation_gradient: [[f32; 4]; 3],
}

impl Record {
    pub fn position(&self) -> Vec3 {
        self.position.into()
    }
    pub fn normal(&self) -> Vec3 {
        self.normal.into()
    }
    pub fn irradiance(&self) -> Vec3 {
        Vec3::new(self.irradiance[0], self.irradiance[1], self.irradiance[2])
    }

    /// The relative noise of the record's irradiance, estimated from its plane
    /// ([`reference::plane_noise`]); 0 where its source estimates none (VPL and photon
    /// records) and for dark planes.
    pub fn relative_noise(&self) -> f32 {
        self.rotation_gradient[0][3]
    }

    /// Whether its plane saw no light (E = 0 in every channel). Where only such records
    /// reach a pixel of a still frame, tail fill gives it the lit records that reach it at
    /// the tail's accuracy (`SplatSource::dark_only_empty`).
    pub fn is_dark(&self) -> bool {
        self.irradiance() == Vec3::ZERO
    }

    /// Ward's error term `|p - p_k| / R_k + sqrt(1 - n.n_k)` (thesis eq. 4.2 is its inverse).
    pub fn error_at(&self, p: Vec3, n: Vec3) -> f32 {
        (p - self.position()).length() / self.radius + (1.0 - n.dot(self.normal())).max(0.0).sqrt()
    }

    /// The "behind" test of WGSL `record_in_front`.
    pub fn in_front_of(&self, p: Vec3, n: Vec3, accuracy: f32) -> bool {
        (p - self.position()).dot(n + self.normal()) * 0.5 >= -1.0e-2 * accuracy * self.radius
    }

    /// Whether the record contributes at (p, n) at `accuracy`: Ward's error within it, not
    /// behind and inside its corral (WGSL `reach_error` below `NOT_REACHED`).
    pub fn reaches(&self, p: Vec3, n: Vec3, accuracy: f32) -> bool {
        self.reaches_corralled(p, n, accuracy, true)
    }

    /// [`Record::reaches`] with the corral weighed or not (tail fill's gather weighs
    /// none; placement's cover and the other gathers as [`Corral`] says).
    pub fn reaches_corralled(&self, p: Vec3, n: Vec3, accuracy: f32, corral: bool) -> bool {
        self.error_at(p, n) <= accuracy
            && self.in_front_of(p, n, accuracy)
            && (!corral || self.corral_allows(p))
    }

    /// The corral: [`CORRAL_BITS`] bits per vertex of the polygon of [`CORRAL_SECTORS`]
    /// vertices around the normal (the levels of [`corral_level`]), eight vertices in each
    /// of the green and blue channels' unused rotational-gradient w, as exact integers (0:
    /// no vertex near; records without a plane keep 0).
    pub fn corral(&self) -> [u32; 2] {
        [
            self.rotation_gradient[1][3] as u32,
            self.rotation_gradient[2][3] as u32,
        ]
    }

    /// Stores the corral (see [`Record::corral`]).
    pub fn set_corral(&mut self, corral: [u32; 2]) {
        debug_assert!(corral.iter().all(|&w| w < 1 << 24), "exact in an f32");
        self.rotation_gradient[1][3] = corral[0] as f32;
        self.rotation_gradient[2][3] = corral[1] as f32;
    }

    /// Whether the corral lets the record reach `p` (WGSL `corral_allows`): p's offset
    /// along the record's tangent plane lies on the record's side of the polygon's edge
    /// across p's sector.
    pub fn corral_allows(&self, p: Vec3) -> bool {
        let words = self.corral();
        if words == [0, 0] {
            return true;
        }
        let base = crate::sampling::orthonormal_basis(self.normal());
        let d = p - self.position();
        let q = glam::Vec2::new(d.dot(base.x_axis), d.dot(base.y_axis));
        // In the frame of q's quarter turn (WGSL `corral_quarter`), as the GPU computes it.
        let (quarter, xy) = corral_quarter(q.x, q.y);
        let k = corral_sub_sector(xy);
        let s = 4 * quarter + k;
        let level = |b: u32| {
            (words[(b / CORRAL_PER_WORD) as usize] >> (CORRAL_BITS * (b % CORRAL_PER_WORD))) & 7
        };
        let (l0, l1) = (level(s), level((s + 1) % CORRAL_SECTORS));
        if l0 == 0 && l1 == 0 {
            return true;
        }
        let direction = |k: u32| glam::Vec2::from(CORRAL_DIRECTIONS[k as usize + 8]);
        let p0 = direction(k) * (CORRAL_DISTANCE[l0 as usize] * self.radius);
        let p1 = direction(k + 1) * (CORRAL_DISTANCE[l1 as usize] * self.radius);
        let edge = p1 - p0;
        let side_q = edge.x * (xy.y - p0.y) - edge.y * (xy.x - p0.x);
        let side_o = edge.x * (-p0.y) - edge.y * (-p0.x);
        side_q * side_o >= 0.0
    }

    /// E_k extrapolated to (p, n) with the gradients, clamped at 0 (WGSL
    /// `record_irradiance_at`).
    pub fn irradiance_at(&self, p: Vec3, n: Vec3) -> Vec3 {
        let axis = self.normal().cross(n);
        let d = p - self.position();
        let g = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
        let mut e = self.irradiance();
        for c in 0..3 {
            e[c] += axis.dot(g(self.rotation_gradient[c])) + d.dot(g(self.translation_gradient[c]));
        }
        e.max(Vec3::ZERO)
    }
}

/// How the records' radii R sit between their R_min and R_max (the `render --stats`
/// JSON): records at R_min mark where the harmonic mean distance, or Ward's gradient
/// limit, asked for less than the pixel footprint allows.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct RadiusStats {
    pub records: usize,
    /// Share of records with R = R_min (within 0.1 %).
    pub at_r_min: f64,
    /// Share of records with R = R_max (within 0.1 %).
    pub at_r_max: f64,
    /// Quartiles of R / R_min.
    pub ratio_quartiles: [f32; 3],
    /// Share of records whose plane saw no light (E = 0 in every channel): where only such
    /// records reach, a pixel's indirect light is exactly zero.
    pub dark: f64,
    /// Quartiles of [`Record::relative_noise`].
    pub noise_quartiles: [f32; 3],
}

impl RadiusStats {
    pub fn of(records: &[Record], r_max_factor: f32) -> Self {
        if records.is_empty() {
            return Self::default();
        }
        let mut ratios: Vec<f32> = records
            .iter()
            .map(|r| r.radius / r.r_min.max(f32::MIN_POSITIVE))
            .collect();
        ratios.sort_by(f32::total_cmp);
        let n = ratios.len();
        let share =
            |f: &dyn Fn(f32) -> bool| ratios.iter().filter(|&&x| f(x)).count() as f64 / n as f64;
        Self {
            records: n,
            at_r_min: share(&|x| x <= 1.001),
            at_r_max: share(&|x| x >= r_max_factor * 0.999),
            ratio_quartiles: quartiles(&ratios),
            dark: records.iter().filter(|r| r.is_dark()).count() as f64 / n as f64,
            noise_quartiles: {
                let mut noise: Vec<f32> = records.iter().map(Record::relative_noise).collect();
                noise.sort_by(f32::total_cmp);
                quartiles(&noise)
            },
        }
    }
}

/// The quartiles of sorted, non-empty `values`.
fn quartiles(values: &[f32]) -> [f32; 3] {
    let n = values.len();
    [values[n / 4], values[n / 2], values[(3 * n) / 4]]
}

/// Where a new record goes (mirror of WGSL `RecordSite`, 48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RecordSite {
    pub position: [f32; 3],
    pub r_min: f32,
    /// Shading normal (the record's hemisphere).
    pub normal: [f32; 3],
    /// Scrambles the light samples of the plane's hits.
    pub seed: u32,
    /// Geometric normal (offsets ray origins).
    pub geometric_normal: [f32; 3],
    /// The instance the site lies on.
    pub instance: u32,
}

/// One traced plane pixel (mirror of WGSL `PlaneSample`, 16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct PlaneSample {
    pub radiance: [f32; 3],
    /// Hit depth along the record normal (`r cos(theta)`), negative on a miss.
    pub depth: f32,
}

/// Depth of the nearer of two plane samples (Ward's min rule for the edges of the
/// translational gradients); <= 0 when both are misses. WGSL: `nearer_depth`, records.wgsl.
pub(crate) fn nearer_depth(a: f32, b: f32) -> f32 {
    if a <= 0.0 {
        b
    } else if b <= 0.0 {
        a
    } else {
        a.min(b)
    }
}

/// The records of a scene, resident on the GPU, with room to grow (view-independent: a
/// new camera reuses them, thesis section 4.7.2). A cache holds records of one
/// [`RecordKind`]; radiance records keep their coefficients in `coefficients`, one block
/// per record at the record's index.
pub struct RecordCache {
    pub buffer: wgpu::Buffer,
    /// The kind's per-record blocks beside `buffer` ([`RecordKind::coefficient_floats`]
    /// f32 each); a 16-byte placeholder for irradiance records.
    pub coefficients: wgpu::Buffer,
    pub kind: RecordKind,
    /// Records in use (the first `count` of the buffer).
    pub count: u32,
    capacity: u32,
    /// Records gathered from VPLs under temporal instant caching keep one visibility bit
    /// per VPL slot (`visibility_words` u32 per record, at the record's index): which of
    /// their rays reached their VPL, so that a later frame traces again only the rays what
    /// moved may have changed. A 16-byte placeholder when `visibility_words` is 0.
    pub visibility: wgpu::Buffer,
    pub visibility_words: u32,
}

/// Bytes per record.
pub const RECORD_BYTES: u64 = std::mem::size_of::<Record>() as u64;

impl RecordCache {
    /// A view of the first `count` records (the same GPU buffer): what the cache held
    /// before later records were added.
    pub fn prefix(&self, count: u32) -> RecordCache {
        RecordCache {
            buffer: self.buffer.clone(),
            coefficients: self.coefficients.clone(),
            kind: self.kind,
            count: count.min(self.count),
            capacity: self.capacity,
            visibility: self.visibility.clone(),
            visibility_words: self.visibility_words,
        }
    }

    /// An empty cache of irradiance records.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Self::with_kind(ctx, RecordKind::Irradiance)
    }

    /// An empty cache of `kind` records.
    pub fn with_kind(ctx: &GpuContext, kind: RecordKind) -> Result<Self> {
        let capacity = 1024;
        Ok(Self {
            buffer: ctx.storage_buffer_sized("records", u64::from(capacity) * RECORD_BYTES)?,
            coefficients: ctx.storage_buffer_sized(
                "record coefficients",
                (u64::from(capacity) * kind.coefficient_bytes()).max(16),
            )?,
            kind,
            count: 0,
            capacity,
            visibility: ctx.storage_buffer_sized("record vpl visibility", 16)?,
            visibility_words: 0,
        })
    }

    /// An empty cache of irradiance records that keep a visibility bit per VPL slot
    /// (`slots` of them; temporal instant caching).
    pub fn with_vpl_visibility(ctx: &GpuContext, slots: u32) -> Result<Self> {
        let mut cache = Self::with_kind(ctx, RecordKind::Irradiance)?;
        cache.visibility_words = slots.div_ceil(32).max(1);
        cache.visibility = ctx.storage_buffer_sized(
            "record vpl visibility",
            u64::from(cache.capacity) * cache.visibility_bytes(),
        )?;
        Ok(cache)
    }

    /// Bytes of one record's visibility bits.
    fn visibility_bytes(&self) -> u64 {
        u64::from(self.visibility_words) * 4
    }

    /// Most records of this cache's kind one binding holds on `ctx`'s device.
    pub fn max_records(&self, ctx: &GpuContext) -> u64 {
        Self::max_records_of(ctx, self.kind)
            .min(ctx.max_binding_size() / self.visibility_bytes().max(1))
    }

    /// Most records of `kind` one binding holds on `ctx`'s device (the records or their
    /// coefficient blocks, whichever is larger per record).
    pub fn max_records_of(ctx: &GpuContext, kind: RecordKind) -> u64 {
        ctx.max_binding_size() / RECORD_BYTES.max(kind.coefficient_bytes())
    }

    /// Makes room for `extra` more records, growing the buffers (copying the records) or
    /// failing with a device-limit error naming the record count.
    pub fn reserve(&mut self, ctx: &GpuContext, extra: u32) -> Result<()> {
        let needed = u64::from(self.count) + u64::from(extra);
        if needed <= u64::from(self.capacity) {
            return Ok(());
        }
        let max_records = self.max_records(ctx);
        if needed > max_records {
            let per = RECORD_BYTES
                .max(self.kind.coefficient_bytes())
                .max(self.visibility_bytes());
            let hint = match self.kind {
                RecordKind::Irradiance => String::new(),
                RecordKind::Radiance { .. } => {
                    "; a lower --radiance-order or a larger --radiance-accuracy needs fewer bytes"
                        .into()
                }
            };
            return Err(Error::DeviceLimit(format!(
                "{needed} {} need {} MiB in one buffer; this device allows {} \
                 records ({} MiB per binding){hint}",
                self.kind.describe(),
                (needed * per).div_ceil(1 << 20),
                max_records,
                ctx.max_binding_size() >> 20
            )));
        }
        let capacity = (needed.max(u64::from(self.capacity) * 2)).min(max_records) as u32;
        let buffer = ctx.storage_buffer_sized("records", u64::from(capacity) * RECORD_BYTES)?;
        let block = self.kind.coefficient_bytes();
        let coefficients =
            ctx.storage_buffer_sized("record coefficients", (u64::from(capacity) * block).max(16))?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(
            &self.buffer,
            0,
            &buffer,
            0,
            u64::from(self.count) * RECORD_BYTES,
        );
        if block > 0 && self.count > 0 {
            enc.copy_buffer_to_buffer(
                &self.coefficients,
                0,
                &coefficients,
                0,
                u64::from(self.count) * block,
            );
        }
        let bits = self.visibility_bytes();
        if bits > 0 {
            let visibility =
                ctx.storage_buffer_sized("record vpl visibility", u64::from(capacity) * bits)?;
            if self.count > 0 {
                enc.copy_buffer_to_buffer(
                    &self.visibility,
                    0,
                    &visibility,
                    0,
                    u64::from(self.count) * bits,
                );
            }
            self.visibility = visibility;
        }
        ctx.queue.submit([enc.finish()]);
        self.buffer = buffer;
        self.coefficients = coefficients;
        self.capacity = capacity;
        Ok(())
    }

    /// Reads the visibility bits back (`visibility_words` per record; empty without).
    pub fn read_visibility(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        if self.visibility_words == 0 {
            return Ok(Vec::new());
        }
        let mut all: Vec<u32> = ctx.read_buffer(&self.visibility)?;
        all.truncate((self.count * self.visibility_words) as usize);
        Ok(all)
    }

    /// Replaces the contents with `records` and their visibility bits
    /// (`visibility_words` per record, in order).
    pub fn upload_with_visibility(
        &mut self,
        ctx: &GpuContext,
        records: &[Record],
        bits: &[u32],
    ) -> Result<()> {
        if bits.len() != records.len() * self.visibility_words as usize {
            return Err(Error::Usage(format!(
                "internal: {} visibility words for {} records",
                bits.len(),
                records.len()
            )));
        }
        self.upload(ctx, records)?;
        if !bits.is_empty() {
            ctx.queue
                .write_buffer(&self.visibility, 0, bytemuck::cast_slice(bits));
        }
        Ok(())
    }

    /// Reads the records back.
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<Record>> {
        if self.count == 0 {
            return Ok(Vec::new());
        }
        // The records alone, not the buffer's spare capacity.
        let bytes = u64::from(self.count) * RECORD_BYTES;
        let mut read = ctx.read_buffer_ranges::<Record>(&[(&self.buffer, 0..bytes)])?;
        let mut all = read.pop().unwrap_or_default();
        all.truncate(self.count as usize);
        Ok(all)
    }

    /// Reads the coefficient blocks back (`count x coefficient_floats` f32; empty for
    /// irradiance records).
    pub fn read_coefficients(&self, ctx: &GpuContext) -> Result<Vec<f32>> {
        if self.kind.coefficient_floats() == 0 {
            return Ok(Vec::new());
        }
        let mut all: Vec<f32> = ctx.read_buffer(&self.coefficients)?;
        all.truncate(self.count as usize * self.kind.coefficient_floats());
        Ok(all)
    }

    /// The byte range of records `first..first + count`, for
    /// [`GpuContext::read_buffer_ranges`].
    pub fn byte_range(first: u32, count: u32) -> std::ops::Range<u64> {
        u64::from(first) * RECORD_BYTES..u64::from(first + count) * RECORD_BYTES
    }

    /// Replaces the contents with `records` (tests, cache files); radiance records keep
    /// whatever coefficients their blocks held.
    pub fn upload(&mut self, ctx: &GpuContext, records: &[Record]) -> Result<()> {
        self.count = 0;
        self.reserve(ctx, records.len() as u32)?;
        ctx.queue
            .write_buffer(&self.buffer, 0, bytemuck::cast_slice(records));
        self.count = records.len() as u32;
        Ok(())
    }

    /// Replaces the contents with `records` and their coefficient blocks (`coefficients`:
    /// [`RecordKind::coefficient_floats`] per record, in order; empty for irradiance).
    pub fn upload_with_coefficients(
        &mut self,
        ctx: &GpuContext,
        records: &[Record],
        coefficients: &[f32],
    ) -> Result<()> {
        if coefficients.len() != records.len() * self.kind.coefficient_floats() {
            return Err(Error::Usage(format!(
                "internal: {} coefficients for {} {}",
                coefficients.len(),
                records.len(),
                self.kind.describe()
            )));
        }
        self.upload(ctx, records)?;
        if !coefficients.is_empty() {
            ctx.queue
                .write_buffer(&self.coefficients, 0, bytemuck::cast_slice(coefficients));
        }
        Ok(())
    }

    /// The byte range of the coefficient blocks of records `first..first + count`.
    pub fn coefficient_range(&self, first: u32, count: u32) -> std::ops::Range<u64> {
        let block = self.kind.coefficient_bytes();
        u64::from(first) * block..u64::from(first + count) * block
    }
}
