//! The seek evaluation over the plant family (`sledid control-family --seek`): every plant of the
//! seeded family runs the same log-uniform seek commands under the seek mode (the servo fed the
//! step, [`SeekController::Seek`]) and under today's reference-following servo
//! ([`SeekController::Reference`]), both designed from the same prior; each seek's access time is
//! divided by the minimum-time bound of that plant from where its sled started.
//!
//! Statistics over the family (what issue 14's targets name): the median and p95 of access /
//! bound over all seeks of all plants, the median over the seeks of at least
//! [`LONG_SEEK_TRACKS`], the fraction of plants with 0 unsettled seeks and 0 limit-cycle pulses;
//! and on the nominal sled, the median access time of both controllers.

use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::Serialize;

use super::access::Quantiles;
use super::run::{
    LONG_SEEK_TRACKS, SeekController, SeekOptions, SeekRow, SeekSummary, run_seeks, seek_design,
};
use crate::control::design::design_from_prior;
use crate::control::family::PlantFactors;
use crate::control::family_eval::FamilyOptions;
use crate::twin::TwinParams;

/// One controller on one plant, in brief.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SeekBrief {
    /// Median access time, ms.
    pub access_median_ms: f64,
    /// Median of access / bound.
    pub ratio_median: f64,
    /// 95th percentile of access / bound.
    pub ratio_p95: f64,
    /// Median of access / bound over the seeks of at least [`LONG_SEEK_TRACKS`].
    pub ratio_long_median: f64,
    /// Seeks not settled for 10 ms before their end.
    pub unsettled: usize,
    /// Of those, the seeks the servo reported as seek errors.
    pub unsettled_reported: usize,
    /// Settled seeks the servo reported all the same (settled late, or a false alarm).
    pub settled_reported: usize,
    /// Failing seeks (unsettled, or with a limit-cycle pulse) the servo did not report.
    pub failing_unreported: usize,
    /// Limit-cycle pulses.
    pub limit_cycle_pulses: usize,
    /// Fine steps that landed (not pulses).
    pub fine_steps: usize,
    /// The safety layer's stop, if it latched one.
    pub safe_stop: Option<super::run::SafeStop>,
    /// Per seek: distance (tracks) and access / bound (not in the JSON).
    #[serde(skip)]
    pub ratios: Vec<(i64, f64)>,
}

impl SeekBrief {
    fn of(summary: &SeekSummary, rows: &[SeekRow]) -> Self {
        Self {
            access_median_ms: summary.access_ms.median,
            ratio_median: summary.ratio.median,
            ratio_p95: summary.ratio.p95,
            ratio_long_median: summary.ratio_long_median,
            unsettled: summary.unsettled,
            unsettled_reported: summary.unsettled_reported,
            settled_reported: summary.settled_reported,
            failing_unreported: summary.failing_unreported,
            limit_cycle_pulses: summary.limit_cycle_pulses,
            fine_steps: summary.fine_steps,
            safe_stop: summary.safe_stop,
            ratios: rows
                .iter()
                .filter_map(|r| r.ratio.map(|q| (r.distance_tracks, q)))
                .collect(),
        }
    }

    /// No unsettled seek and no limit-cycle pulse.
    pub fn clean(&self) -> bool {
        self.unsettled == 0 && self.limit_cycle_pulses == 0
    }

    /// Failing with nothing flagged: no stop, and a seek unsettled or with a limit-cycle pulse
    /// that the servo did not report as a seek error.
    pub fn unflagged(&self) -> bool {
        self.safe_stop.is_none() && self.failing_unreported > 0
    }
}

/// One plant's seek results.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SeekPlantResult {
    /// Index in the family.
    pub index: u64,
    /// Its factors.
    pub factors: PlantFactors,
    /// The bound of the longest seek from rest, ms.
    pub longest_bound_ms: f64,
    /// The seek mode (time-optimal seeks).
    pub seek: SeekBrief,
    /// Today's reference-following servo.
    pub reference: SeekBrief,
}

/// One controller over the family.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SeekFamilyStats {
    /// Access / bound over every seek of every plant.
    pub ratio: Quantiles,
    /// Median of access / bound over the seeks of at least [`LONG_SEEK_TRACKS`].
    pub ratio_long_median: f64,
    /// Fraction of plants with 0 unsettled seeks and 0 limit-cycle pulses.
    pub clean: f64,
    /// Unsettled seeks, all plants.
    pub unsettled: usize,
    /// Limit-cycle pulses, all plants.
    pub limit_cycle_pulses: usize,
    /// Fine steps that landed, all plants.
    pub fine_steps: usize,
    /// Plants whose safety layer latched a stop (calibration's refusals included).
    pub safe_stops: usize,
    /// Unsettled seeks the servo reported as seek errors, all plants.
    pub unsettled_reported: usize,
    /// Settled seeks the servo reported all the same, all plants.
    pub settled_reported: usize,
    /// Plants failing with nothing flagged ([`SeekBrief::unflagged`]).
    pub unflagged_failures: usize,
}

