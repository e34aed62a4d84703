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
    // Values beyond ±1e300 are drawn at it (the axis's span and padding stay finite).
    for x in v.filter(|x| x.is_finite()).map(|x| x.clamp(-1e300, 1e300)) {
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
                plain_tick(*v, xs.1 - xs.0)
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

/// A heatmap of a value over a regular grid, with a colour bar: cells with `None` are drawn
/// in a marker colour of their own (e.g. outside the work zone, on a singular locus).
#[derive(Debug, Clone)]
pub struct Heatmap {
    /// Title.
    pub title: String,
    /// x-axis label, with unit.
    pub x_label: String,
    /// y-axis label, with unit.
    pub y_label: String,
    /// Colour-bar label, with unit.
    pub value_label: String,
    /// Cell centres along x (increasing).
    pub xs: Vec<f64>,
    /// Cell centres along y (increasing).
    pub ys: Vec<f64>,
    /// Values row by row (y outer, x inner): `Ok(v)`, or `Err(k)` for marker class k.
    pub values: Vec<Result<f64, usize>>,
    /// Marker classes: legend name and colour (r, g, b).
    pub markers: Vec<(String, (u8, u8, u8))>,
    /// Points marked with a dot on top of the cells (e.g. near a singular locus), and
    /// their legend name.
    pub dots: (String, Vec<(f64, f64)>),
}

/// A perceptually ordered colour scale (viridis, by its published anchor colours).
fn viridis(t: f64) -> RGBColor {
    const A: [(f64, f64, f64); 6] = [
        (68.0, 1.0, 84.0),
        (65.0, 68.0, 135.0),
        (42.0, 120.0, 142.0),
        (34.0, 168.0, 132.0),
        (122.0, 209.0, 81.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 } * (A.len() - 1) as f64;
    let k = (t.floor() as usize).min(A.len() - 2);
    let f = t - k as f64;
    let mix = |a: f64, b: f64| (a + (b - a) * f).round() as u8;
    RGBColor(
        mix(A[k].0, A[k + 1].0),
        mix(A[k].1, A[k + 1].1),
        mix(A[k].2, A[k + 1].2),
    )
}

fn draw_heatmap<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    h: &Heatmap,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (main, bar) = root.split_horizontally(820);
    let half = |v: &[f64], k: usize| -> (f64, f64) {
        let d = if v.len() > 1 { (v[1] - v[0]) / 2.0 } else { 0.5 };
        (v[k] - d, v[k] + d)
    };
    let (x0, x1) = (half(&h.xs, 0).0, half(&h.xs, h.xs.len() - 1).1);
    let (y0, y1) = (half(&h.ys, 0).0, half(&h.ys, h.ys.len() - 1).1);
    let finite = h
        .values
        .iter()
        .filter_map(|v| v.as_ref().ok().copied())
        .filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (lo, hi) = if lo.is_finite() {
        (lo, if hi > lo { hi } else { lo + 1.0 })
    } else {
        (0.0, 1.0)
    };
    let mut chart = ChartBuilder::on(&main)
        .caption(&h.title, (FONT_NAME, 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(&h.x_label)
        .y_desc(&h.y_label)
        .label_style((FONT_NAME, 14))
        .axis_desc_style((FONT_NAME, 16))
        .draw()
        .map_err(|e| e.to_string())?;
    let nx = h.xs.len();
    chart
        .draw_series(h.values.iter().enumerate().map(|(c, v)| {
            let (i, k) = (c % nx, c / nx);
            let (xa, xb) = half(&h.xs, i);
            let (ya, yb) = half(&h.ys, k);
            let colour = match v {
                Ok(v) => viridis((v - lo) / (hi - lo)),
                Err(m) => {
                    let (r, g, b) = h.markers.get(*m).map(|x| x.1).unwrap_or((128, 128, 128));
                    RGBColor(r, g, b)
                }
            };
            Rectangle::new([(xa, ya), (xb, yb)], colour.filled())
        }))
        .map_err(|e| e.to_string())?;
    for (name, (r, g, b)) in &h.markers {
        let col = RGBColor(*r, *g, *b);
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(|e| e.to_string())?
            .label(name.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], col.filled()));
    }
    if !h.dots.1.is_empty() {
        chart
            .draw_series(h.dots.1.iter().map(|&p| Circle::new(p, 2, BLACK.filled())))
            .map_err(|e| e.to_string())?
            .label(h.dots.0.clone())
            .legend(|(x, y)| Circle::new((x + 7, y), 3, BLACK.filled()));
    }
    if !h.markers.is_empty() || !h.dots.1.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT_NAME, 13))
            .draw()
            .map_err(|e| e.to_string())?;
    }
    // The colour bar.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(50)
        .margin_bottom(57)
        .margin_right(10)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(|e| e.to_string())?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(&h.value_label)
        .label_style((FONT_NAME, 13))
        .axis_desc_style((FONT_NAME, 14))
        .draw()
        .map_err(|e| e.to_string())?;
    let steps = 100;
    cb.draw_series((0..steps).map(|s| {
        let a = lo + (hi - lo) * s as f64 / steps as f64;
        let b = lo + (hi - lo) * (s + 1) as f64 / steps as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            viridis((s as f64 + 0.5) / steps as f64).filled(),
        )
    }))
    .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}

