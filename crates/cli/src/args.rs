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

// Parsed once per run: the size of the largest variant (the method flags
// every render-like command carries) costs nothing worth a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render the embedded scene (no files needed) with the reference and every
    /// real-time method, side by side in one labelled image: ms per frame and
    /// error against the reference.
    Demo(Box<DemoArgs>),
    /// Render a scene file, or a mesh under an environment map.
    Render(Box<RenderArgs>),
    /// Interactive window: drag to orbit, right-drag to turn the lighting,
    /// keys 1-9 for wavelet/sh/fog/shexp/reference/ndf/nearfield/triple/ltc, a for
    /// antialiasing, l (or Shift) to move and scale an area light, t for its
    /// texture, Tab for the next light, s to save, Esc to quit.
    View(Box<ViewArgs>),
    /// Describe files: environment maps, images and meshes with statistics; scene files with the methods that render them.
    Info {
        /// Files to describe: environment maps, images, meshes, MERL BRDFs, and
        /// scene files (`.toml`: what they hold and which methods render them).
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
    /// Wavelet-domain image tools (affine transforms, thesis §4.6.2).
    #[command(subcommand)]
    Wavelet(crate::zoom::WaveletCommand),
    /// Benchmarks: print a table (or JSON) of measured speed.
    Bench(BenchArgs),
    /// Accuracy against the reference renderer: print a table (or JSON).
    Verify(VerifyArgs),
    /// Sphere sets of meshes (shadow proxies).
    #[command(subcommand)]
    Spheres(crate::shexp::SpheresCommand),
    /// The bake caches (wavelet, nearfield, triple): list their entries or delete them.
    #[command(subcommand)]
    Cache(CacheCommand),
    /// Normal-map filtering tools: `ndf bake` writes an engine-ready MIP chain.
    #[command(subcommand)]
    Ndf(crate::ndf_bake::NdfCommand),
}

/// `relight cache list|clear` (crate::cache).
#[derive(Subcommand, Debug)]
pub enum CacheCommand {
    /// List cached bakes: kind, configuration, size and date.
    List {
        /// Only entries whose file name or configuration contains this text
        /// (e.g. `rot-n128`, `ggx`, `terms=128`).
        pattern: Option<String>,
        /// Cache folder [default: $RELIGHT_CACHE/wavelet, $RELIGHT_CACHE/nearfield
        /// and $RELIGHT_CACHE/triple, else under $XDG_CACHE_HOME/relight/,
        /// else under ~/.cache/relight/].
        #[arg(long)]
        cache: Option<PathBuf>,
    },
    /// Delete cached bakes: every entry, or those matching PATTERN.
    Clear {
        /// Only entries whose file name or configuration contains this text.
        pattern: Option<String>,
        /// Cache folder [default: as for `cache list`].
        #[arg(long)]
        cache: Option<PathBuf>,
    },
}

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Composite image (PNG, tone-mapped, labelled); beside it the composite
    /// EXR (linear, no labels) and one EXR per method, `STEM-METHOD.exr`
    /// (linear, with coverage and object-id channels).
    #[arg(long, default_value = "demo.png")]
    pub out: PathBuf,
    /// Size of each method's tile, WIDTHxHEIGHT [default: 480x270].
    #[arg(long)]
    pub size: Option<String>,
    /// Methods shown, one tile each (repeat the flag) [default: reference,
    /// wavelet, sh, fog, shexp]; errors are measured against the reference
    /// when it is among them.
    #[arg(long, value_enum)]
    pub method: Vec<Method>,
    /// Antialiasing of the raster methods: K × K samples per pixel,
    /// box-filtered like the reference's pixels (1…8) [default: 2].
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
    /// Camera `ex,ey,ez,tx,ty,tz[,fov_deg]` (a top-down view looks with −Z up);
    /// default frames the meshes.
    #[arg(long)]
    pub camera: Option<String>,
    /// Image size WIDTHxHEIGHT.
    #[arg(long)]
    pub size: Option<String>,
    /// Rotate the environment by yaw,pitch,roll in degrees (the scene's
    /// world_from_env; every method rotates in its own domain).
    #[arg(long)]
    pub light_rotate: Option<String>,
    /// Tangent-space normal map (PNG or JPEG, +Z out of the surface) on
    /// every object; HDR and EXR images are refused (they hold radiance).
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
    /// Area light centre `x,y,z` (scene units). The `--light-*` area-light
    /// flags override the scene's one `[[area_light]]`, or add one (this flag
    /// is then needed; the others default to size 1,1, orientation 0,90,0
    /// (emitting straight down), intensity 1, no texture).
    #[arg(long, allow_hyphen_values = true)]
    pub light_center: Option<String>,
    /// Area light side lengths `w,h` along its x̂ and ŷ (scene units, > 0).
    #[arg(long, allow_hyphen_values = true)]
    pub light_size: Option<String>,
    /// Area light orientation `yaw,pitch,roll` in degrees, as the scene
    /// file's `[[area_light]] rotate` (0,0,0 emits towards +Z, 0,90,0 straight
    /// down). Absolute, replacing the file's orientation (`--light-rotate`
    /// turns the environment).
    #[arg(long, allow_hyphen_values = true)]
    pub light_orientation: Option<String>,
    /// Area light radiance scale: `r,g,b` or one number (≥ 0).
    #[arg(long, allow_hyphen_values = true)]
    pub light_intensity: Option<String>,
    /// Area light radiance texture (EXR/HDR linear, PNG/JPEG sRGB), times
    /// the intensity.
    #[arg(long)]
    pub light_texture: Option<PathBuf>,
    /// Which of the scene's `[[area_light]]`s the `--light-*` flags edit,
    /// counting from 1 in file order (needed when the scene has several).
    #[arg(long)]
    pub light_index: Option<usize>,
}

