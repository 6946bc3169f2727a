#!/usr/bin/env python3
"""Verify the built-in glass catalogue (src/flare/optics/GlassCatalogData.inc).

For every row the dispersion formula is evaluated at the Fraunhofer d, F and C
lines and the resulting nd and Abbe number Vd = (nd - 1) / (nF - nC) are
compared with the nd and Vd written in the row (the values printed in the
maker's catalogue).  A row passes when the coefficients reproduce the printed
digits: |dnd| <= 5e-6 and |dVd| <= 0.005 (plus 1e-9 slack for rounding).

Usage: check_glass_catalog.py [path/to/GlassCatalogData.inc]
Exit status: 0 if every row passes, 1 if any row fails, 2 on a parse error.
Standard library only.
"""

import math
import os
import re
import sys

LAMBDA_D = 0.5875618  # um, helium d line
LAMBDA_F = 0.4861327  # um, hydrogen F line
LAMBDA_C = 0.6562725  # um, hydrogen C line

TOL_ND = 5e-6 + 1e-9
TOL_VD = 0.005 + 1e-9

MAKERS = {"Schott", "Ohara", "Hoya"}

NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
ROW_RE = re.compile(
    r'^\{\s*"(?P<name>[^"]+)"\s*,\s*"(?P<maker>[^"]+)"\s*,\s*'
    r"GlassFormula::(?P<formula>\w+)\s*,\s*"
    r"\{(?P<coeffs>[^{}]*)\}\s*,\s*"
    r"(?P<nd>" + NUM + r")\s*,\s*(?P<vd>" + NUM + r")\s*\}\s*,?\s*(?://.*)?$"
)


def sellmeier3(c, lam):
    """n^2 - 1 = sum B_i l^2 / (l^2 - C_i); c = [B1, B2, B3, C1, C2, C3]."""
    l2 = lam * lam
    n2 = 1.0
    for b, cc in zip(c[0:3], c[3:6]):
        n2 += b * l2 / (l2 - cc)
    return n2


def polynomial(c, lam):
    """n^2 = A0 + A1 l^2 + A2 l^-2 + A3 l^-4 + A4 l^-6 + A5 l^-8."""
    l2 = lam * lam
    return (c[0] + c[1] * l2 + c[2] / l2 + c[3] / l2 ** 2
            + c[4] / l2 ** 3 + c[5] / l2 ** 4)


FORMULAS = {"Sellmeier3": sellmeier3, "Polynomial": polynomial}


def index(formula, coeffs, lam):
    n2 = FORMULAS[formula](coeffs, lam)
    if not (n2 > 1.0) or math.isinf(n2) or math.isnan(n2):
        raise ValueError("n^2 = %r at %.7f um" % (n2, lam))
    return math.sqrt(n2)


def parse(path):
    rows, errors = [], []
    in_block_comment = False
    with open(path, encoding="utf-8") as fh:
        for lineno, raw in enumerate(fh, 1):
            line = raw.strip()
            if in_block_comment:
                if "*/" in line:
                    in_block_comment = False
                continue
            if not line or line.startswith("//"):
                continue
            if line.startswith("/*"):
                in_block_comment = "*/" not in line
                continue
            m = ROW_RE.match(line)
            if not m:
                errors.append("line %d: cannot parse: %s" % (lineno, line))
                continue
            coeffs = [s.strip() for s in m.group("coeffs").split(",") if s.strip()]
            if len(coeffs) != 6:
                errors.append("line %d: %s: expected 6 coefficients, got %d"
                              % (lineno, m.group("name"), len(coeffs)))
                continue
            try:
                coeffs = [float(s) for s in coeffs]
            except ValueError as exc:
                errors.append("line %d: %s: bad coefficient (%s)"
                              % (lineno, m.group("name"), exc))
                continue
            if m.group("formula") not in FORMULAS:
                errors.append("line %d: %s: unknown formula GlassFormula::%s"
                              % (lineno, m.group("name"), m.group("formula")))
                continue
            if m.group("maker") not in MAKERS:
                errors.append("line %d: %s: unknown maker %r"
                              % (lineno, m.group("name"), m.group("maker")))
                continue
            rows.append({
                "line": lineno,
                "name": m.group("name"),
                "maker": m.group("maker"),
                "formula": m.group("formula"),
                "coeffs": coeffs,
                "nd": float(m.group("nd")),
                "vd": float(m.group("vd")),
            })
    return rows, errors


def main(argv):
    if len(argv) > 1:
        path = argv[1]
    else:
        here = os.path.dirname(os.path.abspath(__file__))
        path = os.path.join(here, os.pardir, "src", "flare", "optics", "GlassCatalogData.inc")
    path = os.path.normpath(path)

    rows, errors = parse(path)
    seen = {}
    for r in rows:
        key = (r["maker"], r["name"])
        if key in seen:
            errors.append("line %d: duplicate %s %s (first on line %d)"
                          % (r["line"], r["maker"], r["name"], seen[key]))
        else:
            seen[key] = r["line"]
    if errors:
        for e in errors:
            print("ERROR " + e)
        return 2
    if not rows:
        print("ERROR no glass rows found in %s" % path)
        return 2

    print("%s: %d glasses" % (path, len(rows)))
    print("%-12s %-7s %-10s %9s %10s %10s %10s %7s %9s %9s %s"
          % ("glass", "maker", "formula", "nd(cat)", "nd(calc)", "dnd",
             "nF", "Vd(cat)", "Vd(calc)", "dVd", "status"))
    max_dnd = max_dvd = 0.0
    worst_nd = worst_vd = ""
    failed = []
    for r in rows:
        try:
            nd = index(r["formula"], r["coeffs"], LAMBDA_D)
            nf = index(r["formula"], r["coeffs"], LAMBDA_F)
            nc = index(r["formula"], r["coeffs"], LAMBDA_C)
        except ValueError as exc:
            print("%-12s %-7s FAIL: %s" % (r["name"], r["maker"], exc))
            failed.append(r["name"])
            continue
        vd = (nd - 1.0) / (nf - nc)
        dnd = nd - r["nd"]
        dvd = vd - r["vd"]
        ok = abs(dnd) <= TOL_ND and abs(dvd) <= TOL_VD
        if abs(dnd) > max_dnd:
            max_dnd, worst_nd = abs(dnd), r["name"]
        if abs(dvd) > max_dvd:
            max_dvd, worst_vd = abs(dvd), r["name"]
        if not ok:
            failed.append(r["name"])
        print("%-12s %-7s %-10s %9.5f %10.7f %+10.2e %10.7f %7.2f %9.4f %+9.4f %s"
              % (r["name"], r["maker"], r["formula"], r["nd"], nd, dnd, nf,
                 r["vd"], vd, dvd, "ok" if ok else "FAIL"))

    nds = [r["nd"] for r in rows]
    vds = [r["vd"] for r in rows]
    print()
    print("max |dnd| = %.2e (%s)   limit %.0e" % (max_dnd, worst_nd, 5e-6))
    print("max |dVd| = %.4f (%s)   limit %.3f" % (max_dvd, worst_vd, 0.005))
    print("coverage: nd %.5f .. %.5f, Vd %.2f .. %.2f"
          % (min(nds), max(nds), min(vds), max(vds)))
    if failed:
        print("FAILED (%d): %s" % (len(failed), ", ".join(failed)))
        return 1
    print("all %d glasses reproduce their catalogue nd and Vd" % len(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
