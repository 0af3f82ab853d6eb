//! The G83 electronic-helical-guide cycle: grammar, parser and conversion to a set-up.
//!
//! Procedia CIRP 56 (2016) says only that "a special G code with parameters (G83)" was designed; the words
//! below are this crate's choice, modelled on FANUC's EGB command `G81 T_ L_ Q_ P_`
//! (T teeth, L tool threads, Q module, P helix angle with the sign giving the hand):
//!
//! | word | meaning | unit | required |
//! |---|---|---|---|
//! | T | workpiece teeth Z_C1 | – | yes |
//! | L | cutter teeth Z_C2 | – | yes |
//! | Q | normal module m_n | mm | yes |
//! | P | helix angle β, + right hand, − left hand, 0 spur | deg | yes |
//! | D | helix-angle correction Δβ, added to \|β\| | deg | no (0) |
//! | I | 0 external, 1 internal workpiece | – | no (0) |
//! | R | crank radius | mm | yes |
//! | K | connecting-rod length | mm | yes |
//! | S | double strokes per minute | 1/min | yes |
//! | F | circular feed per double stroke on the pitch circle | mm | yes |
//! | U | radial feed per double stroke | mm | no (0) |
//! | X | total radial depth | mm | no (2.25·m_n) |
//! | E | return-stroke lift-off | mm | no (0.2) |
//! | B | facewidth of the workpiece | mm | yes |
//!
//! A program is lines of words (`N` sequence numbers, comments `( … )` and `; …`, `%`
//! delimiters allowed), e.g. `N10 G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 U0.02 B40`;
//! `G80` cancels, `M30`/`M02` end the program. Errors give line and column.

use winnow::ascii::{digit0, digit1, space0};
use winnow::combinator::{alt, opt};
use winnow::error::{ContextError, StrContext, StrContextValue};
use winnow::prelude::*;
use winnow::token::{one_of, take_till};

use crate::coupling::{GearCut, Hand, Mesh, MAX_HELIX_DEG};
use crate::crank::SliderCrank;
use crate::error::{check_range, Result, ShapingError};
use crate::interpolator::{Interpolator, InterpolatorConfig, LinearLimits, RotaryLimits};
use crate::servo::{LoopParams, ServoModel};
use crate::simulate::{execution_plan, validate_simulation, SimulationConfig};
use crate::units::{deg_to_rad, rev_s2_to_rad_s2, rpm_to_rad_s};

/// One word of a block: address letter, value and 1-based column of the letter.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Word {
    /// Address letter, upper case.
    pub letter: char,
    /// Value.
    pub value: f64,
    /// 1-based column (characters) of the letter.
    pub column: usize,
}

/// G83 parameters in interface units (degrees, mm, strokes/min).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct G83Params {
    /// T: workpiece teeth Z_C1.
    pub workpiece_teeth: u32,
    /// L: cutter teeth Z_C2.
    pub cutter_teeth: u32,
    /// Q: normal module in mm.
    pub normal_module_mm: f64,
    /// P: signed helix angle in degrees (+ right, − left).
    pub helix_deg: f64,
    /// D: helix-angle correction in degrees.
    pub delta_beta_deg: f64,
    /// I: internal workpiece.
    pub internal: bool,
    /// R: crank radius in mm.
    pub crank_radius_mm: f64,
    /// K: rod length in mm.
    pub rod_length_mm: f64,
    /// S: double strokes per minute.
    pub strokes_per_min: f64,
    /// F: circular feed per double stroke in mm.
    pub circular_feed_mm: f64,
    /// U: radial feed per double stroke in mm.
    pub radial_feed_mm: f64,
    /// X: total radial depth in mm.
    pub depth_mm: f64,
    /// E: lift-off in mm.
    pub lift_off_mm: f64,
    /// B: facewidth in mm.
    pub face_width_mm: f64,
}

/// A G83 block with where it came from.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct G83Block {
    /// 1-based line number.
    pub line: usize,
    /// Parameters.
    pub params: G83Params,
    /// The block's words (for error columns).
    pub words: Vec<Word>,
}

/// A parsed program: its G83 cycles in order.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Program {
    /// The G83 blocks.
    pub cycles: Vec<G83Block>,
}

