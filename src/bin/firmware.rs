//! `sledid-fw`: the whole per-sample loop as firmware. SysTick fires once per sled sample period
//! (Ts = 0.455 ms); its handler feeds the next sample of a recording embedded in flash (the first
//! 640 rows of the EMPS benchmark, `fixtures/emps_excerpt.bin`) through the loop in shadow mode
//! ([`sledid::servo::SledServo::step_shadow`]: the scheduled controller and its supervisor
//! compute a drive beside the rig's recorded one, the ARX(1,1) velocity identifier learns from
//! the recorded drive — configuration in [`fw_config`],
//! decoded at start-up from configuration words the host computed from its design
//! (`src/bin/firmware/loop_words.rs`, [`sledid::words`]: of the `f64` design only the two RLS
//! settings are built on the target),
//! folds every output into a checksum and pushes a telemetry record into a fixed-capacity SPSC
//! queue. The main loop drains the queue, counts the records, logs a few with defmt (over
//! semihosting), and runs the controller's slow-rate gain redesign (f32) on the job the handler
//! posts: the handler never waits for it, it adopts the result at the sample the hand-over names
//! ([`sledid::servo::handover`], [`fw_config`]'s redesign rule). At the end it prints the
//! result line (sample and update counts, redesign outcomes, the checksum, the identifier's final
//! θ), the stack high-water mark, and exits through semihosting;
//! `host-tests/tests/firmware_qemu.rs` runs it under QEMU for both targets and asserts the result
//! is bit-exact with the host replay of the same fixture.
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
//! For `count_insns.py`, built with `--features fw-bench`, the image also exports `sledid_fw_bench_init` (`--init`),
//! `sledid_fw_bench_step` (one sample as the interrupt does it: loop step and checksum, on record
//! `i mod FIXTURE_SAMPLES`), `sledid_fw_bench_loop` (the loop step alone),
//! `sledid_fw_bench_settle` (the loop step with the reference moved into the settle band, where
//! the controller settles and holds: the worst case) and
//! `sledid_fw_bench_overhead` (the same scaffolding without either, to subtract). The bench run
//! never redesigns (the redesign is outside the interrupt): its gains stay those of the prior.
#![cfg_attr(target_os = "none", no_std, no_main)]
#![deny(missing_docs, unsafe_code)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

#[path = "firmware/config.rs"]
mod fw_config;

/// The embedded recording: [`fw_config::FIXTURE_SAMPLES`] delta-encoded records (layout:
/// [`fw_config::recording`]; the host test checks the count).
static FIXTURE: &[u8] = include_bytes!("../../fixtures/emps_excerpt.bin");

#[cfg(target_os = "none")]
mod target {
    use core::cell::Cell;

    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m_rt::{entry, exception};
    use cortex_m_semihosting::debug;
    use critical_section::Mutex;
    use defmt_semihosting as _;
    use heapless::spsc::{Consumer, Producer, Queue};
    use sledid::control::Redesign;
    use sledid::control::scheduled::{RedesignJob, RedesignResult};
    use sledid::servo::{Posted, SledServo, Ticket};

