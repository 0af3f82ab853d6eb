//! Thermal model files (`gearcomp_core::model::ModelFile`, written by `gearcomp fit`) run
//! by the engine: the transforms' documented semantics against closed forms, and the
//! CN105397560 regression → workpiece-shrink chain of docs/thermal.md "CN105397560 chain".
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_core::model::ModelFile;
use gearcomp_thermal::{Engine, EngineConfig, Inputs, Reading};

fn engine_with(model_toml: &str, channels: &[&str]) -> Engine {
    let mut cfg_text = String::new();
    for c in channels {
        cfg_text.push_str(&format!(
            "[[channels]]\nname = \"{c}\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -50.0\nvalid_max = 1000.0\nstale_timeout_s = 100.0\n"
        ));
    }
    cfg_text.push_str(
        "[[axes]]\nname = \"X\"\napply = { kind = \"command\" }\nmax_offset_um = 10000.0\n\
         [[axes.terms]]\nkind = \"model\"\nfile = \"m.toml\"\naxis = \"X\"\n",
    );
    let mut cfg = EngineConfig::from_toml_str(&cfg_text).unwrap();
    cfg.insert_model("m.toml", ModelFile::from_toml_str(model_toml).unwrap());
    Engine::new(&cfg).unwrap()
}

fn step(e: &mut Engine, t: f64, values: &[f64]) -> f64 {
    let r: Vec<Reading> = values
        .iter()
        .map(|&v| Reading { raw: v, stamp_s: t })
        .collect();
    e.step(&Inputs {
        time_s: t,
        readings: &r,
        trigger: true,
        safe_point: true,
        positions_mm: &[],
    })
    .axes()[0]
        .law_um
}

/// Ramp u = r·t into each transform, coefficient 1, over 0…5000 s at 1 s steps:
/// value → r·t; delay d → r·(t − d); first-order lag τ of a ramp (started at u(0) = 0):
/// r·(t − τ·(1 − e^(−t/τ))); rate → (u − lag)/τ = r·(1 − e^(−t/τ)). The discrete lag sees
/// the input as held over each step at its new value, which leads the continuous
/// response by r·Δt·(τ-weighted) ≤ r·Δt: tolerance r·Δt.
#[test]
fn transforms_match_closed_forms_on_a_ramp() {
    let model = r#"
format = "gearcomp-thermal-model/1"
name = "ramp"
[[axes]]
axis = "X"
[axes.machine]
intercept = 0.0
[[axes.machine.terms]]
channel = "u"
coefficient = 1.0
transform = TRANSFORM
"#;
    let r = 0.002;
    let (tau, d) = (600.0, 900.0);
    type Expected = Box<dyn Fn(f64) -> f64>;
    let cases: [(&str, Expected, f64); 4] = [
        ("{ kind = \"value\" }", Box::new(move |t| r * t), 1e-12),
        (
            "{ kind = \"delay\", delay_s = 900.0 }",
            Box::new(move |t| r * (t - d).max(0.0)),
            1e-9,
        ),
        (
            "{ kind = \"first_order_lag\", tau_s = 600.0 }",
            Box::new(move |t| r * (t - tau * (1.0 - (-t / tau).exp()))),
            r * 1.0,
        ),
        (
            "{ kind = \"rate\", tau_s = 600.0 }",
            Box::new(move |t| r * (1.0 - (-t / tau).exp())),
            r / tau,
        ),
    ];
    for (kind, expect, tol) in cases {
        let text = model.replace("TRANSFORM", kind);
        let mut e = engine_with(&text, &["u"]);
        for k in 0..=5000 {
            let t = k as f64;
            let y = step(&mut e, t, &[r * t]);
            assert!(
                (y - expect(t)).abs() <= tol,
                "{kind} at t = {t}: {y} vs {}",
                expect(t)
            );
        }
    }
}

/// docs/thermal.md "CN105397560 chain": Ta = −12.531724 + 0.479769·t1 +
/// 1.535764·t2 + 0.360204·t3 at t = (21.0, 29.0, 30.5) → Ta = 53.0668 °C; Tb = 20 °C,
/// λ = 11.5e-6 /K, m = 3, z = 40, α = 20° → δT_p = 22.8488 µm (exact), 22.8161 µm (first
/// order, r·ε) and δT_a = 31.2764 µm at the tip (r_a1 = 63 mm). Machine part: intercept
/// 1.5 µm only, so the offset is 1.5 + δT.
#[test]
fn seed003_workpiece_shrink_chain() {
    let base = r#"
format = "gearcomp-thermal-model/1"
name = "CN105397560 chain"
[[axes]]
axis = "X"
[axes.machine]
intercept = 1.5
[axes.workpiece]
design_temp_c = 20.0
expansion_per_k = 11.5e-6
REFMETHOD
[axes.workpiece.gear]
normal_module_mm = 3.0
pressure_angle_deg = 20.0
teeth = 40
tip_diameter_mm = 126.0
[axes.workpiece.temperature]
intercept = -12.531724
[[axes.workpiece.temperature.terms]]
channel = "t1"
coefficient = 0.479769
[[axes.workpiece.temperature.terms]]
channel = "t2"
coefficient = 1.535764
[[axes.workpiece.temperature.terms]]
channel = "t3"
coefficient = 0.360204
"#;
    let cases = [
        ("reference = \"pitch\"\nmethod = \"exact\"", 22.8488),
        ("reference = \"pitch\"\nmethod = \"first_order\"", 22.8161),
        ("reference = \"tip\"\nmethod = \"exact\"", 31.2764),
    ];
    for (refmethod, delta_um) in cases {
        let mut e = engine_with(&base.replace("REFMETHOD", refmethod), &["t1", "t2", "t3"]);
        let y = step(&mut e, 0.0, &[21.0, 29.0, 30.5]);
        // The published values have 4 decimals (5e-5 µm) and Ta to 4 decimals.
        assert!((y - (1.5 + delta_um)).abs() < 2e-4, "{refmethod}: {y}");
    }
}

