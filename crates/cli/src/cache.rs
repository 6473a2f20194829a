//! `relight cache list|clear`: the wavelet and nearfield bake caches.
//!
//! `relight render --method wavelet` keeps baked rotation matrices and BRDF
//! slices in one folder (`WaveletOptions::cache_dir`, by default
//! [`relight_wavelet::default_cache_dir`]), one file per configuration, named
//! by its parameters and a hash of all of them (`rot-n64-m32-t32-q1-v1-….bin`,
//! `brdf-<key>-m32-v64-k128-v1-….bin`). A rotation bake at n = 64 is about
//! 318 MB, so the folder grows with every configuration tried. `list` prints
//! each entry with its kind, configuration, size and date; `clear` deletes
//! all of them, or those whose file name contains a pattern. Only files
//! named like cache entries (and the `.tmp` files of interrupted bakes) are
//! touched; anything else in the folder is left alone.
//!
//! The nearfield method's transport bakes live in a sibling folder
//! ([`relight_nearfield::cache::default_cache_dir`]),
//! `nearfield-n32-f4000-o2-s1-v1-….bin` (order, face × 1000, objects,
//! shadows, format version, hash of the key). The triple-product method's
//! BRDF tables and visibility bakes live in a third
//! ([`relight_triple::cache::default_cache_dir`]): `brdf-m1-16-….bin`,
//! `vis-m1-2-….bin`, `vistex-m1-2-….bin` (coefficient level m, for
//! n = 20·4^m terms; BRDF views or visibility level). Without `--cache` all
//! three folders are listed (and cleared); with it, that one folder.
//!
//! An interrupted write leaves its temp file beside the entry
//! (`.NAME.tmp-PID-N`, `relight_assets::write_atomic_with`; `NAME.tmp`
//! before that): kind `partial`, listed and cleared with the rest.

use crate::args::CacheCommand;
use anyhow::Result;
use relight_assets::io_reason;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// One file of the cache folder.
#[derive(Debug)]
pub struct Entry {
    pub path: PathBuf,
    /// `rotation`, `brdf`, `nearfield`, `triple` or `partial` (an
    /// interrupted bake's temp file).
    pub kind: &'static str,
    /// The parameters the file name carries, e.g. `n=64 m=32 ntess=32 ntrunc=1`.
    pub configuration: String,
    pub bytes: u64,
    pub modified: Option<SystemTime>,
}

/// The configuration of a cache file name, or `None` if the name is not one.
#[must_use]
pub fn parse_name(name: &str) -> Option<(&'static str, String)> {
    // `.ENTRY.tmp-PID-N` (today's atomic writes) or `ENTRY.tmp` (before).
    let partial = name
        .strip_prefix('.')
        .and_then(|n| n.rsplit_once(".tmp-"))
        .filter(|(_, tail)| {
            tail.split('-').count() == 2
                && tail
                    .split('-')
                    .all(|t| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()))
        })
        .map(|(entry, _)| entry)
        .or_else(|| name.strip_suffix(".tmp"));
    if let Some(entry) = partial {
        let (kind, configuration) = parse_name(entry)?;
        return (kind != "partial").then(|| {
            (
                "partial",
                format!("interrupted bake: {kind} {configuration}"),
            )
        });
    }
    let stem = name.strip_suffix(".bin")?;
    let fields: Vec<&str> = stem.split('-').collect();
    let num = |f: &str, p: &str| -> Option<String> {
        f.strip_prefix(p)
            .filter(|v| !v.is_empty() && v.chars().all(|c| c.is_ascii_digit()))
            .map(str::to_string)
    };
    match fields.as_slice() {
        ["rot", n, m, t, q, v, hash] if hash.len() == 16 => Some((
            "rotation",
            format!(
                "n={} m={} ntess={} ntrunc={} format v{}",
                num(n, "n")?,
                num(m, "m")?,
                num(t, "t")?,
                num(q, "q")?,
                num(v, "v")?
            ),
        )),
        ["brdf", key @ .., m, views, k, v, hash] if hash.len() == 16 && !key.is_empty() => Some((
            "brdf",
            format!(
                "{} m={} views={} terms={} format v{}",
                key.join("-"),
                num(m, "m")?,
                num(views, "v")?,
                num(k, "k")?,
                num(v, "v")?
            ),
        )),
        ["nearfield", n, f, o, s, v, hash] if hash.len() == 16 => Some((
            "nearfield",
            format!(
                "n={} face={} objects={} {} format v{}",
                num(n, "n")?,
                num(f, "f")?.parse::<f64>().ok()? / 1000.0,
                num(o, "o")?,
                match num(s, "s")?.as_str() {
                    "0" => "unshadowed",
                    "1" => "shadows",
                    _ => return None,
                },
                num(v, "v")?
            ),
        )),
        [t @ ("brdf" | "vis" | "vistex"), m, second, hash] if hash.len() == 16 => {
            let m: u32 = num(m, "m")?.parse().ok().filter(|&m| m <= 4)?;
            let second = num(second, "")?;
            let n = 20 * 4u32.pow(m);
            Some((
                "triple",
                match *t {
                    "brdf" => format!("BRDF table n={n} views={second}"),
                    "vis" => format!("visibility n={n} level {second}"),
                    _ => format!("visibility texture n={n} level {second}"),
                },
            ))
        }
        _ => None,
    }
}

