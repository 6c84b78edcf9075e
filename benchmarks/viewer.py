"""Offline viewer benchmark (issue 26.2): the load time of a golden model's ``viewer.html`` in
headless chromium, opened from the file system: from navigation start to the first frame drawn
(the page records ``performance.now()`` when a WebGL fence after its first render has
signalled, i.e. the GPU has finished drawing it: the figure includes parsing three.js and
data.js, building every mesh, compiling the shaders and the draw), and to the first frame with
the image-based lighting (the environment map's shaders, built after the first frame). Also
prints the time to write the viewer and the size of its files.

Chromium draws with SwiftShader (software WebGL) here, so a machine with a GPU loads faster.

Run: ``python benchmarks/viewer.py [--only rover] [--runs 5] [--screenshot PATH]``.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ARGS = ["--use-gl=swiftshader", "--enable-unsafe-swiftshader"]


def write_viewer(name: str, out: Path) -> tuple[float, int, int]:
    """Compile ``golden/<name>`` and write its viewer into ``out``; (seconds to write, parts,
    triangles)."""
    from procedura_brep.export.bundle import write_bundle
    from procedura_brep.program.sandbox import compile_source
    model = compile_source((ROOT / "golden" / name / "program.py").read_text(), name=name)
    [p.mesh() for p in model.parts]  # tessellated once beforehand, as the build's gates do
    t = time.perf_counter()
    write_bundle(model, out, formats="viewer")
    dt = time.perf_counter() - t
    return dt, len(model.parts), sum(len(p.mesh().faces) for p in model.parts)


def load_times(page_path: Path, runs: int, screenshot: Path | None) -> list[tuple[float, float]]:
    """Milliseconds from navigation to the first frame drawn and to the first lit one, one
    fresh page per run."""
    from playwright.sync_api import sync_playwright
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        sys.exit("no chromium on PATH")
    out = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=ARGS)
        for i in range(runs):
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            errors: list[str] = []
            page.on("pageerror", lambda e, errors=errors: errors.append(str(e)))
            page.on("console", lambda m, errors=errors: errors.append(m.text) if m.type == "error" else None)
            page.goto(page_path.as_uri())
            page.wait_for_function("window.viewer && window.viewer.lit", timeout=120_000)
            if errors:
                sys.exit(f"the page reported errors: {errors}")
            out.append((float(page.evaluate("viewer.firstFrameMs")),
                        float(page.evaluate("viewer.litFrameMs"))))
            if screenshot is not None and i == runs - 1:
                screenshot.parent.mkdir(parents=True, exist_ok=True)
                page.screenshot(path=str(screenshot))
            page.close()
        browser.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="rover", help="the golden model (default rover)")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--screenshot", type=Path, default=None, help="save the last page's picture")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        dt, parts, tris = write_viewer(args.only, out)
        sizes = {p.relative_to(out).as_posix(): p.stat().st_size for p in out.rglob("*") if p.is_file()}
        ms = load_times(out / "viewer.html", args.runs, args.screenshot)
    print(f"{args.only}: {parts} parts, {tris:,} triangles; viewer written in {dt:.2f} s")
    for rel, size in sorted(sizes.items()):
        print(f"  {rel:22s} {size / 1024:8.0f} KiB")
    print(f"  total                  {sum(sizes.values()) / 1024:8.0f} KiB")
    for i, what in enumerate(("first frame drawn", "first lit frame (environment map)")):
        t = [m[i] for m in ms]
        print(f"navigation -> {what} (file://, SwiftShader), {len(t)} runs: median "
              f"{statistics.median(t):.0f} ms, min {min(t):.0f} ms, max {max(t):.0f} ms")


if __name__ == "__main__":
    main()
