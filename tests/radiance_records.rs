//! Radiance records (issue 18): coefficient gradients against finite differences, the
//! record's frame rotated into a tilted pixel's against a record computed there, the
//! three rotation methods' errors, the GPU radiance gather against its CPU mirror (a flat
//! glossy wall and a glossy sphere, whose records need the tilt), glossy renders against
//! the reference, and determinism.

mod common;

use glam::{Mat3, Vec3};
use radsplat::Renderer;
use radsplat::frame::RadianceCache;
use radsplat::hsh::coefficient_count;
use radsplat::hsh::rotation::{RotationMethod, rotation_error};
use radsplat::records::kind::FRAME_FLOATS;
use radsplat::records::radiance_projection::{PlaneBasis, project_with_gradients};
use radsplat::records::reference::RecordReference;
use radsplat::records::{CacheSettings, Record, RecordKind, RecordSite};
use radsplat::reference::{ReferenceOptions, ReferencePass};
use radsplat::sampling::record_frame;
use radsplat::scene::{GlossyLobe, Scene};
use radsplat::splat::radiance::{
    RadianceRecord, RadianceSettings, RadianceTables, record_radiance_at, reference_gather,
};
use radsplat::visibility::GpuCamera;

/// A floor under a 1 x 1 emitting square (MTL `Ke`) and a second, dimmer one to the side:
/// the incoming radiance changes smoothly with position and direction.
fn emitters_over_floor() -> Scene {
    common::scene_from_texts(
        "radiance",
        "mtllib scene.mtl\n\
         v -20 0 -20\nv 20 0 -20\nv 20 0 20\nv -20 0 20\n\
         v 0.5 1 -0.5\nv 1.5 1 -0.5\nv 1.5 1 0.5\nv 0.5 1 0.5\n\
         v -2 0.5 -1\nv -2 0.5 1\nv -2 1.5 1\nv -2 1.5 -1\n\
         usemtl floor\nf 1 4 3\nf 1 3 2\n\
         usemtl emitter\nf 5 6 7\nf 5 7 8\n\
         usemtl side\nf 9 12 11\nf 9 11 10\n",
        "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl emitter\nKd 0 0 0\nKe 1 2 3\n\
         newmtl side\nKd 0 0 0\nKe 0.5 0.4 0.3\n",
        "[camera]\nposition = [0, 3, 3]\ntarget = [0, 0, 0]\nfov_y = 60\nresolution = [16, 16]\n\
         [[mesh]]\nfile = \"scene.obj\"\n",
    )
}

/// A plain 130-degree plane (no refinement): what the projections below read.
fn plane_settings(resolution: u32) -> CacheSettings {
    CacheSettings {
        plane_resolution: resolution,
        plane_fov_degrees: 130.0,
        plane_refine: 0.0,
        ..CacheSettings::default()
    }
}

fn site(position: Vec3, normal: Vec3) -> RecordSite {
    RecordSite {
        position: position.into(),
        r_min: 1e-3,
        normal: normal.into(),
        seed: 7,
        geometric_normal: normal.into(),
        instance: 0,
    }
}

fn rr<'a>(record: &'a Record, block: &'a [f32]) -> RadianceRecord<'a> {
    RadianceRecord { record, block }
}

/// A radiance record's block computed on the CPU: frame, coefficients, gradients.
fn block(reference: &RecordReference<'_>, basis: &PlaneBasis, s: &RecordSite) -> Vec<f32> {
    let samples = reference.trace_plane(s);
    let frame: Mat3 = record_frame(s.normal.into(), s.seed);
    let mut out = vec![0.0f32; FRAME_FLOATS];
    out[..3].copy_from_slice(&frame.x_axis.to_array());
    out[4..7].copy_from_slice(&frame.y_axis.to_array());
    out.extend(project_with_gradients(basis, &samples));
    out
}

/// An emitting parallelogram: corner, two edges, radiance.
type Emitter = ([f64; 3], [f64; 3], [f64; 3], [f64; 3]);

