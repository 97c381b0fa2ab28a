//! The TOML scene file: parsing, validation, and assembly of a [`Scene`] from it.
//!
//! The format is documented in `docs/scene-format.md`. Syntax and type errors come from the
//! TOML deserializer and are reported as "line N, column M"; errors found while validating
//! values name the field path (e.g. `mesh[2].scale`) and, where it can be found, its line.

use super::animation::{
    Animation, CameraKey, LightTrack, MIN_DETERMINANT, RectQuad, Track, TransformKey, check_light,
    check_light_value,
};
use super::asset_path::resolve_asset;
use super::obj::{ObjData, load_obj};
use super::texture::TextureCache;
use super::{Camera, GlossyLobe, Instance, Light, Material, Mesh, RenderSettings, Scene};
use crate::{Error, Result};
use glam::{Mat4, Vec2, Vec3};
use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// `camera.up` when not given.
const DEFAULT_UP: [f32; 3] = [0.0, 1.0, 0.0];

/// Prefix of the names of the materials and meshes generated for rect lights.
pub const RECT_LIGHT_PREFIX: &str = "__rect_light_";

/// Loads and validates a scene file, with the OBJ, MTL and texture files it names.
///
/// In the returned scene, `instances[i]` is the `i`-th `[[mesh]]` entry; the instances of the
/// emissive meshes generated for rect lights follow. A scene of one `[[mesh]]` entry, placed
/// as modelled and without keyframes, keeps the quads of its rect lights without keyframes
/// in that mesh instead (two triangles each, after the OBJ's): it stays one instance.
/// Meshes are shared between entries naming the same OBJ file. Errors name the file and the
/// line or field at fault.
pub fn load_scene(path: &Path) -> Result<Scene> {
    let text = crate::input::read_to_string(path, crate::input::MAX_TEXT_BYTES)?;
    parse_scene(&text, path)
}

/// Like [`load_scene`], for scene text already in memory. `path` is where the text is taken
/// to come from: it names the file in messages, and relative asset names are looked up next
/// to it.
pub fn parse_scene(text: &str, path: &Path) -> Result<Scene> {
    let ctx = Context { path, text };
    let def: SceneDef = toml::from_str(text).map_err(|e| ctx.toml_error(&e))?;
    SceneBuilder::new(&ctx).build(def)
}

