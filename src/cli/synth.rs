//! `sbrdf synth`: the test materials (Phong, GGX, MERL ABC fits) sampled on a grid and written
//! as CSV or spectral-EXR slices.

use super::parse::{check_nonnegative, parse_pair, parse_range};
use clap::{Args, Subcommand, ValueEnum};
use sbrdf::io::csv as csv_io;
use sbrdf::io::exr;
use sbrdf::io::output::{ensure_output_folder, write_atomic, write_bytes_atomic};
use sbrdf::io::synth::{paper_grid, sample_material, Abc, Ggx, Phong};
use sbrdf::model::angles::wrap_phi;
use sbrdf::{Error, Result};
use std::path::PathBuf;

#[derive(Subcommand)]
pub enum SynthCommand {
    /// The paper's Phong material: ρ = kd·Sd(λ) + ks·Ss(λ)·max(0, cos α)^n, α the angle from the
    /// mirror direction, with ColorChecker spectra (N. Ohta) for Sd and Ss.
    #[command(after_help = "Example (the paper's setup):\n  \
sbrdf synth phong --diffuse green --specular white --kd 1 --ks 15 --n 15 --incident 15,0 -o phong.csv")]
    Phong(PhongArgs),
    /// A GGX microfacet material: kd·Sd(λ)/π + D·G2·F/(4 cos θi cos θo), height-correlated
    /// Smith G2, Schlick Fresnel with F0(λ) = 0.04 + 0.5·(the --fresnel patch). Isotropic with
    /// --alpha, anisotropic (brushed metal) with --alpha-x, --alpha-y and --axis-angle.
    #[command(after_help = "Examples:\n  \
sbrdf synth ggx --alpha 0.1 --diffuse blue --fresnel yellow --incident 0,0 --incident 45,0 -o ggx.csv\n  \
sbrdf synth ggx --alpha-x 0.08 --alpha-y 0.35 --axis-angle 30 --diffuse blue --fresnel yellow \\\n    \
--incident 20,0 --incident 20,45 --incident 40,0 --incident 40,45 -o brushed.csv")]
    Ggx(GgxArgs),
    /// A MERL material from Löw et al.'s ABC fits, made spectral with a ColorChecker diffuse
    /// colour and a dispersive dielectric Fresnel (see the library's `synth::Abc`).
    #[command(after_help = "Example:\n  \
sbrdf synth abc --material pearl-paint --diffuse orange --incident 30,0 -o pearl.csv")]
    Abc(AbcArgs),
}

#[derive(Args)]
#[command(group(clap::ArgGroup::new("roughness").required(true).args(["alpha", "alpha_x"])))]
pub struct GgxArgs {
    /// GGX roughness α (isotropic).
    #[arg(long, conflicts_with_all = ["alpha_x", "alpha_y", "axis_angle"])]
    pub alpha: Option<f64>,
    /// Anisotropic GGX: roughness along the first surface axis.
    #[arg(long, requires = "alpha_y")]
    pub alpha_x: Option<f64>,
    /// Anisotropic GGX: roughness along the second axis (perpendicular to the first).
    #[arg(long, requires = "alpha_x")]
    pub alpha_y: Option<f64>,
    /// Anisotropic GGX: angle of the first axis from the tangent x towards y, degrees.
    #[arg(
        long,
        requires = "alpha_x",
        default_value_t = 0.0,
        allow_hyphen_values = true
    )]
    pub axis_angle: f64,
    /// Diffuse ColorChecker patch.
    #[arg(long)]
    pub diffuse: String,
    /// ColorChecker patch shaping F0(λ) = 0.04 + 0.5·patch.
    #[arg(long)]
    pub fresnel: String,
    #[arg(long, default_value_t = 1.0)]
    pub kd: f64,
    #[command(flatten)]
    pub grid: GridArgs,
}

#[derive(Args)]
pub struct AbcArgs {
    /// MERL material name (e.g. pearl-paint, gray-plastic, chrome).
    #[arg(long)]
    pub material: String,
    /// Diffuse ColorChecker patch, scaled to the fit's diffuse luminance.
    #[arg(long)]
    pub diffuse: String,
    #[command(flatten)]
    pub grid: GridArgs,
}