/// The emitters of [`emitters_over_floor`].
const EMITTERS: [Emitter; 2] = [
    (
        [0.5, 1.0, -0.5],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 2.0, 3.0],
    ),
    (
        [-2.0, 0.5, -1.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 2.0],
        [0.5, 0.4, 0.3],
    ),
];

/// The exact red coefficients at `p` in `frame` (the emitters are the only light and
/// nothing occludes them): `integral over each emitter of L H_k(w) cos_e / r^2 dA`, by a
/// 400 x 400 midpoint rule over its area, in f64.
fn exact_coefficients(p: Vec3, frame: Mat3, order: u32) -> Vec<f64> {
    let n = coefficient_count(order);
    let p = p.as_dvec3();
    let (fx, fy, fz) = (
        frame.x_axis.as_dvec3(),
        frame.y_axis.as_dvec3(),
        frame.z_axis.as_dvec3(),
    );
    let mut c = vec![0.0f64; n];
    let cells = 400;
    for (corner, eu, ev, radiance) in EMITTERS {
        let (corner, eu, ev) = (
            glam::DVec3::from(corner),
            glam::DVec3::from(eu),
            glam::DVec3::from(ev),
        );
        let normal = eu.cross(ev);
        let area = normal.length();
        let normal = normal / area;
        let da = area / (cells * cells) as f64;
        for i in 0..cells {
            for j in 0..cells {
                let q = corner
                    + eu * ((i as f64 + 0.5) / cells as f64)
                    + ev * ((j as f64 + 0.5) / cells as f64);
                let d = q - p;
                let r2 = d.length_squared();
                let w = d / r2.sqrt();
                let cos_e = -w.dot(normal);
                let local = glam::DVec3::new(w.dot(fx), w.dot(fy), w.dot(fz));
                if cos_e <= 0.0 || local.z <= 0.0 {
                    continue;
                }
                let weight = radiance[0] * cos_e / r2 * da;
                for (ck, hk) in c.iter_mut().zip(radsplat::hsh::basis(order, local)) {
                    *ck += weight * hk;
                }
            }
        }
    }
    c
}

/// Translational gradients of the coefficients (from the plane's pixel edges) against
/// central finite differences of the exact coefficients, over every red coefficient,
/// along both tangent axes; and the coefficients themselves against the exact ones.
#[test]
fn coefficient_gradients_match_finite_differences() {
    let scene = emitters_over_floor();
    // The default 170-degree cosine-spaced plane: the side emitter lies 53-76 degrees off
    // the normal, where a 130-degree plane has only its stretched border pixels.
    let settings = CacheSettings {
        plane_resolution: 128,
        plane_refine: 0.0,
        ..CacheSettings::default()
    };
    let reference = RecordReference::new(&scene, &settings);
    let order = 4;
    let n = coefficient_count(order);
    let plane = settings.plane(settings.plane_resolution);
    let basis = PlaneBasis::new(&plane, order, 4);
    let p = Vec3::new(0.0, 0.0, 0.2);
    let centre = block(&reference, &basis, &site(p, Vec3::Y));
    let frame = record_frame(Vec3::Y, 7);
    let v = FRAME_FLOATS;
    let exact = exact_coefficients(p, frame, order);
    let largest_c = exact.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let worst_c = (0..n)
        .map(|k| (f64::from(centre[v + k]) - exact[k]).abs())
        .fold(0.0f64, f64::max);
    eprintln!("coefficients: largest {largest_c:.4}, worst error {worst_c:.4}");
    // Stated tolerance: 1 % of the largest coefficient (measured: 0.2 %).
    assert!(
        worst_c <= 0.01 * largest_c,
        "coefficients: {worst_c} vs {largest_c}"
    );
    let h = 1e-3;
    for axis in [Vec3::X, Vec3::Z] {
        let plus = exact_coefficients(p + axis * h, frame, order);
        let minus = exact_coefficients(p - axis * h, frame, order);
        let (ax, ay) = (frame.x_axis.dot(axis), frame.y_axis.dot(axis));
        let mut worst = 0.0f64;
        let mut largest = 0.0f64;
        for k in 0..n {
            let fd = (plus[k] - minus[k]) / (2.0 * f64::from(h));
            let grad = f64::from(ax * centre[v + 3 * n + k] + ay * centre[v + 6 * n + k]);
            worst = worst.max((grad - fd).abs());
            largest = largest.max(fd.abs());
        }
        eprintln!("along {axis:?}: largest |d lambda/dx| {largest:.4}, worst error {worst:.4}");
        assert!(largest > 0.05, "the field changes along {axis:?}");
        // Stated tolerance: 3 % of the largest derivative (measured: under 1 %; the edge
        // sums are first order in the plane's pixel size, 128 x 128 here).
        assert!(
            worst <= 0.03 * largest,
            "along {axis:?}: worst error {worst} against largest {largest}"
        );
    }
}

