//! [`NdfMethod`]: normal-map filtering behind the method interface
//! (`relight_render::method::Relighter`, name `ndf`).
//!
//! # What it renders
//! The unshadowed reflection of environment light (Lambert only, through
//! SH: per-vertex lighting in the tangent frame, a 9-term dot product per
//! pixel for bands 0–2, plus the bands 4–8 of the environment from the
//! representation's mean normal, `effective::lambert_tail_env`, evaluated in
//! the environment's frame) and point lights (every [`NdfBrdf`]) off normal-mapped objects,
//! each pixel shading the NDF of its MIP footprint: the level is
//! [`crate::Footprint::of`] the uv derivatives from
//! `relight_render::raster::barycentric_derivatives` (anisotropic: up to [`crate::MAX_PROBES`]
//! trilinear probes along the footprint's major axis, averaged — every
//! representation filters linearly). [`NdfFilter`] picks the representation or a baseline.
//!
//! # A row's pixels
//! Each pixel's shading has two halves: `NdfMethod::shade_prologue` (view
//! direction, footprint, the NDF sampled) and `NdfMethod::shade_epilogue`
//! (lighting). Under environment light an SH NDF also needs its view mask
//! (`crate::mask::seen_sh9`), about a third of the pixel's cost one pixel
//! at a time: a row defers those pixels to a `Batch` and takes eight
//! masks at once ([`crate::seen_lanes`], vector code, the same bits) before
//! their epilogues. With [`NdfOptions::probe_masks`] a pixel whose
//! footprint is seen in part takes one mask per footprint probe, averaged
//! (`seen_of_probes`).
//!
//! # The BRDF
//! The method shades the model of [`NdfOptions::brdf`] (the effective forms
//! need to know it); each object's colour is read from its own BRDF
//! (`f(z, z)` over the model's), and `prepare` refuses an object whose BRDF
//! is not that model times a colour (probed at 6 direction pairs, 2 %).
//!
//! # Cache
//! Pyramids are baked once per normal map (keyed by its texels) and kept in
//! memory across `prepare`s; `relight ndf bake` writes them for engines.

use crate::effective::{
    Baseline, LAMBERT_TAIL_ORDER, LambertTail, NdfBrdf, lambert_lit9, lambert_sh_dir_seen_with,
    mean_normal_matrix, mixture_sh9, shade_baseline, shade_lobe, shade_mixture,
    shade_mixture_blinn,
};
use crate::lean::{LeanPyramid, LeanTexel, shade_lean};
use crate::pyramid::{MAX_LOBES, ShadeLobe, VmfBakeOptions, VmfPyramid, unpack_fast};
use crate::{Footprint, MeanPyramid, NdfError, ShNdfPyramid};
use glam::{Mat3, Vec2, Vec3, Vec4};
use relight_render::cull::{closed_bounds, cull_for_closed};
use relight_render::method::{
    FrameRequest, MethodError, Relighter, Rendered, SceneFeature, Support,
};
use relight_render::raster::{CullMode, DrawCall, RasterOptions, Rasterizer};
use relight_render::{Image, NormalMap, Numbered, Progress, Scene};
use relight_sh::project::EnvProjection;
use relight_sh::rotation::{Rot3, ShRotation};
use relight_sphere::Frame;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

/// The method's name on the command line.
pub const NDF_METHOD_NAME: &str = "ndf";

/// How a MIP texel's normals are shaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum NdfFilter {
    /// Plain normal mapping: the level-0 normal, bilinear (aliases at distance).
    None,
    /// Baseline: the mean normal, unnormalized.
    Unnormalized,
    /// Baseline: the mean normal, renormalized.
    Normalized,
    /// Baseline: Toksvig's widened lobe.
    Toksvig,
    /// Baseline: LEAN mapping's anisotropic lobe (5 moments per texel).
    Lean,
    /// The SH NDF (eq. 5.7; Lambert only).
    Sh,
    /// The vMF mixture.
    Vmf,
}

impl NdfFilter {
    /// Every filter, in a fixed order.
    pub const ALL: [NdfFilter; 7] = [
        Self::None,
        Self::Unnormalized,
        Self::Normalized,
        Self::Toksvig,
        Self::Lean,
        Self::Sh,
        Self::Vmf,
    ];

    /// The flag value.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Unnormalized => "unnormalized",
            Self::Normalized => "normalized",
            Self::Toksvig => "toksvig",
            Self::Lean => "lean",
            Self::Sh => "sh",
            Self::Vmf => "vmf",
        }
    }

    /// The next filter after this one in [`Self::ALL`] (cyclically) that
    /// `brdf` can use (`sh` is Lambert only): the viewer's key.
    #[must_use]
    pub fn next_for(self, brdf: NdfBrdf) -> Self {
        let at = Self::ALL.iter().position(|f| *f == self).unwrap_or(0);
        (1..=Self::ALL.len())
            .map(|k| Self::ALL[(at + k) % Self::ALL.len()])
            .find(|f| *f != Self::Sh || brdf == NdfBrdf::Lambert)
            .unwrap_or(self)
    }

    /// Parses a flag value.
    ///
    /// # Errors
    /// An unknown name, listing the known ones.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|f| f.name()).collect();
                format!("unknown normal filter `{s}` (known: {})", names.join(", "))
            })
    }
}

/// Settings of [`NdfMethod`]; `Default` holds the defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NdfOptions {
    /// Default [`NdfFilter::Sh`] for Lambert; glossy BRDFs need `vmf` or a baseline.
    pub filter: NdfFilter,
    /// Default Lambert.
    pub brdf: NdfBrdf,
    /// SH NDF bands (3..=8). Default 3 (Lambert needs 9 coefficients).
    pub order: usize,
    /// The vMF bake (lobes J, EM stopping rules).
    pub vmf: VmfBakeOptions,
    /// Samples per texel side of the interpolated normal field the SH and
    /// vMF pyramids are built from ([`crate::field`]): 1 builds them from
    /// the texel normals (level 0 a delta per texel), 2 or 4 from the
    /// bilinearly interpolated, renormalised normals that plain normal
    /// mapping and the reference shade. Default 2.
    pub supersample: usize,
    /// How a pixel's vMF lobes come from its footprint's texel taps (the
    /// vmf filter's; the other filters do not read it, so that a viewer
    /// cycling filters keeps it). Default [`VmfTaps::Merge`].
    pub vmf_taps: VmfTaps,
    /// The sh filter's quality mode under environment light: the view mask
    /// taken for each of the footprint's probes ([`crate::Footprint`]) and
    /// averaged, instead of once for their mean NDF. One Gaussian for a
    /// wide footprint's NDF sees too much of it from a grazing eye; per
    /// probe the NDFs are narrower (`docs/ndf.md`, "Masking each probe":
    /// the horizon plane under the sky 0.064 → 0.049 relative RMS, its
    /// frame about 1.5× as long). Default off.
    pub probe_masks: bool,
}

impl Default for NdfOptions {
    fn default() -> Self {
        Self {
            filter: NdfFilter::Sh,
            brdf: NdfBrdf::Lambert,
            order: 3,
            vmf: VmfBakeOptions::default(),
            supersample: 2,
            vmf_taps: VmfTaps::Merge,
            probe_masks: false,
        }
    }
}

/// How the vMF representation filters a pixel's footprint: the texel taps
/// (bilinear per probe, two levels, up to [`crate::MAX_PROBES`] probes) and
/// their `J` lobes each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VmfTaps {
    /// The taps' packed lobes averaged slot by slot: the moment-matching
    /// merge ([`crate::pyramid`]), what GPU trilinear filtering of the
    /// stored lobe textures computes. `J` lobes per pixel. Merging two
    /// narrow lobes of different axes gives one broad lobe, which blurs a
    /// sharp highlight (the error measured in `docs/ndf.md`).
    Merge,
    /// Every tap's lobes kept, each weighted by its tap: the pixel's NDF is
    /// the exact trilinear filter of the texels' mixtures, and since the
    /// shading is linear in the NDF, so is the pixel's colour. Up to
    /// `2 × 16 × J` lobes per pixel (tens on average): a quality mode, not
    /// a real-time one.
    Mixture,
}

impl VmfTaps {
    /// Both, in a fixed order.
    pub const ALL: [Self; 2] = [Self::Merge, Self::Mixture];

    /// The name on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Merge => "merge",
            Self::Mixture => "mixture",
        }
    }
}

impl std::str::FromStr for VmfTaps {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("`{s}`: expected merge or mixture"))
    }
}

/// The most lobes one pixel's vMF NDF holds: [`VmfTaps::Mixture`]'s every
/// tap's `J` lobes, and plain normal mapping's delta.
const MAX_PIXEL_LOBES: usize = 2 * crate::MAX_LEVEL_TAPS * MAX_LOBES + 1;

