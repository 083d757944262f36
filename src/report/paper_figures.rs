//! `sbrdf paper-figures`: the data (CSV) and plots (SVG) of Xu & Sun's Figs. 4, 6 and 7,
//! recomputed from the shipped ColorChecker spectra, the paper's method beside the defaults.
//!
//! The setup is the paper's Sec. 3: a Phong BRDF ρ = kd·green(λ) + ks·white(λ)·cosⁿα (α from
//! the mirror direction, kd = 1), 400–700 nm every 10 nm, outgoing θo = 2.5…87.5° × φo = 0…355°
//! every 5°, incidence (15°, 0°), 13 periodic Fourier terms.
//!
//! * Fig. 4: relative error against ks/kd and n for the paper's baseline (direct SH, L = 4),
//!   its hybrid method ("paper mode": SH level 1 + Gaussian peak, automatic critical angle,
//!   f32) and the default mode (data-derived basis, joint fit, 0.5% budget, f16).
//! * Fig. 6: paper mode's error against a fixed critical angle γ, with the default mode's
//!   error (it has no critical angle) as a dashed line of the same colour.
//! * Fig. 7: original and reconstructed spectra at ωo = (15°, 180°) (the peak), (15°, 135°),
//!   (15°, 90°) and (15°, 0°) for ks/kd = 15, n = 15, against the errors the paper prints.
//!
//! Errors are relative L2 over every sample (Fig. 4, 6) or over one spectrum (Fig. 7); bytes
//! are whole files without sample positions.

use crate::encode::encoder::{encode, EncodeOptions, Encoded};
use crate::encode::fit::{CriticalAngle, PeakMode};
use crate::encode::samples::SampleSet;
use crate::error::Result;
use crate::io::output::{ensure_output_folder, write_bytes_atomic};
use crate::io::synth::{paper_grid, sample_material, Phong};
use crate::report::draw::{
    draw_error, draw_legend, font, house_mesh, percent_label, render, tick_label, Figure,
    ImageKind, SERIES_COLORS,
};
use crate::Decoder;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How much to compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PaperFiguresOptions {
    /// Fewer materials and critical angles (for tests): Fig. 4 at ks/kd = 15 and n = 15, 200;
    /// Fig. 6 for those two and γ every 8°. Fig. 7 is the same either way.
    pub quick: bool,
}

/// What was written.
#[derive(Debug, Clone)]
pub struct PaperFigures {
    /// The markdown table (also `table.md`).
    pub table: String,
    /// The paths of every file written.
    pub files: Vec<PathBuf>,
}

/// The incident direction of the paper's study.
pub const INCIDENCE: (f64, f64) = (15.0, 0.0);
/// The outgoing directions of the paper's Fig. 7 (a)–(d), and the errors it prints for them.
pub const FIG7: [((f64, f64), f64); 4] = [
    ((15.0, 180.0), 0.048),
    ((15.0, 135.0), 0.025),
    ((15.0, 90.0), 0.028),
    ((15.0, 0.0), 0.03),
];

fn wavelengths() -> Vec<f64> {
    (0..31).map(|i| 400.0 + 10.0 * i as f64).collect()
}

fn phong(ks: f64, n: f64) -> Result<Phong> {
    Phong::colorchecker("green", "white", (1.0, ks, n), &wavelengths())
}

fn samples(p: &Phong) -> SampleSet {
    sample_material(
        &wavelengths(),
        &[INCIDENCE],
        &paper_grid(5.0, 5.0),
        |i, o, w| p.value(i, o, w),
    )
}

fn options(base: EncodeOptions) -> EncodeOptions {
    EncodeOptions {
        sample_positions: false,
        ..base
    }
}

/// The paper's baseline: SH only, level 4, 13 Fourier terms, f32.
pub fn direct_options() -> EncodeOptions {
    options(EncodeOptions {
        peak: PeakMode::None,
        sh_level: Some(4),
        ..EncodeOptions::paper()
    })
}

