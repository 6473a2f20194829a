//! relight-shlight
