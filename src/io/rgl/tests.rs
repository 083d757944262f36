//! Unit tests on small synthetic tensor files (the real RGL files are in `tests/rgl.rs`).

use super::bsdf::*;
use super::tensor::*;

fn f32b(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A small isotropic RGB material: 2 incidences (0°, 45°), R = 5, VNDF 6 × 6.
pub fn tiny_file() -> Vec<u8> {
    let (r, vw) = (5usize, 6usize);
    let theta = [0.0f32, std::f32::consts::FRAC_PI_4];
    // Periodic in φ (row vw-1 equals row 0), as a real VNDF is.
    let vndf: Vec<f32> = (0..2 * vw * vw)
        .map(|i| {
            let (slice, y, x) = (i / (vw * vw), (i / vw) % vw, i % vw);
            let y = if y == vw - 1 { 0 } else { y };
            let j = (slice * vw + y) * vw + x;
            1.0 + 0.5 * ((j * 7 % 11) as f32) / 11.0
        })
        .collect();
    let rgb: Vec<f32> = (0..2 * 3 * r * r)
        .map(|i| 0.1 + 0.01 * (i % 13) as f32)
        .collect();
    write_tensor(&[
        ("description", 1, vec![4], b"tiny".to_vec()),
        ("phi_i", 10, vec![1], f32b(&[0.0])),
        ("theta_i", 10, vec![2], f32b(&theta)),
        ("sigma", 10, vec![2, 4], f32b(&[1.0; 8])),
        (
            "ndf",
            10,
            vec![2, 4],
            f32b(&[0.5, 0.6, 0.7, 0.8, 0.5, 0.6, 0.7, 0.8]),
        ),
        ("vndf", 10, vec![1, 2, vw as u64, vw as u64], f32b(&vndf)),
        (
            "luminance",
            10,
            vec![1, 2, r as u64, r as u64],
            f32b(&vec![1.0; 2 * r * r]),
        ),
        ("rgb", 10, vec![1, 2, 3, r as u64, r as u64], f32b(&rgb)),
        ("jacobian", 1, vec![1], vec![1]),
        ("valid", 1, vec![7], vec![0xff; 7]),
    ])
}

#[test]
fn tiny_file_reads() {
    let b = RglBsdf::from_bytes(&tiny_file()).unwrap();
    assert_eq!(b.res, 5);
    assert!(b.isotropic && b.is_rgb() && b.jacobian);
    let inc = b.incidence(1, 0).unwrap();
    assert_eq!(inc.cells.len(), 25);
    // Column 0 is the half vector at the normal: the mirror direction (45°, 180°).
    for c in inc.cells.iter().filter(|c| c.col == 0) {
        assert!(
            (c.theta_o - 45.0).abs() < 1e-5 && (c.phi_o - 180.0).abs() < 1e-5,
            "{c:?}"
        );
    }
}

#[test]
fn spectral_file_reads() {
    // The tiny file with `spectra` at 4 wavelengths instead of `rgb`.
    let base = tiny_file();
    let tf = TensorFile::parse(&base).unwrap();
    let mut fields: Vec<(&str, u8, Vec<u64>, Vec<u8>)> = tf
        .fields
        .iter()
        .filter(|f| f.name != "rgb")
        .map(|f| {
            let code = if f.dtype == DType::U8 { 1 } else { 10 };
            (f.name.as_str(), code, f.shape.clone(), tf.data(f).to_vec())
        })
        .collect();
    let r = 5usize;
    let spectra: Vec<f32> = (0..2 * 4 * r * r).map(|i| (i % 17) as f32 * 0.01).collect();
    fields.push((
        "wavelengths",
        10,
        vec![4],
        f32b(&[450.0, 500.0, 550.0, 600.0]),
    ));
    fields.push((
        "spectra",
        10,
        vec![1, 2, 4, r as u64, r as u64],
        f32b(&spectra),
    ));
    let b = RglBsdf::from_bytes(&write_tensor(&fields)).unwrap();
    assert_eq!(b.channel_count(), 4);
    assert_eq!(b.values_field(), "spectra");
    let inc = b.incidence(1, 0).unwrap();
    assert_eq!(inc.values.len(), 4 * r * r);
    // Node (row 2, col 3), wavelength 2: value × NDF/(4σ) / cos θo.
    let k = 2 * r + 3;
    let c = inc.cells[k];
    let at = |lambda: usize| spectra[((4 + lambda) * r + 2) * r + 3] as f64; // [0, 1, λ, 2, 3]
    let raw = at(2);
    let ratio = inc.values[4 * k + 2] * c.wo[2] / raw;
    let ratio0 = inc.values[4 * k] * c.wo[2] / at(0);
    assert!(
        (ratio - ratio0).abs() < 1e-12 && ratio > 0.0,
        "{ratio} {ratio0}"
    );
    // `wavelengths` without `spectra` is refused by name.
    fields.pop();
    let e = RglBsdf::from_bytes(&write_tensor(&fields)).unwrap_err();
    assert_eq!(
        e,
        RglError::MissingField {
            field: "spectra".into()
        }
    );
}

#[test]
fn warp_inverts() {
    let b = RglBsdf::from_bytes(&tiny_file()).unwrap();
    let w = b.warp(1, 0).unwrap();
    for i in 0..=20 {
        for j in 0..=20 {
            let (sx, sy) = (i as f64 / 20.0, j as f64 / 20.0);
            let (ux, uy) = w.sample(sx, sy);
            let (bx, by) = w.invert(ux, uy);
            assert!(
                (bx - sx).abs() < 1e-9 && (by - sy).abs() < 1e-9,
                "{sx} {sy} -> {bx} {by}"
            );
        }
    }
}

#[test]
fn eval_matches_cells() {
    let b = RglBsdf::from_bytes(&tiny_file()).unwrap();
    let inc = b.incidence(1, 0).unwrap();
    let e = b.evaluator(1, 0).unwrap();
    let mut out = [0.0; 3];
    for (k, c) in inc.cells.iter().enumerate() {
        if !c.above || c.col == 0 || c.theta_o > 89.0 {
            continue;
        }
        assert!(e.eval(c.theta_o, c.phi_o, &mut out));
        // Rows 0 and R-1 are both φm − φi = ±180°: one direction, either row's value.
        let twin = if c.row == 0 {
            k + 4 * 5
        } else if c.row == 4 {
            k - 4 * 5
        } else {
            k
        };
        for ch in 0..3 {
            let close = |v: f64| (out[ch] - v).abs() <= 1e-8 * v.abs().max(1.0);
            let (v, w) = (inc.values[3 * k + ch], inc.values[3 * twin + ch]);
            assert!(close(v) || close(w), "{c:?} {out:?} {v} {w}");
        }
    }
}

#[test]
fn grazing_incidence_refused() {
    let mut f = tiny_file();
    // theta_i[1] = π/2 (float32), still increasing.
    let tf = TensorFile::parse(&f).unwrap();
    let off = tf.field("theta_i").unwrap().offset as usize + 4;
    f[off..off + 4].copy_from_slice(&std::f32::consts::FRAC_PI_2.to_le_bytes());
    let b = RglBsdf::from_bytes(&f).unwrap();
    assert!(!b.incidence_usable(1));
    assert!(matches!(
        b.incidence(1, 0),
        Err(RglError::BadIncidence { .. })
    ));
    assert_eq!(b.incidences().unwrap().len(), 1);
}

#[test]
fn header_errors_name_place() {
    let f = tiny_file();
    assert!(TensorFile::parse(&f[..5])
        .unwrap_err()
        .to_string()
        .contains("byte 0"));
    let mut g = f.clone();
    g[0] = b'x';
    assert_eq!(TensorFile::parse(&g).unwrap_err(), RglError::BadMagic);
    let mut g = f.clone();
    g[14..18].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        TensorFile::parse(&g),
        Err(RglError::TooManyFields { .. })
    ));
    // An offset beyond the end.
    let tf = TensorFile::parse(&f).unwrap();
    let rgb = tf.field("rgb").unwrap();
    let at = rgb.header_at as usize + 2 + 3 + 2 + 1;
    let mut g = f.clone();
    g[at..at + 8].copy_from_slice(&(f.len() as u64).to_le_bytes());
    let e = TensorFile::parse(&g).unwrap_err();
    assert!(
        matches!(e, RglError::DataOutOfBounds { ref field, .. } if field == "rgb"),
        "{e}"
    );
    // A shape whose size overflows.
    let mut g = f.clone();
    let at = rgb.header_at as usize + 2 + 3 + 2 + 1 + 8;
    g[at..at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(
        TensorFile::parse(&g),
        Err(RglError::SizeOverflow { .. })
    ));
}

