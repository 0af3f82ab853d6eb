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

/// The modification polynomials (--worm-c/-l/-q, --gear-c/-l/-q) are checked in the options'
/// own unit, µm·mm⁻ᵏ, naming the option and the coefficient: the library's limit is 1e12 mm,
/// which `--worm-c=1e300` reported in mm without the option before. 16 coefficients pass,
/// a 17th is refused.
#[test]
fn grind_polynomial_options_named_in_their_unit() {
    let range = "is out of range: expected finite coefficients of magnitude ≤ 1e15 µm·mm⁻ᵏ";
    for (args, want) in [
        (
            &["grind", "simulate", "--worm-c=1e300"][..],
            "--worm-c = 1e300 (coefficient 1)",
        ),
        (
            &["grind", "simulate", "--worm-l=0,-2e15"][..],
            "--worm-l = -2e15 (coefficient 2)",
        ),
        (
            &["grind", "simulate", "--worm-q=nan"][..],
            "--worm-q = NaN (coefficient 1)",
        ),
        (
            &["grind", "solve", "--gear-rho-deg=30", "--gear-c=1e16"][..],
            "--gear-c = 1e16 (coefficient 1)",
        ),
    ] {
        let err = refused(args);
        assert!(err.contains(&format!("{want} {range}")), "{err}");
        assert!(!err.contains("mm·mm⁻ᵏ (") && !err.contains("F_C"), "{err}");
        no_internals(&err);
    }
    let err = refused(&[
        "grind",
        "simulate",
        &format!("--worm-c={}", ["0"; 17].join(",")),
    ]);
    assert!(
        err.contains("--worm-c: 17 coefficients given: expected at most 16 (degree 15)"),
        "{err}"
    );
    accepted(&[
        "grind",
        "simulate",
        &format!("--worm-c={}", ["0"; 16].join(",")),
    ]);
}

/// The face width's stated range is the one enforced (1e-9 mm passed `0 < b` and then
/// failed in the flank grid with an internal field), and a cone whose narrow end leaves no
/// default roll range says so, naming --gear-cone-deg and the largest --face-width-mm that
/// keeps one: that width is accepted, 1 % more is refused.
#[test]
fn grind_face_width_and_narrow_end_limits_are_the_enforced_ones() {
    for b in ["1e-9", "0", "-1", "2000.5", "nan"] {
        let err = refused(&["grind", "simulate", &format!("--face-width-mm={b}")]);
        assert!(
            err.contains("is out of range: expected 0.001 ..= 2000 mm")
                && err.contains("--face-width-mm = "),
            "{err}"
        );
        no_internals(&err);
    }
    accepted(&["grind", "simulate", "--face-width-mm=0.001"]);
    let err = refused(&["grind", "simulate", "--gear-cone-deg", "30"]);
    assert!(
        err.contains("at --gear-cone-deg 30 the tip circle of the narrow end")
            && err.contains("--face-width-mm 30")
            && err.contains("give --face-width-mm below "),
        "{err}"
    );
    assert!(!err.contains("w_end"), "{err}");
    let b: f64 = err
        .split("give --face-width-mm below ")
        .nth(1)
        .and_then(|r| r.split(" mm").next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(b > 0.0 && b < 30.0, "{b}");
    let at = |b: f64| {
        gearcomp(&[
            "grind",
            "simulate",
            "--gear-cone-deg",
            "30",
            "--face-width-mm",
            &b.to_string(),
        ])
    };
    let ok = at(b);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let out = at(1.01 * b);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("give --face-width-mm below "), "{err}");
    // Both ends given in the wrong order: named as such.
    let err = refused(&[
        "grind",
        "simulate",
        "--roll-start-mm",
        "20",
        "--roll-end-mm",
        "20",
    ]);
    assert!(
        err.contains("--roll-start-mm = 20 mm must be below --roll-end-mm = 20 mm"),
        "{err}"
    );
}

/// `grind simulate --dress` with a crowning the worm and dresser cannot carry names the
/// key written and the largest crowning they carry, which is then accepted; a crowning
/// beyond the 3-point targets' ±1000 µm is refused with that range.
#[test]
fn grind_dressed_crowning_names_the_key_and_the_largest_it_carries() {
    let base = std::fs::read_to_string(Z5).unwrap();
    let cfg = |c: &str| {
        write_config(
            "input-errors",
            &format!("crown{c}"),
            "c.toml",
            &format!("{base}\n[dressing]\ncrowning_um = {c}\n"),
        )
    };
    for c in ["10", "-5"] {
        let p = cfg(c);
        let err = refused(&["grind", "simulate", "--dress", p.to_str().unwrap()]);
        let lead = "the largest crowning this worm and dresser carry is crowning_um = ";
        assert!(
            err.contains("not producible ([dressing] crowning_um)") && err.contains(lead),
            "{err}"
        );
        let most: f64 = err
            .split(lead)
            .nth(1)
            .and_then(|r| r.split(" µm").next())
            .unwrap()
            .parse()
            .unwrap();
        let want: f64 = c.parse().unwrap();
        assert!(
            most * want > 0.0 && most.abs() < want.abs(),
            "{most} for {c}"
        );
        let p = cfg(&most.to_string());
        accepted(&["grind", "simulate", "--dress", p.to_str().unwrap()]);
    }
    let p = cfg("1e6");
    let err = refused(&["grind", "simulate", "--dress", p.to_str().unwrap()]);
    assert!(
        err.contains(
            "[dressing] crowning_um = 1000000 µm is out of range: expected -1000 ..= 1000 µm"
        ),
        "{err}"
    );
}
