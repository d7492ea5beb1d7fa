"""A process written in Python with a unit type of the user's own, defined here, outside the
package: registered with `register_unit_type`, placed in a process built by `process_from_dict`,
it runs the sensitivity study, its sensitivities equal central differences and its balances close."""

import jax.numpy as jnp
import pytest

from chemistry import MECHANISMS
from chemistry.pharma import (
    BUILT_IN_PROCESS, BUMP_SOLVER, AbstractUnit, Liquid, Parameter, PharmaChain, mass_balances, process_from_dict,
    register_unit_type, sensitivity_study)
from snapo_ode import InputError, strict_yaml


class Quench(AbstractUnit):
    """The user's unit: brings the liquid to `temperature` [K] at once (a heat exchanger with no
    hold-up), so that the crystallizer starts from it."""

    def __call__(self, inlet: Liquid, parameters: dict, rates, solver) -> Liquid:
        return Liquid(inlet.amounts, jnp.asarray(parameters["temperature"], dtype=float))


@pytest.fixture(scope="module")
def process():
    try:
        register_unit_type("quench", {"temperature": Parameter("K", "outlet temperature", 159.0, 351.4)}, "reactor",
                           lambda chain, unit, mechanism, profile: Quench())
    except InputError:  # registered by an earlier test in this process
        pass
    data = strict_yaml(BUILT_IN_PROCESS.read_text(), "the built-in process")
    data["mechanism"]["file"] = str(MECHANISMS / "pharma.yaml")
    data["units"].insert(2, {"name": "quench", "type": "quench"})  # after R2, before the crystallizer
    data["cpps"].append({"name": "quench_temperature", "target": "quench.temperature", "unit": "degC",
                         "nominal": 43.0, "nor": [40.0, 46.0], "par": [35.0, 50.0]})
    return process_from_dict(data, name="quenched chain")


def test_a_user_unit_runs_the_sensitivity_study(process):
    chain = PharmaChain(solver=BUMP_SOLVER, process=process)
    assert chain.cpp_names[-1] == "quench_temperature" and chain.cpp_ranges[-1].nominal == pytest.approx(316.15)
    study = sensitivity_study(chain, chain.cpps(), repeats=1, reference=None)
    assert study.max_rel_diff_fd <= 1e-5 and study.max_rel_diff_fd_parameters <= 1e-5
    # Starting the cooling hotter lengthens it at the same rate: the crystals grow larger.
    assert study.matrix["mean_crystal_size"]["quench_temperature"] > 0
    assert max(float(r) for r in mass_balances(chain, study.inputs).values()) <= 1e-12


def test_a_unit_type_is_registered_once(process):
    with pytest.raises(InputError, match="registered already"):
        register_unit_type("quench", {}, "reactor", lambda *args: None)
    with pytest.raises(InputError, match="role = 'mixer'"):
        register_unit_type("mixer", {}, "mixer", lambda *args: None)
