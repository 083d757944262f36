"""sbrdf: compact spectral BRDFs from Python.

    import numpy as np, sbrdf
    m = sbrdf.open("material.sbrdf")
    wi = np.array([0.0, 0.0, 1.0])                      # toward the light, local frame
    wo = np.array([[0.3, 0.0, 0.954], [0.0, 0.5, 0.866]]) # toward the viewer, (N, 3)
    rho = m.eval(wi, wo, [450.0, 550.0, 650.0])          # (2, 3) float32, 1/sr
    sbrdf.encode({"theta_i": ..., "phi_i": ..., "theta_o": ..., "phi_o": ...,
                  "wavelength_nm": ..., "value": ...}, "out.sbrdf", max_error=0.01)

Everything runs in the Rust crate `sbrdf`; errors raise `sbrdf.Error` (a ValueError) with the
command line's messages. `import sbrdf.mitsuba` registers the BSDF type `sbrdf` with Mitsuba 3.
"""

from ._sbrdf import Error, Material, __version__, encode, open, read_rgl

__all__ = ["Error", "Material", "encode", "open", "read_rgl", "__version__"]
