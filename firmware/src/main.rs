//! `sledid-fw`: the servo as firmware, closing the loop around the host's sled twin
//! (processor in the loop, PIL).
//!
//! SysTick fires once per sled sample period (Ts = 0.455 ms on the part's core clock:
//! [`sledid_firmware::PART_M4F`], [`sledid_firmware::PART_M0PLUS`]). Its handler reads the period's frame from
//! the host (reference r(k), quantised position y(k)), runs the servo's step behind the
//! embedded-hal boundary ([`sledid_firmware::Ticker`]: `sledid::servo::hal::ControlLoop`, position in,
//! PWM + direction pin out), answers with the drive and the step's flags, and posts the
//! redesign job a step asks for. The main loop is the background: it computes the redesign (f32)
//! and hands the result back; the handler adopts it at sample k + L, where L is the configuration
//! words' hand-over latency, or flags the miss and keeps the old gains — it never waits. The
//! configuration is decoded at start-up from the words the host computed (`loop_words.rs`,
//! [`sledid::words`]).
//!
//! # The link
//! Two FIFOs in QEMU's working directory ([`sledid_firmware::LINK_DOWN`], [`sledid_firmware::LINK_UP`]),
//! opened through semihosting; `host-tests/src/pil` creates them, runs QEMU with
//! `-icount shift=6,sleep=off` and steps the twin. A semihosting call stops the emulator until
//! the host answers and costs one instruction of virtual time, so under `-icount` the link
//! stands for a board's encoder and PWM registers: the handler's timing does not depend on how
//! fast the host is, and a run is deterministic. QEMU's boards clock SysTick at 25 MHz
//! (mps2-an386) and 16 MHz (microbit), not at the parts' 72 / 48 MHz, so under QEMU a period
//! (the parts' reload + 1 ticks) lasts 1.31 / 1.37 ms of virtual time, 20,475 / 21,327
//! instructions at 64 ns each; the cycle budget is measured with `count_insns.py` instead
//! (`BENCHMARKS.md`).
//!
//! # Overruns
//! [`sledid_firmware::timing`] (on target): SysTick's COUNTFLAG, set again before the handler ends, is an overrun, counted
//! (result line); the handler's length in SysTick ticks (core cycles on a part) and on
//! Cortex-M4 in DWT cycles (QEMU does not model the DWT: there that count stays 0) go into the
//! timing line.
//!
//! # Output (defmt frames on semihosting stdout)
//! The result line ([`sledid_firmware::Summary`]: samples, hand-overs, redesign outcomes,
//! overruns, the safety layer's stop — reason and sample —, the identifier's final θ, and the
//! friction health — ĉ, c_ref, updates, verdict flags, samples dropped on a full queue:
//! [`sledid_firmware::health`]), which
//! the host's reference must equal (it expects one overrun per stall it asked for), and the timing line:
//! `clock_hz=… reload=… stalls=… max_ticks=… dwt_max_cycles=… late_dropped=…
//! stack=used/size link_ok=…` (the part's name is on the first line).
//!
//! ```text
//! cargo xtask pil          # both images under QEMU, 20 seeks each, checked against the host
//! ```
//! Built for the host, `main` prints the configuration the words decode to.
//!
//! For `count_insns.py`, built with `--features fw-bench`, the image also exports
//! `sledid_fw_bench_init` (`--init`) and `sledid_fw_bench_tick` (one interrupt, its frame from a
//! recorded closed-loop run embedded in the image, `fixtures/pil_trace.bin`), and
//! `sledid_fw_bench_overhead` (the same scaffolding without the step, to subtract).
#![cfg_attr(target_os = "none", no_std, no_main)]
#![deny(missing_docs, unsafe_code)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

/// The defmt logger over semihosting (no panic path).
#[cfg(target_os = "none")]
mod logger;

#[cfg(target_os = "none")]
mod target {
    use core::cell::Cell;

    use cortex_m::peripheral::{SCB, SYST};
    use cortex_m_rt::{entry, exception};
    use critical_section::Mutex;
    use semihosting::fs::File;
    use semihosting::io::{Read, Write};
    use sledid::control::Controller;
    use sledid::control::scheduled::{RedesignJob, RedesignResult};
    use sledid::servo::{
        Calibrated, CalibratedModel, CalibrationRecord, Posted, Refusal, ServoFlags, SledServo,
        StopReason, Ticket,
    };

