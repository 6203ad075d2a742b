#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Latency of terracl studio as an artist feels it: headless chromium (Debian's chromium and
chromium-driver through python3-selenium) driving the page with real mouse events, the browser
sharing the machine with the server.

  scripts/bench-studio-browser.py [build/bin/terracl] [--size 1025] [--strokes 30] [--changes 10]

Starts `terracl studio flat:NxN@10` and measures, from the page's own clock (performance.now()
at the mouse release -> the requestAnimationFrame after the new terrain is drawn):
  * stroke: a crest drawn with the mouse -> painted map, median and p95 of --strokes strokes
    (the first one separately: kernels compiled at start-up, not on the first stroke);
  * drag: preview frames per second while a stroke is being drawn (POST /api/preview);
  * after-erosion: a vertex of a crest that lies after an erosion layer dragged -> painted map
    (the session replays from its snapshot after the erosion);
The load average (1 min) is printed before and after.
"""
import os
import random
import re
import secrets
import statistics
import subprocess
import sys
import time
import json
import urllib.request

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

TOKEN = secrets.token_hex(16)


def arg(name, default):
    return type(default)(sys.argv[sys.argv.index(name) + 1]) if name in sys.argv else default


def pct(v, q):
    v = sorted(v)
    return v[min(len(v) - 1, int(round(q * (len(v) - 1))))]


def request(base, method, path, body=None):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(base + path, data=data, method=method,
                                 headers={"Content-Type": "application/json", "X-Terracl-Token": TOKEN})
    with urllib.request.urlopen(req, timeout=600) as r:
        return json.load(r)


def main():
    cli = sys.argv[1] if len(sys.argv) > 1 and not sys.argv[1].startswith("--") else "build/bin/terracl"
    n, strokes, changes = arg("--size", 1025), arg("--strokes", 30), arg("--changes", 10)
    p = subprocess.Popen([cli, "-q", "studio", f"flat:{n}x{n}@10", "--port", "0", "--workspace", "/tmp/terracl-bench-browser"],
                         stdout=subprocess.PIPE, text=True, env={**os.environ, "TERRACL_STUDIO_TOKEN": TOKEN})
    url = None
    for _ in range(50):
        m = re.search(r"(http://127\.0\.0\.1:\d+/)", p.stdout.readline())
        if m:
            url = m.group(1)
            break
    if not url:
        raise SystemExit("the studio did not start")
    opts = webdriver.ChromeOptions()
    # Chromium as it runs on a machine without a GPU: software compositing, WebGL on SwiftShader.
    # (Forcing all of its GL onto SwiftShader, --use-gl=angle --use-angle=swiftshader, composites
    # every frame through the emulated GPU: 8x the CPU per frame, taken from the server's cores.)
    for a in ["--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1700,860",
              "--enable-unsafe-swiftshader"]:
        opts.add_argument(a)
    opts.binary_location = "/usr/bin/chromium"
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
    rng = random.Random(1)
    js = lambda s: driver.execute_script("return " + s)

    def wait_version(old):
        t0 = time.time()
        while time.time() - t0 < 120:
            v = js("document.body.dataset.version")
            if v is not None and v != old:
                return v
            time.sleep(0.01)
        tool = js("document.getElementById('tool').value")
        raise SystemExit(f"the page did not refresh from version {old} (status: {driver.find_element(By.ID, 'status').text}; tool {tool})")

    def wait_idle():  # the page's own work after a change (the zoomed-in window, 3D) settles
        time.sleep(0.4)

    def last_latency():
        return js("window.__terracl.latency[window.__terracl.latency.length - 1]")

    def crest(x, y, moves, pause=0.0):
        # duration: each pointer move takes 10 ms (Selenium's default, 250 ms, paces a drag at 4 Hz)
        chain = ActionChains(driver, duration=10).move_to_element_with_offset(canvas, x, y).click_and_hold()
        for dx, dy in moves:
            chain.move_by_offset(dx, dy)
            if pause:
                chain.pause(pause)
        chain.release().perform()

    try:
        load0 = os.getloadavg()[0]
        driver.get(url)
        v = wait_version(None)
        # The start-up compile runs in the background; the first stroke is measured like the rest.
        t0 = time.time()
        while js("document.getElementById('status').textContent").startswith("compiling") and time.time() - t0 < 120:
            time.sleep(0.2)
        canvas = driver.find_element(By.ID, "map")
        Select(driver.find_element(By.ID, "tool")).select_by_value("crest")
        lat = []
        for i in range(strokes):
            x, y = rng.randint(-250, 100), rng.randint(-250, 250)
            crest(x, y, [(15, rng.randint(-6, 6)) for _ in range(8)])
            v = wait_version(v)
            wait_idle()
            lat.append(last_latency())
        # Preview frames per second while drawing a slow stroke (4 s).
        f0, t0 = js("window.__terracl.previewFrames"), time.time()
        crest(-250, 250, [(2, -2)] * 200, pause=0.01)
        fps = (js("window.__terracl.previewFrames") - f0) / (time.time() - t0)
        v = wait_version(v)
        wait_idle()
        prev_ms = js("window.__terracl.previewMs")

        # A crest after an erosion layer: drag one of its vertices.
        def drag_vertex(index, dy):
            nonlocal v
            op = request(url, "GET", "api/state")["operations"][index]
            pt = op["points"][-1]
            Select(driver.find_element(By.ID, "tool")).select_by_value("select")
            layer = driver.find_elements(By.CSS_SELECTOR, "#layer_list li span")[index]
            layer.click()
            driver.execute_script("window.scrollTo(0, 0)")
            ex, ey = js(f"window.__terraclCanvas({pt[0]}, {pt[1]})")
            ActionChains(driver).move_to_element_with_offset(canvas, ex - 320, ey - 320).click_and_hold() \
                .move_by_offset(0, dy).move_by_offset(0, dy).release().perform()
            v = wait_version(v)
            wait_idle()
            return last_latency(), request(url, "GET", "api/state")["last"]

        request(url, "POST", "api/erosion/start", {"preset": "young_alpine"})
        for _ in range(12):
            urllib.request.urlopen(urllib.request.Request(url + "api/erosion/step?steps=5&max=16", method="POST",
                                                          headers={"X-Terracl-Token": TOKEN}), timeout=600).read()
        request(url, "POST", "api/erosion/commit", {})
        # the page picks the committed erosion up by its poll (within a second)
        server_v = str(request(url, "GET", "api/state")["version"])
        t0 = time.time()
        while js("document.body.dataset.version") != server_v and time.time() - t0 < 60:
            time.sleep(0.05)
        wait_idle()
        Select(driver.find_element(By.ID, "tool")).select_by_value("crest")
        v = js("document.body.dataset.version")
        crest(230, -290, [(10, 3)] * 6)  # a corner the random strokes do not reach
        v = wait_version(v)
        wait_idle()
        nops = len(request(url, "GET", "api/state")["operations"])
        after = []
        mode_after = None
        for i in range(changes):
            ms, last = drag_vertex(nops - 1, 6 if i % 2 == 0 else -6)
            after.append(ms)
            mode_after = last
        load1 = os.getloadavg()[0]
        print(f"studio in headless chromium, flat:{n}x{n}@10, {os.cpu_count()} cores, load {load0:.1f} -> {load1:.1f}")
        print(f"  stroke -> painted map: first {lat[0]:.0f} ms; median {statistics.median(lat):.0f} ms, "
              f"p95 {pct(lat, 0.95):.0f} ms (n = {len(lat)})")
        ph = js("window.__terracl.phases")[:len(lat)]
        med = lambda k: statistics.median(x[k] for x in ph)
        print(f"    of which: request {med('change'):.0f} ms (server {med('server'):.0f} ms), terrain fetch + shading {med('terrain'):.0f} ms, "
              f"to the painted frame {med('paint'):.0f} ms (medians)")
        sp = [x["serverPhases"] for x in ph]
        print("      server phases (medians, ms): " +
              ", ".join(f"{k} {statistics.median(x.get(k, 0) for x in sp):.1f}" for k in sp[0]))
        print(f"  drawing: {fps:.1f} preview frames/s (server {statistics.median(prev_ms):.0f} ms median per preview)")
        print(f"  vertex of a layer after an erosion -> painted map: median {statistics.median(after):.0f} ms, "
              f"p95 {pct(after, 0.95):.0f} ms (n = {len(after)}; last: {mode_after})")
    finally:
        driver.quit()
        p.terminate()
        p.wait(10)


if __name__ == "__main__":
    main()
