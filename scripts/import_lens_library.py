#!/usr/bin/env python3
"""Builds lenses/library from a public collection of patent prescriptions (docs/lens-library.md).

Source: the `.lens` files of FlareSim for Nuke (lenses/lens_files/, MIT licence), which are the
Optical Bench transcriptions of patent examples at photonstophotos.net. Their table has six columns:
radius, thickness, nd, Vd, the clear DIAMETER (the converter calls it a semi-aperture; see
docs/lens-library.md for the check against patent geometry) and a coating flag of its own.

Every converted lens is checked with `flare lens check` (load, EFL, stop, axial ray fan); lenses that
fail, and those set aside before (teleconverters, mirror lenses, duplicates, unusable glass data), go
to set-aside.json with their cause. Zoom lenses whose patent table gives several zoom states are
merged into one file with named positions (--lensvisualizer: the zoom states of the patent table).
Then scripts/merge_zoom_states.py adds the states of variable-aperture zooms (an f-number per state),
and last scripts/library_names.py keeps every name true to its prescription (renames or scales).

Usage (the FlareSim folder from a checkout or `git archive` of the collection):
    /usr/bin/python3 scripts/import_lens_library.py --flaresim FLARESIM/lenses --source-commit HASH \\
        --flare build/src/flare --lensvisualizer LENSVISUALIZER.git --out lenses/library
"""

import argparse
import collections
import concurrent.futures
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

COLLECTION = "flaresim"
COLLECTION_TEXT = ("FlareSim for Nuke, lenses/lens_files/ (github.com/petermercell/flaresim_nuke, forked from "
                   "LocalStarlight/flaresim_nuke; MIT licence), converted from the Optical Bench transcriptions "
                   "of patent examples at photonstophotos.net")

# Maker tokens in the collection's file names, spelled as the makers spell themselves.
MAKER_ALIASES = {
    "konica": "Konica Minolta", "konina": "Konica Minolta", "konica minolta": "Konica Minolta",
    "fujifim": "Fujifilm", "fujifilm": "Fujifilm", "simga": "Sigma", "sasmung": "Samsung",
    "venux": "Venus Optics", "venus": "Venus Optics", "rodenstein": "Rodenstock", "zhong": "Zhongyi",
    "zhong yi": "Zhongyi", "ricoh": "Pentax", "pentax": "Pentax", "ai": "Nikon", "af": "Nikon",
    "af-s": "Nikon", "zoom": "Nikon", "nikkor": "Nikon", "nikkor-n": "Nikon", "nikkor-s": "Nikon",
    "nikkor-h": "Nikon", "w-nikkor": "Nikon", "medical-nikkor": "Nikon", "coolpix": "Nikon",
    "mamiya-sekor": "Mamiya", "isco-gottingen": "Isco", "arriflex": "Arri", "~canon": "Canon",
    "7artisans": "7Artisans", "kino": "Kino Precision", "kino precision": "Kino Precision",
    "leica": "Leica", "zeiss": "Zeiss", "phase": "Phase One", "pikaichi": "Nikon", "th": "Irix",
    "cosina voigtlander": "Voigtlander", "konica minolta": "Konica Minolta", "phase one": "Phase One",
    "kino precision": "Kino Precision", "zhong yi": "Zhongyi",
}

STEM = re.compile(r"^(?P<maker>.*?)_?(?P<focal>\d+(?:\.\d+)?(?:-\d+(?:\.\d+)?)?)(?:mm)?_[Ff](?P<fno>\d+(?:\.\d+)?(?:-\d+(?:\.\d+)?)?)"
                  r"(?P<tags>[^()]*?)_*(?:\((?P<product>.*)\))?$")


def slug(text):
    s = re.sub(r"[^a-z0-9.]+", "-", text.lower()).strip("-.")
    return re.sub(r"-+", "-", s)


def canonical_maker(token):
    """The maker from the first one or two words of a file name or product name."""
    words = token.strip().replace("_", " ").split()
    if not words:
        return ""
    two = " ".join(words[:2]).lower()
    if two in MAKER_ALIASES:
        return MAKER_ALIASES[two]
    return MAKER_ALIASES.get(words[0].lower(), words[0])


def read_flaresim(path):
    """The header fields and the surface rows of one collection file."""
    with open(path, encoding="utf-8", errors="replace") as f:
        text = f.read()
    lens = {"title": "", "patent": "", "name": "", "focal": None, "fno_comment": None, "rows": []}
    in_rows = False
    for line in text.splitlines():
        s = line.strip()
        if not in_rows:
            if s.startswith("#"):
                body = s[1:].strip()
                if not lens["title"] and body:
                    lens["title"] = body
                elif body.startswith("Patent:"):
                    lens["patent"] = body[len("Patent:"):].strip()
                m = re.search(r"f/(\d+(?:\.\d+)?)\s*$", body)
                if m and "surfaces" in body:
                    lens["fno_comment"] = float(m.group(1))
            elif s.startswith("name:"):
                lens["name"] = s[5:].strip()
            elif s.startswith("focal_length:"):
                lens["focal"] = float(s[len("focal_length:"):])
            elif s.startswith("surfaces:"):
                in_rows = True
            continue
        if not s or s.startswith("#"):
            continue
        cols = s.split()
        lens["rows"].append({"stop": cols[0].lower() == "stop",
                             "radius": 0.0 if cols[0].lower() == "stop" else float(cols[0]),
                             "thickness": float(cols[1]), "nd": float(cols[2]), "vd": float(cols[3]),
                             "diameter": float(cols[4])})
    return lens


