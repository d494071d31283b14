//! Processor in the loop (PIL): the firmware image (`firmware/src/main.rs`) under QEMU closes the
//! loop around the sled twin running here, and every answer it gives is checked against the host
//! running the same interrupt body ([`sledid_firmware::Ticker`]) on the same configuration words.
//!
//! # One sample period
//! ```text
//! twin        r(k), y(k)                                  (crate::twin: reference, sensor)
//! reference   Ticker::step(frame) on the host → expected UpFrame, posted job
//!             background at once: a job is redesigned and delivered (adopted at k + L),
//!             unless the fault plan holds it back ≥ L periods (then it is not delivered)
//! target      the same frame over the link → UpFrame        (link::QemuLink)
//! check       target's UpFrame == expected, bit for bit (u raw I16F16, flags, duty, pin)
//! twin        advances one period under the target's u(k)
//! ```
//! Checked in lockstep, the target's drive sequence equals the host closed-loop run's
//! ([`run_loop`] without a target: same library code, plant, seed and words) sample for sample:
//! the first difference stops the run and names the sample.
//!
//! # Faults the host injects ([`Faults`])
//! Carried in the down frame's command word (`sledid_firmware::Command`), decided from the host's
//! reference alone, so that the host-only run makes the same decisions:
//! - a slow background: the target hands a job's result back only after `delay` more samples
//!   (L − 1: still adopted at k + L; L: the hand-over misses, the old gains stay, flagged);
//! - an overrun: the handler spins past the next period's start (the target must count it);
//! - a lost position: the frame carries no y (`step_lost`);
//! - a reversed sensor (the frame's y mirrored), a reversed drive (the twin gets −u) and mass or
//!   friction steps of the twin's plant, all on the host's side of the link.
//!
//! `sledid pil --inject` builds them from specs ([`Faults::from_specs`], in `faults.rs` with the
//! sample indices the PIL counts); the tests use the plan [`Faults::plan`].
//!
//! The sleds are [`plants::plants`]: the nominal one, the plant family's corners and sleds
//! drawn from it, each with its fault plan; the words are the nominal sled's design on all of
//! them (each calibrates at power-on).
//!
//! The configuration is [`design`]: the scheduled controller tuned on the default twin's sled
//! (`crate::control_eval::scheduled_design_for`, at the sled's Ts = 0.455 ms) with the hand-over
//! latency [`HANDOVER_LATENCY`]; its words are `firmware/src/loop_words.rs`
//! (`SLEDID_WRITE_CONFIG=1 cargo test -p sledid-host --test integration firmware_qemu::loop_words`).

mod cli;
mod faults;
pub mod link;
mod outcome;
pub mod plants;

use std::path::{Path, PathBuf};
use std::process::Command as Process;
use std::time::{Duration, Instant};

use sledid::SignalI16F16;
use sledid::servo::{
    CalibrationDesign, Identification, SERVO_WORDS_MAX, ServoDesign, ServoOptions, SledServo,
};

use crate::control::design::scheduled_design_for;
use crate::control::inject::apply_plant_faults;
use crate::control::run::twin_safety;
use crate::control::seek::{SeekOptions, seek_design};
use crate::reference::control::position_from_quanta;
use crate::twin::{ReferenceProfile, SledController, Twin, TwinParams};
pub use cli::{PilArgs, pil_cmd};
pub use faults::{Faults, PilFault, StopRule};
pub use link::{Core, QemuLink};
pub use outcome::{MOVED_QUANTA, SafeStop};
use sledid_firmware::health::Queue;
use sledid_firmware::{
    Command, DownFrame, HealthConsumer, HealthLine, HealthProducer, HealthTap, HealthWatch, Kind,
    RESULT_PREFIX, Summary, TIMING_PREFIX, Ticker, UpFrame,
};

