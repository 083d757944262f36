//! Pictures of a material and of the encoder's trade-offs, drawn with plotters into PNG or SVG.
//! Text uses a font compiled into the program (`assets/fonts/`), so output does not depend on
//! the fonts of the machine.
//!
//! * [`coefficient_plot`] (`sbrdf plot`): what one record stores, as the paper's Figs. 2, 5 and
//!   7 show it — one spectral coefficient over the outgoing hemisphere, split into the SH
//!   background and the peak (the lobes), beside the original samples' coefficient, and spectra
//!   at chosen outgoing directions.
//! * [`render_preview`] (`sbrdf preview`): a sphere under a point light, rendered spectrally.
//! * [`render`]: any [`Figure`] to PNG or SVG bytes, ready for
//!   [`crate::output::write_bytes_atomic`].

use crate::angles::{angle_between, dir_from_deg, dot, wrap_phi};
use crate::color::Illuminant;
use crate::error::{Error, Result};
use crate::fit::spectral_projection;
use crate::lobes::microfacet_variants_with;
use crate::material::{IncidentRecord, LobeKind, Material};
use crate::samples::{IncidentSamples, SampleSet};
use crate::sh::{sh_count, ShBasis};
use crate::spectral::{SpectralBasis, SpectralSpace};
use crate::Decoder;
use plotters::coord::Shift;
use plotters::prelude::*;
use rayon::prelude::*;
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

// ---------------------------------------------------------------------------------------------
// Rendering to bytes

/// Something drawn with plotters on any backend.
pub trait Figure {
    /// Width and height in pixels (SVG: user units).
    fn size(&self) -> (u32, u32);
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
const fn rgb(c: u32) -> RGBColor {
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
    Sequential { lo: f64, hi: f64 },
    /// Blue–white–red over [−m, m], white at 0: for values of both signs.
    Diverging { m: f64 },
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

    pub fn color(&self, v: f64) -> RGBColor {
        let t = self.position(v);
        match self {
            ColorScale::Sequential { .. } => interpolate(&VIRIDIS, t),
            ColorScale::Diverging { .. } => interpolate(&DIVERGING, t),
        }
    }
}

/// Tick labels for values spaced about `step` apart: enough decimals to tell neighbours apart,
/// scientific notation for very large or small magnitudes.
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
    pub rows: usize,
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
struct HeatPanel<'a> {
    title: String,
    map: &'a HemisphereMap,
    scale: ColorScale,
    marks: Vec<((f64, f64), String)>,
    /// Levels of colour in SVG output (cells of equal colour along a row are merged into one
    /// rectangle, which keeps files small); PNG uses every level.
    svg_levels: Option<usize>,
}

