//! When to calibrate again (issue 22, item 5): a calibrated servo that does not settle a command
//! within the time its own model allows has a model the sled no longer follows (a mass or
//! friction change, wear). Then it calibrates again from where the sled is, at most once per
//! command, instead of waiting for the safety layer's stop.
//!
//! # Rule (per sample; positions I48F16 raw, quanta)
//! ```text
//! a new command r:   d = |r − y|, budget T = 2·d / v_max + T₀, since = 0, settled = false
//! every sample:      settled once |y − r| ≤ 1 quantum for 22 samples in a row (10 ms at Ts)
//! since = T, not settled, not yet re-calibrated for this command  →  calibrate again
//! since ≥ T_e and fewer than 22 readings in a row within 1 quantum   →  seek error (per sample)
//! ```
//! with the seek error's budget T_e = 2·d / v_max + 4/(1 − a) + 66 samples (30 ms instead of
//! 100 ms: a drive reports a late seek; re-calibrating is kept for a sled the model has lost).
//! The seek error is what a drive reports to its host for a seek that has not settled in time
//! ([`crate::servo::ServoFlags::SEEK_ERROR`]); after a re-calibration the command keeps being
//! watched with a budget from the new model, counted from the adoption, and a command that still
//! does not settle raises it.
//!
//! # Off track after settling
//! A command that has settled is *off track* — the data under the head cannot be read — when its
//! reading leaves ±1 quantum again: that raises the seek error at once, whatever the budget, until
//! 22 readings in a row are within 1 quantum again (`settled` below). A sled whose budget T_e (four
//! of its time constants: a heavy, lightly damped sled's run to seconds) outlasted the command
//! used to leave such a hunt unreported. Measured (`control-family --passes seek`, seeds 1 / 7):
//! the wider family's failing plants with nothing flagged 7 / 7 → 6 / 4; the healthy family's
//! settled seeks reported 3 / 12 → 39 / 35 of 10,000 (seeks whose reading left the track after
//! settling and came back before the window's last 10 ms). Tried and not taken: a drive beyond
//! the calibrated breakaway level after settling (a corrective pulse) as off track too — 2 / 3
//! unflagged, but 170 / 102 healthy seeks reported, most of them pulses that never moved the
//! reading; at twice the breakaway level 6 / 4 unflagged, 42 / 35 reported (no gain).
//! ```text
//! seek error:  (since ≥ T_e or settled) and fewer than 22 readings in a row within 1 quantum
//! ```
//! v_max = K·(1 − u_c) (quanta per sample, the calibrated model's top speed at full drive, at
//! least 1/16) and T₀ = 4/(1 − a) + 220 samples (four time constants and 100 ms), both fixed at
//! the calibration's adoption ([`CalibrationWatch::arm`]). Integer arithmetic on the sample path.
//!
//! # Hunting after settling
//! A settled command whose drive keeps rising past the calibrated breakaway level (in the
//! drive's direction) hunts — the limit cycle of a sticky sled the settle law keeps kicking —
//! even while its readings stay within ±1 quantum and the off-track rule sees nothing:
//! ```text
//! pulses: rises of |u| past u_s(sgn u) since the command settled, each the other way than the
//!         last one counted;  seek error once pulses ≥ 4
//! ```
//! until the next command. A limit cycle pushes one way, then the other; a fine step pushes
//! one way (its drive may cross the level several times as a flickering reading kicks the
//! derivative: counted once), at most two per seek
//! ([`crate::control::scheduled::rest::FINE_STEPS_MAX`]), each perhaps braked the other way:
//! four alternating pulses are a hunt. The level is the breakaway drive calibration's search
//! found, capped at [`STICTION_MAX`] × the fitted Coulomb level: on heavy sleds the search finds
//! the level up to 3× too high (the sled has not moved a quantum before the next, higher level),
//! and a hunt kicking below it went unflagged. Measured on the wider family's (`--wide`) failing plants
//! with nothing flagged and on the healthy family's settled seeks reported (three pulses: more
//! of the former flagged, twice the latter's rise): BENCHMARKS.md, "Seek errors".
//!
//! # Ringing
//! A command whose readings cross the target again and again, each time more than a quantum
//! past it, rings — the seek law of a model the sled does not follow, long before any budget:
//! ```text
//! side:      sgn(r − y) of each reading more than 1 quantum off the target
//! crossings: changes of side since the command;  seek error once crossings ≥ 4
//! ```
//! until the next command. A seek that overshoots and comes back crosses once, a fine step's
//! overshoot and its return twice; readings within ±1 quantum (a flicker, a hunt within the
//! band, the rule above) do not count. Found on the wider family (seed 7, plant 186: mass 0.7×,
//! Coulomb 3.5×, stiction 5.6×): after a re-calibration its seeks rang ±250 tracks at full drive
//! with a period of 14 samples for two whole commands, unreported — the new model's budget
//! outlasted them. Measured: BENCHMARKS.md, "Seek errors".
//!
//! # Back-off: a re-calibration that finds the same sled
//! A re-calibration whose model matches the one it replaces — K within ×/÷ [`SAME_GAIN`] and the
//! Coulomb level within [`SAME_COULOMB_FS`] + 25 % of it — found no change: the commands missed
//! their budgets for another reason (a sled the laws cannot land faster), and calibrating again
//! only stops the seeks for the experiment and the fit's latency. After n such fruitless
//! re-calibrations in a row the next one needs 2ⁿ commands in a row that miss their budget
//! (n ≤ [`FRUITLESS_MAX`]); one that finds a changed sled resets n. A mass or friction change
//! still finds its re-calibration, later.
//!
//! # A re-calibration without a model
//! A re-calibration that runs out of its samples after every push has ended (a sled that flickers
//! at rest never gives the experiment its closing quiet) found no fault of the sled — it had a
//! model that worked until the commands missed their budgets. The previous model then stands: the watch is armed from it again, the re-calibration counted fruitless
//! (the back-off above), and the law resumes with its gains from a fresh signal history
//! ([`crate::control::Controller::restart`]). A sled that does not respond like one (stuck,
//! reversed, out of its travel, a gain outside the range, a record that does not fit) or whose
//! pushes do not end in time (a hundred times the mass: its last push still braking at the
//! 330th sample) still stops the servo, as at power-on.
//! Measured on the family's fast, sticky corner (`sledid seek --plant F`, seeds 1–10): the stop
//! (`calibration_timeout`) on seeds 2 and 10 is gone, every unsettled seek reported; the wider
//! family's safe stops 14 / 14 / 10 → 12 / 14 / 9 (seeds 1 / 7 / 2), the healthy families'
//! figures unchanged (BENCHMARKS.md, "A re-calibration without a model").

