//! The record map: record sites drawn over the (dimmed, tone-mapped) image, like the
//! thesis's figures, each dot coloured by its radius on a log scale from R_min (red)
//! through green to R_max = 64 R_min (blue).

use super::tonemap_to_srgb8;
use crate::frame::Frame;
use crate::records::Record;
use crate::visibility::GpuCamera;
use glam::Vec3;

/// False colour of `t` in [0, 1]: red → green → blue.
fn ramp(t: f32) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0);
    let (r, g, b) = if t < 0.5 {
        (1.0 - 2.0 * t, 2.0 * t, 0.0)
    } else {
        (0.0, 2.0 - 2.0 * t, 2.0 * t - 1.0)
    };
    [(r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8]
}

/// RGB8 pixels of the record map. Records hidden from the camera (farther than the
/// visible surface at their pixel) are not drawn.
pub fn record_map(frame: &Frame, camera: &GpuCamera, records: &[Record], exposure: f32) -> Vec<u8> {
    let (w, h) = (frame.width as i64, frame.height as i64);
    let mut rgb: Vec<u8> = tonemap_to_srgb8(&frame.beauty, exposure)
        .into_iter()
        .map(|c| c / 3)
        .collect();
    let origin = Vec3::from(camera.origin);
    let (fwd, right, up) = (
        Vec3::from(camera.forward),
        Vec3::from(camera.right),
        Vec3::from(camera.up),
    );
    for r in records {
        let d = r.position() - origin;
        let z = d.dot(fwd);
        if z <= 0.0 {
            continue;
        }
        let x = ((d.dot(right) / (right.length_squared() * z) + 1.0) * 0.5 * w as f32) as i64;
        let y = ((1.0 - d.dot(up) / (up.length_squared() * z)) * 0.5 * h as f32) as i64;
        if x < 0 || y < 0 || x >= w || y >= h {
            continue;
        }
        let v = &frame.visibility[(y * w + x) as usize];
        if !v.is_hit() || d.length() > v.t * 1.01 + 1e-4 {
            continue;
        }
        let t = (r.radius / r.r_min).max(1.0).ln() / 64f32.ln();
        let colour = ramp(t);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (px, py) = (x + dx, y + dy);
                if px >= 0 && py >= 0 && px < w && py < h {
                    let i = ((py * w + px) * 3) as usize;
                    rgb[i..i + 3].copy_from_slice(&colour);
                }
            }
        }
    }
    rgb
}
