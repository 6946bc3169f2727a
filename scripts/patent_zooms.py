#!/usr/bin/env python3
"""Adds library zooms entered from a patent example's tables (docs/lens-library.md, "Zooms").

For a focal range none of whose library files can be given its zoom positions (no transcription of
the patent table with every state matches the file), a zoom of that range whose patent example
LensVisualizer transcribes with every state is added as a new library file, `"collection":
"patent"` in index.json, as the thesis's 80-200 mm was entered by hand. Only the patent's numbers
are taken from the transcription: radii, thicknesses, nd and Vd, the stop's place where the patent
gives it, each zoom state's focal length and variable gaps at infinity focus, and the f-numbers
(SPECS names which and where they are printed). None of LensVisualizer's modelling values (clear
radii, glass choices, focus reconstructions) is used: it states no licence.

Clear radii (the patents give none) are derived here as for the thesis zoom: at each surface the
largest, over the zoom states, of |paraxial marginal ray at the state's f-number| + |paraxial chief
ray to the corner of the lens's image format|, times CLEARANCE, at most MAX_RIM_TO_RADIUS |radius|,
then cut back where an edge would be thinner than the importer's minimum at the narrowest state of
each gap (import_lens_library.cut_pass). The stop's radius at each state is the marginal ray's
height there at that state's f-number (an `aperture` line when it differs between states), rounded
up to 0.1 um. Every file is then run through `flare lens check` at each position (EFL within 1 % of
the patent's focal length, the stop, the axial ray fan) and written only if all pass. Idempotent.

A table of lenses/zoom-tables/ (one LensVisualizer added after the snapshot in LENSVISUALIZER.git)
is read instead of the git folder's file of the same path (table_text).

Aspheres are base spheres, but where SPECS asks for them (`aspheres`) the patent's coefficients are
written on their rows: a hybrid asphere's moulded resin layer keeps a positive thickness only with
its asphere, and such a layer is cut only where it thins to RESIN_LAYER_MIN_EDGE_MM (resin_layer).

Usage:  /usr/bin/python3 scripts/patent_zooms.py lenses/library LENSVISUALIZER.git build/src/flare
"""

import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import textwrap

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import import_lens_library as imp  # noqa: E402  (cut_pass, the check runner)

CLEARANCE = 1.02
MAX_RIM_TO_RADIUS = imp.MAX_RIM_TO_RADIUS