#![deny(clippy::float_arithmetic)]

use super::fit::CalibratedModel;

/// Samples in the band that count as settled (10 ms at Ts = 0.455 ms).
pub const SETTLED_SAMPLES: u16 = 22;
/// How much sooner than the re-calibration's budget a seek error is reported, samples (70 ms):
/// measured on the wider family, seeds 1 / 7, the plants failing with nothing flagged fell from
/// 14 / 10 to 7 / 6, while the healthy family's settled seeks reported rose from 2 / 2 to
/// 3 / 12 of 10,000 (BENCHMARKS.md, "Seek errors").
pub const REPORT_EARLIER: u32 = 154;

/// The hunting level is at most this many times the fitted Coulomb level: the family's largest
/// stiction ratio (1.2–3 × Coulomb), so a drive past it would break any sled of the family away
/// (module doc, "Hunting after settling").
pub const STICTION_MAX: f32 = 3.0;

/// Drive pulses past the calibrated breakaway level after a command has settled that make it a
/// hunt (module doc, "Hunting after settling").
pub const HUNT_PULSES: u8 = 4;

/// Crossings of the target, each more than a quantum past it the other way, that make a command
/// a ring (module doc, "Ringing").
pub const RING_CROSSINGS: u8 = 4;

/// A re-calibrated gain K within this ratio either way of the previous one is the same sled's.
pub const SAME_GAIN: f32 = 1.25;
/// A re-calibrated Coulomb level within this (fraction of full scale) plus 25 % of the previous
/// one is the same sled's.
pub const SAME_COULOMB_FS: f32 = 0.002;
/// The most fruitless re-calibrations counted: the back-off stops at 2⁴ = 16 commands.
pub const FRUITLESS_MAX: u8 = 4;

