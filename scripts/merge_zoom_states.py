#!/usr/bin/env python3
"""Gives library zooms that hold one state their other zoom states (docs/lens-library.md, "Zooms").

The collection gives one zoom state of each zoom (its first). LensVisualizer transcribes many of the
same patent tables with every zoom state: the states' focal lengths, the variable gaps at infinity
focus and, for a variable-aperture zoom, the f-number of each state. For every library file tagged
`zoom-first-position-only` whose radii match such a table (the rule of the import script's
match_zoom: the same radii row by row, one of the table's states' gaps equal to the file's: usually
the first, sometimes another), this
writes the states as zoom positions (matched row by row, or, where the file's stop row sits in
another air space than the table's stop or the file ends with a plate, a filter or cover glass, that
the table folds into its back focus, air space by air space: _space_gaps) (`zoom`, `gap` lines; `f_number` per position for a
variable-aperture zoom, the file's own f-number kept at the first) and keeps the result only if
`flare lens check` passes at every position: the paraxial EFL within 1 % of the state's published
focal length, the stop opening to the state's f-number, the axial ray fan at it passing.

The iris. The file's stop row gives one semi-aperture (the collection's, for its first state). A
zoom's iris opens as it zooms: a constant-aperture zoom keeps its f-number only because its stop
opens wider towards tele, and a variable-aperture zoom's later f-numbers are what its iris gives
there. Where the file's stop does not open to a state's stated f-number, the merge gives the stop
row a semi-aperture per position (an `aperture iris ...` line, docs/lens-format.md): the file's at
every state where it opens far enough, elsewhere the radius that opens to the stated f-number
exactly (paraxially the f-number goes as 1/radius: r = r_file * F_file / F_stated, rounded up to
0.1 um). Neither source prints the stop's diameter per state (the patents print F-numbers); the
stated F-number is the datum, the radius follows from it. The checks are then run again unchanged:
the stop check now confirms the arithmetic, and the ray fan whether the wider beam passes every
other clear aperture (the collection's diameters, mostly estimates). A table
with more than MAX_STATES states is not a patent's list of states (LensVisualizer samples some zoom
cams finely) and is not used. Failures are listed in set-aside.json as `zoom-merge-*` (the file
ships as its one state). Only the patents' numbers are taken from LensVisualizer (no licence
stated there). Idempotent.

The tables LensVisualizer transcribed after the snapshot in LENSVISUALIZER.git are read from
lenses/zoom-tables/ (the patents' numbers only, each naming the file and commit it was read at;
import_lens_library.lensvisualizer_texts). Where the collection's clear radii would cross at a gap's
narrowest state they are cut there by the importer's rule (narrowest_cut); STATES leaves out a
table's states outside the range a lens is named for.

Usage:  /usr/bin/python3 scripts/merge_zoom_states.py lenses/library LENSVISUALIZER.git build/src/flare [--skip ID ...]
(scripts/import_lens_library.py runs it when given --lensvisualizer.) --skip leaves a library file
as it is (one being reworked by hand).
"""

import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import import_lens_library as imp  # noqa: E402  (the LensVisualizer reader and the check runner)

MAX_STATES = 6
# Two transcriptions of one patent table print its gaps to 0.01 mm (or finer): a gap of the file and
# the table's at the same state differ by at most that.
GAP_TOLERANCE_MM = 0.0101
# LensCheck.h's kFNumberRounding: a stop within this of the stated f-number passes the stop check.
F_NUMBER_ROUNDING = 0.05


