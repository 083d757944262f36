//! Warped tables (format 1.4) on the real RGL measurements the project ships: the default
//! encode's size and error, every error budget honoured or refused, the decoder against the
//! measurement's own evaluation (Mitsuba's `measured`, as the RGL reader emulates it) between
//! its nodes and at a stored incidence left out of the file, the spectral source, and hostile
//! damage to the chunk behind a valid CRC.

mod common;
use common::{held, rgl_error_at_nodes, samples_dir, sbrdf, stderr, unit, SLACK};
use sbrdf::encode::samples::{ReadOptions, RgbToSpectrum};
use sbrdf::encode::warped::{encode_warped, WarpedInput, WarpedOptions, DEFAULT_MAX_ERROR};
use sbrdf::io::rgl::{read_warped, RglBsdf};
use sbrdf::io::synth::SpectrumTable;
use sbrdf::model::warped::{PayloadCoding, TableTransform, WarpedModel};
use sbrdf::{write_material, Decoder};
use std::path::{Path, PathBuf};

const MATERIALS: [&str; 3] = ["cc_ibiza_sunset", "paper_white", "satin_rosaline"];

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/rgl")
        .join(format!("{name}_rgb.bsdf"))
}

fn rgb_options() -> ReadOptions {
    ReadOptions {
        rgb_to_spectrum: Some(RgbToSpectrum::JakobHanika2019),
    }
}

fn input(name: &str) -> WarpedInput {
    let bytes = std::fs::read(data(name)).unwrap();
    read_warped(name, &bytes, &rgb_options())
        .unwrap()
        .unwrap()
        .input
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Relative L2 of the decoder's ρ·cos θ (light) against the measurement's at stored
/// incidence `t` (the viewing direction: the file's θi), over `count` random light directions
/// up to 85° (not the nodes), in linear sRGB.
fn error_against_measurement(dec: &Decoder, b: &RglBsdf, t: usize, count: usize) -> f64 {
    let ev = b.evaluator(t, 0).unwrap();
    let viewer_theta = (b.theta_i[t] as f64).to_degrees();
    let viewer = unit(viewer_theta, 0.0);
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ t as u64);
    let (mut num, mut den) = (0.0, 0.0);
    let mut want = [0.0; 3];
    for _ in 0..count {
        let theta = (rng.next() * 0.996).acos().to_degrees().min(85.0);
        let phi = 360.0 * rng.next();
        if !ev.eval(theta, phi, &mut want) {
            continue;
        }
        let got = dec.eval_linear_srgb(unit(theta, phi), viewer, Default::default());
        let c = theta.to_radians().cos();
        for (g, w) in got.iter().zip(&want) {
            let (g, w) = (g * c, w.max(0.0) * c);
            num += (g - w) * (g - w);
            den += w * w;
        }
    }
    (num / den).sqrt()
}

#[test]
fn default_encode_meets_its_budget_and_size_on_every_rgl_material() {
    // The table of `docs/guide/warped-tables.md`: default budget 1% at the worst stored incidence, file ≤ 6.5 kB
    // (1/100 of the 644 kB RGB .bsdf) with the program's metadata, and each file within 1.25×
    // of the size the table states for it.
    let stated = [3.9e3, 1.7e3, 2.5e3];
    let dir = tempfile::tempdir().unwrap();
    for (name, stated) in MATERIALS.into_iter().zip(stated) {
        let out = format!("{name}.sbrdf");
        let o = sbrdf(
            &[
                "encode",
                data(name).to_str().unwrap(),
                "-o",
                &out,
                "--rgb-to-spectrum",
                "jakob-hanika-2019",
            ],
            dir.path(),
        );
        let e = stderr(&o);
        assert!(o.status.success(), "{e}");
        let bytes = std::fs::read(dir.path().join(&out)).unwrap();
        eprintln!("{name}: {} bytes; {e}", bytes.len());
        assert!(bytes.len() <= 6500, "{name}: {} bytes", bytes.len());
        // What a renderer holds of it (issue 42) and uploads to a GPU (issue 38): both bounded
        // at 64 KiB for these 32 × 32 measurements, as for the golden files.
        let dec = Decoder::from_bytes(&bytes).unwrap();
        let layout = 4 * dec.gpu_layout().unwrap().len();
        eprintln!(
            "{name}: resident {} B, GPU layout {layout} B",
            dec.resident_bytes()
        );
        assert!(dec.resident_bytes() <= 64 << 10, "{name}: resident");
        assert!(layout <= 64 << 10, "{name}: GPU layout {layout} B");
        assert!(
            bytes.len() as f64 <= SLACK * stated,
            "{name}: {} bytes, the guide states {stated}",
            bytes.len()
        );
        let enc = encode_warped(
            &input(name),
            &WarpedOptions {
                noise_floor: false,
                coding: PayloadCoding::Range,
                predict: true,
                max_error: DEFAULT_MAX_ERROR,
                terms: None,
                transform: None,
            },
        )
        .unwrap();
        assert!(enc.met);
        assert!(enc.errors.iter().all(|&e| e <= DEFAULT_MAX_ERROR));
        // Not an idle budget: every incidence spends most of it.
        assert!(enc.errors.iter().all(|&e| e > 0.5 * DEFAULT_MAX_ERROR));
    }
}

#[test]
fn every_budget_is_met_and_bytes_fall_as_it_grows() {
    // The sizes the guide's table states at 0.5%, 1%, 2% and 5% (warped-tables.md; files as the
    // command line writes them, so with its metadata: the material alone is smaller), each held
    // at SLACK; and the README's "every material within 0.5% under 6.5 kB" at `--max-error 0.5%`
    // (`budgets_are_met`).
    let stated = [
        [5.6e3, 3.9e3, 2.5e3, 1.3e3],
        [2.3e3, 1.7e3, 1.3e3, 0.8e3],
        [3.6e3, 2.5e3, 1.7e3, 1.1e3],
    ];
    for (name, stated) in MATERIALS.into_iter().zip(stated) {
        budgets_are_met(name, stated);
    }
}

