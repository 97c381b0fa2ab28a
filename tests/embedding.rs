//! An engine hands radsplat its own device: rendering must work on it and give the same
//! images as a device radsplat created itself.

mod common;

use radsplat::Renderer;
use radsplat::gpu::{GpuContext, required_limits};

fn engine_device() -> (wgpu::Device, wgpu::Queue) {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter =
        pollster::block_on(instance.request_adapter(&Default::default())).expect("adapter");
    // The engine asks for exactly what radsplat documents, nothing more.
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("engine"),
        required_limits: required_limits(),
        ..Default::default()
    }))
    .expect("device")
}

#[test]
fn renders_on_a_callers_device_with_the_documented_limits() {
    let scene = common::load("cube-in-box.toml", Some((48, 32)));
    let (device, queue) = engine_device();
    let renderer = Renderer::new(GpuContext::from_device(device, queue)).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let embedded = renderer
        .render_frame(&prepared, &scene.camera)
        .expect("frame");
    renderer.ctx.check().expect("no device loss");

    let own = Renderer::new(common::gpu()).expect("renderer");
    let prepared = own.prepare(&scene).expect("prepare");
    let reference = own.render_frame(&prepared, &scene.camera).expect("frame");
    assert_eq!(embedded.beauty, reference.beauty);
    assert!(
        embedded.beauty.iter().any(|p| p[0] > 0.0),
        "image is not black"
    );
}

/// A scene an engine builds in code skips the loader's checks: a light or material that is
/// not finite is refused when the scene is prepared, naming it, where it rendered NaN
/// pixels.
#[test]
fn a_scene_built_in_code_with_a_bad_light_or_material_is_refused() {
    use glam::Vec3;
    use radsplat::scene::Light;
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let mut scene = common::load("cornell-box.toml", Some((16, 16)));
    scene.lights.push(Light::Point {
        position: Vec3::new(0.2, 0.3, 0.2),
        intensity: Vec3::splat(f32::NAN),
    });
    let index = scene.lights.len() - 1;
    let e = match renderer.prepare(&scene) {
        Ok(_) => panic!("a NaN light was prepared"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains(&format!("light[{index}].intensity")), "{e}");
    scene.lights.pop();
    renderer.prepare(&scene).expect("the scene without it");
    // A material likewise (a NaN albedo rendered NaN pixels).
    let kept = scene.materials[0].albedo;
    scene.materials[0].albedo = Vec3::new(0.5, f32::NAN, 0.5);
    let e = match renderer.prepare(&scene) {
        Ok(_) => panic!("a NaN albedo was prepared"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("material[0]") && e.contains("albedo"), "{e}");
    scene.materials[0].albedo = kept;
    renderer.prepare(&scene).expect("the scene as loaded");
}

/// An engine that builds the visibility, direct-light and glossy passes for one scene's
/// features (`for_scene`, which lavapipe builds and runs faster) and then hands them another
/// scene gets an error naming the pass, not an image without that scene's environment,
/// instances or textures.
#[test]
fn passes_compiled_for_one_scene_refuse_a_scene_with_other_features() {
    use radsplat::direct::DirectLightPass;
    use radsplat::glossy::GlossyIndirectPass;
    use radsplat::visibility::VisibilityPass;
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let ctx = &renderer.ctx;
    let cornell = common::load("cornell-box.toml", Some((16, 16)));
    let own = renderer.prepare(&cornell).expect("prepare");
    let features = own.gpu.features();
    let visibility = VisibilityPass::for_scene(ctx, features).expect("visibility pass");
    let direct = DirectLightPass::for_scene(ctx, features).expect("direct pass");
    let glossy = GlossyIndirectPass::for_scene(ctx, features).expect("glossy pass");
    // The environment sphere has an environment (and no rect light).
    let other_scene = common::load("env-sphere.toml", Some((16, 16)));
    let other = renderer.prepare(&other_scene).expect("prepare");
    let refused = |r: radsplat::Result<()>, pass: &str| {
        let message = r.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            message.contains(&format!("this {pass} was compiled for the scene features")),
            "the {pass} took a scene with other features: {message:?}"
        );
    };
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    // Their own scene records.
    let vis = visibility
        .record(ctx, &mut enc, &own.gpu, &cornell.camera, None)
        .expect("visibility of its own scene");
    direct
        .record(ctx, &mut enc, &own.gpu, &vis, None)
        .expect("direct light of its own scene");
    glossy
        .record(ctx, &mut enc, &own.gpu, &vis, 1, None, false, None)
        .expect("glossy of its own scene");
    // The other scene is refused by each.
    refused(
        visibility
            .record(ctx, &mut enc, &other.gpu, &other_scene.camera, None)
            .map(|_| ()),
        "visibility pass",
    );
    refused(
        direct
            .record(ctx, &mut enc, &other.gpu, &vis, None)
            .map(|_| ()),
        "direct-light pass",
    );
    refused(
        glossy
            .record(ctx, &mut enc, &other.gpu, &vis, 1, None, false, None)
            .map(|_| ()),
        "glossy indirect pass",
    );
    ctx.queue.submit([enc.finish()]);
    ctx.check().expect("no wgpu errors");
}
