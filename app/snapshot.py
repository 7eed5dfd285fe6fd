"""Headless pictures of the app: ``python -m app snapshot`` renders a preset at a simulated time to PNG.

The picture is taken the way a person would see it: the app is started in this process on a free
loopback port, Debian's Chromium (driven by PyPI's ``playwright``, software WebGL) opens the page,
the session is paused at the requested time, and the canvas is photographed once the browser has
drawn the very poses the server holds. The browser helpers below are shared with the browser tests
(``tests/browser``), so the tests check the same path users run.

``--json`` prints the session's state snapshot instead and needs no browser.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import shutil
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from physics import METHOD_NAMES, LinkageError, preset_names
from physics.mechanism import MECHANISM_PRESETS

from .scene import pose_disc

CHROMIUM_ENV = "LINKAGE_LAB_CHROMIUM"
CHROMIUM_CANDIDATES = ("/usr/bin/chromium", "/usr/bin/chromium-browser", "chromium", "chromium-browser")
INSTALL_HINT = (
    "install it with `apt-get install chromium` (Debian/Ubuntu) or point "
    f"{CHROMIUM_ENV} at a Chromium or Chrome executable"
)

# Software WebGL (SwiftShader through ANGLE) on every machine, so a picture does not depend on a GPU;
# everything that could reach the network or change the browser behind our back is off.
CHROMIUM_ARGS = (
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--force-device-scale-factor=1",
)

# Small pages: software WebGL costs CPU in proportion to pixels, and CI has two cores.
VIEWPORT = {"width": 960, "height": 640}

# viser reads these from the page URL: a fixed device-pixel ratio (its adaptive ratio would lower the
# resolution of a slow software renderer at an unpredictable moment) and no logo in the corner.
PAGE_QUERY = "?fixedDpr=1&hideViserLogo"

SOFTWARE_NOTICE = "#webgl-software-rendering"
CONTROL_PANEL = '[data-testid="floating-panel"]'
NOTIFICATIONS = ".mantine-Notifications-root"
SCENE_CANVAS = "canvas[data-engine]"

# A page needs a few seconds to compile shaders on a software renderer; a cold cache adds derivation.
PAGE_TIMEOUT_S = 120.0
# Identical consecutive pictures prove the page has stopped changing (environment map decoded,
# late shader variants compiled); this many tries, each after two more drawn frames, before giving up.
SETTLE_ATTEMPTS = 20
# Page conditions are polled on a timer: playwright's default (every animation frame) stalls while a
# software renderer is busy, and an idle viser page renders on demand only.
POLL_MS = 50
# viser shows its software-WebGL notice as soon as the page mounts; a hardware renderer shows none.
NOTICE_WAIT_S = 15.0


class SnapshotError(RuntimeError):
    """A snapshot cannot be taken; the text is the one line the command prints."""


# ---------------------------------------------------------------------------------------------------
# Browser helpers (also used by tests/browser)
# ---------------------------------------------------------------------------------------------------


def find_chromium() -> str:
    """Path of the Chromium to drive: ``$LINKAGE_LAB_CHROMIUM`` if set, else the usual Debian names."""
    override = os.environ.get(CHROMIUM_ENV)
    if override:
        if Path(override).is_file() and os.access(override, os.X_OK):
            return override
        raise SnapshotError(f"{CHROMIUM_ENV}={override} is not an executable file; {INSTALL_HINT}")
    for candidate in CHROMIUM_CANDIDATES:
        found = shutil.which(candidate)
        if found:
            return found
    raise SnapshotError(f"no Chromium found (looked for {', '.join(CHROMIUM_CANDIDATES)}); {INSTALL_HINT}")


def import_playwright():
    """``playwright.sync_api.sync_playwright``, or a one-line error saying how to get it."""
    try:
        from playwright.sync_api import sync_playwright  # noqa: PLC0415 - the optional snapshot extra
    except ImportError:
        raise SnapshotError(
            "the snapshot command needs the `playwright` Python package: pip install playwright "
            "(its browser download is not needed: the system Chromium is used)"
        ) from None
    return sync_playwright


def launch_chromium(playwright: Any, executable: str | None = None, env: dict[str, str] | None = None) -> Any:
    """A headless Chromium with software WebGL. Never downloads a browser (no ``playwright install``).
    ``env``: the browser's environment (default: this process's)."""
    return playwright.chromium.launch(
        executable_path=executable or find_chromium(), headless=True, args=list(CHROMIUM_ARGS), env=env
    )


LOADING_SCREEN_ID = "linkage-lab-loading"  # static/page.html


def page_url(port: int) -> str:
    return f"http://127.0.0.1:{port}/{PAGE_QUERY}"


def open_app_page(browser: Any, port: int, viewport: dict | None = None, timeout_s: float = PAGE_TIMEOUT_S) -> Any:
    """Open the app in a fresh browser context (its own websocket, so its own session) and wait until
    the renderer has drawn a frame and viser's software-WebGL notice is dismissed."""
    page = goto_app(browser, port, viewport, timeout_s)
    wait_until_drawn(page, timeout_s)
    return page