/// Letters a G83 block accepts (besides N, G).
pub const G83_LETTERS: &str = "TLQPDIRKSFUXEB";
const REQUIRED: &str = "TLQPRKSFB";

fn number(input: &mut &str) -> ModalResult<f64> {
    (
        opt(one_of(['+', '-'])),
        alt(((digit1, opt(('.', digit0))).take(), ('.', digit1).take())),
    )
        .take()
        .try_map(str::parse::<f64>)
        .context(StrContext::Expected(StrContextValue::Description(
            "a number such as 40, -15.5 or .25",
        )))
        .parse_next(input)
}

fn comment<'i>(input: &mut &'i str) -> ModalResult<&'i str> {
    ('(', take_till(0.., ')'), ')')
        .map(|(_, c, _)| c)
        .context(StrContext::Expected(StrContextValue::Description(
            "a comment closed by ')'",
        )))
        .parse_next(input)
}

fn column_of(line: &str, rest: &str) -> usize {
    let off = line.len() - rest.len();
    line[..off].chars().count() + 1
}

fn err(line: usize, column: usize, message: impl Into<String>) -> ShapingError {
    ShapingError::Parse {
        line,
        column,
        message: message.into(),
    }
}

/// Splits one line into words; comments are dropped.
///
/// # Formula (grammar)
/// line = ws { word ws | comment ws } [ ';' any* ];  word = letter ws number;
/// number = [+|-] ( digits [ '.' digits* ] | '.' digits );  comment = '(' [^)]* ')'
pub fn parse_line(text: &str, line_no: usize) -> Result<Vec<Word>> {
    let mut words = Vec::new();
    let mut input = text;
    loop {
        let _ = space0::<_, ContextError>.parse_next(&mut input);
        let Some(c) = input.chars().next() else { break };
        let col = column_of(text, input);
        if c == ';' {
            break;
        } else if c == '(' {
            if comment.parse_next(&mut input).is_err() {
                return Err(err(line_no, col, "comment '(' is not closed by ')'"));
            }
        } else if c.is_ascii_alphabetic() {
            input = &input[1..];
            let _ = space0::<_, ContextError>.parse_next(&mut input);
            let num_col = column_of(text, input);
            match number.parse_next(&mut input) {
                Ok(value) => words.push(Word {
                    letter: c.to_ascii_uppercase(),
                    value,
                    column: col,
                }),
                Err(_) => {
                    let found = input
                        .chars()
                        .next()
                        .map_or_else(|| "end of line".to_string(), |f| format!("'{f}'"));
                    return Err(err(
                        line_no,
                        num_col,
                        format!(
                            "expected a number after address '{}' (e.g. {}40 or {}-15.5), found {found}",
                            c.to_ascii_uppercase(),
                            c.to_ascii_uppercase(),
                            c.to_ascii_uppercase()
                        ),
                    ));
                }
            }
        } else {
            return Err(err(
                line_no,
                col,
                format!(
                    "unexpected character '{c}': expected an address word (e.g. T40), a comment \
                     '( … )' or ';'"
                ),
            ));
        }
    }
    Ok(words)
}

/// Most G83 blocks one program may hold. Each block is a whole cut that `gearcomp shape run`
/// executes and simulates (about 0.1–1 s each); a real part program has a few. A longer
/// program is refused at parse time, before anything runs, instead of running for hours.
pub const MAX_G83_BLOCKS: usize = 100;

