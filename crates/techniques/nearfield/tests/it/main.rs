//! All of this crate's integration tests in one binary, one module per
//! topic (`cargo test -p relight-nearfield --test it <topic>::`).

mod cache;
mod light_field;
mod lights;
mod method;
mod rotation;
mod specular;
