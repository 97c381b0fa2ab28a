//! Temporal caching of radiance records (issue 18 item 6, seed 000): the same lifecycle as
//! irradiance records (estimate at t+1 by reprojection, lifespan, replacement, deletion,
//! temporal gradients) over the records' HSH coefficient blocks
//! ([`crate::records::RecordKind::Radiance`]). A [`super::TemporalCache`] of radiance
//! records runs beside the irradiance one; this file holds what differs for a block:
//!
//! - **tau of a coefficient vector.** The change of a record's incoming radiance from t to
//!   t+1 is `delta = |c_Y(t+1) - c_Y(t)| / |c_Y(t)|`, the L2 norms of the luminance
//!   coefficients (`c_Y = 0.2126 c_r + 0.7152 c_g + 0.0722 c_b`). HSH are orthonormal over
//!   the hemisphere, so this is the relative L2 change of the radiance function itself;
//!   for a constant radiance (one coefficient) it is `|E(t+1) / E(t) - 1|`, the seed's
//!   `|tau - 1|` of an irradiance record. We set `tau = 1 + delta` and keep the lifespan
//!   rule as it is (`delta (t - t_k) <= a_t`, decision 9). A ratio of norms would miss a
//!   change of direction at equal power (a light moving around the record); the norm of
//!   the difference sees it.
//! - **Temporal gradients per coefficient.** Extrapolated: every value and gradient
//!   coefficient moves by `(c(t+1) - c(t))` per frame (seed 000 eqs. 14-17, per
//!   coefficient); interpolated: towards the successor's block (eqs. 18-20).
//! - **Motion.** A block is in the record's turned frame (its plane's tangent and
//!   bitangent, the header): a record carried by its instance turns its frame with the
//!   instance's rotation; the coefficients, in that frame, stay; their translational
//!   gradients (per unit length) divide by the instance's scale.

use crate::records::kind::FRAME_FLOATS;
use glam::{Mat3, Mat4, Vec3};

/// Luminance weights of the three channels (Rec. 709, as [`super::temporal_ratio`]).
const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// Coefficients per channel in a block of `floats` f32s (frame header, then values,
/// x-gradients and y-gradients of three channels).
fn per_channel(floats: usize) -> usize {
    floats.saturating_sub(FRAME_FLOATS) / 9
}

/// tau of a radiance record (module docs): `1 + |c_Y(t+1) - c_Y(t)| / |c_Y(t)|` over the
/// value coefficients of blocks `now` and `next`; infinite for a record born in the dark
/// that lights up, 1 when both are dark.
pub fn coefficient_ratio(now: &[f32], next: &[f32]) -> f32 {
    let n = per_channel(now.len());
    let luma = |block: &[f32], k: usize| -> f64 {
        (0..3)
            .map(|c| f64::from(LUMA[c]) * f64::from(block[FRAME_FLOATS + c * n + k]))
            .sum()
    };
    let (mut norm, mut change) = (0.0f64, 0.0f64);
    for k in 0..n {
        let (a, b) = (luma(now, k), luma(next, k));
        norm += a * a;
        change += (b - a) * (b - a);
    }
    if norm > 0.0 {
        1.0 + (change / norm).sqrt() as f32
    } else if change > 0.0 {
        f32::INFINITY
    } else {
        1.0
    }
}

/// Block `next` (an estimate at t+1 projected with values only,
/// `Lookahead::values_only`) given the translational gradients of block `now`, the
/// record's own at t; frame and values stay `next`'s.
pub fn keep_gradients(next: &mut [f32], now: &[f32]) {
    let gradients = FRAME_FLOATS + 3 * per_channel(now.len());
    if next.len() == now.len() && next.len() > gradients {
        next[gradients..].copy_from_slice(&now[gradients..]);
    }
}

/// Block `from` with every coefficient (values and gradients) moved the fraction `f`
/// towards `to`; the frame header stays `from`'s.
pub fn blend_coefficients(from: &[f32], to: &[f32], f: f32) -> Vec<f32> {
    let mut out = from.to_vec();
    if f == 0.0 {
        return out;
    }
    for (o, &b) in out.iter_mut().zip(to).skip(FRAME_FLOATS) {
        *o += (b - *o) * f;
    }
    out
}