/// Each budget met, bytes falling as it grows, and the guide's sizes at 0.5%, 1%, 2% and 5%.
fn budgets_are_met(name: &str, stated: [f64; 4]) {
    let inp = input(name);
    let mut last = usize::MAX;
    for budget in [0.002, 0.005, 0.01, 0.02, 0.05] {
        let enc = encode_warped(
            &inp,
            &WarpedOptions {
                noise_floor: false,
                coding: PayloadCoding::Range,
                predict: true,
                max_error: budget,
                terms: None,
                transform: None,
            },
        )
        .unwrap();
        let worst = enc.errors.iter().cloned().fold(0.0, f64::max);
        let size = write_material(&enc.material).unwrap().len();
        eprintln!("{name} at {budget}: worst {worst:.5}, {size} bytes");
        assert!(enc.met && worst <= budget, "{budget}: {worst}");
        assert!(size < last, "{budget}: {size} bytes, not fewer than {last}");
        last = size;
        if let Some(i) = [0.005, 0.01, 0.02, 0.05].iter().position(|&b| b == budget) {
            held(
                &format!("{name} at {budget}, bytes"),
                size as f64,
                stated[i],
            );
            if budget == 0.005 {
                assert!(size < 6500, "{name} at 0.5%: {size} bytes");
            }
        }
    }
}

#[test]
fn an_unreachable_budget_is_refused_with_the_best_figure_and_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let args = |extra: &'static [&'static str]| {
        let mut a = vec![
            "encode",
            "x.sbrdf",
            "-o",
            "out.sbrdf",
            "--rgb-to-spectrum",
            "jakob-hanika-2019",
            "--max-error",
            "1e-12",
        ];
        a.extend_from_slice(extra);
        a
    };
    std::fs::copy(data("paper_white"), dir.path().join("x.sbrdf")).unwrap();
    let o = sbrdf(&args(&[]), dir.path());
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("at best") && e.contains("x.sbrdf"), "{e}");
    assert!(!dir.path().join("out.sbrdf").exists());
    let o = sbrdf(&args(&["--best-effort"]), dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path().join("out.sbrdf").exists());
}

#[test]
fn the_decoder_follows_the_measurement_between_its_nodes() {
    // Random light directions, not the nodes: the file against Mitsuba's evaluation of the
    // measurement itself (the RGL reader's emulation, tests/rgl.rs checks it against Mitsuba).
    for name in MATERIALS {
        let enc = encode_warped(
            &input(name),
            &WarpedOptions {
                noise_floor: false,
                coding: PayloadCoding::Range,
                predict: true,
                max_error: DEFAULT_MAX_ERROR,
                terms: None,
                transform: None,
            },
        )
        .unwrap();
        let dec = Decoder::from_bytes(&write_material(&enc.material).unwrap()).unwrap();
        let b = RglBsdf::from_bytes(&std::fs::read(data(name)).unwrap()).unwrap();
        for t in 0..b.theta_i.len() - 1 {
            let e = error_against_measurement(&dec, &b, t, 3000);
            eprintln!("{name} incidence {t}: {e:.4}");
            // The guide's 0.5–1.0% (warped-tables.md, "Held out"), held at 1.25× (seen 1.03%).
            assert!(e <= SLACK * 0.010, "{name} incidence {t}: {e}");
        }
    }
}

#[test]
fn an_incidence_left_out_is_predicted_from_its_neighbours() {
    // Held out: the file is written without stored incidence j, and the decoder's answer at
    // that viewing direction (blended between its neighbours in the warped square, as Mitsuba
    // blends) is compared with the measurement there. The figures are `docs/guide/warped-tables.md`'s.
    let mut all = Vec::new();
    for name in MATERIALS {
        let full = input(name);
        let b = RglBsdf::from_bytes(&std::fs::read(data(name)).unwrap()).unwrap();
        let per = full.grid * full.grid * full.wavelengths.len();
        for j in 1..full.thetas_deg.len() - 2 {
            let mut held = full.clone();
            held.thetas_deg.remove(j);
            held.spectra.drain(j * per..(j + 1) * per);
            let enc = encode_warped(
                &held,
                &WarpedOptions {
                    noise_floor: false,
                    coding: PayloadCoding::Range,
                    predict: true,
                    max_error: DEFAULT_MAX_ERROR,
                    terms: None,
                    transform: None,
                },
            )
            .unwrap();
            let dec = Decoder::from_bytes(&write_material(&enc.material).unwrap()).unwrap();
            let e = error_against_measurement(&dec, &b, j, 3000);
            eprintln!(
                "{name}: incidence {j} ({:.1}°) left out: {e:.4}",
                full.thetas_deg[j]
            );
            all.push(e);
        }
    }
    all.sort_by(f64::total_cmp);
    let (median, worst) = (all[all.len() / 2], all[all.len() - 1]);
    eprintln!("held-out incidences: median {median:.4}, worst {worst:.4}");
    // Measured (`docs/guide/warped-tables.md`, "Held out"): median 8.5%, 4.1–26% up to 60°, 46–71% at ≈ 70°,
    // where leaving an incidence out puts its neighbours 20° apart across the fastest change
    // of the lobe. Held at 1.5× the median and 1.4× the worst.
    assert!(median < 0.13, "median held-out incidence {median}");
    assert!(worst < 1.0, "worst held-out incidence {worst}");
}

