//! Scene loading: every kind of bad input gives an error naming the file and the line or
//! field; the bundled scenes load; Sponza loads when `RADSPLAT_ASSET_PATH` is set.

mod common;

use radsplat::Error;
use radsplat::scene::{Light, Scene, load_scene};
use std::path::{Path, PathBuf};

/// A fresh, empty directory for one test's files, removed when the test ends.
fn test_dir(test: &str) -> common::TestDir {
    common::TestDir::new(&format!("scene-tests-{test}"))
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write test file");
    path
}

/// Loads a scene that must fail, returning the error and its message.
fn load_error(path: &Path) -> (Error, String) {
    match load_scene(path) {
        Ok(_) => panic!("{} loaded, but an error was expected", path.display()),
        Err(e) => {
            let message = e.to_string();
            eprintln!("{message}");
            (e, message)
        }
    }
}

fn assert_mentions(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(
            message.contains(part),
            "error message should mention {part:?}:\n{message}"
        );
    }
}

const CAMERA: &str = "[camera]
position = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov_y = 40.0
resolution = [8, 8]
";

const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A scene with the standard camera and one mesh entry naming `obj`.
fn scene_with_mesh(dir: &Path, obj: &str) -> PathBuf {
    write(
        dir,
        "scene.toml",
        &format!("{CAMERA}\n[[mesh]]\nfile = \"{obj}\"\n"),
    )
}

fn manifest_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
}

// ---------------------------------------------------------------------------------------------
// Errors.

#[test]
fn missing_scene_file() {
    let dir = test_dir("missing-scene");
    let (e, message) = load_error(&dir.join("absent.toml"));
    assert!(matches!(e, Error::Io { .. }), "{e:?}");
    assert_mentions(&message, &["absent.toml", "cannot read"]);
}

#[test]
fn malformed_toml_names_line() {
    let dir = test_dir("malformed-toml");
    let path = write(
        &dir,
        "scene.toml",
        "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0,, 0]\n",
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "line 3"]);
}

#[test]
fn unknown_key_names_line_and_key() {
    let dir = test_dir("unknown-key");
    let text = CAMERA.replace("fov_y = 40.0", "fov_y = 40.0\nfovy = 40.0");
    let path = write(&dir, "scene.toml", &text);
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "line 5", "fovy"]);
}

#[test]
fn unknown_key_in_mesh_entry_names_line_and_key() {
    let dir = test_dir("unknown-mesh-key");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let path = write(
        &dir,
        "scene.toml",
        &format!("{CAMERA}\n[[mesh]]\nfile = \"tri.obj\"\nrotation = [0, 1, 0]\n"),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "line 9", "rotation"]);
}

#[test]
fn missing_obj_names_field() {
    let dir = test_dir("missing-obj");
    let path = scene_with_mesh(&dir, "models/nothere.obj");
    let (e, message) = load_error(&path);
    assert!(matches!(e, Error::AssetNotFound { .. }), "{e:?}");
    assert_mentions(
        &message,
        &["scene.toml", "mesh[0].file", "models/nothere.obj"],
    );
}

#[test]
fn missing_mtl_names_obj_and_mtllib() {
    let dir = test_dir("missing-mtl");
    write(
        &dir,
        "box.obj",
        &format!("# a triangle\nmtllib gone.mtl\n{TRIANGLE_OBJ}"),
    );
    let path = scene_with_mesh(&dir, "box.obj");
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["box.obj", "line 2", "mtllib", "gone.mtl"]);
}

#[test]
fn missing_texture_names_mtl_and_texture() {
    let dir = test_dir("missing-texture");
    write(
        &dir,
        "box.obj",
        &format!("mtllib box.mtl\nusemtl paint\n{TRIANGLE_OBJ}"),
    );
    write(
        &dir,
        "box.mtl",
        "newmtl paint\nKd 0.5 0.5 0.5\nmap_Kd textures/paint.png\n",
    );
    let path = scene_with_mesh(&dir, "box.obj");
    let (e, message) = load_error(&path);
    assert!(matches!(e, Error::AssetNotFound { .. }), "{e:?}");
    assert_mentions(
        &message,
        &["box.mtl", "line 3", "map_Kd", "textures/paint.png"],
    );
}

#[test]
fn nan_coordinate_names_v_line() {
    let dir = test_dir("nan-coordinate");
    write(
        &dir,
        "bad.obj",
        "# comment\nv 0 0 0\nvt 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n",
    );
    let path = scene_with_mesh(&dir, "bad.obj");
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["bad.obj", "line 4", "not finite"]);
}

#[test]
fn inf_coordinate_names_v_line() {
    let dir = test_dir("inf-coordinate");
    write(&dir, "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n");
    let path = scene_with_mesh(&dir, "bad.obj");
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["bad.obj", "line 3", "not finite"]);
}