def patent_examples(flaresim_dir):
    """Collection file stem -> (Optical Bench data file, example number), from its batch script."""
    script = os.path.join(flaresim_dir, "all_lenses.sh")
    out = {}
    with open(script, encoding="utf-8", errors="replace") as f:
        for data, stem in re.findall(r"Data/(\S+?)\.txt -o lens_files_v2/(.*)\.lens", f.read()):
            m = re.search(r"_Example(\d+)", data)
            out[stem] = (data, int(m.group(1)) if m else 0)
    return out


def pretty_patent(code):
    """US004621909 -> US 4,621,909; JP2000-019398 -> JP 2000-019398; others as given."""
    m = re.fullmatch(r"US0*(\d{6,7})", code)
    if m:
        return "US " + f"{int(m.group(1)):,}"
    m = re.fullmatch(r"US(\d{4})(\d{7})", code)
    if m:
        return f"US {m.group(1)}/{m.group(2)}"
    m = re.fullmatch(r"([A-Z]{2})(.*)", code)
    return f"{m.group(1)} {m.group(2)}" if m else code


def describe(stem, lens, examples):
    """Maker, model, kind, tags, design focal range and f-number of one collection file."""
    info = {"stem": stem}
    m = STEM.match(stem)
    product = ""
    tags_text = ""
    if m:
        maker_token = stem if m.group("maker") else (m.group("product") or "").split("_")[0]
        product = (m.group("product") or "").replace("_", " ").strip()
        focal_text, fno_text, tags_text = m.group("focal"), m.group("fno"), m.group("tags") or ""
        info["focal_range"] = [float(x) for x in focal_text.split("-")]
        info["fno_range"] = [float(x) for x in fno_text.split("-")]
    else:
        maker_token = stem
        product = lens["name"]
        info["focal_range"] = None
        info["fno_range"] = None
    named_after_patent = re.match(r"^~?(US|JP|WO|CN|DE|EP|GB|FR)\s*[\d,/ -]", lens["name"]) is not None
    if not product and not named_after_patent:
        product = lens["name"]
    info["maker"] = canonical_maker(maker_token)
    model = product
    # The model without the maker's name (or the brand it was sold under: "Ricoh smc Pentax ...").
    for prefix in (info["maker"], "Ricoh", "Konica Minolta", "Konica", "Cosina", "Zhong Yi", "TH Swiss"):
        if model.lower().startswith(prefix.lower() + " "):
            model = model[len(prefix) + 1:]
    info["model"] = model
    data, example = examples.get(stem, ("", 0))
    info["example"] = example
    info["patent"] = pretty_patent(lens["patent"]) if lens["patent"] else ""
    text = (stem + " " + lens["name"]).lower()
    tags = []
    for word, tag in (("fisheye", "fisheye"), ("macro", "macro"), ("mirror", "mirror"), ("reflex", "mirror"),
                      ("_tc", "teleconverter"), ("tc_", "teleconverter"), ("extender", "teleconverter"),
                      ("teleconverter", "teleconverter"), ("mutar", "converter"), ("conversion", "converter"),
                      ("with_main_lens", "with-converter"), ("3d_left", "stereo-left"), ("3d_right", "stereo-right"),
                      ("anamorphic", "anamorphic")):
        if word in text and tag not in tags:
            tags.append(tag)
    focal_range = info["focal_range"]
    is_zoom = (focal_range is not None and len(focal_range) == 2) or re.search(r"\d-\d+\s*mm", lens["name"]) is not None
    info["kind"] = "zoom" if is_zoom else "prime"
    if is_zoom and (focal_range is None or len(focal_range) != 2):
        m2 = re.search(r"(\d+(?:\.\d+)?)-(\d+(?:\.\d+)?)\s*mm", lens["name"])
        info["focal_range"] = [float(m2.group(1)), float(m2.group(2))] if m2 else None
    info["tags"] = tags
    if info["fno_range"]:
        info["f_number"] = info["fno_range"][0]
    else:
        m3 = re.search(r"[Ff]/?(\d+(?:\.\d+)?)", lens["name"])
        info["f_number"] = lens["fno_comment"] or (float(m3.group(1)) if m3 else None)
    info["named_after_patent"] = named_after_patent
    return info


