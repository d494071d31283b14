//! The study's compact comparison table (Markdown) and its header, printed by `sledid study` and
//! `sledid demo`: the linear models, then the nonlinear ones with their change against their
//! linear counterpart and the paper's 9 % / 13 % beside.
//!
//! RMS figures are labelled with the study's y unit ([`Study::y_unit_name`]: quanta only on the
//! twin or when the user names it so). The findings.md columns — reference figures of a simulated
//! sled — appear only when the study carries them, i.e. for the twin; a study of a user's
//! recording has no such columns.

use std::fmt::Write as _;

use super::Study;
use super::results::{ModelReport, NonlinearReport, RateReport};

/// What one table row needs from a linear or a nonlinear model.
struct Row<'a> {
    rms_valid: f64,
    rms_ident: f64,
    pred_valid: Option<f64>,
    poles: &'a [[f64; 2]],
    stable: bool,
    boundary: bool,
    n_params: usize,
    samples: usize,
    overfit: bool,
    change: Option<f64>,
    cv: f64,
    recommended: bool,
}

impl<'a> Row<'a> {
    fn linear(m: &'a ModelReport) -> Self {
        Self {
            rms_valid: m.rms_sim_valid,
            rms_ident: m.rms_sim_ident,
            pred_valid: Some(m.rms_pred_valid),
            poles: &m.poles,
            stable: m.stable,
            boundary: m.at_stability_boundary,
            n_params: m.n_params,
            samples: m.samples_ident,
            overfit: m.overfit_risk,
            change: None,
            cv: m.cv.rms,
            recommended: false,
        }
    }

    fn nonlinear(m: &'a NonlinearReport) -> Self {
        Self {
            rms_valid: m.rms_sim_valid,
            rms_ident: m.rms_sim_ident,
            pred_valid: None,
            poles: &m.poles,
            stable: m.stable,
            boundary: m
                .poles
                .iter()
                .any(|p| p[0].hypot(p[1]) > super::report::BOUNDARY_MODULUS),
            n_params: m.n_params,
            samples: m.samples_ident,
            overfit: m.overfit_risk,
            change: Some(m.change_vs_linear_valid),
            cv: m.cv.rms,
            recommended: false,
        }
    }

    fn of(rate: &'a RateReport, name: &str) -> Option<Self> {
        let mut row = rate
            .model(name)
            .map(Self::linear)
            .or_else(|| rate.nonlinear_model(name).map(Self::nonlinear))?;
        row.recommended = rate.recommended.as_ref().is_some_and(|r| r.model == name);
        Some(row)
    }

    fn rms(&self, v: f64) -> String {
        let mark = if !self.stable {
            " †"
        } else if self.boundary {
            " ‡"
        } else {
            ""
        };
        let mut s = if v.abs() < 1e4 {
            format!("{v:.2}{mark}")
        } else {
            format!("{v:.1e}{mark}")
        };
        if v == self.rms_valid {
            if let Some(c) = self.change {
                let _ = write!(s, " ({:+.0} %)", 100.0 * c);
            }
            if self.recommended {
                s.push_str(" ★");
            }
        }
        s
    }
}

impl Study {
    /// What was studied, in two lines.
    pub fn header(&self) -> String {
        let (ts, dec) = (&self.at_ts, &self.decimated_by_2);
        format!(
            "identification: {} {} ({} samples, ÷2: {})\n\
             validation:     {} {} ({} samples, ÷2: {}); Ts = {:.4} ms; centring: {:?}",
            self.ident_source,
            self.ident_segment,
            ts.samples_ident,
            dec.samples_ident,
            self.valid_source,
            self.valid_segment,
            ts.samples_valid,
            dec.samples_valid,
            self.ts_s * 1e3,
            self.centring
        )
    }

