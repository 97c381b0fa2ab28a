//! Projection of hemisphere planes onto hemispherical harmonics (issue 18: the incoming
//! radiance of radiance records): the GPU pass against its CPU mirror, the basis integrals
//! against the hemisphere's, and the projected radiance reproducing the plane's irradiance
//! through the exactly represented cosine lobe.

mod common;

use glam::DVec3;
use radsplat::Renderer;
use radsplat::hsh::{HemisphereQuadrature, coefficient_count};
use radsplat::records::kind::FRAME_FLOATS;
use radsplat::records::radiance_projection::{
    PlaneBasis, RadianceProjectionPass, limit_gradients, project, project_with_gradients,
};
use radsplat::records::reference::RecordReference;
use radsplat::records::{CacheSettings, PlaneSample, Record, RecordKind, RecordPass};
use radsplat::visibility::GpuCamera;

const ORDER: u32 = 6;

#[test]
fn the_plane_basis_integrates_the_basis_over_the_whole_hemisphere() {
    let settings = CacheSettings::default();
    let plane = settings.plane(settings.plane_resolution);
    let n = coefficient_count(ORDER);
    let q = HemisphereQuadrature::new(32);
    let exact = q.project(ORDER, |_| 1.0);
    // The stretched plane covers the hemisphere: sum_p W_pk = integral of H_k, up to the
    // quadrature of the border pixels (each stands for a wide band down to the horizon),
    // which converges as their cells shrink.
    let worst = |sub: u32| {
        let basis = PlaneBasis::new(&plane, ORDER, sub);
        (0..n)
            .map(|k| {
                let sum: f64 = (0..plane.pixels.len())
                    .map(|p| f64::from(basis.weights[p * n + k]))
                    .sum();
                (sum - exact[k]).abs()
            })
            .fold(0.0, f64::max)
    };
    let (w8, w16) = (worst(8), worst(16));
    eprintln!("largest error of sum_p W_pk: {w8:.2e} with 8x8 cells, {w16:.2e} with 16x16");
    assert!(w16 < 2e-3, "16x16 cells: {w16} (W_00 is about 2.5)");
    assert!(w16 < 0.5 * w8, "the quadrature converges: {w16} vs {w8}");
    // H_0^0 = 1 / sqrt(2 pi): its integral is sqrt(2 pi).
    assert!((exact[0] - (2.0 * std::f64::consts::PI).sqrt()).abs() < 1e-9);
}

