//! Line plots of the diagnosis reports (residual spectra, Allan deviations, effect overlays,
//! line tracks): linear or log axes, a title, axis labels and a legend, drawn with `plotters`'
//! SVG backend in the style of [`super::allan::plot`].
//!
//! Axis ranges: a log axis spans the whole decades around the data; a linear axis is widened to
//! multiples of the "nice" step 1, 2 or 5 × 10^k that gives about six ticks (Heckbert 1990,
//! "Nice numbers for graph labels", Graphics Gems). plotters chooses the ticks inside the range.
//! Points that are not finite (or not positive on a log axis) are skipped and break the line.

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use std::ops::Range;

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

/// The plots' colours (matplotlib's "tab10" and a grey), by name; shared with `allan/plot.rs`.
pub(super) mod palette {
    use plotters::style::RGBColor;
    pub const BLUE: RGBColor = RGBColor(31, 119, 180);
    pub const ORANGE: RGBColor = RGBColor(255, 127, 14);
    pub const GREEN: RGBColor = RGBColor(44, 160, 44);
    pub const RED: RGBColor = RGBColor(214, 39, 40);
    pub const PURPLE: RGBColor = RGBColor(148, 103, 189);
    pub const BROWN: RGBColor = RGBColor(140, 86, 75);
    pub const GREY: RGBColor = RGBColor(85, 85, 85);
}

const COLORS: [RGBColor; 6] = {
    use palette::*;
    [BLUE, RED, GREEN, ORANGE, PURPLE, GREY]
};

/// plotters' SVG backend writes a font of size `n` as `n / 1.24` px: 15 gives 12 px.
const FONT: (&str, u32) = ("sans-serif", 15);

fn nice_step(span: f64, target: f64) -> f64 {
    let raw = span / target;
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let nice = [(1.5, 1.0), (3.5, 2.0), (7.5, 5.0)]
        .iter()
        .find(|(lim, _)| f < *lim)
        .map_or(10.0, |(_, n)| *n);
    nice * mag
}

/// The axis range of `vals` (in data units): whole decades on a log axis, multiples of a nice
/// step on a linear one; 0..1 (or 1..10) when no value is usable.
fn axis_range(vals: impl Iterator<Item = f64>, log: bool) -> Range<f64> {
    let usable = |v: &f64| v.is_finite() && (!log || *v > 0.0);
    let u = |v: f64| if log { v.log10() } else { v };
    let (mut lo, mut hi) = vals
        .filter(usable)
        .map(u)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        (lo, hi) = (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        let pad = if lo.abs() > 0.0 { 0.1 * lo.abs() } else { 1.0 };
        (lo, hi) = (lo - pad, hi + pad);
    }
    if log {
        let (lo, hi) = (lo.floor(), hi.ceil().max(lo.floor() + 1.0));
        // Widened by a hair: plotters finds the first decade tick as 10^ceil(log10(start)),
        // which rounding can push one decade past the start (log10(0.1) > -1 in floats).
        10f64.powf(lo) * (1.0 - 1e-9)..10f64.powf(hi) * (1.0 + 1e-9)
    } else {
        let st = nice_step(hi - lo, 6.0);
        (lo / st).floor() * st..(hi / st).ceil() * st
    }
}

fn decade_label(v: &f64) -> String {
    format!("{v:.0e}")
}

/// The unbroken runs of a series: the points usable on the axes, split where one is not.
fn runs(s: &Series, log_x: bool, log_y: bool) -> Vec<Vec<(f64, f64)>> {
    let ok = |v: f64, log: bool| v.is_finite() && (!log || v > 0.0);
    let pts: Vec<Option<(f64, f64)>> =
        s.x.iter()
            .zip(&s.y)
            .map(|(&x, &y)| (ok(x, log_x) && ok(y, log_y)).then_some((x, y)))
            .collect();
    pts.split(Option::is_none)
        .map(|r| r.iter().flatten().copied().collect::<Vec<_>>())
        .filter(|r| !r.is_empty())
        .collect()
}