/// A record whose normal is tilted from the pixel's, rotated into the pixel's frame, shades
/// the pixel's lobe like a record computed at the pixel with the pixel's normal; without the
/// rotation (its coefficients read as if in the pixel's frame) it does much worse.
#[test]
fn rotated_records_shade_like_records_computed_at_the_pixel() {
    let scene = emitters_over_floor();
    let settings = plane_settings(96);
    let reference = RecordReference::new(&scene, &settings);
    let radiance = RadianceSettings::default();
    let order = radiance.order;
    let plane = settings.plane(settings.plane_resolution);
    let basis = PlaneBasis::new(&plane, order, 4);
    let lobe = GlossyLobe::Phong {
        specular: Vec3::ONE,
        exponent: 10.0,
    };
    let methods: Vec<RadianceTables> = RotationMethod::ALL
        .iter()
        .map(|&rotation| {
            RadianceTables::new(
                &[Some(lobe)],
                RadianceSettings {
                    rotation,
                    ..radiance
                },
            )
        })
        .collect();
    assert_eq!(
        methods[0].slots,
        vec![0],
        "a Phong-10 lobe gets radiance records"
    );
    let p = Vec3::new(0.3, 0.0, 0.1);
    let record_at = |normal: Vec3| {
        let r = Record {
            position: p.into(),
            normal: normal.into(),
            radius: 1.0,
            ..Default::default()
        };
        (r, block(&reference, &basis, &site(p, normal)))
    };
    let (r0, b0) = record_at(Vec3::Y);
    for degrees in [8.0f32, 16.0] {
        let tilt = glam::Quat::from_axis_angle(Vec3::Z, degrees.to_radians());
        let np = tilt * Vec3::Y;
        let (r1, b1) = record_at(np);
        let mut err = [0.0f32; 3];
        let mut unrotated = 0.0f32;
        let mut total = 0.0f32;
        for k in 0..12 {
            // View directions around the pixel's normal, 20..60 degrees off it.
            let theta = (20.0 + 40.0 * (k % 3) as f32 / 2.0).to_radians();
            let phi = k as f32 * 0.52;
            let local = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            let wo = (tilt * (Mat3::from_cols(Vec3::X, -Vec3::Z, Vec3::Y) * local)).normalize();
            let tables = &methods[0];
            let direct = record_radiance_at(tables, 0, &rr(&r1, &b1), p, np, wo);
            for (e, t) in err.iter_mut().zip(&methods) {
                let moved = record_radiance_at(t, 0, &rr(&r0, &b0), p, np, wo);
                *e += (moved - direct).length_squared();
            }
            // The record's coefficients read as if its frame were the pixel's.
            let mut b_same = b0.clone();
            b_same[..FRAME_FLOATS].copy_from_slice(&b1[..FRAME_FLOATS]);
            let naive = record_radiance_at(tables, 0, &rr(&r1, &b_same), p, np, wo);
            unrotated += (naive - direct).length_squared();
            total += direct.length_squared();
        }
        let err = err.map(|e| (e / total).sqrt());
        let unrotated = (unrotated / total).sqrt();
        eprintln!(
            "tilt {degrees} deg: tabulated {:.4}, conversion matrix {:.4}, digon deletion {:.4}, \
             unrotated {unrotated:.4} (relative RMS of the shaded lobe)",
            err[0], err[1], err[2]
        );
        // Stated tolerance: 6 % at 16 degrees for the default (tabulated); most of it is
        // the side emitter's light that the tilted pixel sees below the record's horizon,
        // which no rotation can supply.
        assert!(err[0] < 0.06, "tilt {degrees}: relative error {}", err[0]);
        // At 16 degrees the missing light dominates every method's error and they tie
        // (measured 3.97 %, 3.96 %, 4.21 % at order 8); at 8 the tabulated one is ahead.
        let others = err[1].min(err[2]);
        assert!(err[0] <= 1.05 * others, "tilt {degrees}: {err:?}");
        if degrees < 10.0 {
            assert!(err[0] < others, "tilt {degrees}: {err:?}");
        }
        assert!(
            err[0] < 0.2 * unrotated,
            "tilt {degrees}: {err:?} vs unrotated {unrotated}"
        );
    }
}

