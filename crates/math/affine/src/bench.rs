//! `relight bench affine`: the Fig. 4.6 curves, the §4.4.3 complexity
//! table, the §4.5.5 table's size and build time on its grid, the error its
//! quantisation adds, computational vs table propagation time, and the
//! §4.6.2 zoom against the pixel path.
//! Measured figures belong in docs/affine.md, not here.

use crate::sparsity::{ComplexityRow, CurvePoint, complexity_table, fig46_curves, random_sets};
use crate::table::{AccTable, Grid, quantisation_error};
use std::time::Instant;

/// The thesis' §4.5.5 table: (order, resolution, MB, seconds) on a 3 GHz
/// machine (one thread).
pub const THESIS_TABLE: [(usize, usize, f64, f64); 20] = [
    (8, 64, 0.26, 0.011),
    (8, 128, 1.05, 0.044),
    (8, 256, 4.22, 0.176),
    (8, 512, 16.92, 0.708),
    (8, 1024, 67.74, 2.760),
    (16, 64, 0.56, 0.029),
    (16, 128, 2.25, 0.114),
    (16, 256, 9.03, 0.457),
    (16, 512, 36.24, 1.801),
    (16, 1024, 145.09, 7.093),
    (32, 64, 1.15, 0.066),
    (32, 128, 4.65, 0.257),
    (32, 256, 18.66, 1.059),
    (32, 512, 74.81, 4.236),
    (32, 1024, 299.45, 16.871),
    (64, 64, 2.33, 0.147),
    (64, 128, 9.44, 0.589),
    (64, 256, 37.83, 2.368),
    (64, 512, 151.60, 9.498),
    (64, 1024, 606.78, 37.768),
];

/// One table size/time point.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TableRow {
    /// Wavelet order N.
    pub order: usize,
    /// Grid points per axis R (R² cells).
    pub res: usize,
    /// Stored non-zeros.
    pub nonzeros: usize,
    /// Size in MB (10⁶ bytes).
    pub mb: f64,
    /// Build time, seconds (one thread).
    pub build_s: f64,
    /// The thesis' size, MB.
    pub thesis_mb: f64,
    /// The thesis' time, s.
    pub thesis_s: f64,
    /// RMS relative L2 error of a propagated random signal, nearest cell.
    pub quant_err_nearest: f64,
    /// Same, bilinear blend of four cells.
    pub quant_err_bilinear: f64,
}

/// Propagation time per (s, o) query.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RowTimeRow {
    /// Order N.
    pub order: usize,
    /// `computational` (exact rows from M), `table_nearest`, `table_bilinear`.
    pub method: &'static str,
    /// Microseconds per propagation of a dense N-vector.
    pub us_per_query: f64,
}

/// All tables of the bench.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchAffine {
    /// Fig. 4.6.
    pub fig46: Vec<CurvePoint>,
    /// §4.4.3 at N = 256 (quick: 64) for three (s, o).
    pub complexity: Vec<ComplexityRow>,
    /// §4.5.5 table grid.
    pub table: Vec<TableRow>,
    /// Computational vs memory-based propagation.
    pub row_time: Vec<RowTimeRow>,
    /// §4.6.2 zoom: wavelet domain vs the pixel path.
    pub zoom: Vec<ZoomRow>,
}

/// One zoom timing (§4.6.2, Fig. 4.13): the wavelet path (source terms
/// kept → [`crate::zoom::zoom_sparse`], optionally only the coarse target
/// levels) against the pixel path (inverse Haar →
/// [`crate::separable::box_resample_2d`] → forward Haar) of the same
/// coefficients.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ZoomRow {
    /// Image side.
    pub n: usize,
    /// Magnification.
    pub scale: f64,
    /// Fraction of the n² source coefficients kept (largest |c|).
    pub source_terms: f64,
    /// Fraction of the n² target coefficients computed: the levels below
    /// `log₂ side`, `side²/n²` (Fig. 4.13's "dst" compression by level).
    pub target_terms: f64,
    /// Wavelet path, ms per zoom (one thread).
    pub wavelet_ms: f64,
    /// Pixel path, ms per zoom (one thread).
    pub pixel_ms: f64,
    /// `pixel_ms / wavelet_ms`.
    pub speedup: f64,
    /// Thesis target (Fig. 4.13 / issue 13): 15× at ≤ 5 %, 60× at ≤ 1 %.
    pub target: Option<f64>,
    /// `speedup ≥ target`.
    pub pass: Option<bool>,
    /// PSNR (dB) of the zoomed image against the pixel path of the full
    /// image (peak: its largest |pixel|).
    pub psnr_db: f64,
    /// Max |wavelet − pixel path| over the computed coefficients ÷ the
    /// largest |coefficient| (f32 transforms; the exactness check, ≤ 1e-5
    /// at 100 %).
    pub max_diff: f64,
    /// Where the target comes from.
    pub source: &'static str,
}

