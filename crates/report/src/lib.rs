//! Self-contained HTML reports (no external assets, no JavaScript) with SVG charts drawn by
//! `plotters`. Every gearcomp command that writes a report (`demo`, `fit`, `shape`, `dress`)
//! builds it with [`HtmlReport`] and [`Chart`], so reports look alike and open offline.
//! Values over a grid are drawn as a [`HeatMap`].

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;
use thiserror::Error;

mod heat_map;
pub use heat_map::{diverging_colour, HeatAxis, HeatMap};

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ReportError>;

/// What can go wrong drawing or writing a report.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ReportError {
    /// The plotting back-end failed.
    #[error("cannot draw chart {title:?}: {message}")]
    Draw {
        /// Title of the chart.
        title: String,
        /// The back-end's message.
        message: String,
    },
    /// Writing the file failed.
    #[error(transparent)]
    Io(#[from] gearcomp_core::CoreError),
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Style {
    /// Connected line.
    #[default]
    Line,
    /// Unconnected dots.
    Points,
}

/// One named series of (x, y) points.
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// The points; non-finite points are skipped when drawing.
    pub points: Vec<(f64, f64)>,
    /// Line or points.
    pub style: Style,
}

impl Series {
    /// A line series.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            style: Style::Line,
        }
    }
    /// A point (scatter) series.
    pub fn points(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            style: Style::Points,
        }
    }
}

/// An x–y chart.
#[derive(Debug, Clone, Default)]
pub struct Chart {
    /// Title above the plot.
    pub title: String,
    /// X axis label with unit, e.g. "time / h".
    pub x_label: String,
    /// Y axis label with unit, e.g. "drift / µm".
    pub y_label: String,
    /// The series drawn.
    pub series: Vec<Series>,
    /// Width in pixels (default 900).
    pub width: u32,
    /// Height in pixels (default 380).
    pub height: u32,
}

impl Chart {
    /// A chart with the default size.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            width: 900,
            height: 380,
        }
    }

    /// Adds a series (builder style).
    pub fn with(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }

    fn bounds(&self) -> ((f64, f64), (f64, f64)) {
        let mut xr = (f64::INFINITY, f64::NEG_INFINITY);
        let mut yr = (f64::INFINITY, f64::NEG_INFINITY);
        for s in &self.series {
            for &(x, y) in &s.points {
                if x.is_finite() && y.is_finite() {
                    xr = (xr.0.min(x), xr.1.max(x));
                    yr = (yr.0.min(y), yr.1.max(y));
                }
            }
        }
        let widen = |r: (f64, f64)| {
            if !r.0.is_finite() {
                (0.0, 1.0)
            } else if (r.1 - r.0).abs() < 1e-12 * (1.0 + r.0.abs()) {
                (r.0 - 0.5, r.1 + 0.5)
            } else {
                let pad = 0.04 * (r.1 - r.0);
                (r.0 - pad, r.1 + pad)
            }
        };
        (widen(xr), widen(yr))
    }

    /// Draws the chart as an SVG document.
    pub fn to_svg(&self) -> Result<String> {
        let err = |e: &dyn std::fmt::Display| ReportError::Draw {
            title: self.title.clone(),
            message: e.to_string(),
        };
        let (xr, yr) = self.bounds();
        let mut svg = String::new();
        {
            let w = if self.width == 0 { 900 } else { self.width };
            let h = if self.height == 0 { 380 } else { self.height };
            let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .x_desc(&self.x_label)
                .y_desc(&self.y_label)
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| err(&e))?;
            for (i, s) in self.series.iter().enumerate() {
                let colour = Palette99::pick(i).to_rgba();
                let pts = s
                    .points
                    .iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite());
                let anno = match s.style {
                    Style::Line => chart
                        .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                        .map_err(|e| err(&e))?,
                    Style::Points => chart
                        .draw_series(pts.map(|p| Circle::new(p, 2, colour.filled())))
                        .map_err(|e| err(&e))?,
                };
                anno.label(s.name.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(3))
                });
            }
            if self.series.len() > 1 || self.series.iter().any(|s| !s.name.is_empty()) {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .position(SeriesLabelPosition::UpperRight)
                    .draw()
                    .map_err(|e| err(&e))?;
            }
            root.present().map_err(|e| err(&e))?;
        }
        Ok(svg)
    }
}

