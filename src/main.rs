//! The `radsplat` command line.

use clap::{Parser, Subcommand};
use radsplat::commands;
use radsplat::hsh::rotation::RotationMethod;
use radsplat::records::{CacheSettings, RecordSource};
use radsplat::splat::radiance::RadianceSettings;
use radsplat::temporal::{
    EstimateMode, MoverRecords, RecordAnchor, RefreshMode, Replacement, TemporalGradients,
    TemporalSettings,
};
use std::path::PathBuf;
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
        /// Write frame statistics as JSON here (pass times only with --time-passes).
        #[arg(long)]
        stats: Option<PathBuf>,
        /// Time each GPU pass, and shader compilation apart, for the summary and --stats
        /// (a profile: a few percent slower on lavapipe; the same image).
        #[arg(long)]
        time_passes: bool,
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
        /// How the planes' pixels are spaced (as `render --plane-spacing`).
        #[arg(long, value_enum, default_value_t = CacheSettings::default().plane_spacing)]
        plane_spacing: radsplat::records::PlaneSpacing,
        /// Light samples per area light at each hit (planes and Monte Carlo alike).
        #[arg(long, default_value_t = 1)]
        light_samples: u32,
        /// Also compare adaptive refinement of this fraction of the pixels (as `render
        /// --plane-refine`) with a plain plane of equal rays; adds the share of points
        /// whose plane irradiance is zero where Monte Carlo's is not.
        #[arg(long, default_value_t = 0.0, value_parser = parse_fraction)]
        plane_refine: f32,
        /// Sub-samples per axis of a refined pixel.
        #[arg(long, default_value_t = 2, value_parser = parse_refine_split)]
        plane_refine_split: u32,
        /// Resolution of the plain plane compared at equal rays (default: the one whose
        /// Q^2 rays are closest to the refined plane's P^2 + K split^2).
        #[arg(long)]
        equal_rays_resolution: Option<u32>,
        /// Write the table as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        #[arg(short, long)]
        quiet: bool,
    },
    /// BRDF projection (thesis eqs. 3.32-3.36): how much of each glossy material's lobe
    /// hemispherical harmonics of each order hold, over a paraboloid map of outgoing
    /// directions (CPU).
    BrdfProjection {
        scene: PathBuf,
        /// HSH orders, comma-separated (order n: n^2 coefficients per channel; at most 10).
        #[arg(long, value_delimiter = ',', default_value = "3,4,5,6,7,8,9,10")]
        orders: Vec<u32>,
        /// Outgoing directions per side of the paraboloid map (the thesis: 32).
        #[arg(long, default_value_t = 32)]
        resolution: u32,
        /// Write the table as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
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
        /// Where records stay while objects move: `instance` (the default: carried with
        /// the instance they lie on) or `world` (the thesis: at their world position, where
        /// records on a moving object are left behind: on cube in a box, 48x48, the
        /// indirect error climbs from 5 % to 12 % across a record generation, against
        /// 4.9-6.9 % anchored).
        #[arg(long, default_value = "instance", value_parser = ["world", "instance"])]
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
        /// of the frame no kept record covers). In every mode a record whose place an object
        /// that moved now covers is deleted instead (traced from inside the object it saw
        /// black: docs/results.md, "Replacements inside a moving object").
        #[arg(long, default_value = "visible", value_parser = ["visible", "covering", "needed"])]
        replace: String,
        /// The E(t+1) estimate reprojects every N-th plane sample each way (1: all). With
        /// interpolated gradients it only gives tau, so 2 costs a quarter as much.
        /// Default: 2 with interpolated gradients (1 if the plane resolution is odd or
        /// below 8), 1 with extrapolated.
        #[arg(long)]
        estimate_stride: Option<u32>,
        /// Which new records are estimated at t+1 (the estimate gives their lifespan):
        /// `auto` (each record kind's, while the frames of life its estimates win outweigh
        /// their cost; else its records live one frame, and every 4th frame estimates to
        /// look again) or `always` (the seed). On glossy Spheres radiance records' estimates
        /// won 0.08 frames a record for half a record's cost (docs/results.md).
        #[arg(long, default_value = "auto", value_parser = ["auto", "always"])]
        estimates: String,
        /// How long records on an instance that moves to the next frame live: `one-frame`
        /// (recomputed every frame: reusing them made moving objects flicker, 0.60 against
        /// 0.30 % change error on glossy Spheres' moving balls) or `by-change` (as every
        /// other record: by tau and dt_max, the seed).
        #[arg(long, default_value = "one-frame", value_parser = ["one-frame", "by-change"])]
        mover_records: String,
        /// At most N new records placed per frame (replacements do not count): pixels
        /// left uncovered get records in later frames, spreading a walkthrough's new views
        /// over frames. Default: every uncovered pixel gets one. Needs temporal caching.
        #[arg(long, value_name = "N")]
        max_new_records: Option<u32>,
        /// Refine irradiance records' planes under temporal caching as `--plane-refine`
        /// says (radiance records' planes are not refined). Off by default: on glossy
        /// Spheres 96x72 it lowers the error from 0.96 to 0.93 % and the flicker from 0.52
        /// to 0.51 % for about 16 % more time, where per-frame computation with unrefined
        /// planes is faster and more accurate still; on cube in a box 48x48 it lowers the
        /// indirect error from 3.23 to 2.92 % (per frame 2.99 %) for 18 % more time.
        #[arg(long)]
        temporal_refine: bool,
        #[command(flatten)]
        cache: CacheArgs,
        /// Also write a lifespan map per frame (PNG pattern with `#`): record sites from
        /// red (short-lived) to green (long-lived).
        #[arg(long)]
        lifespan_map: Option<PathBuf>,
        /// Write per-frame statistics as JSON here (pass times only with --time-passes).
        #[arg(long)]
        stats: Option<PathBuf>,
        /// Time each GPU pass, and shader compilation apart, for --stats (a profile: a
        /// few percent slower on lavapipe; the same images).
        #[arg(long)]
        time_passes: bool,
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
        /// placed record with `--sites placed`). (`--records` names the record source.)
        #[arg(long = "record-count", default_value_t = 1000)]
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
        /// Sample sequence seed: 0 (default) is the historical sequence; another value
        /// gives independent noise (two seeds measure a reference's own noise).
        #[arg(long, default_value_t = 0)]
        seed: u32,
        /// Bounces of indirect light (Radiance's `-ab`): 1 reflects direct light once;
        /// N follows each path N - 1 more (Lambertian) hits.
        #[arg(long, default_value_t = 1, value_parser = parse_bounces)]
        bounces: u32,
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
    /// --plane-resolution: on the Cornell box 128x128 a = 0.1 gave 1.9 % indirect error with
    /// 16x16 planes, 1.0 % with 32x32 and 0.87 % with 48x48 (a = 0.2: 2.1 %, 1.7 % with the
    /// default 24x24, 1.4 % with 32x32, split-sphere records); a = 0.3-0.5 gets by with
    /// 16x16. Default: 0.25 (with --record-radius hessian), 0.2 for `animate` and for
    /// `--records vpl|photons` (their records are sized by the split sphere).
    #[arg(short, long, value_parser = parse_accuracy)]
    accuracy: Option<f32>,
    /// Hemisphere plane resolution P (P x P rays per record, plus --plane-refine's): the
    /// noise of each record's irradiance. Goes with -a: fewer plane rays need a larger a
    /// (fewer, wider records average the plane noise over more pixels), see -a.
    #[arg(long, default_value_t = CacheSettings::default().plane_resolution, value_parser = parse_plane_resolution)]
    plane_resolution: u32,
    /// Hemisphere plane field of view in degrees.
    #[arg(long, default_value_t = CacheSettings::default().plane_fov_degrees, value_parser = parse_plane_fov)]
    plane_fov: f32,
    /// How the plane's pixels are spaced: `cosine` evenly in sin(angle) along each axis, so
    /// that every column and row carries the same cosine weight (a 32x32 plane at 150
    /// degrees is worth about 950 equally weighted rays); `uniform` evenly on the plane,
    /// as the thesis rasterises it (worth about 155). `animate` uses `uniform`.
    #[arg(long, value_enum, default_value_t = CacheSettings::default().plane_spacing)]
    plane_spacing: radsplat::records::PlaneSpacing,
    /// Light samples per area light and for the environment at each plane hit. Where the
    /// records' own sampling noise is what is left, more pay: on env-sphere (lit by its
    /// map alone) 2 / 4 samples take the indirect error from 6.3 % to 4.7 / 3.4 % for 10 /
    /// 35 % more time, more than finer planes or more records give; on Sponza (sun and
    /// sky) they gain nothing (docs/results.md, "Environment light at plane hits").
    #[arg(long, default_value_t = CacheSettings::default().plane_light_samples, value_parser = parse_at_least_one)]
    plane_light_samples: u32,
    /// Lights sampled at each plane hit where a scene has more: chosen by what they give the
    /// hit unoccluded (exact: a rect light's clipped Lambert formula), by systematic
    /// resampling (unbiased; a light above 1/N of the total is never missed). 0: every
    /// light, one shadow ray each (docs/results.md: conference room).
    #[arg(long, default_value_t = CacheSettings::default().plane_light_choices)]
    plane_light_choices: u32,
    /// Bounces of indirect light (Radiance's `-ab`): 1 reflects direct light once; N > 1
    /// lets plane hits reflect a surface cache of N - 1 more bounces (docs/architecture.md).
    #[arg(long, default_value_t = CacheSettings::default().bounce.bounces, value_parser = parse_bounces)]
    bounces: u32,
    /// Gather rays per cell side and level of the bounce cache (with --bounces above 1).
    #[arg(long, default_value_t = CacheSettings::default().bounce.rays, value_parser = parse_at_least_one)]
    bounce_rays: u32,
    /// Bounce-cache cell edge as a fraction of the scene's bounding-box diagonal.
    #[arg(long, default_value_t = CacheSettings::default().bounce.cell_size, value_parser = parse_positive)]
    bounce_cell: f32,
    /// Most bounce-cache cell sides (two per cell); cells grow until they fit.
    #[arg(long, default_value_t = CacheSettings::default().bounce.max_cells, value_parser = parse_at_least_one)]
    bounce_cells: u32,
    /// Shadow rays at the bounce cache's gather hits instead of light-space maps of every
    /// light.
    #[arg(long)]
    bounce_shadow_rays: bool,
    /// Where records get their irradiance: `planes` (hemisphere planes, thesis chapter 4)
    /// or `vpl` (instant caching, seed 003: one visibility ray per virtual point light
    /// traced from the lights; the VPL paths carry --bounces) or `photons` (photon-mapped
    /// irradiance caching, thesis chapter 6: records from the photon map alone, plane
    /// records where photons are too few; not with temporal caching).
    #[arg(long = "records", value_enum, default_value_t = RecordSource::Planes)]
    record_source: RecordSource,
    /// Light paths of `--records vpl` (about; each light gets at least one): one VPL per
    /// path and bounce, one visibility ray each per record.
    #[arg(long, default_value_t = CacheSettings::default().vpl.paths, value_parser = parse_at_least_one)]
    vpl_paths: u32,
    /// Bounding distance of `--records vpl` (seed 003 eq. 2-3: VPLs nearer a record than
    /// about this fade out) in units of the VPLs' mean spacing sqrt(scene area / paths);
    /// 0: none.
    #[arg(long, default_value_t = CacheSettings::default().vpl.clamp)]
    vpl_clamp: f32,
    /// Light paths of `--records photons` (about; each light gets at least one): one
    /// photon per path and bounce.
    #[arg(long, default_value_t = CacheSettings::default().photons.paths, value_parser = parse_at_least_one)]
    photon_paths: u32,
    /// Photons of a photon record's first neighbourhood (its R, and the fewest its
    /// irradiance is estimated from).
    #[arg(long, default_value_t = CacheSettings::default().photons.gather)]
    photon_gather: u32,
    /// The area a photon record divides its photons' flux by: `hull`, their convex hull
    /// (the thesis's); `probed`, the hull less its part with no surface under it (probe
    /// rays; gaps between coplanar pieces no longer darken the record).
    #[arg(long, value_enum, default_value_t = CacheSettings::default().photons.area)]
    photon_area: radsplat::photons::PhotonArea,
    /// R_min as the validity radius a R_min in pixels at creation. Default: 2 for still
    /// frames, 3 for animations and for VPL and photon records (what they were measured
    /// with).
    #[arg(long, value_parser = parse_positive)]
    r_min_pixels: Option<f32>,
    /// Records are interpolated at this times the accuracy -a (placed at -a itself), in
    /// [1, 4]: a pixel near the edge of a record's reach averages more records instead of
    /// taking one record's plane noise.
    #[arg(long, default_value_t = CacheSettings::default().interpolation_factor)]
    interpolation_factor: f32,
    /// A still frame whose records are typically noisier than this times -a (their
    /// median relative noise, estimated from each plane) interpolates wider than
    /// --interpolation-factor, by the ratio, up to 4 a: where the records' plane noise is
    /// the error (small bright patches), more records average it; each pixel stays within
    /// --widening-tolerance times -a of the narrower gather. On a hall lit through small windows
    /// the indirect error went from 14.6 to 12.6 %; quiet scenes (a Cornell box) keep
    /// their bytes (docs/results.md, "The widened gather checked against the default
    /// one"). 0: never
    #[arg(long, default_value_t = CacheSettings::default().noise_widening)]
    noise_widening: f32,
    /// With --noise-widening: a pixel keeps the widened gather's indirect irradiance only
    /// where it is within this times -a (relative) of the gather at
    /// --interpolation-factor, whose value it keeps elsewhere, so that a narrow peak of
    /// light (the foot of a sunlit wall) is not spread over its neighbours. 'inf': the
    /// widened gather everywhere
    #[arg(long, default_value_t = CacheSettings::default().widening_tolerance)]
    widening_tolerance: f32,
    /// A world-space lower bound on R_min, as a fraction of the scene's bounding-box
    /// diagonal (like Radiance's -ar: R_min is the larger of this and the pixel bound).
    #[arg(long, default_value_t = CacheSettings::default().r_min_scene)]
    r_min_scene: f32,
    /// R_max / R_min.
    #[arg(long, default_value_t = CacheSettings::default().r_max_factor, value_parser = parse_r_max_factor)]
    r_max_factor: f32,
    /// Most records the cache may hold.
    #[arg(long, default_value_t = CacheSettings::default().record_budget, value_parser = parse_record_budget)]
    record_budget: u32,
    /// Tail fill: once at most this share of the visible pixels is uncovered, placement
    /// covers the rest at --tail-factor x a, interpolating a pixel that a record reaches
    /// there from those records instead of placing one of its own (the last pixels are
    /// slivers between records); 0: off. The tail's records trace planes of
    /// P sqrt(a / a_tail) per side. Not used by `animate`.
    #[arg(long, default_value_t = CacheSettings::default().tail_share, value_parser = parse_fraction)]
    tail_share: f32,
    /// Tail fill's accuracy factor (>= 1): the tail is covered and interpolated at this
    /// times -a.
    #[arg(long, default_value_t = CacheSettings::default().tail_factor, value_parser = parse_tail_factor)]
    tail_factor: f32,
    /// Lobe directions per pixel for the indirect light of glossy materials (Monte Carlo
    /// through the lobe, each hit shaded with direct light).
    #[arg(long, default_value_t = CacheSettings::default().glossy_samples, value_parser = parse_at_least_one)]
    glossy_samples: u32,
    /// Highest HSH order of radiance records (n^2 coefficients per channel, at most 10),
    /// which cache the indirect light of low-frequency glossy lobes; records carry fewer
    /// bands when every lobe they shade keeps fewer (--radiance-lobe-share); 0: every
    /// glossy lobe by Monte Carlo.
    #[arg(long, default_value_t = RadianceSettings::default().order)]
    radiance_order: u32,
    /// Ward's accuracy a of radiance records (their own, beside -a for irradiance ones).
    #[arg(long, default_value_t = RadianceSettings::default().accuracy)]
    radiance_accuracy: f32,
    /// Lobes whose HSH projection holds less of their energy than this (thesis eq. 3.32,
    /// mean over view directions) are too sharp for radiance records: Monte Carlo.
    #[arg(long, default_value_t = RadianceSettings::default().min_lobe_accuracy)]
    radiance_lobe_accuracy: f32,
    /// Each glossy lobe is evaluated with the fewest HSH bands (up to --radiance-order)
    /// whose projection holds this share of its energy (eq. 3.32): broad lobes need few,
    /// and the splat's cost follows the bands. 1 keeps every band.
    #[arg(long, default_value_t = RadianceSettings::default().lobe_share)]
    radiance_lobe_share: f32,
    /// How radiance records are tilted into a pixel's frame (thesis section 3.4).
    #[arg(long, value_enum, default_value = "tabulated")]
    radiance_rotation: RotationMethod,
    /// Plane resolution P of radiance records (0: from the sharpest lobe they shade,
    /// --plane-resolution times sqrt(exponent / 5), at most twice it).
    #[arg(long, default_value_t = RadianceSettings::default().plane_resolution)]
    radiance_plane_resolution: u32,
    /// Do not compute or use irradiance gradients.
    #[arg(long)]
    no_gradients: bool,
    /// What a record's R measures: `split-sphere` (Ward's harmonic mean distance) or
    /// `hessian` (second-order error control from the irradiance's Hessian, scaled by
    /// --hessian-scale).
    /// `animate` and `--records vpl|photons` keep split-sphere records at -a 0.2 when
    /// neither this nor -a is given.
    #[arg(long, value_enum, default_value = "hessian")]
    record_radius: RecordRadiusArg,
    /// With --record-radius hessian: R = scale sqrt(E / lambda).
    #[arg(long, default_value_t = CacheSettings::HESSIAN_SCALE)]
    hessian_scale: f32,
    /// Turn neighbour clamping off (Krivanek et al. 2006, on by default: a new record's R is
    /// at most R_j + |p - p_j| over the records placed before it; quadratic in the record
    /// count).
    #[arg(long)]
    no_neighbour_clamp: bool,
    /// The corral (after Radiance's ambcorral): a record does not reach pixels beyond a
    /// surface that its plane's horizon rays hit near it. `cover` (the default):
    /// placement's cover weighs it, so such pixels get records of their own, and the
    /// gathers weigh every record; `gather`: the gathers alone weigh it (the same records
    /// as `off`); `placement`: both (more accurate beside a lit wall's end, 1.1-1.2x the
    /// time on lavapipe); `off`. Animations keep no corral.
    #[arg(long, value_enum, default_value = "cover")]
    corral: radsplat::records::Corral,
    /// How hemisphere-plane hits are shadowed: `maps` traces light-space visibility maps
    /// once per scene (an orthographic map for a sun, octahedral maps for point and spot
    /// lights, an N x N grid of them per rect light) and looks shadows up; `rays` traces a
    /// shadow ray per light sample at every plane hit (exact); `auto` maps the sun, point
    /// and spot lights and traces rays to rect lights (whose maps approximate penumbrae).
    /// With maps, a plane hit still traces its ray where the map cannot decide (creases and
    /// contact shadows). `animate` with temporal caching always uses rays (its records
    /// outlive a frame); `animate --temporal off` follows this setting.
    #[arg(long, value_enum, default_value_t = CacheSettings::default().plane_shadows)]
    plane_shadows: radsplat::records::PlaneShadows,
    /// Texels per side of a sun's light map (point and rect-light maps get half).
    #[arg(long, default_value_t = CacheSettings::default().light_maps.resolution)]
    light_map_resolution: u32,
    /// With light maps: a rect light gets an N x N grid of maps (one per cell, traced from
    /// its centre); a plane hit's random point on the light takes its cell's visibility.
    #[arg(long, default_value_t = CacheSettings::default().light_maps.rect_grid, value_parser = parse_at_least_one)]
    light_map_grid: u32,
    /// Adaptive plane refinement (Radiance's -as): the fraction F in [0, 1] of each
    /// record's plane pixels, those of highest contrast to their neighbours (less what
    /// their environment samples gave them: that part is noise), traced again
    /// with --plane-refine-split^2 rays each; where fewer have contrast and the light maps
    /// see every lit surface (suns, point and rect lights alone), pixels near a lit surface
    /// take the rest. Costs up to F x split^2 x P^2 more plane rays per
    /// record (F = 0.1, split 2: +40 %), and two passes; a plane that saw no light is
    /// refined everywhere (see --no-dark-plane-refine). 0: none by contrast. Temporal
    /// caching (`animate`) refines by contrast only with --temporal-refine, and only
    /// irradiance records' planes.
    #[arg(long, default_value_t = CacheSettings::default().plane_refine, value_parser = parse_fraction)]
    plane_refine: f32,
    /// Sub-samples per axis of a refined plane pixel (split x split strata), 1..=8.
    #[arg(long, default_value_t = CacheSettings::default().plane_refine_split, value_parser = parse_refine_split)]
    plane_refine_split: u32,
    /// Do not refine planes that saw no light (by default every pixel of such a plane
    /// gets --plane-refine-split^2 more rays, whatever --plane-refine says, in `animate`
    /// too: P^2 rays miss small bright patches, and without it a sunlit interior's
    /// animation showed floors of exactly zero indirect light).
    #[arg(long)]
    no_dark_plane_refine: bool,
    /// Refine a plane that saw no light everywhere, not only at the pixels whose rays can
    /// land near a lit surface (by default, where the light maps see every lit surface:
    /// every light mapped, no environment, no emitters of their own, one bounce)
    #[arg(long)]
    dark_planes_everywhere: bool,
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

/// A number from the command line that `ok` accepts, else the rule `why` it breaks.
fn parse_checked<T: std::str::FromStr + Copy>(
    s: &str,
    ok: impl Fn(T) -> bool,
    why: &str,
) -> std::result::Result<T, String> {
    let x: T = parse_number(s)?;
    if ok(x) { Ok(x) } else { Err(why.into()) }
}

fn parse_accuracy(s: &str) -> std::result::Result<f32, String> {
    parse_checked(
        s,
        |a: f32| a > 0.0 && a <= 1.0,
        "the accuracy must be in (0, 1]",
    )
}

fn parse_plane_resolution(s: &str) -> std::result::Result<u32, String> {
    parse_checked(
        s,
        |p: u32| (2..=512).contains(&p),
        "the plane resolution must be in 2..=512",
    )
}

fn parse_plane_fov(s: &str) -> std::result::Result<f32, String> {
    parse_checked(
        s,
        |fov: f32| fov > 1.0 && fov < 179.0,
        "the plane field of view must be in (1, 179) degrees",
    )
}

fn parse_at_least_one(s: &str) -> std::result::Result<u32, String> {
    parse_checked(s, |n: u32| n >= 1, "must be at least 1")
}

/// Bounces: 1 to [`radsplat::bounce::MAX_BOUNCES`].
fn parse_bounces(s: &str) -> std::result::Result<u32, String> {
    let most = radsplat::bounce::MAX_BOUNCES;
    parse_checked(
        s,
        |n: u32| (1..=most).contains(&n),
        &format!("must be 1 to {most}"),
    )
}

fn parse_positive(s: &str) -> std::result::Result<f32, String> {
    parse_checked(
        s,
        |x: f32| x > 0.0 && x.is_finite(),
        "must be a positive number",
    )
}

fn parse_r_max_factor(s: &str) -> std::result::Result<f32, String> {
    parse_checked(
        s,
        |x: f32| x >= 1.0 && x.is_finite(),
        "must be a number >= 1 (R_max / R_min)",
    )
}

fn parse_fraction(s: &str) -> std::result::Result<f32, String> {
    parse_checked(
        s,
        |x: f32| (0.0..=1.0).contains(&x),
        "must be a fraction in [0, 1]",
    )
}

fn parse_tail_factor(s: &str) -> std::result::Result<f32, String> {
    parse_checked(
        s,
        |x: f32| (1.0..=16.0).contains(&x),
        "must be a number in [1, 16]",
    )
}

fn parse_refine_split(s: &str) -> std::result::Result<u32, String> {
    parse_checked(s, |n: u32| (1..=8).contains(&n), "must be in 1..=8")
}

fn parse_record_budget(s: &str) -> std::result::Result<u32, String> {
    parse_checked(
        s,
        |n: u32| n >= 1,
        "must be at least 1: no records means no indirect light (for direct light \
         only, use `render --direct-only`)",
    )
}

/// `--record-radius` (records::RecordRadius without its scale).
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum RecordRadiusArg {
    SplitSphere,
    Hessian,
}

impl CacheArgs {
    /// The cache settings of these flags for a still frame or an animation (`animated`:
    /// the default accuracy and pixel bound differ).
    fn settings(&self, animated: bool) -> CacheSettings {
        // Animations and VPL/photon records were measured with their own accuracy and
        // pixel bound; still frames of plane records with the library's defaults.
        let measured_apart =
            animated || self.record_source != radsplat::records::RecordSource::Planes;
        CacheSettings {
            accuracy: self.accuracy.unwrap_or(if measured_apart {
                CacheSettings::ANIMATION_ACCURACY
            } else {
                CacheSettings::default().accuracy
            }),
            plane_resolution: self.plane_resolution,
            plane_fov_degrees: self.plane_fov,
            plane_spacing: self.plane_spacing,
            plane_light_samples: self.plane_light_samples,
            plane_light_choices: self.plane_light_choices,
            r_min_pixels: self.r_min_pixels.unwrap_or(if measured_apart {
                CacheSettings::ANIMATION_R_MIN_PIXELS
            } else {
                CacheSettings::default().r_min_pixels
            }),
            interpolation_factor: self.interpolation_factor,
            noise_widening: self.noise_widening,
            widening_tolerance: self.widening_tolerance,
            r_min_scene: self.r_min_scene,
            r_max_factor: self.r_max_factor,
            record_radius: match self.record_radius {
                RecordRadiusArg::SplitSphere => radsplat::records::RecordRadius::SplitSphere,
                RecordRadiusArg::Hessian => radsplat::records::RecordRadius::Hessian {
                    scale: self.hessian_scale,
                },
            },
            record_budget: self.record_budget,
            tail_share: self.tail_share,
            tail_factor: self.tail_factor,
            gradients: !self.no_gradients,
            neighbour_clamp: !self.no_neighbour_clamp,
            corral: self.corral,
            plane_shadows: self.plane_shadows,
            light_maps: radsplat::light_maps::LightMapSettings {
                resolution: self.light_map_resolution,
                rect_grid: self.light_map_grid,
            },
            plane_refine: self.plane_refine,
            plane_refine_split: self.plane_refine_split,
            dark_plane_refine: !self.no_dark_plane_refine,
            dark_plane_guide: !self.dark_planes_everywhere,
            glossy_samples: self.glossy_samples,
            radiance: RadianceSettings {
                order: self.radiance_order,
                accuracy: self.radiance_accuracy,
                min_lobe_accuracy: self.radiance_lobe_accuracy,
                lobe_share: self.radiance_lobe_share,
                rotation: self.radiance_rotation,
                plane_resolution: self.radiance_plane_resolution,
            },
            bounce: radsplat::bounce::BounceSettings {
                bounces: self.bounces,
                rays: self.bounce_rays,
                cell_size: self.bounce_cell,
                max_cells: self.bounce_cells,
                shadow_maps: !self.bounce_shadow_rays,
            },
            source: self.record_source,
            vpl: radsplat::vpl::VplSettings {
                paths: self.vpl_paths,
                clamp: self.vpl_clamp,
            },
            photons: radsplat::photons::PhotonSettings {
                paths: self.photon_paths,
                gather: self.photon_gather,
                area: self.photon_area,
            },
            ..CacheSettings::default()
        }
    }
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
    // SAFETY: as above, before any thread is started.
    unsafe { radsplat::gpu::context::two_lavapipe_threads_per_core() };
    // A closed pipe on stdout (`radsplat compare A B | head`) ends the process quietly, as
    // for any Unix tool, instead of panicking in `println!` (Rust ignores SIGPIPE).
    // SAFETY: restores the default disposition before any thread is started.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
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
            time_passes,
            direct_only,
            cache,
            record_map,
            quiet,
        } => match commands::render::render(commands::render::RenderArgs {
            scene_path: &scene,
            output,
            png,
            size,
            light_samples,
            stats,
            time_passes,
            cache: (!direct_only).then(|| cache.settings(false)),
            record_map,
            quiet,
        }) {
            // Its outputs are committed: the process ends here, the device not torn down
            // (`Rendered::end_process`).
            Ok(rendered) => rendered.end_process(),
            Err(e) => Err(e),
        },
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
            estimates,
            mover_records,
            max_new_records,
            temporal_refine,
            cache,
            lifespan_map,
            stats,
            time_passes,
            quiet,
        } => commands::animate::animate(commands::animate::AnimateArgs {
            scene_path: &scene,
            frames,
            output,
            size,
            light_samples,
            cache: cache.settings(true),
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
                refine_planes: temporal_refine,
                estimates: if estimates == "always" {
                    EstimateMode::Always
                } else {
                    EstimateMode::Auto
                },
                mover_records: if mover_records == "by-change" {
                    MoverRecords::ByChange
                } else {
                    MoverRecords::OneFrame
                },
                ..TemporalSettings::default()
            }),
            lifespan_map,
            stats,
            time_passes,
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
        } => commands::temporal_error::temporal_error(
            &scene,
            frame,
            (records, &sites),
            size,
            &cache.settings(true),
            (&record_anchor, estimate_stride),
            json.as_deref(),
        ),
        Command::Info => commands::info::info(),
        Command::BrdfProjection {
            scene,
            orders,
            resolution,
            json,
        } => commands::brdf_projection::brdf_projection(&scene, &orders, resolution, json),
        Command::PlaneError {
            scene,
            points,
            mc_samples,
            fovs,
            plane_resolution,
            plane_spacing,
            light_samples,
            plane_refine,
            plane_refine_split,
            equal_rays_resolution,
            json,
            quiet,
        } => commands::plane_error::plane_error(
            &scene,
            points,
            mc_samples,
            &fovs,
            (plane_resolution, plane_spacing),
            light_samples,
            (plane_refine, plane_refine_split, equal_rays_resolution),
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
            seed,
            bounces,
            frame,
            output,
            png,
            size,
            light_samples,
            stats,
            quiet,
        } => commands::reference::reference(
            &scene,
            radsplat::reference::ReferenceOptions::new(spp)
                .with_seed(seed)
                .with_bounces(bounces),
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
        } => commands::compare::compare(
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
        } => commands::compare::compare_seq(
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
        } => commands::export_rad::export_rad(&scene, &out_dir, size),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn parse_frames(s: &str) -> std::result::Result<std::ops::RangeInclusive<u32>, String> {
    radsplat::output::parse_frame_range(s).map_err(|e| e.to_string())
}
