//! Smaller files derived from an existing one, without the original samples: fewer incident
//! directions, a narrower wavelength range, fewer spectral terms, a lower SH level, f16 storage.
//!
//! Every cut is a truncation except one re-tabulation, and none re-fits (there are no samples
//! to fit): records beyond `incident_max` are dropped; wavelengths outside the range are dropped
//! and a tabulated basis loses those nodes (exact inside the range), while an analytic basis
//! (Fourier, cosine) becomes a tabulated one sampled at the kept wavelengths (exact at them,
//! linear between); spectral terms and SH functions beyond the new counts are dropped (a
//! truncated orthogonal series is still a valid series, and for an orthonormal basis the best one
//! of its size in the least-squares sense); f16 rounds. The cost is measured against the original
//! file at its stored sample positions (or a 5° grid) and combined with each record's recorded
//! error into an upper bound on the new error (triangle inequality; see the comments in
//! `subset`), which the new file records.

use crate::decode::decoder::Decoder;
use crate::error::{Error, Result};
use crate::model::basis_storage::BasisStorage;
use crate::model::material::{DirectionSet, IncidentRecord, Material};
use crate::model::sh::sh_count;
use crate::model::spectral::{BasisTable, SpectralBasis};
use crate::model::Precision;

/// What to keep. `None` keeps everything of that kind.
#[derive(Debug, Clone, Default)]
pub struct SubsetOptions {
    /// Keep wavelengths in [min, max] nm.
    pub wavelengths: Option<(f64, f64)>,
    /// Keep incident directions with θi ≤ this, degrees.
    pub incident_max: Option<f64>,
    /// Keep at most this many spectral terms.
    pub terms: Option<usize>,
    /// Keep SH functions up to this level.
    pub sh_level: Option<usize>,
    /// `Some(F16)`: store records (and a tabulated basis) in f16. `Some(F32)` changes nothing
    /// (a subset never widens storage).
    pub precision: Option<Precision>,
}

/// What one record became.
#[derive(Debug, Clone)]
pub struct RecordChange {
    /// The record's incident polar angle θi, degrees.
    pub theta_i: f32,
    /// The record's incident azimuth φi, degrees.
    pub phi_i: f32,
    /// The error the original file records for this incidence.
    pub recorded: f64,
    /// Relative L2 change of the reconstruction caused by the cuts, at the measuring positions.
    pub change: f64,
    /// The upper bound on the error now stored (rounded up to f32): the recorded error plus the
    /// change, widened where the cuts leave the recorded figure less informative (see
    /// `subset`).
    pub bound: f32,
}

/// What [`subset`] did: the cuts made and what each kept record became.
#[derive(Debug, Clone)]
pub struct SubsetReport {
    /// One line per cut made, saying whether it truncates or re-tabulates.
    pub actions: Vec<String>,
    /// One entry per kept record, in file order.
    pub records: Vec<RecordChange>,
    /// Whether the change was measured at the file's stored sample positions (else a 5° grid).
    pub at_stored_positions: bool,
}

