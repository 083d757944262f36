//! The drawing kit every picture shares, drawn with plotters into PNG or SVG: the embedded
//! font (`assets/fonts/`, so output does not depend on the machine's fonts), rendering a
//! [`Figure`] to bytes, colour maps and scales, axis labels, the house style of charts, and heat
//! maps over the outgoing hemisphere.

use crate::error::{Error, Result};
use crate::model::angles::wrap_phi;
use plotters::chart::MeshStyle;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::prelude::*;
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
            include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf"),
        )
        .map_err(|_| "the embedded font could not be read".to_string())
    })
    .clone()
    .map_err(Error::Parameter)
}

/// How a picture is written, from the output's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageKind {
    /// A PNG raster (`.png`).
    Png,
    /// An SVG document (`.svg`).
    Svg,
}

impl ImageKind {
    /// The kind `path`'s extension names (`.png` or `.svg`, any case); [`Error::Parameter`] for
    /// any other.
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

// ---------------------------------------------------------------------------------------------
// Rendering to bytes

/// Something drawn with plotters on any backend.
pub trait Figure {
    /// Width and height in pixels (SVG: user units).
    fn size(&self) -> (u32, u32);
    /// Draws the figure onto `root`, a drawing area of [`Figure::size`].
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>;
}

/// Draws `figure` into an encoded PNG or an SVG document.
pub fn render(figure: &impl Figure, kind: ImageKind) -> Result<Vec<u8>> {
    register_font()?;
    let (w, h) = figure.size();
    match kind {
        ImageKind::Svg => {
            let mut s = String::new();
            {
                let root = SVGBackend::with_string(&mut s, (w, h)).into_drawing_area();
                figure.draw(&root)?;
                root.present().map_err(|e| draw_error("the picture", e))?;
            }
            Ok(s.into_bytes())
        }
        ImageKind::Png => {
            let mut buf = vec![0u8; w as usize * h as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                figure.draw(&root)?;
                root.present().map_err(|e| draw_error("the picture", e))?;
            }
            encode_png(&buf, w, h)
        }
    }
}

/// Encodes 8-bit RGB pixels (row-major, top row first) as a PNG file.
pub fn encode_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, width, height, image::ColorType::Rgb8)
        .map_err(|e| Error::Parameter(format!("encoding the PNG failed: {e}")))?;
    Ok(out)
}

/// The embedded font at `size` pixels.
pub fn font(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

/// A colour from "#rrggbb"-style components.
pub(crate) const fn rgb(c: u32) -> RGBColor {
    RGBColor((c >> 16) as u8, (c >> 8) as u8, c as u8)
}

/// Line colours for curves (Okabe–Ito, readable by colour-blind viewers), then black.
pub const SERIES_COLORS: [RGBColor; 8] = [
    rgb(0x0072b2),
    rgb(0xd55e00),
    rgb(0x009e73),
    rgb(0xcc79a7),
    rgb(0xe69f00),
    rgb(0x56b4e9),
    rgb(0x8b6f00),
    rgb(0x000000),
];

/// A chart's mesh in the house style: label and axis-description fonts, light grid lines.
/// Callers add axis descriptions, label counts and formatters, then draw.
pub fn house_mesh<'a, 'b, DB, X, Y>(
    chart: &'b mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
) -> MeshStyle<'a, 'b, X, Y, DB>
where
    DB: DrawingBackend,
    X: Ranged + ValueFormatter<X::ValueType>,
    Y: Ranged + ValueFormatter<Y::ValueType>,
{
    let mut mesh = chart.configure_mesh();
    mesh.label_style(font(12.0))
        .axis_desc_style(font(13.0))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(215, 215, 215));
    mesh
}

/// Draws a chart's series legend in the house style at `position`.
pub fn draw_legend<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
    what: &str,
) -> Result<()>
where
    DB: DrawingBackend + 'a,
    CT: CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .label_font(font(12.0))
        .draw()
        .map_err(|e| draw_error(what, e))
}

// ---------------------------------------------------------------------------------------------
// Colour maps

/// Viridis (perceptually uniform, colour-blind safe): dark purple at 0, yellow at 1.
const VIRIDIS: [u32; 11] = [
    0x440154, 0x482475, 0x414487, 0x355f8d, 0x2a788e, 0x21918c, 0x22a884, 0x44bf70, 0x7ad151,
    0xbddf26, 0xfde725,
];

/// ColorBrewer RdBu reversed: blue for negative, near-white at 0, red for positive.
const DIVERGING: [u32; 11] = [
    0x053061, 0x2166ac, 0x4393c3, 0x92c5de, 0xd1e5f0, 0xf7f7f7, 0xfddbc7, 0xf4a582, 0xd6604d,
    0xb2182b, 0x67001f,
];

