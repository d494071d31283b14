//! The sleds the PIL closes the loop around (`cargo xtask pil`): the nominal sled, the plant
//! family's four corners (fastest and slowest in quanta, with the most friction or none:
//! [`Corner`]) and sleds drawn from the family, each with its fault plan. The firmware's words
//! stay those of [`super::design`] (designed from the nominal sled): on every other sled the
//! product calibrates at power-on, as it would on a drive it was never tuned on.

use crate::control::family::{Corner, FamilyRanges};
use crate::twin::{ReferenceProfile, TwinParams};

use super::{Faults, seek_options};

/// Seed of the family the drawn sleds come from.
pub const FAMILY_SEED: u64 = 1;

/// The nominal sled and the four corners come first; the rest are drawn.
pub const NAMED_PLANTS: usize = 1 + Corner::ALL.len();

/// One sled of the PIL run.
#[derive(Clone, Debug)]
pub struct PilPlant {
    /// `nominal`, the corner's name, or `family-1/i` (plant i of family seed 1).
    pub name: String,
    /// The twin: the sled and its seek commands.
    pub params: TwinParams,
    /// Its faults: the nominal sled the tests' plan ([`Faults::plan`]), the others
    /// [`Faults::generic`].
    pub faults: Faults,
}

/// The first `count` sleds of the PIL run (the nominal sled, the corners, then plants 0, 1, … of
/// family [`FAMILY_SEED`]), `seeks` seek commands each.
///
/// # Errors
/// A sled the seek schedule refuses (named).
pub fn plants(count: usize, seeks: u32) -> Result<Vec<PilPlant>, String> {
    let ranges = FamilyRanges::default();
    let base = TwinParams::default();
    let named = std::iter::once(("nominal".to_owned(), base.plant.clone())).chain(
        Corner::ALL
            .into_iter()
            .map(|c| (c.name().to_owned(), ranges.corner(c).plant())),
    );
    let drawn = (0..).map(|i| {
        (
            format!("family-{FAMILY_SEED}/{i}"),
            ranges.draw(FAMILY_SEED, i).plant(),
        )
    });
    named
        .chain(drawn)
        .take(count)
        .enumerate()
        .map(|(i, (name, plant))| {
            let sled = TwinParams {
                plant,
                ..base.clone()
            };
            let params = seek_options(seeks)
                .twin_params(&sled, ReferenceProfile::Step)
                .map_err(|e| format!("PIL sled {name}: {e}"))?;
            let faults = if i == 0 {
                Faults::plan()
            } else {
                Faults::generic(i)
            };
            Ok(PilPlant {
                name,
                params,
                faults,
            })
        })
        .collect()
}