/// Error and size of one encode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// Relative L2 error over the input's samples.
    pub error: f64,
    /// Size of the written file, bytes.
    pub bytes: usize,
    /// The record's critical angle (paper mode), degrees.
    pub critical_angle: f64,
}

fn outcome(e: &Encoded) -> Result<Outcome> {
    Ok(Outcome {
        error: e.rel_error,
        bytes: crate::write_material(&e.material)?.len(),
        critical_angle: e.material.records[0].critical_angle as f64,
    })
}

/// One Fig. 4 material in the three modes.
#[derive(Debug, Clone)]
pub struct Fig4Row {
    /// The Phong material's ks (with kd = 1).
    pub ks: f64,
    /// The Phong exponent n.
    pub n: f64,
    /// SH only ([`direct_options`]).
    pub direct: Outcome,
    /// The paper's method ([`EncodeOptions::paper`]).
    pub paper: Outcome,
    /// The encoder's defaults.
    pub default: Outcome,
}

/// One Fig. 6 curve.
#[derive(Debug, Clone)]
pub struct Fig6Curve {
    /// The Phong material's ks (with kd = 1).
    pub ks: f64,
    /// The Phong exponent n.
    pub n: f64,
    /// (γ, paper-mode error); γ the encoder refuses (too few background samples) are left out.
    pub points: Vec<(f64, f64)>,
    /// The error of the encoder's defaults on the same material, for comparison.
    pub default_error: f64,
}

/// One Fig. 7 direction: the original spectrum and both reconstructions at the 31 samples,
/// and the reconstructions every 2 nm for drawing.
#[derive(Debug, Clone)]
pub struct Fig7Panel {
    /// The outgoing direction (θo, φo), degrees.
    pub outgoing: (f64, f64),
    /// The error the paper prints for this direction.
    pub published: f64,
    /// The material's spectrum at the 31 wavelengths (400–700 nm every 10 nm), 1/sr.
    pub original: Vec<f64>,
    /// The paper's method's reconstruction at those wavelengths.
    pub paper: Vec<f64>,
    /// The default encoder's reconstruction at those wavelengths.
    pub default: Vec<f64>,
    /// The paper's method's reconstruction every 2 nm from 400 to 700 nm.
    pub paper_dense: Vec<f64>,
    /// The default encoder's reconstruction every 2 nm from 400 to 700 nm.
    pub default_dense: Vec<f64>,
    /// Relative L2 error of `paper` against `original`.
    pub paper_error: f64,
    /// Relative L2 error of `default` against `original`.
    pub default_error: f64,
}

/// Everything computed, before writing.
#[derive(Debug, Clone)]
pub struct PaperData {
    /// Fig. 4: one row per material.
    pub fig4: Vec<Fig4Row>,
    /// Fig. 6: error against critical angle, one curve per material.
    pub fig6: Vec<Fig6Curve>,
    /// Fig. 7: the four directions of [`FIG7`].
    pub fig7: Vec<Fig7Panel>,
    /// Paper mode's automatic critical angle for the Fig. 7 material.
    pub fig7_critical_angle: f64,
}

fn grid(quick: bool) -> (Vec<f64>, Vec<f64>) {
    if quick {
        (vec![15.0], vec![15.0, 200.0])
    } else {
        (
            vec![0.5, 1.0, 5.0, 15.0, 30.0],
            vec![1.0, 5.0, 15.0, 50.0, 200.0, 1000.0],
        )
    }
}

fn fig6_materials(quick: bool) -> Vec<(f64, f64)> {
    if quick {
        vec![(15.0, 15.0), (15.0, 200.0)]
    } else {
        [5.0, 15.0]
            .iter()
            .flat_map(|&ks| [15.0, 50.0, 200.0].map(|n| (ks, n)))
            .collect()
    }
}

fn relative(a: &[f64], b: &[f64]) -> f64 {
    let e: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    let r: f64 = b.iter().map(|y| y * y).sum();
    crate::encode::metrics::rel(e, r)
}

