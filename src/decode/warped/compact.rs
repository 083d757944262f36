//! The compact form of warped tables: the GPU layout's warped-tables section
//! (`spec/GPU_LAYOUT.md`, "Warped tables section"), which the CPU decoder also evaluates, so
//! that one representation serves a renderer on either side.
//!
//! Each table is packed with the resolution the file stores it at: codes of B bits on a grid of
//! step q/32 from the table's least value (q the table's quantisation step in the file), so a
//! packed value is within q/64 of the decoded one (the file's own quantisation leaves errors
//! of about q/3.5 per node). The RGL measurements need 5–10 bits a value on average instead of
//! 64 (`tests/memory.rs`). The VNDF keeps G columns and, per incidence, G rows of two words
//! (`super::vndf`); everything else is f32.

use super::source::{averaged, values_density, Dims, ExactTables, Incidence, ValuesRow};
use super::source::{TableView, VndfRow, WarpSource};
use super::vndf::Column;
use crate::decode::gpu_layout::words::{
    codes, warped, warped_column, warped_incidence, warped_table, warped_values,
};
use crate::error::{Error, Result};

// Word offsets and sizes are the layout's one definition (`crate::decode::gpu_layout::words`): the
// section's header (`warped`), a stored incidence (6 words: θ, sin θ, cos θ, 1/I, the values'
// 1/total and floor), a VNDF column (5: f, sin θm, cos θm, U, V), a VNDF row (1 word: the
// positive run in the low WARP_POSITIVE_BITS bits, the marginal above in 23-bit fixed point), a
// table entry (4: offset of its codes, bits, lo, step) and a values row (total, marginal, the
// marks' conditional integrals).
/// Words per VNDF row.
const VNDF_ROW_WORDS: usize = 1;
const POSITIVE_BITS: u32 = codes::WARP_POSITIVE_BITS;
/// The packing step is the file's quantisation step divided by this.
pub(crate) const STEP_DIVISOR: f32 = 256.0;
/// Most bits per code: beyond, the step grows to span the table in 2²⁴ − 1 steps (an f32 holds
/// every code exactly).
pub(crate) const MAX_BITS: u32 = 24;

/// A warped-table material in its compact form: the section's words.
#[derive(Debug, Clone)]
pub(crate) struct CompactTables {
    words: Vec<u32>,
    dims: Dims,
    /// Each table's entry (offset, bits, least value, step) read from the words once: a query
    /// reads 2K of them (the section keeps them too, for a shader).
    entries: Vec<(usize, u32, f64, f64)>,
    /// The header's offsets, read once.
    incidences: usize,
    ndf: usize,
    sigma: usize,
    columns: usize,
    row_cosines: usize,
    vndf_rows: usize,
    values_rows: usize,
    basis_means: usize,
}

/// A table's packing: codes of `bits` bits at word `offset`, value = lo + code·step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Packing {
    pub bits: u32,
    pub lo: f32,
    pub step: f32,
}

impl Packing {
    /// The packing of a table whose values are `values` and whose quantisation step in the
    /// file is `q`. Fails when a value lies beyond the `f32` range (only a hostile file's steps
    /// and integers reach there): the packing's least value and step are `f32`.
    pub(crate) fn of(values: &[f64], q: f32) -> Result<Self> {
        let (min, max) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
        let single = f32::MAX as f64;
        if min < -single || max > single {
            return Err(Error::LimitsExceeded(format!(
                "warped tables: a table's values reach {}, beyond single precision (±{single:e}), \
                 which the decoder's packed tables hold",
                if max > single { max } else { min }
            )));
        }
        if !(min.is_finite() && max.is_finite()) || max <= min {
            let lo = if min.is_finite() { min as f32 } else { 0.0 };
            return Ok(Packing {
                bits: 0,
                lo,
                step: 0.0,
            });
        }
        // The least value rounded down to f32, so that every code is ≥ 0.
        let mut lo = min as f32;
        if lo as f64 > min {
            lo = lo.next_down();
        }
        let span = max - lo as f64;
        let mut step = q / STEP_DIVISOR;
        let codes = |step: f32| (span / step as f64 + 0.5).floor() + 1.0;
        if step.is_nan() || step <= 0.0 || codes(step) > (1u64 << MAX_BITS) as f64 {
            // The span in 2²⁴ − 1 steps, the step rounded up.
            step = (span / ((1u64 << MAX_BITS) - 1) as f64) as f32;
            while codes(step) > (1u64 << MAX_BITS) as f64 {
                step = step.next_up();
            }
        }
        // At least one code: the span is finite and below 2·f32::MAX here.
        let count = (codes(step) as u64).max(1);
        let bits = 64 - (count - 1).leading_zeros();
        Ok(Packing { bits, lo, step })
    }

