//! The README's commands, run as written, so that the README cannot drift
//! from the binary.
//!
//! Every line of README.md's ```sh blocks that starts with `relight ` is run
//! through the built binary in a fresh folder laid out like a clone
//! (`examples/` beside it, `../shared` reachable, an empty bake cache in
//! `$RELIGHT_CACHE`), in README order, so that `compare` reads the files the
//! earlier lines wrote. Only sizes are shrunk, by the rules of [`shrink`]
//! (`--size`, `--spp`, the wavelet resolution), so the whole test takes
//! seconds; a README command no rule knows fails the test, and so does
//! every command that fails.
//!
//! Synopsis lines (with `[optional]` parts or `a|b` alternatives) are
//! expanded: every alternative must parse (clap checks the values and flags
//! before `--help`), and the quick suites of [`RUN_SUITES`] also run with
//! `--quick --json --plot DIR` and must write a plot. `relight view` needs a
//! window: each `--method` alternative must get as far as the missing
//! display (flags parsed, scene built). Every file the README's commands
//! write in the clone must be ignored by `.gitignore`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const README: &str = include_str!("../../../../README.md");
const GITIGNORE: &str = include_str!("../../../../.gitignore");

/// `bench`/`verify` suites whose `--quick` run is cheap enough to run here
/// (about a second each); the others (tens of seconds) are only parsed.
const RUN_SUITES: [&str; 3] = ["bench raster", "bench reference", "verify reference"];

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The `relight …` lines of the README's shell blocks: continuation lines
/// joined, comments removed.
fn readme_commands() -> Vec<String> {
    let mut out = Vec::new();
    let mut in_sh = false;
    let mut pending = String::new();
    for line in README.lines() {
        let t = line.trim();
        if t.starts_with("```") {
            in_sh = !in_sh && (t == "```sh" || t == "```bash" || t == "```shell");
            continue;
        }
        if !in_sh {
            continue;
        }
        let code = t.split(" #").next().unwrap_or("").trim_end();
        if let Some(head) = code.strip_suffix('\\') {
            pending.push_str(head.trim_end());
            pending.push(' ');
            continue;
        }
        pending.push_str(code);
        let cmd = std::mem::take(&mut pending).trim().to_string();
        if cmd.starts_with("relight ") {
            out.push(cmd);
        }
    }
    out
}

/// Sets `flag value` in `args`: replaces the value if the flag is there,
/// appends both if not.
fn set(args: &mut Vec<String>, flag: &str, value: &str) {
    if let Some(i) = args.iter().position(|a| a == flag) {
        args[i + 1] = value.to_string();
    } else {
        args.extend([flag.to_string(), value.to_string()]);
    }
}

/// The value of `flag` in `args`.
fn get<'a>(args: &'a [String], flag: &str) -> Option<&'a str> {
    let i = args.iter().position(|a| a == flag)?;
    args.get(i + 1).map(String::as_str)
}

/// The method `relight render ARGS` uses: `--method`, else the scene file's
/// `[render] method`, else the reference.
fn render_method(args: &[String], clone: &Path) -> String {
    if let Some(m) = get(args, "--method") {
        return m.to_string();
    }
    if let Some(file) = args.get(1).filter(|a| a.ends_with(".toml")) {
        let text = std::fs::read_to_string(clone.join(file)).unwrap_or_default();
        let mut in_render = false;
        for line in text.lines() {
            let l = line.trim();
            if l.starts_with('[') {
                in_render = l == "[render]";
            } else if in_render
                && let Some(v) = l.strip_prefix("method")
                && let Some(v) = v.trim().strip_prefix('=')
            {
                return v.trim().trim_matches('"').to_string();
            }
        }
    }
    "reference".into()
}

/// `path/with/*.ext` → the matching files (sorted), relative to `clone`.
fn glob(arg: &str, clone: &Path) -> Vec<String> {
    let Some((dir, pattern)) = arg.rsplit_once('/').filter(|(_, p)| p.contains('*')) else {
        return vec![arg.to_string()];
    };
    let (pre, post) = pattern.split_once('*').unwrap();
    let mut hits: Vec<String> = std::fs::read_dir(clone.join(dir))
        .map(|r| {
            r.filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with(pre) && n.ends_with(post))
                .map(|n| format!("{dir}/{n}"))
                .collect()
        })
        .unwrap_or_default();
    hits.sort();
    assert!(!hits.is_empty(), "README glob {arg} matches nothing");
    hits
}

/// What to do with one README command.
enum Plan {
    /// Run these arguments; must succeed.
    Run(Vec<String>),
    /// Must parse (`--help` appended).
    Parse(Vec<String>),
    /// `relight view …`: must fail only for want of a display.
    NoDisplay(Vec<String>),
}

