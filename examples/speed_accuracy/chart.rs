//! The study's charts: log-log line and scatter charts written as SVG and PNG, and their data
//! as CSV.

use std::error::Error;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

/// One line of a chart.
pub(crate) struct Series {
    pub(crate) name: String,
    pub(crate) points: Vec<(f64, f64)>,
    pub(crate) color: RGBColor,
    /// Draw the points only (no line).
    pub(crate) scatter: bool,
}

impl Series {
    pub(crate) fn line(name: impl Into<String>, color: RGBColor, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points: points
                .into_iter()
                .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
                .collect(),
            color,
            scatter: false,
        }
    }

    pub(crate) fn scatter(
        name: impl Into<String>,
        color: RGBColor,
        points: Vec<(f64, f64)>,
    ) -> Self {
        Self {
            scatter: true,
            ..Self::line(name, color, points)
        }
    }
}

/// A log-log chart.
pub(crate) struct Chart<'a> {
    pub(crate) file: &'a str,
    pub(crate) title: &'a str,
    pub(crate) x_label: &'a str,
    pub(crate) y_label: &'a str,
    pub(crate) series: Vec<Series>,
    pub(crate) legend: SeriesLabelPosition,
}

pub(crate) const COLORS: [RGBColor; 5] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
];

/// A tick label on a log axis spanning `span` (its upper over its lower end): on a wide axis
/// only at mantissas 1, 2 and 5; as short as the value allows.
fn tick(v: f64, span: f64) -> String {
    if v <= 0.0 || !v.is_finite() {
        return String::new();
    }
    let exponent = v.log10().floor();
    let mantissa = v / 10f64.powf(exponent);
    if span > 30.0
        && ![1.0, 2.0, 5.0, 10.0]
            .iter()
            .any(|m| (mantissa - m).abs() < 1e-6 * m)
    {
        return String::new();
    }
    if (1e-2..1e4).contains(&v) {
        let text = format!("{v:.3}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// The axis range over `values`: whole decades, so that a log axis always has labelled ticks.
fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !lo.is_finite() || hi <= 0.0 {
        return 0.1..10.0;
    }
    let lo = 10f64.powf((lo / 1.2).log10().floor());
    let hi = 10f64.powf((hi * 1.2).log10().ceil());
    lo..hi
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    chart: &Chart,
) -> Result<(), Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let points = || chart.series.iter().flat_map(|s| s.points.iter());
    let xs = range(points().map(|p| p.0));
    let ys = range(points().map(|p| p.1));
    let (x_span, y_span) = (xs.end / xs.start, ys.end / ys.start);
    let x_tick = move |v: &f64| tick(*v, x_span);
    let y_tick = move |v: &f64| tick(*v, y_span);
    let mut c = ChartBuilder::on(&root)
        .caption(chart.title, ("sans-serif", 22))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())?;
    c.configure_mesh()
        .x_desc(chart.x_label)
        .y_desc(chart.y_label)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .x_labels(12)
        .y_labels(12)
        .x_label_formatter(&x_tick)
        .y_label_formatter(&y_tick)
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for s in &chart.series {
        let color = s.color;
        if !s.scatter {
            c.draw_series(LineSeries::new(s.points.clone(), color.stroke_width(2)))?;
        }
        c.draw_series(
            s.points
                .iter()
                .map(|&p| Circle::new(p, if s.scatter { 6 } else { 3 }, color.filled())),
        )?
        .label(&s.name)
        .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    c.configure_series_labels()
        .position(chart.legend.clone())
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", 15))
        .draw()?;
    root.present()?;
    Ok(())
}

/// Writes `chart` as SVG and PNG into `out`, and returns the two paths.
pub(crate) fn write_chart(out: &Path, chart: &Chart) -> Result<[PathBuf; 2], Box<dyn Error>> {
    let svg = out.join(format!("{}.svg", chart.file));
    let png = out.join(format!("{}.png", chart.file));
    draw(SVGBackend::new(&svg, (900, 600)).into_drawing_area(), chart)?;
    draw(
        BitMapBackend::new(&png, (900, 600)).into_drawing_area(),
        chart,
    )?;
    Ok([svg, png])
}

/// Writes `text` as `file`.csv into `out`, and returns the path.
pub(crate) fn write_csv(out: &Path, file: &str, text: &str) -> Result<PathBuf, Box<dyn Error>> {
    let path = out.join(format!("{file}.csv"));
    std::fs::write(&path, text)?;
    Ok(path)
}
