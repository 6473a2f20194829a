//! Method flags → one method's options ([`relight_methods::MethodOptions`]).
//!
//! Each flag belongs to the methods listed in [`FLAG_METHODS`]; a flag given
//! to a method it does not belong to is a one-line error naming the method,
//! never silently dropped. Unset flags keep the method's own defaults (its
//! options type's `Default`, the one place they live).

use crate::args::{Method, MethodFlags, Scattering};
use anyhow::{Result, anyhow, bail};
use relight_methods::{MethodKind, MethodOptions};

/// The method of a `--method` value.
#[must_use]
pub fn kind_of(m: Method) -> MethodKind {
    match m {
        Method::Reference => MethodKind::Reference,
        Method::Sh => MethodKind::Sh,
        Method::Wavelet => MethodKind::Wavelet,
        Method::Fog => MethodKind::Fog,
        Method::Shexp => MethodKind::ShExp,
        Method::RadianceCache => MethodKind::RadianceCache,
        Method::Ndf => MethodKind::Ndf,
        Method::Triple => MethodKind::Triple,
        Method::Nearfield => MethodKind::Nearfield,
        Method::Ltc => MethodKind::Ltc,
    }
}

/// Which methods each method flag applies to.
pub const FLAG_METHODS: [(&str, &[MethodKind]); 33] = [
    ("--spp", &[MethodKind::Reference, MethodKind::RadianceCache]),
    (
        "--seed",
        &[MethodKind::Reference, MethodKind::RadianceCache],
    ),
    ("--scattering", &[MethodKind::Reference]),
    ("--light-sampling", &[MethodKind::Reference]),
    (
        "--order",
        &[
            MethodKind::Sh,
            MethodKind::Fog,
            MethodKind::ShExp,
            MethodKind::RadianceCache,
            MethodKind::Ndf,
            MethodKind::Nearfield,
        ],
    ),
    ("--error", &[MethodKind::RadianceCache]),
    ("--rotation", &[MethodKind::Sh, MethodKind::RadianceCache]),
    ("--window", &[MethodKind::Sh]),
    ("--n", &[MethodKind::Wavelet]),
    ("--ntess", &[MethodKind::Wavelet]),
    ("--terms", &[MethodKind::Wavelet, MethodKind::Triple]),
    ("--ao", &[MethodKind::Wavelet]),
    (
        "--cache",
        &[
            MethodKind::Wavelet,
            MethodKind::Triple,
            MethodKind::Nearfield,
        ],
    ),
    ("--fog", &[MethodKind::Fog]),
    ("--exp", &[MethodKind::ShExp]),
    ("--spheres", &[MethodKind::ShExp]),
    (
        "--visibility-texture",
        &[MethodKind::ShExp, MethodKind::Triple],
    ),
    ("--normal-filter", &[MethodKind::Ndf, MethodKind::Sh]),
    ("--ndf-brdf", &[MethodKind::Ndf]),
    ("--lobes", &[MethodKind::Ndf]),
    ("--vmf-taps", &[MethodKind::Ndf]),
    ("--ndf-mask", &[MethodKind::Ndf]),
    ("--ndf-supersample", &[MethodKind::Ndf]),
    ("--select", &[MethodKind::Triple]),
    ("--shading", &[MethodKind::Triple]),
    ("--twists", &[MethodKind::Triple]),
    ("--storage", &[MethodKind::Triple]),
    ("--source-terms", &[MethodKind::Nearfield]),
    ("--source-ranking", &[MethodKind::Nearfield]),
    ("--target-terms", &[MethodKind::Nearfield]),
    ("--face", &[MethodKind::Nearfield]),
    (
        "--refine-coarse",
        &[
            MethodKind::Triple,
            MethodKind::Nearfield,
            MethodKind::Wavelet,
        ],
    ),
    ("--env-glow", &[MethodKind::Fog]),
];

/// The flags of `f` that are set, by name.
pub fn given(f: &MethodFlags) -> Vec<&'static str> {
    let set = [
        f.spp.is_some(),
        f.seed.is_some(),
        f.scattering.is_some(),
        f.light_sampling.is_some(),
        f.order.is_some(),
        f.error.is_some(),
        f.rotation.is_some(),
        f.window.is_some(),
        f.n.is_some(),
        f.ntess.is_some(),
        f.terms.is_some(),
        f.ao.is_some(),
        f.cache.is_some(),
        f.fog.is_some(),
        f.exp.is_some(),
        f.spheres.is_some(),
        f.visibility_texture.is_some(),
        f.normal_filter.is_some(),
        f.ndf_brdf.is_some(),
        f.lobes.is_some(),
        f.vmf_taps.is_some(),
        f.ndf_mask.is_some(),
        f.ndf_supersample.is_some(),
        f.select.is_some(),
        f.shading.is_some(),
        f.twists.is_some(),
        f.storage.is_some(),
        f.source_terms.is_some(),
        f.source_ranking.is_some(),
        f.target_terms.is_some(),
        f.face.is_some(),
        f.refine_coarse.is_some(),
        f.env_glow.is_some(),
    ];
    FLAG_METHODS
        .iter()
        .zip(set)
        .filter(|(_, s)| *s)
        .map(|((name, _), _)| *name)
        .collect()
}