/// Escapes text for HTML.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

/// A single-file HTML report built section by section.
#[derive(Debug, Clone, Default)]
pub struct HtmlReport {
    title: String,
    body: String,
}

impl HtmlReport {
    /// Starts a report with a title.
    pub fn new(title: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            body: String::new(),
        }
    }

    /// Adds a section heading.
    pub fn heading(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<h2>{}</h2>", escape(text));
        self
    }

    /// Adds a paragraph of plain text.
    pub fn paragraph(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<p>{}</p>", escape(text));
        self
    }

    /// Adds preformatted text (a console table, a model file).
    pub fn preformatted(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<pre>{}</pre>", escape(text));
        self
    }

    /// Adds a table; cells are plain text.
    pub fn table<S: AsRef<str>>(&mut self, headers: &[S], rows: &[Vec<String>]) -> &mut Self {
        self.body.push_str("<table><thead><tr>");
        for h in headers {
            let _ = write!(self.body, "<th>{}</th>", escape(h.as_ref()));
        }
        self.body.push_str("</tr></thead><tbody>\n");
        for r in rows {
            self.body.push_str("<tr>");
            for c in r {
                let _ = write!(self.body, "<td>{}</td>", escape(c));
            }
            self.body.push_str("</tr>\n");
        }
        self.body.push_str("</tbody></table>\n");
        self
    }

    /// Adds a chart drawn as inline SVG.
    pub fn chart(&mut self, chart: &Chart) -> Result<&mut Self> {
        let svg = chart.to_svg()?;
        let _ = writeln!(self.body, "<figure>{svg}</figure>");
        Ok(self)
    }

    /// Adds an SVG drawn by the caller (e.g. a dendrogram); it is inserted as is.
    pub fn raw_svg(&mut self, svg: &str) -> &mut Self {
        let _ = writeln!(self.body, "<figure>{svg}</figure>");
        self
    }

    /// The complete HTML document.
    pub fn to_html(&self) -> String {
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n\
<style>body{{font-family:sans-serif;max-width:980px;margin:2em auto;color:#222}}\
table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}}\
th{{background:#eee}}figure{{margin:1em 0}}pre{{background:#f6f6f6;padding:8px;overflow-x:auto}}</style>\n\
</head><body><h1>{t}</h1>\n{b}<footer><p>gearcomp {v}</p></footer></body></html>\n",
            t = escape(&self.title),
            b = self.body,
            v = env!("CARGO_PKG_VERSION")
        )
    }

    /// Writes the report atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        Ok(gearcomp_core::fsio::write_atomic(
            path,
            self.to_html().as_bytes(),
        )?)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn chart_svg_has_title_and_polyline() {
        let c = Chart::new("drift <test>", "t / h", "x / µm")
            .with(Series::line(
                "a",
                vec![(0.0, 1.0), (1.0, 3.0), (2.0, f64::NAN)],
            ))
            .with(Series::points("b", vec![(0.5, 2.0)]));
        let svg = c.to_svg().unwrap();
        assert!(svg.starts_with("<svg"));
        assert!(svg.contains("polyline") || svg.contains("<path"));
        let mut r = HtmlReport::new("Report & co");
        r.heading("h").paragraph("<p>").chart(&c).unwrap();
        r.table(&["a", "b"], &[vec!["1".into(), "2".into()]]);
        let html = r.to_html();
        assert!(html.contains("Report &amp; co"));
        assert!(html.contains("&lt;p&gt;"));
        assert!(html.contains("<td>2</td>"));
    }

    #[test]
    fn empty_chart_draws() {
        assert!(Chart::new("e", "x", "y").to_svg().is_ok());
    }
}
