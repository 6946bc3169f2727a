#!/usr/bin/env python3
"""The Python steps of scripts/thesis.sh (the thesis's chapter-5 results, docs/thesis.md).

Subcommands:
  scene OUT.json ...        write a scene file for the thesis's zoom
  record MANIFEST ...       add one result (command line, wall time, report) to the manifest
  bounces MANIFEST OUT.md   the bounce-limit study's table from its four reports, and its checks
  ghosts OUT.md JSON...     the strongest ghosts of `flare ghosts --json` tables, one per position
  overlay ...               a generated frame with one flare merged over it (EXR and PNG)
  thumb EXR PNG ...         a small PNG of an EXR (box filter, the CLI's tone curve) for docs/images
  check MANIFEST            every output written, every number finite
  gallery MANIFEST OUT.md   the manifest as a Markdown table

The manifest is JSON: {"results": [{"id", "figure", "caption", "command", "wall_s", "photons",
"estimated_error", "outputs": [...]}, ...]}. Every file it names is relative to its folder.
"""
import argparse
import json
import math
import os
import struct
import sys
import zlib

LENS = "nikon-ai-s-zoom-nikkor-80-200mm-f2.8-ed"


def fail(message):
    print(f"thesis_tools: error: {message}", file=sys.stderr)
    sys.exit(2)


