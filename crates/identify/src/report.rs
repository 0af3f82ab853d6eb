//! Renderers of an identification result: the text summary, the JSON document and the
//! HTML report that `gearcomp fit` prints and writes.
//!
//! [`FitReport`] gathers what one fit produced (the table, the [`Identification`], the
//! plain least-squares baseline, the split, the model file and the optional workpiece
//! shrink model); its methods render it. The figures are the identification's own (RMSE,
//! coefficients, standard errors in the target unit, µm); the only computations here are
//! the per-target extrapolation counts ([`Extrapolation`]), the dendrogram cut level drawn
//! in the report ([`dendrogram_cut`]) and the thinning of long series for charts ([`thin`]).

use std::fmt::Write as _;

use gearcomp_core::model::{ModelFile, WorkpieceShrink};
use gearcomp_report::{Chart, HtmlReport, Series};
use serde_json::{json, Value};
use thiserror::Error;

use crate::cluster::Dendrogram;
use crate::data::Table;
use crate::dendrogram::dendrogram_svg;
use crate::workpiece::{combined_offsets_um, shrink_offset_um};
use crate::{Identification, Split, TargetModel};

/// Most points drawn per line series of a chart.
const MAX_LINE_POINTS: usize = 2500;
/// Most points drawn for the "outside the training envelope" marks.
const MAX_MARK_POINTS: usize = 1500;
/// Most data issues listed in the text summary.
const MAX_LISTED_ISSUES: usize = 20;

/// What can go wrong rendering a fit.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FitReportError {
    /// Evaluating the workpiece shrink model.
    #[error(transparent)]
    Identify(#[from] crate::IdentifyError),
    /// Drawing a chart.
    #[error(transparent)]
    Chart(#[from] gearcomp_report::ReportError),
    /// Serialising the model file as TOML.
    #[error(transparent)]
    Model(#[from] gearcomp_core::error::CoreError),
    /// Serialising the JSON document.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}

/// Result alias of the renderers.
pub type Result<T> = std::result::Result<T, FitReportError>;

/// A figure for printing: `prec` decimals, "-" instead of NaN or infinity.
pub fn num(v: f64, prec: usize) -> String {
    if v.is_finite() {
        format!("{v:.prec$}")
    } else {
        "-".into()
    }
}

/// A coefficient-like figure in exponent form with `prec` decimals, "-" when not finite.
pub fn num_e(v: f64, prec: usize) -> String {
    if v.is_finite() {
        format!("{v:.prec$e}")
    } else {
        "-".into()
    }
}

/// A number for JSON: null when not finite.
fn jnum(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        Value::Null
    }
}

/// Every `step`-th point, `step = ⌈len / max⌉` (at least 1), so at most `max` points remain
/// (`max = 0` counts as 1); the first point is always kept.
pub fn thin(points: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
    let step = points.len().div_ceil(max.max(1)).max(1);
    points.into_iter().step_by(step).collect()
}

/// How far a target model extrapolates on the test rows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extrapolation {
    /// Rows not used for training.
    pub test_rows: usize,
    /// Test rows whose inputs are outside the training envelope.
    pub outside_rows: usize,
    /// Mean 95 % prediction-interval half-width over the test rows, the rows the
    /// extrapolation line speaks of (over every row when there is none; target unit, µm);
    /// NaN without intervals.
    pub mean_half_width_um: f64,
}

impl Extrapolation {
    /// Counts from the test-row mask `test` and the per-row `outside` flags and interval
    /// half-widths of a model (a missing `outside` entry counts as inside).
    pub fn of(test: &[bool], outside: &[bool], interval_um: &[f64]) -> Self {
        let mut test_rows = 0;
        let mut outside_rows = 0;
        let (mut half_sum, mut half_rows) = (0.0, 0usize);
        for (i, &te) in test.iter().enumerate() {
            if te {
                test_rows += 1;
                outside_rows += usize::from(outside.get(i).copied().unwrap_or(false));
                if let Some(h) = interval_um.get(i) {
                    half_sum += h;
                    half_rows += 1;
                }
            }
        }
        let mean_half_width_um = if half_rows > 0 {
            half_sum / half_rows as f64
        } else if interval_um.is_empty() {
            f64::NAN
        } else {
            interval_um.iter().sum::<f64>() / interval_um.len() as f64
        };
        Extrapolation {
            test_rows,
            outside_rows,
            mean_half_width_um,
        }
    }

    /// The counts of a target model of `id`.
    pub fn of_model(id: &Identification, m: &TargetModel) -> Self {
        let test = m.own_rows.as_ref().map_or(&id.test, |(_, test)| test);
        Self::of(test, &m.outside, &m.interval_um)
    }
}

/// The λ level at which the report draws the dendrogram cut for `classes` classes of
/// `inputs` variables: the level of the merge after the `inputs − classes` merges that
/// form those classes (the last merge's level when there is none after them); `None`
/// for no classes.
pub fn dendrogram_cut(dendrogram: &Dendrogram, inputs: usize, classes: usize) -> Option<f64> {
    if classes == 0 {
        return None;
    }
    let merges = &dendrogram.merges;
    let done = inputs.saturating_sub(classes);
    merges
        .get(done)
        .map(|m| m.level)
        .or_else(|| merges.last().map(|m| m.level))
}

/// One fit and what it was fitted on, ready to render.
#[derive(Debug, Clone, Copy)]
pub struct FitReport<'a> {
    /// Name of the data (file names, or the embedded data set).
    pub data_name: &'a str,
    /// The data read.
    pub table: &'a Table,
    /// The identification.
    pub id: &'a Identification,
    /// Per target: train and test RMSE (µm) of plain least squares on every input
    /// (`pipeline::plain_least_squares`).
    pub plain_ls: &'a [(f64, Option<f64>)],
    /// The train/test split used.
    pub split: &'a Split,
    /// A note on how the split was chosen by default, if it was.
    pub split_note: Option<&'a str>,
    /// The model file written.
    pub file: &'a ModelFile,
    /// The workpiece shrink model and its temperature model, if any.
    pub workpiece: Option<(&'a WorkpieceShrink, &'a TargetModel)>,
}

