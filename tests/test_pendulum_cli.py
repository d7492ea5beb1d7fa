"""`snapo pendulum` at a small size: the JSON keys, the saved policy, and bad input answered with
exit code 2 before anything is compiled."""

import json

import jax.numpy as jnp
import numpy as np

from snapo_control.cli import register
from snapo_control.pendulum import features
from snapo_ode import load_policy
from snapo_ode.cli import main

KEYS = {"mean_return", "std_return", "episodes", "eval_seed", "train_seconds", "compile_seconds",
        "mean_return_without_periodic", "policy_path", "returns", "learning_curve", "load_average"}


def test_pendulum_writes_every_key_and_the_policy(tmp_path, capsys):
    out = tmp_path / "pendulum.json"
    code = main(["pendulum", "--train-steps", "3", "--batch", "4", "--eval-episodes", "2", "--eval-seed", "5",
                 "--no-progress", "--json", str(out)], plugins=[register])
    assert code == 0
    payload = json.loads(out.read_text())
    assert KEYS <= set(payload)
    assert payload["episodes"] == 2 and payload["eval_seed"] == 5 and len(payload["returns"]) == 2
    assert payload["mean_return"] == np.mean(payload["returns"]) and payload["mean_return"] < 0
    assert payload["mean_return_without_periodic"] < 0 and len(payload["learning_curve"]) == 3
    policy = load_policy(payload["policy_path"])
    assert np.isfinite(float(policy(features(jnp.array([3.0, 0.5])))[0]))
    assert "without the periodic treatment" in capsys.readouterr().out


def test_bad_input_exits_2_naming_the_field(tmp_path, capsys):
    assert main(["pendulum", "--eval-episodes", "0", "--out", str(tmp_path)], plugins=[register]) == 2
    assert "--eval-episodes: 0 is out of range" in capsys.readouterr().err
    assert main(["pendulum", "--eval-seed", "-1", "--out", str(tmp_path)], plugins=[register]) == 2
    assert "--eval-seed: -1 is out of range: allowed from 0 to 9223372036854775807" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
