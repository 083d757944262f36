//! The `sbrdf._sbrdf` extension module: a thin layer over the `sbrdf` crate. Decoding, encoding,
//! validation and messages are the crate's; this file only moves arrays and errors across.

use numpy::{
    AllowTypeChange, PyArray1, PyArray2, PyArrayLike1, PyArrayLikeDyn, PyArrayMethods,
    PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use sbrdf::decode::color::Illuminant;
use sbrdf::encode::settings::{encode_samples, EncodeSettings};
use sbrdf::Decoder;
use std::path::PathBuf;

create_exception!(
    _sbrdf,
    Error,
    PyValueError,
    "Bad input or a damaged file; the message is the command line's."
);

fn err(e: sbrdf::Error) -> PyErr {
    Error::new_err(e.to_string())
}

/// `Material.sample`'s result: directions (N, 3) and densities (N,).
type Sampled<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>);

/// An opened .sbrdf file: evaluate, sample, describe.
#[pyclass(module = "sbrdf", frozen)]
struct Material {
    dec: Decoder,
    name: String,
    bytes: u64,
}

/// N rows of K values from an array of shape (N, K) or (K,) (then N = 1): direction vectors
/// (K = 3) or pairs of uniform numbers (K = 2).
fn rows<const K: usize>(
    name: &str,
    a: &PyArrayLikeDyn<'_, f32, AllowTypeChange>,
) -> PyResult<Vec<[f32; K]>> {
    let v = a.as_array();
    let shape = v.shape().to_vec();
    let n = match shape.as_slice() {
        [k] if *k == K => 1,
        [n, k] if *k == K => *n,
        _ => {
            return Err(Error::new_err(format!(
                "{name}: expected shape (N, {K}) or ({K},), got {shape:?}"
            )))
        }
    };
    let flat: Vec<f32> = v.iter().copied().collect();
    Ok((0..n)
        .map(|i| std::array::from_fn(|j| flat[K * i + j]))
        .collect())
}

/// The number of queries from two row counts, broadcasting a single row against N.
fn broadcast(a: (&str, usize), b: (&str, usize)) -> PyResult<usize> {
    match (a.1, b.1) {
        (x, y) if x == y => Ok(x),
        (1, y) => Ok(y),
        (x, 1) => Ok(x),
        (x, y) => Err(Error::new_err(format!(
            "{} has {x} rows and {} {y}: give as many of each, or one of either",
            a.0, b.0
        ))),
    }
}

/// Row i of a broadcast argument.
fn at<T: Copy>(v: &[T], i: usize) -> T {
    v[if v.len() == 1 { 0 } else { i }]
}

