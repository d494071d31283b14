//! Compensation of an identified static input nonlinearity: the inverse of a monotone Hammerstein
//! input map, precomputed as a table.
//!
//! The paper's nonlinear models put a small net on the lagged input (eq. 5, eq. 7, §5):
//! `ŷ(t) = −f₁ŷ(t−1) + b₁u(t−1) + g(u(t−1))`, `g(u) = w·tanh(a·u + c)`. Divided by b₁ the plant
//! sees the effective input
//!
//! ```text
//! h(u) = u + w·tanh(a·u + c)          (w already divided by b₁: full-scale units)
//! ```
//!
//! and a linear controller that asks for the effective drive v gets it with `u = h⁻¹(v)`. A
//! Coulomb-like friction of u_c (fraction of full scale) is `w = −u_c`, `a ≈ 1/u_c` (a dead zone,
//! softened so that h stays increasing: `1 + w·a·(1 − tanh²) ≥ 0` needs `|w·a| ≤ 1`).
//!
//! # Table
//! h is evaluated with the library's fixed-point [`Neuron`] (the same tanh table as the
//! estimator), and inverted at design time by bisection on I16F16 at `2^K + 1` grid points
//! `v_j = v₀ + j·2^s` spanning ±`range`. Per sample `u = h⁻¹(v)` is one linear interpolation;
//! outside the grid `h(u) − u` is taken as constant (h has slope 1 once tanh saturates).
//!
//! # Formats and overflow
//! | quantity | format |
//! |---|---|
//! | v, u, table entries | I16F16 `i32` (fraction of full scale) |
//! | grid step | 2^s raw, s ≤ 16 |
//! | interpolation | `(t₁ − t₀)·frac` in `i64` (< 2⁴⁸), then `>> s` |
//!
//! Sums saturate (`saturating_add`): a v near ±32,768 full scales cannot wrap.

#![deny(clippy::float_arithmetic)]

use super::ConfigError;
use crate::ident::neuron::Neuron;
use crate::num::fixed::{ParamI12F20, SignalI16F16, shr_round_i64};
use crate::num::float_bits::from_fixed;
use crate::words::{WordReader, WordWriter, Words};

/// Grid intervals of the inverse table (2^5).
pub const MAP_INTERVALS_LOG2: u32 = 5;
/// Entries of the inverse table.
pub const MAP_ENTRIES: usize = (1 << MAP_INTERVALS_LOG2) + 1;

/// `u = h⁻¹(v)` as a table on a power-of-two grid (`Copy`, 33 × 4 B + 8 B).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InverseInputMap {
    /// The forward map's neuron (h(u) = u + neuron(u)), for bumpless transfers.
    neuron: Neuron,
    /// First grid point v₀, I16F16 raw.
    v0: i32,
    /// log₂ of the grid step (raw).
    shift: u32,
    /// u at each grid point, I16F16 raw.
    table: [i32; MAP_ENTRIES],
}

/// h(u) = u + neuron(u), saturating.
fn forward(neuron: &Neuron, u: i32) -> i32 {
    u.saturating_add(neuron.value(SignalI16F16::from_raw(u)).raw())
}

impl InverseInputMap {
    /// The inverse of `h(u) = u + w·tanh(a·u + c)` over `v ∈ ±range_fs` (fraction of full scale).
    ///
    /// # Errors
    /// [`ConfigError::CompensationMap`] when `range_fs` is not in (0, 16384) or h is not increasing
    /// over the table (then it has no inverse: |w·a| > 1).
    pub fn from_neuron(neuron: &Neuron, range_fs: f64) -> Result<Self, ConfigError> {
        match SignalI16F16::from_f64(range_fs) {
            Ok(r) if r.raw() > 0 && range_fs < 16_384.0 => Self::from_neuron_raw(neuron, r.raw()),
            _ => Err(ConfigError::CompensationMap(range_fs)),
        }
    }

