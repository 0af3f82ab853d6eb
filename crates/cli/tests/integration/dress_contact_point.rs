//! `gearcomp dress` end to end for the contact line through a point (ν_zS as fifth unknown,
//! test D5) and the zero-stretch profile angle of `dress plan` (claim 2, test F3).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{gearcomp, write_config};

fn write_config_here(name: &str, text: &str) -> PathBuf {
    write_config("dress-cp", name, "dress.toml", text)
}

use std::path::PathBuf;

use gearcomp_dressing::dresser::{Dresser, DresserSpec};
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::kinematics::AxisCorrection;
use gearcomp_dressing::simulation::{simulate, SimSpec};
use gearcomp_dressing::worm::{Flank, Worm};

const CONFIG: &str = concat!(
    include_str!("../fixtures/worm_z5_dresser.toml"),
    r#"
[solve]
flank = "right"
method = "three-point"
crowning_um = 0.2
contact_point = { w_fraction = 0.5, b_mm = 20.0 }

[plan]
diameters_mm = [160.0, 150.0, 140.0]
zero_stretch = true
"#
);

/// D5 through the CLI: `dress solve` with `contact_point` reports ν_zS; the full time-stepped
/// simulation (an independent method: vectors shortened at discrete dresser poses) aborted at
/// that ν_zS shows the switch "final / not yet final" in the row w_0 within one grid cell
/// (0.25 mm) of b_0 = 20 mm, and machine (5) at that point has V1 = ν_zS, X1 = d_0 + Δd.
#[test]
fn d5_contact_line_through_a_point_via_cli() {
    let cfg = write_config_here("d5", CONFIG);
    let report = cfg.with_file_name("d5.html");
    let out = gearcomp(&[
        "dress",
        "solve",
        cfg.to_str().unwrap(),
        "--json",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let f = |k: &str| v[k].as_f64().unwrap();
    let cp = &v["contact_point"];
    let nu = cp["nu_zs_mm"].as_f64().unwrap();
    let w0 = cp["w_mm"].as_f64().unwrap();
    assert_eq!(cp["b_mm"].as_f64().unwrap(), 20.0);
    let dk = AxisCorrection::from_array([
        f("dphi_s_rad"),
        f("dgamma_deg").to_radians(),
        f("dd_mm"),
        f("dnu_ya_mm"),
    ]);
    // Independent check by the full simulation, built from the library.
    let worm = Worm::design(5, 160.0, 3.0, 20f64.to_radians()).unwrap();
    let dresser = Dresser::design(
        &worm,
        DresserSpec {
            d_a_mm: 100.0,
            jacket_width_mm: 0.8,
            clearance_mm: 0.0,
        },
    )
    .unwrap();
    let s = DressingSetup::new(worm, dresser);
    let (a, b) = s.active_profile(Flank::Right).unwrap();
    assert!((w0 - 0.5 * (a + b)).abs() < 1e-9);
    let cell = 0.25;
    let spec = SimSpec {
        flank: Flank::Right,
        w_mm: vec![w0],
        b_mm: (-8..=8).map(|i| 20.0 + cell * f64::from(i)).collect(),
        dt_rad: 0.01f64.to_radians(),
        stock_mm: 0.05,
        inside_mm: 0.05,
        stop_nu_zs_mm: Some(nu),
    };
    let r = simulate(&s, &spec, &dk).unwrap();
    let fin = s.dress_point(Flank::Right, w0, &dk).unwrap().f_mm;
    for (i, bk) in spec.b_mm.iter().enumerate() {
        let l = r.f_mm[0][i];
        if *bk >= 20.0 + cell {
            assert!(
                (l - fin).abs() < 1e-6,
                "b {bk}: {l} should be final ({fin})"
            );
        } else if *bk <= 20.0 - cell {
            assert!(l - fin > 1e-3, "b {bk}: {l} should not be final yet");
        }
    }
    let ax = &cp["axes_bsp2"];
    assert!((ax["v1_mm"].as_f64().unwrap() - nu).abs() < 1e-9);
    assert!((ax["x1_mm"].as_f64().unwrap() - (s.nominal.d_mm + dk.dd_mm)).abs() < 1e-6);
    // The reported contact line at ν_zS passes through the point.
    let line = cp["contact_line"].as_array().unwrap();
    let mid = &line[10];
    assert!((mid[0].as_f64().unwrap() - w0).abs() < 1e-9);
    assert!((mid[1].as_f64().unwrap() - 20.0).abs() < 1e-6);
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(html.contains("prescribed point"));
    // The table names it too.
    let out = gearcomp(&["dress", "solve", cfg.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("nu_zS"));
}

/// `dress plan` with `zero_stretch = true`: per dressing the chosen profile angle; the new worm
/// keeps 20°, the worn ones get an angle between the unchanged helicoid's and 20° with zero
/// stretching and the profile still held (< 0.1 µm).
#[test]
fn plan_zero_stretch_reports_the_profile_angle() {
    let cfg = write_config_here("f3", CONFIG);
    let out = gearcomp(&["dress", "plan", cfg.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert!((rows[0]["alpha_n_deg"].as_f64().unwrap() - 20.0).abs() < 1e-9);
    for r in &rows[1..] {
        let a = r["alpha_n_deg"].as_f64().unwrap();
        let keep = r["alpha_keep_deg"].as_f64().unwrap();
        assert!(keep < a && a < 20.0, "{keep} {a}");
        assert!(r["stretch"].as_f64().unwrap().abs() < 1e-8);
        assert!(r["deviation_max_um"].as_f64().unwrap() < 0.1);
    }
    let out = gearcomp(&["dress", "plan", cfg.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("alpha deg"));
    let bad = write_config_here(
        "f3bad",
        &CONFIG.replace(
            "zero_stretch = true",
            "zero_stretch = true\nalpha_search_deg = 50.0",
        ),
    );
    let out = gearcomp(&["dress", "plan", bad.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("alpha_search_deg") && err.contains("0.01 ..= 20"),
        "{err}"
    );
    let bad = write_config_here(
        "cpbad",
        &CONFIG.replace("w_fraction = 0.5", "w_fraction = 1.5"),
    );
    let out = gearcomp(&["dress", "solve", bad.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("contact_point.w_fraction"));
}
