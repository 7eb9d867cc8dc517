//! The Allan plot of a log: one log-log panel per channel (gyros on top, accelerometers below)
//! with the measured overlapping deviation, its confidence band (shaded), the fitted model
//! (dashed) and the line of every resolved term (thin). Drawn with `plotters`' SVG backend
//! (default features off: no font files, the SVG names the font and the viewer renders it).

use super::report::{AllanReport, ChannelAllan};
use super::terms::Term;
use crate::analysis::line_plot::palette::{BLUE, BROWN, GREEN, ORANGE, PURPLE, RED};
use plotters::prelude::*;

const TERM_COLORS: [RGBColor; 5] = [PURPLE, GREEN, ORANGE, RED, BROWN];
const CURVE: RGBColor = BLUE;

fn decade_label(v: &f64) -> String {
    format!("{v:.0e}")
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    ch: &ChannelAllan,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let pts = &ch.fit.points;
    let (x0, x1) = (pts[0].tau_s / 1.5, pts[pts.len() - 1].tau_s * 1.5);
    let ys = pts
        .iter()
        .flat_map(|p| [p.lo, p.hi, p.adev, p.model_adev])
        .filter(|v| v.is_finite() && *v > 0.0);
    let (mut y0, mut y1) = ys.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !(y0 > 0.0 && y1 > y0) {
        y0 = 1e-9;
        y1 = 1.0;
    }
    let (y0, y1) = (y0 / 2.0, y1 * 2.0);
    let unit = if ch.gyro { "rad/s" } else { "m/s^2" };
    let mut chart = ChartBuilder::on(area)
        .caption(&ch.channel, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("tau (s)")
        .y_desc(format!("Allan deviation ({unit})"))
        .x_label_formatter(&decade_label)
        .y_label_formatter(&decade_label)
        .draw()?;
    // confidence band: upper limits left to right, lower limits back
    let band: Vec<(f64, f64)> = pts
        .iter()
        .map(|p| (p.tau_s, p.hi))
        .chain(pts.iter().rev().map(|p| (p.tau_s, p.lo)))
        .filter(|(_, y)| y.is_finite() && *y > 0.0)
        .collect();
    chart
        .draw_series(std::iter::once(Polygon::new(band, CURVE.mix(0.2))))?
        .label("68 % band")
        .legend(|(x, y)| Rectangle::new([(x, y - 4), (x + 18, y + 4)], CURVE.mix(0.2).filled()));
    chart
        .draw_series(LineSeries::new(
            pts.iter().map(|p| (p.tau_s, p.adev)),
            CURVE.stroke_width(2),
        ))?
        .label("overlapping ADEV")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], CURVE.stroke_width(2)));
    chart.draw_series(
        pts.iter()
            .map(|p| Circle::new((p.tau_s, p.adev), 2, CURVE.filled())),
    )?;
    // a fine τ grid for the model lines
    let grid: Vec<f64> = (0..=200)
        .map(|i| x0 * (x1 / x0).powf(i as f64 / 200.0))
        .collect();
    chart
        .draw_series(DashedLineSeries::new(
            grid.iter().map(|&t| (t, ch.fit.model_var(t).sqrt())),
            6,
            4,
            BLACK.stroke_width(1),
        ))?
        .label("fitted model")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
    for (t, color) in Term::ALL.iter().zip(TERM_COLORS) {
        let r = ch.fit.term(*t);
        let Some(v) = r.value() else { continue };
        let line: Vec<(f64, f64)> = grid
            .iter()
            .map(|&x| (x, v * t.basis(x).sqrt()))
            .filter(|(_, y)| *y >= y0 && *y <= y1)
            .collect();
        chart
            .draw_series(LineSeries::new(line, color.stroke_width(1)))?
            .label(format!("{} = {v:.3e}", t.letter()))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", 11))
        .draw()?;
    Ok(())
}

/// The SVG text of the report's plot (an empty panel for a channel not analysed).
pub fn allan_svg(report: &AllanReport) -> Result<String, String> {
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, (1500, 900)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let title = format!(
            "Overlapping Allan deviation: {} ({:.0} s at {:.2} Hz)",
            report.source, report.duration_s, report.rate_hz
        );
        let root = root
            .titled(&title, ("sans-serif", 18))
            .map_err(|e| e.to_string())?;
        let rows =
            if report.channels.iter().any(|c| c.gyro) && report.channels.iter().any(|c| !c.gyro) {
                2
            } else {
                1
            };
        let cols = report.channels.len().div_ceil(rows).max(1);
        let areas = root.split_evenly((rows, cols));
        for (area, ch) in areas.iter().zip(&report.channels) {
            panel(area, ch).map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(buf)
}
