//! Real measurements, judged away from the samples (issue 14's acceptance): the Cornell
//! materials and NIST PTFE, encoded with the defaults and measured by `validate`'s protocols —
//! 5-fold over the outgoing samples, incidences left out — with the relative L2 and log errors
//! of `spec/EVALUATION.md`, "Held-out error", and against the nearest sample on the same folds
//! (never above it: issue 41). Slow for a test (about a minute per material in
//! an optimised build); the figures are in `docs/guide/measured.md`.

mod common;
use common::{held, SLACK};
use sbrdf::encode::validate::{validate, ValidateOptions, ValidationReport};
use sbrdf::encode::EncodeOptions;
use std::path::Path;

fn read(name: &str) -> sbrdf::encode::SampleSet {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    sbrdf::io::read_inputs(&[p]).unwrap().0
}

fn run(name: &str, leave_out: &[f64], dense: bool) -> ValidationReport {
    let set = read(name);
    let v = ValidateOptions {
        folds: 5,
        leave_incidence_out: true,
        leave_out_only: leave_out.to_vec(),
        dense_grid: dense,
    };
    validate(&set, &EncodeOptions::default(), &v).unwrap()
}

fn left_out(r: &ValidationReport, theta: f64) -> (f64, f64) {
    let i = r
        .incidences
        .iter()
        .find(|i| (i.theta_i - theta).abs() < 1e-3)
        .unwrap();
    let s = i.left_out.unwrap();
    (s.log(), s.rel())
}

/// A relative L2 figure held like any other ([`held`]), whose bound must also be below 1.0, the
/// score of a prediction of zero everywhere, or it would hold for no model at all.
fn held_rel(what: &str, got: f64, stated: f64) {
    assert!(
        SLACK * stated < 1.0,
        "{what}: a bound of {} cannot fail",
        SLACK * stated
    );
    held(what, got, stated);
}

/// The default file's figures as the guide states them: 5-fold (log, rel), per incidence left
/// out at 30°, 50° and 70° (log, rel), and bytes.
struct Stated {
    folds: (f64, f64),
    left_out: [(f64, f64); 3],
    bytes: f64,
}

/// `leave_out`: the incidences left out in turn (empty: every one). None may be predicted with
/// more light than it holds, rel ≤ 1.0 (what a prediction of zero scores; issue 41).
fn cornell(name: &str, leave_out: &[f64], stated: Stated) {
    let r = run(&format!("cornell/{name}.astm"), leave_out, false);
    let left: Vec<_> = r
        .incidences
        .iter()
        .filter(|i| i.left_out.is_some())
        .collect();
    let asked = if leave_out.is_empty() {
        r.incidences.len()
    } else {
        leave_out.len()
    };
    assert_eq!(left.len(), asked, "{name}: incidences left out");
    for i in left {
        let s = i.left_out.expect("left out");
        eprintln!(
            "{name}: {}° left out: log {:.3} rel {:.3}",
            i.theta_i,
            s.log(),
            s.rel()
        );
        assert!(
            s.rel() <= 1.0,
            "{name}: {}° left out predicts rel {:.3} > 1.0: light the measurement does not hold",
            i.theta_i,
            s.rel()
        );
    }
    let f = r.folds.unwrap();
    eprintln!(
        "{name}: 5-fold log {:.3} rel {:.3}; {} bytes",
        f.log(),
        f.rel(),
        r.bytes
    );
    let nn = r.nearest_folds.unwrap();
    eprintln!(
        "{name}: the nearest sample, same folds: log {:.3} rel {:.3}",
        nn.log(),
        nn.rel()
    );
    // Issue 41: never worse than handing out the nearest measurement, on the same folds.
    assert!(
        f.log() <= nn.log(),
        "{name}: 5-fold log {:.3} above the nearest sample's {:.3}",
        f.log(),
        nn.log()
    );
    held(&format!("{name} 5-fold log"), f.log(), stated.folds.0);
    held_rel(&format!("{name} 5-fold rel"), f.rel(), stated.folds.1);
    for (t, (log_stated, rel_stated)) in [30.0, 50.0, 70.0].into_iter().zip(stated.left_out) {
        let (log, rel) = left_out(&r, t);
        held(&format!("{name} {t}° left out log"), log, log_stated);
        held_rel(&format!("{name} {t}° left out rel"), rel, rel_stated);
    }
    held(&format!("{name} bytes"), r.bytes as f64, stated.bytes);
}

#[test]
fn cornell_acrylic_generalises() {
    // Every incidence: acryl_blue's 40° comes nearest to 1.0 (0.893).
    cornell(
        "acryl_blue",
        &[],
        Stated {
            folds: (0.393, 0.761),
            left_out: [(0.270, 0.391), (0.277, 0.241), (0.704, 0.164)],
            bytes: 1.8e3,
        },
    );
}

