#!/usr/bin/env python3
"""Writes the six night validation scenes and the shared USAF 1951 chart OBJ.

The layout is shared by duplication: every sims/night-*/scene.toml is
generated from the one description below, so edit this file and re-run

    python3 sims/night-layout/generate.py

rather than editing the scenes by hand. Scene frame: +x east, +y north,
+z up, metres; the origin is the middle of the panel row.
"""

import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))
SIMS = os.path.dirname(HERE)

# Site: Rochester Institute of Technology, Rochester NY (DIRSIG's home).
SITE = dict(latitude_deg=43.0844, longitude_deg=-77.6749, height_m=170.0)

# Instants found with `gloam ephem --find` (see docs/night-sky.md).
NIGHTS = {
    "full-moon": dict(
        utc="2025-10-07T05:00:00Z",
        moon=True,
        note="full moon (100.0 % lit, phase angle 2.4 deg), Moon at 54.4 deg elevation, "
        "azimuth 181 deg (due south, behind the camera); gloam sky: 0.298 lux",
    ),
    "half-moon": dict(
        utc="2025-10-13T08:30:00Z",
        moon=True,
        note="waning half moon (54.6 % lit, phase angle 84.7 deg), Moon at 57.1 deg "
        "elevation, azimuth 108 deg (east-south-east); gloam sky: 0.028 lux",
    ),
    "new-moon": dict(
        utc="2025-10-22T04:00:00Z",
        moon=False,
        note="new moon (0.5 % lit), Moon 59.8 deg BELOW the horizon: starlight and "
        "airglow only (moon = false makes that explicit); gloam sky: 1.0e-3 lux",
    ),
}

BAR_OBJ = "usaf1951-bars.obj"


def usaf_bars():
    """USAF 1951 chart, groups -2..1, elements 1..6, enlarged so the
    largest bar (group -2 element 1, 0.25 lp/mm) is 80 mm wide.

    Resolution R = 2**(group + (element - 1)/6) lp/mm at chart scale;
    bar width = scale / (2 R); bars are 5 widths long, spaced by one width.
    Each element: three horizontal bars, a 2-width gap, three vertical bars.
    Groups are columns left to right; elements run top to bottom.
    Returns a list of (x0, x1, z0, z1) rectangles on the board face, in
    board coordinates (x from the board's left edge, z from its bottom)."""
    scale_mm = 80.0 * 2 * 0.25  # bar width 80 mm at R = 0.25 lp/mm
    rects = []
    x = 0.15
    top = 2.25
    for group in (-2, -1, 0, 1):
        z = top
        widths = []
        for element in range(1, 7):
            r = 2.0 ** (group + (element - 1) / 6.0)
            w = scale_mm / (2 * r) / 1000.0  # metres
            widths.append(w)
            z_top = z
            z_bot = z - 5 * w
            # three horizontal bars (long axis along x), 5w x w each
            for k in range(3):
                zt = z_top - 2 * k * w
                rects.append((x, x + 5 * w, zt - w, zt))
            # three vertical bars (long axis along z), w x 5w each
            xv = x + 7 * w
            for k in range(3):
                xl = xv + 2 * k * w
                rects.append((xl, xl + w, z_bot, z_top))
            z = z_bot - 0.6 * w
        x += 12 * widths[0] + 0.1
    return rects


# The chart board: 2.6 m wide, 2.4 m tall, facing south, bottom 0.3 m up.
BOARD = dict(x0=2.2, width=2.6, height=2.4, bottom=0.3, y=0.0)


def write_obj():
    rects = usaf_bars()
    y = BOARD["y"] - 0.005  # 5 mm in front of the board
    lines = [
        "# USAF 1951 resolution chart bars, groups -2..1, elements 1..6,",
        "# enlarged so group -2 element 1 has 80 mm bars. Written by generate.py.",
        "# Scene metres, +x east, +y north, +z up; every quad faces south (-y).",
        "o usaf1951_bars",
    ]
    for (a, b, c, d) in rects:
        x0, x1 = BOARD["x0"] + a, BOARD["x0"] + b
        z0, z1 = BOARD["bottom"] + c, BOARD["bottom"] + d
        for (px, pz) in ((x0, z0), (x1, z0), (x1, z1), (x0, z1)):
            lines.append(f"v {px:.5f} {y:.5f} {pz:.5f}")
    for i in range(len(rects)):
        k = 4 * i + 1
        lines.append(f"f {k} {k + 1} {k + 2} {k + 3}")
    with open(os.path.join(HERE, BAR_OBJ), "w") as f:
        f.write("\n".join(lines) + "\n")
    return len(rects)


