//! The CLI's [`Progress`]: an indicatif bar per phase, and Ctrl-C as cancellation.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use relight_render::Progress;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

static CANCELLED: AtomicBool = AtomicBool::new(false);

/// Installs the Ctrl-C handler: the first Ctrl-C asks running work to stop
/// (outputs are left untouched), a second one exits at once.
pub fn install_ctrlc() {
    let _ = ctrlc::set_handler(|| {
        if CANCELLED.swap(true, Ordering::SeqCst) {
            eprintln!("relight: interrupted");
            std::process::exit(130);
        }
        eprintln!("relight: stopping (Ctrl-C again to quit now)…");
    });
}

/// True once Ctrl-C was pressed.
pub fn cancelled() -> bool {
    CANCELLED.load(Ordering::Relaxed)
}

/// A progress bar on stderr (hidden when stderr is not a terminal or `quiet`).
pub struct Bar {
    bar: Mutex<Option<ProgressBar>>,
    quiet: bool,
}

impl Bar {
    pub fn new(quiet: bool) -> Self {
        Self {
            bar: Mutex::new(None),
            quiet,
        }
    }
}

impl Progress for Bar {
    fn start(&self, what: &str, total: u64) {
        let bar = ProgressBar::with_draw_target(
            Some(total),
            if self.quiet {
                ProgressDrawTarget::hidden()
            } else {
                ProgressDrawTarget::stderr()
            },
        );
        bar.set_style(
            ProgressStyle::with_template(
                "{msg:>14} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        bar.set_message(what.to_string());
        if let Some(old) = self
            .bar
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .replace(bar)
        {
            old.finish_and_clear();
        }
    }
    fn inc(&self, n: u64) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.inc(n);
        }
    }
    fn finish(&self) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
    fn is_cancelled(&self) -> bool {
        cancelled()
    }
}
