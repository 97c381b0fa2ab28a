//! Keyframed animation in scene files: parsing, interpolated values, the `Scene` frame API,
//! errors naming the file and field, and the bundled animated scenes.

mod common;

use glam::{Mat4, Vec3};
use radsplat::scene::{Light, Scene, load_scene};
use std::path::{Path, PathBuf};

/// A fresh, empty directory for one test's files, removed when the test ends.
fn test_dir(test: &str) -> common::TestDir {
    common::TestDir::new(&format!("animation-tests-{test}"))
}

const CAMERA: &str = "[camera]
position = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov_y = 40.0
resolution = [8, 8]
";

const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// Writes `tri.obj` and a scene of the standard camera followed by `body`; the directory
/// goes when the returned guard does.
fn scene_file(test: &str, body: &str) -> (common::TestDir, PathBuf) {
    let dir = test_dir(test);
    std::fs::write(dir.join("tri.obj"), TRIANGLE_OBJ).expect("write obj");
    let path = dir.join("scene.toml");
    std::fs::write(&path, format!("{CAMERA}\n{body}")).expect("write scene");
    (dir, path)
}

fn load(test: &str, body: &str) -> Scene {
    let (_dir, path) = scene_file(test, body);
    load_scene(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Loads a scene that must fail and checks that its message names every one of `parts`.
fn assert_error(test: &str, body: &str, parts: &[&str]) {
    let (_dir, path) = scene_file(test, body);
    let message = match load_scene(&path) {
        Ok(_) => panic!("{} loaded, but an error was expected", path.display()),
        Err(e) => e.to_string(),
    };
    eprintln!("{message}");
    for part in ["scene.toml"].iter().chain(parts) {
        assert!(
            message.contains(part),
            "error message should mention {part:?}:\n{message}"
        );
    }
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

/// One mesh turning 90° about y and moving from the origin to (2, 4, 6) over frames 0..10,
/// with a static scale of 2 that the keyframes do not mention.
const TURNING_MESH: &str = "[[mesh]]
file = \"tri.obj\"
scale = 2

[[mesh.keyframe]]
frame = 0
translate = [0, 0, 0]

[[mesh.keyframe]]
frame = 10
translate = [2, 4, 6]
rotate = [0, 90, 0]
";

#[test]
fn mesh_keyframes_interpolate_linearly_and_slerp() {
    let scene = load("mesh-interpolation", TURNING_MESH);
    let at = |frame: f32| scene.instance_transform_at(0, frame);
    // Linear midpoint of the translation.
    assert!(close(at(5.0).w_axis.truncate(), Vec3::new(1.0, 2.0, 3.0)));
    // Slerp midpoint of a 90° turn is 45°; the static scale 2 applies to every key.
    let x = at(5.0).transform_vector3(Vec3::X);
    let half = std::f32::consts::FRAC_1_SQRT_2 * 2.0;
    assert!(close(x, Vec3::new(half, 0.0, -half)), "{x}");
    let x = at(2.5).transform_vector3(Vec3::X) / 2.0;
    let angle = x.z.atan2(x.x).to_degrees();
    assert!((angle + 22.5).abs() < 1e-3, "{angle}");
    // Held before the first and after the last keyframe.
    assert!(at(-3.0).abs_diff_eq(Mat4::from_scale(Vec3::splat(2.0)), 1e-6));
    assert!(at(0.0).abs_diff_eq(at(-100.0), 0.0));
    assert!(at(10.0).abs_diff_eq(at(1e6), 0.0));
    assert!(close(at(25.0).w_axis.truncate(), Vec3::new(2.0, 4.0, 6.0)));
    assert!(close(
        at(25.0).transform_vector3(Vec3::X),
        Vec3::new(0.0, 0.0, -2.0)
    ));
}

#[test]
fn keyframes_without_animation_table_get_defaults() {
    let scene = load("animation-defaults", TURNING_MESH);
    let animation = scene
        .animation
        .as_ref()
        .expect("keyframes make an animation");
    assert_eq!(animation.fps, 25.0);
    assert_eq!((animation.first_frame, animation.last_frame), (0, 0));
    assert_eq!(scene.frames(), 0..=0);
    assert!(scene.instance_is_animated(0));
    assert!(!scene.lights_are_animated());
    assert!(!scene.camera_is_animated());
}

#[test]
fn loaded_scene_is_at_its_first_frame_and_set_frame_matches_evaluation() {
    let body = format!(
        "[animation]\nfps = 30\nframes = [4, 8]\n\n{TURNING_MESH}\n\
         [[mesh]]\nfile = \"tri.obj\"\ntranslate = [0, 0, -1]\n\n\
         [[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\n\n\
         [[light.keyframe]]\nframe = 0\n\n\
         [[light.keyframe]]\nframe = 8\nposition = [0, 3, 0]\nintensity = [5, 5, 5]\n\n\
         [[camera.keyframe]]\nframe = 0\nfov_y = 30\n\n\
         [[camera.keyframe]]\nframe = 8\nfov_y = 50\nposition = [0, 0, 9]\n"
    );
    let mut scene = load("set-frame", &body);
    assert_eq!(scene.frames(), 4..=8);
    assert_eq!(scene.animation.as_ref().map(|a| a.fps), Some(30.0));
    assert!(scene.instance_is_animated(0));
    assert!(!scene.instance_is_animated(1));
    assert!(scene.lights_are_animated());
    assert!(scene.camera_is_animated());

    // After loading: frame 4.
    let check = |scene: &Scene, frame: f32| {
        for i in 0..scene.instances.len() {
            assert_eq!(
                scene.instances[i].transform,
                scene.instance_transform_at(i, frame)
            );
        }
        assert_eq!(scene.lights, scene.lights_at(frame));
        assert_eq!(scene.camera, scene.camera_at(frame));
    };
    check(&scene, 4.0);
    assert!(close(
        scene.instances[0].transform.w_axis.truncate(),
        Vec3::new(0.8, 1.6, 2.4)
    ));
    assert_eq!(scene.camera.fov_y_degrees, 40.0);

    scene.set_frame(6.0);
    check(&scene, 6.0);
    // Point light: omitted fields of keyframe 0 are the static ones.
    assert_eq!(
        scene.lights,
        vec![Light::Point {
            position: Vec3::new(0.0, 2.5, 0.0),
            intensity: Vec3::splat(4.0),
        }]
    );
    assert_eq!(scene.camera.fov_y_degrees, 45.0);
    assert!(close(scene.camera.position, Vec3::new(0.0, 0.0, 8.0)));
    assert_eq!((scene.camera.width, scene.camera.height), (8, 8));
    // The unanimated instance keeps its static transform.
    assert_eq!(
        scene.instances[1].transform,
        Mat4::from_translation(Vec3::new(0.0, 0.0, -1.0))
    );
}

#[test]
fn set_frame_on_a_static_scene_changes_nothing() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cube-in-box.toml");
    let mut scene = load_scene(&path).expect("cube in box");
    assert!(scene.animation.is_none());
    assert_eq!(scene.frames(), 0..=0);
    let before = scene.clone();
    scene.set_frame(17.5);
    assert_eq!(scene.lights, before.lights);
    assert_eq!(scene.camera, before.camera);
    assert_eq!(scene.materials, before.materials);
    for (i, (a, b)) in scene.instances.iter().zip(&before.instances).enumerate() {
        assert_eq!(a.transform, b.transform);
        assert_eq!(scene.instance_transform_at(i, 3.0), b.transform);
        assert!(!scene.instance_is_animated(i));
    }
    assert_eq!(scene.lights_at(3.0), before.lights);
    assert_eq!(scene.camera_at(3.0), before.camera);
    assert!(!scene.lights_are_animated());
}

#[test]
fn animated_rect_light_moves_its_quad_and_emission() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[light]]\ntype = \"rect\"\ncorner = [0, 2, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 0, 1]\n\
        radiance = [1, 1, 1]\n\n\
        [[light.keyframe]]\nframe = 0\n\n\
        [[light.keyframe]]\nframe = 10\ncorner = [4, 3, 0]\nedge_u = [0, 0, 2]\n\
        edge_v = [-1, 0, 0]\nradiance = [3, 3, 3]\n";
    let mut scene = load("rect-light", body);
    let quad = 1; // instances: the mesh entry, then the light's quad
    assert!(scene.instance_is_animated(quad));
    assert!(scene.lights_are_animated());
    scene.set_frame(10.0);
    let mesh = &scene.meshes[scene.instances[quad].mesh as usize];
    let world: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|&p| scene.instances[quad].transform.transform_point3(p))
        .collect();
    let (c, u, v) = (
        Vec3::new(4.0, 3.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(-1.0, 0.0, 0.0),
    );
    let expected = [c, c + u, c + u + v, c + v];
    for (p, e) in world.iter().zip(expected) {
        assert!(close(*p, e), "{p} vs {e}");
    }
    let material = mesh.material_ids[0] as usize;
    assert_eq!(scene.materials[material].emission, Vec3::splat(3.0));
    scene.set_frame(5.0);
    assert_eq!(scene.materials[material].emission, Vec3::splat(2.0));
    assert!(
        matches!(scene.lights[0], Light::Rect { corner, .. } if close(corner, Vec3::new(2.0, 2.5, 0.0)))
    );
}

