//! Running `gearcomp grind simulate | solve | equalise`: calls the grinding and dressing
//! crates, generic over the mesh (cylindrical `WormGearPair` or conical `ConicalPair`).

use super::*;

/// Runs `gearcomp grind`.
pub fn run(args: Args) -> Result<()> {
    match args.command {
        GrindCommand::Simulate(a) => simulate(a),
        GrindCommand::Solve(a) => solve(a),
        GrindCommand::Equalise(a) => equalise(a),
    }
}

/// The coefficients of `opt` (µm·mm⁻ᵏ, as written) as a polynomial in mm, range-checked
/// against the grinding library's limits in the option's own unit.
pub(super) fn poly_um(opt: &str, coeffs: &[f64]) -> Result<Poly> {
    if coeffs.len() > MAX_POLY_COEFFS {
        anyhow::bail!(
            "{opt}: {} coefficients given: expected at most {MAX_POLY_COEFFS} (degree {})",
            coeffs.len(),
            MAX_POLY_COEFFS - 1
        );
    }
    let max_um = mm_to_um(MAX_POLY_COEFF_MM);
    if let Some((k, v)) = coeffs
        .iter()
        .enumerate()
        .find(|(_, v)| !(v.is_finite() && v.abs() <= max_um))
    {
        anyhow::bail!(
            "{opt} = {} (coefficient {}) is out of range: expected finite coefficients of \
             magnitude ≤ {} µm·mm⁻ᵏ",
            fmt_value(*v),
            k + 1,
            fmt_value(max_um)
        );
    }
    Ok(Poly(coeffs.iter().map(|&c| um_to_mm(c)).collect()))
}

/// What `grind_and_report` takes beyond the mesh and the worm.
#[derive(Default)]
pub(super) struct Extras {
    pub(super) worm_radii_mm: Option<(f64, f64)>,
    /// A flank already ground with this worm (the iterated solve's last simulation).
    pub(super) pre_ground: Option<GroundFlank>,
    pub(super) solve: Option<SolveReport>,
}

