//! How a file stores a tabulated spectral basis (`spec/FORMAT.md` §3.2): IEEE values, or (1.6)
//! integers on a power-of-two grid per function. The values themselves are in
//! [`super::spectral::BasisTable`].

/// How a file stores a tabulated basis (`spec/FORMAT.md` §3.2).
#[derive(Debug, Clone, PartialEq)]
pub enum BasisStorage {
    /// Each value as an IEEE number of this precision (`SBAS` precision 1 or 2).
    Float(crate::model::Precision),
    /// Row k as integers times 2^`exponents[k]`, range-coded along the wavelengths (`SBAS`
    /// precision 3, format 1.6): a smooth row costs a few bits per value instead of 16, and
    /// every value is exact in `f32`. The warped-table encoder fits its tables to the basis so
    /// stored, so the coarser grid costs the measured values nothing.
    Quantised {
        /// One power-of-two step per basis function, in [−128, 103].
        exponents: Vec<i8>,
    },
}

impl BasisStorage {
    /// Whether `v` is exactly a value of row `k` in this storage.
    pub fn holds(&self, k: usize, v: f64) -> bool {
        match self {
            BasisStorage::Float(crate::model::Precision::F32) => (v as f32) as f64 == v,
            BasisStorage::Float(crate::model::Precision::F16) => {
                half::f16::from_f64(v).to_f64() == v
            }
            BasisStorage::Quantised { exponents } => exponents.get(k).is_some_and(|&e| {
                let n = v / 2f64.powi(e as i32);
                n.fract() == 0.0 && n.abs() < QUANTISED_LIMIT as f64
            }),
        }
    }

    /// Heap bytes held (the decoder reports its resident size).
    pub fn heap_bytes(&self) -> usize {
        match self {
            BasisStorage::Float(_) => 0,
            BasisStorage::Quantised { exponents } => exponents.capacity(),
        }
    }

    /// What the storage is, as reports name it: `"f32"`, `"f16"` or `"quantised"`.
    pub fn name(&self) -> &'static str {
        match self {
            BasisStorage::Float(p) => p.name(),
            BasisStorage::Quantised { .. } => "quantised",
        }
    }
}

/// The integers of a quantised basis stay below 2^24 in magnitude, so that each value
/// (an integer times a power of two) is exact in `f32`.
pub const QUANTISED_LIMIT: i64 = 1 << 24;
/// The range of a quantised basis row's exponent: 2^e·n is an `f32` number (normal or
/// subnormal) for every |n| < 2^24 exactly when e is in this range.
pub const QUANTISED_EXPONENTS: std::ops::RangeInclusive<i32> = -128..=103;
