# gloam bench accuracy: the same scene in Mitsuba 3, for a side-by-side
# ladder of per-pixel error against time. Run by
# crates/pipeline/src/bench/accuracy_mitsuba.rs as
# `python3 THIS DIR`; DIR holds `scene.json` (written by that module: the
# loaded scene's facets as one OBJ per material, each band's reflectance
# and emitted radiance, the camera, the spp ladder) and receives one raw
# little-endian float32 image per rung (`mi-<depth>-<spp>.f32`, height x
# width x 3, channel k = band k) and `mitsuba.json` (the times).
#
# Mitsuba's `path` integrator in the scalar_rgb variant: with spectrally
# flat reflectances each band is an independent grey transport, so the
# three RGB channels carry up to three bands exactly. `max_depth` -1 is the
# whole light (Russian roulette after 5 bounces), 2 is direct light only.
import array
import json
import os
import sys
import time

t_start = time.perf_counter()
import mitsuba as mi  # noqa: E402

mi.set_variant("scalar_rgb")
T = mi.ScalarTransform4f

out_dir = sys.argv[1]
with open(os.path.join(out_dir, "scene.json"), "rb") as f:
    s = json.load(f)

cam = s["camera"]
d = {
    "type": "scene",
    "sensor": {
        "type": "perspective",
        "fov": cam["fov_deg"],
        "fov_axis": "x",
        "to_world": T().look_at(origin=cam["position"], target=cam["look_at"], up=cam["up"]),
        "film": {
            "type": "hdrfilm",
            "width": cam["width"],
            "height": cam["height"],
            "pixel_format": "rgb",
            "rfilter": {"type": "box"},
        },
        "sampler": {"type": s["sampler"], "sample_count": 1},
    },
}
for i, m in enumerate(s["meshes"]):
    shape = {"type": "obj", "filename": os.path.join(out_dir, m["obj"]), "face_normals": True}
    rho = {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["reflectance"]}}
    # gloam reflects on both faces of a facet; an emitter radiates from
    # its front face only, as Mitsuba's area emitter does.
    shape["bsdf"] = {"type": "twosided", "bsdf": rho}
    if m.get("emission") is not None:
        shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": m["emission"]}}
    d[f"mesh-{i}"] = shape

load_s = None
runs = []
for depth, ladder in s["ladders"]:
    d["integrator"] = {"type": "path", "max_depth": depth}
    t0 = time.perf_counter()
    scene = mi.load_dict(d)
    if load_s is None:
        load_s = time.perf_counter() - t0
    last_s, t_ladder, limit = 0.0, time.perf_counter(), s["time_limit_s"] / len(s["ladders"])
    for spp in ladder:
        # Each ladder has its share of the time limit; it stops climbing
        # when the next rung (about 4x the last) would pass it.
        if last_s > 0.0 and time.perf_counter() - t_ladder + 4.0 * last_s > limit:
            break
        t0 = time.perf_counter()
        img = mi.render(scene, spp=spp, seed=s["seed"])
        render_s = time.perf_counter() - t0
        last_s = render_s
        name = f"mi-{depth}-{spp}.f32"
        with open(os.path.join(out_dir, name), "wb") as f:
            array.array("f", img.array).tofile(f)
        runs.append({"max_depth": depth, "spp": spp, "render_s": render_s, "file": name})
        print(f"mitsuba max_depth {depth} spp {spp}: {render_s:.2f} s", file=sys.stderr, flush=True)

with open(os.path.join(out_dir, "mitsuba.json"), "w") as f:
    json.dump(
        {
            "version": mi.__version__,
            "variant": "scalar_rgb",
            "threads": os.cpu_count(),
            "load_s": load_s,
            "runs": runs,
            "total_s": time.perf_counter() - t_start,
        },
        f,
    )
