"""Real-browser test harness: Debian's Chromium driven by PyPI's playwright, the app started in-process.

Without Chromium (or playwright) the browser tests skip with a one-line reason; with
``LINKAGE_LAB_REQUIRE_BROWSER=1`` (set by .ci/run) they fail instead. ``LINKAGE_LAB_CHROMIUM`` points at
another Chromium. Never ``playwright install``: the system browser is used.

One Chromium serves the whole run; every test starts its own app (``LabServer`` on a free loopback port)
and opens as few small pages as it needs. Helpers drive viser's Mantine controls as a person would
(mouse drags, clicks, the keyboard) and wait for real signals: viser's test points (frames drawn, scene
nodes at the server's poses), never a fixed sleep.
"""

from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from app import snapshot as snap

from . import pictures

REQUIRE_BROWSER_ENV = "LINKAGE_LAB_REQUIRE_BROWSER"
KEEP_PICTURES_ENV = "LINKAGE_LAB_KEEP_PICTURES"
REFERENCES = Path(__file__).resolve().parent / "references"
# Pictures of failed comparisons go here (never into references/): look at them, then decide.
OUTPUT = Path(__file__).resolve().parent / "output"
SERVER_TIMEOUT_S = 60.0


def pytest_collection_modifyitems(items):
    here = Path(__file__).resolve().parent
    for item in items:
        if Path(str(item.fspath)).resolve().is_relative_to(here):
            item.add_marker(pytest.mark.browser)


def _unavailable(reason: str):
    if os.environ.get(REQUIRE_BROWSER_ENV) == "1":
        pytest.fail(f"{REQUIRE_BROWSER_ENV}=1 and {reason}", pytrace=False)
    pytest.skip(reason)


@pytest.fixture(scope="session")
def chromium_executable() -> str:
    try:
        snap.import_playwright()
        return snap.find_chromium()
    except snap.SnapshotError as error:
        _unavailable(f"browser tests need Chromium and playwright: {error}")


@pytest.fixture(scope="session")
def browser(chromium_executable, tmp_path_factory):
    sync_playwright = snap.import_playwright()
    playwright = sync_playwright().start()
    try:
        env = pictures.pinned_font_environment(tmp_path_factory.mktemp("fonts"))
        chromium = snap.launch_chromium(playwright, chromium_executable, env=env)
    except Exception as error:  # a broken browser install is the same as none
        playwright.stop()
        _unavailable(f"Chromium at {chromium_executable} did not start: {str(error).splitlines()[0]}")
    yield chromium
    chromium.close()
    playwright.stop()


# ------------------------------------------------------------------------------------------ the app
@dataclass
class Lab:
    """One running app and the pages a test opened on it."""

    server: Any
    browser: Any
    pages: list = field(default_factory=list)
    opened: list = field(default_factory=list)  # plain playwright pages a test opened itself

    @property
    def port(self) -> int:
        return self.server.port

    def open_page(self, pause: bool = True, viewport: dict | None = None) -> "AppPage":
        """A new page (own browser context, so its own websocket and session), drawn and with its session
        (paused at once unless ``pause`` is False); ``viewport`` ``{"width", "height"}`` in CSS pixels."""
        before = set(self.server.sessions)
        page = snap.goto_app(self.browser, self.port, viewport)
        deadline = time.monotonic() + SERVER_TIMEOUT_S
        while time.monotonic() < deadline:
            new = set(self.server.sessions) - before
            if new:
                break
            time.sleep(0.02)
        else:
            raise AssertionError("the server made no session for the new page")
        (client_id,) = new
        app_page = AppPage(page=page, client_id=client_id, lab=self)
        self.pages.append(app_page)
        if pause:
            # An animating scene keeps a software renderer busy: pause before anything else.
            app_page.session.pause()
        snap.wait_until_drawn(page)
        return app_page

    def close(self) -> None:
        for app_page in self.pages:
            app_page.close()
        for page in self.opened:
            page.context.close()
        self.server.stop()


