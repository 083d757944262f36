from os import PathLike
from typing import Any, Dict, Mapping, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class Error(ValueError):
    """Bad input or a damaged file; the message is the command line's."""

_Path = Union[str, PathLike[str]]

class Material:
    """An opened .sbrdf file."""

    @staticmethod
    def from_bytes(data: bytes) -> Material:
        """Opens a file held in memory."""
    def eval(
        self,
        wi: npt.ArrayLike,
        wo: npt.ArrayLike,
        wavelengths: npt.ArrayLike,
    ) -> npt.NDArray[np.float32]:
        """ρ(wi, wo, λ) in 1/sr, shape (N, M): wi, wo unit vectors (local frame, z the normal;
        wi toward the light, wo toward the viewer) of shape (N, 3) or (3,); wavelengths in nm,
        shape (M,) for every row or (N, M) per row (outside the file's range the end values
        are held). Vectorised; releases the GIL."""
    def eval_rgb(self, wi: npt.ArrayLike, wo: npt.ArrayLike) -> npt.NDArray[np.float32]:
        """ρ(wi, wo) as linear sRGB, shape (N, 3): the spectrum at 380–780 nm every 5 nm
        through the CIE 1931 2° observer under D65 and the sRGB matrix (constant 1 gives
        (1, 1, 1)); out-of-gamut components stay negative. Releases the GIL."""
    def sample(
        self, wi: npt.ArrayLike, u: npt.ArrayLike
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
        """Importance-samples wo for wi ((N, 3) or (3,)) from uniform u ((N, 2) or (2,)):
        (wo (N, 3), pdf (N,)) over solid angle, 1/sr; pdf 0 where nothing can be drawn."""
    def pdf(self, wi: npt.ArrayLike, wo: npt.ArrayLike) -> npt.NDArray[np.float32]:
        """The density with which `sample` draws wo for wi, shape (N,)."""
    @property
    def info(self) -> Dict[str, Any]:
        """What `sbrdf info --json` prints."""
    @property
    def wavelengths(self) -> npt.NDArray[np.float32]:
        """The file's wavelength samples, nm."""

def open(path: _Path) -> Material:
    """Opens a .sbrdf file."""

def read_rgl(path: _Path, max_theta_i: float = 85.0) -> Dict[str, Any]:
    """What the RGL reader makes of an RGL `.bsdf` file: description, channels ("rgb" or
    "spectral"), wavelengths (spectral files), and per stored incidence with θi ≤ max_theta_i a
    dict of theta_index, theta_i, phi_i, theta_o (K,), phi_o (K,), nodes (K, 2) and values
    (K, C) in 1/sr, exactly as read (RGB not converted)."""

def encode(
    samples: Union[Mapping[str, npt.ArrayLike], _Path, Sequence[_Path]],
    out_path: _Path,
    **options: Any,
) -> Dict[str, Any]:
    """Encodes samples (a dict of the long CSV layout's columns theta_i, phi_i, theta_o, phi_o,
    wavelength_nm, value; or CSV/EXR/RGL paths) into `out_path`, with `sbrdf encode`'s options
    as keywords (max_error=0.01, basis="cosine", rgb_to_spectrum="jakob-hanika-2019", ...).
    Returns bytes, rel_error, worst_error, messages. One RGL file is encoded as `sbrdf encode`
    encodes it, byte for byte (warped tables by default; model="warped" requires them,
    transform="dct"|"wavelet"|"auto" picks their transform); rel_error and worst_error are then
    the worst stored incidence's error, and noise_floor the measurement's noise as the encoder
    estimated it (worst incidence; the default budget codes no incidence below it)."""