    use sledid_firmware::health::Queue;
    use sledid_firmware::timing::Timing;
    use sledid_firmware::{
        DOWN_FRAME_BYTES, DownFrame, HealthConsumer, HealthLine, HealthProducer, HealthTap,
        HealthWatch, Kind, LINK_DOWN, LINK_UP, Part, RESULT_PREFIX, TIMING_PREFIX, Ticker, UpFrame,
    };

    /// The part this image is built for.
    #[cfg(target_abi = "eabihf")]
    const PART: Part = sledid_firmware::PART_M4F;
    /// The part this image is built for.
    #[cfg(not(target_abi = "eabihf"))]
    const PART: Part = sledid_firmware::PART_M0PLUS;

    /// SysTick reload for one sample period on [`PART`]'s clock: 32,759 at 72 MHz, 21,839 at
    /// 48 MHz.
    const SYST_RELOAD: u32 = PART.syst_reload();

    // cortex-m-rt's default handler (every exception and interrupt without one of its own).
    #[allow(unsafe_code)] // declares a symbol of cortex-m-rt's `link.x`; never called from Rust
    unsafe extern "C" {
        fn DefaultHandler();
    }

    /// The device-specific part of the vector table (cortex-m-rt's `device` feature, `build.rs`):
    /// one entry, IRQ 0, to cortex-m-rt's default handler — the image enables no device interrupt
    /// (SysTick is a core exception) and cortex-m-rt requires at least one. The generic table it
    /// replaces held 240 entries on v7-M (960 bytes of flash), 32 on v6-M.
    #[allow(unsafe_code)] // `no_mangle` + `link_section`: the symbol cortex-m-rt's `link.x` places
    #[unsafe(link_section = ".vector_table.interrupts")]
    #[unsafe(no_mangle)]
    static __INTERRUPTS: [unsafe extern "C" fn(); 1] = [DefaultHandler];

    /// Stack paint pattern.
    const PAINT: u32 = 0xCCCC_CCCC;
    /// Bytes left unpainted below the painter's stack pointer (its own frame, see [`paint_stack`]).
    const STACK_PAINT_GUARD: usize = 64;

    /// The PIL link: two host files (FIFOs) through semihosting.
    struct Link {
        /// Host → target frames.
        down: File,
        /// Target → host frames.
        up: File,
    }

    impl Link {
        /// Opens the down link, then the up link (the host opens them in the same order).
        fn open() -> Option<Self> {
            let down = File::open(LINK_DOWN).ok()?;
            let up = File::create(LINK_UP).ok()?;
            Some(Self { down, up })
        }

        /// The next frame; `None` when the host has gone or sent something that is not a frame.
        fn receive(&mut self) -> Option<DownFrame> {
            let mut bytes = [0u8; DOWN_FRAME_BYTES];
            let mut got = 0;
            while let Some(rest @ [_, ..]) = bytes.get_mut(got..) {
                match self.down.read(rest) {
                    Ok(n) if n > 0 => got += n,
                    _ => return None,
                }
            }
            DownFrame::from_bytes(&bytes)
        }

        /// Sends `frame`; false when the host has gone.
        fn send(&mut self, frame: &UpFrame) -> bool {
            let bytes = frame.to_bytes();
            let mut sent = 0;
            while let Some(rest @ [_, ..]) = bytes.get(sent..) {
                match self.up.write(rest) {
                    Ok(n) if n > 0 => sent += n,
                    _ => return false,
                }
            }
            true
        }
    }

    /// Everything the SysTick handler steps, shared with the background under a critical
    /// section: the handler holds it for one period's work; the background only for taking a
    /// job and for handing a result back (a copy), never while it computes.
    struct Loop {
        /// The loop.
        ticker: Ticker<&'static SledServo>,
        /// The friction health's feed (after each step).
        health: HealthTap,
        /// The interrupt's end of the health queue.
        producer: HealthProducer<'static>,
        /// The host.
        link: Link,
        /// SysTick (the handler reads and clears its COUNTFLAG).
        syst: SYST,
        /// The clocks.
        timing: Timing,
        /// For the job the last step posted: hand its result back only once this many samples
        /// have been stepped (the host's fault injection, [`sledid_firmware::Command::delay`]).
        release_at: u32,
        /// Samples stepped so far.
        stepped: u32,
        /// Overruns the host asked for ([`sledid_firmware::Command::stall`]).
        stalls: u32,
        /// Set once the run has ended (false: the link failed, the host went away or sent a bad
        /// frame): the handler returns at once from then on.
        ended: Option<bool>,
    }