fn interpolate(table: &[u32], t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (table.len() - 1) as f64;
    let i = (x as usize).min(table.len() - 2);
    let f = x - i as f64;
    let (a, b) = (rgb(table[i]), rgb(table[i + 1]));
    let mix = |p: u8, q: u8| (p as f64 + f * (q as f64 - p as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// How values map to colours in a heat map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ColorScale {
    /// Viridis over [lo, hi]: for values of one sign.
    Sequential {
        /// The value drawn at the scale's low end.
        lo: f64,
        /// The value drawn at the scale's high end.
        hi: f64,
    },
    /// Blue–white–red over [−m, m], white at 0: for values of both signs.
    Diverging {
        /// The magnitude drawn at either end.
        m: f64,
    },
}

impl ColorScale {
    /// The scale for these values: diverging, centred on 0, when some are negative (beyond
    /// rounding), so that 0 is white and the sign reads at a glance; sequential over their
    /// range when none is. NaNs are ignored.
    pub fn fit(values: &[f64]) -> Self {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &v in values.iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo > hi {
            return ColorScale::Sequential { lo: 0.0, hi: 1.0 };
        }
        let m = lo.abs().max(hi.abs());
        if lo < -1e-6 * m {
            return ColorScale::Diverging { m };
        }
        if hi - lo <= 1e-12 * m.max(1e-300) {
            // A constant: centre it in a small range so it draws mid-scale.
            let d = if m > 0.0 { 0.05 * m } else { 1.0 };
            return ColorScale::Sequential {
                lo: lo - d,
                hi: hi + d,
            };
        }
        ColorScale::Sequential { lo, hi }
    }

    /// The scale covering two sets of values at once (original beside reconstruction).
    pub fn fit_both(a: &[f64], b: &[f64]) -> Self {
        let all: Vec<f64> = a.iter().chain(b).copied().collect();
        Self::fit(&all)
    }

    /// The values at the scale's two ends, (low, high).
    pub fn range(&self) -> (f64, f64) {
        match *self {
            ColorScale::Sequential { lo, hi } => (lo, hi),
            ColorScale::Diverging { m } => (-m, m),
        }
    }

    /// Position of `v` along the scale, 0..1.
    pub fn position(&self, v: f64) -> f64 {
        let (lo, hi) = self.range();
        ((v - lo) / (hi - lo)).clamp(0.0, 1.0)
    }

    /// The colour of `v` (clamped to the scale's range).
    pub fn color(&self, v: f64) -> RGBColor {
        let t = self.position(v);
        match self {
            ColorScale::Sequential { .. } => interpolate(&VIRIDIS, t),
            ColorScale::Diverging { .. } => interpolate(&DIVERGING, t),
        }
    }
}

/// A fraction as a percentage label for log axes: 1 → "100%", 0.001 → "0.1%".
pub fn percent_label(v: f64) -> String {
    let p = 100.0 * v;
    if !(p.is_finite() && p > 0.0) {
        return format!("{p}%");
    }
    let decimals = if p >= 1.0 {
        0
    } else {
        (-p.log10() - 1e-9).ceil() as usize
    };
    format!("{p:.decimals$}%")
}

/// Tick labels for values spaced about `step` apart: enough decimals to tell neighbours apart,
/// scientific notation for very large or small magnitudes.
pub fn tick_label(v: f64, step: f64) -> String {
    let a = v.abs().max(step.abs());
    if v.abs() < 1e-3 * step.abs() {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&a) {
        let digits = ((a.log10() - step.abs().log10()).ceil().max(0.0) as usize).min(6);
        return format!("{v:.digits$e}");
    }
    let decimals = (-(step.abs().log10()).floor() as i64).clamp(0, 8) as usize;
    format!("{v:.decimals$}")
}

// ---------------------------------------------------------------------------------------------
// Heat maps over the outgoing hemisphere

/// Values on a regular (θo, φo) raster of the outgoing hemisphere: `rows` bands of θo in
/// [0°, 90°] (row i centred on (i + ½)·90°/rows), `columns` of φo in [0°, 360°); NaN where
/// there is nothing to show.
#[derive(Debug, Clone)]
pub struct HemisphereMap {
    /// Number of θo bands.
    pub rows: usize,
    /// Number of φo columns.
    pub columns: usize,
    /// rows × columns values, row-major.
    pub values: Vec<f64>,
}

impl HemisphereMap {
    /// The centre (θo, φo) of every cell, row-major.
    pub fn centres(rows: usize, columns: usize) -> Vec<(f64, f64)> {
        let (dt, dp) = (90.0 / rows as f64, 360.0 / columns as f64);
        (0..rows)
            .flat_map(|i| (0..columns).map(move |j| ((i as f64 + 0.5) * dt, (j as f64 + 0.5) * dp)))
            .collect()
    }
}

/// One heat-map panel: a title, the map, its colour scale and labelled points to mark.
pub(crate) struct HeatPanel<'a> {
    pub(crate) title: String,
    pub(crate) map: &'a HemisphereMap,
    pub(crate) scale: ColorScale,
    pub(crate) marks: Vec<((f64, f64), String)>,
    /// Levels of colour in SVG output (cells of equal colour along a row are merged into one
    /// rectangle, which keeps files small); PNG uses every level.
    pub(crate) svg_levels: Option<usize>,
}

/// Draws a heat-map panel with its colour bar (unit 1/sr) into `area`.
pub(crate) fn draw_heat<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &HeatPanel,
) -> Result<()> {
    let err = |e| draw_error("a heat map", e);
    let (w, _) = area.dim_in_pixel();
    let bar_width = 92u32.min(w / 3);
    let (left, bar) = area.split_horizontally(w - bar_width);
    let mut chart = ChartBuilder::on(&left)
        .caption(&p.title, font(15.0))
        .margin(6)
        .margin_right(4)
        .x_label_area_size(34)
        .y_label_area_size(46)
        .build_cartesian_2d(0.0..360.0f64, 0.0..90.0f64)
        .map_err(err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("φo (degrees)")
        .y_desc("θo (degrees)")
        .x_labels(9)
        .y_labels(7)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style(font(12.0))
        .axis_desc_style(font(13.0))
        .draw()
        .map_err(err)?;
    let m = p.map;
    let (dt, dp) = (90.0 / m.rows as f64, 360.0 / m.columns as f64);
    // SVG: the colour level of a value (None for NaN), so that runs of one level merge.
    let level = |v: f64, n: usize| -> Option<usize> {
        v.is_finite()
            .then(|| (p.scale.position(v) * (n - 1) as f64).round() as usize)
    };
    let mut cells = Vec::new();
    for i in 0..m.rows {
        let row = &m.values[i * m.columns..(i + 1) * m.columns];
        let mut j = 0;
        while j < m.columns {
            let v = row[j];
            if !v.is_finite() {
                j += 1;
                continue;
            }
            let mut end = j + 1;
            let color = if let Some(n) = p.svg_levels {
                let l = level(v, n);
                while end < m.columns && level(row[end], n) == l {
                    end += 1;
                }
                let t = l.unwrap_or(0) as f64 / (n - 1) as f64;
                let (lo, hi) = p.scale.range();
                p.scale.color(lo + t * (hi - lo))
            } else {
                p.scale.color(v)
            };
            cells.push(Rectangle::new(
                [
                    (j as f64 * dp, i as f64 * dt),
                    (end as f64 * dp, (i + 1) as f64 * dt),
                ],
                color.filled(),
            ));
            j = end;
        }
    }
    chart.draw_series(cells).map_err(err)?;
    for ((t, ph), label) in &p.marks {
        let at = (wrap_phi(*ph), t.clamp(0.0, 90.0));
        // Labels above the mark, or below it near the top edge.
        let dy = if *t > 75.0 { 6 } else { -17 };
        chart
            .draw_series(std::iter::once(
                EmptyElement::at(at)
                    + Circle::new((0, 0), 5, WHITE.stroke_width(3))
                    + Circle::new((0, 0), 5, BLACK.stroke_width(1))
                    + Text::new(label.clone(), (7, dy + 1), font(13.0).color(&WHITE))
                    + Text::new(label.clone(), (6, dy), font(13.0)),
            ))
            .map_err(err)?;
    }
    draw_color_bar(&bar, p.scale, "1/sr")
}

/// A vertical colour bar with tick labels and its unit underneath.
pub(crate) fn draw_color_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: ColorScale,
    unit: &str,
) -> Result<()> {
    let err = |e| draw_error("a colour bar", e);
    let (lo, hi) = scale.range();
    let (_, h) = area.dim_in_pixel();
    let mut bar = ChartBuilder::on(area)
        .margin_top(30)
        .margin_bottom(40)
        .margin_left(2)
        .right_y_label_area_size(60)
        .build_cartesian_2d(0.0..1.0f64, lo..hi)
        .map_err(err)?;
    let step = (hi - lo) / 6.0;
    bar.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_formatter(&|v| tick_label(*v, step))
        .label_style(font(11.0))
        .draw()
        .map_err(err)?;
    let n = 64;
    bar.draw_series((0..n).map(|i| {
        let a = lo + (hi - lo) * i as f64 / n as f64;
        let b = lo + (hi - lo) * (i + 1) as f64 / n as f64;
        Rectangle::new([(0.0, a), (1.0, b)], scale.color(0.5 * (a + b)).filled())
    }))
    .map_err(err)?;
    area.draw(&Text::new(unit.to_string(), (4, h as i32 - 34), font(12.0)))
        .map_err(err)?;
    Ok(())
}