/// The tabulated tilt matrix is the exact rotation of what the record saw: it matches
/// projecting the tilted field over the directions both hemispheres share, which checks
/// the matrix's index convention and quadrature; the other two methods approximate it.
#[test]
fn the_tabulated_rotation_is_the_exact_rotation_of_what_the_record_saw() {
    let field = |v: glam::DVec3| 1.0 + 0.8 * v.x + 3.0 * v.x.max(0.0).powi(4) + 0.5 * v.y * v.z;
    for beta in [0.15, 0.35] {
        let errors: Vec<(f64, f64)> = RotationMethod::ALL
            .iter()
            .map(|&m| rotation_error(m, 5, beta, field))
            .collect();
        eprintln!(
            "beta {beta}: (against the ideal, against the direct record) for tabulated, conversion matrix, digon deletion = {errors:?}"
        );
        assert!(
            errors[0].0 < 1e-3,
            "tabulated against the ideal: {}",
            errors[0].0
        );
        assert!(errors.iter().all(|e| e.0.is_finite() && e.1.is_finite()));
    }
}

/// With `second`, the material named "sphere" gets a glossy lobe of that exponent too.
/// Returns the records' order and the bands each lobe kept.
fn gpu_gather_matches_cpu(
    name: &str,
    size: u32,
    order: u32,
    exponent: f32,
    lobe_share: f32,
    second: Option<f32>,
) -> (u32, Vec<u32>) {
    let mut scene = common::load(name, Some((size, size)));
    scene.settings.light_samples = 2;
    // A broad lobe, so that records reach across the sphere's curvature (tilted frames).
    for m in &mut scene.materials {
        if let Some(GlossyLobe::Phong { specular, .. }) = m.glossy {
            m.glossy = Some(GlossyLobe::Phong { specular, exponent });
        }
    }
    if let Some(exponent) = second {
        let m = scene.materials.iter_mut().find(|m| m.name == "sphere");
        m.expect("a material named sphere").glossy = Some(GlossyLobe::Phong {
            specular: Vec3::splat(0.2),
            exponent,
        });
    }
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let settings = CacheSettings {
        glossy_samples: 4,
        radiance: RadianceSettings {
            order,
            min_lobe_accuracy: 0.0,
            lobe_share,
            ..Default::default()
        },
        ..CacheSettings::default()
    };
    let mut cache = renderer.new_cache(&settings).expect("cache");
    renderer
        .render_gi_frame(&prepared, &scene.camera, &mut cache, None, |_| {})
        .expect("GI frame");
    let rc: &RadianceCache = cache.radiance.as_ref().expect("radiance records");
    assert!(rc.records.count > 0, "{name}: radiance records placed");
    let bands: Vec<u32> = rc.splat.tables.lobes.iter().map(|t| t.bands).collect();
    eprintln!("{name}: Phong {exponent} at order {order}: bands {bands:?}");
    // Records carry the most bands a lobe keeps.
    let record_order = bands.iter().copied().max().expect("a lobe");
    assert!(record_order <= order);
    assert_eq!(
        rc.records.kind,
        RecordKind::Radiance {
            order: record_order
        }
    );
    let records = rc.records.read(&renderer.ctx).expect("records");
    let blocks = rc
        .records
        .read_coefficients(&renderer.ctx)
        .expect("coefficients");
    let (vis, gpu) = renderer
        .splat_radiance_cache(&prepared, &scene.camera, rc)
        .expect("radiance splat");
    let cpu = reference_gather(
        &rc.splat.tables,
        &records,
        &blocks,
        &GpuCamera::new(&scene.camera),
        &vis,
    );
    let mut covered = 0;
    let mut errors = Vec::new();
    for (g, c) in gpu.iter().zip(&cpu) {
        if c[3] > 0.0 {
            covered += 1;
            let (gl, cl) = (
                Vec3::new(g[0], g[1], g[2]) / g[3],
                Vec3::new(c[0], c[1], c[2]) / c[3],
            );
            errors.push((gl - cl).abs().max_element() / cl.max_element().max(1e-3));
            assert!(
                (g[3] - c[3]).abs() <= 1e-4 * c[3],
                "weights {} vs {}",
                g[3],
                c[3]
            );
        } else {
            assert_eq!(g[3], 0.0, "the GPU covers a pixel the CPU does not");
        }
    }
    errors.sort_by(f32::total_cmp);
    let p99 = errors[errors.len() * 99 / 100];
    eprintln!("{name}: {covered} covered pixels, 99th percentile relative error {p99:.2e}");
    assert!(covered > 20, "{name}: {covered} covered pixels");
    // Stated tolerance: f32 on the GPU against f64 on the CPU (the tilt matrices are f32
    // in both; acos near 1 loses digits).
    assert!(p99 < 2e-3, "{name}: 99th percentile relative error {p99}");
    (record_order, bands)
}