/// The small-size versions of README command `cmd` (split at spaces, the
/// leading `relight` removed), or an error naming what no rule covers.
fn shrink(cmd: &str, clone: &Path, plots: &Path) -> Result<Vec<Plan>, String> {
    let words: Vec<String> = cmd.split_whitespace().skip(1).map(str::to_string).collect();
    let sub = words.first().map(String::as_str).unwrap_or("");
    let synopsis = words.iter().any(|w| w.contains('[') || w.contains('|'));
    let small = "64x36";
    match (sub, synopsis) {
        ("render", false) => {
            let mut a = words;
            set(&mut a, "--size", small);
            match render_method(&a, clone).as_str() {
                "reference" => set(&mut a, "--spp", "4"),
                "wavelet" => {
                    set(&mut a, "--n", "16");
                    set(&mut a, "--ntess", "4");
                }
                "sh" | "fog" | "shexp" | "triple" | "ndf" | "ltc" => {}
                "nearfield" => set(&mut a, "--order", "8"),
                "radiance-cache" => set(&mut a, "--spp", "1"),
                m => return Err(format!("render with method {m}")),
            }
            Ok(vec![Plan::Run(a)])
        }
        ("bake", false) if words.get(1).is_some_and(|w| w == "nearfield") => {
            let mut a = words;
            set(&mut a, "--order", "8");
            Ok(vec![Plan::Run(a)])
        }
        ("convert", false) => {
            let mut a = words;
            set(&mut a, "--size", "32");
            Ok(vec![Plan::Run(a)])
        }
        ("info", false) => Ok(vec![Plan::Run(
            words.iter().flat_map(|w| glob(w, clone)).collect(),
        )]),
        ("compare" | "sh" | "cache" | "spheres" | "wavelet", false) => Ok(vec![Plan::Run(words)]),
        ("demo", false) => {
            // Whatever small-size flags the demo has.
            let help = relight(&["demo".into(), "--help".into()], clone);
            let help = String::from_utf8_lossy(&help.stdout).into_owned();
            let mut a = words;
            for (flag, value) in [
                ("--size", small),
                ("--spp", "4"),
                ("--n", "16"),
                ("--ntess", "4"),
            ] {
                if help.contains(&format!("{flag} ")) {
                    set(&mut a, flag, value);
                }
            }
            if help.contains("--quick") && !a.iter().any(|w| w == "--quick") {
                a.push("--quick".into());
            }
            Ok(vec![Plan::Run(a)])
        }
        ("view", true) => {
            let methods = words
                .iter()
                .find(|w| w.contains('|'))
                .map(|w| w.trim_matches(['[', ']']).to_string())
                .ok_or("view synopsis without --method alternatives")?;
            let mut plans = Vec::new();
            for m in methods.split('|') {
                plans.push(Plan::NoDisplay(vec![
                    "view".into(),
                    "--method".into(),
                    m.into(),
                    "--size".into(),
                    small.into(),
                ]));
            }
            Ok(plans)
        }
        ("bench" | "verify", true) => {
            let suites = words.get(1).ok_or("bench/verify synopsis without suites")?;
            let flags: Vec<String> = words[2..]
                .iter()
                .map(|w| w.trim_matches(['[', ']']).to_string())
                .map(|w| {
                    if w == "DIR" {
                        plots.display().to_string()
                    } else {
                        w
                    }
                })
                .collect();
            let mut plans = Vec::new();
            for s in suites.split('|') {
                let mut a = vec![sub.to_string(), s.to_string()];
                a.extend(flags.iter().cloned());
                if RUN_SUITES.contains(&format!("{sub} {s}").as_str()) {
                    plans.push(Plan::Run(a.clone()));
                }
                plans.push(Plan::Parse(a));
            }
            Ok(plans)
        }
        _ => Err(format!("`{cmd}`: no rule to shrink `relight {sub}`")),
    }
}

fn relight(args: &[String], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_relight"))
        .arg("-q")
        .args(args)
        .current_dir(dir)
        .env("RELIGHT_CACHE", dir.join("../cache"))
        .env_remove("RELIGHT_DATA")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .expect("run relight")
}

/// Whether `name` (a file in the repository root) is ignored by `.gitignore`
/// (the patterns it uses: `*` wildcards, a leading `/` anchoring at the root).
fn ignored(name: &str) -> bool {
    fn matches(p: &str, s: &str) -> bool {
        match p.split_once('*') {
            None => p == s,
            Some((pre, rest)) => {
                s.starts_with(pre) && (pre.len()..=s.len()).any(|i| matches(rest, &s[i..]))
            }
        }
    }
    GITIGNORE
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#') && !l.starts_with('!'))
        .any(|l| matches(l.trim_start_matches('/').trim_end_matches('/'), name))
}