/// A coordinate too far for f32 (near 1e19 the scene's diagonal overflowed and turned the
/// indirect light off without a word) names its line.
#[test]
fn far_coordinate_names_v_line() {
    let dir = test_dir("far-coordinate");
    write(
        &dir,
        "far.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv -1e20 0 -1e20\nf 1 2 3\n",
    );
    let path = scene_with_mesh(&dir, "far.obj");
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["far.obj", "line 4", "1e9"]);
}

/// A camera beyond f32's precision names its field (its distance to the target overflowed
/// and was reported as "must differ from camera.position").
#[test]
fn far_camera_names_its_field() {
    let dir = test_dir("far-camera");
    write(&dir, "t.obj", TRIANGLE_OBJ);
    let path = write(
        &dir,
        "scene.toml",
        "[camera]\nposition = [0.0, 0.0, 1e30]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 40.0\n\
         resolution = [8, 8]\n\n[[mesh]]\nfile = \"t.obj\"\n",
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "camera.position", "1e9"]);
}

/// MTL exponents that are not finite, or so large that the normalised lobe is no longer
/// exact in f32 (images 1e30 times too bright), name their line; so does a scene's
/// `exponent` override.
#[test]
fn unusable_phong_exponents_name_their_line() {
    let dir = test_dir("phong-exponent");
    write(
        &dir,
        "box.obj",
        &format!("mtllib box.mtl\nusemtl paint\n{TRIANGLE_OBJ}"),
    );
    for (ns, expect) in [
        ("inf", "not finite"),
        ("nan", "not finite"),
        ("1e38", "1e6"),
    ] {
        write(
            &dir,
            "box.mtl",
            &format!("newmtl paint\nKd 0.5 0.5 0.5\nKs 0.3 0.3 0.3\nNs {ns}\n"),
        );
        let path = scene_with_mesh(&dir, "box.obj");
        let (_, message) = load_error(&path);
        assert_mentions(&message, &["box.mtl", "line 4", "Ns", expect]);
    }
    write(
        &dir,
        "box.mtl",
        "newmtl paint\nKd 0.5 0.5 0.5\nKs 0.3 0.3 0.3\nNs 20\n",
    );
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[mesh]]\nfile = \"box.obj\"\n\n[[material]]\nname = \"paint\"\nexponent = 3e38\n"
        ),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "exponent", "1e6"]);
}

/// A scene file that is a device or FIFO is refused before it is read (`/dev/zero` took
/// the machine's memory, a FIFO blocked forever).
#[cfg(unix)]
#[test]
fn a_scene_that_is_not_a_regular_file_is_refused() {
    let (_, message) = load_error(Path::new("/dev/zero"));
    assert_mentions(&message, &["/dev/zero", "not a regular file"]);
    let dir = test_dir("fifo-scene");
    let fifo = dir.join("scene.toml");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        let (_, message) = load_error(&fifo);
        assert_mentions(&message, &["scene.toml", "not a regular file"]);
    }
}

#[test]
fn nan_normal_names_vn_line() {
    let dir = test_dir("nan-normal");
    write(
        &dir,
        "bad.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn nan 0 1\nf 1//1 2//2 3//1\n",
    );
    let path = scene_with_mesh(&dir, "bad.obj");
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["bad.obj", "line 5", "normal"]);
}

#[test]
fn face_index_out_of_range_names_line() {
    let dir = test_dir("face-index");
    write(
        &dir,
        "bad.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
    );
    let path = scene_with_mesh(&dir, "bad.obj");
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["bad.obj", "line 5", "vertex 7"]);
}

#[test]
fn malformed_obj_line_names_line() {
    let dir = test_dir("malformed-obj");
    write(&dir, "bad.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n");
    let path = scene_with_mesh(&dir, "bad.obj");
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["bad.obj", "line 2"]);
}

/// tobj panics on a colour with fewer than three numbers; we must report it instead.
#[test]
fn short_mtl_colour_names_line() {
    let dir = test_dir("short-colour");
    write(
        &dir,
        "box.obj",
        &format!("mtllib box.mtl\nusemtl paint\n{TRIANGLE_OBJ}"),
    );
    write(&dir, "box.mtl", "newmtl paint\nNs 10\nKd 0.5 0.5\n");
    let path = scene_with_mesh(&dir, "box.obj");
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["box.mtl", "line 3", "Kd"]);
}

#[test]
fn empty_scene_is_an_error() {
    let dir = test_dir("empty-scene");
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\n"
        ),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "scene has no geometry"]);
}