#[test]
fn shape_checks() {
    let base = tiny_file();
    let tf = TensorFile::parse(&base).unwrap();
    let fields: Vec<(String, u8, Vec<u64>, Vec<u8>)> = tf
        .fields
        .iter()
        .map(|f| {
            let code = match f.dtype {
                DType::U8 => 1,
                _ => 10,
            };
            (f.name.clone(), code, f.shape.clone(), tf.data(f).to_vec())
        })
        .collect();
    type Fields = Vec<(String, u8, Vec<u64>, Vec<u8>)>;
    let rebuild = |edit: &dyn Fn(&mut Fields)| {
        let mut v = fields.clone();
        edit(&mut v);
        let borrowed: Vec<(&str, u8, Vec<u64>, Vec<u8>)> = v
            .iter()
            .map(|(n, c, s, d)| (n.as_str(), *c, s.clone(), d.clone()))
            .collect();
        RglBsdf::from_bytes(&write_tensor(&borrowed))
    };
    assert!(rebuild(&|_| {}).is_ok());
    let idx = |n: &str| fields.iter().position(|f| f.0 == n).unwrap();
    // rgb with 2 channels.
    let e = rebuild(&|v| {
        let i = idx("rgb");
        v[i].2[2] = 2;
        let n = v[i].3.len() * 2 / 3;
        v[i].3.truncate(n);
    })
    .unwrap_err();
    assert!(
        matches!(e, RglError::WrongShape { ref field, .. } if field == "rgb"),
        "{e}"
    );
    // vndf over the wrong number of incidences.
    let e = rebuild(&|v| {
        let i = idx("vndf");
        v[i].2[1] = 1;
        let n = v[i].3.len() / 2;
        v[i].3.truncate(n);
    })
    .unwrap_err();
    assert!(
        matches!(e, RglError::WrongShape { ref field, .. } if field == "vndf"),
        "{e}"
    );
    // theta_i as float64.
    let e = rebuild(&|v| v[idx("theta_i")].1 = 11).unwrap_err();
    assert!(
        matches!(e, RglError::WrongShape { .. } | RglError::WrongDType { .. }),
        "{e}"
    );
    // Missing jacobian.
    let e = rebuild(&|v| v.retain(|f| f.0 != "jacobian")).unwrap_err();
    assert_eq!(
        e,
        RglError::MissingField {
            field: "jacobian".into()
        }
    );
    // Non-square luminance.
    let e = rebuild(&|v| {
        let i = idx("luminance");
        v[i].2[3] = 4;
    })
    .unwrap_err();
    assert!(
        matches!(e, RglError::WrongShape { ref field, .. } if field == "luminance"),
        "{e}"
    );
    // A NaN in the VNDF, a negative density, a zero slice.
    let e =
        rebuild(&|v| v[idx("vndf")].3[8..12].copy_from_slice(&f32::NAN.to_le_bytes())).unwrap_err();
    assert!(
        matches!(e, RglError::BadData { ref field, .. } if field == "vndf"),
        "{e}"
    );
    let e =
        rebuild(&|v| v[idx("vndf")].3[8..12].copy_from_slice(&(-1f32).to_le_bytes())).unwrap_err();
    assert!(e.to_string().contains("negative"), "{e}");
    let b = rebuild(&|v| {
        let d = &mut v[idx("vndf")].3;
        let n = d.len() / 2;
        d[n..].iter_mut().for_each(|x| *x = 0);
    })
    .unwrap();
    assert!(b
        .incidence(1, 0)
        .unwrap_err()
        .to_string()
        .contains("integrates to zero"));
    // Duplicate field.
    let e = rebuild(&|v| {
        let d = v[idx("phi_i")].clone();
        v.push(d)
    })
    .unwrap_err();
    assert!(matches!(e, RglError::DuplicateField { .. }), "{e}");
}

#[test]
fn truncation_and_flips_never_panic() {
    let f = tiny_file();
    for n in 0..f.len() {
        let _ = RglBsdf::from_bytes(&f[..n]).map(|b| b.incidences());
    }
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..3000 {
        let mut g = f.clone();
        for _ in 0..1 + (state % 3) {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let bit = (state % (g.len() as u64 * 8)) as usize;
            g[bit / 8] ^= 1 << (bit % 8);
        }
        if let Ok(b) = RglBsdf::from_bytes(&g) {
            let _ = b.samples(90.0, 90.0);
        }
    }
}

#[test]
fn tiny_seed_file_is_the_tiny_file() {
    // `tests/data/rgl/tiny_rgb.bsdf` seeds the `rgl` fuzz target: it must stay this file, so
    // that what the fuzzer starts from is a valid RGL file (SBRDF_WRITE_SEED=1 rewrites it).
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/rgl/tiny_rgb.bsdf");
    if std::env::var_os("SBRDF_WRITE_SEED").is_some() {
        std::fs::write(&path, tiny_file()).unwrap();
    }
    assert_eq!(std::fs::read(&path).unwrap(), tiny_file());
}
