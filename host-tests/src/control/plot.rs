//! The figures of the control commands: `sledid control`'s step responses (the start of a few
//! seeks, error and reference relative to the target, the drive, the scheduled controller's
//! region shaded behind), `sledid control-family`'s per-plant settling ratios and events, and
//! `sledid seek`'s seek time versus distance and step responses.
//!
//! Font and legend box: [`crate::figure`], as the study's figures.

use plotters::prelude::*;
use std::path::Path;

use super::family_eval::{FamilyReport, PlantResult, RunBrief};
use super::run::ControlRun;
use super::seek::family::{SeekBrief, SeekFamilyReport, SeekPlantResult};
use super::seek::{SeekRow, SeekRun};
use crate::figure::{FONT, font_ready, legend};
use sledid::control::Region;

/// Shown window after the seek's start, ms.
const WINDOW_MS: f64 = 60.0;
/// Error axis, quanta.
const E_RANGE: f64 = 12.0;
/// Drive axis, V.
const U_RANGE: f64 = 0.4;

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
            legend(&mut c, SeriesLabelPosition::LowerRight, 12, 0.8)?;
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
        legend(&mut c, SeriesLabelPosition::UpperLeft, 12, 0.8)?;
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
        legend(&mut e, SeriesLabelPosition::UpperLeft, 12, 0.8)?;
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("{}: {e}", path.display()))
}

/// One controller's seeks for [`plot_seek_distance`]: its name and rows.
pub type SeekSeries<'a> = (&'a str, &'a [SeekRow]);

/// Seek time versus distance (`sledid seek`), log-log: each seek's access time per controller
/// (filled; an unsettled seek hollow, at its whole length, a lower bound) and the plant's
/// minimum-time bound from rest (`bound_curve`: distance in tracks, bound in ms).
///
/// # Errors
/// The font or the drawing backend failed.
pub fn plot_seek_distance(
    series: &[SeekSeries<'_>],
    bound_curve: &[(f64, f64)],
    title: &str,
    path: &Path,
) -> Result<(), String> {
    if !font_ready() {
        return Err("the embedded DejaVu Sans font could not be loaded".to_owned());
    }
    let draw = || -> Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(path, (1100, 760)).into_drawing_area();
        root.fill(&WHITE)?;
        let distances = series
            .iter()
            .flat_map(|(_, rows)| rows.iter().map(|r| r.distance_tracks.unsigned_abs() as f64))
            .chain(bound_curve.iter().map(|b| b.0));
        let (d_lo, d_hi) =
            distances.fold((f64::MAX, 1.0_f64), |(lo, hi), d| (lo.min(d), hi.max(d)));
        let times = series
            .iter()
            .flat_map(|(_, rows)| rows.iter().map(|r| r.access_ms))
            .chain(bound_curve.iter().map(|b| b.1))
            .filter(|t| *t > 0.0);
        let (t_lo, t_hi) = times.fold((f64::MAX, 0.1_f64), |(lo, hi), t| (lo.min(t), hi.max(t)));
        let d_lo = (d_lo.min(d_hi) * 0.8).max(0.5);
        let t_lo = (t_lo.min(t_hi) * 0.7).max(0.01);
        let mut c = ChartBuilder::on(&root)
            .caption(title, (FONT, 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (d_lo..d_hi * 1.25).log_scale(),
                (t_lo..t_hi * 1.4).log_scale(),
            )?;
        c.configure_mesh()
            .x_desc("seek distance (tracks)")
            .y_desc("access time (ms): until |y − target| ≤ 1 track for ≥ 10 ms")
            .label_style((FONT, 12))
            .draw()?;
        c.draw_series(LineSeries::new(
            bound_curve.iter().copied(),
            BLACK.stroke_width(2),
        ))?
        .label("minimum-time bound (bang-bang, this plant, from rest)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK.stroke_width(2)));
        let colors = [
            RGBColor(0, 114, 178),
            RGBColor(230, 159, 0),
            RGBColor(0, 158, 115),
            RGBColor(204, 121, 167),
        ];
        for (k, (name, rows)) in series.iter().enumerate() {
            let color = colors.get(k % colors.len()).copied().unwrap_or(BLACK);
            let point = |r: &SeekRow| {
                (
                    r.distance_tracks.unsigned_abs() as f64,
                    r.access_ms.max(t_lo),
                )
            };
            c.draw_series(
                rows.iter()
                    .filter(|r| r.settled)
                    .map(|r| Circle::new(point(r), 3, color.filled())),
            )?
            .label(*name)
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, color.filled()));
            c.draw_series(
                rows.iter()
                    .filter(|r| !r.settled)
                    .map(|r| Circle::new(point(r), 5, color.stroke_width(2))),
            )?;
        }
        legend(&mut c, SeriesLabelPosition::UpperLeft, 13, 0.85)?;
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("{}: {e}", path.display()))
}