/// L, the firmware's hand-over latency: a redesign requested by sample k is adopted at k + 64
/// (29 ms). The background gets what the interrupt leaves of each period, and one redesign
/// (the placement and the Coulomb inverse map) takes up to ≈ 9.4 periods of that on the
/// M0+ at 48 MHz (≈ 2.2 on the M4F at 72 MHz; `BENCHMARKS.md`, `sledid_fw_bench_redesign`) —
/// but it queues behind the friction health's drain (a full queue: 15 samples of the neuron,
/// up to ≈ 30 periods on the M0+). L = 12 sufficed while the calibrated product placed no
/// redesign after calibration; since the seeks learn their gain (`control::scheduled::learn`)
/// the M0+ missed a learnt redesign's hand-over at 12 on the fast, sticky corner sled
/// (`firmware_qemu`, 2026-11-27). A learnt redesign is adopted in the dwell after its seek
/// (≥ 0.3 s): 64 costs nothing there.
pub const HANDOVER_LATENCY: u16 = 64;

/// The fit's hand-over latency on target: calibration's record is answered by the background at
/// sample k + 3,072 (1.40 s). The fit ([`sledid::servo::SledServo::calibrate`], `f32`) is measured
/// by `cargo xtask cost firmware` (`sledid_fw_bench_calibrate`, BENCHMARKS.md): on the M0+,
/// without an FPU, it takes about 1,550 periods' worth of cycles at 48 MHz, and the interrupt
/// keeps its share of every period; 3,072 leaves that ×2. (The host's `sledid seek` keeps the
/// library's default, 64 samples: its background has no such limit.)
pub const FIT_LATENCY: u16 = 3_072;

/// Longest power-on calibration a run waits for before the seek schedule starts anyway (the
/// experiment's own bound is 330 samples, then the fit's [`FIT_LATENCY`]; a refused sled stops the
/// servo earlier).
pub const CALIBRATION_SAMPLES_MAX: usize = 2 * FIT_LATENCY as usize;

/// Seeks of the PIL runs `cargo xtask pil` and the tests make.
pub const SEEKS: u32 = 20;

/// Sleds of `cargo xtask pil` ([`plants::plants`]): the nominal one, the family's four corners
/// and five drawn.
pub const PLANTS: usize = 10;

/// Seed of those runs.
pub const SEED: u64 = 1;

/// The PIL's seek schedule: `seeks` seek commands (steps) of 20–2,000 tracks, log-uniform, as
/// `sledid seek` makes them ([`SeekOptions`]' defaults).
pub fn seek_options(seeks: u32) -> SeekOptions {
    SeekOptions {
        seeks,
        calibrate: true,
        ..SeekOptions::default()
    }
}

/// The twin the PIL closes the loop around: the default (the paper's sled, Ts = 0.455 ms) with
/// `seeks` seek commands ([`seek_options`]).
///
/// # Errors
/// The schedule's errors (none for the default sled).
pub fn twin_params(seeks: u32) -> Result<TwinParams, String> {
    // The seek mode's commands are steps.
    seek_options(seeks).twin_params(&TwinParams::default(), ReferenceProfile::Step)
}

/// The firmware's servo: the product's composition, as `sledid seek` runs it — power-on
/// calibration, then the scheduled controller in its seek mode (time-optimal seeks, settle,
/// hold: [`seek_design`]) designed from the default twin's sled as its prior
/// ([`scheduled_design_for`]), the velocity identifier seeded by calibration and holding its
/// model, the safety layer of the twin's travel ([`twin_safety`]), hand-over latency
/// [`HANDOVER_LATENCY`].
///
/// # Errors
/// The design's errors.
pub fn design() -> Result<ServoDesign, String> {
    let params = twin_params(SEEKS)?;
    let controller = seek_design(scheduled_design_for(&params, &params.plant)?);
    Ok(ServoDesign {
        options: ServoOptions {
            handover_latency_samples: HANDOVER_LATENCY,
            identification: Identification::FrozenAtPrior,
            ..ServoOptions::default()
        },
        safety: twin_safety(&params, &controller),
        calibration: Some(CalibrationDesign {
            fit_latency_samples: FIT_LATENCY,
            ..CalibrationDesign::default()
        }),
        ..ServoDesign::new(controller)
    })
}

