//! CPU mirror of `wgsl/shared/sampling.wgsl`: the same hashes and Owen-scrambled Sobol
//! points, bit for bit, so CPU references draw exactly the samples the GPU draws.

use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

pub fn hash_u32(x: u32) -> u32 {
    let state = x.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

pub fn hash_combine(seed: u32, v: u32) -> u32 {
    hash_u32(
        seed ^ v
            .wrapping_add(0x9e3779b9)
            .wrapping_add(seed << 6)
            .wrapping_add(seed >> 2),
    )
}

fn laine_karras_permutation(x: u32, seed: u32) -> u32 {
    let mut x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50b47c);
    x ^= x.wrapping_mul(0xb82f1e52);
    x ^= x.wrapping_mul(0xc7afe638);
    x ^= x.wrapping_mul(0x8d22f6e6);
    x
}

fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

fn sobol_dim1(mut i: u32) -> u32 {
    let mut v = 1u32 << 31;
    let mut r = 0;
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        v ^= v >> 1;
        i >>= 1;
    }
    r
}

pub fn u32_to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Point `index` of the 2D Owen-scrambled Sobol sequence with scramble `seed`.
pub fn sobol_2d(index: u32, seed: u32) -> Vec2 {
    let i = nested_uniform_scramble(index, hash_u32(seed));
    let x = nested_uniform_scramble(i.reverse_bits(), hash_combine(seed, 1));
    let y = nested_uniform_scramble(sobol_dim1(i), hash_combine(seed, 2));
    Vec2::new(u32_to_unit(x), u32_to_unit(y))
}

/// Tangent frame around unit `n` (Duff et al. 2017); columns are t, b, n.
pub fn orthonormal_basis(n: Vec3) -> Mat3 {
    let s = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    Mat3::from_cols(
        Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        Vec3::new(b, s + n.y * n.y * a, -n.y),
        n,
    )
}

/// The tangent frame of a record's hemisphere plane (WGSL `record_frame`, records.wgsl):
/// [`orthonormal_basis`] around `n`, turned about it by an angle drawn from the record's
/// seed, so that nearby records with the same normal do not share their plane's directions
/// and their sampling errors average out where they overlap.
pub fn record_frame(n: Vec3, seed: u32) -> Mat3 {
    let base = orthonormal_basis(n);
    let (c, s) = record_frame_turn(seed);
    Mat3::from_cols(
        c * base.x_axis + s * base.y_axis,
        c * base.y_axis - s * base.x_axis,
        base.z_axis,
    )
}

/// (cos, sin) of the angle [`record_frame`] turns [`orthonormal_basis`] by (WGSL
/// `record_frame_turn`): plane coordinates (x, y) lie along (c x - s y, s x + c y) in the
/// unturned basis.
pub fn record_frame_turn(seed: u32) -> (f32, f32) {
    let angle = 6.283_185_5_f32 * u32_to_unit(hash_combine(seed, 0x7f4a_7c15));
    (angle.cos(), angle.sin())
}

/// Index of the first light sample of plane sample `index` in its record's sequences (WGSL
/// `plane_light_first`): the samples of one record's plane stratify each light together.
pub fn plane_light_first(index: u32, count: u32) -> u32 {
    index * count
}

/// Cosine-weighted direction around +z.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_points_are_stratified() {
        // 16 points of a scrambled (0,2)-sequence: one per 4x4 stratum.
        for seed in [0u32, 1, 77, 123_456] {
            let mut cells = [0u32; 16];
            for i in 0..16 {
                let p = sobol_2d(i, seed);
                assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
                cells[(p.y * 4.0) as usize * 4 + (p.x * 4.0) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "seed {seed}: {cells:?}");
        }
    }

    #[test]
    fn record_frames_are_orthonormal_around_the_normal_and_turned_by_the_seed() {
        let n = Vec3::new(0.3, -0.5, 0.2).normalize();
        let mut tangents = Vec::new();
        for seed in 0..32u32 {
            let m = record_frame(n, seed);
            assert!((m.z_axis - n).length() < 1e-6);
            assert!(m.x_axis.dot(m.y_axis).abs() < 1e-5 && m.x_axis.dot(n).abs() < 1e-5);
            assert!((m.x_axis.length() - 1.0).abs() < 1e-5);
            // Right-handed like orthonormal_basis: t x b = n.
            assert!((m.x_axis.cross(m.y_axis) - n).length() < 1e-5);
            assert_eq!(record_frame(n, seed), m, "deterministic");
            tangents.push(m.x_axis);
        }
        // Turned: the tangents of 32 seeds spread around the normal (a fixed frame would
        // give one tangent 32 times); their mean is short.
        let mean = tangents.iter().copied().sum::<Vec3>() / 32.0;
        assert!(mean.length() < 0.35, "mean tangent {mean}");
        // Plane light samples: consecutive runs of one sequence.
        assert_eq!(plane_light_first(3, 4), 12);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.5, 0.2).normalize(),
            Vec3::X,
        ] {
            let m = orthonormal_basis(n);
            assert!((m.x_axis.dot(m.y_axis)).abs() < 1e-6);
            assert!((m.x_axis.length() - 1.0).abs() < 1e-5);
            assert!((m.x_axis.cross(m.y_axis) - n).length() < 1e-5);
        }
    }
}
