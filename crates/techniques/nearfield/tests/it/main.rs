//! All of this crate's integration tests in one binary, one module per
//! topic (`cargo test -p relight-nearfield --test it <topic>::`).

mod cache;
mod lights;
mod method;
mod rotation;
mod specular;