/// Computes the three figures' data (in parallel over materials).
pub fn compute(opts: &PaperFiguresOptions) -> Result<PaperData> {
    let (ks_list, n_list) = grid(opts.quick);
    let mut materials: Vec<(f64, f64)> = ks_list
        .iter()
        .flat_map(|&ks| n_list.iter().map(move |&n| (ks, n)))
        .collect();
    if !materials.contains(&(15.0, 15.0)) {
        materials.push((15.0, 15.0)); // Fig. 7's material
    }
    let encoded: Vec<(Fig4Row, Option<(Encoded, Encoded)>)> = materials
        .par_iter()
        .map(|&(ks, n)| -> Result<_> {
            let set = samples(&phong(ks, n)?);
            let direct = encode(&set, &direct_options())?;
            let paper = encode(&set, &options(EncodeOptions::paper()))?;
            let default = encode(&set, &options(EncodeOptions::default()))?;
            let row = Fig4Row {
                ks,
                n,
                direct: outcome(&direct)?,
                paper: outcome(&paper)?,
                default: outcome(&default)?,
            };
            let keep = ((ks, n) == (15.0, 15.0)).then_some((paper, default));
            Ok((row, keep))
        })
        .collect::<Result<_>>()?;
    let mut fig4 = Vec::new();
    let mut fig7_models = None;
    for (row, keep) in encoded {
        if keep.is_some() {
            fig7_models = keep;
        }
        if ks_list.contains(&row.ks) && n_list.contains(&row.n) {
            fig4.push(row);
        }
    }
    let (paper7, default7) = fig7_models.expect("Fig. 7's material is always encoded");

    let step = if opts.quick { 8.0 } else { 2.0 };
    let angles: Vec<f64> = (0..)
        .map(|i| 1.0 + step * i as f64)
        .take_while(|&g| g <= 89.0)
        .collect();
    let fig6 = fig6_materials(opts.quick)
        .par_iter()
        .map(|&(ks, n)| -> Result<Fig6Curve> {
            let set = samples(&phong(ks, n)?);
            let points = angles
                .iter()
                .filter_map(|&g| {
                    let o = options(EncodeOptions {
                        critical_angle: CriticalAngle::Fixed(g),
                        ..EncodeOptions::paper()
                    });
                    encode(&set, &o).ok().map(|e| (g, e.rel_error))
                })
                .collect();
            let default_error = match fig4.iter().find(|r| (r.ks, r.n) == (ks, n)) {
                Some(r) => r.default.error,
                None => encode(&set, &options(EncodeOptions::default()))?.rel_error,
            };
            Ok(Fig6Curve {
                ks,
                n,
                points,
                default_error,
            })
        })
        .collect::<Result<_>>()?;

    let p = phong(15.0, 15.0)?;
    let wl = wavelengths();
    let dense: Vec<f64> = (0..=150).map(|i| 400.0 + 2.0 * i as f64).collect();
    let paper_dec = Decoder::from_material(paper7.material.clone())?;
    let default_dec = Decoder::from_material(default7.material)?;
    let eval = |d: &Decoder, o: (f64, f64), at: &[f64]| {
        let mut v = vec![0.0; at.len()];
        d.eval_deg(INCIDENCE, o, at, &mut v);
        v
    };
    let fig7 = FIG7
        .iter()
        .map(|&(o, published)| {
            let original: Vec<f64> = (0..wl.len()).map(|w| p.value(INCIDENCE, o, w)).collect();
            let paper = eval(&paper_dec, o, &wl);
            let default = eval(&default_dec, o, &wl);
            Fig7Panel {
                outgoing: o,
                published,
                paper_error: relative(&paper, &original),
                default_error: relative(&default, &original),
                paper_dense: eval(&paper_dec, o, &dense),
                default_dense: eval(&default_dec, o, &dense),
                original,
                paper,
                default,
            }
        })
        .collect();
    Ok(PaperData {
        fig4,
        fig6,
        fig7,
        fig7_critical_angle: paper7.material.records[0].critical_angle as f64,
    })
}

