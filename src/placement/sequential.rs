//! The thesis's sequential placement (Algorithm 4) on the CPU: scan the visible pixels in
//! raster order; where no record contributes (sum w = 0, i.e. none with w >= 1/a), compute
//! a record at that pixel and splat it at once. The reference for how many records a view
//! needs.

use crate::records::reference::RecordReference;
use crate::records::{CacheSettings, Record};
use crate::scene::Scene;
use crate::splat::reference::splat_records;
use crate::visibility::{GpuCamera, VisSample};

/// Records placed by the sequential scan for the visibility buffer `vis` of `camera`
/// (at most `settings.record_budget`).
pub fn sequential_placement(
    scene: &Scene,
    camera: &GpuCamera,
    vis: &[VisSample],
    settings: &CacheSettings,
) -> Vec<Record> {
    let reference = RecordReference::new(scene, settings);
    let mut records: Vec<Record> = Vec::new();
    let mut sums = vec![[0.0f32; 4]; vis.len()];
    for (pixel, v) in vis.iter().enumerate() {
        if !v.is_hit() || sums[pixel][3] > 0.0 {
            continue;
        }
        if records.len() as u32 >= settings.record_budget {
            break;
        }
        let site = RecordReference::site_from_pixel(settings, camera, v, records.len() as u32);
        records.push(reference.record(&site));
        splat_records(
            &records,
            records.len() - 1,
            vis,
            settings.accuracy,
            // Covered as placement's cover covers: with the corrals where it weighs them.
            settings.corral.in_cover(),
            &mut sums,
        );
    }
    records
}
