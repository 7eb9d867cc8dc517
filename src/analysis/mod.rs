//! Offline analyses of recorded sensor series: noise characterisation and model comparison.

pub mod allan;
pub mod bias_compare;
pub mod detector_compare;
pub mod detectors;
pub mod gate_sweep;
pub mod gauss_markov;
pub mod hypothesis;
pub mod pipeline_eval;
pub mod special;
pub mod wavelet;
