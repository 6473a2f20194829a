//! `relight wavelet zoom`: image dilation and translation directly in the
//! Haar wavelet domain (thesis §4.6.2): forward Haar of each channel, keep
//! the largest source terms, propagate by the affine coupling coefficients
//! (`relight_affine::zoom::zoom_sparse`: only the couplings that can be
//! non-zero), inverse Haar. Equal to
//! inverse Haar → box resampling → forward Haar (checked by `relight verify
//! affine`); exact at 100 % (`--scale 1 --center 0.5,0.5`).

use anyhow::{Context, Result, bail};
use clap::Subcommand;
use glam::Vec3;
use std::path::PathBuf;
use std::time::Instant;

/// Wavelet-domain tools.
#[derive(Subcommand, Debug)]
pub enum WaveletCommand {
    /// Zoom an image in the wavelet domain (dilation about a centre).
    Zoom {
        /// Input image (square, side a power of two).
        input: PathBuf,
        /// Output image (.png tone mapped, .exr/.hdr linear).
        output: PathBuf,
        /// Magnification (> 0; 2 shows half the image twice as large).
        #[arg(long, default_value_t = 2.0)]
        scale: f64,
        /// Input point shown at the output's centre, as fractions X,Y (each in 0…1) of the width and height.
        #[arg(long, default_value = "0.5,0.5")]
        center: String,
        /// Source wavelet terms kept (largest RGB energy; ≥ 1); default all.
        #[arg(long)]
        terms: Option<usize>,
    },
}

/// Runs a `relight wavelet` command.
pub fn run(c: WaveletCommand) -> Result<()> {
    let WaveletCommand::Zoom {
        input,
        output,
        scale,
        center,
        terms,
    } = c;
    let c = crate::parse::parse_floats(&center, 2, "--center")?;
    let center = [f64::from(c[0]), f64::from(c[1])];
    if !(scale.is_finite() && scale > 0.0) {
        bail!("--scale: must be a finite number > 0, got {scale}");
    }
    // A centre off the image would show none of it: a black output.
    if !center.iter().all(|c| (0.0..=1.0).contains(c)) {
        bail!(
            "--center {},{}: each fraction must be in 0…1 (a centre off the image shows none of it)",
            c[0],
            c[1]
        );
    }
    if terms == Some(0) {
        bail!("--terms 0: keep at least one source term (none gives a black image)");
    }
    crate::output::check_output(&output, "output", &["exr", "hdr", "png"])?;
    let (img, _) = relight_assets::read_image(&input)?;
    let n = img.width;
    if img.height != n || !n.is_power_of_two() {
        bail!(
            "{}: wavelet zoom needs a square image with a power-of-two side, got {}×{}",
            input.display(),
            img.width,
            img.height
        );
    }
    let t0 = Instant::now();
    let mut coeffs: Vec<[f32; 3]> = img.pixels.iter().map(|p| p.to_array()).collect();
    relight_haar::try_forward_2d_rgb(&mut coeffs, n).context("forward Haar")?;
    let kept = relight_haar::top_k_rgb(
        &coeffs,
        n,
        terms.unwrap_or(n * n),
        relight_haar::Ranking::Magnitude,
    );
    let dense = kept.to_dense(n * n);
    let (s, o) = relight_affine::separable::zoom_transform(scale, center);
    let mut out = vec![[0.0f32; 3]; n * n];
    let mut chan = Vec::with_capacity(n * n);
    let mut res = vec![0.0f64; n * n];
    let mut scratch = relight_affine::zoom::ZoomScratch::default();
    for c in 0..3 {
        chan.clear();
        chan.extend(
            dense
                .iter()
                .enumerate()
                .filter(|(_, v)| v[c] != 0.0)
                .map(|(k, v)| (k as u32, v[c])),
        );
        relight_affine::zoom::zoom_sparse(&chan, n, s, o, n, &mut res, &mut scratch);
        for (d, v) in out.iter_mut().zip(&res) {
            d[c] = *v as f32;
        }
    }
    relight_haar::try_inverse_2d_rgb(&mut out, n).context("inverse Haar")?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let pixels: Vec<Vec3> = out
        .iter()
        .map(|p| Vec3::from_array(*p).max(Vec3::ZERO))
        .collect();
    relight_assets::write_image(&output, n, n, &pixels, relight_assets::ToneMap::default())?;
    eprintln!(
        "relight: zoomed {}× about ({:.3}, {:.3}) with {} of {} source terms in {ms:.1} ms; wrote {}",
        scale,
        center[0],
        center[1],
        kept.nnz(),
        n * n,
        output.display()
    );
    Ok(())
}
