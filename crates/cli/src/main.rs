//! `relight`: the command-line face of the relight library.
//!
//! Thin glue (ripgrep style): parse and validate flags, call the library
//! crates, print, map the outcome to an exit code (0 success, 1 error,
//! 130 cancelled). Every message on stderr starts with `relight:`.

mod args;
mod bench_frames;
mod commands;
mod compare;
mod method_args;
mod output;
mod parse;
mod plot;
mod progress;
mod render_cmd;
mod scene_args;
mod table;
mod verify_methods;

use clap::Parser;

fn main() {
    let cli = args::Cli::parse();
    progress::install_ctrlc();
    match commands::run(cli) {
        Ok(()) => {}
        Err(err) => {
            if progress::cancelled() || err.chain().any(relight_render::method::is_cancelled) {
                eprintln!("relight: cancelled; no output was written");
                std::process::exit(130);
            }
            eprintln!("relight: {err:#}");
            std::process::exit(1);
        }
    }
}
