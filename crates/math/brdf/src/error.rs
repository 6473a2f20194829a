//! [`BrdfError`]: everything that can go wrong building a BRDF.

/// Why a BRDF could not be built, parsed or read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BrdfError {
    /// A model parameter is outside its documented range.
    #[error("{model} BRDF: parameter `{param}` = {value} is out of range; expected {expected}")]
    OutOfRange {
        /// Model name as in the spec syntax (`ggx`, `phong`, …).
        model: &'static str,
        /// Parameter name (`alpha`, `exponent`, `colour`, …).
        param: &'static str,
        /// The rejected value.
        value: f32,
        /// The accepted range, in words.
        expected: &'static str,
    },
    /// A spec string names no known model.
    #[error("unknown BRDF `{name}`; known: {}", crate::spec::KNOWN_SPECS)]
    UnknownModel {
        /// The name as written.
        name: String,
    },
    /// A spec string is malformed (wrong parameter count, not a number, …).
    #[error("invalid BRDF spec `{spec}`: {problem}")]
    Spec {
        /// The whole spec (or the offending term).
        spec: String,
        /// What is wrong and how to write it.
        problem: String,
    },
    /// A MERL buffer ends before the data its header announces.
    #[error("MERL data truncated: header announces {needed} bytes, buffer has {got}")]
    MerlTruncated {
        /// Bytes required by the header.
        needed: usize,
        /// Bytes present.
        got: usize,
    },
    /// A MERL buffer's header dimensions are unusable.
    #[error("MERL data has invalid dimensions {dims:?}: {problem}")]
    MerlDims {
        /// The three header integers (θ_h, θ_d, φ_d resolutions).
        dims: [i64; 3],
        /// What is wrong.
        problem: &'static str,
    },
    /// A MERL buffer holds more bytes than its header announces.
    #[error("MERL data has {extra} trailing bytes after the {needed} its header announces")]
    MerlTrailing {
        /// Bytes required by the header.
        needed: usize,
        /// Bytes beyond those.
        extra: usize,
    },
    /// A MERL buffer holds NaN or infinite reflectance values.
    #[error("MERL data holds {count} non-finite values (first at value index {first})")]
    MerlNonFinite {
        /// How many values are NaN/±∞.
        count: usize,
        /// Index (0-based, over all 3·n values) of the first one.
        first: usize,
    },
}

/// Checks that `value` is finite and in `[lo, hi]`.
pub(crate) fn check_range(
    model: &'static str,
    param: &'static str,
    value: f32,
    lo: f32,
    hi: f32,
    expected: &'static str,
) -> Result<f32, BrdfError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(value)
    } else {
        Err(BrdfError::OutOfRange {
            model,
            param,
            value,
            expected,
        })
    }
}

/// Checks an RGB reflectance: every channel finite and in `[0, 1]`.
pub(crate) fn check_colour(
    model: &'static str,
    param: &'static str,
    c: glam::Vec3,
) -> Result<glam::Vec3, BrdfError> {
    for v in c.to_array() {
        check_range(
            model,
            param,
            v,
            0.0,
            1.0,
            "each RGB channel finite in [0, 1]",
        )?;
    }
    Ok(c)
}