#[test]
fn model_errors_name_the_field() {
    let model = r#"
format = "gearcomp-thermal-model/1"
name = "m"
[[axes]]
axis = "X"
[axes.machine]
intercept = 0.0
[[axes.machine.terms]]
channel = "missing_c"
coefficient = 1.0
"#;
    let mut cfg = EngineConfig::from_toml_str(
        "[[channels]]\nname = \"u\"\nsensor = { kind = \"celsius\" }\nvalid_min = 0.0\nvalid_max = 1.0\nstale_timeout_s = 1.0\n\
         [[axes]]\nname = \"X\"\napply = { kind = \"command\" }\nmax_offset_um = 1.0\n\
         [[axes.terms]]\nkind = \"model\"\nfile = \"m.toml\"\naxis = \"Y\"\n",
    )
    .unwrap();
    let err = Engine::new(&cfg).unwrap_err().to_string();
    assert!(err.contains("axes[0].terms[0].file"), "{err}");
    cfg.insert_model("m.toml", ModelFile::from_toml_str(model).unwrap());
    let err = Engine::new(&cfg).unwrap_err().to_string();
    assert!(
        err.contains("axes[0].terms[0].axis") && err.contains("\"Y\"") && err.contains("X"),
        "{err}"
    );
    let fixed = EngineConfig::from_toml_str(
        &cfg.to_toml_string()
            .unwrap()
            .replace("axis = \"Y\"", "axis = \"X\""),
    );
    let mut fixed = fixed.unwrap();
    fixed.insert_model("m.toml", ModelFile::from_toml_str(model).unwrap());
    let err = Engine::new(&fixed).unwrap_err().to_string();
    assert!(
        err.contains("missing_c") && err.contains("terms[0].channel"),
        "{err}"
    );
}

/// `restart_after_s`: a value more than that after the channel's previous one restarts the
/// lag, rate and delay states (closed forms: a lag restarted at u₁ is u₁, its rate 0, a
/// delay with no history the current value), and a step of exactly that carries them on.
/// Without the key the states carry on over any gap. Stepping 2 s at u = 10, then u = 30
/// after a gap.
#[test]
fn restart_after_s_restarts_the_states_after_a_longer_gap() {
    let model = |restart: &str, transform: &str| {
        format!(
            "format = \"gearcomp-thermal-model/1\"\nname = \"gap\"\n{restart}\n[[axes]]\naxis = \"X\"\n\
             [axes.machine]\nintercept = 0.0\n[[axes.machine.terms]]\nchannel = \"u\"\n\
             coefficient = 1.0\ntransform = {transform}\n"
        )
    };
    let (tau, d) = (600.0, 300.0);
    let lag = format!("{{ kind = \"first_order_lag\", tau_s = {tau} }}");
    let rate = format!("{{ kind = \"rate\", tau_s = {tau} }}");
    let delay = format!("{{ kind = \"delay\", delay_s = {d} }}");
    // (transform, after a restart, carried on over a gap g: the closed form at u = 30)
    type Carried = Box<dyn Fn(f64) -> f64>;
    let cases: [(&str, f64, Carried); 3] = [
        (
            &lag,
            30.0,
            Box::new(move |g| 30.0 - 20.0 * (-g / tau).exp()),
        ),
        (&rate, 0.0, Box::new(move |g| 20.0 * (-g / tau).exp() / tau)),
        (
            &delay,
            30.0,
            Box::new(move |g| {
                if g >= d {
                    10.0 + 20.0 * (g - d) / g
                } else {
                    10.0
                }
            }),
        ),
    ];
    for (transform, restarted, carried) in &cases {
        for (restart, gap, restarts) in [
            ("restart_after_s = 120.0", 121.0, true),
            ("restart_after_s = 120.0", 120.0, false),
            ("", 5000.0, false),
        ] {
            let mut e = engine_with(&model(restart, transform), &["u"]);
            let mut t = 0.0;
            // Every 2 s: above the delay line's spacing 300/256 s, so every point is kept.
            for _ in 0..2000 {
                t += 2.0;
                step(&mut e, t, &[10.0]);
            }
            let got = step(&mut e, t + gap, &[30.0]);
            let want = if restarts { *restarted } else { carried(gap) };
            assert!(
                (got - want).abs() <= 1e-9 * (1.0 + want.abs()),
                "{transform} {restart:?} gap {gap}: {got} vs {want}"
            );
        }
    }
    let bad = model("restart_after_s = -1.0", &lag);
    let err = ModelFile::from_toml_str(&bad)
        .and_then(|m| m.validate().map(|_| m))
        .unwrap_err();
    assert!(err.to_string().contains("restart_after_s"), "{err}");
}