/// The spectral version of an RGL file as the shared `*_spec.bsdf` files are made:
/// R·red + G·green + B·blue of the ColorChecker patches, each scaled to peak 1, at 380–780 nm
/// every 10 nm.
fn spectral_version(name: &str) -> Vec<u8> {
    let bytes = std::fs::read(data(name)).unwrap();
    let wl: Vec<f64> = (0..41).map(|i| 380.0 + 10.0 * i as f64).collect();
    let table = SpectrumTable::colorchecker();
    let patch = |p: &str| {
        let s = table.sample(table.find(p).unwrap(), &wl).unwrap();
        let peak = s.iter().cloned().fold(0.0, f64::max);
        s.into_iter().map(|v| v / peak).collect::<Vec<_>>()
    };
    let primaries = [patch("red"), patch("green"), patch("blue")];
    let wl32: Vec<f32> = wl.iter().map(|&v| v as f32).collect();
    common::rgl_spectral(&bytes, &wl32, |l, rgb| {
        (0..3).map(|c| rgb[c] as f64 * primaries[c][l]).sum::<f64>() as f32
    })
}

#[test]
fn a_spectral_source_keeps_its_spectra_within_the_budget_and_size() {
    // 41 bands: `docs/guide/warped-tables.md`'s spectral row; the file ≤ 9.5 kB (1/200 of the 1.9 MB source).
    let dir = tempfile::tempdir().unwrap();
    for name in MATERIALS {
        let spec = spectral_version(name);
        std::fs::write(dir.path().join("spec.bsdf"), &spec).unwrap();
        let o = sbrdf(&["encode", "spec.bsdf", "-o", "spec.sbrdf"], dir.path());
        let e = stderr(&o);
        assert!(o.status.success(), "{e}");
        let bytes = std::fs::read(dir.path().join("spec.sbrdf")).unwrap();
        eprintln!("{name} (41 bands): {} bytes; {e}", bytes.len());
        assert!(bytes.len() <= 9500, "{name}: {} bytes", bytes.len());
        let dec = Decoder::from_bytes(&bytes).unwrap();
        assert_eq!(dec.material().wavelengths.len(), 41);
        // The spectra at the nodes of incidence 2 against the source's, in the spectral domain.
        let read = read_warped("spec.bsdf", &spec, &ReadOptions::default())
            .unwrap()
            .unwrap();
        let inp = read.input;
        let b = RglBsdf::from_bytes(&spec).unwrap();
        let inc = b.incidence(2, 0).unwrap();
        let viewer = unit(inc.theta_i, inc.phi_i);
        let wl: Vec<f32> = inp.wavelengths.clone();
        let mut out = vec![0.0f32; wl.len()];
        let (mut num, mut den) = (0.0, 0.0);
        for (k, c) in inc.cells.iter().enumerate() {
            if !c.above || c.theta_o > 85.0 {
                continue;
            }
            dec.eval(unit(c.theta_o, c.phi_o), viewer, &wl, &mut out);
            let cos = c.theta_o.to_radians().cos();
            for (l, &got) in out.iter().enumerate() {
                let want = inc.values[k * wl.len() + l].max(0.0) * cos;
                let got = got as f64 * cos;
                num += (got - want) * (got - want);
                den += want * want;
            }
        }
        let err = (num / den).sqrt();
        eprintln!("{name} (41 bands): spectral error at incidence 2's nodes {err:.4}");
        assert!(err < 0.015, "{name}: {err}");
    }
}

#[test]
fn each_transform_meets_the_budget_and_the_default_keeps_the_smaller_file() {
    for name in MATERIALS {
        let inp = input(name);
        let mut sizes = Vec::new();
        for transform in [
            None,
            Some(TableTransform::Dct),
            Some(TableTransform::Wavelet53),
        ] {
            let enc = encode_warped(
                &inp,
                &WarpedOptions {
                    noise_floor: false,
                    coding: PayloadCoding::Range,
                    predict: true,
                    max_error: DEFAULT_MAX_ERROR,
                    terms: None,
                    transform,
                },
            )
            .unwrap();
            let bytes = write_material(&enc.material).unwrap();
            let w = enc.material.warped.as_ref().unwrap();
            if let Some(t) = transform {
                assert_eq!(w.transform, t);
            }
            // Range-coded with prediction: 1.7 whatever the transform (every RGL file repeats
            // its last incidence, which is predicted; without prediction 1.6, deflated 1.4 for
            // the DCT and 1.5 for the wavelet,
            // `format_1_5_keeps_zlib_and_1_4_the_dct_with_the_same_values`).
            let minor = u16::from_le_bytes([bytes[20], bytes[21]]);
            assert_eq!(minor, 7, "{name}");
            assert!(enc.met && enc.errors.iter().all(|&e| e <= DEFAULT_MAX_ERROR));
            // What is written decodes to the same tables (read back through the format).
            let back = sbrdf::read_material(&bytes, &sbrdf::Limits::default()).unwrap();
            assert_eq!(back.warped.as_deref(), Some(w.as_ref()), "{name}");
            sizes.push(bytes.len());
        }
        eprintln!(
            "{name}: default {} bytes, DCT {}, wavelet {}",
            sizes[0], sizes[1], sizes[2]
        );
        assert_eq!(sizes[0], sizes[1].min(sizes[2]), "{name}");
    }
}

/// The same tables read from a file: everything but the payload's coding.
fn tables_of(file: &str) -> sbrdf::model::warped::WarpedModel {
    let bytes = std::fs::read(samples_dir().join("golden").join(file)).unwrap();
    let m = sbrdf::read_material(&bytes, &sbrdf::Limits::default()).unwrap();
    *m.warped.unwrap()
}

