//! Pictures of a material and of the encoder's trade-offs, drawn with plotters into PNG or SVG.
//! Text uses a font compiled into the program (`assets/fonts/`), so output does not depend on
//! the fonts of the machine.

use crate::error::{Error, Result};
use std::sync::OnceLock;

/// The font family name plots ask for.
pub const FONT: &str = "sans-serif";

/// Registers the embedded font with plotters once; later calls are free.
pub fn register_font() -> Result<()> {
    static DONE: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font(
            FONT,
            plotters::style::FontStyle::Normal,
            include_bytes!("../assets/fonts/DejaVuSans-subset.ttf"),
        )
        .map_err(|_| "the embedded font could not be read".to_string())
    })
    .clone()
    .map_err(Error::Parameter)
}

/// How a picture is written, from the output's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageKind {
    Png,
    Svg,
}

impl ImageKind {
    pub fn of(path: &std::path::Path) -> Result<Self> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("png") => Ok(ImageKind::Png),
            Some("svg") => Ok(ImageKind::Svg),
            _ => Err(Error::Parameter(format!(
                "{}: the picture's name must end in .png or .svg",
                path.display()
            ))),
        }
    }
}

/// Turns a plotters error into ours, naming what was being drawn.
pub fn draw_error(what: &str, e: impl std::fmt::Display) -> Error {
    Error::Parameter(format!("drawing {what} failed: {e}"))
}