#[test]
fn gpu_radiance_gather_matches_the_cpu_on_a_flat_glossy_wall() {
    gpu_gather_matches_cpu(
        "cornell-box-glossy.toml",
        32,
        RadianceSettings::default().order,
        10.0,
        RadianceSettings::default().lobe_share,
        None,
    );
}

#[test]
fn gpu_radiance_gather_matches_the_cpu_on_a_glossy_sphere() {
    gpu_gather_matches_cpu(
        "env-sphere.toml",
        32,
        RadianceSettings::default().order,
        10.0,
        RadianceSettings::default().lobe_share,
        None,
    );
}

/// A broad lobe keeps few bands (hsh::brdf_projection::LobeTable::truncated): beside a
/// sharper lobe that keeps more (and sets the records' order), the GPU's tilt stops at the
/// broad lobe's bands, the CPU mirror multiplies its zeros.
#[test]
fn gpu_radiance_gather_matches_the_cpu_for_a_broad_lobe_on_a_glossy_sphere() {
    let order = RadianceSettings::default().order;
    let (record_order, bands) =
        gpu_gather_matches_cpu("env-sphere.toml", 32, order, 2.0, 0.995, Some(10.0));
    let broad = bands.iter().copied().min().expect("two lobes");
    assert_eq!(bands.len(), 2);
    assert!(broad <= order / 2, "Phong 2 kept {broad} of {order} bands");
    assert!(
        broad < record_order,
        "bands {bands:?}, records of order {record_order}"
    );
}

