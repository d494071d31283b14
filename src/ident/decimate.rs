//! Anti-alias low-pass and decimation by 2, on-line: a 23-tap linear-phase half-band FIR evaluated
//! only at the kept samples.
//!
//! # Equation
//! The paper halves the sampling rate of the sled data "by first low-pass filtering the data to
//! avoid aliasing, and then picking out every second data sample" (§4, Figure 9). With x the input
//! at Ts and y the output at 2·Ts:
//!
//! ```text
//! y(m) = Σₙ h(n)·x(2m + 1 − n),   n = 0 … 22
//! h(11) = 1/2,   h(11 ± k) = 0 for even k ≠ 0,   h(11 − k) = h(11 + k)       (half-band, symmetric)
//! ```
//!
//! so one output needs 6 multiplies (one per symmetric pair of non-zero taps) and a shift (the
//! centre tap). [`DecimatorConfig::push`] returns an output for every second input (the 2nd, 4th, …):
//! n inputs give ⌊n/2⌋ outputs. Run the same filter on u and y: the identified model is then the
//! plant's at 2·Ts, unaffected by the filter's delay and its passband gain.
//!
//! # Design
//! Equiripple half-band (Vaidyanathan–Nguyen): the 12-tap type-II one-band filter
//! `G = remez(12, [0, 0.28], [1], fs = 1)` (`scipy.signal.remez`), scaled to G(0) = 1, spread onto the
//! even taps (h(2k) = g(k)/2) with h(11) = 1/2; quantised to I1F31 with the largest coefficient
//! adjusted by one unit so that the DC gain is exactly 1 (a constant input gives exactly the same
//! constant output). Figures of the quantised filter, frequencies as fractions of the *input* rate:
//!
//! | figure | value |
//! |---|---|
//! | taps | 23 (13 non-zero: 6 symmetric pairs and the centre) |
//! | passband edge | 0.14·fs (308 Hz at Ts = 0.455 ms; 56 % of the output Nyquist) |
//! | passband ripple | \|H − 1\| ≤ 5.5·10⁻⁵ (±0.00048 dB) |
//! | stopband edge | 0.36·fs: everything that aliases onto the passband is attenuated |
//! | stopband attenuation | ≥ 85.2 dB |
//! | gain at fs/4 | exactly 1/2 (half-band) |
//! | DC gain | exactly 1 |
//! | group delay | 11 input samples (linear phase): y(m) estimates the filtered signal at input time 2m − 10, 5.5 output samples before the output time m + ½ |
//! | ℓ₁ norm Σ\|h\| | 1.3875 (worst-case gain) |
//!
//! # Formats
//! | quantity | format | note |
//! |---|---|---|
//! | x, y | I16F16 ([`SignalI16F16`]) | any signal of the path |
//! | h(11 ± (2j+1)), j = 0 … 5 | I1F31 `i32` | \|h\| < 0.32; the centre 1/2 is a shift |
//! | pair sum x(a) + x(b) | 33 bits, `i64` | multiplied as 2·h·⌊s/2⌋ + h·(s mod 2): one 32×32 product |
//! | accumulator | I17F47 `i64` | exact |
//!
//! # Scaling and overflow
//! Every product is exact and the sum is exact: |acc| ≤ Σ|h|·2³¹·2³¹ = 1.39·2⁶² < 2⁶³. The only
//! rounding is the final I17F47 → I16F16 (half up). The output saturates (flagged
//! [`Status::SATURATED`]) only when |x| exceeds 32,768/1.3875 ≈ 23,600 with the worst-case sign
//! pattern; a steady sine of amplitude ≤ 32,766 does not (|H| ≤ 1 + 5.5·10⁻⁵).
//!
//! # Accuracy
//! Against exact (f64) filtering of the same I16F16 input with the quantised coefficients: error
//! ≤ ½ LSB (2⁻¹⁷), the final rounding. Against the unquantised f64 design: in addition ≤ 12·2⁻³²·|x|
//! (coefficient rounding). Asserted in `host-tests/tests/integration/neuron_decimate.rs`:
//! `decimator_impulse_response_equals_the_reference`, `decimator_sine_sweep_meets_the_figures`
//! (ripple and attenuation measured by sine sweeps through this filter), and
//! `decimator_on_silverbox_matches_float64` (RMS and max error on a real recording).
//!
//! # Cost
//! Per output: 6 widening multiplies ([`mul_i32_wide`]: `UMULL` with sign fix-ups on Armv7-M, four
//! `MULS` on Armv6-M) and 13 loads; per discarded input: one store. Measured per call:
//! `bench_decimate_push` in BENCHMARKS.md.
//!
//! State per signal (`DecimatorState`): 30 words of delay line (the 12 newest second-of-pair samples
//! stored twice, 6 first-of-pair samples) and two indices, 132 B on a 32-bit target.

