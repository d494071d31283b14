//! Figures over time and lag: the data (Fig. 5, 9), simulations (Fig. 6, 10, 11a) and
//! residual–input cross-correlations (Fig. 7, 18).

use plotters::prelude::*;

use super::{Area, Drawn, FONT, INPUT, MEASURED, MODEL, legend, range, tick, time_axis};
use crate::study::Dataset;
use crate::study::results::{CrossCorrelation, ModelReport, RateReport};

/// Fig. 5 / 9: time and frequency views of the identification segment.
pub(super) fn data_panels(area: &Area, rate: &RateReport) -> Drawn {
    let panels = area.split_evenly((1, 2));
    let d = &rate.ident;
    let (t, t_label) = time_axis(d.y.len(), d.ts_s);
    let r = d.r.clone().unwrap_or_default();
    let (y0, y1) = range(d.y.iter().chain(&r).copied(), 0.1);
    let (u0, u1) = range(d.u.iter().copied(), 0.1);
    let t1 = t.last().copied().unwrap_or(1.0);
    let mut c = ChartBuilder::on(&panels[0])
        .caption(format!("identification data, {}", rate.label), (FONT, 18))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(50)
        .right_y_label_area_size(50)
        .build_cartesian_2d(0.0..t1, y0..y1)?
        .set_secondary_coord(0.0..t1, u0..u1);
    c.configure_mesh()
        .x_desc(t_label)
        .x_labels(6)
        .y_desc(format!("y, r ({})", d.y_unit_name))
        .label_style((FONT, 13))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    c.configure_secondary_axes()
        .y_desc("u (V)")
        .label_style((FONT, 13))
        .y_label_formatter(&tick)
        .draw()?;
    c.draw_secondary_series(LineSeries::new(
        t.iter().copied().zip(d.u.iter().copied()),
        INPUT,
    ))?
    .label("u")
    .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], INPUT));
    if !r.is_empty() {
        c.draw_series(DashedLineSeries::new(
            t.iter().copied().zip(r.iter().copied()),
            6,
            4,
            GREEN.stroke_width(2),
        ))?
        .label("r")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], GREEN));
    }
    c.draw_series(LineSeries::new(
        t.iter().copied().zip(d.y.iter().copied()),
        MEASURED.stroke_width(2),
    ))?
    .label("y")
    .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], MEASURED));
    legend(&mut c, SeriesLabelPosition::UpperRight)?;

    let (pu, py) = &rate.spectra;
    let f1 = pu.freq_hz.last().copied().unwrap_or(1.0);
    let (p0, p1) = range(pu.power_db.iter().chain(&py.power_db).copied(), 0.05);
    let mut c = ChartBuilder::on(&panels[1])
        .caption(format!("periodograms, {}", rate.label), (FONT, 18))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..f1, p0..p1)?;
    c.configure_mesh()
        .x_desc("frequency (Hz)")
        .y_desc("|X|²/N (dB)")
        .label_style((FONT, 13))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    let y_power = format!("y ({}²)", d.y_unit_name);
    for (p, colour, name) in [(pu, INPUT, "u (V²)"), (py, MEASURED, y_power.as_str())] {
        c.draw_series(LineSeries::new(
            p.freq_hz.iter().copied().zip(p.power_db.iter().copied()),
            colour.stroke_width(2),
        ))?
        .label(name)
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
    }
    legend(&mut c, SeriesLabelPosition::UpperRight)?;
    Ok(())
}

/// An RMS for a title: compact when a simulation diverged, marked when the model is unstable.
fn rms_label(m: &ModelReport) -> String {
    let v = m.rms_sim_valid;
    let value = if v.abs() < 1e4 {
        format!("{v:.2}")
    } else {
        format!("{v:.1e}")
    };
    if m.stable {
        value
    } else {
        format!("{value} (unstable)")
    }
}

/// Samples drawn of a simulation panel.
pub(super) const SIM_WINDOW: usize = 400;

/// Fig. 6 / 10 / 11a: simulation on validation data, one panel per model.
pub(super) fn simulation_panels(area: &Area, rate: &RateReport) -> Drawn {
    let panels = area.split_evenly((1, rate.models.len()));
    for (panel, m) in panels.iter().zip(&rate.models) {
        let title = format!("{} {}: sim RMS {}", m.name, rate.label, rms_label(m));
        sim_panel(panel, &rate.valid, title, &m.sim_valid)?;
    }
    Ok(())
}