/// The worm that grinds: a line modification from the command line, or a dressed worm.
pub(super) enum WormUsed<'a> {
    Line(&'a LineModification),
    Dressed(&'a DressedWorm, Box<DressedReport>),
}

/// Grinds the grid and builds the output (design = `wanted`, or the unmodified flank: the
/// involute helicoid, or the nominal beveloid flank on a conical gear).
///
/// `gear` is the workpiece body at z = 0 (reference diameter and module for the ISO 1328
/// tolerances). The cylindrical [`WormGearPair`] runs the library's `Grinder` (which is
/// `EnvelopeGrinder<WormGearPair>`), a [`ConicalPair`] the same algorithm on chains (29)–(31).
#[allow(clippy::too_many_arguments)]
pub(super) fn grind_and_report<M: GrindingMesh>(
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
) -> Result<GrindReport> {
    let (worm_mod, worm_out, dressed_out): (&dyn FlankModification, _, _) = match worm {
        WormUsed::Line(m) => (m, Some(LineModReport::from(m)), None),
        WormUsed::Dressed(d, o) => (d, None, Some(*o)),
    };
    let cpl = FeedCoupling::linear(k, a.shift_offset_mm).context("feed coupling")?;
    let ground = match extras.pre_ground {
        Some(pre) => pre,
        None => grind(mesh, &cpl, worm_mod, g, extras.worm_radii_mm)?,
    };
    let cmp = FlankComparison::new(mesh, &cpl, worm_mod, &ground, wanted)
        .with_context(|| format!("analytic map of the {}", M::NAME))?;
    let (iso, iso_traces) = iso_evaluation(gear, g, a, &cmp, wanted.is_some())?;
    let warnings = run_warnings(&cmp, extras.solve.as_ref(), gear, a, &iso);
    Ok(GrindReport {
        mode,
        worm_cone_deg: cones.worm_deg,
        gear_cone_deg: cones.gear_deg,
        path: mesh.path_report(),
        diagonal_ratio: k,
        shift_offset_mm: a.shift_offset_mm,
        line_map: lm,
        worm_modification: worm_out,
        dressed_worm: dressed_out,
        wanted_gear_modification: wanted.map(LineModReport::from),
        max_abs_ground_um: mm_to_um(cmp.max_abs_ground_mm),
        max_abs_ground_minus_analytic_um: mm_to_um(cmp.max_abs_ground_minus_analytic_mm),
        max_abs_deviation_um: mm_to_um(cmp.max_abs_deviation_mm),
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
        flagged_points: cmp.flagged,
        warnings,
        solve: extras.solve,
        map: cmp.map,
    })
}

/// The envelope simulation of the grid (the worm bounded by its root and tip radii when
/// given).
fn grind<M: GrindingMesh>(
    mesh: &M,
    cpl: &FeedCoupling,
    worm_mod: &dyn FlankModification,
    g: FlankGrid,
    worm_radii_mm: Option<(f64, f64)>,
) -> Result<GroundFlank> {
    let mut grinder = EnvelopeGrinder::new(mesh, cpl, worm_mod, EnvelopeMode::RotationAndFeed);
    if let Some((root, tip)) = worm_radii_mm {
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
    Ok(ground)
}

/// The flagged points' warnings, the solve's and [`scope_warning`].
fn run_warnings(
    cmp: &FlankComparison,
    solve: Option<&SolveReport>,
    gear: &InvoluteGear,
    a: &SetupArgs,
    iso: &FlankEvaluation,
) -> Vec<String> {
    let mut warnings = cmp.flag_warnings();
    warnings.extend(solve.and_then(SolveReport::warning));
    warnings.extend(scope_warning(gear, a, iso));
    warnings
}

/// Why a gear has no ISO 1328-1 tolerances (outside the standard's scope), naming the option.
fn scope_warning(gear: &InvoluteGear, a: &SetupArgs, iso: &FlankEvaluation) -> Option<String> {
    if iso.tolerances.is_some() {
        return None;
    }
    let d_mm = 2.0 * gear.reference_radius_mm();
    let why = tolerances(d_mm, gear.m_n_mm, a.face_width_mm, a.class).err()?;
    let why = why.to_string();
    let flag = if why.starts_with("normal module") {
        "--module-mm"
    } else if why.starts_with("facewidth") {
        "--face-width-mm"
    } else {
        "--teeth/--module-mm/--helix-angle-deg"
    };
    Some(format!("{OUT_OF_SCOPE}: {flag}: {why}"))
}

/// ISO 1328-1 of the deviation map (middle traces), and over three traces from the design
/// and from the unmodified flank.
fn iso_evaluation(
    gear: &InvoluteGear,
    g: FlankGrid,
    a: &SetupArgs,
    cmp: &FlankComparison,
    wanted: bool,
) -> Result<(FlankEvaluation, TracesReport)> {
    let d_mm = 2.0 * gear.reference_radius_mm();
    // None outside the standard's scope (m_n < 0.5 mm, b < 4 mm, d > 15 m): deviations only
    let tol = tolerances_in_scope(d_mm, gear.m_n_mm, a.face_width_mm, a.class)
        .context("ISO 1328-1 tolerances (--class)")?;
    let iso = DeviationMap::new(g, cmp.deviation_mm.clone())?
        .evaluate(tol, gear.m_n_mm)
        .context("ISO 1328-1 evaluation")?;
    let traces = |v: Vec<f64>| -> Result<MultiTraceEvaluation> {
        DeviationMap::new(g, v)?
            .evaluate_traces(d_mm, gear.m_n_mm, a.face_width_mm, a.class, 3)
            .context("ISO 1328-1 evaluation (three traces)")
    };
    let iso_traces = TracesReport {
        design_reference: if wanted {
            "wanted gear modification"
        } else {
            "analytic worm → gear map of the given worm"
        },
        from_design: traces(cmp.from_design_mm.clone())?,
        from_involute: traces(cmp.ground_mm.clone())?,
    };
    Ok((iso, iso_traces))
}

pub(super) fn simulate(a: SimulateArgs) -> Result<()> {
    check_feed_option("--shift-offset-mm", a.setup.shift_offset_mm, " mm")?;
    if let Some(k) = a.diagonal_ratio {
        check_feed_option("--diagonal-ratio", k, "")?;
    }
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
    simulate_line(
        &a,
        &s.pair,
        &s.gear,
        s.grid,
        Cones::CYLINDRICAL,
        Extras {
            worm_radii_mm: Some(s.worm_radii_mm),
            ..Extras::default()
        },
    )
}

/// `simulate` with a conical worm and/or workpiece (chains (29)–(31)).
///
/// ρ_F1 defaults to the axial-section estimate of the conical worm flank; --gear-rho-deg picks
/// K_ZV1 and, where it exists, the line map X_F1 = k·X_F2 + c0 of the conical chain
/// (`conical_line_map`; not for profile lines ρ_F2 = ±90° on a feed-dependent (86)).
pub(super) fn simulate_conical(a: &SimulateArgs, c: Cones) -> Result<()> {
    let s = setup_conical(&a.setup, c)?;
    simulate_line(a, &s.pair, &s.gear, s.grid, c, Extras::default())
}

/// `simulate` with the worm line modification of the options (--worm-c/-l/-q along ρ_F1) on
/// either mesh: ρ_F1 from --worm-rho-deg or the mesh's estimate, K_ZV1 from --diagonal-ratio or
/// --gear-rho-deg ([`GrindingMesh::gear_line_choice`]).
fn simulate_line<M: GrindingMesh>(
    a: &SimulateArgs,
    pair: &M,
    gear: &InvoluteGear,
    grid: FlankGrid,
    cones: Cones,
    extras: Extras,
) -> Result<()> {
    let rho1 = a
        .worm_rho_deg
        .map_or_else(|| pair.rho1_default_rad(), deg_to_rad);
    let worm_mod = LineModification::new(
        rho1,
        pair.worm_ref_mm(),
        poly_um("--worm-c", &a.worm_c)?,
        poly_um("--worm-l", &a.worm_l)?,
        poly_um("--worm-q", &a.worm_q)?,
    )
    .context("worm modification")?;
    let (k, lm) = diagonal_choice(a, pair, rho1)?;
    let out = grind_and_report(
        "simulate",
        pair,
        gear,
        grid,
        cones,
        &a.setup,
        k,
        lm,
        WormUsed::Line(&worm_mod),
        None,
        extras,
    )?;
    emit(&out, &a.setup)
}

/// K_ZV1 from --diagonal-ratio, or from --gear-rho-deg and the worm line direction ρ_F1.
pub(super) fn diagonal_choice<M: GrindingMesh>(
    a: &SimulateArgs,
    pair: &M,
    rho1: f64,
) -> Result<(f64, Option<LineMap>)> {
    Ok(match (a.diagonal_ratio, a.gear_rho_deg) {
        (Some(k), _) => (k, None),
        (None, Some(r2)) => pair
            .gear_line_choice(rho1, deg_to_rad(r2), a.setup.shift_offset_mm)
            .with_context(|| {
                let chain = if M::CONICAL { " (conical)" } else { "" };
                format!("diagonal ratio for --gear-rho-deg{chain}")
            })?,
        (None, None) => (0.0, None),
    })
}

pub(super) fn simulate_dressed(a: &SimulateArgs, path: &std::path::Path) -> Result<()> {
    let flank = a.setup.flank;
    let (dworm, profile, mut dout) = dress_worm(path, flank)?;
    let s = setup(&a.setup, Some(&dworm))?;
    let worm = DressedWorm::new(profile, &s.pair.worm).context("dressed worm")?;
    worm.check_covers(&s.pair, s.grid.w_range_mm)
        .context("gear roll range (--roll-start-mm/--roll-end-mm) on the dressed worm")?;
    dout.used_roll_range_mm = DressedWorm::used_roll_range_mm(&s.pair, s.grid.w_range_mm);
    dout.rho_f1_axial_section_estimate_deg = rad_to_deg(rho1_estimate_rad(&s.pair));
    let rho1 = a.worm_rho_deg.map_or_else(|| worm.rho_f1_rad(), deg_to_rad);
    let (k, lm) = diagonal_choice(a, &s.pair, rho1)?;
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

pub(super) fn solve(a: SolveArgs) -> Result<()> {
    check_feed_option("--shift-offset-mm", a.setup.shift_offset_mm, " mm")?;
    let c = cones(&a.setup)?;
    if !c.is_cylindrical() {
        return solve_conical(&a, c);
    }
    let s = setup(&a.setup, None)?;
    let (rho1, wanted) = solve_targets(&a, &s.pair)?;
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
    let solve_out = SolveReport::new(&it, &opts);
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
pub(super) fn solve_conical(a: &SolveArgs, c: Cones) -> Result<()> {
    let s = setup_conical(&a.setup, c)?;
    let (rho1, wanted) = solve_targets(a, &s.pair)?;
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

/// ρ_F1 (--worm-rho-deg, or the mesh's estimate) and the wanted gear line modification
/// (--gear-rho-deg, --gear-c/-l/-q) of `solve`, on either mesh.
fn solve_targets<M: GrindingMesh>(a: &SolveArgs, pair: &M) -> Result<(f64, LineModification)> {
    let rho1 = a
        .worm_rho_deg
        .map_or_else(|| pair.rho1_default_rad(), deg_to_rad);
    let wanted = LineModification::new(
        deg_to_rad(a.gear_rho_deg),
        pair.gear_ref_mm(),
        poly_um("--gear-c", &a.gear_c)?,
        poly_um("--gear-l", &a.gear_l)?,
        poly_um("--gear-q", &a.gear_q)?,
    )
    .context("wanted gear modification")?;
    Ok((rho1, wanted))
}

/// `grind equalise`: T14 on a config, ϑ1 and both flanks' K.
pub(super) fn equalise(a: EqualiseArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.config)
        .with_context(|| format!("reading {}", a.config.display()))?;
    let cfg: EqualiseConfig =
        toml::from_str(&text).with_context(|| format!("parsing {}", a.config.display()))?;
    let spec = cfg.spec()?;
    let given = deg_to_rad(cfg.worm.cone_angle_deg);
    let at_given = flank_ratios(&spec, given).context("[worm] cone_angle_deg")?;
    let e: Equalised = match equalise_worm_cone_angle(&spec) {
        Ok(e) => e,
        Err(GrindError::NoRoot { at_min, at_max, .. }) => anyhow::bail!(
            "no worm cone angle in [{}°, {}°] ([equalise] cone_min_deg/cone_max_deg) gives both \
             flanks the same diagonal ratio: K_l − K_r = {at_min:.6} at {}° and {at_max:.6} at \
             {}° (no sign change, or only across a pole of K); widen the range, or change the worm lines or the wanted \
             directions",
            cfg.equalise.cone_min_deg,
            cfg.equalise.cone_max_deg,
            cfg.equalise.cone_min_deg,
            cfg.equalise.cone_max_deg
        ),
        Err(other) => return Err(other).context("[equalise]"),
    };
    let out = EqualiseReport {
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
        equalised: FlankK::new(
            e.cone1_rad,
            (e.k_left, e.k_right, e.rho1_left_rad, e.rho1_right_rad),
        ),
        at_given_cone: FlankK::new(given, at_given),
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print!("{}", out.to_table());
    }
    Ok(())
}
