//! `sbrdf`: the command-line front end. All logic lives in the library; this file parses the
//! command line and dispatches to one module of [`cli`] per subcommand (or group), which calls
//! the library; errors become messages and exit codes here.

mod cli;

use clap::{Parser, Subcommand};
use cli::{decode, encode, figures, inspect, layout, subset, synth, tradeoff, validate};
use sbrdf::Result;
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
    /// Fit sampled BRDFs (CSV, spectral-EXR slices, ASTM E1392 text, RGL .bsdf) and write an .sbrdf file.
    #[command(
        after_help = "CSV layouts (found by header name; '#' lines are comments):\n  \
long: theta_i,phi_i,theta_o,phi_o,wavelength_nm,value   (one sample a row)\n  \
wide: theta_i,phi_i,theta_o,phi_o,400,410,...           (one column per wavelength; '400nm' works too)\n\n\
Other inputs: spectral-EXR slices (.exr, or a folder of them), ASTM E1392 text (.astm: keyword \
lines, NUM_POINTS, VARS theta_i,phi_i,theta_s,phi_s,400nm,...; angles in radians unless \
ANGLE_UNITS DEGREES; the header is kept in the file's metadata) and \
RGL material database files (rgl.epfl.ch/materials, Dupuy & Jakob 2018; what Mitsuba 3's \
`measured` plugin loads): each stored incidence's warped grid is turned into real outgoing \
directions. Incidences above 85° (the files' last, 89.999995°) are left out, grid nodes below the \
horizon dropped, nodes sharing a direction averaged, and where the grid leaves no node within 5° \
the file's own interpolation (Mitsuba's evaluation) is sampled on a 5° grid. `*_spec.bsdf` gives spectra at the file's \
wavelengths; `*_rgb.bsdf` holds only linear sRGB and is refused unless --rgb-to-spectrum says how \
to make spectra of it.\n\n\
Examples:\n  sbrdf encode material.csv -o material.sbrdf\n  \
sbrdf encode ti*.csv -o m.sbrdf --sh-level 2 --precision f16 --metadata source=lab42\n  \
sbrdf encode material.csv -o direct.sbrdf --peak none --sh-level 4\n  \
sbrdf encode acryl_blue.astm -o acryl.sbrdf\n  \
sbrdf encode satin_rosaline_spec.bsdf -o satin.sbrdf\n  \
sbrdf encode satin_rosaline_rgb.bsdf -o satin.sbrdf --rgb-to-spectrum jakob-hanika-2019"
    )]
    Encode(encode::EncodeArgs),
    /// Write the reconstruction as CSV, EXR slices or ASTM text, at a reference file's positions
    /// or at the encoder's.
    #[command(
        after_help = "Examples:\n  sbrdf decode m.sbrdf -o back.csv --like material.csv\n  \
sbrdf decode m.sbrdf -o back.csv        (at the sample positions the encoder saw, wide layout)\n  \
sbrdf decode m.sbrdf -o back.astm --astm   (ASTM E1392 text, with the source file's header)"
    )]
    Decode(decode::DecodeArgs),
    /// Print the spectrum at one pair of directions as CSV `wavelength_nm,value`.
    #[command(
        after_help = "Directions below the horizon (θ > 90) give 0. Files of records: an incident \
direction that is not stored is answered by interpolating the neighbouring records' parameters \
(isotropic files: rotated to φi = 0 first); outside the stored θi range, the nearest stored θi \
is used. Files with warped tables (RGL measurements): the tables follow the viewing direction \
(--outgoing), blended between the stored viewing angles and clamped to their range; the value \
divides by the light's cos θi, at least 1/1024 (89.94°), so it stays finite at the horizon; at the \
mirror direction the half vector is the pole. Wavelengths outside the file's range are refused \
here (a decoder evaluates them as the nearest end).\n\n\
Example:\n  sbrdf eval m.sbrdf --incident 15,0 --outgoing 15,180 --wavelengths 450,550"
    )]
    Eval(inspect::EvalArgs),
    /// Write a file's flat device layout (spec/GPU_LAYOUT.md): 32-bit little-endian words for
    /// a GPU kernel to evaluate.
    #[command(
        after_help = "Every file is covered: records (layout version 1 and on), the sampling \
section (2), a factor model (FACT, 3) and warped tables (WARP, 4).\n\nExample:\n  \
sbrdf layout m.sbrdf -o m.layout.bin"
    )]
    Layout(layout::LayoutArgs),
    /// Describe a file: its settings, records and metadata.
    #[command(after_help = "Examples:\n  sbrdf info m.sbrdf\n  sbrdf info m.sbrdf --json")]
    Info(inspect::InfoArgs),
    /// Check every CRC and the whole structure of a file.
    #[command(
        after_help = "Example (exit status 0 when the file is whole):\n  sbrdf verify m.sbrdf"
    )]
    Verify(inspect::VerifyArgs),
    /// Generate test materials.
    #[command(
        subcommand,
        after_help = "Examples (each subcommand's --help has more):\n  \
sbrdf synth phong --diffuse green --specular white --kd 1 --ks 15 --n 15 --incident 15,0 -o phong.csv\n  \
sbrdf synth ggx --alpha 0.1 --diffuse blue --fresnel yellow --incident 0,0 --incident 45,0 -o ggx.csv"
    )]
    Synth(synth::SynthCommand),
    /// Draw what a file stores at one incidence: a coefficient over the outgoing hemisphere
    /// (background and peak), beside the original samples, and spectra at chosen directions.
    Plot(figures::PlotArgs),
    /// Render a sphere lit by a point light (D65), spectrally, to an sRGB picture.
    Preview(figures::PreviewArgs),
    /// Regenerate the data and plots of the paper's Figs. 4, 6 and 7, paper mode beside the
    /// default mode.
    PaperFigures(figures::PaperFiguresArgs),
    /// Derive a smaller file from an existing one (no samples needed): fewer incidences,
    /// wavelengths, spectral terms or SH functions, or f16 storage.
    #[command(
        after_help = "Every cut truncates (incidences, wavelengths of a data-derived basis, spectral terms, SH \
functions) or rounds (f16); an analytic basis cut to fewer wavelengths is re-tabulated at the kept \
ones (exact there, linear between). Nothing is re-fitted: there are no samples. Each record's \
stored error becomes an upper bound on its new error, from its recorded error and the change the \
cuts made (measured against the original at its stored sample positions). Re-encoding from the samples with \
`encode --wavelengths --incident-max` gives the best file of a size; subset gives one at once.\n\n\
Example (a scene rendering 450–650 nm with lights below 60°):\n  \
sbrdf subset m.sbrdf -o scene.sbrdf --wavelengths 450:650 --incident-max 60 --precision f16"
    )]
    Subset(subset::SubsetArgs),
    /// Encode the input over a sweep of settings and report size, error and speed of each.
    #[command(
        after_help = "Each row's encode_options column holds the `sbrdf encode` options that \
reproduce it. Errors are measured against the input samples as `decode --like` does; eval times \
are the best of five runs of 4096 random queries on this machine. pareto = 1 marks the rows no \
other row beats in both size and error.\n\n\
Example:\n  \
sbrdf tradeoff material.csv --csv report.csv --plot report.svg --quick"
    )]
    Tradeoff(tradeoff::TradeoffArgs),
    /// Measure how far to trust a file between the measurements: the fit error, the k-fold
    /// held-out error and (optionally) the error at each incidence left out, rel and log.
    #[command(
        after_help = "Takes the encode options; encodes the input once whole, once per fold and once per incidence \
left out. fit: decoded at the samples it was fitted to. k-fold: each incidence's outgoing samples \
in a fixed random order, every k-th held out in turn from every incidence at once, predictions \
pooled. left out: encoded without that incidence, decoded at all of its samples. rel = \
sqrt(Σ(ρ̂ − ρ)²/Σρ²): predicting 0 scores 1, above 1 a model invents energy. log = RMS of \
ln((ρ̂ + ε)/(ρ + ε)), ε = 1% of the median spectral mean: every value weighs alike, where rel is \
dominated by the brightest samples. nn: the same figures for the nearest sample the encode was \
given (no model), on the same held-out values: a file above them does worse than the \
measurement itself.\n\n\
Examples:\n  \
sbrdf validate material.csv --leave-incidence-out\n  \
sbrdf validate ptfe.csv --folds 10 --max-error 1%"
    )]
    Validate(validate::ValidateArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Interrupted (Ctrl-C, SIGTERM, SIGHUP): no destructor runs, so remove the outputs being
    // written here, then exit as a shell expects of an interrupted program (128 + SIGINT).
    // If the handler cannot be installed the default action stays: the destination is still
    // never damaged, but a `.sbrdf-partial-*` file may be left beside it.
    let _ = ctrlc::set_handler(|| {
        sbrdf::io::output::remove_partial_outputs();
        std::process::exit(130);
    });
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
        Command::Encode(a) => encode::cmd_encode(a),
        Command::Decode(a) => decode::cmd_decode(a),
        Command::Eval(a) => inspect::cmd_eval(a),
        Command::Layout(a) => layout::cmd_layout(a),
        Command::Info(a) => inspect::cmd_info(a),
        Command::Verify(a) => inspect::cmd_verify(a),
        Command::Synth(c) => synth::run(c),
        Command::Plot(a) => figures::cmd_plot(a),
        Command::Preview(a) => figures::cmd_preview(a),
        Command::PaperFigures(a) => figures::cmd_paper_figures(a),
        Command::Subset(a) => subset::cmd_subset(a),
        Command::Tradeoff(a) => tradeoff::cmd_tradeoff(a),
        Command::Validate(a) => validate::cmd_validate(a),
    }
}