def early_cause(lens, info):
    """A reason to set the lens aside before converting it, or None."""
    if "teleconverter" in info["tags"] or ("converter" in info["tags"] and "with-converter" not in info["tags"]):
        return "teleconverter-or-attachment", "a teleconverter or afocal attachment, not a complete camera lens"
    if "mirror" in info["tags"] or any(r["thickness"] < 0 for r in lens["rows"]):
        return "catadioptric", "a mirror (catadioptric) lens: the .lens format has no mirror surfaces"
    if not any(r["stop"] for r in lens["rows"]):
        return "no-stop", "the table has no aperture stop row"
    for i, r in enumerate(lens["rows"]):
        if r["nd"] > 1.001 and not (5.0 <= r["vd"] <= 150.0 and r["nd"] <= 3.0):
            return "glass-data", f"row {i + 1}: glass nd {r['nd']} with Abbe number {r['vd']} outside [5, 150]"
        if r["diameter"] <= 0.0:
            return "aperture-data", f"row {i + 1}: no clear diameter"
    stop = next(i for i, r in enumerate(lens["rows"]) if r["stop"])
    for i, r in enumerate(lens["rows"][:-1]):
        if r["thickness"] == 0.0 and i not in (stop - 1, stop):
            return "zero-gap", (f"row {i + 1}: zero axial gap (the source's converter writes an unresolved variable "
                                "gap as 0)")
    if lens["focal"] is None or lens["focal"] <= 0.0:
        return "no-focal-length", "the file states no positive focal length"
    if info["f_number"] is None:
        return "no-f-number", "no f-number in the file or its name"
    return None


# Clear apertures are cut back where the source's would make two surfaces cross (see
# fit_apertures): an air space keeps at least this edge thickness, a glass element at least this,
# neither more than half its axial thickness; a surface keeps its rim below this share of |radius|.
MIN_AIR_EDGE_MM = 0.1
MIN_GLASS_EDGE_MM = 0.3
MAX_RIM_TO_RADIUS = 0.98


def sag(radius, r, asph=None):
    """The sag at height r of a sphere of this radius (0: a plane), or with asph ({"k": conic, "A4":
    ..., "A16": ...}) of the even asphere docs/lens-format.md defines on it."""
    if not asph:
        if radius == 0.0:
            return 0.0
        return radius - (1.0 if radius > 0 else -1.0) * (radius * radius - r * r) ** 0.5
    z = 0.0
    if radius != 0.0:
        c = 1.0 / radius
        z = c * r * r / (1.0 + (1.0 - (1.0 + asph.get("k", 0.0)) * c * c * r * r) ** 0.5)
    return z + sum(value * r ** int(key[1:]) for key, value in asph.items() if key != "k")


def fit_apertures(lens):
    """Cuts the source's clear radii back to what the geometry allows; returns notes for the file.

    The collection's diameters are mostly the Optical Bench's estimates, not patent data: some reach
    past where two surfaces meet (negative edge thickness) or past a hemisphere. Such a radius is
    reduced to the largest one at which every edge keeps the minimum thickness above, with the
    surfaces' full curvature; whether the published f-number's axial beam still passes is for the
    ray-fan check to say.
    """
    rows = lens["rows"]
    notes = []
    semi = [r["diameter"] / 2.0 for r in rows]
    original = list(semi)
    for i, r in enumerate(rows):
        if not r["stop"] and r["radius"] != 0.0 and semi[i] > MAX_RIM_TO_RADIUS * abs(r["radius"]):
            semi[i] = MAX_RIM_TO_RADIUS * abs(r["radius"])
    # Cutting one radius flattens that surface's profile sooner, which can thin the edge on its
    # other side: repeat until nothing changes.
    for _ in range(len(rows)):
        if not cut_pass(rows, semi):
            break
    for i, r in enumerate(rows):
        r["semi"] = semi[i]
        if semi[i] < original[i] - 1e-9:
            notes.append(f"row {i + 1}: clear radius {original[i]:.3f} -> {semi[i]:.3f} mm")
    return notes


def cut_pass(rows, semi):
    """One pass of fit_apertures over every gap; True if a radius was cut. A row may carry `asph`
    (its surface's aspheric terms, for sag) and `min_edge_mm` (the edge its gap keeps, instead of
    the minimum above: scripts/patent_zooms.py's hybrid resin layers)."""
    changed = False
    for i in range(len(rows) - 1):
        a, b = rows[i], rows[i + 1]
        t = a["thickness"]
        glass = a["nd"] > 1.001
        margin = a.get("min_edge_mm", min(MIN_GLASS_EDGE_MM if glass else MIN_AIR_EDGE_MM, 0.5 * t))
        reach = max(semi[i], semi[i + 1])
        # The largest radius out to which the gap stays at least `margin` (64 steps, then bisection).
        def gap(r):
            return (t + sag(b["radius"], min(r, semi[i + 1]), b.get("asph")) -
                    sag(a["radius"], min(r, semi[i]), a.get("asph")))
        if min(gap(reach * k / 64.0) for k in range(65)) >= margin:
            continue
        lo, hi = 0.0, reach
        for k in range(1, 65):
            if gap(reach * k / 64.0) < margin:
                hi = reach * k / 64.0
                break
            lo = reach * k / 64.0
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            if gap(mid) >= margin:
                lo = mid
            else:
                hi = mid
        for k in (i, i + 1):
            if not rows[k]["stop"] and semi[k] > lo:
                semi[k] = lo
                changed = True
    return changed