#[test]
fn obj_without_faces_is_an_error() {
    let dir = test_dir("no-faces");
    write(&dir, "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    let path = scene_with_mesh(&dir, "points.obj");
    let (_, message) = load_error(&path);
    assert_mentions(
        &message,
        &["scene.toml", "mesh[0].file", "points.obj", "no triangles"],
    );
}

#[test]
fn bad_camera_fov_names_field() {
    let dir = test_dir("bad-fov");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let text = CAMERA.replace("fov_y = 40.0", "fov_y = 0");
    let path = write(
        &dir,
        "scene.toml",
        &format!("{text}\n[[mesh]]\nfile = \"tri.obj\"\n"),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "camera.fov_y", "line 4"]);
}

#[test]
fn camera_up_parallel_to_view_names_field() {
    let dir = test_dir("bad-up");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let text = CAMERA.replace("fov_y = 40.0", "fov_y = 40.0\nup = [0, 0, -2]");
    let path = write(
        &dir,
        "scene.toml",
        &format!("{text}\n[[mesh]]\nfile = \"tri.obj\"\n"),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "camera.up", "parallel"]);
}

#[test]
fn non_invertible_transform_names_field() {
    let dir = test_dir("singular-transform");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[mesh]]\nfile = \"tri.obj\"\n\n\
             [[mesh]]\nfile = \"tri.obj\"\nscale = [1, 0, 1]\n"
        ),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["scene.toml", "mesh[1].scale", "not invertible"]);
}

#[test]
fn matrix_with_trs_names_field() {
    let dir = test_dir("matrix-and-trs");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[mesh]]\nfile = \"tri.obj\"\ntranslate = [1, 0, 0]\n\
             matrix = [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]\n"
        ),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["mesh[0].matrix", "cannot be combined"]);
}

#[test]
fn light_parameter_of_other_type_names_field() {
    let dir = test_dir("light-parameter");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[mesh]]\nfile = \"tri.obj\"\n\n[[light]]\ntype = \"point\"\n\
             position = [0, 1, 0]\nintensity = [1, 1, 1]\nradiance = [1, 1, 1]\n"
        ),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["light[0].radiance", "point light"]);
}

#[test]
fn negative_light_radiance_names_field() {
    let dir = test_dir("negative-radiance");
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[light]]\ntype = \"rect\"\ncorner = [0, 1, 0]\nedge_u = [1, 0, 0]\n\
             edge_v = [0, 0, 1]\nradiance = [1, -1, 1]\n"
        ),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["light[0].radiance", "negative"]);
}

#[test]
fn override_of_unknown_material_names_field() {
    let dir = test_dir("unknown-material");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[mesh]]\nfile = \"tri.obj\"\n\n[[material]]\nname = \"marble\"\n\
             albedo = [0.5, 0.5, 0.5]\n"
        ),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["material[0].name", "marble", "__default"]);
}

// ---------------------------------------------------------------------------------------------
// Scenes that load.

fn rect_light_mesh_emission(scene: &Scene) -> Vec<[f32; 3]> {
    scene
        .instances
        .iter()
        .flat_map(|instance| {
            let mesh = &scene.meshes[instance.mesh as usize];
            mesh.material_ids
                .iter()
                .map(|&m| &scene.materials[m as usize])
                .filter(|m| m.name.starts_with("__rect_light_"))
                .map(|m| m.emission.to_array())
        })
        .collect()
}

/// Checks the invariants the renderer relies on.
fn check_consistent(scene: &Scene) {
    for mesh in &scene.meshes {
        let n = mesh.positions.len();
        assert_eq!(mesh.normals.len(), n, "{}", mesh.name);
        assert_eq!(mesh.uvs.len(), n, "{}", mesh.name);
        assert_eq!(mesh.indices.len(), mesh.material_ids.len(), "{}", mesh.name);
        assert!(mesh.positions.iter().all(|p| p.is_finite()));
        assert!(
            mesh.normals
                .iter()
                .all(|v| *v == glam::Vec3::ZERO || (v.length() - 1.0).abs() < 1e-4)
        );
        assert!(mesh.indices.iter().flatten().all(|&i| (i as usize) < n));
        assert!(
            mesh.material_ids
                .iter()
                .all(|&m| (m as usize) < scene.materials.len())
        );
    }
    assert!(
        scene
            .instances
            .iter()
            .all(|i| (i.mesh as usize) < scene.meshes.len())
    );
    for material in &scene.materials {
        if let Some(t) = material.albedo_texture {
            assert!((t as usize) < scene.textures.len());
        }
    }
    for texture in &scene.textures {
        assert_eq!(
            texture.texels.len(),
            (texture.width * texture.height) as usize
        );
    }
}

