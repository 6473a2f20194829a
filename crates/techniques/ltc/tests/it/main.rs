//! All of this crate's integration tests in one binary, one module per
//! topic (`cargo test -p relight-ltc --test it <topic>::`).

mod method;
mod table;
mod verify;
