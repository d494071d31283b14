//! The parts the images are built for: their core clocks set the SysTick reload for Ts.

/// The sled's sample period (Ts = 0.455 ms), ns: the SysTick period the images program.
pub const SAMPLE_PERIOD_NS: u32 = 455_000;

/// A microcontroller an image is built for: its core and clock set the SysTick reload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    /// The part.
    pub name: &'static str,
    /// Core clock, Hz.
    pub core_clock_hz: u32,
}

impl Part {
    /// SysTick reload value for one sample period on the core clock (the counter runs reload + 1
    /// cycles per period).
    pub const fn syst_reload(self) -> u32 {
        let cycles = self.core_clock_hz as u64 * SAMPLE_PERIOD_NS as u64 / 1_000_000_000;
        assert!(cycles > 1 && cycles <= 1 << 24, "SysTick reload is 24 bits");
        (cycles - 1) as u32
    }
}

/// The Cortex-M4F image (`thumbv7em-none-eabihf`): an STM32F411CE (the "Black Pill" board's
/// part) run at 72 MHz, 32,760 cycles per period. The board image (`boards/stm32f411`) is the
/// same part.
pub const PART_M4F: Part = Part {
    name: "STM32F411CE Cortex-M4F @ 72 MHz",
    core_clock_hz: 72_000_000,
};

/// The Cortex-M0 image (`thumbv6m-none-eabi`): an ATSAMD21G18 (Cortex-M0+) at 48 MHz, 21,840
/// cycles per period.
pub const PART_M0PLUS: Part = Part {
    name: "ATSAMD21G18 Cortex-M0+ @ 48 MHz",
    core_clock_hz: 48_000_000,
};