    /// The code of value v.
    fn code(&self, v: f64) -> u32 {
        if self.bits == 0 {
            return 0;
        }
        let c = ((v - self.lo as f64) / self.step as f64).round();
        c.clamp(0.0, ((1u64 << self.bits) - 1) as f64) as u32
    }

    /// Words that `count` codes take.
    fn words(&self, count: usize) -> usize {
        (count * self.bits as usize).div_ceil(32)
    }
}

/// One fixed-point step of a VNDF row's marginal, 2⁻²³.
const MARG_UNIT: f64 = 1.0 / (1u32 << (32 - POSITIVE_BITS)) as f64;

/// A VNDF row's first word: its marginal (in [0, 1], 23-bit fixed point, rounded and kept
/// below 1) over its positive run.
fn pack_marg(marg: f64, positive: usize) -> u32 {
    let max = (1u32 << (32 - POSITIVE_BITS)) - 1;
    let q = (marg / MARG_UNIT).round().clamp(0.0, max as f64) as u32;
    (q << POSITIVE_BITS) | positive as u32
}

/// Code j of `bits` bits in `words` starting at word `at` (LSB first).
#[inline(always)]
pub(crate) fn unpack(words: &[u32], at: usize, bits: u32, j: usize) -> u32 {
    if bits == 0 {
        return 0;
    }
    let bit = j * bits as usize;
    let w = at + bit / 32;
    let [lo, hi]: [u32; 2] = words[w..w + 2].try_into().expect("two words");
    let pair = lo as u64 | (hi as u64) << 32;
    ((pair >> (bit % 32)) & ((1u64 << bits) - 1)) as u32
}

