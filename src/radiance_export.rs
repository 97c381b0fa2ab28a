//! Export of a loaded scene to Radiance (Ward 1994), for comparisons with `rpict`
//! (`benches/peers/`). Only what both renderers model the same way is exported:
//!
//! - every triangle, in world space, as a flat `polygon`, without its vertex normals (measured
//!   on Sponza sun 1000x1000, `rpict -defaults -ab 1`: with them, as `obj2rad`'s `tmesh.cal`
//!   texfuncs or an `obj2mesh` mesh, the direct-light conversion check falls from 5.98 to
//!   2.48 %, but rpict takes 43 s instead of 26-30 s for the same indirect error, 18.3-20.0 %
//!   against 20.0 %: flat polygons are rpict's best); materials as `plastic` with the MTL
//!   `Kd` colour, specularity 0 and roughness 0 (a Lambertian reflector of reflectance
//!   `Kd`); **textures are ignored**, and [`notex_scene_toml`] makes a radsplat scene
//!   variant without them so that both sides render the same thing;
//! - emitters sampled by direct lighting (rect lights) as `light` (same radiance,
//!   W/(sr m²) per channel, one-sided along the same normal; each rect light one 4-vertex
//!   `polygon`, not two triangles, so that rpict samples it exactly), other emitters as `glow` with
//!   radius 0 (seen by camera and indirect rays only, as in radsplat);
//! - point lights as small `light` spheres of radiance I / (π r²) (intensity I); spot
//!   lights as Radiance `spot` with the full cone angle inner + outer half-angles (Radiance
//!   has a sharp cut-off, radsplat a smooth one: an approximation);
//! - the sun as a `light` `source` of angular diameter 0.533° with radiance E / Ω,
//!   Ω = 2π (1 − cos 0.2665°); the environment as a `glow` `source` sky (Radiance counts it
//!   in the ambient, i.e. indirect, calculation; radsplat samples it as direct light);
//! - the camera as a perspective view (`-vtv`) with `-vv` = vertical FOV and
//!   `-vh` = 2 atan(tan(vv/2) · width/height).

use crate::scene::asset_path::resolve_asset;
use crate::scene::file::RECT_LIGHT_PREFIX;
use crate::scene::{Light, Scene};
use crate::{Error, Result};
use glam::{Mat4, Vec3};
use std::fmt::Write as _;
use std::path::Path;

/// Angular diameter of the sun, degrees.
pub const SUN_DIAMETER_DEGREES: f64 = 0.533;

fn ident(prefix: &str, i: usize, name: &str) -> String {
    let clean: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    format!("{prefix}{i}_{clean}")
}

fn v3(v: glam::Vec3) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

