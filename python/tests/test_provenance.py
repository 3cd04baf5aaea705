"""A Python render lists the files it read as the CLI does: the scene and
every file the scene leads to (spectrum CSV, OBJ mesh, placements CSV),
each with the SHA-256 of its bytes, in the report's provenance."""

import hashlib
import json
import subprocess
from pathlib import Path

import gloam

SCENE = """units = "m"

[camera]
position = [0.0, -5.0, 1.5]
look_at = [0.0, 0.0, 1.0]
fov_deg = 60.0
width = 16
height = 12

[bands.vis]
lo_nm = 400
hi_nm = 700

[materials.grey]
reflectance = "paint.csv"

[objects.floor]
material = "grey"
quad = { center = [0.0, 0.0, 0.0], size = [10.0, 10.0], normal = [0.0, 0.0, 1.0] }

[objects.m]
material = "grey"
obj = "tri.obj"
instances_csv = "place.csv"
"""

FILES = {
    "paint.csv": "wavelength_nm,value\n400,0.2\n700,0.4\n",
    "tri.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "place.csv": "x,y,z,rotate_z_deg,scale\n0,0,0.5,0,1\n1,0,0.5,0,1\n",
    "s.toml": SCENE,
}


def scene_inputs(provenance, scene_dir):
    """The provenance's inputs inside `scene_dir`: canonical path → SHA-256."""
    listed = {}
    for i in provenance["inputs"]:
        p = Path(i["path"]).resolve()
        if p.parent == scene_dir:
            assert p not in listed, f"{p} listed twice"
            listed[p] = i["sha256"]
    return listed


def test_a_python_render_lists_the_scenes_obj_and_spectrum_as_the_cli_does(gloam_bin, tmp_path):
    scene_dir = (tmp_path / "scene").resolve()
    scene_dir.mkdir()
    for name, text in FILES.items():
        (scene_dir / name).write_text(text)
    truth = {scene_dir / n: hashlib.sha256(t.encode()).hexdigest() for n, t in FILES.items()}

    py = gloam.render(gloam.Scene.load(scene_dir / "s.toml"), spp=1)
    assert scene_inputs(py.report["provenance"], scene_dir) == truth

    out = tmp_path / "out"
    subprocess.run([gloam_bin, "render", scene_dir / "s.toml", "--spp", "1", "--out", out],
                   check=True, capture_output=True)
    for f in ["report.json", "manifest.json"]:
        cli = json.loads((out / f).read_text())["provenance"]
        assert scene_inputs(cli, scene_dir) == truth, f
