//! The figures of the control commands: `sledid control`'s step responses (the start of a few
//! seeks, error and reference relative to the target, the drive, the scheduled controller's
//! region shaded behind) and `sledid control-family`'s per-plant settling ratios and events.
//!
//! Text uses plotters' `ab_glyph` backend with the DejaVu Sans font embedded by `dejavu` (no
//! system fonts), as the study's figures do.

use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

use super::family_eval::{FamilyReport, PlantResult, RunBrief};
use super::run::ControlRun;
use sledid::control::Region;

const FONT: &str = "sans-serif";
/// Shown window after the seek's start, ms.
const WINDOW_MS: f64 = 60.0;
/// Error axis, quanta.
const E_RANGE: f64 = 12.0;
/// Drive axis, V.
const U_RANGE: f64 = 0.4;

fn font_ready() -> bool {
    static READY: OnceLock<bool> = OnceLock::new();
    *READY.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
    })
}

fn shade(region: Region) -> RGBAColor {
    match region {
        Region::Seek => RGBColor(120, 170, 230).mix(0.25),
        Region::Settle => RGBColor(240, 170, 60).mix(0.30),
        Region::Hold => RGBColor(90, 190, 90).mix(0.30),
    }
}

/// Draws the first `count` seeks of `run` into `path` (PNG, two columns).
///
/// # Errors
/// The font or the drawing backend failed.
pub fn plot_steps(run: &ControlRun, path: &Path, count: usize) -> Result<(), String> {
    if !font_ready() {
        return Err("the embedded DejaVu Sans font could not be loaded".to_owned());
    }
    let draw = || -> Result<(), Box<dyn std::error::Error>> {
        let rows = count.div_ceil(2).max(1) as u32;
        let root = BitMapBackend::new(path, (1200, 380 * rows)).into_drawing_area();
        root.fill(&WHITE)?;
        let panels = root.split_evenly((rows as usize, 2));
        let twin = &run.twin;
        let ts_ms = twin.params().plant.ts_s * 1e3;
        let q = twin.params().plant.quantum_m;
        for (k, (seek, area)) in twin.seeks().iter().zip(&panels).take(count).enumerate() {
            let end = seek.end_index.unwrap_or(twin.samples().len());
            let n = ((WINDOW_MS / ts_ms) as usize).min(end - seek.start_index);
            let window = twin
                .samples()
                .get(seek.start_index..seek.start_index + n)
                .unwrap_or(&[]);
            let target = seek.target_counts as f64;
            let t = |i: usize| i as f64 * ts_ms;
            let stats = twin.seek_stats();
            let settle = stats
                .get(k)
                .and_then(|s| s.settling_time_s)
                .map_or("never".to_owned(), |s| format!("{:.1} ms", s * 1e3));
            let step = stats.get(k).map_or(0, |s| s.step_counts);
            let mut c = ChartBuilder::on(area)
                .caption(
                    format!("seek {k}: {step:+} tracks, settled at {settle}"),
                    (FONT, 17),
                )
                .margin(8)
                .x_label_area_size(34)
                .y_label_area_size(48)
                .right_y_label_area_size(48)
                .build_cartesian_2d(0.0..t(n), -E_RANGE..E_RANGE)?
                .set_secondary_coord(0.0..t(n), -U_RANGE..U_RANGE);
            c.configure_mesh()
                .x_desc("time from the seek's start (ms)")
                .y_desc("y − target, r − target (quanta)")
                .label_style((FONT, 12))
                .draw()?;
            c.configure_secondary_axes()
                .y_desc("u (V)")
                .label_style((FONT, 12))
                .draw()?;
            // Region shading: one rectangle per run of equal regions.
            if let Some(regions) = run.trace.get(seek.start_index..seek.start_index + n) {
                let mut from = 0;
                for i in 1..=regions.len() {
                    let boundary = i == regions.len()
                        || regions.get(i).map(|r| r.0) != regions.get(from).map(|r| r.0);
                    if boundary {
                        if let Some((region, _)) = regions.get(from) {
                            c.draw_series(std::iter::once(Rectangle::new(
                                [(t(from), -E_RANGE), (t(i), E_RANGE)],
                                shade(*region).filled(),
                            )))?;
                        }
                        from = i;
                    }
                }
            }
            let clip = |v: f64| v.clamp(-E_RANGE, E_RANGE);
            c.draw_series(DashedLineSeries::new(
                window
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (t(i), clip(s.r_m / q - target))),
                5,
                4,
                GREEN.stroke_width(2),
            ))?
            .label("r − target")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], GREEN));
            c.draw_series(LineSeries::new(
                window
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (t(i), clip(s.y_counts as f64 - target))),
                BLACK.stroke_width(2),
            ))?
            .label("y − target")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK));
            c.draw_secondary_series(LineSeries::new(
                window
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (t(i), s.u_v.clamp(-U_RANGE, U_RANGE))),
                RGBColor(0, 114, 178),
            ))?
            .label("u (right axis, clipped)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], RGBColor(0, 114, 178)));
            c.configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .label_font((FONT, 12))
                .position(SeriesLabelPosition::LowerRight)
                .draw()?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("{}: {e}", path.display()))
}

