//! `gearcomp gear`: cylindrical involute gear geometry (ISO 21771 / DIN 3960) from flags or
//! a TOML file, printed as a table with units or as JSON.
//!
//! Degrees exist only here: [`rad`] converts every input angle, [`deg`] every output
//! angle. The library works in mm and rad.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Context};
use gearcomp_geometry::units::{deg_to_rad as rad, rad_to_deg as deg};
use gearcomp_geometry::{
    shift_sum_for_centre_distance, BallMeasurement, BasicRack, Gear, GearDimensions, GearPair,
    GearSpec, GeometryError, Hand, Mesh, PairGeometry, Span,
};
use serde::{Deserialize, Serialize};

const AFTER_HELP: &str = "\
Conventions (docs/geometry.md): lengths in mm, angles in degrees. An internal gear is given
with a positive tooth count and --internal. The profile shift x has the ISO 21771 sense for
both kinds of gear: x > 0 makes the tooth thicker. Thickness allowances A_sn are on the normal
tooth thickness at the reference circle; negative values thin the tooth (give them as
\"lower,upper\", e.g. --allowances=-0.06,-0.03).

Examples:
  gearcomp gear --module 1 --teeth 20 --span-k 2 --ball 1.7
  gearcomp gear --module 1 --teeth 30 --allowances=-0.06,-0.03 --ball 1.7 --json
  gearcomp gear --module 3.5 --helix 21 --teeth 31 --width 30 --mate-teeth 30 --centre-distance 116.5
  gearcomp gear --file gear.toml      (keys as the flags: module = 3.5, pressure-angle = 20,
                                       helix = 21, teeth = 31, internal = false, ...)";

/// Options of `gearcomp gear`.
#[derive(Debug, Default, clap::Args, Deserialize)]
#[command(after_help = AFTER_HELP)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub struct Args {
    /// Normal module m_n in mm (> 0).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    module: Option<f64>,
    /// Normal pressure angle α_n in degrees (0 < α_n < 45) [default: 20].
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pressure_angle: Option<f64>,
    /// Helix angle β at the reference circle in degrees, signed as in ISO 21771:
    /// positive = right hand, negative = left hand, 0 = spur (−60 < β < 60) [default: 0].
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    helix: Option<f64>,
    /// Number of teeth z (3 … 10000; positive also for an internal gear).
    #[arg(long, value_name = "Z", allow_negative_numbers = true)]
    teeth: Option<u32>,
    /// Profile shift coefficient x (dimensionless; x·m_n is the shift in mm; x > 0 thickens
    /// the tooth) [default: 0].
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    shift: Option<f64>,
    /// Face width b in mm (for the overlap ratio and the helical span check).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    width: Option<f64>,
    /// The gear has internal teeth (a ring gear).
    #[arg(long)]
    #[serde(default)]
    internal: bool,
    /// Normal tooth-thickness allowances A_sn in mm: "lower,upper" or one value; negative
    /// thins the tooth (e.g. --allowances=-0.06,-0.03).
    #[arg(
        long,
        value_name = "MM[,MM]",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    allowances: Option<Vec<f64>>,
    /// Ball diameter D_M in mm for the dimension over (internal: between) balls
    /// [default: the recommended ball, touching at d + 2·x·m_n].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    ball: Option<f64>,
    /// Number of teeth (internal: spaces) k spanned for W_k, 1 … z−1 [default: recommended].
    #[arg(long, value_name = "K", allow_negative_numbers = true)]
    span_k: Option<u32>,
    /// Diameters in mm at which to print the tooth thickness (comma-separated).
    #[arg(
        long,
        value_name = "MM[,MM...]",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    at_diameter: Option<Vec<f64>>,
    /// Basic rack addendum coefficient h_aP* in units of m_n [default: 1.0, DIN 867].
    #[arg(long, value_name = "COEFF", allow_negative_numbers = true)]
    addendum_coeff: Option<f64>,
    /// Basic rack dedendum coefficient h_fP* in units of m_n [default: 1.25, DIN 867].
    #[arg(long, value_name = "COEFF", allow_negative_numbers = true)]
    dedendum_coeff: Option<f64>,
    /// Basic rack root radius coefficient ρ_fP* in units of m_n [default: 0.25, DIN 867].
    #[arg(long, value_name = "COEFF", allow_negative_numbers = true)]
    root_radius_coeff: Option<f64>,
    /// Mating gear: number of teeth z2 (external gear; the pinion if this gear is internal).
    #[arg(long, value_name = "Z", allow_negative_numbers = true)]
    mate_teeth: Option<u32>,
    /// Mating gear: profile shift coefficient x2 [default: the rest of Σx for zero backlash at
    /// --centre-distance, else 0].
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    mate_shift: Option<f64>,
    /// Mating gear: normal tooth-thickness allowances in mm, "lower,upper" [default: 0].
    #[arg(
        long,
        value_name = "MM[,MM]",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    mate_allowances: Option<Vec<f64>>,
    /// Mating gear: face width in mm [default: --width].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    mate_width: Option<f64>,
    /// Working centre distance a_w in mm [default: zero backlash at x + x2].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    centre_distance: Option<f64>,
    /// TOML file with the same names as the flags (e.g. `module = 3.5`,
    /// `pressure-angle = 20`, `allowances = [-0.06, -0.03]`); flags given on the command
    /// line take precedence.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    file: Option<PathBuf>,
    /// Print JSON for machines instead of the table.
    #[arg(long)]
    #[serde(skip)]
    json: bool,
}

