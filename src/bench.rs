//! Kernel benchmarks behind `radsplat bench`: BVH build time, GPU rays per second for
//! primary, shadow and incoherent (cosine-hemisphere) rays, and obvhs's CPU traversal on
//! one thread over the same incoherent rays. Reports medians of several runs.

use crate::bvh::cpu_trace::CpuTracer;
use crate::bvh::trace_pass::{GpuHit, GpuRay, RayBatch, TraceRaysPass};
use crate::bvh::{BvhPreset, SceneBvh};
use crate::direct::reference::offset_ray_origin;
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, GpuScene};
use crate::sampling::{cosine_hemisphere, hash_combine, hash_u32, orthonormal_basis, sobol_2d};
use crate::scene::{Light, Scene, load_scene};
use crate::visibility::GpuCamera;
use crate::{Error, Result};
use glam::Vec3;
use std::path::Path;
use std::time::Instant;

/// Incoherent rays per primary hit.
pub const RAYS_PER_HIT: u32 = 4;

/// The rays of one benchmark: camera rays, shadow rays to the first light from every
/// primary hit, and cosine-hemisphere rays from every primary hit.
pub struct BenchRays {
    pub primary: Vec<GpuRay>,
    pub shadow: Vec<GpuRay>,
    pub incoherent: Vec<GpuRay>,
}

/// Builds the benchmark rays on the CPU (primary hits found with the CPU tracer).
pub fn make_rays(scene: &Scene, tracer: &CpuTracer) -> BenchRays {
    let cam = GpuCamera::new(&scene.camera);
    let origin = Vec3::from(cam.origin);
    let mut primary = Vec::new();
    let mut shadow = Vec::new();
    let mut incoherent = Vec::new();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let dir = cam.ray_dir(x, y);
            primary.push(GpuRay::new(origin, dir, 0.0, f32::INFINITY));
            let Some(hit) = tracer.closest_hit(origin, dir, 0.0, f32::INFINITY) else {
                continue;
            };
            let p = origin + dir * hit.t;
            // Geometric normal facing the camera, from the hit triangle.
            let n = hit_normal(tracer, &hit, dir);
            let o = offset_ray_origin(p, n);
            let seed = hash_u32(y * cam.width + x);
            if let Some(light) = scene.lights.first() {
                shadow.push(shadow_ray(light, o, seed));
            }
            let frame = orthonormal_basis(n);
            for k in 0..RAYS_PER_HIT {
                let d = frame * cosine_hemisphere(sobol_2d(k, hash_combine(seed, 7)));
                incoherent.push(GpuRay::new(o, d, 0.0, f32::INFINITY));
            }
        }
    }
    BenchRays {
        primary,
        shadow,
        incoherent,
    }
}

fn hit_normal(tracer: &CpuTracer, hit: &crate::bvh::cpu_trace::CpuHit, dir: Vec3) -> Vec3 {
    let t = &tracer.triangles[hit.leaf as usize];
    let n = Vec3::from((t.v1 - t.v0).cross(t.v2 - t.v0)).normalize_or_zero();
    if n.dot(dir) > 0.0 { -n } else { n }
}

fn shadow_ray(light: &Light, o: Vec3, seed: u32) -> GpuRay {
    match *light {
        Light::Point { position, .. } | Light::Spot { position, .. } => {
            GpuRay::new(o, position - o, 0.0, 1.0 - 1e-4)
        }
        Light::Rect {
            corner,
            edge_u,
            edge_v,
            ..
        } => {
            let xi = sobol_2d(0, seed);
            let q = corner + xi.x * edge_u + xi.y * edge_v;
            GpuRay::new(o, q - o, 0.0, 1.0 - 1e-4)
        }
        Light::Sun { direction, .. } => GpuRay::new(o, direction.normalize(), 0.0, f32::INFINITY),
    }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// One row of the benchmark table.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchRow {
    pub name: String,
    pub rays: usize,
    pub median_ms: f64,
    pub mrays_per_s: f64,
}

/// Everything `radsplat bench` measures.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchReport {
    pub scene: String,
    pub adapter: String,
    pub width: u32,
    pub height: u32,
    pub triangles: usize,
    pub runs: usize,
    pub bvh_preset: BvhPreset,
    pub bvh_build_ms: f64,
    pub rows: Vec<BenchRow>,
    /// GPU incoherent Mrays/s divided by CPU (obvhs, 1 thread) incoherent Mrays/s.
    pub gpu_over_cpu_incoherent: f64,
    /// Incoherent rays whose GPU closest hit differs from the CPU's (instance/triangle).
    pub incoherent_mismatches: usize,
}

