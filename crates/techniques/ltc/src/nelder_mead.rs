//! Nelder–Mead downhill simplex minimisation (Nelder & Mead 1965), the
//! minimiser Heitz et al. 2016 fit their tables with: reflection 1,
//! expansion 2, contraction ½, shrink ½. Used by the offline fit only
//! (a few small vectors per iteration).

/// Minimises `f` from `start`, with an initial simplex of `start` and
/// `start + step·e_i`. Stops after `max_iterations` or when the simplex's
/// function values agree to `tolerance` (relative, `|f_max − f_min| ≤
/// tolerance · (|f_min| + 10⁻³⁰)`). Returns the best point and its value.
#[must_use]
pub fn minimize<const N: usize>(
    f: impl Fn(&[f64; N]) -> f64,
    start: [f64; N],
    step: f64,
    tolerance: f64,
    max_iterations: usize,
) -> ([f64; N], f64) {
    let mut x: Vec<[f64; N]> = Vec::with_capacity(N + 1);
    x.push(start);
    for i in 0..N {
        let mut p = start;
        p[i] += step;
        x.push(p);
    }
    let mut fx: Vec<f64> = x.iter().map(&f).collect();
    for _ in 0..max_iterations {
        // Order: best first.
        let mut idx: Vec<usize> = (0..=N).collect();
        idx.sort_by(|&a, &b| fx[a].total_cmp(&fx[b]));
        let xs: Vec<[f64; N]> = idx.iter().map(|&i| x[i]).collect();
        let fs: Vec<f64> = idx.iter().map(|&i| fx[i]).collect();
        x = xs;
        fx = fs;
        if (fx[N] - fx[0]).abs() <= tolerance * (fx[0].abs() + 1e-30) {
            break;
        }
        // Centroid of all but the worst.
        let mut c = [0.0; N];
        for p in &x[..N] {
            for k in 0..N {
                c[k] += p[k] / N as f64;
            }
        }
        let along = |t: f64| -> [f64; N] {
            let mut p = [0.0; N];
            for k in 0..N {
                p[k] = c[k] + t * (x[N][k] - c[k]);
            }
            p
        };
        let xr = along(-1.0);
        let fr = f(&xr);
        if fr < fx[0] {
            let xe = along(-2.0);
            let fe = f(&xe);
            if fe < fr {
                (x[N], fx[N]) = (xe, fe);
            } else {
                (x[N], fx[N]) = (xr, fr);
            }
        } else if fr < fx[N - 1] {
            (x[N], fx[N]) = (xr, fr);
        } else {
            // Contract towards the better of the worst and its reflection.
            let (xc, fc) = if fr < fx[N] {
                let p = along(-0.5);
                let v = f(&p);
                (p, v)
            } else {
                let p = along(0.5);
                let v = f(&p);
                (p, v)
            };
            if fc < fx[N].min(fr) {
                (x[N], fx[N]) = (xc, fc);
            } else {
                // Shrink towards the best.
                let best = x[0];
                for i in 1..=N {
                    for (v, b) in x[i].iter_mut().zip(&best) {
                        *v = b + 0.5 * (*v - b);
                    }
                    fx[i] = f(&x[i]);
                }
            }
        }
    }
    let best = (0..=N)
        .min_by(|&a, &b| fx[a].total_cmp(&fx[b]))
        .unwrap_or(0);
    (x[best], fx[best])
}

#[cfg(test)]
mod tests {
    #[test]
    fn finds_the_minimum_of_rosenbrock() {
        let rosen = |p: &[f64; 2]| (1.0 - p[0]).powi(2) + 100.0 * (p[1] - p[0] * p[0]).powi(2);
        let (x, fx) = super::minimize(rosen, [-1.2, 1.0], 0.1, 1e-14, 5000);
        assert!(
            (x[0] - 1.0).abs() < 1e-3 && (x[1] - 1.0).abs() < 1e-3,
            "{x:?}"
        );
        assert!(fx < 1e-6);
    }
}
