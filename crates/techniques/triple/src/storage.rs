//! How the three functions of Eq. 7 are stored (issue 12, "storage and
//! quantization"): every table is a sequence of **planes** of `stride` cell
//! values (one channel of one lighting frame or BRDF view, or one vertex's
//! visibility), kept as f32, or compactly:
//!
//! * **lighting as f16** ([`Planes::F16`]): an environment's sun texel can be
//!   10⁴ × its mean, so a fixed-point code with one scale per plane would
//!   lose the dim cells next to it; half floats keep 11 significant bits at
//!   every magnitude (relative step 2⁻¹¹ ≈ 4.9e-4, range to 65504 — the
//!   lighting of `relight`'s probes stays far below; larger values saturate
//!   to the largest half).
//! * **BRDF and visibility as 8 bits with a scale per function**
//!   ([`Planes::U8`]): each plane stores `round(v / s · 255)` with
//!   `s = max(plane)`, so each plane keeps 1/255 of its own peak; visibility
//!   (cell averages of a binary function, in [0, 1]) and the
//!   cosine-weighted BRDF term are non-negative.
//!
//! The kernel ([`crate::shade`]) reads planes through [`Cells`], folding a
//! plane's scale into its tap weight, so an 8-bit plane costs one
//! conversion per cell and no extra multiply. What each choice costs in the
//! image is a row of `relight verify triple`; the bytes are rows of
//! `relight bench triple`.

use half::f16;
use serde::Serialize;

/// Which storage the method keeps its tables in: all f32, all compact, or
/// one table compact (what `relight verify triple` charges each choice).
/// The method's default is [`crate::TripleOptions::default`]'s.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Storage {
    /// Every table as f32 (the reference form).
    F32,
    /// Lighting f16, BRDF and visibility 8-bit with a scale per function.
    Compact,
    /// Only the lighting as f16.
    LightingF16,
    /// Only the BRDF tables as 8-bit.
    BrdfU8,
    /// Only the visibility as 8-bit.
    VisibilityU8,
}

impl Storage {
    /// Every storage, f32 first.
    pub const ALL: [Storage; 5] = [
        Self::F32,
        Self::Compact,
        Self::LightingF16,
        Self::BrdfU8,
        Self::VisibilityU8,
    ];

    /// The name on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::F32 => "f32",
            Self::Compact => "compact",
            Self::LightingF16 => "lighting-f16",
            Self::BrdfU8 => "brdf-u8",
            Self::VisibilityU8 => "visibility-u8",
        }
    }

    /// The lighting is kept as f16.
    #[must_use]
    pub fn lighting_f16(self) -> bool {
        matches!(self, Self::Compact | Self::LightingF16)
    }

    /// The BRDF tables are kept as 8-bit.
    #[must_use]
    pub fn brdf_u8(self) -> bool {
        matches!(self, Self::Compact | Self::BrdfU8)
    }

    /// The visibility is kept as 8-bit.
    #[must_use]
    pub fn visibility_u8(self) -> bool {
        matches!(self, Self::Compact | Self::VisibilityU8)
    }
}

impl std::str::FromStr for Storage {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown storage {s:?}: use f32, compact (lighting f16, BRDF and visibility \
                 8-bit), lighting-f16, brdf-u8 or visibility-u8"
                )
            })
    }
}

/// A table's planes (module docs).
#[derive(Clone, Debug, PartialEq)]
pub enum Planes {
    F32(Vec<f32>),
    /// Half-float bit patterns.
    F16(Vec<u16>),
    /// `value = code · scales[plane]` (the scale already divided by 255).
    U8 {
        codes: Vec<u8>,
        scales: Vec<f32>,
    },
}

/// No planes (f32).
impl Default for Planes {
    fn default() -> Self {
        Self::F32(Vec::new())
    }
}

impl Planes {
    /// `values` as f16 (values beyond the half range saturate).
    #[must_use]
    pub fn f16(values: &[f32]) -> Self {
        Self::F16(
            values
                .iter()
                .map(|&v| f16::from_f32(v.clamp(-f16::MAX.to_f32(), f16::MAX.to_f32())).to_bits())
                .collect(),
        )
    }

    /// `values` as 8-bit codes with one scale per plane of `stride`
    /// (negative values clamp to 0).
    ///
    /// # Panics
    /// If `stride` is 0.
    #[must_use]
    pub fn u8(values: &[f32], stride: usize) -> Self {
        assert!(stride > 0, "plane stride must be positive");
        let mut codes = Vec::with_capacity(values.len());
        let mut scales = Vec::with_capacity(values.len().div_ceil(stride));
        for plane in values.chunks(stride) {
            let peak = plane.iter().fold(0.0f32, |m, &v| m.max(v));
            let s = if peak > 0.0 && peak.is_finite() {
                peak / 255.0
            } else {
                0.0
            };
            let inv = if s > 0.0 { 1.0 / s } else { 0.0 };
            codes.extend(
                plane
                    .iter()
                    .map(|&v| (v.max(0.0) * inv).round().min(255.0) as u8),
            );
            scales.push(s);
        }
        Self::U8 { codes, scales }
    }