// Tolerance: the GPU sums the same products in the same order, in f32; fused multiply-adds
// round differently, so coefficients agree to about 1e-6 of the largest.
#[test]
fn gpu_projection_matches_the_cpu_and_keeps_the_irradiance() {
    let scene = common::load("cornell-box.toml", Some((24, 24)));
    let renderer = Renderer::new(common::gpu()).expect("renderer");
    let prepared = renderer.prepare(&scene).expect("prepare");
    let settings = CacheSettings {
        plane_refine: 0.0,
        ..CacheSettings::default()
    };
    let frame = renderer
        .render_frame(&prepared, &scene.camera)
        .expect("frame");
    let cam = GpuCamera::new(&scene.camera);
    let hits: Vec<_> = frame.visibility.iter().filter(|v| v.is_hit()).collect();
    let sites: Vec<_> = (0..10)
        .map(|k| {
            RecordReference::site_from_pixel(
                &settings,
                &cam,
                hits[(k * 53 + 7) % hits.len()],
                k as u32,
            )
        })
        .collect();
    let pass = RecordPass::new(&renderer.ctx, &settings).expect("record pass");
    let samples = pass
        .trace_planes(&renderer.ctx, &prepared.gpu, &sites)
        .expect("planes");
    let plane = settings.plane(settings.plane_resolution);
    let projection =
        RadianceProjectionPass::new(&renderer.ctx, &plane, ORDER, 16).expect("projection pass");
    let n = coefficient_count(ORDER);
    let ctx = &renderer.ctx;
    let stride = RecordKind::Radiance { order: ORDER }.coefficient_floats();
    let samples_buf = ctx.storage_buffer("samples", &samples).expect("upload");
    let sites_buf = ctx.storage_buffer("sites", &sites).expect("upload");
    // The projection of every plane into a coefficient buffer that starts as `initial`.
    let project_on_gpu = |values_only: bool, initial: f32| -> Vec<f32> {
        let out = ctx
            .storage_buffer("coefficients", &vec![initial; sites.len() * stride])
            .expect("out");
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        projection.record(
            ctx,
            &mut enc,
            &prepared.gpu,
            &sites_buf,
            &samples_buf,
            &out,
            0,
            sites.len() as u32,
            values_only,
            None,
        );
        ctx.queue.submit([enc.finish()]);
        let read: Vec<f32> = ctx.read_buffer(&out).expect("read");
        ctx.check().expect("no wgpu errors");
        read
    };
    let gpu = project_on_gpu(false, 0.0);

    // The cosine lobe in 4 coefficients (exact, hsh tests), padded to ORDER.
    let q = HemisphereQuadrature::new(16);
    let cosine = q.project(ORDER, |w: DVec3| w.z);
    let per = plane.pixels.len();
    for (r, site) in sites.iter().enumerate() {
        let plane_samples: &[PlaneSample] = &samples[r * per..(r + 1) * per];
        let full = project_with_gradients(&projection.basis, plane_samples);
        let cpu = project(&projection.basis, plane_samples);
        let block = &gpu[r * stride..(r + 1) * stride];
        // The frame header is the site's turned plane frame: unit, orthogonal, about n.
        let t = glam::Vec3::new(block[0], block[1], block[2]);
        let b = glam::Vec3::new(block[4], block[5], block[6]);
        let nrm = glam::Vec3::from(site.normal);
        assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
        assert!(t.dot(b).abs() < 1e-5 && t.dot(nrm).abs() < 1e-5);
        assert!(
            (t.cross(b) - nrm).length() < 1e-4,
            "right-handed about the normal"
        );
        let g = &block[FRAME_FLOATS..];
        for part in 0..3 {
            let (gp, cp) = (
                &g[part * 3 * n..(part + 1) * 3 * n],
                &full[part * 3 * n..(part + 1) * 3 * n],
            );
            let largest = cp.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            for (a, b) in gp.iter().zip(cp) {
                assert!(
                    (a - b).abs() <= 1e-5 * largest.max(1e-6),
                    "record {r} part {part}: {a} vs {b}"
                );
            }
        }
        // E from the coefficients (lambda . cos) equals E from the plane (sum L cos_weight).
        for c in 0..3 {
            let from_hsh: f64 = (0..n).map(|k| f64::from(cpu[c * n + k]) * cosine[k]).sum();
            let from_plane: f64 = plane_samples
                .iter()
                .zip(&plane.pixels)
                .map(|(s, p)| f64::from(s.radiance[c]) * f64::from(p.cos_weight))
                .sum();
            assert!(
                (from_hsh - from_plane).abs() <= 2e-3 * from_plane.abs().max(1e-3),
                "record {r} ({site:?}) channel {c}: E {from_hsh} from HSH, {from_plane} from the plane"
            );
        }
    }

    // Ward's gradient limit on the coefficients (`radiance_limit.wgsl`) against its CPU
    // mirror: records of radius 1 whose R_min makes the limit shrink R alone, scale the
    // gradients at R_min, or leave the record as it is.
    const REACH: f32 = 0.25;
    let records: Vec<Record> = (0..sites.len())
        .map(|r| Record {
            radius: 1.0,
            r_min: [1e-4, 0.05, 1.0][r % 3],
            ..Record::default()
        })
        .collect();
    let records_buf = ctx.storage_buffer("records", &records).expect("upload");
    let limited_buf = ctx.storage_buffer("coefficients", &gpu).expect("upload");
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    projection.record_limit(
        ctx,
        &mut enc,
        &prepared.gpu,
        &records_buf,
        &limited_buf,
        0,
        sites.len() as u32,
        REACH,
        None,
    );
    ctx.queue.submit([enc.finish()]);
    let limited_records: Vec<Record> = ctx.read_buffer(&records_buf).expect("read");
    let limited: Vec<f32> = ctx.read_buffer(&limited_buf).expect("read");
    ctx.check().expect("no wgpu errors");
    let (mut shrunk, mut scaled) = (0, 0);
    for (r, record) in records.iter().enumerate() {
        let mut cpu = gpu[r * stride + FRAME_FLOATS..(r + 1) * stride].to_vec();
        let radius = limit_gradients(&mut cpu, ORDER, record.radius, record.r_min, REACH);
        let got = &limited_records[r];
        assert!(
            (got.radius - radius).abs() <= 1e-5 * radius,
            "record {r}: R {} on the GPU, {radius} on the CPU",
            got.radius
        );
        let block = &limited[r * stride + FRAME_FLOATS..(r + 1) * stride];
        let largest = cpu.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        for (a, b) in block.iter().zip(&cpu) {
            assert!((a - b).abs() <= 1e-5 * largest, "record {r}: {a} vs {b}");
        }
        // The limit holds: a R |grad lambda| <= |lambda| per channel, to rounding.
        for c in 0..3 {
            let norm =
                |range: std::ops::Range<usize>| block[range].iter().map(|v| v * v).sum::<f32>();
            let v = norm(c * n..(c + 1) * n).sqrt();
            let g = (norm(3 * n + c * n..3 * n + (c + 1) * n)
                + norm(6 * n + c * n..6 * n + (c + 1) * n))
            .sqrt();
            assert!(
                REACH * got.radius * g <= v * 1.0001,
                "record {r} channel {c}"
            );
        }
        shrunk += usize::from(got.radius < 1.0);
        scaled +=
            usize::from(block[3 * n..] != gpu[r * stride + FRAME_FLOATS + 3 * n..(r + 1) * stride]);
    }
    assert!(
        shrunk > 0 && scaled > 0 && scaled < sites.len(),
        "{shrunk} records shrunk, {scaled} of {} scaled",
        sites.len()
    );

    // Values only (the estimates at t+1 that give tau): the same values bit for bit, the
    // gradients' floats left as they were.
    const UNTOUCHED: f32 = 7.25;
    let values = project_on_gpu(true, UNTOUCHED);
    for r in 0..sites.len() {
        let (v, full) = (
            &values[r * stride..(r + 1) * stride],
            &gpu[r * stride..(r + 1) * stride],
        );
        let gradients = FRAME_FLOATS + 3 * n;
        assert_eq!(
            v[..gradients],
            full[..gradients],
            "record {r}: frame and values"
        );
        assert!(
            v[gradients..].iter().all(|&g| g == UNTOUCHED),
            "record {r}: gradients written"
        );
    }
}

