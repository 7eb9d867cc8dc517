//! Worst-case time of one `Pipeline::push` with the embedded default config, paced as a live
//! 1-kHz sensor ("fast enough to vanish in a 1 kHz loop"): the bundled drive's samples
//! re-stamped at 1 ms and fed one per millisecond for the first 8 s, in which every stage's
//! warm-up ends, the gross-error stage identifies its six ARIMA models, and each channel starts
//! its first two searches for a vibration line and takes them up (from about 4.1 s; copies of
//! 2048 values to the stage's line-search thread). In the same go:
//! the default (`identify_defer_s = 0.5`: the models identified on a worker thread), the
//! baseline that identifies on the sample closing the warm-up window (`identify_defer_s = 0`),
//! and a control with no pipeline that only copies six 16-KB windows on the two samples where
//! the default copies them (1999, 2499): what that costs is the machine's, not imuprep's.
//!
//! `cargo bench --bench latency` prints, per variant, the median, 99.9th percentile and
//! maximum time of one call over 3 runs (the median of the runs, and every run's maximum), and
//! how many calls took over 100 µs and over 1 ms in each run. Wall clock of the pushing
//! thread: a busy machine shows in the tail, which is why each variant runs three times. On
//! Linux a last line gives the default's two warm-up calls unpaced in the thread's CPU time:
//! the work itself, without the machine's waits.

use imuprep::config::{Config, DEFAULT_TOML};
use imuprep::sample::Sample;
use std::time::{Duration, Instant};

const PERIOD: Duration = Duration::from_millis(1);
const SECONDS: usize = 8;
const RUNS: usize = 3;

fn samples() -> Vec<Sample> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/drive.log");
    let (_, s, _) =
        imuprep::io::log::read_log(std::path::Path::new(path)).expect("replay/drive.log");
    s.into_iter()
        .take(SECONDS * 1000)
        .enumerate()
        .map(|(i, mut s)| {
            s.t_ns = i as u64 * 1_000_000;
            s
        })
        .collect()
}

struct Times {
    median_ns: u64,
    p999_ns: u64,
    max_ns: u64,
    over_100us: usize,
    over_1ms: usize,
    /// Which calls took over 1 ms (their index).
    slow: Vec<usize>,
}

/// Call `f(i)` once per millisecond for `n` calls; the time of each call.
fn paced(n: usize, mut f: impl FnMut(usize)) -> Times {
    let mut t = Vec::with_capacity(n);
    let start = Instant::now();
    for i in 0..n {
        let due = start + PERIOD * i as u32;
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let t0 = Instant::now();
        f(i);
        t.push(t0.elapsed().as_nanos() as u64);
    }
    let over = |ns: u64| t.iter().filter(|&&x| x > ns).count();
    let (over_100us, over_1ms) = (over(100_000), over(1_000_000));
    let slow = (0..t.len()).filter(|&i| t[i] > 1_000_000).collect();
    t.sort_unstable();
    let q = |f: f64| t[((t.len() - 1) as f64 * f).round() as usize];
    Times {
        median_ns: q(0.5),
        p999_ns: q(0.999),
        max_ns: t[t.len() - 1],
        over_100us,
        over_1ms,
        slow,
    }
}

fn pipeline(defer_s: f64) -> imuprep::stage::Pipeline {
    let mut table: toml::Table = DEFAULT_TOML.parse().expect("default config");
    table["gross_error"]["settings"]
        .as_table_mut()
        .expect("[gross_error.settings]")
        .insert("identify_defer_s".into(), toml::Value::Float(defer_s));
    let mut cfg =
        Config::from_toml_str(&table.to_string(), std::path::Path::new(".")).expect("config");
    cfg.stages.set_sample_rate(1000.0).expect("rate");
    cfg.stages.build().expect("pipeline")
}

fn pipeline_run(defer_s: f64, input: &[Sample]) -> Times {
    let mut p = pipeline(defer_s);
    let mut out = Vec::with_capacity(64);
    paced(input.len(), |i| {
        out.clear();
        p.push(input[i], &mut out);
    })
}

/// The default pipeline unpaced, timed in the pushing thread's CPU time (which leaves out any
/// wait for the worker and any time the thread was not running): the cost of the calls that
/// close the warm-up windows (1999) and take the models over (2499), and the largest other call.
#[cfg(target_os = "linux")]
fn unpaced_cpu(input: &[Sample]) -> (u64, u64, u64) {
    fn cpu_ns() -> u64 {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: a valid timespec that outlives the call; the clock id is a constant.
        unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
    }
    let mut p = pipeline(0.5);
    let mut out = Vec::with_capacity(64);
    let mut t = Vec::with_capacity(input.len());
    for s in input {
        out.clear();
        let c0 = cpu_ns();
        p.push(*s, &mut out);
        t.push(cpu_ns() - c0);
    }
    let other = t
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != 1999 && *i != 2499)
        .map(|(_, v)| *v)
        .max()
        .unwrap_or(0);
    (t[1999], t[2499], other)
}

fn control_run() -> Times {
    let src: Vec<f64> = (0..2000).map(f64::from).collect();
    let mut dst: Vec<Vec<f64>> = (0..6).map(|_| Vec::with_capacity(src.len())).collect();
    paced(SECONDS * 1000, |i| {
        if i == 1999 || i == 2499 {
            for d in dst.iter_mut() {
                d.clear();
                d.extend_from_slice(&src);
            }
        }
        std::hint::black_box(&dst);
    })
}

fn print(name: &str, runs: &[Times]) {
    let med = |f: fn(&Times) -> u64| {
        let mut v: Vec<u64> = runs.iter().map(f).collect();
        v.sort_unstable();
        v[v.len() / 2]
    };
    let each = |f: fn(&Times) -> String| runs.iter().map(f).collect::<Vec<_>>().join("/");
    println!(
        "{name}: call median {} ns, p99.9 {:.1} µs, max {:.2} ms (runs: {}); calls > 100 µs: {}, > 1 ms: {} (at {})",
        med(|t| t.median_ns),
        med(|t| t.p999_ns) as f64 / 1e3,
        med(|t| t.max_ns) as f64 / 1e6,
        each(|t| format!("{:.2}", t.max_ns as f64 / 1e6)),
        each(|t| t.over_100us.to_string()),
        each(|t| t.over_1ms.to_string()),
        each(|t| format!("{:?}", t.slow)),
    );
}

fn main() {
    let input = samples();
    for (name, defer) in [
        ("default (identify_defer_s = 0.5)", 0.5),
        ("baseline (identify_defer_s = 0)", 0.0),
    ] {
        let runs: Vec<Times> = (0..RUNS).map(|_| pipeline_run(defer, &input)).collect();
        print(name, &runs);
    }
    let runs: Vec<Times> = (0..RUNS).map(|_| control_run()).collect();
    print(
        "control (no pipeline; six 16-KB copies on calls 1999 and 2499)",
        &runs,
    );
    #[cfg(target_os = "linux")]
    {
        let r: Vec<(u64, u64, u64)> = (0..RUNS).map(|_| unpaced_cpu(&input)).collect();
        let each = |f: fn(&(u64, u64, u64)) -> u64| {
            r.iter()
                .map(|x| format!("{:.3}", f(x) as f64 / 1e6))
                .collect::<Vec<_>>()
                .join("/")
        };
        println!(
            "default unpaced, thread CPU time (runs): close {} ms, take-over {} ms, largest other call {} ms",
            each(|x| x.0),
            each(|x| x.1),
            each(|x| x.2),
        );
    }
}
