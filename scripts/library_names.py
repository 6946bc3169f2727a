#!/usr/bin/env python3
"""Keeps every library lens's name true to its prescription (docs/lens-library.md, "Names").

A library id promises a focal length (or zoom range) and an f-number ("canon-ef50mm-f1.4-usm").
The collection attributes some patent examples to a product whose numbers they do not have (an
example of another lens in the same patent, or a table normalised to f = 100). This script reads an
imported library folder and, for every lens whose focal length differs from its name's by more than
ISO 517's 5 % (zooms: the file's positions outside the named range by more than that) or whose
f-number differs by more than a third of a stop:
  - scales the prescription to the named focal length when the example is known to be that lens
    and its table is normalised (KNOWN_NORMALISED, with the evidence);
  - otherwise renames it for what it is: maker, the prescription's own focal length (or the zoom
    range its source names) and f-number, patent and example; the old id is kept in the index as
    `renamed_from` (the CLI names the new id when the old one is asked for) and the name says
    which product the source listed it as.
The same reading of names is src/flare/optics/LensName.cpp; the unit test
LensLibrary.EveryNameMatchesItsPrescription checks the result with the paraxial EFL. Idempotent.

Usage:  /usr/bin/python3 scripts/library_names.py lenses/library
(scripts/import_lens_library.py runs it on the library it writes.)
"""

import json
import os
import re
import sys

FOCAL_TOLERANCE = 0.05            # ISO 517: marked focal length within 5 % of the real one
F_NUMBER_FACTOR = 2 ** (1 / 6)    # marked f-numbers: the nearest third stop

# Patent examples normalised to a round focal length that are known to be the named lens: scaled
# to the named focal length (every length of the table times the factor; f-number unchanged).
KNOWN_NORMALISED = {
    "nikon-ai-nikkor-180mm-f-2.8-ed-us-4338001-ex2-2": {
        "id": "nikon-ai-nikkor-180mm-f-2.8-ed",
        "factor": 1.8,
        "evidence": ("US 4,338,001 (Nippon Kogaku, S. Matsui) tabulates Example 2 at f = 100; the Optical Bench "
                     "(photonstophotos.net) and LensVisualizer both identify it as the AI Nikkor 180mm f/2.8 ED "
                     "(5 elements in 5 groups, as the product) and scale it to 180 mm"),
    },
}

NUMBER = r"(\d+(?:\.\d+)?)"


def _range(a, b, scale=1.0):
    lo = scale * float(a)
    hi = scale * float(b) if b else lo
    return (min(lo, hi), max(lo, hi))


def _f_number_in(text):
    m = re.search(r"(?:^|-|mm)[ft]-?" + NUMBER + r"(?:-" + NUMBER + r")?(?=[a-z]*(?:-|$))", text)
    if not m:
        return None
    first = float(m.group(1))
    if m.group(2) and float(m.group(2)) > first:
        return (first, float(m.group(2)))
    return (first, first)


def parse_name(lens_id):
    """(focal range, f-number range) an id states, each (lo, hi) or None; as LensName.cpp."""
    rules = [(r"(?:^|[^\d.])" + NUMBER + r"(?:-" + NUMBER + r")?-?mm", 1.0, True),
             (r"(?:^|[^\d.])" + NUMBER + r"(?:-" + NUMBER + r")?-f-?\d", 1.0, True),
             (r"(?:^|[^\d.])" + NUMBER + r"cm", 10.0, False),
             (r"-xf" + NUMBER, 1.0, False)]
    focal, end = None, None
    # The first two rules are tried together in LensName.cpp: "mm" first, then a number before "-f".
    for rx, scale, has_range in rules:
        m = re.search(rx, lens_id)
        if m:
            focal = _range(m.group(1), m.group(2) if has_range else None, scale)
            end = m.end(2) if has_range and m.group(2) else m.end(1)
            break
    if focal is None:
        m = re.search(r"-" + NUMBER + r"-(\d+)(?:-(\d+))?(?=[a-z]?(?:-|$))", lens_id)
        if m and float(m.group(1)) <= 32.0:
            return _range(m.group(2), m.group(3)), _range(m.group(1), None)
    fno = _f_number_in(lens_id[end:]) if end is not None else None
    if fno is None:
        fno = _f_number_in(lens_id)
    if fno is None:
        m = re.search(r"-(\d+\.\d+)-\d+(?:\.\d+)?mm", lens_id)
        if m:
            fno = _range(m.group(1), None)
    return focal, fno


def mismatch(entry):
    """What the id promises that the prescription does not have, or None."""
    focal, fno = parse_name(entry["id"])
    problems = []
    focals = entry.get("zoom_focal_lengths_mm") or [entry["focal_length_mm"]]
    if focal:
        lo, hi = focal
        for f in focals:
            if not (lo * (1 - FOCAL_TOLERANCE) <= f <= hi * (1 + FOCAL_TOLERANCE)):
                problems.append(f"focal length {f:g} mm where the name says {lo:g}" + (f"-{hi:g}" if hi > lo else "") + " mm")
                break
    if fno:
        lo, hi = fno
        n = entry["f_number"]
        if not (lo / F_NUMBER_FACTOR <= n <= hi * F_NUMBER_FACTOR):
            problems.append(f"f/{n:g} where the name says f/{lo:g}" + (f"-{hi:g}" if hi > lo else ""))
    return "; ".join(problems) or None


def slug(text):
    s = re.sub(r"[^a-z0-9.]+", "-", text.lower()).strip("-.")
    return re.sub(r"-+", "-", s)