/// Derives the smaller material and reports what each cut cost.
pub fn subset(original: &Material, o: &SubsetOptions) -> Result<(Material, SubsetReport)> {
    let mut m = original.clone();
    let mut actions = Vec::new();
    // Which original record each kept record is (for measuring).
    let mut kept: Vec<usize> = (0..m.records.len()).collect();

    if let Some(max) = o.incident_max {
        if !(max.is_finite() && (0.0..=90.0).contains(&max)) {
            return Err(Error::Parameter(format!(
                "--incident-max {max} is outside 0..=90 degrees"
            )));
        }
        kept.retain(|&i| original.records[i].theta_i as f64 <= max);
        if kept.is_empty() {
            return Err(Error::Parameter(format!(
                "--incident-max {max}: no stored incident direction has θi ≤ {max}° (the \
                 smallest is {}°)",
                original
                    .records
                    .iter()
                    .map(|r| r.theta_i)
                    .fold(f32::INFINITY, f32::min)
            )));
        }
        let dropped = m.records.len() - kept.len();
        m.records = kept.iter().map(|&i| original.records[i].clone()).collect();
        if let Some(w) = &mut m.warped {
            // Warped tables: each kept (viewing) incidence keeps its K steps and K tables.
            let (k, rr) = (m.spectral.terms, w.grid * w.grid);
            w.steps = kept
                .iter()
                .flat_map(|&i| w.steps[i * k..(i + 1) * k].to_vec())
                .collect();
            w.levels = kept
                .iter()
                .flat_map(|&i| w.levels[i * k * rr..(i + 1) * k * rr].to_vec())
                .collect();
            // The kept incidences are the first ones (θi increases), so a predicted incidence
            // keeps the one it is predicted from.
            if !w.predicted.is_empty() {
                if kept.iter().enumerate().any(|(j, &i)| i != j) {
                    return Err(Error::Input(
                        "warped tables predicted across incidences whose θi do not increase".into(),
                    ));
                }
                w.predicted.truncate(kept.len());
            }
        }
        if let Some(sp) = &mut m.sample_positions {
            let used: Vec<u32> = kept.iter().map(|&i| sp.set_of_incidence[i]).collect();
            let mut sets = Vec::new();
            let mut remap = std::collections::BTreeMap::new();
            for &s in &used {
                remap.entry(s).or_insert_with(|| {
                    sets.push(sp.sets[s as usize].clone());
                    (sets.len() - 1) as u32
                });
            }
            sp.set_of_incidence = used.iter().map(|s| remap[s]).collect();
            sp.sets = sets;
        }
        actions.push(format!(
            "incident directions: kept {} with θi ≤ {max}°, dropped {dropped} (truncation: \
             queries above {max}° now use the last kept incidence)",
            kept.len()
        ));
    }

    if let Some((lo, hi)) = o.wavelengths {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(Error::Parameter(format!(
                "--wavelengths {lo}:{hi}: expected MIN:MAX with MIN ≤ MAX"
            )));
        }
        let idx: Vec<usize> = (0..m.wavelengths.len())
            .filter(|&w| (lo..=hi).contains(&(m.wavelengths[w] as f64)))
            .collect();
        if idx.is_empty() {
            return Err(Error::Parameter(format!(
                "--wavelengths {lo}:{hi} keeps none of the file's wavelengths ({}–{} nm)",
                m.wavelengths[0],
                m.wavelengths[m.wavelengths.len() - 1]
            )));
        }
        let k = m.spectral.terms;
        let nodes: Vec<f64> = idx.iter().map(|&w| m.wavelengths[w] as f64).collect();
        let how = match m.spectral.basis {
            SpectralBasis::Tabulated => {
                let t = m.spectral.table.as_ref().expect("validated");
                let w_all = t.nodes.len();
                let values = (0..k)
                    .flat_map(|kk| idx.iter().map(move |&w| (kk, w)))
                    .map(|(kk, w)| t.values[kk * w_all + w])
                    .collect();
                m.spectral.table = Some(BasisTable {
                    nodes: nodes.clone(),
                    values,
                    storage: t.storage.clone(),
                });
                "the tabulated basis keeps those nodes (exact inside the range)"
            }
            SpectralBasis::PeriodicFourier | SpectralBasis::Cosine => {
                let mut values = vec![0.0; k * nodes.len()];
                let mut b = vec![0.0; k];
                for (w, &l) in nodes.iter().enumerate() {
                    m.spectral.eval(l, &mut b);
                    for kk in 0..k {
                        values[kk * nodes.len() + w] = b[kk] as f32 as f64;
                    }
                }
                m.spectral.basis = SpectralBasis::Tabulated;
                m.spectral.table = Some(BasisTable {
                    nodes: nodes.clone(),
                    values,
                    storage: BasisStorage::Float(Precision::F32),
                });
                "the analytic basis is re-tabulated at the kept wavelengths (exact there, \
                 linear between them)"
            }
        };
        m.spectral.lambda_min = nodes[0];
        m.spectral.lambda_max = nodes[nodes.len() - 1];
        if nodes.len() == 1 && m.spectral.terms > 1 {
            // One node: only a constant is left to represent; the validator needs K = 1.
            truncate_terms(&mut m, 1);
        }
        m.wavelengths = nodes.iter().map(|&l| l as f32).collect();
        actions.push(format!(
            "wavelengths: kept {} in {lo}–{hi} nm; {how}",
            idx.len()
        ));
    }

    if let Some(t) = o.terms {
        if t == 0 {
            return Err(Error::Parameter("--terms must be at least 1".into()));
        }
        if t < m.spectral.terms {
            let from = m.spectral.terms;
            truncate_terms(&mut m, t);
            actions.push(format!(
                "spectral terms: {from} → {t} (truncation of the series; the data-derived and \
                 cosine bases are orthogonal, so the kept terms are unchanged)"
            ));
        }
    }

    if let Some(l) = o.sh_level {
        if l < m.sh_level {
            let from = m.sh_level;
            for r in &mut m.records {
                if r.sh_level > l {
                    let (p_old, p_new) = (sh_count(r.sh_level), sh_count(l));
                    r.sh = (0..r.terms)
                        .flat_map(|kk| r.sh[kk * p_old..kk * p_old + p_new].to_vec())
                        .collect();
                    r.sh_level = l;
                }
            }
            m.sh_level = l;
            actions.push(format!(
                "SH level: {from} → {l} (truncation of each record's expansion)"
            ));
        }
    }

    if o.precision == Some(Precision::F16) {
        for r in &mut m.records {
            if r.precision != Precision::F16 {
                crate::format::quantize_record_f16(r);
            }
        }
        if let Some(t) = &mut m.spectral.table {
            if t.storage != BasisStorage::Float(Precision::F16) {
                t.values
                    .iter_mut()
                    .for_each(|v| *v = half::f16::from_f64(*v).to_f64());
                t.storage = BasisStorage::Float(Precision::F16);
            }
        }
        actions.push("precision: f16 (rounding, with a power-of-two scale per record)".into());
    }

    // Measure what the cuts cost, record by record, against the original reconstruction.
    let before = Decoder::from_material(original.clone())?;
    let after = Decoder::from_material(m.clone())
        .map_err(|e| Error::Parameter(format!("the subset is not a valid file: {e}")))?;
    let wl: Vec<f64> = m.wavelengths.iter().map(|&w| w as f64).collect();
    let wl_all: Vec<f64> = original.wavelengths.iter().map(|&w| w as f64).collect();
    let cut_wavelengths = wl.len() != wl_all.len();
    let grid = DirectionSet::Grid {
        theta0: 2.5,
        dtheta: 5.0,
        ntheta: 18,
        phi0: 2.5,
        dphi: 5.0,
        nphi: 72,
    };
    let at_stored_positions = original.sample_positions.is_some();
    let mut records = Vec::new();
    let (mut a, mut b) = (vec![0.0; wl.len()], vec![0.0; wl.len()]);
    let mut full = vec![0.0; wl_all.len()];
    for (new_i, &old_i) in kept.iter().enumerate() {
        let r = &original.records[old_i];
        let dirs = match &original.sample_positions {
            Some(sp) => sp.sets[sp.set_of_incidence[old_i] as usize].directions(),
            None => grid.directions(),
        };
        let inc = (r.theta_i as f64, r.phi_i as f64);
        // Warped tables are stored per viewing direction: the stored incidence is the query's
        // outgoing one there, the grid the light's.
        let warped = original.warped.is_some();
        let pair = |d: &[f64; 2]| {
            if warped {
                ((d[0], d[1]), inc)
            } else {
                (inc, (d[0], d[1]))
            }
        };
        // D = |new − old| and Rs = |old| at the kept wavelengths, R = |old| at all of them.
        let (mut d2, mut rs2, mut r2) = (0.0, 0.0, 0.0);
        for d in &dirs {
            let (qi, qo) = pair(d);
            before.eval_deg(qi, qo, &wl, &mut a);
            after.eval_deg(qi, qo, &wl, &mut b);
            for (x, y) in a.iter().zip(&b) {
                d2 += (x - y) * (x - y);
                rs2 += x * x;
            }
            before.eval_deg(qi, qo, &wl_all, &mut full);
            r2 += full.iter().map(|v| v * v).sum::<f64>();
        }
        let (d, rs, rr) = (d2.sqrt(), rs2.sqrt(), r2.sqrt());
        let e = r.rel_error as f64;
        let change = if rs > 0.0 {
            d / rs
        } else if d > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        // With ρ the unknown samples, ρ̂ the original reconstruction and e = |ρ − ρ̂|/|ρ| as
        // recorded: |ρ| ≥ R/(1 + e), so without a wavelength cut the new error is at most
        // e + D(1 + e)/R. With a cut, the recorded error may sit anywhere in the spectrum:
        // |ρ − ρ̂| ≤ eR/(1 − e) and |ρ_kept| ≥ Rs − eR/(1 − e), hence the second form.
        let sum = if d == 0.0 && !cut_wavelengths {
            e
        } else if !cut_wavelengths {
            if rr > 0.0 {
                e + d * (1.0 + e) / rr
            } else {
                f64::INFINITY
            }
        } else if e < 1.0 {
            let err = e * rr / (1.0 - e);
            let floor = rs - err;
            if floor > 0.0 {
                (err + d) / floor
            } else {
                f64::INFINITY
            }
        } else {
            f64::INFINITY
        };
        let mut bound = sum as f32;
        if (bound as f64) < sum {
            bound = f32::from_bits(bound.to_bits() + 1); // round up: a bound must not shrink
        }
        if !bound.is_finite() {
            bound = f32::MAX;
        }
        // A warped file's implied records hold no error (FORMAT.md §3.10: rel_error +0); its
        // bound is reported only, against the original reconstruction (e = 0 there).
        if !warped {
            m.records[new_i].rel_error = bound;
        }
        records.push(RecordChange {
            theta_i: r.theta_i,
            phi_i: r.phi_i,
            recorded: e,
            change,
            bound,
        });
    }
    m.validate()
        .map_err(|e| Error::Parameter(format!("the subset is not a valid file: {e}")))?;
    Ok((
        m,
        SubsetReport {
            actions,
            records,
            at_stored_positions,
        },
    ))
}

