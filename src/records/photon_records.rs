//! Records from the photon map alone (`--records photons`): photon-mapped irradiance
//! caching, thesis chapter 6 (Brouillat's method; algorithms.md section 5).
//!
//! - **Placement (thesis Algorithm 6)**, on the CPU: the photon array is walked in slot
//!   order; a photon no record yet covers (Ward's weight `w >= 1/a` and the "behind" test,
//!   as for pixels: decision 2) gets a record. The walk is sequential by nature (each new
//!   record decides what the next photons see); it stays cheap because the photons are
//!   few against the pixels and a grid holds the records. Only photons inside the camera's
//!   frustum are walked: a record no pixel of the frame can see would never be splatted.
//! - **The record's neighbourhood (Algorithm 7 steps 1-3)**: the `gather` nearest photons
//!   on the record's surface ([`crate::photons::map`]) give the harmonic mean h of their
//!   stored distances, hence R (clamped to `[R_min, R_max]` as plane records are); the
//!   record's footprint `a R` is queried again and h recomputed over it. Fewer than
//!   `gather` there: no photon record (the pixels get plane records). The record
//!   is estimated over its footprint alone: taking the `gather` nearest where they reach
//!   farther (as this did before) made records out of photons metres away on sparse
//!   surfaces (Sponza's walls: 8-18 m for a footprint of 0.3-0.8 m) and left them 30 % dark.
//! - **The reduction (Algorithm 7 steps 4-5 and the gradients)**, on the GPU
//!   (`wgsl/photon_reduce.wgsl`; CPU mirror [`reference_record`]): `E = sum Phi / A` (thesis
//!   eq. 6.2) with A the area of the photons' convex hull in the tangent plane, corrected
//!   for the hull's shortfall ([`hull_correction`]), and by default less the part of the
//!   hull with no surface under it ([`PhotonArea::Probed`]: [`PROBES`] probe rays over the
//!   photons' disc; the hull alone counts the gaps between coplanar pieces, chairs and
//!   slats, and left the conference room 6 % dark); the flux binned per hemisphere cell
//!   (eq. 6.5) gives the cell radiance `L_jk = M N Phi_jk / (pi A)` (eq. 6.11 with Ward's
//!   equal-projected-area strata), and Ward and Heckbert's gradients follow from the
//!   `L_jk` and the cells' harmonic mean photon distances (algorithms.md 1.5); then Ward's
//!   gradient limit (decision 5) on the gradients alone: R stays what placement covered the
//!   photons with (shrinking it, as plane records do, left 380 of 1,360 records to hole
//!   filling on the Cornell box at 128x128, against 19 with R kept).
//! - **Holes**: pixels no photon record covers (too few photons nearby, or photons the
//!   walk skipped) get hemisphere-plane records from the usual placement afterwards.

use super::{CacheSettings, Record};
use crate::direct::reference::DirectReference;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::photons::map::{Neighbour, PhotonMap, SAME_SURFACE_COS, SAME_SURFACE_SLOPE};
use crate::photons::{Photon, PhotonArea};
use crate::sampling::orthonormal_basis;
use crate::visibility::GpuCamera;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3, IVec3, Vec2, Vec3};
use std::collections::HashMap;
use std::f64::consts::PI;

/// Altitude cells of the flux binning (strata of equal projected solid angle:
/// `sin^2 theta` in `[j/M, (j+1)/M)`).
pub const THETA_CELLS: u32 = 4;
/// Azimuth cells.
pub const PHI_CELLS: u32 = 8;
/// Fewest photons `--photon-gather` may ask for: the hull of fewer says little about the
/// area. A record is made from photons only where its footprint holds at least `gather`
/// of them (the pixels elsewhere get plane records).
pub const MIN_PHOTONS: usize = 8;
/// Most photons a record's reduction reads (its nearest).
pub const MAX_PHOTONS: usize = 1024;
/// Probe points of the probed area ([`PhotonArea::Probed`]), spread over the photons' disc.
pub const PROBES: u32 = 64;
/// Fewest probes inside the hull for its surface share to be measured; with fewer (a hull
/// much thinner than the disc: photons along a strip), the hull is taken as it is.
pub const MIN_PROBES_INSIDE: u32 = 8;

