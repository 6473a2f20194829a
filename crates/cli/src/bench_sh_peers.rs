//! `relight bench sh --peers PATH`: this run's SH timings against the peer
//! libraries' timings from the peer kit (`shared/peers/run_all.sh`), with the
//! targets of issue 17 ("SH kernels ahead of DirectXMath at low order and of
//! SHTns at high order") as pass/fail.
//!
//! `PATH` is one of the kit's JSON-lines files (`r<k>_<peer>.jsonl`) or a
//! directory of them (`$PEERS_WORK/runs/<session>/`): every line is one peer
//! timing `{peer, method, order, metric, ns, …}`; lines of the same peer,
//! method, order and metric (rounds) are reduced to their median. The speedup
//! is peer ns ÷ relight ns (above 1: relight is faster).
//!
//! Relight's figures: where `PATH` is a runs directory holding the kit's own
//! relight rounds (`r<k>_relight.json`, the `relight bench sh --json` it ran
//! between the peers), the median of those rounds, so that every row —
//! the batch and `eval_sh_array` rows too — is the kit's interleaved
//! comparison; otherwise the figures this process just measured (run it
//! pinned to the kit's CPU, right after the kit). The column `relight_from`
//! says which.

use anyhow::{Context, Result, bail};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// One comparison row.
#[derive(Debug, Serialize)]
pub struct PeerRow {
    pub target: String,
    pub order: usize,
    pub relight: String,
    pub relight_ns: f64,
    /// Where `relight_ns` comes from: the kit's rounds or this run.
    pub relight_from: String,
    pub peer: String,
    pub peer_ns: f64,
    /// peer ns ÷ relight ns.
    pub speedup: f64,
    /// The speedup the target asks for (0: reported only).
    pub need: f64,
    /// `true`/`false` against `need`, `"report"` where the issue asks only for the figure.
    pub pass: serde_json::Value,
}

/// (peer, peer method, peer metric, relight method, relight field, orders, need, target text).
type Target = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    Field,
    &'static [usize],
    f64,
    &'static str,
);

#[derive(Clone, Copy)]
enum Field {
    Apply,
    Total,
}