    impl Loop {
        /// One sample period (nothing once the run has ended).
        #[inline(always)]
        fn tick(&mut self) {
            if self.ended.is_some() {
                return;
            }
            self.timing.enter(&mut self.syst);
            let frame = self.link.receive();
            let kind = frame.and_then(|f| f.command.kind());
            let (Some(frame), Some(Kind::Sample | Kind::Lost)) = (frame, kind) else {
                self.ended = Some(kind == Some(Kind::End));
                return;
            };
            let up = self.ticker.step(&frame);
            let sent = self.link.send(&up);
            self.health.feed(&mut self.producer, &frame, &up);
            self.stepped = up.k.wrapping_add(1);
            if up.servo_flags().contains(ServoFlags::REDESIGN_POSTED) {
                self.release_at = self.stepped.wrapping_add(u32::from(frame.command.delay()));
            }
            if frame.command.stall() {
                // Injected overrun: spin until the next period's interrupt is pending.
                self.stalls = self.stalls.wrapping_add(1);
                while !SCB::is_pendst_pending() {}
            }
            self.timing.exit(&mut self.syst, SYST_RELOAD);
            if !sent {
                self.ended = Some(false);
            }
        }
    }

    /// The loop, once `main` has built it (a pointer: `.bss`). A `Cell` the pointer is taken out
    /// of and put back, not a `RefCell`: a `RefCell`'s borrow check is a panic path, and its
    /// message's formatting would link `core::fmt` into the image.
    static LOOP: Mutex<Cell<Option<&'static mut Loop>>> = Mutex::new(Cell::new(None));

    /// `f` on the loop, in a critical section (`None` before it is built; inside the critical
    /// section nothing else can be holding it).
    #[inline(always)]
    fn with_loop<T>(f: impl FnOnce(&mut Loop) -> T) -> Option<T> {
        critical_section::with(|cs| {
            let cell = LOOP.borrow(cs);
            let state = cell.take()?;
            let out = f(&mut *state);
            cell.set(Some(state));
            Some(out)
        })
    }

    /// The sample-period interrupt: one period of the loop. It never waits for the background (a
    /// redesign is handed over into the loop's state between two periods, or the step flags the
    /// miss at its due sample).
    #[exception]
    fn SysTick() {
        with_loop(Loop::tick);
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

    /// Decodes the configuration words into their static storage, once (`None` if they do not
    /// decode, or on a second call). `cortex_m::singleton!` keeps that storage in `.bss` (a
    /// static `Option` would start as a non-zero `None`, in `.data`, and take its size twice: in
    /// RAM and in flash). Out of line, so that the decoding's temporaries are gone before
    /// [`install`] runs and SysTick starts.
    #[inline(never)]
    fn install_config() -> Option<&'static SledServo> {
        let slot = cortex_m::singleton!(CONFIG: Option<SledServo> = None)?;
        sledid_firmware::config_into(slot).ok()?;
        slot.as_ref()
    }

    /// The friction health's queue (`.bss`), split into the interrupt's and the background's
    /// ends, and the background's estimator (`.bss`), once: `None` on a second call or if the
    /// health design does not build.
    #[inline(never)]
    fn install_health() -> Option<(
        HealthTap,
        HealthProducer<'static>,
        HealthConsumer<'static>,
        &'static mut HealthWatch,
    )> {
        let config = sledid_firmware::health_config().ok()?;
        let queue = cortex_m::singleton!(HEALTH_QUEUE: Queue = Queue::new())?;
        let (producer, consumer) = queue.split();
        let slot = cortex_m::singleton!(HEALTH_WATCH: Option<HealthWatch> = None)?;
        let watch = slot.insert(HealthWatch::new(config));
        Some((HealthTap::new(config), producer, consumer, watch))
    }