#[test]
fn cornell_box_loads() {
    let scene = load_scene(&manifest_path("scenes/cornell-box.toml")).expect("cornell box");
    check_consistent(&scene);
    // 5 walls + 2 blocks of 5 faces, as quads, and the light's two triangles: in the one
    // mesh, which the light's quad joins (the scene stays one instance).
    assert_eq!(scene.triangle_count(), 15 * 2 + 2);
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(
        (scene.camera.width, scene.camera.height),
        (256, 256),
        "resolution"
    );
    assert_eq!(scene.settings.light_samples, 16);
    assert!(matches!(scene.lights.as_slice(), [Light::Rect { .. }]));
    assert_eq!(rect_light_mesh_emission(&scene), vec![[17.0, 12.0, 4.0]; 2]);
    let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["white", "red", "green", "__rect_light_0"]);
}

#[test]
fn rect_light_mesh_faces_along_light_normal() {
    let scene = load_scene(&manifest_path("scenes/cornell-box.toml")).expect("cornell box");
    let Light::Rect { edge_u, edge_v, .. } = scene.lights[0] else {
        panic!("expected a rect light");
    };
    let normal = edge_u.cross(edge_v).normalize();
    assert!(
        (normal - glam::Vec3::NEG_Y).length() < 1e-6,
        "light faces down"
    );
    let mesh = &scene.meshes[scene.instances[0].mesh as usize];
    let quad = mesh
        .indices
        .iter()
        .zip(&mesh.material_ids)
        .filter(|(_, m)| scene.materials[**m as usize].name == "__rect_light_0")
        .map(|(t, _)| *t)
        .collect::<Vec<_>>();
    assert_eq!(quad.len(), 2);
    for &[a, b, c] in &quad {
        let p = |i: u32| mesh.positions[i as usize];
        let geometric = (p(b) - p(a)).cross(p(c) - p(a)).normalize();
        assert!(
            (geometric - normal).length() < 1e-5,
            "{geometric} vs {normal}"
        );
    }
}

/// A static rect light's quad joins the scene's one mesh when that mesh is placed as
/// modelled and never moves (the scene stays one instance, which rays traverse faster);
/// otherwise, or when the light moves, the quad is an instance of its own. Either way the
/// quad is the same two triangles.
#[test]
fn rect_light_quads_join_a_single_static_mesh() {
    let dir = test_dir("quad-join");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let light = "[[light]]\ntype = \"rect\"\ncorner = [0, 1, 0]\nedge_u = [1, 0, 0]\n\
                 edge_v = [0, 0, 1]\nradiance = [2, 2, 2]\n";
    let moving_light = format!("{light}[[light.keyframe]]\nframe = 3\ncorner = [0, 2, 0]\n");
    let cases = [
        ("[[mesh]]\nfile = \"tri.obj\"\n", light.to_string(), 1),
        (
            "[[mesh]]\nfile = \"tri.obj\"\ntranslate = [1, 0, 0]\n",
            light.to_string(),
            2,
        ),
        (
            "[[mesh]]\nfile = \"tri.obj\"\n[[mesh.keyframe]]\nframe = 0\n\
             [[mesh.keyframe]]\nframe = 2\ntranslate = [1, 0, 0]\n",
            light.to_string(),
            2,
        ),
        ("[[mesh]]\nfile = \"tri.obj\"\n", moving_light, 2),
        (
            "[[mesh]]\nfile = \"tri.obj\"\n[[mesh]]\nfile = \"tri.obj\"\n",
            light.to_string(),
            3,
        ),
    ];
    let mut quads = Vec::new();
    for (meshes, lights, instances) in cases {
        let path = write(&dir, "scene.toml", &format!("{CAMERA}\n{meshes}\n{lights}"));
        let scene = load_scene(&path).unwrap_or_else(|e| panic!("{meshes}{lights}: {e}"));
        check_consistent(&scene);
        assert_eq!(scene.instances.len(), instances, "{meshes}{lights}");
        let joined = instances == 1;
        assert_eq!(scene.meshes.len(), if joined { 1 } else { 2 }, "{meshes}");
        // The OBJ's triangles first, then the quad's, whichever mesh holds them.
        let mut quad = Vec::new();
        for instance in &scene.instances {
            let mesh = &scene.meshes[instance.mesh as usize];
            for (t, m) in mesh.indices.iter().zip(&mesh.material_ids) {
                if scene.materials[*m as usize]
                    .name
                    .starts_with("__rect_light_")
                {
                    quad.push(t.map(|i| mesh.positions[i as usize]));
                }
            }
        }
        assert_eq!(rect_light_mesh_emission(&scene), vec![[2.0, 2.0, 2.0]; 2]);
        if joined {
            assert_eq!(
                scene.meshes[0].indices[0],
                [0, 1, 2],
                "the OBJ's triangle first"
            );
        }
        quads.push(quad);
    }
    assert_eq!(quads[0], quads[1], "the same quad joined or not");
}