#[test]
fn radiance_only_rect_animation_leaves_the_quad_alone() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[light]]\ntype = \"rect\"\ncorner = [0, 2, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 0, 1]\n\
        radiance = [1, 1, 1]\n\n\
        [[light.keyframe]]\nframe = 10\nradiance = [3, 3, 3]\n";
    let scene = load("rect-radiance", body);
    assert!(!scene.instance_is_animated(1));
    assert!(scene.lights_are_animated());
}

#[test]
fn spot_direction_is_interpolated_and_normalised() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\ndirection = [1, 0, 0]\n\
        intensity = [1, 1, 1]\ninner_angle = 10\nouter_angle = 20\n\n\
        [[light.keyframe]]\nframe = 0\n\n\
        [[light.keyframe]]\nframe = 2\ndirection = [0, 5, 0]\n";
    let scene = load("spot-direction", body);
    let Light::Spot { direction, .. } = scene.lights_at(1.0)[0] else {
        panic!("a spot light");
    };
    let h = std::f32::consts::FRAC_1_SQRT_2;
    assert!(close(direction, Vec3::new(h, h, 0.0)), "{direction}");
}

// ---------------------------------------------------------------------------------------------
// Errors.

#[test]
fn non_increasing_keyframe_frames_name_field() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[mesh.keyframe]]\nframe = 5\n\n[[mesh.keyframe]]\nframe = 5\n";
    assert_error(
        "non-increasing",
        body,
        &[
            "mesh[0].keyframe[1].frame",
            "line 14",
            "strictly increasing",
        ],
    );
}

