//! `sbrdf validate`: the error a file will have between the measurements — at samples the
//! encoder did not see — per incidence and overall.

use super::encode::EncodeOptionArgs;
use clap::Args;
use sbrdf::encode::metrics::ErrorSums;
use sbrdf::encode::validate::{validate, ValidateOptions};
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
    /// Leave out only the incidence(s) at θi = DEG (repeatable; implies
    /// --leave-incidence-out).
    #[arg(long, value_name = "DEG")]
    pub leave_out: Vec<f64>,
    /// Also evaluate the model on a dense grid (θi every 5°, θo every 2.5°, φo every 5°) and
    /// count the values below 0 before the decoder's clamp.
    #[arg(long)]
    pub dense_grid: bool,
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
    let (set, report) = sbrdf::io::read_inputs_with(&a.inputs, &settings.read)?;
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
        leave_incidence_out: a.leave_incidence_out || !a.leave_out.is_empty(),
        leave_out_only: a.leave_out.clone(),
        dense_grid: a.dense_grid,
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
                    "nearest_folds": json(i.nearest_folds.as_ref()),
                    "nearest_left_out": json(i.nearest_left_out.as_ref()),
                })
            })
            .collect();
        let v = serde_json::json!({
            "inputs": inputs, "folds": a.folds, "epsilon": r.epsilon,
            "bytes_without_positions": r.bytes, "raw_f32_bytes": set.raw_f32_bytes(),
            "fit": json(Some(&r.fit)), "folds_error": json(r.folds.as_ref()),
            "left_out": json(r.left_out.as_ref()), "incidences": rows,
            "nearest_folds": json(r.nearest_folds.as_ref()),
            "nearest_left_out": json(r.nearest_left_out.as_ref()),
            "dense_grid": r.dense.map(|d| serde_json::json!({
                "values": d.values, "negative": d.negative, "minimum": d.minimum,
                "not_finite": d.not_finite, "zero_below_85": d.zero_below_85,
            })),
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
        "{:>9} {:>9} {:>8} | {:>9} {:>8} | {:>9} {:>8} | {:>9} {:>8} | {:>9} {:>8} | {:>9} {:>8}",
        "θi",
        "φi",
        "samples",
        "fit rel",
        "log",
        format!("{k} rel"),
        "log",
        "left out",
        "log",
        format!("nn {k}"),
        "log",
        "nn out",
        "log"
    );
    for i in &r.incidences {
        println!(
            "{:>9.3} {:>9.3} {:>8} | {} | {} | {} | {} | {}",
            i.theta_i,
            i.phi_i,
            i.samples,
            cell(Some(&i.fit)),
            cell(i.folds.as_ref()),
            cell(i.left_out.as_ref()),
            cell(i.nearest_folds.as_ref()),
            cell(i.nearest_left_out.as_ref())
        );
    }
    println!(
        "{:>19} {:>8} | {} | {} | {} | {} | {}",
        "overall",
        set.incidences
            .iter()
            .map(|s| s.directions.len())
            .sum::<usize>(),
        cell(Some(&r.fit)),
        cell(r.folds.as_ref()),
        cell(r.left_out.as_ref()),
        cell(r.nearest_folds.as_ref()),
        cell(r.nearest_left_out.as_ref())
    );
    println!(
        "nn: the nearest sample's error on the same held-out values (each predicted by the \
         nearest sample the encode was given, no model): a model above it does worse than the \
         measurement itself"
    );
    if let Some(d) = r.dense {
        println!(
            "dense grid: {} values, {} below 0 before the clamp ({:.3}%), lowest {:.4e}; {} at or \
             below 0 where θi and θo are below 85°{}",
            d.values,
            d.negative,
            100.0 * d.negative as f64 / d.values.max(1) as f64,
            d.minimum,
            d.zero_below_85,
            if d.not_finite > 0 {
                format!(", {} not finite", d.not_finite)
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
