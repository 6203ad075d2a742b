#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""terracl studio in a real browser: Debian's chromium, headless (no display), driven by
python3-selenium through chromium-driver with real mouse events. Draws a crest (the terrain
previews during the drag), zooms in with the wheel (the window shows every cell), pans with the
right button, grabs the crest and drags a vertex (an update of the operation), undoes it, checks
that bad gestures (a vertex off the map, a zero-length stroke) get a message and change nothing,
paints a brush, adds amplify, drainage, layered rock and a lake, saves the script and exports
from the Export dialog with masks; `terracl edit` replays the saved script and its output must
equal the studio's export bit for bit.

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
from selenium.webdriver.common.actions.wheel_input import ScrollOrigin

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


def page(driver, js):
    return driver.execute_script("return " + js)


def version(driver):
    return page(driver, "document.body.dataset.version")


def status_text(driver):
    return driver.find_element(By.ID, "status").text


def wheel(driver, canvas, dx, dy, notches, delta=-200):
    for _ in range(notches):
        ActionChains(driver).scroll_from_origin(ScrollOrigin.from_element(canvas, dx, dy), 0, delta).perform()


def drag_path(driver, canvas, x, y, moves, pause=0.04, release=True):
    """Left-button drag from (x, y) (offsets from the canvas centre) by each (dx, dy) of `moves`."""
    chain = ActionChains(driver).move_to_element_with_offset(canvas, x, y).click_and_hold()
    for dx, dy in moves:
        chain.move_by_offset(dx, dy).pause(pause)
    if release:
        chain.release()
    chain.perform()


def check_overview(driver, url, when):
    """The page's overview terrain equals the server's live terrain sampled the same way."""
    ov = page(driver, "window.__terraclOverview()")
    with api_get(url + f"api/terrain.f32?step={ov['step']}") as r:
        z = np.frombuffer(r.read(), dtype=np.float32)
    check(np.array_equal(np.array(ov["z"], dtype=np.float32), z), f"the page's terrain is the server's {when}")


def shot(driver, shots, name):
    if shots:
        time.sleep(0.4)
        driver.save_screenshot(os.path.join(shots, name))