#[test]
fn the_range_coded_golden_holds_the_deflated_goldens_tables_value_for_value() {
    let (old, new) = (
        tables_of("rgl_satin_warp_v15.sbrdf"),
        tables_of("rgl_satin_warp_v16.sbrdf"),
    );
    assert_eq!(old.coding, PayloadCoding::Deflate);
    assert_eq!(new.coding, PayloadCoding::Range);
    assert_eq!(
        old,
        sbrdf::model::warped::WarpedModel {
            coding: PayloadCoding::Deflate,
            ..new.clone()
        }
    );
    // And so they evaluate alike, bit for bit.
    let open = |f: &str| {
        Decoder::from_bytes(&std::fs::read(samples_dir().join("golden").join(f)).unwrap()).unwrap()
    };
    let (a, b) = (
        open("rgl_satin_warp_v15.sbrdf"),
        open("rgl_satin_warp_v16.sbrdf"),
    );
    for (ti, to, po) in [(0.0, 30.0, 10.0), (35.0, 40.0, 180.0), (70.0, 75.0, 5.0)] {
        let (mut x, mut y) = ([0.0f32; 3], [0.0f32; 3]);
        a.eval(unit(ti, 0.0), unit(to, po), &[450.0, 550.0, 650.0], &mut x);
        b.eval(unit(ti, 0.0), unit(to, po), &[450.0, 550.0, 650.0], &mut y);
        assert_eq!(x, y);
    }
    // 28% fewer bytes for the same values.
    let len = |f: &str| {
        std::fs::metadata(samples_dir().join("golden").join(f))
            .unwrap()
            .len()
    };
    assert!(len("rgl_satin_warp_v16.sbrdf") * 100 < 75 * len("rgl_satin_warp_v15.sbrdf"));
}

#[test]
fn format_1_5_keeps_zlib_and_1_4_the_dct_with_the_same_values() {
    let path = data("satin_rosaline");
    let encode = |format: &str| {
        let (bytes, warped) = encode_rgl("satin_rosaline", format, None);
        (u16::from_le_bytes([bytes[20], bytes[21]]), warped)
    };
    let (v6, new) = encode("1.6");
    let (v5, old) = encode("1.5");
    let (v4, dct) = encode("1.4");
    assert_eq!((v6, v5, v4), (6, 5, 4));
    assert_eq!(
        (new.coding, old.coding, dct.coding),
        (
            PayloadCoding::Range,
            PayloadCoding::Deflate,
            PayloadCoding::Deflate
        )
    );
    // The same warp; the tables differ by the basis they are fitted to (1.6 stores it
    // quantised, 1.5 in f16), so only the layout is compared here.
    assert_eq!(
        (
            &old.ndf,
            old.grid,
            old.warp_grid,
            old.sigma_scale,
            old.transform
        ),
        (
            &new.ndf,
            new.grid,
            new.warp_grid,
            new.sigma_scale,
            new.transform
        )
    );
    assert_eq!(old.levels.len(), new.levels.len());
    assert_eq!(dct.transform, TableTransform::Dct);
    let mut s = sbrdf::encode::settings::EncodeSettings::default();
    s.set("rgb-to-spectrum", "jakob-hanika-2019").unwrap();
    s.set("format", "1.3").unwrap();
    let e = sbrdf::io::rgl::encode_warped_file(std::slice::from_ref(&path), &s).unwrap_err();
    assert!(e.to_string().contains("need format 1.4"), "{e}");
}

#[test]
fn a_range_coded_payload_is_refused_in_a_1_5_file() {
    let good = std::fs::read(samples_dir().join("golden/rgl_satin_warp_v16.sbrdf")).unwrap();
    assert!(Decoder::from_bytes(&good).is_ok());
    let mut old = good.clone();
    old[20] = 5;
    let head_len = u32::from_le_bytes(old[10..14].try_into().unwrap()) as usize;
    fix_crc(&mut old, 18, head_len);
    let e = Decoder::from_bytes(&old).unwrap_err().to_string();
    assert!(e.contains("1.6 feature") && e.contains("malformed"), "{e}");
    // A payload too short for its integers (1600 a byte at most) is refused before decoding.
    let (at, len) = warp_chunk(&good);
    let mut short = good[..at + 16 + 5].to_vec();
    short.extend_from_slice(&good[at + len..]);
    short[at - 8..at - 4].copy_from_slice(&21u32.to_le_bytes());
    short[at + 12..at + 16].copy_from_slice(&5u32.to_le_bytes());
    fix_crc(&mut short, at, 21);
    let e = Decoder::from_bytes(&short).unwrap_err().to_string();
    assert!(e.contains("cannot hold") && e.contains("malformed"), "{e}");
}

/// The file with its `HEAD` rewritten: `minor` and the incidences as (θi, φi = 0) pairs, flag
/// bit 2 cleared (what a 1.6 writer would write), the rest unchanged.
fn with_pairs_in_head(bytes: &[u8], minor: u16) -> Vec<u8> {
    let (at, len) = chunk(bytes, b"HEAD");
    let head = &bytes[at..at + len];
    let flags = u32::from_le_bytes(head[4..8].try_into().unwrap());
    assert!(flags & 4 != 0, "incidences as θi alone");
    let n = u32::from_le_bytes(head[36..40].try_into().unwrap()) as usize;
    let thetas = &head[len - 4 * n..];
    let mut d = head[..len - 4 * n].to_vec();
    d[2..4].copy_from_slice(&minor.to_le_bytes());
    d[4..8].copy_from_slice(&(flags & !4).to_le_bytes());
    for t in thetas.chunks_exact(4) {
        d.extend_from_slice(t);
        d.extend_from_slice(&0f32.to_le_bytes());
    }
    let mut out = bytes[..at - 8].to_vec();
    out.extend_from_slice(&(d.len() as u32).to_le_bytes());
    out.extend_from_slice(b"HEAD");
    out.extend_from_slice(&d);
    out.extend_from_slice(&crc32fast::hash(&[&b"HEAD"[..], &d].concat()).to_le_bytes());
    out.extend_from_slice(&bytes[at + len + 4..]);
    out
}

