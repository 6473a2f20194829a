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
    View(Box<ViewArgs>),
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
        /// Pixels compared: `object` (fully covered by objects in both,
        /// from the EXRs' coverage channel), `background` or `all`.
        #[arg(long, value_enum, default_value_t = Region::Object)]
        region: Region,
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
    /// Output image (PNG, tone-mapped); an EXR (linear, with coverage and
    /// object-id channels) is written beside it.
    #[arg(long, default_value = "demo.png")]
    pub out: PathBuf,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "960x540")]
    pub size: String,
    /// Rendering method.
    #[arg(long, value_enum, default_value_t = Method::Reference)]
    pub method: Method,
    /// Antialiasing: K × K samples per pixel, box-filtered like the
    /// reference's pixels (1…8; the reference integrates pixels itself).
    #[arg(long)]
    pub aa: Option<usize>,
    #[command(flatten)]
    pub options: MethodFlags,
}

/// What the scene is: a scene file and/or flags that build or override it.
#[derive(Args, Debug, Default)]
pub struct SceneArgs {
    /// Scene file (TOML, see docs/scene-format.md); flags below override it.
    pub scene: Option<PathBuf>,
    /// Environment map file, or `studio` for the embedded one.
    #[arg(long)]
    pub env: Option<String>,
    /// Mesh files (OBJ, PLY, glTF/GLB), or a built-in shape (sphere, torus, knot, ground).
    #[arg(long)]
    pub mesh: Vec<String>,
    /// BRDF for every object, e.g. `lambert`, `ggx:0.2`, `phong:50`, `ward:0.1,0.3`.
    #[arg(long)]
    pub brdf: Option<String>,
    /// Camera `ex,ey,ez,tx,ty,tz[,fov_deg]`; default frames the meshes.
    #[arg(long)]
    pub camera: Option<String>,
    /// Image size WIDTHxHEIGHT.
    #[arg(long)]
    pub size: Option<String>,
    /// Rotate the environment by yaw,pitch,roll in degrees (the scene's
    /// world_from_env; every method rotates in its own domain).
    #[arg(long)]
    pub light_rotate: Option<String>,
    /// Tangent-space normal map (PNG) on every object.
    #[arg(long)]
    pub normal_map: Option<PathBuf>,
    /// Point light `x,y,z,intensity` (radiant intensity; repeatable).
    #[arg(long)]
    pub light: Vec<String>,
    /// Homogeneous medium: extinction coefficient β (1/scene units).
    #[arg(long)]
    pub beta: Option<f32>,
    /// Single-scattering albedo of the medium (0…1; with --beta).
    #[arg(long)]
    pub albedo: Option<f32>,
    /// Radius of the fog ball about the origin; the environment lies beyond it
    /// (scene units; with --beta).
    #[arg(long)]
    pub medium_radius: Option<f32>,
    /// Objects shadow the lights (binary visibility); without it, the
    /// unshadowed reflection integral.
    #[arg(long)]
    pub visibility: bool,
    /// Time in seconds for animated objects (keyframes in the scene file).
    #[arg(long)]
    pub time: Option<f32>,
}

/// Options of the methods. Each flag belongs to some methods; giving it to
/// another is an error naming the method. Unset flags take the method's
/// own defaults.
#[derive(Args, Debug, Default, Clone)]
pub struct MethodFlags {
    /// Samples per pixel (reference) [default: 64].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Random seed (reference) [default: 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Media in the reference: `multiple` (full transport) or `single`
    /// (single scattering only, the fog model's classes) [default: multiple].
    #[arg(long, value_enum)]
    pub scattering: Option<Scattering>,
    /// SH order, number of bands (sh; fog's environment part) [default: 6].
    #[arg(long)]
    pub order: Option<usize>,
    /// Per-pixel SH rotation (sh): exact, zyz, taylor1, taylor15, taylor2, none
    /// [default: exact].
    #[arg(long)]
    pub rotation: Option<String>,
    /// Octahedral source resolution n, N = n² (wavelet) [default: 64].
    #[arg(long)]
    pub n: Option<usize>,
    /// Normal tessellation side, ntess² sampled normals (wavelet) [default: 32].
    #[arg(long)]
    pub ntess: Option<usize>,
    /// Lighting terms kept (wavelet) [default: 256].
    #[arg(long)]
    pub terms: Option<usize>,
    /// Per-vertex ambient occlusion rays (wavelet, §3: radiance × AO; 0 = off).
    /// Renders visibility approximately (needs --approximate with --visibility).
    #[arg(long)]
    pub ao: Option<u32>,
    /// Bake cache folder (wavelet) [default: $RELIGHT_CACHE or ~/.cache/relight].
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Fog model (fog): `analytic` or `opengl` (classic exponential fog)
    /// [default: analytic].
    #[arg(long)]
    pub fog: Option<String>,
}

/// Media transport of the reference renderer.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scattering {
    Single,
    Multiple,
}

#[derive(Args, Debug)]
pub struct ViewArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Method shown first.
    #[arg(long, value_enum, default_value_t = Method::Wavelet)]
    pub method: Method,
    /// Render what a method approximates (e.g. visibility by ambient
    /// occlusion) with a warning instead of refusing.
    #[arg(long)]
    pub approximate: bool,
    /// Samples per pixel side of still frames (1…8) [default: 2].
    #[arg(long)]
    pub aa: Option<usize>,
    #[command(flatten)]
    pub options: MethodFlags,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Monte Carlo ground truth: renders every scene feature.
    Reference,
    /// Spherical-harmonics environment shading with per-pixel rotation.
    Sh,
    /// Haar wavelets on octahedral maps with precomputed rotation matrices.
    Wavelet,
    /// Analytic single-scattering fog: point lights and the foggy environment.
    Fog,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Rendering method [default: the scene file's, else reference].
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// Render what the method approximates with a warning instead of refusing.
    #[arg(long)]
    pub approximate: bool,
    /// Output image (PNG); an EXR (linear, with coverage and object-id
    /// channels) is written beside it.
    #[arg(long, default_value = "render.png")]
    pub out: PathBuf,
    /// Antialiasing of the raster methods: K × K samples per pixel,
    /// box-filtered like the reference's pixels (1…8) [default: 1].
    #[arg(long)]
    pub aa: Option<usize>,
    #[command(flatten)]
    pub options: MethodFlags,
}

/// Which pixels `relight compare` measures.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    Object,
    Background,
    All,
}

impl Region {
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Object => "object",
            Self::Background => "background",
            Self::All => "all",
        }
    }
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
    /// The viewer's frame path per method at 960×540 and 1280×720.
    Frames,
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
    /// `bench frames` only: run only the rows of these methods (repeatable).
    #[arg(long = "method", value_name = "NAME")]
    pub methods: Vec<String>,
}

/// Accuracy suites of `relight verify`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum VerifySuite {
    Raster,
    Reference,
    Sh,
    Wavelet,
    Fog,
    /// Every method on a matrix of scenes against one reference.
    Methods,
}

#[derive(Args, Debug)]
pub struct VerifyArgs {
    #[arg(value_enum)]
    pub suite: VerifySuite,
    #[arg(long)]
    pub json: bool,
    #[arg(long)]
    pub quick: bool,
    /// Also write an SVG plot of each table into this directory.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}
