//! relight-fog