/// The cache entries in `dir` (sorted by name); an absent folder has none.
///
/// # Errors
/// The folder exists but cannot be read.
pub fn entries(dir: &Path) -> Result<Vec<Entry>> {
    let read = match std::fs::read_dir(dir) {
        Ok(r) => r,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(unreadable(dir, &e)),
    };
    let mut out = Vec::new();
    for item in read {
        let item = item.map_err(|e| unreadable(dir, &e))?;
        let name = item.file_name().to_string_lossy().into_owned();
        let Some((kind, configuration)) = parse_name(&name) else {
            continue;
        };
        let meta = item.metadata().ok();
        out.push(Entry {
            path: item.path(),
            kind,
            configuration,
            bytes: meta.as_ref().map_or(0, std::fs::Metadata::len),
            modified: meta.and_then(|m| m.modified().ok()),
        });
    }
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
}

/// The one-line error for a cache folder that exists but cannot be read.
fn unreadable(dir: &Path, e: &std::io::Error) -> anyhow::Error {
    anyhow::anyhow!("reading cache folder {}: {}", dir.display(), io_reason(e))
}

/// `YYYY-MM-DD HH:MM` UTC of `t` (Hinnant's days-to-civil algorithm).
#[must_use]
pub fn utc(t: SystemTime) -> String {
    let Ok(d) = t.duration_since(SystemTime::UNIX_EPOCH) else {
        return "before 1970".into();
    };
    let secs = d.as_secs() as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60
    )
}

fn megabytes(b: u64) -> String {
    format!("{:.1} MB", b as f64 / 1e6)
}

fn matching<'a>(all: &'a [Entry], pattern: Option<&str>) -> Vec<&'a Entry> {
    all.iter()
        .filter(|e| {
            pattern.is_none_or(|p| {
                e.path
                    .file_name()
                    .is_some_and(|n| n.to_string_lossy().contains(p))
                    || e.configuration.contains(p)
            })
        })
        .collect()
}

/// Runs `relight cache …`.
///
/// # Errors
/// An unreadable folder, or a file that cannot be deleted.
pub fn run(c: CacheCommand) -> Result<()> {
    match c {
        CacheCommand::List { cache, pattern } => {
            for dir in folders(cache) {
                list(&dir, pattern.as_deref())?;
            }
            Ok(())
        }
        CacheCommand::Clear { cache, pattern } => {
            for dir in folders(cache) {
                clear(&dir, pattern.as_deref())?;
            }
            Ok(())
        }
    }
}

/// `--cache`, or the wavelet, nearfield and triple folders.
fn folders(cache: Option<PathBuf>) -> Vec<PathBuf> {
    match cache {
        Some(d) => vec![d],
        None => vec![
            relight_wavelet::default_cache_dir(),
            relight_nearfield::cache::default_cache_dir(),
            relight_triple::cache::default_cache_dir(),
        ],
    }
}

/// Prints the entries of `dir` matching `pattern`.
fn list(dir: &Path, pattern: Option<&str>) -> Result<()> {
    let all = entries(dir)?;
    let shown = matching(&all, pattern);
    println!("relight cache: {}", dir.display());
    if shown.is_empty() {
        println!(
            "(no entries{})",
            pattern.map_or(String::new(), |p| format!(" matching `{p}`"))
        );
        return Ok(());
    }
    let w = shown
        .iter()
        .map(|e| e.configuration.len())
        .max()
        .unwrap_or(0);
    println!(
        "{:<9}  {:<w$}  {:>10}  {:<16}  file",
        "kind", "configuration", "size", "modified (UTC)"
    );
    for e in &shown {
        println!(
            "{:<9}  {:<w$}  {:>10}  {:<16}  {}",
            e.kind,
            e.configuration,
            megabytes(e.bytes),
            e.modified.map_or("-".into(), utc),
            e.path.file_name().unwrap_or_default().to_string_lossy()
        );
    }
    let total: u64 = shown.iter().map(|e| e.bytes).sum();
    println!("{} entries, {}", shown.len(), megabytes(total));
    Ok(())
}

