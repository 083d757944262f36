//! The `tensor_file` container (Mitsuba 3's `TensorFile`, version 1.0) that RGL `.bsdf` files
//! use, and the errors of everything under [`crate::io::rgl`].
//!
//! Layout, little endian: bytes 0–11 `tensor_file\0`; byte 12 major = 1, byte 13 minor = 0;
//! bytes 14–17 the field count (u32). Then per field: u16 name length, the name (UTF-8, not
//! terminated), u16 ndim, u8 dtype (Mitsuba's `Struct::Type`: 1 u8, 2 i8, 3 u16, 4 i16, 5 u32,
//! 6 i32, 7 u64, 8 i64, 9 f16, 10 f32, 11 f64), u64 absolute data offset, ndim × u64 shape.
//! Data are C order. Every count, shape product and offset is checked against the bytes
//! present before anything is allocated (Mitsuba's own reader checks neither).

use std::fmt;

/// Everything that can be wrong with an RGL file or a request made of it.
#[derive(Debug, Clone, PartialEq)]
pub enum RglError {
    /// The bytes end before `what` (which starts at byte `at` and needs `need` bytes).
    Truncated {
        /// What was being read.
        what: String,
        /// Its byte offset.
        at: u64,
        /// Bytes it needs.
        need: u64,
        /// Bytes left in the file.
        have: u64,
    },
    /// The first 12 bytes are not `tensor_file\0`.
    BadMagic,
    /// Version bytes at offset 12 other than 1.0.
    BadVersion {
        /// Byte 12.
        major: u8,
        /// Byte 13.
        minor: u8,
    },
    /// The field count at byte 14 cannot fit in the bytes that follow.
    TooManyFields {
        /// The stored count.
        count: u32,
        /// The most field headers the remaining bytes could hold.
        max: u64,
    },
    /// A field name that is not UTF-8.
    BadName {
        /// The field's position among the headers, from 0.
        index: u32,
        /// Byte offset of the name.
        at: u64,
    },
    /// A dtype code outside Mitsuba's `Struct::Type` 1..=11.
    UnknownDType {
        /// The field's name.
        field: String,
        /// Byte offset of the dtype code.
        at: u64,
        /// The code found.
        code: u8,
    },
    /// A field whose element count × element size overflows.
    SizeOverflow {
        /// The field's name.
        field: String,
        /// Byte offset of its shape.
        at: u64,
    },
    /// A field whose data lies (partly) outside the file.
    DataOutOfBounds {
        /// The field's name.
        field: String,
        /// Its data's byte offset.
        offset: u64,
        /// Its data's length in bytes.
        len: u64,
        /// The file's length in bytes.
        file_len: u64,
    },
    /// The same field name twice (header of the second at `at`).
    DuplicateField {
        /// The repeated name.
        field: String,
        /// Byte offset of the second header.
        at: u64,
    },
    /// A field an RGL BSDF needs is absent.
    MissingField {
        /// The missing field's name.
        field: String,
    },
    /// A field an RGL BSDF needs has another element type than it expects.
    WrongDType {
        /// The field's name.
        field: String,
        /// Byte offset of its data.
        at: u64,
        /// The type an RGL BSDF stores there.
        expected: DType,
        /// The type the file has.
        found: DType,
    },
    /// A field an RGL BSDF needs has another shape than it expects.
    WrongShape {
        /// The field's name.
        field: String,
        /// Byte offset of its data.
        at: u64,
        /// The expected shape, in words.
        expected: String,
        /// The shape the file has.
        found: Vec<u64>,
    },
    /// A value that makes no sense (`at` is the byte offset of the element).
    BadData {
        /// The field's name.
        field: String,
        /// Byte offset of the element.
        at: u64,
        /// What is wrong with it.
        reason: String,
    },
    /// An incidence index out of range or at/under grazing (cos θi ≤ 0).
    BadIncidence {
        /// Which, and why.
        reason: String,
    },
    /// The RGB → spectrum fit could not reproduce a colour within tolerance.
    Upsample {
        /// The colour, linear sRGB.
        rgb: [f64; 3],
        /// The best fit's relative error (+∞ for a colour that was not finite).
        rel_error: f64,
    },
}

