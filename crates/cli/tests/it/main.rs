//! All of this crate's integration tests in one binary (one link of the
//! dependency graph instead of one per file); each module is one former
//! `tests/*.rs` file.

mod area_light_flags;
mod cli;
mod common;
mod issue11;
mod methods;
mod nearfield_bake;
mod readme;
mod triple;