def write_atomic(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


# ---- scene ----------------------------------------------------------------------------------------

def cmd_scene(a):
    field = [float(v) for v in a.field.split(",")]
    width, height = (int(v) for v in a.resolution.split(","))
    scene = {
        "description": a.description,
        "lens": a.lens,
        "zoom": a.zoom if not a.zoom.replace(".", "", 1).isdigit() else float(a.zoom),
        "focus_distance_mm": "infinity" if a.focus == "inf" else float(a.focus),
        "f_number": a.f_number,
        "sensor": {"resolution": [width, height]},
        "lights": [{"type": "directional", "name": "sun", "field_deg": field, "angular_diameter_deg": 0.53,
                    "spectrum": {"blackbody_k": 5778}, "power": 1.0}],
        "render": {"seed": 1},
    }
    if a.coating:
        scene["coating"] = a.coating
    write_atomic(a.out, json.dumps(scene, indent=2) + "\n")


# ---- manifest -------------------------------------------------------------------------------------

def load_manifest(path):
    if not os.path.exists(path):
        return {"results": []}
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def cmd_record(a):
    manifest = load_manifest(a.manifest)
    entry = {"id": a.id, "figure": a.figure, "caption": a.caption, "command": a.command,
             "wall_s": round(float(a.wall), 2), "outputs": a.outputs, "photons": None, "estimated_error": None}
    if a.report:
        with open(os.path.join(os.path.dirname(a.manifest), a.report), encoding="utf-8") as f:
            report = json.load(f)
        entry["photons"] = report.get("photons")
        entry["estimated_error"] = report.get("flare_estimated_relative_error")
        entry["report"] = a.report
    manifest["results"] = [r for r in manifest["results"] if r["id"] != a.id] + [entry]
    write_atomic(a.manifest, json.dumps(manifest, indent=1) + "\n")


# ---- the bounce-limit study -----------------------------------------------------------------------

def read_report(folder, name):
    with open(os.path.join(folder, name), encoding="utf-8") as f:
        return json.load(f)


def bounce_rows(folder, pairs):
    """(limit, layers, report) for each `LIMIT=report.json` (LIMIT `unbounded`: -1); layers: name ->
    (power, standard error)."""
    rows = []
    for pair in pairs:
        limit, name = pair.split("=", 1)
        report = read_report(folder, name)
        layers = {k: (v["power_w"], v["standard_error_w"]) for k, v in report["layers"].items()}
        rows.append((-1 if limit == "unbounded" else int(limit), layers, report))
    return rows


def flare_power(layers):
    """The flare without the direct image, and its standard error (independent layers)."""
    names = ("ghost", "higher", "scatter")
    return sum(layers[n][0] for n in names), math.sqrt(sum(layers[n][1] ** 2 for n in names))


def bounce_checks(rows, z=3.29):
    """The study's claims, each a two-sided z-test at 1e-3: what failed, as text (empty: none).

    Limits in increasing order, -1 (unbounded) last. Each limit's flare power is at least the
    previous one's, and the unbounded render's `higher` layer is what the limits from 2 up add
    to the flare (its power less the 2-limit render's), within the renders' standard errors.
    """
    problems = []
    ordered = sorted(rows, key=lambda r: math.inf if r[0] < 0 else r[0])
    for (k0, l0, _), (k1, l1, _) in zip(ordered, ordered[1:]):
        p0, s0 = flare_power(l0)
        p1, s1 = flare_power(l1)
        if p1 - p0 < -z * math.hypot(s0, s1):
            problems.append(f"flare power falls from limit {k0} ({p0:.4e} W) to {k1} ({p1:.4e} W), "
                            f"beyond {z} standard errors ({math.hypot(s0, s1):.2e})")
    two = [r for r in ordered if r[0] == 2]
    unbounded = [r for r in ordered if r[0] < 0]
    if two and unbounded:
        p2, s2 = flare_power(two[0][1])
        pinf, sinf = flare_power(unbounded[0][1])
        higher, sh = unbounded[0][1]["higher"]
        # The 2-limit render's own `higher` (TIR and unenumerated two-reflection chains) is in p2.
        h2, sh2 = two[0][1]["higher"]
        added = pinf - p2
        sigma = math.sqrt(s2 ** 2 + sinf ** 2 + sh ** 2 + sh2 ** 2)
        if abs(added - (higher - h2)) > z * sigma:
            problems.append(f"limits 2 -> unbounded add {added:.4e} W, the unbounded higher layer (less "
                            f"the 2-limit's) holds {higher - h2:.4e} W: differ by more than {z} x {sigma:.2e}")
    return problems


def cmd_bounces(a):
    folder = os.path.dirname(a.manifest) or "."
    rows = bounce_rows(folder, a.reports)
    lines = ["| limit | ghost (W) | higher (W) | scatter (W) | flare = ghost + higher + scatter (W) | "
             "higher / flare | photons | wall (s) |", "|---|---|---|---|---|---|---|---|"]
    for limit, layers, report in sorted(rows, key=lambda r: math.inf if r[0] < 0 else r[0]):
        p, s = flare_power(layers)
        cell = lambda n: f"{layers[n][0]:.3e} ± {layers[n][1]:.1e}"
        lines.append(f"| {'unbounded' if limit < 0 else limit} | {cell('ghost')} | {cell('higher')} | "
                     f"{cell('scatter')} | {p:.4e} ± {s:.1e} | {layers['higher'][0] / p:.3%} | "
                     f"{report['photons']} | {report['wall_time_s']:.1f} |")
    problems = bounce_checks(rows)
    lines.append("")
    lines.append("Checks (z-tests at 1e-3 on the renders' standard errors): " +
                 ("all pass." if not problems else "; ".join(problems)))
    write_atomic(a.out, "\n".join(lines) + "\n")
    if problems:
        for p in problems:
            print("thesis_tools: bounce study: " + p, file=sys.stderr)
        sys.exit(1)


# ---- ghost tables ---------------------------------------------------------------------------------

def cmd_ghosts(a):
    lines = []
    for spec in a.tables:
        title, path = spec.split("=", 1)
        with open(path, encoding="utf-8") as f:
            table = json.load(f)
        ghosts = table["ghosts"][: a.top]
        lines.append(f"**{title}** — {table['enumerated']} ghosts enumerated, {table['pruned_count']} pruned; "
                     f"direct image {table['direct_power_fraction']:.4e} of the entering power, all ghosts "
                     f"{table['total_ghost_power_fraction']:.4e}")
        lines.append("")
        lines.append("| surfaces | power (of entering) | share of the ghosts | peak E/E0 | ghost EFL (mm) |")
        lines.append("|---|---|---|---|---|")
        for g in ghosts:
            efl = g.get("ghost_efl_mm")
            lines.append(f"| {'-'.join(str(n) for n in g['surfaces'])} | {g['power_fraction']:.3e} | "
                         f"{g['power_fraction'] / table['total_ghost_power_fraction']:.1%} | "
                         f"{g['peak_irradiance_ratio']:.3e} | {'' if efl is None else f'{efl:.1f}'} |")
        lines.append("")
    write_atomic(a.out, "\n".join(lines))


# ---- the overlay ----------------------------------------------------------------------------------

def tone_map(rgb, stops):
    """docs/rendering.md, "The PNG": exposure, Reinhard on luminance, gamut pull to grey, sRGB."""
    import numpy as np
    v = rgb.astype(np.float64) * 2.0 ** stops
    y = 0.2126 * v[..., 0] + 0.7152 * v[..., 1] + 0.0722 * v[..., 2]
    scale = np.where(y > 0, 1.0 / (1.0 + y), 1.0)
    v = v * scale[..., None]
    y = y * scale
    grey = y[..., None] * np.ones(3)
    over = np.maximum(v.max(axis=-1) - 1.0, 0.0)
    under = np.maximum(-v.min(axis=-1), 0.0)
    # The smallest t in [0, 1] with grey + (v - grey)(1 - t) inside [0, 1]^3.
    with np.errstate(divide="ignore", invalid="ignore"):
        t_over = np.where(over > 0, over / np.maximum(v.max(axis=-1) - y, 1e-30), 0.0)
        t_under = np.where(under > 0, under / np.maximum(y - v.min(axis=-1), 1e-30), 0.0)
    t = np.clip(np.maximum(t_over, t_under), 0.0, 1.0)[..., None]
    v = np.clip(grey + (v - grey) * (1.0 - t), 0.0, 1.0)
    s = np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)


