#!/usr/bin/python3
"""terracl studio in a real browser: Debian's chromium, headless (no display), driven by
python3-selenium through chromium-driver. Loads the page, draws a crest with mouse events, checks
that the terrain changed (API state and the map canvas), undoes and redoes it, adds a lake at the
elevation the cursor readout shows (blue on the map), saves the script from
the page and replays it with `terracl edit`: the studio's export and the CLI's output must be equal
bit for bit.

usage: test_studio_browser.py TERRACL_CLI [--screenshots DIR]
"""
import json
import os
import re
import subprocess
import sys
import tempfile
import time
import secrets
import shutil
import urllib.request

import numpy as np
from osgeo import gdal
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import Select

# Operations read files inside the workspace only: the exemplar is copied there.
EXEMPLAR_SRC = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "data", "crops", "presidential_128x96.tif"))
EXEMPLAR = "presidential_128x96.tif"

gdal.UseExceptions()


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


def check(cond, msg):
    if not cond:
        fail(msg)
    print("ok:", msg)


# The studio's API wants its token (docs/studio.md, "Threat model"); the test fixes it.
TOKEN = secrets.token_hex(16)


def api_get(url):
    return urllib.request.urlopen(urllib.request.Request(url, headers={"X-Terracl-Token": TOKEN}), timeout=60)


def get_json(url):
    with api_get(url) as r:
        return json.load(r)


def start_studio(cli, ws):
    p = subprocess.Popen([cli, "-q", "studio", "flat:257x257@10", "--port", "0", "--workspace", ws],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                         env={**os.environ, "TERRACL_STUDIO_TOKEN": TOKEN})
    t0 = time.time()
    while time.time() - t0 < 60:
        line = p.stdout.readline()
        if not line:
            break
        m = re.search(r"(http://127\.0\.0\.1:\d+/)", line)
        if m:
            return p, m.group(1)
    p.kill()
    fail("the studio did not print its URL: " + (p.stdout.read() or ""))


def wait_version(driver, old, timeout=60):
    t0 = time.time()
    while time.time() - t0 < timeout:
        v = driver.execute_script("return document.body.dataset.version")
        if v is not None and v != old:
            return v
        time.sleep(0.05)
    fail(f"the page did not refresh (version stayed {old})")


CANVAS_STATS = """
const c = document.getElementById('map'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
let n = 0, s = 0, s2 = 0;
for (let i = 0; i < d.length; i += 4) { const v = d[i] + d[i + 1] + d[i + 2]; if (v > 0) n++; s += v; s2 += v * v; }
const m = s / (d.length / 4);
return [n, Math.sqrt(Math.max(0, s2 / (d.length / 4) - m * m))];
"""


