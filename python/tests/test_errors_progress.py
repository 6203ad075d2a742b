# SPDX-License-Identifier: Apache-2.0
"""terracl.Error / UsageError / Cancelled, progress callbacks and cancellation, the GIL, devices."""
import threading
import time

import numpy as np
import pytest

import terracl
from conftest import same_bits


def test_unknown_option_is_a_usage_error_naming_stage_and_options(dem):
    with pytest.raises(terracl.UsageError) as e:
        terracl.erode(dem, stpes=10)
    assert e.value.stage == "erode"
    assert "stpes" in e.value.message and "steps" in e.value.message
    assert isinstance(e.value, terracl.Error) and isinstance(e.value, ValueError)
    assert str(e.value).startswith("erode: ")


@pytest.mark.parametrize("kw, words", [
    (dict(steps=-3), ["/steps", "out of range"]),
    (dict(rain="3 km"), ["/rain", "km"]),
    (dict(boundary="leaky"), ["/boundary", "closed|open"]),
    (dict(steps="many"), ["/steps"]),
])
def test_bad_values_name_the_option(dem, kw, words):
    with pytest.raises(terracl.UsageError) as e:
        terracl.erode(dem, **kw)
    for w in words:
        assert w in e.value.message


def test_stage_errors_carry_the_stage(dem):
    bad = dem.copy()
    bad.z[2, 2] = np.inf
    with pytest.raises(terracl.Error) as e:
        terracl.extract(bad)
    assert e.value.stage == "extract" and "NaN" in e.value.message
    with pytest.raises(terracl.Error) as e:
        terracl.edit("flat:65x65@10", {"operations": [{"op": "crest", "points": [[1, 2]]}]})
    assert e.value.stage == "edit" and "/operations/0" in e.value.message
    with pytest.raises(terracl.UsageError, match="no stage named"):
        terracl.stage("smooth", dem)
    with pytest.raises(TypeError, match="/operations/0/points"):
        terracl.edit("flat:65x65@10", {"operations": [{"op": "crest", "points": object()}]})


def test_progress_callback_sees_increasing_fractions(dem):
    seen = []
    terracl.erode(dem, steps=40, progress=lambda f, m: seen.append((f, m)))
    assert len(seen) >= 2 and all(0 <= f <= 1 for f, _ in seen)
    assert [f for f, _ in seen] == sorted(f for f, _ in seen)


def test_false_from_the_callback_cancels(dem):
    calls = []

    def stop(f, m):
        calls.append(f)
        return len(calls) < 2
    with pytest.raises(terracl.Cancelled) as e:
        terracl.erode(dem, steps=400, progress=stop)
    assert e.value.stage == "erode" and len(calls) == 2
    assert e.value.__cause__ is None


def test_exception_in_the_callback_cancels_and_is_chained(dem):
    def boom(f, m):
        raise KeyError("user code failed")
    with pytest.raises(terracl.Cancelled) as e:
        terracl.reconstruct(terracl.extract(dem), progress=boom)
    assert isinstance(e.value.__cause__, KeyError)
    # Nothing is left behind: the next call runs normally.
    assert terracl.reconstruct(terracl.extract(dem)).width == dem.width


def test_gil_is_released_during_a_solve():
    """A second Python thread keeps running while a 1025^2 reconstruction runs in another."""
    rng = np.random.default_rng(3)
    g = terracl.GradientField(rng.standard_normal((1025, 1025)).astype(np.float32) * 0.1,
                              rng.standard_normal((1025, 1025)).astype(np.float32) * 0.1, cell_size=10)
    window = {}

    def solve():
        window["start"] = time.perf_counter()
        terracl.reconstruct(g, tolerance=1e-7)
        window["end"] = time.perf_counter()
    ticks = []
    t = threading.Thread(target=solve)
    t.start()
    while t.is_alive():
        ticks.append(time.perf_counter())
    t.join()
    span = window["end"] - window["start"]
    inner = [x for x in ticks if window["start"] + 0.2 * span < x < window["end"] - 0.2 * span]
    # With the GIL held through the solve this thread would not run at all in the middle 60 %.
    assert span > 0.05 and len(inner) > 1000, (span, len(inner))