#[test]
fn cube_in_box_loads() {
    let scene = load_scene(&manifest_path("scenes/cube-in-box.toml")).expect("cube in box");
    check_consistent(&scene);
    assert_eq!(scene.triangle_count(), 12 + 12 + 2);
    assert_eq!(scene.meshes.len(), 3);
    assert_eq!(scene.meshes[scene.instances[1].mesh as usize].name, "cube");
    let translation = scene.instances[1].transform.w_axis.truncate();
    assert_eq!(translation, glam::Vec3::new(0.4, 0.0, -0.3));
    // room.obj and cube.obj share cube-in-box.mtl: its 5 materials appear once.
    assert_eq!(scene.materials.len(), 5 + 1);
    assert_eq!(
        rect_light_mesh_emission(&scene),
        vec![[20.0, 19.0, 17.0]; 2]
    );
}

#[test]
fn obj_used_twice_is_loaded_once() {
    let dir = test_dir("shared-obj");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[mesh]]\nfile = \"tri.obj\"\n\n[[mesh]]\nfile = \"./tri.obj\"\n\
             translate = [2, 0, 0]\nscale = 2\n"
        ),
    );
    let scene = load_scene(&path).expect("scene");
    check_consistent(&scene);
    assert_eq!(scene.meshes.len(), 1);
    assert_eq!(scene.instances.len(), 2);
    assert_eq!(scene.triangle_count(), 2);
    assert_eq!(scene.materials.len(), 1);
    assert_eq!(scene.materials[0].name, "__default");
}

#[test]
fn textures_are_shared_downsampled_and_overridable() {
    let dir = test_dir("textures");
    image::RgbaImage::from_pixel(4096, 8, image::Rgba([10, 20, 30, 255]))
        .save(dir.join("wide.png"))
        .expect("write png");
    image::RgbaImage::from_pixel(2, 1, image::Rgba([200, 100, 50, 255]))
        .save(dir.join("small.png"))
        .expect("write png");
    write(
        &dir,
        "two.obj",
        "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl a\nf 1 2 3\n\
         usemtl b\nf 2 4 3\nusemtl c\nf 1 2 4\n",
    );
    write(
        &dir,
        "two.mtl",
        "newmtl a\nmap_Kd wide.png\nnewmtl b\nKd 0.5 0.5 0.5\nmap_Kd ./wide.png\n\
         newmtl c\nKd 2 0.5 -1\nKe 1 2 3\nmap_Kd small.png\n",
    );
    let path = write(
        &dir,
        "scene.toml",
        &format!(
            "{CAMERA}\n[[mesh]]\nfile = \"two.obj\"\n\n[[material]]\nname = \"c\"\n\
             texture = \"\"\nalbedo = [0.25, 0.5, 0.75]\n"
        ),
    );
    let scene = load_scene(&path).expect("scene");
    check_consistent(&scene);
    assert_eq!(scene.textures.len(), 1, "wide.png once; small.png removed");
    let texture = &scene.textures[0];
    assert_eq!((texture.width, texture.height), (2048, 4));
    assert_eq!(texture.texels[0], [10, 20, 30, 255]);
    let [a, b, c] = [0, 1, 2].map(|i| &scene.materials[i]);
    assert_eq!((a.albedo_texture, b.albedo_texture), (Some(0), Some(0)));
    assert_eq!(a.albedo, glam::Vec3::ONE, "no Kd with a texture");
    assert_eq!(b.albedo, glam::Vec3::splat(0.5));
    assert_eq!(c.albedo_texture, None);
    assert_eq!(c.albedo, glam::Vec3::new(0.25, 0.5, 0.75));
    assert_eq!(c.emission, glam::Vec3::new(1.0, 2.0, 3.0));
}

#[test]
fn degenerate_triangles_and_bad_normals_are_fixed_not_rejected() {
    let dir = test_dir("degenerate");
    write(
        &dir,
        "mesh.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nvn 0 0 0\nvn 0 0 3\n\
         f 1//2 2//2 3//2\nf 1//1 2//1 4//1\nf 1//2 1//2 3//2\n",
    );
    let path = scene_with_mesh(&dir, "mesh.obj");
    let scene = load_scene(&path).expect("scene");
    check_consistent(&scene);
    assert_eq!(scene.triangle_count(), 1);
    let mesh = &scene.meshes[0];
    assert!(mesh.normals.contains(&glam::Vec3::Z));
    assert!(mesh.normals.contains(&glam::Vec3::ZERO));
}

// ---------------------------------------------------------------------------------------------
// Sponza (third-party, found along RADSPLAT_ASSET_PATH).

/// Triangles of the Dabrovic Sponza OBJ (every face is a triangle).
const SPONZA_TRIANGLES: usize = 66_454;