#[test]
fn a_1_7_head_holds_theta_alone_and_is_refused_where_it_does_not_belong() {
    let good = std::fs::read(samples_dir().join("golden/rgl_ibiza_pred_v17.sbrdf")).unwrap();
    let (at, len) = chunk(&good, b"HEAD");
    // 40 fixed bytes, a wavelength range (2 × 4) and 8 θi of 4 bytes: 32 fewer than pairs.
    assert_eq!(len, 40 + 8 + 4 * 8);
    // The same file with (θi, 0) pairs and minor 7 reads as the same material.
    let pairs = with_pairs_in_head(&good, 7);
    assert_eq!(pairs.len(), good.len() + 32);
    let (a, b) = (
        sbrdf::read_material(&good, &Default::default()).unwrap(),
        sbrdf::read_material(&pairs, &Default::default()).unwrap(),
    );
    assert_eq!(a.records, b.records);
    assert_eq!(a.warped, b.warped);
    // Flag bit 2 in a 1.6 file, and without the isotropic flag: malformed.
    for (minor, flags, what) in [(6u16, 7u32, "1.7 feature"), (7, 6, "without the isotropic")] {
        let mut bad = good.clone();
        bad[at + 2..at + 4].copy_from_slice(&minor.to_le_bytes());
        bad[at + 4..at + 8].copy_from_slice(&flags.to_le_bytes());
        fix_crc(&mut bad, at, len);
        let e = Decoder::from_bytes(&bad).unwrap_err().to_string();
        assert!(e.contains(what) && e.contains("malformed"), "{e}");
    }
    // Bit 3, which no version defines: unsupported.
    let mut bad = good.clone();
    bad[at + 4] |= 8;
    fix_crc(&mut bad, at, len);
    let e = Decoder::from_bytes(&bad).unwrap_err().to_string();
    assert!(
        e.contains("unknown flag bits") && e.contains("unsupported"),
        "{e}"
    );
}

#[test]
fn prediction_flags_are_refused_in_a_1_6_file_without_range_coding_and_as_arrangement_3() {
    let good = std::fs::read(samples_dir().join("golden/rgl_ibiza_pred_v17.sbrdf")).unwrap();
    assert!(Decoder::from_bytes(&good).is_ok());
    // A 1.6 HEAD (pairs, no flag bit 2) before the 1.7 WARP chunk.
    let old = with_pairs_in_head(&good, 6);
    let e = Decoder::from_bytes(&old).unwrap_err().to_string();
    assert!(
        e.contains("prediction flags") && e.contains("1.7 feature") && e.contains("malformed"),
        "{e}"
    );
    let (at, len) = warp_chunk(&good);
    assert_eq!(good[at] & 0x0F, 0x0A, "arrangement 2, range-coded");
    // Arrangement 2 with bit 3 cleared (zlib): the flags have nowhere to be.
    let mut deflated = good.clone();
    deflated[at] &= !0x08;
    fix_crc(&mut deflated, at, len);
    let e = Decoder::from_bytes(&deflated).unwrap_err().to_string();
    assert!(
        e.contains("need a range-coded payload") && e.contains("malformed"),
        "{e}"
    );
    // Arrangement 3, which no version defines.
    let mut unknown = good.clone();
    unknown[at] = (unknown[at] & !0x07) | 3;
    fix_crc(&mut unknown, at, len);
    let e = Decoder::from_bytes(&unknown).unwrap_err().to_string();
    assert!(
        e.contains("unknown warped-table arrangement 3") && e.contains("unsupported"),
        "{e}"
    );
}

/// Encodes an RGL file with `format` (and `--max-error` when given): the bytes and the warped
/// model read back.
fn encode_rgl(name: &str, format: &str, max_error: Option<&str>) -> (Vec<u8>, WarpedModel) {
    let path = data(name);
    let mut s = sbrdf::encode::settings::EncodeSettings::default();
    s.set("rgb-to-spectrum", "jakob-hanika-2019").unwrap();
    s.set("format", format).unwrap();
    if let Some(e) = max_error {
        s.set("max-error", e).unwrap();
    }
    let o = sbrdf::io::rgl::encode_warped_file(std::slice::from_ref(&path), &s)
        .unwrap()
        .unwrap();
    let m = sbrdf::read_material(&o.bytes, &sbrdf::Limits::default()).unwrap();
    (o.bytes, *m.warped.unwrap())
}

/// [`rgl_error_at_nodes`] of a file's bytes.
fn error_at_nodes(bytes: &[u8], b: &RglBsdf) -> f64 {
    rgl_error_at_nodes(&Decoder::from_bytes(bytes).unwrap(), b)
}

