//! The sweep's plot: error against time, one curve per knob, the Pareto front marked. Drawn with
//! plotters as SVG, and as PNG into a buffer encoded by `image`; labels use an embedded subset of
//! DejaVu Sans (fonts/LICENSE.txt), so the PNG looks the same on every machine.

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// One curve: a name and its (seconds, error) points in drawing order.
pub(crate) struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

/// What to draw.
pub(crate) struct Plot<'a> {
    pub title: String,
    pub y_label: String,
    /// Logarithmic error axis (RMSE, 1 − SSIM); linear for PSNR.
    pub log_y: bool,
    pub series: &'a [Series],
    /// The Pareto-optimal points, by increasing time.
    pub pareto: &'a [(f64, f64)],
}

/// Pixel size of the plot.
const SIZE: (u32, u32) = (960, 640);

const FONT: &[u8] = include_bytes!("fonts/DejaVuSans-subset.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is embedded and known good; a failure would only lose the labels.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Writes the plot as SVG to `path`, atomically.
pub(crate) fn write_svg(path: &Path, plot: &Plot) -> Result<(), String> {
    register_font();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        draw(&root, plot)?;
        root.present().map_err(|e| e.to_string())?;
    }
    crate::image::write::write_atomically(path, |w| w.write_all(svg.as_bytes()).map_err(|e| e.to_string())).map_err(|e| e.to_string())
}

/// Writes the plot as PNG to `path`, atomically.
pub(crate) fn write_png(path: &Path, plot: &Plot) -> Result<(), String> {
    register_font();
    let mut rgb = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        draw(&root, plot)?;
        root.present().map_err(|e| e.to_string())?;
    }
    crate::image::write::write_atomically(path, |w| {
        crate::image::output::encode_rgb8(w, &rgb, SIZE.0, SIZE.1, crate::image::output::ImageKind::Png)
    })
    .map_err(|e| e.to_string())
}

/// Colours of the curves (Tableau 10), in order.
const COLORS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// A range around `lo..hi` with a margin, for a log axis (positive) or a linear one.
fn padded(lo: f64, hi: f64, log: bool) -> (f64, f64) {
    if log {
        let (lo, hi) = (lo.max(1e-12), hi.max(lo.max(1e-12) * 1.0001));
        (lo / 1.25, hi * 1.25)
    } else {
        let m = ((hi - lo) * 0.06).max(1e-9);
        (lo - m, hi + m)
    }
}

/// A tick label with three significant digits and no trailing zeros: `0.3`, `0.0012`, `25`.
fn tick(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let decimals = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, plot: &Plot) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let pts = plot.series.iter().flat_map(|s| s.points.iter()).filter(|(t, e)| *t > 0.0 && e.is_finite() && (!plot.log_y || *e > 0.0));
    let (mut t0, mut t1, mut e0, mut e1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(t, e) in pts {
        t0 = t0.min(t);
        t1 = t1.max(t);
        e0 = e0.min(e);
        e1 = e1.max(e);
    }
    if !(t0.is_finite() && e0.is_finite()) {
        return Err("nothing to plot: no setting has a finite time and error".into());
    }
    let (t0, t1) = padded(t0, t1, true);
    let (e0, e1) = padded(e0, e1, plot.log_y);
    let mut builder = ChartBuilder::on(root);
    builder.caption(&plot.title, ("sans-serif", 24)).margin(18).x_label_area_size(52).y_label_area_size(84);
    // Two chart types (log or linear error); one drawing routine for both.
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc("wall time of the render, s (log)")
                .y_desc(plot.y_label.as_str())
                .label_style(("sans-serif", 16))
                .axis_desc_style(("sans-serif", 18))
                .light_line_style(RGBColor(238, 238, 238))
                .x_labels(10)
                .y_labels(10)
                .x_label_formatter(&|v| tick(*v))
                .y_label_formatter(&|v| tick(*v))
                .draw()
                .map_err(err)?;
            for (i, s) in plot.series.iter().enumerate() {
                let c = COLORS[i % COLORS.len()];
                let pts: Vec<(f64, f64)> =
                    s.points.iter().copied().filter(|(t, e)| *t > 0.0 && e.is_finite() && (!plot.log_y || *e > 0.0)).collect();
                chart
                    .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                    .map_err(err)?
                    .label(s.name.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], c.stroke_width(3)));
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled()))).map_err(err)?;
            }
            if !plot.pareto.is_empty() {
                let front: Vec<(f64, f64)> = plot.pareto.to_vec();
                chart
                    .draw_series(DashedLineSeries::new(front.clone(), 6, 4, BLACK.stroke_width(1)))
                    .map_err(err)?
                    .label("Pareto front")
                    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], BLACK.stroke_width(1)));
                chart.draw_series(front.iter().map(|&p| Circle::new(p, 8, BLACK.stroke_width(2)))).map_err(err)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerLeft)
                .label_font(("sans-serif", 16))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(180, 180, 180))
                .draw()
                .map_err(err)?;
        }};
    }
    if plot.log_y {
        body!(builder.build_cartesian_2d((t0..t1).log_scale(), (e0..e1).log_scale()).map_err(err)?);
    } else {
        body!(builder.build_cartesian_2d((t0..t1).log_scale(), e0..e1).map_err(err)?);
    }
    Ok(())
}