# A stop row at zero distance from a neighbouring vertex is moved this far off it, into the gap on
# its other side (see separate_stop).
STOP_OFFSET_MM = 0.01


def separate_stop(lens):
    """Moves a stop that lies on a neighbouring surface's vertex plane STOP_OFFSET_MM off it.

    The tracer does not count a hit at zero distance, so a ray along the axis from a vertex to a
    coincident stop plane (or from the stop to a coincident vertex) is reported as missing the surface.
    The stop is a plane in air: moving it changes no paraxial quantity, only the pupils' positions,
    by STOP_OFFSET_MM. Returns a note for the file, or None.
    """
    rows = lens["rows"]
    k = next(i for i, r in enumerate(rows) if r["stop"])
    before = rows[k - 1] if k > 0 else None
    after_gap = rows[k]["thickness"]
    if before is not None and before["thickness"] == 0.0 and after_gap > 2 * STOP_OFFSET_MM:
        before["thickness"] = STOP_OFFSET_MM
        rows[k]["thickness"] = after_gap - STOP_OFFSET_MM
        return f"Stop: on the vertex of row {k} in the source; moved {STOP_OFFSET_MM} mm behind it (tracing needs a gap)."
    if after_gap == 0.0 and before is not None and before["thickness"] > 2 * STOP_OFFSET_MM and k + 1 < len(rows):
        before["thickness"] -= STOP_OFFSET_MM
        rows[k]["thickness"] = STOP_OFFSET_MM
        return f"Stop: on the vertex of row {k + 2} in the source; moved {STOP_OFFSET_MM} mm in front of it (tracing needs a gap)."
    return None


# The zoom tables LensVisualizer added after the snapshot its git folder holds (lenses/zoom-tables/,
# README.md there): the patent's numbers only, each file naming the LensVisualizer file and commit
# they were read from. Read beside the git folder's; a later table replaces one of the same path.
# A table of a patent LensVisualizer has not transcribed names its source instead, in a `source: "..."`
# field (SOURCE), and is cited by its own path there.
LATER_TABLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "lenses", "zoom-tables")


SOURCE = re.compile(r'^\s*source:\s*"([^"]+)",?\s*$', re.M)


def lensvisualizer_texts(git_dir, later=LATER_TABLES, git=None):
    """{LensVisualizer path: (text, commit)} of every .data.ts file: the git folder's at HEAD (commit
    None: the folder's HEAD) and the later tables (`later`/<maker>/<file>, commit from their header;
    a table that names its `source` instead is keyed by its path in this repository, commit None)."""
    if git is None:
        def git(*a):
            return subprocess.run(["git", "--git-dir", git_dir, *a], capture_output=True, text=True,
                                  check=True).stdout
    texts = {}
    for path in git("ls-tree", "-r", "--name-only", "HEAD", "src/lens-data").split("\n"):
        if path.endswith(".data.ts"):
            texts[path] = (git("show", "HEAD:" + path), None)
    if later and os.path.isdir(later):
        for maker in sorted(os.listdir(later)):
            folder = os.path.join(later, maker)
            if not os.path.isdir(folder):
                continue
            for name in sorted(os.listdir(folder)):
                if not name.endswith(".data.ts"):
                    continue
                with open(os.path.join(folder, name), encoding="utf-8") as f:
                    text = f.read()
                commit = re.search(r"\bcommit ([0-9a-f]{12,40})\b", text)
                if SOURCE.search(text) and not commit:
                    texts[f"lenses/zoom-tables/{maker}/{name}"] = (text, None)
                    continue
                if not commit:
                    raise SystemExit(f"{os.path.join(folder, name)}: names no LensVisualizer commit and no source")
                texts[f"src/lens-data/{maker}/{name}"] = (text, commit.group(1))
    return texts


