//! Progress reporting and cancellation for long work (bakes, renders).
//!
//! Libraries report through [`Progress`]; the CLI implements it with an
//! indicatif bar and a Ctrl-C flag. Long loops call [`Progress::inc`] per unit
//! of work and stop with [`Cancelled`] when [`Progress::is_cancelled`] turns true,
//! before writing any output.

/// The work was cancelled (Ctrl-C); nothing was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cancelled;

impl std::fmt::Display for Cancelled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("cancelled")
    }
}
impl std::error::Error for Cancelled {}

/// A sink for progress of one task. Implementations must be cheap to call
/// from many threads.
pub trait Progress: Sync {
    /// Starts a phase named `what` with `total` units of work.
    fn start(&self, what: &str, total: u64);
    /// `n` more units are done.
    fn inc(&self, n: u64);
    /// The phase ended.
    fn finish(&self);
    /// True once the user asked to stop.
    fn is_cancelled(&self) -> bool;
    /// `Err(Cancelled)` once the user asked to stop.
    fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

/// Reports nothing and never cancels.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _: &str, _: u64) {}
    fn inc(&self, _: u64) {}
    fn finish(&self) {}
    fn is_cancelled(&self) -> bool {
        false
    }
}