impl Args {
    /// Fills every option not given on the command line from the TOML file.
    fn merge_file(mut self) -> anyhow::Result<Args> {
        let Some(path) = self.file.clone() else {
            return Ok(self);
        };
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("reading {}", path.display()))?;
        let f: Args =
            toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        macro_rules! fill {
            ($($field:ident),*) => { $( if self.$field.is_none() { self.$field = f.$field; } )* };
        }
        fill!(
            module,
            pressure_angle,
            helix,
            teeth,
            shift,
            width,
            allowances,
            ball,
            span_k,
            at_diameter,
            addendum_coeff,
            dedendum_coeff,
            root_radius_coeff,
            mate_teeth,
            mate_shift,
            mate_allowances,
            mate_width,
            centre_distance
        );
        self.internal |= f.internal;
        Ok(self)
    }
}

/// Output: the gear.
#[derive(Debug, Serialize)]
struct GearOut {
    mesh: Mesh,
    /// "right", "left" or "spur".
    hand: &'static str,
    teeth: u32,
    normal_module_mm: f64,
    normal_pressure_angle_deg: f64,
    /// Signed: + right hand, − left hand.
    helix_angle_deg: f64,
    profile_shift: f64,
    face_width_mm: Option<f64>,
    transverse_module_mm: f64,
    transverse_pressure_angle_deg: f64,
    base_helix_angle_deg: f64,
    lead_mm: Option<f64>,
    reference_diameter_mm: f64,
    base_diameter_mm: f64,
    tip_diameter_mm: f64,
    root_diameter_mm: f64,
    root_form_diameter_mm: Option<f64>,
    normal_pitch_mm: f64,
    transverse_pitch_mm: f64,
    normal_base_pitch_mm: f64,
    transverse_base_pitch_mm: f64,
    min_shift_undercut: Option<f64>,
    overlap_ratio: Option<f64>,
}

impl GearOut {
    fn new(g: &Gear) -> GearOut {
        let s = g.spec();
        let d: &GearDimensions = g.dims();
        let spur = s.helix_angle_rad == 0.0;
        let signed = s.hand.sign();
        GearOut {
            mesh: s.mesh,
            hand: if spur { "spur" } else { s.hand.name() },
            teeth: s.teeth,
            normal_module_mm: s.normal_module_mm,
            normal_pressure_angle_deg: deg(s.normal_pressure_angle_rad),
            helix_angle_deg: signed * deg(s.helix_angle_rad),
            profile_shift: s.profile_shift,
            face_width_mm: s.face_width_mm,
            transverse_module_mm: d.transverse_module_mm,
            transverse_pressure_angle_deg: deg(d.transverse_pressure_angle_rad),
            base_helix_angle_deg: deg(d.base_helix_angle_rad),
            lead_mm: d.lead_mm,
            reference_diameter_mm: d.reference_diameter_mm,
            base_diameter_mm: d.base_diameter_mm,
            tip_diameter_mm: d.tip_diameter_mm,
            root_diameter_mm: d.root_diameter_mm,
            root_form_diameter_mm: d.root_form_diameter_mm,
            normal_pitch_mm: d.normal_pitch_mm,
            transverse_pitch_mm: d.transverse_pitch_mm,
            normal_base_pitch_mm: d.normal_base_pitch_mm,
            transverse_base_pitch_mm: d.transverse_base_pitch_mm,
            min_shift_undercut: d.min_shift_undercut,
            overlap_ratio: d.overlap_ratio,
        }
    }
}