/// Probe point `i` of [`PROBES`] on the unit disc: a sunflower spiral (radius
/// `sqrt((i + 1/2) / PROBES)`, the golden angle apart), even over the disc with no seed.
/// WGSL: `probe_point`, photon_reduce.wgsl.
pub fn probe_point(i: u32) -> Vec2 {
    const GOLDEN_ANGLE: f32 = 2.399_963_2; // pi (3 - sqrt 5)
    let r = ((i as f32 + 0.5) / PROBES as f32).sqrt();
    let theta = i as f32 * GOLDEN_ANGLE;
    Vec2::new(r * theta.cos(), r * theta.sin())
}

/// The probe ray for the point `q` (tangent-plane offset from the record at `p` with
/// normal `n`, `frame` its basis, `rho` the photons' disc radius): from above the plane
/// down along -n, through the band the photons' slope bound admits (`|z| <= 0.25 |q|`),
/// plus a margin of 1e-3 rho (and of the coordinates' precision). Returns origin and tmax.
/// WGSL: the probe loop of photon_reduce.wgsl.
pub fn probe_ray(p: Vec3, frame: glam::Mat3, q: Vec2, rho: f32) -> (Vec3, f32) {
    let margin = (1e-3 * rho).max(1e-5 * p.abs().max_element());
    let h = SAME_SURFACE_SLOPE * q.length() + margin;
    (p + frame * Vec3::new(q.x, q.y, h), 2.0 * h)
}

/// Where a photon record goes and the photons it is made from (mirror of WGSL
/// `PhotonSite`, 48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct PhotonSite {
    /// The photon it was placed at.
    pub position: [f32; 3],
    /// R: the photons' harmonic mean distance clamped to `[r_min, r_max]` (Ward's
    /// gradient limit may shrink it further in the reduction).
    pub radius: f32,
    pub normal: [f32; 3],
    pub r_min: f32,
    /// Its photons: `list[first..first + count]` (photon slots).
    pub first: u32,
    pub count: u32,
    pub _pad: [u32; 2],
}

/// The records Algorithm 6 places for a frame.
#[derive(Clone, Debug, Default)]
pub struct PhotonPlacement {
    pub sites: Vec<PhotonSite>,
    /// The photons of every site, by slot.
    pub list: Vec<u32>,
    /// Photons walked (those inside the frustum).
    pub walked: u32,
    /// Photons that needed a record but had fewer than `gather` photons in its footprint.
    pub too_sparse: u32,
}

/// `sin^2` of the altitude boundary `theta_{j-}` of cell j (and `theta_{j+}` of j - 1).
fn sin2_boundary(j: u32) -> f64 {
    f64::from(j) / f64::from(THETA_CELLS)
}

/// The shortfall of a convex hull: for n points uniform in a disc, the mean hull area is
/// `1 - c(n) n^(-2/3)` of the disc's (the Renyi-Sulanke rate; c measured by Monte Carlo,
/// 10,000 trials below 64 points and 2,500 above). The table is (n, c(n)).
const HULL_SHORTFALL: [(f32, f32); 17] = [
    (3.0, 1.926),
    (4.0, 2.151),
    (6.0, 2.426),
    (8.0, 2.575),
    (12.0, 2.779),
    (16.0, 2.887),
    (24.0, 3.019),
    (32.0, 3.074),
    (48.0, 3.156),
    (64.0, 3.200),
    (96.0, 3.240),
    (128.0, 3.257),
    (192.0, 3.297),
    (256.0, 3.311),
    (384.0, 3.337),
    (512.0, 3.348),
    (1024.0, 3.369),
];

