#!/usr/bin/env python3
"""Writes a generated night town: scene.toml plus building and window OBJ files.

    python3 sims/night-town/generate.py                      # the committed default
    python3 sims/night-town/generate.py --lamps 10 --windows 20 --out /tmp/town

A street grid of square blocks, box buildings (three facade finishes, a few
storeys, taller towards the centre), street lamps as shaped point sources
(high-pressure sodium, some old mercury-phosphor), lit windows as dim
emitting quads (incandescent and fluorescent), the half moon and the night
sky over Rochester NY, and a camera on a tower roof at the south-west corner
looking across the town. Python 3 standard library only; the same
arguments always give byte-identical files (random.Random(seed).random() is
the only randomness). Frame: +x east, +y north, +z up, metres.

The town's size follows --lamps: the smallest G x G grid of blocks whose
streets hold that many lamp positions (3 per block side per street).
"""

import argparse
import math
import os
import random
import sys

HERE = os.path.dirname(os.path.abspath(__file__))

# Site and instant shared with sims/night-half-moon (see docs/night-sky.md):
# waning half moon, 54.6 % lit, 57.1 deg elevation, azimuth 108 deg.
SITE = dict(latitude_deg=43.0844, longitude_deg=-77.6749, height_m=170.0)
UTC = "2025-10-13T08:30:00Z"

# ---- the street grid ----
PITCH = 90.0  # block pitch, street centreline to centreline
ROAD_W = 8.0  # carriageway
WALK_W = 2.0  # sidewalk each side
SETBACK = 8.0  # building lots start this far from the street centreline
LAMP_S = 30.0  # lamp spacing along a block side (3 per side)
LAMP_OFFSET = 3.5  # lamp head from the street centreline (mast arm over the road)
FLOOR_H = 3.2
BAY_W = 4.0  # facade bay (one window position per floor per bay)
WIN_W, WIN_H = 1.4, 1.6

# ---- lamp photometry ----
# I_s (W/sr, 380-780 nm) = I_v / LER with I_v = Phi (m + 1) / (2 pi), the
# on-axis intensity of a cos^m lobe putting luminaire flux Phi into the
# lower hemisphere; LER = 683 * int(S V) / int(S) over 380-780 nm from
# `gloam spectra integrate NAME --band 380:780 [--weight v-photopic]`.
LER = {"hps": 380.9, "mercury-phosphor": 310.1, "incandescent": 155.5, "fluorescent-f11": 336.8}
LAMP_TYPES = {
    # Lamp lumens: typical catalogue ratings (e.g. GE Lucalox LU100 9500 lm,
    # LU250 28000 lm; 175 W MBF deluxe mercury about 8000 lm), 70 % luminaire
    # efficiency as in sims/night-layout, times a lumen-maintenance factor
    # drawn per lamp in 0.8 .. 1.0.
    "hps-250w": dict(spectrum="hps", lamp_lm=28000.0, m=2.0, height=10.0,
                     note="250 W HPS cobra-head on a 10 m pole (arterial streets)"),
    "hps-100w": dict(spectrum="hps", lamp_lm=9500.0, m=2.0, height=8.0,
                     note="100 W HPS cobra-head on an 8 m pole (residential streets)"),
    "mbf-175w": dict(spectrum="mercury-phosphor", lamp_lm=8000.0, m=1.5, height=8.0,
                     note="175 W phosphor-coated mercury on an 8 m pole (old fittings, 5 % of residential)"),
}
LUMINAIRE_EFF = 0.7

# ---- lit windows ----
# Window luminance: an interior lit to 150-300 lux on 0.3-0.6 reflectance
# surfaces has luminance E rho / pi of about 15-60 cd/m2; through glazing
# (tau ~ 0.7) and curtains or blinds that gives roughly 5-30 cd/m2 (an
# assumed range, not a measurement). Four levels, log-spaced.
WINDOW_LEVELS_CD_M2 = [5.0, 9.0, 16.0, 30.0]
WINDOW_SPECTRA = [("incandescent", 0.55), ("fluorescent-f11", 0.45)]

MATERIALS = [
    ("ground", "../night-layout/grass.csv", "lawns and yards inside the blocks (illustrative grass shape)"),
    ("asphalt", "0.08", "road surface"),
    ("sidewalk", "0.25", "concrete sidewalks"),
    ("brick", "0.20", "brick facades"),
    ("concrete", "0.35", "concrete facades"),
    ("render", "0.50", "painted render facades"),
    ("roof", "0.12", "tar and gravel roofs"),
]
FACADES = ["brick", "concrete", "render"]


