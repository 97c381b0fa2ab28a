//! The `//!include` rule that composes a pass's WGSL from `wgsl/` (shared by the crate,
//! which reads the sources embedded in the binary, and `build.rs`, which reads the files to
//! parse every pass once at build time).

/// The full WGSL text of `name` with its `//!include <name>` lines replaced by the named
/// files' text, each file once; `source` returns a file's text by name.
pub fn compose_with<S: AsRef<str>>(
    name: &str,
    source: &dyn Fn(&str) -> Result<S, String>,
) -> Result<String, String> {
    let mut out = String::new();
    let mut seen = Vec::new();
    expand(name, source, &mut out, &mut seen)?;
    Ok(out)
}

fn expand<S: AsRef<str>>(
    name: &str,
    source: &dyn Fn(&str) -> Result<S, String>,
    out: &mut String,
    seen: &mut Vec<String>,
) -> Result<(), String> {
    if seen.iter().any(|s| s == name) {
        return Ok(());
    }
    seen.push(name.to_string());
    let text = source(name)?;
    for line in text.as_ref().lines() {
        if let Some(inc) = line.trim().strip_prefix("//!include ") {
            expand(inc.trim(), source, out, seen)?;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    Ok(())
}