/// The factor the hull area of `n` photons is divided by: the mean share of the covered
/// disc that the hull of n uniform points spans (c(n) interpolated linearly in log n).
/// WGSL: `hull_correction`, photon_reduce.wgsl.
pub fn hull_correction(n: u32) -> f32 {
    let n = n.max(3) as f32;
    let last = HULL_SHORTFALL.len() - 1;
    let c = if n >= HULL_SHORTFALL[last].0 {
        HULL_SHORTFALL[last].1
    } else {
        let mut c = HULL_SHORTFALL[0].1;
        for i in 0..last {
            let (n0, c0) = HULL_SHORTFALL[i];
            let (n1, c1) = HULL_SHORTFALL[i + 1];
            if n >= n0 && n <= n1 {
                let t = (n / n0).ln() / (n1 / n0).ln();
                c = c0 + t * (c1 - c0);
                break;
            }
        }
        c
    };
    1.0 - c * n.powf(-2.0 / 3.0)
}

/// Area of the convex hull of `points` (Andrew's monotone chain); 0 for fewer than 3.
pub fn convex_hull_area(points: &[DVec2]) -> f64 {
    let hull = convex_hull(points);
    let mut area = 0.0;
    for i in 0..hull.len() {
        area += hull[i].perp_dot(hull[(i + 1) % hull.len()]);
    }
    0.5 * area.abs()
}

/// Whether `q` lies in the convex polygon `hull` (counter-clockwise), its edges included.
fn inside_hull(hull: &[DVec2], q: DVec2) -> bool {
    hull.len() >= 3
        && (0..hull.len()).all(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            (b - a).perp_dot(q - a) >= 0.0
        })
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain); empty for
/// fewer than 3.
fn convex_hull(points: &[DVec2]) -> Vec<DVec2> {
    if points.len() < 3 {
        return Vec::new();
    }
    let mut pts = points.to_vec();
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// Harmonic mean of the photons' stored distances (Algorithm 7 step 1).
fn harmonic_mean(photons: &[Photon], near: &[Neighbour]) -> f32 {
    let inv: f64 = near
        .iter()
        .map(|n| 1.0 / f64::from(photons[n.slot as usize].distance.max(1e-12)))
        .sum();
    if inv > 0.0 {
        (near.len() as f64 / inv) as f32
    } else {
        f32::INFINITY
    }
}

/// The records a grid of cells holds, for Algorithm 6's coverage queries.
struct RecordGrid {
    cell: f32,
    cells: HashMap<IVec3, Vec<u32>>,
}

impl RecordGrid {
    fn insert(&mut self, index: u32, centre: Vec3, reach: f32) {
        let lo = ((centre - Vec3::splat(reach)) / self.cell)
            .floor()
            .as_ivec3();
        let hi = ((centre + Vec3::splat(reach)) / self.cell)
            .floor()
            .as_ivec3();
        for x in lo.x..=hi.x {
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    self.cells
                        .entry(IVec3::new(x, y, z))
                        .or_default()
                        .push(index);
                }
            }
        }
    }

    fn at(&self, p: Vec3) -> &[u32] {
        self.cells
            .get(&(p / self.cell).floor().as_ivec3())
            .map(Vec::as_slice)
            .unwrap_or(&[])
    }
}

/// The camera's view of a point: whether it lies in the frustum (with a small margin) and
/// the world size of a pixel there.
fn pixel_footprint(camera: &GpuCamera, p: Vec3) -> Option<f32> {
    let d = p - Vec3::from(camera.origin);
    let forward = Vec3::from(camera.forward);
    let (right, up) = (Vec3::from(camera.right), Vec3::from(camera.up));
    let z = d.dot(forward);
    if z <= 0.0 {
        return None;
    }
    let x = d.dot(right) / right.length_squared() / z;
    let y = d.dot(up) / up.length_squared() / z;
    if x.abs() > 1.05 || y.abs() > 1.05 {
        return None;
    }
    // As record_sites.wgsl: 2 |up| t / height, t the distance along the unit camera ray.
    Some(2.0 * up.length() * d.length() / camera.height as f32)
}