    use super::FIXTURE;
    use super::fw_config::{
        self, Cursor, FIXTURE_SAMPLES, QUANTUM_M, RESULT_PREFIX, Run, SAMPLE_PERIOD_NS, Summary,
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
        /// The controller's drive u(k) (shadow: not applied), raw I16F16 full scale.
        u_raw: i32,
        /// The controller's region (0 seek, 1 settle, 2 hold).
        region: u8,
        /// The controller's flags (`ControlFlags` bits).
        control_bits: u16,
        /// Velocity identifier ŷ(t), raw I16F16 (quanta per sample).
        y_hat_raw: i32,
        /// Velocity identifier ε(t), raw I16F16.
        eps_raw: i32,
        /// Velocity identifier status bits ([`sledid::Status`]).
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

    /// What one tick did.
    enum Tick {
        /// Stepped a sample.
        Stepped,
        /// Stepped the last sample.
        Finished(Finished),
        /// Nothing left to step.
        Idle,
    }

    /// Everything the SysTick handler owns: the run, the read position and the queue's producer.
    struct Ticker {
        /// The loop and its checksum.
        run: FwRun,
        /// The read position in the recording (index of the next record).
        cursor: Cursor,
        /// Telemetry out.
        producer: Producer<'static, Telemetry>,
        /// Records dropped on a full queue.
        dropped: u32,
    }

    impl Ticker {
        /// One sample period: the next record through the loop.
        fn tick(&mut self) -> Tick {
            let index = self.cursor.index();
            let Some(sample) = self.cursor.next(FIXTURE) else {
                return Tick::Idle;
            };
            // The background's result, if it finished: adopted at its due sample by the step.
            if let Some((ticket, design)) = critical_section::with(|cs| RESULT.borrow(cs).take()) {
                self.run.deliver(ticket, design);
            }
            let out = self.run.step(&sample);
            if let Some(job) = self.run.take_job() {
                critical_section::with(|cs| JOB.borrow(cs).set(Some(job)));
            }
            let record = Telemetry {
                index: index as u32,
                u_raw: out.u.raw(),
                region: out.region.index(),
                control_bits: out.control.bits(),
                y_hat_raw: out.identifier.y_hat.raw(),
                eps_raw: out.identifier.eps.raw(),
                status_bits: out.identifier.status.bits(),
            };
            if self.producer.enqueue(record).is_err() {
                self.dropped = self.dropped.saturating_add(1);
            }
            if self.cursor.index() == FIXTURE_SAMPLES {
                Tick::Finished(Finished {
                    summary: self.run.summary(),
                    dropped: self.dropped,
                })
            } else {
                Tick::Stepped
            }
        }
    }

    /// Main → SysTick, once: the ticker (the run state lives once, in `main`'s static storage).
    static HANDOFF: Mutex<Cell<Option<&'static mut Ticker>>> = Mutex::new(Cell::new(None));
    /// SysTick → main: the redesign job a step posted (one in flight at most).
    static JOB: Mutex<Cell<Option<Posted<RedesignJob>>>> = Mutex::new(Cell::new(None));
    /// Main → SysTick: the finished redesign, adopted at its due sample.
    static RESULT: Mutex<Cell<Option<(Ticket, RedesignResult)>>> = Mutex::new(Cell::new(None));
    /// SysTick → main, once: the outcome.
    static DONE: Mutex<Cell<Option<Finished>>> = Mutex::new(Cell::new(None));

    /// The sample-period interrupt: one step of the loop on the next record. It takes the ticker
    /// from [`HANDOFF`] once and keeps it; it never waits for the main loop (a redesign arrives
    /// through [`RESULT`] or is flagged missed at its due sample).
    #[exception]
    fn SysTick() {
        static mut TICKER: Option<&'static mut Ticker> = None;
        if TICKER.is_none() {
            *TICKER = critical_section::with(|cs| HANDOFF.borrow(cs).take());
        }
        let Some(ticker) = TICKER.as_deref_mut() else {
            return;
        };
        if let Tick::Finished(done) = ticker.tick() {
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

    /// The run the handler steps: its configuration borrowed from [`install_config`]'s storage
    /// (shared: the main loop reads it for the redesigns).
    type FwRun = Run<&'static SledServo>;

    /// Decodes the configuration words into their static storage, once (`None` if they do not
    /// decode, or on a second call). `cortex_m::singleton!` keeps that storage in `.bss` (a
    /// static `Option` would start as a non-zero `None`, in `.data`, and take its size twice: in
    /// RAM and in flash); it starts empty and the configuration is decoded into it, so that the
    /// frame holds one copy at most. Out of line, so that the decoding's temporaries are gone
    /// before [`install`] runs and SysTick starts.
    #[inline(never)]
    fn install_config() -> Option<&'static SledServo> {
        let slot = cortex_m::singleton!(CONFIG: Option<SledServo> = None)?;
        fw_config::config_into(slot).ok()?;
        slot.as_ref()
    }

    /// Builds the ticker (the run state on `config`, the read position, the producer) into its
    /// static storage (`.bss`, as [`install_config`]'s), once: `None` on a second call. Called
    /// after [`install_config`] has returned, so that their frames do not add up.
    #[inline(never)]
    fn install(
        config: &'static SledServo,
        producer: Producer<'static, Telemetry>,
    ) -> Option<&'static mut Ticker> {
        let slot = cortex_m::singleton!(TICKER: Option<Ticker> = None)?;
        Some(slot.insert(Ticker {
            run: Run::from_config(config),
            cursor: Cursor::new(),
            producer,
            dropped: 0,
        }))
    }

    /// Starts SysTick, waits for the recording to be consumed, reports. `true` on success. The
    /// ticker (the run state) lives in [`install`]'s static storage: the handler only gets a
    /// reference to it.
    fn run(queue: &'static mut Queue<Telemetry, QUEUE_SLOTS>) -> bool {
        let Some(cp) = cortex_m::Peripherals::take() else {
            return false;
        };
        let (producer, mut consumer) = queue.split();
        let Some(config) = install_config() else {
            defmt::println!("sledid-fw: the configuration words do not decode");
            return false;
        };
        let Some(ticker) = install(config, producer) else {
            return false;
        };
        defmt::println!(
            "sledid-fw: scheduled controller (EMPS cascade PID baseline) + ARX(1,1) velocity, \
             shadow mode; {=usize} EMPS samples (quantum {=f64} m, u full scale {=f64} V); \
             SysTick every {=u32} ns, reload {=u32} at {=u32} Hz",
            FIXTURE_SAMPLES,
            QUANTUM_M,
            U_FULL_SCALE_V,
            SAMPLE_PERIOD_NS,
            SYST_RELOAD,
            CORE_CLOCK_HZ
        );
        critical_section::with(|cs| HANDOFF.borrow(cs).set(Some(ticker)));

        let mut syst = cp.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(SYST_RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();

        let mut received = 0u32;
        let mut redesigns = 0u32;
        let finished = loop {
            drain(&mut consumer, &mut received);
            if let Some(job) = critical_section::with(|cs| JOB.borrow(cs).take()) {
                let design = config.redesign(&job);
                critical_section::with(|cs| RESULT.borrow(cs).set(Some((job.ticket, design))));
                let (outcome, at) = (design.outcome, job.ticket.due);
                redesigns = redesigns.saturating_add(1);
                if redesigns <= 3 {
                    let what = match outcome {
                        Redesign::Applied(_) => "applied",
                        Redesign::Rejected(_) => "rejected",
                        Redesign::Skipped => "skipped",
                    };
                    defmt::println!("redesign due at sample {=u32}: {=str}", at, what);
                }
            }
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
            "{=str} samples={=u32} updates={=u32} redesigns={} fallback={=bool} \
             checksum={=u64:#018x} theta={}",
            RESULT_PREFIX,
            s.samples,
            s.updates,
            s.redesigns,
            s.fallback,
            s.checksum,
            s.theta_raw
        );
        defmt::println!(
            "telemetry: {=u32} received, {=u32} dropped; {=u32} redesigns; \
             stack high-water {=usize} of {=usize} bytes",
            received,
            finished.dropped,
            redesigns,
            stack_used,
            stack_size
        );
        let counted = received.saturating_add(finished.dropped);
        let [applied, rejected, skipped] = s.redesigns;
        let outcomes = u32::from(applied) + u32::from(rejected) + u32::from(skipped);
        s.samples as usize == FIXTURE_SAMPLES && counted == s.samples && outcomes == redesigns
    }

    /// Reset entry: paint the stack, run, exit through semihosting.
    #[entry]
    fn main() -> ! {
        static mut QUEUE: Queue<Telemetry, QUEUE_SLOTS> = Queue::new();
        // Nothing calls the bench exports; referencing them keeps the linker from dropping them.
        #[cfg(feature = "fw-bench")]
        core::hint::black_box(&bench::BENCH_EXPORTS);
        paint_stack();
        let ok = run(QUEUE);
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

    /// The `count_insns.py` entry points (`--features fw-bench`; the shipped image leaves them
    /// out: their run would be a second copy of the loop state, 1.4 KB of RAM and flash).
    #[cfg(feature = "fw-bench")]
    mod bench {
        use core::cell::RefCell;

        use critical_section::Mutex;
        use sledid::{Sample, Status};

        use super::super::FIXTURE;
        use super::fw_config::{self, Cursor, FIXTURE_SAMPLES, Run};

        /// The run `count_insns.py` measures (independent of the firmware's own).
        static BENCH: Mutex<RefCell<Option<Run>>> = Mutex::new(RefCell::new(None));
        /// The bench's read position in the recording.
        static BENCH_CURSOR: Mutex<RefCell<Cursor>> = Mutex::new(RefCell::new(Cursor::new()));

        /// `--init`: a fresh run for [`sledid_fw_bench_step`].
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_init() {
            let run = fw_config::config().ok().map(Run::from_config);
            critical_section::with(|cs| BENCH.borrow(cs).replace(run));
        }

        /// Record `index`: the next one of the bench's cursor when the calls go in order (as
        /// `count_insns.py --args i` makes them), else decoded from the start.
        #[inline(never)]
        fn bench_record(cursor: &mut Cursor, index: usize) -> Option<Sample> {
            if cursor.index() != index {
                *cursor = Cursor::new();
                while cursor.index() < index {
                    cursor.next(FIXTURE)?;
                }
            }
            cursor.next(FIXTURE)
        }

        /// Runs `f` on the bench run and record `i mod FIXTURE_SAMPLES`, in a critical section (0 if the bench
        /// run was not initialised).
        #[inline(always)]
        fn with_bench(i: u32, f: impl FnOnce(&mut Run, &Sample) -> u32) -> u32 {
            critical_section::with(|cs| {
                let index = i as usize % FIXTURE_SAMPLES;
                let sample = bench_record(&mut BENCH_CURSOR.borrow_ref_mut(cs), index);
                match (BENCH.borrow_ref_mut(cs).as_mut(), sample) {
                    (Some(run), Some(sample)) => f(run, &sample),
                    _ => 0,
                }
            })
        }

        /// One sample as the interrupt does it: record `i mod FIXTURE_SAMPLES` through the loop
        /// step and the checksum. Returns the drive's raw bits mixed with the status bits.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_step(i: u32) -> u32 {
            with_bench(i, |run, sample| {
                let out = run.step(sample);
                (out.u.raw() as u32) ^ u32::from(out.identifier.status.bits())
            })
        }

        /// The full loop step alone ([`fw_config::loop_step`]: controller, supervisor, velocity
        /// identifier; no checksum) on record `i mod FIXTURE_SAMPLES`.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_loop(i: u32) -> u32 {
            with_bench(i, |run, sample| {
                let out = fw_config::loop_step(&run.config, &mut run.state, sample);
                (out.u.raw() as u32) ^ u32::from(out.identifier.status.bits())
            })
        }

        /// The full loop step in the settle band: the drive of
        /// record `i mod FIXTURE_SAMPLES`, a still reference r = 300 quanta and a measurement
        /// within ±2 quanta of it (`y = r + (7i mod 5) − 2`), so the controller settles or holds.
        /// Its outputs mean nothing.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_settle(i: u32) -> u32 {
            with_bench(i, |run, sample| {
                let r = sledid::PositionI48F16::from_counts(300);
                let offset = i64::from(i.wrapping_mul(7) % 5) - 2;
                let y = sledid::PositionI48F16::from_raw(r.raw() + (offset << 16));
                let sample = Sample { r, y, u: sample.u };
                let out = fw_config::loop_step(&run.config, &mut run.state, &sample);
                (out.u.raw() as u32) ^ u32::from(out.identifier.status.bits())
            })
        }

        /// The scaffolding of the bench exports without the step, to subtract.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_overhead(i: u32) -> u32 {
            with_bench(i, |run, sample| {
                core::hint::black_box(run);
                u32::from(sample.y.raw() as u16 & Status::UPDATED.bits())
            })
        }

