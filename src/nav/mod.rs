//! Navigation beside imuprep: a loosely coupled GNSS/INS error-state EKF ([`eskf`]) on a WGS-84
//! local-level Earth model ([`earth`]), and the RTKLIB solution reader ([`pos`]) that feeds it
//! GNSS and scores it. The driver that runs it on recordings is [`crate::report::navtest`].

pub mod earth;
pub mod eskf;
pub mod pos;

#[cfg(test)]
mod eskf_tests;
