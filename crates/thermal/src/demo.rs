//! The demo shift of `gearcomp demo`: a preset's engine optionally driven by a thermal model
//! file ([`use_model_file`]), and the closed-loop result ([`ShiftReport`]) as a text table,
//! JSON and an HTML report with the temperatures, the drift with and without compensation,
//! the applied offset and the residual.
//!
//! The figures are those of [`ClosedLoopRun`] (µm, ISO 230-3 drift statistics via
//! [`ClosedLoopRun::uncompensated`] and [`ClosedLoopRun::compensated`]); nothing is
//! recomputed here but the thinning of long series for the charts ([`thin`]).

use gearcomp_core::model::ModelFile;
use gearcomp_report::{Chart, HtmlReport, Series};
use serde_json::{json, Value};

use crate::closed_loop::{ClosedLoopRun, DriftStats};
use crate::config::{Sign, TermConfig};
use crate::presets::{Preset, PresetBundle};

/// Most points per chart series.
const MAX_CHART_POINTS: usize = 900;

/// Replaces the law of the bundle's first axis by the model file `model` (loaded from `key`,
/// the name the configuration refers to it by): the model's axis of the same name, else its
/// first axis, with sign +. Returns the law's description for the report, or `None` when the
/// model file has no axis.
pub fn use_model_file(
    bundle: &mut PresetBundle,
    preset: Preset,
    key: &str,
    model: ModelFile,
) -> Option<String> {
    let axis = bundle.config.axes.first_mut()?;
    let model_axis = model
        .axes
        .iter()
        .find(|a| a.axis == axis.name)
        .or(model.axes.first())
        .map(|a| a.axis.clone())?;
    axis.terms = vec![TermConfig::Model {
        file: key.to_string(),
        axis: model_axis.clone(),
        sign: Sign::Plus,
    }];
    let law = format!(
        "model file {key} (\"{}\", axis {model_axis}) on the {} preset",
        model.name,
        preset.name()
    );
    bundle.config.insert_model(key, model);
    Some(law)
}

/// Every `⌊len / n⌋`-th (x, y) pair (at least every one; `n = 0` counts as 1), so about `n`
/// points remain; the first point is always kept.
pub fn thin(x: &[f64], y: &[f64], n: usize) -> Vec<(f64, f64)> {
    let step = (x.len() / n.max(1)).max(1);
    x.iter()
        .zip(y)
        .step_by(step)
        .map(|(a, b)| (*a, *b))
        .collect()
}

/// A simulated shift and what it was run with, ready to render.
#[derive(Debug, Clone, Copy)]
pub struct ShiftReport<'a> {
    /// The preset's name (`grinder`, …).
    pub preset: &'a str,
    /// The simulated machine's description.
    pub machine: &'a str,
    /// The compensation law's description.
    pub law: &'a str,
    /// Shift length (h).
    pub hours: f64,
    /// Noise seed.
    pub seed: u64,
    /// The closed-loop run.
    pub run: &'a ClosedLoopRun,
}

fn stats_json(s: &DriftStats) -> Value {
    json!({ "max_abs_um": s.max_abs_um, "rms_um": s.rms_um, "range_um": s.range_um })
}

