//! The model choice: a linear model or one of the paper's nonlinear ones, each with its float64
//! twin ([`super::reference`]) and its units, handed to the per-sample loop ([`super::run`]).

use std::path::Path;

use sledid::Normalisation;
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::nonlinear::{InputRanges, NonlinearDesign, NonlinearStructure};
use sledid::ident::rls::RlsDesign;

use super::reference::{LinearReference, NonlinearReference};
use super::run::replay_model;
use super::{Normalise, Rate, ReplaySpec, ReplaySummary, replay, units};
use crate::reference::linear::LinearF64;
use crate::reference::nonlinear::NonlinearF64;
use crate::reference::units::{ModelKind, to_normalised};

/// A linear model of `spec`'s structure and order, in the user's units unless `spec` normalises.
pub(super) fn replay_linear<const N: usize>(
    file: &Path,
    spec: &ReplaySpec,
    out: &Path,
) -> Result<ReplaySummary, String> {
    let units = units(file, spec, false)?;
    let norm = units.norm;
    let mut model = LinearDesign::<N>::new(spec.structure, spec.order.0, spec.order.1);
    model.rls = normalised_rls(spec.rls, norm);
    let reference = LinearReference {
        model: LinearF64::new(&model),
        na: spec.order.0,
    };
    let label = format!(
        "{:?}({},{}) conditioning {:?}",
        spec.structure, spec.order.0, spec.order.1, spec.conditioning
    );
    let kind = ModelKind::Linear { na: spec.order.0 };
    replay_model(file, spec, out, model, reference, label, (units, kind))
}

/// The RLS settings in signal units (dead zone, outlier gate) moved into the normalised units.
fn normalised_rls(mut rls: RlsDesign, norm: Normalisation) -> RlsDesign {
    rls.dead_zone /= norm.y_factor();
    rls.outlier_threshold /= norm.y_factor();
    rls
}

/// One of the paper's nonlinear models, in normalised units, started from the linear OE model of
/// its order (`spec.nonlinear_init`, or identified first by a linear replay into
/// `out/linear-init`).
pub(super) fn replay_nonlinear<const N: usize>(
    file: &Path,
    spec: &ReplaySpec,
    out: &Path,
    structure: NonlinearStructure,
) -> Result<ReplaySummary, String> {
    let na = structure.na();
    let units = units(file, spec, true)?;
    let norm = units.norm;
    let (linear, ranges) = match &spec.nonlinear_init {
        Some(l) => (to_normalised(ModelKind::Linear { na }, l, norm), None),
        None => {
            let mut first = spec.clone();
            first.nonlinear = None;
            first.structure = Structure::OutputErrorPredictionError;
            first.order = (na, na);
            first.rate = Rate::Max;
            first.progress = false;
            first.normalise = Normalise::Fixed(units);
            let dir = out.join("linear-init");
            let s = replay(file, &first, &dir)?;
            (s.theta_normalised, Some(s.ranges))
        }
    };
    let ranges = ranges.unwrap_or(InputRanges {
        u: 1.0,
        y: 10.0,
        dy: 1.0,
    });
    let mut model = NonlinearDesign::<N>::from_linear(structure, &linear, ranges);
    model.rls = normalised_rls(spec.rls, norm);
    let reference = NonlinearReference {
        model: NonlinearF64::new(&model),
        structure,
    };
    let label = format!(
        "{} from OE{na} {:?}, conditioning {:?}",
        structure.name(),
        linear,
        spec.conditioning
    );
    let kind = ModelKind::Nonlinear(structure);
    replay_model(file, spec, out, model, reference, label, (units, kind))
}
