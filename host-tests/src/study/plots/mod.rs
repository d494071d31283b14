//! The study's figures, drawn like the paper's with `plotters` into PNG files.
//!
//! Text is rendered with plotters' pure-Rust `ab_glyph` backend and the DejaVu Sans font that the
//! `dejavu` crate embeds, so no system font (and no fontconfig) is needed on any machine.
//!
//! | file | paper | panels (rows: Ts, 2·Ts) |
//! |---|---|---|
//! | `fig5_ident_data.png` | Fig. 5, 9 | identification data in time (y, r in the study's y unit — quanta on the twin; u in V, right axis) and frequency (periodograms) |
//! | `fig6_simulation.png` | Fig. 6, 10, 11a | measured vs simulated y on the validation segment, per model |
//! | `fig7_xcorr.png` | Fig. 7, 18 | residual–input cross-correlation on the validation segment with 99 % bounds |
//! | `fig8_criterion.png` | Fig. 8 | log10 V_N over (pole, b1) for ARX1 and OE1, both minima marked |
//! | `fig11b_poles_zeros.png` | Fig. 11b | poles (×) and zeros (○) with the unit circle, per model |
//! | `fig13_nonlinear_simulation.png` | Fig. 13a, 14b, 17a | measured vs simulated y on the validation segment, per nonlinear model |
//! | `fig13b_15_17b_static_maps.png` | Fig. 13b, 15, 17b | each estimated static nonlinearity beside its linear model's |
//! | `fig18_nonlinear_xcorr.png` | Fig. 18 | simulation residual–input cross-correlation of each nonlinear model |

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::error::Error;
use std::path::Path;

pub mod curves;
mod nonlinear;
mod planes;
mod time;

use super::results::{PlotInfo, RateReport};
use super::{Study, StudyError};
use planes::{pole_zero_panels, surface_panels};
use time::{data_panels, simulation_panels, xcorr_panels};

pub(super) type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
pub(super) type Drawn = Result<(), Box<dyn Error>>;

pub(super) use crate::figure::{FONT, font_ready};
const PANEL_W: u32 = 460;
const PANEL_H: u32 = 400;
/// Measured data.
pub(super) const MEASURED: RGBColor = RGBColor(30, 30, 30);
/// Model output.
pub(super) const MODEL: RGBColor = RGBColor(220, 50, 32);
/// Input.
pub(super) const INPUT: RGBColor = RGBColor(0, 114, 178);

