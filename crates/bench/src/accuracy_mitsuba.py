# gloam bench accuracy: the same scene in Mitsuba 3, for a side-by-side
# ladder of per-pixel error against time. Run by
# crates/bench/src/accuracy_mitsuba.rs as
# `python3 THIS DIR`; DIR holds `scene.json` (written by that module: the
# loaded scene's facets as one OBJ per material, each band's reflectance
# and emitted radiance, the camera, the spp ladder) and receives one raw
# little-endian float32 image per rung (`mi-<depth>-<spp>.f32`, height x
# width x 3, channel k = band k) and `mitsuba.json` (the times).
#
# Mitsuba's `path` integrator in the llvm_ad_rgb variant (scalar_rgb where
# LLVM cannot start): with spectrally
# flat reflectances each band is an independent grey transport, so the
# three RGB channels carry up to three bands exactly. `max_depth` -1 is the
# whole light (Russian roulette after 5 bounces), 2 is direct light only.
import array
import glob
import json
import os
import sys
import time

t_start = time.perf_counter()
# Dr.Jit's LLVM backend needs a recent libLLVM; offer Debian's when the
# user has not named one (without it the llvm variant cannot start).
if "DRJIT_LIBLLVM_PATH" not in os.environ:
    for cand in sorted(glob.glob("/usr/lib/*/libLLVM-1[7-9]*.so") + glob.glob("/usr/lib/*/libLLVM-2[0-9]*.so"), reverse=True):
        os.environ["DRJIT_LIBLLVM_PATH"] = cand
        break
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402


def pick_variant():
    """Mitsuba's fastest CPU variant that runs here: the vectorised,
    multi-threaded llvm_ad_rgb, else scalar_rgb."""
    for v in ("llvm_ad_rgb", "scalar_rgb"):
        if v not in mi.variants():
            continue
        try:
            mi.set_variant(v)
            probe = mi.load_dict({"type": "scene", "integrator": {"type": "path"}, "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 4, "height": 4}}})
            mi.render(probe, spp=1)
            return v
        except Exception as e:  # noqa: BLE001
            print(f"mitsuba variant {v} unavailable: {e}", file=sys.stderr)
    raise SystemExit("no usable Mitsuba 3 CPU variant")


variant = pick_variant()
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
warmup_s = {}
runs = []
for depth, ladder in s["ladders"]:
    # (Mitsuba splits a large spp into passes itself, bounding memory.)
    d["integrator"] = {"type": "path", "max_depth": depth}
    t0 = time.perf_counter()
    scene = mi.load_dict(d)
    if load_s is None:
        load_s = time.perf_counter() - t0
    # One untimed 1-spp render compiles (llvm) the kernels every rung
    # reuses; its time is reported apart as the JIT's.
    t0 = time.perf_counter()
    dr.eval(mi.render(scene, spp=1, seed=s["seed"] + 1))
    dr.sync_thread()
    warmup_s[str(depth)] = time.perf_counter() - t0
    last_s, t_ladder, limit = 0.0, time.perf_counter(), s["time_limit_s"] / len(s["ladders"])
    for spp in ladder:
        # Each ladder has its share of the time limit; it stops climbing
        # when the next rung (about 4x the last) would pass it.
        if last_s > 0.0 and time.perf_counter() - t_ladder + 4.0 * last_s > limit:
            break
        t0 = time.perf_counter()
        img = mi.render(scene, spp=spp, seed=s["seed"])
        # The llvm variant records lazily: the time counts once the image
        # is computed.
        dr.eval(img)
        dr.sync_thread()
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
            "variant": variant,
            "warmup_s": warmup_s,
            "threads": os.cpu_count(),
            "load_s": load_s,
            "runs": runs,
            "total_s": time.perf_counter() - t_start,
        },
        f,
    )
