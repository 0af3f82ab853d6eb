//! Generating grinding of a cylindrical involute gear with a cylindrical (dressed) worm,
//! after JP6903407B2, part 2 (diagonal generating grinding).
//!
//! - [`flank`]: gears and worms as involute helicoids over the (w, z) plane of each flank.
//! - [`kinematics`]: the chain (28), the feed coupling (36)/(94), the machine chain (34) and
//!   its inverse.
//! - [`contact`]: the contact line in the plane of action, the contact path (39)/(40), the
//!   roll-distance relation (R7) and the generating coupling (R4).
//! - [`diagonal`]: the diagonal ratio K_ZV1, the line-to-line map, worm → gear modification
//!   transfer and its inverse, the variable diagonal ratio.
//! - [`decompose`]: weighted least-squares decomposition of a wanted modification (102), and
//!   the general form (100) with the dresser-profile part f_PFt (97).
//! - [`dressed`]: a worm dressed by the dressing module (tabulated f_nFS(w)) as a grinding worm.
//! - [`dressed_topology`]: a topologically dressed worm (grid f_nFS(w, b)) as a grinding worm
//!   for diagonal generating grinding.
//! - [`machine`]: machine chain (35) and its inverse.
//! - [`envelope`]: the envelope grinder for any worm–workpiece chain ([`envelope::MeshKinematics`]):
//!   the shortest cut over rotation and feed at every gear point, storing the worm point that
//!   ground it.
//! - [`simulate`]: the envelope grinder on the cylindrical chain and the contact path fitted
//!   from it.
//! - [`mesh`]: one trait ([`mesh::GrindingMesh`]) over the cylindrical and the conical pair for
//!   what a grinding run needs beyond the envelope kinematics.
//! - [`report`]: the record of a grinding run (and of `equalise`) and its text tables.
//! - [`setup`]: the set-up of a run: worm body for a gear, the pair of a shifted gear or a
//!   redressed worm, default worm radii, the usable roll range of the gear flank.
//! - [`solve`]: the worm for a wanted gear modification, iterated on the envelope simulation.
//! - [`iso1328`]: ISO 1328-1:2013 profile and helix evaluation and tolerances.
//! - [`conical`]: conical (beveloid) worm and/or workpiece: beveloid flanks, chains (29)–(31),
//!   the contact path (50)–(86) with its feed terms, generating coupling and diagonal ratio.
//! - [`conical_sim`]: the conical contact path fitted from two simulated feed couplings.
//! - [`equalise_request`]: the `grind equalise` config (`[gear]`, `[worm]`, `[equalise]`) and
//!   its search input.
//! - [`conical_equalise`]: the worm cone angle that equalises K_ZV1 on both flanks (A6, T14).
//! - [`conical_lines`]: line-class transfer on conical chains (worm ↔ gear modification of the
//!   form (25)/(26)) and its inverse.
//!
//! Conventions are collected in `docs/grinding.md`; every formula cites its source.
//!
//! ```
//! use gearcomp_grinding::{contact::WormGearPair, flank::{Flank, Hand, InvoluteGear}};
//! let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians())?;
//! let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right)?;
//! let pair = WormGearPair::reference(&worm, &gear, Flank::Right)?;
//! let k = gearcomp_grinding::diagonal::diagonal_ratio(&pair, 20f64.to_radians(), 45f64.to_radians())?;
//! assert!((k + 0.877178).abs() < 1e-6);
//! # Ok::<(), gearcomp_grinding::GrindError>(())
//! ```

pub mod conical;
pub mod conical_equalise;
pub mod conical_lines;
pub mod conical_sim;
pub mod contact;
pub mod decompose;
pub mod diagonal;
pub mod dressed;
pub mod dressed_topology;
pub mod envelope;
pub mod equalise_request;
mod error;
pub mod flank;
pub mod iso1328;
pub mod kinematics;
pub mod machine;
pub mod mesh;
pub mod modification;
pub mod report;
pub mod setup;
pub mod simulate;
pub mod solve;

pub use error::{GrindError, Result};