/// The configuration words of [`design`] (what `loop_words.rs` must hold).
///
/// # Errors
/// The design's errors.
pub fn design_words() -> Result<Vec<u32>, String> {
    let mut buf = [0u32; SERVO_WORDS_MAX];
    let n = design()?.to_words(&mut buf).map_err(|e| e.to_string())?;
    Ok(buf.get(..n).unwrap_or(&[]).to_vec())
}

/// The configuration the firmware runs (the committed words).
///
/// # Errors
/// When the committed words do not decode.
pub fn firmware_config() -> Result<SledServo, String> {
    sledid_firmware::config().map_err(|e| format!("firmware/src/loop_words.rs: {e}"))
}

/// What the host's plan did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FaultLog {
    /// Samples sent without a position.
    pub lost: Vec<u32>,
    /// Samples whose handler was told to overrun.
    pub stalls: Vec<u32>,
    /// (job, posting sample, delay) of every job held back (slow or late).
    pub delayed: Vec<(u32, u32, u8)>,
    /// Jobs posted.
    pub jobs: u32,
}

/// One sample of a run: the frame sent and the answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record {
    /// What the host sent.
    pub frame: DownFrame,
    /// What came back (the target's, or the host's reference without a target).
    pub up: UpFrame,
}

/// The first sample at which the target's answer differed from the reference's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mismatch {
    /// The sample.
    pub k: u32,
    /// The frame sent.
    pub frame: DownFrame,
    /// The target's answer.
    pub target: UpFrame,
    /// The reference's.
    pub expected: UpFrame,
}

/// The other end of the lockstep: something that answers frames like the firmware.
pub trait Target {
    /// Sends `frame`, returns the answer.
    ///
    /// # Errors
    /// The link's failure.
    fn exchange(&mut self, frame: &DownFrame) -> Result<UpFrame, String>;
}

impl Target for QemuLink {
    fn exchange(&mut self, frame: &DownFrame) -> Result<UpFrame, String> {
        QemuLink::exchange(self, frame)
    }
}

/// A target that replays recorded answers (the tests' fake firmware: [`Self::corrupt`] makes it
/// answer one sample differently).
#[derive(Clone, Debug)]
pub struct ReplayTarget {
    answers: Vec<UpFrame>,
    next: usize,
}

impl ReplayTarget {
    /// Answers `answers` in order.
    pub fn new(answers: Vec<UpFrame>) -> Self {
        Self { answers, next: 0 }
    }

    /// XORs the fields of `flip` into the answer to sample `k`.
    pub fn corrupt(&mut self, k: usize, flip: UpFrame) {
        if let Some(a) = self.answers.get_mut(k) {
            a.k ^= flip.k;
            a.u_raw ^= flip.u_raw;
            a.flags ^= flip.flags;
            a.duty ^= flip.duty;
            a.forward ^= flip.forward;
        }
    }
}

impl Target for ReplayTarget {
    fn exchange(&mut self, _frame: &DownFrame) -> Result<UpFrame, String> {
        let answer = self.answers.get(self.next).copied();
        self.next += 1;
        answer.ok_or_else(|| format!("no recorded answer for sample {}", self.next - 1))
    }
}

/// The controller the twin sees: the reference in lockstep with the target (if any).
struct Lockstep<'a, 't> {
    reference: Ticker<SledServo>,
    /// The friction health beside it (`sledid_firmware::health`): fed after each step and
    /// drained at once (the target drains when its background gets to it).
    health: HostHealth<'a>,
    latency: u32,
    target: Option<&'t mut dyn Target>,
    faults: &'a Faults,
    stall_from: usize,
    log: FaultLog,
    records: Vec<Record>,
    mismatch: Option<Mismatch>,
    link_error: Option<String>,
    u_full_scale_v: f64,
    /// The reading the reversed sensor mirrors about, once reversed.
    pivot: Option<f64>,
}