/// Draws a heat-map panel with its colour bar (unit 1/sr) into `area`.
fn draw_heat<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &HeatPanel) -> Result<()> {
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
fn draw_color_bar<DB: DrawingBackend>(
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

// ---------------------------------------------------------------------------------------------
// `sbrdf plot`: a record's coefficient over the hemisphere, and spectra

/// What to plot: the incidence (the nearest stored record is shown), the spectral coefficient,
/// and outgoing directions for spectra (empty: the peak direction and three others at its θ,
/// 45°, 90° and 180° away in φ, as in the paper's Fig. 7).
#[derive(Debug, Clone, PartialEq)]
pub struct PlotOptions {
    pub incident: (f64, f64),
    pub coefficient: usize,
    pub outgoing: Vec<(f64, f64)>,
    /// Picture kind: sets the raster (finer for PNG; coarser, with merged cells, for SVG).
    pub kind: ImageKind,
}

/// A spectrum panel: the reconstruction along the file's wavelengths, the original samples
/// where a reference was given, and their relative error.
#[derive(Debug, Clone)]
pub struct SpectrumPanel {
    pub outgoing: (f64, f64),
    pub label: String,
    pub wavelengths: Vec<f64>,
    pub reconstructed: Vec<f64>,
    /// (wavelengths, values) of the reference sample at this direction.
    pub original: Option<(Vec<f64>, Vec<f64>)>,
    /// sqrt(Σ(ρ̂ − ρ)² / Σρ²) over the reference's wavelengths.
    pub error: Option<f64>,
}

/// Everything `sbrdf plot` draws, computed (see [`coefficient_plot`]).
#[derive(Debug, Clone)]
pub struct CoefficientPlot {
    pub title: String,
    pub subtitle: String,
    /// The coefficient's name: a0, a1, b1, … for the paper's Fourier basis, c0, c1, … otherwise.
    pub name: String,
    /// Index of the record shown.
    pub record: usize,
    /// The full coefficient c_k(ωo) of the stored model: background + peak.
    pub full: HemisphereMap,
    /// Σ_j A(k, j)·Y_j(ωo): the SH part.
    pub background: HemisphereMap,
    /// Σ_m ℓ_m(k, ωo): what the record's lobes add.
    pub peak: HemisphereMap,
    /// The reference samples' coefficient (projected as the encoder projects), nearest sample
    /// per cell; NaN far from every sample.
    pub original: Option<HemisphereMap>,
    /// The record's peak direction (θp, φp).
    pub peak_direction: (f64, f64),
    pub spectra: Vec<SpectrumPanel>,
    pub lobes: String,
    pub sh_level: usize,
    svg_levels: Option<usize>,
}

/// The coefficient's conventional name.
pub fn coefficient_name(basis: SpectralBasis, k: usize) -> String {
    match basis {
        SpectralBasis::PeriodicFourier if k == 0 => "a0".into(),
        SpectralBasis::PeriodicFourier => {
            format!("{}{}", if k % 2 == 1 { "a" } else { "b" }, k.div_ceil(2))
        }
        _ => format!("c{k}"),
    }
}

/// The record nearest an incident direction: by θ alone for isotropic files (any φi is a
/// rotation of φi = 0), else by the angle between incident directions.
pub fn nearest_record(m: &Material, incident: (f64, f64)) -> usize {
    let mut best = (f64::NEG_INFINITY, 0);
    for (i, r) in m.records.iter().enumerate() {
        let score = if m.isotropic {
            -(r.theta_i as f64 - incident.0).abs()
        } else {
            dot(
                dir_from_deg(incident.0, incident.1),
                dir_from_deg(r.theta_i as f64, r.phi_i as f64),
            )
        };
        if score > best.0 {
            best = (score, i);
        }
    }
    best.1
}

/// The file's spectral space cut to a record's own terms.
fn record_space(space: &SpectralSpace, terms: usize) -> SpectralSpace {
    let mut s = space.clone();
    s.terms = terms;
    if let Some(t) = s.table.as_mut() {
        t.values.truncate(terms * t.nodes.len());
    }
    s
}

fn check_angle(what: &str, (t, p): (f64, f64)) -> Result<()> {
    if !(t.is_finite() && p.is_finite() && (0.0..=90.0).contains(&t)) {
        return Err(Error::Parameter(format!(
            "{what} ({t}, {p}): θ must lie in [0, 90] degrees"
        )));
    }
    Ok(())
}

fn fmt_deg(v: f64) -> String {
    let r = (v * 10.0).round() / 10.0;
    if r == r.trunc() {
        format!("{r:.0}°")
    } else {
        format!("{r:.1}°")
    }
}

fn fmt_dir((t, p): (f64, f64)) -> String {
    format!("({}, {})", fmt_deg(t), fmt_deg(wrap_phi(p)))
}

/// Relative L2 error of `approx` against `reference`.
fn rel_l2(approx: &[f64], reference: &[f64]) -> f64 {
    let e: f64 = approx
        .iter()
        .zip(reference)
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    let r: f64 = reference.iter().map(|b| b * b).sum();
    crate::fit::rel(e, r)
}

/// Computes what `sbrdf plot` draws for the record nearest `opts.incident`.
///
/// * Background: Σ_j A(k, j)·Y_j(ωo) from the record's SH coefficients.
/// * Peak: Σ_m ℓ_m(k, ωo), the record's lobes ([`lobes_value`]).
/// * Full coefficient: background + peak, c_k(ωo) of `spec/EVALUATION.md`, "Reconstruction".
///   (Not a projection of the decoded spectrum: the decoder clamps ρ at 0, which takes it out
///   of the span of the basis wherever the series undershoots.)
/// * Spectra: what the decoder returns (clamp included) at the record's own incidence.
/// * Original (with a reference): each sample spectrum projected as the encoder projects it
///   (the paper's Eq. 5 for the periodic Fourier basis, least squares otherwise), shown by
///   nearest sample.
///
/// The reference must hold the record's incidence; spectra directions are moved to the
/// reference's nearest sample direction so that original and reconstruction are compared at the
/// same direction.
pub fn coefficient_plot(
    dec: &Decoder,
    name: &str,
    reference: Option<&SampleSet>,
    opts: &PlotOptions,
) -> Result<CoefficientPlot> {
    check_angle("--incident", opts.incident)?;
    for &o in &opts.outgoing {
        check_angle("--outgoing", o)?;
    }
    let m = dec.material();
    let ri = nearest_record(m, opts.incident);
    let rec = &m.records[ri];
    let k = opts.coefficient;
    if k >= rec.terms {
        return Err(Error::Parameter(format!(
            "--coefficient {k}: the record at θi = {}°, φi = {}° has {} spectral terms \
             (coefficients 0..={})",
            rec.theta_i,
            rec.phi_i,
            rec.terms,
            rec.terms - 1
        )));
    }
    let inc = (rec.theta_i as f64, rec.phi_i as f64);
    let samples = match reference {
        Some(set) => Some(reference_incidence(set, inc)?),
        None => None,
    };
    let (rows, columns, svg_levels) = match opts.kind {
        ImageKind::Png => (90, 180, None),
        ImageKind::Svg => (45, 120, Some(48)),
    };
    let cells = HemisphereMap::centres(rows, columns);
    let space = record_space(&m.spectral, rec.terms);
    let sh = ShBasis::new(rec.sh_level);
    let p = sh_count(rec.sh_level);
    let a_k = &rec.sh[k * p..(k + 1) * p];
    let wi = dir_from_deg(inc.0, inc.1);
    let values: Vec<(f64, f64, f64)> = cells
        .par_iter()
        .map_init(
            || vec![0.0; p],
            |y, &(t, ph)| {
                let wo = dir_from_deg(t, ph);
                sh.eval(wo, y);
                let bg: f64 = a_k.iter().zip(y.iter()).map(|(a, b)| *a as f64 * b).sum();
                let peak = lobes_value(rec, k, wi, wo);
                (bg + peak, bg, peak)
            },
        )
        .collect();
    let map = |f: &dyn Fn(&(f64, f64, f64)) -> f64| HemisphereMap {
        rows,
        columns,
        values: values.iter().map(f).collect(),
    };
    let full = map(&|v| v.0);
    let background = map(&|v| v.1);
    let peak = map(&|v| v.2);
    let original = samples
        .map(|s| original_map(s, &reference.unwrap().wavelengths, &space, k, rows, columns))
        .transpose()?;
    let peak_direction = (rec.theta_p as f64, rec.phi_p as f64);
    let directions = if opts.outgoing.is_empty() {
        default_directions(peak_direction)
    } else {
        opts.outgoing.clone()
    };
    let spectra = directions
        .iter()
        .enumerate()
        .map(|(i, &d)| spectrum_panel(dec, inc, d, i, peak_direction, samples, reference))
        .collect();
    let lobes = if rec.lobes.is_empty() {
        "no lobe".to_string()
    } else {
        rec.lobes
            .iter()
            .map(|l| l.kind.name())
            .collect::<Vec<_>>()
            .join(" + ")
    };
    let name_k = coefficient_name(m.spectral.basis, k);
    let requested = fmt_dir(opts.incident);
    let stored = fmt_dir(inc);
    let exact = if m.isotropic {
        rec.theta_i as f64 == opts.incident.0
    } else {
        inc == (opts.incident.0, wrap_phi(opts.incident.1))
    };
    let mut at = if exact {
        "stored at the requested incidence".to_string()
    } else {
        format!("the stored incidence nearest to the requested {requested}")
    };
    if m.isotropic {
        at += "; isotropic, shown at φi = 0°";
    }
    Ok(CoefficientPlot {
        title: format!(
            "{name}: coefficient {name_k} at θi, φi = {stored}, record {} of {} ({at})",
            ri + 1,
            m.records.len()
        ),
        subtitle: format!(
            "{} basis, {} terms; SH level {}; {}; {}; stored error {:.2}%",
            m.spectral.basis.name(),
            rec.terms,
            rec.sh_level,
            lobes,
            rec.precision.name(),
            100.0 * rec.rel_error as f64
        ),
        name: name_k,
        record: ri,
        full,
        background,
        peak,
        original,
        peak_direction,
        spectra,
        lobes,
        sh_level: rec.sh_level,
        svg_levels,
    })
}

/// The reference's samples at a record's incidence, or an error that lists what it has.
fn reference_incidence(set: &SampleSet, inc: (f64, f64)) -> Result<&IncidentSamples> {
    set.incidences
        .iter()
        .find(|s| (s.theta_i - inc.0).abs() < 1e-3 && (s.phi_i - inc.1).abs() < 1e-3)
        .ok_or_else(|| {
            let have: Vec<String> = set
                .incidences
                .iter()
                .map(|s| fmt_dir((s.theta_i, s.phi_i)))
                .collect();
            Error::Parameter(format!(
                "the reference has no samples at the plotted record's incidence {}; it has {}",
                fmt_dir(inc),
                have.join(", ")
            ))
        })
}

/// Σ over the record's lobes of their contribution ℓ(k, ωo) to spectral coefficient `k`
/// (`spec/EVALUATION.md`, "Lobes"), evaluated for the record alone at its own incidence `wi`
/// (unit vectors in the record's frame).
pub fn lobes_value(rec: &IncidentRecord, k: usize, wi: [f64; 3], wo: [f64; 3]) -> f64 {
    let t = rec.terms;
    let peak = dir_from_deg(rec.theta_p as f64, rec.phi_p as f64);
    rec.lobes
        .iter()
        .map(|l| match l.kind {
            LobeKind::AngleGaussian => {
                let a = angle_between(wo, peak);
                l.amplitude[k] as f64 * (-a * a / l.params[k] as f64).exp()
            }
            LobeKind::CosinePower => {
                let g = dot(wo, peak).clamp(0.0, 1.0);
                l.amplitude[k] as f64 * g.powf(l.params[0] as f64)
            }
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 => {
                let v =
                    microfacet_variants_with(&l.params, wi, wo, l.kind == LobeKind::MicrofacetSin2);
                (0..4).map(|j| l.amplitude[j * t + k] as f64 * v[j]).sum()
            }
        })
        .sum()
}

/// The paper's Fig. 7 choice: the peak, then its θ at 45°, 90° and 180° from it in φ (at the
/// normal, where φ means nothing, θ = 30° instead; at most 75°, away from the horizon).
fn default_directions(peak: (f64, f64)) -> Vec<(f64, f64)> {
    let t = if peak.0 < 5.0 { 30.0 } else { peak.0.min(75.0) };
    vec![
        peak,
        (t, wrap_phi(peak.1 - 45.0)),
        (t, wrap_phi(peak.1 - 90.0)),
        (t, wrap_phi(peak.1 - 180.0)),
    ]
}

/// Index of the sample direction nearest (θ, φ).
fn nearest_sample(dirs: &[[f64; 3]], d: [f64; 3]) -> (usize, f64) {
    let mut best = (0, f64::NEG_INFINITY);
    for (i, v) in dirs.iter().enumerate() {
        let c = dot(*v, d);
        if c > best.1 {
            best = (i, c);
        }
    }
    best
}

/// The reference samples' coefficient k on the raster, by nearest sample; cells farther from
/// every sample than twice the typical sample spacing (at least 3°) are left empty.
fn original_map(
    s: &IncidentSamples,
    wavelengths: &[f64],
    space: &SpectralSpace,
    k: usize,
    rows: usize,
    columns: usize,
) -> Result<HemisphereMap> {
    let proj = spectral_projection(space, wavelengths);
    let w = wavelengths.len();
    let coef: Vec<f64> = s
        .values
        .chunks(w)
        .map(|spec| (0..w).map(|i| proj[(k, i)] * spec[i]).sum())
        .collect();
    let dirs: Vec<[f64; 3]> = s
        .directions
        .iter()
        .map(|d| dir_from_deg(d[0], d[1]))
        .collect();
    // Typical spacing: the median angle from a sample to its nearest neighbour.
    let mut nn: Vec<f64> = (0..dirs.len())
        .into_par_iter()
        .map(|i| {
            let mut best = f64::NEG_INFINITY;
            for (j, v) in dirs.iter().enumerate() {
                if j != i {
                    best = best.max(dot(dirs[i], *v));
                }
            }
            best.clamp(-1.0, 1.0).acos().to_degrees()
        })
        .collect();
    nn.sort_by(f64::total_cmp);
    let spacing = nn.get(nn.len() / 2).copied().unwrap_or(90.0);
    let limit = (2.0 * spacing).max(3.0).to_radians().cos();
    let values = HemisphereMap::centres(rows, columns)
        .par_iter()
        .map(|&(t, p)| {
            let (i, c) = nearest_sample(&dirs, dir_from_deg(t, p));
            if c >= limit {
                coef[i]
            } else {
                f64::NAN
            }
        })
        .collect();
    Ok(HemisphereMap {
        rows,
        columns,
        values,
    })
}

fn spectrum_panel(
    dec: &Decoder,
    inc: (f64, f64),
    asked: (f64, f64),
    index: usize,
    peak: (f64, f64),
    samples: Option<&IncidentSamples>,
    reference: Option<&SampleSet>,
) -> SpectrumPanel {
    let m = dec.material();
    let (mut at, mut original) = (asked, None);
    if let (Some(s), Some(set)) = (samples, reference) {
        let dirs: Vec<[f64; 3]> = s
            .directions
            .iter()
            .map(|d| dir_from_deg(d[0], d[1]))
            .collect();
        let (i, _) = nearest_sample(&dirs, dir_from_deg(asked.0, asked.1));
        at = (s.directions[i][0], s.directions[i][1]);
        let w = set.wavelengths.len();
        original = Some((
            set.wavelengths.clone(),
            s.values[i * w..(i + 1) * w].to_vec(),
        ));
    }
    // The reconstruction along the file's range, every nm or so (at least the file's samples).
    let (lo, hi) = (
        m.wavelengths[0] as f64,
        *m.wavelengths.last().unwrap() as f64,
    );
    let n = ((hi - lo).ceil() as usize + 1).clamp(2, 2001);
    let mut wavelengths: Vec<f64> = if hi > lo {
        (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect()
    } else {
        vec![lo]
    };
    if let Some((wl, _)) = &original {
        wavelengths.extend(wl.iter().copied());
        wavelengths.sort_by(f64::total_cmp);
        wavelengths.dedup();
    }
    let mut reconstructed = vec![0.0; wavelengths.len()];
    dec.eval_deg(inc, at, &wavelengths, &mut reconstructed);
    let error = original.as_ref().map(|(wl, v)| {
        let mut r = vec![0.0; wl.len()];
        dec.eval_deg(inc, at, wl, &mut r);
        rel_l2(&r, v)
    });
    let near = |d: (f64, f64)| dot(dir_from_deg(d.0, d.1), dir_from_deg(peak.0, peak.1)) > 0.99999;
    let suffix = if near(at) {
        ", the peak"
    } else if near(asked) {
        ", the sample nearest the peak"
    } else {
        ""
    };
    let label = format!("{}: ωo = {}{suffix}", index + 1, fmt_dir(at));
    SpectrumPanel {
        outgoing: at,
        label,
        wavelengths,
        reconstructed,
        original,
        error,
    }
}

impl Figure for CoefficientPlot {
    fn size(&self) -> (u32, u32) {
        (1600, 980)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let err = |e| draw_error("the plot", e);
        root.fill(&WHITE).map_err(err)?;
        let (head, rest) = root.split_vertically(56);
        head.draw(&Text::new(self.title.clone(), (12, 6), font(17.0)))
            .map_err(err)?;
        head.draw(&Text::new(
            self.subtitle.clone(),
            (12, 30),
            font(14.0).color(&RGBColor(70, 70, 70)),
        ))
        .map_err(err)?;
        let (maps, bottom) = rest.split_vertically(560);
        let quads = maps.split_evenly((2, 2));
        let n = &self.name;
        let marks: Vec<((f64, f64), String)> = self
            .spectra
            .iter()
            .enumerate()
            .map(|(i, s)| (s.outgoing, format!("{}", i + 1)))
            .collect();
        let shared = match &self.original {
            Some(o) => ColorScale::fit_both(&o.values, &self.full.values),
            None => ColorScale::fit(&self.full.values),
        };
        let full_panel = HeatPanel {
            title: format!("{n} reconstructed = background + peak"),
            map: &self.full,
            scale: shared,
            marks: marks.clone(),
            svg_levels: self.svg_levels,
        };
        let background_panel = HeatPanel {
            title: format!("{n} SH background (level {})", self.sh_level),
            map: &self.background,
            scale: ColorScale::fit(&self.background.values),
            marks: Vec::new(),
            svg_levels: self.svg_levels,
        };
        let peak_panel = HeatPanel {
            title: format!("{n} peak part: {}", self.lobes),
            map: &self.peak,
            scale: ColorScale::fit(&self.peak.values),
            marks: vec![(self.peak_direction, "peak".into())],
            svg_levels: self.svg_levels,
        };
        match &self.original {
            Some(o) => {
                let panel = HeatPanel {
                    title: format!("{n} of the original samples (same colour scale)"),
                    map: o,
                    scale: shared,
                    marks: marks.clone(),
                    svg_levels: self.svg_levels,
                };
                draw_heat(&quads[0], &panel)?;
                draw_heat(&quads[1], &full_panel)?;
            }
            None => {
                draw_heat(&quads[0], &full_panel)?;
                quads[1]
                    .draw(&Text::new(
                        "No reference given: add --reference INPUT to show the original samples.",
                        (30, 120),
                        font(15.0).color(&RGBColor(90, 90, 90)),
                    ))
                    .map_err(err)?;
            }
        }
        draw_heat(&quads[2], &background_panel)?;
        if self.peak.values.iter().all(|v| v.abs() < 1e-300) {
            quads[3]
                .draw(&Text::new(
                    "This record has no lobe: the background is the whole coefficient.",
                    (30, 120),
                    font(15.0).color(&RGBColor(90, 90, 90)),
                ))
                .map_err(err)?;
        } else {
            draw_heat(&quads[3], &peak_panel)?;
        }
        let count = self.spectra.len().max(1);
        let panels = bottom.split_evenly((1, count));
        for (s, area) in self.spectra.iter().zip(panels.iter()) {
            draw_spectrum(area, s)?;
        }
        Ok(())
    }
}

fn draw_spectrum<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    s: &SpectrumPanel,
) -> Result<()> {
    let err = |e| draw_error("a spectrum", e);
    let mut lo = 0.0f64;
    let mut hi = f64::NEG_INFINITY;
    for v in s
        .reconstructed
        .iter()
        .chain(s.original.iter().flat_map(|o| o.1.iter()))
    {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        hi = lo + 1.0;
    }
    let pad = 0.08 * (hi - lo);
    let step = (hi - lo) / 6.0;
    let (x0, x1) = (
        s.wavelengths[0],
        s.wavelengths[s.wavelengths.len() - 1].max(s.wavelengths[0] + 1.0),
    );
    let mut chart = ChartBuilder::on(area)
        .caption(&s.label, font(14.0))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(58)
        .build_cartesian_2d(x0..x1, (lo - if lo < 0.0 { pad } else { 0.0 })..(hi + pad))
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("wavelength (nm)")
        .y_desc("ρ (1/sr)")
        .x_labels(5)
        .y_labels(6)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| tick_label(*v, step))
        .label_style(font(12.0))
        .axis_desc_style(font(13.0))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()
        .map_err(err)?;
    let blue = SERIES_COLORS[0];
    chart
        .draw_series(LineSeries::new(
            s.wavelengths
                .iter()
                .copied()
                .zip(s.reconstructed.iter().copied()),
            blue.stroke_width(2),
        ))
        .map_err(err)?
        .label("reconstructed")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], blue.stroke_width(2)));
    if let Some((wl, v)) = &s.original {
        let orange = SERIES_COLORS[1];
        let label = match s.error {
            Some(e) if e < 0.01 => format!("original (error {:.2}%)", 100.0 * e),
            Some(e) => format!("original (error {:.1}%)", 100.0 * e),
            None => "original".into(),
        };
        chart
            .draw_series(
                wl.iter()
                    .zip(v)
                    .map(|(&x, &y)| Circle::new((x, y), 3, orange.filled())),
            )
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| Circle::new((x + 9, y), 3, orange.filled()));
    }
    // The legend goes in the right-hand corner the curves leave free.
    let tail = s.reconstructed[s.reconstructed.len() * 3 / 4..]
        .iter()
        .fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    let corner = if tail > lo + 0.55 * (hi - lo) {
        SeriesLabelPosition::LowerRight
    } else {
        SeriesLabelPosition::UpperRight
    };
    chart
        .configure_series_labels()
        .position(corner)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .label_font(font(12.0))
        .draw()
        .map_err(err)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// `sbrdf preview`: a sphere under a point light