    /// Builds the loop into its static storage (`.bss`), once: `None` on a second call. Called
    /// after [`install_config`] has returned, so that their frames do not add up.
    #[inline(never)]
    #[allow(clippy::mut_from_ref)] // the storage is the singleton's, not `config`'s
    fn install(
        config: &'static SledServo,
        health: (HealthTap, HealthProducer<'static>),
        link: Link,
        syst: SYST,
    ) -> Option<&'static mut Loop> {
        let slot = cortex_m::singleton!(LOOP_STATE: Option<Loop> = None)?;
        Some(slot.insert(Loop {
            ticker: Ticker::new(config),
            health: health.0,
            producer: health.1,
            link,
            syst,
            timing: Timing::default(),
            release_at: 0,
            stepped: 0,
            stalls: 0,
            ended: None,
        }))
    }

    /// The background's work on one job (out of line: its frame is only there while it runs).
    #[inline(never)]
    fn redesign(config: &SledServo, posted: &Posted<RedesignJob>) -> RedesignResult {
        config.redesign(posted)
    }

    /// The background's fit of calibration's record, when the loop has posted it: the record is
    /// copied into this frame (the loop's state keeps the only other copy) and is gone from the
    /// stack when this returns, before [`calibration_job`] places the first design. `None`
    /// without a record; else the fit's ticket and answer.
    #[inline(never)]
    fn fit_job(config: &SledServo) -> Option<(Ticket, Result<CalibratedModel, Refusal>)> {
        // Copied straight into this frame's record, not returned through the critical section's
        // closure: one copy of the record on the stack.
        let mut record = CalibrationRecord::EMPTY;
        let ticket = with_loop(|l| l.ticker.take_calibration_job_into(&mut record)).flatten()?;
        Some((ticket, config.fit_calibration(&record)))
    }

    /// The background's health work: the queued samples through the estimator (out of line, as
    /// [`redesign`]).
    #[inline(never)]
    fn health_drain(health: &mut HealthWatch, consumer: &mut HealthConsumer<'static>) {
        health.drain(consumer);
    }

    /// An accepted fit as the health's reference (out of line, as [`redesign`]).
    #[inline(never)]
    fn health_adopt(
        health: &mut HealthWatch,
        consumer: &mut HealthConsumer<'static>,
        answer: &Calibrated<RedesignResult>,
    ) {
        health.adopt(consumer, answer);
    }

    /// Power-on calibration's record, when the loop has posted it: the fit ([`fit_job`]), then
    /// the first design and the hand-over ([`answer_job`]). `None` without a record; else whether
    /// the hand-over refused the answer (its due sample had passed).
    #[inline(never)]
    fn calibration_job(
        config: &SledServo,
        health: &mut HealthWatch,
        consumer: &mut HealthConsumer<'static>,
    ) -> Option<bool> {
        let (ticket, fitted) = fit_job(config)?;
        Some(answer_job(config, ticket, fitted, health, consumer))
    }

    /// The fit's answer: θ and the first design placed from it ([`SledServo::calibrated`] in
    /// two frames side by side: the design here, placed by [`first_design`], then the answer in
    /// [`deliver_answer`] — the answer is not on the stack under the redesign); whether the
    /// hand-over refused it. Out of line, as [`redesign_job`]: the design is on the stack only
    /// while this runs (not under the fit, nor under every redesign).
    #[inline(never)]
    fn answer_job(
        config: &SledServo,
        ticket: Ticket,
        fitted: Result<CalibratedModel, Refusal>,
        health: &mut HealthWatch,
        consumer: &mut HealthConsumer<'static>,
    ) -> bool {
        let design = config
            .first_design_job(&fitted)
            .map(|job| first_design(config, &job));
        deliver_answer(config, ticket, fitted, design.as_ref(), health, consumer)
    }

    /// The first design's redesign (out of line, as [`redesign`]).
    #[inline(never)]
    fn first_design(config: &SledServo, job: &RedesignJob) -> RedesignResult {
        config.controller().redesign(job)
    }

    /// The fit's answer from the first design, handed back into the loop's state and, accepted,
    /// made the friction health's reference; whether the hand-over refused it (out of line: see
    /// [`answer_job`]).
    #[inline(never)]
    fn deliver_answer(
        config: &SledServo,
        ticket: Ticket,
        fitted: Result<CalibratedModel, Refusal>,
        design: Option<&RedesignResult>,
        health: &mut HealthWatch,
        consumer: &mut HealthConsumer<'static>,
    ) -> bool {
        let answer = config.calibrated_answer(fitted, design);
        let accepted = with_loop(|l| l.ticker.deliver_calibration(ticket, answer));
        if accepted == Some(true) {
            health_adopt(health, consumer, &answer);
        }
        accepted == Some(false)
    }

