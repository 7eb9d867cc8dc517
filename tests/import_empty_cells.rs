//! Empty cells in a CSV (a logger that dropped a value): the row is kept, the missing value is
//! NaN, the import counts the empty cells per channel with the line of the first, and the
//! default pipeline flags the sample non-finite and replaces the value, the row's other channels
//! passing as they would without the hole. A column empty in every row stays an absent channel;
//! a cell that is not a number stays an error naming file, line and column.
mod common;

use imuprep::io::csv::{EmptyCells, ImportOptions, read_csv_report};
use imuprep::rng::Rng;
use imuprep::sample::flags;
use std::fmt::Write as _;
use std::path::Path;

const FS: f64 = 100.0;
/// 30 s: past the default pipeline's warm-up, so the holes meet a running gate.
const N: usize = 3000;
/// The data row (0 = first after the header; file line = row + 2) with gy empty, and the one
/// with every channel empty.
const GY_HOLE: usize = 1500;
const ALL_HOLE: usize = 2200;

/// A seeded static recording (gyro bias + noise, gravity on z) as CSV text, with the cells of
/// `holes` (row, channel) left empty.
fn recording(holes: &[(usize, usize)]) -> String {
    let mut r = Rng::new(20_261_125);
    let mut s = String::from("t,gx,gy,gz,ax,ay,az\n");
    for i in 0..N {
        let v = [
            0.01 + 0.002 * r.normal(),
            -0.02 + 0.002 * r.normal(),
            0.005 + 0.002 * r.normal(),
            0.02 * r.normal(),
            0.02 * r.normal(),
            9.80665 + 0.02 * r.normal(),
        ];
        let _ = write!(s, "{:.2}", i as f64 / FS);
        for (c, x) in v.iter().enumerate() {
            s.push(',');
            if !holes.contains(&(i, c)) {
                let _ = write!(s, "{x:.6}");
            }
        }
        s.push('\n');
    }
    s
}

fn holes() -> Vec<(usize, usize)> {
    let mut h = vec![(GY_HOLE, 1)];
    h.extend((0..6).map(|c| (ALL_HOLE, c)));
    h
}

/// Import `csv` with the CLI into `dir/name.log`; the import's output.
fn import(dir: &Path, name: &str, csv: &str) -> (String, String) {
    let p = dir.join(format!("{name}.csv"));
    std::fs::write(&p, csv).unwrap();
    let log = dir.join(format!("{name}.log"));
    let out = common::run_cli(&["import", p.to_str().unwrap(), "-o", log.to_str().unwrap()]);
    (log.to_str().unwrap().to_string(), out)
}

/// Replay `log` through the embedded default pipeline; the output CSV's rows.
fn replay(log: &str, out: &Path) -> Vec<Vec<String>> {
    common::run_cli(&["replay", log, "--out", &format!("csv:{}", out.display())]);
    common::csv_rows(&std::fs::read_to_string(out).unwrap())
}

#[test]
fn empty_cells_are_counted_with_their_first_line_and_the_rows_kept() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("holes.csv");
    std::fs::write(&p, recording(&holes())).unwrap();
    let (d, s, rep) = read_csv_report(&p, &ImportOptions::default()).unwrap();
    assert_eq!(s.len(), N, "every row is a sample: {rep}");
    assert_eq!(d.absent, 0, "a channel with values is not absent: {rep}");
    // gy: its own hole and the empty row; every other channel: the empty row.
    let want: Vec<EmptyCells> = ["gx", "gy", "gz", "ax", "ay", "az"]
        .iter()
        .map(|c| EmptyCells {
            channel: c.to_string(),
            cells: if *c == "gy" { 2 } else { 1 },
            first_line: if *c == "gy" { GY_HOLE } else { ALL_HOLE } + 2,
            file: None,
        })
        .collect();
    assert_eq!(rep.empty_cells, want, "{rep}");
    assert_eq!(
        (rep.empty_rows, rep.first_empty_row),
        (1, Some(ALL_HOLE + 2)),
        "{rep}"
    );
    // The missing values are NaN in a present channel; the rest of the row is the file's.
    assert!(s[GY_HOLE].gyro[1].is_nan() && !s[GY_HOLE].is_absent(1));
    assert!(s[GY_HOLE].gyro[0].is_finite() && s[GY_HOLE].accel.iter().all(|v| v.is_finite()));
    assert!(s[ALL_HOLE].channels().iter().all(|v| v.is_nan()));
    // No time fault from a hole: the empty row's time stamp holds the time base.
    assert!(!rep.time.any(), "{rep}");
    // With time from the row index (`--rate`), the kept rows keep every later time right.
    let o = ImportOptions {
        time_from_index_hz: Some(FS),
        ..ImportOptions::default()
    };
    let (_, by_index, _) = read_csv_report(&p, &o).unwrap();
    assert_eq!(by_index.len(), N);
    assert_eq!(by_index[N - 1].t_ns, (N as u64 - 1) * 10_000_000);
    let text = rep.to_string();
    assert!(
        text.contains(
            "gx: 1 empty cell (first at line 2202), gy: 2 empty cells (first at line 1502)"
        ),
        "{text}"
    );
    assert!(
        text.contains("1 row with every channel empty (first at line 2202)"),
        "{text}"
    );
}