/// True when the method flag `name` (as in [`FLAG_METHODS`]) applies to `kind`.
pub fn flag_applies(name: &str, kind: MethodKind) -> bool {
    FLAG_METHODS
        .iter()
        .any(|(n, methods)| *n == name && methods.contains(&kind))
}

/// Refuses every set flag that does not apply to `kind`.
///
/// # Errors
/// The first such flag, naming the method and the methods it applies to.
pub fn check_flags(kind: MethodKind, f: &MethodFlags) -> Result<()> {
    for name in given(f) {
        let (_, methods) = FLAG_METHODS
            .iter()
            .find(|(n, _)| *n == name)
            .expect("every given flag is in FLAG_METHODS");
        if !methods.contains(&kind) {
            let names: Vec<&str> = methods.iter().map(|m| m.name()).collect();
            bail!(
                "{name} does not apply to method {kind} (it is an option of {})",
                names.join(", ")
            );
        }
    }
    Ok(())
}

/// Unsets every flag of `f` that does not apply to `kind` (the viewer hands
/// each of its methods the flags that belong to it).
pub fn clear_foreign(kind: MethodKind, f: &mut MethodFlags) {
    let applies = |name: &str| flag_applies(name, kind);
    macro_rules! clear {
        ($($field:ident => $name:literal),* $(,)?) => {
            $(if !applies($name) { f.$field = None; })*
        };
    }
    clear!(
        spp => "--spp", seed => "--seed", scattering => "--scattering",
        light_sampling => "--light-sampling", order => "--order",
        error => "--error", rotation => "--rotation", window => "--window", n => "--n", ntess => "--ntess", terms => "--terms",
        ao => "--ao", cache => "--cache", fog => "--fog", exp => "--exp", spheres => "--spheres",
        visibility_texture => "--visibility-texture",
        normal_filter => "--normal-filter", ndf_brdf => "--ndf-brdf", lobes => "--lobes", vmf_taps => "--vmf-taps", ndf_mask => "--ndf-mask", ndf_supersample => "--ndf-supersample",
        select => "--select", shading => "--shading", twists => "--twists",
        storage => "--storage",
        source_terms => "--source-terms", source_ranking => "--source-ranking", target_terms => "--target-terms", face => "--face",
        refine_coarse => "--refine-coarse", env_glow => "--env-glow",
    );
}

/// `--refine-coarse on|off`, if given.
///
/// # Errors
/// Any other value.
pub fn refine_coarse(f: &MethodFlags) -> Result<Option<bool>> {
    match f.refine_coarse.as_deref() {
        None => Ok(None),
        Some("on") => Ok(Some(true)),
        Some("off") => Ok(Some(false)),
        Some(other) => bail!("--refine-coarse {other}: expected `on` or `off`"),
    }
}