fn draw<X, Y>(buf: &mut String, (w, h): (u32, u32), plot: &Plot, x: X, y: Y) -> Result<(), String>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let e = |e: DrawingAreaErrorKind<_>| e.to_string();
    let root = SVGBackend::with_string(buf, (w, h)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(&plot.title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)
        .map_err(e)?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(&plot.x_label)
        .y_desc(&plot.y_label)
        .label_style(FONT)
        .axis_desc_style(FONT);
    if plot.log_x {
        mesh.x_label_formatter(&decade_label);
    }
    if plot.log_y {
        mesh.y_label_formatter(&decade_label);
    }
    mesh.draw().map_err(e)?;
    for (s, color) in plot.series.iter().zip(COLORS.iter().cycle()) {
        let mut runs = runs(s, plot.log_x, plot.log_y).into_iter();
        // The first run (empty if none) carries the legend entry, so every series has one.
        let first = runs.next().unwrap_or_default();
        chart
            .draw_series(LineSeries::new(first, color.stroke_width(1)))
            .map_err(e)?
            .label(s.label.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
        for r in runs {
            chart
                .draw_series(LineSeries::new(r, color.stroke_width(1)))
                .map_err(e)?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(FONT)
        .draw()
        .map_err(e)?;
    root.present().map_err(e)
}

/// Render `plot` as an SVG document of `width` × `height` pixels.
pub fn render(plot: &Plot, width: u32, height: u32) -> Result<String, String> {
    let xr = axis_range(
        plot.series.iter().flat_map(|s| s.x.iter().copied()),
        plot.log_x,
    );
    let yr = axis_range(
        plot.series.iter().flat_map(|s| s.y.iter().copied()),
        plot.log_y,
    );
    let mut buf = String::new();
    let size = (width, height);
    match (plot.log_x, plot.log_y) {
        (true, true) => draw(&mut buf, size, plot, xr.log_scale(), yr.log_scale()),
        (true, false) => draw(&mut buf, size, plot, xr.log_scale(), yr),
        (false, true) => draw(&mut buf, size, plot, xr, yr.log_scale()),
        (false, false) => draw(&mut buf, size, plot, xr, yr),
    }?;
    Ok(buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps_and_ranges() {
        assert_eq!(nice_step(10.0, 5.0), 2.0);
        assert_eq!(nice_step(0.07, 6.0), 0.01);
        let r = axis_range([0.013, 0.068].into_iter(), false);
        assert!((r.start - 0.01).abs() < 1e-12 && (r.end - 0.07).abs() < 1e-12);
        let r = axis_range([0.02, 0.0, 30.0].into_iter(), true);
        assert!((r.start / 0.01 - 1.0).abs() < 1e-8 && (r.end / 100.0 - 1.0).abs() < 1e-8);
        let r = axis_range(std::iter::empty(), true);
        assert!((r.start - 1.0).abs() < 1e-8 && (r.end / 10.0 - 1.0).abs() < 1e-8);
    }

    #[test]
    fn log_plot_has_title_legend_and_a_zero_breaks_the_line() {
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
        let s = render(&p, 640, 400).unwrap();
        assert!(s.starts_with("<svg") && s.trim_end().ends_with("</svg>"));
        // plotters writes each text on a line of its own.
        for lab in [
            "before",
            "after",
            "Allan &lt;deviation&gt;",
            "tau (s)",
            "1e-1",
            "1e1",
        ] {
            assert!(s.contains(&format!(">\n{lab}\n<")), "missing {lab}");
        }
        assert_eq!(runs(&p.series[1], true, true).len(), 2);
        // Lines of "after" (red): two runs plus the legend sample.
        let red = s
            .lines()
            .filter(|l| l.contains("<polyline") && l.contains("#D62728"))
            .count();
        assert_eq!(red, 3, "{s}");
    }

    #[test]
    fn linear_plot_spans_nice_multiples_and_draws_every_point() {
        let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
        let series = |label: &str, f: &dyn Fn(f64) -> f64| Series {
            label: label.into(),
            x: t.clone(),
            y: t.iter().map(|&v| f(v)).collect(),
        };
        let p = Plot {
            title: "gz: effect 1 (step) over the residual before it".into(),
            x_label: "t (s)".into(),
            y_label: "residual".into(),
            log_x: false,
            log_y: false,
            series: vec![
                series("residual before", &|v| (v * 3.0).sin() * 0.013 + 0.002),
                series("fitted step", &|v| if v > 4.0 { 0.01 } else { 0.0 }),
            ],
        };
        let s = render(&p, 800, 480).unwrap();
        // y spans −0.011..0.015, widened to the step 0.005: −0.015..0.015, both labelled.
        for lab in ["residual before", "fitted step", "-0.015", "0.015", "t (s)"] {
            assert!(s.contains(&format!(">\n{lab}\n<")), "missing {lab}");
        }
        let long: Vec<usize> = s
            .lines()
            .filter(|l| l.starts_with("<polyline"))
            .map(|l| l.matches(',').count())
            .filter(|&n| n > 2)
            .collect();
        assert_eq!(long, [200, 200], "{s}");
    }
}
