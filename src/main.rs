//! `sbrdf`: the command-line front end. All logic lives in the library; this file parses
//! arguments, calls it, and turns errors into messages and exit codes.

mod cli_figures;

use clap::{Args, Parser, Subcommand, ValueEnum};
use sbrdf::csv_input::{self, Layout};
use sbrdf::fit::PeakMode;
use sbrdf::joint::LobeFamily;
use sbrdf::output::{write_atomic, write_bytes_atomic};
use sbrdf::samples::SampleSet;
use sbrdf::settings::{self, EncodeSettings};
use sbrdf::synth::{paper_grid, sample_material, Phong, SpectrumTable};
use sbrdf::{Decoder, Error, Precision, Result};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "sbrdf",
    version,
    about = "Compact, archival spectral BRDFs: encode samples, decode, evaluate, inspect",
    long_about = "sbrdf stores a sampled spectral BRDF as, per incident direction, spherical-harmonic \
coefficients of each spectral coefficient plus a specular peak (Xu & Sun). Angles are in degrees \
(θ from the normal, φ counter-clockwise from +x), wavelengths in nm, values in 1/sr.",
    after_help = "Examples:\n  \
sbrdf synth phong --diffuse green --specular white --kd 1 --ks 15 --n 15 --incident 15,0 -o phong.csv\n  \
sbrdf encode phong.csv -o phong.sbrdf\n  \
sbrdf encode phong.csv -o paper.sbrdf --basis fourier --peak paper --precision f32\n  \
sbrdf info phong.sbrdf\n  \
sbrdf eval phong.sbrdf --incident 15,0 --outgoing 15,180 --wavelengths 450,550,650\n  \
sbrdf decode phong.sbrdf -o back.csv --like phong.csv\n  \
sbrdf verify phong.sbrdf"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Fit sampled BRDFs (CSV) and write an .sbrdf file.
    #[command(
        after_help = "CSV layouts (found by header name; '#' lines are comments):\n  \
long: theta_i,phi_i,theta_o,phi_o,wavelength_nm,value   (one sample a row)\n  \
wide: theta_i,phi_i,theta_o,phi_o,400,410,...           (one column per wavelength; '400nm' works too)\n\n\
Examples:\n  sbrdf encode material.csv -o material.sbrdf\n  \
sbrdf encode ti*.csv -o m.sbrdf --sh-level 2 --precision f16 --metadata source=lab42\n  \
sbrdf encode material.csv -o direct.sbrdf --peak none --sh-level 4"
    )]
    Encode(EncodeArgs),
    /// Write the reconstruction as CSV, at a reference file's positions or at the encoder's.
    #[command(
        after_help = "Examples:\n  sbrdf decode m.sbrdf -o back.csv --like material.csv\n  \
sbrdf decode m.sbrdf -o back.csv        (at the sample positions the encoder saw, wide layout)"
    )]
    Decode(DecodeArgs),
    /// Print the spectrum at one pair of directions as CSV `wavelength_nm,value`.
    #[command(
        after_help = "Example:\n  sbrdf eval m.sbrdf --incident 15,0 --outgoing 15,180 --wavelengths 450,550\n\n\
Directions below the horizon (θ > 90) give 0. An incident direction that is not stored is \
answered by interpolating the neighbouring records' parameters (isotropic files: rotated to \
φi = 0 first); outside the stored θi range, the nearest stored θi is used."
    )]
    Eval(EvalArgs),
    /// Describe a file: its settings, records and metadata.
    Info(InfoArgs),
    /// Check every CRC and the whole structure of a file.
    Verify(VerifyArgs),
    /// Generate test materials.
    #[command(subcommand)]
    Synth(SynthCommand),
    /// Draw what a file stores at one incidence: a coefficient over the outgoing hemisphere
    /// (background and peak), beside the original samples, and spectra at chosen directions.
    Plot(cli_figures::PlotArgs),
    /// Render a sphere lit by a point light (D65), spectrally, to an sRGB picture.
    Preview(cli_figures::PreviewArgs),
    /// Regenerate the data and plots of the paper's Figs. 4, 6 and 7, paper mode beside the
    /// default mode.
    PaperFigures(cli_figures::PaperFiguresArgs),
    /// Derive a smaller file from an existing one (no samples needed): fewer incidences,
    /// wavelengths, spectral terms or SH functions, or f16 storage.
    #[command(
        after_help = "Example (a scene rendering 450–650 nm with lights below 60°):\n  \
sbrdf subset m.sbrdf -o scene.sbrdf --wavelengths 450:650 --incident-max 60 --precision f16\n\n\
Every cut truncates (incidences, wavelengths of a data-derived basis, spectral terms, SH \
functions) or rounds (f16); an analytic basis cut to fewer wavelengths is re-tabulated at the kept \
ones (exact there, linear between). Nothing is re-fitted: there are no samples. Each record's \
stored error becomes an upper bound on its new error, from its recorded error and the change the \
cuts made (measured against the original at its stored sample positions). Re-encoding from the samples with \
`encode --wavelengths --incident-max` gives the best file of a size; subset gives one at once."
    )]
    Subset(SubsetArgs),
    /// Encode the input over a sweep of settings and report size, error and speed of each.
    #[command(after_help = "Example:\n  \
