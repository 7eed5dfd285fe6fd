"""Regenerate the reference pictures of tests/browser/references/ -- on purpose, never from a test.

    python tests/browser/regenerate_references.py            # every preset
    python tests/browser/regenerate_references.py four-bar   # only the presets named
    python tests/browser/regenerate_references.py report-tab # a panel picture (tests/browser/panel_pictures.py)

Each picture is exactly what ``python -m app snapshot --preset NAME --time 3.5 --out NAME.png`` writes
(960 x 640, scene only, paused). A picture in which any bar's colour is missing is refused: a blank or
broken render must never become a reference. Look at every changed picture before committing it.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from app import snapshot as snap  # noqa: E402
from physics import preset_names  # noqa: E402
from tests.browser import pictures  # noqa: E402
from tests.browser.panel_pictures import PANEL_PICTURES, panel_png  # noqa: E402
from tests.browser.references_spec import REFERENCE_TIME, REFERENCES, VIEWPORT, bars_drawn  # noqa: E402

MIN_PANEL_COLOURS = 16  # a panel picture with text and a figure has hundreds of colours; a blank one a few


def main(argv: list[str]) -> int:
    names = argv or list(preset_names()) + list(PANEL_PICTURES)
    unknown = sorted(set(names) - set(preset_names()) - set(PANEL_PICTURES))
    if unknown:
        print(f"regenerate_references: unknown preset(s) {', '.join(unknown)}; known: {', '.join(preset_names())}")
        return 2
    REFERENCES.mkdir(parents=True, exist_ok=True)
    manifest_path = REFERENCES / "manifest.json"
    manifest = json.loads(manifest_path.read_text()) if manifest_path.exists() else {}
    fonts = Path(tempfile.mkdtemp(prefix="linkage-lab-fonts-"))  # the fonts the tests' browser sees
    with snap.chromium(env=pictures.pinned_font_environment(fonts)) as browser:
        version = browser.version
        for name in names:
            started = time.perf_counter()
            if name in PANEL_PICTURES:
                png = panel_png(name, browser)
                image = pictures.decode_png(png)
                if len(np.unique(image.reshape(-1, 3), axis=0)) < MIN_PANEL_COLOURS:
                    print(f"{name}: REFUSED, the picture is (nearly) blank")
                    return 1
                missing = {}
            else:
                png = snap.render_pngs(name, [REFERENCE_TIME], viewport=VIEWPORT, browser=browser)[0]
                image = pictures.decode_png(png)
                missing = bars_drawn(image, name)
            if missing:
                print(f"{name}: REFUSED, bar colour(s) missing from the picture: {missing}")
                return 1
            path = REFERENCES / f"{name}.png"
            previous = pictures.read_png(path) if path.exists() else None
            path.write_bytes(png)
            change = "new" if previous is None or previous.shape != image.shape else (
                f"{100 * pictures.differing_fraction(image, previous):.3f} % of pixels changed"
            )
            print(f"{name}: wrote {path.relative_to(ROOT)} ({change}; {time.perf_counter() - started:.1f} s)")
    manifest.update(
        {
            "time_s": REFERENCE_TIME,
            "viewport": VIEWPORT,
            "chromium": version,
            "command": "python -m app snapshot --preset NAME --time {:g} --out NAME.png".format(REFERENCE_TIME),
        }
    )
    manifest_path.write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
