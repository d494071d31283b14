//! `sledid pacing-probe`: can this machine pace a replay at Ts? Spin on the clock doing nothing
//! else and count the gaps.

/// `sledid pacing-probe`.
#[derive(clap::Args)]
pub struct Args {
    /// How long to spin, s.
    #[arg(long, default_value_t = 60.0)]
    pub seconds: f64,
    /// The sampling period to judge against, s.
    #[arg(long, default_value_t = 0.000455)]
    pub ts: f64,
}

/// Runs the command.
///
/// # Errors
/// Non-positive arguments.
pub fn run(a: &Args) -> Result<(), String> {
    pacing_probe(a.seconds, a.ts)
}

fn pacing_probe(seconds: f64, ts: f64) -> Result<(), String> {
    if !(seconds.is_finite() && seconds > 0.0 && ts.is_finite() && ts > 0.0) {
        return Err(format!(
            "pacing-probe: --seconds ({seconds}) and --ts ({ts}) must be positive"
        ));
    }
    let r = sledid_host::pacing::probe(seconds, ts);
    let mut j = serde_json::to_value(r).map_err(|e| e.to_string())?;
    if let Some(o) = j.as_object_mut() {
        o.insert(
            "gaps_over_ts_per_minute".into(),
            r.gaps_over_ts_per_minute().into(),
        );
    }
    println!(
        "{}",
        serde_json::to_string_pretty(&j).map_err(|e| e.to_string())?
    );
    Ok(())
}
