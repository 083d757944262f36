//! `sbrdf tradeoff`: the input encoded over a sweep of settings, each measured.

use clap::Args;
use sbrdf::io::output::{write_atomic, write_bytes_atomic};
use sbrdf::report::draw::ImageKind;
use sbrdf::report::tradeoff;
use sbrdf::{Error, Result};
use std::path::PathBuf;

#[derive(Args)]
pub struct TradeoffArgs {
    /// Inputs, as for `encode` (CSV, EXR slices, folders).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// The report: one row per setting.
    #[arg(long, value_name = "REPORT.csv")]
    pub csv: PathBuf,
    /// The plot: error against bytes with the Pareto front, and decode time.
    #[arg(long, value_name = "REPORT.svg")]
    pub plot: Option<PathBuf>,
    /// 12 settings instead of 24.
    #[arg(long)]
    pub quick: bool,
}

pub fn cmd_tradeoff(a: TradeoffArgs) -> Result<()> {
    if let Some(p) = &a.plot {
        if ImageKind::of(p)? != ImageKind::Svg {
            return Err(Error::Parameter(format!(
                "--plot {}: the trade-off plot is written as SVG (name it .svg)",
                p.display()
            )));
        }
    }
    let (set, _) = sbrdf::io::read_inputs(&a.inputs)?;
    let inputs: Vec<String> = a.inputs.iter().map(|p| p.display().to_string()).collect();
    let settings = tradeoff::sweep(a.quick, set.wavelengths.len());
    // A progress bar on stderr; indicatif draws nothing when stderr is not a terminal.
    let bar = indicatif::ProgressBar::new(settings.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} settings  {msg}")
            .expect("a valid template"),
    );
    let mut rows = Vec::with_capacity(settings.len());
    for s in &settings {
        bar.set_message(s.cli_options().join(" "));
        rows.push(tradeoff::measure(&set, &inputs, s)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    tradeoff::mark_pareto(&mut rows);
    write_atomic(&a.csv, |w| tradeoff::write_csv(&rows, w))?;
    if let Some(p) = &a.plot {
        let title = format!("sbrdf tradeoff: {}", inputs.join(", "));
        let svg = tradeoff::plot_svg(&rows, &title)?;
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
