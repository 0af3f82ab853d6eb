//! Defects found by fuzzing `gearcomp replay` with random logs (gaps, NaN cells, restarts,
//! repeated time stamps) and random configurations (session 10):
//!
//! 1. a row whose time does not increase (a restart of the logger's clock, a repeated stamp)
//!    is a cycle the engine ignores, yet its cells replaced the held readings: an empty cell
//!    in the next good row then re-fed a reading stamped before the last accepted one (an
//!    `OutOfOrder` fault and a frozen axis on a good row), or, for a repeated stamp, the
//!    ignored row's value entered the law;
//! 2. two axes of one name were accepted (two identical `X_offset_um` output columns, an
//!    ambiguous `position_X_mm`);
//! 3. a channel named like a column of the log format (`time_s`, `trigger`, `safe_point`,
//!    `ack_stop`, `position_<axis>_mm`) silently read that column (the time as a temperature).

use gearcomp_thermal::replay::replay_csv;
use gearcomp_thermal::{AxisStatus, Engine, EngineConfig};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn channel(name: &str) -> String {
    format!(
        "[[channels]]\nname = \"{name}\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -50.0\n\
         valid_max = 150.0\nstale_timeout_s = 1e6\n"
    )
}

/// Cz = kd·A + alpha + kz·(A − B), no averaging, dead band or rate limit.
fn config(kd: f64, alpha: f64, kz: f64) -> String {
    format!(
        "{}{}[[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 1e5\n\
         [[axes.terms]]\nkind = \"linear\"\nchannel = \"A\"\nkd_um_per_c = {kd:?}\nalpha_um = {alpha:?}\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = {kz:?}\n",
        channel("A"),
        channel("B")
    )
}

fn engine(text: &str) -> Engine {
    Engine::new(&EngineConfig::from_toml_str(text).unwrap()).unwrap()
}

/// By hand, Cz = 2·A: 10 s A = 20 → 40 µm; 20 s A = 21 → 42; 15 s (clock restart, ignored);
/// 30 s A empty → holds 21 → 42, no alarm; 20 s A = 25 (repeated stamp, ignored); 40 s A
/// empty → still 21 → 42; 50 s A = 22 → 44.
#[test]
fn an_ignored_row_does_not_replace_the_held_readings() {
    let mut e = engine(&config(2.0, 0.0, 0.0));
    let log = "time_s,A,B\n10,20,0\n20,21,\n15,30,\n30,,\n30,25,\n40,,\n50,22,\n";
    let r = replay_csv(&mut e, log).unwrap();
    assert!(r.bad_rows.is_empty(), "{:?}", r.bad_rows);
    let got: Vec<(f64, AxisStatus, bool)> = r
        .rows
        .iter()
        .map(|row| (row.offset_um[0], row.axis_status[0], row.alarm.is_empty()))
        .collect();
    let want = [40.0, 42.0, 42.0, 42.0, 42.0, 42.0, 44.0];
    for (k, ((off, _, _), w)) in got.iter().zip(want).enumerate() {
        assert!((off - w).abs() < 1e-12, "row {k}: {got:?}");
    }
    // The ignored rows carry the time alarm; the good rows after them none.
    for k in [2, 4] {
        assert!(r.rows[k].alarm.contains("not after"), "{:?}", r.rows[k]);
    }
    for k in [3, 5, 6] {
        assert!(got[k].2, "row {k}: {:?}", r.rows[k]);
        assert_ne!(got[k].1, AxisStatus::Frozen, "row {k}: {:?}", r.rows[k]);
    }
}

/// One generated log row: time step (negative or zero = restart / repeated stamp) and the
/// cells of A and B (None = empty, Some(NaN) = "nan").
type Row = (f64, Option<f64>, Option<f64>);

fn row() -> impl Strategy<Value = Row> {
    let cell = prop_oneof![
        8 => (10.0..40.0f64).prop_map(Some),
        1 => Just(None),
        1 => Just(Some(f64::NAN)),
    ];
    let dt = prop_oneof![8 => 0.5..100.0f64, 1 => Just(0.0), 1 => -50.0..0.0f64];
    (dt, cell.clone(), cell)
}

/// The replay semantics written out independently: an accepted row (time after the last
/// accepted one) updates the held value of each non-empty cell; the law needs both channels
/// held; a held NaN freezes the axis at its last offset; an ignored row leaves everything.
fn expected(rows: &[(f64, Option<f64>, Option<f64>)], kd: f64, alpha: f64, kz: f64) -> Vec<f64> {
    let (mut a, mut b): (Option<f64>, Option<f64>) = (None, None);
    let mut last_t = f64::NEG_INFINITY;
    let mut offset = 0.0;
    let mut out = Vec::new();
    for &(t, ca, cb) in rows {
        if t > last_t {
            last_t = t;
            a = ca.or(a);
            b = cb.or(b);
            if let (Some(va), Some(vb)) = (a, b) {
                if va.is_finite() && vb.is_finite() {
                    offset = kd * va + alpha + kz * (va - vb);
                }
            }
        }
        out.push(offset);
    }
    out
}