    /// The next redesign job, when the loop has posted one: the redesign, held back until the
    /// loop has stepped the sample the host's fault injection asks for (the health queue drained
    /// meanwhile), then handed back. `None` without a job; else whether the hand-over refused
    /// the answer. Out of line (see [`calibration_job`]).
    #[inline(never)]
    fn redesign_job(
        config: &SledServo,
        health: &mut HealthWatch,
        consumer: &mut HealthConsumer<'static>,
    ) -> Option<bool> {
        let (posted, release_at) =
            with_loop(|l| l.ticker.take_job().map(|job| (job, l.release_at))).flatten()?;
        let design = redesign(config, &posted);
        // Held back until the loop has stepped `release_at` samples.
        while with_loop(|l| l.stepped < release_at && l.ended.is_none()) == Some(true) {
            health_drain(health, consumer);
            cortex_m::asm::wfi();
        }
        let accepted = with_loop(|l| l.ticker.deliver(posted.ticket, design));
        Some(accepted == Some(false))
    }

    /// The background: takes power-on calibration's record and each redesign job the loop
    /// posts, computes the fit or the redesign, and hands the answer back into the loop's state
    /// (a redesign held back as long as the host's fault injection asks); the hand-over refuses
    /// an answer whose due sample has passed (the step has flagged the miss). An accepted fit
    /// becomes the friction health's reference; after every job, and while a job is held back,
    /// it drains the health queue ([`sledid_firmware::health`]). Returns when the run has ended,
    /// with the number of answers refused.
    #[inline(never)]
    fn background(
        config: &SledServo,
        health: &mut HealthWatch,
        consumer: &mut HealthConsumer<'static>,
    ) -> u32 {
        let mut late = 0u32;
        loop {
            if let Some(refused) = calibration_job(config, health, consumer) {
                late = late.wrapping_add(u32::from(refused));
                continue;
            }
            if let Some(refused) = redesign_job(config, health, consumer) {
                late = late.wrapping_add(u32::from(refused));
                continue; // a job posted meanwhile is waiting
            }
            health_drain(health, consumer);
            if with_loop(|l| l.ended.is_some()) == Some(true) {
                return late;
            }
            // SysTick keeps running: a job posted by the next period wakes us.
            cortex_m::asm::wfi();
        }
    }

    /// The result line's `stop=` field: `none`, or the reason's [`StopReason::code`] (as
    /// [`sledid_firmware::Summary`] displays it; a code, not the reason's name, keeps the names
    /// out of the image's flash).
    struct StopField(Option<StopReason>);

    impl defmt::Format for StopField {
        fn format(&self, f: defmt::Formatter<'_>) {
            match self.0 {
                None => defmt::write!(f, "none"),
                Some(reason) => defmt::write!(f, "{=u8}", reason.code()),
            }
        }
    }

    /// The result and timing lines (the health queue drained first: the interrupt no longer
    /// feeds once the run has ended).
    #[inline(never)]
    fn report(late: u32, health: &mut HealthWatch, consumer: &mut HealthConsumer<'static>) -> bool {
        health.drain(consumer);
        let Some((mut s, t, stalls, link_ok)) = with_loop(|l| {
            let mut s = l.ticker.summary();
            s.health.dropped = l.health.dropped();
            (s, l.timing, l.stalls, l.ended == Some(true))
        }) else {
            return false;
        };
        s.health = HealthLine::new(&health.verdict(), s.health.dropped);
        let h = s.health;
        let (stack_used, stack_size) = stack_high_water();
        defmt::println!(
            "{=str} samples={=u32} lost={=u32} updates={=u32} handover={} \
             redesigns={} overruns={=u32} calibrations={=u32} stop={} theta={} health={} \
             health_updates={=u32} health_flags={=u8} health_dropped={=u32}",
            RESULT_PREFIX,
            s.samples,
            s.lost,
            s.updates,
            s.handover,
            s.redesigns,
            t.overruns,
            s.calibrations,
            StopField(s.stop),
            s.theta_raw,
            h.coulomb_raw,
            h.updates,
            h.flags,
            h.dropped
        );
        defmt::println!(
            "{=str} clock_hz={=u32} reload={=u32} stalls={=u32} max_ticks={=u32} \
             dwt_max_cycles={=u32} late_dropped={=u32} stack={=usize}/{=usize} link_ok={=bool}",
            TIMING_PREFIX,
            PART.core_clock_hz,
            SYST_RELOAD,
            stalls,
            t.max_ticks,
            t.dwt_max_cycles,
            late,
            stack_used,
            stack_size,
            link_ok
        );
        link_ok
    }