#[test]
fn prediction_takes_fewer_bytes_at_the_same_budget_and_1_6_writes_none() {
    for name in MATERIALS {
        let b = RglBsdf::from_bytes(&std::fs::read(data(name)).unwrap()).unwrap();
        for budget in ["1%", "2%"] {
            let (new, w7) = encode_rgl(name, "1.7", Some(budget));
            let (old, w6) = encode_rgl(name, "1.6", Some(budget));
            assert!(w6.predicted.is_empty(), "{name}: 1.6 has no flags");
            assert_eq!(w7.predicted.len(), 8);
            // Every RGL file repeats its last incidence: at least that one is predicted.
            assert!(
                w7.predicted[7] && !w7.predicted[0],
                "{name}: {:?}",
                w7.predicted
            );
            assert!(
                (new.len() as f64) < 0.95 * old.len() as f64,
                "{name} at {budget}: {} bytes with {:?} predicted, {} without",
                new.len(),
                w7.predicted,
                old.len()
            );
            // Both within the budget of the measurement itself at its nodes (1.5×, as
            // tests/roundtrip.rs holds the golden files: the budget is the tables' error, this
            // the decoded colours'), and prediction no less accurate than standing alone.
            let limit = 1.5 * budget.trim_end_matches('%').parse::<f64>().unwrap() / 100.0;
            let (e7, e6) = (error_at_nodes(&new, &b), error_at_nodes(&old, &b));
            eprintln!(
                "{name} at {budget}: 1.7 {} B, error {e7:.5}; 1.6 {} B, error {e6:.5}",
                new.len(),
                old.len()
            );
            assert!(
                e7 <= limit && e6 <= limit && e7 <= 1.05 * e6,
                "{name} at {budget}: {e7}, {e6}"
            );
        }
    }
}

#[test]
fn a_subset_of_a_predicted_file_keeps_the_incidences_it_predicts_from() {
    let (bytes, w) = encode_rgl("cc_ibiza_sunset", "1.7", None);
    assert!(w.predicted.iter().any(|&p| p));
    let original = sbrdf::read_material(&bytes, &sbrdf::Limits::default()).unwrap();
    let (cut, _) = sbrdf::encode::subset::subset(
        &original,
        &sbrdf::encode::subset::SubsetOptions {
            incident_max: Some(60.0),
            ..Default::default()
        },
    )
    .unwrap();
    let cut_bytes = write_material(&cut).unwrap();
    let back = sbrdf::read_material(&cut_bytes, &sbrdf::Limits::default()).unwrap();
    let cw = back.warped.as_ref().unwrap();
    let kept = back.records.len();
    assert!(kept < 8 && cw.predicted[..] == w.predicted[..kept]);
    assert!(cut_bytes.len() < bytes.len());
    // The kept tables decode exactly as in the original.
    let (a, b) = (w.decode_tables(), cw.decode_tables());
    assert_eq!(a[..b.len()], b[..]);
}

#[test]
fn the_wavelet_is_refused_in_a_1_4_file_and_an_unknown_transform_is_unsupported() {
    let good = std::fs::read(samples_dir().join("golden/rgl_satin_warp_v15.sbrdf")).unwrap();
    assert!(Decoder::from_bytes(&good).is_ok());
    // HEAD's version_minor 5 → 4 (HEAD's data starts at 18; its CRC rewritten).
    let mut old = good.clone();
    old[20] = 4;
    let head_len = u32::from_le_bytes(old[10..14].try_into().unwrap()) as usize;
    fix_crc(&mut old, 18, head_len);
    let e = Decoder::from_bytes(&old).unwrap_err().to_string();
    assert!(e.contains("1.5 feature") && e.contains("malformed"), "{e}");
    // Layout 0x21: transform 2, which no version defines.
    let (at, len) = warp_chunk(&good);
    let mut unknown = good.clone();
    unknown[at] = 0x21;
    fix_crc(&mut unknown, at, len);
    let e = Decoder::from_bytes(&unknown).unwrap_err().to_string();
    assert!(
        e.contains("unknown warped-table transform 2") && e.contains("unsupported"),
        "{e}"
    );
}

/// The WARP chunk of a file: (offset of its data, its length).
fn warp_chunk(bytes: &[u8]) -> (usize, usize) {
    chunk(bytes, b"WARP")
}

/// The chunk of type `kind` in a file: (offset of its data, its length).
fn chunk(bytes: &[u8], kind: &[u8; 4]) -> (usize, usize) {
    let mut p = 10;
    while p + 12 <= bytes.len() {
        let len = u32::from_le_bytes(bytes[p..p + 4].try_into().unwrap()) as usize;
        if &bytes[p + 4..p + 8] == kind {
            return (p + 8, len);
        }
        p += 12 + len;
    }
    panic!("no {} chunk", String::from_utf8_lossy(kind));
}

/// Rewrites the CRC of the chunk whose data starts at `at` (so a reader gets past it).
fn fix_crc(bytes: &mut [u8], at: usize, len: usize) {
    let crc = crc32fast::hash(&bytes[at - 4..at + len]);
    bytes[at + len..at + len + 4].copy_from_slice(&crc.to_le_bytes());
}

#[test]
fn damage_behind_a_valid_crc_is_refused_or_decoded_never_a_panic() {
    for golden in ["rgl_paper_warp_v14.sbrdf", "rgl_satin_warp_v15.sbrdf"] {
        damage_behind_a_valid_crc(golden, 12 + 2 * 128 + 4 * 24 + 4, true);
    }
    // Range-coded (1.6): the NDF and steps are in the payload, and the payload has no check of
    // its own (the chunk's CRC is what catches accidental damage), so a flipped bit may decode
    // to other values: finite ones, never a panic.
    for golden in [
        "rgl_satin_dct_warp_v16.sbrdf",
        "rgl_satin_warp_v16.sbrdf",
        "rgl_ibiza_pred_v17.sbrdf",
    ] {
        damage_behind_a_valid_crc(golden, 16, false);
    }
}

