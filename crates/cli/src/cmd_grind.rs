//! `gearcomp grind`: generating grinding with a (dressed) worm, JP6903407B2, part 2.
//!
//! `simulate` grinds a gear flank with a given worm modification and diagonal ratio (envelope
//! simulation, compared with the analytic worm→gear mapping); `solve` finds the diagonal ratio
//! and worm modification for a wanted gear modification of the line class and verifies it by
//! simulation. Both print a table (or `--json`) and can write an HTML report with the (w, z)
//! deviation map and the ISO 1328-1 evaluation.
//!
//! `simulate --dress CONFIG.toml` closes the loop with the dressing module: the worm of the
//! config is dressed (given ΔK, or the 3-point solve of `gearcomp dress`), its profile is
//! tabulated and used as the grinding worm, and the ground gear is evaluated against ISO 1328.
//!
//! `simulate --gear-cone-deg ϑ2 --worm-cone-deg ϑ1` grinds with a conical (beveloid) workpiece
//! and/or worm: the envelope simulation runs on the chains (29)–(31) of a [`ConicalPair`] and is
//! compared with the conical pair's analytic map. With both angles 0 the cylindrical chain (28)
//! runs exactly as before. `solve` with cone angles uses the conical line-class transfer
//! (`conical_lines`) and verifies it by the same envelope simulation; `simulate --dress`
//! refuses cone angles (conical dressing is not modelled).
//!
//! `equalise CONFIG.toml` reads gear and worm (with their cone angles) and finds the worm cone
//! angle ϑ1 that gives both flanks the same diagonal ratio (A6/T14).
//!
//! Interface units: degrees for angles, µm for modifications (coefficients in µm·mm⁻ᵏ), mm for
//! lengths. They are converted by the gear crates' shared `gearcomp_geometry::units` only. Exception kept for
//! copy-paste compatibility with `gearcomp dress` output: Δφ_S is given in rad (`dphi_s_rad`).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Subcommand;
use gearcomp_dressing::dresser::{Dresser, DresserSpec};
use gearcomp_dressing::request::GrindDressConfig;
use gearcomp_dressing::worm::Worm as DressWorm;
use gearcomp_geometry::units::{deg_to_rad, mm_to_um, rad_to_deg, um_to_mm};
use gearcomp_geometry::GeometryError;
use gearcomp_grinding::conical::{self, BeveloidGear, ConicalPair, MAX_CONE_ANGLE_RAD};
use gearcomp_grinding::conical_equalise::{
    equalise_worm_cone_angle, flank_ratios, EqualiseSpec, Equalised, WormLines,
};
use gearcomp_grinding::conical_lines;
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{diagonal_ratio, line_map, rho1_estimate_rad, LineMap};
use gearcomp_grinding::dressed::{DressedProfile, DressedWorm};
use gearcomp_grinding::envelope::{AnalyticTransfer, EnvelopeGrinder};
use gearcomp_grinding::envelope::{EnvelopeMode, FlankGrid, GroundFlank};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteFlank, InvoluteGear};
use gearcomp_grinding::iso1328::{tolerances, DeviationMap, FlankEvaluation, MultiTraceEvaluation};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{FlankModification, LineModification, Poly};
use gearcomp_grinding::solve::{solve_iterated, IterationOptions};
use gearcomp_grinding::GrindError;
use gearcomp_report::{Chart, HeatAxis, HeatMap, HtmlReport, Series};
use serde::{Deserialize, Serialize};

/// Options of `gearcomp grind`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: GrindCommand,
}

#[derive(Debug, Subcommand)]
enum GrindCommand {
    /// Grind a gear flank with a given worm modification and diagonal ratio.
    Simulate(SimulateArgs),
    /// Find the diagonal ratio and worm modification for a wanted gear modification, and
    /// verify them by simulation.
    Solve(SolveArgs),
    /// Find the worm cone angle ϑ1 that gives both flanks the same diagonal ratio (two-flank
    /// diagonal grinding with a conical worm, A6/T14).
    Equalise(EqualiseArgs),
}

#[derive(Debug, clap::Args)]
struct SetupArgs {
    /// Gear: number of teeth z2.
    #[arg(long, default_value_t = 31)]
    teeth: u32,
    /// Normal module m_n in mm (gear and worm).
    #[arg(long, default_value_t = 3.0)]
    module_mm: f64,
    /// Normal pressure angle in degrees (right flank; both flanks if --pressure-angle-left-deg
    /// is not given).
    #[arg(long, default_value_t = 20.0)]
    pressure_angle_deg: f64,
    /// Normal pressure angle of the left flank in degrees (asymmetric teeth).
    #[arg(long)]
    pressure_angle_left_deg: Option<f64>,
    /// Gear helix angle in degrees, signed (> 0 right hand).
    #[arg(long, default_value_t = 15.0, allow_hyphen_values = true)]
    helix_angle_deg: f64,
    /// Face width b in mm (the flank spans z = −b/2 … b/2).
    #[arg(long, default_value_t = 30.0)]
    face_width_mm: f64,
    /// Worm: number of starts z1.
    #[arg(long, default_value_t = 1)]
    worm_starts: u32,
    /// Worm reference (pitch) radius in mm.
    #[arg(long, default_value_t = 130.0)]
    worm_radius_mm: f64,
    /// Worm tip radius in mm: the thread grinds only between root and tip
    /// [default: worm radius + 1.25·m_n; with --dress the dressed worm's tip].
    #[arg(long)]
    worm_tip_radius_mm: Option<f64>,
    /// Worm root radius in mm [default: worm radius − 1.25·m_n; with --dress the dressed
    /// worm's root].
    #[arg(long)]
    worm_root_radius_mm: Option<f64>,
    /// Profile shift coefficient x of the gear (the worm runs at d = r1 + r2 + x·m_n).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    profile_shift: f64,
    /// Worm hand.
    #[arg(long, value_enum, default_value_t = Hand::Right)]
    worm_hand: Hand,
    /// Flank to grind.
    #[arg(long, value_enum, default_value_t = Flank::Right)]
    flank: Flank,
    /// Start of the active profile (roll distance) in mm [default: w_P − 2·m_n].
    #[arg(long)]
    roll_start_mm: Option<f64>,
    /// End of the active profile (roll distance) in mm [default: min(w_P + 2·m_n, tip)].
    #[arg(long)]
    roll_end_mm: Option<f64>,
    /// Grid points along the profile.
    #[arg(long, default_value_t = 25)]
    grid_w: usize,
    /// Grid points along the face width.
    #[arg(long, default_value_t = 31)]
    grid_z: usize,
    /// Worm shift offset z_V01 in mm (selects the worm region).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    shift_offset_mm: f64,
    /// ISO 1328-1:2013 accuracy class for the evaluation.
    #[arg(long, default_value_t = 6)]
    class: u8,
    /// Workpiece cone angle ϑ2 in degrees (beveloid gear, chains (30)/(31); > 0: the reference
    /// cone grows towards +z). 0 = cylindrical gear.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    gear_cone_deg: f64,
    /// Worm cone angle ϑ1 in degrees (conical worm, chains (29)/(31); > 0: the reference cone
    /// grows towards +z of the worm). 0 = cylindrical worm.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    worm_cone_deg: f64,
    /// Print JSON instead of tables.
    #[arg(long)]
    json: bool,
    /// Write an HTML report to this file.
    #[arg(long)]
    report: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
struct SimulateArgs {
    #[command(flatten)]
    setup: SetupArgs,
    /// Diagonal ratio K_ZV1 (0 = axial grinding) [default: the K that maps --worm-rho-deg
    /// onto --gear-rho-deg if that is given, else 0].
    #[arg(long, allow_hyphen_values = true)]
    diagonal_ratio: Option<f64>,
    /// Gear line direction ρ_F2 in degrees used to choose K when --diagonal-ratio is absent.
    #[arg(long, allow_hyphen_values = true)]
    gear_rho_deg: Option<f64>,
    /// Worm modification line direction ρ_F1 in degrees [default: axial-section estimate].
    #[arg(long, allow_hyphen_values = true)]
    worm_rho_deg: Option<f64>,
    /// Worm F_C(X) coefficients in µm, µm/mm, µm/mm², … (comma separated).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    worm_c: Vec<f64>,
    /// Worm F_L(X) coefficients (per mm of w − w_P1): µm/mm, µm/mm², …
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    worm_l: Vec<f64>,
    /// Worm F_Q(X) coefficients (per mm² of (w − w_P1)²): µm/mm², µm/mm³, …
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    worm_q: Vec<f64>,
    /// Grind with a worm dressed by the dressing module: a `gearcomp dress` TOML ([worm],
    /// [dresser]) with an optional [dressing] table (ΔK or 3-point crowning). The worm geometry
    /// then comes from the file (--worm-starts/--worm-radius-mm are not used).
    #[arg(long, value_name = "CONFIG.toml", conflicts_with_all = ["worm_c", "worm_l", "worm_q"])]
    dress: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
struct SolveArgs {
    #[command(flatten)]
    setup: SetupArgs,
    /// Direction ρ_F2 of the wanted gear modification lines in degrees (0 = lead, 90 = profile).
    #[arg(long, allow_hyphen_values = true)]
    gear_rho_deg: f64,
    /// Wanted F_C(X) coefficients in µm, µm/mm, µm/mm², … (comma separated).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    gear_c: Vec<f64>,
    /// Wanted F_L(X) coefficients (per mm of w − w_P2): µm/mm, µm/mm², …
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    gear_l: Vec<f64>,
    /// Wanted F_Q(X) coefficients (per mm² of (w − w_P2)²): µm/mm², …
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    gear_q: Vec<f64>,
    /// Worm modification line direction ρ_F1 in degrees (dresser contact line)
    /// [default: axial-section estimate].
    #[arg(long, allow_hyphen_values = true)]
    worm_rho_deg: Option<f64>,
}

#[derive(Debug, clap::Args)]
struct EqualiseArgs {
    /// Grind config: [gear], [worm] (with `cone_angle_deg` for each body) and [equalise].
    #[arg(value_name = "CONFIG.toml")]
    config: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Runs `gearcomp grind`.
pub fn run(args: Args) -> Result<()> {
    match args.command {
        GrindCommand::Simulate(a) => simulate(a),
        GrindCommand::Solve(a) => solve(a),
        GrindCommand::Equalise(a) => equalise(a),
    }
}

struct Setup {
    pair: WormGearPair,
    gear: InvoluteGear,
    grid: FlankGrid,
    /// Worm root and tip radii in mm.
    worm_radii_mm: (f64, f64),
}

/// Cone angles of worm (ϑ1) and workpiece (ϑ2), rad, in the library's convention: ϑ > 0 when
/// the body's reference cone grows towards +z of that body (docs/grinding.md "Conical tool and
/// workpiece").
#[derive(Debug, Clone, Copy, PartialEq)]
struct Cones {
    worm_rad: f64,
    gear_rad: f64,
    /// The values as given at the interface (reported unchanged).
    worm_deg: f64,
    gear_deg: f64,
}

impl Cones {
    const CYLINDRICAL: Cones = Cones {
        worm_rad: 0.0,
        gear_rad: 0.0,
        worm_deg: 0.0,
        gear_deg: 0.0,
    };

