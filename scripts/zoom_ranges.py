#!/usr/bin/env python3
"""Which of the most used zoom ranges have a library zoom that can zoom (docs/lens-library.md, "Zooms").

A range is the focal range a zoom's id names (`nikon-ai-nikkor-80-200mm-f4.5` names 80-200; read
by library_names.parse_name, the same reading as src/flare/optics/LensName.cpp). The ranges are
ranked by how many of the imported collection's zooms name them (the hand-entered patent lenses,
`"collection": "patent"`, are not counted, so the count compares with the collection as imported),
ties broken by the shorter wide end, then the shorter tele end. A range is covered when at least one
library zoom naming it can zoom (`zoom_positions` in index.json: `--zoom` works on it): a merged file
of the collection, or a zoom entered from a patent example (scripts/patent_zooms.py, the thesis's
80-200 mm).

Ranges named by the same number of files tie: from some place on every range is named by two files,
and where the top N ends among them is the tie-break's choice. So the script also reports every
range named by at least as many files as the N-th (no tie to break there).

Usage:  /usr/bin/python3 scripts/zoom_ranges.py lenses/library [--top N] [--list]
  --top N   how many ranges (default 50)
  --list    print every ranked range (rank, files, merged files, ids), not only the summary and the
            ranges without a zooming lens
"""

import collections
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import library_names  # noqa: E402  (the reading of ids as LensName.cpp reads them)


def ranked_ranges(index):
    """[(range (lo, hi), [the collection's zoom entries naming it], [every library zoom naming it that
    can zoom])], most named first (ties: by lo, then hi)."""
    by_range = collections.defaultdict(list)
    zooming = collections.defaultdict(list)
    for entry in index["lenses"]:
        if entry["kind"] != "zoom":
            continue
        focal, _ = library_names.parse_name(entry["id"])
        if focal is None:
            continue
        if entry.get("collection") == "flaresim":
            by_range[focal].append(entry)
        if entry.get("zoom_positions"):
            zooming[focal].append(entry["id"])
    ranked = sorted(by_range.items(), key=lambda item: (-len(item[1]), item[0]))
    return [(focal, entries, zooming[focal]) for focal, entries in ranked]


def name(focal):
    return "%g-%g" % focal


def main():
    args = sys.argv[1:]
    top, show_all = 50, False
    if "--list" in args:
        show_all = True
        args.remove("--list")
    if "--top" in args:
        at = args.index("--top")
        if at + 1 >= len(args) or not args[at + 1].isdigit() or int(args[at + 1]) < 1:
            raise SystemExit(__doc__)
        top = int(args[at + 1])
        del args[at:at + 2]
    if len(args) != 1:
        raise SystemExit(__doc__)
    with open(os.path.join(args[0], "index.json"), encoding="utf-8") as f:
        index = json.load(f)
    ranked = ranked_ranges(index)
    zooms = sum(len(entries) for _, entries, _ in ranked)
    merged_zooms = sum(1 for _, entries, _ in ranked for e in entries if e.get("zoom_positions"))
    head = ranked[:top]
    threshold = len(head[-1][1])
    tied = [item for item in ranked if len(item[1]) >= threshold]
    print(f"{zooms} zooms of the collection name {len(ranked)} ranges; {merged_zooms} of them can zoom")
    print(f"top {top} ranges (ties by the shorter wide end, then tele end): "
          f"{sum(1 for _, _, z in head if z)} have a zooming lens")
    print(f"all {len(tied)} ranges named by at least {threshold} files (the {top}th range's count): "
          f"{sum(1 for _, _, z in tied if z)} have a zooming lens")
    if show_all:
        print("\nrank  range        files  zooming  ids of the library zooms that can zoom")
        for rank, (focal, entries, zooming) in enumerate(ranked, 1):
            print(f"{rank:4d}  {name(focal):<12s} {len(entries):5d}  {len(zooming):7d}  {' '.join(zooming)}")
    print(f"\nranges among the {len(tied)} without a zooming lens (rank, range, files: ids):")
    for rank, (focal, entries, zooming) in enumerate(tied, 1):
        if not zooming:
            print(f"{rank:4d}  {name(focal)}  {len(entries)}: {' '.join(e['id'] for e in entries)}")


if __name__ == "__main__":
    main()