// ---------------------------------------------------------------------------------------------
// File structure (serde). Every table denies unknown fields so typos are errors, not no-ops.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneDef {
    camera: CameraDef,
    render: Option<RenderDef>,
    environment: Option<EnvironmentDef>,
    #[serde(default)]
    mesh: Vec<MeshDef>,
    #[serde(default)]
    material: Vec<MaterialDef>,
    #[serde(default)]
    light: Vec<LightDef>,
    animation: Option<AnimationDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AnimationDef {
    fps: Option<f32>,
    frames: Option<[u32; 2]>,
    temporal_accuracy: Option<f32>,
    max_lifespan: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDef {
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov_y: f32,
    resolution: [u32; 2],
    #[serde(default)]
    keyframe: Vec<CameraKeyDef>,
}

/// A `[[camera.keyframe]]`: omitted fields come from `[camera]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraKeyDef {
    frame: f32,
    position: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    up: Option<[f32; 3]>,
    fov_y: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderDef {
    light_samples: Option<u32>,
    exposure: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EnvironmentDef {
    radiance: Option<[f32; 3]>,
    /// A latitude-longitude HDR map (Radiance .hdr or OpenEXR).
    map: Option<String>,
    /// The map's rotation about +y, degrees.
    rotation: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshDef {
    file: String,
    name: Option<String>,
    translate: Option<[f32; 3]>,
    rotate: Option<[f32; 3]>,
    scale: Option<ScaleDef>,
    matrix: Option<[f32; 16]>,
    #[serde(default)]
    keyframe: Vec<MeshKeyDef>,
}

/// A `[[mesh.keyframe]]`: omitted fields come from the `[[mesh]]` entry.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshKeyDef {
    frame: f32,
    translate: Option<[f32; 3]>,
    rotate: Option<[f32; 3]>,
    scale: Option<ScaleDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDef {
    name: String,
    albedo: Option<[f32; 3]>,
    emission: Option<[f32; 3]>,
    texture: Option<String>,
    /// The glossy (Phong) lobe's reflectance; `[0, 0, 0]` removes the lobe.
    specular: Option<[f32; 3]>,
    /// The Phong exponent.
    exponent: Option<f32>,
}

/// All light parameters in one flat table; which ones a type takes is checked by hand, so
/// that a misplaced parameter gets a message naming the light type (serde's tagged enums lose
/// the line information).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDef {
    #[serde(rename = "type")]
    kind: String,
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    intensity: Option<[f32; 3]>,
    inner_angle: Option<f32>,
    outer_angle: Option<f32>,
    corner: Option<[f32; 3]>,
    edge_u: Option<[f32; 3]>,
    edge_v: Option<[f32; 3]>,
    radiance: Option<[f32; 3]>,
    irradiance: Option<[f32; 3]>,
    #[serde(default)]
    keyframe: Vec<LightKeyDef>,
}

/// A `[[light.keyframe]]`: any of the light type's animatable parameters (see
/// [`light_animatable`]); omitted ones come from the `[[light]]` entry. The cone angles and
/// the type cannot be animated, so they are not fields here (serde reports them by name).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightKeyDef {
    frame: f32,
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    intensity: Option<[f32; 3]>,
    corner: Option<[f32; 3]>,
    edge_u: Option<[f32; 3]>,
    edge_v: Option<[f32; 3]>,
    radiance: Option<[f32; 3]>,
    irradiance: Option<[f32; 3]>,
}

/// `scale = 2.0` or `scale = [1, 2, 1]`.
#[derive(Clone, Copy)]
struct ScaleDef([f32; 3]);

impl<'de> Deserialize<'de> for ScaleDef {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        struct ScaleVisitor;
        impl<'de> Visitor<'de> for ScaleVisitor {
            type Value = ScaleDef;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<ScaleDef, E> {
                Ok(ScaleDef([v as f32; 3]))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<ScaleDef, E> {
                Ok(ScaleDef([v as f32; 3]))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<ScaleDef, E> {
                Ok(ScaleDef([v as f32; 3]))
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<ScaleDef, A::Error> {
                let mut xyz = [0.0f32; 3];
                for (i, value) in xyz.iter_mut().enumerate() {
                    *value = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(ScaleDef(xyz))
            }
        }
        deserializer.deserialize_any(ScaleVisitor)
    }
}

// ---------------------------------------------------------------------------------------------
// Error locations.

/// The scene file being loaded, for error messages.
struct Context<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Context<'_> {
    /// A TOML syntax or type error, located by line and column.
    fn toml_error(&self, e: &toml::de::Error) -> Error {
        let location = match e.span() {
            Some(span) => {
                let (line, column) = line_column(self.text, span.start);
                format!("line {line}, column {column}")
            }
            None => "scene file".to_string(),
        };
        Error::invalid(self.path, location, e.message().trim())
    }

    /// An error in the value of `field` (a path like `mesh[2].scale`), with the field's line
    /// when it (or its enclosing table) can be found in the file.
    fn field_error(&self, field: &str, message: impl Into<String>) -> Error {
        let location = match self.locate(field) {
            Some(offset) => format!("{field} (line {})", line_column(self.text, offset).0),
            None => field.to_string(),
        };
        Error::invalid(self.path, location, message)
    }

    /// Byte offset of `field`, or of the deepest enclosing table or array element found.
    /// Re-parses the text with spans; this only runs when reporting an error.
    fn locate(&self, field: &str) -> Option<usize> {
        let root = toml::de::DeTable::parse(self.text).ok()?.into_inner();
        let root = toml::de::DeValue::Table(root);
        let mut current = &root;
        let mut found = None;
        for segment in field.split('.') {
            let (key, index) = match segment.split_once('[') {
                Some((key, rest)) => (key, rest.trim_end_matches(']').parse::<usize>().ok()),
                None => (segment, None),
            };
            let Some(value) = current.get(key) else {
                break;
            };
            found = Some(value.span().start);
            current = value.get_ref();
            if let Some(index) = index {
                let Some(value) = current.get(index) else {
                    break;
                };
                found = Some(value.span().start);
                current = value.get_ref();
            }
        }
        found
    }
}

/// 1-based line and column (in characters) of byte `offset` in `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

// ---------------------------------------------------------------------------------------------
// Value checks. Each names the field in its error.

impl Context<'_> {
    fn finite3(&self, field: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = Vec3::from_array(v);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.field_error(field, format!("must be finite, got {v}")))
        }
    }

    fn non_negative3(&self, field: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = self.finite3(field, v)?;
        if v.min_element() >= 0.0 {
            Ok(v)
        } else {
            Err(self.field_error(field, format!("must not be negative, got {v}")))
        }
    }

    /// A light value (radiance, intensity, irradiance, emission): finite, non-negative and
    /// at most [`super::limits::MAX_LIGHT_VALUE`].
    fn light3(&self, field: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = Vec3::from_array(v);
        check_light_value(v).map_err(|m| self.field_error(field, m))?;
        Ok(v)
    }

    fn unit_range3(&self, field: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = self.non_negative3(field, v)?;
        if v.max_element() <= 1.0 {
            Ok(v)
        } else {
            Err(self.field_error(field, format!("must be in [0, 1], got {v}")))
        }
    }

    /// A non-zero finite vector, normalised.
    fn direction3(&self, field: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = self.finite3(field, v)?;
        v.try_normalize()
            .ok_or_else(|| self.field_error(field, "must be a non-zero direction"))
    }
}

// ---------------------------------------------------------------------------------------------
// Assembly.

/// Accumulates the scene while the file's entries are processed in order.
struct SceneBuilder<'a> {
    ctx: &'a Context<'a>,
    meshes: Vec<Mesh>,
    instances: Vec<Instance>,
    materials: Vec<Material>,
    /// Texture file of each material (same index as `materials`), loaded at the end so that
    /// overrides can replace or remove it first.
    material_textures: Vec<Option<PathBuf>>,
    /// OBJ file (canonical) -> index in `meshes`: a file used by several entries is loaded once.
    mesh_by_file: HashMap<PathBuf, u32>,
    /// (MTL file (canonical), material name) -> index in `materials`.
    material_by_key: HashMap<(Option<PathBuf>, String), u32>,
    lights: Vec<Light>,
    /// Tracks of the instances of `[[mesh]]` entries with keyframes.
    instance_tracks: Vec<(usize, Track<TransformKey>)>,
    /// Tracks of the lights with keyframes.
    light_tracks: Vec<(usize, LightTrack)>,
}

impl<'a> SceneBuilder<'a> {
    fn new(ctx: &'a Context<'a>) -> Self {
        Self {
            ctx,
            meshes: Vec::new(),
            instances: Vec::new(),
            materials: Vec::new(),
            material_textures: Vec::new(),
            mesh_by_file: HashMap::new(),
            material_by_key: HashMap::new(),
            lights: Vec::new(),
            instance_tracks: Vec::new(),
            light_tracks: Vec::new(),
        }
    }