def _scale_rows(text, factor):
    """The lens text with every length (radius, thickness, semi-aperture, gaps, focal length) scaled."""
    out, in_rows = [], False
    def num(tok):
        try:
            return f"{float(tok) * factor:.6f}".rstrip("0").rstrip(".")
        except ValueError:
            return tok
    for line in text.splitlines():
        body, _, comment = line.partition("#")
        tokens = body.split()
        if not in_rows and tokens and tokens[0] == "surfaces":
            in_rows = True
        elif not in_rows and tokens and tokens[0] == "focal_length_mm":
            line = f"focal_length_mm {num(tokens[1])}"
        elif not in_rows and tokens and tokens[0] == "gap":
            line = "gap " + tokens[1] + " " + " ".join(f"{t.split('=')[0]}={num(t.split('=')[1])}" for t in tokens[2:])
        elif in_rows and len(tokens) >= 4:
            radius = tokens[0] if tokens[0] in ("stop", "inf") else num(tokens[0])
            thickness = num(tokens[1]) if tokens[1] != "auto" and re.fullmatch(r"[-\d.eE+]+", tokens[1]) else tokens[1]
            line = (f"   {radius:<13} {thickness:<11} {tokens[2]:<17} {num(tokens[3]):<11}" +
                    (" " + " ".join(tokens[4:]) if len(tokens) > 4 else "") + (f" #{comment}" if comment else ""))
        out.append(line.rstrip())
    return "\n".join(out) + "\n"


def _retitle(text, name, note):
    """The lens text with its display name replaced and `note` added to the header comment."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("name "):
            lines[i] = f"name            {name}"
    first_setting = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    lines[0] = f"# {name}"
    lines[first_setting:first_setting] = [f"# {n}" for n in note]
    return "\n".join(lines) + "\n"


def apply(folder):
    index_path = os.path.join(folder, "index.json")
    with open(index_path, encoding="utf-8") as f:
        index = json.load(f)
    changed = []
    for entry in index["lenses"]:
        problem = mismatch(entry)
        if not problem:
            continue
        old_id, old_path = entry["id"], os.path.join(folder, entry["file"])
        with open(old_path, encoding="utf-8") as f:
            text = f.read()
        listed_as = f"{entry['maker']} {entry['model']}".strip() if entry["model"] else None
        known = KNOWN_NORMALISED.get(old_id)
        if known:
            factor = known["factor"]
            new_id = known["id"]
            name = entry["name"]
            text = _scale_rows(text, factor)
            text = re.sub(r"^(source .*)$", lambda m: m.group(1) + f"; scaled by {factor:g} to f = "
                          f"{entry['focal_length_mm'] * factor:g} mm", text, count=1, flags=re.M)
            note = [f"Scaled by {factor:g} (every radius, thickness and clear radius): the source tabulates the example "
                    f"normalised to f = {entry['focal_length_mm']:g} mm; {known['evidence']}. The Back focus and "
                    "Check lines above are at the source's scale.",
                    f"Renamed from {old_id} (scripts/library_names.py)."]
            entry["focal_length_mm"] = round(entry["focal_length_mm"] * factor, 3)
            entry["tags"] = sorted(set(entry["tags"]) | {"scaled-from-normalised-example"})
        else:
            zoom_range = entry.get("zoom_range_mm") or entry.get("focal_range_mm")
            focal = (f"{zoom_range[0]:g}-{zoom_range[1]:g}mm" if zoom_range and entry["kind"] == "zoom"
                     else f"{entry['focal_length_mm']:g}mm")
            example = f"Example {entry['example']}" if entry["example"] else "example"
            new_id = slug(f"{entry['maker']} {focal} f{entry['f_number']:g} {entry['patent'].replace(',', '')} "
                          f"ex{entry['example']}")
            name = (f"{entry['maker']} {focal} F{entry['f_number']:g} ({entry['patent']} {example}"
                    + (f"; listed by its source as the {listed_as}" if listed_as else "") + ")")
            note = [f"Renamed from {old_id} (scripts/library_names.py): {problem}.",
                    "The table is the patent's; it is named for what it is, not for the product the source listed."]
            entry["model"] = ""
            entry["tags"] = sorted(set(entry["tags"]) | {"renamed-patent-example"})
        text = _retitle(text, name, note)
        new_file = os.path.join(os.path.dirname(entry["file"]), new_id + ".lens")
        with open(os.path.join(folder, new_file), "w", encoding="utf-8") as f:
            f.write(text)
        if os.path.join(folder, new_file) != old_path:
            os.remove(old_path)
        entry.update({"id": new_id, "file": new_file, "name": name})
        entry["renamed_from"] = sorted(set(entry.get("renamed_from", [])) | {old_id})
        changed.append((old_id, new_id, problem, "scaled" if known else "renamed"))
    ids = [e["id"] for e in index["lenses"]]
    dupes = {i for i in ids if ids.count(i) > 1}
    if dupes:
        raise SystemExit(f"renaming made ids repeat: {sorted(dupes)}")
    index["lenses"].sort(key=lambda e: (e["maker"].lower(), e["focal_length_mm"], e["id"]))
    with open(index_path, "w", encoding="utf-8") as f:
        json.dump(index, f, indent=1, ensure_ascii=False)
        f.write("\n")
    return changed


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    for old, new, problem, how in apply(sys.argv[1]):
        print(f"{how:8} {old} -> {new}  ({problem})")


if __name__ == "__main__":
    main()
