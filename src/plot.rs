//! Line charts as PNG and SVG with a bundled font (DejaVu Sans, `assets/fonts/`), so plots
//! need no system font libraries.

use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::Path;
use std::sync::Once;

static FONT: Once = Once::new();
const FONT_NAME: &str = "lash-sans";

fn ensure_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
        // The bundled font is valid; a failure here would only make text disappear.
        let _ = register_font(FONT_NAME, FontStyle::Normal, bytes);
    });
}

/// One named series of (x, y) points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
}

/// A line chart: title, axis labels (with units), series.
#[derive(Debug, Clone)]
pub struct LineChart {
    /// Title.
    pub title: String,
    /// x-axis label, with unit.
    pub x_label: String,
    /// y-axis label, with unit.
    pub y_label: String,
    /// Series.
    pub series: Vec<Series>,
    /// Fixed y range (values outside are clipped by the frame); `None` fits the data.
    pub y_range: Option<(f64, f64)>,
}

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v.filter(|x| x.is_finite()) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-300 + 1e-12 * hi.abs() {
        let pad = if hi.abs() > 0.0 { 0.05 * hi.abs() } else { 1.0 };
        return (lo - pad, hi + pad);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    c: &LineChart,
    log: bool,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    // Log-log charts plot log10 of positive data and label the axes with powers of ten.
    let tf = |v: f64| if log { v.log10() } else { v };
    let kept = |p: &&(f64, f64)| !log || (p.0 > 0.0 && p.1 > 0.0);
    let series: Vec<Vec<(f64, f64)>> = c
        .series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .filter(kept)
                .map(|&(x, y)| (tf(x), tf(y)))
                .collect()
        })
        .collect();
    let xs = range(series.iter().flat_map(|s| s.iter().map(|p| p.0)));
    let ys = c
        .y_range
        .map(|(a, b)| (tf(a), tf(b)))
        .unwrap_or_else(|| range(series.iter().flat_map(|s| s.iter().map(|p| p.1))));
    let span = (ys.1 - ys.0).abs().max(ys.0.abs()).max(ys.1.abs());
    let plain = (1e-3..1e4).contains(&span);
    let mut chart = ChartBuilder::on(&root)
        .caption(&c.title, (FONT_NAME, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(xs.0..xs.1, ys.0..ys.1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(&c.x_label)
        .y_desc(&c.y_label)
        .label_style((FONT_NAME, 14))
        .axis_desc_style((FONT_NAME, 16))
        .x_label_formatter(&|v| {
            if log {
                format!("{:.1e}", 10f64.powf(*v))
            } else {
                format!("{v}")
            }
        })
        .y_label_formatter(&|v| {
            if log {
                format!("{:.1e}", 10f64.powf(*v))
            } else if plain {
                format!("{v:.4}")
                    .trim_end_matches('0')
                    .trim_end_matches('.')
                    .to_string()
            } else if v.abs() < 1e-9 * (ys.1 - ys.0).abs() {
                "0".to_string()
            } else {
                format!("{v:.2e}")
            }
        })
        .draw()
        .map_err(|e| e.to_string())?;
    for (k, (s, pts)) in c.series.iter().zip(&series).enumerate() {
        let col = COLOURS[k % COLOURS.len()];
        let clamp = |&(x, y): &(f64, f64)| (x, y.clamp(ys.0.min(ys.1), ys.0.max(ys.1)));
        if log {
            chart
                .draw_series(pts.iter().map(|p| Circle::new(clamp(p), 4, col.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart
            .draw_series(LineSeries::new(pts.iter().map(clamp), col.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
    }
    if c.series.len() > 1 || c.series.first().is_some_and(|s| !s.name.is_empty()) {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT_NAME, 14))
            .draw()
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}

impl LineChart {
    /// Writes `<stem>.png` and `<stem>.svg` (stem without extension).
    pub fn save(&self, stem: &Path) -> Result<(), String> {
        self.save_with(stem, false)
    }

    /// Writes `<stem>.png` and `<stem>.svg` with logarithmic x and y axes and a marker at
    /// every point (work-precision diagrams, scaling plots); non-positive points are skipped.
    pub fn save_log_log(&self, stem: &Path) -> Result<(), String> {
        self.save_with(stem, true)
    }

    fn save_with(&self, stem: &Path, log: bool) -> Result<(), String> {
        ensure_font();
        let png = stem.with_extension("png");
        let svg = stem.with_extension("svg");
        draw(
            BitMapBackend::new(&png, (1000, 600)).into_drawing_area(),
            self,
            log,
        )
        .map_err(|e| format!("{}: {e}", png.display()))?;
        draw(SVGBackend::new(&svg, (1000, 600)).into_drawing_area(), self, log)
            .map_err(|e| format!("{}: {e}", svg.display()))?;
        Ok(())
    }
}