impl FitReport<'_> {
    fn training_rows(&self) -> usize {
        self.id.train.iter().filter(|&&m| m).count()
    }

    fn sensor_names(&self, m: &TargetModel) -> Vec<&str> {
        m.sensors
            .iter()
            .map(|&s| self.id.input_names[s].as_str())
            .collect()
    }

    /// The text summary: data, notes, method, per target the family comparison, errors,
    /// extrapolation and terms, and the workpiece temperature model.
    pub fn summary_text(&self) -> Result<String> {
        let mut out = self.data_text();
        for (m, b) in self.id.targets.iter().zip(self.plain_ls) {
            self.target_text(&mut out, m, b);
        }
        if let Some((w, wm)) = self.workpiece {
            let chans: Vec<&str> = w
                .temperature
                .terms
                .iter()
                .map(|t| t.channel.as_str())
                .collect();
            let _ = writeln!(
                out,
                "\nworkpiece: Ta = {:.6} + Σ ai·ti on {} (train RMSE {:.3} °C); δT at Ta = Tb + 30 K: {:.4} µm",
                w.temperature.intercept,
                chans.join(", "),
                wm.train_rmse,
                shrink_offset_um(w, w.design_temp_c + 30.0)?
            );
        }
        Ok(out)
    }

    /// The summary's opening lines: data, split, runs, notes, data issues and method.
    fn data_text(&self) -> String {
        let (table, id) = (self.table, self.id);
        let mut out = String::new();
        let n_train = self.training_rows();
        let _ = writeln!(
            out,
            "data: {}: {} rows, {} inputs, {} target(s); {} training rows, {} test rows",
            self.data_name,
            table.time_s.len(),
            table.inputs.len(),
            table.targets.len(),
            n_train,
            id.test.iter().filter(|&&t| t).count()
        );
        if let Some(n) = self.split_note {
            let _ = writeln!(out, "  note: {n}");
        }
        if table.runs.is_some() {
            let _ = writeln!(
                out,
                "  runs: {} ({}); {} segment(s) (filters restart at each)",
                table.run_names.len(),
                table.run_names.join(", "),
                table.segment_ranges().len()
            );
        }
        for n in &id.notes {
            let _ = writeln!(out, "  note: {n}");
        }
        for i in table.issues.iter().take(MAX_LISTED_ISSUES) {
            let _ = writeln!(out, "  note: {i}");
        }
        if table.issues.len() > MAX_LISTED_ISSUES {
            let _ = writeln!(
                out,
                "  note: … {} more",
                table.issues.len() - MAX_LISTED_ISSUES
            );
        }
        let (left_out, first) = table.rows_left_out();
        if left_out > 0 {
            let _ = writeln!(
                out,
                "  rows left out: {left_out} (first at line(s) {}{})",
                first
                    .iter()
                    .map(u64::to_string)
                    .collect::<Vec<_>>()
                    .join(", "),
                if left_out > first.len() { ", …" } else { "" }
            );
        }
        let _ = writeln!(out, "method: {}", id.method);
        out
    }

    /// One target's block of the summary; `b` is its plain least-squares baseline.
    fn target_text(&self, out: &mut String, m: &TargetModel, b: &(f64, Option<f64>)) {
        let sensors = self.sensor_names(m);
        let _ = writeln!(
            out,
            "\n{}: {}; {} sensor(s): {}{}{}",
            m.target,
            if m.classes.is_empty() {
                m.family.clone()
            } else {
                format!("{} classes", m.classes.len())
            },
            sensors.len(),
            sensors.join(", "),
            m.tau_s
                .map_or(String::new(), |t| format!("; rate τ = {t} s")),
            m.ridge_alpha
                .map_or(String::new(), |a| format!("; ridge α = {a}"))
        );
        comparison_text(out, m);
        let _ = writeln!(
            out,
            "  RMSE µm: train {}, test {}, validation {} (folds: {}); R² = {}",
            num(m.train_rmse, 3),
            opt_num(m.test_rmse),
            num(m.cv_rmse, 3),
            folds(&m.fold_rmse),
            num(m.fit.r2, 4)
        );
        let _ = writeln!(
            out,
            "  plain least squares on all {} inputs: train {}, test {} µm",
            self.id.input_names.len(),
            num(b.0, 3),
            opt_num(b.1)
        );
        let e = Extrapolation::of_model(self.id, m);
        let _ = writeln!(
            out,
            "  extrapolation: {} of {} test rows outside the training envelope; 95 % prediction interval ± {} µm on average (validation RMSE × √(1 + leverage))",
            e.outside_rows,
            e.test_rows,
            num(e.mean_half_width_um, 3)
        );
        terms_text(out, m);
    }

    /// The rows of the summary table (target, family, sensors, τ, train, test, validation,
    /// plain least-squares test RMSE).
    pub fn summary_rows(&self) -> Vec<Vec<String>> {
        self.id
            .targets
            .iter()
            .zip(self.plain_ls)
            .map(|(m, b)| {
                vec![
                    m.target.clone(),
                    m.family.clone(),
                    self.sensor_names(m).join(" "),
                    m.tau_s.map_or("-".into(), |t| format!("{t}")),
                    num(m.train_rmse, 3),
                    opt_num(m.test_rmse),
                    num(m.cv_rmse, 3),
                    opt_num(b.1),
                ]
            })
            .collect()
    }

    /// The JSON document of `fit --json`: per target the chosen family, sensors, model
    /// terms, validation folds, the family comparison, train and test error; the model file.
    pub fn to_json(&self) -> Result<Value> {
        let (table, id) = (self.table, self.id);
        let n_train = self.training_rows();
        let targets: Vec<Value> = id
            .targets
            .iter()
            .zip(self.plain_ls)
            .map(|(m, b)| self.target_json(m, b))
            .collect();
        Ok(json!({
            "data": self.data_name,
            "rows": table.time_s.len(),
            "training_rows": n_train,
            "test_rows": id.test.iter().filter(|&&t| t).count(),
            "runs": table.run_names,
            "split_note": self.split_note,
            "inputs": id.input_names,
            "notes": id.notes,
            "data_issues": table.issues.iter().map(|i| i.to_string()).collect::<Vec<_>>(),
            "rows_left_out": table.rows_left_out().0,
            "rows_left_out_first_lines": table.rows_left_out().1,
            "method": id.method,
            "targets": targets,
            "model_file": serde_json::to_value(self.file)?,
        }))
    }

    fn target_json(&self, m: &TargetModel, b: &(f64, Option<f64>)) -> Value {
        let e = Extrapolation::of_model(self.id, m);
        let opt = |v: Option<f64>| v.map_or(Value::Null, jnum);
        let fold_list = |f: &[f64]| f.iter().map(|v| jnum(*v)).collect::<Vec<_>>();
        json!({
            "target": m.target,
            "family": m.family,
            "sensors": self.sensor_names(m),
            "intercept": jnum(m.model.intercept),
            "terms": serde_json::to_value(&m.model.terms).unwrap_or_default(),
            "validation_rmse_um": jnum(m.cv_rmse),
            "validation_folds_um": fold_list(&m.fold_rmse),
            "train_rmse_um": jnum(m.train_rmse),
            "test_rmse_um": opt(m.test_rmse),
            "test_rows_outside_envelope": e.outside_rows,
            "mean_interval_half_width_um": jnum(e.mean_half_width_um),
            "plain_ls_all_inputs": {
                "train_rmse_um": jnum(b.0),
                "test_rmse_um": opt(b.1),
            },
            "comparison": m.comparison.iter().map(|c| json!({
                "family": c.family,
                "sensors": c.sensors,
                "validation_rmse_um": jnum(c.cv_rmse),
                "validation_folds_um": fold_list(&c.fold_rmse),
                "detail": c.detail,
            })).collect::<Vec<_>>(),
        })
    }

    /// The HTML report titled `gearcomp fit: {name}`: summary table, data notes,
    /// dendrogram, per target the family comparison, classes, charts (measured vs
    /// predicted with the 95 % interval and the extrapolating rows, residual), the
    /// workpiece shrink and the model file.
    pub fn html_report(&self, name: &str) -> Result<HtmlReport> {
        let (table, id) = (self.table, self.id);
        let mut r = HtmlReport::new(format!("gearcomp fit: {name}"));
        r.paragraph(&format!("Data: {}. {}", self.data_name, id.method));
        r.heading("Summary (RMSE in the target unit, µm)");
        r.table(
            &[
                "target",
                "family",
                "chosen sensors",
                "rate τ / s",
                "train",
                "test",
                "cross-validation",
                "plain LS test (all inputs)",
            ],
            &self.summary_rows(),
        );
        if !table.issues.is_empty() {
            r.heading("Data notes");
            r.preformatted(
                &table
                    .issues
                    .iter()
                    .map(|i| i.to_string())
                    .collect::<Vec<_>>()
                    .join("\n"),
            );
        }
        self.dendrogram_html(&mut r);
        for (j, m) in id.targets.iter().enumerate() {
            self.target_html(&mut r, j, m)?;
        }
        if let Some((w, _)) = self.workpiece {
            let offs = combined_offsets_um(table, &self.file.axes[0]).ok();
            r.heading("Workpiece shrink (dry hobbing)");
            r.paragraph(&format!(
                "Ta model intercept {:.6} °C, {} term(s); δT at Ta = Tb + 30 K: {:.4} µm.",
                w.temperature.intercept,
                w.temperature.terms.len(),
                shrink_offset_um(w, w.design_temp_c + 30.0)?
            ));
            if offs.is_none() {
                r.paragraph("The combined offset δM + δT is not drawn: the workpiece model's channels are not all in the main data.");
            }
        }
        r.heading("Model file");
        r.preformatted(&self.file.to_toml_string()?);
        Ok(r)
    }

    /// The dendrogram of the first target with its cut and chosen sensors.
    fn dendrogram_html(&self, r: &mut HtmlReport) {
        let id = self.id;
        r.heading("Sensor classes (fuzzy equivalence dendrogram, training rows)");
        let Some(first) = id.targets.first() else {
            return;
        };
        let cut = dendrogram_cut(&id.dendrogram, id.input_names.len(), first.classes.len());
        r.raw_svg(&dendrogram_svg(
            &id.dendrogram,
            &id.input_names,
            cut,
            &first.sensors,
        ));
        if cut.is_some() {
            r.paragraph(&format!(
                "Dashed line: the cut giving {} classes for {}; red: its chosen sensors.",
                first.classes.len(),
                first.target
            ));
        } else {
            r.paragraph(&format!("Red: the sensors chosen for {}.", first.target));
        }
    }

    /// One target's section: comparison table, classes, charts, extrapolation note.
    fn target_html(&self, r: &mut HtmlReport, j: usize, m: &TargetModel) -> Result<()> {
        let id = self.id;
        r.heading(&m.target);
        if !m.comparison.is_empty() {
            r.paragraph(&format!("Family comparison ({}), validation RMSE on the training rows in µm; the lowest eligible is kept: {}.", id.method, m.family));
            r.table(
                &[
                    "family",
                    "sensors",
                    "validation RMSE",
                    "folds",
                    "choice",
                    "",
                ],
                &comparison_rows(m),
            );
        }
        let cls: Vec<String> = m
            .classes
            .iter()
            .map(|c| {
                let names: Vec<&str> = c.iter().map(|&i| id.input_names[i].as_str()).collect();
                format!("{{{}}}", names.join(", "))
            })
            .collect();
        r.paragraph(&format!(
            "Classes: {}. Chosen: {}.",
            cls.join(" "),
            self.sensor_names(m).join(", ")
        ));
        let hours: Vec<f64> = self.table.time_s.iter().map(|t| t / 3600.0).collect();
        r.chart(&self.prediction_chart(&hours, j, m))?;
        let e = Extrapolation::of_model(id, m);
        r.paragraph(&format!(
            "{} of {} test rows are outside the training envelope (a channel outside its training range, or the regressors farther from the training mean than any training row: Mahalanobis bound); they are marked on the chart. 95 % prediction interval: ± {} µm on average.",
            e.outside_rows,
            e.test_rows,
            num(e.mean_half_width_um, 3)
        ));
        let res = hours
            .iter()
            .zip(self.table.targets[j].iter().zip(&m.predicted))
            .map(|(h, (y, p))| (*h, y - p))
            // Rows without a measured target have no residual.
            .filter(|(_, e)| e.is_finite())
            .collect();
        r.chart(
            &Chart::new(
                format!("{}: residual (measured − predicted)", m.target),
                "time / h",
                "residual / µm",
            )
            .with(Series::line("residual", thin(res, MAX_LINE_POINTS))),
        )?;
        Ok(())
    }

    /// Measured vs predicted over time (h), with the 95 % interval and the rows outside
    /// the training envelope.
    fn prediction_chart(&self, hours: &[f64], j: usize, m: &TargetModel) -> Chart {
        let along = |ys: &[f64]| -> Vec<(f64, f64)> {
            // Rows without a measured target are not drawn (NaN there).
            let pts = hours
                .iter()
                .copied()
                .zip(ys.iter().copied())
                .filter(|(_, y)| y.is_finite())
                .collect();
            thin(pts, MAX_LINE_POINTS)
        };
        let band = |sign: f64| -> Vec<(f64, f64)> {
            let pts = hours
                .iter()
                .zip(m.predicted.iter().zip(&m.interval_um))
                .map(|(h, (p, w))| (*h, p + sign * w))
                .collect();
            thin(pts, MAX_LINE_POINTS)
        };
        let outside = hours
            .iter()
            .zip(m.predicted.iter().zip(&m.outside))
            .filter(|(_, (_, &o))| o)
            .map(|(h, (p, _))| (*h, *p))
            .collect();
        let split_h = match self.split {
            Split::TimeBefore(s) => format!(" (train before {:.1} h)", s / 3600.0),
            _ => String::new(),
        };
        Chart::new(
            format!("{}: measured vs predicted{split_h}", m.target),
            "time / h",
            "displacement / µm",
        )
        .with(Series::line("measured", along(&self.table.targets[j])))
        .with(Series::line("predicted", along(&m.predicted)))
        .with(Series::line("95 % interval (upper)", band(1.0)))
        .with(Series::line("95 % interval (lower)", band(-1.0)))
        .with(Series::points(
            "outside the training envelope (extrapolating)",
            thin(outside, MAX_MARK_POINTS),
        ))
    }
}

