//! The batch entry point, the one-wavelength view and the decoder's resident form, on every
//! golden file: `eval_batch` writes exactly (bit for bit) what `eval` writes pair by pair, and
//! `Decoder::at(λ)` what `eval` writes at `[λ]`, whatever width the batch kernel runs at
//! (one lane, AVX2, AVX-512: each that this CPU has), with one incident or outgoing direction
//! broadcast over the batch, runs of repeated incident directions, hostile vectors and
//! wavelengths, and over a million random pairs; the material a decoder rebuilds from its
//! resident form is the one the reader returned, and writing it back gives the file's bytes.

use sbrdf::{read_material, write_material, Decoder, Limits};
use std::path::PathBuf;

fn files() -> Vec<(PathBuf, Vec<u8>)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir.join("golden"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "sbrdf"))
        .collect();
    paths.push(dir.join("ggx_slices.sbrdf"));
    paths.sort();
    let v: Vec<_> = paths
        .into_iter()
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    assert!(v.len() >= 9, "only {} files", v.len());
    v
}

/// Deterministic pseudo-random numbers in [-1, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    }
    fn dir(&mut self) -> [f32; 3] {
        [self.next(), self.next(), self.next().abs() + 0.01]
    }
}

fn pairs() -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let (mut wi, mut wo) = (Vec::new(), Vec::new());
    for i in 0..400 {
        // Runs of one incident direction, changing every 1 to 7 pairs.
        let a = if i % 7 < 3 && i > 0 {
            wi[i - 1]
        } else {
            rng.dir()
        };
        wi.push(a);
        wo.push(rng.dir());
    }
    // Hostile and edge vectors on either side.
    let odd = [
        [0.0, 0.0, 0.0],
        [f32::NAN, 0.0, 1.0],
        [0.0, f32::INFINITY, 1.0],
        [0.3, 0.2, -0.5],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1e-30],
        [3.0, -4.0, 12.0],
    ];
    for (k, v) in odd.iter().enumerate() {
        wi.push(*v);
        wo.push(rng.dir());
        wi.push(rng.dir());
        wo.push(odd[(k + 3) % odd.len()]);
    }
    (wi, wo)
}