/// The golden files hold 8 incidences × 3 terms and 128 f16 NDF nodes; `header` bytes come
/// before the payload; `checked`: the payload's coding checks itself (zlib's Adler-32).
fn damage_behind_a_valid_crc(golden: &str, header: usize, checked: bool) {
    let good = std::fs::read(samples_dir().join("golden").join(golden)).unwrap();
    let (at, len) = warp_chunk(&good);
    let mut refused = 0;
    // Every header and NDF byte, and a spread of payload bytes, each flipped.
    let spots: Vec<usize> = (0..header).chain((header..len).step_by(7)).collect();
    for &i in &spots {
        for mask in [0x01u8, 0x80] {
            let mut b = good.clone();
            b[at + i] ^= mask;
            fix_crc(&mut b, at, len);
            match Decoder::from_bytes(&b) {
                Err(_) => refused += 1,
                Ok(d) => {
                    // What decodes evaluates to finite values.
                    let mut out = [0.0f32; 3];
                    d.eval(
                        unit(30.0, 10.0),
                        unit(40.0, 200.0),
                        &[450.0, 550.0, 650.0],
                        &mut out,
                    );
                    assert!(out.iter().all(|v| v.is_finite() && *v >= 0.0), "byte {i}");
                }
            }
        }
    }
    // Payload damage is caught by zlib's own checks nearly always.
    assert!(
        !checked || refused > spots.len() / 2,
        "{refused} of {} refused",
        2 * spots.len()
    );
    // A payload cut short (lengths kept consistent) is refused as malformed.
    for cut in [1usize, 10, 500] {
        let mut b = good[..at + len - cut].to_vec();
        b.extend_from_slice(&good[at + len..]);
        let new_len = (len - cut) as u32;
        b[at - 8..at - 4].copy_from_slice(&new_len.to_le_bytes());
        let plen_at = at + header - 4;
        let plen = u32::from_le_bytes(b[plen_at..plen_at + 4].try_into().unwrap()) - cut as u32;
        b[plen_at..plen_at + 4].copy_from_slice(&plen.to_le_bytes());
        fix_crc(&mut b, at, len - cut);
        let e = Decoder::from_bytes(&b).unwrap_err().to_string();
        assert!(e.contains("WARP") && e.contains("malformed"), "{e}");
    }
}

#[test]
fn tables_that_would_cost_too_much_to_open_are_refused_before_inflating() {
    // A 3 kB file whose header asks for 4096 NDF nodes on a 256² VNDF grid: 2.7·10⁸ operations
    // to open. Refused as a limit exceeded (Limits::max_warp_work), not parsed further.
    let good = std::fs::read(samples_dir().join("golden/rgl_paper_warp_v14.sbrdf")).unwrap();
    let (at, len) = warp_chunk(&good);
    let mut b = good.clone();
    b[at + 4..at + 6].copy_from_slice(&256u16.to_le_bytes());
    b[at + 6..at + 8].copy_from_slice(&4096u16.to_le_bytes());
    fix_crc(&mut b, at, len);
    let e = Decoder::from_bytes(&b).unwrap_err();
    assert!(matches!(e, sbrdf::Error::LimitsExceeded(_)), "{e}");
    // A caller who accepts the cost gets the ordinary answer: this header no longer matches
    // the bytes that follow it.
    let lax = sbrdf::Limits {
        max_warp_work: u64::MAX,
        ..Default::default()
    };
    let e = sbrdf::read_material(&b, &lax).unwrap_err().to_string();
    assert!(e.contains("malformed"), "{e}");
}

#[test]
fn a_file_written_and_read_back_is_the_same_material_and_bytes() {
    let enc = encode_warped(
        &input("cc_ibiza_sunset"),
        &WarpedOptions {
            noise_floor: false,
            coding: PayloadCoding::Range,
            predict: true,
            max_error: 0.02,
            terms: None,
            transform: None,
        },
    )
    .unwrap();
    let bytes = write_material(&enc.material).unwrap();
    let back = sbrdf::read_material(&bytes, &sbrdf::Limits::default()).unwrap();
    assert_eq!(back, enc.material);
    assert_eq!(write_material(&back).unwrap(), bytes);
}

/// The compact form a renderer opens (`Residency::Compact`: the tables packed to 1/256 of the
/// file's quantisation step, the warps' quantities in f32; the GPU layout's section) against the
/// exact binary64 values, on every golden file with warped tables: relative L2 of ρ over random
/// pairs at the file's wavelengths within a fifth of the file's own stored error (seen 0.003–0.13
/// of it: the packing adds a few percent to the error the file already has), every value finite
/// and the sampling densities of both forms positive where the pair can be drawn.
#[test]
fn the_compact_form_is_the_exact_one_within_a_fraction_of_the_stored_error() {
    let mut checked = 0;
    for name in common::golden_files() {
        let bytes = std::fs::read(samples_dir().join("golden").join(&name)).unwrap();
        let limits = sbrdf::Limits::default();
        let exact = Decoder::from_bytes_with(&bytes, &limits, sbrdf::Residency::Exact).unwrap();
        let Some(warped) = exact.material().warped.as_ref() else {
            continue;
        };
        // The encoder's figure, in the metadata ("rel_error": the largest over the incidences).
        let meta = exact.material().metadata.clone().unwrap_or_default();
        let stored: f64 = meta
            .split("\"rel_error\":")
            .nth(1)
            .and_then(|v| v.split([',', '}']).next())
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or_else(|| panic!("{name}: no rel_error in its metadata {meta}"));
        assert!(stored > 0.0, "{name}: stored error {stored}");
        let compact = Decoder::from_bytes(&bytes).unwrap();
        assert_eq!(compact.residency(), sbrdf::Residency::Compact);
        let wl = exact.material().wavelengths.clone();
        let (mut a, mut b) = (vec![0.0f32; wl.len()], vec![0.0f32; wl.len()]);
        let mut rng = Rng(0x2545_F491_4F6C_DD1D);
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for _ in 0..20_000 {
            let mut dir = || unit(rng.next().acos().to_degrees(), 360.0 * rng.next());
            let (wi, wo) = (dir(), dir());
            compact.eval(wi, wo, &wl, &mut a);
            exact.eval(wi, wo, &wl, &mut b);
            for (x, y) in a.iter().zip(&b) {
                assert!(x.is_finite(), "{name}: {x} at {wi:?} {wo:?}");
                num += (*x as f64 - *y as f64).powi(2);
                den += (*y as f64).powi(2);
            }
            let (pc, pe) = (compact.pdf(wi, wo), exact.pdf(wi, wo));
            assert!(
                pc.is_finite() && (pc > 0.0) == (pe > 0.0),
                "{name}: pdf {pc} vs {pe}"
            );
        }
        let e = (num / den).sqrt();
        let (r, share) = (warped.grid, e / stored);
        eprintln!(
            "{name} ({r}×{r}): compact against exact, relative L2 {e:.3e} = {share:.3} of the \
             stored error {stored}"
        );
        assert!(e <= 0.2 * stored, "{name}: {e} against a stored {stored}");
        checked += 1;
    }
    assert!(checked >= 3, "{checked} golden files with warped tables");
}

