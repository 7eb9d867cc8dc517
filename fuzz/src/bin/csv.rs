//! CSV import (vendor layouts, units, bad cells): the input is written to a file in /dev/shm
//! (the importer reads paths) and imported with default options; errors are fine, panics not.
fn main() {
    let path = std::env::temp_dir().join(format!("imuprep-fuzz-{}.csv", std::process::id()));
    afl::fuzz!(|data: &[u8]| {
        if std::fs::write(&path, data).is_ok() {
            let _ = imuprep::io::csv::read_csv(&path, &Default::default());
        }
    });
}
