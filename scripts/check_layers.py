#!/usr/bin/env python3
"""Check that the engine's include graph follows the pipeline's stages.

src/flare/ is split into stage folders, lowest first:

    core -> optics -> ghosts -> photons -> film -> wave -> render -> scene

A file may include headers of its own stage and of the stages below it, never above: a scene
builds render options, a render drives photons onto a film and diffracts the light's own image
(wave: the starburst, from the pupil that the optics trace), photons use the ghost analysis to
guide their emission, ghosts are traced through optics, and everything uses core. Every source
file must sit in one of these folders (none directly in src/flare/).

Usage: check_layers.py [path/to/src/flare]     exit 0 when the graph is clean, 1 otherwise
       check_layers.py --self-test                checks that the checker catches each kind of fault
"""
import os
import re
import sys
import tempfile

STAGES = ["core", "optics", "ghosts", "photons", "film", "wave", "render", "scene"]
INCLUDE = re.compile(r'^\s*#\s*include\s+"flare/([^"/]+)/([^"]+)"', re.MULTILINE)
SOURCE_SUFFIXES = (".h", ".cpp", ".inc")


def check(root):
    problems = []
    rank = {stage: i for i, stage in enumerate(STAGES)}
    for name in sorted(os.listdir(root)):
        path = os.path.join(root, name)
        if os.path.isfile(path):
            problems.append(f"{path}: not in a stage folder ({', '.join(STAGES)})")
        elif name not in rank:
            problems.append(f"{path}: unknown stage folder (stages: {', '.join(STAGES)})")
    for stage in STAGES:
        folder = os.path.join(root, stage)
        if not os.path.isdir(folder):
            continue
        for dirpath, _, files in os.walk(folder):
            for file in sorted(files):
                if not file.endswith(SOURCE_SUFFIXES):
                    continue
                path = os.path.join(dirpath, file)
                with open(path, encoding="utf-8") as handle:
                    text = handle.read()
                for match in INCLUDE.finditer(text):
                    target = match.group(1)
                    line = text.count("\n", 0, match.start()) + 1
                    if target not in rank:
                        problems.append(f"{path}:{line}: includes flare/{target}/{match.group(2)}, "
                                        f"which is in no stage folder")
                    elif rank[target] > rank[stage]:
                        problems.append(f"{path}:{line}: {stage} includes flare/{target}/{match.group(2)}: "
                                        f"{target} comes after {stage} in the pipeline")
                    elif not os.path.isfile(os.path.join(root, target, match.group(2))):
                        problems.append(f"{path}:{line}: includes flare/{target}/{match.group(2)}, "
                                        f"which does not exist")
    return problems


def self_test():
    """The checker on small trees: a clean one passes; a back arrow, a file outside the stage
    folders, an unknown folder and a missing header are each reported."""
    cases = {
        "clean": ({"core/A.h": "", "optics/B.h": '#include "flare/core/A.h"\n'}, 0),
        "back arrow": ({"core/A.h": '#include "flare/optics/B.h"\n', "optics/B.h": ""}, 1),
        "loose file": ({"core/A.h": "", "Loose.h": ""}, 1),
        "unknown folder": ({"core/A.h": "", "misc/C.h": ""}, 1),
        "missing header": ({"optics/B.h": '#include "flare/core/Gone.h"\n'}, 1),
    }
    failures = 0
    for name, (files, expected) in cases.items():
        with tempfile.TemporaryDirectory(prefix="flare_check_layers_") as root:
            for relative, text in files.items():
                path = os.path.join(root, relative)
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with open(path, "w", encoding="utf-8") as handle:
                    handle.write(text)
            found = len(check(root))
        if found != expected:
            print(f"self-test '{name}': {found} problem(s) reported, expected {expected}")
            failures += 1
    print("self-test: " + ("failed" if failures else f"all {len(cases)} cases as expected"))
    return 1 if failures else 0


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    here = os.path.dirname(os.path.abspath(__file__))
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, os.pardir, "src", "flare")
    problems = check(os.path.normpath(root))
    for problem in problems:
        print(problem)
    if problems:
        print(f"{len(problems)} include(s) against the pipeline ({' -> '.join(STAGES)})")
        return 1
    print(f"include graph follows the pipeline: {' -> '.join(STAGES)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