/// "-" for a missing figure, else 3 decimals.
fn opt_num(v: Option<f64>) -> String {
    v.map_or("-".to_string(), |v| num(v, 3))
}

/// Fold RMSEs, 3 decimals, comma separated.
fn folds(f: &[f64]) -> String {
    f.iter().map(|v| num(*v, 3)).collect::<Vec<_>>().join(", ")
}

/// The family comparison table of the text summary (nothing for a fixed kind).
fn comparison_text(out: &mut String, m: &TargetModel) {
    if m.comparison.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "  {:<40} {:>8} {:>12}  folds µm; choice",
        "family (validation on training rows)", "sensors", "RMSE µm"
    );
    for c in &m.comparison {
        let _ = writeln!(
            out,
            "  {:<40} {:>8} {:>12}  {}; {}{}",
            c.family,
            c.sensors,
            num(c.cv_rmse, 3),
            folds(&c.fold_rmse),
            c.detail,
            if c.family == m.family {
                "  ← kept"
            } else {
                ""
            }
        );
    }
}

/// The terms table of the text summary: intercept, then one row per regressor.
fn terms_text(out: &mut String, m: &TargetModel) {
    let _ = writeln!(
        out,
        "  {:<34} {:>16} {:>14}",
        "term", "coefficient", "std. error"
    );
    let _ = writeln!(
        out,
        "  {:<34} {:>16} {:>14}",
        "intercept",
        num(m.fit.coefficients[0], 6),
        num(m.fit.std_errors.first().copied().unwrap_or(f64::NAN), 6)
    );
    for (k, name) in m.regressors.iter().enumerate() {
        let _ = writeln!(
            out,
            "  {:<34} {:>16} {:>14}",
            name,
            num_e(m.fit.coefficients[k + 1], 6),
            num_e(m.fit.std_errors.get(k + 1).copied().unwrap_or(f64::NAN), 4)
        );
    }
}

