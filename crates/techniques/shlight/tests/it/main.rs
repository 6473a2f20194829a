//! All of this crate's integration tests in one binary (one link of the
//! dependency graph instead of one per file); each module is one former
//! `tests/*.rs` file.

mod filter;
mod method;
mod render;
mod window;
