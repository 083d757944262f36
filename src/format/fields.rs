//! The cursor every chunk reader reads its fields with ([`Fields`]: little-endian, bounded by the
//! chunk's data, errors located by file offset and chunk), and what `HEAD` says ([`Head`]), which
//! the other chunks' readers need.

use crate::error::{Error, Location, Result};
use crate::model::spectral::SpectralSpace;
use crate::model::Precision;
use half::f16;

/// Reads little-endian fields from one chunk's data, reporting file offsets in errors.
pub(super) struct Fields<'a> {
    data: &'a [u8],
    pos: usize,
    /// File offset of data[0].
    base: u64,
    chunk: [u8; 4],
}

impl<'a> Fields<'a> {
    /// The fields of chunk `chunk`, whose data `data` starts at file offset `base`.
    pub(super) fn new(data: &'a [u8], base: u64, chunk: [u8; 4]) -> Self {
        Fields {
            data,
            pos: 0,
            base,
            chunk,
        }
    }
    pub(super) fn at(&self) -> Location {
        Location {
            offset: self.base + self.pos as u64,
            chunk: Some(self.chunk),
        }
    }
    pub(super) fn malformed(&self, message: impl Into<String>) -> Error {
        Error::Format {
            at: self.at(),
            message: message.into(),
        }
    }
    pub(super) fn unsupported(&self, message: impl Into<String>) -> Error {
        Error::Unsupported {
            at: self.at(),
            message: message.into(),
        }
    }
    pub(super) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if self.data.len() - self.pos < n {
            return Err(self.malformed(format!(
                "chunk ends before its field '{what}' ({} bytes left, {n} needed)",
                self.data.len() - self.pos
            )));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    pub(super) fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }
    pub(super) fn u8(&mut self, what: &str) -> Result<u8> {
        Ok(self.take(1, what)?[0])
    }
    pub(super) fn u16(&mut self, what: &str) -> Result<u16> {
        Ok(u16::from_le_bytes(self.take(2, what)?.try_into().unwrap()))
    }
    pub(super) fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
    pub(super) fn f32(&mut self, what: &str) -> Result<f32> {
        Ok(f32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
    pub(super) fn f64(&mut self, what: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    pub(super) fn stored(&mut self, precision: Precision, scale: f32, what: &str) -> Result<f32> {
        Ok(match precision {
            Precision::F32 => self.f32(what)?,
            Precision::F16 => {
                f16::from_le_bytes(self.take(2, what)?.try_into().unwrap()).to_f32() * scale
            }
        })
    }
    pub(super) fn zero(&mut self, n: usize, what: &str) -> Result<()> {
        let at = self.at();
        if self.take(n, what)?.iter().any(|&b| b != 0) {
            return Err(Error::Format {
                at,
                message: format!("reserved field '{what}' is not zero"),
            });
        }
        Ok(())
    }
    pub(super) fn finish(&self) -> Result<()> {
        if self.remaining() != 0 {
            return Err(self.malformed(format!(
                "{} unexpected bytes at the end of the chunk",
                self.remaining()
            )));
        }
        Ok(())
    }
}

/// What `HEAD` says, as the other chunks' readers need it.
pub(super) struct Head {
    pub(super) spectral: SpectralSpace,
    pub(super) sh_level: usize,
    pub(super) isotropic: bool,
    pub(super) minor: u16,
    pub(super) wavelengths: Vec<f32>,
    pub(super) incidences: Vec<[f32; 2]>,
}