/// The baked pyramids of one normal map.
#[derive(Debug)]
pub struct Baked {
    /// Level 0's size of the active filter's pyramid, the texels the uv
    /// footprint is measured in: the map's times
    /// [`NdfOptions::supersample`] for SH and vMF, the map's for the
    /// baselines.
    pub width: usize,
    pub height: usize,
    pub sh: Option<ShNdfPyramid>,
    pub vmf: Option<VmfPyramid>,
    pub lean: Option<LeanPyramid>,
    pub mean: MeanPyramid,
}

impl Baked {
    /// Bakes what `filter` needs.
    #[must_use]
    pub fn bake(map: &NormalMap, options: &NdfOptions) -> Self {
        let (w, h) = (map.width, map.height);
        // Our representations are built from the interpolated field at s×
        // the map's resolution ([`crate::field`]); the baselines from the
        // texels, as engines filter them.
        let s = match options.filter {
            NdfFilter::Sh | NdfFilter::Vmf => options.supersample,
            _ => 1,
        };
        let field = || crate::field::interpolated_field(map, s);
        Self {
            width: w * s,
            height: h * s,
            sh: (options.filter == NdfFilter::Sh)
                .then(|| ShNdfPyramid::build(w * s, h * s, &field(), options.order)),
            vmf: (options.filter == NdfFilter::Vmf)
                .then(|| VmfPyramid::build(w * s, h * s, &field(), &options.vmf)),
            lean: (options.filter == NdfFilter::Lean)
                .then(|| LeanPyramid::build(w, h, &map.texels)),
            mean: MeanPyramid::build(w, h, &map.texels),
        }
    }

    fn bytes(&self) -> u64 {
        self.sh.as_ref().map_or(0, ShNdfPyramid::bytes)
            + self.vmf.as_ref().map_or(0, VmfPyramid::bytes)
            + self.lean.as_ref().map_or(0, LeanPyramid::bytes)
            + self
                .mean
                .levels
                .iter()
                .map(|l| l.2.len() as u64 * 12)
                .sum::<u64>()
    }
}

/// Per-object data of a prepared scene.
struct ObjectData {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    normals: Vec<Vec3>,
    tangents: Vec<Vec4>,
    uvs: Vec<Vec2>,
    colour: Vec3,
    map: Option<(Arc<NormalMap>, Arc<Baked>)>,
    /// 27 floats per vertex: the 9 SH lighting coefficients per channel in
    /// the vertex frame `Frame::from_normal_tangent(n, t)`.
    light: Vec<f32>,
    /// The bounds of a closed, outward-oriented mesh, whose back faces the
    /// raster culls from outside them ([`relight_render::cull`]); `None`
    /// for an open mesh.
    closed: Option<relight_geom::Aabb>,
}

/// The `ndf` method (module docs).
pub struct NdfMethod {
    options: NdfOptions,
    cache: HashMap<u64, Arc<Baked>>,
    objects: Vec<ObjectData>,
    raster: Rasterizer,
    pending_lighting_ms: f64,
    /// Whether a flat triangle's frame and lighting are taken once per
    /// triangle ([`TriangleConsts::flat`]); off only in the test that
    /// compares the two.
    flat_triangles: bool,
    /// Whether SH NDF pixels under environment light take their view masks
    /// eight at a time ([`crate::seen_lanes`]); off only in the test that
    /// compares the two.
    masks_in_lanes: bool,
    /// Whether rows may take the AVX2+FMA copy of the pixel loop
    /// ([`NdfMethod::render_row`]); off only in the test that compares the
    /// two.
    simd: bool,
    /// The environment's SH to [`LAMBERT_TAIL_ORDER`] bands per channel, in
    /// the environment's frame, prepared: the Lambert tail's lighting.
    env_tail: LambertTail,
    /// The environment's projection, kept by its texels: a lighting change
    /// that turns it (`world_from_env`) projects nothing again.
    env_projection: EnvProjection,
    /// The fingerprint of the map `env_tail` was prepared from (`None`:
    /// none, the default tail of a scene without environment).
    env_tail_for: Option<u64>,
    /// `world_from_env` inverted (a rotation).
    env_from_world: Mat3,
    /// Blinn–Phong's normalization for [`NdfOptions::brdf`] (0 for other
    /// models), once instead of per pixel.
    blinn_norm: f32,
}

fn invalid(option: &'static str, message: String) -> MethodError {
    MethodError::InvalidOption {
        method: NDF_METHOD_NAME,
        option,
        message,
    }
}