/// Output: the tooth at one generating profile shift (nominal or an allowance).
#[derive(Debug, Serialize)]
struct ToothOut {
    /// "nominal", "lower" or "upper".
    case: &'static str,
    allowance_mm: f64,
    generating_shift: f64,
    normal_thickness_mm: f64,
    transverse_thickness_mm: f64,
    transverse_space_width_mm: f64,
    tip_normal_thickness_mm: f64,
    root_diameter_mm: f64,
    root_form_diameter_mm: Option<f64>,
    span: Span,
    ball: BallMeasurement,
}

/// Output: thickness at a requested diameter (nominal shift).
#[derive(Debug, Serialize)]
struct AtDiameterOut {
    diameter_mm: f64,
    transverse_thickness_mm: f64,
    normal_thickness_mm: f64,
    transverse_space_width_mm: f64,
}

/// Output: backlash of the pair for one combination of allowances.
#[derive(Debug, Serialize)]
struct BacklashOut {
    /// "max" (both lower allowances), "min" (both upper) or "nominal".
    case: &'static str,
    allowance_1_mm: f64,
    allowance_2_mm: f64,
    generating_shift_1: f64,
    generating_shift_2: f64,
    circumferential_mm: f64,
    normal_mm: f64,
}

/// Output: the pair.
#[derive(Debug, Serialize)]
struct PairOut {
    /// Which gear is gear 1 (the external one): "this" or "mate".
    gear_1: &'static str,
    mate: GearOut,
    gear_ratio: f64,
    reference_centre_distance_mm: f64,
    centre_distance_mm: f64,
    working_pressure_angle_deg: f64,
    shift_sum: f64,
    nominal_shift_sum: f64,
    working_diameter_1_mm: f64,
    working_diameter_2_mm: f64,
    transverse_contact_ratio: f64,
    overlap_ratio: Option<f64>,
    total_contact_ratio: Option<f64>,
    transverse_base_pitch_mm: f64,
    normal_base_pitch_mm: f64,
    active_root_diameter_1_mm: Option<f64>,
    active_root_diameter_2_mm: Option<f64>,
    backlash: Vec<BacklashOut>,
}

/// Output: recommended measurement settings at the nominal shift.
#[derive(Debug, Serialize)]
struct RecommendedOut {
    span_k: u32,
    ball_mm: f64,
}

/// The whole result of `gearcomp gear`.
#[derive(Debug, Serialize)]
struct Output {
    gear: GearOut,
    recommended: RecommendedOut,
    tooth: Vec<ToothOut>,
    at_diameter: Vec<AtDiameterOut>,
    pair: Option<PairOut>,
    warnings: Vec<String>,
}

/// The command-line option (and TOML key) a library parameter name comes from.
fn flag_of(name: &str) -> Option<&'static str> {
    let table: [(&str, &str); 19] = [
        ("tip diameter d_a (internal", "--shift"),
        ("root diameter d_f", "--teeth"),
        ("teeth of the internal gear", "--teeth/--mate-teeth"),
        ("shift_sum", "--shift/--mate-shift/--centre-distance"),
        ("centre_distance_mm", "--centre-distance"),
        ("span axial", "--width"),
        ("normal_module_mm", "--module"),
        ("normal_pressure_angle", "--pressure-angle"),
        ("helix_angle", "--helix"),
        ("teeth", "--teeth"),
        ("profile_shift", "--shift"),
        ("face_width_mm", "--width"),
        ("addendum_coeff", "--addendum-coeff"),
        ("dedendum_coeff", "--dedendum-coeff"),
        ("root_radius_coeff", "--root-radius-coeff"),
        ("span_k", "--span-k"),
        ("ball_mm", "--ball"),
        ("diameter_mm", "--at-diameter"),
        ("thickness_allowance_mm", "--allowances"),
    ];
    table
        .iter()
        .find(|(lib, _)| name.starts_with(lib))
        .map(|(_, flag)| *flag)
}

/// A geometry error prefixed with the option the user wrote (the library names its own
/// parameters), then with what was being computed.
fn flagged(e: GeometryError, what: &str) -> anyhow::Error {
    let name = match e {
        GeometryError::OutOfRange { name, .. }
        | GeometryError::OffFlank { name, .. }
        | GeometryError::SpanTooWide { name, .. }
        | GeometryError::BallOffFlank { name, .. }
        | GeometryError::PointedTooth { name, .. } => Some(name),
        _ => None,
    };
    match name.and_then(flag_of) {
        Some(flag) => anyhow::anyhow!("{what}: {flag}: {e}"),
        None => anyhow::anyhow!("{what}: {e}"),
    }
}

