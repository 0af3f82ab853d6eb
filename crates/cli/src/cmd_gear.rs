//! `gearcomp gear`: cylindrical involute gear geometry (ISO 21771 / DIN 3960) from flags or
//! a TOML file, printed as a table with units or as JSON.
//!
//! Glue: the options (degrees converted by [`rad`]) become a
//! [`GearRequest`]; [`GearReport`] (`gearcomp_geometry::report`) computes the report and renders
//! its table; this file maps the library's parameter names in errors to the options.

use std::path::PathBuf;

use anyhow::{bail, Context};
use gearcomp_geometry::report::{tooth_extent, GearReport, GearRequest, MateRequest, ReportError};
use gearcomp_geometry::units::{deg_to_rad as rad, fmt_value};
use gearcomp_geometry::{BasicRack, GearSpec, GeometryError, Hand, Mesh};
use serde::Deserialize;

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
    /// Normal pressure angle α_n in degrees (0 < α_n < 45, and below atan(π/(4·h_fP*)),
    /// where the tool tooth becomes pointed: 32.14 for the DIN 867 rack) [default: 20].
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
        allow_hyphen_values = true,
        value_parser = finite_mm
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
    /// Basic rack dedendum coefficient h_fP* in units of m_n (above h_aP*, at most 3 and
    /// below π/(4·tan α_n), where the tool tooth becomes pointed) [default: 1.25, DIN 867].
    #[arg(long, value_name = "COEFF", allow_negative_numbers = true)]
    dedendum_coeff: Option<f64>,
    /// Basic rack root radius coefficient ρ_fP* in units of m_n [default: 0.25, DIN 867;
    /// above about 25° of pressure angle, where the tool tip cannot carry 0.25, the largest it
    /// can (a full-radius tip)].
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
        allow_hyphen_values = true,
        value_parser = finite_mm
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

/// An allowance in mm as written on the command line: a finite number (clap then names the
/// option and the value as written when it is not).
fn finite_mm(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err("not a finite number of mm (allowances are \"lower,upper\" in mm)".into()),
        Err(e) => Err(format!("{e} (allowances are \"lower,upper\" in mm)")),
    }
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

/// The command-line option (and TOML key) a library parameter name comes from.
fn flag_of(name: &str) -> Option<&'static str> {
    let table: [(&str, &str); 19] = [
        ("tip diameter d_a", "--shift"),
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
        | GeometryError::PointedTooth { name, .. }
        | GeometryError::DedendumRange { name, .. }
        | GeometryError::PointedTool { name, .. } => Some(name),
        _ => None,
    };
    match name.and_then(flag_of) {
        Some(flag) => anyhow::anyhow!("{what}: {flag}: {e}"),
        None => anyhow::anyhow!("{what}: {e}"),
    }
}

/// [`flagged`] for the mating gear: its own options are --mate-shift (or --centre-distance
/// when x2 is derived from it: `shift_flag`), --mate-teeth and --mate-width; the rest it
/// shares with this gear.
fn flagged_mate(e: GeometryError, what: &str, shift_flag: &str) -> anyhow::Error {
    let name = match e {
        GeometryError::OutOfRange { name, .. } | GeometryError::PointedTooth { name, .. } => {
            Some(name)
        }
        _ => None,
    };
    let flag = name.and_then(|n| {
        if n.starts_with("profile_shift") || n.starts_with("tip diameter d_a") {
            Some(shift_flag)
        } else if n.starts_with("teeth") || n.starts_with("root diameter d_f") {
            Some("--mate-teeth")
        } else if n.starts_with("face_width_mm") {
            Some("--mate-width")
        } else if n.starts_with("thickness_allowance_mm")
            || n.starts_with("generating profile shift x_E")
        {
            Some("--mate-allowances")
        } else {
            flag_of(n)
        }
    });
    match flag {
        Some(flag) => anyhow::anyhow!("{what}: {flag}: {e}"),
        None => anyhow::anyhow!("{what}: {e}"),
    }
}

/// Splits "lower,upper" (or one value) into (lower, upper); a NaN or infinite value is
/// refused here (sorting would drop a NaN silently: min/max ignore it).
fn allowance_pair(a: Option<&[f64]>, what: &str) -> anyhow::Result<Option<(f64, f64)>> {
    if let Some(bad) = a.and_then(|v| v.iter().find(|x| !x.is_finite())) {
        let written = a
            .unwrap_or_default()
            .iter()
            .map(|x| fmt_value(*x))
            .collect::<Vec<_>>()
            .join(",");
        bail!(
            "{what}={written}: {} is not a number of mm; give finite allowances \
             \"lower,upper\" in mm (each within ±0.5·m_n)",
            fmt_value(*bad)
        );
    }
    match a {
        None | Some([]) => Ok(None),
        Some([one]) => Ok(Some((*one, *one))),
        Some([a, b]) => Ok(Some((a.min(*b), a.max(*b)))),
        Some(v) => bail!(
            "{what} takes one or two values (lower,upper) in mm, got {} values",
            v.len()
        ),
    }
}