class Rng:
    """Deterministic draws from random.Random(seed).random() only."""

    def __init__(self, seed):
        self.r = random.Random(seed)

    def u(self, lo=0.0, hi=1.0):
        return lo + (hi - lo) * self.r.random()

    def pick(self, n):
        return min(int(self.r.random() * n), n - 1)

    def sample(self, items, k):
        """k items (in their original order) by a partial Fisher-Yates shuffle."""
        idx = list(range(len(items)))
        k = min(k, len(idx))
        for i in range(k):
            j = i + self.pick(len(idx) - i)
            idx[i], idx[j] = idx[j], idx[i]
        return [items[i] for i in sorted(idx[:k])]


def grid_for(lamps):
    """Smallest G with 6 G (G + 1) >= lamps lamp positions."""
    g = 1
    while 6 * g * (g + 1) < lamps:
        g += 1
    return g


def lamp_positions(g):
    """Every lamp position: (x, y, street_is_arterial). Streets run along
    x = i P (north-south) and y = j P (east-west), i, j = 0..G; each block
    side has 3 lamps, staggered across the road."""
    out = []
    for i in range(g + 1):
        arterial = i % 4 == 0
        for k in range(g):
            for q in range(3):
                t = k * PITCH + 15.0 + LAMP_S * q
                side = 1 if (k * 3 + q) % 2 == 0 else -1
                out.append((i * PITCH + side * LAMP_OFFSET, t, arterial))  # north-south street
                out.append((t, i * PITCH + side * LAMP_OFFSET, arterial))  # east-west street
    return out


def facade_quad(c, n, a, b):
    """A quad centred at c with outward normal n (horizontal), half width a,
    half height b, counter-clockwise seen from outside: u = z x n."""
    u = (-n[1], n[0], 0.0)
    x, y, z = c
    return [
        (x - u[0] * a, y - u[1] * a, z - b),
        (x + u[0] * a, y + u[1] * a, z - b),
        (x + u[0] * a, y + u[1] * a, z + b),
        (x - u[0] * a, y - u[1] * a, z + b),
    ]


def box_quads(x0, y0, x1, y1, h):
    """Four walls (outward) and the roof of a building; no bottom."""
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    hx, hy, hz = (x1 - x0) / 2, (y1 - y0) / 2, h / 2
    walls = [
        facade_quad((x1, cy, hz), (1, 0), hy, hz),
        facade_quad((x0, cy, hz), (-1, 0), hy, hz),
        facade_quad((cx, y1, hz), (0, 1), hx, hz),
        facade_quad((cx, y0, hz), (0, -1), hx, hz),
    ]
    roof = [(x0, y0, h), (x1, y0, h), (x1, y1, h), (x0, y1, h)]
    return walls + [roof]


def buildings(g, rng):
    """(x0, y0, x1, y1, height, facade) per building: 2 x 2 lots per block,
    85 % built, storeys 2..12 falling off from the centre; block (0, 0)'s
    south-west lot is the 45 m camera tower."""
    out = []
    lot = (PITCH - 2 * SETBACK) / 2  # 37 m
    centre = g * PITCH / 2
    for bi in range(g):
        for bj in range(g):
            for li in range(2):
                for lj in range(2):
                    lx = bi * PITCH + SETBACK + li * lot
                    ly = bj * PITCH + SETBACK + lj * lot
                    if (bi, bj, li, lj) == (0, 0, 0, 0):
                        out.append((lx + 2.0, ly + 2.0, lx + 24.0, ly + 24.0, 45.0, "concrete"))
                        continue
                    if rng.u() > 0.85:
                        rng.u(), rng.u(), rng.u(), rng.u()  # keep the draw count fixed per lot
                        continue
                    w = rng.u(12.0, lot - 4.0)
                    d = rng.u(12.0, lot - 4.0)
                    ox = rng.u(1.0, lot - 1.0 - w)
                    oy = rng.u(1.0, lot - 1.0 - d)
                    r = math.hypot(lx + lot / 2 - centre, ly + lot / 2 - centre) / max(centre, 1.0)
                    storeys = max(2, min(12, round(2 + 10 * math.exp(-2.5 * r * r) * rng.u(0.5, 1.0))))
                    facade = FACADES[rng.pick(3)]
                    out.append((lx + ox, ly + oy, lx + ox + w, ly + oy + d, storeys * FLOOR_H, facade))
    return out