/// Deletes the entries of `dir` matching `pattern`.
fn clear(dir: &Path, pattern: Option<&str>) -> Result<()> {
    let all = entries(dir)?;
    let doomed = matching(&all, pattern);
    let mut freed = 0;
    for e in &doomed {
        std::fs::remove_file(&e.path)
            .map_err(|err| anyhow::anyhow!("deleting {}: {}", e.path.display(), io_reason(&err)))?;
        freed += e.bytes;
    }
    println!(
        "relight cache: deleted {} of {} entries ({}) in {}",
        doomed.len(),
        all.len(),
        megabytes(freed),
        dir.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_into_configurations() {
        assert_eq!(
            parse_name("rot-n64-m32-t32-q1-v1-0123456789abcdef.bin"),
            Some(("rotation", "n=64 m=32 ntess=32 ntrunc=1 format v1".into()))
        );
        assert_eq!(
            parse_name("brdf-lambert@0.25,0.2,0.3-m32-v64-k128-v1-0cf02dc4551c9f5a.bin"),
            Some((
                "brdf",
                "lambert@0.25,0.2,0.3 m=32 views=64 terms=128 format v1".into()
            ))
        );
        // Names written before BRDF labels (the `Debug` text) still list.
        assert_eq!(
            parse_name(
                "brdf-Ggx___alpha_x__0.2__alpha_y__0.2-m32-v64-k128-v1-0cf02dc4551c9f5a.bin"
            ),
            Some((
                "brdf",
                "Ggx___alpha_x__0.2__alpha_y__0.2 m=32 views=64 terms=128 format v1".into()
            ))
        );
        assert_eq!(
            parse_name("rot-n64-m32-t32-q1-v1-0123456789abcdef.bin.tmp"),
            Some((
                "partial",
                "interrupted bake: rotation n=64 m=32 ntess=32 ntrunc=1 format v1".into()
            ))
        );
        // Today's temp names (`relight_assets::write_atomic_with`).
        assert_eq!(
            parse_name(".vis-m1-2-0123456789abcdef.bin.tmp-4242-7"),
            Some((
                "partial",
                "interrupted bake: triple visibility n=80 level 2".into()
            ))
        );
        assert_eq!(parse_name(".notes.txt.tmp-1-2"), None);
        assert_eq!(parse_name(".vis-m1-2-0123456789abcdef.bin.tmp-x-7"), None);
        // The triple-product method's bakes.
        assert_eq!(
            parse_name("brdf-m1-16-0f6713bc29c21342.bin"),
            Some(("triple", "BRDF table n=80 views=16".into()))
        );
        assert_eq!(
            parse_name("vistex-m2-4-0123456789abcdef.bin").map(|p| p.1),
            Some("visibility texture n=320 level 4".into())
        );
        assert_eq!(parse_name("vis-m9-4-0123456789abcdef.bin"), None);
        assert_eq!(
            parse_name("nearfield-n32-f4000-o2-s1-v1-0123456789abcdef.bin"),
            Some((
                "nearfield",
                "n=32 face=4 objects=2 shadows format v1".into()
            ))
        );
        assert_eq!(
            parse_name("nearfield-n16-f3500-o1-s0-v1-0123456789abcdef.bin").map(|p| p.1),
            Some("n=16 face=3.5 objects=1 unshadowed format v1".into())
        );
        assert_eq!(
            parse_name("nearfield-n16-f3500-o1-s2-v1-0123456789abcdef.bin"),
            None
        );
        assert_eq!(parse_name("notes.txt"), None);
        assert_eq!(
            parse_name("rot-nX-m32-t32-q1-v1-0123456789abcdef.bin"),
            None
        );
    }

    #[test]
    fn utc_dates() {
        let t = SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_780_000_000);
        assert_eq!(utc(t), "2026-05-28 20:26");
        assert_eq!(utc(SystemTime::UNIX_EPOCH), "1970-01-01 00:00");
    }
}
