//! `sledid-stm32f411`: the servo on a board — an STM32F411CE (the WeAct "Black Pill") at 72 MHz,
//! the part the QEMU Cortex-M4F image is built for (`sledid_firmware::PART_M4F`).
//!
//! The same loop as the PIL image, on real pins through the HAL (`stm32f4xx-hal`):
//! - SysTick every Ts = 0.455 ms (reload 32,759 at 72 MHz): the interrupt reads the encoder,
//!   runs `sledid::servo::hal::ControlLoop::tick` (the library's step behind embedded-hal 1.0)
//!   and writes the drive; overruns are counted as in the QEMU image (`timing.rs`: SysTick
//!   COUNTFLAG, the DWT cycle counter);
//! - position in: TIM2 in quadrature-encoder mode on PA0/PA1 (32-bit count, one quantum per
//!   edge), extended to `i64`;
//! - drive out: TIM3 channel 1 on PA6, 20 kHz PWM (|u|), and PB0 as the direction pin (high for
//!   u ≥ 0), `PwmDirection` over embedded-hal 1.0's `SetDutyCycle` and `OutputPin`;
//! - the product's composition (the configuration words): power-on calibration — the servo
//!   drives its identification experiment before following r —, then time-optimal seeks, settle
//!   and hold with the safety layer armed;
//! - the background (main loop) fits calibration's record and computes each redesign and hands
//!   it over; it is adopted at its due sample or, late, refused (the configuration words'
//!   latencies, `loop_words.rs`);
//! - the reference: a demonstration that alternates between two targets every half second (an
//!   application sets r from its own seek commands).
//!
//! Its configuration is the QEMU images' words (`firmware/src/loop_words.rs`), designed on
//! the twin's sled: on another sled, design and generate words for it first. Logs (defmt over
//! RTT) once a second: samples, overruns, the longest handler in cycles, the region. Flash with
//! probe-rs (README: "Firmware on a board").
#![no_std]
#![no_main]
#![deny(missing_docs, unsafe_code)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use core::cell::RefCell;
use core::convert::Infallible;

use cortex_m::peripheral::SYST;
use cortex_m_rt::{entry, exception};
use critical_section::Mutex;
use defmt_rtt as _;
use sledid::PositionI48F16;
use sledid::servo::hal::{ControlLoop, PositionSensor, PwmDirection};
use sledid::servo::{SledServo, SledServoState};
use stm32f4xx_hal::gpio::{Output, PB0, PushPull};
use stm32f4xx_hal::pac::{self, TIM2, TIM3};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::timer::ErasedChannel;

use sledid_firmware::Part;
use sledid_firmware::timing::Timing;

/// The part and clock.
const PART: Part = sledid_firmware::PART_M4F;
/// SysTick reload for Ts on the core clock.
const SYST_RELOAD: u32 = PART.syst_reload();
/// The Black Pill's crystal.
const HSE_HZ: u32 = 25_000_000;
/// The drive's PWM frequency.
const PWM_HZ: u32 = 20_000;
/// The demonstration's targets, quanta, and its dwell at each, samples (≈ 0.5 s).
const DEMO_TARGETS: [i64; 2] = [0, 2_000];
/// The demonstration's dwell at each target, samples (≈ 0.5 s).
const DEMO_DWELL: u32 = 1_100;
/// Samples between two log lines (≈ 1 s).
const LOG_EVERY: u32 = 2_200;

/// The quadrature encoder on TIM2 (32 bits), its count extended to `i64`.
struct Encoder {
    qei: Qei<TIM2>,
    last: u32,
    counts: i64,
}

impl PositionSensor for Encoder {
    type Error = Infallible;
    fn read_counts(&mut self) -> Result<i64, Infallible> {
        let now = self.qei.count();
        // The counter wraps at 2³²: the signed difference of two readings is the motion.
        self.counts = self
            .counts
            .wrapping_add(i64::from(now.wrapping_sub(self.last) as i32));
        self.last = now;
        Ok(self.counts)
    }
}

/// The drive: |u| on TIM3 channel 1, the sign on PB0.
type Drive = PwmDirection<ErasedChannel<TIM3>, PB0<Output<PushPull>>>;

/// Everything the SysTick handler steps, shared with the background under a critical section.
struct Board {
    config: &'static SledServo,
    state: SledServoState,
    control: ControlLoop<Encoder, Drive>,
    syst: SYST,
    timing: Timing,
    samples: u32,
    region: u8,
}

