//! A row of simple x–y panels (true vs estimated curves), for figures outside the study proper —
//! e.g. the recovered static nonlinearities of `tests/integration/nonlinear.rs` against the true ones.

use plotters::prelude::*;
use std::path::Path;

use super::{MEASURED, MODEL, curve_axes, font_ready, legend, range};
use crate::study::StudyError;

/// One curve of a panel.
#[derive(Clone, Debug)]
pub struct Curve {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// Dashed black (the truth) or solid colour (an estimate).
    pub reference: bool,
}

/// One panel.
#[derive(Clone, Debug)]
pub struct CurvePanel {
    /// Caption.
    pub title: String,
    /// x-axis description.
    pub x_desc: String,
    /// y-axis description.
    pub y_desc: String,
    /// The curves.
    pub curves: Vec<Curve>,
}

const ESTIMATES: [RGBColor; 3] = [MODEL, RGBColor(0, 114, 178), RGBColor(0, 158, 115)];

/// Draws `panels` side by side into the PNG `path`.
///
/// # Errors
/// [`StudyError::Plot`] naming the file if drawing or writing fails.
pub fn write_curves(path: &Path, panels: &[CurvePanel]) -> Result<(), StudyError> {
    let err = |e: String| StudyError::Plot {
        path: path.to_path_buf(),
        message: e,
    };
    if !font_ready() {
        return Err(err("font".into()));
    }
    let width = 460 * panels.len().max(1) as u32;
    let root = BitMapBackend::new(path, (width, 400)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let areas = root.split_evenly((1, panels.len().max(1)));
    for (area, p) in areas.iter().zip(panels) {
        draw(area, p).map_err(|e| err(e.to_string()))?;
    }
    root.present().map_err(|e| err(e.to_string()))
}

fn draw(area: &super::Area, p: &CurvePanel) -> super::Drawn {
    let xs = || p.curves.iter().flat_map(|c| c.points.iter().map(|q| q.0));
    let (x0, x1) = range(xs(), 0.0);
    let (y0, y1) = range(
        p.curves.iter().flat_map(|c| c.points.iter().map(|q| q.1)),
        0.08,
    );
    let mut c = curve_axes(area, &p.title, (x0, x1), (y0, y1), &p.x_desc, &p.y_desc)?;
    let mut k = 0;
    for curve in &p.curves {
        if curve.reference {
            c.draw_series(DashedLineSeries::new(
                curve.points.iter().copied(),
                8,
                5,
                MEASURED.stroke_width(2),
            ))?
            .label(curve.label.as_str())
            .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], MEASURED));
        } else {
            let colour = ESTIMATES[k % ESTIMATES.len()];
            k += 1;
            c.draw_series(LineSeries::new(
                curve.points.iter().copied(),
                colour.stroke_width(2),
            ))?
            .label(curve.label.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
        }
    }
    legend(&mut c, SeriesLabelPosition::UpperLeft)?;
    Ok(())
}
