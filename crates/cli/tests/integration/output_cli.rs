//! Every command's output, whatever it is written to: a closed pipe ends the program quietly,
//! a report path that is a symbolic link or a FIFO is written through (the link stays a link,
//! the FIFO stays a FIFO, `/dev/null` stays a device), and a negative value is accepted as the
//! word after its option (`--helix -30`) as well as glued on (`--helix=-30`).

use crate::common::{gearcomp, gearcomp_cmd, temp_dir};
use std::process::Stdio;

/// A small, fast `grind simulate` (default gear and worm, coarse grid).
const GRIND_SMALL: [&str; 6] = ["grind", "simulate", "--grid-w", "3", "--grid-z", "3"];

/// Runs `args` with stdout a pipe whose reader is closed before the program writes.
fn run_into_closed_pipe(args: &[&str]) -> std::process::Output {
    let mut child = gearcomp_cmd()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    child.wait_with_output().unwrap()
}

#[test]
fn closed_pipe_ends_quietly_for_print_and_write_paths() {
    // `grind simulate --json` prints with println!, `gear --json` writes with write!: both
    // must end with exit 0 and nothing on stderr (no "panicked", no "Broken pipe").
    let mut grind_json: Vec<&str> = GRIND_SMALL.to_vec();
    grind_json.push("--json");
    for args in [
        grind_json,
        GRIND_SMALL.to_vec(),
        vec!["gear", "--module", "2", "--teeth", "40", "--json"],
        vec!["gear", "--module", "2", "--teeth", "40"],
    ] {
        let out = run_into_closed_pipe(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {:?} {stderr}", out.status);
        assert!(stderr.is_empty(), "{args:?}: {stderr}");
    }
}

#[test]
fn an_open_pipe_still_gets_the_whole_output() {
    // The hook only ends quietly on a closed stdout; a normal run with an open pipe must
    // still print everything (the hook must not cut output short).
    let out = gearcomp(&["gear", "--module", "2", "--teeth", "40", "--json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v.is_object());
}

#[test]
fn negative_values_as_the_next_word() {
    // A single number: --helix -30 is --helix=-30.
    let spaced = gearcomp(&[
        "gear", "--module", "2", "--teeth", "40", "--helix", "-30", "--json",
    ]);
    let glued = gearcomp(&[
        "gear",
        "--module",
        "2",
        "--teeth",
        "40",
        "--helix=-30",
        "--json",
    ]);
    assert!(
        spaced.status.success(),
        "{}",
        String::from_utf8_lossy(&spaced.stderr)
    );
    assert_eq!(spaced.stdout, glued.stdout);
    // The left hand really reached the geometry: it differs from the right-hand gear.
    let right = gearcomp(&[
        "gear", "--module", "2", "--teeth", "40", "--helix", "30", "--json",
    ]);
    assert_ne!(spaced.stdout, right.stdout);

    // A comma-separated list starting with a negative number.
    let mut spaced_list: Vec<&str> = GRIND_SMALL.to_vec();
    spaced_list.extend(["--worm-l", "-0.01,0.002", "--json"]);
    let mut glued_list: Vec<&str> = GRIND_SMALL.to_vec();
    glued_list.extend(["--worm-l=-0.01,0.002", "--json"]);
    let a = gearcomp(&spaced_list);
    let b = gearcomp(&glued_list);
    assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
    assert_eq!(a.stdout, b.stdout);

    // A list option with its value missing names the option, not some later one.
    let mut missing: Vec<&str> = GRIND_SMALL.to_vec();
    missing.extend(["--worm-l", "--json"]);
    let m = gearcomp(&missing);
    assert!(!m.status.success());
    let err = String::from_utf8_lossy(&m.stderr);
    assert!(err.contains("--worm-l"), "{err}");
}

#[test]
fn report_through_a_symlink_keeps_the_link() {
    let dir = temp_dir("output", "symlink");
    let target = dir.join("real-report.html");
    std::fs::write(&target, "old").unwrap();
    let link = dir.join("report.html");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let mut args: Vec<&str> = GRIND_SMALL.to_vec();
    let link_s = link.to_str().unwrap().to_owned();
    args.extend(["--report", &link_s]);
    let out = gearcomp(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let html = std::fs::read_to_string(&target).unwrap();
    assert!(
        html.contains("<html") || html.contains("<!DOCTYPE"),
        "{}",
        &html[..html.len().min(80)]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn report_into_a_fifo_and_dev_null_stays_what_it_was() {
    use std::os::unix::fs::FileTypeExt;
    let dir = temp_dir("output", "fifo");
    let fifo = dir.join("report.fifo");
    assert!(std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let reader_path = fifo.clone();
    let reader = std::thread::spawn(move || std::fs::read_to_string(&reader_path).unwrap());
    let mut args: Vec<&str> = GRIND_SMALL.to_vec();
    let fifo_s = fifo.to_str().unwrap().to_owned();
    args.extend(["--report", &fifo_s]);
    let out = gearcomp(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = reader.join().unwrap();
    assert!(html.len() > 100, "{}", html.len());
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());

    // /dev/null as the report: still the character device afterwards.
    let mut args: Vec<&str> = GRIND_SMALL.to_vec();
    args.extend(["--report", "/dev/null"]);
    let out = gearcomp(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());
    std::fs::remove_dir_all(&dir).unwrap();
}
