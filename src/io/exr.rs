//! OpenEXR slices of a spectral BRDF in the spectral-EXR layout of Fichet, Pacanowski and
//! Wilkie ("An OpenEXR Layout for Spectral Images", JCGT 10(3), 2021), read and written with the
//! `exr` crate.
//!
//! One image is one incident direction; pixel (row i, column j) of an H×W image holds the
//! outgoing direction θo = (i + 0.5)·90°/H, φo = (j + 0.5)·360°/W, row 0 at the top (nearest
//! the normal). Channels named `T.<number><unit>` (reflective) or `S0.<number><unit>` (emissive,
//! unpolarised part) hold one wavelength each; the number uses a comma as its decimal separator
//! (`T.550,000000nm`) and the unit is an SI-prefixed metre or hertz, converted to nm. The incident
//! direction comes from the header attributes `sbrdf.thetaI` and `sbrdf.phiI` (degrees), or else
//! from the file name's `_ti<deg>_pi<deg>` part. Normative text: `spec/EXR.md`.

use crate::error::{Error, Result};
use crate::io::collect::{Place, Sample};
use exr::prelude::*;
use std::io::Cursor;

/// The header attribute naming the incident polar angle, degrees.
pub const THETA_I_ATTRIBUTE: &str = "sbrdf.thetaI";
/// The header attribute naming the incident azimuth, degrees.
pub const PHI_I_ATTRIBUTE: &str = "sbrdf.phiI";
/// The attribute that marks a spectral EXR, and the layout version this module writes.
pub const LAYOUT_VERSION_ATTRIBUTE: &str = "spectralLayoutVersion";
/// The spectral-EXR layout version this module writes (the value of
/// [`LAYOUT_VERSION_ATTRIBUTE`]).
pub const LAYOUT_VERSION: &str = "1.0";
/// An optional channel marking measured pixels: 0 means "not measured", anything else measured.
pub const MASK_CHANNEL: &str = "mask";
/// At most this many pixel values (pixels × channels) in one slice, checked from the header
/// before any pixel is read (1 GiB of f32).
pub const MAX_SLICE_VALUES: usize = 1 << 28;
/// The most pixel bytes one byte of an EXR file can decompress to: DEFLATE's limit (about
/// 1032:1: 258 bytes from 2 bits), which the ZIP and ZIPS compressions reach; RLE (64:1), PIZ,
/// PXR24 and the B44s stay below it. A header claiming more pixel bytes than that times the
/// file's length is refused before anything is allocated, so a 1 kB file costs at most about
/// 1 MB (issue 39: a 1 kB fuzz input asked for over 1 GB).
pub const MAX_EXPANSION: usize = 1032;

const SPEED_OF_LIGHT: f64 = 299_792_458.0; // m/s

/// One decoded slice: the incidence and the spectra at the pixels that hold a measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct Slice {
    /// Incident polar angle θi, degrees ([`THETA_I_ATTRIBUTE`]).
    pub theta_i: f64,
    /// Incident azimuth φi, degrees ([`PHI_I_ATTRIBUTE`]).
    pub phi_i: f64,
    /// Image size: rows (θo) × columns (φo).
    pub height: usize,
    /// Number of columns (φo); see `height`.
    pub width: usize,
    /// Wavelengths in nm, strictly increasing.
    pub wavelengths: Vec<f64>,
    /// Per measured pixel, in row-major order: (row, column, spectrum).
    pub pixels: Vec<(usize, usize, Vec<f64>)>,
    /// Pixels skipped as missing (NaN in some channel, or mask 0).
    pub missing: usize,
}

/// The outgoing direction (θo, φo) in degrees of pixel (row, column) of an H×W slice.
pub fn pixel_direction(row: usize, column: usize, height: usize, width: usize) -> [f64; 2] {
    [
        (row as f64 + 0.5) * 90.0 / height as f64,
        (column as f64 + 0.5) * 360.0 / width as f64,
    ]
}

