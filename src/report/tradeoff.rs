//! The speed/accuracy/size trade, measured on the user's own material: encode it over a sweep of
//! settings, measure each file's bytes, its error against the input samples (as `decode --like`
//! would), the encode time and the decode time, and mark the size/error Pareto front.
//!
//! Every setting is a set of `sbrdf encode` options, written out in the report, so any row can
//! be reproduced with the command line.

use crate::decode::decoder::Decoder;
use crate::encode::encoder::{encode, EncodeOptions};
use crate::encode::fit::PeakMode;
use crate::encode::samples::SampleSet;
use crate::error::{Error, Result};
use crate::io::synth::QueryRng;
use crate::model::spectral::SpectralBasis;
use crate::model::Precision;
use std::time::Instant;

/// One point of the sweep: the encode options that matter, as the CLI names them.
#[derive(Debug, Clone, PartialEq)]
pub struct Setting {
    /// `--basis`.
    pub basis: SpectralBasis,
    /// `--terms`.
    pub terms: usize,
    /// `--sh-level` (with a budget, the largest level tried).
    pub sh_level: usize,
    /// `--peak`.
    pub peak: PeakMode,
    /// `--precision`.
    pub precision: Precision,
    /// `--max-error` (joint fit only; written with `--best-effort`).
    pub max_error: Option<f64>,
}

impl Setting {
    fn joint(basis: SpectralBasis, terms: usize, sh_level: usize, p: Precision, e: f64) -> Self {
        Setting {
            basis,
            terms,
            sh_level,
            peak: PeakMode::Joint,
            precision: p,
            max_error: Some(e),
        }
    }

    fn fixed(basis: SpectralBasis, terms: usize, sh_level: usize, peak: PeakMode) -> Self {
        Setting {
            basis,
            terms,
            sh_level,
            peak,
            precision: Precision::F32,
            max_error: None,
        }
    }

    /// The peak mode as `--peak` spells it: `"joint"`, `"paper"` or `"none"`.
    pub fn peak_name(&self) -> &'static str {
        match self.peak {
            PeakMode::Joint => "joint",
            PeakMode::Paper => "paper",
            PeakMode::None => "none",
        }
    }

    /// The encoder options of this setting (everything else at the CLI's defaults).
    pub fn options(&self) -> EncodeOptions {
        EncodeOptions {
            basis: self.basis,
            terms: Some(self.terms),
            sh_level: Some(self.sh_level),
            peak: self.peak,
            precision: self.precision,
            max_error: self.max_error,
            // `--max-error` on the command line is an explicit budget: same here, so a
            // row reproduces with `sbrdf encode` and its options.
            budget_given: self.max_error.is_some(),
            ..EncodeOptions::default()
        }
    }

    /// The `sbrdf encode` options that reproduce this setting.
    pub fn cli_options(&self) -> Vec<String> {
        let mut v: Vec<String> = [
            "--basis",
            self.basis.name(),
            "--terms",
            &self.terms.to_string(),
            "--sh-level",
            &self.sh_level.to_string(),
            "--peak",
            self.peak_name(),
            "--precision",
            self.precision.name(),
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        if let Some(e) = self.max_error {
            v.extend(["--max-error".into(), format!("{e}"), "--best-effort".into()]);
        }
        v
    }
}