def goto_app(browser: Any, port: int, viewport: dict | None = None, timeout_s: float = PAGE_TIMEOUT_S) -> Any:
    """Load the app's page in a fresh browser context; returns at once (nothing drawn yet)."""
    context = browser.new_context(viewport=viewport or VIEWPORT, device_scale_factor=1)
    page = context.new_page()
    page.set_default_timeout(timeout_s * 1000)
    page.goto(page_url(port))
    return page


def wait_until_drawn(page: Any, timeout_s: float = PAGE_TIMEOUT_S) -> None:
    """First frame drawn, the app's loading screen gone (app/page.py), software-WebGL notice gone."""
    wait_for_first_frame(page, timeout_s)
    wait_for_panel(page, timeout_s)
    dismiss_software_notice(page, timeout_s)


def wait_for_panel(page: Any, timeout_s: float = PAGE_TIMEOUT_S) -> None:
    """The session's panel has arrived and the loading screen has removed itself."""
    page.wait_for_function(
        f"() => !document.getElementById('{LOADING_SCREEN_ID}')", timeout=timeout_s * 1000, polling=POLL_MS
    )


def wait_for_first_frame(page: Any, timeout_s: float = PAGE_TIMEOUT_S) -> None:
    """viser's test points (``window.__viserTestpoints``) report the renderer's frame count."""
    page.wait_for_function(
        "() => window.__viserTestpoints !== undefined && window.__viserMutable !== undefined"
        " && window.__viserTestpoints.rendererInfo.render.frame > 0",
        timeout=timeout_s * 1000,
        polling=POLL_MS,
    )


def dismiss_software_notice(page: Any, timeout_s: float = PAGE_TIMEOUT_S) -> bool:
    """Close viser's "Software WebGL rendering detected" notice; True if it was shown.

    We force SwiftShader, so viser always shows it soon after the first frame; it covers the top left
    of the scene and must not end up in a picture."""
    notice = page.locator(SOFTWARE_NOTICE)
    try:
        notice.wait_for(state="visible", timeout=min(timeout_s, NOTICE_WAIT_S) * 1000)
    except Exception:  # playwright's TimeoutError: a hardware renderer shows no notice
        return False
    # The close button's click event, sent straight to it: a full mouse click first waits for the
    # button to hold still over several animation frames, which costs 10-20 s while a software
    # renderer is busy with its first frames.
    notice.locator("button").first.dispatch_event("click")
    notice.wait_for(state="detached", timeout=timeout_s * 1000)
    return True


def frame_count(page: Any) -> int:
    return int(page.evaluate("() => window.__viserTestpoints.rendererInfo.render.frame"))


def wait_for_drawn_frames(page: Any, frames: int = 2, timeout_s: float = 30.0) -> None:
    """Ask viser for fresh frames (it renders on demand) and wait until ``frames`` more are drawn."""
    start = frame_count(page)
    page.evaluate("() => window.__viserMutable.requestRender()")
    page.wait_for_function(
        f"() => window.__viserTestpoints.rendererInfo.render.frame >= {start + frames}",
        timeout=timeout_s * 1000,
        polling=POLL_MS,
    )


# Position of a scene node or of one instance of a batched node (a session's ``part_addresses()``) in the
# browser: world coordinates, or local ones (in the frame of the node's parent); null when not there yet.
PART_POSITION_JS = """
const partPosition = (mutable, [nodeName, index], world) => {
    const node = mutable.nodeRefFromName[nodeName];
    if (node === undefined) return null;
    node.updateWorldMatrix(true, true);
    let position;
    if (index === null) {
        position = node.getWorldPosition(node.position.clone());
    } else {
        let mesh = null;
        node.traverse((o) => { if (mesh === null && o.isMesh && typeof o.getMatrixAt === "function") mesh = o; });
        if (mesh === null || index >= mesh.count) return null;
        const matrix = mesh.matrixWorld.clone();
        mesh.getMatrixAt(index, matrix);
        matrix.premultiply(mesh.matrixWorld);
        position = node.position.clone().setFromMatrixPosition(matrix);
    }
    return world || node.parent === null ? position : node.parent.worldToLocal(position);
};
"""