/// Parses a whole program and returns its G83 cycles (at most [`MAX_G83_BLOCKS`]).
pub fn parse_program(text: &str) -> Result<Program> {
    let mut cycles: Vec<G83Block> = Vec::new();
    let mut ended = false;
    for (i, raw_line) in text.lines().enumerate() {
        let line_no = i + 1;
        let trimmed = raw_line.trim();
        if trimmed.is_empty() || trimmed == "%" {
            continue;
        }
        let words = parse_line(raw_line, line_no)?;
        if words.is_empty() {
            continue;
        }
        if ended {
            return Err(err(
                line_no,
                words[0].column,
                "block after the program end M30/M02",
            ));
        }
        let mut g83_col = None;
        let mut params = Vec::new();
        for (k, w) in words.iter().enumerate() {
            match w.letter {
                'N' if k == 0 => {}
                'N' => {
                    return Err(err(
                        line_no,
                        w.column,
                        "sequence number N must open the block",
                    ))
                }
                'G' if w.value == 83.0 => g83_col = Some(w.column),
                'G' if w.value == 80.0 => {}
                'G' => {
                    return Err(err(
                        line_no,
                        w.column,
                        format!(
                            "unsupported G{}: this interpreter runs G83 shaping cycles and G80 \
                             only",
                            w.value
                        ),
                    ))
                }
                'M' if w.value == 30.0 || w.value == 2.0 => ended = true,
                'M' => {
                    return Err(err(
                        line_no,
                        w.column,
                        format!(
                            "unsupported M{}: only M30 or M02 (program end) are accepted",
                            w.value
                        ),
                    ))
                }
                _ => params.push(*w),
            }
        }
        match g83_col {
            Some(col) if cycles.len() == MAX_G83_BLOCKS => {
                return Err(err(
                    line_no,
                    col,
                    format!(
                        "more than {MAX_G83_BLOCKS} G83 blocks: a program may hold at most \
                         {MAX_G83_BLOCKS} (each is a whole cut, executed and simulated); split \
                         the program (the first {MAX_G83_BLOCKS} end on line {})",
                        cycles.last().map_or(0, |c| c.line)
                    ),
                ))
            }
            Some(col) => cycles.push(g83_block(line_no, col, &params)?),
            None => {
                if let Some(w) = params.first() {
                    return Err(err(
                        line_no,
                        w.column,
                        format!("parameter word '{}' outside a G83 block", w.letter),
                    ));
                }
            }
        }
    }
    if cycles.is_empty() {
        return Err(err(1, 1, "the program contains no G83 block"));
    }
    Ok(Program { cycles })
}

fn g83_block(line: usize, g_col: usize, words: &[Word]) -> Result<G83Block> {
    let mut seen: [Option<Word>; 26] = [None; 26];
    for w in words {
        if !G83_LETTERS.contains(w.letter) {
            return Err(err(
                line,
                w.column,
                format!(
                    "'{}' is not a G83 parameter; allowed: T L Q P D I R K S F U X E B",
                    w.letter
                ),
            ));
        }
        let slot = &mut seen[(w.letter as u8 - b'A') as usize];
        if slot.is_some() {
            return Err(err(
                line,
                w.column,
                format!("parameter '{}' given twice", w.letter),
            ));
        }
        *slot = Some(*w);
    }
    let get = |c: char| seen[(c as u8 - b'A') as usize];
    let missing: Vec<String> = REQUIRED
        .chars()
        .filter(|&c| get(c).is_none())
        .map(|c| c.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(err(
            line,
            g_col,
            format!("G83 is missing required parameter(s) {}", missing.join(" ")),
        ));
    }
    let val = |c: char, default: f64| get(c).map_or(default, |w| w.value);
    let int = |c: char, min: u32, max: u32, what: &str| -> Result<u32> {
        let w = get(c);
        let v = w.map_or(0.0, |w| w.value);
        let col = w.map_or(g_col, |w| w.column);
        if v.fract() != 0.0 || v < f64::from(min) || v > f64::from(max) {
            return Err(err(
                line,
                col,
                format!("{c} ({what}) = {v} must be a whole number in {min} ..= {max}"),
            ));
        }
        Ok(v as u32)
    };
    let m_n = val('Q', 0.0);
    let params = G83Params {
        workpiece_teeth: int('T', 1, 1000, "workpiece teeth")?,
        cutter_teeth: int('L', 1, 1000, "cutter teeth")?,
        normal_module_mm: m_n,
        helix_deg: val('P', 0.0),
        delta_beta_deg: val('D', 0.0),
        internal: if get('I').is_some() {
            int('I', 0, 1, "0 external, 1 internal")? == 1
        } else {
            false
        },
        crank_radius_mm: val('R', 0.0),
        rod_length_mm: val('K', 0.0),
        strokes_per_min: val('S', 0.0),
        circular_feed_mm: val('F', 0.0),
        radial_feed_mm: val('U', 0.0),
        depth_mm: val('X', 2.25 * m_n),
        lift_off_mm: val('E', 0.2),
        face_width_mm: val('B', 0.0),
    };
    Ok(G83Block {
        line,
        params,
        words: words.to_vec(),
    })
}