    /// The compact comparison table (Markdown), with footnotes.
    pub fn table(&self) -> String {
        let num = |x: Option<f64>| x.map_or_else(|| "–".to_owned(), |v| format!("{v:.2}"));
        let pred = |x: Option<f64>| x.map_or_else(|| "= sim".to_owned(), |v| format!("{v:.2}"));
        let findings = self.reference.iter().any(|r| {
            r.findings_rms_sim_valid_ts.is_some() || r.findings_rms_sim_valid_dec2.is_some()
        });
        let unit = &self.y_unit_name;
        let mut t = format!(
            "| model (RMS in {unit}) | sim RMS valid, Ts | sim RMS valid, ÷2 {}\
             | pred RMS valid, Ts | pred RMS valid, ÷2 | sim RMS ident, Ts | CV RMS ident (Ts, ÷2) \
             | poles at Ts | d / N (Ts, ÷2) | paper |\n\
             |---|---|---|{}---|---|---|---|---|---|---|\n",
            if findings {
                "| twin's reference (findings.md) Ts | twin's reference (findings.md) ÷2 "
            } else {
                ""
            },
            if findings { "---|---|" } else { "" },
        );
        for r in &self.reference {
            let (Some(a), Some(b)) = (
                Row::of(&self.at_ts, r.model),
                Row::of(&self.decimated_by_2, r.model),
            ) else {
                continue;
            };
            let poles: Vec<String> = a
                .poles
                .iter()
                .filter(|p| p[1] >= 0.0)
                .map(|p| {
                    if p[1] == 0.0 {
                        format!("{:.3}", p[0])
                    } else {
                        format!("{:.3}±{:.3}i", p[0], p[1].abs())
                    }
                })
                .collect();
            let flag = |r: &Row| if r.overfit { "§" } else { "" };
            let reference = if findings {
                format!(
                    " {} | {} |",
                    num(r.findings_rms_sim_valid_ts),
                    num(r.findings_rms_sim_valid_dec2)
                )
            } else {
                String::new()
            };
            let _ = writeln!(
                t,
                "| {} | {} | {} |{} {} | {} | {} | {:.2}, {:.2} | {} | {}/{}{}, {}/{}{} | {} |",
                r.model,
                a.rms(a.rms_valid),
                b.rms(b.rms_valid),
                reference,
                pred(a.pred_valid),
                pred(b.pred_valid),
                a.rms(a.rms_ident),
                a.cv,
                b.cv,
                poles.join(", "),
                a.n_params,
                a.samples,
                flag(&a),
                b.n_params,
                b.samples,
                flag(&b),
                r.paper
            );
        }
        let _ = write!(
            t,
            "\nRMS in {unit} over samples 2..N of each segment; (±x %): a nonlinear model's \
             validation RMS against its linear start (OE1 for NOE-Hammerstein1, NOE1-yu, Wiener1; \
             OE2 for NOE221, Friction2); the paper: −9 % (eq. 5 vs OE1), −13 % (eq. 7 vs OE2). \
             † unstable model: its simulation diverges. ‡ a pole at |p| > 0.999 (on the stability \
             constraint). § fewer than 10 identification samples per parameter: may fit noise. \
             CV RMS ident: the identification-only criterion, simulation RMS on held-out parts of \
             the identification segment (each model refitted on the rest)."
        );
        if findings {
            t.push_str(
                " twin's reference: shared/findings.md, validation simulation RMS in quanta of a \
                 float64 study of a simulated friction-dominated sled — reference values for the \
                 twin, not figures of this run.",
            );
        }
        t.push('\n');
        for rate in [&self.at_ts, &self.decimated_by_2] {
            if let Some(r) = &rate.recommended {
                let _ = writeln!(
                    t,
                    "★ recommended at {}: {} (CV RMS {:.3}; best linear {} {:.3}; a nonlinear \
                     model must be {:.0} % lower than the best linear one)",
                    rate.label,
                    r.model,
                    r.value,
                    r.best_linear,
                    r.best_linear_value,
                    100.0 * r.margin
                );
            }
        }
        t
    }
}