#![deny(clippy::float_arithmetic)]

use crate::ident::status::Status;
use crate::num::fixed::{SignalI16F16, sat_i32, shr_round_i64};
use crate::num::wide::mul_i32_wide;

/// Number of taps of the filter.
pub const TAPS: usize = 23;
/// Number of distinct non-zero off-centre coefficients (symmetric pairs).
pub const HALF_TAPS: usize = 6;
/// Group delay in input samples (the centre tap).
pub const GROUP_DELAY_SAMPLES: usize = 11;
/// The samples that meet the symmetric pairs at an output: every second input, 12 of them.
const BRANCH: usize = 2 * HALF_TAPS;
/// The other branch only feeds the centre tap, 5 of its samples back.
const CENTRE: usize = HALF_TAPS;

/// The quantised half-band filter (`Copy`): coefficients h(11 ± 1), h(11 ± 3), …, h(11 ± 11).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecimatorConfig {
    h_i1f31: [i32; HALF_TAPS],
}

impl DecimatorConfig {
    /// The documented 23-tap half-band (passband 0.14·fs, ≥ 85.2 dB from 0.36·fs, DC gain 1).
    pub const HALF_BAND_23: Self = Self {
        h_i1f31: [
            666_596_133,
            -181_155_898,
            71_137_186,
            -25_698_591,
            7_176_919,
            -1_184_837,
        ],
    };

    /// The off-centre coefficients h(11 ± (2j + 1)), j = 0 … 5, in I1F31 (the centre is 1/2).
    pub const fn half_band_i1f31(&self) -> [i32; HALF_TAPS] {
        self.h_i1f31
    }

    /// A fresh state for this filter.
    pub const fn new_state(&self) -> DecimatorState {
        DecimatorState::new()
    }

    /// Takes one input sample; returns the decimated output after every second input.
    ///
    /// ```
    /// use sledid::ident::decimate::{DecimatorConfig, DecimatorState};
    /// use sledid::SignalI16F16;
    /// let cfg = DecimatorConfig::default();
    /// let mut st = DecimatorState::new();
    /// let x = SignalI16F16::from_int(7);
    /// let out: Vec<_> = (0..40).filter_map(|_| cfg.push(&mut st, x)).collect();
    /// assert_eq!(out.len(), 20);
    /// assert_eq!(out.last().unwrap().y, x); // DC gain exactly 1
    /// ```
    pub fn push(&self, st: &mut DecimatorState, x: SignalI16F16) -> Option<Decimated> {
        if !st.odd {
            // First of a pair: it only ever meets the centre tap.
            if let Some(slot) = st.centre_i16f16.get_mut(st.centre_pos) {
                *slot = x.raw();
            }
            st.centre_pos = if st.centre_pos + 1 >= CENTRE {
                0
            } else {
                st.centre_pos + 1
            };
            st.odd = true;
            return None;
        }
        st.odd = false;
        // Second of a pair: into the doubled branch buffer, newest first at `pos`.
        st.pos = if st.pos == 0 { BRANCH - 1 } else { st.pos - 1 };
        for i in [st.pos, st.pos + BRANCH] {
            if let Some(slot) = st.branch_i16f16.get_mut(i) {
                *slot = x.raw();
            }
        }
        // Centre tap x(2m + 1 − 11): the oldest of the other branch's six, × 1/2 → I17F47.
        let centre = st.centre_i16f16.get(st.centre_pos).copied().unwrap_or(0);
        let mut acc_i17f47 = i64::from(centre) << 30;
        if let Some(window) = st.branch_i16f16.get(st.pos..st.pos + BRANCH) {
            let (newer, older) = window.split_at(HALF_TAPS);
            // Pair k (age k and 11 − k, k = 0 … 5) has offset 11 − 2k from the centre: h[5 − k].
            for ((&a, &b), &h) in newer
                .iter()
                .zip(older.iter().rev())
                .zip(self.h_i1f31.iter().rev())
            {
                // s = a + b needs 33 bits: h·s = 2·h·⌊s/2⌋ + h·(s mod 2), exactly.
                let s = i64::from(a) + i64::from(b);
                let half = (s >> 1) as i32; // ⌊s/2⌋ ∈ [−2^31, 2^31): exact
                let odd = if s & 1 != 0 { i64::from(h) } else { 0 };
                // |h·s| ≤ |h|·2^32; Σ over the pairs plus the centre ≤ 1.39·2^62 (module doc).
                acc_i17f47 += (mul_i32_wide(h, half) << 1) + odd;
            }
        }
        let mut sat = false;
        let y = sat_i32(shr_round_i64(acc_i17f47, 31), &mut sat);
        Some(Decimated {
            y: SignalI16F16::from_raw(y),
            status: if sat { Status::SATURATED } else { Status::NONE },
        })
    }
}

