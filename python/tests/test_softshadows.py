"""The softshadows module: the interface of docs/python.md, its errors, its device memory and the GIL.

Run by `cargo xtask test` with ENGINE_VALIDATION=1 (a validation error makes the call that caused it raise, and a
leak makes `close()` raise). Sizes are tiny: these check the binding, not the techniques (tests/ does that).
"""

import os
import pathlib
import threading

import numpy as np
import pytest

import softshadows as ss

ROOT = pathlib.Path(__file__).resolve().parents[2]
W, H = 32, 24


@pytest.fixture(scope="module")
def renderer():
    r = ss.Renderer(device=None)
    yield r
    # Raises on a leaked device allocation or a validation error seen since the last call.
    r.close()


@pytest.fixture(scope="module")
def bunny():
    return ss.load("bunny")


def test_render_is_float32_hxwx3_linear(renderer, bunny):
    img = renderer.render(bunny, technique="isg:patches=16", width=W, height=H)
    assert isinstance(img, np.ndarray)
    assert img.shape == (H, W, 3) and img.dtype == np.float32
    assert np.isfinite(img).all() and (img >= 0).all()
    # Lit, and not a flat colour: the bunny and its shadow are in the frame.
    assert img.mean() > 0.01 and img.std() > 0.01
    times = renderer.last_pass_times()
    assert isinstance(times, dict) and times
    assert any(name.startswith("shade/") for name in times), times
    assert all(ms >= 0 for ms in times.values())


def test_techniques_come_from_the_engine_registry(renderer, bunny):
    names = ss.techniques()
    for t in ["isg", "shexp", "lobes", "none", "reference"]:
        assert t in names
    # Shadows darken: a shadowing technique is darker than no shadows at all (`none`), in total. (shexp and lobes
    # render in test_compare_rows; each technique made costs seconds on lavapipe.)
    isg = renderer.render(bunny, technique="isg", width=W, height=H)
    none = renderer.render(bunny, technique="none", width=W, height=H)
    assert isg.sum() < none.sum()


def test_errors_carry_the_engine_message(renderer, bunny):
    with pytest.raises(ss.EngineError, match="unknown technique 'nope'"):
        renderer.render(bunny, technique="nope", width=W, height=H)
    with pytest.raises(ss.EngineError, match="isg"):
        renderer.render(bunny, technique="isg:patches=banana", width=W, height=H)
    with pytest.raises(ss.EngineError, match="unknown scene 'nope'"):
        ss.load("nope")
    with pytest.raises(ss.EngineError):
        ss.load(str(ROOT / "examples" / "no-such-file.toml"))
    with pytest.raises(ss.EngineError, match="visibility 'walls'"):
        renderer.reference(bunny, width=W, height=H, visibility="walls", spp=4)
    with pytest.raises(ss.EngineError):
        renderer.render(bunny, width=0, height=H)
    assert issubclass(ss.EngineError, RuntimeError)
    # The renderer still works after errors.
    assert np.isfinite(renderer.render(bunny, technique="none", width=W, height=H)).all()


def test_scene_files_load(renderer):
    scene = ss.load(str(ROOT / "examples" / "arm.toml"))
    assert "arm.toml" in scene.name
    img = renderer.render(scene, technique="isg", width=W, height=H)
    assert img.shape == (H, W, 3) and np.isfinite(img).all() and img.max() > 0


def test_reference_is_deterministic_and_agrees_with_a_technique(renderer, bunny):
    ref = renderer.reference(bunny, width=W, height=H, visibility="triangles", spp=32)
    assert ref.shape == (H, W, 3) and ref.dtype == np.float32 and np.isfinite(ref).all()
    # The same seed every time: the same samples, the same image.
    again = renderer.reference(bunny, width=W, height=H, visibility="triangles", spp=32)
    np.testing.assert_array_equal(ref, again)
    # More samples change it (a noisy estimate), but not its mean.
    more = renderer.reference(bunny, width=W, height=H, visibility="triangles", spp=128)
    assert not np.array_equal(ref, more)
    assert abs(more.mean() - ref.mean()) < 0.05 * more.mean()
    # A technique and the ground truth see the same scene: means within 20 %.
    isg = renderer.render(bunny, technique="isg", width=W, height=H)
    assert abs(isg.mean() - more.mean()) < 0.2 * more.mean()
    unoccluded = renderer.reference(bunny, width=W, height=H, visibility="unoccluded", spp=32)
    assert unoccluded.sum() > ref.sum()


