//! Run the comparison of Tamazin et al. 2013 (Tables 1-2) on a real static recording, all six
//! channels, plus Allan and Gauss-Markov readings.
//!
//! `cargo run --release --example compare_real -- PATH [--skip-s S] [--temp-exo] [--out DIR]`
//!
//! PATH: CSV (or .csv.gz, read through `gzip -dc` into memory) with columns
//! `t_s, gyro_x_dps, gyro_y_dps, gyro_z_dps, acc_x_g, acc_y_g, acc_z_g[, temp_c]`.
//! Gyro converted to rad/s, accel to m/s^2 (g = 9.80665). Samples are taken by index at the
//! mean rate `(N-1) / (t_last - t_first)` (the mpu6050 host timestamps are bursty).
//! `--skip-s` drops a start-up transient; `--temp-exo` adds temperature as an exogenous input
//! to extra FOS rows. JSON and CSV per channel go to `--out` (default /tmp/imuprep_compare).
use imuprep::analysis::allan::overlapping_adev;
use imuprep::analysis::bias_compare::{CompareSettings, SensorKind, compare_channel};
use imuprep::analysis::gauss_markov::{GmMethod, fit_gauss_markov};
use imuprep::sample::CHANNEL_NAMES;
use std::io::Read;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: compare_real PATH [--skip-s S] [--temp-exo] [--out DIR]");
        std::process::exit(2);
    };
    let opt = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
    };
    let skip_s: f64 = opt("--skip-s").and_then(|v| v.parse().ok()).unwrap_or(0.0);
    let temp_exo = args.iter().any(|a| a == "--temp-exo");
    let out_dir = opt("--out")
        .cloned()
        .unwrap_or("/tmp/imuprep_compare".into());
    if !std::path::Path::new(path).exists() {
        eprintln!("SKIP: {path} not found (real recordings live in ../shared/data/real)");
        return;
    }
    let text = if path.ends_with(".gz") {
        let out = std::process::Command::new("gzip")
            .args(["-dc", path])
            .output()
            .expect("gzip");
        String::from_utf8(out.stdout).expect("utf8")
    } else {
        let mut s = String::new();
        std::fs::File::open(path)
            .unwrap()
            .read_to_string(&mut s)
            .unwrap();
        s
    };
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').map(|s| s.trim()).collect();
    let col = |n: &str| header.iter().position(|h| *h == n);
    let names = [
        "gyro_x_dps",
        "gyro_y_dps",
        "gyro_z_dps",
        "acc_x_g",
        "acc_y_g",
        "acc_z_g",
    ];
    let idx: Vec<usize> = names.iter().map(|n| col(n).expect("column")).collect();
    let it = col("t_s").expect("t_s");
    let itemp = col("temp_c");
    let (mut t, mut ch, mut temp) = (Vec::new(), vec![Vec::new(); 6], Vec::new());
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        if f.len() < header.len() {
            continue;
        }
        t.push(f[it].trim().parse::<f64>().unwrap());
        for (c, &i) in idx.iter().enumerate() {
            let v: f64 = f[i].trim().parse().unwrap();
            ch[c].push(if c < 3 { v.to_radians() } else { v * 9.80665 });
        }
        if let Some(i) = itemp {
            temp.push(f[i].trim().parse::<f64>().unwrap());
        }
    }
    let n = t.len();
    let rate = (n - 1) as f64 / (t[n - 1] - t[0]);
    let skip = (skip_s * rate).round() as usize;
    println!("{path}: {n} samples, mean rate {rate:.3} Hz, skipping the first {skip} samples");
    std::fs::create_dir_all(&out_dir).ok();
    let settings = CompareSettings::paper(rate);
    for c in 0..6 {
        let y = &ch[c][skip..];
        let kind = if c < 3 {
            SensorKind::Gyro
        } else {
            SensorKind::Accel
        };
        let exo: Vec<&[f64]> = if temp_exo && !temp.is_empty() {
            vec![&temp[skip..]]
        } else {
            vec![]
        };
        let t0 = std::time::Instant::now();
        let rep = compare_channel(y, &exo, CHANNEL_NAMES[c], kind, &settings).expect("compare");
        print!("{}", rep.to_text_table());
        let a = overlapping_adev(y, rate);
        if let Some(r) = a.readings() {
            println!(
                "  Allan: white {:?} ({}*sqrt(s)), bias instability {:.4e} at tau {:.1} s, RRW {:?}",
                r.white,
                kind.units().0,
                r.bias_instability,
                r.tau_min_s,
                r.rate_random_walk
            );
        }
        match fit_gauss_markov(y, rate, 2000, GmMethod::LogLeastSquares) {
            Ok(g) => println!(
                "  Gauss-Markov (log-LS ACF): sigma {:.4e}, T_c {:.3} s",
                g.sigma, g.tau_c_s
            ),
            Err(e) => println!("  Gauss-Markov: {e}"),
        }
        println!("  (channel done in {:.1} s)\n", t0.elapsed().as_secs_f64());
        let stem = std::path::Path::new(path)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .replace(".csv.gz", "")
            .replace(".csv", "");
        std::fs::write(
            format!("{out_dir}/{stem}_{}.json", CHANNEL_NAMES[c]),
            rep.to_json(),
        )
        .ok();
        std::fs::write(
            format!("{out_dir}/{stem}_{}.csv", CHANNEL_NAMES[c]),
            rep.to_csv(),
        )
        .ok();
    }
}
