//! `imuprep diagnose`: the effects a bias model lacks, found in a recording.
//!
//! The default loop is [`whole`] (the whole log, interleaved selection and held-out blocks:
//! [`blocks`]; its candidates: [`lines`], [`slow`], [`wander`]; its text and plots:
//! [`whole_report`]). The `--paper-split` loop is [`paper_split`] (train, validation, test; its
//! terms in `terms`, its result types in [`result`], its text and plots in [`report`], its tests
//! in `tests.rs`).

pub mod blocks;
pub mod lines;
pub mod paper_split;
pub mod report;
pub mod result;
pub mod slow;
mod terms;
pub mod wander;
pub mod whole;
pub mod whole_report;