impl CompactTables {
    /// The compact form of an exact material; `steps` are the file's quantisation steps q(i, k)
    /// at i·K + k. Errors only for a section past 2³² words.
    pub(crate) fn new(exact: &ExactTables, steps: &[f32]) -> Result<Self> {
        let d = exact.dims;
        let rr = d.r * d.r;
        let mut out = vec![0u32; warped::WORDS];
        let f = |v: f64| (v as f32).to_bits();
        let mut header = [0u32; warped::WORDS];
        header[warped::KIND] = codes::MODEL_WARPED;
        for (at, v) in [
            (warped::N, d.n),
            (warped::K, d.k),
            (warped::R, d.r),
            (warped::G, d.g),
            (warped::M, d.m),
        ] {
            header[at] = word(v)?;
        }
        header[warped::OFF_INCIDENCES] = word(out.len())?;
        // The values' scale and floor are the packed tables' own (filled in below).
        let incidences_at = out.len();
        for inc in &exact.incidences {
            out.extend([
                f(inc.theta),
                f(inc.sin),
                f(inc.cos),
                f(inc.vndf_scale),
                0,
                0,
            ]);
        }
        header[warped::OFF_NDF] = word(out.len())?;
        out.extend(exact.ndf.iter().map(|v| v.to_bits()));
        header[warped::OFF_SIGMA] = word(out.len())?;
        out.extend(exact.sigma.iter().map(|&v| f(v)));
        header[warped::OFF_COLUMNS] = word(out.len())?;
        for c in &exact.columns {
            out.extend([f(c.f), f(c.sin), f(c.cos), f(c.u), f(c.v)]);
        }
        header[warped::OFF_ROW_COSINES] = word(out.len())?;
        out.extend(exact.cos_phi.iter().map(|&v| f(v)));
        header[warped::OFF_VNDF_ROWS] = word(out.len())?;
        for r in &exact.vndf_rows {
            out.push(pack_marg(r.marg, r.positive));
        }
        header[warped::OFF_BASIS_MEANS] = word(out.len())?;
        out.extend(exact.basis_means.iter().map(|&v| f(v)));
        header[warped::OFF_VALUES_ROWS] = word(out.len())?;
        let values_at = out.len();
        out.resize(values_at + warped_values::WORDS * d.n * d.r, 0);
        header[warped::OFF_TABLES] = word(out.len())?;
        let entries = out.len();
        out.resize(entries + warped_table::WORDS * d.n * d.k, 0);
        for t in 0..d.n * d.k {
            let values = &exact.tables[t * rr..(t + 1) * rr];
            let p = Packing::of(values, steps[t])?;
            let at = out.len();
            out.resize(at + p.words(rr), 0);
            for (j, &v) in values.iter().enumerate().filter(|_| p.bits > 0) {
                let code = p.code(v) as u64;
                let bit = j * p.bits as usize;
                let w = at + bit / 32;
                let shifted = code << (bit % 32);
                out[w] |= shifted as u32;
                if (shifted >> 32) != 0 {
                    out[w + 1] |= (shifted >> 32) as u32;
                }
            }
            out[entries + warped_table::WORDS * t..entries + warped_table::WORDS * (t + 1)]
                .copy_from_slice(&[word(at)?, p.bits, p.lo.to_bits(), p.step.to_bits()]);
        }
        // One word past the last code, so that a read of two words never leaves the section.
        out.push(0);
        out.shrink_to_fit();
        out[..warped::WORDS].copy_from_slice(&header);
        let mut compact = CompactTables::read(out)?;
        // The values' density from the packed tables and the section's f32 basis means, so
        // that sampling draws from and reports the density of the numbers it reads.
        for i in 0..d.n {
            let slice: Vec<f64> = (0..d.k * rr)
                .map(|j| compact.table(i * d.k + j / rr).at(j % rr))
                .collect();
            let means: Vec<f64> = (0..d.k).map(|k| compact.basis_mean(k)).collect();
            let (scale, floor, rows) =
                values_density(d.r, |node| averaged(&slice, rr, &means, node)).ok_or_else(
                    || Error::Parameter("warped tables: a slice's values sum to zero".into()),
                )?;
            let w = &mut compact.words;
            w[incidences_at + warped_incidence::WORDS * i + warped_incidence::VALUES_SCALE] =
                f(scale);
            w[incidences_at + warped_incidence::WORDS * i + warped_incidence::VALUES_FLOOR] =
                f(floor);
            for (b, row) in rows.iter().enumerate() {
                let at = values_at + warped_values::WORDS * (i * d.r + b);
                w[at + warped_values::TOTAL] = f(row.total);
                w[at + warped_values::MARG] = f(row.marg);
                for (j, m) in row.marks.iter().enumerate() {
                    w[at + warped_values::MARKS + j] = f(*m);
                }
            }
        }
        Ok(compact)
    }

    /// Takes a section's words (as [`CompactTables::new`] wrote them).
    fn read(words: Vec<u32>) -> Result<Self> {
        let h = |i: usize| words[i] as usize;
        let dims = Dims {
            n: h(warped::N),
            k: h(warped::K),
            r: h(warped::R),
            g: h(warped::G),
            m: h(warped::M),
        };
        let tables = h(warped::OFF_TABLES);
        let entries = (0..dims.n * dims.k)
            .map(|t| {
                let e = tables + warped_table::WORDS * t;
                let f = |i: usize| f32::from_bits(words[i]) as f64;
                (
                    words[e + warped_table::OFF_CODES] as usize,
                    words[e + warped_table::BITS],
                    f(e + warped_table::LO),
                    f(e + warped_table::STEP),
                )
            })
            .collect();
        Ok(CompactTables {
            dims,
            entries,
            incidences: h(warped::OFF_INCIDENCES),
            ndf: h(warped::OFF_NDF),
            sigma: h(warped::OFF_SIGMA),
            columns: h(warped::OFF_COLUMNS),
            row_cosines: h(warped::OFF_ROW_COSINES),
            vndf_rows: h(warped::OFF_VNDF_ROWS),
            values_rows: h(warped::OFF_VALUES_ROWS),
            basis_means: h(warped::OFF_BASIS_MEANS),
            words,
        })
    }

