//! The `radsplat` command line.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use radsplat::gpu::GpuContext;
use radsplat::output::{ImageFormat, OutputSet};
use radsplat::records::CacheSettings;
use radsplat::scene::load_scene;
use radsplat::temporal::{
    RecordAnchor, RefreshMode, Replacement, TemporalGradients, TemporalSettings,
};
use radsplat::{Error, Renderer, Result};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "radsplat",
    version,
    about = "Compute-shader global illumination renderer"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a linear EXR (with AOVs) and optionally a tone-mapped PNG.
    Render {
        /// Scene file (TOML, see docs/scene-format.md).
        scene: PathBuf,
        /// Output image: `.exr` (linear, with AOVs) or `.png` (tone-mapped); default
        /// <scene name>.exr in the current directory.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Also write a tone-mapped sRGB PNG here.
        #[arg(long)]
        png: Option<PathBuf>,
        /// Override the scene's resolution, e.g. 640x480.
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// Override the scene's light samples per pixel (area lights, environment).
        #[arg(long)]
        light_samples: Option<u32>,
        /// Write frame statistics as JSON here.
        #[arg(long)]
        stats: Option<PathBuf>,
        /// Direct light only (no irradiance cache).
        #[arg(long)]
        direct_only: bool,
        #[command(flatten)]
        cache: CacheArgs,
        /// Also write the record map (record sites over the image) as a PNG here.
        #[arg(long)]
        record_map: Option<PathBuf>,
        /// No progress bar or summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Thesis Table 4.1: RMS error of plane irradiance against full-hemisphere Monte Carlo
    /// at random visible points, per field of view and border compensation (CPU).
    PlaneError {
        scene: PathBuf,
        /// Random visible points.
        #[arg(long, default_value_t = 1000)]
        points: usize,
        /// Monte Carlo samples per point.
        #[arg(long, default_value_t = 16384)]
        mc_samples: u32,
        /// Fields of view in degrees, comma-separated.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "90,110,120,130,140,150,160"
        )]
        fovs: Vec<f32>,
        #[arg(long, default_value_t = 64)]
        plane_resolution: u32,
        /// Light samples per area light at each hit (planes and Monte Carlo alike).
        #[arg(long, default_value_t = 1)]
        light_samples: u32,
        /// Write the table as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        #[arg(short, long)]
        quiet: bool,
    },
    /// Print the adapter, driver, limits and features radsplat would use.
    Info,
    /// Benchmark BVH build and ray kernels on a scene; prints a table of medians.
    Bench {
        scene: PathBuf,
        /// Timed runs per kernel (after one warm-up).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Override the scene's resolution, e.g. 512x512.
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// obvhs preset for the mesh BVHs.
        #[arg(long, value_enum, default_value_t = radsplat::bvh::BvhPreset::Medium)]
        bvh_preset: radsplat::bvh::BvhPreset,
        /// Write the results as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        #[arg(short, long)]
        quiet: bool,
    },
    /// Render an animation (scene file `[animation]`, keyframes): one image per frame,
    /// with temporal radiance caching (records reused across frames) by default.
    Animate {
        /// Scene file (TOML, see docs/scene-format.md).
        scene: PathBuf,
        /// Frames to render, `A..B` (inclusive) or `A`; default: the scene's range.
        #[arg(long, value_parser = parse_frames)]
        frames: Option<std::ops::RangeInclusive<u32>>,
        /// Output pattern: the last run of `#` becomes the zero-padded frame number;
        /// `.exr` or `.png`. Default: <scene name>_####.exr.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Override the scene's resolution, e.g. 128x128.
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// Override the scene's light samples per pixel (area lights, environment).
        #[arg(long)]
        light_samples: Option<u32>,
        /// `on`: temporal radiance caching; `off`: a fresh cache every frame (baseline).
        #[arg(long, default_value = "on", value_parser = ["on", "off"])]
        temporal: String,
        /// Temporal accuracy a_t: a record lives while |tau - 1| (t - t_k) <= a_t.
        /// Default: the scene's `[animation].temporal_accuracy`, else 0.05.
        #[arg(long)]
        temporal_accuracy: Option<f32>,
        /// dt_max: the longest a record lives, in frames (1 = recompute every frame).
        /// Default: the scene's `[animation].max_lifespan`, else 20.
        #[arg(long)]
        max_lifespan: Option<u32>,
        /// Temporal gradients: `interpolated` (two passes: every record moves towards its
        /// replacement; no jumps) or `extrapolated` (one pass, from the E(t+1) estimate).
        #[arg(long, default_value = "interpolated", value_parser = ["interpolated", "extrapolated"])]
        temporal_gradients: String,
        /// Where records stay while objects move: `world` (the thesis: at their world
        /// position) or `instance` (carried with the instance they lie on).
        #[arg(long, default_value = "world", value_parser = ["world", "instance"])]
        record_anchor: String,
        /// `on`: a replacement traces again only the plane samples that motion since its
        /// predecessor's birth may have changed (the same images with fewer rays); `off`:
        /// it traces its whole plane; `auto`: on while it saves at least a fifth of the
        /// plane rays (judged after 64 refreshed planes), then off for the sequence.
        #[arg(long, default_value = "auto", value_parser = ["auto", "on", "off"])]
        plane_refresh: String,
        /// Most MiB of retained planes for plane refresh; records beyond are traced.
        #[arg(long, default_value_t = TemporalSettings::default().plane_budget_bytes >> 20)]
        plane_budget_mib: u64,
        /// Which expired records are recomputed at the same place: `visible` (those that
        /// cover a pixel of the frame, where they would be now), `covering` (the seed: those
        /// that covered a pixel in their last frame) or `needed` (those that cover a pixel
        /// of the frame no kept record covers).
        #[arg(long, default_value = "visible", value_parser = ["visible", "covering", "needed"])]
        replace: String,
        /// The E(t+1) estimate reprojects every N-th plane sample each way (1: all). With
        /// interpolated gradients it only gives tau, so 2 costs a quarter as much.
        /// Default: 2 with interpolated gradients (1 if the plane resolution is odd or
        /// below 8), 1 with extrapolated.
        #[arg(long)]
        estimate_stride: Option<u32>,
        /// At most N new records placed per frame (replacements do not count): pixels
        /// left uncovered get records in later frames, spreading a walkthrough's new views
        /// over frames. Default: every uncovered pixel gets one. Needs temporal caching.
        #[arg(long, value_name = "N")]
        max_new_records: Option<u32>,
        #[command(flatten)]
        cache: CacheArgs,
        /// Also write a lifespan map per frame (PNG pattern with `#`): record sites from
        /// red (short-lived) to green (long-lived).
        #[arg(long)]
        lifespan_map: Option<PathBuf>,
        /// Write per-frame statistics as JSON here.
        #[arg(long)]
        stats: Option<PathBuf>,
        /// No progress bar or summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Thesis Table 5.1: error of the E(t+1) estimate of new records, with reprojection
    /// and without (E(t+1) = E(t)), against records recomputed at t+1.
    TemporalError {
        scene: PathBuf,
        /// Frame t (records are placed at t and estimated at t+1).
        #[arg(long, default_value_t = 0)]
        frame: u32,
        /// Number of records (sites at evenly strided visible pixels, or every n-th
        /// placed record with `--sites placed`).
        #[arg(long, default_value_t = 1000)]
        records: usize,
        /// Where the records lie: `even` (visible pixels evenly strided over the image,
        /// the thesis's table) or `placed` (where a frame rendered from scratch places its
        /// records: the lifespans then bound what temporal caching can save).
        #[arg(long, default_value = "even", value_parser = ["even", "placed"])]
        sites: String,
        /// Override the scene's resolution (sites are chosen among its pixels).
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        #[command(flatten)]
        cache: CacheArgs,
        /// Where records stay while objects move: `world` (the thesis's table) or
        /// `instance` (records move with their instance; recomputed from the moved site).
        #[arg(long, default_value = "world", value_parser = ["world", "instance"])]
        record_anchor: String,
        /// The estimate reprojects every N-th plane sample each way and scales E(t) by
        /// that subset's change (as `animate --estimate-stride`); 1: the whole plane.
        #[arg(long, default_value_t = 1)]
        estimate_stride: u32,
        /// Write the table as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Brute-force reference: direct light + first-bounce indirect light by Monte Carlo,
    /// `--spp` bounce directions per pixel. The EXR adds the AOV `indirect.*`.
    Reference {
        /// Scene file (TOML, see docs/scene-format.md).
        scene: PathBuf,
        /// Bounce directions per pixel (powers of two suit the Sobol points).
        #[arg(long)]
        spp: u32,
        /// Render this frame of an animated scene (default: its first frame).
        #[arg(long)]
        frame: Option<u32>,
        /// Output image: `.exr` (linear, with AOVs) or `.png` (tone-mapped); default
        /// <scene name>-reference.exr in the current directory.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Also write a tone-mapped sRGB PNG here.
        #[arg(long)]
        png: Option<PathBuf>,
        /// Override the scene's resolution, e.g. 128x128.
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// Override the scene's light samples (per light, at the pixel and at every bounce hit).
        #[arg(long)]
        light_samples: Option<u32>,
        /// Write timings as JSON here.
        #[arg(long)]
        stats: Option<PathBuf>,
        /// No progress bar or summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Compare image A against reference B (EXR or Radiance .hdr): RMSE and relative RMSE
    /// of the beauty, and of `indirect.*` when both EXRs have it.
    Compare {
        a: PathBuf,
        /// The reference.
        b: PathBuf,
        /// Write a false-colour PNG of |Y(A) - Y(B)| / mean Y(B) here (viridis, legend below).
        /// (`surfaces` in the output: beauty over pixels where B's albedo.* is non-zero.)
        #[arg(long)]
        diff: Option<PathBuf>,
        /// The relative difference shown as full yellow in `--diff`.
        #[arg(long, default_value_t = 0.25)]
        diff_scale: f32,
        /// Box-filter both images by N x N pixels before comparing (averages out the
        /// per-pixel noise of a Monte Carlo reference).
        #[arg(long, default_value_t = 1)]
        downsample: u32,
        /// Compare A minus this image (e.g. rpict -ab 1 minus -ab 0: its indirect light);
        /// the difference is also compared with B's `indirect.*`.
        #[arg(long)]
        minus: Option<PathBuf>,
        /// Write the numbers as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Compare an image sequence against a reference sequence frame by frame: RMSE and
    /// relative RMSE per frame, and flicker, the mean over pixels of
    /// | |Y_A(f) - Y_A(f-1)| - |Y_ref(f) - Y_ref(f-1)| |. Patterns replace their last run of
    /// '#' by the zero-padded frame number: frame_####.exr, 12 -> frame_0012.exr.
    CompareSeq {
        /// The sequence to measure, e.g. out/frame_####.exr.
        a_pattern: PathBuf,
        /// The reference sequence.
        ref_pattern: PathBuf,
        /// Frames to compare: A..B (inclusive) or a single frame A.
        #[arg(long, value_name = "A..B", value_parser = parse_frames)]
        frames: std::ops::RangeInclusive<u32>,
        /// Write a PNG chart of relative RMSE and relative flicker per frame here.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Write the per-frame numbers and the summary as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Write a PNG of where the sequence flickers: per pixel, the mean flicker term
        /// relative to the reference's mean luminance, black (0) to white (10 %).
        #[arg(long)]
        flicker_map: Option<PathBuf>,
        /// Box-filter all images by N x N pixels before comparing.
        #[arg(long, default_value_t = 1)]
        downsample: u32,
    },
    /// Export a scene to Radiance for rpict: OUT_DIR/scene.rad, OUT_DIR/view.vf,
    /// OUT_DIR/notex.toml (the scene without textures) and OUT_DIR/export.json.
    ExportRad {
        scene: PathBuf,
        out_dir: PathBuf,
        /// Override the scene's resolution, e.g. 128x128 (written to export.json).
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
    },
}

/// Irradiance cache settings (defaults: `radsplat::records::CacheSettings::default()`).
#[derive(clap::Args, Clone, Debug)]
struct CacheArgs {
    /// Accuracy a in (0, 1]: a record contributes where Ward's weight w >= 1/a. Smaller
    /// a places more, smaller records: less interpolation error, more time, and each
    /// record's own plane noise shows more. Lower a only together with a larger
    /// --plane-resolution: at 16x16 planes a = 0.1 gave more error than a = 0.2 (plane
    /// noise dominates); a = 0.1 wants 64x64 planes, a = 0.4-0.5 gets by with 24x24-32x32.
    #[arg(short, long, default_value_t = CacheSettings::default().accuracy, value_parser = parse_accuracy)]
    accuracy: f32,
    /// Hemisphere plane resolution P (P x P rays per record): the noise of each record's
    /// irradiance. Goes with -a: fewer plane rays need a larger a (fewer, wider records
    /// average the plane noise over more pixels), see -a.
    #[arg(long, default_value_t = CacheSettings::default().plane_resolution, value_parser = parse_plane_resolution)]
    plane_resolution: u32,
    /// Hemisphere plane field of view in degrees.
    #[arg(long, default_value_t = CacheSettings::default().plane_fov_degrees, value_parser = parse_plane_fov)]
    plane_fov: f32,
    /// Light samples per area light at each plane hit.
    #[arg(long, default_value_t = CacheSettings::default().plane_light_samples, value_parser = parse_at_least_one)]
    plane_light_samples: u32,
    /// R_min as the validity radius a R_min in pixels at creation.
    #[arg(long, default_value_t = CacheSettings::default().r_min_pixels, value_parser = parse_positive)]
    r_min_pixels: f32,
    /// R_max / R_min.
    #[arg(long, default_value_t = CacheSettings::default().r_max_factor, value_parser = parse_r_max_factor)]
    r_max_factor: f32,
    /// Most records the cache may hold.
    #[arg(long, default_value_t = CacheSettings::default().record_budget, value_parser = parse_record_budget)]
    record_budget: u32,
    /// Do not compute or use irradiance gradients.
    #[arg(long)]
    no_gradients: bool,
}

// Value parsers of `CacheArgs`: clap reports their errors as "invalid value 'V' for
// '--flag <FLAG>': <rule>", naming the flag and the value, before anything is loaded. The
// ranges are those of `CacheSettings::validate`, which checks them again for library users.

/// A number from the command line, with the parse error in words.
fn parse_number<T: std::str::FromStr>(s: &str) -> std::result::Result<T, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))
}

