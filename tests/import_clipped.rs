//! A text table from a sensor clipped at its full scale: the range is read from the rails the
//! data hold (`src/io/csv/rails.rs`), the clipped values are flagged saturated, and the default
//! pipeline replaces none of the motion leaving a rail. Without it (no range in a table, so no
//! saturation flag) the gross-error stage judged the descent from a 250 °/s rail against the
//! rail's zero roughness and replaced 20 samples of it (two exits, 10 each), up to 3.4 °/s off
//! (measured on this file with the inference switched off).
//!
//! The recording is seeded: 120 s at 200 Hz, gyro noise 0.1 °/s on a 16-bit ±250 °/s grid, six
//! 1.5-s turns about z peaking at ±400 °/s (with a 60 °/s wobble about x).
mod common;

use imuprep::io::csv::{ImportOptions, read_csv_report};
use imuprep::rng::Rng;
use imuprep::sample::flags;
use std::path::Path;

const FS: f64 = 200.0;
const RAIL_DPS: f64 = 250.0;

/// The table's text: `peak_dps` the turns' peak; values beyond the rail clipped to the top
/// code (+rail − LSB) or the bottom code (−rail), as a 16-bit sensor reports them.
fn table(peak_dps: f64) -> String {
    let lsb = RAIL_DPS / 32768.0;
    let mut rng = Rng::new(41);
    let mut s = String::from("t,gx,gy,gz,ax,ay,az\n");
    for i in 0..(120.0 * FS) as usize {
        let t = i as f64 / FS;
        let mut g = [0.1 * rng.normal(), 0.1 * rng.normal(), 0.1 * rng.normal()];
        for k in 0..6 {
            let t0 = 10.0 + 18.0 * k as f64;
            if (t0..t0 + 1.5).contains(&t) {
                let sign = if k % 2 == 0 { -1.0 } else { 1.0 };
                let phase = std::f64::consts::PI * (t - t0) / 1.5;
                g[2] += sign * peak_dps * phase.sin();
                g[0] += 60.0 * (2.0 * phase).sin();
            }
        }
        let g = g.map(|v| ((v / lsb).round() * lsb).clamp(-RAIL_DPS, RAIL_DPS - lsb));
        let f = [
            0.02 * rng.normal(),
            0.02 * rng.normal(),
            9.80665 + 0.02 * rng.normal(),
        ];
        s += &format!(
            "{t},{},{},{},{},{},{}\n",
            g[0].to_radians(),
            g[1].to_radians(),
            g[2].to_radians(),
            f[0],
            f[1],
            f[2]
        );
    }
    s
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn a_clipped_table_has_its_range_read_from_its_rails_and_its_motion_kept() {
    let dir = tempfile::tempdir().unwrap();
    let clipped = write(dir.path(), "clipped.csv", &table(400.0));
    let (d, samples, report) = read_csv_report(&clipped, &ImportOptions::default()).unwrap();
    // The smaller rail's magnitude: the top code, one LSB (0.0076 °/s) inside 250 °/s; f32 as
    // the descriptor stores it, never above the rail.
    let range_dps = f64::from(d.gyro_range_rad_s).to_degrees();
    let top = RAIL_DPS - RAIL_DPS / 32768.0;
    assert!(range_dps <= top && range_dps > top - 1e-4, "{range_dps}");
    assert_eq!(d.accel_range_m_s2, 0.0, "the accelerometer held no rail");
    let note = report.notes.iter().find(|n| n.starts_with("gyro range"));
    assert!(note.is_some(), "{:?}", report.notes);
    // Saturated: exactly the values on a rail, each turn's flat top.
    let on_rail = samples
        .iter()
        .filter(|s| s.gyro.z.to_degrees().abs() >= top - 1e-9)
        .count();
    let flagged = samples.iter().filter(|s| s.has(flags::SAT_GYRO_Z)).count();
    assert!(
        on_rail > 6 * 40,
        "six turns, each on its rail for a while: {on_rail}"
    );
    assert_eq!(flagged, on_rail);
    assert!(
        samples
            .iter()
            .all(|s| !s.has(flags::SAT_GYRO_X | flags::SAT_GYRO_Y))
    );

    // The default pipeline: no gz value replaced, the clipped values counted as saturated. (A
    // lone 3.7-σ noise value elsewhere may be: this is about the motion leaving a rail.)
    let out_csv = dir.path().join("out.csv");
    let out = common::imuprep(&[
        "replay",
        clipped.to_str().unwrap(),
        "--out",
        &format!("csv:{}", out_csv.display()),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    common::assert_says(&err, &["gyro range: ±4.36319"]);
    assert!(err.contains(&format!("{on_rail} saturated")), "{err}");
    let rows = common::csv_rows(&std::fs::read_to_string(&out_csv).unwrap());
    let gz_replaced = rows
        .iter()
        .filter(|r| r[9].parse::<u32>().unwrap() & flags::replaced_ch(2) != 0)
        .count();
    assert_eq!(gz_replaced, 0, "{err}");

    // A range stated by flag is kept, and the rails are not read.
    let (d, _, report) = read_csv_report(
        &clipped,
        &ImportOptions {
            gyro_range_rad_s: 300f32.to_radians(),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(d.gyro_range_rad_s, 300f32.to_radians());
    assert!(report.notes.iter().all(|n| !n.contains("range")));
}

#[test]
fn the_same_motion_within_range_has_no_rail() {
    // Turns to 200 °/s: each peak reached once, nothing held, no range invented.
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "within.csv", &table(200.0));
    let (d, samples, report) = read_csv_report(&p, &ImportOptions::default()).unwrap();
    assert_eq!((d.gyro_range_rad_s, d.accel_range_m_s2), (0.0, 0.0));
    assert!(report.notes.iter().all(|n| !n.contains("range")));
    assert!(samples.iter().all(|s| s.flags & flags::SAT_ANY == 0));
}