#[pymethods]
impl Material {
    /// Opens a file held in memory (the bytes of a .sbrdf file).
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let owned = data.to_vec();
        let dec = py
            .allow_threads(|| Decoder::from_bytes(&owned))
            .map_err(err)?;
        Ok(Material {
            dec,
            name: "<bytes>".into(),
            bytes: data.len() as u64,
        })
    }

    /// ρ(wi, wo, λ) in 1/sr, shape (N, M), float32: wi and wo are unit vectors in the local
    /// frame (z the normal; wi toward the light, wo toward the viewer), shape (N, 3) or (3,);
    /// wavelengths in nm, shape (M,) for every row, or (N, M) (or (1, M)) for a list per row,
    /// as a spectral renderer draws them per path. Outside the file's wavelength range the
    /// end values are held. Below the horizon, 0. The GIL is released while it runs; with one
    /// list for every row the rows go through the decoder's batch entry point
    /// (`Decoder::eval_batch`).
    fn eval<'py>(
        &self,
        py: Python<'py>,
        wi: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
        wo: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
        wavelengths: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let wi = rows::<3>("wi", &wi)?;
        let wo = rows::<3>("wo", &wo)?;
        let n = broadcast(("wi", wi.len()), ("wo", wo.len()))?;
        let wv = wavelengths.as_array();
        let (wl_rows, m) = match wv.shape() {
            [m] => (1, *m),
            [r, m] => (*r, *m),
            s => {
                return Err(Error::new_err(format!(
                    "wavelengths: expected shape (M,) or (N, M), got {s:?}"
                )))
            }
        };
        let n = if wv.ndim() == 2 {
            broadcast(("wi and wo", n), ("wavelengths", wl_rows))?
        } else {
            n
        };
        let wl: Vec<f32> = wv.iter().copied().collect();
        let dec = &self.dec;
        // The batch entry point: the incident side once per run of rows with the same wi (all
        // of them when wi is one vector), the spectral basis once per wavelength.
        let out = py.allow_threads(|| {
            let mut out = vec![0.0f32; n * m];
            if wl_rows == 1 {
                return dec.eval_batch(&wi, &wo, &wl, &mut out).map(|()| out);
            }
            if m > 0 {
                for (i, row) in out.chunks_mut(m).enumerate() {
                    dec.eval(at(&wi, i), at(&wo, i), &wl[i * m..(i + 1) * m], row);
                }
            }
            Ok(out)
        });
        let out = out.map_err(err)?;
        PyArray1::from_vec(py, out).reshape([n, m])
    }

    /// ρ(wi, wo) as linear sRGB (1/sr), shape (N, 3), float32: the spectrum evaluated at
    /// 380–780 nm every 5 nm and integrated against the CIE 1931 2° observer under D65, then the
    /// sRGB matrix (`Decoder::eval_linear_srgb`): a spectrum constant at 1 gives (1, 1, 1).
    /// Saturated spectra can give negative components (outside the sRGB gamut); they are
    /// returned as they are. Shapes of wi and wo as for `eval`. Releases the GIL.
    fn eval_rgb<'py>(
        &self,
        py: Python<'py>,
        wi: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
        wo: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let wi = rows::<3>("wi", &wi)?;
        let wo = rows::<3>("wo", &wo)?;
        let n = broadcast(("wi", wi.len()), ("wo", wo.len()))?;
        let dec = &self.dec;
        let out = py.allow_threads(|| {
            let mut out = Vec::with_capacity(3 * n);
            for i in 0..n {
                let rgb = dec.eval_linear_srgb(at(&wi, i), at(&wo, i), Illuminant::D65);
                out.extend(rgb.map(|v| v as f32));
            }
            out
        });
        PyArray1::from_vec(py, out).reshape([n, 3])
    }

    /// Importance sampling of wo for wi (shape (N, 3) or (3,)) from uniform numbers u in
    /// [0, 1)² (shape (N, 2) or (2,)), from the spectrum-averaged BRDF × cos θo: returns
    /// (wo of shape (N, 3), pdf of shape (N,)), the density over solid angle in 1/sr; pdf 0 and
    /// wo 0 where no direction can be drawn (wi below the horizon). Releases the GIL.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        wi: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
        u: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
    ) -> PyResult<Sampled<'py>> {
        let wi = rows::<3>("wi", &wi)?;
        let us = rows::<2>("u", &u)?;
        let n = broadcast(("wi", wi.len()), ("u", us.len()))?;
        let dec = &self.dec;
        let (wos, pdfs) = py.allow_threads(|| {
            let mut wos = vec![0.0f32; 3 * n];
            let mut pdfs = vec![0.0f32; n];
            for i in 0..n {
                if let Some(s) = dec.sample(at(&wi, i), at(&us, i)) {
                    wos[3 * i..3 * i + 3].copy_from_slice(&s.wo);
                    pdfs[i] = s.pdf;
                }
            }
            (wos, pdfs)
        });
        Ok((
            PyArray1::from_vec(py, wos).reshape([n, 3])?,
            PyArray1::from_vec(py, pdfs),
        ))
    }

    /// The density (1/sr) with which `sample` draws wo for wi; shapes as for `eval`, result (N,).
    fn pdf<'py>(
        &self,
        py: Python<'py>,
        wi: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
        wo: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let wi = rows::<3>("wi", &wi)?;
        let wo = rows::<3>("wo", &wo)?;
        let n = broadcast(("wi", wi.len()), ("wo", wo.len()))?;
        let dec = &self.dec;
        let out = py.allow_threads(|| {
            (0..n)
                .map(|i| dec.pdf(at(&wi, i), at(&wo, i)))
                .collect::<Vec<f32>>()
        });
        Ok(PyArray1::from_vec(py, out))
    }

    /// The description `sbrdf info --json` prints, as a dict.
    #[getter]
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text =
            sbrdf::encode::info::to_json(self.dec.material(), &self.name, self.bytes).to_string();
        py.import("json")?.call_method1("loads", (text,))
    }

    /// The file's wavelength samples, nm.
    #[getter]
    fn wavelengths<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        PyArray1::from_vec(py, self.dec.material().wavelengths.clone())
    }

    fn __repr__(&self) -> String {
        let m = self.dec.material();
        format!(
            "<sbrdf.Material {}: {} incidences, {} wavelengths, {} bytes>",
            self.name,
            m.records.len(),
            m.wavelengths.len(),
            self.bytes
        )
    }
}

