//! relight-assets