/// A few seeks as step responses (`sledid seek`): for each of `seeks` (indices into the runs'
/// schedule, the same targets in every run) the reading relative to the target, in tracks, of
/// every run — left the whole seek, right within ±[`SEEK_ZOOM_QUANTA`] — with the minimum-time
/// bound of the first run dashed and each run's access time dotted.
///
/// # Errors
/// The font or the drawing backend failed.
pub fn plot_seek_steps(runs: &[&SeekRun], seeks: &[usize], path: &Path) -> Result<(), String> {
    if !font_ready() {
        return Err("the embedded DejaVu Sans font could not be loaded".to_owned());
    }
    let colors = [
        RGBColor(0, 114, 178),
        RGBColor(230, 159, 0),
        RGBColor(0, 158, 115),
    ];
    let draw = || -> Result<(), Box<dyn std::error::Error>> {
        let rows = seeks.len().max(1) as u32;
        let root = BitMapBackend::new(path, (1300, 340 * rows)).into_drawing_area();
        root.fill(&WHITE)?;
        let panels = root.split_evenly((rows as usize, 2));
        for (n, &k) in seeks.iter().enumerate() {
            let row_of = |r: &SeekRun| r.rows.iter().find(|row| row.index == k).copied();
            let Some(first) = runs.first().and_then(|r| row_of(r)) else {
                continue;
            };
            let end_ms = runs
                .iter()
                .filter_map(|r| row_of(r).map(|row| row.access_ms))
                .chain(first.bound_ms)
                .fold(0.0_f64, f64::max)
                * 1.3
                + 12.0;
            let d = first.distance_tracks as f64;
            for (side, zoom) in [(0, false), (1, true)] {
                let Some(area) = panels.get(2 * n + side) else {
                    continue;
                };
                let (lo, hi) = if zoom {
                    (-SEEK_ZOOM_QUANTA, SEEK_ZOOM_QUANTA)
                } else {
                    let m = d.abs() * 1.15 + 2.0;
                    (-m, m)
                };
                let caption = if zoom {
                    format!("seek {k}: within ±{SEEK_ZOOM_QUANTA} tracks")
                } else {
                    format!(
                        "seek {k}: {:+} tracks, bound {:.2} ms",
                        first.distance_tracks,
                        first.bound_ms.unwrap_or(0.0)
                    )
                };
                let mut c = ChartBuilder::on(area)
                    .caption(caption, (FONT, 16))
                    .margin(8)
                    .x_label_area_size(34)
                    .y_label_area_size(56)
                    .build_cartesian_2d(0.0..end_ms, lo..hi)?;
                c.configure_mesh()
                    .x_desc("time from the command (ms)")
                    .y_desc("y − target (tracks)")
                    .label_style((FONT, 12))
                    .draw()?;
                if let Some(b) = first.bound_ms {
                    c.draw_series(DashedLineSeries::new(
                        [(b, lo), (b, hi)],
                        6,
                        4,
                        BLACK.stroke_width(1),
                    ))?
                    .label("bound")
                    .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK));
                }
                for (i, r) in runs.iter().enumerate() {
                    let color = colors.get(i % colors.len()).copied().unwrap_or(BLACK);
                    let (Some(seek), Some(row)) = (r.run.twin.seeks().get(k), row_of(r)) else {
                        continue;
                    };
                    let ts_ms = r.run.twin.params().plant.ts_s * 1e3;
                    let end = seek.end_index.unwrap_or(r.run.twin.samples().len());
                    let window = r
                        .run
                        .twin
                        .samples()
                        .get(seek.start_index..end)
                        .unwrap_or(&[]);
                    let target = seek.target_counts as f64;
                    c.draw_series(LineSeries::new(
                        window
                            .iter()
                            .enumerate()
                            .map(|(j, s)| {
                                (j as f64 * ts_ms, (s.y_counts as f64 - target).clamp(lo, hi))
                            })
                            .take_while(|(t, _)| *t <= end_ms),
                        color.stroke_width(2),
                    ))?
                    .label(format!(
                        "{}: {:.2} ms{}",
                        r.controller.label(),
                        row.access_ms,
                        if row.settled { "" } else { " (unsettled)" }
                    ))
                    .legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 16, y)], color.stroke_width(2))
                    });
                    c.draw_series(DashedLineSeries::new(
                        [(row.access_ms, lo), (row.access_ms, hi)],
                        2,
                        3,
                        color.stroke_width(1),
                    ))?;
                }
                legend(&mut c, SeriesLabelPosition::LowerRight, 12, 0.85)?;
            }
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("{}: {e}", path.display()))
}