# Each lens: the LensVisualizer file, the library id and names, the patent example, each state's
# f-number as the patent prints it (with where LensVisualizer's header says so), the image format.
SPECS = [
    {
        "lv": "src/lens-data/nikon/NikonAFSDXZoomNikkor1224mmf4GIFED.data.ts",
        "id": "nikon-af-s-dx-zoom-nikkor-12-24mm-f4g-if-ed",
        "folder": "nikon",
        "maker": "Nikon",
        "model": "AF-S DX Zoom-Nikkor 12-24mm f/4G IF-ED",
        "patent": "US 6,940,655 B2",
        "example": 1,
        "f_numbers": [4.1, 4.1, 4.1],
        "f_number_source": "f/4.1 at every state, the design f-number as LensVisualizer transcribes the patent "
                           "(apertureDesign 4.1, one nominalFno for every state: a constant-aperture zoom)",
        "sensor_mm": (23.6, 15.7),
        "format": "Nikon DX",
        # The patent prints the first element's effective diameter, 43.65 mm (as LensVisualizer's header
        # quotes it): the front surface's clear radius (the field's corners are vignetted there at wide,
        # as in the patent).
        "published_semi": {1: 21.825},
    },
    {
        "lv": "src/lens-data/pentax/PentaxDA1770mmf4ALSDM.data.ts",
        "id": "pentax-smc-pentax-da-17-70mm-f4al-if-sdm",
        "folder": "pentax",
        "maker": "Pentax",
        "model": "smc Pentax-DA 17-70mm F4 AL [IF] SDM",
        "patent": "US 7,804,652 B2",
        "example": 4,
        "f_numbers": [4.1, 4.1, 4.1],
        "f_number_source": "the patent's f/4.1 at 17.50 / 35.00 / 67.89 mm (as LensVisualizer's header quotes it)",
        "sensor_mm": (23.5, 15.6),
        "format": "Pentax APS-C",
        # The hybrid-aspheric resin layer on surface 28 (0.1 mm on the axis, radius -7107 mm on a -206 mm
        # glass surface) crosses the glass 6.5 mm off the axis as base spheres: with the patent's
        # aspheric coefficients it keeps 0.03 mm or more out to the rim (RESIN_LAYER_MAX_MM).
        "aspheres": True,
        "why": "the hybrid-aspheric resin layer behind surface 28 (with the patent's aspheric coefficients)",
    },
    {
        "lv": "src/lens-data/panasonic/PanasonicLumixGVario714mmf4.data.ts",
        "id": "panasonic-7-14mm-f4-us-2010-0194930-ex1",
        "folder": "panasonic",
        "maker": "Panasonic",
        "model": "LUMIX G VARIO 7-14mm F4.0 ASPH. (Example 1 of its patent)",
        "patent": "US 2010/0194930",
        "example": 1,
        "f_numbers": [4.0, 4.0, 4.0],
        "f_number_source": "f/4 at every state, the constant aperture LensVisualizer gives (nominalFno 4; the patent's "
                           "own F-numbers are not quoted there)",
        "sensor_mm": (17.3, 13.0),
        "format": "Four Thirds",
    },
    {
        "lv": "src/lens-data/pentax/HDPentaxDA6452845mmF45EDAWSR.data.ts",
        "id": "pentax-hd-pentax-da645-28-45mm-f4.5-ed-aw-sr",
        "folder": "pentax",
        "maker": "Pentax",
        "model": "HD PENTAX-DA645 28-45mm F4.5 ED AW SR",
        "patent": "JP 2015-087681 A",
        "example": 1,
        "f_numbers": [4.6, 4.6, 4.6],
        "f_number_source": "the patent's FNO 4.6 at all three states (as LensVisualizer's header quotes it; sold as f/4.5)",
        "sensor_mm": (44.0, 33.0),
        "format": "645 digital (44 x 33 mm)",
    },
    # From the tables LensVisualizer transcribed after the snapshot (lenses/zoom-tables).
    {
        "lv": "src/lens-data/nikon/NikonAFSZoomNikkor2485mmf3545GIFED.data.ts",
        "id": "nikon-af-s-zoom-nikkor-24-85mm-f3.5-4.5g-if-ed",
        "folder": "nikon",
        "maker": "Nikon",
        "model": "AF-S Zoom-Nikkor 24-85mm f/3.5-4.5G IF-ED",
        "patent": "JP 2003-241093 A",
        "example": 2,
        "f_numbers": [3.6, 4.5, 4.7],
        "f_number_source": "the patent's F-numbers 3.6 / 4.5 / 4.7 at 25.0 / 50.0 / 82.5 mm (as LensVisualizer's file "
                           "gives them); the stop's place, 0.8 mm in front of G3, is LensVisualizer's reading of the "
                           "patent's figure (the patent puts it between G2 and G3, moving with G3, without a distance)",
        "sensor_mm": (36.0, 24.0),
        "format": "35 mm full frame",
    },
    {
        "lv": "src/lens-data/nikon/NikonAFSNikkor2485mmf3545GEDVR.data.ts",
        "id": "nikon-24-85mm-f3.6-5.8-jp-2011-221421-ex4",
        "folder": "nikon",
        "maker": "Nikon",
        "model": "24-85mm F3.6-5.8, patent example of the AF-S NIKKOR 24-85mm f/3.5-4.5G ED VR",
        "patent": "JP 2011-221421 A",
        "example": 4,
        "f_numbers": [3.6, 5.8],
        "f_number_source": "the patent's Table 13 F-numbers 3.60 / 5.80 at 24.70 / 87.20 mm (as LensVisualizer's file "
                           "quotes them; its nominalFno is a calibration to the patent's Figure 8). Named for the "
                           "24-85 mm range it is an example of (both ends within 5 %, docs/lens-library.md \"Names\") "
                           "with its own f-numbers: f/5.8 at tele is more than a third of a stop beyond the product's "
                           "f/4.5",
        "sensor_mm": (36.0, 24.0),
        "format": "35 mm full frame",
        "aspheres": True,
    },
    {
        "lv": "src/lens-data/minolta/Minolta75150mmf40MDZoom.data.ts",
        "id": "konica-minolta-75-150mm-f4-md-zoom",
        "folder": "konica-minolta",
        "maker": "Konica Minolta",
        "model": "MD Zoom 75-150mm F4",
        "patent": "JP S56-150717 A",
        "example": 1,
        "f_numbers": [4.1, 4.1, 4.1],
        "f_number_source": "the patent's F/4.1 at 77 / 101 / 146 mm (as LensVisualizer's file quotes it); the patent "
                           "marks no stop: it sits 0.1 mm in front of the master group, LensVisualizer's choice",
        "sensor_mm": (36.0, 24.0),
        "format": "35 mm full frame",
    },
    # From a table that names its own source (not LensVisualizer's: it has none of this patent).
    {
        "lv": "lenses/zoom-tables/canon/CanonNewFD70210mmf4.data.ts",
        "id": "canon-new-fd70-210mm-f4-us-4380377-ex1",
        "folder": "canon",
        "maker": "Canon",
        "model": "New FD 70-210mm f/4, entered whole from its patent",
        "patent": "US 4,380,377",
        "example": 1,
        "f_numbers": [4.0, 4.0, 4.0],
        "f_number_source": "the patent's F/4 at 70.55 / 137.04 / 205.31 mm; the patent marks no stop: it sits 1 mm in "
                           "front of group IV (fixed), where the library's file of this example (the Optical Bench's "
                           "transcription) puts it, so the f-number stays the same as the lens zooms. That file keeps its "
                           "one state: merged with the patent's gaps, its clear radii (estimates sized for the wide end) "
                           "stop the f/4 beam at tele",
        "sensor_mm": (36.0, 24.0),
        "format": "35 mm full frame",
        "why": "as printed, rows 7 and 8 (R 40.285 and -45.202 mm, 4.2 mm of air apart) meet 13.21 mm off the axis, "
               "below the 13.82 and 13.77 mm the paraxial marginal ray at f/4 reaches there at tele: no clear radius "
               "lets the patent's F/4 through at 205.31 mm",
    },
]