/// At order 10 a tilted record costs about 1,850 loop iterations of the gather
/// (`RadianceTables::iterations_per_record`; 2,800 before the tilt went block-wise), and llvmpipe
/// stops an invocation after 65,535 in all: the gather is split into dispatches over each
/// tile's list (splat::radiance::RadianceSplatPass::gather). Before the split, the pixels
/// of this sphere with the most records lost some (99th-percentile error 175 %).
#[test]
fn gpu_radiance_gather_matches_the_cpu_at_order_10_on_a_glossy_sphere() {
    // Every band kept (a lobe share of 1), so the records are of order 10.
    let (record_order, _) = gpu_gather_matches_cpu("env-sphere.toml", 32, 10, 10.0, 1.0, None);
    assert_eq!(record_order, 10);
}

/// The glossy Cornell box with radiance records against the path-traced reference: the
/// back wall's indirect light within a stated tolerance of the reference, and no worse
/// than Monte Carlo at the default sample count by more than a margin.
#[test]
fn glossy_cornell_box_with_radiance_records_matches_the_reference() {
    let mut scene = common::load("cornell-box-glossy.toml", Some((64, 64)));
    scene.settings.light_samples = 2;
    // The wall's Lambertian lobe off: its indirect light is the glossy lobe's alone.
    let glossy_wall = scene
        .materials
        .iter()
        .position(|m| m.name == "glossy_white")
        .expect("glossy wall");
    scene.materials[glossy_wall].albedo = Vec3::ZERO;
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let pass = ReferencePass::new(&renderer.ctx).expect("reference pass");
    let reference_with = |seed: u32| {
        pass.render(
            &renderer,
            &prepared,
            &scene.camera,
            &ReferenceOptions {
                seed,
                ..ReferenceOptions::new(512)
            },
            &mut |_, _| {},
        )
        .expect("reference")
    };
    let reference = reference_with(0);
    let second = reference_with(2);
    let render = |order: u32| {
        let settings = CacheSettings {
            radiance: RadianceSettings {
                order,
                ..Default::default()
            },
            ..CacheSettings::default()
        };
        let mut cache = renderer.new_cache(&settings).expect("cache");
        let frame = renderer
            .render_gi_frame(&prepared, &scene.camera, &mut cache, None, |_| {})
            .expect("GI frame");
        (frame, cache.radiance.map_or(0, |r| r.records.count))
    };
    let wall = scene
        .materials
        .iter()
        .position(|m| m.name == "glossy_white")
        .expect("glossy wall") as u32;
    let wall_error = |vis: &[radsplat::visibility::VisSample], indirect: &[[f32; 4]]| {
        let (mut se, mut sr) = (0.0f64, 0.0f64);
        for (i, v) in vis.iter().enumerate() {
            if !v.is_hit() {
                continue;
            }
            let mesh = scene.instances[v.instance as usize].mesh as usize;
            if scene.meshes[mesh].material_ids[v.mesh_triangle as usize] == wall {
                for (a, r) in indirect[i].iter().zip(&reference.indirect[i]).take(3) {
                    let d = f64::from(a - r);
                    se += d * d;
                    sr += f64::from(*r).powi(2);
                }
            }
        }
        (se / sr).sqrt()
    };
    let (cached, records) = render(RadianceSettings::default().order);
    let (mc, none) = render(0);
    assert!(records > 0 && none == 0);
    let indirect = |f: &radsplat::frame::Frame| f.indirect.clone().expect("indirect");
    let vis = &cached.visibility;
    let (e_cached, e_mc) = (
        wall_error(vis, &indirect(&cached)),
        wall_error(vis, &indirect(&mc)),
    );
    // The reference's own noise: a second seed against the first.
    let noise = wall_error(vis, &second.indirect);
    eprintln!(
        "glossy wall relative RMS error: radiance records {e_cached:.4} ({records} records), \
         Monte Carlo (32 lobe rays) {e_mc:.4}, reference noise {noise:.4}"
    );
    // Stated tolerance: radiance records beat 32 Monte Carlo lobe rays per pixel on the
    // wall, and their error above the reference's noise is under 20 % (64 x 64, 50
    // records; docs/results.md has the full-size figures).
    assert!(
        e_cached < e_mc,
        "radiance records {e_cached} vs Monte Carlo {e_mc}"
    );
    let excess = (e_cached * e_cached - noise * noise).max(0.0).sqrt();
    assert!(
        excess < 0.2,
        "radiance records: {e_cached} with reference noise {noise}"
    );
    // Both frames: the same bytes on a second run.
    let (again, _) = render(RadianceSettings::default().order);
    assert_eq!(
        bytemuck::cast_slice::<[f32; 4], u8>(&cached.beauty),
        bytemuck::cast_slice::<[f32; 4], u8>(&again.beauty),
        "two runs differ"
    );
}