/// Algorithm 6 with Algorithm 7's neighbourhoods: walks `map`'s photons in slot order and
/// places a record at each one inside `camera`'s frustum that no record covers yet.
/// `r_min_world`: the world-space bound on R_min (`r_min_scene` x the scene diagonal).
pub fn place(
    map: &PhotonMap,
    camera: &GpuCamera,
    settings: &CacheSettings,
    r_min_world: f32,
) -> PhotonPlacement {
    let a = settings.accuracy;
    let gather = settings.photons.gather as usize;
    let photons = &map.photons;
    let mut out = PhotonPlacement::default();
    let mut records: Vec<Record> = Vec::new();
    let mut grid = RecordGrid {
        cell: map.cell().max(1e-6) * 2.0,
        cells: HashMap::new(),
    };
    for ph in photons {
        if ph.is_empty() {
            continue;
        }
        let (p, n) = (ph.position(), ph.normal());
        let Some(footprint) = pixel_footprint(camera, p) else {
            continue;
        };
        out.walked += 1;
        let covered = grid
            .at(p)
            .iter()
            .any(|&k| records[k as usize].reaches(p, n, a));
        if covered {
            continue;
        }
        let r_min = (settings.r_min_pixels * footprint / a).max(r_min_world);
        let r_max = r_min * settings.r_max_factor;
        // A photon record only where its footprint holds `gather` photons: with fewer its
        // density estimate is noisier than a plane record (Sponza 160x160, two bounces:
        // 20.7 % at 8, 9.0 % at 32, 7.5 % at 64; docs/results.md).
        let needed = gather.max(MIN_PHOTONS);
        let near = map.nearest(p, n, gather, a * r_max);
        if near.len() < needed {
            out.too_sparse += 1;
            continue;
        }
        let h = harmonic_mean(photons, &near);
        let radius = h.clamp(r_min, r_max);
        let set = map.within(p, n, a * radius, MAX_PHOTONS);
        if set.len() < needed {
            out.too_sparse += 1;
            continue;
        }
        let radius = harmonic_mean(photons, &set).clamp(r_min, r_max);
        let site = PhotonSite {
            position: ph.position,
            radius,
            normal: ph.normal,
            r_min,
            first: out.list.len() as u32,
            count: set.len() as u32,
            _pad: [0; 2],
        };
        out.list.extend(set.iter().map(|f| f.slot));
        let index = records.len() as u32;
        records.push(Record {
            position: ph.position,
            radius,
            normal: ph.normal,
            r_min,
            ..Default::default()
        });
        grid.insert(index, p, a * radius);
        out.sites.push(site);
    }
    out
}

/// A photon's cell: altitude j (from `sin^2 theta`) and azimuth k, for a unit direction in
/// the record's frame with z > 0. WGSL: `photon_cell`.
pub fn photon_cell(local: Vec3) -> (u32, u32) {
    let m = THETA_CELLS as f32;
    let n = PHI_CELLS as f32;
    let sin2 = (1.0 - local.z * local.z).max(0.0);
    let j = ((sin2 * m) as u32).min(THETA_CELLS - 1);
    let mut phi = local.y.atan2(local.x);
    if phi < 0.0 {
        phi += 2.0 * std::f32::consts::PI;
    }
    let k = ((phi / (2.0 * std::f32::consts::PI) * n) as u32).min(PHI_CELLS - 1);
    (j, k)
}

/// The share of the hull's probes ([`probe_point`] over the disc of radius `rho`) that find
/// the record's surface under them ([`PhotonArea::Probed`]): 1 when fewer than
/// [`MIN_PROBES_INSIDE`] fall inside the hull, at least one probe's worth otherwise (the
/// record's own point is on the surface). `scene` traces the probes on the CPU.
fn probed_share(scene: &DirectReference, site: &PhotonSite, hull: &[DVec2], rho: f32) -> f64 {
    let n = Vec3::from(site.normal);
    let frame = orthonormal_basis(n);
    let p = Vec3::from(site.position);
    let (mut inside, mut found) = (0u32, 0u32);
    for i in 0..PROBES {
        let q = probe_point(i) * rho;
        if !inside_hull(hull, DVec2::new(f64::from(q.x), f64::from(q.y))) {
            continue;
        }
        inside += 1;
        let (origin, tmax) = probe_ray(p, frame, q, rho);
        if let Some(hit) = scene.tracer.closest_hit(origin, -n, 0.0, tmax) {
            let s = scene.surface_at(&hit, -n);
            found += u32::from(s.shading_normal.dot(n) >= SAME_SURFACE_COS);
        }
    }
    if inside < MIN_PROBES_INSIDE {
        1.0
    } else {
        f64::from(found.max(1)) / f64::from(inside)
    }
}