/// Random logs with gaps, NaN cells, clock restarts and repeated stamps: every row's offset
/// equals the law evaluated by [`expected`] (fixed seed + fresh cases).
#[test]
fn offsets_follow_the_held_readings_over_random_logs() {
    let strat = (
        -5.0..5.0f64,
        -50.0..50.0f64,
        -5.0..5.0f64,
        prop::collection::vec(row(), 1..120),
    );
    let prop = |(kd, alpha, kz, steps): (f64, f64, f64, Vec<Row>)| {
        let mut t = 100.0;
        let mut rows = Vec::new();
        let mut log = String::from("time_s,A,B\n");
        let cell = |c: Option<f64>| c.map_or(String::new(), |v| format!("{v:?}"));
        for (dt, ca, cb) in steps {
            t += dt;
            rows.push((t, ca, cb));
            log.push_str(&format!("{t:?},{},{}\n", cell(ca), cell(cb)));
        }
        let mut e = engine(&config(kd, alpha, kz));
        let r = replay_csv(&mut e, &log).unwrap();
        let want = expected(&rows, kd, alpha, kz);
        prop_assert_eq!(r.rows.len(), want.len());
        for (k, (row, w)) in r.rows.iter().zip(&want).enumerate() {
            prop_assert!(
                (row.offset_um[0] - w).abs() <= 1e-9 * (1.0 + w.abs()),
                "row {}: {} vs {} ({:?})\n{}",
                k,
                row.offset_um[0],
                w,
                row,
                log
            );
        }
        Ok(())
    };
    let cfg = Config {
        cases: 96,
        failure_persistence: None,
        ..Config::default()
    };
    let mut fixed = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[10; 32]),
    );
    fixed.run(&strat, prop).unwrap();
    TestRunner::new(cfg).run(&strat, prop).unwrap();
}

#[test]
fn two_axes_of_one_name_are_refused() {
    let axis = "[[axes]]\nname = \"X\"\napply = { kind = \"command\" }\nmax_offset_um = 10.0\n\
                [[axes.terms]]\nkind = \"linear\"\nchannel = \"A\"\nkd_um_per_c = 1.0\n";
    let text = format!("{}{axis}{axis}", channel("A"));
    let e = Engine::new(&EngineConfig::from_toml_str(&text).unwrap())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("axes[1].name") && e.contains("\"X\"") && e.contains("another axis"),
        "{e}"
    );
}

#[test]
fn a_channel_named_like_a_log_column_is_refused() {
    for name in [
        "time_s",
        "trigger",
        "safe_point",
        "ack_stop",
        "position_X_mm",
    ] {
        let text = format!(
            "{}[[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 10.0\n\
             [[axes.terms]]\nkind = \"linear\"\nchannel = \"{name}\"\nkd_um_per_c = 1.0\n",
            channel(name)
        );
        let mut e = engine(&text);
        let log = format!("time_s,{name}\n1,20\n2,21\n");
        let err = replay_csv(&mut e, &log).err().unwrap().to_string();
        assert!(
            err.contains("channels[0].name") && err.contains(&format!("\"{name}\"")),
            "{name}: {err}"
        );
    }
}

/// 4. A long value in the configuration (a 5000-character sensor kind, channel name or
///    key) came back whole, several times, in the TOML error (30 488 characters for a
///    5000-character kind through `gearcomp replay`): the message now keeps the value's
///    start and says its length, whatever the value's characters.
#[test]
fn a_long_configuration_value_is_shown_by_its_start_and_length() {
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]);
    let mut runner = TestRunner::new_with_rng(Config::with_cases(24), rng);
    let long = proptest::string::string_regex("[a-zA-Zµ0-9 _\"\\\\-]{300,3000}").unwrap();
    runner
        .run(&(long, 0usize..3), |(v, place)| {
            let esc = v.replace('\\', "\\\\").replace('"', "\\\"");
            let text = match place {
                0 => format!(
                    "[[channels]]\nname = \"A\"\nsensor = {{ kind = \"{esc}\" }}\nvalid_min = 0.0\nvalid_max = 1.0\nstale_timeout_s = 1.0\n"
                ),
                1 => format!("[[channels]]\nname = \"A\"\n{}\n", "k".repeat(v.len())),
                _ => format!("[[axes]]\nname = \"X\"\napply = {{ kind = \"{esc}\" }}\n"),
            };
            let e = EngineConfig::from_toml_str(&text).unwrap_err().to_string();
            prop_assert!(e.chars().count() < 1500, "{} characters", e.chars().count());
            prop_assert!(e.contains("characters)"), "{e}");
            Ok(())
        })
        .unwrap();
}