/// What a channel name says, under the spectral-EXR naming rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ChannelKind {
    /// `T.<q>`: a reflective (non-polarised) spectral channel at this wavelength, nm.
    Reflective(f64),
    /// `S0.<q>` … `S3.<q>`: an emissive Stokes component (0 is the intensity).
    Emissive {
        /// The Stokes component, 0 to 3.
        stokes: u8,
        /// The wavelength, nm.
        nm: f64,
    },
    /// `T.<q>.<q>`: a bispectral (re-radiation) channel, which a BRDF slice cannot hold.
    Bispectral,
    /// Anything else (RGB previews, alpha, the mask): not spectral.
    Other,
}

/// Classifies a channel name (given as its bytes: EXR names are byte strings, and `µ` may arrive
/// as UTF-8 or Latin-1). Returns `Err(unit)` for a spectral-looking name whose quantity does not
/// parse, so that a typo is reported instead of ignored.
pub fn classify_channel(name: &[u8]) -> std::result::Result<ChannelKind, String> {
    let text: String = match std::str::from_utf8(name) {
        Ok(s) => s.to_string(),
        Err(_) => name.iter().map(|&b| b as char).collect(), // Latin-1
    };
    let (prefix, rest) = match text.split_once('.') {
        Some(p) => p,
        None => return Ok(ChannelKind::Other),
    };
    let stokes = match prefix {
        "T" => None,
        "S0" => Some(0),
        "S1" => Some(1),
        "S2" => Some(2),
        "S3" => Some(3),
        _ => return Ok(ChannelKind::Other),
    };
    if stokes.is_none() && rest.contains('.') {
        return Ok(ChannelKind::Bispectral);
    }
    let nm = parse_quantity(rest).ok_or_else(|| {
        format!("channel '{text}': '{rest}' is not a wavelength or frequency (like 550,000000nm)")
    })?;
    Ok(match stokes {
        None => ChannelKind::Reflective(nm),
        Some(s) => ChannelKind::Emissive { stokes: s, nm },
    })
}

/// The unit part of a quantity (`nm`, `um`, `THz`, …), for the mixed-units check.
fn unit_of(q: &str) -> &str {
    let digits = q
        .char_indices()
        .find(|(_, c)| !(c.is_ascii_digit() || matches!(c, ',' | '.' | 'e' | 'E' | '+' | '-')))
        .map_or(q.len(), |(i, _)| i);
    // "e" may start no exponent but a unit ("Em"): back off to the last digit or separator.
    let mut start = digits;
    while start > 0 && matches!(q.as_bytes()[start - 1], b'e' | b'E' | b'+' | b'-') {
        start -= 1;
    }
    &q[start..]
}

/// Parses `<number><SI prefix>?(m|Hz)` into nm: the number with a comma (or point) as decimal
/// separator and an optional exponent; metres and hertz with the prefixes Y…y (`u`, `µ` and
/// `μ` for micro).
fn parse_quantity(q: &str) -> Option<f64> {
    let unit = unit_of(q);
    let number = &q[..q.len() - unit.len()];
    if number.is_empty() {
        return None;
    }
    let value: f64 = number.replace(',', ".").parse().ok()?;
    let (scale_unit, hertz) = if let Some(p) = unit.strip_suffix("Hz") {
        (p, true)
    } else if let Some(p) = unit.strip_suffix('m') {
        (p, false)
    } else {
        return None;
    };
    let factor = match scale_unit {
        "Y" => 1e24,
        "Z" => 1e21,
        "E" => 1e18,
        "P" => 1e15,
        "T" => 1e12,
        "G" => 1e9,
        "M" => 1e6,
        "k" => 1e3,
        "h" => 1e2,
        "da" => 1e1,
        "" => 1.0,
        "d" => 1e-1,
        "c" => 1e-2,
        "m" => 1e-3,
        "u" | "µ" | "μ" | "Âµ" => 1e-6,
        "n" => 1e-9,
        "p" => 1e-12,
        "f" => 1e-15,
        "a" => 1e-18,
        "z" => 1e-21,
        "y" => 1e-24,
        _ => return None,
    };
    let nm = if hertz {
        SPEED_OF_LIGHT / (value * factor) * 1e9
    } else if scale_unit == "n" {
        value // exact: no scaling round trip for the common case
    } else {
        value * factor * 1e9
    };
    (nm.is_finite() && nm > 0.0).then_some(nm)
}