def _addresses(names: Sequence[str], where: Mapping[str, tuple[str, int | None]] | None = None) -> list[list]:
    """``[name, node, instance]`` of each part: from ``where`` (a session's ``part_addresses()``, which knows its
    drawing), else the scene node of that name."""
    where = where or {}
    return [[name, *(where.get(name) or (name, None))] for name in names]


def node_addresses(session: Any) -> dict[str, tuple[str, int | None]]:
    """Where the session's parts are drawn in the browser (its ``part_addresses()``; none for another object)."""
    addresses = getattr(session, "part_addresses", None)
    return dict(addresses()) if callable(addresses) else {}


def browser_node_positions(page: Any, names: Sequence[str],
                           where: Mapping[str, tuple[str, int | None]] | None = None) -> dict[str, list[float] | None]:
    """Local positions of scene nodes or parts as the browser holds them (None: not there yet)."""
    return page.evaluate(
        "(addresses) => {" + PART_POSITION_JS + """
            return Object.fromEntries(addresses.map(([name, node, index]) => {
                const p = partPosition(window.__viserMutable, [node, index], false);
                return [name, p === null ? null : [p.x, p.y, p.z]];
            }));
        }""",
        _addresses(names, where),
    )


def wait_for_node_positions(
    page: Any, positions: Mapping[str, Sequence[float]], tolerance: float = 1e-5, timeout_s: float = PAGE_TIMEOUT_S,
    where: Mapping[str, tuple[str, int | None]] | None = None,
) -> None:
    """Wait until every named scene node or part exists in the browser at the server's position (``where``: the
    session's :func:`node_addresses`)."""
    expected = [[*address, [float(v) for v in positions[address[0]]]]
                for address in _addresses(list(positions), where)]
    page.wait_for_function(
        "([expected, tolerance]) => {" + PART_POSITION_JS + """
            return expected.every(([name, node, index, position]) => {
                const p = partPosition(window.__viserMutable, [node, index], false);
                if (p === null) return false;
                return [p.x, p.y, p.z].every((value, i) => Math.abs(value - position[i]) <= tolerance);
            });
        }""",
        arg=[expected, tolerance],
        timeout=timeout_s * 1000,
        polling=POLL_MS,
    )


def project_to_page(page: Any, names: Sequence[str],
                    where: Mapping[str, tuple[str, int | None]] | None = None) -> dict[str, list[float] | None]:
    """Page pixel coordinates ``[x, y]`` of the named scene nodes' or parts' origins, through the browser's own
    camera (None for one the browser does not have)."""
    return page.evaluate(
        "(addresses) => {" + PART_POSITION_JS + """
            const mutable = window.__viserMutable;
            const rect = mutable.canvas.getBoundingClientRect();
            return Object.fromEntries(addresses.map(([name, node, index]) => {
                const p = partPosition(mutable, [node, index], true);
                if (p === null) return [name, null];
                const point = p.project(mutable.camera);
                return [name, [rect.left + (point.x + 1) / 2 * rect.width, rect.top + (1 - point.y) / 2 * rect.height]];
            }));
        }""",
        _addresses(names, where),
    )


def project_world_points(page: Any, frame_node: str, points: Sequence[Sequence[float]]) -> list[list[float]]:
    """Page pixel coordinates of points given in the frame of scene node ``frame_node`` (e.g. the
    mechanism's root ``/linkage``, whose frame is viser's world), through the browser's camera."""
    return page.evaluate(
        """([name, points]) => {
            const mutable = window.__viserMutable;
            const node = mutable.nodeRefFromName[name];
            if (node === undefined) throw new Error(`no scene node ${name}`);
            node.updateWorldMatrix(true, false);
            const rect = mutable.canvas.getBoundingClientRect();
            const v = node.position.clone();
            return points.map(([x, y, z]) => {
                v.set(x, y, z);
                node.localToWorld(v).project(mutable.camera);
                return [rect.left + (v.x + 1) / 2 * rect.width, rect.top + (1 - v.y) / 2 * rect.height];
            });
        }""",
        [frame_node, [[float(c) for c in point] for point in points]],
    )