#[test]
fn every_readme_command_works_as_written() {
    let repo = repo();
    let root = std::env::temp_dir().join(format!("relight-readme-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let clone = root.join("clone");
    std::fs::create_dir_all(&clone).unwrap();
    let plots = root.join("plots");
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(repo.join("examples"), clone.join("examples")).unwrap();
        let shared = repo.join("../shared");
        if shared.exists() {
            std::os::unix::fs::symlink(&shared, root.join("shared")).unwrap();
        }
    }
    let have_data = root.join("shared/data").exists();
    if !have_data {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set and ../shared/data is missing"
        );
    }

    let commands = readme_commands();
    assert!(commands.len() >= 10, "README commands found: {commands:#?}");
    let mut unknown = Vec::new();
    let mut ran = 0;
    for cmd in &commands {
        if !have_data && cmd.contains("../shared/data") {
            eprintln!("skipping (../shared/data is absent): {cmd}");
            continue;
        }
        let plans = match shrink(cmd, &clone, &plots) {
            Ok(p) => p,
            Err(e) => {
                unknown.push(e);
                continue;
            }
        };
        for plan in plans {
            match plan {
                Plan::Run(args) => {
                    let out = relight(&args, &clone);
                    assert!(
                        out.status.success(),
                        "README: {cmd}\nran: relight {}\n{}",
                        args.join(" "),
                        String::from_utf8_lossy(&out.stderr)
                    );
                    if let Some(dir) = args.iter().position(|a| a == "--plot") {
                        let dir = Path::new(&args[dir + 1]);
                        let svgs = std::fs::read_dir(dir).map_or(0, |r| r.count());
                        assert!(svgs > 0, "relight {}: no plot written", args.join(" "));
                    }
                    ran += 1;
                }
                Plan::Parse(mut args) => {
                    args.push("--help".into());
                    let out = relight(&args, &clone);
                    assert!(
                        out.status.success(),
                        "README: {cmd}\ndoes not parse: relight {}\n{}",
                        args.join(" "),
                        String::from_utf8_lossy(&out.stderr)
                    );
                }
                Plan::NoDisplay(args) => {
                    let out = relight(&args, &clone);
                    let err = String::from_utf8_lossy(&out.stderr);
                    assert!(
                        !out.status.success() && err.contains("needs DISPLAY or WAYLAND_DISPLAY"),
                        "README: {cmd}\nrelight {}: expected only the missing display: {err}",
                        args.join(" ")
                    );
                }
            }
        }
    }
    assert!(
        unknown.is_empty(),
        "README commands this test cannot shrink (add a rule to tests/readme.rs): {unknown:#?}"
    );
    assert!(ran >= 10, "only {ran} README commands ran");
    // The compare line compares files earlier lines made.
    if have_data {
        for f in ["bunny-reference.exr", "bunny-wavelet.exr", "bunny-diff.png"] {
            assert!(
                clone.join(f).exists(),
                "{f} not written by the README's commands"
            );
        }
    }
    // Everything the README writes is ignored by git.
    let mut stray = Vec::new();
    for e in std::fs::read_dir(&clone).unwrap().filter_map(Result::ok) {
        let name = e.file_name().to_string_lossy().into_owned();
        if name != "examples" && !ignored(&name) {
            stray.push(name);
        }
    }
    assert!(
        stray.is_empty(),
        ".gitignore misses README outputs: {stray:?}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// The README says how to install the binary and which Rust it needs, the
/// version the workspace declares.
#[test]
fn readme_states_the_install_line_and_the_rust_version() {
    let manifest = include_str!("../../../../Cargo.toml");
    let version = manifest
        .lines()
        .find_map(|l| l.trim().strip_prefix("rust-version = "))
        .expect("workspace rust-version")
        .trim_matches('"');
    assert!(
        README.contains("cargo install --path crates/cli"),
        "no install line"
    );
    assert!(
        README.contains(&format!("Rust {version} or newer")),
        "README must name Rust {version} (Cargo.toml's rust-version)"
    );
}

#[test]
fn the_ignore_matcher_reads_gitignore_patterns() {
    assert!(ignored("bunny-reference.png"));
    assert!(ignored("x.tmp"));
    assert!(ignored("target"));
    assert!(!ignored("README.md"));
    assert!(!ignored("Cargo.toml"));
}
