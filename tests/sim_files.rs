//! The simulator's files (issue 3): scenario validation with key paths, unknown keys, the
//! committed and documented scenarios, and the truth CSV (exact round trip, header, gzip).
//! Split from tests/sim_realism.rs, which keeps the realism checks.

mod sim_common;

use imuprep::sample::CHANNEL_NAMES;
use imuprep::sim::{
    Effect, N_EFFECTS, Scenario, SimError, Simulator, TruthWriter, write_truth_file,
};
use sim_common::{DRIVE, STATIC_BENCH, run, static_scenario, truth_bytes};

#[test]
fn validation_reports_every_problem_with_its_key_path() {
    let text = r#"
[sensor]
sample_rate_hz = -100.0
[motion]
kind = "drive"
[[motion.segments]]
kind = "turn"
yaw_rate_deg_s = 10.0
duration_s = 5.0
[[motion.segments]]
kind = "stop"
duration_s = 0.0
[[errors.gauss_markov]]
tau_s = 0.0
[errors.ar_bias]
gyro_coeffs = [1.2, 0.3]
gyro_innovation_sd_deg_h = [1.0, 1.0, 1.0]
[errors.gross]
rate_per_sample = 2.0
amplitude_sigma = [30.0, 6.0]
channels = ["gx", "qq"]
[errors.temperature]
t0_c = 25.0
[errors.misalignment]
gyro_mrad = [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
"#;
    let err = Scenario::from_toml_str(text).unwrap_err();
    let SimError::Invalid(issues) = &err else {
        panic!("expected Invalid, got {err}")
    };
    let paths: Vec<&str> = issues.iter().map(|i| i.path.as_str()).collect();
    for want in [
        "sensor.sample_rate_hz",
        "motion.segments[0]",
        "motion.segments[1].duration_s",
        "errors.gauss_markov[0].tau_s",
        "errors.ar_bias.gyro_coeffs",
        "errors.gross.rate_per_sample",
        "errors.gross.amplitude_sigma",
        "errors.gross.channels[1]",
        "errors.temperature",
        "errors.misalignment.gyro_mrad[0][0]",
    ] {
        assert!(paths.contains(&want), "missing {want} in {paths:?}");
    }
    // The message names the problem, e.g. the turn at standstill.
    assert!(issues.iter().any(|i| i.message.contains("standstill")));
    // And the Display lists them all.
    assert!(err.to_string().contains("errors.gauss_markov[0].tau_s"));
}

#[test]
fn unknown_keys_are_rejected_even_inside_tagged_tables() {
    for bad in [
        "[sensor]\nsample_rate_hz = 100.0\nsample_rate = 5\n[motion]\nkind = \"static\"\nduration_s = 1.0",
        "[sensor]\nsample_rate_hz = 100.0\n[motion]\nkind = \"static\"\nduration_s = 1.0\npitch = 3.0",
        "[sensor]\nsample_rate_hz = 100.0\n[motion]\nkind = \"drive\"\n[[motion.segments]]\nkind = \"stop\"\nduration = 3.0",
        "[sensor]\nsample_rate_hz = 100.0\n[motion]\nkind = \"static\"\nduration_s = 1.0\n[errors.white_noise]\narw = [1.0, 1.0, 1.0]",
    ] {
        match Scenario::from_toml_str(bad) {
            Err(SimError::Parse(msg)) => assert!(msg.contains("unknown"), "{msg}"),
            other => panic!("expected a parse error for {bad:?}, got {other:?}"),
        }
    }
}

#[test]
fn replay_scenarios_parse_and_validate() {
    let s = Scenario::from_toml_str(STATIC_BENCH).unwrap();
    let sim = Simulator::new(&s, s.seed.unwrap()).unwrap();
    assert_eq!(sim.len(), 60_000);
    let d = Scenario::from_toml_str(DRIVE).unwrap();
    let sim = Simulator::new(&d, d.seed.unwrap()).unwrap();
    assert_eq!(sim.len(), 30_000); // 5 minutes at 100 Hz
    // Every effect family is on in the drive.
    assert_eq!(sim.enabled_effects().count_ones() as usize, N_EFFECTS);
}

#[test]
fn truth_csv_round_trips_every_f64_exactly_and_matches_its_header() {
    let scn = Scenario::from_toml_str(DRIVE).unwrap();
    let mut sim = Simulator::new(&scn, 8).unwrap();
    let header = sim.truth_header();
    let ncol = header.split(',').count();
    for _ in 0..2000 {
        let r = sim.next_record().unwrap();
        let mut line = Vec::new();
        r.truth.write_csv_row(&mut line).unwrap();
        let line = String::from_utf8(line).unwrap();
        let fields: Vec<&str> = line.trim_end().split(',').collect();
        assert_eq!(fields.len(), ncol);
        let get = |name: &str| {
            let i = header.split(',').position(|h| h == name).unwrap();
            fields[i]
        };
        for (c, ch) in CHANNEL_NAMES.iter().enumerate() {
            assert_eq!(
                get(&format!("true_{ch}")).parse::<f64>().unwrap(),
                r.truth.true_signal[c]
            );
            for e in Effect::ALL {
                let v: f64 = get(&format!("{}_{ch}", e.name())).parse().unwrap();
                assert_eq!(v.to_bits(), r.truth.component(e, c).to_bits());
            }
        }
        assert_eq!(get("t_s").parse::<f64>().unwrap(), r.truth.t_s);
        assert_eq!(get("seq").parse::<u32>().unwrap(), r.sample.seq);
        assert_eq!(get("t_ns").parse::<u64>().unwrap(), r.sample.t_ns);
    }
}

#[test]
fn truth_header_lists_only_enabled_effects() {
    let scn = static_scenario(
        1.0,
        "[errors.white_noise]\narw_deg_sqrt_h = [0.3, 0.3, 0.3]",
    );
    let h = Simulator::new(&scn, 0).unwrap().truth_header();
    assert_eq!(
        h,
        "t_s,seq,t_ns,true_gx,true_gy,true_gz,true_ax,true_ay,true_az,\
         noise_gx,noise_gy,noise_gz,noise_ax,noise_ay,noise_az,dropped,duplicated"
    );
}

#[test]
fn gzip_truth_file_decompresses_to_the_plain_file() {
    use std::io::Read;
    let scn = Scenario::from_toml_str(STATIC_BENCH).unwrap();
    let short = Scenario {
        motion: match scn.motion.clone() {
            imuprep::sim::scenario::MotionConfig::Static { .. } => static_scenario(30.0, "").motion,
            m => m,
        },
        ..scn
    };
    let dir = std::env::temp_dir().join(format!("imuprep_sim_test_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let plain = dir.join("t.csv");
    let gz = dir.join("t.csv.gz");
    let rows = write_truth_file(&plain, &short, 5).unwrap();
    assert_eq!(rows, 3000);
    write_truth_file(&gz, &short, 5).unwrap();
    let mut unzipped = Vec::new();
    flate2::read::GzDecoder::new(std::fs::File::open(&gz).unwrap())
        .read_to_end(&mut unzipped)
        .unwrap();
    assert_eq!(unzipped, std::fs::read(&plain).unwrap());
    assert_eq!(unzipped, truth_bytes(&short, 5));
    // The streaming writer gives the same bytes.
    let mut sim = Simulator::new(&short, 5).unwrap();
    let p2 = dir.join("t2.csv");
    let mut w = TruthWriter::create(&p2, &sim.truth_header()).unwrap();
    while let Some(r) = sim.next_record() {
        w.write_row(&r.truth).unwrap();
    }
    assert_eq!(w.finish().unwrap(), 3000);
    assert_eq!(std::fs::read(&p2).unwrap(), unzipped);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn every_toml_example_in_the_scenario_docs_parses_and_validates() {
    // Full examples (with [sensor]) parse alone; per-effect snippets are appended to a short
    // drive (a drive accepts every key a snippet may use, e.g. speed_ref_m_s).
    let base = "[sensor]\nsample_rate_hz = 100.0\n[motion]\nkind = \"drive\"\n\
                [[motion.segments]]\nkind = \"accelerate\"\nto_speed_m_s = 10.0\nduration_s = 5.0\n\
                [[motion.segments]]\nkind = \"cruise\"\nduration_s = 5.0\n";
    let doc = include_str!("../docs/scenario.md");
    let mut n = 0;
    for block in doc.split("```toml\n").skip(1) {
        let block = block.split("```").next().unwrap();
        let text = if block.contains("[sensor]") {
            block.to_string()
        } else {
            format!("{base}{block}")
        };
        let scn = Scenario::from_toml_str(&text).unwrap_or_else(|e| panic!("{e}\n---\n{text}"));
        Simulator::new(&scn, 1).unwrap();
        n += 1;
    }
    // One block per effect (15 families incl. vibration, transport, 4 temperature profiles…).
    assert!(n >= 22, "only {n} examples found");
}

#[test]
fn seq_wraps_at_u32_max() {
    let text = "[sensor]\nsample_rate_hz = 100.0\nfirst_seq = 4294967294\n[motion]\nkind = \"static\"\nduration_s = 0.05";
    let recs = run(&Scenario::from_toml_str(text).unwrap(), 0);
    let seqs: Vec<u32> = recs.iter().map(|r| r.sample.seq).collect();
    assert_eq!(seqs, vec![u32::MAX - 1, u32::MAX, 0, 1, 2]);
}
