//! Figures over parameter and complex planes: criterion surfaces (Fig. 8) and poles and zeros
//! (Fig. 11b).

use plotters::prelude::*;

use super::{Area, Drawn, FONT, INPUT, MODEL, legend, tick};
use crate::study::results::RateReport;

/// Fig. 8: criterion surfaces of the first-order models with both minima.
pub(super) fn surface_panels(area: &Area, rate: &RateReport) -> Drawn {
    let s = &rate.criterion_surfaces;
    let log = |v: f64| v.max(1e-12).log10();
    let panels = area.split_evenly((1, 2));
    for (panel, (name, z)) in panels
        .iter()
        .zip([("ARX1", &s.arx_v_n), ("OE1", &s.oe_v_n)])
    {
        let (plot_area, bar_area) = panel.split_horizontally(panel.dim_in_pixel().0 - 90);
        let zmin = z
            .iter()
            .flatten()
            .map(|&v| log(v))
            .fold(f64::INFINITY, f64::min);
        // Three decades above the minimum: enough to show the valley.
        let zmax = z
            .iter()
            .flatten()
            .map(|&v| log(v))
            .fold(f64::NEG_INFINITY, f64::max)
            .min(zmin + 3.0);
        let (p, b) = (&s.pole_axis, &s.b1_axis);
        let (dp, db) = (step(p), step(b));
        let mut c = ChartBuilder::on(&plot_area)
            .caption(format!("{name} criterion, {}", rate.label), (FONT, 17))
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(
                p[0] - dp / 2.0..p[p.len() - 1] + dp / 2.0,
                b[0] - db / 2.0..b[b.len() - 1] + db / 2.0,
            )?;
        c.draw_series(z.iter().enumerate().flat_map(|(i, row)| {
            row.iter().enumerate().map(move |(j, &v)| {
                let colour = ViridisRGB::get_color_normalized(log(v).min(zmax), zmin, zmax);
                Rectangle::new(
                    [
                        (p[j] - dp / 2.0, b[i] - db / 2.0),
                        (p[j] + dp / 2.0, b[i] + db / 2.0),
                    ],
                    colour.filled(),
                )
            })
        }))?;
        c.configure_mesh()
            .disable_mesh()
            .x_desc("pole (−a1 / −f1)")
            .y_desc("b1")
            .label_style((FONT, 13))
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .draw()?;
        for (m, colour, label) in [
            (&s.arx_minimum, WHITE, "ARX1 estimate"),
            (&s.oe_minimum, MODEL, "OE1 estimate"),
        ] {
            c.draw_series([Circle::new((m.pole, m.b1), 7, BLACK.stroke_width(1))])?;
            c.draw_series([Circle::new((m.pole, m.b1), 6, colour.filled())])?
                .label(label)
                .legend(move |(x, y)| Circle::new((x + 8, y), 5, colour.filled()));
        }
        legend(&mut c, SeriesLabelPosition::UpperLeft)?;
        colour_bar(&bar_area, zmin, zmax)?;
    }
    Ok(())
}

/// Spacing of an evenly spaced axis.
fn step(axis: &[f64]) -> f64 {
    match axis {
        [a, b, ..] => b - a,
        _ => 1.0,
    }
}

/// A vertical Viridis colour bar labelled with log10 V_N.
fn colour_bar(area: &Area, zmin: f64, zmax: f64) -> Drawn {
    let mut c = ChartBuilder::on(area)
        .margin_top(40)
        .margin_bottom(44)
        .margin_right(4)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..1.0, zmin..zmax.max(zmin + 1e-9))?;
    let n = 64;
    let dz = (zmax - zmin) / n as f64;
    c.draw_series((0..n).map(|k| {
        let z = zmin + k as f64 * dz;
        Rectangle::new(
            [(0.0, z), (1.0, z + dz)],
            ViridisRGB::get_color_normalized(z + dz / 2.0, zmin, zmax).filled(),
        )
    }))?;
    c.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc("log10 V_N")
        .label_style((FONT, 12))
        .y_label_formatter(&tick)
        .draw()?;
    Ok(())
}

/// Fig. 11b: poles and zeros with the unit circle.
pub(super) fn pole_zero_panels(area: &Area, rate: &RateReport) -> Drawn {
    for (panel, m) in area
        .split_evenly((1, rate.models.len()))
        .iter()
        .zip(&rate.models)
    {
        let extent = m
            .poles
            .iter()
            .chain(&m.zeros)
            .map(|p| p[0].abs().max(p[1].abs()))
            .fold(1.0, f64::max)
            .min(4.0)
            * 1.15;
        // Square plotting area: the caption drawn first, then the larger side padded.
        let area = panel.titled(&format!("{} {}", m.name, rate.label), (FONT, 17))?;
        let (w, h) = area.dim_in_pixel();
        let (label_x, label_y, margin) = (36i32, 46i32, 8i32);
        let excess = (w as i32 - label_y - 2 * margin) - (h as i32 - label_x - 2 * margin);
        let (pad_x, pad_y) = (excess.max(0) / 2, (-excess).max(0));
        let mut c = ChartBuilder::on(&area)
            .margin(margin)
            .margin_left(margin + pad_x)
            .margin_right(margin + pad_x)
            .margin_bottom(margin + pad_y)
            .x_label_area_size(label_x)
            .y_label_area_size(label_y)
            .build_cartesian_2d(-extent..extent, -extent..extent)?;
        c.configure_mesh()
            .x_desc("Re")
            .y_desc("Im")
            .label_style((FONT, 13))
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .draw()?;
        let circle = (0..=360).map(|k| {
            let a = (k as f64).to_radians();
            (a.cos(), a.sin())
        });
        c.draw_series(LineSeries::new(circle, BLACK.mix(0.6)))?;
        let clip = |p: &[f64; 2]| (p[0].clamp(-extent, extent), p[1].clamp(-extent, extent));
        c.draw_series(
            m.poles
                .iter()
                .map(|p| Cross::new(clip(p), 8, MODEL.stroke_width(3))),
        )?;
        c.draw_series(
            m.zeros
                .iter()
                .map(|p| Circle::new(clip(p), 8, INPUT.stroke_width(3))),
        )?;
    }
    Ok(())
}
