//! The record map: record sites drawn over the (dimmed, tone-mapped) image, like the
//! thesis's figures, each dot coloured by its radius on a log scale from R_min (red)
//! through green to R_max = 64 R_min (blue), records whose plane saw no light (E = 0)
//! magenta; and the lifespan map of temporal caching
//! (thesis figure 5.11): the same dots coloured by lifespan, red short to green long.

use super::tonemap_to_srgb8;
use crate::frame::Frame;
use crate::records::Record;
use crate::visibility::GpuCamera;
use glam::Vec3;

/// The dot of a record whose plane saw no light.
const DARK: [u8; 3] = [255, 0, 255];

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
    let colours: Vec<[u8; 3]> = records
        .iter()
        .map(|r| {
            if r.is_dark() {
                DARK
            } else {
                ramp((r.radius / r.r_min).max(1.0).ln() / 64f32.ln())
            }
        })
        .collect();
    dots_over_image(frame, camera, records, &colours, exposure)
}

/// RGB8 pixels of the lifespan map: each record's dot from red (`lifespans[i]` = 1 frame)
/// to green (`max_lifespan` frames or more).
pub fn lifespan_map(
    frame: &Frame,
    camera: &GpuCamera,
    records: &[Record],
    lifespans: &[u32],
    max_lifespan: u32,
    exposure: f32,
) -> Vec<u8> {
    let span = max_lifespan.saturating_sub(1).max(1) as f32;
    let colours: Vec<[u8; 3]> = lifespans
        .iter()
        .map(|&l| ramp(0.5 * (l.saturating_sub(1) as f32 / span).min(1.0)))
        .collect();
    dots_over_image(frame, camera, records, &colours, exposure)
}

/// Draws a 3x3 dot of `colours[i]` at each visible record site over the dimmed image.
fn dots_over_image(
    frame: &Frame,
    camera: &GpuCamera,
    records: &[Record],
    colours: &[[u8; 3]],
    exposure: f32,
) -> Vec<u8> {
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
    for (r, colour) in records.iter().zip(colours) {
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
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (px, py) = (x + dx, y + dy);
                if px >= 0 && py >= 0 && px < w && py < h {
                    let i = ((py * w + px) * 3) as usize;
                    rgb[i..i + 3].copy_from_slice(colour);
                }
            }
        }
    }
    rgb
}