#[test]
fn a_missing_value_is_flagged_and_replaced_by_the_default_pipeline_and_nothing_else_moves() {
    let dir = tempfile::tempdir().unwrap();
    let (holey, said) = import(dir.path(), "holey", &recording(&holes()));
    let (clean, _) = import(dir.path(), "clean", &recording(&[]));
    // The user is told, on a line of its own.
    assert!(
        said.contains(
            "import: gx: 1 empty cell (first at line 2202), gy: 2 empty cells (first at line 1502)"
        ) && said.contains("imported as missing values (NaN), rows kept"),
        "{said}"
    );
    assert!(said.contains(&format!("imported {N} samples")), "{said}");
    let out = replay(&holey, &dir.path().join("holey_out.csv"));
    let reference = replay(&clean, &dir.path().join("clean_out.csv"));
    assert_eq!(out.len(), N, "no sample dropped");
    assert_eq!(reference.len(), N);
    let flags_of = |row: &[String]| row[9].parse::<u32>().unwrap();
    for (i, row) in out.iter().enumerate() {
        // Nothing non-finite reaches the output unflagged.
        let finite = row[1..7]
            .iter()
            .all(|v| v.parse::<f64>().unwrap().is_finite());
        assert!(
            finite || flags_of(row) & flags::NON_FINITE != 0,
            "row {i}: {row:?}"
        );
    }
    // The holes: flagged non-finite, each empty channel replaced (its REPLACED bit) by a
    // finite value.
    let gy = &out[GY_HOLE];
    assert_ne!(flags_of(gy) & flags::NON_FINITE, 0, "{gy:?}");
    assert_ne!(flags_of(gy) & flags::replaced_ch(1), 0, "{gy:?}");
    assert!(gy[2].parse::<f64>().unwrap().is_finite(), "{gy:?}");
    let all = &out[ALL_HOLE];
    assert_ne!(flags_of(all) & flags::NON_FINITE, 0, "{all:?}");
    for c in 0..6 {
        assert_ne!(flags_of(all) & flags::replaced_ch(c), 0, "ch {c}: {all:?}");
        assert!(all[1 + c].parse::<f64>().unwrap().is_finite(), "{all:?}");
    }
    // The other channels of the gy row pass exactly as they do from the file without the hole
    // (same text: the CSV writes the f32 value in its shortest exact form).
    for c in [0usize, 2, 3, 4, 5] {
        assert_eq!(gy[1 + c], reference[GY_HOLE][1 + c], "channel {c}");
        assert_eq!(
            flags_of(gy) & (flags::replaced_ch(c) | flags::suspect_ch(c)),
            0,
            "channel {c}: {gy:?}"
        );
    }
}

/// What stays as it was: a column empty in every row is an absent channel, and a cell that is
/// text is an error naming file, line and column (nothing says what number it meant).
#[test]
fn an_all_empty_column_is_absent_and_text_is_still_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("gyro_only.csv");
    std::fs::write(&p, "t,gx,gy,gz,ax\n0,1,2,3,\n0.01,1,,3,\n0.02,1,2,3,\n").unwrap();
    let (d, s, rep) = read_csv_report(&p, &ImportOptions::default()).unwrap();
    assert_eq!(s.len(), 3);
    assert_eq!(rep.absent, ["ax", "ay", "az"], "{rep}");
    assert_eq!(d.absent, 0b111_000);
    assert_eq!(rep.empty_cells.len(), 1, "{rep}");
    assert_eq!(
        (rep.empty_cells[0].cells, rep.empty_cells[0].first_line),
        (1, 3)
    );
    assert_eq!(rep.empty_rows, 0, "gx and gz have values on line 3");
    let p = dir.path().join("text.csv");
    std::fs::write(&p, "t,gx,gy,gz\n0,1,2,3\n0.01,1,n/a,3\n").unwrap();
    let e = read_csv_report(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("text.csv:3:3") && e.contains("\"n/a\"") && e.contains("column gy"),
        "{e}"
    );
}