    /// Lighting planes: f16 when `half`, else f32.
    #[must_use]
    pub fn lighting(values: Vec<f32>, half: bool) -> Self {
        if half {
            Self::f16(&values)
        } else {
            Self::F32(values)
        }
    }

    /// BRDF or visibility planes of `stride`: 8-bit when `quantize`, else
    /// f32.
    #[must_use]
    pub fn scaled(values: Vec<f32>, stride: usize, quantize: bool) -> Self {
        if quantize {
            Self::u8(&values, stride)
        } else {
            Self::F32(values)
        }
    }

    /// Bytes held (codes and scales).
    #[must_use]
    pub fn bytes(&self) -> u64 {
        match self {
            Self::F32(v) => v.len() as u64 * 4,
            Self::F16(v) => v.len() as u64 * 2,
            Self::U8 { codes, scales } => codes.len() as u64 + scales.len() as u64 * 4,
        }
    }

    /// Values stored.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            Self::F32(v) => v.len(),
            Self::F16(v) => v.len(),
            Self::U8 { codes, .. } => codes.len(),
        }
    }

    /// No values.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i`, decoded (for tests and per-point tools, not the kernel).
    #[must_use]
    pub fn get(&self, i: usize, stride: usize) -> f32 {
        match self {
            Self::F32(v) => v[i],
            Self::F16(v) => f16::from_bits(v[i]).to_f32(),
            Self::U8 { codes, scales } => f32::from(codes[i]) * scales[i / stride],
        }
    }
}

/// Eight consecutive cells of a plane, as the kernel reads them; the
/// plane's scale is applied by the caller through [`Cells::scale`].
pub trait Cells: Sync {
    /// The cells at `offset .. offset + 8`, unscaled.
    fn load8(&self, offset: usize) -> [f32; 8];
    /// The scale of the plane starting at `plane_offset` (a multiple of the
    /// stride).
    fn scale(&self, plane_offset: usize) -> f32;
}

/// f32 planes.
pub struct F32Cells<'a>(pub &'a [f32]);

impl Cells for F32Cells<'_> {
    #[inline(always)]
    fn load8(&self, offset: usize) -> [f32; 8] {
        self.0[offset..offset + 8]
            .try_into()
            .expect("a slice of eight")
    }
    #[inline(always)]
    fn scale(&self, _: usize) -> f32 {
        1.0
    }
}

/// f16 planes.
pub struct F16Cells<'a>(pub &'a [u16]);

impl Cells for F16Cells<'_> {
    #[inline(always)]
    fn load8(&self, offset: usize) -> [f32; 8] {
        let s = &self.0[offset..offset + 8];
        let mut out = [0.0f32; 8];
        for i in 0..8 {
            out[i] = f16::from_bits(s[i]).to_f32();
        }
        out
    }
    #[inline(always)]
    fn scale(&self, _: usize) -> f32 {
        1.0
    }
}

/// 8-bit planes with a scale per plane of `stride`.
pub struct U8Cells<'a> {
    pub codes: &'a [u8],
    pub scales: &'a [f32],
    pub stride: usize,
}

impl Cells for U8Cells<'_> {
    #[inline(always)]
    fn load8(&self, offset: usize) -> [f32; 8] {
        let s = &self.codes[offset..offset + 8];
        let mut out = [0.0f32; 8];
        for i in 0..8 {
            out[i] = f32::from(s[i]);
        }
        out
    }
    #[inline(always)]
    fn scale(&self, plane_offset: usize) -> f32 {
        self.scales[plane_offset / self.stride]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_within_their_step() {
        let stride = 8;
        let v: Vec<f32> = (0..32)
            .map(|i| {
                if i < 8 {
                    9e3 * i as f32
                } else {
                    0.01 * i as f32
                }
            })
            .collect();
        let h = Planes::f16(&v);
        let q = Planes::u8(&v, stride);
        for (i, &x) in v.iter().enumerate() {
            let e = (h.get(i, stride) - x).abs();
            assert!(e <= x.abs() * 4.9e-4, "f16 {i}: {x} → {}", h.get(i, stride));
            let peak = v[i / stride * stride..(i / stride + 1) * stride]
                .iter()
                .fold(0.0f32, |m, &y| m.max(y));
            let e = (q.get(i, stride) - x).abs();
            assert!(
                e <= peak / 255.0 * 0.5 + 1e-6,
                "u8 {i}: {x} → {}",
                q.get(i, stride)
            );
        }
        assert_eq!(h.bytes(), 64);
        assert_eq!(q.bytes(), 32 + 4 * 4);
        // The kernel's view agrees with `get`.
        if let Planes::U8 { codes, scales } = &q {
            let c = U8Cells {
                codes,
                scales,
                stride,
            };
            for (i, v) in c.load8(8).iter().enumerate() {
                assert_eq!(v * c.scale(8), q.get(8 + i, stride));
            }
        }
        assert_eq!("compact".parse::<Storage>(), Ok(Storage::Compact));
        assert!("f8".parse::<Storage>().is_err());
    }
}
