//! The judge of `relight verify nearfield`'s image rows: one reference
//! render of a verify scene and the object pixels every figure is taken
//! over.
//!
//! Each image row is a relative RMS over the pixels the method's frame
//! covers (the sky behind the objects is read from the environment, nearly
//! noise-free, and would dilute the figure), and the reference's own noise
//! σ_MC is reported over the same pixels, so that a row and the noise it
//! carries are comparable. The error ladder's first rungs draw exact
//! per-vertex colours through the method's own raster
//! ([`ImageJudge::colors_error`]), so that they differ from the method's
//! rows only in the vertex colours.

use crate::method::NearfieldMethod;
use crate::verify::{VerifyOptions, VerifyRow, fail, magnitude_ranked_image, reference_render};
use glam::Vec3;
use relight_render::method::{FrameRequest, Relighter};
use relight_render::reference::ReferenceImage;
use relight_render::verify_row::row;
use relight_render::{Image, Progress, Scene};

/// A reference render, the object mask of the method's frame, and the
/// frame request both were drawn for.
pub(crate) struct ImageJudge {
    reference: ReferenceImage,
    mask: Vec<bool>,
    request: FrameRequest,
}

impl ImageJudge {
    /// Renders the reference of `scene` (Monte Carlo seed `seed`) and `m`'s
    /// frame of it as prepared and lit now, whose coverage gives the mask.
    /// Returns the judge and that frame's image.
    pub(crate) fn new(
        m: &mut NearfieldMethod,
        scene: &Scene,
        opts: &VerifyOptions,
        seed: u64,
        progress: &dyn Progress,
    ) -> Result<(Self, Image), String> {
        let reference = reference_render(scene, opts, seed, progress)?;
        let request = FrameRequest::new(scene.camera).with_aa(opts.aa);
        let frame = m.render(scene, &request, progress).map_err(fail)?;
        let mask = frame
            .coverage
            .as_ref()
            .map(|c| c.object_mask())
            .ok_or("the method's frame has no coverage")?;
        Ok((
            Self {
                reference,
                mask,
                request,
            },
            frame.image,
        ))
    }

    /// The same mask and request against the reference of a variant of the
    /// scene (same camera and objects, e.g. the light turned).
    pub(crate) fn with_reference(&self, reference: ReferenceImage) -> Self {
        Self {
            reference,
            mask: self.mask.clone(),
            request: self.request.clone(),
        }
    }

    /// Relative RMS of `image` against the reference over the object pixels.
    pub(crate) fn error(&self, image: &Image) -> f64 {
        image.relative_rms_error(&self.reference.image, Some(&self.mask))
    }

    /// The error of `m`'s frame of `scene` as lit now.
    pub(crate) fn render_error(
        &self,
        m: &mut NearfieldMethod,
        scene: &Scene,
        progress: &dyn Progress,
    ) -> Result<f64, String> {
        let r = m.render(scene, &self.request, progress).map_err(fail)?;
        Ok(self.error(&r.image))
    }

    /// The error of `m`'s frame with per-vertex `colors` (per object) in
    /// place of its own, which are restored afterwards.
    pub(crate) fn colors_error(
        &self,
        m: &mut NearfieldMethod,
        scene: &Scene,
        colors: Vec<Vec<Vec3>>,
        progress: &dyn Progress,
    ) -> Result<f64, String> {
        let saved = m.replace_colors(colors);
        let r = m.render(scene, &self.request, progress).map_err(fail);
        m.replace_colors(saved);
        Ok(self.error(&r?.image))
    }

    /// The error of `m`'s frame at 1 %/20 % with its sources ranked by
    /// magnitude (`m`'s own ranking restored after).
    pub(crate) fn magnitude_ranked_error(
        &self,
        m: &mut NearfieldMethod,
        scene: &Scene,
        progress: &dyn Progress,
    ) -> Result<f64, String> {
        Ok(self.error(&magnitude_ranked_image(m, scene, &self.request, progress)?))
    }

    /// The reported row of the reference's noise σ_MC over the object
    /// pixels, its label prefixed by `what` (e.g. `"glossy: "`).
    pub(crate) fn noise_row(&self, what: &str) -> VerifyRow {
        row(
            format!("{what}reference noise σ_MC ({} spp)", self.reference.spp),
            self.reference.rms_relative_std_error_over(&self.mask),
            "relative RMS",
            None,
            "relight_render::reference",
        )
    }
}

/// An image row: `error` as a relative RMS against the reference, with an
/// optional upper bound `gate` from `source`.
pub(crate) fn image_row(
    label: impl Into<String>,
    error: f64,
    gate: Option<f64>,
    source: &str,
) -> VerifyRow {
    row(
        label,
        error,
        "relative RMS vs reference",
        gate.map(|g| (g, true)),
        source,
    )
}
