"""Training: converges on a problem with a known optimum, is deterministic, stops early, guards
against NaN naming the step, and checkpoints atomically."""

import hashlib
import json
import os
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode


def quadratic_loss(params):
    loss = jnp.sum((params["x"] - jnp.array([1.0, -2.0])) ** 2)
    return loss, {"value": -loss}


def test_reaches_the_known_minimum():
    result = snapo_ode.train(quadratic_loss, {"x": jnp.zeros(2)}, steps=400, learning_rate=0.1,
                             progress=False)
    np.testing.assert_allclose(result.params["x"], [1.0, -2.0], atol=1e-4)
    assert result.history["value"][-1] == pytest.approx(-result.history["loss"][-1])


def test_deterministic_under_a_key():
    def noisy(params, key):
        noise = jax.random.normal(key, (2,))
        return jnp.sum((params["x"] - noise) ** 2), {}

    runs = [snapo_ode.train(noisy, {"x": jnp.zeros(2)}, steps=20, key=jax.random.key(7), progress=False)
            for _ in range(2)]
    np.testing.assert_array_equal(runs[0].params["x"], runs[1].params["x"])
    assert runs[0].history["loss"] == runs[1].history["loss"]


def test_the_step_reaches_the_loss_without_recompiling():
    traces = []

    def scheduled(params, key, step):
        traces.append(step)
        target = jnp.where(step < 10, 1.0, -1.0)  # a two-phase curriculum
        return jnp.sum((params["x"] - target) ** 2), {"step": step}

    result = snapo_ode.train(scheduled, {"x": jnp.zeros(1)}, steps=20, key=jax.random.key(0), pass_step=True,
                             learning_rate=0.1, progress=False)
    assert result.history["step"] == list(range(20)) and len(traces) == 1
    assert result.history["loss"][10] > result.history["loss"][9]  # the target moved at step 10


def test_data_reaches_the_loss_as_an_argument_not_a_constant():
    seen = []

    def with_data(params, key, target):
        seen.append(isinstance(target, jax.core.Tracer))  # traced: an input of the step, not baked in
        return jnp.sum((params["x"] - target - jax.random.normal(key, (2,))) ** 2), {}

    target = jnp.array([1.0, -2.0])
    kwargs = dict(steps=20, key=jax.random.key(2), learning_rate=0.1, progress=False)
    given = snapo_ode.train(with_data, {"x": jnp.zeros(2)}, data=target, **kwargs)
    closed = snapo_ode.train(lambda params, key: with_data(params, key, target), {"x": jnp.zeros(2)}, **kwargs)
    assert seen == [True, False]
    np.testing.assert_array_equal(given.params["x"], closed.params["x"])


def test_keep_best_false_returns_the_last_parameters():
    def noisy(params, key):  # the batch's noise makes some steps' losses lucky
        return jnp.sum((params["x"] - 1.0) ** 2) + jax.random.normal(key), {}

    kwargs = dict(steps=30, key=jax.random.key(1), learning_rate=0.05, progress=False)
    best = snapo_ode.train(noisy, {"x": jnp.zeros(1)}, **kwargs)
    last = snapo_ode.train(noisy, {"x": jnp.zeros(1)}, keep_best=False, **kwargs)
    assert best.history == last.history and best.best_loss == last.best_loss
    step = int(np.argmin(best.history["loss"]))
    assert step < 29 and float(best.params["x"][0]) < float(last.params["x"][0])  # x climbs towards 1


def test_early_stopping_returns_the_best_parameters():
    flat = lambda params: (jnp.sum(params["x"] * 0.0) + 1.0, {})  # noqa: E731
    result = snapo_ode.train(flat, {"x": jnp.zeros(2)}, steps=100, patience=5, progress=False)
    assert result.stopped_early and result.steps_run == 6


def test_nan_guard_names_the_step_and_keeps_the_last_good_params():
    def explodes(params):
        # Unbounded below, so Adam walks x upward until the loss turns NaN past 0.35.
        return jnp.where(params["x"][0] > 0.35, jnp.nan, -jnp.sum(params["x"])), {}

    with pytest.raises(snapo_ode.TrainingDiverged, match=r"at step \d+") as info:
        snapo_ode.train(explodes, {"x": jnp.zeros(2)}, steps=500, learning_rate=0.05, progress=False)
    assert info.value.step > 0
    assert float(info.value.params["x"][0]) <= 0.35