impl SceneArgs {
    /// True when any `--light-*` flag that edits an area light is given
    /// (`--light-index` only says which light they edit).
    #[must_use]
    pub fn edits_area_light(&self) -> bool {
        self.light_center.is_some()
            || self.light_size.is_some()
            || self.light_orientation.is_some()
            || self.light_intensity.is_some()
            || self.light_texture.is_some()
    }
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
    /// Light sampling strategy of the reference: `mis` (light + BSDF samples,
    /// power heuristic), `light` (light samples only), `bsdf` (BSDF samples
    /// only) or `wavelet` (mis plus wavelet importance sampling of the area
    /// lights' light × BRDF product, sun-thesis §4.6.1) [default: mis].
    #[arg(long, value_name = "STRATEGY")]
    pub light_sampling: Option<String>,
    /// SH order, number of bands (sh; fog's environment part; radiance-cache
    /// records) [default: 6; shexp: 4]; nearfield: wavelet order per axis, a
    /// power of two 4…64 [default: 32].
    #[arg(long)]
    pub order: Option<usize>,
    /// Allowed error a of the radiance cache's interpolation criterion
    /// w_i(p) > 1/a, in (0, 1] (radiance-cache) [default: 0.2].
    #[arg(long)]
    pub error: Option<f32>,
    /// Per-pixel SH rotation (sh): exact, zyz, taylor1, taylor15, taylor2, none
    /// [default: zyz]; the radiance cache's aligning rotation: ignore, taylor1,
    /// taylor15, taylor2, zyz, ivanic [default: taylor15].
    #[arg(long)]
    pub rotation: Option<String>,
    /// Ringing window of each BRDF's SH transfer (sh): none, hann, lanczos,
    /// dering (Sloan 2017: least change keeping the lobe non-negative), auto
    /// (dering where a lobe would go negative) [default: auto].
    #[arg(long)]
    pub window: Option<String>,
    /// Octahedral source resolution n, N = n² (wavelet) [default: 64].
    #[arg(long)]
    pub n: Option<usize>,
    /// Normal tessellation side, ntess² sampled normals (wavelet) [default: 32].
    #[arg(long)]
    pub ntess: Option<usize>,
    /// Lighting terms kept (wavelet) [default: 256]; triple: 20, 80, 320, 1280 or
    /// 5120 [default: 320].
    #[arg(long)]
    pub terms: Option<usize>,
    /// Per-vertex ambient occlusion rays (wavelet, §3: radiance × AO; 0 = off).
    /// Renders visibility approximately (needs --approximate with --visibility).
    #[arg(long)]
    pub ao: Option<u32>,
    /// Bake cache folder (wavelet, triple, nearfield) [default: $RELIGHT_CACHE/wavelet,
    /// else ~/.cache/relight/wavelet; nearfield: $RELIGHT_CACHE/nearfield, else
    /// ~/.cache/relight/nearfield; see `relight cache list`].
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Fog model (fog): `analytic` or `opengl` (classic exponential fog)
    /// [default: analytic].
    #[arg(long)]
    pub fog: Option<String>,
    /// Visibility accumulation (shexp): ps*2, ps*4, hyb, ol (log space and
    /// that exponential) or product (products of blocker visibilities) [default: ps*2].
    #[arg(long)]
    pub exp: Option<String>,
    /// Leaf spheres per blocker object (shexp) [default: 32].
    #[arg(long)]
    pub spheres: Option<usize>,
    /// Visibility per texel of a RES × RES texture instead of per vertex:
    /// shexp shades flat receivers (a floor) at its texels instead of
    /// refining them; triple keeps every object's visibility over its uvs
    /// [default: off].
    #[arg(long, value_name = "RES")]
    pub visibility_texture: Option<usize>,
    /// How MIP texels of normal maps are shaded (ndf; sh: its filtering
    /// mode, for normal-mapped Lambertian objects): none, unnormalized,
    /// normalized, toksvig, lean, sh, vmf [default: ndf sh, sh none].
    #[arg(long)]
    pub normal_filter: Option<String>,
    /// The BRDF the ndf method's effective forms shade (ndf): lambert,
    /// blinn:S, ggx:A, beckmann:A; must match the scene's [default: lambert].
    #[arg(long)]
    pub ndf_brdf: Option<String>,
    /// vMF lobes per texel J (ndf) [default: 6].
    #[arg(long)]
    pub lobes: Option<usize>,
    /// How the vmf filter reads a pixel's texel taps (ndf): `merge` (the
    /// taps' lobes averaged slot by slot, GPU trilinear filtering, J lobes
    /// per pixel) or `mixture` (every tap's lobes kept: the exact filter,
    /// tens of lobes per pixel) [default: merge].
    #[arg(long)]
    pub vmf_taps: Option<String>,
    /// How the sh filter masks a pixel's NDF from the eye under environment
    /// light (ndf): `footprint` (one Gaussian for the footprint's NDF) or
    /// `probes` (each footprint probe's NDF masked, then averaged: nearer at
    /// grazing views, about 1.5× the frame time) [default: footprint].
    #[arg(long)]
    pub ndf_mask: Option<String>,
    /// Samples per texel side of the interpolated normal field the SH and
    /// vMF pyramids are built from (ndf): 1 (the texel normals), 2 or 4
    /// [default: 2].
    #[arg(long)]
    pub ndf_supersample: Option<usize>,
    /// Coefficient selection (triple): `top` (complete levels, per pixel)
    /// [default: top]; `adaptive` (each function's largest terms, per vertex:
    /// with `--shading vertex --twists 1`).
    #[arg(long)]
    pub select: Option<String>,
    /// Where the triple product is evaluated (triple): `pixel` (the lighting
    /// looked up in each pixel's frame), `interpolated` (the vertices'
    /// functions interpolated per pixel, §3.3) or `vertex`
    /// (Gouraud) [default: pixel].
    #[arg(long)]
    pub shading: Option<String>,
    /// Twist bins of the lighting table (triple; 1 = isotropic table rebuilt
    /// per light rotation) [default: 16].
    #[arg(long)]
    pub twists: Option<usize>,
    /// How the tables are kept (triple): f32, compact (lighting f16, BRDF and
    /// visibility 8-bit with a scale per function), or one table compact:
    /// lighting-f16, brdf-u8, visibility-u8 [default: compact].
    #[arg(long)]
    pub storage: Option<String>,
    /// Fraction of the light's wavelet terms kept, source level (nearfield)
    /// [default: 0.01].
    #[arg(long)]
    pub source_terms: Option<f64>,
    /// How the source terms are ranked (nearfield): `area-weighted`
    /// (`|F| · √support area`: coarse terms first, what a vertex's integral
    /// feels) or `magnitude` (`|F|`, the light's own L2 error)
    /// [default: area-weighted].
    #[arg(long)]
    pub source_ranking: Option<String>,
    /// Fraction of each vertex's target terms kept by the constant-light
    /// heuristic (nearfield) [default: 0.2].
    #[arg(long)]
    pub target_terms: Option<f64>,
    /// Side of the expanded top face at unit distance (nearfield; a cube
    /// map's top face is 2) [default: 4].
    #[arg(long)]
    pub face: Option<f64>,
    /// Objects whose vertices are too far apart for per-vertex visibility
    /// or light (a ground quad under a sphere): `on` shades a midpoint-refined
    /// copy and warns, `off` shades them as given and only warns (triple,
    /// nearfield, wavelet with --ao) [default: on].
    #[arg(long, value_name = "on|off")]
    pub refine_coarse: Option<String>,
    /// How the environment scatters in the fog ball (fog): `ball` (the
    /// ball's own single-scattering kernel, exact at its centre), `thesis`
    /// (sun-thesis-2008 eq. 3.30's point-source PSF) or `thesis-factorized`
    /// (its T e^{−T} NPSF, eq. 3.32) [default: ball].
    #[arg(long, value_name = "ball|thesis|thesis-factorized")]
    pub env_glow: Option<String>,
}

