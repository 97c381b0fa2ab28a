//! Plain-Rust reference of the E(t+1) reprojection (`plane_reproject.wgsl`,
//! `plane_fill.wgsl`): the plane traced at t on the CPU, every hit rebuilt and re-shaded
//! in the scene at t+1, projected onto the record's plane with the same (depth bits,
//! sample index) keys, and holes filled from the deepest neighbour (holes wider than
//! that keep the sample traced at t). With an estimate stride, only the subset of samples
//! [`super::reprojection::subset_pixel`] picks is moved, onto a plane of P/stride cells.

use super::motion::InstanceMotion;
use super::reprojection::subset_pixel;
use crate::direct::reference::{DirectReference, offset_ray_origin};
use crate::records::reference::RecordReference;
use crate::records::{PlaneMode, PlaneSample, PlaneSpacing, RecordSite};
use crate::sampling::{plane_light_first, record_frame};
use glam::{Mat4, Vec3};
use std::f32::consts::PI;

const INDEX_MASK: u32 = 0x3fff;
const MISS_DEPTH: f32 = 3.0e38;

fn key(depth: f32, sample: u32) -> u32 {
    (depth.to_bits() & !INDEX_MASK) | sample
}

/// The plane of `site` traced in the scene of `at_t` and estimated at t+1 in the scene of
/// `next` (same meshes and instance order, moved instances and lights). With
/// `anchored_motion` (the instances' motions from t to t+1), the record moves with its
/// site's instance ([`super::RecordAnchor::Instance`]). Every hit is re-shaded: the GPU
/// pass's reuse of the radiance traced at t must agree with this. Returns the estimated
/// plane and the samples at t it was moved from, `(P / stride)^2` each.
pub fn reproject_plane(
    at_t: &RecordReference,
    next: &DirectReference,
    site: &RecordSite,
    anchored_motion: Option<&[InstanceMotion]>,
    stride: u32,
) -> (Vec<PlaneSample>, Vec<PlaneSample>) {
    let plane = &at_t.plane;
    let fine = plane.resolution as usize;
    let res = fine / stride as usize;
    let subset = |c: usize| -> usize {
        let pick = |i: usize| subset_pixel(i as u32, stride, res as u32) as usize;
        pick(c / res) * fine + pick(c % res)
    };
    let half = super::reprojection::estimate_half_extent(&at_t.settings);
    let cosine = at_t.settings.plane_spacing == PlaneSpacing::Cosine;
    let stretched = at_t.settings.plane_mode == PlaneMode::Stretched;
    let n = Vec3::from(site.normal);
    let ng = Vec3::from(site.geometric_normal);
    let frame = record_frame(n, site.seed);
    let origin = offset_ray_origin(site.position.into(), ng);
    // The cell of a direction with tangent-frame components a (one axis) and z > 0: even
    // in x = a / z, or in sin(atan x) for cosine spacing (`plane_index`, same f32 steps).
    let index = |a: f32, z: f32| -> Option<usize> {
        let u = if cosine {
            a / (a * a + z * z).sqrt()
        } else {
            a / z
        };
        let i = ((u + half) / (2.0 * half) * res as f32).floor() as i64;
        if stretched {
            Some(i.clamp(0, res as i64 - 1) as usize)
        } else if (0..res as i64).contains(&i) {
            Some(i as usize)
        } else {
            None
        }
    };
    let mut cells = vec![u32::MAX; res * res];
    let mut moved = vec![PlaneSample::default(); fine * fine];
    for own in 0..res * res {
        let k = subset(own);
        let px = &plane.pixels[k];
        let dir = (frame * Vec3::new(px.center[0], px.center[1], 1.0)).normalize();
        let hit = if dir.dot(ng) > 0.0 {
            at_t.shading
                .tracer
                .closest_hit(origin, dir, 0.0, f32::INFINITY)
        } else {
            None
        };
        let Some(hit) = hit else {
            cells[own] = cells[own].min(key(MISS_DEPTH, k as u32));
            moved[k] = PlaneSample {
                radiance: [0.0; 3],
                depth: -1.0,
            };
            continue;
        };
        let probe = next.surface_at(&hit, n);
        let mut to_point = probe.position - origin;
        let mut view = to_point;
        if let Some(m) = anchored_motion.and_then(|m| m.get(site.instance as usize)) {
            if m.moves != 0 {
                let to_next = Mat4::from_cols_array_2d(&m.to_next);
                let from_next = Mat4::from_cols_array_2d(&m.from_next);
                view = probe.position - to_next.transform_point3(origin);
                to_point = from_next.transform_point3(probe.position) - origin;
            }
        }
        let s = next.surface_at(&hit, view.normalize());
        let e = next.plane_direct_irradiance_at(
            &s,
            site.seed,
            plane_light_first(k as u32, next.light_samples),
            at_t.settings.plane_light_choices,
        );
        let m = &next.scene.materials[s.material as usize];
        let emission = if s.front_face && !m.sampled_light {
            m.emission
        } else {
            Vec3::ZERO
        };
        let radiance = next.albedo(&s) / PI * e + emission;
        let local = Vec3::new(
            to_point.dot(frame.col(0)),
            to_point.dot(frame.col(1)),
            to_point.dot(frame.col(2)),
        );
        moved[k] = PlaneSample {
            radiance: radiance.into(),
            depth: local.z,
        };
        if local.z <= 0.0 {
            continue;
        }
        if let (Some(ix), Some(iy)) = (index(local.x, local.z), index(local.y, local.z)) {
            let c = iy * res + ix;
            cells[c] = cells[c].min(key(local.z, k as u32));
        }
    }
    let sample_of = |key: u32| moved[(key & INDEX_MASK) as usize];
    let traced = at_t.trace_plane(site);
    let estimate = (0..res * res)
        .map(|c| {
            if cells[c] != u32::MAX {
                return sample_of(cells[c]);
            }
            let (x, y) = ((c % res) as i64, (c / res) as i64);
            let mut best: Option<u32> = None;
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let (nx, ny) = (x + dx, y + dy);
                    if (dx == 0 && dy == 0)
                        || nx < 0
                        || ny < 0
                        || nx >= res as i64
                        || ny >= res as i64
                    {
                        continue;
                    }
                    let k = cells[(ny as usize) * res + nx as usize];
                    if k != u32::MAX && best.is_none_or(|b| k > b) {
                        best = Some(k);
                    }
                }
            }
            best.map_or(traced[subset(c)], sample_of)
        })
        .collect();
    (
        estimate,
        (0..res * res).map(|c| traced[subset(c)]).collect(),
    )
}