    /// The section's words.
    pub(crate) fn words(&self) -> &[u32] {
        &self.words
    }

    pub(crate) fn heap_bytes(&self) -> usize {
        4 * self.words.capacity()
            + std::mem::size_of::<(usize, u32, f64, f64)>() * self.entries.capacity()
    }

    /// Table t's packing, as its entry in the words says.
    #[cfg(test)]
    pub(crate) fn packing(&self, t: usize) -> Packing {
        let e = self.words[warped::OFF_TABLES] as usize + warped_table::WORDS * t;
        Packing {
            bits: self.words[e + 1],
            lo: f32::from_bits(self.words[e + 2]),
            step: f32::from_bits(self.words[e + 3]),
        }
    }

    #[inline(always)]
    fn f(&self, at: usize) -> f64 {
        f32::from_bits(self.words[at]) as f64
    }

    /// `N` words from `at` as f64 (one bounds check).
    #[inline(always)]
    fn fs<const N: usize>(&self, at: usize) -> [f64; N] {
        let w: &[u32; N] = self.words[at..at + N].try_into().expect("N words");
        w.map(|v| f32::from_bits(v) as f64)
    }
}

/// An offset or count as a u32 word.
fn word(v: usize) -> Result<u32> {
    u32::try_from(v).map_err(|_| {
        Error::LimitsExceeded("gpu layout: more than 2^32 words cannot be addressed".into())
    })
}

/// A packed table: codes of `bits` bits from word `at`, value = lo + code·step.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PackedTable<'a> {
    words: &'a [u32],
    at: usize,
    bits: u32,
    lo: f64,
    step: f64,
}

impl TableView for PackedTable<'_> {
    #[inline(always)]
    fn at(&self, node: usize) -> f64 {
        self.lo + unpack(self.words, self.at, self.bits, node) as f64 * self.step
    }

    /// Two neighbouring codes from one read of two words when they fit (up to 16 bits each).
    #[inline(always)]
    fn pair(&self, j: usize) -> (f64, f64) {
        if self.bits > 16 || self.bits == 0 {
            return (self.at(j), self.at(j + 1));
        }
        let bit = j * self.bits as usize;
        let w = self.at + bit / 32;
        let [lo, hi]: [u32; 2] = self.words[w..w + 2].try_into().expect("two words");
        let pair = (lo as u64 | (hi as u64) << 32) >> (bit % 32);
        let mask = (1u64 << self.bits) - 1;
        let (c0, c1) = (pair & mask, (pair >> self.bits) & mask);
        (
            self.lo + c0 as f64 * self.step,
            self.lo + c1 as f64 * self.step,
        )
    }
}