impl Default for DecimatorConfig {
    fn default() -> Self {
        Self::HALF_BAND_23
    }
}

/// One decimated output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Decimated {
    /// The low-passed signal at the output rate.
    pub y: SignalI16F16,
    /// [`Status::SATURATED`] when the output saturated.
    pub status: Status,
}

/// The delay line: the last 23 inputs split into the two polyphase branches, and the phase.
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecimatorState {
    /// Second-of-pair inputs, each stored twice (at i and i + 12) so the 12 newest are always the
    /// contiguous window `pos .. pos + 12`, newest first.
    branch_i16f16: [i32; 2 * BRANCH],
    pos: usize,
    /// First-of-pair inputs, a ring of 6; `centre_pos` is the oldest (the centre tap's sample).
    centre_i16f16: [i32; CENTRE],
    centre_pos: usize,
    /// The next input is the second of a pair (it produces an output).
    odd: bool,
}

impl DecimatorState {
    /// Zero history, next input is the first of a pair.
    pub const fn new() -> Self {
        Self {
            branch_i16f16: [0; 2 * BRANCH],
            pos: 0,
            centre_i16f16: [0; CENTRE],
            centre_pos: 0,
            odd: false,
        }
    }

    /// Back to [`DecimatorState::new`].
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

impl Default for DecimatorState {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_dc_gain_and_symmetry() {
        let h = DecimatorConfig::HALF_BAND_23.half_band_i1f31();
        assert_eq!(h.iter().map(|&v| i64::from(v)).sum::<i64>(), 1 << 29);
        let cfg = DecimatorConfig::default();
        for v in [i32::MIN, -1, 1, i32::MAX] {
            let mut st = DecimatorState::new();
            let mut last = None;
            for _ in 0..2 * TAPS {
                if let Some(o) = cfg.push(&mut st, SignalI16F16::from_raw(v)) {
                    last = Some(o);
                }
            }
            assert_eq!(last.map(|o| o.y.raw()), Some(v));
        }
    }

    #[test]
    fn impulse_gives_every_tap_once() {
        let cfg = DecimatorConfig::default();
        let h = cfg.half_band_i1f31();
        let mut taps = [0i64; TAPS];
        for shift in 0..2 {
            let mut st = DecimatorState::new();
            let mut m = 0;
            for n in 0..TAPS + 2 {
                let x = if n == shift { 1 << 30 } else { 0 };
                if let Some(o) = cfg.push(&mut st, SignalI16F16::from_raw(x)) {
                    // Output m sees the impulse at lag 2m + 1 − shift.
                    if let Some(t) = taps.get_mut(2 * m + 1 - shift) {
                        *t = i64::from(o.y.raw());
                    }
                    m += 1;
                }
            }
        }
        for (n, &t) in taps.iter().enumerate() {
            let k = n.abs_diff(GROUP_DELAY_SAMPLES);
            let want = match k {
                0 => 1 << 29,
                k if k % 2 == 1 => (i64::from(h[(k - 1) / 2]) + 1) >> 1,
                _ => 0,
            };
            assert!((t - want).abs() <= 1, "tap {n}: {t} vs {want}");
        }
    }

    #[test]
    fn saturates_with_a_flag() {
        let cfg = DecimatorConfig::default();
        let mut st = DecimatorState::new();
        let h = cfg.half_band_i1f31();
        // Worst-case sign pattern at full scale: sign(h) at every tap.
        let mut flagged = false;
        for n in 0..TAPS + 1 {
            let k = (TAPS - n).abs_diff(GROUP_DELAY_SAMPLES);
            let sign = if k % 2 == 1 && h[(k - 1) / 2] < 0 {
                -1
            } else {
                1
            };
            let x = if sign > 0 { i32::MAX } else { i32::MIN };
            if let Some(o) = cfg.push(&mut st, SignalI16F16::from_raw(x)) {
                flagged |= o.status == Status::SATURATED;
            }
        }
        assert!(flagged);
        st.reset();
        assert_eq!(st, DecimatorState::new());
    }
}
