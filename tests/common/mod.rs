#![allow(dead_code)]
//! Shared helpers: the paper's test materials, built from the shipped ColorChecker spectra.

pub mod examples;

/// The `sbrdf validate` commands of `docs/guide/measured.md` (the README shows the first), as
/// written: `tests/measured.rs` runs each (with `--json`) and holds the figures the guide
/// states, so `tests/doc_commands.rs` leaves them to it instead of encoding them a second time
/// (each is a minute of encodes).
pub const MEASURED_COMMANDS: [&str; 2] = [
    "sbrdf validate tests/data/cornell/acryl_blue.astm --leave-incidence-out",
    "sbrdf validate tests/data/nist_ptfe_fr11.csv --leave-out 45 --dense-grid",
];

use sbrdf::encode::encoder::{encode, EncodeOptions, Encoded};
use sbrdf::encode::samples::SampleSet;
use sbrdf::io::synth::{paper_grid, sample_material, Phong, SpectrumTable};

/// 400–700 nm every 10 nm, as in the paper.
pub fn paper_wavelengths() -> Vec<f64> {
    (0..31).map(|i| 400.0 + 10.0 * i as f64).collect()
}

/// The paper's Phong material: ColorChecker green diffuse, white specular, kd = 1.
pub fn paper_phong(ks: f64, n: f64) -> Phong {
    Phong::colorchecker("green", "white", (1.0, ks, n), &paper_wavelengths()).unwrap()
}

/// The paper's setup: θo = 2.5…87.5°, φo = 0…355° every 5°, at the given incidences.
pub fn paper_samples(ks: f64, n: f64, incidences: &[(f64, f64)]) -> SampleSet {
    let p = paper_phong(ks, n);
    sample_material(
        &paper_wavelengths(),
        incidences,
        &paper_grid(5.0, 5.0),
        |i, o, w| p.value(i, o, w),
    )
}

/// Encodes with the paper's options, changed by `f`.
pub fn encode_with(set: &SampleSet, f: impl FnOnce(&mut EncodeOptions)) -> Encoded {
    let mut o = EncodeOptions::paper();
    f(&mut o);
    encode(set, &o).expect("encode")
}

/// Encodes with the defaults (the joint fit within 0.5%), changed by `f`.
pub fn encode_default(set: &SampleSet, f: impl FnOnce(&mut EncodeOptions)) -> Encoded {
    let mut o = EncodeOptions::default();
    f(&mut o);
    encode(set, &o).expect("encode")
}

/// Relative L2 error of `approx` against `reference`.
pub fn rel_l2(approx: &[f64], reference: &[f64]) -> f64 {
    assert_eq!(approx.len(), reference.len());
    let e: f64 = approx
        .iter()
        .zip(reference)
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    let r: f64 = reference.iter().map(|b| b * b).sum();
    (e / r).sqrt()
}

pub fn samples_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("samples")
}

/// Every golden file, as `samples/golden/MANIFEST` lists them (in its order), checked complete:
/// the manifest and the folder's `.sbrdf` files are the same set, and there are at least 14.
/// What "every golden file" means in the tests.
#[allow(dead_code)] // not every test binary that includes `common` uses it
pub fn golden_files() -> Vec<String> {
    let dir = samples_dir().join("golden");
    let manifest = std::fs::read_to_string(dir.join("MANIFEST")).unwrap();
    let listed: Vec<String> = manifest
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.split(':').next().unwrap().trim().to_string())
        .collect();
    let mut present: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".sbrdf"))
        .collect();
    present.sort();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(sorted, present, "MANIFEST and samples/golden disagree");
    assert!(listed.len() >= 14, "{} golden files", listed.len());
    listed
}

/// The paper's outgoing grid at the given incidences, sampled from `f`.
pub fn sample_on_paper_grid(
    incidences: &[(f64, f64)],
    f: impl Fn((f64, f64), (f64, f64), usize) -> f64,
) -> SampleSet {
    sample_material(&paper_wavelengths(), incidences, &paper_grid(5.0, 5.0), f)
}

pub fn colorchecker(name: &str) -> Vec<f64> {
    let t = SpectrumTable::colorchecker();
    t.sample(t.find(name).unwrap(), &paper_wavelengths())
        .unwrap()
}

fn half(wi: [f64; 3], wo: [f64; 3]) -> (f64, f64) {
    let h = sbrdf::model::angles::normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]).unwrap();
    (h[2], sbrdf::model::angles::dot(wi, h))
}