    /// [`Self::from_neuron`] over ±`range` (I16F16 raw, in (0, 2³⁰)): integer arithmetic only, for
    /// a redesign on a core without a double-precision FPU.
    ///
    /// # Errors
    /// As [`Self::from_neuron`].
    pub fn from_neuron_raw(neuron: &Neuron, range: i32) -> Result<Self, ConfigError> {
        let bad = ConfigError::CompensationMap(from_fixed(i64::from(range), 16));
        if !(range > 0 && range < 1 << 30) {
            return Err(bad);
        }
        // Smallest step 2^s with 2^K·2^s ≥ 2·range.
        let mut shift = 0;
        while (1i64 << (shift + MAP_INTERVALS_LOG2)) < 2 * i64::from(range) {
            shift += 1;
        }
        let span = 1i64 << (shift + MAP_INTERVALS_LOG2);
        let v0 = -(span / 2) as i32; // |span/2| ≤ 2^30: fits
        let mut table = [0i32; MAP_ENTRIES];
        let mut previous = i32::MIN;
        for (j, entry) in table.iter_mut().enumerate() {
            let v = v0.saturating_add(((j as i64) << shift) as i32);
            // h(u) − u = w·tanh ∈ [−|w|, |w|]: the root lies in v ∓ |w| (plus rounding).
            let reach = neuron.w().raw().unsigned_abs() >> (20 - 16); // I12F20 → I16F16
            let reach = reach.saturating_add(2) as i32;
            let (mut lo, mut hi) = (v.saturating_sub(reach), v.saturating_add(reach));
            if forward(neuron, lo) > v || forward(neuron, hi) < v {
                return Err(bad);
            }
            // Invariant h(lo) ≤ v ≤ h(hi); |hi − lo| < 2^31 halves each step.
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if forward(neuron, mid) <= v {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            if lo < previous {
                return Err(bad);
            }
            previous = lo;
            *entry = lo;
        }
        // Strictly increasing h means non-decreasing entries; a flat h would repeat them. Check
        // monotonicity of h itself on a fine grid so a non-invertible map is refused.
        let mut last = forward(neuron, v0.saturating_sub(range));
        let mut u = v0.saturating_sub(range);
        let step = (1i32 << shift) >> 2;
        let step = step.max(1);
        let end = v0.saturating_add((span as i32).saturating_add(range));
        while u < end {
            u = u.saturating_add(step);
            let h = forward(neuron, u);
            if h < last {
                return Err(bad);
            }
            last = h;
        }
        let map = Self {
            neuron: *neuron,
            v0,
            shift,
            table,
        };
        map.validate()?;
        Ok(map)
    }

    /// The invariants [`Self::apply`] relies on, checked by [`Self::from_neuron`] and by the
    /// decoding of configuration words alike: a grid step `2^s` with `s ≤ 26`, the grid centred
    /// (`v₀ = −2^(s + K − 1)`), and a non-decreasing table.
    ///
    /// # Errors
    /// [`ConfigError::CompensationMap`] (with the grid's half-span, fraction of full scale).
    pub fn validate(&self) -> Result<(), ConfigError> {
        // `&&` keeps the shift in range before it is used.
        let grid = self.shift <= 26
            && i64::from(self.v0) == -(1i64 << (self.shift + MAP_INTERVALS_LOG2 - 1));
        let monotone = self.table.windows(2).all(|p| p.first() <= p.get(1));
        if grid && monotone {
            Ok(())
        } else {
            Err(ConfigError::CompensationMap(from_fixed(
                -i64::from(self.v0),
                16,
            )))
        }
    }

    /// The friction-like map `w = −u_c`, `a = softness/u_c`, `c = 0` (softness < 1 keeps h
    /// increasing), inverted over ±`range_fs`.
    ///
    /// # Errors
    /// [`ConfigError::CompensationMap`] for a Coulomb level or softness out of range, or the
    /// errors of [`Self::from_neuron`].
    #[allow(clippy::float_arithmetic)] // design time
    pub fn coulomb(coulomb_fs: f64, softness: f64, range_fs: f64) -> Result<Self, ConfigError> {
        if !(coulomb_fs.is_finite() && coulomb_fs > 0.0 && softness > 0.0 && softness < 1.0) {
            return Err(ConfigError::CompensationMap(coulomb_fs));
        }
        let q = |v: f64| ParamI12F20::from_f64(v).map_err(|_| ConfigError::CompensationMap(v));
        let neuron = Neuron::new(
            q(-coulomb_fs)?,
            q(softness / coulomb_fs)?,
            ParamI12F20::ZERO,
        );
        Self::from_neuron(&neuron, range_fs)
    }

    /// [`Self::coulomb`] from an identified Coulomb level `coulomb_i16f16` (full scale, I16F16
    /// raw, > 0): w = −u_c, a = 0.9/u_c, over ±`range` (I16F16 raw) — integer arithmetic only
    /// (the redesign's, outside the interrupt).
    ///
    /// # Errors
    /// [`ConfigError::CompensationMap`] for a level that is not positive or makes `a` leave the
    /// I12F20 range, or the errors of [`Self::from_neuron_raw`].
    pub fn coulomb_raw(coulomb_i16f16: i32, range: i32) -> Result<Self, ConfigError> {
        let bad = ConfigError::CompensationMap(from_fixed(i64::from(coulomb_i16f16), 16));
        if coulomb_i16f16 <= 0 {
            return Err(bad);
        }
        // w = −u_c in I12F20 (×16); a = 0.9/u_c in I12F20: 0.9·2²⁰·2¹⁶ / raw.
        let w = i64::from(coulomb_i16f16) << 4;
        let a = (943_718i64 << 16) / i64::from(coulomb_i16f16); // 0.9·2²⁰ = 943,718
        if w > i64::from(i32::MAX) || a > i64::from(i32::MAX) {
            return Err(bad);
        }
        let neuron = Neuron::new(
            ParamI12F20::from_raw(-(w as i32)),
            ParamI12F20::from_raw(a as i32),
            ParamI12F20::ZERO,
        );
        Self::from_neuron_raw(&neuron, range)
    }

    /// u = h⁻¹(v), I16F16 raw in and out; never panics.
    #[inline]
    pub fn apply(&self, v: i32) -> i32 {
        let offset = i64::from(v) - i64::from(self.v0);
        let last = MAP_ENTRIES - 1;
        let (first_u, last_u) = (
            self.table.first().copied().unwrap_or(0),
            self.table.get(last).copied().unwrap_or(0),
        );
        if offset < 0 {
            // Below the grid: h(u) − u constant, u − v = first_u − v₀.
            return v.saturating_add(first_u.saturating_sub(self.v0));
        }
        let index = (offset >> self.shift) as usize; // offset < 2^33: fits
        if index >= last {
            let v_last = i64::from(self.v0) + ((last as i64) << self.shift);
            let delta = (i64::from(last_u) - v_last) as i32; // |·| ≤ |w| + 2 quanta-ish
            return v.saturating_add(delta);
        }
        let frac = offset & ((1i64 << self.shift) - 1);
        let t0 = self.table.get(index).copied().unwrap_or(0);
        let t1 = self.table.get(index + 1).copied().unwrap_or(t0);
        // |t1 − t0| < 2^32, frac < 2^16: product < 2^48.
        let step = shr_round_i64((i64::from(t1) - i64::from(t0)) * frac, self.shift);
        (i64::from(t0) + step) as i32 // between t0 and t1
    }

    /// The forward map h(u) = u + w·tanh(a·u + c), I16F16 raw, saturating.
    #[inline]
    pub fn forward(&self, u: i32) -> i32 {
        forward(&self.neuron, u)
    }

    /// The neuron of the forward map.
    pub fn neuron(&self) -> Neuron {
        self.neuron
    }

    /// The grid: (v₀, step) in I16F16 raw, and the table.
    pub fn grid(&self) -> (i32, i32, &[i32; MAP_ENTRIES]) {
        (self.v0, 1 << self.shift, &self.table)
    }
}

/// Words: the neuron (w, a, c raw I12F20), v₀, s, the table. Checked as
/// [`InverseInputMap::from_neuron`] builds it: s ≤ 26 (a range below 16,384 full scales),
/// `v₀ = −2^(s + K − 1)`, entries non-decreasing.
impl Words for InverseInputMap {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        [self.neuron.w(), self.neuron.a(), self.neuron.c()].put(w)?;
        self.v0.put(w)?;
        self.shift.put(w)?;
        self.table.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let [nw, na, nc] = <[ParamI12F20; 3]>::take(r);
        let v0 = i32::take(r);
        let shift = u32::take(r);
        let table = <[i32; MAP_ENTRIES]>::take(r);
        Self {
            neuron: Neuron::new(nw, na, nc),
            v0,
            shift,
            table,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_of_the_identity_and_of_a_coulomb_map() {
        // w = 0: h is the identity, the inverse too.
        let id = InverseInputMap::from_neuron(&Neuron::default(), 0.05).unwrap();
        for v in [-40_000, -3_000, -1, 0, 1, 777, 3_276, 40_000] {
            assert!((id.apply(v) - v).abs() <= 1, "{v}");
        }
        // Coulomb 0.0075 full scale (37.5 mV at 5 V): far from 0, u = v ± 0.0075.
        let c = InverseInputMap::coulomb(0.0075, 0.9, 0.04).unwrap();
        let uc = 492; // 0.0075 · 65536
        for v in [2_000, 2_621, 10_000] {
            assert!((c.apply(v) - (v + uc)).abs() < 20, "{v}: {}", c.apply(v));
            assert!((c.apply(-v) + (v + uc)).abs() < 20, "{v}");
        }
        // Monotone and odd (to the grid's rounding) everywhere.
        let mut last = i32::MIN;
        for v in (-5_000..5_000).step_by(7) {
            let u = c.apply(v);
            assert!(u >= last);
            last = u;
        }
        assert_eq!(c.apply(i32::MAX), i32::MAX);
        assert!(c.apply(i32::MIN) <= i32::MIN / 2);
    }

    #[test]
    fn non_invertible_maps_are_refused() {
        // |w·a| = 2 > 1: h decreases near 0.
        let w = ParamI12F20::from_f64(-0.01).unwrap();
        let a = ParamI12F20::from_f64(200.0).unwrap();
        assert!(matches!(
            InverseInputMap::from_neuron(&Neuron::new(w, a, ParamI12F20::ZERO), 0.04),
            Err(ConfigError::CompensationMap(_))
        ));
        assert!(InverseInputMap::coulomb(0.0075, 1.5, 0.04).is_err());
        assert!(InverseInputMap::coulomb(0.0075, 0.9, 0.0).is_err());
        assert!(InverseInputMap::coulomb(f64::NAN, 0.9, 0.04).is_err());
    }
}
