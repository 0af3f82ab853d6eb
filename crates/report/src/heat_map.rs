//! Heat map of a value over a rectangular grid (x to the right, y upwards) as an SVG chart:
//! a diverging colour scale, blue (negative) – white (0) – red (positive), symmetric about 0
//! and scaled to the largest |value|, with a legend and a tooltip per cell. `gearcomp grind`
//! draws the ground flank and its deviation over (w, z) with it.

use std::fmt::Write as _;

use crate::escape;

/// One axis of a [`HeatMap`]: its symbol, quantity, unit and grid positions.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatAxis {
    /// Symbol in tooltips, e.g. "w".
    pub symbol: String,
    /// Quantity in the axis label, e.g. "roll distance".
    pub quantity: String,
    /// Unit, e.g. "mm".
    pub unit: String,
    /// Grid positions, ascending.
    pub values: Vec<f64>,
}

impl HeatAxis {
    /// An axis.
    pub fn new(
        symbol: impl Into<String>,
        quantity: impl Into<String>,
        unit: impl Into<String>,
        values: Vec<f64>,
    ) -> Self {
        Self {
            symbol: symbol.into(),
            quantity: quantity.into(),
            unit: unit.into(),
            values,
        }
    }
}

/// A heat map: `cells[i][j]` is the value at (x.values\[i\], y.values\[j\]).
#[derive(Debug, Clone, PartialEq)]
pub struct HeatMap<'a> {
    /// Title above the map.
    pub title: &'a str,
    /// Horizontal axis.
    pub x: &'a HeatAxis,
    /// Vertical axis (upwards).
    pub y: &'a HeatAxis,
    /// Unit of the values, e.g. "µm".
    pub value_unit: &'a str,
    /// Values, one row per x position, one entry per y position.
    pub cells: &'a [Vec<f64>],
}

