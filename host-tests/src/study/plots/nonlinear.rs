//! Figures of the nonlinear models: simulation on validation data (Fig. 13a, 14b, 17a), the
//! estimated static nonlinearities against the linear model's (Fig. 13b, 15, 17b) and the
//! residual–input cross-correlation (Fig. 18).

use plotters::prelude::*;

use super::time::{sim_panel, xcorr_panel};
use super::{Area, Drawn, MEASURED, MODEL, curve_axes, legend, range};
use crate::study::results::RateReport;

/// Colours of the ŷ(t−1) slices of eq. 6 after the first (which is [`MODEL`]).
const SLICES: [RGBColor; 2] = [RGBColor(0, 158, 115), RGBColor(230, 159, 0)];

/// Fig. 13a / 14b / 17a: simulation of each nonlinear model on validation data.
pub(super) fn simulation_panels(area: &Area, rate: &RateReport) -> Drawn {
    let panels = area.split_evenly((1, rate.nonlinear.len().max(1)));
    for (panel, m) in panels.iter().zip(&rate.nonlinear) {
        let title = format!(
            "{} {}: {:.2} ({:+.0} % vs {})",
            m.name,
            rate.label,
            m.rms_sim_valid,
            100.0 * m.change_vs_linear_valid,
            m.linear_counterpart
        );
        sim_panel(panel, &rate.valid, title, &m.sim_valid)?;
    }
    Ok(())
}

/// Fig. 18: simulation residual vs input of each nonlinear model, 99 % bounds.
pub(super) fn xcorr_panels(area: &Area, rate: &RateReport) -> Drawn {
    let panels = area.split_evenly((1, rate.nonlinear.len().max(1)));
    for (panel, m) in panels.iter().zip(&rate.nonlinear) {
        xcorr_panel(panel, &format!("{} {}", m.name, rate.label), &m.xcorr_valid)?;
    }
    Ok(())
}

/// Fig. 13b / 15 / 17b: each estimated static map (red; eq. 6 one curve per ŷ(t−1) slice) and
/// the linear counterpart's (black dashed); grey verticals: the identification data's range.
pub(super) fn map_panels(area: &Area, rate: &RateReport) -> Drawn {
    let panels = area.split_evenly((1, rate.nonlinear.len().max(1)));
    for (panel, m) in panels.iter().zip(&rate.nonlinear) {
        let map = &m.static_map;
        let (x0, x1) = (
            map.x.first().copied().unwrap_or(-1.0),
            map.x.last().copied().unwrap_or(1.0),
        );
        let (v0, v1) = range(
            map.linear
                .values
                .iter()
                .chain(map.nonlinear.iter().flat_map(|c| &c.values))
                .copied(),
            0.08,
        );
        let mut c = curve_axes(
            panel,
            &format!("{} {}", m.name, rate.label),
            (x0, x1),
            (v0, v1),
            &map.input,
            &map.output,
        )?;
        for x in map.data_range {
            c.draw_series(LineSeries::new(
                [(x, v0), (x, v1)],
                RGBColor(170, 170, 170).stroke_width(1),
            ))?;
        }
        c.draw_series(DashedLineSeries::new(
            map.x.iter().copied().zip(map.linear.values.iter().copied()),
            8,
            5,
            MEASURED.stroke_width(2),
        ))?
        .label(map.linear.label.as_str())
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], MEASURED));
        for (k, curve) in map.nonlinear.iter().enumerate() {
            let colour = if k == 0 { MODEL } else { SLICES[(k - 1) % 2] };
            let label = if map.nonlinear.len() == 1 {
                m.name.clone()
            } else {
                curve.label.clone()
            };
            c.draw_series(LineSeries::new(
                map.x.iter().copied().zip(curve.values.iter().copied()),
                colour.stroke_width(2),
            ))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
        }
        legend(&mut c, SeriesLabelPosition::UpperLeft)?;
    }
    Ok(())
}