/// A 64-bit fingerprint of a normal map's texels (FNV-1a over the bits).
fn fingerprint(m: &NormalMap) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64 ^ (m.width as u64) << 32 ^ m.height as u64;
    for t in &m.texels {
        for v in t.to_array() {
            h = (h ^ u64::from(v.to_bits())).wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// The colour of `brdf` as `model × colour`, or why it is not (probed at
/// six direction pairs, 2 %): the test `prepare` makes of every object, and
/// the SH method's filter mode of the objects it can filter.
///
/// # Errors
/// Why the BRDF is not the model times a colour, one line.
pub fn colour_of(brdf: &dyn relight_brdf::Brdf, model: NdfBrdf) -> Result<Vec3, String> {
    let z = Vec3::Z;
    let base = shade_lobe(model, z, 0.0, z, z);
    let c = brdf.eval(z, z) * z.z / base;
    let probes = [
        (Vec3::new(0.3, 0.1, 0.95), Vec3::new(-0.2, 0.25, 0.95)),
        (Vec3::new(0.0, 0.5, 0.87), Vec3::new(0.0, -0.45, 0.89)),
        (Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.58, 0.05, 0.81)),
        (Vec3::new(0.1, 0.1, 0.99), Vec3::new(0.7, 0.0, 0.71)),
        (Vec3::new(0.5, 0.5, 0.71), Vec3::new(0.2, -0.3, 0.93)),
    ];
    for (wo, wi) in probes {
        let (wo, wi) = (wo.normalize(), wi.normalize());
        let want = c * shade_lobe(model, z, 0.0, wo, wi);
        let got = brdf.eval(wo, wi) * wi.z;
        let scale = want.max_element().max(got.max_element()).max(1e-6);
        if (want - got).abs().max_element() > 0.02 * scale {
            return Err(format!(
                "its BRDF {} is not {} times a colour; pass the --ndf-brdf (lambert, blinn:S, ggx:A, beckmann:A) that matches it",
                brdf.label(),
                model.label()
            ));
        }
    }
    Ok(c)
}

impl NdfMethod {
    /// A method with `options`.
    ///
    /// # Errors
    /// An out-of-range order or lobe count, or a filter the BRDF cannot use.
    pub fn new(options: NdfOptions) -> Result<Self, MethodError> {
        if !(3..=8).contains(&options.order) {
            return Err(invalid(
                "order",
                format!("must be 3…8 SH bands (got {})", options.order),
            ));
        }
        if !(1..=MAX_LOBES).contains(&options.vmf.lobes) {
            return Err(invalid(
                "lobes",
                format!("must be 1…{MAX_LOBES} (got {})", options.vmf.lobes),
            ));
        }
        if ![1, 2, 4].contains(&options.supersample) {
            return Err(invalid(
                "supersample",
                format!("must be 1, 2 or 4 (got {})", options.supersample),
            ));
        }
        if options.filter == NdfFilter::Sh && options.brdf != NdfBrdf::Lambert {
            return Err(invalid(
                "normal-filter",
                format!(
                    "sh filters Lambert only ({} needs ~2√s bands; use vmf)",
                    options.brdf.label()
                ),
            ));
        }
        Ok(Self {
            options,
            cache: HashMap::new(),
            objects: Vec::new(),
            raster: Rasterizer::new(),
            pending_lighting_ms: 0.0,
            flat_triangles: true,
            masks_in_lanes: true,
            simd: true,
            env_tail: LambertTail::default(),
            env_projection: EnvProjection::default(),
            env_tail_for: None,
            env_from_world: Mat3::IDENTITY,
            blinn_norm: match options.brdf {
                NdfBrdf::Blinn { s } => relight_brdf::phong::blinn_phong_normalization(s),
                _ => 0.0,
            },
        })
    }

    /// Object `i`'s colour under the options' BRDF model, or why its BRDF
    /// is not that model times a colour.
    fn object_colour(&self, i: usize, ob: &relight_render::Object) -> Result<Vec3, MethodError> {
        colour_of(ob.brdf.as_ref(), self.options.brdf)
            .map_err(|e| invalid("ndf-brdf", format!("{}: {e}", Numbered::object(i))))
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &NdfOptions {
        &self.options
    }

    /// Changes how the vmf filter reads its taps, from the next frame on
    /// (the pyramids do not depend on it: no re-bake).
    pub fn set_vmf_taps(&mut self, taps: VmfTaps) {
        self.options.vmf_taps = taps;
    }

    /// The pyramids baked for `map` with this method's options (from the
    /// in-memory cache when baked before).
    pub fn baked(&mut self, map: &NormalMap) -> Arc<Baked> {
        let key = fingerprint(map);
        self.cache
            .entry(key)
            .or_insert_with(|| Arc::new(Baked::bake(map, &self.options)))
            .clone()
    }

    /// Shading one visible point (everything in the tangent frame), first
    /// half: its view direction and representation, its footprint's
    /// NDF (an SH NDF's bands, or vMF lobes into `lobes`) and plain normal
    /// mapping's share; `None` for a point seen from behind (black).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn shade_prologue(
        &self,
        o: &ObjectData,
        position: Vec3,
        eye: Vec3,
        frame: &Frame,
        hand: f32,
        uv: Vec2,
        fp: &Footprint,
        lobes: &mut [ShadeLobe; MAX_PIXEL_LOBES],
        out: &mut Prologue,
    ) -> bool {
        let to_t = |v: Vec3| Vec3::new(v.dot(frame.x), hand * v.dot(frame.y), v.dot(frame.z));
        let wo = to_t((eye - position).normalize_or_zero());
        if wo.z <= 0.0 {
            return false;
        }
        // J lobes (or every tap's, `VmfTaps::Mixture`) and a delta for plain
        // normal mapping's share, in the caller's scratch.
        let mut nl = 0;
        // Lambert reads bands 0–2 of the SH NDF, whatever its order.
        let gamma = &mut out.gamma;
        out.probes = 0;
        // Plain normal mapping's share (`Footprint::plain`), for our
        // representations (the baselines filter as engines do), mixed into
        // the pixel's NDF: `(1 − w)·NDF_pyramid + w·δ(n)` — SH coefficients
        // blend linearly, and the vMF mixture gains a delta lobe.
        let plain = match (&o.map, self.options.filter) {
            (Some((m, _)), NdfFilter::Sh | NdfFilter::Vmf) if fp.plain > 0.0 => {
                Some((m.sample(uv), fp.plain))
            }
            _ => None,
        };
        let rep = match (&o.map, self.options.filter) {
            (None, _) => Rep::Normal(Vec3::Z),
            (Some((m, _)), NdfFilter::None) => Rep::Normal(m.sample(uv)),
            (Some(_), _) if plain.is_some_and(|(_, w)| w >= 1.0) => {
                Rep::Normal(plain.map_or(Vec3::Z, |(n, _)| n))
            }
            (Some((_, b)), NdfFilter::Sh) => {
                // The footprint's NDF (linear: the probes' mean), and with
                // `probe_masks` each probe's, which the environment's view
                // mask takes one by one (it is not linear in the NDF).
                match &b.sh {
                    Some(sh) if self.options.probe_masks => {
                        sh.sample_probes9(fp, &mut out.probe_gamma);
                        out.probes = fp.count;
                        let inv_n = 1.0 / out.probes as f32;
                        *gamma = [0.0; 9];
                        for pg in &out.probe_gamma[..out.probes] {
                            for (g, v) in gamma.iter_mut().zip(pg) {
                                *g += v * inv_n;
                            }
                        }
                    }
                    Some(sh) if sh.order == 3 => sh.sample_footprint(fp, gamma),
                    Some(sh) => {
                        let mut all = [0.0f32; 64];
                        sh.sample_footprint(fp, &mut all);
                        gamma.copy_from_slice(&all[..9]);
                    }
                    None => *gamma = [0.0; 9],
                }
                // Plain normal mapping's share stays apart: the view masks
                // below take the NDF's moments, and a delta mixed into them
                // would be masked as part of one Gaussian.
                Rep::Sh
            }
            (Some((_, b)), NdfFilter::Vmf) => {
                let mut packed = [Vec4::ZERO; MAX_LOBES];
                match (&b.vmf, self.options.vmf_taps) {
                    (Some(v), VmfTaps::Merge) => {
                        // Packed moments filter linearly (moment-matching merge).
                        v.sample_footprint_on(fp, &mut packed, self.simd);
                        for p in &packed[..v.lobes] {
                            if let Some(l) = unpack_fast(*p) {
                                lobes[nl] = l;
                                nl += 1;
                            }
                        }
                    }
                    (Some(v), VmfTaps::Mixture) => {
                        // Every tap's lobes, weighted by the tap: the
                        // mixture of the texels' mixtures.
                        let taps =
                            fp.taps(v.levels.len(), |k| (v.levels[k].width, v.levels[k].height));
                        for j in 0..taps.count {
                            let level = &v.levels[taps.levels[j]];
                            for (i, w) in taps.level(j) {
                                for p in &level.lobes[i * v.lobes..(i + 1) * v.lobes] {
                                    if let Some(l) = unpack_fast(*p * w) {
                                        lobes[nl] = l;
                                        nl += 1;
                                    }
                                }
                            }
                        }
                    }
                    (None, _) => {}
                }
                if let Some((n, w)) = plain {
                    for l in &mut lobes[..nl] {
                        l.alpha *= 1.0 - w;
                    }
                    lobes[nl] = ShadeLobe {
                        alpha: w,
                        mu: n,
                        inv_kappa: 0.0,
                    };
                    nl += 1;
                }
                Rep::Vmf
            }
            (Some((_, b)), NdfFilter::Lean) => Rep::Lean(
                b.lean
                    .as_ref()
                    .map_or_else(|| LeanTexel::of_normal(Vec3::Z), |l| l.sample_footprint(fp)),
            ),
            (Some((_, b)), _) => Rep::Mean(b.mean.sample_footprint(fp)),
        };
        out.wo = wo;
        out.plain = plain;
        out.rep = rep;
        out.nl = nl;
        true
    }

    /// The radiance of a [`Self::shade_prologue`]: environment light
    /// (Lambert) and point lights, times the object's colour. `seen` holds
    /// an SH NDF's environment view mask when the caller took it for
    /// several pixels at once ([`crate::seen_lanes`]); else it is taken
    /// here ([`seen_of_probes`]), the same f32 operations.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn shade_epilogue(
        &self,
        o: &ObjectData,
        position: Vec3,
        frame: &Frame,
        hand: f32,
        p: &Prologue,
        env: &PixelEnv,
        scene: &Scene,
        has_env: bool,
        lobes: &[ShadeLobe; MAX_PIXEL_LOBES],
        seen: Option<&ShSeen>,
    ) -> Vec3 {
        let Prologue {
            wo,
            plain,
            ref rep,
            ref gamma,
            nl,
            ..
        } = *p;
        let to_t = |v: Vec3| Vec3::new(v.dot(frame.x), hand * v.dot(frame.y), v.dot(frame.z));
        let brdf = self.options.brdf;
        let baseline = match self.options.filter {
            NdfFilter::Unnormalized => Baseline::Unnormalized,
            NdfFilter::Toksvig => Baseline::Toksvig,
            _ => Baseline::Normalized,
        };
        // An SH NDF's moments: the point lights' masks read the footprint's.
        let moments = match rep {
            Rep::Sh if !scene.point_lights.is_empty() => crate::mask::ShMoments::of_sh(gamma),
            _ => crate::mask::ShMoments {
                mean: Vec3::Z,
                cov: [0.0; 6],
            },
        };
        let mut out = Vec3::ZERO;
        if has_env && brdf == NdfBrdf::Lambert {
            // Bands 0–2: `Σ_i c_i lit_i` per channel, `c` the representation's
            // SH (γ, or the SH of its normal) restricted to the normals that
            // face the viewer (the reference's convention: a normal turned
            // away shades zero), `lit` the lighting with `Λ_l/π` folded in
            // ([`PixelEnv`]). A single normal is masked by its step; an
            // NDF by [`crate::mask::seen_sh9`] (per lobe for a mixture),
            // whose seen share also scales the tail.
            let mut y = [0.0f32; 9];
            let facing = |n: Vec3| if n.dot(wo) > 0.0 { 1.0 } else { 0.0 };
            let tail = |t: Vec3| self.env_tail.eval(env.env_from_tangent * t);
            // `y` takes `c`; the arms give the step that gates it (1 for an
            // NDF, already masked) and bands 4–8 (`lambert_tail_env`, in
            // the environment's frame) of what the viewer sees.
            let (seen, tail_sum) = match rep {
                Rep::Normal(n) => {
                    relight_sh::eval_sh_into(3, n.to_array(), &mut y);
                    let h = facing(*n);
                    (h, h * tail(*n))
                }
                Rep::Mean(m) => {
                    let n = m.normalize_or(Vec3::Z);
                    let (c, t) = match baseline {
                        Baseline::Unnormalized => (*m, m.length() * tail(n)),
                        _ => (n, tail(n)),
                    };
                    relight_sh::eval_sh_into(3, c.to_array(), &mut y);
                    let h = facing(*m);
                    (h, h * t)
                }
                Rep::Lean(t) => {
                    let n = t.normal();
                    relight_sh::eval_sh_into(3, n.to_array(), &mut y);
                    let h = facing(n);
                    (h, h * tail(n))
                }
                // An SH NDF: its seen part (`seen_sh9`), and the tail at that
                // part's mean normal (its band 1 over its share, rotated with
                // `mean_normal_of_sh` as one matrix) times the share; plain
                // normal mapping's share `w` is a delta with its own step.
                Rep::Sh => {
                    let share;
                    (y, share) = match seen {
                        Some(s) => (s.y, s.share),
                        None => seen_of_probes(p, wo),
                    };
                    let mut t = if share > 0.0 {
                        share
                            * self
                                .env_tail
                                .eval(env.env_from_sh1 * (Vec3::new(y[1], y[2], y[3]) / share))
                    } else {
                        Vec3::ZERO
                    };
                    if let Some((n, w)) = plain {
                        let h = facing(n);
                        let mut yn = [0.0f32; 9];
                        relight_sh::eval_sh_into(3, n.to_array(), &mut yn);
                        for (c, yn) in y.iter_mut().zip(yn) {
                            *c = *c * (1.0 - w) + h * w * yn;
                        }
                        t = t * (1.0 - w) + h * w * tail(n);
                    }
                    (1.0, t)
                }
                // A mixture: each lobe's seen part, the lobe narrower than
                // the mixture, so each is nearer the Gaussian the mask
                // assumes; the delta of plain normal mapping gets its step.
                Rep::Vmf => {
                    let mut t = Vec3::ZERO;
                    for l in &lobes[..nl] {
                        let one = ShadeLobe { alpha: 1.0, ..*l };
                        let (yl, share) = crate::mask::seen_sh9(&mixture_sh9(&[one]), wo);
                        for (c, yl) in y.iter_mut().zip(yl) {
                            *c += l.alpha * yl;
                        }
                        t += (l.alpha * share) * tail(l.mean_normal());
                    }
                    (1.0, t)
                }
            };
            if seen > 0.0 {
                for c in 0..3 {
                    out[c] += dot9(&y, &env.lit[c * 9..c * 9 + 9]);
                }
            }
            out += tail_sum;
        }
        for pl in &scene.point_lights {
            let d = pl.position - position;
            let r2 = d.length_squared();
            if r2 <= 0.0 {
                continue;
            }
            let wi = to_t(d / r2.sqrt());
            // `f·cos θ_i` of the representation, written out here rather than
            // as a closure: a closure was not inlined, and its body (the
            // whole Blinn lobe loop) was then compiled for the baseline
            // target instead of the AVX2 copy of the pixel loop.
            let fcos = match rep {
                Rep::Normal(n) => shade_lobe(brdf, *n, 0.0, wo, wi),
                Rep::Mean(m) => shade_baseline(brdf, baseline, *m, wo, wi),
                Rep::Sh => {
                    let f = lambert_sh_dir_seen_with(gamma, &moments, wo, wi);
                    match plain {
                        Some((n, w)) => {
                            f * (1.0 - w) + w * shade_lobe(NdfBrdf::Lambert, n, 0.0, wo, wi)
                        }
                        None => f,
                    }
                }
                Rep::Vmf => match brdf {
                    NdfBrdf::Blinn { s } => {
                        shade_mixture_blinn(s, self.blinn_norm, &lobes[..nl], wo, wi)
                    }
                    _ => shade_mixture(brdf, &lobes[..nl], wo, wi),
                },
                Rep::Lean(t) => shade_lean(brdf, t, wo, wi),
            };
            out += pl.intensity / r2 * fcos;
        }
        out * o.colour
    }

    /// One row of pixels: the body of [`Self::render`]'s loop, inlined into
    /// [`Self::render_row`]'s portable and AVX2+FMA copies.
    #[inline(always)]
    fn row_body(&self, ctx: &RowCtx<'_>, y: usize, row: &mut [Vec3]) {
        // The last triangle's constants (a row crosses few).
        let mut cached: Option<TriangleConsts> = None;
        // The pixels' vMF lobes, one scratch per row.
        let mut lobes = [ShadeLobe {
            alpha: 0.0,
            mu: Vec3::Z,
            inv_kappa: 0.0,
        }; MAX_PIXEL_LOBES];
        // SH NDF pixels under environment light leave their view masks to
        // a batch of `seen_lanes::LANES` (the costliest part of their
        // shading, vectorized across pixels), finished when it fills.
        let batching = self.masks_in_lanes
            && ctx.has_env
            && self.options.filter == NdfFilter::Sh
            && self.options.brdf == NdfBrdf::Lambert;
        let tables = crate::seen_lanes::SeenTables::get();
        let mut batch = Batch::new();
        for x in 0..row.len() {
            let Some((d, tri, lam)) = ctx.raster.barycentrics_at(ctx.draws, x, y) else {
                continue;
            };
            let o = &self.objects[d];
            let [i0, i1, i2] = o.triangles[tri].map(|i| i as usize);
            let tc = match &cached {
                Some(tc) if tc.draw == d && tc.tri == tri => tc,
                _ => cached.insert(TriangleConsts::new(
                    ctx.basis,
                    ctx.eye,
                    o,
                    d,
                    tri,
                    self.flat_triangles,
                    &self.env_from_world,
                )),
            };
            let mix3 = |a: Vec3, b: Vec3, c: Vec3| a * lam.x + b * lam.y + c * lam.z;
            let position = mix3(o.positions[i0], o.positions[i1], o.positions[i2]);
            let uv = o.uvs[i0] * lam.x + o.uvs[i1] * lam.y + o.uvs[i2] * lam.z;
            let (frame, hand) = match &tc.flat {
                Some(f) => (f.frame, f.hand),
                None => {
                    let n = mix3(o.normals[i0], o.normals[i1], o.normals[i2]).normalize_or(Vec3::Z);
                    let tg =
                        o.tangents[i0] * lam.x + o.tangents[i1] * lam.y + o.tangents[i2] * lam.z;
                    (
                        Frame::from_normal_tangent(n, tg.truncate()),
                        if tg.w < 0.0 { -1.0 } else { 1.0 },
                    )
                }
            };
            let fp = match (&o.map, &tc.lod) {
                // A `match`, not `map_or`: the generic `map_or` was not
                // inlined, which kept `Footprint::of` out of the AVX2 copy.
                (Some((_, b)), Some(tl)) => match tl.duv(ctx.basis, x as f32 + 0.5, y as f32 + 0.5)
                {
                    Some([dx, dy]) => Footprint::of(uv, dx, dy, b.width, b.height),
                    None => Footprint::point(uv, 0.0),
                },
                _ => Footprint::point(uv, 0.0),
            };
            let pixel_env;
            let env = match &tc.flat {
                // One normal and tangent: the three vertices'
                // lighting is the same (λ sums to 1 within an ulp),
                // prepared once per triangle.
                Some(f) => &f.env,
                None => {
                    let mut light = [0.0f32; 27];
                    let (l0, l1, l2) = (
                        &o.light[i0 * 27..i0 * 27 + 27],
                        &o.light[i1 * 27..i1 * 27 + 27],
                        &o.light[i2 * 27..i2 * 27 + 27],
                    );
                    for j in 0..27 {
                        light[j] = l0[j] * lam.x + l1[j] * lam.y + l2[j] * lam.z;
                    }
                    pixel_env = PixelEnv::new(&light, &frame, hand, &self.env_from_world);
                    &pixel_env
                }
            };
            // The prologue goes straight into the batch's next slot (a
            // copy of it cost a store-forwarding stall per pixel); it is
            // kept there only if deferred.
            let slot = &mut batch.slots[batch.n];
            if !self.shade_prologue(
                o,
                position,
                ctx.eye,
                &frame,
                hand,
                uv,
                &fp,
                &mut lobes,
                &mut slot.p,
            ) {
                row[x] = Vec3::ZERO;
                continue;
            }
            if batching && matches!(slot.p.rep, Rep::Sh) {
                slot.x = x;
                slot.object = d;
                slot.position = position;
                slot.frame = frame;
                slot.hand = hand;
                batch.commit(env, tc.flat.is_some().then_some((d, tri)));
                if batch.n == crate::seen_lanes::LANES {
                    self.finish_batch(&mut batch, &tables, ctx, row, &lobes);
                }
            } else {
                row[x] = self.shade_epilogue(
                    o,
                    position,
                    &frame,
                    hand,
                    &slot.p,
                    env,
                    ctx.scene,
                    ctx.has_env,
                    &lobes,
                    None,
                );
            }
        }
        self.finish_batch(&mut batch, &tables, ctx, row, &lobes);
    }

    /// Shades a [`Batch`]'s pixels into `row`: their moments and view
    /// masks in lanes ([`crate::seen_lanes`]), then each one's
    /// [`Self::shade_epilogue`]; empties it.
    #[inline(always)]
    fn finish_batch(
        &self,
        batch: &mut Batch,
        tables: &crate::seen_lanes::SeenTables,
        ctx: &RowCtx<'_>,
        row: &mut [Vec3],
        lobes: &[ShadeLobe; MAX_PIXEL_LOBES],
    ) {
        use crate::seen_lanes::LANES;
        if batch.n == 0 {
            return;
        }
        // One lane per pixel, one plane per probe: plane `j` holds each
        // pixel's probe `j` (with `probe_masks`; else plane 0 holds the
        // footprint's NDF). Lanes past a pixel's probes keep γ = 0 (a
        // delta's branch) and are not read.
        const PLANES: usize = crate::MAX_PROBES;
        let mut gamma = [[[0.0; LANES]; 9]; PLANES];
        let mut wo = [[0.0; LANES]; 3];
        let mut probes = [0usize; LANES];
        let mut planes = 1;
        for (l, d) in batch.slots[..batch.n].iter().enumerate() {
            for (w, v) in wo.iter_mut().zip(d.p.wo.to_array()) {
                w[l] = v;
            }
            probes[l] = d.p.probes;
            if d.p.probes == 0 {
                for (g, v) in gamma[0].iter_mut().zip(d.p.gamma) {
                    g[l] = v;
                }
                continue;
            }
            planes = planes.max(d.p.probes);
            for (plane, pg) in gamma.iter_mut().zip(&d.p.probe_gamma[..d.p.probes]) {
                for (g, v) in plane.iter_mut().zip(pg) {
                    g[l] = *v;
                }
            }
        }
        let mut e_pixel = [[0.0; LANES]; 9];
        let mut share_pixel = [0.0; LANES];
        if !self.options.probe_masks {
            crate::seen_lanes::seen_moments_lanes(
                tables,
                &gamma[0],
                &wo,
                &mut e_pixel,
                &mut share_pixel,
            );
        } else {
            // Each pixel's probes' mean, in `seen_of_probes`' order: a
            // plane past a pixel's probes leaves its sums as they are.
            let mut inv_n = [0.0f32; LANES];
            for (v, n) in inv_n.iter_mut().zip(probes) {
                *v = 1.0 / n.max(1) as f32;
            }
            let mut e = [[0.0; LANES]; 9];
            let mut share = [0.0; LANES];
            for (j, plane) in gamma.iter().enumerate().take(planes) {
                crate::seen_lanes::seen_moments_lanes(tables, plane, &wo, &mut e, &mut share);
                for (ep, ej) in e_pixel.iter_mut().zip(&e) {
                    for l in 0..LANES {
                        let sum = ep[l] + ej[l] * inv_n[l];
                        ep[l] = if j < probes[l] { sum } else { ep[l] };
                    }
                }
                for l in 0..LANES {
                    let sum = share_pixel[l] + share[l] * inv_n[l];
                    share_pixel[l] = if j < probes[l] { sum } else { share_pixel[l] };
                }
            }
        }
        let mut y = [[0.0; LANES]; 9];
        crate::seen_lanes::sh9_of_seen_moments_lanes(tables, &e_pixel, &mut y);
        for (l, d) in batch.slots[..batch.n].iter().enumerate() {
            let mut seen = ShSeen {
                y: [0.0; 9],
                share: share_pixel[l],
            };
            for (s, v) in seen.y.iter_mut().zip(&y) {
                *s = v[l];
            }
            row[d.x] = self.shade_epilogue(
                &self.objects[d.object],
                d.position,
                &d.frame,
                d.hand,
                &d.p,
                &batch.envs[d.env],
                ctx.scene,
                ctx.has_env,
                lobes,
                Some(&seen),
            );
        }
        batch.n = 0;
        batch.n_envs = 0;
        batch.last_flat = None;
    }

    /// [`Self::row_body`], compiled for the CPU it runs on: an AVX2+FMA copy
    /// (VEX 3-operand code, `roundss` for floors) where the CPU has them,
    /// else the baseline x86-64 copy. Rust does not contract `a * b + c`
    /// into an FMA, so both copies compute the same f32 operations: the
    /// same image bit for bit (tested).
    fn render_row(&self, ctx: &RowCtx<'_>, y: usize, row: &mut [Vec3]) {
        #[cfg(target_arch = "x86_64")]
        if self.simd && relight_isa::avx2() {
            // SAFETY: the CPU has AVX2 and FMA (checked above).
            unsafe { self.row_avx2(ctx, y, row) };
            return;
        }
        self.row_body(ctx, y, row);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn row_avx2(&self, ctx: &RowCtx<'_>, y: usize, row: &mut [Vec3]) {
        self.row_body(ctx, y, row);
    }
}

/// A pixel's representation ([`NdfMethod::shade_prologue`]).
#[derive(Clone, Copy)]
enum Rep {
    Normal(Vec3),
    Mean(Vec3),
    /// An SH NDF, its bands 0–2 in [`Prologue::gamma`].
    Sh,
    /// A vMF mixture, its lobes in the caller's scratch.
    Vmf,
    Lean(LeanTexel),
}

/// What [`NdfMethod::shade_prologue`] hands [`NdfMethod::shade_epilogue`].
#[derive(Clone, Copy)]
struct Prologue {
    /// The view direction, tangent frame.
    wo: Vec3,
    /// Plain normal mapping's normal and share (`Footprint::plain`).
    plain: Option<(Vec3, f32)>,
    rep: Rep,
    /// [`Rep::Sh`]'s bands 0–2: the mean of its probes'.
    gamma: [f32; 9],
    /// [`Rep::Sh`]'s probes' bands 0–2 (`Footprint::probes`), each its own
    /// NDF, `probes` of them: with [`NdfOptions::probe_masks`] only (else
    /// `probes` is 0 and the footprint's NDF is `gamma` alone).
    probe_gamma: [[f32; 9]; crate::MAX_PROBES],
    probes: usize,
    /// [`Rep::Vmf`]'s lobe count.
    nl: usize,
}

/// An SH NDF's environment view mask taken ahead ([`crate::seen_lanes`]):
/// [`seen_of_probes`]'s values.
struct ShSeen {
    y: [f32; 9],
    share: f32,
}

/// The seen part of a [`Rep::Sh`] pixel's NDF from `wo` (bands 0–2) and
/// its share: the footprint's NDF's seen moments
/// ([`crate::mask::seen_moments`]) turned into bands
/// ([`crate::mask::sh9_of_seen_moments`]); with
/// [`NdfOptions::probe_masks`] (`probes > 0`) each probe's seen moments,
/// averaged, then the bands. Masking the probes one by one, rather than
/// their mean, keeps what a wide footprint's spread hides from a grazing
/// view: one Gaussian for the whole footprint sees too much (`docs/ndf.md`,
/// "Masking each probe"). Where every probe is seen whole the average is
/// the footprint's own `(m, C + m mᵀ)`, to rounding.
#[inline(always)]
fn seen_of_probes(p: &Prologue, wo: Vec3) -> ([f32; 9], f32) {
    if p.probes == 0 {
        let (e, share) = crate::mask::seen_moments(&crate::mask::ShMoments::of_sh(&p.gamma), wo);
        return (crate::mask::sh9_of_seen_moments(&e), share);
    }
    let inv_n = 1.0 / p.probes as f32;
    let (mut e, mut share) = ([0.0f32; 9], 0.0f32);
    for g in &p.probe_gamma[..p.probes] {
        let (ej, sj) = crate::mask::seen_moments(&crate::mask::ShMoments::of_sh(g), wo);
        for (e, v) in e.iter_mut().zip(ej) {
            *e += v * inv_n;
        }
        share += sj * inv_n;
    }
    (crate::mask::sh9_of_seen_moments(&e), share)
}

/// An SH NDF pixel waiting for its view mask ([`NdfMethod::finish_batch`]):
/// what its [`NdfMethod::shade_epilogue`] reads.
#[derive(Clone, Copy)]
struct Deferred {
    /// Its column.
    x: usize,
    object: usize,
    position: Vec3,
    frame: Frame,
    hand: f32,
    /// Its lighting, [`Batch::envs`]`[env]`.
    env: usize,
    p: Prologue,
}

/// Up to [`crate::seen_lanes::LANES`] [`Deferred`] pixels of one row, and
/// their lighting: one copy per flat triangle's run of pixels (a row
/// crosses few), one per pixel elsewhere.
struct Batch {
    slots: [Deferred; crate::seen_lanes::LANES],
    n: usize,
    envs: [PixelEnv; crate::seen_lanes::LANES],
    n_envs: usize,
    /// The flat triangle (object, triangle) whose lighting is
    /// `envs[n_envs − 1]`, if it came from one.
    last_flat: Option<(usize, usize)>,
}

impl Batch {
    /// An empty batch (its slots' contents are never read before written).
    fn new() -> Self {
        let env = PixelEnv {
            lit: [0.0; 27],
            env_from_tangent: Mat3::IDENTITY,
            env_from_sh1: Mat3::IDENTITY,
        };
        let slot = Deferred {
            x: 0,
            object: 0,
            position: Vec3::ZERO,
            frame: Frame::from_z(Vec3::Z),
            hand: 1.0,
            env: 0,
            p: Prologue {
                wo: Vec3::Z,
                plain: None,
                rep: Rep::Sh,
                gamma: [0.0; 9],
                probe_gamma: [[0.0; 9]; crate::MAX_PROBES],
                probes: 0,
                nl: 0,
            },
        };
        Self {
            slots: [slot; crate::seen_lanes::LANES],
            n: 0,
            envs: [env; crate::seen_lanes::LANES],
            n_envs: 0,
            last_flat: None,
        }
    }

    /// Keeps the next slot, the pixel lit by `env`; `flat`: the flat
    /// triangle it lies on, whose lighting the previous pixel may already
    /// have stored.
    #[inline(always)]
    fn commit(&mut self, env: &PixelEnv, flat: Option<(usize, usize)>) {
        if flat.is_none() || flat != self.last_flat || self.n_envs == 0 {
            self.envs[self.n_envs] = *env;
            self.n_envs += 1;
            self.last_flat = flat;
        }
        self.slots[self.n].env = self.n_envs - 1;
        self.n += 1;
    }
}

/// What [`NdfMethod::row_body`] reads besides the method.
struct RowCtx<'a> {
    draws: &'a [DrawCall<'a>],
    raster: &'a Rasterizer,
    basis: &'a RayBasis,
    eye: Vec3,
    scene: &'a Scene,
    has_env: bool,
}

