//! `sledid control-family`: the servo on N plants of the seeded family × the seeks, against the
//! baseline, the servo frozen at its prior and the servo without friction identification — in
//! parallel, with a progress bar; writes a table, JSON and a plot. With `--passes seek|both`, the
//! seek evaluation too (issue 14): every plant's seek commands under the seek mode and today's
//! reference-following servo, access time over the plant's minimum-time bound.

use indicatif::{ProgressBar, ProgressStyle};
use sledid_host::control::family_eval::{self, FamilyOptions};
use sledid_host::control::plot;
use sledid_host::control::seek::SeekOptions;
use sledid_host::control::seek::family as seek_family;
use sledid_host::twin::TwinParams;
use std::path::PathBuf;

/// `sledid control-family`.
#[derive(clap::Args)]
pub struct Args {
    /// Plants of the family.
    #[arg(long, default_value_t = 200)]
    pub plants: u64,
    /// The family's seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Seeks per plant and controller.
    #[arg(long, default_value_t = 100)]
    pub seeks: u32,
    /// The plant every servo is designed from (JSON, its `plant` section), or `exact`: each
    /// plant's servo designed from that plant itself. Default: the built-in nominal sled.
    #[arg(long)]
    pub prior: Option<PathBuf>,
    /// The seek pass's servos never adapt (identification frozen at the prior; with `--prior
    /// exact`, the seek law alone on each plant's exact model).
    #[arg(long)]
    pub frozen: bool,
    /// The seek pass's seek mode does not calibrate at power-on (it calibrates by default, except
    /// with `--prior exact`): it starts seeking on the prior and identifies on-line.
    #[arg(long)]
    pub no_calibrate: bool,
    /// The wider family: every range doubled at both ends on a log scale
    /// (`FamilyRanges::wide`).
    #[arg(long)]
    pub wide: bool,
    /// Which evaluations: the seek evaluation (the default: access time over the plant's
    /// minimum-time bound, the product's seek mode — calibrated at power-on — beside the
    /// reference-following servo), the settling comparison of four reference-following
    /// controllers (issue 13), or both.
    #[arg(long, value_enum, default_value = "seek")]
    pub passes: Passes,
    /// Seek distances MIN:MAX, tracks, of the seek evaluation (log-uniform).
    #[arg(long, default_value = "20:2000")]
    pub distances: String,
    /// Output directory: family.json, family.md, family.png (settling); seek.json, seek.md,
    /// seek.png (seek).
    #[arg(long, default_value = "out/control-family")]
    pub out: PathBuf,
}

/// `--passes`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Passes {
    /// The settling comparison (baseline, servo, frozen, linear-only).
    Settling,
    /// The seek evaluation only.
    Seek,
    /// Both.
    Both,
}

/// Runs the command.
///
/// # Errors
/// Parameter, run, file or plot errors.
pub fn run(a: &Args) -> Result<(), String> {
    let exact_prior = super::is_exact_prior(a.prior.as_ref());
    let prior = match &a.prior {
        Some(_) if exact_prior => TwinParams::default().plant,
        Some(p) => {
            TwinParams::from_json_file(p)
                .map_err(|e| format!("{}: {e}", p.display()))?
                .plant
        }
        None => TwinParams::default().plant,
    };
    let options = FamilyOptions {
        plants: a.plants,
        seed: a.seed,
        seeks: a.seeks,
        prior,
        exact_prior,
        frozen: a.frozen,
        calibrate: !a.no_calibrate && !exact_prior,
        ranges: if a.wide {
            sledid_host::control::family::FamilyRanges::wide()
        } else {
            sledid_host::control::family::FamilyRanges::default()
        },
        ..FamilyOptions::default()
    };
    let (min_tracks, max_tracks) = SeekOptions::parse_distances(&a.distances)?;
    let new_bar = || {
        let bar = ProgressBar::new(a.plants);
        if let Ok(style) = ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} plants, eta {eta}",
        ) {
            bar.set_style(style);
        }
        bar
    };
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let write = |name: &str, text: String| {
        let path = a.out.join(name);
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
    };
    if a.passes != Passes::Seek {
        let bar = new_bar();
        let report = family_eval::evaluate(&options, Some(&bar))?;
        bar.finish_and_clear();
        let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        write("family.json", json + "\n")?;
        let stats = family_eval::stats_table(&report.stats);
        write(
            "family.md",
            format!(
                "# Servo on {} plants of family seed {}, {} seeks each\n\n{stats}\n{}",
                a.plants,
                a.seed,
                a.seeks,
                family_eval::plant_table(&report)
            ),
        )?;
        plot::plot_family(&report, &a.out.join("family.png"))?;
        println!("{stats}");
    }
    if a.passes != Passes::Settling {
        let schedule = SeekOptions {
            min_tracks,
            max_tracks,
            ..SeekOptions::default()
        };
        let bar = new_bar();
        let report = seek_family::evaluate(&options, &schedule, Some(&bar))?;
        bar.finish_and_clear();
        let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        write("seek.json", json + "\n")?;
        let stats = seek_family::stats_table(&report);
        write(
            "seek.md",
            format!(
                "# Seeks on {} plants of family seed {}, {} seeks of {min_tracks}–{max_tracks} tracks each\n\n{stats}\n{}",
                a.plants,
                a.seed,
                a.seeks,
                seek_family::plant_table(&report)
            ),
        )?;
        plot::plot_seek_family(&report, &a.out.join("seek.png"))?;
        println!("{stats}");
    }
    println!("→ {}", a.out.display());
    Ok(())
}