/// The channel name this module writes for a reflective wavelength: `T.` then the wavelength in
/// nm with six decimals and a decimal comma, as the layout's reference code writes it; more
/// digits when six do not give the value back exactly.
pub fn reflective_channel_name(nm: f64) -> String {
    let six = format!("{nm:.6}");
    let text = if six.parse::<f64>() == Ok(nm) {
        six
    } else {
        format!("{nm}")
    };
    format!("T.{}nm", text.replace('.', ","))
}

/// The incident direction from a file name's `_ti<deg>_pi<deg>` part (`gold_ti15_pi0.exr`).
pub fn incidence_from_file_name(name: &str) -> Option<(f64, f64)> {
    let stem = std::path::Path::new(name).file_stem()?.to_str()?;
    let number = |s: &str| -> Option<(f64, usize)> {
        let len = s
            .char_indices()
            .take_while(|(i, c)| c.is_ascii_digit() || *c == '.' || (*i == 0 && *c == '-'))
            .count();
        Some((s[..len].parse().ok()?, len))
    };
    // The last `_ti` followed by a number, then `_pi` and a number.
    let mut found = None;
    for (at, _) in stem.match_indices("_ti") {
        let rest = &stem[at + 3..];
        let Some((t, len)) = number(rest) else {
            continue;
        };
        let Some(after) = rest[len..].strip_prefix("_pi") else {
            continue;
        };
        let Some((p, _)) = number(after) else {
            continue;
        };
        found = Some((t, p));
    }
    found
}

fn attribute_number(value: &exr::meta::attribute::AttributeValue) -> Option<f64> {
    use exr::meta::attribute::AttributeValue as V;
    match value {
        V::F32(v) => Some(*v as f64),
        V::F64(v) => Some(*v),
        V::I32(v) => Some(*v as f64),
        V::Text(t) => t.to_string().trim().parse().ok(),
        _ => None,
    }
}

fn exr_error(name: &str, e: exr::error::Error) -> Error {
    Error::Input(format!("{name}: not a readable OpenEXR file: {e}"))
}

