//! [`BrdfSpec`]: the one-line BRDF syntax used on the command line, in scene
//! files and in bake cache keys.
//!
//! ```text
//! spec  := term ('+' term)*
//! term  := [WEIGHT '*'] name [':' p1 (',' pk)*] ['@' r ',' g ',' b]
//! ```
//!
//! | spec                      | model                       | parameters |
//! |---------------------------|-----------------------------|------------|
//! | `lambert`, `lambert:0.8`  | [`Lambert`]                 | grey albedo (default 1) |
//! | `phong:EXP`               | [`Phong`]                   | exponent n |
//! | `blinn:EXP`               | [`BlinnPhong`]              | exponent n |
//! | `ward:A`, `ward:AX,AY`    | [`Ward`]                    | RMS slope α |
//! | `ggx:A`, `ggx:AX,AY`      | [`Ggx`]                     | roughness α; colour = F₀ |
//! | `ashikhmin:NU,NV[,RS]`, `ashikhmin:NU,NV,R,G,B` | [`AshikhminShirley`] | exponents, specular R_s (default 0.04); colour = R_d |
//! | `oren-nayar:SIGMA`        | [`OrenNayar`]               | σ in radians |
//!
//! The optional `@r,g,b` suffix is the model's RGB reflectance colour
//! (default white, 1,1,1), multiplied into `lambert`'s grey albedo. Several
//! weighted terms make a [`Mix`], e.g. `0.8*lambert@0.8,0.2,0.2+0.2*ggx:0.1`.
//! Aliases: `blinn-phong`, `cook-torrance`, `ashikhmin-shirley`, `orennayar`.
//!
//! [`Display`](std::fmt::Display) writes the canonical form (defaults
//! omitted); parsing it gives back an equal spec, so it is safe as a cache key.

use crate::{
    AshikhminShirley, BlinnPhong, Brdf, BrdfError, Ggx, Lambert, Mix, OrenNayar, Phong, Ward,
};
use glam::Vec3;
use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

/// The known spec forms, listed in error messages.
pub const KNOWN_SPECS: &str = "lambert[:ALBEDO], phong:EXP, blinn:EXP, ward:ALPHA | ward:AX,AY, \
    ggx:ALPHA | ggx:AX,AY, ashikhmin:NU,NV[,RS], oren-nayar:SIGMA (each with optional @r,g,b; \
    mix as W*SPEC+W*SPEC)";

/// A parsed, validated BRDF description (module docs). Each variant holds a
/// constructed model, so [`BrdfSpec::build`] cannot fail.
#[derive(Clone, Debug, PartialEq)]
pub enum BrdfSpec {
    /// `lambert[:ALBEDO]`.
    Lambert(Lambert),
    /// `phong:EXP`.
    Phong(Phong),
    /// `blinn:EXP`.
    BlinnPhong(BlinnPhong),
    /// `ward:A` / `ward:AX,AY`.
    Ward(Ward),
    /// `ggx:A` / `ggx:AX,AY`.
    Ggx(Ggx),
    /// `ashikhmin:NU,NV[,RS]`.
    AshikhminShirley(AshikhminShirley),
    /// `oren-nayar:SIGMA`.
    OrenNayar(OrenNayar),
    /// `W*SPEC+W*SPEC…`.
    Mix(MixSpec),
}

/// Validated weighted terms of a mixture spec (no nested mixtures).
#[derive(Clone, Debug, PartialEq)]
pub struct MixSpec {
    terms: Vec<(f32, BrdfSpec)>,
}

impl MixSpec {
    /// Weights each in [0, 1], summing to (0, 1]; terms may not be mixtures.
    pub fn new(terms: Vec<(f32, BrdfSpec)>) -> Result<Self, BrdfError> {
        crate::mix::check_weights(terms.iter().map(|t| t.0))?;
        if terms.iter().any(|t| matches!(t.1, BrdfSpec::Mix(_))) {
            return Err(BrdfError::Spec {
                spec: String::new(),
                problem: "a mix term cannot itself be a mix".into(),
            });
        }
        Ok(Self { terms })
    }
    /// The (weight, spec) terms.
    #[must_use]
    pub fn terms(&self) -> &[(f32, BrdfSpec)] {
        &self.terms
    }
}

