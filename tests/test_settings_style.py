"""One settings style (issue 34): every settings object is a `snapo_ode.Settings`, an equinox
module of static fields validated when built, cross-field rules included, so that `replace`
and every constructor refuse a bad value naming the field, before anything is traced."""

import dataclasses

import pytest
from snapo_ode import InputError, Settings, SolverSettings

from chemistry.pharma import DesignSpaceSettings
from snapo_control.pendulum import TrainingSettings
from finance.alm import ALMConfig
from finance.gas_storage import StudySettings

SETTINGS = (SolverSettings, ALMConfig, StudySettings, TrainingSettings, DesignSpaceSettings)


@pytest.mark.parametrize("kind", SETTINGS, ids=lambda kind: kind.__name__)
def test_every_settings_object_is_one_style(kind):
    settings = kind()
    assert isinstance(settings, Settings)
    assert hash(settings) == hash(kind()) and settings == kind()  # static: equal settings, one program
    assert settings.replace() == settings
    assert set(settings.as_dict()) >= {field.name for field in dataclasses.fields(settings)}


@pytest.mark.parametrize(("build", "message"), [
    (lambda: SolverSettings().replace(rtol=0.0), "rtol = 0"),
    (lambda: ALMConfig().replace(indexation=1.5), "indexation = 1.5"),
    (lambda: StudySettings().replace(paths=1), "paths = 1"),
    (lambda: TrainingSettings().replace(clip_norm=-1.0), "clip_norm = -1"),
    (lambda: DesignSpaceSettings().replace(level=1.0), "level = 1"),
])
def test_replace_validates_again_naming_the_field(build, message):
    with pytest.raises(InputError, match=message):
        build()


@pytest.mark.parametrize(("build", "message"), [
    (lambda: SolverSettings(solver="bdf", differentiation="backsolve"), "'bdf' with differentiation = 'backsolve'"),
    (lambda: SolverSettings(nonstiff_solver="bdf", differentiation="backsolve"),
     "nonstiff_solver = 'bdf' with differentiation = 'backsolve'"),
    (lambda: StudySettings(split_actions=True, head="fraction"), "split_actions = True with head = 'fraction'"),
    (lambda: DesignSpaceSettings(x="r1_temperature", y="r1_temperature"), "y = 'r1_temperature' is not one of"),
    (lambda: DesignSpaceSettings(points=3, verify_points=10), "verify_points = 10"),
    (lambda: DesignSpaceSettings(points=5, curvature_points=6), "curvature_points = 6"),
])
def test_rules_between_fields_are_the_settings_own(build, message):
    with pytest.raises(InputError, match=message):
        build()


def test_defaults_that_depend_on_other_fields_are_filled_when_built():
    assert StudySettings().repeats == 5 and StudySettings(stochastic=True).repeats == 1
    assert StudySettings(split_actions=True).head == "split"
