//! `radsplat brdf-projection`: per glossy material of a scene, how much of its lobe HSH of
//! each order holds (thesis eq. 3.32, mean and least over the paraboloid map of outgoing
//! directions), what radiance records will choose their order from.

use crate::hsh::brdf_projection::{ProjectedLobe, quadrature_for};
use crate::hsh::{MAX_ORDER, coefficient_count};
use crate::output::OutputSet;
use crate::scene::load_scene;
use crate::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One row: a material at one order.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ProjectionRow {
    pub material: String,
    pub exponent: f32,
    pub order: u32,
    pub coefficients: usize,
    /// Mean and least accuracy (eq. 3.32) over the map's outgoing directions.
    pub mean_accuracy: f64,
    pub least_accuracy: f64,
    /// CPU time of the projection (all map cells).
    pub ms: f64,
}

/// Projects every glossy material of `scene_path` at `orders` on a `resolution^2` map,
/// prints the table and writes it as JSON to `json`.
pub fn brdf_projection(
    scene_path: &Path,
    orders: &[u32],
    resolution: u32,
    json: Option<PathBuf>,
) -> Result<()> {
    if let Some(&bad) = orders.iter().find(|&&o| o == 0 || o > MAX_ORDER) {
        return Err(Error::Usage(format!(
            "--orders: order {bad} is outside 1..={MAX_ORDER}"
        )));
    }
    if resolution == 0 || resolution > 256 {
        return Err(Error::Usage(format!(
            "--resolution {resolution}: must be in 1..=256"
        )));
    }
    let scene = load_scene(scene_path)?;
    let mut outputs = OutputSet::new();
    outputs.plan_opt(json.as_deref())?;
    let mut rows = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for m in &scene.materials {
        let Some(lobe) = m.glossy else { continue };
        if !seen.insert(m.name.clone()) {
            continue;
        }
        for &order in orders {
            let t = Instant::now();
            let q = quadrature_for(&lobe, order);
            let p = ProjectedLobe::new(&lobe, order, resolution, &q);
            let (mean, least) = p.accuracy_summary();
            rows.push(ProjectionRow {
                material: m.name.clone(),
                exponent: lobe.exponent(),
                order,
                coefficients: coefficient_count(order),
                mean_accuracy: mean,
                least_accuracy: least,
                ms: t.elapsed().as_secs_f64() * 1e3,
            });
        }
    }
    if rows.is_empty() {
        println!("{}: no material has a glossy lobe", scene_path.display());
    } else {
        println!(
            "BRDF projection of the glossy lobes ({resolution}x{resolution} outgoing directions, \
             eq. 3.32 accuracy = share of the lobe's energy held)"
        );
        println!("material             exponent  order  coeffs   mean acc  least acc     ms");
        for r in &rows {
            println!(
                "{:20} {:8.1} {:6} {:7} {:10.4} {:10.4} {:6.0}",
                r.material,
                r.exponent,
                r.order,
                r.coefficients,
                r.mean_accuracy,
                r.least_accuracy,
                r.ms
            );
        }
    }
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&rows).map_err(|e| Error::Output {
            path: path.clone(),
            message: e.to_string(),
        })?;
        outputs.stage(&path, text.as_bytes())?;
    }
    outputs.commit()
}
