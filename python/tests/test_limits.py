# SPDX-License-Identifier: Apache-2.0
"""Limits of the Python module (issue #32): re-entrant calls from progress callbacks, Ctrl-C during
a stage, the memory check of array copies, non-finite writes, out-of-range integers and
non-callable progress arguments. Each is a clear Python exception, never a hang or a crash."""
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import terracl


def _python(code, **kw):
    """A child Python running `code` with this test's terracl (PYTHONPATH is inherited)."""
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def test_a_stage_called_from_a_progress_callback_raises_instead_of_deadlocking():
    # In a child: before the fix this hung at 0 % CPU, deaf to Ctrl-C.
    p = _python("""
        import numpy as np, terracl
        h = terracl.Heightfield(np.random.default_rng(1).random((48, 48), dtype=np.float32) * 100, cell_size=10)
        small = terracl.Heightfield(np.zeros((8, 8), np.float32), cell_size=10)
        seen = []
        def cb(f, m):
            try:
                terracl.erode(small, steps=2)
            except RuntimeError as e:
                seen.append(str(e))
                raise
        try:
            terracl.erode(h, steps=5, progress=cb)
        except terracl.Cancelled as e:
            assert isinstance(e.__cause__, RuntimeError), repr(e.__cause__)
        print("SEEN", seen[0])
    """)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 0, err
    assert "cannot be called from inside a progress callback" in out


@pytest.mark.parametrize("with_callback", [True, False])
def test_ctrl_c_interrupts_a_running_stage(with_callback):
    p = _python("""
        import sys, numpy as np, terracl
        h = terracl.Heightfield(np.random.default_rng(1).random((256, 256), dtype=np.float32) * 500, cell_size=10)
        terracl.erode(h, steps=2)  # the device is open before the parent starts its clock
        print("running", flush=True)
        terracl.erode(h, steps=100000%s)
        print("finished")
    """ % (", progress=lambda f, m: None" if with_callback else ""))
    assert p.stdout.readline().strip() == "running"
    time.sleep(1.0)
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    try:
        out, err = p.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        p.kill()
        pytest.fail("the stage did not stop on SIGINT")
    assert time.monotonic() - t0 < 15
    assert "KeyboardInterrupt" in err, err
    assert "finished" not in out


def test_array_copies_respect_the_memory_limit(monkeypatch):
    monkeypatch.setenv("TERRACL_MAX_MEMORY", "1G")
    # 65536^2 float32 (16 GiB) that takes no memory itself: every element is the same float.
    huge = np.lib.stride_tricks.as_strided(np.zeros(1, np.float32), shape=(65536, 65536), strides=(0, 0))
    with pytest.raises(MemoryError) as e:
        terracl.Heightfield(huge, cell_size=1)
    assert "65536 x 65536" in str(e.value) and "TERRACL_MAX_MEMORY" in str(e.value)
    with pytest.raises(MemoryError):
        terracl.fill(huge)


@pytest.mark.parametrize("ext", ["tif", "exr", "npy", "png"])
def test_infinite_elevations_are_not_written(tmp_path, ext):
    z = np.full((16, 16), 100, np.float32)
    z[3, 4] = np.inf
    path = tmp_path / ("inf." + ext)
    with pytest.raises(ValueError) as e:
        terracl.write(terracl.Heightfield(z, cell_size=10), path)
    assert str(path) in str(e.value) and "infinite elevation" in str(e.value)
    assert not path.exists()
    # NaN is nodata: written, and read back as NaN, as the CLI reads it.
    z[3, 4] = np.nan
    terracl.write(terracl.Heightfield(z, cell_size=10), path)
    assert np.isnan(terracl.read(path).z[3, 4])


def test_cell_sizes_out_of_range_are_not_written(tmp_path):
    h = terracl.Heightfield(np.zeros((8, 8), np.float32), cell_size=10)
    h.georef.cell_x = h.georef.cell_y = 1e300
    with pytest.raises(ValueError) as e:
        terracl.write(h, tmp_path / "c.tif")
    assert "c.tif" in str(e.value) and "cell size" in str(e.value)


@pytest.mark.parametrize("steps", [2**63, 2**64 + 1, 10**30])
def test_huge_integers_name_the_accepted_range(steps):
    h = terracl.Heightfield(np.zeros((8, 8), np.float32), cell_size=10)
    with pytest.raises(ValueError) as e:
        terracl.erode(h, steps=steps)
    assert "/steps" in str(e.value) and "expected an integer from 0 to" in str(e.value), str(e.value)


def test_progress_must_be_callable():
    h = terracl.Heightfield(np.zeros((8, 8), np.float32), cell_size=10)
    with pytest.raises(TypeError) as e:
        terracl.erode(h, steps=1, progress=5)
    assert "progress must be callable" in str(e.value)
    s = terracl.Session("flat:16x16@10")
    with pytest.raises(TypeError):
        s.progress = "yes"


def test_a_stage_too_large_for_memory_is_refused_before_it_runs(monkeypatch):
    # The CLI's memory column: erosion needs ~168 B per cell on a CPU device (docs/reliability.md).
    monkeypatch.setenv("TERRACL_MAX_MEMORY", "64M")
    h = np.full((1024, 1024), 100, np.float32)
    with pytest.raises(terracl.Error) as e:
        terracl.erode(h, steps=1, cell_size=10)
    assert "needs about" in str(e.value) and "TERRACL_MAX_MEMORY" in str(e.value), str(e.value)