fn parse_accuracy(s: &str) -> std::result::Result<f32, String> {
    let a: f32 = parse_number(s)?;
    if a > 0.0 && a <= 1.0 {
        Ok(a)
    } else {
        Err("the accuracy must be in (0, 1]".into())
    }
}

fn parse_plane_resolution(s: &str) -> std::result::Result<u32, String> {
    let p: u32 = parse_number(s)?;
    if (2..=512).contains(&p) {
        Ok(p)
    } else {
        Err("the plane resolution must be in 2..=512".into())
    }
}

fn parse_plane_fov(s: &str) -> std::result::Result<f32, String> {
    let fov: f32 = parse_number(s)?;
    if fov > 1.0 && fov < 179.0 {
        Ok(fov)
    } else {
        Err("the plane field of view must be in (1, 179) degrees".into())
    }
}

fn parse_at_least_one(s: &str) -> std::result::Result<u32, String> {
    let n: u32 = parse_number(s)?;
    if n >= 1 {
        Ok(n)
    } else {
        Err("must be at least 1".into())
    }
}

fn parse_positive(s: &str) -> std::result::Result<f32, String> {
    let x: f32 = parse_number(s)?;
    if x > 0.0 && x.is_finite() {
        Ok(x)
    } else {
        Err("must be a positive number".into())
    }
}