/// The camera's unnormalized ray `D(px, py) = f + (px − cx) h_x + (py − cy) h_y`
/// (affine in the pixel, `f` the unit forward axis through the image centre
/// `(cx, cy)`), recovered from `CameraRays::dir`: `D·f = 1`, so a unit
/// direction `d` is `D = d / (d·f)`.
struct RayBasis {
    f: Vec3,
    hx: Vec3,
    hy: Vec3,
    cx: f32,
    cy: f32,
}

impl RayBasis {
    fn new(rays: &relight_render::CameraRays, camera: &relight_render::Camera) -> Self {
        let (w, h) = (camera.width as f32, camera.height as f32);
        let (cx, cy) = (
            (0.5 - camera.image_offset.x) * w,
            (0.5 - camera.image_offset.y) * h,
        );
        let f = rays.dir(cx, cy);
        // Steps of half the image keep the difference well conditioned.
        let axis = |d: Vec3, step: f32| (d / d.dot(f) - f) / step;
        Self {
            f,
            hx: axis(rays.dir(cx + 0.5 * w, cy), 0.5 * w),
            hy: axis(rays.dir(cx, cy + 0.5 * h), 0.5 * h),
            cx,
            cy,
        }
    }

    #[inline]
    fn ray(&self, px: f32, py: f32) -> Vec3 {
        self.f + self.hx * (px - self.cx) + self.hy * (py - self.cy)
    }
}

