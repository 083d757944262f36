//! The decoder's benchmark materials and the baseline it is measured against, shared by
//! `benches/decode.rs` and `examples/decode_cost.rs` (included with `#[path]`).

use sbrdf::encode::encoder::{encode, EncodeOptions};
use sbrdf::encode::samples::SampleSet;
use sbrdf::io::synth::{paper_grid, sample_material, Ggx, Phong};
use sbrdf::Decoder;

/// The raw-table baseline: values[inc][iθ][iφ][w] on a 5° grid (θo = 2.5…87.5°, φo = 0…355°).
pub struct RawTable {
    pub thetas: Vec<f64>,
    pub wavelengths: Vec<f32>,
    /// Some(1/step) for evenly spaced wavelengths; otherwise the bracket is searched.
    inv_step: Option<f32>,
    pub values: Vec<f32>,
}

const NT: usize = 18;
const NP: usize = 72;

impl RawTable {
    pub fn new(thetas: Vec<f64>, wavelengths: Vec<f32>, values: Vec<f32>) -> Self {
        let h = wavelengths.get(1).map_or(1.0, |w| w - wavelengths[0]);
        let even = wavelengths.windows(2).all(|p| p[1] - p[0] == h);
        RawTable {
            thetas,
            inv_step: even.then_some(1.0 / h),
            wavelengths,
            values,
        }
    }

    fn from_samples(set: &SampleSet) -> Self {
        let mut values = Vec::new();
        for s in &set.incidences {
            assert_eq!(s.directions.len(), NT * NP);
            values.extend(s.values.iter().map(|&v| v as f32));
        }
        RawTable::new(
            set.incidences.iter().map(|s| s.theta_i).collect(),
            set.wavelengths.iter().map(|&w| w as f32).collect(),
            values,
        )
    }

    /// A material given by its decoder, resampled on the grid at the file's incidences and
    /// wavelengths (for a measurement whose directions are scattered).
    fn resampled(dec: &Decoder) -> Self {
        let m = dec.material();
        let wl64: Vec<f64> = m.wavelengths.iter().map(|&w| w as f64).collect();
        let mut values = Vec::new();
        let mut out = vec![0.0; wl64.len()];
        for r in &m.records {
            for d in paper_grid(5.0, 5.0) {
                dec.eval_deg((r.theta_i as f64, 0.0), (d[0], d[1]), &wl64, &mut out);
                values.extend(out.iter().map(|&v| v as f32));
            }
        }
        RawTable::new(
            m.records.iter().map(|r| r.theta_i as f64).collect(),
            m.wavelengths.clone(),
            values,
        )
    }

    pub fn eval(&self, wi: [f32; 3], wo: [f32; 3], wl: &[f32], out: &mut [f32]) {
        let ti = wi[2].clamp(-1.0, 1.0).acos().to_degrees() as f64;
        let inc = self
            .thetas
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - ti).abs().total_cmp(&(b.1 - ti).abs()))
            .unwrap()
            .0;
        // Rotate wo so the incident azimuth is 0 (isotropic), then grid coordinates.
        let phi_i = wi[1].atan2(wi[0]);
        let phi_o = wo[1].atan2(wo[0]) - phi_i;
        let to = wo[2].clamp(-1.0, 1.0).acos().to_degrees();
        let po = phi_o.to_degrees().rem_euclid(360.0);
        let ft = ((to - 2.5) / 5.0).clamp(0.0, (NT - 1) as f32);
        let it = (ft as usize).min(NT - 2);
        let t = ft - it as f32;
        let fp = po / 5.0;
        let ip = (fp as usize) % NP;
        let u = fp - fp.floor();
        let ip1 = (ip + 1) % NP;
        let nw = self.wavelengths.len();
        let base = inc * NT * NP * nw;
        let at = |a: usize, b: usize, w: usize| self.values[base + (a * NP + b) * nw + w];
        for (o, &l) in out.iter_mut().zip(wl) {
            let (iw, s) = match self.inv_step {
                Some(inv) => {
                    let fw = ((l - self.wavelengths[0]) * inv).clamp(0.0, (nw - 1) as f32);
                    let iw = (fw as usize).min(nw - 2);
                    (iw, fw - iw as f32)
                }
                None => {
                    let iw = self
                        .wavelengths
                        .partition_point(|&x| x <= l)
                        .clamp(1, nw - 1)
                        - 1;
                    let (a, b) = (self.wavelengths[iw], self.wavelengths[iw + 1]);
                    (iw, ((l - a) / (b - a)).clamp(0.0, 1.0))
                }
            };
            let bil = |w: usize| {
                (1.0 - t) * ((1.0 - u) * at(it, ip, w) + u * at(it, ip1, w))
                    + t * ((1.0 - u) * at(it + 1, ip, w) + u * at(it + 1, ip1, w))
            };
            *o = (1.0 - s) * bil(iw) + s * bil(iw + 1);
        }
    }
}

