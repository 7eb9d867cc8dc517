//! The async edges: sources that turn bytes into samples, sinks that publish them, and the
//! CSV import/export that lets other tools and recordings meet imuprep.

#[cfg(any(feature = "ros1", feature = "ros2-sqlite"))]
pub mod bag;
pub mod convert;
pub mod csv;
pub mod format;
pub mod log;
#[cfg(feature = "ros2")]
pub mod mcap_sink;
#[cfg(feature = "ros1")]
pub mod ros1;
#[cfg(feature = "ros2-sqlite")]
pub mod ros2_db3;
pub mod sim_log;
pub mod sink;
pub mod source;
pub mod timing;
#[cfg(feature = "zenoh")]
pub mod zenoh;
