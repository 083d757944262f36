//! A quantised tabulated basis (`SBAS` precision 3, format 1.6, `spec/FORMAT.md` §3.2): one
//! power-of-two step per basis function, then every function's integers along the wavelengths,
//! each predicted linearly from the two before it in its row and the residual range-coded as
//! the warped payload codes its NDF (§3.10). A basis row is a smooth spectrum, so its second
//! differences are small: 3 functions of 41 wavelengths take about 70–110 bytes here against
//! 246 in `f16`.

use super::fields::Fields;
use super::range_coder::{RangeDecoder, RangeEncoder};
use super::warp_payload::{ndf_prediction, why, Side};
use crate::error::Result;
use crate::model::basis_storage::{BasisStorage, QUANTISED_EXPONENTS, QUANTISED_LIMIT};

/// Integers a stream may claim per byte of it before the reader allocates for them (each adaptive
/// binary decision costs more than 1/190 bit, as for the warped payload, §8).
const INTEGERS_PER_BYTE: usize = 1600;

/// The chunk data after the precision byte and its 3 reserved bytes: K exponents, then the
/// stream. `values` are the K rows of W values, each exactly 2^e_k times an integer (the caller
/// validated the material).
pub(super) fn quantised_data(values: &[f64], exponents: &[i8], w: usize) -> Vec<u8> {
    let mut out: Vec<u8> = exponents.iter().map(|&e| e as u8).collect();
    let mut enc = RangeEncoder::new();
    let mut side = Side::new();
    for (row, &e) in values.chunks(w.max(1)).zip(exponents) {
        let n: Vec<i64> = row
            .iter()
            .map(|&v| (v / 2f64.powi(e as i32)) as i64)
            .collect();
        for j in 0..n.len() {
            side.put(&mut enc, n[j] - ndf_prediction(&n, j));
        }
    }
    out.extend_from_slice(&enc.finish());
    out
}

/// Reads the rest of a quantised `SBAS` chunk of `k` functions at `w` wavelengths.
pub(super) fn read_quantised(
    f: &mut Fields,
    k: usize,
    w: usize,
) -> Result<(Vec<f64>, BasisStorage)> {
    let mut exponents = Vec::with_capacity(k.min(f.remaining()));
    for _ in 0..k {
        let e = f.u8("exponent")? as i8;
        if !QUANTISED_EXPONENTS.contains(&(e as i32)) {
            return Err(f.malformed(format!(
                "basis exponent {e} outside [{}, {}]",
                QUANTISED_EXPONENTS.start(),
                QUANTISED_EXPONENTS.end()
            )));
        }
        exponents.push(e);
    }
    let stream = f.take(f.remaining(), "basis stream")?;
    let count = k * w;
    if count > INTEGERS_PER_BYTE * stream.len() {
        return Err(f.malformed(format!(
            "{k} functions × {w} wavelengths cannot be coded in {} bytes",
            stream.len()
        )));
    }
    let mut dec = RangeDecoder::new(stream).map_err(|e| f.malformed(why(e)))?;
    let mut side = Side::new();
    let mut values = Vec::with_capacity(count);
    let mut row = Vec::with_capacity(w);
    for (kk, &e) in exponents.iter().enumerate() {
        row.clear();
        for j in 0..w {
            let n = side.get(&mut dec).map_err(|m| f.malformed(m))? + ndf_prediction(&row, j);
            if n.abs() >= QUANTISED_LIMIT {
                return Err(f.malformed(format!(
                    "basis function {kk}'s integer {j} is {n}, beyond ±(2²⁴ − 1)"
                )));
            }
            row.push(n);
            values.push(n as f64 * 2f64.powi(e as i32));
        }
    }
    if dec.consumed() != stream.len() {
        return Err(f.malformed(format!(
            "{} bytes after the basis stream's last integer",
            stream.len() - dec.consumed()
        )));
    }
    Ok((values, BasisStorage::Quantised { exponents }))
}
