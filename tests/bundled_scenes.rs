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
