//! The SH method's normal-map filtering mode (`--method sh --normal-filter
//! F`; sun-thesis-2008 §5.1, issue 14: "a filtering mode of the SH … methods
//! where it applies").
//!
//! # What it does
//! Plain normal mapping shades one normal per sample and aliases where a
//! pixel covers many texels. For a Lambertian object under the environment
//! the filtered form is eq. 5.7 with SH lighting, `Σ_lm L_lm Â_l γ_lm`
//! over the NDF `γ` of the pixel's uv footprint: what `relight_ndf`'s
//! method computes per pixel (per-vertex SH lighting in the tangent frame,
//! the footprint's NDF from its pyramids, Lambert's view mask and the
//! band-4+ tail), with the baselines (normalized MIP, Toksvig, LEAN) and
//! the vMF mixtures as its other filters. This mode runs that shading on
//! the scene's normal-mapped Lambertian objects and takes its pixels where
//! the SH frame shows those objects whole; every other pixel is the SH
//! method's own.
//!
//! # Where it applies
//! Lambertian objects (the BRDF probed by [`relight_ndf::colour_of`]) with
//! a normal map. A normal-mapped object with another BRDF keeps plain
//! normal mapping, and the method's warnings say so by object. Pixels
//! the objects cover only in part (silhouettes at `aa > 1`) keep the SH
//! method's plain shading.

use relight_ndf::{NdfBrdf, NdfFilter, NdfMethod, NdfOptions};
use relight_render::method::{FrameRequest, MethodError, Relighter, Rendered};
use relight_render::{Numbered, Progress, Scene};

/// The filtering mode of one prepared scene: the `ndf` shading of its
/// filtered objects.
pub(crate) struct Filtered {
    method: NdfMethod,
    /// Indices (in the scene) of the filtered objects, in order.
    objects: Vec<usize>,
    /// The scene of the filtered objects as last lit (the environment is
    /// copied at each lighting change, not per frame).
    sub: Scene,
}

impl Filtered {
    /// The mode for `scene` with `filter`, prepared (`None` when no object
    /// of `scene` is a normal-mapped Lambertian), and one warning per
    /// normal-mapped object it does not apply to.
    ///
    /// # Errors
    /// The `ndf` method's (bad options, cancellation).
    pub(crate) fn prepare(
        filter: NdfFilter,
        scene: &Scene,
        progress: &dyn Progress,
    ) -> Result<(Option<Self>, Vec<String>), MethodError> {
        let mut objects = Vec::new();
        let mut warnings = Vec::new();
        for (i, o) in scene.objects.iter().enumerate() {
            if o.normal_map.is_none() {
                continue;
            }
            match relight_ndf::colour_of(o.brdf.as_ref(), NdfBrdf::Lambert) {
                Ok(_) => objects.push(i),
                Err(_) => warnings.push(format!(
                    "method sh: --normal-filter {} applies to Lambertian objects; {} keeps plain normal mapping",
                    filter.name(),
                    Numbered::object(i)
                )),
            }
        }
        if objects.is_empty() {
            return Ok((None, warnings));
        }
        let mut method = NdfMethod::new(NdfOptions {
            filter,
            brdf: NdfBrdf::Lambert,
            ..NdfOptions::default()
        })?;
        let sub = sub_scene(scene, &objects);
        method.prepare(&sub, progress)?;
        Ok((
            Some(Self {
                method,
                objects,
                sub,
            }),
            warnings,
        ))
    }

    /// Gives the filtered objects `scene`'s lighting.
    pub(crate) fn set_lighting(
        &mut self,
        scene: &Scene,
        progress: &dyn Progress,
    ) -> Result<f64, MethodError> {
        self.sub = sub_scene(scene, &self.objects);
        self.method.set_lighting(&self.sub, progress)
    }

    /// Draws the filtered objects for `request` (their meshes as prepared:
    /// the SH method checks that the scene's are the same) and puts their
    /// pixels into `frame` (the SH method's frame of the same request)
    /// wherever both frames show the same filtered object over the whole
    /// pixel.
    pub(crate) fn composite(
        &mut self,
        request: &FrameRequest,
        frame: &mut Rendered,
        progress: &dyn Progress,
    ) -> Result<(), MethodError> {
        let own = self.method.render(&self.sub, request, progress)?;
        let (Some(all), Some(sub)) = (frame.coverage.as_deref(), own.coverage.as_deref()) else {
            return Ok(());
        };
        for (p, px) in frame.image.pixels.iter_mut().enumerate() {
            let (id, sub_id) = (all.object_id[p], sub.object_id[p]);
            if sub_id == 0 || all.coverage[p] < 1.0 || sub.coverage[p] < 1.0 {
                continue;
            }
            if id as usize == self.objects[sub_id as usize - 1] + 1 {
                *px = own.image.pixels[p];
            }
        }
        frame.timings.view_ms += own.timings.view_ms;
        Ok(())
    }
}

/// `scene` with only the objects `keep` (same meshes, maps and BRDFs; the
/// same lighting and camera).
fn sub_scene(scene: &Scene, keep: &[usize]) -> Scene {
    let mut s = scene.clone();
    s.objects = keep.iter().map(|&i| scene.objects[i].clone()).collect();
    s
}
