"""The EMVA 1288 dataset `gloam calibrate ptc` writes, read by the reference
analysis (the PyPI `emva1288` package): the package must find saturation
within 5 % of the scientific CCD's 100 000 e⁻ full well, and the exposure
times the rig gives (1 s), not 0."""

import logging
import subprocess

import numpy as np
import pytest

emva = pytest.importorskip("emva1288.process")

# emva1288 1.0.2 calls np.asfarray, which NumPy 2 removed.
if not hasattr(np, "asfarray"):
    np.asfarray = lambda a, dtype=float: np.asarray(a, dtype=dtype)


def test_reference_analysis_finds_the_full_well(repo, gloam_bin, tmp_path):
    out = tmp_path / "ptc"
    subprocess.run(
        [gloam_bin, "calibrate", "ptc", "--grabber", "sim:scientific-ccd?size=128x128",
         "--source", str(repo / "sims/calibration/sphere.toml"),
         "--levels", "50", "--gain", "1", "--auto-range", "1.4", "--out", str(out)],
        check=True, capture_output=True,
    )
    desc = out / "emva1288" / "emva1288_descriptor.txt"
    p = emva.ParseEmvaDescriptorFile(str(desc), loglevel=logging.WARNING)
    d = emva.Data1288(emva.LoadImageData(p.images, loglevel=logging.WARNING).data,
                      loglevel=logging.WARNING)
    r = emva.Results1288(d.data, loglevel=logging.WARNING)
    assert set(d.data["temporal"]["texp"]) == {1e9}  # ns
    assert r.u_e_sat == pytest.approx(100_000, rel=0.05)
    # Its K (a line through the origin, unweighted) against the preset's
    # 1/1.6 DN/e⁻, and its η against the preset's QE under CIE A (0.4986).
    assert r.K == pytest.approx(0.625, rel=0.02)
    assert r.QE / 100 == pytest.approx(0.4986, rel=0.02)