/// The settings a sweep tries: the joint fit at several budgets, sizes and precisions, the
/// paper's method at several SH levels, and SH alone. `quick` keeps 12 of them.
pub fn sweep(quick: bool, wavelengths: usize) -> Vec<Setting> {
    use SpectralBasis::{Cosine, PeriodicFourier as Fourier, Tabulated as Data};
    let k = |n: usize| n.min(wavelengths).max(1);
    // The periodic series has one free value fewer than there are samples (`encode` says why).
    let kf = |n: usize| n.min(wavelengths.saturating_sub(1)).max(1);
    let mut v = vec![
        Setting::joint(Data, k(3), 6, Precision::F16, 0.02),
        Setting::joint(Data, k(3), 6, Precision::F16, 0.005),
        Setting::joint(Data, k(3), 6, Precision::F16, 0.001),
        Setting::joint(Data, k(2), 4, Precision::F16, 0.01),
        Setting::joint(Data, k(5), 6, Precision::F32, 0.001),
        Setting::joint(Cosine, k(8), 6, Precision::F16, 0.005),
        Setting::fixed(Fourier, kf(13), 1, PeakMode::Paper),
        Setting::fixed(Fourier, kf(13), 2, PeakMode::Paper),
        Setting::fixed(Fourier, kf(13), 4, PeakMode::Paper),
        Setting::fixed(Data, k(3), 2, PeakMode::Paper),
        Setting::fixed(Fourier, kf(13), 4, PeakMode::None),
        Setting::fixed(Fourier, kf(13), 6, PeakMode::None),
    ];
    if !quick {
        v.extend([
            Setting::joint(Data, k(3), 6, Precision::F16, 0.05),
            Setting::joint(Data, k(3), 6, Precision::F16, 0.002),
            Setting::joint(Data, k(4), 6, Precision::F16, 0.0005),
            Setting::joint(Data, k(8), 6, Precision::F32, 0.0002),
            Setting::joint(Data, k(2), 2, Precision::F16, 0.02),
            Setting::joint(Cosine, k(13), 6, Precision::F16, 0.002),
            Setting::joint(Fourier, kf(13), 6, Precision::F32, 0.002),
            Setting::fixed(Cosine, k(13), 1, PeakMode::Paper),
            Setting::fixed(Data, k(5), 4, PeakMode::Paper),
            Setting::fixed(Data, k(3), 4, PeakMode::None),
            Setting::fixed(Cosine, k(13), 8, PeakMode::None),
            Setting {
                precision: Precision::F16,
                ..Setting::fixed(Fourier, kf(13), 1, PeakMode::Paper)
            },
        ]);
    }
    v.dedup();
    v
}

/// One measured setting.
#[derive(Debug, Clone)]
pub struct Row {
    /// The setting measured.
    pub setting: Setting,
    /// Size of the written file, bytes.
    pub bytes: usize,
    /// Relative L2 error over every input sample, and the largest absolute difference (1/sr).
    pub rel_l2_error: f64,
    /// The largest absolute difference over every input sample, 1/sr (see `rel_l2_error`).
    pub max_abs_error: f64,
    /// Wall-clock time of the encode and write, milliseconds.
    pub encode_ms: f64,
    /// Nanoseconds per `Decoder::eval` query: one wavelength, and the file's whole spectrum.
    pub eval_ns_1wl: f64,
    /// Nanoseconds per `Decoder::eval` query over the file's whole spectrum (see `eval_ns_1wl`).
    pub eval_ns_spectrum: f64,
    /// On the size/error Pareto front: no other row is at least as small and as accurate and
    /// better in one.
    pub pareto: bool,
}

