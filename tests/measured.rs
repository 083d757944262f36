//! Real measurements, judged away from the samples (issue 14's acceptance): the Cornell
//! materials and NIST PTFE, encoded with the defaults and measured by `validate`'s protocols —
//! 5-fold over the outgoing samples, incidences left out — with the relative L2 and log errors
//! of `spec/EVALUATION.md`, "Held-out error", and against the nearest sample on the same folds
//! (never above it: issue 41). The guide's commands (`docs/guide/measured.md`, the first also in
//! the README) run here as written, with `--json`, and their figures are held to what the guide
//! states; `tests/doc_commands.rs` leaves them to this file rather than encode them twice. Slow
//! for a test (about a minute per material in an optimised build on two cores).

mod common;
use common::{held, MEASURED_COMMANDS, SLACK};
use sbrdf::encode::validate::{validate, ValidateOptions};
use sbrdf::encode::EncodeOptions;
use serde_json::Value;
use std::path::Path;

/// The figures of one validation that these tests hold: (log, rel) pairs.
struct Figures {
    folds: (f64, f64),
    nearest_folds: (f64, f64),
    /// Per incidence: θi and, where it was left out, its (log, rel).
    left_out: Vec<(f64, Option<(f64, f64)>)>,
    bytes: f64,
    /// The dense grid's values, values below 0 and values at 0 below 85° (when asked for).
    dense: Option<(f64, f64, f64)>,
}

/// Runs one of [`MEASURED_COMMANDS`] as the guide writes it (checked against the page), with
/// `--json`, in the repository's root, and reads its figures.
fn documented(command: &str) -> Figures {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let page = std::fs::read_to_string(root.join("docs/guide/measured.md")).unwrap();
    assert!(
        page.lines().any(|l| l.trim() == command),
        "docs/guide/measured.md no longer shows `{command}`"
    );
    let args: Vec<&str> = command.split_whitespace().skip(1).collect();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_sbrdf"))
        .args(&args)
        .arg("--json")
        .current_dir(root)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "`{command} --json` failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let pair = |v: &Value| -> Option<(f64, f64)> {
        Some((v.get("log")?.as_f64()?, v.get("rel")?.as_f64()?))
    };
    let number = |v: &Value, k: &str| v[k].as_f64().unwrap_or_else(|| panic!("no {k}"));
    Figures {
        folds: pair(&v["folds_error"]).expect("5-fold figures"),
        nearest_folds: pair(&v["nearest_folds"]).expect("the nearest sample's figures"),
        left_out: v["incidences"]
            .as_array()
            .expect("incidences")
            .iter()
            .map(|i| (number(i, "theta_i"), pair(&i["left_out"])))
            .collect(),
        bytes: number(&v, "bytes_without_positions"),
        dense: (!v["dense_grid"].is_null()).then(|| {
            let d = &v["dense_grid"];
            (
                number(d, "values"),
                number(d, "negative"),
                number(d, "zero_below_85"),
            )
        }),
    }
}

/// The same figures through the library, for a validation the guide does not show.
fn library(name: &str, leave_out: &[f64]) -> Figures {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    let set = sbrdf::io::read_inputs(&[p]).unwrap().0;
    let v = ValidateOptions {
        folds: 5,
        leave_incidence_out: true,
        leave_out_only: leave_out.to_vec(),
        dense_grid: false,
    };
    let r = validate(&set, &EncodeOptions::default(), &v).unwrap();
    let pair = |s: sbrdf::encode::metrics::ErrorSums| (s.log(), s.rel());
    Figures {
        folds: pair(r.folds.unwrap()),
        nearest_folds: pair(r.nearest_folds.unwrap()),
        left_out: r
            .incidences
            .iter()
            .map(|i| (i.theta_i, i.left_out.map(pair)))
            .collect(),
        bytes: r.bytes as f64,
        dense: None,
    }
}