#[test]
fn a_quantised_basis_holds_the_same_colours_in_a_third_of_the_bytes() {
    // Format 1.6 stores the basis as power-of-two-gridded integers, range-coded (FORMAT.md
    // §3.2, precision 3); --format 1.5 keeps f16. The tables are fitted to the basis as
    // stored, so both files meet the same budget on the measured colours.
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/rgl/paper_white_rgb.bsdf");
    let mut files = Vec::new();
    for format in ["1.6", "1.5"] {
        let mut s = sbrdf::encode::settings::EncodeSettings::default();
        s.set("rgb-to-spectrum", "jakob-hanika-2019").unwrap();
        s.set("format", format).unwrap();
        let out = sbrdf::io::rgl::encode_warped_file(std::slice::from_ref(&path), &s)
            .unwrap()
            .unwrap();
        files.push(out);
    }
    let (new, old) = (&files[0].bytes, &files[1].bytes);
    let (at, len) = chunk(new, b"SBAS");
    let (old_at, old_len) = chunk(old, b"SBAS");
    assert_eq!(new[at], 3, "precision code 3 in 1.6");
    assert_eq!(old[old_at], 2, "f16 in 1.5");
    assert_eq!(old_len, 4 + 3 * 41 * 2);
    assert!(
        len * 3 < old_len,
        "quantised SBAS {len} bytes, f16 {old_len}"
    );
    for out in &files {
        assert!(out.errors.iter().all(|&e| e <= 0.01), "{:?}", out.errors);
    }
    // Every value is an integer times its function's power of two, and reads back exactly.
    let m = sbrdf::read_material(new, &sbrdf::Limits::default()).unwrap();
    let table = m.spectral.table.as_ref().unwrap();
    assert_eq!(
        sbrdf::write_material(&m).unwrap(),
        *new,
        "read and written back unchanged"
    );
    let sbrdf::model::basis_storage::BasisStorage::Quantised { exponents } = &table.storage else {
        panic!("{:?}", table.storage)
    };
    for (k, row) in table.values.chunks(41).enumerate() {
        let step = 2f64.powi(exponents[k] as i32);
        let largest = row.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(row.iter().all(|v| (v / step).fract() == 0.0));
        // 8 bits below the largest value (an RGB file's stand-in spectra).
        assert!(
            largest / step > 127.0 && largest / step <= 256.0,
            "{}",
            largest / step
        );
    }
}

#[test]
fn a_damaged_quantised_basis_is_refused_with_its_reason() {
    let good = std::fs::read(samples_dir().join("golden/rgl_paper_qbasis_v16.sbrdf")).unwrap();
    assert!(Decoder::from_bytes(&good).is_ok());
    let (at, len) = chunk(&good, b"SBAS");
    assert_eq!(good[at], 3);
    let refused = |b: &[u8]| Decoder::from_bytes(b).unwrap_err().to_string();
    // An exponent above 103 (2^104 · n overflows f32 for large n).
    let mut b = good.clone();
    b[at + 4] = 104;
    fix_crc(&mut b, at, len);
    let e = refused(&b);
    assert!(e.contains("exponent 104") && e.contains("malformed"), "{e}");
    // In a 1.5 file: a 1.6 feature.
    let mut b = good.clone();
    b[20] = 5;
    let head_len = u32::from_le_bytes(b[10..14].try_into().unwrap()) as usize;
    fix_crc(&mut b, 18, head_len);
    let e = refused(&b);
    assert!(e.contains("1.6 feature") && e.contains("malformed"), "{e}");
    // The stream cut short, or a byte after its last integer (the chunk re-framed).
    for cut in [-6i64, 1] {
        let new_len = (len as i64 + cut) as usize;
        let mut b = good[..at].to_vec();
        if cut < 0 {
            b.extend_from_slice(&good[at..at + new_len]);
        } else {
            b.extend_from_slice(&good[at..at + len]);
            b.push(0);
        }
        b.extend_from_slice(&[0; 4]);
        b.extend_from_slice(&good[at + len + 4..]);
        b[at - 8..at - 4].copy_from_slice(&(new_len as u32).to_le_bytes());
        fix_crc(&mut b, at, new_len);
        let e = refused(&b);
        assert!(e.contains("malformed") && e.contains("SBAS"), "{cut}: {e}");
    }
    // A stream too short for K·W integers (1600 a byte) is refused before decoding: here none.
    let mut b = good[..at + 4 + 3].to_vec();
    b.extend_from_slice(&[0; 4]);
    b.extend_from_slice(&good[at + len + 4..]);
    b[at - 8..at - 4].copy_from_slice(&7u32.to_le_bytes());
    fix_crc(&mut b, at, 7);
    let e = refused(&b);
    assert!(e.contains("cannot be coded in 0 bytes"), "{e}");
}