/// The host's friction health: both ends of the queue and both sides of the estimator.
struct HostHealth<'q> {
    tap: HealthTap,
    producer: HealthProducer<'q>,
    watch: HealthWatch,
    consumer: HealthConsumer<'q>,
}

impl HostHealth<'_> {
    /// The result line's fields (after a last drain).
    fn line(&mut self) -> HealthLine {
        self.watch.drain(&mut self.consumer);
        HealthLine::new(&self.watch.verdict(), self.tap.dropped())
    }
}

impl Lockstep<'_, '_> {
    fn stopped(&self) -> bool {
        self.mismatch.is_some() || self.link_error.is_some()
    }

    /// Power-on calibration (or a re-calibration) owns the drive.
    fn calibrating(&self) -> bool {
        self.reference.state().calibration().is_running()
    }
}

impl SledController for Lockstep<'_, '_> {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        let k = self.records.len() as u32;
        let y_counts = match self.faults.reversed_sensor_from {
            Some(from) if k >= from => 2.0 * *self.pivot.get_or_insert(y_counts) - y_counts,
            _ => y_counts,
        };
        let kind = if self.faults.lost.contains(&k) {
            self.log.lost.push(k);
            Kind::Lost
        } else {
            Kind::Sample
        };
        let mut frame = DownFrame {
            command: Command::new(kind),
            r: position_from_quanta(r_counts),
            y: position_from_quanta(y_counts),
        };
        let expected = self.reference.step(&frame);
        let h = &mut self.health;
        h.tap.feed(&mut h.producer, &frame, &expected);
        h.watch.drain(&mut h.consumer);
        if let Some(posted) = self.reference.take_calibration_job() {
            // The fit, delivered at once (the target's background has its latency to answer),
            // and the health's reference from it, as on the target.
            let answer = self.reference.config().calibrate(&posted.job);
            if self.reference.deliver_calibration(posted.ticket, answer) {
                h.watch.adopt(&mut h.consumer, &answer);
            }
        }
        if let Some(posted) = self.reference.take_job() {
            let n = self.log.jobs;
            self.log.jobs += 1;
            let delay = if self.faults.missed_jobs.contains(&n) {
                self.latency
            } else if self.faults.slow_jobs.contains(&n) {
                self.latency.saturating_sub(1)
            } else {
                0
            };
            let delay = u8::try_from(delay).unwrap_or(u8::MAX);
            if delay > 0 {
                self.log.delayed.push((n, k, delay));
            }
            frame.command = frame.command.with_delay(delay);
            if u32::from(delay) < self.latency {
                let design = self.reference.config().redesign(&posted);
                self.reference.deliver(posted.ticket, design);
            }
        }
        if let Some(&at) = self.faults.stalls.get(self.stall_from)
            && k >= at
            && !self.reference.state().redesign_in_flight()
            && !self.calibrating()
        {
            self.stall_from += 1;
            self.log.stalls.push(k);
            frame.command = frame.command.with_stall();
        }
        let up = match self.target.as_mut() {
            None => expected,
            Some(link) => match link.exchange(&frame) {
                Ok(up) => up,
                Err(e) => {
                    self.link_error = Some(e);
                    expected
                }
            },
        };
        if up != expected && self.mismatch.is_none() {
            self.mismatch = Some(Mismatch {
                k,
                frame,
                target: up,
                expected,
            });
        }
        self.records.push(Record { frame, up });
        SignalI16F16::from_raw(up.u_raw).to_f64() * self.u_full_scale_v * self.faults.drive_sign(k)
    }
}

