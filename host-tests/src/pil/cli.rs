//! `sledid pil` (`cargo xtask pil`): builds the firmware, runs it under QEMU in the loop with the
//! twin on each core, checks it against the host and prints what it measured.

use super::{
    Core, Faults, build_firmware, firmware_elf, firmware_target_dir, run_pil, twin_params,
};

/// `sledid pil`'s options.
#[derive(Clone, Debug, clap::Args)]
pub struct PilArgs {
    /// The core(s): m4f, m0 or both.
    #[arg(long, default_value = "both")]
    pub core: String,
    /// Seeks.
    #[arg(long, default_value_t = super::SEEKS)]
    pub seeks: u32,
    /// Seed of the seeks and the sensor noise.
    #[arg(long, default_value_t = super::SEED)]
    pub seed: u64,
    /// Run without the fault plan (no late or slow background, no overrun, no lost position).
    #[arg(long, conflicts_with = "inject")]
    pub no_faults: bool,
    /// A fault injected into the run, repeatable; given, the faults are these alone (they replace
    /// the default plan): `lost:at=K[,n=N]`, `stall:at=K`, `handover-miss:job=J`,
    /// `handover-slow:job=J`, `flip:from=K` (reversed sensor), `drive-flip:from=K`,
    /// `mass:at=K,factor=F`, `friction:at=K,factor=F`. K is the sample as the PIL counts it: the
    /// frame's index from 0 at the run's first frame (the up frame's k; power-on calibration's
    /// frames first: 3,194 on the default sled); J the redesign jobs in
    /// the order posted, from 0. E.g. `--inject flip:from=4312`. Each core's line shows what the
    /// servo did: every seek settled, or the safe stop (reason, sample, seek, reading).
    #[arg(long)]
    pub inject: Vec<String>,
}

/// The faults `args` asks for, and how to say so.
fn faults_of(args: &PilArgs) -> Result<(Faults, String), String> {
    if args.no_faults {
        Ok((Faults::default(), "none (--no-faults)".to_owned()))
    } else if args.inject.is_empty() {
        let plan = Faults::plan();
        let specs = plan.to_specs().join(" ");
        Ok((plan, format!("the default plan: --inject {specs}")))
    } else {
        let faults = Faults::from_specs(&args.inject)?;
        Ok((faults, format!("--inject {}", args.inject.join(" "))))
    }
}

/// Runs the PIL as `args` asks; prints one line per core and fails on the first failed check.
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
    let (faults, described) = faults_of(args)?;
    println!("faults: {described}");
    build_firmware()?;
    let params = twin_params(args.seeks)?;
    let mut failed = Vec::new();
    for &core in cores {
        let dir = firmware_target_dir().join(format!("pil-{}", core.name()));
        let pil = run_pil(core, &firmware_elf(core), &params, args.seed, &faults, &dir)?;
        let t = pil.timing.unwrap_or_default();
        println!(
            "{core}: {samples} samples, {outcome}, answers {lockstep}; \
             {result}\n      overruns {overruns} (stalls asked {stalls}), hand-overs \
             posted/adopted/missed {handover:?}, late results refused {late}; handler max \
             {ticks} of {period} SysTick ticks (QEMU virtual time), stack {stack} B; {wall:.2?} \
             wall, QEMU log in {dir}",
            core = core.name(),
            samples = pil.run.records.len(),
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
        if let Err(e) = pil.check() {
            failed.push(e);
        }
    }
    if failed.is_empty() {
        println!("pil: every check passed");
        Ok(())
    } else {
        Err(failed.join("\n"))
    }
}