    fn build(mut self, def: SceneDef) -> Result<Scene> {
        let ctx = self.ctx;
        let camera = camera(ctx, &def.camera)?;
        let camera_track = camera_track(ctx, &def.camera)?;
        let settings = render_settings(ctx, def.render.as_ref())?;
        let (environment, environment_map) = match &def.environment {
            Some(EnvironmentDef {
                map: Some(name),
                radiance,
                rotation,
            }) => {
                // With a map, `radiance` scales it (a tint or exposure; default 1).
                let scale = match radiance {
                    Some(r) => ctx.light3("environment.radiance", *r)?,
                    None => Vec3::ONE,
                };
                let rotation = rotation.unwrap_or(0.0);
                if !rotation.is_finite() {
                    return Err(ctx.field_error("environment.rotation", "must be finite"));
                }
                let path = resolve_asset(ctx.path, "environment.map", name)?;
                let map = super::EnvironmentMap::load(&path, scale, rotation)?;
                (Vec3::ZERO, Some(map))
            }
            Some(EnvironmentDef {
                map: None,
                rotation: Some(_),
                ..
            }) => {
                return Err(ctx.field_error(
                    "environment.rotation",
                    "rotates an environment map: give `map` too",
                ));
            }
            Some(EnvironmentDef {
                radiance: Some(r), ..
            }) => (ctx.light3("environment.radiance", *r)?, None),
            _ => (Vec3::ZERO, None),
        };
        for (i, mesh) in def.mesh.iter().enumerate() {
            self.add_mesh_entry(i, mesh)?;
        }
        for (i, material) in def.material.iter().enumerate() {
            self.apply_override(i, material)?;
        }
        // The one mesh of a scene placed as modelled and never moved: static rect lights'
        // quads join it, so the scene stays one instance (see `add_rect_light_mesh`).
        let single_mesh = match self.instances.as_slice() {
            [only] if self.instance_tracks.is_empty() && only.transform == Mat4::IDENTITY => {
                Some(only.mesh)
            }
            _ => None,
        };
        for (i, light_def) in def.light.iter().enumerate() {
            let light = parse_light(ctx, &format!("light[{i}]"), light_def)?;
            let track = light_track(ctx, i, light_def)?;
            let mut quad = None;
            if let Light::Rect {
                corner,
                edge_u,
                edge_v,
                radiance,
            } = light
            {
                let into = single_mesh.filter(|_| track.is_none());
                self.add_rect_light_mesh(i, corner, edge_u, edge_v, radiance, into);
                quad = into.is_none().then_some(RectQuad {
                    instance: self.instances.len() - 1,
                    material: self.materials.len() - 1,
                    corner,
                    edge_u,
                    edge_v,
                    moves: light_def
                        .keyframe
                        .iter()
                        .any(|k| k.corner.is_some() || k.edge_u.is_some() || k.edge_v.is_some()),
                });
            }
            if let Some(track) = track {
                self.light_tracks.push((i, LightTrack { track, quad }));
            }
            self.lights.push(light);
        }
        let animation = animation(
            ctx,
            def.animation.as_ref(),
            self.instance_tracks,
            self.light_tracks,
            camera_track,
        )?;

        let mut textures = TextureCache::new();
        for (material, texture) in self.materials.iter_mut().zip(&self.material_textures) {
            if let Some(path) = texture {
                material.albedo_texture = Some(textures.get_or_load(path)?);
            }
        }

        let mut scene = Scene {
            source: ctx.path.to_path_buf(),
            meshes: self.meshes,
            instances: self.instances,
            materials: self.materials,
            textures: textures.into_textures(),
            lights: self.lights,
            environment,
            environment_map,
            camera,
            settings,
            animation,
        };
        // The static values are only defaults for keyframes: a loaded animated scene shows
        // its first frame.
        let first = *scene.frames().start();
        scene.set_frame(first as f32);
        // Keyframes were checked one by one above; the states between them are checked
        // here, at every integer frame inside the keyframe spans (the frames any frame
        // range can render).
        scene.check_keyframe_spans()?;
        if scene.triangle_count() == 0 {
            return Err(ctx.field_error(
                "mesh",
                "scene has no geometry (no [[mesh]] entry with triangles and no rect light)",
            ));
        }
        Ok(scene)
    }

    /// One `[[mesh]]` entry: loads its OBJ (once per file) and adds an instance.
    fn add_mesh_entry(&mut self, i: usize, def: &MeshDef) -> Result<()> {
        let ctx = self.ctx;
        let transform = mesh_transform(ctx, i, def)?;
        let track = mesh_track(ctx, i, def)?;
        let file = resolve_asset(ctx.path, &format!("mesh[{i}].file"), &def.file)?;
        let key = std::fs::canonicalize(&file).unwrap_or_else(|_| file.clone());
        let mesh = match self.mesh_by_file.get(&key) {
            Some(&mesh) => mesh,
            None => {
                let data = load_obj(&file)?;
                // An instance needs a BLAS with at least one triangle.
                if data.mesh.indices.is_empty() {
                    return Err(Error::invalid(
                        ctx.path,
                        format!("mesh[{i}].file"),
                        format!("{} has no triangles", file.display()),
                    ));
                }
                let mesh = self.add_obj(data, def.name.as_deref());
                self.mesh_by_file.insert(key, mesh);
                mesh
            }
        };
        self.instances.push(Instance { mesh, transform });
        if let Some(track) = track {
            self.instance_tracks.push((self.instances.len() - 1, track));
        }
        Ok(())
    }

