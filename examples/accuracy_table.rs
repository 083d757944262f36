//! Prints the accuracy table of `docs/guide/encoder.md`: for each test set, relative error and bytes per incident
//! direction for the paper's method and for the defaults.
//!
//!     cargo run --release --example accuracy_table
//!
//! Bytes are whole files without sample positions (`--no-sample-positions`), divided by the
//! number of incident directions; errors are the worst and the mean over the set's incidences.

#[path = "../tests/common/mod.rs"]
mod common;

use common::*;
use sbrdf::encode::encoder::{encode, EncodeOptions};
use sbrdf::encode::samples::SampleSet;

struct Row {
    name: String,
    sets: Vec<SampleSet>,
}

fn measure(sets: &[SampleSet], opts: &EncodeOptions) -> (f64, f64, f64) {
    let (mut worst, mut sum, mut count, mut bytes) = (0.0f64, 0.0, 0usize, 0usize);
    for set in sets {
        let mut o = opts.clone();
        if o.terms.is_some() {
            // The paper's 13 terms, or as many as the periodic series supports on few
            // wavelengths (it takes λmin and λmax as one point: W − 1).
            o.terms = Some(13.min(set.wavelengths.len().saturating_sub(1)).max(1));
        }
        let e = encode(set, &o).expect("encode");
        bytes += sbrdf::write_material(&e.material).unwrap().len();
        for r in &e.material.records {
            worst = worst.max(r.rel_error as f64);
            sum += r.rel_error as f64;
            count += 1;
        }
    }
    (worst, sum / count as f64, bytes as f64 / count as f64)
}

fn main() {
    let incs: Vec<(f64, f64)> = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0]
        .iter()
        .map(|&t| (t, 0.0))
        .collect();
    let upto60 = &incs[..5];
    let wl = paper_wavelengths();
    let mut rows = Vec::new();
    let mut phong = Vec::new();
    for ks in [0.5, 5.0, 15.0, 30.0] {
        for n in [1.0, 15.0, 50.0, 200.0, 1000.0] {
            phong.push(paper_samples(ks, n, &[(15.0, 0.0)]));
        }
    }
    rows.push(Row {
        name: "Phong grid (20 materials, 15°)".into(),
        sets: phong,
    });
    for alpha in [0.1, 0.3] {
        let g = ggx(alpha);
        rows.push(Row {
            name: format!("GGX α = {alpha}, 0–60°"),
            sets: vec![sample_on_paper_grid(upto60, |i, o, w| g.value(i, o, w))],
        });
        rows.push(Row {
            name: format!("GGX α = {alpha}, 75° and 85°"),
            sets: vec![sample_on_paper_grid(&incs[5..], |i, o, w| g.value(i, o, w))],
        });
    }
    let abc: Vec<_> = ABC_MATERIALS
        .iter()
        .map(|(n, p)| sbrdf::io::synth::Abc::from_table(n, p, &wl).unwrap())
        .collect();
    rows.push(Row {
        name: "10 MERL ABC fits, 0–60°".into(),
        sets: abc
            .iter()
            .map(|m| sample_on_paper_grid(upto60, |i, o, w| m.value(i, o, w)))
            .collect(),
    });
    rows.push(Row {
        name: "10 MERL ABC fits, 75° and 85°".into(),
        sets: abc
            .iter()
            .map(|m| sample_on_paper_grid(&incs[5..], |i, o, w| m.value(i, o, w)))
            .collect(),
    });
    rows.push(Row {
        name: "outside the lobe families (Beckmann ×2, two-layer GGX), 0–85°".into(),
        sets: vec![
            sample_on_paper_grid(&incs, beckmann(0.2)),
            sample_on_paper_grid(&incs, beckmann(0.05)),
            sample_on_paper_grid(&incs, two_layer()),
        ],
    });
    let nist =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/nist_ptfe_fr11.csv");
    rows.push(Row {
        name: "NIST PTFE (6 incidences, 351–1064 nm)".into(),
        sets: vec![sbrdf::io::csv::read_samples(&[nist]).unwrap().0],
    });

    let paper = EncodeOptions {
        sample_positions: false,
        ..EncodeOptions::paper()
    };
    let default = EncodeOptions {
        sample_positions: false,
        ..EncodeOptions::default()
    };
    println!("| test set | paper mode: worst / mean error | bytes per incidence | default: worst / mean error | bytes per incidence |");
    println!("| --- | ---: | ---: | ---: | ---: |");
    for row in rows {
        let (pw, pm, pb) = measure(&row.sets, &paper);
        let (dw, dm, db) = measure(&row.sets, &default);
        println!(
            "| {} | {:.2}% / {:.2}% | {:.0} | {:.2}% / {:.2}% | {:.0} |",
            row.name,
            100.0 * pw,
            100.0 * pm,
            pb,
            100.0 * dw,
            100.0 * dm,
            db
        );
    }
}
