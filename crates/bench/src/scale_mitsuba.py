# gloam bench scale: the same generated scene in Mitsuba 3, for a side-by-side
# of load (preparation) time, render time and peak memory. Run by
# crates/bench/src/scale.rs as `python3 THIS SCENE_DIR SPP`; prints
# one JSON object. Reads the scene.toml the bench generated (boxes, quads,
# OBJ files, point sources) with tomllib (Python >= 3.11).
#
# Not the same estimator: Mitsuba's `path` integrator (max_depth 3: direct
# light and one diffuse bounce) in the scalar_rgb variant, flat RGB spectra,
# and isotropic `point` lights (Mitsuba has no cos^m point emitter). The
# figures compare cost, not images.
import json
import os
import resource
import sys
import time

t_start = time.perf_counter()
import tomllib  # noqa: E402

import mitsuba as mi  # noqa: E402

mi.set_variant("scalar_rgb")
T = mi.ScalarTransform4f

scene_dir, spp = sys.argv[1], int(sys.argv[2])
with open(os.path.join(scene_dir, "scene.toml"), "rb") as f:
    s = tomllib.load(f)


def band_value(spec):
    """Radiance or intensity per nm from a gloam `normalize` over the band."""
    n = spec.get("normalize")
    if n:
        return n["value"] / (n["hi_nm"] - n["lo_nm"])
    return float(spec.get("value", 1.0))


def bsdf(mat):
    r = mat.get("reflectance", 0.0)
    r = r if isinstance(r, (int, float)) else 0.5
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [r, r, r]}}


mats = s.get("materials", {})
cam = s["camera"]
d = {
    "type": "scene",
    "integrator": {"type": "path", "max_depth": 3},
    "sensor": {
        "type": "perspective",
        "fov": cam["fov_deg"],
        "fov_axis": "x",
        "to_world": T().look_at(origin=cam["position"], target=cam["look_at"], up=cam.get("up", [0, 0, 1])),
        "film": {"type": "hdrfilm", "width": cam["width"], "height": cam["height"], "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": spp},
    },
}
for name, o in s.get("objects", {}).items():
    mat = mats[o["material"]]
    shape = {"bsdf": bsdf(mat)}
    if "emission" in mat:
        v = band_value(mat["emission"])
        shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": [v, v, v]}}
    if "box" in o:
        lo, hi = o["box"]["min"], o["box"]["max"]
        c = [(a + b) / 2 for a, b in zip(lo, hi)]
        h = [(b - a) / 2 for a, b in zip(lo, hi)]
        shape.update(type="cube", to_world=T().translate(c) @ T().scale(h), flip_normals=bool(o["box"].get("inward", False)))
    elif "quad" in o:
        q = o["quad"]
        c, n = q["center"], q["normal"]
        up = [0, 1, 0] if abs(n[2]) > 0.9 else [0, 0, 1]
        target = [a + b for a, b in zip(c, n)]
        shape.update(type="rectangle", to_world=T().look_at(origin=c, target=target, up=up) @ T().scale([q["size"][0] / 2, q["size"][1] / 2, 1]))
    elif "obj" in o:
        shape.update(type="obj", filename=os.path.join(scene_dir, o["obj"]), face_normals=True)
    else:
        continue
    d[name] = shape
for name, p in s.get("point_sources", {}).items():
    v = band_value(p)
    d["light-" + name] = {"type": "point", "position": p["position"], "intensity": {"type": "rgb", "value": [v, v, v]}}

t0 = time.perf_counter()
scene = mi.load_dict(d)
t1 = time.perf_counter()
img = mi.render(scene, spp=spp)
_ = float(mi.TensorXf(img).array[0])  # make sure the render is done
t2 = time.perf_counter()
faces = 0
for sh in scene.shapes():
    faces += sh.face_count() if sh.is_mesh() else 2
print(json.dumps({
    "variant": mi.variant(),
    "version": mi.__version__,
    "integrator": "path, max_depth 3 (direct + one bounce), isotropic point lights",
    "triangles": faces,
    "emitters": len(scene.emitters()),
    "import_s": t0 - t_start,
    "load_s": t1 - t0,
    "render_s": t2 - t1,
    "peak_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
}))