/// Per-triangle constants of the exact uv derivatives: on the triangle's
/// plane `λ_1 = (c (D·a_1)/(D·n) + b_1)/|n|²` with `n = e_1 × e_2`,
/// `a_1 = e_2 × n`, `a_2 = n × e_1`, `c = n·(p_0 − o)` (ray–plane
/// intersection; `D` unnormalized, the ratio is scale-free), so
/// `∂λ_i/∂x = c/|n|² · ((h_x·a_i)(D·n) − (D·a_i)(h_x·n)) / (D·n)²` — the
/// analytic form of `relight_render::raster::barycentric_derivatives`
/// (which takes central differences by four ray casts), three dot products
/// per pixel.
struct TriangleLod {
    n: Vec3,
    a1: Vec3,
    a2: Vec3,
    scale: f32,
    /// `h_x·a_1, h_x·a_2, h_x·n` and the same for `h_y`.
    hx: Vec3,
    hy: Vec3,
    duv1: Vec2,
    duv2: Vec2,
    ok: bool,
}

impl TriangleLod {
    fn new(basis: &RayBasis, eye: Vec3, p: [Vec3; 3], uv: [Vec2; 3]) -> Self {
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let n = e1.cross(e2);
        let area2 = n.length_squared();
        let (a1, a2) = (e2.cross(n), n.cross(e1));
        let ok = area2.is_finite() && area2 > 0.0;
        let dots = |h: Vec3| Vec3::new(h.dot(a1), h.dot(a2), h.dot(n));
        Self {
            n,
            a1,
            a2,
            scale: if ok { n.dot(p[0] - eye) / area2 } else { 0.0 },
            hx: dots(basis.hx),
            hy: dots(basis.hy),
            duv1: uv[1] - uv[0],
            duv2: uv[2] - uv[0],
            ok,
        }
    }

