//! Shared helpers for the integration tests.
#![allow(dead_code)]

use radsplat::gpu::GpuContext;
use radsplat::scene::{Scene, load_scene};
use std::path::PathBuf;

/// A bundled scene file.
pub fn bundled(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// Loads a bundled scene, optionally at another resolution.
pub fn load(name: &str, size: Option<(u32, u32)>) -> Scene {
    let mut scene = load_scene(&bundled(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    if let Some((w, h)) = size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    scene
}

/// True when tests on third-party scenes must run (CI sets `RADSPLAT_ASSET_PATH`).
pub fn shared_scenes_enabled() -> bool {
    let on = std::env::var_os("RADSPLAT_ASSET_PATH").is_some_and(|v| !v.is_empty());
    if !on {
        eprintln!("RADSPLAT_ASSET_PATH is not set: this test's shared-scene part did not run");
    }
    on
}

/// A GPU context; wgpu errors are recorded and fail the test through `ctx.check()`.
pub fn gpu() -> GpuContext {
    GpuContext::new().unwrap_or_else(|e| panic!("no GPU context: {e}"))
}

/// Asserts a golden SHA-256. Golden hashes are tied to the driver CI installs (lavapipe of
/// Mesa 22.3.6): on another driver the test fails with a message saying so, never skips.
pub fn assert_golden(ctx: &GpuContext, what: &str, hash: &str, golden: &str) {
    let driver = ctx
        .adapter_info
        .as_ref()
        .map(|a| a.driver_info.clone())
        .unwrap_or_default();
    eprintln!("{what} SHA-256 {hash} (driver {driver})");
    if driver.contains("Mesa 22.3.6") {
        assert_eq!(hash, golden, "{what} changed");
    } else {
        panic!(
            "the golden hash of {what} is tied to lavapipe of Mesa 22.3.6; this driver is '{driver}'"
        );
    }
}