def _rows(text):
    """The surface rows of a .lens file as token lists, with their line indices."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.split("#")[0].split() == ["surfaces"])
    rows = []
    for i in range(start + 1, len(lines)):
        tokens = lines[i].split("#")[0].split()
        if tokens:
            rows.append((i, tokens))
    return lines, rows


def _same_radii(a, b):
    """The radii of a library file and of a table, both rounded to 0.01 mm, are the same: the file
    prints six significant figures of the collection's radius, so a value on a rounding boundary
    can round to the neighbouring hundredth (-181.2948 is -181.295 in the file, -181.3 rounded),
    and from 10 000 mm on six figures are coarser than the hundredth: there the two may differ by
    half the sixth figure's unit as well (the patent's 26667.449 is 26667.4 in the file); a plane is
    0 in the file and may be a huge radius in the table."""
    def plane(r):
        return 0.0 if abs(r) > 1e6 else r

    def tolerance(x, y):
        big = max(abs(x), abs(y))
        return 0.0101 + (0.5 * 10.0 ** (math.floor(math.log10(big)) - 5) if big >= 1e4 else 0.0)
    return len(a) == len(b) and all(abs(plane(x) - plane(y)) <= tolerance(plane(x), plane(y)) for x, y in zip(a, b))


# A cemented resin layer (the thin aspheric layer of a hybrid element) is at most this thick; some
# transcriptions (LensVisualizer) leave it out, folding it into the glass it sits on.
MAX_LAYER_MM = 0.02


def _layers(rows):
    """The rows that are the back of a thin cemented layer: the same radius as the row before, which
    is glass at most MAX_LAYER_MM thick."""
    out = set()
    for i in range(1, len(rows)):
        prev, cur = rows[i - 1][1], rows[i][1]
        if "stop" in (prev[0], cur[0]) or "inf" in (prev[0], cur[0]) or prev[2] == "air":
            continue
        try:
            thick = float(prev[1])
        except ValueError:
            continue
        if thick <= MAX_LAYER_MM and abs(float(prev[0]) - float(cur[0])) <= 0.0101:
            out.add(i)
    return out


def _radii(rows, drop_layers=False):
    """The radii of the surface rows (stop excluded; a plane is 0), to 0.01 mm; without the backs of
    thin cemented layers when asked."""
    skip = _layers(rows) if drop_layers else set()
    return tuple(round(0.0 if t[0] == "inf" else float(t[0]), 2)
                 for i, (_, t) in enumerate(rows) if t[0] != "stop" and i not in skip)


def _matches(rows, key):
    """Whether a file's rows match a table's radii: as they are, with a plate more at the end, or
    without the backs of thin cemented layers the table leaves out (and maybe a plate more)."""
    for drop in (False, True):
        radii = _radii(rows, drop)
        if _same_radii(radii, key) or _same_radii_but_plate(radii, key):
            return True
    return False


def _same_radii_but_plate(a, b):
    """The file's radii are the table's and two plane surfaces more at the end: a plane-parallel plate
    (a filter or the sensor's cover glass) the table leaves out."""
    return len(a) == len(b) + 2 and a[-2:] == (0.0, 0.0) and _same_radii(a[:-2], b)


def _f_numbers(text, count):
    """LensVisualizer's nominalFno: a list per state (variable aperture) or None (constant)."""
    m = re.search(r"nominalFno:\s*\[([^\]]*)\]", text)
    if not m:
        return None
    values = [float(x) for x in re.findall(r"\d+(?:\.\d+)?", m.group(1))]
    return values if len(values) == count else None


def _row_gaps(rows, table):
    """The variable gaps matched row by row (the file and the table list the stop at the same row):
    ({row: [gap per state]}, the state the file holds), or None."""
    if len(table["labels"]) != len(rows):
        return None
    n = len(table["focal_lengths"])
    gaps = {}
    for label, values in table["gaps"].items():
        if label not in table["labels"]:
            return None
        row = table["labels"].index(label)
        if row + 1 == len(rows):
            continue  # the back focus: the sensor is placed by the focus solve
        if max(values) - min(values) > 1e-9:
            gaps[row] = values
    if not gaps:
        return None
    # The state the file holds: the first whose every variable gap is the file's, to the rounding of
    # two transcriptions that print gaps to 0.01 mm (the collection's is usually the first state;
    # some files hold another, e.g. the tele end).
    held = [k for k in range(n)
            if all(abs(values[k] - float(rows[row][1][1])) <= GAP_TOLERANCE_MM for row, values in gaps.items())]
    return (gaps, held[0]) if held else None


# The least gap left between the stop and a vertex when the stop's air space is re-split (the
# importer's rule for a stop on a vertex, docs/lens-library.md "Conversion").
MIN_STOP_GAP_MM = 0.01


def _space_gaps(rows, table):
    """The variable gaps matched air space by air space, for a file whose stop row splits an air
    space differently from the table (the Optical Bench and LensVisualizer place a stop the patent
    omits or puts on a vertex in different spaces, or split one space differently). An air space is
    everything between two refracting surfaces: the same in both transcriptions, since the radii
    match. Where the file's stop sits in a variable space, its distance to one neighbour is kept: to
    the surface behind it (the stop travels with the group behind it), unless the table puts its
    stop in the same space and varies the gap behind the stop instead (and the file's stop, kept at
    its distance to the surface in front, stays clear of the surface behind at every state).
    A file may end with a plane-parallel plate (a filter or the sensor's cover glass) that the
    table leaves out, folding it into its back focus as an equivalent air gap: then the gap before
    the plate changes from state to state as the table's back focus does (the plate stays with the
    sensor; the sensor itself is placed by the focus solve).
    Returns ({row: [gap per state]}, held state, [surface numbers whose space holds a re-split
    stop], whether the back focus moved the gap before a plate) or None."""
    if table.get("thicknesses") is None:
        return None
    n = len(table["focal_lengths"])

    def spaces(kinds):
        """[[rows from a surface to the next]] from row kinds ("surface", "stop", or "layer": the
        back of a thin cemented layer the table leaves out, part of the glass before it)."""
        out = []
        for i, kind in enumerate(kinds):
            if kind != "surface":
                continue
            space = [i]
            while space[-1] + 1 < len(kinds) and kinds[space[-1] + 1] != "surface":
                space.append(space[-1] + 1)
            out.append(space)
        return out

    layers = _layers(rows) if not _same_radii(_radii(rows), table["key"]) and \
        not _same_radii_but_plate(_radii(rows), table["key"]) else set()
    file_spaces = spaces(["stop" if t[0] == "stop" else "layer" if i in layers else "surface"
                          for i, (_, t) in enumerate(rows)])
    labels = table["labels"]
    table_spaces = spaces(["stop" if lb.upper() in ("STO", "STOP") else "surface" for lb in labels])
    m = len(table_spaces)
    plate = len(file_spaces) == m + 2
    if len(file_spaces) != m and not plate:
        return None

    def table_value(row, k):
        values = table["gaps"].get(labels[row])
        return values[k] if values else table["thicknesses"][row]

    gaps, totals, resplit = {}, {}, []
    for j, (fs, ts) in enumerate(zip(file_spaces[:m - 1], table_spaces[:-1])):  # the last: the back focus
        total = [sum(table_value(r, k) for r in ts) for k in range(n)]
        if max(total) - min(total) > 1e-9:
            totals[j] = total
    if not totals:
        return None
    # Two gaps summed in either transcription: up to two roundings of 0.01 mm.
    held = [k for k in range(n)
            if all(abs(sum(float(rows[r][1][1]) for r in file_spaces[j]) - total[k]) <=
                   GAP_TOLERANCE_MM * (len(file_spaces[j]) + len(table_spaces[j]) - 1) for j, total in totals.items())]
    if not held:
        return None
    for j, total in totals.items():
        fs, ts = file_spaces[j], table_spaces[j]
        if len(fs) == 1:
            gaps[fs[0]] = [round(t, 6) for t in total]
            continue
        if len(fs) != 2:
            return None
        before, behind = (float(rows[r][1][1]) for r in fs)
        if len(ts) != 2 or abs(table_value(ts[0], held[0]) - before) > GAP_TOLERANCE_MM:
            resplit.append(j + 1)
        table_varies = [max(table_value(r, k) for k in range(n)) - min(table_value(r, k) for k in range(n)) > 1e-9
                        for r in ts]
        # The table's stop travelling with the group in front, unless the file's stop sits so far back
        # in the space that it would then pass the vertex behind it (its place is the collection's,
        # not the table's: the stop then travels with the group behind it).
        if len(ts) == 2 and table_varies == [False, True] and min(total) - before >= MIN_STOP_GAP_MM:
            row, values = fs[1], [round(t - before, 6) for t in total]
        else:
            row, values = fs[0], [round(t - behind, 6) for t in total]
        if min(values) < MIN_STOP_GAP_MM:
            return None
        gaps[row] = values
    moved_plate = False
    if plate:
        back = [sum(table_value(r, k) for r in table_spaces[m - 1]) for k in range(n)]
        fs = file_spaces[m - 1]
        if max(back) - min(back) > 1e-9:
            if len(fs) != 1:
                return None
            base = float(rows[fs[0]][1][1])
            values = [round(base + b - back[held[0]], 6) for b in back]
            if min(values) < MIN_STOP_GAP_MM:
                return None
            gaps[fs[0]] = values
            moved_plate = True
    return gaps, held[0], resplit, moved_plate


# Where LensVisualizer's nominalFno is its own fixed-stop model's f-number, not the patent's, the
# patent's f-numbers per state (with why). A constant-aperture design keeps its one f-number at every
# state: its iris opens towards tele (opened_text).
F_NUMBER_OVERRIDES = {
    "pentax-smc-pentax-a-35-70mm-f4": (
        [4.1, 4.1],
        "US 4,812,022 Example 3 prints one F-number, 4.1, for the design (a constant-aperture zoom, sold as f/4); "
        "LensVisualizer's nominalFno [4.1, 5.394215] is its model's fixed stop at tele, as its header says, and is "
        "not used"),
    "samyang-af-35-150mm-f2-2.8-l": (
        [2.07, 2.63, 2.90],
        "the patent's F-numbers 2.07 / 2.63 / 2.90 (as LensVisualizer's header quotes them; its nominalFno "
        "[2, 2.5, 2.8] is the marketed f/2-2.8 and is not used)"),
    "canon-ef28-135mm-f3.5-5.6-is-usm": (
        [3.6, 4.36, 5.6],
        "the file's f/3.6 at wide; the patent's f/4.36 at mid (as LensVisualizer's file quotes it; its nominalFno "
        "4.24 there is that value scaled by a design-to-market ratio and is not used); at tele the marketed f/5.6 "
        "(nominalFno; the patent's tele F-number is quoted in neither source)"),
    "nikon-af-zoom-nikkor-28-85mm-f3.5-4.5": (
        [3.5, 4.0],
        "the patent's f/3.5-4.0 (US 4,806,000 Example 1, as LensVisualizer's file quotes it; its nominalFno 4.5 at "
        "tele is the marketed value and is not used)"),
    "konica-minolta-28-85mm-f3.5-4.5-md-zoom": (
        [3.6, 4.0, 4.63],
        "the patent's printed F-numbers 3.6 / 4.0 / 4.63 (JP H01-193709 Example 1, as LensVisualizer's file quotes "
        "them; its nominalFno 3.637 / 3.967 / 4.63 is its fixed-stop model's)"),
    "konica-minolta-35-135mm-f3.5-4.5-md-zoom": (
        [3.608, 4.56],
        "the patent's F-numbers 3.608 / 4.56 (US 5,249,079 Table 4, as LensVisualizer's file quotes them; its "
        "nominalFno 3.611 / 4.557 is its fixed-stop model's), the file keeping its f/3.6 at wide"),
    # The patents' F-numbers that LensVisualizer's analysis files quote (src/lens-data/<maker>/*.analysis.md),
    # beside the fixed-stop model's nominalFno of the data file.
    "tamron-14-150mm-f3.5-5.8-di-iii": (
        [3.6708, 5.4085, 5.9148],
        "the patent's F-numbers 3.6708 / 5.4085 / 5.9148 at 14.43 / 57.85 / 145.40 mm (US 2014/0347522 Example 3, "
        "Tables 9-12, as LensVisualizer's analysis of the example quotes them; its nominalFno 3.691 / 5.388 / 5.905 "
        "is its single fixed-stop fit to them and is not used)"),
    "nikon-nikkor-z-dx-50-250mm-f4.5-6.3-vr": (
        [4.63, 6.34],
        "the patent's FNO 4.63-6.34 at 51.50 / 242.80 mm (WO 2020/105107 Example 1, as LensVisualizer's analysis of "
        "the example quotes it; its nominalFno 4.5 / 5.1 / 6.3 is the product's f/4.5-6.3 and is not used)"),
    "tamron-sp-150-600mm-f5-6.3-di-vc-usd": (
        [4.99224, 5.87742, 6.53711],
        "the patent's F-numbers 4.99224 / 5.87742 / 6.53711 at 152.16 / 297.49 / 582.52 mm (US 10,545,321 B2 "
        "Example 4, Table 11, as LensVisualizer's analysis of the example quotes them; its nominalFno 4.994 / "
        "5.872 / 6.541 is its normalised fixed-stop model's and is not used)"),
}


# Variable-aperture zooms whose table's later f-numbers are LensVisualizer's fixed-stop model, with
# the patent's own F-numbers in neither source: not merged (their f-number per position would not be
# the patent's).
MODELLED_F_NUMBERS = {
    "fujifilm-fujinon-7.1-28.4mm-f2.0-2.8-super-ebc-x10": "JP patent Table 3's rounded f-numbers are replaced by "
                                                          "LensVisualizer's model (nominalFno 2.064 / 2.357 / 2.875)",
    "canon-ef-s55-250mm-f4-5.6-is": "US 7,471,462 Example 2: LensVisualizer's nominalFno at mid (5.1291...) is its "
                                    "model's, and the patent's F-number there is quoted in neither source",
}


# Zooms whose patent table has a state outside the range the lens is named for (the name check,
# docs/lens-library.md "Names", allows 5 %), or a state whose F-number neither source gives: the
# table's states kept (0-based), with why. The kept states are the patent's, unchanged.
STATES = {
    "nikon-nikkor-z-dx-50-250mm-f4.5-6.3-vr": (
        [0, 2],
        "WO 2020/105107 Example 1's F-numbers are quoted at its two ends only (FNO 4.63-6.34, in "
        "LensVisualizer's analysis of the example; its nominalFno 4.5 / 5.1 / 6.3 is the product's and a value "
        "for its display), so the positions are the 51.50 and 242.80 mm states"),
    "canon-ef100-300mm-f5.6": (
        [1, 2, 3],
        "JP S61-77818 Example 1 tabulates 69 / 100 / 198 / 290 mm; the 69 mm state lies outside the 100-300 mm the "
        "lens is named for (and the file holds the 100 mm state), so the positions are the 100, 198 and 290 mm "
        "states"),
}


def _kept_states(table, f_numbers, lens_id):
    """The table (and its f-numbers) with only the states STATES keeps for the lens; the note why."""
    if lens_id not in STATES:
        return table, f_numbers, None
    keep, why = STATES[lens_id]
    table = dict(table, focal_lengths=[table["focal_lengths"][k] for k in keep],
                 gaps={label: [values[k] for k in keep] for label, values in table["gaps"].items()})
    return table, [f_numbers[k] for k in keep] if f_numbers else f_numbers, why


def merged_text(text, table, f_numbers, commit, patent=None, f_number_note=None, state_note=None):
    """The file with the table's states as zoom positions, or None when the table does not match."""
    lines, rows = _rows(text)
    if not _matches(rows, table["key"]):
        return None
    n = len(table["focal_lengths"])
    names = ["wide", "tele"] if n == 2 else ["wide"] + (["mid"] if n == 3 else [f"mid{i}" for i in range(1, n - 1)]) + ["tele"]
    matched = _row_gaps(rows, table)
    resplit, moved_plate = [], False
    if matched is None:
        matched = _space_gaps(rows, table)
        if matched is None:
            return None
        gaps, held, resplit, moved_plate = matched
    else:
        gaps, held = matched
    stated_f = None
    for line in lines:
        tokens = line.split("#")[0].split()
        if tokens and tokens[0] == "f_number":
            stated_f = float(tokens[1])
    source = (f"the variable gaps at {n} zoom states (infinity focus) and the states' focal lengths are the patent "
              f"table's{' (' + patent + ')' if patent else ''}, {imp.table_citation(table, commit, 'this file')}, "
              f"merged by scripts/merge_zoom_states.py")
    if state_note:
        source += f"; the zoom positions are the table's states kept (STATES): {state_note}"
    if held:
        source += f"; this file held the table's state {held + 1} ({names[held]}, its focal length {table['focal_lengths'][held]:g} mm)"
    if resplit:
        source += (f"; the stop row sits in the air space behind surface {', '.join(map(str, resplit))}, which the table "
                   f"splits at another place or not at all: the whole space is the table's at every state, and the stop "
                   f"keeps the file's distance to the surface behind it (it travels with the group behind it; the "
                   f"patents print no stop position there), or to the one before it where the table varies the gap "
                   f"behind its stop")
    if moved_plate:
        source += ("; the file ends with a plane-parallel plate (a filter or the sensor's cover glass) that the table "
                   "folds into its back focus: the gap before the plate changes as the table's back focus does")
    if f_numbers and f_number_note:
        source += f"; the f-numbers: {f_number_note}"
    elif f_numbers:
        source += (f"; the f-numbers of the other states are LensVisualizer's nominalFno (the patent's, or the marketed "
                   f"value where it rounds), the one this file held keeps its f/{stated_f:g}; the check below confirms "
                   f"the stop opens to each")
    out = []
    for i, line in enumerate(lines):
        tokens = line.split("#")[0].split()
        if tokens and tokens[0] == "name":
            out.append(f"# Zoom: {source}.")
            out.append(line)
        elif tokens and tokens[0] == "focal_length_mm":
            out.append("zoom            " + " ".join(f"{nm}={f:.2f}" for nm, f in zip(names, table["focal_lengths"])))
        elif tokens and tokens[0] == "f_number" and f_numbers:
            values = f_numbers[:held] + [stated_f] + f_numbers[held + 1:]
            out.append("f_number        " + " ".join(f"{nm}={v:g}" for nm, v in zip(names, values)))
        elif tokens and tokens[0] == "default_coating":
            out.append(line)
            for row, values in sorted(gaps.items()):
                out.append(f"gap d{row + 1:<4d}" + " ".join(f"{nm}={v:g}" for nm, v in zip(names, values)))
        else:
            out.append(line)
    # The rows whose thickness varies name their gap.
    lines2, rows2 = _rows("\n".join(out) + "\n")
    for r, (line_index, tokens) in enumerate(rows2):
        if r in gaps:
            old = lines2[line_index]
            body, hash_, comment = old.partition("#")
            parts = body.split()
            parts[1] = f"d{r + 1}"
            lines2[line_index] = (f"   {parts[0]:<13s} {parts[1]:<11s} {parts[2]:<17s} {parts[3]:<10s}" +
                                  (" " + " ".join(parts[4:]) if len(parts) > 4 else "") +
                                  (f"  #{comment}" if hash_ else "")).rstrip()
    stated = f_numbers[:held] + [stated_f] + f_numbers[held + 1:] if f_numbers else [stated_f] * n
    return "\n".join(lines2) + "\n", names, stated


def _cross(table, semi):
    """Whether two neighbouring surfaces cross inside their clear radii (the load check's fault)."""
    for a, b, ra, rb in zip(table, table[1:], semi, semi[1:]):
        reach = max(ra, rb)
        if any(a["thickness"] + imp.sag(b["radius"], min(reach * k / 64.0, rb)) -
               imp.sag(a["radius"], min(reach * k / 64.0, ra)) < 0.0 for k in range(65)):
            return True
    return False


def narrowest_cut(text):
    """For a merged file whose surfaces would cross at the narrowest state of a variable gap (the
    collection's clear radii, mostly estimates, sized for the state it held): the file with its clear
    radii cut where two surfaces come closer than the importer's minimum edge (0.3 mm of glass, 0.1 mm
    of air, or half the gap) at that state, the rule the import applied to the state the file held
    (import_lens_library.cut_pass). None when nothing crosses (a merge that loads keeps its radii).
    The checks then say whether the axial beam still passes (the ray fan)."""
    lines, rows = _rows(text)
    narrowest = {}
    for line in lines:
        tokens = line.split("#")[0].split()
        if tokens and tokens[0] == "gap":
            narrowest[tokens[1]] = min(float(t.split("=")[1]) for t in tokens[2:])
    table, semi = [], []
    for _, tokens in rows:
        radius, thickness, material, aperture = tokens[:4]
        table.append({"radius": 0.0 if radius in ("inf", "stop") else float(radius),
                      "thickness": narrowest[thickness] if thickness in narrowest else
                      (0.0 if thickness == "auto" else float(thickness)),
                      "nd": 1.0 if material == "air" else float(material.split("/")[0]) if "/" in material else 1.5,
                      "stop": radius == "stop"})
        semi.append(float(aperture) if aperture != IRIS else 0.0)
    if not _cross(table, semi):
        return None
    before = list(semi)
    for _ in range(len(rows)):
        if not imp.cut_pass(table, semi):
            break
    # A cut below 1 um is the bisection's and the file's rounding (the import cut there already).
    cut = [i for i in range(len(rows)) if semi[i] < before[i] - 1e-3]
    if not cut:
        return None
    note = ("# Clear radii cut back for the narrowest state of each variable gap, where surfaces would cross there "
            "(the importer's rule, which it applied to the state the file held): " +
            ", ".join(f"row {i + 1}: {before[i]:g} -> {math.floor(semi[i] * 1e4) / 1e4:g} mm" for i in cut) +
            ". Merged by scripts/merge_zoom_states.py.")
    out = list(lines)
    for i in cut:
        line_index, tokens = rows[i]
        body, hash_, comment = out[line_index].partition("#")
        parts = body.split()
        parts[3] = f"{math.floor(semi[i] * 1e4) / 1e4:g}"
        out[line_index] = (f"   {parts[0]:<13s} {parts[1]:<11s} {parts[2]:<17s} {parts[3]:<10s}" +
                           (" " + " ".join(parts[4:]) if len(parts) > 4 else "") +
                           (f"  #{comment}" if hash_ else "")).rstrip()
    at = next(i for i, line in enumerate(out) if line.startswith("name "))
    out.insert(at, note)
    return "\n".join(out) + "\n"


IRIS = "iris"


def opened_text(text, names, stated, positions):
    """The merged file with the stop row's semi-aperture given per position (an `aperture` line):
    where the file's stop opens to the position's stated f-number (within the check's rounding) it
    is kept, elsewhere it is opened to give that f-number exactly. `positions`: `flare lens check`'s
    per-position report of the merged file (its wide-open f-number with the fixed stop). None when
    the fixed stop opens far enough everywhere (nothing to open)."""
    lines, rows = _rows(text)
    stop = [(i, t) for i, t in rows if t[0] == "stop"]
    if len(stop) != 1 or len(positions) != len(names):
        return None
    line_index, tokens = stop[0]
    radius = float(tokens[3])
    radii, opened = [], False
    for name, f_stated, position in zip(names, stated, positions):
        assert position["zoom"] == name
        f_file = position["wide_open_f_number"]
        if f_file <= f_stated + F_NUMBER_ROUNDING:
            radii.append(radius)
        else:
            radii.append(math.ceil(radius * f_file / f_stated * 1e4) / 1e4)
            opened = True
    if not opened:
        return None
    widened = [f"{nm}" for nm, r in zip(names, radii) if r != radius]
    note = (f"# Iris: the stop's semi-aperture per zoom position (aperture {IRIS}): {radius:g} mm as the file gives it "
            f"where it opens to the stated f-number, opened at {', '.join(widened)} to give the stated f-number there "
            f"(radius x wide-open f-number with the file's stop / stated f-number; neither source prints the stop "
            f"diameter per state). Merged by scripts/merge_zoom_states.py.")
    out = []
    for i, line in enumerate(lines):
        toks = line.split("#")[0].split()
        if i == line_index:
            body, hash_, comment = line.partition("#")
            parts = body.split()
            parts[3] = IRIS
            out.append((f"   {parts[0]:<13s} {parts[1]:<11s} {parts[2]:<17s} {parts[3]:<10s}" +
                        (" " + " ".join(parts[4:]) if len(parts) > 4 else "") +
                        (f"  #{comment}" if hash_ else "")).rstrip())
            continue
        if toks and toks[0] == "name":
            out.append(note)
        out.append(line)
        if toks and toks[0] == "default_coating":
            out.append(f"aperture {IRIS:<5s}" + " ".join(f"{nm}={r:g}" for nm, r in zip(names, radii)))
    return "\n".join(out) + "\n"


def _check_staged(flare, staging, items):
    """Writes each (key, text) into `staging` and checks them: {key: (staged path, result)}."""
    paths = {}
    for key, text in items:
        staged = os.path.join(staging, key)
        with open(staged, "w", encoding="utf-8") as f:
            f.write(text)
        paths[key] = staged
    results = imp.check_files(flare, list(paths.values())) if paths else {}
    return {key: (path, results[path]) for key, path in paths.items()}


def apply(folder, git_dir, flare, skip=()):
    tables = imp.lensvisualizer_zooms(git_dir)
    for key, table in tables.items():
        table["key"] = key
    commit = subprocess.run(["git", "--git-dir", git_dir, "rev-parse", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    index_path = os.path.join(folder, "index.json")
    aside_path = os.path.join(folder, "set-aside.json")
    with open(index_path, encoding="utf-8") as f:
        index = json.load(f)
    with open(aside_path, encoding="utf-8") as f:
        aside = json.load(f)
    merged, failed = [], []
    staging = tempfile.mkdtemp(prefix="flare-zoom-merge-")
    candidates = []
    # A zoom whose table's f-numbers are a model's is not merged (docs/lens-library.md): an earlier
    # run's merge failure of it no longer stands.
    aside["set_aside"] = [e for e in aside["set_aside"]
                          if not (e.get("id") in MODELLED_F_NUMBERS and e["cause"].startswith("zoom-merge"))]
    for entry in index["lenses"]:
        if "zoom-first-position-only" not in entry["tags"] or entry["id"] in skip or entry["id"] in MODELLED_F_NUMBERS:
            continue
        path = os.path.join(folder, entry["file"])
        with open(path, encoding="utf-8") as f:
            text = f.read()
        _, rows = _rows(text)
        radii = _radii(rows)
        table = (tables.get(radii) or next((t for k, t in tables.items() if _same_radii(radii, k)), None) or
                 next((t for k, t in tables.items() if _matches(rows, k)), None))
        if not table or len(table["focal_lengths"]) > MAX_STATES:
            continue
        f_numbers = _f_numbers(table["text"], len(table["focal_lengths"]))
        table, f_numbers, state_note = _kept_states(table, f_numbers, entry["id"])
        patent = f"{entry['patent']} Example {entry['example']}" if entry.get("patent") and entry.get("example") else None
        f_number_note = None
        if entry["id"] in F_NUMBER_OVERRIDES:
            f_numbers, f_number_note = F_NUMBER_OVERRIDES[entry["id"]]
        result = merged_text(text, table, f_numbers, table.get("commit") or commit, patent, f_number_note,
                             state_note)
        if not result:
            continue
        new_text, names, stated = result
        new_text = narrowest_cut(new_text) or new_text
        candidates.append([entry, path, new_text, names, table, stated])
    try:
        # First with the file's stop as it is; then, where a position's stop does not open to its
        # stated f-number, with the iris opened there (opened_text), checked again.
        checked = _check_staged(flare, staging, [(os.path.basename(c[1]), c[2]) for c in candidates])
        reopened = []
        for c in candidates:
            staged, result = checked[os.path.basename(c[1])]
            if result["ok"] or any(x["check"] == "load" for x in result["failures"]):
                continue
            opened = opened_text(c[2], c[3], c[5], result["positions"])
            if opened:
                reopened.append((c, opened))
        rechecked = _check_staged(flare, staging, [("opened-" + os.path.basename(c[1]), t) for c, t in reopened])
        for c, opened in reopened:
            staged, result = rechecked["opened-" + os.path.basename(c[1])]
            c[2] = opened
            checked[os.path.basename(c[1])] = (staged, result)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    for entry, path, new_text, names, table, stated in candidates:
        staged, result = checked[os.path.basename(path)]
        if not result["ok"]:
            cause = "zoom-merge-" + imp.cause_of(result["failures"])
            detail = "merged zoom (scripts/merge_zoom_states.py): " + "; ".join(
                f"{x['check']} ({x['zoom']}): {x['detail'].replace(staged, entry['file'])}" for x in result["failures"])
            failed.append((entry["id"], cause))
            # The latest failure replaces an earlier one of this merge (the import's, or a run
            # before the iris could open per position).
            aside["set_aside"] = [e for e in aside["set_aside"]
                                  if not (e.get("id") == entry["id"] and e["cause"].startswith("zoom-merge"))]
            aside["set_aside"].append({"source_file": entry["source_file"], "id": entry["id"], "cause": cause,
                                       "detail": detail})
            continue
        checks = [f"# Check: paraxial EFL at {p['zoom']} {p['efl_mm']:.3f} mm (stated {p['stated_focal_length_mm']:.2f} mm), "
                  f"wide open f/{p['wide_open_f_number']:.3f}, ray fan at f/{p['fan_f_number']:.3f}."
                  for p in result["positions"]]
        lines = new_text.splitlines()
        at = next(i for i, line in enumerate(lines) if line.startswith("name "))
        lines[at:at] = checks
        with open(path, "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")
        entry["tags"] = [t for t in entry["tags"] if t != "zoom-first-position-only"]
        entry.pop("zoom_range_mm", None)
        focal_lengths = table["focal_lengths"]
        entry["focal_length_mm"] = round(focal_lengths[0], 3)
        entry["zoom_positions"] = names
        entry["zoom_focal_lengths_mm"] = [round(f, 2) for f in focal_lengths]
        entry["focal_range_mm"] = [round(focal_lengths[0], 2), round(focal_lengths[-1], 2)]
        # Drop an older failure of this merge (the import script's) now that it passes.
        aside["set_aside"] = [e for e in aside["set_aside"] if not (e.get("id") == entry["id"] and e["cause"].startswith("zoom-merge"))]
        merged.append(entry["id"])
    aside["set_aside"].sort(key=lambda e: (e["cause"], e["source_file"]))
    with open(index_path, "w", encoding="utf-8") as f:
        json.dump(index, f, indent=1, ensure_ascii=False)
        f.write("\n")
    with open(aside_path, "w", encoding="utf-8") as f:
        json.dump(aside, f, indent=1, ensure_ascii=False)
        f.write("\n")
    return merged, failed


def main():
    args = sys.argv[1:]
    skip = []
    while "--skip" in args:
        at = args.index("--skip")
        if at + 1 >= len(args):
            raise SystemExit(__doc__)
        skip.append(args[at + 1])
        del args[at:at + 2]
    if len(args) != 3:
        raise SystemExit(__doc__)
    merged, failed = apply(*args, skip=skip)
    for lens_id in merged:
        print(f"merged  {lens_id}")
    for lens_id, cause in failed:
        print(f"failed  {lens_id} ({cause})")
    print(f"{len(merged)} merged, {len(failed)} failed their checks and keep one state")


if __name__ == "__main__":
    main()
