"""What a well-kept library does is done by it: scenario files are written by ``tomli-w``, the
progress bar is ``tqdm`` (``tqdm.auto``, a widget in Jupyter), updated between compiled chunks only.
"""

from __future__ import annotations

import io
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w
import tqdm.auto
import tqdm.std

import lgvi
from lgvi import integrator, so3
from lgvi.io.scenario import BodiesScenario, Scenario, load_scenario, to_toml

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.toml"))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_every_example_scenario_round_trips_through_tomli_w(path):
    d = tomllib.loads(path.read_text())
    text = to_toml(d)
    assert text == tomli_w.dumps(d)
    assert tomllib.loads(text) == d
    a, b = load_scenario(path), Scenario.from_dict(tomllib.loads(text))
    if isinstance(a, BodiesScenario):   # [orbiting_body] or [two_body]: the call's arguments
        assert type(b) is BodiesScenario and a.kind == b.kind and a.kwargs.keys() == b.kwargs.keys()
        for x, y in zip(a.args + tuple(a.kwargs.values()), b.args + tuple(b.kwargs.values())):
            if isinstance(x, np.ndarray):
                np.testing.assert_array_equal(x, y)
    else:
        for name in ("R0", "Pi0"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert a.simulate_kwargs().keys() == b.simulate_kwargs().keys()
    assert tomllib.loads(Scenario.from_dict(d).text) == d  # the text a run records reads back the same


def test_to_toml_writes_control_characters_and_numpy_values():
    d = {"name": "x", "note": "carriage\r return, escape \x1b, delete \x7f, tab\t, nul \x00",
         "body": {"inertia": np.array([1.0, 2.0, 3.0]), "n": np.int64(3), "flag": np.bool_(True)},
         "torque": [{"type": "pd", "kp": np.float64(2.5), "target": {"rotvec": (0.0, 0.0, 0.5)}}]}
    back = tomllib.loads(to_toml(d))
    assert back["note"] == d["note"]
    assert back["body"] == {"inertia": [1.0, 2.0, 3.0], "n": 3, "flag": True}
    assert back["torque"] == [{"type": "pd", "kp": 2.5, "target": {"rotvec": [0.0, 0.0, 0.5]}}]
    with pytest.raises(TypeError):
        to_toml({"x": None})


class Recorder(tqdm.std.tqdm):
    """A text tqdm writing to a buffer, remembering every bar and its updates."""

    bars: list["Recorder"] = []

    def __init__(self, *args, **kwargs):
        kwargs["file"] = io.StringIO()
        self.updates: list[int] = []
        super().__init__(*args, **kwargs)
        Recorder.bars.append(self)

    def update(self, n=1):
        self.updates.append(n)
        return super().update(n)


@pytest.fixture
def recorder(monkeypatch):
    Recorder.bars = []
    monkeypatch.setattr(tqdm.auto, "tqdm", Recorder)
    monkeypatch.setattr(lgvi.driver, "interactive", lambda: True)    # as on a terminal
    return Recorder.bars


def test_progress_true_draws_nothing_where_nobody_watches(recorder, monkeypatch):
    """stderr to a file or a CI log (not a terminal, not Jupyter): no bar, the run the same."""
    monkeypatch.setattr(lgvi.driver, "interactive", lambda: False)
    quiet = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=50, progress=True)
    assert recorder == []
    assert np.array_equal(quiet.R, lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01,
                                                 steps=50).R)


def test_interactive_means_a_terminal_or_jupyter(monkeypatch):
    import io
    import sys
    import types

    class Tty(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr(sys, "stderr", io.StringIO())
    monkeypatch.delitem(sys.modules, "IPython", raising=False)
    assert not lgvi.driver.interactive()
    monkeypatch.setattr(sys, "stderr", Tty())
    assert lgvi.driver.interactive()
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    ZMQInteractiveShell = type("ZMQInteractiveShell", (), {})
    monkeypatch.setitem(sys.modules, "IPython", types.SimpleNamespace(get_ipython=lambda: ZMQInteractiveShell()))
    assert lgvi.driver.interactive()


def test_progress_true_is_a_tqdm_bar_updated_between_chunks(recorder, monkeypatch, tmp_path):
    monkeypatch.setattr(integrator, "CHUNK_STEPS", 100)
    lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=450, save_every=50,
                  progress=True)
    lgvi.simulate_stream(tmp_path / "s", [1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=400,
                         chunk_steps=200, progress=True)
    run, stream = recorder
    assert run.updates == [100, 100, 100, 100, 50] and run.total == 450 and run.n == 450
    assert stream.updates == [200, 200] and stream.unit == "step"
    assert "450/450" in run.fp.getvalue()
    for bar in recorder:  # closed: the line is finished, the bar released
        assert bar.fp.getvalue().endswith("\n") or bar.leave is False


def test_progress_bar_of_a_resumed_stream_starts_at_the_resumed_step(recorder, tmp_path):
    folder = tmp_path / "s"
    opts = dict(omega0=[0.3, 1.0, 0.2], h=0.01, steps=400, chunk_steps=100)

    def stop(done, total):
        if done == 200:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        lgvi.simulate_stream(folder, [1.0, 2.0, 3.0], np.eye(3), progress=stop, **opts)
    lgvi.simulate_stream(folder, [1.0, 2.0, 3.0], np.eye(3), progress=True, resume=True, **opts)
    (bar,) = recorder
    assert bar.updates == [100, 100] and bar.n == 400 and bar.total == 400


def test_ensemble_progress_bars_count_steps_or_bodies(recorder, tmp_path):
    rng = np.random.default_rng(2)
    R0 = so3.exp(0.3 * rng.normal(size=(5, 3)))
    Pi0 = [0.2, 0.5, -0.3] + 0.1 * rng.normal(size=(5, 3))
    lgvi.simulate_ensemble([1.0, 2.0, 3.0], R0, Pi0, h=0.01, steps=30, progress=True)
    lgvi.simulate_ensemble([1.0, 2.0, 3.0], R0, Pi0, h=0.01, steps=30, progress=True, out_dir=tmp_path / "b",
                           block_size=2)
    steps, bodies = recorder
    assert steps.n == 30 and steps.unit == "step"
    assert bodies.updates == [2, 2, 1] and bodies.unit == "body" and bodies.total == 5


def test_progress_false_and_callables_draw_nothing(recorder):
    calls = []
    lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=20, progress=False)
    lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=20,
                  progress=lambda d, n: calls.append((d, n)))
    assert recorder == [] and calls == [(20, 20)]
    with pytest.raises(TypeError, match="progress must be True, False or a callable"):
        lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=20, progress="yes")