/// Per-axis servo data as written in a machine-data file (interface units).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AxisServoData {
    /// Model the axis as ideal (actual = command).
    pub ideal: bool,
    /// Position-loop gain K_v in 1/s.
    pub kv_per_s: f64,
    /// Closed velocity-loop time constant in ms.
    pub velocity_time_constant_ms: f64,
    /// Velocity feed-forward factor (0–1).
    pub feed_forward: f64,
    /// Acceleration feed-forward factor (0–1).
    pub accel_feed_forward: f64,
    /// Position-encoder counts per revolution (quantisation).
    pub encoder_counts_per_rev: u32,
    /// Command delay in control cycles.
    pub delay_cycles: u32,
    /// Drive (servo) cycles per control cycle, with linear fine interpolation.
    pub drive_cycles_per_control_cycle: u32,
}

impl Default for AxisServoData {
    fn default() -> Self {
        Self {
            ideal: false,
            kv_per_s: 30.0,
            velocity_time_constant_ms: 2.0,
            feed_forward: 1.0,
            accel_feed_forward: 1.0,
            encoder_counts_per_rev: 3_600_000,
            delay_cycles: 1,
            drive_cycles_per_control_cycle: 8,
        }
    }
}

impl AxisServoData {
    /// The servo model in internal units (rad).
    pub fn model(&self) -> ServoModel {
        if self.ideal {
            ServoModel::Ideal
        } else {
            ServoModel::Loop(LoopParams {
                kv_per_s: self.kv_per_s,
                velocity_time_constant_s: self.velocity_time_constant_ms * 1e-3,
                feed_forward: self.feed_forward,
                accel_feed_forward: self.accel_feed_forward,
                quantum: std::f64::consts::TAU / f64::from(self.encoder_counts_per_rev.max(1)),
                delay_cycles: self.delay_cycles,
                substeps: self.drive_cycles_per_control_cycle,
            })
        }
    }
}

/// Machine data of the shaper (a TOML file at the CLI; defaults are a plausible
/// direct-drive shaper, not a particular machine).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MachineData {
    /// Control (interpolation) cycle in ms, 0.25–4.
    pub cycle_ms: f64,
    /// Crank encoder counts per revolution.
    pub crank_counts_per_rev: u32,
    /// C1 command counts per revolution.
    pub c1_counts_per_rev: u32,
    /// C2 command counts per revolution.
    pub c2_counts_per_rev: u32,
    /// C2 speed limit in rpm.
    pub c2_max_speed_rpm: f64,
    /// C2 acceleration limit in rev/s².
    pub c2_max_accel_rev_s2: f64,
    /// X speed limit in mm/s.
    pub x_max_speed_mm_s: f64,
    /// X acceleration limit in mm/s².
    pub x_max_accel_mm_s2: f64,
    /// Dead-time compensation of the helical term in cycles.
    pub delay_compensation_cycles: f64,
    /// Normal pressure angle of the gear in degrees.
    pub pressure_angle_deg: f64,
    /// ISO 1328-1:2013 flank tolerance class for the f_Hβ verdict.
    pub iso_class: u8,
    /// Double strokes to simulate (the last is evaluated).
    pub strokes: u32,
    /// C1 servo.
    pub c1: AxisServoData,
    /// C2 servo.
    pub c2: AxisServoData,
}

impl Default for MachineData {
    fn default() -> Self {
        Self {
            cycle_ms: 1.0,
            crank_counts_per_rev: 3_600_000,
            c1_counts_per_rev: 3_600_000,
            c2_counts_per_rev: 3_600_000,
            c2_max_speed_rpm: 150.0,
            c2_max_accel_rev_s2: 100.0,
            x_max_speed_mm_s: 200.0,
            x_max_accel_mm_s2: 20_000.0,
            delay_compensation_cycles: 1.0,
            pressure_angle_deg: 20.0,
            iso_class: 6,
            strokes: 4,
            c1: AxisServoData::default(),
            c2: AxisServoData::default(),
        }
    }
}