impl fmt::Display for RglError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use RglError::*;
        match self {
            Truncated {
                what,
                at,
                need,
                have,
            } => write!(
                f,
                "truncated: {what} at byte {at} needs {need} bytes, only {have} remain"
            ),
            BadMagic => write!(
                f,
                "not a tensor file: bytes 0..12 are not \"tensor_file\\0\""
            ),
            BadVersion { major, minor } => {
                write!(
                    f,
                    "unsupported tensor_file version {major}.{minor} at byte 12 (want 1.0)"
                )
            }
            TooManyFields { count, max } => write!(
                f,
                "field count {count} at byte 14 is impossible: at most {max} field headers fit"
            ),
            BadName { index, at } => write!(f, "field #{index}: name at byte {at} is not UTF-8"),
            UnknownDType { field, at, code } => {
                write!(
                    f,
                    "field \"{field}\": unknown dtype code {code} at byte {at}"
                )
            }
            SizeOverflow { field, at } => {
                write!(
                    f,
                    "field \"{field}\": shape at byte {at} overflows the size computation"
                )
            }
            DataOutOfBounds {
                field,
                offset,
                len,
                file_len,
            } => write!(
                f,
                "field \"{field}\": data at bytes {offset}..{offset}+{len} lies outside the \
                 {file_len}-byte file"
            ),
            DuplicateField { field, at } => {
                write!(
                    f,
                    "field \"{field}\" defined twice (second header at byte {at})"
                )
            }
            MissingField { field } => write!(f, "required field \"{field}\" is missing"),
            WrongDType {
                field,
                at,
                expected,
                found,
            } => write!(
                f,
                "field \"{field}\" (data at byte {at}): dtype {found}, expected {expected}"
            ),
            WrongShape {
                field,
                at,
                expected,
                found,
            } => write!(
                f,
                "field \"{field}\" (data at byte {at}): shape {found:?}, expected {expected}"
            ),
            BadData { field, at, reason } => {
                write!(f, "field \"{field}\", element at byte {at}: {reason}")
            }
            BadIncidence { reason } => write!(f, "incidence: {reason}"),
            Upsample { rgb, rel_error } => write!(
                f,
                "RGB ({:.6}, {:.6}, {:.6}) cannot be upsampled: best spectrum is off by {:.2e} \
                 (relative)",
                rgb[0], rgb[1], rgb[2], rel_error
            ),
        }
    }
}

impl std::error::Error for RglError {}

/// `std::result::Result` with [`RglError`].
pub type Result<T> = std::result::Result<T, RglError>;

/// Element types (Mitsuba `Struct::Type` codes 1..=11).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DType {
    /// Code 1: `uint8`.
    U8,
    /// Code 2: `int8`.
    I8,
    /// Code 3: `uint16`.
    U16,
    /// Code 4: `int16`.
    I16,
    /// Code 5: `uint32`.
    U32,
    /// Code 6: `int32`.
    I32,
    /// Code 7: `uint64`.
    U64,
    /// Code 8: `int64`.
    I64,
    /// Code 9: `float16`.
    F16,
    /// Code 10: `float32`.
    F32,
    /// Code 11: `float64`.
    F64,
}

impl DType {
    /// The type with this `Struct::Type` code; None outside 1..=11.
    pub fn from_code(code: u8) -> Option<DType> {
        use DType::*;
        Some(match code {
            1 => U8,
            2 => I8,
            3 => U16,
            4 => I16,
            5 => U32,
            6 => I32,
            7 => U64,
            8 => I64,
            9 => F16,
            10 => F32,
            11 => F64,
            _ => return None,
        })
    }

