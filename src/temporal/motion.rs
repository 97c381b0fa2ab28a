//! How instances move from one frame to the next, and records that move with them.
//!
//! The thesis keeps every record at its world position (seed 000 Fig. 5, decision 9): a
//! record on a moving object stays in the air where the object was, and the object's new
//! surface needs new records every frame. [`RecordAnchor::Instance`] instead carries a
//! record rigidly with the instance it lies on (its position, normal and gradients move
//! with the instance's transform); its reprojected plane (E(t+1)) is then seen from where
//! the record will be at t+1. Records on instances that do not move are unaffected.

use crate::records::{Record, RecordSite};
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Mat4, Vec3};

/// Where temporal records stay while the scene moves (CLI `--record-anchor`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum RecordAnchor {
    /// At their world position, as in the thesis (decision 9). Records on a moving object
    /// are left behind, and a replacement at their place may lie inside it (cube in a box,
    /// 48x48, dt_max 1: 68 pixels of zero indirect light from such records).
    World,
    /// On the instance they lie on: records move rigidly with it. The default (cube in a
    /// box 48x48, frames 0..23: indirect error 4.9-6.9 % against 5-12 % world-anchored).
    Instance,
}

/// How one instance moves from frame t to t+1 (mirror of WGSL `InstanceMotion` in
/// `shared/reprojection.wgsl`, 144 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct InstanceMotion {
    /// World at t to world at t+1 for points on the instance (column-major).
    pub to_next: [[f32; 4]; 4],
    /// Its inverse.
    pub from_next: [[f32; 4]; 4],
    /// 1 when the instance moves between t and t+1, else 0.
    pub moves: u32,
    pub _pad: [u32; 3],
}

/// The motion of every instance of `now` (the scene at t) to `next` (the same scene at
/// t+1), in instance order.
pub fn instance_motions(now: &Scene, next: &Scene) -> Vec<InstanceMotion> {
    now.instances
        .iter()
        .zip(&next.instances)
        .map(|(a, b)| {
            let moves = a.transform != b.transform;
            let to_next = if moves {
                b.transform * a.transform.inverse()
            } else {
                Mat4::IDENTITY
            };
            InstanceMotion {
                to_next: to_next.to_cols_array_2d(),
                from_next: to_next.inverse().to_cols_array_2d(),
                moves: u32::from(moves),
                _pad: [0; 3],
            }
        })
        .collect()
}

/// An instance that moves over a span of frames, as its box in its own space and the
/// world-to-instance transforms at the span's first and last frames (mirror of WGSL
/// `MovingBounds` in `shared/movers.wgsl`, 160 bytes). A ray meets the instance at either
/// end only if it meets this box at that end: the test follows the instance's rotation
/// instead of boxing both ends in one world box (which only serves as a quick reject).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct MovingBounds {
    /// World box around the instance box at both ends.
    pub world_lo: [f32; 4],
    pub world_hi: [f32; 4],
    /// The instance's mesh box in its own space, slightly enlarged.
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    /// Rows of the affine world-to-instance transform at the span's first frame, then at
    /// its last.
    pub to_instance: [[[f32; 4]; 3]; 2],
}

impl MovingBounds {
    /// The world box around every box of `movers` (lo, hi; w = 0): a shadow pyramid that
    /// misses it misses each of them. Empty (lo > hi) when there are none.
    pub fn union(movers: &[MovingBounds]) -> ([f32; 4], [f32; 4]) {
        let mut lo = [f32::INFINITY, f32::INFINITY, f32::INFINITY, 0.0];
        let mut hi = [f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY, 0.0];
        for m in movers {
            for c in 0..3 {
                lo[c] = lo[c].min(m.world_lo[c]);
                hi[c] = hi[c].max(m.world_hi[c]);
            }
        }
        (lo, hi)
    }

