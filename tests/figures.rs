//! `sbrdf plot`, `sbrdf preview` and `sbrdf paper-figures`: the pictures decode, show what they
//! claim, and bad input gets a clear message.

mod common;
use common::{sbrdf, stderr};
use std::path::PathBuf;
use std::process::Output;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn sample(rel: &str) -> String {
    root().join(rel).display().to_string()
}

fn assert_ok(o: &Output) {
    assert!(
        o.status.success(),
        "failed: {}{}",
        String::from_utf8_lossy(&o.stdout),
        stderr(o)
    );
}

/// Asserts failure with exit status 1, a message containing `needle`, no panic, and no output
/// file left in `dir` besides `keep`.
fn assert_refused(o: &Output, needle: &str) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains(needle), "message lacks '{needle}': {e}");
    assert!(!e.contains("panicked"), "{e}");
}

/// PNG signature and IHDR size.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert!(bytes.len() > 1000, "PNG of {} bytes", bytes.len());
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

fn assert_svg(text: &str, labels: &[&str]) {
    assert!(text.len() > 5000, "SVG of {} bytes", text.len());
    let t = text.trim_start();
    assert!(
        t.starts_with("<svg") || t.starts_with("<?xml"),
        "{}",
        &t[..80]
    );
    assert!(text.trim_end().ends_with("</svg>"));
    // Tags balance (XML-ish): every '<' has its '>'.
    assert_eq!(text.matches('<').count(), text.matches('>').count());
    for l in labels {
        assert!(text.contains(l), "SVG lacks '{l}'");
    }
}

/// The first record's incidence "θ,φ".
fn first_incidence(file: &str) -> String {
    let d = sbrdf::Decoder::open(file).unwrap();
    let r = &d.material().records[0];
    format!("{},{}", r.theta_i, r.phi_i)
}

/// Every golden file (the MANIFEST's) and the shipped sample, as paths from the repository root.
fn golden() -> Vec<String> {
    common::golden_files()
        .iter()
        .map(|f| format!("samples/golden/{f}"))
        .chain(["samples/ggx_slices.sbrdf".to_string()])
        .collect()
}

#[test]
fn plot_draws_every_golden_file_as_png() {
    let dir = tempfile::tempdir().unwrap();
    for f in &golden() {
        let file = sample(f);
        let inc = first_incidence(&file);
        let o = sbrdf(
            &["plot", &file, "--incident", &inc, "-o", "p.png"],
            dir.path(),
        );
        assert_ok(&o);
        let bytes = std::fs::read(dir.path().join("p.png")).unwrap();
        assert_eq!(png_size(&bytes), (1600, 980), "{f}");
        // Decodes, and is a picture rather than a blank page.
        let img = image::load_from_memory(&bytes).unwrap().to_rgb8();
        let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
        assert!(colours.len() > 200, "{f}: only {} colours", colours.len());
    }
}

#[test]
fn plot_svg_with_a_reference_shows_original_and_reconstruction() {
    let dir = tempfile::tempdir().unwrap();
    // EXR slices as the reference, a microfacet file.
    let o = sbrdf(
        &[
            "plot",
            &sample("samples/ggx_slices.sbrdf"),
            "--reference",
            &sample("samples/ggx_slices"),
            "--incident",
            "30,0",
            "-o",
            "g.svg",
        ],
        dir.path(),
    );
    assert_ok(&o);
    assert!(stderr(&o).contains("spectrum errors"), "{}", stderr(&o));
    let svg = std::fs::read_to_string(dir.path().join("g.svg")).unwrap();
    assert_svg(
        &svg,
        &[
            "φo (degrees)",
            "θo (degrees)",
            "wavelength (nm)",
            "ρ (1/sr)",
            "1/sr",
            "of the original samples",
            "SH background",
            "peak part",
            "original (error",
            "the peak",
            "record 2 of 3",
        ],
    );
    // The paper's file with its CSV: coefficient 2 is b1, and a requested incidence that is
    // not stored says which record is shown.
    let o = sbrdf(
        &[
            "plot",
            &sample("samples/golden/phong_3inc_paper.sbrdf"),
            "--reference",
            &sample("samples/golden/phong_3inc.csv"),
            "--incident",
            "25,40",
            "--coefficient",
            "2",
            "--outgoing",
            "30,180",
            "--outgoing",
            "45,90",
            "-o",
            "b1.svg",
        ],
        dir.path(),
    );
    assert_ok(&o);
    let svg = std::fs::read_to_string(dir.path().join("b1.svg")).unwrap();
    assert_svg(
        &svg,
        &[
            "coefficient b1",
            "nearest to the requested (25°, 40°)",
            "isotropic, shown at φi = 0°",
            "angle-gaussian",
            "2: ωo = (45°, 90°)",
        ],
    );
}