fn parse_r_max_factor(s: &str) -> std::result::Result<f32, String> {
    let x: f32 = parse_number(s)?;
    if x >= 1.0 && x.is_finite() {
        Ok(x)
    } else {
        Err("must be a number >= 1 (R_max / R_min)".into())
    }
}

fn parse_record_budget(s: &str) -> std::result::Result<u32, String> {
    let n: u32 = parse_number(s)?;
    if n >= 1 {
        Ok(n)
    } else {
        Err(
            "must be at least 1: no records means no indirect light (for direct light \
             only, use `render --direct-only`)"
                .into(),
        )
    }
}

impl CacheArgs {
    fn settings(&self) -> CacheSettings {
        CacheSettings {
            accuracy: self.accuracy,
            plane_resolution: self.plane_resolution,
            plane_fov_degrees: self.plane_fov,
            plane_light_samples: self.plane_light_samples,
            r_min_pixels: self.r_min_pixels,
            r_max_factor: self.r_max_factor,
            record_budget: self.record_budget,
            gradients: !self.no_gradients,
            ..CacheSettings::default()
        }
    }
}

/// Loads a scene with the command line's overrides: an animation frame, the resolution
/// and the light samples (at least 1).
fn load_scene_with(
    path: &Path,
    frame: Option<u32>,
    size: Option<(u32, u32)>,
    light_samples: Option<u32>,
) -> Result<radsplat::scene::Scene> {
    let mut scene = load_scene(path)?;
    if let Some(f) = frame {
        scene.try_set_frame(f as f32)?;
    }
    if let Some((w, h)) = size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    if let Some(n) = light_samples {
        if n == 0 {
            return Err(Error::Usage("--light-samples must be at least 1".into()));
        }
        scene.settings.light_samples = n;
    }
    Ok(scene)
}

fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("'{v}' in '{s}' is not a positive integer"))
    };
    Ok((parse(w)?, parse(h)?))
}