/// Block `block` carried by the affine map `m` (a rigid motion, possibly with uniform
/// scale; as [`super::motion::move_record`]): the frame turns with its rotation, the
/// translational gradients divide by its scale. The identity returns `block` bit for bit.
pub fn move_coefficients(block: &[f32], m: &Mat4) -> Vec<f32> {
    let mut out = block.to_vec();
    if *m == Mat4::IDENTITY || block.len() < FRAME_FLOATS {
        return out;
    }
    let linear = Mat3::from_mat4(*m);
    let scale = linear.determinant().abs().cbrt().max(f32::MIN_POSITIVE);
    let rotation = linear * (1.0 / scale);
    for axis in 0..2 {
        let at = 4 * axis;
        let v = Vec3::new(block[at], block[at + 1], block[at + 2]);
        let turned = (rotation * v).normalize_or_zero();
        out[at..at + 3].copy_from_slice(&turned.to_array());
    }
    let n = per_channel(block.len());
    for g in &mut out[FRAME_FLOATS + 3 * n..] {
        *g /= scale;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    /// A block of order 2 (4 coefficients per channel) with values `v` in every channel.
    fn block(v: [f32; 4]) -> Vec<f32> {
        let mut b = vec![1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0];
        for _ in 0..3 {
            b.extend_from_slice(&v);
        }
        for _ in 0..6 {
            b.extend_from_slice(&[0.5, -0.5, 0.25, 0.0]);
        }
        b
    }

    #[test]
    fn tau_of_a_constant_radiance_is_the_irradiance_ratio() {
        // One nonzero coefficient: the vector rule reduces to E(t+1) / E(t).
        let tau = coefficient_ratio(&block([2.0, 0.0, 0.0, 0.0]), &block([2.5, 0.0, 0.0, 0.0]));
        assert!((tau - 1.25).abs() < 1e-6, "{tau}");
        let dim = coefficient_ratio(&block([2.0, 0.0, 0.0, 0.0]), &block([1.5, 0.0, 0.0, 0.0]));
        assert!((dim - 1.25).abs() < 1e-6, "{dim}");
    }

    #[test]
    fn tau_sees_a_change_of_direction_at_equal_power() {
        // The same norm, the radiance turned to another coefficient: a ratio of norms
        // would say 1 (no change); the vector rule says the radiance changed entirely.
        let tau = coefficient_ratio(&block([0.0, 1.0, 0.0, 0.0]), &block([0.0, 0.0, 1.0, 0.0]));
        assert!((tau - (1.0 + 2f32.sqrt())).abs() < 1e-6, "{tau}");
        assert_eq!(coefficient_ratio(&block([0.0; 4]), &block([0.0; 4])), 1.0);
        assert_eq!(
            coefficient_ratio(&block([0.0; 4]), &block([1.0, 0.0, 0.0, 0.0])),
            f32::INFINITY
        );
    }

    #[test]
    fn an_estimate_of_values_keeps_the_records_gradients() {
        let now = block([1.0, 2.0, 3.0, 4.0]);
        let mut next = block([5.0, 6.0, 7.0, 8.0]);
        next[FRAME_FLOATS + 12..].fill(0.0);
        keep_gradients(&mut next, &now);
        assert_eq!(
            &next[..FRAME_FLOATS + 12],
            &block([5.0, 6.0, 7.0, 8.0])[..FRAME_FLOATS + 12]
        );
        assert_eq!(&next[FRAME_FLOATS + 12..], &now[FRAME_FLOATS + 12..]);
    }

    #[test]
    fn blending_moves_coefficients_and_keeps_the_frame() {
        let a = block([1.0, 2.0, 3.0, 4.0]);
        let mut b = block([3.0, 2.0, 1.0, 0.0]);
        b[0] = 0.0;
        b[1] = 1.0;
        let half = blend_coefficients(&a, &b, 0.5);
        assert_eq!(&half[..FRAME_FLOATS], &a[..FRAME_FLOATS]);
        assert_eq!(&half[FRAME_FLOATS..FRAME_FLOATS + 4], &[2.0, 2.0, 2.0, 2.0]);
        assert_eq!(blend_coefficients(&a, &b, 0.0), a);
    }

    #[test]
    fn motion_turns_the_frame_and_scales_the_gradients() {
        let b = block([1.0, 2.0, 3.0, 4.0]);
        assert_eq!(move_coefficients(&b, &Mat4::IDENTITY), b);
        let m = Mat4::from_scale_rotation_translation(
            Vec3::splat(2.0),
            Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let moved = move_coefficients(&b, &m);
        // Tangent x turns to y, bitangent y to -x.
        assert!((Vec3::from_slice(&moved[0..3]) - Vec3::Y).length() < 1e-6);
        assert!((Vec3::from_slice(&moved[4..7]) + Vec3::X).length() < 1e-6);
        // Values stay; gradients halve with a scale of 2.
        assert_eq!(
            &moved[FRAME_FLOATS..FRAME_FLOATS + 12],
            &b[FRAME_FLOATS..FRAME_FLOATS + 12]
        );
        for (g, g0) in moved[FRAME_FLOATS + 12..]
            .iter()
            .zip(&b[FRAME_FLOATS + 12..])
        {
            assert!((g - g0 / 2.0).abs() < 1e-6);
        }
    }
}
