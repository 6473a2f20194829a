//! relight-scene