/// A material outside every lobe family of the encoder: Beckmann distribution, separable
/// Smith–Beckmann shadowing (Walter et al. 2007's rational form), exact dielectric Fresnel with
/// a mildly dispersive index 1.5, Lambert base 0.5·green.
pub fn beckmann(alpha: f64) -> impl Fn((f64, f64), (f64, f64), usize) -> f64 {
    let green = colorchecker("green");
    let wl = paper_wavelengths();
    move |i, o, w| {
        let wi = sbrdf::model::angles::dir_from_deg(i.0, i.1);
        let wo = sbrdf::model::angles::dir_from_deg(o.0, o.1);
        let (ci, co) = (wi[2], wo[2]);
        let base = 0.5 * green[w] / std::f64::consts::PI;
        if ci <= 0.0 || co <= 0.0 {
            return base;
        }
        let (ch, cd) = half(wi, wo);
        let t2 = (1.0 - ch * ch) / (ch * ch);
        let d = (-t2 / (alpha * alpha)).exp() / (std::f64::consts::PI * alpha * alpha * ch.powi(4));
        let g1 = |c: f64| {
            let a = c / (alpha * (1.0 - c * c).max(1e-12).sqrt());
            if a < 1.6 {
                (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
            } else {
                1.0
            }
        };
        let eta = 1.5 * (1.0 + 0.02 * (550.0 - wl[w]) / 150.0);
        let f = sbrdf::io::synth::fresnel_dielectric(eta, cd);
        base + d * g1(ci) * g1(co) * f / (4.0 * ci * co)
    }
}

/// Two GGX layers (a clear coat α = 0.05 with F0 = 0.04 over a coloured α = 0.4 metal with F0 =
/// the 'orange yellow' patch) plus 0.3·purple Lambert: two lobes of very different widths.
pub fn two_layer() -> impl Fn((f64, f64), (f64, f64), usize) -> f64 {
    let coat = sbrdf::io::synth::Ggx {
        alpha: 0.05,
        alpha_y: 0.05,
        axis_deg: 0.0,
        kd: 0.0,
        diffuse: vec![0.0; 31],
        f0: vec![0.04; 31],
    };
    let metal = sbrdf::io::synth::Ggx {
        alpha: 0.4,
        alpha_y: 0.4,
        axis_deg: 0.0,
        kd: 0.0,
        diffuse: vec![0.0; 31],
        f0: colorchecker("orange yellow"),
    };
    let purple = colorchecker("purple");
    move |i, o, w| {
        let wi = sbrdf::model::angles::dir_from_deg(i.0, i.1);
        let wo = sbrdf::model::angles::dir_from_deg(o.0, o.1);
        coat.specular(wi, wo, coat.f0[w])
            + metal.specular(wi, wo, metal.f0[w])
            + 0.3 * purple[w] / std::f64::consts::PI
    }
}

pub fn ggx(alpha: f64) -> sbrdf::io::synth::Ggx {
    sbrdf::io::synth::Ggx::colorchecker(alpha, 1.0, "blue", "yellow", &paper_wavelengths()).unwrap()
}

/// Ten MERL materials from the ABC fits, each with its own ColorChecker diffuse colour.
pub const ABC_MATERIALS: [(&str, &str); 10] = [
    ("special-walnut-224", "dark skin"),
    ("pearl-paint", "orange"),
    ("silver-metallic-paint2", "moderate red"),
    ("black-soft-plastic", "yellow green"),
    ("violet-rubber", "blue"),
    ("pvc", "red"),
    ("alum-bronze", "yellow"),
    ("gray-plastic", "magenta"),
    ("chrome", "cyan"),
    ("specular-red-phenolic", "orange yellow"),
];

/// Runs the `sbrdf` program with `args` in the folder `dir`. (Integration tests only: the
/// program's path is known to them, not to the example that shares this module.)
#[cfg(test)]
pub fn sbrdf(args: &[&str], dir: &std::path::Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_sbrdf"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run sbrdf")
}