@pytest.fixture
def start_lab(browser):
    """``start_lab(preset=..., **LabServer options)``: the app on a free loopback port; stopped afterwards."""
    from app.server import LabServer

    labs: list[Lab] = []

    def start(**options) -> Lab:
        options.setdefault("warm", False)
        lab = Lab(server=LabServer(host="127.0.0.1", port=0, **options), browser=browser)
        labs.append(lab)
        return lab

    yield start
    for lab in labs:
        lab.close()


# ------------------------------------------------------------------------------------------ one page
@dataclass
class AppPage:
    """A page showing one session, with the moves a person makes and the pictures a test checks."""

    page: Any
    client_id: int
    lab: Lab
    closed: bool = False

    @property
    def session(self):
        session = self.lab.server.session_for(self.client_id)
        assert session is not None, f"client {self.client_id} has no session"
        return session

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.page.context.close()

    # ---------------------------------------------------------------- pictures
    def show_time(self, t: float) -> None:
        """Pause at simulated time ``t`` (server side) and wait until the browser shows those poses."""
        snap.show_time(self.session, t)
        self.wait_for_server_poses()

    def wait_for_server_poses(self) -> None:
        snap.wait_for_node_positions(self.page, snap.node_positions(self.session),
                                     where=snap.node_addresses(self.session))

    def picture(self, name: str, clip: dict | None = None) -> np.ndarray:
        """The page (or ``clip``) once it has stopped changing, as (H, W, 3) RGB. With
        ``LINKAGE_LAB_KEEP_PICTURES=1`` it is also written to tests/browser/output/<name>.png."""
        png = snap.settled_screenshot(self.page, clip=clip)
        if os.environ.get(KEEP_PICTURES_ENV) == "1":
            OUTPUT.mkdir(parents=True, exist_ok=True)
            (OUTPUT / f"{name}.png").write_bytes(png)
        return pictures.decode_png(png)

    def project(self, names) -> dict[str, list[float] | None]:
        return snap.project_to_page(self.page, names, snap.node_addresses(self.session))

    def panel_box(self) -> dict | None:
        return self.page.locator(snap.CONTROL_PANEL).bounding_box()

    # ---------------------------------------------------------------- controls
    def open_tab(self, name: str) -> None:
        self.page.get_by_role("tab", name=name, exact=True).click()

    def folder(self, title: str):
        """A folder of the control panel: viser draws its title as a Paper inside the folder's Paper."""
        heading = self.page.locator(
            ".mantine-Paper-root > .mantine-Paper-root", has_text=re.compile(f"^{re.escape(title)}$")
        ).first
        return heading.locator("xpath=..")

    def slider(self, label: str, folder: str | None = None):
        """The Mantine slider root labelled ``label`` (inside folder ``folder`` when labels repeat)."""
        scope = self.folder(folder) if folder is not None else self.page
        label_element = scope.locator("label", has_text=re.compile(f"^{re.escape(label)}$")).first
        slider_id = label_element.get_attribute("for")
        return self.page.locator(f'[id="{slider_id}"]')

    def drag_slider(self, label: str, value: float, folder: str | None = None) -> None:
        """Drag the slider's thumb with the mouse to where ``value`` sits on its track."""
        slider = self.slider(label, folder)
        thumb = slider.locator(".mantine-Slider-thumb")
        thumb.scroll_into_view_if_needed()
        low = float(thumb.get_attribute("aria-valuemin"))
        high = float(thumb.get_attribute("aria-valuemax"))
        track = slider.locator(".mantine-Slider-track").bounding_box()
        start = thumb.bounding_box()
        x = track["x"] + (value - low) / (high - low) * track["width"]
        y = start["y"] + start["height"] / 2
        mouse = self.page.mouse
        mouse.move(start["x"] + start["width"] / 2, y)
        mouse.down()
        mouse.move(x, y, steps=8)
        mouse.up()

    def slider_value(self, label: str, folder: str | None = None) -> float:
        return float(self.slider(label, folder).locator(".mantine-Slider-thumb").get_attribute("aria-valuenow"))

    def press_on_slider(self, label: str, key: str, times: int = 1, folder: str | None = None) -> None:
        """Focus the slider's thumb and press ``key`` (ArrowRight, ArrowLeft, Home, End) ``times`` times."""
        thumb = self.slider(label, folder).locator(".mantine-Slider-thumb")
        thumb.scroll_into_view_if_needed()
        thumb.focus()
        for _ in range(times):
            thumb.press(key)

    def choose(self, label: str, option: str) -> None:
        """Open the dropdown labelled ``label`` and click ``option``."""
        label_element = self.page.locator("label", has_text=re.compile(f"^{re.escape(label)}$")).first
        combobox = self.page.locator(f'[id="{label_element.get_attribute("for")}"]')
        combobox.scroll_into_view_if_needed()
        combobox.click()
        self.page.get_by_role("option", name=option, exact=True).click()

    def notification_texts(self) -> list[str]:
        return self.page.locator(".mantine-Notification-root").all_inner_texts()