    /// Adds a loaded OBJ's mesh and materials; returns the mesh index.
    fn add_obj(&mut self, data: ObjData, name: Option<&str>) -> u32 {
        let ObjData {
            mut mesh,
            materials,
            stats,
        } = data;
        log::debug!("{}: {stats:?}", mesh.name);
        let remap: Vec<u32> = materials
            .into_iter()
            .map(|m| {
                let library = m
                    .library
                    .as_ref()
                    .map(|p| std::fs::canonicalize(p).unwrap_or_else(|_| p.clone()));
                let key = (library, m.material.name.clone());
                *self.material_by_key.entry(key).or_insert_with(|| {
                    self.materials.push(m.material);
                    self.material_textures.push(m.texture);
                    (self.materials.len() - 1) as u32
                })
            })
            .collect();
        for id in &mut mesh.material_ids {
            *id = remap[*id as usize];
        }
        if let Some(name) = name {
            mesh.name = name.to_string();
        }
        self.meshes.push(mesh);
        (self.meshes.len() - 1) as u32
    }

    /// One `[[material]]` override: changes every loaded material of that name.
    fn apply_override(&mut self, i: usize, def: &MaterialDef) -> Result<()> {
        let ctx = self.ctx;
        let field = |name: &str| format!("material[{i}].{name}");
        let targets: Vec<usize> = (0..self.materials.len())
            .filter(|&m| self.materials[m].name == def.name)
            .collect();
        if targets.is_empty() {
            let mut known: Vec<&str> = self.materials.iter().map(|m| m.name.as_str()).collect();
            known.sort_unstable();
            known.dedup();
            let shown = known
                .iter()
                .take(20)
                .copied()
                .collect::<Vec<_>>()
                .join(", ");
            let more = if known.len() > 20 { ", ..." } else { "" };
            return Err(ctx.field_error(
                &field("name"),
                format!(
                    "no loaded material is named '{}' (known: {shown}{more})",
                    def.name
                ),
            ));
        }
        let albedo = def
            .albedo
            .map(|v| ctx.unit_range3(&field("albedo"), v))
            .transpose()?;
        let emission = def
            .emission
            .map(|v| ctx.light3(&field("emission"), v))
            .transpose()?;
        // `texture = ""` removes the texture.
        let texture = match def.texture.as_deref() {
            None => None,
            Some("") => Some(None),
            Some(name) => Some(Some(resolve_asset(ctx.path, &field("texture"), name)?)),
        };
        let specular = def
            .specular
            .map(|v| ctx.unit_range3(&field("specular"), v))
            .transpose()?;
        if let Some(e) = def.exponent {
            let max = super::limits::MAX_PHONG_EXPONENT;
            if !(e.is_finite() && (0.0..=max).contains(&e)) {
                return Err(ctx.field_error(
                    &field("exponent"),
                    format!("must be a number from 0 to {max:e}, got {e}"),
                ));
            }
        }
        for &m in &targets {
            let material = &self.materials[m];
            let lobe = match (specular, def.exponent, material.glossy) {
                (Some(ks), _, _) if ks.max_element() <= 0.0 => None,
                (Some(ks), e, old) => Some(GlossyLobe::Phong {
                    specular: ks,
                    exponent: e.or(old.map(|l| l.exponent())).unwrap_or(1.0),
                }),
                (None, Some(e), Some(old)) => Some(GlossyLobe::Phong {
                    specular: old.specular(),
                    exponent: e,
                }),
                (None, Some(_), None) => {
                    return Err(ctx.field_error(
                        &field("exponent"),
                        format!(
                            "material '{}' has no glossy lobe: give `specular` too",
                            def.name
                        ),
                    ));
                }
                (None, None, old) => old,
            };
            let kd = albedo.unwrap_or(material.albedo);
            if let Some(l) = lobe {
                let sum = kd + l.specular();
                if sum.max_element() > 1.0 + 1e-6 {
                    let name = if specular.is_some() {
                        "specular"
                    } else {
                        "albedo"
                    };
                    return Err(ctx.field_error(
                        &field(name),
                        format!(
                            "albedo + specular must be at most 1 per channel (energy), got \
                             {kd} + {}",
                            l.specular()
                        ),
                    ));
                }
            }
            self.materials[m].glossy = lobe;
        }
        for m in targets {
            if let Some(albedo) = albedo {
                self.materials[m].albedo = albedo;
            }
            if let Some(emission) = emission {
                self.materials[m].emission = emission;
            }
            if let Some(texture) = &texture {
                self.material_textures[m] = texture.clone();
            }
        }
        Ok(())
    }