/// The targets of issue 17, each a speedup over one peer call.
const TARGETS: &[Target] = &[
    (
        "directxmath",
        "XMSHRotate",
        "total",
        "zyz",
        Field::Total,
        &[2, 3, 4, 5, 6],
        1.25,
        "issue 17: rotation from 3×3 ≤ 0.8× XMSHRotate",
    ),
    (
        "directxmath",
        "XMSHEvalDirection",
        "apply",
        "eval",
        Field::Apply,
        &[2, 3, 4, 5, 6],
        1.0,
        "issue 17: eval ≤ 1.0× XMSHEvalDirection",
    ),
    (
        "directxmath",
        "XMSHEvalDirection",
        "apply",
        "eval_array",
        Field::Apply,
        &[2, 3, 4, 5, 6],
        1.0,
        "issue 17: eval, order fixed at compile time (eval_sh_array) ≤ 1.0× XMSHEvalDirection",
    ),
    (
        "directxmath",
        "XMSHMultiply",
        "apply",
        "product",
        Field::Apply,
        &[2, 3, 4, 5, 6],
        1.0,
        "issue 17: product ≤ 1.0× XMSHMultiply",
    ),
    (
        "shtns",
        "SH_to_spat x2 + mul + spat_to_SH",
        "apply",
        "product",
        Field::Apply,
        &[8, 10],
        1.5,
        "issue 17: product ≥ 1.5× SHTns",
    ),
    (
        "pbrt-v2-mono",
        "SHRotate",
        "total",
        "zyz",
        Field::Total,
        &[8, 10],
        2.0,
        "issue 17: rotation ≥ 2× pbrt-v2 (mono)",
    ),
    (
        "shtns",
        "set_angles_ZYZ+apply_real",
        "total",
        "zyz",
        Field::Total,
        &[8, 10],
        2.0,
        "issue 17: rotation ≥ 2× SHTns",
    ),
    (
        "pbrt-v2-mono",
        "SHEvaluate",
        "apply",
        "eval",
        Field::Apply,
        &[8, 10],
        2.0,
        "issue 17: eval ≥ 2× pbrt-v2 (mono)",
    ),
    (
        "shtns",
        "3x spat_to_SH (from interleaved RGB f32)",
        "apply",
        "project_latlong",
        Field::Apply,
        &[10],
        2.0,
        "issue 17: projection ≥ 2× SHTns",
    ),
    (
        "shtns",
        "3x spat_to_SH (from interleaved RGB f32)",
        "apply",
        "project_latlong",
        Field::Apply,
        &[3, 6, 16, 30],
        0.0,
        "issue 17: projection vs SHTns (reported)",
    ),
    (
        "directxmath",
        "XMSHEvalDirection",
        "apply",
        "eval_batch",
        Field::Apply,
        &[3],
        3.0,
        "issue 17: batch eval ≥ 3× XMSHEvalDirection per item",
    ),
    (
        "directxmath",
        "XMSHEvalDirection",
        "apply",
        "shade_batch",
        Field::Apply,
        &[3],
        3.0,
        "issue 17: batch shade ≥ 3× XMSHEvalDirection per item (DX eval alone, no dot)",
    ),
    (
        "directxmath",
        "XMSHRotate",
        "total",
        "rotate_batch",
        Field::Total,
        &[3],
        3.0,
        "issue 17: batch rotation ≥ 3× XMSHRotate per item",
    ),
    (
        "directxmath",
        "XMSHRotate",
        "total",
        "zyz_rgb",
        Field::Total,
        &[3, 4, 5, 6],
        0.0,
        "issue 17: RGB rotation vs 1× XMSHRotate (reported)",
    ),
    (
        "directxmath",
        "XMSHMultiply",
        "apply",
        "product_rgb",
        Field::Apply,
        &[3, 4, 5, 6],
        0.0,
        "issue 17: RGB product vs 1× XMSHMultiply (reported)",
    ),
];

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The files of the kit's runs directory `dir` whose names pass `keep`, sorted.
fn files_named(dir: &Path, keep: impl Fn(&str) -> bool) -> Result<Vec<std::path::PathBuf>> {
    let mut f: Vec<_> = std::fs::read_dir(dir)
        .with_context(|| format!("--peers {}: cannot list the directory", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(&keep))
        .collect();
    f.sort();
    Ok(f)
}

/// Reads peer timings: `(peer, method, order, metric) → median ns`.
fn read_peers(path: &Path) -> Result<BTreeMap<(String, String, usize, String), f64>> {
    let files: Vec<std::path::PathBuf> = if path.is_dir() {
        files_named(path, |n| n.ends_with(".jsonl"))?
    } else {
        vec![path.to_path_buf()]
    };
    let mut all: BTreeMap<(String, String, usize, String), Vec<f64>> = BTreeMap::new();
    for f in &files {
        let text = std::fs::read_to_string(f)
            .with_context(|| format!("--peers {}: cannot read", f.display()))?;
        for (ln, line) in text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty())
        {
            let v: serde_json::Value = serde_json::from_str(line)
                .with_context(|| format!("--peers {}:{}: not a JSON line", f.display(), ln + 1))?;
            let s = |k: &str| {
                v.get(k)
                    .and_then(serde_json::Value::as_str)
                    .map(str::to_string)
            };
            let (Some(peer), Some(method), Some(metric), Some(order), Some(ns)) = (
                s("peer"),
                s("method"),
                s("metric"),
                v.get("order").and_then(serde_json::Value::as_u64),
                v.get("ns").and_then(serde_json::Value::as_f64),
            ) else {
                bail!(
                    "--peers {}:{}: a peer timing needs peer, method, order, metric and ns",
                    f.display(),
                    ln + 1
                );
            };
            all.entry((peer, method, order as usize, metric))
                .or_default()
                .push(ns);
        }
    }
    if all.is_empty() {
        bail!(
            "--peers {}: no peer timings found (give a kit r<k>_<peer>.jsonl file or its runs directory)",
            path.display()
        );
    }
    Ok(all
        .into_iter()
        .map(|(k, mut v)| (k, median(&mut v)))
        .collect())
}

/// Relight's `(ns_apply, ns_total)` per `(method, order)`.
type KitRelight = BTreeMap<(String, usize), (f64, f64)>;