def hide_overlays(page: Any) -> None:
    """Hide everything drawn over the canvas (viser's control panel, wherever its layout puts it, the
    notifications, the logo) so a picture shows the scene alone. Only visibility changes: the layout,
    and so the canvas and its camera, stay as they are."""
    page.add_style_tag(content=f"{NOTIFICATIONS} {{ visibility: hidden !important; }}")
    page.evaluate(
        """(selector) => {
            let node = document.querySelector(selector);
            while (node !== null && node !== document.body) {
                for (const sibling of node.parentElement.children) {
                    if (sibling !== node) sibling.style.setProperty("visibility", "hidden", "important");
                }
                node = node.parentElement;
            }
        }""",
        SCENE_CANVAS,
    )


def settled_screenshot(page: Any, clip: dict | None = None, attempts: int = SETTLE_ATTEMPTS) -> bytes:
    """A PNG of the page once two consecutive pictures, each after freshly drawn frames, are identical.

    Call it with the animation paused: a moving scene never settles and raises SnapshotError."""
    previous = None
    for _ in range(attempts):
        wait_for_drawn_frames(page)
        picture = page.screenshot(clip=clip, animations="disabled", caret="hide")
        if picture == previous:
            return picture
        previous = picture
    raise SnapshotError(f"the page kept changing over {attempts} pictures; is the animation paused?")


def canvas_clip(page: Any) -> dict:
    box = page.locator(SCENE_CANVAS).bounding_box()
    if box is None:
        raise SnapshotError("the page has no scene canvas")
    return {"x": box["x"], "y": box["y"], "width": box["width"], "height": box["height"]}


# ---------------------------------------------------------------------------------------------------
# The app, paused at a simulated time
# ---------------------------------------------------------------------------------------------------


@contextlib.contextmanager
def paused_app(
    preset: str, *, links: int | None = None, method: str | None = None, values: Sequence[tuple[str, str]] = ()
) -> Iterator[tuple[Any, Any]]:
    """``(server, session)``: the app on a free loopback port with one shared session (so it exists before
    any browser connects, and ``--json`` needs none), with ``values`` applied by their ``--set`` names."""
    from .server import LabServer  # noqa: PLC0415 - viser: not for --json runs that fail on their arguments

    mechanism = preset in MECHANISM_PRESETS  # a general mechanism: its method is set on its session below
    # shared: the session exists before any page connects; no presenter lock (the picture's page is the only one)
    server = LabServer(host="127.0.0.1", port=0, preset=preset, links=links, method=None if mechanism else method,
                       shared=True, warm=False, presenter=False)
    try:
        session = server.shared_session
        assert session is not None  # a shared server makes its session before it serves
        session.pause()
        if mechanism and method is not None:  # a chain's was the server's start
            session.set_value("method", method)
        for name, value in values:  # a chain's --set names in SI, a mechanism's its panel's (mass:crank, g, ...)
            session.set_value(name, value)
        yield server, session
    finally:
        server.stop()


PROGRESS_EVERY_S = 2.0


def show_time(session: Any, t: float, timeout_s: float = PAGE_TIMEOUT_S,
              progress: Callable[[str], None] | None = None) -> None:
    """Pause the session at simulated time ``t`` (simulating up to it from the start); a long way there reports
    how far it got every few seconds through ``progress``."""
    reached: list[bool] = []
    worker = threading.Thread(target=lambda: reached.append(session.goto_time(t, timeout=timeout_s)), daemon=True,
                              name="snapshot-goto")
    started = time.perf_counter()
    worker.start()
    while worker.is_alive():
        worker.join(PROGRESS_EVERY_S)
        if worker.is_alive() and progress is not None:
            runs = list(session.player.runs)
            so_far = min((run.ring.t_last for run in runs), default=0.0)
            elapsed = time.perf_counter() - started
            progress(f"simulating: {so_far:.1f} of {t:g} s ({elapsed:.0f} s so far, at most {timeout_s:g} s)")
    if not reached or not reached[0]:
        raise SnapshotError(f"time = {t}: the simulation did not reach it within {timeout_s:g} s")