/// A synthetic photograph-like test image: smooth shading, a disc and a
/// step edge.
fn zoom_image(n: usize) -> Vec<f32> {
    (0..n * n)
        .map(|k| {
            let (x, y) = ((k % n) as f32 / n as f32, (k / n) as f32 / n as f32);
            let mut v = 0.45 + 0.25 * (6.0 * x).sin() * (4.0 * y).cos();
            if (x - 0.45).powi(2) + (y - 0.55).powi(2) < 0.04 {
                v += 0.3;
            }
            if x > 0.7 {
                v -= 0.15;
            }
            v
        })
        .collect()
}

/// Mean ms per call of `f`, repeated until at least `min_ms` have passed.
fn time_ms(min_ms: f64, mut f: impl FnMut()) -> f64 {
    let t0 = Instant::now();
    let mut reps = 0u32;
    loop {
        f();
        reps += 1;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        if ms >= min_ms {
            return ms / f64::from(reps);
        }
    }
}

/// The zoom rows: `n × n` image (256; quick 64), magnification 2 about
/// (0.45, 0.55); source terms 100 %, 5 %, 1 % with every target level, and
/// 5 % / 1 % with the target cut to the levels below `n/4` (6.25 %) and
/// `n/8` (1.56 %).
#[must_use]
pub fn zoom_rows(quick: bool) -> Vec<ZoomRow> {
    use crate::separable::{box_resample_2d, zoom_transform};
    use crate::zoom::{ZoomScratch, zoom_sparse};
    use relight_haar::{try_forward_2d, try_inverse_2d};
    let n = if quick { 64 } else { 256 };
    let min_ms = if quick { 2.0 } else { 40.0 };
    let scale = 2.0;
    let (s, o) = zoom_transform(scale, [0.45, 0.55]);
    let mut coeffs = zoom_image(n);
    if try_forward_2d(&mut coeffs, n).is_err() {
        return Vec::new();
    }
    // Pixel path: decompress, resample, recompress (Fig. 4.13's timing).
    let (mut img, mut tmp, mut px) = (
        vec![0.0f32; n * n],
        vec![0.0f32; n * n],
        vec![0.0f32; n * n],
    );
    let pixel_ms = time_ms(min_ms, || {
        img.copy_from_slice(&coeffs);
        let _ = try_inverse_2d(&mut img, n);
        box_resample_2d(&img, n, s, o, &mut tmp, &mut px);
        let _ = try_forward_2d(&mut px, n);
    });
    let mut want = px.clone();
    let _ = try_inverse_2d(&mut want, n);
    let peak = want.iter().fold(0.0f32, |a, &b| a.max(b.abs()));
    let top = px.iter().fold(0.0f64, |a, &b| a.max(f64::from(b).abs()));
    let mut order: Vec<usize> = (0..n * n).collect();
    order.sort_by(|&a, &b| coeffs[b].abs().total_cmp(&coeffs[a].abs()).then(a.cmp(&b)));
    let mut scratch = ZoomScratch::default();
    let mut rows = Vec::new();
    let cases = [
        (1.0, n, None),
        (0.05, n, Some(15.0)),
        (0.01, n, Some(60.0)),
        (0.05, n / 4, Some(15.0)),
        (0.01, n / 8, Some(60.0)),
    ];
    for (frac, side, target) in cases {
        let keep = ((frac * (n * n) as f64).round() as usize).clamp(1, n * n);
        let mut kept: Vec<usize> = order[..keep].to_vec();
        kept.sort_unstable();
        let src: Vec<(u32, f32)> = kept.iter().map(|&k| (k as u32, coeffs[k])).collect();
        let mut out = vec![0.0f64; side * side];
        let wavelet_ms = time_ms(min_ms, || {
            zoom_sparse(&src, n, s, o, side, &mut out, &mut scratch);
        });
        let mut max_diff = 0.0f64;
        let mut got = vec![0.0f32; n * n];
        for r in 0..side {
            for c in 0..side {
                let v = out[r * side + c];
                max_diff = max_diff.max((v - f64::from(px[r * n + c])).abs());
                got[r * n + c] = v as f32;
            }
        }
        let max_diff = max_diff / top.max(1e-30);
        let _ = try_inverse_2d(&mut got, n);
        let mse = got
            .iter()
            .zip(&want)
            .map(|(a, b)| f64::from(a - b).powi(2))
            .sum::<f64>()
            / (n * n) as f64;
        let psnr_db = 10.0 * (f64::from(peak).powi(2) / mse.max(1e-30)).log10();
        let speedup = pixel_ms / wavelet_ms;
        rows.push(ZoomRow {
            n,
            scale,
            source_terms: frac,
            target_terms: (side * side) as f64 / (n * n) as f64,
            wavelet_ms,
            pixel_ms,
            speedup,
            target,
            pass: target.map(|t| speedup >= t),
            psnr_db,
            max_diff,
            source: "sun-thesis-2008 Fig. 4.13; issue 13 (bench zoom)",
        });
    }
    rows
}