#[test]
fn keyframes_with_matrix_name_field() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\
        matrix = [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]\n\n\
        [[mesh.keyframe]]\nframe = 0\ntranslate = [1, 0, 0]\n";
    assert_error("keyframe-matrix", body, &["mesh[0].matrix", "keyframes"]);
}

#[test]
fn unknown_mesh_keyframe_key_names_key() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[mesh.keyframe]]\nframe = 0\ntranslation = [1, 0, 0]\n";
    assert_error("mesh-key-unknown", body, &["translation", "line 12"]);
}

#[test]
fn keyframe_without_frame_is_an_error() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n[[mesh.keyframe]]\ntranslate = [1, 0, 0]\n";
    assert_error("no-frame", body, &["frame"]);
}

#[test]
fn light_keyframe_key_of_other_type_names_field() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[light]]\ntype = \"sun\"\ndirection = [0, 1, 0]\nirradiance = [1, 1, 1]\n\n\
        [[light.keyframe]]\nframe = 0\nposition = [1, 0, 0]\n";
    assert_error(
        "light-key-other-type",
        body,
        &["light[0].keyframe[0].position", "sun light"],
    );
}

#[test]
fn light_keyframe_non_animatable_key_names_key() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\ndirection = [1, 0, 0]\n\
        intensity = [1, 1, 1]\ninner_angle = 10\nouter_angle = 20\n\n\
        [[light.keyframe]]\nframe = 0\nouter_angle = 30\n";
    assert_error("light-key-angle", body, &["outer_angle"]);
}

#[test]
fn bad_light_keyframe_value_names_field() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = [1, 1, 1]\n\n\
        [[light.keyframe]]\nframe = 0\n\n\
        [[light.keyframe]]\nframe = 1\nintensity = [1, -1, 1]\n";
    assert_error(
        "light-key-negative",
        body,
        &["light[0].keyframe[1].intensity", "negative"],
    );
}

#[test]
fn opposite_sun_directions_name_field() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[light]]\ntype = \"sun\"\ndirection = [0, 1, 0]\nirradiance = [1, 1, 1]\n\n\
        [[light.keyframe]]\nframe = 0\ndirection = [1, 0, 0]\n\n\
        [[light.keyframe]]\nframe = 1\ndirection = [-2, 0, 0]\n";
    assert_error(
        "sun-opposite",
        body,
        &["light[0].keyframe[1].direction", "opposite"],
    );
}

