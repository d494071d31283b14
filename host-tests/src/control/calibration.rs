//! Power-on calibration over the plant family: each plant's servo (designed from the prior)
//! calibrates on its twin before any seek; what it found against the plant's true velocity model
//! ([`physical_model`]) and Coulomb level, and what it cost (samples, travel).

use rayon::prelude::*;
use serde::Serialize;
use sledid::servo::CalibrationDesign;

use super::design::{design_from_prior, identifier_design, physical_model};
use super::family::PlantFactors;
use super::family_eval::FamilyOptions;
use super::run::{CalibrationOutcome, ScheduledLoop};
use super::seek::run::seek_design;
use crate::twin::{PlantParams, Twin, TwinParams};

/// One plant's calibration against its truth.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CalibrationCheck {
    /// Index in the family.
    pub index: u64,
    /// Its factors.
    pub factors: PlantFactors,
    /// The true velocity model (a, b), quanta per sample per full scale.
    pub true_model: (f64, f64),
    /// The true Coulomb level, fraction of full scale.
    pub true_coulomb_fs: f64,
    /// The calibrated (a, b, u_c mean), or `None` when refused.
    pub found: Option<(f64, f64, f64)>,
    /// The refusal's name.
    pub refusal: Option<&'static str>,
    /// Samples of the experiment.
    pub samples: usize,
    /// Samples to the first seek (with the fit's hand-over).
    pub samples_to_seek: usize,
    /// The furthest the sled went, quanta.
    pub travel_quanta: f64,
    /// The whole outcome (the record, for the float64 reference).
    #[serde(skip)]
    pub outcome: CalibrationOutcome,
}

impl CalibrationCheck {
    /// |b̂/b − 1| (∞ when refused).
    pub fn gain_error(&self) -> f64 {
        self.found.map_or(f64::INFINITY, |(_, b, _)| {
            (b / self.true_model.1 - 1.0).abs()
        })
    }

    /// |û_c/u_c − 1| (∞ when refused).
    pub fn coulomb_error(&self) -> f64 {
        self.found.map_or(f64::INFINITY, |(_, _, c)| {
            (c / self.true_coulomb_fs - 1.0).abs()
        })
    }
}

/// Calibrates the servo designed from `prior` on the twin `params` (noise stream `seed`).
///
/// # Errors
/// A design or twin error.
pub fn calibrate(
    params: &TwinParams,
    prior: &PlantParams,
    design: CalibrationDesign,
    seed: u64,
) -> Result<CalibrationOutcome, String> {
    let d = seek_design(design_from_prior(params, prior)?);
    let mut servo =
        ScheduledLoop::new(&d, &identifier_design(&d))?.with_calibration(Some(design))?;
    let mut twin = Twin::new(params.clone(), seed).map_err(|e| e.to_string())?;
    servo
        .calibrate(&mut twin)
        .ok_or_else(|| "no calibration configured".to_owned())
}

/// Every plant of `family` calibrated (in parallel), plant `i` with noise seed `i`.
///
/// # Errors
/// The first plant's design or twin error.
pub fn family(family: &FamilyOptions) -> Result<Vec<CalibrationCheck>, String> {
    (0..family.plants)
        .into_par_iter()
        .map(|index| {
            let factors = family.ranges.draw(family.seed, index);
            let params = factors.twin(&TwinParams::default());
            let p = &params.plant;
            let out = calibrate(&params, &family.prior, CalibrationDesign::default(), index)?;
            Ok(CalibrationCheck {
                index,
                factors,
                true_model: physical_model(p),
                true_coulomb_fs: p.coulomb_n / p.force_per_volt_n_per_v / p.u_max_v,
                found: out.model.map(|m| {
                    (
                        f64::from(m.a),
                        f64::from(m.b()),
                        f64::from(m.coulomb_mean_fs()),
                    )
                }),
                refusal: out.refusal.map(sledid::servo::Refusal::name),
                samples: out.experiment_samples,
                samples_to_seek: out.samples,
                travel_quanta: out.travel_quanta,
                outcome: out,
            })
        })
        .collect()
}
