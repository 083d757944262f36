//! The binary range coder of format 1.6 (`spec/FORMAT.md` §3.10, "Range-coded payload"): the
//! LZMA range coder (Igor Pavlov's, public domain), with 12-bit adaptive probabilities that move
//! by 1/16 of the distance after each bit, and direct (equiprobable) bits.
//!
//! Why this one: it is a few lines of integer arithmetic that a stranger can re-implement from
//! the spec alone, decoding reads each byte once, and its adaptive bits let contexts learn the
//! statistics of each file's own tables (DEFLATE's byte matching finds little in quantised
//! transform coefficients).

/// Probabilities are `p / 2^PROB_BITS` that the next bit is 0.
pub(crate) const PROB_BITS: u32 = 12;
/// A model's probability moves by `1 / 2^MOVE_BITS` of the distance to the bit seen.
const MOVE_BITS: u32 = 4;
/// Where a fresh model starts: one half.
pub(crate) const PROB_INIT: u16 = 1 << (PROB_BITS - 1);
/// Below this the range is renormalised by a byte.
const TOP: u32 = 1 << 24;

/// An adaptive bit's probability of a 0, in units of 2^-12; stays within [15, 4081].
#[derive(Debug, Clone, Copy)]
pub(crate) struct BitModel(u16);

impl Default for BitModel {
    fn default() -> Self {
        BitModel(PROB_INIT)
    }
}

impl BitModel {
    fn update(&mut self, bit: bool) {
        if bit {
            self.0 -= self.0 >> MOVE_BITS;
        } else {
            self.0 += ((1u16 << PROB_BITS) - self.0) >> MOVE_BITS;
        }
    }
}

/// Writes bits into bytes.
pub(crate) struct RangeEncoder {
    low: u64,
    range: u32,
    cache: u8,
    cache_size: u64,
    out: Vec<u8>,
}

impl RangeEncoder {
    pub(crate) fn new() -> Self {
        RangeEncoder {
            low: 0,
            range: u32::MAX,
            cache: 0,
            cache_size: 1,
            out: Vec::new(),
        }
    }

    fn shift_low(&mut self) {
        if (self.low as u32) < 0xFF00_0000 || (self.low >> 32) != 0 {
            let carry = (self.low >> 32) as u8;
            let mut byte = self.cache;
            loop {
                self.out.push(byte.wrapping_add(carry));
                byte = 0xFF;
                self.cache_size -= 1;
                if self.cache_size == 0 {
                    break;
                }
            }
            self.cache = (self.low >> 24) as u8;
        }
        self.cache_size += 1;
        self.low = (self.low & 0x00FF_FFFF) << 8;
    }

    fn normalise(&mut self) {
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    /// One bit with an adaptive model.
    pub(crate) fn bit(&mut self, m: &mut BitModel, bit: bool) {
        let bound = (self.range >> PROB_BITS) * m.0 as u32;
        if bit {
            self.low += bound as u64;
            self.range -= bound;
        } else {
            self.range = bound;
        }
        m.update(bit);
        self.normalise();
    }

    /// One equiprobable bit.
    pub(crate) fn direct(&mut self, bit: bool) {
        self.range >>= 1;
        if bit {
            self.low += self.range as u64;
        }
        self.normalise();
    }

    /// The bytes, the coder flushed (five more shifts).
    pub(crate) fn finish(mut self) -> Vec<u8> {
        for _ in 0..5 {
            self.shift_low();
        }
        self.out
    }
}

/// Reads bits from bytes; reading past the end is an error, never a panic.
pub(crate) struct RangeDecoder<'a> {
    bytes: &'a [u8],
    pos: usize,
    range: u32,
    code: u32,
}

/// Why a range-coded stream cannot be read.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum RangeError {
    /// The first byte, always 0 from the encoder, is not.
    FirstByte(u8),
    /// The stream needs more bytes than it has.
    Truncated,
}

impl<'a> RangeDecoder<'a> {
    /// Starts on `bytes`: reads the first five.
    pub(crate) fn new(bytes: &'a [u8]) -> Result<Self, RangeError> {
        if bytes.len() < 5 {
            return Err(RangeError::Truncated);
        }
        if bytes[0] != 0 {
            return Err(RangeError::FirstByte(bytes[0]));
        }
        let code = u32::from_be_bytes([bytes[1], bytes[2], bytes[3], bytes[4]]);
        Ok(RangeDecoder {
            bytes,
            pos: 5,
            range: u32::MAX,
            code,
        })
    }