fn left_out(r: &Figures, theta: f64) -> (f64, f64) {
    r.left_out
        .iter()
        .find(|i| (i.0 - theta).abs() < 1e-3)
        .and_then(|i| i.1)
        .unwrap_or_else(|| panic!("{theta}° was not left out"))
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

/// `asked`: how many incidences were left out in turn. None may be predicted with more light
/// than it holds, rel ≤ 1.0 (what a prediction of zero scores; issue 41).
fn cornell(name: &str, r: &Figures, asked: usize, stated: Stated) {
    let left: Vec<(f64, (f64, f64))> = r
        .left_out
        .iter()
        .filter_map(|&(t, s)| Some((t, s?)))
        .collect();
    assert_eq!(left.len(), asked, "{name}: incidences left out");
    for (t, (log, rel)) in left {
        eprintln!("{name}: {t}° left out: log {log:.3} rel {rel:.3}");
        assert!(
            rel <= 1.0,
            "{name}: {t}° left out predicts rel {rel:.3} > 1.0: light the measurement does not hold"
        );
    }
    let (f, nn) = (r.folds, r.nearest_folds);
    eprintln!(
        "{name}: 5-fold log {:.3} rel {:.3}; {} bytes",
        f.0, f.1, r.bytes
    );
    eprintln!(
        "{name}: the nearest sample, same folds: log {:.3} rel {:.3}",
        nn.0, nn.1
    );
    // Issue 41: never worse than handing out the nearest measurement, on the same folds.
    assert!(
        f.0 <= nn.0,
        "{name}: 5-fold log {:.3} above the nearest sample's {:.3}",
        f.0,
        nn.0
    );
    held(&format!("{name} 5-fold log"), f.0, stated.folds.0);
    held_rel(&format!("{name} 5-fold rel"), f.1, stated.folds.1);
    for (t, (log_stated, rel_stated)) in [30.0, 50.0, 70.0].into_iter().zip(stated.left_out) {
        let (log, rel) = left_out(r, t);
        held(&format!("{name} {t}° left out log"), log, log_stated);
        held_rel(&format!("{name} {t}° left out rel"), rel, rel_stated);
    }
    held(&format!("{name} bytes"), r.bytes, stated.bytes);
}

#[test]
fn cornell_acrylic_generalises() {
    // Every incidence left out (the guide's command): acryl_blue's 40° comes nearest to 1.0
    // (0.893).
    let r = documented(MEASURED_COMMANDS[0]);
    cornell(
        "acryl_blue",
        &r,
        8,
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
    let r = library("cornell/krylon_blue.astm", &[30.0, 50.0, 70.0]);
    cornell(
        "krylon_blue",
        &r,
        3,
        Stated {
            folds: (0.291, 0.298),
            left_out: [(0.085, 0.057), (0.120, 0.178), (0.679, 0.683)],
            bytes: 1.8e3,
        },
    );
}

#[test]
fn nist_ptfe_generalises_and_stays_positive() {
    let r = documented(MEASURED_COMMANDS[1]);
    let (log45, rel45) = left_out(&r, 45.0);
    eprintln!(
        "PTFE: 5-fold rel {:.4}, 45° left out {rel45:.4}, {} bytes",
        r.folds.1, r.bytes
    );
    assert!(
        r.folds.0 <= r.nearest_folds.0,
        "PTFE: 5-fold log {:.4} above the nearest sample's {:.4}",
        r.folds.0,
        r.nearest_folds.0
    );
    held("PTFE 5-fold log", r.folds.0, 0.012);
    held_rel("PTFE 5-fold rel", r.folds.1, 0.0127);
    held("PTFE 45° left out log", log45, 0.014);
    held_rel("PTFE 45° left out rel", rel45, 0.0148);
    held("PTFE bytes", r.bytes, 1.28e3);
    let (values, negative, zero_below_85) = r.dense.expect("the dense grid");
    assert!(values > 100_000.0);
    assert_eq!(negative, 0.0, "values below 0 before the clamp");
    // Issue 41: the material plainly reflects wherever θi and θo are below 85°; no 0 there.
    assert_eq!(zero_below_85, 0.0, "values at 0 where θi, θo < 85°");
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
