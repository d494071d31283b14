//! The sample interrupt's clocks, shared by the QEMU image (`firmware/src/main.rs`) and the board
//! image (`boards/stm32f411`): overrun detection with SysTick's COUNTFLAG on every core, the
//! handler's length in SysTick ticks, and on Cortex-M4 the DWT cycle counter.
//!
//! On entry the handler clears COUNTFLAG (set by the wrap that raised the interrupt); on exit a
//! set COUNTFLAG means the counter wrapped again while it ran — the next period had begun: an
//! overrun, counted. A handler that ends in time has run `reload − VAL` ticks since its period
//! began (interrupt latency included): with SysTick on the core clock, core cycles.

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;

/// Programs SysTick for the sample period: the core clock, `reload` (ticks per period − 1), the
/// counter cleared, its interrupt and the counter enabled.
pub fn start_sample_clock(syst: &mut SYST, reload: u32) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(reload);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// The handler's clocks.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timing {
    /// Handlers that ended after the next period had begun.
    pub overruns: u32,
    /// Longest handler that did not overrun, SysTick ticks since its period began.
    pub max_ticks: u32,
    /// Longest handler, DWT cycles from entry to exit (Cortex-M4; stays 0 without a DWT, as under
    /// QEMU, which does not model it).
    pub dwt_max_cycles: u32,
    /// DWT cycle count at this handler's entry.
    #[cfg(target_abi = "eabihf")]
    dwt_entry: u32,
}

impl Timing {
    /// On entry: clears COUNTFLAG (set by the wrap that raised this interrupt).
    #[inline(always)]
    pub fn enter(&mut self, syst: &mut SYST) {
        let _ = syst.has_wrapped();
        #[cfg(target_abi = "eabihf")]
        {
            self.dwt_entry = cortex_m::peripheral::DWT::cycle_count();
        }
    }

    /// On exit: an overrun if the counter wrapped again, else the handler's length.
    #[inline(always)]
    pub fn exit(&mut self, syst: &mut SYST, reload: u32) {
        let now = SYST::get_current();
        if syst.has_wrapped() {
            self.overruns = self.overruns.wrapping_add(1);
        } else {
            self.max_ticks = self.max_ticks.max(reload.saturating_sub(now));
        }
        #[cfg(target_abi = "eabihf")]
        {
            let cycles = cortex_m::peripheral::DWT::cycle_count().wrapping_sub(self.dwt_entry);
            self.dwt_max_cycles = self.dwt_max_cycles.max(cycles);
        }
    }
}