/// The options of `kind`: its defaults with the given flags applied.
///
/// # Errors
/// A flag that does not apply to `kind`, a bad value, or a `--cache` folder
/// that cannot be made.
pub fn options_for(kind: MethodKind, f: &MethodFlags) -> Result<MethodOptions> {
    check_flags(kind, f)?;
    if let Some(c) = &f.cache {
        crate::output::check_out_dir(c, "--cache")?;
    }
    let mut o = MethodOptions::default_for(kind);
    match &mut o {
        MethodOptions::Reference(r) => {
            if let Some(spp) = f.spp {
                r.spp = spp;
            }
            if let Some(seed) = f.seed {
                r.seed = seed;
            }
            if let Some(s) = f.scattering {
                r.medium_mode = match s {
                    Scattering::Single => relight_render::reference::MediumMode::SingleScattering,
                    Scattering::Multiple => {
                        relight_render::reference::MediumMode::MultipleScattering
                    }
                };
            }
            if let Some(s) = &f.light_sampling {
                r.light_sampling = s
                    .parse()
                    .map_err(|e| anyhow!("--light-sampling {s}: {e}"))?;
            }
        }
        MethodOptions::Sh(s) => {
            if let Some(order) = f.order {
                s.order = order;
            }
            if let Some(r) = &f.rotation {
                s.rotation = r.parse().map_err(|e| anyhow!("--rotation {r}: {e}"))?;
            }
            if let Some(w) = &f.window {
                s.window = w.parse().map_err(|e| anyhow!("--window {w}: {e}"))?;
            }
            if let Some(v) = &f.normal_filter {
                s.normal_filter = relight_ndf::NdfFilter::parse(v)
                    .map_err(|e| anyhow!("--normal-filter: {e}"))?;
            }
        }
        MethodOptions::Wavelet(w) => {
            if let Some(n) = f.n {
                w.n = n;
            }
            if let Some(ntess) = f.ntess {
                w.ntess = ntess;
            }
            if let Some(terms) = f.terms {
                w.terms = terms;
            }
            if let Some(ao) = f.ao {
                w.ao = ao;
            }
            if let Some(c) = &f.cache {
                w.cache_dir = c.clone();
            }
            if let Some(r) = refine_coarse(f)? {
                w.refine_coarse = r;
            }
        }
        MethodOptions::ShExp(x) => {
            if let Some(order) = f.order {
                x.order = order;
            }
            if let Some(e) = &f.exp {
                x.exp = e.parse().map_err(|m| anyhow!("--exp {e}: {m}"))?;
            }
            if let Some(k) = f.spheres {
                x.spheres = k;
            }
            if let Some(r) = f.visibility_texture {
                if !(1..=relight_shexp::method::MAX_VISIBILITY_TEXTURE).contains(&r) {
                    bail!(
                        "--visibility-texture {r}: texels per side must be 1…{}",
                        relight_shexp::method::MAX_VISIBILITY_TEXTURE
                    );
                }
                x.visibility_texture = r;
            }
        }
        MethodOptions::RadianceCache(c) => {
            if let Some(spp) = f.spp {
                c.spp = spp;
            }
            if let Some(seed) = f.seed {
                c.seed = seed;
            }
            if let Some(order) = f.order {
                c.order = order;
            }
            if let Some(a) = f.error {
                c.error = a;
            }
            if let Some(r) = &f.rotation {
                c.rotation = r.parse().map_err(|e| anyhow!("--rotation {r}: {e}"))?;
            }
        }
        MethodOptions::Triple(t) => {
            if let Some(terms) = f.terms {
                t.terms = terms;
            }
            if let Some(c) = &f.cache {
                t.cache_dir = c.clone();
            }
            if let Some(s) = &f.select {
                t.selection = s.parse().map_err(|e| anyhow!("--select {s}: {e}"))?;
            }
            if let Some(s) = &f.shading {
                t.shading = s.parse().map_err(|e| anyhow!("--shading {s}: {e}"))?;
            }
            if let Some(n) = f.twists {
                t.twists = n;
            }
            if let Some(s) = &f.storage {
                t.storage = s.parse().map_err(|e| anyhow!("--storage {s}: {e}"))?;
            }
            if let Some(r) = f.visibility_texture {
                if !(1..=relight_triple::vis_texture::MAX_RES).contains(&r) {
                    bail!(
                        "--visibility-texture {r}: texels per side must be 1…{} for triple",
                        relight_triple::vis_texture::MAX_RES
                    );
                }
                t.visibility_texture = r;
            }
            if let Some(r) = refine_coarse(f)? {
                t.refine_coarse = r;
            }
        }
        MethodOptions::Fog(g) => {
            if let Some(order) = f.order {
                g.env_order = order;
            }
            if let Some(mode) = &f.fog {
                g.mode = match mode.as_str() {
                    "analytic" => relight_fog::FogMode::Analytic,
                    "opengl" => relight_fog::FogMode::OpenGl {
                        fog_color: glam::Vec3::splat(0.5),
                    },
                    other => bail!("--fog {other}: expected `analytic` or `opengl`"),
                };
            }
            if let Some(glow) = &f.env_glow {
                g.env_glow = match glow.as_str() {
                    "ball" => relight_fog::EnvGlow::Ball,
                    "thesis" => relight_fog::EnvGlow::Thesis { factorized: false },
                    "thesis-factorized" => relight_fog::EnvGlow::Thesis { factorized: true },
                    other => {
                        bail!(
                            "--env-glow {other}: expected `ball`, `thesis` or `thesis-factorized`"
                        )
                    }
                };
            }
        }
        MethodOptions::Ndf(o) => crate::ndf::apply_flags(o, f)?,
        MethodOptions::Nearfield(o) => crate::nearfield::apply_flags(o, f)?,
        MethodOptions::Ltc(_) => {}
    }
    Ok(o)
}
