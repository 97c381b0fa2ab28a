//! Light-space visibility maps (src/light_maps): the GPU trace against the CPU tracer,
//! and plane hits shaded from the maps against plane hits shaded with shadow rays.

mod common;

use glam::Vec3;
use radsplat::Renderer;
use radsplat::bvh::cpu_trace::CpuTracer;
use radsplat::light_maps::{
    LightMapSettings, MAP_OCTAHEDRAL, MAP_ORTHOGRAPHIC, MappedLights, NO_MAP, layout,
    reference_depths,
};
use radsplat::records::{CacheSettings, PlaneShadows};
use radsplat::scene::{Light, Scene};

/// The Cornell box (one rect light) with a sun above its ceiling and a point light inside.
fn cornell_with_sun_and_point(size: (u32, u32)) -> Scene {
    let mut scene = common::load("cornell-box.toml", Some(size));
    scene.lights.push(Light::Sun {
        direction: Vec3::new(0.2, 1.0, 0.1).normalize(),
        irradiance: Vec3::splat(3.0),
    });
    scene.lights.push(Light::Point {
        position: Vec3::new(0.15, 0.2, 0.25),
        intensity: Vec3::splat(0.02),
    });
    scene
}

#[test]
fn light_map_layout_gives_each_light_its_maps() {
    let scene = cornell_with_sun_and_point((8, 8));
    let lights: Vec<_> = scene
        .lights
        .iter()
        .map(radsplat::gpu::scene_buffers::GpuLight::new)
        .collect();
    let settings = LightMapSettings {
        resolution: 64,
        rect_grid: 2,
    };
    let bounds = radsplat::bvh::scene_bounds(&scene);
    let (maps, first) = layout(&lights, bounds, &settings, MappedLights::All);
    // Rect: a 2 x 2 grid of octahedral maps; sun: 1 orthographic; point: 1 octahedral.
    assert_eq!(first, vec![6, 0, 2, 4, 0, 5, 0]);
    let kinds: Vec<u32> = maps.iter().map(|m| m.kind).collect();
    assert_eq!(kinds[..4], [MAP_OCTAHEDRAL; 4]);
    assert_eq!(kinds[4..], [MAP_ORTHOGRAPHIC, MAP_OCTAHEDRAL]);
    assert_eq!(maps[4].resolution, 64);
    assert_eq!(maps[5].resolution, 32);
    // Texel ranges are consecutive and disjoint.
    let mut next = 0;
    for m in &maps {
        assert_eq!(m.offset, next);
        next += m.resolution * m.resolution;
    }
    assert!(first[1..].iter().step_by(2).all(|&f| f != NO_MAP));
    // The default: delta lights only, the rect light keeps its rays.
    let (delta, first) = layout(&lights, bounds, &settings, MappedLights::DeltaOnly);
    assert_eq!(first, vec![2, NO_MAP, 0, 0, 0, 1, 0]);
    assert_eq!(delta.len(), 2);
    assert_eq!(delta[0].kind, MAP_ORTHOGRAPHIC);
}

#[test]
fn gpu_light_maps_match_cpu_trace() {
    let scene = cornell_with_sun_and_point((8, 8));
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let settings = LightMapSettings {
        resolution: 64,
        rect_grid: 2,
    };
    let (maps, gpu) = renderer.light_maps(&prepared, &settings).expect("maps");
    let cpu = reference_depths(&maps, &CpuTracer::new(&scene));
    assert_eq!(gpu.len(), cpu.len());
    let mut hits = 0;
    let mut differ = 0;
    for (g, c) in gpu.iter().zip(&cpu) {
        let (g_hit, c_hit) = (*g < 1e29, *c < 1e29);
        if g_hit && c_hit {
            hits += 1;
            if (g - c).abs() > 1e-4 * c.max(1e-3) {
                differ += 1;
            }
        } else if g_hit != c_hit {
            differ += 1;
        }
    }
    eprintln!("{} texels, {hits} hits, {differ} differ", gpu.len());
    // Texels whose ray grazes a triangle edge may go either way; nothing else differs.
    assert!(hits > gpu.len() / 2, "{hits} of {} texels hit", gpu.len());
    assert!(
        differ * 1000 <= gpu.len(),
        "{differ} of {} texels differ",
        gpu.len()
    );
}

