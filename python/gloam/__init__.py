"""gloam from Python: low-light-level imaging with NumPy arrays in and out.

The heavy work runs in gloam's Rust crates (no subprocess): the spectral ray
tracer (:func:`render`, :func:`probe`, :class:`Scene`), the intensified
camera chain (:class:`Sensor`), frame grabbers (:func:`open_grabber`), the
calibration flows (:func:`calibrate_radiance`, :func:`photon_transfer`,
:func:`mtf` — also in voltage space —, :func:`agc_linearity`,
:func:`compare`, :class:`Lut`), the oscilloscope (:func:`scope`), sweeps
(:func:`sweep`) and the night sky (:func:`ephem`, :func:`sky`).

Results are classes with attributes and a readable ``repr``: arrays on
:class:`RenderResult`, :class:`Capture` and :class:`Frame`, and the CLI's
JSON documents as :class:`Result` subclasses (``r.mtf50``), which are
dicts too (``r["mtf50"]``, ``r.to_dict()``). Images are accepted in any
float dtype and memory layout. Renders, captures and sweeps take
``progress=True`` (a tqdm bar when tqdm is installed) or a callable
``progress(done, total, what)``.

Long calls release the GIL (a thread pool of renders or captures uses every
core) and honour Ctrl-C (``KeyboardInterrupt``), a render's scene
preparation included. Errors are
:class:`GloamError` (a ``ValueError``) with the CLI's message, e.g.
``scene.toml:15: materials.wall.reflectance: …``. Seeds give results
bit-identical to the ``gloam`` CLI's files.
"""

from ._gloam import (
    Capture,
    Frame,
    FrameStream,
    GloamError,
    Grabber,
    Lut,
    RenderResult,
    Scene,
    Sensor,
    __version__,
    agc_linearity,
    calibrate_radiance,
    compare,
    ephem,
    mtf,
    open_grabber,
    photon_transfer,
    probe,
    render,
    scope,
    sky,
    sweep,
)
from . import _results
from ._results import *  # noqa: F403 -- the result classes, named once in _results.__all__

__all__ = [
    "Capture",
    "Frame",
    "FrameStream",
    "GloamError",
    "Grabber",
    "Lut",
    "RenderResult",
    "Scene",
    "Sensor",
    "__version__",
    "agc_linearity",
    "calibrate_radiance",
    "compare",
    "ephem",
    "mtf",
    "open_grabber",
    "photon_transfer",
    "probe",
    "render",
    "scope",
    "sky",
    "sweep",
]
# The static form type checkers read (pyright, mypy) for a submodule's names.
__all__ += _results.__all__
