//! The MERL measured isotropic BRDF format (Matusik, Pfister, Brand &
//! McMillan, *A Data-Driven Reflectance Model*, SIGGRAPH 2003), parsed from
//! bytes (the file is read by `relight-assets`).
//!
//! # Layout (little-endian)
//! | bytes            | content |
//! |------------------|---------|
//! | 0..12            | three `i32`: resolutions (n_θh, n_θd, n_φd), standard 90, 90, 180 |
//! | 12..12+8n        | `f64` red values, n = n_θh·n_θd·n_φd |
//! | …+8n, …+16n      | green, blue |
//!
//! Value index = (i_θh · n_θd + i_θd) · n_φd + i_φd (φ_d fastest). Stored
//! values are multiplied by the per-channel scales 1/1500, 1.15/1500,
//! 1.66/1500 to give f in sr⁻¹. Negative entries (unmeasured) read as 0.
//!
//! # Indexing (Rusinkiewicz half/difference angles)
//! ĥ = (wi + wo)/|wi + wo| has angles (θ_h, φ_h); the difference vector is wi
//! rotated by −φ_h about the normal and then by −θ_h about the bitangent,
//! with angles (θ_d, φ_d). Bins: i_θh = ⌊n_θh · √(θ_h/(π/2))⌋ (denser near
//! the specular peak), i_θd = ⌊n_θd · θ_d/(π/2)⌋, and φ_d folded into [0, π)
//! by reciprocity (φ_d < 0 ↦ φ_d + π), i_φd = ⌊n_φd · φ_d/π⌋; each clamped
//! into range. Lookup is nearest-bin, as in the MERL reference reader.
//!
//! [`Merl::from_fn`] tabulates any function at the bin centres and
//! [`Merl::to_bytes`] writes the format, so tests build files without data.
//! Sampling is cosine-weighted (density cos θ_i / π).

use crate::diffuse::{cosine_pdf, sample_cosine};
use crate::{Brdf, BrdfError, BrdfSample};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};

/// Per-channel scales from stored values to sr⁻¹ (R, G, B).
pub const MERL_SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];
/// The standard resolutions (n_θh, n_θd, n_φd) of MERL files.
pub const MERL_STANDARD_DIMS: [usize; 3] = [90, 90, 180];
/// Largest accepted resolution per axis (guards absurd headers).
pub const MERL_MAX_DIM: usize = 4096;

/// A tabulated isotropic BRDF in the MERL layout (module docs).
#[derive(Clone, PartialEq)]
pub struct Merl {
    dims: [usize; 3],
    /// RGB f (sr⁻¹, scales applied, negatives clamped), value-index order.
    rgb: Vec<[f32; 3]>,
    /// A 64-bit hash of `dims` and `rgb` (see [`Merl::fingerprint`]).
    fingerprint: u64,
}

impl std::fmt::Debug for Merl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Merl")
            .field("dims", &self.dims)
            .finish_non_exhaustive()
    }
}

/// (θ_h, θ_d, φ_d) of the pair (wi, wo), both unit.
#[must_use]
pub fn half_diff_angles(wi: Vec3, wo: Vec3) -> Option<(f32, f32, f32)> {
    let h = (wi + wo).try_normalize()?;
    let theta_h = h.z.clamp(-1.0, 1.0).acos();
    let phi_h = h.y.atan2(h.x);
    // diff = rot_y(rot_z(wi, −φ_h), −θ_h)
    let (s, c) = (-phi_h).sin_cos();
    let t = Vec3::new(wi.x * c - wi.y * s, wi.x * s + wi.y * c, wi.z);
    let (s, c) = (-theta_h).sin_cos();
    let d = Vec3::new(t.x * c + t.z * s, t.y, t.z * c - t.x * s);
    Some((theta_h, d.z.clamp(-1.0, 1.0).acos(), d.y.atan2(d.x)))
}

/// Inverse of [`half_diff_angles`] with φ_h = 0: returns (wi, wo).
#[must_use]
pub fn directions_from_half_diff(theta_h: f32, theta_d: f32, phi_d: f32) -> (Vec3, Vec3) {
    let h = Vec3::new(theta_h.sin(), 0.0, theta_h.cos());
    let d = Vec3::new(
        theta_d.sin() * phi_d.cos(),
        theta_d.sin() * phi_d.sin(),
        theta_d.cos(),
    );
    let (s, c) = theta_h.sin_cos();
    let wi = Vec3::new(d.x * c + d.z * s, d.y, d.z * c - d.x * s);
    let wo = 2.0 * wi.dot(h) * h - wi;
    (wi, wo)
}

