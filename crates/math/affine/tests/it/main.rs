//! All of this crate's integration tests in one binary (one link of the
//! dependency graph instead of one per file); each module is one former
//! `tests/*.rs` file.

mod canonical;
mod coupling;
mod separable;
mod sparsity;
mod standard;
mod zoom;