/// The zoomed panels of [`plot_seek_steps`] show ±this many tracks.
pub const SEEK_ZOOM_QUANTA: f64 = 6.0;

/// The family's seeks (`sledid control-family --passes seek`): every seek of every plant, access
/// time over that plant's bound against the distance (log-log), for the seek mode and for
/// today's reference-following servo; the bound itself (1) and issue 14's median / p95 targets
/// (1.5, 2.5) dashed.
///
/// # Errors
/// The font or the drawing backend failed.
pub fn plot_seek_family(report: &SeekFamilyReport, path: &Path) -> Result<(), String> {
    if !font_ready() {
        return Err("the embedded DejaVu Sans font could not be loaded".to_owned());
    }
    let draw = || -> Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(path, (1100, 760)).into_drawing_area();
        root.fill(&WHITE)?;
        let s = &report.schedule;
        let (d_lo, d_hi) = (
            f64::from(s.min_tracks) * 0.8,
            f64::from(s.max_tracks) * 1.25,
        );
        let (r_lo, r_hi) = (0.5, 200.0);
        let mut c = ChartBuilder::on(&root)
            .caption(
                format!(
                    "{} plants of family seed {}, {} seeks each: access time over the plant's bound",
                    report.plants.len(),
                    report.family.seed,
                    s.seeks
                ),
                (FONT, 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d((d_lo..d_hi).log_scale(), (r_lo..r_hi).log_scale())?;
        c.configure_mesh()
            .x_desc("seek distance (tracks)")
            .y_desc("access time / minimum-time bound (clipped at 200)")
            .label_style((FONT, 12))
            .draw()?;
        type Pick = fn(&SeekPlantResult) -> &SeekBrief;
        let picks: [(&str, RGBColor, Pick); 2] = [
            (
                "reference-following (30 ms S-curve)",
                RGBColor(230, 159, 0),
                |p| &p.reference,
            ),
            (
                "seek mode (time-optimal seeks)",
                RGBColor(0, 114, 178),
                |p| &p.seek,
            ),
        ];
        for (name, color, pick) in picks {
            c.draw_series(report.plants.iter().flat_map(|p| {
                pick(p).ratios.iter().map(move |&(d, r)| {
                    Circle::new(
                        (d.unsigned_abs() as f64, r.clamp(r_lo, r_hi)),
                        1,
                        color.mix(0.5).filled(),
                    )
                })
            }))?
            .label(name)
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, color.filled()));
        }
        for (level, label, color) in [
            (1.0, "bound", BLACK),
            (1.5, "1.5 (median target)", RGBColor(213, 94, 0)),
            (2.5, "2.5 (p95 target)", RGBColor(204, 121, 167)),
        ] {
            c.draw_series(DashedLineSeries::new(
                [(d_lo, level), (d_hi, level)],
                6,
                4,
                color.stroke_width(2),
            ))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], color.stroke_width(2)));
        }
        legend(&mut c, SeriesLabelPosition::UpperRight, 13, 0.85)?;
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("{}: {e}", path.display()))
}