# Lamps: realistic photometry turned into radiometric on-axis intensity.
# I_s (W/sr, 380-780 nm) = I_v / LER, with I_v = Phi (m + 1) / (2 pi) for a
# cos^m lobe that puts luminaire flux Phi into the lower hemisphere, and the
# luminous efficacy of radiation LER = 683 * int(S V) / int(S) over 380-780 nm
# (from `gloam spectra integrate`): hps 381, mercury-clear 342,
# tungsten-halogen-3200k 171 lm/W.
LAMPS = [
    dict(
        name="hps-streetlight",
        spectrum="hps",
        pole_xy=(-11.0, 6.0),
        height=8.0,
        direction=(0.0, 0.0, -1.0),
        m=2.0,
        flux_lm=0.7 * 9500.0,
        ler=381.0,
        note="100 W HPS cobra-head on an 8 m pole: 9500 lm lamp, 70 % luminaire efficiency",
    ),
    dict(
        name="mercury-streetlight",
        spectrum="mercury-clear",
        pole_xy=(11.0, 9.0),
        height=8.0,
        direction=(0.0, 0.0, -1.0),
        m=1.5,
        flux_lm=0.7 * 7900.0,
        ler=342.0,
        note="175 W clear mercury (MB) on an 8 m pole: 7900 lm lamp, 70 % luminaire efficiency",
    ),
    dict(
        name="halogen-floodlight",
        spectrum="tungsten-halogen-3200k",
        pole_xy=(-4.0, -15.0),
        height=4.0,
        aim=(1.0, 0.0, 1.0),
        m=6.0,
        flux_lm=0.6 * 9500.0,
        ler=171.0,
        note="500 W tungsten-halogen floodlight on a 4 m pole aimed at the chart "
        "(55 deg beam, cos^6): 9500 lm lamp, 60 % into the beam",
    ),
]


def lamp_lines():
    out = ["", "# ---- man-made sources (shaped point lamps on poles) ----"]
    objs = []
    for lp in LAMPS:
        x, y = lp["pole_xy"]
        z = lp["height"]
        if "aim" in lp:
            ax, ay, az = lp["aim"]
            d = (ax - x, ay - y, az - z)
        else:
            d = lp["direction"]
        n = math.sqrt(sum(c * c for c in d))
        d = tuple(c / n for c in d)
        i_cd = lp["flux_lm"] * (lp["m"] + 1) / (2 * math.pi)
        i_w = i_cd / lp["ler"]
        out += [
            "",
            f"# {lp['note']}:",
            f"# I_v = {lp['flux_lm']:.0f} lm x (m + 1) / 2pi = {i_cd:.0f} cd on axis "
            f"-> {i_w:.2f} W/sr over 380-780 nm.",
            f"[point_sources.{lp['name']}]",
            # On a 0.55 m mast arm, just below the open-bottomed housing, so
            # the lamp sees the ground (a lamp inside a closed box lights nothing).
            f"position = [{x + 0.55:.2f}, {y}, {z - 0.35:.2f}]",
            f"direction = [{d[0]:.4f}, {d[1]:.4f}, {d[2]:.4f}]",
            f"shape_exponent = {lp['m']}",
            f'spectrum = "{lp["spectrum"]}"',
            f"normalize = {{ lo_nm = 380, hi_nm = 780, value = {i_w:.3f} }}",
        ]
        objs += [
            "",
            f"[objects.{lp['name']}-pole]",
            'material = "pole-steel"',
            f"box = {{ min = [{x - 0.08}, {y - 0.08}, 0.0], max = [{x + 0.08}, {y + 0.08}, {z:.2f}], omit = [\"bottom\"] }}",
            f"[objects.{lp['name']}-head]",
            'material = "pole-steel"',
            f"box = {{ min = [{x + 0.08:.2f}, {y - 0.25}, {z - 0.3:.2f}], max = [{x + 0.8:.2f}, {y + 0.25}, {z:.2f}], omit = [\"bottom\"] }}",
        ]
    return out + objs


