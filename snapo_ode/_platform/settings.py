"""The one style of every settings object in the project (solver, studies, training, design
space): an `equinox.Module` whose fields are static (two settings compile to two programs),
validated when it is built, cross-field rules included, so that a bad value is refused naming
the field, the value and what is allowed, before anything is traced."""

import dataclasses

import equinox as eqx


class Settings(eqx.Module):
    """Base of the settings objects. A subclass declares its fields with
    `equinox.field(static=True, default=...)`, fills defaults that depend on other fields in
    `__post_init__`, and checks every field and every rule between fields in `__check_init__`
    (raising `InputError` through `check_range`, `check_choice`, ...)."""

    def replace(self, **changes):
        """A copy with `changes`, validated again."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """The fields by name (for JSON, through `snapo_ode.jsonable`)."""
        return {field.name: getattr(self, field.name) for field in dataclasses.fields(self)}