def test_devices_and_selection(dem):
    devs = terracl.devices()
    assert devs and all(isinstance(d, terracl.DeviceInfo) for d in devs)
    assert terracl.select_device(0).index == 0
    assert terracl.device().name == devs[0].name
    name_part = devs[0].name.split("-")[0]
    assert terracl.device(name_part).index == devs[0].index
    a = terracl.erode(dem, steps=5, device=0)
    b = terracl.erode(dem, steps=5, device=name_part)
    assert same_bits(a.z, b.z)
    with pytest.raises(terracl.Error) as e:
        terracl.select_device("no-such-device-xyz")
    assert "no-such-device-xyz" in str(e.value)
    assert terracl.device().index == 0  # a refused spec does not change the selection
    with pytest.raises(terracl.Error):
        terracl.erode(dem, steps=5, device=len(devs) + 5)
    with pytest.raises(TypeError):
        terracl.erode(dem, steps=5, device=1.5)
    terracl.select_device(None)


def test_session_keeps_state_and_solves_warm(tmp_path):
    crest = {"units": "cells", "operations": [
        {"op": "crest", "points": [[20, 60], [100, 40]], "elevation": 400, "radius": 10, "height": 150}]}
    more = {"units": "cells", "operations": [
        {"op": "river", "points": [[10, 100], [110, 110]], "elevation": 20, "radius": 5}]}
    s = terracl.Session("flat:129x129@10")
    s.apply(crest)
    first = s.height()
    assert same_bits(first.z, terracl.edit("flat:129x129@10", crest).z)  # first apply == terracl edit
    s.apply(more)
    warm = s.solve(warm=True)
    cold = s.solve(warm=False)
    assert warm["converged"] and cold["converged"] and warm["cycles"] <= cold["cycles"]
    assert s.hard_cells > 0 and np.isfinite(s.hard_constraints()).sum() == s.hard_cells
    assert len(s.report()["operations"]) == 2
    with pytest.raises(terracl.Error) as e:
        s.apply({"operations": [{"op": "nope"}]})
    assert "/operations/0" in str(e.value)
    # Cancelling through the session's callback (called per operation), then going on.
    s.progress = lambda f, m: False
    with pytest.raises(terracl.Cancelled) as e:
        s.apply(more)
    assert e.value.stage == "edit"
    s.progress = None
    assert s.solve()["converged"]


def test_session_lake_is_a_water_layer_over_the_untouched_terrain():
    # A bowl whose lowest rim cell is on the grid's edge: the spill level is that cell's elevation.
    y, x = np.mgrid[0:33, 0:33]
    bowl = (((x - 16.2) ** 2 + (y - 15.8) ** 2) * 0.25).astype(np.float32)
    s = terracl.Session(bowl, cell_size=1)  # 1 m cells, said explicitly
    assert s.water() is None
    s.apply({"units": "cells", "operations": [{"op": "lake", "seed": [16, 16]}]})
    w = s.water()
    lake = s.lakes()[0]
    edge = min(bowl[0, :].min(), bowl[-1, :].min(), bowl[:, 0].min(), bowl[:, -1].min())
    assert lake["level_m"] == float(edge) and lake["spills_off_map"]
    assert same_bits(s.height().z, bowl)  # the terrain is untouched
    assert (w.z > 0).sum() == lake["cells"] == (bowl < edge).sum()  # the bowl is one basin
    assert np.allclose(w.z[bowl < edge], edge - bowl[bowl < edge])
    assert s.report()["lakes"] == s.lakes()


def test_ctrl_c_stops_a_long_stage(dem):
    """SIGINT while the main thread is inside a stage (GIL released) stops it at the next progress
    report with KeyboardInterrupt itself, as any Python code stops on Ctrl-C."""
    import os
    import signal
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        terracl.erode(dem, steps=200000)
    timer.join()
    assert time.perf_counter() - t0 < 60


def test_a_missing_input_is_a_file_not_found_error(tmp_path):
    missing = str(tmp_path / "nope.tif")
    for call in (lambda: terracl.read(missing),
                 lambda: terracl.run_pipeline([missing, str(tmp_path / "o.tif")]),
                 lambda: terracl.Heightfield.from_rasterio(missing)):
        with pytest.raises(FileNotFoundError) as info:
            call()
        assert info.value.filename == missing
        assert "nope.tif" in str(info.value)
    with pytest.raises(terracl.MissingFileError):
        terracl.read(missing)
    assert issubclass(terracl.MissingFileError, terracl.Error)