/// Media transport of the reference renderer.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scattering {
    /// Single scattering only (the fog model's light paths).
    Single,
    /// Full multiple-scattering transport.
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
    /// Soft shadows of dynamic blockers by SH exponentiation (sphere sets).
    Shexp,
    /// Radiance caching: reference direct light plus indirect light from
    /// rotation-aligned SH records.
    RadianceCache,
    /// Normal-map filtering: SH / vMF normal distributions per MIP texel.
    Ndf,
    /// Triple product of lighting, visibility and BRDF in spherical wavelets (local frames).
    Triple,
    /// Near-field textured area light by affine wavelet products (per vertex).
    Nearfield,
    /// Rectangular area lights by linearly transformed cosines (per pixel;
    /// shadows need --approximate and are ignored; a texture is its mean).
    Ltc,
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
    /// Pixels fully covered by objects in both images.
    Object,
    /// Pixels no object touches in either image.
    Background,
    /// Every pixel.
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
    /// Equirectangular, 2:1.
    Latlong,
    /// Six square faces.
    Cube,
    /// Octahedral map of the whole sphere.
    Octahedral,
    /// Hemi-octahedral map of the upper hemisphere.
    HemiOctahedral,
}

#[derive(Subcommand, Debug)]
pub enum ShCommand {
    /// Project an environment map onto real SH and print or write the coefficients.
    Project {
        /// Environment map to project (EXR, HDR, PNG; any parameterization).
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
    /// The SH log of cap visibility by cap angle (sun-thesis §5.2.3), zonal.
    LogTable {
        /// Number of bands n.
        #[arg(long, default_value_t = 4)]
        order: usize,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Irradiance environment map (Ramamoorthi–Hanrahan): 9 coefficients and an image.
    Irradiance {
        /// Environment map (EXR, HDR, PNG; any parameterization).
        file: PathBuf,
        /// Irradiance map image to write (lat-long).
        #[arg(long, default_value = "irradiance.png")]
        out: PathBuf,
        /// Print the 9 coefficients as JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand, Debug)]
pub enum BakeCommand {
    /// Wavelet rotation matrices (wavelet-rotation-2006 §2–3).
    Rotation {
        /// Octahedral source resolution n (a power of two; N = n² texels).
        #[arg(long, default_value_t = 64)]
        n: usize,
        /// Normal tessellation side: ntess² sampled normals, one matrix each.
        #[arg(long, default_value_t = 32)]
        ntess: usize,
        /// Truncation threshold (paper Table 1): quantized matrix entries (16-bit scale) with |q| below it are dropped; 1 keeps every non-zero, the paper uses 1–4 and shows artifacts at 128
        #[arg(long, default_value_t = 1)]
        ntrunc: u16,
        /// Target hemi-octahedral side m (default n/2).
        #[arg(long)]
        m: Option<usize>,
        /// Samples per target texel side of the area integral (1…32).
        #[arg(long, default_value_t = 8)]
        supersample: usize,
        /// Output file of the baked matrices (binary, versioned, with a CRC).
        #[arg(long)]
        out: PathBuf,
    },
    /// Wavelet BRDF slices (wavelet-rotation-2006 §3, "Precomputing BRDFs").
    Brdf {
        /// BRDF to bake, e.g. `ggx:0.2`, `phong:50`, `ward:0.1,0.3`.
        #[arg(long)]
        brdf: String,
        /// Hemi-octahedral side m of each slice (m² outgoing texels).
        #[arg(long, default_value_t = 32)]
        m: usize,
        /// View directions per side: views² slices over the hemisphere.
        #[arg(long, default_value_t = 64)]
        views: usize,
        /// Wavelet terms kept per slice (largest magnitudes).
        #[arg(long, default_value_t = 128)]
        terms: usize,
        /// Output file of the baked slices (binary, versioned, with a CRC).
        #[arg(long)]
        out: PathBuf,
    },
    /// The nearfield method's per-vertex transport (sun-thesis-2008 §4.5):
    /// baked, or loaded, into the cache `relight render --method nearfield`
    /// reads ($RELIGHT_CACHE/nearfield, else ~/.cache/relight/nearfield).
    Nearfield {
        #[command(flatten)]
        scene: Box<SceneArgs>,
        /// Wavelet order per axis, a power of two 4…64 [default: 32].
        #[arg(long)]
        order: Option<usize>,
        /// Side of the expanded top face, 0.5…32 [default: 4].
        #[arg(long)]
        face: Option<f64>,
        /// Cache folder [default: $RELIGHT_CACHE/nearfield, else
        /// ~/.cache/relight/nearfield].
        #[arg(long)]
        cache: Option<PathBuf>,
        /// Also write the bake to this file (the cache's format: versioned,
        /// with a CRC); lights in several planes write one file per plane,
        /// `.plane1`, `.plane2`, … before the extension.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

#[derive(Subcommand, Debug)]
pub enum FogCommand {
    /// Write the special-function tables F, G0, Gn as EXR images.
    Tables {
        /// Table side in texels (at least 2): SIZE × SIZE samples per table.
        #[arg(long, default_value_t = 64)]
        size: usize,
        /// Output name: one EXR per table, NAME-F.exr, NAME-G0.exr, ….
        #[arg(long, default_value = "fog-tables.exr")]
        out: PathBuf,
    },
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Suite {
    /// The viewer's frame path per method at 960×540 and 1280×720, and the later methods' rows on their own issues' scenes.
    Frames,
    /// The tiled rasterizer: G-buffer, Gouraud and per-pixel passes.
    Raster,
    /// The Monte Carlo reference renderer: rays and samples per second.
    Reference,
    /// SH rotations and the SH shading frame.
    Sh,
    /// Wavelet view and lighting changes.
    Wavelet,
    /// Analytic fog shading.
    Fog,
    /// SH exponentiation shadows: Fig. 5.5 table, thesis-like scenes, sphere fitting.
    Shexp,
    /// Radiance cache: time per aligning rotation by method (Table 1).
    RadianceCache,
    /// Normal-map filtering: bakes, frames and memory.
    Ndf,
    /// Affine Haar coefficients: sparsity, complexity, 4D table, propagation.
    Affine,
    /// Triple-product frames (Table 3) and bake/edit/rotation timings.
    Triple,
    /// Near-field relighting: Fig. 4.11's table and the bake.
    Nearfield,
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Which benchmark to run.
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
    /// Cap the vector instruction set of every run-time-selected kernel (SH,
    /// rasterizer, fog, triple, near-field, NDF, SH exponentiation) at this
    /// level, to time the paths a CPU without AVX-512 (or AVX2) takes;
    /// default: the best this CPU has. A level above the CPU's changes nothing.
    #[arg(long, value_enum, value_name = "ISA")]
    pub isa: Option<IsaArg>,
    /// `bench sh` only: the peer kit's timings (a `.jsonl` file or its runs directory); adds a table of speedups with issue 17's targets.
    #[arg(long, value_name = "PATH")]
    pub peers: Option<PathBuf>,
}

/// Vector instruction-set levels of the kernels (`relight_isa::Isa`).
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum IsaArg {
    /// The baseline target, no run-time-selected kernels.
    Portable,
    /// AVX2 with FMA and F16C.
    Avx2,
    /// AVX-512F with AVX-512VL.
    Avx512,
}

impl From<IsaArg> for relight_sh::Isa {
    fn from(a: IsaArg) -> Self {
        match a {
            IsaArg::Portable => Self::Portable,
            IsaArg::Avx2 => Self::Avx2,
            IsaArg::Avx512 => Self::Avx512,
        }
    }
}

/// Accuracy suites of `relight verify`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum VerifySuite {
    /// The reference renderer's BRDF sampling: sampled against quadrature albedo.
    Reference,
    /// SH shading and rotation against the reference.
    Sh,
    /// Wavelet shading and rotated lighting against the reference.
    Wavelet,
    /// Analytic fog against quadrature and Monte Carlo.
    Fog,
    /// Every method on a matrix of scenes against one reference.
    Methods,
    /// SH exponentiation shadows: log table, round trips, log vs product, images.
    Shexp,
    /// The radiance cache's indirect light against the GI reference.
    RadianceCache,
    /// Normal-map filtering: identities, per-level and screen accuracy.
    Ndf,
    /// Affine Haar coupling/tripling coefficients (thesis ch. 4) against overlap and quadrature.
    Affine,
    /// Triple-product identities and error against the reference.
    Triple,
    /// Near-field relighting against quadrature and the reference.
    Nearfield,
    /// Near-field relighting: only the face-coverage and per-vertex rows (no reference render).
    NearfieldVertex,
    /// Wavelet importance sampling of area lights: density, unbiasedness, variance at 8 spp.
    Importance,
    /// The LTC baseline: its fitted table, and LTC and nearfield against the reference.
    Ltc,
}

#[derive(Args, Debug)]
pub struct VerifyArgs {
    /// Which accuracy suite to run.
    #[arg(value_enum)]
    pub suite: VerifySuite,
    /// Print JSON instead of a table (the verdict summary goes to stderr).
    #[arg(long)]
    pub json: bool,
    /// Fewer scenes, orders and samples (a smoke run; looser noise).
    #[arg(long)]
    pub quick: bool,
    /// Also write an SVG plot of each table into this directory.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::Cli;
    use clap::CommandFactory;

    /// `relight view`'s help names the methods in the order the number keys
    /// select them ([`relight_viewer::ViewerOptions`]'s).
    #[test]
    fn view_help_lists_the_keys_in_the_viewers_order() {
        let cli = Cli::command();
        let about = cli
            .find_subcommand("view")
            .and_then(|v| v.get_about())
            .expect("view has an about")
            .to_string();
        let names: Vec<&str> = relight_viewer::ViewerOptions::default()
            .methods
            .iter()
            .map(|m| m.kind().name())
            .collect();
        let want = format!("keys 1-{} for {}", names.len(), names.join("/"));
        assert!(about.contains(&want), "{about:?} lacks {want:?}");
    }

    /// Every subcommand, argument and value of `relight` has help text.
    #[test]
    fn every_flag_has_help() {
        fn walk(cmd: &clap::Command, path: &str, missing: &mut Vec<String>) {
            let path = format!("{path} {}", cmd.get_name());
            if cmd.get_about().is_none() && cmd.get_long_about().is_none() {
                missing.push(format!("{path}: command without about"));
            }
            for arg in cmd.get_arguments() {
                let id = arg.get_id().as_str();
                if id == "help" || id == "version" {
                    continue;
                }
                if arg.get_help().is_none() && arg.get_long_help().is_none() {
                    missing.push(format!("{path} {id}"));
                }
                let values = if arg.get_action().takes_values() {
                    arg.get_possible_values()
                } else {
                    Vec::new()
                };
                for v in values {
                    if v.get_help().is_none() && !v.is_hide_set() {
                        missing.push(format!("{path} {id}={}", v.get_name()));
                    }
                }
            }
            for sub in cmd.get_subcommands() {
                if sub.get_name() != "help" {
                    walk(sub, &path, missing);
                }
            }
        }
        let cmd = Cli::command();
        cmd.clone().debug_assert();
        let mut missing = Vec::new();
        walk(&cmd, "", &mut missing);
        assert!(missing.is_empty(), "no help text: {missing:#?}");
    }
}
