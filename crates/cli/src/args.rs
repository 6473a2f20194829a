//! Command-line flags (clap). Raw flags are validated into library
//! parameters in `commands`.

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// relight: real-time relighting with spherical harmonics, Haar wavelets and
/// analytic fog, judged against a Monte Carlo ground-truth renderer.
#[derive(Parser, Debug)]
#[command(name = "relight", version, about, long_about = None)]
pub struct Cli {
    /// Hide progress bars.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render the embedded default scene (no files needed) with the best method available.
    Demo(DemoArgs),
    /// Render a scene file, or a mesh under an environment map.
    Render(Box<RenderArgs>),
    /// Interactive window: drag to orbit, right-drag to turn the lighting,
    /// 1-4 for wavelet/sh/fog/reference, a for antialiasing, s to save, Esc to quit.
    View(ViewArgs),
    /// Describe files: environment maps, images and meshes, with statistics.
    Info {
        /// Files to describe.
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Compare two images (EXR, HDR or PNG) of the same size: relative RMS
    /// difference of the first against the second, the `verify` measure.
    Compare {
        /// Image under test.
        image: PathBuf,
        /// Reference image.
        reference: PathBuf,
        /// Write |image − reference| here (PNG, and an EXR beside it).
        #[arg(long)]
        diff: Option<PathBuf>,
    },
    /// Convert an environment map between parameterizations and formats.
    Convert(ConvertArgs),
    /// Spherical-harmonics tools for IBL bakers.
    #[command(subcommand)]
    Sh(ShCommand),
    /// Precompute (bake) data for the real-time methods.
    #[command(subcommand)]
    Bake(BakeCommand),
    /// Analytic fog tools.
    #[command(subcommand)]
    Fog(FogCommand),
    /// Benchmarks: print a table (or JSON) of measured speed.
    Bench(BenchArgs),
    /// Accuracy against the reference renderer: print a table (or JSON).
    Verify(VerifyArgs),
}

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Output image (PNG, tone-mapped); an EXR (linear) is written beside it.
    #[arg(long, default_value = "demo.png")]
    pub out: PathBuf,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "960x540")]
    pub size: String,
    /// Rendering method.
    #[arg(long, value_enum, default_value_t = Method::Reference)]
    pub method: Method,
    /// Samples per pixel for the reference renderer.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Antialiasing of the raster methods (sh, wavelet, fog): K × K
    /// samples per pixel, box-filtered like the reference's pixels (1…8).
    #[arg(long, default_value_t = 2)]
    pub aa: usize,
}

#[derive(Args, Debug)]
pub struct ViewArgs {
    /// Scene file (TOML); the embedded default scene when absent.
    pub scene: Option<PathBuf>,
    /// Environment map file, or `studio`, replacing the scene's.
    #[arg(long)]
    pub env: Option<String>,
    /// Method shown first.
    #[arg(long, value_enum, default_value_t = ViewMethodArg::Wavelet)]
    pub method: ViewMethodArg,
    /// Window size WIDTHxHEIGHT.
    #[arg(long, default_value = "960x540")]
    pub size: String,
    /// Samples per pixel side of still frames (1…8).
    #[arg(long, default_value_t = 2)]
    pub aa: usize,
    /// Wavelet source side n, normal tessellation side and lighting terms.
    #[arg(long, default_value_t = 64)]
    pub n: usize,
    #[arg(long, default_value_t = 32)]
    pub ntess: usize,
    #[arg(long, default_value_t = 256)]
    pub terms: usize,
    /// SH bands.
    #[arg(long, default_value_t = 6)]
    pub order: usize,
    /// Fog extinction coefficient β.
    #[arg(long, default_value_t = 0.04)]
    pub beta: f32,
    /// Bake cache of the wavelet method.
    #[arg(long)]
    pub cache: Option<PathBuf>,
}