/// Draws every figure into `dir`.
pub fn write_all(study: &Study, dir: &Path) -> Result<Vec<PlotInfo>, StudyError> {
    if !font_ready() {
        return Err(StudyError::Plot {
            path: dir.to_path_buf(),
            message: "the embedded DejaVu Sans font could not be loaded".to_owned(),
        });
    }
    type Figure = fn(&Area, &RateReport) -> Drawn;
    let figures: [(&str, &str, &str, usize, Figure); 8] = [
        (
            "fig5_ident_data.png",
            "5, 9",
            "identification segment; left: y and r (centred, {y unit}) and u (V, right axis) vs time from the segment's start; right: periodograms of u and y (dB) vs frequency (Hz); top row Ts, bottom row 2·Ts",
            2,
            data_panels,
        ),
        (
            "fig6_simulation.png",
            "6, 10, 11a",
            "validation segment: measured y (black) and simulated y (red), {y unit} vs time from the segment's start; RMS over samples 2..N in the title; simulations beyond the axes are clipped; top row Ts, bottom row 2·Ts",
            4,
            simulation_panels,
        ),
        (
            "fig7_xcorr.png",
            "7, 18",
            "normalised cross-correlation of the one-step residual and the input on the validation segment vs lag (samples), dashed: 99 % bounds ±2.58/√N; top row Ts, bottom row 2·Ts",
            4,
            xcorr_panels,
        ),
        (
            "fig8_criterion.png",
            "8",
            "log10 V_N (eq. 3) on the identification segment over pole (−a1, −f1) and b1, colour bar at the right; white dot: ARX1 minimum, red dot: OE1 minimum (both in both panels); top row Ts, bottom row 2·Ts",
            2,
            surface_panels,
        ),
        (
            "fig11b_poles_zeros.png",
            "11b",
            "poles (×) and zeros (○) of each model with the unit circle; top row Ts, bottom row 2·Ts",
            4,
            pole_zero_panels,
        ),
        (
            "fig13_nonlinear_simulation.png",
            "13a, 14b, 17a",
            "validation segment: measured y (black) and the simulated y (red) of each nonlinear model, {y unit} vs time; title: validation RMS and its change against the linear start (OE1 or OE2); top row Ts, bottom row 2·Ts",
            5,
            nonlinear::simulation_panels,
        ),
        (
            "fig13b_15_17b_static_maps.png",
            "13b, 15, 17b",
            "estimated static maps (red) vs the linear counterpart's (black dashed) over the identification data's range (grey verticals) ±10 %: eq. 5 and eq. 7 b1·u + g(u) vs b1·u (Fig. 13b, 15); eq. 6 b1·u + g(ŷ, u) at three ŷ(t−1) slices; Wiener x + g(x) vs x (Fig. 17b); friction g(v) of the simulated velocity; top row Ts, bottom row 2·Ts",
            5,
            nonlinear::map_panels,
        ),
        (
            "fig18_nonlinear_xcorr.png",
            "18",
            "normalised cross-correlation of each nonlinear model's simulation residual (its predictor) and the input on the validation segment vs lag (samples), dashed: 99 % bounds ±2.58/√N; top row Ts, bottom row 2·Ts",
            5,
            nonlinear::xcorr_panels,
        ),
    ];
    let mut infos = Vec::new();
    for (file, fig, description, cols, draw) in figures {
        let path = dir.join(file);
        let err = |e: Box<dyn Error>| StudyError::Plot {
            path: path.clone(),
            message: e.to_string(),
        };
        let size = (PANEL_W * cols as u32, 2 * PANEL_H);
        let root = BitMapBackend::new(&path, size).into_drawing_area();
        let drawn = (|| -> Drawn {
            root.fill(&WHITE)?;
            let rows = root.split_evenly((2, 1));
            draw(&rows[0], &study.at_ts)?;
            draw(&rows[1], &study.decimated_by_2)?;
            root.present()?;
            Ok(())
        })();
        drawn.map_err(err)?;
        infos.push(PlotInfo {
            file: file.to_owned(),
            paper_figure: fig.to_owned(),
            description: description.replace("{y unit}", &study.y_unit_name),
        });
    }
    Ok(infos)
}

/// The legend every panel of the study draws: `position`, 13 pt, a white translucent box.
pub(super) fn legend<'a, 'b: 'a, CT: plotters::coord::CoordTranslate>(
    c: &mut ChartContext<'a, BitMapBackend<'b>, CT>,
    position: SeriesLabelPosition,
) -> Drawn {
    crate::figure::legend(c, position, 13, 0.85)
}

/// The axes of a curve panel (the study's static maps, `curves::write_curves`): `caption` at
/// 17 pt over `x` × `y`, five x labels, tick labels by [`tick`].
pub(super) fn curve_axes<'a, 'b: 'a>(
    area: &'a Area<'b>,
    caption: &str,
    x: (f64, f64),
    y: (f64, f64),
    x_desc: &str,
    y_desc: &str,
) -> Result<
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    Box<dyn Error>,
> {
    let mut c = ChartBuilder::on(area)
        .caption(caption, (FONT, 17))
        .margin(8)
        .x_label_area_size(50)
        .y_label_area_size(56)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
    c.configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_labels(5)
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    Ok(c)
}

/// `[lo, hi]` of `values` with a relative margin; never empty.
pub(super) fn range(values: impl Iterator<Item = f64>, margin: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * margin).max(1e-9);
    (lo - pad, hi + pad)
}

/// Tick label: at most 6 decimals, no `-0`.
pub(super) fn tick(v: &f64) -> String {
    let r = (v * 1e6).round() / 1e6;
    if r == 0.0 {
        "0".to_owned()
    } else {
        format!("{r}")
    }
}

/// Time from the segment's start of `n` samples at `ts_s`, in ms (or in s past 10 s), and its
/// axis label.
pub(super) fn time_axis(n: usize, ts_s: f64) -> (Vec<f64>, &'static str) {
    let (scale, label) = if n as f64 * ts_s > 10.0 {
        (1.0, "time (s)")
    } else {
        (1e3, "time (ms)")
    };
    ((0..n).map(|k| k as f64 * ts_s * scale).collect(), label)
}
