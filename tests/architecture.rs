//! The layers of `src/` (README "Architecture"): a frame's data flow, scene → BVH →
//! visibility → records → splat → resolve → frame, with temporal caching and the commands
//! on top. A module may use its own layer and the layers below, never one above: the
//! static pipeline can be read, and changed, without temporal caching (issue 18: records/
//! used to import temporal/, which imports frame.rs, which imports records/).

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;

/// Layer of each top-level module of the crate (a folder under src/ or a file).
fn layers() -> BTreeMap<&'static str, u32> {
    [
        // Foundations.
        ("error", 0),
        ("sampling", 0),
        ("parallel", 0),
        ("scene", 0),
        ("hsh", 0),
        ("input", 0),
        // The GPU scene: the BVH and the device that holds it (each uses the other).
        ("bvh", 1),
        ("gpu", 1),
        ("visibility", 2),
        ("direct", 3),
        ("light_maps", 3),
        ("bounce", 3),
        ("vpl", 3),
        ("photons", 3),
        ("records", 4),
        ("glossy", 4),
        ("splat", 5),
        ("placement", 6),
        ("resolve", 6),
        // One frame, from the passes above.
        ("frame", 7),
        ("output", 8),
        // What runs frames: temporal caching, the path-traced reference, exporters.
        ("temporal", 9),
        ("reference", 9),
        ("radiance_export", 9),
        // Commands and tools on top.
        ("commands", 10),
        ("compare", 10),
        ("compare_seq", 10),
        ("bench", 10),
    ]
    .into_iter()
    .collect()
}

/// Every `crate::name` a source text mentions (in code or in doc links).
fn crate_mentions(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("crate::") {
        let tail = &rest[at + "crate::".len()..];
        let name: String = tail
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if !name.is_empty() {
            out.push(name);
        }
        rest = tail;
    }
    out
}

fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in fs::read_dir(dir).expect("read src") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_module_uses_a_layer_above_its_own() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let layers = layers();
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut seen_modules = std::collections::BTreeSet::new();
    let mut violations = Vec::new();
    for file in &files {
        let rel = file.strip_prefix(&src).expect("under src");
        let top = rel
            .components()
            .next()
            .and_then(|c| c.as_os_str().to_str())
            .expect("name")
            .trim_end_matches(".rs")
            .to_string();
        if top == "lib" || top == "main" {
            continue;
        }
        let Some(&own) = layers.get(top.as_str()) else {
            violations.push(format!(
                "{}: module `{top}` has no layer here",
                rel.display()
            ));
            continue;
        };
        seen_modules.insert(top.clone());
        let text = fs::read_to_string(file).expect("read source");
        for used in crate_mentions(&text) {
            if let Some(&layer) = layers.get(used.as_str()) {
                if layer > own {
                    violations.push(format!(
                        "{}: `{top}` (layer {own}) uses crate::{used} (layer {layer})",
                        rel.display()
                    ));
                }
            }
        }
    }
    // The table must name real modules: one that matched nothing would let a rename pass.
    for name in layers.keys() {
        assert!(
            seen_modules.contains(*name),
            "layer table names `{name}`, which src/ does not have"
        );
    }
    assert!(
        violations.is_empty(),
        "layering broken:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_mention_scanner_finds_paths_in_code_and_docs() {
    let text = "use crate::records::Record;\n/// see [`crate::temporal::Lookahead`]\nx::crate";
    assert_eq!(crate_mentions(text), ["records", "temporal"]);
}
