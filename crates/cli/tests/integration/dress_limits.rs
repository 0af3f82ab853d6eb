//! Issue 13 item 6 through the binary: `dress solve` refuses what the worm cannot carry (the
//! penetration check of `dress plan`) naming `budget_mm` and the producible range, no internal
//! non-convergence reaches the user, input errors name the TOML key and its unit, and `dress
//! plan` states its evaluation range. Plus random requests (fixed seed and fresh).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{all_finite, gearcomp, prop_runners, write_config};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// G1-Z5 (docs/dressing.md "Reference case G1-Z5") with a [solve] table to fill in.
const BASE: &str = concat!(
    include_str!("../fixtures/worm_z5_dresser.toml"),
    r#"
[solve]
flank = "right"
method = "three-point"
"#
);

fn solve(name: &str, solve_lines: &str, json: bool) -> std::process::Output {
    let cfg = write_config(
        "dress-limits",
        name,
        "dress.toml",
        &format!("{BASE}{solve_lines}\n"),
    );
    let mut args = vec!["dress", "solve", cfg.to_str().unwrap()];
    if json {
        args.push("--json");
    }
    gearcomp(&args)
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn crowning_2um_is_refused_unless_accepted() {
    let o = solve("c2", "crowning_um = 2.0", false);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("[solve] crowning_um")
            && err.contains("903.5 µm into the opposite flank")
            && err.contains("670.8 µm below the worm root circle")
            && err.contains("[solve] budget_mm = 0.1 mm")
            && err.contains("largest crowning")
            && err.contains("accept_penetration = true"),
        "{err}"
    );
    let o = solve(
        "c2acc",
        "crowning_um = 2.0\naccept_penetration = true",
        true,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["penetration"], true);
    assert_eq!(v["undercut"], true);
    assert!((v["opposite_flank_cut_um"].as_f64().unwrap() - 903.5).abs() < 0.1);
    assert!((v["budget_um"].as_f64().unwrap() - 100.0).abs() < 1e-9);
    // A larger budget lets it through unflagged.
    let o = solve("c2big", "crowning_um = 2.0\nbudget_mm = 1.0", true);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn crowning_3um_and_worn_worms_give_a_cause_not_a_solver_failure() {
    for (name, lines, expect) in [
        ("c3", "crowning_um = 3.0", "crowning_um = 0.47"),
        (
            "d100",
            "crowning_um = 0.2\ndiameter_mm = 100.0",
            "463.1 µm into the opposite flank",
        ),
        (
            "d80",
            "crowning_um = 0.2\ndiameter_mm = 80.0",
            "producible for [solve] diameter_mm from",
        ),
    ] {
        let o = solve(name, lines, false);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}");
        assert!(!err.contains("did not converge"), "{name}: {err}");
        assert!(err.contains(expect), "{name}: {err}");
    }
}

#[test]
fn input_errors_name_the_toml_key_and_unit() {
    let cases: [(&str, String, &str); 6] = [
        (
            "dup",
            format!("{BASE}points = [[0.5, 0.0], [0.5, -0.2], [0.95, 0.0]]"),
            "[solve] points: rows 0 and 1 have the same fraction 0.5",
        ),
        (
            "jacket0",
            format!("{BASE}crowning_um = 0.2")
                .replace("jacket_width_mm = 0.8", "jacket_width_mm = 0.0"),
            "[dresser] jacket_width_mm = 0 mm is outside the allowed range",
        ),
        (
            "alpha",
            format!("{BASE}crowning_um = 0.2")
                .replace("profile_angle_deg = 20.0", "profile_angle_deg = 60.0"),
            "[worm] profile_angle_deg = 60 degrees is outside the allowed range 5 ..= 45 degrees",
        ),
        (
            "starts",
            format!("{BASE}crowning_um = 0.2").replace("starts = 5", "starts = 0"),
            "[worm] starts = 0 is outside the allowed range 1 ..= 20",
        ),
        (
            "dsmall",
            format!("{BASE}crowning_um = 0.2\ndiameter_mm = 50.0"),
            // 2·(r_b + 2.25·m_n) = 2·(19.954757 + 6.75) = 53.40951 mm, rounded up.
            "[solve] diameter_mm = 50 mm is outside the allowed range 53.4096 ..= 160 mm",
        ),
        (
            "module",
            format!("{BASE}crowning_um = 0.2").replace("diameter_mm = 160.0", "diameter_mm = 14.0"),
            "[worm] diameter_mm = 14 mm is outside the allowed range",
        ),
    ];
    for (name, text, expect) in cases {
        let cfg = write_config("dress-limits", name, "dress.toml", &text);
        let o = gearcomp(&["dress", "solve", cfg.to_str().unwrap()]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}");
        assert!(err.contains(expect), "{name}: {err}");
        for lib in ["_rad", "z_s", "d_s_mm", "alpha_n", "d_a_mm"] {
            assert!(!err.contains(lib), "{name}: {lib} in {err}");
        }
    }
}