def write_png(path, rgb8):
    """An 8-bit RGB PNG (zlib from the standard library): the overlay's picture."""
    import numpy as np
    height, width, _ = rgb8.shape
    # Filter "Sub" on every row (each byte less the same channel of the pixel to its left): smooth
    # pictures compress several times better than unfiltered.
    rows = rgb8.reshape(height, width * 3).astype(np.int16)
    sub = rows.copy()
    sub[:, 3:] -= rows[:, :-3]
    sub = (sub % 256).astype(np.uint8)
    raw = b"".join(b"\x01" + sub[row].tobytes() for row in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
           chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    with open(path + ".tmp", "wb") as f:
        f.write(png)
    os.replace(path + ".tmp", path)


def generated_frame(width, height, sun_px, sky_w_m2):
    """A frame to put the flare over, made here: a clear sky brightening towards the horizon, dark
    ground below it and hills on the horizon, in the same units as the flare (sensor irradiance,
    W/m², for a sun of 1 W/m²). The sun itself is not in it: its image is the flare's `starburst`."""
    import numpy as np
    rows = np.arange(height)[:, None] / max(1, height - 1)
    cols = np.arange(width)[None, :] / max(1, width - 1)
    horizon = 0.62 + 0.05 * np.sin(cols * 7.0) + 0.03 * np.sin(cols * 17.0 + 1.0)
    sky = rows < horizon
    sky_rgb = np.array([0.55, 0.72, 1.0]) * (0.6 + 0.4 * rows[..., None] / 0.62)
    ground_rgb = np.array([0.18, 0.22, 0.10]) * (0.5 + 0.5 * (1.0 - rows[..., None]))
    frame = np.where(sky[..., None], sky_rgb, ground_rgb * 0.25) * sky_w_m2
    # A glow about the sun in the sky (forward scattering in the air), part of the scene.
    yy, xx = np.mgrid[0:height, 0:width]
    r2 = ((xx - sun_px[0]) ** 2 + (yy - sun_px[1]) ** 2) / float(width) ** 2
    frame += (sky[..., None] * np.exp(-r2 / 0.01)[..., None] * np.array([1.0, 0.95, 0.85])) * 2.0 * sky_w_m2
    return frame.astype(np.float32)


def cmd_overlay(a):
    import numpy as np
    import flare
    images = flare.read_exr(a.flare_exr)
    main = np.asarray(images[""], dtype=np.float32)
    height, width, _ = main.shape
    with open(a.scene, encoding="utf-8") as f:
        scene = json.load(f)
    lens = flare.load_scene(a.scene).lens()
    efl = lens.paraxial().efl_mm
    fx, fy = scene["lights"][0]["field_deg"]
    sensor = lens.info()["sensor"]
    sensor_w, sensor_h = sensor["width_mm"], sensor["height_mm"]
    # docs/scene-format.md, Conventions: column = W (0.5 - x / widthMm), row = H (0.5 + y / heightMm),
    # with the image point at EFL·tan(field) (paraxially; only the sky glow is placed by it).
    sun_px = (width * (0.5 - (-efl * math.tan(math.radians(fx))) / sensor_w),
              height * (0.5 + (-efl * math.tan(math.radians(fy))) / sensor_h))
    # The sky's level: a fixed fraction of the flare's ghosts' brightest pixels, so that the ghosts
    # show over it as in a photograph against the sun (the 99th percentile of the lit ghost pixels;
    # of the whole flare when the EXR has no `ghost` layer, as a preview without --layers).
    ghost = np.asarray(images.get("ghost", main), dtype=np.float64)
    y = 0.2126 * ghost[..., 0] + 0.7152 * ghost[..., 1] + 0.0722 * ghost[..., 2]
    lit = y[y > 1e-6 * y.max()] if y.max() > 0 else np.array([1.0])
    sky = float(np.percentile(lit, 99)) * a.sky_level
    frame = generated_frame(width, height, sun_px, sky)
    # The merge: irradiances add. The flare is light the lens sends to the sensor besides the
    # scene's own image, so the picture stays physically correct: frame + flare, pixel by pixel.
    composite = frame + main
    flare.write_exr(a.out_exr, {"": composite, "frame": frame, "flare": main})
    stops = a.exposure if a.exposure is not None else -math.log2(max(sky * 4.0, 1e-30))
    write_png(a.out_png, tone_map(composite, stops))
    write_png(a.frame_png, tone_map(frame, stops))


def cmd_thumb(a):
    """A small PNG of an EXR's main image for docs/images: box-filtered by an integer factor (the
    irradiance averaged, so the picture's levels stay), then the CLI's tone curve at --exposure."""
    import numpy as np
    import flare
    image = np.asarray(flare.read_exr(a.exr)[""], dtype=np.float64)
    f = a.factor
    h, w = image.shape[0] // f * f, image.shape[1] // f * f
    small = image[:h, :w].reshape(h // f, f, w // f, f, 3).mean(axis=(1, 3))
    write_png(a.png, tone_map(small, a.exposure))


# ---- checks and the gallery -----------------------------------------------------------------------

def finite_json(value, where):
    if isinstance(value, float) and not math.isfinite(value):
        fail(f"{where}: a number is not finite")
    if isinstance(value, dict):
        for k, v in value.items():
            finite_json(v, where)
    if isinstance(value, list):
        for v in value:
            finite_json(v, where)


def cmd_check(a):
    import numpy as np
    import flare
    folder = os.path.dirname(a.manifest) or "."
    manifest = load_manifest(a.manifest)
    if len(manifest["results"]) < a.expect:
        fail(f"{a.manifest}: {len(manifest['results'])} results, expected at least {a.expect}")
    checked = 0
    for r in manifest["results"]:
        if not (isinstance(r["wall_s"], (int, float)) and math.isfinite(r["wall_s"]) and r["wall_s"] >= 0):
            fail(f"{r['id']}: wall time {r['wall_s']!r}")
        for name in r["outputs"] + ([r["report"]] if r.get("report") else []):
            path = os.path.join(folder, name)
            if not os.path.isfile(path) or os.path.getsize(path) == 0:
                fail(f"{r['id']}: {path} was not written")
            if name.endswith(".exr"):
                for layer, image in flare.read_exr(path).items():
                    if not np.all(np.isfinite(np.asarray(image))):
                        fail(f"{path}: layer '{layer}' holds a value that is not finite")
            elif name.endswith(".json"):
                with open(path, encoding="utf-8") as f:
                    finite_json(json.load(f), path)
            elif name.endswith(".png"):
                with open(path, "rb") as f:
                    if f.read(8) != b"\x89PNG\r\n\x1a\n":
                        fail(f"{path}: not a PNG")
            checked += 1
        if r.get("report") and (r["photons"] is None or r["photons"] <= 0):
            fail(f"{r['id']}: the report counts no photons")
    print(f"thesis: {len(manifest['results'])} results, {checked} files written and finite")


def cmd_gallery(a):
    manifest = load_manifest(a.manifest)
    lines = ["| result | thesis | image | photons | wall (s) | estimated error | command |", "|---|---|---|---|---|---|---|"]
    for r in manifest["results"]:
        image = next((o for o in r["outputs"] if o.endswith(".png") or o.endswith(".svg")), "")
        err = "" if r["estimated_error"] is None else f"{r['estimated_error']:.2%}"
        photons = "" if r["photons"] is None else f"{r['photons']:,}"
        lines.append(f"| {r['caption']} | {r['figure']} | {('![](' + image + ')') if image else ''} | {photons} | "
                     f"{r['wall_s']:.1f} | {err} | `{r['command']}` |")
    write_atomic(a.out, "\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("scene")
    s.add_argument("out")
    s.add_argument("--lens", default=LENS)
    s.add_argument("--zoom", default="wide")
    s.add_argument("--field", default="6,4")
    s.add_argument("--f-number", type=float, default=4.0)
    s.add_argument("--focus", default="inf")
    s.add_argument("--coating")
    s.add_argument("--resolution", default="768,512")
    s.add_argument("--description", default="")
    s = sub.add_parser("record")
    s.add_argument("manifest")
    for k in ("--id", "--figure", "--caption", "--command", "--wall"):
        s.add_argument(k, required=True)
    s.add_argument("--report")
    s.add_argument("--output", action="append", default=[], dest="outputs", help="a file the step wrote (repeatable)")
    s = sub.add_parser("bounces")
    s.add_argument("manifest")
    s.add_argument("out")
    s.add_argument("reports", nargs="+", help="LIMIT=report.json (relative to the manifest's folder; LIMIT a number or 'unbounded')")
    s = sub.add_parser("ghosts")
    s.add_argument("out")
    s.add_argument("tables", nargs="+", help="TITLE=ghosts.json")
    s.add_argument("--top", type=int, default=8)
    s = sub.add_parser("overlay")
    s.add_argument("--scene", required=True)
    s.add_argument("--flare-exr", required=True)
    s.add_argument("--out-exr", required=True)
    s.add_argument("--out-png", required=True)
    s.add_argument("--frame-png", required=True)
    s.add_argument("--sky-level", type=float, default=0.5)
    s.add_argument("--exposure", type=float)
    s = sub.add_parser("thumb")
    s.add_argument("exr")
    s.add_argument("png")
    s.add_argument("--factor", type=int, default=2)
    s.add_argument("--exposure", type=float, required=True)
    s = sub.add_parser("check")
    s.add_argument("manifest")
    s.add_argument("--expect", type=int, default=1)
    s = sub.add_parser("gallery")
    s.add_argument("manifest")
    s.add_argument("out")
    a = ap.parse_args()
    {"scene": cmd_scene, "record": cmd_record, "bounces": cmd_bounces, "ghosts": cmd_ghosts,
     "overlay": cmd_overlay, "thumb": cmd_thumb, "check": cmd_check, "gallery": cmd_gallery}[a.cmd](a)


if __name__ == "__main__":
    main()