    /// The mesh box `lo..hi` (instance space) of an instance whose transforms are `start`
    /// and `end` at the span's two ends. The box is enlarged by a relative margin so that
    /// rounding in the world-to-instance transform cannot make the test miss a ray the
    /// trace would find; a transform with no finite inverse gives a box every ray meets.
    pub fn new(lo: Vec3, hi: Vec3, start: &Mat4, end: &Mat4) -> Self {
        let rows = |m: &Mat4| {
            let inv = m.inverse();
            let t = inv.transpose();
            [
                t.x_axis.to_array(),
                t.y_axis.to_array(),
                t.z_axis.to_array(),
            ]
        };
        let (a, b) = (rows(start), rows(end));
        let finite = |r: &[[f32; 4]; 3]| r.iter().flatten().all(|v| v.is_finite());
        if !(finite(&a) && finite(&b)) {
            let identity = [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ];
            return Self {
                world_lo: [-1e30, -1e30, -1e30, 0.0],
                world_hi: [1e30, 1e30, 1e30, 0.0],
                lo: [-1e30, -1e30, -1e30, 0.0],
                hi: [1e30, 1e30, 1e30, 0.0],
                to_instance: [identity; 2],
            };
        }
        let margin = 1e-3 * (hi - lo).max_element().max(1e-3);
        let (lo, hi) = (lo - margin, hi + margin);
        let (mut wlo, mut whi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for m in [start, end] {
            for c in 0..8 {
                let corner = Vec3::new(
                    if c & 1 == 0 { lo.x } else { hi.x },
                    if c & 2 == 0 { lo.y } else { hi.y },
                    if c & 4 == 0 { lo.z } else { hi.z },
                );
                let w = m.transform_point3(corner);
                wlo = wlo.min(w);
                whi = whi.max(w);
            }
        }
        // The corners went through the forward transform, the rays go through its
        // inverse: a second margin keeps the world box around the instance box.
        let world_margin = 1e-3 * (whi - wlo).max_element().max(1e-3);
        Self {
            world_lo: (wlo - world_margin).extend(0.0).into(),
            world_hi: (whi + world_margin).extend(0.0).into(),
            lo: lo.extend(0.0).into(),
            hi: hi.extend(0.0).into(),
            to_instance: [a, b],
        }
    }
}

/// Whether the lights (and the environment) are the same at both frames.
pub fn lights_unchanged(now: &Scene, next: &Scene) -> bool {
    now.lights == next.lights && now.environment == next.environment
}

fn rgb(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

fn rgb0(v: Vec3) -> [f32; 4] {
    [v.x, v.y, v.z, 0.0]
}

/// `site` carried by the affine map `m` as [`move_record`] carries a record: position and
/// both normals move with it (normals by its rotation); the seed and instance stay.
pub fn move_site(site: &RecordSite, m: &Mat4) -> RecordSite {
    let turn = |n: [f32; 3]| {
        (Mat3::from_mat4(*m) * Vec3::from(n))
            .normalize_or_zero()
            .into()
    };
    if *m == Mat4::IDENTITY {
        return *site;
    }
    RecordSite {
        position: m.transform_point3(site.position.into()).into(),
        normal: turn(site.normal),
        geometric_normal: turn(site.geometric_normal),
        ..*site
    }
}

/// The site the replacement of `record` is computed at: the site its plane was traced
/// from (`stored`, when kept), carried by `motion` (the record's motion since its birth
/// with its instance; None: it stays). Position and both normals move with it: the
/// geometric normal is not the shading normal on smooth meshes, and plane rays are cut
/// and offset by it (shared/plane.wgsl), so a site given the shading normal for both
/// traces rays between the two planes into its own surface (glossy Spheres: radiance
/// records with translational gradients 60x their usual, docs/results.md, stop 43).
/// Without a stored site the record's own position and normal stand for both normals,
/// with `new_seed`.
pub fn replacement_site(
    stored: Option<RecordSite>,
    record: &Record,
    motion: Option<&Mat4>,
    new_seed: u32,
) -> RecordSite {
    match (stored, motion) {
        (Some(site), None) => site,
        (Some(site), Some(m)) => RecordSite {
            r_min: move_record(record, m).r_min,
            ..move_site(&site, m)
        },
        (None, m) => {
            let r = m.map_or(*record, |m| move_record(record, m));
            RecordSite {
                position: r.position,
                r_min: r.r_min,
                normal: r.normal,
                seed: new_seed,
                geometric_normal: r.normal,
                instance: r.instance,
            }
        }
    }
}

/// `record` carried by the affine map `m` (a rigid motion, possibly with uniform scale):
/// position and normal move with it; the rotational gradient turns with its rotation
/// (`(n_k x n).grad_r` is invariant under a rotation of all three); the translational
/// gradient, a covector (`grad_t . dp`), maps by the inverse transpose; R and R_min scale
/// with it. Irradiance is unchanged. The identity returns `record` bit for bit. A moved
/// record loses its corral ([`Record::corral`]): its sectors are counted from Duff's basis
/// around the normal, which a rotation does not carry along.
pub fn move_record(record: &Record, m: &Mat4) -> Record {
    if *m == Mat4::IDENTITY {
        return *record;
    }
    let linear = Mat3::from_mat4(*m);
    let scale = linear.determinant().abs().cbrt().max(f32::MIN_POSITIVE);
    let rotation = linear * (1.0 / scale);
    let covector = linear.inverse().transpose();
    let mut r = *record;
    r.position = m.transform_point3(record.position.into()).into();
    r.normal = (rotation * Vec3::from(record.normal))
        .normalize_or_zero()
        .into();
    r.radius = record.radius * scale;
    r.r_min = record.r_min * scale;
    for c in 0..3 {
        r.rotation_gradient[c] = rgb0(rotation * rgb(record.rotation_gradient[c]));
        r.translation_gradient[c] = rgb0(covector * rgb(record.translation_gradient[c]));
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    /// A record on a smooth mesh (its shading normal tilted from the facet's) that moved
    /// with its instance is replaced at its site carried along: the geometric normal turns
    /// with the instance and stays the facet's, not the shading normal (which let plane
    /// rays into the record's own surface); R_min scales with the instance.
    #[test]
    fn a_moved_replacement_keeps_its_sites_geometric_normal() {
        let shading = Vec3::new(0.3, 0.0, 1.0).normalize();
        let site = RecordSite {
            position: [1.0, 2.0, 3.0],
            r_min: 0.01,
            normal: shading.into(),
            seed: 77,
            geometric_normal: [0.0, 0.0, 1.0],
            instance: 4,
        };
        let record = Record {
            position: site.position,
            radius: 0.2,
            normal: site.normal,
            r_min: site.r_min,
            instance: 4,
            ..Record::default()
        };
        let motion = Mat4::from_scale_rotation_translation(
            Vec3::splat(2.0),
            Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
            Vec3::new(0.5, 0.0, -1.0),
        );
        let moved = replacement_site(Some(site), &record, Some(&motion), 5);
        let turned = |n: Vec3| Quat::from_rotation_x(std::f32::consts::FRAC_PI_2) * n;
        let close = |a: [f32; 3], b: Vec3| (Vec3::from(a) - b).length() < 1e-6;
        assert!(close(moved.geometric_normal, turned(Vec3::Z)));
        assert!(close(moved.normal, turned(shading)));
        assert!(!close(moved.geometric_normal, Vec3::from(moved.normal)));
        assert!(close(
            moved.position,
            motion.transform_point3(Vec3::from(site.position))
        ));
        assert!((moved.r_min - 0.02).abs() < 1e-6);
        assert_eq!((moved.seed, moved.instance), (77, 4));
        // Unmoved: the stored site itself; no stored site: the record's, with the new seed.
        assert_eq!(replacement_site(Some(site), &record, None, 5), site);
        let from_record = replacement_site(None, &record, None, 5);
        assert_eq!(from_record.geometric_normal, record.normal);
        assert_eq!(from_record.seed, 5);
    }

    /// The shadow tests reject a pyramid against the box around every mover first, which
    /// is exact only if that box contains each mover's world box.
    #[test]
    fn the_union_box_contains_every_mover() {
        let a = MovingBounds::new(
            Vec3::splat(-1.0),
            Vec3::splat(1.0),
            &Mat4::IDENTITY,
            &Mat4::from_translation(Vec3::new(0.5, 0.0, 0.0)),
        );
        let b = MovingBounds::new(
            Vec3::ZERO,
            Vec3::ONE,
            &Mat4::from_translation(Vec3::new(3.0, -2.0, 0.0)),
            &Mat4::from_scale_rotation_translation(
                Vec3::splat(2.0),
                Quat::from_rotation_y(0.3),
                Vec3::new(3.0, -2.0, 1.0),
            ),
        );
        let (lo, hi) = MovingBounds::union(&[a, b]);
        for m in [a, b] {
            for c in 0..3 {
                assert!(lo[c] <= m.world_lo[c] && hi[c] >= m.world_hi[c]);
            }
        }
        assert_eq!(lo[0], a.world_lo[0].min(b.world_lo[0]));
        assert_eq!(hi[0], a.world_hi[0].max(b.world_hi[0]));
        // No movers: an empty box (lo > hi) that nothing meets.
        let (lo, hi) = MovingBounds::union(&[]);
        assert!((0..3).all(|c| lo[c] > hi[c]));
    }

    /// The mover box follows the instance: points of the mesh at either end of the span
    /// map back into the instance box and lie in the world box, and a point beside the
    /// turned cube (inside the world box) is outside the instance box.
    #[test]
    fn moving_bounds_follow_the_instance_at_both_ends() {
        let (lo, hi) = (Vec3::splat(-0.5), Vec3::splat(0.5));
        let start = Mat4::from_translation(Vec3::new(1.0, 0.0, 0.0));
        let end = Mat4::from_rotation_translation(
            Quat::from_rotation_y(std::f32::consts::FRAC_PI_4),
            Vec3::new(1.5, 0.0, 0.0),
        );
        let m = MovingBounds::new(lo, hi, &start, &end);
        let to_instance = |rows: &[[f32; 4]; 3], p: Vec3| {
            Vec3::from_array(rows.map(|r| r[0] * p.x + r[1] * p.y + r[2] * p.z + r[3]))
        };
        let inside =
            |p: Vec3, lo: [f32; 4], hi: [f32; 4]| (0..3).all(|c| p[c] >= lo[c] && p[c] <= hi[c]);
        for (k, transform) in [start, end].iter().enumerate() {
            for c in 0..8 {
                let corner = Vec3::new(
                    if c & 1 == 0 { -0.5 } else { 0.5 },
                    if c & 2 == 0 { -0.5 } else { 0.5 },
                    if c & 4 == 0 { -0.5 } else { 0.5 },
                );
                let world = transform.transform_point3(corner);
                assert!(inside(to_instance(&m.to_instance[k], world), m.lo, m.hi));
                assert!(inside(world, m.world_lo, m.world_hi));
            }
        }
        // Beside a face of the turned cube, within the world box: the end's instance
        // box does not hold it.
        let p = Vec3::new(1.5 + 0.45, 0.0, 0.45);
        assert!(inside(p, m.world_lo, m.world_hi));
        assert!(!inside(to_instance(&m.to_instance[1], p), m.lo, m.hi));
        // A transform without an inverse gives a box every point is in.
        let flat = MovingBounds::new(lo, hi, &start, &Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)));
        assert!(inside(
            to_instance(&flat.to_instance[0], Vec3::splat(1e6)),
            flat.lo,
            flat.hi
        ));
    }

    fn record() -> Record {
        Record {
            position: [1.0, 2.0, 3.0],
            radius: 0.5,
            normal: [0.0, 1.0, 0.0],
            r_min: 0.1,
            irradiance: [1.0, 2.0, 3.0],
            instance: 4,
            rotation_gradient: [[0.1, 0.2, 0.3, 0.0]; 3],
            translation_gradient: [[0.3, -0.2, 0.1, 0.0]; 3],
        }
    }

    /// Irradiance the record extrapolates to (p, n) (decision 3), red channel.
    fn extrapolate(r: &Record, p: Vec3, n: Vec3) -> f32 {
        let axis = Vec3::from(r.normal).cross(n);
        r.irradiance[0]
            + axis.dot(rgb(r.rotation_gradient[0]))
            + (p - Vec3::from(r.position)).dot(rgb(r.translation_gradient[0]))
    }

    #[test]
    fn a_moved_record_extrapolates_to_moved_points_as_before() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::splat(1.5),
            Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 0.2),
            Vec3::new(-2.0, 0.5, 4.0),
        );
        let r = record();
        let moved = move_record(&r, &m);
        let p = Vec3::new(1.2, 2.1, 2.7);
        let n = Vec3::new(0.1, 0.98, -0.1).normalize();
        let before = extrapolate(&r, p, n);
        let rotation = Mat3::from_mat4(m) * (1.0 / 1.5);
        let after = extrapolate(&moved, m.transform_point3(p), rotation * n);
        assert!((before - after).abs() < 1e-4, "{before} vs {after}");
        assert!((moved.radius - 0.75).abs() < 1e-6);
        assert_eq!(moved.irradiance, r.irradiance);
    }

    #[test]
    fn the_identity_leaves_a_record_unchanged() {
        let r = record();
        let same = move_record(&r, &Mat4::IDENTITY);
        assert_eq!(bytemuck::bytes_of(&same), bytemuck::bytes_of(&r));
    }
}