NUMBER = r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?"


def table_text(git_dir, path):
    """A LensVisualizer file's text and the commit it was read at: a later table of lenses/zoom-tables
    (import_lens_library.LATER_TABLES; its header names the commit) where one has the path, else the
    git folder's at HEAD (commit None). A path in lenses/zoom-tables/ itself is a table that names its
    own source (import_lens_library.SOURCE), not LensVisualizer's: its text, commit None."""
    if path.startswith("lenses/zoom-tables/"):
        with open(os.path.join(imp.LATER_TABLES, *path.split("/")[2:]), encoding="utf-8") as f:
            return f.read(), None
    later = os.path.join(imp.LATER_TABLES, *path.split("/")[2:])
    if os.path.isfile(later):
        with open(later, encoding="utf-8") as f:
            text = f.read()
        return text, re.search(r"\bcommit ([0-9a-f]{12,40})\b", text).group(1)
    return subprocess.run(["git", "--git-dir", git_dir, "show", "HEAD:" + path], capture_output=True, text=True,
                          check=True).stdout, None


def read_table(git_dir, path, with_aspheres=False):
    """The patent's numbers from a LensVisualizer file: rows [{label, radius, thickness, nd, vd,
    stop}, and `asph` with_aspheres], focal lengths per state, {row: [gap per state]} at infinity
    focus."""
    text, _ = table_text(git_dir, path)
    vd_of = {int(i): float(v) for i, v in re.findall(r"\bid:\s*(\d+),[^{}]*?\bnd:\s*" + NUMBER + r",\s*vd:\s*(" + NUMBER + ")",
                                                       text)}
    rows = []
    for label, radius, d, nd, elem in re.findall(
            r'\{\s*label:\s*"([^"]+)",\s*R:\s*(' + NUMBER + r'),\s*d:\s*(' + NUMBER + r'),\s*nd:\s*(' + NUMBER +
            r'),\s*elemId:\s*(\d+)', text):
        stop = label.upper() in ("STO", "STOP")
        nd = float(nd)
        glass = nd > 1.001
        if glass and int(elem) not in vd_of:
            raise SystemExit(f"{path}: row {label}: no Vd for element {elem}")
        rows.append({"label": label, "radius": 0.0 if abs(float(radius)) > 1e10 else float(radius),
                     "thickness": float(d), "nd": nd, "vd": vd_of.get(int(elem)), "stop": stop})
    focal = [float(x) for x in re.findall(NUMBER, re.search(r"zoomPositions:\s*\[([^\]]*)\]", text).group(1))]
    for label, terms in (aspheres(text) if with_aspheres else {}).items():
        rows[[r["label"] for r in rows].index(label)]["asph"] = terms
    var = re.search(r"\bvar:\s*\{(.*?)\n  \},", text, re.S).group(1)
    gaps = {}
    labels = [r["label"] for r in rows]
    for quoted, bare, body in re.findall(r'(?:"([^"]+)"|\b(\d+[A-Za-z]?|STO)):\s*\[((?:\s*\[[^\]]*\],?)+)\s*\]', var):
        label = quoted or bare
        values = [float(re.findall(NUMBER, st)[0]) for st in re.findall(r"\[([^\]]*)\]", body)]
        if len(values) != len(focal):
            raise SystemExit(f"{path}: gap {label} has {len(values)} states, not {len(focal)}")
        gaps[labels.index(label)] = values
    return rows, focal, gaps