impl Heatmap {
    /// Writes `<stem>.png` and `<stem>.svg` (stem without extension).
    pub fn save(&self, stem: &Path) -> Result<(), String> {
        ensure_font();
        if self.xs.is_empty() || self.ys.is_empty() || self.values.len() != self.xs.len() * self.ys.len() {
            return Err(format!(
                "heatmap: {} values for {} × {} cells",
                self.values.len(),
                self.xs.len(),
                self.ys.len()
            ));
        }
        let png = stem.with_extension("png");
        let svg = stem.with_extension("svg");
        draw_heatmap(BitMapBackend::new(&png, (1000, 800)).into_drawing_area(), self)
            .map_err(|e| format!("{}: {e}", png.display()))?;
        draw_heatmap(SVGBackend::new(&svg, (1000, 800)).into_drawing_area(), self)
            .map_err(|e| format!("{}: {e}", svg.display()))?;
        Ok(())
    }
}

/// A tick label on a linear axis spanning `span`: two significant digits of the span's
/// scale after the point, trailing zeros trimmed (2.5, not 2.5000000000000004).
fn plain_tick(v: f64, span: f64) -> String {
    let decimals = if span.abs() > 0.0 && span.is_finite() {
        (2.0 - span.abs().log10().floor()).clamp(0.0, 9.0) as usize
    } else {
        3
    };
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::{plain_tick, range};

    /// An axis over values near the largest float keeps a finite span (an infinite one
    /// hung the tick search).
    #[test]
    fn an_axis_over_huge_values_stays_finite() {
        let (lo, hi) = range([-1.7e308, 0.0, 1.7e308].into_iter());
        assert!(
            lo.is_finite() && hi.is_finite() && lo < -1e299 && hi > 1e299,
            "{lo} {hi}"
        );
        let (lo, hi) = range([2.0, 4.0].into_iter());
        assert_eq!((lo, hi), (1.9, 4.1));
    }

    /// Tick labels carry the digits the axis's span resolves, no float noise.
    #[test]
    fn tick_labels_are_short() {
        assert_eq!(plain_tick(2.500_000_000_000_000_4, 0.6), "2.5");
        assert_eq!(plain_tick(2.7, 0.6), "2.7");
        assert_eq!(plain_tick(2.65, 0.6), "2.65");
        assert_eq!(plain_tick(0.05, 0.2), "0.05");
        assert_eq!(plain_tick(1500.0, 4000.0), "1500");
        assert_eq!(plain_tick(-1e-9, 1.0), "0");
        assert_eq!(plain_tick(3.0, 5.0), "3");
    }
}