fn main() -> ExitCode {
    // SAFETY: first thing in main, before any thread is started.
    unsafe { radsplat::gpu::context::quiet_device_select_layer() };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render {
            scene,
            output,
            png,
            size,
            light_samples,
            stats,
            direct_only,
            cache,
            record_map,
            quiet,
        } => render(RenderArgs {
            scene_path: &scene,
            output,
            png,
            size,
            light_samples,
            stats,
            cache: (!direct_only).then(|| cache.settings()),
            record_map,
            quiet,
        }),
        Command::Animate {
            scene,
            frames,
            output,
            size,
            light_samples,
            temporal,
            temporal_accuracy,
            max_lifespan,
            temporal_gradients,
            record_anchor,
            plane_refresh,
            plane_budget_mib,
            replace,
            estimate_stride,
            max_new_records,
            cache,
            lifespan_map,
            stats,
            quiet,
        } => animate(AnimateArgs {
            scene_path: &scene,
            frames,
            output,
            size,
            light_samples,
            cache: cache.settings(),
            temporal_accuracy,
            max_lifespan,
            max_new_records,
            temporal: (temporal == "on").then_some(TemporalSettings {
                gradients: if temporal_gradients == "extrapolated" {
                    TemporalGradients::Extrapolated
                } else {
                    TemporalGradients::Interpolated
                },
                anchor: if record_anchor == "instance" {
                    RecordAnchor::Instance
                } else {
                    RecordAnchor::World
                },
                plane_refresh: match plane_refresh.as_str() {
                    "on" => RefreshMode::On,
                    "off" => RefreshMode::Off,
                    _ => RefreshMode::Auto,
                },
                plane_budget_bytes: plane_budget_mib.saturating_mul(1 << 20),
                replacement: match replace.as_str() {
                    "needed" => Replacement::Needed,
                    "covering" => Replacement::Covering,
                    _ => Replacement::Visible,
                },
                estimate_stride,
                ..TemporalSettings::default()
            }),
            lifespan_map,
            stats,
            quiet,
        }),
        Command::TemporalError {
            scene,
            frame,
            records,
            sites,
            size,
            cache,
            record_anchor,
            estimate_stride,
            json,
        } => temporal_error(
            &scene,
            frame,
            (records, &sites),
            size,
            &cache.settings(),
            (&record_anchor, estimate_stride),
            json.as_deref(),
        ),
        Command::Info => info(),
        Command::PlaneError {
            scene,
            points,
            mc_samples,
            fovs,
            plane_resolution,
            light_samples,
            json,
            quiet,
        } => plane_error(
            &scene,
            points,
            mc_samples,
            &fovs,
            plane_resolution,
            light_samples,
            json,
            quiet,
        ),
        Command::Bench {
            scene,
            runs,
            size,
            bvh_preset,
            json,
            quiet,
        } => radsplat::bench::run_cli(&scene, runs, size, bvh_preset, json.as_deref(), quiet),
        Command::Reference {
            scene,
            spp,
            frame,
            output,
            png,
            size,
            light_samples,
            stats,
            quiet,
        } => reference(
            &scene,
            spp,
            frame,
            output,
            png,
            size,
            light_samples,
            stats,
            quiet,
        ),
        Command::Compare {
            a,
            b,
            diff,
            diff_scale,
            downsample,
            minus,
            json,
        } => compare(
            &a,
            &b,
            minus.as_deref(),
            diff.as_deref(),
            diff_scale,
            downsample,
            json.as_deref(),
        ),
        Command::CompareSeq {
            a_pattern,
            ref_pattern,
            frames,
            plot,
            json,
            flicker_map,
            downsample,
        } => compare_seq(
            &a_pattern,
            &ref_pattern,
            frames,
            plot,
            json,
            flicker_map,
            downsample,
        ),
        Command::ExportRad {
            scene,
            out_dir,
            size,
        } => export_rad(&scene, &out_dir, size),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn progress(quiet: bool, steps: u64) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(steps);
    if let Ok(style) = ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} (ETA {eta}) {msg}",
    ) {
        bar.set_style(style);
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

struct RenderArgs<'a> {
    scene_path: &'a Path,
    output: Option<PathBuf>,
    png: Option<PathBuf>,
    size: Option<(u32, u32)>,
    light_samples: Option<u32>,
    stats: Option<PathBuf>,
    /// None: direct light only.
    cache: Option<CacheSettings>,
    record_map: Option<PathBuf>,
    quiet: bool,
}

fn render(args: RenderArgs) -> Result<()> {
    let RenderArgs {
        scene_path,
        output,
        png,
        size,
        light_samples,
        stats,
        cache,
        record_map,
        quiet,
    } = args;
    if let Some(c) = &cache {
        c.validate()?;
    }
    if record_map.is_some() && cache.is_none() {
        return Err(Error::Usage(
            "--record-map needs GI (drop --direct-only)".into(),
        ));
    }
    let bar = progress(quiet, 5);
    bar.set_message("loading scene");
    let scene = load_scene_with(scene_path, None, size, light_samples)?;
    let output = output.unwrap_or_else(|| {
        let stem = scene_path.file_stem().unwrap_or_default().to_string_lossy();
        PathBuf::from(format!("{stem}.exr"))
    });
    let format = ImageFormat::from_path(&output)?;
    // Every output is checked now and replaced only once all of them are written.
    let mut outputs = OutputSet::new();
    outputs.plan(&output)?;
    outputs.plan_opt(png.as_deref())?;
    outputs.plan_opt(record_map.as_deref())?;
    outputs.plan_opt(stats.as_deref())?;
    bar.inc(1);
    bar.set_message("starting GPU");
    let renderer = Renderer::new(GpuContext::new()?)?;
    radsplat::visibility::check_resolution(&renderer.ctx, scene.camera.width, scene.camera.height)?;
    bar.inc(1);
    bar.set_message("building BVH");
    let prepared = renderer.prepare(&scene)?;
    bar.inc(1);
    bar.set_message("rendering");
    let mut records = Vec::new();
    let frame = match &cache {
        None => renderer.render_frame(&prepared, &scene.camera)?,
        Some(settings) => {
            let mut cache = renderer.new_cache(settings)?;
            let frame =
                renderer.render_gi_frame(&prepared, &scene.camera, &mut cache, None, |n| {
                    bar.set_message(format!("rendering: {n} records"));
                })?;
            if record_map.is_some() {
                records = cache.read(&renderer.ctx)?;
            }
            frame
        }
    };
    bar.inc(1);
    bar.set_message("writing");
    let exposure = scene.settings.exposure;
    outputs.stage(&output, &format.encode_frame(&output, &frame, exposure)?)?;
    if let Some(path) = &record_map {
        let camera = radsplat::visibility::GpuCamera::new(&scene.camera);
        let rgb = radsplat::output::record_map(&frame, &camera, &records, exposure);
        outputs.stage(path, &encode_png(path, frame.width, frame.height, &rgb)?)?;
    }
    if let Some(png) = &png {
        outputs.stage(png, &ImageFormat::Png.encode_frame(png, &frame, exposure)?)?;
    }
    if let Some(stats_path) = &stats {
        let json = serde_json_string(&prepared.bvh_stats, &frame.stats);
        outputs.stage(stats_path, json.as_bytes())?;
    }
    outputs.commit()?;
    bar.inc(1);
    bar.finish_and_clear();
    if !quiet {
        let passes: Vec<String> = frame
            .stats
            .pass_ms
            .iter()
            .map(|(n, ms)| format!("{n} {ms:.1} ms"))
            .collect();
        if let Some(c) = &frame.stats.cache {
            eprintln!(
                "records: {} ({} new in {} rounds{}), {} plane rays, {} visible pixels uncovered, wall {:.0} ms",
                c.records,
                c.placement.new_records,
                c.placement.rounds,
                if c.placement.limit_reached {
                    ", LIMIT REACHED"
                } else {
                    ""
                },
                c.plane_rays,
                c.uncovered_pixels,
                frame.stats.wall_ms
            );
        }
        let compile: f64 = frame.stats.shader_compile_ms.iter().map(|(_, ms)| ms).sum();
        eprintln!(
            "{}x{}, {} triangles, BVH {:.1} ms, shader compilation {:.0} ms ({} pipelines), \
             GPU: {}; wrote {}{}",
            frame.width,
            frame.height,
            prepared.bvh_stats.triangles,
            prepared.bvh_stats.build_ms,
            compile,
            frame.stats.shader_compile_ms.len(),
            if passes.is_empty() {
                "no timestamps".to_string()
            } else {
                passes.join(", ")
            },
            output.display(),
            png.map(|p| format!(" and {}", p.display()))
                .unwrap_or_default()
        );
    }
    Ok(())
}

