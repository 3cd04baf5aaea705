"""Result classes: the dicts gloam's calls return, with attribute access.

Every JSON object a call returns (the documents the CLI writes as JSON) is
a :class:`Result`: a ``dict`` (``r["mtf50"]``, ``json.dumps(r)``, ``r ==
{...}`` keep working) whose keys are also attributes (``r.mtf50``), with a
readable ``repr`` and :meth:`Result.to_dict` for a plain copy. The named
subclasses say what a call returned; their fields are the CLI's JSON keys.
"""

import json

__all__ = [
    "Result",
    "Effect",
    "RenderReport",
    "Probe",
    "SensorDescription",
    "FrameRecord",
    "FrameMeta",
    "RadianceCalibration",
    "PhotonTransfer",
    "Mtf",
    "AgcLinearity",
    "Comparison",
    "Scope",
    "Ephemeris",
    "SkyIlluminance",
    "SweepResult",
]

_SHOWN = 12


def _short(v):
    """A value's short form for a repr: lists and dicts summarised."""
    if isinstance(v, dict):
        return "{…%d fields}" % len(v)
    if isinstance(v, (list, tuple)):
        if len(v) <= 4 and all(isinstance(x, (int, float, str, type(None))) for x in v):
            return repr(list(v))
        return "[%d items]" % len(v)
    if isinstance(v, float):
        return "%.6g" % v
    shape = getattr(v, "shape", None)
    if shape is not None:
        return "array%s %s" % (tuple(shape), getattr(v, "dtype", ""))
    r = repr(v)
    return r if len(r) <= 60 else r[:57] + "…"


class Result(dict):
    """A dict with attribute access: ``r.key`` is ``r["key"]``.

    What gloam's calls return for the JSON documents the CLI writes; the
    keys are the CLI's JSON keys (``gloam … --json``).
    """

    __slots__ = ()

    def __getattr__(self, name):
        """``r.key`` for ``r["key"]``; AttributeError naming the fields."""
        try:
            return self[name]
        except KeyError:
            fields = ", ".join(k for k in self if isinstance(k, str))
            raise AttributeError(f"{type(self).__name__} has no field {name!r} (fields: {fields})") from None

    def __dir__(self):
        """Attributes and the keys that are identifiers (tab completion)."""
        return sorted(set(super().__dir__()) | {k for k in self if isinstance(k, str) and k.isidentifier()})

    def to_dict(self):
        """A plain ``dict`` copy (nested results as plain dicts and lists)."""
        return _plain(self)

    def __repr__(self):
        """``Name(key=value, …)``: scalars in full, lists and dicts summarised."""
        items = list(self.items())
        parts = [f"{k}={_short(v)}" for k, v in items[:_SHOWN]]
        if len(items) > _SHOWN:
            parts.append(f"… {len(items) - _SHOWN} more")
        one = f"{type(self).__name__}({', '.join(parts)})"
        if len(one) <= 100:
            return one
        return f"{type(self).__name__}(\n" + "".join(f"    {p},\n" for p in parts) + ")"

    def _repr_pretty_(self, p, cycle):
        """IPython's pretty printer: the same as ``repr``."""
        p.text(repr(self))


def _plain(v):
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_plain(x) for x in v]
    return v


def _kind(name, doc):
    cls = type(name, (Result,), {"__slots__": (), "__doc__": doc, "__module__": "gloam"})
    return cls


Effect = _kind("Effect", "One entry of the effect plan: name, enabled, reason, estimated_share.")
RenderReport = _kind("RenderReport", "A render's report.json: settings, effect_plan, timings_s, rays, bands, …")
Probe = _kind("Probe", "Irradiance at a point: band, irradiance_w_m2, std_error_w_m2, radiance_w_m2_sr.")
SensorDescription = _kind(
    "SensorDescription", "A camera's derived figures at a gain (gloam sensor describe --json)."
)
FrameRecord = _kind(
    "FrameRecord", "A captured frame's frames.jsonl record: gain, agc, mean_dn, saturated_fraction, pixels_crc32c, …"
)
FrameMeta = _kind("FrameMeta", "A grabbed frame's metadata: seq, timestamp_us, gain, agc, bits, width, height, …")
RadianceCalibration = _kind(
    "RadianceCalibration", "A radiance LUT (lut.json): per gain the fitted line g, b and its levels."
)
PhotonTransfer = _kind(
    "PhotonTransfer", "EMVA 1288 photon transfer (ptc.json): system_gain_dn_per_e, dark_noise_e, …"
)
Mtf = _kind(
    "Mtf",
    "An MTF curve: method, frequencies_cy_per_px, mtf, mtf50, mtf10 (voltage space: also curves, details).",
)
AgcLinearity = _kind("AgcLinearity", "The AGC staircase (agc.json): settling, overshoot, hysteresis, linearity.")
Comparison = _kind("Comparison", "Two images compared over regions: spearman_rho, rms, regions.")
Scope = _kind("Scope", "Scan lines on the oscilloscope: sensor, format, pixel_clock_hz, readouts, lines.")
Ephemeris = _kind("Ephemeris", "Moon and Sun positions and the lunar phase: moon, sun, illuminated_fraction, …")
SkyIlluminance = _kind("SkyIlluminance", "Night illuminance on the ground: illuminance_lux, ephemeris, spectra.")
SweepResult = _kind("SweepResult", "A sweep run: dir, tasks, ran, skipped, failed, results (results.json rows).")

_CLASSES = {c.__name__: c for c in (Result,) + tuple(globals()[n] for n in __all__[1:])}


def load(text, kind=""):
    """JSON text as results: every object a Result, the top level (or each
    item of a top-level list) of class ``kind`` (used by the extension)."""
    v = json.loads(text, object_hook=Result)
    cls = _CLASSES.get(kind) if kind else None
    if cls is not None:
        if isinstance(v, dict):
            v = cls(v)
        elif isinstance(v, list):
            v = [cls(x) if isinstance(x, dict) else x for x in v]
    return v