def window_slots(blds):
    """Every window position: (centre, outward normal) on each facade, one
    per bay per storey, 5 cm proud of the wall."""
    out = []
    for (x0, y0, x1, y1, h, _) in blds:
        floors = int(h / FLOOR_H + 1e-9)
        for (n, a0, a1, fixed) in (((1, 0), y0, y1, x1), ((-1, 0), y0, y1, x0), ((0, 1), x0, x1, y1), ((0, -1), x0, x1, y0)):
            bays = int((a1 - a0) / BAY_W)
            if bays < 1:
                continue
            margin = (a1 - a0 - bays * BAY_W) / 2
            for f in range(floors):
                z = f * FLOOR_H + 1.7
                for b in range(bays):
                    a = a0 + margin + (b + 0.5) * BAY_W
                    if n[0] != 0:
                        c = (fixed + 0.05 * n[0], a, z)
                    else:
                        c = (a, fixed + 0.05 * n[1], z)
                    out.append((c, n))
    return out


def obj_text(quads, header):
    lines = [f"# {h}" for h in header]
    k = 1
    for q in quads:
        for (x, y, z) in q:
            lines.append(f"v {x:.3f} {y:.3f} {z:.3f}")
    for _ in quads:
        lines.append(f"f {k} {k + 1} {k + 2} {k + 3}")
        k += 4
    return "\n".join(lines) + "\n"


def fmt(v):
    return f"{v:.3f}".rstrip("0").rstrip(".")


def toml_str(s):
    """s as a TOML basic string: quotes, backslashes and control characters
    escaped, so a checkout path holding `"` or `\\` stays one string."""
    out = []
    for ch in s:
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


# Every file this script writes carries this in its first lines; an existing
# file without it is not the generator's and is never replaced.
MARK = "generate.py"


class OutError(Exception):
    pass


def check_out(out, names):
    """Refuses an --out that is not a directory gloam's generator may write
    into: an existing non-directory (a file, /dev/null), or one holding a
    file of one of these names that the generator did not write."""
    if os.path.lexists(out) and not os.path.isdir(out):
        raise OutError(f"--out {out}: exists and is not a directory")
    for name in names:
        p = os.path.join(out, name)
        if not os.path.lexists(p):
            continue
        if os.path.islink(p) or not os.path.isfile(p):
            raise OutError(f"--out {out}: {name} exists and is not a regular file; not replaced")
        with open(p, "rb") as f:
            head = f.read(4096)
        if MARK.encode() not in head:
            raise OutError(f"--out {out}: {name} exists and was not written by {MARK}; not replaced")


