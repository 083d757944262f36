//! `sbrdf validate`: the error a file will have between the measurements — at samples the
//! encoder did not see — per incidence and overall.

use super::encode::EncodeOptionArgs;
use clap::Args;
use sbrdf::encode::validate::{validate, ErrorSums, ValidateOptions};
use sbrdf::{Error, Result};
use std::path::PathBuf;

#[derive(Args)]
pub struct ValidateArgs {
    /// Inputs, as for `encode` (CSV, EXR slices, ASTM text, folders).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// k of the k-fold protocol: each incidence's outgoing samples in a fixed random order,
    /// every k-th held out in turn (0: no folds).
    #[arg(long, default_value_t = 5, value_name = "K")]
    pub folds: usize,
    /// Also encode without each incidence in turn and measure the error at it.
    #[arg(long)]
    pub leave_incidence_out: bool,
    /// Machine-readable output.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub options: EncodeOptionArgs,
}

fn cell(s: Option<&ErrorSums>) -> String {
    match s {
        Some(s) => format!("{:>9.4} {:>8.3}", s.rel(), s.log()),
        None => format!("{:>9} {:>8}", "—", "—"),
    }
}

fn json(s: Option<&ErrorSums>) -> serde_json::Value {
    match s {
        Some(s) => serde_json::json!({"rel": s.rel(), "log": s.log(), "values": s.count}),
        None => serde_json::Value::Null,
    }
}

pub fn cmd_validate(a: ValidateArgs) -> Result<()> {
    let settings = a.options.settings()?;
    let (set, report) = sbrdf::io::read_inputs(&a.inputs)?;
    let set = if settings.wavelengths.is_some() || settings.incident_max.is_some() {
        set.restricted(settings.wavelengths, settings.incident_max)
            .map_err(Error::Parameter)?
    } else {
        set
    };
    for n in &report.notes {
        eprintln!("sbrdf: note: {n}");
    }
    let inputs: Vec<String> = a.inputs.iter().map(|p| p.display().to_string()).collect();
    let opts = settings.options(&inputs);
    let v = ValidateOptions {
        folds: a.folds,
        leave_incidence_out: a.leave_incidence_out,
    };
    let r = validate(&set, &opts, &v)?;
    if a.json {
        let rows: Vec<serde_json::Value> = r
            .incidences
            .iter()
            .map(|i| {
                serde_json::json!({
                    "theta_i": i.theta_i, "phi_i": i.phi_i, "samples": i.samples,
                    "fit": json(Some(&i.fit)), "folds": json(i.folds.as_ref()),
                    "left_out": json(i.left_out.as_ref()),
                })
            })
            .collect();
        let v = serde_json::json!({
            "inputs": inputs, "folds": a.folds, "epsilon": r.epsilon,
            "bytes_without_positions": r.bytes, "raw_f32_bytes": set.raw_f32_bytes(),
            "fit": json(Some(&r.fit)), "folds_error": json(r.folds.as_ref()),
            "left_out": json(r.left_out.as_ref()), "incidences": rows,
        });
        println!("{}", serde_json::to_string_pretty(&v).expect("JSON"));
        return Ok(());
    }
    println!(
        "{}: {} incidences, {} wavelengths; {} bytes without sample positions (raw float32: {}); \
         log error ε = {:.4e} (1% of the median spectral mean)",
        inputs.join(", "),
        set.incidences.len(),
        set.wavelengths.len(),
        r.bytes,
        set.raw_f32_bytes(),
        r.epsilon
    );
    let k = if a.folds >= 2 {
        format!("{}-fold", a.folds)
    } else {
        "folds".into()
    };
    println!(
        "{:>9} {:>9} {:>8} | {:>9} {:>8} | {:>9} {:>8} | {:>9} {:>8}",
        "θi",
        "φi",
        "samples",
        "fit rel",
        "log",
        format!("{k} rel"),
        "log",
        "left out",
        "log"
    );
    for i in &r.incidences {
        println!(
            "{:>9.3} {:>9.3} {:>8} | {} | {} | {}",
            i.theta_i,
            i.phi_i,
            i.samples,
            cell(Some(&i.fit)),
            cell(i.folds.as_ref()),
            cell(i.left_out.as_ref())
        );
    }
    println!(
        "{:>19} {:>8} | {} | {} | {}",
        "overall",
        set.incidences
            .iter()
            .map(|s| s.directions.len())
            .sum::<usize>(),
        cell(Some(&r.fit)),
        cell(r.folds.as_ref()),
        cell(r.left_out.as_ref())
    );
    Ok(())
}