/// A sphere seen from the camera, lit by a point light of D65's spectrum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreviewOptions {
    /// Width and height of the picture in pixels.
    pub size: u32,
    /// Direction toward the light in the camera's frame, degrees: θ from the viewing direction
    /// (0 = light at the camera), φ counter-clockwise from the picture's right.
    pub light: (f64, f64),
}

impl Default for PreviewOptions {
    fn default() -> Self {
        PreviewOptions {
            size: 256,
            light: (45.0, 135.0),
        }
    }
}

/// A rendered preview: 8-bit sRGB pixels, row-major, top row first.
#[derive(Debug, Clone)]
pub struct Preview {
    pub size: u32,
    pub rgb: Vec<u8>,
    /// The factor applied to luminance (Y in units where a white Lambertian surface lit head-on
    /// by the light has Y = 1) before the tone curve.
    pub exposure: f64,
    /// Pixel (column, row) of the sphere point whose normal is the half vector of light and
    /// camera: where a mirror-like highlight sits.
    pub highlight: (u32, u32),
}

impl Preview {
    pub fn png(&self) -> Result<Vec<u8>> {
        encode_png(&self.rgb, self.size, self.size)
    }
}

/// The background, sRGB-encoded.
const PREVIEW_BACKGROUND: [u8; 3] = [46, 48, 54];

