//! `gearcomp grind equalise`: the worm cone angle ϑ1 that gives both flanks the same diagonal
//! ratio (A6/T14). Reference numbers: docs/grinding.md "Independent reference: reference example"
//! (K = −0.877178 for ρ_F1 = 20°,
//! ρ_F2 = 45°; the asymmetric gear's cylindrical-worm K_r = −0.878547), and the library's T14
//! root for the asymmetric example (docs/grinding.md: ϑ1 = 0.114662°, K = −0.877781).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::process::{Command, Output};

fn gearcomp() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gearcomp"))
}

/// Writes a config into the test's own temp directory (tests run in parallel).
fn config(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gearcomp-grind-equalise-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The reference example (z2 = 31, m_n = 3, β = 15°, one-start worm r1 = 130 mm) with
/// pressure angles α_r/α_l and the [equalise] table `eq`.
fn cfg(alpha_r: f64, alpha_l: f64, worm_cone: f64, eq: &str) -> String {
    format!(
        "[gear]\nteeth = 31\nmodule_mm = 3.0\npressure_angle_deg = {alpha_r}\n\
         pressure_angle_left_deg = {alpha_l}\nhelix_angle_deg = 15.0\ncone_angle_deg = 0.0\n\n\
         [worm]\nstarts = 1\nradius_mm = 130.0\nhand = \"right\"\ncone_angle_deg = {worm_cone}\n\n\
         [equalise]\n{eq}\n"
    )
}

const GIVEN_LINES: &str = "gear_rho_right_deg = 45.0\ngear_rho_left_deg = -45.0\n\
                           worm_rho_right_deg = 20.0\nworm_rho_left_deg = -20.0\n";

fn run(args: &[&str]) -> Output {
    gearcomp().args(args).output().unwrap()
}

fn json(path: &std::path::Path) -> serde_json::Value {
    let out = run(&["grind", "equalise", path.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn f(v: &serde_json::Value, path: &[&str]) -> f64 {
    path.iter().fold(v, |v, k| &v[*k]).as_f64().unwrap()
}

/// Symmetric gear, mirror-symmetric modification: no cone is needed (ϑ1 = 0) and the common K
/// is T7's −0.877178.
#[test]
fn symmetric_gear_gives_zero_cone_and_t7_ratio() {
    let p = config("sym.toml", &cfg(20.0, 20.0, 0.0, GIVEN_LINES));
    let v = json(&p);
    assert!(f(&v, &["cone1_deg"]).abs() < 1e-9, "{v}");
    assert!((f(&v, &["k_zv1"]) + 0.877178).abs() < 1e-6, "{v}");
    assert!((f(&v, &["equalised", "k_left"]) + 0.877178).abs() < 1e-6);
    assert!((f(&v, &["equalised", "k_right"]) + 0.877178).abs() < 1e-6);
}

/// Asymmetric gear (α_n,r = 25°, α_n,l = 20°): at the present cylindrical worm the flanks need
/// T6's different K (−0.877178 / −0.878547); the equalising cone is 0.114662° with
/// K = −0.877781 on both flanks.
#[test]
fn asymmetric_gear_reproduces_t14_root() {
    let p = config("asym.toml", &cfg(25.0, 20.0, 0.0, GIVEN_LINES));
    let v = json(&p);
    assert!(
        (f(&v, &["at_given_cone", "k_left"]) + 0.877178).abs() < 1e-6,
        "{v}"
    );
    assert!((f(&v, &["at_given_cone", "k_right"]) + 0.878547).abs() < 1e-6);
    assert!((f(&v, &["cone1_deg"]) - 0.114662).abs() < 5e-7, "{v}");
    assert!((f(&v, &["k_zv1"]) + 0.877781).abs() < 5e-7, "{v}");
    let (kl, kr) = (
        f(&v, &["equalised", "k_left"]),
        f(&v, &["equalised", "k_right"]),
    );
    assert!((kl - kr).abs() < 1e-9, "{kl} {kr}");
    // the table prints the same root
    let out = run(&["grind", "equalise", p.to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("worm cone ϑ1 = 0.114662°"), "{text}");
    assert!(text.contains("common K_ZV1 = -0.877781"), "{text}");
}

/// cone_angle_deg = 0 on both bodies is the cylindrical path: the K reported at the given
/// (zero) worm cone equals the diagonal ratio of `grind simulate` (chain (28), `WormGearPair`)
/// on each flank.
#[test]
fn zero_cone_matches_the_cylindrical_path() {
    let p = config("zero.toml", &cfg(25.0, 20.0, 0.0, GIVEN_LINES));
    let v = json(&p);
    for (flank, worm_rho, gear_rho, key) in [
        ("right", "20", "45", "k_right"),
        ("left", "-20", "-45", "k_left"),
    ] {
        let out = run(&[
            "grind",
            "simulate",
            "--pressure-angle-deg",
            "25",
            "--pressure-angle-left-deg",
            "20",
            "--flank",
            flank,
            "--worm-rho-deg",
            worm_rho,
            "--gear-rho-deg",
            gear_rho,
            "--grid-w",
            "3",
            "--grid-z",
            "3",
            "--json",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let s: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let k_cyl = s["diagonal_ratio"].as_f64().unwrap();
        let k_cone = f(&v, &["at_given_cone", key]);
        assert!(
            (k_cyl - k_cone).abs() < 1e-12,
            "{flank}: {k_cyl} vs {k_cone}"
        );
    }
}

/// With the axial-section worm lines the asymmetric example has no root within ±15°: a clear
/// error naming the range fields.
#[test]
fn no_root_is_a_clear_error() {
    let eq = "gear_rho_right_deg = 45.0\ngear_rho_left_deg = -45.0\n\
              cone_min_deg = -15.0\ncone_max_deg = 15.0\n";
    let p = config("noroot.toml", &cfg(25.0, 20.0, 0.0, eq));
    let out = run(&["grind", "equalise", p.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no worm cone angle in [-15°, 15°]") && err.contains("cone_min_deg"),
        "{err}"
    );
}

/// Bad configs name the field: one worm line only, a cone beyond 50°, an unknown key.
#[test]
fn bad_configs_name_the_field() {
    let one = "gear_rho_right_deg = 45.0\ngear_rho_left_deg = -45.0\nworm_rho_right_deg = 20.0\n";
    let p = config("one.toml", &cfg(20.0, 20.0, 0.0, one));
    let out = run(&["grind", "equalise", p.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("worm_rho_left_deg"));
    let p = config("cone.toml", &cfg(20.0, 20.0, 60.0, GIVEN_LINES));
    let out = run(&["grind", "equalise", p.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("cone_angle"), "{err}");
    let p = config(
        "unknown.toml",
        &cfg(20.0, 20.0, 0.0, GIVEN_LINES).replace("starts", "start"),
    );
    let out = run(&["grind", "equalise", p.to_str().unwrap()]);
    assert!(!out.status.success());
}