impl G83Block {
    /// Column of the word with `letter`, or 1.
    pub fn column_of(&self, letter: char) -> usize {
        self.words
            .iter()
            .find(|w| w.letter == letter)
            .map_or(1, |w| w.column)
    }

    /// Builds the simulation set-up and checks everything the interpolator, the simulation
    /// and the whole-cut execution will check (ranges of every word, feasibility, length of
    /// the cut), so each error carries this block's line and the responsible word's column.
    pub fn to_simulation(&self, m: &MachineData) -> Result<SimulationConfig> {
        let cfg = self.build(m).map_err(|e| self.locate(e))?;
        let ip = Interpolator::new(cfg.interp).map_err(|e| self.locate(e))?;
        validate_simulation(&cfg).map_err(|e| self.locate(e))?;
        execution_plan(&cfg.interp, &ip).map_err(|e| self.locate(e))?;
        Ok(cfg)
    }

    /// An error of this block's set-up or run, with its line (and the word's column where
    /// the error names one); errors that already have a place are kept.
    pub fn locate(&self, e: ShapingError) -> ShapingError {
        match e {
            ShapingError::Parse { .. } => e,
            other => self.locate_word(other),
        }
    }

    fn locate_word(&self, e: ShapingError) -> ShapingError {
        let letter = match &e {
            ShapingError::OutOfRange { field, .. } => field
                .split_whitespace()
                .find(|t| t.len() == 1 && G83_LETTERS.contains(*t))
                .and_then(|t| t.chars().next()),
            ShapingError::Infeasible { .. } | ShapingError::InsufficientData { .. } => Some('S'),
            _ => None,
        };
        match letter {
            Some(c) if self.words.iter().any(|w| w.letter == c) => ShapingError::Parse {
                line: self.line,
                column: self.column_of(c),
                message: e.to_string(),
            },
            _ => ShapingError::Parse {
                line: self.line,
                column: 1,
                message: e.to_string(),
            },
        }
    }

    fn build(&self, m: &MachineData) -> Result<SimulationConfig> {
        let p = &self.params;
        // The signed value as written (P-45.5 was reported as "= 45.5 deg": the magnitude).
        check_range(
            "helix angle P (beta, + right hand, - left hand)",
            p.helix_deg,
            -MAX_HELIX_DEG,
            MAX_HELIX_DEG,
            "deg",
        )?;
        let hand = if p.helix_deg < 0.0 {
            Hand::Left
        } else {
            Hand::Right
        };
        let mesh = if p.internal {
            Mesh::Internal
        } else {
            Mesh::External
        };
        let cut = GearCut::new(
            p.workpiece_teeth,
            p.cutter_teeth,
            p.normal_module_mm,
            deg_to_rad(p.helix_deg.abs()),
            deg_to_rad(p.delta_beta_deg),
            hand,
            mesh,
        )?;
        let crank = SliderCrank::new(p.crank_radius_mm, p.rod_length_mm)?;
        let interp = InterpolatorConfig {
            cut,
            crank,
            strokes_per_min: p.strokes_per_min,
            cycle_s: m.cycle_ms * 1e-3,
            crank_cpr: m.crank_counts_per_rev,
            c1_cpr: m.c1_counts_per_rev,
            c2_cpr: m.c2_counts_per_rev,
            circular_feed_mm: p.circular_feed_mm,
            radial_feed_mm: p.radial_feed_mm,
            depth_mm: p.depth_mm,
            lift_off_mm: p.lift_off_mm,
            c2_limits: RotaryLimits {
                max_speed_rad_s: rpm_to_rad_s(m.c2_max_speed_rpm),
                max_accel_rad_s2: rev_s2_to_rad_s2(m.c2_max_accel_rev_s2),
            },
            x_limits: LinearLimits {
                max_speed_mm_s: m.x_max_speed_mm_s,
                max_accel_mm_s2: m.x_max_accel_mm_s2,
            },
            delay_compensation_cycles: m.delay_compensation_cycles,
        };
        Ok(SimulationConfig {
            interp,
            c1_servo: m.c1.model(),
            c2_servo: m.c2.model(),
            strokes: m.strokes,
            face_width_mm: p.face_width_mm,
            pressure_angle_rad: deg_to_rad(m.pressure_angle_deg),
            iso_class: m.iso_class,
        })
    }
}