def node_positions(session: Any) -> dict[str, list[float]]:
    """Positions of the session's mechanism nodes on the server (what the browser must show)."""
    nodes = session.snapshot()["scene"]["nodes"]
    return {name: node["position"] for name, node in nodes.items() if "position" in node}


def pose_points(session: Any) -> np.ndarray:
    """Every drawn point as it stands now (a chain's joints, a mechanism's body points) and the trace as drawn:
    what a picture framed on the pose must hold (the trace was cut at the picture's edge)."""
    points = np.array(session.snapshot()["joints"], dtype=float).reshape(-1, 2)
    trace = getattr(session, "trace", None)
    shown = getattr(trace, "shown_xy", None)
    return points if shown is None or len(shown) < 2 else np.vstack([points, shown])


def scene_picture(page: Any, session: Any, t: float, progress: Callable[[str], None] | None = None,
                  tight: bool = False) -> bytes:
    """PNG of the scene at simulated time ``t``, paused, once the browser shows the server's poses; ``tight``:
    framed on the mechanism as it stands at ``t`` rather than on its whole reach."""
    show_time(session, t, progress=progress)
    where = node_addresses(session)
    wait_for_node_positions(page, node_positions(session), where=where)
    if tight:
        positions = node_positions(session)
        points = pose_points(session)
        on_page = project_to_page(page, list(positions), where)
        session.camera.disc = disc = pose_disc(points)
        chain = getattr(session, "chain", None)
        if chain is not None:  # a chain: framed by its bars and pin, within the disc
            session.camera.frame(np.asarray(chain.L, dtype=float), chain.pin, force=True)
        else:  # a general mechanism: by the disc alone (as app/session.py frames it)
            session.camera.frame(np.array([disc[1]]), None, force=True)
        deadline = time.monotonic() + CAMERA_WAIT_S  # the camera's move shows as the nodes moving on the page
        while time.monotonic() < deadline and project_to_page(page, list(positions), where) == on_page:
            time.sleep(POLL_MS / 1000.0)
    return settled_screenshot(page, clip=canvas_clip(page))


MAX_CAPTION = 200
CAMERA_WAIT_S = 5.0


CAPTION_HEIGHT_FRACTION = 0.045  # the font's size per picture height: its letters (ascender to descender) ~3.5 %


def labelled(png: bytes, caption: str | None, stamp: str | None) -> bytes:
    """``png`` with a caption (bottom left) and a time stamp (bottom right) drawn on a light band, for slides.
    The text scales with the picture (Pillow's scalable default font, :data:`CAPTION_HEIGHT_FRACTION` of its
    height), so a 1920x1080 slide reads from the back row as a small one does; a caption wider than the picture
    is shrunk, never below 3 % of its height."""
    if not caption and not stamp:
        return png
    from PIL import Image, ImageDraw, ImageFont  # noqa: PLC0415 - Pillow (viser's) only for labelled pictures

    image = Image.open(io.BytesIO(png)).convert("RGB")
    draw = ImageDraw.Draw(image)
    width, height = image.size
    size = max(12, round(CAPTION_HEIGHT_FRACTION * height))
    smallest = max(12, round(0.035 * height))
    text = f"{caption or ''}    {stamp or ''}"
    while size > smallest and draw.textlength(text, font=ImageFont.load_default(size=size)) > width - size:
        size -= 1
    font = ImageFont.load_default(size=size)
    band = round(size * 1.5)
    margin = round(size / 2)
    draw.rectangle([0, height - band, width, height], fill=(245, 245, 245))
    top = height - band + round(size * 0.2)
    if caption:
        draw.text((margin, top), caption, fill=(20, 20, 20), font=font)
    if stamp:
        right = draw.textlength(stamp, font=font)
        draw.text((width - right - margin, top), stamp, fill=(20, 20, 20), font=font)
    out = io.BytesIO()
    image.save(out, format="PNG")
    return out.getvalue()


@contextlib.contextmanager
def chromium(env: dict[str, str] | None = None) -> Iterator[Any]:
    """A headless Chromium for the length of the block (``env``: its environment, default this process's)."""
    sync_playwright = import_playwright()
    executable = find_chromium()
    with sync_playwright() as playwright:
        browser = launch_chromium(playwright, executable, env=env)
        try:
            yield browser
        finally:
            browser.close()