    /// Adds the emissive two-triangle quad of rect light `i`, so the light is visible: as a
    /// mesh and instance of its own, or, with `into`, as two more triangles of that mesh.
    ///
    /// `into` is the scene's one mesh when it is placed as modelled, never moves, and the
    /// light does not either (`build`). The scene then stays one instance, whose rays start
    /// in its BLAS and whose plane pipelines leave instance traversal out
    /// (`bvh::SceneBvh::traversal_start`, `gpu::SceneFeatures`): the Cornell box's planes,
    /// refinement and direct light took about 0.84 of their time (docs/results.md, stop 57).
    /// The quad's triangles are the same either way (an identity instance transform changes
    /// no bit of a hit), so are its hits.
    fn add_rect_light_mesh(
        &mut self,
        i: usize,
        corner: Vec3,
        u: Vec3,
        v: Vec3,
        radiance: Vec3,
        into: Option<u32>,
    ) {
        let name = format!("{RECT_LIGHT_PREFIX}{i}");
        self.materials.push(Material {
            name: name.clone(),
            albedo: Vec3::ZERO,
            albedo_texture: None,
            emission: radiance,
            sampled_light: true,
            glossy: None,
        });
        self.material_textures.push(None);
        let material = (self.materials.len() - 1) as u32;
        let normal = u.cross(v).normalize_or_zero();
        // Both triangles have cross(e1, e2) parallel to cross(u, v): (c, c+u, c+u+v) gives
        // cross(u, u+v) = cross(u, v), and (c, c+u+v, c+v) gives cross(u+v, v) = cross(u, v).
        let positions = [corner, corner + u, corner + u + v, corner + v];
        if let Some(m) = into {
            let mesh = &mut self.meshes[m as usize];
            let base = mesh.positions.len() as u32;
            mesh.positions.extend(positions);
            mesh.normals.extend([normal; 4]);
            mesh.uvs.extend([Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
            mesh.indices
                .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
            mesh.material_ids.extend([material; 2]);
            return;
        }
        self.meshes.push(Mesh {
            name,
            positions: positions.to_vec(),
            normals: vec![normal; 4],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material_ids: vec![material; 2],
        });
        self.instances.push(Instance {
            mesh: (self.meshes.len() - 1) as u32,
            transform: Mat4::IDENTITY,
        });
    }
}

/// The view of `[camera]` or of one of its keyframes (`prefix` names which in errors).
fn camera_view(
    ctx: &Context,
    prefix: &str,
    position: [f32; 3],
    target: [f32; 3],
    up: [f32; 3],
    fov: f32,
) -> Result<CameraKey> {
    let field = |name: &str| format!("{prefix}.{name}");
    let position = ctx.finite3(&field("position"), position)?;
    let target = ctx.finite3(&field("target"), target)?;
    let max = super::limits::MAX_COORDINATE;
    for (name, p) in [("position", position), ("target", target)] {
        if p.abs().max_element() > max {
            return Err(ctx.field_error(
                &field(name),
                format!("{p} is beyond +-{max:e}: rescale the scene"),
            ));
        }
    }
    let up = ctx.direction3(&field("up"), up)?;
    let view = (target - position).try_normalize().ok_or_else(|| {
        ctx.field_error(
            &field("target"),
            format!("must differ from {prefix}.position"),
        )
    })?;
    if view.cross(up).length() < 1e-6 {
        return Err(ctx.field_error(
            &field("up"),
            "must not be parallel to the view direction (target - position)",
        ));
    }
    if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
        return Err(ctx.field_error(
            &field("fov_y"),
            format!("vertical field of view must be in (0, 180) degrees, got {fov}"),
        ));
    }
    Ok(CameraKey {
        position,
        target,
        up,
        fov_y_degrees: fov,
    })
}

fn camera(ctx: &Context, def: &CameraDef) -> Result<Camera> {
    let CameraKey {
        position,
        target,
        up,
        fov_y_degrees: fov,
    } = camera_view(
        ctx,
        "camera",
        def.position,
        def.target,
        def.up.unwrap_or(DEFAULT_UP),
        def.fov_y,
    )?;
    let [width, height] = def.resolution;
    if width == 0 || height == 0 {
        return Err(ctx.field_error(
            "camera.resolution",
            format!("width and height must be at least 1, got [{width}, {height}]"),
        ));
    }
    Ok(Camera {
        position,
        target,
        up,
        fov_y_degrees: fov,
        width,
        height,
    })
}

fn render_settings(ctx: &Context, def: Option<&RenderDef>) -> Result<RenderSettings> {
    let mut settings = RenderSettings::default();
    let Some(def) = def else {
        return Ok(settings);
    };
    if let Some(samples) = def.light_samples {
        if samples == 0 {
            return Err(ctx.field_error("render.light_samples", "must be at least 1"));
        }
        settings.light_samples = samples;
    }
    if let Some(exposure) = def.exposure {
        if !(exposure.is_finite() && exposure > 0.0) {
            return Err(ctx.field_error(
                "render.exposure",
                format!("must be a positive number, got {exposure}"),
            ));
        }
        settings.exposure = exposure;
    }
    Ok(settings)
}

/// The object-to-world matrix of mesh entry `i`: either `matrix` (row-major, affine) or
/// `T * Rz * Ry * Rx * S` from `translate`, `rotate` (Euler degrees) and `scale`.
fn mesh_transform(ctx: &Context, i: usize, def: &MeshDef) -> Result<Mat4> {
    let field = |name: &str| format!("mesh[{i}].{name}");
    let (transform, blame) = if let Some(rows) = def.matrix {
        if def.translate.is_some() || def.rotate.is_some() || def.scale.is_some() {
            return Err(ctx.field_error(
                &field("matrix"),
                "'matrix' cannot be combined with 'translate', 'rotate' or 'scale'",
            ));
        }
        if rows.iter().any(|x| !x.is_finite()) {
            return Err(ctx.field_error(&field("matrix"), "all 16 numbers must be finite"));
        }
        let m = Mat4::from_cols_array(&rows).transpose();
        if (m.row(3) - glam::Vec4::W).abs().max_element() > 1e-6 {
            return Err(ctx.field_error(
                &field("matrix"),
                format!(
                    "must be affine: the last row must be [0, 0, 0, 1], got {}",
                    m.row(3)
                ),
            ));
        }
        (m, field("matrix"))
    } else {
        let translate = ctx.finite3(&field("translate"), def.translate.unwrap_or([0.0; 3]))?;
        let rotate = ctx.finite3(&field("rotate"), def.rotate.unwrap_or([0.0; 3]))?;
        let scale = ctx.finite3(&field("scale"), def.scale.map_or([1.0; 3], |s| s.0))?;
        let rotate = Vec3::new(
            rotate.x.to_radians(),
            rotate.y.to_radians(),
            rotate.z.to_radians(),
        );
        let m = Mat4::from_translation(translate)
            * Mat4::from_rotation_z(rotate.z)
            * Mat4::from_rotation_y(rotate.y)
            * Mat4::from_rotation_x(rotate.x)
            * Mat4::from_scale(scale);
        (m, field("scale"))
    };
    let det = transform.determinant();
    if !(det.is_finite() && det.abs() > MIN_DETERMINANT) {
        return Err(ctx.field_error(
            &blame,
            format!("transform is not invertible (determinant {det})"),
        ));
    }
    Ok(transform)
}

/// The parameters each light type takes (all required).
fn light_parameters(kind: &str) -> Option<&'static [&'static str]> {
    Some(match kind {
        "point" => &["position", "intensity"],
        "spot" => &[
            "position",
            "direction",
            "intensity",
            "inner_angle",
            "outer_angle",
        ],
        "rect" => &["corner", "edge_u", "edge_v", "radiance"],
        "sun" => &["direction", "irradiance"],
        _ => return None,
    })
}

