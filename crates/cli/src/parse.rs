//! Parsing of flag values that clap leaves as strings.

use anyhow::{Result, anyhow, ensure};

/// Parses `WIDTHxHEIGHT`.
pub fn parse_size(s: &str, flag: &str) -> Result<(usize, usize)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| anyhow!("{flag} {s}: expected WIDTHxHEIGHT, e.g. 960x540"))?;
    let w: usize = w
        .trim()
        .parse()
        .map_err(|_| anyhow!("{flag} {s}: width `{w}` is not a positive integer"))?;
    let h: usize = h
        .trim()
        .parse()
        .map_err(|_| anyhow!("{flag} {s}: height `{h}` is not a positive integer"))?;
    ensure!(
        (1..=16384).contains(&w) && (1..=16384).contains(&h),
        "{flag} {s}: each side must be 1…16384 pixels"
    );
    Ok((w, h))
}

/// Parses a comma-separated list of exactly `n` finite floats.
pub fn parse_floats(s: &str, n: usize, flag: &str) -> Result<Vec<f32>> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f32>()
                .map_err(|_| anyhow!("{flag} {s}: `{x}` is not a number"))
        })
        .collect::<Result<_>>()?;
    ensure!(
        v.len() == n,
        "{flag} {s}: expected {n} comma-separated numbers, got {}",
        v.len()
    );
    ensure!(
        v.iter().all(|x| x.is_finite()),
        "{flag} {s}: values must be finite"
    );
    Ok(v)
}
