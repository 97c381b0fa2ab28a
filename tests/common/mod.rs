//! Shared helpers for the integration tests.
#![allow(dead_code)]

use glam::Vec3;
use radsplat::gpu::GpuContext;
use radsplat::scene::{Light, Scene, load_scene};
use std::path::{Path, PathBuf};

/// A fresh, empty directory for one test's files (`radsplat-<name>-<pid>` under the system's
/// temp dir), removed when dropped: tests left theirs behind, a set per run.
pub struct TestDir(PathBuf);

impl TestDir {
    pub fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("radsplat-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("test directory");
        Self(dir)
    }
}

impl std::ops::Deref for TestDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for TestDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

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

/// The driver golden hashes are recorded on: lavapipe (adapter "llvmpipe") of this Mesa.
pub const GOLDEN_DRIVER: &str = "Mesa 22.3.6";

/// Why golden hashes cannot be compared on this context's driver, or None when it is the
/// pinned one (lavapipe of [`GOLDEN_DRIVER`]).
pub fn golden_driver_mismatch(ctx: &GpuContext) -> Option<String> {
    let (name, driver) = ctx
        .adapter_info
        .as_ref()
        .map(|a| (a.name.clone(), a.driver_info.clone()))
        .unwrap_or_default();
    if name.to_lowercase().contains("llvmpipe") && driver.contains(GOLDEN_DRIVER) {
        return None;
    }
    Some(format!(
        "golden hashes are recorded on lavapipe (llvmpipe) of {GOLDEN_DRIVER} (Debian 12's \
         mesa-vulkan-drivers, what CI installs); this run's adapter is '{name}' with driver \
         '{driver}'. Run the tests on the pinned driver: install mesa-vulkan-drivers of \
         Debian 12 and run `WGPU_ADAPTER_NAME=llvmpipe cargo test` (or set \
         VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json)"
    ))
}

/// Asserts a golden SHA-256. Golden hashes are tied to the driver CI installs (lavapipe of
/// Mesa 22.3.6): on another driver the test fails with a message saying so (expected
/// driver, found driver, how to run on the pinned one), never skips.
pub fn assert_golden(ctx: &GpuContext, what: &str, hash: &str, golden: &str) {
    eprintln!("{what} SHA-256 {hash}");
    if let Some(why) = golden_driver_mismatch(ctx) {
        panic!("cannot check the golden hash of {what}: {why}");
    }
    assert_eq!(hash, golden, "{what} changed");
}

/// Ray/triangle test in f64: (t, smallest barycentric) of the triangle `tri` of the
/// instance, or None if the ray's line misses its plane.
pub fn exact_hit(scene: &Scene, instance: u32, tri: u32, o: Vec3, d: Vec3) -> Option<(f64, f64)> {
    let inst = &scene.instances[instance as usize];
    let mesh = &scene.meshes[inst.mesh as usize];
    let idx = mesh.indices[tri as usize];
    let p = |k: usize| {
        inst.transform
            .transform_point3(mesh.positions[idx[k] as usize])
            .as_dvec3()
    };
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let (e1, e2) = (p(1) - p(0), p(2) - p(0));
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let s = o - p(0);
    let u = s.dot(pv) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    Some((e2.dot(q) / det, u.min(v).min(1.0 - u - v)))
}