/// A report error with the option the user wrote; `mate_shift_flag` names where the mate's
/// shift x2 came from.
fn report_error(e: ReportError, mate_shift_flag: &str) -> anyhow::Error {
    match e {
        ReportError::Step {
            what,
            mate: false,
            source,
        } => flagged(source, &what),
        ReportError::Step {
            what,
            mate: true,
            source,
        } => flagged_mate(source, &what, mate_shift_flag),
        ReportError::NoSpan(e) => {
            let flag = match e {
                GeometryError::SpanTooWide { .. } => "--width",
                _ => "--span-k",
            };
            anyhow::anyhow!("no span measurement W_k fits this gear ({flag}): {e}")
        }
        ReportError::OutsideTooth {
            diameter_mm,
            lo_mm,
            hi_mm,
            mesh,
        } => anyhow::anyhow!(
            "thickness at diameter: --at-diameter {diameter_mm} mm is outside the tooth: \
             allowed {lo_mm:.4} … {hi_mm:.4} mm ({})",
            tooth_extent(mesh)
        ),
        e @ ReportError::Geometry(_) => e.into(),
    }
}

/// Runs `gearcomp gear`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let args = args.merge_file()?;
    let req = request(&args)?;
    let mate_shift_flag = req.mate.as_ref().map_or("--mate-shift", |m| m.shift_name);
    let out = GearReport::compute(&req).map_err(|e| match e {
        // A pointed tool tooth: the pressure angle's fault, and the dedendum's too when the
        // user gave it (the limit is the rack's).
        ReportError::Step {
            what,
            source: source @ GeometryError::PointedTool { .. },
            ..
        } if args.dedendum_coeff.is_some() => {
            anyhow::anyhow!("{what}: --pressure-angle/--dedendum-coeff: {source}")
        }
        e => report_error(e, mate_shift_flag),
    })?;
    let text = if args.json {
        serde_json::to_string_pretty(&out)? + "\n"
    } else {
        out.to_table()
    };
    use std::io::Write as _;
    std::io::stdout().write_all(text.as_bytes())?;
    Ok(())
}

/// The gear from the options (degrees → rad, sign of the helix → hand).
fn spec(args: &Args) -> anyhow::Result<GearSpec> {
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
    let din = BasicRack::DIN_867;
    let alpha_n = rad(args.pressure_angle.unwrap_or(20.0));
    let rack = BasicRack {
        addendum_coeff: args.addendum_coeff.unwrap_or(din.addendum_coeff),
        dedendum_coeff: args.dedendum_coeff.unwrap_or(din.dedendum_coeff),
        root_radius_coeff: args.root_radius_coeff.unwrap_or(din.root_radius_coeff),
    };
    // DIN 867's 0.25 where the tool tip carries it, else the full-radius tip, so the default
    // rack works up to the pointed tool; a radius the user gave is checked as given.
    let rack = match args.root_radius_coeff {
        Some(_) => rack,
        None => rack.root_radius_carried_at(alpha_n),
    };
    Ok(GearSpec {
        normal_module_mm: module,
        normal_pressure_angle_rad: alpha_n,
        helix_angle_rad: rad(helix_deg.abs()),
        hand: if helix_deg < 0.0 {
            Hand::Left
        } else {
            Hand::Right
        },
        teeth,
        mesh: if args.internal {
            Mesh::Internal
        } else {
            Mesh::External
        },
        profile_shift: args.shift.unwrap_or(0.0),
        face_width_mm: args.width,
        rack,
    })
}

/// The library request from the options.
fn request(args: &Args) -> anyhow::Result<GearRequest> {
    let spec = spec(args)?;
    let allowances_mm = allowance_pair(args.allowances.as_deref(), "--allowances")?;
    let mate = match args.mate_teeth {
        None => {
            let given = [
                ("--centre-distance", args.centre_distance.is_some()),
                ("--mate-shift", args.mate_shift.is_some()),
                ("--mate-allowances", args.mate_allowances.is_some()),
                ("--mate-width", args.mate_width.is_some()),
            ];
            if let Some((flag, _)) = given.iter().find(|(_, set)| *set) {
                bail!("{flag} needs --mate-teeth (the mating gear); it would be ignored");
            }
            None
        }
        Some(teeth) => Some(MateRequest {
            teeth,
            // x2 derived from a_w: its errors and warnings name --centre-distance
            shift_name: match (args.mate_shift, args.centre_distance) {
                (None, Some(_)) => "x2 (from --centre-distance)",
                _ => "--mate-shift",
            },
            profile_shift: args.mate_shift,
            allowances_mm: allowance_pair(args.mate_allowances.as_deref(), "--mate-allowances")?,
            face_width_mm: args.mate_width,
            centre_distance_mm: args.centre_distance,
        }),
    };
    Ok(GearRequest {
        spec,
        shift_name: "--shift",
        allowances_mm,
        span_k: args.span_k,
        ball_mm: args.ball,
        at_diameters_mm: args.at_diameter.clone().unwrap_or_default(),
        mate,
    })
}
