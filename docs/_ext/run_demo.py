"""Run one demo cell by cell, as a notebook would, and write what each cell printed and drew.

    python run_demo.py demos/demo_paper3.py cells.json      (in an empty working directory)

The demo is read by jupytext (light format), its code cells executed in order in one namespace
with ``__name__ == "__main__"`` and no command-line arguments, so the demo runs as
``python3 demos/demo_X.py`` does (shortened: ``make docs`` sets ``CI``). For each cell the JSON
holds its kind and source, and for a code cell its printed output and the image files (PNG, GIF)
it wrote into the working directory. A cell that raises ends the run with exit code 1 and the
traceback.
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
import traceback
from pathlib import Path

IMAGES = (".png", ".gif", ".jpg", ".svg")


def _images(root: Path) -> dict[str, float]:
    return {str(p.relative_to(root)): p.stat().st_mtime_ns
            for p in root.rglob("*") if p.suffix in IMAGES and p.is_file()}


def run(demo: Path, root: Path) -> list[dict]:
    import jupytext

    notebook = jupytext.read(demo)
    namespace = {"__name__": "__main__", "__file__": str(demo)}
    sys.argv = [str(demo)]
    cells = []
    for number, cell in enumerate(notebook.cells):
        record = {"kind": cell.cell_type, "source": cell.source}
        cells.append(record)
        if cell.cell_type != "code":
            continue
        before = _images(root)
        out = io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            try:
                exec(compile(cell.source, f"{demo} (cell {number})", "exec"), namespace)
            except SystemExit as stop:
                if stop.code not in (0, None):
                    raise
        sys.stdout.flush()
        record["output"] = out.getvalue()
        record["images"] = sorted(name for name, mtime in _images(root).items()
                                  if before.get(name) != mtime)
    return cells


def main() -> int:
    demo, target = Path(sys.argv[1]).resolve(), Path(sys.argv[2])
    try:
        cells = run(demo, Path.cwd())
    except BaseException:  # noqa: BLE001 (reported to the build, which fails)
        traceback.print_exc()
        return 1
    target.write_text(json.dumps(cells, indent=1, ensure_ascii=False), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
