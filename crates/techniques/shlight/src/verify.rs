//! `relight verify sh`: relative RMS image error of SH shading against the
//! Monte Carlo reference renderer.
//!
//! For every scene given (the CLI passes the default scene and `park` with
//! GGX α = 0.3): one unshadowed reference render with the mesh normals and one
//! with the normal-mapped normals (the reference's shading-normal override
//! calls the same [`NormalMap::perturb`] as the SH renderer), then SH renders
//! for every order and rotation method with and without the normal map.
//! Without a normal map the perturbed and vertex frames coincide and every
//! rotation method gives the same image, so those rows carry
//! `rotation = "any"`.
//!
//! Error: `sqrt(Σ|sh − ref|²) / sqrt(Σ|ref|²)` over RGB, restricted to pixels
//! fully covered by objects in the SH render ([`crate::ShImage::mask`]).
//! `reference_rel_std_error` is the reference's own Monte Carlo noise on the
//! same scale, `sqrt(Σ se²) / sqrt(Σ Y²)` over the same pixels (se = standard
//! error of the pixel's mean luminance Y): errors well above it are real.

use crate::relight::ShRotationMethod;
use crate::{NormalMap, ShLightError, ShRenderer};
use relight_render::bvh::SceneBvh;
use relight_render::reference::{
    EnvLight, ReferenceImage, ReferenceOptions, render_reference_with,
};
use relight_render::sampling::{EnvFilter, luminance};
use relight_render::{Progress, Scene};
use serde::Serialize;
use std::time::Instant;

/// A named scene to verify on.
#[derive(Clone, Copy, Debug)]
pub struct VerifyScene<'a> {
    pub name: &'a str,
    pub scene: &'a Scene,
}

/// Settings of [`verify_sh`].
#[derive(Clone, Debug, PartialEq)]
pub struct VerifyOptions {
    /// Image size (the scene cameras are resized to it).
    pub width: usize,
    pub height: usize,
    /// SH orders (bands) to test.
    pub orders: Vec<usize>,
    /// Rotation methods (with the normal map).
    pub methods: Vec<ShRotationMethod>,
    /// Reference samples per pixel.
    pub spp: u32,
    /// SH sub-samples per pixel side.
    pub supersampling: usize,
    pub seed: u64,
}

impl VerifyOptions {
    /// The full run: 320×240, orders 3…10, every method, 512 spp, 3×3 SH sub-samples.
    #[must_use]
    pub fn full() -> Self {
        Self {
            width: 320,
            height: 240,
            orders: (3..=10).collect(),
            methods: ShRotationMethod::ALL.to_vec(),
            spp: 512,
            supersampling: 3,
            seed: 7,
        }
    }

    /// A smoke run: 128×96, orders 3…10, every method, 96 spp, 2×2 sub-samples.
    #[must_use]
    pub fn quick() -> Self {
        Self {
            width: 128,
            height: 96,
            spp: 96,
            supersampling: 2,
            ..Self::full()
        }
    }

    /// [`quick`](Self::quick) or [`full`](Self::full).
    #[must_use]
    pub fn new(quick: bool) -> Self {
        if quick { Self::quick() } else { Self::full() }
    }
}

/// One row of `relight verify sh`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ShVerifyRow {
    pub scene: String,
    /// Bands (n² coefficients).
    pub order: usize,
    /// `exact|zyz|taylor1|taylor15|taylor2|none`, or `any` without a normal map.
    pub rotation: String,
    /// The normal map's name, or `none`.
    pub normal_map: String,
    /// Relative RMS error against the reference (object pixels).
    pub rel_rms_error: f64,
    /// Relative RMS difference from the exact per-pixel rotation at the same
    /// order and normal map (0 for the rows without a normal map): the error
    /// the rotation method itself adds.
    pub rel_rms_vs_exact: f64,
    /// The reference's own relative standard error on the same pixels.
    pub reference_rel_std_error: f64,
    pub reference_spp: u32,
    /// Pixels compared.
    pub pixels: usize,
    /// Per-pixel shading time of this SH image (ms, excluding bake and per-vertex work).
    pub ms_shade: f64,
}

fn masked_std_error(r: &ReferenceImage, mask: &[bool]) -> f64 {
    let (mut se2, mut y2) = (0.0f64, 0.0f64);
    for (i, &m) in mask.iter().enumerate() {
        if m {
            se2 += f64::from(r.std_error[i]).powi(2);
            y2 += f64::from(luminance(r.image.pixels[i])).powi(2);
        }
    }
    if y2 > 0.0 { (se2 / y2).sqrt() } else { 0.0 }
}