/// A closed-loop run on the twin.
pub struct LoopRun {
    /// The twin with its recording (driven by the target's answers when there was a target).
    pub twin: Twin,
    /// Every sample's frame and answer, power-on calibration's first.
    pub records: Vec<Record>,
    /// Samples of power-on calibration, before the seek schedule (the first records).
    pub calibration_samples: usize,
    /// The host's reference at the end (what the target's result line must equal; its overruns
    /// are the stalls asked for).
    pub summary: Summary,
    /// The faults asked for.
    pub plan: Faults,
    /// The faults injected.
    pub faults: FaultLog,
    /// The first difference between target and reference.
    pub mismatch: Option<Mismatch>,
    /// The link's failure, if it failed.
    pub link_error: Option<String>,
}

impl LoopRun {
    /// Seeks that ended, and of those, seeks that settled (|target − y| ≤ 1 quantum for the rest
    /// of the seek, `crate::twin::analysis`).
    pub fn settled(&self) -> (usize, usize) {
        let stats = self.twin.seek_stats();
        let settled = stats.iter().filter(|s| s.settling_time_s.is_some()).count();
        (stats.len(), settled)
    }
}

/// Runs the twin of `params` (seed `seed`) in closed loop with the firmware's configuration:
/// the host's reference alone (`target` = `None`: the host closed-loop run) or in lockstep with
/// a target, with `faults` (the plant steps applied before the sample they name). Stops at the
/// first mismatch or link failure.
///
/// # Errors
/// Twin parameters or the words.
pub fn run_loop(
    params: &TwinParams,
    seed: u64,
    faults: &Faults,
    target: Option<&mut dyn Target>,
) -> Result<LoopRun, String> {
    let config = firmware_config()?;
    let health = sledid_firmware::health_config().map_err(|e| e.to_string())?;
    let mut queue = Queue::new();
    let (producer, consumer) = queue.split();
    let mut twin = Twin::new(params.clone(), seed).map_err(|e| e.to_string())?;
    twin.set_controller_label("sledid-fw");
    let mut lockstep = Lockstep {
        latency: config.handover_latency(),
        reference: Ticker::new(config),
        health: HostHealth {
            tap: HealthTap::new(health),
            producer,
            watch: HealthWatch::new(health),
            consumer,
        },
        target,
        faults,
        stall_from: 0,
        log: FaultLog::default(),
        records: Vec::new(),
        mismatch: None,
        link_error: None,
        u_full_scale_v: params.plant.u_max_v,
        pivot: None,
    };
    let calibration_samples = twin.pre_roll(
        &mut lockstep,
        |l| l.stopped() || !l.calibrating(),
        CALIBRATION_SAMPLES_MAX,
    );
    while !lockstep.stopped() {
        // K counts frames (calibration's first): a plant step due during calibration comes at
        // the schedule's first sample.
        let k = calibration_samples + twin.samples().len();
        let from = if twin.samples().is_empty() { 0 } else { k };
        for at in from..=k {
            apply_plant_faults(&mut twin, &faults.plant_steps, at);
        }
        if twin.step(&mut lockstep).is_none() {
            break;
        }
    }
    let mut summary = lockstep.reference.summary();
    summary.overruns = lockstep.log.stalls.len() as u32;
    summary.health = lockstep.health.line();
    Ok(LoopRun {
        twin,
        summary,
        plan: faults.clone(),
        records: lockstep.records,
        calibration_samples,
        faults: lockstep.log,
        mismatch: lockstep.mismatch,
        link_error: lockstep.link_error,
    })
}

/// The workspace root (the `sledid` package).
pub fn workspace() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().unwrap_or(manifest).to_path_buf()
}

/// The firmware builds' own target directory (an outer `cargo test` holds the lock of its own).
pub fn firmware_target_dir() -> PathBuf {
    workspace().join("target/fw")
}