#[test]
fn sponza_loads_when_asset_path_set() {
    if std::env::var_os(radsplat::scene::asset_path::ASSET_PATH_VAR).is_none() {
        eprintln!(
            "sponza_loads_when_asset_path_set: RADSPLAT_ASSET_PATH is not set, test did not run"
        );
        return;
    }
    let scene_path = manifest_path("scenes/sponza.toml");
    let start = std::time::Instant::now();
    let scene = load_scene(&scene_path).expect("sponza must load when RADSPLAT_ASSET_PATH is set");
    let elapsed = start.elapsed();
    check_consistent(&scene);

    let obj = radsplat::scene::asset_path::resolve_asset(
        &scene_path,
        "mesh[0].file",
        "dabrovic-sponza/sponza.obj",
    )
    .expect("sponza.obj");
    let data = radsplat::scene::obj::load_obj(&obj).expect("sponza.obj loads");
    eprintln!(
        "sponza: {} triangles in {elapsed:?}; {:?}; {} materials; {} textures: {:?}",
        scene.triangle_count(),
        data.stats,
        scene.materials.len(),
        scene.textures.len(),
        scene
            .textures
            .iter()
            .map(|t| format!(
                "{} {}x{}",
                t.path.file_name().unwrap_or_default().to_string_lossy(),
                t.width,
                t.height
            ))
            .collect::<Vec<_>>()
    );
    assert_eq!(data.stats.triangles_read, SPONZA_TRIANGLES);
    assert_eq!(data.stats.degenerate_dropped, SPONZA_DEGENERATE);
    assert_eq!(scene.triangle_count(), SPONZA_TRIANGLES - SPONZA_DEGENERATE);
    // sponza.mtl defines 20 materials; all faces have one.
    assert_eq!(scene.materials.len(), 20);
    // 12 distinct map_Kd files in sponza.mtl.
    assert_eq!(scene.textures.len(), 12);
    assert!(matches!(scene.lights.as_slice(), [Light::Sun { .. }]));
}

/// Degenerate triangles in the Dabrovic Sponza OBJ (measured: one zero-area face, line 233201).
const SPONZA_DEGENERATE: usize = 1;

// ---------------------------------------------------------------------------------------------
// Untrusted sizes and nonsense input (issue 16).

/// CRC-32 (IEEE) of PNG chunks, so a test can rewrite a PNG header and keep it valid.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A valid 2x2 PNG whose IHDR then claims `width x height` (CRC fixed, so only the size
/// lies).
fn lying_png(width: u32, height: u32) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]))
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .expect("encode png");
    // Signature (8), IHDR length (4), "IHDR" (4), width, height, 5 more bytes, CRC.
    assert_eq!(&bytes[12..16], b"IHDR");
    bytes[16..20].copy_from_slice(&width.to_be_bytes());
    bytes[20..24].copy_from_slice(&height.to_be_bytes());
    let crc = crc32(&bytes[12..29]);
    bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    bytes
}

/// A scene whose one mesh uses a material textured with `texture`.
fn scene_with_texture(dir: &Path, texture: &str) -> PathBuf {
    write(
        dir,
        "box.obj",
        &format!("mtllib box.mtl\nusemtl paint\n{TRIANGLE_OBJ}"),
    );
    write(dir, "box.mtl", &format!("newmtl paint\nmap_Kd {texture}\n"));
    scene_with_mesh(dir, "box.obj")
}

#[test]
fn texture_whose_header_lies_is_refused_before_decoding() {
    let dir = test_dir("lying-png");
    // Above the cap: refused whatever the file holds.
    std::fs::write(dir.join("huge.png"), lying_png(100_000, 100_000)).expect("write");
    let start = std::time::Instant::now();
    let (_, message) = load_error(&scene_with_texture(&dir, "huge.png"));
    assert_mentions(&message, &["huge.png", "PNG", "100000x100000", "at most"]);
    // Within the cap, but the 2x2 image's bytes cannot hold 16000x16000 pixels.
    std::fs::write(dir.join("big.png"), lying_png(16_000, 16_000)).expect("write");
    let (_, message) = load_error(&scene_with_texture(&dir, "big.png"));
    assert_mentions(
        &message,
        &["big.png", "16000x16000", "need at least", "the file holds"],
    );
    // Neither decoded a single pixel: both refusals are immediate.
    assert!(start.elapsed().as_secs() < 5, "{:?}", start.elapsed());
    // The honest image still loads.
    std::fs::write(dir.join("ok.png"), lying_png(2, 2)).expect("write");
    load_scene(&scene_with_texture(&dir, "ok.png")).expect("a valid 2x2 PNG texture loads");
}

#[test]
fn texture_that_is_not_png_or_jpeg_is_named() {
    let dir = test_dir("hdr-texture");
    write(
        &dir,
        "sky.hdr",
        "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n\u{1}\u{1}\u{1}\u{1}",
    );
    let (_, message) = load_error(&scene_with_texture(&dir, "sky.hdr"));
    assert_mentions(&message, &["sky.hdr", "PNG or JPEG"]);
}

