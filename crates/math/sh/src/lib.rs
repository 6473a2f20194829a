//! relight-sh
