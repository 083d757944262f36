//! `sbrdf plot`, `sbrdf preview` and `sbrdf paper-figures`: the command-line side of
//! [`sbrdf::report::plot`], [`sbrdf::report::preview`] and [`sbrdf::report::paper_figures`].

use clap::Args;
use sbrdf::io::output::write_bytes_atomic;
use sbrdf::report::draw::{render, ImageKind};
use sbrdf::report::paper_figures::{paper_figures, PaperFiguresOptions};
use sbrdf::report::plot::{coefficient_plot, PlotOptions};
use sbrdf::report::preview::{preview_png, render_preview, PreviewOptions};
use sbrdf::{Decoder, Error, Result};
use std::path::{Path, PathBuf};

#[derive(Args)]
#[command(
    after_help = "What the picture shows (the paper's Figs. 2, 5 and 7), for the stored record \
nearest --incident (the title says which; isotropic files are shown at φi = 0):\n  \
top: spectral coefficient K over the outgoing hemisphere (φo across, θo up, degrees; colour in \
1/sr) — the original samples' coefficient (with --reference), the reconstruction, its SH \
background and its peak part (the lobes). Maps with negative values use a blue–white–red scale \
centred on 0, the others viridis.\n  \
bottom: spectra at the numbered outgoing directions, reconstruction as a line and the original \
samples as dots with their relative error. By default: the peak direction, then its θ at 45°, 90° \
and 180° from it in φ (with a reference, moved to its nearest sample direction).\n\n\
Coefficient names: a0, a1, b1, a2, … for the paper's Fourier basis (K = 0, 1, 2, 3, …), c0, c1, … \
for the others.\n\n\
Examples:\n  \
sbrdf plot phong.sbrdf --incident 15,0 -o a0.png\n  \
sbrdf plot phong.sbrdf --reference phong.csv --incident 15,0 --coefficient 1 -o b1.svg\n  \
sbrdf plot ggx.sbrdf --reference slices --incident 30,0 -o ggx.png --outgoing 30,180 --outgoing 60,180"
)]
pub struct PlotArgs {
    /// The .sbrdf file.
    pub input: PathBuf,
    /// The original samples (a CSV file, spectral-EXR slices or a folder, as `encode` takes
    /// them), shown beside the reconstruction; repeat for several files.
    #[arg(long)]
    pub reference: Vec<PathBuf>,
    /// Incident direction θ,φ in degrees; the nearest stored record is drawn.
    #[arg(long, allow_hyphen_values = true)]
    pub incident: String,
    /// Output picture: .png (1600×980 pixels) or .svg.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Spectral coefficient to map (0 = the first: a0 for the Fourier basis).
    #[arg(long, default_value_t = 0)]
    pub coefficient: usize,
    /// Outgoing direction θ,φ (degrees) for a spectrum panel; repeat for more (at most 6).
    #[arg(long, allow_hyphen_values = true)]
    pub outgoing: Vec<String>,
}

#[derive(Args)]
#[command(
    after_help = "The sphere is seen head-on by an orthographic camera and lit by one point \
light with D65's spectrum (no ambient light, so the side facing away stays black). Each pixel is \
ρ(ωi, ωo, λ)·cos θi integrated against the CIE 1931 observer (2×2 samples per pixel), converted to \
linear sRGB, exposed automatically (the median lit point to mid-grey, highlights compressed so \
the brightest reaches white) and encoded with the sRGB transfer curve, on a dark background.\n\n\
Examples:\n  \
sbrdf preview phong.sbrdf -o sphere.png\n  \
sbrdf preview ggx.sbrdf -o ggx.png --size 512 --light 60,90     (light from above, 60° from the camera)"
)]
pub struct PreviewArgs {
    /// The .sbrdf file.
    pub input: PathBuf,
    /// Output picture (.png).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Width and height in pixels (16–4096).
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// Direction toward the light, θ,φ in degrees: θ from the viewing direction (0 = light at
    /// the camera, at most 90), φ counter-clockwise from the picture's right (90 = from above).
    #[arg(long, default_value = "45,135", allow_hyphen_values = true)]
    pub light: String,
}

