"""gloam from Python: low-light-level imaging with NumPy arrays in and out.

The heavy work runs in gloam's Rust crates (no subprocess): the spectral ray
tracer (:func:`render`, :func:`probe`, :class:`Scene`), the intensified
camera chain (:class:`Sensor`), frame grabbers (:func:`open_grabber`), the
calibration flows (:func:`calibrate_radiance`, :func:`photon_transfer`,
:func:`mtf`, :func:`agc_linearity`, :func:`compare`, :class:`Lut`) and the
night sky (:func:`ephem`, :func:`sky`).

Long calls release the GIL (a thread pool of renders or captures uses every
core) and honour Ctrl-C (``KeyboardInterrupt``). Errors are
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
    sky,
)

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
    "sky",
]