def main():
    cli = sys.argv[1]
    shots = sys.argv[sys.argv.index("--screenshots") + 1] if "--screenshots" in sys.argv else None
    if shots:
        os.makedirs(shots, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="terracl-browser-")
    ws = os.path.join(tmp, "ws")
    studio, url = start_studio(cli, ws)
    shutil.copy(EXEMPLAR_SRC, os.path.join(ws, EXEMPLAR))
    opts = webdriver.ChromeOptions()
    # Chromium as it runs on a machine without a GPU: software compositing, WebGL on SwiftShader.
    # (Forcing all of its GL onto SwiftShader, --use-gl=angle --use-angle=swiftshader, composites
    # every frame through the emulated GPU: 8x the CPU per frame, taken from the server's cores.)
    for a in ["--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1700,860",
              "--enable-unsafe-swiftshader"]:
        opts.add_argument(a)
    opts.binary_location = "/usr/bin/chromium"
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
    try:
        driver.get(url)
        v0 = wait_version(driver, None)
        lit, flat_std = driver.execute_script(CANVAS_STATS)
        check(lit > 0, f"the map canvas is drawn ({lit} lit pixels)")
        canvas = driver.find_element(By.ID, "map")

        # A crest drawn with the mouse: the terrain previews during the drag, then the stroke posts.
        driver.find_element(By.CSS_SELECTOR, "#tool option[value=crest]").click()
        drag_path(driver, canvas, -220, 60, [(20, -6 if i < 12 else 4) for i in range(1, 23)], release=False)
        time.sleep(0.5)
        frames = page(driver, "window.__terracl.previewFrames")
        check(frames >= 3, f"the terrain previewed during the drag ({frames} frames)")
        shot(driver, shots, "studio_drawing.png")
        ActionChains(driver).release().perform()
        v1 = wait_version(driver, v0)
        st = get_json(url + "api/state")
        check(len(st["operations"]) == 1 and st["operations"][0]["op"] == "crest", "the stroke posted a crest operation")
        crest = st["operations"][0]
        check(len(crest["points"]) >= 2, f"the crest has {len(crest['points'])} vertices")
        with api_get(url + "api/terrain.f32") as r:
            z = np.frombuffer(r.read(), dtype=np.float32)
        check("elevation" not in crest, f"the crest is placed relative to the ground ({crest})")
        check(float(z.max() - z.min()) > 10.0 and float(z.min()) > -1.0,
              f"the crest rose above the plain and dug nothing (min {z.min():.2f} m, max {z.max():.2f} m)")
        check_overview(driver, url, "after the stroke (patched where the solve moved cells)")
        lit, std = driver.execute_script(CANVAS_STATS)
        check(std > flat_std + 5, f"the map shows the crest (pixel std {flat_std:.1f} -> {std:.1f})")
        has3d = driver.execute_script("return !!document.querySelector('#view3d canvas')")
        print("3D view:", "WebGL canvas present" if has3d else "no WebGL in this browser")

        # Zoom in on the crest with the wheel: the map fetches the window on screen, cell for cell.
        wheel(driver, canvas, 0, 40, 5)
        time.sleep(1.0)
        zoom = float(driver.find_element(By.ID, "zoom").text.split()[0])
        check(zoom > 4, f"the wheel zoomed in ({zoom} px per cell)")
        ActionChains(driver).move_to_element_with_offset(canvas, 5, 45).perform()
        det = page(driver, "window.__terracl.detail")
        check(det is not None and det["step"] == 1, f"the zoomed-in map shows every cell of its window ({det})")
        m = re.match(r"^(-?[\d.]+), (-?[\d.]+) m: (-?[\d.]+) m$", driver.find_element(By.ID, "readout").text)
        check(m is not None, "the readout shows x, y and z under the cursor when zoomed in")
        shot(driver, shots, "studio_zoomed.png")
        # Pan with the right button: the same point of the terrain moves with the mouse.
        a = page(driver, "window.__terraclCanvas(1000, 1000)")
        ActionChains(driver).move_to_element_with_offset(canvas, 0, 0).perform()
        actions = ActionChains(driver)
        actions.w3c_actions.pointer_action.move_to(canvas, 0, 0).pointer_down(button=2)
        for _ in range(5):
            actions.w3c_actions.pointer_action.move_by(20, 10)
        actions.w3c_actions.pointer_action.pointer_up(button=2)
        actions.perform()
        b = page(driver, "window.__terraclCanvas(1000, 1000)")
        check(abs(b[0] - a[0] - 100) < 2 and abs(b[1] - a[1] - 50) < 2, f"the right-button drag panned the map ({a} -> {b})")
        driver.find_element(By.ID, "fit").click()
        time.sleep(0.3)

        # Grab the crest: select it, drag its last vertex; the change is an update of the operation.
        Select(driver.find_element(By.ID, "tool")).select_by_value("select")
        end = crest["points"][-1]
        ex, ey = page(driver, f"window.__terraclCanvas({end[0]}, {end[1]})")
        ActionChains(driver).move_to_element_with_offset(canvas, ex - 320, ey - 320).click().perform()
        time.sleep(0.3)
        f0 = page(driver, "window.__terracl.previewFrames")
        drag_path(driver, canvas, ex - 320, ey - 320, [(0, 10)] * 8, release=False)
        time.sleep(0.4)
        check(page(driver, "window.__terracl.previewFrames") > f0, "dragging the vertex previews the terrain")
        shot(driver, shots, "studio_vertex_drag.png")
        ActionChains(driver).release().perform()
        v2 = wait_version(driver, v1)
        moved = get_json(url + "api/state")["operations"]
        check(len(moved) == 1 and moved[0]["points"][-1][1] > end[1] + 200 and moved[0]["points"][0] == crest["points"][0],
              f"the drag moved the last vertex south ({end} -> {moved[0]['points'][-1]})")
        driver.find_element(By.ID, "undo").click()
        v3 = wait_version(driver, v2)
        check(get_json(url + "api/state")["operations"][0] == crest, "undo put the vertex back")

        # Double-click the first segment: a vertex is inserted there; Delete over it removes it.
        (ax, ay), (bx, by) = crest["points"][0], crest["points"][1]
        mx, my = page(driver, f"window.__terraclCanvas({(ax + bx) / 2}, {(ay + by) / 2})")
        ActionChains(driver).move_to_element_with_offset(canvas, mx - 320, my - 320).click().perform()
        ActionChains(driver).move_to_element_with_offset(canvas, mx - 320, my - 320).double_click().perform()
        v3b = wait_version(driver, v3)
        pts = get_json(url + "api/state")["operations"][0]["points"]
        check(len(pts) == len(crest["points"]) + 1, f"a double-click on a segment inserted a vertex ({len(crest['points'])} -> {len(pts)})")
        nx, ny = page(driver, f"window.__terraclCanvas({pts[1][0]}, {pts[1][1]})")
        ActionChains(driver).move_to_element_with_offset(canvas, nx - 320, ny - 320).perform()
        ActionChains(driver).send_keys(Keys.DELETE).perform()
        v3 = wait_version(driver, v3b)
        check(get_json(url + "api/state")["operations"][0]["points"] == crest["points"], "Delete over the vertex removed it")

        # Bad gestures get a message and change nothing: a vertex dragged off the map, a click with
        # a curve tool (a zero-length stroke).
        ex, ey = page(driver, f"window.__terraclCanvas({end[0]}, {end[1]})")
        ActionChains(driver).move_to_element_with_offset(canvas, ex - 320, ey - 320).click().perform()
        drag_path(driver, canvas, ex - 320, ey - 320, [(60, 0)] * 8)
        time.sleep(0.5)
        check("left the map" in status_text(driver), f"a vertex dragged off the map is refused with a message ({status_text(driver)!r})")
        Select(driver.find_element(By.ID, "tool")).select_by_value("crest")
        ActionChains(driver).move_to_element_with_offset(canvas, 0, 0).click().perform()
        time.sleep(0.3)
        check("too short" in status_text(driver), f"a zero-length stroke gets a message ({status_text(driver)!r})")
        check(version(driver) == v3 and get_json(url + "api/state")["operations"] == [crest], "and the session is unchanged")

        # A painted brush: one noise operation along the whole drag.
        Select(driver.find_element(By.ID, "tool")).select_by_value("noise")
        drag_path(driver, canvas, -150, -180, [(25, 8)] * 12)
        v4 = wait_version(driver, v3)
        noise = get_json(url + "api/state")["operations"][-1]
        check(noise["op"] == "noise" and len(noise.get("path", [])) >= 2 and noise["radius"] > 0,
              f"the drag painted one noise operation along a path ({noise})")
        check_overview(driver, url, "after the painted brush")
        shot(driver, shots, "studio_painted.png")

        # Amplify a dragged region with an exemplar DEM typed into the tool's parameters.
        Select(driver.find_element(By.ID, "tool")).select_by_value("amplify")
        ex = driver.find_element(By.ID, "p_exemplar")
        ex.clear()
        ex.send_keys(EXEMPLAR + Keys.TAB)
        v = version(driver)
        ActionChains(driver).move_to_element_with_offset(canvas, -90, -30).click_and_hold() \
            .move_by_offset(90, 30).move_by_offset(90, 30).release().perform()
        wait_version(driver, v)
        ops = get_json(url + "api/state")["operations"]
        check(len(ops) == 3 and ops[2]["op"] == "amplify" and ops[2]["exemplar"] == EXEMPLAR and "radius" in ops[2],
              f"the drag posted an amplify operation of a region ({ops[-1]})")

        # Drainage over the whole map (a click) and layered rock on the crest (a click).
        for tool, dx, dy in (("drainage", 0, 0), ("strata", 0, 20)):
            if tool == "strata":  # the terrain the strata's top is read from
                with api_get(url + "api/terrain.f32") as r:
                    z = np.frombuffer(r.read(), dtype=np.float32)
            Select(driver.find_element(By.ID, "tool")).select_by_value(tool)
            v = version(driver)
            ActionChains(driver).move_to_element_with_offset(canvas, dx, dy).click().perform()
            wait_version(driver, v)
        ops = get_json(url + "api/state")["operations"]
        check(len(ops) == 5 and ops[3]["op"] == "drainage" and "radius" not in ops[3],
              f"the click posted a drainage operation of the whole map ({ops[3:]})")
        check(ops[4]["op"] == "strata" and 10.0 < ops[4]["top"] <= float(z.max()) + 0.5,
              f"the click posted a strata operation whose top is the highest cell in its disc ({ops[4:]})")

        # A lake 15 m above the elevation the readout shows, seeded by a click there.
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
        v = version(driver)
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
        time.sleep(0.3)
        blue1 = driver.execute_script(blue)
        check(blue1 > blue0 + 100, f"the map shows the water in blue ({blue0} -> {blue1} blue pixels)")

        # The gallery's cliff and canyon scripts set a cliff's plateau `back` and a canyon's side-valley
        # `branches`: both are fields of those tools, posted as typed (empty: the operation's default).
        for tool, field, value in (("cliff", "back", "900"), ("canyon", "branches", "0.5")):
            Select(driver.find_element(By.ID, "tool")).select_by_value(tool)
            box = driver.find_element(By.ID, "p_" + field)
            box.clear()
            box.send_keys(value + Keys.TAB)
            v = version(driver)
            drag_path(driver, canvas, -250, -250, [(20, 6)] * 10)
            wait_version(driver, v)
            st = get_json(url + "api/state")
            want = float(value)
            if field == "back" and st["units"] == "cells":
                want = round(want / st["cell_x"], 1)
            got = st["operations"][-1]
            check(got["op"] == tool and abs(float(got.get(field, -1)) - want) < 0.06,
                  f"the {tool} tool posts its {field} field ({got})")

        # Save the script; export from the dialog with masks.
        name = driver.find_element(By.ID, "file")
        name.clear()
        name.send_keys("sketch.json")
        driver.find_element(By.ID, "save").click()
        driver.find_element(By.ID, "export").click()
        xn = driver.find_element(By.ID, "x_name")
        xn.clear()
        xn.send_keys("sketch")
        Select(driver.find_element(By.ID, "x_format")).select_by_value("tif")
        for mask in ("slope", "flow", "water"):
            driver.find_element(By.ID, "x_mask_" + mask).click()
        check(not driver.find_element(By.ID, "x_mask_wear").is_enabled(), "the wear mask is offered only with an erosion layer")
        shot(driver, shots, "studio_export.png")
        driver.find_element(By.ID, "x_go").click()
        script, exported = os.path.join(ws, "sketch.json"), os.path.join(ws, "sketch.tif")
        t0 = time.time()
        while not ("wrote" in driver.find_element(By.ID, "x_status").text or "error" in driver.find_element(By.ID, "x_status").text) \
                and time.time() - t0 < 120:
            time.sleep(0.1)
        xs = driver.find_element(By.ID, "x_status").text
        check(xs.startswith("wrote") and os.path.exists(script) and os.path.exists(exported), f"the page saved the script and exported ({xs})")
        masks = [f for f in os.listdir(ws) if f.startswith("sketch") and f.endswith(".png")]
        check(len(masks) >= 3, f"the export wrote the three masks ({sorted(masks)})")
        driver.find_element(By.ID, "x_close").click()
        out = os.path.join(tmp, "cli.tif")
        water = os.path.join(tmp, "water.tif")
        r = subprocess.run([cli, "-q", "edit", "--script", script, "-o", out, "--water", water], capture_output=True, text=True)
        check(r.returncode == 0, "terracl edit replays the saved script " + r.stderr)
        a = gdal.Open(exported).ReadAsArray()
        b = gdal.Open(out).ReadAsArray()
        check(a.shape == b.shape and np.array_equal(a, b), "the studio's export equals terracl edit's output bit for bit")
        check(int((gdal.Open(water).ReadAsArray() > 0).sum()) > 0, "the replay writes the lake's water (--water)")

        if shots:  # a mountain range being eroded live
            Select(driver.find_element(By.ID, "tool")).select_by_value("mountain_range")
            v = version(driver)
            drag_path(driver, canvas, -200, -150, [(12, 20)] * 15)
            wait_version(driver, v)
            driver.find_element(By.ID, "erode_all").click()
            time.sleep(8)
            driver.find_element(By.ID, "erode_stop").click()
            time.sleep(1)
            driver.execute_script("window.scrollTo(0, 0)")
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
