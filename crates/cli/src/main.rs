//! `relight`: the command-line face of the relight library.
//!
//! Thin glue (ripgrep style): parse and validate flags, call the library
//! crates, print, map the outcome to an exit code (0 success, 1 error,
//! 130 cancelled). Every message on stderr starts with `relight:`.

mod affine;
mod args;
mod bench_frames;
mod bench_sh_peers;
mod cache;
mod commands;
mod compare;
mod demo;
mod ltc;
mod method_args;
mod ndf;
mod ndf_bake;
mod nearfield;
mod output;
mod parse;
mod plot;
mod progress;
mod radcache;
mod render_cmd;
mod scene_args;
mod scene_info;
mod shexp;
mod table;
mod triple;
mod verify_methods;
mod zoom;

use clap::Parser;

/// Restores the default action of SIGPIPE, which Rust's runtime ignores: a
/// reader that stops early (`relight info *.exr | head -1`) then ends the
/// process quietly, as it does any Unix tool, instead of `println!`
/// panicking on the broken pipe.
fn quiet_broken_pipe() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to its default, before any
    // thread starts; no handler runs Rust code.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn main() {
    quiet_broken_pipe();
    let cli = args::Cli::parse();
    progress::install_ctrlc();
    match commands::run(cli) {
        Ok(()) => {}
        Err(err) => {
            if progress::cancelled() || err.chain().any(relight_render::method::is_cancelled) {
                eprintln!("relight: cancelled; no output was written");
                std::process::exit(130);
            }
            eprintln!("relight: {}", message(&err));
            std::process::exit(1);
        }
    }
}

/// The error and its causes on one line, each cause once: library errors
/// often quote their source in their own message (`FILE: KEY: {source}`),
/// so a cause already contained in the text so far is not repeated (as
/// anyhow's `{:#}` would).
fn message(err: &anyhow::Error) -> String {
    let mut text = err.to_string();
    for cause in err.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::message;

    #[derive(Debug, thiserror::Error)]
    #[error("{path}: file not found")]
    struct Missing {
        path: String,
    }

    #[derive(Debug, thiserror::Error)]
    #[error("{context}: {source}")]
    struct Keyed {
        context: String,
        #[source]
        source: Missing,
    }

    /// A source its wrapper already quotes is printed once; a context that
    /// does not quote it keeps it.
    #[test]
    fn each_cause_once() {
        let e = anyhow::Error::new(Keyed {
            context: "a.toml: environment.file".into(),
            source: Missing {
                path: "x.exr".into(),
            },
        });
        assert_eq!(
            message(&e),
            "a.toml: environment.file: x.exr: file not found"
        );
        let e = anyhow::Error::new(Missing {
            path: "x.exr".into(),
        })
        .context("loading");
        assert_eq!(message(&e), "loading: x.exr: file not found");
    }
}