/// [`flagged`] for the mating gear: its own options are --mate-shift, --mate-teeth and
/// --mate-width; the rest it shares with this gear.
fn flagged_mate(e: GeometryError, what: &str) -> anyhow::Error {
    let name = match e {
        GeometryError::OutOfRange { name, .. } | GeometryError::PointedTooth { name, .. } => {
            Some(name)
        }
        _ => None,
    };
    let flag = name.and_then(|n| {
        if n.starts_with("profile_shift") || n.starts_with("tip diameter d_a (internal") {
            Some("--mate-shift")
        } else if n.starts_with("teeth") || n.starts_with("root diameter d_f") {
            Some("--mate-teeth")
        } else if n.starts_with("face_width_mm") {
            Some("--mate-width")
        } else {
            flag_of(n)
        }
    });
    match flag {
        Some(flag) => anyhow::anyhow!("{what}: {flag}: {e}"),
        None => anyhow::anyhow!("{what}: {e}"),
    }
}

/// Splits "lower,upper" (or one value) into (lower, upper) pairs labelled for the output.
fn allowance_cases(a: Option<&[f64]>, what: &str) -> anyhow::Result<Vec<(&'static str, f64)>> {
    match a {
        None | Some([]) => Ok(vec![]),
        Some([one]) => Ok(vec![("lower", *one), ("upper", *one)]),
        Some([a, b]) => Ok(vec![("lower", a.min(*b)), ("upper", a.max(*b))]),
        Some(v) => bail!(
            "{what} takes one or two values (lower,upper) in mm, got {} values",
            v.len()
        ),
    }
}

/// Runs `gearcomp gear`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let args = args.merge_file()?;
    let json = args.json;
    let out = compute(&args)?;
    let text = if json {
        serde_json::to_string_pretty(&out)? + "\n"
    } else {
        render(&out)
    };
    use std::io::Write as _;
    std::io::stdout().write_all(text.as_bytes())?;
    Ok(())
}