/// Colour of a value in [−m, m]: blue (negative) – white (0) – red (positive); values beyond
/// ±m take the end colour.
pub fn diverging_colour(v: f64, m: f64) -> String {
    let t = if m > 0.0 {
        (v / m).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let (r, g, b) = if t >= 0.0 {
        (255.0, 255.0 * (1.0 - t), 255.0 * (1.0 - t))
    } else {
        (255.0 * (1.0 + t), 255.0 * (1.0 + t), 255.0)
    };
    format!("rgb({},{},{})", r as u8, g as u8, b as u8)
}

impl HeatMap<'_> {
    /// The map as a self-contained SVG element (760 × 380 px).
    pub fn to_svg(&self) -> String {
        let (w_px, h_px, left, top, bottom) = (760.0, 380.0, 70.0, 40.0, 50.0);
        let (nx, ny) = (self.x.values.len().max(1), self.y.values.len().max(1));
        let m = self
            .cells
            .iter()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        let plot_w = w_px - left - 120.0;
        let plot_h = h_px - top - bottom;
        let cw = plot_w / nx as f64;
        let ch = plot_h / ny as f64;
        let (xs, ys, vu) = (
            escape(&self.x.symbol),
            escape(&self.y.symbol),
            escape(self.value_unit),
        );
        let (xu, yu) = (escape(&self.x.unit), escape(&self.y.unit));
        let mut s = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w_px}\" height=\"{h_px}\" \
             font-family=\"sans-serif\" font-size=\"12\">\
             <text x=\"{}\" y=\"20\" font-size=\"16\" text-anchor=\"middle\">{}</text>",
            w_px / 2.0,
            escape(self.title)
        );
        for (i, row) in self.cells.iter().enumerate() {
            let Some(xv) = self.x.values.get(i) else {
                continue;
            };
            for (j, v) in row.iter().enumerate() {
                let Some(yv) = self.y.values.get(j) else {
                    continue;
                };
                let x = left + i as f64 * cw;
                let y = top + plot_h - (j + 1) as f64 * ch;
                let _ = write!(
                    s,
                    "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{:.2}\" height=\"{:.2}\" fill=\"{}\"><title>{xs} {:.3} {xu}, {ys} {:.3} {yu}: {:.4} {vu}</title></rect>",
                    cw + 0.3,
                    ch + 0.3,
                    diverging_colour(*v, m),
                    xv,
                    yv,
                    v
                );
            }
        }
        let _ = write!(
            s,
            "<rect x=\"{left}\" y=\"{top}\" width=\"{plot_w}\" height=\"{plot_h}\" fill=\"none\" stroke=\"#333\"/>\
             <text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{} {xs} / {xu} ({:.2} … {:.2})</text>\
             <text x=\"16\" y=\"{}\" transform=\"rotate(-90 16 {})\" text-anchor=\"middle\">{} {ys} / {yu} ({:.2} … {:.2})</text>",
            left + plot_w / 2.0,
            h_px - 15.0,
            escape(&self.x.quantity),
            self.x.values.first().copied().unwrap_or(0.0),
            self.x.values.last().copied().unwrap_or(0.0),
            top + plot_h / 2.0,
            top + plot_h / 2.0,
            escape(&self.y.quantity),
            self.y.values.first().copied().unwrap_or(0.0),
            self.y.values.last().copied().unwrap_or(0.0),
        );
        let lx = left + plot_w + 30.0;
        for k in 0..=10 {
            let v = m * (1.0 - 0.2 * f64::from(k));
            let y = top + plot_h * f64::from(k) / 10.0;
            let _ = write!(
                s,
                "<rect x=\"{lx}\" y=\"{y:.1}\" width=\"20\" height=\"{:.1}\" fill=\"{}\"/>",
                plot_h / 10.0 + 0.5,
                diverging_colour(v, m)
            );
            if k % 2 == 0 {
                let _ = write!(
                    s,
                    "<text x=\"{}\" y=\"{:.1}\">{:+.3} {vu}</text>",
                    lx + 26.0,
                    y + 4.0,
                    v
                );
            }
        }
        s.push_str("</svg>");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cells, colours and positions against values worked out by hand: a 2 × 3 grid in a
    /// 570 × 290 px plot area starting at (70, 40), so cells are 285 × 96.67 px; the largest
    /// |value| is 2, so +2 is pure red, −2 pure blue, 0 white, +1 half-way (255,127,127).
    #[test]
    fn cells_colours_and_positions_by_hand() {
        let x = HeatAxis::new("w", "roll distance", "mm", vec![1.0, 2.0]);
        let y = HeatAxis::new("z", "width", "mm", vec![-1.0, 0.0, 1.0]);
        let cells = vec![vec![2.0, 0.0, -2.0], vec![1.0, -1.0, 0.5]];
        let svg = HeatMap {
            title: "f <map>",
            x: &x,
            y: &y,
            value_unit: "µm",
            cells: &cells,
        }
        .to_svg();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert!(svg.contains(">f &lt;map&gt;</text>"));
        assert_eq!(svg.matches("<title>").count(), 6);
        // first cell (x = 1, y = −1) at the bottom left: y = 40 + 290 − 96.67 = 233.3
        assert!(svg.contains(
            "<rect x=\"70.0\" y=\"233.3\" width=\"285.30\" height=\"96.97\" fill=\"rgb(255,0,0)\"><title>w 1.000 mm, z -1.000 mm: 2.0000 µm</title>"
        ));
        // (x = 1, y = 1) at the top left, −2 → blue
        assert!(svg.contains(
            "<rect x=\"70.0\" y=\"40.0\" width=\"285.30\" height=\"96.97\" fill=\"rgb(0,0,255)\"><title>w 1.000 mm, z 1.000 mm: -2.0000 µm</title>"
        ));
        assert!(svg.contains("fill=\"rgb(255,255,255)\"><title>w 1.000 mm, z 0.000 mm"));
        assert!(svg.contains("fill=\"rgb(255,127,127)\"><title>w 2.000 mm, z -1.000 mm"));
        assert!(svg.contains("roll distance w / mm (1.00 … 2.00)"));
        assert!(svg.contains("width z / mm (-1.00 … 1.00)"));
        assert!(svg.contains(">+2.000 µm</text>") && svg.contains(">-2.000 µm</text>"));
    }

    #[test]
    fn colour_scale_ends_and_zero_range() {
        assert_eq!(diverging_colour(5.0, 1.0), "rgb(255,0,0)");
        assert_eq!(diverging_colour(-5.0, 1.0), "rgb(0,0,255)");
        assert_eq!(diverging_colour(0.3, 0.0), "rgb(255,255,255)");
    }
}