fn num(v: f64) -> String {
    let s = format!("{v}");
    s.strip_suffix(".0").map(str::to_string).unwrap_or(s)
}

fn err4(e: f64) -> String {
    format!("{e:.4}")
}

/// The markdown tables of the three figures.
pub fn table(d: &PaperData) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "**Fig. 4** — relative error (and file bytes) against ks/kd and the Phong exponent n, \
         incidence (15°, 0°); paper mode's automatic critical angle γ in brackets.\n"
    );
    let _ = writeln!(
        t,
        "| ks/kd | n | direct SH, L = 4 (the paper's Fig. 4) | paper mode, L = 1 | default mode |"
    );
    let _ = writeln!(t, "| ---: | ---: | ---: | ---: | ---: |");
    for r in d.fig4.iter().filter(|r| r.ks == 15.0) {
        let _ = writeln!(
            t,
            "| {} | {} | {} ({} B) | {} ({} B, γ = {}°) | {} ({} B) |",
            num(r.ks),
            num(r.n),
            err4(r.direct.error),
            r.direct.bytes,
            err4(r.paper.error),
            r.paper.bytes,
            num(r.paper.critical_angle),
            err4(r.default.error),
            r.default.bytes
        );
    }
    let worst_mean = |f: &dyn Fn(&Fig4Row) -> f64| {
        let worst = d.fig4.iter().map(f).fold(0.0, f64::max);
        let mean = d.fig4.iter().map(f).sum::<f64>() / d.fig4.len() as f64;
        format!("{} / {}", err4(worst), err4(mean))
    };
    let _ = writeln!(
        t,
        "| all {} materials | worst / mean | {} | {} | {} |",
        d.fig4.len(),
        worst_mean(&|r| r.direct.error),
        worst_mean(&|r| r.paper.error),
        worst_mean(&|r| r.default.error)
    );
    let _ = writeln!(
        t,
        "\n**Fig. 6** — paper mode's error against a fixed critical angle γ (SH level 1); the \
         default mode has no critical angle.\n"
    );
    let _ = writeln!(
        t,
        "| ks/kd | n | γ at the minimum | minimum error | error at γ = 37° (the paper's) | default mode |"
    );
    let _ = writeln!(t, "| ---: | ---: | ---: | ---: | ---: | ---: |");
    for c in &d.fig6 {
        let best =
            c.points.iter().copied().fold(
                (f64::NAN, f64::INFINITY),
                |b, p| if p.1 < b.1 { p } else { b },
            );
        let at37 = c
            .points
            .iter()
            .find(|p| p.0 == 37.0)
            .map_or("—".to_string(), |p| err4(p.1));
        let _ = writeln!(
            t,
            "| {} | {} | {}° | {} | {} | {} |",
            num(c.ks),
            num(c.n),
            num(best.0),
            err4(best.1),
            at37,
            err4(c.default_error)
        );
    }
    let _ = writeln!(
        t,
        "\n**Fig. 7** — relative error of one spectrum, ks/kd = 15, n = 15 (paper mode's \
         automatic γ = {}°; the paper used 37°).\n",
        num(d.fig7_critical_angle)
    );
    let _ = writeln!(
        t,
        "| outgoing direction | published (Xu & Sun) | paper mode | default mode |"
    );
    let _ = writeln!(t, "| --- | ---: | ---: | ---: |");
    for (i, p) in d.fig7.iter().enumerate() {
        let _ = writeln!(
            t,
            "| ({}) ({}°, {}°){} | {} | {} | {} |",
            ["a", "b", "c", "d"][i.min(3)],
            num(p.outgoing.0),
            num(p.outgoing.1),
            if i == 0 { ", the peak" } else { "" },
            p.published,
            err4(p.paper_error),
            err4(p.default_error)
        );
    }
    t
}

