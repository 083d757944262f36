//! Storage precision of coefficients and amplitudes: f32, or f16 under a power-of-two scale.

/// How SH coefficients and lobe amplitudes are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Precision {
    /// IEEE binary32, stored as is.
    F32,
    /// IEEE binary16 after division by the record's power-of-two scale.
    F16,
}

impl Precision {
    /// The precision's code in the file: 1 for f32, 2 for f16.
    pub fn code(self) -> u8 {
        match self {
            Precision::F32 => 1,
            Precision::F16 => 2,
        }
    }
    /// The precision with this file code; None for an unknown code.
    pub fn from_code(c: u8) -> Option<Self> {
        match c {
            1 => Some(Precision::F32),
            2 => Some(Precision::F16),
            _ => None,
        }
    }
    /// Bytes per stored value: 4 or 2.
    pub fn bytes(self) -> usize {
        match self {
            Precision::F32 => 4,
            Precision::F16 => 2,
        }
    }
    /// `"f32"` or `"f16"`, as the command line and reports spell it.
    pub fn name(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F16 => "f16",
        }
    }
}