impl BrdfSpec {
    /// The model this spec describes, ready to share across threads.
    #[must_use]
    pub fn build(&self) -> Arc<dyn Brdf> {
        match self {
            Self::Lambert(m) => Arc::new(*m),
            Self::Phong(m) => Arc::new(*m),
            Self::BlinnPhong(m) => Arc::new(*m),
            Self::Ward(m) => Arc::new(*m),
            Self::Ggx(m) => Arc::new(*m),
            Self::AshikhminShirley(m) => Arc::new(*m),
            Self::OrenNayar(m) => Arc::new(*m),
            Self::Mix(m) => Arc::new(Mix::from_checked(
                m.terms.iter().map(|(w, s)| (*w, s.build())).collect(),
            )),
        }
    }

    /// The canonical model name (`mix` for mixtures).
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Lambert(_) => "lambert",
            Self::Phong(_) => "phong",
            Self::BlinnPhong(_) => "blinn",
            Self::Ward(_) => "ward",
            Self::Ggx(_) => "ggx",
            Self::AshikhminShirley(_) => "ashikhmin",
            Self::OrenNayar(_) => "oren-nayar",
            Self::Mix(_) => "mix",
        }
    }
}

fn spec_err(spec: &str, problem: impl Into<String>) -> BrdfError {
    BrdfError::Spec {
        spec: spec.to_string(),
        problem: problem.into(),
    }
}

fn parse_num(term: &str, what: &str, s: &str) -> Result<f32, BrdfError> {
    s.trim()
        .parse::<f32>()
        .map_err(|_| spec_err(term, format!("{what} `{}` is not a number", s.trim())))
}

/// Splits on '+' except inside exponents such as `1e+3`.
fn split_terms(s: &str) -> Vec<&str> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut start = 0;
    for i in 0..b.len() {
        let in_exponent = i >= 2
            && matches!(b[i - 1], b'e' | b'E')
            && b[i - 2].is_ascii_digit()
            && b.get(i + 1).is_some_and(u8::is_ascii_digit);
        if b[i] == b'+' && !in_exponent {
            out.push(&s[start..i]);
            start = i + 1;
        }
    }
    out.push(&s[start..]);
    out
}

fn parse_term(term: &str) -> Result<BrdfSpec, BrdfError> {
    let (body, colour) = match term.split_once('@') {
        Some((body, c)) => {
            let cs: Vec<&str> = c.split(',').collect();
            if cs.len() != 3 {
                return Err(spec_err(
                    term,
                    "colour suffix must be @r,g,b (three numbers in [0, 1])",
                ));
            }
            let mut v = [0.0; 3];
            for (k, s) in cs.iter().enumerate() {
                v[k] = parse_num(term, "colour channel", s)?;
            }
            (body, Vec3::from_array(v))
        }
        None => (term, Vec3::ONE),
    };
    let (name, params) = match body.split_once(':') {
        Some((n, p)) => (n.trim(), p.split(',').collect::<Vec<_>>()),
        None => (body.trim(), Vec::new()),
    };
    let name = name.to_ascii_lowercase();
    let mut p = Vec::with_capacity(params.len());
    for s in &params {
        p.push(parse_num(term, &format!("{name} parameter"), s)?);
    }
    let arity = |ok: &[usize], form: &str| -> Result<(), BrdfError> {
        if ok.contains(&p.len()) {
            Ok(())
        } else {
            Err(spec_err(
                term,
                format!("expected {form}, got {} parameter(s)", p.len()),
            ))
        }
    };
    Ok(match name.as_str() {
        "lambert" => {
            arity(&[0, 1], "lambert or lambert:ALBEDO")?;
            BrdfSpec::Lambert(Lambert::new(colour * p.first().copied().unwrap_or(1.0))?)
        }
        "phong" => {
            arity(&[1], "phong:EXP")?;
            BrdfSpec::Phong(Phong::new(p[0], colour)?)
        }
        "blinn" | "blinn-phong" => {
            arity(&[1], "blinn:EXP")?;
            BrdfSpec::BlinnPhong(BlinnPhong::new(p[0], colour)?)
        }
        "ward" => {
            arity(&[1, 2], "ward:ALPHA or ward:AX,AY")?;
            BrdfSpec::Ward(Ward::new(p[0], *p.last().unwrap_or(&p[0]), colour)?)
        }
        "ggx" | "cook-torrance" => {
            arity(&[1, 2], "ggx:ALPHA or ggx:AX,AY")?;
            BrdfSpec::Ggx(Ggx::new(p[0], *p.last().unwrap_or(&p[0]), colour)?)
        }
        "ashikhmin" | "ashikhmin-shirley" => {
            arity(
                &[2, 3, 5],
                "ashikhmin:NU,NV, ashikhmin:NU,NV,RS or ashikhmin:NU,NV,R,G,B",
            )?;
            let rs = match p.len() {
                2 => Vec3::splat(AshikhminShirley::DEFAULT_RS),
                3 => Vec3::splat(p[2]),
                _ => Vec3::new(p[2], p[3], p[4]),
            };
            BrdfSpec::AshikhminShirley(AshikhminShirley::new(p[0], p[1], colour, rs)?)
        }
        "oren-nayar" | "orennayar" => {
            arity(&[1], "oren-nayar:SIGMA (radians)")?;
            BrdfSpec::OrenNayar(OrenNayar::new(p[0], colour)?)
        }
        _ => {
            return Err(BrdfError::UnknownModel {
                name: name.to_string(),
            });
        }
    })
}