/// Algorithm 7's reduction of `site`'s photons (`list[first..first + count]` of
/// `photons`) into a record, in f64: the CPU mirror of `photon_reduce.wgsl`. `scene`
/// traces the area probes of [`PhotonArea::Probed`].
pub fn reference_record(
    site: &PhotonSite,
    photons: &[Photon],
    list: &[u32],
    settings: &CacheSettings,
    scene: &DirectReference,
) -> Record {
    let (mc, nc) = (THETA_CELLS as usize, PHI_CELLS as usize);
    let n = Vec3::from(site.normal);
    let frame = orthonormal_basis(n);
    let frame_t = frame.transpose();
    let p = Vec3::from(site.position);
    let mut flux = DVec3::ZERO;
    let mut cell_flux = vec![DVec3::ZERO; mc * nc];
    let mut cell_inv = vec![0.0f64; mc * nc];
    let mut cell_count = vec![0u32; mc * nc];
    let mut points = Vec::new();
    let mut rho = 0.0f32;
    let slots = &list[site.first as usize..(site.first + site.count) as usize];
    for &slot in slots {
        let ph = &photons[slot as usize];
        let local = frame_t * ph.direction();
        if local.z <= 0.0 {
            continue;
        }
        let q = frame_t * (ph.position() - p);
        points.push(DVec2::new(f64::from(q.x), f64::from(q.y)));
        rho = rho.max((q.x * q.x + q.y * q.y).sqrt());
        let phi = ph.flux().as_dvec3();
        flux += phi;
        let (j, k) = photon_cell(local);
        let c = j as usize * nc + k as usize;
        cell_flux[c] += phi;
        cell_inv[c] += 1.0 / f64::from(ph.distance.max(1e-12));
        cell_count[c] += 1;
    }
    let hull = convex_hull(&points);
    let mut area = convex_hull_area(&hull) / f64::from(hull_correction(points.len() as u32));
    if settings.photons.area == PhotonArea::Probed && area > 0.0 {
        area *= probed_share(scene, site, &hull, rho);
    }
    let mut record = Record {
        position: site.position,
        radius: site.radius,
        normal: site.normal,
        r_min: site.r_min,
        ..Default::default()
    };
    if area.is_nan() || area <= 0.0 {
        return record;
    }
    let e = flux / area; // thesis eq. 6.2
    record.irradiance = [e.x as f32, e.y as f32, e.z as f32];
    if !settings.gradients {
        return record;
    }
    // Cell radiance (eq. 6.11): L = 2 Phi / (A (cos^2 - cos^2)(phi+ - phi-)) = M N Phi / (pi A).
    let scale = (mc * nc) as f64 / (PI * area);
    let l = |j: usize, k: usize| cell_flux[j * nc + k] * scale;
    let h = f64::from(site.radius);
    let r = |j: usize, k: usize| {
        let c = j * nc + k;
        if cell_count[c] > 0 {
            f64::from(cell_count[c]) / cell_inv[c]
        } else {
            h
        }
    };
    let mut rot = [DVec3::ZERO; 3];
    let mut tr = [DVec3::ZERO; 3];
    for k in 0..nc {
        let phi_c = 2.0 * PI * (k as f64 + 0.5) / nc as f64;
        let phi_lo = 2.0 * PI * k as f64 / nc as f64;
        let w_k = DVec3::new(-phi_c.sin(), phi_c.cos(), 0.0);
        let u_k = DVec3::new(phi_c.cos(), phi_c.sin(), 0.0);
        let v_lo = DVec3::new(-phi_lo.sin(), phi_lo.cos(), 0.0);
        let k_prev = (k + nc - 1) % nc;
        for j in 0..mc {
            // Rotational (algorithms.md 1.5): (pi / MN) sum_k w_k sum_j tan(theta_j) L_jk.
            let sin2_c = (j as f64 + 0.5) / mc as f64;
            let tan_c = (sin2_c / (1.0 - sin2_c)).sqrt();
            let lj = l(j, k);
            for c in 0..3 {
                rot[c] += w_k * (PI / (mc * nc) as f64 * tan_c * lj[c]);
            }
            let sin_lo = sin2_boundary(j as u32).sqrt();
            let sin_hi = sin2_boundary(j as u32 + 1).sqrt();
            // Translational, azimuthal edge between cells k-1 and k.
            let dk = lj - l(j, k_prev);
            let rk = r(j, k).min(r(j, k_prev));
            for c in 0..3 {
                tr[c] += v_lo * ((sin_hi - sin_lo) / rk * dk[c]);
            }
            // Translational, altitude edge between cells j-1 and j.
            if j > 0 {
                let cos2_lo = 1.0 - sin2_boundary(j as u32);
                let dj = lj - l(j - 1, k);
                let rj = r(j, k).min(r(j - 1, k));
                for c in 0..3 {
                    tr[c] += u_k * (2.0 * PI / nc as f64 * sin_lo * cos2_lo / rj * dj[c]);
                }
            }
        }
    }
    let frame = frame.as_dmat3();
    let e_arr = [e.x, e.y, e.z];
    for c in 0..3 {
        rot[c] = frame * rot[c];
        tr[c] = frame * tr[c];
    }
    // Ward's gradient limit on the gradients alone (R stays: placement covered the
    // photons with it; a smaller R would leave holes): |grad_t| R <= E per channel.
    let radius = f64::from(site.radius);
    for c in 0..3 {
        let g = tr[c].length();
        if g * radius > e_arr[c] {
            tr[c] *= e_arr[c] / (g * radius);
        }
    }
    let v4 = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
    record.rotation_gradient = [v4(rot[0]), v4(rot[1]), v4(rot[2])];
    record.translation_gradient = [v4(tr[0]), v4(tr[1]), v4(tr[2])];
    record
}