impl WarpSource for CompactTables {
    type Table<'a> = PackedTable<'a>;
    #[inline(always)]
    fn dims(&self) -> Dims {
        self.dims
    }
    #[inline(always)]
    fn theta(&self, i: usize) -> f64 {
        self.f(self.incidences + warped_incidence::WORDS * i)
    }
    #[inline(always)]
    fn incidence(&self, i: usize) -> Incidence {
        let [theta, sin, cos, vndf_scale, values_scale, values_floor] =
            self.fs::<{ warped_incidence::WORDS }>(self.incidences + warped_incidence::WORDS * i);
        Incidence {
            theta,
            sin,
            cos,
            vndf_scale,
            values_scale,
            values_floor,
        }
    }
    #[inline(always)]
    fn ndf(&self, j: usize) -> f64 {
        self.f(self.ndf + j)
    }
    #[inline(always)]
    fn sigma(&self, j: usize) -> f64 {
        self.f(self.sigma + j)
    }
    #[inline(always)]
    fn column(&self, a: usize) -> Column {
        let [f, sin, cos, u, v] =
            self.fs::<{ warped_column::WORDS }>(self.columns + warped_column::WORDS * a);
        Column { f, sin, cos, u, v }
    }
    #[inline(always)]
    fn cos_phi(&self, b: usize) -> f64 {
        self.f(self.row_cosines + b)
    }
    #[inline(always)]
    fn vndf_row(&self, i: usize, b: usize) -> VndfRow {
        let first = self.words[self.vndf_rows + VNDF_ROW_WORDS * (i * self.dims.g + b)];
        VndfRow {
            marg: (first >> POSITIVE_BITS) as f64 * MARG_UNIT,
            positive: (first & ((1 << POSITIVE_BITS) - 1)) as usize,
        }
    }
    #[inline(always)]
    fn table(&self, t: usize) -> PackedTable<'_> {
        let (at, bits, lo, step) = self.entries[t];
        PackedTable {
            words: &self.words,
            at,
            bits,
            lo,
            step,
        }
    }
    #[inline(always)]
    fn values_row(&self, i: usize, b: usize) -> ValuesRow {
        let [total, marg, m1, m2, m3] = self.fs::<{ warped_values::WORDS }>(
            self.values_rows + warped_values::WORDS * (i * self.dims.r + b),
        );
        ValuesRow {
            total,
            marg,
            marks: [m1, m2, m3],
        }
    }
    #[inline(always)]
    fn basis_mean(&self, k: usize) -> f64 {
        self.f(self.basis_means + k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::{read_material, Limits};

    /// The golden files with warped tables, their exact and compact forms.
    fn golden() -> Vec<(String, ExactTables, CompactTables, Vec<f32>)> {
        [
            "rgl_paper_warp_v14.sbrdf",
            "rgl_satin_warp_v15.sbrdf",
            "rgl_satin64_warp_v15.sbrdf",
        ]
        .iter()
        .map(|f| {
            let path = format!("{}/samples/golden/{f}", env!("CARGO_MANIFEST_DIR"));
            let m = read_material(&std::fs::read(&path).unwrap(), &Limits::default()).unwrap();
            let w = m.warped.as_ref().unwrap();
            let thetas: Vec<f32> = m.records.iter().map(|r| r.theta_i).collect();
            let res = crate::decode::records::resident::Resident::new(&m);
            let exact = ExactTables::new(w, &thetas, m.spectral.terms, &res.basis_means()).unwrap();
            let compact = CompactTables::new(&exact, &w.steps).unwrap();
            (f.to_string(), exact, compact, w.steps.clone())
        })
        .collect()
    }

    /// Every packed value is within half its packing step of the decoded value, and that step
    /// is the file's quantisation step over [`STEP_DIVISOR`] (no table here needs the cap).
    #[test]
    fn packed_tables_are_within_half_a_packing_step() {
        for (name, exact, compact, steps) in golden() {
            let d = exact.dims;
            let rr = d.r * d.r;
            for (t, &q) in steps.iter().enumerate().take(d.n * d.k) {
                let p = compact.packing(t);
                let worst = (0..rr)
                    .map(|j| (compact.table(t).at(j) - exact.table(t).at(j)).abs())
                    .fold(0.0, f64::max);
                assert!(p.bits <= MAX_BITS, "{name} table {t}: {p:?}");
                if p.bits > 0 {
                    assert_eq!(p.step, q / STEP_DIVISOR, "{name} table {t}");
                }
                assert!(
                    worst <= 0.5 * p.step as f64 * (1.0 + 1e-6) + 1e-12,
                    "{name} table {t}: {worst} for step {} ({} bits)",
                    p.step,
                    p.bits
                );
            }
        }
    }
}
