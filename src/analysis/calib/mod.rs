//! The still-stretch calibration of `imuprep calibrate`: the still stretches ([`still`]), the
//! accelerometer fit ([`fit`]), the gyroscope fit ([`gyro`], the noise of its residuals in
//! `gyro_noise`) and the gyro's scale about the vertical from the turns of a drive ([`course`]).

pub mod course;
pub mod fit;
pub mod gyro;
mod gyro_noise;
pub mod still;
#[cfg(test)]
mod tests;