/// The firmware image of `core` (after [`build_firmware`]).
pub fn firmware_elf(core: Core) -> PathBuf {
    firmware_target_dir().join(format!("{}/firmware/sledid-fw", core.target()))
}

/// Builds the firmware for both cores: `cargo build --profile firmware -p sledid --bin
/// sledid-fw --target thumbv7em-none-eabihf --target thumbv6m-none-eabi` in
/// [`firmware_target_dir`].
///
/// # Errors
/// When cargo fails.
pub fn build_firmware() -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Process::new(cargo);
    cmd.current_dir(workspace()).args([
        "build",
        "--profile",
        "firmware",
        "-p",
        "sledid-firmware",
        "--bin",
        "sledid-fw",
    ]);
    for core in Core::ALL {
        cmd.args(["--target", core.target()]);
    }
    let status = cmd
        .env("CARGO_TARGET_DIR", firmware_target_dir())
        // These would replace the config's per-target rustflags (and drop `-Tlink.x`).
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("firmware build failed: {status}"))
    }
}

/// The firmware's timing line (`sledid_firmware::TIMING_PREFIX`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Timing {
    /// The part's core clock, Hz.
    pub clock_hz: u32,
    /// SysTick reload.
    pub reload: u32,
    /// Overruns the host asked for.
    pub stalls: u32,
    /// Longest handler that did not overrun, SysTick ticks (under QEMU: virtual time at the
    /// emulated board's SysTick clock, see `firmware/src/main.rs`).
    pub max_ticks: u32,
    /// Longest handler by the DWT cycle counter (0 on Cortex-M0 and under QEMU).
    pub dwt_max_cycles: u32,
    /// Redesign results the background dropped because their hand-over had passed.
    pub late_dropped: u32,
    /// Painted-stack high-water mark, bytes.
    pub stack_used: u32,
    /// The stack region, bytes.
    pub stack_size: u32,
    /// False when the link failed before the end frame.
    pub link_ok: bool,
}

impl Timing {
    /// Parses the timing line (`key=value` pairs after the prefix).
    ///
    /// # Errors
    /// A missing or malformed field.
    pub fn parse(line: &str) -> Result<Self, String> {
        let rest = line
            .strip_prefix(TIMING_PREFIX)
            .ok_or_else(|| format!("not a timing line: {line}"))?;
        let mut t = Self::default();
        let mut seen = 0;
        for pair in rest.split_whitespace() {
            let (key, value) = pair
                .split_once('=')
                .ok_or_else(|| format!("`{pair}` in the timing line"))?;
            let num = |v: &str| {
                v.parse::<u32>()
                    .map_err(|e| format!("{key}={v} in the timing line: {e}"))
            };
            match key {
                "clock_hz" => t.clock_hz = num(value)?,
                "reload" => t.reload = num(value)?,
                "stalls" => t.stalls = num(value)?,
                "max_ticks" => t.max_ticks = num(value)?,
                "dwt_max_cycles" => t.dwt_max_cycles = num(value)?,
                "late_dropped" => t.late_dropped = num(value)?,
                "stack" => {
                    let (used, size) = value
                        .split_once('/')
                        .ok_or_else(|| format!("stack={value} in the timing line"))?;
                    t.stack_used = num(used)?;
                    t.stack_size = num(size)?;
                }
                "link_ok" => t.link_ok = value == "true",
                _ => return Err(format!("unknown field `{key}` in the timing line")),
            }
            seen += 1;
        }
        if seen != 8 {
            return Err(format!(
                "{seen} fields in the timing line, expected 8: {line}"
            ));
        }
        Ok(t)
    }
}

/// A PIL run on one core.
pub struct PilRun {
    /// The core.
    pub core: Core,
    /// The closed loop (the twin driven by the target).
    pub run: LoopRun,
    /// QEMU's exit status (the firmware's semihosting exit code).
    pub status: std::process::ExitStatus,
    /// The decoded defmt log.
    pub log: String,
    /// The firmware's result line.
    pub result_line: Option<String>,
    /// The firmware's timing line.
    pub timing: Option<Timing>,
    /// Wall time of the run.
    pub wall: Duration,
}

