//! gearcomp-dressing: dressing the grinding worm (JP6903407B2, worm dressing).
//!
//! A grinding worm is redressed many times with the same profile roller dresser and shrinks; a
//! dresser designed for the new worm then puts unwanted profile crowning on the small worm.
//! This crate computes the axis corrections ΔK = (Δφ_S, Δγ, Δd, Δν_yA) that keep the profile
//! right, with:
//!
//! - [`kinematics`]: the worm–dresser chain K_R (eq. (1)), machines (4) and (5), pose → axes;
//! - [`worm`], [`gear`]: the involute worm helicoid and DIN 3960 quantities;
//! - [`dresser`]: the dresser designed as the exact envelope of the worm gap, jacket and fillets;
//! - [`envelope`]: f_nFS(w; ΔK) and the radius association r_FA by the screw evaluation of the
//!   vector-shortening simulation and, independently, by the analytic envelope;
//! - [`schedule`]: ΔK(ν_zS) over the worm width (constant, polynomial, dressing program);
//! - [`simulation`]: the full time-stepped (w, b)-grid simulation and the contact line;
//! - [`solve`]: 3-point (with radius association), 4-point (minimum norm) and curve-fit solvers
//!   (damped Newton, natural-monotonicity test, scaled unknowns, Tikhonov-filtered steps);
//! - [`topology`]: topological dressing, ΔK(ν_zS) over the worm width, the 9-component 4-point
//!   and the width-dependent 3-point solves, the dressed worm f_nFS(w, b) as a grid;
//! - [`campaign`]: the plan of a worm's whole life (claims 1–2);
//! - [`request`]: a `[solve]` request in the user's keys and units, validated, solved and
//!   checked against the clearance budget, with the producible range when it is not.
//! - [`topological_request`]: a `[solve.topological]` request, the 3- or 4-point program over
//!   the worm width, checked per position, with the dressed worm f_nFS(w, b).
//! - [`report`]: the results of `gearcomp dress` in interface units (degrees, µm) with their
//!   text tables and HTML reports.
//!
//! Design trade-off: the dresser flank is tabulated once (exact envelope at 1201 stations,
//! natural cubic spline) instead of being re-solved at every query; the spline error
//! (< 1e-10 mm) is far below the µm budget and every evaluation becomes allocation-free and
//! ~40 µs per flank point, so a 3-point solve takes ~6 ms. Conventions: `docs/dressing.md`.
//!
//! ```
//! use gearcomp_dressing::{dresser::{Dresser, DresserSpec}, envelope::DressingSetup};
//! use gearcomp_dressing::{kinematics::AxisCorrection, worm::{Flank, Worm}};
//! let worm = Worm::design(5, 160.0, 3.0, 20f64.to_radians()).unwrap();
//! let spec = DresserSpec { d_a_mm: 100.0, jacket_width_mm: 0.8, clearance_mm: 0.0 };
//! let setup = DressingSetup::new(worm, Dresser::design(&worm, spec).unwrap());
//! // Turning the worm by 1e-3 rad offsets the involute flank by r_b·cos β_b·Δφ = 7.0477 µm.
//! let dk = AxisCorrection { dphi_s_rad: 1e-3, ..Default::default() };
//! let f = setup.dress_point(Flank::Right, 77.0, &dk).unwrap().f_mm;
//! assert!((f - 7.0477e-3).abs() < 1e-7);
//! ```

pub mod campaign;
pub mod config;
pub mod dresser;
pub mod envelope;
pub mod error;
pub mod gear;
pub mod kinematics;
pub mod report;
pub mod request;
pub mod schedule;
pub mod simulation;
pub mod solve;
pub mod spline;
pub mod topological_request;
pub mod topology;
pub mod transform;
pub mod worm;

pub use error::{DressError, Result};