/// Mirror of WGSL `PhotonReduceParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ReduceParams {
    count: u32,
    first_record: u32,
    gradients: u32,
    area: u32,
}

/// The GPU reduction of photon sites into records (`photon_reduce.wgsl`).
pub struct PhotonReducePass {
    reduce: std::sync::Arc<ComputePass>,
}

impl PhotonReducePass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            reduce: ComputePass::new(
                ctx,
                "photon_reduce.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                ],
            )?,
        })
    }

    /// Reduces the sites of `placement` over `photons` (uploaded here) into records
    /// written at `first_record..` of `records` (which must have room). Timed as
    /// "photon records".
    #[allow(clippy::too_many_arguments)]
    pub fn reduce(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        photons: &wgpu::Buffer,
        placement: &PhotonPlacement,
        records: &wgpu::Buffer,
        first_record: u32,
        settings: &CacheSettings,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<()> {
        let count = placement.sites.len() as u32;
        if count == 0 {
            return Ok(());
        }
        let list_bytes = (placement.list.len() as u64) * 4;
        if list_bytes > ctx.max_binding_size() {
            return Err(Error::DeviceLimit(format!(
                "the photon lists of {count} photon records need {} MiB in one buffer; this \
                 device allows {} MiB per binding: use a larger --accuracy or fewer \
                 --photon-paths",
                list_bytes.div_ceil(1 << 20),
                ctx.max_binding_size() >> 20
            )));
        }
        let params = ctx.uniform_buffer(
            "photon reduce params",
            &ReduceParams {
                count,
                first_record,
                gradients: u32::from(settings.gradients),
                area: u32::from(settings.photons.area == PhotonArea::Probed),
            },
        );
        let sites = ctx.storage_buffer("photon sites", &placement.sites)?;
        let list = if placement.list.is_empty() {
            ctx.storage_buffer("photon lists", &[0u32])?
        } else {
            ctx.storage_buffer("photon lists", &placement.list)?
        };
        let bind = self
            .reduce
            .bind(ctx, &[&params, &sites, &list, photons, records]);
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.reduce.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            [count.div_ceil(64), 1, 1],
            timer.next("photon records"),
        );
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(())
    }
}