fn fig4_csv(d: &PaperData) -> String {
    let mut s = String::from(
        "ks_kd,n,direct_l4_error,direct_bytes,paper_error,paper_critical_angle,paper_bytes,\
         default_error,default_bytes\n",
    );
    for r in &d.fig4 {
        let _ = writeln!(
            s,
            "{},{},{:.6},{},{:.6},{},{},{:.6},{}",
            num(r.ks),
            num(r.n),
            r.direct.error,
            r.direct.bytes,
            r.paper.error,
            num(r.paper.critical_angle),
            r.paper.bytes,
            r.default.error,
            r.default.bytes
        );
    }
    s
}

fn fig6_csv(d: &PaperData) -> String {
    let mut s = String::from("ks_kd,n,critical_angle,paper_error,default_error\n");
    for c in &d.fig6 {
        for (g, e) in &c.points {
            let _ = writeln!(
                s,
                "{},{},{},{:.6},{:.6}",
                num(c.ks),
                num(c.n),
                num(*g),
                e,
                c.default_error
            );
        }
    }
    s
}

fn fig7_csv(d: &PaperData) -> String {
    let mut s = String::from("theta_o,phi_o,wavelength_nm,original,paper_mode,default_mode\n");
    for p in &d.fig7 {
        for (w, l) in wavelengths().iter().enumerate() {
            let _ = writeln!(
                s,
                "{},{},{},{:.6},{:.6},{:.6}",
                num(p.outgoing.0),
                num(p.outgoing.1),
                num(*l),
                p.original[w],
                p.paper[w],
                p.default[w]
            );
        }
    }
    s
}

/// Computes everything and writes `fig4.csv`, `fig4.svg`, `fig6.csv`, `fig6.svg`, `fig7.csv`,
/// `fig7.svg` and `table.md` into `dir` (created if its parent exists), each atomically.
pub fn paper_figures(dir: &Path, opts: &PaperFiguresOptions) -> Result<PaperFigures> {
    ensure_output_folder(dir, "paper-figures")?;
    let d = compute(opts)?;
    let table = table(&d);
    let mut files = Vec::new();
    let mut put = |name: &str, bytes: &[u8]| -> Result<()> {
        let p = dir.join(name);
        write_bytes_atomic(&p, bytes)?;
        files.push(p);
        Ok(())
    };
    put("fig4.csv", fig4_csv(&d).as_bytes())?;
    put("fig4.svg", &render(&Fig4(&d), ImageKind::Svg)?)?;
    put("fig6.csv", fig6_csv(&d).as_bytes())?;
    put("fig6.svg", &render(&Fig6(&d), ImageKind::Svg)?)?;
    put("fig7.csv", fig7_csv(&d).as_bytes())?;
    put("fig7.svg", &render(&Fig7(&d), ImageKind::Svg)?)?;
    put("table.md", table.as_bytes())?;
    Ok(PaperFigures { table, files })
}

// ---------------------------------------------------------------------------------------------
// Plots

/// The Fig. 4 plot: error against n, a line per ks/kd, one panel per mode.
pub struct Fig4<'a>(pub &'a PaperData);
/// The Fig. 6 plot: paper mode's error against γ, default mode dashed.
pub struct Fig6<'a>(pub &'a PaperData);
/// The Fig. 7 plot: four spectra panels.
pub struct Fig7<'a>(pub &'a PaperData);

fn color(i: usize) -> RGBColor {
    SERIES_COLORS[i % SERIES_COLORS.len()]
}

/// A decade range covering every value (log axes).
fn decades(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (1e-4, 1.0);
    }
    // A hair beyond the decades, so that rounding cannot drop their tick labels.
    (
        0.98 * 10f64.powf(lo.log10().floor()),
        1.02 * 10f64.powf(hi.log10().ceil()),
    )
}

fn heading<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    note: &str,
) -> Result<DrawingArea<DB, Shift>> {
    let err = |e| draw_error("a heading", e);
    root.fill(&WHITE).map_err(err)?;
    let (head, rest) = root.split_vertically(52);
    head.draw(&Text::new(title.to_string(), (12, 6), font(17.0)))
        .map_err(err)?;
    head.draw(&Text::new(
        note.to_string(),
        (12, 29),
        font(13.0).color(&RGBColor(80, 80, 80)),
    ))
    .map_err(err)?;
    Ok(rest)
}