    fn is_cylindrical(&self) -> bool {
        self.worm_rad == 0.0 && self.gear_rad == 0.0
    }
}

/// --worm-cone-deg / --gear-cone-deg, range-checked against the library's limit
/// ([`MAX_CONE_ANGLE_RAD`], 50°) and converted to rad.
fn cones(a: &SetupArgs) -> Result<Cones> {
    let max_deg = rad_to_deg(MAX_CONE_ANGLE_RAD);
    for (opt, v) in [
        ("--worm-cone-deg", a.worm_cone_deg),
        ("--gear-cone-deg", a.gear_cone_deg),
    ] {
        if !(v.is_finite() && v.abs() <= max_deg) {
            anyhow::bail!(
                "{opt} = {v} is out of range: expected -{max_deg} ..= {max_deg} degrees \
                 (cone angle limit of the grinding library, JP6903407B2: below 50°)"
            );
        }
    }
    Ok(Cones {
        worm_rad: deg_to_rad(a.worm_cone_deg),
        gear_rad: deg_to_rad(a.gear_cone_deg),
        worm_deg: a.worm_cone_deg,
        gear_deg: a.gear_cone_deg,
    })
}

fn flank_arg(a: &SetupArgs) -> Flank {
    a.flank
}

fn hand_arg(a: &SetupArgs) -> Hand {
    a.worm_hand
}

/// The gear body (cylinder, or the beveloid's body at z = 0) from the set-up options.
fn gear_body(a: &SetupArgs) -> Result<InvoluteGear> {
    let alpha_r = deg_to_rad(a.pressure_angle_deg);
    let alpha_l = deg_to_rad(a.pressure_angle_left_deg.unwrap_or(a.pressure_angle_deg));
    let gear = InvoluteGear::asymmetric(
        a.teeth,
        a.module_mm,
        alpha_r,
        alpha_l,
        deg_to_rad(a.helix_angle_deg),
        a.profile_shift,
    )
    .map_err(|e| gear_error(&e))?;
    // a gear as the geometry crate defines one (3 ≤ z, no pointed tooth, root above 0, ...)
    for f in [Flank::Right, Flank::Left] {
        gear.flank_limits(f).map_err(|e| gear_error(&e))?;
    }
    Ok(gear)
}

/// A gear error with the option the user wrote.
fn gear_error(e: &GrindError) -> anyhow::Error {
    let field = match e {
        GrindError::OutOfRange { field, .. } => *field,
        GrindError::Geometry(g) => match g {
            GeometryError::OutOfRange { name, .. } => name,
            GeometryError::Undercut { .. } | GeometryError::PointedTooth { .. } => "profile_shift",
            _ => "",
        },
        _ => "",
    };
    let opt = match field {
        "teeth" => "--teeth",
        "m_n_mm" | "normal_module_mm" => "--module-mm",
        "alpha_n_right_rad" | "normal_pressure_angle" => "--pressure-angle-deg",
        "alpha_n_left_rad" => "--pressure-angle-left-deg",
        "beta_rad" | "helix_angle" => "--helix-angle-deg",
        "x_shift" | "profile_shift" => "--profile-shift",
        _ => "--teeth/--module-mm/--pressure-angle-deg/--helix-angle-deg/--profile-shift",
    };
    anyhow::anyhow!("gear ({opt}): {e}")
}

/// The worm body from the set-up options; its rack has the gear's profile angles (93).
fn worm_body(a: &SetupArgs) -> Result<InvoluteGear> {
    let alpha_r = deg_to_rad(a.pressure_angle_deg);
    let alpha_l = deg_to_rad(a.pressure_angle_left_deg.unwrap_or(a.pressure_angle_deg));
    let w = InvoluteGear::worm(
        a.worm_starts,
        a.module_mm,
        alpha_r,
        a.worm_radius_mm,
        hand_arg(a),
    )
    .context("worm")?;
    InvoluteGear::asymmetric(w.teeth, w.m_n_mm, alpha_r, alpha_l, w.beta_rad, 0.0).context("worm")
}

/// The usable roll range of the gear flank [lo, hi] in mm and what bounds each end.
struct RollLimits {
    lo_mm: f64,
    hi_mm: f64,
    lo_what: String,
    hi_what: String,
    /// Cap of the default roll end (below hi on a conical gear: the narrow end's tip).
    default_hi_mm: f64,
}

/// The (w, z) grid of the gear flank `f2` inside its usable roll range `lim`.
fn flank_grid(a: &SetupArgs, f2: &InvoluteFlank, lim: &RollLimits) -> Result<FlankGrid> {
    let expected = format!(
        "expected {:.4} ≤ --roll-start-mm < --roll-end-mm ≤ {:.4} mm (from {} to {})",
        lim.lo_mm, lim.hi_mm, lim.lo_what, lim.hi_what
    );
    if let Some(ws) = a.roll_start_mm {
        if !(ws >= lim.lo_mm - 1e-9 && ws < lim.hi_mm) {
            anyhow::bail!("--roll-start-mm = {ws} mm is outside the usable flank: {expected}");
        }
    }
    if let Some(we) = a.roll_end_mm {
        if !(we <= lim.hi_mm + 1e-9 && we > lim.lo_mm) {
            anyhow::bail!("--roll-end-mm = {we} mm is outside the usable flank: {expected}");
        }
    }
    let w_start = a.roll_start_mm.unwrap_or(
        (f2.w_ref_mm - 2.0 * a.module_mm)
            .max(0.1 * f2.w_ref_mm)
            .max(lim.lo_mm),
    );
    let w_end = a
        .roll_end_mm
        .unwrap_or((f2.w_ref_mm + 2.0 * a.module_mm).min(lim.default_hi_mm));
    if !(a.face_width_mm.is_finite() && a.face_width_mm > 0.0 && a.face_width_mm <= 2000.0) {
        anyhow::bail!(
            "--face-width-mm = {} is out of range: expected 0 < b ≤ 2000 mm",
            a.face_width_mm
        );
    }
    let half = 0.5 * a.face_width_mm;
    FlankGrid::new((w_start, w_end), (-half, half), a.grid_w, a.grid_z)
        .context("flank grid (--roll-start-mm/--roll-end-mm/--grid-w/--grid-z)")
}

/// Worm root and tip radii: the options, else the dressed worm's, else r1 ∓ 1.25·m_n.
fn worm_radii(a: &SetupArgs, r1_mm: f64, dressed: Option<&DressWorm>) -> Result<(f64, f64)> {
    let (root0, tip0) = dressed.map_or(
        (r1_mm - 1.25 * a.module_mm, r1_mm + 1.25 * a.module_mm),
        |d| (d.r_f_mm, d.r_a_mm),
    );
    let root = a.worm_root_radius_mm.unwrap_or(root0);
    let tip = a.worm_tip_radius_mm.unwrap_or(tip0);
    if !(root.is_finite() && tip.is_finite() && root >= 0.0 && root < r1_mm && tip > r1_mm) {
        anyhow::bail!(
            "--worm-root-radius-mm = {root} / --worm-tip-radius-mm = {tip}: expected \
             0 ≤ root < worm radius {r1_mm} mm < tip"
        );
    }
    Ok((root, tip))
}

/// Usable roll range of the gear flank on a cylindrical chain: the gear's root form and tip
/// circles, and the gear roll distances the worm thread reaches between its root and tip
/// ((R7): w1 = a·w2 + b, exact on the cylindrical chain).
fn roll_limits(
    gear: &InvoluteGear,
    flank: Flank,
    pair: &WormGearPair,
    radii: (f64, f64),
) -> Result<RollLimits> {
    let lim = gear.flank_limits(flank).map_err(|e| gear_error(&e))?;
    let rb1 = pair.worm.r_b_mm;
    let w1 = |r: f64| (r * r - rb1 * rb1).max(0.0).sqrt();
    let (a, b) = (pair.path.a, pair.path.b_mm);
    let w2_root = (w1(radii.0) - b) / a;
    let w2_tip = (w1(radii.1) - b) / a;
    let (w2_lo_worm, lo_worm_what, w2_hi_worm, hi_worm_what) = if w2_tip < w2_root {
        (w2_tip, "worm tip", w2_root, "worm root")
    } else {
        (w2_root, "worm root", w2_tip, "worm tip")
    };
    if w2_lo_worm.is_nan() || w2_lo_worm <= 0.0 {
        anyhow::bail!(
            "the {lo_worm_what} (r = {:.4} mm, --worm-root-radius-mm/--worm-tip-radius-mm) \
             reaches below the gear's base circle: it undercuts the involute, which the \
             envelope simulation does not model; raise --profile-shift or --teeth, or lower \
             the worm tip",
            if lo_worm_what == "worm tip" {
                radii.1
            } else {
                radii.0
            }
        );
    }
    let (lo, lo_what) = if lim.w_root_form_mm >= w2_lo_worm {
        (
            lim.w_root_form_mm,
            match lim.root_form_diameter_mm {
                Some(d) => format!("the root form circle d_Ff = {d:.4} mm"),
                None => "the base circle (undercut)".to_string(),
            },
        )
    } else {
        (
            w2_lo_worm,
            format!(
                "the reach of the {lo_worm_what} (r = {:.4} mm)",
                if lo_worm_what == "worm tip" {
                    radii.1
                } else {
                    radii.0
                }
            ),
        )
    };
    let (hi, hi_what) = if lim.w_tip_mm <= w2_hi_worm {
        (
            lim.w_tip_mm,
            format!("the tip circle d_a = {:.4} mm", lim.tip_diameter_mm),
        )
    } else {
        (
            w2_hi_worm,
            format!(
                "the reach of the {hi_worm_what} (r = {:.4} mm)",
                if hi_worm_what == "worm tip" {
                    radii.1
                } else {
                    radii.0
                }
            ),
        )
    };
    if !(hi > lo && lo.is_finite()) {
        anyhow::bail!(
            "the worm (--worm-root-radius-mm {} / --worm-tip-radius-mm {}) does not reach the \
             gear flank between {lo_what} and {hi_what}",
            radii.0,
            radii.1
        );
    }
    Ok(RollLimits {
        lo_mm: lo.max(1e-6),
        hi_mm: hi,
        lo_what,
        hi_what,
        default_hi_mm: hi,
    })
}

fn setup(a: &SetupArgs, dressed: Option<&DressWorm>) -> Result<Setup> {
    let gear = gear_body(a)?;
    let flank = flank_arg(a);
    let (pair, r1) = match dressed {
        None => {
            let worm = worm_body(a)?;
            let pair = if a.profile_shift == 0.0 {
                WormGearPair::reference(&worm, &gear, flank)
            } else {
                // the shifted gear's rack datum is x·m_n outside its reference circle
                WormGearPair::new(
                    &worm,
                    &gear,
                    flank,
                    worm.reference_radius_mm()
                        + gear.reference_radius_mm()
                        + a.profile_shift * a.module_mm,
                    -(worm.beta_rad + gear.beta_rad),
                )
            };
            (pair.context("worm/gear mesh")?, worm.reference_radius_mm())
        }
        Some(dw) => (
            dressed_pair(a, dw, &gear, flank, hand_arg(a))?,
            0.5 * dw.d_s_mm,
        ),
    };
    let radii = worm_radii(a, r1, dressed)?;
    let lim = roll_limits(&gear, flank, &pair, radii)?;
    let f2 = gear.flank(flank);
    let grid = flank_grid(a, &f2, &lim)?;
    Ok(Setup {
        pair,
        gear,
        grid,
        worm_radii_mm: radii,
    })
}

/// Conical worm and/or workpiece at the reference setting (pivots coincide, γ = −(β1 + β2)).
struct ConeSetup {
    pair: ConicalPair,
    /// The gear's body (teeth, module, angles at z = 0) for the ISO 1328 tolerances.
    gear: InvoluteGear,
    grid: FlankGrid,
}

/// The conical set-up: beveloid worm and gear from the options, chain (29)–(31).
///
/// The default end of the roll range uses the gear's tip circle at the narrow end of the face,
/// so every grid point lies on the flank.
/// # Formula
/// r_a,min = r + m_n − (b/2)·|tan ϑ2| (tip cone parallel to the reference cone: addendum m_n
/// over the local profile shift x(z) = z·tan ϑ2/m_n).
/// # Source
/// Beveloid local profile shift, docs/grinding.md "Conical tool and workpiece" [RECONSTRUCTED];
/// addendum h_a = m_n, ISO
/// 53 basic rack [STANDARD]; convention fixed here (docs/grinding.md).
fn setup_conical(a: &SetupArgs, c: Cones) -> Result<ConeSetup> {
    let gear = gear_body(a)?;
    let flank = flank_arg(a);
    let bev2 = BeveloidGear::new(gear, c.gear_rad)
        .with_context(|| format!("--gear-cone-deg = {}", a.gear_cone_deg))?;
    let bev1 = BeveloidGear::new(worm_body(a)?, c.worm_rad)
        .with_context(|| format!("--worm-cone-deg = {}", a.worm_cone_deg))?;
    let pair = ConicalPair::reference(&bev1, &bev2, flank)
        .context("conical worm/gear mesh (chains (29)–(31))")?;
    let r_tip = gear.reference_radius_mm() + a.module_mm * (1.0 + a.profile_shift)
        - 0.5 * a.face_width_mm * c.gear_rad.tan().abs();
    let f2 = &pair.gear;
    let body = gear.flank_limits(flank).map_err(|e| gear_error(&e))?;
    // the tip and root form of the body at z = 0 bound the options; the default end stays on
    // the flank over the whole face (the tip at the narrow end)
    let lim = RollLimits {
        lo_mm: body.w_root_form_mm.max(1e-6),
        hi_mm: body.w_tip_mm,
        lo_what: "the root form circle at z = 0".to_string(),
        hi_what: format!(
            "the tip circle d_a = {:.4} mm at z = 0",
            body.tip_diameter_mm
        ),
        default_hi_mm: (r_tip * r_tip - f2.r_b_mm * f2.r_b_mm).max(0.0).sqrt(),
    };
    let grid = flank_grid(a, f2, &lim)?;
    Ok(ConeSetup { pair, gear, grid })
}

/// The worm of a dress config as a grinding worm, and its set-up with the gear.
///
/// The helicoid (r_b, β_b) is that of the design diameter d_S0 (the dressing module keeps it
/// over the worm's life). A new worm runs at the reference setting d = d_S0/2 + r2,
/// γ = −(β1 + β2) (R3); a redressed worm (d_S < d_S0) at d = d_S/2 + r2 with the helix angle of
/// the same helicoid at d_S/2, tan β1(r) = tan β1(r0)·r/r0.
fn dressed_pair(
    a: &SetupArgs,
    dw: &DressWorm,
    gear: &InvoluteGear,
    flank: Flank,
    hand: Hand,
) -> Result<WormGearPair> {
    if hand != Hand::Right {
        anyhow::bail!(
            "--worm-hand left with --dress: the dressing module models right-hand worms only"
        );
    }
    let alpha = rad_to_deg(dw.alpha_n_rad);
    if (dw.m_n_mm - a.module_mm).abs() > 1e-9 * a.module_mm {
        anyhow::bail!(
            "[worm] normal_module_mm = {} does not mesh with --module-mm {}: expected equal",
            dw.m_n_mm,
            a.module_mm
        );
    }
    let left = a.pressure_angle_left_deg.unwrap_or(a.pressure_angle_deg);
    if (alpha - a.pressure_angle_deg).abs() > 1e-9 || (alpha - left).abs() > 1e-9 {
        anyhow::bail!(
            "[worm] profile_angle_deg = {alpha} does not mesh with --pressure-angle-deg {} \
             (left {left}): expected equal on both flanks (the dressed worm is symmetric)",
            a.pressure_angle_deg
        );
    }
    let r0 = 0.5 * dw.d_s0_mm;
    let worm = InvoluteGear::worm(dw.z_s, dw.m_n_mm, dw.alpha_n_rad, r0, Hand::Right)
        .context("[worm] as grinding worm")?;
    let r = 0.5 * dw.d_s_mm;
    let beta1 = (worm.beta_rad.tan() * r / r0).atan();
    WormGearPair::new(
        &worm,
        gear,
        flank,
        r + gear.reference_radius_mm() + gear.x_shift * gear.m_n_mm,
        -(beta1 + gear.beta_rad),
    )
    .context("dressed worm/gear mesh")
}

fn poly_um(coeffs: &[f64]) -> Poly {
    Poly(coeffs.iter().map(|&c| um_to_mm(c)).collect())
}

fn poly_to_um(p: &Poly) -> Vec<f64> {
    p.0.iter().map(|&c| mm_to_um(c)).collect()
}

#[derive(Debug, Serialize)]
struct LineModOut {
    rho_deg: f64,
    w0_mm: f64,
    c_um: Vec<f64>,
    l_um: Vec<f64>,
    q_um: Vec<f64>,
}

impl LineModOut {
    fn from(m: &LineModification) -> Self {
        Self {
            rho_deg: rad_to_deg(m.rho_rad),
            w0_mm: m.w0_mm,
            c_um: poly_to_um(&m.c),
            l_um: poly_to_um(&m.l),
            q_um: poly_to_um(&m.q),
        }
    }
}

#[derive(Debug, Serialize)]
struct PathOut {
    flank: &'static str,
    centre_distance_mm: f64,
    crossing_deg: f64,
    c_w1: f64,
    c_c1_mm: f64,
    c_w2: f64,
    c_c2_mm: f64,
    dw1_dw2: f64,
    /// (R7) w1/cos β_b1 + w2/cos β_b2, constant on cylindrical chains only (null on conical).
    r7_sum_mm: Option<f64>,
    rho_kf_deg: f64,
    /// Feed terms of the conical contact path (76)/(77)/(86) (conical chains only).
    #[serde(skip_serializing_if = "Option::is_none")]
    conical: Option<ConicalPathOut>,
}

/// Feed terms of (76)/(77)/(86) that a cylindrical chain does not have (or has as −1/0).
#[derive(Debug, Serialize)]
struct ConicalPathOut {
    c_zv11: f64,
    c_zv21: f64,
    c_zv12: f64,
    c_zv22: f64,
    b_zv1: f64,
    b_zv2: f64,
    b_mm: f64,
}

#[derive(Debug, Serialize)]
struct MapOut {
    w_mm: Vec<f64>,
    z_mm: Vec<f64>,
    /// Row per w, column per z.
    ground_um: Vec<Vec<f64>>,
    analytic_um: Vec<Vec<f64>>,
    deviation_um: Vec<Vec<f64>>,
}

#[derive(Debug, Serialize)]
struct Output {
    mode: &'static str,
    /// Worm cone angle ϑ1 in degrees (0 = cylindrical worm).
    worm_cone_deg: f64,
    /// Workpiece cone angle ϑ2 in degrees (0 = cylindrical gear).
    gear_cone_deg: f64,
    path: PathOut,
    diagonal_ratio: f64,
    shift_offset_mm: f64,
    line_map: Option<LineMap>,
    /// The worm modification given on the command line (None with --dress).
    worm_modification: Option<LineModOut>,
    /// The dressed worm (with --dress).
    dressed_worm: Option<DressedOut>,
    wanted_gear_modification: Option<LineModOut>,
    max_abs_ground_um: f64,
    max_abs_ground_minus_analytic_um: f64,
    max_abs_deviation_um: f64,
    deviation_reference: &'static str,
    iso1328: FlankEvaluation,
    /// ISO 1328-1 over three profile and three helix traces, against the design and against
    /// the unmodified flank, with the class achieved.
    iso1328_traces: TracesOut,
    /// Gear profile shift coefficient x.
    profile_shift: f64,
    /// Worm root and tip radii (mm) that bound the grinding thread (None on conical chains,
    /// where only the thread-turn bound applies).
    worm_radii_mm: Option<(f64, f64)>,
    /// Points whose envelope value is not explained by the analytic map and its second-order
    /// correction, or that the worm grinds with its tip or root edge.
    flagged_points: Vec<FlaggedPoint>,
    /// Warnings (also printed to stderr).
    warnings: Vec<String>,
    /// The iterated solve (solve on a cylindrical chain).
    #[serde(skip_serializing_if = "Option::is_none")]
    solve: Option<SolveOut>,
    map: MapOut,
}

#[derive(Debug, Serialize)]
struct TracesOut {
    /// What "design" is: the wanted modification (solve) or the analytic worm → gear map of
    /// the given worm (simulate).
    design_reference: &'static str,
    /// Deviation from the design (intended modification removed).
    from_design: MultiTraceEvaluation,
    /// Deviation from the unmodified flank (involute helicoid / nominal beveloid flank).
    from_involute: MultiTraceEvaluation,
}

#[derive(Debug, Serialize)]
struct FlaggedPoint {
    w_mm: f64,
    z_mm: f64,
    ground_um: f64,
    analytic_um: f64,
    /// Second-order model (analytic state's cut plus −½·gᵀH⁻¹g); None if it has no minimum.
    second_order_um: Option<f64>,
    reason: &'static str,
}

#[derive(Debug, Serialize)]
struct SolveIterationOut {
    iteration: usize,
    max_abs_deviation_um: f64,
}

#[derive(Debug, Serialize)]
struct SolveOut {
    /// Every envelope simulation; 1 = the first-order worm.
    iterations: Vec<SolveIterationOut>,
    wish_max_abs_um: f64,
    /// Remaining max |ground − wish| with the reported worm.
    remaining_um: f64,
    remaining_percent_of_wish: f64,
    /// Stopping rule: max(0.5 % of the wish, 0.01 µm).
    tolerance_um: f64,
    converged: bool,
    /// The first-order worm (before the iteration).
    first_order_worm: LineModOut,
}

/// What `grind_and_report` takes beyond the mesh and the worm.
#[derive(Default)]
struct Extras {
    worm_radii_mm: Option<(f64, f64)>,
    /// A flank already ground with this worm (the iterated solve's last simulation).
    pre_ground: Option<GroundFlank>,
    solve: Option<SolveOut>,
}

/// What `grind_and_report` needs of a worm–workpiece mesh beyond the simulation kinematics and
/// the analytic map (both in the grinding crate).
trait GrindMesh: AnalyticTransfer {
    /// The mesh named in error messages.
    const NAME: &'static str;
    /// The contact path for the output.
    fn path_out(&self) -> PathOut;
}

impl GrindMesh for WormGearPair {
    const NAME: &'static str = "worm–gear pair";