def render_pngs(
    preset: str,
    times: Sequence[float],
    *,
    links: int | None = None,
    method: str | None = None,
    values: Sequence[tuple[str, str]] = (),
    viewport: dict | None = None,
    with_panel: bool = False,
    browser: Any = None,
    view: str = "3d",
    progress: Callable[[str], None] | None = None,
    tight: bool = False,
) -> list[bytes]:
    """PNG pictures of ``preset`` at each simulated time in ``times``: the snapshot command's core, also
    what tests/browser/regenerate_references.py stores and the reference test compares. ``browser``: an
    already running Chromium (tests share one); otherwise one is started for the call."""
    with contextlib.ExitStack() as stack:
        if browser is None:
            browser = stack.enter_context(chromium())
        server, session = stack.enter_context(paused_app(preset, links=links, method=method, values=values))
        session.camera.reserve_panel = with_panel  # a picture without the panel frames on the whole canvas
        session.set_camera_view(view)
        page = open_app_page(browser, server.port, viewport)
        stack.callback(page.context.close)
        if not with_panel:
            hide_overlays(page)
        return [scene_picture(page, session, t, progress, tight) for t in times]


def session_json(
    preset: str, t: float, *, links: int | None = None, method: str | None = None, values: Sequence[tuple[str, str]] = ()
) -> dict:
    """The session's JSON snapshot at simulated time ``t``: no browser involved."""
    with paused_app(preset, links=links, method=method, values=values) as (_, session):
        show_time(session, t)
        return session.snapshot()


# ---------------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------------

EXIT_BAD_INPUT = 2
EXIT_CANNOT_RENDER = 3
MAX_FRAMES = 10_000


class _OneLineParser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise SnapshotInputError(f"{self.prog}: {message}")


class SnapshotInputError(ValueError):
    """Bad arguments: the one line printed, exit status 2."""


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineParser(
        prog="linkage-lab snapshot",
        description="Render the app's scene headlessly to PNG (needs Chromium), or print the session's JSON state.",
    )
    parser.add_argument("--preset", default="triple-a", choices=[*preset_names(), *MECHANISM_PRESETS],
                        metavar="NAME",
                        help="mechanism: " + ", ".join([*preset_names(), *MECHANISM_PRESETS]) + " (default triple-a)")
    parser.add_argument("--links", type=int, default=None, help="number of bars for --preset chain")
    parser.add_argument("--method", default=None, choices=METHOD_NAMES, metavar="METHOD",
                        help="formulation: " + ", ".join(METHOD_NAMES))
    parser.add_argument("--time", type=float, default=0.0, help="simulated time of the (first) picture, s")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", dest="values",
                        help="change a value before the run, by the names of `python -m physics --set` "
                        "(L1, d2, m3, I1, g, theta1 in radians, omega1, pin_x, pin_y, integrator, rtol, ...); for a "
                        "general mechanism the names of its panel and share links (mass:crank, size:rod, speed:O "
                        "in degrees per second, g, stabilization, trace); repeatable")
    parser.add_argument("--out", type=Path, help="PNG file to write (one picture)")
    parser.add_argument("--frames", type=int, default=None, help="write a sequence of N pictures to --out-dir")
    parser.add_argument("--interval", type=float, default=0.1,
                        help="simulated seconds between pictures of a sequence (default 0.1)")
    parser.add_argument("--out-dir", type=Path, help="folder for --frames (frame_0000.png, ...)")
    parser.add_argument("--width", type=int, default=VIEWPORT["width"], help="picture width in pixels")
    parser.add_argument("--height", type=int, default=VIEWPORT["height"], help="picture height in pixels")
    parser.add_argument("--with-panel", action="store_true", help="keep the control panel in the picture")
    parser.add_argument("--view", choices=("front", "3d"), default="front",
                        help="front: the plane of the motion straight on, for slides (default); 3d: from above")
    parser.add_argument("--frame", choices=("pose", "reach"), default=None,
                        help="pose: frame the mechanism as it stands at --time (default for one picture); reach: "
                        "frame all it can sweep, as the app does (default for --frames, so the view stays put)")
    parser.add_argument("--caption", default=None, help=f"text under the picture (at most {MAX_CAPTION} characters)")
    parser.add_argument("--stamp", action="store_true", help="write the simulated time on the picture")
    parser.add_argument("--json", action="store_true", help="print the session's JSON snapshot instead (no browser)")
    return parser


def _parse_values(items: Sequence[str]) -> list[tuple[str, str]]:
    values = []
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise SnapshotInputError(f"--set {item!r}: expected NAME=VALUE, e.g. --set L1=2")
        values.append((name.strip(), value.strip()))
    return values