impl Figure for Fig4<'_> {
    fn size(&self) -> (u32, u32) {
        (1500, 520)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let err = |e| draw_error("Fig. 4", e);
        let d = self.0;
        let rest = heading(
            root,
            "Fig. 4 — relative error against the Phong exponent n and ks/kd",
            "ColorChecker green diffuse + white specular, kd = 1, θi = 15°; 400–700 nm every 10 nm, \
             outgoing directions every 5°. Lower is better.",
        )?;
        let (ylo, yhi) = decades(
            d.fig4
                .iter()
                .flat_map(|r| [r.direct.error, r.paper.error, r.default.error]),
        );
        let (nlo, nhi) = d.fig4.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
            (a.min(r.n), b.max(r.n))
        });
        let mut ks: Vec<f64> = d.fig4.iter().map(|r| r.ks).collect();
        ks.sort_by(f64::total_cmp);
        ks.dedup();
        let panels = rest.split_evenly((1, 3));
        type Pick = fn(&Fig4Row) -> Outcome;
        let modes: [(&str, Pick, SeriesLabelPosition); 3] = [
            (
                "direct SH, L = 4 (the paper's Fig. 4)",
                |r| r.direct,
                SeriesLabelPosition::LowerRight,
            ),
            (
                "paper mode: SH L = 1 + Gaussian peak",
                |r| r.paper,
                SeriesLabelPosition::LowerRight,
            ),
            (
                "default mode: joint fit, 0.5% budget",
                |r| r.default,
                SeriesLabelPosition::UpperRight,
            ),
        ];
        for (area, (title, pick, legend)) in panels.iter().zip(modes) {
            let mut chart = ChartBuilder::on(area)
                .caption(title, font(15.0))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(64)
                .build_cartesian_2d(
                    ((nlo * 0.7)..(nhi * 1.4)).log_scale(),
                    (ylo..yhi).log_scale(),
                )
                .map_err(err)?;
            house_mesh(&mut chart)
                .x_desc("Phong exponent n")
                .y_desc("relative error")
                .x_label_formatter(&|v| format!("{v}"))
                .y_label_formatter(&|v| percent_label(*v))
                .draw()
                .map_err(err)?;
            for (i, &k) in ks.iter().enumerate() {
                let c = color(i);
                let pts: Vec<(f64, f64)> = d
                    .fig4
                    .iter()
                    .filter(|r| r.ks == k)
                    .map(|r| (r.n, pick(r).error))
                    .collect();
                chart
                    .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                    .map_err(err)?
                    .label(format!("ks/kd = {}", num(k)))
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                    });
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                    .map_err(err)?;
            }
            draw_legend(&mut chart, legend, "a legend")?;
        }
        Ok(())
    }
}

impl Figure for Fig6<'_> {
    fn size(&self) -> (u32, u32) {
        (1100, 620)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let err = |e| draw_error("Fig. 6", e);
        let d = self.0;
        let rest = heading(
            root,
            "Fig. 6 — paper mode's relative error against the critical angle γ (SH level 1)",
            "Solid: paper mode at a fixed γ, the minimum marked. Dashed: the default mode, which \
             has no critical angle (joint fit). θi = 15°.",
        )?;
        let (ylo, yhi) = decades(
            d.fig6
                .iter()
                .flat_map(|c| c.points.iter().map(|p| p.1).chain([c.default_error])),
        );
        let mut chart = ChartBuilder::on(&rest)
            .margin(12)
            .margin_right(24)
            .x_label_area_size(42)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..90.0f64, (ylo..yhi).log_scale())
            .map_err(err)?;
        house_mesh(&mut chart)
            .x_desc("critical angle γ (degrees)")
            .y_desc("relative error")
            .x_labels(10)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| percent_label(*v))
            .draw()
            .map_err(err)?;
        for (i, c) in d.fig6.iter().enumerate() {
            let col = color(i);
            chart
                .draw_series(LineSeries::new(c.points.clone(), col.stroke_width(2)))
                .map_err(err)?
                .label(format!(
                    "ks/kd = {}, n = {} (default: {:.2}%)",
                    num(c.ks),
                    num(c.n),
                    100.0 * c.default_error
                ))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], col.stroke_width(2))
                });
            if let Some(best) = c.points.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)) {
                chart
                    .draw_series(std::iter::once(Circle::new(best, 4, col.filled())))
                    .map_err(err)?;
            }
            chart
                .draw_series(DashedLineSeries::new(
                    [(0.0, c.default_error), (90.0, c.default_error)],
                    8,
                    5,
                    col.stroke_width(2),
                ))
                .map_err(err)?;
        }
        draw_legend(
            &mut chart,
            SeriesLabelPosition::Coordinate(320, 250),
            "a legend",
        )?;
        Ok(())
    }
}