fn per_pair(dec: &Decoder, wi: &[[f32; 3]], wo: &[[f32; 3]], wl: &[f32]) -> Vec<f32> {
    let n = wi.len().max(wo.len());
    let mut out = vec![f32::NAN; n * wl.len()];
    for i in 0..n {
        let a = wi[if wi.len() == 1 { 0 } else { i }];
        let b = wo[if wo.len() == 1 { 0 } else { i }];
        dec.eval(a, b, wl, &mut out[i * wl.len()..(i + 1) * wl.len()]);
    }
    out
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The decoder as opened, and with its batch kernel at each width this CPU has (files without
/// the kernel: as opened only).
fn widths(bytes: &[u8]) -> Vec<(String, Decoder)> {
    let dec = Decoder::from_bytes(bytes).unwrap();
    let mut v = vec![("as opened".to_string(), dec.clone())];
    for lanes in [1, 4, 8] {
        if let Some(d) = dec.clone().with_kernel_lanes(lanes) {
            v.push((format!("{lanes} lanes"), d));
        }
    }
    v
}

/// `Decoder::at(λ)` gives `eval`'s bits at `[λ]` for every pair.
fn at_is_eval(dec: &Decoder, a: &[[f32; 3]], b: &[[f32; 3]], l: f32, want: &[f32], what: &str) {
    let at = dec.at(l);
    let n = a.len().max(b.len());
    for i in 0..n {
        let (x, y) = (
            a[if a.len() == 1 { 0 } else { i }],
            b[if b.len() == 1 { 0 } else { i }],
        );
        assert_eq!(
            at.eval(x, y).to_bits(),
            want[i].to_bits(),
            "{what}: pair {i} at {l} nm through at(λ)"
        );
    }
}

#[test]
fn a_batch_is_eval_pair_by_pair() {
    let (wi, wo) = pairs();
    for (path, bytes) in files() {
        let dec = Decoder::from_bytes(&bytes).unwrap();
        let w = dec.material().wavelengths.clone();
        let (lo, hi) = (w[0], w[w.len() - 1]);
        let lists: Vec<Vec<f32>> = vec![
            vec![550.0],
            vec![lo, 0.5 * (lo + hi), hi],
            w.clone(),
            vec![
                lo - 50.0,
                f32::NAN,
                hi + 1.0,
                f32::INFINITY,
                0.37 * lo + 0.63 * hi,
            ],
            vec![],
        ];
        for wl in &lists {
            for (a, b) in [
                (&wi[..], &wo[..]),
                (&wi[..1], &wo[..]),
                (&wi[..], &wo[3..4]),
                (&wi[..0], &wo[..0]),
            ] {
                let n = a.len().max(b.len());
                let want = per_pair(&dec, a, b, wl);
                for (width, d) in widths(&bytes) {
                    let mut out = vec![f32::NAN; n * wl.len() + 3];
                    d.eval_batch(a, b, wl, &mut out).unwrap();
                    assert_eq!(
                        bits(&out[..n * wl.len()]),
                        bits(&want),
                        "{} with {} wavelengths, batch {width}",
                        path.display(),
                        wl.len()
                    );
                    // Nothing written past the rows.
                    assert!(out[n * wl.len()..].iter().all(|v| v.is_nan()));
                }
                if let [l] = wl[..] {
                    at_is_eval(&dec, a, b, l, &want, &path.display().to_string());
                }
            }
        }
    }
}

/// A million random pairs (pseudo-random, fixed seed) spread over the golden files, at 1, 4
/// and 31 wavelengths: `eval`, `eval_batch` at every kernel width and `at(λ)` give the same
/// bits.
#[test]
fn a_million_random_pairs_give_the_same_bits_by_every_route() {
    let files = files();
    let per_file = 1_000_000 / files.len() + 1;
    let mut rng = Rng(0x0dd_ba11_5eed_cafe);
    let mut checked = 0usize;
    for (path, bytes) in &files {
        let what = path.display().to_string();
        let dec = Decoder::from_bytes(bytes).unwrap();
        let (wi, wo): (Vec<[f32; 3]>, Vec<[f32; 3]>) =
            (0..per_file).map(|_| (rng.dir(), rng.dir())).unzip();
        let w = dec.material().wavelengths.clone();
        let (lo, hi) = (w[0], w[w.len() - 1]);
        let spread = |m: usize| -> Vec<f32> {
            (0..m)
                .map(|j| lo - 10.0 + (hi - lo + 20.0) * (j as f32 + 0.37) / m as f32)
                .collect()
        };
        for m in [1, 4, 31] {
            let wl = spread(m);
            let want = per_pair(&dec, &wi, &wo, &wl);
            let routes = if m == 1 {
                widths(bytes)
            } else {
                vec![("as opened".to_string(), dec.clone())]
            };
            for (width, d) in routes {
                let mut out = vec![0.0f32; per_file * m];
                d.eval_batch(&wi, &wo, &wl, &mut out).unwrap();
                if let Some(i) = (0..out.len()).find(|&i| out[i].to_bits() != want[i].to_bits()) {
                    panic!(
                        "{what}: {m} wavelengths, batch {width}: value {i} is {} against eval's {}",
                        out[i], want[i]
                    );
                }
            }
            if m == 1 {
                at_is_eval(&dec, &wi, &wo, wl[0], &want, &what);
            }
            assert!(want.iter().any(|&v| v > 0.0), "{what}: all zero");
            checked += per_file;
        }
    }
    assert!(checked >= 3_000_000, "{checked} pair evaluations");
}

#[test]
fn a_batch_refuses_shapes_that_do_not_match() {
    let (_, bytes) = &files()[0];
    let dec = Decoder::from_bytes(bytes).unwrap();
    let d = [[0.0f32, 0.0, 1.0]; 3];
    let mut out = [7.0f32; 6];
    assert!(dec
        .eval_batch(&d[..2], &d[..3], &[500.0], &mut out)
        .is_err());
    assert!(dec
        .eval_batch(&d[..3], &d[..3], &[500.0, 600.0], &mut out[..5])
        .is_err());
    assert_eq!(out, [7.0; 6], "nothing written on refusal");
}

#[test]
fn the_resident_form_gives_back_the_material_and_the_bytes() {
    for (path, bytes) in files() {
        let read = read_material(&bytes, &Limits::default()).unwrap();
        let dec = Decoder::from_bytes(&bytes).unwrap();
        let before = dec.resident_bytes();
        assert_eq!(dec.material(), &read, "{}", path.display());
        assert!(
            dec.resident_bytes() > before,
            "the view is counted once built"
        );
        assert_eq!(
            write_material(dec.material()).unwrap(),
            bytes,
            "{}: written back",
            path.display()
        );
        assert_eq!(dec.clone().into_material(), read);
        assert_eq!(Decoder::from_bytes(&bytes).unwrap().into_material(), read);
    }
}

/// `eval` takes shortcuts — one wavelength on a θ line through the kernel (`src/decode/kernel/`),
/// elsewhere with terms before records (`src/decode/records/general.rs`), many wavelengths of a
/// tabulated basis from node sums (`SpectrumEvaluator::eval_clamped`), θ from a polynomial —
/// that must give the general path's values to rounding: each is checked against `eval_deg`
/// (double precision angles, the general path) at the same directions, within a few f32
/// roundings (2·10⁻⁷ relative, plus 10⁻⁹ of the material's largest value).
/// On every golden file, and on the benchmark's Phong and GGX materials (θ lines, one lobe).
#[test]
fn evals_shortcuts_give_the_general_paths_values() {
    use sbrdf::encode::encoder::{encode, EncodeOptions};
    use sbrdf::io::synth::{paper_grid, sample_material, Ggx, Phong};
    use sbrdf::model::angles::{deg_from_dir, polar_deg};
    let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
    let grid = paper_grid(10.0, 10.0);
    let phong = Phong::colorchecker("green", "white", (1.0, 15.0, 50.0), &wl).unwrap();
    let ggx = Ggx::colorchecker(0.2, 1.0, "blue", "yellow", &wl).unwrap();
    let incs: Vec<(f64, f64)> = (0..5).map(|i| (18.0 * i as f64, 0.0)).collect();
    let mut decoders: Vec<(String, Decoder)> = files()
        .into_iter()
        .map(|(p, b)| (p.display().to_string(), Decoder::from_bytes(&b).unwrap()))
        .collect();
    for (name, set) in [
        (
            "phong",
            sample_material(&wl, &incs, &grid, |i, o, w| phong.value(i, o, w)),
        ),
        (
            "ggx",
            sample_material(&wl, &incs, &grid, |i, o, w| ggx.value(i, o, w)),
        ),
    ] {
        let enc = encode(&set, &EncodeOptions::default()).unwrap();
        let bytes = write_material(&enc.material).unwrap();
        decoders.push((name.to_string(), Decoder::from_bytes(&bytes).unwrap()));
    }
    // Directions above the horizon, as (f32 vector, its angles in degrees).
    let (wi, wo) = pairs();
    // θ as the decoder computes it (`polar_deg`, within 1.4·10⁻⁸ rad of atan2: a steep
    // material's value moves by up to ~10⁻⁴ relative with it, which "Rounding" allows), so that
    // what differs is the paths alone.
    // (The outgoing direction's θ is the vector's own: the decoder takes the vector.)
    let angles = |v: [f32; 3], incident: bool| {
        let d = v.map(|x| x as f64);
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        (n.is_finite() && n > 0.0 && d[2] >= 0.0).then(|| {
            let s = 1.0 / n;
            let u = [d[0] * s, d[1] * s, d[2] * s];
            let (theta, phi) = deg_from_dir(u);
            match incident {
                true => (polar_deg((u[0] * u[0] + u[1] * u[1]).sqrt(), u[2]), phi),
                false => (theta, phi),
            }
        })
    };
    let good: Vec<_> = wi
        .iter()
        .zip(&wo)
        .filter_map(|(&a, &b)| Some((a, b, angles(a, true)?, angles(b, false)?)))
        .collect();
    assert!(good.len() > 350);
    for (name, dec) in &decoders {
        let w = dec.material().wavelengths.clone();
        let (lo, hi) = (w[0], w[w.len() - 1]);
        let general = |ia, oa, l: f32| {
            let mut v = [f64::NAN];
            dec.eval_deg(ia, oa, &[l as f64], &mut v);
            v[0]
        };
        let mut scale = 0.0f64;
        for &(_, _, ia, oa) in &good {
            scale = scale.max(general(ia, oa, 0.5 * (lo + hi)));
        }
        let mut checked = 0;
        let mut close = |got: f32, want: f64, what: &str| {
            let tol = 2e-7 * want.abs() + 1e-9 * scale;
            assert!(
                (got as f64 - want).abs() <= tol,
                "{name}: {what}: {got} against the general path's {want}"
            );
            checked += 1;
        };
        let warped = dec.material().warped.is_some();
        for &(a, b, ia, oa) in &good {
            // Warped tables grow as 1/cos θ toward the horizon (the measurement's own
            // divergence, "Warped tables"): there the angle form's vector and the f32 vector
            // differ by a rounding that the value magnifies without bound, so such pairs
            // compare nothing about the paths.
            if warped && (a[2].abs() < 1e-3 || b[2].abs() < 1e-3) {
                continue;
            }
            for l in [lo, 0.37 * lo + 0.63 * hi, hi, lo - 20.0] {
                let mut one = [f32::NAN];
                dec.eval(a, b, &[l], &mut one);
                close(one[0], general(ia, oa, l), &format!("{l} nm alone"));
            }
            for list in [&w[..], &[lo, 0.5 * (lo + hi), hi][..]] {
                let mut all = vec![f32::NAN; list.len()];
                dec.eval(a, b, list, &mut all);
                for (&got, &l) in all.iter().zip(list) {
                    close(
                        got,
                        general(ia, oa, l),
                        &format!("{l} nm of {}", list.len()),
                    );
                }
            }
        }
        assert!(checked > 1000, "{name}: {checked} values");
    }
}
