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

/// Whether two paths name one file: the same file when both exist (links followed), or an
/// output not made yet that would land on the other (its folder resolved, its name compared).
pub fn same_file(a: &std::path::Path, b: &std::path::Path) -> bool {
    fn resolved(p: &std::path::Path) -> Option<std::path::PathBuf> {
        if let Ok(c) = std::fs::canonicalize(p) {
            return Some(c);
        }
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
        Some(
            std::fs::canonicalize(dir.unwrap_or(std::path::Path::new(".")))
                .ok()?
                .join(p.file_name()?),
        )
    }
    matches!((resolved(a), resolved(b)), (Some(x), Some(y)) if x == y)
}