/// The Radiance scene description (materials, geometry, lights) of a loaded scene.
pub fn scene_rad(scene: &Scene) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Exported by radsplat export-rad from {} (textures ignored)",
        scene.source.display()
    );
    let glossy = scene
        .materials
        .iter()
        .filter(|m| m.glossy.is_some())
        .count();
    if glossy > 0 {
        // Radiance's `plastic` lobe is Ward's isotropic Gaussian, not normalised Phong: a
        // translation would not be the same BRDF, so the comparison stays Lambertian.
        log::warn!(
            "{}: the glossy lobes of {glossy} material(s) are exported as Lambertian \
             (plastic with specularity 0)",
            scene.source.display()
        );
        let _ = writeln!(
            out,
            "# {glossy} glossy material(s): their Phong lobes are not exported (Lambertian)"
        );
    }
    for (i, m) in scene.materials.iter().enumerate() {
        let id = ident("m", i, &m.name);
        let e = m.emission;
        if e.max_element() > 0.0 {
            if m.sampled_light {
                let _ = writeln!(out, "void light {id} 0 0 3 {}", v3(e));
            } else {
                let _ = writeln!(out, "void glow {id} 0 0 4 {} 0", v3(e));
            }
        } else {
            let _ = writeln!(out, "void plastic {id} 0 0 5 {} 0 0", v3(m.albedo));
        }
    }
    let mut n = 0usize;
    // Rect lights' quads (the loader's `add_rect_light_mesh`: two triangles of a mesh of
    // their own, or of the scene's one mesh) are written from the lights below, each as one
    // 4-vertex `light` polygon. As two triangles, rpict samples each triangle over an
    // equal-area rectangle about its centre (rays outside the triangle miss, the triangle
    // outside it is never sampled) and splits it into at most 64 parts: fine from afar
    // (Cornell box), but near a panel it lost most of the light (conference room: walls
    // within ~30 cm of a panel 3-15x too dark in -ab 0).
    for inst in &scene.instances {
        let mesh = &scene.meshes[inst.mesh as usize];
        for (t, tri) in mesh.indices.iter().enumerate() {
            let mi = mesh.material_ids[t] as usize;
            if scene.materials[mi].sampled_light {
                continue;
            }
            let id = ident("m", mi, &scene.materials[mi].name);
            let p = |k: usize| {
                v3(inst
                    .transform
                    .transform_point3(mesh.positions[tri[k] as usize]))
            };
            let _ = writeln!(out, "{id} polygon t{n} 0 0 9 {} {} {}", p(0), p(1), p(2));
            n += 1;
        }
    }
    for (i, light) in scene.lights.iter().enumerate() {
        let Light::Rect {
            corner,
            edge_u,
            edge_v,
            ..
        } = *light
        else {
            continue;
        };
        let name = format!("{RECT_LIGHT_PREFIX}{i}");
        let Some(mi) = scene.materials.iter().position(|m| m.name == name) else {
            continue;
        };
        let id = ident("m", mi, &name);
        // The quad's corners as the loader made them, through the identity its instance
        // had (so the same digits as when the quad was an instance of its own).
        let p = |q: Vec3| v3(Mat4::IDENTITY.transform_point3(q));
        let _ = writeln!(
            out,
            "{id} polygon t{n} 0 0 12 {} {} {} {}",
            p(corner),
            p(corner + edge_u),
            p(corner + edge_u + edge_v),
            p(corner + edge_v)
        );
        n += 1;
    }
    let radius = point_light_radius(scene);
    for (i, light) in scene.lights.iter().enumerate() {
        match *light {
            Light::Point {
                position,
                intensity,
            } => {
                let l = intensity / (std::f32::consts::PI * radius * radius);
                let _ = writeln!(out, "void light point{i}_mat 0 0 3 {}", v3(l));
                let _ = writeln!(
                    out,
                    "point{i}_mat sphere point{i} 0 0 4 {} {radius}",
                    v3(position)
                );
            }
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                let angle = cos_inner.acos().to_degrees() + cos_outer.acos().to_degrees();
                let l = intensity / (std::f32::consts::PI * radius * radius);
                let _ = writeln!(
                    out,
                    "void spot spot{i}_mat 0 0 7 {} {angle} {}",
                    v3(l),
                    v3(direction)
                );
                let _ = writeln!(
                    out,
                    "spot{i}_mat sphere spot{i} 0 0 4 {} {radius}",
                    v3(position)
                );
            }
            Light::Sun {
                direction,
                irradiance,
            } => {
                let half = (SUN_DIAMETER_DEGREES * 0.5).to_radians();
                let omega = 2.0 * std::f64::consts::PI * (1.0 - half.cos());
                let l = irradiance / omega as f32;
                let _ = writeln!(out, "void light sun{i}_mat 0 0 3 {}", v3(l));
                let _ = writeln!(
                    out,
                    "sun{i}_mat source sun{i} 0 0 4 {} {SUN_DIAMETER_DEGREES}",
                    v3(direction)
                );
            }
            // Already part of the geometry: the loader adds the quad with a `light` material.
            Light::Rect { .. } => {}
        }
    }
    if scene.environment_map.is_some() {
        log::warn!(
            "{}: the environment map is not exported (Radiance needs a `colorpict` sky)",
            scene.source.display()
        );
    }
    if scene.environment.max_element() > 0.0 {
        let _ = writeln!(out, "void glow sky_mat 0 0 4 {} 0", v3(scene.environment));
        let _ = writeln!(out, "sky_mat source sky 0 0 4 0 0 1 360");
    }
    out
}

