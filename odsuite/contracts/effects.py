"""The effect contract: a named, parametrised change of a model that the diagnosis can fit.

A provider registered through ``odsuite_register_effects`` is an :class:`Effect` (subclass it) or
any object with the same members:

- ``name`` (str): the registry name; ``description`` (str): one sentence for listings;
- ``target`` (str): ``"model"`` when it changes the structure (M, C, K, flexible modes) or
  ``"chain"`` when it changes only the measurement chain (sensor and force-gauge signals: the
  structure's cached matrices and simulations are then reused, which makes fitting fast);
- ``parameters(model) -> list[Parameter]``: its parameters for this model (SI units, a nominal
  value that leaves the model unchanged, bounds; ``scope`` "shared" by every experiment or
  "per_experiment"); called once per diagnosis, so it may depend on the rig's bodies and sensors;
  an empty list means the effect does not apply to this model (the diagnosis lists it as not
  applicable instead of fitting it);
- ``apply(model, values) -> Model``: the model with the effect at ``values`` (a mapping from
  parameter name to value; missing names take their nominal). Called in fitting loops: it must be
  cheap, pure (never change ``model``) and raise :class:`~odsuite.domain.errors.ConfigError` for values
  it cannot use.

Optional: ``structures`` (a tuple of structure classes, default None: any): the model families the
effect applies to, by the class of ``model.structure`` (rigid bodies on springs:
:class:`~odsuite.domain.model.Structure`; the beam plugin's ``BeamStructure``; a lab's own). A chain
effect usually applies to any. On a model of another family the diagnosis lists the effect as not
applicable and ``add-effect`` refuses it, without calling ``parameters`` (:func:`applies`).

Optional: ``data_driven`` (bool, default False): the effect presupposes no shape (a mode of any
shape), so the diagnosis ranks a significant named mechanism it is confounded with before it.

Optional: ``refines`` (str): the effect extends the named effect's fit. The diagnosis fits it only
from that fit (after the other candidates, when that one is significant, leaves the error above
the floor and no candidate reaches the floor) and counts it significant only when its gain over
that fit passes the test for its extra parameters; ``add-effect`` fits the named effect first.
With it, optional ``held_when(model, fixed) -> {name: value}``: parameters held at a value given
the refined fit's discrete choices, and ``refined_start(model, values) -> {name: value}``: start
values replacing the refined fit's (:func:`odsuite.diagnosis.fitting.refined`).

Optional: ``repeatable`` (bool, default False): each addition is one more instance (a structure may
lack several modes): the diagnosis tries it again when the model has it, ``add-effect`` adds it
after the one stored, and a revision applies each entry's values per experiment with its shared
ones, so ``apply`` must find its own instance by them.

Optional: ``breaks_rigidity`` (bool, default False): the effect makes a rigid body's redundant
sensors disagree (a flexible mode, a sensor fault), so the diagnosis cites the rigidity check's
residual as evidence for it.

Optional: ``adds_body`` (bool, default False): away from its nominal values the effect gives the
model another moving body (the base moving on its mounts). Paired with another effect it is
applied last, so the other's parameters keep the names they have on the model without it (per
body only where there are several).

Each :class:`Parameter` may declare ``plausible`` (low, high): the physically plausible range of
its value, narrower than the bounds the fit may explore (a sensor resonance near the sensor's rated
band, a tilt below 45 degrees, a mass change within the body's own mass). A fit outside it is
reported as not ``plausible`` by ``diagnose`` and warned about by ``add-effect``: the effect then
more likely stands in for other physics. None: any value within the bounds is plausible.

Optional, for effects with target "chain" that describe the measurement rather than the structure:
``correct(rig, signals, fs, values) -> (rig, signals)`` undoes the effect at ``values`` on
recorded signals (``signals``: sensor name -> samples along the sensor's axis at ``fs`` Hz, in
one physical quantity; the effects are linear, so it may be acceleration or displacement). It
returns the rig as the sensors were mounted (a tilted axis, a moved sensor: the correction then
re-expresses those sensors' signals along their nominal axes at their nominal places from the
motion their body's sensors record together) and the signals with the distortion removed. It
must be pure and leave sensors it does not concern unchanged. ``correction_stage`` says where
the effect sits between structure and converter, so undoing runs from the converter back:
``"channel"`` (a sampling delay, the channel's filters: undone first), ``"wiring"`` (which
sensor a channel carries: next), ``"sensor"`` (the sensor's own gain, polarity, axis, place:
last; the default). An effect of the structure corrects nothing (the model changes instead); a
chain effect without ``correct`` (a force gauge's gain, a hammer's place) stays in the model the
correction's drift estimate is predicted with. The uncertainty of a correction follows from the
fitted values' standard errors (:mod:`odsuite.analysis.correction`).

Optional, variable projection: ``linear_parameters(model) -> list[str]`` names parameters the
effect solves itself, by linear least squares, once the others are given; ``project(models, values,
exps, base, weights) -> (shared, per_experiment, deltas)`` returns them for the models ``models``
(experiment name -> model without the effect) at the other ``values``, fitted to the residual
``measured - base`` of each prepared experiment (rows weighted by ``weights``, None: all), and each
experiment's change of prediction. The fit then searches only the remaining parameters. (A
projection may also read its parameters off the records without a least-squares fit: modal damping
ratios identified in the modal domain.) An effect whose change is an added uncoupled mode's
response declares ``projects_added_mode = True``; its ``project`` then also takes ``unit_response``, a
callable (experiment, frequency_hz, damping_ratio) -> the response to unit participations on that
experiment's model (prediction.flexible_mode_unit), which the caller keeps.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Protocol
from types import MappingProxyType

from odsuite.domain.errors import ConfigError
from odsuite.domain.model import Model


class EffectProvider(Protocol):
    """What every registered effect has (checked when a plugin registers one); :class:`Effect`
    implements it. The optional members above are read where present."""

    name: str
    target: str
    description: str

    def parameters(self, model: Model) -> list[Parameter]: ...

    def apply(self, model: Model, values: Mapping[str, float] | None = None) -> Model: ...


PROTOCOL = EffectProvider
#: optional members that, where given, must be methods
OPTIONAL_METHODS = ("held_when", "refined_start", "linear_parameters", "project", "correct", "added_mode")
#: the stages of a measurement effect, in the order corrections undo them (see ``correct``)
CORRECTION_STAGES = ("channel", "wiring", "sensor")


def corrects(effect) -> bool:
    """Whether ``effect`` describes the measurement and says how to undo it on recorded signals."""
    return getattr(effect, "target", "model") == "chain" and callable(getattr(effect, "correct", None))


@dataclass(frozen=True)
class Parameter:
    """One effect parameter. ``choices`` marks a discrete parameter (e.g. polarity +1/-1);
    ``plausible`` (low, high) its physically plausible range (None: the bounds).
    ``starts`` are values the screening tries besides the nominal (global starts for angles and
    frequencies, whose error surface has local minima). ``sensor`` names the one sensor whose
    prediction the parameter alone changes (a gain, a tilt): the screening's finite differences
    then move the parameters of different sensors in one evaluation. ``ladder``: the starts are
    magnitudes in increasing order away from the nominal (a hardening's decades), along which the
    error falls towards the value the data hold and rises beyond it: the screening stops climbing
    at the first start that raises the error. ``below_nyquist``: a frequency of the response the
    records must resolve (a mode's): a fit bounds it below their Nyquist frequency, and a fit
    ending within one frequency line of that bound is not plausible (``within_records``)."""

    name: str
    unit: str
    nominal: float
    lower: float
    upper: float
    scope: str = "shared"
    description: str = ""
    choices: tuple[float, ...] | None = None
    plausible: tuple[float, float] | None = None
    starts: tuple[float, ...] | None = None
    sensor: str | None = None
    ladder: bool = False
    below_nyquist: bool = False

    def within_records(self, nyquist_hz: float, line_hz: float) -> Parameter:
        """This parameter as records sampled up to ``nyquist_hz`` with lines ``line_hz`` apart can
        hold it: a ``below_nyquist`` frequency bounded by the Nyquist frequency, plausible only
        below its last line (a mode there is not resolved); any other parameter unchanged."""
        if not self.below_nyquist or self.upper <= nyquist_hz - line_hz:
            return self
        upper = max(min(self.upper, nyquist_hz), self.lower)
        low, high = self.plausible or (self.lower, self.upper)
        return replace(self, upper=upper, nominal=max(min(self.nominal, upper - line_hz), self.lower),
                       plausible=(low, min(high, max(upper - line_hz, self.lower))))

    def as_dict(self) -> dict:
        return {"name": self.name, "unit": self.unit, "nominal": self.nominal, "lower": self.lower,
                "upper": self.upper, "scope": self.scope, "description": self.description,
                **({"choices": list(self.choices)} if self.choices else {}),
                **({"plausible": list(self.plausible)} if self.plausible else {})}


class Effect:
    """Base class of effects: resolves values against the parameters, then calls ``_apply``."""

    name: str = ""
    target: str = "model"  # "model" or "chain"
    description: str = ""
    breaks_rigidity: bool = False
    adds_body: bool = False
    #: each addition is one more instance (a second missing mode), not a refit of the first
    repeatable: bool = False
    #: a stand-in that presupposes no shape (a mode of any shape): a named mechanism that explains
    #: the same residual (``confounded_with``) is ranked before it
    data_driven: bool = False
    #: the structure classes (model families) the effect applies to; None: any
    structures: tuple[type, ...] | None = None

    #: where a measurement effect sits between structure and converter (see ``correct``)
    correction_stage: str = "sensor"

    def parameters(self, model: Model) -> list[Parameter]:
        raise NotImplementedError

    def _apply(self, model: Model, v: dict[str, float]) -> Model:
        raise NotImplementedError

    def values(self, model: Model, values: Mapping[str, float] | None = None) -> dict[str, float]:
        """Complete ``values`` with nominals; refuse unknown names and values outside the bounds."""
        params = self._declared(model)
        values = dict(values or {})
        unknown = sorted(set(values) - set(params))
        if unknown:
            raise ConfigError(f"effect {self.name!r}: unknown parameter(s) {unknown} (known: {sorted(params)})")
        out = {}
        for name, (nominal, choices, lower, upper, unit) in params.items():
            v = float(values.get(name, nominal))
            if choices is not None:
                if v not in choices:
                    raise ConfigError(f"effect {self.name!r} parameter {name!r}: expected one of {choices}, got {v!r}")
            elif not (lower <= v <= upper):
                unit_text = "" if unit in ("", "1") else f" {unit}"  # a factor's unit is 1: no word
                raise ConfigError(f"effect {self.name!r} parameter {name!r}: expected {lower:g} to {upper:g}{unit_text}, "
                                  f"got {v!r}")
            out[name] = v
        return out

    def _declared(self, model: Model) -> dict[str, tuple]:
        """Each parameter's nominal, choices, bounds and unit for ``model``, kept on the model per
        effect (kept alive with the entry): a fit applies the effect to one base model at every
        evaluation, and ``parameters`` builds every Parameter and its description again."""
        kept = model.__dict__.setdefault("_declared", {})
        got = kept.get(id(self))
        if got is None or got[0] is not self:
            got = kept[id(self)] = (self, MappingProxyType(
                {p.name: (p.nominal, p.choices, p.lower, p.upper, p.unit) for p in self.parameters(model)}))
        return got[1]

    def apply(self, model: Model, values: Mapping[str, float] | None = None) -> Model:
        """The model with this effect at ``values`` (nominal where missing)."""
        v = self.values(model, values)
        return self._apply(model, v).replace(effect=self.name, values=v)

    def __repr__(self) -> str:
        return f"<effect {self.name!r} ({self.target})>"


def applies(effect, model: Model) -> bool:
    """Whether ``effect`` applies to ``model``: its structure is of a family the effect names
    (``structures``) and the effect has parameters for it."""
    families = getattr(effect, "structures", None)
    if families is not None and not isinstance(model.structure, tuple(families)):
        return False
    return bool(effect.parameters(model))


def family(model: Model) -> str:
    """A model's family in words, for messages: the name of its structure's class."""
    return type(model.structure).__name__
