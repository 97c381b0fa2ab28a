//! Every scene file in scenes/ loads: the bundled ones from the repository alone, the
//! third-party ones along RADSPLAT_ASSET_PATH (without it, their error must say where they
//! were looked for).

mod common;

use radsplat::scene::load_scene;

#[test]
fn every_bundled_scene_loads() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("scenes/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 12, "{} scene files", files.len());
    let third_party = ["sponza.toml", "sponza-sun.toml", "conference.toml"];
    for f in &files {
        let name = f.file_name().and_then(|n| n.to_str()).expect("name");
        match load_scene(f) {
            Ok(scene) => assert!(!scene.instances.is_empty(), "{name}: no instances"),
            Err(e) if third_party.contains(&name) && !common::shared_scenes_enabled() => {
                let msg = e.to_string();
                assert!(msg.contains("RADSPLAT_ASSET_PATH"), "{name}: {msg}");
            }
            Err(e) => panic!("{name}: {e}"),
        }
    }
}

/// The commands trace a static scene of several OBJ files as one instance (`--stats`:
/// `bvh.instances`), while the loaded scene keeps them; an animated one keeps its own.
#[test]
fn the_commands_trace_a_static_scene_as_one_instance() {
    let dir = common::TestDir::new("bundled-one-instance");
    for (name, loaded, traced) in [("cube-in-box.toml", 3, 1), ("cube-in-box-anim.toml", 3, 3)] {
        let path = common::bundled(name);
        let scene = load_scene(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(scene.instances.len(), loaded, "{name} as loaded");
        let stats = dir.join("stats.json");
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_radsplat"))
            .args(["render", path.to_str().expect("utf-8"), "--size", "8x8"])
            .args(["--direct-only", "--quiet", "-o"])
            .arg(dir.join("out.exr"))
            .arg("--stats")
            .arg(&stats)
            .output()
            .expect("run radsplat");
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).expect("stats")).expect("json");
        assert_eq!(json["bvh"]["instances"], traced, "{name} as traced");
    }
}
