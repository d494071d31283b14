//! Conditional integration, the anti-windup every integrating law here uses (the baseline PID and
//! the scheduled controller's settle law): one copy.
//!
//! ```text
//! I* = clamp(I(k−1) + ΔI, ±I_max)
//! I(k) = I(k−1)   if |T + I*| > u_max and I* − I(k−1) has the sign of T + I*   (held: no windup)
//!        I*       otherwise
//! ```
//! with T the law's other terms. Everything I32F32 (`i64`); sums saturate.

#![deny(clippy::float_arithmetic)]

use crate::num::gain::clamp_sym_i64;

/// What one conditional integration step did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Integration {
    /// The clamp ±I_max bound.
    pub limited: bool,
    /// The integrator was held: it would have wound further into saturation.
    pub held: bool,
}

/// One step of conditional integration of `integral_i32f32` by `increment_i32f32`, the law's other
/// terms being `terms_i32f32`, with the integrator limit `i_max_i32f32 ≥ 0` and the output limit
/// `u_max_i32f32 ≥ 0`.
#[inline(always)]
pub fn integrate(
    integral_i32f32: &mut i64,
    increment_i32f32: i64,
    terms_i32f32: i64,
    i_max_i32f32: i64,
    u_max_i32f32: i64,
) -> Integration {
    let previous = *integral_i32f32;
    let wanted = previous.saturating_add(increment_i32f32);
    let candidate = clamp_sym_i64(wanted, i_max_i32f32);
    let v = terms_i32f32.saturating_add(candidate);
    let held =
        (v > u_max_i32f32 && candidate > previous) || (v < -u_max_i32f32 && candidate < previous);
    if !held {
        *integral_i32f32 = candidate;
    }
    Integration {
        limited: candidate != wanted,
        held,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_clamps_and_holds_only_when_winding_further() {
        let mut i = 0;
        // Plain integration.
        assert_eq!(integrate(&mut i, 5, 0, 100, 1_000), Integration::default());
        assert_eq!(i, 5);
        // The clamp binds.
        let r = integrate(&mut i, 500, 0, 100, 1_000);
        assert_eq!((i, r.limited, r.held), (100, true, false));
        // Saturated output and the integrator growing toward it: held.
        let r = integrate(&mut i, -10, -2_000, 100, 1_000);
        assert_eq!((i, r.held), (100, true), "{r:?}");
        // Saturated, but the integrator unwinding: allowed.
        let r = integrate(&mut i, -10, 2_000, 100, 1_000);
        assert_eq!((i, r.held), (90, false));
        // Extremes saturate, never panic: at the top already, nothing moves.
        let mut j = i64::MAX;
        let r = integrate(&mut j, i64::MAX, i64::MAX, i64::MAX, 0);
        assert_eq!((j, r), (i64::MAX, Integration::default()));
        let mut j = 0;
        let r = integrate(&mut j, i64::MIN, i64::MIN, i64::MAX - 1, 0);
        assert!(r.held && r.limited && j == 0, "{r:?}");
    }
}
