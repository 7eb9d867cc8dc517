//! `imuprep import` of text tables that are not comma-separated CSV with a header: semicolon
//! files with decimal commas (a European spreadsheet's export), tab- and whitespace-separated
//! `.txt`/`.tsv`/`.dat` files (told by their content, not their name), comment preambles, headers
//! written as comments (EuRoC's `#timestamp`, ROS's `%time`), and headerless files with their
//! columns named by position (`--columns`). Ragged or mixed lines are an error at file:line;
//! prose is no table; a binary protocol file is still decoded as one.
//!
//! Synthetic recordings are seeded: 20 s at 200 Hz of a sensor rolling ±20° about x (as in
//! tests/import_layouts.rs), values written with Rust's shortest round-trip formatting, so an
//! import reproduces the truth to 1e-9.
mod common;

use imuprep::io::csv::{Delimiter, ImportOptions, ImportReport, read_csv_report};
use imuprep::sample::Sample;
use std::path::{Path, PathBuf};
use std::process::Output;

const FS: f64 = 200.0;
const N: usize = 4000;
const G0: f64 = 9.80665;

use common::TruthRow as Row;

/// Roll φ = 20° sin(2πt/6 s) about x from t = 100 s ([`common::rocking`]).
fn motion(seed: u64) -> Vec<Row> {
    common::rocking(N, FS, 100.0, 20.0, seed)
}

/// A row's seven numbers (t, gx..gz, ax..az) as text.
fn cells(r: &Row) -> Vec<String> {
    std::iter::once(r.t)
        .chain(r.g)
        .chain(r.f)
        .map(|x| format!("{x}"))
        .collect()
}