/// A scene written from its texts (`scene.obj`, `scene.mtl`, `scene.toml`) into a temporary
/// directory named after `tag`, loaded, and the directory removed.
pub fn scene_from_texts(tag: &str, obj: &str, mtl: &str, toml: &str) -> Scene {
    let dir = std::env::temp_dir().join(format!("radsplat-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("scene.obj"), obj).expect("obj");
    std::fs::write(dir.join("scene.mtl"), mtl).expect("mtl");
    std::fs::write(dir.join("scene.toml"), toml).expect("toml");
    let scene = load_scene(&dir.join("scene.toml")).expect("scene");
    let _ = std::fs::remove_dir_all(&dir);
    scene
}

/// A closed sphere of radius 1 and albedo 0.5 with a point light of intensity 1 at its
/// centre, the camera inside. Every wall point receives the same indirect irradiance,
/// E0 (rho + ... + rho^N) with E0 = I / r^2 = 1 for N bounces, so the indirect radiance
/// rho / pi E0 (rho + ... + rho^N) is known in closed form (VPL and photon records).
pub fn integrating_sphere() -> Scene {
    let obj = std::fs::read_to_string(bundled("sphere.obj")).expect("sphere.obj");
    scene_from_texts(
        "integrating-sphere",
        &obj.replace("mtllib sphere.mtl", "mtllib scene.mtl"),
        "newmtl sphere\nKd 0.5 0.5 0.5\n",
        "[camera]\nposition = [0.1, -0.2, 0.3]\ntarget = [-0.3, 0.2, -1]\nfov_y = 70\n\
         resolution = [16, 16]\n[[mesh]]\nfile = \"scene.obj\"\n\
         [[light]]\ntype = \"point\"\nposition = [0, 0, 0]\nintensity = [1, 1, 1]\n",
    )
}

/// The indirect light of `scene`'s path-traced reference at `spp` samples per pixel.
pub fn reference_indirect(renderer: &radsplat::Renderer, scene: &Scene, spp: u32) -> Vec<[f32; 4]> {
    let prepared = renderer.prepare(scene).expect("prepare");
    radsplat::reference::ReferencePass::new(&renderer.ctx)
        .expect("reference pass")
        .render(
            renderer,
            &prepared,
            &scene.camera,
            &radsplat::reference::ReferenceOptions::new(spp),
            &mut |_, _| {},
        )
        .expect("reference")
        .indirect
}

/// One GI frame of `scene` from a new cache with `settings`, checked for wgpu errors.
pub fn render_gi(
    renderer: &radsplat::Renderer,
    scene: &Scene,
    settings: &radsplat::records::CacheSettings,
) -> radsplat::frame::Frame {
    render_gi_with_cache(renderer, scene, settings).0
}

/// [`render_gi`], with the cache it filled.
pub fn render_gi_with_cache(
    renderer: &radsplat::Renderer,
    scene: &Scene,
    settings: &radsplat::records::CacheSettings,
) -> (radsplat::frame::Frame, radsplat::frame::IrradianceCache) {
    let prepared = renderer.prepare(scene).expect("prepare");
    let mut cache = renderer.new_cache(settings).expect("cache");
    let frame = renderer
        .render_gi_frame(&prepared, &scene.camera, &mut cache, None, |_| {})
        .expect("frame");
    renderer.ctx.check().expect("no wgpu errors");
    (frame, cache)
}

/// Asserts that GPU splat sums `(sum w E, sum w)` match the CPU mirror's: the same pixels
/// covered, each sum within 1e-4 of the CPU's (relative, or of 1e-3 of the weight sum).
/// Returns the pixels covered.
pub fn assert_splat_sums_match(gpu: &[[f32; 4]], cpu: &[[f32; 4]]) -> usize {
    assert_eq!(gpu.len(), cpu.len());
    let mut covered = 0;
    for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        assert_eq!(g[3] > 0.0, c[3] > 0.0, "coverage differs at pixel {i}");
        if c[3] > 0.0 {
            covered += 1;
            for k in 0..4 {
                let tol = 1e-4 * c[k].abs().max(1e-3 * c[3]);
                assert!(
                    (g[k] - c[k]).abs() <= tol,
                    "pixel {i} channel {k}: {g:?} vs {c:?}"
                );
            }
        }
    }
    covered
}

/// Mean of the green channel of `indirect` against `reference`'s, and the relative RMS
/// difference after averaging both over `block` x `block` pixels (image width `w`).
pub fn compare_blocks(
    indirect: &[[f32; 4]],
    reference: &[[f32; 4]],
    w: usize,
    block: usize,
) -> (f32, f32) {
    let h = indirect.len() / w;
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for by in 0..h / block {
        for bx in 0..w / block {
            let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
            for y in 0..block {
                for x in 0..block {
                    let i = (by * block + y) * w + bx * block + x;
                    a += Vec3::from_slice(&indirect[i][..3]);
                    b += Vec3::from_slice(&reference[i][..3]);
                }
            }
            diff += f64::from((a - b).length_squared());
            norm += f64::from(b.length_squared());
        }
    }
    let mean = |v: &[[f32; 4]]| v.iter().map(|p| p[1]).sum::<f32>();
    (
        mean(indirect) / mean(reference),
        (diff / norm).sqrt() as f32,
    )
}

/// The Cornell box at 32x32 with four more lights, one of each kind and a second rect
/// below the ceiling panel (no geometry of their own): a scene where hemisphere-plane hits
/// choose one light of several, some of which cannot light them.
pub fn many_lights_cornell_box() -> Scene {
    let mut scene = load("cornell-box.toml", Some((32, 32)));
    scene.lights.extend([
        Light::Point {
            position: Vec3::new(0.15, 0.45, 0.3),
            intensity: Vec3::new(0.02, 0.03, 0.04),
        },
        Light::Spot {
            position: Vec3::new(0.45, 0.5, 0.1),
            direction: Vec3::new(0.0, -1.0, 0.3).normalize(),
            intensity: Vec3::new(0.08, 0.05, 0.02),
            cos_inner: 0.9,
            cos_outer: 0.6,
        },
        // Near the open front, facing the back wall (+z): what lies in front of it (z
        // under 0.05) sees its back.
        Light::Rect {
            corner: Vec3::new(0.1, 0.1, 0.05),
            edge_u: Vec3::new(0.1, 0.0, 0.0),
            edge_v: Vec3::new(0.0, 0.1, 0.0),
            radiance: Vec3::new(1.0, 2.0, 3.0),
        },
        // Through the open front (closed box: mostly occluded).
        Light::Sun {
            direction: Vec3::new(0.2, 0.3, -1.0).normalize(),
            irradiance: Vec3::new(3.0, 3.0, 3.0),
        },
    ]);
    scene
}
