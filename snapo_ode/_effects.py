"""Effects and scenes: a model is assembled from named effects, and a scene says which are active.

Models branch on `scene.has(name)` in Python, at trace time, so an effect that is not active is
absent from the traced computation (the jaxpr), never multiplied by zero.
"""

from collections.abc import Iterable, Mapping

import equinox as eqx

from ._platform.validation import InputError


class Scene(eqx.Module):
    """The set of active effects of one model. Static: two scenes compile to two programs.

    **Arguments:**
    - `catalogue`: the model's `EffectCatalogue`.
    - `active`: the names of the active effects.
    """

    catalogue: "EffectCatalogue" = eqx.field(static=True)
    active: frozenset[str] = eqx.field(static=True)

    def has(self, name: str) -> bool:
        """Whether effect `name` is active. A name the model does not define raises, so a typo
        in model code cannot silently switch an effect off."""
        if name not in self.catalogue.effects:
            raise InputError(
                f"effect {name!r} is not defined for {self.catalogue.model}; "
                f"valid effects: {', '.join(sorted(self.catalogue.effects))}."
            )
        return name in self.active

    def __repr__(self) -> str:
        return f"Scene({self.catalogue.model}: {', '.join(sorted(self.active)) or 'no effects'})"


class EffectCatalogue(eqx.Module):
    """The named effects a model is built from.

    **Arguments:**
    - `model`: the model's name, for messages.
    - `effects`: effect name -> one-line description.
    - `conflicts`: pairs of effects that cannot be active together.
    - `requires`: effect name -> effects that must be active with it.
    """

    model: str = eqx.field(static=True)
    effects: Mapping[str, str] = eqx.field(static=True)
    conflicts: tuple[tuple[str, str], ...] = eqx.field(static=True, default=())
    requires: Mapping[str, tuple[str, ...]] = eqx.field(static=True, default_factory=dict)

    def __check_init__(self):
        for pair in self.conflicts:
            for name in pair:
                if name not in self.effects:
                    raise ValueError(f"conflict names unknown effect {name!r}")
        for name, needed in self.requires.items():
            for other in (name, *needed):
                if other not in self.effects:
                    raise ValueError(f"requirement names unknown effect {other!r}")

    def __hash__(self):
        return hash((self.model, tuple(sorted(self.effects))))

    def scene(self, names: Iterable[str] | None = None, *, without: Iterable[str] = ()) -> Scene:
        """A validated scene: `names` (default: every effect) minus `without`.

        **Raises:** `InputError` for an unknown name (listing the valid ones), a conflicting pair,
        or a missing requirement.
        """
        chosen = set(self.effects if names is None else names)
        removed = set(without)
        for name in sorted(chosen | removed):
            if name not in self.effects:
                raise InputError(
                    f"unknown effect {name!r} for {self.model}; "
                    f"valid effects: {', '.join(sorted(self.effects))}."
                )
        chosen -= removed
        for a, b in self.conflicts:
            if a in chosen and b in chosen:
                raise InputError(f"effects {a!r} and {b!r} of {self.model} cannot be active together.")
        for name in sorted(chosen):
            missing = [other for other in self.requires.get(name, ()) if other not in chosen]
            if missing:
                raise InputError(
                    f"effect {name!r} of {self.model} needs {', '.join(map(repr, missing))} active too."
                )
        return Scene(self, frozenset(chosen))
