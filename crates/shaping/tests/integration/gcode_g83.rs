//! G83 parser: accepted programs, errors with line and column, no panic on random input.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use approx::assert_abs_diff_eq;
use gearcomp_shaping::gcode::{parse_program, MachineData};
use gearcomp_shaping::ShapingError;
use proptest::prelude::*;

const PROGRAM: &str = "%\n\
(helical gear, seed 002 example)\n\
N10 G83 T40 L25 Q3 P15 D0 R25 K200 S300 F0.5 U0.02 X6.75 E0.2 B40 ; cut\n\
N20 G80\n\
N30 M30\n\
%\n";

fn parse_err(text: &str) -> (usize, usize, String) {
    match parse_program(text).unwrap_err() {
        ShapingError::Parse {
            line,
            column,
            message,
        } => (line, column, message),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn parses_the_example_program() {
    let p = parse_program(PROGRAM).unwrap();
    assert_eq!(p.cycles.len(), 1);
    let b = &p.cycles[0];
    assert_eq!(b.line, 3);
    let g = b.params;
    assert_eq!(
        (g.workpiece_teeth, g.cutter_teeth, g.internal),
        (40, 25, false)
    );
    assert_abs_diff_eq!(g.helix_deg, 15.0);
    assert_abs_diff_eq!(g.face_width_mm, 40.0);
    assert_abs_diff_eq!(g.lift_off_mm, 0.2);
    let cfg = b.to_simulation(&MachineData::default()).unwrap();
    assert_abs_diff_eq!(
        cfg.interp.cut.beta_rad().to_degrees(),
        15.0,
        epsilon = 1e-12
    );
}

#[test]
fn defaults_left_hand_internal_and_lowercase() {
    let p = parse_program("g83 t80 l25 q3 p-12.5 i1 r25 k200 s300 f.5 b40").unwrap();
    let g = p.cycles[0].params;
    assert!(g.internal);
    assert_abs_diff_eq!(g.helix_deg, -12.5);
    assert_abs_diff_eq!(g.circular_feed_mm, 0.5);
    assert_abs_diff_eq!(g.depth_mm, 6.75); // 2.25·m_n
    assert_abs_diff_eq!(g.radial_feed_mm, 0.0);
}

#[test]
fn errors_point_at_line_and_column() {
    // Missing number after a letter: column of where the number should start.
    let (l, c, m) = parse_err("N10 G83 T40 L25 Q P15");
    assert_eq!((l, c), (1, 19), "{m}");
    assert!(m.contains("number after address 'Q'"), "{m}");
    // Unknown character.
    let (l, c, _) = parse_err("%\nG83 T40 L25 # Q3");
    assert_eq!((l, c), (2, 13));
    // Unclosed comment.
    let (_, c, m) = parse_err("G83 T40 (oops");
    assert_eq!(c, 9);
    assert!(m.contains("not closed"), "{m}");
    // Not a G83 parameter.
    let (_, c, m) = parse_err("G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 B40 Y3");
    assert_eq!(c, 43);
    assert!(m.contains("'Y' is not a G83 parameter"), "{m}");
    // Given twice.
    let (_, c, _) = parse_err("G83 T40 T41 L25 Q3 P15 R25 K200 S300 F0.5 B40");
    assert_eq!(c, 9);
    // Missing required parameters: at the G83 word.
    let (_, c, m) = parse_err("N5 G83 T40 L25");
    assert_eq!(c, 4);
    assert!(m.contains("Q P R K S F B"), "{m}");
    // Teeth must be whole numbers.
    let (_, c, m) = parse_err("G83 T40.5 L25 Q3 P15 R25 K200 S300 F0.5 B40");
    assert_eq!(c, 5);
    assert!(m.contains("whole number"), "{m}");
    // Unsupported G code.
    let (_, c, _) = parse_err("G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 B40\nG01 X5");
    assert_eq!(c, 1);
    // Multi-byte characters count as one column.
    let (_, c, _) = parse_err("(µ) G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 B40 Ä");
    assert_eq!(c, 47);
}

#[test]
fn range_and_feasibility_errors_point_at_the_word() {
    let m = MachineData::default();
    // Rod shorter than 2R: points at K.
    let p = parse_program("G83 T40 L25 Q3 P15 R25 K40 S300 F0.5 B40").unwrap();
    match p.cycles[0].to_simulation(&m).unwrap_err() {
        ShapingError::Parse {
            column, message, ..
        } => {
            assert_eq!(column, 24);
            assert!(
                message.contains("rod length K") && message.contains("40"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
    // Helix angle beyond 45°: points at P.
    let p = parse_program("G83 T40 L25 Q3 P50 R25 K200 S300 F0.5 B40").unwrap();
    match p.cycles[0].to_simulation(&m).unwrap_err() {
        ShapingError::Parse {
            column, message, ..
        } => {
            assert_eq!(column, 16);
            assert!(message.contains("45"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    // Infeasible stroke rate: refused when the block is converted, pointing at S (col 29).
    let p = parse_program("G83 T40 L25 Q3 P15 R25 K200 S1000 F0.5 B40").unwrap();
    match p.cycles[0].to_simulation(&m).unwrap_err() {
        ShapingError::Parse {
            line,
            column,
            message,
        } => {
            assert_eq!((line, column), (1, 29));
            assert!(message.contains("infeasible"), "{message}");
        }
        other => panic!("{other:?}"),
    }
}

proptest! {
    #[test]
    fn parser_never_panics(text in "\\PC{0,80}") {
        let _ = parse_program(&text);
    }

    #[test]
    fn gcode_like_text_never_panics(words in proptest::collection::vec(
        ("[GTLQPDIRKSFUXEBNMYZ( ;]", "[-+]?[0-9]{0,4}(\\.[0-9]{0,3})?"), 0..20)) {
        let text: String = words.iter().map(|(l, n)| format!("{l}{n} ")).collect();
        if let Ok(p) = parse_program(&text) {
            for b in &p.cycles {
                if let Ok(cfg) = b.to_simulation(&MachineData::default()) {
                    let _ = gearcomp_shaping::interpolator::Interpolator::new(cfg.interp);
                }
            }
        }
    }

    #[test]
    fn random_parameters_never_panic(t in 0u32..1100, l in 0u32..1100, q in -1.0f64..30.0,
                                     p in -60.0f64..60.0, r in -5.0f64..600.0, k in -5.0f64..2000.0,
                                     s in -5.0f64..4000.0, f in -1.0f64..12.0, b in -1.0f64..120.0) {
        let text = format!("G83 T{t} L{l} Q{q:.4} P{p:.3} R{r:.3} K{k:.3} S{s:.1} F{f:.4} B{b:.2}");
        if let Ok(prog) = parse_program(&text) {
            if let Ok(cfg) = prog.cycles[0].to_simulation(&MachineData::default()) {
                let _ = gearcomp_shaping::interpolator::Interpolator::new(cfg.interp);
            }
        }
    }
}
