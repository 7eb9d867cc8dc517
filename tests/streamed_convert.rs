//! `import` of a protocol file and `export` of any decodable recording are streamed (two passes,
//! nothing held whole); each must write exactly what the whole-file path writes: the import the
//! log `load_with(..).write(..)` writes (time faults derived over the whole file, the rate, the
//! `--rebase-time` shift, the report's numbers and texts), the export the bytes
//! `encode_stream` makes of the samples `read_any` reads.

use imuprep::frame::detect::{ProtocolArgs, ProtocolConfig};
use imuprep::io::convert::{ExportFormat, encode_stream, read_any};
use imuprep::report::Recording;
use imuprep::report::convert::{ImportArgs, export, import, load_with};
use imuprep::sample::Sample;
use std::path::Path;

/// 30 000 samples at 250 Hz with every time fault the sequence derivation knows: a gap of five
/// missing samples, a repeated stamp, a late sample a little behind, and a restart far behind;
/// the first 40 intervals 3 ms, so a streaming decoder, which learns its period from the first
/// intervals, takes the ten 5-ms intervals at 5000 for gaps, where the whole file's rule
/// (4 ms) does not.
fn faulty() -> (imuprep::frame::Descriptor, Vec<Sample>) {
    let (d, s, _) = imuprep::io::log::read_log(Path::new("replay/drive.log")).unwrap();
    let mut t = 1_000_000_000u64;
    let mut out = Vec::new();
    for (i, x) in s.iter().cycle().take(30_000).enumerate() {
        match i {
            1..=40 => t += 3_000_000,
            5000..5010 => t += 5_000_000,
            1000 => t += 6 * 4_000_000,
            2000 => {}
            3000 => t -= 2 * 4_000_000,
            20_000 => t -= 10_000_000_000,
            _ => t += 4_000_000,
        }
        out.push(Sample {
            t_ns: t,
            seq: 0,
            flags: 0,
            ..*x
        });
    }
    (d.unwrap(), out)
}

#[test]
fn a_streamed_import_writes_the_log_the_whole_import_writes() {
    let (d, s) = faulty();
    let dir = tempfile::tempdir().unwrap();
    let mut formats = vec![
        ExportFormat::Ulog,
        ExportFormat::Ubx,
        ExportFormat::Mavlink,
        ExportFormat::Native,
    ];
    if cfg!(feature = "ros2") {
        formats.push(ExportFormat::Mcap);
    }
    for to in formats {
        let input = dir.path().join(format!("in.{to:?}"));
        std::fs::write(&input, encode_stream(to, &d, &s).unwrap()).unwrap();
        for rebase in [false, true] {
            let a = ImportArgs {
                rebase_time: rebase,
                ..ImportArgs::default()
            };
            let p = ProtocolArgs::default();
            let (streamed, whole) = (dir.path().join("s.log"), dir.path().join("w.log"));
            let rs = import(&input, &p, &a, &streamed).unwrap();
            let rw = load_with(&input, &p, &a).unwrap().write(&whole).unwrap();
            let what = format!("{to:?}, rebase {rebase}");
            assert_eq!(
                std::fs::read(&streamed).unwrap(),
                std::fs::read(&whole).unwrap(),
                "{what}: log bytes"
            );
            assert_eq!(
                (rs.samples, rs.duration_s, rs.sample_rate_hz),
                (rw.samples, rw.duration_s, rw.sample_rate_hz),
                "{what}"
            );
            assert_eq!(
                (&rs.timing, &rs.decoded),
                (&rw.timing, &rw.decoded),
                "{what}"
            );
            // The faults were there to be derived afresh (the comparison compares something):
            // the decoder's own flags differ from the imported ones.
            if to != ExportFormat::Native {
                let t = rs.timing.unwrap();
                assert!(t.contains("; 1 gap (5 samples missing)"), "{what}: {t}");
                assert!(t.contains("(1 of them a restart)"), "{what}: {t}");
                let flags = |v: &[Sample]| v.iter().map(|x| x.flags).collect::<Vec<_>>();
                let decoded = read_any(&input, &ProtocolConfig::auto()).unwrap().samples;
                let (_, imported, _) = imuprep::io::log::read_log(&streamed).unwrap();
                assert_ne!(flags(&decoded), flags(&imported), "{what}");
            }
        }
    }
}

