//! relight-haar