impl SeekFamilyStats {
    /// Over `briefs`.
    pub fn of<'a>(briefs: impl Iterator<Item = &'a SeekBrief> + Clone) -> Self {
        let all: Vec<f64> = briefs
            .clone()
            .flat_map(|b| b.ratios.iter().map(|r| r.1))
            .collect();
        let long: Vec<f64> = briefs
            .clone()
            .flat_map(|b| b.ratios.iter())
            .filter(|r| r.0.abs() >= LONG_SEEK_TRACKS)
            .map(|r| r.1)
            .collect();
        let n = briefs.clone().count();
        Self {
            ratio: Quantiles::of(&all),
            ratio_long_median: Quantiles::of(&long).median,
            clean: briefs.clone().filter(|b| b.clean()).count() as f64 / n.max(1) as f64,
            unsettled: briefs.clone().map(|b| b.unsettled).sum(),
            limit_cycle_pulses: briefs.clone().map(|b| b.limit_cycle_pulses).sum(),
            fine_steps: briefs.clone().map(|b| b.fine_steps).sum(),
            safe_stops: briefs.clone().filter(|b| b.safe_stop.is_some()).count(),
            unsettled_reported: briefs.clone().map(|b| b.unsettled_reported).sum(),
            settled_reported: briefs.clone().map(|b| b.settled_reported).sum(),
            unflagged_failures: briefs.filter(|b| b.unflagged()).count(),
        }
    }
}

/// The nominal sled under both controllers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NominalSeeks {
    /// The seek mode.
    pub seek: SeekSummary,
    /// Today's reference-following servo.
    pub reference: SeekSummary,
    /// Reference-following median access over the seek mode's.
    pub speedup: f64,
}

/// Everything `control-family --seek` measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SeekFamilyReport {
    /// The family.
    pub family: FamilyOptions,
    /// The seek schedule of every plant.
    pub schedule: SeekOptions,
    /// Per plant.
    pub plants: Vec<SeekPlantResult>,
    /// The seek mode over the family.
    pub seek: SeekFamilyStats,
    /// Today's reference-following servo over the family.
    pub reference: SeekFamilyStats,
    /// The nominal sled.
    pub nominal: NominalSeeks,
}

/// The two controllers of a plant, designed from `family.prior` only.
fn controllers(
    params: &TwinParams,
    family: &FamilyOptions,
) -> Result<(SeekController, SeekController), String> {
    let design = design_from_prior(params, family.prior_for(&params.plant))?;
    let seek = if family.exact_prior {
        seek_design(design).with_trusted_prior()
    } else {
        seek_design(design)
    };
    Ok((
        SeekController::Seek(seek),
        SeekController::Reference(design),
    ))
}

/// The schedule of the family's runs: `family.seeks` seeks seeded by `family.run_seed`, the
/// distances and dwell of `schedule`.
fn family_schedule(family: &FamilyOptions, schedule: &SeekOptions) -> SeekOptions {
    SeekOptions {
        seeks: family.seeks,
        seed: family.run_seed,
        frozen: family.frozen,
        calibrate: family.calibrate,
        ..*schedule
    }
}

/// Runs plant `index` of the family under both controllers.
///
/// # Errors
/// A design, schedule or run error, naming the plant.
pub fn evaluate_plant(
    family: &FamilyOptions,
    schedule: &SeekOptions,
    index: u64,
) -> Result<SeekPlantResult, String> {
    let factors = family.ranges.draw(family.seed, index);
    let params = factors.twin(&TwinParams::default());
    let at = |e: String| format!("plant {index} ({}): {e}", factors.label());
    let schedule = family_schedule(family, schedule);
    let (seek, reference) = controllers(&params, family).map_err(at)?;
    let brief = |c: &SeekController| {
        run_seeks(&params, c, &schedule)
            .map(|r| SeekBrief::of(&r.summary, &r.rows))
            .map_err(at)
    };
    let longest_bound_ms =
        crate::twin::min_time_seek(&params.plant, 0.0, i64::from(schedule.max_tracks))
            .map_or(f64::NAN, |b| b.time_s * 1e3);
    Ok(SeekPlantResult {
        index,
        factors,
        longest_bound_ms,
        seek: brief(&seek)?,
        reference: brief(&reference)?,
    })
}

