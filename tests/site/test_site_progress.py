"""`grainmech site` says what runs while a layer runs (site.runner.LayerWatch), with a fake
clock and fake model lines: no model run."""

from __future__ import annotations

from grainmech.site.runner import SITE_PROGRESS_EVERY, LayerWatch


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_layer_line_names_the_layer_the_models_amplitude_and_the_time_left():
    assert SITE_PROGRESS_EVERY <= 10.0
    clock = Clock()
    w = LayerWatch(total=3, todo=3, in_process=True, clock=clock)
    w.start("layer 1 'sand-1'")
    clock.t = 12.0
    assert w.line() == "[site] layer 1/3 layer 1 'sand-1': running 12 s"
    w.note("[packing] amplitude 2/3, step 40/96, 4 s (total 10 s), about 14 s left")
    clock.t = 15.0
    assert w.line() == ("[site] layer 1/3 layer 1 'sand-1': running 15 s; [packing] amplitude 2/3, step 40/96, "
                        "4 s (total 10 s), about 14 s left (3 s ago)")
    w.done(100.0)  # the first layer took 100 s
    clock.t = 100.0
    w.start("layer 2 'sand-2'")
    clock.t = 130.0
    # two layers left at 100 s each, 30 s of the running one already spent
    assert w.line() == "[site] layer 2/3 layer 2 'sand-2': running 30 s; profile: about 170 s left"


def test_a_stopped_amplitude_is_said_at_once_not_only_in_the_next_line():
    """A model's stop line (``[packing] amplitude 0.0001 stopped: ...``) is said the moment
    the layer's model says it, with the layer; other lines wait for the heartbeat."""
    said: list[str] = []
    w = LayerWatch(total=3, todo=3, in_process=True, clock=Clock(), say=said.append)
    w.start("layer 1 'upper sand'")
    w.note("[packing] amplitude 4/8, step 24/48, 128 s (total 158 s), about 203 s left")
    w.note("[packing] amplitude 0.0001 stopped: step 26: no equilibrium of the fixed geometry")
    w.note("[dem 1/5] cyclic simple shear, amplitude 0.0001 (32 steps, 2000 grains)")
    assert said == ["[site] layer 1/3 layer 1 'upper sand': [packing] amplitude 0.0001 stopped: step 26: no "
                    "equilibrium of the fixed geometry"]


def test_cluster_line_counts_the_layers():
    clock = Clock()
    w = LayerWatch(total=4, todo=2, in_process=False, clock=clock)
    clock.t = 25.0
    assert w.line() == "[site] 0/2 layer(s) of this run finished on the cluster, 25 s"
    w.done(20.0)
    assert w.line() == "[site] 1/2 layer(s) of this run finished on the cluster, 25 s; profile: about 20 s left"


def test_site_run_prints_progress_lines_while_a_layer_runs(monkeypatch, capsys):
    """run_site in this process with a slow fake layer: a heartbeat line arrives before the layer ends."""
    import threading

    import grainmech.site.runner as runner

    monkeypatch.setattr(runner, "SITE_PROGRESS_EVERY", 0.05)
    seen = threading.Event()
    lines: list[str] = []

    def say(msg: str) -> None:
        lines.append(msg)
        if msg.startswith("[site] layer 1/1"):
            seen.set()

    def slow_layer(task, progress=None):
        progress("[packing 1/2] cyclic simple shear, amplitude 1e-05 (64 steps, 400 grains)")
        assert seen.wait(5.0)
        return {"status": "ok", "seconds": 0.3, "amplitudes_run": 2, "amplitudes_reused": 0}

    monkeypatch.setattr(runner, "run_task", slow_layer)

    class Layer:
        label, index, slug, vs = "layer 1 'sand'", 0, "01-sand", None

    class Folder:
        def __init__(self, path):
            self.path = self.staging = path

    monkeypatch.setattr(runner, "read_anchor", lambda *a: None)
    monkeypatch.setattr(runner, "write_layer_record", lambda *a: None)
    monkeypatch.setattr(runner, "layer_key", lambda la: "k")
    monkeypatch.setattr(runner, "write_outputs", lambda *a, **k: {"lines": list(lines)})

    class Profile:
        source, method, layers, raw = "p.toml", "packing", [Layer()], {"layers": [{"name": "sand"}]}

    import pathlib
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        out = runner._run_in(Folder(pathlib.Path(tmp)), Profile(), tmp, say, (None, None, None), False, None, 0.0)
    beat = [s for s in out["lines"] if s.startswith("[site] layer 1/1")]
    assert beat and "amplitude 1e-05" in beat[0]
    assert out["lines"][-1].startswith("[1/1] layer 1 'sand': ok (2 amplitude(s) run, 0 reused, 0.3 s)")
