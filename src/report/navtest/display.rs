//! The text report of `imuprep navtest` (markdown tables).

use std::fmt::{self, Write as _};

use super::{AttRefReport, AttRefSource, LENGTHS, NavtestReport, RecordResult, Row};

const ROW_HEAD: &str = "| outage s | variant | outages | horiz. median m | horiz. p95 m | vert. median m | vert. p95 m | heading median ° | heading p95 ° | tilt median ° |\n|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|";

fn row_table(f: &mut fmt::Formatter<'_>, rows: &[Row]) -> fmt::Result {
    writeln!(f, "{ROW_HEAD}")?;
    for l in LENGTHS {
        for w in rows.iter().filter(|w| w.length_s == l && w.outages > 0) {
            writeln!(
                f,
                "| {:.0} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
                w.length_s,
                w.variant,
                w.outages,
                w.horiz_median_m,
                w.horiz_p95_m,
                w.vert_median_m,
                w.vert_p95_m,
                w.heading_median_deg,
                w.heading_p95_deg,
                w.tilt_median_deg
            )?;
        }
    }
    Ok(())
}

fn v3(v: &[f64; 3]) -> String {
    format!("{:+.3}, {:+.3}, {:+.3}", v[0], v[1], v[2])
}

fn att_ref_table(f: &mut fmt::Formatter<'_>, name: &str, a: &AttRefReport) -> fmt::Result {
    let what = match a.source {
        AttRefSource::Course { min_speed_mps } => format!(
            "heading against the RTK course over ground (fixed epochs, ≥ {min_speed_mps:.0} m/s); no tilt reference"
        ),
        AttRefSource::Pose => {
            "heading and tilt against the post-processed pose's orientation".into()
        }
        AttRefSource::None => "none".into(),
    };
    // Without a tilt reference (a course over ground) roll, pitch and tilt have no value: a
    // dash, not "NaN°".
    let deg = |x: f64, signed: bool| match (x.is_nan(), signed) {
        (true, _) => "—".to_string(),
        (false, true) => format!("{x:+.2}°"),
        (false, false) => format!("{x:.2}°"),
    };
    writeln!(
        f,
        "\n#### {name}: heading and tilt against an independent reference\n\n{what}. \
         Constant removed (median of the GNSS-aided raw filter − reference over {} epochs from \
         the first outage on): roll {}, pitch {}, yaw {}. The aided filter itself \
         then differs by heading {} median / {} p95, tilt {} / {}.\n",
        a.epochs,
        deg(a.offset_deg[0], true),
        deg(a.offset_deg[1], true),
        deg(a.offset_deg[2], true),
        deg(a.aided_heading_deg[0], false),
        deg(a.aided_heading_deg[1], false),
        deg(a.aided_tilt_deg[0], false),
        deg(a.aided_tilt_deg[1], false)
    )?;
    writeln!(
        f,
        "| outage s | variant | outages with a reference | heading median ° | heading p95 ° | tilt median ° | tilt p95 ° |\n|---:|---|---:|---:|---:|---:|---:|"
    )?;
    let t = |x: f64| {
        if x.is_nan() {
            "—".into()
        } else {
            format!("{x:.2}")
        }
    };
    for l in LENGTHS {
        for w in a.rows.iter().filter(|w| w.length_s == l) {
            writeln!(
                f,
                "| {:.0} | {} | {} | {:.2} | {:.2} | {} | {} |",
                w.length_s,
                w.variant,
                w.outages,
                w.heading_median_deg,
                w.heading_p95_deg,
                t(w.tilt_median_deg),
                t(w.tilt_p95_deg)
            )?;
        }
    }
    Ok(())
}

