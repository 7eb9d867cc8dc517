//! Minimal dependency-free SVG line plots: linear or log axes, tick labels, a legend.
//!
//! Data map to the plot rectangle by x_px = L + (u(x) − u_min)/(u_max − u_min)·W with u = x or
//! log₁₀ x (and likewise for y, flipped). Linear ticks are the "nice" steps 1, 2, 5 × 10^k that
//! give 4–8 ticks (Heckbert 1990, "Nice numbers for graph labels", Graphics Gems); log ticks are
//! the decades, plus 2 and 5 within each decade when fewer than three decades are shown.
//! Points that are not finite (or not positive on a log axis) are skipped and break the line.

use std::fmt::Write;

/// One line.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
}

/// A plot.
#[derive(Clone, Debug)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
}

const COLORS: [&str; 6] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#555555",
];

fn nice_step(span: f64, target: f64) -> f64 {
    let raw = span / target;
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let nice = if f < 1.5 {
        1.0
    } else if f < 3.5 {
        2.0
    } else if f < 7.5 {
        5.0
    } else {
        10.0
    };
    nice * mag
}

fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let e = a.log10().floor() as i32;
        let m = v / 10f64.powi(e);
        if (m - m.round()).abs() < 1e-9 {
            format!("{}e{}", m.round(), e)
        } else {
            format!("{m:.1}e{e}")
        }
    } else {
        let s = format!("{v:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

struct Axis {
    log: bool,
    lo: f64,
    hi: f64,
}

impl Axis {
    fn new(vals: impl Iterator<Item = f64>, log: bool) -> Axis {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in vals {
            if v.is_finite() && (!log || v > 0.0) {
                let u = if log { v.log10() } else { v };
                lo = lo.min(u);
                hi = hi.max(u);
            }
        }
        if !lo.is_finite() {
            (lo, hi) = (0.0, 1.0);
        }
        if hi - lo < 1e-12 {
            let pad = if lo.abs() > 0.0 { 0.1 * lo.abs() } else { 1.0 };
            lo -= pad;
            hi += pad;
        }
        if log {
            (lo, hi) = (lo.floor(), hi.ceil());
            if hi - lo < 1.0 {
                hi = lo + 1.0;
            }
        } else {
            let st = nice_step(hi - lo, 6.0);
            (lo, hi) = ((lo / st).floor() * st, (hi / st).ceil() * st);
        }
        Axis { log, lo, hi }
    }
    fn u(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.log && v <= 0.0) {
            return None;
        }
        let u = if self.log { v.log10() } else { v };
        Some((u - self.lo) / (self.hi - self.lo))
    }
    fn ticks(&self) -> Vec<f64> {
        if self.log {
            let decades = (self.hi - self.lo).round() as i32;
            let mut t = Vec::new();
            for e in (self.lo as i32)..=(self.hi as i32) {
                let base = 10f64.powi(e);
                t.push(base);
                if decades < 3 && e < self.hi as i32 {
                    t.push(2.0 * base);
                    t.push(5.0 * base);
                }
            }
            t
        } else {
            let st = nice_step(self.hi - self.lo, 6.0);
            let n = ((self.hi - self.lo) / st).round() as i32;
            (0..=n).map(|i| self.lo + i as f64 * st).collect()
        }
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Render `plot` as an SVG document of `width` × `height` pixels.
pub fn render(plot: &Plot, width: u32, height: u32) -> String {
    let (w, h) = (width as f64, height as f64);
    let (l, r, t, b) = (80.0, 20.0, 40.0, 55.0);
    let (pw, ph) = (w - l - r, h - t - b);
    let xa = Axis::new(
        plot.series.iter().flat_map(|s| s.x.iter().copied()),
        plot.log_x,
    );
    let ya = Axis::new(
        plot.series.iter().flat_map(|s| s.y.iter().copied()),
        plot.log_y,
    );
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(o, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        o,
        r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
        w / 2.0,
        esc(&plot.title)
    );
    // Grid and ticks.
    for tv in xa.ticks() {
        if let Some(u) = xa.u(tv).filter(|u| (-1e-9..=1.0 + 1e-9).contains(u)) {
            let x = l + u * pw;
            let _ = writeln!(
                o,
                r##"<line x1="{x:.1}" y1="{t}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/>"##,
                t + ph
            );
            let _ = writeln!(
                o,
                r#"<text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
                t + ph + 16.0,
                fmt_num(tv)
            );
        }
    }
    for tv in ya.ticks() {
        if let Some(u) = ya.u(tv).filter(|u| (-1e-9..=1.0 + 1e-9).contains(u)) {
            let y = t + (1.0 - u) * ph;
            let _ = writeln!(
                o,
                r##"<line x1="{l}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/>"##,
                l + pw
            );
            let _ = writeln!(
                o,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
                l - 6.0,
                y + 4.0,
                fmt_num(tv)
            );
        }
    }
    let _ = writeln!(
        o,
        r#"<rect x="{l}" y="{t}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
    );
    let _ = writeln!(
        o,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
        l + pw / 2.0,
        h - 12.0,
        esc(&plot.x_label)
    );
    let _ = writeln!(
        o,
        r#"<text x="16" y="{:.1}" text-anchor="middle" transform="rotate(-90 16 {:.1})">{}</text>"#,
        t + ph / 2.0,
        t + ph / 2.0,
        esc(&plot.y_label)
    );
    // Lines.
    for (i, s) in plot.series.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let mut d = String::new();
        let mut pen_down = false;
        for (x, y) in s.x.iter().zip(&s.y) {
            match (xa.u(*x), ya.u(*y)) {
                (Some(ux), Some(uy)) => {
                    let (px, py) = (l + ux * pw, t + (1.0 - uy) * ph);
                    let _ = write!(d, "{}{px:.1},{py:.1} ", if pen_down { "L" } else { "M" });
                    pen_down = true;
                }
                _ => pen_down = false,
            }
        }
        let _ = writeln!(
            o,
            r#"<path d="{}" fill="none" stroke="{color}" stroke-width="1.3"/>"#,
            d.trim_end()
        );
    }
    // Legend, top right.
    let lw = 12.0
        + 7.0
            * plot
                .series
                .iter()
                .map(|s| s.label.chars().count())
                .max()
                .unwrap_or(0) as f64
        + 30.0;
    let lx = l + pw - lw - 8.0;
    let _ = writeln!(
        o,
        r##"<rect x="{lx:.1}" y="{:.1}" width="{lw:.1}" height="{:.1}" fill="white" fill-opacity="0.85" stroke="#999"/>"##,
        t + 8.0,
        8.0 + 18.0 * plot.series.len() as f64
    );
    for (i, s) in plot.series.iter().enumerate() {
        let y = t + 22.0 + 18.0 * i as f64;
        let color = COLORS[i % COLORS.len()];
        let _ = writeln!(
            o,
            r#"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{color}" stroke-width="2"/>"#,
            lx + 6.0,
            lx + 28.0
        );
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
            lx + 34.0,
            y + 4.0,
            esc(&s.label)
        );
    }
    o.push_str("</svg>\n");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps_and_labels() {
        assert_eq!(nice_step(10.0, 5.0), 2.0);
        assert_eq!(nice_step(0.07, 6.0), 0.01);
        assert_eq!(fmt_num(0.5), "0.5");
        assert_eq!(fmt_num(1e-5), "1e-5");
        assert_eq!(fmt_num(2500.0), "2500");
    }

    #[test]
    fn log_plot_has_decade_ticks_legend_and_skips_nonpositive() {
        let p = Plot {
            title: "Allan <deviation>".into(),
            x_label: "tau (s)".into(),
            y_label: "adev".into(),
            log_x: true,
            log_y: true,
            series: vec![
                Series {
                    label: "before".into(),
                    x: vec![0.01, 0.1, 1.0, 10.0],
                    y: vec![1.0, 0.3, 0.1, 0.05],
                },
                Series {
                    label: "after".into(),
                    x: vec![0.01, 0.1, 1.0, 10.0],
                    y: vec![1.0, 0.0, 0.1, 0.03],
                },
            ],
        };
        let s = render(&p, 640, 400);
        assert!(s.starts_with("<svg") && s.trim_end().ends_with("</svg>"));
        for lab in [
            ">0.01<",
            ">0.1<",
            ">1<",
            ">10<",
            ">before<",
            ">after<",
            "&lt;deviation&gt;",
        ] {
            assert!(s.contains(lab), "missing {lab}");
        }
        // The zero in "after" breaks its line into two sub-paths.
        let after_path = s.lines().filter(|l| l.starts_with("<path")).nth(1).unwrap();
        assert_eq!(after_path.matches('M').count(), 2);
    }
}