/// `pre` lines, then one line per row of `rows` joined by `sep`, each cell through `cell`.
fn table(pre: &[&str], rows: &[Row], sep: &str, cell: impl Fn(&str) -> String) -> String {
    let mut s = String::new();
    for l in pre {
        s += l;
        s.push('\n');
    }
    for r in rows {
        let c: Vec<String> = cells(r).iter().map(|c| cell(c)).collect();
        s += &c.join(sep);
        s.push('\n');
    }
    s
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn import(p: &Path, o: &ImportOptions) -> (f64, Vec<Sample>, ImportReport) {
    let (d, s, rep) = read_csv_report(p, o).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    (d.sample_rate_hz, s, rep)
}

/// Every channel equals the truth within 1e-9, the time within 1 µs, the rate is 200 Hz.
fn assert_truth(label: &str, rate: f64, s: &[Sample], rows: &[Row]) {
    common::assert_rows(label, (rate, FS), s, rows);
    for (k, (s, r)) in s.iter().zip(rows).enumerate() {
        assert!(
            (s.t_s() - r.t).abs() < 1e-6,
            "{label} row {k}: t {}",
            s.t_s()
        );
    }
}

/// `imuprep import IN -o OUT [args]`.
fn cli(input: &Path, out: &Path, args: &[&str]) -> Output {
    std::process::Command::new(common::bin())
        .arg("import")
        .arg(input)
        .arg("-o")
        .arg(out)
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A change to a file's lines.
type Edit = dyn Fn(&mut Vec<String>);

const HEADER: [&str; 7] = ["t", "gx", "gy", "gz", "ax", "ay", "az"];

#[test]
fn each_delimiter_imports_to_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(1);
    let same = |c: &str| c.to_string();
    for (name, sep, delim) in [
        ("comma.csv", ",", Delimiter::Comma),
        ("semi.csv", ";", Delimiter::Semicolon),
        ("tab.tsv", "\t", Delimiter::Tab),
        ("space.txt", " ", Delimiter::Whitespace),
    ] {
        let head = HEADER.join(sep);
        let p = write(dir.path(), name, &table(&[&head], &rows, sep, same));
        let (rate, s, rep) = import(&p, &ImportOptions::default());
        assert_truth(name, rate, &s, &rows);
        match &rep.table {
            None => assert_eq!(delim, Delimiter::Comma, "{name}: {rep}"),
            Some(t) => {
                assert_eq!(t.delimiter, delim, "{name}");
                assert!(!t.decimal_comma && t.header, "{name}: {rep}");
                assert!(
                    rep.to_string()
                        .starts_with(&format!("table: {}", delim.describe())),
                    "{rep}"
                );
            }
        }
    }
    // Columns aligned with runs of spaces and tabs, leading and trailing blanks, CRLF.
    let mut aligned = format!("   {}  \r\n", HEADER.map(|h| format!("{h:>22}")).join(""));
    for r in &rows {
        let c: Vec<String> = cells(r).iter().map(|c| format!("{c:>22}")).collect();
        aligned += &format!("{} \t\r\n", c.join(" \t"));
    }
    let p = write(dir.path(), "aligned.dat", &aligned);
    let (rate, s, rep) = import(&p, &ImportOptions::default());
    assert_truth("aligned.dat", rate, &s, &rows);
    assert_eq!(rep.table.unwrap().delimiter, Delimiter::Whitespace);
}

#[test]
fn a_semicolon_file_with_decimal_commas_imports_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(2);
    let head = "time;gyro x;gyro y;gyro z;acc x;acc y;acc z";
    let p = write(
        dir.path(),
        "export.csv",
        &table(&[head], &rows, ";", |c| c.replace('.', ",")),
    );
    let (rate, s, rep) = import(&p, &ImportOptions::default());
    assert_truth("decimal commas", rate, &s, &rows);
    let t = rep.table.as_ref().unwrap();
    assert!(t.decimal_comma && t.delimiter == Delimiter::Semicolon);
    // The CLI's summary says it.
    let out = cli(&p, &dir.path().join("x.log"), &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("import: table: semicolon-separated, decimal commas"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_whitespace_txt_imports_by_content_to_the_same_log_as_its_csv() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(3);
    let csv = write(
        dir.path(),
        "imu.csv",
        &table(&[&HEADER.join(",")], &rows, ",", str::to_string),
    );
    // A dataset's `imu.txt`: `timestamp wx wy wz ax ay az`, one space.
    let head = "timestamp wx wy wz ax ay az";
    let txt = write(
        dir.path(),
        "imu.txt",
        &table(&[head], &rows, " ", str::to_string),
    );
    let (a, b) = (dir.path().join("a.log"), dir.path().join("b.log"));
    let oa = cli(&csv, &a, &[]);
    let ob = cli(&txt, &b, &[]);
    assert!(
        oa.status.success() && ob.status.success(),
        "{}",
        stderr(&ob)
    );
    assert!(
        stderr(&ob).contains("table: whitespace-separated, header on line 1"),
        "{}",
        stderr(&ob)
    );
    // Canonical names say rad/s by convention, `wx` leaves it to the data: both rad/s here.
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

#[test]
fn a_headerless_file_imports_with_columns_by_position() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(4);
    // An extra column (a counter) between time and gyro; deg/s and g, as a logger writes them.
    let mut text = String::new();
    for (i, r) in rows.iter().enumerate() {
        let g = r.g.map(|x| format!("{}", x.to_degrees()));
        let f = r.f.map(|x| format!("{}", x / G0));
        text += &format!("{}\t{i}\t{}\t{}\n", r.t, g.join("\t"), f.join("\t"));
    }
    let p = write(dir.path(), "oxiod.txt", &text);
    let o = ImportOptions {
        positions: imuprep::io::csv::parse_positions("t,_,gx,gy,gz,ax,ay,az").unwrap(),
        ..Default::default()
    };
    let (_, s, rep) = import(&p, &o);
    assert!(!rep.table.as_ref().unwrap().header, "{rep}");
    assert_eq!(
        rep.columns
            .iter()
            .map(|c| format!("{}={}", c.key, c.column))
            .collect::<Vec<_>>()
            .join(","),
        "t=column 1,gx=column 3,gy=column 4,gz=column 5,ax=column 6,ay=column 7,az=column 8"
    );
    // No name states a unit: the data decide (g by |f|, deg/s by gravity's turning).
    for q in ["gyro", "accel", "time"] {
        let u = rep.units.iter().find(|u| u.quantity == q).unwrap();
        assert_eq!(u.source, "data", "{q}: {rep}");
    }
    for (k, (s, r)) in s.iter().zip(&rows).enumerate() {
        for c in 0..3 {
            assert!((s.gyro[c] - r.g[c]).abs() < 1e-9, "row {k} g{c}");
            assert!((s.accel[c] - r.f[c]).abs() < 1e-9, "row {k} a{c}");
        }
    }
    // The CLI, with the unit flags as for any table; the first row is data, not a header.
    let log = dir.path().join("x.log");
    let out = cli(
        &p,
        &log,
        &[
            "--columns",
            "t,_,gx,gy,gz,ax,ay,az",
            "--gyro-unit",
            "deg/s",
            "--accel-unit",
            "g",
        ],
    );
    let e = stderr(&out);
    assert!(out.status.success(), "{e}");
    assert!(e.contains(&format!("imported {N} samples")), "{e}");
    assert!(e.contains("gyro unit: deg/s (stated by --gyro-unit"), "{e}");
    // Fewer names than columns: the rest skipped (a gyro alone: no accelerometer to check its
    // unit against, so the flag); more: an error naming the count.
    let o = ImportOptions {
        positions: imuprep::io::csv::parse_positions("t,_,gx,gy,gz").unwrap(),
        gyro_unit: Some(imuprep::io::csv::GyroUnit::DegS),
        ..Default::default()
    };
    let (_, _, rep) = import(&p, &o);
    assert_eq!(rep.absent, ["ax", "ay", "az"], "{rep}");
    let o = ImportOptions {
        positions: imuprep::io::csv::parse_positions("t,_,gx,gy,gz,ax,ay,az,temp").unwrap(),
        ..Default::default()
    };
    let e = read_csv_report(&p, &o).unwrap_err().to_string();
    assert!(
        e.contains("--columns names 9 columns, the first row has 8"),
        "{e}"
    );
    // Keys checked.
    assert!(
        imuprep::io::csv::parse_positions("t,gx,gx")
            .unwrap_err()
            .contains("gx named twice")
    );
    assert!(
        imuprep::io::csv::parse_positions("t,wx")
            .unwrap_err()
            .contains("\"wx\" (column 2) is not one of")
    );
}

/// A headerless file with a text column (a frame id, as a ROS echo writes it) in every row:
/// its first row is data — it was taken for a header and, with `--columns`, lost.
#[test]
fn a_headerless_file_with_a_text_column_keeps_its_first_row() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(6);
    let mut text = String::new();
    for r in &rows {
        text += &format!("{},imu_link,{}\n", r.t, cells(r)[1..].join(","));
    }
    let p = write(dir.path(), "frames.csv", &text);
    let e = read_csv_report(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("frames.csv:1: no header"), "{e}");
    let o = ImportOptions {
        positions: imuprep::io::csv::parse_positions("t,_,gx,gy,gz,ax,ay,az").unwrap(),
        ..Default::default()
    };
    let (_, s, rep) = import(&p, &o);
    assert!(!rep.table.as_ref().unwrap().header, "{rep}");
    assert_eq!(s.len(), rows.len(), "{rep}");
    for (k, (s, r)) in s.iter().zip(&rows).enumerate() {
        for c in 0..3 {
            assert!((s.gyro[c] - r.g[c]).abs() < 1e-9, "row {k} g{c}");
            assert!((s.accel[c] - r.f[c]).abs() < 1e-9, "row {k} a{c}");
        }
    }
}

#[test]
fn a_headerless_file_without_columns_says_so_and_shows_the_first_row() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(5);
    let p = write(
        dir.path(),
        "data.csv",
        &table(&[], &rows, ",", str::to_string),
    );
    let out = cli(&p, &dir.path().join("x.log"), &[]);
    let e = stderr(&out);
    assert!(!out.status.success());
    let first = cells(&rows[0]).join(",");
    assert!(
        e.contains(&format!(
            "data.csv:1: no header: the first row holds values, not names ({first}); name the columns by position with --columns, e.g. --columns t,gx,gy,gz,ax,ay,az"
        )),
        "{e}"
    );
    // After a comment preamble the line is the file's.
    let p = write(
        dir.path(),
        "data2.txt",
        &table(&["# logger v2", "# 200 Hz"], &rows, " ", str::to_string),
    );
    let e = stderr(&cli(&p, &dir.path().join("y.log"), &[]));
    assert!(e.contains("data2.txt:3: no header"), "{e}");
}

