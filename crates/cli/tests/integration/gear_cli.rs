//! Issue 2's test vectors through the binary: `gearcomp gear --json`, parsed with serde_json.
//! Tolerance 5e-5 mm is half a unit of the published 4th decimal (Σx: 5e-7, 6 decimals).
#![allow(clippy::unwrap_used, clippy::expect_used)]
// The published s_n = 1.5708 mm is a 4-decimal value, not an attempt at π/2.
#![allow(clippy::approx_constant)]

use std::process::Command;

use serde_json::Value;

fn gearcomp(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .arg("gear")
        .args(args)
        .output()
        .unwrap()
}

fn json(args: &[&str]) -> Value {
    let mut a = args.to_vec();
    a.push("--json");
    let out = gearcomp(&a);
    assert!(
        out.status.success(),
        "gearcomp gear {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn num(v: &Value, path: &str) -> f64 {
    let mut cur = v;
    for key in path.split('.') {
        cur = match key.parse::<usize>() {
            Ok(i) => &cur[i],
            Err(_) => &cur[key],
        };
    }
    cur.as_f64()
        .unwrap_or_else(|| panic!("{path} is not a number: {cur}"))
}

fn close(v: &Value, path: &str, want: f64, tol: f64) {
    let got = num(v, path);
    assert!(
        (got - want).abs() <= tol,
        "{path}: got {got}, want {want} ± {tol}"
    );
}

/// TV1 (MESYS): z = 20, m_n = 1, α_n = 20°, x = 0, k = 2, D_M = 1.7.
#[test]
fn tv1_spur_z20() {
    let v = json(&[
        "--module", "1", "--teeth", "20", "--span-k", "2", "--ball", "1.7",
    ]);
    close(&v, "gear.base_diameter_mm", 18.7939, 5e-5);
    close(&v, "gear.root_form_diameter_mm", 18.8003, 5e-5);
    close(&v, "tooth.0.normal_thickness_mm", 1.5708, 5e-5);
    close(&v, "tooth.0.tip_normal_thickness_mm", 0.6949, 5e-5);
    close(&v, "tooth.0.span.span_mm", 4.7083, 5e-5);
    close(&v, "tooth.0.ball.dimension_mm", 22.2941, 5e-5);
    assert_eq!(v["recommended"]["span_k"], 3);
}

/// TV2 (Ondrives/MESYS): z = 30, m_n = 1, A_sn = −0.06/−0.03 mm, D_M = 1.7.
#[test]
fn tv2_spur_z30_allowances() {
    let v = json(&[
        "--module",
        "1",
        "--teeth",
        "30",
        "--allowances=-0.06,-0.03",
        "--ball",
        "1.7",
    ]);
    close(&v, "gear.base_diameter_mm", 28.1908, 5e-5);
    assert_eq!(v["tooth"][1]["case"], "lower");
    close(&v, "tooth.1.normal_thickness_mm", 1.5108, 5e-5);
    close(&v, "tooth.2.normal_thickness_mm", 1.5408, 5e-5);
    close(&v, "tooth.1.generating_shift", -0.0824, 5e-5);
    close(&v, "tooth.2.generating_shift", -0.0412, 5e-5);
    close(&v, "tooth.1.root_diameter_mm", 27.3352, 5e-5);
    close(&v, "tooth.2.root_diameter_mm", 27.4176, 5e-5);
    close(&v, "tooth.1.ball.dimension_mm", 32.1641, 5e-5);
    close(&v, "tooth.2.ball.dimension_mm", 32.2380, 5e-5);
}

/// TV3: helical pair m_n = 3.5, α_n = 20°, β = 21°, z1 = 31, z2 = 30, a_w = 116.5 mm.
#[test]
fn tv3_helical_pair() {
    let v = json(&[
        "--module",
        "3.5",
        "--pressure-angle",
        "20",
        "--helix",
        "21",
        "--teeth",
        "31",
        "--width",
        "30",
        "--mate-teeth",
        "30",
        "--centre-distance",
        "116.5",
    ]);
    close(&v, "gear.transverse_pressure_angle_deg", 21.2991, 5e-5);
    close(&v, "pair.reference_centre_distance_mm", 114.3447, 5e-5);
    close(&v, "pair.working_pressure_angle_deg", 23.8708, 5e-5);
    close(&v, "pair.shift_sum", 0.651877, 5e-7);
    // The mate takes the rest of Σx, so the nominal design has zero backlash.
    close(&v, "pair.mate.profile_shift", 0.651877, 5e-7);
    close(&v, "pair.backlash.0.normal_mm", 0.0, 1e-12);
    assert_eq!(v["pair"]["mate"]["hand"], "left");
}

/// The same gear from a TOML file with the flags' names; a flag overrides the file.
#[test]
fn toml_file_matches_flags() {
    let dir = std::env::temp_dir().join(format!("gearcomp-gear-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("gear.toml");
    std::fs::write(
        &path,
        "module = 1.0\nteeth = 31\npressure-angle = 20\nallowances = [-0.06, -0.03]\nball = 1.7\n",
    )
    .unwrap();
    let p = path.to_str().unwrap();
    let v = json(&["--file", p, "--teeth", "30"]);
    close(&v, "tooth.1.ball.dimension_mm", 32.1641, 5e-5);
    std::fs::write(&path, "module = 1.0\nteeth = 30\ntypo-key = 3\n").unwrap();
    let out = gearcomp(&["--file", p]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("typo-key"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Bad input: exit code 2 and a message naming the parameter, its value and the range.
#[test]
fn bad_input_is_a_clear_error() {
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--module", "0", "--teeth", "20"],
            &["normal_module_mm = 0", "0 … 1000 mm"],
        ),
        (
            &["--module", "-2", "--teeth", "20"],
            &["normal_module_mm = -2"],
        ),
        (
            &["--module", "1", "--teeth", "20", "--pressure-angle", "45"],
            &["normal_pressure_angle = 45", "0 … 45 °"],
        ),
        (
            &["--module", "1", "--teeth", "20", "--helix", "-60"],
            &["helix = -60", "−60 < β < 60"],
        ),
        (
            &["--module", "1", "--teeth", "2"],
            &["teeth = 2", "3 … 10000"],
        ),
        (
            &["--module", "1", "--teeth", "10"],
            &["undercut", "x_min = 0.5006"],
        ),
        (
            &["--module", "1", "--teeth", "10", "--shift", "1.2"],
            &["pointed tooth"],
        ),
        (
            &["--module", "1", "--teeth", "20", "--ball", "0.5"],
            &["ball_mm = 0.5", "does not touch"],
        ),
        (
            &["--module", "1", "--teeth", "20", "--span-k", "21"],
            &["span_k = 21", "1 … 19"],
        ),
        (
            &[
                "--module",
                "1",
                "--teeth",
                "20",
                "--mate-teeth",
                "20",
                "--centre-distance",
                "5",
            ],
            &["centre_distance_mm = 5"],
        ),
        (&["--teeth", "20"], &["--module"]),
    ];
    for (args, needles) in cases {
        let out = gearcomp(args);
        assert_eq!(out.status.code(), Some(2), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        for n in *needles {
            assert!(err.contains(n), "{args:?}: {err:?} lacks {n:?}");
        }
    }
}

/// `--help` explains every parameter with its unit.
#[test]
fn help_names_units() {
    let out = gearcomp(&["--help"]);
    assert!(out.status.success());
    let h = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "--module",
        "in mm",
        "--pressure-angle",
        "in degrees",
        "--helix",
        "right hand",
        "--teeth",
        "--shift",
        "--width",
        "--internal",
        "--allowances",
        "--ball",
        "--span-k",
        "--mate-teeth",
        "--centre-distance",
        "--file",
        "--json",
    ] {
        assert!(h.contains(needle), "--help lacks {needle:?}");
    }
}

/// The table prints the main values with units.
#[test]
fn table_output_has_units() {
    let out = gearcomp(&[
        "--module", "1", "--teeth", "20", "--span-k", "2", "--ball", "1.7",
    ]);
    assert!(out.status.success());
    let t = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "18.7939 mm",
        "4.7083 mm",
        "22.2941 mm",
        "1.5708 mm",
        "20.0000 °",
    ] {
        assert!(t.contains(needle), "table lacks {needle:?}:\n{t}");
    }
}
