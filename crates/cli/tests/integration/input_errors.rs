//! Input errors of `gearcomp grind` and `gearcomp dress` found by an independent test: every
//! refusal names the option or key the user wrote, the value as written and the range in the
//! user's unit (never an internal field or radians), the stated range agrees with what is
//! accepted, and a report that cannot be written leaves stdout empty.

use crate::common::{gearcomp, write_config};

const Z5: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/fixtures/worm_z5_dresser.toml"
);

/// Exit code 2 and the message on stderr.
fn refused(args: &[&str]) -> String {
    let out = gearcomp(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    err
}

fn accepted(args: &[&str]) {
    let out = gearcomp(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// No internal field names or radians in a message.
fn no_internals(err: &str) {
    for bad in [
        "_rad",
        "rho1",
        "rho2",
        "m_n_mm",
        "alpha_n",
        "beta_deg",
        "z_v01",
        "k_zv1",
        "cone_range",
        "0.99999999",
        "0000000001",
        ".tmp",
    ] {
        assert!(!err.contains(bad), "{bad:?} in {err}");
    }
}

#[test]
fn dress_report_unwritable_prints_nothing_and_names_the_report() {
    for extra in [&[][..], &["--json"][..]] {
        let mut args = vec!["dress", "design", Z5, "--report", "/nonexistent/x.html"];
        args.extend_from_slice(extra);
        let out = gearcomp(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            out.stdout.is_empty(),
            "{}",
            String::from_utf8_lossy(&out.stdout)
        );
        assert!(
            err.contains("writing report /nonexistent/x.html: "),
            "{err}"
        );
        assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
        assert!(!err.contains("at path") && !err.contains(".tmp"), "{err}");
    }
    // the same for `grind`: the OS reason once, no temporary file name
    let err = refused(&["grind", "simulate", "--report", "/nonexistent/x.html"]);
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
    assert!(!err.contains("at path"), "{err}");
}

const EQUALISE: &str = "[gear]\nteeth=31\nmodule_mm=3.0\npressure_angle_deg=25.0\n\
    pressure_angle_left_deg=20.0\nhelix_angle_deg=15.0\ncone_angle_deg=0.0\n\
    [worm]\nstarts=1\nradius_mm=130.0\nhand=\"right\"\ncone_angle_deg=0.0\n\
    [equalise]\ngear_rho_right_deg=45.0\ngear_rho_left_deg=-45.0\nworm_rho_right_deg=20.0\n\
    worm_rho_left_deg=-20.0\ncone_min_deg=-15.0\ncone_max_deg=15.0\n";

#[test]
fn equalise_errors_name_the_key_written() {
    let ok = write_config("input-errors", "eq", "ok.toml", EQUALISE);
    accepted(&["grind", "equalise", ok.to_str().unwrap()]);
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "gear_rho_right_deg=45.0",
            "gear_rho_right_deg=1000.0",
            &["[equalise] gear_rho_right_deg = 1000 ", "-180 ..= 180 °"],
        ),
        (
            "gear_rho_right_deg=45.0",
            "gear_rho_right_deg=nan",
            &["[equalise] gear_rho_right_deg = NaN ", "-180 ..= 180 °"],
        ),
        (
            "worm_rho_right_deg=20.0",
            "worm_rho_right_deg=500",
            &["[equalise] worm_rho_right_deg = 500 ", "-180 ..= 180 °"],
        ),
        (
            "module_mm=3.0",
            "module_mm=0",
            &["[gear] module_mm = 0 ", "0.01 ..= 1000 mm"],
        ),
        (
            "pressure_angle_deg=25.0",
            "pressure_angle_deg=50",
            &["[gear] pressure_angle_deg = 50 ", "32.1419 °"],
        ),
        (
            "helix_angle_deg=15.0",
            "helix_angle_deg=70",
            &["[gear] helix_angle_deg = 70 ", "below 60 °"],
        ),
        (
            "cone_min_deg=-15.0",
            "cone_min_deg=20.0",
            &[
                "[equalise] cone_min_deg = 20 ",
                "below [equalise] cone_max_deg = 15 °",
            ],
        ),
        (
            "helix_angle_deg=15.0\ncone_angle_deg=0.0",
            "helix_angle_deg=15.0\ncone_angle_deg=60",
            &["[gear] cone_angle_deg = 60 ", "-50 ..= 50 °"],
        ),
        (
            "hand=\"right\"\ncone_angle_deg=0.0",
            "hand=\"right\"\ncone_angle_deg=60",
            &["[worm] cone_angle_deg = 60 ", "-50 ..= 50 °"],
        ),
    ];
    for (i, (from, to, wanted)) in cases.iter().enumerate() {
        let text = EQUALISE.replacen(from, to, 1);
        assert_ne!(text, EQUALISE, "{from}");
        let p = write_config("input-errors", "eq", &format!("bad{i}.toml"), &text);
        let err = refused(&["grind", "equalise", p.to_str().unwrap()]);
        for w in *wanted {
            assert!(err.contains(w), "{w:?} not in {err}");
        }
        no_internals(&err);
        assert!(!err.contains("[worm] cone_angle_deg: "), "{err}");
    }
}

/// One range per quantity: the refusal states it, the boundary it states is accepted and
/// just beyond it is refused, on both sides.
#[test]
fn grind_gear_ranges_agree_with_what_is_accepted() {
    let sim = |opt: &str, v: &str| {
        vec![
            "grind".to_string(),
            "simulate".to_string(),
            format!("{opt}={v}"),
        ]
    };
    let run = |opt: &str, v: &str| {
        let a = sim(opt, v);
        gearcomp(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let check = |opt: &str, ok: &[&str], bad: &[&str], range: &str| {
        for v in ok {
            let out = run(opt, v);
            assert!(
                out.status.success(),
                "{opt} {v}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        for v in bad {
            let out = run(opt, v);
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{opt} {v}: {err}");
            assert!(
                err.contains(&format!("{opt} = {v} is out of range: expected {range}")),
                "{err}"
            );
            no_internals(&err);
        }
    };
    check(
        "--teeth",
        &["10000"],
        &["0", "1", "2", "10001", "100000"],
        "3 ..= 10000",
    );
    let alpha = "above 0 and at most 32.1419 °";
    check(
        "--pressure-angle-deg",
        &["32.1419"],
        &["0", "32.142", "45", "60"],
        alpha,
    );
    check(
        "--pressure-angle-left-deg",
        &["32.1419"],
        &["32.142"],
        alpha,
    );
    let beta = "above -60 and below 60 °";
    check(
        "--helix-angle-deg",
        &["59.99", "-59.99"],
        &["60", "-60", "75", "89", "90"],
        beta,
    );
}

#[test]
fn grind_options_named_in_derived_errors() {
    let err = refused(&["grind", "simulate", "--module-mm", "0.01"]);
    assert!(
        err.contains("--module-mm = 0.01")
            && err.contains("--worm-radius-mm 130")
            && err.contains("lead angle")
            && err.contains("0.136135675435 ..< 234 mm"),
        "{err}"
    );
    no_internals(&err);
    let err = refused(&["grind", "simulate", "--module-mm", "200"]);
    assert!(
        err.contains("default worm radii for --module-mm 200") && err.contains("--worm-radius-mm"),
        "{err}"
    );
    for (args, opt) in [
        (
            &["grind", "simulate", "--shift-offset-mm=nan"][..],
            "--shift-offset-mm = NaN",
        ),
        (
            &["grind", "simulate", "--diagonal-ratio=nan"][..],
            "--diagonal-ratio = NaN",
        ),
        (
            &[
                "grind",
                "solve",
                "--gear-rho-deg=30",
                "--gear-c=1",
                "--shift-offset-mm=nan",
            ][..],
            "--shift-offset-mm = NaN",
        ),
    ] {
        let err = refused(args);
        assert!(
            err.contains(opt) && err.contains("-1000000 ..= 1000000"),
            "{err}"
        );
        no_internals(&err);
    }
}

#[test]
fn dress_ranges_print_rounded() {
    let text = std::fs::read_to_string(Z5).unwrap() + "clearance_mm = 1.0\n";
    let p = write_config("input-errors", "clearance", "c.toml", &text);
    let err = refused(&["dress", "design", p.to_str().unwrap()]);
    assert!(
        err.contains("[dresser] clearance_mm = 1 mm is outside the allowed range 0 ..= 0.6 mm"),
        "{err}"
    );
}