    /// `[∂uv/∂x, ∂uv/∂y]` at pixel point `(px, py)`, `None` for a degenerate
    /// triangle or a ray (nearly) parallel to its plane.
    #[inline(always)]
    fn duv(&self, basis: &RayBasis, px: f32, py: f32) -> Option<[Vec2; 2]> {
        let d = basis.ray(px, py);
        let (dn, da1, da2) = (d.dot(self.n), d.dot(self.a1), d.dot(self.a2));
        if !self.ok || dn.abs() <= 1e-12 * self.n.length() {
            return None;
        }
        let k = self.scale / (dn * dn);
        let grad = |h: Vec3| {
            let l1 = k * (h.x * dn - da1 * h.z);
            let l2 = k * (h.y * dn - da2 * h.z);
            self.duv1 * l1 + self.duv2 * l2
        };
        Some([grad(self.hx), grad(self.hy)])
    }
}

/// What the render loop keeps of the triangle under the last pixel.
struct TriangleConsts {
    draw: usize,
    tri: usize,
    /// The uv derivatives' constants, for a normal-mapped object.
    lod: Option<TriangleLod>,
    /// A flat triangle's shading frame, handedness and prepared lighting:
    /// its three vertices carry one normal and one tangent (bit for bit), so
    /// the per-pixel interpolation would give them back (to an ulp of
    /// `Σλ = 1`).
    flat: Option<FlatTriangle>,
}

/// [`TriangleConsts::flat`].
struct FlatTriangle {
    frame: Frame,
    hand: f32,
    env: PixelEnv,
}

/// The environment lighting of one shading frame as the Lambert path reads
/// it: the 27 SH coefficients (bands 0–2 per channel, in the tangent frame:
/// `m < 0` functions flipped for a mirrored tangent frame) with the
/// clamped cosine's `Λ_l/π` folded in, so a pixel's bands 0–2 are one
/// 9-term dot product per channel (`effective::lambert_sh_env` up to
/// rounding), and the rotation from the tangent frame to the environment's
/// frame, where the Lambert tail is looked up.
#[derive(Clone, Copy)]
struct PixelEnv {
    lit: [f32; 27],
    env_from_tangent: Mat3,
    /// `env_from_tangent` times [`mean_normal_matrix`]: an SH NDF's band 1
    /// to its mean normal in the environment's frame.
    env_from_sh1: Mat3,
}

impl PixelEnv {
    /// From the frame's lighting (`NdfMethod::set_lighting`'s 27 floats).
    #[inline]
    fn new(light: &[f32], frame: &Frame, hand: f32, env_from_world: &Mat3) -> Self {
        let mut lit = [0.0f32; 27];
        for c in 0..3 {
            let mut lt = [0.0f32; 9];
            lt.copy_from_slice(&light[c * 9..c * 9 + 9]);
            if hand < 0.0 {
                // Tangent-space y = −frame y: the m < 0 functions flip.
                for i in [1, 4, 5] {
                    lt[i] = -lt[i];
                }
            }
            lit[c * 9..c * 9 + 9].copy_from_slice(&lambert_lit9(&lt));
        }
        let env_from_tangent = *env_from_world * Mat3::from_cols(frame.x, frame.y * hand, frame.z);
        Self {
            lit,
            env_from_tangent,
            env_from_sh1: env_from_tangent * mean_normal_matrix(),
        }
    }
}

/// `Σ_i a_i b_i` over 9 coefficients.
#[inline]
fn dot9(a: &[f32], b: &[f32]) -> f32 {
    let (a, b) = (&a[..9], &b[..9]);
    let mut s = 0.0;
    for i in 0..9 {
        s += a[i] * b[i];
    }
    s
}

