//! The flat device layout (`spec/GPU_LAYOUT.md`): a material as one buffer of 32-bit words
//! (f32 and u32, offsets instead of pointers) that a shader evaluates with bounded loops. Built
//! from the decoder's resident form, so it holds exactly the values the decoder evaluates.

use super::resident::{Rec, Resident};
use crate::error::{Error, Result};
use crate::format::f16_scale;
use crate::model::sh::sh_count;
use crate::model::Precision;
use half::f16;

/// `SBGL` read as a little-endian u32: the first word of every layout.
pub const GPU_LAYOUT_MAGIC: u32 = u32::from_le_bytes(*b"SBGL");
/// The version of `spec/GPU_LAYOUT.md` this module writes.
pub const GPU_LAYOUT_VERSION: u32 = 4;
/// Words in the header.
const HEADER_WORDS: usize = 20;
/// Words in a record table entry.
const RECORD_WORDS: usize = 12;
/// Words in a lobe table entry.
const LOBE_WORDS: usize = 3;

/// Value encodings of a record (`spec/GPU_LAYOUT.md`, "Value encodings").
pub(super) const ENCODING_F32: u32 = 1;
pub(super) const ENCODING_F16_PAIRS: u32 = 2;

/// The header, wavelengths, basis table, stored incidences and record table of a resident
/// material (its sections are appended by the caller).
pub(crate) fn gpu_layout(res: &Resident) -> Result<Vec<u32>> {
    let thetas = distinct_sorted(res.recs.iter().map(|r| r.theta_i));
    let phis = distinct_sorted(res.recs.iter().map(|r| r.phi_i));
    // `spec/EVALUATION.md`, "The lattice of stored incidences".
    let incidence_layout: u32 = if res.isotropic {
        0
    } else if thetas.len() * phis.len() == res.recs.len() {
        1
    } else {
        2
    };
    let table = res.spectrum.table();
    let k = res.spectral.terms;
    let w = res.wavelengths.len();

    let mut out = vec![0u32; HEADER_WORDS];
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
    out.resize(off_records + RECORD_WORDS * res.recs.len(), 0);
    for (ri, r) in res.recs.iter().enumerate() {
        let at = off_records + RECORD_WORDS * ri;
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
        out.resize(off_lobes + LOBE_WORDS * r.nlobes as usize, 0);
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
            let e = off_lobes + LOBE_WORDS * li;
            out[e] = l.kind.code() as u32;
            out[e + 1] = word(off_amp)?;
            out[e + 2] = word(off_par)?;
        }
        let entry = [
            r.theta_i.to_bits(),
            r.phi_i.to_bits(),
            r.theta_p.to_bits(),
            r.phi_p.to_bits(),
            r.level as u32,
            r.terms as u32,
            r.nlobes as u32,
            encoding,
            scale.to_bits(),
            word(off_sh)?,
            word(off_lobes)?,
            0,
        ];
        out[at..at + RECORD_WORDS].copy_from_slice(&entry);
    }
    let header = [
        GPU_LAYOUT_MAGIC,
        GPU_LAYOUT_VERSION,
        word(out.len())?,
        incidence_layout,
        res.spectral.basis.code() as u32,
        word(k)?,
        word(res.sh_level)?,
        word(w)?,
        word(res.recs.len())?,
        word(thetas.len())?,
        word(phis.len())?,
        (res.spectral.lambda_min as f32).to_bits(),
        (res.spectral.lambda_max as f32).to_bits(),
        word(off_waves)?,
        word(off_table)?,
        word(off_thetas)?,
        word(off_phis)?,
        word(off_records)?,
        0,
        0,
    ];
    out[..HEADER_WORDS].copy_from_slice(&header);
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