impl Merl {
    fn new(dims: [usize; 3], rgb: Vec<[f32; 3]>) -> Self {
        // Four interleaved multiply–rotate streams over the values' bits, so
        // that hashing a standard table (4.4 M values) takes milliseconds.
        let mut h = [
            0x243F_6A88_85A3_08D3u64,
            0x1319_8A2E_0370_7344,
            0xA409_3822_299F_31D0,
            0x082E_FA98_EC4E_6C89,
        ];
        let mix = |h: u64, w: u64| (h ^ w).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(29);
        for (k, d) in dims.iter().enumerate() {
            h[k] = mix(h[k], *d as u64);
        }
        for (i, v) in rgb.iter().flatten().enumerate() {
            h[i & 3] = mix(h[i & 3], u64::from(v.to_bits()));
        }
        let fingerprint = h.iter().fold(rgb.len() as u64, |a, &x| mix(a, x));
        Self {
            dims,
            rgb,
            fingerprint,
        }
    }

    /// A 64-bit hash of the resolutions and every value, computed once at
    /// construction; [`Brdf::label`] carries it, so that caches keyed by the
    /// label tell two measured materials apart (`Debug` shows only `dims`).
    #[must_use]
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// Parses a MERL binary buffer (module docs). Errors: fewer than 12
    /// bytes or fewer than the header announces ([`BrdfError::MerlTruncated`]),
    /// non-positive or oversized dimensions ([`BrdfError::MerlDims`]),
    /// trailing bytes ([`BrdfError::MerlTrailing`]), NaN/∞ values.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, BrdfError> {
        if bytes.len() < 12 {
            return Err(BrdfError::MerlTruncated {
                needed: 12,
                got: bytes.len(),
            });
        }
        let mut raw = [0i64; 3];
        for (k, r) in raw.iter_mut().enumerate() {
            let b: [u8; 4] = bytes[4 * k..4 * k + 4].try_into().expect("4-byte slice");
            *r = i64::from(i32::from_le_bytes(b));
        }
        if raw.iter().any(|&d| d <= 0) {
            return Err(BrdfError::MerlDims {
                dims: raw,
                problem: "each must be positive",
            });
        }
        if raw.iter().any(|&d| d as usize > MERL_MAX_DIM) {
            return Err(BrdfError::MerlDims {
                dims: raw,
                problem: "each must be at most 4096",
            });
        }
        let dims = raw.map(|d| d as usize);
        let n = dims[0] * dims[1] * dims[2];
        let needed = 12 + 24 * n;
        if bytes.len() < needed {
            return Err(BrdfError::MerlTruncated {
                needed,
                got: bytes.len(),
            });
        }
        if bytes.len() > needed {
            return Err(BrdfError::MerlTrailing {
                needed,
                extra: bytes.len() - needed,
            });
        }
        let mut rgb = vec![[0.0f32; 3]; n];
        let (mut bad, mut first) = (0usize, usize::MAX);
        for (c, scale) in MERL_SCALE.iter().enumerate() {
            let chunk = &bytes[12 + 8 * n * c..12 + 8 * n * (c + 1)];
            for (i, (v, out)) in chunk.chunks_exact(8).zip(rgb.iter_mut()).enumerate() {
                let x = f64::from_le_bytes(v.try_into().expect("8-byte chunk"));
                if !x.is_finite() {
                    bad += 1;
                    first = first.min(c * n + i);
                }
                out[c] = (x * scale).max(0.0) as f32;
            }
        }
        if bad > 0 {
            return Err(BrdfError::MerlNonFinite { count: bad, first });
        }
        Ok(Self::new(dims, rgb))
    }

    /// Writes the MERL binary layout (values divided by [`MERL_SCALE`]).
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let n = self.rgb.len();
        let mut out = Vec::with_capacity(12 + 24 * n);
        for d in self.dims {
            out.extend_from_slice(&(d as i32).to_le_bytes());
        }
        for (c, scale) in MERL_SCALE.iter().enumerate() {
            for v in &self.rgb {
                out.extend_from_slice(&(f64::from(v[c]) / scale).to_le_bytes());
            }
        }
        out
    }

    /// Tabulates `f(wo, wi)` (sr⁻¹, RGB) at the bin centres of a table with
    /// resolutions `dims` = (n_θh, n_θd, n_φd), each in [1, 4096]. Negative
    /// or non-finite values are stored as 0.
    pub fn from_fn(dims: [usize; 3], f: impl Fn(Vec3, Vec3) -> Vec3) -> Result<Self, BrdfError> {
        if dims.iter().any(|&d| d == 0 || d > MERL_MAX_DIM) {
            return Err(BrdfError::MerlDims {
                dims: dims.map(|d| d as i64),
                problem: "each must be in [1, 4096]",
            });
        }
        let mut rgb = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for i in 0..dims[0] {
            let theta_h = ((i as f32 + 0.5) / dims[0] as f32).powi(2) * FRAC_PI_2;
            for j in 0..dims[1] {
                let theta_d = (j as f32 + 0.5) / dims[1] as f32 * FRAC_PI_2;
                for k in 0..dims[2] {
                    let phi_d = (k as f32 + 0.5) / dims[2] as f32 * PI;
                    let (wi, wo) = directions_from_half_diff(theta_h, theta_d, phi_d);
                    let v = f(wo, wi);
                    let v = if v.is_finite() {
                        v.max(Vec3::ZERO)
                    } else {
                        Vec3::ZERO
                    };
                    rgb.push(v.to_array());
                }
            }
        }
        Ok(Self::new(dims, rgb))
    }

    /// Resolutions (n_θh, n_θd, n_φd).
    #[must_use]
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Whether the table has the standard 90×90×180 resolution.
    #[must_use]
    pub fn is_standard_resolution(&self) -> bool {
        self.dims == MERL_STANDARD_DIMS
    }

    /// Value index of the bin holding (θ_h, θ_d, φ_d) (module docs).
    #[must_use]
    pub fn index(&self, theta_h: f32, theta_d: f32, phi_d: f32) -> usize {
        let [nh, nd, np] = self.dims;
        let bin = |x: f32, n: usize| ((x.max(0.0) * n as f32) as usize).min(n - 1);
        let ih = bin((theta_h.max(0.0) / FRAC_PI_2).sqrt(), nh);
        let id = bin(theta_d / FRAC_PI_2, nd);
        let phi_d = if phi_d < 0.0 { phi_d + PI } else { phi_d };
        let ip = bin(phi_d / PI, np);
        (ih * nd + id) * np + ip
    }
}