#[test]
fn obj_with_absurd_indices_is_refused_by_line() {
    let dir = test_dir("absurd-indices");
    // No vertices at all, but a face claiming vertex 4e9: nothing may be sized by it.
    write(&dir, "empty.obj", "f 4000000000 1 2\n");
    let (_, message) = load_error(&scene_with_mesh(&dir, "empty.obj"));
    assert_mentions(
        &message,
        &["empty.obj", "line 1", "4000000000", "0 'v' lines"],
    );
    // An index beyond any integer type.
    write(
        &dir,
        "huge.obj",
        &format!("{TRIANGLE_OBJ}f 1 2 99999999999999999999999\n"),
    );
    let (_, message) = load_error(&scene_with_mesh(&dir, "huge.obj"));
    assert_mentions(&message, &["huge.obj", "line 5", "not an index"]);
    // A negative index reaching before the first vertex.
    write(
        &dir,
        "neg.obj",
        &format!("{TRIANGLE_OBJ}f -1 -2 -4000000000\n"),
    );
    let (_, message) = load_error(&scene_with_mesh(&dir, "neg.obj"));
    assert_mentions(&message, &["neg.obj", "line 5", "-4000000000"]);
}

/// Bytes that are not text: a fixed pseudo-random sequence (the same every run).
fn random_bytes(n: usize) -> Vec<u8> {
    let mut x = 0x2545_f491_4f6c_dd1du64;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 32) as u8
        })
        .collect()
}

#[test]
fn mtl_of_random_bytes_is_an_error_naming_the_mtl() {
    let dir = test_dir("random-mtl");
    write(
        &dir,
        "box.obj",
        &format!("mtllib box.mtl\nusemtl paint\n{TRIANGLE_OBJ}"),
    );
    std::fs::write(dir.join("box.mtl"), random_bytes(512)).expect("write");
    let (_, message) = load_error(&scene_with_mesh(&dir, "box.obj"));
    assert_mentions(&message, &["box.mtl", "line 1", "not an OBJ/MTL text file"]);

    // An OBJ of random bytes likewise.
    std::fs::write(dir.join("noise.obj"), random_bytes(512)).expect("write");
    let (_, message) = load_error(&scene_with_mesh(&dir, "noise.obj"));
    assert_mentions(
        &message,
        &["noise.obj", "line 1", "not an OBJ/MTL text file"],
    );
}

#[test]
fn mtl_without_materials_used_by_the_obj_is_an_error() {
    let dir = test_dir("empty-mtl");
    write(
        &dir,
        "box.obj",
        &format!("mtllib box.mtl\n{TRIANGLE_OBJ}usemtl paint\nf 1 3 2\n"),
    );
    // Text, but only statements tobj does not know: no material at all.
    write(&dir, "box.mtl", "# exported by something\nfoo 1 2 3\nbar\n");
    let (_, message) = load_error(&scene_with_mesh(&dir, "box.obj"));
    assert_mentions(
        &message,
        &["box.mtl", "no materials", "box.obj", "line 6", "'paint'"],
    );
    // An empty library is fine when the OBJ uses no material from it.
    write(
        &dir,
        "plain.obj",
        &format!("mtllib box.mtl\n{TRIANGLE_OBJ}"),
    );
    load_scene(&scene_with_mesh(&dir, "plain.obj")).expect("no usemtl: the empty MTL is unused");
}

#[test]
fn light_values_near_f32_max_are_refused() {
    let dir = test_dir("huge-radiance");
    write(&dir, "tri.obj", TRIANGLE_OBJ);
    let mesh = "\n[[mesh]]\nfile = \"tri.obj\"\n";
    let cases = [
        (
            "type = \"rect\"\ncorner = [0, 1, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 0, 1]\n\
             radiance = [3.0e38, 3.0e38, 3.0e38]\n",
            "light[0].radiance",
        ),
        (
            "type = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 3.4e38, 1]\n",
            "light[0].intensity",
        ),
        (
            // Each edge is fine, the radiance too, but radiance x area overflows.
            "type = \"rect\"\ncorner = [0, 1, 0]\nedge_u = [1e9, 0, 0]\nedge_v = [0, 0, 1e9]\n\
             radiance = [1e15, 1e15, 1e15]\n",
            "light[0].radiance",
        ),
    ];
    for (light, field) in cases {
        let path = write(
            &dir,
            "scene.toml",
            &format!("{CAMERA}{mesh}\n[[light]]\n{light}"),
        );
        let (_, message) = load_error(&path);
        assert_mentions(&message, &["scene.toml", field, "too large"]);
    }
    let path = write(
        &dir,
        "scene.toml",
        &format!("{CAMERA}{mesh}\n[environment]\nradiance = [1, 1, 3e38]\n"),
    );
    let (_, message) = load_error(&path);
    assert_mentions(&message, &["environment.radiance", "too large"]);
}

