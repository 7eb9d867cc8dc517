//! The commands' drivers: each runs library code over recordings and returns a report type
//! (`Display` for people, `Serialize` for machines).

pub mod audit;
pub mod navtest;
