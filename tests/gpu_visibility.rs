//! The visibility buffer against obvhs's CPU traversal on the same camera rays.

mod common;

use glam::Vec3;
use radsplat::Renderer;
use radsplat::bvh::cpu_trace::CpuTracer;
use radsplat::scene::Scene;
use radsplat::visibility::GpuCamera;

/// Renders the visibility buffer and checks every pixel against the CPU: same instance
/// and triangle, t within 1e-4 relative. A differing triangle is accepted only as an exact
/// tie: the GPU's triangle is hit by the same ray at the CPU's distance (within 1e-4),
/// e.g. on a shared edge or coplanar overlap. Returns (pixels hit, ties).
fn check_against_cpu(scene: &Scene) -> (usize, usize) {
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(scene).expect("prepare");
    let frame = renderer
        .render_frame(&prepared, &scene.camera)
        .expect("frame");
    let tracer = CpuTracer::new(scene);
    let cam = GpuCamera::new(&scene.camera);
    let (mut hits, mut ties, mut bad) = (0, 0, Vec::new());
    for y in 0..cam.height {
        for x in 0..cam.width {
            let g = frame.visibility[(y * cam.width + x) as usize];
            let dir = cam.ray_dir(x, y);
            let c = tracer.closest_hit(cam.origin.into(), dir, 0.0, f32::INFINITY);
            match c {
                None => {
                    if g.is_hit() {
                        bad.push(format!("({x},{y}): GPU hit, CPU miss"));
                    }
                }
                Some(c) => {
                    hits += 1;
                    if !g.is_hit() {
                        bad.push(format!("({x},{y}): GPU miss, CPU hit t={}", c.t));
                        continue;
                    }
                    let rel = (g.t - c.t).abs() / c.t.max(1e-6);
                    if rel > 1e-4 {
                        bad.push(format!("({x},{y}): t GPU {} CPU {}", g.t, c.t));
                    } else if (g.instance, g.mesh_triangle) != (c.instance, c.triangle) {
                        // Exact tie? Intersect the GPU's triangle on the CPU.
                        let inst = &scene.instances[g.instance as usize];
                        let mesh = &scene.meshes[inst.mesh as usize];
                        let idx = mesh.indices[g.mesh_triangle as usize];
                        let p = |k: usize| {
                            inst.transform
                                .transform_point3(mesh.positions[idx[k] as usize])
                        };
                        let tri = obvhs::triangle::Triangle {
                            v0: p(0).into(),
                            v1: p(1).into(),
                            v2: p(2).into(),
                        };
                        let ray =
                            obvhs::ray::Ray::new_inf(Vec3::from(cam.origin).into(), dir.into());
                        let t = tri.intersect(&ray);
                        if t.is_finite() && (t - c.t).abs() <= 1e-4 * c.t {
                            ties += 1;
                        } else {
                            bad.push(format!(
                                "({x},{y}): GPU ({}, {}) CPU ({}, {}) t {}",
                                g.instance, g.mesh_triangle, c.instance, c.triangle, c.t
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{} mismatching pixels, first: {:?}",
        bad.len(),
        &bad[..bad.len().min(10)]
    );
    renderer.ctx.check().expect("no wgpu errors");
    (hits, ties)
}

#[test]
fn cornell_box_visibility_matches_cpu() {
    let scene = common::load("cornell-box.toml", Some((96, 96)));
    let (hits, ties) = check_against_cpu(&scene);
    assert!(
        hits > 96 * 96 * 9 / 10,
        "most of the view is the box: {hits}"
    );
    assert!(ties < hits / 100, "ties {ties}");
}

#[test]
fn cube_in_box_visibility_matches_cpu() {
    let scene = common::load("cube-in-box.toml", Some((96, 72)));
    let (hits, _) = check_against_cpu(&scene);
    assert!(hits > 0);
}

#[test]
fn sponza_visibility_matches_cpu() {
    if !common::shared_scenes_enabled() {
        return;
    }
    let scene = common::load("sponza.toml", Some((160, 160)));
    let (hits, ties) = check_against_cpu(&scene);
    eprintln!("sponza: {hits} hits, {ties} exact ties");
    assert!(hits > 160 * 160 / 2);
}