/// The rows of the HTML family comparison table.
fn comparison_rows(m: &TargetModel) -> Vec<Vec<String>> {
    m.comparison
        .iter()
        .map(|c| {
            vec![
                c.family.clone(),
                c.sensors.to_string(),
                num(c.cv_rmse, 3),
                folds(&c.fold_rmse),
                c.detail.clone(),
                if c.kept { "kept".into() } else { String::new() },
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::cluster::Merge;
    use crate::data::{read_csv, Selection};
    use crate::{identify, plain_least_squares, IdentifyOptions, ModelKind, Origin};

    #[test]
    fn figures_print_dash_for_non_finite_values() {
        assert_eq!(num(1.23456, 3), "1.235");
        assert_eq!(num(-0.5, 1), "-0.5");
        assert_eq!(num(f64::NAN, 3), "-");
        assert_eq!(num(f64::INFINITY, 3), "-");
        assert_eq!(num_e(1234.5, 2), "1.23e3");
        assert_eq!(num_e(-2.0e-5, 1), "-2.0e-5");
        assert_eq!(num_e(f64::NEG_INFINITY, 4), "-");
        assert_eq!(opt_num(None), "-");
        assert_eq!(folds(&[1.0, f64::NAN, 0.25]), "1.000, -, 0.250");
    }

    #[test]
    fn thinning_keeps_every_step_th_point() {
        let pts: Vec<(f64, f64)> = (0..10).map(|i| (f64::from(i), 0.0)).collect();
        // ⌈10 / 4⌉ = 3: points 0, 3, 6, 9.
        let xs: Vec<f64> = thin(pts.clone(), 4).iter().map(|p| p.0).collect();
        assert_eq!(xs, [0.0, 3.0, 6.0, 9.0]);
        assert_eq!(thin(pts.clone(), 10).len(), 10);
        assert_eq!(thin(pts.clone(), 100).len(), 10);
        assert_eq!(thin(pts, 0), [(0.0, 0.0)]);
        assert!(thin(Vec::new(), 5).is_empty());
    }

    #[test]
    fn extrapolation_counts_only_test_rows() {
        // Rows 0, 1 train; rows 2, 3, 4 test; rows 1, 2, 4 outside → 2 test rows outside.
        let e = Extrapolation::of(
            &[false, false, true, true, true],
            &[false, true, true, false, true],
            &[1.0, 2.0, 3.0, 4.0, 6.0],
        );
        assert_eq!(e.test_rows, 3);
        assert_eq!(e.outside_rows, 2);
        // (3 + 4 + 6) / 3, over the test rows (as the reference numpy_static.py).
        assert!((e.mean_half_width_um - 13.0 / 3.0).abs() < 1e-15);
        // No test row: over every row.
        let e = Extrapolation::of(&[false, false], &[false, false], &[1.0, 2.0]);
        assert!((e.mean_half_width_um - 1.5).abs() < 1e-15);
        // Missing flags count as inside; no intervals → NaN.
        let e = Extrapolation::of(&[true, true], &[true], &[]);
        assert_eq!((e.test_rows, e.outside_rows), (2, 1));
        assert!(e.mean_half_width_um.is_nan());
    }

    #[test]
    fn dendrogram_cut_is_the_level_of_the_next_merge() {
        // Four leaves merged at 0.9, 0.7, 0.5: two classes exist after two merges, the
        // cut is drawn at the third merge's level.
        let merge = |level, left: &[usize], right: &[usize]| Merge {
            level,
            left: left.to_vec(),
            right: right.to_vec(),
        };
        let d = Dendrogram {
            leaves: 4,
            merges: vec![
                merge(0.9, &[0], &[1]),
                merge(0.7, &[2], &[3]),
                merge(0.5, &[0, 1], &[2, 3]),
            ],
        };
        assert_eq!(dendrogram_cut(&d, 4, 2), Some(0.5));
        assert_eq!(dendrogram_cut(&d, 4, 3), Some(0.7));
        assert_eq!(dendrogram_cut(&d, 4, 4), Some(0.9));
        // One class: no merge after the last, the last level.
        assert_eq!(dendrogram_cut(&d, 4, 1), Some(0.5));
        assert_eq!(dendrogram_cut(&d, 4, 0), None);
        let empty = Dendrogram {
            leaves: 1,
            merges: Vec::new(),
        };
        assert_eq!(dendrogram_cut(&empty, 1, 1), None);
    }

    /// y = 3·a − 2·b exactly (c does not enter), one row a minute for an hour.
    fn exact_table() -> Table {
        let mut csv = String::from("time_s,a_c,b_c,c_c,d_um\n");
        for k in 0..60 {
            let t = f64::from(k) * 60.0;
            let a = 20.0 + (t / 900.0).sin();
            let b = 21.0 + (t / 1500.0).cos();
            let c = 22.0 + 0.5 * (t / 400.0).sin();
            csv += &format!("{t},{a},{b},{c},{}\n", 3.0 * a - 2.0 * b);
        }
        let sel = Selection {
            targets: vec!["d_um".into()],
            ..Default::default()
        };
        read_csv(&csv, "exact", &sel, Default::default()).unwrap()
    }

    /// The coefficient printed in the terms table for `name`.
    fn printed_coefficient(text: &str, name: &str) -> f64 {
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("no term {name} in\n{text}"));
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    }

    #[test]
    fn renderers_show_the_generating_coefficients() {
        let table = exact_table();
        let split = Split::None;
        let opts = IdentifyOptions {
            model: ModelKind::Static,
            classes: Some(3),
            split: split.clone(),
            ..Default::default()
        };
        let id = identify(&table, &opts).unwrap();
        let base = plain_least_squares(&table, &split).unwrap();
        let origin = Origin {
            name: "exact",
            data: "exact",
            rows: 60,
            created_by: "test",
            restart_after_s: None,
        };
        let file = id.to_model_file(&origin, &[], None).unwrap();
        let fit = FitReport {
            data_name: "exact",
            table: &table,
            id: &id,
            plain_ls: &base,
            split: &split,
            split_note: Some("every row trains"),
            file: &file,
            workpiece: None,
        };
        let text = fit.summary_text().unwrap();
        assert!(
            text.starts_with("data: exact: 60 rows, 3 inputs, 1 target(s); 60 training rows, 0 test rows\n  note: every row trains\n"),
            "{text}"
        );
        assert!(
            (printed_coefficient(&text, "a_c") - 3.0).abs() < 1e-6,
            "{text}"
        );
        assert!(
            (printed_coefficient(&text, "b_c") + 2.0).abs() < 1e-6,
            "{text}"
        );
        assert!(printed_coefficient(&text, "c_c").abs() < 1e-6, "{text}");
        assert!(text.contains("extrapolation: 0 of 0 test rows"), "{text}");
        assert!(text.contains("train 0.000, test -,"), "{text}");

        let v = fit.to_json().unwrap();
        assert_eq!(v["rows"], 60);
        assert_eq!(v["training_rows"], 60);
        assert_eq!(v["test_rows"], 0);
        let t = &v["targets"][0];
        assert_eq!(t["target"], "d_um");
        assert!(t["test_rmse_um"].is_null());
        assert!(t["train_rmse_um"].as_f64().unwrap() < 1e-9);
        assert_eq!(t["sensors"].as_array().unwrap().len(), 3);
        assert_eq!(v["model_file"]["axes"].as_array().unwrap().len(), 1);

        let rows = fit.summary_rows();
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0][0], "d_um");
        assert_eq!(rows[0][4], "0.000");
        assert_eq!(rows[0][5], "-");

        let html = fit.html_report("exact").unwrap().to_html();
        assert!(html.contains("gearcomp fit: exact"));
        assert!(html.contains("d_um: measured vs predicted"));
        assert!(html.contains("d_um: residual (measured − predicted)"));
        assert!(html.contains("Model file"));
        assert!(!html.contains("Workpiece shrink"));
    }
}