/// GPU time of one trace of `batch`, in ms (timestamps when available, else wall time).
fn time_gpu(
    ctx: &GpuContext,
    pass: &TraceRaysPass,
    scene: &GpuScene,
    batch: &RayBatch,
) -> Result<f64> {
    let mut timer = PassTimer::new(ctx, 1);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    let t0 = Instant::now();
    pass.record(&mut encoder, scene, batch, timer.next("trace"));
    timer.resolve(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    ctx.wait()?;
    let wall = t0.elapsed().as_secs_f64() * 1e3;
    Ok(timer.read(ctx)?.first().map(|t| t.1).unwrap_or(wall))
}

/// Runs the benchmark on an already loaded scene.
pub fn run(
    ctx: &GpuContext,
    scene: &Scene,
    runs: usize,
    preset: BvhPreset,
    mut progress: impl FnMut(&str),
) -> Result<BenchReport> {
    let runs = runs.max(1);
    progress("building BVH");
    let mut build = Vec::new();
    let mut bvh = None;
    for _ in 0..runs {
        let t0 = Instant::now();
        let b = SceneBvh::build_with(scene, preset);
        build.push(t0.elapsed().as_secs_f64() * 1e3);
        bvh = Some(b);
    }
    let bvh = bvh.ok_or_else(|| Error::Usage("no runs".into()))?;
    let gpu_scene = GpuScene::upload(ctx, scene, &bvh, scene.settings.light_samples)?;
    progress("generating rays");
    let tracer = CpuTracer::new(scene);
    let rays = make_rays(scene, &tracer);
    let pass = TraceRaysPass::new(ctx)?;
    let mut rows = Vec::new();
    let mut incoherent_hits = Vec::new();
    for (name, list, any_hit) in [
        ("primary (GPU)", &rays.primary, false),
        ("shadow (GPU, any hit)", &rays.shadow, true),
        ("incoherent (GPU)", &rays.incoherent, false),
    ] {
        if list.is_empty() {
            continue;
        }
        progress(name);
        let batch = pass.upload(ctx, list, any_hit)?;
        // Warm-up: lavapipe compiles the shader on first dispatch.
        let hits: Vec<GpuHit> = pass.trace(ctx, &gpu_scene, &batch)?;
        let mut ms: Vec<f64> = (0..runs)
            .map(|_| time_gpu(ctx, &pass, &gpu_scene, &batch))
            .collect::<Result<_>>()?;
        let m = median(&mut ms);
        rows.push(BenchRow {
            name: name.into(),
            rays: list.len(),
            median_ms: m,
            mrays_per_s: list.len() as f64 / m / 1e3,
        });
        if name.starts_with("incoherent") {
            incoherent_hits = hits;
        }
    }
    progress("incoherent (CPU)");
    let mut cpu_ms = Vec::new();
    let mut cpu_hits = Vec::new();
    for _ in 0..runs {
        let t0 = Instant::now();
        cpu_hits = rays
            .incoherent
            .iter()
            .map(|r| tracer.closest_hit(r.origin.into(), r.dir.into(), r.tmin, r.tmax))
            .collect::<Vec<_>>();
        cpu_ms.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    let cpu_m = median(&mut cpu_ms);
    rows.push(BenchRow {
        name: "incoherent (CPU obvhs, 1 thread)".into(),
        rays: rays.incoherent.len(),
        median_ms: cpu_m,
        mrays_per_s: rays.incoherent.len() as f64 / cpu_m / 1e3,
    });
    let mismatches = incoherent_hits
        .iter()
        .zip(&cpu_hits)
        .filter(|(g, c)| match c {
            None => g.instance != u32::MAX,
            Some(c) => {
                g.instance != c.instance
                    || bvh.shading[g.triangle as usize].mesh_triangle != c.triangle
            }
        })
        .count();
    let gpu_inc = rows
        .iter()
        .find(|r| r.name == "incoherent (GPU)")
        .map(|r| r.mrays_per_s);
    let cpu_inc = rows.last().map(|r| r.mrays_per_s);
    Ok(BenchReport {
        scene: scene.source.display().to_string(),
        adapter: ctx
            .adapter_info
            .as_ref()
            .map(|a| a.name.clone())
            .unwrap_or_default(),
        width: scene.camera.width,
        height: scene.camera.height,
        triangles: bvh.triangles.len(),
        runs,
        bvh_preset: preset,
        bvh_build_ms: median(&mut build),
        rows,
        gpu_over_cpu_incoherent: match (gpu_inc, cpu_inc) {
            (Some(g), Some(c)) => g / c,
            _ => f64::NAN,
        },
        incoherent_mismatches: mismatches,
    })
}

/// Formats a report as a table.
pub fn format_table(r: &BenchReport) -> String {
    let mut s = format!(
        "scene {} ({} triangles), {}x{}, adapter {}, medians of {} runs\n",
        r.scene, r.triangles, r.width, r.height, r.adapter, r.runs
    );
    s += &format!(
        "{:<36} {:>10} {:>12} {:>10}\n",
        "kernel", "rays", "median ms", "Mrays/s"
    );
    s += &format!(
        "{:<36} {:>10} {:>12.2} {:>10}\n",
        format!("BVH build ({:?}, CPU)", r.bvh_preset),
        "-",
        r.bvh_build_ms,
        "-"
    );
    for row in &r.rows {
        s += &format!(
            "{:<36} {:>10} {:>12.2} {:>10.3}\n",
            row.name, row.rays, row.median_ms, row.mrays_per_s
        );
    }
    s += &format!(
        "GPU / CPU incoherent ratio: {:.3}   (hit mismatches GPU vs CPU: {} of {})\n",
        r.gpu_over_cpu_incoherent,
        r.incoherent_mismatches,
        r.rows
            .iter()
            .find(|x| x.name == "incoherent (GPU)")
            .map(|x| x.rays)
            .unwrap_or(0)
    );
    s
}

/// `radsplat bench`.
pub fn run_cli(
    scene_path: &Path,
    runs: usize,
    size: Option<(u32, u32)>,
    preset: BvhPreset,
    json: Option<&Path>,
    quiet: bool,
) -> Result<()> {
    let mut scene = load_scene(scene_path)?;
    // Traced as `render` traces it.
    scene.merge_static_instances();
    if let Some((w, h)) = size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    let mut outputs = crate::output::OutputSet::new();
    outputs.plan_opt(json)?;
    let ctx = GpuContext::new()?;
    // The table is GPU time: timestamps where the device has them.
    ctx.set_pass_timing(true);
    let bar = if quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new_spinner()
    };
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    let report = run(&ctx, &scene, runs, preset, |m| {
        bar.set_message(m.to_string())
    })?;
    bar.finish_and_clear();
    print!("{}", format_table(&report));
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| Error::Output {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        outputs.stage(path, text.as_bytes())?;
    }
    outputs.commit()
}