def lensvisualizer_table(path, text, commit=None):
    """One LensVisualizer file's zoom table ({"file", "commit", "text", "focal_lengths", "gaps":
    {label: [value per position]}, "labels": [surface label per row], "thicknesses"}), or None when it
    has not several zoom states. Only the patent's numbers are used: the radii (to match a collection
    file), the zoom states' focal lengths and their variable gaps at infinity focus."""
    number = r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?"
    zoom = re.search(r"zoomPositions:\s*\[([^\]]*)\]", text)
    var = re.search(r"\bvar:\s*\{(.*?)\n  \},", text, re.S)
    if not zoom or not var:
        return None
    focal_lengths = [float(x) for x in re.findall(number, zoom.group(1))]
    rows = re.findall(r'\{\s*label:\s*"([^"]+)",\s*R:\s*(' + number + r')', text)
    gaps = {}
    # A gap's label is a quoted string ("27A": ...) or, in some files, a bare number (13: ...) or the
    # bare STO of the gap behind the stop (the gap that row's thickness column holds).
    for quoted, bare, body in re.findall(r'(?:"([^"]+)"|\b(\d+[A-Za-z]?|STO)):\s*\[((?:\s*\[[^\]]*\],?)+)\s*\]',
                                         var.group(1)):
        label = quoted or bare
        states = re.findall(r"\[([^\]]*)\]", body)
        gaps[label] = [float(re.findall(number, st)[0]) for st in states]
    if len(focal_lengths) < 2 or not rows or any(len(v) != len(focal_lengths) for v in gaps.values()):
        return None
    # Each row's gap as the surface list prints it (the first state's): merge_zoom_states.py needs
    # the gap beside a stop that the table places in another air space than a library file does.
    thick = re.findall(r'\{\s*label:\s*"[^"]+",\s*R:\s*' + number + r',\s*d:\s*(' + number + r')', text)
    source = SOURCE.search(text)
    return {"file": path, "commit": commit, "text": text, "focal_lengths": focal_lengths, "gaps": gaps,
            "labels": [lb for lb, _ in rows], "radii": [float(r) for _, r in rows],
            "thicknesses": [float(t) for t in thick] if len(thick) == len(rows) else None,
            "source": source.group(1) if source else None}


def lensvisualizer_zooms(git_dir, later=LATER_TABLES):
    """Zoom tables of the LensVisualizer transcriptions (patent examples with several zoom states):
    {radii signature (the refracting rows' radii to 0.01 mm): lensvisualizer_table(...)}."""
    tables = {}
    for path, (text, commit) in lensvisualizer_texts(git_dir, later).items():
        table = lensvisualizer_table(path, text, commit)
        if table:
            key = tuple(round(r, 2) for label, r in zip(table["labels"], table["radii"])
                        if label.upper() not in ("STO", "STOP"))
            tables[key] = table
    return tables


def match_zoom(lens, info, tables, commit):
    """The zoom spec of a collection file whose patent table LensVisualizer transcribes with several
    zoom states, or None. Merged only for constant-aperture zooms (the file states one f-number) and
    when the collection file is the table's first zoom state."""
    if info["kind"] != "zoom" or (info["fno_range"] and len(info["fno_range"]) > 1):
        return None
    key = tuple(round(r["radius"], 2) for r in lens["rows"] if not r["stop"])
    table = tables.get(key)
    if not table or len(table["labels"]) != len(lens["rows"]):
        return None
    gaps = {}
    for label, values in table["gaps"].items():
        if label not in table["labels"]:
            return None
        row = table["labels"].index(label)
        if row + 1 == len(lens["rows"]):
            continue  # the back focus: the sensor is placed by the focus solve
        if abs(values[0] - lens["rows"][row]["thickness"]) > 1e-3:
            return None
        if max(values) - min(values) > 1e-9:
            gaps[row] = values
    if not gaps:
        return None
    n = len(table["focal_lengths"])
    names = ["wide", "tele"] if n == 2 else ["wide"] + (["mid"] if n == 3 else [f"mid{i}" for i in range(1, n - 1)]) + ["tele"]
    return {"positions": list(zip(names, table["focal_lengths"])), "gaps": gaps,
            "source": (f"the variable gaps at {n} zoom states (infinity focus) and the states' focal lengths are the "
                       f"patent table's, {table_citation(table, commit, 'this collection file')}")}


def table_citation(table, commit, matched_to):
    """Where a zoom table's numbers were read: LensVisualizer's file and commit, or, for a table of
    lenses/zoom-tables that names its own source, that file and its source; and what its radii were
    matched to."""
    if table.get("source"):
        return f"as {table['file']} gives them ({table['source']}; the radii were matched to {matched_to})"
    return (f"as transcribed in LensVisualizer (github.com/ronbuening/LensVisualizer, {table['file']}, commit "
            f"{(table.get('commit') or commit)[:12]}; no licence stated there: only the patent's numbers are taken, "
            f"and the radii were matched to {matched_to})")


def table_key(lens):
    return tuple((round(r["radius"], 4), round(r["thickness"], 4), round(r["nd"], 5)) for r in lens["rows"])


def material(row):
    return "air" if row["nd"] <= 1.001 else f"{row['nd']:.5f}/{row['vd']:.2f}"


def fmt(x):
    return f"{x:.6g}" if abs(x) < 1e5 else f"{x:.6e}"


