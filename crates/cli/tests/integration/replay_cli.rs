//! `gearcomp replay` on the real FL_THERMAL log (embedded in gearcomp-datasets) and on a
//! log with bad rows.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::PathBuf;
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gearcomp-replay-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn channels(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("[[channels]]\nname = \"{n}\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 60.0\n"))
        .collect()
}

/// `gearcomp replay` of the configuration `cfg` (written to `dir`) on a one-row log:
/// asserts the exit code of a refused input (2) and returns what it printed on stderr.
fn refused_config(dir: &std::path::Path, cfg: &str) -> String {
    std::fs::write(dir.join("cfg.toml"), cfg).unwrap();
    std::fs::write(dir.join("log.csv"), "time_s,A\n0,1\n").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .current_dir(dir)
        .args(["replay", "--config", "cfg.toml", "--data", "log.csv"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The FL_THERMAL log (11 115 rows, 16 temperatures) through Cz = −1.2·t3 + 30 +
/// 0.8·(t5 − t9) with no averaging, dead band or rate limit: every row's offset must equal
/// the law evaluated independently here from the CSV text.
#[test]
fn replay_fl_thermal_matches_independent_evaluation() {
    let dir = tmp("fl");
    let csv_text = gearcomp_datasets::fl_thermal_csv();
    let data = dir.join("fl_thermal.csv");
    std::fs::write(&data, csv_text).unwrap();
    let names: Vec<String> = (1..=16).map(|i| format!("t{i}_c")).collect();
    let cfg = format!(
        "{}[[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 200.0\n\
         [[axes.terms]]\nkind = \"linear\"\nchannel = \"t3_c\"\nkd_um_per_c = -1.2\nalpha_um = 30.0\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"t5_c\"\nb = \"t9_c\"\nkz_um_per_c = 0.8\n",
        channels(&names)
    );
    let cfg_path = dir.join("cfg.toml");
    std::fs::write(&cfg_path, cfg).unwrap();
    let out = dir.join("offsets.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .args(["replay", "--config"])
        .arg(&cfg_path)
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("11115 rows, 0 bad rows"), "{stderr}");

    let mut lines = csv_text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let idx = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (i3, i5, i9) = (idx("t3_c"), idx("t5_c"), idx("t9_c"));
    let expected: Vec<f64> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.trim().parse().unwrap()).collect();
            -1.2 * f[i3] + 30.0 + 0.8 * (f[i5] - f[i9])
        })
        .collect();
    let written = std::fs::read_to_string(&out).unwrap();
    let mut rows = written.lines();
    assert!(rows
        .next()
        .unwrap()
        .starts_with("line,time_s,X_offset_um,X_target_um,X_pulses,X_status,status,alarm,stop"));
    let got: Vec<f64> = rows
        .map(|r| r.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    assert_eq!(got.len(), 11_115);
    for (k, (g, e)) in got.iter().zip(&expected).enumerate() {
        // Offsets are written with 4 decimals.
        assert!((g - e).abs() <= 5.1e-5, "row {k}: {g} vs {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Bad rows are reported with their line numbers: a non-number is fed as NaN (the engine
/// raises its alarm and holds the offset), a row with the wrong field count is skipped.
#[test]
fn replay_reports_bad_rows_with_line_numbers() {
    let dir = tmp("bad");
    let cfg = format!(
        "{}[[axes]]\nname = \"Z\"\napply = {{ kind = \"measuring_system\" }}\nmax_offset_um = 100.0\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = -3.75\n",
        channels(&["A".into(), "B".into()])
    );
    std::fs::write(dir.join("cfg.toml"), cfg).unwrap();
    let log = "time_s,A,B\n0,24,20\n1,24,20\n2,abc,20\n3,24\n4,25,20\n";
    std::fs::write(dir.join("log.csv"), log).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .current_dir(&dir)
        .args(["replay", "--config", "cfg.toml", "--data", "log.csv"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("log.csv:4: column A: \"abc\" is not a number"),
        "{stderr}"
    );
    assert!(
        stderr.contains("log.csv:5: 2 fields, the header has 3"),
        "{stderr}"
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    let rows: Vec<&str> = stdout.lines().skip(1).collect();
    assert_eq!(rows.len(), 4, "{stdout}");
    assert!(rows[0].starts_with("2,0,-15.0000,"), "{}", rows[0]);
    assert!(
        rows[2].starts_with("4,2,-15.0000,")
            && rows[2].contains("Frozen")
            && rows[2].contains("NotANumber"),
        "{}",
        rows[2]
    );
    assert!(rows[3].starts_with("6,4,-18.7500,"), "{}", rows[3]);
    // The same log with Excel's byte-order mark, in UTF-16 (Excel's "Unicode text") and in
    // Windows-1252: the same offsets, the same lines.
    let bom = [&[0xEF, 0xBB, 0xBF][..], log.as_bytes()].concat();
    let utf16: Vec<u8> = [0xFF, 0xFE]
        .into_iter()
        .chain(log.encode_utf16().flat_map(u16::to_le_bytes))
        .collect();
    let cp1252 = log
        .replace("abc", "ab\u{b0}")
        .chars()
        .map(|c| c as u8)
        .collect::<Vec<u8>>();
    for (bytes, note) in [
        (bom, None),
        (utf16, Some("UTF-16LE")),
        (cp1252, Some("windows-1252")),
    ] {
        std::fs::write(dir.join("log.csv"), &bytes).unwrap();
        let o2 = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
            .current_dir(&dir)
            .args(["replay", "--config", "cfg.toml", "--data", "log.csv"])
            .output()
            .unwrap();
        assert_eq!(String::from_utf8_lossy(&o2.stdout), stdout);
        let err = String::from_utf8_lossy(&o2.stderr);
        assert_eq!(
            note.map(|n| err.contains(&format!("log.csv: not UTF-8, read as {n}"))),
            note.map(|_| true),
            "{err}"
        );
    }
    // --strict turns the report into a failure, before anything is written: no offsets on
    // stdout, no --out file, and an existing one left as it was.
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .current_dir(&dir)
        .args([
            "replay", "--config", "cfg.toml", "--data", "log.csv", "--strict",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--strict") && err.contains("nothing written"),
        "{err}"
    );
    for before in [None, Some("kept\n")] {
        let out = dir.join("offsets.csv");
        std::fs::remove_file(&out).ok();
        if let Some(b) = before {
            std::fs::write(&out, b).unwrap();
        }
        let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
            .current_dir(&dir)
            .args([
                "replay",
                "--config",
                "cfg.toml",
                "--data",
                "log.csv",
                "--strict",
                "--out",
                "offsets.csv",
            ])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2));
        assert_eq!(std::fs::read_to_string(&out).ok().as_deref(), before);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn replay_config_errors_name_field_value_and_range() {
    let dir = tmp("cfgerr");
    let cfg = "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\nvalid_min = 50.0\nvalid_max = 10.0\nstale_timeout_s = 1.0\n\
               [[axes]]\nname = \"Z\"\napply = { kind = \"command\" }\nmax_offset_um = 10.0\n[[axes.terms]]\nkind = \"linear\"\nchannel = \"A\"\nkd_um_per_c = 1.0\n";
    let stderr = refused_config(&dir, cfg);
    assert!(
        stderr.contains("channels[0].valid_max = 10") && stderr.contains("> valid_min = 50"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A 5000-character sensor kind: the whole printed error (with its causes) shows the value
/// by its start and length, in a few hundred characters (it printed 30 491 characters: the
/// TOML error repeats the value, and its source printed it again).
#[test]
fn replay_shortens_a_long_configuration_value() {
    let dir = tmp("longval");
    let kind = "q".repeat(5000);
    let cfg = format!(
        "[[channels]]\nname = \"A\"\nsensor = {{ kind = \"{kind}\" }}\nvalid_min = 0.0\nvalid_max = 1.0\nstale_timeout_s = 1.0\n"
    );
    let stderr = refused_config(&dir, &cfg);
    assert!(
        stderr.chars().count() < 1500
            && stderr.contains("(5000 characters)")
            && stderr.contains("celsius"),
        "{} characters: {stderr}",
        stderr.chars().count()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 12 item 4 through the command: a model file with a training envelope (t3_c and
/// t5_c ranges over FL_THERMAL's first 24 h, computed here from the CSV) replayed over the
/// whole log: `gearcomp replay` writes the warning, naming the channel, its value and the
/// range in °C, on the 5000 rpm period (24 h … 28 h) and on no training row; the offsets
/// go on (no alarm status, the law's value on every row).
#[test]
fn replay_warns_when_a_model_leaves_its_training_envelope() {
    let dir = tmp("envelope");
    let csv_text = gearcomp_datasets::fl_thermal_csv();
    let data = dir.join("fl_thermal.csv");
    std::fs::write(&data, csv_text).unwrap();
    let mut lines = csv_text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let idx = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (it, i3, i5) = (idx("time_s"), idx("t3_c"), idx("t5_c"));
    let rows: Vec<Vec<f64>> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').map(|x| x.trim().parse().unwrap()).collect())
        .collect();
    let range = |c: usize| {
        rows.iter()
            .filter(|r| r[it] < 86_400.0)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
                (a.min(r[c]), b.max(r[c]))
            })
    };
    let ((lo3, hi3), (lo5, hi5)) = (range(i3), range(i5));
    let model = format!(
        "format = \"gearcomp-thermal-model/1\"\nname = \"fl\"\n[[axes]]\naxis = \"X\"\n\
         [axes.machine]\nintercept = 30.0\n\
         [[axes.machine.terms]]\nchannel = \"t3_c\"\ncoefficient = -1.2\n\
         [[axes.machine.terms]]\nchannel = \"t5_c\"\ncoefficient = 0.8\n\
         [[envelopes]]\naxis = \"X\"\nrows = 5760\nranges = [\n\
         {{ channel = \"t3_c\", min = {lo3:?}, max = {hi3:?} }},\n\
         {{ channel = \"t5_c\", min = {lo5:?}, max = {hi5:?} }},\n]\n"
    );
    std::fs::write(dir.join("model.toml"), model).unwrap();
    let names: Vec<String> = (1..=16).map(|i| format!("t{i}_c")).collect();
    let cfg = format!(
        "{}[[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 200.0\n\
         [[axes.terms]]\nkind = \"model\"\nfile = \"model.toml\"\naxis = \"X\"\n",
        channels(&names)
    );
    let cfg_path = dir.join("cfg.toml");
    std::fs::write(&cfg_path, cfg).unwrap();
    let out = dir.join("offsets.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .args(["replay", "--config"])
        .arg(&cfg_path)
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let written = std::fs::read_to_string(&out).unwrap();
    let mut rdr = csv_reader(&written);
    let head: Vec<String> = rdr.next().unwrap();
    let col = |n: &str| head.iter().position(|h| h == n).unwrap();
    let (cw, cs, co) = (col("warning"), col("status"), col("X_offset_um"));
    let (mut train_warn, mut hot, mut hot_warn, mut all_warn) = (0, 0, 0, 0);
    let mut example = String::new();
    for (rec, src) in rdr.zip(&rows) {
        let h = src[it] / 3600.0;
        let w = &rec[cw];
        assert_eq!(rec[cs], "Running", "{rec:?}");
        let law = 30.0 - 1.2 * src[i3] + 0.8 * src[i5];
        let got: f64 = rec[co].parse().unwrap();
        assert!((got - law).abs() <= 5.1e-5, "{got} vs {law}");
        all_warn += usize::from(!w.is_empty());
        if h < 24.0 {
            train_warn += usize::from(!w.is_empty());
        } else if h < 28.0 {
            hot += 1;
            hot_warn += usize::from(!w.is_empty());
            if example.is_empty() && !w.is_empty() {
                example = w.clone();
            }
        }
    }
    assert_eq!(train_warn, 0);
    assert!(hot_warn * 2 > hot, "{hot_warn}/{hot}");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(&format!(
            "0 rows with alarms, 0 with a stop request, {all_warn} with a warning"
        )),
        "{stderr}"
    );
    // The message names the axis, the channel, its value and the training range in °C.
    assert!(
        example.starts_with("axis X: warning, model extrapolating")
            && example.contains("outside its training range")
            && example.contains("°C"),
        "{example}"
    );
    let named = example.contains("channel t3_c = ")
        && example.contains(&format!("{lo3:.3} … {hi3:.3} °C"))
        || example.contains("channel t5_c = ")
            && example.contains(&format!("{lo5:.3} … {hi5:.3} °C"));
    println!("envelope warning on {hot_warn} of {hot} rows of 24 h … 28 h: {example}");
    assert!(named, "{example}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The records of a CSV text (quoted fields with commas read whole).
fn csv_reader(text: &str) -> impl Iterator<Item = Vec<String>> + '_ {
    text.lines().map(|l| {
        let mut out = Vec::new();
        let mut cur = String::new();
        let mut quoted = false;
        for ch in l.chars() {
            match ch {
                '"' => quoted = !quoted,
                ',' if !quoted => out.push(std::mem::take(&mut cur)),
                c => cur.push(c),
            }
        }
        out.push(cur);
        out
    })
}

/// The whole chain of issue 12 on FL_THERMAL: `gearcomp fit` (default: every family,
/// training on the first 24 h, envelopes from the identification's QR route, lag terms)
/// writes the model file; `gearcomp replay` runs it for ch1, ch3 and ch5 on the whole log.
/// The engine's own transforms reproduce the training regressors closely enough that no
/// training row warns, and the 5000 rpm period (24 h … 28 h, above the 3750 rpm of
/// training) does. Measured: 0 training rows; 902 of 960 rows of 24 h … 28 h (per axis
/// alone: 865, 902, 878).
#[test]
fn fitted_model_warns_in_the_5000_rpm_period_and_never_on_training_rows() {
    let dir = tmp("fit-envelope");
    let csv_text = gearcomp_datasets::fl_thermal_csv();
    let data = dir.join("fl_thermal.csv");
    std::fs::write(&data, csv_text).unwrap();
    let fit = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .args(["fit", "--target", "ch1_um", "ch3_um", "ch5_um", "--out"])
        .arg(dir.join("model.toml"))
        .output()
        .unwrap();
    assert!(
        fit.status.success(),
        "{}",
        String::from_utf8_lossy(&fit.stderr)
    );
    let model = std::fs::read_to_string(dir.join("model.toml")).unwrap();
    assert_eq!(model.matches("[[envelopes]]").count(), 3, "{model}");
    let names: Vec<String> = (1..=16).map(|i| format!("t{i}_c")).collect();
    let mut cfg = channels(&names);
    for ax in ["ch1_um", "ch3_um", "ch5_um"] {
        cfg += &format!(
            "[[axes]]\nname = \"{ax}\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 500.0\n\
             [[axes.terms]]\nkind = \"model\"\nfile = \"model.toml\"\naxis = \"{ax}\"\n"
        );
    }
    let cfg_path = dir.join("cfg.toml");
    std::fs::write(&cfg_path, cfg).unwrap();
    let out = dir.join("offsets.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .args(["replay", "--config"])
        .arg(&cfg_path)
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let written = std::fs::read_to_string(&out).unwrap();
    let mut rdr = csv_reader(&written);
    let head: Vec<String> = rdr.next().unwrap();
    let col = |n: &str| head.iter().position(|h| h == n).unwrap();
    let (ct, cw, cs) = (col("time_s"), col("warning"), col("status"));
    let (mut train, mut train_warn, mut hot, mut hot_warn) = (0, 0, 0, 0);
    for rec in rdr {
        let h = rec[ct].parse::<f64>().unwrap() / 3600.0;
        let w = !rec[cw].is_empty();
        assert_eq!(rec[cs], "Running", "{rec:?}");
        if h < 24.0 {
            train += 1;
            train_warn += usize::from(w);
        } else if h < 28.0 {
            hot += 1;
            hot_warn += usize::from(w);
        }
    }
    println!("fitted model: warning on {train_warn} of {train} training rows, {hot_warn} of {hot} rows of 24 h … 28 h");
    assert_eq!((train, hot), (5760, 960));
    assert_eq!(train_warn, 0);
    assert!(hot_warn * 100 >= hot * 85, "{hot_warn}/{hot}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A log separated by tabs or `;`, with decimal commas (a spreadsheet's export in a German
/// locale), replays to the same offsets as the comma-separated log with decimal points:
/// random logs (fixed seeds), compared row by row with the plain log's output.
#[test]
fn replay_reads_tab_and_semicolon_logs_with_decimal_commas() {
    let dir = tmp("dialects");
    let cfg = format!(
        "{}[[axes]]\nname = \"Z\"\napply = {{ kind = \"measuring_system\" }}\nmax_offset_um = 100.0\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = -3.75\n",
        channels(&["A".into(), "B".into()])
    );
    std::fs::write(dir.join("cfg.toml"), cfg).unwrap();
    let run = |log: &str| {
        std::fs::write(dir.join("log.csv"), log).unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
            .current_dir(&dir)
            .args(["replay", "--config", "cfg.toml", "--data", "log.csv"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(err.contains(" 0 bad rows"), "{err}");
        String::from_utf8(o.stdout).unwrap()
    };
    for seed in [1u64, 2, 3] {
        // SplitMix64: temperatures 18–30 °C with three decimals, 40 rows a second apart.
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            (z ^ (z >> 31)) as f64 / u64::MAX as f64
        };
        let rows: Vec<(f64, f64, f64)> = (0..40)
            .map(|k| {
                let a = (18.0 + 12.0 * next()) * 1000.0;
                let b = (18.0 + 12.0 * next()) * 1000.0;
                (k as f64 + 0.5, a.round() / 1000.0, b.round() / 1000.0)
            })
            .collect();
        let write = |sep: &str, comma: bool| {
            let mut t = format!("time_s{sep}A{sep}B\n");
            for (time, a, b) in &rows {
                let cells = [time, a, b].map(|v| {
                    let v = v.to_string();
                    if comma {
                        v.replace('.', ",")
                    } else {
                        v
                    }
                });
                t.push_str(&cells.join(sep));
                t.push('\n');
            }
            t
        };
        let plain = run(&write(",", false));
        assert_eq!(plain.lines().count(), 41, "{plain}");
        for (sep, comma) in [("\t", false), ("\t", true), (";", true), (";", false)] {
            assert_eq!(
                run(&write(sep, comma)),
                plain,
                "seed {seed}, {sep:?} comma {comma}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