def main():
    cli = sys.argv[1]
    shots = sys.argv[sys.argv.index("--screenshots") + 1] if "--screenshots" in sys.argv else None
    tmp = tempfile.mkdtemp(prefix="terracl-browser-")
    ws = os.path.join(tmp, "ws")
    studio, url = start_studio(cli, ws)
    shutil.copy(EXEMPLAR_SRC, os.path.join(ws, EXEMPLAR))
    opts = webdriver.ChromeOptions()
    for a in ["--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1700,860",
              "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]:
        opts.add_argument(a)
    opts.binary_location = "/usr/bin/chromium"
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
    try:
        driver.get(url)
        v0 = wait_version(driver, None)
        lit, flat_std = driver.execute_script(CANVAS_STATS)
        check(lit > 0, f"the map canvas is drawn ({lit} lit pixels)")

        # Draw a crest across the map with the mouse (offsets from the canvas centre).
        canvas = driver.find_element(By.ID, "map")
        driver.find_element(By.CSS_SELECTOR, "#tool option[value=crest]").click()
        chain = ActionChains(driver).move_to_element_with_offset(canvas, -220, 60).click_and_hold()
        for i in range(1, 23):
            chain.move_by_offset(20, -6 if i < 12 else 4)
        chain.release().perform()
        v1 = wait_version(driver, v0)
        st = get_json(url + "api/state")
        check(len(st["operations"]) == 1 and st["operations"][0]["op"] == "crest", "the stroke posted a crest operation")
        check(len(st["operations"][0]["points"]) >= 2, f"the crest has {len(st['operations'][0]['points'])} vertices")
        with api_get(url + "api/terrain.f32") as r:
            z = np.frombuffer(r.read(), dtype=np.float32)
        op0 = st["operations"][0]
        check("elevation" not in op0, f"the crest is placed relative to the ground ({op0})")
        check(float(z.max() - z.min()) > 10.0 and float(z.min()) > -1.0,
              f"the crest rose above the plain and dug nothing (min {z.min():.2f} m, max {z.max():.2f} m)")
        lit, std = driver.execute_script(CANVAS_STATS)
        check(std > flat_std + 5, f"the map shows the crest (pixel std {flat_std:.1f} -> {std:.1f})")
        has3d = driver.execute_script("return !!document.querySelector('#view3d canvas')")
        print("3D view:", "WebGL canvas present" if has3d else "no WebGL in this browser")
        if shots:
            os.makedirs(shots, exist_ok=True)
            driver.find_element(By.ID, "contours").click()
            v1 = wait_version(driver, None)
            time.sleep(1.0)
            driver.save_screenshot(os.path.join(shots, "studio.png"))

        driver.find_element(By.ID, "undo").click()
        v2 = wait_version(driver, v1)
        st = get_json(url + "api/state")
        check(len(st["operations"]) == 0 and st["can_redo"], "undo removed the crest")
        driver.find_element(By.ID, "redo").click()
        wait_version(driver, v2)
        check(len(get_json(url + "api/state")["operations"]) == 1, "redo restored it")

        # Amplify a dragged region with an exemplar DEM typed into the tool's parameters.
        Select(driver.find_element(By.ID, "tool")).select_by_value("amplify")
        ex = driver.find_element(By.ID, "p_exemplar")
        ex.clear()
        ex.send_keys(EXEMPLAR + Keys.TAB)
        v = driver.execute_script("return document.body.dataset.version")
        ActionChains(driver).move_to_element_with_offset(canvas, -90, -30).click_and_hold() \
            .move_by_offset(90, 30).move_by_offset(90, 30).release().perform()
        wait_version(driver, v)
        st = get_json(url + "api/state")
        ops = st["operations"]
        check(len(ops) == 2 and ops[1]["op"] == "amplify" and ops[1]["exemplar"] == EXEMPLAR and "radius" in ops[1],
              f"the drag posted an amplify operation of a region ({ops[-1]})")

        # Drainage over the whole map (a click) and layered rock on the crest (a click): their
        # operations go into the saved script, so the replay below covers them too.
        for tool, dx, dy in (("drainage", 0, 0), ("strata", 0, 20)):
            Select(driver.find_element(By.ID, "tool")).select_by_value(tool)
            v = driver.execute_script("return document.body.dataset.version")
            ActionChains(driver).move_to_element_with_offset(canvas, dx, dy).click().perform()
            wait_version(driver, v)
        ops = get_json(url + "api/state")["operations"]
        check(len(ops) == 4 and ops[2]["op"] == "drainage" and "radius" not in ops[2],
              f"the click posted a drainage operation of the whole map ({ops[2:]})")
        check(ops[3]["op"] == "strata" and 10.0 < ops[3]["top"] <= float(z.max()) + 0.5,
              f"the click posted a strata operation whose top is the highest cell in its disc ({ops[3:]})")

        # A lake: the readout names the terrain under the cursor, and a lake 15 m above it, seeded
        # by a click there, fills the water around the click and tints the map blue.
        blue = "const d = document.getElementById('map').getContext('2d').getImageData(0, 0, 640, 640).data; " \
               "let n = 0; for (let i = 0; i < d.length; i += 4) if (d[i + 2] > d[i] + 40 && d[i + 2] > d[i + 1]) n++; return n;"
        blue0 = driver.execute_script(blue)
        Select(driver.find_element(By.ID, "tool")).select_by_value("lake")
        ActionChains(driver).move_to_element_with_offset(canvas, 0, 200).perform()
        txt = driver.find_element(By.ID, "readout").text
        m = re.match(r"^(-?[\d.]+), (-?[\d.]+) m: (-?[\d.]+) m$", txt)
        check(m is not None, f"the readout shows 'x, y: z m' under the cursor ({txt!r})")
        level = driver.find_element(By.ID, "p_level")
        level.clear()
        level.send_keys(f"{float(m.group(3)) + 15:.1f}" + Keys.TAB)
        v = driver.execute_script("return document.body.dataset.version")
        ActionChains(driver).move_to_element_with_offset(canvas, 0, 200).click().perform()
        wait_version(driver, v)
        st = get_json(url + "api/state")
        lake = st["operations"][-1]
        check(lake["op"] == "lake" and abs(lake["level"] - float(m.group(3)) - 15) < 0.11,
              f"the click posted a lake 15 m above the readout's elevation ({lake})")
        check(len(st["lakes"]) == 1 and st["lakes"][0]["cells"] > 0, f"the lake holds water ({st['lakes']})")
        with api_get(url + "api/water.f32") as r:
            w = np.frombuffer(r.read(), dtype=np.float32)
        check(int((w > 0).sum()) == st["lakes"][0]["cells"], "the water layer covers the lake's cells")
        blue1 = driver.execute_script(blue)
        check(blue1 > blue0 + 100, f"the map shows the water in blue ({blue0} -> {blue1} blue pixels)")

        name = driver.find_element(By.ID, "file")
        name.clear()
        name.send_keys("sketch.json")
        driver.find_element(By.ID, "save").click()
        driver.find_element(By.ID, "export").click()
        script, exported = os.path.join(ws, "sketch.json"), os.path.join(ws, "sketch.tif")
        t0 = time.time()
        while not (os.path.exists(script) and os.path.exists(exported)) and time.time() - t0 < 60:
            time.sleep(0.1)
        check(os.path.exists(script) and os.path.exists(exported), "the page saved the script and exported the terrain")
        out = os.path.join(tmp, "cli.tif")
        water = os.path.join(tmp, "water.tif")
        r = subprocess.run([cli, "-q", "edit", "--script", script, "-o", out, "--water", water], capture_output=True, text=True)
        check(r.returncode == 0, "terracl edit replays the saved script " + r.stderr)
        a = gdal.Open(exported).ReadAsArray()
        b = gdal.Open(out).ReadAsArray()
        check(a.shape == b.shape and np.array_equal(a, b), "the studio's export equals terracl edit's output bit for bit")
        check(int((gdal.Open(water).ReadAsArray() > 0).sum()) > 0, "the replay writes the lake's water (--water)")

        if shots:  # a second picture: a mountain range being eroded live
            Select(driver.find_element(By.ID, "tool")).select_by_value("mountain_range")
            v = driver.execute_script("return document.body.dataset.version")
            chain = ActionChains(driver).move_to_element_with_offset(canvas, -200, -150).click_and_hold()
            for i in range(1, 16):
                chain.move_by_offset(12, 20)
            chain.release().perform()
            wait_version(driver, v)
            driver.find_element(By.ID, "erode_all").click()
            time.sleep(8)
            driver.find_element(By.ID, "erode_stop").click()
            time.sleep(1)
            driver.save_screenshot(os.path.join(shots, "studio_erosion.png"))
            driver.find_element(By.ID, "erode_cancel").click()

        errors = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        check(not errors, f"no errors in the browser console {errors}")
    finally:
        driver.quit()
        studio.terminate()
        studio.wait(10)
    print("studio browser test: all checks passed")


if __name__ == "__main__":
    main()