fn srgb_encode(linear: f64) -> u8 {
    let v = linear.clamp(0.0, 1.0);
    let e = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0).round() as u8
}

fn srgb_decode(c: u8) -> f64 {
    let v = c as f64 / 255.0;
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Renders a sphere with the file's BRDF (orthographic camera, sphere filling 90% of the
/// picture, 2×2 samples per pixel). Radiance per sample is ρ(ωi, ωo)·cos θi under a point light
/// of D65's spectrum (XYZ by the CIE 1931 observer, then linear sRGB); incident directions
/// between stored incidences are interpolated by the decoder. Each point's tangent frame has
/// its x axis along the sphere's horizontal circle (it matters for anisotropic files only).
///
/// Exposure is automatic: the luminance of the lit sphere's median sample is brought to 0.3,
/// within limits that keep the brightest (99.9th percentile) sample between 1 and 8; the
/// extended Reinhard curve then maps that brightest sample to white, compressing highlights
/// smoothly (it is the identity when the exposure is the lower limit), hue preserved. Then the
/// sRGB transfer curve. The background is a dark grey; the unlit side stays black.
pub fn render_preview(dec: &Decoder, o: &PreviewOptions) -> Result<Preview> {
    if !(16..=4096).contains(&o.size) {
        return Err(Error::Parameter(format!(
            "--size {} is outside 16..=4096 pixels",
            o.size
        )));
    }
    let (lt, lp) = o.light;
    if !(lt.is_finite() && lp.is_finite() && (0.0..=90.0).contains(&lt)) {
        return Err(Error::Parameter(format!(
            "--light ({lt}, {lp}): θ must lie in [0, 90] degrees from the viewing direction"
        )));
    }
    let n = o.size as usize;
    let ss = 2usize;
    let light = dir_from_deg(lt, lp);
    let view = [0.0, 0.0, 1.0];
    let radius = 0.9;
    // Linear sRGB radiance per sub-sample; None off the sphere.
    let sub = n * ss;
    let samples: Vec<Option<[f64; 3]>> = (0..sub * sub)
        .into_par_iter()
        .map(|i| {
            let (row, col) = (i / sub, i % sub);
            let x = ((col as f64 + 0.5) / sub as f64 * 2.0 - 1.0) / radius;
            let y = (1.0 - (row as f64 + 0.5) / sub as f64 * 2.0) / radius;
            let r2 = x * x + y * y;
            if r2 >= 1.0 {
                return None;
            }
            let normal = [x, y, (1.0 - r2).sqrt()];
            let cos_i = dot(normal, light);
            if cos_i <= 0.0 {
                return Some([0.0; 3]);
            }
            // Tangent along the horizontal circle: up × normal, normalised.
            let t =
                crate::angles::normalize([normal[2], 0.0, -normal[0]]).unwrap_or([1.0, 0.0, 0.0]);
            let b = [
                normal[1] * t[2] - normal[2] * t[1],
                normal[2] * t[0] - normal[0] * t[2],
                normal[0] * t[1] - normal[1] * t[0],
            ];
            let local = |v: [f64; 3]| [dot(v, t) as f32, dot(v, b) as f32, dot(v, normal) as f32];
            let c = dec.eval_linear_srgb(local(light), local(view), Illuminant::D65);
            Some([c[0] * cos_i, c[1] * cos_i, c[2] * cos_i])
        })
        .collect();
    let lum = |c: &[f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let mut lit: Vec<f64> = samples
        .iter()
        .flatten()
        .map(lum)
        .filter(|&l| l > 0.0 && l.is_finite())
        .collect();
    lit.sort_by(f64::total_cmp);
    let (exposure, white) = if lit.is_empty() {
        (1.0, 1.0)
    } else {
        let median = lit[lit.len() / 2];
        let top = lit[((lit.len() - 1) as f64 * 0.999) as usize];
        let s = (0.3 / median).clamp(1.0 / top, 8.0 / top);
        (s, (s * top).max(1.0))
    };
    let background = PREVIEW_BACKGROUND.map(srgb_decode);
    let tone = |c: [f64; 3]| -> [f64; 3] {
        let c = c.map(|v| {
            if v.is_finite() {
                v.max(0.0) * exposure
            } else {
                0.0
            }
        });
        let l = lum(&c);
        if l <= 0.0 {
            return c;
        }
        let mapped = l * (1.0 + l / (white * white)) / (1.0 + l);
        let f = mapped / l;
        c.map(|v| (v * f).min(1.0))
    };
    let mut rgb = vec![0u8; n * n * 3];
    rgb.par_chunks_mut(n * 3)
        .enumerate()
        .for_each(|(row, out)| {
            for col in 0..n {
                let mut acc = [0.0; 3];
                for dy in 0..ss {
                    for dx in 0..ss {
                        let s = samples[(row * ss + dy) * sub + col * ss + dx];
                        let c = match s {
                            Some(c) => tone(c),
                            None => background,
                        };
                        for (a, v) in acc.iter_mut().zip(c) {
                            *a += v;
                        }
                    }
                }
                for (o, a) in out[col * 3..col * 3 + 3].iter_mut().zip(acc) {
                    *o = srgb_encode(a / (ss * ss) as f64);
                }
            }
        });
    let h = crate::angles::normalize([light[0], light[1], light[2] + 1.0]).unwrap_or(view);
    let px = |v: f64| (((v * radius + 1.0) / 2.0) * n as f64).clamp(0.0, n as f64 - 1.0) as u32;
    let highlight = (px(h[0]), px(-h[1]));
    Ok(Preview {
        size: o.size,
        rgb,
        exposure,
        highlight,
    })
}