    /// Decodes the configuration, builds the health's queue and estimator, opens the link,
    /// starts SysTick and hands the loop to the handler; what the background needs, or `None`
    /// (said on the log where it is not the host's doing). Out of line: its temporaries (the
    /// parts moved into the loop's state) are gone from the stack before the background runs.
    #[inline(never)]
    fn start() -> Option<(
        &'static SledServo,
        &'static mut HealthWatch,
        HealthConsumer<'static>,
    )> {
        let cp = cortex_m::Peripherals::take()?;
        let Some(config) = install_config() else {
            defmt::println!("sledid-fw: the configuration words do not decode");
            return None;
        };
        let (tap, producer, consumer, health) = install_health()?;
        defmt::println!(
            "sledid-fw: {=str}, SysTick reload {=u32}; hand-over latency {=u32} samples; \
             waiting for the host",
            PART.name,
            SYST_RELOAD,
            config.handover_latency()
        );
        let Some(link) = Link::open() else {
            defmt::println!("sledid-fw: no PIL link (run it with `cargo xtask pil`)");
            return None;
        };
        #[cfg(target_abi = "eabihf")]
        {
            let (mut dcb, mut dwt) = (cp.DCB, cp.DWT);
            dcb.enable_trace();
            dwt.enable_cycle_counter();
        }
        let mut syst = cp.SYST;
        sledid_firmware::timing::start_sample_clock(&mut syst, SYST_RELOAD);
        // The handler owns SYST from here on; until the loop is built it does nothing.
        let state = install(config, (tap, producer), link, syst)?;
        critical_section::with(|cs| LOOP.borrow(cs).set(Some(state)));
        Some((config, health, consumer))
    }

    /// Starts the loop ([`start`]), runs the background until the host ends the run, reports.
    /// `true` on success.
    #[inline(never)]
    fn run() -> bool {
        let Some((config, health, mut consumer)) = start() else {
            return false;
        };
        let late = background(config, health, &mut consumer);
        report(late, health, &mut consumer)
    }

    /// Reset entry: paint the stack, run, exit through semihosting.
    #[entry]
    fn main() -> ! {
        // Nothing calls the bench exports; referencing them keeps the linker from dropping them.
        #[cfg(feature = "fw-bench")]
        core::hint::black_box(&bench::BENCH_EXPORTS);
        paint_stack();
        let ok = run();
        semihosting::process::exit(if ok { 0 } else { 1 })
    }

