//! [`RadianceCacheRelighter`]: the radiance cache behind the method interface
//! (`--method radiance-cache`). `prepare` tabulates the BRDFs' SH
//! coefficients; each frame builds its records anew (a camera change moves
//! the shading points) and shades direct light with the reference's code plus
//! the cached indirect light.

use crate::{
    RadCacheError, RadianceCacheOptions, brdf_sh::BrdfSh, render_radiance_cache, validate,
};
use relight_render::method::{
    FrameRequest, FrameTimings, MethodError, Relighter, Rendered, SceneFeature, Support,
};
use relight_render::{Progress, Scene};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

const NAME: &str = "radiance-cache";

/// The radiance cache as a [`Relighter`].
#[derive(Clone, Debug, Default)]
pub struct RadianceCacheRelighter {
    /// Its settings (defaults in [`RadianceCacheOptions::default`]).
    pub options: RadianceCacheOptions,
    tables: HashMap<usize, Arc<BrdfSh>>,
    last: Option<crate::CacheStats>,
}

impl RadianceCacheRelighter {
    /// A renderer with `options`.
    ///
    /// # Errors
    /// An option out of range, naming its flag.
    pub fn new(options: RadianceCacheOptions) -> Result<Self, MethodError> {
        validate(&options).map_err(method_error)?;
        Ok(Self {
            options,
            ..Self::default()
        })
    }

    /// The statistics of the last frame (records, rotations, …).
    #[must_use]
    pub fn last_stats(&self) -> Option<crate::CacheStats> {
        self.last
    }
}

fn method_error(e: RadCacheError) -> MethodError {
    match e {
        RadCacheError::Cancelled => MethodError::Cancelled,
        RadCacheError::InvalidOption { option, message } => MethodError::InvalidOption {
            method: NAME,
            option,
            message,
        },
        e => MethodError::failed(NAME, e),
    }
}

impl Relighter for RadianceCacheRelighter {
    fn name(&self) -> &'static str {
        NAME
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            SceneFeature::Medium => Support::No,
            SceneFeature::SpatiallyVaryingBrdf => {
                Support::Approximate("the blend's two BRDF tables are mixed by its weight")
            }
            _ => Support::Full,
        }
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        validate(&self.options).map_err(method_error)?;
        progress.start("radiance cache: BRDF tables", 1);
        self.tables = crate::brdf_tables(scene, self.options.order);
        progress.finish();
        Ok(())
    }

    fn set_lighting(
        &mut self,
        _scene: &Scene,
        _progress: &dyn Progress,
    ) -> Result<f64, MethodError> {
        // Records depend on the lighting; each frame builds its own.
        Ok(0.0)
    }

    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError> {
        request.validate(NAME)?;
        if self.tables.is_empty() && !scene.objects.is_empty() {
            self.tables = crate::brdf_tables(scene, self.options.order);
        }
        let t = Instant::now();
        let r = render_radiance_cache(
            scene,
            &request.camera,
            &self.options,
            &self.tables,
            0,
            progress,
        )
        .map_err(method_error)?;
        let mut image = r.direct;
        for (o, i) in image.pixels.iter_mut().zip(&r.indirect.pixels) {
            *o += *i;
        }
        self.last = Some(r.stats);
        Ok(Rendered {
            image,
            coverage: None,
            timings: FrameTimings {
                lighting_ms: 0.0,
                view_ms: t.elapsed().as_secs_f64() * 1e3,
            },
            noise: None,
        })
    }

    fn warnings(&self) -> Vec<String> {
        self.last
            .map(|s| {
                vec![format!(
                    "radiance cache: {} records, {} rotations ({} exact above β_lim)",
                    s.records, s.rotations, s.exact_rotations
                )]
            })
            .unwrap_or_default()
    }
}
