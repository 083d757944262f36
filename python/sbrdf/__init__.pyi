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
        shape (M,). Vectorised; releases the GIL."""
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

def encode(
    samples: Union[Mapping[str, npt.ArrayLike], _Path, Sequence[_Path]],
    out_path: _Path,
    **options: Any,
) -> Dict[str, Any]:
    """Encodes samples (a dict of the long CSV layout's columns theta_i, phi_i, theta_o, phi_o,
    wavelength_nm, value; or CSV/EXR paths) into `out_path`, with `sbrdf encode`'s options as
    keywords (max_error=0.01, basis="cosine", ...). Returns bytes, rel_error, worst_error,
    messages."""