def test_compare_rows(bunny):
    techniques = ["isg", "shexp", "lobes"]
    rows = ss.compare(bunny, techniques, width=16, height=12, frames=1, max_spp=32, visibility="both")
    assert [(r["visibility"], r["technique"]) for r in rows] == [(v, t) for v in ["spheres", "triangles"] for t in techniques]
    for r in rows:
        for key in ["rmse_percent", "debiased_percent", "max_error", "flip", "shade_ms", "frame_ms"]:
            assert np.isfinite(r[key]) and r[key] >= 0, (key, r)
        assert 0 < r["rmse_percent"] < 100
        assert 0 < r["reference_spp"] <= 32
    # The same images against two references: the same shade times, different errors.
    for t in range(3):
        assert rows[t]["shade_ms"] == rows[t + 3]["shade_ms"]
        assert rows[t]["rmse_percent"] != rows[t + 3]["rmse_percent"]
    with pytest.raises(ss.EngineError, match="unknown technique 'nope'"):
        ss.compare(bunny, ["nope", "isg"], width=16, height=12, frames=1, max_spp=16)


def test_the_gil_is_released_while_the_gpu_works(renderer, bunny):
    count = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            count[0] += 1

    t = threading.Thread(target=spin)
    t.start()
    try:
        before = count[0]
        renderer.render(bunny, technique="isg", width=W, height=H, frames=2)
        during = count[0] - before
    finally:
        stop.set()
        t.join()
    # Holding the GIL for the whole call would leave the thread at (almost exactly) zero: Python switches threads
    # only between bytecodes, and none of the main thread's run during the call.
    assert during > 1000, during


def test_two_threads_share_one_renderer(renderer, bunny):
    out, errors = {}, []

    def work(name):
        try:
            out[name] = renderer.render(bunny, technique=name, width=W, height=H)
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(n,)) for n in ["isg", "none"]]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    np.testing.assert_array_equal(out["isg"], renderer.render(bunny, technique="isg", width=W, height=H))


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="RSS read from /proc")
def test_memory_stays_flat_over_many_renders(bunny):
    """Nothing a render makes outlives it: the allocator's report is the same after 200 renders, and the
    process's memory (lavapipe's device memory is host memory) grows by less than a few MB."""
    n = int(os.environ.get("SOFTSHADOWS_RENDERS", "200"))
    with ss.Renderer() as r:
        for _ in range(10):
            r.render(bunny, technique="isg", width=16, height=12)
        mem0, rss0 = r.memory(), rss_bytes()
        for _ in range(n):
            img = r.render(bunny, technique="isg", width=16, height=12)
            del img
        mem1, rss1 = r.memory(), rss_bytes()
    assert mem1["live_allocations"] == mem0["live_allocations"], (mem0, mem1)
    assert mem1["allocated_bytes"] == mem0["allocated_bytes"], (mem0, mem1)
    assert mem1["allocations_made"] > mem0["allocations_made"], "the renders allocated nothing?"
    growth = (rss1 - rss0) / 2**20
    print(f"{n} renders: RSS {rss0 / 2**20:.1f} -> {rss1 / 2**20:.1f} MiB ({growth:+.1f}); device {mem1}")
    assert growth < 16, f"RSS grew {growth:.1f} MiB over {n} renders"


def test_closed_renderer_raises(bunny):
    r = ss.Renderer()
    assert r.device
    r.close()
    r.close()
    with pytest.raises(ss.EngineError, match="closed"):
        r.render(bunny, width=W, height=H)


def test_device_choice(bunny):
    name = ss.Renderer().device
    # A part of the adapter's name picks it, as --device does.
    with ss.Renderer(device=name[:6].lower()) as r:
        assert r.device == name
    with pytest.raises(ss.EngineError, match="no-such-gpu"):
        ss.Renderer(device="no-such-gpu")
