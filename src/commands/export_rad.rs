//! `radsplat export-rad`: the scene for Radiance (rpict) and a texture-less variant.

use super::load_scene_with;
use crate::output::OutputSet;
use crate::{Error, Result};
use std::path::Path;

/// `radsplat export-rad`: writes `scene.rad`, `view.vf`, `notex.toml` and `export.json`
/// into `out_dir`.
pub fn export_rad(scene_path: &Path, out_dir: &Path, size: Option<(u32, u32)>) -> Result<()> {
    use crate::radiance_export::{notex_scene_toml, scene_rad, view_options};
    let scene = load_scene_with(scene_path, None, size, None)?;
    std::fs::create_dir_all(out_dir).map_err(|e| Error::Output {
        path: out_dir.to_path_buf(),
        message: e.to_string(),
    })?;
    let (rad, vf, notex, json) = (
        out_dir.join("scene.rad"),
        out_dir.join("view.vf"),
        out_dir.join("notex.toml"),
        out_dir.join("export.json"),
    );
    let mut outputs = OutputSet::new();
    for path in [&rad, &vf, &notex, &json] {
        outputs.plan(path)?;
    }
    let view = view_options(&scene);
    outputs.stage(&rad, scene_rad(&scene).as_bytes())?;
    outputs.stage(&vf, format!("rview {view}\n").as_bytes())?;
    outputs.stage(&notex, notex_scene_toml(scene_path, &scene)?.as_bytes())?;
    let info = serde_json::json!({
        "scene": scene_path,
        "width": scene.camera.width,
        "height": scene.camera.height,
        "view": view,
        "triangles": scene.triangle_count(),
        "textured_materials": scene.materials.iter().filter(|m| m.albedo_texture.is_some()).count(),
        "has_environment": scene.environment.max_element() > 0.0,
        "exposure": scene.settings.exposure,
    });
    outputs.stage(
        &json,
        serde_json::to_string_pretty(&info)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    outputs.commit()?;
    println!(
        "wrote {}/{{scene.rad, view.vf, notex.toml, export.json}}",
        out_dir.display()
    );
    Ok(())
}