impl FromStr for BrdfSpec {
    type Err = BrdfError;
    fn from_str(s: &str) -> Result<Self, BrdfError> {
        let s = s.trim();
        if s.is_empty() {
            return Err(spec_err(s, format!("empty; known: {KNOWN_SPECS}")));
        }
        let terms = split_terms(s);
        let weighted = terms.len() > 1 || terms[0].contains('*');
        if !weighted {
            return parse_term(terms[0]);
        }
        let mut out = Vec::with_capacity(terms.len());
        for t in terms {
            let (w, body) = t.split_once('*').ok_or_else(|| {
                spec_err(
                    s,
                    format!("mix term `{t}` needs a weight, as in 0.5*{}", t.trim()),
                )
            })?;
            out.push((parse_num(s, "mix weight", w)?, parse_term(body)?));
        }
        Ok(Self::Mix(MixSpec::new(out).map_err(|e| match e {
            BrdfError::Spec { problem, .. } => spec_err(s, problem),
            e => e,
        })?))
    }
}

fn is_grey(c: Vec3) -> bool {
    c.x == c.y && c.y == c.z
}

fn write_colour(f: &mut fmt::Formatter<'_>, c: Vec3) -> fmt::Result {
    if c != Vec3::ONE {
        write!(f, "@{},{},{}", c.x, c.y, c.z)
    } else {
        Ok(())
    }
}

fn write_alpha(f: &mut fmt::Formatter<'_>, name: &str, (ax, ay): (f32, f32)) -> fmt::Result {
    if ax == ay {
        write!(f, "{name}:{ax}")
    } else {
        write!(f, "{name}:{ax},{ay}")
    }
}