/// The nominal sled (`TwinParams::default()`) under both controllers designed from
/// `family.prior`.
///
/// # Errors
/// A design, schedule or run error.
pub fn evaluate_nominal(
    family: &FamilyOptions,
    schedule: &SeekOptions,
) -> Result<NominalSeeks, String> {
    let params = TwinParams::default();
    let schedule = family_schedule(family, schedule);
    let (seek, reference) = controllers(&params, family)?;
    let seek = run_seeks(&params, &seek, &schedule)?.summary;
    let reference = run_seeks(&params, &reference, &schedule)?.summary;
    Ok(NominalSeeks {
        speedup: reference.access_ms.median / seek.access_ms.median,
        seek,
        reference,
    })
}

/// Runs the family's seek evaluation in parallel, ticking `progress` once per plant.
///
/// # Errors
/// The first plant's error.
pub fn evaluate(
    family: &FamilyOptions,
    schedule: &SeekOptions,
    progress: Option<&ProgressBar>,
) -> Result<SeekFamilyReport, String> {
    let plants: Vec<SeekPlantResult> = (0..family.plants)
        .into_par_iter()
        .map(|i| {
            let r = evaluate_plant(family, schedule, i);
            if let Some(p) = progress {
                p.inc(1);
            }
            r
        })
        .collect::<Result<_, _>>()?;
    Ok(SeekFamilyReport {
        family: family.clone(),
        schedule: family_schedule(family, schedule),
        seek: SeekFamilyStats::of(plants.iter().map(|p| &p.seek)),
        reference: SeekFamilyStats::of(plants.iter().map(|p| &p.reference)),
        nominal: evaluate_nominal(family, schedule)?,
        plants,
    })
}

/// The summary table: issue 14's measures for both controllers.
pub fn stats_table(r: &SeekFamilyReport) -> String {
    let row = |name: &str, s: &SeekFamilyStats, n: &SeekSummary| {
        format!(
            "| {name} | {:.2} | {:.2} | {:.2} | {:.1} % | {} ({} reported; settled but reported {}) | {} | {} | {} | {} | {:.1} |\n",
            s.ratio.median,
            s.ratio.p95,
            s.ratio_long_median,
            100.0 * s.clean,
            s.unsettled,
            s.unsettled_reported,
            s.settled_reported,
            s.limit_cycle_pulses,
            s.fine_steps,
            s.safe_stops,
            s.unflagged_failures,
            n.access_ms.median
        )
    };
    format!(
        "| controller | access / bound median | p95 | median, ≥ {LONG_SEEK_TRACKS} tracks | plants with 0 unsettled, 0 pulses | unsettled | limit-cycle pulses | fine steps (landed; not pulses) | safe stops | failing plants, nothing flagged (no stop; a seek unsettled or with a pulse and not reported) | nominal sled: median access (ms) |\n|---|---|---|---|---|---|---|---|---|---|---|\n{}{}\nNominal sled: the seek mode's median access is {:.2}× shorter than the reference-following servo's.\n",
        row("seek mode (time-optimal seeks)", &r.seek, &r.nominal.seek),
        row(
            "reference-following (30 ms S-curve)",
            &r.reference,
            &r.nominal.reference
        ),
        r.nominal.speedup
    )
}

/// The per-plant Markdown table.
pub fn plant_table(r: &SeekFamilyReport) -> String {
    let mut t = String::from(
        "| plant | factors | longest bound (ms) | seek: access median (ms), ratio median / p95 / ≥ 200, unsettled/pulses, safe stop | reference-following: the same |\n|---|---|---|---|---|\n",
    );
    let cell = |b: &SeekBrief| {
        format!(
            "{:.1}, {:.2} / {:.2} / {:.2}, {}/{}{}",
            b.access_median_ms,
            b.ratio_median,
            b.ratio_p95,
            b.ratio_long_median,
            b.unsettled,
            b.limit_cycle_pulses,
            b.safe_stop.map_or(String::new(), |st| format!(
                ", stop: {} in seek {}",
                st.reason, st.seek
            ))
        )
    };
    for p in &r.plants {
        t += &format!(
            "| {} | {} | {:.1} | {} | {} |\n",
            p.index,
            p.factors.label(),
            p.longest_bound_ms,
            cell(&p.seek),
            cell(&p.reference)
        );
    }
    t
}