/// Keeps the first `t` spectral terms of the file and of every record.
fn truncate_terms(m: &mut Material, t: usize) {
    if let Some(table) = &mut m.spectral.table {
        table.values.truncate(t * table.nodes.len());
    }
    let k = m.spectral.terms;
    if let Some(w) = &mut m.warped {
        // Warped tables: each incidence keeps its first t steps and tables (incidence-major).
        let (n, rr) = (m.records.len(), w.grid * w.grid);
        w.steps = (0..n)
            .flat_map(|i| w.steps[i * k..i * k + t].to_vec())
            .collect();
        w.levels = (0..n)
            .flat_map(|i| w.levels[i * k * rr..(i * k + t) * rr].to_vec())
            .collect();
    }
    m.spectral.terms = t;
    for r in &mut m.records {
        truncate_record_terms(r, t);
    }
}

fn truncate_record_terms(r: &mut IncidentRecord, t: usize) {
    if r.terms <= t {
        return;
    }
    let p = sh_count(r.sh_level);
    r.sh.truncate(t * p);
    let old = r.terms;
    for l in &mut r.lobes {
        let variants = l.amplitude.len() / old;
        l.amplitude = (0..variants)
            .flat_map(|j| l.amplitude[j * old..j * old + t].to_vec())
            .collect();
        if l.kind == crate::model::material::LobeKind::AngleGaussian {
            l.params.truncate(t); // one width per term
        }
    }
    r.terms = t;
}