/// The watch's state (in the servo's state).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationWatch {
    /// Armed by a calibrated model.
    armed: bool,
    /// v_max, I16F16 raw quanta per sample (≥ 1/16).
    v_max_i16f16: i64,
    /// T₀, samples.
    base: u32,
    /// The command being watched, I48F16 raw.
    r: i64,
    /// Samples since it.
    since: u32,
    /// Its budget T, samples (the seek error's, T_e, is T − [`REPORT_EARLIER`]).
    budget: u32,
    in_band: u16,
    settled: bool,
    /// Re-calibrated for this command already.
    spent: bool,
    /// The next command seen is the one a re-calibration interrupted: not re-calibrated again.
    resumed: bool,
    /// The model armed from: K and the mean Coulomb level (fraction of full scale), `f32` bits.
    gain_k_bits: u32,
    coulomb_fs_bits: u32,
    /// Re-calibrations in a row that found the same sled (≤ [`FRUITLESS_MAX`]).
    fruitless: u8,
    /// The hunting level (+, −): the calibrated breakaway drive, at most [`STICTION_MAX`] × the
    /// fitted Coulomb level, I16F16 raw full scale (`i32::MAX`: none found).
    breakaway_i16f16: [i32; 2],
    /// Pulses past it since the command settled (≤ 255).
    pulses: u8,
    /// The last drive was past it.
    strong: bool,
    /// The direction of the last pulse counted (0: none yet).
    last_pulse: i8,
    /// Commands in a row that missed their budget since the last re-calibration.
    misses: u16,
    /// The side of the target (sign of r − y) of the last reading more than a quantum off
    /// (0: none yet this command).
    side: i8,
    /// Crossings of the target since the command (≤ 255, module doc, "Ringing").
    crossings: u8,
}

impl CalibrationWatch {
    /// Armed from a calibrated model (f32 arithmetic, at the adoption, not per sample).
    #[allow(clippy::float_arithmetic, clippy::cast_possible_truncation)]
    pub fn arm(model: &CalibratedModel) -> Self {
        let v_max = (model.gain_k * (1.0 - model.coulomb_mean_fs())).max(1.0 / 16.0);
        let v = (v_max * 65536.0).min(1.0e12);
        let tau = 4.0 / (1.0 - model.a).max(1.0 / 4096.0);
        Self {
            armed: true,
            v_max_i16f16: v as i64,
            base: (tau.min(1.0e6) as u32).saturating_add(220),
            // No command yet: the first sample arms the first budget.
            r: i64::MIN,
            gain_k_bits: model.gain_k.to_bits(),
            coulomb_fs_bits: model.coulomb_mean_fs().to_bits(),
            breakaway_i16f16: {
                let ([cp, cn], [bp, bn]) = (model.coulomb_fs, model.breakaway_fs);
                [(cp, bp), (cn, bn)]
            }
            .map(|(c, b)| {
                let b = libm::fabsf(b);
                // The search's level, at most the family's largest stiction over the fitted
                // Coulomb level (module doc, "Hunting after settling").
                let b = if c.is_finite() && c > 0.0 {
                    b.min(STICTION_MAX * c)
                } else {
                    b
                };
                if b.is_finite() && b > 0.0 {
                    (b.min(2.0) * 65536.0) as i32
                } else {
                    i32::MAX
                }
            }),
            ..Self::default()
        }
    }

    /// Fruitless re-calibrations in a row (the back-off's n).
    pub const fn fruitless(&self) -> u8 {
        self.fruitless
    }