/// A run's standard error as text.
#[cfg(test)]
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Relative L2 error of `dec` against the material `truth` (incidence, outgoing, wavelength
/// index → value) at incidence `inc`, over the paper's 5° outgoing grid and wavelengths.
pub fn error_on_paper_grid(
    dec: &sbrdf::Decoder,
    inc: (f64, f64),
    truth: impl Fn((f64, f64), (f64, f64), usize) -> f64,
) -> f64 {
    let wl = paper_wavelengths();
    let (mut approx, mut reference) = (Vec::new(), Vec::new());
    let mut out = vec![0.0; wl.len()];
    for d in paper_grid(5.0, 5.0) {
        let o = (d[0], d[1]);
        dec.eval_deg(inc, o, &wl, &mut out);
        approx.extend_from_slice(&out);
        reference.extend((0..wl.len()).map(|w| truth(inc, o, w)));
    }
    rel_l2(&approx, &reference)
}

/// An RGL tensor file with its `rgb` field replaced by `spectra` at `wavelengths` (and a
/// `wavelengths` field), every other field kept: node p of slice s at wavelength index l gets
/// `mix(l, [R, G, B])` of that node.
pub fn rgl_spectral(
    rgb_file: &[u8],
    wavelengths: &[f32],
    mix: impl Fn(usize, [f32; 3]) -> f32,
) -> Vec<u8> {
    use sbrdf::io::rgl::{write_tensor, DType, TensorFile};
    let tf = TensorFile::parse(rgb_file).unwrap();
    let mut fields: Vec<(&str, u8, Vec<u64>, Vec<u8>)> = Vec::new();
    for f in &tf.fields {
        let code = match f.dtype {
            DType::U8 => 1,
            DType::U32 => 5,
            DType::F32 => 10,
            d => panic!("unexpected dtype {d}"),
        };
        if f.name != "rgb" {
            fields.push((f.name.as_str(), code, f.shape.clone(), tf.data(f).to_vec()));
            continue;
        }
        let (np, nt, r) = (f.shape[0], f.shape[1], f.shape[3] as usize);
        let rgb: Vec<f32> = tf
            .data(f)
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        let n = wavelengths.len();
        let mut spectra = Vec::with_capacity((np * nt) as usize * n * r * r * 4);
        for slice in 0..(np * nt) as usize {
            for l in 0..n {
                for p in 0..r * r {
                    let at = |c: usize| rgb[(slice * 3 + c) * r * r + p];
                    spectra.extend_from_slice(&mix(l, [at(0), at(1), at(2)]).to_le_bytes());
                }
            }
        }
        let wl: Vec<u8> = wavelengths.iter().flat_map(|w| w.to_le_bytes()).collect();
        fields.push(("wavelengths", 10, vec![n as u64], wl));
        fields.push((
            "spectra",
            10,
            vec![np, nt, n as u64, r as u64, r as u64],
            spectra,
        ));
    }
    write_tensor(&fields)
}

/// The anisotropic materials' lattice of incidences (`tests/anisotropic.rs`,
/// `examples/anisotropic.rs`): θi 10°, 30°, 50°, 70° × φi every 45°.
pub fn aniso_lattice() -> Vec<(f64, f64)> {
    let mut v = Vec::new();
    for t in [10.0, 30.0, 50.0, 70.0] {
        for p in 0..8 {
            v.push((t, 45.0 * p as f64));
        }
    }
    v
}

/// Incidences between the nodes of [`aniso_lattice`] (θi half-way, φi half-way, and both), up
/// to 60°: where the anisotropy table of `docs/guide/anisotropy.md` is measured.
pub fn aniso_between() -> Vec<(f64, f64)> {
    let mut v = Vec::new();
    for t in [20.0, 40.0, 60.0] {
        for p in [22.5, 112.5, 202.5, 292.5] {
            v.push((t, p));
        }
        v.push((t, 90.0));
    }
    for p in [67.5, 157.5, 247.5, 337.5] {
        v.push((30.0, p));
        v.push((50.0, p));
    }
    v
}

/// How far a measured figure may move from the value the README or the guide states for it
/// (other CPUs, compilers and small encoder changes) before a test fails.
pub const SLACK: f64 = 1.25;

/// A stated figure that may not be exceeded (an error, a size), held at [`SLACK`] times its
/// value.
pub fn held(what: &str, got: f64, stated: f64) {
    eprintln!("{what}: {got} (stated {stated})");
    assert!(
        got.is_finite() && got <= SLACK * stated,
        "{what}: {got}, stated {stated} (bound {SLACK}×)"
    );
}

/// The unit vector at polar angle θ and azimuth φ (degrees), z the normal.
pub fn unit(theta_deg: f64, phi_deg: f64) -> [f32; 3] {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    [
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    ]
}

/// Relative L2 of a decoded file's ρ·cos θ (light) against an RGL measurement's at the
/// measurement's own nodes (the RGL reader's samples, Mitsuba's evaluation), every stored
/// incidence up to [`sbrdf::io::rgl::MAX_THETA_I`] pooled, in linear sRGB. ρ·cos θ is what a
/// renderer sums (ρ alone grows as 1/cos θ toward the horizon); negative measured values
/// (noise) count as 0. The tables follow the viewing direction ("Warped tables"): the
/// measurement's incidence is the decoder's ωo.
pub fn rgl_error_at_nodes(dec: &sbrdf::Decoder, b: &sbrdf::io::rgl::RglBsdf) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for s in b.samples(sbrdf::io::rgl::MAX_THETA_I, 89.0).unwrap() {
        let viewer = unit(s.theta_i, s.phi_i);
        for (k, d) in s.directions.iter().enumerate() {
            let rgb = dec.eval_linear_srgb(unit(d[0], d[1]), viewer, Default::default());
            let c = d[0].to_radians().cos();
            for (got, want) in rgb.iter().zip(&s.values[3 * k..3 * k + 3]) {
                let (got, want) = (got * c, want.max(0.0) * c);
                num += (got - want) * (got - want);
                den += want * want;
            }
        }
    }
    (num / den).sqrt()
}
