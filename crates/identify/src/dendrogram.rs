//! The fuzzy-equivalence dendrogram drawn as a self-contained SVG (for the HTML report).

use crate::cluster::Dendrogram;
use std::fmt::Write as _;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Draws the dendrogram: leaves at the bottom, λ (= |r| level) on the vertical axis, an
/// optional dashed cut line at `cut_level`, and `highlight` leaves in bold red.
pub fn dendrogram_svg(
    d: &Dendrogram,
    names: &[String],
    cut_level: Option<f64>,
    highlight: &[usize],
) -> String {
    let (w, h) = (900.0, 420.0);
    let (left, right, top, bottom) = (70.0, 20.0, 30.0, 90.0);
    let order = d.leaf_order();
    let n = d.leaves.max(1);
    let min_level = d
        .merges
        .iter()
        .map(|m| m.level)
        .fold(1.0f64, f64::min)
        .min(cut_level.unwrap_or(1.0));
    let lo = (min_level - 0.05 * (1.0 - min_level).max(0.02)).max(-1.0);
    let y_of = |lvl: f64| top + (1.0 - lvl) / (1.0 - lo).max(1e-9) * (h - top - bottom);
    let step = (w - left - right) / n as f64;
    let mut x = vec![0.0; n];
    for (pos, &leaf) in order.iter().enumerate() {
        if leaf < n {
            x[leaf] = left + step * (pos as f64 + 0.5);
        }
    }
    // Each class is represented by its lowest member; track its x and current height.
    let mut node_x = x.clone();
    let mut node_y = vec![y_of(1.0); n];
    let mut s = String::new();
    let _ = write!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12"><rect width="100%" height="100%" fill="white"/>"#
    );
    let _ = write!(
        s,
        r#"<text x="{}" y="18" text-anchor="middle" font-size="15">Fuzzy-equivalence dendrogram (λ = |r| level; single linkage)</text>"#,
        w / 2.0
    );
    for t in 0..=5 {
        let lvl = lo + (1.0 - lo) * t as f64 / 5.0;
        let y = y_of(lvl);
        let _ = write!(
            s,
            r##"<line x1="{left}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#eee"/><text x="{}" y="{:.1}" text-anchor="end">{lvl:.3}</text>"##,
            w - right,
            left - 6.0,
            y + 4.0
        );
    }
    for m in &d.merges {
        let (a, b) = (m.left[0], m.right[0]);
        let y = y_of(m.level);
        let _ = write!(
            s,
            r##"<path d="M{:.1},{:.1}V{y:.1}H{:.1}V{:.1}" fill="none" stroke="#246" stroke-width="1.5"/>"##,
            node_x[a], node_y[a], node_x[b], node_y[b]
        );
        let lo_id = a.min(b);
        node_x[lo_id] = (node_x[a] + node_x[b]) / 2.0;
        node_y[lo_id] = y;
    }
    if let Some(c) = cut_level {
        let y = y_of(c);
        let _ = write!(
            s,
            r##"<line x1="{left}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#c33" stroke-dasharray="6,4"/><text x="{}" y="{:.1}" fill="#c33" text-anchor="end">cut λ = {c:.4}</text>"##,
            w - right,
            w - right,
            y - 4.0
        );
    }
    for (i, &xi) in x.iter().enumerate() {
        let name = names
            .get(i)
            .map_or_else(|| format!("x{}", i + 1), |s| esc(s));
        let hl = highlight.contains(&i);
        let _ = write!(
            s,
            r##"<text transform="translate({xi:.1},{:.1}) rotate(-60)" text-anchor="end" fill="{}" font-weight="{}">{name}</text>"##,
            h - bottom + 14.0,
            if hl { "#c33" } else { "#222" },
            if hl { "bold" } else { "normal" }
        );
    }
    let _ = write!(
        s,
        r#"<text transform="translate(16,{:.1}) rotate(-90)" text-anchor="middle">λ level (|r|)</text></svg>"#,
        (top + h - bottom) / 2.0
    );
    s
}