sbrdf tradeoff material.csv --csv report.csv --plot report.svg --quick\n\n\
Each row's encode_options column holds the `sbrdf encode` options that reproduce it. Errors are \
measured against the input samples as `decode --like` does; eval times are the best of five runs \
of 4096 random queries on this machine. pareto = 1 marks the rows no other row beats in both size \
and error.")]
    Tradeoff(TradeoffArgs),
}

#[derive(Args)]
struct TradeoffArgs {
    /// Inputs, as for `encode` (CSV, EXR slices, folders).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// The report: one row per setting.
    #[arg(long, value_name = "REPORT.csv")]
    csv: PathBuf,
    /// The plot: error against bytes with the Pareto front, and decode time.
    #[arg(long, value_name = "REPORT.svg")]
    plot: Option<PathBuf>,
    /// 12 settings instead of 24.
    #[arg(long)]
    quick: bool,
}

#[derive(Args)]
struct SubsetArgs {
    input: PathBuf,
    /// Output .sbrdf file (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Keep wavelengths within MIN:MAX nm.
    #[arg(long, value_name = "MIN:MAX")]
    wavelengths: Option<String>,
    /// Keep incident directions with θi ≤ DEG.
    #[arg(long, value_name = "DEG")]
    incident_max: Option<f64>,
    /// Keep at most K spectral terms.
    #[arg(long, value_name = "K")]
    terms: Option<usize>,
    /// Keep SH functions up to level L.
    #[arg(long, value_name = "L")]
    sh_level: Option<usize>,
    /// Store coefficients in f16 (f32 records are rounded).
    #[arg(long, value_enum)]
    precision: Option<SubsetPrecisionArg>,
}

#[derive(Clone, Copy, ValueEnum)]
enum SubsetPrecisionArg {
    F16,
}

#[derive(Clone, Copy, ValueEnum)]
enum BasisArg {
    /// The paper's periodic Fourier series (a0, a1, b1, a2, b2, …).
    Fourier,
    /// Cosine series (DCT): no wrap-around between the ends of the spectrum.
    Cosine,
    /// Derived from the data (leading singular vectors, stored in the file); --terms is the rank.
    Data,
}

#[derive(Clone, Copy, ValueEnum)]
enum PeakArg {
    /// SH background + Gaussian peak (the paper's method).
    Paper,
    /// SH only (the paper's baseline).
    None,
    /// SH background and lobe amplitudes fitted together, lobe width searched (no critical angle).
    Joint,
}

#[derive(Clone, Copy, ValueEnum)]
enum LobeArg {
    /// Phong's lobe: a power of the cosine of the angle from the peak direction.
    CosinePower,
    /// A Gaussian in the angle from the peak direction.
    Gaussian,
    /// A microfacet lobe in the half vector (1 − cos θh), with shadowing and Fresnel variants.
    Microfacet,
    /// The same in sin²θh (GGX-shaped).
    MicrofacetSin2,
}

#[derive(Clone, Copy, ValueEnum)]
enum PrecisionArg {
    F32,
    F16,
}

#[derive(Args)]
struct EncodeArgs {
    /// Inputs: CSV files (long or wide layout), spectral-EXR slices (one per incident
    /// direction), or folders of them; all are merged.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Output .sbrdf file (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Spectral basis.
    #[arg(long, value_enum, default_value = "data")]
    basis: BasisArg,
    /// Number of spectral terms K (13 = a0, a1..a6, b1..b6 for fourier) [default: 13 for
    /// fourier and cosine; for data the smallest rank leaving ≤ half the error budget, ≤ 8].
    #[arg(long)]
    terms: Option<usize>,
    /// Spherical-harmonic level L (with an error budget, the highest tried) [default: 6 with
    /// --peak joint, 1 with --peak paper, 4 with --peak none].
    #[arg(long)]
    sh_level: Option<usize>,
    /// How the specular peak is represented.
    #[arg(long, value_enum, default_value = "joint")]
    peak: PeakArg,
    /// Critical angle in degrees around the peak, or `auto` to minimise the error.
    #[arg(long, default_value = "auto")]
    critical_angle: String,
    /// Storage precision of coefficients (with an error budget, f16 records fall back to f32
    /// where f16 misses it).
    #[arg(long, value_enum, default_value = "f16")]
    precision: PrecisionArg,
    /// Lobe shapes the joint fit may use, per incidence the better one.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "cosine-power,gaussian,microfacet,microfacet-sin2"
    )]
    lobes: Vec<LobeArg>,
    /// Relative error budget per incident direction (0.01 = 1%): with --peak joint, the smallest
    /// model (spectral terms, SH level, lobe, precision) meeting it. Given explicitly, the encode
    /// fails where it cannot be met [default with --peak joint: 0.5%, best effort].
    #[arg(long, value_name = "E")]
    max_error: Option<String>,
    /// With --max-error: write the most accurate model where the budget cannot be met, and
    /// succeed.
    #[arg(long)]
    best_effort: bool,
    /// Provenance recorded in the file's metadata (repeatable).
    #[arg(long, value_name = "KEY=VALUE")]
    metadata: Vec<String>,
    /// Do not store the outgoing sample positions (smaller file; `decode` then needs --like).
    #[arg(long)]
    no_sample_positions: bool,
    /// Keep only the input's wavelengths within MIN:MAX nm (what a scene renders).
    #[arg(long, value_name = "MIN:MAX")]
    wavelengths: Option<String>,
    /// Keep only incident directions with θi ≤ DEG (what a scene's lights reach).
    #[arg(long, value_name = "DEG")]
    incident_max: Option<f64>,
}

