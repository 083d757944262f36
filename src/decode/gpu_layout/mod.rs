//! The flat device layout (`spec/GPU_LAYOUT.md`): a material as one buffer of 32-bit words
//! (f32 and u32, offsets instead of pointers) that a shader evaluates with bounded loops. Built
//! from the decoder's resident form, so it holds exactly the values the decoder evaluates.

pub(crate) mod factor;
pub(crate) mod pack;
pub(crate) mod sampling;
pub(crate) mod warped;
pub(crate) mod words;

use super::records::resident::{Rec, Resident};
use crate::error::{Error, Result};
use crate::format::f16_scale;
use crate::model::sh::sh_count;
use crate::model::Precision;
use half::f16;
use words::codes::{
    ENCODING_F16_PAIRS, ENCODING_F32, INCIDENCE_ISOTROPIC, INCIDENCE_LATTICE, INCIDENCE_SCATTERED,
};
use words::{codes, header, lobe, record};

/// `SBGL` read as a little-endian u32: the first word of every layout.
pub const GPU_LAYOUT_MAGIC: u32 = codes::MAGIC;
/// The version of `spec/GPU_LAYOUT.md` this module writes.
pub const GPU_LAYOUT_VERSION: u32 = 4;

/// The header, wavelengths, basis table, stored incidences and record table of a resident
/// material (its sections are appended by the caller).
pub(crate) fn gpu_layout(res: &Resident) -> Result<Vec<u32>> {
    let thetas = distinct_sorted(res.recs.iter().map(|r| r.theta_i));
    let phis = distinct_sorted(res.recs.iter().map(|r| r.phi_i));
    // `spec/EVALUATION.md`, "The lattice of stored incidences".
    let incidence_layout: u32 = if res.isotropic {
        INCIDENCE_ISOTROPIC
    } else if thetas.len() * phis.len() == res.recs.len() {
        INCIDENCE_LATTICE
    } else {
        INCIDENCE_SCATTERED
    };
    let table = res.spectrum.table();
    let k = res.spectral.terms;
    let w = res.wavelengths.len();

    let mut out = vec![0u32; header::WORDS];
    let off_waves = out.len();
    out.extend(res.wavelengths.iter().map(|v| v.to_bits()));
    let off_table = match &table {
        Some(t) => {
            let at = out.len();
            // Validated: the table's values are the file's f32 or f16 numbers, exact in f32.
            out.extend(t.values.iter().map(|&v| (v as f32).to_bits()));
            at
        }
        None => 0,
    };
    let off_thetas = out.len();
    out.extend(thetas.iter().map(|v| v.to_bits()));
    let off_phis = out.len();
    out.extend(phis.iter().map(|v| v.to_bits()));
    let off_records = out.len();
    out.resize(off_records + record::WORDS * res.recs.len(), 0);
    for (ri, r) in res.recs.iter().enumerate() {
        let at = off_records + record::WORDS * ri;
        let (encoding, scale) = record_encoding(res, r);
        let p = sh_count(r.level as usize);
        let t = r.terms as usize;
        let off_sh = out.len();
        push_values(
            &mut out,
            &res.vals[r.sh as usize..r.sh as usize + t * p],
            encoding,
            scale,
        );
        let off_lobes = out.len();
        out.resize(off_lobes + lobe::WORDS * r.nlobes as usize, 0);
        for li in 0..r.nlobes as usize {
            let l = res.lobe(r, li);
            let na = l.kind.amplitude_count(t);
            let off_amp = out.len();
            push_values(
                &mut out,
                &res.vals[l.amp as usize..l.amp as usize + na],
                encoding,
                scale,
            );
            let off_par = out.len();
            out.extend(res.params(r, l).iter().map(|v| v.to_bits()));
            let e = &mut out[off_lobes + lobe::WORDS * li..][..lobe::WORDS];
            e[lobe::KIND] = l.kind.code() as u32;
            e[lobe::OFF_AMPLITUDES] = word(off_amp)?;
            e[lobe::OFF_PARAMETERS] = word(off_par)?;
        }
        let e = &mut out[at..at + record::WORDS];
        e[record::THETA_I] = r.theta_i.to_bits();
        e[record::PHI_I] = r.phi_i.to_bits();
        e[record::THETA_P] = r.theta_p.to_bits();
        e[record::PHI_P] = r.phi_p.to_bits();
        e[record::LEVEL] = r.level as u32;
        e[record::TERMS] = r.terms as u32;
        e[record::LOBES] = r.nlobes as u32;
        e[record::ENCODING] = encoding;
        e[record::SCALE] = scale.to_bits();
        e[record::OFF_SH] = word(off_sh)?;
        e[record::OFF_LOBES] = word(off_lobes)?;
        e[record::RESERVED] = 0;
    }
    let total = word(out.len())?;
    let h = &mut out[..header::WORDS];
    h[header::MAGIC] = GPU_LAYOUT_MAGIC;
    h[header::VERSION] = GPU_LAYOUT_VERSION;
    h[header::TOTAL] = total;
    h[header::INCIDENCE] = incidence_layout;
    h[header::BASIS] = res.spectral.basis.code() as u32;
    h[header::TERMS] = word(k)?;
    h[header::SH_LEVEL] = word(res.sh_level)?;
    h[header::WAVES] = word(w)?;
    h[header::RECORDS] = word(res.recs.len())?;
    h[header::THETAS] = word(thetas.len())?;
    h[header::PHIS] = word(phis.len())?;
    h[header::LAMBDA_MIN] = (res.spectral.lambda_min as f32).to_bits();
    h[header::LAMBDA_MAX] = (res.spectral.lambda_max as f32).to_bits();
    h[header::OFF_WAVES] = word(off_waves)?;
    h[header::OFF_BASIS_TABLE] = word(off_table)?;
    h[header::OFF_THETAS] = word(off_thetas)?;
    h[header::OFF_PHIS] = word(off_phis)?;
    h[header::OFF_RECORDS] = word(off_records)?;
    // The sampling and model sections are appended after (sampling.rs, factor.rs).
    h[header::OFF_SAMPLING] = 0;
    h[header::OFF_MODEL] = 0;
    Ok(out)
}