    /// Reports where it panicked (none is expected: the data path has none) and exits with
    /// failure. The location only, through defmt: formatting the message would link `core::fmt`.
    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        match info.location() {
            Some(l) => defmt::println!("sledid-fw panic at {=str}:{=u32}", l.file(), l.line()),
            None => defmt::println!("sledid-fw panic"),
        }
        semihosting::process::exit(1)
    }

    /// The `count_insns.py` entry points (`--features fw-bench`; the shipped image leaves them
    /// out: their run is a second copy of the loop state).
    ///
    /// The redesign is the background's work, outside the interrupt: `sledid_fw_bench_init` runs
    /// the whole trace once with every job redesigned, keeping the results in order, so that the
    /// measured calls only hand them over (as the background does, between two periods),
    /// bit-identical to the PIL run.
    #[cfg(feature = "fw-bench")]
    mod bench {
        use core::cell::RefCell;

        use critical_section::Mutex;
        use sledid::control::scheduled::{RedesignJob, RedesignResult};
        use sledid::servo::{Calibrated, CalibrationRecord, Posted, SledServo};

        use sledid::servo::health::HealthQueue;
        use sledid_firmware::recording::Cursor;
        use sledid_firmware::{Command, DownFrame, HealthTap, Kind, Ticker};

        /// A closed-loop run of the PIL's configuration on the twin (`fixtures/pil_trace.bin`:
        /// r and y of every sample, the recording codec with u = 0).
        static TRACE: &[u8] = include_bytes!("../../fixtures/pil_trace.bin");

        /// Redesign results kept by the init run, in the order of their jobs: the trace's 3 seeks
        /// post 4 (each result carries the placed gains with their seek plan, ≈ 0.4 KB: 32 of
        /// them, twice, overflowed the QEMU map's 16 KiB of RAM; 8 did with the health queue).
        const RESULTS: usize = 6;

        /// The measured run: the loop, its read position in the trace, the results, the next
        /// result's index, and power-on calibration's record with the fit's answer.
        struct Bench {
            ticker: Ticker<SledServo>,
            cursor: Cursor,
            results: [Option<RedesignResult>; RESULTS],
            jobs: [Option<Posted<RedesignJob>>; RESULTS],
            next: usize,
            calibration: Option<(Posted<CalibrationRecord>, Calibrated<RedesignResult>)>,
            /// The friction health's feed and a one-sample queue (the bench empties it itself).
            tap: HealthTap,
            queue: HealthQueue<2>,
        }

        /// The run `count_insns.py` measures.
        static BENCH: Mutex<RefCell<Option<Bench>>> = Mutex::new(RefCell::new(None));

        /// The trace's next sample as a frame.
        #[inline(always)]
        fn next_frame(cursor: &mut Cursor) -> Option<DownFrame> {
            let sample = cursor.next(TRACE)?;
            Some(DownFrame {
                command: Command::new(Kind::Sample),
                r: sample.r,
                y: sample.y,
            })
        }

        /// `--init`: runs the trace once, answering calibration's record and redesigning every
        /// job at once (the host's rule), and keeps the answers; then a fresh run for the
        /// measured calls.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_init() {
            let (Ok(config), Ok(health)) =
                (sledid_firmware::config(), sledid_firmware::health_config())
            else {
                return;
            };
            let mut results = [None; RESULTS];
            let mut jobs = [None; RESULTS];
            let mut ticker = Ticker::new(config);
            let mut cursor = Cursor::new();
            let mut n = 0;
            let mut calibration = None;
            while let Some(frame) = next_frame(&mut cursor) {
                ticker.step(&frame);
                if let Some(posted) = ticker.take_calibration_job() {
                    let answer = config.calibrate(&posted.job);
                    ticker.deliver_calibration(posted.ticket, answer);
                    calibration.get_or_insert((posted, answer));
                }
                if let Some(posted) = ticker.take_job() {
                    let design = config.redesign(&posted);
                    ticker.deliver(posted.ticket, design);
                    if let (Some(slot), Some(job)) = (results.get_mut(n), jobs.get_mut(n)) {
                        *slot = Some(design);
                        *job = Some(posted);
                    }
                    n += 1;
                }
            }
            let bench = Bench {
                ticker: Ticker::new(config),
                cursor: Cursor::new(),
                results,
                jobs,
                next: 0,
                calibration,
                tap: HealthTap::new(health),
                queue: HealthQueue::new(),
            };
            critical_section::with(|cs| BENCH.borrow(cs).replace(Some(bench)));
        }

        /// Runs `f` on the bench run and the trace's next frame, in a critical section (0 once
        /// the trace is exhausted or if the run was not initialised).
        #[inline(always)]
        fn with_bench(f: impl FnOnce(&mut Bench, &DownFrame) -> u32) -> u32 {
            critical_section::with(|cs| {
                let mut bench = BENCH.borrow_ref_mut(cs);
                let Some(bench) = bench.as_mut() else {
                    return 0;
                };
                let Some(frame) = next_frame(&mut bench.cursor) else {
                    return 0;
                };
                f(bench, &frame)
            })
        }

        /// One interrupt's work on the trace's next sample: the step behind the embedded-hal
        /// boundary, the answer's bytes, the friction health's feed, and a posted job's result
        /// handed over (adopted at k + L). The sample fed is popped again at once (the
        /// background's work on target; a few cycles every second call), so that every push
        /// finds room, as under PIL. Returns the answer's u.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_tick(_i: u32) -> u32 {
            with_bench(|b, frame| {
                let up = b.ticker.step(frame);
                let (mut producer, mut consumer) = b.queue.split();
                b.tap.feed(&mut producer, frame, &up);
                core::hint::black_box(consumer.dequeue());
                if let (Some(posted), Some((_, answer))) =
                    (b.ticker.take_calibration_job(), b.calibration)
                {
                    b.ticker.deliver_calibration(posted.ticket, answer);
                }
                if let Some(posted) = b.ticker.take_job() {
                    if let Some(Some(design)) = b.results.get(b.next) {
                        b.ticker.deliver(posted.ticket, *design);
                    }
                    b.next += 1;
                }
                core::hint::black_box(&up.to_bytes());
                up.u_raw as u32
            })
        }

        /// The scaffolding of [`sledid_fw_bench_tick`] without the step, to subtract.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_overhead(_i: u32) -> u32 {
            with_bench(|b, frame| {
                core::hint::black_box(&b.ticker);
                frame.y.raw() as u32
            })
        }

        /// The background's work: the redesign of job `i` (mod the jobs the trace posts), the
        /// time the hand-over latency L must cover. Returns the outcome's discriminant.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_redesign(i: u32) -> u32 {
            with_bench_ref(|b| {
                let n = b.jobs.iter().take_while(|j| j.is_some()).count().max(1);
                match b.jobs.get(i as usize % n) {
                    Some(Some(job)) => {
                        let design = b.ticker.config().redesign(core::hint::black_box(job));
                        core::hint::black_box(&design);
                        1
                    }
                    _ => 0,
                }
            })
        }

        /// `f` on the measured run without stepping it (0 before `--init`).
        fn with_bench_ref(f: impl FnOnce(&Bench) -> u32) -> u32 {
            critical_section::with(|cs| BENCH.borrow_ref(cs).as_ref().map_or(0, f))
        }

        /// The background's work on power-on calibration's record: the fit, θ and the first
        /// design ([`SledServo::calibrate`]), the time the fit's hand-over latency must cover.
        /// Returns 1 for a model, 0 for a refusal or without a record.
        #[allow(unsafe_code)] // `no_mangle` exports the symbol for count_insns.py; the name is unique.
        #[unsafe(no_mangle)]
        pub(super) extern "C" fn sledid_fw_bench_calibrate(_i: u32) -> u32 {
            with_bench_ref(|b| match &b.calibration {
                Some((posted, _)) => {
                    let answer = b
                        .ticker
                        .config()
                        .calibrate(core::hint::black_box(&posted.job));
                    u32::from(matches!(
                        core::hint::black_box(answer),
                        Calibrated::Model { .. }
                    ))
                }
                None => 0,
            })
        }

        /// The `count_insns.py` entry points, referenced from `main` so that they stay in the image.
        pub(super) static BENCH_EXPORTS: (extern "C" fn(), [extern "C" fn(u32) -> u32; 4]) = (
            sledid_fw_bench_init,
            [
                sledid_fw_bench_tick,
                sledid_fw_bench_overhead,
                sledid_fw_bench_redesign,
                sledid_fw_bench_calibrate,
            ],
        );
    }
}

/// Host build: prints the configuration the committed words decode to.
#[cfg(not(target_os = "none"))]
fn main() {
    use sledid_firmware::{PART_M0PLUS, PART_M4F, SAMPLE_PERIOD_NS};
    match sledid_firmware::config() {
        Ok(config) => println!(
            "sledid-fw (host build): configuration words (firmware/src/loop_words.rs, {} words) \
             decode to:\n{config:#?}",
            sledid_firmware::LOOP_WORDS.len()
        ),
        Err(e) => {
            eprintln!(
                "sledid-fw: the configuration words do not decode: {e}; regenerate them \
                 (SLEDID_WRITE_CONFIG=1 cargo test -p sledid-host --test integration firmware_qemu::loop_words)"
            );
            std::process::exit(1);
        }
    }
    for part in [PART_M4F, PART_M0PLUS] {
        println!(
            "{}: SysTick reload {} for {SAMPLE_PERIOD_NS} ns",
            part.name,
            part.syst_reload()
        );
    }
    println!("Firmware in the loop under QEMU: cargo xtask pil");
}