impl ShiftReport<'_> {
    /// "gearcomp demo: {machine} ({hours} h, seed {seed})".
    pub fn title(&self) -> String {
        format!(
            "gearcomp demo: {} ({} h, seed {})",
            self.machine, self.hours, self.seed
        )
    }

    /// The text table: title, law, max |e|, RMS and drift range without and with
    /// compensation, the reduction factor (when the compensated maximum is not 0), alarms,
    /// stops and pulses.
    pub fn text(&self) -> String {
        let (u, c) = (self.run.uncompensated(), self.run.compensated());
        let mut s = format!("{}\nlaw: {}\n", self.title(), self.law);
        s += "gear size error (centre distance)   max |e| / µm   RMS / µm   drift range / µm\n";
        s += &format!(
            "  without compensation              {:>12.2} {:>10.2} {:>18.2}\n",
            u.max_abs_um, u.rms_um, u.range_um
        );
        s += &format!(
            "  with compensation                 {:>12.2} {:>10.2} {:>18.2}\n",
            c.max_abs_um, c.rms_um, c.range_um
        );
        if c.max_abs_um > 0.0 {
            s += &format!(
                "max |e| reduced {:.1}×; alarms {}, stops {}, pulses {}\n",
                u.max_abs_um / c.max_abs_um,
                self.run.alarm_cycles,
                self.run.stop_cycles,
                self.run.pulse_total
            );
        }
        s
    }

    /// The JSON document of `demo --json`; `report` is the report's path as shown.
    pub fn to_json(&self, report: &str) -> Value {
        json!({
            "preset": self.preset,
            "machine": self.machine,
            "law": self.law,
            "hours": self.hours,
            "seed": self.seed,
            "uncompensated": stats_json(&self.run.uncompensated()),
            "compensated": stats_json(&self.run.compensated()),
            "alarm_cycles": self.run.alarm_cycles,
            "stop_cycles": self.run.stop_cycles,
            "pulse_total": self.run.pulse_total,
            "report": report,
        })
    }

    /// The result paragraphs of the HTML report: law, the two maxima and ranges, the alarm,
    /// stop and pulse counts.
    fn result_lines(&self) -> [String; 3] {
        let (u, c) = (self.run.uncompensated(), self.run.compensated());
        [
            format!("Law: {}.", self.law),
            format!(
                "Without compensation the size error reaches {:.1} µm (drift range {:.1} µm); with compensation {:.1} µm (range {:.1} µm).",
                u.max_abs_um, u.range_um, c.max_abs_um, c.range_um
            ),
            format!(
                "Alarm cycles: {}, stop-request cycles: {}, infeed pulses issued: {}.",
                self.run.alarm_cycles, self.run.stop_cycles, self.run.pulse_total
            ),
        ]
    }

    /// The HTML report; `cfg_toml` is the engine configuration shown at its end.
    pub fn html(&self, cfg_toml: &str) -> gearcomp_report::Result<HtmlReport> {
        let (u, c) = (self.run.uncompensated(), self.run.compensated());
        let mut r = HtmlReport::new(self.title());
        r.heading("Result");
        for l in &self.result_lines() {
            r.paragraph(l);
        }
        let row = |name: &str, s: &DriftStats| {
            vec![
                name.to_string(),
                format!("{:.2}", s.max_abs_um),
                format!("{:.2}", s.rms_um),
                format!("{:.2}", s.range_um),
            ]
        };
        r.table(
            &[
                "gear size error (centre distance)",
                "max |e| / µm",
                "RMS / µm",
                "drift range / µm",
            ],
            &[
                row("without compensation", &u),
                row("with compensation", &c),
            ],
        );
        self.charts(&mut r)?;
        r.heading("Engine configuration");
        r.preformatted(cfg_toml);
        r.paragraph(
            "Sign convention: a positive offset increases the centre distance; the residual is drift + offset. \
             Drift range is max − min over the shift (ISO 230-3 total drift). The machine is simulated by a \
             lumped thermal network with illustrative constants tuned to the magnitudes of EP0138375, JPH0761598B2 and CN105397560.",
        );
        Ok(r)
    }

    /// Temperatures, displacement sensors, drift, offset and residual over time.
    fn charts(&self, r: &mut HtmlReport) -> gearcomp_report::Result<()> {
        let run = self.run;
        let n = MAX_CHART_POINTS;
        let mut temps = Chart::new(
            "Sensor temperatures and ambient",
            "time / h",
            "temperature / °C",
        );
        let mut disp = Chart::new("Displacement sensors", "time / h", "reading / µm");
        for (name, s) in run.sensor_names.iter().zip(&run.sensors) {
            let series = Series::line(name.clone(), thin(&run.time_h, s, n));
            if name.ends_with("_um") {
                disp.series.push(series);
            } else {
                temps.series.push(series);
            }
        }
        temps.series.push(Series::line(
            "ambient",
            thin(&run.time_h, &run.ambient_c, n),
        ));
        r.heading("Temperatures");
        r.chart(&temps)?;
        if !disp.series.is_empty() {
            r.chart(&disp)?;
        }
        r.heading("Drift, offset and residual");
        let line = |name: &str, y: &[f64]| Series::line(name, thin(&run.time_h, y, n));
        r.chart(
            &Chart::new(
                "Centre-distance drift: without and with compensation",
                "time / h",
                "size error / µm",
            )
            .with(line("without compensation (true drift)", &run.drift_um))
            .with(line("with compensation (residual)", &run.residual_um)),
        )?;
        r.chart(
            &Chart::new("Applied offset", "time / h", "offset / µm")
                .with(line("applied offset", &run.offset_um)),
        )?;
        r.chart(
            &Chart::new(
                "Residual error with compensation",
                "time / h",
                "residual / µm",
            )
            .with(line("residual", &run.residual_um)),
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::presets::bundle;

    /// A run by hand: drift 0, 2, −4, 6 µm; offset −0, −1, 3, −4; residual 0, 1, −1, 2.
    fn hand_run() -> ClosedLoopRun {
        ClosedLoopRun {
            time_h: vec![0.0, 1.0, 2.0, 3.0],
            ambient_c: vec![20.0; 4],
            sensors: vec![vec![21.0; 4], vec![5.0; 4]],
            sensor_names: vec!["bed_c".into(), "probe_um".into()],
            drift_um: vec![0.0, 2.0, -4.0, 6.0],
            offset_um: vec![0.0, -1.0, 3.0, -4.0],
            residual_um: vec![0.0, 1.0, -1.0, 2.0],
            alarm_cycles: 1,
            stop_cycles: 0,
            pulse_total: -7,
        }
    }

    #[test]
    fn thinning_takes_every_floor_len_over_n_th_point() {
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        // ⌊10 / 3⌋ = 3: points 0, 3, 6, 9.
        let t = thin(&x, &x, 3);
        assert_eq!(t, [(0.0, 0.0), (3.0, 3.0), (6.0, 6.0), (9.0, 9.0)]);
        assert_eq!(thin(&x, &x, 100).len(), 10);
        // n = 0 counts as 1: ⌊10 / 1⌋ = 10, the first point only.
        assert_eq!(thin(&x, &x, 0), [(0.0, 0.0)]);
        // Shorter y: pairs end with it.
        assert_eq!(thin(&x, &[1.0, 2.0], 10), [(0.0, 1.0), (1.0, 2.0)]);
    }

    #[test]
    fn text_and_json_carry_the_iso_230_3_figures() {
        let run = hand_run();
        let s = ShiftReport {
            preset: "grinder",
            machine: "test machine",
            law: "by hand",
            hours: 3.0,
            seed: 7,
            run: &run,
        };
        // Without: max |e| 6, RMS √((0+4+16+36)/4) = √14, range 6 − (−4) = 10.
        // With: max 2, RMS √((0+1+1+4)/4) = √1.5, range 2 − (−1) = 3; reduction 6/2 = 3.
        let text = s.text();
        let expected = format!(
            "gearcomp demo: test machine (3 h, seed 7)\nlaw: by hand\n\
             gear size error (centre distance)   max |e| / µm   RMS / µm   drift range / µm\n\
             \x20 without compensation              {:>12.2} {:>10.2} {:>18.2}\n\
             \x20 with compensation                 {:>12.2} {:>10.2} {:>18.2}\n\
             max |e| reduced 3.0×; alarms 1, stops 0, pulses -7\n",
            6.0,
            14f64.sqrt(),
            10.0,
            2.0,
            1.5f64.sqrt(),
            3.0
        );
        assert_eq!(text, expected);
        let v = s.to_json("r.html");
        assert_eq!(v["uncompensated"]["range_um"], 10.0);
        assert!((v["compensated"]["rms_um"].as_f64().unwrap() - 1.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(v["pulse_total"], -7);
        assert_eq!(v["report"], "r.html");
        let html = s.html("[engine]").unwrap().to_html();
        assert!(html.contains("Displacement sensors") && html.contains("[engine]"));
        assert!(html.contains("Alarm cycles: 1, stop-request cycles: 0, infeed pulses issued: -7."));
    }

    #[test]
    fn a_perfect_run_prints_no_reduction_factor() {
        let mut run = hand_run();
        run.residual_um = vec![0.0; 4];
        let s = ShiftReport {
            preset: "grinder",
            machine: "m",
            law: "l",
            hours: 1.0,
            seed: 1,
            run: &run,
        };
        assert!(!s.text().contains("reduced"));
    }

    #[test]
    fn model_file_replaces_the_first_axis_law() {
        let text = r#"format = "gearcomp-thermal-model/1"
name = "two axes"
[[axes]]
axis = "Q"
[axes.machine]
intercept = 0.0
[[axes.machine.terms]]
channel = "bed_top_c"
coefficient = -3.75
"#;
        let model: ModelFile = toml::from_str(text).unwrap();
        let mut b = bundle(Preset::Grinder);
        let first = b.config.axes[0].name.clone();
        let law = use_model_file(&mut b, Preset::Grinder, "m.toml", model.clone()).unwrap();
        // No axis of the preset's name in the file: its first axis (Q) is used.
        assert_eq!(
            law,
            "model file m.toml (\"two axes\", axis Q) on the grinder preset"
        );
        assert_eq!(b.config.axes[0].name, first);
        assert!(matches!(
            &b.config.axes[0].terms[..],
            [TermConfig::Model { file, axis, sign: Sign::Plus }] if file == "m.toml" && axis == "Q"
        ));
        let mut empty = model;
        empty.axes.clear();
        assert!(
            use_model_file(&mut bundle(Preset::Grinder), Preset::Grinder, "e", empty).is_none()
        );
    }
}
