//! `relight bench sh --peers PATH`: this run's SH timings against the peer
//! libraries' timings from the peer kit (`shared/peers/run_all.sh`), with the
//! targets of issue 17 ("SH kernels ahead of DirectXMath at low order and of
//! SHTns at high order") as pass/fail.
//!
//! `PATH` is one of the kit's JSON-lines files (`r<k>_<peer>.jsonl`) or a
//! directory of them (`$PEERS_WORK/runs/<session>/`): every line is one peer
//! timing `{peer, method, order, metric, ns, …}`; lines of the same peer,
//! method, order and metric (rounds) are reduced to their median. The speedup
//! is peer ns ÷ relight ns (above 1: relight is faster). Relight's figures are
//! the ones this process just measured, so for an interleaved comparison run
//! the kit and this command back to back on the same pinned CPU.

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

/// Reads peer timings: `(peer, method, order, metric) → median ns`.
fn read_peers(path: &Path) -> Result<BTreeMap<(String, String, usize, String), f64>> {
    let files: Vec<std::path::PathBuf> = if path.is_dir() {
        let mut f: Vec<_> = std::fs::read_dir(path)
            .with_context(|| format!("--peers {}: cannot list the directory", path.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "jsonl"))
            .collect();
        f.sort();
        f
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

/// The comparison rows for `rows` (this run) against the kit's timings at `path`.
pub fn compare(rows: &[relight_sh::ShBenchRow], path: &Path) -> Result<Vec<PeerRow>> {
    let peers = read_peers(path)?;
    let mut out = Vec::new();
    for &(peer, pm, metric, rm, field, orders, need, target) in TARGETS {
        for &n in orders {
            let Some(&peer_ns) =
                peers.get(&(peer.to_string(), pm.to_string(), n, metric.to_string()))
            else {
                continue;
            };
            let Some(r) = rows.iter().find(|r| r.method == rm && r.order == n) else {
                continue;
            };
            let relight_ns = match field {
                Field::Apply => r.ns_apply,
                Field::Total => r.ns_total,
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
