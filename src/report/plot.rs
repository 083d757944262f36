//! `sbrdf plot`: what one record stores, as the paper's Figs. 2, 5 and 7 show it — one spectral
//! coefficient over the outgoing hemisphere, split into the SH background and the peak (the
//! lobes), beside the original samples' coefficient, and spectra at chosen outgoing directions.

use super::draw::*;
use crate::encode::fit::spectral_projection;
use crate::encode::samples::{IncidentSamples, SampleSet};
use crate::error::{Error, Result};
use crate::model::angles::{angle_between, dir_from_deg, dot, wrap_phi};
use crate::model::lobes::{cosine_power, microfacet_kind_variants};
use crate::model::material::{IncidentRecord, LobeKind, Material};
use crate::model::sh::{sh_count, ShBasis};
use crate::model::spectral::{SpectralBasis, SpectralSpace};
use crate::Decoder;
use plotters::coord::Shift;
use plotters::prelude::*;
use rayon::prelude::*;

/// What to plot: the incidence (the nearest stored record is shown), the spectral coefficient,
/// and outgoing directions for spectra (empty: the peak direction and three others at its θ,
/// 45°, 90° and 180° away in φ, as in the paper's Fig. 7).
#[derive(Debug, Clone, PartialEq)]
pub struct PlotOptions {
    /// The requested incidence (θi, φi), degrees.
    pub incident: (f64, f64),
    /// Index k of the spectral coefficient shown.
    pub coefficient: usize,
    /// Outgoing directions (θo, φo) for the spectrum panels, degrees.
    pub outgoing: Vec<(f64, f64)>,
    /// Picture kind: sets the raster (finer for PNG; coarser, with merged cells, for SVG).
    pub kind: ImageKind,
}

/// A spectrum panel: the reconstruction along the file's wavelengths, the original samples
/// where a reference was given, and their relative error.
#[derive(Debug, Clone)]
pub struct SpectrumPanel {
    /// The outgoing direction (θo, φo) shown, degrees (moved to the nearest reference sample
    /// when there is a reference).
    pub outgoing: (f64, f64),
    /// The panel's legend: its number, the direction, and whether it is the peak.
    pub label: String,
    /// Wavelengths (nm) of `reconstructed`: the file's range about every nm, plus the
    /// reference's wavelengths.
    pub wavelengths: Vec<f64>,
    /// The decoded ρ (1/sr) at `wavelengths`.
    pub reconstructed: Vec<f64>,
    /// (wavelengths, values) of the reference sample at this direction.
    pub original: Option<(Vec<f64>, Vec<f64>)>,
    /// sqrt(Σ(ρ̂ − ρ)² / Σρ²) over the reference's wavelengths.
    pub error: Option<f64>,
}

/// Everything `sbrdf plot` draws, computed (see [`coefficient_plot`]).
#[derive(Debug, Clone)]
pub struct CoefficientPlot {
    /// The picture's title: the file, coefficient, incidence and record.
    pub title: String,
    /// The record's model in one line: basis, terms, SH level, lobes, precision, stored error.
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
    /// The spectrum panels, one per outgoing direction.
    pub spectra: Vec<SpectrumPanel>,
    /// The record's lobe kinds joined by " + " ("no lobe" without).
    pub lobes: String,
    /// The record's SH level.
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
    crate::encode::metrics::rel(e, r)
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
                l.amplitude[k] as f64 * cosine_power(l.params[0] as f64, wo, peak)
            }
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 | LobeKind::MicrofacetAniso => {
                let v = microfacet_kind_variants(l.kind, &l.params, wi, wo);
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
    house_mesh(&mut chart)
        .x_desc("wavelength (nm)")
        .y_desc("ρ (1/sr)")
        .x_labels(5)
        .y_labels(6)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| tick_label(*v, step))
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
    draw_legend(&mut chart, corner, "a legend")?;
    Ok(())
}