/// Where a synthetic material is sampled and how it is written.
#[derive(Args)]
pub struct GridArgs {
    /// Incident direction θ,φ in degrees (repeatable).
    #[arg(long, required = true, value_name = "θ,φ", allow_hyphen_values = true)]
    pub incident: Vec<String>,
    /// Output CSV file (with --layout exr, a folder, created if its parent exists).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Wavelengths MIN:MAX:STEP in nm (within 380–780).
    #[arg(long, default_value = "400:700:10")]
    pub wavelengths: String,
    /// Outgoing θ spacing: θo = step/2, 3·step/2, … below 90.
    #[arg(long, default_value_t = 5.0)]
    pub theta_step: f64,
    /// Outgoing φ spacing: φo = 0, step, … below 360 (with --layout exr, pixel centres:
    /// step/2, 3·step/2, …).
    #[arg(long, default_value_t = 5.0)]
    pub phi_step: f64,
    /// Output layout: a wide or long CSV, or one spectral EXR slice per incident direction
    /// (float pixels; the steps must divide 90° and 360°).
    #[arg(long, value_enum, default_value = "wide")]
    pub layout: LayoutArg,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
pub enum LayoutArg {
    Wide,
    Long,
    Exr,
}

#[derive(Args)]
pub struct PhongArgs {
    /// Diffuse ColorChecker patch (case-insensitive; a unique prefix works: `white`).
    #[arg(long)]
    pub diffuse: String,
    /// Specular ColorChecker patch.
    #[arg(long)]
    pub specular: String,
    #[arg(long)]
    pub kd: f64,
    #[arg(long)]
    pub ks: f64,
    /// Phong exponent.
    #[arg(long)]
    pub n: f64,
    #[command(flatten)]
    pub grid: GridArgs,
}

/// Runs one `synth` subcommand.
pub fn run(c: SynthCommand) -> Result<()> {
    match c {
        SynthCommand::Phong(a) => cmd_phong(a),
        SynthCommand::Ggx(a) => cmd_ggx(a),
        SynthCommand::Abc(a) => cmd_abc(a),
    }
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
        incidences.push((t, wrap_phi(p)));
    }
    if g.layout == LayoutArg::Exr {
        return write_synth_exr(g, &wl, &incidences, f);
    }
    let dirs = paper_grid(g.theta_step, g.phi_step);
    let set = sample_material(&wl, &incidences, &dirs, f);
    write_atomic(&g.output, |w| match g.layout {
        LayoutArg::Wide => csv_io::write_wide(&set, w, Some(note)),
        LayoutArg::Long => {
            writeln!(w, "# {note}").map_err(|e| Error::Io {
                path: None,
                source: e,
            })?;
            csv_io::write_long(&set, w)
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
    ensure_output_folder(dir, "--layout exr")?;
    let stem = dir
        .file_name()
        .map_or("slice".into(), |s| s.to_string_lossy().into_owned());
    for &(ti, pi) in incidences {
        let mut values = Vec::with_capacity(h * w * wl.len());
        for row in 0..h {
            for col in 0..w {
                let [to, po] = exr::pixel_direction(row, col, h, w);
                values.extend((0..wl.len()).map(|k| f((ti, pi), (to, po), k)));
            }
        }
        let bytes = exr::write_slice(ti, pi, h, w, wl, &values, exr::PixelType::Float)?;
        write_bytes_atomic(&dir.join(exr::slice_file_name(&stem, ti, pi)), &bytes)?;
    }
    Ok(())
}

fn cmd_phong(a: PhongArgs) -> Result<()> {
    let wl = parse_range(&a.grid.wavelengths)?;
    check_nonnegative(&[("kd", a.kd), ("ks", a.ks), ("n", a.n)])?;
    let phong = Phong::colorchecker(&a.diffuse, &a.specular, (a.kd, a.ks, a.n), &wl)?;
    let note = format!(
        "sbrdf synth phong --diffuse {:?} --specular {:?} --kd {} --ks {} --n {}",
        a.diffuse, a.specular, a.kd, a.ks, a.n
    );
    write_synth(&a.grid, &note, |i, o, w| phong.value(i, o, w))
}

fn cmd_ggx(a: GgxArgs) -> Result<()> {
    let wl = parse_range(&a.grid.wavelengths)?;
    check_nonnegative(&[("kd", a.kd)])?;
    let check_alpha = |name: &str, v: f64| {
        if (1e-3..=1.0).contains(&v) {
            Ok(v)
        } else {
            Err(Error::Parameter(format!(
                "--{name} {v} is outside [0.001, 1]"
            )))
        }
    };
    let (ggx, roughness) = match (a.alpha, a.alpha_x, a.alpha_y) {
        (Some(alpha), _, _) => (
            Ggx::colorchecker(
                check_alpha("alpha", alpha)?,
                a.kd,
                &a.diffuse,
                &a.fresnel,
                &wl,
            )?,
            format!("--alpha {alpha}"),
        ),
        (None, Some(ax), Some(ay)) => {
            if !a.axis_angle.is_finite() {
                return Err(Error::Parameter(format!(
                    "--axis-angle {} is not a finite angle",
                    a.axis_angle
                )));
            }
            let ggx = Ggx::colorchecker(
                check_alpha("alpha-x", ax)?,
                a.kd,
                &a.diffuse,
                &a.fresnel,
                &wl,
            )?
            .with_anisotropy(check_alpha("alpha-y", ay)?, a.axis_angle);
            (
                ggx,
                format!(
                    "--alpha-x {ax} --alpha-y {ay} --axis-angle {}",
                    a.axis_angle
                ),
            )
        }
        // clap's group requires --alpha or --alpha-x, and --alpha-x requires --alpha-y.
        _ => {
            return Err(Error::Parameter(
                "give --alpha, or --alpha-x with --alpha-y".into(),
            ))
        }
    };
    let note = format!(
        "sbrdf synth ggx {roughness} --diffuse {:?} --fresnel {:?} --kd {}",
        a.diffuse, a.fresnel, a.kd
    );
    write_synth(&a.grid, &note, |i, o, w| ggx.value(i, o, w))
}

fn cmd_abc(a: AbcArgs) -> Result<()> {
    let wl = parse_range(&a.grid.wavelengths)?;
    let abc = Abc::from_table(&a.material, &a.diffuse, &wl)?;
    let note = format!(
        "sbrdf synth abc --material {:?} --diffuse {:?}",
        a.material, a.diffuse
    );
    write_synth(&a.grid, &note, |i, o, w| abc.value(i, o, w))
}
