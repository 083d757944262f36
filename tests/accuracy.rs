//! The accuracy of the default encoder on the test sets of the accuracy issue: the paper's Phong
//! grid, microfacet materials (GGX and MERL ABC fits with ColorChecker spectra, plus materials
//! outside every lobe family), and the NIST PTFE measurement. Figures are printed for the
//! record (`cargo test --test accuracy -- --nocapture`).

mod common;
use common::*;
use sbrdf::encode::encoder::EncodeOptions;
use sbrdf::write_material;

const INCIDENCES: [f64; 7] = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0];

/// Encodes with the defaults and returns the per-incidence errors and the file size.
fn run(
    set: &sbrdf::encode::samples::SampleSet,
    f: impl FnOnce(&mut EncodeOptions),
) -> (Vec<f64>, usize) {
    let e = encode_default(set, |o| {
        o.inputs = vec!["material.csv".into()];
        f(o)
    });
    let bytes = write_material(&e.material).unwrap().len();
    let errs = e
        .material
        .records
        .iter()
        .map(|r| r.rel_error as f64)
        .collect();
    (errs, bytes)
}

#[test]
fn phong_grid_within_half_a_percent_at_one_two_hundredth_of_the_size() {
    let mut worst = 0.0f64;
    let mut largest = 0usize;
    for ks in [0.5, 5.0, 15.0, 30.0] {
        for n in [1.0, 15.0, 50.0, 200.0, 1000.0] {
            let set = paper_samples(ks, n, &[(15.0, 0.0)]);
            let (errs, bytes) = run(&set, |_| {});
            eprintln!(
                "phong ks/kd={ks} n={n}: error {:.5}, {bytes} bytes",
                errs[0]
            );
            assert!(errs[0] <= 0.005, "ks={ks} n={n}: {}", errs[0]);
            assert!(
                bytes * 200 <= set.raw_f32_bytes(),
                "ks={ks} n={n}: {bytes} bytes > 1/200 of {}",
                set.raw_f32_bytes()
            );
            worst = worst.max(errs[0]);
            largest = largest.max(bytes);
        }
    }
    eprintln!("phong grid: worst {worst:.5}, largest file {largest} bytes");
    held("Phong grid", worst, 0.0045);
    // The README's size figure: 624 bytes per incidence (format 1.0 files, the largest of the
    // grid); the default format 1.1 files are smaller still.
    assert!(
        largest as f64 <= SLACK * 624.0,
        "largest file {largest} bytes, stated 624"
    );
}

/// Prints a material's per-incidence errors and returns its worst at 0–60° and at 75°/85°.
fn worst_of(name: &str, errs: &[f64], bytes: usize) -> (f64, f64) {
    let cells: Vec<String> = errs.iter().map(|e| format!("{:.2}%", 100.0 * e)).collect();
    eprintln!("{name}: {} ({bytes} bytes)", cells.join(" "));
    let mut w = (0.0f64, 0.0f64);
    for (t, &e) in INCIDENCES.iter().zip(errs) {
        assert!(e.is_finite(), "{name} at {t}°: {e}");
        if *t <= 60.0 {
            w.0 = w.0.max(e);
        } else {
            w.1 = w.1.max(e);
        }
    }
    w
}

#[test]
fn microfacet_materials_up_to_grazing() {
    let incs: Vec<(f64, f64)> = INCIDENCES.iter().map(|&t| (t, 0.0)).collect();
    // The README's "GGX and MERL fits 0.2–0.4 kB per incidence": the largest file over its 7
    // incidences.
    let mut per_incidence = 0.0f64;
    // The table's rows: worst at 0–60°, worst at 75° and 85°.
    for (alpha, stated) in [(0.1, (0.0092, 0.0032)), (0.3, (0.0045, 0.0003))] {
        let g = ggx(alpha);
        let set = sample_on_paper_grid(&incs, |i, o, w| g.value(i, o, w));
        let (errs, bytes) = run(&set, |_| {});
        per_incidence = per_incidence.max(bytes as f64 / incs.len() as f64);
        let (low, high) = worst_of(&format!("GGX α={alpha}"), &errs, bytes);
        held(&format!("GGX α = {alpha}, 0–60°"), low, stated.0);
        held(&format!("GGX α = {alpha}, 75° and 85°"), high, stated.1);
    }
    let wl = paper_wavelengths();
    let mut merl = (0.0f64, 0.0f64);
    for (name, patch) in ABC_MATERIALS {
        let m = sbrdf::io::synth::Abc::from_table(name, patch, &wl).unwrap();
        let set = sample_on_paper_grid(&incs, |i, o, w| m.value(i, o, w));
        let (errs, bytes) = run(&set, |_| {});
        per_incidence = per_incidence.max(bytes as f64 / incs.len() as f64);
        let w = worst_of(name, &errs, bytes);
        merl = (merl.0.max(w.0), merl.1.max(w.1));
    }
    held(
        "GGX and MERL fits, bytes per incidence",
        per_incidence,
        400.0,
    );
    assert_eq!(ABC_MATERIALS.len(), 10, "the table's row is over 10 fits");
    held("10 MERL ABC fits, 0–60°", merl.0, 0.0050);
    held("10 MERL ABC fits, 75° and 85°", merl.1, 0.0045);
}

