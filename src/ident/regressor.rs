//! The lagged-signal history the regressors of eq. 1 and 2 are built from.

/// Largest input delay nk supported by the regressor history.
pub const MAX_DELAY: usize = 8;

use crate::num::fixed::SignalI16F16;

/// Shifts `x` into the front of `lags` (every element moves one place back) and returns the
/// element that fell off the end (`x` itself for an empty array): `rotate_right(1)` and a store,
/// without the `memmove` call (and its 1.5 KB of flash) that `rotate_right` compiles to.
#[inline(always)]
fn shift_in<const M: usize>(lags: &mut [SignalI16F16; M], x: SignalI16F16) -> SignalI16F16 {
    let mut carry = x;
    for slot in lags.iter_mut() {
        carry = core::mem::replace(slot, carry);
    }
    carry
}

/// Lagged outputs and inputs: `y_lag[i] = y(t−1−i)`, `u_lag[i] = u(t−i)` (after [`History::push_input`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct History<const N: usize> {
    y_lag: [SignalI16F16; N],
    u_lag: [SignalI16F16; N],
    u_delay: [SignalI16F16; MAX_DELAY],
}

impl<const N: usize> Default for History<N> {
    fn default() -> Self {
        Self {
            y_lag: [SignalI16F16::ZERO; N],
            u_lag: [SignalI16F16::ZERO; N],
            u_delay: [SignalI16F16::ZERO; MAX_DELAY],
        }
    }
}

impl<const N: usize> History<N> {
    /// Records u(t) at the start of sample t; afterwards `input_lag(m)` is u(t − m).
    pub fn push_input(&mut self, u: SignalI16F16) {
        // One delay line of MAX_DELAY + N samples, split in two arrays: u_delay holds
        // u(t)…u(t−MAX_DELAY+1) and u_lag continues with u(t−MAX_DELAY)…. The sample that
        // falls off the end of u_delay enters u_lag.
        let spill = shift_in(&mut self.u_delay, u);
        shift_in(&mut self.u_lag, spill);
    }

    /// Records the output used for lag 1 at the next sample (y(t), or ŷ(t) for output error).
    pub fn push_output(&mut self, y: SignalI16F16) {
        shift_in(&mut self.y_lag, y);
    }

    /// u(t − m) for 0 ≤ m < MAX_DELAY + N (zero beyond).
    pub fn input_lag(&self, m: usize) -> SignalI16F16 {
        if m < MAX_DELAY {
            self.u_delay.get(m).copied().unwrap_or(SignalI16F16::ZERO)
        } else {
            self.u_lag
                .get(m - MAX_DELAY)
                .copied()
                .unwrap_or(SignalI16F16::ZERO)
        }
    }

    /// The output lagged by `m ≥ 1` samples (zero beyond the history).
    pub fn output_lag(&self, m: usize) -> SignalI16F16 {
        m.checked_sub(1)
            .and_then(|i| self.y_lag.get(i))
            .copied()
            .unwrap_or(SignalI16F16::ZERO)
    }

    /// The regressor `[−y(t−1) … −y(t−na), u(t−nk) … u(t−nk−nb+1)]` (eq. 1/2 of the paper).
    pub fn regressor(&self, na: usize, nk: usize) -> [SignalI16F16; N] {
        let mut phi = [SignalI16F16::ZERO; N];
        for (i, p) in phi.iter_mut().enumerate() {
            *p = if i < na {
                SignalI16F16::ZERO.saturating_sub(self.output_lag(i + 1))
            } else {
                self.input_lag(nk + (i - na))
            };
        }
        phi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(x: i32) -> SignalI16F16 {
        SignalI16F16::from_int(x)
    }

    #[test]
    fn shift_in_is_rotate_right_and_a_store() {
        let mut a = [s(1), s(2), s(3)];
        let mut b = a;
        assert_eq!(shift_in(&mut a, s(9)), s(3));
        b.rotate_right(1);
        b[0] = s(9);
        assert_eq!(a, b);
        assert_eq!(shift_in(&mut [], s(5)), s(5));
    }

    #[test]
    fn regressor_orders_lags_as_in_eq_1() {
        let mut h = History::<4>::default();
        for t in 1..=12 {
            h.push_input(s(t));
            if t < 12 {
                h.push_output(s(100 + t));
            }
        }
        // Now at t = 12: y(t−1) = 111, u(t) = 12.
        let phi = h.regressor(2, 1);
        assert_eq!(phi, [s(-111), s(-110), s(11), s(10)]);
        let phi0 = h.regressor(1, 0);
        assert_eq!(phi0, [s(-111), s(12), s(11), s(10)]);
        // Crossing from the delay line into the lag line.
        assert_eq!(h.input_lag(8), s(4));
        assert_eq!(h.input_lag(11), s(1));
        assert_eq!(h.input_lag(12), s(0));
    }
}
