//! `sbrdf encode`: its flags, mapped onto the library's option set
//! ([`sbrdf::encode::settings::EncodeSettings`]), which the Python binding shares.

use clap::{Args, ValueEnum};
use sbrdf::encode::fit::{LobeFamily, PeakMode};
use sbrdf::encode::settings::{self, EncodeSettings, WarpedChoice};
use sbrdf::encode::{EncodeOptions, ModelChoice};
use sbrdf::io::output::write_bytes_atomic;
use sbrdf::model::warped::TableTransform;
use sbrdf::{Precision, Result, SpectralBasis};
use std::path::PathBuf;

#[derive(Clone, Copy, ValueEnum)]
pub enum BasisArg {
    /// The paper's periodic Fourier series (a0, a1, b1, a2, b2, …).
    Fourier,
    /// Cosine series (DCT): no wrap-around between the ends of the spectrum.
    Cosine,
    /// Derived from the data (leading singular vectors, stored in the file); --terms is the rank.
    Data,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum PeakArg {
    /// SH background + Gaussian peak (the paper's method).
    Paper,
    /// SH only (the paper's baseline).
    None,
    /// SH background and lobe amplitudes fitted together, lobe width searched (no critical angle).
    Joint,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum LobeArg {
    /// Phong's lobe: a power of the cosine of the angle from the peak direction.
    CosinePower,
    /// A Gaussian in the angle from the peak direction.
    Gaussian,
    /// A microfacet lobe in the half vector (1 − cos θh), with shadowing and Fresnel variants.
    Microfacet,
    /// The same in sin²θh (GGX-shaped).
    MicrofacetSin2,
    /// The same with two roughnesses along turned surface axes (anisotropic GGX-shaped: brushed
    /// metal, satin); used only when the input has several incident azimuths.
    MicrofacetAniso,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum ModelArg {
    /// Records, unless they cannot meet the budget between the samples of an isotropic input
    /// (measured data); then whichever of records and the shared model predicts held-out
    /// samples better. An explicit --max-error keeps records.
    Auto,
    /// One record per incidence (SH background and lobes), fitted to its own samples: the most
    /// accurate at the samples of dense, clean data.
    Records,
    /// One factor model shared by every incidence (isotropic inputs): for sparse, noisy
    /// measurements, predicting between the samples and between the incidences.
    Shared,
    /// The measurement kept on its own warped grid, transform-coded (format 1.4): for one
    /// isotropic RGL file, which `auto` also encodes this way. The error budget (--max-error,
    /// default 1%) holds at every stored incidence's nodes.
    Warped,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum TransformArg {
    /// Whichever gives the smaller file.
    Auto,
    /// Orthonormal DCT-II (format 1.4).
    Dct,
    /// CDF 5/3 wavelet (format 1.5).
    Wavelet,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum PrecisionArg {
    F32,
    F16,
}

#[derive(Args)]
pub struct EncodeArgs {
    /// Inputs: CSV files (long or wide layout), spectral-EXR slices (one per incident
    /// Inputs: CSV files (long or wide layout), spectral-EXR slices (one per incident
    /// direction), ASTM E1392 text, RGL material-database measurements (`*_spec.bsdf`;
    /// `*_rgb.bsdf` with --rgb-to-spectrum), or folders of them; all are merged.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output .sbrdf file (written atomically).
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub options: EncodeOptionArgs,
}

/// The encoder's options, as `encode`, `validate` and the other commands that encode take them.
#[derive(Args)]
pub struct EncodeOptionArgs {
    /// Which model the file holds.
    #[arg(long, value_enum, default_value = "auto")]
    pub model: ModelArg,
    /// Warped tables' transform (one RGL file): `dct` (format 1.4, smooth tables), `wavelet`
    /// (1.5, local features such as a one-column spike) or `auto`, whichever gives the smaller
    /// file.
    #[arg(long, value_enum, default_value = "auto")]
    pub transform: TransformArg,
    /// Spectral basis.
    #[arg(long, value_enum, default_value = "data")]
    pub basis: BasisArg,
    /// Number of spectral terms K (13 = a0, a1..a6, b1..b6 for fourier) [default: 13 for
    /// fourier and cosine; for data the smallest rank leaving ≤ half the error budget, ≤ 8].
    #[arg(long)]
    pub terms: Option<usize>,
    /// Spherical-harmonic level L (with an error budget, the highest tried) [default: 6 with
    /// --peak joint, 1 with --peak paper, 4 with --peak none].
    #[arg(long)]
    pub sh_level: Option<usize>,
    /// How the specular peak is represented.
    #[arg(long, value_enum, default_value = "joint")]
    pub peak: PeakArg,
    /// Critical angle in degrees around the peak, or `auto` to minimise the error.
    #[arg(long, default_value = "auto")]
    pub critical_angle: String,
    /// Storage precision of coefficients (with an error budget, f16 records fall back to f32
    /// where f16 misses it).
    #[arg(long, value_enum, default_value = "f16")]
    pub precision: PrecisionArg,
    /// Lobe shapes the joint fit may use, per incidence the better one.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "cosine-power,gaussian,microfacet,microfacet-sin2"
    )]
    pub lobes: Vec<LobeArg>,
    /// Relative error budget per incident direction (0.01 = 1%): with --peak joint, the smallest
    /// model (spectral terms, SH level, lobe, precision) meeting it; with warped tables (one RGL
    /// file), the largest quantisation step meeting it at every stored incidence. Given
    /// explicitly, the encode fails where it cannot be met [default with --peak joint: 0.5%,
    /// best effort; with warped tables: 1%, or an incidence's estimated measurement noise
    /// where that is higher, so that no bytes code noise (`sbrdf info` shows the estimate)].
    #[arg(long, value_name = "E")]
    pub max_error: Option<String>,
    /// With --max-error: write the most accurate model where the budget cannot be met, and
    /// succeed.
    #[arg(long)]
    pub best_effort: bool,
    /// Provenance recorded in the file's metadata (repeatable).
    #[arg(long, value_name = "KEY=VALUE")]
    pub metadata: Vec<String>,
    /// Do not store the outgoing sample positions (smaller file; `decode` then needs --like).
    #[arg(long)]
    pub no_sample_positions: bool,
    /// What the metadata keeps: `full` (the encoder, inputs, every option, provenance, the
    /// error), `short` (the encoder, options that differ from the defaults, provenance, the
    /// error) or `none` (no metadata chunk).
    #[arg(long, value_name = "LEVEL", default_value = "full")]
    pub meta: String,
    /// The newest format version the file may use: 1.7 (warped tables: an incidence may be coded
    /// as its difference to the one before, and the header keeps θi alone: 10–14% fewer bytes on
    /// RGL measurements), 1.6 (warped
    /// tables' integers range-coded, 19–34% fewer bytes), 1.5 (warped tables deflated, either transform), 1.4 (warped tables
    /// deflated, the DCT only), 1.3 (compact records: 27 bytes fewer per incidence; records and
    /// the shared model are never written above 1.3), 1.2 (anisotropic lobes, for inputs with
    /// several incident azimuths), 1.1 (evenly spaced wavelengths stored as a range, the shared
    /// factor model) or 1.0 (readable by every 1.0 reader). Below 1.3 a file is written as the
    /// lowest version whose features it uses: one using no 1.1 feature is 1.0. Give an older
    /// version for readers older than this sbrdf (warped tables need 1.4).
    #[arg(long, value_name = "VERSION", default_value = "1.7")]
    pub format: String,
    /// Keep only the input's wavelengths within MIN:MAX nm (what a scene renders).
    #[arg(long, value_name = "MIN:MAX")]
    pub wavelengths: Option<String>,
    /// Keep only incident directions with θi ≤ DEG (what a scene's lights reach).
    #[arg(long, value_name = "DEG")]
    pub incident_max: Option<f64>,
    /// Accept RGB-only measurements (RGL `*_rgb.bsdf`) by making a spectrum of each colour with
    /// this published method, recorded in the file's metadata. Without it they are refused:
    /// use the material's `*_spec.bsdf` file. jakob-hanika-2019: a sigmoid of a quadratic in λ
    /// whose linear sRGB under D65 is the colour (what Mitsuba 3 does with RGB reflectances);
    /// it reproduces the colour, not the measured spectrum.
    #[arg(long, value_name = "METHOD", value_parser = ["jakob-hanika-2019"])]
    pub rgb_to_spectrum: Option<String>,
}

impl EncodeOptionArgs {
    /// The library's option set for these flags.
    pub fn settings(&self) -> Result<EncodeSettings> {
        let a = self;
        let encoder = EncodeOptions {
            basis: match a.basis {
                BasisArg::Fourier => SpectralBasis::PeriodicFourier,
                BasisArg::Cosine => SpectralBasis::Cosine,
                BasisArg::Data => SpectralBasis::Tabulated,
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
                    LobeArg::MicrofacetAniso => LobeFamily::MicrofacetAniso,
                })
                .collect(),
            sample_positions: !a.no_sample_positions,
            provenance: a
                .metadata
                .iter()
                .map(|kv| settings::parse_metadata(kv))
                .collect::<Result<_>>()?,
            meta: settings::parse_meta(&a.meta)?,
            format_minor: settings::parse_format(&a.format)?,
            model: match a.model {
                ModelArg::Auto => ModelChoice::Auto,
                ModelArg::Records => ModelChoice::Records,
                ModelArg::Shared => ModelChoice::Shared,
                // Handled before the sample-based encoder (`encode_warped_file`).
                ModelArg::Warped => ModelChoice::Auto,
            },
            // Resolved by EncodeSettings::options.
            ..EncodeOptions::default()
        };
        let settings = EncodeSettings {
            encoder,
            max_error: a
                .max_error
                .as_deref()
                .map(|e| settings::parse_fraction("max-error", e))
                .transpose()?,
            best_effort: a.best_effort,
            wavelengths: a
                .wavelengths
                .as_deref()
                .map(|w| settings::parse_window("wavelengths", w))
                .transpose()?,
            incident_max: a.incident_max,
            read: sbrdf::io::ReadOptions {
                rgb_to_spectrum: a
                    .rgb_to_spectrum
                    .as_deref()
                    .map(settings::parse_rgb_to_spectrum)
                    .transpose()?,
            },
            warped: match a.model {
                ModelArg::Auto => WarpedChoice::Auto,
                ModelArg::Warped => WarpedChoice::Required,
                ModelArg::Records | ModelArg::Shared => WarpedChoice::Never,
            },
            transform: match a.transform {
                TransformArg::Auto => None,
                TransformArg::Dct => Some(TableTransform::Dct),
                TransformArg::Wavelet => Some(TableTransform::Wavelet53),
            },
        };
        Ok(settings)
    }
}

pub fn cmd_encode(a: EncodeArgs) -> Result<()> {
    let settings = a.options.settings()?;
    if super::encode_warped::try_encode(&a.inputs, &a.output, &settings)? {
        return Ok(());
    }
    let (set, report) = sbrdf::io::read_inputs_with(&a.inputs, &settings.read)?;
    let inputs: Vec<String> = a.inputs.iter().map(|p| p.display().to_string()).collect();
    // A progress bar on stderr, drawn only when it is a terminal (indicatif hides it otherwise).
    let bar = std::sync::OnceLock::<indicatif::ProgressBar>::new();
    let progress = |done: usize, total: usize| {
        let b = bar.get_or_init(|| {
            let b = indicatif::ProgressBar::new(total as u64);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "sbrdf: fitting {bar:32} {pos}/{len} incidences, {elapsed} (about {eta} left)",
            ) {
                b.set_style(style);
            }
            b
        });
        b.set_position(done as u64);
    };
    let outcome =
        settings::encode_samples_with_progress(set, &report, &inputs, &settings, Some(&progress));
    if let Some(b) = bar.get() {
        b.finish_and_clear();
    }
    let outcome = outcome?;
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
