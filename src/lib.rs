//! imuprep — a real-time preprocessor for low-cost MEMS inertial sensors.
//!
//! ```text
//!  serial port ─┐                                          ┌─► TCP clients (each its own bounded queue)
//!  replay file ─┼─► FrameDecoder ─► Pipeline (sync) ───────┼─► UDP / file / stdout
//!  stdin       ─┘   bytes → Sample    │  GrossError (ARIMA) └─► health counters, model status
//!                   faults = counted  │  Bias (FOS/AR)
//!                                     ▼
//!                               Sample + flags
//! ```
//!
//! Async lives only at the edges ([`io`], [`runtime`]); the numerical stages ([`stage`]) are
//! synchronous and pure, and the offline tools share their models. Layout and floors:
//! `docs/architecture.md`.

pub mod analysis;
pub mod config;
pub mod frame;
pub mod io;
pub mod model;
pub mod nav;
pub mod progress;
pub mod report;
pub mod rng;
pub mod runtime;
pub mod sample;
pub mod settings;
pub mod sim;
pub mod stage;
pub mod stats;
pub mod text;

pub use sample::{Sample, flags};