/// One simulation panel: measured y (black) and `sim` (red) over the validation segment `d`.
/// Long segments show only their first [`SIM_WINDOW`] samples (the RMS in the title is over
/// the whole segment; the legend says so).
pub(super) fn sim_panel(panel: &Area, d: &Dataset, title: String, sim: &[f64]) -> Drawn {
    let n = d.y.len().min(SIM_WINDOW);
    let (y_all, sim) = (&d.y[..n], &sim[..n.min(sim.len())]);
    let measured = if n < d.y.len() {
        format!("measured (first {n} of {})", d.y.len())
    } else {
        "measured".to_owned()
    };
    let (t, t_label) = time_axis(n, d.ts_s);
    let t1 = t.last().copied().unwrap_or(1.0);
    // Scale to the data; a diverging simulation is clipped at 3× the data's span.
    let (y0, y1) = range(y_all.iter().copied(), 0.15);
    let span = (y1 - y0).max(2.0);
    let (s0, s1) = range(sim.iter().copied(), 0.05);
    let (lo, hi) = (s0.max(y0 - span).min(y0), s1.min(y1 + span).max(y1));
    let mut c = ChartBuilder::on(panel)
        .caption(title, (FONT, 17))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(46)
        .build_cartesian_2d(0.0..t1, lo..hi)?;
    c.configure_mesh()
        .x_desc(t_label)
        .x_labels(6)
        .y_desc(format!("y ({})", d.y_unit_name))
        .label_style((FONT, 13))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    let clip = |v: f64| v.clamp(lo, hi);
    c.draw_series(LineSeries::new(
        t.iter().copied().zip(y_all.iter().copied()),
        MEASURED.stroke_width(2),
    ))?
    .label(measured)
    .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], MEASURED));
    c.draw_series(LineSeries::new(
        t.iter().copied().zip(sim.iter().map(|&v| clip(v))),
        MODEL.stroke_width(2),
    ))?
    .label("simulated")
    .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], MODEL));
    legend(&mut c, SeriesLabelPosition::UpperRight)?;
    Ok(())
}

/// Fig. 7 / 18: residual–input cross-correlation with 99 % bounds.
pub(super) fn xcorr_panels(area: &Area, rate: &RateReport) -> Drawn {
    let panels = area.split_evenly((1, rate.models.len()));
    for (panel, m) in panels.iter().zip(&rate.models) {
        xcorr_panel(panel, &format!("{} {}", m.name, rate.label), &m.xcorr_valid)?;
    }
    Ok(())
}

/// One cross-correlation panel with its 99 % bounds; `name` heads the title.
pub(super) fn xcorr_panel(panel: &Area, name: &str, x: &CrossCorrelation) -> Drawn {
    let l = x.lags.last().copied().unwrap_or(1) as f64 + 0.5;
    let top = x
        .values
        .iter()
        .fold(x.bound, |a, v| a.max(v.abs()))
        .max(0.1)
        * 1.1;
    let mut c = ChartBuilder::on(panel)
        .caption(
            format!("{name}: {}/{} outside", x.outside, x.lags.len()),
            (FONT, 17),
        )
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(46)
        .build_cartesian_2d(-l..l, -top..top)?;
    c.configure_mesh()
        .x_desc("lag τ (samples)")
        .y_desc("R_εu(τ)")
        .label_style((FONT, 13))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()?;
    c.draw_series(x.lags.iter().zip(&x.values).map(|(&k, &v)| {
        let k = k as f64;
        PathElement::new([(k, 0.0), (k, v)], INPUT.stroke_width(3))
    }))?;
    c.draw_series(
        x.lags
            .iter()
            .zip(&x.values)
            .map(|(&k, &v)| Circle::new((k as f64, v), 3, INPUT.filled())),
    )?;
    for b in [x.bound, -x.bound] {
        c.draw_series(DashedLineSeries::new(
            [(-l, b), (l, b)],
            8,
            5,
            MODEL.stroke_width(2),
        ))?;
    }
    Ok(())
}