/// (name, decoder, file bytes, table, the wavelength counts to time).
pub type Bench = (&'static str, Decoder, Vec<u8>, RawTable, Vec<usize>);

/// The benchmark materials: Phong (9 incidences), GGX (7), NIST PTFE and an RGL warped file.
pub fn materials() -> Vec<Bench> {
    NAMES.iter().filter_map(|n| material(n)).collect()
}

/// The materials' names, in the benchmark's order.
pub const NAMES: [&str; 4] = ["phong9", "ggx7", "ptfe6", "rgl_paper"];

/// One benchmark material by name (None for a name not in [`NAMES`]).
pub fn material(name: &str) -> Option<Bench> {
    let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
    let grid = paper_grid(5.0, 5.0);
    let synthetic = |set: SampleSet| {
        let enc = encode(&set, &EncodeOptions::default()).unwrap();
        let bytes = sbrdf::write_material(&enc.material).unwrap();
        let dec = Decoder::from_bytes(&bytes).unwrap();
        (dec, bytes, RawTable::from_samples(&set), vec![1, 4, 31])
    };
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let (dec, bytes, table, counts) = match name {
        "phong9" => {
            let phong = Phong::colorchecker("green", "white", (1.0, 15.0, 50.0), &wl).unwrap();
            let nine: Vec<(f64, f64)> = (0..9).map(|i| (10.0 * i as f64, 0.0)).collect();
            synthetic(sample_material(&wl, &nine, &grid, |i, o, w| {
                phong.value(i, o, w)
            }))
        }
        "ggx7" => {
            let ggx = Ggx::colorchecker(0.2, 1.0, "blue", "yellow", &wl).unwrap();
            let seven: Vec<(f64, f64)> = (0..7).map(|i| (12.0 * i as f64, 0.0)).collect();
            synthetic(sample_material(&wl, &seven, &grid, |i, o, w| {
                ggx.value(i, o, w)
            }))
        }
        "ptfe6" => {
            let nist = root.join("tests/data/nist_ptfe_fr11.csv");
            let (set, _) = sbrdf::io::csv::read_samples(&[nist]).unwrap();
            let enc = encode(&set, &EncodeOptions::default()).unwrap();
            let bytes = sbrdf::write_material(&enc.material).unwrap();
            let dec = Decoder::from_bytes(&bytes).unwrap();
            let table = RawTable::resampled(&dec);
            (dec, bytes, table, vec![1, 4])
        }
        "rgl_paper" => {
            // An RGL measurement as warped tables (format 1.4, the golden file), against a
            // table of its own values on the 5° grid at its stored incidences.
            let bytes =
                std::fs::read(root.join("samples/golden/rgl_paper_warp_v14.sbrdf")).unwrap();
            let dec = Decoder::from_bytes(&bytes).unwrap();
            let table = RawTable::resampled(&dec);
            (dec, bytes, table, vec![1, 4, 41])
        }
        _ => return None,
    };
    let name = NAMES.into_iter().find(|n| *n == name)?;
    Some((name, dec, bytes, table, counts))
}
