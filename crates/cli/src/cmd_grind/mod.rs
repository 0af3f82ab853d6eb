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
//!
//! Glue only: `args.rs` (options), `config.rs` (options and TOML configs → the grinding
//! crate's set-up, `gearcomp_grinding::setup`; the `equalise` config is
//! `gearcomp_grinding::equalise_request`), `run.rs` (the subcommands, generic over
//! `gearcomp_grinding::mesh::GrindingMesh`), `output.rs` (the record of
//! `gearcomp_grinding::report` as JSON or its table) and `report.rs` (the HTML report).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Subcommand;
use gearcomp_dressing::request::{DressedWormTable, GrindDressConfig};
use gearcomp_dressing::worm::Worm as DressWorm;
use gearcomp_geometry::units::{deg_to_rad, fmt_value, mm_to_um, rad_to_deg, um_to_mm};
use gearcomp_geometry::GeometryError;
use gearcomp_grinding::conical::{BeveloidGear, ConicalPair, MAX_CONE_ANGLE_RAD};
use gearcomp_grinding::conical_equalise::{
    equalise_worm_cone_angle, flank_ratios, Equalised, WormLines,
};
use gearcomp_grinding::conical_lines;
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{diagonal_ratio, rho1_estimate_rad, LineMap};
use gearcomp_grinding::dressed::{DressedProfile, DressedWorm};
use gearcomp_grinding::envelope::EnvelopeGrinder;
use gearcomp_grinding::envelope::{EnvelopeMode, FlankGrid, GroundFlank, MIN_ROLL_SPAN_MM};
use gearcomp_grinding::equalise_request::EqualiseConfig;
use gearcomp_grinding::flank::{Flank, Hand, InvoluteFlank, InvoluteGear};
use gearcomp_grinding::iso1328::{
    tolerances, tolerances_in_scope, DeviationMap, FlankEvaluation, MultiTraceEvaluation,
    OUT_OF_SCOPE,
};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::mesh::GrindingMesh;
use gearcomp_grinding::modification::{
    FlankModification, LineModification, Poly, MAX_POLY_COEFFS, MAX_POLY_COEFF_MM,
};
use gearcomp_grinding::report::{
    iso_rows, DressedReport, EqualiseReport, FlankComparison, FlankK, GrindReport, LineModReport,
    MapReport, SolveReport, TracesReport,
};
use gearcomp_grinding::setup::{self, default_worm_radii_mm, RollLimits, RollRangeError};
use gearcomp_grinding::solve::{solve_iterated, IterationOptions};
use gearcomp_grinding::GrindError;
use gearcomp_report::{Chart, HeatAxis, HeatMap, HtmlReport, Series};

mod args;
mod config;
mod output;
mod report;
mod run;

pub use args::Args;
pub use run::run;

use args::*;
use config::*;
use output::*;
use report::*;