/// A light from its (possibly keyframe-merged) parameters; `prefix` (`light[2]` or
/// `light[2].keyframe[0]`) names the fields in errors.
fn parse_light(ctx: &Context, prefix: &str, def: &LightDef) -> Result<Light> {
    let field = |name: &str| format!("{prefix}.{name}");
    let kind = def.kind.as_str();
    let Some(takes) = light_parameters(kind) else {
        return Err(ctx.field_error(
            &field("type"),
            format!(
                "unknown light type '{kind}' (expected \"point\", \"spot\", \"rect\" or \"sun\")"
            ),
        ));
    };
    let given = [
        ("position", def.position.is_some()),
        ("direction", def.direction.is_some()),
        ("intensity", def.intensity.is_some()),
        ("inner_angle", def.inner_angle.is_some()),
        ("outer_angle", def.outer_angle.is_some()),
        ("corner", def.corner.is_some()),
        ("edge_u", def.edge_u.is_some()),
        ("edge_v", def.edge_v.is_some()),
        ("radiance", def.radiance.is_some()),
        ("irradiance", def.irradiance.is_some()),
    ];
    for (name, is_given) in given {
        if is_given && !takes.contains(&name) {
            return Err(ctx.field_error(
                &field(name),
                format!(
                    "a {kind} light has no parameter '{name}' (it takes: {})",
                    takes.join(", ")
                ),
            ));
        }
        if !is_given && takes.contains(&name) {
            return Err(ctx.field_error(
                &field(name),
                format!("missing: a {kind} light needs {}", takes.join(", ")),
            ));
        }
    }
    // All required parameters are present (checked above); the defaults below are unused.
    let v3 = |v: Option<[f32; 3]>| v.unwrap_or_default();
    let light = match kind {
        "point" => Light::Point {
            position: ctx.finite3(&field("position"), v3(def.position))?,
            intensity: ctx.light3(&field("intensity"), v3(def.intensity))?,
        },
        "spot" => {
            let inner = def.inner_angle.unwrap_or_default();
            let outer = def.outer_angle.unwrap_or_default();
            if !(outer.is_finite() && outer > 0.0 && outer < 90.0) {
                return Err(ctx.field_error(
                    &field("outer_angle"),
                    format!("half-angle must be in (0, 90) degrees, got {outer}"),
                ));
            }
            if !(inner.is_finite() && (0.0..=outer).contains(&inner)) {
                return Err(ctx.field_error(
                    &field("inner_angle"),
                    format!(
                        "half-angle must be in [0, outer_angle = {outer}] degrees, got {inner}"
                    ),
                ));
            }
            Light::Spot {
                position: ctx.finite3(&field("position"), v3(def.position))?,
                direction: ctx.direction3(&field("direction"), v3(def.direction))?,
                intensity: ctx.light3(&field("intensity"), v3(def.intensity))?,
                cos_inner: inner.to_radians().cos(),
                cos_outer: outer.to_radians().cos(),
            }
        }
        "rect" => {
            let corner = ctx.finite3(&field("corner"), v3(def.corner))?;
            let edge_u = ctx.finite3(&field("edge_u"), v3(def.edge_u))?;
            let edge_v = ctx.finite3(&field("edge_v"), v3(def.edge_v))?;
            if edge_u.length() == 0.0 {
                return Err(ctx.field_error(&field("edge_u"), "edge must not be zero"));
            }
            if edge_v.length() == 0.0 {
                return Err(ctx.field_error(&field("edge_v"), "edge must not be zero"));
            }
            if edge_u.cross(edge_v).length() <= 1e-6 * edge_u.length() * edge_v.length() {
                return Err(ctx.field_error(
                    &field("edge_v"),
                    "edges must not be parallel (the rectangle would have no area)",
                ));
            }
            Light::Rect {
                corner,
                edge_u,
                edge_v,
                radiance: ctx.light3(&field("radiance"), v3(def.radiance))?,
            }
        }
        _ => Light::Sun {
            direction: ctx.direction3(&field("direction"), v3(def.direction))?,
            irradiance: ctx.light3(&field("irradiance"), v3(def.irradiance))?,
        },
    };
    // What the checks above leave: products that overflow (a rect light's area, its
    // radiance x area), the same test every animated frame gets.
    check_light(&light).map_err(|(name, m)| ctx.field_error(&field(name), m))?;
    Ok(light)
}

// ---------------------------------------------------------------------------------------------
// Animation.

/// Keyframes of consecutive directions closer to opposite than this (|a + b| below it) are
/// rejected: the normalised linear interpolation between them is undefined.
const MIN_DIRECTION_SUM: f32 = 1e-3;

