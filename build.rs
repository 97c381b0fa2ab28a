//! Parses and validates every pass's WGSL once, at build time, and embeds the naga module
//! and its validation info (postcard) in the binary: at run time each pipeline then starts
//! from them instead of parsing its 0.5-2k lines again (naga's WGSL front end was most of
//! naga's share of a run's start-up: `gpu::shader::specialised_module`). A WGSL error
//! fails the build with naga's message.

#[path = "src/gpu/wgsl_compose.rs"]
mod wgsl_compose;

use std::path::{Path, PathBuf};

fn main() {
    let wgsl = Path::new("wgsl");
    println!("cargo:rerun-if-changed=wgsl");
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    let mut passes: Vec<String> = std::fs::read_dir(wgsl)
        .expect("wgsl/")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl"))
        .collect();
    passes.sort();
    let read = |name: &str| -> Result<String, String> {
        std::fs::read_to_string(wgsl.join(name)).map_err(|e| format!("wgsl/{name}: {e}"))
    };
    let mut table = String::from(
        "/// Every pass's parsed and validated naga module with its info (postcard), by file name.\n\
         pub const PARSED_PASSES: &[(&str, &[u8])] = &[\n",
    );
    for name in &passes {
        let text = wgsl_compose::compose_with(name, &read).unwrap_or_else(|e| panic!("{e}"));
        let module = naga::front::wgsl::parse_str(&text)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&text)));
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&text)));
        let bytes = postcard::to_allocvec(&(&module, &info)).expect("postcard");
        let file = out.join(format!("{name}.naga"));
        std::fs::write(&file, bytes).expect("writing the parsed pass");
        table.push_str(&format!(
            "    ({name:?}, include_bytes!({:?})),\n",
            file.display().to_string()
        ));
    }
    table.push_str("];\n");
    std::fs::write(out.join("parsed_passes.rs"), table).expect("writing parsed_passes.rs");
}