fn compute(args: &Args) -> anyhow::Result<Output> {
    let Some(module) = args.module else {
        bail!("--module (normal module m_n in mm) is required (flag or `module` in --file)");
    };
    let Some(teeth) = args.teeth else {
        bail!("--teeth (number of teeth z) is required (flag or `teeth` in --file)");
    };
    let helix_deg = args.helix.unwrap_or(0.0);
    if !(helix_deg.is_finite() && helix_deg.abs() < 60.0) {
        bail!("invalid helix = {helix_deg} °: expected −60 < β < 60 ° (sign = hand)");
    }
    let hand = if helix_deg < 0.0 {
        Hand::Left
    } else {
        Hand::Right
    };
    let rack = BasicRack {
        addendum_coeff: args
            .addendum_coeff
            .unwrap_or(BasicRack::DIN_867.addendum_coeff),
        dedendum_coeff: args
            .dedendum_coeff
            .unwrap_or(BasicRack::DIN_867.dedendum_coeff),
        root_radius_coeff: args
            .root_radius_coeff
            .unwrap_or(BasicRack::DIN_867.root_radius_coeff),
    };
    let spec = GearSpec {
        normal_module_mm: module,
        normal_pressure_angle_rad: rad(args.pressure_angle.unwrap_or(20.0)),
        helix_angle_rad: rad(helix_deg.abs()),
        hand,
        teeth,
        mesh: if args.internal {
            Mesh::Internal
        } else {
            Mesh::External
        },
        profile_shift: args.shift.unwrap_or(0.0),
        face_width_mm: args.width,
        rack,
    };
    let gear = Gear::new(spec).map_err(|e| flagged(e, "the gear"))?;
    let x = spec.profile_shift;
    let m_n = spec.normal_module_mm;
    let mut warnings = Vec::new();
    if let Some(u) = gear.undercut("--shift", x) {
        warnings.push(u.to_string());
    }

    let mut cases = vec![("nominal", 0.0, x)];
    for (case, allowance) in allowance_cases(args.allowances.as_deref(), "--allowances")? {
        let x_e = gear
            .generating_shift(allowance)
            .map_err(|e| flagged(e, &format!("{case} thickness allowance")))?;
        cases.push((case, allowance, x_e));
    }
    let shifts: Vec<f64> = cases.iter().map(|c| c.2).collect();
    // A k the user gave is checked first, so its own error is the one reported.
    if let Some(k) = args.span_k {
        for (case, _, x_e) in &cases {
            gear.span(k, *x_e)
                .map_err(|e| flagged(e, &format!("span W_k, {case} thickness")))?;
        }
    }
    let rec_k = gear.recommended_span_k_for(x, &shifts).map_err(|e| {
        let flag = match e {
            GeometryError::SpanTooWide { .. } => "--width",
            _ => "--span-k",
        };
        anyhow::anyhow!("no span measurement W_k fits this gear ({flag}): {e}")
    })?;
    let rec_ball = gear
        .recommended_ball_mm(x)
        .map_err(|e| flagged(e, "recommended ball"))?;
    let k = args.span_k.unwrap_or(rec_k);
    let ball = args.ball.unwrap_or(rec_ball);

    let mut tooth = Vec::new();
    for (case, allowance, x_e) in cases {
        if case != "nominal" {
            if let Some(u) = gear.undercut("generating shift x_E", x_e) {
                if gear.undercut("--shift", x).is_none() {
                    warnings.push(format!("{case}: {u}"));
                }
            }
        }
        let d = gear.dims().reference_diameter_mm;
        let span = gear
            .span(k, x_e)
            .map_err(|e| flagged(e, &format!("span W_k, {case} thickness")))?;
        let ball_m = gear
            .ball_dimension(ball, x_e)
            .map_err(|e| flagged(e, &format!("dimension over balls, {case} thickness")))?;
        if !ball_m.protrudes_beyond_tip {
            warnings.push(format!(
                "{case}: the {ball} mm ball does not stand out beyond the tip circle; M_dK cannot be taken with flat anvils"
            ));
        }
        let s_an = gear.tip_normal_thickness_mm(x_e)?;
        if s_an < 0.2 * m_n {
            warnings.push(format!(
                "{case}: tip thickness s_an = {s_an:.4} mm is below 0.2·m_n = {:.4} mm (DIN 3960 guideline)",
                0.2 * m_n
            ));
        }
        tooth.push(ToothOut {
            case,
            allowance_mm: allowance,
            generating_shift: x_e,
            normal_thickness_mm: gear.normal_thickness_at_reference_mm(x_e),
            transverse_thickness_mm: gear.transverse_thickness_at_mm(d, x_e)?,
            transverse_space_width_mm: gear.space_width_at_mm(d, x_e)?,
            tip_normal_thickness_mm: s_an,
            root_diameter_mm: gear.root_diameter_mm(x_e),
            root_form_diameter_mm: gear.root_form_diameter_mm(x_e),
            span,
            ball: ball_m,
        });
    }

    let mut at_diameter = Vec::new();
    // The tooth exists between the base circle (external; inside it there is no involute)
    // or the tip circle (internal) and the tip (external) or root (internal) circle.
    let (d_lo, d_hi) = match spec.mesh {
        Mesh::External => (gear.dims().base_diameter_mm, gear.dims().tip_diameter_mm),
        Mesh::Internal => (gear.dims().tip_diameter_mm, gear.dims().root_diameter_mm),
    };
    for &d_y in args.at_diameter.as_deref().unwrap_or(&[]) {
        if !(d_y.is_finite() && d_y >= d_lo - 1e-9 && d_y <= d_hi + 1e-9) {
            bail!(
                "thickness at diameter: --at-diameter {d_y} mm is outside the tooth: allowed \
                 {d_lo:.4} … {d_hi:.4} mm ({})",
                match spec.mesh {
                    Mesh::External => "base circle d_b to tip circle d_a",
                    Mesh::Internal => "tip circle d_a to root circle d_f",
                }
            );
        }
        at_diameter.push(AtDiameterOut {
            diameter_mm: d_y,
            transverse_thickness_mm: gear
                .transverse_thickness_at_mm(d_y, x)
                .map_err(|e| flagged(e, "thickness at diameter"))?,
            normal_thickness_mm: gear
                .normal_thickness_at_mm(d_y, x)
                .map_err(|e| flagged(e, "thickness at diameter"))?,
            transverse_space_width_mm: gear
                .space_width_at_mm(d_y, x)
                .map_err(|e| flagged(e, "thickness at diameter"))?,
        });
    }

    let pair = match args.mate_teeth {
        None => {
            if args.centre_distance.is_some() || args.mate_shift.is_some() {
                bail!("--centre-distance and --mate-shift need --mate-teeth (the mating gear)");
            }
            None
        }
        Some(z2) => Some(compute_pair(args, &gear, z2, &mut warnings)?),
    };

    Ok(Output {
        gear: GearOut::new(&gear),
        recommended: RecommendedOut {
            span_k: rec_k,
            ball_mm: rec_ball,
        },
        tooth,
        at_diameter,
        pair,
        warnings,
    })
}