impl PilRun {
    /// The result line the host's reference expects.
    pub fn expected_result_line(&self) -> String {
        format!("{RESULT_PREFIX} {}", self.run.summary)
    }

    /// Every check of a PIL run: [`Self::check_lockstep`], then that the servo did what the
    /// faults call for ([`LoopRun::check_outcome`]: every seek settled, or — with a fault that may
    /// or must stop it — a safe stop, held, whose reason (the result line) and sample (the first
    /// answer flagged `SAFE_STOP`) the target and the host agree on).
    ///
    /// # Errors
    /// The first check that fails, with what was seen.
    pub fn check(&self) -> Result<(), String> {
        self.check_lockstep()?;
        self.run
            .check_outcome()
            .map_err(|e| format!("{}: {e}", self.core.name()))
    }

    /// The target against the host: the link held, no mismatch, QEMU exited with success, the
    /// result line equals the reference's (overruns included: one per stall asked for; the
    /// safe stop's reason), the stalls were made.
    ///
    /// # Errors
    /// The first check that fails, with what was seen.
    pub fn check_lockstep(&self) -> Result<(), String> {
        let core = self.core.name();
        if let Some(e) = &self.run.link_error {
            return Err(format!("{core}: {e}\n{}", self.log));
        }
        if let Some(m) = &self.run.mismatch {
            return Err(format!(
                "{core}: the target differs from the host at sample {}: {m:?}",
                m.k
            ));
        }
        if !self.status.success() {
            return Err(format!(
                "{core}: QEMU exited with {}; log:\n{}",
                self.status, self.log
            ));
        }
        let expected = self.expected_result_line();
        if self.result_line.as_deref() != Some(expected.as_str()) {
            return Err(format!(
                "{core}: result line\n  target: {:?}\n  host:   {expected}",
                self.result_line
            ));
        }
        let timing = self
            .timing
            .ok_or_else(|| format!("{core}: no timing line"))?;
        if timing.stalls != self.run.faults.stalls.len() as u32 {
            return Err(format!(
                "{core}: {} stalls made, {} asked for",
                timing.stalls,
                self.run.faults.stalls.len()
            ));
        }
        Ok(())
    }
}

/// Runs `elf` for `core` under QEMU in closed loop with the twin of `params` (seed `seed`),
/// checked in lockstep against the host's reference, with `faults`; QEMU works in `dir`.
///
/// # Errors
/// QEMU or its link failing to start, the words, the defmt log not decoding. A mismatch or a link failure
/// during the run is in the result, not an error.
pub fn run_pil(
    core: Core,
    elf: &Path,
    params: &TwinParams,
    seed: u64,
    faults: &Faults,
    dir: &Path,
) -> Result<PilRun, String> {
    let qemu = link::require_qemu()?;
    let start = Instant::now();
    let mut link = QemuLink::start(&qemu, elf, core, dir, Duration::from_secs(60))?;
    let run = run_loop(params, seed, faults, Some(&mut link as &mut dyn Target))?;
    let exit = link.finish(Duration::from_secs(60))?;
    let wall = start.elapsed();
    let log = link::decode_defmt(elf, &exit.defmt_frames)?;
    let line = |prefix: &str| {
        log.lines()
            .find(|l| l.starts_with(prefix))
            .map(str::to_owned)
    };
    let timing = line(TIMING_PREFIX).map(|l| Timing::parse(&l)).transpose()?;
    Ok(PilRun {
        core,
        run,
        status: exit.status,
        result_line: line(RESULT_PREFIX),
        timing,
        log: if exit.stderr.is_empty() {
            log
        } else {
            format!("{log}\nQEMU stderr:\n{}", exit.stderr)
        },
        wall,
    })
}