MATERIALS = """
# ---- materials ----
# Grey panels: spectrally flat (painted plywood, matte).
[materials.black]
reflectance = 0.04
[materials.dark-grey]
reflectance = 0.12
[materials.medium-grey]
reflectance = 0.25
[materials.light-grey]
reflectance = 0.50
[materials.white]
reflectance = 0.85
# Coloured paints, grass, skin, vehicle paint, aluminium: illustrative
# spectral shapes (see ../night-layout/README.md), not measurements.
[materials.red]
reflectance = "../night-layout/red-paint.csv"
[materials.blue]
reflectance = "../night-layout/blue-paint.csv"
[materials.aluminium]
reflectance = "../night-layout/aluminium.csv"
specular_fraction = 0.85
[materials.chart-black]
reflectance = 0.05
[materials.grass]
reflectance = "../night-layout/grass.csv"
[materials.vehicle-paint]
reflectance = "../night-layout/olive-drab.csv"
[materials.vehicle-glass]
reflectance = 0.08
specular_fraction = 0.9
[materials.tyre]
reflectance = 0.03
[materials.skin]
reflectance = "../night-layout/skin.csv"
[materials.jacket]
reflectance = 0.10
[materials.trousers]
reflectance = 0.07
[materials.pole-steel]
reflectance = 0.30
specular_fraction = 0.2
"""


def quad(name, mat, center, size, normal, width_axis=None):
    c = ", ".join(f"{v:g}" for v in center)
    n = ", ".join(f"{v:g}" for v in normal)
    wa = "" if width_axis is None else ", width_axis = [" + ", ".join(f"{v:g}" for v in width_axis) + "]"
    return [
        f"[objects.{name}]",
        f'material = "{mat}"',
        f"quad = {{ center = [{c}], size = [{size[0]:g}, {size[1]:g}], normal = [{n}]{wa} }}",
    ]


def box(name, mat, lo, hi, omit=None):
    a = ", ".join(f"{v:g}" for v in lo)
    b = ", ".join(f"{v:g}" for v in hi)
    o = "" if not omit else ", omit = [" + ", ".join(f'"{s}"' for s in omit) + "]"
    return [f"[objects.{name}]", f'material = "{mat}"', f"box = {{ min = [{a}], max = [{b}]{o} }}"]