fn point_light_radius(scene: &Scene) -> f32 {
    let mut lo = glam::Vec3::splat(f32::INFINITY);
    let mut hi = -lo;
    for inst in &scene.instances {
        for p in &scene.meshes[inst.mesh as usize].positions {
            let q = inst.transform.transform_point3(*p);
            lo = lo.min(q);
            hi = hi.max(q);
        }
    }
    let diag = (hi - lo).length();
    if diag.is_finite() && diag > 0.0 {
        diag * 1e-3
    } else {
        1e-3
    }
}

/// `rpict` view options matching the scene's camera (pixel centres are sampled with
/// `-pj 0`, so use `-x width -y height -pa 0 -pj 0 -ps 1` with these).
pub fn view_options(scene: &Scene) -> String {
    let c = &scene.camera;
    let vv = f64::from(c.fov_y_degrees);
    let aspect = f64::from(c.width) / f64::from(c.height);
    let vh = 2.0 * ((vv.to_radians() * 0.5).tan() * aspect).atan().to_degrees();
    format!(
        "-vtv -vp {} -vd {} -vu {} -vv {} -vh {vh:.6}",
        v3(c.position),
        v3(c.target - c.position),
        v3(c.up),
        c.fov_y_degrees
    )
}

/// A copy of the scene file `scene_path` whose `[[mesh]]` files are absolute paths and which
/// removes every albedo texture (`[[material]] texture = ""`, docs/scene-format.md) and
/// every glossy lobe (`specular = [0, 0, 0]`), for texture-less, Lambertian comparisons
/// with Radiance. `scene` is the same file, loaded.
pub fn notex_scene_toml(scene_path: &Path, scene: &Scene) -> Result<String> {
    let text = crate::input::read_to_string(scene_path, crate::input::MAX_TEXT_BYTES)?;
    let mut table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| Error::invalid(scene_path, "TOML", e.to_string()))?;
    if let Some(toml::Value::Array(meshes)) = table.get_mut("mesh") {
        for (i, m) in meshes.iter_mut().enumerate() {
            if let Some(toml::Value::String(file)) =
                m.as_table_mut().and_then(|t| t.get_mut("file"))
            {
                let found = resolve_asset(scene_path, &format!("mesh[{i}].file"), file)?;
                let abs = std::fs::canonicalize(&found).map_err(|e| Error::io(&found, e))?;
                *file = abs.to_string_lossy().into_owned();
            }
        }
    }
    // Existing overrides that set a texture: remove it (its path may be relative).
    if let Some(toml::Value::Array(materials)) = table.get_mut("material") {
        for t in materials.iter_mut().filter_map(|m| m.as_table_mut()) {
            if t.contains_key("texture") {
                t.insert("texture".into(), toml::Value::String(String::new()));
            }
        }
    }
    let names = |keep: &dyn Fn(&crate::scene::Material) -> bool| {
        let mut v: Vec<&str> = scene
            .materials
            .iter()
            .filter(|m| keep(m))
            .map(|m| m.name.as_str())
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let textured = names(&|m| m.albedo_texture.is_some());
    // Glossy lobes go too: the Radiance export is Lambertian (`scene_rad`), and both
    // renderers must render the same scene.
    let glossy = names(&|m| m.glossy.is_some());
    if !textured.is_empty() || !glossy.is_empty() {
        let overrides = table
            .entry("material")
            .or_insert_with(|| toml::Value::Array(Vec::new()));
        if let toml::Value::Array(list) = overrides {
            for name in textured {
                let mut t = toml::Table::new();
                t.insert("name".into(), toml::Value::String(name.into()));
                t.insert("texture".into(), toml::Value::String(String::new()));
                list.push(toml::Value::Table(t));
            }
            for name in glossy {
                let mut t = toml::Table::new();
                t.insert("name".into(), toml::Value::String(name.into()));
                let zero = toml::Value::Float(0.0);
                t.insert(
                    "specular".into(),
                    toml::Value::Array(vec![zero.clone(), zero.clone(), zero]),
                );
                list.push(toml::Value::Table(t));
            }
        }
    }
    let body =
        toml::to_string(&table).map_err(|e| Error::invalid(scene_path, "TOML", e.to_string()))?;
    Ok(format!(
        "# {} without textures, written by radsplat export-rad\n{body}",
        scene_path.display()
    ))
}