def aspheres(text):
    """{row label: {"k": conic, "A4": ..., ...}} from a LensVisualizer file's `asph` block: the
    patent's aspheric coefficients as transcribed (terms that are 0 left out; a surface with none
    left is a sphere)."""
    start = re.search(r"\basph:\s*\{", text)
    if not start:
        return {}
    depth, end = 1, start.end()
    while depth:
        depth += {"{": 1, "}": -1}.get(text[end], 0)
        end += 1
    found = {}
    for quoted, bare, body in re.findall(r'(?:"([^"]+)"|\b(\w+)):\s*\{([^{}]*)\}', text[start.end():end - 1]):
        terms = {("k" if key == "K" else key): float(value)
                 for key, value in re.findall(r"\b(K|A\d+):\s*(" + NUMBER + ")", body) if float(value) != 0.0}
        if terms:
            found[quoted or bare] = terms
    return found


# A hybrid asphere's moulded resin layer: a layer at most this thick on the axis, cemented to glass,
# one of whose surfaces is aspheric. Its shape is the patent's own (the asphere keeps it thin but
# positive out to the rim: JP 2011-221421 A Example 4's 0.22 mm layer thins to 0.08 mm, US 7,804,652
# B2 Example 4's 0.1 mm layer to 0.03 mm), not an estimate of the collection's, so its clear radius is
# cut only where its surfaces would come within RESIN_LAYER_MIN_EDGE_MM of each other, not at the
# importer's minimum edge for glass elements (0.3 mm, or half the axial thickness, which such a layer
# cannot keep). That floor keeps the two surfaces from meeting at the rim (where a ray would hit both
# at zero distance, which the tracer does not count: the importer's STOP_OFFSET_MM, for the same reason).
RESIN_LAYER_MAX_MM = 0.25
RESIN_LAYER_MIN_EDGE_MM = imp.STOP_OFFSET_MM


def resin_layer(rows, i):
    r = rows[i]
    if r["stop"] or r["nd"] <= 1.001 or r["thickness"] > RESIN_LAYER_MAX_MM or i + 1 >= len(rows):
        return False
    cemented = rows[i + 1]["nd"] > 1.001 or (i > 0 and rows[i - 1]["nd"] > 1.001)
    return cemented and bool(r.get("asph") or rows[i + 1].get("asph"))


def paraxial(rows, thickness):
    """y-nu traces at the d line (nd) through the rows with the given thicknesses. Returns (EFL,
    back focus, per-row heights of the ray from infinity at unit height, per-row heights of the ray
    through the first vertex at unit slope, the two rays' image-side heights and slopes)."""
    def trace(y, u):
        n, heights = 1.0, []
        for i, r in enumerate(rows):
            heights.append(y)
            n2 = 1.0 if r["stop"] else (r["nd"] if r["nd"] > 1.001 else 1.0)
            if not r["stop"] and r["radius"] != 0.0:
                u = (n * u - y * (n2 - n) / r["radius"]) / n2
            else:
                u = n * u / n2
            n = n2
            if i + 1 < len(rows):
                y += thickness[i] * u
        return heights, y, u
    ha, ya, ua = trace(1.0, 0.0)
    hb, yb, ub = trace(0.0, 1.0)
    efl = -1.0 / ua
    back = -ya / ua
    return efl, back, ha, hb, (ya, ua), (yb, ub)