impl TriangleConsts {
    fn new(
        basis: &RayBasis,
        eye: Vec3,
        o: &ObjectData,
        draw: usize,
        tri: usize,
        allow_flat: bool,
        env_from_world: &Mat3,
    ) -> Self {
        let [i0, i1, i2] = o.triangles[tri].map(|i| i as usize);
        let lod = o.map.as_ref().map(|_| {
            TriangleLod::new(
                basis,
                eye,
                [o.positions[i0], o.positions[i1], o.positions[i2]],
                [o.uvs[i0], o.uvs[i1], o.uvs[i2]],
            )
        });
        let same3 = |a: Vec4, b: Vec4, c: Vec4| {
            a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)
                && a.to_array().map(f32::to_bits) == c.to_array().map(f32::to_bits)
        };
        let (n, t) = (o.normals[i0], o.tangents[i0]);
        let flat = (allow_flat
            && same3(
                n.extend(0.0),
                o.normals[i1].extend(0.0),
                o.normals[i2].extend(0.0),
            )
            && same3(t, o.tangents[i1], o.tangents[i2]))
        .then(|| {
            let frame = Frame::from_normal_tangent(n.normalize_or(Vec3::Z), t.truncate());
            let hand = if t.w < 0.0 { -1.0 } else { 1.0 };
            FlatTriangle {
                frame,
                hand,
                env: PixelEnv::new(
                    &o.light[i0 * 27..i0 * 27 + 27],
                    &frame,
                    hand,
                    env_from_world,
                ),
            }
        });
        Self {
            draw,
            tri,
            lod,
            flat,
        }
    }
}