def lens_text(lens, info, zoom=None, notes=None, glasses=None):
    """The .lens file. `zoom`: {"positions": [(name, focal)], "gaps": {row index: [values]}}."""
    rows = lens["rows"]
    out = []
    title = info["maker"] + " " + (info["model"] or lens["name"])
    patent = f"{info['patent']} Example {info['example']}" if info["example"] else info["patent"]
    out.append(f"# {title}")
    out.append(f"# Patent: {patent}." + ("" if info["model"] else " A patent example not tied to a product."))
    out.append(f"# Collection: {COLLECTION_TEXT}; file lenses/lens_files/{info['stem']}.lens.")
    out.append("# Converted by scripts/import_lens_library.py (docs/lens-library.md):")
    out.append("#   semi-apertures are half the source's clear-diameter column;")
    out.append("#   the sensor sits at the paraxial focus for an object at infinity (thickness 'auto' on the last row);")
    out.append("#   glasses are the published nd/Vd; each takes the dispersion shape of the nearest built-in catalogue")
    out.append("#   glass, scaled to reproduce nd and Vd (docs/lens-format.md); the glass named at import is noted per row;")
    out.append("#   coating: ASSUMPTION, single-layer MgF2 on every air-glass surface (the source publishes none);")
    out.append("#   aspheres: the source carries no aspheric coefficients; every surface is its base sphere;")
    out.append("#   the iris is circular and the sensor 36 x 24 mm (neither is in the source).")
    for note in notes or []:
        out.append("# " + note)
    name = f"{title} ({patent})"
    out.append(f"name            {name}")
    out.append(f"source          {patent}; {COLLECTION} collection (MIT), Optical Bench transcription")
    if zoom:
        out.append("zoom            " + " ".join(f"{n}={f:.2f}" for n, f in zoom["positions"]))
    else:
        out.append(f"focal_length_mm {lens['focal']:.2f}")
    out.append(f"f_number        {info['f_number']:g}")
    out.append("default_coating mgf2")
    if zoom:
        for k, values in sorted(zoom["gaps"].items()):
            out.append(f"gap d{k + 1:<4d}" + " ".join(f"{n}={v:g}" for (n, _), v in zip(zoom["positions"], values)))
    out.append("")
    out.append("surfaces")
    out.append("#  radius        thickness   material          semi_aperture")
    for i, r in enumerate(rows):
        radius = "stop" if r["stop"] else ("inf" if r["radius"] == 0.0 else fmt(r["radius"]))
        if i + 1 == len(rows):
            thickness = "auto"
        elif zoom and i in zoom["gaps"]:
            thickness = f"d{i + 1}"
        else:
            thickness = fmt(r["thickness"])
        line = f"   {radius:<13s} {thickness:<11s} {material(r):<17s} {fmt(r['semi']):<10s}"
        if glasses and glasses.get(i):
            line += f"  # {glasses[i]}"
        out.append(line.rstrip())
    return "\n".join(out) + "\n"


def run_json(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0, 2):
        raise RuntimeError(f"{' '.join(cmd[:3])}: exit {p.returncode}: {p.stderr.strip()}")
    return json.loads(p.stdout) if p.stdout.strip() else None


def check_files(flare, paths):
    """flare lens check --json over many files, in two parallel batches."""
    results = {}
    batches = [paths[i::2] for i in range(2)]
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        for out in pool.map(lambda b: run_json([flare, "lens", "check", "--json", *b]) if b else {"lenses": []}, batches):
            for entry in out["lenses"]:
                results[entry["lens"]] = entry
    return results


def lens_info(flare, path):
    p = subprocess.run([flare, "lens", "info", "--json", path], capture_output=True, text=True)
    return json.loads(p.stdout) if p.returncode == 0 else None