/// Checks that the frames of `prefix`'s keyframes are finite and strictly increasing.
fn check_frames(ctx: &Context, prefix: &str, frames: impl Iterator<Item = f32>) -> Result<()> {
    let mut previous: Option<f32> = None;
    for (j, frame) in frames.enumerate() {
        let field = format!("{prefix}.keyframe[{j}].frame");
        if !frame.is_finite() {
            return Err(ctx.field_error(&field, format!("must be finite, got {frame}")));
        }
        if let Some(previous) = previous.filter(|&p| frame <= p) {
            return Err(ctx.field_error(
                &field,
                format!(
                    "keyframe frames must be strictly increasing, got {frame} after {previous}"
                ),
            ));
        }
        previous = Some(frame);
    }
    Ok(())
}

/// Rejects consecutive keys whose directions (from `direction`) are opposite.
fn check_not_opposite<T>(
    ctx: &Context,
    prefix: &str,
    name: &str,
    keys: &[(f32, T)],
    direction: impl Fn(&T) -> Option<Vec3>,
) -> Result<()> {
    for j in 1..keys.len() {
        if let (Some(a), Some(b)) = (direction(&keys[j - 1].1), direction(&keys[j].1)) {
            if (a + b).length() < MIN_DIRECTION_SUM {
                return Err(ctx.field_error(
                    &format!("{prefix}.keyframe[{j}].{name}"),
                    format!(
                        "opposite to the previous keyframe's {name}: the interpolation \
                         between them is undefined (add a keyframe in between)"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The transform track of mesh entry `i`, if it has keyframes.
fn mesh_track(ctx: &Context, i: usize, def: &MeshDef) -> Result<Option<Track<TransformKey>>> {
    if def.keyframe.is_empty() {
        return Ok(None);
    }
    let prefix = format!("mesh[{i}]");
    if def.matrix.is_some() {
        return Err(ctx.field_error(
            &format!("{prefix}.matrix"),
            "a mesh with keyframes must be placed with 'translate', 'rotate' and 'scale', \
             not 'matrix' (a matrix cannot be interpolated)",
        ));
    }
    check_frames(ctx, &prefix, def.keyframe.iter().map(|k| k.frame))?;
    let mut keys = Vec::with_capacity(def.keyframe.len());
    for (j, key) in def.keyframe.iter().enumerate() {
        let field = |name: &str| format!("{prefix}.keyframe[{j}].{name}");
        let translate = key.translate.or(def.translate).unwrap_or([0.0; 3]);
        let rotate = key.rotate.or(def.rotate).unwrap_or([0.0; 3]);
        let scale = key.scale.or(def.scale).map_or([1.0; 3], |s| s.0);
        let translate = ctx.finite3(&field("translate"), translate)?;
        let rotate = ctx.finite3(&field("rotate"), rotate)?;
        let scale = ctx.finite3(&field("scale"), scale)?;
        // A rotation has determinant 1, so the scale alone decides invertibility.
        let det = scale.x * scale.y * scale.z;
        if !(det.is_finite() && det.abs() > MIN_DETERMINANT) {
            return Err(ctx.field_error(
                &field("scale"),
                format!("transform is not invertible (determinant {det})"),
            ));
        }
        keys.push((key.frame, TransformKey::from_trs(translate, rotate, scale)));
    }
    Ok(Some(Track { keys }))
}

/// The parameters a keyframe of each light type may set.
fn light_animatable(kind: &str) -> &'static [&'static str] {
    match kind {
        "point" => &["position", "intensity"],
        "spot" => &["position", "direction", "intensity"],
        "rect" => &["corner", "edge_u", "edge_v", "radiance"],
        "sun" => &["direction", "irradiance"],
        _ => &[],
    }
}

/// The track of light entry `i` (already parsed without error), if it has keyframes. Each
/// key is the static light with the keyframe's parameters replaced, validated like a light.
fn light_track(ctx: &Context, i: usize, def: &LightDef) -> Result<Option<Track<Light>>> {
    if def.keyframe.is_empty() {
        return Ok(None);
    }
    let prefix = format!("light[{i}]");
    check_frames(ctx, &prefix, def.keyframe.iter().map(|k| k.frame))?;
    let kind = def.kind.as_str();
    let animatable = light_animatable(kind);
    let mut keys = Vec::with_capacity(def.keyframe.len());
    for (j, key) in def.keyframe.iter().enumerate() {
        let key_prefix = format!("{prefix}.keyframe[{j}]");
        let given = [
            ("position", key.position.is_some()),
            ("direction", key.direction.is_some()),
            ("intensity", key.intensity.is_some()),
            ("corner", key.corner.is_some()),
            ("edge_u", key.edge_u.is_some()),
            ("edge_v", key.edge_v.is_some()),
            ("radiance", key.radiance.is_some()),
            ("irradiance", key.irradiance.is_some()),
        ];
        for (name, is_given) in given {
            if is_given && !animatable.contains(&name) {
                return Err(ctx.field_error(
                    &format!("{key_prefix}.{name}"),
                    format!(
                        "a {kind} light has no animatable parameter '{name}' (a keyframe may \
                         set: frame, {})",
                        animatable.join(", ")
                    ),
                ));
            }
        }
        let merged = LightDef {
            kind: def.kind.clone(),
            position: key.position.or(def.position),
            direction: key.direction.or(def.direction),
            intensity: key.intensity.or(def.intensity),
            inner_angle: def.inner_angle,
            outer_angle: def.outer_angle,
            corner: key.corner.or(def.corner),
            edge_u: key.edge_u.or(def.edge_u),
            edge_v: key.edge_v.or(def.edge_v),
            radiance: key.radiance.or(def.radiance),
            irradiance: key.irradiance.or(def.irradiance),
            keyframe: Vec::new(),
        };
        keys.push((key.frame, parse_light(ctx, &key_prefix, &merged)?));
    }
    check_not_opposite(ctx, &prefix, "direction", &keys, |light| match light {
        Light::Spot { direction, .. } | Light::Sun { direction, .. } => Some(*direction),
        _ => None,
    })?;
    Ok(Some(Track { keys }))
}

/// The camera's track, if `[camera]` has keyframes.
fn camera_track(ctx: &Context, def: &CameraDef) -> Result<Option<Track<CameraKey>>> {
    if def.keyframe.is_empty() {
        return Ok(None);
    }
    check_frames(ctx, "camera", def.keyframe.iter().map(|k| k.frame))?;
    let mut keys = Vec::with_capacity(def.keyframe.len());
    for (j, key) in def.keyframe.iter().enumerate() {
        let view = camera_view(
            ctx,
            &format!("camera.keyframe[{j}]"),
            key.position.unwrap_or(def.position),
            key.target.unwrap_or(def.target),
            key.up.or(def.up).unwrap_or(DEFAULT_UP),
            key.fov_y.unwrap_or(def.fov_y),
        )?;
        keys.push((key.frame, view));
    }
    check_not_opposite(ctx, "camera", "up", &keys, |key| Some(key.up))?;
    Ok(Some(Track { keys }))
}

/// The scene's animation: `None` without an `[animation]` table and without keyframes.
fn animation(
    ctx: &Context,
    def: Option<&AnimationDef>,
    instances: Vec<(usize, Track<TransformKey>)>,
    lights: Vec<(usize, LightTrack)>,
    camera: Option<Track<CameraKey>>,
) -> Result<Option<Animation>> {
    if def.is_none() && instances.is_empty() && lights.is_empty() && camera.is_none() {
        return Ok(None);
    }
    let fps = def.and_then(|d| d.fps).unwrap_or(25.0);
    if !(fps.is_finite() && fps > 0.0) {
        return Err(ctx.field_error(
            "animation.fps",
            format!("must be a positive number, got {fps}"),
        ));
    }
    let [first_frame, last_frame] = def.and_then(|d| d.frames).unwrap_or([0, 0]);
    if first_frame > last_frame {
        return Err(ctx.field_error(
            "animation.frames",
            format!("must be [first, last] with first <= last, got [{first_frame}, {last_frame}]"),
        ));
    }
    let temporal_accuracy = def.and_then(|d| d.temporal_accuracy);
    if let Some(a) = temporal_accuracy {
        if !(a.is_finite() && a > 0.0) {
            return Err(ctx.field_error(
                "animation.temporal_accuracy",
                format!("must be a positive number, got {a}"),
            ));
        }
    }
    let max_lifespan = def.and_then(|d| d.max_lifespan);
    if max_lifespan == Some(0) {
        return Err(ctx.field_error("animation.max_lifespan", "must be at least 1 frame"));
    }
    Ok(Some(Animation {
        fps,
        first_frame,
        last_frame,
        temporal_accuracy,
        max_lifespan,
        instances,
        lights,
        camera,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_column_counts_from_one() {
        let text = "a = 1\nbé = 2\n";
        assert_eq!(line_column(text, 0), (1, 1));
        assert_eq!(line_column(text, 6), (2, 1));
        assert_eq!(line_column(text, 10), (2, 4));
        assert_eq!(line_column(text, 1000), (3, 1));
    }

    #[test]
    fn locate_finds_array_of_tables_fields() {
        let text =
            "[camera]\nfov_y = 0\n\n[[mesh]]\nfile = \"a\"\n\n[[mesh]]\nfile = \"b\"\nscale = 0\n";
        let ctx = Context {
            path: Path::new("s.toml"),
            text,
        };
        let line = |field: &str| ctx.locate(field).map(|o| line_column(text, o).0);
        assert_eq!(line("camera.fov_y"), Some(2));
        assert_eq!(line("mesh[1].scale"), Some(9));
        assert_eq!(line("mesh[0].file"), Some(5));
        assert!(line("mesh[1].rotate").is_some_and(|l| l >= 7));
    }

    #[test]
    fn trs_order_is_t_rz_ry_rx_s() {
        let ctx = Context {
            path: Path::new("s.toml"),
            text: "",
        };
        let def = MeshDef {
            file: String::new(),
            name: None,
            translate: Some([1.0, 2.0, 3.0]),
            rotate: Some([90.0, 0.0, 90.0]),
            scale: Some(ScaleDef([2.0; 3])),
            matrix: None,
            keyframe: Vec::new(),
        };
        let m = mesh_transform(&ctx, 0, &def).unwrap();
        // x: scale 2 -> (2,0,0); Rx keeps it; Rz(90) -> (0,2,0); translate -> (1,4,3).
        let p = m.transform_point3(Vec3::X);
        assert!((p - Vec3::new(1.0, 4.0, 3.0)).length() < 1e-5, "{p}");
        // y: (0,2,0); Rx(90) -> (0,0,2); Rz keeps z -> (1,2,5).
        let p = m.transform_point3(Vec3::Y);
        assert!((p - Vec3::new(1.0, 2.0, 5.0)).length() < 1e-5, "{p}");
    }

    #[test]
    fn matrix_is_row_major() {
        let ctx = Context {
            path: Path::new("s.toml"),
            text: "",
        };
        let def = MeshDef {
            file: String::new(),
            name: None,
            translate: None,
            rotate: None,
            scale: None,
            matrix: Some([
                1.0, 0.0, 0.0, 5.0, 0.0, 1.0, 0.0, 6.0, 0.0, 0.0, 1.0, 7.0, 0.0, 0.0, 0.0, 1.0,
            ]),
            keyframe: Vec::new(),
        };
        let m = mesh_transform(&ctx, 0, &def).unwrap();
        assert_eq!(m.transform_point3(Vec3::ZERO), Vec3::new(5.0, 6.0, 7.0));
    }
}