impl Board {
    /// One sample period: encoder → step → PWM and pin.
    fn tick(&mut self) {
        self.timing.enter(&mut self.syst);
        let k = self.state.sample_index();
        let at = usize::from((k / DEMO_DWELL) % 2 == 1);
        let target = DEMO_TARGETS.get(at).copied().unwrap_or(0);
        let r = PositionI48F16::from_counts(target);
        // The drive's errors are `Infallible`.
        let Ok(out) = self.control.tick(self.config, &mut self.state, r);
        self.region = out.region.index();
        self.samples = self.samples.wrapping_add(1);
        self.timing.exit(&mut self.syst, SYST_RELOAD);
    }
}

/// The board's loop, once `main` has built it.
static BOARD: Mutex<RefCell<Option<&'static mut Board>>> = Mutex::new(RefCell::new(None));

/// `f` on the loop, in a critical section (`None` before it is built).
fn with_board<T>(f: impl FnOnce(&mut Board) -> T) -> Option<T> {
    critical_section::with(|cs| BOARD.borrow_ref_mut(cs).as_deref_mut().map(f))
}

/// The sample-period interrupt.
#[exception]
fn SysTick() {
    with_board(Board::tick);
}

/// Clocks, pins, timers, the configuration, then the background forever.
#[entry]
fn main() -> ! {
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        defmt::panic!("peripherals taken twice");
    };
    let mut rcc = dp
        .RCC
        .freeze(Config::hse(HSE_HZ.Hz()).sysclk(PART.core_clock_hz.Hz()));
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);

    let qei = Qei::new(dp.TIM2, (gpioa.pa0, gpioa.pa1), &mut rcc);
    let last = qei.count();
    let (_, (ch1, ..)) = dp.TIM3.pwm_hz(PWM_HZ.Hz(), &mut rcc);
    let mut pwm = ch1.with(gpioa.pa6).erase();
    pwm.enable();
    let direction = gpiob.pb0.into_push_pull_output();

    let Some(slot) = cortex_m::singleton!(CONFIG: Option<SledServo> = None) else {
        defmt::panic!("configured twice");
    };
    if let Err(e) = sledid_firmware::config_into(slot) {
        defmt::panic!("the configuration words do not decode: {}", e);
    }
    let Some(config) = slot.as_ref() else {
        defmt::panic!("no configuration");
    };

    let (mut dcb, mut dwt) = (cp.DCB, cp.DWT);
    dcb.enable_trace();
    dwt.enable_cycle_counter();
    let mut syst = cp.SYST;
    sledid_firmware::timing::start_sample_clock(&mut syst, SYST_RELOAD);
    let Some(board) = cortex_m::singleton!(BOARD_STATE: Option<Board> = None) else {
        defmt::panic!("built twice");
    };
    let board = board.insert(Board {
        config,
        state: config.new_state(),
        control: ControlLoop::new(
            Encoder {
                qei,
                last,
                counts: 0,
            },
            PwmDirection { pwm, direction },
        ),
        syst,
        timing: Timing::default(),
        samples: 0,
        region: 0,
    });
    critical_section::with(|cs| BOARD.borrow_ref_mut(cs).replace(board));
    defmt::println!(
        "sledid on {=str}: SysTick reload {=u32}, hand-over latency {=u32}",
        PART.name,
        SYST_RELOAD,
        config.handover_latency()
    );

    let mut next_log = LOG_EVERY;
    loop {
        // The background: power-on calibration's record is fitted, a posted job redesigned,
        // outside the interrupt, and the answer handed back.
        if let Some(Some(posted)) = with_board(|b| b.state.take_calibration_job()) {
            let answer = config.calibrate(&posted.job);
            if with_board(|b| b.state.deliver_calibration(posted.ticket, answer)) == Some(false) {
                defmt::println!(
                    "calibration fit due at {=u32} was late: the record is posted again",
                    posted.ticket.due
                );
            }
            continue;
        }
        if let Some(Some(posted)) = with_board(|b| b.state.take_job()) {
            let design = config.redesign(&posted);
            if with_board(|b| b.state.deliver(posted.ticket, design)) == Some(false) {
                defmt::println!(
                    "redesign due at {=u32} was late: refused",
                    posted.ticket.due
                );
            }
            continue;
        }
        if let Some((samples, t, region)) = with_board(|b| (b.samples, b.timing, b.region))
            && samples >= next_log
        {
            next_log = samples.wrapping_add(LOG_EVERY);
            defmt::println!(
                "samples={=u32} overruns={=u32} max_ticks={=u32} dwt_max_cycles={=u32} region={=u8}",
                samples,
                t.overruns,
                t.max_ticks,
                t.dwt_max_cycles,
                region
            );
        }
        cortex_m::asm::wfi();
    }
}

/// Logs where it panicked, then halts (the drive's last duty stays: a board wires a watchdog or
/// a hardware enable that drops it).
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    if let Some(l) = info.location() {
        defmt::println!("panic at {=str}:{=u32}", l.file(), l.line());
    }
    loop {
        cortex_m::asm::wfi();
    }
}