fn compute_pair(
    args: &Args,
    gear: &Gear,
    mate_teeth: u32,
    warnings: &mut Vec<String>,
) -> anyhow::Result<PairOut> {
    let spec = *gear.spec();
    let internal = spec.mesh == Mesh::Internal;
    let mut mate_spec = spec;
    mate_spec.teeth = mate_teeth;
    mate_spec.mesh = Mesh::External;
    mate_spec.face_width_mm = args.mate_width.or(spec.face_width_mm);
    // External pairs have opposite hands, internal pairs the same hand.
    mate_spec.hand = if internal {
        spec.hand
    } else {
        spec.hand.opposite()
    };
    // Gear 1 is the external gear: the mate when this gear is internal.
    let order = |this: GearSpec, mate: GearSpec| if internal { (mate, this) } else { (this, mate) };
    let x2 = match (args.mate_shift, args.centre_distance) {
        (Some(x2), _) => x2,
        (None, Some(a_w)) => {
            let (s1, s2) = order(spec, mate_spec);
            let sum =
                shift_sum_for_centre_distance(&s1, &s2, a_w).map_err(|e| flagged(e, "the pair"))?;
            sum - spec.profile_shift
        }
        (None, None) => 0.0,
    };
    mate_spec.profile_shift = x2;
    let mate = Gear::new(mate_spec).map_err(|e| flagged_mate(e, "the mating gear"))?;
    if let Some(u) = mate.undercut("--mate-shift", x2) {
        warnings.push(format!("mating gear: {u}"));
    }
    let (g1, g2) = if internal {
        (&mate, gear)
    } else {
        (gear, &mate)
    };
    let a_w = match args.centre_distance {
        Some(a) => a,
        None => gearcomp_geometry::centre_distance_for_shift_sum(
            g1.spec(),
            g2.spec(),
            g1.spec().profile_shift + g2.spec().profile_shift,
        )
        .map_err(|e| flagged(e, "the pair"))?,
    };
    let pair = GearPair::new(g1, g2, a_w).map_err(|e| flagged(e, "the pair"))?;
    let p: &PairGeometry = pair.geometry();

    let this_cases = allowance_cases(args.allowances.as_deref(), "--allowances")?;
    let mate_cases = allowance_cases(args.mate_allowances.as_deref(), "--mate-allowances")?;
    let pick = |c: &[(&'static str, f64)], i: usize| c.get(i).map_or(0.0, |v| v.1);
    let mut combos = vec![("nominal", 0.0, 0.0)];
    if !this_cases.is_empty() || !mate_cases.is_empty() {
        combos.push(("max", pick(&this_cases, 0), pick(&mate_cases, 0)));
        combos.push(("min", pick(&this_cases, 1), pick(&mate_cases, 1)));
    }
    let mut backlash = Vec::new();
    for (case, a_this, a_mate) in combos {
        let (a1, a2) = if internal {
            (a_mate, a_this)
        } else {
            (a_this, a_mate)
        };
        let b = pair
            .backlash(a1, a2)
            .map_err(|e| flagged(e, &format!("backlash, {case}")))?;
        if b.normal_mm < -1e-9 {
            warnings.push(format!(
                "{case} backlash j_bn = {:.4} mm is negative: the teeth would jam at a_w = {a_w} mm",
                b.normal_mm
            ));
        }
        backlash.push(BacklashOut {
            case,
            allowance_1_mm: a1,
            allowance_2_mm: a2,
            generating_shift_1: b.generating_shift_1,
            generating_shift_2: b.generating_shift_2,
            circumferential_mm: b.circumferential_mm,
            normal_mm: b.normal_mm,
        });
    }
    if p.transverse_contact_ratio < 1.0 {
        warnings.push(format!(
            "transverse contact ratio ε_α = {:.4} < 1",
            p.transverse_contact_ratio
        ));
    }
    for (i, g, d_nf) in [
        (1, g1, p.active_root_diameter_1_mm),
        (2, g2, p.active_root_diameter_2_mm),
    ] {
        let (lo, hi) = g.flank_range_mm(g.spec().profile_shift);
        let ok = d_nf.is_some_and(|d| {
            if i == 1 || !internal {
                d >= lo
            } else {
                d <= hi
            }
        });
        if !ok {
            warnings.push(format!(
                "gear {i}: the mate's tip reaches below the usable involute (active root {:?} mm, flank {lo:.4} … {hi:.4} mm): interference",
                d_nf
            ));
        }
    }
    Ok(PairOut {
        gear_1: if internal { "mate" } else { "this" },
        mate: GearOut::new(&mate),
        gear_ratio: p.gear_ratio,
        reference_centre_distance_mm: p.reference_centre_distance_mm,
        centre_distance_mm: p.centre_distance_mm,
        working_pressure_angle_deg: deg(p.working_pressure_angle_rad),
        shift_sum: p.shift_sum,
        nominal_shift_sum: p.nominal_shift_sum,
        working_diameter_1_mm: p.working_diameter_1_mm,
        working_diameter_2_mm: p.working_diameter_2_mm,
        transverse_contact_ratio: p.transverse_contact_ratio,
        overlap_ratio: p.overlap_ratio,
        total_contact_ratio: p.total_contact_ratio,
        transverse_base_pitch_mm: p.transverse_base_pitch_mm,
        normal_base_pitch_mm: p.normal_base_pitch_mm,
        active_root_diameter_1_mm: p.active_root_diameter_1_mm,
        active_root_diameter_2_mm: p.active_root_diameter_2_mm,
        backlash,
    })
}

/// One table row: description, symbol, value, unit.
fn row(out: &mut String, label: &str, symbol: &str, value: String, unit: &str) {
    let _ = writeln!(out, "  {label:<42} {symbol:<6} {value:>12} {unit}");
}

fn num(v: f64, places: usize) -> String {
    format!("{v:.places$}")
}

fn opt(v: Option<f64>, places: usize) -> String {
    v.map_or_else(|| "–".to_string(), |v| num(v, places))
}

fn render_gear(out: &mut String, g: &GearOut) {
    row(out, "mesh", "", format!("{:?}", g.mesh).to_lowercase(), "");
    row(out, "number of teeth", "z", g.teeth.to_string(), "");
    row(
        out,
        "normal module",
        "m_n",
        num(g.normal_module_mm, 4),
        "mm",
    );
    row(
        out,
        "normal pressure angle",
        "α_n",
        num(g.normal_pressure_angle_deg, 4),
        "°",
    );
    let hand = format!("° ({})", g.hand);
    row(
        out,
        "helix angle",
        "β",
        num(g.helix_angle_deg.abs(), 4),
        &hand,
    );
    row(
        out,
        "profile shift coefficient",
        "x",
        num(g.profile_shift, 4),
        "",
    );
    row(out, "face width", "b", opt(g.face_width_mm, 3), "mm");
    row(
        out,
        "transverse module",
        "m_t",
        num(g.transverse_module_mm, 4),
        "mm",
    );
    row(
        out,
        "transverse pressure angle",
        "α_t",
        num(g.transverse_pressure_angle_deg, 4),
        "°",
    );
    row(
        out,
        "base helix angle",
        "β_b",
        num(g.base_helix_angle_deg, 4),
        "°",
    );
    row(out, "lead", "p_z", opt(g.lead_mm, 3), "mm");
    row(
        out,
        "reference diameter",
        "d",
        num(g.reference_diameter_mm, 4),
        "mm",
    );
    row(
        out,
        "base diameter",
        "d_b",
        num(g.base_diameter_mm, 4),
        "mm",
    );
    row(out, "tip diameter", "d_a", num(g.tip_diameter_mm, 4), "mm");
    row(
        out,
        "root diameter",
        "d_f",
        num(g.root_diameter_mm, 4),
        "mm",
    );
    row(
        out,
        "root form diameter",
        "d_Ff",
        opt(g.root_form_diameter_mm, 4),
        "mm",
    );
    row(
        out,
        "normal base pitch",
        "p_bn",
        num(g.normal_base_pitch_mm, 4),
        "mm",
    );
    row(
        out,
        "transverse base pitch",
        "p_bt",
        num(g.transverse_base_pitch_mm, 4),
        "mm",
    );
    row(
        out,
        "smallest shift without undercut",
        "x_min",
        opt(g.min_shift_undercut, 4),
        "",
    );
    row(out, "overlap ratio", "ε_β", opt(g.overlap_ratio, 4), "");
}

fn render(o: &Output) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "Gear (ISO 21771 / DIN 3960)");
    render_gear(&mut out, &o.gear);
    let _ = writeln!(out, "\nTooth thickness and measurement");
    for t in &o.tooth {
        let _ = writeln!(out, " [{}] A_sn = {:+.4} mm", t.case, t.allowance_mm);
        row(
            &mut out,
            "generating profile shift",
            "x_E",
            num(t.generating_shift, 4),
            "",
        );
        row(
            &mut out,
            "normal tooth thickness",
            "s_n",
            num(t.normal_thickness_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "transverse tooth thickness",
            "s_t",
            num(t.transverse_thickness_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "transverse space width",
            "e_t",
            num(t.transverse_space_width_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "normal tip thickness",
            "s_an",
            num(t.tip_normal_thickness_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "root diameter",
            "d_f",
            num(t.root_diameter_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "root form diameter",
            "d_Ff",
            opt(t.root_form_diameter_mm, 4),
            "mm",
        );
        row(
            &mut out,
            &format!(
                "span over k = {} (contact d_M {:.3})",
                t.span.k, t.span.contact_diameter_mm
            ),
            "W_k",
            num(t.span.span_mm, 4),
            "mm",
        );
        row(
            &mut out,
            &format!(
                "over balls D_M = {:.4} (contact {:.3})",
                t.ball.ball_mm, t.ball.contact_diameter_mm
            ),
            "M_dK",
            num(t.ball.dimension_mm, 4),
            "mm",
        );
    }
    let _ = writeln!(
        out,
        " recommended: k = {}, ball D_M = {:.4} mm (touching at d + 2·x·m_n)",
        o.recommended.span_k, o.recommended.ball_mm
    );
    if !o.at_diameter.is_empty() {
        let _ = writeln!(out, "\nThickness at diameter (nominal shift)");
        for a in &o.at_diameter {
            row(
                &mut out,
                &format!("at d_y = {}", a.diameter_mm),
                "s_yt",
                num(a.transverse_thickness_mm, 4),
                "mm",
            );
            row(&mut out, "", "s_yn", num(a.normal_thickness_mm, 4), "mm");
            row(
                &mut out,
                "",
                "e_yt",
                num(a.transverse_space_width_mm, 4),
                "mm",
            );
        }
    }
    if let Some(p) = &o.pair {
        let _ = writeln!(
            out,
            "\nMating gear (gear 1 = {} gear)",
            if p.gear_1 == "this" { "this" } else { "mating" }
        );
        render_gear(&mut out, &p.mate);
        let _ = writeln!(out, "\nPair");
        row(&mut out, "gear ratio", "u", num(p.gear_ratio, 4), "");
        row(
            &mut out,
            "reference centre distance",
            "a",
            num(p.reference_centre_distance_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "working centre distance",
            "a_w",
            num(p.centre_distance_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "working pressure angle",
            "α_wt",
            num(p.working_pressure_angle_deg, 4),
            "°",
        );
        row(
            &mut out,
            "sum of shifts for zero backlash",
            "Σx",
            num(p.shift_sum, 6),
            "",
        );
        row(
            &mut out,
            "sum of nominal shifts",
            "x1+x2",
            num(p.nominal_shift_sum, 6),
            "",
        );
        row(
            &mut out,
            "working diameter gear 1",
            "d_w1",
            num(p.working_diameter_1_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "working diameter gear 2",
            "d_w2",
            num(p.working_diameter_2_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "transverse contact ratio",
            "ε_α",
            num(p.transverse_contact_ratio, 4),
            "",
        );
        row(
            &mut out,
            "overlap ratio",
            "ε_β",
            opt(p.overlap_ratio, 4),
            "",
        );
        row(
            &mut out,
            "total contact ratio",
            "ε_γ",
            opt(p.total_contact_ratio, 4),
            "",
        );
        row(
            &mut out,
            "active root diameter gear 1",
            "d_Nf1",
            opt(p.active_root_diameter_1_mm, 4),
            "mm",
        );
        row(
            &mut out,
            "active root diameter gear 2",
            "d_Nf2",
            opt(p.active_root_diameter_2_mm, 4),
            "mm",
        );
        for b in &p.backlash {
            row(
                &mut out,
                &format!(
                    "backlash {} (A_sn {:+.3}/{:+.3})",
                    b.case, b.allowance_1_mm, b.allowance_2_mm
                ),
                "j_bn",
                num(b.normal_mm, 4),
                "mm",
            );
            row(&mut out, "", "j_wt", num(b.circumferential_mm, 4), "mm");
        }
    }
    for w in &o.warnings {
        let _ = writeln!(out, "warning: {w}");
    }
    out
}
