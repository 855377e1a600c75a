"""The live panel end to end in a real headless Chromium (Debian's chromium + chromedriver, which
``.ci/run`` installs), driven by Selenium as a user would: the page loads and its traces move, the supply
pressure and the load are changed from the page, a hose burst is injected and cleared, ten seconds are
recorded and downloaded, stop ends the plant cleanly. Screenshots go to the test's folder."""

import io
import json
import shutil
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from conftest import PanelProcess
from hydrohil.simulation.outputs import read_csv_columns

pytestmark = pytest.mark.slow      # a real Chromium driving the panel for half a minute

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


def browser_driver(tmp_path: Path):
    """Headless Debian Chromium under Selenium, downloads into ``tmp_path/downloads``."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--disable-quic",
              "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
              f"--user-data-dir={tmp_path / 'chromium-profile'}", "--window-size=1400,1300"):
        opts.add_argument(a)
    opts.add_experimental_option("prefs", {"download.default_directory": str(tmp_path / "downloads"),
                                           "download.prompt_for_download": False})
    drv = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    drv.set_page_load_timeout(120)
    return drv


@pytest.fixture
def browser(tmp_path):
    if not (CHROMIUM and CHROMEDRIVER):
        pytest.fail("the browser tests need Debian's chromium and chromium-driver (bash .ci/run installs them: "
                    "apt-get install chromium chromium-driver)")
    drv = browser_driver(tmp_path)
    yield drv
    drv.quit()


T0 = time.monotonic()


def wait_until(fn, what, timeout=120, on_fail=None):
    """Until fn() is truthy (a state the page or the plant reaches), polled; fails with ``what`` (and what
    ``on_fail()`` says: the page's message)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        v = fn()
        if v:
            print(f"TIMING {time.monotonic() - T0:.2f} s: {what}", flush=True)
            return v
        time.sleep(0.05)
    raise AssertionError(f"{what} within {timeout} s" + (f": {on_fail()}" if on_fail else ""))


def png_pixels(png: bytes) -> np.ndarray:
    import matplotlib.image as mpimg
    return mpimg.imread(io.BytesIO(png), format="png")


@pytest.mark.parametrize("plant", ["python", "c"])
def test_panel_in_chromium(browser, tmp_path, plant):
    """The same user session on either plant (``hydrohil panel --plant python|c``)."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select
    p = PanelProcess(tmp_path / "panel", "--plant", plant)
    shots = tmp_path / "screenshots"
    shots.mkdir()
    try:
        browser.get(p.url)
        el = lambda i: browser.find_element(By.ID, i)   # noqa: E731
        assert browser.title == "hydrohil panel"
        assert wait_until(lambda: el("scenario").text, "the header").endswith(
            {"c": "C plant", "python": "Python plant"}[plant])                 # the page says which plant runs
        # live traces: the frame counter runs, the pictures differ from one moment to the next
        f0 = wait_until(lambda: int(el("frames").text), "a first frame")
        p.wait_steps(p.api("api/state")["counters"]["steps"] + 200)
        a = png_pixels(el("c-position").screenshot_as_png)
        wait_until(lambda: int(el("frames").text) >= f0 + 25, "25 more frames")
        p.wait_steps(p.api("api/state")["counters"]["steps"] + 200)
        b = png_pixels(el("c-position").screenshot_as_png)
        assert a.shape == b.shape and np.mean(np.any(a != b, axis=-1)) > 1e-3     # > 0.1 % of the pixels changed
        # the axes tick at round values (issue #25 §5: they read 212.6 / -584.6 / 1.033e+4)
        ticks = browser.execute_script("return [niceTicks(212.6, 1033.2, 4), niceTicks(-584.6, 10330, 4), "
                                       "niceTicks(0.0123, 0.0187, 4), niceTicks(-2.5, 2.5, 4)].map("
                                       "(t) => t.map((x) => x[1]))")
        assert ticks == [["250", "500", "750", "1000"], ["0", "5000", "10000"], ["0.014", "0.016", "0.018"],
                         ["-2", "0", "2"]]
        assert wait_until(lambda: el("status").text.startswith("running"), "status 'running'")
        # record, change the supply pressure (bar on the page) and the load, inject and clear a hose burst
        el("record").click()
        wait_until(lambda: p.api("api/state")["recording"], "the recording to start")
        inp = el("tun-supply_pressure")
        inp.click()                               # as a user does: into the field, then type over it
        inp.clear()
        inp.send_keys("30")
        el("set-supply_pressure").click()
        ev = wait_until(lambda: [e for e in p.api("api/state")["events"] if e.get("name") == "supply_pressure"],
                        "the supply change applied", on_fail=lambda: el("message").text)[0]
        assert ev["value"] == 30e5
        inp = el("tun-mass")
        inp.click()
        inp.clear()
        inp.send_keys("120")
        el("set-mass").click()
        wait_until(lambda: [e for e in p.api("api/state")["events"] if e.get("name") == "mass"], "the mass change")
        Select(el("fault-type")).select_by_visible_text("hose_burst")
        Select(browser.find_element(By.CSS_SELECTOR, "#fault-fields select[data-name=line]")).select_by_visible_text("2")
        el("fault-on").click()
        wait_until(lambda: browser.find_elements(By.CSS_SELECTOR, "#faults-active button"), "the burst listed")
        k_burst = p.api("api/state")["events"][-1]["k"]
        p.wait_steps(k_burst + 400)
        browser.save_screenshot(str(shots / "panel.png"))
        browser.find_element(By.CSS_SELECTOR, "#faults-active button").click()
        wait_until(lambda: not browser.find_elements(By.CSS_SELECTOR, "#faults-active li"), "the burst cleared")
        # ten seconds of plant time in the recording
        k0 = p.api("api/state")["recording"]["k0"]
        p.wait_steps(k0 + int(10 / 5e-4), timeout=300)
        el("record").click()
        wait_until(lambda: "report done" in el("recordings").text, "the recording listed, its report made",
                   timeout=300)
        browser.find_element(By.CSS_SELECTOR, "#recordings a").click()
        zips = wait_until(lambda: list((tmp_path / "downloads").glob("rec-*.zip")), "the download")
        # stop ends the plant cleanly
        el("stop").click()
        wait_until(lambda: el("status").text == "ended", "the session to end")
        ended = p.api("api/state")["ended"]
        assert ended["exit_codes"]["plant"] in (0, 3) and ended["exit_codes"]["controller"] == 0     # 3: INVALID
        assert ended["stopped_early"] and ended["stop_signal"] is None and ended["fault"] is None
    finally:
        p.close()
    # the download is the recording's run folder
    with zipfile.ZipFile(wait_until(lambda: [z for z in zips if z.stat().st_size], "a complete zip")[0]) as z:
        names = {Path(n).name for n in z.namelist()}
    assert {"plant_log.csv", "timing.json", "events.jsonl", "report.png", "comparison.json", "scenario.toml"} <= names
    rec = next((p.session / "recordings").iterdir())
    log = read_csv_columns(rec / "plant_log.csv")
    assert log["k"][-1] - log["k"][0] >= 10 / 5e-4 - 1
    # the supply change shows in the plant log (the supply transducer) within 50 ms of plant time of the
    # request reaching the panel (k_requested: the newest step the plant had reported by then)
    k30 = int(log["k"][np.argmax(np.abs(log["ps_meas"] - 30e5) < 0.1e5)])
    assert k30 == ev["k"] + 1                 # the first row after the step it was applied at
    assert (k30 - ev["k_requested"]) * 5e-4 <= 0.050, (ev["k_requested"], ev["k"], k30)
    events = [json.loads(x) for x in (rec / "events.jsonl").read_text().splitlines()]
    assert [e.get("name") or e["op"] for e in events] == ["supply_pressure", "mass", "fault_on", "fault_off"]
    assert events[1]["value"] == 120.0 and events[2]["fault"]["line"] == 2
    burst = (log["k"] > events[2]["k"]) & (log["k"] <= events[3]["k"])
    assert np.all(log["faults"][burst] == 1) and np.all(log["faults"][log["k"] > events[3]["k"]] == 0)
    cmp = json.loads((rec / "comparison.json").read_text())
    assert cmp["replay_xp_max_abs"] == 0.0 and cmp["replay_p2_max_abs"] == 0.0


def test_circuit_panel_in_chromium(browser, tmp_path):
    """A circuit on the panel (``hydrohil panel examples/circuits/motor_speed/scenario.toml``) as a user sees it:
    the page draws the circuit's own plots (its loop's speed in rpm first) and mode strips, an input is held from
    its form (in its display unit) and given back to its drive, a parameter is changed from the list, the
    scenario's leak is switched on and off from its faults box, stop ends the session."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select
    from conftest import EXAMPLES
    motor = EXAMPLES / "circuits" / "motor_speed"
    scen = tmp_path / "motor.toml"
    scen.write_text((motor / "scenario.toml").read_text().replace('circuit = "circuit.toml"',
                                                                   f'circuit = "{motor / "circuit.toml"}"')
                    + '[[faults]]\ntype = "leak"\nnode = "a"\narea = "2 mm2"\nstart = 100.0\n')
    p = PanelProcess(tmp_path / "panel", scen)
    try:
        browser.get(p.url)
        el = lambda i: browser.find_element(By.ID, i)   # noqa: E731
        f0 = wait_until(lambda: int(el("frames").text), "a first frame")
        assert el("c-loop").get_attribute("data-title") == "motor.w and its reference [rpm]"
        assert el("c-modes").is_displayed() and not el("faults-box").is_displayed()
        p.wait_steps(p.api("api/state")["counters"]["steps"] + 200)
        a = png_pixels(el("c-loop").screenshot_as_png)
        wait_until(lambda: int(el("frames").text) >= f0 + 25, "25 more frames")
        p.wait_steps(p.api("api/state")["counters"]["steps"] + 200)
        b = png_pixels(el("c-loop").screenshot_as_png)
        assert a.shape == b.shape and np.mean(np.any(a != b, axis=-1)) > 1e-3
        inp = el("in-motor.load_torque")
        inp.click()
        inp.send_keys("6")
        el("hold-motor.load_torque").click()
        ev = wait_until(lambda: [e for e in p.api("api/state")["events"] if e.get("op") == "input"],
                        "the held input applied", on_fail=lambda: el("message").text)[0]
        assert ev["name"] == "motor.load_torque" and ev["value"] == 6.0
        Select(el("param-name")).select_by_visible_text("motor.inertia")
        assert el("param-label").text == "[kg.m2]"
        box = el("param-value")
        box.clear()
        box.send_keys("0.03")
        el("param-set").click()
        wait_until(lambda: p.api("api/state")["values"].get("motor.inertia") == 0.03, "the inertia changed",
                   on_fail=lambda: el("message").text)
        el("free-motor.load_torque").click()
        wait_until(lambda: p.api("api/state")["held"] == {}, "the input back on its drive")
        shown = lambda: browser.execute_script(          # noqa: E731 (the list is redrawn when a fault switches)
            "return document.getElementById('cf-state-0').textContent")
        assert el("circuit-faults-box").is_displayed() and shown() == "scheduled"
        el("cf-on-0").click()
        wait_until(lambda: shown() == "on", "the leak switched on", on_fail=lambda: el("message").text)
        browser.save_screenshot(str(tmp_path / "circuit_panel.png"))
        el("cf-off-0").click()
        wait_until(lambda: shown() == "off", "the leak switched off", on_fail=lambda: el("message").text)
        el("stop").click()
        wait_until(lambda: el("status").text == "ended", "the session to end")
        ended = p.api("api/state")["ended"]
        assert ended["exit_codes"]["plant"] in (0, 3) and ended["exit_codes"]["controller"] == 0     # 3: INVALID
    finally:
        p.close()
    events = [json.loads(x) for x in (p.session / "events.jsonl").read_text().splitlines()]
    assert [(e["op"], e.get("name"), e.get("value")) for e in events[:3]] == [("input", "motor.load_torque", 6.0),
                                                                            ("set", "motor.inertia", 0.03),
                                                                            ("input", "motor.load_torque", None)]
    assert [(e["op"], e["slot"], e["on"], e["inputs"]) for e in events[3:]] == [
        ("fault", 0, True, {"leak_a.opening": 1.0}), ("fault", 0, False, {"leak_a.opening": 0.0})]