/// Reads one slice from the bytes of an EXR file called `name` (used in messages and, when the
/// header lacks the incidence attributes, for the `_ti…_pi…` convention).
pub fn read_slice(name: &str, bytes: &[u8]) -> Result<Slice> {
    // The header alone first: the sizes it claims are checked before pixels are allocated.
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| exr_error(name, e))?;
    for h in &meta.headers {
        if h.deep {
            return Err(Error::Input(format!(
                "{name}: deep images are not spectral BRDF slices"
            )));
        }
        let values = h.layer_size.area().saturating_mul(h.channels.list.len());
        let pixel_bytes = h.channels.list.iter().fold(0usize, |a, c| {
            a.saturating_add(
                h.layer_size
                    .area()
                    .saturating_mul(c.sample_type.bytes_per_sample()),
            )
        });
        if pixel_bytes > MAX_EXPANSION.saturating_mul(bytes.len()) {
            return Err(Error::Input(format!(
                "{name}: the header claims {}×{} pixels × {} channels ({pixel_bytes} bytes), more \
                 than {} bytes of file can hold at EXR's largest compression ({MAX_EXPANSION}:1); \
                 the file is truncated or damaged",
                h.layer_size.width(),
                h.layer_size.height(),
                h.channels.list.len(),
                bytes.len()
            )));
        }
        if values > MAX_SLICE_VALUES {
            return Err(Error::LimitsExceeded(format!(
                "{name}: {}×{} pixels × {} channels exceeds the limit of {MAX_SLICE_VALUES} values",
                h.layer_size.width(),
                h.layer_size.height(),
                h.channels.list.len()
            )));
        }
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| exr_error(name, e))?;

    // The one layer holding spectral channels.
    let mut spectral_layers = Vec::new();
    for (li, layer) in image.layer_data.iter().enumerate() {
        let mut any = false;
        for ch in &layer.channel_data.list {
            match classify_channel(ch.name.as_slice()) {
                Ok(ChannelKind::Other) => {}
                Ok(_) => any = true,
                Err(msg) => return Err(Error::Input(format!("{name}: {msg}"))),
            }
        }
        if any {
            spectral_layers.push(li);
        }
    }
    let layer = match spectral_layers.as_slice() {
        [] => {
            return Err(Error::Input(format!(
                "{name}: no spectral channels (expected names like T.550,000000nm or \
                 S0.550,000000nm, one per wavelength)"
            )))
        }
        [one] => &image.layer_data[*one],
        _ => {
            return Err(Error::Input(format!(
                "{name}: {} layers hold spectral channels; a slice has one",
                spectral_layers.len()
            )))
        }
    };
    if let Some(v) = layer
        .attributes
        .other
        .get(&Text::from(LAYOUT_VERSION_ATTRIBUTE))
        .or_else(|| {
            image
                .attributes
                .other
                .get(&Text::from(LAYOUT_VERSION_ATTRIBUTE))
        })
    {
        let version = match v {
            exr::meta::attribute::AttributeValue::Text(t) => t.to_string(),
            other => format!("{other:?}"),
        };
        if !version.trim().starts_with("1.") && version.trim() != "1" {
            return Err(Error::Input(format!(
                "{name}: {LAYOUT_VERSION_ATTRIBUTE} is '{version}'; this reader knows version 1"
            )));
        }
    }
    let display = image.attributes.display_window;
    if layer.attributes.layer_position != display.position || layer.size != display.size {
        return Err(Error::Input(format!(
            "{name}: the data window ({:?} at {:?}) differs from the display window ({:?} at \
             {:?}); the pixel-to-direction convention needs the whole image",
            layer.size, layer.attributes.layer_position, display.size, display.position
        )));
    }

    // Spectral channels: reflective or emissive intensity, one unit throughout.
    let mut reflective = Vec::new();
    let mut emissive = Vec::new();
    let mut mask = None;
    let mut units: Vec<(String, String)> = Vec::new();
    for ch in &layer.channel_data.list {
        let cname = ch.name.to_string();
        let kind = classify_channel(ch.name.as_slice()).map_err(Error::Input)?;
        match kind {
            ChannelKind::Reflective(nm) => reflective.push((nm, ch)),
            ChannelKind::Emissive { stokes: 0, nm } => emissive.push((nm, ch)),
            ChannelKind::Emissive { .. } => continue, // polarisation beyond intensity
            ChannelKind::Bispectral => {
                return Err(Error::Input(format!(
                    "{name}: channel '{cname}' is bispectral (fluorescence); a BRDF slice holds \
                     one wavelength per channel"
                )))
            }
            ChannelKind::Other => {
                if cname == MASK_CHANNEL {
                    mask = Some(ch);
                }
                continue;
            }
        }
        let quantity = cname.split_once('.').map_or("", |p| p.1);
        units.push((unit_of(quantity).to_string(), cname));
    }
    if let Some((first_unit, first)) = units.first() {
        if let Some((u, c)) = units.iter().find(|(u, _)| u != first_unit) {
            return Err(Error::Input(format!(
                "{name}: mixed units in spectral channels ('{first}' in {first_unit}, '{c}' in \
                 {u}); use one unit throughout"
            )));
        }
    }
    let mut channels = match (reflective.is_empty(), emissive.is_empty()) {
        (false, true) => reflective,
        (true, false) => emissive,
        _ => {
            return Err(Error::Input(format!(
                "{name}: both reflective (T.*) and emissive (S0.*) channels; a slice holds one kind"
            )))
        }
    };
    channels.sort_by(|a, b| a.0.total_cmp(&b.0));
    for w in channels.windows(2) {
        if w[0].0 == w[1].0 {
            return Err(Error::Input(format!(
                "{name}: channels '{}' and '{}' are the same wavelength ({} nm)",
                w[0].1.name, w[1].1.name, w[0].0
            )));
        }
    }

    // The incidence: header attributes, else the file name.
    let attr = |key: &str| {
        let k = Text::from(key);
        layer
            .attributes
            .other
            .get(&k)
            .or_else(|| image.attributes.other.get(&k))
    };
    let (theta_i, phi_i) = match (attr(THETA_I_ATTRIBUTE), attr(PHI_I_ATTRIBUTE)) {
        (Some(t), Some(p)) => {
            let number = |key: &str, v| {
                attribute_number(v).ok_or_else(|| {
                    Error::Input(format!(
                        "{name}: attribute {key} is not a number (expected a float in degrees)"
                    ))
                })
            };
            (number(THETA_I_ATTRIBUTE, t)?, number(PHI_I_ATTRIBUTE, p)?)
        }
        (None, None) => incidence_from_file_name(name).ok_or_else(|| {
            Error::Input(format!(
                "{name}: no incident direction: give the header attributes {THETA_I_ATTRIBUTE} \
                 and {PHI_I_ATTRIBUTE} (degrees) or name the file like slice_ti15_pi0.exr"
            ))
        })?,
        (t, _) => {
            let (has, lacks) = if t.is_some() {
                (THETA_I_ATTRIBUTE, PHI_I_ATTRIBUTE)
            } else {
                (PHI_I_ATTRIBUTE, THETA_I_ATTRIBUTE)
            };
            return Err(Error::Input(format!(
                "{name}: attribute {has} is given but {lacks} is missing"
            )));
        }
    };
    if !(0.0..=90.0).contains(&theta_i) || !phi_i.is_finite() {
        return Err(Error::Input(format!(
            "{name}: incident direction ({theta_i}, {phi_i}) is outside θ ∈ [0, 90]"
        )));
    }
    let phi_i = crate::model::angles::wrap_phi(phi_i);

    let (width, height) = (layer.size.width(), layer.size.height());
    if width == 0 || height == 0 {
        return Err(Error::Input(format!("{name}: the image has no pixels")));
    }
    let data: Vec<Vec<f32>> = channels
        .iter()
        .map(|(_, ch)| ch.sample_data.values_as_f32().collect())
        .collect();
    let mask: Option<Vec<f32>> = mask.map(|m| m.sample_data.values_as_f32().collect());
    let mut pixels = Vec::new();
    let mut missing = 0;
    for row in 0..height {
        for column in 0..width {
            let at = row * width + column;
            if mask.as_ref().is_some_and(|m| m[at] == 0.0) {
                missing += 1;
                continue;
            }
            let spectrum: Vec<f64> = data.iter().map(|c| c[at] as f64).collect();
            if spectrum.iter().any(|v| v.is_nan()) {
                missing += 1;
                continue;
            }
            if let Some(i) = spectrum.iter().position(|v| !v.is_finite()) {
                return Err(Error::Input(format!(
                    "{name}: pixel (row {row}, column {column}), channel '{}': value {} is not \
                     finite (mark missing pixels with NaN or the '{MASK_CHANNEL}' channel)",
                    channels[i].1.name, spectrum[i]
                )));
            }
            pixels.push((row, column, spectrum));
        }
    }
    Ok(Slice {
        theta_i,
        phi_i,
        height,
        width,
        wavelengths: channels.iter().map(|c| c.0).collect(),
        pixels,
        missing,
    })
}

