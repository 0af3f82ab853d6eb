//! The set-up of `gearcomp grind` from its arguments and TOML configs: gear, worm, flank
//! grid and cones from the options, the dressed worm of `--dress`, the `equalise` config.

use super::*;

pub(super) struct Setup {
    pub(super) pair: WormGearPair,
    pub(super) gear: InvoluteGear,
    pub(super) grid: FlankGrid,
    /// Worm root and tip radii in mm.
    pub(super) worm_radii_mm: (f64, f64),
}

/// Cone angles of worm (ϑ1) and workpiece (ϑ2), rad, in the library's convention: ϑ > 0 when
/// the body's reference cone grows towards +z of that body (docs/grinding.md "Conical tool and
/// workpiece").
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Cones {
    pub(super) worm_rad: f64,
    pub(super) gear_rad: f64,
    /// The values as given at the interface (reported unchanged).
    pub(super) worm_deg: f64,
    pub(super) gear_deg: f64,
}

impl Cones {
    pub(super) const CYLINDRICAL: Cones = Cones {
        worm_rad: 0.0,
        gear_rad: 0.0,
        worm_deg: 0.0,
        gear_deg: 0.0,
    };

    pub(super) fn is_cylindrical(&self) -> bool {
        self.worm_rad == 0.0 && self.gear_rad == 0.0
    }
}

