//! Parsing the values of the program's flags that clap cannot type by itself: direction pairs,
//! wavelength ranges, pixel resolutions.

use sbrdf::{Error, Result};

pub fn parse_pair(flag: &str, s: &str) -> Result<(f64, f64)> {
    let bad = || {
        Error::Parameter(format!(
            "--{flag} '{s}': expected θ,φ in degrees, like 15,0"
        ))
    };
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let t: f64 = a.trim().parse().map_err(|_| bad())?;
    let p: f64 = b.trim().parse().map_err(|_| bad())?;
    if !(t.is_finite() && p.is_finite()) {
        return Err(bad());
    }
    Ok((t, p))
}

pub fn parse_resolution(s: &str) -> Result<(usize, usize)> {
    let bad = || {
        Error::Parameter(format!(
            "--resolution '{s}': expected rows x columns, like 18x72 (both 1..=4096)"
        ))
    };
    let (h, w) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    if !(1..=4096).contains(&h) || !(1..=4096).contains(&w) {
        return Err(bad());
    }
    Ok((h, w))
}

pub fn parse_range(s: &str) -> Result<Vec<f64>> {
    let bad = || {
        Error::Parameter(format!(
            "--wavelengths '{s}': expected MIN:MAX:STEP, like 400:700:10"
        ))
    };
    let parts: Vec<f64> = s
        .split(':')
        .map(|p| p.trim().parse::<f64>().map_err(|_| bad()))
        .collect::<Result<_>>()?;
    let [lo, hi, step] = parts[..] else {
        return Err(bad());
    };
    if !(lo.is_finite() && hi.is_finite() && step.is_finite() && step > 0.0 && hi >= lo) {
        return Err(bad());
    }
    let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
    if n > 100_000 {
        return Err(bad());
    }
    Ok((0..n).map(|i| lo + i as f64 * step).collect())
}

pub fn check_nonnegative(values: &[(&str, f64)]) -> Result<()> {
    for (name, v) in values {
        if !(v.is_finite() && *v >= 0.0) {
            return Err(Error::Parameter(format!(
                "--{name} {v} must be a finite number ≥ 0"
            )));
        }
    }
    Ok(())
}