/// Pixel storage for [`write_slice`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelType {
    /// 16-bit floats.
    Half,
    /// 32-bit floats.
    Float,
}

/// Encodes one slice as a spectral EXR: reflective channels `T.<λ>nm`, the layout version, and
/// the incidence attributes (single-precision floats, double where single would round them).
/// `values` holds height × width spectra of `wavelengths.len()` values, row-major; NaN marks a
/// missing pixel.
pub fn write_slice(
    theta_i: f64,
    phi_i: f64,
    height: usize,
    width: usize,
    wavelengths: &[f64],
    values: &[f64],
    pixel_type: PixelType,
) -> Result<Vec<u8>> {
    let n = wavelengths.len();
    if height == 0 || width == 0 || n == 0 || values.len() != height * width * n {
        return Err(Error::Parameter(format!(
            "an EXR slice needs height × width × wavelengths values ({height} × {width} × {n}), \
             got {}",
            values.len()
        )));
    }
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (w, &nm) in wavelengths.iter().enumerate() {
        let column = values.iter().skip(w).step_by(n);
        let samples = match pixel_type {
            PixelType::Float => FlatSamples::F32(column.map(|&v| v as f32).collect()),
            PixelType::Half => FlatSamples::F16(column.map(|&v| f16::from_f64(v)).collect()),
        };
        list.push(AnyChannel::new(
            Text::new_or_none(reflective_channel_name(nm)).ok_or_else(|| {
                Error::Parameter(format!("wavelength {nm} nm gives no valid channel name"))
            })?,
            samples,
        ));
    }
    let mut attributes = LayerAttributes::default();
    let angle = |v: f64| {
        if (v as f32) as f64 == v {
            exr::meta::attribute::AttributeValue::F32(v as f32)
        } else {
            exr::meta::attribute::AttributeValue::F64(v)
        }
    };
    attributes
        .other
        .insert(Text::from(THETA_I_ATTRIBUTE), angle(theta_i));
    attributes
        .other
        .insert(Text::from(PHI_I_ATTRIBUTE), angle(phi_i));
    attributes.other.insert(
        Text::from(LAYOUT_VERSION_ATTRIBUTE),
        exr::meta::attribute::AttributeValue::Text(Text::from(LAYOUT_VERSION)),
    );
    attributes.software_name = Some(Text::from(concat!("sbrdf ", env!("CARGO_PKG_VERSION"))));
    let layer = Layer::new(
        (width, height),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = Image::from_layer(layer);
    let mut out = Cursor::new(Vec::new());
    image
        .write()
        .non_parallel()
        .to_buffered(&mut out)
        .map_err(|e| Error::Parameter(format!("EXR encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// The file name `decode --exr` and `synth --layout exr` give a slice: `<stem>_ti<θ>_pi<φ>.exr`.
pub fn slice_file_name(stem: &str, theta_i: f64, phi_i: f64) -> String {
    format!("{stem}_ti{theta_i}_pi{phi_i}.exr")
}

/// Appends the samples of one EXR slice; returns how many pixels were marked missing.
pub(crate) fn collect_exr(
    fi: usize,
    name: &str,
    bytes: &[u8],
    samples: &mut Vec<Sample>,
) -> Result<usize> {
    let slice = read_slice(name, bytes)?;
    let (ti, pi) = (slice.theta_i.to_bits(), slice.phi_i.to_bits());
    samples.reserve(slice.pixels.len() * slice.wavelengths.len());
    for (row, column, spectrum) in &slice.pixels {
        let [to, po] = pixel_direction(*row, *column, slice.height, slice.width);
        for (&l, &v) in slice.wavelengths.iter().zip(spectrum) {
            samples.push(Sample {
                key: [ti, pi, to.to_bits(), po.to_bits(), l.to_bits()],
                value: v,
                file: fi as u32,
                place: Place::Pixel {
                    row: *row as u32,
                    column: *column as u32,
                },
            });
        }
    }
    Ok(slice.missing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_names_follow_the_layout() {
        assert_eq!(
            classify_channel(b"T.550,000000nm"),
            Ok(ChannelKind::Reflective(550.0))
        );
        assert_eq!(
            classify_channel(b"S0.412,5nm"),
            Ok(ChannelKind::Emissive {
                stokes: 0,
                nm: 412.5
            })
        );
        let um = classify_channel(b"T.0,55um").unwrap();
        assert!(matches!(um, ChannelKind::Reflective(v) if (v - 550.0).abs() < 1e-9));
        let micro = classify_channel("T.0,55µm".as_bytes()).unwrap();
        assert!(matches!(micro, ChannelKind::Reflective(v) if (v - 550.0).abs() < 1e-9));
        let latin1 = classify_channel(b"T.0,55\xb5m").unwrap();
        assert!(matches!(latin1, ChannelKind::Reflective(v) if (v - 550.0).abs() < 1e-9));
        let hz = classify_channel(b"T.545,077196THz").unwrap();
        assert!(
            matches!(hz, ChannelKind::Reflective(v) if (v - 550.0).abs() < 1e-3),
            "{hz:?}"
        );
        let exp = classify_channel(b"T.5,5e2nm").unwrap();
        assert_eq!(exp, ChannelKind::Reflective(550.0));
        assert_eq!(
            classify_channel(b"T.400nm.500nm"),
            Ok(ChannelKind::Bispectral)
        );
        for other in ["R", "G", "A", "mask", "Y.550nm", "T"] {
            assert_eq!(
                classify_channel(other.as_bytes()),
                Ok(ChannelKind::Other),
                "{other}"
            );
        }
        for bad in ["T.550", "T.nm", "T.550,0xm", "S0.abcnm"] {
            assert!(classify_channel(bad.as_bytes()).is_err(), "{bad}");
        }
    }

    #[test]
    fn written_names_read_back_exactly() {
        for nm in [400.0, 412.5, 555.123456, 380.0000001] {
            let name = reflective_channel_name(nm);
            assert_eq!(
                classify_channel(name.as_bytes()),
                Ok(ChannelKind::Reflective(nm)),
                "{name}"
            );
        }
        assert_eq!(reflective_channel_name(550.0), "T.550,000000nm");
    }

    #[test]
    fn incidence_from_names() {
        assert_eq!(
            incidence_from_file_name("gold_ti15_pi0.exr"),
            Some((15.0, 0.0))
        );
        assert_eq!(
            incidence_from_file_name("dir/x_ti37.5_pi90.exr"),
            Some((37.5, 90.0))
        );
        assert_eq!(incidence_from_file_name("x_ti15.exr"), None);
        assert_eq!(incidence_from_file_name("plain.exr"), None);
    }

    #[test]
    fn slice_round_trip_in_memory() {
        let wl = [400.0, 550.0, 700.0];
        let (h, w) = (3, 4);
        let mut values: Vec<f64> = (0..h * w * 3).map(|i| i as f64 * 0.25).collect();
        values[5 * 3 + 1] = f64::NAN; // pixel 5 missing
        let bytes = write_slice(37.5, 90.0, h, w, &wl, &values, PixelType::Float).unwrap();
        let s = read_slice("mem.exr", &bytes).unwrap();
        assert_eq!((s.theta_i, s.phi_i, s.height, s.width), (37.5, 90.0, h, w));
        assert_eq!(s.wavelengths, wl);
        assert_eq!(s.missing, 1);
        assert_eq!(s.pixels.len(), h * w - 1);
        for (row, col, spec) in &s.pixels {
            let at = row * w + col;
            assert_eq!(spec.as_slice(), &values[at * 3..at * 3 + 3]);
        }
    }
}
