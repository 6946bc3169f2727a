#!/usr/bin/env python3
"""Check that the project's documentation stands alone and matches the program.

1. Every relative link in README.md and the Markdown files under docs/ and lenses/ points to a file
   or folder inside the repository that exists, and no text points readers outside it (a path
   through ../shared, or any relative path that climbs out of the repository).
2. README's command summary (the first ``` block under "## Command line") names every option each
   command's --help lists (`flare ghosts --help` has --zoom: the summary line of `flare ghosts` must
   say --zoom).

Usage: check_docs.py SOURCE_DIR FLARE_PROGRAM    exit 0 when both hold, 1 otherwise (each problem on
       a line: file:line: problem)
       check_docs.py --self-test                 checks that the checker catches each kind of fault
"""
import os
import re
import subprocess
import sys
import tempfile

LINK = re.compile(r"\]\(([^)\s]+)\)")
OUTSIDE = re.compile(r"\.\./shared\b")
OPTION = re.compile(r"^\s+(?:(-\w),)?(--[a-z][a-z0-9-]*)", re.MULTILINE)
COMMANDS = ["lens info", "lens list", "lens search", "lens check", "lens export", "lens draw", "ghosts", "preview",
            "render", "compare", "dataset", "composite", "volume make", "volume info"]


def markdown_files(source_dir):
    files = [os.path.join(source_dir, "README.md")]
    for folder in ("docs", "lenses"):
        for root, _, names in os.walk(os.path.join(source_dir, folder)):
            files += [os.path.join(root, n) for n in sorted(names) if n.endswith(".md")]
    return [f for f in files if os.path.isfile(f)]


def check_links(source_dir):
    problems = []
    top = os.path.realpath(source_dir)
    for path in markdown_files(source_dir):
        shown = os.path.relpath(path, source_dir)
        with open(path, encoding="utf-8") as handle:
            lines = handle.read().splitlines()
        for number, line in enumerate(lines, 1):
            if OUTSIDE.search(line):
                problems.append(f"{shown}:{number}: points outside the repository (../shared)")
            for target in LINK.findall(line):
                if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                    continue  # a URL, or an anchor in the same file
                file_part = target.split("#", 1)[0]
                resolved = os.path.realpath(os.path.join(os.path.dirname(path), file_part))
                if not (resolved == top or resolved.startswith(top + os.sep)):
                    problems.append(f"{shown}:{number}: link '{target}' leaves the repository")
                elif not os.path.exists(resolved):
                    problems.append(f"{shown}:{number}: link '{target}' points to nothing")
    return problems


def summary_lines(readme_text):
    """The command summary of README: each command's text (its lines up to the next `flare`)."""
    section = readme_text.split("## Command line", 1)[1]
    block = section.split("```", 2)[1]
    commands, current = {}, None
    for line in block.splitlines():
        match = re.match(r"^flare ((?:lens|volume) \w+|\w+)", line)
        if match:
            current = match.group(1)
            commands[current] = ""
        if current:
            commands[current] += line + "\n"
    return commands


def check_summary(source_dir, program, help_of=None):
    def run_help(command):
        return subprocess.run([program, *command.split(), "--help"], capture_output=True, text=True).stdout

    help_of = help_of or run_help
    with open(os.path.join(source_dir, "README.md"), encoding="utf-8") as handle:
        summary = summary_lines(handle.read())
    problems = []
    for command in COMMANDS:
        options = [(short, long) for short, long in OPTION.findall(help_of(command)) if long != "--help"]
        if not options:
            problems.append(f"README.md: `flare {command} --help` lists no options (is the program right?)")
            continue
        text = summary.get(command)
        if text is None:
            problems.append(f"README.md: the command summary has no line for `flare {command}`")
            continue
        for short, long in options:
            named = [o for o in (short, long) if o and re.search(r"(?<![\w-])" + re.escape(o) + r"(?![\w-])", text)]
            if not named:
                problems.append(f"README.md: the summary of `flare {command}` does not name {long}")
    return problems


def self_test():
    failures = []
    with tempfile.TemporaryDirectory(prefix="flare-check-docs-") as source:
        os.makedirs(os.path.join(source, "docs"))
        with open(os.path.join(source, "docs", "a.md"), "w", encoding="utf-8") as handle:
            handle.write("see [design](../shared/DESIGN.md)\nand [b](b.md) and [web](https://x.org) [up](../../x.md)\n")
        with open(os.path.join(source, "README.md"), "w", encoding="utf-8") as handle:
            handle.write("## Command line\n\n```\nflare ghosts LENS [--all] -o X\nflare render [--seed N]\n```\n")
        found = "\n".join(check_links(source))
        for expected in ("docs/a.md:1: points outside", "'../shared/DESIGN.md' points to nothing", "'b.md' points to nothing",
                         "'../../x.md' leaves"):
            if expected not in found:
                failures.append(f"check_links missed: {expected}")
        if "x.org" in found:
            failures.append("check_links flagged a URL")
        helps = {"ghosts": "Options:\n  -h,--help  help\n  --all  every\n  --zoom TEXT  zoom\n  -o,--output X  out\n",
                 "render": "Options:\n  --seed-file X\n  --seed N\n"}
        found = "\n".join(check_summary(source, "", lambda c: helps.get(c, "")))
        if "`flare ghosts` does not name --zoom" not in found:
            failures.append("check_summary missed an option left out")
        if any(f"does not name {o}\n" in found + "\n" for o in ("--all", "--seed", "--help", "--output")):
            failures.append("check_summary flagged an option that is there: " + found)
        if "`flare render` does not name --seed-file" not in found:
            failures.append("check_summary took --seed for --seed-file")
        if "no line for `flare preview`" in found or "lists no options" not in found:
            failures.append("check_summary did not report a command without options")
    for failure in failures:
        print(failure)
    return 1 if failures else 0


def main(argv):
    if len(argv) == 2 and argv[1] == "--self-test":
        return self_test()
    if len(argv) != 3:
        print(__doc__)
        return 2
    problems = check_links(argv[1]) + check_summary(argv[1], argv[2])
    for problem in problems:
        print(problem)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
