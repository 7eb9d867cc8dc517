//! Offline analyses of recorded sensor series: noise characterisation and model comparison.

pub mod allan;
pub mod detectors;
pub mod gate_sweep;
pub mod hypothesis;
pub mod special;
pub mod bias_compare;
pub mod gauss_markov;
pub mod wavelet;