/// 8-bit RGB as PNG bytes, errors naming `path`.
fn encode_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    radsplat::output::png_out::encode_png_rgb8(width, height, rgb).map_err(|message| {
        Error::Output {
            path: path.to_path_buf(),
            message,
        }
    })
}

fn serde_json_string(bvh: &radsplat::frame::BvhStats, frame: &radsplat::FrameStats) -> String {
    #[derive(serde::Serialize)]
    struct Stats<'a> {
        bvh: &'a radsplat::frame::BvhStats,
        frame: &'a radsplat::FrameStats,
    }
    serde_json::to_string_pretty(&Stats { bvh, frame }).unwrap_or_default()
}

#[allow(clippy::too_many_arguments)]
fn plane_error(
    scene_path: &Path,
    points: usize,
    mc_samples: u32,
    fovs: &[f32],
    plane_resolution: u32,
    light_samples: u32,
    json: Option<PathBuf>,
    quiet: bool,
) -> Result<()> {
    let scene = load_scene(scene_path)?;
    let settings = CacheSettings {
        plane_resolution,
        plane_light_samples: light_samples,
        ..CacheSettings::default()
    };
    for &fov in fovs {
        CacheSettings {
            plane_fov_degrees: fov,
            ..settings.clone()
        }
        .validate()?;
    }
    if points == 0 || mc_samples == 0 {
        return Err(Error::Usage(
            "--points and --mc-samples must be positive".into(),
        ));
    }
    let mut outputs = OutputSet::new();
    outputs.plan_opt(json.as_deref())?;
    let bar = progress(quiet, points as u64);
    let table = radsplat::records::plane_error::plane_error_table(
        &scene,
        &settings,
        points,
        mc_samples,
        fovs,
        |done| bar.set_position(done as u64),
    );
    bar.finish_and_clear();
    print!("{}", radsplat::records::plane_error::format_table(&table));
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&table).map_err(|e| Error::Output {
            path: path.clone(),
            message: e.to_string(),
        })?;
        outputs.stage(&path, text.as_bytes())?;
    }
    outputs.commit()
}