#[test]
fn materials_outside_the_lobe_families() {
    let incs: Vec<(f64, f64)> = INCIDENCES.iter().map(|&t| (t, 0.0)).collect();
    let sets = [
        ("Beckmann α=0.2", sample_on_paper_grid(&incs, beckmann(0.2))),
        (
            "Beckmann α=0.05",
            sample_on_paper_grid(&incs, beckmann(0.05)),
        ),
        ("two-layer GGX", sample_on_paper_grid(&incs, two_layer())),
    ];
    let mut worst = 0.0f64;
    for (name, set) in sets {
        let (errs, bytes) = run(&set, |_| {});
        let w = worst_of(name, &errs, bytes);
        worst = worst.max(w.0).max(w.1);
    }
    held("outside the lobe families, 0–85°", worst, 0.0324);
}

#[test]
fn nist_ptfe_measurement() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/nist_ptfe_fr11.csv");
    let (set, report) = sbrdf::io::csv::read_samples(&[path]).unwrap();
    assert_eq!(report.negative_values, 0);
    assert_eq!(set.wavelengths, vec![351.0, 532.0, 633.0, 1064.0]);
    assert_eq!(set.incidences.len(), 6);
    // The defaults (0.5%, best effort: below the 0.8% noise floor), and a 1.5% budget, which
    // asks for no more than the measurement holds.
    for budget in [None, Some(0.015)] {
        let (errs, bytes) = run(&set, |o| {
            if budget.is_some() {
                o.max_error = budget
            }
        });
        let worst = errs.iter().cloned().fold(0.0, f64::max);
        eprintln!(
            "NIST PTFE, budget {budget:?}: per incidence {:?}, {bytes} bytes (raw f32 {} bytes)",
            errs.iter().map(|e| format!("{:.4}", e)).collect::<Vec<_>>(),
            set.raw_f32_bytes()
        );
        assert!(worst <= 0.015, "worst {worst}");
        if budget.is_none() {
            // The guide's figure for the default file (encoder.md: 1.06% worst).
            held("NIST PTFE, defaults", worst, 0.0106);
        }
    }
}

#[test]
fn a_looser_budget_gives_a_smaller_file_and_an_impossible_one_is_reported() {
    let g = ggx(0.3);
    let set = sample_on_paper_grid(&[(15.0, 0.0), (45.0, 0.0), (60.0, 0.0)], |i, o, w| {
        g.value(i, o, w)
    });
    // The model's own bytes (records and basis), not the metadata, whose text varies.
    let model_bytes = |m: &sbrdf::Material| {
        let mut bare = m.clone();
        bare.metadata = None;
        bare.sample_positions = None;
        write_material(&bare).unwrap().len()
    };
    let sizes: Vec<usize> = [0.0005, 0.005, 0.02, 0.1]
        .iter()
        .map(|&e| {
            let enc = encode_default(&set, |o| {
                o.max_error = Some(e);
                o.budget_given = true;
            });
            let errs: Vec<f32> = enc.material.records.iter().map(|r| r.rel_error).collect();
            assert!(
                errs.iter().all(|x| (*x as f64) <= e),
                "budget {e}: {errs:?}"
            );
            let bytes = model_bytes(&enc.material);
            eprintln!("budget {e}: model {bytes} bytes, errors {errs:?}");
            bytes
        })
        .collect();
    for w in sizes.windows(2) {
        assert!(w[1] <= w[0], "sizes grow with a looser budget: {sizes:?}");
    }
    assert!(
        sizes[3] < sizes[0],
        "the loosest budget is not smaller: {sizes:?}"
    );
    let e = encode_default(&set, |o| {
        o.max_error = Some(1e-9);
        o.budget_given = true;
    });
    assert_eq!(e.unmet.len(), 3, "a 1e-9 budget cannot be met");
}