    /// One sample: the command `r` and the reading `y` (I48F16 raw). True when the servo should
    /// calibrate again now.
    pub fn step(&mut self, r: i64, y: i64) -> bool {
        if !self.armed {
            return false;
        }
        let signed = r.saturating_sub(y);
        let e = signed.unsigned_abs();
        if r != self.r {
            self.side = 0;
            self.crossings = 0;
            self.r = r;
            self.since = 0;
            self.in_band = 0;
            self.settled = false;
            self.spent = self.resumed;
            self.resumed = false;
            self.pulses = 0;
            self.strong = false;
            self.last_pulse = 0;
            // 2·d / v_max, both I16F16: the quotient is in samples.
            let travel = (e.min(1 << 47) as i64).saturating_mul(2) / self.v_max_i16f16.max(1);
            self.budget = u32::try_from(travel)
                .unwrap_or(u32::MAX)
                .saturating_add(self.base);
            return false;
        }
        self.since = self.since.saturating_add(1);
        if e <= 1 << 16 {
            self.in_band = self.in_band.saturating_add(1);
            self.settled |= self.in_band >= SETTLED_SAMPLES;
        } else {
            self.in_band = 0;
            // A side only more than a quantum off (module doc, "Ringing").
            let side = signed.signum() as i8;
            if self.side != 0 && side != self.side {
                self.crossings = self.crossings.saturating_add(1);
            }
            self.side = side;
        }
        if self.settled {
            self.misses = 0;
        }
        if self.since == self.budget && !self.settled && !self.spent {
            self.spent = true;
            self.misses = self.misses.saturating_add(1);
            if self.misses >= 1 << self.fruitless {
                self.misses = 0;
                return true;
            }
        }
        false
    }

    /// The command in progress is late or off track: its reading is not (yet, or no longer)
    /// within 1 quantum for 22 samples in a row, and either the seek error's budget T_e has
    /// passed or the command had settled (module doc).
    pub const fn seek_error(&self) -> bool {
        self.armed
            && (((self.settled || self.since >= self.budget.saturating_sub(REPORT_EARLIER))
                && self.in_band < SETTLED_SAMPLES)
                || self.pulses >= HUNT_PULSES
                || self.crossings >= RING_CROSSINGS)
    }

    /// The drive `u_i16f16` (I16F16 raw full scale) the servo put out this sample: once the
    /// command has settled, a rise past the calibrated breakaway level in its direction counts
    /// a pulse when it pushes the other way than the last pulse counted (module doc, "Hunting
    /// after settling").
    pub fn drive(&mut self, u_i16f16: i32) {
        if !(self.armed && self.settled) {
            return;
        }
        let [pos, neg] = self.breakaway_i16f16;
        let (level, direction) = if u_i16f16 < 0 { (neg, -1) } else { (pos, 1) };
        let strong = u_i16f16.unsigned_abs() > level.unsigned_abs();
        if strong && !self.strong && direction != self.last_pulse {
            self.pulses = self.pulses.saturating_add(1);
            self.last_pulse = direction;
        }
        self.strong = strong;
    }

    /// Pulses past the calibrated breakaway level since the command in progress settled.
    pub const fn pulses(&self) -> u8 {
        self.pulses
    }