#[test]
fn cornell_paint_generalises() {
    // The stated incidences, its largest (70°: 0.683) among them; every incidence is a minute
    // more of encodes, which CI's time cannot hold (`sbrdf validate --leave-incidence-out`
    // prints them all: docs/guide/measured.md).
    cornell(
        "krylon_blue",
        &[30.0, 50.0, 70.0],
        Stated {
            folds: (0.291, 0.298),
            left_out: [(0.085, 0.057), (0.120, 0.178), (0.679, 0.683)],
            bytes: 1.8e3,
        },
    );
}

#[test]
fn nist_ptfe_generalises_and_stays_positive() {
    let r = run("nist_ptfe_fr11.csv", &[45.0], true);
    let f = r.folds.unwrap();
    let (_, rel45) = left_out(&r, 45.0);
    eprintln!(
        "PTFE: 5-fold rel {:.4}, 45° left out {rel45:.4}, {} bytes",
        f.rel(),
        r.bytes
    );
    let (log45, _) = left_out(&r, 45.0);
    let nn = r.nearest_folds.unwrap();
    assert!(
        f.log() <= nn.log(),
        "PTFE: 5-fold log {:.4} above the nearest sample's {:.4}",
        f.log(),
        nn.log()
    );
    held("PTFE 5-fold log", f.log(), 0.012);
    held_rel("PTFE 5-fold rel", f.rel(), 0.0127);
    held("PTFE 45° left out log", log45, 0.014);
    held_rel("PTFE 45° left out rel", rel45, 0.0148);
    held("PTFE bytes", r.bytes as f64, 1.28e3);
    let d = r.dense.unwrap();
    assert!(d.values > 100_000);
    assert_eq!(
        d.negative, 0,
        "values below 0 before the clamp, lowest {}",
        d.minimum
    );
    // Issue 41: the material plainly reflects wherever θi and θo are below 85°; no 0 there.
    assert_eq!(d.zero_below_85, 0, "values at 0 where θi, θo < 85°");
}

/// Beyond the measured incidences (issue 41, item 3) the factor model holds each angle at the
/// nearest end of its stored range, so the last measured shape follows the mirror direction at
/// that end's level: the light it sends out stays physically bounded. The directional albedo
/// ∫ρ cos θo dωo (midpoint rule, θo every 0.2°, φo every 1°) of the golden Cornell factor
/// file stays at most 1 at every incidence to grazing, and at the measured end (80°) and
/// beyond it never grows past what the measured incidences send out.
#[test]
fn factor_model_albedo_is_bounded_beyond_the_measurement() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/golden/krylon_shared_v11.sbrdf");
    let dec = sbrdf::Decoder::open(&p).unwrap();
    let wl: Vec<f32> = dec.material().wavelengths.clone();
    let (nt, np) = (450, 360);
    let (dt, dp) = (
        std::f64::consts::FRAC_PI_2 / nt as f64,
        std::f64::consts::TAU / np as f64,
    );
    let mut out = vec![0.0f32; wl.len()];
    let albedo = |ti: f64, out: &mut Vec<f32>| -> f64 {
        let a = ti.to_radians();
        let wi = [a.sin() as f32, 0.0, a.cos() as f32];
        let mut sum = vec![0.0f64; wl.len()];
        for i in 0..nt {
            let t = (i as f64 + 0.5) * dt;
            let w = t.cos() * t.sin() * dt * dp;
            for j in 0..np {
                let p = (j as f64 + 0.5) * dp;
                let wo = [
                    (t.sin() * p.cos()) as f32,
                    (t.sin() * p.sin()) as f32,
                    t.cos() as f32,
                ];
                dec.eval(wi, wo, &wl, out);
                for (s, v) in sum.iter_mut().zip(out.iter()) {
                    *s += w * *v as f64;
                }
            }
        }
        sum.into_iter().fold(0.0, f64::max)
    };
    let measured: Vec<f64> = [10.0, 30.0, 50.0, 70.0, 80.0]
        .iter()
        .map(|&t| albedo(t, &mut out))
        .collect();
    let most = measured.iter().cloned().fold(0.0, f64::max);
    eprintln!("krylon albedo (max over λ) at 10/30/50/70/80°: {measured:.4?}");
    for ti in [85.0, 88.0, 89.9] {
        let a = albedo(ti, &mut out);
        eprintln!("krylon albedo at {ti}°: {a:.4}");
        assert!(a <= 1.0, "albedo {a} > 1 at θi = {ti}°");
        assert!(
            a <= most,
            "albedo {a} at θi = {ti}° beyond the measured incidences, above their largest {most}"
        );
    }
}
