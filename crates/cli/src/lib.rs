//! relight-cli