/// Runs the accuracy study. `normal_map`: a named map (e.g. one of
/// `shared/data/normalmaps`); `None` uses the procedural bumps
/// [`NormalMap::bumps`]`(256, 8, 0.6)` named `bumps`.
///
/// # Errors
/// Invalid orders, meshes without uvs/tangents (the normal-mapped rows need
/// them), anisotropic BRDFs, cancellation.
pub fn verify_sh(
    scenes: &[VerifyScene],
    normal_map: Option<(&str, &NormalMap)>,
    opts: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<Vec<ShVerifyRow>, ShLightError> {
    let bumps;
    let (nm_name, nm) = match normal_map {
        Some(x) => x,
        None => {
            bumps = NormalMap::bumps(256, 8, 0.6);
            ("bumps", &bumps)
        }
    };
    let order_max = opts
        .orders
        .iter()
        .copied()
        .max()
        .ok_or(ShLightError::InvalidParameter {
            what: "orders",
            why: "empty list".into(),
        })?;
    let mut rows = Vec::new();
    for vs in scenes {
        let mut scene = vs.scene.clone();
        scene.camera.width = opts.width;
        scene.camera.height = opts.height;
        let renderer = ShRenderer::new(order_max, ShRotationMethod::Exact)?
            .with_supersampling(opts.supersampling);
        let prepared = renderer.prepare(&scene, Some(nm), order_max, progress)?;
        let bvh = SceneBvh::from_scene(&scene);
        let light = EnvLight::new(&scene.env, EnvFilter::Nearest);
        let ropts = ReferenceOptions {
            spp: opts.spp,
            pass_spp: 16,
            seed: opts.seed,
            env_filter: EnvFilter::Nearest,
            ..ReferenceOptions::default()
        };
        // The reference without visibility, plain and with the normal map.
        let mut ref_scene = scene.clone();
        ref_scene.visibility = false;
        let plain = render_reference_with(&ref_scene, &bvh, &light, &ropts, progress)?;
        let mut bumped_scene = ref_scene.clone();
        let shared_nm = std::sync::Arc::new(nm.clone());
        for o in &mut bumped_scene.objects {
            o.normal_map = Some(shared_nm.clone());
        }
        let bumped = render_reference_with(&bumped_scene, &bvh, &light, &ropts, progress)?;
        for &order in &opts.orders {
            progress.check()?;
            // The per-pixel exact rotation at this order: the best any rotation
            // method can do with n bands, so `rel_rms_vs_exact` isolates the
            // error of the rotation from that of the band limit.
            let exact_nm = prepared.shade(
                &scene,
                order,
                ShRotationMethod::Exact,
                Some(nm),
                f32::INFINITY,
                false,
            )?;
            let mut push = |rotation: String,
                            with_nm: bool,
                            method: ShRotationMethod|
             -> Result<(), ShLightError> {
                let t0 = Instant::now();
                let img = prepared.shade(
                    &scene,
                    order,
                    method,
                    with_nm.then_some(nm),
                    f32::INFINITY,
                    false,
                )?;
                let ms_shade = t0.elapsed().as_secs_f64() * 1e3;
                let reference = if with_nm { &bumped } else { &plain };
                rows.push(ShVerifyRow {
                    scene: vs.name.to_string(),
                    order,
                    rotation,
                    normal_map: if with_nm {
                        nm_name.to_string()
                    } else {
                        "none".to_string()
                    },
                    rel_rms_error: img
                        .image
                        .relative_rms_error(&reference.image, Some(&img.mask)),
                    rel_rms_vs_exact: if with_nm {
                        img.image
                            .relative_rms_error(&exact_nm.image, Some(&img.mask))
                    } else {
                        0.0
                    },
                    reference_rel_std_error: masked_std_error(reference, &img.mask),
                    reference_spp: reference.spp,
                    pixels: img.mask.iter().filter(|&&m| m).count(),
                    ms_shade,
                });
                Ok(())
            };
            push("any".to_string(), false, ShRotationMethod::Exact)?;
            for &m in &opts.methods {
                push(m.name().to_string(), true, m)?;
            }
        }
    }
    Ok(rows)
}