def test_checkpoint_round_trip(tmp_path):
    path = tmp_path / "ckpt.eqx"
    result = snapo_ode.train(quadratic_loss, {"x": jnp.zeros(2)}, steps=30, checkpoint_path=path,
                             checkpoint_every=10, progress=False)
    restored, info = snapo_ode.load_checkpoint(path, {"x": jnp.zeros(2)})
    np.testing.assert_array_equal(restored["x"], result.params["x"])
    assert info["next_step"] == 30 and len(info["history"]["loss"]) == 30
    assert not list(tmp_path.glob(".*tmp"))


def noisy_loss(params, key):
    """A stochastic objective, so that a resumed run must also continue the key sequence."""
    target = jnp.array([1.0, -2.0]) + 0.3 * jax.random.normal(key, (2,))
    return jnp.sum((params["x"] - target) ** 2), {"value": params["x"][0]}


def test_an_interrupted_run_resumed_equals_an_uninterrupted_one(tmp_path):
    settings = dict(steps=40, key=jax.random.key(3), progress=False, checkpoint_every=7)
    whole = snapo_ode.train(noisy_loss, {"x": jnp.zeros(2)}, **settings)

    def interrupt(step, loss, metrics):
        if step == 18:
            raise KeyboardInterrupt

    path = tmp_path / "run.ckpt"
    with pytest.raises(KeyboardInterrupt):
        snapo_ode.train(noisy_loss, {"x": jnp.zeros(2)}, checkpoint_path=path, callback=interrupt, **settings)
    _, info = snapo_ode.load_checkpoint(path, {"x": jnp.zeros(2)})
    assert info["next_step"] == 19  # every completed step is kept, not only the last periodic checkpoint
    resumed = snapo_ode.train(noisy_loss, {"x": jnp.zeros(2)}, checkpoint_path=path, resume=True, **settings)
    np.testing.assert_array_equal(resumed.params["x"], whole.params["x"])
    assert resumed.history["loss"] == whole.history["loss"] and resumed.best_loss == whole.best_loss
    with pytest.raises(snapo_ode.InputError, match="its training settings differ"):
        snapo_ode.train(noisy_loss, {"x": jnp.zeros(2)}, checkpoint_path=path, resume=True,
                        **{**settings, "steps": 50})


def test_resume_refuses_the_checkpoint_of_another_run_naming_what_differs(tmp_path):
    path = tmp_path / "run.ckpt"
    settings = dict(steps=5, progress=False, checkpoint_path=path)
    snapo_ode.train(noisy_loss, {"x": jnp.zeros(2)}, key=jax.random.key(3), fingerprint={"inputs": np.ones(3)},
                    **settings)
    again = dict(key=jax.random.key(3), fingerprint={"inputs": np.ones(3)}, resume=True, **settings)
    assert snapo_ode.train(noisy_loss, {"x": jnp.zeros(2)}, **again).steps_run == 5  # its own run resumes
    for change, named in (({"fingerprint": {"inputs": np.array([1.0, 1.0, 2.0])}}, "its inputs differ"),
                          ({"key": jax.random.key(4)}, "its key differ"),
                          ({"fingerprint": {"inputs": np.ones(3), "seed": 1}}, "its seed differ")):
        with pytest.raises(snapo_ode.InputError, match=named):
            snapo_ode.train(noisy_loss, {"x": jnp.zeros(2)}, **{**again, **change})
    with pytest.raises(snapo_ode.InputError, match="initial parameters differ"):
        snapo_ode.train(noisy_loss, {"x": jnp.ones(2)}, **again)