/// Encodes `set` with `s` (the inputs named as the CLI would, so the bytes match) and measures it.
pub fn measure(set: &SampleSet, inputs: &[String], s: &Setting) -> Result<Row> {
    let mut opts = s.options();
    opts.inputs = inputs.to_vec();
    let t = Instant::now();
    let encoded = encode(set, &opts)?;
    let bytes = crate::write_material(&encoded.material)?;
    let encode_ms = t.elapsed().as_secs_f64() * 1e3;
    let dec = Decoder::from_bytes(&bytes)?;
    let wl = &set.wavelengths;
    let mut out = vec![0.0; wl.len()];
    let (mut e2, mut r2, mut max_abs) = (0.0, 0.0, 0.0f64);
    for inc in &set.incidences {
        for (d, dir) in inc.directions.iter().enumerate() {
            dec.eval_deg((inc.theta_i, inc.phi_i), (dir[0], dir[1]), wl, &mut out);
            for (a, b) in out
                .iter()
                .zip(&inc.values[d * wl.len()..(d + 1) * wl.len()])
            {
                e2 += (a - b) * (a - b);
                r2 += b * b;
                max_abs = max_abs.max((a - b).abs());
            }
        }
    }
    let rel_l2_error = if r2 > 0.0 {
        (e2 / r2).sqrt()
    } else if e2 > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    let spectrum: Vec<f32> = wl.iter().map(|&w| w as f32).collect();
    let one = [spectrum[spectrum.len() / 2]];
    Ok(Row {
        setting: s.clone(),
        bytes: bytes.len(),
        rel_l2_error,
        max_abs_error: max_abs,
        encode_ms,
        eval_ns_1wl: eval_ns(&dec, &one),
        eval_ns_spectrum: eval_ns(&dec, &spectrum),
        pareto: false,
    })
}

/// The best of five timings of 4096 fixed pseudo-random queries, in ns per query (the minimum
/// is the least disturbed by other work on the machine).
fn eval_ns(dec: &Decoder, wavelengths: &[f32]) -> f64 {
    let queries = QueryRng::new(0x9E37_79B9_7F4A_7C15).direction_pairs(4096, 0.05);
    let mut out = vec![0.0f32; wavelengths.len()];
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        for (wi, wo) in &queries {
            dec.eval(*wi, *wo, wavelengths, &mut out);
            std::hint::black_box(&out);
        }
        best = best.min(t.elapsed().as_nanos() as f64 / queries.len() as f64);
    }
    best
}

/// Marks the rows on the bytes/error Pareto front.
pub fn mark_pareto(rows: &mut [Row]) {
    let dominated = |a: &Row, b: &Row| {
        b.bytes <= a.bytes
            && b.rel_l2_error <= a.rel_l2_error
            && (b.bytes < a.bytes || b.rel_l2_error < a.rel_l2_error)
    };
    let flags: Vec<bool> = rows
        .iter()
        .map(|a| !rows.iter().any(|b| dominated(a, b)))
        .collect();
    for (r, f) in rows.iter_mut().zip(flags) {
        r.pareto = f;
    }
}

/// The report's columns, in order.
pub const COLUMNS: [&str; 14] = [
    "basis",
    "terms",
    "sh_level",
    "peak",
    "precision",
    "max_error",
    "bytes",
    "rel_l2_error",
    "max_abs_error",
    "encode_ms",
    "eval_ns_1wl",
    "eval_ns_spectrum",
    "pareto",
    "encode_options",
];

/// Writes the report as CSV (the `csv` crate quotes the options column).
pub fn write_csv(rows: &[Row], out: impl std::io::Write) -> Result<()> {
    let mut w = csv::Writer::from_writer(out);
    let bad = |e: csv::Error| Error::Parameter(format!("writing the report: {e}"));
    w.write_record(COLUMNS).map_err(bad)?;
    for r in rows {
        let s = &r.setting;
        w.write_record([
            s.basis.name().to_string(),
            s.terms.to_string(),
            s.sh_level.to_string(),
            s.peak_name().to_string(),
            s.precision.name().to_string(),
            s.max_error.map_or(String::new(), |e| format!("{e}")),
            r.bytes.to_string(),
            format!("{:.6e}", r.rel_l2_error),
            format!("{:.6e}", r.max_abs_error),
            format!("{:.1}", r.encode_ms),
            format!("{:.1}", r.eval_ns_1wl),
            format!("{:.1}", r.eval_ns_spectrum),
            (r.pareto as u8).to_string(),
            s.cli_options().join(" "),
        ])
        .map_err(bad)?;
    }
    w.flush()
        .map_err(|e| Error::Parameter(format!("writing the report: {e}")))?;
    Ok(())
}

