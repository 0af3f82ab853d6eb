//! `gearcomp dress solve` with `[solve.topological]`: a 3-point program whose crowning varies
//! over the worm width, checked position by position with the library's screw evaluation, and
//! against the docs/dressing.md "Reference case G1-Z5" root where the wanted crowning is that of docs/dressing.md "Reference case G1-Z5" (0.2 µm, G1-Z5).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{gearcomp, write_config};

fn write_config_here(name: &str, text: &str) -> PathBuf {
    write_config("dress-topo", name, "dress.toml", text)
}

use std::path::PathBuf;

use gearcomp_dressing::dresser::{Dresser, DresserSpec};
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::kinematics::AxisCorrection;
use gearcomp_dressing::topology::contact_point;
use gearcomp_dressing::worm::{Flank, Worm};

const CONFIG: &str = concat!(
    include_str!("../fixtures/worm_z5_dresser.toml"),
    r#"
[solve]
flank = "right"
method = "three-point"

[solve.topological]
positions = 3
b_range_mm = [-10.0, 10.0]
crowning_table = [[-10.0, 0.1], [10.0, 0.3]]
"#
);

/// G1-Z5 with its gap-filling dresser (docs/dressing.md "Reference case G1-Z5"), built here from the library directly.
fn g1_z5() -> DressingSetup {
    let worm = Worm::design(5, 160.0, 3.0, 20f64.to_radians()).unwrap();
    let spec = DresserSpec {
        d_a_mm: 100.0,
        jacket_width_mm: 0.8,
        clearance_mm: 0.0,
    };
    DressingSetup::new(worm, Dresser::design(&worm, spec).unwrap())
}

/// The wanted crowning of the table above, c(b) in µm (linear, held beyond the ends).
fn c_um(b: f64) -> f64 {
    0.1 + 0.2 * ((b + 10.0) / 20.0).clamp(0.0, 1.0)
}

#[test]
fn topological_program_hits_the_width_dependent_targets() {
    let cfg = write_config_here("ok", CONFIG);
    let report = cfg.with_file_name("topo.html");
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
    let pos = v["positions"].as_array().unwrap();
    assert_eq!(pos.len(), 3);
    let ws: Vec<f64> = v["target_w_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    // docs/dressing.md "Reference case G1-Z5" targets: 5/50/95 % of the active profile of G1-Z5.
    for (w, e) in ws.iter().zip([74.49085, 77.36834, 80.24583]) {
        assert!((w - e).abs() < 1e-5, "{w} vs {e}");
    }
    let s = g1_z5();
    let fl = Flank::Right;
    let k0 = AxisCorrection::default();
    let r_tip = s.association(fl, 80.56555, &k0).unwrap();
    let g = |p: &serde_json::Value, k: &str| p[k].as_f64().unwrap();
    let mut dgammas = Vec::new();
    for p in pos {
        let dk = AxisCorrection::from_array([
            g(p, "dphi_s_rad"),
            g(p, "dgamma_deg").to_radians(),
            g(p, "dd_mm"),
            g(p, "dnu_ya_mm"),
        ]);
        dgammas.push(dk.dgamma_rad);
        let nu = g(p, "nu_zs_mm");
        // Re-evaluate the profile at the local ΔK: where the contact line at ν_zS crosses each
        // target roll distance, the wanted crowning of that width position must be hit.
        for (i, &w) in ws.iter().enumerate() {
            let (d, bc) = contact_point(&s, fl, w, &dk).unwrap();
            let b_i = bc - nu;
            let want = if i == 1 { -c_um(b_i) } else { 0.0 };
            assert!(
                (1e3 * d.f_mm - want).abs() < 2e-3,
                "b0 {} point {i}: f {} µm, want {want} µm",
                g(p, "b0_mm"),
                1e3 * d.f_mm
            );
        }
        // The radius association (22): the new worm's tip dresser radius dresses the tip.
        assert!((s.association(fl, 80.56555, &dk).unwrap() - r_tip).abs() < 1e-5);
    }
    // The interior position (b0 = 0, c = 0.2 µm) is the docs/dressing.md "Reference case G1-Z5" root.
    let p = &pos[1];
    assert!(g(p, "b0_mm").abs() < 1e-12);
    assert!((g(p, "dgamma_deg") / 0.5580 - 1.0).abs() < 0.01);
    assert!((g(p, "dnu_ya_mm") / -1.0413 - 1.0).abs() < 0.01);
    assert!((g(p, "dphi_s_rad") / 6.057e-4 - 1.0).abs() < 0.1);
    assert!((g(p, "dd_mm") / -0.02450 - 1.0).abs() < 0.1);
    // More crowning needs more Δγ (E1–E5 trend): the program is not constant over the width.
    assert!(
        dgammas[0] < dgammas[1] && dgammas[1] < dgammas[2],
        "{dgammas:?}"
    );
    // The quasi-static map at the mid profile passes through −c(b0) at every solved position.
    let map_b = v["map_b_mm"].as_array().unwrap();
    let map_f = v["map_f_um"].as_array().unwrap();
    for p in pos {
        let b0 = g(p, "b0_mm");
        let j = map_b
            .iter()
            .position(|b| (b.as_f64().unwrap() - b0).abs() < 1e-9)
            .unwrap();
        let f = map_f[5][j].as_f64().unwrap();
        assert!((f + c_um(b0)).abs() < 2e-3, "map at b0 {b0}: {f} µm");
    }
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(html.contains("<svg") && html.contains("Dressing program"));
    // Machine axes: V1 is the axial position, X1 the corrected centre distance.
    let a = &pos[1]["axes_bsp2"];
    assert!((a["v1_mm"].as_f64().unwrap() - g(&pos[1], "nu_zs_mm")).abs() < 1e-9);
    assert!((a["x1_mm"].as_f64().unwrap() - (126.25 + g(&pos[1], "dd_mm"))).abs() < 1e-6);
}

#[test]
fn topological_bad_input_names_key_value_range() {
    let cfg = write_config_here("few", &CONFIG.replace("positions = 3", "positions = 1"));
    let out = gearcomp(&["dress", "solve", cfg.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("positions = 1") && err.contains("allowed range 2 ..="),
        "{err}"
    );
    let cfg = write_config_here("typo", &CONFIG.replace("positions = 3", "positons = 3"));
    let out = gearcomp(&["dress", "solve", cfg.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("positons"), "{err}");
    let cfg = write_config_here("range", &CONFIG.replace("[-10.0, 10.0]", "[10.0, -10.0]"));
    let out = gearcomp(&["dress", "solve", cfg.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("b_range_mm"));
}