#[test]
fn a_comment_preamble_is_skipped_and_comment_headers_are_still_headers() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(6);
    let pre = [
        "# IMU log, firmware 1.2",
        "% units: rad/s, m/s^2",
        "",
        "// device 7",
        "t,gx,gy,gz,ax,ay,az",
    ];
    let p = write(
        dir.path(),
        "pre.csv",
        &table(&pre, &rows, ",", str::to_string),
    );
    let (rate, s, rep) = import(&p, &ImportOptions::default());
    assert_truth("preamble", rate, &s, &rows);
    let t = rep.table.as_ref().unwrap();
    assert_eq!((t.skip_lines, t.comment_lines, t.header), (4, 3, true));
    assert!(
        rep.to_string()
            .contains("3 comment lines skipped, header on line 5"),
        "{rep}"
    );
    // EuRoC's header is a comment line; ROS's too, after a preamble, with a frame id in every
    // row; a whitespace header whose marker stands alone.
    let euroc = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]";
    let ns = |r: &Row| format!("{}", (r.t * 1e9).round() as u64);
    let mut text = format!("{euroc}\n");
    for r in &rows {
        text += &format!("{},{}\n", ns(r), cells(r)[1..].join(","));
    }
    let (rate, s, rep) = import(
        &write(dir.path(), "data.csv", &text),
        &ImportOptions::default(),
    );
    assert_truth("euroc", rate, &s, &rows);
    assert!(rep.table.is_none(), "{rep}");
    assert_eq!(rep.columns[0].column, "#timestamp [ns]");
    let mut text = String::from(
        "# rostopic echo -p /imu\n%time,field.header.frame_id,field.angular_velocity.x,field.angular_velocity.y,field.angular_velocity.z,field.linear_acceleration.x,field.linear_acceleration.y,field.linear_acceleration.z\n",
    );
    for r in &rows {
        text += &format!("{},imu_link,{}\n", ns(r), cells(r)[1..].join(","));
    }
    let (rate, s, rep) = import(
        &write(dir.path(), "ros.csv", &text),
        &ImportOptions::default(),
    );
    assert_truth("ros", rate, &s, &rows);
    assert_eq!(rep.columns[0].column, "%time", "{rep}");
    let t = rep.table.as_ref().unwrap();
    assert_eq!((t.skip_lines, t.comment_lines), (1, 1));
    let p = write(
        dir.path(),
        "tum.txt",
        &table(
            &["# recorded by tum", "# t gx gy gz ax ay az"],
            &rows,
            " ",
            str::to_string,
        ),
    );
    let (rate, s, rep) = import(&p, &ImportOptions::default());
    assert_truth("tum", rate, &s, &rows);
    assert_eq!(rep.columns[0].column, "t", "{rep}");
}

