//! `sledid-fw`: the identifier as firmware. SysTick fires once per sled sample period (Ts = 0.455 ms);
//! its handler feeds the next sample of a recording embedded in flash (the first 640 rows of the
//! EMPS benchmark, `fixtures/emps_excerpt.bin`) through [`sledid::step::step`], folds every output
//! into a checksum and pushes a telemetry record into a fixed-capacity SPSC queue. The main loop
//! drains the queue, counts the records and logs a few with defmt (over semihosting). At the end it
//! prints the sample count, the checksum and the final θ, the stack high-water mark, and exits
//! through semihosting; `host-tests/tests/firmware_qemu.rs` runs it under QEMU for both targets and
//! asserts the result is bit-exact with the host replay of the same fixture.
//!
//! ```text
//! # Cortex-M4F (QEMU mps2-an386) and Cortex-M0 (QEMU microbit):
//! cargo run --profile firmware --target thumbv7em-none-eabihf --bin sledid-fw \
//!     | defmt-print -e target/thumbv7em-none-eabihf/firmware/sledid-fw
//! cargo run --profile firmware --target thumbv6m-none-eabi --bin sledid-fw \
//!     | defmt-print -e target/thumbv6m-none-eabi/firmware/sledid-fw
//! ```
//! The runner (`.cargo/config.toml`) is QEMU. Everything the firmware says is defmt frames on
//! semihosting stdout (binary: pipe them into `defmt-print`), the result line included; the image
//! links no `core::fmt` (≈ 5 KB of flash). Built for the host, `main` prints the configuration and
//! the host replay's result line.
//!
//! For `count_insns.py` the image also exports `sledid_fw_bench_init` (`--init`),
//! `sledid_fw_bench_step` (one sample as the interrupt does it: step and checksum, on record
//! `i mod FIXTURE_SAMPLES`), `sledid_fw_bench_identify` (the step alone) and `sledid_fw_bench_overhead` (the
//! same scaffolding without either, to subtract).
#![cfg_attr(target_os = "none", no_std, no_main)]
#![deny(missing_docs, unsafe_code)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

#[path = "firmware/config.rs"]
mod fw_config;

/// The embedded recording (layout: [`fw_config`]'s module doc).
static FIXTURE: &[u8] = include_bytes!("../../fixtures/emps_excerpt.bin");

/// The fixture holds exactly [`fw_config::FIXTURE_SAMPLES`] records (checked when compiling).
const _: () = assert!(
    include_bytes!("../../fixtures/emps_excerpt.bin").len()
        == fw_config::FIXTURE_SAMPLES * fw_config::RECORD_BYTES
);

#[cfg(target_os = "none")]
mod target {
    use core::cell::{Cell, RefCell};

    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m_rt::{entry, exception};
    use cortex_m_semihosting::debug;
    use critical_section::Mutex;
    use defmt_semihosting as _;
    use heapless::spsc::{Consumer, Producer, Queue};
    use sledid::{Sample, Status};

    use super::FIXTURE;
    use super::fw_config::{
        self, FIXTURE_SAMPLES, N, QUANTUM_M, RESULT_PREFIX, Run, SAMPLE_PERIOD_NS, Summary,
        U_FULL_SCALE_V,
    };

    /// Core clock of the emulated part, Hz: the AN386 FPGA image of the MPS2 board runs its
    /// Cortex-M4 at 25 MHz (QEMU `mps2-an386`).
    #[cfg(target_abi = "eabihf")]
    const CORE_CLOCK_HZ: u32 = 25_000_000;
    /// Core clock of the emulated part, Hz: the nRF51822 of the micro:bit runs at 16 MHz (QEMU
    /// `microbit`).
    #[cfg(not(target_abi = "eabihf"))]
    const CORE_CLOCK_HZ: u32 = 16_000_000;

    /// SysTick reload value for one sample period on the core clock (the counter runs reload + 1
    /// cycles per period): 11,374 at 25 MHz, 7,279 at 16 MHz.
    const SYST_RELOAD: u32 = {
        let cycles = CORE_CLOCK_HZ as u64 * SAMPLE_PERIOD_NS as u64 / 1_000_000_000;
        assert!(cycles > 1 && cycles <= 1 << 24, "SysTick reload is 24 bits");
        (cycles - 1) as u32
    };

    /// Slots of the telemetry queue. It holds one fewer, 15 records: the main loop may fall
    /// 15 sample periods (6.8 ms) behind, e.g. while a defmt write blocks on semihosting, before a
    /// record is dropped (and counted in `dropped`).
    const QUEUE_SLOTS: usize = 16;

