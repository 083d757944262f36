//! `sbrdf validate`: the held-out protocol itself, on a material whose answer is known.

mod common;
use common::{sbrdf, stderr};
use sbrdf::encode::validate::{validate, ValidateOptions};
use sbrdf::encode::EncodeOptions;
use sbrdf::io::synth::{paper_grid, sample_material, Phong};

fn phong_set(thetas: &[f64]) -> sbrdf::encode::SampleSet {
    let wl: Vec<f64> = (0..16).map(|i| 400.0 + 20.0 * i as f64).collect();
    let p = Phong::colorchecker("green", "white", (1.0, 2.0, 8.0), &wl).unwrap();
    let inc: Vec<(f64, f64)> = thetas.iter().map(|&t| (t, 0.0)).collect();
    sample_material(&wl, &inc, &paper_grid(10.0, 15.0), |i, o, w| {
        p.value(i, o, w)
    })
}

#[test]
fn held_out_errors_follow_the_protocol() {
    // A broad Phong lobe the encoder's families hold exactly: held-out samples are predicted
    // almost as well as fitted ones, and an incidence between two stored ones is interpolated.
    let set = phong_set(&[20.0, 30.0, 40.0]);
    let v = ValidateOptions {
        folds: 4,
        leave_incidence_out: true,
        dense_grid: true,
        ..ValidateOptions::default()
    };
    let r = validate(&set, &EncodeOptions::default(), &v).unwrap();
    assert_eq!(r.incidences.len(), 3);
    let n: usize = set.incidences.iter().map(|s| s.values.len()).sum();
    assert_eq!(r.fit.count, n, "fit: every value once");
    assert_eq!(
        r.folds.unwrap().count,
        n,
        "folds: every value held out exactly once"
    );
    assert_eq!(r.left_out.unwrap().count, n);
    assert!(r.fit.rel() < 0.006, "fit {}", r.fit.rel());
    let folds = r.folds.unwrap();
    assert!(
        folds.rel() < 0.02 && folds.rel() >= r.fit.rel() * 0.5,
        "folds {}",
        folds.rel()
    );
    // 30° left out lies between 20° and 40°: interpolated; 20° and 40° are extrapolated.
    let mid = r.incidences[1].left_out.unwrap();
    assert!(mid.rel() < 0.1, "30° left out: {}", mid.rel());
    // The nearest-sample baseline on the same values: every value once; on a paper grid 10° ×
    // 15° a broad lobe moves between neighbours, so a model the families hold beats it.
    let (nf, nl) = (r.nearest_folds.unwrap(), r.nearest_left_out.unwrap());
    assert_eq!((nf.count, nl.count), (n, n));
    assert!(
        folds.rel() < nf.rel(),
        "{} vs nearest {}",
        folds.rel(),
        nf.rel()
    );
    assert!(mid.rel() < r.incidences[1].nearest_left_out.unwrap().rel());
    assert!(r.epsilon > 0.0 && r.bytes > 0);
    let d = r.dense.unwrap();
    assert_eq!(d.values, 19 * 36 * 72 * 16);
    assert_eq!(d.not_finite, 0);
}

#[test]
fn validate_runs_through_the_program() {
    let dir = tempfile::tempdir().unwrap();
    let set = phong_set(&[10.0, 50.0]);
    let f = std::fs::File::create(dir.path().join("m.csv")).unwrap();
    sbrdf::io::csv::write_wide(&set, f, None).unwrap();
    let o = sbrdf(
        &[
            "validate",
            "m.csv",
            "--folds",
            "3",
            "--leave-incidence-out",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["incidences"].as_array().unwrap().len(), 2);
    // The program prints the library's figures for the same samples and options (the JSON
    // carries them to about 17 digits). Fit and folds are those of a good fit, far below the
    // 1.0 a zero prediction scores; leaving out one of two incidences 40° apart extrapolates
    // a Phong peak 40° away, so that figure is only held to the library's.
    let lib = validate(
        &set,
        &EncodeOptions::default(),
        &ValidateOptions {
            folds: 3,
            leave_incidence_out: true,
            ..ValidateOptions::default()
        },
    )
    .unwrap();
    let sums = [
        ("fit", Some(lib.fit), 0.01),
        ("folds_error", lib.folds, 0.05),
        ("left_out", lib.left_out, f64::INFINITY),
        ("nearest_folds", lib.nearest_folds, f64::INFINITY),
        ("nearest_left_out", lib.nearest_left_out, f64::INFINITY),
    ];
    for (key, sums, most) in sums {
        let want = sums.unwrap().rel();
        let rel = v[key]["rel"].as_f64().unwrap();
        assert!(
            (rel - want).abs() <= 1e-12 * want.max(1e-300),
            "{key}: the program says {rel}, the library {want}"
        );
        assert!(rel > 0.0 && rel < most, "{key}: {rel} (at most {most})");
    }
    let o = sbrdf(&["validate", "m.csv", "--folds", "1"], dir.path());
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--folds 1"), "{}", stderr(&o));
}
