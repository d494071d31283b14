//! The paper's protocol on a sled-twin recording: identification on the end of one step
//! response, validation on the end of another (Section 4: "a second data set from a similar step
//! response", about 100 samples each).
//!
//! For seek k the window starts at the first sample at which the measured output has reached the
//! target (`|target − y| ≤ 1` quantum for the first time, [`SeekStats::first_within_one_s`]) and
//! holds `window` samples. Identification uses seek 0, validation seek 1. The paper's window is
//! the decaying oscillation before the ±1-quantum limit cycle; the twin's baseline loop rings
//! down within a few samples of reaching the target ([`SeekWindow::settling_samples_in_window`]
//! says how many), so most of a 100-sample window is limit cycle.
//!
//! [`SeekStats::first_within_one_s`]: crate::twin::SeekStats::first_within_one_s

use std::path::Path;

use super::results::{SeekWindow, TwinProtocol};
use super::{Segment, Study, StudyError, StudyInput, StudyOptions, run_files};
use crate::twin::{Twin, TwinParams};

/// The paper's segment length, samples.
pub const PAPER_WINDOW: usize = 100;

/// The column mapping of a twin CSV.
pub const TWIN_COLUMNS: &str = "u=u_v,y=y_m,r=r_m,t=t_s";

/// The `window`-sample window of seek `k` (see the module documentation).
pub fn seek_window(twin: &Twin, k: usize, window: usize) -> Result<SeekWindow, StudyError> {
    let ts_s = twin.params().plant.ts_s;
    let stats = twin.seek_stats();
    let missing = |what: &str| StudyError::Usage(format!("twin seek {k}: {what}"));
    let (Some(seek), Some(st)) = (twin.seeks().get(k), stats.get(k)) else {
        return Err(missing("not in the schedule (need at least two seeks)"));
    };
    let to_samples = |t: f64| (t / ts_s).round() as usize;
    let first = st
        .first_within_one_s
        .map(to_samples)
        .ok_or_else(|| missing("never reaches its target"))?;
    let settled = st.settling_time_s.map_or(usize::MAX, to_samples);
    let start = seek.start_index + first;
    let segment = Segment {
        start,
        end: start + window,
    };
    if seek.end_index.is_none_or(|end| segment.end > end) {
        return Err(missing(
            "the window runs past the seek's dwell (use a shorter --twin-window)",
        ));
    }
    Ok(SeekWindow {
        seek: k,
        target_counts: st.target_counts,
        step_counts: st.step_counts,
        segment,
        settling_samples_in_window: settled.saturating_sub(first).min(window),
        overshoot_counts: st.overshoot_counts,
    })
}

/// Generates the twin (default parameters, `seed`), writes `dir/twin.csv` (+ sidecar) and returns
/// the study of it with the paper's protocol.
pub fn twin_input(
    seed: u64,
    window: usize,
    dir: &Path,
    options: StudyOptions,
) -> Result<(StudyInput, TwinProtocol), StudyError> {
    twin_input_with(TwinParams::default(), seed, window, dir, options)
}

/// [`twin_input`] for a twin of any parameters (e.g. `host-tests/plants/well_damped.json`).
pub fn twin_input_with(
    params: TwinParams,
    seed: u64,
    window: usize,
    dir: &Path,
    options: StudyOptions,
) -> Result<(StudyInput, TwinProtocol), StudyError> {
    let twin = Twin::run_baseline(params, seed).map_err(StudyError::Twin)?;
    std::fs::create_dir_all(dir).map_err(|source| StudyError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let csv = dir.join("twin.csv");
    twin.write_csv(&csv).map_err(StudyError::Twin)?;
    let ident = seek_window(&twin, 0, window)?;
    let valid = seek_window(&twin, 1, window)?;
    let input = StudyInput {
        ident_file: csv.clone(),
        valid_file: None,
        columns: TWIN_COLUMNS.to_owned(),
        ts_s: None,
        y_unit: twin.params().plant.quantum_m,
        y_unit_name: Some("quanta".to_owned()),
        u_scale: 1.0,
        ident: ident.segment,
        valid: valid.segment,
        options,
    };
    let protocol = TwinProtocol {
        seed,
        recording: csv.display().to_string(),
        window,
        ident,
        valid,
    };
    Ok((input, protocol))
}

/// [`twin_input`] and the study of it.
pub fn run_twin(
    seed: u64,
    window: usize,
    dir: &Path,
    options: StudyOptions,
) -> Result<Study, StudyError> {
    run_twin_with(TwinParams::default(), seed, window, dir, options)
}

/// [`run_twin`] for a twin of any parameters.
pub fn run_twin_with(
    params: TwinParams,
    seed: u64,
    window: usize,
    dir: &Path,
    options: StudyOptions,
) -> Result<Study, StudyError> {
    let (input, protocol) = twin_input_with(params, seed, window, dir, options)?;
    let mut study = run_files(&input)?;
    let n = protocol.ident.settling_samples_in_window;
    study.notes.push(format!(
        "twin: the identification window holds {n} samples of decaying oscillation before the \
         ±1-quantum limit cycle (the paper's window is mostly decaying oscillation)"
    ));
    study.twin = Some(protocol);
    study.reference = super::report::reference_figures(true);
    Ok(study)
}