#[test]
fn plot_coefficients_add_up() {
    // Library view: background + peak = reconstruction, and the reconstruction of a0 matches
    // the samples' a0 to within the record's error.
    let dec = sbrdf::Decoder::open(sample("samples/golden/phong_3inc_paper.sbrdf")).unwrap();
    let (set, _) = sbrdf::io::read_inputs(&[sample("samples/golden/phong_3inc.csv")]).unwrap();
    let p = sbrdf::report::plot::coefficient_plot(
        &dec,
        "phong",
        Some(&set),
        &sbrdf::report::plot::PlotOptions {
            incident: (30.0, 0.0),
            coefficient: 0,
            outgoing: Vec::new(),
            kind: sbrdf::report::draw::ImageKind::Png,
        },
    )
    .unwrap();
    for ((full, bg), peak) in p
        .full
        .values
        .iter()
        .zip(&p.background.values)
        .zip(&p.peak.values)
    {
        assert!((bg + peak - full).abs() <= 1e-9 * full.abs().max(1.0));
    }
    // The peak part is largest near the record's peak direction (30°, 180°).
    let (imax, _) = p
        .peak
        .values
        .iter()
        .enumerate()
        .fold((0, f64::MIN), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
    let (t, ph) = sbrdf::report::draw::HemisphereMap::centres(p.peak.rows, p.peak.columns)[imax];
    assert!(
        (t - 30.0).abs() < 3.0 && (ph - 180.0).abs() < 4.0,
        "peak at ({t}, {ph})"
    );
    // Original and reconstruction agree where both exist (paper mode: ≈ 9% overall).
    let o = p.original.as_ref().unwrap();
    let (mut e, mut r) = (0.0, 0.0);
    for (a, b) in p.full.values.iter().zip(&o.values) {
        if b.is_finite() {
            e += (a - b) * (a - b);
            r += b * b;
        }
    }
    assert!((e / r).sqrt() < 0.3, "a0 maps differ by {}", (e / r).sqrt());
    assert_eq!(p.spectra.len(), 4);
    assert!(p.spectra[0].label.contains("the peak") || p.spectra[0].error.is_some());
}

#[test]
fn plotted_coefficients_are_what_the_decoder_evaluates() {
    // Σ_k (Σ_j A(k, j)·Y_j + lobes)·B_k(λ), clamped at 0, is the decoder's value at every stored
    // incidence of every golden file whose value is its records': the maps show exactly what
    // the file stores. (A factor model's or warped tables' file has empty records; its value is
    // the model's, which the plot of `plot_draws_every_golden_file_as_png` draws.)
    let mut checked = 0;
    for f in &golden() {
        let dec = sbrdf::Decoder::open(sample(f)).unwrap();
        let m = dec.material();
        if m.factor.is_some() || m.warped.is_some() {
            continue;
        }
        checked += 1;
        let wl: Vec<f64> = m.wavelengths.iter().map(|&w| w as f64).collect();
        let mut b = vec![0.0; m.spectral.terms];
        for rec in &m.records {
            let sh = sbrdf::model::sh::ShBasis::new(rec.sh_level);
            let p = sh.count();
            let mut y = vec![0.0; p];
            let inc = (rec.theta_i as f64, rec.phi_i as f64);
            let wi = sbrdf::model::angles::dir_from_deg(inc.0, inc.1);
            for t in (1..90).step_by(7) {
                for ph in (0..360).step_by(13) {
                    let o = (t as f64, ph as f64);
                    let wo = sbrdf::model::angles::dir_from_deg(o.0, o.1);
                    sh.eval(wo, &mut y);
                    let c: Vec<f64> = (0..rec.terms)
                        .map(|k| {
                            (0..p).map(|j| rec.sh[k * p + j] as f64 * y[j]).sum::<f64>()
                                + sbrdf::report::plot::lobes_value(rec, k, wi, wo)
                        })
                        .collect();
                    let mut got = vec![0.0; wl.len()];
                    dec.eval_deg(inc, o, &wl, &mut got);
                    for (w, &l) in wl.iter().enumerate() {
                        m.spectral.eval(l, &mut b);
                        let mine = (0..rec.terms).map(|k| c[k] * b[k]).sum::<f64>().max(0.0);
                        assert!(
                            (mine - got[w]).abs() <= 1e-9 * got[w].abs().max(1e-3),
                            "{f} at {inc:?}, {o:?}, {l} nm: {mine} vs decoder {}",
                            got[w]
                        );
                    }
                }
            }
        }
    }
    // Every golden file but the factor-model and warped-table ones (krylon_shared_v11,
    // rgl_paper_warp_v14, rgl_satin_warp_v15, rgl_satin64_warp_v15, rgl_satin_dct_warp_v16,
    // rgl_satin_warp_v16, rgl_paper_qbasis_v16, rgl_ibiza_pred_v17), and the sample.
    assert_eq!(checked, golden().len() - 8, "record files checked");
}

#[test]
fn plot_refuses_bad_input_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let file = sample("samples/golden/phong_3inc_paper.sbrdf");
    let run = |extra: &[&str]| {
        let mut args = vec!["plot"];
        args.extend_from_slice(extra);
        sbrdf(&args, dir.path())
    };
    assert_refused(
        &run(&[&file, "--incident", "30,0", "-o", "p.jpg"]),
        "must end in .png or .svg",
    );
    assert_refused(
        &run(&["missing.sbrdf", "--incident", "30,0", "-o", "p.png"]),
        "missing.sbrdf: no such file",
    );
    assert_refused(
        &run(&[&file, "--incident", "95,0", "-o", "p.png"]),
        "θ must lie in [0, 90]",
    );
    assert_refused(
        &run(&[&file, "--incident", "30", "-o", "p.png"]),
        "expected θ,φ in degrees",
    );
    assert_refused(
        &run(&[
            &file,
            "--incident",
            "30,0",
            "--outgoing",
            "120,0",
            "-o",
            "p.png",
        ]),
        "--outgoing (120, 0)",
    );
    assert_refused(
        &run(&[
            &file,
            "--incident",
            "30,0",
            "--coefficient",
            "13",
            "-o",
            "p.png",
        ]),
        "has 13 spectral terms",
    );
    assert_refused(
        &run(&[
            &file,
            "--reference",
            &sample("samples/golden/tiny.csv"),
            "--incident",
            "60,0",
            "-o",
            "p.png",
        ]),
        "the reference has no samples at the plotted record's incidence (60°, 0°)",
    );
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// Rec. 709 luma of the pixel at (x, y), sRGB-encoded values.
fn luma(img: &image::RgbImage, x: u32, y: u32) -> f64 {
    let p = img.get_pixel(x, y).0;
    0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64
}

#[test]
fn preview_is_a_lit_sphere_brightest_at_the_highlight() {
    let dir = tempfile::tempdir().unwrap();
    for f in [
        "samples/golden/phong_3inc_paper.sbrdf",
        "samples/golden/ggx_3inc_default.sbrdf",
        "samples/ggx_slices.sbrdf",
    ] {
        let o = sbrdf(
            &["preview", &sample(f), "-o", "s.png", "--size", "160"],
            dir.path(),
        );
        assert_ok(&o);
        let bytes = std::fs::read(dir.path().join("s.png")).unwrap();
        assert_eq!(png_size(&bytes), (160, 160));
        let img = image::load_from_memory(&bytes).unwrap().to_rgb8();
        // Dark background in the corners.
        assert!(luma(&img, 0, 0) < 60.0 && luma(&img, 159, 159) < 60.0);
        // The default light (45°, 135°): the half vector of light and camera is where the
        // highlight sits; compare it with the lit rim.
        let l = sbrdf::model::angles::dir_from_deg(45.0, 135.0);
        let h = sbrdf::model::angles::normalize([l[0], l[1], l[2] + 1.0]).unwrap();
        let px = |v: f64| ((v * 0.9 + 1.0) / 2.0 * 160.0) as u32;
        let (hx, hy) = (px(h[0]), px(-h[1]));
        let mut highlight: f64 = 0.0;
        for dy in 0..5 {
            for dx in 0..5 {
                highlight = highlight.max(luma(&img, hx + dx - 2, hy + dy - 2));
            }
        }
        let (mut rim, mut n) = (0.0, 0);
        for y in 0..160 {
            for x in 0..160 {
                let u = (x as f64 + 0.5) / 80.0 - 1.0;
                let v = 1.0 - (y as f64 + 0.5) / 80.0;
                let r = (u * u + v * v).sqrt() / 0.9;
                if (0.9..0.96).contains(&r) && luma(&img, x, y) > 20.0 {
                    rim += luma(&img, x, y);
                    n += 1;
                }
            }
        }
        assert!(n > 50, "{f}: no lit rim");
        let rim = rim / n as f64;
        assert!(
            highlight > 1.3 * rim,
            "{f}: highlight {highlight:.0} vs rim {rim:.0}"
        );
        assert!(highlight > 150.0, "{f}: highlight {highlight:.0} is dim");
    }
}

#[test]
fn preview_refuses_bad_input_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let file = sample("samples/golden/tiny.sbrdf");
    let run = |extra: &[&str]| {
        let mut args = vec!["preview"];
        args.extend_from_slice(extra);
        sbrdf(&args, dir.path())
    };
    assert_refused(&run(&[&file, "-o", "s.svg"]), "name it .png");
    assert_refused(&run(&[&file, "-o", "s.gif"]), "must end in .png or .svg");
    assert_refused(
        &run(&["nope.sbrdf", "-o", "s.png"]),
        "nope.sbrdf: no such file",
    );
    assert_refused(
        &run(&[&file, "-o", "s.png", "--light", "100,0"]),
        "θ must lie in [0, 90]",
    );
    assert_refused(&run(&[&file, "-o", "s.png", "--size", "8"]), "--size 8");
    assert_refused(
        &run(&[&file, "-o", "no/such/folder/s.png"]),
        "does not exist",
    );
    // Not an sbrdf file.
    std::fs::write(dir.path().join("junk.sbrdf"), b"hello").unwrap();
    assert_refused(&run(&["junk.sbrdf", "-o", "s.png"]), "junk.sbrdf");
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| n != "junk.sbrdf")
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn paper_figures_quick_writes_data_plots_and_table() {
    let dir = tempfile::tempdir().unwrap();
    // How long --quick takes is not a test's business (timing belongs in benches).
    let o = sbrdf(&["paper-figures", "out", "--quick"], dir.path());
    assert_ok(&o);
    let out = dir.path().join("out");
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert_eq!(String::from_utf8_lossy(&o.stdout), table);
    for row in [
        "**Fig. 4**",
        "| ks/kd | n | direct SH, L = 4 (the paper's Fig. 4) | paper mode, L = 1 | default mode |",
        "| 15 | 200 |",
        "| all 2 materials | worst / mean |",
        "**Fig. 6**",
        "**Fig. 7**",
        "| (a) (15°, 180°), the peak | 0.048 |",
        "| (b) (15°, 135°) | 0.025 |",
        "| (c) (15°, 90°) | 0.028 |",
        "| (d) (15°, 0°) | 0.03 |",
    ] {
        assert!(table.contains(row), "table lacks '{row}':\n{table}");
    }
    // The Fig. 7 material (ks/kd = 15, n = 15): direct SH ≈ 0.17–0.18 (the paper's Fig. 4),
    // paper mode ≈ 0.084 at γ ≈ 35° (its Fig. 6), the default within its 0.5% budget.
    let row = table
        .lines()
        .find(|l| l.starts_with("| 15 | 15 |"))
        .unwrap();
    let cells: Vec<f64> = row
        .split('|')
        .skip(3)
        .filter_map(|c| c.split_whitespace().next()?.parse().ok())
        .collect();
    assert!((0.14..0.2).contains(&cells[0]), "{row}");
    assert!((0.07..0.1).contains(&cells[1]), "{row}");
    assert!(cells[2] < 0.005, "{row}");
    for (name, labels) in [
        (
            "fig4.svg",
            &["Phong exponent n", "relative error", "ks/kd = 15"][..],
        ),
        ("fig6.svg", &["critical angle γ (degrees)", "n = 200"][..]),
        (
            "fig7.svg",
            &["wavelength (nm)", "paper mode, error", "original samples"][..],
        ),
    ] {
        let svg = std::fs::read_to_string(out.join(name)).unwrap();
        assert_svg(&svg, labels);
    }
    let csv = std::fs::read_to_string(out.join("fig7.csv")).unwrap();
    assert!(csv.starts_with("theta_o,phi_o,wavelength_nm,original,paper_mode,default_mode\n"));
    assert_eq!(csv.lines().count(), 1 + 4 * 31);
    let csv = std::fs::read_to_string(out.join("fig4.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2);
    let csv = std::fs::read_to_string(out.join("fig6.csv")).unwrap();
    assert!(csv.lines().count() > 10);
}

#[test]
fn paper_figures_refuses_a_file_or_a_missing_parent() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("afile"), b"x").unwrap();
    let o = sbrdf(&["paper-figures", "afile", "--quick"], dir.path());
    assert_refused(&o, "is a file");
    let o = sbrdf(&["paper-figures", "no/such/dir", "--quick"], dir.path());
    assert_refused(&o, "no/such/dir");
}
