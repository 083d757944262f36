//! Bytes: the `.sbrdf` format, versions 1.0 to 1.6 — signature, chunk types, limits; the writer and
//! the reader. Uses [`crate::model`] only.
//!
//! Normative text: `spec/FORMAT.md`. Layout: a 10-byte signature, then chunks of
//! `length: u32 | type: [u8; 4] | data | crc: u32` (CRC-32/ISO-HDLC over type and data), all
//! little-endian. A first letter in upper case marks a critical chunk, lower case an ancillary
//! one that readers may skip.

mod basis_payload;
mod consts;
mod fields;
mod range_coder;
mod read;
mod read_records;
mod warp_chunk;
mod warp_payload;
mod write;

pub use consts::{
    is_wavelength_range, range_wavelengths, Limits, ANGLE_CONVENTION, CHUNK_ENDF, CHUNK_FACT,
    CHUNK_HEAD, CHUNK_META, CHUNK_RECD, CHUNK_RECS, CHUNK_SAMP, CHUNK_SBAS, CHUNK_WARP, CHUNK_XVAL,
    FLAG_ISOTROPIC, FLAG_THETA_ONLY, FLAG_WAVELENGTH_RANGE, SBAS_QUANTISED, SIGNATURE,
    VERSION_MAJOR, VERSION_MINOR, VERSION_MINOR_ANISO, VERSION_MINOR_COMPACT, VERSION_MINOR_FACTOR,
    VERSION_MINOR_PREDICTED, VERSION_MINOR_RANGE, VERSION_MINOR_WARP, VERSION_MINOR_WAVELET,
};
pub use read::read_material;
pub use warp_chunk::warp_payload_len;
pub use write::{f16_scale, quantize_record_f16, write_material, written_version};