    /// Stack paint pattern.
    const PAINT: u32 = 0xCCCC_CCCC;
    /// Bytes left unpainted below the painter's stack pointer (its own frame, see [`paint_stack`]).
    const STACK_PAINT_GUARD: usize = 64;

    /// What the interrupt hands to the main loop for each sample.
    #[derive(Clone, Copy, defmt::Format)]
    struct Telemetry {
        /// Sample index in the recording.
        index: u32,
        /// ŷ(t), raw I16F16 (conditioned coordinates: increments, quanta).
        y_hat_raw: i32,
        /// ε(t), raw I16F16.
        eps_raw: i32,
        /// Status bits ([`Status`]).
        status_bits: u16,
    }

    /// What the interrupt publishes once the recording is exhausted.
    #[derive(Clone, Copy)]
    struct Finished {
        /// The run's outcome.
        summary: Summary,
        /// Telemetry records that found the queue full.
        dropped: u32,
    }

    /// Everything the SysTick handler owns: the run, the read position and the queue's producer.
    struct Ticker {
        /// The identifier and its checksum.
        run: Run,
        /// Index of the next record.
        next: usize,
        /// Telemetry out.
        producer: Producer<'static, Telemetry>,
        /// Records dropped on a full queue.
        dropped: u32,
    }

    impl Ticker {
        /// One sample period: the next record through the identifier. `Some` right after the last
        /// record, `None` otherwise (and on every tick after the end: nothing left to do).
        fn tick(&mut self) -> Option<Finished> {
            let sample = fw_config::record(FIXTURE, self.next)?;
            let out = self.run.step(&sample);
            let record = Telemetry {
                index: self.next as u32,
                y_hat_raw: out.y_hat.raw(),
                eps_raw: out.eps.raw(),
                status_bits: out.status.bits(),
            };
            if self.producer.enqueue(record).is_err() {
                self.dropped = self.dropped.saturating_add(1);
            }
            self.next = self.next.saturating_add(1);
            (self.next == FIXTURE_SAMPLES).then(|| Finished {
                summary: self.run.summary(),
                dropped: self.dropped,
            })
        }
    }

    /// Main → SysTick, once: the ticker. Only the reference is handed over: the ticker itself (the
    /// run state) lives once, in `main`'s static storage.
    static HANDOFF: Mutex<Cell<Option<&'static mut Ticker>>> = Mutex::new(Cell::new(None));
    /// SysTick → main, once: the outcome.
    static DONE: Mutex<Cell<Option<Finished>>> = Mutex::new(Cell::new(None));

    /// The sample-period interrupt: one step of the identifier on the next record. The reference to
    /// the ticker is taken from [`HANDOFF`] on the first run, so the step itself runs outside any
    /// critical section.
    #[exception]
    fn SysTick() {
        static mut TICKER: Option<&'static mut Ticker> = None;
        if TICKER.is_none() {
            *TICKER = critical_section::with(|cs| HANDOFF.borrow(cs).take());
        }
        if let Some(done) = TICKER.as_deref_mut().and_then(Ticker::tick) {
            critical_section::with(|cs| DONE.borrow(cs).set(Some(done)));
        }
    }

    /// Drains the queue: counts the records, logs the first three and every 500th.
    fn drain(consumer: &mut Consumer<'static, Telemetry>, received: &mut u32) {
        while let Some(t) = consumer.dequeue() {
            *received = received.saturating_add(1);
            if t.index < 3 || t.index % 500 == 0 {
                defmt::println!("telemetry {}", t);
            }
        }
    }

    /// Paints the free stack below the current stack pointer with [`PAINT`], down to `_stack_end`.
    #[inline(never)]
    fn paint_stack() {
        let (bottom, top) = stack_bounds();
        // Everything below this function's own frame is unused (interrupts are not enabled yet).
        // The compiler may read SP before pushing this function's frame, so stop a guard band
        // below it: the high-water mark is exact whenever it lies deeper than the guard band.
        let limit = (cortex_m::register::msp::read() as usize)
            .min(top)
            .saturating_sub(STACK_PAINT_GUARD);
        let mut addr = bottom;
        while addr + 4 <= limit {
            // SAFETY: [_stack_end, limit) lies inside the stack region cortex-m-rt reserves
            // (between the end of .bss/.uninit and the stack top) and below the live stack, so no
            // Rust object occupies it; the address is 4-aligned (`_stack_end` is, per link.x).
            #[allow(unsafe_code)]
            unsafe {
                core::ptr::write_volatile(
                    core::ptr::with_exposed_provenance_mut::<u32>(addr),
                    PAINT,
                );
            }
            addr += 4;
        }
    }