/// --worm-cone-deg / --gear-cone-deg, range-checked against the library's limit
/// ([`MAX_CONE_ANGLE_RAD`], 50°) and converted to rad.
pub(super) fn cones(a: &SetupArgs) -> Result<Cones> {
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

pub(super) fn flank_arg(a: &SetupArgs) -> Flank {
    a.flank
}

pub(super) fn hand_arg(a: &SetupArgs) -> Hand {
    a.worm_hand
}

/// The options of the gear body, named in its range errors.
const GEAR_OPTIONS: setup::GearInputNames = setup::GearInputNames {
    teeth: "--teeth",
    module: "--module-mm",
    pressure_angle: "--pressure-angle-deg",
    pressure_angle_left: "--pressure-angle-left-deg",
    helix_angle: "--helix-angle-deg",
};

/// The gear body (cylinder, or the beveloid's body at z = 0) from the set-up options.
pub(super) fn gear_body(a: &SetupArgs) -> Result<InvoluteGear> {
    setup::gear_from_input(
        &GEAR_OPTIONS,
        a.teeth,
        a.module_mm,
        a.pressure_angle_deg,
        a.pressure_angle_left_deg,
        a.helix_angle_deg,
        a.profile_shift,
    )
    .map_err(|e| gear_error(&e))
}

/// A gear error with the option the user wrote.
pub(super) fn gear_error(e: &GrindError) -> anyhow::Error {
    let field = match e {
        // already named by its option (setup::check_gear_input)
        GrindError::OutOfRange { field, .. } if field.starts_with("--") => {
            return anyhow::anyhow!("{e}")
        }
        GrindError::OutOfRange { field, .. } => *field,
        GrindError::Geometry(g) => match g {
            GeometryError::OutOfRange { name, .. } => name,
            GeometryError::Undercut { .. } | GeometryError::PointedTooth { .. } => "profile_shift",
            GeometryError::PointedTool { .. } => "normal_pressure_angle",
            _ => "",
        },
        _ => "",
    };
    let opt = match field {
        "teeth" => "--teeth",
        "m_n_mm" | "normal_module_mm" => "--module-mm",
        "alpha_n_right_deg" | "normal_pressure_angle" => "--pressure-angle-deg",
        "alpha_n_left_deg" => "--pressure-angle-left-deg",
        "beta_deg" | "helix_angle" => "--helix-angle-deg",
        "x_shift" | "profile_shift" => "--profile-shift",
        _ => "--teeth/--module-mm/--pressure-angle-deg/--helix-angle-deg/--profile-shift",
    };
    anyhow::anyhow!("gear ({opt}): {e}")
}

/// The worm body from the set-up options; its rack has the gear's profile angles (93).
pub(super) fn worm_body(a: &SetupArgs) -> Result<InvoluteGear> {
    let alpha_r = deg_to_rad(a.pressure_angle_deg);
    let alpha_l = deg_to_rad(a.pressure_angle_left_deg.unwrap_or(a.pressure_angle_deg));
    setup::grinding_worm(
        a.worm_starts,
        a.module_mm,
        alpha_r,
        alpha_l,
        a.worm_radius_mm,
        hand_arg(a),
    )
    .map_err(|e| match e {
        // the lead angle of --module-mm, --worm-starts and --worm-radius-mm is out of range
        GrindError::OutOfRange { field, .. }
            if field == "beta_deg" || field == "worm_reference_radius_mm" =>
        {
            let (lo, hi) = setup::worm_module_range_mm(a.worm_starts, a.worm_radius_mm);
            anyhow::anyhow!(
                "--module-mm = {} with --worm-starts {} and --worm-radius-mm {} gives a worm \
                 lead angle outside 0.03° ..= 64° (cos β1 = starts·module/(2·radius)); with this \
                 worm the module must be {} ..< {} mm, or change --worm-radius-mm",
                fmt_value(a.module_mm),
                a.worm_starts,
                fmt_value(a.worm_radius_mm),
                fmt_value(lo),
                fmt_value(hi)
            )
        }
        other => anyhow::Error::new(other).context("worm"),
    })
}

/// Smallest --face-width-mm (mm): well above the grid's least span of 1e-6 mm.
const MIN_FACE_WIDTH_MM: f64 = 0.001;

/// The (w, z) grid of the gear flank `f2` inside its usable roll range `lim`; on a conical
/// gear `narrow_b_max` gives, for a roll start w, the largest face width whose narrow end
/// keeps the default roll end beyond w ([`RollLimits::conical_max_face_width_mm`]).
pub(super) fn flank_grid(
    a: &SetupArgs,
    f2: &InvoluteFlank,
    lim: &RollLimits,
    narrow_b_max: Option<&dyn Fn(f64) -> Option<f64>>,
) -> Result<FlankGrid> {
    if !(a.face_width_mm.is_finite() && (MIN_FACE_WIDTH_MM..=2000.0).contains(&a.face_width_mm)) {
        anyhow::bail!(
            "--face-width-mm = {} is out of range: expected {MIN_FACE_WIDTH_MM} ..= 2000 mm",
            fmt_value(a.face_width_mm)
        );
    }
    let expected = format!(
        "expected {:.4} ≤ --roll-start-mm < --roll-end-mm ≤ {:.4} mm (from {} to {})",
        lim.lo_mm, lim.hi_mm, lim.lo, lim.hi
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
    let (start0, end0) = lim.default_range_mm(f2, a.module_mm);
    let w_start = a.roll_start_mm.unwrap_or(start0);
    let w_end = a.roll_end_mm.unwrap_or(end0);
    // The grid's least span (FlankGrid::new); a default end or start may leave less.
    let reaches = w_end.partial_cmp(&(w_start + MIN_ROLL_SPAN_MM));
    if !matches!(
        reaches,
        Some(std::cmp::Ordering::Greater | std::cmp::Ordering::Equal)
    ) {
        return Err(empty_roll_range(
            a,
            lim,
            (w_start, w_end),
            &expected,
            narrow_b_max,
        ));
    }
    let half = 0.5 * a.face_width_mm;
    FlankGrid::new((w_start, w_end), (-half, half), a.grid_w, a.grid_z)
        .context("flank grid (--roll-start-mm/--roll-end-mm/--grid-w/--grid-z)")
}

/// Why the roll range `(w_start, w_end)` is empty: both ends given in the wrong order, or a
/// default end (on a cone: the narrow end's tip, with the largest face width that keeps a
/// range) or start; `expected` is the usable range in words.
fn empty_roll_range(
    a: &SetupArgs,
    lim: &RollLimits,
    (w_start, w_end): (f64, f64),
    expected: &str,
    narrow_b_max: Option<&dyn Fn(f64) -> Option<f64>>,
) -> anyhow::Error {
    if let (Some(ws), Some(we)) = (a.roll_start_mm, a.roll_end_mm) {
        return anyhow::anyhow!(
            "--roll-start-mm = {ws} mm must be below --roll-end-mm = {we} mm (by at least \
             {MIN_ROLL_SPAN_MM} mm)"
        );
    }
    let range = format!(
        "the roll range from {} to {} mm{} is empty",
        fmt_value(w_start),
        fmt_value(w_end),
        match (a.roll_start_mm, a.roll_end_mm) {
            (Some(_), _) => " (--roll-start-mm to the default end)",
            (_, Some(_)) => " (the default start to --roll-end-mm)",
            _ => " (the default)",
        }
    );
    match narrow_b_max {
        Some(b_max) if a.roll_end_mm.is_none() && w_end == lim.default_hi_mm => {
            let fix = match b_max(w_start + 2.0 * MIN_ROLL_SPAN_MM) {
                Some(b) => format!(
                    "give --face-width-mm below {} mm or a smaller --gear-cone-deg",
                    fmt_value((b * 1e4).floor() / 1e4)
                ),
                None => "no face width keeps it: give a smaller --gear-cone-deg".into(),
            };
            anyhow::anyhow!(
                "{range}: at --gear-cone-deg {} the tip circle of the narrow end (z = ±b/2 \
                 with --face-width-mm {}) ends it; {fix}, or --roll-start-mm/--roll-end-mm \
                 ({expected})",
                fmt_value(a.gear_cone_deg),
                fmt_value(a.face_width_mm)
            )
        }
        _ => anyhow::anyhow!("{range}: give --roll-start-mm/--roll-end-mm ({expected})"),
    }
}

/// Worm root and tip radii: the options, else the dressed worm's, else r1 ∓ 1.25·m_n.
pub(super) fn worm_radii(
    a: &SetupArgs,
    r1_mm: f64,
    dressed: Option<&DressWorm>,
) -> Result<(f64, f64)> {
    let (root0, tip0) = dressed.map_or(default_worm_radii_mm(r1_mm, a.module_mm), |d| {
        (d.r_f_mm, d.r_a_mm)
    });
    let root = a.worm_root_radius_mm.unwrap_or(root0);
    let tip = a.worm_tip_radius_mm.unwrap_or(tip0);
    if !(root.is_finite() && tip.is_finite() && root >= 0.0 && root < r1_mm && tip > r1_mm) {
        if a.worm_root_radius_mm.is_none() && a.worm_tip_radius_mm.is_none() && dressed.is_none() {
            anyhow::bail!(
                "the default worm radii for --module-mm {} (root {} / tip {} mm, the worm \
                 radius {} mm ∓ 1.25·module) do not fit: the root must stay above 0; give a \
                 larger --worm-radius-mm (at least {} mm), or --worm-root-radius-mm and \
                 --worm-tip-radius-mm",
                fmt_value(a.module_mm),
                fmt_value(root),
                fmt_value(tip),
                fmt_value(r1_mm),
                fmt_value(1.25 * a.module_mm)
            );
        }
        anyhow::bail!(
            "--worm-root-radius-mm = {root} / --worm-tip-radius-mm = {tip}: expected \
             0 ≤ root < worm radius {r1_mm} mm < tip"
        );
    }
    Ok((root, tip))
}

/// [`RollLimits::cylindrical`] with the options the user wrote in its errors.
pub(super) fn roll_limits(
    gear: &InvoluteGear,
    flank: Flank,
    pair: &WormGearPair,
    radii: (f64, f64),
) -> Result<RollLimits> {
    RollLimits::cylindrical(gear, flank, pair, radii).map_err(|e| match e {
        RollRangeError::Gear(e) => gear_error(&e),
        RollRangeError::BelowBaseCircle { end, radius_mm } => anyhow::anyhow!(
            "the {end} (r = {radius_mm:.4} mm, --worm-root-radius-mm/--worm-tip-radius-mm) \
             reaches below the gear's base circle: it undercuts the involute, which the \
             envelope simulation does not model; raise --profile-shift or --teeth, or lower \
             the worm tip"
        ),
        RollRangeError::NoOverlap { lo, hi } => anyhow::anyhow!(
            "the worm (--worm-root-radius-mm {} / --worm-tip-radius-mm {}) does not reach the \
             gear flank between {lo} and {hi}",
            radii.0,
            radii.1
        ),
    })
}

/// A feed-coupling option (`--shift-offset-mm`, `--diagonal-ratio`) checked before it is used
/// (a NaN read "feed coupling: z_v01_mm = NaN"), in the range of [`FeedCoupling::linear`].
pub(super) fn check_feed_option(option: &str, v: f64, unit: &str) -> Result<()> {
    use gearcomp_grinding::kinematics::MAX_LINEAR_COEFF as MAX;
    if !(v.is_finite() && v.abs() <= MAX) {
        anyhow::bail!(
            "{option} = {} is out of range: expected -{} ..= {}{unit}",
            fmt_value(v),
            fmt_value(MAX),
            fmt_value(MAX)
        );
    }
    Ok(())
}

pub(super) fn setup(a: &SetupArgs, dressed: Option<&DressWorm>) -> Result<Setup> {
    check_feed_option("--shift-offset-mm", a.shift_offset_mm, " mm")?;
    let gear = gear_body(a)?;
    let flank = flank_arg(a);
    let (pair, r1) = match dressed {
        None => {
            let worm = worm_body(a)?;
            let pair = setup::shifted_pair(&worm, &gear, flank).context("worm/gear mesh")?;
            (pair, worm.reference_radius_mm())
        }
        Some(dw) => (
            dressed_pair(a, dw, &gear, flank, hand_arg(a))?,
            0.5 * dw.d_s_mm,
        ),
    };
    let radii = worm_radii(a, r1, dressed)?;
    let lim = roll_limits(&gear, flank, &pair, radii)?;
    let f2 = gear.flank(flank);
    let grid = flank_grid(a, &f2, &lim, None)?;
    Ok(Setup {
        pair,
        gear,
        grid,
        worm_radii_mm: radii,
    })
}

/// Conical worm and/or workpiece at the reference setting (pivots coincide, γ = −(β1 + β2)).
pub(super) struct ConeSetup {
    pub(super) pair: ConicalPair,
    /// The gear's body (teeth, module, angles at z = 0) for the ISO 1328 tolerances.
    pub(super) gear: InvoluteGear,
    pub(super) grid: FlankGrid,
}

/// The conical set-up: beveloid worm and gear from the options, chain (29)–(31); the roll
/// range from [`RollLimits::conical`] (default end at the narrow end's tip circle).
pub(super) fn setup_conical(a: &SetupArgs, c: Cones) -> Result<ConeSetup> {
    let gear = gear_body(a)?;
    let flank = flank_arg(a);
    let bev2 = BeveloidGear::new(gear, c.gear_rad)
        .with_context(|| format!("--gear-cone-deg = {}", a.gear_cone_deg))?;
    let bev1 = BeveloidGear::new(worm_body(a)?, c.worm_rad)
        .with_context(|| format!("--worm-cone-deg = {}", a.worm_cone_deg))?;
    let pair = ConicalPair::reference(&bev1, &bev2, flank)
        .context("conical worm/gear mesh (chains (29)–(31))")?;
    let lim = RollLimits::conical(&gear, flank, &pair, a.face_width_mm, c.gear_rad)
        .map_err(|e| gear_error(&e))?;
    let b_max = |w: f64| RollLimits::conical_max_face_width_mm(&gear, &pair, c.gear_rad, w);
    let grid = flank_grid(a, &pair.gear, &lim, Some(&b_max))?;
    Ok(ConeSetup { pair, gear, grid })
}

/// The worm of a dress config as a grinding worm, and its set-up with the gear.
///
/// The helicoid (r_b, β_b) is that of the design diameter d_S0 (the dressing module keeps it
/// over the worm's life); the pair at the present diameter d_S is [`setup::redressed_pair`].
pub(super) fn dressed_pair(
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
    setup::redressed_pair(&worm, r0, 0.5 * dw.d_s_mm, gear, flank).context("dressed worm/gear mesh")
}

/// The worm of the `gearcomp dress` config at `path` dressed as its `[dressing]` table asks
/// ([`DressingInput::dress`]), tabulated for the grinding crate.
///
/// Glue between the crates (docs/grinding.md "Dressed worm"): both use the shared
/// [`Flank`]; (w, b) = (w1, z1); f_nFS (mm, normal) is tabulated as is and turned into
/// f_Ft1 = f_n/cos β_b1 by [`DressedWorm`].
pub(super) fn dress_worm(
    path: &std::path::Path,
    flank: Flank,
) -> Result<(DressWorm, DressedProfile, DressedReport)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let cfg = GrindDressConfig::from_toml_str(&text)
        .with_context(|| format!("invalid TOML in {}", path.display()))?;
    let (design, dresser) = cfg.design()?;
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
    let out = dressed_report(path, cfg.dresser.diameter_mm, &t, &profile);
    Ok((worm, profile, out))
}

/// The record of the dressed worm (the used roll range and the axial-section estimate are
/// filled in once the pair is known).
fn dressed_report(
    path: &std::path::Path,
    dresser_diameter_mm: f64,
    t: &DressedWormTable,
    profile: &DressedProfile,
) -> DressedReport {
    let worm = &t.worm;
    DressedReport {
        config: path.display().to_string(),
        correction: t.kind.name(),
        worm_starts: worm.z_s,
        worm_design_diameter_mm: worm.d_s0_mm,
        worm_diameter_mm: worm.d_s_mm,
        dresser_diameter_mm,
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
        profile_um: DressedReport::sample_profile_um(&t.roll_mm, &t.f_mm),
    }
}