fn record(f: &mut fmt::Formatter<'_>, r: &RecordResult) -> fmt::Result {
    writeln!(
        f,
        "### {}: {} IMU epochs, {} GNSS epochs ({} fixed), {:.1} s\n",
        r.name, r.imu_epochs, r.gnss_epochs, r.fixed_epochs, r.duration_s
    )?;
    for (l, n, a, b, s) in &r.schedule {
        match n {
            0 => writeln!(f, "- {l:.0} s: none (the record is too short)")?,
            1 => writeln!(
                f,
                "- {l:.0} s: 1 outage, at {a:.1} s after the first GNSS epoch"
            )?,
            _ => writeln!(
                f,
                "- {l:.0} s: {n} outages, starts {a:.1}–{b:.1} s after the first GNSS epoch, {s:.2} s apart"
            )?,
        }
    }
    writeln!(f)?;
    row_table(f, &r.rows)?;
    if let Some(a) = &r.att_ref {
        att_ref_table(f, &r.name, a)?;
    }

    writeln!(
        f,
        "\n#### {}: do no harm, (b) ≤ (a), horizontal error at the outage end\n",
        r.name
    )?;
    writeln!(
        f,
        "| outage s | outages | (a) median m | (b) median m | (b) − (a) m | median | (a) p95 m | (b) p95 m | (b) − (a) m | p95 |"
    )?;
    writeln!(f, "|---:|---:|---:|---:|---:|---|---:|---:|---:|---|")?;
    let ok = |b: bool| if b { "met" } else { "**missed**" };
    for c in r.harm.iter().filter(|c| c.outages > 0) {
        writeln!(
            f,
            "| {:.0} | {} | {:.2} | {:.2} | {:+.3} | {} | {:.2} | {:.2} | {:+.3} | {} |",
            c.length_s,
            c.outages,
            c.a_median_m,
            c.b_median_m,
            c.b_median_m - c.a_median_m,
            ok(c.median_ok()),
            c.a_p95_m,
            c.b_p95_m,
            c.b_p95_m - c.a_p95_m,
            ok(c.p95_ok())
        )?;
    }
    if !r.harm_outages.is_empty() {
        writeln!(
            f,
            "\nWhere (b) > (a): the outages with the largest (b) − (a), what imuprep changed inside \
             each and the gyro rates the coasting filter integrates differently (body x, y, z °/s; \
             x, y tilt, z turns):\n"
        )?;
        writeln!(
            f,
            "| outage s | start s | (a) m | (b) m | replaced / bias-corrected / samples | gyro: imuprep mean change (of it: replaced samples) | gyro: filter bias at start (b) − (a) | gyro: net rate difference | accel: net difference m/s² | tilt at start (b) − (a) ° |"
        )?;
        writeln!(f, "|---:|---:|---:|---:|---|---|---|---|---|---:|")?;
        for o in &r.harm_outages {
            writeln!(
                f,
                "| {:.0} | {:.1} | {:.2} | {:.2} | {} / {} / {} | {} ({}) | {} | {} | {} | {:.4} |",
                o.length_s,
                o.start_rel_s,
                o.a_m,
                o.b_m,
                o.replaced,
                o.bias_removed,
                o.samples,
                v3(&o.mean_change_dps),
                v3(&o.replaced_change_dps),
                v3(&o.filter_bias_diff_dps),
                v3(&o.net_rate_diff_dps),
                v3(&o.net_accel_diff),
                o.start_tilt_diff_deg
            )?;
        }
    }

    writeln!(
        f,
        "\n#### {}: error budget of the {:.0}-s outages, raw IMU\n",
        r.name,
        super::BUDGET_LENGTH_S
    )?;
    writeln!(
        f,
        "| coasting filter | outages | horiz. median m | horiz. p95 m | tilt median ° | heading median ° |"
    )?;
    writeln!(f, "|---|---:|---:|---:|---:|---:|")?;
    for b in &r.budget {
        writeln!(
            f,
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} |",
            b.case,
            b.outages,
            b.horiz_median_m,
            b.horiz_p95_m,
            b.tilt_median_deg,
            b.heading_median_deg
        )?;
    }

    writeln!(f, "\n#### {}: (c) fitted models\n", r.name)?;
    for blk in &r.fitted {
        let m = &blk.models;
        writeln!(
            f,
            "**{}** — `imuprep fit` on the {} ({}; {:.1}–{:.1} s after its IMU start). Bias model: {}",
            blk.label,
            m.record,
            m.options,
            m.span_s.0,
            m.span_s.1,
            match &m.bias_skipped {
                Some(why) => format!("NOT FITTED — {why}"),
                None => {
                    let mut s = format!(
                        "fitted on the longest still stretch ({:.1} s), means",
                        m.still_s
                    );
                    for (ch, v) in &m.bias_means {
                        let k = if ch.starts_with('g') {
                            1f64.to_degrees()
                        } else {
                            1.0
                        };
                        let _ = write!(s, " {ch} {:+.4}", v * k);
                    }
                    s + " (°/s, m/s²)"
                }
            }
        )?;
        writeln!(f)?;
        match &blk.not_run {
            Some(why) => writeln!(f, "Not run: {why}\n")?,
            None => {
                row_table(f, &blk.rows)?;
                writeln!(f)?;
            }
        }
    }
    for (o, e) in &r.fit_errors {
        writeln!(f, "fit ({o}) failed: {e}\n")?;
    }

    writeln!(f, "#### {}: what each variant changed\n", r.name)?;
    writeln!(
        f,
        "| variant | imuprep: replaced | bias-corrected | mean (out − in) gyro °/s, body | filter: ZUPT updates | filter gyro bias, median over run °/s, body |"
    )?;
    writeln!(f, "|---|---:|---:|---|---:|---|")?;
    let opt = |x: Option<usize>| x.map_or("—".to_string(), |v| v.to_string());
    for v in &r.variants {
        writeln!(
            f,
            "| {} | {} | {} | {} | {} | {} |",
            v.variant,
            opt(v.replaced),
            opt(v.bias_removed),
            v3(&v.mean_change_dps),
            v.zupt_updates,
            v3(&v.median_gyro_bias_dps)
        )?;
    }
    writeln!(f)?;
    match (&r.augmentation, &r.augmentation_error) {
        (Some(a), _) => {
            writeln!(
                f,
                "(d): Gauss–Markov bias parts from `allan` terms of {:.1}–{:.1} s after the IMU start (longest still stretch), per IMU channel (T_c s, σ, B resolved):",
                a.still_from_s, a.still_to_s
            )?;
            for (ch, tc, s, ok) in &a.channels {
                let (k, u) = if ch.starts_with('g') {
                    (1f64.to_degrees(), "°/s")
                } else {
                    (1.0, "m/s²")
                };
                let refused = a
                    .refused
                    .iter()
                    .find(|r| &r.0 == ch)
                    .map(|r| format!(" — REFUSED, random walk only: {}", r.1))
                    .unwrap_or_default();
                writeln!(
                    f,
                    "  {ch}: T_c {tc:.2} s, σ {:.4} {u}, B {}{refused}",
                    s * k,
                    if *ok { "resolved" } else { "upper bound" }
                )?;
            }
            if a.augmentation.is_none() {
                writeln!(
                    f,
                    "  every part refused: (d) ran as the 15-state filter, i.e. as (a)"
                )?;
            }
            if let Some((n, bounds)) = &a.noise {
                let (d, m) = (1f64.to_degrees(), &r.filter_noise);
                writeln!(
                    f,
                    "\n(e): process noise from the same `allan` terms (largest over each sensor's axes) against (a)'s, the reference filter's: gyro white {:.4} against {:.4} °/s/√Hz, accel white {:.5} against {:.5} m/s²/√Hz, gyro bias random walk {:.2e} against {:.2e} °/s/√s, accel bias random walk {:.2e} against {:.2e} m/s²/√s{}",
                    n.gyro_psd * d,
                    m.gyro_psd * d,
                    n.accel_psd,
                    m.accel_psd,
                    n.gyro_bias_rw * d,
                    m.gyro_bias_rw * d,
                    n.accel_bias_rw,
                    m.accel_bias_rw,
                    if bounds.is_empty() {
                        String::new()
                    } else {
                        format!(
                            " (upper bounds, not resolved by the stretch: {})",
                            bounds.join(", ")
                        )
                    }
                )?;
            }
        }
        (None, Some(e)) => writeln!(f, "(d), (e): not run: {e}")?,
        _ => {}
    }
    writeln!(f)
}

impl fmt::Display for NavtestReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for r in &self.records {
            record(f, r)?;
        }
        for (n, e) in &self.record_errors {
            writeln!(f, "{n}: not run: {e}")?;
        }
        if !self.drift.is_empty() {
            writeln!(f, "### Static drift of a free-inertial solution\n")?;
            writeln!(
                f,
                "| bench | variant | window s | windows | horiz. position median m | p95 m | horiz. velocity median m/s | p95 m/s |"
            )?;
            writeln!(f, "|---|---|---:|---:|---:|---:|---:|---:|")?;
            for d in &self.drift {
                writeln!(
                    f,
                    "| {} | {} | {:.0} | {} | {:.2} | {:.2} | {:.3} | {:.3} |",
                    d.bench,
                    d.variant,
                    d.window_s,
                    d.windows,
                    d.horiz_pos_median_m,
                    d.horiz_pos_p95_m,
                    d.horiz_vel_median_m_s,
                    d.horiz_vel_p95_m_s
                )?;
            }
        }
        for (n, e) in &self.drift_errors {
            writeln!(f, "{n}: not run: {e}")?;
        }
        Ok(())
    }
}