#[derive(Args)]
#[command(after_help = "Writes into OUT_DIR:\n  \
fig4.csv, fig4.svg   error against ks/kd and n: direct SH L = 4 (the paper's Fig. 4), paper \
mode, default mode\n  \
fig6.csv, fig6.svg   paper mode's error against the critical angle, the default mode's error \
beside it\n  \
fig7.csv, fig7.svg   spectra at four outgoing directions: original, paper mode, default mode\n  \
table.md             the summary table (also printed)\n\n\
The material is the paper's: ColorChecker green diffuse and white specular (shipped spectra), \
Phong, kd = 1, incidence (15°, 0°), 400–700 nm every 10 nm, outgoing directions every 5°. Paper \
mode is `--basis fourier --peak paper --precision f32` (13 terms, SH level 1, automatic critical \
angle), the default mode is `encode`'s defaults. Takes about 15 s in a release build on two \
cores; --quick computes fewer materials and angles (for tests).\n\n\
Example:\n  sbrdf paper-figures figures/")]
pub struct PaperFiguresArgs {
    /// Folder for the data (CSV) and plots (SVG); created if its parent exists.
    pub output: PathBuf,
    /// Fewer materials (ks/kd = 15, n = 15 and 200) and critical angles (every 8°).
    #[arg(long)]
    pub quick: bool,
}

fn check_input(path: &Path) -> Result<()> {
    if !path.is_file() {
        return Err(Error::Parameter(format!(
            "{}: no such file (expected an .sbrdf file)",
            path.display()
        )));
    }
    Ok(())
}

pub fn cmd_plot(a: PlotArgs) -> Result<()> {
    let kind = ImageKind::of(&a.output)?;
    let incident = super::parse::parse_pair("incident", &a.incident)?;
    let outgoing = a
        .outgoing
        .iter()
        .map(|s| super::parse::parse_pair("outgoing", s))
        .collect::<Result<Vec<_>>>()?;
    if outgoing.len() > 6 {
        return Err(Error::Parameter(format!(
            "--outgoing given {} times: at most 6 spectra fit the picture",
            outgoing.len()
        )));
    }
    check_input(&a.input)?;
    let dec = Decoder::open_with(&a.input, sbrdf::Residency::Exact)?;
    let reference = if a.reference.is_empty() {
        None
    } else {
        Some(sbrdf::io::read_inputs(&a.reference)?.0)
    };
    let name = a
        .input
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let plot = coefficient_plot(
        &dec,
        &name,
        reference.as_ref(),
        &PlotOptions {
            incident,
            coefficient: a.coefficient,
            outgoing,
            kind,
        },
    )?;
    write_bytes_atomic(&a.output, &render(&plot, kind)?)?;
    let errors: Vec<String> = plot
        .spectra
        .iter()
        .filter_map(|s| s.error.map(|e| format!("{} {:.2}%", s.label, 100.0 * e)))
        .collect();
    eprintln!(
        "sbrdf: wrote {}: coefficient {} of record {} (θi = {}°, φi = {}°){}",
        a.output.display(),
        plot.name,
        plot.record + 1,
        dec.material().records[plot.record].theta_i,
        dec.material().records[plot.record].phi_i,
        if errors.is_empty() {
            String::new()
        } else {
            format!("; spectrum errors: {}", errors.join(", "))
        }
    );
    Ok(())
}

pub fn cmd_preview(a: PreviewArgs) -> Result<()> {
    if ImageKind::of(&a.output)? != ImageKind::Png {
        return Err(Error::Parameter(format!(
            "{}: the preview is a picture of pixels; name it .png",
            a.output.display()
        )));
    }
    let light = super::parse::parse_pair("light", &a.light)?;
    check_input(&a.input)?;
    let dec = Decoder::open_with(&a.input, sbrdf::Residency::Exact)?;
    let p = render_preview(
        &dec,
        &PreviewOptions {
            size: a.size,
            light,
        },
    )?;
    write_bytes_atomic(&a.output, &preview_png(&p)?)?;
    eprintln!(
        "sbrdf: wrote {}: {}×{} pixels, exposure {:.3}",
        a.output.display(),
        p.size,
        p.size,
        p.exposure
    );
    Ok(())
}

pub fn cmd_paper_figures(a: PaperFiguresArgs) -> Result<()> {
    let start = std::time::Instant::now();
    let out = paper_figures(&a.output, &PaperFiguresOptions { quick: a.quick })?;
    print!("{}", out.table);
    eprintln!(
        "sbrdf: wrote {} files into {} in {:.1} s",
        out.files.len(),
        a.output.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