impl Relighter for NdfMethod {
    fn name(&self) -> &'static str {
        NDF_METHOD_NAME
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            SceneFeature::Environment if self.options.brdf == NdfBrdf::Lambert => Support::Full,
            SceneFeature::PointLights | SceneFeature::NormalMaps => Support::Full,
            _ => Support::No,
        }
    }

    /// Every object's BRDF must be the options' model times a colour
    /// ([`colour_of`]).
    fn check_objects(&self, scene: &Scene) -> Result<(), MethodError> {
        for (i, ob) in scene.objects.iter().enumerate() {
            self.object_colour(i, ob)?;
        }
        Ok(())
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        self.objects.clear();
        for (i, ob) in scene.objects.iter().enumerate() {
            progress.check()?;
            let m = &ob.mesh;
            let nv = m.positions.len();
            if m.normals.len() != nv {
                return Err(invalid(
                    "mesh",
                    format!(
                        "{}: {} normals for {nv} vertices",
                        Numbered::object(i),
                        m.normals.len()
                    ),
                ));
            }
            if ob.normal_map.is_some() && (m.uvs.len() != nv || m.tangents.len() != nv) {
                return Err(invalid(
                    "normal-map",
                    format!(
                        "{}: a normal map needs uvs and tangents ({} uvs, {} tangents for {nv} vertices)",
                        Numbered::object(i),
                        m.uvs.len(),
                        m.tangents.len()
                    ),
                ));
            }
            let colour = self.object_colour(i, ob)?;
            let map = match &ob.normal_map {
                Some(nm) => {
                    progress.start("ndf pyramid bake", 1);
                    let b = self.baked(nm);
                    progress.finish();
                    Some((nm.clone(), b))
                }
                None => None,
            };
            let tangents = if m.tangents.len() == nv {
                m.tangents.clone()
            } else {
                m.normals
                    .iter()
                    .map(|n| n.any_orthonormal_vector().extend(1.0))
                    .collect()
            };
            self.objects.push(ObjectData {
                positions: m.positions.clone(),
                triangles: m.indices.clone(),
                normals: m.normals.clone(),
                tangents,
                uvs: if m.uvs.len() == nv {
                    m.uvs.clone()
                } else {
                    vec![Vec2::ZERO; nv]
                },
                colour,
                map,
                light: vec![0.0; nv * 27],
                closed: closed_bounds(m),
            });
        }
        if self.options.brdf == NdfBrdf::Lambert && !scene.point_lights.is_empty() {
            // The view mask's table ([`crate::mask`]) is built on first use:
            // here, not inside the first frame.
            crate::mask::warm();
        }
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let t = Instant::now();
        if scene.objects.len() != self.objects.len() {
            return Err(invalid(
                "scene",
                "the scene changed since prepare; call prepare again".into(),
            ));
        }
        // The projection and the tail are in the environment's frame: a
        // turn of the map (`world_from_env`) reuses both.
        let has_env = scene.has_environment();
        if has_env {
            self.env_projection
                .project(&scene.env, LAMBERT_TAIL_ORDER)
                .map_err(|e| MethodError::failed(NDF_METHOD_NAME, NdfError::from(e)))?;
        }
        let (env, tail_for) = if has_env {
            (
                self.env_projection.last(),
                self.env_projection.fingerprint(),
            )
        } else {
            (None, None)
        };
        self.env_from_world = scene.world_from_env.transpose();
        if tail_for != self.env_tail_for {
            self.env_tail = match env {
                Some(e) => LambertTail::new([0, 1, 2].map(|c| &e.channels[c][..])),
                None => LambertTail::default(),
            };
            self.env_tail_for = tail_for;
        }
        for o in &mut self.objects {
            progress.check()?;
            let Some(env) = &env else {
                o.light.fill(0.0);
                continue;
            };
            use rayon::prelude::*;
            let wfe = scene.world_from_env;
            o.light
                .par_chunks_mut(27)
                .zip(o.normals.par_iter().zip(o.tangents.par_iter()))
                .for_each(|(dst, (n, tg))| {
                    let f = Frame::from_normal_tangent(*n, tg.truncate());
                    let local_from_world = Mat3::from_cols(f.x, f.y, f.z).transpose();
                    let r = local_from_world * wfe;
                    let rot = Rot3::from_mat3_unchecked(r);
                    let Ok(sh) = ShRotation::<f32>::from_rotation(3, &rot) else {
                        return;
                    };
                    for c in 0..3 {
                        sh.apply(&env.channels[c][..9], &mut dst[c * 9..c * 9 + 9]);
                    }
                });
        }
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.pending_lighting_ms = ms;
        Ok(ms)
    }

    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError> {
        request.validate(NDF_METHOD_NAME)?;
        let t = Instant::now();
        let k = request.aa;
        let mut camera = request.camera;
        camera.width *= k;
        camera.height *= k;
        let draws: Vec<DrawCall> = self
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                DrawCall::new(&o.positions, &o.triangles)
                    .with_object_id(i as u32)
                    .with_cull(cull_for_closed(o.closed.as_ref(), camera.eye))
            })
            .collect();
        let opts = RasterOptions {
            cull: CullMode::None,
            ..RasterOptions::default()
        }
        .fit_depth(&camera, &draws);
        let mut raster = std::mem::take(&mut self.raster);
        let res = raster.rasterize(&camera, &draws, &opts);
        if let Err(e) = res {
            self.raster = raster;
            return Err(MethodError::failed(NDF_METHOD_NAME, NdfError::from(e)));
        }
        progress.check()?;
        let rays = camera.ray_frame();
        let basis = RayBasis::new(&rays, &camera);
        let eye = camera.eye;
        let (w, h) = (camera.width, camera.height);
        let mut big = Image::new(w, h);
        // Once per frame: `has_environment` scans the map's texels.
        let has_env = scene.has_environment();
        {
            use rayon::prelude::*;
            let this = &*self;
            let raster_ref = &raster;
            big.pixels
                .par_chunks_mut(w)
                .enumerate()
                .for_each(|(y, row)| {
                    this.render_row(
                        &RowCtx {
                            draws: &draws,
                            raster: raster_ref,
                            basis: &basis,
                            eye,
                            scene,
                            has_env,
                        },
                        y,
                        row,
                    );
                });
        }
        let out = Rendered::from_samples(
            std::borrow::Cow::Owned(big),
            &raster,
            k,
            std::mem::take(&mut self.pending_lighting_ms),
            t,
        );
        self.raster = raster;
        Ok(out)
    }

    fn data_bytes(&self) -> u64 {
        self.cache.values().map(|b| b.bytes()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_render::Camera;
    use relight_render::NoProgress;

    /// The screen sphere (closed) seen from outside: its back faces are
    /// culled, and the image is the one drawing both sides gives.
    #[test]
    fn a_closed_sphere_culled_from_outside_renders_the_same() {
        let map = NormalMap::bumps(64, 4, 0.8);
        let scene = crate::verify::sphere_scene(&map, NdfBrdf::Lambert, 64);
        let mut m = NdfMethod::new(NdfOptions::default()).expect("options");
        m.prepare(&scene, &NoProgress).expect("prepare");
        assert!(m.objects[0].closed.is_some(), "the sphere is closed");
        let req = FrameRequest::new(scene.camera);
        let culled = m.render(&scene, &req, &NoProgress).expect("render");
        m.objects[0].closed = None;
        let both = m.render(&scene, &req, &NoProgress).expect("render");
        let lit = both
            .image
            .pixels
            .iter()
            .filter(|p| p.max_element() > 0.0)
            .count();
        assert!(lit > 64 * 64 / 4, "{lit} lit pixels");
        assert_eq!(culled.image.pixels, both.image.pixels);
    }

    /// The bench's horizon plane (96², 16 tiles) with `filter` and `brdf`
    /// (vMF at 3 lobes), under a coloured sky when `sky`, prepared.
    fn prepared_plane(
        map: &NormalMap,
        filter: NdfFilter,
        brdf: NdfBrdf,
        sky: bool,
    ) -> (Scene, NdfMethod) {
        let mut scene = crate::verify::horizon_plane_scene(map, brdf, 96, 16.0);
        if sky {
            scene.env = relight_sphere::EnvMap::from_fn(
                relight_sphere::Param::LatLong {
                    width: 32,
                    height: 16,
                },
                |d| Vec3::new(0.5 + 0.5 * d.y.max(0.0), 0.4, 0.3 + 0.2 * d.x.abs()),
            );
        }
        let mut m = NdfMethod::new(NdfOptions {
            filter,
            brdf,
            vmf: VmfBakeOptions {
                lobes: 3,
                ..VmfBakeOptions::default()
            },
            ..NdfOptions::default()
        })
        .expect("options");
        m.prepare(&scene, &NoProgress).expect("prepare");
        (scene, m)
    }

    #[test]
    fn flat_triangles_shade_as_the_per_pixel_interpolation() {
        // The bench's horizon plane (one normal and tangent everywhere), under
        // the environment (Lambert, SH) and one light (vMF Blinn): per pixel
        // the per-triangle frame and lighting against the interpolated ones.
        let map = NormalMap::bumps(64, 4, 0.8);
        for (filter, brdf) in [
            (NdfFilter::Sh, NdfBrdf::Lambert),
            (NdfFilter::Vmf, NdfBrdf::Blinn { s: 64.0 }),
        ] {
            let (scene, mut m) = prepared_plane(&map, filter, brdf, brdf == NdfBrdf::Lambert);
            let o = &m.objects[0];
            let flat = (0..o.triangles.len())
                .filter(|&t| {
                    let rays = scene.camera.ray_frame();
                    let basis = RayBasis::new(&rays, &scene.camera);
                    TriangleConsts::new(&basis, scene.camera.eye, o, 0, t, true, &Mat3::IDENTITY)
                        .flat
                        .is_some()
                })
                .count();
            assert_eq!(flat, o.triangles.len(), "the plane's triangles are flat");
            let req = FrameRequest::new(scene.camera);
            let fast = m.render(&scene, &req, &NoProgress).expect("render");
            m.flat_triangles = false;
            let slow = m.render(&scene, &req, &NoProgress).expect("render");
            let (a, b) = (&fast.image.pixels, &slow.image.pixels);
            let peak = b.iter().map(|p| p.max_element()).fold(0.0f32, f32::max);
            assert!(peak > 0.0);
            let worst = a
                .iter()
                .zip(b)
                .map(|(p, q)| (*p - *q).abs().max_element())
                .fold(0.0f32, f32::max);
            assert!(worst <= 1e-5 * peak, "{filter:?}: {worst} of peak {peak}");
        }
    }

    #[test]
    fn masks_in_lanes_shade_as_one_pixel_at_a_time() {
        // The batched view masks (`seen_lanes`) against the scalar ones, bit
        // for bit: under the sky with the scene's point light (whose mask
        // reads the batch's moments), with the flat triangles' shared
        // lighting and with per-pixel lighting.
        let map = NormalMap::bumps(64, 4, 0.8);
        let (scene, mut m) = prepared_plane(&map, NdfFilter::Sh, NdfBrdf::Lambert, true);
        assert!(!scene.point_lights.is_empty());
        let req = FrameRequest::new(scene.camera);
        let mut images = Vec::new();
        for (flat, probes) in [(true, false), (false, false), (true, true), (false, true)] {
            m.flat_triangles = flat;
            m.options.probe_masks = probes;
            m.masks_in_lanes = true;
            let lanes = m.render(&scene, &req, &NoProgress).expect("render");
            m.masks_in_lanes = false;
            let one = m.render(&scene, &req, &NoProgress).expect("render");
            let lit = one.image.pixels.iter().filter(|p| p.max_element() > 0.0);
            assert!(lit.count() > one.image.pixels.len() / 4);
            for (p, q) in lanes.image.pixels.iter().zip(&one.image.pixels) {
                assert_eq!(
                    p.to_array().map(f32::to_bits),
                    q.to_array().map(f32::to_bits),
                    "flat {flat}, probe masks {probes}: {p} vs {q}"
                );
            }
            images.push(one.image);
        }
        // The probes' masks change the grazing pixels (the horizon plane's
        // footprints have several probes).
        let changed = images[0]
            .pixels
            .iter()
            .zip(&images[2].pixels)
            .filter(|(p, q)| (**p - **q).abs().max_element() > 1e-4 * p.max_element())
            .count();
        assert!(
            changed > images[0].pixels.len() / 20,
            "{changed} pixels changed"
        );
    }

    #[test]
    fn avx2_rows_are_the_portable_rows_bit_for_bit() {
        #[cfg(target_arch = "x86_64")]
        if !relight_isa::avx2() {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI: this CPU lacks AVX2+FMA, so the fast row path is untested"
            );
            return;
        }
        let map = NormalMap::bumps(64, 4, 0.8);
        let blinn = NdfBrdf::Blinn { s: 64.0 };
        for (filter, brdf, taps) in [
            (NdfFilter::Sh, NdfBrdf::Lambert, VmfTaps::Merge),
            (NdfFilter::Vmf, blinn, VmfTaps::Merge),
            (NdfFilter::Vmf, blinn, VmfTaps::Mixture),
            (NdfFilter::Toksvig, blinn, VmfTaps::Merge),
            (NdfFilter::Lean, blinn, VmfTaps::Merge),
        ] {
            let (scene, mut m) = prepared_plane(&map, filter, brdf, true);
            m.options.vmf_taps = taps;
            let req = FrameRequest::new(scene.camera);
            let fast = m.render(&scene, &req, &NoProgress).expect("render");
            m.simd = false;
            let slow = m.render(&scene, &req, &NoProgress).expect("render");
            assert!(slow.image.pixels.iter().any(|p| p.max_element() > 0.0));
            for (p, q) in fast.image.pixels.iter().zip(&slow.image.pixels) {
                assert_eq!(
                    p.to_array().map(f32::to_bits),
                    q.to_array().map(f32::to_bits),
                    "{filter:?} {taps:?}: {p} vs {q}"
                );
            }
        }
    }

    #[test]
    fn analytic_uv_derivatives_match_the_rasterizers_central_differences() {
        let camera = Camera {
            eye: Vec3::new(0.3, 1.2, 19.0),
            target: Vec3::new(0.0, 0.0, -2.0),
            up: Vec3::Y,
            vfov_deg: 40.0,
            width: 96,
            height: 64,
            image_offset: Vec2::new(0.01, -0.02),
        };
        let rays = camera.ray_frame();
        let basis = RayBasis::new(&rays, &camera);
        let p = [
            Vec3::new(-20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, 20.0),
            Vec3::new(0.0, 0.5, -20.0),
        ];
        let uv = [Vec2::ZERO, Vec2::new(16.0, 0.0), Vec2::new(8.0, 16.0)];
        let tl = TriangleLod::new(&basis, camera.eye, p, uv);
        let mut worst = 0.0f32;
        // Away from the horizon (|∂uv| ≲ 1 texel-tile per pixel): near it the
        // footprint changes within a pixel and the one-pixel central
        // differences overshoot the derivative (here by 14 % at
        // (30.5, 28.5), 0.2 of a MIP level).
        for (px, py) in [(10.5, 40.5), (48.5, 33.5), (80.5, 60.5), (20.5, 50.5)] {
            let [dx, dy] = tl.duv(&basis, px, py).expect("not parallel");
            let [lx, ly] = relight_render::raster::barycentric_derivatives(&rays, p, px, py)
                .expect("not parallel");
            let duv = |dl: Vec3| uv[0] * dl.x + uv[1] * dl.y + uv[2] * dl.z;
            for (a, b) in [(dx, duv(lx)), (dy, duv(ly))] {
                worst = worst.max((a - b).length() / b.length().max(1e-6));
            }
        }
        // Central differences over one pixel differ from the derivative by
        // O(h²) of the rational function: well under 1 % here.
        assert!(worst < 0.01, "relative difference {worst}");
    }
}