/// The coefficients' edge weights reduce to the irradiance's: the cosine is
/// `(H_0^0 + H_1^0 / sqrt3) sqrt(2 pi) / 2` (l <= 1 span it, algorithms.md 2.2), and the
/// same combination of the HSH edge weights must give the plane's own `edge_x`, `edge_y`
/// (`1 / (1 + x^2 + y^2)^2 = cos / (1 + x^2 + y^2)^(3/2)`), stretched border edges included.
#[test]
fn coefficient_edge_weights_reduce_to_the_irradiance_edge_weights() {
    let settings = CacheSettings::default();
    let plane = settings.plane(settings.plane_resolution);
    let basis = PlaneBasis::new(&plane, 2, 16);
    let q = HemisphereQuadrature::new(8);
    let cosine = q.project(2, |w: DVec3| w.z);
    let mut worst: f64 = 0.0;
    for (p, px) in plane.pixels.iter().enumerate() {
        for (weights, exact) in [(&basis.edge_x, px.edge_x), (&basis.edge_y, px.edge_y)] {
            let from_hsh: f64 = (0..4)
                .map(|k| f64::from(weights[p * 4 + k]) * cosine[k])
                .sum();
            worst =
                worst.max((from_hsh - f64::from(exact)).abs() / f64::from(exact).abs().max(1e-3));
        }
    }
    assert!(worst < 1e-3, "relative error {worst}");
}