def cause_of(failures):
    """A short machine-readable cause from `flare lens check` failures."""
    first = failures[0]
    if first["check"] != "load":
        return first["check"]
    detail = first["detail"]
    for pattern, cause in (("cross", "elements-intersect"), ("edge", "elements-intersect"),
                           ("larger than |radius|", "aperture-beyond-hemisphere"), ("focus solve", "focus-solve"),
                           ("more than", "too-many-surfaces")):
        if pattern in detail:
            return cause
    return "load"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--flaresim", required=True, help="the collection's lenses/ folder (holding lens_files/ and all_lenses.sh)")
    ap.add_argument("--source-commit", required=True, help="commit of the collection the files were taken from")
    ap.add_argument("--flare", required=True, help="the flare program (for lens check and lens info)")
    ap.add_argument("--lensvisualizer", help="git folder of LensVisualizer: zoom states of patent tables for merging")
    ap.add_argument("--out", required=True, help="the library folder to write (replaced)")
    args = ap.parse_args()

    examples = patent_examples(args.flaresim)
    files = sorted(f for f in os.listdir(os.path.join(args.flaresim, "lens_files")) if f.endswith(".lens"))
    zoom_tables, lv_commit = {}, ""
    if args.lensvisualizer:
        zoom_tables = lensvisualizer_zooms(args.lensvisualizer)
        lv_commit = subprocess.run(["git", "--git-dir", args.lensvisualizer, "rev-parse", "HEAD"], capture_output=True,
                                   text=True, check=True).stdout.strip()

    set_aside = []
    candidates = []
    seen_tables = {}
    for name in files:
        stem = name[:-len(".lens")]
        lens = read_flaresim(os.path.join(args.flaresim, "lens_files", name))
        info = describe(stem, lens, examples)
        cause = early_cause(lens, info)
        if cause is None:
            key = table_key(lens)
            if key in seen_tables:
                cause = ("duplicate", f"the same surface table as lenses/lens_files/{seen_tables[key]}.lens")
            else:
                seen_tables[key] = stem
        if cause:
            set_aside.append({"source_file": f"lenses/lens_files/{name}", "cause": cause[0], "detail": cause[1]})
            continue
        info["stop_note"] = separate_stop(lens)
        info["aperture_notes"] = fit_apertures(lens)
        candidates.append((stem, lens, info))

    # Ids: maker + model (or the design description of an unidentified patent example); a repeat
    # gets its patent example appended.
    ids = collections.Counter()
    for stem, lens, info in candidates:
        base = slug(info["maker"] + " " + (info["model"] or stem.split("_", 1)[-1]))
        info["id"] = base
        ids[base] += 1
    for stem, lens, info in candidates:
        if ids[info["id"]] > 1:
            info["id"] = slug(info["id"] + " " + info["patent"].replace(",", "") + f" ex{info['example']}")
    seen_ids = collections.Counter()
    for stem, lens, info in candidates:
        seen_ids[info["id"]] += 1
        if seen_ids[info["id"]] > 1:
            info["id"] += f"-{seen_ids[info['id']]}"

    staging = tempfile.mkdtemp(prefix="flare-lens-import-")
    try:
        staged = {}
        merged = {}
        for stem, lens, info in candidates:
            path = os.path.join(staging, info["id"] + ".lens")
            with open(path, "w", encoding="utf-8") as f:
                f.write(lens_text(lens, info))
            staged[path] = (stem, lens, info, None, None)
            zoom = match_zoom(lens, info, zoom_tables, lv_commit)
            if zoom:
                zoom_path = os.path.join(staging, info["id"] + ".zoom.lens")
                with open(zoom_path, "w", encoding="utf-8") as f:
                    f.write(lens_text(lens, info, zoom))
                merged[path] = zoom_path
                staged[zoom_path] = (stem, lens, info, zoom, zoom)
        results = check_files(args.flare, list(staged))
        # A merged zoom that passes replaces its single-position file; one that fails is set aside
        # (with its cause) and the single position ships if it passes.
        for single, zoom_path in merged.items():
            if results[zoom_path]["ok"]:
                del staged[single]
            else:
                stem, lens, info, _, _ = staged.pop(zoom_path)
                set_aside.append({"source_file": f"lenses/lens_files/{stem}.lens", "id": info["id"],
                                  "cause": "zoom-merge-" + cause_of(results[zoom_path]["failures"]),
                                  "detail": "merged zoom: " + "; ".join(
                                      f"{x['check']} ({x['zoom']}): {x['detail']}" for x in results[zoom_path]["failures"])})
        passed = []
        for path, (stem, lens, info, zoom_spec, zoom) in staged.items():
            result = results[path]
            if not result["ok"]:
                failures = result["failures"]
                set_aside.append({"source_file": f"lenses/lens_files/{stem}.lens", "id": info["id"],
                                  "cause": cause_of(failures),
                                  "detail": "; ".join((f"{x['check']}" + (f" ({x['zoom']})" if x["zoom"] else "") +
                                                       f": {x['detail']}") for x in failures)})
                continue
            passed.append(path)

        # Lenses entered by hand from a patent (index entries of another collection, such as the
        # thesis's 80-200 mm zoom) are not the collection's: kept as they are, files and entries.
        kept_entries, kept_files = [], {}
        if os.path.isfile(os.path.join(args.out, "index.json")):
            with open(os.path.join(args.out, "index.json"), encoding="utf-8") as f:
                old_index = json.load(f)
            for e in old_index.get("lenses", []):
                if e.get("collection", COLLECTION) != COLLECTION:
                    kept_entries.append(e)
                    with open(os.path.join(args.out, e["file"]), encoding="utf-8") as f:
                        kept_files[e["file"]] = f.read()
            kept_collections = {k: v for k, v in old_index.get("collections", {}).items() if k != COLLECTION}
        else:
            kept_collections = {}
        if os.path.isdir(args.out):
            for entry in os.listdir(args.out):
                full = os.path.join(args.out, entry)
                if os.path.isdir(full):
                    shutil.rmtree(full)
        os.makedirs(args.out, exist_ok=True)
        infos = {}
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            for path, j in zip(passed, pool.map(lambda p: lens_info(args.flare, p), passed)):
                infos[path] = j
        index = []
        for path in passed:
            stem, lens, info, zoom_spec, zoom = staged[path]
            j = infos[path]
            glasses = {}
            for i, row in enumerate(j["surface_rows"]):
                m = re.search(r"\(dispersion of (.*)\)", row["material"])
                if m:
                    glasses[i] = "dispersion of " + m.group(1)
            notes = []
            back_focus = lens["rows"][-1]["thickness"]
            image = j["image_distance_mm"]
            notes.append(f"Back focus: the source's last gap is {back_focus:.4f} mm; the paraxial focus lies "
                         f"{image:.4f} mm behind the last surface ({image - back_focus:+.4f} mm)"
                         + (" at the first zoom position." if zoom_spec else "."))
            if info["stop_note"]:
                notes.append(info["stop_note"])
            if info["aperture_notes"]:
                notes.append("Clear radii cut back so that no edge is thinner than "
                             f"{MIN_AIR_EDGE_MM} mm (air) / {MIN_GLASS_EDGE_MM} mm (glass), or half the axial gap, "
                             f"and no rim passes {MAX_RIM_TO_RADIUS} |radius| (the source's radii cross there):")
                notes.extend("  " + n for n in info["aperture_notes"])
            if zoom:
                notes.append("Zoom: " + zoom["source"] + ".")
            positions = results[path]["positions"]
            for p in positions:
                notes.append(f"Check: paraxial EFL{(' at ' + p['zoom']) if p['zoom'] else ''} "
                             f"{p['efl_mm']:.3f} mm (stated {p['stated_focal_length_mm']:.2f} mm), "
                             f"wide open f/{p['wide_open_f_number']:.3f} (stated f/{info['f_number']:g}).")
            text = lens_text(lens, info, zoom_spec, notes, glasses)
            maker_dir = slug(info["maker"])
            os.makedirs(os.path.join(args.out, maker_dir), exist_ok=True)
            relative = f"{maker_dir}/{info['id']}.lens"
            with open(os.path.join(args.out, relative), "w", encoding="utf-8") as f:
                f.write(text)
            focal_range = info["focal_range"] if info["kind"] == "zoom" and info["focal_range"] else None
            tags = list(info["tags"])
            if info["kind"] == "zoom" and not zoom_spec:
                tags.append("zoom-first-position-only")
            entry = {"id": info["id"], "file": relative, "maker": info["maker"], "model": info["model"],
                     "name": j["name"], "kind": info["kind"], "tags": tags,
                     "focal_length_mm": round(positions[0]["stated_focal_length_mm"], 3),
                     "f_number": info["f_number"], "patent": info["patent"], "example": info["example"],
                     "collection": COLLECTION, "source_file": f"lenses/lens_files/{stem}.lens"}
            if zoom_spec:
                entry["zoom_positions"] = [n for n, _ in zoom_spec["positions"]]
                entry["zoom_focal_lengths_mm"] = [f for _, f in zoom_spec["positions"]]
                entry["focal_range_mm"] = [zoom_spec["positions"][0][1], zoom_spec["positions"][-1][1]]
            elif focal_range:
                # The file holds one state of this zoom: it can be set to its EFL only, so the
                # zoom's range is kept apart from what a search by focal length matches.
                entry["zoom_range_mm"] = sorted(focal_range)
            index.append(entry)
        for relative, text in kept_files.items():
            os.makedirs(os.path.dirname(os.path.join(args.out, relative)), exist_ok=True)
            with open(os.path.join(args.out, relative), "w", encoding="utf-8") as f:
                f.write(text)
        index.extend(kept_entries)
        index.sort(key=lambda e: (e["maker"].lower(), e["focal_length_mm"], e["id"]))
        set_aside.sort(key=lambda e: (e["cause"], e["source_file"]))
        meta = {"collections": {COLLECTION: {"description": COLLECTION_TEXT, "licence": "MIT",
                                             "commit": args.source_commit}, **kept_collections}}
        with open(os.path.join(args.out, "index.json"), "w", encoding="utf-8") as f:
            json.dump({**meta, "lenses": index}, f, indent=1, ensure_ascii=False)
            f.write("\n")
        with open(os.path.join(args.out, "set-aside.json"), "w", encoding="utf-8") as f:
            json.dump({**meta, "set_aside": set_aside}, f, indent=1, ensure_ascii=False)
            f.write("\n")
    finally:
        shutil.rmtree(staging, ignore_errors=True)

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    # Zoom states that need an f-number per state (variable-aperture zooms), from the same tables.
    if args.lensvisualizer:
        import merge_zoom_states
        merged, failed = merge_zoom_states.apply(args.out, args.lensvisualizer, args.flare)
        print(f"  zoom states merged into {len(merged)} more files; {len(failed)} merges failed their checks")

    # Names true to the prescriptions: scale known normalised examples, rename the rest.
    import library_names
    for old, new, problem, how in library_names.apply(args.out):
        print(f"  {how} {old} -> {new} ({problem})")

    causes = collections.Counter(e["cause"] for e in set_aside)
    print(f"{len(files)} source files; {len(index)} lenses pass and ship; {len(set_aside)} set aside:")
    for cause, n in causes.most_common():
        print(f"  {n:5d}  {cause}")


if __name__ == "__main__":
    sys.exit(main())