    /// The watch for a newly adopted calibration: armed from `model`; after a re-calibration
    /// (this watch was armed) the command in progress is watched again from its next sample with
    /// a budget from the new model, but not re-calibrated again, and the back-off counts the
    /// re-calibration fruitless when `model` is the same sled's (module doc).
    #[allow(clippy::float_arithmetic)]
    pub fn adopt(&self, model: &CalibratedModel) -> Self {
        let mut w = Self::arm(model);
        w.resumed = self.armed;
        if self.armed {
            let f = f32::from_bits;
            let ratio = f(w.gain_k_bits) / f(self.gain_k_bits);
            let (was, now) = (f(self.coulomb_fs_bits), f(w.coulomb_fs_bits));
            let same = (1.0 / SAME_GAIN..=SAME_GAIN).contains(&ratio)
                && libm::fabsf(now - was) <= SAME_COULOMB_FS + 0.25 * libm::fabsf(was);
            w.fruitless = if same {
                self.fruitless.saturating_add(1).min(FRUITLESS_MAX)
            } else {
                0
            };
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const Q: i64 = 1 << 16;

    /// a = 0.75, K = 16 quanta per sample at full drive, no Coulomb: v_max 16, T₀ = 16 + 220.
    fn model() -> CalibratedModel {
        CalibratedModel {
            a: 0.75,
            gain_k: 16.0,
            coulomb_fs: [0.0; 2],
            breakaway_fs: [0.01; 2],
            rms: 0.1,
        }
    }

    /// A command of 320 quanta: re-calibration budget 2·320/16 + 236 = 276 samples, the seek
    /// error's 276 − 154 = 122. Trips on a seek error raised before its budget, not raised after
    /// it while the reading is off, kept once the reading has settled, or kept into the next
    /// command; on a re-calibration at the wrong sample or twice.
    #[test]
    fn a_seek_error_is_raised_after_its_budget_until_the_command_settles() {
        let mut w = CalibrationWatch::arm(&model());
        let r = 320 * Q;
        assert!(!w.step(r, 0));
        for k in 1..276 {
            assert!(!w.step(r, 5 * Q));
            assert_eq!(w.seek_error(), k >= 122, "sample {k}");
        }
        assert!(w.step(r, 5 * Q), "re-calibrates once, at its budget");
        assert!(w.seek_error());
        for _ in 0..SETTLED_SAMPLES - 1 {
            assert!(!w.step(r, r - Q));
            assert!(w.seek_error(), "not settled yet");
        }
        assert!(!w.step(r, r));
        assert!(!w.seek_error(), "settled");
        assert!(!w.step(r, r + 2 * Q));
        assert!(w.seek_error(), "off again after its budget");
        assert!(!w.step(2 * r, r));
        assert!(!w.seek_error(), "a new command");
    }

    /// Ringing: readings more than a quantum past the target, side after side, report a seek
    /// error at the fourth crossing, long before the budget (T_e = 122 samples here), until the
    /// next command; readings within ±1 quantum take no side. Trips on a threshold of 3 or 5,
    /// on readings within the band counted as a side (the 2nd crossing would come early), or on
    /// crossings kept into the next command.
    #[test]
    fn a_ringing_command_reports_a_seek_error_at_its_fourth_crossing() {
        let mut w = CalibrationWatch::arm(&model());
        let r = 320 * Q;
        assert!(!w.step(r, 0));
        // (reading, crossings so far): a side only more than a quantum off.
        for (k, (y, crossings)) in [
            (0, 0),
            (r + 40 * Q, 1),
            (r + Q, 1),
            (r - Q, 1),
            (r + 3 * Q, 1),
            (r - 2 * Q, 2),
            (r, 2),
            (r + 2 * Q, 3),
            (r - 30 * Q, 4),
        ]
        .into_iter()
        .enumerate()
        {
            assert!(!w.step(r, y));
            assert_eq!(w.seek_error(), crossings >= 4, "sample {k}: {y}");
        }
        for _ in 0..SETTLED_SAMPLES {
            w.step(r, r);
        }
        assert!(w.seek_error(), "a ring is reported until the next command");
        assert!(!w.step(2 * r, r));
        assert!(!w.step(2 * r, 2 * r + 5 * Q));
        assert!(!w.seek_error(), "a new command: no crossings yet");
    }

    /// Hunting after settling: with the reading within ±1 quantum, three drive pulses past the
    /// calibrated breakaway level (0.01 full scale), each the other way, are not reported (a
    /// fine step or two and a brake), the fourth is, until the next command; drives at the level itself, a
    /// long pulse, repeated pulses the same way (a fine step's chatter) and pulses before the
    /// command settled do not count. Trips on counting samples instead of rises, on counting
    /// before settling, on a threshold of 1, 2 or 3, on counting same-way pulses, on the level's
    /// direction ignored, or on the count kept into the next command.
    #[test]
    fn alternating_pulses_past_the_breakaway_after_settling_report_a_hunt() {
        let bk = (0.01f32 * 65536.0) as i32;
        let mut w = CalibrationWatch::arm(&model());
        let r = 320 * Q;
        assert!(!w.step(r, 0));
        for k in 0..10 {
            assert!(!w.step(r, r));
            w.drive(if k % 2 == 0 { 4 * bk } else { -4 * bk });
            w.drive(0);
        }
        assert_eq!(w.pulses(), 0, "not settled yet");
        for _ in 0..SETTLED_SAMPLES {
            assert!(!w.step(r, r));
        }
        assert!(!w.seek_error(), "settled");
        for pulse in 1..4u8 {
            let sign = if pulse % 2 == 1 { 1 } else { -1 };
            for _ in 0..3 {
                for _ in 0..5 {
                    w.drive(sign * 2 * bk); // a long pulse, three times the same way
                }
                w.drive(sign * bk); // at the level: not past it
            }
            w.drive(-sign * bk); // at the level the other way
            assert!(!w.step(r, r));
            assert_eq!(w.pulses(), pulse);
            assert!(!w.seek_error(), "{pulse} pulses");
        }
        w.drive(-bk - 1);
        assert!(!w.step(r, r));
        assert!(w.seek_error(), "the fourth pulse, the other way again");
        for _ in 0..SETTLED_SAMPLES {
            assert!(!w.step(r, r));
        }
        assert!(w.seek_error(), "a hunt stays reported for its command");
        assert!(!w.step(2 * r, r));
        assert!(!w.seek_error(), "a new command");
        assert_eq!(w.pulses(), 0);
    }

    /// A breakaway level the search found far above the fitted Coulomb level (a heavy sled that
    /// had not moved before the next level) is capped at STICTION_MAX × Coulomb: four alternating
    /// pulses between the cap and the search's level report a hunt; without a fitted Coulomb
    /// level they stay below the watch's level. Trips on a watch at the search's level alone
    /// (the wider family's hunts that went unflagged).
    #[test]
    fn the_hunting_level_is_capped_by_the_fitted_coulomb_level() {
        let pulse = (0.01f32 * 65536.0) as i32; // past 3 × 0.002, below 0.03
        for (coulomb, reported) in [(0.002f32, true), (0.0, false)] {
            let mut w = CalibrationWatch::arm(&CalibratedModel {
                coulomb_fs: [coulomb; 2],
                breakaway_fs: [0.03, -0.03],
                ..model()
            });
            let r = 320 * Q;
            assert!(!w.step(r, 0));
            for _ in 0..SETTLED_SAMPLES + 10 {
                assert!(!w.step(r, r));
            }
            for k in 0..4 {
                w.drive(if k % 2 == 0 { pulse } else { -pulse });
                w.drive(0);
                assert!(!w.step(r, r));
            }
            assert_eq!(w.seek_error(), reported, "Coulomb {coulomb}");
        }
    }

    /// Off track after settling, long before the budget (122 samples): a reading outside ±1
    /// quantum raises the seek error at once and until 22 readings in a row are within 1 quantum
    /// again; before the command settled, within its budget, it does not. Trips on the former
    /// rule (nothing before the budget T_e), or on a seek reported while it moves.
    #[test]
    fn a_settled_command_off_track_is_reported_at_once() {
        let mut w = CalibrationWatch::arm(&model());
        let r = 320 * Q;
        assert!(!w.step(r, 0));
        for k in 1..40 {
            assert!(!w.step(r, k * 8 * Q));
            assert!(!w.seek_error(), "sample {k}: the seek, within its budget");
        }
        for _ in 0..SETTLED_SAMPLES {
            assert!(!w.step(r, r - Q));
        }
        assert!(!w.seek_error(), "settled");
        assert!(!w.step(r, r + 2 * Q));
        assert!(
            w.seek_error(),
            "off track at sample 62 of a 122-sample budget"
        );
        for _ in 0..SETTLED_SAMPLES - 1 {
            assert!(!w.step(r, r));
            assert!(w.seek_error(), "until 22 readings in the band again");
        }
        assert!(!w.step(r, r));
        assert!(!w.seek_error(), "on track again");
        assert!(!w.step(2 * r, r));
        assert!(!w.seek_error(), "a new command");
    }

    /// After a re-calibration the interrupted command is watched again with a new budget from
    /// the adoption (counted from its next sample), raises the seek error when it expires, and
    /// is not re-calibrated a second time. Trips on the former rule (an unlimited budget: the
    /// command never reported) or on a second re-calibration.
    #[test]
    fn a_command_calibrated_again_still_reports_a_seek_error() {
        let w = CalibrationWatch::arm(&model());
        let mut w = w.adopt(&model());
        let r = 320 * Q;
        // The next sample prices the command from where the sled is: 0 quanta away → 236, the
        // seek error's 82.
        assert!(!w.step(r, r - 5 * Q / 10));
        for k in 1..236 {
            assert!(!w.step(r, r - 5 * Q));
            assert_eq!(w.seek_error(), k >= 82, "sample {k}");
        }
        assert!(!w.step(r, r - 5 * Q), "no second re-calibration");
        assert!(w.seek_error());
    }

    /// `commands` commands of 320 quanta each that never settle (the reading stays 5 quanta
    /// off), from a watch `w`: the commands (bit c for command c, counted from 0) at whose
    /// budget it re-calibrates.
    fn recalibrations(w: &mut CalibrationWatch, commands: i64) -> u64 {
        let mut at = 0;
        for c in 0..commands {
            let r = (c + 1) * 320 * Q;
            assert!(!w.step(r, r - 320 * Q));
            for _ in 1..=276 {
                if w.step(r, r - 5 * Q) {
                    at |= 1 << c;
                }
            }
        }
        at
    }

    /// The back-off: a re-calibration that finds the same sled (K ×1.2, the Coulomb level 0.002
    /// FS up) makes the next need two commands in a row that miss their budget, then four (after
    /// another), while one that finds a changed sled (K ×2) resets it; a settled command starts
    /// the count again. Trips on a watch that re-calibrates on every missed command of a sled
    /// that does not change, or never again after a fruitless one.
    #[test]
    fn fruitless_recalibrations_back_off() {
        let mut w = CalibrationWatch::arm(&model());
        assert_eq!(recalibrations(&mut w, 1), 0b1, "the first missed command");
        let same = CalibratedModel {
            gain_k: 16.0 * 1.2,
            coulomb_fs: [0.002; 2],
            ..model()
        };
        w = w.adopt(&same);
        assert_eq!(w.fruitless(), 1);
        // The first command is the interrupted one (not re-calibrated again, not counted).
        assert_eq!(
            recalibrations(&mut w, 4),
            0b0100,
            "the second missed command after it"
        );
        w = w.adopt(&same);
        assert_eq!(w.fruitless(), 2);
        // A settled command between two misses starts the count again.
        assert_eq!(
            recalibrations(&mut w, 3),
            0,
            "the interrupted command, two misses"
        );
        let r = 100 * 320 * Q;
        assert!(!w.step(r, r));
        for _ in 0..SETTLED_SAMPLES {
            assert!(!w.step(r, r));
        }
        assert_eq!(
            recalibrations(&mut w, 4),
            0b1000,
            "four in a row after two fruitless ones"
        );
        let changed = CalibratedModel {
            gain_k: 16.0 * 2.4,
            ..model()
        };
        w = w.adopt(&changed);
        assert_eq!(w.fruitless(), 0, "a changed sled resets the back-off");
        assert_eq!(
            recalibrations(&mut w, 2),
            0b10,
            "the interrupted command is not redone, the next miss re-calibrates"
        );
    }
}