    /// Bytes per element: 1, 2, 4 or 8.
    pub fn size(self) -> u64 {
        use DType::*;
        match self {
            U8 | I8 => 1,
            U16 | I16 | F16 => 2,
            U32 | I32 | F32 => 4,
            U64 | I64 | F64 => 8,
        }
    }
}

impl fmt::Display for DType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            DType::U8 => "uint8",
            DType::I8 => "int8",
            DType::U16 => "uint16",
            DType::I16 => "int16",
            DType::U32 => "uint32",
            DType::I32 => "int32",
            DType::U64 => "uint64",
            DType::I64 => "int64",
            DType::F16 => "float16",
            DType::F32 => "float32",
            DType::F64 => "float64",
        };
        f.write_str(s)
    }
}

/// One field's header: where its data is and how it is laid out (C order, little endian).
#[derive(Debug, Clone, PartialEq)]
pub struct FieldInfo {
    /// The field's name.
    pub name: String,
    /// Its element type.
    pub dtype: DType,
    /// Its shape, outermost axis first (C order).
    pub shape: Vec<u64>,
    /// Byte offset of the data in the file.
    pub offset: u64,
    /// Data length in bytes (checked to lie inside the file).
    pub len: u64,
    /// Byte offset of this field's header.
    pub header_at: u64,
}

impl FieldInfo {
    /// The number of elements (data length / element size).
    pub fn count(&self) -> u64 {
        self.len / self.dtype.size()
    }
}

/// A parsed tensor file borrowing its bytes. Field data are checked to lie inside `bytes`.
#[derive(Debug, Clone)]
pub struct TensorFile<'a> {
    bytes: &'a [u8],
    /// (major, minor) from bytes 12 and 13; always (1, 0) once parsed.
    pub version: (u8, u8),
    /// The field headers, in file order.
    pub fields: Vec<FieldInfo>,
}

struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn remaining(&self) -> usize {
        self.b.len() - self.pos
    }
    fn take(&mut self, n: usize, what: &dyn Fn() -> String) -> Result<&'a [u8]> {
        if n > self.remaining() {
            return Err(RglError::Truncated {
                what: what(),
                at: self.pos as u64,
                need: n as u64,
                have: self.remaining() as u64,
            });
        }
        let s = &self.b[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn array<const N: usize>(&mut self, what: &dyn Fn() -> String) -> Result<[u8; N]> {
        let s = self.take(N, what)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }
}

/// Smallest possible field header: name length (2) + ndim (2) + dtype (1) + offset (8).
const MIN_FIELD_HEADER: u64 = 13;

