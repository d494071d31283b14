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
    #[arg(long)]
    pub no_faults: bool,
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
    let faults = if args.no_faults {
        Faults::default()
    } else {
        Faults::plan()
    };
    build_firmware()?;
    let params = twin_params(args.seeks);
    let mut failed = Vec::new();
    for &core in cores {
        let dir = firmware_target_dir().join(format!("pil-{}", core.name()));
        let pil = run_pil(core, &firmware_elf(core), &params, args.seed, &faults, &dir)?;
        let (seeks, settled) = pil.run.settled();
        let t = pil.timing.unwrap_or_default();
        println!(
            "{core}: {samples} samples, {settled}/{seeks} seeks settled, answers {lockstep}; \
             {result}\n      overruns {overruns} (stalls asked {stalls}), hand-overs \
             posted/adopted/missed {handover:?}, late results refused {late}; handler max \
             {ticks} of {period} SysTick ticks (QEMU virtual time), stack {stack} B; {wall:.2?} \
             wall, QEMU log in {dir}",
            core = core.name(),
            samples = pil.run.records.len(),
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