#[test]
fn a_binary_protocol_file_with_any_name_is_still_decoded_as_one() {
    let dir = tempfile::tempdir().unwrap();
    let samples = common::samples(500, 7);
    let p = dir.path().join("imu.dat");
    imuprep::io::csv::write_log(&p, &common::descriptor(), &samples).unwrap();
    let out = cli(&p, &dir.path().join("x.log"), &[]);
    let e = stderr(&out);
    assert!(out.status.success(), "{e}");
    assert!(e.starts_with("native input"), "{e}");
    assert!(e.contains("imported 500 samples"), "{e}");
    assert_eq!(
        imuprep::io::csv::sniff_file(&p),
        imuprep::io::csv::Sniffed::Binary
    );
}

#[test]
fn ragged_and_mixed_lines_are_an_error_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(8);
    let head = HEADER.join(",");
    let base = table(&[&head], &rows, ",", str::to_string);
    let mut lines: Vec<String> = base.lines().map(str::to_string).collect();
    // Row 300 (file line 302) cut short; row 500 with semicolons; row 700 with decimal commas.
    let cut =
        |l: &mut Vec<String>| l[301] = l[301].split(',').take(4).collect::<Vec<_>>().join(",");
    let semi = |l: &mut Vec<String>| l[501] = l[501].replace(',', ";");
    let dec = |l: &mut Vec<String>| {
        l[701] = l[701]
            .split(',')
            .map(|c| c.replace('.', ","))
            .collect::<Vec<_>>()
            .join(",")
    };
    let cases: [(&str, &Edit, &str); 3] = [
        ("cut.csv", &cut, ":302: 4 cells where the header has 7"),
        ("semi.csv", &semi, ":502: 1 cell where the header has 7"),
        ("dec.csv", &dec, ":702: 14 cells where the header has 7"),
    ];
    for (name, edit, want) in cases {
        let mut l = lines.clone();
        edit(&mut l);
        let p = write(dir.path(), name, &(l.join("\n") + "\n"));
        let e = read_csv_report(&p, &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("{name}{want}")), "{e}");
    }
    // The same in a whitespace .txt through the CLI: nothing imported, the line named.
    lines[1201] = lines[1201].replace(',', " ") + " 0.5";
    let text = lines
        .iter()
        .enumerate()
        .map(|(k, l)| {
            if k == 1201 {
                l.clone()
            } else {
                l.replace(',', " ")
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let p = write(dir.path(), "long.txt", &text);
    let log = dir.path().join("long.log");
    let out = cli(&p, &log, &[]);
    let e = stderr(&out);
    assert!(!out.status.success() && !log.exists(), "{e}");
    assert!(
        e.contains("long.txt:1202: 8 cells where the header has 7"),
        "{e}"
    );
    // A trailing delimiter is no ragged row.
    let trailing: String = base.lines().map(|l| format!("{l},\n")).collect();
    let (rate, s, _) = import(
        &write(dir.path(), "trailing.csv", &trailing),
        &ImportOptions::default(),
    );
    assert_truth("trailing", rate, &s, &rows);
}

#[test]
fn a_last_row_cut_short_is_left_out_and_said_the_rows_before_it_imported() {
    // A logger stopped mid-write: the file's last line holds 3 of its 7 cells (blank lines
    // after it change nothing). Every whole row is imported, the cut one is named in a warning;
    // the same short row anywhere else stays an error (ragged_and_mixed_lines_… above).
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(9);
    let head = HEADER.join(",");
    let mut text = table(&[&head], &rows, ",", str::to_string);
    let whole = text.clone();
    text += "100.5,0.01,0.02\n\n  \n";
    let p = write(dir.path(), "cut_last.csv", &text);
    let (rate, s, rep) = import(&p, &ImportOptions::default());
    assert_truth("cut last", rate, &s, &rows);
    let line = whole.lines().count() + 1;
    assert!(
        rep.warnings.iter().any(|w| w.contains(&format!(
            "line {line}, the file's last, has 3 cells where the header has 7"
        ))),
        "{:?}",
        rep.warnings
    );
    // The CLI says it and writes the log.
    let log = dir.path().join("cut_last.log");
    let out = cli(&p, &log, &[]);
    let e = stderr(&out);
    assert!(out.status.success() && log.exists(), "{e}");
    assert!(
        e.contains("WARNING: line") && e.contains("a write cut off"),
        "{e}"
    );
}

#[test]
fn prose_is_no_table_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "README.txt",
        "IMU recording of a walk\n=======================\nSensor: a low-cost MEMS IMU, 100 Hz.\nColumns are described below, with units.\n",
    );
    let out = cli(&p, &dir.path().join("x.log"), &[]);
    let e = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{e}");
    assert!(
        e.contains("README.txt: text, but not a table of numbers"),
        "{e}"
    );
}