        /// The `count_insns.py` entry points, referenced from `main` so that they stay in the image.
        pub(super) static BENCH_EXPORTS: (extern "C" fn(), [extern "C" fn(u32) -> u32; 4]) = (
            sledid_fw_bench_init,
            [
                sledid_fw_bench_step,
                sledid_fw_bench_loop,
                sledid_fw_bench_settle,
                sledid_fw_bench_overhead,
            ],
        );
    }
}

/// Host build: prints the configuration and the host replay's result line (the line the firmware
/// must print under QEMU).
#[cfg(not(target_os = "none"))]
fn main() {
    use fw_config::{FIXTURE_SAMPLES, QUANTUM_M, RESULT_PREFIX, SAMPLE_PERIOD_NS, U_FULL_SCALE_V};
    println!("sledid-fw (host build): {:#?}", fw_config::design());
    // What the firmware decodes instead of building the design from f64.
    let words = fw_config::LOOP_WORDS.len();
    if fw_config::config() == fw_config::design().build() {
        println!(
            "configuration words (src/bin/firmware/loop_words.rs): {words}, equal to the design"
        );
    } else {
        eprintln!(
            "sledid-fw: the configuration words ({words}) are stale: regenerate them \
             (SLEDID_WRITE_CONFIG=1 cargo test -p sledid-host --test firmware_qemu loop_words)"
        );
        std::process::exit(1);
    }
    println!(
        "recording: {FIXTURE_SAMPLES} EMPS samples, quantum {QUANTUM_M} m, u full scale {U_FULL_SCALE_V} V; \
         SysTick period {SAMPLE_PERIOD_NS} ns"
    );
    let summary = match fw_config::replay(FIXTURE) {
        Ok(summary) => summary,
        Err(e) => {
            eprintln!("sledid-fw: the design does not build: {e}");
            std::process::exit(1);
        }
    };
    println!("{RESULT_PREFIX} {summary}");
    println!(
        "Firmware under QEMU: cargo run --profile firmware --target thumbv7em-none-eabihf --bin sledid-fw \
         | defmt-print -e target/thumbv7em-none-eabihf/firmware/sledid-fw"
    );
}