impl Figure for Fig7<'_> {
    fn size(&self) -> (u32, u32) {
        (1200, 860)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let err = |e| draw_error("Fig. 7", e);
        let d = self.0;
        let rest = heading(
            root,
            "Fig. 7 — original and reconstructed spectra, ks/kd = 15, n = 15, θi = 15°",
            &format!(
                "Dots: the Phong material's samples. Solid: paper mode (automatic γ = {}°). \
                 Dashed: default mode. Errors are relative L2 over the spectrum.",
                num(d.fig7_critical_angle)
            ),
        )?;
        let dense: Vec<f64> = (0..=150).map(|i| 400.0 + 2.0 * i as f64).collect();
        let wl = wavelengths();
        let panels = rest.split_evenly((2, 2));
        for (i, (area, p)) in panels.iter().zip(&d.fig7).enumerate() {
            let hi = p
                .original
                .iter()
                .chain(&p.paper_dense)
                .chain(&p.default_dense)
                .fold(0.0f64, |a, &b| a.max(b));
            let lo = p
                .paper_dense
                .iter()
                .chain(&p.default_dense)
                .fold(0.0f64, |a, &b| a.min(b));
            let title = format!(
                "({}) ωo = ({}°, {}°){}: published {}",
                ["a", "b", "c", "d"][i.min(3)],
                num(p.outgoing.0),
                num(p.outgoing.1),
                if i == 0 { ", the peak" } else { "" },
                p.published
            );
            let step = (hi * 1.12 - lo) / 6.0;
            let mut chart = ChartBuilder::on(area)
                .caption(title, font(15.0))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(400.0..700.0f64, lo..(hi * 1.12))
                .map_err(err)?;
            house_mesh(&mut chart)
                .x_desc("wavelength (nm)")
                .y_desc("ρ (1/sr)")
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| tick_label(*v, step))
                .draw()
                .map_err(err)?;
            let (cp, cd, co) = (color(0), color(2), color(1));
            chart
                .draw_series(LineSeries::new(
                    dense.iter().copied().zip(p.paper_dense.iter().copied()),
                    cp.stroke_width(2),
                ))
                .map_err(err)?
                .label(format!("paper mode, error {:.3}", p.paper_error))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], cp.stroke_width(2))
                });
            chart
                .draw_series(DashedLineSeries::new(
                    dense.iter().copied().zip(p.default_dense.iter().copied()),
                    7,
                    4,
                    cd.stroke_width(2),
                ))
                .map_err(err)?
                .label(format!("default mode, error {:.4}", p.default_error))
                .legend(move |(x, y)| {
                    DashedPathElement::new(vec![(x, y), (x + 18, y)], 5, 3, cd.stroke_width(2))
                });
            chart
                .draw_series(
                    wl.iter()
                        .zip(&p.original)
                        .map(|(&x, &y)| Circle::new((x, y), 3, co.filled())),
                )
                .map_err(err)?
                .label("original samples")
                .legend(move |(x, y)| Circle::new((x + 9, y), 3, co.filled()));
            draw_legend(&mut chart, SeriesLabelPosition::LowerRight, "a legend")?;
        }
        Ok(())
    }
}