#[derive(Args)]
struct DecodeArgs {
    input: PathBuf,
    /// Output CSV file; with --exr, the folder for the slices (created if its parent exists).
    #[arg(short, long)]
    output: PathBuf,
    /// Reference CSV: write values at exactly its rows, in its layout.
    #[arg(long, value_name = "REF", conflicts_with = "exr")]
    like: Option<PathBuf>,
    /// Write one spectral EXR per stored incident direction (channels T.<λ>nm; pixel (i, j) is
    /// θo = (i + ½)·90°/H, φo = (j + ½)·360°/W), named <stem>_ti<θ>_pi<φ>.exr.
    #[arg(long)]
    exr: bool,
    /// With --exr: rows × columns (θo × φo), like 18x72 [default: the stored sample grid when
    /// it is a pixel grid, else 18x72, i.e. 5°].
    #[arg(long, value_name = "HxW", requires = "exr")]
    resolution: Option<String>,
    /// With --exr: pixel storage.
    #[arg(long, value_enum, default_value = "float", requires = "exr")]
    pixel_type: PixelTypeArg,
}

#[derive(Clone, Copy, ValueEnum)]
enum PixelTypeArg {
    Half,
    Float,
}

#[derive(Args)]
struct EvalArgs {
    input: PathBuf,
    /// Incident direction θ,φ in degrees.
    #[arg(long, value_name = "θ,φ", allow_hyphen_values = true)]
    incident: String,
    /// Outgoing direction θ,φ in degrees.
    #[arg(long, value_name = "θ,φ", allow_hyphen_values = true)]
    outgoing: String,
    /// Wavelengths in nm [default: the file's samples].
    #[arg(long, value_delimiter = ',', value_name = "λ1,λ2,...")]
    wavelengths: Option<Vec<f64>>,
}

#[derive(Args)]
struct InfoArgs {
    input: PathBuf,
    /// Machine-readable output.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct VerifyArgs {
    input: PathBuf,
}

#[derive(Subcommand)]
enum SynthCommand {
    /// The paper's Phong material: ρ = kd·Sd(λ) + ks·Ss(λ)·max(0, cos α)^n, α the angle from the
    /// mirror direction, with ColorChecker spectra (N. Ohta) for Sd and Ss.
    #[command(after_help = "Example (the paper's setup):\n  \
sbrdf synth phong --diffuse green --specular white --kd 1 --ks 15 --n 15 --incident 15,0 -o phong.csv")]
    Phong(PhongArgs),
    /// A GGX microfacet material: kd·Sd(λ)/π + D·G2·F/(4 cos θi cos θo), height-correlated
    /// Smith G2, Schlick Fresnel with F0(λ) = 0.04 + 0.5·(the --fresnel patch).
    #[command(after_help = "Example:\n  \
sbrdf synth ggx --alpha 0.1 --diffuse blue --fresnel yellow --incident 0,0 --incident 45,0 -o ggx.csv")]
    Ggx(GgxArgs),
    /// A MERL material from Löw et al.'s ABC fits, made spectral with a ColorChecker diffuse
    /// colour and a dispersive dielectric Fresnel (see the library's `synth::Abc`).
    #[command(after_help = "Example:\n  \
sbrdf synth abc --material pearl-paint --diffuse orange --incident 30,0 -o pearl.csv")]
    Abc(AbcArgs),
}

#[derive(Args)]
struct GgxArgs {
    /// GGX roughness α.
    #[arg(long)]
    alpha: f64,
    /// Diffuse ColorChecker patch.
    #[arg(long)]
    diffuse: String,
    /// ColorChecker patch shaping F0(λ) = 0.04 + 0.5·patch.
    #[arg(long)]
    fresnel: String,
    #[arg(long, default_value_t = 1.0)]
    kd: f64,
    #[command(flatten)]
    grid: GridArgs,
}

#[derive(Args)]
struct AbcArgs {
    /// MERL material name (e.g. pearl-paint, gray-plastic, chrome).
    #[arg(long)]
    material: String,
    /// Diffuse ColorChecker patch, scaled to the fit's diffuse luminance.
    #[arg(long)]
    diffuse: String,
    #[command(flatten)]
    grid: GridArgs,
}

