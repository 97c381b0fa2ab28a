//! The visibility buffer against obvhs's CPU traversal on the same camera rays.

mod common;

use glam::Vec3;
use radsplat::Renderer;
use radsplat::bvh::cpu_trace::CpuTracer;
use radsplat::scene::Scene;
use radsplat::visibility::GpuCamera;

/// Renders the visibility buffer and checks every pixel against obvhs's CPU traversal:
/// same instance and triangle, t within 1e-4 relative. A disagreement is accepted only
/// when it is a precision case that both answers can claim, checked in f64: an exact tie
/// (the other triangle is hit at the same distance), or a ray grazing a triangle edge
/// (within 1e-5 in barycentric terms), where obvhs's and our Möller–Trumbore variants may
/// round differently. Returns (pixels hit, ambiguous pixels).
fn check_against_cpu(scene: &Scene) -> (usize, usize) {
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(scene).expect("prepare");
    let frame = renderer
        .render_frame(&prepared, &scene.camera)
        .expect("frame");
    let tracer = CpuTracer::new(scene);
    let cam = GpuCamera::new(&scene.camera);
    let origin = Vec3::from(cam.origin);
    let (mut hits, mut ambiguous, mut bad) = (0, 0, Vec::new());
    // Either answer is a real hit within rounding: on or within 1e-5 of the triangle.
    let genuine = |inst: u32, tri: u32, t: f32, d: Vec3| {
        common::exact_hit(scene, inst, tri, origin, d).is_some_and(|(te, margin)| {
            margin > -1e-5 && (te - f64::from(t)).abs() <= 1e-4 * te.abs()
        })
    };
    let on_edge = |inst: u32, tri: u32, d: Vec3| {
        common::exact_hit(scene, inst, tri, origin, d)
            .is_some_and(|(_, margin)| margin.abs() <= 1e-5)
    };
    for y in 0..cam.height {
        for x in 0..cam.width {
            let g = frame.visibility[(y * cam.width + x) as usize];
            let dir = cam.ray_dir(x, y);
            let c = tracer.closest_hit(origin, dir, cam.tmin, f32::INFINITY);
            let same = match c {
                None => !g.is_hit(),
                Some(c) => {
                    g.is_hit()
                        && (g.instance, g.mesh_triangle) == (c.instance, c.triangle)
                        && (g.t - c.t).abs() <= 1e-4 * c.t
                }
            };
            if c.is_some() {
                hits += 1;
            }
            if same {
                continue;
            }
            // Which answers are precision cases?
            let gpu_ok = !g.is_hit() || genuine(g.instance, g.mesh_triangle, g.t, dir);
            let edge = (g.is_hit() && on_edge(g.instance, g.mesh_triangle, dir))
                || c.is_some_and(|c| on_edge(c.instance, c.triangle, dir));
            let tie = c.is_some_and(|c| g.is_hit() && (g.t - c.t).abs() <= 1e-4 * c.t);
            if gpu_ok && (edge || tie) {
                ambiguous += 1;
            } else {
                bad.push(format!(
                    "({x},{y}): GPU {:?} t {}, CPU {:?}",
                    g.is_hit().then_some((g.instance, g.mesh_triangle)),
                    g.t,
                    c.map(|c| (c.instance, c.triangle, c.t))
                ));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{} mismatching pixels, first: {:?}",
        bad.len(),
        &bad[..bad.len().min(10)]
    );
    // Ambiguous pixels must stay rare (here: < 0.1 % of hits).
    assert!(
        ambiguous * 1000 <= hits,
        "{ambiguous} ambiguous pixels of {hits}"
    );
    renderer.ctx.check().expect("no wgpu errors");
    (hits, ambiguous)
}

#[test]
fn cornell_box_visibility_matches_cpu() {
    let scene = common::load("cornell-box.toml", Some((96, 96)));
    let (hits, _) = check_against_cpu(&scene);
    assert!(
        hits > 96 * 96 * 9 / 10,
        "most of the view is the box: {hits}"
    );
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
    eprintln!("sponza: {hits} hits, {ties} ambiguous (edge or tie)");
    assert!(hits > 160 * 160 / 2);
}

/// A camera placed exactly on a surface, looking away from it (on the Cornell box's back
/// wall, into the room), sees the room and matches the CPU traversal from the same start:
/// camera rays start a few ulps out (`GpuCamera::tmin`), where starting at t = 0 every
/// pixel hit the wall it stands on.
#[test]
fn a_camera_on_a_wall_sees_past_it() {
    let mut scene = common::load("cornell-box.toml", Some((24, 24)));
    scene.camera.position = Vec3::new(0.278, 0.273, 0.5592);
    scene.camera.target = Vec3::new(0.278, 0.273, 0.0);
    let (hits, _) = check_against_cpu(&scene);
    // The box is open at the front: the outer pixels look out of it.
    assert!(
        hits > 24 * 24 / 2,
        "{hits} of {} pixels hit the room",
        24 * 24
    );
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let frame = renderer
        .render_frame(&prepared, &scene.camera)
        .expect("frame");
    let near = frame
        .visibility
        .iter()
        .filter(|v| v.t >= 0.0 && v.t < 0.01)
        .count();
    assert_eq!(near, 0, "{near} pixels hit the wall the camera stands on");
}