def _check(args: argparse.Namespace) -> None:
    if not (math.isfinite(args.time) and 0.0 <= args.time <= 1e5):
        raise SnapshotInputError(f"--time {args.time}: allowed range 0 <= time <= 1e5")
    if args.caption is not None and (len(args.caption) > MAX_CAPTION or not args.caption.isprintable()):
        raise SnapshotInputError(f"--caption: at most {MAX_CAPTION} printable characters on one line "
                                 f"(got {len(args.caption)})")
    if not (64 <= args.width <= 4096 and 64 <= args.height <= 4096):
        raise SnapshotInputError(f"--width {args.width} --height {args.height}: allowed range 64..4096 pixels each")
    if args.json:
        return
    if args.frames is None:
        if args.out is None:
            raise SnapshotInputError("--out FILE.png is required (or --frames N --out-dir DIR, or --json)")
        if args.out.suffix.lower() != ".png":
            raise SnapshotInputError(f"--out {args.out}: the picture is a PNG, name it *.png")
        return
    if not 1 <= args.frames <= MAX_FRAMES:
        raise SnapshotInputError(f"--frames {args.frames}: allowed range 1..{MAX_FRAMES}")
    if args.out_dir is None:
        raise SnapshotInputError("--frames needs --out-dir DIR")
    if not (math.isfinite(args.interval) and args.interval > 0.0):
        raise SnapshotInputError(f"--interval {args.interval}: must be a positive number of seconds")


def main(argv: list[str] | None = None) -> int:
    """``python -m app snapshot ...``: 0 on success; one line on stderr and 2 (bad input) or 3 (cannot
    render: no Chromium, page never drew) otherwise."""
    try:
        return _main(list(sys.argv[1:] if argv is None else argv))
    finally:  # a general mechanism's worker processes, if its session started them (none other holds them)
        pool = getattr(sys.modules.get("app.mechanism_workers"), "POOL", None)
        if pool is not None:
            pool.stop_idle()


def _main(argv: list[str]) -> int:
    try:
        args = build_parser().parse_args(argv)
        _check(args)
        values = _parse_values(args.values)
        options = {"links": args.links, "method": args.method, "values": values}
        if args.json:
            print(json.dumps(session_json(args.preset, args.time, **options), indent=2))
            return 0
        if args.frames is None:
            times = [args.time]
        else:
            times = [args.time + k * args.interval for k in range(args.frames)]
        import_playwright()  # fail before starting anything when the browser is missing
        find_chromium()
        started = time.perf_counter()
        pictures = render_pngs(
            args.preset, times, viewport={"width": args.width, "height": args.height}, with_panel=args.with_panel,
            view=args.view, progress=lambda line: print(line, file=sys.stderr, flush=True), tight=(args.frame or ("pose" if args.frames is None else "reach")) == "pose",
            **options,
        )
        pictures = [labelled(picture, args.caption, f"t = {t:.2f} s" if args.stamp else None)
                    for picture, t in zip(pictures, times)]
        if args.frames is None:
            paths = [args.out]
        else:
            args.out_dir.mkdir(parents=True, exist_ok=True)
            paths = [args.out_dir / f"frame_{k:04d}.png" for k in range(len(pictures))]
        for path, picture in zip(paths, pictures):
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(picture)
        where = paths[0] if len(paths) == 1 else f"{len(paths)} pictures in {args.out_dir}"
        print(f"wrote {where} ({time.perf_counter() - started:.1f} s)", file=sys.stderr)
        return 0
    except (SnapshotInputError, LinkageError) as error:
        print(f"linkage-lab snapshot: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except SnapshotError as error:
        print(f"linkage-lab snapshot: error: {error}", file=sys.stderr)
        return EXIT_CANNOT_RENDER
    except OSError as error:
        print(f"linkage-lab snapshot: error: {error.strerror or error}: {error.filename or ''}".rstrip(": "),
              file=sys.stderr)
        return EXIT_CANNOT_RENDER
    except Exception as error:
        if not type(error).__module__.startswith("playwright"):
            raise
        first_line = (str(error).strip().splitlines() or [type(error).__name__])[0]
        print(f"linkage-lab snapshot: error: the browser failed: {first_line}", file=sys.stderr)
        return EXIT_CANNOT_RENDER