    fn path_out(&self) -> PathOut {
        PathOut {
            flank: self.worm.flank.name(),
            centre_distance_mm: self.centre_distance_mm,
            crossing_deg: rad_to_deg(self.crossing_rad),
            c_w1: self.path.c_w1,
            c_c1_mm: self.path.c_c1_mm,
            c_w2: self.path.c_w2,
            c_c2_mm: self.path.c_c2_mm,
            dw1_dw2: self.path.a,
            r7_sum_mm: Some(self.path.r7_sum_mm),
            rho_kf_deg: rad_to_deg(self.rho_kf_rad()),
            conical: None,
        }
    }
}

impl GrindMesh for ConicalPair {
    const NAME: &'static str = "conical pair";

    fn path_out(&self) -> PathOut {
        let p = &self.path;
        PathOut {
            flank: self.worm.flank.name(),
            centre_distance_mm: self.chain.centre_distance_mm,
            crossing_deg: rad_to_deg(self.chain.crossing_rad),
            c_w1: p.c_w1,
            c_c1_mm: p.c_c1_mm,
            c_w2: p.c_w2,
            c_c2_mm: p.c_c2_mm,
            dw1_dw2: p.a,
            r7_sum_mm: None,
            rho_kf_deg: rad_to_deg(self.rho_kf_rad()),
            conical: Some(ConicalPathOut {
                c_zv11: p.c_zv11,
                c_zv21: p.c_zv21,
                c_zv12: p.c_zv12,
                c_zv22: p.c_zv22,
                b_zv1: p.b_zv1,
                b_zv2: p.b_zv2,
                b_mm: p.b_mm,
            }),
        }
    }
}

/// The worm that grinds: a line modification from the command line, or a dressed worm.
enum WormUsed<'a> {
    Line(&'a LineModification),
    Dressed(&'a DressedWorm, Box<DressedOut>),
}

/// Grinds the grid and builds the output (design = `wanted`, or the unmodified flank: the
/// involute helicoid, or the nominal beveloid flank on a conical gear).
///
/// `gear` is the workpiece body at z = 0 (reference diameter and module for the ISO 1328
/// tolerances). The cylindrical [`WormGearPair`] runs the library's `Grinder` (which is
/// `EnvelopeGrinder<WormGearPair>`), a [`ConicalPair`] the same algorithm on chains (29)–(31).
#[allow(clippy::too_many_arguments)]
fn grind_and_report<M: GrindMesh>(
    mode: &'static str,
    mesh: &M,
    gear: &InvoluteGear,
    g: FlankGrid,
    cones: Cones,
    a: &SetupArgs,
    k: f64,
    lm: Option<LineMap>,
    worm: WormUsed<'_>,
    wanted: Option<&LineModification>,
    extras: Extras,
) -> Result<Output> {
    let (worm_mod, worm_out, dressed_out): (&dyn FlankModification, _, _) = match worm {
        WormUsed::Line(m) => (m, Some(LineModOut::from(m)), None),
        WormUsed::Dressed(d, o) => (d, None, Some(*o)),
    };
    let cpl = FeedCoupling::linear(k, a.shift_offset_mm).context("feed coupling")?;
    let ground = match extras.pre_ground {
        Some(pre) => pre,
        None => {
            let mut grinder =
                EnvelopeGrinder::new(mesh, &cpl, worm_mod, EnvelopeMode::RotationAndFeed);
            if let Some((root, tip)) = extras.worm_radii_mm {
                grinder = grinder
                    .with_worm_radii(root, tip)
                    .context("--worm-root-radius-mm/--worm-tip-radius-mm")?;
            }
            let mut ground = GroundFlank::new(g);
            grinder.grind_flank(&mut ground).context(
                "grinding simulation (check --roll-start-mm/--roll-end-mm against the worm's \
                 --worm-root-radius-mm/--worm-tip-radius-mm, --shift-offset-mm and the worm \
                 modification)",
            )?;
            ground
        }
    };
    let mut flagged = Vec::new();
    let mut design_mm = Vec::with_capacity(g.len());
    let mut ground_mm = Vec::with_capacity(g.len());
    let mut map = MapOut {
        w_mm: (0..g.n_w).map(|i| g.w_mm(i)).collect(),
        z_mm: (0..g.n_z).map(|j| g.z_mm(j)).collect(),
        ground_um: Vec::with_capacity(g.n_w),
        analytic_um: Vec::with_capacity(g.n_w),
        deviation_um: Vec::with_capacity(g.n_w),
    };
    let mut dev_mm = Vec::with_capacity(g.len());
    let (mut max_g, mut max_ga, mut max_d) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..g.n_w {
        let (mut rg, mut ra, mut rd) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..g.n_z {
            let (w, z) = (g.w_mm(i), g.z_mm(j));
            let f = ground.at(i, j).f_ft_mm;
            let an = mesh
                .predicted_gear_f_ft_mm(&cpl, worm_mod, w, z)
                .with_context(|| format!("analytic map of the {}", M::NAME))?;
            let design = wanted.map_or(0.0, |m| m.f_ft_mm(w, z));
            dev_mm.push(f - design);
            design_mm.push(f - wanted.map_or(an, |m| m.f_ft_mm(w, z)));
            ground_mm.push(f);
            let gp = ground.at(i, j);
            if !gp.explained {
                flagged.push(FlaggedPoint {
                    w_mm: w,
                    z_mm: z,
                    ground_um: mm_to_um(f),
                    analytic_um: mm_to_um(an),
                    second_order_um: gp.second_order_f_ft_mm.map(mm_to_um),
                    reason: if gp.worm_edge {
                        "the worm grinds this point with its tip or root edge"
                    } else {
                        "envelope and analytic map differ beyond their second-order terms"
                    },
                });
            }
            max_g = max_g.max(f.abs());
            max_ga = max_ga.max((f - an).abs());
            max_d = max_d.max((f - design).abs());
            rg.push(mm_to_um(f));
            ra.push(mm_to_um(an));
            rd.push(mm_to_um(f - design));
        }
        map.ground_um.push(rg);
        map.analytic_um.push(ra);
        map.deviation_um.push(rd);
    }
    let tol = tolerances(
        2.0 * gear.reference_radius_mm(),
        gear.m_n_mm,
        a.face_width_mm,
        a.class,
    )
    .context("ISO 1328-1 tolerances")?;
    let iso = DeviationMap::new(g, dev_mm)?
        .evaluate(tol, gear.m_n_mm)
        .context("ISO 1328-1 evaluation")?;
    let d_mm = 2.0 * gear.reference_radius_mm();
    let traces = |v: Vec<f64>| -> Result<MultiTraceEvaluation> {
        DeviationMap::new(g, v)?
            .evaluate_traces(d_mm, gear.m_n_mm, a.face_width_mm, a.class, 3)
            .context("ISO 1328-1 evaluation (three traces)")
    };
    let iso_traces = TracesOut {
        design_reference: if wanted.is_some() {
            "wanted gear modification"
        } else {
            "analytic worm → gear map of the given worm"
        },
        from_design: traces(design_mm)?,
        from_involute: traces(ground_mm)?,
    };
    let mut warnings = Vec::new();
    for reason in [
        "the worm grinds this point with its tip or root edge",
        "envelope and analytic map differ beyond their second-order terms",
    ] {
        let pts: Vec<&FlaggedPoint> = flagged.iter().filter(|p| p.reason == reason).collect();
        if let Some(p) = pts.first() {
            warnings.push(format!(
                "{} of {} points: {reason} (first at w = {:.4} mm, z = {:.4} mm: envelope {:.4} \
                 µm, analytic {:.4} µm); see flagged_points",
                pts.len(),
                g.len(),
                p.w_mm,
                p.z_mm,
                p.ground_um,
                p.analytic_um
            ));
        }
    }
    if let Some(sv) = &extras.solve {
        if !sv.converged {
            warnings.push(format!(
                "the iterated solve stopped at {:.4} µm remaining deviation ({:.3} % of the \
                 wish), above its tolerance {:.4} µm",
                sv.remaining_um, sv.remaining_percent_of_wish, sv.tolerance_um
            ));
        }
    }
    Ok(Output {
        mode,
        worm_cone_deg: cones.worm_deg,
        gear_cone_deg: cones.gear_deg,
        path: mesh.path_out(),
        diagonal_ratio: k,
        shift_offset_mm: a.shift_offset_mm,
        line_map: lm,
        worm_modification: worm_out,
        dressed_worm: dressed_out,
        wanted_gear_modification: wanted.map(LineModOut::from),
        max_abs_ground_um: mm_to_um(max_g),
        max_abs_ground_minus_analytic_um: mm_to_um(max_ga),
        max_abs_deviation_um: mm_to_um(max_d),
        deviation_reference: if wanted.is_some() {
            "wanted gear modification"
        } else if cones.gear_rad != 0.0 {
            "nominal beveloid flank"
        } else {
            "unmodified involute flank"
        },
        iso1328: iso,
        iso1328_traces: iso_traces,
        profile_shift: a.profile_shift,
        worm_radii_mm: extras.worm_radii_mm,
        flagged_points: flagged,
        warnings,
        solve: extras.solve,
        map,
    })
}

fn simulate(a: SimulateArgs) -> Result<()> {
    let c = cones(&a.setup)?;
    if !c.is_cylindrical() {
        if a.dress.is_some() {
            anyhow::bail!(
                "--dress with --worm-cone-deg = {} / --gear-cone-deg = {}: grinding with a \
                 dressed worm is modelled for a cylindrical worm and gear only (dressing of \
                 conical worms is not supported); give both cone angles 0, or a worm \
                 modification (--worm-c/--worm-l/--worm-q) instead of --dress",
                a.setup.worm_cone_deg,
                a.setup.gear_cone_deg
            );
        }
        return simulate_conical(&a, c);
    }
    if let Some(path) = &a.dress {
        return simulate_dressed(&a, path);
    }
    let s = setup(&a.setup, None)?;
    let rho1 = a
        .worm_rho_deg
        .map_or_else(|| rho1_estimate_rad(&s.pair), deg_to_rad);
    let worm_mod = LineModification::new(
        rho1,
        s.pair.worm.w_ref_mm,
        poly_um(&a.worm_c),
        poly_um(&a.worm_l),
        poly_um(&a.worm_q),
    )
    .context("worm modification")?;
    let (k, lm) = diagonal_choice(&a, &s, rho1)?;
    let out = grind_and_report(
        "simulate",
        &s.pair,
        &s.gear,
        s.grid,
        Cones::CYLINDRICAL,
        &a.setup,
        k,
        lm,
        WormUsed::Line(&worm_mod),
        None,
        Extras {
            worm_radii_mm: Some(s.worm_radii_mm),
            ..Extras::default()
        },
    )?;
    emit(&out, &a.setup)
}

/// `simulate` with a conical worm and/or workpiece (chains (29)–(31)).
///
/// ρ_F1 defaults to the axial-section estimate of the conical worm flank; --gear-rho-deg picks
/// K_ZV1 and, where it exists, the line map X_F1 = k·X_F2 + c0 of the conical chain
/// (`conical_line_map`; not for profile lines ρ_F2 = ±90° on a feed-dependent (86)).
fn simulate_conical(a: &SimulateArgs, c: Cones) -> Result<()> {
    let s = setup_conical(&a.setup, c)?;
    let rho1 = a
        .worm_rho_deg
        .map_or_else(|| conical::rho1_estimate_rad(&s.pair.worm), deg_to_rad);
    let worm_mod = LineModification::new(
        rho1,
        s.pair.worm.w_ref_mm,
        poly_um(&a.worm_c),
        poly_um(&a.worm_l),
        poly_um(&a.worm_q),
    )
    .context("worm modification")?;
    let (k, lm) = match (a.diagonal_ratio, a.gear_rho_deg) {
        (Some(k), _) => (k, None),
        (None, Some(r2)) => {
            let r2 = deg_to_rad(r2);
            let k = s
                .pair
                .diagonal_ratio(rho1, r2)
                .context("diagonal ratio for --gear-rho-deg (conical)")?;
            // the line map exists wherever K does, except for profile lines on a chain whose
            // roll relation (86) depends on the feeds; then only K is reported
            let lm = conical_lines::conical_line_map(&s.pair, rho1, r2, a.setup.shift_offset_mm)
                .ok()
                .map(|m| m.line);
            (k, lm)
        }
        (None, None) => (0.0, None),
    };
    let out = grind_and_report(
        "simulate",
        &s.pair,
        &s.gear,
        s.grid,
        c,
        &a.setup,
        k,
        lm,
        WormUsed::Line(&worm_mod),
        None,
        Extras::default(),
    )?;
    emit(&out, &a.setup)
}

/// K_ZV1 from --diagonal-ratio, or from --gear-rho-deg and the worm line direction ρ_F1.
fn diagonal_choice(a: &SimulateArgs, s: &Setup, rho1: f64) -> Result<(f64, Option<LineMap>)> {
    Ok(match (a.diagonal_ratio, a.gear_rho_deg) {
        (Some(k), _) => (k, None),
        (None, Some(r2)) => {
            let lm = line_map(&s.pair, rho1, deg_to_rad(r2), a.setup.shift_offset_mm)
                .context("diagonal ratio for --gear-rho-deg")?;
            (lm.k_zv1, Some(lm))
        }
        (None, None) => (0.0, None),
    })
}

#[derive(Debug, Serialize)]
struct DressedOut {
    config: String,
    correction: &'static str,
    worm_starts: u32,
    worm_design_diameter_mm: f64,
    worm_diameter_mm: f64,
    dresser_diameter_mm: f64,
    dphi_s_rad: f64,
    dgamma_deg: f64,
    dd_mm: f64,
    dnu_ya_mm: f64,
    newton_iterations: Option<usize>,
    rho_f1_deg: f64,
    rho_f1_axial_section_estimate_deg: f64,
    dressed_roll_range_mm: (f64, f64),
    dressed_radius_range_mm: (f64, f64),
    used_roll_range_mm: (f64, f64),
    /// (w mm, f_nFS µm) of the dressed worm profile.
    profile_um: Vec<(f64, f64)>,
}

/// The worm of the `gearcomp dress` config at `path` dressed as its `[dressing]` table asks
/// ([`DressingInput::dress`]), tabulated for the grinding crate.
///
/// Glue between the crates (docs/grinding.md "Dressed worm"): both use the shared
/// [`Flank`]; (w, b) = (w1, z1); f_nFS (mm, normal) is tabulated as is and turned into
/// f_Ft1 = f_n/cos β_b1 by [`DressedWorm`].
fn dress_worm(
    path: &std::path::Path,
    flank: Flank,
) -> Result<(DressWorm, DressedProfile, DressedOut)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let cfg: GrindDressConfig =
        toml::from_str(&text).with_context(|| format!("invalid TOML in {}", path.display()))?;
    let wc = &cfg.worm;
    let design = DressWorm::design(
        wc.starts,
        wc.diameter_mm,
        wc.normal_module_mm,
        deg_to_rad(wc.profile_angle_deg),
    )
    .context("[worm]")?;
    let dresser = Dresser::design(
        &design,
        DresserSpec {
            d_a_mm: cfg.dresser.diameter_mm,
            jacket_width_mm: cfg.dresser.jacket_width_mm,
            clearance_mm: cfg.dresser.clearance_mm,
        },
    )
    .context("[dresser]")?;
    let t = cfg.dressing.dress(&design, &dresser, flank)?;
    let worm = t.worm;
    let profile = DressedProfile::new(
        flank,
        worm.r_b_mm,
        worm.beta_b_rad,
        t.roll_mm.clone(),
        t.f_mm.clone(),
        t.dressed_roll_range_mm,
        t.contact_line_rad,
    )
    .context("dressed profile table")?;
    let n = t.roll_mm.len();
    let step = (n - 1).div_ceil(20).max(1);
    let out = DressedOut {
        config: path.display().to_string(),
        correction: t.kind.name(),
        worm_starts: worm.z_s,
        worm_design_diameter_mm: worm.d_s0_mm,
        worm_diameter_mm: worm.d_s_mm,
        dresser_diameter_mm: cfg.dresser.diameter_mm,
        dphi_s_rad: t.dk.dphi_s_rad,
        dgamma_deg: rad_to_deg(t.dk.dgamma_rad),
        dd_mm: t.dk.dd_mm,
        dnu_ya_mm: t.dk.dnu_ya_mm,
        newton_iterations: t.iterations,
        rho_f1_deg: rad_to_deg(t.contact_line_rad),
        rho_f1_axial_section_estimate_deg: 0.0,
        dressed_roll_range_mm: t.dressed_roll_range_mm,
        dressed_radius_range_mm: profile.dressed_radius_range_mm(),
        used_roll_range_mm: (0.0, 0.0),
        profile_um: t
            .roll_mm
            .iter()
            .zip(&t.f_mm)
            .enumerate()
            .filter(|(i, _)| i % step == 0 || *i == n - 1)
            .map(|(_, (w, v))| (*w, mm_to_um(*v)))
            .collect(),
    };
    Ok((worm, profile, out))
}

fn simulate_dressed(a: &SimulateArgs, path: &std::path::Path) -> Result<()> {
    let flank = a.setup.flank;
    let (dworm, profile, mut dout) = dress_worm(path, flank)?;
    let s = setup(&a.setup, Some(&dworm))?;
    let worm = DressedWorm::new(profile, &s.pair.worm).context("dressed worm")?;
    worm.check_covers(&s.pair, s.grid.w_range_mm)
        .context("gear roll range (--roll-start-mm/--roll-end-mm) on the dressed worm")?;
    dout.used_roll_range_mm = DressedWorm::used_roll_range_mm(&s.pair, s.grid.w_range_mm);
    dout.rho_f1_axial_section_estimate_deg = rad_to_deg(rho1_estimate_rad(&s.pair));
    let rho1 = a.worm_rho_deg.map_or_else(|| worm.rho_f1_rad(), deg_to_rad);
    let (k, lm) = diagonal_choice(a, &s, rho1)?;
    let out = grind_and_report(
        "simulate",
        &s.pair,
        &s.gear,
        s.grid,
        Cones::CYLINDRICAL,
        &a.setup,
        k,
        lm,
        WormUsed::Dressed(&worm, Box::new(dout)),
        None,
        Extras {
            worm_radii_mm: Some(s.worm_radii_mm),
            ..Extras::default()
        },
    )?;
    emit(&out, &a.setup)
}

fn solve(a: SolveArgs) -> Result<()> {
    let c = cones(&a.setup)?;
    if !c.is_cylindrical() {
        return solve_conical(&a, c);
    }
    let s = setup(&a.setup, None)?;
    let rho1 = a
        .worm_rho_deg
        .map_or_else(|| rho1_estimate_rad(&s.pair), deg_to_rad);
    let wanted = LineModification::new(
        deg_to_rad(a.gear_rho_deg),
        s.pair.gear.w_ref_mm,
        poly_um(&a.gear_c),
        poly_um(&a.gear_l),
        poly_um(&a.gear_q),
    )
    .context("wanted gear modification")?;
    let opts = IterationOptions::default();
    let it = solve_iterated(
        &s.pair,
        &wanted,
        rho1,
        a.setup.shift_offset_mm,
        s.grid,
        s.worm_radii_mm,
        &opts,
    )
    .context(
        "worm modification for the wanted gear modification (iterated on the envelope; check \
         --gear-c/--gear-l/--gear-q, --worm-rho-deg, --roll-start-mm/--roll-end-mm and \
         --worm-root-radius-mm/--worm-tip-radius-mm)",
    )?;
    let (lm, worm_mod) = (it.line_map, it.worm.clone());
    // the same K from the closed form, as a cross-check of the line map
    let k = diagonal_ratio(&s.pair, rho1, wanted.rho_rad)?;
    let tol_mm = (opts.rel_tol * it.wish_max_abs_mm).max(opts.abs_tol_mm);
    let solve_out = SolveOut {
        iterations: it
            .iterations
            .iter()
            .map(|i| SolveIterationOut {
                iteration: i.iteration,
                max_abs_deviation_um: mm_to_um(i.max_abs_deviation_mm),
            })
            .collect(),
        wish_max_abs_um: mm_to_um(it.wish_max_abs_mm),
        remaining_um: mm_to_um(it.remaining_mm),
        remaining_percent_of_wish: if it.wish_max_abs_mm > 0.0 {
            100.0 * it.remaining_mm / it.wish_max_abs_mm
        } else {
            0.0
        },
        tolerance_um: mm_to_um(tol_mm),
        converged: it.converged,
        first_order_worm: LineModOut::from(&it.first_order_worm),
    };
    let out = grind_and_report(
        "solve",
        &s.pair,
        &s.gear,
        s.grid,
        Cones::CYLINDRICAL,
        &a.setup,
        k,
        Some(lm),
        WormUsed::Line(&worm_mod),
        Some(&wanted),
        Extras {
            worm_radii_mm: Some(s.worm_radii_mm),
            pre_ground: Some(it.ground),
            solve: Some(solve_out),
        },
    )?;
    emit(&out, &a.setup)
}

/// `solve` with a conical worm and/or workpiece (chains (29)–(31)): the conical line-class
/// transfer (`conical_lines::worm_modification_for_gear`), verified by the envelope simulation
/// of the worm it computes, as on the cylindrical chain.
///
/// ρ_F1 defaults to the axial-section estimate of the conical worm flank; the wanted gear
/// modification is referred to the gear flank's reference roll distance, the worm's to
/// w_01 = a'·w_02 + g (the worm roll distance along the gear line, docs/grinding.md).
fn solve_conical(a: &SolveArgs, c: Cones) -> Result<()> {
    let s = setup_conical(&a.setup, c)?;
    let rho1 = a
        .worm_rho_deg
        .map_or_else(|| conical::rho1_estimate_rad(&s.pair.worm), deg_to_rad);
    let wanted = LineModification::new(
        deg_to_rad(a.gear_rho_deg),
        s.pair.gear.w_ref_mm,
        poly_um(&a.gear_c),
        poly_um(&a.gear_l),
        poly_um(&a.gear_q),
    )
    .context("wanted gear modification")?;
    let (lm, worm_mod) =
        conical_lines::worm_modification_for_gear(&s.pair, &wanted, rho1, a.setup.shift_offset_mm)
            .context("worm modification for the wanted gear modification (conical chain)")?;
    let out = grind_and_report(
        "solve",
        &s.pair,
        &s.gear,
        s.grid,
        c,
        &a.setup,
        lm.line.k_zv1,
        Some(lm.line),
        WormUsed::Line(&worm_mod),
        Some(&wanted),
        Extras::default(),
    )?;
    emit(&out, &a.setup)
}

fn fmt_poly(v: &[f64]) -> String {
    if v.is_empty() {
        "0".into()
    } else {
        v.iter()
            .map(|c| format!("{c:.6e}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

fn table(out: &Output) -> String {
    let mut t = String::new();
    let p = &out.path;
    let _ = writeln!(t, "gearcomp grind {} — {} flank", out.mode, p.flank);
    if out.worm_cone_deg != 0.0 || out.gear_cone_deg != 0.0 {
        let chain = match (out.worm_cone_deg != 0.0, out.gear_cone_deg != 0.0) {
            (true, false) => "(29), conical worm",
            (false, true) => "(30), conical workpiece",
            _ => "(31), conical worm and workpiece",
        };
        let _ = writeln!(
            t,
            "  cone angles: worm ϑ1 {:.6}°, gear ϑ2 {:.6}° (chain {chain})",
            out.worm_cone_deg, out.gear_cone_deg
        );
    }
    let _ = writeln!(
        t,
        "  centre distance {:.6} mm, crossing angle {:.6}°",
        p.centre_distance_mm, p.crossing_deg
    );
    let _ = writeln!(
        t,
        "  contact path: C_Fw1 {:.6}  C_Fc1 {:.6} mm  C_Fw2 {:.6}  C_Fc2 {:.6} mm",
        p.c_w1, p.c_c1_mm, p.c_w2, p.c_c2_mm
    );
    match (&p.conical, p.r7_sum_mm) {
        (Some(c), _) => {
            let _ = writeln!(
                t,
                "  feed terms: C_FzV11 {:.6}  C_FzV21 {:.6}  C_FzV12 {:.6}  C_FzV22 {:.6}",
                c.c_zv11, c.c_zv21, c.c_zv12, c.c_zv22
            );
            let _ = writeln!(
                t,
                "  roll distances (86): w1 = {:.6}·w2 + {:.6}·z_V1 + {:.6}·z_V2 + {:.6} mm; \
                 ρ_KF {:.6}°",
                p.dw1_dw2, c.b_zv1, c.b_zv2, c.b_mm, p.rho_kf_deg
            );
        }
        (None, r7) => {
            let _ = writeln!(
                t,
                "  roll distances: dw1/dw2 {:.6}, w1/cos β_b1 + w2/cos β_b2 = {:.6} mm; ρ_KF {:.6}°",
                p.dw1_dw2,
                r7.unwrap_or(f64::NAN),
                p.rho_kf_deg
            );
        }
    }
    let _ = writeln!(
        t,
        "  diagonal ratio K_ZV1 {:.6}, shift offset z_V01 {:.3} mm",
        out.diagonal_ratio, out.shift_offset_mm
    );
    if let Some(lm) = &out.line_map {
        let _ = writeln!(
            t,
            "  line map X_F1 = {:.6}·X_F2 + {:.6} mm (ρ_F1 {:.4}°, ρ_F2 {:.4}°)",
            lm.k,
            lm.c0_mm,
            rad_to_deg(lm.rho1_rad),
            rad_to_deg(lm.rho2_rad)
        );
    }
    if let Some(wm) = &out.worm_modification {
        let _ = writeln!(
            t,
            "  worm modification (ρ_F1 {:.4}°, w0 {:.4} mm): F_C [{}] F_L [{}] F_Q [{}] (µm·mm⁻ᵏ)",
            wm.rho_deg,
            wm.w0_mm,
            fmt_poly(&wm.c_um),
            fmt_poly(&wm.l_um),
            fmt_poly(&wm.q_um)
        );
    }
    if let Some(d) = &out.dressed_worm {
        dressed_table(&mut t, d);
    }
    if let Some(g) = &out.wanted_gear_modification {
        let _ = writeln!(
            t,
            "  wanted gear modification (ρ_F2 {:.4}°, w0 {:.4} mm): F_C [{}] F_L [{}] F_Q [{}]",
            g.rho_deg,
            g.w0_mm,
            fmt_poly(&g.c_um),
            fmt_poly(&g.l_um),
            fmt_poly(&g.q_um)
        );
    }
    let _ = writeln!(
        t,
        "  ground flank: max |f_Ft2| {:.4} µm; envelope − analytic map: max {:.4} µm; \
         deviation from {}: max {:.4} µm",
        out.max_abs_ground_um,
        out.max_abs_ground_minus_analytic_um,
        out.deviation_reference,
        out.max_abs_deviation_um
    );
    let e = &out.iso1328;
    let tl = &e.tolerances;
    let _ = writeln!(
        t,
        "  ISO 1328-1:2013 class {} (profile at z = {:.2} mm over w {:.3}…{:.3} mm; helix at w = {:.3} mm over z {:.3}…{:.3} mm)",
        tl.class,
        e.profile_z_mm,
        e.profile.range_mm.0,
        e.profile.range_mm.1,
        e.helix_w_mm,
        e.helix.range_mm.0,
        e.helix.range_mm.1
    );
    let _ = writeln!(t, "    {:<6} {:>10} {:>10}  ok", "", "value µm", "tol µm");
    for (name, v, tol, ok) in iso_rows(e) {
        let _ = writeln!(
            t,
            "    {:<6} {:>10.3} {:>10.1}  {}",
            name,
            v,
            tol,
            if ok { "yes" } else { "NO" }
        );
    }
    let _ = writeln!(
        t,
        "  verdict: {}",
        if e.within_tolerance {
            "within tolerance"
        } else {
            "OUT of tolerance"
        }
    );
    let tr = &out.iso1328_traces;
    for (what, m) in [
        (
            format!("from the design ({})", tr.design_reference),
            &tr.from_design,
        ),
        ("from the unmodified flank".to_string(), &tr.from_involute),
    ] {
        let _ = writeln!(
            t,
            "  ISO 1328-1, 3 profile traces (z {}) and 3 helix traces (w {}), deviation {what}:",
            m.profiles
                .iter()
                .map(|p| format!("{:.2}", p.at_mm))
                .collect::<Vec<_>>()
                .join("/"),
            m.helices
                .iter()
                .map(|p| format!("{:.2}", p.at_mm))
                .collect::<Vec<_>>()
                .join("/")
        );
        let _ = writeln!(
            t,
            "    F_α {:.3}  f_fα {:.3}  f_Hα {:.3}  F_β {:.3}  f_fβ {:.3}  f_Hβ {:.3} µm; class {}: {}; \
             class achieved: {}",
            m.profile_worst.total_um,
            m.profile_worst.form_um,
            m.profile_worst.slope_um,
            m.helix_worst.total_um,
            m.helix_worst.form_um,
            m.helix_worst.slope_um,
            m.tolerances.class,
            if m.within_tolerance { "within" } else { "OUT" },
            m.class_achieved
                .map_or("worse than 11".to_string(), |c| c.to_string())
        );
    }
    let _ = writeln!(t, "  {}", tr.from_design.pitch);
    if let Some(sv) = &out.solve {
        let _ =
            writeln!(
            t,
            "  iterated solve: {} simulation(s), max |ground − wish| {} µm; remaining {:.4} µm \
             = {:.3} % of the wish {:.4} µm (tolerance {:.4} µm){}",
            sv.iterations.len(),
            sv.iterations
                .iter()
                .map(|i| format!("{:.4}", i.max_abs_deviation_um))
                .collect::<Vec<_>>()
                .join(" → "),
            sv.remaining_um,
            sv.remaining_percent_of_wish,
            sv.wish_max_abs_um,
            sv.tolerance_um,
            if sv.converged { "" } else { " — NOT converged" }
        );
    }
    if let Some((root, tip)) = out.worm_radii_mm {
        let _ = writeln!(t, "  worm thread between r = {root:.4} and {tip:.4} mm");
    }
    for w in &out.warnings {
        let _ = writeln!(t, "  WARNING: {w}");
    }
    t
}

fn dressed_table(t: &mut String, d: &DressedOut) {
    let _ = writeln!(
        t,
        "  dressed worm ({}): {} start(s), d_S0 {:.3} mm, d_S {:.3} mm, dresser d_A {:.3} mm, \
         correction: {}{}",
        d.config,
        d.worm_starts,
        d.worm_design_diameter_mm,
        d.worm_diameter_mm,
        d.dresser_diameter_mm,
        d.correction,
        d.newton_iterations
            .map_or(String::new(), |n| format!(" ({n} Newton iterations)"))
    );
    let _ = writeln!(
        t,
        "    ΔK: Δφ_S {:.6e} rad, Δγ {:.6}°, Δd {:.6} mm, Δν_yA {:.6} mm",
        d.dphi_s_rad, d.dgamma_deg, d.dd_mm, d.dnu_ya_mm
    );
    let _ = writeln!(
        t,
        "    dressed w {:.4}…{:.4} mm (r {:.4}…{:.4} mm); used by the gear w {:.4}…{:.4} mm; \
         ρ_F1 (37) {:.4}° (axial-section estimate {:.4}°)",
        d.dressed_roll_range_mm.0,
        d.dressed_roll_range_mm.1,
        d.dressed_radius_range_mm.0,
        d.dressed_radius_range_mm.1,
        d.used_roll_range_mm.0,
        d.used_roll_range_mm.1,
        d.rho_f1_deg,
        d.rho_f1_axial_section_estimate_deg
    );
    let _ = writeln!(t, "    {:>10} {:>12}", "w1 mm", "f_nFS µm");
    for (w, f) in &d.profile_um {
        let _ = writeln!(t, "    {w:>10.4} {f:>12.5}");
    }
}

fn iso_rows(e: &FlankEvaluation) -> Vec<(&'static str, f64, f64, bool)> {
    let t = &e.tolerances;
    vec![
        (
            "F_α",
            e.profile.total_um,
            t.total_alpha_t_um,
            e.profile.total_um <= t.total_alpha_t_um,
        ),
        (
            "f_fα",
            e.profile.form_um,
            t.f_f_alpha_t_um,
            e.profile.form_um <= t.f_f_alpha_t_um,
        ),
        (
            "f_Hα",
            e.profile.slope_um,
            t.f_h_alpha_t_um,
            e.profile.slope_um.abs() <= t.f_h_alpha_t_um,
        ),
        (
            "F_β",
            e.helix.total_um,
            t.total_beta_t_um,
            e.helix.total_um <= t.total_beta_t_um,
        ),
        (
            "f_fβ",
            e.helix.form_um,
            t.f_f_beta_t_um,
            e.helix.form_um <= t.f_f_beta_t_um,
        ),
        (
            "f_Hβ",
            e.helix.slope_um,
            t.f_h_beta_t_um,
            e.helix.slope_um.abs() <= t.f_h_beta_t_um,
        ),
    ]
}

fn emit(out: &Output, a: &SetupArgs) -> Result<()> {
    if let Some(path) = &a.report {
        write_report(out, path)?;
    }
    if a.json {
        for w in &out.warnings {
            eprintln!("warning: {w}");
        }
        println!("{}", serde_json::to_string_pretty(out)?);
    } else {
        print!("{}", table(out));
        if let Some(p) = &a.report {
            println!("  report: {}", p.display());
        }
    }
    Ok(())
}

/// SVG heat map of a (w, z) map: w to the right, z upwards (drawn by the report crate).
fn heat_map_svg(title: &str, map: &MapOut, values: &[Vec<f64>]) -> String {
    let w = HeatAxis::new("w", "roll distance", "mm", map.w_mm.clone());
    let z = HeatAxis::new("z", "width", "mm", map.z_mm.clone());
    HeatMap {
        title,
        x: &w,
        y: &z,
        value_unit: "µm",
        cells: values,
    }
    .to_svg()
}

fn write_report(out: &Output, path: &std::path::Path) -> Result<()> {
    let mut r = HtmlReport::new(format!(
        "gearcomp grind {} — {} flank",
        out.mode, out.path.flank
    ));
    r.heading("Set-up and results").preformatted(&table(out));
    r.paragraph(
        "Deviations are transverse (f_Ft, along the base tangent), in µm, positive = material \
         left on the gear. The ground flank is the envelope of the worm over rotation and feed; \
         the analytic map is the first-order worm→gear mapping along the contact path.",
    );
    r.heading("Ground flank over (w, z)");
    r.raw_svg(&heat_map_svg(
        "ground f_Ft2 / µm",
        &out.map,
        &out.map.ground_um,
    ));
    r.heading(&format!("Deviation from the {}", out.deviation_reference));
    r.raw_svg(&heat_map_svg(
        "deviation / µm",
        &out.map,
        &out.map.deviation_um,
    ));
    // profile and helix traces of the deviation map at the evaluation lines
    let e = &out.iso1328;
    let jz = nearest(&out.map.z_mm, e.profile_z_mm);
    let iw = nearest(&out.map.w_mm, e.helix_w_mm);
    let prof: Vec<(f64, f64)> = out
        .map
        .w_mm
        .iter()
        .zip(&out.map.deviation_um)
        .map(|(w, row)| (*w, row[jz]))
        .collect();
    let helix: Vec<(f64, f64)> = out
        .map
        .z_mm
        .iter()
        .zip(&out.map.deviation_um[iw])
        .map(|(z, v)| (*z, *v))
        .collect();
    let prof_an: Vec<(f64, f64)> = out
        .map
        .w_mm
        .iter()
        .zip(out.map.ground_um.iter().zip(&out.map.analytic_um))
        .map(|(w, (g, a))| (*w, g[jz] - a[jz]))
        .collect();
    r.chart(
        &Chart::new(
            format!("Profile deviation at z = {:.2} mm", out.map.z_mm[jz]),
            "roll distance w / mm",
            "deviation / µm",
        )
        .with(Series::line("deviation", prof))
        .with(Series::line("envelope − analytic map", prof_an)),
    )?;
    r.chart(
        &Chart::new(
            format!("Helix deviation at w = {:.3} mm", out.map.w_mm[iw]),
            "width z / mm",
            "deviation / µm",
        )
        .with(Series::line("deviation", helix)),
    )?;
    r.heading("ISO 1328-1:2013 evaluation");
    let rows: Vec<Vec<String>> = iso_rows(e)
        .into_iter()
        .map(|(n, v, t, ok)| {
            vec![
                n.to_string(),
                format!("{v:.3}"),
                format!("{t:.1}"),
                if ok { "yes".into() } else { "NO".into() },
            ]
        })
        .collect();
    r.table(
        &["quantity", "value / µm", "tolerance / µm", "within"],
        &rows,
    );
    r.paragraph(&format!(
        "Class {}; profile evaluation range {:.3}…{:.3} mm of roll distance (95 % of the active \
         profile from its start), helix evaluation range {:.3}…{:.3} mm (face width less min(5 % b, \
         m_n) per end). Verdict: {}.",
        e.tolerances.class,
        e.profile.range_mm.0,
        e.profile.range_mm.1,
        e.helix.range_mm.0,
        e.helix.range_mm.1,
        if e.within_tolerance { "within tolerance" } else { "out of tolerance" }
    ));
    r.write(path)
        .with_context(|| format!("writing report {}", path.display()))?;
    Ok(())
}

fn nearest(v: &[f64], x: f64) -> usize {
    v.iter()
        .enumerate()
        .fold((0, f64::INFINITY), |(bi, bd), (i, y)| {
            let d = (y - x).abs();
            if d < bd {
                (i, d)
            } else {
                (bi, bd)
            }
        })
        .0
}

/// A `gearcomp grind` config (`grind equalise`): gear and worm bodies, cone angles included.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GrindConfig {
    gear: GearCfg,
    worm: WormCfg,
    equalise: EqualiseCfg,
}

/// [gear] of a grind config.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GearCfg {
    teeth: u32,
    module_mm: f64,
    /// Right flank (both flanks if `pressure_angle_left_deg` is absent).
    pressure_angle_deg: f64,
    pressure_angle_left_deg: Option<f64>,
    helix_angle_deg: f64,
    /// Workpiece cone angle ϑ2 (0 = cylindrical gear, chain (28)/(29)).
    #[serde(default)]
    cone_angle_deg: f64,
}

/// [worm] of a grind config.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct WormCfg {
    starts: u32,
    radius_mm: f64,
    #[serde(default = "default_hand")]
    hand: String,
    /// The worm's present cone angle ϑ1; `equalise` reports both flanks' K at it, next to the
    /// equalising ϑ1 it searches (0 = cylindrical worm).
    #[serde(default)]
    cone_angle_deg: f64,
}

fn default_hand() -> String {
    "right".to_owned()
}

/// [equalise] of a grind config.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EqualiseCfg {
    /// Wanted modification direction ρ_r2 on the gear's right flank.
    gear_rho_right_deg: f64,
    /// ρ_l2 (raw flank convention: a mirror-symmetric modification has ρ_l2 = −ρ_r2).
    gear_rho_left_deg: f64,
    /// Worm line directions ρ_r1/ρ_l1 (dresser contact lines, eq. (37)); both or neither
    /// (neither = the axial-section estimate of each conical worm flank).
    worm_rho_right_deg: Option<f64>,
    worm_rho_left_deg: Option<f64>,
    #[serde(default = "default_cone_min")]
    cone_min_deg: f64,
    #[serde(default = "default_cone_max")]
    cone_max_deg: f64,
}

fn default_cone_min() -> f64 {
    -15.0
}

fn default_cone_max() -> f64 {
    15.0
}

#[derive(Debug, Serialize)]
struct FlankKOut {
    cone1_deg: f64,
    k_left: f64,
    k_right: f64,
    rho1_left_deg: f64,
    rho1_right_deg: f64,
}

#[derive(Debug, Serialize)]
struct EqualiseOut {
    mode: &'static str,
    gear_cone_deg: f64,
    gear_rho_left_deg: f64,
    gear_rho_right_deg: f64,
    worm_lines: &'static str,
    cone_range_deg: (f64, f64),
    /// The equalising worm cone angle ϑ1.
    cone1_deg: f64,
    /// The common diagonal ratio (mean of the two flanks' values at ϑ1).
    k_zv1: f64,
    /// Both flanks at ϑ1.
    equalised: FlankKOut,
    /// Both flanks at the worm's present cone angle ([worm] cone_angle_deg).
    at_given_cone: FlankKOut,
}

fn flank_k_out(cone1_rad: f64, r: (f64, f64, f64, f64)) -> FlankKOut {
    FlankKOut {
        cone1_deg: rad_to_deg(cone1_rad),
        k_left: r.0,
        k_right: r.1,
        rho1_left_deg: rad_to_deg(r.2),
        rho1_right_deg: rad_to_deg(r.3),
    }
}

/// The T14 search input from a grind config.
fn equalise_spec(c: &GrindConfig) -> Result<EqualiseSpec> {
    let g = &c.gear;
    let alpha_r = deg_to_rad(g.pressure_angle_deg);
    let alpha_l = deg_to_rad(g.pressure_angle_left_deg.unwrap_or(g.pressure_angle_deg));
    let gear = InvoluteGear::asymmetric(
        g.teeth,
        g.module_mm,
        alpha_r,
        alpha_l,
        deg_to_rad(g.helix_angle_deg),
        0.0,
    )
    .context("[gear]")?;
    let gear =
        BeveloidGear::new(gear, deg_to_rad(g.cone_angle_deg)).context("[gear] cone_angle_deg")?;
    let hand = match c.worm.hand.as_str() {
        "right" => Hand::Right,
        "left" => Hand::Left,
        other => {
            anyhow::bail!("[worm] hand = {other:?} is not allowed: expected \"right\" or \"left\"")
        }
    };
    let w = InvoluteGear::worm(c.worm.starts, g.module_mm, alpha_r, c.worm.radius_mm, hand)
        .context("[worm]")?;
    // (93): equal normal base pitch per flank with equal m_n fixes the worm rack's α_nF.
    let worm = InvoluteGear::asymmetric(w.teeth, w.m_n_mm, alpha_r, alpha_l, w.beta_rad, 0.0)
        .context("[worm]")?;
    let e = &c.equalise;
    let worm_lines = match (e.worm_rho_left_deg, e.worm_rho_right_deg) {
        (Some(l), Some(r)) => WormLines::Given {
            left_rad: deg_to_rad(l),
            right_rad: deg_to_rad(r),
        },
        (None, None) => WormLines::AxialSection,
        _ => anyhow::bail!(
            "[equalise] worm_rho_left_deg / worm_rho_right_deg: give both (dresser contact \
             lines) or neither (axial-section estimate)"
        ),
    };
    Ok(EqualiseSpec {
        worm,
        gear,
        rho2_left_rad: deg_to_rad(e.gear_rho_left_deg),
        rho2_right_rad: deg_to_rad(e.gear_rho_right_deg),
        worm_lines,
        cone_range_rad: (deg_to_rad(e.cone_min_deg), deg_to_rad(e.cone_max_deg)),
    })
}

/// `grind equalise`: T14 on a config, ϑ1 and both flanks' K.
fn equalise(a: EqualiseArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.config)
        .with_context(|| format!("reading {}", a.config.display()))?;
    let cfg: GrindConfig =
        toml::from_str(&text).with_context(|| format!("parsing {}", a.config.display()))?;
    let spec = equalise_spec(&cfg)?;
    let given = deg_to_rad(cfg.worm.cone_angle_deg);
    let at_given = flank_ratios(&spec, given).context("[worm] cone_angle_deg")?;
    let e: Equalised = match equalise_worm_cone_angle(&spec) {
        Ok(e) => e,
        Err(GrindError::NoRoot { at_min, at_max, .. }) => anyhow::bail!(
            "no worm cone angle in [{}°, {}°] ([equalise] cone_min_deg/cone_max_deg) gives both \
             flanks the same diagonal ratio: K_l − K_r = {at_min:.6} at {}° and {at_max:.6} at \
             {}° (no sign change); widen the range, or change the worm lines or the wanted \
             directions",
            cfg.equalise.cone_min_deg,
            cfg.equalise.cone_max_deg,
            cfg.equalise.cone_min_deg,
            cfg.equalise.cone_max_deg
        ),
        Err(other) => return Err(other).context("[equalise]"),
    };
    let out = EqualiseOut {
        mode: "equalise",
        gear_cone_deg: cfg.gear.cone_angle_deg,
        gear_rho_left_deg: cfg.equalise.gear_rho_left_deg,
        gear_rho_right_deg: cfg.equalise.gear_rho_right_deg,
        worm_lines: match spec.worm_lines {
            WormLines::Given { .. } => "given",
            WormLines::AxialSection => "axial-section estimate",
        },
        cone_range_deg: (cfg.equalise.cone_min_deg, cfg.equalise.cone_max_deg),
        cone1_deg: rad_to_deg(e.cone1_rad),
        k_zv1: e.k_zv1,
        equalised: flank_k_out(
            e.cone1_rad,
            (e.k_left, e.k_right, e.rho1_left_rad, e.rho1_right_rad),
        ),
        at_given_cone: flank_k_out(given, at_given),
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print!("{}", equalise_table(&out));
    }
    Ok(())
}

fn equalise_table(o: &EqualiseOut) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "gearcomp grind equalise: worm cone angle for two-flank diagonal grinding (A6/T14)"
    );
    let _ = writeln!(
        t,
        "  gear cone ϑ2 = {:.6}°, wanted ρ_l2 = {:.6}°, ρ_r2 = {:.6}°, worm lines: {}",
        o.gear_cone_deg, o.gear_rho_left_deg, o.gear_rho_right_deg, o.worm_lines
    );
    let _ = writeln!(
        t,
        "  searched ϑ1 in [{}°, {}°]",
        o.cone_range_deg.0, o.cone_range_deg.1
    );
    let _ = writeln!(t, "  worm cone ϑ1 = {:.6}°", o.cone1_deg);
    let _ = writeln!(t, "  common K_ZV1 = {:.6}", o.k_zv1);
    let _ = writeln!(
        t,
        "  {:<22} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "", "ϑ1 [°]", "K_l", "K_r", "ρ_l1 [°]", "ρ_r1 [°]"
    );
    for (name, f) in [
        ("equalised", &o.equalised),
        ("given [worm] cone", &o.at_given_cone),
    ] {
        let _ = writeln!(
            t,
            "  {:<22} {:>12.6} {:>12.6} {:>12.6} {:>12.6} {:>12.6}",
            name, f.cone1_deg, f.k_left, f.k_right, f.rho1_left_deg, f.rho1_right_deg
        );
    }
    t
}