#[test]
fn plan_states_its_evaluation_range() {
    let text = format!(
        "{}\n[plan]\ndiameters_mm = [160.0, 150.0]\ncrowning_um = 0.2\n",
        BASE.replace("[solve]\nflank = \"right\"\nmethod = \"three-point\"\n", "")
    );
    let cfg = write_config("dress-limits", "plan", "dress.toml", &text);
    let o = gearcomp(&["dress", "plan", cfg.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("5 % ..= 95 % of the active profile") && out.contains("foot"),
        "{out}"
    );
    let o = gearcomp(&["dress", "plan", cfg.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for r in v.as_array().unwrap() {
        let (a, b) = (
            r["active_mm"][0].as_f64().unwrap(),
            r["active_mm"][1].as_f64().unwrap(),
        );
        let e0 = r["deviation_eval_mm"][0].as_f64().unwrap();
        let e1 = r["deviation_eval_mm"][1].as_f64().unwrap();
        assert!(
            (e0 - (a + 0.05 * (b - a))).abs() < 1e-9 && (e1 - (a + 0.95 * (b - a))).abs() < 1e-9
        );
        assert!(r["deviation_foot_um"].as_f64().unwrap().is_finite());
        assert!(r["deviation_tip_um"].as_f64().unwrap().is_finite());
    }
}

/// Random crowning and worm diameter on G1-Z5: exit 0 ⇒ finite numbers and the printed
/// profile hits the targets (0, −c, 0) at 5/50/95 % (points 1, 10, 19 of 21); exit ≠ 0 ⇒ the
/// message names a [solve] key with its unit.
#[test]
fn random_requests_through_the_binary() {
    for (k, mut runner) in prop_runners(3, 0x0d2e_5514).into_iter().enumerate() {
        runner
            .run(&(-0.6f64..0.6, 140.0f64..160.0), |(c, d)| {
                let name = format!("rand{k}");
                let o = solve(
                    &name,
                    &format!("crowning_um = {c:?}\ndiameter_mm = {d:?}"),
                    true,
                );
                if o.status.success() {
                    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
                    prop_assert!(all_finite(&v), "{v}");
                    let prof = v["profile_um"].as_array().unwrap();
                    for (i, want) in [(1usize, 0.0), (10, -c), (19, 0.0)] {
                        let f = prof[i][1].as_f64().unwrap();
                        prop_assert!((f - want).abs() < 1e-3, "point {i}: {f} vs {want}");
                    }
                } else {
                    let err = stderr(&o);
                    prop_assert!(
                        err.contains("[solve] crowning_um")
                            && err.contains("µm")
                            && err.contains("budget_mm"),
                        "{err}"
                    );
                }
                Ok::<(), TestCaseError>(())
            })
            .unwrap();
    }
}

/// A topological program gets the same check per position: 2 µm at one end of the width is
/// refused naming the position and `budget_mm`; accepted, the rows carry the flags.
#[test]
fn topological_program_beyond_the_budget_is_refused() {
    let topo = "\n[solve.topological]\npositions = 2\nb_range_mm = [-10.0, 10.0]\ncrowning_table = [[-10.0, 0.1], [10.0, 2.0]]\n";
    let o = solve("topo", topo, false);
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("at b0 = 10.000 mm")
            && err.contains("[solve] budget_mm = 0.1 mm")
            && err.contains("accept_penetration"),
        "{err}"
    );
    let o = solve("topoacc", &format!("accept_penetration = true{topo}"), true);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let p = v["positions"].as_array().unwrap();
    assert_eq!(p[0]["penetration"], false);
    assert_eq!(p[1]["penetration"], true);
}

/// Fuzzing (session 10): a 100 mm dresser on a module-100 worm of 5330 mm made `dress plan`
/// print a 138 mm deviation flagged PENETRATION with exit code 0. The dresser axis must clear
/// the tip circle: d_A > 2 × 2.25 × m_n = 450 mm (DIN 3960 tooth depth h_a + h_f = 2.25 m_n).
#[test]
fn a_dresser_smaller_than_twice_the_tooth_depth_is_refused() {
    let text = "[worm]\nstarts = 3\ndiameter_mm = 5330.0\nnormal_module_mm = 100.0\n\
                profile_angle_deg = 20.0\n[dresser]\ndiameter_mm = 100.0\n\
                jacket_width_mm = 26.66667\n[plan]\ndiameters_mm = [5330.0, 5300.0]\n";
    let cfg = write_config("dress-limits", "dresser-small", "dress.toml", text);
    let o = gearcomp(&["dress", "plan", cfg.to_str().unwrap()]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(
            "[dresser] diameter_mm = 100 mm is outside the admissible range > 450.0000 ..= 2000 mm"
        ),
        "{err}"
    );
    assert!(!err.contains("PENETRATION") && o.stdout.is_empty(), "{err}");
}