/// The methods of `relight view`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewMethodArg {
    Wavelet,
    Sh,
    Fog,
    /// The Monte Carlo reference, refining while the view is still.
    Reference,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Monte Carlo ground truth (MIS of environment and BRDF).
    Reference,
    /// Spherical-harmonics environment shading with per-pixel rotation.
    Sh,
    /// Haar wavelets on octahedral maps with precomputed rotation matrices.
    Wavelet,
    /// Analytic single-scattering fog with point lights.
    Fog,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML); flags below override it.
    pub scene: Option<PathBuf>,
    /// Environment map file, or `studio` for the embedded one.
    #[arg(long)]
    pub env: Option<String>,
    /// Mesh files (OBJ, PLY, glTF/GLB), or `sphere`, `torus`, `knot`.
    #[arg(long)]
    pub mesh: Vec<String>,
    /// BRDF for every object, e.g. `lambert`, `ggx:0.2`, `phong:50`, `ward:0.1,0.3`.
    #[arg(long)]
    pub brdf: Option<String>,
    /// Camera `ex,ey,ez,tx,ty,tz[,fov_deg]`; default frames the meshes.
    #[arg(long)]
    pub camera: Option<String>,
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// Samples per pixel (reference method).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Image size WIDTHxHEIGHT.
    #[arg(long)]
    pub size: Option<String>,
    /// Output image (PNG); an EXR is written beside it.
    #[arg(long, default_value = "render.png")]
    pub out: PathBuf,
    /// Rotate the lighting by yaw,pitch,roll in degrees.
    #[arg(long)]
    pub light_rotate: Option<String>,
    /// Antialiasing of the raster methods (sh, wavelet, fog): K × K
    /// samples per pixel, box-filtered like the reference's pixels (1…8).
    /// Per-vertex shading (wavelet) costs the same at any K; only the
    /// raster work grows.
    #[arg(long, default_value_t = 1)]
    pub aa: usize,
    /// Trace shadow rays (self-visibility) in the reference renderer.
    #[arg(long)]
    pub visibility: bool,
    /// Random seed of the reference renderer.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// SH order (number of bands), `--method sh`.
    #[arg(long, default_value_t = 6)]
    pub order: usize,
    /// Per-pixel SH rotation, `--method sh`.
    #[arg(long, default_value = "exact")]
    pub rotation: String,
    /// Tangent-space normal map (PNG), `--method sh` and reference.
    #[arg(long)]
    pub normal_map: Option<PathBuf>,
    /// Cache directory for baked data (`--method wavelet`).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Per-vertex ambient occlusion for `--method wavelet` (§3: radiance ×
    /// AO): this many cosine-weighted rays per vertex against every object
    /// (0 = off).
    #[arg(long, default_value_t = 0)]
    pub ao: u32,
    /// Wavelet lighting terms kept.
    #[arg(long, default_value_t = 256)]
    pub terms: usize,
    /// Octahedral source resolution n (N = n²), `--method wavelet`.
    #[arg(long, default_value_t = 64)]
    pub n: usize,
    /// Normal tessellation ntess (ntess² sampled normals), `--method wavelet`.
    #[arg(long, default_value_t = 32)]
    pub ntess: usize,
    /// Fog extinction coefficient β (1/scene units): `--method fog`, and
    /// `--method sh`, which then shades with the foggy environment
    /// (sun-thesis-2008 eq. 3.35–3.37) and shows it behind the objects.
    #[arg(long)]
    pub beta: Option<f32>,
    /// Distance of the environment's light sources for `--method sh
    /// --beta` (the PSF needs a finite one, §3.6.4), scene units.
    #[arg(long, default_value_t = 10.0)]
    pub env_distance: f32,
    /// Point light `x,y,z,intensity` (repeatable), `--method fog`.
    #[arg(long)]
    pub light: Vec<String>,
    /// Fog model: `analytic` (default) or `opengl` (classic exponential fog).
    #[arg(long, default_value = "analytic")]
    pub fog: String,
}

#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// Input environment map.
    pub input: PathBuf,
    /// Output file (.exr linear, .png tone-mapped, .hdr).
    pub output: PathBuf,
    /// Target parameterization.
    #[arg(long, value_enum, default_value_t = ParamKind::Latlong)]
    pub to: ParamKind,
    /// Target size: lat-long height, cube face size, or octahedral side.
    #[arg(long)]
    pub size: Option<usize>,
    /// Supersampling per target texel side.
    #[arg(long, default_value_t = 4)]
    pub supersample: usize,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    Latlong,
    Cube,
    Octahedral,
    HemiOctahedral,
}

#[derive(Subcommand, Debug)]
pub enum ShCommand {
    /// Project an environment map onto real SH and print or write the coefficients.
    Project {
        file: PathBuf,
        /// Number of bands n (n² coefficients).
        #[arg(long, default_value_t = 3)]
        order: usize,
        /// Ringing window: none, hanning, lanczos, sloan.
        #[arg(long, default_value = "none")]
        window: String,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Write the coefficients (JSON) here.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Irradiance environment map (Ramamoorthi–Hanrahan): 9 coefficients and an image.
    Irradiance {
        file: PathBuf,
        /// Irradiance map image to write (lat-long).
        #[arg(long, default_value = "irradiance.png")]
        out: PathBuf,
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand, Debug)]
pub enum BakeCommand {
    /// Wavelet rotation matrices (wavelet-rotation-2006 §2–3).
    Rotation {
        #[arg(long, default_value_t = 64)]
        n: usize,
        #[arg(long, default_value_t = 32)]
        ntess: usize,
        #[arg(long, default_value_t = 1)]
        ntrunc: u16,
        /// Target hemi-octahedral side m (default n/2).
        #[arg(long)]
        m: Option<usize>,
        /// Samples per target texel side of the area integral (1…32).
        #[arg(long, default_value_t = 8)]
        supersample: usize,
        #[arg(long)]
        out: PathBuf,
    },
    /// Wavelet BRDF slices (wavelet-rotation-2006 §3, "Precomputing BRDFs").
    Brdf {
        #[arg(long)]
        brdf: String,
        #[arg(long, default_value_t = 32)]
        m: usize,
        #[arg(long, default_value_t = 64)]
        views: usize,
        #[arg(long, default_value_t = 128)]
        terms: usize,
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Subcommand, Debug)]
pub enum FogCommand {
    /// Write the special-function tables F, G0, Gn as EXR images.
    Tables {
        #[arg(long, default_value_t = 64)]
        size: usize,
        #[arg(long, default_value = "fog-tables.exr")]
        out: PathBuf,
    },
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Suite {
    Raster,
    Reference,
    Sh,
    Wavelet,
    Fog,
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    #[arg(value_enum)]
    pub suite: Suite,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Fewer repetitions and smaller sizes (a smoke run).
    #[arg(long)]
    pub quick: bool,
    /// Also write an SVG plot of each table into this directory.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct VerifyArgs {
    #[arg(value_enum)]
    pub suite: Suite,
    #[arg(long)]
    pub json: bool,
    #[arg(long)]
    pub quick: bool,
    /// Also write an SVG plot of each table into this directory.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}