    /// Bytes read so far.
    pub(crate) fn consumed(&self) -> usize {
        self.pos
    }

    fn normalise(&mut self) -> Result<(), RangeError> {
        while self.range < TOP {
            let &b = self.bytes.get(self.pos).ok_or(RangeError::Truncated)?;
            self.pos += 1;
            self.range <<= 8;
            self.code = (self.code << 8) | b as u32;
        }
        Ok(())
    }

    /// One bit with an adaptive model.
    pub(crate) fn bit(&mut self, m: &mut BitModel) -> Result<bool, RangeError> {
        let bound = (self.range >> PROB_BITS) * m.0 as u32;
        let bit = self.code >= bound;
        if bit {
            self.code -= bound;
            self.range -= bound;
        } else {
            self.range = bound;
        }
        m.update(bit);
        self.normalise()?;
        Ok(bit)
    }

    /// One equiprobable bit.
    pub(crate) fn direct(&mut self) -> Result<bool, RangeError> {
        self.range >>= 1;
        let bit = self.code >= self.range;
        if bit {
            self.code -= self.range;
        }
        self.normalise()?;
        Ok(bit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fixed pseudo-random sequence (linear congruential).
    fn lcg(seed: u64) -> impl FnMut() -> u64 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            s >> 33
        }
    }

    #[test]
    fn bits_come_back_and_the_decoder_reads_exactly_the_stream() {
        for (seed, count, skew) in [
            (1, 0, 2),
            (2, 1, 2),
            (3, 1000, 2),
            (4, 50_000, 20),
            (5, 7, 1),
        ] {
            let mut next = lcg(seed);
            // Three models and direct bits, interleaved; `skew` makes adaptive bits mostly 0.
            let bits: Vec<(u8, bool)> = (0..count)
                .map(|_| ((next() % 4) as u8, next() % skew == 1))
                .collect();
            let mut enc = RangeEncoder::new();
            let mut models = [BitModel::default(); 3];
            for &(m, b) in &bits {
                match m {
                    3 => enc.direct(b),
                    m => enc.bit(&mut models[m as usize], b),
                }
            }
            let bytes = enc.finish();
            assert_eq!(bytes[0], 0);
            let mut dec = RangeDecoder::new(&bytes).unwrap();
            let mut models = [BitModel::default(); 3];
            for (i, &(m, b)) in bits.iter().enumerate() {
                let got = match m {
                    3 => dec.direct().unwrap(),
                    m => dec.bit(&mut models[m as usize]).unwrap(),
                };
                assert_eq!(got, b, "seed {seed}, bit {i}");
            }
            assert_eq!(dec.consumed(), bytes.len(), "seed {seed}: {count} bits");
        }
    }

    #[test]
    fn skewed_bits_cost_less_than_a_bit_each() {
        let mut enc = RangeEncoder::new();
        let mut m = BitModel::default();
        for i in 0..80_000 {
            enc.bit(&mut m, i % 100 == 0);
        }
        // An ideal coder needs 80 000 · H(0.01) / 8 ≈ 808 bytes.
        let n = enc.finish().len();
        assert!(n < 1100, "{n} bytes");
    }

    #[test]
    fn hostile_streams_fail_cleanly() {
        assert_eq!(
            RangeDecoder::new(&[0, 1]).err(),
            Some(RangeError::Truncated)
        );
        assert_eq!(
            RangeDecoder::new(&[7, 0, 0, 0, 0]).err(),
            Some(RangeError::FirstByte(7))
        );
        // All-ones bytes: decodes something or runs out, never panics.
        let bytes = [0u8, 255, 255, 255, 255, 255, 255];
        let mut dec = RangeDecoder::new(&bytes).unwrap();
        let mut m = BitModel::default();
        let mut outcome = Ok(true);
        for _ in 0..1000 {
            outcome = dec.bit(&mut m).and_then(|_| dec.direct());
            if outcome.is_err() {
                break;
            }
        }
        assert_eq!(outcome, Err(RangeError::Truncated));
    }
}