fn signal(n: usize) -> Vec<f64> {
    random_sets(n, 77).iter().map(|p| p.1).collect()
}

/// Runs the bench (`quick`: N ≤ 256 curves, R ≤ 128, orders 8–32).
#[must_use]
pub fn bench_affine(quick: bool) -> BenchAffine {
    let sets = random_sets(50, 1);
    let fig46 = fig46_curves(&sets, if quick { 256 } else { 4096 });
    let cn = if quick { 64 } else { 256 };
    let mut complexity = Vec::new();
    for (s, o) in [(1.0, 0.0), (2.0, 0.3), (0.37, -0.21)] {
        complexity.extend(complexity_table(cn, s, o));
    }
    let orders: &[usize] = if quick { &[8, 32] } else { &[8, 16, 32, 64] };
    let resolutions: &[usize] = if quick {
        &[64, 128]
    } else {
        &[64, 128, 256, 512]
    };
    let queries = random_sets(200, 4242);
    let mut table = Vec::new();
    let mut row_time = Vec::new();
    for &order in orders {
        let f = signal(order);
        for &res in resolutions {
            let t0 = Instant::now();
            let t = AccTable::build(order, Grid::standard(res));
            let build_s = t0.elapsed().as_secs_f64();
            let (en, eb) = quantisation_error(&t, &f, &queries);
            let thesis = THESIS_TABLE
                .iter()
                .find(|r| r.0 == order && r.1 == res)
                .map_or((f64::NAN, f64::NAN), |r| (r.2, r.3));
            table.push(TableRow {
                order,
                res,
                nonzeros: t.nonzeros(),
                mb: t.bytes() as f64 / 1e6,
                build_s,
                thesis_mb: thesis.0,
                thesis_s: thesis.1,
                quant_err_nearest: en,
                quant_err_bilinear: eb,
            });
            if res == 256 || (quick && res == 128) {
                row_time.extend(time_rows(&t, &f, &queries));
            }
        }
    }
    BenchAffine {
        fig46,
        complexity,
        table,
        row_time,
        zoom: zoom_rows(quick),
    }
}

fn time_rows(t: &AccTable, f: &[f64], queries: &[(f64, f64)]) -> Vec<RowTimeRow> {
    let n = f.len();
    let mut out = vec![0.0; n];
    let mut row = Vec::new();
    let reps = 20;
    let mut time = |g: &mut dyn FnMut(f64, f64, &mut [f64])| {
        let t0 = Instant::now();
        let mut sink = 0.0;
        for _ in 0..reps {
            for &(s, o) in queries {
                g(s, o, &mut out);
                sink += out[0];
            }
        }
        std::hint::black_box(sink);
        t0.elapsed().as_secs_f64() * 1e6 / (reps * queries.len()) as f64
    };
    let comp = time(&mut |s, o, out| crate::rows::propagate(f, s, o, out, &mut row));
    let near = time(&mut |s, o, out| t.propagate_nearest(f, s, o, out));
    let bil = time(&mut |s, o, out| t.propagate_bilinear(f, s, o, out));
    vec![
        RowTimeRow {
            order: n,
            method: "computational",
            us_per_query: comp,
        },
        RowTimeRow {
            order: n,
            method: "table_nearest",
            us_per_query: near,
        },
        RowTimeRow {
            order: n,
            method: "table_bilinear",
            us_per_query: bil,
        },
    ]
}
