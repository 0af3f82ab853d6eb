//! A 5000-character value a user wrote (a TOML string, a CSV cell, a column name) is shown
//! in every command's error by its start and its length, not whole (a TOML parse error
//! repeats the value, and the source line's `^^^` marker is as wide as it): the printed
//! error stays a few lines, and still names what was wrong.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{gearcomp, write_config};

const LONG: usize = 5000;

fn assert_short(o: &std::process::Output, names: &str) {
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    let n = e.chars().count();
    assert!(
        n < 2500
            && e.contains(&format!("({LONG}"))
            && e.contains(" characters)")
            && e.contains(names),
        "{n} characters: {e}"
    );
}

#[test]
fn dress_and_fit_show_a_long_value_by_its_start_and_length() {
    let q = "q".repeat(LONG);
    // dress: a TOML string value of [solve].
    let dress = format!(
        "{}\n[solve]\nflank = \"{q}\"\nmethod = \"three-point\"\n",
        include_str!("../fixtures/worm_z5_dresser.toml")
    );
    let cfg = write_config("long-values", "dress", "dress.toml", &dress);
    assert_short(
        &gearcomp(&["dress", "solve", cfg.to_str().unwrap()]),
        "flank",
    );
    // fit: a CSV cell of an input.
    let mut log = String::from("time_s,a_c,y_um\n");
    for i in 0..30 {
        let a = if i == 7 {
            q.clone()
        } else {
            format!("{}", 20 + i)
        };
        log += &format!("{},{a},{}\n", i * 60, i);
    }
    let data = write_config("long-values", "fit", "log.csv", &log);
    let o = gearcomp(&["fit", "--target", "y_um", "--data", data.to_str().unwrap()]);
    assert_short(&o, "a_c");
    // fit: a column name of 5000 letters among the inputs given.
    let log = format!("time_s,{q},y_um\n0,1,2\n60,2,3\n");
    let data = write_config("long-values", "fit-name", "log.csv", &log);
    let o = gearcomp(&[
        "fit",
        "--target",
        "y_um",
        "--inputs",
        "zz",
        "--data",
        data.to_str().unwrap(),
    ]);
    assert_short(&o, "--inputs");
}
