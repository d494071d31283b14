//! Closed-loop control on the sled twin: the library's servo (`sledid::servo`: the
//! gain-scheduled controller fed by its on-line identifier) or the paper's baseline PID in the
//! twin's loop, the controller designed from a *prior* plant and never from the one it runs on,
//! the settling statistics the issues ask for, a seeded family of plants to judge the servo on,
//! and the figures.
//!
//! | module | job |
//! |---|---|
//! | [`design`] | the scheduled design from a prior plant's physics |
//! | [`mod@run`] | one closed-loop run: the servo's per-sample step behind the twin's controller interface |
//! | [`summary`] | per-seek settling, overshoot, limit-cycle pulses, fallbacks, redesigns |
//! | [`perturb`] | a plant scaled from a nominal one (`--perturb`, the seven variants) |
//! | [`family`] | the seeded plant family |
//! | [`family_eval`] | baseline, identified and frozen servo over the family, in parallel |
//! | [`plot`] | step responses, the family's settling ratios and pulses, seek time versus distance |
//! | [`seek`] | seeks as commands: access time per seek against the plant's minimum-time bound |
//!
//! The scheduled controller is designed from a *prior* plant only ([`design_from_prior`]:
//! `sledid control --prior`, the built-in nominal sled without one), never from the plant it runs
//! on (`--plant`, `--perturb` [`Perturbation`], the [`family`]); the on-line identifier corrects
//! it, or, frozen at the prior (`--identification frozen`), does not (the ablation).
//! The default twin's baseline is the paper's kind of badly tuned loop, which oscillates while
//! settling (`host-tests/plants/paper_sled.json` writes it out); `host-tests/plants/well_damped.json`
//! is the same sled under the earlier, well-damped baseline (see the README beside them).
//!
//! # Measures (per seek; the error is `target − y` in quanta, as in `twin::analysis`)
//! - settling time: from the seek's first sample until |e| ≤ 1 for the rest of the seek; a seek
//!   that never settles counts as `unsettled` and enters the statistics with its whole length (a
//!   lower bound of its settling time);
//! - overshoot: beyond the target after the first entry into |e| ≤ 1;
//! - `limit_cycle_pulses`: runs of |u| above the breakaway voltage in the last half of each dwell,
//!   from the seek's settling and the first stop or reversal of the sled after it on
//!   (`twin::analysis`, the same window for every controller); `hold_pulses`: such runs while the
//!   scheduled controller is in Hold;
//! - `reference_bound_ms`: when the reference itself comes within 1 quantum of the target for
//!   good — no controller that follows the reference settles earlier (by more than the overshoot
//!   of a faster-than-reference seek, which the reference does not ask for).

pub mod calibration;
pub mod design;
pub mod family;
pub mod family_eval;
pub mod inject;
pub mod perturb;
pub mod plot;
pub mod run;
pub mod seek;
pub mod summary;

pub use design::{
    design_from_prior, identifier_design, physical_model, scheduled_design, scheduled_design_for,
};
pub use perturb::{Perturbation, perturbed};
pub use run::{ControlRun, ScheduledLoop, run, run_tuned, run_with, run_with_options};
pub use summary::{ControlSummary, ControllerKind, RedesignCounts, Spread};
