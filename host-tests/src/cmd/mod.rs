//! The CLI's commands, one module each: its arguments and its `run`.

pub mod control;
pub mod control_family;
pub mod demo;
pub mod pacing;
pub mod replay;
pub mod seek;
pub mod soak;
pub mod study;
pub mod twin;

/// `--prior exact`: each plant's servo designed from that plant itself (`seek`, `control-family`).
fn is_exact_prior(prior: Option<&std::path::PathBuf>) -> bool {
    prior.is_some_and(|p| p.as_os_str() == "exact")
}
