//! `sledid pil` (`cargo xtask pil`): builds the firmware, runs it under QEMU in the loop with the
//! twin on each core, checks it against the host and prints what it measured.

use super::{Core, Faults, build_firmware, firmware_elf, firmware_target_dir, plants, run_pil};

/// `sledid pil`'s options.
#[derive(Clone, Debug, clap::Args)]
pub struct PilArgs {
    /// The core(s): m4f, m0 or both.
    #[arg(long, default_value = "both")]
    pub core: String,
    /// Seeks per sled.
    #[arg(long, default_value_t = super::SEEKS)]
    pub seeks: u32,
    /// Sleds: the nominal one, the plant family's four corners, then sleds drawn from the
    /// family (`pil::plants`); 1 runs the nominal sled alone.
    #[arg(long, default_value_t = super::PLANTS)]
    pub plants: usize,
    /// Seed of the seeks and the sensor noise.
    #[arg(long, default_value_t = super::SEED)]
    pub seed: u64,
    /// Run without the fault plans (no late or slow background, no overrun, no lost position, no
    /// reversed sensor).
    #[arg(long, conflicts_with = "inject")]
    pub no_faults: bool,
    /// A fault injected into every sled's run, repeatable; given, the faults are these alone (they
    /// replace the default plans): `lost:at=K[,n=N]`, `stall:at=K`, `handover-miss:job=J`,
    /// `handover-slow:job=J`, `flip:from=K` (reversed sensor), `drive-flip:from=K`,
    /// `mass:at=K,factor=F`, `friction:at=K,factor=F`. K is the sample as the PIL counts it: the
    /// frame's index from 0 at the run's first frame (the up frame's k; power-on calibration's
    /// frames first: 3,194 on the default sled); J the redesign jobs in
    /// the order posted, from 0. E.g. `--inject flip:from=4312`. Each core's line shows what the
    /// servo did: every seek settled, or the safe stop (reason, sample, seek, reading).
    #[arg(long)]
    pub inject: Vec<String>,
}

/// The faults of sled `plant` (its own plan by default) and how to say so.
fn faults_of(args: &PilArgs, plant: &plants::PilPlant) -> Result<(Faults, String), String> {
    if args.no_faults {
        Ok((Faults::default(), "none (--no-faults)".to_owned()))
    } else if args.inject.is_empty() {
        let specs = plant.faults.to_specs().join(" ");
        Ok((plant.faults.clone(), format!("its plan: --inject {specs}")))
    } else {
        let faults = Faults::from_specs(&args.inject)?;
        Ok((faults, format!("--inject {}", args.inject.join(" "))))
    }
}

/// Runs the PIL as `args` asks: each sled on each core, one line per run; fails when a target
/// differs from the host (answers, result line, overruns), naming each. Where the servo does not
/// do what the faults call for (every seek settled, or a safe stop where a fault calls for one)
/// it says so: the host's run does the same.
///
/// # Errors
/// A bad option, the build, QEMU, or a failed check (with what was seen).
pub fn pil_cmd(args: &PilArgs) -> Result<(), String> {
    let cores: &[Core] = match args.core.as_str() {
        "both" => &Core::ALL,
        "m4f" => &[Core::M4f],
        "m0" => &[Core::M0],
        other => return Err(format!("--core {other}: m4f, m0 or both")),
    };
    if args.plants == 0 {
        return Err("--plants 0: need at least one sled".to_owned());
    }
    let sleds = plants::plants(args.plants, args.seeks)?;
    build_firmware()?;
    let (mut failed, mut servo) = (Vec::new(), Vec::new());
    for sled in &sleds {
        let (faults, described) = faults_of(args, sled)?;
        println!("{}: faults {described}", sled.name);
        for &core in cores {
            let dir = firmware_target_dir().join(format!("pil-{}", core.name()));
            let pil = run_pil(
                core,
                &firmware_elf(core),
                &sled.params,
                args.seed,
                &faults,
                &dir,
            )?;
            let t = pil.timing.unwrap_or_default();
            println!(
                "  {core}: {samples} samples ({calibration} calibrating), {outcome}, answers \
                 {lockstep}; {result}\n      overruns {overruns} (stalls asked {stalls}), \
                 hand-overs posted/adopted/missed {handover:?}, late results refused {late}; \
                 handler max {ticks} of {period} SysTick ticks (QEMU virtual time), stack {stack} \
                 B; {wall:.2?} wall, QEMU log in {dir}",
                core = core.name(),
                samples = pil.run.records.len(),
                calibration = pil.run.calibration_samples,
                outcome = pil.run.outcome_line(),
                lockstep = if pil.run.mismatch.is_none() && pil.run.link_error.is_none() {
                    "bit-identical to the host"
                } else {
                    "DIFFERENT"
                },
                result = pil.result_line.as_deref().unwrap_or("no result line"),
                overruns = pil.run.summary.overruns,
                stalls = pil.run.faults.stalls.len(),
                handover = pil.run.summary.handover,
                late = t.late_dropped,
                ticks = t.max_ticks,
                period = t.reload + 1,
                stack = t.stack_used,
                wall = pil.wall,
                dir = dir.display(),
            );
            if let Err(e) = pil.check_lockstep() {
                failed.push(format!("{}: {e}", sled.name));
            } else if let Err(e) = pil.run.check_outcome() {
                servo.push(format!("{} ({}): {e}", sled.name, core.name()));
            }
        }
    }
    // The servo's misses are the host's too (the answers are bit-identical): reported, not the
    // PIL's failure.
    for miss in &servo {
        println!("servo (as on the host): {miss}");
    }
    if failed.is_empty() {
        println!(
            "pil: every answer bit-identical to the host on {} sleds; the servo did what the \
             faults call for on {} of {} runs",
            sleds.len(),
            sleds.len() * cores.len() - servo.len(),
            sleds.len() * cores.len()
        );
        Ok(())
    } else {
        Err(failed.join("\n"))
    }
}