/// Where a synthetic material is sampled and how it is written.
#[derive(Args)]
struct GridArgs {
    /// Incident direction θ,φ in degrees (repeatable).
    #[arg(long, required = true, value_name = "θ,φ", allow_hyphen_values = true)]
    incident: Vec<String>,
    /// Output CSV file (with --layout exr, a folder, created if its parent exists).
    #[arg(short, long)]
    output: PathBuf,
    /// Wavelengths MIN:MAX:STEP in nm (within 380–780).
    #[arg(long, default_value = "400:700:10")]
    wavelengths: String,
    /// Outgoing θ spacing: θo = step/2, 3·step/2, … below 90.
    #[arg(long, default_value_t = 5.0)]
    theta_step: f64,
    /// Outgoing φ spacing: φo = 0, step, … below 360 (with --layout exr, pixel centres:
    /// step/2, 3·step/2, …).
    #[arg(long, default_value_t = 5.0)]
    phi_step: f64,
    /// Output layout: a wide or long CSV, or one spectral EXR slice per incident direction
    /// (float pixels; the steps must divide 90° and 360°).
    #[arg(long, value_enum, default_value = "wide")]
    layout: LayoutArg,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum LayoutArg {
    Wide,
    Long,
    Exr,
}

#[derive(Args)]
struct PhongArgs {
    /// Diffuse ColorChecker patch (case-insensitive; a unique prefix works: `white`).
    #[arg(long)]
    diffuse: String,
    /// Specular ColorChecker patch.
    #[arg(long)]
    specular: String,
    #[arg(long)]
    kd: f64,
    #[arg(long)]
    ks: f64,
    /// Phong exponent.
    #[arg(long)]
    n: f64,
    #[command(flatten)]
    grid: GridArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sbrdf: error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Encode(a) => cmd_encode(a),
        Command::Decode(a) => cmd_decode(a),
        Command::Eval(a) => cmd_eval(a),
        Command::Info(a) => cmd_info(a),
        Command::Verify(a) => cmd_verify(a),
        Command::Synth(SynthCommand::Phong(a)) => cmd_phong(a),
        Command::Synth(SynthCommand::Ggx(a)) => cmd_ggx(a),
        Command::Synth(SynthCommand::Abc(a)) => cmd_abc(a),
        Command::Plot(a) => cli_figures::cmd_plot(a),
        Command::Preview(a) => cli_figures::cmd_preview(a),
        Command::PaperFigures(a) => cli_figures::cmd_paper_figures(a),
        Command::Subset(a) => cmd_subset(a),
        Command::Tradeoff(a) => cmd_tradeoff(a),
    }
}

fn parse_pair(flag: &str, s: &str) -> Result<(f64, f64)> {
    let bad = || {
        Error::Parameter(format!(
            "--{flag} '{s}': expected θ,φ in degrees, like 15,0"
        ))
    };
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let t: f64 = a.trim().parse().map_err(|_| bad())?;
    let p: f64 = b.trim().parse().map_err(|_| bad())?;
    if !(t.is_finite() && p.is_finite()) {
        return Err(bad());
    }
    Ok((t, p))
}

/// A fraction like `0.01` or a percentage like `1%`.
fn cmd_encode(a: EncodeArgs) -> Result<()> {
    let settings = EncodeSettings {
        basis: match a.basis {
            BasisArg::Fourier => sbrdf::SpectralBasis::PeriodicFourier,
            BasisArg::Cosine => sbrdf::SpectralBasis::Cosine,
            BasisArg::Data => sbrdf::SpectralBasis::Tabulated,
        },
        terms: a.terms,
        sh_level: a.sh_level,
        peak: match a.peak {
            PeakArg::Paper => PeakMode::Paper,
            PeakArg::None => PeakMode::None,
            PeakArg::Joint => PeakMode::Joint,
        },
        critical_angle: settings::parse_critical_angle(&a.critical_angle)?,
        precision: match a.precision {
            PrecisionArg::F32 => Precision::F32,
            PrecisionArg::F16 => Precision::F16,
        },
        lobes: a
            .lobes
            .iter()
            .map(|l| match l {
                LobeArg::Gaussian => LobeFamily::Gaussian,
                LobeArg::CosinePower => LobeFamily::CosinePower,
                LobeArg::Microfacet => LobeFamily::Microfacet,
                LobeArg::MicrofacetSin2 => LobeFamily::MicrofacetSin2,
            })
            .collect(),
        max_error: a
            .max_error
            .as_deref()
            .map(|e| settings::parse_fraction("max-error", e))
            .transpose()?,
        best_effort: a.best_effort,
        metadata: a
            .metadata
            .iter()
            .map(|kv| settings::parse_metadata(kv))
            .collect::<Result<_>>()?,
        no_sample_positions: a.no_sample_positions,
        wavelengths: a
            .wavelengths
            .as_deref()
            .map(|w| settings::parse_window("wavelengths", w))
            .transpose()?,
        incident_max: a.incident_max,
    };
    let (set, report) = sbrdf::input::read_inputs(&a.inputs)?;
    let inputs: Vec<String> = a.inputs.iter().map(|p| p.display().to_string()).collect();
    let outcome = settings::encode_samples(set, &report, &inputs, &settings)?;
    for m in &outcome.messages {
        eprintln!("sbrdf: {m}");
    }
    let (bytes, encoded, set) = (outcome.bytes, outcome.encoded, outcome.samples);
    write_bytes_atomic(&a.output, &bytes)?;
    let worst = encoded
        .material
        .records
        .iter()
        .max_by(|x, y| x.rel_error.total_cmp(&y.rel_error))
        .unwrap();
    eprintln!(
        "sbrdf: wrote {}: {} incident directions, {} wavelengths, {} bytes (raw float32 samples: {} \
         bytes, ratio {:.1}); relative error {:.4} overall, worst {:.4} at ({}, {})",
        a.output.display(),
        encoded.material.records.len(),
        set.wavelengths.len(),
        bytes.len(),
        encoded.raw_bytes,
        encoded.raw_bytes as f64 / bytes.len() as f64,
        encoded.rel_error,
        worst.rel_error,
        worst.theta_i,
        worst.phi_i
    );
    Ok(())
}

