//! What every figure of the harness shares (the study's, `study::plots`, and the control
//! commands', `control::plot`): the embedded font and the legend box.
//!
//! Text uses plotters' pure-Rust `ab_glyph` backend with the DejaVu Sans font the `dejavu` crate
//! embeds, so no system font (and no fontconfig) is needed on any machine.

use plotters::coord::CoordTranslate;
use plotters::prelude::*;
use std::error::Error;
use std::sync::OnceLock;

/// The family name DejaVu Sans is registered under.
pub const FONT: &str = "sans-serif";

/// Registers DejaVu Sans with plotters once; false if the font could not be parsed.
pub fn font_ready() -> bool {
    static READY: OnceLock<bool> = OnceLock::new();
    *READY.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
    })
}

/// The legend box: at `position`, labels at `size` pt, a white box of opacity `opacity` with a
/// black border.
///
/// # Errors
/// The drawing backend failed.
pub fn legend<'a, 'b: 'a, CT: CoordTranslate>(
    c: &mut ChartContext<'a, BitMapBackend<'b>, CT>,
    position: SeriesLabelPosition,
    size: u32,
    opacity: f64,
) -> Result<(), Box<dyn Error>> {
    c.configure_series_labels()
        .position(position)
        .label_font((FONT, size))
        .background_style(WHITE.mix(opacity))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}