/// Radiance records on the back wall a few cm behind the tall block see the block at
/// depths far below their reach (a R), where the edge slopes of their coefficients'
/// gradients hold only over displacements smaller than those depths. Without Ward's limit
/// on the coefficients (`radiance_limit.wgsl`) the wall beside the block got 20-70x its
/// light at 48 x 48 (worst pixel off by 0.08 against a wall mean of about 0.02; indirect
/// error 22 % against 5.5 % with the limit, docs/results.md).
#[test]
fn radiance_records_beside_an_object_do_not_overshoot_the_reference() {
    let scene = common::load("cornell-box-glossy.toml", Some((48, 48)));
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let reference = common::reference_indirect(&renderer, &scene, 256);
    let (frame, cache) = common::render_gi_with_cache(&renderer, &scene, &CacheSettings::default());
    assert!(cache.radiance.as_ref().is_some_and(|r| r.records.count > 0));
    let indirect = frame.indirect.expect("indirect");
    let wall = scene
        .materials
        .iter()
        .position(|m| m.name == "glossy_white")
        .expect("glossy wall") as u32;
    let luminance = |p: [f32; 4]| (p[0] + p[1] + p[2]) / 3.0;
    let (mut worst, mut mean, mut n) = (0.0f32, 0.0f32, 0);
    for (i, v) in frame.visibility.iter().enumerate() {
        if !v.is_hit() {
            continue;
        }
        let mesh = scene.instances[v.instance as usize].mesh as usize;
        if scene.meshes[mesh].material_ids[v.mesh_triangle as usize] == wall {
            let r = luminance(reference[i]);
            worst = worst.max((luminance(indirect[i]) - r).abs());
            mean += r;
            n += 1;
        }
    }
    mean /= n as f32;
    eprintln!("back wall ({n} pixels): worst indirect error {worst:.4}, mean {mean:.4}");
    // Stated tolerance: no wall pixel off by more than the wall's mean indirect light
    // (with the limit the worst is 0.69 of it, without 5x; the reference's noise at 256 spp is
    // a few % of a pixel).
    assert!(n > 300, "{n} wall pixels");
    assert!(
        worst < mean,
        "a wall pixel is off by {worst}, the wall's mean indirect light is {mean}"
    );
}

/// Order 10 is 908 floats per record: one 128 MiB binding holds about 37,000. Asking for
/// more fails cleanly, naming the kind and what to change, before anything is allocated.
#[test]
fn radiance_records_past_the_binding_limit_are_refused() {
    let ctx = common::gpu();
    let kind = RecordKind::Radiance { order: 10 };
    assert_eq!(kind.coefficient_floats(), 908);
    let mut cache = radsplat::records::RecordCache::with_kind(&ctx, kind).expect("cache");
    let max = cache.max_records(&ctx);
    assert_eq!(max, ctx.max_binding_size() / kind.coefficient_bytes());
    let err = cache
        .reserve(&ctx, max as u32 + 1)
        .expect_err("past the binding limit")
        .to_string();
    assert!(
        err.contains("radiance records of HSH order 10") && err.contains("--radiance-order"),
        "{err}"
    );
    cache.reserve(&ctx, 2048).expect("within the limit");
    ctx.check().expect("no wgpu errors");
}