def write_files(out, files):
    """Writes each (name, text) into out, each through a temporary file
    renamed over its name, so a failed run leaves no half-written file."""
    os.makedirs(out, exist_ok=True)
    for name, text in files:
        p = os.path.join(out, name)
        tmp = os.path.join(out, f".{name}.partial-{os.getpid()}")
        try:
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(text)
            os.replace(tmp, p)
        finally:
            if os.path.lexists(tmp):
                os.unlink(tmp)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lamps", type=int, default=1000, help="street lamps, 10 .. 10000 (default 1000)")
    ap.add_argument("--windows", type=int, default=2000, help="lit windows, 0 .. 100000 (default 2000; capped at the window positions the town has)")
    ap.add_argument("--seed", type=int, default=27, help="random seed (default 27)")
    ap.add_argument("--blocks", type=int, default=None,
                    help="G: a G x G grid of blocks, 1 .. 60 (default: the smallest grid with room for --lamps); "
                         "the same G and seed give the same buildings whatever --lamps, so lamp counts compare on one town")
    ap.add_argument("--out", default=HERE, help="output directory (default: this script's directory)")
    a = ap.parse_args(argv)
    if not 10 <= a.lamps <= 10000:
        ap.error(f"--lamps {a.lamps}: must be within 10 .. 10000")
    if not 0 <= a.windows <= 100000:
        ap.error(f"--windows {a.windows}: must be within 0 .. 100000")
    out = os.path.abspath(a.out)
    files = []  # (name, text), written together once all are made
    # Relative path from the output directory to the shared grass reflectance.
    grass = os.path.relpath(os.path.join(HERE, "..", "night-layout", "grass.csv"), out)
    sensor = os.path.relpath(os.path.join(HERE, "..", "sensors", "gen2-s20-iccd.toml"), out)

    rng = Rng(a.seed)
    g = grid_for(a.lamps) if a.blocks is None else a.blocks
    if not 1 <= g <= 60:
        ap.error(f"--blocks {g}: must be within 1 .. 60")
    if 6 * g * (g + 1) < a.lamps:
        ap.error(f"--blocks {g}: room for {6 * g * (g + 1)} lamps, fewer than --lamps {a.lamps}")
    size = g * PITCH

    # Buildings, one OBJ per facade finish (roofs in their own file).
    blds = buildings(g, rng)
    facets = 0
    objs = []  # (object name, material, obj file, facet count)
    for fin in FACADES:
        walls = [q for b in blds if b[5] == fin for q in box_quads(*b[:5])[:4]]
        if walls:
            name = f"buildings-{fin}.obj"
            files.append((name, obj_text(walls, [f"night-town {fin} facades, written by generate.py (seed {a.seed}); quads face outward."])))
            objs.append((f"buildings-{fin}", fin, name, len(walls)))
    roofs = [box_quads(*b[:5])[4] for b in blds]
    files.append(("roofs.obj", obj_text(roofs, [f"night-town roofs, written by generate.py (seed {a.seed}); quads face up."])))
    objs.append(("roofs", "roof", "roofs.obj", len(roofs)))

    # Lit windows.
    slots = window_slots(blds)
    chosen = rng.sample(slots, a.windows)
    if len(chosen) < a.windows:
        print(f"note: --windows {a.windows}: the town has {len(slots)} window positions; using all of them", file=sys.stderr)
    groups = {}
    for (c, n) in chosen:
        x = rng.u()
        spec = WINDOW_SPECTRA[0][0] if x < WINDOW_SPECTRA[0][1] else WINDOW_SPECTRA[1][0]
        lvl = rng.pick(len(WINDOW_LEVELS_CD_M2))
        groups.setdefault((spec, lvl), []).append(facade_quad(c, n, WIN_W / 2, WIN_H / 2))
    window_mats = []
    for (spec, lvl) in sorted(groups):
        quads = groups[(spec, lvl)]
        mat = f"window-{spec}-{lvl}"
        name = f"{mat}.obj"
        files.append((name, obj_text(quads, [f"night-town lit windows ({spec}, level {lvl}), written by generate.py (seed {a.seed}); quads face outward."])))
        objs.append((f"windows-{spec}-{lvl}", mat, name, len(quads)))
        window_mats.append((mat, spec, WINDOW_LEVELS_CD_M2[lvl]))
    emitting = sum(len(q) for q in groups.values())

    # Lamps.
    positions = rng.sample(lamp_positions(g), a.lamps)
    lamp_lines = []
    counts = {}
    for k, (x, y, arterial) in enumerate(positions):
        if arterial:
            kind = "hps-250w"
        else:
            kind = "mbf-175w" if rng.u() < 0.05 else "hps-100w"
        t = LAMP_TYPES[kind]
        maint = rng.u(0.8, 1.0)
        i_cd = LUMINAIRE_EFF * t["lamp_lm"] * maint * (t["m"] + 1) / (2 * math.pi)
        i_w = i_cd / LER[t["spectrum"]]
        counts[kind] = counts.get(kind, 0) + 1
        lamp_lines += [
            f"[point_sources.lamp-{k:05d}]   # {kind}, {i_cd:.0f} cd on axis",
            f"position = [{fmt(x)}, {fmt(y)}, {fmt(t['height'] - 0.3)}]",
            "direction = [0.0, 0.0, -1.0]",
            f"shape_exponent = {t['m']}",
            f'spectrum = {toml_str(t["spectrum"])}',
            f"normalize = {{ lo_nm = 380, hi_nm = 780, value = {i_w:.4f} }}",
        ]

    # Streets: a carriageway and two sidewalks per street; east-west streets
    # sit 5 mm above the north-south ones so crossings do not coincide.
    street_quads = []
    span = size + PITCH
    for i in range(g + 1):
        c = i * PITCH
        for (z, along) in ((0.03, "ns"), (0.035, "ew")):
            for (w, off, mat) in ((ROAD_W, 0.0, "asphalt"), (WALK_W, (ROAD_W + WALK_W) / 2, "sidewalk"), (WALK_W, -(ROAD_W + WALK_W) / 2, "sidewalk")):
                zz = z if mat == "asphalt" else z - 0.02
                if along == "ns":
                    centre, sz = (c + off, size / 2, zz), (w, span)
                else:
                    centre, sz = (size / 2, c + off, zz), (span, w)
                street_quads.append((f"street-{along}-{i}{'' if off == 0 else ('-e' if off > 0 else '-w') if along == 'ns' else ('-n' if off > 0 else '-s')}", mat, centre, sz))

    # Camera on the tower roof (block (0, 0)), eye 1.7 m above the roof at
    # its north-east corner, looking across the town.
    tower = blds[0]
    cam = (tower[2] - 0.3, tower[3] - 0.3, tower[4] + 1.7)
    reach = min(250.0, size / 2 * math.sqrt(2))
    look = (cam[0] + reach / math.sqrt(2), cam[1] + reach / math.sqrt(2), 0.0)

    facets += sum(o[3] for o in objs) + len(street_quads) + 1
    head = [
        f"# night-town: a generated town at night: {g} x {g} blocks ({size:.0f} m square), {len(blds)} buildings,",
        f"# {a.lamps} street lamps ({', '.join(f'{v} {k}' for k, v in sorted(counts.items()))}), {emitting} lit windows.",
        f"# {facets} facets, {emitting} of them emitting; {a.lamps} point sources.",
        f"# Generated by generate.py --lamps {a.lamps} --windows {a.windows} --seed {a.seed} -- edit that, not this file.",
        "# Half moon over Rochester NY (as sims/night-half-moon); photometry: README.md.",
        "# Frame: +x east, +y north, +z up, metres.",
        "",
        'units = "m"',
        f"sensor = {toml_str(sensor)}",
        "",
        "# On the roof of the 45 m tower at the south-west corner, looking north-east.",
        "[camera]",
        f"position = [{fmt(cam[0])}, {fmt(cam[1])}, {fmt(cam[2])}]",
        f"look_at = [{fmt(look[0])}, {fmt(look[1])}, 0.0]",
        "up = [0.0, 0.0, 1.0]",
        "fov_deg = 60.0",
        "width = 640",
        "height = 480",
        "",
        "[bands.visible]",
        "lo_nm = 400",
        "hi_nm = 700",
        "[bands.s20]",
        'response = "qe-s20"',
        "",
        "[sky]",
        f"utc = {toml_str(UTC)}",
        f"latitude_deg = {SITE['latitude_deg']}",
        f"longitude_deg = {SITE['longitude_deg']}",
        f"height_m = {SITE['height_m']}",
        "visibility_km = 23.0",
        "moon = true",
        "night_sky = true",
        "overcast = false",
        "",
        "# ---- materials (spectrally flat unless a file is named) ----",
    ]
    body = head
    for (name, refl, note) in MATERIALS:
        value = toml_str(grass) if name == "ground" else refl
        body += [f"[materials.{name}]   # {note}", f"reflectance = {value}"]
    for (mat, spec, cd) in window_mats:
        w = cd / LER[spec]
        body += [
            f"[materials.{mat}]   # lit window, {spec}, {cd:g} cd/m2",
            f'emission = {{ spectrum = {toml_str(spec)}, normalize = {{ lo_nm = 380, hi_nm = 780, value = {w:.5f} }} }}',
        ]
    body += ["", "# ---- ground and streets ----", "[objects.ground]", 'material = "ground"',
             f"quad = {{ center = [{fmt(size / 2)}, {fmt(size / 2)}, 0], size = [{fmt(span)}, {fmt(span)}], normal = [0, 0, 1] }}"]
    for (name, mat, c, sz) in street_quads:
        body += [f"[objects.{name}]", f"material = {toml_str(mat)}",
                 f"quad = {{ center = [{fmt(c[0])}, {fmt(c[1])}, {c[2]:g}], size = [{fmt(sz[0])}, {fmt(sz[1])}], normal = [0, 0, 1] }}"]
    body += ["", "# ---- buildings and lit windows (OBJ) ----"]
    for (name, mat, f, n) in objs:
        body += [f"[objects.{name}]   # {n} quads", f"material = {toml_str(mat)}", f"obj = {toml_str(f)}"]
    body += ["", "# ---- street lamps (shaped point sources, cos^m about straight down) ----"] + lamp_lines
    files.append(("scene.toml", "\n".join(body) + "\n"))
    try:
        check_out(out, [name for name, _ in files])
        write_files(out, files)
    except OutError as e:
        print(f"generate.py: error: {e}", file=sys.stderr)
        return 1
    except (OSError, UnicodeError) as e:
        if isinstance(e, OSError) and e.strerror:
            why = f"cannot write {e.filename or out}: {e.strerror}"
        else:
            why = f"cannot write there: {e}"
        print(f"generate.py: error: --out {out}: {why}", file=sys.stderr)
        return 1
    print(f"{out}/scene.toml: {g} x {g} blocks, {len(blds)} buildings, {facets} facets "
          f"({emitting} emitting), {a.lamps} lamps, {len(slots)} window positions")
    return 0


if __name__ == "__main__":
    sys.exit(main())