/// An offset or count as a u32 word; a layout past 2³² words cannot be addressed.
pub(super) fn word(v: usize) -> Result<u32> {
    u32::try_from(v).map_err(|_| {
        Error::LimitsExceeded("gpu layout: more than 2^32 words cannot be addressed".into())
    })
}

/// The distinct values, increasing: the stored θi or φi that step 4 of `spec/EVALUATION.md`
/// brackets the query between (the format forbids −0 angles, so `total_cmp` merges equal ones).
fn distinct_sorted(values: impl Iterator<Item = f32>) -> Vec<f32> {
    let mut v: Vec<f32> = values.collect();
    v.sort_by(f32::total_cmp);
    v.dedup();
    v
}

/// A record's encoding and scale: f16 pairs when it was stored as f16 and every value is
/// exactly a binary16 times the scale the writer would choose (then the layout keeps the file's
/// two bytes per value), else one f32 per word (same values, twice the words).
fn record_encoding(res: &Resident, r: &Rec) -> (u32, f32) {
    if r.precision != Precision::F16 {
        return (ENCODING_F32, 1.0);
    }
    let t = r.terms as usize;
    let values = || {
        let sh = &res.vals[r.sh as usize..r.sh as usize + t * sh_count(r.level as usize)];
        let lobes = (0..r.nlobes as usize).flat_map(move |li| {
            let l = res.lobe(r, li);
            &res.vals[l.amp as usize..l.amp as usize + l.kind.amplitude_count(t)]
        });
        sh.iter().chain(lobes).copied()
    };
    let scale = f16_scale(values());
    let exact = values().all(|v| f16::from_f32(v / scale).to_f32() * scale == v);
    if exact {
        (ENCODING_F16_PAIRS, scale)
    } else {
        (ENCODING_F32, 1.0)
    }
}

/// Appends values in an encoding, starting on a word boundary.
pub(super) fn push_values(out: &mut Vec<u32>, values: &[f32], encoding: u32, scale: f32) {
    if encoding == ENCODING_F32 {
        out.extend(values.iter().map(|v| v.to_bits()));
        return;
    }
    for pair in values.chunks(2) {
        let half_bits = |v: f32| f16::from_f32(v / scale).to_bits() as u32;
        let low = half_bits(pair[0]);
        let high = pair.get(1).map_or(0, |&v| half_bits(v));
        out.push(low | (high << 16));
    }
}
