#!/usr/bin/env python3
"""Gives library zooms that hold one state their other zoom states (docs/lens-library.md, "Zooms").

The collection gives one zoom state of each zoom (its first). LensVisualizer transcribes many of the
same patent tables with every zoom state: the states' focal lengths, the variable gaps at infinity
focus and, for a variable-aperture zoom, the f-number of each state. For every library file tagged
`zoom-first-position-only` whose radii match such a table (the rule of the import script's
match_zoom: the same radii row by row, the table's first state's gaps equal to the file's), this
writes the states as zoom positions (`zoom`, `gap` lines; `f_number` per position for a
variable-aperture zoom, the file's own f-number kept at the first) and keeps the result only if
`flare lens check` passes at every position: the paraxial EFL within 1 % of the state's published
focal length, the stop opening to the state's f-number, the axial ray fan at it passing. A table
with more than MAX_STATES states is not a patent's list of states (LensVisualizer samples some zoom
cams finely) and is not used. Failures are listed in set-aside.json as `zoom-merge-*` (the file
ships as its one state). Only the patents' numbers are taken from LensVisualizer (no licence
stated there). Idempotent.

Usage:  /usr/bin/python3 scripts/merge_zoom_states.py lenses/library LENSVISUALIZER.git build/src/flare
(scripts/import_lens_library.py runs it when given --lensvisualizer.)
"""

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import import_lens_library as imp  # noqa: E402  (the LensVisualizer reader and the check runner)

MAX_STATES = 6


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


def _f_numbers(git_dir, path, count):
    """LensVisualizer's nominalFno: a list per state (variable aperture) or None (constant)."""
    text = subprocess.run(["git", "--git-dir", git_dir, "show", "HEAD:" + path], capture_output=True, text=True,
                          check=True).stdout
    m = re.search(r"nominalFno:\s*\[([^\]]*)\]", text)
    if not m:
        return None
    values = [float(x) for x in re.findall(r"\d+(?:\.\d+)?", m.group(1))]
    return values if len(values) == count else None


def merged_text(text, table, f_numbers, commit):
    """The file with the table's states as zoom positions, or None when the table does not match."""
    lines, rows = _rows(text)
    radii = tuple(round(0.0 if t[0] == "inf" else float(t[0]), 2) for _, t in rows if t[0] != "stop")
    if radii != table["key"] or len(table["labels"]) != len(rows):
        return None
    n = len(table["focal_lengths"])
    names = ["wide", "tele"] if n == 2 else ["wide"] + (["mid"] if n == 3 else [f"mid{i}" for i in range(1, n - 1)]) + ["tele"]
    gaps = {}
    for label, values in table["gaps"].items():
        if label not in table["labels"]:
            return None
        row = table["labels"].index(label)
        if row + 1 == len(rows):
            continue  # the back focus: the sensor is placed by the focus solve
        if abs(values[0] - float(rows[row][1][1])) > 1e-3:
            return None
        if max(values) - min(values) > 1e-9:
            gaps[row] = values
    if not gaps:
        return None
    stated_f = None
    for line in lines:
        tokens = line.split("#")[0].split()
        if tokens and tokens[0] == "f_number":
            stated_f = float(tokens[1])
    source = (f"the variable gaps at {n} zoom states (infinity focus) and the states' focal lengths are the patent "
              f"table's, as transcribed in LensVisualizer (github.com/ronbuening/LensVisualizer, {table['file']}, "
              f"commit {commit[:12]}; no licence stated there: only the patent's numbers are taken, and the radii were "
              f"matched to this file), merged by scripts/merge_zoom_states.py")
    if f_numbers:
        source += (f"; the f-numbers of the later states are LensVisualizer's nominalFno (the patent's, or the marketed "
                   f"value where it rounds), the first keeps this file's f/{stated_f:g}; the check below confirms the "
                   f"stop opens to each")
    out = []
    for i, line in enumerate(lines):
        tokens = line.split("#")[0].split()
        if tokens and tokens[0] == "name":
            out.append(f"# Zoom: {source}.")
            out.append(line)
        elif tokens and tokens[0] == "focal_length_mm":
            out.append("zoom            " + " ".join(f"{nm}={f:.2f}" for nm, f in zip(names, table["focal_lengths"])))
        elif tokens and tokens[0] == "f_number" and f_numbers:
            values = [stated_f] + f_numbers[1:]
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
    return "\n".join(lines2) + "\n", names


def apply(folder, git_dir, flare):
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
    known_failures = {(e.get("id"), e["cause"]) for e in aside["set_aside"]}
    merged, failed = [], []
    staging = tempfile.mkdtemp(prefix="flare-zoom-merge-")
    candidates = []
    for entry in index["lenses"]:
        if "zoom-first-position-only" not in entry["tags"]:
            continue
        path = os.path.join(folder, entry["file"])
        with open(path, encoding="utf-8") as f:
            text = f.read()
        _, rows = _rows(text)
        radii = tuple(round(0.0 if t[0] == "inf" else float(t[0]), 2) for _, t in rows if t[0] != "stop")
        table = tables.get(radii)
        if not table or len(table["focal_lengths"]) > MAX_STATES:
            continue
        f_numbers = _f_numbers(git_dir, table["file"], len(table["focal_lengths"]))
        result = merged_text(text, table, f_numbers, commit)
        if not result:
            continue
        new_text, names = result
        staged = os.path.join(staging, os.path.basename(path))
        with open(staged, "w", encoding="utf-8") as f:
            f.write(new_text)
        candidates.append((entry, path, staged, new_text, names, table))
    try:
        results = imp.check_files(flare, [c[2] for c in candidates]) if candidates else {}
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    for entry, path, staged, new_text, names, table in candidates:
        result = results[staged]
        if not result["ok"]:
            cause = "zoom-merge-" + imp.cause_of(result["failures"])
            detail = "merged zoom (scripts/merge_zoom_states.py): " + "; ".join(
                f"{x['check']} ({x['zoom']}): {x['detail'].replace(staged, entry['file'])}" for x in result["failures"])
            failed.append((entry["id"], cause))
            if not any(i == entry["id"] and c.startswith("zoom-merge") for i, c in known_failures):
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
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    merged, failed = apply(*sys.argv[1:])
    for lens_id in merged:
        print(f"merged  {lens_id}")
    for lens_id, cause in failed:
        print(f"failed  {lens_id} ({cause})")
    print(f"{len(merged)} merged, {len(failed)} failed their checks and keep one state")


if __name__ == "__main__":
    main()