/// Opens a .sbrdf file.
#[pyfunction]
fn open(py: Python<'_>, path: PathBuf) -> PyResult<Material> {
    let name = path.display().to_string();
    let dec = py.allow_threads(|| Decoder::open(&path)).map_err(err)?;
    let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    Ok(Material { dec, name, bytes })
}

/// What the RGL reader makes of an RGL material-database file (`.bsdf`, the tensor files
/// Mitsuba 3's `measured` plugin loads): a dict with `description`, `channels` ("rgb" or
/// "spectral"), `wavelengths` (nm, spectral files), and `incidences`, a list with one dict per
/// stored incidence with θi ≤ `max_theta_i` degrees: `theta_index`, `theta_i`, `phi_i`
/// (degrees), `theta_o`, `phi_o` (degrees, shape (K,): the outgoing directions above the
/// horizon, nodes sharing a direction averaged), `nodes` (K, 2) (grid row and column of each,
/// column 0 being the mirror direction), `values` (K, C) float64, the BRDF in 1/sr (RGB or one
/// column per wavelength) exactly as read, not converted. What `encode` reads from the file.
#[pyfunction]
#[pyo3(signature = (path, max_theta_i = sbrdf::io::rgl::MAX_THETA_I))]
fn read_rgl<'py>(py: Python<'py>, path: PathBuf, max_theta_i: f64) -> PyResult<Bound<'py, PyDict>> {
    use sbrdf::io::rgl::{Channels, RglBsdf};
    let name = path.display().to_string();
    let bytes = std::fs::read(&path).map_err(|e| Error::new_err(format!("{name}: {e}")))?;
    let (bsdf, incs) = py
        .allow_threads(|| {
            let b = RglBsdf::from_bytes(&bytes)?;
            let s = b.samples(max_theta_i, 90.0)?;
            Ok((b, s))
        })
        .map_err(|e: sbrdf::io::rgl::RglError| Error::new_err(format!("{name}: {e}")))?;
    let d = PyDict::new(py);
    d.set_item("description", bsdf.description.clone())?;
    match &bsdf.channels {
        Channels::Rgb => d.set_item("channels", "rgb")?,
        Channels::Spectral { wavelengths } => {
            d.set_item("channels", "spectral")?;
            d.set_item("wavelengths", PyArray1::from_vec(py, wavelengths.clone()))?;
        }
    }
    let nc = bsdf.channel_count();
    let list = PyList::empty(py);
    for s in incs {
        let k = s.directions.len();
        let e = PyDict::new(py);
        e.set_item("theta_index", s.index[0])?;
        e.set_item("theta_i", s.theta_i)?;
        e.set_item("phi_i", s.phi_i)?;
        let to: Vec<f64> = s.directions.iter().map(|d| d[0]).collect();
        let po: Vec<f64> = s.directions.iter().map(|d| d[1]).collect();
        e.set_item("theta_o", PyArray1::from_vec(py, to))?;
        e.set_item("phi_o", PyArray1::from_vec(py, po))?;
        let nodes: Vec<u32> = s.nodes.iter().flatten().copied().collect();
        e.set_item("nodes", PyArray1::from_vec(py, nodes).reshape([k, 2])?)?;
        e.set_item("values", PyArray1::from_vec(py, s.values).reshape([k, nc])?)?;
        list.append(e)?;
    }
    d.set_item("incidences", list)?;
    Ok(d)
}

/// An option value as the command line would spell it.
fn option_text(name: &str, v: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    if let Ok(b) = v.extract::<bool>() {
        return Ok(vec![b.to_string()]);
    }
    if let Ok(d) = v.downcast::<PyDict>() {
        // metadata={"source": "lab 4"}: one KEY=VALUE each.
        return d
            .iter()
            .map(|(k, v)| Ok(format!("{}={}", k.str()?, v.str()?)))
            .collect();
    }
    if v.downcast::<PyList>().is_ok() || v.downcast::<PyTuple>().is_ok() {
        let items: Vec<String> = v
            .try_iter()?
            .map(|x| Ok(x?.str()?.to_string()))
            .collect::<PyResult<_>>()?;
        return Ok(if name == "metadata" {
            items
        } else {
            vec![items.join(",")]
        });
    }
    Ok(vec![v.str()?.to_string()])
}