/// One controller's points in the family figure: its name, colour and where its brief is.
type Series = (&'static str, RGBColor, fn(&PlantResult) -> &RunBrief);

/// The family's figure (`sledid control-family`): per plant, ordered by the servo's ratio, the
/// median settling of the servo, the frozen servo and the servo without friction identification
/// over the baseline's (log scale, the 0.7 target dashed); below, each one's limit-cycle pulses
/// plus unsettled seeks, plus one (log scale, clipped at 200).
///
/// # Errors
/// The font or the drawing backend failed.
pub fn plot_family(report: &FamilyReport, path: &Path) -> Result<(), String> {
    if !font_ready() {
        return Err("the embedded DejaVu Sans font could not be loaded".to_owned());
    }
    let draw = || -> Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(path, (1200, 900)).into_drawing_area();
        root.fill(&WHITE)?;
        let (top, bottom) = root.split_vertically(560);
        let mut order: Vec<&PlantResult> = report.plants.iter().collect();
        order.sort_by(|a, b| a.ratio_to_baseline().total_cmp(&b.ratio_to_baseline()));
        let n = order.len() as f64;
        let ratio = |b: &RunBrief, p: &PlantResult| {
            (b.settling_median_ms / p.baseline.settling_median_ms).clamp(0.03, 30.0)
        };
        let series: [Series; 3] = [
            ("servo (identified)", RGBColor(0, 114, 178), |p| {
                &p.identified
            }),
            ("frozen at the prior", RGBColor(230, 159, 0), |p| &p.frozen),
            (
                "linear-only (friction not identified)",
                RGBColor(0, 158, 115),
                |p| &p.linear_only,
            ),
        ];
        let mut c = ChartBuilder::on(&top)
            .caption(
                format!(
                    "{} plants of family seed {}, {} seeks each: median settling over the baseline's",
                    report.plants.len(),
                    report.options.seed,
                    report.options.seeks
                ),
                (FONT, 18),
            )
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..n, (0.03..30.0).log_scale())?;
        c.configure_mesh()
            .x_desc("plant, ordered by the servo's ratio")
            .y_desc("median settling / baseline's")
            .label_style((FONT, 12))
            .draw()?;
        c.draw_series(DashedLineSeries::new(
            [(0.0, 0.7), (n, 0.7)],
            6,
            4,
            BLACK.stroke_width(1),
        ))?
        .label("0.7 (target)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK));
        for (name, color, pick) in series {
            c.draw_series(order.iter().enumerate().map(|(i, p)| {
                Circle::new((i as f64 + 0.5, ratio(pick(p), p)), 3, color.filled())
            }))?
            .label(name)
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, color.filled()));
        }
        c.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((FONT, 12))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()?;
        let mut e = ChartBuilder::on(&bottom)
            .caption(
                "limit-cycle pulses + unsettled seeks per plant, plus one (log scale)",
                (FONT, 16),
            )
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..n, (0.9..200.0).log_scale())?;
        e.configure_mesh()
            .x_desc("plant, same order")
            .y_desc("events + 1")
            .label_style((FONT, 12))
            .draw()?;
        let baseline: [Series; 1] = [("baseline", RGBColor(120, 120, 120), |p| &p.baseline)];
        for (name, color, pick) in baseline.into_iter().chain(series) {
            e.draw_series(order.iter().enumerate().map(|(i, p)| {
                let b = pick(p);
                let events = (b.limit_cycle_pulses + b.unsettled).min(199) as f64 + 1.0;
                Circle::new((i as f64 + 0.5, events), 3, color.filled())
            }))?
            .label(name)
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, color.filled()));
        }
        e.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((FONT, 12))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()?;
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("{}: {e}", path.display()))
}
