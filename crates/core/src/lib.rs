//! Shared types of gearcomp that several capabilities agree on.
//!
//! * [`model`]: the thermal model file format. `gearcomp fit` (identification) writes it,
//!   the compensation engine (`gearcomp-thermal`) loads and runs it. It is the one
//!   contract between identification and the runtime; change it only additively.
//! * [`delay`]: the delay transform's line, shared by the engine and the fit.
//! * [`fsio`]: writing output files atomically, so a crash never leaves a half-written file.
//! * [`textline`]: source line numbers of CSV records (right for CRLF files too).
//! * [`shorten`]: long user values in messages, shown by their start and length.

pub mod delay;
pub mod error;
pub mod fsio;
pub mod model;
pub mod shorten;
pub mod textline;

pub use error::{CoreError, Result};
