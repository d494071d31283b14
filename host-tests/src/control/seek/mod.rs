//! Seeks as commands (issue 14's harness): how long each seek takes until the data can be read —
//! its *access time* — against the *minimum-time bound* of the true plant under the same drive
//! rail, per seek, for any controller.
//!
//! | module | job |
//! |---|---|
//! | [`access`] | the access time of one seek from its readings; median / p95 / max |
//! | [`run`] | one controller on a schedule of log-uniform seeks: per-seek rows, the summary |
//! | [`family`] | the seek evaluation over the plant family (`sledid control-family --seek`) |
//!
//! The bound is [`crate::twin::bound`]: bang-bang with a switch-time search on the twin's own
//! plant (mass, force constant, viscous, Coulomb and static friction, the rail, zero-order hold
//! at Ts), from where the sled rested at the command, on the same readings as the access time.
//!
//! The controller under test is a parameter ([`SeekController`]): the baseline PID or the
//! scheduled servo fed the *step* (a seek command, `twin::ReferenceProfile::Step`; the servo's
//! seek mode reads it as the target, [`seek_design`]), or the scheduled servo following the
//! paper's 30 ms S-curve (today's reference-following mode, `sledid control`). Every servo is
//! designed from a prior only (`control::design_from_prior`), never from the plant it runs on.
//! Figures: `BENCHMARKS.md` (controller, seeks).

pub mod access;
pub mod family;
pub mod run;

pub use access::{MIN_DWELL_S, Quantiles, access_samples};
pub use run::{
    LONG_SEEK_TRACKS, SafeStop, SeekController, SeekOptions, SeekRow, SeekRun, SeekSummary,
    bound_curve, rows_of, run_seeks, seek_design,
};