    /// Bytes of stack used at the deepest point since [`paint_stack`], and the stack's size.
    fn stack_high_water() -> (usize, usize) {
        let (bottom, top) = stack_bounds();
        let mut addr = bottom;
        while addr < top {
            // SAFETY: reads a 4-aligned word of the stack region; below the live stack pointer
            // nothing else accesses it (a plain read of memory nobody owns; volatile so that it
            // is actually performed).
            #[allow(unsafe_code)]
            let word = unsafe {
                core::ptr::read_volatile(core::ptr::with_exposed_provenance::<u32>(addr))
            };
            if word != PAINT {
                break;
            }
            addr += 4;
        }
        (top - addr, top - bottom)
    }

    /// `(_stack_end, _stack_start)`: the stack region from cortex-m-rt's linker script.
    fn stack_bounds() -> (usize, usize) {
        // An `unsafe extern` block declares the linker's symbols; only their addresses are used.
        #[allow(unsafe_code)]
        unsafe extern "C" {
            /// The lowest address of the stack region (end of .bss/.uninit, 4-aligned).
            static _stack_end: u32;
            /// The initial stack pointer (top of RAM).
            static _stack_start: u32;
        }
        // Taking the address of an extern static is safe; nothing is read through it.
        let bottom = (&raw const _stack_end).expose_provenance();
        let top = (&raw const _stack_start).expose_provenance();
        (bottom, top)
    }