/// The indirect light of a GI frame with plane hits shadowed by light maps against the
/// same frame with shadow rays: the sun above the closed ceiling must stay dark (a map that
/// let it through would brighten the box), and the rect light's and point light's
/// shadows must agree within the maps' resolution, with no light let through contact
/// shadows.
#[test]
fn plane_hits_shaded_from_maps_agree_with_shadow_rays() {
    let scene = cornell_with_sun_and_point((48, 40));
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let indirect = |shadows: PlaneShadows| {
        let settings = CacheSettings {
            plane_resolution: 32,
            plane_shadows: shadows,
            light_maps: LightMapSettings {
                resolution: 256,
                rect_grid: 2,
            },
            ..CacheSettings::default()
        };
        let mut cache = renderer.new_cache(&settings).expect("cache");
        let frame = renderer
            .render_gi_frame(&prepared, &scene.camera, &mut cache, None, |_| {})
            .expect("frame");
        renderer.ctx.check().expect("no wgpu errors");
        frame.indirect.expect("indirect")
    };
    let rays = indirect(PlaneShadows::Rays);
    let luminance = |p: &[f32; 4]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let mean = |img: &[[f32; 4]]| img.iter().map(luminance).sum::<f32>() / img.len() as f32;
    let rms = (rays.iter().map(|p| luminance(p).powi(2)).sum::<f32>() / rays.len() as f32).sqrt();
    let against_rays = |img: &[[f32; 4]]| {
        let rmse = (rays
            .iter()
            .zip(img)
            .map(|(a, b)| (luminance(a) - luminance(b)).powi(2))
            .sum::<f32>()
            / rays.len() as f32)
            .sqrt();
        (mean(img) / mean(&rays), rmse / rms)
    };
    assert!(mean(&rays) > 0.0);
    // Maps for the sun and the point light (the default): the lookup with a normal offset
    // and a depth bias of a texel and a half that the receiver-plane test replaced gave
    // means 0.78 % apart and 3.9 % RMSE here (the sun leaking through contact shadows).
    let (delta_mean, delta_rmse) = against_rays(&indirect(PlaneShadows::Auto));
    // Maps for the rect light too: its penumbra from a 2 x 2 grid of cell maps.
    let (all_mean, all_rmse) = against_rays(&indirect(PlaneShadows::Maps));
    eprintln!(
        "maps over rays: delta lights mapped: mean {delta_mean}, relative RMSE {delta_rmse}; \
         all lights mapped: mean {all_mean}, relative RMSE {all_rmse}"
    );
    assert!((delta_mean - 1.0).abs() < 0.003, "mean ratio {delta_mean}");
    assert!(delta_rmse < 0.02, "relative RMSE {delta_rmse}");
    assert!((all_mean - 1.0).abs() < 0.03, "mean ratio {all_mean}");
    assert!(all_rmse < 0.08, "relative RMSE {all_rmse}");
}

/// A point light exactly on the ceiling (a lamp modelled on it): its octahedral map's rays
/// start a little out from the light (`light_maps::OCTAHEDRAL_TMIN`), as exact shadow rays
/// stop short of it. Starting at the light, every ray found the ceiling at t = 0 and the
/// plane hits read the whole room as shadowed: no indirect light at all.
#[test]
fn a_light_on_a_surface_lights_plane_hits_from_its_map() {
    let mut scene = common::load("cornell-box.toml", Some((32, 32)));
    // On the ceiling (y = 0.5488), beside the rect light's quad (whose emission the scene
    // keeps: without its light it is an emitter plane hits see).
    scene.lights = vec![Light::Point {
        position: Vec3::new(0.1, 0.5488, 0.12),
        intensity: Vec3::splat(0.05),
    }];
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let mean_indirect = |shadows: PlaneShadows| {
        let settings = CacheSettings {
            plane_shadows: shadows,
            ..CacheSettings::default()
        };
        let indirect = common::render_gi(&renderer, &scene, &settings)
            .indirect
            .expect("indirect");
        indirect.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / indirect.len() as f32
    };
    let rays = mean_indirect(PlaneShadows::Rays);
    let maps = mean_indirect(PlaneShadows::Auto);
    assert!(rays > 0.0, "the lamp lights the room");
    assert!(
        (maps / rays - 1.0).abs() < 0.01,
        "indirect light from the map {maps} against shadow rays {rays}"
    );
}