def clear_radii(rows, gaps, n_states, f_numbers, half_diagonal):
    """Semi-apertures (marginal + chief ray envelope over the states) and the stop radius per state."""
    stop = next(i for i, r in enumerate(rows) if r["stop"])
    semi = [0.0] * len(rows)
    stop_radius = []
    for k in range(n_states):
        thickness = [gaps[i][k] if i in gaps else r["thickness"] for i, r in enumerate(rows)]
        efl, back, ha, hb, (ya, ua), (yb, ub) = paraxial(rows, thickness)
        marginal = [h * efl / (2.0 * f_numbers[k]) for h in ha]
        # The chief ray crosses the axis at the stop: a*ha + b*hb = 0 there; scaled to the corner.
        a, b = hb[stop], -ha[stop]
        image = a * (ya + back * ua) + b * (yb + back * ub)
        chief = [(a * p + b * q) * half_diagonal / abs(image) for p, q in zip(ha, hb)]
        stop_radius.append(math.ceil(abs(marginal[stop]) * 1e4) / 1e4)
        for i in range(len(rows)):
            semi[i] = max(semi[i], CLEARANCE * (abs(marginal[i]) + abs(chief[i])))
    for i, r in enumerate(rows):
        if not r["stop"] and r["radius"] != 0.0:
            semi[i] = min(semi[i], MAX_RIM_TO_RADIUS * abs(r["radius"]))
    # The narrowest state of each variable gap decides where two surfaces would cross.
    tight = [dict(r, thickness=min(gaps[i]) if i in gaps else r["thickness"]) for i, r in enumerate(rows)]
    for i in range(len(rows)):
        if resin_layer(rows, i):
            tight[i]["min_edge_mm"] = RESIN_LAYER_MIN_EDGE_MM
    before = list(semi)
    for _ in range(len(rows)):
        if not imp.cut_pass(tight, semi):
            break
    cut = [i + 1 for i in range(len(rows)) if semi[i] < before[i] - 1e-9]
    semi[stop] = max(stop_radius)
    return semi, stop_radius, cut


def published(semi, spec):
    """The clear radii the patent prints (row number: radius) replace the derived ones."""
    for row, radius in spec.get("published_semi", {}).items():
        semi[row - 1] = radius
    return semi