    /// Starts SysTick, waits for the recording to be consumed, reports. `true` on success. `slot`
    /// is where the ticker (the run state) lives: the handler only gets a reference to it.
    fn run(
        queue: &'static mut Queue<Telemetry, QUEUE_SLOTS>,
        slot: &'static mut Option<Ticker>,
    ) -> bool {
        let Some(cp) = cortex_m::Peripherals::take() else {
            return false;
        };
        let run = match Run::new() {
            Ok(run) => run,
            Err(_) => {
                defmt::println!("sledid-fw: the design does not build");
                return false;
            }
        };
        defmt::println!(
            "sledid-fw: ARX(2,2) on increments, lambda 0.995, trace(P) <= 100; {=usize} EMPS samples \
             (quantum {=f64} m, u full scale {=f64} V); SysTick every {=u32} ns, reload {=u32} at {=u32} Hz",
            FIXTURE_SAMPLES,
            QUANTUM_M,
            U_FULL_SCALE_V,
            SAMPLE_PERIOD_NS,
            SYST_RELOAD,
            CORE_CLOCK_HZ
        );
        let (producer, mut consumer) = queue.split();
        let ticker = slot.insert(Ticker {
            run,
            next: 0,
            producer,
            dropped: 0,
        });
        critical_section::with(|cs| HANDOFF.borrow(cs).set(Some(ticker)));

        let mut syst = cp.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(SYST_RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();

        let mut received = 0u32;
        let finished = loop {
            drain(&mut consumer, &mut received);
            if let Some(f) = critical_section::with(|cs| DONE.borrow(cs).take()) {
                break f;
            }
            // SysTick keeps running, so a result published just before this wakes us next period.
            cortex_m::asm::wfi();
        };
        syst.disable_interrupt();
        syst.disable_counter();
        drain(&mut consumer, &mut received);

        let s = finished.summary;
        let (stack_used, stack_size) = stack_high_water();
        defmt::println!(
            "{=str} samples={=u32} updates={=u32} checksum={=u64:#018x} theta={}",
            RESULT_PREFIX,
            s.samples,
            s.updates,
            s.checksum,
            s.theta_raw
        );
        defmt::println!(
            "telemetry: {=u32} received, {=u32} dropped; stack high-water {=usize} of {=usize} bytes",
            received,
            finished.dropped,
            stack_used,
            stack_size
        );
        let counted = received.saturating_add(finished.dropped);
        s.samples as usize == FIXTURE_SAMPLES && counted == s.samples
    }

    /// Reset entry: paint the stack, run, exit through semihosting.
    #[entry]
    fn main() -> ! {
        static mut QUEUE: Queue<Telemetry, QUEUE_SLOTS> = Queue::new();
        static mut TICKER: Option<Ticker> = None;
        // Nothing calls the bench exports; referencing them keeps the linker from dropping them.
        core::hint::black_box(&BENCH_EXPORTS);
        paint_stack();
        let ok = run(QUEUE, TICKER);
        debug::exit(if ok {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        });
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// Reports where it panicked (none is expected: the data path has none) and exits with
    /// failure. The location only, through defmt: formatting the message would link `core::fmt`
    /// (≈ 5 KB of flash).
    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        match info.location() {
            Some(l) => defmt::println!("sledid-fw panic at {=str}:{=u32}", l.file(), l.line()),
            None => defmt::println!("sledid-fw panic"),
        }
        debug::exit(debug::EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// The run `count_insns.py` measures (independent of the firmware's own).
    static BENCH: Mutex<RefCell<Option<Run>>> = Mutex::new(RefCell::new(None));

    /// `--init`: a fresh run for [`sledid_fw_bench_step`].
    #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
    #[unsafe(no_mangle)]
    pub extern "C" fn sledid_fw_bench_init() {
        critical_section::with(|cs| BENCH.borrow(cs).replace(Run::new().ok()));
    }

    /// Runs `f` on the bench run and record `i mod FIXTURE_SAMPLES`, in a critical section (0 if the bench
    /// run was not initialised).
    #[inline(always)]
    fn with_bench(i: u32, f: impl FnOnce(&mut Run, &Sample) -> u32) -> u32 {
        let sample = fw_config::record(FIXTURE, i as usize % FIXTURE_SAMPLES);
        critical_section::with(|cs| match (BENCH.borrow_ref_mut(cs).as_mut(), sample) {
            (Some(run), Some(sample)) => f(run, &sample),
            _ => 0,
        })
    }

    /// One sample as the interrupt does it: record `i mod FIXTURE_SAMPLES` through the step and the checksum.
    /// Returns the status bits.
    #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
    #[unsafe(no_mangle)]
    pub extern "C" fn sledid_fw_bench_step(i: u32) -> u32 {
        with_bench(i, |run, sample| u32::from(run.step(sample).status.bits()))
    }

    /// The per-sample step alone ([`fw_config::identify`], no checksum) on record `i mod FIXTURE_SAMPLES`.
    /// Returns the status bits.
    #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
    #[unsafe(no_mangle)]
    pub extern "C" fn sledid_fw_bench_identify(i: u32) -> u32 {
        with_bench(i, |run, sample| {
            let out = fw_config::identify(&run.config, &mut run.state, sample);
            u32::from(out.status.bits())
        })
    }

    /// The scaffolding of the bench exports without the step, to subtract.
    #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
    #[unsafe(no_mangle)]
    pub extern "C" fn sledid_fw_bench_overhead(i: u32) -> u32 {
        with_bench(i, |run, sample| {
            core::hint::black_box(run);
            u32::from(sample.y.raw() as u16 & Status::UPDATED.bits())
        })
    }

    /// The `count_insns.py` entry points, referenced from `main` so that they stay in the image.
    static BENCH_EXPORTS: (extern "C" fn(), [extern "C" fn(u32) -> u32; 3]) = (
        sledid_fw_bench_init,
        [
            sledid_fw_bench_step,
            sledid_fw_bench_identify,
            sledid_fw_bench_overhead,
        ],
    );

    /// θ has N entries (the defmt result line prints them as a slice).
    const _: () = assert!(N == 4);
}

/// Host build: prints the configuration and the host replay's result line (the line the firmware
/// must print under QEMU).
#[cfg(not(target_os = "none"))]
fn main() {
    use fw_config::{FIXTURE_SAMPLES, QUANTUM_M, RESULT_PREFIX, SAMPLE_PERIOD_NS, U_FULL_SCALE_V};
    println!("sledid-fw (host build): {:#?}", fw_config::design());
    println!(
        "recording: {FIXTURE_SAMPLES} EMPS samples, quantum {QUANTUM_M} m, u full scale {U_FULL_SCALE_V} V; \
         SysTick period {SAMPLE_PERIOD_NS} ns"
    );
    let mut run = match fw_config::Run::new() {
        Ok(run) => run,
        Err(e) => {
            eprintln!("sledid-fw: the design does not build: {e}");
            std::process::exit(1);
        }
    };
    for i in 0..FIXTURE_SAMPLES {
        if let Some(sample) = fw_config::record(FIXTURE, i) {
            run.step(&sample);
        }
    }
    println!("{RESULT_PREFIX} {}", run.summary());
    println!(
        "Firmware under QEMU: cargo run --profile firmware --target thumbv7em-none-eabihf --bin sledid-fw \
         | defmt-print -e target/thumbv7em-none-eabihf/firmware/sledid-fw"
    );
}
