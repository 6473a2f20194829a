//! relight-wavelet