/// Encodes samples into a .sbrdf file at `out_path` (written atomically) and returns a summary
/// dict (bytes, rel_error, worst_error, messages; noise_floor for an RGL file's warped
/// tables). `samples` is a dict of equally long arrays named like the long CSV layout's
/// columns (theta_i, phi_i, theta_o, phi_o in degrees, wavelength_nm, value in 1/sr), or a
/// path (CSV, EXR slice, folder) or a list of paths.
/// Keyword options are `sbrdf encode`'s, with `_` for `-`: basis="cosine", terms=5,
/// max_error=0.01, best_effort=True, lobes=["gaussian"], metadata={"source": "lab"}, …
#[pyfunction]
#[pyo3(signature = (samples, out_path, **options))]
fn encode(
    py: Python<'_>,
    samples: &Bound<'_, PyAny>,
    out_path: PathBuf,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyObject> {
    let mut settings = EncodeSettings::default();
    if let Some(opts) = options {
        for (k, v) in opts.iter() {
            let name: String = k.extract()?;
            for text in option_text(&name, &v)? {
                settings.set(&name, &text).map_err(err)?;
            }
        }
    }
    let (set, report, inputs) = if let Ok(d) = samples.downcast::<PyDict>() {
        let mut columns: Vec<Vec<f64>> = Vec::with_capacity(6);
        for c in sbrdf::io::COLUMNS {
            let v = d.get_item(c)?.ok_or_else(|| {
                Error::new_err(format!(
                    "samples: no '{c}' array (give {})",
                    sbrdf::io::COLUMNS.join(", ")
                ))
            })?;
            let a: PyArrayLike1<'_, f64, AllowTypeChange> = v.extract()?;
            columns.push(a.as_array().iter().copied().collect());
        }
        let refs: [&[f64]; 6] = std::array::from_fn(|i| columns[i].as_slice());
        let (set, report) = sbrdf::io::samples_from_columns("samples", refs).map_err(err)?;
        (set, report, vec!["<arrays>".to_string()])
    } else {
        let paths: Vec<PathBuf> = if let Ok(p) = samples.extract::<PathBuf>() {
            vec![p]
        } else {
            samples.extract::<Vec<PathBuf>>().map_err(|_| {
                Error::new_err("samples: expected a dict of arrays, a path or a list of paths")
            })?
        };
        // One RGL file: warped tables, as `sbrdf encode` writes them (the same library call).
        let warped = py
            .allow_threads(|| -> sbrdf::Result<_> {
                let Some(o) = sbrdf::io::rgl::encode_warped_file(&paths, &settings)? else {
                    return Ok(None);
                };
                sbrdf::io::output::write_bytes_atomic(&out_path, &o.bytes)?;
                Ok(Some(o))
            })
            .map_err(err)?;
        if let Some(o) = warped {
            let d = PyDict::new(py);
            d.set_item("bytes", o.bytes.len())?;
            d.set_item("rel_error", o.worst_error())?;
            d.set_item("worst_error", o.worst_error())?;
            d.set_item("noise_floor", o.noise_floor())?;
            d.set_item("messages", o.messages)?;
            return Ok(d.into_any().unbind());
        }
        let (set, report) = py
            .allow_threads(|| sbrdf::io::read_inputs_with(&paths, &settings.read))
            .map_err(err)?;
        let names = paths.iter().map(|p| p.display().to_string()).collect();
        (set, report, names)
    };
    let outcome = py
        .allow_threads(|| -> sbrdf::Result<_> {
            let o = encode_samples(set, &report, &inputs, &settings)?;
            sbrdf::io::output::write_bytes_atomic(&out_path, &o.bytes)?;
            Ok(o)
        })
        .map_err(err)?;
    let worst = outcome
        .encoded
        .material
        .records
        .iter()
        .map(|r| r.rel_error as f64)
        .fold(0.0, f64::max);
    let d = PyDict::new(py);
    d.set_item("bytes", outcome.bytes.len())?;
    d.set_item("rel_error", outcome.encoded.rel_error)?;
    d.set_item("worst_error", worst)?;
    d.set_item("messages", outcome.messages)?;
    Ok(d.into_any().unbind())
}

#[pymodule]
fn _sbrdf(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_class::<Material>()?;
    m.add_function(wrap_pyfunction!(open, m)?)?;
    m.add_function(wrap_pyfunction!(encode, m)?)?;
    m.add_function(wrap_pyfunction!(read_rgl, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