// Keyframes that are each valid but interpolate through a degenerate state: refused at load,
// naming the frame, the field and the two keyframes.

fn animated_scene(dir: &Path, body: &str) -> PathBuf {
    write(dir, "tri.obj", TRIANGLE_OBJ);
    write(
        dir,
        "scene.toml",
        &format!("{CAMERA}\n[animation]\nframes = [0, 10]\n\n{body}"),
    )
}

#[test]
fn scale_through_zero_is_refused_with_the_frame() {
    let dir = test_dir("scale-through-zero");
    let path = animated_scene(
        &dir,
        "[[mesh]]\nfile = \"tri.obj\"\n\
         [[mesh.keyframe]]\nframe = 0\nscale = [1, 1, 1]\n\
         [[mesh.keyframe]]\nframe = 10\nscale = [1, -1, 1]\n",
    );
    let (_, message) = load_error(&path);
    assert_mentions(
        &message,
        &[
            "scene.toml",
            "frame 5",
            "mesh[0].scale",
            "singular",
            "mesh[0].keyframe[0]",
            "mesh[0].keyframe[1]",
        ],
    );
}

#[test]
fn rect_light_edge_through_zero_is_refused_with_the_frame() {
    let dir = test_dir("edge-through-zero");
    let path = animated_scene(
        &dir,
        "[[mesh]]\nfile = \"tri.obj\"\n\n\
         [[light]]\ntype = \"rect\"\ncorner = [0, 1, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 0, 1]\n\
         radiance = [5, 5, 5]\n\
         [[light.keyframe]]\nframe = 2\n\
         [[light.keyframe]]\nframe = 8\nedge_u = [-1, 0, 0]\n",
    );
    let (_, message) = load_error(&path);
    assert_mentions(
        &message,
        &[
            "frame 5",
            "light[0].edge_u",
            "no area",
            "light[0].keyframe[0] at frame 2",
            "light[0].keyframe[1] at frame 8",
        ],
    );
}

#[test]
fn camera_view_through_up_is_refused_with_the_frame() {
    let dir = test_dir("view-through-up");
    // The camera passes over the target: at frame 5 it looks straight down, along -up.
    let path = animated_scene(
        &dir,
        "[[mesh]]\nfile = \"tri.obj\"\n\n\
         [[camera.keyframe]]\nframe = 0\nposition = [0, 5, 5]\n\
         [[camera.keyframe]]\nframe = 10\nposition = [0, 5, -5]\n",
    );
    let (_, message) = load_error(&path);
    assert_mentions(
        &message,
        &["frame 5", "camera.up", "parallel to the view direction"],
    );
}

#[test]
fn frame_checks_cover_sub_frames_and_explicit_ranges() {
    let dir = test_dir("sub-frame");
    // The zero crossing is at frame 0.5: no integer frame is degenerate, so the scene loads,
    // but evaluating that instant is refused and leaves the scene where it was.
    let path = animated_scene(
        &dir,
        "[[mesh]]\nfile = \"tri.obj\"\n\
         [[mesh.keyframe]]\nframe = 0\nscale = 1\n\
         [[mesh.keyframe]]\nframe = 1\nscale = -1\n",
    );
    let mut scene = load_scene(&path).expect("integer frames are all valid");
    scene
        .check_frames(0..=10)
        .expect("integer frames are valid");
    let before = scene.instances[0].transform;
    let message = scene.try_set_frame(0.5).expect_err("singular").to_string();
    assert_mentions(&message, &["frame 0.5", "mesh[0].scale"]);
    assert_eq!(scene.instances[0].transform, before);
    scene.try_set_frame(1.0).expect("a key is valid");
    assert_ne!(scene.instances[0].transform, before);
}

#[test]
fn a_huge_keyframe_span_loads_without_evaluating_every_frame() {
    let dir = test_dir("huge-span");
    // A billion frames between two keys: loading checks a bounded number of them, and
    // the frames beyond are checked when asked for.
    let path = animated_scene(
        &dir,
        "[[mesh]]\nfile = \"tri.obj\"\n\
         [[mesh.keyframe]]\nframe = 0\nscale = 1\n\
         [[mesh.keyframe]]\nframe = 1e9\nscale = -1\n",
    );
    let start = std::time::Instant::now();
    let scene = load_scene(&path).expect("the first 2^18 frames are valid");
    eprintln!("loaded in {:?}", start.elapsed());
    assert!(start.elapsed().as_secs() < 60, "{:?}", start.elapsed());
    let message = scene
        .check_frame(5e8)
        .expect_err("scale 0 at frame 5e8")
        .to_string();
    assert_mentions(&message, &["frame 500000000", "mesh[0].scale", "singular"]);
}