#[test]
fn a_streamed_export_writes_what_the_whole_samples_encode_to() {
    let (d, s) = faulty();
    let dir = tempfile::tempdir().unwrap();
    let ulog = dir.path().join("in.ulg");
    std::fs::write(&ulog, encode_stream(ExportFormat::Ulog, &d, &s).unwrap()).unwrap();
    let mut formats = vec![
        ExportFormat::Native,
        ExportFormat::Ubx,
        ExportFormat::Mavlink,
        ExportFormat::Ulog,
        ExportFormat::Csv,
    ];
    if cfg!(feature = "ros2") {
        formats.push(ExportFormat::Mcap);
    }
    for input in [Path::new("replay/drive.log"), ulog.as_path()] {
        let f = read_any(input, &ProtocolConfig::auto()).unwrap();
        for &to in &formats {
            let out = dir.path().join("out.bin");
            let log = Recording {
                path: input.to_path_buf(),
                ..Recording::default()
            };
            let r = export(&log, &out, to).unwrap();
            assert_eq!(r.samples, f.samples.len());
            let want = if to == ExportFormat::Csv {
                let p = dir.path().join("want.csv");
                imuprep::io::csv::write_csv(&p, &f.samples).unwrap();
                std::fs::read(&p).unwrap()
            } else {
                let d = f.descriptor.unwrap_or_default();
                encode_stream(to, &d, &f.samples).unwrap().to_vec()
            };
            let got = std::fs::read(&out).unwrap();
            assert!(got.len() > 100_000, "{to:?}: a real stream");
            assert!(got == want, "{}, {to:?}: bytes differ", input.display());
        }
    }
}

#[test]
fn an_export_ulog_cannot_carry_is_refused_before_a_file_is_written() {
    let (mut d, mut s) = faulty();
    // A recording without gx: ULog can mark only the whole accelerometer absent.
    d.absent = 0b001;
    for x in &mut s {
        x.absent = 0b001;
        x.gyro[0] = f64::NAN;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.log");
    std::fs::write(&input, encode_stream(ExportFormat::Native, &d, &s).unwrap()).unwrap();
    let out = dir.path().join("out.ulg");
    let log = Recording {
        path: input,
        ..Recording::default()
    };
    let e = export(&log, &out, ExportFormat::Ulog).unwrap_err();
    assert!(format!("{e:#}").contains("export --to ulog"), "{e:#}");
    assert!(!out.exists(), "nothing written");
}

#[test]
fn an_import_or_export_onto_its_own_input_replaces_it_whole() {
    let (d, s) = faulty();
    let dir = tempfile::tempdir().unwrap();
    let ulg = encode_stream(ExportFormat::Ulog, &d, &s).unwrap();
    let (p, a) = (ProtocolArgs::default(), ImportArgs::default());
    // Imported elsewhere, then onto itself: the same log.
    let (input, other) = (dir.path().join("x.ulg"), dir.path().join("other.log"));
    std::fs::write(&input, &ulg).unwrap();
    import(&input, &p, &a, &other).unwrap();
    let r = import(&input, &p, &a, &input).unwrap();
    assert_eq!(r.samples, s.len());
    assert_eq!(
        std::fs::read(&input).unwrap(),
        std::fs::read(&other).unwrap()
    );
    // Exported elsewhere, then onto itself: the same CSV.
    let log = Recording {
        path: input.clone(),
        ..Recording::default()
    };
    let csv = dir.path().join("other.csv");
    export(&log, &csv, ExportFormat::Csv).unwrap();
    export(&log, &input, ExportFormat::Csv).unwrap();
    assert_eq!(std::fs::read(&input).unwrap(), std::fs::read(&csv).unwrap());
    // No temporary file is left beside them.
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".part"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn a_failed_import_or_export_leaves_an_existing_output_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.log");
    std::fs::write(&out, b"keep me").unwrap();
    // Garbage: nothing to import or export.
    let bad = dir.path().join("bad.bin");
    std::fs::write(&bad, vec![0x5Au8; 100_000]).unwrap();
    assert!(import(&bad, &ProtocolArgs::default(), &ImportArgs::default(), &out).is_err());
    let log = Recording {
        path: bad,
        ..Recording::default()
    };
    assert!(export(&log, &out, ExportFormat::Native).is_err());
    assert_eq!(std::fs::read(&out).unwrap(), b"keep me");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        2,
        "no file left"
    );
}

#[cfg(unix)]
#[test]
fn an_output_that_is_a_link_or_a_device_is_written_through() {
    let dir = tempfile::tempdir().unwrap();
    let log = Recording {
        path: "replay/drive.log".into(),
        ..Recording::default()
    };
    // A link keeps being a link; the file it names gets the export.
    let (real, link) = (dir.path().join("real.csv"), dir.path().join("link.csv"));
    std::fs::write(&real, b"old").unwrap();
    std::os::unix::fs::symlink(&real, &link).unwrap();
    let r = export(&log, &link, ExportFormat::Csv).unwrap();
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    let text = std::fs::read_to_string(&real).unwrap();
    assert_eq!(text.lines().count(), r.samples + 1, "header and rows");
    // A device cannot be replaced by a file: written directly (`-o /dev/stdout` is this case).
    let null = Path::new("/dev/null");
    export(&log, null, ExportFormat::Native).unwrap();
    let (p, a) = (ProtocolArgs::default(), ImportArgs::default());
    import(Path::new("replay/drive.log"), &p, &a, null).unwrap();
    assert!(
        !std::fs::metadata(null).unwrap().is_file(),
        "still a device"
    );
}