fn cmd_tradeoff(a: TradeoffArgs) -> Result<()> {
    if let Some(p) = &a.plot {
        if sbrdf::figures::ImageKind::of(p)? != sbrdf::figures::ImageKind::Svg {
            return Err(Error::Parameter(format!(
                "--plot {}: the trade-off plot is written as SVG (name it .svg)",
                p.display()
            )));
        }
    }
    let (set, _) = sbrdf::input::read_inputs(&a.inputs)?;
    let inputs: Vec<String> = a.inputs.iter().map(|p| p.display().to_string()).collect();
    let settings = sbrdf::tradeoff::sweep(a.quick, set.wavelengths.len());
    // A progress bar on stderr; indicatif draws nothing when stderr is not a terminal.
    let bar = indicatif::ProgressBar::new(settings.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} settings  {msg}")
            .expect("a valid template"),
    );
    let mut rows = Vec::with_capacity(settings.len());
    for s in &settings {
        bar.set_message(s.cli_options().join(" "));
        rows.push(sbrdf::tradeoff::measure(&set, &inputs, s)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    sbrdf::tradeoff::mark_pareto(&mut rows);
    write_atomic(&a.csv, |w| sbrdf::tradeoff::write_csv(&rows, w))?;
    if let Some(p) = &a.plot {
        let title = format!("sbrdf tradeoff: {}", inputs.join(", "));
        let svg = sbrdf::tradeoff::plot_svg(&rows, &title)?;
        write_bytes_atomic(p, svg.as_bytes())?;
    }
    let front = rows.iter().filter(|r| r.pareto).count();
    eprintln!(
        "sbrdf: {} settings measured, {front} on the Pareto front; report in {}",
        rows.len(),
        a.csv.display()
    );
    Ok(())
}

fn cmd_subset(a: SubsetArgs) -> Result<()> {
    let dec = Decoder::open(&a.input)?;
    let original = dec.into_material();
    let opts = sbrdf::subset::SubsetOptions {
        wavelengths: a
            .wavelengths
            .as_deref()
            .map(|w| settings::parse_window("wavelengths", w))
            .transpose()?,
        incident_max: a.incident_max,
        terms: a.terms,
        sh_level: a.sh_level,
        precision: a.precision.map(|_| Precision::F16),
    };
    let (m, report) = sbrdf::subset::subset(&original, &opts)?;
    let before = sbrdf::write_material(&original)?.len();
    let bytes = sbrdf::write_material(&m)?;
    write_bytes_atomic(&a.output, &bytes)?;
    for action in &report.actions {
        eprintln!("sbrdf: {action}");
    }
    if report.actions.is_empty() {
        eprintln!("sbrdf: nothing to cut: the file is copied unchanged");
    }
    let place = if report.at_stored_positions {
        "at the stored sample positions"
    } else {
        "on a 5° grid (the file stores no sample positions)"
    };
    eprintln!(
        "sbrdf: error per incidence: recorded, change made by the cuts ({place}), and the \
         upper bound now stored:"
    );
    for r in &report.records {
        eprintln!(
            "  ({}, {}): recorded {:.5}, change {:.5}, bound {:.5}",
            r.theta_i, r.phi_i, r.recorded, r.change, r.bound
        );
    }
    eprintln!(
        "sbrdf: wrote {}: {} bytes (was {before}, {:.0}%)",
        a.output.display(),
        bytes.len(),
        100.0 * bytes.len() as f64 / before as f64
    );
    Ok(())
}

fn cmd_decode(a: DecodeArgs) -> Result<()> {
    let dec = Decoder::open(&a.input)?;
    if a.exr {
        return decode_exr(&dec, &a);
    }
    match &a.like {
        Some(reference) => decode_like(&dec, reference, &a.output),
        None => {
            let m = dec.material();
            let sp = m.sample_positions.as_ref().ok_or_else(|| {
                Error::Parameter(format!(
                    "{} stores no sample positions (encoded with --no-sample-positions): \
                     give --like REF to name the positions",
                    a.input.display()
                ))
            })?;
            let total: u64 = sp
                .set_of_incidence
                .iter()
                .map(|&i| sp.sets[i as usize].len() as u64)
                .sum();
            if total > 1 << 26 {
                return Err(Error::LimitsExceeded(format!(
                    "{} lists {total} sample positions, more than this command writes; \
                     give --like REF to choose the positions",
                    a.input.display()
                )));
            }
            let wl: Vec<f64> = m.wavelengths.iter().map(|&w| w as f64).collect();
            let mut set = SampleSet {
                wavelengths: wl.clone(),
                incidences: Vec::new(),
            };
            for (i, r) in m.records.iter().enumerate() {
                let dirs = sp.sets[sp.set_of_incidence[i] as usize].directions();
                let mut values = vec![0.0; dirs.len() * wl.len()];
                for (d, dir) in dirs.iter().enumerate() {
                    dec.eval_deg(
                        (r.theta_i as f64, r.phi_i as f64),
                        (dir[0], dir[1]),
                        &wl,
                        &mut values[d * wl.len()..(d + 1) * wl.len()],
                    );
                }
                set.incidences.push(sbrdf::samples::IncidentSamples {
                    theta_i: r.theta_i as f64,
                    phi_i: r.phi_i as f64,
                    directions: dirs,
                    values,
                });
            }
            let note = format!(
                "decoded by sbrdf {} from {}",
                env!("CARGO_PKG_VERSION"),
                a.input.display()
            );
            write_atomic(&a.output, |w| csv_input::write_wide(&set, w, Some(&note)))
        }
    }
}

/// The stored sample grid of record `i` as (rows, columns) when it is an EXR pixel grid.
fn stored_pixel_grid(m: &sbrdf::Material, i: usize) -> Option<(usize, usize)> {
    let sp = m.sample_positions.as_ref()?;
    match sp.sets.get(*sp.set_of_incidence.get(i)? as usize)? {
        sbrdf::material::DirectionSet::Grid {
            theta0,
            dtheta,
            ntheta,
            phi0,
            dphi,
            nphi,
        } => {
            let (h, w) = (*ntheta as usize, *nphi as usize);
            let close = |a: f32, b: f64| (a as f64 - b).abs() <= 1e-5 * b.abs().max(1.0);
            (h > 0
                && w > 0
                && close(*dtheta, 90.0 / h as f64)
                && close(*theta0, 45.0 / h as f64)
                && close(*dphi, 360.0 / w as f64)
                && close(*phi0, 180.0 / w as f64))
            .then_some((h, w))
        }
        sbrdf::material::DirectionSet::List(_) => None,
    }
}

fn parse_resolution(s: &str) -> Result<(usize, usize)> {
    let bad = || {
        Error::Parameter(format!(
            "--resolution '{s}': expected rows x columns, like 18x72 (both 1..=4096)"
        ))
    };
    let (h, w) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    if !(1..=4096).contains(&h) || !(1..=4096).contains(&w) {
        return Err(bad());
    }
    Ok((h, w))
}

fn decode_exr(dec: &Decoder, a: &DecodeArgs) -> Result<()> {
    let m = dec.material();
    let fixed = a.resolution.as_deref().map(parse_resolution).transpose()?;
    let dir = &a.output;
    sbrdf::output::ensure_output_folder(dir, "--exr")?;
    let stem = a
        .input
        .file_stem()
        .map_or("slice".into(), |s| s.to_string_lossy().into_owned());
    let wl: Vec<f64> = m.wavelengths.iter().map(|&w| w as f64).collect();
    let pixel_type = match a.pixel_type {
        PixelTypeArg::Half => sbrdf::exr_io::PixelType::Half,
        PixelTypeArg::Float => sbrdf::exr_io::PixelType::Float,
    };
    for (i, r) in m.records.iter().enumerate() {
        let (h, w) = fixed
            .or_else(|| stored_pixel_grid(m, i))
            .unwrap_or((18, 72));
        let (ti, pi) = (r.theta_i as f64, r.phi_i as f64);
        let mut values = vec![0.0; h * w * wl.len()];
        for row in 0..h {
            for col in 0..w {
                let o = sbrdf::exr_io::pixel_direction(row, col, h, w);
                let at = (row * w + col) * wl.len();
                dec.eval_deg((ti, pi), (o[0], o[1]), &wl, &mut values[at..at + wl.len()]);
            }
        }
        let bytes = sbrdf::exr_io::write_slice(ti, pi, h, w, &wl, &values, pixel_type)?;
        let path = dir.join(sbrdf::exr_io::slice_file_name(&stem, ti, pi));
        write_bytes_atomic(&path, &bytes)?;
    }
    eprintln!(
        "sbrdf: wrote {} spectral EXR slices ({} wavelengths) to {}",
        m.records.len(),
        wl.len(),
        dir.display()
    );
    Ok(())
}

fn decode_like(dec: &Decoder, reference: &Path, output: &Path) -> Result<()> {
    write_atomic(output, |w| {
        let mut out = csv::WriterBuilder::new().flexible(true).from_writer(w);
        let mut wrote_header = false;
        let mut values = Vec::new();
        let fail = |e: csv::Error| Error::Parameter(format!("{}: {e}", output.display()));
        csv_input::scan(reference, |h, row, raw| {
            if !wrote_header {
                out.write_record(&h.names).map_err(fail)?;
                wrote_header = true;
            }
            let inc = (row.angles[0], row.angles[1]);
            let outg = (row.angles[2], row.angles[3]);
            let mut fields: Vec<String> = raw.iter().map(|s| s.to_string()).collect();
            match &h.layout {
                Layout::Long { value, .. } => {
                    let mut v = [0.0];
                    dec.eval_deg(inc, outg, &[row.wavelength.unwrap()], &mut v);
                    fields[*value] = v[0].to_string();
                }
                Layout::Wide { columns } => {
                    let wl: Vec<f64> = columns.iter().map(|c| c.1).collect();
                    values.resize(wl.len(), 0.0);
                    dec.eval_deg(inc, outg, &wl, &mut values);
                    for (j, (c, _)) in columns.iter().enumerate() {
                        fields[*c] = values[j].to_string();
                    }
                }
            }
            out.write_record(&fields).map_err(fail)
        })?;
        out.flush().map_err(|e| Error::Io {
            path: Some(output.to_path_buf()),
            source: e,
        })
    })
}

fn cmd_eval(a: EvalArgs) -> Result<()> {
    let dec = Decoder::open(&a.input)?;
    let inc = parse_pair("incident", &a.incident)?;
    let outg = parse_pair("outgoing", &a.outgoing)?;
    if !(0.0..=90.0).contains(&inc.0) {
        return Err(Error::Parameter(format!(
            "--incident θ = {} is outside [0, 90] degrees",
            inc.0
        )));
    }
    if outg.0 < 0.0 || outg.0 > 180.0 {
        return Err(Error::Parameter(format!(
            "--outgoing θ = {} is outside [0, 180] degrees",
            outg.0
        )));
    }
    let m = dec.material();
    let wl: Vec<f64> = match a.wavelengths {
        Some(w) => w,
        None => m.wavelengths.iter().map(|&w| w as f64).collect(),
    };
    let (lo, hi) = (m.spectral.lambda_min, m.spectral.lambda_max);
    if let Some(l) = wl
        .iter()
        .find(|l| !(l.is_finite() && **l >= lo && **l <= hi))
    {
        return Err(Error::Parameter(format!(
            "--wavelengths {l} is outside the file's range {lo}–{hi} nm"
        )));
    }
    let mut out = vec![0.0; wl.len()];
    dec.eval_deg(inc, outg, &wl, &mut out);
    println!("wavelength_nm,value");
    for (l, v) in wl.iter().zip(&out) {
        println!("{l},{v}");
    }
    Ok(())
}

fn cmd_info(a: InfoArgs) -> Result<()> {
    let len = std::fs::metadata(&a.input)
        .map_err(|e| Error::Io {
            path: Some(a.input.clone()),
            source: e,
        })?
        .len();
    let dec = Decoder::open(&a.input)?;
    let m = dec.material();
    if a.json {
        let v = sbrdf::info::to_json(m, &a.input.display().to_string(), len);
        println!("{}", serde_json::to_string_pretty(&v).unwrap());
        return Ok(());
    }
    println!("file:           {} ({len} bytes)", a.input.display());
    println!(
        "format:         sbrdf {}.{}",
        sbrdf::format::VERSION_MAJOR,
        m.version_minor
    );
    println!(
        "spectral basis: {}, {} terms over [{}, {}] nm",
        m.spectral.basis.name(),
        m.spectral.terms,
        m.spectral.lambda_min,
        m.spectral.lambda_max
    );
    println!(
        "wavelengths:    {} samples, {}–{} nm",
        m.wavelengths.len(),
        m.wavelengths[0],
        m.wavelengths.last().unwrap()
    );
    println!(
        "SH level:       {} ({} coefficients per term)",
        m.sh_level,
        m.sh_count()
    );
    println!("precision:      {}", m.precision_name());
    println!(
        "incidences:     {}{}",
        m.records.len(),
        if m.isotropic {
            " (isotropic: φi = 0 only)"
        } else {
            ""
        }
    );
    println!("records:        θi      φi      θp      φp      critical  lobes  rel_error");
    for r in &m.records {
        println!(
            "                {:<7} {:<7} {:<7.3} {:<7.3} {:<9.2} {:<6} {:.5}",
            r.theta_i,
            r.phi_i,
            r.theta_p,
            r.phi_p,
            r.critical_angle,
            r.lobes.len(),
            r.rel_error
        );
    }
    if let Some(meta) = &m.metadata {
        println!("metadata:       {meta}");
    }
    Ok(())
}

fn cmd_verify(a: VerifyArgs) -> Result<()> {
    let dec = Decoder::open(&a.input)?;
    let m = dec.material();
    println!(
        "ok: {}: sbrdf {}.{}, {} records; every CRC and the structure check out",
        a.input.display(),
        sbrdf::format::VERSION_MAJOR,
        m.version_minor,
        m.records.len()
    );
    Ok(())
}

fn parse_range(s: &str) -> Result<Vec<f64>> {
    let bad = || {
        Error::Parameter(format!(
            "--wavelengths '{s}': expected MIN:MAX:STEP, like 400:700:10"
        ))
    };
    let parts: Vec<f64> = s
        .split(':')
        .map(|p| p.trim().parse::<f64>().map_err(|_| bad()))
        .collect::<Result<_>>()?;
    let [lo, hi, step] = parts[..] else {
        return Err(bad());
    };
    if !(lo.is_finite() && hi.is_finite() && step.is_finite() && step > 0.0 && hi >= lo) {
        return Err(bad());
    }
    let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
    if n > 100_000 {
        return Err(bad());
    }
    Ok((0..n).map(|i| lo + i as f64 * step).collect())
}

fn check_nonnegative(values: &[(&str, f64)]) -> Result<()> {
    for (name, v) in values {
        if !(v.is_finite() && *v >= 0.0) {
            return Err(Error::Parameter(format!(
                "--{name} {v} must be a finite number ≥ 0"
            )));
        }
    }
    Ok(())
}

/// Samples `f` on the grid the arguments describe and writes it; `note` heads the file.
fn write_synth(
    g: &GridArgs,
    note: &str,
    f: impl Fn((f64, f64), (f64, f64), usize) -> f64,
) -> Result<()> {
    let wl = parse_range(&g.wavelengths)?;
    for (name, v) in [("theta-step", g.theta_step), ("phi-step", g.phi_step)] {
        if !(v.is_finite() && v >= 0.01) {
            return Err(Error::Parameter(format!(
                "--{name} {v} must be at least 0.01 degrees"
            )));
        }
    }
    let mut incidences = Vec::new();
    for s in &g.incident {
        let (t, p) = parse_pair("incident", s)?;
        if !(0.0..=90.0).contains(&t) {
            return Err(Error::Parameter(format!(
                "--incident θ = {t} is outside [0, 90]"
            )));
        }
        incidences.push((t, sbrdf::angles::wrap_phi(p)));
    }
    if g.layout == LayoutArg::Exr {
        return write_synth_exr(g, &wl, &incidences, f);
    }
    let dirs = paper_grid(g.theta_step, g.phi_step);
    let set = sample_material(&wl, &incidences, &dirs, f);
    write_atomic(&g.output, |w| match g.layout {
        LayoutArg::Wide => csv_input::write_wide(&set, w, Some(note)),
        LayoutArg::Long => {
            writeln!(w, "# {note}").map_err(|e| Error::Io {
                path: None,
                source: e,
            })?;
            csv_input::write_long(&set, w)
        }
        LayoutArg::Exr => unreachable!("handled above"),
    })
}

/// `synth --layout exr`: one float slice per incidence, pixel centres as outgoing directions.
fn write_synth_exr(
    g: &GridArgs,
    wl: &[f64],
    incidences: &[(f64, f64)],
    f: impl Fn((f64, f64), (f64, f64), usize) -> f64,
) -> Result<()> {
    let count = |span: f64, step: f64, name: &str| -> Result<usize> {
        let n = (span / step).round();
        if (n * step - span).abs() > 1e-9 * span || !(1.0..=4096.0).contains(&n) {
            return Err(Error::Parameter(format!(
                "--{name} {step} must divide {span}° into 1..=4096 pixels for --layout exr"
            )));
        }
        Ok(n as usize)
    };
    let h = count(90.0, g.theta_step, "theta-step")?;
    let w = count(360.0, g.phi_step, "phi-step")?;
    let dir = &g.output;
    sbrdf::output::ensure_output_folder(dir, "--layout exr")?;
    let stem = dir
        .file_name()
        .map_or("slice".into(), |s| s.to_string_lossy().into_owned());
    for &(ti, pi) in incidences {
        let mut values = Vec::with_capacity(h * w * wl.len());
        for row in 0..h {
            for col in 0..w {
                let [to, po] = sbrdf::exr_io::pixel_direction(row, col, h, w);
                values.extend((0..wl.len()).map(|k| f((ti, pi), (to, po), k)));
            }
        }
        let bytes =
            sbrdf::exr_io::write_slice(ti, pi, h, w, wl, &values, sbrdf::exr_io::PixelType::Float)?;
        write_bytes_atomic(
            &dir.join(sbrdf::exr_io::slice_file_name(&stem, ti, pi)),
            &bytes,
        )?;
    }
    Ok(())
}

fn cmd_phong(a: PhongArgs) -> Result<()> {
    let table = SpectrumTable::colorchecker();
    let wl = parse_range(&a.grid.wavelengths)?;
    check_nonnegative(&[("kd", a.kd), ("ks", a.ks), ("n", a.n)])?;
    let phong = Phong {
        diffuse: table.sample(table.find(&a.diffuse)?, &wl)?,
        specular: table.sample(table.find(&a.specular)?, &wl)?,
        kd: a.kd,
        ks: a.ks,
        n: a.n,
    };
    let note = format!(
        "sbrdf synth phong --diffuse {:?} --specular {:?} --kd {} --ks {} --n {}",
        a.diffuse, a.specular, a.kd, a.ks, a.n
    );
    write_synth(&a.grid, &note, |i, o, w| phong.value(i, o, w))
}

fn cmd_ggx(a: GgxArgs) -> Result<()> {
    let table = SpectrumTable::colorchecker();
    let wl = parse_range(&a.grid.wavelengths)?;
    check_nonnegative(&[("kd", a.kd), ("alpha", a.alpha)])?;
    if a.alpha < 1e-3 || a.alpha > 1.0 {
        return Err(Error::Parameter(format!(
            "--alpha {} is outside [0.001, 1]",
            a.alpha
        )));
    }
    let ggx = sbrdf::synth::Ggx {
        alpha: a.alpha,
        kd: a.kd,
        diffuse: table.sample(table.find(&a.diffuse)?, &wl)?,
        f0: table
            .sample(table.find(&a.fresnel)?, &wl)?
            .iter()
            .map(|v| 0.04 + 0.5 * v)
            .collect(),
    };
    let note = format!(
        "sbrdf synth ggx --alpha {} --diffuse {:?} --fresnel {:?} --kd {}",
        a.alpha, a.diffuse, a.fresnel, a.kd
    );
    write_synth(&a.grid, &note, |i, o, w| ggx.value(i, o, w))
}

fn cmd_abc(a: AbcArgs) -> Result<()> {
    let wl = parse_range(&a.grid.wavelengths)?;
    let abc = sbrdf::synth::Abc::from_table(&a.material, &a.diffuse, &wl)?;
    let note = format!(
        "sbrdf synth abc --material {:?} --diffuse {:?}",
        a.material, a.diffuse
    );
    write_synth(&a.grid, &note, |i, o, w| abc.value(i, o, w))
}