/// Draws the report: error against bytes with the Pareto front, and decode time against bytes.
pub fn plot_svg(rows: &[Row], title: &str) -> Result<String> {
    use crate::report::draw::{draw_error, draw_legend, house_mesh, register_font, FONT};
    use plotters::prelude::*;
    register_font()?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 480)).into_drawing_area();
        let e = |x| draw_error("the trade-off plot", x);
        root.fill(&WHITE).map_err(e)?;
        let root = root
            .titled(title, (FONT, 20))
            .map_err(|x| draw_error("the trade-off plot", x))?;
        let (left, right) = root.split_horizontally(560);
        let bytes: Vec<f64> = rows.iter().map(|r| r.bytes as f64).collect();
        let (bmin, bmax) = bytes
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
        let xr = (bmin / 1.3)..(bmax * 1.3);
        let errs: Vec<f64> = rows.iter().map(|r| r.rel_l2_error.max(1e-7)).collect();
        let (emin, emax) = errs
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
        let mut c = ChartBuilder::on(&left)
            .margin(12)
            .caption("error against size (Pareto front in red)", (FONT, 16))
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                xr.clone().log_scale(),
                ((emin / 1.5)..(emax * 1.5)).log_scale(),
            )
            .map_err(|x| draw_error("the trade-off plot", x))?;
        house_mesh(&mut c)
            .x_desc("file size (bytes)")
            .y_desc("relative L2 error")
            .x_labels(6)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|x| draw_error("the trade-off plot", x))?;
        c.draw_series(
            rows.iter()
                .zip(&errs)
                .map(|(r, &e)| Circle::new((r.bytes as f64, e), 4, BLUE.mix(0.6).filled())),
        )
        .map_err(|x| draw_error("the trade-off plot", x))?;
        let mut front: Vec<(f64, f64)> = rows
            .iter()
            .zip(&errs)
            .filter(|(r, _)| r.pareto)
            .map(|(r, &e)| (r.bytes as f64, e))
            .collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        c.draw_series(LineSeries::new(front.clone(), RED.stroke_width(2)))
            .map_err(|x| draw_error("the trade-off plot", x))?;
        c.draw_series(front.iter().map(|&p| Circle::new(p, 5, RED.filled())))
            .map_err(|x| draw_error("the trade-off plot", x))?;

        let (tmin, tmax) = rows.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
            (
                a.min(r.eval_ns_1wl).min(r.eval_ns_spectrum),
                b.max(r.eval_ns_1wl).max(r.eval_ns_spectrum),
            )
        });
        let mut c = ChartBuilder::on(&right)
            .margin(12)
            .caption("decode time per query", (FONT, 16))
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(xr.log_scale(), ((tmin / 1.3)..(tmax * 1.3)).log_scale())
            .map_err(|x| draw_error("the trade-off plot", x))?;
        house_mesh(&mut c)
            .x_desc("file size (bytes)")
            .y_desc("ns per eval")
            .x_labels(6)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_labels(10)
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(|x| draw_error("the trade-off plot", x))?;
        c.draw_series(
            rows.iter()
                .map(|r| Circle::new((r.bytes as f64, r.eval_ns_1wl), 4, GREEN.filled())),
        )
        .map_err(|x| draw_error("the trade-off plot", x))?
        .label("one wavelength")
        .legend(|(x, y)| Circle::new((x, y), 4, GREEN.filled()));
        c.draw_series(rows.iter().map(|r| {
            TriangleMarker::new((r.bytes as f64, r.eval_ns_spectrum), 5, MAGENTA.filled())
        }))
        .map_err(|x| draw_error("the trade-off plot", x))?
        .label("whole spectrum")
        .legend(|(x, y)| TriangleMarker::new((x, y), 5, MAGENTA.filled()));
        draw_legend(&mut c, SeriesLabelPosition::UpperLeft, "the trade-off plot")?;
        root.present()
            .map_err(|x| draw_error("the trade-off plot", x))?;
    }
    Ok(svg)
}