#[test]
fn bad_camera_keyframe_names_field() {
    let body = "[[mesh]]\nfile = \"tri.obj\"\n\n\
        [[camera.keyframe]]\nframe = 0\nfov_y = 200\n";
    assert_error(
        "camera-key-fov",
        body,
        &["camera.keyframe[0].fov_y", "(0, 180)"],
    );
    let body =
        "[[mesh]]\nfile = \"tri.obj\"\n\n[[camera.keyframe]]\nframe = 0\nresolution = [4, 4]\n";
    assert_error("camera-key-resolution", body, &["resolution"]);
}

#[test]
fn bad_animation_table_names_field() {
    let body = "[animation]\nframes = [10, 2]\n\n[[mesh]]\nfile = \"tri.obj\"\n";
    assert_error(
        "frames-reversed",
        body,
        &["animation.frames", "first <= last"],
    );
    let body = "[animation]\nfps = 0\n\n[[mesh]]\nfile = \"tri.obj\"\n";
    assert_error("fps-zero", body, &["animation.fps", "positive"]);
    let body = "[animation]\nframes = [-1, 2]\n\n[[mesh]]\nfile = \"tri.obj\"\n";
    assert_error("frames-negative", body, &["line 8"]);
    let body = "[animation]\ntemporal_accuracy = 0\n\n[[mesh]]\nfile = \"tri.obj\"\n";
    assert_error(
        "accuracy-zero",
        body,
        &["animation.temporal_accuracy", "positive"],
    );
    let body = "[animation]\nmax_lifespan = 0\n\n[[mesh]]\nfile = \"tri.obj\"\n";
    assert_error(
        "lifespan-zero",
        body,
        &["animation.max_lifespan", "at least 1"],
    );
}

// ---------------------------------------------------------------------------------------------
// Bundled animated scenes.

fn bundled(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    load_scene(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn cube_in_box_anim_loads() {
    let scene = bundled("cube-in-box-anim.toml");
    assert_eq!(scene.frames(), 0..=399);
    assert!(scene.instance_is_animated(1));
    assert!(!scene.instance_is_animated(0));
    assert!(!scene.lights_are_animated() && !scene.camera_is_animated());
    let start = scene.instance_transform_at(1, 0.0).w_axis.truncate();
    let end = scene.instance_transform_at(1, 399.0).w_axis.truncate();
    assert!(close(start, Vec3::new(-1.2, 0.0, -1.2)));
    assert!(close(end, Vec3::new(1.2, 0.0, -1.2)));
}

#[test]
fn moving_light_loads() {
    let scene = bundled("moving-light.toml");
    assert_eq!(scene.frames(), 0..=399);
    assert!(scene.lights_are_animated());
    // room, tiled floor, the light's quad.
    assert_eq!(scene.instances.len(), 3);
    assert!(scene.instance_is_animated(2));
    assert_ne!(scene.lights_at(0.0), scene.lights_at(150.0));
    // Its own temporal accuracy (flicker below per-frame recomputation), the seed's dt_max.
    let anim = scene.animation.as_ref().expect("animated");
    assert_eq!(
        (anim.temporal_accuracy, anim.max_lifespan),
        (Some(0.02), Some(20))
    );
}

#[test]
fn cornell_sphere_loads() {
    let scene = bundled("cornell-sphere.toml");
    assert_eq!(scene.frames(), 0..=99);
    assert!(scene.instance_is_animated(1));
    let sphere = &scene.meshes[scene.instances[1].mesh as usize];
    assert!((320..=1280).contains(&sphere.indices.len()));
    let x = |f: f32| scene.instance_transform_at(1, f).w_axis.x;
    assert!(x(0.0) > x(50.0) && x(50.0) > x(99.0));
}

#[test]
fn spheres_load() {
    let scene = bundled("spheres.toml");
    assert_eq!(scene.frames(), 0..=199);
    // The seed's a_t and dt_max for this scene.
    let anim = scene.animation.as_ref().expect("animated");
    assert_eq!(
        (anim.temporal_accuracy, anim.max_lifespan),
        (Some(0.05), Some(5))
    );
    // room, 66 spheres, the light's quad.
    assert_eq!(scene.instances.len(), 1 + 66 + 1);
    assert!((1..=66).all(|i| scene.instance_is_animated(i)));
    // Every sphere rests on the floor (y = radius) at some keyframe and never sinks into it.
    for i in 1..=66 {
        let heights: Vec<f32> = (0..=199 * 4)
            .map(|q| scene.instance_transform_at(i, q as f32 / 4.0).w_axis.y)
            .collect();
        let lowest = heights.iter().copied().fold(f32::INFINITY, f32::min);
        assert!((0.14 - 1e-4..0.2).contains(&lowest), "sphere {i}: {lowest}");
    }
}