fn info() -> Result<()> {
    let ctx = GpuContext::new()?;
    if let Some(a) = &ctx.adapter_info {
        println!("adapter:      {}", a.name);
        println!("backend:      {:?}", a.backend);
        println!("device type:  {:?}", a.device_type);
        println!("driver:       {} ({})", a.driver, a.driver_info);
    }
    let l = ctx.device.limits();
    println!("limits:");
    println!(
        "  max_storage_buffer_binding_size   {} MiB",
        l.max_storage_buffer_binding_size >> 20
    );
    println!(
        "  max_buffer_size                   {} MiB",
        l.max_buffer_size >> 20
    );
    println!(
        "  max_storage_buffers_per_stage     {}",
        l.max_storage_buffers_per_shader_stage
    );
    println!(
        "  max_compute_workgroups_per_dim    {}",
        l.max_compute_workgroups_per_dimension
    );
    println!(
        "  max_compute_invocations_per_wg    {}",
        l.max_compute_invocations_per_workgroup
    );
    println!(
        "  max_compute_workgroup_storage     {} KiB",
        l.max_compute_workgroup_storage_size >> 10
    );
    let side =
        ((ctx.max_binding_size() / radsplat::visibility::VIS_SAMPLE_BYTES) as f64).sqrt() as u64;
    println!("  largest square image              {side}x{side}");
    println!("features used:");
    println!(
        "  TIMESTAMP_QUERY (per-pass GPU times): {}",
        ctx.has_timestamps()
    );
    println!(
        "required by radsplat: {:?}",
        radsplat::gpu::required_limits().max_storage_buffers_per_shader_stage
    );
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn reference(
    scene_path: &Path,
    spp: u32,
    frame: Option<u32>,
    output: Option<PathBuf>,
    png: Option<PathBuf>,
    size: Option<(u32, u32)>,
    light_samples: Option<u32>,
    stats: Option<PathBuf>,
    quiet: bool,
) -> Result<()> {
    use radsplat::reference::{ReferenceOptions, ReferencePass};
    if spp == 0 {
        return Err(Error::Usage("--spp must be at least 1".into()));
    }
    let scene = load_scene_with(scene_path, frame, size, light_samples)?;
    let output = output.unwrap_or_else(|| {
        let stem = scene_path.file_stem().unwrap_or_default().to_string_lossy();
        PathBuf::from(format!("{stem}-reference.exr"))
    });
    let format = ImageFormat::from_path(&output)?;
    let mut outputs = OutputSet::new();
    outputs.plan(&output)?;
    outputs.plan_opt(png.as_deref())?;
    outputs.plan_opt(stats.as_deref())?;
    let t0 = std::time::Instant::now();
    let renderer = Renderer::new(GpuContext::new()?)?;
    radsplat::visibility::check_resolution(&renderer.ctx, scene.camera.width, scene.camera.height)?;
    let pass = ReferencePass::new(&renderer.ctx)?;
    let prepared = renderer.prepare(&scene)?;
    let options = ReferenceOptions::new(spp);
    let bar = progress(quiet, 1);
    bar.set_message(format!("reference, {spp} spp"));
    let result = pass.render(
        &renderer,
        &prepared,
        &scene.camera,
        &options,
        &mut |done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        },
    )?;
    bar.finish_and_clear();
    let exposure = scene.settings.exposure;
    radsplat::output::check_finite(&output, &result.frame)?;
    let bytes = match format {
        ImageFormat::Exr => result.encode_exr()?,
        ImageFormat::Png => format.encode_frame(&output, &result.frame, exposure)?,
    };
    outputs.stage(&output, &bytes)?;
    if let Some(png) = &png {
        outputs.stage(
            png,
            &ImageFormat::Png.encode_frame(png, &result.frame, exposure)?,
        )?;
    }
    let wall_ms = t0.elapsed().as_secs_f64() * 1e3;
    if let Some(stats_path) = &stats {
        #[derive(serde::Serialize)]
        struct Stats<'a> {
            bvh: &'a radsplat::frame::BvhStats,
            frame: &'a radsplat::FrameStats,
            reference: &'a radsplat::reference::ReferenceStats,
            wall_ms: f64,
        }
        let json = serde_json::to_string_pretty(&Stats {
            bvh: &prepared.bvh_stats,
            frame: &result.frame.stats,
            reference: &result.stats,
            wall_ms,
        })
        .unwrap_or_default();
        outputs.stage(stats_path, json.as_bytes())?;
    }
    outputs.commit()?;
    if !quiet {
        // Compilation of the passes (the frame's, and the reference pass's own).
        let compile: f64 = result
            .frame
            .stats
            .shader_compile_ms
            .iter()
            .map(|(_, ms)| *ms)
            .chain(renderer.ctx.take_compile_times().iter().map(|(_, ms)| *ms))
            .sum();
        eprintln!(
            "{}x{}, {spp} spp, {} light samples: shader compilation {compile:.0} ms, direct \
             {:.0} ms, indirect {:.0} ms in {} dispatches ({} bounce rays); wrote {}{}",
            result.frame.width,
            result.frame.height,
            scene.settings.light_samples,
            result.stats.direct_ms,
            result.stats.indirect_ms,
            result.stats.dispatches,
            result.stats.bounce_rays,
            output.display(),
            png.map(|p| format!(" and {}", p.display()))
                .unwrap_or_default()
        );
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn compare(
    a: &Path,
    b: &Path,
    minus: Option<&Path>,
    diff: Option<&Path>,
    scale: f32,
    downsample: u32,
    json: Option<&Path>,
) -> Result<()> {
    use radsplat::compare::{compare, diff_image, load_image};
    if !(scale.is_finite() && scale > 0.0) {
        return Err(Error::Usage(
            "--diff-scale must be a positive number".into(),
        ));
    }
    let mut outputs = OutputSet::new();
    outputs.plan_opt(diff)?;
    outputs.plan_opt(json)?;
    let mut ia = load_image(a)?;
    if let Some(c) = minus {
        ia = ia.minus(&load_image(c)?)?;
    }
    let mut ib = load_image(b)?;
    if downsample != 1 {
        ia = ia.downsample(downsample)?;
        ib = ib.downsample(downsample)?;
    }
    let c = compare(&ia, &ib)?;
    println!(
        "{} vs reference {} ({}x{}{})",
        a.display(),
        b.display(),
        c.width,
        c.height,
        if downsample != 1 {
            format!(", box-filtered {downsample}x{downsample}")
        } else {
            String::new()
        }
    );
    let line = |name: &str, s: &radsplat::compare::ErrorStats| {
        println!(
            "{name:<9} RMSE {:.6e}  RMS(ref) {:.6e}  relative RMSE {:.4} ({:.2} %)",
            s.rmse,
            s.rms_reference,
            s.relative_rmse,
            100.0 * s.relative_rmse
        );
    };
    line("beauty", &c.beauty);
    if let Some(s) = &c.surfaces {
        line("surfaces", s);
    }
    match &c.indirect {
        Some(s) => line("indirect", s),
        None => println!("indirect  (not in both files)"),
    }
    if let Some(path) = diff {
        let rgb = diff_image(&ia, &ib, scale);
        // The diff image has a legend strip below the picture.
        let rows = (rgb.len() / 3) as u32 / ia.width.max(1);
        outputs.stage(path, &encode_png(path, ia.width, rows, &rgb)?)?;
        println!(
            "wrote {}: |Y(A)-Y(B)| / mean Y(B), viridis from 0 to {scale} (legend strip below)",
            path.display()
        );
    }
    if let Some(path) = json {
        #[derive(serde::Serialize)]
        struct Out<'a> {
            #[serde(flatten)]
            comparison: &'a radsplat::compare::Comparison,
            diff_scale: f32,
        }
        let text = serde_json::to_string_pretty(&Out {
            comparison: &c,
            diff_scale: scale,
        })
        .map_err(|e| Error::Output {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        outputs.stage(path, text.as_bytes())?;
    }
    outputs.commit()
}

fn parse_frames(s: &str) -> std::result::Result<std::ops::RangeInclusive<u32>, String> {
    radsplat::output::parse_frame_range(s).map_err(|e| e.to_string())
}

fn compare_seq(
    a_pattern: &Path,
    ref_pattern: &Path,
    frames: std::ops::RangeInclusive<u32>,
    plot: Option<PathBuf>,
    json: Option<PathBuf>,
    flicker_map: Option<PathBuf>,
    downsample: u32,
) -> Result<()> {
    let mut outputs = OutputSet::new();
    outputs.plan_opt(plot.as_deref())?;
    outputs.plan_opt(json.as_deref())?;
    outputs.plan_opt(flicker_map.as_deref())?;
    let c = radsplat::compare_seq::compare_sequence(a_pattern, ref_pattern, frames, downsample)?;
    if let Some(path) = &flicker_map {
        outputs.stage_with(path, |tmp| c.write_flicker_map(tmp))?;
    }
    print!("{}", c.table());
    println!("{}", c.summary_line());
    if let Some(path) = &plot {
        outputs.stage_with(path, |tmp| c.write_plot(tmp))?;
    }
    if let Some(path) = &json {
        outputs.stage_with(path, |tmp| c.write_json(tmp))?;
    }
    outputs.commit()?;
    for path in [&flicker_map, &plot].into_iter().flatten() {
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn export_rad(scene_path: &Path, out_dir: &Path, size: Option<(u32, u32)>) -> Result<()> {
    use radsplat::radiance_export::{notex_scene_toml, scene_rad, view_options};
    let scene = load_scene_with(scene_path, None, size, None)?;
    std::fs::create_dir_all(out_dir).map_err(|e| Error::Output {
        path: out_dir.to_path_buf(),
        message: e.to_string(),
    })?;
    let (rad, vf, notex, json) = (
        out_dir.join("scene.rad"),
        out_dir.join("view.vf"),
        out_dir.join("notex.toml"),
        out_dir.join("export.json"),
    );
    let mut outputs = OutputSet::new();
    for path in [&rad, &vf, &notex, &json] {
        outputs.plan(path)?;
    }
    let view = view_options(&scene);
    outputs.stage(&rad, scene_rad(&scene).as_bytes())?;
    outputs.stage(&vf, format!("rview {view}\n").as_bytes())?;
    outputs.stage(&notex, notex_scene_toml(scene_path, &scene)?.as_bytes())?;
    let info = serde_json::json!({
        "scene": scene_path,
        "width": scene.camera.width,
        "height": scene.camera.height,
        "view": view,
        "triangles": scene.triangle_count(),
        "textured_materials": scene.materials.iter().filter(|m| m.albedo_texture.is_some()).count(),
        "has_environment": scene.environment.max_element() > 0.0,
        "exposure": scene.settings.exposure,
    });
    outputs.stage(
        &json,
        serde_json::to_string_pretty(&info)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    outputs.commit()?;
    println!(
        "wrote {}/{{scene.rad, view.vf, notex.toml, export.json}}",
        out_dir.display()
    );
    Ok(())
}

struct AnimateArgs<'a> {
    scene_path: &'a Path,
    frames: Option<std::ops::RangeInclusive<u32>>,
    output: Option<PathBuf>,
    size: Option<(u32, u32)>,
    light_samples: Option<u32>,
    cache: CacheSettings,
    /// a_t and dt_max given on the command line (else the scene's, else the defaults).
    temporal_accuracy: Option<f32>,
    max_lifespan: Option<u32>,
    /// `--max-new-records` (checked here, so the error names the flag).
    max_new_records: Option<u32>,
    /// None: the per-frame baseline.
    temporal: Option<TemporalSettings>,
    lifespan_map: Option<PathBuf>,
    stats: Option<PathBuf>,
    quiet: bool,
}

fn animate(mut args: AnimateArgs) -> Result<()> {
    use radsplat::output::{frame_path, lifespan_map};
    use radsplat::temporal::animation::{AnimationOptions, AnimationStep, render_animation};
    args.cache.validate()?;
    match (args.max_new_records, args.temporal.as_mut()) {
        (Some(0), _) => {
            return Err(Error::Usage(
                "--max-new-records 0: the cap on new records per frame must be at least 1".into(),
            ));
        }
        (Some(n), None) => {
            return Err(Error::Usage(format!(
                "--max-new-records {n} caps the records a frame adds to the temporal cache: \
                 drop --temporal off (a frame from scratch would stay partly uncovered)"
            )));
        }
        (n, Some(t)) => t.max_new_records = n,
        (None, None) => {}
    }
    let scene = load_scene_with(args.scene_path, None, args.size, args.light_samples)?;
    if let Some(t) = args.temporal.as_mut() {
        t.apply_scene(
            scene.animation.as_ref(),
            args.temporal_accuracy,
            args.max_lifespan,
        );
        // The stride chosen, so that --stats records it.
        t.estimate_stride = Some(t.estimate_stride_for(args.cache.plane_resolution));
        t.validate()?;
    }
    let frames = args.frames.clone().unwrap_or_else(|| scene.frames());
    // Every frame's state before any work (its cost follows the keyframe spans, not the
    // range): a keyframe pair that interpolates through a degenerate state is refused here.
    scene.check_frames(frames.clone())?;
    let output = args.output.unwrap_or_else(|| {
        let stem = args
            .scene_path
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy();
        PathBuf::from(format!("{stem}_####.exr"))
    });
    // Check every output name and directory before rendering anything.
    let format = ImageFormat::from_path(&frame_path(&output, *frames.start())?)?;
    radsplat::output::output_dir(&frame_path(&output, *frames.start())?)?;
    // The stats JSON is written at the end; its path is checked and reserved now.
    let mut stats_output = OutputSet::new();
    stats_output.plan_opt(args.stats.as_deref())?;
    if let Some(map) = &args.lifespan_map {
        if args.temporal.is_none() {
            return Err(Error::Usage(
                "--lifespan-map needs temporal caching (drop --temporal off)".into(),
            ));
        }
        if ImageFormat::from_path(&frame_path(map, *frames.start())?)? != ImageFormat::Png {
            return Err(Error::Usage(
                "--lifespan-map writes PNG: use a .png pattern".into(),
            ));
        }
        radsplat::output::output_dir(&frame_path(map, *frames.start())?)?;
    }
    let renderer = Renderer::new(GpuContext::new()?)?;
    radsplat::visibility::check_resolution(&renderer.ctx, scene.camera.width, scene.camera.height)?;
    let count = frames.end() - frames.start() + 1;
    let options = AnimationOptions {
        frames: frames.clone(),
        cache: args.cache.clone(),
        temporal: args.temporal.clone(),
    };
    // Interpolated gradients: pass 1 computes the records, pass 2 renders each frame up to
    // dt_max frames behind it; the bar counts the steps of both.
    let two_pass = args
        .temporal
        .as_ref()
        .is_some_and(|t| t.gradients == TemporalGradients::Interpolated);
    let passes = if two_pass { 2 } else { 1 };
    let bar = progress(args.quiet, u64::from(count) * passes);
    bar.set_message("rendering");
    // The last frame written (pass 2's position), for the messages of pass 1.
    let written = std::cell::Cell::new(None::<u32>);
    let pass_2 = || match written.get() {
        Some(t) => format!("; pass 2 (images) wrote frame {t}"),
        None => "; pass 2 (images) waits for the records' successors".to_string(),
    };
    let max_lifespan = args.temporal.as_ref().map_or(1, |t| t.max_lifespan);
    let exposure = scene.settings.exposure;
    // Per-frame statistics only for --stats (their JSON is written at the end; without
    // --stats nothing grows with the range).
    let mut per_frame = Vec::new();
    let summary = render_animation(
        &renderer,
        &scene,
        &options,
        |f| {
            // A frame's image and its lifespan map appear together or not at all.
            let path = frame_path(&output, f.frame_number)?;
            let mut frame_outputs = OutputSet::new();
            frame_outputs.plan(&path)?;
            let map_path = match &args.lifespan_map {
                Some(map) => Some(frame_path(map, f.frame_number)?),
                None => None,
            };
            frame_outputs.plan_opt(map_path.as_deref())?;
            frame_outputs.stage(&path, &format.encode_frame(&path, f.frame, exposure)?)?;
            if let Some(map_path) = &map_path {
                let camera = radsplat::visibility::GpuCamera::new(&f.scene.camera);
                let rgb = lifespan_map(
                    f.frame,
                    &camera,
                    &f.records,
                    &f.lifespans,
                    max_lifespan,
                    exposure,
                );
                let png = encode_png(map_path, f.frame.width, f.frame.height, &rgb)?;
                frame_outputs.stage(map_path, &png)?;
            }
            frame_outputs.commit()?;
            if args.stats.is_some() {
                per_frame.push(f.stats.clone());
            }
            written.set(Some(f.frame_number));
            let s = &f.stats.temporal;
            bar.inc(1);
            let pass_1 = match f.first_pass_at {
                Some(t) => format!("pass 1 (records) at frame {t}; pass 2 (images) wrote "),
                None => "wrote ".to_string(),
            };
            bar.set_message(format!(
                "{pass_1}frame {}: {} records ({} new, {} replaced, {} deleted)",
                f.frame_number, s.alive, s.new, s.replaced, s.deleted
            ));
            Ok(())
        },
        |t, step| match step {
            AnimationStep::Placing { new_records } if two_pass => bar.set_message(format!(
                "pass 1 (records) frame {t}: {new_records} new records{}",
                pass_2()
            )),
            AnimationStep::Placing { new_records } => {
                bar.set_message(format!("frame {t}: {new_records} new records"))
            }
            AnimationStep::Computed => bar.inc(1),
        },
    )?;
    bar.finish_and_clear();
    let wall_s = summary.wall_ms / 1e3;
    let rays = summary.plane_rays;
    let created = summary.records_computed;
    if !args.quiet {
        println!(
            "{count} frames in {wall_s:.2} s ({:.2} s/frame); records computed {created}, \
             plane rays {rays}; temporal caching {}",
            wall_s / f64::from(count),
            if args.temporal.is_some() { "on" } else { "off" }
        );
    }
    if let Some(path) = &args.stats {
        #[derive(serde::Serialize)]
        struct Summary<'a> {
            scene: &'a Path,
            cache: &'a CacheSettings,
            temporal: &'a Option<TemporalSettings>,
            wall_s: f64,
            records_computed: u64,
            plane_rays: u64,
            frames: &'a [radsplat::temporal::animation::AnimationFrameStats],
        }
        let json = serde_json::to_string_pretty(&Summary {
            scene: args.scene_path,
            cache: &args.cache,
            temporal: &args.temporal,
            wall_s,
            records_computed: created,
            plane_rays: rays,
            frames: &per_frame,
        })
        .map_err(|e| Error::Usage(format!("stats JSON: {e}")))?;
        stats_output.stage(path, json.as_bytes())?;
    }
    stats_output.commit()
}

fn temporal_error(
    scene_path: &Path,
    frame: u32,
    (records, sites): (usize, &str),
    size: Option<(u32, u32)>,
    settings: &CacheSettings,
    (record_anchor, stride): (&str, u32),
    json: Option<&Path>,
) -> Result<()> {
    use radsplat::temporal::estimate_error::{RecordSites, estimate_error_table};
    settings.validate()?;
    let mut outputs = OutputSet::new();
    outputs.plan_opt(json)?;
    // Statistics over no records would print a table of 0.00 % errors.
    if records == 0 {
        return Err(Error::Usage(
            "--records 0: must be at least 1 (the table summarises the records' errors)".into(),
        ));
    }
    if stride == 0 {
        return Err(Error::Usage(
            "--estimate-stride 0: must be at least 1 (1: the whole plane)".into(),
        ));
    }
    let mut scene = load_scene_with(scene_path, None, size, None)?;
    let mut next = scene.clone();
    scene.try_set_frame(frame as f32)?;
    next.try_set_frame((frame + 1) as f32)?;
    let renderer = Renderer::new(GpuContext::new()?)?;
    let anchored = record_anchor == "instance";
    // The scene's a_t and dt_max, as `animate` would use them.
    let mut temporal = TemporalSettings::default();
    temporal.apply_scene(scene.animation.as_ref(), None, None);
    let sites = if sites == "placed" {
        RecordSites::Placed
    } else {
        RecordSites::Even
    };
    let table = estimate_error_table(
        &renderer, &scene, &next, settings, records, anchored, stride, &temporal, sites,
    )?;
    if table.records == 0 {
        return Err(Error::Usage(format!(
            "{}: no record could be placed at frame {frame} (no visible surface?), so there \
             are no errors to report",
            scene_path.display()
        )));
    }
    println!(
        "{}: {} records placed at frame {frame}, E(t+1) estimate vs recomputed (RGB RMS relative error)",
        scene_path.display(),
        table.records
    );
    println!(
        "{:<18} {:>8} {:>8} {:>8} {:>8}",
        "", "min", "max", "mean", "median"
    );
    for (name, s) in [
        ("reprojection", &table.reprojection),
        ("no reprojection", &table.no_reprojection),
        ("  on movers: repr.", &table.on_movers_reprojection),
        ("  on movers: none", &table.on_movers_no_reprojection),
    ] {
        println!(
            "{name:<18} {:>7.2}% {:>7.2}% {:>7.2}% {:>7.2}%",
            100.0 * s.min,
            100.0 * s.max,
            100.0 * s.mean,
            100.0 * s.median
        );
    }
    let l = &table.lifespans;
    println!(
        "lifespans (a_t {}, dt_max {}): mean {:.2} frames from the estimated tau, {:.2} from \
         the true tau; records living 1, 2, ... frames: {:?} estimated, {:?} true",
        l.accuracy, l.max_lifespan, l.estimated_mean, l.true_mean, l.estimated, l.truth
    );
    println!(
        "harmonic mean lifespans (records recomputed per frame = records / it): {:.2} \
         estimated, {:.2} true; true on movers ({} records) {:.2}, on the others {:.2}",
        l.estimated_harmonic,
        l.true_harmonic,
        l.movers,
        l.movers_true_harmonic,
        l.still_true_harmonic
    );
    if let Some(path) = json {
        let text =
            serde_json::to_string_pretty(&table).map_err(|e| Error::Usage(format!("JSON: {e}")))?;
        outputs.stage(path, text.as_bytes())?;
    }
    outputs.commit()
}