def wait_until(condition, timeout_s: float = SERVER_TIMEOUT_S, message: str = "condition") -> None:
    """Poll a server-side condition (a session's state) until it holds."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.02)
    raise AssertionError(f"timed out after {timeout_s:g} s waiting for {message}")


# ------------------------------------------------------------------------------------------ checks
def save_failure(name: str, actual: np.ndarray, reference: np.ndarray | None = None) -> Path:
    """Write the picture that failed (and a diff) to tests/browser/output/ for a person to look at."""
    path = OUTPUT / f"{name}.png"
    pictures.write_png(path, actual)
    if reference is not None and reference.shape == actual.shape:
        pictures.write_png(OUTPUT / f"{name}.diff.png", pictures.diff_picture(actual, reference))
    return path


def bar_colour_pixels(image: np.ndarray, projected: dict, radius: int = 6) -> dict[str, int]:
    """For each bar (``{"/linkage/bar_k": [x, y]}``), how many pixels of that bar's colour lie around its
    midpoint on the page. The midpoint comes from the browser's own camera (``project_to_page``), the
    colour from the scene's palette: a blank picture, or one showing only the control panel, has none."""
    from app.scene import BAR_COLORS

    counts = {}
    for name, xy in projected.items():
        k = int(name.rsplit("_", 1)[1])
        colour = BAR_COLORS[(k - 1) % len(BAR_COLORS)]
        counts[name] = pictures.count_near(pictures.colour_match(image, colour), xy, radius)
    return counts


def assert_mechanism_drawn(image: np.ndarray, app_page: AppPage, minimum: int = 12) -> None:
    """Every bar's colour is drawn where the browser's camera puts that bar, outside the control panel."""
    session = app_page.session
    names = [f"/linkage/bar_{k}" for k in range(1, session.params.n + 1)]
    projected = app_page.project(names)
    panel = pictures.box_mask(image.shape, app_page.panel_box())
    visible = {}
    for name, xy in projected.items():
        assert xy is not None, f"{name} is not in the browser's scene"
        x, y = int(round(xy[0])), int(round(xy[1]))
        inside = 0 <= y < image.shape[0] and 0 <= x < image.shape[1]
        if inside and not panel[y, x]:
            visible[name] = xy
    assert visible, f"no bar's midpoint is on the canvas outside the control panel: {projected}"
    counts = bar_colour_pixels(image, visible)
    assert all(count >= minimum for count in counts.values()), (
        f"bar colours missing where the bars are (pixels of each bar's colour near its midpoint: {counts}, "
        f"need {minimum}); the picture is blank or shows only the GUI"
    )