impl<'a> TensorFile<'a> {
    /// Parses the header and every field header; checks that each field's data lies in `bytes`.
    pub fn parse(bytes: &'a [u8]) -> Result<TensorFile<'a>> {
        let file_len = bytes.len() as u64;
        let mut c = Cursor { b: bytes, pos: 0 };
        let magic = c.take(12, &|| "the 12-byte magic".into())?;
        if magic != b"tensor_file\0" {
            return Err(RglError::BadMagic);
        }
        let [major, minor] = c.array::<2>(&|| "the version".into())?;
        if (major, minor) != (1, 0) {
            return Err(RglError::BadVersion { major, minor });
        }
        let count = u32::from_le_bytes(c.array::<4>(&|| "the field count".into())?);
        let max = c.remaining() as u64 / MIN_FIELD_HEADER;
        if count as u64 > max {
            return Err(RglError::TooManyFields { count, max });
        }
        let mut fields: Vec<FieldInfo> = Vec::with_capacity(count as usize);
        for index in 0..count {
            let header_at = c.pos as u64;
            let name_len =
                u16::from_le_bytes(c.array::<2>(&|| format!("field #{index}'s name length"))?);
            let name_at = c.pos as u64;
            let raw = c.take(name_len as usize, &|| format!("field #{index}'s name"))?;
            let name = std::str::from_utf8(raw)
                .map_err(|_| RglError::BadName { index, at: name_at })?
                .to_string();
            let ndim = u16::from_le_bytes(c.array::<2>(&|| format!("field \"{name}\"'s ndim"))?);
            let dtype_at = c.pos as u64;
            let [code] = c.array::<1>(&|| format!("field \"{name}\"'s dtype"))?;
            let dtype = DType::from_code(code).ok_or_else(|| RglError::UnknownDType {
                field: name.clone(),
                at: dtype_at,
                code,
            })?;
            let offset =
                u64::from_le_bytes(c.array::<8>(&|| format!("field \"{name}\"'s data offset"))?);
            let shape_at = c.pos as u64;
            // The shape's bytes are checked before the vector is allocated.
            let raw_shape = c.take(8 * ndim as usize, &|| {
                format!("field \"{name}\"'s {ndim}-entry shape")
            })?;
            let shape: Vec<u64> = raw_shape
                .chunks_exact(8)
                .map(|b| u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
                .collect();
            let len = shape
                .iter()
                .try_fold(dtype.size(), |acc, &d| acc.checked_mul(d))
                .ok_or_else(|| RglError::SizeOverflow {
                    field: name.clone(),
                    at: shape_at,
                })?;
            if offset > file_len || len > file_len - offset {
                return Err(RglError::DataOutOfBounds {
                    field: name,
                    offset,
                    len,
                    file_len,
                });
            }
            if fields.iter().any(|f| f.name == name) {
                return Err(RglError::DuplicateField {
                    field: name,
                    at: header_at,
                });
            }
            fields.push(FieldInfo {
                name,
                dtype,
                shape,
                offset,
                len,
                header_at,
            });
        }
        Ok(TensorFile {
            bytes,
            version: (major, minor),
            fields,
        })
    }

    /// The field named `name`, if present.
    pub fn field(&self, name: &str) -> Option<&FieldInfo> {
        self.fields.iter().find(|f| f.name == name)
    }

    /// The raw bytes of a field (in bounds by construction).
    pub fn data(&self, f: &FieldInfo) -> &'a [u8] {
        &self.bytes[f.offset as usize..(f.offset + f.len) as usize]
    }

    /// A float32 field's values; the caller has checked the dtype.
    pub fn f32s(&self, f: &FieldInfo) -> Vec<f32> {
        self.data(f)
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }
}

/// Writes a tensor file from (name, dtype code, shape, data bytes) fields, data packed in field
/// order right after the headers. For tests and tools (a spectral file made from an RGB one, a
/// fuzz corpus); nothing here checks that the data match the shapes.
pub fn write_tensor(fields: &[(&str, u8, Vec<u64>, Vec<u8>)]) -> Vec<u8> {
    let mut head = Vec::new();
    head.extend_from_slice(b"tensor_file\0");
    head.extend_from_slice(&[1, 0]);
    head.extend_from_slice(&(fields.len() as u32).to_le_bytes());
    let header_len: usize = 18
        + fields
            .iter()
            .map(|(n, _, s, _)| 2 + n.len() + 2 + 1 + 8 + 8 * s.len())
            .sum::<usize>();
    let mut offset = header_len as u64;
    let mut data = Vec::new();
    for (name, code, shape, bytes) in fields {
        head.extend_from_slice(&(name.len() as u16).to_le_bytes());
        head.extend_from_slice(name.as_bytes());
        head.extend_from_slice(&(shape.len() as u16).to_le_bytes());
        head.push(*code);
        head.extend_from_slice(&offset.to_le_bytes());
        for d in shape {
            head.extend_from_slice(&d.to_le_bytes());
        }
        data.extend_from_slice(bytes);
        offset += bytes.len() as u64;
    }
    head.extend_from_slice(&data);
    head
}