def test_resume_refuses_a_checkpoint_trained_on_other_data(tmp_path):
    def on_data(params, key, target):
        return jnp.sum((params["x"] - target) ** 2) + jax.random.normal(key), {}

    settings = dict(steps=5, progress=False, checkpoint_path=tmp_path / "run.ckpt", key=jax.random.key(3))
    snapo_ode.train(on_data, {"x": jnp.zeros(2)}, data=jnp.ones(2), **settings)
    again = dict(settings, resume=True)
    assert snapo_ode.train(on_data, {"x": jnp.zeros(2)}, data=jnp.ones(2), **again).steps_run == 5
    with pytest.raises(snapo_ode.InputError, match="data differ"):
        snapo_ode.train(on_data, {"x": jnp.zeros(2)}, data=jnp.array([1.0, 2.0]), **again)


@pytest.mark.parametrize("header, message", [
    (b"not json", "not a checkpoint's JSON header"),
    (b'{"next_step": 1}', "steps: Field required"),
    (b'{"next_step": "1", "steps": 5, "history": {"loss": [1.0]}, "best_loss": null, "since_best": 0, '
     b'"stopped_early": false}', "next_step = '1': Input should be a valid integer"),
    (b'{"next_step": 9, "steps": 5, "history": {"loss": []}, "best_loss": null, "since_best": 0, '
     b'"stopped_early": false}', "exceeds steps"),
    (b'{"next_step": 1, "steps": 5, "history": {"loss": []}, "best_loss": null, "since_best": 0, '
     b'"stopped_early": false}', "must all equal next_step"),
])
def test_a_malformed_checkpoint_is_a_one_line_input_error(tmp_path, header, message):
    path = tmp_path / "run.ckpt"
    path.write_bytes(sealed(header, b"\x00" * 16))
    with pytest.raises(snapo_ode.InputError, match=message) as caught:
        snapo_ode.train(quadratic_loss, {"x": jnp.zeros(2)}, steps=5, progress=False, checkpoint_path=path, resume=True)
    assert "\n" not in str(caught.value) and str(path) in str(caught.value)


def sealed(header: bytes, payload: bytes) -> bytes:
    """A checkpoint file of `header` (a JSON object) and `payload`, its checksum the SHA-256 of both."""
    if not header.startswith(b"{"):
        return header + b"\n" + payload
    checksum = "sha256:" + hashlib.sha256(header + b"\n" + payload).hexdigest()
    return header[:-1] + f', "checksum": "{checksum}"}}'.encode() + b"\n" + payload


def test_a_truncated_checkpoint_is_an_input_error(tmp_path):
    path = tmp_path / "run.ckpt"
    snapo_ode.train(quadratic_loss, {"x": jnp.zeros(2)}, steps=5, progress=False, checkpoint_path=path)
    path.write_bytes(path.read_bytes()[:-20])
    with pytest.raises(snapo_ode.InputError, match="is corrupt: its checksum"):
        snapo_ode.train(quadratic_loss, {"x": jnp.zeros(2)}, steps=5, progress=False, checkpoint_path=path, resume=True)
    header, payload = path.read_bytes().split(b"\n", 1)
    cut = json.loads(header)  # a body cut short under a checksum that matches: the leaves cannot be read
    del cut["checksum"]
    path.write_bytes(sealed(json.dumps(cut).encode(), payload[:-20]))
    with pytest.raises(snapo_ode.InputError, match="cannot be read"):
        snapo_ode.train(quadratic_loss, {"x": jnp.zeros(2)}, steps=5, progress=False, checkpoint_path=path, resume=True)


def test_rejects_bad_step_count():
    with pytest.raises(snapo_ode.InputError, match="steps"):
        snapo_ode.train(quadratic_loss, {"x": jnp.zeros(2)}, steps=0)


def test_a_fingerprint_is_the_same_in_every_process():
    import subprocess
    import sys

    script = ("import equinox as eqx, numpy as np, snapo_ode\n"
              "class M(eqx.Module):\n    names: frozenset = eqx.field(static=True)\n    x: np.ndarray\n"
              "print(snapo_ode.digest_of({'m': M(frozenset('abcdefgh'), np.arange(3.0)), 's': {'u', 'v', 'w'},"
              " 'f': print}))")
    digests = {subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True,
                              env={**os.environ, "PYTHONHASHSEED": seed}).stdout for seed in ("1", "2", "3")}
    assert len(digests) == 1
