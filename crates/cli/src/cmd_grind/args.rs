//! `gearcomp grind` command-line arguments (clap).

use super::*;

/// Options of `gearcomp grind`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub(super) command: GrindCommand,
}

#[derive(Debug, Subcommand)]
pub(super) enum GrindCommand {
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
pub(super) struct SetupArgs {
    /// Gear: number of teeth z2.
    #[arg(long, default_value_t = 31)]
    pub(super) teeth: u32,
    /// Normal module m_n in mm (gear and worm).
    #[arg(long, default_value_t = 3.0)]
    pub(super) module_mm: f64,
    /// Normal pressure angle in degrees (right flank; both flanks if --pressure-angle-left-deg
    /// is not given).
    #[arg(long, default_value_t = 20.0)]
    pub(super) pressure_angle_deg: f64,
    /// Normal pressure angle of the left flank in degrees (asymmetric teeth).
    #[arg(long)]
    pub(super) pressure_angle_left_deg: Option<f64>,
    /// Gear helix angle in degrees, signed (> 0 right hand).
    #[arg(long, default_value_t = 15.0, allow_hyphen_values = true)]
    pub(super) helix_angle_deg: f64,
    /// Face width b in mm (the flank spans z = −b/2 … b/2).
    #[arg(long, default_value_t = 30.0)]
    pub(super) face_width_mm: f64,
    /// Worm: number of starts z1.
    #[arg(long, default_value_t = 1)]
    pub(super) worm_starts: u32,
    /// Worm reference (pitch) radius in mm.
    #[arg(long, default_value_t = 130.0)]
    pub(super) worm_radius_mm: f64,
    /// Worm tip radius in mm: the thread grinds only between root and tip
    /// [default: worm radius + 1.25·m_n; with --dress the dressed worm's tip].
    #[arg(long)]
    pub(super) worm_tip_radius_mm: Option<f64>,
    /// Worm root radius in mm [default: worm radius − 1.25·m_n; with --dress the dressed
    /// worm's root].
    #[arg(long)]
    pub(super) worm_root_radius_mm: Option<f64>,
    /// Profile shift coefficient x of the gear (the worm runs at d = r1 + r2 + x·m_n).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub(super) profile_shift: f64,
    /// Worm hand.
    #[arg(long, value_enum, default_value_t = Hand::Right)]
    pub(super) worm_hand: Hand,
    /// Flank to grind.
    #[arg(long, value_enum, default_value_t = Flank::Right)]
    pub(super) flank: Flank,
    /// Start of the active profile (roll distance) in mm [default: w_P − 2·m_n].
    #[arg(long)]
    pub(super) roll_start_mm: Option<f64>,
    /// End of the active profile (roll distance) in mm [default: min(w_P + 2·m_n, tip)].
    #[arg(long)]
    pub(super) roll_end_mm: Option<f64>,
    /// Grid points along the profile.
    #[arg(long, default_value_t = 25)]
    pub(super) grid_w: usize,
    /// Grid points along the face width.
    #[arg(long, default_value_t = 31)]
    pub(super) grid_z: usize,
    /// Worm shift offset z_V01 in mm (selects the worm region).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub(super) shift_offset_mm: f64,
    /// ISO 1328-1:2013 accuracy class for the evaluation.
    #[arg(long, default_value_t = 6)]
    pub(super) class: u8,
    /// Workpiece cone angle ϑ2 in degrees (beveloid gear, chains (30)/(31); > 0: the reference
    /// cone grows towards +z). 0 = cylindrical gear.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub(super) gear_cone_deg: f64,
    /// Worm cone angle ϑ1 in degrees (conical worm, chains (29)/(31); > 0: the reference cone
    /// grows towards +z of the worm). 0 = cylindrical worm.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub(super) worm_cone_deg: f64,
    /// Print JSON instead of tables.
    #[arg(long)]
    pub(super) json: bool,
    /// Write an HTML report to this file.
    #[arg(long)]
    pub(super) report: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub(super) struct SimulateArgs {
    #[command(flatten)]
    pub(super) setup: SetupArgs,
    /// Diagonal ratio K_ZV1 (0 = axial grinding) [default: the K that maps --worm-rho-deg
    /// onto --gear-rho-deg if that is given, else 0].
    #[arg(long, allow_hyphen_values = true)]
    pub(super) diagonal_ratio: Option<f64>,
    /// Gear line direction ρ_F2 in degrees used to choose K when --diagonal-ratio is absent.
    #[arg(long, allow_hyphen_values = true)]
    pub(super) gear_rho_deg: Option<f64>,
    /// Worm modification line direction ρ_F1 in degrees [default: axial-section estimate].
    #[arg(long, allow_hyphen_values = true)]
    pub(super) worm_rho_deg: Option<f64>,
    /// Worm F_C(X) coefficients in µm, µm/mm, µm/mm², … (comma separated).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub(super) worm_c: Vec<f64>,
    /// Worm F_L(X) coefficients (per mm of w − w_P1): µm/mm, µm/mm², …
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub(super) worm_l: Vec<f64>,
    /// Worm F_Q(X) coefficients (per mm² of (w − w_P1)²): µm/mm², µm/mm³, …
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub(super) worm_q: Vec<f64>,
    /// Grind with a worm dressed by the dressing module: a `gearcomp dress` TOML ([worm],
    /// [dresser]) with an optional [dressing] table (ΔK or 3-point crowning). The worm geometry
    /// then comes from the file (--worm-starts/--worm-radius-mm are not used).
    #[arg(long, value_name = "CONFIG.toml", conflicts_with_all = ["worm_c", "worm_l", "worm_q"])]
    pub(super) dress: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub(super) struct SolveArgs {
    #[command(flatten)]
    pub(super) setup: SetupArgs,
    /// Direction ρ_F2 of the wanted gear modification lines in degrees (0 = lead, 90 = profile).
    #[arg(long, allow_hyphen_values = true)]
    pub(super) gear_rho_deg: f64,
    /// Wanted F_C(X) coefficients in µm, µm/mm, µm/mm², … (comma separated).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub(super) gear_c: Vec<f64>,
    /// Wanted F_L(X) coefficients (per mm of w − w_P2): µm/mm, µm/mm², …
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub(super) gear_l: Vec<f64>,
    /// Wanted F_Q(X) coefficients (per mm² of (w − w_P2)²): µm/mm², …
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub(super) gear_q: Vec<f64>,
    /// Worm modification line direction ρ_F1 in degrees (dresser contact line)
    /// [default: axial-section estimate].
    #[arg(long, allow_hyphen_values = true)]
    pub(super) worm_rho_deg: Option<f64>,
}

#[derive(Debug, clap::Args)]
pub(super) struct EqualiseArgs {
    /// Grind config: [gear], [worm] (with `cone_angle_deg` for each body) and [equalise].
    #[arg(value_name = "CONFIG.toml")]
    pub(super) config: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub(super) json: bool,
}