def layout_lines():
    out = ["", "# ---- the test layout ----", "# Ground: mown grass field, 400 m x 400 m."]
    out += quad("ground", "grass", (0, 0, 0), (400, 400), (0, 0, 1))
    out += ["", "# Reflectance panels, 1.2 m x 1.2 m, upright, facing south (the camera), bottom 0.3 m up."]
    for i, mat in enumerate(["black", "dark-grey", "medium-grey", "light-grey", "white", "red", "blue"]):
        x = -9.0 + 1.5 * i
        out += quad(f"panel-{mat}", mat, (x, 0, 0.9), (1.2, 1.2), (0, -1, 0))
    b = BOARD
    cx = b["x0"] + b["width"] / 2
    cz = b["bottom"] + b["height"] / 2
    out += ["", "# USAF 1951 resolution chart: white board, black bars as thin quads 5 mm in front."]
    out += quad("usaf-board", "white", (cx, b["y"], cz), (b["width"], b["height"]), (0, -1, 0))
    out += [
        "[objects.usaf-bars]",
        'material = "chart-black"',
        f'obj = "../night-layout/{BAR_OBJ}"',
    ]
    out += ["", "# Aluminium panels (specular): one upright, one tilted 45 deg up towards the south sky."]
    out += quad("aluminium-upright", "aluminium", (5.8, 0, 0.9), (1.2, 1.2), (0, -1, 0))
    out += quad("aluminium-tilted", "aluminium", (7.3, 0, 0.75), (1.2, 1.2), (0, -0.7071, 0.7071))
    out += ["", "# Vehicle (a 4.5 m x 1.8 m car/light truck in boxes), long axis east-west."]
    out += box("vehicle-body", "vehicle-paint", (10.0, 4.0, 0.35), (14.5, 5.8, 1.1))
    out += box("vehicle-cabin", "vehicle-glass", (11.0, 4.1, 1.1), (13.3, 5.7, 1.65), omit=["bottom"])
    for k, (x0, y0) in enumerate([(10.5, 3.9), (13.3, 3.9), (10.5, 5.65), (13.3, 5.65)]):
        out += box(f"vehicle-wheel-{k + 1}", "tyre", (x0, y0, 0.0), (x0 + 0.7, y0 + 0.25, 0.7))
    out += ["", "# Standing person, 1.78 m, facing south."]
    px, py = -12.0, 2.0
    out += box("person-leg-left", "trousers", (px - 0.2, py - 0.1, 0.0), (px - 0.02, py + 0.1, 0.85))
    out += box("person-leg-right", "trousers", (px + 0.02, py - 0.1, 0.0), (px + 0.2, py + 0.1, 0.85))
    out += box("person-torso", "jacket", (px - 0.25, py - 0.12, 0.85), (px + 0.25, py + 0.12, 1.45))
    out += box("person-arm-left", "jacket", (px - 0.37, py - 0.07, 0.8), (px - 0.26, py + 0.07, 1.42))
    out += box("person-arm-right", "jacket", (px + 0.26, py - 0.07, 0.8), (px + 0.37, py + 0.07, 1.42))
    out += box("person-head", "skin", (px - 0.1, py - 0.11, 1.5), (px + 0.1, py + 0.11, 1.78))
    out += box("person-neck", "skin", (px - 0.05, py - 0.05, 1.45), (px + 0.05, py + 0.05, 1.5))
    return out


def scene(night, lamps):
    n = NIGHTS[night]
    name = f"night-{night}" + ("-lamps" if lamps else "")
    head = [
        f"# {name}: the classic low-light validation scene, {night.replace('-', ' ')}"
        + (", with high-pressure sodium, mercury and tungsten-halogen lamps." if lamps else ", natural light only."),
        f"# {n['note']}.",
        "# Site: Rochester Institute of Technology, Rochester NY (43.0844 N, 77.6749 W, 170 m).",
        "# Generated by ../night-layout/generate.py (shared layout) -- edit that, not this file.",
        "# Frame: +x east, +y north, +z up, metres.",
        "",
        'units = "m"',
        'sensor = "../sensors/gen2-s20-iccd.toml"',
        "",
        "# Camera 40 m south of the panel row, 1.8 m up, looking north.",
        "[camera]",
        "position = [0.0, -40.0, 1.8]",
        "look_at = [0.0, 0.0, 1.0]",
        "up = [0.0, 0.0, 1.0]",
        "fov_deg = 40.0",
        "width = 768",
        "height = 576",
        "",
        "[bands.visible]",
        "lo_nm = 400",
        "hi_nm = 700",
        "[bands.s20]",
        'response = "qe-s20"',
        "",
        "[sky]",
        f'utc = "{n["utc"]}"',
        f"latitude_deg = {SITE['latitude_deg']}",
        f"longitude_deg = {SITE['longitude_deg']}",
        f"height_m = {SITE['height_m']}",
        "visibility_km = 23.0",
        f"moon = {'true' if n['moon'] else 'false'}",
        "night_sky = true",
        "overcast = false",
    ]
    body = head + MATERIALS.rstrip("\n").split("\n") + layout_lines()
    if lamps:
        body += lamp_lines()
    d = os.path.join(SIMS, name)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "scene.toml"), "w") as f:
        f.write("\n".join(body) + "\n")
    return name


if __name__ == "__main__":
    bars = write_obj()
    for night in NIGHTS:
        for lamps in (False, True):
            print(scene(night, lamps))
    print(f"{BAR_OBJ}: {bars} bars")
