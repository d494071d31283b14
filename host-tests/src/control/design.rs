//! The scheduled controller's design from a prior plant: the prior's physical velocity model, its
//! Coulomb friction as the starting input compensation, the twin's baseline PID as the fallback.

use sledid::control::{InverseInputMap, ScheduledDesign};
use sledid::ident::step::IdentifierDesign;
use sledid::servo::{ServoDesign, VELOCITY_N};

use crate::reference::control::baseline_design;
use crate::twin::{PlantParams, TwinParams};

/// [`sledid::servo::velocity_identifier`] from the design's prior and the Coulomb level of its
/// compensation ([`ServoDesign::new`]), the one the firmware runs too.
pub fn identifier_design(design: &ScheduledDesign) -> IdentifierDesign<VELOCITY_N> {
    ServoDesign::new(*design).velocity
}

/// The velocity model (a, b) of a plant from its physics (viscous pole, drive gain; friction
/// ignored): `a = e^{−b_v·Ts/m}`, `b = (1 − a)·k_f·u_fs/b_v·Ts/q` quanta per sample per full scale.
pub fn physical_model(plant: &PlantParams) -> (f64, f64) {
    let a = (-plant.viscous_n_s_per_m * plant.ts_s / plant.mass_kg).exp();
    let v_fs_m_per_s = plant.force_per_volt_n_per_v * plant.u_max_v / plant.viscous_n_s_per_m;
    (a, (1.0 - a) * v_fs_m_per_s * plant.ts_s / plant.quantum_m)
}

/// The scheduled design for a twin, tuned on the default sled ([`PlantParams::default`]):
/// [`scheduled_design_for`] with that sled as the nominal plant.
pub fn scheduled_design(params: &TwinParams) -> Result<ScheduledDesign, String> {
    scheduled_design_for(params, &PlantParams::default())
}

/// The scheduled design for the twin `params`, tuned on the plant `nominal` in the units of
/// `params`: [`design_from_prior`] with the prior's quantum replaced by the plant's (the
/// controller knows its sensor's resolution; on a perturbed plant it still believes the nominal
/// mass and friction).
pub fn scheduled_design_for(
    params: &TwinParams,
    nominal: &PlantParams,
) -> Result<ScheduledDesign, String> {
    let prior = PlantParams {
        quantum_m: params.plant.quantum_m,
        ..nominal.clone()
    };
    design_from_prior(params, &prior)
}

/// The scheduled design for running on the twin `params`, designed from the plant `prior` only
/// (`sledid control --prior`, the family): the prior's physical velocity model (its quantum
/// included: a sensor finer or coarser than the prior's is one more thing the identifier finds
/// out), its Coulomb friction as the starting input compensation, the baseline PID of `params`
/// as the fallback. Of `params` only the sampling period and the rail are used (the loop's
/// electronics), never the plant's mass, friction, force constant or quantum.
///
/// # Errors
/// A prior whose friction map cannot be built.
pub fn design_from_prior(
    params: &TwinParams,
    prior: &PlantParams,
) -> Result<ScheduledDesign, String> {
    let p = &params.plant;
    let prior = PlantParams {
        ts_s: p.ts_s,
        u_max_v: p.u_max_v,
        ..prior.clone()
    };
    let mut d = ScheduledDesign::new(baseline_design(&params.controller, p.ts_s, p.u_max_v));
    d.prior_model = Some(physical_model(&prior));
    let coulomb_fs = prior.coulomb_n / prior.force_per_volt_n_per_v / prior.u_max_v;
    d.compensation = if coulomb_fs > f64::from(sledid::control::scheduled::MIN_COULOMB_FS) {
        Some(InverseInputMap::coulomb(coulomb_fs, 0.9, 0.05).map_err(|e| e.to_string())?)
    } else {
        None
    };
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The design never reads the plant it runs on: a heavy, sticky, coarse, strong plant gives
    /// the same design as the nominal one from the same prior; a different prior does change it.
    #[test]
    fn the_design_comes_from_the_prior_only() {
        let nominal = TwinParams::default();
        let mut other = nominal.clone();
        other.plant.mass_kg *= 3.0;
        other.plant.coulomb_n *= 2.0;
        other.plant.quantum_m *= 2.0;
        other.plant.force_per_volt_n_per_v *= 1.7;
        let prior = PlantParams::default();
        let a = design_from_prior(&nominal, &prior).unwrap();
        let b = design_from_prior(&other, &prior).unwrap();
        assert_eq!(a, b);
        let heavy_prior = other.plant.clone();
        let c = design_from_prior(&nominal, &heavy_prior).unwrap();
        assert_ne!(a.prior_model, c.prior_model);
        assert_ne!(a.compensation, c.compensation);
    }
}