impl fmt::Display for BrdfSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Lambert(m) => {
                let a = m.albedo();
                if a == Vec3::ONE {
                    write!(f, "lambert")
                } else if is_grey(a) {
                    write!(f, "lambert:{}", a.x)
                } else {
                    write!(f, "lambert@{},{},{}", a.x, a.y, a.z)
                }
            }
            Self::Phong(m) => {
                write!(f, "phong:{}", m.exponent())?;
                write_colour(f, m.colour())
            }
            Self::BlinnPhong(m) => {
                write!(f, "blinn:{}", m.exponent())?;
                write_colour(f, m.colour())
            }
            Self::Ward(m) => {
                write_alpha(f, "ward", m.alpha())?;
                write_colour(f, m.colour())
            }
            Self::Ggx(m) => {
                write_alpha(f, "ggx", m.alpha())?;
                write_colour(f, m.f0())
            }
            Self::AshikhminShirley(m) => {
                let (nu, nv) = m.exponents();
                let rs = m.rs();
                write!(f, "ashikhmin:{nu},{nv}")?;
                if !is_grey(rs) {
                    write!(f, ",{},{},{}", rs.x, rs.y, rs.z)?;
                } else if rs.x != AshikhminShirley::DEFAULT_RS {
                    write!(f, ",{}", rs.x)?;
                }
                write_colour(f, m.rd())
            }
            Self::OrenNayar(m) => {
                write!(f, "oren-nayar:{}", m.sigma())?;
                write_colour(f, m.albedo())
            }
            Self::Mix(m) => {
                for (k, (w, s)) in m.terms.iter().enumerate() {
                    if k > 0 {
                        write!(f, "+")?;
                    }
                    write!(f, "{w}*{s}")?;
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parse(s: &str) -> BrdfSpec {
        s.parse()
            .unwrap_or_else(|e| panic!("`{s}` should parse: {e}"))
    }

    #[test]
    fn known_forms_parse_to_their_models() {
        assert_eq!(
            parse("lambert"),
            BrdfSpec::Lambert(Lambert::new(Vec3::ONE).unwrap())
        );
        assert_eq!(
            parse("lambert:0.8"),
            BrdfSpec::Lambert(Lambert::new(Vec3::splat(0.8)).unwrap())
        );
        assert_eq!(
            parse("lambert:0.5@1,0.5,0"),
            BrdfSpec::Lambert(Lambert::new(Vec3::new(0.5, 0.25, 0.0)).unwrap())
        );
        assert_eq!(
            parse("phong:20"),
            BrdfSpec::Phong(Phong::new(20.0, Vec3::ONE).unwrap())
        );
        assert_eq!(
            parse(" Blinn-Phong:8 "),
            BrdfSpec::BlinnPhong(BlinnPhong::new(8.0, Vec3::ONE).unwrap())
        );
        assert_eq!(
            parse("ward:0.2"),
            BrdfSpec::Ward(Ward::new(0.2, 0.2, Vec3::ONE).unwrap())
        );
        assert_eq!(
            parse("ward:0.1,0.3"),
            BrdfSpec::Ward(Ward::new(0.1, 0.3, Vec3::ONE).unwrap())
        );
        assert_eq!(
            parse("ggx:0.2@1,0.8,0.6"),
            BrdfSpec::Ggx(Ggx::new(0.2, 0.2, Vec3::new(1.0, 0.8, 0.6)).unwrap())
        );
        assert_eq!(
            parse("ashikhmin:100,10"),
            BrdfSpec::AshikhminShirley(
                AshikhminShirley::new(100.0, 10.0, Vec3::ONE, Vec3::splat(0.04)).unwrap()
            )
        );
        assert_eq!(
            parse("ashikhmin:1,2,0.9,0.5,0.1@0.2,0.2,0.2"),
            BrdfSpec::AshikhminShirley(
                AshikhminShirley::new(1.0, 2.0, Vec3::splat(0.2), Vec3::new(0.9, 0.5, 0.1))
                    .unwrap()
            )
        );
        assert_eq!(
            parse("oren-nayar:0.3"),
            BrdfSpec::OrenNayar(OrenNayar::new(0.3, Vec3::ONE).unwrap())
        );
        let BrdfSpec::Mix(m) = parse("0.7*lambert+0.3*ggx:1e-1") else {
            panic!("not a mix")
        };
        assert_eq!(m.terms().len(), 2);
        assert_eq!(m.terms()[1], (0.3, parse("ggx:0.1")));
    }

    #[test]
    fn display_round_trips() {
        for s in [
            "lambert",
            "lambert:0.25",
            "lambert@0.5,0.25,0",
            "phong:20@1,0.5,0.5",
            "blinn:300",
            "ward:0.2",
            "ward:0.1,0.3@0.5,0.5,0.5",
            "ggx:0.2",
            "ggx:0.05,0.6@1,0.8,0.6",
            "ashikhmin:100,10",
            "ashikhmin:100,10,0.5@0.2,0.3,0.4",
            "ashikhmin:100,10,0.5,0.6,0.7",
            "oren-nayar:0.3@0.8,0.8,0.8",
            "0.7*lambert@0.8,0.1,0.1+0.3*ggx:0.1",
        ] {
            let spec = parse(s);
            assert_eq!(spec.to_string(), s, "canonical form of `{s}`");
            assert_eq!(parse(&spec.to_string()), spec, "round trip of `{s}`");
            assert_eq!(spec.build().label(), s, "the built model's label for `{s}`");
        }
        assert_eq!(parse("ggx:0.2,0.2@1,1,1").to_string(), "ggx:0.2");
        assert_eq!(parse("ashikhmin:1,1,0.04").to_string(), "ashikhmin:1,1");
    }

    proptest! {
        #[test]
        fn random_specs_round_trip(
            a in 1e-4f32..=1.0, b in 1e-4f32..=1.0, n in 0f32..1e4,
            r in 0f32..=1.0, g in 0f32..=1.0, bl in 0f32..=1.0, w in 0.01f32..0.99,
        ) {
            let c = Vec3::new(r, g, bl);
            for spec in [
                BrdfSpec::Ggx(Ggx::new(a, b, c).unwrap()),
                BrdfSpec::Ward(Ward::new(a, b, c).unwrap()),
                BrdfSpec::Phong(Phong::new(n, c).unwrap()),
                BrdfSpec::BlinnPhong(BlinnPhong::new(n, c).unwrap()),
                BrdfSpec::Lambert(Lambert::new(c).unwrap()),
                BrdfSpec::OrenNayar(OrenNayar::new(a, c).unwrap()),
                BrdfSpec::AshikhminShirley(AshikhminShirley::new(n, n * a, c, Vec3::new(b, a, r)).unwrap()),
                BrdfSpec::Mix(MixSpec::new(vec![
                    (w, BrdfSpec::Lambert(Lambert::new(c).unwrap())),
                    (1.0 - w, BrdfSpec::Ggx(Ggx::new(a, b, c).unwrap())),
                ]).unwrap()),
            ] {
                let text = spec.to_string();
                prop_assert_eq!(spec.build().label(), text.clone());
                prop_assert_eq!(text.parse::<BrdfSpec>(), Ok(spec), "{}", text);
            }
        }
    }

    fn err(s: &str) -> String {
        match s.parse::<BrdfSpec>() {
            Ok(b) => panic!("`{s}` should fail, got {b}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn bad_specs_explain_themselves() {
        let e = err("plastic:3");
        assert!(
            e.contains("unknown BRDF `plastic`")
                && e.contains("ggx:ALPHA")
                && e.contains("oren-nayar"),
            "{e}"
        );
        assert!(
            err("ggx").contains("expected ggx:ALPHA or ggx:AX,AY, got 0"),
            "{}",
            err("ggx")
        );
        assert!(
            err("ggx:0").contains("alpha_x") && err("ggx:0").contains("[1e-4, 1]"),
            "{}",
            err("ggx:0")
        );
        assert!(
            err("ggx:abc").contains("`abc` is not a number"),
            "{}",
            err("ggx:abc")
        );
        assert!(
            err("ggx:nan").contains("out of range"),
            "{}",
            err("ggx:nan")
        );
        assert!(err("phong:-1").contains("exponent"), "{}", err("phong:-1"));
        assert!(
            err("lambert@1,2,0").contains("albedo"),
            "{}",
            err("lambert@1,2,0")
        );
        assert!(
            err("lambert@1,1").contains("@r,g,b"),
            "{}",
            err("lambert@1,1")
        );
        assert!(
            err("oren-nayar:20").contains("radians"),
            "{}",
            err("oren-nayar:20")
        );
        assert!(
            err("ashikhmin:1,2,3,4").contains("got 4"),
            "{}",
            err("ashikhmin:1,2,3,4")
        );
        assert!(
            err("0.7*lambert+0.7*ggx:0.1").contains("sum of weights"),
            "{}",
            err("0.7*lambert+0.7*ggx:0.1")
        );
        assert!(
            err("lambert+ggx:0.1").contains("needs a weight"),
            "{}",
            err("lambert+ggx:0.1")
        );
        assert!(err("").contains("empty"), "{}", err(""));
    }
}