def fmt(x):
    """A number as the table prints it (the shortest text that reads back as the same double)."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def transcription(spec, commit, source):
    """The header's sentence on where the table's numbers were read (comment lines)."""
    if source:
        return ["# " + line for line in textwrap.wrap(f"patent's, as {spec['lv']} gives them ({source}).", 104)]
    return [f"# patent's, as transcribed in LensVisualizer (github.com/ronbuening/LensVisualizer, {spec['lv']},",
            f"# commit {commit[:12]}; no licence stated there: only the patent's numbers are taken, none of that file's",
            "# modelling values)."]


def lens_text(spec, rows, focal, gaps, commit, source=None):
    n = len(focal)
    names = ["wide", "tele"] if n == 2 else ["wide"] + (["mid"] if n == 3 else [f"mid{i}" for i in range(1, n - 1)]) + ["tele"]
    w, h = spec["sensor_mm"]
    semi, stop_radius, cut = clear_radii(rows, gaps, n, spec["f_numbers"], 0.5 * math.hypot(w, h))
    layers = [i for i in range(len(rows)) if resin_layer(rows, i)]
    semi = published(semi, spec)
    # The last gap is the back focus: the focus solve places the sensor ('auto'); a gap the table lists
    # but that is the same at every state (it varies for close focus only) is a plain thickness.
    last = len(rows) - 1
    gaps = {i: v for i, v in gaps.items() if i != last and max(v) - min(v) > 1e-9}
    title = f"{spec['maker']} {spec['model']}"
    example = f"{spec['patent']} Example {spec['example']}"
    varies = len(set(stop_radius)) > 1
    out = [
        f"# {title}, patent example {example}.",
        "# Entered from the patent's tables by scripts/patent_zooms.py (docs/lens-library.md, \"Zooms\"): no file of",
        "# this focal range in the library could be given its zoom positions. Transcription: radii, thicknesses,",
        "# nd/Vd, the stop's place, each zoom state's focal length and variable gaps at infinity focus are the",
        *transcription(spec, commit, source),
        f"# f-numbers: {spec['f_number_source']}.",
        "# Semi-apertures: the patent gives none. Derived here: at each surface the largest, over the zoom states,",
        "# of |paraxial marginal ray at the state's f-number| + |paraxial chief ray to the corner of the",
        f"# {spec['format']} format ({w} x {h} mm)|, x {CLEARANCE}, at most {MAX_RIM_TO_RADIUS} |R|, then cut back where an",
        "# edge at a gap's narrowest state would be thinner than 0.3 mm (glass) or 0.1 mm (air)" +
        (f" (rows {', '.join(map(str, cut))})" if cut else "") + (
            "; " + ", ".join(f"row {r}: {v} mm, the patent's" for r, v in spec["published_semi"].items())
            if spec.get("published_semi") else "") + ": the field",
        "# corners may be vignetted at full aperture; the axial beam at the stated f-number passes (flare lens check).",
        "# Stop: " + ("its radius at each position is the paraxial marginal ray's height there at the stated f-number "
                      "(the iris opens as the lens zooms; the patent prints F-numbers, not the stop's diameter)."
                      if varies else "its radius is the paraxial marginal ray's height there at the stated f-number."),
    ]
    if any(r.get("asph") for r in rows):
        note = ("Aspheres: the patent's aspheric coefficients (k, A4... as transcribed: docs/lens-format.md's even "
                "asphere) on rows " + ", ".join(str(i + 1) for i, r in enumerate(rows) if r.get("asph")) + (
                    f"; the hybrid resin layers (rows {', '.join(str(i + 1) for i in layers)}), the patent's own shape, "
                    f"keep their clear radius out to where they thin to {RESIN_LAYER_MIN_EDGE_MM} mm, not to a 0.3 mm "
                    "glass edge (RESIN_LAYER_MAX_MM)" if layers else "") + ". Focus: the focus solve moves the sensor (the "
                "patent's inner")
        out += ["# " + line for line in textwrap.wrap(note, 104)]
    else:
        out += ["# Aspheres: the surfaces the patent makes aspheric are their base spheres (the paraxial checks are",
                "# unaffected; ghost shapes are approximate). Focus: the focus solve moves the sensor (the patent's inner"]
    out += [
        "# focusing is not modelled). Glasses: the patent's nd/Vd, each with the dispersion shape of the nearest",
        "# catalogue glass (docs/lens-format.md). ASSUMPTION: a circular iris; single-layer MgF2 on every",
        "# air-glass surface, the project's usual assumption (the patent publishes no coating); the sensor",
        f"# 36 x 24 mm as in every library file (the clear radii above are sized for the {spec['format']} format).",
        f"name            {title} ({example})",
        f"source          {example}; zoom gaps and f-numbers from the patent's tables",
        "zoom            " + " ".join(f"{nm}={f:.2f}" for nm, f in zip(names, focal)),
    ]
    fnos = spec["f_numbers"]
    out.append("f_number        " + (f"{fnos[0]:g}" if len(set(fnos)) == 1 else
                                     " ".join(f"{nm}={v:g}" for nm, v in zip(names, fnos))))
    out.append("default_coating mgf2")
    if varies:
        out.append("aperture iris " + " ".join(f"{nm}={r:g}" for nm, r in zip(names, stop_radius)))
    for i, values in sorted(gaps.items()):
        out.append(f"gap d{i + 1:<4d}" + " ".join(f"{nm}={fmt(v)}" for nm, v in zip(names, values)))
    out += ["", "surfaces", "#  radius        thickness   material          semi_aperture"]
    for i, r in enumerate(rows):
        radius = "stop" if r["stop"] else ("inf" if r["radius"] == 0.0 else fmt(r["radius"]))
        thickness = "auto" if i == last else (f"d{i + 1}" if i in gaps else fmt(r["thickness"]))
        material = f"{fmt(r['nd'])}/{fmt(r['vd'])}" if r["nd"] > 1.001 else "air"
        aperture = "iris" if (r["stop"] and varies) else f"{semi[i]:.4f}"
        terms = " ".join(f"{key}={value:g}" for key, value in r.get("asph", {}).items())
        out.append(f"   {radius:<13s} {thickness:<11s} {material:<17s} {aperture} {terms}".rstrip())
    return "\n".join(out) + "\n", names


def main():
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    folder, git_dir, flare = sys.argv[1:]
    commit = subprocess.run(["git", "--git-dir", git_dir, "rev-parse", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    index_path = os.path.join(folder, "index.json")
    with open(index_path, encoding="utf-8") as f:
        index = json.load(f)
    aside_path = os.path.join(folder, "set-aside.json")
    with open(aside_path, encoding="utf-8") as f:
        aside = json.load(f)
    staging = tempfile.mkdtemp(prefix="flare-patent-zooms-")
    try:
        for spec in SPECS:
            rows, focal, gaps = read_table(git_dir, spec["lv"], spec.get("aspheres", False))
            raw, read_at = table_text(git_dir, spec["lv"])
            source = imp.SOURCE.search(raw)
            text, names = lens_text(spec, rows, focal, gaps, read_at or commit, source.group(1) if source else None)
            staged = os.path.join(staging, spec["id"] + ".lens")
            with open(staged, "w", encoding="utf-8") as f:
                f.write(text)
            result = imp.check_files(flare, [staged])[staged]
            source = f"{spec['lv']} ({'' if source else 'LensVisualizer; '}{spec['patent']} Example {spec['example']})"
            aside["set_aside"] = [e for e in aside["set_aside"] if e["source_file"] != source]
            if not result["ok"]:
                detail = "entered from the patent (scripts/patent_zooms.py): " + "; ".join(
                    f"{x['check']} ({x['zoom']}): {x['detail'].replace(staged, spec['id'] + '.lens')}"
                    for x in result["failures"])
                aside["set_aside"].append({"source_file": source, "id": spec["id"],
                                           "cause": "patent-zoom-" + imp.cause_of(result["failures"]),
                                           "detail": detail + (f"; {spec['why']}" if spec.get("why") else "")})
                print(f"failed  {spec['id']}: {detail}")
                continue
            checks = [f"# Check: paraxial EFL at {p['zoom']} {p['efl_mm']:.3f} mm (stated {p['stated_focal_length_mm']:.2f} mm), "
                      f"wide open f/{p['wide_open_f_number']:.3f}, ray fan at f/{p['fan_f_number']:.3f}."
                      for p in result["positions"]]
            lines = text.splitlines()
            at = next(i for i, line in enumerate(lines) if line.startswith("name "))
            lines[at:at] = checks
            relative = os.path.join(spec["folder"], spec["id"] + ".lens")
            with open(os.path.join(folder, relative), "w", encoding="utf-8") as f:
                f.write("\n".join(lines) + "\n")
            entry = {"id": spec["id"], "file": relative, "maker": spec["maker"], "model": spec["model"],
                     "name": f"{spec['maker']} {spec['model']} ({spec['patent']} Example {spec['example']})",
                     "kind": "zoom", "tags": [], "focal_length_mm": round(focal[0], 3),
                     "f_number": spec["f_numbers"][0], "patent": spec["patent"], "example": spec["example"],
                     "collection": "patent", "zoom_positions": names,
                     "zoom_focal_lengths_mm": [round(x, 2) for x in focal],
                     "focal_range_mm": [round(focal[0], 2), round(focal[-1], 2)]}
            lenses = index["lenses"]
            at = next((i for i, e in enumerate(lenses) if e["id"] == spec["id"]), None)
            if at is not None:
                lenses[at] = entry
            else:  # after the maker folder's last entry
                at = max((i for i, e in enumerate(lenses) if e["file"].startswith(spec["folder"] + "/")), default=len(lenses) - 1)
                lenses.insert(at + 1, entry)
            print(f"added   {spec['id']}: " + ", ".join(f"{p['zoom']} {p['efl_mm']:.3f} mm" for p in result["positions"]))
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    with open(index_path, "w", encoding="utf-8") as f:
        json.dump(index, f, indent=1, ensure_ascii=False)
        f.write("\n")
    aside["set_aside"].sort(key=lambda e: (e["cause"], e["source_file"]))
    with open(aside_path, "w", encoding="utf-8") as f:
        json.dump(aside, f, indent=1, ensure_ascii=False)
        f.write("\n")


if __name__ == "__main__":
    main()