impl Brdf for Merl {
    /// `merl:90x90x180#<fingerprint>`: the table's resolutions and its hash.
    fn label(&self) -> String {
        let [a, b, c] = self.dims;
        format!("merl:{a}x{b}x{c}#{:016x}", self.fingerprint)
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        match half_diff_angles(wi, wo) {
            Some((th, td, pd)) => Vec3::from_array(self.rgb[self.index(th, td, pd)]),
            None => Vec3::ZERO,
        }
    }
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        sample_cosine(self, wo, u)
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        cosine_pdf(wo, wi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BlinnPhong;

    fn blinn() -> BlinnPhong {
        BlinnPhong::new(20.0, Vec3::new(1.0, 0.7, 0.4)).unwrap()
    }

    #[test]
    fn the_label_tells_measured_tables_apart() {
        let dims = [4, 4, 8];
        let a = Merl::from_fn(dims, |wo, wi| blinn().eval(wo, wi)).unwrap();
        let b = Merl::from_fn(dims, |wo, wi| 1.001 * blinn().eval(wo, wi)).unwrap();
        // The same values give the same label, through the file format too.
        let again = Merl::from_bytes(&a.to_bytes()).unwrap();
        assert_eq!(again.label(), a.label());
        assert!(a.label().starts_with("merl:4x4x8#"), "{}", a.label());
        // `Debug` cannot tell them apart; the label must.
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_ne!(a.label(), b.label());
        // One value changed by one ulp changes the fingerprint.
        let mut c = a.clone();
        c.rgb[17][1] = f32::from_bits(c.rgb[17][1].to_bits() + 1);
        assert_ne!(Merl::new(c.dims, c.rgb).fingerprint(), a.fingerprint());
    }

    #[test]
    fn half_diff_angles_of_known_configurations() {
        // Mirror pair in the xz-plane: ĥ = +Z, θ_d = θ_i, φ_d = 0 (wi towards +x).
        let a = 0.6f32;
        let wi = Vec3::new(a.sin(), 0.0, a.cos());
        let wo = Vec3::new(-a.sin(), 0.0, a.cos());
        let (th, td, pd) = half_diff_angles(wi, wo).unwrap();
        assert!(
            th.abs() < 1e-3 && (td - a).abs() < 1e-5 && pd.abs() < 1e-5,
            "{th} {td} {pd}"
        );
        // Retro-reflection: wi = wo, so ĥ = wi and θ_d = 0.
        let w = Vec3::new(0.3, 0.4, 0.866).normalize();
        let (th, td, _) = half_diff_angles(w, w).unwrap();
        assert!(
            (th - w.z.acos()).abs() < 1e-5 && td.abs() < 2e-3,
            "{th} {td}"
        );
        // Round trip through the inverse.
        for (th, td, pd) in [(0.3f32, 0.5f32, 1.0f32), (1.0, 0.2, 2.5), (0.05, 1.2, 0.4)] {
            let (wi, wo) = directions_from_half_diff(th, td, pd);
            let (a, b, c) = half_diff_angles(wi, wo).unwrap();
            assert!(
                (a - th).abs() < 1e-4 && (b - td).abs() < 1e-4 && (c - pd).abs() < 1e-4,
                "{a} {b} {c} vs {th} {td} {pd}"
            );
        }
    }

    #[test]
    fn bytes_round_trip_and_bin_centres_match_source() {
        let src = blinn();
        let m = Merl::from_fn([20, 20, 40], |wo, wi| src.eval(wo, wi)).unwrap();
        let bytes = m.to_bytes();
        assert_eq!(bytes.len(), 12 + 24 * 20 * 20 * 40);
        assert_eq!(&bytes[0..4], &20i32.to_le_bytes());
        let back = Merl::from_bytes(&bytes).unwrap();
        assert_eq!(back.dims(), [20, 20, 40]);
        for (a, b) in m.rgb.iter().zip(&back.rgb) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-6 * a[c].abs(), "{a:?} vs {b:?}");
            }
        }
        // At bin centres the table reproduces the source exactly.
        for (i, j, k) in [(0, 0, 0), (3, 7, 11), (10, 2, 39), (19, 5, 20), (6, 15, 1)] {
            let th = ((i as f32 + 0.5) / 20.0).powi(2) * FRAC_PI_2;
            let td = (j as f32 + 0.5) / 20.0 * FRAC_PI_2;
            let pd = (k as f32 + 0.5) / 40.0 * PI;
            let (wi, wo) = directions_from_half_diff(th, td, pd);
            if wi.z <= 0.0 || wo.z <= 0.0 {
                continue;
            }
            let (got, want) = (back.eval(wo, wi), src.eval(wo, wi));
            assert!(
                (got - want).abs().max_element() <= 1e-5 * want.max_element().max(1.0),
                "bin ({i},{j},{k}): {got} vs {want}"
            );
        }
    }

    #[test]
    fn standard_resolution_reproduces_albedo() {
        let src = blinn();
        let m = Merl::from_fn(MERL_STANDARD_DIMS, |wo, wi| src.eval(wo, wi)).unwrap();
        assert!(m.is_standard_resolution());
        let m = Merl::from_bytes(&m.to_bytes()).unwrap();
        for theta in [0.0f32, 30.0, 60.0] {
            let wo = crate::verify::direction_deg(theta, 40.0);
            let a = crate::verify::directional_albedo_quadrature(&m, wo, (256, 64));
            let b = crate::verify::directional_albedo_quadrature(&src, wo, (256, 64));
            assert!(
                (a - b).abs().max_element() < 0.02 * b.max_element(),
                "θo={theta}: MERL albedo {a} vs Blinn–Phong {b}"
            );
        }
    }

    #[test]
    fn bad_buffers_are_errors() {
        let good = Merl::from_fn([4, 4, 8], |_, _| Vec3::splat(0.3))
            .unwrap()
            .to_bytes();
        for len in [0, 3, 11, 12, 13, 100, good.len() - 1] {
            assert!(
                matches!(
                    Merl::from_bytes(&good[..len]),
                    Err(BrdfError::MerlTruncated { .. })
                ),
                "truncated to {len} bytes"
            );
        }
        let mut extra = good.clone();
        extra.push(0);
        assert_eq!(
            Merl::from_bytes(&extra),
            Err(BrdfError::MerlTrailing {
                needed: good.len(),
                extra: 1
            })
        );
        for dims in [
            [0, 4, 8],
            [4, -1, 8],
            [4, 4, 100_000],
            [i32::MAX, i32::MAX, i32::MAX],
        ] {
            let mut b = good.clone();
            for (k, d) in dims.iter().enumerate() {
                b[4 * k..4 * k + 4].copy_from_slice(&d.to_le_bytes());
            }
            let e = Merl::from_bytes(&b);
            assert!(
                matches!(e, Err(BrdfError::MerlDims { .. })),
                "dims {dims:?}: {e:?}"
            );
        }
        let mut nan = good.clone();
        nan[12 + 8 * 5..12 + 8 * 6].copy_from_slice(&f64::NAN.to_le_bytes());
        assert_eq!(
            Merl::from_bytes(&nan),
            Err(BrdfError::MerlNonFinite { count: 1, first: 5 })
        );
        // Negative (unmeasured) values read as zero.
        let mut neg = good;
        neg[12..20].copy_from_slice(&(-1.0f64).to_le_bytes());
        assert_eq!(Merl::from_bytes(&neg).unwrap().rgb[0][0], 0.0);
        let msg = Merl::from_bytes(&[0; 5]).unwrap_err().to_string();
        assert!(msg.contains("truncated") && msg.contains("12"), "{msg}");
    }
}