#[test]
fn audit_picks_up_text_tables_and_lists_a_headerless_one_as_skipped() {
    use imuprep::report::audit::{find_recordings, load_recording};
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(9);
    write(
        dir.path(),
        "walk.txt",
        &table(&["t gx gy gz ax ay az"], &rows, " ", str::to_string),
    );
    write(
        dir.path(),
        "bench.tsv",
        &table(&[&HEADER.join("\t")], &rows, "\t", str::to_string),
    );
    write(
        dir.path(),
        "noheader.dat",
        &table(&[], &rows, " ", str::to_string),
    );
    write(
        dir.path(),
        "NOTES.txt",
        "Recorded on a bench.\nThe files are described here, in prose.\n",
    );
    let found: Vec<String> = find_recordings(dir.path())
        .unwrap()
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(found, ["bench.tsv", "noheader.dat", "walk.txt"]);
    for name in ["walk.txt", "bench.tsv"] {
        let (d, s) = load_recording(&dir.path().join(name)).unwrap();
        assert_truth(name, d.sample_rate_hz, &s, &rows);
    }
    let e = load_recording(&dir.path().join("noheader.dat")).unwrap_err();
    assert!(e.contains("no header") && e.contains("--columns"), "{e}");
}

/// The real walk written as a semicolon file with decimal commas and as a whitespace `.txt`
/// (a comment line, aligned columns) imports to the very samples of the original CSV.
#[test]
fn the_real_walk_as_semicolon_decimal_comma_and_as_whitespace_txt_imports_alike() {
    let Some(src) = common::real_data("rtklibexplorer_drive_walk/walk_0827_imu.csv") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&src).unwrap();
    let lines: Vec<&str> = text.lines().filter(|l| !l.is_empty()).collect();
    let semi: String = lines
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let l = l.replace(',', ";");
            // Decimal commas in the numbers (the header's names have no point).
            (if k == 0 { l } else { l.replace('.', ",") }) + "\n"
        })
        .collect();
    let ws: String = std::iter::once("# rtklibexplorer walk, written as a text table\n".into())
        .chain(
            lines
                .iter()
                .map(|l| l.split(',').map(|c| format!("{c:>16}")).collect::<String>() + "\n"),
        )
        .collect();
    let (r0, s0, _) = import(&src, &ImportOptions::default());
    for (name, body, delim, dc) in [
        ("walk_semi.csv", semi, Delimiter::Semicolon, true),
        ("walk.txt", ws, Delimiter::Whitespace, false),
    ] {
        let p = write(dir.path(), name, &body);
        let (r1, s1, rep) = import(&p, &ImportOptions::default());
        let t = rep.table.as_ref().unwrap();
        assert_eq!((t.delimiter, t.decimal_comma), (delim, dc), "{rep}");
        assert_eq!(r0, r1, "{name}");
        assert_eq!(s0, s1, "{name}: samples differ");
        assert!(rep.warnings.is_empty(), "{rep}");
    }
}