/// Relight's `(ns_apply, ns_total)` per `(method, order)` from the kit's
/// relight rounds in the runs directory `dir` (the first JSON array of each
/// `r<k>_relight.json`, the `bench sh` table), median over the rounds, and
/// the number of rounds; `None` where `dir` is not a directory or holds none.
fn read_kit_relight(dir: &Path) -> Result<Option<(KitRelight, usize)>> {
    if !dir.is_dir() {
        return Ok(None);
    }
    let files = files_named(dir, |n| n.starts_with('r') && n.ends_with("_relight.json"))?;
    if files.is_empty() {
        return Ok(None);
    }
    let mut all: BTreeMap<(String, usize), (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for f in &files {
        let text = std::fs::read_to_string(f)
            .with_context(|| format!("--peers {}: cannot read", f.display()))?;
        let first = serde_json::Deserializer::from_str(&text)
            .into_iter::<serde_json::Value>()
            .next()
            .transpose()
            .with_context(|| format!("--peers {}: not relight's JSON output", f.display()))?;
        let Some(serde_json::Value::Array(rows)) = first else {
            bail!(
                "--peers {}: expected the `relight bench sh --json` table (a JSON array) first",
                f.display()
            );
        };
        for r in &rows {
            let (Some(method), Some(order), Some(apply), Some(total)) = (
                r.get("method").and_then(serde_json::Value::as_str),
                r.get("order").and_then(serde_json::Value::as_u64),
                r.get("ns_apply").and_then(serde_json::Value::as_f64),
                r.get("ns_total").and_then(serde_json::Value::as_f64),
            ) else {
                bail!(
                    "--peers {}: a bench sh row needs method, order, ns_apply and ns_total",
                    f.display()
                );
            };
            let e = all.entry((method.to_string(), order as usize)).or_default();
            e.0.push(apply);
            e.1.push(total);
        }
    }
    let rounds = files.len();
    Ok(Some((
        all.into_iter()
            .map(|(k, (mut a, mut t))| (k, (median(&mut a), median(&mut t))))
            .collect(),
        rounds,
    )))
}

/// The comparison rows against the kit's timings at `path`: relight's
/// figures from the kit's own rounds where `path` holds them, else `rows`
/// (this run).
pub fn compare(rows: &[relight_sh::ShBenchRow], path: &Path) -> Result<Vec<PeerRow>> {
    let peers = read_peers(path)?;
    let kit = read_kit_relight(path)?;
    let from = match &kit {
        Some((_, k)) => format!("kit, median of {k} rounds"),
        None => "this run".to_string(),
    };
    let mut out = Vec::new();
    for &(peer, pm, metric, rm, field, orders, need, target) in TARGETS {
        for &n in orders {
            let Some(&peer_ns) =
                peers.get(&(peer.to_string(), pm.to_string(), n, metric.to_string()))
            else {
                continue;
            };
            let (apply, total) = match &kit {
                Some((m, _)) => match m.get(&(rm.to_string(), n)) {
                    Some(&v) => v,
                    None => continue,
                },
                None => match rows.iter().find(|r| r.method == rm && r.order == n) {
                    Some(r) => (r.ns_apply, r.ns_total),
                    None => continue,
                },
            };
            let relight_ns = match field {
                Field::Apply => apply,
                Field::Total => total,
            };
            let speedup = peer_ns / relight_ns;
            let pass = if need <= 0.0 {
                serde_json::Value::from("report")
            } else {
                serde_json::Value::Bool(speedup >= need)
            };
            out.push(PeerRow {
                target: target.to_string(),
                order: n,
                relight: rm.to_string(),
                relight_ns,
                relight_from: from.clone(),
                peer: format!("{peer} {pm}"),
                peer_ns,
                speedup,
                need,
                pass,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: &str, order: usize, apply: f64, total: f64) -> relight_sh::ShBenchRow {
        relight_sh::ShBenchRow {
            method: method.into(),
            order,
            ns_build: 0.0,
            ns_apply: apply,
            ns_total: total,
            note: String::new(),
        }
    }

    /// A fresh directory under the system temp dir.
    fn dir(name: &str) -> std::path::PathBuf {
        let d =
            std::env::temp_dir().join(format!("relight-peers-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    const DX_EVAL: &str = r#"{"peer":"directxmath","method":"XMSHEvalDirection","order":3,"metric":"apply","ns":3.0}"#;

    #[test]
    fn this_run_without_kit_rounds_and_kit_medians_with_them() {
        let d = dir("medians");
        std::fs::write(d.join("r1_dxsh.jsonl"), format!("{DX_EVAL}\n")).unwrap();
        let rows = [row("eval", 3, 6.0, 6.0)];
        // No relight rounds: this run's 6 ns, 0.5×, a failure.
        let c = compare(&rows, &d).unwrap();
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].relight_from, "this run");
        assert!((c[0].speedup - 0.5).abs() < 1e-12);
        assert_eq!(c[0].pass, serde_json::Value::Bool(false));
        // Three kit rounds (the first array is the bench sh table; later
        // documents are other tables): median 2 ns, 1.5×, a pass.
        for (k, ns) in [(1, 2.0), (2, 9.0), (3, 1.0)] {
            let t = format!(
                r#"[{{"method":"eval","order":3,"ns_build":0,"ns_apply":{ns},"ns_total":{ns},"note":""}}]
[{{"order":3,"ms_frame":1.0}}]"#
            );
            std::fs::write(d.join(format!("r{k}_relight.json")), t).unwrap();
        }
        let c = compare(&rows, &d).unwrap();
        assert_eq!(c[0].relight_from, "kit, median of 3 rounds");
        assert!((c[0].relight_ns - 2.0).abs() < 1e-12);
        assert_eq!(c[0].pass, serde_json::Value::Bool(true));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_corrupt_kit_round_is_an_error_naming_the_file() {
        let d = dir("corrupt");
        std::fs::write(d.join("r1_dxsh.jsonl"), format!("{DX_EVAL}\n")).unwrap();
        std::fs::write(d.join("r1_relight.json"), "[{\"method\": \"eval\", \"ord").unwrap();
        let e = compare(&[], &d).unwrap_err();
        assert!(format!("{e:#}").contains("r1_relight.json"), "{e:#}");
        std::fs::write(d.join("r1_relight.json"), "[{\"method\": \"eval\"}]").unwrap();
        let e = compare(&[], &d).unwrap_err();
        assert!(format!("{e:#}").contains("needs method, order"), "{e:#}");
        let _ = std::fs::remove_dir_all(&d);
    }
}
